"""Python API for active queries (thesis chapter 6) over the in-process SWI-Prolog bridge.

    aq = ActiveQueries.from_source(text, "shop.pl", mode="tabled")
    aq.on_add(lambda qid, answer: ...)
    aq.on_delete(lambda qid, answer: ...)
    answers = aq.register("q1", "accessible(O, S)")   # current answers (writeq text, sorted)
    aq.assert_fact("offers(s1, o7, 3)")                # callbacks fire for the changes
    aq.retract_facts(["offers(s1, o7, 3)", "seller(s1, t1)"])   # one DRed pass
    aq.add_rule("cheap(O) :- offers(_, O, P), P < 5")    # checked, then propagated; remove_rule
    aq.unregister("q1")                                # frees its tables, goals and records

Goals, facts and query ids cross the boundary as values (`Bridge.apply` into
`prolog_runtime/rtl_aq_api.pl`), never pasted into goal text: a goal or fact is read there
as exactly one term (a registered goal can only be one atom of a program predicate). Answers
come back as writeq text. One program is loaded per process (the bridge has one Prolog
engine): loading another program unloads the previous one and drops every query.
"""
from __future__ import annotations

import sys
import tempfile
from pathlib import Path
from typing import Callable, Dict, Iterable, List, NamedTuple, Optional, Union

from ..compiler import AqOptions, compile_source
from . import snapshot
from .bridge import Bridge, PrologError
from .feed import FeedLoop, ScriptSource, Sinks, TextSink

_API = "rtl_aq_api"

QueryId = Union[str, int]
Callback = Callable[[QueryId, str], None]


class ScriptBatch(NamedTuple):
    """What one `ActiveQueries.run_script_batch` call did."""
    output: str            # the JSON Lines the commands printed
    next_line: int         # the script line after the last command run
    status: str            # "more", "done" or "error"
    exit_status: int       # with "error": 2 for a bad line, 1 for a failed command
    message: str           # with "error": the message `retalisc aq` prints

_loaded: Dict[str, Optional[str]] = {"path": None}


def _id_value(qid: QueryId) -> QueryId:
    if isinstance(qid, bool) or not isinstance(qid, (str, int)):
        raise TypeError(f"query ids are str or int, not {type(qid).__name__}")
    return qid


def _text(value: str, what: str) -> str:
    if not isinstance(value, str):
        raise TypeError(f"{what} must be a str, not {type(value).__name__}")
    return value


class ActiveQueries:
    """Register queries, update facts, receive add/delete notifications."""

    def __init__(self, bridge: Optional[Bridge] = None):
        self.bridge = bridge or Bridge()
        self._on_add: List[Callback] = []
        self._on_delete: List[Callback] = []
        self._ids: Dict[str, QueryId] = {}
        self._tmp = tempfile.TemporaryDirectory(prefix="retalisc_aq_")
        self._identity: Optional[str] = None

    # -- loading ---------------------------------------------------------------------------
    @classmethod
    def from_source(cls, source_text: str, file: str = "<program>", mode: str = "tabled",
                    subsumption: bool = False, bridge: Optional[Bridge] = None) -> "ActiveQueries":
        aq = cls(bridge)
        aq.load(source_text, file, mode, subsumption)
        return aq

    @classmethod
    def from_compiled(cls, prolog: str, bridge: Optional[Bridge] = None) -> "ActiveQueries":
        """The program `compile_source(..., active_queries=...)` compiled, loaded."""
        aq = cls(bridge)
        aq.load_compiled(prolog)
        return aq

    @classmethod
    def from_file(cls, path: Union[str, Path], mode: str = "tabled", subsumption: bool = False,
                  bridge: Optional[Bridge] = None) -> "ActiveQueries":
        text = Path(path).read_text(encoding="utf-8")
        return cls.from_source(text, str(path), mode, subsumption, bridge)

    def load(self, source_text: str, file: str = "<program>", mode: str = "tabled",
             subsumption: bool = False) -> None:
        """Compile the definite program and load it (replacing a previously loaded one)."""
        self.load_compiled(compile_source(source_text, file, active_queries=AqOptions(mode, subsumption)).prolog)

    def load_compiled(self, prolog: str) -> None:
        """Load a program compiled for active queries (replacing a previously loaded one)."""
        out = Path(self._tmp.name) / f"aq_program_{abs(hash(prolog)) % 10**12}.pl"
        out.write_text(prolog, encoding="utf-8")
        previous = _loaded["path"]
        if previous is not None:
            # every query, table and fact asserted or rule added at run time (rtl_aq.pl,
            # aq_reset_program/0)
            self.bridge.apply(_API, "aq_api_reset")
            self.bridge.apply(_API, "aq_api_unload", previous)
        self.bridge.consult(out)
        # the API module next to the runtime the program loaded (a constant goal, no values)
        self.bridge.once("module_property(rtl_aq, file(F)), file_directory_name(F, D), "
                         "directory_file_path(D, 'rtl_aq_api.pl', P), use_module(user:P)")
        _loaded["path"] = str(out)
        self._ids.clear()
        self._identity = snapshot.program_identity(prolog, "")

    # -- callbacks -------------------------------------------------------------------------
    def on_add(self, callback: Callback) -> None:
        self._on_add.append(callback)

    def on_delete(self, callback: Callback) -> None:
        self._on_delete.append(callback)

    def _events(self) -> List[tuple]:
        text = self.bridge.apply(_API, "aq_api_events")
        events = []
        for line in text.splitlines():
            qtext, op, answer = line.split("\t", 2)
            events.append((self._ids.get(qtext, qtext), op, answer))
        return events

    def _dispatch(self) -> None:
        for qid, op, answer in self._events():
            if op == "add":
                for cb in self._on_add:
                    cb(qid, answer)
            elif op == "delete":
                for cb in self._on_delete:
                    cb(qid, answer)

    # -- queries ---------------------------------------------------------------------------
    def register(self, query_id: QueryId, goal: str) -> List[str]:
        """Register `goal` as active query `query_id`; returns its current answers."""
        qid = _id_value(query_id)
        text = self.bridge.apply(_API, "aq_api_register", qid, _text(goal, "a goal"))
        self._ids[self.bridge.apply(_API, "aq_api_id_text", qid)] = query_id
        return text.splitlines()

    def unregister(self, query_id: QueryId) -> None:
        self.bridge.apply(_API, "aq_api_unregister", _id_value(query_id))
        self._dispatch()

    def answers(self, query_id: QueryId) -> List[str]:
        return self.bridge.apply(_API, "aq_api_answers", _id_value(query_id)).splitlines()

    # -- updates ---------------------------------------------------------------------------
    def assert_fact(self, fact: str) -> None:
        self.assert_facts([fact])

    def retract_fact(self, fact: str) -> None:
        self.retract_facts([fact])

    def assert_facts(self, facts: Iterable[str]) -> None:
        self.bridge.apply(_API, "aq_api_assert", [_text(f, "a fact") for f in facts])
        self._dispatch()

    def retract_facts(self, facts: Iterable[str]) -> None:
        """Retract several facts in one DRed pass."""
        self.bridge.apply(_API, "aq_api_retract", [_text(f, "a fact") for f in facts])
        self._dispatch()

    def add_rule(self, rule: str) -> None:
        """Add the rule `H :- B` (text) at run time; callbacks fire for what it derives. The rule
        is untrusted: its body may use the program's predicates and the comparison builtins only
        (PrologError otherwise)."""
        self.bridge.apply(_API, "aq_api_add_rule", _text(rule, "a rule"))
        self._dispatch()

    def remove_rule(self, rule: str) -> None:
        """Remove a rule added by `add_rule` (DRed); PrologError when no such rule was added."""
        self.bridge.apply(_API, "aq_api_remove_rule", _text(rule, "a rule"))
        self._dispatch()

    def stats(self) -> Dict[str, int]:
        text = self.bridge.apply(_API, "aq_api_stats")
        return {k: int(v) for k, v in (line.split() for line in text.splitlines())}

    # -- update scripts and snapshots (docs/recovery.md) ----------------------------------
    def run_script_batch(self, script: Union[str, Path], first_line: int, max_commands: int) -> ScriptBatch:
        """Run at most `max_commands` commands of the update script file `script` (the format
        of `retalisc aq --script`) from its line `first_line` on; the callbacks do not fire,
        the notifications come back as the JSON Lines `retalisc aq` prints."""
        text = self.bridge.apply(_API, "aq_api_script_batch", str(script), int(first_line), int(max_commands))
        head, rest = text.split("\n", 1)
        next_line, status, exit_status, length = head.split(" ")
        length = int(length)
        return ScriptBatch(rest[length:], int(next_line), status, int(exit_status), rest[:length])

    def identity(self) -> str:
        """The hash of the compiled program and the runtime a snapshot carries."""
        if self._identity is None:
            raise RuntimeError("no program is loaded")
        return self._identity

    def save_state(self, path: Union[str, Path]) -> None:
        """Write the state (registered queries, their tables and records, stored facts, rules
        added at run time) to `path`, atomically (a temporary file, fsync, rename)."""
        snapshot.replace_atomically(
            Path(path), lambda temporary: self.bridge.apply(_API, "aq_api_save_state", str(temporary),
                                                            self.identity()))

    def restore_state(self, path: Union[str, Path]) -> None:
        """Replace the state by the one `save_state` wrote; `recovery.StateError` (and nothing
        changed) for a file that is not a complete snapshot of this program and runtime."""
        try:
            self.bridge.apply(_API, "aq_api_restore_state", str(path), self.identity())
        except PrologError as error:
            raise snapshot.StateError(f"{path}: {error}") from None

    def state_digest(self) -> str:
        """A hash of everything a snapshot holds (equal states, equal digests)."""
        return self.bridge.apply(_API, "aq_api_state_digest")


def run_script(aq: ActiveQueries, script: Union[str, Path], out: str = "-", display_name: Optional[str] = None,
               log=None) -> int:
    """`retalisc aq PROGRAM --script SCRIPT [--out OUT]`: the update script run on the loaded
    ActiveQueries `aq` by the feed loop (a `ScriptSource`), the notifications as JSON Lines on
    standard output or to `out`; a bad line ends the run with its message (`display_name`
    naming the script) and status 2, a failed command with status 1. Returns the exit status."""
    if out == "-":
        sink = TextSink(sys.stdout, "standard output", owned=False)
    else:
        sink = TextSink(open(out, "w", encoding="utf-8", newline=""), str(out), owned=True)
    source = ScriptSource(str(Path(script).resolve()), display_name or str(script))
    return FeedLoop(aq, source, Sinks([sink]), signals=False, engine_errors=(PrologError,), log=log).run()
