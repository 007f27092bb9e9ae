"""Generated Prolog stays readable: a clause body one goal a line, no code line longer than the
writer's width (frontend/writer.py, `WIDTH`) where it can be broken, and the broken text reads
back in SWI-Prolog as the very term the one-line text is.

What a program does with the broken text is checked by the golden runs (tests/test_golden.py:
every golden case and every example with an event stream runs through standalone `swipl` and
the Python driver with its expected output unchanged); here every other example is loaded.
"""
from __future__ import annotations

import subprocess
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from golden_cases import ROOT, aq_cases, compiled_aq_program, compiled_event_program, event_cases, modes
from retalisc.compiler import compile_file, compile_source
from retalisc.driver.engine import Engine
from retalisc.frontend.terms import NIL, Atom, Compound, Number, String, Var
from retalisc.frontend import writer
from retalisc.frontend.writer import WIDTH, layout_term, write_term

EXAMPLES = sorted(ROOT.glob("examples/*/*.rtl"))


def _long_code_lines(prolog: str, source: str):
    """Lines over the width, but for the comments that quote a source rule after its
    location (as long as the author wrote it)."""
    long = []
    for line in prolog.splitlines():
        if len(line) <= WIDTH:
            continue
        comment = line.lstrip().startswith("%")
        quoted = line.lstrip()[1:].split(": ", 1)[-1] if comment else None
        if quoted is not None and " ".join(quoted.split()) in " ".join(source.split()):
            continue
        long.append(line)
    return long


def _programs():
    cases = [pytest.param(p, id=str(p.relative_to(ROOT))) for p in EXAMPLES]
    cases += [pytest.param(c / "program.rtl", id=str(c.relative_to(ROOT))) for c in event_cases()]
    return cases


def _sources(program: Path) -> str:
    """The text of a program and of the files beside it (the rule files it includes)."""
    return "\n".join(p.read_text(encoding="utf-8", errors="replace")
                     for p in sorted(program.parent.iterdir()) if p.suffix in (".rtl", ".txt", ".pl"))


def _compiled(program: Path) -> str:
    """Compiled as from the checkout, `retalisc compile examples/...` (file names in comments
    relative)."""
    relative = program.relative_to(ROOT)
    return compile_source(program.read_text(encoding="utf-8"), str(relative), output_name="program.pl").prolog


@pytest.mark.parametrize("program", _programs())
def test_event_programs_compile_to_lines_within_the_width(program, monkeypatch):
    monkeypatch.chdir(ROOT)
    assert _long_code_lines(_compiled(program), _sources(program)) == []


@pytest.mark.parametrize("case", aq_cases(), ids=lambda c: c.name)
def test_active_query_programs_compile_to_lines_within_the_width(case):
    for mode in modes(case):
        assert _long_code_lines(compiled_aq_program(case, mode), _sources(case / "program.pl")) == [], mode


_SAME_CLAUSES = """
terms(F, Ts) :- setup_call_cleanup(open(F, read, S), all(S, Ts), close(S)).
all(S, Ts) :- read_term(S, T, []), ( T == end_of_file -> Ts = [] ; Ts = [T|R], all(S, R) ).
same(A, B) :- terms(A, TA), terms(B, TB), ( TA =@= TB -> true ; format("~w differs~n", [B]) ).
"""


def test_broken_lines_are_the_clauses_of_one_line_text(tmp_path, monkeypatch):
    """Every example and every golden program (active-query ones in each of their modes),
    compiled with the width and compiled with no limit (every term on one line, the text of
    `write_term`): SWI-Prolog reads the same clauses from both files."""
    monkeypatch.chdir(ROOT)
    texts = {}
    for program in EXAMPLES + [c / "program.rtl" for c in event_cases()]:
        texts[str(program.relative_to(ROOT))] = lambda p=program: _compiled(p)
    for case in aq_cases():
        for mode in modes(case):
            texts[f"{case.name}.{mode}"] = lambda c=case, m=mode: compiled_aq_program(c, m)
    pairs, changed = [], 0
    for n, (name, make) in enumerate(texts.items()):
        broken = tmp_path / f"{n}.broken.pl"
        broken.write_text(make())
        with monkeypatch.context() as m:
            m.setattr(writer, "WIDTH", 10 ** 9)
            flat = make()
        changed += flat != (tmp_path / f"{n}.broken.pl").read_text()
        (tmp_path / f"{n}.flat.pl").write_text(flat)
        pairs.append(f"same('{tmp_path}/{n}.flat.pl', '{tmp_path}/{n}.broken.pl')")
    assert len(pairs) > 80 and changed > 30            # the width was in effect
    (tmp_path / "same.pl").write_text(_SAME_CLAUSES)
    run = subprocess.run(["swipl", "-q", "-g", f"forall(member(G, [{', '.join(pairs)}]), G)", "-g", "halt",
                          str(tmp_path / "same.pl")], capture_output=True, text=True, timeout=120,
                         stdin=subprocess.DEVNULL)
    assert run.returncode == 0 and run.stdout == "" and run.stderr == "", run.stdout + run.stderr


def test_the_longest_clause_of_nao_is_broken_one_goal_a_line():
    """examples/nao/nao.rtl made lines of 2,384 columns: every goal of a clause body now
    starts a line of its own, and a body goal is never joined to the head."""
    prolog = compile_file(str(ROOT / "examples/nao/nao.rtl")).prolog
    assert max(len(line) for line in prolog.splitlines() if not line.lstrip().startswith("%")) <= WIDTH
    rules = prolog[prolog.index("% ---- r"):]           # the clauses compiled from the event rules
    heads = [line for line in rules.splitlines() if ":-" in line and not line.startswith(("%", ":-", " "))]
    assert heads and all(line.endswith(":-") for line in heads), [h for h in heads if not h.endswith(":-")][:3]


def test_short_bodies_keep_an_if_then_else_in_the_usual_layout():
    """A body goal that is an if-then-else is laid out as `(   If` / `->  Then` / `;   Else` /
    `)` even when it would fit on one line; a short term stays on one line."""
    from retalisc.backends.prolog.render import write_clause
    x, y = Var("X"), Var("Y")
    clause = Compound(":-", (Compound("p", (x,)),
                             Compound(",", (Compound(";", (Compound("->", (Compound("q", (x,)), Atom("true"))),
                                                           Compound("r", (x, y)))),
                                            Compound("s", (y,))))))
    assert write_clause(clause) == "p(X) :-\n    (   q(X)\n    ->  true\n    ;   r(X, Y)\n    ),\n    s(Y)."


def test_generated_text_of_the_goldens_is_deterministic():
    """The same source gives the same text whatever was compiled before in the process (the
    count variable of `star_times` was numbered by a process-wide counter)."""
    case = next(c for c in event_cases() if c.name == "etalis_operators")
    first = compiled_event_program(case)
    for other in event_cases()[:3]:
        compiled_event_program(other)
    assert compiled_event_program(case) == first


@pytest.mark.parametrize("program", [p for p in EXAMPLES if not (p.parent / "events.jsonl").exists()
                                     or sorted(p.parent.glob("*.rtl"))[0] != p],
                         ids=lambda p: str(p.relative_to(ROOT)))
def test_examples_without_a_golden_run_load(program):
    engine = Engine.load(program)
    assert engine.module


# ---- the broken text is the same term ----------------------------------------------------

_NAMES = ["a", "f", "g", "long_functor_name", "'quoted atom'", "-", "+", "*", "=", "is", "<", ";", ",",
          "->", "*->", "\\+", ":-", ":", "dynamic", "[]", "{}", "!", "|", "-->", "?-", "^", "\\", "@"]

_leaves = st.one_of(
    st.sampled_from(["X", "Y", "_Z", "Long_variable_name"]).map(Var),
    st.sampled_from(_NAMES).map(lambda n: Atom(n.strip("'"))),
    st.integers(-1000, 10 ** 12).map(Number),
    st.floats(-1e6, 1e6, allow_nan=False, allow_infinity=False).map(Number),
    st.sampled_from(["", "text", "with \"quotes\" and \\"]).map(String),
)


def _compound(inner):
    return st.one_of(
        st.tuples(st.sampled_from(_NAMES).map(lambda n: n.strip("'")),
                  st.lists(inner, min_size=1, max_size=4)).map(lambda p: Compound(p[0], tuple(p[1]))),
        st.tuples(st.lists(inner, max_size=5), st.sampled_from([NIL, Var("T")])).map(_list),
        inner.map(lambda t: Compound("{}", (t,))),
    )


def _list(pair):
    items, tail = pair
    term = tail
    for item in reversed(items):
        term = Compound("[|]", (item, term))
    return term if items or tail is NIL else NIL


_terms = st.recursive(_leaves, _compound, max_leaves=25)


@settings(max_examples=12, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.lists(_terms, min_size=30, max_size=30), st.sampled_from([12, 30, 60]))
def test_layout_reads_back_as_the_one_line_term(tmp_path_factory, terms, width):
    """SWI-Prolog reads the text of `layout_term` (broken for a narrow width) as the term
    it reads from `write_term`'s one-line text: the oracle is SWI-Prolog's own reader."""
    directory = tmp_path_factory.mktemp("layout")
    lines = []
    for n, term in enumerate(terms):
        for event_operators in (False, True):
            flat = write_term(term, 999, event_operators=event_operators)
            broken = layout_term(term, 999, column=len("same(N, "), trailing=2,
                                 event_operators=event_operators, width=width)
            lines.append(f"same({n}, {flat},\n{' ' * len('same(N, ')}{broken}).")
    path = Path(directory) / "terms.pl"
    path.write_text("\n".join(lines) + "\n")
    check = ("read_file(F) :- setup_call_cleanup(open(F, read, S), read_all(S), close(S)). "
             "read_all(S) :- read_term(S, T, []), ( T == end_of_file -> true ; "
             "T = same(N, A, B), ( A == B -> true ; format('~w: ~q =/= ~q~n', [N, A, B]) ), read_all(S) ).")
    program = Path(directory) / "check.pl"
    program.write_text(check.replace(". ", ".\n") + "\n")
    run = subprocess.run(["swipl", "-q", "-g", f"read_file({str(path)!r})", "-g", "halt", str(program)],
                         capture_output=True, text=True, timeout=60, stdin=subprocess.DEVNULL)
    assert run.returncode == 0 and run.stdout == "" and run.stderr == "", run.stdout + run.stderr
