"""The reference of the speed goal of ``vrcal discover`` (issue 9, part 4): a plain script that does
the same fits, one ``scipy.optimize.least_squares`` per candidate model with its default
finite-difference Jacobian (one simulation per parameter), reading the file with numpy.

Usage (benchmarks/bench_discover.py runs it as a separate process and times it):
    python benchmarks/plain_lsq_reference.py DATA.csv MODELS.json

MODELS.json: ``{"ball": {"mass_kg", "diameter_m"}, "g_m_per_s2": G, "models": [[effect, ...], ...],
"start": {...}}`` -- the models that ``vrcal discover`` fitted (baseline first), written by the
benchmark from a discover run on the same file. Prints the number of fits and their total RSS.
"""

import json
import sys

import numpy as np
from scipy.optimize import least_squares

from vrcal.drop.effects import EFFECTS
from vrcal.drop.simulate import simulate_drops
from vrcal.model.body import BallProperties

#: effect -> (its parameter, default, lower bound, upper bound), from the registry (one parameter each)
DEFAULTS = {name: (p.name, p.default, *p.bounds) for name, e in EFFECTS.items() for p in e.parameters}


def main(path, models_path):
    spec = json.load(open(models_path))
    t, y = np.loadtxt(path, delimiter=",", skiprows=1, unpack=True)
    ball = BallProperties(spec["ball"]["mass_kg"], spec["ball"]["diameter_m"])
    g = spec["g_m_per_s2"]
    H0, t00, eps0 = spec["start"]["drop_height_m"], spec["start"]["release_time_s"], spec["start"]["epsilon"]
    n_bounces = spec["n_bounces"]
    total = 0.0
    for effects in spec["models"]:
        def residual(p):
            params = {e: {DEFAULTS[e][0]: v} for e, v in zip(effects, p[3:])}
            d = simulate_drops(p[0], p[2], n_bounces, ball, effects=params or None, g_m_per_s2=g,
                               release_time_s=p[1])
            return y - d.height_m(t)[0]

        x0 = [H0, t00, eps0] + [DEFAULTS[e][1] for e in effects]
        lo = [1e-3, t[0] - 10.0, 0.05] + [DEFAULTS[e][2] for e in effects]
        hi = [100.0, t[-1], 0.999] + [DEFAULTS[e][3] for e in effects]
        sol = least_squares(residual, x0, bounds=(lo, hi))
        total += float(sol.fun @ sol.fun)
    print(f"{len(spec['models'])} fits, total RSS {total:.6g}")


if __name__ == "__main__":
    main(*sys.argv[1:3])
