"""Benchmark of ``vrcal discover``: wall time and hidden-effect detection rates.

Prints
* the wall time of :func:`vrcal.discovery.ranking.discover` on a 1,500-sample trajectory
  (target < 1 s), median of a few runs;
* the speed goal of issue 9 (part 4): the whole process ``vrcal discover FILE`` on that
  trajectory against a plain script that does the same fits, one ``scipy.optimize.least_squares``
  per candidate model (``benchmarks/plain_lsq_reference.py``), run alternately in fresh
  processes (bytecode cached for both); the median ratio must be <= 0.6;
* the detection rate over many seeds per planted effect (and pair) and data kind,
  with the synthetic generator :func:`vrcal.drop.synthetic.hidden_effect_case`: a case
  counts as correct when the named effects are exactly the planted ones (in any
  order); also the false-positive rate on clean data and the largest relative error
  of the recovered parameters.

With ``--misses`` it also says, for every single-effect case named wrongly, how well the
named rival fits compared with the planted effect (chi-square at the data's noise sigma,
round 1) and whether the rival's parameter is physically plausible (inside the 95 %
highest-density region of its prior density, :mod:`vrcal.drop.effects`): a miss where the rival
fits as well with a plausible value is one the data cannot decide. For impact times and apex
heights it also prints the information limit of each single-effect case
(:func:`information_limit`): how close the nearest rival comes to the planted model's noise-free
data, and how many seeds a likelihood-ratio test between the two could name at this noise.

The drop-table cases (``drops``) plant drag, a speed-dependent epsilon or nothing in a synthetic
table of drop and rebound heights (5 heights x 3 trials, :func:`vrcal.drop.synthetic.drop_table_case`).

Usage:
    python benchmarks/bench_discover.py                 # 100 seeds per case
    python benchmarks/bench_discover.py --speed-only    # only the timing lines
    python benchmarks/bench_discover.py --seeds 20 --kinds trajectory
    python benchmarks/bench_discover.py --kinds impacts apexes --misses
    python benchmarks/bench_discover.py --kinds apexes --cases velocity_dependent_restitution --misses --no-speed
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import time
from collections import Counter

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(__file__), ".."))

from vrcal.discovery import residuals as res  # noqa: E402
from vrcal.discovery.ranking import discover  # noqa: E402
from vrcal.drop.effects import EFFECTS  # noqa: E402
from vrcal.drop.simulate import sample_measurement, simulate_drops  # noqa: E402
from vrcal.drop.synthetic import drop_table_case, hidden_effect_case, noise_free_measurement  # noqa: E402
from vrcal.model.body import BallProperties  # noqa: E402
from vrcal.model.standards import get_ball  # noqa: E402

#: Planted cases per data kind: single effects the kind can show, pairs, and the clean case.
CASES = {
    "trajectory": [(), ("air_drag",), ("velocity_dependent_restitution",), ("contact_duration",),
                   ("height_offset",), ("buoyancy",), ("air_drag", "height_offset"),
                   ("air_drag", "contact_duration"), ("velocity_dependent_restitution", "height_offset")],
    "impacts": [(), ("air_drag",), ("velocity_dependent_restitution",), ("contact_duration",)],
    "apexes": [(), ("air_drag",), ("velocity_dependent_restitution",), ("height_offset",)],
    "drops": [(), ("air_drag",), ("velocity_dependent_restitution",)],
}

#: Balls of the drop-table cases (by seed: seed % 2).
TABLE_BALLS = ("table_tennis", "tennis")


def timing(repeats=5):
    """Median wall time [s] of discover on a 1,500-sample tennis trajectory with air drag."""
    ball = BallProperties.from_ball(get_ball("tennis"))
    fs = 300.0
    drops = simulate_drops(2.54, 0.75, 14, ball, effects={"air_drag": {"drag_coefficient": 0.5}}, release_time_s=0.3)
    cols = sample_measurement(drops, "trajectory", fs_hz=fs, noise_m=0.002, rng=1)
    from vrcal.measurements import Trajectory

    t, y = cols["t"][:1500], cols["y"][:1500]
    data = Trajectory(t_s=t, y_m=y, source="bench", release_index=int(np.searchsorted(t, 0.3, side="right")))
    times, result = [], None
    for _ in range(repeats):
        t0 = time.perf_counter()
        result = discover(data, ball)
        times.append(time.perf_counter() - t0)
    return t.size, float(np.median(times)), result


def speed_ratio(repeats=7):
    """(median, min, max) of t(vrcal discover FILE) / t(plain least-squares script) over alternating
    fresh processes, and the median times [s], on the 1,500-sample trajectory of :func:`timing`."""
    import json
    import statistics
    import subprocess
    import tempfile

    from vrcal.discovery import residuals as res
    from vrcal.measurements import read_measurement

    ball = BallProperties.from_ball(get_ball("tennis"))
    drops = simulate_drops(2.54, 0.75, 14, ball, effects={"air_drag": {"drag_coefficient": 0.5}}, release_time_s=0.3)
    cols = sample_measurement(drops, "trajectory", fs_hz=300.0, noise_m=0.002, rng=1)
    here = os.path.dirname(os.path.abspath(__file__))
    with tempfile.TemporaryDirectory() as tmp:
        path = os.path.join(tmp, "traj1500.csv")
        with open(path, "w") as fh:
            rows = zip(cols["t"][:1500], cols["y"][:1500])
            fh.write("t,y\n" + "".join(f"{float(a)!r},{float(b)!r}\n" for a, b in rows))
        data = read_measurement(path)
        d = discover(data, ball)
        problem = res.make_problem(data, ball)
        models = [[]] + [list(c.fit.effects) for c in d.candidates]
        spec = os.path.join(tmp, "models.json")
        with open(spec, "w") as fh:
            json.dump({"ball": {"mass_kg": ball.mass_kg, "diameter_m": ball.diameter_m}, "g_m_per_s2": 9.80665,
                       "models": models, "start": res.initial_baseline(data), "n_bounces": problem.n_bounces}, fh)
        env = dict(os.environ)
        env.pop("PYTHONDONTWRITEBYTECODE", None)   # both sides read cached bytecode, as an installed package does
        env["PYTHONPATH"] = os.path.dirname(here) + os.pathsep + env.get("PYTHONPATH", "")
        vrcal_cmd = [sys.executable, "-m", "vrcal.cli", "discover", path, "--ball", "tennis", "-q"]
        plain_cmd = [sys.executable, os.path.join(here, "plain_lsq_reference.py"), path, spec]

        def wall(cmd):
            t0 = time.perf_counter()
            subprocess.run(cmd, env=env, check=True, capture_output=True)
            return time.perf_counter() - t0

        wall(vrcal_cmd), wall(plain_cmd)   # warm-up: bytecode written, files cached
        ours, plain = [], []
        for _ in range(repeats):
            plain.append(wall(plain_cmd))
            ours.append(wall(vrcal_cmd))
    ratios = [a / b for a, b in zip(ours, plain)]
    return (statistics.median(ratios), min(ratios), max(ratios), statistics.median(ours), statistics.median(plain),
            len(models))


def plausible(param, value, ball, mass=0.95):
    """True when ``value`` lies in the highest-density region holding ``mass`` of the parameter's
    prior density (numerically, within its bounds; a union of intervals for a multimodal prior)."""
    x = np.linspace(param.bounds[0], param.bounds[1], 200001)
    d = param.prior_pdf(x, ball)
    top = np.sort(d)[::-1]
    cum = np.cumsum(top) / np.sum(top)
    level = top[min(int(np.searchsorted(cum, mass)), top.size - 1)]
    return bool(param.prior_pdf(value, ball) >= level)


def miss_diagnosis(d, planted, truth=None):
    """(rival, chi2 of the rival - chi2 of the planted effect, rival's parameter, plausible?) of a
    wrongly named single-effect case, from round 1 (chi-square at the discovery's noise sigma)."""
    first = {c.name: c for c in d.rounds[0]}
    rival = d.effects[0] if d.effects else None
    if rival is None or planted not in first or rival not in first:
        return rival, float("nan"), float("nan"), False
    sigma2 = d.noise_floor ** 2
    dchi2 = (first[rival].fit.rss - first[planted].fit.rss) / sigma2
    p = EFFECTS[rival].parameters[0]
    value = first[rival].fit.effect_values[rival][p.name]
    return rival, float(dchi2), float(value), plausible(p, value, d.ball)


def information_limit(d, data, truth, planted):
    """(nearest rival, its chi-square on the noise-free data) of a single planted effect in impact
    times or apex heights: each rival the kind can show is fitted to the planted model's noise-free
    observations (the same samples, :func:`vrcal.drop.synthetic.noise_free_measurement`) and its
    RSS divided by the discovery's noise sigma squared. That is the expected chi-square difference
    between the planted model and the rival on noisy data: the most that any rule can go on. Two
    models that far apart are told apart by a likelihood-ratio test in about Phi(sqrt(dchi2) / 2)
    of the noise draws (Phi(0.5) = 69 % at dchi2 = 1, 84 % at 4, 93 % at 9)."""
    clean = noise_free_measurement(data, truth)
    first = {c.name: c for c in d.rounds[0]} if d.rounds else {}
    best = (None, float("inf"))
    for rival in res.applicable_effects(data.kind):
        if rival == planted:
            continue
        fitted = first[rival].fit if rival in first else None
        starts = [] if fitted is None else [{p.key: float(v) for p, v in zip(fitted.layout, fitted.values)}]
        chi2 = res.separation_chi2(clean, d.ball, (rival,), d.noise_floor, d.g_m_per_s2, starts)
        if chi2 < best[1]:
            best = (rival, float(chi2))
    return best


def sweep(kind, planted, seeds, misses=None, limits=None):
    """Detection statistics of one planted case over ``seeds`` seeds (``misses``: a list that
    collects :func:`miss_diagnosis` of each wrongly named single-effect case, with its
    :func:`information_limit` for impact times and apex heights; ``limits``: a list that collects
    (seed, named exactly?, information limit) of every seed there)."""
    named = Counter()
    errors = {}
    correct = 0
    covered = 0
    elapsed = 0.0
    for seed in range(seeds):
        if kind == "drops":
            data, truth = drop_table_case(seed, planted, ball=TABLE_BALLS[seed % 2])
        else:
            data, truth = hidden_effect_case(seed, kind, planted)
        t0 = time.perf_counter()
        d = discover(data, BallProperties.from_ball(get_ball(truth["ball"])))
        elapsed += time.perf_counter() - t0
        key = ",".join(d.effects) or "-"
        named[key] += 1
        alternatives = set(d.effects) | {a for alts in d.ambiguous.values() for a in alts}
        if len(d.effects) == len(planted) and set(planted) <= alternatives:
            covered += 1
        if sorted(d.effects) == sorted(planted):
            correct += 1
            for name in planted:
                for p, true in truth["effects"][name].items():
                    got = d.final.effect_values[name][p]
                    errors.setdefault(f"{name}.{p}", []).append(abs(got / true - 1.0))
        limit = (None, float("nan"))
        if limits is not None and len(planted) == 1 and kind in ("impacts", "apexes"):
            limit = information_limit(d, data, truth, planted[0])
            limits.append((seed, sorted(d.effects) == sorted(planted), limit))
        if sorted(d.effects) != sorted(planted) and misses is not None and len(planted) == 1:
            misses.append((seed, truth["ball"], *miss_diagnosis(d, planted[0], truth), limit))
    return correct, covered, named, errors, elapsed / max(seeds, 1)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=100, help="seeds per case (default 100)")
    ap.add_argument("--kinds", nargs="*", default=list(CASES), help="data kinds to sweep (drops: drop tables)")
    ap.add_argument("--misses", action="store_true",
                    help="diagnose every wrongly named single-effect case (rival's fit and plausibility)")
    ap.add_argument("--speed-only", action="store_true", help="print the timing lines only")
    ap.add_argument("--no-speed", action="store_true", help="skip the timing lines (rates only)")
    ap.add_argument("--cases", nargs="*", default=None, metavar="EFFECT",
                    help="only the planted cases whose effects are all among these (clean: the clean case)")
    args = ap.parse_args(argv)
    diagnoses = []
    if not args.no_speed:
        n, wall, result = timing()
        print(f"discover on a {n}-sample trajectory: {wall * 1000:.0f} ms (median of 5; target < 1000 ms); "
              f"named {result.effects}")
        med, lo, hi, ours, plain, n_fits = speed_ratio()
        print(f"whole process 'vrcal discover' / plain least-squares script ({n_fits} fits each): median ratio "
              f"{med:.2f} (range {lo:.2f}-{hi:.2f}; target <= 0.6); median wall {ours:.2f} s vs {plain:.2f} s",
              flush=True)
    if args.speed_only:
        return
    print("rate = the named effects are exactly the planted ones; +amb = or the planted one is named as an "
          "ambiguous alternative (CONFUSABLE groups of vrcal.discovery.ranking)")
    print(f"{'kind':<11s} {'planted':<50s} {'rate':>7s} {'+amb':>7s}  {'max rel err':>11s} {'ms/run':>7s}  named")
    totals = {}  # kind -> [exact, covered, runs]
    for kind in args.kinds:
        for planted in CASES[kind]:
            if args.cases is not None and not set(planted or ("clean",)) <= set(args.cases):
                continue
            assert all((kind if kind != "drops" else "apexes") in EFFECTS[p].kinds for p in planted)
            misses = [] if args.misses else None
            limits = [] if args.misses else None
            correct, covered, named, errors, per = sweep(kind, planted, args.seeds, misses, limits)
            if misses or limits:
                diagnoses.append((kind, planted[0], misses, limits))
            t = totals.setdefault(kind, [0, 0, 0])
            t[0], t[1], t[2] = t[0] + correct, t[1] + covered, t[2] + args.seeds
            err = ", ".join(f"{k.split('.')[-1]} {100 * max(v):.1f}%" for k, v in sorted(errors.items())) or "-"
            label = " + ".join(planted) or "(clean)"
            print(f"{kind:<11s} {label:<50s} {100.0 * correct / args.seeds:>6.1f}% "
                  f"{100.0 * covered / args.seeds:>6.1f}%  "
                  f"{err:>11s} {per * 1000:>7.0f}  "
                  f"{dict(named.most_common())}", flush=True)
    all_runs = [0, 0, 0]
    for kind, (exact, covered, runs) in totals.items():
        print(f"all {kind:<16s}: {exact}/{runs} exact ({100.0 * exact / runs:.1f}%), "
              f"{covered}/{runs} incl. ambiguous ({100.0 * covered / runs:.1f}%)")
        all_runs = [a + b for a, b in zip(all_runs, (exact, covered, runs))]
    if len(totals) > 1:
        exact, covered, runs = all_runs
        print(f"all kinds           : {exact}/{runs} exact ({100.0 * exact / runs:.1f}%), "
              f"{covered}/{runs} incl. ambiguous ({100.0 * covered / runs:.1f}%)")
    for kind, planted, misses, limits in diagnoses:
        if limits:
            nf = np.array([lim[2][1] for lim in limits])
            ideal = float(np.sum(0.5 * (1.0 + np.vectorize(math.erf)(np.sqrt(nf) / 2.0 / math.sqrt(2.0)))))
            exact = sum(ok for _, ok, _ in limits)
            hard = nf < 4
            print(f"information limit {kind}/{planted}: noise-free, the nearest rival fits within dchi2 < 1 in "
                  f"{int(np.sum(nf < 1))} of {nf.size} seeds, < 4 in {int(np.sum(hard))}; a likelihood-ratio "
                  f"test against it would name the planted effect in about {ideal:.0f} of {nf.size}; named "
                  f"exactly: {exact} (in {sum(ok for (_, ok, _), h in zip(limits, hard) if h)} of the "
                  f"{int(np.sum(hard))} with dchi2 < 4, {sum(ok for (_, ok, _), h in zip(limits, hard) if not h)} "
                  f"of the {int(np.sum(~hard))} others)")
        if not misses:
            continue
        dchi2 = np.array([m[3] for m in misses])
        n_plausible = sum(bool(m[5]) for m in misses)
        print(f"misses {kind}/{planted}: {len(misses)}; the named rival fits better (dchi2 < 0) in "
              f"{int(np.sum(dchi2 < 0))}, within |dchi2| < 4 in {int(np.sum(np.abs(dchi2) < 4))}; its parameter is "
              f"inside the 95 % highest-density region of its prior in {n_plausible}")
        for seed, ball, rival, d, value, ok, (nearest, nf) in misses:
            limit = "" if nearest is None else f"; noise-free dchi2 to {nearest} {nf:.2f}"
            print(f"    seed {seed:3d} {ball:<13s} named {rival}: dchi2 {d:+7.2f}, parameter {value:.4g}"
                  f"{'' if ok else ' (implausible)'}{limit}")


if __name__ == "__main__":
    main()
