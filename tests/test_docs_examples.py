"""Every fenced code block in docs/ and README.md is run or checked, with its output.

A block says what it is on its opening fence (docs/architecture.md, "Documentation examples"):

    ```rtl                 a program (or part of one): it must compile, without warnings
                           unless the fence says `warnings`
    ```rtl file=NAME       the same, and saved as NAME for the blocks after it on the page
    ```jsonl file=NAME     event lines saved as NAME (each line must be accepted by the reader)
    ```python              run, in one namespace per page (blocks build on each other);
                           what it prints is compared with an `output` block right after it
    ```console             `$ COMMAND` lines run (`retalisc ...` in this process, `swipl`,
                           `python`, `cat`), each followed by its expected output (standard output;
                           with `2>&1` standard error too); `...` on a line of its own
                           stands for any lines, and times in seconds ("0.01 s") are not compared
    ```output              the expected output of the python block before it
    ```text                not code: a diagram, a synopsis, an illustration in notation

Each page runs in a fresh directory that holds its saved files and a link to `examples/`.
Any other fence (or none) fails the test: a block is either run or said not to be code.
"""
from __future__ import annotations

import contextlib
import io
import json
import os
import re
import shlex
import shutil
import subprocess
import sys
from dataclasses import dataclass, field
from pathlib import Path
from typing import Dict, List

import pytest
from click.testing import CliRunner

from retalisc.cli import main
from retalisc.compiler import compile_source

ROOT = Path(__file__).resolve().parent.parent
PAGES = sorted((ROOT / "docs").glob("*.md")) + [ROOT / "README.md"]
KINDS = {"rtl", "jsonl", "python", "console", "output", "text"}
FENCE = re.compile(r"^```(.*)$")
SECONDS = re.compile(r"\b\d+(\.\d+)? s\b")


@dataclass
class Block:
    page: Path
    line: int
    kind: str
    attrs: Dict[str, str]
    text: str
    flags: List[str] = field(default_factory=list)

    def where(self) -> str:
        page = self.page.relative_to(ROOT) if self.page.is_relative_to(ROOT) else self.page.name
        return f"{page}:{self.line}"


def blocks_of(page: Path) -> List[Block]:
    found, lines = [], page.read_text(encoding="utf-8").splitlines()
    i = 0
    while i < len(lines):
        match = FENCE.match(lines[i])
        if match is None:
            i += 1
            continue
        words = match.group(1).split()
        kind = words[0] if words else ""
        attrs = dict(w.split("=", 1) for w in words[1:] if "=" in w)
        flags = [w for w in words[1:] if "=" not in w]
        body, j = [], i + 1
        while j < len(lines) and lines[j].rstrip() != "```":
            body.append(lines[j])
            j += 1
        found.append(Block(page, i + 1, kind, attrs, "\n".join(body) + "\n", flags))
        i = j + 1
    return found


def normalize(text: str) -> List[str]:
    return [SECONDS.sub("N s", line.rstrip()) for line in text.rstrip("\n").splitlines()]


def matches(expected: List[str], actual: List[str]) -> bool:
    """`...` on a line of its own matches any number of lines."""
    if not expected:
        return not actual
    if expected[0] == "...":
        return any(matches(expected[1:], actual[k:]) for k in range(len(actual) + 1))
    return bool(actual) and expected[0] == actual[0] and matches(expected[1:], actual[1:])


def compare(block: Block, expected: str, actual: str, what: str) -> None:
    want, got = normalize(expected), normalize(actual)
    assert matches(want, got), (f"{block.where()}: {what}\n--- expected\n" + "\n".join(want) +
                                "\n--- got\n" + "\n".join(got))


class Page:
    def __init__(self, page: Path, work: Path):
        self.page, self.work = page, work
        self.namespace: dict = {"__name__": "__docs__"}
        self.runner = CliRunner()

    def run(self, blocks: List[Block]) -> None:
        for index, block in enumerate(blocks):
            following = blocks[index + 1] if index + 1 < len(blocks) else None
            assert block.kind in KINDS, (f"{block.where()}: a code block must say what it is "
                                         f"(```{' / ```'.join(sorted(KINDS))}), not {block.kind!r}")
            getattr(self, "do_" + block.kind)(block, following)

    # ---- kinds -------------------------------------------------------------------------------

    def do_text(self, block: Block, following) -> None:
        pass

    def do_output(self, block: Block, following) -> None:
        pass                                    # checked with the block before it

    def do_rtl(self, block: Block, following) -> None:
        name = block.attrs.get("file", "block.rtl")
        result = compile_source(block.text, name)
        if "warnings" not in block.flags:
            assert result.warnings == [], f"{block.where()}: warnings:\n" + "\n".join(result.warnings)
        if "file" in block.attrs:
            (self.work / name).write_text(block.text, encoding="utf-8")

    def do_jsonl(self, block: Block, following) -> None:
        for number, line in enumerate(block.text.splitlines(), start=1):
            if line.strip():
                assert isinstance(json.loads(line), dict), f"{block.where()}+{number}: not an object"
        if "file" in block.attrs:
            (self.work / block.attrs["file"]).write_text(block.text, encoding="utf-8")

    def do_python(self, block: Block, following) -> None:
        out = io.StringIO()
        with contextlib.redirect_stdout(out):
            exec(compile(block.text, block.where(), "exec"), self.namespace)
        if following is not None and following.kind == "output":
            compare(block, following.text, out.getvalue(), "python output")

    def do_console(self, block: Block, following) -> None:
        for command, expected in commands_of(block.text):
            compare(block, expected, self.shell(block, command), f"$ {command}")

    # ---- commands ------------------------------------------------------------------------------

    def shell(self, block: Block, command: str) -> str:
        words = shlex.split(command)
        merge = "2>&1" in words
        words = [w for w in words if w != "2>&1"]
        stdin = None
        if "<" in words:
            at = words.index("<")
            stdin = (self.work / words[at + 1]).read_text(encoding="utf-8")
            del words[at:at + 2]
        if words[0] == "retalisc":
            result = self.runner.invoke(main, words[1:], input=stdin, catch_exceptions=False)
            return result.output if merge else result.stdout
        if words[0] == "cat":
            return "".join((self.work / w).read_text(encoding="utf-8") for w in words[1:])
        if words[0] == "python":
            result = subprocess.run([sys.executable] + words[1:], cwd=self.work, input=stdin, capture_output=True,
                                    text=True, timeout=60, env=dict(os.environ, PYTHONPATH=str(ROOT)))
            return result.stdout + (result.stderr if merge else "")
        if words[0] == "swipl":
            swipl = shutil.which("swipl")
            result = subprocess.run([swipl] + words[1:], cwd=self.work, input=stdin, capture_output=True,
                                    text=True, timeout=60, env=dict(os.environ, PYTHONPATH=str(ROOT)))
            return result.stdout + (result.stderr if merge else "")
        raise AssertionError(f"{block.where()}: the docs test does not run {words[0]!r}")


def commands_of(text: str):
    """(command, expected output) pairs of a console block; `\\` continues a command."""
    pairs: List[List[str]] = []
    lines = text.splitlines()
    i = 0
    while i < len(lines):
        line = lines[i]
        if line.startswith("$ "):
            command = line[2:]
            while command.endswith("\\") and i + 1 < len(lines):
                i += 1
                command = command[:-1] + " " + lines[i].strip()
            pairs.append([command, ""])
        elif pairs:
            pairs[-1][1] += line + "\n"
        elif line.strip():
            raise AssertionError(f"console block: output before any $ command: {line!r}")
        i += 1
    return [(c, e) for c, e in pairs]


def page_ids():
    return [str(p.relative_to(ROOT)) for p in PAGES]


@pytest.mark.parametrize("page", PAGES, ids=page_ids())
def test_page_examples_run(page, tmp_path, monkeypatch):
    (tmp_path / "examples").symlink_to(ROOT / "examples")
    monkeypatch.chdir(tmp_path)
    Page(page, tmp_path).run(blocks_of(page))


def test_the_harness_catches_wrong_output(tmp_path, monkeypatch):
    page = tmp_path / "page.md"
    page.write_text("```python\nprint(1 + 1)\n```\n\n```output\n3\n```\n", encoding="utf-8")
    monkeypatch.chdir(tmp_path)
    with pytest.raises(AssertionError, match="expected"):
        Page(page, tmp_path).run(blocks_of(page))
    assert matches(["a", "...", "d"], ["a", "b", "c", "d"]) and not matches(["a", "...", "e"], ["a", "d"])
    untagged = tmp_path / "untagged.md"
    untagged.write_text("```\nx\n```\n", encoding="utf-8")
    with pytest.raises(AssertionError, match="must say what it is"):
        Page(untagged, tmp_path).run(blocks_of(untagged))
