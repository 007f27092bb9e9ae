"""The command line as users script it : outputs, exit codes, messages."""
import json
import os
import subprocess
import sys
from pathlib import Path

import pytest
from click.testing import CliRunner

from retalisc.cli import main

ROOT = Path(__file__).resolve().parent.parent
FIRE = ROOT / "examples" / "fire_alarm"


def retalisc(*args, cwd=None, input=None):
    return subprocess.run([sys.executable, "-m", "retalisc", *map(str, args)], capture_output=True, text=True,
                          cwd=cwd, input=input, timeout=120)


def test_compile_then_swipl_from_another_directory(tmp_path, swipl):
    out = tmp_path / "fire.pl"
    assert retalisc("compile", FIRE / "fire_alarm.rtl", "-o", out).returncode == 0
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    run = subprocess.run([swipl, str(out), str(FIRE / "events.jsonl")], capture_output=True, text=True,
                         cwd=elsewhere, timeout=60)
    assert run.returncode == 0
    assert run.stdout == (FIRE / "expected.jsonl").read_text()
    assert "8 events" in run.stderr and "3 derived" in run.stderr


def test_compile_is_deterministic(tmp_path):
    first = retalisc("compile", FIRE / "fire_alarm.rtl").stdout
    second = retalisc("compile", FIRE / "fire_alarm.rtl").stdout
    assert first == second and "ele_trigger(smoke(S1)" in first
    assert "% " + str(FIRE / "fire_alarm.rtl") in first or "fire_alarm.rtl" in first


def test_run_prints_the_same_lines_as_swipl():
    run = retalisc("run", FIRE / "fire_alarm.rtl", "--events", FIRE / "events.jsonl")
    assert run.returncode == 0
    assert run.stdout == (FIRE / "expected.jsonl").read_text()
    for line in run.stdout.splitlines():
        assert set(json.loads(line)) == {"event", "start", "end"}


def test_run_echo_input_and_stdin():
    events = '{"event": "smoke(smoke_1)", "t": 1}\n{"event": "high_temperature(temp_1)", "t": 2}\n'
    run = retalisc("run", FIRE / "fire_alarm.rtl", "--events", "-", "--echo-input", input=events)
    lines = [json.loads(line) for line in run.stdout.splitlines()]
    assert [line["event"] for line in lines] == ["smoke(smoke_1)", "high_temperature(temp_1)",
                                                "fire_alarm(smoke_1,temp_1)"]


def test_bad_event_lines_are_counted_and_skipped(tmp_path):
    events = tmp_path / "events.jsonl"
    events.write_text('{"event": "smoke(smoke_1)", "t": 1}\nnot json\n{"event": "x(Y)", "t": 2}\n\n'
                      '{"event": "high_temperature(temp_1)", "t": 3}\n')
    run = retalisc("run", FIRE / "fire_alarm.rtl", "--events", events)
    assert run.returncode == 0
    assert json.loads(run.stdout)["event"] == "fire_alarm(smoke_1,temp_1)"
    assert f"{events}:2: rejected: invalid JSON" in run.stderr
    assert f"{events}:3: rejected: \"event\" must be ground" in run.stderr
    assert "2 rejected" in run.stderr


@pytest.mark.parametrize("program, where, message", [
    ("h(X) <- a(X) seq.\n", "bad.rtl:1:14:", "syntax error"),
    ("h(X) <- a(X) SEQ b(X).\n", "bad.rtl:1:14:", "'seq'"),
    ("ok.\nh(X, Y) <- a(X).\n", "bad.rtl:2:6:", "does not occur in the pattern"),
])
def test_program_errors_exit_2_with_location(tmp_path, program, where, message):
    path = tmp_path / "bad.rtl"
    path.write_text(program)
    for command in (["compile", path], ["check", path], ["run", path, "--events", path]):
        result = retalisc(*command, cwd=tmp_path)
        assert result.returncode == 2
        assert result.stderr.startswith(str(path).replace("bad.rtl", "") + where) or where in result.stderr
        assert message in result.stderr
        assert "Traceback" not in result.stderr
        assert result.stderr.splitlines()[-1].strip() == "^"


def test_dump_after_binarize():
    run = retalisc("compile", FIRE / "fire_alarm.rtl", "--dump-after", "binarize")
    assert run.returncode == 0
    assert "e_r1_1(S1, S2) <- smoke(S1) and high_temperature(S2) where nearby(S1, S2) within 300" in run.stdout


def test_dump_after_an_active_query_pass(tmp_path):
    program = tmp_path / "path.pl"
    program.write_text("edge(1,2).\npath(X,Y) :- edge(X,Y).\npath(X,Y) :- edge(X,Z), path(Z,Y).\n")
    run = retalisc("compile", program, "--active-queries", "naive", "--dump-after", "aq_naive")
    assert run.returncode == 0, run.stderr
    assert run.stdout.startswith("% retalisc: the program after pass 'aq_naive'\n\n% transformation: naive\n")
    assert "    path(Z, Y).  % call" in run.stdout and "% rule 3 (added by the transformation)" in run.stdout
    run = retalisc("compile", program, "--active-queries", "tabled", "--dump-after", "aq_program")
    assert run.returncode == 0 and "    edge(X, Y).  % fact" in run.stdout
    for wrong in (["--active-queries", "tabled", "--dump-after", "aq_naive"], ["--dump-after", "aq_tabled"]):
        run = retalisc("compile", program, *wrong)
        assert run.returncode == 2 and "this compilation runs the passes" in run.stderr


def test_check_ok_and_usage_error(tmp_path):
    assert retalisc("check", FIRE / "fire_alarm.rtl").returncode == 0
    assert retalisc("compile", tmp_path / "missing.rtl").returncode == 2
    assert retalisc("compile", FIRE / "fire_alarm.rtl", "--dump-after", "nonsense").returncode == 2


def test_swipl_without_event_file_is_a_usage_error(tmp_path, swipl):
    out = tmp_path / "fire.pl"
    retalisc("compile", FIRE / "fire_alarm.rtl", "-o", out)
    run = subprocess.run([swipl, str(out)], capture_output=True, text=True, timeout=60)
    assert run.returncode == 2 and "usage" in run.stderr


def test_rule_changes_in_the_event_stream_report_bad_lines():
    case = ROOT / "tests" / "golden" / "stream_rule_changes"
    run = retalisc("run", case / "program.rtl", "--events", case / "events.jsonl", "--allow-control")
    assert run.returncode == 0
    assert ":6: rejected: " in run.stderr and "does not occur in the pattern" in run.stderr
    assert ":10: rejected: event_rule `nosuch' does not exist" in run.stderr
    assert ":11: rejected: \"op\": \"add_rule\" needs \"rule\"" in run.stderr


@pytest.mark.parametrize("mode", ["naive", "optimized", "tabled"])
def test_compile_active_queries_runs_in_plain_swipl(tmp_path, swipl, mode):
    program = tmp_path / "path.pl"
    program.write_text("edge(1,2).\nedge(2,3).\npath(X,Y) :- edge(X,Y).\npath(X,Y) :- edge(X,Z), path(Z,Y).\n")
    out = tmp_path / "path_aq.pl"
    assert retalisc("compile", program, "--active-queries", mode, "-o", out).returncode == 0
    goal = ("aq_register(q, path(1,X)), aq_events(E1), aq_assert(edge(3,4)), aq_events(E2), "
            "aq_retract(edge(1,2)), aq_events(E3), print([E1, E2, E3]), nl")
    run = subprocess.run([swipl, "-g", goal, "-t", "halt", str(out)], capture_output=True, text=True, timeout=60)
    assert run.returncode == 0, run.stderr
    initial, added, deleted = run.stdout.strip()[2:-2].split("],[")
    assert "path(1,2)" in initial and "path(1,3)" in initial
    assert added == "ev(q,add,path(1,4))"
    assert all(p in deleted for p in ("path(1,2)", "path(1,3)", "path(1,4)")) and "delete" in deleted


def test_commands_are_imported_when_used():
    """`retalisc.commands` names each module's commands; a command imports only its own
    module, and `run --help` does not import the compiler."""
    import importlib

    from retalisc.commands import COMMAND_MODULES

    for module, names in COMMAND_MODULES.items():
        try:
            commands = importlib.import_module(module).COMMANDS
        except ModuleNotFoundError:
            continue
        assert tuple(command.name for command in commands) == names
    probe = ("import sys; from retalisc.cli import main\n"
             "try:\n    main(['run', '--help'])\nexcept SystemExit:\n    pass\n"
             "print(sorted(m for m in sys.modules if m.split('.')[0] in ('lark', 'jinja2') "
             "or m.startswith(('retalisc.commands.', 'retalisc.passes', 'retalisc.frontend.parser'))))")
    done = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, timeout=60,
                          env={**os.environ, "PYTHONPATH": str(ROOT)})
    assert "--events" in done.stdout
    assert done.stdout.splitlines()[-1] == "['retalisc.commands.compile', 'retalisc.commands.options']"
    listing = CliRunner().invoke(main, ["--help"]).output
    assert all(f"  {name} " in listing for names in COMMAND_MODULES.values() for name in names
               if name not in ("ros", "ros2", "zenoh"))
    assert CliRunner().invoke(main, ["no-such"]).exit_code == 2


def test_compile_output_dash_is_standard_output(tmp_path):
    to_stdout = retalisc("compile", FIRE / "fire_alarm.rtl", cwd=tmp_path)
    dash = retalisc("compile", FIRE / "fire_alarm.rtl", "-o", "-", cwd=tmp_path)
    assert dash.returncode == 0
    assert dash.stdout == to_stdout.stdout != ""
    assert not (tmp_path / "-").exists()
