"""`retalisc aq --state DIR` (docs/recovery.md): snapshots of active queries (their tables,
consumer and goal records, the stored facts, rules added at run time) restore the state
exactly, a script stopped at any point and restored goes on as a script that never stopped,
and the --out file of a recoverable run equals that of a plain `retalisc aq` run, also when
the script stops at a bad line. (Killing it with SIGKILL: tests/test_recovery_run.py.)"""
import io
import random

import pytest
from click.testing import CliRunner
from hypothesis import HealthCheck, given, settings, strategies as st

from retalisc.cli import main
from retalisc.driver import recovery
from retalisc.driver.active_queries import ActiveQueries

# recursion (tables with answers of answers), left recursion (states that are joins of a
# consumer with its table, without goal records), a stored-fact query, a rule added and
# removed at run time (its clause references are in the state), a negation, a rule for a
# predicate with stored facts only (its clauses rewritten to wait on its table)
PROGRAM = """\
path(X, Y) :- edge(X, Y).
path(X, Y) :- edge(X, Z), path(Z, Y).
reach(X) :- path(0, X).
lonely(X) :- node(X), \\+ reach(X).
weight(Y) :- w(X), Y is X + 1.
lpath(X, Y) :- lpath(X, Z), edge(Z, Y).
lpath(X, Y) :- edge(X, Y).
:- dynamic w/1.
node(0). node(1). node(2). node(3). node(4). node(5). node(6). node(7).
edge(0, 1).
edge(1, 2).
"""


def write_script(path, commands, seed):
    """An update script of `commands` lines: queries registered (and one unregistered and
    registered again), edges asserted and retracted, a rule added and removed, comments."""
    rng = random.Random(seed)
    lines = ["?q1 path(X, Y).", "?q2 reach(X).", "?q3 path(1, Y).", "?q4 lonely(X).", "?q5 edge(X, 3).",
             "?q6 weight(W).", "?q7 lpath(0, Y).",
             "+(w(X) :- node(X), X > 5)."]      # w/1 had stored facts only: now a mixed predicate
    edges, rule, q3 = set(), False, True
    while len(lines) < commands:
        r = rng.random()
        if r < 0.45:
            edge = (rng.randint(0, 7), rng.randint(0, 7))
            edges.add(edge)
            lines.append(f"+edge({edge[0]}, {edge[1]}).")
        elif r < 0.9 and edges:
            edge = rng.choice(sorted(edges))
            edges.discard(edge)
            lines.append(f"-edge({edge[0]}, {edge[1]}).")
        elif r < 0.94:
            lines.append(("-" if rule else "+") + "(path(X, Y) :- edge(Y, X), node(X)).")
            rule = not rule
        elif r < 0.97:
            lines.append("!q3." if q3 else "?q3 path(1, Y).")
            q3 = not q3
        else:
            lines.append("% a comment")
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")


class Case(tuple):
    def __repr__(self):
        return "Case(...)"


@pytest.fixture(scope="module")
def case(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("aq_recovery")
    program = tmp / "program.pl"
    program.write_text(PROGRAM, encoding="utf-8")
    script = tmp / "script.txt"
    write_script(script, 250, 7)
    expected = tmp / "expected.jsonl"
    done = CliRunner().invoke(main, ["aq", str(program), "--script", str(script), "--out", str(expected)])
    assert done.exit_code == 0, done.output
    assert expected.stat().st_size > 10_000
    return Case((tmp, program, script, expected.read_bytes()))


_FULL = {}


def _full_output(program, script, subsumption):
    if subsumption not in _FULL:
        batch = ActiveQueries.from_file(program, subsumption=subsumption).run_script_batch(script, 1, 10 ** 9)
        assert batch.status == "done"
        _FULL[subsumption] = batch.output
    return _FULL[subsumption]


@settings(max_examples=6, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(split=st.integers(min_value=0, max_value=250), subsumption=st.booleans())
def test_stopped_saved_restored_into_a_new_load_goes_on_as_if_never_stopped(case, tmp_path, split, subsumption):
    _, program, script, expected = case
    full = _full_output(program, script, subsumption)
    assert full.encode("utf-8") == expected
    aq = ActiveQueries.from_file(program, subsumption=subsumption)
    first = aq.run_script_batch(script, 1, split)
    digest = aq.state_digest()
    aq.save_state(tmp_path / "s.state")
    again = ActiveQueries.from_file(program, subsumption=subsumption)    # as after a restart: loaded anew
    assert again.state_digest() != digest or split == 0
    again.restore_state(tmp_path / "s.state")
    assert again.state_digest() == digest
    rest = again.run_script_batch(script, first.next_line, 10 ** 9)
    assert first.output + rest.output == full


def test_an_event_program_run_earlier_in_the_process_does_not_change_a_restore(case, tmp_path):
    # The event engine's modules (rtl_ele, rtl_tf) share the process: a restore that tidies
    # their idle hooks once set a global the snapshot did not hold, and the digests differed.
    from retalisc.driver.engine import Engine
    engine = Engine.from_source("b(X) <- a(X).\n")
    engine.on_output(lambda out: None)
    assert [out.name for out in engine.feed("a(1)", 1)] == ["b"]
    _, program, script, _ = case
    aq = ActiveQueries.from_file(program)
    aq.run_script_batch(script, 1, 100)
    digest = aq.state_digest()
    aq.save_state(tmp_path / "s.state")
    again = ActiveQueries.from_file(program)
    again.restore_state(tmp_path / "s.state")
    assert again.state_digest() == digest


def test_snapshot_of_another_program_is_refused_and_changes_nothing(case, tmp_path):
    _, program, script, _ = case
    aq = ActiveQueries.from_file(program)
    aq.run_script_batch(script, 1, 50)
    aq.save_state(tmp_path / "s.state")
    other = tmp_path / "other.pl"
    other.write_text(PROGRAM + "extra(1).\n", encoding="utf-8")
    aq2 = ActiveQueries.from_file(other)
    digest = aq2.state_digest()
    with pytest.raises(recovery.StateError, match="another program or runtime version"):
        aq2.restore_state(tmp_path / "s.state")
    assert aq2.state_digest() == digest


def _aq(program, script, out, state=None, every=None, extra=()):
    args = ["aq", str(program), "--script", str(script), "--out", str(out), *extra]
    if state is not None:
        args += ["--state", str(state), "--snapshot-every", str(every)]
    return CliRunner().invoke(main, args)


def test_recoverable_run_restarted_from_each_snapshot_ends_with_the_plain_output(case, tmp_path):
    _, program, script, expected = case
    out, state = tmp_path / "out.jsonl", tmp_path / "state"
    done = _aq(program, script, out, state, 60)
    assert done.exit_code == 0, done.output
    assert out.read_bytes() == expected
    manifests = sorted(state.glob("snapshot-*.json"))
    assert len(manifests) == 2                       # the two newest are kept
    # a restart from the older one (the newer deleted): the file is cut back and written again
    manifests[-1].unlink()
    with open(out, "ab") as stream:
        stream.write(b'{"query": "q1", "op": "ad')   # as if killed in the middle of a line
    log = io.StringIO()
    status = recovery.run_aq_recoverable(ActiveQueries.from_file(program), str(script), str(out), state,
                                         snapshot_commands=60, log=log)
    assert status == 0
    assert "restored snapshot" in log.getvalue()
    assert out.read_bytes() == expected


@pytest.mark.parametrize("bad, status, message", [
    ("+edge(1, .", 2, "error: "),
    ("+w(a).", 1, "runtime error"),
])
def test_a_bad_line_stops_the_recoverable_run_as_the_plain_one(case, tmp_path, bad, status, message):
    _, program, _, _ = case
    script = tmp_path / "bad.txt"
    write_script(script, 150, 3)
    lines = script.read_text(encoding="utf-8").splitlines()
    lines.insert(120, bad)
    script.write_text("\n".join(lines) + "\n", encoding="utf-8")
    plain = _aq(program, script, tmp_path / "plain.jsonl")
    recoverable = _aq(program, script, tmp_path / "state.jsonl", tmp_path / "state", 25)
    assert plain.exit_code == recoverable.exit_code == status
    assert f"{script}:121: {message}" in plain.output
    assert f"{script}:121: {message}" in recoverable.output
    assert (tmp_path / "plain.jsonl").read_bytes() == (tmp_path / "state.jsonl").read_bytes()
    assert (tmp_path / "plain.jsonl").stat().st_size > 1000


def test_state_needs_an_output_file(case, tmp_path):
    _, program, script, _ = case
    done = CliRunner().invoke(main, ["aq", str(program), "--script", str(script), "--state", str(tmp_path / "s")])
    assert done.exit_code == 2 and "--state needs --out FILE" in done.output


def test_snapshot_of_a_run_over_another_script_is_refused(case, tmp_path):
    _, program, script, _ = case
    state = tmp_path / "state"
    assert _aq(program, script, tmp_path / "a.jsonl", state, 100).exit_code == 0
    other = tmp_path / "other.txt"
    other.write_text("?q1 path(X, Y).\n", encoding="utf-8")
    done = _aq(program, other, tmp_path / "b.jsonl", state, 100)
    assert done.exit_code == 2 and "belongs to a run over" in done.output
    assert "Traceback" not in done.output
