"""loadable: the Prolog that the program contributes to the generated module loads in SWI-Prolog.

Static clauses, directives, `where`/`check` conditions and `do` actions are copied into the
generated module as they are written, so what SWI-Prolog would refuse while loading it (or
would accept only by silently changing the meaning of generated code) is an error here, at
its place in the source:

- a clause head that is not an atom or a compound term (`1.`, `X :- a.`), a control
  construct (`(a, b, c).`), a module-qualified head, or a predicate the program may not
  define: a builtin (ISO ones fail to load, others would replace what the generated code
  calls), a `rtl_*` predicate of the runtime (generated code calls them), a predicate of the
  generated code (`Unit.target` lists them; the backend fills it in). The runtime's library
  predicates (`min/3`, `new_event/1`, ...) may be defined: they go to `Unit.runtime_overrides`
  and the generated module does not import the runtime's;
- a goal that is not callable (`foo :- 1.`, `where "s"`, `do 1`);
- a directive that is not a goal (`:- :- G.`), `:- module(...)` (the program is compiled into
  a module of its own), a malformed `op/3`, a declaration (`dynamic`, ...) of a predicate the
  program may not define, and a directive that calls a predicate that does not exist when it
  runs (directives run while the module loads: only builtins, library and runtime
  predicates and the clauses above them exist then; `initialization/1` goals run after the
  whole file);
- a `'.'/2` term outside the window and negation of patterns (SWI-Prolog 7 reads it as a dict
  access);
- a start-up declaration (`c_mem/4`, `sub/5`, ...) with an argument the runtime refuses when
  the program starts, a memory instance or subscription created twice, or one ended that no
  declaration made;
- a step of a rule with more arguments than SWI-Prolog allows a predicate.

Runs after `edbc`, which names the predicates of the generated code.
"""
from __future__ import annotations

from typing import Iterable, Optional, Set, Tuple

from ..frontend.errors import RetalisSemanticError
from ..frontend.operators import OP_TYPES
from ..frontend.program import (Aggregate, Check, Declaration, Directive, EventAtom, EventRule, StaticClause, Where,
                                pattern_conditions, walk_pattern)
from ..frontend.terms import (Atom, Compound, Number, String, Term, Var, indicator, list_items, span_of, to_prolog,
                              walk)
from .unit import TargetPredicates, Unit

name = "loadable"

Indicator = Tuple[str, int]

#: Terms that are not clause heads whatever SWI-Prolog makes of them.
CONTROL_HEADS = {(":-", 1), (":-", 2), ("?-", 1), ("-->", 2), ("|", 2), ("<-", 2), ("rule:", 2),
                 (".", 2)}                            # SWI-Prolog 7: Dict.Key

# What SWI-Prolog's grammar translation refuses as a non-terminal (boot/dcg.pl, dcg_no_extend/1).
_NOT_NONTERMINALS = {("[]", 0), ("[|]", 2), ("{}", 1), ("{}", 0), ("!", 0), ("\\+", 1), (",", 2), (";", 2),
                     ("|", 2), ("->", 2), ("*->", 2), ("-->", 2)}

# Goal arguments of control constructs and of the meta-predicates SWI-Prolog compiles in place
# (or that take a goal written in the clause): the positions that hold goals.
_GOAL_POSITIONS = {
    (",", 2): (0, 1), (";", 2): (0, 1), ("|", 2): (0, 1), ("->", 2): (0, 1), ("*->", 2): (0, 1), ("\\+", 1): (0,),
    ("call", 1): (0,), ("once", 1): (0,), ("ignore", 1): (0,), ("forall", 2): (0, 1),
    ("findall", 3): (1,), ("findall", 4): (1,), ("aggregate_all", 3): (1,), ("aggregate_all", 4): (2,),
    ("catch", 3): (0, 2), ("call_cleanup", 2): (0, 1), ("setup_call_cleanup", 3): (0, 1, 2),
}

# Directives that declare properties of predicates given by indicators.
_DECLARATIONS = {"dynamic", "discontiguous", "multifile", "public", "table", "thread_local",
                 "module_transparent"}

# Directives after which the directive check cannot know what is defined.
_LOADERS = {"use_module", "ensure_loaded", "consult", "include", "load_files", "reexport", "autoload",
            "use_foreign_library"}



#: SWI-Prolog's `max_procedure_arity` flag: a predicate cannot have more arguments.
MAX_PROCEDURE_ARITY = 1024


def run(unit: Unit) -> Unit:
    _check_generated_arities(unit)
    target = unit.target
    generated = frozenset(_generated_predicates(unit)) | target.generated
    reserved = _Reserved(target, generated)
    defined: Set[Indicator] = set()
    everything = _program_predicates(unit.program.clauses)      # what initialization/1 goals can call
    loaders_seen = False
    start_up = _StartUp()
    runtime_callers = _runtime_callers(unit.program.clauses, target)
    deferring = False
    for clause in unit.program.clauses:
        _check_no_dots(clause)
        if isinstance(clause, StaticClause):
            key = _check_clause(clause, reserved)
            if key is not None:
                defined.add(key)
                _note_override(unit, key)
        elif isinstance(clause, Directive):
            _check_directive_goal(clause.goal, clause.span)
            for key in _declared(clause.goal, clause.span, reserved):
                defined.add(key)
                _note_override(unit, key)
            # once a directive waits for the runtime, the later ones wait too (program order),
            # except those the load itself needs (op/3, dynamic/1, use_module/1, ...)
            clause.after_load = _calls_runtime(clause.goal, target, runtime_callers) or \
                (deferring and not _needed_by_the_load(clause.goal))
            deferring = deferring or clause.after_load
            if not loaders_seen and target.builtins:
                # a directive that runs after the load sees every clause of the program
                _check_calls_exist(clause.goal, everything if clause.after_load else defined, everything,
                                   target, clause.span)
            loaders_seen = loaders_seen or _loads_code(clause.goal)
        elif isinstance(clause, Declaration):
            _check_directive_goal(clause.goal, clause.span)
            _check_declaration_arguments(clause.goal, clause.span)
            start_up.declare(clause.goal, clause.span)
        elif isinstance(clause, EventRule):
            for condition in pattern_conditions(clause.pattern):
                _check_callable(condition, clause.span, "a condition")
            if clause.action is not None:
                _check_callable(clause.action, clause.span, "an action")
    return unit


def _check_no_dots(clause) -> None:
    """SWI-Prolog 7 reads a `'.'/2` term in a clause as a dict access (`Dict.Key`), which fails
    or raises when the clause runs: outside the window `(P).Q` and negation `not(N).[P1, P2]`
    of patterns, a `.` is an error."""
    if isinstance(clause, EventRule):
        terms = [clause.head] + ([clause.action] if clause.action is not None else [])
        for p in walk_pattern(clause.pattern):
            if isinstance(p, EventAtom):
                terms += [t for t in (p.term, p.start, p.end) if t is not None]
            elif isinstance(p, (Where, Check)):
                terms.append(p.condition)
            elif isinstance(p, Aggregate):
                terms += [p.function, p.value]
    else:
        terms = [clause.term if isinstance(clause, StaticClause) else clause.goal]
    for term in terms:
        for t in walk(term):
            if isinstance(t, Compound) and t.name == "." and t.arity == 2:
                raise RetalisSemanticError(
                    "'.' cannot stand here: SWI-Prolog would read Term.Key as a dict access (a window is "
                    "written (Pattern).Seconds, a negation not(N).[P1, P2]; end a clause with '. ')",
                    span_of(t) or clause.span)


class _StartUp:
    """What the start-up declarations create, in order: a memory instance (by id) or a
    subscription (by consumer and id) created twice, or a subscription ended or deleted that no
    declaration above made, fails when the program starts."""

    def __init__(self):
        self.memories: dict = {}
        self.subscriptions: dict = {}

    def declare(self, goal: Term, span) -> None:
        key = indicator(goal) if isinstance(goal, (Atom, Compound)) else None
        if key in (("c_mem", 4), ("c_mem", 5), ("memorize", 5)):
            memory_id = goal.args[3] if key[0] == "memorize" else goal.args[0]
            first = self.memories.get(memory_id)
            if first is not None:
                raise RetalisSemanticError(f"a memory instance {to_prolog(memory_id)} is already created at line "
                                           f"{first.line} (d_mem/1 deletes one)", span_of(memory_id) or span)
            self.memories[memory_id] = span
        elif key in (("d_mem", 1), ("delete_memory", 1)):
            self._forget(self.memories, goal.args[0])
        elif key in (("sub", 5), ("subscribe", 5)):
            sub_id, consumer = (goal.args[0], goal.args[1]) if key[0] == "sub" else (goal.args[4], goal.args[3])
            if isinstance(sub_id, Var):
                return                                  # a fresh id
            ident = (_text(consumer), sub_id)
            first = self.subscriptions.get(ident)
            if first is not None:
                raise RetalisSemanticError(f"subscription {to_prolog(sub_id)} of {ident[0]} is already made at line "
                                           f"{first.line}", span_of(sub_id) or span)
            self.subscriptions[ident] = span
        elif key == ("unsub", 2):
            sub_id = goal.args[0]
            if not any(made_id == sub_id for _, made_id in self.subscriptions):
                raise RetalisSemanticError(f"unsub: no declaration above makes a subscription {to_prolog(sub_id)}",
                                           span_of(sub_id) or span)
        elif key == ("delete_subscription", 2):
            consumer, sub_id = goal.args
            if isinstance(consumer, Var) or any(isinstance(t, Var) for t in walk(sub_id)):
                return
            if self.subscriptions.pop((_text(consumer), sub_id), None) is None:
                raise RetalisSemanticError(f"delete_subscription: no declaration above makes a subscription "
                                           f"{to_prolog(sub_id)} of {_text(consumer)}", span_of(sub_id) or span)

    @staticmethod
    def _forget(made: dict, pattern: Term) -> None:
        if any(isinstance(t, Var) for t in walk(pattern)):
            made.clear()
        else:
            made.pop(pattern, None)


def _text(term: Term) -> str:
    if isinstance(term, Atom):
        return term.name
    if isinstance(term, String):
        return term.text
    return to_prolog(term)


def _note_override(unit: Unit, key: Indicator) -> None:
    """A program may define its own `min/3`, `new_event/1`, ... (not the `rtl_*` predicates the
    generated code calls): the generated module then does not import the runtime's."""
    if key in unit.target.runtime and key not in unit.runtime_overrides:
        unit.runtime_overrides.append(key)


def _check_generated_arities(unit: Unit) -> None:
    for rule in unit.generated or []:
        widest = max((arity for _, arity in _rule_predicates(rule)), default=0)
        if widest > MAX_PROCEDURE_ARITY:
            source = next(r.rule for r in unit.rules if r.rule_id == rule.rule_id)
            raise RetalisSemanticError(
                f"this rule needs a step predicate with {widest} arguments, and SWI-Prolog allows at most "
                f"{MAX_PROCEDURE_ARITY}: split the pattern into several rules (each carries fewer variables)",
                source.span)


def _generated_predicates(unit: Unit) -> Iterable[Indicator]:
    for rule in unit.generated or []:
        yield from _rule_predicates(rule)


def _rule_predicates(rule) -> Iterable[Indicator]:
    for clause in rule.clauses + rule.triggers:
        head = clause.args[0] if isinstance(clause, Compound) and clause.name == ":-" and clause.arity == 2 \
            else clause
        key = indicator(head)
        if key is not None:
            yield key
    for store_name, arity, _ in rule.stores:
        yield (store_name, arity)


class _Reserved:
    """Why the program may not define a predicate."""

    def __init__(self, target: TargetPredicates, generated: frozenset):
        self.target = target
        self.generated = generated

    def why(self, key: Indicator) -> Optional[str]:
        if key in CONTROL_HEADS:
            return "it is not a predicate a program can define"
        if key in self.target.builtins or key[0].startswith("$"):
            return "it is a builtin predicate of SWI-Prolog"
        module = self.target.runtime.get(key)
        if module is not None and key[0].startswith("rtl_"):
            return f"it is a predicate of the Retalis runtime (module {module})"
        if key in self.generated:
            return "it is a predicate of the code generated for the event rules"
        return None


def _check_clause(clause: StaticClause, reserved: _Reserved) -> Optional[Indicator]:
    term = clause.term
    if isinstance(term, Compound) and term.name == "-->" and term.arity == 2:
        head, body = term.args
        if isinstance(head, Compound) and head.name == "," and head.arity == 2:
            head = head.args[0]                       # Head, PushBack --> Body
        if indicator(head) in _NOT_NONTERMINALS:
            raise RetalisSemanticError("the head of a grammar rule must be a non-terminal, not a list, "
                                       "{...}, ! or a control construct", span_of(head) or clause.span)
        key = _check_head(head, clause, reserved, extra=2)
        _check_grammar_body(body, clause)
        return key
    key = _check_head(clause.head, clause, reserved)
    if clause.body is not None:
        _check_callable(clause.body, clause.span, "a clause body")
    return key


def _check_head(head: Term, clause: StaticClause, reserved: _Reserved, extra: int = 0) -> Indicator:
    where = span_of(head) or clause.span
    if isinstance(head, Var):
        raise RetalisSemanticError(f"the head of a clause cannot be a variable ({head.name})", where)
    if not isinstance(head, (Atom, Compound)):
        raise RetalisSemanticError("the head of a clause must be an atom or a compound term", where)
    if isinstance(head, Compound) and head.name == ":" and head.arity == 2:
        raise RetalisSemanticError("a program cannot define clauses of another module (Module:Head)", where)
    key = (head.name, (head.arity if isinstance(head, Compound) else 0) + extra)
    if key == (":", 2):                               # `: --> ...` would define Module:Head
        raise RetalisSemanticError("a program cannot define clauses of another module (Module:Head)", where)
    reason = reserved.why(key)
    if reason is not None:
        raise RetalisSemanticError(f"cannot define {key[0]}/{key[1]}: {reason}", where)
    return key


def _goals(goal: Term):
    """The goals of `goal` that are called, looking through control constructs."""
    stack = [goal]
    while stack:
        g = stack.pop()
        key = indicator(g)
        positions = _GOAL_POSITIONS.get(key) if key is not None else None
        if positions is None:
            yield g
        else:
            stack.extend(g.args[i] for i in reversed(positions))


# Clause-level operators: as goals they are a misplaced rule, clause or directive.
_CLAUSE_OPERATORS = {("<-", 2): "an event rule", (":-", 2): "a clause", (":-", 1): "a directive",
                     ("?-", 1): "a directive", ("-->", 2): "a grammar rule", ("rule:", 2): "a labelled rule"}


def _check_callable(goal: Term, fallback, what: str) -> None:
    for g in _goals(goal):
        clause_kind = _CLAUSE_OPERATORS.get(indicator(g)) if isinstance(g, Compound) else None
        if clause_kind is not None:
            raise RetalisSemanticError(f"{what} contains '{g.name}': {clause_kind} cannot stand inside a goal",
                                       span_of(g) or fallback)
        if isinstance(g, (Number, String)):
            shown = g.text if isinstance(g, String) else g.value
            raise RetalisSemanticError(f"{what} calls {shown!r}, which is not a goal (not callable)",
                                       span_of(g) or fallback)
        if isinstance(g, Compound) and g.name == ":" and g.arity == 2:
            if not isinstance(g.args[0], (Atom, Var)):
                raise RetalisSemanticError(f"{what} calls Module:Goal with a module that is not an atom",
                                           span_of(g.args[0]) or span_of(g) or fallback)
            _check_callable(g.args[1], span_of(g) or fallback, what)


def _check_grammar_body(body: Term, clause: StaticClause) -> None:
    stack = [body]
    while stack:
        b = stack.pop()
        if isinstance(b, Compound) and (b.name, b.arity) in ((",", 2), (";", 2), ("|", 2), ("->", 2)):
            stack.extend(b.args)
        elif isinstance(b, Compound) and (b.name, b.arity) == ("\\+", 1):
            stack.append(b.args[0])
        elif isinstance(b, Compound) and (b.name, b.arity) == ("{}", 1):
            _check_callable(b.args[0], clause.span, "a grammar rule")
        elif isinstance(b, Compound) and (b.name, b.arity) == (":", 2):
            if not isinstance(b.args[0], (Atom, Var)):
                raise RetalisSemanticError("a grammar rule calls Module:NonTerminal with a module that is not an "
                                           "atom", span_of(b.args[0]) or clause.span)
            stack.append(b.args[1])
        elif isinstance(b, Number):
            raise RetalisSemanticError(f"a grammar rule body cannot contain the number {b.value}",
                                       span_of(b) or clause.span)


def _check_directive_goal(goal: Term, span) -> None:
    where = span_of(goal) or span
    if isinstance(goal, Var):
        raise RetalisSemanticError(f"a directive must be a goal, not a variable ({goal.name})", where)
    for g in _goals(goal):
        key = indicator(g)
        if key in ((":-", 1), (":-", 2), ("?-", 1), ("-->", 2), ("<-", 2), ("rule:", 2)):
            raise RetalisSemanticError(f"'{key[0]}' inside a directive: a directive is written ':- Goal.'",
                                       span_of(g) or where)
        if key is not None and key[0] == "module" and key[1] in (1, 2):
            raise RetalisSemanticError("a program cannot declare a module: retalisc compiles it into a module "
                                       "of its own (remove the module/2 directive)", span_of(g) or where)
        if key == ("op", 3):
            _check_op(g, span)
    _check_callable(goal, where, "a directive")


def _check_op(goal: Compound, span) -> None:
    priority, kind, names = goal.args
    if not (isinstance(priority, Number) and isinstance(priority.value, int) and 0 <= priority.value <= 1200):
        raise RetalisSemanticError("op/3: the priority must be an integer from 0 to 1200",
                                   span_of(priority) or span)
    if not (isinstance(kind, Atom) and kind.name in OP_TYPES):
        raise RetalisSemanticError(f"op/3: the type must be one of {', '.join(OP_TYPES)}", span_of(kind) or span)
    items = list_items(names)
    for item in [names] if items is None else items:
        if not isinstance(item, Atom):
            raise RetalisSemanticError("op/3: the operator must be an atom or a list of atoms",
                                       span_of(item) or span)
        if item.name in (",", "[]", "{}", "|") or item.name in ("rule:", "<-"):
            raise RetalisSemanticError(f"op/3: the operator '{item.name}' cannot be changed",
                                       span_of(item) or span)


# The start-up declarations the runtime runs when the program is loaded, with what each
# argument must be (the runtime's own checks, rtl_slr.pl, rtl_subscriptions.pl, rtl_sync.pl).
_DECLARATION_ARGUMENTS = {
    ("c_mem", 4): ("ground", "memory_query", "size", "limit"),
    ("c_mem", 5): ("ground", "memory_query", "size", "limit", "list"),
    ("memorize", 5): ("callable", "goals", "any", "ground", "size"),
    ("stream_history", 1): ("type",),
    ("stream_history", 3): ("type", "size", "limit"),
    ("subscribe", 5): ("callable", "goals", "any", "consumer", "id"),
    ("sub", 5): ("id", "consumer", "query", "any", "time"),
    ("subscribe_between", 5): ("consumer", "query", "any", "time", "time"),
    ("unsub", 2): ("ground", "time"),
    ("max_delay", 2): ("type", "delay"),
}

_ARGUMENT_KINDS = {
    "ground": "a ground term (no variables)",
    "query": "an event atom, or Event-[Goal, ...]",
    "memory_query": "an event atom, or Event-[Goal, ...]",
    "size": "a positive integer or inf",
    "limit": "a number of seconds >= 0 or inf",
    "list": "a list",
    "goals": "a list of goals",
    "callable": "an event atom",
    "consumer": "an atom (the consumer)",
    "id": "a variable or a ground term",
    "time": "now, inf, -inf, a number of seconds, [Secs, NSecs] or datime/7",
    "type": "Name/Arity",
    "delay": "a number of seconds >= 0 or learn",
}


def _check_declaration_arguments(goal: Term, span) -> None:
    kinds = _DECLARATION_ARGUMENTS.get(indicator(goal)) if isinstance(goal, Compound) else None
    for position, (kind, arg) in enumerate(zip(kinds or (), getattr(goal, "args", ())), start=1):
        if not _argument_fits(kind, arg):
            raise RetalisSemanticError(f"{goal.name}/{goal.arity}: argument {position} must be "
                                       f"{_ARGUMENT_KINDS[kind]}", span_of(arg) or span)


def _argument_fits(kind: str, arg: Term) -> bool:
    if kind == "any":
        return True
    if kind in ("ground", "id"):
        return (kind == "id" and isinstance(arg, Var)) or not any(isinstance(t, Var) for t in walk(arg))
    if kind in ("callable", "consumer"):
        return isinstance(arg, Atom) or (kind == "callable" and isinstance(arg, Compound)) or \
            (kind == "consumer" and isinstance(arg, String))
    if kind in ("list", "goals"):
        items = list_items(arg)
        return items is not None and (kind == "list" or all(isinstance(i, (Atom, Compound, Var)) for i in items))
    if kind in ("query", "memory_query"):
        # a memory query splits every Event-Conds; a subscription only when Conds is a list
        if isinstance(arg, Compound) and arg.name == "-" and arg.arity == 2 and \
                (kind == "memory_query" or list_items(arg.args[1]) is not None):
            return _argument_fits("callable", arg.args[0]) and _argument_fits("goals", arg.args[1])
        return _argument_fits("callable", arg)
    if kind == "size":
        return arg == Atom("inf") or (isinstance(arg, Number) and isinstance(arg.value, int) and arg.value >= 1)
    if kind in ("limit", "delay"):
        if arg == Atom("inf" if kind == "limit" else "learn"):
            return True
        return isinstance(arg, Number) and arg.value == arg.value and arg.value >= 0 and \
            (kind == "limit" or arg.value != float("inf"))
    if kind == "type":
        return _is_indicator(arg) and arg.name == "/"
    if kind == "time":
        if arg in (Atom("now"), Atom("inf")) or (isinstance(arg, Compound) and arg.name == "datime" and arg.arity == 7):
            return True
        if isinstance(arg, Compound) and arg.name == "-" and arg.arity == 1 and arg.args[0] == Atom("inf"):
            return True
        if isinstance(arg, Number):
            return arg.value == arg.value
        items = list_items(arg)
        return items is not None and len(items) == 2 and all(isinstance(i, Number) and isinstance(i.value, int)
                                                             for i in items)
    raise AssertionError(kind)


def _declared(goal: Term, span, reserved: _Reserved) -> Set[Indicator]:
    """Predicates a `dynamic`/`discontiguous`/... directive declares (checked: each is written
    Name/Arity, and the program must be allowed to define it)."""
    found: Set[Indicator] = set()
    for g in _goals(goal):
        if isinstance(g, Compound) and g.name in _DECLARATIONS and g.arity == 1:
            for key, where in _indicators(g.args[0], g.name == "table"):
                if key is None:
                    raise RetalisSemanticError(f"{g.name} takes predicate indicators Name/Arity (or a list of them)",
                                               where or span_of(g) or span)
                if key[0] == ":":
                    continue                            # Module:Name/Arity: another module's business
                reason = reserved.why(key)
                if reason is not None:
                    raise RetalisSemanticError(f"cannot declare {g.name} {key[0]}/{key[1]}: {reason}",
                                               where or span)
                found.add(key)
    return found


def _indicators(spec: Term, heads: bool = False):
    """(indicator or None when malformed, span) for each `Name/Arity` (or `Name//Arity`) of a
    declaration argument; with `heads` (table/1) a term such as `path(_, _, min)` counts too."""
    stack = [spec]
    while stack:
        spec = stack.pop()
        if isinstance(spec, Compound) and spec.name == "as" and spec.arity == 2:
            stack.append(spec.args[0])
            continue
        items = list_items(spec)
        if items is not None:
            stack.extend(reversed(items))
            continue
        if isinstance(spec, Compound) and spec.name == "," and spec.arity == 2:
            stack.extend(reversed(spec.args))
            continue
        if (isinstance(spec, Compound) and spec.name == ":" and spec.arity == 2 and isinstance(spec.args[0], Atom)
                and _is_indicator(spec.args[1])):
            yield (":", 2), span_of(spec)
        elif _is_indicator(spec):
            arity = spec.args[1].value + (2 if spec.name == "//" else 0)
            yield (spec.args[0].name, arity), span_of(spec)
        elif heads and isinstance(spec, (Atom, Compound)) and spec.name not in ("/", "//"):
            yield indicator(spec), span_of(spec)
        else:
            yield None, span_of(spec)


def _is_indicator(spec: Term) -> bool:
    return (isinstance(spec, Compound) and spec.name in ("/", "//") and spec.arity == 2
            and isinstance(spec.args[0], Atom) and isinstance(spec.args[1], Number)
            and isinstance(spec.args[1].value, int) and 0 <= spec.args[1].value <= 1024)


def _program_predicates(clauses) -> Set[Indicator]:
    """Every predicate the program's clauses define or its directives declare."""
    found: Set[Indicator] = set()
    for clause in clauses:
        if isinstance(clause, StaticClause):
            head = clause.head
            extra = 0
            if isinstance(clause.term, Compound) and clause.term.name == "-->" and clause.term.arity == 2:
                head, extra = clause.term.args[0], 2
                if isinstance(head, Compound) and head.name == "," and head.arity == 2:
                    head = head.args[0]
            key = indicator(head)
            if key is not None:
                found.add((key[0], key[1] + extra))
        elif isinstance(clause, Directive):
            for g in _goals(clause.goal):
                if isinstance(g, Compound) and g.name in _DECLARATIONS and g.arity == 1:
                    found.update(key for key, _ in _indicators(g.args[0], g.name == "table") if key is not None)
    return found


def _check_calls_exist(goal: Term, defined: Set[Indicator], everything: Set[Indicator], target: TargetPredicates,
                       span) -> None:
    for g in _goals(goal):
        key = indicator(g)
        if key is None or (key[0] == ":" and key[1] == 2):
            continue
        if key in (("initialization", 1), ("initialization", 2)):
            # runs when the whole file is loaded: any clause of the program exists by then
            _check_calls_exist(g.args[0], everything, everything, target, span)
            continue
        if key in defined or target.known(key):
            continue
        raise RetalisSemanticError(
            f"this directive calls {key[0]}/{key[1]}, which does not exist when it runs (a directive runs "
            "while the program loads: it can call builtins, library and runtime predicates and the "
            "clauses above it)", span_of(g) or span)


def _calls_runtime(goal: Term, target: TargetPredicates, callers: Set[Indicator] = frozenset()) -> bool:
    """Whether a directive calls a predicate of the runtime (`:- subscribe(...), ...`,
    `:- initialization(sub(...))`), directly or through the program's own predicates
    (`callers`): such a directive runs after the runtime has taken the program in
    (`rtl_program_loaded/1`), in program order with the start-up declarations."""
    for g in _goals(goal):
        key = indicator(g)
        if key == ("initialization", 1):
            if _calls_runtime(g.args[0], target, callers):
                return True
        elif key is not None and (key in target.runtime or key in callers):
            return True
    return False


def _runtime_callers(clauses, target: TargetPredicates) -> Set[Indicator]:
    """The program's predicates whose clauses call the runtime, directly or through others."""
    calls = {}
    for clause in clauses:
        if isinstance(clause, StaticClause):
            key = indicator(clause.head)
            if key is not None and clause.body is not None:
                calls.setdefault(key, set()).update(k for k in map(indicator, _goals(clause.body)) if k is not None)
    found: Set[Indicator] = set()
    changed = True
    while changed:
        changed = False
        for key, called in calls.items():
            if key not in found and any(k in target.runtime or k in found for k in called):
                found.add(key)
                changed = True
    return found


# Directives the load of the generated file itself needs where they stand.
_LOAD_TIME = _DECLARATIONS | _LOADERS | {"op", "set_prolog_flag", "style_check", "encoding", "meta_predicate",
                                         "license", "module"}


def _needed_by_the_load(goal: Term) -> bool:
    return all(isinstance(g, (Atom, Compound)) and g.name in _LOAD_TIME for g in _goals(goal))


def _loads_code(goal: Term) -> bool:
    return any(isinstance(g, (Atom, Compound)) and g.name in _LOADERS for g in _goals(goal))
