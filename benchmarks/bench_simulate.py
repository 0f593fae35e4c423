"""Speed of the drop simulator: simulated drops per second, single and vectorised.

Run: python benchmarks/bench_simulate.py [--million]

Targets (issue 3, part 5): a 10-bounce drop in well under a millisecond; a million
drops in seconds. Prints numbers only; asserts nothing.
"""

import argparse
import time

import numpy as np

from vrcal.drop.simulate import simulate_drops
from vrcal.model.body import BallProperties

TT = BallProperties(0.0027, 0.040, "table_tennis")
ALL = {"air_drag": {}, "velocity_dependent_restitution": {}, "contact_duration": {}, "height_offset": {},
       "buoyancy": {}}


def best_of(fn, repeat=5, number=1):
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        for _ in range(number):
            fn()
        times.append((time.perf_counter() - t0) / number)
    return min(times)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--million", action="store_true", help="batch of 1,000,000 drops (default 100,000)")
    args = parser.parse_args()
    print("vrcal simulate_drops benchmark (10 bounces per drop; single drops: best of 5 x 200 calls, "
          "batches: best of 3)")
    for label, effects in (("no effects", None), ("air_drag", {"air_drag": {}}), ("all five effects", ALL)):
        t = best_of(lambda: simulate_drops(0.305, 0.9, 10, TT, effects=effects), number=200)
        print(f"  single drop, {label:17s}: {t * 1e6:8.1f} us/drop  ({1 / t:10.0f} drops/s)")
    big = 1_000_000 if args.million else 100_000
    rng = np.random.default_rng(0)
    H = rng.uniform(0.2, 2.0, big)
    eps = rng.uniform(0.6, 0.95, big)
    cd = rng.uniform(0.3, 0.6, big)
    for label, effects in (("no effects", None), ("air_drag", {"air_drag": {"drag_coefficient": cd}}),
                           ("all five effects", dict(ALL, air_drag={"drag_coefficient": cd}))):
        t = best_of(lambda: simulate_drops(H, eps, 10, TT, effects=effects), repeat=3)
        print(f"  {big:,} drops at once, {label:17s}: {t:6.3f} s  ({big / t:12.0f} drops/s)")
    d = simulate_drops(0.305, 0.9, 10, TT, effects={"air_drag": {}})
    t_s = np.arange(0, d.landing_times_s[0], 1 / 240.0)
    t = best_of(lambda: d.height_m(t_s), number=50)
    print(f"  trajectory of one drop at 240 Hz ({t_s.size} frames): {t * 1e3:.3f} ms")


if __name__ == "__main__":
    main()
