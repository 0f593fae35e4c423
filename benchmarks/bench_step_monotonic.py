"""Is "passes at a step" monotonic in the step? ODE and PyBullet, balls of the standards and users' own.

Run: python benchmarks/bench_step_monotonic.py [--steps 60] [--engines bullet,ode] [--phases 4]
     python benchmarks/bench_step_monotonic.py --steps 0      (the contact-phase table only)

For each ball (every ball of the standards at its nominal epsilon and drop height, and three of
users' own given as --mass/--diameter/--epsilon/--drop-height) and each engine, the drop test of
`vrcal export` (``--phases`` contact phases x 3 bounces, tolerance 0.01, penetration limit R/4) is
run at ``--steps`` steps spaced evenly in log from 1/60 s down to 1/2000 s. Printed per (engine,
ball): the largest step that passed, how many smaller steps missed (with the first few), and the
largest ratio of the measured worst epsilon error to the step bound of
vrcal.engines.export.step_bound (above 1: the bound does not hold there). Then, for the softest
ball, the worst error at a few steps with 4, 16 and 64 contact phases in PyBullet, ODE and MuJoCo,
and the wall time of each drop test: how much a pass at 4 phases is a sample, and what the export's
confirmation with 16 (vrcal.engines.common.CONFIRM_PHASES) costs. Prints numbers; asserts nothing.
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
    for engine in args.engines.split(",") if args.steps else ():
        for name in BALLS + tuple(OWN):
            largest, below, ratio = sweep(engine, name, steps, args.phases)
            first = " ".join(f"{dt:.3g}" for dt in below[:4])
            print(f"{engine:7} {name:18} {largest or float('nan'):14.3g} {len(below):12d}  {ratio:13.2f}  {first}")
    print("soft 200 g (own): worst epsilon error by contact phases (wall time of the drop test)")
    for engine, steps in (("bullet", (7.7e-4, 5.8e-4, 4.6e-4, 2e-4)), ("ode", (2e-3, 1e-3, 7.7e-4, 5e-4)),
                          ("mujoco", (1e-3, 7e-4, 4.7e-4))):
        for dt in steps:
            print(f"  {engine:6} dt {dt:g} s: " + "  ".join(
                f"{n} phases {err:.4f} ({wall:.1f} s)" for n, err, wall in by_phases(engine, dt)))


def by_phases(engine, dt, phases=(4, 16, 64)):
    """(phases, worst error, wall s) of the soft ball's drop test at dt; MuJoCo: its contact calibrated
    at dt over 4 phases, then run over each count."""
    import time

    setup = replace(build_setup(None, engine, **OWN["soft 200 g (own)"]), dt_s=dt)
    if engine == "mujoco":
        from vrcal.engines import mujoco as M

        mjcf = M.model_xml(setup, M.calibrate(setup, 4).contact)
    out = []
    for n in phases:
        t0 = time.perf_counter()
        runs = (M.drop_test(mjcf, setup, setup.n_bounces, n) if engine == "mujoco"
                else _run_in_engine(setup, engine, dt, n))
        out.append((n, runs.worst_error, time.perf_counter() - t0))
    return out

if __name__ == "__main__":
    main()
