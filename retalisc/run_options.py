"""The run options, declared once: what `retalisc run` takes that reaches the runtime, and
what `swipl PROGRAM.pl` takes on its command line.

Each `RunOption` says the option's name, the kind of its value, the runtime's default, its
help text and how it reaches the runtime (its `road`). Everything else is made from this
table:

- the click options of `retalisc run` (retalisc/commands/options.py, `run_options`);
- the flags an in-process run sets on its Engine (`engine_flags`);
- the argument list of the hand-over to `swipl` (`arguments`; retalisc/driver/swipl_handover.py);
- the runtime's own reader of `swipl PROGRAM.pl --name=VALUE ...`: prolog_runtime/rtl_arguments.pl
  reads the table as the Prolog facts of prolog_runtime/rtl_run_options.pl, written from
  this table by `python -m retalisc.run_options` (`prolog_table`; a test fails when that file
  is not what this table makes), and the runtime's flag defaults are those facts.

Adding an option is one entry here, then `python -m retalisc.run_options`.
"""
from __future__ import annotations

import math
import re
from dataclasses import dataclass
from pathlib import Path
from typing import Dict, Iterable, List, Optional, Tuple

#: The kinds of value, with what the runtime's reader takes (rtl_arguments.pl, kind/3):
#:   switch     no value: `--name` (true when given);
#:   count      a positive integer or `inf`;
#:   seconds    a number >= 0 or `inf` (written as Python's repr of a float: `1.0`);
#:   limit      a number of seconds >= 0 or `inf`, written as an integer when it is one;
#:   directory, file   a path;
#:   labels     rule labels, comma-separated (names).
KINDS = ("switch", "count", "seconds", "limit", "directory", "file", "labels")

#: The roads to the runtime (rtl_arguments.pl, apply/2):
#:   ("flag", F)       the runtime flag F (rtl_set_flag/2; Engine.set_flag in Python);
#:   ("stream", O)     the line loop's option O(true) (Python passes it to the run loop);
#:   ("global", K)     the runtime's global variable K (Python passes it to the run loop);
#:   ("consumer_dir", "")  rtl_consumer_dir/1;   ("action_output", "")  rtl_set_action_output/1.
ROADS = ("flag", "stream", "global", "consumer_dir", "action_output")


@dataclass(frozen=True)
class RunOption:
    """One run option. `name` is the Python name (`max_delay`: `--max-delay`); `default` is
    what the runtime holds when the option is not given (None: nothing); `cli`: an option of
    `retalisc run`; `handed_over`: `retalisc run` may hand a run with it over to `swipl`
    (otherwise the run stays in Python, which serves it)."""

    name: str
    kind: str
    default: object
    help: str
    road: Tuple[str, str]
    metavar: Optional[str] = None
    cli: bool = True
    handed_over: bool = True

    @property
    def option(self) -> str:
        return "--" + self.name.replace("_", "-")

    def text(self, value) -> str:
        """The value as the runtime's reader takes it (after `--name=`)."""
        if value == "inf" or (isinstance(value, float) and math.isinf(value) and value > 0):
            return "inf"
        if self.kind == "count":
            return str(int(value))
        if self.kind == "seconds":
            return repr(float(value))
        if self.kind == "limit":
            number = float(value)
            return str(int(number)) if number.is_integer() else repr(number)
        if self.kind == "labels":
            return ",".join(value)
        if self.kind == "switch":
            return "true"
        return str(value)

    def argument(self, value) -> str:
        """The command-line argument of `swipl PROGRAM.pl` for this value."""
        return self.option if self.kind == "switch" else f"{self.option}={self.text(value)}"

    def default_text(self) -> str:
        """The default as the help texts say it (`{default}` in `help`)."""
        if self.default == "inf":
            return "'inf'"
        return str(self.default)

    def help_text(self) -> str:
        return self.help.replace("{default}", self.default_text())


RUN_OPTIONS: List[RunOption] = [
    RunOption("echo_input", "switch", False, "Also write the input events to the output.",
              ("flag", "echo_input")),
    RunOption("max_delay", "seconds", 1.0,
              "Seconds an event may arrive behind the latest one and still be matched in full "
              "(default {default}; a number >= 0, or inf).", ("flag", "max_delay"), metavar="SECONDS"),
    RunOption("retraction_horizon", "seconds", "auto",
              "Keep what deletions need for this long: a deletion of an event that ended at most "
              "SECONDS before the latest one is exact (default and minimum: the delay bound plus the "
              "largest window; 'inf' keeps everything). Later deletions are reported and change nothing.",
              ("flag", "retraction_horizon"), metavar="SECONDS"),
    RunOption("max_steps", "count", 1_000_000,
              "Inferences one input event may take, everything it derives included, before it is "
              "stopped with an error (default {default}; 'inf' for no limit).", ("flag", "max_steps"), metavar="N"),
    RunOption("max_timers", "count", 100_000,
              "Timers (absences, alarms) that may be pending at once; one more is not set, but counted "
              "and reported as a warning (default {default}; 'inf' for no limit).", ("flag", "max_timers"),
              metavar="N"),
    RunOption("max_event_types", "count", "inf",
              "Distinct event types (Name/Arity) the run takes; a line of a new type beyond them is "
              "rejected (default {default}: SWI-Prolog keeps each type's functor, ~140 bytes, for good).",
              ("flag", "max_event_types"), metavar="N"),
    RunOption("max_line_bytes", "count", 1_048_576,
              "The longest input line, in bytes; a longer one is rejected, read without being kept "
              "(default {default}; 'inf' for no limit; docs/runtime.md, \"Input limits\").",
              ("flag", "max_line_bytes"), metavar="N"),
    RunOption("max_digits", "count", 4300,
              "The longest run of digits in an input line (a number's size); a line with a longer one is "
              "rejected before any number of it is read (default {default}; 'inf' for no limit).",
              ("flag", "max_digits"), metavar="N"),
    RunOption("max_future", "limit", 86400,
              "How far after the clock (and the wall clock) an input event may end; a later one is "
              "rejected (default {default}; 'inf' for no limit).", ("flag", "max_future"), metavar="SECONDS"),
    RunOption("drop_pending", "switch", False,
              "At the end of the input, discard the synchronized matches still waiting instead of "
              "running them.", ("global", "rtl_drop_pending")),
    RunOption("flush_timers", "switch", False,
              "At the end of the input, fire the timers still pending (absences not(C).[A, D] and "
              "alarm(E, D) heads) as if the clock had passed them; by default they do not fire, since "
              "the clock never reached them.", ("flag", "flush_timers")),
    RunOption("allow_control", "switch", False,
              "Obey control lines in the events ({\"op\": \"add_rule\", ...}, \"delete_rule\"); "
              "without it they are refused (an error each) and skipped.", ("stream", "allow_control")),
    RunOption("strict", "switch", False,
              "End the run with exit status 1 at the first line that is rejected or whose event "
              "fails, after writing everything produced before it.", ("stream", "strict")),
    RunOption("consumer_dir", "directory", None,
              "Write the subscription deliveries of each consumer to DIR/<consumer>.jsonl instead "
              "of the output.", ("consumer_dir", ""), metavar="DIR", handed_over=False),
    RunOption("action_output", "file", None,
              "Write the text that actions and conditions print to FILE (default: standard error; "
              "standard output carries only JSON Lines).", ("action_output", ""), metavar="FILE",
              handed_over=False),
    RunOption("detections", "labels", None,
              "Write the detections per rule before the summary, the rules labelled L1, L2, ... first "
              "(`retalisc run` hands its runs over with it).", ("global", "rtl_detection_labels"),
              metavar="LABELS", cli=False),
]

BY_NAME: Dict[str, RunOption] = {option.name: option for option in RUN_OPTIONS}

#: The options of `retalisc run` that Python serves and that do not reach the runtime's
#: command line, each with what keeps it off it (tests/test_run_options.py checks that every
#: parameter of `retalisc run` is either here or in RUN_OPTIONS).
PYTHON_ONLY: Dict[str, str] = {
    "program": "compiled by Python",
    "events": "the input: the last argument of the hand-over",
    "out": "a file: the run stays in Python",
    "batch_size": "how Python batches; the runtime reads the file itself",
    "subscriptions": "the run stays in Python", "memories": "the run stays in Python",
    "queries": "the run stays in Python", "query_timeout": "with --query",
    "heartbeat": "the run stays in Python", "progress": "a progress line: the run stays in Python",
    "traces": "the run stays in Python", "late_file": "the run stays in Python",
    "no_cache": "no cached program file to hand over", "state": "the run stays in Python",
    "snapshot_every": "with --state", "snapshot_seconds": "with --state",
}


def cli_options() -> List[RunOption]:
    """The options of `retalisc run` made from the table, in its order."""
    return [option for option in RUN_OPTIONS if option.cli]


def given(values: Dict[str, object]) -> List[Tuple[RunOption, object]]:
    """The table's options given a value in `values` (a switch when true, another when not
    None), in table order; names not in the table are left alone."""
    return [(option, values[option.name]) for option in RUN_OPTIONS
            if option.name in values and values[option.name] is not None and values[option.name] is not False]


def arguments(values: Dict[str, object]) -> List[str]:
    """The arguments of `swipl PROGRAM.pl` that give the runtime these values."""
    return [option.argument(value) for option, value in given(values)]


def keeps_python(values: Dict[str, object]) -> List[str]:
    """The options given that `retalisc run` serves in Python (no hand-over)."""
    return [option.option for option, _ in given(values) if not option.handed_over]


def engine_flags(values: Dict[str, object]) -> List[Tuple[str, str]]:
    """(flag, value text) of the flag options given: what an in-process run sets on its
    Engine (`Engine.set_flag`)."""
    return [(option.road[1], option.text(value)) for option, value in given(values) if option.road[0] == "flag"]


# --------------------------------------------------------------------------- the Prolog table

TABLE_FILE = Path(__file__).resolve().parent.parent / "prolog_runtime" / "rtl_run_options.pl"
_NAME = re.compile(r"[a-z][a-z0-9_]*\Z")


def _atom(text: str) -> str:
    """A Prolog atom for one of the table's own constants (a name, else quoted)."""
    if _NAME.match(text):
        return text
    if not re.fullmatch(r"[\x20-\x7e]*", text):
        raise ValueError(f"not a plain constant: {text!r}")
    return "'" + text.replace("\\", "\\\\").replace("'", "\\'") + "'"


def _term(value) -> str:
    if value is None:
        return "none"
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        return repr(value)
    return _atom(str(value))


def prolog_table() -> str:
    """The text of prolog_runtime/rtl_run_options.pl: the table as Prolog facts."""
    lines = [
        ":- module(rtl_run_options, [rtl_run_option/5]).",
        "",
        "/** <module> The run options (generated: do not edit)",
        "",
        "Written by `python -m retalisc.run_options` from the table of retalisc/run_options.py,",
        "where the run options are declared once; tests/test_run_options.py fails when this file",
        "is not what the table makes. rtl_arguments.pl reads `swipl PROGRAM.pl` command lines by",
        "these facts, and rtl_flags.pl takes the defaults of the flags from them.",
        "*/",
        "",
        "%!  rtl_run_option(?Option, ?Kind, ?Metavar, ?Default, ?Road) is nondet.",
        "%",
        "%   Option is the name after `--` (`'max-delay'`); Kind the kind of its value (switch,",
        "%   count, seconds, limit, directory, file, labels); Metavar what the usage line calls the",
        "%   value; Default the runtime's value when the option is not given (none: nothing);",
        "%   Road how it reaches the runtime: flag(Flag), stream(Option), global(Key),",
        "%   consumer_dir or action_output.",
        "",
    ]
    for option in RUN_OPTIONS:
        road, target = option.road
        road_term = f"{road}({_atom(target)})" if target else road
        metavar = option.metavar or ("" if option.kind == "switch" else option.kind.upper())
        lines.append(f"rtl_run_option({_atom(option.option[2:])}, {option.kind}, {_atom(metavar)}, "
                     f"{_term(option.default)}, {road_term}).")
    return "\n".join(lines) + "\n"


def check_table(options: Iterable[RunOption] = RUN_OPTIONS) -> None:
    """Raise ValueError when an entry is not one the generated table can say."""
    names = set()
    for option in options:
        if option.kind not in KINDS or option.road[0] not in ROADS:
            raise ValueError(f"{option.name}: kind {option.kind!r} or road {option.road!r} unknown")
        if option.name in names or not _NAME.match(option.name):
            raise ValueError(f"{option.name}: a duplicate or not a name")
        names.add(option.name)


def main() -> None:
    check_table()
    TABLE_FILE.write_text(prolog_table(), encoding="utf-8")
    print(f"wrote {TABLE_FILE}")


if __name__ == "__main__":
    main()
