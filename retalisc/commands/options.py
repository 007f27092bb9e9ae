"""Option types and checks shared by the commands: a bad value is a one-line usage error
(exit status 2), never a traceback."""
from __future__ import annotations

import math
import os

import click

from ..run_options import BY_NAME, cli_options


class Seconds(click.ParamType):
    """A duration in seconds: a number >= 0, `inf` when `allow_inf` (no bound); never NaN or
    negative."""

    name = "seconds"

    def __init__(self, allow_inf: bool = True):
        self.allow_inf = allow_inf

    def convert(self, value, param, ctx):
        if isinstance(value, (int, float)) and not isinstance(value, bool):
            number = float(value)
        else:
            try:
                number = float(str(value).strip())
            except ValueError:
                self.fail(f"{value!r} is not a number of seconds", param, ctx)
        if math.isnan(number):
            self.fail("NaN is not a number of seconds", param, ctx)
        if number < 0:
            self.fail(f"{value} is negative; give a number of seconds >= 0", param, ctx)
        if math.isinf(number) and not self.allow_inf:
            self.fail("must be a finite number of seconds", param, ctx)
        return number


class FiniteTime(click.ParamType):
    """A time stamp in seconds: any finite number."""

    name = "time"

    def convert(self, value, param, ctx):
        try:
            number = float(str(value).strip()) if not isinstance(value, (int, float)) else float(value)
        except ValueError:
            self.fail(f"{value!r} is not a number", param, ctx)
        if not math.isfinite(number):
            self.fail(f"{value} is not a finite number", param, ctx)
        return number


def output_file(path: str, option: str) -> None:
    """Fail with a usage error unless `path` can be written (it is created, empty, if missing)."""
    if path in (None, "-"):
        return
    if os.path.isdir(path):
        raise click.BadParameter(f"{path} is a directory", param_hint=option)
    try:
        with open(path, "a", encoding="utf-8"):
            pass
    except OSError as error:
        raise click.BadParameter(f"cannot write {path}: {error.strerror}", param_hint=option) from None


def output_directory(path: str, option: str) -> None:
    """Fail with a usage error unless directory `path` exists or can be made, and is writable."""
    if path is None:
        return
    try:
        os.makedirs(path, exist_ok=True)
    except OSError as error:
        raise click.BadParameter(f"cannot make the directory {path}: {error.strerror}", param_hint=option) from None
    if not os.access(path, os.W_OK):
        raise click.BadParameter(f"cannot write in the directory {path}", param_hint=option)


def state_options(state_help: str, every_help: str, seconds_help: str):
    """The crash-recovery options of a command (docs/recovery.md): `--state DIR`,
    `--snapshot-every N`, `--snapshot-seconds S`, with the command's own help texts."""
    options = [
        click.option("--state", "state", type=click.Path(file_okay=False), default=None, metavar="DIR",
                     help=state_help),
        click.option("--snapshot-every", "snapshot_every", type=click.IntRange(1), default=None, metavar="N",
                     help=every_help),
        click.option("--snapshot-seconds", "snapshot_seconds", type=Seconds(allow_inf=True), default=None,
                     metavar="S", help=seconds_help),
    ]

    def decorate(command):
        for option in reversed(options):
            command = option(command)
        return command
    return decorate


def check_snapshot_options(state, snapshot_every, snapshot_seconds) -> None:
    """Fail with a usage error when a snapshot option comes without --state."""
    if state is None and (snapshot_every is not None or snapshot_seconds is not None):
        raise click.UsageError("--snapshot-every and --snapshot-seconds go with --state DIR")


class LazyChoice(click.Choice):
    """A `click.Choice` whose choices come from `load()` when first needed (to check a value,
    or for the help text), so that defining a command does not import what lists them."""

    def __init__(self, load, case_sensitive: bool = True):
        self._load = load
        self._choices = None
        self.case_sensitive = case_sensitive

    @property
    def choices(self):
        if self._choices is None:
            self._choices = tuple(self._load())
        return self._choices


class Count(click.ParamType):
    """A positive integer or `inf` (`1_000` and `1,000` too): `--max-steps N` and the other
    count options of the run (retalisc/run_options.py)."""

    name = "count"

    def convert(self, value, param, ctx):
        if value == "inf" or (isinstance(value, int) and not isinstance(value, bool) and value > 0):
            return value
        text = str(value)
        if text.strip() == "inf":
            return "inf"
        try:
            number = int(text.replace("_", "").replace(",", ""))
        except ValueError:
            number = 0
        if number <= 0:
            self.fail(f"{text!r}: expected a positive integer or 'inf'", param, ctx)
        return number


class LimitSeconds(click.ParamType):
    """A finite number of seconds >= 0 or `inf` (`--max-future SECONDS`)."""

    name = "seconds"

    def convert(self, value, param, ctx):
        text = str(value)
        if text.strip() == "inf":
            return "inf"
        try:
            number = float(text)
        except ValueError:
            number = -1.0
        if not 0 <= number < float("inf"):
            self.fail(f"{text!r}: expected a number of seconds >= 0 or 'inf'", param, ctx)
        return number


def _click_type(option):
    if option.kind == "count":
        return Count()
    if option.kind == "seconds":
        return Seconds()
    if option.kind == "limit":
        return LimitSeconds()
    if option.kind == "directory":
        return click.Path(file_okay=False)
    if option.kind == "file":
        return click.Path(dir_okay=False)
    raise ValueError(f"{option.name}: no click type for the kind {option.kind}")


def run_option(name: str, help: str = None):
    """The click option of the run option `name` (retalisc/run_options.py), with its own help
    text unless `help` is given (`--max-delay` of `retalisc query`: "As for `retalisc run`.")."""
    option = BY_NAME[name]
    text = help if help is not None else option.help_text()
    if option.kind == "switch":
        return click.option(option.option, option.name, is_flag=True, help=text)
    return click.option(option.option, option.name, type=_click_type(option), default=None,
                        metavar=option.metavar, help=text)


def run_options(command):
    """The options of `retalisc run` that reach the runtime, all of the table of run options
    (retalisc/run_options.py), in its order."""
    for option in reversed(cli_options()):
        command = run_option(option.name)(command)
    return command
