"""Generated programs: whatever the compiler is given, it either rejects the
program with a located error or compiles it into Prolog that loads and runs.

A few hundred programs are mutated from the examples, the golden tests and a few seed programs
(token deletions, duplications, swaps, operator and name substitutions, odd numbers and quoted
atoms, deep nesting, long `seq` chains, clauses that used to slip through), one in five is a
soup of random tokens. For each one:

- no Python exception other than a located `RetalisError` escapes `compile_source` (nor the
  compilation of the same text as rules added at run time or as an active-query program), and
  `retalisc check` exits 2 with `FILE:LINE:COL: ` and the offending line, or 0;
- every compiled program loads in SWI-Prolog without an error or warning (all of them, in one
  `swipl` process);
- a sample of them runs with `swipl OUT.pl EVENTS.jsonl` on events made for its patterns, to the
  end of the events. Programs whose rules feed their own patterns or that raise events are only
  loaded: a derivation that never ends is the runtime's business (its step limit), not the
  compiler's.

RETALISC_FUZZ_SEED, RETALISC_FUZZ_PROGRAMS and RETALISC_FUZZ_RUNS run other or more cases
locally (`RETALISC_FUZZ_SEED=7 RETALISC_FUZZ_PROGRAMS=3000 pytest tests/test_fuzz_programs.py`).
"""
from __future__ import annotations

import json
import os
import random
import re
import subprocess
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

from click.testing import CliRunner

from retalisc.cli import main
from retalisc.compiler import AqOptions, compile_added_rules, compile_source
from retalisc.frontend.errors import RetalisError
from retalisc.frontend.program import EventAtom, walk_pattern
from retalisc.frontend.terms import Atom, Compound, Number, Var, indicator, to_prolog

ROOT = Path(__file__).resolve().parent.parent
SEED = int(os.environ.get("RETALISC_FUZZ_SEED", "20240611"))
PROGRAMS = int(os.environ.get("RETALISC_FUZZ_PROGRAMS", "300"))
RUNS = int(os.environ.get("RETALISC_FUZZ_RUNS", "30"))

SEED_PROGRAMS = [
    "a2(X) <- a(X) seq b(X).\nc2(X, Y) <- a(X) and b(Y) where X < Y.\nd2 <- (a(_) or b(_)).3.\n",
    "n(X) <- not(c(X)).[a(X), b(X)].\nf(X) <- a(X) fnot c(X).\nm(X) <- (a(X) seq b(X)) cnot c(X).\n",
    "s(X, S) <- a(X) seq aggregate(sum(Y), b(Y), S).\nk(N) <- a(_) seq aggregate(count, c(_), N).\n",
    "r1 'rule:' p(X) <- a(X)^T where T > 1.\nr2([property(event_rule_window, 2)]) 'rule:' q(X) <- a(X) par b(X).\n"
    "t(X) <- a(X) check (t1(S), t2(E), S =< E).\n",
    "small(X) :- X < 3.\nbig(X) :- \\+ small(X).\nsb(X) <- a(X) where (small(X) -> true ; big(X)).\n"
    ":- dynamic seen/1.\nnull do assertz(seen(X)) <- b(X).\nagain(X) <- c(X) where seen(X).\n",
    "e1(X) <- a(X) equals b(X).\ne2(X) <- a(X) meets b(X).\ne3(X) <- a(X) during b(X).\n"
    "e4(X) <- a(X) starts b(X).\ne5(X) <- a(X) finishes b(X).\n",
    ":- set_etalis_flag(event_consumption_policy, recent).\nprint_trigger(p/1).\np(X) <- a(X) seq b(X).\n"
    "q(X) <- p(X) seq c(X).\n",
    "c_mem(m1, a(_)-[], 5, 10).\nlast(X) <- b(_)^T where prev(m1, a(X)^_, T).\n",
]

OPERATORS = ["seq", "and", "or", "par", "where", "check", "cnot", "fnot", "equals", "meets", "during", "starts",
             "finishes", ",", ";", "<-", ":-", "->", ".", "^", "-", "=", "is", "do", "'rule:'", ":", "|", "\\+",
             "<", ">", "=<", "+", "*", "//", "-->", "?-", "'seq'", "==", "=..", "@"]
NAMES = ["a", "b", "c", "x", "not", "aggregate", "median", "sum", "count", "seq", "and", "meets", "where",
         "new_event", "atom_length", "forall", "assertz", "rtl_input", "rtl_derived", "ele_trigger", "e_r1_1",
         "module", "op", "dynamic", "true", "fail", "prev", "next", "mem", "c_mem", "print_trigger",
         "set_etalis_flag", "event_rule_property", "null", "call", "findall", "t1", "t2", "min", "max", "inf",
         "write", "format", "member", "nb_getval", "succ", "rule", "property", "synchronized"]
NUMBERS = ["0", "1", "-1", "2.5", "1.0Inf", "1.5NaN", "0x1F", "0'a", "123456789012345678901234567890", "1e10",
           "0.0", "7", "-0.0", "1.0e-300", "0b101", "0o17", "1_000"]
QUOTED = ["'a\\qb'", "'\\x41\\'", "'\\u00e9'", "\"str\"", "'it''s'", "'\\z'", "'\\u12'", "'seq'", "'<-'", "'.'",
          "'[]'", "'{}'", "`back`", "'a b'", "'\\x110000\\'", "'rauch'", "'\\n'"]
CLAUSES = [":- new_event(foo(1)).", "foo :- 1.", "(a, b).", ":- op(700, xfx, ===>).", "x <- a ===> b.",
           "l1 : q <- a.", "l1 : q2 <- b.", "7 'rule:' z <- a.", ":- module(m, []).", ":- :- a.", "1 <- a.",
           "atom_length(a, 1).", "z(S) <- aggregate(median(Y), a(Y), S).", "z <- not(a(_)).",
           "z <- a seq (b <- c).", "meets(R, P) <- a(R) seq b(P).", "seq(X, Y) <- a(X) and b(Y).",
           ":- dynamic q/1.", ":- initialization(true).", "q(1).", "q(X) :- X > 1.", ":- q(_).",
           "w <- a where 1.", "v do true <- b.", ":- dynamic foo/x.", "g --> [a], g.", "g --> [].",
           "{a}.", "'$x'.", "ev(X) <- a(X)^[S, E] where S =< E.", "c_mem(mm, a(_)-[], 2, 5).",
           "z <- (a).1.0Inf.", "z <- (a).-1.", "x(\"a\\qb\") <- a.", ":- op(200, xfy, ^).", "z <- a(X) seq b(X) where X.",
           "event_rule_property(l1, event_rule_window, 3).", "syncronized(a(X), [q], []) <- b(X).",
           "x(1.0Inf, 1.5NaN) <- a.", "y(Z) <- a(X) where Z is X ** 0.5.", "p(X) :- X = \"str\", X \\= 0'a.",
           "x('rauch_\u00fc', \"\u00e9\") <- a.", "r(X) <- a(X)^[S, E] check (t1(S), t2(E)).",
           "sub(1, cons, a(X)-[X > 1], got(X), 0).", "subscribe(b(X), [], _, cons, s1).",
           "stream_history(a/1).", "max_delay(a/1, 2).", "w <- a(X) fnot b(X).", "u <- (a seq b).0.5."]

_TOKEN = re.compile(r"""%[^\n]*|/\*.*?\*/|'(?:[^'\\\n]|\\.|'')*'|"(?:[^"\\\n]|\\.)*"|`[^`\n]*`|0'.|"""
                    r"""\d+(?:\.\d+)?(?:[eE][+-]?\d+)?|[a-z][A-Za-z0-9_]*|[A-Z_][A-Za-z0-9_]*|"""
                    r"""[+\-*/\\^<>=~:.?@#&$]+|\s+|.""", re.S)


def corpus():
    programs = [p.read_text() for p in sorted(ROOT.glob("examples/*/*.rtl"))]
    programs += [p.read_text() for p in sorted(ROOT.glob("tests/golden/*/program.rtl"))]
    return programs + SEED_PROGRAMS


def mutate(text: str, rng: random.Random) -> str:
    tokens = _TOKEN.findall(text)
    for _ in range(rng.choice([1, 1, 2, 3])):
        significant = [i for i, t in enumerate(tokens) if t.strip() and not t.startswith(("%", "/*"))]
        if not significant:
            break
        i = rng.choice(significant)
        token = tokens[i]
        kind = rng.randrange(12)
        if kind == 0:
            tokens[i] = ""
        elif kind == 1:
            tokens[i] = token + " " + token
        elif kind == 2:
            j = significant[min(significant.index(i) + 1, len(significant) - 1)]
            tokens[i], tokens[j] = tokens[j], tokens[i]
        elif kind == 3 and not token[0].isalnum():
            tokens[i] = f" {rng.choice(OPERATORS)} "
        elif kind == 4 and token[0].islower():
            tokens[i] = rng.choice(NAMES + OPERATORS[:13])
        elif kind == 5 and (token[0].isupper() or token[0] == "_"):
            tokens[i] = rng.choice(["X", "_", "Y1", "a", "1", "_Z"])
        elif kind == 6 and token[0].isdigit():
            tokens[i] = rng.choice(NUMBERS)
        elif kind == 7:
            tokens[i] = rng.choice(QUOTED)
        elif kind == 8:
            depth = rng.choice([2, 10, 60, 400])
            tokens[i] = "(" * depth + token + ")" * depth
        elif kind == 9 and token[0].islower():
            depth = rng.choice([3, 30, 300])
            tokens[i] = "f(" * depth + token + ")" * depth
        elif kind == 10 and token[0].islower():
            tokens[i] = "(" + " seq ".join([token] * rng.choice([2, 20, 200])) + ")"
        else:
            ends = [k for k, t in enumerate(tokens) if t == "." and k + 1 < len(tokens) and tokens[k + 1].isspace()]
            at = rng.choice(ends) + 1 if ends else len(tokens)
            tokens.insert(at, "\n" + rng.choice(CLAUSES) + "\n")
    return "".join(tokens)


SOUP = list("abcXY_ ()[]{},;|'\"`\\0123456789+-*/<>=:^!\n") + [
    "seq", "<-", ":-", "0'a", "1.0Inf", "1.5NaN", "where", "not", "do", "and", "\u00fc", " . ", "f(", "a(X)", "g(Y)",
    "-->", "?-", "'rule:'", "[H|T]", "\"s\"", "is", "->", "\\+", "findall(", "dynamic", "op(", "c_mem(", "sub(",
    "new_event(", "'.'", "{", "}", "aggregate(", "count", "sum(X)", ").3", "check", "t1(T)"]


def soup(rng: random.Random) -> str:
    """A clause or two of random tokens: mostly rejected, now and then a program no example
    resembles."""
    return "".join(rng.choice(SOUP) + rng.choice(["", "", " "]) for _ in range(rng.randrange(1, 30))) + ".\n"


# ---- events for a program -----------------------------------------------------------------------

def _event_shapes(unit):
    shapes = {}
    for rule in unit.program.event_rules:
        for p in walk_pattern(rule.pattern):
            if isinstance(p, EventAtom):
                shapes.setdefault(indicator(p.term), p.term)
    return list(shapes.values())


def _instance(term, rng):
    if isinstance(term, Var):
        return rng.choice([Number(1), Number(2), Number(15), Atom("a"), Atom("smoke_1"), Atom("kitchen")])
    if isinstance(term, Compound):
        return Compound(term.name, tuple(_instance(a, rng) for a in term.args))
    return term


def events_for(unit, rng: random.Random) -> str:
    shapes = _event_shapes(unit)
    lines, time = [], 0.0
    for _ in range(rng.randrange(4, 25)):
        if not shapes:
            break
        time += rng.choice([0, 0.5, 1, 2, 7])
        event = to_prolog(_instance(rng.choice(shapes), rng))
        roll = rng.random()
        if roll < 0.1:
            lines.append(json.dumps({"event": event, "start": time, "end": time + 1}))
        elif roll < 0.15 and lines:
            lines.append(lines[-1].replace('"t":', '"op": "retract", "t":'))
        elif roll < 0.2:
            lines.append(rng.choice(['{"event": "a(1"', "not json", '{"t": 3}', '{"event": "a", "t": "x"}', ""]))
        elif roll < 0.25:
            lines.append(json.dumps({"event": event, "t": max(time - 3, 0)}))      # late
        else:
            lines.append(json.dumps({"event": event, "t": time}))
    return "".join(line + "\n" for line in lines)


def _feeds_itself(unit) -> bool:
    """A derived event can feed (through rules) a pattern of a rule deriving it again, or the
    program raises events (`new_event`): runs of such programs need the runtime's step limit."""
    if "new_event" in unit.program.text:
        return True
    edges = {}
    for rule in unit.program.event_rules:
        head = indicator(rule.head)
        for p in walk_pattern(rule.pattern):
            if isinstance(p, EventAtom):
                edges.setdefault(indicator(p.term), set()).add(head)
    seen, stack = set(), [(k, k) for k in edges]
    while stack:
        start, node = stack.pop()
        for nxt in edges.get(node, ()):
            if nxt == start:
                return True
            if (start, nxt) not in seen:
                seen.add((start, nxt))
                stack.append((start, nxt))
    return False


# ---- the test -----------------------------------------------------------------------------------

def _other_compilations(text: str, file: str) -> None:
    """The same text as rules added to a running program, and as a definite program for active
    queries: a located error or a result, never another exception."""
    for compile_it in (lambda: compile_added_rules(text, "rtl_prog_fuzz", "fz", file),
                       lambda: compile_source(text, file, active_queries=AqOptions("tabled"))):
        try:
            compile_it()
        except RetalisError as error:
            assert error.span is not None and error.span.line >= 1, (text, error.message)
        except Exception as error:
            raise AssertionError(f"{type(error).__name__}: {error}\nprogram:\n{text}") from error


_LOCATED = re.compile(r"^(?P<file>.+?):(?P<line>\d+):(?P<col>\d+): ")


def _load_problems(stderr: str, files) -> list:
    """Messages of SWI-Prolog about loading the generated files (load errors and warnings name
    the file and line), each with the lines that continue it and the source of the program.

    A directive of the program that fails or raises when it runs (`:- q(_).` with `q(X) :- X > 1`)
    is the program's own doing, not a load failure, unless it calls a predicate that does not
    exist (the compiler rejects those)."""
    names = [str(f) for f in files]
    lines = stderr.splitlines()
    problems = []
    for i, line in enumerate(lines):
        found = re.match(r"^(?:ERROR|Warning): (\S+?\.pl):(\d+):", line)
        if not found or found[1] not in names:
            continue
        block = [line] + [more for more in lines[i + 1:i + 4] if more.startswith(("ERROR:    ", "Warning:    "))]
        text = "\n".join(block)
        source_line = Path(found[1]).read_text().splitlines()[int(found[2]) - 1]
        user_directive = source_line.startswith(":- ") and not source_line.startswith((":- initialization(rtl_",
                                                                                      ":- use_module("))
        if user_directive and "Unknown procedure" not in text and "Initialization goal" not in text:
            continue
        problems.append(text + "\n--- program:\n" + Path(found[1]).with_suffix(".rtl").read_text())
    return problems


def test_generated_programs_are_rejected_with_a_location_or_load_and_run(tmp_path, swipl):
    rng = random.Random(SEED)
    sources = corpus()
    compiled = []            # (pl path, unit, events path)
    rejected = 0
    runner = CliRunner()
    for n in range(PROGRAMS):
        text = soup(rng) if n % 5 == 4 else mutate(rng.choice(sources), rng)
        path = tmp_path / f"p{n}.rtl"
        path.write_text(text, encoding="utf-8")
        _other_compilations(text, str(path))
        try:
            result = compile_source(text, str(path), output_name=f"p{n}.pl")
        except RetalisError as error:
            rejected += 1
            assert error.span is not None and error.span.file == str(path), (text, error.message)
            assert error.span.line >= 1 and error.span.column >= 1, (text, error.message)
            if n % 5 == 0:       # the command line says the same (it is the same code path)
                cli = runner.invoke(main, ["check", str(path)])
                assert cli.exit_code == 2, (text, cli.stderr)
                first = cli.stderr.splitlines()[0]
                match = _LOCATED.match(first)
                assert match and match["file"] == str(path), (text, cli.stderr)
                assert "Traceback" not in cli.stderr
            continue
        except Exception as error:      # a traceback for the user: the bug this test hunts
            raise AssertionError(f"{type(error).__name__}: {error}\nprogram:\n{text}") from error
        out = tmp_path / f"p{n}.pl"
        out.write_text(result.prolog, encoding="utf-8")
        events = tmp_path / f"p{n}.jsonl"
        events.write_text(events_for(result.unit, rng), encoding="utf-8")
        compiled.append((out, result.unit, events))
    assert rejected >= PROGRAMS // 10 and len(compiled) >= PROGRAMS // 10, (rejected, len(compiled))

    # every compiled program loads, in one process (rtl_main does nothing when embedded)
    files = [str(out) for out, _, _ in compiled]
    goal = ("create_prolog_flag(retalis_embedded, true, []), "
            f"forall(member(F, {json.dumps(files)}), load_files(F, [])), halt(0)")
    load = subprocess.run([swipl, "--no-tty", "-q", "--stack-limit=256m", "-g", goal, "-t", "halt(1)"],
                          capture_output=True, text=True, timeout=300)
    problems = _load_problems(load.stderr, files)
    assert load.returncode == 0 and not problems, "\n\n".join(problems[:5]) or load.stderr[-2000:]

    # a sample runs standalone on its events, to the end
    runnable = [c for c in compiled if not _feeds_itself(c[1])]
    sample = rng.sample(runnable, min(RUNS, len(runnable)))

    def run(case):
        out, _, events = case
        return case, subprocess.run([swipl, "--stack-limit=64m", str(out), str(events)], capture_output=True,
                                    text=True, timeout=120)

    with ThreadPoolExecutor(max_workers=2) as pool:
        for (out, unit, events), proc in pool.map(run, sample):
            source = Path(unit.program.file).read_text()
            assert not _load_problems(proc.stderr, [out]), (source, proc.stderr)
            # (stdout is not parsed: text that `do write(...)` actions print goes there until
            # the run sends it to standard error)
            if proc.returncode == 0:
                assert re.search(r"^retalis: [\d,]+ events", proc.stderr, re.M), (source, proc.stderr)
            else:
                # until the runtime reports a failing event and goes on, an
                # error raised by the program's own goals on an event may end the run
                assert proc.returncode == 1 and "ERROR" in proc.stderr, (source, proc.returncode, proc.stderr)
