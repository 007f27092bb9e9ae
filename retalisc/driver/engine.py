"""The Python face of a running Retalis program.

An `Engine` loads one compiled program into the in-process SWI-Prolog (through `Bridge`)
and feeds it events, one at a time or in batches. Every output line the program produces
(derived events, subscription deliveries, deletions) comes back as an `OutputEvent`, in
processing order, and is also handed to the callbacks registered with `on_output`.
Batches are the fast path: one Prolog call per batch, not per event.
"""
from __future__ import annotations

import itertools
import json
import tempfile
from concurrent.futures import Future
from dataclasses import dataclass
from pathlib import Path
from typing import Callable, Dict, Iterable, List, Optional, Sequence, Tuple, Union

from ..compiler import CompileResult, compile_file, compile_source, module_name
from .bridge import Bridge

Number = Union[int, float]

_loaded_modules = itertools.count(1)
_python_queries = itertools.count(1)


def _unique_module(program_name: str) -> str:
    """A module name for the program no other program of this process has."""
    return f"{module_name(program_name)}_{next(_loaded_modules)}"


@dataclass(frozen=True)
class OutputEvent:
    """One output line: `event` is the term text (writeq), `consumer` is set for subscription
    deliveries, `op` is "add" or "retract"; or, with `op` "answer", the result of a synchronized
    query (`query` holds its JSON object: query, at, status, answers, message)."""

    event: str
    start: Number
    end: Number
    consumer: Optional[str] = None
    op: str = "add"
    line: str = ""
    query: Optional[dict] = None     # op "answer": the result line of a synchronized query

    @classmethod
    def from_line(cls, line: str) -> "OutputEvent":
        data = json.loads(line)
        if "query" in data:
            return cls("", data["at"], data["at"], None, "answer", line, data)
        return cls(data["event"], data["start"], data["end"], data.get("consumer"), data.get("op", "add"), line)


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
    line: int
    reason: str


@dataclass(frozen=True)
class EngineWarning:
    """A warning about an input (a deletion outside the retraction horizon): its line in a
    `feed_lines` batch, None for `feed`/`feed_batch`."""
    line: Optional[int]
    text: str


def prolog_string(text: str) -> str:
    """`text` as a Prolog string literal."""
    escaped = text.replace("\\", "\\\\").replace('"', '\\"').replace("\n", "\\n").replace("\r", "\\r")
    return f'"{escaped}"'


def _bound_text(value, default: str) -> str:
    """A subscription time bound as Prolog text: a number, "now", or the default."""
    if value is None:
        return default
    if value in ("now", "inf"):
        return value
    if value == "-inf":
        return "(-inf)"
    return _number_text(value)


def _number_text(value: Number) -> str:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise TypeError(f"a time must be a number of seconds, not {value!r}")
    if isinstance(value, float) and value != value:
        raise ValueError("a time must not be NaN")
    text = repr(value)
    return f"({text})" if text.startswith("-") else text


class Engine:
    """A loaded Retalis program fed with events from Python."""

    def __init__(self, prolog_file: Union[str, Path], bridge: Optional[Bridge] = None, module: str = ""):
        self.bridge = bridge or Bridge()
        self.module = module
        self._callbacks: List[Callable[[OutputEvent], None]] = []
        self._consumers: Dict[str, List[Callable[[OutputEvent], None]]] = {}
        self._synchronized: Dict[str, "Future"] = {}
        self._warnings: List[EngineWarning] = []
        self.bridge.once("set_prolog_flag(retalis_embedded, true)")
        self.bridge.consult(str(prolog_file))
        if module:
            self.bridge.once(f"retalis:rtl_use_program({module})")
        self.bridge.once("retalis:rtl_output_to(buffer)")

    # ---- loading -------------------------------------------------------------------------

    @classmethod
    def from_compiled(cls, result: CompileResult, bridge: Optional[Bridge] = None) -> "Engine":
        """Load an already compiled program. Programs loaded into one process need distinct
        module names: `load` and `from_source` make them unique."""
        return cls._load_text(result.prolog, result.unit.module, bridge)

    @classmethod
    def load(cls, program_path: Union[str, Path], bridge: Optional[Bridge] = None) -> "Engine":
        """Compile and load a `.rtl` program file."""
        path = str(program_path)
        result = compile_file(path, module=_unique_module(path))
        return cls.from_compiled(result, bridge)

    @classmethod
    def from_source(cls, text: str, name: str = "program.rtl", bridge: Optional[Bridge] = None) -> "Engine":
        """Compile and load program text."""
        result = compile_source(text, name, module=_unique_module(name))
        return cls.from_compiled(result, bridge)

    @classmethod
    def _load_text(cls, prolog: str, module: str, bridge: Optional[Bridge]) -> "Engine":
        directory = Path(tempfile.mkdtemp(prefix="retalisc-"))
        path = directory / f"{module}.pl"
        path.write_text(prolog, encoding="utf-8")
        return cls(path, bridge, module)

    # ---- configuration -------------------------------------------------------------------

    def set_flag(self, name: str, value_text: str) -> None:
        """Set a runtime flag (`max_delay`, `echo_input`); value_text is Prolog text."""
        self.bridge.once(f"retalis:rtl_set_flag({name}, {value_text})")

    def on_output(self, callback: Callable[[OutputEvent], None]) -> None:
        """Call `callback(output_event)` for every output line, in processing order."""
        self._callbacks.append(callback)

    # ---- feeding -------------------------------------------------------------------------

    def feed(self, event: str, start: Number, end: Optional[Number] = None, op: str = "add") -> List[OutputEvent]:
        """Process one event (term text); return what it produced."""
        return self.feed_batch([(event, start, end, op)])

    def feed_batch(self, events: Iterable[Sequence]) -> List[OutputEvent]:
        """Process `(event_text, start[, end[, op]])` tuples in order, in one Prolog call."""
        items = []
        for item in events:
            event, start = item[0], item[1]
            end = item[2] if len(item) > 2 and item[2] is not None else start
            op = item[3] if len(item) > 3 else "add"
            if op not in ("add", "retract"):
                raise ValueError(f"op must be 'add' or 'retract', not {op!r}")
            items.append(f"event({op}, {event}, {_number_text(start)}, {_number_text(end)})")
        if not items:
            return []
        output = self.bridge.call_text(f"retalis:rtl_feed_events([{', '.join(items)}], Out)")
        return self._deliver(output)

    def feed_lines(self, text: str, first_line: int = 1) -> Tuple[List[OutputEvent], List[Rejection]]:
        """Process event JSON Lines (SPEC section 11) exactly as `swipl PROGRAM.pl FILE` does;
        return the output and the rejected lines with their reasons."""
        output = self.bridge.call_text(f"retalis:rtl_feed_lines({prolog_string(text)}, {first_line}, Out)")
        rejections = []
        lines = []
        for line in output.splitlines():
            if line.startswith("!"):
                number, _, reason = line[1:].partition("\t")
                rejections.append(Rejection(int(number), reason))
            elif line:
                lines.append(line)
        return self._deliver_lines(lines), rejections

    def _deliver(self, output: str) -> List[OutputEvent]:
        return self._deliver_lines([line for line in output.splitlines() if line])

    def take_warnings(self) -> List[EngineWarning]:
        """The warnings of the inputs fed since the last call (deletions outside the retraction
        horizon, docs/runtime.md), in order."""
        warnings, self._warnings = self._warnings, []
        return warnings

    def _deliver_lines(self, lines: List[str]) -> List[OutputEvent]:
        for line in lines:
            if line.startswith("?"):        # ?LINE<TAB>text: a warning (rtl_feed_lines/3)
                number, _, text = line[1:].partition("\t")
                self._warnings.append(EngineWarning(int(number) if number else None, text))
        events = [OutputEvent.from_line(line) for line in lines if line and not line.startswith("?")]
        for event in events:
            if event.query is not None:
                self._resolve(event.query)
        for callback in self._callbacks:
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
        `template_text` (default: the event itself). `start`/`end` are seconds or "now";
        None means unbounded. Deliveries come back as OutputEvents with `consumer` set,
        and go to `callback` if given. Returns the subscription id (text). A bad
        subscription raises PrologError saying why; nothing is registered then."""
        text = f"s(({pattern_text}), ({template_text or '_'}), ({conditions_text}))"
        goal = (f"term_string(T, {prolog_string(text)}), T = s(P, Tmpl, Conds), "
                f"retalis:rtl_subscribe(Id, {prolog_string(consumer)}, P, Conds, Tmpl, "
                f"{_bound_text(start, '(-inf)')}, {_bound_text(end, 'inf')}), "
                f"term_string(Id, IdText)")
        subscription_id = self.bridge.call_text(goal, "IdText")
        if callback is not None:
            self._consumers.setdefault(consumer, []).append(callback)
        return subscription_id

    def unsubscribe(self, subscription_id: str, end: Union[Number, str, None] = None) -> None:
        """Stop delivering the events of subscription `subscription_id` that end after `end`
        (seconds; default "now", the clock)."""
        self.bridge.once(f"term_string(Id, {prolog_string(str(subscription_id))}), "
                         f"retalis:rtl_unsubscribe(Id, {_bound_text(end, 'now')})")

    def add_rules(self, text: str) -> List[str]:
        """Add the event rules in `text` (.rtl syntax) to the running program; they see only
        the events processed from now on. Unlabelled rules get fresh ids. Returns the rule
        ids. Raises RetalisError for a rule that does not compile, PrologError when a label
        is already in use."""
        from ..runtime_rules import compile_rules

        prefix = self.bridge.call_text(f"retalis:rtl_fresh_rule_prefix({self.module}, P)", "P")
        compiled = compile_rules(text, self.module, prefix)
        self.bridge.once(f"retalis:rtl_install_rules({self.module}, {prolog_string(compiled.text)}, _)")
        return compiled.rule_ids

    def remove_rule(self, label: str) -> None:
        """Remove the event rule `label` (added at runtime or compiled with the program), its
        triggers and its stored partial matches."""
        self.bridge.once(f"atom_string(Id, {prolog_string(label)}), retalis:rtl_remove_rule({self.module}, Id)")

    def clear(self) -> None:
        """Forget every event seen so far (partial matches, memory records, clock, statistics)."""
        self.bridge.once("retalis:rtl_clear")
        self.bridge.once("retalis:rtl_output_to(buffer)")

    def end_of_input(self, drop_pending: bool = False) -> List[OutputEvent]:
        """The input has ended: every history is complete, so the postponed synchronized
        matches run now, in time order (or are discarded with `drop_pending`). Returns what
        they produced."""
        mode = "drop" if drop_pending else "run"
        return self._deliver(self.bridge.call_text(f"retalis:rtl_end_of_input({mode}, Out)"))

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
        self._synchronized[query_id] = future
        self.post_synchronized(goal, at, timeout, query_id)
        return future

    def post_synchronized(self, goal: str, at: Number, timeout: Optional[Number] = None,
                          query_id: str = "") -> List["OutputEvent"]:
        """Post the synchronized query <goal, at> under `query_id`; its result comes as an
        output line `{"query": ID, "at": Z, "status": ..., "answers": [...], "message": ...}`
        (an OutputEvent with op "answer") when it is known. Returns what was output at once."""
        timeout_text = "inf" if timeout is None else _number_text(timeout)
        goal_text = (f"retalis:rtl_output_to(buffer), atom_string(Q, {prolog_string(query_id)}), "
                     f"retalis:rtl_sync_query({prolog_string(goal)}, {_number_text(at)}, {timeout_text}, Q, E), "
                     f"( var(E) -> retalis:rtl_take_output(Ls), atomic_list_concat(Ls, '\\n', Out) ; "
                     f"E =.. [K, M], format(string(Out), \"!~w\\t~w\", [K, M]) )")
        try:
            output = _raise_if_refused(self.bridge.call_text(goal_text))
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
        at_text = "inf" if at is None else _number_text(at)
        output = self.bridge.call_text(f"retalis:rtl_query_lines({prolog_string(goal)}, {at_text}, {limit}, Out)")
        return [json.loads(line) for line in _raise_if_refused(output).splitlines() if line]

    def memory(self, request: str) -> None:
        """Create or delete memory instances: `request` is the text of `c_mem(Id, Event-Conds, N, L)`,
        `memorize(Event, Conds, Template, Id, N)`, `d_mem(IdPattern)` or `delete_memory(IdPattern)`.
        The conditions must pass the sandbox; QueryError says why a request was refused."""
        goal = (f"retalis:rtl_memory_request({prolog_string(request)}, E), "
                f"( var(E) -> Out = \"\" ; E =.. [K, M], format(string(Out), \"!~w\\t~w\", [K, M]) )")
        _raise_if_refused(self.bridge.call_text(goal))

    # ---- inspection ----------------------------------------------------------------------

    def stats(self) -> dict:
        pairs = self.bridge.all("retalis:rtl_stat(Name, Value)", "Name-Value")
        result = {}
        for pair in pairs:
            name, _, value = pair.partition("-")
            result[name] = int(value)
        return result

    def summary(self) -> str:
        return self.bridge.call_text("retalis:rtl_summary(Out)")

    def store_size(self) -> int:
        return int(self.bridge.once("retalis:rtl_store_size(N)", "N"))

    def clock(self) -> float:
        return float(self.bridge.once("retalis:rtl_clock(C)", "C"))
