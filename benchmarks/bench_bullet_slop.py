"""What takes restitution off a slow bounce in PyBullet: the contact slop, and the bounce threshold.

Run: python benchmarks/bench_bullet_slop.py [--phases 16]

1. The exported settings (``vrcal export --engine bullet``) with PyBullet's default
   ``contactSlop`` (1e-5 m) and with the exported 0: the worst |epsilon error| of each impact
   (3 bounces, ``--phases`` contact phases) at steps from 2 ms to 0.1 ms, for a soft ball of
   one's own (200 g, 70 mm, epsilon 0.45, 0.5 m) and three balls of the standards. The slop
   takes up to ``slop / (v dt)`` off epsilon; it grows as the step shrinks.
2. ``restitutionVelocityThreshold``: the soft ball's velocity ratio at each of 6 impacts (down to
   0.06 m/s) at 1 ms with Bullet's default 0.2 m/s and the exported 0.01 m/s.

Prints numbers; asserts nothing.
"""

import argparse
from dataclasses import replace

import numpy as np

from vrcal.engines import bullet as E
from vrcal.engines.export import build_setup

SOFT = dict(mass_kg=0.2, diameter_m=0.07, epsilon=0.45, drop_height_m=0.5)
BALLS = ("soft 200 g (own)", "basketball", "tennis", "table_tennis")
STEPS = (2e-3, 1e-3, 5e-4, 2e-4, 1e-4)


def per_impact(setup, slop, n_phases):
    params = E.export_params(setup)
    params["setPhysicsEngineParameter"]["contactSlop"] = slop
    runs = E.drop_test(params, setup, setup.n_bounces, n_phases)
    return np.max(np.abs(runs.errors), axis=(0, 1))


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--phases", type=int, default=16)
    args = ap.parse_args()
    print(f"worst |epsilon error| per impact, {args.phases} phases x 3 bounces: "
          f"contactSlop {E.PYBULLET_CONTACT_SLOP_M:g} m (PyBullet) | {E.CONTACT_SLOP_M:g} (exported)")
    for name in BALLS:
        setup0 = build_setup(None, "bullet", **SOFT) if name.startswith("soft") else build_setup(name, "bullet")
        speeds = " ".join(f"{v:.2f}" for v in setup0.impact_speeds_m_per_s[:3])
        print(f"{name} (impacts {speeds} m/s)")
        for dt in STEPS:
            setup = replace(setup0, dt_s=dt)
            old, new = (per_impact(setup, slop, args.phases) for slop in (E.PYBULLET_CONTACT_SLOP_M, E.CONTACT_SLOP_M))
            print(f"  dt {dt * 1e3:4.1f} ms:  " + " ".join(f"{x:.4f}" for x in old) + "  |  "
                  + " ".join(f"{x:.4f}" for x in new))
    setup = replace(build_setup(None, "bullet", **SOFT), dt_s=1e-3, n_bounces=6)
    print("soft 200 g (own), 6 impacts at " + " ".join(f"{v:.2f}" for v in setup.impact_speeds_m_per_s[:6])
          + " m/s, dt 1 ms, 1 phase: stored velocity after / before the contact step")
    for threshold in (0.2, E.RESTITUTION_VELOCITY_THRESHOLD):
        params = E.export_params(replace(setup, n_bounces=3))
        params["setPhysicsEngineParameter"]["restitutionVelocityThreshold"] = threshold
        z, v, dt, g = E.run_drop(params, setup.drop_height_m, 1.2)
        turns = np.flatnonzero((v[:-1] < 0) & (v[1:] > v[:-1] + 1e-9))[:6]
        ratios = " ".join(f"{v[i + 1] / -v[i]:.3f}" for i in turns)
        print(f"  restitutionVelocityThreshold {threshold:g} m/s: {ratios}")


if __name__ == "__main__":
    main()
