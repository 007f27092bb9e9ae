"""The C reader of event lines (prolog_runtime/c/rtl_fastread.c) reads what the Prolog reader
reads: every line, well-formed or not, gives the same parse (event, times, op, or the same
rejection) with the C reader on and off. The Prolog reader is the oracle."""
import json
import subprocess
from pathlib import Path

import pytest
from hypothesis import given, settings, HealthCheck
from hypothesis import strategies as st

ROOT = Path(__file__).resolve().parent.parent
LIBRARY = ROOT / "prolog_runtime" / "foreign" / "rtl_fastread.so"

# For each line: parse with the Prolog reader, then with the C reader; print the line
# number when the two differ, and count the lines the C reader took itself.
CHECK = r"""
:- use_module(library(readutil)).
main :-
    current_prolog_flag(argv, [File|_]),
    read_file_to_string(File, Text, []),
    split_string(Text, "\n", "", Lines0),
    append(Lines, [_], Lines0),
    rtl_use_fast_reader(true),
    foldl(compare_line, Lines, 0-0, Taken-Differ),
    format("taken ~w differ ~w~n", [Taken, Differ]).

compare_line(Line, T0-D0, T-D) :-
    rtl_use_fast_reader(false),
    rtl_parse_event_line(Line, 1000, Slow),
    rtl_use_fast_reader(true),
    rtl_parse_event_line(Line, 1000, Fast),
    (   rtl_io:rtl_fast_event_line(Line, 1000, _, _, _, _, _) -> T is T0 + 1 ; T = T0 ),
    (   Slow == Fast
    ->  D = D0
    ;   D is D0 + 1,
        format("DIFFER ~q~n  prolog ~q~n  c      ~q~n", [Line, Slow, Fast])
    ).
"""

pytestmark = pytest.mark.skipif(not LIBRARY.exists(),
                                reason="the C reader is not built (bash prolog_runtime/c/build.sh)")


def compare(tmp_path, swipl, lines):
    return run_check(tmp_path, swipl, "check", lines, CHECK)


def run_check(tmp_path, swipl, name, lines, check):
    """Run the Prolog comparison `check` over `lines` (one per line of its input file): it
    prints DIFFER for a line the two roads disagree on, and ends with its two counts."""
    events = tmp_path / f"{name}.txt"
    events.write_text("".join(line + "\n" for line in lines), encoding="utf-8")
    script = tmp_path / f"{name}.pl"
    script.write_text(f":- use_module('{ROOT / 'prolog_runtime' / 'rtl_io'}').\n" + check)
    done = subprocess.run([swipl, "-g", "main", "-t", "halt", str(script), str(events)],
                          capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    assert "DIFFER" not in done.stdout, done.stdout
    last = done.stdout.strip().splitlines()[-1].split()
    return int(last[1]), int(last[3])


COMMON = [
    '{"event": "a(73, 98)", "t": 1}',
    '{"event": "pose(r1, [1.5, -2, 0.25e-3], \'Frame A\')", "t": [12, 500000000]}',
    '{"event": "door_closed", "start": 1, "end": 2.5, "op": "retract"}',
    '{ "t" : 3 , "event" : "seen(p1, kitchen)." , "seq": 7, "frame": "map", "ok": true }',
    '{"event": "m([], [[a], []], \'\', \'[]\')", "t": 0, "extra": [1, 2.5]}',
]


def test_the_common_case_is_read_in_c(tmp_path, swipl):
    taken, differ = compare(tmp_path, swipl, COMMON)
    assert (taken, differ) == (len(COMMON), 0)


# Lines the C reader must leave to the Prolog reader, which gives the same answer.
UNCOMMON = [
    '{"event": "a(1)", "t": 1, "t": 2}', '{"event": "a(\\"x\\")", "t": 1}',
    '{"event": "a(X)", "t": 1}', '{"event": "a(1+2)", "t": 1}', '{"event": "a(- 1)", "t": 1}',
    '{"event": "a(0\'c)", "t": 1}', '{"event": "a(0x1F)", "t": 1}', '{"event": "a(1e10)", "t": 1}',
    '{"event": "a(1.0Inf)", "t": 1}', '{"event": "a(99999999999999999999)", "t": 1}',
    '{"event": "[a]", "t": 1}', '{"event": "7", "t": 1}', '{"event": "a (1)", "t": 1}',
    '{"event": "a(b)c", "t": 1}', '{"event": "a(1). b", "t": 1}', '{"event": "a([b|c])", "t": 1}',
    '{"event": "a({b})", "t": 1}', '{"event": "\'it\'\'s\'", "t": 1}', '{"event": "a(1)", "t": 1e400}',
    '{"event": "a(1)", "t": 010}', '{"event": "a(1)", "t": [1, 0.5]}', '{"event": "a(1)", "t": [1, -1]}',
    '{"event": "a(1)", "start": 3, "end": 1}', '{"event": "a(1)", "t": 1, "op": "add_rule"}',
    '{"event": "a(1)", "t": 1} x', '{"event": "caf\u00e9", "t": 1}', '{"event": "a(1)"}',
    '{"event": "a(mod, is, dynamic, -)", "t": 1}', '', '   ', '[1]', '{"event": "a(1)", "t": "1"}',
    '{"event": "a(1)", "t": 1, "x": {"y": 1}}', '{"event": "a(1)", "t": -0}', '{"event": "a(-0.0)", "t": 1}',
    '{"event": "a(1)", "t": 1, "op": "retract"}',
]


def test_uncommon_lines_get_the_same_answer(tmp_path, swipl):
    taken, differ = compare(tmp_path, swipl, UNCOMMON)
    assert differ == 0


# Random lines: event texts from a small term grammar, then tokens from both languages
# spliced in at random places, so that near misses of the common case are frequent.
NAMES = st.sampled_from(["a", "b_1", "pose", "mod", "is", "dynamic", "xB9", "'Q x'", "''", "'a\\\\b'",
                         "'[]'", "[]", "X", "_", "e"])
NUMBERS = st.one_of(st.integers(-10**20, 10**20).map(str),
                    st.floats(allow_nan=False, allow_infinity=False).map(repr),
                    st.sampled_from(["0.5e3", "1.0E-2", "007", "-0", "1e5", "0'a", "1_000", "- 3", "2.", ".5"]))


def terms(depth):
    if depth == 0:
        return st.one_of(NAMES, NUMBERS)
    sub = terms(depth - 1)
    return st.one_of(
        NAMES, NUMBERS,
        st.builds(lambda f, args, sep: f + "(" + sep.join(args) + ")", NAMES, st.lists(sub, min_size=1, max_size=3),
                  st.sampled_from([", ", ",", " , "])),
        st.builds(lambda items: "[" + ", ".join(items) + "]", st.lists(sub, max_size=3)),
    )


SPLICE = st.sampled_from([" ", ".", "(", ")", "[", "]", ",", "|", "'", "\\\"", "+", "-", "{", "}", "\\\\",
                          "\\u00e9", "\\n", "\t", "é", "0", "e", "X"])


@st.composite
def lines(draw):
    event = draw(terms(3))
    fields = {"event": event}
    time = draw(st.one_of(st.integers(-5, 10**12), st.floats(allow_nan=False, allow_infinity=False),
                          st.lists(st.integers(-2, 10**10), min_size=2, max_size=2)))
    if draw(st.booleans()):
        fields["t"] = time
    else:
        fields["start"], fields["end"] = time, draw(st.integers(-5, 10))
    if draw(st.integers(0, 4)) == 0:
        fields["op"] = draw(st.sampled_from(["add", "retract", "add_rule", "x"]))
    if draw(st.integers(0, 3)) == 0:
        fields[draw(st.sampled_from(["seq", "frame", "t", "event"]))] = draw(
            st.one_of(st.integers(), st.text(max_size=3), st.booleans(), st.lists(st.integers(), max_size=2)))
    line = json.dumps(fields, ensure_ascii=draw(st.booleans()))
    for _ in range(draw(st.integers(0, 2))):
        at = draw(st.integers(0, len(line)))
        line = line[:at] + draw(SPLICE) + line[at:]
    return line


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(st.lists(lines(), min_size=20, max_size=40))
def test_random_lines_get_the_same_answer(tmp_path, swipl, batch):
    batch = [line.replace("\n", " ") for line in batch]
    compare(tmp_path, swipl, batch)


def test_without_the_c_reader_the_runtime_reads_every_line_in_prolog(tmp_path, swipl):
    import shutil
    from retalisc.compiler import compile_source

    runtime = tmp_path / "runtime"
    shutil.copytree(ROOT / "prolog_runtime", runtime, ignore=shutil.ignore_patterns("foreign", "tests"))
    program = tmp_path / "p.pl"
    program.write_text(compile_source("both(X, Y) <- a(X) seq b(Y).\n", "p.rtl", output_name="p.pl").prolog)
    events = tmp_path / "e.jsonl"
    events.write_text("".join(line + "\n" for line in
                              ['{"event": "a(1)", "t": 1}', '{"event": "b(\'x y\')", "t": [2, 5]}', 'not json']))
    runs = {}
    for name, env in (("c", {}), ("prolog", {"RETALIS_RUNTIME": str(runtime)})):
        import os
        done = subprocess.run([swipl, str(program), str(events)], capture_output=True, text=True, timeout=60,
                              env={**os.environ, **env})
        assert done.returncode == 0, done.stderr
        runs[name] = (done.stdout, done.stderr.splitlines()[0])
    assert runs["c"] == runs["prolog"]
    assert runs["c"][0].startswith('{"event": "both(1,\'x y\')"')


# The C writer of output lines (rtl_fast_event_json/4) against rtl_event_json/6 in Prolog:
# each event text is read as a term and written both ways with each pair of times.
WRITE_CHECK = r"""
:- use_module(library(readutil)).
main :-
    current_prolog_flag(argv, [File|_]),
    read_file_to_string(File, Text, []),
    split_string(Text, "\n", "", Lines0),
    append(Lines, [_], Lines0),
    foldl(compare_output, Lines, 0-0, Taken-Differ),
    format("taken ~w differ ~w~n", [Taken, Differ]).

compare_output(Line, T0-D0, T-D) :-
    catch(term_string(Event, Line), _, fail),       % (random texts need not be terms)
    ground(Event),                                  % (a variable's name depends on the stack)
    !,
    Inf is inf, NaN is nan, Big is 2^70,
    Times = [1-2, 1.5-2.25, 0-0, -3-(-1), 1.0e20-1.0e21, 0.1-0.30000000000000004, -0.0-1.0e-300,
             Inf-1, 1-NaN, Big-Big],
    foldl(compare_times(Event), Times, T0-D0, T-D).
compare_output(_, TD, TD).

compare_times(Event, S-E, T0-D0, T-D) :-
    rtl_use_fast_reader(false),
    rtl_event_json(Event, S, E, -, add, Slow),
    rtl_use_fast_reader(true),
    rtl_event_json(Event, S, E, -, add, Fast),
    (   rtl_io:rtl_fast_event_json(Event, S, E, _) -> T is T0 + 1 ; T = T0 ),
    written_line(Event, S, E, Written),
    (   Slow == Fast, ( Written == "" ; string_concat(Slow, "\n", Written) )
    ->  D = D0
    ;   D is D0 + 1,
        format("DIFFER ~q~n  prolog ~s~n  c      ~s~n  stream ~s~n", [Event, Slow, Fast, Written])
    ).

% What rtl_write_event_line/4 writes to a UTF-8 file ("" when it leaves the line to Prolog).
written_line(Event, S, E, Written) :-
    tmp_file_stream(utf8, File, Out),
    (   rtl_write_event_line(Out, Event, S, E) -> true ; true ),
    close(Out),
    read_file_to_string(File, Written, [encoding(utf8)]),
    delete_file(File).
"""

OUTPUT_TERMS = [
    "p(1, 2)", "a", "'A b'", "'it''s'", "f(\"str\\\"ing\")", "'new\\nline'", "'tab\\there'", "'café'",
    "'中文'(x)", "f('$VAR'(1))", "f('$VAR'('X'))", "- 1", "-(1)", "1-2", "a:b:c", "[1,2|t]", "{x,y}",
    "'a.b'", "f(-1)", "f(- 1)", "f(1.5e300)", "f(1.0Inf)", "f(1.5NaN)", "f(0'a)", "f(1.0)",
    "f(123456789012345678901234567890)", "[]", "'[]'", "'{}'", "f(;)", "f((a:-b))", "f(\\+a)",
    "f('\\x1\\')", "f('\\x7f\\')", "f(\"back\\\\slash\")", "f('quo\"te')", "f(a= \\+)", "f(1r3)",
    "f(- (-1))", "f(-(-(1)))", "f(1.0e-10)", "f(-0.0)", "f(\"\\x0\\\")",
]


def compare_output(tmp_path, swipl, texts):
    return run_check(tmp_path, swipl, "write_check", texts, WRITE_CHECK)


def test_output_lines_written_in_c_are_those_written_in_prolog(tmp_path, swipl):
    taken, differ = compare_output(tmp_path, swipl, OUTPUT_TERMS)
    assert differ == 0
    # every term with finite times of at most 64 bits (7 of the 10 pairs) is written in C
    assert taken == 7 * len(OUTPUT_TERMS)


@settings(max_examples=15, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(st.lists(terms(3), min_size=10, max_size=30))
def test_random_output_lines_are_written_the_same(tmp_path, swipl, texts):
    compare_output(tmp_path, swipl, texts)
