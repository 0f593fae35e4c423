"""Run the console examples of README.md and docs/ and compare their output (with Sybil).

A ```console block holds commands (lines starting with ``$ ``; a line ending in ``\\`` goes on)
each followed by the output it prints -- stdout and stderr together, as a terminal shows them.
Every document runs in a sandbox of its own: a temporary directory that links the repository's
folders (``examples``, ``docs``, ``vrcal``, ...) and has ``../shared`` beside it, so the paths
of the docs work and whatever a command writes goes to the sandbox. Commands run in order; a
file one command writes is there for the next.

The shown output must match the real one:

* text matches after collapsing runs of blanks;
* a number matches to the digits shown: ``0.7662`` matches ``0.76617813``, ``0.77`` does
  not match ``0.7662`` (the shown number must equal the real one rounded to as many places);
* a line ``...`` stands for any number of lines, ``...`` inside a line for any text;
* a command must exit with status 0, unless its output ends with a line ``[exit N]``: then with N;
* a traceback never matches.

:func:`compare` is the matcher (tested in tests/test_doc_console.py).
"""

from __future__ import annotations

import math
import os
import re
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

from sybil.parsers.markdown import CodeBlockParser

ROOT = Path(__file__).resolve().parents[1]
NUMBER = re.compile(r"[-+]?(?:\d+\.\d*|\.\d+|\d+)(?:[eE][-+]?\d+)?")
ELLIPSIS = "..."
#: Longest a single documented command may run [s].
COMMAND_TIMEOUT_S = 600


# --------------------------------------------------------------------------- matching


def _decimals(text):
    """(places after the point, exponent) of a number as written."""
    mantissa, _, exponent = text.lower().partition("e")
    places = len(mantissa.split(".", 1)[1]) if "." in mantissa else 0
    return places, int(exponent) if exponent else 0


def number_matches(shown, actual):
    """True when ``actual`` (text) rounds to ``shown`` (text) at the digits ``shown`` has."""
    s, a = float(shown), float(actual)
    if math.isnan(s) or math.isnan(a):
        return math.isnan(s) and math.isnan(a)
    places, exponent = _decimals(shown)
    half_unit = 0.5 * 10.0 ** (exponent - places)
    return abs(a - s) <= half_unit * (1 + 1e-9) + 1e-300


def _line_pattern(line):
    """A regex for one expected line and the numbers it shows, in order."""
    parts, numbers, pos = [], [], 0
    text = " ".join(line.split())
    for m in re.finditer(re.escape(ELLIPSIS) + "|" + NUMBER.pattern, text):
        parts.append(_text_pattern(text[pos:m.start()]))
        if m.group(0) == ELLIPSIS:
            parts.append(".*?")
        else:
            parts.append(f"({NUMBER.pattern})")
            numbers.append(m.group(0))
        pos = m.end()
    parts.append(_text_pattern(text[pos:]))
    return re.compile("^" + "".join(parts) + "$"), numbers


def _text_pattern(text):
    return "".join(r"\s+" if ch == " " else re.escape(ch) for ch in text)


def line_matches(expected, actual):
    """True when one actual line matches one expected line (see the module docstring)."""
    pattern, numbers = _line_pattern(expected)
    m = pattern.match(" ".join(actual.split()))
    if not m:
        return False
    return all(number_matches(s, a) for s, a in zip(numbers, m.groups()))


def compare(expected, actual):
    """None when ``actual`` output matches the ``expected`` text, else a message saying where not."""
    exp = [line for line in expected.splitlines()]
    act = [line for line in actual.splitlines()]
    while exp and not exp[-1].strip():
        exp.pop()
    while act and not act[-1].strip():
        act.pop()
    memo = {}

    def match(i, j):
        key = (i, j)
        if key in memo:
            return memo[key]
        if i == len(exp):
            ok = j == len(act)
        elif exp[i].strip() == ELLIPSIS:
            ok = any(match(i + 1, k) for k in range(j, len(act) + 1))
        else:
            ok = j < len(act) and line_matches(exp[i], act[j]) and match(i + 1, j + 1)
        memo[key] = ok
        return ok

    sys.setrecursionlimit(max(sys.getrecursionlimit(), 4 * (len(exp) + len(act)) + 100))
    if match(0, 0):
        return None
    # the first expected line that no actual line in order can take: a readable hint
    j = 0
    for i, line in enumerate(exp):
        if line.strip() == ELLIPSIS:
            continue
        while j < len(act) and not line_matches(line, act[j]):
            j += 1
        if j == len(act):
            return f"expected line {i + 1} not found in order: {line!r}\n--- actual output ---\n{actual}"
        j += 1
    return f"output has lines the example does not show\n--- actual output ---\n{actual}"


# --------------------------------------------------------------------------- parsing a block


def commands(block):
    """``[(command, expected output), ...]`` of a console block."""
    out, cmd, lines = [], None, []
    source = block.splitlines()
    i = 0
    while i < len(source):
        line = source[i]
        if line.startswith("$ "):
            if cmd is not None:
                out.append((cmd, "\n".join(lines)))
            cmd, lines = line[2:], []
            while cmd.endswith("\\") and i + 1 < len(source):
                i += 1
                cmd = cmd[:-1] + "\n" + source[i]
        elif cmd is not None:
            lines.append(line)
        i += 1
    if cmd is not None:
        out.append((cmd, "\n".join(lines)))
    return out


def expected_status(expected):
    """(exit status, output without the status line): ``[exit N]`` as the last line gives N, else 0."""
    lines = expected.rstrip().splitlines()
    if lines:
        m = re.fullmatch(r"\[exit (\d+)\]", lines[-1].strip())
        if m:
            return int(m.group(1)), "\n".join(lines[:-1])
    return 0, expected


# --------------------------------------------------------------------------- the sandbox


def make_sandbox():
    """A temporary directory laid out like the checkout's parent: ``sandbox/repo`` links the
    repository's folders, ``sandbox/shared`` the shared data. Returns the repo-like cwd."""
    top = Path(tempfile.mkdtemp(prefix="vrcal-docs-"))
    cwd = top / ROOT.name
    cwd.mkdir()
    for entry in ROOT.iterdir():
        if entry.name.startswith(".") or entry.name in ("build", "dist"):
            continue
        (cwd / entry.name).symlink_to(entry)
    shared = ROOT.parent / "shared"
    if shared.exists():
        (top / "shared").symlink_to(shared)
    return cwd


def remove_sandbox(cwd):
    shutil.rmtree(Path(cwd).parent, ignore_errors=True)


def run(command, cwd):
    """Run one shell command in ``cwd``; its stdout and stderr together, and the exit status."""
    env = dict(os.environ)
    env["PATH"] = str(Path(sys.executable).parent) + os.pathsep + env.get("PATH", "")
    env.update({"MPLBACKEND": "Agg", "PYTHONUNBUFFERED": "1", "COLUMNS": "100", "LC_ALL": "C.UTF-8"})
    proc = subprocess.run(["bash", "-c", command], cwd=cwd, env=env, stdout=subprocess.PIPE,
                          stderr=subprocess.STDOUT, text=True, timeout=COMMAND_TIMEOUT_S)
    return proc.stdout, proc.returncode


def _require_shared(path):
    """Skip an example that reads the shared data when a plain clone has none beside it (fail with
    ``VRCAL_REQUIRE_SHARED=1``, as CI runs: there it must be present)."""
    if path.exists():
        return
    import pytest

    if os.environ.get("VRCAL_REQUIRE_SHARED") == "1":
        pytest.fail(f"VRCAL_REQUIRE_SHARED=1 but {path} is absent")
    pytest.skip("reads ../shared/data, which is not beside this checkout (the README's 'Set up' says where it "
                "comes from)")


# --------------------------------------------------------------------------- Sybil


class ConsoleParser(CodeBlockParser):
    """Sybil parser of ```console blocks (see the module docstring)."""

    language = "console"

    def evaluate(self, example):
        cwd = example.namespace.setdefault("sandbox", None)
        if cwd is None:
            cwd = example.namespace["sandbox"] = make_sandbox()
        steps = commands(example.parsed)
        if any("../shared" in command for command, _ in steps):
            example.namespace["needs_shared"] = True
        if example.namespace.get("needs_shared"):
            # this block reads ../shared (or a later one may read what such a block wrote)
            _require_shared(Path(cwd).parent / "shared")
        for command, expected in steps:
            output, status = run(command, cwd)
            want_status, expected = expected_status(expected)
            if "Traceback (most recent call last)" in output:
                return f"$ {command}\nprinted a traceback:\n{output}"
            if status != want_status:
                return f"$ {command}\nexit status {status}, the example says {want_status}\n{output}"
            problem = compare(expected, output)
            if problem:
                return f"$ {command}\n{problem}"
        return None
