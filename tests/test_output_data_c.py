"""Outputs cross to Python as data (rtl_output_data/2 in prolog_runtime/rtl_io.pl): the C writer
(rtl_fast_output_data/2, c/rtl_fastread.c) writes the same bytes as the Prolog writer, the
reference; the Python side reads the array back into the outputs the runtime meant: each
output's line, written by Python (`OutputEvent.line`), is byte for byte the line the runtime
writes (rtl_output_record_line/2), and each term's value is the value read from its writeq
text by the one reader of term text (`values.read_term`), or the value the test wrote."""
import json
import math
import subprocess
from pathlib import Path

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from retalisc.driver.engine import OutputEvent
from retalisc.driver.values import String, Term, read_term, write_term

ROOT = Path(__file__).resolve().parent.parent

# For each term text: the records of the term with each time pair, consumer and op; printed:
# `C<TAB>outputs<TAB>terms` (the two arrays; `C<TAB>-` when the C writer leaves them to Prolog),
# `P<TAB>outputs<TAB>terms` (Prolog), then `L<TAB>line` for each record.
CHECK = r"""
:- use_module(library(readutil)).
main :-
    current_prolog_flag(argv, [File|_]),
    read_file_to_string(File, Text, []),
    split_string(Text, "\n", "", Lines0),
    append(Lines, [_], Lines0),
    forall(member(Line, Lines), check(Line)).

check(Line) :-
    term_string(Event, Line),
    Inf is inf, Big is 2^70,
    findall(event(Event, S, E, C, Op),
            ( member(S-E, [1-2, 1.5-2.25, 0-0, -3-(-1), 1.0e15-1.0e16, 1234567890123456.0-1.0e22,
                           0.0001-1.0e-5, -0.0-5.0e-324, 0.1-0.30000000000000004, Inf-1, Big-Big]),
              member(C-Op, [(-)-add, (-)-retract, ops-add, 'a "b"'-retract, echo(input)-add]) ),
            Records0),
    Records = [json("{\"query\": \"q\\\"1\", \"at\": 2.5, \"status\": \"answered\", \"answers\": [{\"X\": \"a\"}, {\"X\": \"'\\\\n'\"}], \"message\": \"\"}")|Records0],
    rtl_use_fast_reader(true),
    (   rtl_io:rtl_fast_output_data(Records, C0) -> tabbed(C0, C) ; C = "-" ),
    rtl_use_fast_reader(false),
    rtl_output_data(Records, P0),
    tabbed(P0, P),
    format("C\t~s~nP\t~s~n", [C, P]),
    forall(member(R, Records), ( rtl_output_record_line(R, L), format("L\t~s~n", [L]) )),
    % the records one by one: the C writer takes each one it can
    rtl_use_fast_reader(true),
    forall(member(R, Records),
           (   rtl_io:rtl_fast_output_data([R], C1)
           ->  rtl_use_fast_reader(false), rtl_output_data([R], P1), rtl_use_fast_reader(true),
               tabbed(C1, C2), tabbed(P1, P2),
               format("1\t~s\t~s~n", [C2, P2])
           ;   true
           )).

% The two lines of the data, on one line (JSON text holds no tab).
tabbed(Data, Tabbed) :-
    split_string(Data, "\n", "", [Outputs, Terms]),
    atomics_to_string([Outputs, "\t", Terms], Tabbed).
"""


def run_check(tmp_path, swipl, texts):
    """The arrays and lines of each text's records (see CHECK), and how many of them the C
    writer took as a whole batch."""
    terms = tmp_path / "terms.txt"
    terms.write_text("".join(text + "\n" for text in texts), encoding="utf-8")
    script = tmp_path / "check.pl"
    script.write_text(f":- use_module('{ROOT / 'prolog_runtime' / 'rtl_io'}').\n" + CHECK)
    done = subprocess.run([swipl, "-g", "main", "-t", "halt", str(script), str(terms)],
                          capture_output=True, text=True, timeout=120, encoding="utf-8")
    assert done.returncode == 0, done.stderr
    taken, singles, results = 0, 0, []
    for row in done.stdout.split("\n")[:-1]:
        kind, _, rest = row.partition("\t")
        if kind == "C":
            c_array = rest
        elif kind == "P":
            if c_array != "-":
                assert c_array == rest
                taken += 1
            outputs, terms = rest.split("\t")
            results.append((json.loads(outputs), json.loads(terms), []))
        elif kind == "L":
            results[-1][2].append(rest)
        else:
            c_outputs, c_terms, prolog_outputs, prolog_terms = rest.split("\t")
            assert (c_outputs, c_terms) == (prolog_outputs, prolog_terms)
            singles += 1
    assert len(results) == len(texts)
    return results, taken, singles


def check_python_side(results, values=None):
    """Each element read by OutputEvent.from_data gives the runtime's line and the term's value."""
    for index, (array, terms, lines) in enumerate(results):
        assert len(array) == len(terms) == len(lines)
        outputs = [OutputEvent.from_data(item, term) for item, term in zip(array, terms)]
        assert [out.line for out in outputs] == lines
        answer = outputs[0]
        assert answer.op == "answer" and answer.answer.answers == ({"X": "a"}, {"X": "'\\n'"})
        for out in outputs[1:]:
            if values is not None:
                expected = values[index]
            elif out.event == "f(B)":          # '$VAR'(1): writeq writes it as a variable's name
                assert out.term == Term("f", (Term("$VAR", (1,)),))
                continue
            else:
                expected = read_term(out.event)
            assert same_value(out.term, expected), (out.event, out.term, expected)
            assert out.name == (expected.name if isinstance(expected, Term) else str(expected))


def same_value(a, b) -> bool:
    """Equal values of the same kinds (an atom is not a string; NaN equals NaN)."""
    if type(a) is not type(b):
        return False
    if isinstance(a, float):
        return a == b or (math.isnan(a) and math.isnan(b))
    if isinstance(a, list):
        return len(a) == len(b) and all(same_value(x, y) for x, y in zip(a, b))
    if isinstance(a, Term):
        return a.name == b.name and len(a.args) == len(b.args) and all(map(same_value, a.args, b.args))
    return a == b


TERMS = [
    "p(1, 2)", "a", "'A b'", "'it''s'", "f(\"str\\\"ing\")", "'new\\nline'", "'tab\\there'", "'café'",
    "'中文'(x)", "f('$VAR'(1))", "- 1", "-(1)", "1-2", "a:b:c", "[1,2|t]", "{x,y}", "'a.b'", "f(-1)",
    "f(1.5e300)", "f(1.0Inf)", "f(-1.0Inf)", "f(1.5NaN)", "f(0'a)", "f(1.0)", "f(123456789012345678901234567890)",
    "[]", "'[]'", "'{}'", "f(;)", "f((a:-b))", "f(\\+a)", "f('\\x1\\')", "f('\\x7f\\')", "f('\\r\\b\\f')",
    "f(\"back\\\\slash\")", "f('quo\"te')", "f(1.0e-10)", "f(-0.0)", "f(\"\\x0\\\")", "f(\"\")", "f('')",
    "p(-9223372036854775808,9223372036854775807)", "p([" + ",".join(map(str, range(-300, 300))) + "])",
    "q('" + "long quoted text " * 300 + "')", "'[|]'(a, b)", "f(x, [a, \"b\", 'C'], g(1.5, [[]]))",
]


def test_the_c_writer_writes_the_prolog_writer_s_bytes(tmp_path, swipl):
    results, taken, singles = run_check(tmp_path, swipl, TERMS)
    check_python_side(results)
    # a batch holds a time of 2^70 and one that is not finite: the Prolog writer takes it whole
    assert taken == 0
    # one by one, the C writer takes every record with finite times of 64 bits, unless the term
    # holds an integer beyond 64 bits (one of the terms): 9 of the 11 time pairs, 5 consumers and
    # ops each, and every query result
    assert singles == (len(TERMS) - 1) * 9 * 5 + len(TERMS)


ATOMS = st.one_of(st.from_regex(r"[a-z][a-zA-Z0-9_]{0,6}", fullmatch=True),
                  st.text(st.characters(codec="utf-8", exclude_categories=("Cs", "Cn", "Co")), max_size=5))
NUMBERS = st.one_of(st.integers(-10 ** 20, 10 ** 20), st.floats(width=64))
LEAVES = st.one_of(ATOMS, NUMBERS, st.builds(String, st.text(st.characters(codec="utf-8",
                                                                           exclude_categories=("Cs", "Cn", "Co")),
                                                             max_size=5)))
VALUES = st.recursive(
    LEAVES,
    lambda inner: st.one_of(st.lists(inner, max_size=4),
                            st.builds(lambda n, a: Term(n, tuple(a)), ATOMS, st.lists(inner, min_size=1, max_size=3))),
    max_leaves=10)


@settings(max_examples=12, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(st.lists(VALUES, min_size=5, max_size=20))
def test_random_terms_cross_as_the_values_they_are(tmp_path, swipl, values):
    results, _, _ = run_check(tmp_path, swipl, [write_term(value) for value in values])
    check_python_side(results, values)
