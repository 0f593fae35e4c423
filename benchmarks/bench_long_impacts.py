"""``discover`` on long records of impact times: wall time and peak memory against the number of impacts.

Run: python benchmarks/bench_long_impacts.py [--sizes 100 500 2000 5000 20000] [--scatters 0.01 0]
                                             [--limit-gb 16] [--timeout 1800]

Each record is a steel-like ball (20 g, 40 mm: drag-free impact times do not depend on it) dropped from
2 m with epsilon 0.99 (the plausibility checks take flights shrinking by less than 0.5 % a bounce
for a clock's ticks), each bounce's epsilon scattering by ``scatter`` (0.01: 1 %; 0: none) and each
time by a phone's 0.2 ms (:func:`vrcal.drop.synthetic.scattered_impact_times`). One drop gives at most
:data:`RUN_IMPACTS` impacts (its last flight then lasts 8.6 ms, 40 times the timing noise; 20,000
impacts of one drop would need flights far below a microsecond): longer records are several drops
fitted jointly (:class:`vrcal.measurements.Runs`, as a file with several chains is read), 500 impacts
each from heights 2.0, 1.975, 1.95 ... m; 20,000 impacts (the most the impact reader accepts,
:data:`vrcal.measurements.impacts.MAX_IMPACT_EVENTS`) are 40 drops.

Every case runs :func:`vrcal.discovery.ranking.discover` in a fresh process, so that the peak resident
memory (``ru_maxrss``) is the case's own; ``--limit-gb`` caps the address space of that process (a case
that would need more fails with a MemoryError instead of swapping), ``--timeout`` its wall time. The
table gives the wall time of discover alone (the record built beforehand), the peak memory of the whole
process (Python, numpy and vrcal imported: about 100 MB of it), epsilon, the named effects and whether
the effects were judged by generalized least squares (the bounces' scatter found). Prints numbers;
asserts nothing.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import time

sys.path.insert(0, os.path.join(os.path.dirname(__file__), ".."))

#: Most impacts of one drop in these records.
RUN_IMPACTS = 500


def make_record(n, scatter, seed=0):
    """``n`` impact times: one drop up to :data:`RUN_IMPACTS` impacts, else several fitted jointly."""
    from vrcal.drop.synthetic import scattered_impact_times
    from vrcal.measurements import Runs

    sizes = [RUN_IMPACTS] * (n // RUN_IMPACTS) + ([n % RUN_IMPACTS] if n % RUN_IMPACTS else [])
    runs = [scattered_impact_times(seed + i, drop_height_m=2.0 - 0.025 * i, epsilon=0.99, scatter=scatter,
                                   n_impacts=k, release_time_s=1.0) for i, k in enumerate(sizes)]
    if len(runs) == 1:
        return runs[0]
    return Runs(runs=tuple(runs), source=f"{len(runs)} drops", labels=tuple(f"drop {i + 1}" for i in range(len(runs))))


def one_case(n, scatter):
    """Run discover once; print a JSON line with the numbers."""
    from vrcal.discovery.ranking import discover
    from vrcal.model.body import BallProperties

    data = make_record(n, scatter)
    t0 = time.perf_counter()
    d = discover(data, BallProperties(0.020, 0.040, "steel-like"))
    wall = time.perf_counter() - t0
    peak_mb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0
    print(json.dumps({"n": n, "scatter": scatter, "wall_s": wall, "peak_mb": peak_mb,
                      "epsilon": d.final.value("epsilon"), "named": list(d.effects),
                      "judged": d.judged is not None}))


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[100, 500, 2000, 5000, 20000])
    parser.add_argument("--scatters", type=float, nargs="+", default=[0.01, 0.0])
    parser.add_argument("--limit-gb", type=float, default=16.0, help="address-space cap of each case [GiB]")
    parser.add_argument("--timeout", type=float, default=1800.0, help="wall-time cap of each case [s]")
    parser.add_argument("--one", nargs=2, metavar=("N", "SCATTER"), help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.one:
        one_case(int(args.one[0]), float(args.one[1]))
        return

    def limit():
        cap = int(args.limit_gb * 2**30)
        resource.setrlimit(resource.RLIMIT_AS, (cap, cap))

    print(f"{'impacts':>8} {'scatter':>8} {'time [s]':>9} {'peak [MB]':>10} {'epsilon':>9} {'GLS':>4}  named")
    for scatter in args.scatters:
        for n in args.sizes:
            cmd = [sys.executable, __file__, "--one", str(n), str(scatter)]
            try:
                out = subprocess.run(cmd, capture_output=True, text=True, timeout=args.timeout, preexec_fn=limit)
            except subprocess.TimeoutExpired:
                print(f"{n:>8} {scatter:>8g} {'> ' + format(args.timeout, 'g'):>9}  (timed out)", flush=True)
                continue
            lines = [line for line in out.stdout.splitlines() if line.startswith("{")]
            if out.returncode or not lines:
                why = (out.stderr.strip().splitlines() or ["?"])[-1][:60]
                print(f"{n:>8} {scatter:>8g} {'failed':>9}  ({why})", flush=True)
                continue
            r = json.loads(lines[-1])
            print(f"{n:>8} {scatter:>8g} {r['wall_s']:>9.2f} {r['peak_mb']:>10.0f} {r['epsilon']:>9.5f} "
                  f"{'yes' if r['judged'] else 'no':>4}  {', '.join(r['named']) or '-'}", flush=True)


if __name__ == "__main__":
    main()
