"""lint: warnings for programs that compile but cannot mean what they say.

Each finding is a `LintWarning` (a place, a message and a hint); `retalisc check` and
`retalisc compile` print them as `file:line:col: warning: ...` and `--werror` turns them into
errors. The pass changes nothing in the unit but `unit.lint` and `unit.warnings`. It looks for:

- `window-on-last-operand`: `a(X) seq b(X).10` puts the window on `b(X)` only (`.` binds
  tighter than the event operators); the sequence needs `(a(X) seq b(X)).10`;
- `prolog-control-in-pattern`: `,`, `;` or `->` inside an event pattern is read as an event
  named `,` (or `;`, `->`) that never occurs; `and`, `or` and `where` are the event forms;
- `event-operator-in-clause`: an event operator in the body of a `:-` clause (an event rule
  written with the wrong arrow), and `no-event-rules`: a program without event rules whose
  clauses use event operators;
- `head-variable-unbound`: a head variable bound only in one branch of `or`, only inside an
  aggregate or only in a negated pattern: the derived event would carry an unbound variable;
- `undefined-predicate`: a `where`/`check` condition or an action calls a predicate that no
  clause defines and that is neither a builtin nor a library or runtime predicate (the run
  would stop with an existence error at the first event that gets there);
- `keyless-join`: the two sides of a join have variables but share none, no condition
  relates them and no window bounds them: every event of one side is paired with every
  earlier event of the other, and a rule without window keeps its partial matches forever,
  so each event costs more than the one before (not reported under the `recent` and
  `chronological` policies, which consume partners);
- `new-event-at-the-clock`: an action of an event rule calls `new_event/1` (directly or
  through the program's predicates): the raised event is stamped with the clock (the latest
  event time processed), not with the time of the match that raised it, which differs as soon
  as the triggering event comes late (language.md, "Actions and raising events");
- `one-event-per-solution`: a `where` (or `check`, `event_multiply`) condition holds a
  disjunction, or a goal with several solutions (member/2, between/3, a predicate of several
  clauses, ...), that binds no variable of the head: one event is derived per solution, so the
  same event comes several times;
- `variable-bound-after-negation`: a variable met first inside `\\+ G` of a clause body or a
  condition and used by a later goal: `\\+` binds nothing, so the negation asks whether G holds
  for any value, not for the one the later goal finds (and SWI-Prolog 9.0.4 may compile such a
  clause wrongly: `p(0) :- \\+ f(Y), e(Y, Y).` with only `e(0, 1)` stored succeeds);
- `string-mode`: a pattern (of an event rule, a memory or a subscription) holds a string in
  the form the program's ROS strings are not in (collect_settings `ros_strings`): the 2015
  release's quoted atom `'"odom"'` in a plain program, or, in a quoted program, a plain atom
  as the frame id of a header or the child frame id of a transform. No message's string
  field is ever that atom, so the pattern never matches one.

Runs last in the event pipeline, after the checks that make a program an error.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Iterable, List, Optional, Set

from ..frontend.errors import render_at
from ..frontend.program import (Absence, Aggregate, Binary, Check, EventAtom, EventRule, Negation, Pattern, Sliding,
                                StaticClause, Where, Window, pattern_conditions, pattern_text, walk_pattern)
from ..frontend.terms import Atom, Compound, Span, Term, Var, indicator, span_of, variables, walk
from ..frontend.writer import write_term
from .loadable import _goals, _loads_code, _program_predicates
from .unit import Unit
from ..frontend.terms import Number

name = "lint"

#: Operators that only mean something in an event pattern.
EVENT_OPERATORS = {"seq", "and", "par", "or", "equals", "meets", "during", "starts", "finishes", "fnot", "cnot",
                   "where", "check"}

#: Joins: binary operators whose two sides are matched against each other.
JOINS = {"seq", "and", "par", "equals", "meets", "during", "starts", "finishes"}

_PROLOG_CONTROL = {(",", 2): "and", (";", 2): "or", ("->", 2): "where", ("*->", 2): "where", ("|", 2): "or"}


@dataclass(frozen=True)
class LintWarning:
    """One finding: `code` names the kind (see the module doc), `span` the place."""

    code: str
    span: Optional[Span]
    message: str
    hint: str

    def render(self, source_text: Optional[str] = None, kind: str = "warning") -> str:
        """`file:line:col: warning: message`, the offending line, a caret, and the hint."""
        body = render_at(self.span, kind, self.message, source_text) if self.span else f"{kind}: {self.message}"
        return f"{body}\n    hint: {self.hint}"


def run(unit: Unit) -> Unit:
    found = lint_unit(unit)
    unit.lint = found
    text = unit.program.text or None
    unit.warnings.extend(w.render(text) for w in found)
    return unit


def lint_unit(unit: Unit) -> List[LintWarning]:
    program = unit.program
    found: List[LintWarning] = []
    for rule in program.event_rules:
        found += _window_on_last_operand(rule, program.text)
        found += _prolog_control(rule)
        found += _unbound_head_variables(rule)
        if unit.settings.consumption_policy == "unrestricted":
            found += _keyless_joins(rule)
    found += _event_operators_in_clauses(program)
    found += _new_events_at_the_clock(program)
    found += _solutions_with_the_same_head(program)
    found += _variables_bound_after_negation(program)
    found += _undefined_predicates(unit)
    found += _string_mode(unit)
    found.sort(key=lambda w: (w.span.line, w.span.column) if w.span else (0, 0))
    return found


# ---- window after the last operand ------------------------------------------------------


def _window_on_last_operand(rule: EventRule, text: str) -> Iterable[LintWarning]:
    for p in walk_pattern(rule.pattern):
        if not isinstance(p, Binary):
            continue
        window = p.right
        if isinstance(window, Window) and isinstance(window.pattern, EventAtom) and \
                not _parenthesized(window.span, text):
            length = write_term(_number(window.length), 0)
            operand = pattern_text(window.pattern)
            yield LintWarning(
                "window-on-last-operand", window.span,
                f"the window .{length} applies to {operand} only, not to the whole '{p.op}' pattern",
                f"write ({pattern_text(p.left)} {p.op} {operand}).{length} to bound the whole pattern, "
                f"or ({operand}).{length} if the window is meant for this event alone")


def _number(value):
    return Number(int(value) if float(value).is_integer() else value)


def _parenthesized(span: Optional[Span], text: str) -> bool:
    """Whether the source has an opening bracket right before `span` (`(b(X)).10`)."""
    if span is None or not text:
        return False
    lines = text.lstrip("\ufeff").splitlines()
    row, column = span.line - 1, span.column - 2
    while 0 <= row < len(lines):
        line = lines[row]
        column = min(column, len(line) - 1)
        while column >= 0 and line[column].isspace():
            column -= 1
        if column >= 0:
            return line[column] == "("
        row, column = row - 1, 10 ** 9
    return False


# ---- Prolog control constructs used as events ---------------------------------------------


def _prolog_control(rule: EventRule) -> Iterable[LintWarning]:
    for p in walk_pattern(rule.pattern):
        if isinstance(p, EventAtom) and isinstance(p.term, Compound) and (p.term.name, p.term.arity) in _PROLOG_CONTROL:
            instead = _PROLOG_CONTROL[p.term.name, p.term.arity]
            what = f"'{p.term.name}'"
            hint = {"and": "write 'and' for two events that both occur, 'seq' for one after the other, or "
                           "'P where (C1, C2)' for conditions",
                    "or": "write 'or' for either of two events",
                    "where": "write 'P where (C -> A ; B)' for a condition; a pattern has no if-then-else"}[instead]
            yield LintWarning("prolog-control-in-pattern", p.span,
                              f"{what} inside an event pattern is read as an event named {what}, which never occurs",
                              hint)


# ---- event operators under :- -------------------------------------------------------------


def _event_operators_in_clauses(program) -> Iterable[LintWarning]:
    defined = {key for key in _program_predicates(program.clauses)}
    found = []
    for clause in program.static_clauses:
        body = clause.body
        if body is None:
            continue
        for goal in _goals(body):
            if isinstance(goal, Compound) and goal.arity == 2 and goal.name in EVENT_OPERATORS and \
                    (goal.name, 2) not in defined:
                found.append(LintWarning(
                    "event-operator-in-clause", span_of(goal) or clause.span,
                    f"'{goal.name}' is an event operator, but this clause is a Prolog rule (':-'), which calls "
                    f"{goal.name}/2 instead of matching events",
                    f"an event rule is written with '<-': {write_term(clause.head, 999)} <- "
                    f"{write_term(body, 1199)}."))
                break
    if not found and not program.event_rules:
        for clause in program.static_clauses + program.directives:
            term = clause.term if isinstance(clause, StaticClause) else clause.goal
            hit = next((t for t in walk(term) if isinstance(t, Compound) and t.arity == 2
                        and t.name in EVENT_OPERATORS and (t.name, 2) not in defined), None)
            if hit is not None:
                found.append(LintWarning(
                    "no-event-rules", span_of(hit) or clause.span,
                    f"the program has 0 event rules, but this clause uses the event operator '{hit.name}'",
                    "event rules are written 'Head <- Pattern.'; nothing is detected without one"))
                break
    return found


# ---- head variables that may stay unbound -------------------------------------------------


def _bound(pattern: Pattern) -> Set[str]:
    """The variables every match of `pattern` binds."""
    if isinstance(pattern, EventAtom):
        names = {v.name for v in variables(pattern.term)}
        for t in (pattern.start, pattern.end):
            if t is not None:
                names |= {v.name for v in variables(t)}
        return names
    if isinstance(pattern, Binary):
        if pattern.op == "or":
            return _bound(pattern.left) & _bound(pattern.right)
        if pattern.op == "fnot":
            return _bound(pattern.left)
        return _bound(pattern.left) | _bound(pattern.right)
    if isinstance(pattern, (Where, Check)):
        return _bound(pattern.pattern) | {v.name for v in variables(pattern.condition)}
    if isinstance(pattern, Window):
        return _bound(pattern.pattern)
    if isinstance(pattern, Negation):
        return _bound(pattern.first) | _bound(pattern.second)
    if isinstance(pattern, Absence):
        return _bound(pattern.first)
    if isinstance(pattern, Aggregate):
        return {v.name for v in variables(pattern.value)}
    if isinstance(pattern, Sliding):
        return {v.name for v in variables(pattern.group)} | {v.name for v in variables(pattern.value)}
    return set()


def _where_only(pattern: Pattern, name_: str) -> str:
    """Why variable `name_` is not bound by every match: the construct that hides it."""
    for p in walk_pattern(pattern):
        if isinstance(p, Aggregate) and name_ in _all_variables(p.pattern):
            return "only inside an aggregate (the aggregate binds its value, not the events it counts)"
        if isinstance(p, (Negation, Absence)) and name_ in _all_variables(p.negated):
            return "only in a negated pattern (an event that must not occur binds nothing)"
        if isinstance(p, Binary) and p.op == "fnot" and name_ in _all_variables(p.right):
            return "only in a negated pattern (an event that must not occur binds nothing)"
        if isinstance(p, Binary) and p.op == "or" and (name_ in _bound(p.left)) != (name_ in _bound(p.right)):
            return "in only one branch of 'or' (a match of the other branch leaves it unbound)"
    return "in only part of the pattern"


def _mentioned(pattern: Pattern) -> Set[str]:
    """Every variable a pattern mentions outside negated parts (a join key may be inside an
    aggregate: `a(X) seq aggregate(count, b(X), N)`)."""
    names = _bound(pattern)
    for p in walk_pattern(pattern, into=lambda q: not isinstance(q, (Negation, Absence))):
        if isinstance(p, (Aggregate, Sliding)):
            names |= _all_variables(p.pattern)
    return names


def _all_variables(pattern: Pattern) -> Set[str]:
    names: Set[str] = set()
    for p in walk_pattern(pattern):
        if isinstance(p, EventAtom):
            names |= {v.name for v in variables(p.term)}
    return names


def _unbound_head_variables(rule: EventRule) -> Iterable[LintWarning]:
    if rule.synchronized is not None:
        return
    bound = _bound(rule.pattern)
    for var in variables(rule.head):
        if var.name in bound:
            continue
        yield LintWarning(
            "head-variable-unbound", span_of(var) or rule.span,
            f"variable {var.name} of the rule head is bound {_where_only(rule.pattern, var.name)}; derived events "
            f"would carry an unbound variable",
            f"bind {var.name} in every match: use it in both branches of 'or', or outside the aggregate or "
            "negation, or leave it out of the head")


# ---- joins without a key -----------------------------------------------------------------


def _keyless_joins(rule: EventRule) -> Iterable[LintWarning]:
    related = [{v.name for v in variables(c)} for c in pattern_conditions(rule.pattern)]
    for p in walk_pattern(rule.pattern, into=lambda q: not isinstance(q, (Window, Negation))):
        if not (isinstance(p, Binary) and p.op in JOINS):
            continue
        left, right = _mentioned(p.left), _mentioned(p.right)
        if not left or not right or left & right:
            continue
        if any(names & left and names & right for names in related):
            continue            # a condition relates the two sides (a join on a computed key)
        yield LintWarning(
            "keyless-join", p.span,
            f"the two sides of '{p.op}' share no variable ({pattern_text(p.left)} / {pattern_text(p.right)}) and "
            "no window bounds them: every event of one side is paired with every earlier event of the other, "
            "kept forever, so each event costs more than the one before",
            "use the same variable on both sides for the thing they are about (a(X) seq b(X)), relate them "
            "with a where condition, or bound the pattern with a window: (P).Seconds")


# ---- new_event/1 in an action -------------------------------------------------------------


def _predicate_bodies(program) -> dict:
    """Per predicate of the program, the bodies of its clauses."""
    bodies: dict = {}
    for clause in program.clauses:
        if isinstance(clause, StaticClause):
            key = indicator(clause.head)
            if key is not None:
                bodies.setdefault(key, []).append(clause.body)
    return bodies


def _calls_new_event_1(goal, bodies: dict, seen: Set) -> Optional[Term]:
    """The `new_event/1` call that `goal` makes, itself or through the program's predicates."""
    for g in _goals(goal):
        key = indicator(g)
        if key == ("new_event", 1):
            return g
        if key in bodies and key not in seen:
            seen.add(key)
            for body in bodies[key]:
                if body is not None:
                    found = _calls_new_event_1(body, bodies, seen)
                    if found is not None:
                        return found
    return None


def _new_events_at_the_clock(program) -> Iterable[LintWarning]:
    bodies = _predicate_bodies(program)
    for rule in program.event_rules:
        if rule.action is None:
            continue
        call = _calls_new_event_1(rule.action, bodies, set())
        if call is None:
            continue
        yield LintWarning(
            "new-event-at-the-clock", span_of(call) or span_of(rule.action) or rule.span,
            f"new_event/1 in this action stamps {write_term(call.args[0], 999)} with the clock (the latest event "
            "time processed), not with the time of the match that raised it: a late triggering event gives "
            "its raised event a later time",
            "stamp it with the match's time: bind it with E^T in the pattern and call new_event(Event, T), or "
            "new_event(Event, Sec, NSec) with a ROS stamp")


# ---- a condition whose solutions give the same event ------------------------------------------

#: Builtins that commonly have several solutions (member(X, L) with X unbound, ...).
MULTI_SOLUTION = {("member", 2), ("between", 3), ("select", 3), ("nth0", 3), ("nth1", 3), ("append", 3),
                  ("append", 2), ("sub_atom", 5), ("permutation", 2), ("subtract", 3), ("last", 2),
                  ("clause", 2), ("current_op", 3), ("repeat", 0)}


def _condition_goals(goal):
    """The goals of a condition in order, conjunctions opened; a disjunction stays whole (an
    if-then-else is one goal)."""
    stack = [goal]
    while stack:
        g = stack.pop()
        if isinstance(g, Compound) and g.name == "," and g.arity == 2:
            stack.extend(reversed(g.args))
        else:
            yield g


def _several_solutions(goal, clause_heads: dict) -> Optional[str]:
    if isinstance(goal, Compound) and goal.name in (";", "|") and goal.arity == 2:
        left = goal.args[0]
        if isinstance(left, Compound) and left.name in ("->", "*->") and left.arity == 2:
            return None                             # if-then-else: one branch runs
        return "this disjunction"
    key = indicator(goal)
    if key in MULTI_SOLUTION:
        return f"{key[0]}/{key[1]}"
    heads = [h for h in clause_heads.get(key, []) if _may_match(h, goal)]
    if len(heads) > 1:
        return f"{key[0]}/{key[1]} ({len(heads)} clauses for this call)"
    return None


def _may_match(head, goal) -> bool:
    """False when an argument of the call and of the clause head are different constants
    (first-argument style selection: the clause cannot run for this call)."""
    if not (isinstance(head, Compound) and isinstance(goal, Compound)):
        return True
    for a, b in zip(head.args, goal.args):
        if isinstance(a, Compound) and a.name == "^" and isinstance(b, Compound) and b.name == "^":
            a, b = a.args[0], b.args[0]
        if isinstance(a, Compound) and isinstance(b, Compound):
            if (a.name, a.arity) != (b.name, b.arity) or not _may_match(a, b):
                return False
        elif not isinstance(a, Var) and not isinstance(b, Var) and not isinstance(a, Compound) \
                and not isinstance(b, Compound) and a != b:
            return False
    return True


def _solutions_with_the_same_head(program) -> Iterable[LintWarning]:
    clause_heads: dict = {}
    for clause in program.clauses:
        if isinstance(clause, StaticClause) and indicator(clause.head) is not None:
            clause_heads.setdefault(indicator(clause.head), []).append(clause.head)
    for rule in program.event_rules:
        if rule.synchronized is not None:
            continue
        head = {v.name for v in variables(rule.head)}
        for p in walk_pattern(rule.pattern):
            if not isinstance(p, (Where, Check)):
                continue
            known = _mentioned(p.pattern)
            for goal in _condition_goals(p.condition):
                names = {v.name for v in variables(goal)}
                what = _several_solutions(goal, clause_heads)
                new = {n for n in names - known if not n.startswith("_") or n == "_"}
                if what is not None and not (new & head) and (new or what == "this disjunction"):
                    yield LintWarning(
                        "one-event-per-solution", span_of(goal) or p.span,
                        f"{what} in the condition can hold more than once for one match and binds no variable "
                        f"of the head {write_term(rule.head, 999)}: the rule derives one event per solution, "
                        "so the same event several times",
                        "make the condition hold at most once (once(G), or an if-then-else (C -> true ; D) "
                        "for 'either'), or put the variable it binds into the head")
                known |= names


# ---- a variable met first inside a negation -------------------------------------------------


def _variables_bound_after_negation(program) -> List[LintWarning]:
    found: List[LintWarning] = []
    for clause in program.static_clauses:
        if clause.body is not None:
            found += _negated_then_used(clause.body, {v.name for v in variables(clause.head)}, clause.span)
    for rule in program.event_rules:
        conditions = list(pattern_conditions(rule.pattern))
        events = _all_variables(rule.pattern) | {v.name for v in variables(rule.head)}
        for i, condition in enumerate(conditions):
            others = {v.name for c in conditions[:i] + conditions[i + 1:] for v in variables(c)}
            found += _negated_then_used(condition, events | others, rule.span)
    return found


def _conjuncts(goal):
    while isinstance(goal, Compound) and goal.name == "," and goal.arity == 2:
        yield from _conjuncts(goal.args[0])
        goal = goal.args[1]
    yield goal


def _negated_then_used(body, known: Set[str], fallback: Optional[Span]) -> List[LintWarning]:
    """Variables of a `\\+` in the conjunction `body` that no earlier goal (nor `known`)
    mentions and a later goal uses."""
    goals = list(_conjuncts(body))
    seen = set(known)
    found: List[LintWarning] = []
    for i, goal in enumerate(goals):
        if isinstance(goal, Compound) and goal.name == "\\+" and goal.arity == 1:
            later = set()
            for after in goals[i + 1:]:
                if not (isinstance(after, Compound) and after.name == "\\+" and after.arity == 1):
                    later |= {v.name for v in variables(after)}
            for var in variables(goal.args[0]):
                if var.name in seen or var.name not in later or var.name.startswith("_"):
                    continue
                seen.add(var.name)          # once per variable
                negated = write_term(goal.args[0], 999)
                found.append(LintWarning(
                    "variable-bound-after-negation", span_of(var) or span_of(goal) or fallback,
                    f"variable {var.name} is met first inside \\+ {negated} and used after it: \\+ binds "
                    f"nothing, so this asks whether {negated} holds for any {var.name}, not for the one the "
                    "later goal finds (SWI-Prolog 9.0.4 may also compile such a clause wrongly)",
                    f"put the goal that binds {var.name} before the negation"))
        else:
            seen |= {v.name for v in variables(goal)}
    return found


# ---- predicates that do not exist -------------------------------------------------------


def _undefined_predicates(unit: Unit) -> List[LintWarning]:
    program = unit.program
    target = unit.target
    if not target.builtins:
        return []                               # no list of what exists: nothing to compare with
    if any(_loads_code(d.goal) for d in program.directives):
        return []                               # use_module/consult: the program brings in more
    defined = _program_predicates(program.clauses)
    events = set()
    for rule in program.event_rules:
        if rule.head != Atom("null"):
            events.add(indicator(rule.head))
    found: List[LintWarning] = []
    for rule in program.event_rules:
        checks = {("t1", 1), ("t2", 1)} if any(isinstance(p, Check) for p in walk_pattern(rule.pattern)) else set()
        goals = [(c, "condition") for c in pattern_conditions(rule.pattern)]
        if rule.action is not None:
            goals.append((rule.action, "action"))
        for goal, what in goals:
            for g in _goals(goal):
                key = indicator(g)
                if key is None or key == (":", 2) or key in defined or key in checks or key in events:
                    continue
                if target.known(key):
                    continue
                found.append(LintWarning(
                    "undefined-predicate", span_of(g) or rule.span,
                    f"this {what} calls {key[0]}/{key[1]}, which no clause of the program defines and which is "
                    "not a builtin or library predicate: the run stops with an error at the first event "
                    "that gets here",
                    f"define {key[0]}/{key[1]} in the program (or declare it ':- dynamic {key[0]}/{key[1]}.' if "
                    "it is added while the program runs), or correct the name"))
    return found


# ---- strings in the other mode ---------------------------------------------------------------

#: Declarations whose first argument is a pattern matched against events.
_PATTERN_DECLARATIONS = {("memorize", 5), ("c_mem", 4), ("c_mem", 5), ("subscribe", 5), ("sub", 5),
                         ("subscribe_between", 5)}


def _string_mode(unit: Unit) -> List[LintWarning]:
    patterns = [(p.term, p.span) for rule in unit.program.event_rules for p in walk_pattern(rule.pattern)
                if isinstance(p, EventAtom)]
    patterns += [(d.goal.args[0], d.span) for d in unit.program.declarations + unit.program.directives
                 if isinstance(d.goal, Compound) and (d.goal.name, d.goal.arity) in _PATTERN_DECLARATIONS]
    quoted = unit.settings.ros_strings == "quoted"
    found = []
    for term, fallback in patterns:
        for atom in (_plain_frame_atoms(term) if quoted else _quoted_atoms(term)):
            text = write_term(atom)
            if quoted:
                message = (f"{text} is a plain string, but this program reads ROS strings in the 2015 release's "
                           f"quoted form ({write_term(Atom(chr(34) + atom.name + chr(34)))}): no frame id is "
                           f"ever {text}")
                hint = f"write {write_term(Atom(chr(34) + atom.name + chr(34)))}, or drop ros_strings(quoted)"
            else:
                plain = write_term(Atom(atom.name[1:-1]))
                message = (f"{text} is a string in the 2015 release's quoted form, but this program reads ROS "
                           f"strings as plain atoms ({plain}): no string field of a message is ever {text}")
                hint = f"write {plain}, or add `:- ros_strings(quoted).` for a program written for the release"
            found.append(LintWarning("string-mode", span_of(atom) or fallback, message, hint))
    return found


def _quoted_atoms(term) -> List[Atom]:
    return [t for t in walk(term) if isinstance(t, Atom) and len(t.name) >= 2 and t.name[0] == t.name[-1] == '"']


# Where a message term holds a frame id: the last argument of a header (ROS 1 has a seq
# first), the second of a TransformStamped (its child frame id).
_FRAME_POSITIONS = {("std_msgs__0__Header", 2): 1, ("std_msgs__0__Header", 3): 2,
                    ("geometry_msgs__0__TransformStamped", 3): 1}


def _plain_frame_atoms(term) -> List[Atom]:
    found = []
    for t in walk(term):
        position = _FRAME_POSITIONS.get((t.name, t.arity)) if isinstance(t, Compound) else None
        if position is not None:
            frame = t.args[position]
            if isinstance(frame, Atom) and frame.name != "[]" and not (
                    len(frame.name) >= 2 and frame.name[0] == frame.name[-1] == '"'):
                found.append(frame)
    return found
