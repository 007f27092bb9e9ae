"""The Python face of a running Retalis program.

An `Engine` loads one compiled program into the in-process SWI-Prolog (through `Bridge`)
and feeds it events, one at a time or in batches. Every output line the program produces
(derived events, subscription deliveries, deletions) comes back as an `OutputEvent`, in
processing order, and is also handed to the callbacks registered with `on_output`.
Batches are the fast path: one Prolog call per batch, not per event.

Values are data: every call goes to a fixed predicate of `prolog_runtime/rtl_api.pl` with
the Python values as Prolog strings and numbers (`Bridge.apply`), never as goal text. Text
that stands for a term (an event, a goal, a label) is read on the Prolog side as exactly
one term; rules, queries and conditions from here must pass the sandbox (rtl_sandbox.pl).

An Engine may be used from any thread: its calls are serialised, and every bridge call runs
in the bridge's one Prolog thread, where the runtime keeps its state (docs/runtime.md,
"Threads"). Callbacks run in the thread whose call produced the output, before the next call
of the Engine starts.
"""
from __future__ import annotations

import itertools
import json
import math
import shutil
import tempfile
import threading
from concurrent.futures import Future
from dataclasses import dataclass
from functools import cached_property
from pathlib import Path
from types import TracebackType
from typing import Callable, Dict, Iterable, List, Optional, Sequence, Tuple, Type, Union

from ..compiler import CompileResult, compile_file, compile_source, unique_module_name
from ..runtime_rules import RulesRefused, compile_rules, compile_rules_for_the_runtime
from . import snapshot
from .bridge import Bridge, PrologError, ServedCallError
from ..frontend.depth import with_room_for_depth
from .values import QueryAnswer, String, Term, Time, Value, Variable, read_term, term_value, time_value

__all__ = ["Engine", "OutputEvent", "Rejection", "EngineWarning", "QueryError", "PrologError", "Term",
           "String", "Variable", "Value", "QueryAnswer", "Time", "TfTransform", "TfLookupError"]

Number = Union[int, float]

_python_queries = itertools.count(1)

_API = "rtl_api"        # prolog_runtime/rtl_api.pl: the predicates an Engine calls
# The entry points of prolog_runtime/rtl_trace.pl that Engine.trace calls (`rtl_trace_NAME`).
_TRACE_REQUESTS = ("start", "stop", "feed_line", "feed_byte_line", "explain", "why_not", "matches", "late", "rules",
                   "report", "end")


_NO_DATA = object()


class _BatchTerms:
    """The terms of one call's outputs, as the runtime's data (the second line of
    rtl_output_data/2), decoded once, when a term is first asked for."""

    __slots__ = ("text", "items")

    def __init__(self, text: str):
        self.text = text
        self.items: Optional[list] = None

    def item(self, index: int):
        items = self.items
        if items is None:
            items = self.items = _decode_json(self.text)
            self.text = ""
        return items[index]


class OutputEvent:
    """One output: `event` is the term text (writeq), `start` and `end` its times,
    `consumer` is set for subscription deliveries, `input` is True for the echo of an input
    event (`echo_input`), `op` is "add" or "retract"; or, with `op` "answer", the result of a
    synchronized query: `answer` is then a `QueryAnswer` (query id, at, status, answers,
    message; `query` holds the same as its JSON object) and `event` is empty. `line` is its
    output line, as the runtime writes it (docs/runtime.md, "Output").

    The term is also there as data: `term` is its Python value (`Term(name, args)`, or a `str`
    for an atom; see `retalisc.driver.values`), `name` and `args` its name and arguments. The
    runtime sends the term as data with the text (`from_data`): nothing is read again. For
    an answer, `term` and `answer` are the QueryAnswer, `name` is "answer" and `args` is `()`."""

    __slots__ = ("event", "start", "end", "consumer", "op", "query", "input", "_line", "_data", "_batch", "_index",
                 "_term", "_answer")

    def __init__(self, event: str, start: Number, end: Number, consumer: Optional[str] = None, op: str = "add",
                 line: str = "", query: Optional[dict] = None, input: bool = False):
        self.event = event
        self.start = start
        self.end = end
        self.consumer = consumer
        self.op = op
        self.query = query          # op "answer": the result object of a synchronized query
        self.input = input          # the echo of an input event (`echo_input`, `--echo-input`)
        self._line = line or None
        self._data = _NO_DATA       # the term as the runtime's data (from_data), read when asked for
        self._batch = None          # or the terms of the call that produced it, with its index there
        self._index = 0
        self._term = _NO_DATA
        self._answer = _NO_DATA

    @classmethod
    def from_data(cls, data: Union[list, dict], term=_NO_DATA) -> "OutputEvent":
        """The output from one element of the runtime's output data (rtl_output_data/2 in
        prolog_runtime/rtl_io.pl): `[Text, Start, End]` for an event with no consumer and op
        add, the object of its output line for any other, the result object of a synchronized
        query for an answer; `term` the element of the terms' array, the event's term as data."""
        new = _new_output(cls)
        if type(data) is list:
            new.event, new.start, new.end = data
            new.consumer, new.op, new.query, new.input = None, "add", None, False
        elif "query" in data:
            new.event, new.start, new.end = "", data["at"], data["at"]
            new.consumer, new.op, new.query, new.input = None, "answer", data, False
        else:
            new.event, new.start, new.end = data["event"], data["start"], data["end"]
            new.consumer, new.op = data.get("consumer"), data.get("op", "add")
            new.query, new.input = None, data.get("input") is True
        new._data, new._batch, new._index = term, None, 0
        new._line = None
        new._term = new._answer = _NO_DATA
        return new

    @property
    def line(self) -> str:
        """The output line (docs/runtime.md, "Output"), byte for byte as the runtime writes it."""
        line = self._line
        if line is None:
            line = self._line = _answer_line(self.query) if self.op == "answer" else _event_line(self)
        return line

    @property
    def answer(self) -> Optional[QueryAnswer]:
        """The result of a synchronized query (op "answer"); None for an event."""
        if self._answer is _NO_DATA:
            self._answer = QueryAnswer.from_json(self.query) if self.op == "answer" and self.query is not None else None
        return self._answer

    @property
    def term(self) -> Union[Value, QueryAnswer]:
        """The event term as a Python value (see `retalisc.driver.values`); the QueryAnswer
        for an answer."""
        if self.op == "answer":
            return self.answer
        term = self._term
        if term is _NO_DATA:
            data = self._batch.item(self._index) if self._batch is not None else self._data
            term = self._term = term_value(data) if data is not _NO_DATA else read_term(self.event)
        return term

    @property
    def name(self) -> str:
        """The event's name: `fire_alarm` for `fire_alarm(smoke_1, temp_1)`; "answer" for the
        result of a synchronized query."""
        if self.op == "answer":
            return "answer"
        term = self.term
        return term.name if isinstance(term, Term) else str(term)

    @property
    def args(self) -> Tuple[Value, ...]:
        """The event's arguments as Python values; `()` for an atom and for an answer."""
        term = self.term
        return term.args if isinstance(term, Term) else ()

    @property
    def text(self) -> str:
        """The event term as Prolog text (the same as `event`)."""
        return self.event

    def _fields(self) -> tuple:
        return (self.event, self.start, self.end, self.consumer, self.op, self.query, self.input)

    def __eq__(self, other) -> bool:
        if type(other) is not type(self):
            return NotImplemented
        return self._fields() == other._fields()

    def __hash__(self) -> int:
        return hash((self.event, self.start, self.end, self.consumer, self.op, self.input))

    def __repr__(self) -> str:
        return (f"OutputEvent(event={self.event!r}, start={self.start!r}, end={self.end!r}, "
                f"consumer={self.consumer!r}, op={self.op!r}, query={self.query!r}, input={self.input!r})")


_new_output = object.__new__
_from_data = OutputEvent.from_data

_encode_json_string = json.encoder.encode_basestring        # C; escapes as the runtime does but for 3 controls
_RUNTIME_ESCAPES = {code: f"\\u{code:04x}" for code in range(0x20)}
_RUNTIME_ESCAPES.update({ord('"'): '\\"', ord("\\"): "\\\\", ord("\n"): "\\n", ord("\t"): "\\t"})


def _json_text(text: str) -> str:
    """`text` as a JSON string, escaped as the runtime escapes it (rtl_json_string_escape/2:
    `"`, `\\`, `\\n`, `\\t`, other control characters as `\\u00xx`)."""
    if "\r" in text or "\b" in text or "\f" in text:      # the C encoder writes these as \r, \b, \f
        return '"' + text.translate(_RUNTIME_ESCAPES) + '"'
    return _encode_json_string(text)


def _float_text(value: float) -> str:
    """A finite float as SWI-Prolog's write/1 writes it (the shortest digits that read back,
    as Python's repr; exponents written `e+22`, `e-5`, and from 1.0e15 on for an integral
    value)."""
    text = repr(value)
    if "e" in text:
        mantissa, _, exponent = text.partition("e")
        if "." not in mantissa:
            mantissa += ".0"
        power = int(exponent)
        return f"{mantissa}e{power}" if power < 0 else f"{mantissa}e+{power}"
    if text.endswith(".0") and abs(value) >= 1e15:
        sign = "-" if text[0] == "-" else ""
        whole = text[len(sign):-2]
        digits = whole.rstrip("0")
        return f"{sign}{digits[0]}.{digits[1:] or '0'}e+{len(whole) - 1}"
    return text


def _number_text(value) -> str:
    """A time or number of an output line as the runtime writes it (a time that is not finite
    comes as the text the runtime quotes)."""
    kind = type(value)
    if kind is int:
        return str(value)
    if kind is float:
        return _float_text(value)
    if kind is str:
        return _json_text(value)
    raise TypeError(f"not a time of an output line: {value!r}")


def _event_line(event: "OutputEvent") -> str:
    """The output line of an event, byte for byte as rtl_event_json/6 (rtl_io.pl) writes it."""
    text, start, end = event.event, event.start, event.end
    line = ('{"event": ' + (_json_text(text) if "\r" in text or "\b" in text or "\f" in text else
                            _encode_json_string(text))
            + ', "start": ' + (str(start) if type(start) is int else _number_text(start))
            + ', "end": ' + (str(end) if type(end) is int else _number_text(end)))
    if event.consumer is None and not event.input:
        return line + ("}" if event.op != "retract" else ', "op": "retract"}')
    if event.input:
        line += ', "input": true'
    else:
        line += ', "consumer": ' + _json_text(event.consumer)
    if event.op == "retract":
        line += ', "op": "retract"'
    return line + "}"


def _answer_line(query: dict) -> str:
    """The output line of a synchronized query's result, as rtl_query.pl writes it."""
    answers = ", ".join("{" + ", ".join(f"{_json_text(name)}: {_json_text(value)}" for name, value in answer.items())
                        + "}" for answer in query["answers"])
    return (f'{{"query": {_json_text(query["query"])}, "at": {_number_text(query["at"])}, '
            f'"status": {_json_text(query["status"])}, "answers": [{answers}], '
            f'"message": {_json_text(query["message"])}}}')


@dataclass
class Answer:
    """What a feeding predicate of prolog_runtime/rtl_api.pl answered, read once by
    `read_answer` (the protocol: docs/architecture.md, "The Python/Prolog boundary"):
    `outputs` the outputs (`OutputEvent`s, from the runtime's output data), `warnings` and
    `rejections` in order, and `stop` the batch's last line when it ended early: "error"
    (`index` the event that raised, `message` why), "undecodable" (`index`), "paced"
    (`index` the items processed); "" when it did not."""

    outputs: List["OutputEvent"]
    warnings: List["EngineWarning"]
    rejections: List["Rejection"]
    stop: str = ""
    index: int = -1
    message: str = ""


def read_answer(text: str) -> Answer:
    """The `Answer` of an output string of rtl_api.pl: first, when there are outputs, one line
    `[...]` (every output, as the JSON array of rtl_output_data/2: one decoding), then lines
    `?LINE<TAB>TEXT` (a warning; LINE empty outside a batch of lines), `!LINE<TAB>KIND<TAB>REASON`
    (a line not processed), and as the last line `!error<TAB>INDEX<TAB>MESSAGE`,
    `!undecodable<TAB>INDEX` or `!paced<TAB>N`."""
    answer = Answer([], [], [])
    if not text:
        return answer
    if text[0] == "[":
        outputs, _, text = text.partition("\n")
        terms, _, text = text.partition("\n")
        answer.outputs = _output_events(outputs, terms)
    for line in text.split("\n"):             # (not splitlines: a reason may hold U+2028, U+0085)
        if not line:
            continue
        first = line[0]
        if first == "?":
            number, _, warning = line[1:].partition("\t")
            answer.warnings.append(EngineWarning(int(number) if number else None, warning))
        elif first == "!":
            head, _, rest = line[1:].partition("\t")
            if head.isdigit():
                kind, _, reason = rest.partition("\t")
                answer.rejections.append(Rejection(int(head), reason, kind))
            else:
                index, _, message = rest.partition("\t")
                answer.stop, answer.index, answer.message = head, int(index), message
        else:
            raise ValueError(f"not a line of the runtime's answer: {line[:80]!r}")
    return answer


def _output_events(outputs: str, terms: str) -> List["OutputEvent"]:
    """The OutputEvents of the two lines of rtl_output_data/2: the outputs, decoded now, and
    their terms, decoded when one is asked for (`OutputEvent.term`)."""
    batch = _BatchTerms(terms)
    events = [_from_data(item) for item in _decode_json(outputs)]
    for index, event in enumerate(events):
        event._batch, event._index = batch, index
    return events


def _decode_json(text: str):
    try:
        return json.loads(text)
    except RecursionError:                  # a deep term (input terms nest up to 1,000 levels)
        return with_room_for_depth(lambda: json.loads(text))


def _bad_item_index(error: PrologError) -> Optional[int]:
    """The index of the item a feeding predicate refused before processing anything (its error
    term `error(bad_item(Index, Error), _)`, rtl_api.pl); None for any other error."""
    term = error.term or ""
    prefix = "error(bad_item("
    if not term.startswith(prefix):
        return None
    index = term[len(prefix):].partition(",")[0]
    return int(index) if index.isdigit() else None


class QueryError(Exception):
    """A query or memory request that was refused or failed. `kind` is "syntax" (the text does
    not parse), "unsafe" (the sandbox refused it) or "failed" (it raised an error)."""

    def __init__(self, kind: str, message: str):
        super().__init__(f"{kind}: {message}")
        self.kind = kind
        self.message = message


def _raise_if_refused(output: str) -> str:
    if output.startswith("!"):
        kind, _, message = output[1:].rstrip("\n").partition("\t")
        raise QueryError(kind, message)
    return output


@dataclass(frozen=True)
class Rejection:
    """An input line that was not processed: `kind` is "rejected" (malformed: bad JSON, a
    non-ground term, a bad time...), "error" (a refused control line, or the program raised
    an error or ran out of steps while processing the event) or "halt" (program code
    called halt: processing stopped there). `line` is 0 for the end of the input."""

    line: int
    reason: str
    kind: str = "rejected"


def _time(value: Number, what: str = "a time") -> Number:
    """A finite number of seconds, or ValueError/TypeError (checked before Prolog sees it)."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise TypeError(f"{what} must be a number of seconds, not {value!r}")
    if isinstance(value, float) and not math.isfinite(value):
        raise ValueError(f"{what} must be a finite number, not {value!r}")
    return value


@dataclass(frozen=True)
class EngineWarning:
    """A warning about an input (a deletion outside the retraction horizon): its line in a
    `feed_lines` batch, None for `feed`/`feed_batch`."""
    line: Optional[int]
    text: str


def _bound(value, default: str) -> Union[Number, str]:
    """A subscription time bound: a finite number, "now", "inf", "-inf", or the default."""
    if value is None:
        return default
    if isinstance(value, str):
        if value in ("now", "inf", "-inf"):
            return value
        raise ValueError(f"a time bound is a number, 'now', 'inf' or '-inf', not {value!r}")
    if isinstance(value, float) and math.isinf(value):
        return "inf" if value > 0 else "-inf"
    return _time(value, "a time bound")


class Ros1Bytes:
    """An input event given as a ROS 1 message's serialized bytes and the handle of its
    type's schema (Engine.ros1_schema; retalisc/robot_io/ros1_terms.py builds both): the
    runtime builds the event term from the bytes in C (prolog_runtime/rtl_ros1.pl), which
    is the term the text conversion of robot_io/messages.py gives."""

    __slots__ = ("handle", "data")

    def __init__(self, handle: int, data: bytes):
        self.handle = handle
        self.data = data

    def __repr__(self) -> str:
        return f"Ros1Bytes({self.handle}, {len(self.data)} bytes)"


_ROS1_SCHEMAS: Dict[str, Optional[int]] = {}      # schema text -> handle (the C registry is per process)


def _event_value(value):
    if isinstance(value, Ros1Bytes):
        return [value.handle, value.data]
    return _text(value, "an event")


def _text(value, what: str) -> str:
    if not isinstance(value, str):
        raise TypeError(f"{what} must be a str, not {type(value).__name__}")
    return value


def _compile_rules_for_the_runtime(module: str, prefix: str, text: str) -> str:
    """The rules the runtime adds while it runs (control lines, ins_event_rule/1 in an
    action: rtl_rules.pl, compile_in_process/4), compiled in this process, not by a
    `retalisc compile-rules` subprocess."""
    try:
        return compile_rules_for_the_runtime(module, prefix, text)
    except RulesRefused as refused:
        raise ServedCallError(str(refused)) from None


@dataclass(frozen=True)
class TfTransform:
    """The answer of `Engine.tf_lookup`: the pose of the source frame's origin in the target
    frame, `translation` (x, y, z) in metres and `rotation` (qx, qy, qz, qw), at `stamp`
    (secs, nsecs): the time used, the latest common time for "latest" (docs/tf.md)."""

    translation: Tuple[float, float, float]
    rotation: Tuple[float, float, float, float]
    stamp: Tuple[int, int]


class TfLookupError(LookupError):
    """`Engine.tf_lookup` found no transform: `reason` is tf_lookup/6's reason term as text
    (`unknown_frame(base)`, `not_connected(a, b)`, `extrapolation(future, T, Earliest,
    Latest)`, `loop`) and `kind` its name, tf2's failures (docs/tf.md)."""

    def __init__(self, reason: str):
        super().__init__(reason)
        self.reason = reason
        self.kind = reason.partition("(")[0]


def _tf_time(value) -> Union[str, Number, List]:
    """A tf lookup time as data: "latest" (or 0), seconds, (secs, nsecs), ("ns", nanoseconds)."""
    if isinstance(value, str):
        if value != "latest":
            raise ValueError(f"a tf time is 'latest', seconds, (secs, nsecs) or ('ns', n), not {value!r}")
        return value
    if isinstance(value, (list, tuple)) and len(value) == 2:
        first, second = value
        if first == "ns" and isinstance(second, int) and not isinstance(second, bool):
            return ["ns", second]
        if all(isinstance(v, int) and not isinstance(v, bool) for v in value):
            return [first, second]
        raise TypeError(f"a tf stamp is (secs, nsecs) integers or ('ns', nanoseconds), not {value!r}")
    return _time(value, "a tf time")


class InactiveEngineError(RuntimeError):
    """An Engine was used after another Engine was loaded in the same process."""


class Engine:
    """A loaded Retalis program fed with events from Python. The runtime processes one
    program per process: the Engine loaded (or activated) last is the one that can be used."""

    def __init__(self, prolog_file: Union[str, Path], bridge: Optional[Bridge] = None, module: str = ""):
        self.bridge = bridge or Bridge()
        self.module = module
        self._closed = False
        self._directory: Optional[Path] = None      # the temporary directory of a compiled program
        self.prolog_file = Path(prolog_file)
        self._identity: Optional[str] = None
        self._callbacks: List[Callable[[OutputEvent], None]] = []
        self._consumers: Dict[str, List[Callable[[OutputEvent], None]]] = {}
        self._synchronized: Dict[str, "Future"] = {}
        self._lock = threading.RLock()    # one call (and its output delivery) at a time
        self._tracing = False             # rtl_trace.pl loaded (trace)
        self.bridge.active_program = None                # this Engine takes over (see activate)
        self.bridge.once("set_prolog_flag(retalis_embedded, true)")     # constant text, no values
        self.bridge.serve("compile_rules", _compile_rules_for_the_runtime)
        self._warnings: List[EngineWarning] = []
        self.rules: List[str] = []           # the labels of the event rules, in program order
        if self.bridge.once("current_predicate(rtl_api:rtl_api_default_flags/1)"):   # constant text
            self._call("rtl_api_default_flags")          # flags another Engine set do not carry over
        self.bridge.consult(str(prolog_file))
        if module:
            self._call("rtl_api_use_program", module)
        self._call("rtl_api_output_to_buffer")
        self.bridge.active_program = module

    # ---- loading -------------------------------------------------------------------------

    @classmethod
    def from_compiled(cls, result: CompileResult, bridge: Optional[Bridge] = None) -> "Engine":
        """Load an already compiled program. Programs loaded into one process need distinct
        module names: `load` and `from_source` make them unique."""
        return cls.from_prolog(result.prolog, result.unit.module, [rule.rule_id for rule in result.unit.rules],
                               bridge)

    @classmethod
    def from_prolog(cls, prolog: str, module: str, rules: Sequence[str] = (),
                    bridge: Optional[Bridge] = None) -> "Engine":
        """Load the compiled program text `prolog`, the module `module` whose event rules
        are labelled `rules` (as `from_compiled`, for a compilation kept as text)."""
        engine = cls._load_text(prolog, module, bridge)
        engine.rules = list(rules)
        return engine

    @classmethod
    def load(cls, program_path: Union[str, Path], bridge: Optional[Bridge] = None) -> "Engine":
        """Compile and load a `.rtl` program file."""
        path = str(program_path)
        result = compile_file(path, module=unique_module_name(path))
        return cls.from_compiled(result, bridge)

    @classmethod
    def from_source(cls, text: str, name: str = "program.rtl", bridge: Optional[Bridge] = None) -> "Engine":
        """Compile and load program text."""
        result = compile_source(text, name, module=unique_module_name(name))
        return cls.from_compiled(result, bridge)

    @classmethod
    def _load_text(cls, prolog: str, module: str, bridge: Optional[Bridge]) -> "Engine":
        directory = Path(tempfile.mkdtemp(prefix="retalisc-"))
        path = directory / f"{module}.pl"
        path.write_text(prolog, encoding="utf-8")
        engine = cls(path, bridge, module)
        engine._directory = directory
        return engine

    def _call(self, name: str, *args) -> str:
        """rtl_api:Name(Args..., Out): the values go to Prolog as data (Bridge.apply)."""
        self._check_usable()
        return self.bridge.apply(_API, name, *args)

    def _check_usable(self) -> None:
        if self._closed:
            raise RuntimeError("this Engine is closed")
        active = getattr(self.bridge, "active_program", None)
        if active is not None and active != self.module:
            raise InactiveEngineError(
                f"this Engine ({self.module}) is not the active one: the runtime processes one program per "
                f"process, and {active} was loaded or activated after it (call activate() to switch back)")

    def _predicate_call(self, module: str, name: str, *args) -> str:
        """`module:name(Args..., Out)` of another API module (the tracing), as `_call`."""
        if self._closed:
            raise RuntimeError("this Engine is closed")
        return self.bridge.apply(module, name, *args)

    def activate(self) -> None:
        """Make this Engine the one that processes events again, after another Engine was
        loaded in the same process. Its partial matches and memories are kept; its clock and
        statistics start again (they belong to the process, not to the program)."""
        with self._lock:
            self.bridge.active_program = None
            self._call("rtl_api_use_program", self.module)
            self._call("rtl_api_output_to_buffer")
            self.bridge.active_program = self.module
    # ---- as a context manager --------------------------------------------------------------

    def __enter__(self) -> "Engine":
        return self

    def __exit__(self, kind: Optional[Type[BaseException]], error: Optional[BaseException],
                 traceback: Optional[TracebackType]) -> None:
        self.close(run_pending=kind is None)

    def close(self, run_pending: bool = True) -> List["OutputEvent"]:
        """End the input (running the postponed synchronized matches, delivered to the
        callbacks, unless `run_pending` is false), forget every event and free the compiled
        program's files. Returns what the end of the input produced. Later calls raise
        RuntimeError; closing twice does nothing."""
        with self._lock:
            if self._closed:
                return []
            try:
                if getattr(self.bridge, "active_program", None) in (None, self.module):
                    produced = self.end_of_input(drop_pending=not run_pending)
                    self.clear()
                else:                       # another Engine took over: nothing of it runs now
                    produced = []
            finally:
                self._closed = True
                if self._directory is not None:
                    shutil.rmtree(self._directory, ignore_errors=True)
            return produced

    @property
    def closed(self) -> bool:
        return self._closed

    # ---- configuration -------------------------------------------------------------------

    def set_flag(self, name: str, value_text: str) -> None:
        """Set a runtime flag (`max_delay`, `echo_input`, `query_time_limit`); value_text is
        the value as Prolog text ("2.5", "inf", "true"), read as one ground term. A bad name or
        value raises PrologError and changes nothing."""
        with self._lock:
            self._call("rtl_api_set_flag", _text(name, "a flag name"), _text(value_text, "a flag value"))

    def on_output(self, callback: Callable[[OutputEvent], None]) -> None:
        """Call `callback(output_event)` for every output line, in processing order: derived
        events, subscription deliveries (`consumer` set), deletions (`op` "retract"), the echo
        of inputs, and the results of synchronized queries (`op` "answer", `answer` a
        QueryAnswer)."""
        with self._lock:
            self._callbacks.append(callback)

    # ---- feeding -------------------------------------------------------------------------

    def feed(self, event: str, start: Time, end: Optional[Time] = None, op: str = "add") -> List[OutputEvent]:
        """Process one event (term text) that occurred at `start` (or over [start, end]);
        return what it produced. Times are seconds, `[secs, nsecs]`, a `datetime` or a ROS
        time message, and are checked as an event file's are (`feed_batch`)."""
        return self.feed_batch([(event, start, end, op)])

    def feed_batch(self, events: Iterable[Sequence]) -> List[OutputEvent]:
        """Process `(event_text, start[, end[, op]])` tuples in order, in one Prolog call.

        Each event text must be one ground term; an event may also be a `Ros1Bytes` (a ROS
        1 message the runtime reads itself). When its bytes are not one message of its type
        (or hold a non-finite float), PrologError is raised with `undecodable` True at its
        index, after what the events before it produced: the caller converts that message
        itself and feeds the rest. A time is a number of seconds, a ROS stamp
        `[secs, nsecs]`, a `datetime.datetime` (UTC when naive) or a ROS time message; the
        runtime checks it with the check of the event-file reader, so a time is refused
        exactly when a file line with it is, with the same reason (ValueError: `"start" is
        after "end"`, `"t": nanoseconds must be in [0, 1e9), not -2`). A bad item raises
        (TypeError/ValueError for Python values and times, PrologError for the text) before
        anything of the batch is processed. An event whose processing raises an error stops
        the batch: what the events before it produced is delivered (callbacks included),
        then PrologError says which event failed; the engine stays usable."""
        delivered, _ = self._feed_items("rtl_api_feed_events", self._items(events))
        return delivered

    def feed_paced(self, events: Sequence[Sequence], dues: Sequence[float], tick: float = 0.01,
                   deliver: Optional[Callable[[List[OutputEvent]], None]] = None) -> List[OutputEvent]:
        """Process the items of `feed_batch`, each when it falls due: `dues[i]` is the
        wall-clock time (`time.time()`) at which `events[i]` is due, in order, and `tick`
        the latency allowed: this thread sleeps inside Prolog until the first item not
        processed is `tick` seconds late, then processes every item due by then as one
        batch (the fewest wake-ups that keep each item within `tick` of its due time): the
        pacing of a recording replayed at a rate, without a Python step per batch. The output is
        passed to `deliver(output)` as soon as a batch produced it (then the call goes on
        with the items left, which stay in the runtime: they are not passed again), and the
        output of the last batches is returned. Errors are raised as by `feed_batch`, with
        the failing item's index in `events` (the items before it were processed, their
        output delivered; the items after it are dropped). The engine's lock is held
        meanwhile: other threads' calls wait."""
        items = self._items(events)
        if len(dues) != len(items):
            raise ValueError(f"{len(dues)} due times for {len(items)} items")
        if not items:
            return []
        tick = float(tick)
        with self._lock:
            produced, done = self._feed_items("rtl_api_feed_paced", items, [float(d) for d in dues], tick)
            while done < len(items):
                if deliver is not None:
                    deliver(produced)
                    produced = []
                more, done = self._feed_items("rtl_api_feed_paced_rest", items, tick)
                produced = produced + more
            return produced

    @staticmethod
    def _items(events: Iterable[Sequence]) -> list:
        items = []
        for item in events:
            event, start = item[0], item[1]
            end = item[2] if len(item) > 2 else None
            op = item[3] if len(item) > 3 else "add"
            if op not in ("add", "retract"):
                raise ValueError(f"op must be 'add' or 'retract', not {op!r}")
            start_value = time_value(start, "a start time")
            end_value = "" if end is None else time_value(end, "an end time")
            items.append([op, _event_value(event), start_value, end_value])
        return items

    def _feed_items(self, predicate: str, items: list, *extra) -> Tuple[List[OutputEvent], int]:
        """Call `predicate` with `items` (unless it continues a paced call: `extra` only)."""
        if not items:
            return [], 0
        with self._lock:
            try:
                args = extra if predicate == "rtl_api_feed_paced_rest" else (items, *extra)
                answer = read_answer(self._call(predicate, *args))
            except PrologError as error:
                index = _bad_item_index(error)
                if index is None:
                    raise
                # a bad item: nothing of the batch was processed (so no batch_index, which
                # says that the items before it were)
                error.refused_index = index
                if "error(invalid_time(" in (error.term or ""):
                    bad = ValueError(str(error))
                    bad.refused_index = index
                    raise bad from None
                raise
            processed = answer.index if answer.stop == "paced" else len(items)
            delivered = self._deliver_answer(answer)
        if answer.stop == "undecodable":
            index = answer.index
            error = PrologError(f"event {index} of the batch ({items[index][1][:1]!r}): not one ROS 1 message of "
                                f"its type, or a float that is not finite")
            error.batch_index = index
            error.delivered = delivered
            error.undecodable = True
            raise error
        if answer.stop == "error":
            index = answer.index
            error = PrologError(f"event {index} of the batch ({items[index][1]!r}): {answer.message}")
            error.batch_index = index      # the events after it were not processed
            error.delivered = delivered
            raise error
        return delivered, processed

    def ros1_schema(self, schema: str) -> Optional[int]:
        """The handle of a ROS 1 message schema (text of the ground term c/rtl_ros1.c
        describes) for `Ros1Bytes` events; None when the runtime cannot read ROS 1 bytes
        (its C helper is not built, or the bridge cannot pass bytes). Registered once per
        process."""
        if schema in _ROS1_SCHEMAS:
            return _ROS1_SCHEMAS[schema]
        handle = None
        if getattr(self.bridge, "backend", "") == "pyswip":
            with self._lock:
                out = self._call("rtl_api_ros1_schema", schema)
            handle = int(out) if out else None
        _ROS1_SCHEMAS[schema] = handle
        return handle

    def feed_lines(self, text: Union[str, bytes], first_line: int = 1, *, allow_control: bool = False,
                   strict: bool = False) -> Tuple[List[OutputEvent], List[Rejection]]:
        """Process event JSON Lines (docs/runtime.md, "Event input") exactly as `swipl PROGRAM.pl FILE` does;
        return the output and the lines not processed, with their reasons. `text` is the
        lines joined by newlines, or their bytes: each line is then decoded as UTF-8, and one
        that is not UTF-8 text is rejected. Control lines
        (`add_rule`, `delete_rule`) are refused unless `allow_control`. An event whose
        processing raises is reported (kind "error") and the lines after it are processed;
        with `strict`, processing stops at the first line not processed, as it does after a
        halt (kind "halt"). The output of every line processed is returned, once."""
        if isinstance(first_line, bool) or not isinstance(first_line, int):
            raise TypeError(f"first_line must be an int, not {first_line!r}")
        feed = "rtl_api_feed_byte_lines" if isinstance(text, bytes) else "rtl_api_feed_lines"
        with self._lock:
            answer = read_answer(self._call(feed, text if isinstance(text, bytes) else _text(text, "event lines"),
                                            first_line, "true" if allow_control else "false",
                                            "true" if strict else "false"))
            return self._deliver_answer(answer), answer.rejections

    def _deliver(self, output: str) -> List[OutputEvent]:
        return self._deliver_answer(read_answer(output))

    def take_warnings(self) -> List[EngineWarning]:
        """The warnings of the inputs fed since the last call (deletions outside the retraction
        horizon, docs/runtime.md), in order."""
        warnings, self._warnings = self._warnings, []
        return warnings

    def _deliver_answer(self, answer: "Answer") -> List[OutputEvent]:
        self._warnings.extend(answer.warnings)
        events = answer.outputs
        for event in events:
            if event.query is not None:
                self._resolve(event.query)
        for callback in list(self._callbacks):
            for event in events:
                callback(event)
        if self._consumers:
            for event in events:
                for callback in self._consumers.get(event.consumer, []) if event.consumer is not None else []:
                    callback(event)
        return events

    # ---- subscriptions (thesis 3.4) and runtime rules --------------------------------------

    def subscribe(self, consumer: str, pattern_text: str, template_text: Optional[str] = None,
                  conditions_text: str = "[]", start: Union[Number, str, None] = None,
                  end: Union[Number, str, None] = None,
                  callback: Optional[Callable[[OutputEvent], None]] = None) -> str:
        """Deliver every event matching `pattern_text` (term text) and `conditions_text` (a
        Prolog list of goals) that occurs within [start, end] to `consumer`, as
        `template_text` (default: the event itself). The three texts share variables by name.
        `start`/`end` are seconds or "now"; None means unbounded. Deliveries come back as
        OutputEvents with `consumer` set, and go to `callback` if given. Returns the
        subscription id (text). The conditions must pass the sandbox. A bad subscription
        raises PrologError saying why; nothing is registered then."""
        args = (_text(consumer, "a consumer"), _text(pattern_text, "a pattern"),
                "" if template_text is None else _text(template_text, "a template"),
                _text(conditions_text, "the conditions"), _bound(start, "-inf"), _bound(end, "inf"))
        with self._lock:
            subscription_id = self._call("rtl_api_subscribe", *args)
            if callback is not None:
                self._consumers.setdefault(consumer, []).append(callback)
        return subscription_id

    def subscribe_query(self, consumer: str, query_text: str, template_text: Optional[str] = None) -> str:
        """Subscribe `consumer` to `query_text`, an event pattern or `Pattern-[Goals]` (the
        form of `retalisc run --subscribe`), from the start of the input. Returns the id."""
        args = (_text(consumer, "a consumer"), _text(query_text, "a query"),
                "" if template_text is None else _text(template_text, "a template"))
        with self._lock:
            return self._call("rtl_api_subscribe_query", *args)

    def unsubscribe(self, subscription_id: str, end: Union[Number, str, None] = None) -> None:
        """Stop delivering the events of subscription `subscription_id` that end after `end`
        (seconds; default "now", the clock)."""
        with self._lock:
            self._call("rtl_api_unsubscribe", str(subscription_id), _bound(end, "now"))

    def add_rules(self, text: str) -> List[str]:
        """Add the event rules in `text` (.rtl syntax) to the running program; they see only
        the events processed from now on. Unlabelled rules get fresh ids. Returns the rule
        ids. Raises RetalisError for a rule that does not compile, PrologError when a label
        is already in use or when a goal of a rule is unsafe (`unsafe goal: shell/1`): the
        rules come from outside the program file, so they must pass the sandbox
        (prolog_runtime/rtl_sandbox.pl). Nothing of `text` is added then."""
        with self._lock:
            prefix = self._call("rtl_api_fresh_rule_prefix", self.module)
            compiled = compile_rules(_text(text, "rule text"), self.module, prefix)
            self._call("rtl_api_install_rules", self.module, compiled.text)
            self.rules += [label for label in compiled.rule_ids if label not in self.rules]
        return compiled.rule_ids

    def remove_rule(self, label: str) -> None:
        """Remove the event rule `label` (added at runtime or compiled with the program), its
        triggers and its stored partial matches."""
        with self._lock:
            self._call("rtl_api_remove_rule", self.module, _text(label, "a rule label"))

    def clear(self) -> None:
        """Forget every event seen so far (partial matches, memory records, clock, statistics)."""
        with self._lock:
            self._call("rtl_api_clear")

    def end_of_input(self, drop_pending: bool = False) -> List[OutputEvent]:
        """The input has ended: every history is complete, so the postponed synchronized
        matches run now, in time order (or are discarded with `drop_pending`). Returns what
        they produced."""
        with self._lock:
            return self._deliver(self._call("rtl_api_end_of_input", "drop" if drop_pending else "run"))

    # ---- SLR: queries and memory instances (thesis 4.2) -----------------------------------

    def query_synchronized(self, goal: str, at: Number, timeout: Optional[Number] = None) -> "Future":
        """Post the synchronized query <goal, at> (thesis 4.2.5): it runs as soon as every
        memory it can read holds a record after `at` or has its history up to `at` complete,
        without holding up anything else. Returns a `concurrent.futures.Future` whose result
        is the list of answers (as `query_all`); it fails with QueryError kind "timeout" when
        the clock (event time) reaches `at + timeout` first, kind "dropped" when the input
        ends with `end_of_input(drop_pending=True)`. A goal that does not parse or that the
        sandbox refuses raises QueryError at once."""
        future: Future = Future()
        query_id = f"py{next(_python_queries)}"
        with self._lock:
            self._synchronized[query_id] = future
            self.post_synchronized(goal, at, timeout, query_id)
        return future

    def post_synchronized(self, goal: str, at: Number, timeout: Optional[Number] = None,
                          query_id: str = "") -> List["OutputEvent"]:
        """Post the synchronized query <goal, at> under `query_id`; its result comes as an
        output line `{"query": ID, "at": Z, "status": ..., "answers": [...], "message": ...}`
        (an OutputEvent with op "answer") when it is known. Returns what was output at once."""
        args = (_text(query_id, "a query id"), _text(goal, "a goal"), _time(at, "the query time"),
                "inf" if timeout is None else _time(timeout, "a timeout"))
        with self._lock:
            try:
                output = _raise_if_refused(self._call("rtl_api_post_query", *args))
            except QueryError:
                self._synchronized.pop(query_id, None)
                raise
            return self._deliver(output)

    def _resolve(self, result: dict) -> None:
        future = self._synchronized.pop(str(result["query"]), None)
        if future is None:
            return
        if result["status"] == "answered":
            future.set_result(result["answers"])
        else:
            future.set_exception(QueryError(result["status"], result["message"]))

    def query(self, goal: str, at: Optional[Number] = None, synchronized: bool = False,
              timeout: Optional[Number] = None):
        """The first answer to the SLR query <goal, at>: a dict mapping each variable of `goal`
        (those not starting with `_`) to its value as writeq text, `{}` for a goal without
        variables that succeeds, None when it fails. `at` limits what `mem/2` sees to records
        ending at or before it (default: everything). The goal runs under SWI-Prolog's sandbox;
        QueryError says why a goal was refused or failed.

        With `synchronized=True` (and `at`), the query waits until the data it needs has
        arrived and a Future of all its answers is returned: see `query_synchronized`."""
        if synchronized:
            if at is None:
                raise ValueError("a synchronized query needs a time: at=...")
            return self.query_synchronized(goal, at, timeout)
        answers = self._query(goal, at, "first")
        return answers[0] if answers else None

    def query_all(self, goal: str, at: Optional[Number] = None) -> List[Dict[str, str]]:
        """Every answer to <goal, at>, in Prolog's order (see `query`)."""
        return self._query(goal, at, "all")

    def _query(self, goal: str, at: Optional[Number], limit: str) -> List[Dict[str, str]]:
        at_value = "inf" if at is None else _time(at, "the query time")
        with self._lock:
            output = self._call("rtl_api_query", _text(goal, "a goal"), at_value, limit)
        return [json.loads(line) for line in _raise_if_refused(output).splitlines() if line]

    def tf_lookup(self, target: str, source: str, time: Union[str, Number, Sequence] = "latest") -> TfTransform:
        """The pose of frame `source` in frame `target` at `time`, from the tf tree the program
        learned from its tf messages (tf2's `lookupTransform(target, source, time)`; the
        runtime's tf library, docs/tf.md). `time` is "latest" (or 0: the latest common time),
        seconds, `(secs, nsecs)` or `("ns", nanoseconds)`. The frame ids and the time go to the
        runtime as data (a fixed call of tf_lookup/6, no goal text to read or check): the cost
        of the lookup plus one bridge call. Raises TfLookupError with tf2's reason when there is
        no transform."""
        args = (_text(target, "a frame id"), _text(source, "a frame id"), _tf_time(time))
        with self._lock:
            self._check_usable()
            answer = self.bridge.apply_numbers(_API, "rtl_api_tf_lookup_numbers", 7, 2, *args)
            if answer is None:      # no typed road in this process: the same answer as text
                answer = self._call("rtl_api_tf_lookup", *args)
        if type(answer) is tuple:
            (x, y, z, qx, qy, qz, qw), (secs, nsecs) = answer
            return TfTransform((x, y, z), (qx, qy, qz, qw), (secs, nsecs))
        output = answer
        if output[0] == "!":
            raise TfLookupError(output[2:])
        _, x, y, z, qx, qy, qz, qw, secs, nsecs = output.split("\t")
        return TfTransform((float(x), float(y), float(z)), (float(qx), float(qy), float(qz), float(qw)),
                           (int(secs), int(nsecs)))

    def memory(self, request: str) -> None:
        """Create or delete memory instances: `request` is the text of `c_mem(Id, Event-Conds, N, L)`,
        `c_mem(Id, Event-Conds, N, L, Options)` (Options: `[record_events(true)]` raises
        memory_record_added/2 and memory_record_forgotten/2), `memorize(Event, Conds, Template,
        Id, N)`, `d_mem(IdPattern)` or `delete_memory(IdPattern)`.
        The conditions must pass the sandbox; QueryError says why a request was refused."""
        with self._lock:
            _raise_if_refused(self._call("rtl_api_memory", _text(request, "a memory request")))

    # ---- inspection ----------------------------------------------------------------------

    def stats(self) -> dict:
        with self._lock:
            text = self._call("rtl_api_stats")
        result = {}
        for line in text.splitlines():
            name, _, value = line.partition("\t")
            result[name] = int(value)
        return result

    def detections(self) -> Dict[str, int]:
        """Detections per event rule since the start (or `clear`): how many complete matches
        of each rule passed its `where` conditions, by rule label (`r1`, `r2`, ... for rules
        without one). Every rule of the program is there, 0 for one that detected nothing,
        in program order, then the rules added with `add_rules`. A detection is counted when
        the match completes: an `alarm` rule's event comes later, a synchronized rule's only
        if its query holds, a `null` rule derives none, so the counts need not add up to the
        `derived` of `stats()`."""
        with self._lock:
            text = self._call("rtl_api_detections")
        counts = dict.fromkeys(self.rules, 0)
        for line in text.splitlines():
            rule, _, count = line.partition("\t")
            counts[rule] = int(count)
        return counts

    @cached_property
    def ros_strings(self) -> str:
        """How the program reads a ROS message's string field (collect_settings): `plain`
        (frame id `odom` is the atom `odom`) or `quoted`, the 2015 release's `'"odom"'`."""
        from .bridge import GoalFailed

        try:
            return self.bridge.apply(self.module, "ele_ros_strings") if self.module else "plain"
        except (GoalFailed, PrologError):       # not a quoted program: the fact is not there
            return "plain"

    def summary(self) -> str:
        with self._lock:
            return self._call("rtl_api_summary")

    def store_size(self) -> int:
        with self._lock:
            return int(self._call("rtl_api_store_size"))

    def clock(self) -> float:
        with self._lock:
            return float(self._call("rtl_api_clock"))

    def advance_clock(self, time: Number) -> List[OutputEvent]:
        """A heartbeat: move the clock to `time` (event time, seconds) without an event, if
        that is later than the clock; the timers it passes (absences, alarms) fire and the
        memory records it puts beyond their time limit are forgotten. Returns what they
        produced."""
        if isinstance(time, bool) or not isinstance(time, (int, float)) or not math.isfinite(time):
            raise ValueError(f"advance_clock needs a finite number of seconds, not {time!r}")
        with self._lock:
            return self._deliver(self._call("rtl_api_advance_clock", time))
    # ---- snapshots (docs/recovery.md) ----------------------------------------------------

    def identity(self) -> str:
        """The hash of the compiled program and the runtime a snapshot of this Engine carries."""
        if self._identity is None:
            self._identity = snapshot.program_identity(self.prolog_file.read_text(encoding="utf-8"), self.module)
        return self._identity

    def save_state(self, path: Union[str, Path]) -> None:
        """Write the whole state of the program (partial matches, memories, subscriptions,
        rules added, postponed queries, active queries, flags, clock, counters) to the file
        `path`, atomically: a temporary file, flushed to disk, renamed over `path`. Call it
        between calls that feed events (never from a callback)."""
        path = Path(path)
        with self._lock:
            snapshot.replace_atomically(
                path, lambda temporary: self._call("rtl_api_save_state", str(temporary), self.identity()))

    def restore_state(self, path: Union[str, Path]) -> None:
        """Replace the state by the one `save_state` wrote to `path`. A file that is not a
        complete snapshot of this program under this runtime version raises
        `recovery.StateError` (`snapshot.StateError`) and changes nothing."""
        with self._lock:
            try:
                self._call("rtl_api_restore_state", str(path), self.identity())
            except PrologError as error:
                raise snapshot.StateError(f"{path}: {error}") from None

    # ---- the runtime's loop, halts and action output (the driver's roads) ------------------

    def flag(self, name: str) -> str:
        """The value of the runtime flag `name` as text (`inf`, `2.5`, `true`)."""
        with self._lock:
            return self._call("rtl_api_flag", _text(name, "a flag name"))

    def end_stopped(self) -> bool:
        """Whether program code called halt in a match the end of the input ran (`end_of_input`)."""
        with self._lock:
            return self._call("rtl_api_end_stopped") == "yes"

    def take_halted(self) -> str:
        """Why loading the program stopped (program code called halt in a directive), once; ""
        when it did not."""
        with self._lock:
            return self._call("rtl_api_take_halted")

    def set_action_output(self, path: str) -> None:
        """Send what program code prints (actions, conditions) to the file `path`; PrologError
        when it cannot be opened."""
        with self._lock:
            self._call("rtl_api_set_action_output", _text(path, "a path"))

    def close_action_output(self) -> None:
        """Close the file of the action output, if any (`set_action_output`)."""
        with self._lock:
            self._call("rtl_api_close_action_output")

    def run_event_file(self, path: str, allow_control: bool = False, strict: bool = False) -> str:
        """The runtime's own loop over the event file `path` (`-`: standard input), writing the
        output to standard output, as `swipl PROGRAM.pl FILE` does: "done", "stopped" (a halt,
        or strict) or "output gone" (the reader of standard output went away)."""
        with self._lock:
            return self._call("rtl_api_run_event_file", _text(path, "a path"),
                              "true" if allow_control else "false", "true" if strict else "false")

    def trace(self, request: str, *args) -> str:
        """A request to the runtime's tracing (prolog_runtime/rtl_trace.pl), for `explain` and
        `--trace`: `request` names one of its entry points (`start`, `stop`, `feed_line`,
        `feed_byte_line`, `explain`, `why_not`, `matches`, `late`, `rules`, `report`, `end`), `args` its
        values. Returns its output text."""
        if request not in _TRACE_REQUESTS:
            raise ValueError(f"no tracing request {request!r} (one of {', '.join(_TRACE_REQUESTS)})")
        with self._lock:
            if not self._tracing:
                self._call("rtl_api_use_tracing")
                self._tracing = True
            return self._predicate_call("rtl_trace", f"rtl_trace_{request}", *args)

    def state_digest(self) -> str:
        """A hash of everything a snapshot holds (equal states, equal digests)."""
        with self._lock:
            return self._call("rtl_api_state_digest")
