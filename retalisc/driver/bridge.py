"""Bridge between Python and an in-process SWI-Prolog.

Every piece of Python code that talks to Prolog goes through :class:`Bridge`.
There are two kinds of call:

:meth:`Bridge.apply` (values as data)
    ``apply("rtl_api", "rtl_api_feed_events", items)`` runs the fixed goal
    ``rtl_api:rtl_api_feed_events(Items, Out)`` with every Python argument
    passed as a Prolog *value* (str -> string, int -> integer, float -> float,
    list/tuple -> list), never as source text, and returns ``Out`` as text.
    This is the only form for anything that comes from outside (event text,
    goals, labels): the Prolog side reads such strings with read_term.
``once``/``all``/``call_text``/``consult`` (trusted text)
    Goal *text* written by the programmer (tests, tools); answers come back as
    ``writeq`` text.  Never build such text from values you did not write.

Backends
--------
``janus``
    Used when ``janus_swi`` imports (SWI-Prolog >= 9.1.12).  Calls go through
    ``janus_swi.query_once``.
``pyswip``
    Fallback.  We use only pyswip's ctypes layer (``pyswip/core.py``) to find
    and load ``libswipl``, and call the C foreign-language interface directly.

Both backends call the same two helper predicates (``retalisc_bridge:bridge/6``
for text, ``retalisc_bridge:bridge_apply/6`` for values; source in
prolog_runtime/rtl_bridge.pl), so one small interface fits both.

Threads
-------
SWI-Prolog global variables (``nb_setval``) and ``thread_local`` predicates
belong to a Prolog thread, and the runtime keeps its state (clock, output
buffer, current program) in them.  So that an engine works from any Python
thread (ROS and zenoh callbacks come from other threads), every request runs
in one Prolog thread, the *owner*, created by the helper (``thread_create/3``)
at the first call: the calling thread sends the request to the owner's message
queue and waits for the answer on its own (``thread_send_message/2``,
``thread_get_message/1``), all inside one C call, with the GIL released.  The
handoff costs two thread wake-ups (20 us on an idle machine, 60-90 us on a busy
one: benchmarks/call_cost.py); the bridge's lock serialises callers.
(A Prolog *engine* shared by the threads would be cheaper, but SWI-Prolog 9.0
ties an engine to the C stack of the thread that created it and aborts,
``stack_avail: Assertion failed``, when another thread runs it.)
``run_in_calling_thread`` makes the calling thread the owner: no handoff, and
(pyswip backend, C library built) ``apply`` calls the API predicate itself from C,
resolved once, without building a goal (``apply_numbers`` also reads a numeric answer
without text; docs/architecture.md, "The Python/Prolog boundary").

Why not ``pyswip.Prolog``
-------------------------
``Prolog.query`` builds Python ``Atom``/``Term`` wrappers for every binding,
registers atoms it never releases and opens a nested query per call, which
makes it both slow (hundreds of microseconds per trivial query) and leaky in
long runs.  Importing the ``pyswip`` *package* also initialises Prolog as an
import side effect with fixed arguments (no ``--no-tty``, user init file
loaded), so we load ``pyswip/core.py`` on its own and call ``PL_initialise``
ourselves.  If some other code already imported ``pyswip`` we simply reuse the
engine it started.

Calls from Prolog into Python
-----------------------------
:meth:`Bridge.serve` offers a Python function to the Prolog side, which calls it
as ``retalisc_bridge:python_call(+Name, +Args, -Status, -Result)``: Args a list
of strings (or atoms), Result a string; Status is ``ok``, ``error`` (Result is
the message: the function raised) or ``unknown`` (nothing is served under
Name).  The runtime compiles the rules added at run time this way
(prolog_runtime/rtl_rules.pl).  With the pyswip backend ``python_call/4`` is a
foreign predicate (a ctypes callback, which takes the GIL: the Python thread
waiting for the request released it in its C call); the janus backend does not
define it.  A served function runs while the bridge's lock is held by the
waiting caller, so it must not call Prolog: a bridge call from it raises
PrologError instead of waiting for ever.

Protocol
--------
The helpers run the request inside ``catch/3`` in the owner thread and report
``Status`` (1 success, 0 failure, 2 error) plus a result string, so Prolog
exceptions never escape into the C interface, never reach the debugger and are
turned into :class:`PrologError` carrying Prolog's own message text.
"""

from __future__ import annotations

import ctypes
import importlib.util
import os
import shutil
import struct
import subprocess
import sys
import threading
from types import ModuleType
from typing import Any, Callable, ClassVar, List, Optional, Tuple, Union

__all__ = ["Bridge", "PrologError", "GoalFailed", "ServedCallError"]


class PrologError(RuntimeError):
    """A Prolog exception (or syntax error in goal text) raised by a bridge call.

    ``str(err)`` is Prolog's own message text; ``err.term`` is the ``writeq``
    text of the exception term (``None`` when there is no single term, e.g.
    for errors collected while consulting a file).
    """

    def __init__(self, message: str, term: Optional[str] = None) -> None:
        super().__init__(message)
        self.message = message
        self.term = term


class GoalFailed(PrologError):
    """Raised by :meth:`Bridge.call_text` when its goal fails."""


# Call modes understood by retalisc_bridge:bridge/6 (bridge_apply/6 has none).
_MODE_BOOL, _MODE_ONCE, _MODE_ALL, _MODE_TEXT, _MODE_CONSULT = range(5)
_OK, _FAILED, _ERROR = 1, 0, 2

def _helper_file() -> str:
    """The Prolog half of the bridge: prolog_runtime/rtl_bridge.pl (module retalisc_bridge)."""
    from retalisc.runtime_location import runtime_dir

    return str(runtime_dir() / "rtl_bridge.pl")


def _quoted(text: str) -> str:
    """`text` as a quoted Prolog atom (a path of this installation)."""
    return "'" + text.replace("\\", "\\\\").replace("'", "\\'") + "'"


# --------------------------------------------------------------------------
# pyswip backend: direct foreign-language-interface calls
# --------------------------------------------------------------------------

_CVT_ATOM = 0x0001
_CVT_STRING = 0x0002
_CVT_LIST = 0x0004
_REP_UTF8 = 0x00100000
_REP_ISO_LATIN_1 = 0x0
_BUF_DISCARDABLE = 0x0000
_TEXT_FLAGS = _CVT_ATOM | _CVT_STRING | _CVT_LIST | _REP_UTF8 | _BUF_DISCARDABLE
_PL_Q_NODEBUG = 0x0004
_PL_Q_PASS_EXCEPTION = 0x0010

_term_t = ctypes.c_size_t  # uintptr_t in SWI-Prolog.h
_CORE_MODULE = "_retalisc_pyswip_core"


def _load_pyswip_core() -> ModuleType:
    """Return pyswip's ctypes layer without running pyswip's package init."""
    for name in ("pyswip.core", _CORE_MODULE):
        if name in sys.modules:
            return sys.modules[name]
    spec = importlib.util.find_spec("pyswip")
    if spec is None or not spec.submodule_search_locations:
        raise ImportError("neither janus_swi nor pyswip is installed")
    core_path = os.path.join(list(spec.submodule_search_locations)[0], "core.py")
    core_spec = importlib.util.spec_from_file_location(_CORE_MODULE, core_path)
    assert core_spec is not None and core_spec.loader is not None
    core = importlib.util.module_from_spec(core_spec)
    core_spec.loader.exec_module(core)
    sys.modules[_CORE_MODULE] = core
    return core


def _swipl_home(core: ModuleType) -> Optional[str]:
    home = getattr(core, "SWI_HOME_DIR", None) or os.environ.get("SWI_HOME_DIR")
    if home:
        return home
    exe = shutil.which("swipl")
    if exe is None:
        return None
    out = subprocess.run([exe, "--dump-runtime-variables"], capture_output=True,
                         text=True, check=False).stdout
    for line in out.splitlines():
        if line.startswith("PLBASE="):
            return line.split("=", 1)[1].strip().strip(";").strip('"')
    return None


def _fn(lib: ctypes.CDLL, name: str, restype: Any, *argtypes: Any) -> Any:
    # lib[name] makes a fresh function object, so setting argtypes here does
    # not disturb the (differently typed) objects pyswip itself uses.
    f = lib[name]
    f.restype = restype
    f.argtypes = list(argtypes)
    return f


class _ThreadEngine:
    """Owner of the Prolog engine attached to one Python thread.

    Kept in a ``threading.local``; CPython drops a thread's locals from the
    exiting thread itself, so ``__del__`` detaches the engine in the thread
    that owns it (otherwise ``PL_cleanup`` at exit warns about live threads).
    """

    def __init__(self, destroy: Any) -> None:
        self._destroy = destroy

    def __del__(self) -> None:
        self._destroy()


class _PyswipEngine:
    name = "pyswip"

    def __init__(self) -> None:
        core = _load_pyswip_core()
        lib: ctypes.CDLL = core._lib
        self._string_type: int = core.PL_STRING  # version dependent, pyswip knows
        # pyswip.core's CVT_WRITEQ (0xC0) is the pre-8.2 value; 8.2+ uses 0x200.
        self._cvt_writeq = 0x200 if getattr(core, "PL_VERSION", 0) >= 80200 else 0xC0
        self._init_prolog(lib, core)

        self._open_frame = _fn(lib, "PL_open_foreign_frame", ctypes.c_size_t)
        self._discard_frame = _fn(lib, "PL_discard_foreign_frame", None, ctypes.c_size_t)
        self._new_refs = _fn(lib, "PL_new_term_refs", _term_t, ctypes.c_int)
        self._new_ref = _fn(lib, "PL_new_term_ref", _term_t)
        self._put_integer = _fn(lib, "PL_put_integer", ctypes.c_int, _term_t, ctypes.c_long)
        self._put_chars = _fn(lib, "PL_put_chars", ctypes.c_int, _term_t, ctypes.c_int,
                              ctypes.c_size_t, ctypes.c_char_p)
        self._call_pred = _fn(lib, "PL_call_predicate", ctypes.c_int, ctypes.c_void_p,
                              ctypes.c_int, ctypes.c_void_p, _term_t)
        self._get_integer = _fn(lib, "PL_get_integer", ctypes.c_int, _term_t,
                                ctypes.POINTER(ctypes.c_int))
        self._get_nchars = _fn(lib, "PL_get_nchars", ctypes.c_int, _term_t,
                               ctypes.POINTER(ctypes.c_size_t),
                               ctypes.POINTER(ctypes.c_void_p), ctypes.c_uint)
        self._get_list = _fn(lib, "PL_get_list", ctypes.c_int, _term_t, _term_t, _term_t)
        self._copy_ref = _fn(lib, "PL_copy_term_ref", _term_t, _term_t)
        self._exception = _fn(lib, "PL_exception", _term_t, ctypes.c_void_p)
        self._clear_exception = _fn(lib, "PL_clear_exception", None)
        self._thread_self = _fn(lib, "PL_thread_self", ctypes.c_int)
        self._attach = _fn(lib, "PL_thread_attach_engine", ctypes.c_int, ctypes.c_void_p)
        self._destroy_engine = _fn(lib, "PL_thread_destroy_engine", ctypes.c_int)
        self._mark_strings = _fn(lib, "PL_mark_string_buffers", None,
                                 ctypes.POINTER(ctypes.c_size_t))
        self._release_strings = _fn(lib, "PL_release_string_buffers_from_mark", None,
                                    ctypes.c_size_t)
        self._put_int64 = _fn(lib, "PL_put_int64", ctypes.c_int, _term_t, ctypes.c_int64)
        self._put_float = _fn(lib, "PL_put_float", ctypes.c_int, _term_t, ctypes.c_double)
        self._put_nil = _fn(lib, "PL_put_nil", ctypes.c_int, _term_t)
        self._cons_list = _fn(lib, "PL_cons_list", ctypes.c_int, _term_t, _term_t, _term_t)
        self._mark = ctypes.c_size_t()
        predicate = _fn(lib, "PL_predicate", ctypes.c_void_p, ctypes.c_char_p,
                        ctypes.c_int, ctypes.c_char_p)
        self._flags = _PL_Q_NODEBUG | _PL_Q_PASS_EXCEPTION
        self._status = ctypes.c_int()
        self._len = ctypes.c_size_t()
        self._ptr = ctypes.c_void_p()
        self._local = threading.local()

        self._ensure_thread()
        self._boot(lib)
        self._pred = predicate(b"bridge", 6, b"retalisc_bridge")
        self._apply_pred = predicate(b"bridge_apply", 6, b"retalisc_bridge")
        self._claim_pred = predicate(b"claim_caller", 1, b"retalisc_bridge")
        self._load_call_library()
        self._register_python_call(lib)

    def claim_caller(self) -> bool:
        """Run every later request in the calling thread (retalisc_bridge:claim_caller/1,
        called here directly: a request would start the owner thread)."""
        self._ensure_thread()
        self._mark_strings(ctypes.byref(self._mark))
        mark = self._mark.value
        fid = self._open_frame()
        try:
            t = self._new_refs(1)
            if not self._call_pred(None, self._flags, self._claim_pred, t):
                raise self._pending_error("bridge helper failed")
            claimed = self._text(t) == "true"
            if claimed and self._fast is not None:
                self._claimed()         # the C library then calls the API predicates itself
                self._owned = True
            return claimed
        finally:
            self._discard_frame(fid)
            self._release_strings(mark)

    def _register_python_call(self, lib: ctypes.CDLL) -> None:
        """Define retalisc_bridge:python_call/4 (see the module documentation) as a foreign
        predicate that calls the functions of Bridge.serve."""
        new_ref = _fn(lib, "PL_new_term_ref", _term_t)
        get_nchars = _fn(lib, "PL_get_nchars", ctypes.c_int, _term_t, ctypes.POINTER(ctypes.c_size_t),
                         ctypes.POINTER(ctypes.c_void_p), ctypes.c_uint)
        get_list = _fn(lib, "PL_get_list", ctypes.c_int, _term_t, _term_t, _term_t)
        get_nil = _fn(lib, "PL_get_nil", ctypes.c_int, _term_t)
        copy_ref = _fn(lib, "PL_copy_term_ref", _term_t, _term_t)
        unify_atom = _fn(lib, "PL_unify_atom_chars", ctypes.c_int, _term_t, ctypes.c_char_p)
        unify_chars = _fn(lib, "PL_unify_chars", ctypes.c_int, _term_t, ctypes.c_int, ctypes.c_size_t,
                          ctypes.c_char_p)
        string_flags = self._string_type | _REP_UTF8
        text_flags = _CVT_ATOM | _CVT_STRING | _REP_UTF8 | _BUF_DISCARDABLE

        def text(t: int) -> Optional[str]:
            length, pointer = ctypes.c_size_t(), ctypes.c_void_p()
            if not get_nchars(t, ctypes.byref(length), ctypes.byref(pointer), text_flags):
                return None
            return ctypes.string_at(pointer.value or 0, length.value).decode("utf-8")

        def python_call(name_ref: int, args_ref: int, status_ref: int, result_ref: int) -> int:
            name, args = text(name_ref), []
            head, tail = new_ref(), copy_ref(args_ref)
            while get_list(tail, head, tail):
                args.append(text(head))
            if name is None or None in args or not get_nil(tail):
                status, result = "error", "python_call/4: a name and a list of strings, please"
            else:
                status, result = _served_call(name, args)
            data = result.encode("utf-8")
            return int(unify_atom(status_ref, status.encode()) and
                       unify_chars(result_ref, string_flags, len(data), data))

        callback_type = ctypes.CFUNCTYPE(ctypes.c_size_t, _term_t, _term_t, _term_t, _term_t)
        self._python_call = callback_type(python_call)     # kept alive as long as Prolog may call it
        register = _fn(lib, "PL_register_foreign_in_module", ctypes.c_int, ctypes.c_char_p, ctypes.c_char_p,
                       ctypes.c_int, ctypes.c_void_p, ctypes.c_int)
        if not register(b"retalisc_bridge", b"python_call", 4, ctypes.cast(self._python_call, ctypes.c_void_p), 0):
            raise PrologError("cannot define retalisc_bridge:python_call/4")

    @staticmethod
    def _init_prolog(lib: ctypes.CDLL, core: ModuleType) -> None:
        is_init = _fn(lib, "PL_is_initialised", ctypes.c_int, ctypes.c_void_p, ctypes.c_void_p)
        if is_init(None, None):
            return
        args = ["swipl", "-q", "--no-signals", "--no-tty", "--no-packs", "-f", "none"]
        home = _swipl_home(core)
        if home:
            args.append(f"--home={home}")
        argv = (ctypes.c_char_p * (len(args) + 1))(*[a.encode() for a in args], None)
        init = _fn(lib, "PL_initialise", ctypes.c_int, ctypes.c_int,
                   ctypes.POINTER(ctypes.c_char_p))
        if not init(len(args), argv):
            raise PrologError(f"PL_initialise failed with arguments {args}")

    def _boot(self, lib: ctypes.CDLL) -> None:
        """Load the helper module (prolog_runtime/rtl_bridge.pl) and set its flags."""
        from_chars = _fn(lib, "PL_put_term_from_chars", ctypes.c_int, _term_t, ctypes.c_int,
                         ctypes.c_size_t, ctypes.c_char_p)
        call = _fn(lib, "PL_call", ctypes.c_int, _term_t, ctypes.c_void_p)
        fid = self._open_frame()
        try:
            goal = (f"load_files({_quoted(_helper_file())}, [silent(true), if(not_loaded)]),"
                    " retalisc_bridge:set_flags").encode()
            t = self._new_ref()
            if not (from_chars(t, _REP_UTF8, len(goal), goal) and call(t, None)):
                raise self._pending_error("loading the bridge helper failed")
        finally:
            self._discard_frame(fid)

    def _ensure_thread(self) -> None:
        # Prolog engines are per OS thread; attach one to threads other than
        # the one that initialised Prolog the first time they call in.
        if not hasattr(self._local, "engine"):
            engine = None
            if self._thread_self() == -1:
                if self._attach(None) < 0:
                    raise PrologError("cannot attach a Prolog engine to this thread")
                engine = _ThreadEngine(self._destroy_engine)
            self._local.engine = engine

    def _text(self, t: int) -> str:
        if not self._get_nchars(t, ctypes.byref(self._len), ctypes.byref(self._ptr),
                                _TEXT_FLAGS):
            raise PrologError("bridge result is not text")
        return ctypes.string_at(self._ptr.value or 0, self._len.value).decode("utf-8")

    def _text_list(self, t: int) -> list[str]:
        head, tail = self._new_ref(), self._copy_ref(t)
        out: list[str] = []
        while self._get_list(tail, head, tail):
            out.append(self._text(head))
        return out

    def _pending_error(self, fallback: str) -> PrologError:
        ex = self._exception(None)
        if not ex:
            return PrologError(fallback)
        ok = self._get_nchars(ex, ctypes.byref(self._len), ctypes.byref(self._ptr),
                              self._cvt_writeq | _REP_UTF8 | _BUF_DISCARDABLE)
        text = (ctypes.string_at(self._ptr.value or 0, self._len.value).decode("utf-8")
                if ok else fallback)
        self._clear_exception()
        return PrologError(text, text)

    def _put_value(self, t: int, value: Any) -> None:
        """Put a Python value into term ref `t` as a Prolog value (never parsed)."""
        if isinstance(value, str):
            data = value.encode("utf-8")
            ok = self._put_chars(t, self._string_type | _REP_UTF8, len(data), data)
        elif isinstance(value, bytes):       # a string of codes 0..255 (ISO Latin-1: byte by byte)
            ok = self._put_chars(t, self._string_type | _REP_ISO_LATIN_1, len(value), value)
        elif isinstance(value, bool) or value is None:
            raise TypeError(f"cannot pass {value!r} to Prolog")
        elif isinstance(value, int):
            if not -2**63 <= value < 2**63:
                raise ValueError(f"integer out of range for Prolog: {value}")
            ok = self._put_int64(t, value)
        elif isinstance(value, float):
            ok = self._put_float(t, value)
        elif isinstance(value, (list, tuple)):
            ok = self._put_nil(t)
            head = self._new_ref()
            for item in reversed(value):
                self._put_value(head, item)
                ok = ok and self._cons_list(t, head, t)
        else:
            raise TypeError(f"cannot pass a {type(value).__name__} to Prolog")
        if not ok:
            raise self._pending_error("cannot build the arguments of a bridge call")

    def _load_call_library(self) -> None:
        """prolog_runtime/foreign/rtl_bridge_call.so (c/rtl_bridge_call.c), when built: a request
        in one ctypes call instead of about twenty."""
        from retalisc.runtime_location import runtime_dir

        self._fast = None
        self._owned = False             # this thread owns the state and the C library is built
        self._predicates: dict = {}
        for suffix in ("so", "dylib", "dll"):
            path = runtime_dir() / "foreign" / f"rtl_bridge_call.{suffix}"
            if path.exists():
                try:
                    lib = ctypes.CDLL(str(path))
                except OSError:
                    return
                self._fast = _fn(lib, "rtl_bridge_call", ctypes.c_int, ctypes.c_void_p, ctypes.c_char_p,
                                 ctypes.c_char_p, ctypes.c_char_p, ctypes.c_size_t,
                                 ctypes.POINTER(ctypes.c_void_p), ctypes.POINTER(ctypes.c_size_t),
                                 ctypes.POINTER(ctypes.c_void_p), ctypes.POINTER(ctypes.c_size_t))
                self._fast_numbers = _fn(lib, "rtl_bridge_call_numbers", ctypes.c_int, ctypes.c_void_p,
                                         ctypes.c_char_p, ctypes.c_char_p, ctypes.c_char_p, ctypes.c_size_t,
                                         ctypes.POINTER(ctypes.c_double), ctypes.c_int,
                                         ctypes.POINTER(ctypes.c_int64), ctypes.c_int,
                                         ctypes.POINTER(ctypes.c_void_p), ctypes.POINTER(ctypes.c_size_t),
                                         ctypes.POINTER(ctypes.c_void_p), ctypes.POINTER(ctypes.c_size_t))
                self._resolve = _fn(lib, "rtl_bridge_predicate", ctypes.c_void_p, ctypes.c_char_p,
                                    ctypes.c_char_p, ctypes.c_int)
                self._claimed = _fn(lib, "rtl_bridge_claimed", None)
                self._out_ptr, self._out_len = ctypes.c_void_p(), ctypes.c_size_t()
                self._err_ptr, self._err_len = ctypes.c_void_p(), ctypes.c_size_t()
                self._fast_refs = (ctypes.byref(self._out_ptr), ctypes.byref(self._out_len),
                                   ctypes.byref(self._err_ptr), ctypes.byref(self._err_len))
                self._reals = (ctypes.c_double * 16)()
                self._ints = (ctypes.c_int64 * 16)()
                return

    def _predicate(self, module: str, name: str, arity: int) -> Tuple[Any, bytes, bytes]:
        """(predicate handle, module, name) of module:name/arity, resolved once (the C library
        calls it directly when this thread owns the state)."""
        key = (module, name, arity)
        entry = self._predicates.get(key)
        if entry is None:
            module_bytes, name_bytes = module.encode("utf-8"), name.encode("utf-8")
            entry = (self._resolve(module_bytes, name_bytes, arity), module_bytes, name_bytes)
            self._predicates[key] = entry
        return entry

    def _fast_outcome(self, status: int) -> tuple[int, Any, str]:
        if status == _OK:
            return status, ctypes.string_at(self._out_ptr.value or 0, self._out_len.value).decode("utf-8"), ""
        if status == _FAILED:
            return status, None, ""
        err = ctypes.string_at(self._err_ptr.value or 0, self._err_len.value).decode("utf-8")
        if status == _ERROR:
            return status, ctypes.string_at(self._out_ptr.value or 0, self._out_len.value).decode("utf-8"), err
        if status == -2:
            raise PrologError("cannot build the arguments of a bridge call")
        raise PrologError(err or "bridge helper failed", err or None)

    def apply_numbers(self, module: str, name: str, nreals: int, nints: int,
                      args: tuple) -> tuple[int, Any, str]:
        """As apply, for a predicate whose answer is `F(R1..Rm, I1..Ik)`: Out is then
        (reals, ints), read without text; another answer comes back as its text. None when
        the C library is not built or requests are handed to the bridge's thread (the caller
        uses the text road)."""
        if not self._owned or nreals > 16 or nints > 16:
            return None
        self._ensure_thread()
        data = _packed(args)
        pred, module_bytes, name_bytes = self._predicate(module, name, len(args) + 1)
        status = self._fast_numbers(pred, module_bytes, name_bytes, data, len(data),
                                    self._reals, nreals, self._ints, nints, *self._fast_refs)
        if status == _OK:
            return status, (self._reals[:nreals], self._ints[:nints]), ""
        if status == 3:
            return _OK, ctypes.string_at(self._out_ptr.value or 0, self._out_len.value).decode("utf-8"), ""
        return self._fast_outcome(status)

    def apply(self, module: str, name: str, args: tuple) -> tuple[int, Any, str]:
        self._ensure_thread()
        if self._fast is not None:
            data = _packed(args)
            pred, module_bytes, name_bytes = self._predicate(module, name, len(args) + 1)
            return self._fast_outcome(self._fast(pred, module_bytes, name_bytes, data, len(data),
                                                 *self._fast_refs))
        self._mark_strings(ctypes.byref(self._mark))
        mark = self._mark.value
        fid = self._open_frame()
        try:
            t = self._new_refs(6)
            self._put_value(t, module)
            self._put_value(t + 1, name)
            self._put_value(t + 2, list(args))
            if not self._call_pred(None, self._flags, self._apply_pred, t):
                raise self._pending_error("bridge helper failed")
            self._get_integer(t + 3, ctypes.byref(self._status))
            status = self._status.value
            if status == _ERROR:
                return status, self._text(t + 4), self._text(t + 5)
            if status == _FAILED:
                return status, None, ""
            return status, self._text(t + 4), ""
        finally:
            self._discard_frame(fid)
            self._release_strings(mark)

    def run(self, mode: int, goal: str, aux: str) -> tuple[int, Any, str]:
        self._ensure_thread()
        # Even with BUF_DISCARDABLE, PL_get_nchars(REP_UTF8) pushes a buffer
        # on the thread's string-buffer stack; outside a foreign predicate
        # nobody pops it and SWI dies with "Too many stacked strings" after
        # 2^20 results unless we release explicitly.
        self._mark_strings(ctypes.byref(self._mark))
        mark = self._mark.value
        fid = self._open_frame()
        try:
            t = self._new_refs(6)
            self._put_integer(t, mode)
            g = goal.encode("utf-8")
            self._put_chars(t + 1, self._string_type | _REP_UTF8, len(g), g)
            if mode != _MODE_BOOL:
                a = aux.encode("utf-8")
                self._put_chars(t + 2, self._string_type | _REP_UTF8, len(a), a)
            if not self._call_pred(None, self._flags, self._pred, t):
                raise self._pending_error("bridge helper failed")
            self._get_integer(t + 3, ctypes.byref(self._status))
            status = self._status.value
            if status == _ERROR:
                return status, self._text(t + 4), self._text(t + 5)
            if status == _FAILED or mode in (_MODE_BOOL, _MODE_CONSULT):
                return status, None, ""
            out = self._text_list(t + 4) if mode == _MODE_ALL else self._text(t + 4)
            return status, out, ""
        finally:
            self._discard_frame(fid)
            self._release_strings(mark)


# --------------------------------------------------------------------------
# janus backend
# --------------------------------------------------------------------------

class _JanusEngine:
    name = "janus"
    _QUERY = "retalisc_bridge:bridge(Mode, Goal, Aux, Status, Out, Err)"

    def __init__(self) -> None:
        import janus_swi    # optional: pyswip's C layer serves without it

        self._janus = janus_swi
        self._error: type[BaseException] = getattr(janus_swi, "PrologError", RuntimeError)
        janus_swi.consult(_helper_file())
        janus_swi.query_once("retalisc_bridge:set_flags")

    def run(self, mode: int, goal: str, aux: str) -> tuple[int, Any, str]:
        # query_once() stores 'truth' into its inputs dict: pass a fresh one.
        try:
            r = self._janus.query_once(self._QUERY,
                                       {"Mode": mode, "Goal": goal, "Aux": aux})
        except self._error as e:
            raise PrologError(str(e)) from None
        if not r.get("truth"):
            raise PrologError("bridge helper failed")
        status = r["Status"]
        if status == _ERROR:
            return status, r["Out"], r["Err"]
        if status == _FAILED or mode in (_MODE_BOOL, _MODE_CONSULT):
            return status, None, ""
        return status, r["Out"], ""


    _APPLY = "retalisc_bridge:bridge_apply(Module, Name, Args, Status, Out, Err)"

    def apply_numbers(self, module: str, name: str, nreals: int, nints: int, args: tuple) -> None:
        return None     # no typed road: the caller takes the text road

    def apply(self, module: str, name: str, args: tuple) -> tuple[int, Any, str]:
        for arg in args:
            _check_value(arg)
        try:
            r = self._janus.query_once(self._APPLY, {"Module": module, "Name": name, "Args": list(args)})
        except self._error as e:
            raise PrologError(str(e)) from None
        if not r.get("truth"):
            raise PrologError("bridge helper failed")
        status = r["Status"]
        if status == _ERROR:
            return status, r["Out"], r["Err"]
        if status == _FAILED:
            return status, None, ""
        return status, r["Out"], ""


_STRING, _BYTES, _INT, _FLOAT, _LIST = (struct.Struct("<cI").pack, struct.Struct("<cI").pack,
                                        struct.Struct("<cq").pack, struct.Struct("<cd").pack,
                                        struct.Struct("<cI").pack)


def _pack(value: Any, parts: List[bytes]) -> None:
    """Append the encoding of `value` that c/rtl_bridge_call.c reads (tagged data, never text
    to parse): str, bytes, int, float and lists or tuples of them."""
    kind = type(value)
    if kind is str:
        data = value.encode("utf-8")
        parts.append(_STRING(b"s", len(data)))
        parts.append(data)
    elif kind is int:
        if not -2**63 <= value < 2**63:
            raise ValueError(f"integer out of range for Prolog: {value}")
        parts.append(_INT(b"i", value))
    elif kind is float:
        parts.append(_FLOAT(b"f", value))
    elif kind is list or kind is tuple:
        parts.append(_LIST(b"l", len(value)))
        for item in value:
            _pack(item, parts)
    elif kind is bytes:
        parts.append(_BYTES(b"b", len(value)))
        parts.append(value)
    elif isinstance(value, bool) or value is None:
        raise TypeError(f"cannot pass {value!r} to Prolog")
    elif isinstance(value, (str, int, float, list, tuple, bytes)):     # subclasses
        base = next(t for t in (str, int, float, list, bytes) if isinstance(value, t))
        _pack(base(value), parts)
    else:
        raise TypeError(f"cannot pass a {type(value).__name__} to Prolog")


def _packed(args: tuple) -> bytes:
    """The encoding of the argument list `args` (_pack), strings and numbers on the spot."""
    parts: List[bytes] = [_LIST(b"l", len(args))]
    append = parts.append
    for value in args:
        kind = type(value)
        if kind is str:
            data = value.encode("utf-8")
            append(_STRING(b"s", len(data)))
            append(data)
        elif kind is float:
            append(_FLOAT(b"f", value))
        else:
            _pack(value, parts)
    return b"".join(parts)


def _check_value(value: Any) -> None:
    """The values bridge calls pass: str, int, float and lists of them."""
    if isinstance(value, (list, tuple)):
        for item in value:
            _check_value(item)
    elif isinstance(value, bool) or not isinstance(value, (str, int, float)):
        raise TypeError(f"cannot pass {value!r} to Prolog")


def _make_engine() -> Union[_JanusEngine, _PyswipEngine]:
    choice = os.environ.get("RETALISC_BRIDGE_BACKEND", "").strip().lower()
    if choice != "pyswip":
        try:
            return _JanusEngine()
        except Exception:
            # Import errors, or janus built against another libswipl.
            if choice == "janus":
                raise
    return _PyswipEngine()


_STATE_MODULE = "_retalisc_bridge_state"


def _shared_state() -> ModuleType:
    """Process-wide engine + lock.

    Kept in ``sys.modules`` rather than in this module's globals so that
    ``importlib.reload`` or importing this file under a second name still
    finds the one engine: Prolog can be initialised only once per process.
    """
    state = sys.modules.get(_STATE_MODULE)
    if state is None:
        state = ModuleType(_STATE_MODULE)
        state.engine = None
        state.lock = threading.RLock()
        state.served = {}
        state = sys.modules.setdefault(_STATE_MODULE, state)
    return state


_serving = threading.local()      # .active: this thread runs a function Prolog called


def _served_call(name: str, args: List[str]) -> Tuple[str, str]:
    """(Status, Result) of retalisc_bridge:python_call/4 for the function served as `name`."""
    function = getattr(_shared_state(), "served", {}).get(name)
    if function is None:
        return "unknown", f"no Python function is served as {name!r}"
    _serving.active = True
    try:
        return "ok", function(*args)
    except ServedCallError as error:
        return "error", str(error)
    except Exception as error:       # a bug in the function: Prolog gets its name and message
        return "error", f"{name}: {type(error).__name__}: {error}"
    finally:
        _serving.active = False


def _not_serving() -> None:
    if getattr(_serving, "active", False):
        raise PrologError("a Python function called from Prolog (Bridge.serve) cannot call Prolog")


# --------------------------------------------------------------------------
# Public interface
# --------------------------------------------------------------------------

class ServedCallError(Exception):
    """Raised by a function offered with Bridge.serve: its text is the message Prolog gets
    (Status `error`), without the exception's name."""


class Bridge:
    """Process-wide handle on the embedded SWI-Prolog (one engine per process).

    ``Bridge()`` always returns the same object; the environment variable
    ``RETALISC_BRIDGE_BACKEND`` (``janus``/``pyswip``) forces a backend for
    the first construction.  Calls are serialised by one re-entrant lock.
    Goal text is parsed in module ``user`` and run there; a trailing full stop
    is allowed, anything after the first term is ignored by the reader.

    Every call, from any Python thread, runs in the same Prolog thread, so
    global variables (``nb_setval``) and ``thread_local`` predicates are the
    same for all callers (see the module documentation).
    """

    _instance: ClassVar[Optional["Bridge"]] = None

    backend: str
    _engine: Union[_JanusEngine, _PyswipEngine]
    _lock: Any  # threading.RLock() returns a private type

    def __new__(cls) -> "Bridge":
        inst = cls._instance
        if inst is None:
            state = _shared_state()
            with state.lock:
                inst = cls._instance
                if inst is None:
                    if state.engine is None:
                        state.engine = _make_engine()
                    inst = super().__new__(cls)
                    inst._engine = state.engine
                    inst._lock = state.lock
                    inst.backend = state.engine.name
                    cls._instance = inst
        return inst

    @classmethod
    def instance(cls) -> "Bridge":
        return cls()

    def run_in_calling_thread(self) -> bool:
        """Make the calling thread the one Prolog thread of this process, when no call has
        run yet: requests then run at once in that thread, without a handoff (two thread
        switches, whose wake-ups make a call's time spread on a busy machine). For a process
        in which one thread makes every call, such as a command-line run; a call from any
        other thread then raises PrologError. Returns whether the calling thread is the
        owner (False when calls already ran in the bridge's own thread, which stays the
        owner; the janus backend has no such mode)."""
        claim = getattr(self._engine, "claim_caller", None)
        if claim is None:
            return False
        with self._lock:
            return claim()

    def _call(self, mode: int, goal: str, aux: str) -> tuple[int, Any]:
        _not_serving()
        with self._lock:
            status, out, term = self._engine.run(mode, goal, aux)
        if status == _ERROR:
            raise PrologError(out or term, term or None)
        return status, out

    def apply(self, module: str, name: str, *args: Any) -> str:
        """Run ``module:name(Arg1, ..., ArgN, Out)`` once and return the text of ``Out``.

        The arguments are passed as Prolog values: str as a string, int and
        float as numbers, lists and tuples as lists (nested freely); nothing
        is parsed as Prolog source. Atoms, strings and numbers come back as
        their text, other terms as ``write`` text. Raises :class:`GoalFailed`
        when the goal fails, :class:`PrologError` when it raises.
        """
        _not_serving()
        with self._lock:
            status, out, term = self._engine.apply(module, name, args)
        if status == _ERROR:
            raise PrologError(out or term, term or None)
        if status != _OK:
            raise GoalFailed(f"goal failed: {module}:{name}/{len(args) + 1}")
        return out

    def apply_numbers(self, module: str, name: str, nreals: int, nints: int,
                      *args: Any) -> Union[Tuple[List[float], List[int]], str, None]:
        """Run ``module:name(Arg1, ..., ArgN, Out)`` once, as `apply`, for a predicate whose
        answer is a term ``F(R1, ..., Rm, I1, ..., Ik)`` of `nreals` floats and `nints`
        integers: returns (reals, ints), read by the C library without text; an answer of
        another form comes back as its text. None when this backend has no typed road (janus,
        or the C library not built): the caller then uses `apply` on a text answer."""
        _not_serving()
        with self._lock:
            result = self._engine.apply_numbers(module, name, nreals, nints, args)
        if result is None:
            return None
        status, out, term = result
        if status == _ERROR:
            raise PrologError(out or term, term or None)
        if status != _OK:
            raise GoalFailed(f"goal failed: {module}:{name}/{len(args) + 1}")
        return out

    def serve(self, name: str, function: Callable[..., str]) -> bool:
        """Offer `function` to Prolog as `retalisc_bridge:python_call(Name, Args, Status,
        Result)` (see the module documentation): it is called with the strings of Args and
        returns the text of Result; raising ServedCallError gives Status `error` with its
        message. Replaces what was served as `name`. Returns whether Prolog can call it (not
        with the janus backend)."""
        state = _shared_state()
        if not hasattr(state, "served"):        # a state made by an older copy of this module
            state.served = {}
        state.served[name] = function
        return self.backend == "pyswip"

    def consult(self, path: Union[str, "os.PathLike[str]"]) -> None:
        """Load a Prolog file into ``user``; errors printed while loading are raised."""
        self._call(_MODE_CONSULT, os.fspath(path), "")

    def once(self, goal: str, template: Optional[str] = None) -> Union[str, bool, None]:
        """Run ``goal`` once.

        Without ``template``: True/False.  With ``template`` (text whose
        variables are shared *by name* with ``goal``): the ``writeq`` text of
        the template after success, None on failure.
        """
        if template is None:
            return self._call(_MODE_BOOL, goal, "")[0] == _OK
        status, out = self._call(_MODE_ONCE, goal, template)
        return out if status == _OK else None

    def all(self, goal: str, template: str) -> list[str]:
        """``writeq`` text of ``template`` for every solution of ``goal`` (findall)."""
        return self._call(_MODE_ALL, goal, template)[1]

    def call_text(self, goal: str, result_var: str = "Out") -> str:
        """Run ``goal`` once and return the text bound to variable ``result_var``.

        Atoms, strings and code/char lists come back unquoted; other terms as
        ``write`` text.  Raises :class:`GoalFailed` if the goal fails.
        """
        status, out = self._call(_MODE_TEXT, goal, result_var)
        if status != _OK:
            raise GoalFailed(f"goal failed: {goal[:200]}")
        return out
