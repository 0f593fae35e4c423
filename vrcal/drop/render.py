"""Synthetic recordings of a simulated drop, with known truth: the sound of the impacts and a video.

This module owns turning a simulated drop (:func:`vrcal.drop.simulate.simulate_drops`) into
what a phone records -- a sound file (:func:`impact_sound`, :func:`write_wav`) and a video
(:func:`render_video`, OpenCV) -- with the nuisances of real rooms and cameras switchable one
by one, so that :mod:`vrcal.measurements.sound` and :mod:`vrcal.measurements.video` can be
tested and benchmarked against the exact impact times and ball centres.

Sound model
-----------
Each impact starts at its exact time (between samples) with a 20 µs raised-cosine attack,
then rings: a broadband click (white noise decaying in 0.4 ms) plus three damped modes
(2.1, 3.7, 5.3 kHz, decaying in 3-6 ms), amplitude proportional to the impact speed. Room
echoes are delayed, attenuated copies; mains hum is a 50 Hz tone with harmonics; a clap is a
broadband burst decaying in 3 ms; a voice is a 140 Hz harmonic series with a 4 Hz syllable
envelope. Clipping saturates at full scale.

Video model
-----------
A disc of the ball's colour with a soft (anti-aliased) edge and a little shading is drawn at
the simulated centre of every frame, over a background (plain, or cluttered with static
shapes, one of them the ball's colour). Motion blur averages sub-frame positions over the
exposure; noise is Gaussian per pixel; a frame-rate conversion repeats frames (e.g. 24 -> 30
fps repeats every fourth source frame).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from vrcal.errors import UsageError

# --------------------------------------------------------------------------- sound


@dataclass(frozen=True)
class SoundScene:
    """Nuisances of a synthetic recording (all off by default)."""

    noise_rms: float = 0.0           # white noise, full scale = 1
    hum_amplitude: float = 0.0       # mains hum (50 Hz + harmonics)
    echoes: tuple = ()               # ((delay_s, gain), ...) room reflections
    clap_times_s: tuple = ()         # claps (broadband bursts)
    voice_times_s: tuple = ()        # start of 0.4 s of speech
    clip: float = 1.0                # saturation level (1 = the file's full scale)
    channels: int = 1                # 1 or 2 (the second is delayed by 0.1 ms and 0.8 x louder)
    level: float = 0.5               # amplitude of the first impact before clipping


def _burst(tau, fs_hz, t0_s, length_s, rng, modes):
    """One impact waveform starting exactly at ``t0_s`` (samples from floor(t0 fs))."""
    start = int(math.floor(t0_s * fs_hz))
    n = int(length_s * fs_hz)
    t = (start + np.arange(n)) / fs_hz - t0_s
    attack = np.clip(t / 2e-5, 0.0, 1.0)
    attack = 0.5 - 0.5 * np.cos(np.pi * attack)
    attack[t < 0] = 0.0
    tp = np.maximum(t, 0.0)
    click = rng.standard_normal(n) * np.exp(-tp / tau)
    ring = sum(a * np.exp(-tp / d) * np.sin(2 * np.pi * f * tp) for f, d, a in modes)
    return start, attack * (click + ring)


def impact_sound(impact_times_s, impact_speeds_m_per_s, *, fs_hz=48000, duration_s=None, scene=SoundScene(),
                 seed=0):
    """Samples of the sound of a drop's impacts (see the module docstring).

    Parameters
    ----------
    impact_times_s : ndarray
        impact times [s]
    impact_speeds_m_per_s : ndarray
        impact speeds [m/s] (loudness is proportional to them)
    fs_hz : int
        sample rate [Hz]
    duration_s : float or None
        length of the recording [s]; default 0.5 s after the last impact
    scene : SoundScene
        the nuisances
    seed : int
        noise seed

    Returns
    -------
    ndarray (n, channels)
        samples, full scale = 1 (clipped at ``scene.clip``)
    """
    rng = np.random.default_rng(seed)
    t_imp = np.asarray(impact_times_s, dtype=float)
    v = np.asarray(impact_speeds_m_per_s, dtype=float)
    if duration_s is None:
        duration_s = float(t_imp[-1]) + 0.5
    n = int(round(duration_s * fs_hz))
    x = np.zeros(n)
    modes = ((2100.0, 6e-3, 0.6), (3700.0, 4e-3, 0.5), (5300.0, 3e-3, 0.4))

    def add(t0, amp, tau=4e-4, length=0.03, mode_set=modes):
        if t0 >= duration_s:
            return
        start, w = _burst(tau, fs_hz, t0, length, rng, mode_set)
        w = amp * w / max(np.max(np.abs(w)), 1e-12)
        lo, hi = max(start, 0), min(start + w.size, n)
        if hi > lo:
            x[lo:hi] += w[lo - start:hi - start]

    for ti, vi in zip(t_imp, v):
        amp = scene.level * vi / v[0]
        add(ti, amp)
        for delay, gain in scene.echoes:
            add(ti + delay, amp * gain)
    for tc in scene.clap_times_s:
        add(tc, scene.level * 0.6, tau=3e-3, length=0.04, mode_set=())
    t = np.arange(n) / fs_hz
    for tv in scene.voice_times_s:
        inside = (t >= tv) & (t < tv + 0.4)
        tau_v = t[inside] - tv
        env = np.sin(np.pi * tau_v / 0.4) * (0.6 + 0.4 * np.sin(2 * np.pi * 4 * tau_v))
        voice = sum(np.sin(2 * np.pi * 140 * k * tau_v) / k for k in range(1, 25))
        x[inside] += scene.level * 0.3 * env * voice / 3.0
    if scene.hum_amplitude:
        x += scene.hum_amplitude * (np.sin(2 * np.pi * 50 * t) + 0.3 * np.sin(2 * np.pi * 150 * t + 0.3)
                                    + 0.1 * np.sin(2 * np.pi * 250 * t + 1.0))
    out = x[:, None]
    if scene.channels == 2:
        lag = 1e-4
        x2 = np.interp(t - lag, t, x, left=0.0) * 0.8
        out = np.column_stack([x, x2])
    if scene.noise_rms:
        out = out + scene.noise_rms * rng.standard_normal(out.shape)
    return np.clip(out, -scene.clip, scene.clip)


def write_wav(path, x, fs_hz, *, bits=16):
    """Write samples (full scale = 1) as a WAV file: ``bits`` 16, 24 or 32 (PCM) or ``"float"``."""
    import io

    from scipy.io import wavfile

    from vrcal.fileio import atomic_write

    x = np.clip(np.asarray(x, dtype=float), -1.0, 1.0)
    if bits == "float":
        data = x.astype(np.float32)
    elif bits == 16:
        data = np.round(x * 32767).astype(np.int16)
    elif bits == 32:
        data = np.round(x * (2 ** 31 - 1)).astype(np.int32)
    elif bits == 24:
        data = None
    else:
        raise UsageError(f"bits must be 16, 24, 32 or 'float', got {bits!r}")
    buf = io.BytesIO()
    if data is not None:
        wavfile.write(buf, int(fs_hz), data.squeeze() if data.shape[1] == 1 else data)
        atomic_write(path, buf.getvalue())
        return
    # 24-bit PCM: scipy writes it from int32 data only in recent versions; pack it by hand
    ints = np.round(x * (2 ** 23 - 1)).astype("<i4")
    packed = ints.view(np.uint8).reshape(-1, 4)[:, :3].tobytes()
    ch = x.shape[1]
    import struct

    header = b"RIFF" + struct.pack("<I", 36 + len(packed)) + b"WAVE"
    header += b"fmt " + struct.pack("<IHHIIHH", 16, 1, ch, int(fs_hz), int(fs_hz) * 3 * ch, 3 * ch, 24)
    header += b"data" + struct.pack("<I", len(packed))
    atomic_write(path, header + packed)


# --------------------------------------------------------------------------- video


@dataclass(frozen=True)
class VideoScene:
    """Camera and scene of a synthetic video."""

    width: int = 640
    height: int = 480
    fps: float = 30.0
    m_per_px: float = 0.0025          # scale at the ball's plane [m/px]
    floor_row: float = 440.0          # image row of the floor [px]
    x_px: float = 320.0               # image column of the ball's centre [px]
    ball_bgr: tuple = (40, 160, 40)   # ball colour (OpenCV order)
    background_bgr: tuple = (200, 205, 210)
    noise_sd: float = 0.0             # Gaussian pixel noise (0-255 scale)
    blur: bool = False                # motion blur over the exposure
    exposure_s: float = 1 / 120       # exposure time when blurred [s]
    clutter: bool = False             # static shapes on the background, one of them ball-coloured
    repeat_every: int = 0             # frame-rate conversion: every n-th frame repeats the one before (0: none)
    still_frames: int = 0             # frames at the start before the clock of the drop starts


def _disc(shape, cx, cy, r, soft=1.0):
    """Anti-aliased disc coverage (0..1) on a pixel grid (pixel centres at integer coordinates)."""
    h, w = shape
    y0, y1 = max(0, int(cy - r - 3)), min(h, int(cy + r + 4))
    x0, x1 = max(0, int(cx - r - 3)), min(w, int(cx + r + 4))
    out = np.zeros(shape, dtype=np.float32)
    if y1 <= y0 or x1 <= x0:
        return out
    yy, xx = np.mgrid[y0:y1, x0:x1]
    d = np.hypot(xx - cx, yy - cy)
    out[y0:y1, x0:x1] = np.clip(r + 0.5 * soft - d, 0.0, soft) / soft
    return out


def _background(scene, rng):
    h, w = scene.height, scene.width
    bg = np.empty((h, w, 3), dtype=np.float32)
    bg[:] = scene.background_bgr
    ramp = np.linspace(-12, 12, h, dtype=np.float32)[:, None, None]
    bg += ramp
    floor = int(scene.floor_row)
    bg[floor:] = (60, 80, 120)
    if scene.clutter:
        import cv2

        r = np.random.default_rng(12345)
        for _ in range(14):
            colour = tuple(int(c) for c in r.integers(30, 230, 3))
            cx, cy = int(r.integers(0, w)), int(r.integers(0, floor))
            if abs(cx - scene.x_px) < 60:
                cx = int((cx + w / 2) % w)
            cv2.rectangle(bg, (cx, cy), (cx + int(r.integers(15, 80)), cy + int(r.integers(15, 80))), colour, -1)
        # a ball-coloured object that does not move (a static decoy)
        cv2.circle(bg, (int(scene.x_px + 150) % w, int(floor - 40)), 18, scene.ball_bgr, -1)
        cv2.line(bg, (0, floor - 5), (w, floor - 5), (90, 90, 90), 3)
    return bg


def video_truth(drops, scene, diameter_m, n_frames):
    """Frame times [s] of the source clock and the ball centre [px] (row, column) of every frame.

    With ``repeat_every`` = k the video has k frames for every k-1 source frames (frame
    i shows source frame i - i // k): times are those of the source frames shown.
    """
    r_px = 0.5 * diameter_m / scene.m_per_px
    src_fps = scene.fps * (scene.repeat_every - 1) / scene.repeat_every if scene.repeat_every else scene.fps
    i = np.arange(n_frames)
    src = i - i // scene.repeat_every if scene.repeat_every else i
    t = src / src_fps
    y_bottom = drops.height_m(t)[0]
    row = scene.floor_row - (y_bottom / scene.m_per_px) - r_px
    return t, row, np.full(n_frames, scene.x_px), src


#: The codec OpenCV writes a container with: MPEG-4 part 2 for MP4 and QuickTime (which do not take
#: Motion JPEG: OpenCV fell back with two lines of FFMPEG warnings), Motion JPEG otherwise (.avi, .mkv).
CODEC_OF_SUFFIX = {".mp4": "mp4v", ".m4v": "mp4v", ".mov": "mp4v"}


def video_duration_s(drops):
    """Length of a synthetic video by default [s]: 0.4 s after the landing of the last bounce."""
    return float(drops.landing_times_s[0]) + 0.4


def render_video(path, drops, diameter_m, *, scene=VideoScene(), duration_s=None, seed=0, fourcc=None,
                 progress=None):
    """Write a synthetic video of a simulated drop (see the module docstring) and return the truth.

    Parameters
    ----------
    path : str or Path
        output file (``.avi``, ``.mkv`` with ``MJPG``; ``.mp4``, ``.mov`` with ``mp4v``)
    drops : Drops
        one simulated drop (:func:`vrcal.drop.simulate.simulate_drops`)
    diameter_m : float
        ball diameter [m]
    scene : VideoScene
    duration_s : float or None
        length [s]; default 0.4 s after the landing of the last bounce
    seed : int
        noise seed
    fourcc : str or None
        OpenCV codec code (None: :data:`CODEC_OF_SUFFIX` by the file's extension, else ``MJPG``)

    Returns
    -------
    dict
        ``t_s`` (source time of each frame), ``row_px``, ``col_px`` (ball centre), ``diameter_px``,
        ``straddles_impact`` (frames whose exposure spans an impact: their centre is the mean
        over a path that turns, not the centre at the frame time)
    """
    try:
        import cv2
    except ImportError:
        from vrcal.measurements.video import VIDEO_HINT

        raise UsageError(VIDEO_HINT) from None
    if fourcc is None:
        fourcc = CODEC_OF_SUFFIX.get(Path(path).suffix.lower(), "MJPG")
    rng = np.random.default_rng(seed)
    if duration_s is None:
        duration_s = video_duration_s(drops)
    n_frames = int(round(duration_s * scene.fps))
    t, row, col, src = video_truth(drops, scene, diameter_m, n_frames)
    r_px = 0.5 * diameter_m / scene.m_per_px
    bg = _background(scene, rng)
    ball = np.asarray(scene.ball_bgr, dtype=np.float32)
    shade_rows = np.arange(scene.height, dtype=np.float32)
    src_fps = scene.fps * (scene.repeat_every - 1) / scene.repeat_every if scene.repeat_every else scene.fps
    from vrcal.fileio import temporary_beside

    with temporary_beside(path) as tmp:
        writer = cv2.VideoWriter(str(tmp), cv2.VideoWriter_fourcc(*fourcc), scene.fps, (scene.width, scene.height))
        if not writer.isOpened():
            raise UsageError(f"OpenCV cannot write '{path}' with codec {fourcc}")
        previous = None
        for i in range(n_frames):
            if previous is not None and scene.repeat_every and src[i] == src[i - 1]:
                writer.write(previous)
                continue
            if scene.blur:
                sub = t[i] + (np.arange(9) / 8.0 - 0.5) * scene.exposure_s
                rows = scene.floor_row - drops.height_m(sub)[0] / scene.m_per_px - r_px
            else:
                rows = [row[i]]
            # each sub-frame position draws the ball with its own shading (lit from above: lighter on
            # top); the exposure averages them
            cover = np.zeros((scene.height, scene.width), dtype=np.float32)
            shaded = np.zeros((scene.height, scene.width), dtype=np.float32)
            for rr in rows:
                disc = _disc(cover.shape, col[i], rr, r_px)
                cover += disc
                shaded += disc * (1.0 - 0.15 * np.clip((shade_rows - rr) / r_px, -1, 1))[:, None]
            cover /= len(rows)
            shaded /= len(rows)
            img = bg * (1 - cover[..., None]) + ball * shaded[..., None]
            if scene.noise_sd:
                img = img + rng.normal(0.0, scene.noise_sd, img.shape).astype(np.float32)
            frame = np.clip(np.round(img), 0, 255).astype(np.uint8)
            writer.write(frame)
            previous = frame
            if progress and i % 30 == 0:
                progress(i / n_frames, "rendering")
        writer.release()
    impacts = drops.impact_times_s[0]
    straddles = np.zeros(n_frames, dtype=bool)
    if scene.blur:  # the exposure spans an impact: the blurred image averages a V-shaped path
        straddles = np.min(np.abs(t[:, None] - impacts[None, :]), axis=1) < 0.5 * scene.exposure_s
    return {"t_s": t, "row_px": row, "col_px": col, "diameter_px": 2 * r_px, "source_fps": src_fps,
            "source_index": src, "impact_times_s": impacts, "straddles_impact": straddles}


# --------------------------------------------------------------------------- `vrcal simulate --format wav|video`

#: The room of ``vrcal simulate --format wav``: a little noise and hum, one wall echo 5 ms later.
ROOM = SoundScene(noise_rms=0.001, hum_amplitude=0.01, echoes=((0.005, 0.4),), level=0.5)

#: The camera of ``vrcal simulate --format video``: 640x480, a little noise, motion blur.
CAMERA = VideoScene(noise_sd=2.0, blur=True)


#: Sample rates of ``vrcal simulate --format wav`` [Hz]: from the lowest that ``vrcal track`` reads
#: (:data:`vrcal.measurements.sound.MIN_SAMPLE_RATE_HZ`) to 384 kHz, the highest of audio interfaces.
WAV_RATE_HZ = (8000.0, 384000.0)
#: Lowest frame rate of ``vrcal simulate --format video`` [Hz]: below it ``vrcal track`` gets too few
#: frames of a flight (a 5 fps video of a tennis ball's drop gives 4 frames; a trajectory needs 20).
MIN_VIDEO_RATE_HZ = 10.0
#: Most frames of ``vrcal simulate --format video``: at 640x480 a frame takes about 3 kB (Motion JPEG) and
#: 10 ms to render here, so 10,000 frames are about 30 MB and two minutes (1000 fps for a 10 s drop).
MAX_VIDEO_FRAMES = 10_000


def check_recording_rate(kind, fs_hz, drops):
    """Refuse up front (one-line UsageError) a ``--fs`` that gives a recording vrcal cannot track, or
    a video with more than :data:`MAX_VIDEO_FRAMES` frames.

    Parameters
    ----------
    kind : {"wav", "video"}
    fs_hz : float
        sample rate [Hz] of the sound, frame rate [Hz] of the video
    drops : Drops
        the simulated drop (its length sets the video's frame count)
    """
    if kind == "wav":
        lo, hi = WAV_RATE_HZ
        if not lo <= fs_hz <= hi:
            raise UsageError(f"--fs {fs_hz:g} Hz: a WAV takes a sample rate of {lo:.0f} to {hi:.0f} Hz "
                             f"({lo:.0f} Hz is the lowest 'vrcal track' reads; 48000 by default)")
        return
    if fs_hz < MIN_VIDEO_RATE_HZ:
        raise UsageError(f"--fs {fs_hz:g} Hz: a video takes a frame rate of {MIN_VIDEO_RATE_HZ:g} Hz or more "
                         f"(fewer frames than 'vrcal track' needs of a flight; 30 by default)")
    duration = video_duration_s(drops)
    n_frames = int(round(duration * fs_hz))
    if n_frames > MAX_VIDEO_FRAMES:
        top = math.floor(MAX_VIDEO_FRAMES / duration)
        raise UsageError(f"--fs {fs_hz:g} Hz: {n_frames:,} video frames, more than the limit of {MAX_VIDEO_FRAMES:,}: "
                         f"lower --fs (at most {top} Hz for this {duration:.2f} s drop) or --bounces")


def simulate_recording(path, ball, kind, *, fs_hz=None, seed=0, standards=None, **drop):
    """Simulate one drop (:func:`vrcal.drop.simulate.simulate_drop`) and write its sound or video.

    Parameters
    ----------
    path : str
        output file (``.wav``; ``.avi`` for a video)
    ball : str or Body or None
        the body, as :func:`vrcal.drop.simulate.simulate_csv` takes it (``mass_kg``,
        ``diameter_m``, ``from_json`` in ``drop``)
    kind : {"wav", "video"}
    fs_hz : float or None
        sample rate [Hz] (default 48000) or frame rate (default 30) of the recording
    seed : int
        noise seed
    standards : dict or None
    **drop :
        the drop's parameters (``drop_height_m``, ``n_bounces``, ``epsilon``, ``effects``,
        ``still_s``, ``mass_kg``, ``diameter_m``, ``from_json``, ``g_m_per_s2``, ...)

    Returns
    -------
    str
        a one-line summary of what was written (the truth: impact times or frames)
    """
    from vrcal.drop.simulate import simulate_drop

    if kind not in ("wav", "video"):
        raise UsageError(f"unknown recording kind '{kind}' (wav, video)")
    drops, props = simulate_drop(ball, standards=standards, **drop)
    check_recording_rate(kind, float(fs_hz or (48000.0 if kind == "wav" else 30.0)), drops)
    t = drops.impact_times_s[0]
    if kind == "wav":
        fs = int(fs_hz or 48000)
        x = impact_sound(t, drops.impact_speeds_m_per_s[0], fs_hz=fs, scene=ROOM, seed=seed)
        write_wav(path, x, fs)
        return (f"wrote {path}: {t.size} impacts at t = {t[0]:.4f} .. {t[-1]:.4f} s, "
                f"{fs / 1000:g} kHz, {x.shape[0] / fs:.2f} s")
    if kind == "video":
        D = float(np.mean(props.diameter_m))
        apex = float(np.max(drops.apex_heights_m[0])) + D
        scene = CAMERA
        m_per_px = max(apex / (scene.floor_row - 30.0), D / 60.0)
        import dataclasses

        scene = dataclasses.replace(scene, fps=float(fs_hz or 30.0), m_per_px=m_per_px)
        truth = render_video(path, drops, D, scene=scene, seed=seed)
        return (f"wrote {path}: {truth['t_s'].size} frames at {scene.fps:g} fps, {scene.width}x{scene.height} px, "
                f"ball {truth['diameter_px']:.1f} px wide")
