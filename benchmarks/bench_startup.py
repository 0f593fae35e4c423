"""Cold start of `vrcal fit basketball` against `python -c "import numpy, yaml, click"`.

Run: python benchmarks/bench_startup.py [--runs 40] [--command "fit basketball"]

Both are run as fresh processes, one after the other in turn (interleaved, so a change of the
machine's load hits both alike), after two warm-up runs of each; the script prints the median,
the quartiles and the ratio of the medians. The issue's goal is a ratio <= 1.3: vrcal's own work
(its modules, the standards file, the table) costs at most 30 % of importing the three libraries
it cannot do without. Prints numbers; asserts nothing.
"""

import argparse
import shlex
import statistics
import subprocess
import sys
import time
from pathlib import Path


def wall_s(argv):
    """Wall time [s] of one run of ``argv`` (stdout and stderr discarded); fails on a non-zero exit."""
    t0 = time.perf_counter()
    subprocess.run(argv, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, check=True)
    return time.perf_counter() - t0


def quartiles_ms(times):
    q1, q2, q3 = statistics.quantiles(times, n=4)
    return f"median {q2 * 1e3:7.1f} ms  (quartiles {q1 * 1e3:6.1f} .. {q3 * 1e3:6.1f} ms)"


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=40, help="runs of each command (default 40)")
    parser.add_argument("--command", default="fit basketball", help="vrcal arguments (default 'fit basketball')")
    args = parser.parse_args()
    vrcal = Path(sys.executable).with_name("vrcal")
    exe = [str(vrcal)] if vrcal.exists() else [sys.executable, "-m", "vrcal"]
    cases = {
        "python -c 'import numpy, yaml, click'": [sys.executable, "-c", "import numpy, yaml, click"],
        f"vrcal {args.command}": exe + shlex.split(args.command),
    }
    times = {name: [] for name in cases}
    for _ in range(2):
        for argv in cases.values():
            wall_s(argv)
    for _ in range(max(args.runs, 4)):
        for name, argv in cases.items():
            times[name].append(wall_s(argv))
    width = max(map(len, cases))
    print(f"cold start, {max(args.runs, 4)} interleaved runs each ({sys.executable})")
    for name, t in times.items():
        print(f"  {name:<{width}}  {quartiles_ms(t)}")
    base, ours = (statistics.median(t) for t in times.values())
    print(f"  ratio (median vrcal / median import): {ours / base:.3f}  (goal <= 1.3)")


if __name__ == "__main__":
    main()
