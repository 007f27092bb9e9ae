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


def lines_main(compare: str, counted: str, fast_reader: bool = False) -> str:
    """The main/0 of a comparison script: fold `compare` over the lines of the file given as
    its argument, counting what it counts and the lines the two roads differ on."""
    setup = "    rtl_use_fast_reader(true),\n" if fast_reader else ""
    return (":- use_module(library(readutil)).\nmain :-\n"
            "    current_prolog_flag(argv, [File|_]),\n"
            "    read_file_to_string(File, Text, []),\n"
            '    split_string(Text, "\\n", "", Lines0),\n'
            "    append(Lines, [_], Lines0),\n"
            f"{setup}    foldl({compare}, Lines, 0-0, Counted-Differ),\n"
            f'    format("{counted} ~w differ ~w~n", [Counted, Differ]).\n')


# For each line: parse with the Prolog reader, then with the C reader; print the line
# number when the two differ, and count the lines the C reader took itself.
CHECK = lines_main("compare_line", "taken", fast_reader=True) + r"""
compare_line(Line, T0-D0, T-D) :-
    rtl_use_fast_reader(false),
    rtl_parse_event_line(Line, 1000, Slow),
    rtl_use_fast_reader(true),
    rtl_parse_event_line(Line, 1000, Fast),
    (   rtl_io:rtl_fast_event_line(Line, 1000, -1, _, _, _, _, _) -> T is T0 + 1 ; T = T0 ),
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
WRITE_CHECK = lines_main("compare_output", "taken") + r"""
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
    # the extremes of 64-bit integers, and lines longer than the C writer's first buffer
    "p(-9223372036854775808,9223372036854775807,0,-1,10)", "p([" + ",".join(map(str, range(-300, 300))) + "])",
    "q('" + "long quoted text " * 60 + "')",
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


# Terms the C writer writes itself, without the Prolog writer (identifiers, integers, floats,
# lists, compounds of arity other than 1 and 2), among the shapes next to them that it leaves
# to the Prolog writer: operator names, quoted atoms, arity 1 and 2, strings, big integers.
PLAIN_NAMES = st.sampled_from(["a", "p1", "pose", "mod", "is", "dynamic", "xor", "r_2", "aB9", "[]", "'[]'",
                               "'A'", "'a b'", "-", "'é'", "{}"])
PLAIN_NUMBERS = st.one_of(st.integers(-10**20, 10**20).map(str),
                          st.floats(allow_nan=False, allow_infinity=False, width=64).map(repr).map(
                              lambda text: text if "." in text or "e" in text else text + ".0"),
                          st.sampled_from(["-0.0", "1.0e300", "-3", "0", "\"s\""]))


def nested_terms(leaves, depth):
    """Texts of terms up to depth: leaves, compound terms and lists (with or without a tail) of
    nested terms."""
    if depth == 0:
        return leaves
    sub = nested_terms(leaves, depth - 1)
    return st.one_of(
        leaves,
        st.builds(lambda f, args: f + "(" + ",".join(args) + ")", PLAIN_NAMES,
                  st.lists(sub, min_size=1, max_size=5)),
        st.builds(lambda items, tail: "[" + ",".join(items) + (("|" + tail) if tail and items else "") + "]",
                  st.lists(sub, max_size=4), st.one_of(st.just(""), sub)),
    )


@settings(max_examples=15, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(st.lists(nested_terms(st.one_of(PLAIN_NAMES, PLAIN_NUMBERS), 3), min_size=10, max_size=30))
def test_plain_output_terms_are_written_as_writeq_writes_them(tmp_path, swipl, texts):
    compare_output(tmp_path, swipl, texts)


# Terms with variables (the derived event of an `or` branch that did not bind everything): the
# C writer names each variable itself, as writeq/1 names it at that moment (`_123`, its offset
# in the stack), so both writers are compared on the same term in the same process; `plain`
# counts the terms the C writer wrote without the Prolog writer (rtl_fast_plain_text/2).
VAR_WRITE_CHECK = lines_main("compare_output", "plain") + r"""
compare_output(Line, P0-D0, P-D) :-
    term_string(Event, Line),
    rtl_use_fast_reader(false),
    rtl_event_json(Event, 1, 2.5, -, add, Slow),
    format(string(Writeq), "~q", [Event]),
    rtl_use_fast_reader(true),
    rtl_event_json(Event, 1, 2.5, -, add, Fast),
    tmp_file_stream(utf8, File, Out),
    (   rtl_write_event_line(Out, Event, 1, 2.5) -> true ; true ),
    close(Out),
    read_file_to_string(File, Written, [encoding(utf8)]),
    delete_file(File),
    (   rtl_io:rtl_fast_plain_text(Event, PlainText)
    ->  P is P0 + 1,
        unnamed(PlainText, Plain1), unnamed(Writeq, Writeq1),
        ( Plain1 == Writeq1 -> Same = true ; Same = false )
    ;   P = P0, Same = true
    ),
    maplist(unnamed, [Slow, Fast, Written], [Slow1, Fast1, Written1]),
    (   Slow1 == Fast1, string_concat(Slow1, "\n", Written1), Same == true
    ->  D = D0
    ;   D is D0 + 1,
        format("DIFFER ~q~n  prolog ~s~n  c      ~s~n  stream ~s~n", [Event, Slow, Fast, Written])
    ).

% A variable's name (_123) is its place on the stacks, which a garbage collection between two
% writes of the same term may change: compare the texts with every name as `_`.
unnamed(Text, Unnamed) :-
    string_codes(Text, Codes),
    phrase(unnamed_codes(Out), Codes),
    string_codes(Unnamed, Out).

unnamed_codes([0'_|Out]) --> "_", [D], { code_type(D, digit) }, !, digits, unnamed_codes(Out).
unnamed_codes([C|Out]) --> [C], !, unnamed_codes(Out).
unnamed_codes([]) --> [].

digits --> [D], { code_type(D, digit) }, !, digits.
digits --> [].
"""

VARIABLE_TERMS = ["p4(1,2,_)", "p(X,X,Y,[a,Y|Z],Z)", "f(_,g(_,_,_))", "[_|_]", "[_]", "_", "p(_,1.5,[],q)",
                  "p(X,'A',X)", "f(- X)", "f(X+1,y,z)", "p(X,Y,Z)"]


def test_output_terms_with_variables_are_written_in_c_as_writeq_writes_them(tmp_path, swipl):
    plain, differ = run_check(tmp_path, swipl, "var_write_check", VARIABLE_TERMS, VAR_WRITE_CHECK)
    assert differ == 0
    # all but the quoted atom, the operators and the compounds of arity 1 and 2 are written by C itself
    assert plain == len(VARIABLE_TERMS) - 4


PLAIN_WITH_VARIABLES = st.one_of(PLAIN_NAMES, PLAIN_NUMBERS, st.sampled_from(["X", "Y", "_", "_A", "Z"]))


@settings(max_examples=15, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(st.lists(nested_terms(PLAIN_WITH_VARIABLES, 3), min_size=10, max_size=30))
def test_random_output_terms_with_variables_are_written_the_same(tmp_path, swipl, texts):
    run_check(tmp_path, swipl, "var_write_check", texts, VAR_WRITE_CHECK)


# ---- the line loop: blocks of plain event lines against every line read in Prolog --------------
# The C reader hands the line loop blocks of lines; a run of plain event lines (a time "t" only)
# is remembered for retractions in one call (rtl_seen_add_atomic/1). Without the C reader every
# line takes the Prolog road, one at a time: the oracle. Retractions of events added in a block,
# added twice, never added, and lines that fail or are rejected between them.

LOOP_PROGRAM = """\
:- set_etalis_flag(event_consumption_policy, recent).
pair(I, X, Y) <- a(I, X) seq b(I, Y).
both(I) <- (a(I, _) and c(I)).5.
big(I, Y) <- b(I, Y) where Y > 2.
"""


@pytest.fixture(scope="module")
def loop_setup(tmp_path_factory):
    import shutil
    from retalisc.compiler import compile_source

    work = tmp_path_factory.mktemp("line_loop")
    runtime = work / "runtime"
    shutil.copytree(ROOT / "prolog_runtime", runtime, ignore=shutil.ignore_patterns("foreign", "tests"))
    program = work / "p.pl"
    program.write_text(compile_source(LOOP_PROGRAM, "p.rtl", output_name="p.pl").prolog)
    return work, runtime, program


def loop_runs(swipl, setup, lines):
    import os
    work, runtime, program = setup
    events = work / "events.jsonl"
    events.write_text("".join(line + "\n" for line in lines))
    runs = {}
    for name, env in (("c", {}), ("prolog", {"RETALIS_RUNTIME": str(runtime)})):
        done = subprocess.run([swipl, str(program), "--max-delay=2", str(events)], capture_output=True, text=True,
                              timeout=60, env={**os.environ, **env})
        assert done.returncode == 0, done.stderr
        stderr = done.stderr.splitlines()
        summary = stderr[-1].rsplit(",", 1)[0]          # (without the time)
        runs[name] = (done.stdout, stderr[:-1], summary)
    return runs


@st.composite
def loop_streams(draw):
    lines, added, t = [], [], 0
    for _ in range(draw(st.integers(1, 60))):
        kind = draw(st.sampled_from(["add"] * 6 + ["retract", "retract_never", "interval", "bad", "twice"]))
        t += draw(st.integers(0, 2))
        event = f"{draw(st.sampled_from('abc'))}({draw(st.integers(1, 3))}"
        event += ")" if event[0] == "c" else f", {draw(st.sampled_from(['1', '5', 'foo']))})"
        if kind in ("add", "twice"):
            lines.append(json.dumps({"event": event, "t": t}))
            added.append((event, t))
            if kind == "twice":
                lines.append(json.dumps({"event": event, "t": t}))
        elif kind == "retract" and added:
            old, when = draw(st.sampled_from(added))
            lines.append(json.dumps({"event": old, "t": when, "op": "retract"}))
        elif kind == "retract_never":
            lines.append(json.dumps({"event": event, "t": t + 100, "op": "retract"}))
        elif kind == "interval":
            lines.append(json.dumps({"event": event, "start": max(t - 1, 0), "end": t}))
        else:
            lines.append("not json")
    return lines


@settings(max_examples=12, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(lines=loop_streams())
def test_the_line_loop_gives_the_same_run_with_and_without_the_c_reader(swipl, loop_setup, lines):
    runs = loop_runs(swipl, loop_setup, lines)
    assert runs["c"] == runs["prolog"]


def test_retractions_of_events_added_in_one_block_are_checked(swipl, loop_setup):
    lines = [json.dumps({"event": f"a(1, {k})", "t": k}) for k in range(1, 400)]
    lines += [json.dumps({"event": "a(1, 7)", "t": 7, "op": "retract"}),       # too old to check: too late
              json.dumps({"event": "a(1, 398)", "t": 398, "op": "retract"}),   # added
              json.dumps({"event": "a(1, 398)", "t": 398, "op": "retract"}),   # retracted already
              json.dumps({"event": "a(1, 399)", "t": 398, "op": "retract"})]   # never added with that time
    runs = loop_runs(swipl, loop_setup, lines)
    assert runs["c"] == runs["prolog"]
    stdout, stderr, summary = runs["c"]
    assert [line.split(": ")[1] for line in stderr] == ["warning", "rejected", "rejected"]
    assert [line.split(": ")[0].rsplit(":", 1)[1] for line in stderr] == ["400", "402", "403"]
    assert "retraction of a(1,398) [398, 398], which was not added" in stderr[1]
    assert "retraction of a(1,399) [398, 398], which was not added" in stderr[2]
    assert "2 rejected, 1 retracted, 1 too late to retract" in summary


def test_output_on_a_regular_file_comes_before_the_message_of_a_later_line(swipl, loop_setup):
    import os
    work, _, program = loop_setup
    events = work / "ordered.jsonl"
    events.write_text("".join(json.dumps({"event": f"b(1, {k})", "t": k}) + "\n" for k in range(3, 6))
                      + "not json\n" + json.dumps({"event": "b(1, 9)", "t": 9}) + "\n")
    done = subprocess.run([swipl, str(program), str(events)], stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                          text=True, timeout=60, env=dict(os.environ))
    lines = done.stdout.splitlines()
    rejected = next(i for i, line in enumerate(lines) if "rejected" in line and ":4:" in line)
    assert [line for line in lines[:rejected] if line.startswith("{")] == \
        [f'{{"event": "big(1,{k})", "start": {k}, "end": {k}}}' for k in range(3, 6)]
    assert lines[rejected + 1] == '{"event": "big(1,9)", "start": 9, "end": 9}'


def test_a_cyclic_list_is_left_to_the_prolog_writer(swipl):
    """The C writer walks a list cell by cell: a cyclic list would never end there, so it
    declines it (and a compound nested without end stops at its depth limit)."""
    goal = ("L = [a|L], ( rtl_io:rtl_fast_plain_text(L, _) -> writeln(written) ; writeln(declined) ), "
            "T = f(T, b, c), ( rtl_io:rtl_fast_plain_text(T, _) -> writeln(written) ; writeln(declined) ), "
            "rtl_io:rtl_fast_plain_text([a, [b|_], c], Text), writeln(Text)")
    done = subprocess.run([swipl, "-g", f"use_module('{ROOT / 'prolog_runtime' / 'rtl_io'}')", "-g", goal,
                           "-t", "halt"], capture_output=True, text=True, timeout=20)
    assert done.returncode == 0, done.stderr
    lines = done.stdout.splitlines()
    assert lines[:2] == ["declined", "declined"]
    assert lines[2].startswith("[a,[b|_") and lines[2].endswith("],c]")
