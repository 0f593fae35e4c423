"""``vrcal track``: a sound or video recording turned into the measurement file vrcal reads.

This module owns the step from a raw recording to a text measurement: it runs the sound
reader (:mod:`vrcal.measurements.sound`, impact times) or the video tracker
(:mod:`vrcal.measurements.video`, a trajectory), writes the result in the ``impacts`` or
``trajectory`` layout with the notes on how it was made as ``#`` comment lines (which every
reader skips), and draws what was detected over the signal or the frames.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from vrcal.errors import UsageError
from vrcal.textout import wrap


@dataclass(frozen=True)
class Tracked:
    """What :func:`track` made: ``kind`` "sound" or "video", the measurement, the text, the tracker's result."""

    kind: str
    measurement: object
    text: str
    detail: object

    def summary(self):
        """A few lines for people: what was found."""
        m = self.measurement
        if self.kind == "sound":
            head = (f"{m.source}: {m.t_s.size} impacts, t = {m.t_s[0]:.4f} .. {m.t_s[-1]:.4f} s "
                    f"(intervals {np.diff(m.t_s)[0] * 1e3:.1f} .. {np.diff(m.t_s)[-1] * 1e3:.1f} ms)")
        else:
            d = self.detail
            head = (f"{m.source}: ball tracked in {m.t_s.size} frames, t = {m.t_s[0]:.3f} .. {m.t_s[-1]:.3f} s, "
                    f"heights up to {np.max(m.y_m):.3f} m ({d.scale_m_per_px * 1e3:.4g} mm/px)")
        return wrap(head, rest="  ") + "".join(wrap(n, first="  ", rest="    ") for n in m.notes)


def track(path, fmt=None, *, diameter_m=None, roi=None, color=None, fps=None, scale_m_per_px=None, progress=None,
          g_m_per_s2=None, rotate=None):
    """Track a recording (see :func:`vrcal.measurements.sound.track_sound` and
    :func:`vrcal.measurements.video.track_video`) and lay the result out as a measurement file.

    Parameters
    ----------
    path : str
        a sound or video file
    fmt : {"sound", "video"} or None
        None: detected from the file
    diameter_m : float or None
        video: the ball's diameter [m]
    roi, color, fps, scale_m_per_px, rotate :
        video options (region ``x,y,w,h``, ball colour, frame rate [Hz], scale [m/px], degrees to turn
        the picture clockwise)
    progress : callable, optional
        ``progress(fraction, message)``
    g_m_per_s2 : float or None
        video: the local g [m/s^2] that scales the flights (None: standard gravity)

    Returns
    -------
    Tracked
    """
    from vrcal.measurements.reader import spooled

    with spooled(path) as readable:
        tracked = _track(readable, fmt, diameter_m=diameter_m, roi=roi, color=color, fps=fps,
                         scale_m_per_px=scale_m_per_px, progress=progress, g_m_per_s2=g_m_per_s2, rotate=rotate)
    if readable == str(path):
        return tracked
    import dataclasses  # read from a copy of stdin or a FIFO: name the input as the user did

    m = tracked.measurement
    m = dataclasses.replace(m, source=str(path), notes=tuple(n.replace(readable, str(path)) for n in m.notes))
    return dataclasses.replace(tracked, measurement=m, text=tracked.text.replace(readable, str(path)))


def _track(path, fmt, *, diameter_m, roi, color, fps, scale_m_per_px, progress, g_m_per_s2, rotate):
    from vrcal.measurements import sound, video
    from vrcal.measurements.reader import _detect_recording

    kind = fmt or _detect_recording(path)
    if kind not in ("sound", "video"):
        from vrcal.errors import DataError

        raise DataError(f"{path}: not a sound or video recording (WAV, m4a, mp3, mp4, mov, avi, ...); "
                        "a text measurement needs no tracking: give it to 'vrcal discover' directly")
    if kind == "sound":
        if any(v is not None for v in (roi, color, fps, scale_m_per_px, rotate)):
            raise UsageError("--roi, --color, --fps, --scale and --rotate apply to videos, not to sound")
        st = sound.track_sound(path, progress=progress)
        return Tracked("sound", st.impacts, impacts_text(st), st)
    vt = video.track_video(path, diameter_m=diameter_m, roi=roi, color=color, fps=fps, scale_m_per_px=scale_m_per_px,
                           progress=progress, rotate=rotate or 0,
                           **({} if g_m_per_s2 is None else {"g_m_per_s2": g_m_per_s2}))
    return Tracked("video", vt.trajectory, trajectory_text(vt), vt)


def _comments(title, notes):
    """``#`` comment lines, each at most 100 columns (a long note goes on over several, each starting '# ')."""
    return "".join(wrap(line, first="# ", rest="#   " if i else "# ") for i, line in enumerate([title, *notes]))


def impacts_text(st):
    """The ``impacts`` layout of a sound track: ``t (s),level (dB)``, notes as comments."""
    m = st.impacts
    rows = [f"{t:.6f},{lv:.1f}" for t, lv in zip(m.t_s, st.snr_db)]
    head = _comments(f"vrcal track: impact times from {m.source} (level = peak over the noise)", m.notes)
    if m.instrument_sd_s:   # how well the onsets are timed, for the reader of this file (table.meta_number)
        head += f"# vrcal instrument_sd_s = {m.instrument_sd_s:.4g}\n"
    if m.suspect:  # what the tracking found suspect, a warning again when the file is read (impacts.parse)
        head += f"# vrcal suspect = {'; '.join(m.suspect)}\n"
    return head + "t (s),level (dB)\n" + "\n".join(rows) + "\n"


def trajectory_text(vt):
    """The ``trajectory`` layout of a video track: ``t (s),y (m),x (m),quality``, notes as comments."""
    m = vt.trajectory
    frames = np.flatnonzero(vt.kept)
    # the trajectory holds the kept frames in order (the track's `kept` follows what finish_trajectory left out)
    q = vt.quality[frames] if frames.size == m.t_s.size else np.full(m.t_s.size, np.nan)
    x = (vt.col_px[frames] - vt.col_px[frames][0]) * vt.scale_m_per_px if frames.size == m.t_s.size else \
        np.zeros(m.t_s.size)
    rows = [f"{t:.6f},{y:.6f},{xx:.6f},{qq:.3f}" for t, y, xx, qq in zip(m.t_s, m.y_m, x, q)]
    head = _comments(f"vrcal track: the ball's centre in {m.source}; y = height of the ball's bottom above the floor",
                     m.notes)
    # the tracker's own uncertainties, for the reader of this file (vrcal.measurements.table.meta_length)
    head += (f"# vrcal systematic_m = {getattr(m, 'systematic_m', 0.0):.4g}\n"
             f"# vrcal floor_sd_m = {getattr(m, 'floor_sd_m', 0.0):.4g}\n")
    return head + "t (s),y (m),x (m),quality\n" + "\n".join(rows) + "\n"


def track_figure(tracked):
    """A figure of what was detected: the signal with the impacts (sound), or the ball's row per
    frame with the frames kept and left out over the background (video). Returns the Figure."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    if tracked.kind == "sound":
        st = tracked.detail
        fig, ax = plt.subplots(figsize=(10, 4))
        x = st.x.mean(axis=1)
        step = max(1, x.size // 200000)
        t = np.arange(0, x.size, step) / st.fs_hz
        ax.plot(t, x[::step], lw=0.4, color="0.5", label=f"signal ({st.what})")
        labelled = set()
        for i in np.concatenate([st.chain, st.second]).astype(int):
            kept = bool(np.any(np.abs(tracked.measurement.t_s - st.onsets.t_s[i]) < 1e-9))
            label = "impacts kept" if kept else "impacts not fitted"
            ax.axvline(st.onsets.t_s[i], color="tab:green" if kept else "tab:orange", lw=0.8,
                       label=None if label in labelled else label)
            labelled.add(label)
        for j, i in enumerate(sorted(st.reasons)):
            ax.axvline(st.onsets.t_s[i], color="tab:red", ls=":", lw=0.8, label="rejected events" if j == 0 else None)
        ax.set_xlabel("time [s]")
        ax.set_ylabel("amplitude (full scale = 1)")
        ax.set_title(f"vrcal track: {tracked.measurement.source}")
        ax.legend(loc="upper right", fontsize=8)
        fig.tight_layout()
        return fig
    vt = tracked.detail
    fig, (ax_img, ax) = plt.subplots(1, 2, figsize=(12, 5), gridspec_kw={"width_ratios": [1, 2]})
    if vt.background is not None:
        ax_img.imshow(vt.background[..., ::-1], extent=(0, vt.size[1], vt.size[0], 0))
    found = np.isfinite(vt.row_px)
    ax_img.plot(vt.col_px[vt.kept], vt.row_px[vt.kept], ".", ms=3, color="tab:green", label="kept")
    ax_img.plot(vt.col_px[found & ~vt.kept], vt.row_px[found & ~vt.kept], "x", ms=3, color="tab:red",
                label="left out")
    ax_img.set_title("background and ball centres")
    ax_img.legend(loc="lower left", fontsize=8)
    ax_img.set_xticks([])
    ax_img.set_yticks([])
    t = vt.t_s
    ax.plot(t[vt.kept], vt.row_px[vt.kept], ".", color="tab:green", label="kept")
    ax.plot(t[found & ~vt.kept], vt.row_px[found & ~vt.kept], "x", color="tab:red", label="left out")
    if vt.bounces is not None:
        tf = np.linspace(min(f[1] for f in vt.bounces.flights), max(f[2] for f in vt.bounces.flights), 800)
        ax.plot(tf, vt.bounces.row_at(tf), color="tab:blue", lw=0.8, label="flights between bounces, fitted")
    ax.axhline(vt.contact_row_px, color="0.5", ls="--", lw=0.8, label="centre at contact")
    ax.invert_yaxis()
    ax.set_xlabel("time [s]")
    ax.set_ylabel("ball centre, image row [px] (down)")
    ax.set_title(f"vrcal track: {tracked.measurement.source}")
    ax.legend(fontsize=8)
    fig.tight_layout()
    return fig
