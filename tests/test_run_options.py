"""The run options are declared once (retalisc/run_options.py): the click options of
`retalisc run`, the flags an in-process run sets, the hand-over's argument list and the
runtime's reader of `swipl PROGRAM.pl --name=VALUE` (prolog_runtime/rtl_arguments.pl, by the
facts of rtl_run_options.pl written from the table) are all made from it. These tests fail
when one road lacks an option or reads it otherwise: every option of the table goes from the
command line of `retalisc run` through click, the hand-over's arguments and the runtime's
reader with a value that is not its default, and comes out equal, on the Python road too."""
from __future__ import annotations

import os
import subprocess
from pathlib import Path

import click
import pytest

from retalisc import run_options
from retalisc.commands.compile import run_command
from retalisc.driver.engine import Engine
from retalisc.driver.swipl_handover import swipl_arguments
from retalisc.robot_io.options import BAG_DEFAULTS
from retalisc.run_options import BY_NAME, PYTHON_ONLY, RUN_OPTIONS

ROOT = Path(__file__).resolve().parent.parent

#: Reads its command line as `swipl PROGRAM.pl` does (rtl_read_arguments/2) and prints where
#: each option went: `Option<TAB>Value` (writeq), then the files; `usage<TAB>Text` on a usage
#: error. Constant text: the runtime's directory comes from the environment.
DRIVER = r"""
:- initialization(main, main).
main :-
    getenv('RETALIS_RUNTIME', Dir),
    directory_file_path(Dir, retalis, Runtime),
    directory_file_path(Dir, rtl_arguments, Arguments),
    use_module(Runtime, []),
    use_module(Arguments),
    retalis:rtl_reset,                          % as a program's loading does
    current_prolog_flag(argv, Argv),
    nb_setval(rtl_stream_options, []),
    catch(( rtl_read_arguments(Argv, Files),
            forall(rtl_run_setting(Option, Value), format("~w\t~q~n", [Option, Value])),
            format("files\t~q~n", [Files]) ),
          error(Formal, _),
          ( rtl_usage_text(Formal, Text), format("usage\t~s~n", [Text]) )).
"""


def read_by_runtime(tmp_path: Path, argv):
    """What the runtime's reader makes of `argv`: {option: writeq text}, and "files"."""
    driver = tmp_path / "driver.pl"
    driver.write_text(DRIVER)
    done = subprocess.run(["swipl", "--no-packs", "-f", "none", str(driver), *argv], capture_output=True,
                          text=True, timeout=60, env={**os.environ, "RETALIS_RUNTIME": str(ROOT / "prolog_runtime")})
    assert done.returncode == 0, done.stderr
    return dict(line.split("\t", 1) for line in done.stdout.splitlines())


def samples(tmp_path: Path):
    """For each option of the table, a value that is not its default, twice: as the command
    line of `retalisc run` writes it, and as the runtime should hold it (writeq text)."""
    out = {}
    for option in RUN_OPTIONS:
        if option.kind == "switch":
            out[option.name] = (None, "true")
        elif option.kind == "count":
            n = 8 if option.default == 7 else 7
            out[option.name] = (f"{n:,}", str(n))         # 1,000 is taken as 1000 on the command line
        elif option.kind == "seconds":
            out[option.name] = ("2.5", "2.5")
        elif option.kind == "limit":
            out[option.name] = ("12345", "12345")
        elif option.kind == "directory":
            out[option.name] = (str(tmp_path / "consumers"), f"'{tmp_path / 'consumers'}'")
        elif option.kind == "file":
            out[option.name] = (str(tmp_path / "actions.txt"), f"'{tmp_path / 'actions.txt'}'")
        elif option.kind == "labels":
            out[option.name] = (None, "[r1,fire_alarm]")
        else:
            raise AssertionError(f"{option.name}: a kind this test does not know ({option.kind})")
    return out


def parsed_by_click(tmp_path: Path, argv):
    """`retalisc run PROGRAM ARGV` parsed by click (what run_command would be called with)."""
    program = tmp_path / "p.rtl"
    program.write_text("p(X) <- a(X).\n")
    context = run_command.make_context("run", [str(program), "--events", "-", *argv])
    return context.params


def cli_argv(sample):
    argv = []
    for option in run_options.cli_options():
        text, _ = sample[option.name]
        argv += [option.option] if option.kind == "switch" else [option.option, text]
    return argv


def test_the_runtime_table_is_the_one_the_python_table_makes():
    """prolog_runtime/rtl_run_options.pl is written by `python -m retalisc.run_options`."""
    run_options.check_table()
    assert run_options.TABLE_FILE.read_text(encoding="utf-8") == run_options.prolog_table(), \
        "prolog_runtime/rtl_run_options.pl is stale: run `python -m retalisc.run_options`"


def test_every_option_goes_through_click_the_hand_over_and_the_runtime_reader(tmp_path):
    sample = samples(tmp_path)
    values = parsed_by_click(tmp_path, cli_argv(sample))
    runtime = {name: values[name] for name in BY_NAME if name in values}
    assert set(runtime) == {o.name for o in RUN_OPTIONS if o.cli}
    runtime["detections"] = ["r1", "fire_alarm"]
    argv = run_options.arguments(runtime) + ["e.jsonl"]
    read = read_by_runtime(tmp_path, argv)
    assert read.pop("files") == "['e.jsonl']"
    assert read == {option.option[2:]: sample[option.name][1] for option in RUN_OPTIONS}
    # the hand-over (retalisc run's own road): every option it may hand over, read the same
    handed = {name: value for name, value in values.items() if name in BY_NAME and BY_NAME[name].handed_over}
    arguments = swipl_arguments("e.jsonl", ["r1", "fire_alarm"], **handed)
    assert arguments is not None and arguments[-1] == "e.jsonl"
    assert set(arguments) <= set(argv)
    read = read_by_runtime(tmp_path, arguments)
    for option in RUN_OPTIONS:
        if option.handed_over:
            assert read[option.option[2:]] == sample[option.name][1], option.name


@pytest.mark.parametrize("kind", ["count", "seconds", "limit"])
def test_inf_goes_through_every_road(tmp_path, kind):
    names = [o.name for o in RUN_OPTIONS if o.kind == kind]
    values = parsed_by_click(tmp_path, [arg for name in names for arg in (BY_NAME[name].option, "inf")])
    read = read_by_runtime(tmp_path, swipl_arguments("-", [], **{name: values[name] for name in names}))
    assert {name: read[BY_NAME[name].option[2:]] for name in names} == {name: "inf" for name in names}


def test_the_runtime_defaults_are_the_table_defaults(tmp_path):
    read = read_by_runtime(tmp_path, ["e.jsonl"])
    for option in RUN_OPTIONS:
        if option.road[0] == "action_output":
            expected = "user_error"                 # no file: standard error
        elif option.default is None or option.default is False:
            expected = "none" if option.default is None else "false"
        else:
            expected = str(option.default)
        assert read[option.option[2:]] == expected, option.name


def test_the_python_road_sets_the_same_flags(tmp_path):
    """An in-process run sets its Engine's flags from the same table (engine_flags)."""
    sample = samples(tmp_path)
    values = parsed_by_click(tmp_path, cli_argv(sample))
    flags = run_options.engine_flags(values)
    assert {flag for flag, _ in flags} == {o.road[1] for o in RUN_OPTIONS if o.road[0] == "flag"}
    engine = Engine.from_source("p(X) <- a(X).\n")
    try:
        for flag, text in flags:
            engine.set_flag(flag, text)
        for option in RUN_OPTIONS:
            if option.road[0] == "flag":
                answer = engine.query(f"rtl_flag({option.road[1]}, V)")
                assert answer == {"V": sample[option.name][1]}, option.name
    finally:
        engine.close()


def test_every_parameter_of_run_is_declared_once():
    """A parameter of `retalisc run` is a table option, one Python serves (PYTHON_ONLY) or a
    --bag option; none is two of them."""
    parameters = {param.name for param in run_command.params}
    table = {o.name for o in RUN_OPTIONS if o.cli}
    bag = set(BAG_DEFAULTS) | {"bag"}
    assert parameters == table | set(PYTHON_ONLY) | bag
    assert not (table & set(PYTHON_ONLY)) and not (table & bag) and not (set(PYTHON_ONLY) & bag)
    context = click.Context(run_command)
    for param in run_command.params:
        if param.name in table:
            option = BY_NAME[param.name]
            assert param.opts == [option.option] and param.get_default(context) in (None, False)
            assert param.help == option.help_text() and "{default}" not in param.help


def test_the_hand_over_refuses_what_it_cannot_say():
    with pytest.raises(TypeError, match="no_such_option"):
        swipl_arguments("e.jsonl", [], no_such_option=1)
    with pytest.raises(TypeError, match="detections"):          # not an option of retalisc run
        swipl_arguments("e.jsonl", [], detections=["r1"])
    assert swipl_arguments("e.jsonl", [], consumer_dir="DIR") is None      # served in Python
    assert swipl_arguments("e.jsonl", [], action_output="FILE") is None
    assert swipl_arguments("e.jsonl", [], strict=False, max_delay=None) == ["--detections=", "e.jsonl"]


@pytest.mark.parametrize("argv, message", [
    (["--max-steps=0"], "error: --max-steps=0: expected a positive integer or inf"),
    (["--max-line-bytes=1.5"], "error: --max-line-bytes=1.5: expected a positive integer or inf"),
    (["--max-delay=abc"], "error: --max-delay=abc: expected a number of seconds >= 0 or inf"),
    (["--max-future=-1"], "error: --max-future=-1: expected a number of seconds >= 0 or inf"),
    (["--max-delay=nan"], "error: --max-delay=nan: expected a number of seconds >= 0 or inf"),
    (["--nope"], "error: unknown option --nope"),
    (["--strict=true"], "error: unknown option --strict=true"),     # a switch takes no value
    (["--max-delay"], "error: unknown option --max-delay"),        # and the others one
])
def test_the_runtime_reader_refuses_bad_arguments(tmp_path, argv, message):
    assert read_by_runtime(tmp_path, [*argv, "e.jsonl"]) == {"usage": message}


def test_the_usage_line_names_every_option():
    done = subprocess.run(["swipl", "--no-packs", "-f", "none", "-g",
                           "use_module(rtl_arguments), rtl_usage_text(no_event_file, T), write(T)", "-t", "halt"],
                          capture_output=True, text=True, timeout=60, cwd=ROOT / "prolog_runtime")
    assert done.stdout.startswith("usage: swipl PROGRAM.pl "), done.stderr
    for option in RUN_OPTIONS:
        expected = f"[{option.option}]" if option.kind == "switch" else f"[{option.option}={option.metavar}]"
        assert expected in done.stdout, option.name


def test_click_refuses_what_the_runtime_refuses(tmp_path):
    for argv in (["--max-steps", "0"], ["--max-timers", "x"], ["--max-future", "-1"], ["--max-delay", "nan"]):
        with pytest.raises(click.BadParameter):
            parsed_by_click(tmp_path, argv)
