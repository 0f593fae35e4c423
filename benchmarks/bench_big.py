"""Big honest records through the installed ``vrcal discover``: wall time for 10^4, 10^5 and 10^6 samples.

Run: python benchmarks/bench_big.py [--sizes 1e4 1e5 1e6] [--effect air_drag] [--keep DIR]

Each record is one drop of a tennis ball from 1 m with epsilon 0.85 and 30 bounces, 1 mm noise,
sampled so that it holds exactly N samples (10^6 samples: 174.5 kHz); it is written as CSV (t, y) and
fitted by a fresh ``vrcal discover FILE --ball tennis -q --json`` process. The table gives the file
size, the wall time of the whole process (reading, noise, decimation, bounces, every fit), the
decimation factor and the samples fitted (:data:`vrcal.discovery.prepare.MAX_FIT_SAMPLES`), epsilon,
the named effects and the verdict. The issue's goal (issue 10): a 10^6-sample record in seconds with
the right answer. Prints numbers; asserts nothing.
"""

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from vrcal.drop.simulate import sample_measurement, simulate_drop


def write_record(path, n, effects=(), seed=0):
    """A tennis-ball drop of exactly ``n`` samples (t, y CSV); returns the sampling rate [Hz]."""
    drops, _ = simulate_drop("tennis", drop_height_m=1.0, n_bounces=30, epsilon=0.85, effects=list(effects))
    fs = (n - 1) / float(drops.landing_times_s[0])
    cols = sample_measurement(drops, "trajectory", fs_hz=fs, noise_m=1e-3, rng=seed)
    with open(path, "w") as fh:
        fh.write("t [s],y [m]\n")
        np.savetxt(fh, np.column_stack([cols["t"], cols["y"]]), fmt="%.10g", delimiter=",")
    return fs


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", nargs="*", type=float, default=[1e4, 1e5, 1e6], help="samples per record")
    parser.add_argument("--effect", action="append", default=[], help="plant an effect (vrcal simulate --effect)")
    parser.add_argument("--keep", default=None, help="write the records into this directory and keep them")
    args = parser.parse_args()
    vrcal = Path(sys.executable).with_name("vrcal")
    exe = [str(vrcal)] if vrcal.exists() else [sys.executable, "-m", "vrcal"]
    folder = args.keep or tempfile.mkdtemp(prefix="vrcal-big-")
    os.makedirs(folder, exist_ok=True)
    planted = "".join(f", {e}" for e in args.effect)
    print(f"vrcal discover on a tennis drop (eps 0.85, 30 bounces, 1 mm noise{planted})")
    print(f"{'samples':>10} {'rate Hz':>9} {'MB':>6} {'wall s':>7} {'every':>6} {'fitted':>7} {'epsilon':>10} "
          f"{'verdict':<12} effects")
    for size in args.sizes:
        n = int(size)
        path = os.path.join(folder, f"drop-{n}.csv")
        fs = write_record(path, n, args.effect)
        out = os.path.join(folder, f"drop-{n}.json")
        t0 = time.perf_counter()
        run = subprocess.run(exe + ["discover", path, "--ball", "tennis", "-q", "--json", out],
                             capture_output=True, text=True)
        wall = time.perf_counter() - t0
        mb = os.path.getsize(path) / 1e6
        if run.returncode != 0:
            print(f"{n:>10,} {fs:>9.0f} {mb:>6.1f} {wall:>7.2f}  exit {run.returncode}: {run.stderr.strip()[-200:]}")
            continue
        d = json.loads(Path(out).read_text())
        print(f"{n:>10,} {fs:>9.0f} {mb:>6.1f} {wall:>7.2f} {d['data'].get('decimation', 1):>6} "
              f"{d['data']['n']:>7,} {d['epsilon']:>10.6f} {d['verdict']:<12} {', '.join(d['effects']) or '-'}")
    if not args.keep:
        for name in os.listdir(folder):
            os.remove(os.path.join(folder, name))
        os.rmdir(folder)


if __name__ == "__main__":
    main()
