"""Benchmark of ``vrcal track``: impact times from sounds and ball centres from videos (issue 12).

Prints:
1. synthetic sounds (vrcal.drop.render: noise, hum, echoes, stereo, clipping, a clap and a voice
   between bounces), several drops each: the share of audible impacts found within 0.25 ms, the
   largest error, the spurious events kept -- for vrcal's detector and for a plain
   high-pass-and-threshold detector (first sample over 6 noise sigmas after a 1 kHz high-pass,
   20 ms dead time);
2. synthetic videos (noise, motion blur, a cluttered background, a 24 -> 30 fps conversion),
   each drop rendered clean and with air drag planted: the largest centre error [px], the
   error of epsilon from ``discover``, and how often an effect is named (clean: none should
   be; drag planted: air_drag should be, and nothing else);
3. the real video ../shared/data/realval/ameen/bounceAmeen.avi (26 g, 68.7 mm ball, 29.97 fps)
   with only its physical parameters: the scale (from g or the diameter), per-bounce epsilon,
   discover's epsilon and the effects it names;
4. the time to process a 1-minute 48 kHz recording and a 10-second 1080p video.

Run: python benchmarks/bench_track.py   (needs the video extra; about five minutes)
     python benchmarks/bench_track.py --sound-only   (section 1 alone, about half a minute)
"""

from __future__ import annotations

import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from vrcal.drop.render import SoundScene, VideoScene, impact_sound, render_video, write_wav
from vrcal.drop.simulate import simulate_drops
from vrcal.measurements.sound import highpassed, track_sound
from vrcal.model.body import BallProperties

ROOT = Path(__file__).resolve().parents[1]
BALL = BallProperties(0.0577, 0.067, "tennis")
AUDIBLE = 10.0     # an impact is audible when its peak is this many times the noise RMS
MATCH_S = 2.5e-4   # the goal: every audible impact within 0.25 ms
SPURIOUS_S = 2e-3  # a detection further than this from every true impact is spurious


def plain_detector(x, fs, k=6.0, dead_s=0.02):
    """High-pass (1 kHz) and threshold: the first sample over k noise sigmas, then a dead time."""
    y = np.abs(highpassed(np.asarray(x, float).reshape(len(x), -1), fs)).max(axis=1)
    sigma = 1.4826 * np.median(y)
    over = np.flatnonzero(y > k * sigma)
    out, last = [], -np.inf
    for i in over:
        if i / fs - last > dead_s:
            out.append(i / fs)
            last = i / fs
    return np.array(out)


def score(found, truth, audible):
    """(audible found within MATCH_S, audible, largest error over the audible found [ms], spurious)."""
    if found.size == 0:
        return 0, int(audible.sum()), float("nan"), 0
    err = np.array([np.min(np.abs(found - t)) for t in truth])
    ok = (err < MATCH_S) & audible
    spurious = int(sum(np.min(np.abs(truth - f)) > SPURIOUS_S for f in found))
    matched = audible & (err < SPURIOUS_S)
    return int(ok.sum()), int(audible.sum()), float(np.max(err[matched]) * 1e3) if matched.any() else float(
        "nan"), spurious


SOUND_SCENES = {
    "noise": lambda t: SoundScene(noise_rms=0.005),
    "hum": lambda t: SoundScene(noise_rms=0.002, hum_amplitude=0.3),
    "echoes": lambda t: SoundScene(noise_rms=0.002, echoes=((0.004, 0.5), (0.009, 0.3))),
    "stereo": lambda t: SoundScene(noise_rms=0.003, channels=2),
    "clipping": lambda t: SoundScene(noise_rms=0.002, level=3.0),
    "clap+voice": lambda t: SoundScene(noise_rms=0.002, clap_times_s=(0.5 * (t[1] + t[2]),),
                                       voice_times_s=(t[0] + 0.15,)),
    "all": lambda t: SoundScene(noise_rms=0.003, hum_amplitude=0.2, echoes=((0.005, 0.4),), channels=2, level=2.0,
                                clap_times_s=(0.5 * (t[2] + t[3]),)),
}


def bench_sounds(tmp):
    print("1. synthetic sounds: audible impacts found within 0.25 ms / audible, largest error, spurious events")
    print(f"   {'scene':12s} {'vrcal':>28s}   {'high-pass + threshold':>28s}")
    totals = {"vrcal": [0, 0, 0.0, 0], "plain": [0, 0, 0.0, 0]}
    quiet = [0, 0.0]  # impacts under AUDIBLE that vrcal keeps anyway, their largest error [ms]
    for name, make in SOUND_SCENES.items():
        rows = {"vrcal": [0, 0, 0.0, 0], "plain": [0, 0, 0.0, 0]}
        for seed, (H, eps) in enumerate([(0.5, 0.6), (0.8, 0.75), (1.2, 0.85), (1.0, 0.9)]):
            d = simulate_drops(H, eps, 20, BALL, release_time_s=0.3)
            t, v = d.impact_times_s[0], d.impact_speeds_m_per_s[0]
            scene = make(t)
            x = impact_sound(t, v, fs_hz=48000, scene=scene, seed=seed)
            path = tmp / f"{name}-{seed}.wav"
            write_wav(path, x, 48000)
            audible = scene.level * v / v[0] > AUDIBLE * max(scene.noise_rms, 1e-6)
            ours = track_sound(path).impacts.t_s
            err = np.array([np.min(np.abs(ours - ti)) for ti in t[~audible]])
            quiet[0] += int(np.sum(err < SPURIOUS_S))
            quiet[1] = max([quiet[1], *(err[err < SPURIOUS_S] * 1e3)])
            for key, found in (("vrcal", ours), ("plain", plain_detector(x, 48000))):
                ok, n, worst, spur = score(found, t, audible)
                r = rows[key]
                r[0] += ok
                r[1] += n
                r[2] = max(r[2], worst) if np.isfinite(worst) else r[2]
                r[3] += spur
        for key in rows:
            for i in (0, 1, 3):
                totals[key][i] += rows[key][i]
            totals[key][2] = max(totals[key][2], rows[key][2])
        print(f"   {name:12s} " + "   ".join(f"{r[0]:3d}/{r[1]:3d} max {r[2]:5.3f} ms, {r[3]:2d} spurious"
                                             for r in rows.values()))
    print(f"   {'total':12s} " + "   ".join(f"{r[0]:3d}/{r[1]:3d} max {r[2]:5.3f} ms, {r[3]:2d} spurious"
                                         for r in totals.values()))
    print(f"   vrcal also keeps {quiet[0]} impacts under {AUDIBLE:g} x the noise, all "
          f"within {quiet[1]:.3f} ms of the truth")


VIDEO_SCENES = {
    "plain": {},
    "noise": {"noise_sd": 5.0},
    "motion blur": {"blur": True, "noise_sd": 2.0},
    "clutter": {"clutter": True, "noise_sd": 2.0},
    "24->30 fps": {"repeat_every": 5, "noise_sd": 2.0},
    "all": {"blur": True, "clutter": True, "noise_sd": 3.0, "repeat_every": 5},
}


def _names(effects):
    return "+".join(sorted(effects)) or "-"


def bench_videos(tmp):
    from vrcal.discovery.ranking import discover
    from vrcal.discovery.residuals import noise_floor
    from vrcal.measurements.types import Trajectory
    from vrcal.measurements.video import track_video

    print("2. synthetic videos (640x480, ball 27 px), two drops a scene (0.9 m, eps 0.6; 1.1 m, eps 0.8), each "
          "rendered clean and with air drag planted (C_d 0.5):")
    print("   the largest centre error, the epsilon error (clean), the effects discover names per drop -- as it is "
          "('as is': the")
    print("   trajectory carries the tracker's errors, the centres' systematic error and the floor's uncertainty), "
          "with that noise")
    print("   given as --noise ('+sys'), and, for the drag, on the true heights at the same frames with the same "
          "white noise")
    print("   ('truth': what discover can find at all)")
    count = {"clean": 0, "clean+sys": 0, "drag": 0, "drag+sys": 0, "drag truth": 0, "other": 0, "other+sys": 0}
    runs = 0
    for name, scene in VIDEO_SCENES.items():
        worst_px, worst_eps, row = 0.0, 0.0, {"clean": [], "drag": []}
        for seed, (H, eps) in enumerate(((0.9, 0.6), (1.1, 0.8))):
            runs += 1
            for kind, effects in (("clean", None), ("drag", {"air_drag": {"drag_coefficient": 0.5}})):
                d = simulate_drops(H, eps, 6, BALL, release_time_s=0.25, effects=effects)
                path = tmp / f"v{seed}.avi"
                sc = VideoScene(m_per_px=0.0025, **scene)
                truth = render_video(path, d, BALL.diameter_m, scene=sc, seed=seed)
                vt = track_video(path, diameter_m=BALL.diameter_m)
                data = vt.trajectory
                floor = noise_floor(data) or 0.0
                as_is = discover(data, BALL).effects
                with_sys = discover(data, BALL, noise=float(np.hypot(floor, vt.systematic_m))).effects
                if kind == "clean":
                    k = vt.kept & ~truth["straddles_impact"]
                    err = np.hypot(vt.row_px[k] - truth["row_px"][k], vt.col_px[k] - truth["col_px"][k])
                    worst_px = max(worst_px, float(np.max(err)))
                    worst_eps = max(worst_eps, abs(discover(data, BALL).epsilon - eps))
                    count["clean"] += bool(as_is)
                    count["clean+sys"] += bool(with_sys)
                    row["clean"].append(f"{_names(as_is)}/{_names(with_sys)}")
                else:
                    k = np.flatnonzero(vt.kept)
                    y = (sc.floor_row - truth["diameter_px"] / 2 - truth["row_px"][k]) * sc.m_per_px
                    y = y + np.random.default_rng(seed).normal(0.0, floor, y.size)
                    found = discover(Trajectory(t_s=vt.t_s[k], y_m=y, source="truth",
                                                release_index=data.release_index), BALL).effects
                    count["drag"] += "air_drag" in as_is
                    count["drag+sys"] += "air_drag" in with_sys
                    count["drag truth"] += "air_drag" in found
                    count["other"] += bool(set(as_is) - {"air_drag"})
                    count["other+sys"] += bool(set(with_sys) - {"air_drag"})
                    row["drag"].append(f"{_names(as_is)}/{_names(with_sys)}/{_names(found)}")
        print(f"   {name:12s} centre within {worst_px:.3f} px, epsilon within {worst_eps:.4f}; named (as is/+sys): "
              f"clean {', '.join(row['clean'])}; drag (as is/+sys/truth) {', '.join(row['drag'])}")
    print(f"   clean videos with an effect named: {count['clean']}/{runs} as is, {count['clean+sys']}/{runs} +sys")
    print(f"   drag planted: air_drag named in {count['drag']}/{runs} as is, {count['drag+sys']}/{runs} +sys, "
          f"{count['drag truth']}/{runs} on the truth; another effect named in {count['other']}/{runs} as is, "
          f"{count['other+sys']}/{runs} +sys")


def bench_real_video():
    from vrcal.discovery.ranking import discover
    from vrcal.measurements.video import track_video

    path = ROOT.parent / "shared" / "data" / "realval" / "ameen" / "bounceAmeen.avi"
    print("3. real video bounceAmeen.avi (26 g, 68.7 mm ball; only these physical parameters)")
    if not path.exists():
        print("   ../shared/data is absent: skipped")
        return
    start = time.perf_counter()
    vt = track_video(path, diameter_m=0.0687)
    took = time.perf_counter() - start
    fit = vt.bounces
    durations = np.array([t1 - t0 for _, t0, t1 in fit.flights])
    print(f"   tracked in {took:.1f} s: {vt.kept.sum()} frames kept, ball {vt.diameter_px:.1f} px wide; the flights "
          f"between bounces curve by {fit.g_px_per_s2:.0f} px/s^2: scale {vt.scale_m_per_px * 1e3:.4f} mm/px "
          f"(the diameter alone: {0.0687 / vt.diameter_px * 1e3:.4f} mm/px, g = {vt.g_measured:.2f} m/s^2)")
    ratios = durations[1:] / durations[:-1]
    print(f"   per-bounce epsilon from the flight times: {', '.join(f'{r:.3f}' for r in ratios)}")
    for note in vt.notes:
        if note.startswith("the fall from the hand"):
            print(f"   {note[:note.index(' -- ')]}")
    result = discover(vt.trajectory, BallProperties(0.026, 0.0687, "green"))
    print(f"   discover: baseline epsilon {result.epsilon_baseline:.4f}, engine epsilon {result.epsilon:.4f}, "
          f"named: {', '.join(result.effects) or 'none'}")


def bench_speed(tmp):
    from vrcal.measurements.video import track_video

    print("4. speed (wall and CPU time on this machine)")
    rng = np.random.default_rng(0)
    times = np.sort(rng.uniform(1, 59, 6))
    t_all = []
    for t0 in times:  # six drops in one minute
        d = simulate_drops(0.8, 0.8, 12, BALL, release_time_s=t0)
        t_all.append((d.impact_times_s[0], d.impact_speeds_m_per_s[0]))
    x = impact_sound(t_all[0][0], t_all[0][1], duration_s=60.0, scene=SoundScene(noise_rms=0.002, channels=2),
                     seed=0)
    path = tmp / "minute.wav"
    write_wav(path, x, 48000)
    w, c = time.perf_counter(), time.process_time()
    track_sound(path)
    print(f"   1-minute 48 kHz stereo WAV: {time.perf_counter() - w:.2f} s wall, {time.process_time() - c:.2f} s CPU")
    # a drop with people talking through it: every pitch pulse of a voice is a sound event, and the bounce
    # sequence is sought among all of them (13 s for a voice's 200 events before it was written with bisect)
    d = simulate_drops(0.8, 0.8, 12, BALL, release_time_s=1.0)
    x = impact_sound(d.impact_times_s[0], d.impact_speeds_m_per_s[0], duration_s=6.0,
                     scene=SoundScene(noise_rms=0.002, voice_times_s=tuple(np.arange(0.2, 5.5, 0.45))), seed=0)
    path = tmp / "talking.wav"
    write_wav(path, x, 48000)
    w, c = time.perf_counter(), time.process_time()
    st = track_sound(path)
    wall, cpu = time.perf_counter() - w, time.process_time() - c
    voiced = next((n.split(" are pitch")[0] for n in st.impacts.notes if "pitch pulses" in n), "none")
    print(f"   6-second WAV with a voice throughout ({voiced} a voice's; {st.impacts.t_s.size} "
          f"impacts kept): {wall:.2f} s wall, {cpu:.2f} s CPU")
    d = simulate_drops(1.0, 0.8, 12, BALL, release_time_s=0.5)
    path = tmp / "hd.mp4"
    scene = VideoScene(width=1920, height=1080, floor_row=1000.0, x_px=960.0, m_per_px=0.0011, noise_sd=2.0,
                       blur=True)
    render_video(path, d, BALL.diameter_m, scene=scene, duration_s=10.0, fourcc="mp4v")
    w, c = time.perf_counter(), time.process_time()
    vt = track_video(path, diameter_m=BALL.diameter_m)
    print(f"   10-second 1080p video ({vt.t_s.size} frames, mp4v): {time.perf_counter() - w:.2f} s wall, "
          f"{time.process_time() - c:.2f} s CPU")


def main(argv=None):
    argv = sys.argv[1:] if argv is None else argv
    with tempfile.TemporaryDirectory() as d:
        tmp = Path(d)
        bench_sounds(tmp)
        if "--sound-only" in argv:
            return 0
        try:
            import cv2  # noqa: F401
        except ImportError:
            print("OpenCV is not installed (pip install 'vrcal[video]'): the video benchmarks are skipped")
            return 0
        bench_videos(tmp)
        bench_real_video()
        bench_speed(tmp)
    return 0


if __name__ == "__main__":
    sys.exit(main())
