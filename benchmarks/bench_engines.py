"""The drop test of vrcal's exports in MuJoCo, ODE and PyBullet: step, epsilon error, penetration, speed.

Run: python benchmarks/bench_engines.py [--phases 4] [--bounces 3] [--record ../shared/data/pingpong-drop-video/raw.txt]

For each engine and time step, every ball of the standards at its nominal epsilon is exported
(`vrcal export BALL --engine E --dt DT`: MuJoCo calibrated in MuJoCo at that step, Euler) and
dropped from its standard's drop height ``--phases`` times with the impact moved across one
step, ``--bounces`` bounces each (`vrcal verify`). A step the export refuses is counted as
refused. Printed per (engine, step): balls that pass (worst |epsilon error| <= 0.01 and the
ball turning within a quarter of its radius from the floor), the worst and median |epsilon
error| over the balls that were exported, the largest penetration (or hover) as a fraction
of the radius, the engine's own wall time per simulated second (one drop of 2 s: stepping
and reading the ball's state, through vrcal's Python loop for ODE and PyBullet, MuJoCo's
rollout in C), and the export's wall time per ball (for MuJoCo the calibration in MuJoCo).
Then vrcal's own simulator on the same drops, a user's
ball (a golf ball) at MuJoCo's default step, and, when the record is there, the ping-pong
video replayed in each engine from its discover result. Prints numbers; asserts nothing.
"""

import argparse
import os
import tempfile
import time

import numpy as np

from vrcal.drop.simulate import simulate_drops
from vrcal.engines import ENGINES, load, require_runtime
from vrcal.engines.common import phase_shifts_m
from vrcal.engines.export import export, parse_exported
from vrcal.errors import EngineUnavailable, UsageError
from vrcal.model.body import BallProperties
from vrcal.model.standards import load_standards

STEPS = {
    "mujoco": (2e-3, 1e-3, 5e-4, 2e-4, 1e-4),
    "ode": (2e-3, 1e-3, 5e-4, 2e-4, 1e-4),
    "bullet": (1 / 240, 2e-3, 1e-3, 5e-4, 2e-4),
}


def engine_rows(name, balls, n_bounces, n_phases):
    module = load(name)
    rows = []
    for dt in STEPS[name]:
        errors, medians, depths, walls, calib, passed, refused = [], [], [], [], [], 0, 0
        for ball in balls:
            t0 = time.perf_counter()
            try:
                ex = export(ball, name, dt_s=dt)
            except UsageError:
                refused += 1
                continue
            calib.append(time.perf_counter() - t0)
            setup = ex.setup
            loaded = parse_exported(name, ex.text)
            runs = module.drop_test(loaded, setup, n_bounces, n_phases)
            walls.append(engine_wall_per_simulated_s(name, module, loaded, setup))
            errors.append(runs.worst_error)
            medians.append(runs.median_error)
            depth = max(runs.penetration_m, runs.hover_m)
            depths.append(depth / setup.radius_m)
            passed += runs.worst_error <= 0.01 and depth <= setup.penetration_limit_m
        rows.append((dt, passed, refused, errors, medians, depths, walls, calib))
    return rows


def engine_wall_per_simulated_s(name, module, loaded, setup, seconds=2.0):
    """Wall time [s] of the engine alone (stepping and reading the ball's state) per simulated second."""
    if name == "mujoco":
        loaded = module.load_model(loaded)             # compiled once, outside the timing
    t0 = time.perf_counter()
    if name == "mujoco":
        module.run_drops(loaded, setup.drop_height_m, [0.0], seconds, setup.radius_m)
    else:
        module.run_drop(loaded, setup.drop_height_m, seconds)
    return (time.perf_counter() - t0) / seconds


def print_engine(name, version, rows, n_balls):
    print(f"\n{name} ({version}); {n_balls} balls of the standards at their nominal epsilon")
    print(f"{'dt [s]':>9} {'pass':>5} {'refused':>7} {'worst err':>9} {'median':>8} {'depth/R':>8} "
          f"{'wall ms per sim s':>17} {'export s':>8}")
    for dt, passed, refused, errors, medians, depths, walls, calib in rows:
        if not errors:
            print(f"{dt:9.3g} {passed:5d} {refused:7d} {'-':>9} {'-':>8} {'-':>8} {'-':>17} {'-':>8}")
            continue
        print(f"{dt:9.3g} {passed:5d} {refused:7d} {max(errors):9.4f} {float(np.median(medians)):8.4f} "
              f"{max(depths):8.3f} {1e3 * float(np.mean(walls)):17.2f} {float(np.mean(calib)):8.3f}")


def vrcal_rows(balls, n_bounces, n_phases):
    standards = load_standards()
    t_total, sim_total, worst = 0.0, 0.0, 0.0
    for ball in balls:
        ex = export(ball, "ode", dt_s=1e-4)
        s = ex.setup
        H = s.drop_height_m + phase_shifts_m(s, n_phases)
        t0 = time.perf_counter()
        for _ in range(20):
            d = simulate_drops(H, s.epsilon, n_bounces, BallProperties(s.mass_kg, 2 * s.radius_m))
        t_total += (time.perf_counter() - t0) / 20
        sim_total += float(np.sum(d.apex_times_s[:, -1]))
        apex = np.sqrt(d.apex_heights_m[:, 1:] / d.apex_heights_m[:, :-1])
        worst = max(worst, float(np.max(np.abs(apex - s.epsilon))))
    del standards
    print(f"\nvrcal simulate_drops (event-driven, exact impacts): worst error {worst:.1e}, "
          f"wall {1e3 * t_total / sim_total:.4f} ms per simulated s")


def users_ball():
    print("\na user's ball at MuJoCo's default step (golf ball 45.9 g, 42.7 mm, epsilon 0.78, dropped 1 m):")
    for dt in (2e-3, 1e-3):
        try:
            ex = export(None, "mujoco", mass_kg=0.0459, diameter_m=0.0427, epsilon=0.78, drop_height_m=1.0, dt_s=dt)
            d = ex.data
            print(f"  dt {dt:g} s: worst error {d['worst_error']:.4f}, median {d['median_error']:.4f}, penetration "
                  f"{1e3 * d['penetration_m']:.2f} mm, hover {1e3 * d['hover_m']:.2f} mm (limit 5.34 mm)")
        except UsageError as exc:
            print(f"  dt {dt:g} s: refused: {exc}")


def pingpong(record, engines):
    from vrcal.discovery.ranking import discover_file
    from vrcal.engines.replay import replay

    if not os.path.exists(record):
        print(f"\n{record} is absent: no replay")
        return
    result = discover_file(record, "table_tennis", fs_hz=100)
    with tempfile.TemporaryDirectory() as tmp:
        path = os.path.join(tmp, "pp.json")
        import json

        with open(path, "w") as f:
            json.dump(result.as_dict(), f)
        print(f"\nping-pong video replayed from its discover result ({', '.join(result.effects)}); "
              "rebound apexes vs the measured ones [% of the rise]:")
        print(f"{'engine':<8} {'dt [s]':>8} {'export':>24} {'vrcal model':>24} {'constant eps':>24} {'gap mm':>7}")
        for name in engines:
            for dt in ((2e-3, 1e-3, 1e-4) if name == "mujoco" else (5e-4, 1e-4)):
                try:
                    r = replay(path, record, name, dt_s=dt, fs_hz=100)
                except UsageError as exc:
                    print(f"{name:<8} {dt:8.3g} refused: {str(exc)[:80]}")
                    continue
                cells = [" ".join(f"{100 * e:+5.1f}" for e in r.apex_errors(k))
                         for k in ("engine", "vrcal", "constant")]
                print(f"{name:<8} {dt:8.3g} {cells[0]:>24} {cells[1]:>24} {cells[2]:>24} "
                      f"{1e3 * r.gaps_m['engine']:7.2f}")


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--phases", type=int, default=4)
    ap.add_argument("--bounces", type=int, default=3)
    ap.add_argument("--record", default=os.path.join(os.path.dirname(__file__), "..", "..", "shared", "data",
                                                     "pingpong-drop-video", "raw.txt"))
    args = ap.parse_args()
    balls = list(load_standards())
    print(f"drop test: {args.phases} contact phases x {args.bounces} bounces per ball; pass = worst |eps error| "
          "<= 0.01 and penetration/hover <= R/4")
    engines = []
    for name, engine in ENGINES.items():
        if not engine.runs:
            continue
        try:
            version = require_runtime(name)
        except EngineUnavailable as exc:
            print(f"{name}: skipped: {exc}")
            continue
        engines.append(name)
        print_engine(name, version, engine_rows(name, balls, args.bounces, args.phases), len(balls))
    vrcal_rows(balls, args.bounces, args.phases)
    if "mujoco" in engines:
        users_ball()
    pingpong(args.record, engines)


if __name__ == "__main__":
    main()
