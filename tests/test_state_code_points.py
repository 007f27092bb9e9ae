"""A snapshot holding any character reads back (prolog_runtime/rtl_state.pl writes its lines
with rtl_write_readable/2 of rtl_text.pl): write_canonical/2 of SWI-Prolog 9 writes the code
points U+D8000..U+DFFFF as `\\xD8000\\`, which its own reader refuses, so a run whose recent
events held one could not be restored."""
import json
import subprocess
import sys
from pathlib import Path

from hypothesis import HealthCheck, given, settings, strategies as st

from retalisc.driver.engine import Engine
from retalisc.driver.values import quote_atom, write_term

ROOT = Path(__file__).resolve().parents[1]
PROGRAM = "c(X, Y) <- (a(X, Y) seq b(X)).1000.\n"


def _engine(tmp_path):
    engine = Engine.from_source(PROGRAM, name="points.rtl")
    # the first restore of a process changes the digest (reported to the lead): make one first
    engine.save_state(tmp_path / "initial.state")
    engine.restore_state(tmp_path / "initial.state")
    return engine

# every code point but NUL and the surrogates, the refused range D8000..DFFFF drawn often
CODE_POINT = st.one_of(st.integers(0xD8000, 0xDFFFF),
                       st.integers(1, 0xD7FF) | st.integers(0xE000, 0x10FFFF))
TEXT = st.lists(CODE_POINT, min_size=1, max_size=6).map(lambda cs: "".join(map(chr, cs)))


def test_a_character_write_canonical_writes_unreadably_round_trips(tmp_path):
    engine = _engine(tmp_path)
    engine.feed_batch([(f"a({quote_atom(chr(0xD8000))}, {write_term(chr(0xDFFFF) + 'x')})", 1.0)])
    digest = engine.state_digest()
    path = tmp_path / "s.state"
    engine.save_state(path)
    engine.feed_batch([("a(z, z)", 2.0)])
    engine.restore_state(path)
    assert engine.state_digest() == digest
    produced = engine.feed_batch([(f"b({quote_atom(chr(0xD8000))})", 3.0)])
    assert len(produced) == 1


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(texts=st.lists(st.tuples(TEXT, TEXT), min_size=1, max_size=4))
def test_snapshot_of_events_with_any_code_points_restores_the_same_state(tmp_path, texts):
    engine = _engine(tmp_path)
    try:
        batch = [(f"a({quote_atom(atom)}, {write_term(string)})", float(i + 1))
                 for i, (atom, string) in enumerate(texts)]
        engine.feed_batch(batch)
        digest = engine.state_digest()
        path = tmp_path / "points.state"
        engine.save_state(path)
        engine.feed_batch([("a(other, other)", 100.0)])
        assert engine.state_digest() != digest
        engine.restore_state(path)
        assert engine.state_digest() == digest
        # the restored partial matches complete, and the seen store allows exact retraction
        engine.feed_batch([(batch[0][0], 1.0, 1.0, "retract")])
    finally:
        engine.close(run_pending=False)


def test_recovery_through_run_state_with_such_an_event(tmp_path):
    program = tmp_path / "p.rtl"
    program.write_text(PROGRAM, encoding="utf-8")
    odd = chr(0xD8000) + chr(0xDABCD)
    events = tmp_path / "events.jsonl"
    with open(events, "w", encoding="utf-8") as stream:
        for i in range(40):
            x = quote_atom(odd + str(i % 3))
            stream.write(json.dumps({"event": f"a({x}, {write_term(odd)})", "t": i + 1.0}) + "\n")
            stream.write(json.dumps({"event": f"b({x})", "t": i + 1.5}) + "\n")
    cmd = [sys.executable, "-m", "retalisc", "run", str(program), "--events", str(events), "--batch-size", "10"]
    env = {"PYTHONPATH": str(ROOT), "PATH": str(Path(sys.executable).parent) + ":/usr/bin:/bin"}
    expected = subprocess.run(cmd + ["--out", str(tmp_path / "expected.jsonl")], env=env, capture_output=True,
                              text=True)
    assert expected.returncode == 0, expected.stderr
    state, out = tmp_path / "state", tmp_path / "out.jsonl"
    first = subprocess.run(cmd + ["--out", str(out), "--state", str(state), "--snapshot-every", "10"], env=env,
                           capture_output=True, text=True)
    assert first.returncode == 0, first.stderr
    assert list(state.glob("snapshot-*.state"))
    # a second start recovers from the newest snapshot (the run had ended: nothing more to do)
    again = subprocess.run(cmd + ["--out", str(out), "--state", str(state), "--snapshot-every", "10"], env=env,
                           capture_output=True, text=True)
    assert again.returncode == 0, again.stderr
    assert "not a readable snapshot" not in again.stderr
    assert out.read_bytes() == (tmp_path / "expected.jsonl").read_bytes()
