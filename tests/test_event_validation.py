"""Event input is validated strictly: a bad line is
rejected with its location and reason, counted and skipped, on both paths; UTF-8 with a
byte-order mark and non-ASCII atoms are accepted in programs and events."""
import json
import subprocess
from pathlib import Path

import pytest

from retalisc.compiler import compile_source
from retalisc.driver.engine import Engine

from stream_paths import PATHS, jsonl, run_path

PROGRAM = "seen(X) <- smoke(X).\nspan(X) <- smoke(X) where true.\n"

ROOT = Path(__file__).resolve().parent.parent
DEEP = 20_000

# (line text, what the message must say)
BAD = [
    ('{"event": "smoke(_)", "t": 1}', '"event" must be ground'),
    ('{"event": "smoke(s1, X)", "t": 1}', '"event" must be ground'),
    ('{"event": "smoke(s18). halt", "t": 1}', "text after the term"),
    ('{"event": "smoke(s18). smoke(s19).", "t": 1}', "text after the term"),
    ('{"event": "smoke(s1)", "t": 1}. {"x": 2}', "invalid JSON (text after the object)"),
    ('{"event": "smoke(s1)", "t": 1} {"x": 2}', "invalid JSON (text after the object)"),
    ('{"event": "smoke(s1)", "t": 1.0Inf}', "invalid JSON"),
    ('{"event": "smoke(s1)", "t": -1.0Inf}', "invalid JSON"),
    ('{"event": "smoke(s1)", "t": 1.5NaN}', "invalid JSON"),
    ('{"event": "smoke(s1)", "t": NaN}', "invalid JSON"),
    ('{"event": "smoke(s1)", "t": 1e400}', "invalid JSON (illegal_number)"),
    ('{"event": "smoke(s1)", "t": 0x10}', "invalid JSON"),
    ("{\"event\": \"smoke(s1)\", \"t\": 0'a}", "invalid JSON"),
    ('{"event": "smoke(s1)", "t": 1_000}', "invalid JSON"),
    ('{"event": "smoke(s1)", "t": 010}', "invalid JSON"),
    ('{"event": "smoke(s1)", "t": "5"}', '"t" must be a finite number'),
    ('{"event": "smoke(s1)", "t": inf}', "invalid JSON"),
    ('{"event": "smoke(s1)", "start": 5, "end": 3}', '"start" is after "end"'),
    ('{"event": "smoke(s1)", "start": 1, "end": "x"}', '"end" must be a finite number'),
    ('{"event": "smoke(s1)", "t": [5, -1]}', "nanoseconds must be in [0, 1e9)"),
    ('{"event": "smoke(s1)", "t": [5, 1000000000]}', "nanoseconds must be in [0, 1e9)"),
    ('{"event": "smoke(s1)", "t": [5, 0.5]}', '"t" must be a finite number'),
    ('{"event": "smoke(s1)", "t": 1, "x": foo}', "invalid JSON"),
    (json.dumps({"event": "smoke(" * DEEP + "s" + ")" * DEEP, "t": 1}), "nested deeper than 1,000 levels"),
    (json.dumps({"event": "smoke(" + "- " * DEEP + "1)", "t": 1}), "nested deeper than 1,000 levels"),
    ('{"event": "smoke(s1)", "t": ' + "[" * DEEP + "]" * DEEP + "}", "nested deeper than 1,000 levels"),
    ('{"event": "smoke(never)", "t": 1, "op": "retract"}', "not added"),
]

GOOD = [
    ('{"event": "smoke(a)", "t": 1}', (1, 1)),
    ('{"event": "smoke(b)", "t": [2, 500000000]}', (2.5, 2.5)),
    ('{"event": "smoke(c)", "start": 1e0, "end": 3.25E0}', (1.0, 3.25)),
    ('{"event": "smoke(d).", "t": -0.5}', (-0.5, -0.5)),
    ('{"event": "smoke([' + ", ".join(["1"] * 5000) + '])", "t": 4}', (4, 4)),       # long, not deep
    ('{"event": "smoke(a)", "t": 1, "op": "retract"}', None),
]


def test_engine_rejects_each_bad_line_with_its_reason():
    engine = Engine.from_source(PROGRAM, "validation.rtl")
    text = "\n".join([line for line, _ in BAD] + ['{"event": "smoke(ok)", "t": 9}'])
    produced, rejected = engine.feed_lines(text)
    assert [e.event for e in produced] == ["seen(ok)", "span(ok)"]
    assert [r.line for r in rejected] == list(range(1, len(BAD) + 1))
    for rejection, (line, expected) in zip(rejected, BAD):
        assert expected in rejection.reason, (line[:80], rejection.reason)
    stats = engine.stats()
    assert stats["rejected"] == len(BAD) and stats["retracted"] == 0 and stats["events"] == 1


def test_engine_accepts_the_good_lines():
    engine = Engine.from_source(PROGRAM, "validation.rtl")
    produced, rejected = engine.feed_lines("\n".join(line for line, _ in GOOD))
    assert rejected == []
    adds = [(e.start, e.end) for e in produced if e.op == "add" and e.event.startswith("seen")]
    assert adds == [times for _, times in GOOD if times]
    assert [e.event for e in produced if e.op == "retract"] == ["seen(a)", "span(a)"]
    assert engine.stats()["retracted"] == 1


def test_a_retraction_is_checked_against_what_was_added():
    engine = Engine.from_source(PROGRAM, "validation.rtl")
    lines = jsonl(("smoke(a)", 1), ("smoke(a)", 1, "retract"), ("smoke(a)", 1, "retract"), ("smoke(b)", 2, "retract"),
                  ("smoke(a)", 3), ("smoke(a)", 3), ("smoke(a)", 3, "retract"), ("smoke(a)", 3, "retract"))
    produced, rejected = engine.feed_lines(lines.rstrip("\n"))
    assert [r.line for r in rejected] == [3, 4]
    assert "smoke(a)" in rejected[0].reason and "not added" in rejected[0].reason
    assert engine.stats()["retracted"] == 3


@pytest.mark.parametrize("path", PATHS)
def test_both_paths_reject_the_same_lines(path, tmp_path, capfd):
    lines = [line for line, _ in BAD] + ['{"event": "smoke(ok)", "t": 9}']
    result = run_path(path, tmp_path, PROGRAM, "\n".join(lines) + "\n", capfd=capfd)
    assert result.returncode == 0, result.stderr[-2000:]
    assert result.events == ["seen(ok)", "span(ok)"]
    for number, (_, expected) in enumerate(BAD, start=1):
        prefix = f"{result.location(number)} rejected: "
        message = next((m for m in result.stderr.splitlines() if m.startswith(prefix)), None)
        assert message is not None and expected in message, (number, result.stderr[-3000:])
    assert f"{len(BAD)} rejected" in result.stderr.splitlines()[-1]


UNICODE_PROGRAM = "\ufeff% Rauchmelder\nalarm(X) <- rauch_ü(X) seq hitze(X).\nort('Küche').\n"


@pytest.mark.parametrize("path", PATHS)
@pytest.mark.parametrize("stdin", [False, True], ids=["file", "stdin"])
def test_utf8_byte_order_mark_and_non_ascii_atoms(path, stdin, tmp_path, capfd):
    events = "\ufeff" + jsonl(("rauch_ü(küche)", 1), ("hitze(küche)", 2), ("rauch_ü('Bad')", 3), ("hitze('Bad')", 4))
    result = run_path(path, tmp_path, UNICODE_PROGRAM, events, stdin=stdin, capfd=capfd)
    assert result.returncode == 0, result.stderr
    assert result.events == ["alarm(küche)", "alarm('Bad')"]
    assert "rejected" not in result.stderr.replace("0 rejected", "")


def test_non_ascii_names_in_programs():
    from retalisc.frontend.parser import read_term
    from retalisc.frontend.terms import Compound, Var

    term = read_term("alarm(Ort) <- rauch_ü(Ort) seq 'Hitze'(Über)")
    assert isinstance(term, Compound) and term.name == "<-"
    pattern = term.args[1]
    assert pattern.args[0].name == "rauch_ü"
    assert isinstance(pattern.args[1].args[0], Var) and pattern.args[1].args[0].name == "Über"
    result = compile_source("p(X) <- größe(X, Ä).\n", "names.rtl")     # Ä is a variable
    assert "ele_trigger('größe'(X, Ä)" in result.prolog


def test_remembered_events_plunit(swipl):
    """rtl_seen.pl (what retractions are checked against): bounded memory on a long stream,
    and agreement with a list model on random adds and retractions."""
    proc = subprocess.run([swipl, "--no-tty", "-q", "-g", "run_tests", "-t", "halt",
                           str(ROOT / "prolog_runtime" / "tests" / "test_seen.pl")],
                          stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, timeout=120)
    assert proc.returncode == 0 and "ERROR" not in proc.stdout, proc.stdout
