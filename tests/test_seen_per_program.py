"""The seen store (prolog_runtime/rtl_seen.pl: the input events remembered to check
retractions) belongs to the program that was active: Engines of one process keep their own
(Engine.activate), a retraction is checked against the Engine's own events, and a snapshot
holds only its program's."""
import json

from retalisc.driver.engine import Engine

PROGRAM = "c(X) <- (a(X) seq b(X)).1000.\n"


def _line(event, t, op="add"):
    return json.dumps({"event": event, "t": t, "op": op})


def _seen_lines(path):
    return [line for line in path.read_text(encoding="utf-8").splitlines()
            if line.startswith("fact(rtl_seen")]


def test_engines_keep_their_own_seen_events(tmp_path):
    a = Engine.from_source(PROGRAM, name="seen_a.rtl")
    b = None
    try:
        _, rejected = a.feed_lines(_line("a(only_a)", 1.0))
        assert rejected == []
        b = Engine.from_source(PROGRAM, name="seen_b.rtl")
        _, rejected = b.feed_lines(_line("a(only_b)", 2.0))
        assert rejected == []
        b.save_state(tmp_path / "b.state")
        seen_b = _seen_lines(tmp_path / "b.state")
        assert any("only_b" in line for line in seen_b) and all("only_a" not in line for line in seen_b)
        _, rejected = b.feed_lines(_line("a(only_a)", 1.0, "retract"))          # A's event, not B's
        assert len(rejected) == 1 and "was not added" in rejected[0].reason
        a.activate()
        a.save_state(tmp_path / "a.state")
        seen_a = _seen_lines(tmp_path / "a.state")
        assert any("only_a" in line for line in seen_a) and all("only_b" not in line for line in seen_a)
        _, rejected = a.feed_lines(_line("a(only_b)", 2.0, "retract"))
        assert len(rejected) == 1
        _, rejected = a.feed_lines(_line("a(only_a)", 1.0, "retract"))          # its own: accepted
        assert rejected == []
        b.activate()
        _, rejected = b.feed_lines(_line("a(only_b)", 2.0, "retract"))
        assert rejected == []
    finally:
        for engine in (a, b):
            if engine is not None and not engine.closed:
                engine.close(run_pending=False)


def test_a_snapshot_restored_next_to_another_engine_keeps_both_stores(tmp_path):
    b = Engine.from_source(PROGRAM, name="seen_b2.rtl")
    b.feed_lines(_line("a(of_b)", 1.0))
    b.save_state(tmp_path / "b.state")
    b.close(run_pending=False)
    a = Engine.from_source(PROGRAM, name="seen_a2.rtl")
    a.feed_lines("\n".join(_line(f"a(of_a{i})", 1.0 + i) for i in range(3)))
    c = Engine.from_source(PROGRAM, name="seen_b2.rtl")
    try:
        c.restore_state(tmp_path / "b.state")         # its generation module is one A holds now
        c.save_state(tmp_path / "c.state")
        seen_c = _seen_lines(tmp_path / "c.state")
        assert any("of_b" in line for line in seen_c) and all("of_a" not in line for line in seen_c)
        _, rejected = c.feed_lines(_line("a(of_a0)", 1.0, "retract"))
        assert len(rejected) == 1
        _, rejected = c.feed_lines(_line("a(of_b)", 1.0, "retract"))
        assert rejected == []
        a.activate()
        _, rejected = a.feed_lines("\n".join(_line(f"a(of_a{i})", 1.0 + i, "retract") for i in range(3)))
        assert rejected == []
    finally:
        a.close(run_pending=False)
        c.close(run_pending=False)
