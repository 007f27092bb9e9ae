"""Explaining detections (`retalisc explain`): run a program over an event file with the
runtime's event log on (prolog_runtime/rtl_trace.pl), then ask how a derived event came
about or why a pattern was not detected.

The rules go to the runtime as one term, `[rule(Label, Place, Head, Pattern), ...]`, with the
pattern in the plain form rtl_trace.pl evaluates (`ev/3`, `seq/2`, ..., `where/2`, `win/2`,
`neg/3`, `absent/3`, `fnot/3`, `agg/3`, `sliding/5`, and `timer/2` or `sync/2` around the
pattern of a timer or synchronized rule, whose head is then the raised event), written by `retalisc.frontend.terms.to_prolog` and read back as
data; the event file is fed line by line so that every event is logged with its line.
"""
from __future__ import annotations

import io
from pathlib import Path
from typing import IO, Iterable, List, Optional, Tuple

from ..compiler import CompileResult
from ..frontend.program import (Absence, Aggregate, Binary, Check, EventAtom, EventRule, Negation, Pattern,
                                Sliding, Where, Window)
from ..frontend.terms import Atom, Compound, Number, Term, Var, to_prolog
from ..passes.edbc import alarm_head
from .engine import Engine, OutputEvent, Rejection, read_answer
from .event_lines import batch_payload, max_line_bytes, read_lines
from .feed import Batch, EngineSource, FeedLoop, Problem, Sink, Sinks, rejection_kind
from ..frontend.writer import write_term
from ..frontend.program import walk_pattern

def _fresh(counter: List[int], what: str) -> Var:
    counter[0] += 1
    return Var(f"_RtlTrace{what}{counter[0]}")


def pattern_term(pattern: Pattern, counter: List[int], window: Optional[float] = None) -> Term:
    """The pattern in the form rtl_trace.pl evaluates; `window` is the innermost window around
    it, which bounds the blockers of an `fnot` (the compiler's binarize gives each step the
    same)."""
    def inner(part: Pattern) -> Term:
        return pattern_term(part, counter, window)

    if isinstance(pattern, EventAtom):
        start = pattern.start if pattern.start is not None else _fresh(counter, "S")
        end = pattern.end if pattern.end is not None else (start if pattern.start is not None
                                                           else _fresh(counter, "E"))
        return Compound("ev", (pattern.term, start, end))
    if isinstance(pattern, Binary) and pattern.op == "fnot":
        return Compound("fnot", (inner(pattern.left), inner(pattern.right),
                                 Atom("none") if window is None else Number(window)))
    if isinstance(pattern, Binary):
        return Compound(pattern.op, (inner(pattern.left), inner(pattern.right)))
    if isinstance(pattern, Where):
        return Compound("where", (inner(pattern.pattern), pattern.condition))
    if isinstance(pattern, Check):
        return Compound("check", (inner(pattern.pattern), pattern.condition))
    if isinstance(pattern, Window):
        length = pattern.length if window is None else min(window, pattern.length)
        return Compound("win", (pattern_term(pattern.pattern, counter, length), Number(pattern.length)))
    if isinstance(pattern, Negation):
        return Compound("neg", (inner(pattern.negated), inner(pattern.first), inner(pattern.second)))
    if isinstance(pattern, Absence):
        return Compound("absent", (inner(pattern.negated), inner(pattern.first), Number(pattern.duration)))
    if isinstance(pattern, Aggregate):
        return Compound("agg", (pattern.function, inner(pattern.pattern), pattern.value))
    if isinstance(pattern, Sliding):
        return Compound("sliding", (pattern.function, inner(pattern.pattern), pattern.group,
                                    Number(pattern.duration), pattern.value))
    raise TypeError(f"rtl_trace has no form for the pattern {type(pattern).__name__}")


def rules_text(rules: Iterable[EventRule]) -> str:
    """The event rules as the list rtl_trace.pl reads (rules without a derived head left out)."""
    items = []
    counter = [0]
    for number, rule in enumerate(rules, start=1):
        if rule.head == Atom("null") and rule.synchronized is None:
            continue
        label = rule.label or f"r{number}"
        place = f"{Path(rule.span.file).name}:{rule.span.line}"
        head, pattern = rule.head, pattern_term(rule.pattern, counter)
        if rule.synchronized is not None:       # synchronized(E, Query, SyncConds): E once Query can run
            head, pattern = rule.synchronized.args[0], Compound("sync", (pattern, rule.synchronized.args[1]))
        elif alarm_head(head):                  # a timer: the raised event, D seconds after the match
            head, pattern = head.args[0], Compound("timer", (pattern, head.args[1]))
        items.append("rule(" + ", ".join([to_prolog(Atom(label)), to_prolog(Atom(place)), to_prolog(head),
                                          to_prolog(pattern)]) + ")")
    return "[" + ",\n".join(items) + "]"


class Explainer:
    """A program run over an event file with every event logged, to be asked about. The lines
    are fed by the feed loop (feed.FeedLoop, one line a batch, `TraceSource`); its problems (a
    rejected line, an error) are kept in `rejections` and, with `log`, reported there as every
    road reports them."""

    def __init__(self, result: CompileResult, log: Optional[IO[str]] = None):
        self.result = result
        self.log = log
        self.engine = Engine.from_compiled(result)
        self.rules = rules_text(result.unit.program.event_rules)
        self.rejections: List[Tuple[object, Rejection]] = []   # (where: line number or TOPIC#N, rejection)
        self.outputs: List[OutputEvent] = []

    def feed_file(self, events: str) -> None:
        """Feed the event file line by line, each event logged with its line number."""
        with open(events, "rb") as source:             # lines read as `retalisc run` reads them
            lines = read_lines(source, max_line_bytes(self.engine))
            self._feed(((batch_payload([raw]), number) for number, (raw, _) in enumerate(lines, start=1)), events)

    def feed_placed(self, lines: Iterable[Tuple[str, str]], name: str = "<input>") -> None:
        """Feed event lines, each `(line, where)`, its events logged as coming from `where`
        (a recording's messages: `TOPIC#N`); `name` names the input in messages."""
        self._feed(lines, name)

    def _feed(self, lines, name: str) -> None:
        source = TraceSource(self, lines, name)
        FeedLoop(self.engine, source, Sinks([_Collected(self.outputs)]), signals=False,
                 log=self.log if self.log is not None else io.StringIO()).run()

    def explain(self, event: str, limit: int = 5) -> str:
        return self.engine.trace("explain", self.rules, event, limit)

    def why_not(self, pattern: str) -> str:
        return self.engine.trace("why_not", self.rules, pattern)

    def matches(self, pattern: str) -> List[Tuple[str, float, float, str]]:
        """Every event unifying with `pattern` that a rule's pattern matches in the whole
        log, as explain evaluates the rules: (event text, start, end, rule label), sorted."""
        text = self.engine.trace("matches", self.rules, pattern)
        found = []
        for line in text.splitlines():
            event, start, end, label = line.split("\t")
            found.append((event, float(start), float(end), label))
        return found


class TraceSource(EngineSource):
    """Event lines fed one at a time with the runtime's event log on (rtl_trace.pl), as a
    source of the feed loop; no end of input and no summary (`retalisc explain` asks about
    the run instead)."""

    def __init__(self, explainer: Explainer, lines, name: str):
        self.explainer = explainer
        self.lines = lines
        self.name = name
        self.started = False

    @property
    def batches(self):
        for line, where in self.lines:
            yield Batch(where, [line], 0)

    def feed(self, engine, batch: Batch, write):
        line, where = batch.lines[0], batch.first
        feed = "feed_byte_line" if isinstance(line, bytes) else "feed_line"
        answer = read_answer(engine.trace(feed, line, where))
        problems = []
        for rejection in answer.rejections:
            self.explainer.rejections.append((where, rejection))
            problems.append(Problem(where, rejection_kind(rejection.kind), rejection.reason))
        write(answer.outputs)
        return problems, False

    def at_start(self, engine) -> str:
        engine.trace("start")
        self.started = True
        return ""

    def at_end(self, engine, write, drop_pending: bool, strict: bool) -> None:
        pass

    def release(self, engine) -> None:
        if self.started:
            engine.trace("stop")

    def summary(self, engine, seconds: float, log) -> None:
        pass


class _Collected(Sink):
    """A sink keeping the outputs in a list."""

    out_name = "the outputs"

    def __init__(self, outputs: list):
        self.outputs = outputs

    def write(self, produced) -> None:
        self.outputs.extend(produced)


# ---- run --trace RULE and --late FILE ------------------------------------------------------


def _step_description(step, side: str) -> str:
    mine, other = (step.left, step.right) if side == "left" else (step.right, step.left)
    text = write_term(mine.term, 999)
    if other is None:
        return f"({text})"
    return f"({text} waiting for {write_term(other.term, 999)})"


def trace_specs(unit, labels: Iterable[str]) -> list:
    """What rtl_trace_rules/2 watches for the rules `labels`: per rule its head and the stores of
    its partial matches, each with a description. Raises KeyError for an unknown label."""
    rules = {b.rule_id: b for b in unit.rules}
    generated = {g.rule_id: g for g in unit.generated}
    specs = []
    for label in labels:
        if label not in rules:
            raise KeyError(label)
        binary, code = rules[label], generated[label]
        steps = {step.name: (number, step) for number, step in enumerate(binary.steps, start=1)}
        stores = []
        for name, arity, _window in code.stores:
            step_name, role = code.roles[name]          # (what the edbc pass says the store holds)
            number, step = steps[step_name]
            side_name = {"lefts": "left", "rights": "right"}.get(role)
            what = (f"step {number} {side_name} {_step_description(step, side_name)}" if side_name
                    else f"step {number} {role}")
            stores.append([name, arity, "live", what])
        for live, arity, kept_a, kept_b, _order in code.kept:
            what = next((s[3] for s in stores if s[0] == live), live)
            stores += [[kept_a, arity, "kept", what], [kept_b, arity, "kept", what]]
        head = binary.rule.head
        name = head.name if isinstance(head, (Atom, Compound)) else "null"
        specs.append([label, name, head.arity if isinstance(head, Compound) else 0, stores])
    return specs


def late_rules(unit) -> list:
    """Per rule: its label, the window of its pattern (-1 for none) and its event atoms, for
    rtl_trace_late/3."""
    found = []
    for binary in unit.rules:
        windows = [p.length for p in walk_pattern(binary.rule.pattern) if isinstance(p, Window)]
        atoms = sorted({to_prolog(p.term) for p in walk_pattern(binary.rule.pattern) if isinstance(p, EventAtom)})
        found.append([binary.rule_id, max(windows) if windows else -1, atoms])
    return found
