"""How close the prior split (``Discovery.split``) and the named model come to the planted epsilon.

For each planted case of ``vrcal.drop.synthetic.hidden_effect_case`` it runs ``discover`` on
``--seeds`` seeds and, on the seeds where a rival is ambiguous (where a split exists), prints the
median and largest |epsilon - planted epsilon| at the reference speed (the first impact speed)
of the named model and of the split. Both effects planted is what a real ball has; one alone is a
world without air (or with a speed-independent contact), where the priors add what is not there.

Usage: python benchmarks/bench_split.py [--seeds 40] [--kinds impacts apexes trajectory]
"""

from __future__ import annotations

import argparse
import os
import sys

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(__file__), ".."))

from vrcal.discovery.ranking import discover  # noqa: E402
from vrcal.drop.synthetic import hidden_effect_case  # noqa: E402
from vrcal.model.body import BallProperties  # noqa: E402
from vrcal.model.standards import get_ball  # noqa: E402

CASES = {"impacts": [("air_drag",), ("velocity_dependent_restitution",), ("contact_duration",),
                     ("air_drag", "velocity_dependent_restitution")],
         "apexes": [("air_drag",), ("velocity_dependent_restitution",), ("height_offset",),
                    ("air_drag", "velocity_dependent_restitution")],
         "trajectory": [("air_drag",), ("velocity_dependent_restitution",), ("height_offset",),
                        ("air_drag", "velocity_dependent_restitution")]}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=40)
    ap.add_argument("--kinds", nargs="+", default=["impacts", "apexes"], choices=sorted(CASES))
    args = ap.parse_args(argv)
    print(f"{'kind':<11s} {'planted':<46s} {'ambiguous':>9s}  {'named: median':>13s} {'max':>6s}  "
          f"{'split: median':>13s} {'max':>6s}")
    for kind in args.kinds:
        for planted in CASES[kind]:
            named, shared = [], []
            for seed in range(args.seeds):
                data, truth = hidden_effect_case(seed, kind, planted)
                d = discover(data, BallProperties.from_ball(get_ball(truth["ball"])))
                if d.split is None:
                    continue
                v = [d.reference_speed]
                named.append(abs(d.epsilon_at(v)[0] - truth["epsilon"]))
                shared.append(abs(d.epsilon_at(v, fit=d.split)[0] - truth["epsilon"]))
            label = " + ".join(planted)
            if not named:
                print(f"{kind:<11s} {label:<46s} {0:>4d}/{args.seeds:<4d}  {'-':>13s} {'-':>6s}  {'-':>13s} {'-':>6s}")
                continue
            print(f"{kind:<11s} {label:<46s} {len(named):>4d}/{args.seeds:<4d}  {np.median(named):13.4f} "
                  f"{max(named):6.4f}  {np.median(shared):13.4f} {max(shared):6.4f}")


if __name__ == "__main__":
    main()
