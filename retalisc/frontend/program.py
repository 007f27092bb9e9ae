"""The program model: what each clause of a Retalis program is.

A `.rtl` file mixes event rules (`Head <- Pattern`), static rules and facts, directives and
the start-up declarations of the original Retalis (`memorize(...)`, `subscribe(...)`...,
written as facts, as in `goalPredicates.txt`). `build_program` sorts the clauses read by
the parser into these dataclasses; patterns become `Pattern` trees.
"""
from __future__ import annotations

import bisect
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import List, Optional, Tuple, Union

from .errors import RetalisSyntaxError
from .operators import ETALIS_ALIASES
from .parser import ReadClause, read_program
from .terms import Atom, Compound, Number, Span, String, Term, Var, list_items, make_list, span_of, to_prolog
from .writer import write_term


# ---- patterns --------------------------------------------------------------------------

BINARY_OPERATORS = ("seq", "and", "par", "or", "equals", "meets", "during", "starts", "finishes", "fnot")


@dataclass
class EventAtom:
    """An event pattern atom; `start`/`end` name the variables bound by `E^T` / `E^[T1,T2]`."""

    term: Term
    span: Optional[Span] = None
    start: Optional[Term] = None
    end: Optional[Term] = None


@dataclass
class Binary:
    op: str
    left: "Pattern"
    right: "Pattern"
    span: Optional[Span] = None


@dataclass
class Where:
    pattern: "Pattern"
    condition: Term
    span: Optional[Span] = None


@dataclass
class Check:
    """ETALIS `P check C`: like where, and `t1(T)`/`t2(T)` in C name P's start and end."""

    pattern: "Pattern"
    condition: Term
    span: Optional[Span] = None


@dataclass
class Window:
    pattern: "Pattern"
    length: float
    span: Optional[Span] = None


@dataclass
class Negation:
    """`not(negated).[first, second]`, ETALIS `(first seq second) cnot negated`."""

    negated: "Pattern"
    first: "Pattern"
    second: "Pattern"
    span: Optional[Span] = None


@dataclass
class Absence:
    """`not(negated).[first, Duration]`: no `negated` in the Duration seconds after `first` ends
    (decided once the clock has passed that time plus the delay bound)."""

    negated: "Pattern"
    first: "Pattern"
    duration: float
    span: Optional[Span] = None


@dataclass
class Aggregate:
    """ETALIS `aggregate(Function, Pattern, Value)`: Function is count, sum(X), min(X), max(X)."""

    function: Term
    pattern: "Pattern"
    value: Term
    span: Optional[Span] = None
    star: bool = False      # ETALIS `Start seq P star_times`: a count whose value is not used


@dataclass
class Sliding:
    """`sliding(Function, Pattern, Group, Seconds, Value)`: Function (count, sum(X), min(X),
    max(X), avg(X)) of the Pattern matches of each Group that ended in the last Seconds, as it
    changes (also when a match leaves the window)."""

    function: Term
    pattern: "Pattern"
    group: Term
    duration: float
    value: Term
    span: Optional[Span] = None


Pattern = Union[EventAtom, Binary, Where, Check, Window, Negation, Absence, Aggregate, Sliding]

LABEL = re.compile(r"[a-z][A-Za-z0-9_]*")

AGGREGATE_FUNCTIONS = {("count", 0), ("sum", 1), ("min", 1), ("max", 1), ("avg", 1)}


# ---- clauses ---------------------------------------------------------------------------


@dataclass
class EventRule:
    head: Term                      # the derived event atom, or `null` for action-only rules
    pattern: Pattern
    span: Span
    source: str
    label: Optional[str] = None
    action: Optional[Term] = None   # `Head do Action <- Pattern` or `Head <- Pattern do Action`
    properties: dict = field(default_factory=dict)
    synchronized: Optional[Compound] = None   # `synchronized(E, Q, SyncConds)` head
    subrules: List["EventRule"] = field(default_factory=list)   # ETALIS subpatterns `(H <- P)` in the pattern


@dataclass
class StaticClause:
    term: Term
    span: Span
    source: str

    @property
    def head(self) -> Term:
        if isinstance(self.term, Compound) and self.term.name == ":-" and self.term.arity == 2:
            return self.term.args[0]
        return self.term

    @property
    def body(self) -> Optional[Term]:
        if isinstance(self.term, Compound) and self.term.name == ":-" and self.term.arity == 2:
            return self.term.args[1]
        return None


@dataclass
class Directive:
    goal: Term
    span: Span
    source: str
    # set by `loadable`: the directive calls the runtime (`subscribe`, `new_event`, ...), so it
    # runs after the runtime has taken the program in, with the start-up declarations
    after_load: bool = False


@dataclass
class Declaration:
    """A Retalis start-up declaration written as a fact (memorize/5, subscribe/5, c_mem/4,
    sub/5, set_etalis_flag/2, print_trigger/1, event_rule_property/3 ...): run at start."""

    goal: Term
    span: Span
    source: str


Clause = Union[EventRule, StaticClause, Directive, Declaration]


@dataclass
class Program:
    file: str
    clauses: List[Clause]
    text: str = ""
    # the files its includes read, in order, with the text read (the compile cache checks them)
    included: List[Tuple[str, str]] = field(default_factory=list)
    # warnings about how it was read (`file:line:col: warning: ...`), shown by check and compile
    notes: List[str] = field(default_factory=list)
    # it reads its event rules with compile_event_file (the release's two-file form)
    reads_event_file: bool = False

    @property
    def event_rules(self) -> List[EventRule]:
        return [c for c in self.clauses if isinstance(c, EventRule)]

    @property
    def static_clauses(self) -> List[StaticClause]:
        return [c for c in self.clauses if isinstance(c, StaticClause)]

    @property
    def directives(self) -> List[Directive]:
        return [c for c in self.clauses if isinstance(c, Directive)]

    @property
    def declarations(self) -> List[Declaration]:
        return [c for c in self.clauses if isinstance(c, Declaration)]


# Start-up declarations of the original Retalis and of the thesis, by name and arity.
DECLARATIONS = {
    ("memorize", 5), ("delete_memory", 1), ("subscribe", 5), ("delete_subscription", 2),
    ("c_mem", 4), ("d_mem", 1), ("sub", 5), ("unsub", 2), ("subscribe_between", 5),
    ("set_etalis_flag", 2), ("print_trigger", 1), ("event_rule_property", 3),
    ("set_retalis_flag", 2), ("c_mem", 5), ("stream_history", 1), ("stream_history", 3),
    ("max_delay", 2), ("goal_set", 3), ("print_event", 1), ("external_trigger", 1),
    ("ros_strings", 1),
}

DECLARATION_NAMES = {name for name, _ in DECLARATIONS}


# ---- building ---------------------------------------------------------------------------



#: The longest window or absence a pattern may have, in seconds (about 31.7 million years):
#: the runtime adds, doubles and compares them with times as floats, which stay finite.
MAX_SECONDS = 1e15


def _bounded_seconds(value) -> bool:
    """A window length or absence duration: a number from 0 to MAX_SECONDS (not NaN)."""
    return 0 <= value <= MAX_SECONDS

def parse_program(text: str, file: str) -> Program:
    """Read and classify a whole program. Raises RetalisSyntaxError.

    Two forms of the original Retalis are read too: goal lines without a final period, one
    per paragraph (`goalPredicates.txt`), and `compile_event_file(Path)`, which reads the
    clauses of Path (relative to the file that names it) in its place."""
    included: List[Tuple[str, str]] = []
    notes: List[str] = []
    include_names: List[str] = []
    program = build_program(_read_with_includes(text, file, [file], included, notes, include_names), file, text)
    program.included = included
    program.notes = notes
    program.reads_event_file = "compile_event_file" in include_names
    return program


def _read_with_includes(text: str, file: str, loading: List[str],
                        included: List[Tuple[str, str]], notes: List[str],
                        include_names: List[str]) -> List[ReadClause]:
    clauses = []
    for clause in read_goal_lines(text, file):
        path = _included_file(clause.term)
        if path is None:
            clauses.append(clause)
            continue
        include_names.append(_include_name(clause.term))
        target = _resolve_include(path, file)
        beside = _beside(target, file)
        if beside is not None:
            notes.append(f"{clause.span}: warning: {_include_name(clause.term)}: {target} does not exist; reading "
                         f"{beside}, the file of that name beside {file}")
            target = beside
        if str(target) in loading:
            raise RetalisSyntaxError(f"{_include_name(clause.term)}: {path} is already being read (it includes itself)",
                                     clause.span)
        try:
            text_read = target.read_text(encoding="utf-8-sig")
        except (OSError, UnicodeDecodeError) as error:
            reason = error.strerror if isinstance(error, OSError) and error.strerror else str(error)
            raise RetalisSyntaxError(f"{_include_name(clause.term)}: cannot read {path} ({target}): {reason}",
                                     clause.span) from None
        included.append((str(target), text_read))
        clauses.extend(_read_with_includes(text_read, str(target), loading + [str(target)], included, notes,
                                           include_names))
    return clauses


# ETALIS's goals that load a file of rules (events rules, static rules, db/1 facts): read in place.
INCLUDES = ("compile_event_file", "load_static_rules", "load_database")


def _included_file(term: Term) -> Optional[str]:
    """The path of a `compile_event_file(Path)` fact or directive, else None."""
    if _is(term, ":-", 1):
        term = term.args[0]
    if isinstance(term, Compound) and term.arity == 1 and term.name in INCLUDES:
        path = term.args[0]
        if isinstance(path, (Atom, String)):
            return path.name if isinstance(path, Atom) else path.text
        raise RetalisSyntaxError(f"{term.name}(Path) takes a file name", span_of(path))
    return None


def _include_name(term: Term) -> str:
    return (term.args[0] if _is(term, ":-", 1) else term).name


def _resolve_include(path: str, file: str) -> Path:
    return (_directory_of(file) / path) if not Path(path).is_absolute() else Path(path)


def _directory_of(file: str) -> Path:
    return Path(file).parent if file and not file.startswith("<") else Path.cwd()


def _beside(target: Path, file: str) -> Optional[Path]:
    """The Retalis 2015 goal file names its rules by an absolute path on the author's machine
    (`compile_event_file('/home/<user>/catkin_ws/.../eventRules.txt')`): when that path is
    missing, the file of the same name beside the file that names it, if there is one."""
    if not target.is_absolute() or target.exists():
        return None
    beside = _directory_of(file) / target.name
    return beside if beside.is_file() and beside != target else None


# A paragraph: text between blank lines.
_PARAGRAPH_BREAK = re.compile(r"\n(?:[ \t\r]*\n)+")


def read_goal_lines(text: str, file: str) -> List[ReadClause]:
    """`read_program`, reading Retalis's goal files too: a paragraph (text between blank
    lines) whose last line does not end with a full stop ends there, as if it had one. When
    the text has such paragraphs, that reading comes first (`goal(a)` then a paragraph
    `:- directive.` must not read as one clause `goal(a) :- directive`); when it cannot be
    read, the text is read as written (a clause may go on after a blank line), and its
    error stands."""
    completed = complete_paragraphs(text)
    if completed != text:
        try:
            return read_program(completed, file)
        except RetalisSyntaxError:
            pass
    return read_program(text, file)


def complete_paragraphs(text: str) -> str:
    """`text` with " ." after the last token of every paragraph that does not end with a
    full stop (comments after it stay after the added period). Paragraphs are separated by
    blank lines outside quoted items and block comments. Lines and columns of everything
    else stay the same."""
    code, breaks = _scan(text)
    out = []
    position = 0
    for start, end in breaks + [(len(text), len(text))]:
        last = _last_code(code, position, start)
        if last is not None and text[last] != ".":
            out.append(text[position:last + 1] + " ." + text[last + 1:start])
        else:
            out.append(text[position:start])
        out.append(text[start:end])
        position = end
    return "".join(out)


def _last_code(code: List[int], start: int, end: int) -> Optional[int]:
    """The last position in [start, end) that holds code (not layout or a comment)."""
    index = bisect.bisect_left(code, end) - 1
    return code[index] if index >= 0 and code[index] >= start else None


def _scan(text: str):
    """The positions of code characters (not layout, not inside comments; quoted items
    count), in order, and (start, end) of each run of blank lines outside quoted items and
    block comments."""
    code: List[int] = []
    breaks = []
    i, n = 0, len(text)
    quote = None
    while i < n:
        c = text[i]
        if quote is not None:
            code.append(i)
            if c == "\\" and i + 1 < n:
                code.append(i + 1)
                i += 2
            elif c == quote and text.startswith(quote * 2, i):
                code.append(i + 1)
                i += 2
            else:
                quote = None if c == quote else quote
                i += 1
        elif c == "%":
            end = text.find("\n", i)
            i = n if end < 0 else end
        elif text.startswith("/*", i):
            end = text.find("*/", i + 2)
            i = n if end < 0 else end + 2
        elif text.startswith("0'", i) and (i == 0 or not (text[i - 1].isalnum() or text[i - 1] == "_")):
            width = 4 if text[i + 2:i + 3] == "\\" or text.startswith("''", i + 2) else 3     # a character code
            code.extend(range(i, min(i + width, n)))
            i += width
        elif c in "'\"`":
            quote = c
            code.append(i)
            i += 1
        elif c == "\n":
            match = _PARAGRAPH_BREAK.match(text, i)
            if match:
                breaks.append((match.start(), match.end()))
                i = match.end()
            else:
                i += 1
        else:
            if not c.isspace():
                code.append(i)
            i += 1
    return code, breaks



def build_program(clauses: List[ReadClause], file: str, text: str = "") -> Program:
    classified: List[Clause] = []
    for read in clauses:
        clause = classify(read)
        if isinstance(clause, EventRule):
            classified.extend(_with_subrules(clause))
        else:
            classified.append(clause)
    return Program(file, classified, text)


def _with_subrules(rule: EventRule) -> List[EventRule]:
    """The rules of ETALIS subpatterns in `rule`'s pattern (innermost first), then `rule`."""
    out: List[EventRule] = []
    for sub in rule.subrules:
        out.extend(_with_subrules(sub))
    out.append(rule)
    return out


def classify(clause: ReadClause) -> Clause:
    term = clause.term
    if _is(term, ":-", 1) or _is(term, "?-", 1):
        goal = term.args[0]
        if isinstance(goal, (Atom, Compound)) and (goal.name, getattr(goal, "arity", 0)) in DECLARATIONS:
            return Declaration(goal, clause.span, clause.text)     # run at start, like the fact form
        return Directive(goal, clause.span, clause.text)
    if _is(term, "rule:", 2):
        label_term, rule = term.args
        if not _is(rule, "<-", 2):
            raise RetalisSyntaxError("a labelled rule must be an event rule 'Label 'rule:' Head <- Pattern'",
                                     clause.span)
        return _event_rule(rule, clause, label_term)
    if _is(term, "<-", 2):
        head = term.args[0]
        if _is(head, ":", 2) and isinstance(head.args[0], (Atom, Compound)) and not _is(head.args[1], ":", 2):
            return _event_rule(Compound("<-", (head.args[1], term.args[1]), term.span), clause, head.args[0])
        if _is(head, "do", 2) and _is(head.args[0], ":", 2) and isinstance(head.args[0].args[0], (Atom, Compound)):
            # `label : Head do Action <- Pattern` reads as `(label : Head) do Action`: `:` binds tighter
            label_term, event = head.args[0].args
            unlabelled = Compound("do", (event, head.args[1]), head.span)
            return _event_rule(Compound("<-", (unlabelled, term.args[1]), term.span), clause, label_term)
        return _event_rule(term, clause, None)
    if isinstance(term, (Atom, Compound)) and term.name in DECLARATION_NAMES:
        return Declaration(term, clause.span, clause.text)
    if _is(term, "db", 1) and isinstance(term.args[0], (Atom, Compound)) and not _is(term.args[0], ":-", 2):
        # ETALIS's facts of the static database: db(p(1, 2)). is the fact p(1, 2).
        return StaticClause(term.args[0], clause.span, clause.text)
    if isinstance(term, (Var, Number)) or (hasattr(term, "text") and not isinstance(term, (Atom, Compound))):
        raise RetalisSyntaxError("a clause must be a rule, a fact or a directive", clause.span)
    return StaticClause(term, clause.span, clause.text)


def _event_rule(term: Compound, clause: ReadClause, label_term: Optional[Term]) -> EventRule:
    head, body = term.args
    label, properties = _label(label_term, clause.span)
    action = None
    if _is(head, "do", 2):
        head, action = head.args
    if _is(body, "do", 2):
        # ETALIS writes the action after the pattern too: `Head <- Pattern do Action` (its
        # parser gives both forms the same meaning: the action runs when the rule fires)
        if action is not None:
            raise RetalisSyntaxError("a rule has one action: Head do Action <- Pattern or Head <- Pattern do "
                                     "Action, not both", span_of(body) or clause.span)
        body, action = body.args
    head = _strip_time(head)
    if _is(head, ":", 2):
        raise RetalisSyntaxError("the head of an event rule cannot be Module:Event; a label is written "
                                 "'label : Head <- Pattern' with a name as label", span_of(head) or clause.span)
    synchronized = None
    if isinstance(head, Compound) and head.name in ("synchronized", "syncronized") and head.arity == 3:
        synchronized = head
    if not isinstance(head, (Atom, Compound)):
        raise RetalisSyntaxError("the head of an event rule must be an event atom", span_of(head) or clause.span)
    subrules: List[EventRule] = []
    body = _extract_subpatterns(body, clause, subrules)
    pattern = to_pattern(body, clause.span)
    return EventRule(head, pattern, clause.span, clause.text, label, action, properties, synchronized, subrules)


def _extract_subpatterns(term: Term, clause: ReadClause, found: List["EventRule"]) -> Term:
    """ETALIS subpatterns: `a seq (sub1 <- b0(X) seq b1(Y) where X < Y)` defines `sub1` by
    a rule of its own (added to `found`) and uses `sub1` in its place. Only operands of
    event operators are looked at (not the arguments of event atoms or conditions)."""
    if _is(term, "<-", 2):
        rule = _event_rule(term, clause, None)
        found.append(rule)
        return rule.head
    if isinstance(term, Compound) and (term.name in _PATTERN_OPERATORS or term.name == "."):
        count = term.arity if term.name in BINARY_OPERATORS + ("cnot", "star_times", ".") else 1
        if term.name == "." and _is(term.args[0], "not", 1):
            negated = Compound("not", (_extract_subpatterns(term.args[0].args[0], clause, found),), term.args[0].span)
            items = list_items(term.args[1])
            if items is not None:
                return Compound(".", (negated, make_list([_extract_subpatterns(i, clause, found) for i in items])),
                                term.span)
            return term
        args = tuple(_extract_subpatterns(a, clause, found) if i < count else a for i, a in enumerate(term.args))
        return Compound(term.name, args, term.span)
    if _is(term, "aggregate", 3):
        function, pattern, value = term.args
        return Compound("aggregate", (function, _extract_subpatterns(pattern, clause, found), value), term.span)
    return term


# Operators whose operands (the first only for where, check, timestamp, event_multiply) are patterns.
_PATTERN_OPERATORS = set(BINARY_OPERATORS) | {"cnot", "where", "check", "timestamp", "event_multiply",
                                               "star_times"}


def _label(term: Optional[Term], span: Span):
    if term is None:
        return None, {}
    if isinstance(term, Atom):
        return _label_name(term), {}
    if isinstance(term, Compound) and term.arity == 1:
        items = list_items(term.args[0])
        properties = {}
        for item in items or []:
            if _is(item, "property", 2) and isinstance(item.args[0], Atom):
                properties[item.args[0].name] = item.args[1]
            else:
                raise RetalisSyntaxError("rule properties are written [property(Name, Value), ...]",
                                         span_of(item) or span)
        if items is None:
            raise RetalisSyntaxError("rule properties are written [property(Name, Value), ...]", span)
        return _label_name(term), properties
    raise RetalisSyntaxError("a rule label must be a name ([a-z][A-Za-z0-9_]*) or Label([property(Name, Value), "
                             "...])", span_of(term) or span)


def _label_name(term: Union[Atom, Compound]) -> str:
    """A label names the rule's generated predicates (`e_<label>_<n>`) and is the id that
    `del_event_rule/1` takes, so it must be a plain name."""
    if not LABEL.fullmatch(term.name):
        raise RetalisSyntaxError(f"the rule label {term.name!r} must be a name matching [a-z][A-Za-z0-9_]* "
                                 "(it names the rule's generated predicates)", span_of(term))
    return term.name


def _strip_time(head: Term) -> Term:
    if _is(head, "^", 2):
        return head.args[0]
    return head


def to_pattern(term: Term, span: Span) -> Pattern:
    """Turn an event pattern term into a Pattern tree."""
    where = span_of(term) or span
    if isinstance(term, Compound) and term.arity == 2 and term.name in ETALIS_ALIASES:
        term = Compound(ETALIS_ALIASES[term.name], term.args, term.span)     # 'SEQ'(A, B) in functional notation
    if isinstance(term, Compound):
        if (term.name, term.arity) in _NOT_PATTERNS:
            raise RetalisSyntaxError(f"'{term.name}' cannot stand inside a pattern ({_NOT_PATTERNS[term.name, term.arity]})",
                                     where)
        if term.name == "not":
            raise RetalisSyntaxError("negation is written not(N).[P1, P2]: no N between P1 and P2", where)
        if term.arity == 1 and term.name == "prolog":
            raise RetalisSyntaxError("prolog(Goal) is a step of a sequence, after or before a pattern: "
                                     "P seq prolog(Goal) (it means P where Goal)", where)
        if term.arity == 2 and term.name == "seq" and _is(term.args[1], "star_times", 1):
            repeated = to_pattern(term.args[1].args[0], span)
            at = span_of(term.args[1]) or where
            # the count's variable is named by where it is written: the same source gives the
            # same program text whatever was compiled before in the process
            return Binary("seq", to_pattern(term.args[0], span),
                          Aggregate(Atom("count"), repeated, Var(f"StarTimes_{at.line}_{at.column}"), at, True),
                          where)
        if term.arity == 2 and term.name == "seq" and any(_is(side, "prolog", 1) for side in term.args):
            # ETALIS: `P seq prolog(Goal)` (and `prolog(Goal) seq P`) calls Goal when P is detected
            left, right = term.args
            goal, pattern = (right, left) if _is(right, "prolog", 1) else (left, right)
            if _is(pattern, "prolog", 1):
                raise RetalisSyntaxError("prolog(Goal) needs an event pattern beside it: P seq prolog(Goal)", where)
            return Where(to_pattern(pattern, span), goal.args[0], where)
        if term.arity == 2 and term.name in BINARY_OPERATORS:
            return Binary(term.name, to_pattern(term.args[0], span), to_pattern(term.args[1], span), where)
        if term.arity == 2 and term.name == "where":
            return Where(to_pattern(term.args[0], span), term.args[1], where)
        if term.arity == 2 and term.name in ("check", "timestamp"):
            return Check(to_pattern(term.args[0], span), term.args[1], where)
        if term.arity == 2 and term.name == "event_multiply":
            # ETALIS: one event per solution of the static goal, as a where condition gives
            return Where(to_pattern(term.args[0], span), term.args[1], where)
        if term.arity == 1 and term.name == "star_times":
            raise RetalisSyntaxError("star_times repeats a pattern after a start event: Start seq P star_times",
                                     where)
        if term.arity == 2 and term.name == "cnot":
            first = to_pattern(term.args[0], span)
            if not (isinstance(first, Binary) and first.op == "seq"):
                raise RetalisSyntaxError("'cnot' needs a sequence on its left: (A seq B) cnot C", where)
            return Negation(to_pattern(term.args[1], span), first.left, first.right, where)
        if term.arity == 2 and term.name == ".":
            left, right = term.args
            if _is(left, "not", 1):
                items = list_items(right)
                if items is None or len(items) != 2:
                    raise RetalisSyntaxError("negation is written not(P).[P1, P2] or not(P).[P1, Seconds]", where)
                if isinstance(items[1], Number):
                    duration = items[1].value
                    if not _bounded_seconds(duration):
                        raise RetalisSyntaxError("the duration of an absence not(P).[P1, Seconds] must be a "
                                                 f"number of seconds, not negative and at most {MAX_SECONDS:g}",
                                                 span_of(items[1]) or where)
                    return Absence(to_pattern(left.args[0], span), to_pattern(items[0], span), duration, where)
                return Negation(to_pattern(left.args[0], span), to_pattern(items[0], span),
                                to_pattern(items[1], span), where)
            if isinstance(right, Number):
                if not _bounded_seconds(right.value):
                    raise RetalisSyntaxError("a window length must be a number of seconds, not negative and "
                                             f"at most {MAX_SECONDS:g}", where)
                return Window(to_pattern(left, span), right.value, where)
            raise RetalisSyntaxError("'(Pattern).Q' needs a number Q (the window length in seconds)", where)
        if term.arity == 3 and term.name == "aggregate":
            function = term.args[0]
            key = (function.name, getattr(function, "arity", 0)) if isinstance(function, (Atom, Compound)) else None
            if key in AGGREGATE_FUNCTIONS:
                return Aggregate(function, to_pattern(term.args[1], span), term.args[2], where)
            known = ", ".join(f"{n}(X)" if a else n for n, a in sorted(AGGREGATE_FUNCTIONS))
            raise RetalisSyntaxError(f"unknown aggregate function {_function_text(function)} (expected {known})",
                                     span_of(function) or where)
        if term.name == "aggregate":
            raise RetalisSyntaxError("an aggregate is written aggregate(Function, Pattern, Value)", where)
        if term.arity == 5 and term.name == "sliding":
            function, inner, group, duration, value = term.args
            key = (function.name, getattr(function, "arity", 0)) if isinstance(function, (Atom, Compound)) else None
            if key not in AGGREGATE_FUNCTIONS:
                known = ", ".join(f"{n}(X)" if a else n for n, a in sorted(AGGREGATE_FUNCTIONS))
                raise RetalisSyntaxError(f"unknown aggregate function {_function_text(function)} (expected {known})",
                                         span_of(function) or where)
            if not (isinstance(duration, Number) and duration.value == duration.value and duration.value > 0
                    and duration.value != float("inf")):
                raise RetalisSyntaxError("the duration of sliding(F, Pattern, Group, Seconds, Value) must be a "
                                         "positive number of seconds", span_of(duration) or where)
            if not isinstance(value, Var) or value.is_anonymous:
                raise RetalisSyntaxError("the value of sliding(F, Pattern, Group, Seconds, Value) must be a named "
                                         "variable", span_of(value) or where)
            return Sliding(function, to_pattern(inner, span), group, duration.value, value, where)
        if term.name == "sliding":
            raise RetalisSyntaxError("a sliding aggregate is written sliding(Function, Pattern, Group, Seconds, "
                                     "Value)", where)
        if term.arity == 2 and term.name == "^":
            atom = to_pattern(term.args[0], span)
            if not isinstance(atom, EventAtom):
                raise RetalisSyntaxError("'^' attaches a time to an event atom: E^T or E^[T1, T2]", where)
            times = list_items(term.args[1])
            if times is not None and len(times) == 2:
                return EventAtom(atom.term, where, times[0], times[1])
            return EventAtom(atom.term, where, term.args[1], term.args[1])
        return EventAtom(term, where)
    if isinstance(term, Atom):
        if term.name == "not":
            raise RetalisSyntaxError("negation is written not(N).[P1, P2]: no N between P1 and P2", where)
        return EventAtom(term, where)
    if isinstance(term, Var):
        raise RetalisSyntaxError(f"a variable ({term.name}) cannot stand for an event pattern", where)
    raise RetalisSyntaxError(f"{to_prolog(term)} is not an event pattern", where)


# Clause-level operators that cannot be part of a pattern.
_NOT_PATTERNS = {
    ("<-", 2): "an event rule cannot be nested in a pattern; write the inner rule as a rule of its own "
               "and use its head here",
    (":-", 2): "a pattern is not a Prolog clause",
    (":-", 1): "a pattern is not a directive",
    ("?-", 1): "a pattern is not a directive",
    ("-->", 2): "a pattern is not a grammar rule",
    ("do", 2): "an action is written on the head or after the whole pattern: Head do Action <- Pattern or "
               "Head <- Pattern do Action",
    ("rule:", 2): "a rule label is written before the head: label 'rule:' Head <- Pattern",
}


def _function_text(function: Term) -> str:
    return write_term(function, 999)


def _is(term: Term, name: str, arity: int) -> bool:
    return isinstance(term, Compound) and term.name == name and term.arity == arity


def pattern_children(pattern: Pattern) -> list:
    """The direct sub-patterns of a pattern, left to right."""
    if isinstance(pattern, Binary):
        return [pattern.left, pattern.right]
    if isinstance(pattern, (Where, Check, Window, Aggregate)):
        return [pattern.pattern]
    if isinstance(pattern, Negation):
        return [pattern.negated, pattern.first, pattern.second]
    if isinstance(pattern, Absence):
        return [pattern.negated, pattern.first]
    if isinstance(pattern, Sliding):
        return [pattern.pattern]
    return []


def walk_pattern(pattern: Pattern, into=None):
    """A pattern and its sub-patterns, each before its children, left to right, without
    recursion (a chain of 1,500 `seq` steps nests 1,500 deep); `into(p)` false stops the walk
    from entering p's children."""
    stack = [pattern]
    while stack:
        p = stack.pop()
        yield p
        if into is None or into(p):
            stack.extend(reversed(pattern_children(p)))


def pattern_conditions(pattern: Pattern):
    """The conditions (`where`, `check`) of a pattern and its sub-patterns, outermost first."""
    for p in walk_pattern(pattern):
        if isinstance(p, (Where, Check)):
            yield p.condition


# ---- writing patterns back (for dumps and comments in generated code) -----------------


def pattern_text(pattern: Pattern) -> str:
    if isinstance(pattern, EventAtom):
        text = write_term(pattern.term, 1024)
        if pattern.start is not None:
            if pattern.start == pattern.end:
                text += "^" + write_term(pattern.start, 199)
            else:
                text += f"^[{write_term(pattern.start, 999)}, {write_term(pattern.end, 999)}]"
        return text
    if isinstance(pattern, Binary):
        return f"({pattern_text(pattern.left)} {pattern.op} {pattern_text(pattern.right)})"
    if isinstance(pattern, Where):
        return f"({pattern_text(pattern.pattern)} where {write_term(pattern.condition, 1059)})"
    if isinstance(pattern, Check):
        return f"({pattern_text(pattern.pattern)} check {write_term(pattern.condition, 1049)})"
    if isinstance(pattern, Window):
        length = int(pattern.length) if float(pattern.length).is_integer() else pattern.length
        return f"({pattern_text(pattern.pattern)}).{length}"
    if isinstance(pattern, Negation):
        return f"not({pattern_text(pattern.negated)}).[{pattern_text(pattern.first)}, {pattern_text(pattern.second)}]"
    if isinstance(pattern, Absence):
        length = int(pattern.duration) if float(pattern.duration).is_integer() else pattern.duration
        return f"not({pattern_text(pattern.negated)}).[{pattern_text(pattern.first)}, {length}]"
    if isinstance(pattern, Sliding):
        length = int(pattern.duration) if float(pattern.duration).is_integer() else pattern.duration
        return (f"sliding({write_term(pattern.function, 999)}, {pattern_text(pattern.pattern)}, "
                f"{write_term(pattern.group, 999)}, {length}, {write_term(pattern.value, 999)})")
    if isinstance(pattern, Aggregate) and pattern.star:
        return f"{pattern_text(pattern.pattern)} star_times"
    if isinstance(pattern, Aggregate):
        return (f"aggregate({write_term(pattern.function, 999)}, {pattern_text(pattern.pattern)}, "
                f"{write_term(pattern.value, 999)})")
    raise TypeError(pattern)
