"""Is "passes at a step" monotonic in the step? ODE and PyBullet, balls of the standards and users' own.

Run: python benchmarks/bench_step_monotonic.py [--steps 60] [--engines bullet,ode] [--phases 4]

For each ball (every ball of the standards at its nominal epsilon and drop height, and three of
users' own given as --mass/--diameter/--epsilon/--drop-height) and each engine, the drop test of
`vrcal export` (``--phases`` contact phases x 3 bounces, tolerance 0.01, penetration limit R/4) is
run at ``--steps`` steps spaced evenly in log from 1/60 s down to 1/2000 s. Printed per (engine,
ball): the largest step that passed, how many smaller steps missed (with the first few), and the
largest ratio of the measured worst epsilon error to the step bound of
vrcal.engines.export.step_bound (above 1: the bound does not hold there). Then, for the softest
ball, the worst error at a few steps with 4, 8, 16 and 32 contact phases: how much a pass at 4
phases is a sample. Prints numbers; asserts nothing.
"""

import argparse
from dataclasses import replace

import numpy as np

from vrcal.engines.export import _depth, _run_in_engine, build_setup, step_bound

OWN = {
    "golf (own)": dict(mass_kg=0.0459, diameter_m=0.0427, epsilon=0.78, drop_height_m=1.0),
    "soft 200 g (own)": dict(mass_kg=0.2, diameter_m=0.07, epsilon=0.45, drop_height_m=0.5),
    "lively 50 g (own)": dict(mass_kg=0.05, diameter_m=0.05, epsilon=0.92, drop_height_m=2.0),
}
BALLS = ("basketball", "volleyball", "football", "tennis", "table_tennis")


def sweep(engine, name, steps, n_phases):
    setup = build_setup(None if name in OWN else name, engine, **OWN.get(name, {}))
    passed, ratio = [], 0.0
    for dt in steps:
        trial = replace(setup, dt_s=float(dt))
        runs = _run_in_engine(trial, engine, float(dt), n_phases)
        if isinstance(runs, str) or runs is None:
            passed.append(False)
            continue
        bound = step_bound(trial, engine)[0]
        ratio = max(ratio, runs.worst_error / bound)
        passed.append(runs.worst_error <= setup.tolerance and _depth(runs) <= setup.penetration_limit_m)
    largest = max((dt for dt, ok in zip(steps, passed) if ok), default=None)
    below = [dt for dt, ok in zip(steps, passed) if not ok and largest is not None and dt < largest]
    return largest, below, ratio


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--steps", type=int, default=60)
    ap.add_argument("--engines", default="bullet,ode")
    ap.add_argument("--phases", type=int, default=4)
    args = ap.parse_args()
    steps = np.geomspace(1 / 60, 1 / 2000, args.steps)
    print(f"{args.steps} steps 1/60 .. 1/2000 s, {args.phases} phases x 3 bounces, tolerance 0.01, limit R/4")
    print(f"{'engine':7} {'ball':18} {'largest pass s':>14} {'missed below':>12}  {'max err/bound':>13}  "
          "first misses below")
    for engine in args.engines.split(","):
        for name in BALLS + tuple(OWN):
            largest, below, ratio = sweep(engine, name, steps, args.phases)
            first = " ".join(f"{dt:.3g}" for dt in below[:4])
            print(f"{engine:7} {name:18} {largest or float('nan'):14.3g} {len(below):12d}  {ratio:13.2f}  {first}")
    setup = build_setup(None, "bullet", **OWN["soft 200 g (own)"])
    print("soft 200 g (own) in bullet: worst epsilon error by contact phases")
    for dt in (7.7e-4, 5.8e-4, 4.6e-4, 3e-4, 2e-4, 1e-4):
        errs = [_run_in_engine(replace(setup, dt_s=dt), "bullet", dt, n).worst_error for n in (4, 8, 16, 32)]
        print(f"  dt {dt:g} s: " + "  ".join(f"{n} phases {e:.4f}" for n, e in zip((4, 8, 16, 32), errs)))


if __name__ == "__main__":
    main()
