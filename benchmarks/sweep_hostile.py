"""Hostile, broken and enormous input through the installed ``vrcal``: a table of what happens.

Run: python benchmarks/sweep_hostile.py [-j 2] [--timeout 60] [--only WORD ...] [--list]

Every case runs ``vrcal ...`` in a subprocess, in a fresh directory, with a wall-time limit
(default 60 s) and an address-space limit (default 6 GiB, so a memory bomb shows up as a
failure instead of taking the machine down). For each case the table shows the exit status,
the wall time, the peak memory, and what went wrong:

* ``TRACEBACK``  -- a Python traceback on stderr;
* ``TIMEOUT``    -- still running at the time limit (killed);
* ``SILENT``     -- exit 0 where the input is nonsense (the case expects an error);
* ``FAILED``     -- an error where the case expects a result;
* ``MULTILINE``  -- an error that is not the one line ``vrcal: error: ...``;
* ``LEFT``       -- files left behind by a failed run, or a hidden ``.tmp`` file at all (after a
  SIGTERM only the latter: a file renamed into place before the signal is complete);
* ``REPLACED``   -- a device node, FIFO or symbolic link given as output was replaced;
* ``CHECK``      -- the case's own check of the output failed (e.g. a CSV whose rows do not parse).

Each case names the helper whose part of issue 10 it belongs to (``owner``), so the totals at
the end say which failures remain and whose they are. The commands and numeric options are
read from the installed CLI, so every numeric option of every command is tried with nan,
inf, -inf, -1, 0, 1e-320 and 1e308 (integers: -1, 0 and 10**12). Prints numbers; asserts nothing.
"""

from __future__ import annotations

import argparse
import concurrent.futures
import csv
import io
import os
import re
import resource
import shutil
import signal
import stat
import subprocess
import sys
import tempfile
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
EXAMPLES = ROOT / "examples"
SHARED = ROOT.parent / "shared" / "data"
VRCAL = shutil.which("vrcal") or "vrcal"

# --------------------------------------------------------------------------- fixtures


def _simulated(kind, ball="tennis", extra=()):
    out = subprocess.run([VRCAL, "simulate", ball, "--bounces", "4", "--noise", "0.001", "--format", kind, *extra],
                         capture_output=True, text=True, check=True)
    return out.stdout


_FIXTURES = {}


def fixture(name):
    """Valid files, made once and copied into every case directory that asks for them."""
    if name not in _FIXTURES:
        if name == "traj.csv":
            _FIXTURES[name] = _simulated("trajectory")
        elif name == "impacts.csv":
            _FIXTURES[name] = _simulated("impacts")
        elif name == "apexes.csv":
            _FIXTURES[name] = _simulated("apexes")
        elif name == "standards.yaml":
            from importlib import resources

            _FIXTURES[name] = resources.files("vrcal").joinpath("standards.yaml").read_text(encoding="utf-8")
        elif name == "scene.yaml":
            _FIXTURES[name] = (EXAMPLES / "figure8-basketball.yaml").read_text(encoding="utf-8")
        elif name == "pixels.txt":
            rows = ["0.5;250"] + [f"{100 + 200 * (t / 60) ** 2:.1f};320;" for t in range(1, 40)]
            _FIXTURES[name] = "\n".join(rows) + "\n"
        elif name == "tracker.txt":
            _FIXTURES[name] = (EXAMPLES / "data" / "tracker-export.txt").read_text(encoding="utf-8")
        elif name == "big-trajectory.csv":   # 10^6 honest samples: 30 bounces at 174 kHz, 1 mm noise
            _FIXTURES[name] = subprocess.run(
                [VRCAL, "simulate", "tennis", "--drop", "1", "--bounces", "30", "--epsilon", "0.85", "--fs", "174000",
                 "--noise", "0.001"], capture_output=True, text=True, check=True).stdout
        elif name == "big-impacts-clock.csv":   # a 1 kHz sensor over 17 minutes: 10^6 equally spaced times
            _FIXTURES[name] = "t\n" + "".join(f"{i / 1000:.3f}\n" for i in range(1_000_000))
        elif name == "big-impacts-drops.csv":   # 33,333 drops of 30 impacts each, 6 s apart
            flights = [2 * 0.85 ** k * (2 * 9.80665) ** 0.5 / 9.80665 for k in range(1, 30)]
            one = [0.4516 + sum(flights[:k]) for k in range(30)]
            _FIXTURES[name] = "t\n" + "".join(f"{6.0 * d + x:.6f}\n" for d in range(33_333) for x in one)
        elif name == "drop.wav":
            with tempfile.TemporaryDirectory() as d:
                subprocess.run([VRCAL, "simulate", "tennis", "--bounces", "4", "--format", "wav", "-o",
                                os.path.join(d, "drop.wav")], capture_output=True, check=True)
                _FIXTURES[name] = Path(d, "drop.wav").read_bytes()
        else:
            raise KeyError(name)
    return _FIXTURES[name]


def billion_laughs(key_path, levels=9, width=9):
    """YAML text with ``{bomb}`` in ``key_path`` replaced by aliases of aliases (width**levels strings
    if expanded), all anchors defined inside the value itself so that no unknown field gives it away."""
    parts = ['&a0 "lol"']
    for i in range(1, levels + 1):
        parts.append(f"&a{i} [" + ", ".join([f"*a{i - 1}"] * width) + "]")
    return key_path.format(bomb="[" + ", ".join(parts) + "]") + "\n"


def deep_yaml(depth=100_000, flow=True):
    if flow:
        return "x: " + "[" * depth + "]" * depth + "\n"
    return "".join(" " * i + f"k{i}:\n" for i in range(depth)) + " " * depth + "v: 1\n"


def scene_yaml(bodies, *, duration=2.0, sample_dt=None, extra=""):
    """A scene file: ``bodies`` is a list of (name, ball, [x, y, z], position_of) or YAML text of one body."""
    lines = ["K_per_s: 4.0", f"duration_s: {duration}", "floor: {material: steel}"]
    if sample_dt is not None:
        lines.append(f"sample_dt_s: {sample_dt}")
    if extra:
        lines.append(extra)
    lines.append("bodies:")
    for b in bodies:
        if isinstance(b, str):
            lines.append(b)
            continue
        name, ball, pos, of = b
        lines.append(f"  - name: {name}\n    ball: {ball}\n    position_m: {list(pos)}\n    position_of: {of}")
    return "\n".join(lines) + "\n"


def grid_scene(n, duration=2.0):
    side = int(n ** 0.5) + 1
    bodies = [(f"b{k}", "table_tennis", [0.05 * (k % side), 0.05 * (k // side), 0.3 + 0.001 * k], "bottom")
              for k in range(n)]
    return scene_yaml(bodies, duration=duration)


# --------------------------------------------------------------------------- cases


@dataclass
class Case:
    name: str
    args: list                    # vrcal arguments; "{dir}" is the case directory
    owner: str = "hostile"        # whose part of issue 10: hostile, engines, discover, output, big
    expect: str = "error"         # error | ok | any
    files: dict = field(default_factory=dict)   # name -> text/bytes/fixture:NAME/callable(dir)
    special: str = ""             # chardev | fifo | symlink: the -o target is made special
    signal_after_s: float = 0.0   # send SIGTERM after this many seconds
    check: object = None          # callable(dir, stdout) -> message or "" (the output's own check)
    timeout: float | None = None


def _write_files(d, files):
    for name, content in files.items():
        p = d / name
        p.parent.mkdir(parents=True, exist_ok=True)
        if callable(content):
            content(p)
        elif isinstance(content, bytes):
            p.write_bytes(content)
        elif content.startswith("fixture:"):
            data = fixture(content[len("fixture:"):])
            if isinstance(data, bytes):
                p.write_bytes(data)
            else:
                p.write_text(data, encoding="utf-8")
        else:
            p.write_text(content, encoding="utf-8")


def _symlink_to_dev_zero(p):
    os.symlink("/dev/zero", p)


def _fifo_with_writer(text):
    def make(p):
        os.mkfifo(p)

        def writer():
            try:
                with open(p, "w") as fh:
                    fh.write(text)
            except OSError:
                pass
        threading.Thread(target=writer, daemon=True).start()
    return make


def _unwritable_dir(p):
    """A directory nobody can write into -- root included: a regular file stands where its parent should be."""
    p.write_text("a regular file, not a directory\n")


def _csv_rows_consistent(path):
    def check(d, _stdout):
        f = d / path
        if not f.exists():
            return f"{path} missing"
        rows = list(csv.reader(io.StringIO(f.read_text(encoding="utf-8"))))
        widths = {len(r) for r in rows}
        return "" if len(widths) == 1 else f"{path}: rows of {sorted(widths)} cells"
    return check


def numeric_option_cases():
    """Every numeric option of every command with nan, inf, -inf, -1, 0, tiny and huge values."""
    import click

    from vrcal.cli import main

    base = {
        "fit": ["fit", "basketball"],
        "pair": ["pair", "basketball", "volleyball"],
        "plot curves": ["plot", "curves", "-o", "figs"],
        "table2": ["table2"],
        "simulate": ["simulate", "tennis", "--bounces", "3"],
        "discover": ["discover", "traj.csv", "--ball", "tennis", "-q"],
        "export": ["export", "basketball", "--engine", "ode"],
        "verify": ["verify", "basketball", "--engine", "ode", "--bounces", "1", "--phases", "1"],
        "scene": ["scene", "scene.yaml", "--no-animation", "-o", "out"],
        "track": ["track", "drop.wav", "-q"],
    }
    owners = {"export": "engines", "verify": "engines", "track": "track"}
    cases, skipped = [], []

    def walk(group, path):
        for name, cmd in sorted(group.commands.items()):
            if isinstance(cmd, click.Group):
                yield from walk(cmd, [*path, name])
            else:
                yield " ".join([*path, name]), cmd

    for cname, cmd in walk(main, []):
        numeric = [p for p in cmd.params if isinstance(p, click.Option) and _numeric_kind(p.type)]
        if not numeric:
            continue
        if base.get(cname) is None:
            skipped.append(cname)
            continue
        for p in numeric:
            opt = max(p.opts, key=len)
            kind = _numeric_kind(p.type)
            values = (["nan", "inf", "-inf", "-1", "0", "1e-320", "1e308"] if kind == "float"
                      else ["-1", "0", "1000000000000"])
            for v in values:
                args = list(base[cname])
                if cname == "scene" and opt == "--ode-dt":
                    args += ["--engine", "ode"]
                if cname == "discover" and opt == "--scale":
                    args = ["discover", "pixels.txt", "--ball", "tennis", "--fs", "60", "-q"]
                if cname == "simulate" and opt in ("--x", "--v"):
                    args += ["--x", "0.01", "--v", "0.1"] if opt == "--v" else ["--v", "0.1"]
                if cname == "simulate" and opt in ("--mass", "--diameter"):
                    args = ["simulate", "marble", "--epsilon", "0.6", "--drop", "0.5", "--bounces", "3",
                            "--mass" if opt == "--diameter" else "--diameter",
                            "0.005" if opt == "--diameter" else "0.016"]
                if cname == "fit" and opt in ("--x", "--v") and v in ("0",):
                    pass
                expect = "error" if v in ("nan", "inf", "-inf") else "any"
                if kind == "int" and v == "1000000000000" and opt != "--seed":
                    expect = "error"
                owner = owners.get(cname.split()[0], "hostile")
                cases.append(Case(f"{cname} {opt} {v}", args + [f"{opt}={v}"], owner=owner, expect=expect,
                                  files={"traj.csv": "fixture:traj.csv", "pixels.txt": "fixture:pixels.txt",
                                         "scene.yaml": "fixture:scene.yaml", "drop.wav": "fixture:drop.wav"}))
    return cases, skipped


def _numeric_kind(t):
    import click

    if isinstance(t, (click.types.FloatParamType,)) or getattr(t, "numeric_kind", None) == "float":
        return "float"
    if isinstance(t, (click.types.IntParamType,)) or getattr(t, "numeric_kind", None) == "int":
        return "int"
    return None


def measurement_cases():
    D = ["discover", "data", "--ball", "tennis", "-q"]
    many_cols = ",".join(f"c{i}" for i in range(100_000)) + "\n" + ",".join(["1"] * 100_000) + "\n"
    bad = {
        "empty": "",
        "blank lines": "\n\n  \n",
        "comments only": "# t,y\n# 1,2\n",
        "binary": bytes(range(256)) * 40,
        "NUL in text": "t,y\n0,1\x00\n0.1,0.9\n",
        "header only": "t,y\n",
        "one row": "t,y\n0,1\n",
        "two rows": "t,y\n0,1\n0.1,0.95\n",
        "text cells": "t,y\n0,a\n0.1,b\n0.2,c\n",
        "nan cells": "t,y\n" + "".join(f"{i / 100},nan\n" for i in range(50)),
        "inf cells": "t,y\n" + "".join(f"{i / 100},inf\n" for i in range(50)),
        "huge numbers": "t,y\n" + "".join(f"{i}e300,{i}e300\n" for i in range(1, 50)),
        "tiny numbers": "t,y\n" + "".join(f"{i}e-320,{i}e-320\n" for i in range(1, 50)),
        "time decreasing": "t,y\n" + "".join(f"{(50 - i) / 100},{i / 50}\n" for i in range(50)),
        "time repeated": "t,y\n" + "".join(f"0.5,{i / 50}\n" for i in range(50)),
        "constant height": "t,y\n" + "".join(f"{i / 100},1.0\n" for i in range(200)),
        "numbers without header": "".join(f"{i / 100},{i / 50}\n" for i in range(50)),
        "too many cells": "t,y\n0,1,2,3\n",
        "latin-1": "t;y (m)\n" + "".join(f"{i / 100:.2f};{1 - i / 200:.3f}\n".replace(".", ",") for i in range(50))
                   + "# \xe9\n",
        "utf-16": ("t,y\n" + "".join(f"{i / 100},{1 - i / 100}\n" for i in range(50))).encode("utf-16"),
        "10 MB one line": "t,y\n" + "1" * 10_000_000 + "\n",
        "100000 columns": many_cols,
        "unknown units": "t (fortnights),y (furlongs)\n0,1\n1,2\n2,3\n",
        "only x column": "x\n1\n2\n3\n",
        "apexes rising": "bounce,h\n0,1\n1,1.5\n2,2\n",
        "impacts one": "t\n0.5\n",
        "impacts negative": "t\n-3\n-2\n-1\n",
        "pixels-ref 3 cells": "0.5;250;7\n100;320;\n110;320;\n130;320;\n",
        "pixels-ref 0 px": "0.5;0\n100;320;\n110;320;\n130;320;\n",
        "pixels-ref negative": "-0.5;250\n100;320;\n110;320;\n130;320;\n",
        "tracker junk": "mass_A\nt\tx\ty\nfoo\tbar\tbaz\n",
    }
    cases = []
    for label, content in bad.items():
        extra = ["--fs", "60"] if label.startswith("pixels-ref") else []
        fmt = ["--format", "pixels-ref"] if label.startswith("pixels-ref") else []
        # what a file means (units, sign, which column) is the discover helper's plausibility part
        owner = "discover" if label in ("apexes rising", "impacts negative", "only x column") else "hostile"
        expect = "any" if label in ("latin-1", "utf-16") else "error"
        cases.append(Case(f"discover data: {label}", D + extra + fmt, owner=owner, expect=expect,
                          files={"data": content}))
    for fmt in ("pixels-ref", "tracker", "apexes", "impacts", "trajectory", "nonsense"):
        # a trajectory's time column read as impact times is the discover helper's plausibility check
        owner, expect = {"impacts": ("discover", "error"), "trajectory": ("hostile", "ok")}.get(fmt, ("hostile",
                                                                                                       "error"))
        cases.append(Case(f"discover --format {fmt} on a t,y CSV", D + ["--format", fmt, "--fs", "60"],
                          owner=owner, expect=expect, files={"data": "fixture:traj.csv"}))
    cases += [
        Case("discover data: /dev/zero", ["discover", "/dev/zero", "--ball", "tennis", "-q"]),
        Case("discover data: /dev/urandom", ["discover", "/dev/urandom", "--ball", "tennis", "-q"]),
        Case("discover data: symlink to /dev/zero", D, files={"data": _symlink_to_dev_zero}),
        Case("discover data: a directory", ["discover", ".", "--ball", "tennis", "-q"]),
        Case("discover data: missing", ["discover", "nope.csv", "--ball", "tennis", "-q"]),
        Case("discover data: FIFO with a writer", D, expect="ok", files={"data": _fifo_with_writer(
            fixture("traj.csv"))}),
        Case("discover impacts", ["discover", "impacts.csv", "--ball", "tennis", "-q"], expect="ok",
             files={"impacts.csv": "fixture:impacts.csv"}),
        Case("discover apexes", ["discover", "apexes.csv", "--ball", "tennis", "-q"], expect="ok",
             files={"apexes.csv": "fixture:apexes.csv"}),
        Case("discover tracker export", ["discover", "tracker.txt", "--ball", "tennis", "-q"], expect="any",
             files={"tracker.txt": "fixture:tracker.txt"}),
        Case("discover pixels-ref", ["discover", "pixels.txt", "--ball", "tennis", "--fs", "60", "-q"],
             expect="any", files={"pixels.txt": "fixture:pixels.txt"}),
        Case("discover unknown ball", ["discover", "traj.csv", "--ball", "cannonball", "-q"],
             files={"traj.csv": "fixture:traj.csv"}),
        Case("discover ball name a billion chars", ["discover", "traj.csv", "--ball", "x" * 100_000, "-q"],
             files={"traj.csv": "fixture:traj.csv"}),
    ]
    # measurement content: the discover helper's plausibility checks
    traj = fixture("traj.csv").splitlines()
    upside = [traj[0]] + [f"{r.split(',')[0]},{-float(r.split(',')[1])!r}" for r in traj[1:]]
    mm = [traj[0]] + [f"{r.split(',')[0]},{float(r.split(',')[1]) * 1000!r}" for r in traj[1:]]
    scaled = [traj[0]] + [f"{float(r.split(',')[0]) * 1e-12!r},{r.split(',')[1]}" for r in traj[1:]]
    imp = fixture("impacts.csv").splitlines()
    imp_ms = [imp[0]] + [f"{float(r) * 1000!r}" for r in imp[1:]]
    grow = [imp[0]] + [f"{1 + 0.1 * k * k}" for k in range(1, 8)]
    ap = fixture("apexes.csv").splitlines()
    ap_cm = [ap[0]] + [f"{r.split(',')[0]},{float(r.split(',')[1]) * 100!r}" for r in ap[1:]]
    ap_high = [ap[0]] + [f"{r.split(',')[0]},{float(r.split(',')[1]) * (3 if i else 1)!r}"
                         for i, r in enumerate(ap[1:])]
    for label, rows in (("upside down", upside), ("heights in mm under m", mm), ("times scaled 1e-12", scaled),
                        ("impact times in ms", imp_ms), ("impact intervals grow", grow),
                        ("apexes in cm under m", ap_cm), ("apexes above the drop", ap_high)):
        cases.append(Case(f"discover content: {label}", D, owner="discover", expect="warn",
                          files={"data": "\n".join(rows) + "\n"}))
    return cases


def yaml_cases():
    """Scene and standards files: bombs, depth, duplicates, devices, schema abuse."""
    std = fixture("standards.yaml")
    # a second 'basketball' at the end of the balls mapping (the last key of the file): the volleyball's fields
    volley = std[std.index("  volleyball:"):]
    volley = volley[:re.search(r"\n  [a-z]", volley).start()]
    dup = std.rstrip("\n") + "\n" + volley.replace("  volleyball:", "  basketball:", 1) + "\n"
    S = ["scene", "s.yaml", "--no-animation", "-o", "out"]
    F = ["--standards", "st.yaml", "fit", "basketball"]
    cases = []
    yaml_bad = {
        "empty": "",
        "a list": "- 1\n- 2\n",
        "a number": "42\n",
        "malformed": "a: [1, 2\n",
        "tabs": "a:\n\tb: 1\n",
        "binary": bytes(range(256)) * 8,
        "invalid UTF-8": b"a: \xff\xfe\n",
        "python tag": "a: !!python/object/apply:os.system ['echo hi']\n",
        "deep flow 100000": deep_yaml(100_000, True),
        "deep block 2000": deep_yaml(2000, False),
        "deep flow 1000 mappings": "x: " + "{a: " * 1000 + "1" + "}" * 1000 + "\n",
        "huge integer": "schema_version: " + "9" * 100_000 + "\n",
        "50 MB": "# " + "x" * 50_000_000 + "\n",
        "many aliases, small": "a: &a 1\nb: *a\n",
    }
    for label, content in yaml_bad.items():
        cases.append(Case(f"scene file: {label}", S, files={"s.yaml": content}))
        cases.append(Case(f"standards file: {label}", F, files={"st.yaml": content}))
    for label, path in (("/dev/zero", "/dev/zero"), ("/dev/urandom", "/dev/urandom"), ("a directory", "."),
                        ("missing", "nope.yaml")):
        cases.append(Case(f"scene file: {label}", ["scene", path, "--no-animation", "-o", "out"]))
        cases.append(Case(f"standards file: {label}", ["--standards", path, "fit", "basketball"]))
        cases.append(Case(f"fit --standards after the command: {label}", ["fit", "basketball", "--standards", path]))
    # billion laughs in every place the issue names
    cases += [
        Case("billion laughs: standards schema_version", F,
             files={"st.yaml": billion_laughs("schema_version: {bomb}")}),
        Case("billion laughs: standards ball name", F, files={"st.yaml": billion_laughs(
            "schema_version: 1\nballs:\n  basketball:\n    name: {bomb}")}),
        Case("billion laughs: scene K_per_s", S, files={"s.yaml": billion_laughs(
            "K_per_s: {bomb}\nduration_s: 1\nfloor: {{material: steel}}\nbodies: []")}),
        Case("billion laughs: scene body name", S, files={"s.yaml": billion_laughs(
            "K_per_s: 4\nduration_s: 1\nfloor: {{material: steel}}\nbodies:\n  - name: {bomb}\n    ball: tennis\n"
            "    position_m: [0, 0, 1]")}),
        Case("duplicate ball key in standards", F, files={"st.yaml": dup}),
        Case("duplicate key in a scene", S, files={"s.yaml": "K_per_s: 4\nK_per_s: 40\n" + fixture("scene.yaml")}),
        Case("standards: ball name with a newline and comma", ["--standards", "st.yaml", "table2", "--format", "csv",
                                                               "-o", "t.csv"], expect="any",
             files={"st.yaml": std.replace("name: Basketball", 'name: "Basket,ball\\nnew line"', 1)},
             check=_csv_rows_consistent("t.csv")),
    ]
    # scene content
    tt = ("a", "tennis", [0, 0, 0], "bottom")
    from vrcal.model.standards import get_ball

    rb, rt = get_ball("basketball").radius_m, get_ball("tennis").radius_m
    cases += [
        Case("scene: 10^9 samples", S, files={"s.yaml": scene_yaml([("a", "tennis", [0, 0, 1], "bottom")],
                                                                    duration=1e7, sample_dt=0.01)}),
        Case("scene: 10^9 samples, short", S, files={"s.yaml": scene_yaml([("a", "tennis", [0, 0, 1], "bottom")],
                                                                           duration=10, sample_dt=1e-8)}),
        Case("scene: duration 1e308", S, files={"s.yaml": scene_yaml([("a", "tennis", [0, 0, 1], "bottom")],
                                                                      duration=1e308)}),
        Case("scene: 300 balls", S, files={"s.yaml": grid_scene(300)}),
        Case("scene: 60 balls", S, files={"s.yaml": grid_scene(60)}, expect="any"),
        Case("scene: 2000 balls", S, files={"s.yaml": grid_scene(2000)}),
        Case("scene: ball resting on a resting ball", S, files={"s.yaml": scene_yaml(
            [tt, ("b", "tennis", [0, 0, 2 * rt], "bottom")])}, expect="any"),
        Case("scene: ball resting on a resting ball, ODE", S + ["--engine", "ode"], files={"s.yaml": scene_yaml(
            [tt, ("b", "tennis", [0, 0, 2 * rt], "bottom")])}, expect="any"),
        Case("scene: ball 1 cm above a resting ball", S, files={"s.yaml": scene_yaml(
            [("a", "basketball", [0, 0, 0], "bottom"), ("b", "tennis", [0, 0, 0.2525], "bottom")])},
             expect="any"),
        Case("scene: two stacked balls touching, dropped", S, files={"s.yaml": scene_yaml(
            [("a", "basketball", [0, 0, 1], "bottom"), ("b", "tennis", [0, 0, 1 + 2 * rb], "bottom")])},
             expect="any"),
        Case("scene: ball 1 cm above a resting ball, long", S, files={"s.yaml": scene_yaml(
            [("a", "basketball", [0, 0, 0], "bottom"), ("b", "tennis", [0.001, 0, 2 * rb + 0.01], "bottom")],
            duration=30)}, expect="any"),
        Case("scene: 100 balls", S, files={"s.yaml": grid_scene(100, duration=1.0)}, expect="any"),
        Case("scene: 100 balls, long", S, files={"s.yaml": grid_scene(100, duration=60.0)}),
        Case("scene: overlapping balls", S, files={"s.yaml": scene_yaml(
            [("a", "basketball", [0, 0, 1], "bottom"), ("b", "tennis", [0, 0, 1.1], "bottom")])}),
        Case("scene: body name with comma and newline", S, expect="ok", files={"s.yaml": scene_yaml(
            ['  - name: "x,y\\nz"\n    ball: tennis\n    position_m: [0, 0, 1]'])},
             check=_csv_rows_consistent("out/s-trajectories.csv")),
        Case("scene: body name 1 MB", S, files={"s.yaml": scene_yaml(
            [f"  - name: {'n' * 1_000_000}\n    ball: tennis\n    position_m: [0, 0, 1]"])}, expect="any"),
        Case("scene: radius 1e-300", S, files={"s.yaml": scene_yaml(
            ["  - name: a\n    mass_kg: 1\n    radius_m: 1e-300\n    virtual_body: {x_m: 0, v_m_per_s: 0}\n"
             "    position_m: [0, 0, 1]"])}, expect="any"),
        Case("scene: mass 1e-300", S, files={"s.yaml": scene_yaml(
            ["  - name: a\n    mass_kg: 1e-300\n    radius_m: 0.1\n    virtual_body: {x_m: 0, v_m_per_s: 0}\n"
             "    position_m: [0, 0, 1]"])}, expect="any"),
        Case("scene: speed 1e300", S, files={"s.yaml": scene_yaml(
            ["  - name: a\n    ball: tennis\n    position_m: [0, 0, 1]\n    velocity_m_per_s: [0, 0, -1e300]"])},
             expect="any"),
        Case("scene: gravity 1e300", S, files={"s.yaml": scene_yaml([("a", "tennis", [0, 0, 1], "bottom")],
                                                                     extra="gravity_m_per_s2: 1e300")}, expect="any"),
        Case("scene: K 1e-300", S, files={"s.yaml": scene_yaml([("a", "tennis", [0, 0, 1], "bottom")]).replace(
            "K_per_s: 4.0", "K_per_s: 1e-300")}, expect="any"),
        Case("scene: rest speed 0", S, files={"s.yaml": scene_yaml([("a", "tennis", [0, 0, 1], "bottom")],
                                                                    extra="rest_speed_m_per_s: 0")}, expect="any"),
        Case("scene: example, ODE", ["scene", str(EXAMPLES / "stack-drop.yaml"), "--engine", "ode", "--no-animation",
                                     "-o", "out"], expect="ok"),
    ]
    return cases


def output_cases():
    cases = []
    fit = ["fit", "basketball", "-o"]
    for special in ("chardev", "fifo", "symlink"):
        cases.append(Case(f"fit -o a {special}", fit + ["target"], expect="ok", special=special))
        cases.append(Case(f"simulate -o a {special}", ["simulate", "tennis", "-o", "target"], expect="ok",
                          special=special))
        cases.append(Case(f"discover --json a {special}", ["discover", "traj.csv", "--ball", "tennis", "-q",
                                                          "--json", "target"], expect="ok", special=special,
                          files={"traj.csv": "fixture:traj.csv"}))
    cases += [
        Case("fit -o an unwritable directory", fit + ["ro/x.yaml"], files={"ro": _unwritable_dir}),
        Case("fit -o a directory", fit + ["."]),
        Case("fit -o into a missing directory", fit + ["nope/x.yaml"]),
        Case("fit -o an empty name", fit + [""]),
        Case("discover --json then --report in an unwritable dir",
             ["discover", "traj.csv", "--ball", "tennis", "-q", "--json", "r.json", "--report", "ro/rep"],
             files={"traj.csv": "fixture:traj.csv", "ro": _unwritable_dir}),
        Case("discover --report is a file", ["discover", "traj.csv", "--ball", "tennis", "-q", "--json", "r.json",
                                             "--report", "traj.csv"], files={"traj.csv": "fixture:traj.csv"}),
        Case("scene fails on its third file", ["scene", "s.yaml", "--no-animation", "-o", "out"],
             files={"s.yaml": "fixture:scene.yaml", "out/s.png/x": "a directory where the figure goes"}),
        Case("scene -o unwritable", ["scene", "s.yaml", "--no-animation", "-o", "ro/out"],
             files={"s.yaml": "fixture:scene.yaml", "ro": _unwritable_dir}),
        Case("plot curves -o unwritable", ["plot", "curves", "-o", "ro/figs"], files={"ro": _unwritable_dir}),
        Case("plot curves fails on its third file", ["plot", "curves", "-o", "figs"],
             files={"figs": lambda p: _block_third_figure(p)}),
        Case("SIGTERM during scene", ["scene", str(EXAMPLES / "figure9-five-balls.yaml"), "-o", "out"],
             signal_after_s=2.5, expect="any"),
        Case("SIGTERM during discover --report", ["discover", "traj.csv", "--ball", "tennis", "-q",
                                                  "--json", "r.json", "--report", "rep"],
             files={"traj.csv": "fixture:traj.csv"}, signal_after_s=2.0, expect="any"),
        Case("SIGTERM during plot curves", ["plot", "curves", "-o", "figs"], signal_after_s=1.2, expect="any"),
        Case("SIGTERM during simulate -o", ["simulate", "tennis", "--bounces", "50", "--fs", "20000", "-o",
                                           "x.csv"], signal_after_s=0.8, expect="any"),
    ]
    return cases


_FIGURE_NAMES = []


def _block_third_figure(p):
    """Make the third figure of ``plot curves`` unwritable: a directory of its name."""
    if not _FIGURE_NAMES:
        with tempfile.TemporaryDirectory() as d:
            subprocess.run([VRCAL, "plot", "curves", "-o", d], capture_output=True, text=True)
            _FIGURE_NAMES.extend(sorted(os.listdir(d)))
    p.mkdir()
    if len(_FIGURE_NAMES) >= 3:
        (p / _FIGURE_NAMES[2]).mkdir()
        (p / _FIGURE_NAMES[2] / "x").write_text("block")


def track_cases():
    """'vrcal track' (the recordings helper's command) and discover on recordings: bad recordings."""
    T = ["track", "rec", "-q"]
    return [
        Case("track a wav", ["track", "drop.wav", "-q", "-o", "i.csv"], owner="track", expect="ok",
             files={"drop.wav": "fixture:drop.wav"}),
        Case("track -o fifo", ["track", "drop.wav", "-q", "-o", "target"], owner="track", expect="ok",
             special="fifo", files={"drop.wav": "fixture:drop.wav"}),
        Case("track --plot fails after -o", ["track", "drop.wav", "-q", "-o", "i.csv", "--plot", "blocker/p.png"],
             owner="track", files={"drop.wav": "fixture:drop.wav", "blocker": _unwritable_dir}),
        Case("track /dev/zero", ["track", "/dev/zero", "-q"], owner="track"),
        Case("track an empty file", T, owner="track", files={"rec": b""}),
        Case("track a text file", T, owner="track", files={"rec": "t,y\n0,1\n"}),
        Case("track random bytes", T, owner="track", files={"rec": bytes(range(256)) * 100}),
        Case("track a truncated wav", T, owner="track", files={"rec": lambda p: p.write_bytes(
            fixture("drop.wav")[:100])}),
        Case("track a wav header claiming 4 GB", T, owner="track", files={"rec": lambda p: p.write_bytes(
            fixture("drop.wav")[:40] + (0xFFFFFFF0).to_bytes(4, "little") + fixture("drop.wav")[44:4000])}),
        Case("discover a truncated wav", ["discover", "rec", "--ball", "tennis", "-q"], owner="track",
             files={"rec": lambda p: p.write_bytes(fixture("drop.wav")[:100])}),
    ]


def size_cases():
    big = ["discover", "big.csv", "--ball", "tennis", "-q"]
    return [
        Case("discover a 10^6-sample trajectory", big, owner="big", expect="ok",
             files={"big.csv": "fixture:big-trajectory.csv"}),
        Case("discover 10^6 equally spaced impact times", big, owner="big",
             files={"big.csv": "fixture:big-impacts-clock.csv"}),
        Case("discover 10^6 impact times of 33,333 drops", big, owner="big",
             files={"big.csv": "fixture:big-impacts-drops.csv"}),
        Case("fit --n 10000000", ["fit", "basketball", "--n", "10000000"]),
        Case("fit --n 100000", ["fit", "basketball", "--n", "100000"], expect="any"),
        Case("simulate --bounces 10000000", ["simulate", "tennis", "--bounces", "10000000"]),
        Case("simulate --bounces 100000 impacts", ["simulate", "tennis", "--bounces", "100000", "--format", "impacts"],
             expect="any"),
        Case("simulate --fs 1e9", ["simulate", "tennis", "--fs", "1e9"]),
        Case("simulate --fs 1e6", ["simulate", "tennis", "--fs", "1e6"], expect="any"),
        Case("simulate --still 1e9", ["simulate", "tennis", "--still", "1e9"]),
        Case("simulate --seed 2**64", ["simulate", "tennis", "--seed", str(2 ** 64), "--noise", "0.001"],
             expect="ok"),
        Case("simulate --seed -1", ["simulate", "tennis", "--seed", "-1", "--noise", "0.001"]),
        Case("simulate --effect junk", ["simulate", "tennis", "--effect", "nonsense"]),
        Case("simulate --effect bad param", ["simulate", "tennis", "--effect", "air_drag:k=nan"]),
        Case("simulate --effect huge", ["simulate", "tennis", "--effect", "air_drag:drag_k_per_m=1e308"]),
        Case("verify --engine bullet --bounces 1000000",
             ["verify", "basketball", "--engine", "bullet", "--bounces", "1000000"], owner="engines"),
        Case("verify --engine bullet --dt 1e-9", ["verify", "basketball", "--engine", "bullet", "--dt", "1e-9"],
             owner="engines"),
        Case("export --dt 1e-320", ["export", "basketball", "--engine", "mujoco", "--dt", "1e-320"], owner="engines"),
        Case("verify --file a JSON list", ["verify", "basketball", "--engine", "bullet", "--file", "f.json"],
             owner="engines", files={"f.json": "[1, 2]"}),
        Case("verify --file binary", ["verify", "basketball", "--engine", "bullet", "--file", "f.json"],
             owner="engines", files={"f.json": bytes(range(256))}),
        Case("verify --file /dev/zero", ["verify", "basketball", "--engine", "bullet", "--file", "/dev/zero"],
             owner="engines"),
        Case("verify --file MJCF entity bomb", ["verify", "basketball", "--engine", "mujoco", "--file", "m.xml"],
             owner="engines", files={"m.xml": '<?xml version="1.0"?>\n<!DOCTYPE l [<!ENTITY a "aaaaaaaaaa">'
                                                 + "".join(f'<!ENTITY a{i} "' + f"&a{i - 1 if i else ''};" * 10 + '">'
                                                           for i in range(9)) + ']>\n<mujoco>&a8;</mujoco>\n'}),
        Case("pair with a body 'x=nan,v=1'", ["pair", "x=nan,v=1", "floor"]),
        Case("pair with a body 'x=1e308,v=1e-308'", ["pair", "x=1e308,v=1e-308", "floor"], expect="any"),
        Case("pair with a body 'x=,v='", ["pair", "x=,v=", "floor"]),
        Case("export --floor x=nan,v=1", ["export", "basketball", "--engine", "ode", "--floor", "x=nan,v=1"]),
        Case("unknown command", ["frobnicate"]),
        Case("fit no ball", ["fit"]),
        Case("fit unknown ball", ["fit", "cannonball"]),
        Case("fit ball name with NUL-like junk", ["fit", "\x7f\x1b[31m"]),
        Case("fit --K with a comma", ["fit", "basketball", "--K", "4,5"]),
        Case("table2 --format csv", ["table2", "--format", "csv"], expect="ok"),
        Case("engines", ["engines"], expect="ok"),
        Case("version", ["--version"], expect="ok"),
        Case("pair floor floor", ["pair", "floor", "floor"], expect="any"),
        Case("pair x=0,v=0 floor", ["pair", "x=0,v=0", "floor"], expect="any"),
        Case("plot curves --ball nonsense", ["plot", "curves", "-o", "figs", "--ball", "nonsense"]),
        Case("export --against nonsense", ["export", "basketball", "--engine", "ode", "--against", "nonsense"],
             owner="engines"),
        Case("table2 --compare-paper with a duplicate key", ["--standards", "st.yaml", "table2", "--compare-paper"],
             files={"st.yaml": "schema_version: 1\nschema_version: 1\n"}),
        Case("fit -o /dev/stdout", ["fit", "basketball", "-o", "/dev/stdout"], expect="ok"),
        Case("discover --json /dev/stdout", ["discover", "traj.csv", "--ball", "tennis", "-q", "--json",
                                             "/dev/stdout"], expect="ok", files={"traj.csv": "fixture:traj.csv"}),
        Case("scene file with CRLF and a BOM", ["scene", "s.yaml", "--no-animation", "-o", "out"], expect="ok",
             files={"s.yaml": lambda p: p.write_bytes(b"\xef\xbb\xbf" + fixture("scene.yaml").replace(
                 "\n", "\r\n").encode())}),
        Case("data file with CRLF and a BOM", ["discover", "d.csv", "--ball", "tennis", "-q"], expect="ok",
             files={"d.csv": lambda p: p.write_bytes(b"\xef\xbb\xbf" + fixture("traj.csv").replace(
                 "\n", "\r\n").encode())}),
        Case("scene: unicode names", ["scene", "s.yaml", "--no-animation", "-o", "out"], expect="ok",
             files={"s.yaml": scene_yaml(['  - name: "ball \u00e9\u4e2d\U0001F3C0"\n    ball: tennis\n'
                                          '    position_m: [0, 0, 1]'])},
             check=_csv_rows_consistent("out/s-trajectories.csv")),
    ]


# --------------------------------------------------------------------------- running


@dataclass
class Outcome:
    case: Case
    code: int | None
    wall_s: float
    maxrss_mb: float
    problems: list
    last_line: str


def _prepare_special(d, kind):
    t = d / "target"
    if kind == "chardev":
        try:
            os.mknod(t, stat.S_IFCHR | 0o666, os.makedev(1, 3))  # a /dev/null of our own
        except PermissionError:
            return None
    elif kind == "fifo":
        os.mkfifo(t)
        got = []

        def reader():
            with open(t, "rb") as fh:
                while fh.read(65536):
                    pass
            got.append(True)
        threading.Thread(target=reader, daemon=True).start()
    elif kind == "symlink":
        (d / "real.txt").write_text("original\n")
        os.symlink("real.txt", t)
    return t


def _is_still(t, kind):
    mode = os.lstat(t).st_mode
    return {"chardev": stat.S_ISCHR, "fifo": stat.S_ISFIFO, "symlink": stat.S_ISLNK}[kind](mode)


def _snapshot(d):
    out = set()
    for root, dirs, files in os.walk(d):
        for n in dirs + files:
            out.add(os.path.relpath(os.path.join(root, n), d))
    return out


def run_case(case, timeout_s, mem_bytes):
    d = Path(tempfile.mkdtemp(prefix="sweep-"))
    try:
        _write_files(d, case.files)
        target = _prepare_special(d, case.special) if case.special else None
        if case.special and target is None:
            return Outcome(case, None, 0.0, 0.0, ["SKIPPED (no mknod)"], "")
        before = _snapshot(d)
        out_f, err_f = open(d.parent / f"{d.name}.out", "w+b"), open(d.parent / f"{d.name}.err", "w+b")

        def limits():
            os.setsid()
            resource.setrlimit(resource.RLIMIT_AS, (mem_bytes, mem_bytes))

        env = dict(os.environ, MPLBACKEND="Agg", PYTHONFAULTHANDLER="")
        t0 = time.perf_counter()
        p = subprocess.Popen([VRCAL, *case.args], cwd=d, stdout=out_f, stderr=err_f, stdin=subprocess.DEVNULL,
                             preexec_fn=limits, env=env)
        limit = case.timeout or timeout_s
        timed_out, signalled, status, rusage = False, False, None, None
        while True:
            pid, status, rusage = os.wait4(p.pid, os.WNOHANG)
            if pid:
                break
            el = time.perf_counter() - t0
            if case.signal_after_s and not signalled and el >= case.signal_after_s:
                os.kill(p.pid, signal.SIGTERM)
                signalled = True
            if el > limit:
                timed_out = True
                os.killpg(p.pid, signal.SIGKILL)
                _, status, rusage = os.wait4(p.pid, 0)
                break
            time.sleep(0.01)
        p.returncode = 0  # reaped by wait4
        wall = time.perf_counter() - t0
        code = os.waitstatus_to_exitcode(status)
        out_f.seek(0)
        err_f.seek(0)
        stdout = out_f.read().decode("utf-8", "replace")
        stderr = err_f.read().decode("utf-8", "replace")
        out_f.close()
        err_f.close()
        os.unlink(out_f.name)
        os.unlink(err_f.name)
        problems = []
        if "Traceback (most recent call last)" in stderr or "MemoryError" in stderr:
            problems.append("TRACEBACK")
        if timed_out:
            problems.append("TIMEOUT")
        lines = [ln for ln in stderr.splitlines() if ln.strip() and not ln.startswith(("discover:", "wrote "))]
        last = lines[-1] if lines else ""
        if not timed_out and not signalled:
            if case.expect == "error" and code == 0:
                problems.append("SILENT")
            if case.expect == "warn" and code == 0 and "warning" not in (stderr + stdout).lower():
                problems.append("SILENT")
            if case.expect == "ok" and code != 0:
                problems.append("FAILED")
            if code not in (0, None) and "TRACEBACK" not in problems:
                errs = [ln for ln in lines if not ln.startswith(("vrcal: warning", "warning"))]
                if code not in (1, 2) or len(errs) != 1 or not errs[0].startswith("vrcal: error: "):
                    problems.append("MULTILINE")
                elif len(errs[0]) > 450:
                    problems.append("LONGERROR")
        after = _snapshot(d)
        new = sorted(after - before)
        hidden = [n for n in new if os.path.basename(n).startswith(".") or n.endswith(".tmp")]
        # a signalled run may have finished its (atomic, so complete) writes just before the signal:
        # there only temporary files count as left behind
        if hidden or (code != 0 and new and not timed_out and not signalled):
            problems.append("LEFT " + ",".join(new[:4]) + ("..." if len(new) > 4 else ""))
        if case.special and target is not None and not _is_still(target, case.special):
            problems.append("REPLACED")
        if case.special == "symlink" and code == 0 and (d / "real.txt").read_text() == "original\n":
            problems.append("CHECK symlink target not written")
        if case.check and code == 0:
            msg = case.check(d, stdout)
            if msg:
                problems.append("CHECK " + msg)
        return Outcome(case, code, wall, (rusage.ru_maxrss / 1024 if rusage else 0.0), problems, last[:90])
    finally:
        for root, dirs, _files in os.walk(d):
            for n in dirs:
                try:
                    os.chmod(os.path.join(root, n), 0o755)
                except OSError:
                    pass
        shutil.rmtree(d, ignore_errors=True)


def all_cases():
    numeric, skipped = numeric_option_cases()
    cases = numeric + measurement_cases() + yaml_cases() + output_cases() + size_cases() + track_cases()
    return cases, skipped


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("-j", "--jobs", type=int, default=2, help="cases run at once")
    parser.add_argument("--timeout", type=float, default=60.0, help="wall-time limit per case [s]")
    parser.add_argument("--mem-gib", type=float, default=6.0, help="address-space limit per case [GiB]")
    parser.add_argument("--only", nargs="*", default=None, help="run only cases whose name contains a WORD")
    parser.add_argument("--list", action="store_true", help="list the cases and exit")
    parser.add_argument("--all", action="store_true", help="print every case, not only those with problems")
    args = parser.parse_args()
    cases, skipped = all_cases()
    if args.only:
        cases = [c for c in cases if any(w.lower() in c.name.lower() for w in args.only)]
    if args.list:
        for c in cases:
            print(f"{c.owner:<9} {c.expect:<6} {c.name}")
        print(f"{len(cases)} cases")
        return 0
    for c in cases:  # make the fixtures before the threads start
        for v in c.files.values():
            if isinstance(v, str) and v.startswith("fixture:"):
                fixture(v[len("fixture:"):])
    t0 = time.perf_counter()
    outcomes = []
    with concurrent.futures.ThreadPoolExecutor(max_workers=args.jobs) as pool:
        futures = [pool.submit(run_case, c, args.timeout, int(args.mem_gib * 2**30)) for c in cases]
        for f in concurrent.futures.as_completed(futures):
            o = f.result()
            outcomes.append(o)
            if o.problems:
                print(f"  ... {o.case.name}: {' '.join(o.problems)}", file=sys.stderr, flush=True)
    outcomes.sort(key=lambda o: (not o.problems, o.case.owner, o.case.name))
    print(f"{'case':<58} {'owner':<9} {'exit':>4} {'time s':>7} {'MB':>6}  problems / last line")
    for o in outcomes:
        if not o.problems and not args.all:
            continue
        code = "-" if o.code is None else str(o.code)
        print(f"{o.case.name[:58]:<58} {o.case.owner:<9} {code:>4} {o.wall_s:7.2f} {o.maxrss_mb:6.0f}  "
              f"{' '.join(o.problems) or o.last_line}")
    print()
    kinds = ["TRACEBACK", "TIMEOUT", "SILENT", "FAILED", "MULTILINE", "LONGERROR", "LEFT", "REPLACED", "CHECK"]
    owners = sorted({o.case.owner for o in outcomes})
    print(f"{'owner':<10} {'cases':>5} {'clean':>5} " + " ".join(f"{k:>9}" for k in kinds))
    for owner in owners + ["all"]:
        sel = [o for o in outcomes if owner in ("all", o.case.owner)]
        counts = [sum(any(p.startswith(k) for p in o.problems) for o in sel) for k in kinds]
        clean = sum(not o.problems for o in sel)
        print(f"{owner:<10} {len(sel):5d} {clean:5d} " + " ".join(f"{n:9d}" for n in counts))
    slow = sorted(outcomes, key=lambda o: -o.wall_s)[:5]
    print("\nslowest: " + "; ".join(f"{o.case.name} {o.wall_s:.1f} s" for o in slow))
    print(f"peak memory: {max(o.maxrss_mb for o in outcomes):.0f} MB; "
          f"wall time of the sweep: {time.perf_counter() - t0:.0f} s")
    if skipped:
        print(f"commands with numeric options but no base arguments in this sweep: {', '.join(skipped)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
