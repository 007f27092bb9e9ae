"""The Prolog backend: renders a compiled event unit as one SWI-Prolog module, or as the
clauses of rules to add to a running program.

Layout lives in `templates/program.pl.j2` and `templates/added_rules.pl.j2`; this module only
turns terms into text: each clause is written with operators, one body goal a line, an
if-then-else in the usual Prolog layout and any longer term broken over lines within
`frontend.writer.WIDTH` columns (`layout_term`), so a user debugging a rule recognises it.
"""
from __future__ import annotations

from pathlib import Path
from typing import List, Tuple

import jinja2

from ...frontend.program import Declaration, Directive, StaticClause
from ...frontend.terms import Atom, Compound, Term, Var, conjuncts, quote_atom
from ...frontend.writer import layout_term
from ...frontend.writer import write_term as _write_term
from ...passes.unit import GeneratedRule, Unit
from ...runtime_location import runtime_dir

def write_term(term: Term, max_priority: int = 1200) -> str:
    """A term as generated code writes it: the event operators (`seq`, `where`, `<-`, ...) in
    functional notation, since the runtime module does not declare them as operators."""
    return _write_term(term, max_priority, event_operators=False)


_ENV = jinja2.Environment(
    loader=jinja2.FileSystemLoader(str(Path(__file__).with_name("templates"))),
    keep_trailing_newline=True,
    undefined=jinja2.StrictUndefined,
)

#: The heading of the program's own clauses in templates/program.pl.j2.
_STATIC_HEADING = "% ---- Static rules and facts"

# Directives that only configure the compiler: they are compiled, not copied.
_COMPILED_DIRECTIVES = {("set_etalis_flag", 2), ("set_retalis_flag", 2), ("print_trigger", 1), ("print_event", 1),
                        ("external_trigger", 1), ("ros_strings", 1),
                        ("event_rule_property", 3), ("op", 3)}


def render_program(unit: Unit, output_name: str = "PROGRAM.pl") -> str:
    stores = sorted({(name, arity) for g in unit.generated for name, arity, _ in g.stores}
                    | {(k, arity) for g in unit.generated for _, arity, a, b, _ in g.kept for k in (a, b)}
                    | {(k, arity) for g in unit.generated for _, arity, a, b in g.records for k in (a, b)})
    windowed = sorted({(name, arity, _number_text(window))
                       for g in unit.generated for name, arity, window in g.stores if window is not None})
    records = sorted({(quote_atom(name), arity, quote_atom(a), quote_atom(b))
                      for g in unit.generated for name, arity, a, b in g.records})
    kept = sorted({(quote_atom(live), quote_atom(a), quote_atom(b), order)
                   for g in unit.generated for live, _, a, b, order in g.kept})
    printed = None
    if unit.settings.printed is not None:
        printed = [_printed_clause(spec) for spec in unit.settings.printed]
    template = _ENV.get_template("program.pl.j2")
    return template.render(
        source_file=unit.program.file,
        output_name=output_name,
        module=quote_atom(unit.module),
        runtime_dir=quote_atom(str(runtime_dir())),
        stores=stores,
        windowed_stores=windowed,
        record_stores=records,
        kept_stores=kept,
        printed=printed,
        ros_strings=unit.settings.ros_strings,
        static_clauses=[_static_text(c) for c in unit.program.clauses if _is_copied(c)],
        declarations=[_start_up_text(c) for c in unit.program.clauses
                      if (isinstance(c, Declaration) and _declaration_key(c.goal) not in _COMPILED_DIRECTIVES)
                      or (isinstance(c, Directive) and c.after_load)],
        rules=[_RuleView(g) for g in unit.generated],
        runtime_overrides=[f"{quote_atom(name)}/{arity}" for name, arity in unit.runtime_overrides],
    )


def copied_clause_lines(unit: Unit, prolog: str) -> List[Tuple[int, int, object]]:
    """(first line, last line, clause) of each clause of the program copied into `prolog`, the
    text `render_program(unit)` made: where SWI-Prolog's messages about the generated file
    point back to in the source."""
    found = []
    at = prolog.find(_STATIC_HEADING)
    for clause in unit.program.clauses:
        if not _is_copied(clause) or at < 0:
            continue
        text = _static_text(clause)
        start = prolog.find(text, at)
        if start < 0:
            continue
        first = prolog.count("\n", 0, start) + 1
        found.append((first, first + text.count("\n"), clause))
        at = start + len(text)
    return found


def render_added_rules(unit: Unit) -> str:
    """The rules of `unit` for a running program (see `retalisc/runtime_rules.py`): each rule's
    comment, its `'$rtl_rule'(Id, [store(Name, Arity, Window), ...]).` marker, its clauses."""
    rules = []
    for generated in unit.generated:
        stores = ", ".join([f"store({quote_atom(name)}, {arity}, {_window_text(window)})"
                            for name, arity, window in generated.stores]
                           + [f"record({quote_atom(name)}, {arity}, {quote_atom(a)}, {quote_atom(b)})"
                              for name, arity, a, b in generated.records]
                           + [f"kept({quote_atom(live)}, {arity}, {quote_atom(a)}, {quote_atom(b)}, {order})"
                              for live, arity, a, b, order in generated.kept])
        rules.append({"view": _RuleView(generated), "id": quote_atom(generated.rule_id), "stores": stores})
    return _ENV.get_template("added_rules.pl.j2").render(rules=rules)


def render_rule(rule: GeneratedRule) -> str:
    view = _RuleView(rule)
    return "\n".join([f"% {line}" for line in view.comment_lines] + view.clause_texts)


class _RuleView:
    def __init__(self, rule: GeneratedRule):
        self.rule_id = rule.rule_id
        self.comment_lines = rule.comment.splitlines()
        self.clause_texts = [write_clause(c) for c in rule.triggers + rule.clauses]


def _declaration_key(goal: Term):
    return (goal.name, getattr(goal, "arity", 0)) if isinstance(goal, (Atom, Compound)) else None


def _start_up_text(clause) -> str:
    """A start-up declaration, or `'$directive'(Where, Goal)` for a directive that calls the
    runtime (run after the load, reported at Where when it fails or raises)."""
    if isinstance(clause, Declaration):
        return _declaration_text(clause.goal)
    goal = clause.goal
    if isinstance(goal, Compound) and goal.name == "initialization" and goal.arity == 1:
        goal = goal.args[0]                 # it runs after the load anyway
    where = Atom(f"{clause.span.file}:{clause.span.line}")
    return _declaration_text(Compound("$directive", (where, goal)))


def _declaration_text(goal: Term) -> str:
    """The argument of an `ele_declaration(...).` line of templates/program.pl.j2."""
    return layout_term(goal, 999, column=len("ele_declaration("), trailing=len(")."), event_operators=False)


def _is_copied(clause) -> bool:
    if isinstance(clause, StaticClause):
        return True
    if isinstance(clause, Directive):
        if clause.after_load:
            return False
        goal = clause.goal
        key = (goal.name, getattr(goal, "arity", 0)) if isinstance(goal, (Atom, Compound)) else None
        return key not in _COMPILED_DIRECTIVES
    return False


def _static_text(clause) -> str:
    if isinstance(clause, Directive):
        return _full_stop(f":- {layout_term(clause.goal, 1199, column=3, trailing=1, event_operators=False)}")
    return write_clause(clause.term)


def _full_stop(text: str) -> str:
    """`text.`, with a space before the full stop after a symbol character (`*.` would read as
    one atom)."""
    return text + (" ." if text and text[-1] in _SYMBOL_CHARS else ".")


_SYMBOL_CHARS = set("+-*/\\^<>=~:.?@#&$")


def write_clause(term: Term) -> str:
    """A clause as text: `Head :-` then one goal per line, indented by four spaces, a goal that
    is an if-then-else or a disjunction in the usual layout (`(   If` / `->  Then` / `;   Else`
    / `)`), and any term longer than the line width broken over lines (writer.layout_term)."""
    if isinstance(term, Compound) and term.name == ":-" and term.arity == 2:
        head, body = term.args
        if isinstance(body, Var):
            body = Compound("call", (body,))      # `H :- X.` means call(X); SWI-Prolog wants it written
        goals = conjuncts(body)
        lines = [layout_term(head, 1199, trailing=3, event_operators=False) + " :-"]
        for i, goal in enumerate(goals):
            last = i == len(goals) - 1
            text = layout_term(goal, 999, column=4, trailing=1, event_operators=False, break_control=True)
            lines.append("    " + (_full_stop(text) if last else text + ","))
        return "\n".join(lines)
    return _full_stop(layout_term(term, 1199, trailing=1, event_operators=False))


def _printed_clause(spec: tuple) -> str:
    """The `ele_printed/1` clause for one print_trigger (collect_settings._printed)."""
    if spec[0] == "pattern":
        return f"ele_printed({write_term(spec[1], 999)})."
    _, name, arity = spec
    if name is not None and arity is not None:
        return f"ele_printed({_functor_pattern(name, arity)})."
    if name is None:
        return "ele_printed(E) :- atom(E)." if arity == 0 else \
            f"ele_printed(E) :- compound(E), compound_name_arity(E, _, {arity})."
    return f"ele_printed(E) :- callable(E), functor(E, {quote_atom(name)}, _)."


def _functor_pattern(name: str, arity: int) -> str:
    if arity == 0:
        return quote_atom(name)
    return f"{quote_atom(name)}({', '.join('_' for _ in range(arity))})"


def _window_text(window) -> str:
    return "none" if window is None else _number_text(window)


def _number_text(value) -> str:
    return str(int(value)) if float(value).is_integer() else repr(float(value))
