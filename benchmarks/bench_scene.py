"""Wall time of the example scenes in vrcal's event-driven simulator and in ODE, and how far apart they are.

Run: python benchmarks/bench_scene.py [--dt 1e-3 1e-4 2e-5]

For every scene in examples/ prints the wall time of `vrcal.scenes.multibody.simulate_scene`, of
`vrcal.scenes.ode.simulate_scene_ode` at each time step, and the comparison (largest impact-time
and apex-height differences). ODE missing is reported and skipped. Prints numbers; asserts nothing.
"""

import argparse
import math
import time
from pathlib import Path

from vrcal.errors import EngineUnavailable
from vrcal.scenes.compare import compare_results
from vrcal.scenes.multibody import simulate_scene
from vrcal.scenes.spec import load_scene

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--dt", type=float, nargs="+", default=[1e-3, 1e-4], help="ODE time steps [s]")
    args = parser.parse_args()
    print(f"{'scene':<22} {'engine':<12} {'wall [s]':>9} {'impacts':>8} {'max |dt| [s]':>13} {'max |dh| [m]':>13}")
    for path in sorted(EXAMPLES.glob("*.yaml")):
        scene = load_scene(path)
        t0 = time.perf_counter()
        exact = simulate_scene(scene)
        wall = time.perf_counter() - t0
        print(f"{scene.name:<22} {'vrcal':<12} {wall:9.3f} {len(exact.contacts):8d}")
        for dt in args.dt:
            try:
                from vrcal.scenes.ode import simulate_scene_ode

                t0 = time.perf_counter()
                res = simulate_scene_ode(scene, dt_s=dt)
                wall = time.perf_counter() - t0
            except EngineUnavailable as exc:
                print(f"{scene.name:<22} ode: {exc}")
                break
            cmp = compare_results(exact, res)
            dh = cmp.max_apex_difference_m
            dh_text = f"{'no match':>13}" if math.isnan(dh) else f"{dh:13.3g}"
            print(f"{scene.name:<22} {'ode ' + format(dt, 'g'):<12} {wall:9.3f} {len(res.contacts):8d} "
                  f"{cmp.max_impact_time_difference_s:13.3g} {dh_text}"
                  + (f"  ({cmp.solver_messages} ODE solver messages)" if cmp.solver_messages else ""))


if __name__ == "__main__":
    main()
