"""Handing `retalisc run` over to `swipl`: when a run needs nothing from Python while the
events stream (a plain event file or standard input, the output on standard output, no
option that Python serves), the `retalisc` program replaces itself (`os.execv`) by
`swipl PROGRAM.pl OPTIONS EVENTS` on the compiled program kept in the compile cache. The
runtime's own loop then reads, processes and writes everything, with the start-up of
`swipl` alone instead of that of Python, its Prolog bridge and the runtime embedded in it.
What the run prints (standard output, the messages and the summary on standard error, the
exit status) is what the Python driver prints for the same run, which reads such input in
the same loop (`in_prolog_loop`).
"""
from __future__ import annotations

import os
import re
import shutil
import sys
from typing import List, Optional

from ..run_options import BY_NAME, arguments, keeps_python

#: Rule labels passed in `--detections=L1,L2`: names (what the compiler makes of a label).
_LABEL = re.compile(r"[a-z][A-Za-z0-9_]*\Z")


def swipl_arguments(events: str, rules: List[str], **options) -> Optional[List[str]]:
    """The arguments after `swipl PROGRAM.pl` that run as `retalisc run` does with these
    run options (keyword arguments named as in retalisc/run_options.py, the one table of
    them: `max_delay=0.5`, `strict=True`, ...; None or False: not given), or None when the
    runtime's command line cannot say them: an events file name the runtime would read as an
    option, or not UTF-8, a rule label that is not a name, or an option `retalisc run` serves
    in Python (`--consumer-dir`, `--action-output`)."""
    unknown = [name for name in options if name not in BY_NAME or not BY_NAME[name].cli]
    if unknown:
        raise TypeError(f"swipl_arguments: not run options of retalisc run: {', '.join(unknown)}")
    if events != "-" and events.startswith("-"):
        return None
    try:
        events.encode("utf-8")
    except UnicodeEncodeError:
        return None
    if not all(_LABEL.match(rule) for rule in rules) or keeps_python(options):
        return None
    return arguments({**options, "detections": list(rules)}) + [events]


def swipl_command(program_file: str, arguments: List[str]) -> Optional[List[str]]:
    """The command line of the handover (the options of the embedded runtime: no packs, no
    init file), or None when there is no `swipl` on the PATH."""
    swipl = shutil.which("swipl")
    if swipl is None:
        return None
    return [swipl, "--no-packs", "-f", "none", program_file, *arguments]


def hand_over(command: List[str]) -> None:
    """Replace this process by `command` (what is written so far leaves first). Returns
    only when it cannot be started. A rule added while the events stream (a control line,
    ins_event_rule/1) is compiled by `retalisc compile-rules` run with `$RETALISC_PYTHON`:
    unless it is set, this Python, the one that runs `retalisc` (not one the runtime would
    search for)."""
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except (OSError, ValueError):
            pass
    environment = dict(os.environ)
    if not environment.get("RETALISC_PYTHON") and sys.executable:
        environment["RETALISC_PYTHON"] = sys.executable
    try:
        os.execve(command[0], command, environment)
    except OSError:
        return
