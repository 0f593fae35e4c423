"""The same drop test in MuJoCo, ODE, PyBullet and vrcal's event-driven simulator.

Run: python benchmarks/bench_engines.py [--ball basketball] [--phases 4] [--bounces 3]

For each target epsilon the ball of the standard is dropped from its drop height with the
settings `vrcal export` writes (default time step per engine), ``--phases`` times with the
impact moved across one step, ``--bounces`` bounces each. Prints the wall time per drop,
its ratio to vrcal's simulator (vrcal.drop.simulate.simulate_drops, closed-form flights and
exact impacts) and the largest |achieved - target| epsilon (apex and velocity ratios).
An engine that is not installed is reported and skipped. Prints numbers; asserts nothing.
"""

import argparse
import time

import numpy as np

from vrcal.drop.simulate import simulate_drops
from vrcal.engines import ENGINES, load, require_runtime
from vrcal.engines.export import export, parse_exported
from vrcal.errors import EngineUnavailable
from vrcal.model.body import BallProperties
from vrcal.model.standards import get_ball

EPSILONS = (0.5, 0.7, 0.85, 0.9, 0.95)


def vrcal_drop_test(setup, n_bounces, n_phases):
    """vrcal's simulator on the same drops (all phases in one vectorised call)."""
    shifts = setup.impact_speed_m_per_s * setup.dt_s * np.arange(n_phases) / n_phases
    drops = simulate_drops(setup.drop_height_m + shifts, setup.epsilon, n_bounces,
                           BallProperties(setup.mass_kg, 2 * setup.radius_m), g_m_per_s2=setup.g_m_per_s2)
    apex = np.sqrt(drops.apex_heights_m[:, 1:] / drops.apex_heights_m[:, :-1])
    vel = drops.rebound_speeds_m_per_s / drops.impact_speeds_m_per_s
    return apex, vel


def timed(fn, repeat):
    best, out = np.inf, None
    for _ in range(repeat):
        t0 = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t0)
    return best, out


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--ball", default="basketball")
    ap.add_argument("--phases", type=int, default=4)
    ap.add_argument("--bounces", type=int, default=3)
    args = ap.parse_args()
    ball = get_ball(args.ball)
    n_drops = args.phases
    print(f"drop test: {ball.key}, {args.bounces} bounces x {args.phases} contact phases per epsilon; "
          "time = best of 3 (engines) / 20 (vrcal: all phases in one vectorised call), per drop")
    print(f"{'engine':<8} {'version':<30} {'dt [s]':>8} {'eps':>5} {'ms/drop':>10} {'x vrcal':>9} {'max |err|':>10}")
    engines = {}
    for name, engine in ENGINES.items():
        if not engine.runs:
            continue
        try:
            engines[name] = require_runtime(name)
        except EngineUnavailable as exc:
            print(f"{name:<8} skipped: {exc}")
    for eps in EPSILONS:
        ex = export(ball.key, "ode", epsilon=eps)
        t_v, (apex, vel) = timed(lambda: vrcal_drop_test(ex.setup, args.bounces, n_drops), 20)
        err_v = max(np.max(np.abs(apex - eps)), np.max(np.abs(vel - eps)))
        print(f"{'vrcal':<8} {'simulate_drops (event-driven)':<30} {'exact':>8} {eps:5.2f} {t_v / n_drops * 1e3:10.4f} "
              f"{1.0:9.0f} {err_v:10.2e}")
        for name, version in engines.items():
            ex = export(ball.key, name, epsilon=eps)
            params = parse_exported(name, ex.text)
            module = load(name)
            t, (_, apex, vel) = timed(lambda: module.drop_test(params, ex.setup, args.bounces, n_drops), 3)
            err = max(np.max(np.abs(apex - eps)), np.max(np.abs(vel - eps)))
            print(f"{name:<8} {version[:30]:<30} {ex.setup.dt_s:8.2g} {eps:5.2f} {t / n_drops * 1e3:10.3f} "
                  f"{t / t_v:9.0f} {err:10.2e}")


if __name__ == "__main__":
    main()
