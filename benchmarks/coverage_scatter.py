"""Coverage of discover's epsilon +- on impact times whose bounces scatter at random.

A ball that hits the floor at slightly different spots, with some spin, loses a little more or less
at each bounce: each bounce's epsilon scatters about the ball's own by a few per cent (the blue
ball's phyphox runs: 0.3-7 %, median 1.5 %). Such a scatter shifts every later impact time of the
run, so least squares' errors are not independent. This script plants it
(:func:`vrcal.drop.synthetic.scattered_impact_times`: drag-free flights from 0.45 m, eps_j = 0.88
exp(s z_j), z standard normal; a phone's timing noise 0.2 ms) and prints, over the seeds, the
standard deviation of the pulls (eps_found - eps) / +- and the fractions of them within 1 and 2
(0.68 and 0.95 for an honest +-): with the fit's own +- ((J^T J)^-1 RSS/(n-k), errors taken as
independent) and with the +- discover reports (widened by the sandwich of the scatter's covariance,
:func:`vrcal.discovery.residuals.scatter_uncertainties`).

    python benchmarks/coverage_scatter.py [--seeds 60]
"""
import argparse

import numpy as np

from vrcal.discovery.ranking import discover
from vrcal.drop.synthetic import scattered_impact_times
from vrcal.model.body import BallProperties


def _coverage(pulls):
    """'SD  f1 / f2': the pulls' standard deviation and the fractions within 1 and 2 (0.68 / 0.95 when
    the +- is right)."""
    a = np.abs(np.asarray(pulls))
    return f"{np.std(pulls):8.2f} {np.mean(a < 1):6.2f} /{np.mean(a < 2):5.2f}"


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=60)
    args = ap.parse_args(argv)
    ball = BallProperties(0.020, 0.040, "blue")
    print(f"{'scatter':>8s} {'n':>3s} {'pull SD':>8s} {'within 1/2 +-':>14s}   {'pull SD':>8s} "
          f"{'within 1/2 +-':>14s} {'median +-':>10s} {'median +-':>10s}  effects")
    print(f"{'':12s} {'(the fit alone)':>23s}   {'(reported, with the scatter)':>23s} {'fit':>10s} "
          f"{'reported':>10s}  named")
    for scatter in (0.005, 0.015, 0.03):
        for n in (8, 12):
            fit_pulls, pulls, u_fit, u_rep, named = [], [], [], [], 0
            for seed in range(args.seeds):
                data = scattered_impact_times(1000 * n + seed, epsilon=0.88, scatter=scatter, n_impacts=n)
                d = discover(data, ball)
                if d.effects:
                    named += 1
                    continue
                u = d.final.uncertainty("epsilon")
                j = [p.key for p in d.final.layout].index("epsilon")
                uf = float(d.final.extra.get("fit_uncertainties", d.final.uncertainties)[j])
                fit_pulls.append((d.epsilon - 0.88) / uf)
                pulls.append((d.epsilon - 0.88) / u)
                u_fit.append(uf)
                u_rep.append(u)
            print(f"{scatter:8.3f} {n:3d} {_coverage(fit_pulls)}   {_coverage(pulls)} "
                  f"{np.median(u_fit):10.4f} {np.median(u_rep):10.4f}  {named}/{args.seeds}")


if __name__ == "__main__":
    main()
