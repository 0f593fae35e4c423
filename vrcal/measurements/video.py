"""Video recordings of a drop (the containers a phone writes, read with OpenCV): the ball's trajectory.

This module owns finding the ball in every frame (:func:`track_video`), the frame times
(container time stamps, repeated and dropped frames), the scale from the ball's apparent
diameter, the floor from the bounces, and the ``video`` reader of
:data:`vrcal.measurements.FORMATS` (:func:`parse`), which returns a
:class:`~vrcal.measurements.types.Trajectory`. OpenCV is the optional extra ``video``
(``pip install 'vrcal[video]'``, package opencv-python-headless).

How the ball is found
---------------------
1. **Two passes.** Pass 1 decodes every frame, keeps a small copy (about 480 px wide) and
   a few full-size frames spread over the video; pass 2 decodes again and measures the
   ball at full size only around where pass 1 found it.
2. **Background.** The per-pixel median of about 24 frames spread over the video: the
   static scene, cluttered or not, without the moving ball.
3. **Colour model.** ``--color`` (a name, ``#RRGGBB`` or ``B,G,R``), or learnt: among the
   compact blobs that differ from the background (in CIELAB), the colour that appears in
   the most frames with a steady size is the ball's (a hand, a person or a shadow fail
   either test). The ball's pixels are those near its colour *and* off the background.
4. **Centre.** In the full-size frame, the ball's coverage ``alpha`` of each pixel is the
   projection of ``(pixel - background)`` on ``(ball colour - background)`` in BGR (where
   an edge pixel is a weighted sum of ball and background); pixels far off that line (a
   shadow, a hand) count 0; clipped to 0..2, not at 1, so that the shading of a ball lit
   from above stays symmetric. The centre is the alpha-weighted centroid over the ball's blob (grown by
   3 px): sub-pixel, and unbiased under motion blur (blur spreads alpha symmetrically
   about the centre at mid-exposure).
5. **Quality** (per frame, 0..1): the ball's alpha area over its median area, inverted
   when larger, lowered when the blob touches the frame's edge. Frames below
   :data:`MIN_QUALITY` (ball lost, hidden by a hand, cut by the edge) are left out.

Times, scale, floor and the y axis
----------------------------------
* **Times** are the container's time stamps (phones write variable frame rates); a gap of
  more than 1.5 frame intervals is reported as dropped frames (the times stay right). A
  frame identical to the one before (a frame-rate conversion repeats frames) is dropped;
  then the frames left are timed both by their stamps and evenly spaced over the same
  span, and the timing whose flights are better parabolas is kept (``--fps`` overrides
  the container's rate, e.g. for a slow-motion video).
* **Scale** [m/px] = ``diameter_m`` / the ball's apparent diameter (the median
  area-equivalent diameter of the slowest third of the frames), or ``scale_m_per_px``.
* **Check against g.** Each flight between bounces is fitted with a parabola; its
  curvature times the scale is g. A value far from 9.81 m/s² is reported (wrong
  diameter, or a slow-motion video whose container rate is not the capture rate).
* **Floor and y axis.** Image rows grow downwards; heights are ``(row_c - row) * scale``,
  where ``row_c`` is the centre's row at contact: the median of the crossings of the
  parabolas of consecutive flights. So ``y`` is the height of the ball's bottom above the
  floor (the centre at contact is one radius above it).
* **The drop only.** The track starts at the still segment before release and ends once
  the ball rests on the floor (what follows -- a hand picking it up -- is no bounce).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from vrcal.errors import DataError, UsageError
from vrcal.measurements.cleanup import detect_release_index
from vrcal.measurements.trajectory import finish_trajectory

#: One-line hint when OpenCV is missing.
VIDEO_HINT = "reading video needs OpenCV: pip install 'vrcal[video]'"

#: File name endings read as video.
VIDEO_EXTENSIONS = (".mp4", ".mov", ".m4v", ".avi", ".mkv", ".webm", ".3gp", ".mts", ".m2ts", ".wmv", ".mpg",
                    ".mpeg", ".ogv")

MIN_QUALITY = 0.6          #: frames with a lower quality are left out
G_TOLERANCE = 0.05         #: a g from the flights further than this (relative) from 9.81 is reported
STANDARD_GRAVITY = 9.80665
LOW_RES_WIDTH = 320        #: width of the pass-1 copies [px] (at least)
BACKGROUND_FRAMES = 24     #: frames in the background median

#: Named colours for ``--color`` (B, G, R).
COLORS = {
    "red": (40, 40, 200), "green": (50, 150, 50), "blue": (180, 80, 30), "yellow": (40, 210, 230),
    "orange": (30, 120, 240), "white": (235, 235, 235), "black": (25, 25, 25), "pink": (170, 110, 240),
    "purple": (140, 50, 110), "cyan": (200, 200, 40),
}


def detect(head, path):
    """An MP4/MOV/3GP (``ftyp``, not audio-only), AVI, Matroska/WebM file, or a video extension."""
    if head[4:8] == b"ftyp":
        return head[8:11] not in (b"M4A", b"M4B")
    if head[:4] == b"RIFF" and head[8:12] == b"AVI ":
        return True
    if head[:4] == b"\x1a\x45\xdf\xa3":
        return True
    return Path(path).suffix.lower() in VIDEO_EXTENSIONS


def _cv2():
    try:
        import cv2
    except ImportError:
        raise UsageError(VIDEO_HINT) from None
    return cv2


def parse_color(text):
    """A colour for ``--color``: a name of :data:`COLORS`, ``#RRGGBB``, or ``B,G,R`` (0-255) -> (B, G, R)."""
    s = str(text).strip().lower()
    if s in COLORS:
        return COLORS[s]
    if s.startswith("#") and len(s) == 7:
        try:
            r, g, b = (int(s[i:i + 2], 16) for i in (1, 3, 5))
            return (b, g, r)
        except ValueError:
            pass
    parts = s.split(",")
    if len(parts) == 3:
        try:
            values = tuple(int(float(p)) for p in parts)
            if all(0 <= v <= 255 for v in values):
                return values
        except ValueError:
            pass
    raise UsageError(f"--color '{text}': give a name ({', '.join(sorted(COLORS))}), #RRGGBB or B,G,R")


def parse_roi(text):
    """``X,Y,W,H`` (pixels of the full frame) -> a tuple of four ints."""
    try:
        x, y, w, h = (int(float(p)) for p in str(text).split(","))
    except ValueError:
        raise UsageError(f"--roi '{text}': give X,Y,W,H in pixels (left, top, width, height)") from None
    if w < 8 or h < 8 or x < 0 or y < 0:
        raise UsageError(f"--roi '{text}': width and height must be >= 8 px and X, Y >= 0")
    return x, y, w, h


@dataclass
class VideoTrack:
    """What :func:`track_video` found, per frame of the video (all arrays have one entry a frame)."""

    t_s: np.ndarray            # frame times used [s] (NaN for dropped repeats)
    row_px: np.ndarray         # ball centre, image row (down) [px], NaN where not found
    col_px: np.ndarray         # ball centre, image column [px]
    quality: np.ndarray        # 0..1
    kept: np.ndarray           # bool: in the trajectory
    repeated: np.ndarray       # bool: a repeat of the previous frame
    diameter_px: float
    scale_m_per_px: float
    contact_row_px: float
    g_measured: float
    fps: float
    size: tuple
    notes: list = field(default_factory=list)
    trajectory: object = None
    background: np.ndarray = None   # small copy of the background (for figures)
    scale_down: float = 1.0


class _Progress:
    """Calls ``progress(fraction, message)`` at most every 0.3 s."""

    def __init__(self, progress):
        self.progress = progress
        self.last = 0.0

    def __call__(self, fraction, message, force=False):
        if not self.progress:
            return
        now = time.monotonic()
        if force or now - self.last >= 0.3:
            self.last = now
            self.progress(fraction, message)


def _open(cv2, path):
    p = Path(path)
    if p.is_dir():
        raise DataError(f"{path}: is a directory, not a video")
    if not p.exists():
        raise DataError(f"{path}: no such file")
    cap = cv2.VideoCapture(str(path))
    if not cap.isOpened():
        raise DataError(f"{path}: not a readable video (OpenCV cannot open it; corrupt, or a codec it lacks)")
    return cap


def _lab(cv2, bgr):
    return cv2.cvtColor(bgr, cv2.COLOR_BGR2LAB).astype(np.float32)


#: Weight of CIELAB lightness against the two colour axes in the ball's coverage.
LIGHTNESS_WEIGHT = 0.35


def _weighted(lab):
    out = lab.copy()
    out[..., 0] *= LIGHTNESS_WEIGHT
    return out


def _distance(cv2, a, b):
    """Per-pixel Euclidean distance of two 3-channel float32 images (or an image and a colour)."""
    d = cv2.subtract(a, b) if isinstance(b, np.ndarray) and b.ndim == 3 else a - np.asarray(b, np.float32)
    d = cv2.multiply(d, d)
    return np.sqrt(cv2.transform(d, np.ones((1, 3), np.float32)))


def _read_pass1(cv2, path, roi, prog):
    cap = _open(cv2, path)
    fps = float(cap.get(cv2.CAP_PROP_FPS) or 0.0)
    n_est = int(cap.get(cv2.CAP_PROP_FRAME_COUNT) or 0)
    small, stamps, full = [], [], {}
    step = max(1, n_est // BACKGROUND_FRAMES) if n_est > 0 else 8
    factor = None
    i = 0
    while True:
        ok = cap.grab()
        if not ok:
            break
        ok, frame = cap.retrieve()
        if not ok or frame is None:
            break
        stamps.append(cap.get(cv2.CAP_PROP_POS_MSEC) / 1000.0)
        if roi is not None:
            x, y, w, h = roi
            frame = frame[y:y + h, x:x + w]
            if frame.shape[0] < 8 or frame.shape[1] < 8:
                raise UsageError(f"--roi {roi} lies outside the {frame.shape[1]}x{frame.shape[0]} video")
        if factor is None:
            factor = max(1, int(frame.shape[1] // LOW_RES_WIDTH))
            size = frame.shape[:2]
        small.append(cv2.resize(frame, (frame.shape[1] // factor, frame.shape[0] // factor),
                                interpolation=cv2.INTER_LINEAR) if factor > 1 else frame.copy())
        if i % step == 0:
            full[i] = frame.copy()
            if len(full) > 2 * BACKGROUND_FRAMES:  # unknown length: thin out
                for k in sorted(full)[1::2]:
                    del full[k]
                step *= 2
        i += 1
        prog(0.45 * i / max(n_est, i + 1), f"reading frames {i}/{n_est or '?'}")
    cap.release()
    if not small:
        raise DataError(f"{path}: no frames could be decoded (corrupt video, or a codec OpenCV lacks)")
    return np.stack(small), np.asarray(stamps), full, fps, factor, size


def _background(frames):
    idx = np.linspace(0, len(frames) - 1, min(len(frames), BACKGROUND_FRAMES)).round().astype(int)
    return np.median(frames[np.unique(idx)], axis=0).astype(np.uint8)


def _foreground_threshold(diff):
    med = float(np.median(diff))
    mad = float(np.median(np.abs(diff - med)))
    return max(12.0, med + 8.0 * 1.4826 * mad)


def _blobs(cv2, mask, min_area):
    n, labels, stats, cent = cv2.connectedComponentsWithStats(mask.astype(np.uint8), connectivity=8)
    out = []
    for k in range(1, n):
        x, y, w, h, a = (int(v) for v in stats[k])
        if a < min_area:
            continue
        fill = a / float(w * h)
        if fill < 0.5 or not (1 / 3.5 <= w / h <= 3.5):
            continue
        out.append((k, a, x, y, w, h, cent[k], labels))
    return out


def _learn_colour(cv2, frames, bg_lab, thresholds, min_area):
    """Mean CIELAB colour and area (small frames) of the ball: the compact moving blob colour seen in most frames."""
    samples = []  # (frame, area, lab colour)
    idx = np.unique(np.linspace(0, len(frames) - 1, min(len(frames), 60)).round().astype(int))
    for i in idx:
        lab = _lab(cv2, frames[i])
        diff = _distance(cv2, _weighted(lab), _weighted(bg_lab))
        mask = diff > thresholds
        for k, a, x, y, w, h, c, labels in _blobs(cv2, mask, min_area):
            colour = np.median(lab[labels == k], axis=0)
            samples.append((int(i), a, colour))
    if not samples:
        return None, None, 0
    colours = np.array([s[2] for s in samples])
    areas = np.array([s[1] for s in samples], dtype=float)
    frames_of = np.array([s[0] for s in samples])
    best, best_count = None, -1
    w = np.array([LIGHTNESS_WEIGHT, 1.0, 1.0])
    for j in range(len(samples)):
        near = (np.linalg.norm((colours - colours[j]) * w, axis=1) < 12.0) & (areas > 0.5 * areas[j]) & (
            areas < 2.0 * areas[j])
        count = np.unique(frames_of[near]).size
        if count > best_count:
            best, best_count = near, count
    return np.median(colours[best], axis=0), float(np.median(areas[best])), best_count


def _coarse_track(cv2, frames, bg, ball_lab, ball_area, prog):
    """Per small frame: centre (row, col), area, or NaN: the ball-coloured moving blob nearest in size."""
    n = len(frames)
    rows, cols, areas = np.full(n, np.nan), np.full(n, np.nan), np.full(n, np.nan)
    bg_lab = _lab(cv2, bg)
    w = np.array([LIGHTNESS_WEIGHT, 1.0, 1.0], dtype=np.float32)
    bgw = (bg_lab * w).astype(np.float32)
    ball_w = (ball_lab * w).astype(np.float32)
    sep = float(np.linalg.norm(ball_w - bgw.reshape(-1, 3).mean(0)))
    radius = max(10.0, 0.35 * sep)
    last = None
    for i in range(n):
        lab = _lab(cv2, frames[i]) * w
        near_ball = _distance(cv2, lab, ball_w) < radius
        off_bg = _distance(cv2, lab, bgw) > 0.5 * radius
        mask = near_ball & off_bg
        blobs = _blobs(cv2, mask, max(4, 0.2 * ball_area) if ball_area else 4)
        if blobs and ball_area is None:  # the colour is given, the size not yet known: the largest blob
            b = max(blobs, key=lambda b: b[1])
            cols[i], rows[i], areas[i] = b[6][0], b[6][1], b[1]
        elif blobs:
            def cost(b):
                size = abs(math.log(b[1] / ball_area))
                dist = 0.0 if last is None else math.hypot(b[6][1] - last[0], b[6][0] - last[1]) / math.sqrt(ball_area)
                return size + 0.1 * dist
            b = min(blobs, key=cost)
            if 0.25 < b[1] / ball_area < 4.0:
                cols[i], rows[i], areas[i] = b[6][0], b[6][1], b[1]
                last = (rows[i], cols[i])
        prog(0.45 + 0.1 * (i + 1) / n, f"finding the ball {i + 1}/{n}")
    return rows, cols, areas


class _TiledMedian:
    """Per-pixel median of a few full-size frames, computed tile by tile when first needed."""

    def __init__(self, frames, tile=64):
        self.frames = np.stack(frames)
        self.tile = tile
        self.cache = {}

    def crop(self, y0, y1, x0, x1):
        t = self.tile
        out = np.empty((y1 - y0, x1 - x0, 3), dtype=np.uint8)
        for ty in range(y0 // t, (y1 - 1) // t + 1):
            for tx in range(x0 // t, (x1 - 1) // t + 1):
                key = (ty, tx)
                if key not in self.cache:
                    block = self.frames[:, ty * t:(ty + 1) * t, tx * t:(tx + 1) * t]
                    self.cache[key] = np.median(block, axis=0).astype(np.uint8)
                blk = self.cache[key]
                by0, bx0 = ty * t, tx * t
                sy0, sy1 = max(y0, by0), min(y1, by0 + blk.shape[0])
                sx0, sx1 = max(x0, bx0), min(x1, bx0 + blk.shape[1])
                out[sy0 - y0:sy1 - y0, sx0 - x0:sx1 - x0] = blk[sy0 - by0:sy1 - by0, sx0 - bx0:sx1 - bx0]
        return out


def ball_coverage(cv2, crop, background, ball_lab):
    """Coverage alpha (0..2) of the ball in each pixel of a crop (see the module docstring, step 4).

    The projection of ``(pixel - background)`` on ``(ball colour - background)`` in linear
    BGR, where a pixel that mixes ball and background is their weighted sum; pixels far off
    that line (a shadow, a hand) count 0. Not clipped at 1: a ball lit from above is lighter
    than its mean colour on top and darker below, symmetrically, so the centroid stays put.
    """
    ball_bgr = cv2.cvtColor(np.clip(np.asarray(ball_lab, np.float32), 0, 255).astype(np.uint8).reshape(1, 1, 3),
                            cv2.COLOR_LAB2BGR).reshape(3).astype(np.float32)
    d = crop.astype(np.float32) - background.astype(np.float32)
    c = ball_bgr[None, None, :] - background.astype(np.float32)
    denom = np.maximum(np.sum(c * c, axis=2), 100.0)
    alpha = np.sum(d * c, axis=2) / denom
    perp = np.linalg.norm(d - alpha[..., None] * c, axis=2)
    alpha[perp > 0.6 * np.sqrt(denom) + 8.0] = 0.0
    return np.clip(alpha, 0.0, 2.0)


def ball_presence(cv2, crop, background, ball_lab):
    """Presence (0..1) of the ball in each pixel: the same projection in CIELAB with lightness
    weighted 0.35, so that a ball in the shade, or a shadow (which mainly darkens), is judged by
    its colour. It gives the ball's blob and area; :func:`ball_coverage` its centre."""
    w = np.array([LIGHTNESS_WEIGHT, 1.0, 1.0], dtype=np.float32)
    lab = _lab(cv2, crop) * w
    bgl = _lab(cv2, background) * w
    d = lab - bgl
    c = (np.asarray(ball_lab, np.float32) * w) - bgl
    denom = np.maximum(np.sum(c * c, axis=2), 25.0)
    alpha = np.sum(d * c, axis=2) / denom
    perp = np.linalg.norm(d - alpha[..., None] * c, axis=2)
    alpha[perp > 0.5 * np.sqrt(denom) + 6.0] = 0.0
    return np.clip(alpha, 0.0, 1.0)


def _refine(cv2, path, roi, factor, coarse, diameter_small, ball_lab, bgmed, prog, n):
    """Pass 2: alpha-weighted centroid at full size around each coarse detection."""
    rows, cols, areas = coarse
    row_f, col_f = np.full(n, np.nan), np.full(n, np.nan)
    area_f, edge = np.full(n, np.nan), np.zeros(n, dtype=bool)
    cap = _open(cv2, path)
    half = 0.5 * diameter_small * factor
    i = 0
    while i < n:
        ok = cap.grab()
        if not ok:
            break
        if np.isnan(rows[i]):
            i += 1
            continue
        ok, frame = cap.retrieve()
        if not ok:
            break
        if roi is not None:
            x, y, w, h = roi
            frame = frame[y:y + h, x:x + w]
        H, W = frame.shape[:2]
        cy, cx = (rows[i] + 0.5) * factor - 0.5, (cols[i] + 0.5) * factor - 0.5
        # a box 3 diameters tall (motion blur) and 2 wide
        y0, y1 = max(0, int(cy - 3 * half)), min(H, int(cy + 3 * half) + 1)
        x0, x1 = max(0, int(cx - 2 * half)), min(W, int(cx + 2 * half) + 1)
        if y1 - y0 < 4 or x1 - x0 < 4:
            i += 1
            continue
        crop, back = frame[y0:y1, x0:x1], bgmed.crop(y0, y1, x0, x1)
        presence = ball_presence(cv2, crop, back, ball_lab)
        alpha = ball_coverage(cv2, crop, back, ball_lab)
        core = (presence > 0.3).astype(np.uint8)
        k, labels, stats, cent = cv2.connectedComponentsWithStats(core, connectivity=8)
        if k > 1:
            j = 1 + int(np.argmax(stats[1:, 4]))
            blob = (labels == j).astype(np.uint8)
            grown = cv2.dilate(blob, cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (7, 7)))
            a = alpha * grown
            total = float(a.sum())
            if total > 0:
                yy, xx = np.mgrid[y0:y1, x0:x1]
                row_f[i] = float((a * yy).sum() / total)
                col_f[i] = float((a * xx).sum() / total)
                area_f[i] = float((blob * (presence > 0.5)).sum())
                bx, by, bw, bh = (int(v) for v in stats[j, :4])
                edge[i] = (y0 + by <= 0) or (x0 + bx <= 0) or (y0 + by + bh >= H) or (x0 + bx + bw >= W)
        i += 1
        prog(0.55 + 0.4 * i / n, f"measuring the ball {i}/{n}")
    cap.release()
    return row_f, col_f, area_f, edge


def _flights(t, row, min_frames=4):
    """Parabolas ``row = a t^2 + b t + c`` of the flights between bounces.

    Bounces are the frames where the ball, moving down (row growing), turns up. Returns
    ``[(indices, coeffs, rms)]`` for flights with at least ``min_frames`` frames; the frames
    at each bounce are left out of both flights (the ball may be in contact).
    """
    dt = np.diff(t)
    v = np.diff(row) / dt
    step = float(np.median(dt))
    bounce = [i for i in range(1, row.size - 1) if v[i - 1] > 0 and v[i] < 0 and row[i] >= row[i - 1]]
    gaps = [i + 1 for i in np.flatnonzero(dt > 3.5 * step)]  # a gap without the ball ends a flight
    bounds = [-1] + sorted(set(bounce) | set(gaps)) + [row.size]
    out = []
    for a, b in zip(bounds[:-1], bounds[1:]):
        idx = np.arange(a + 1, b)
        if b in gaps:
            idx = np.arange(a + 1, b)
        if idx.size < min_frames:
            continue
        coef = np.polyfit(t[idx], row[idx], 2)
        if coef[0] <= 0:  # not falling with g (image rows grow downwards): a hand, not a flight
            continue
        res = row[idx] - np.polyval(coef, t[idx])
        out.append((idx, coef, float(np.sqrt(np.mean(res ** 2)))))
    if len(out) >= 3:  # a flight's curvature is g / scale: drop the ones far from the median
        g = np.median([c[0] for _, c, _ in out])
        out = [f for f in out if 0.6 * g < f[1][0] < 1.6 * g]
    return out


def _bounce_crossings(t, flights):
    """(time, row) of the crossing of each pair of consecutive flight parabolas between their frames."""
    out = []
    for (i1, c1, _), (i2, c2, _) in zip(flights[:-1], flights[1:]):
        if i2[0] - i1[-1] > 3:
            continue
        t_lo, t_hi = t[i1[-1]], t[i2[0]]
        roots = np.roots(np.asarray(c1) - np.asarray(c2))
        roots = roots[np.isreal(roots)].real
        inside = roots[(roots >= t_lo - 1e-9) & (roots <= t_hi + 1e-9)]
        if inside.size:
            tc = float(inside[0])
            out.append((tc, float(np.polyval(c1, tc))))
    return out


def _track_end(t, row, flights, contact_row, tol_px, rest_s=0.3, gap_s=0.25):
    """One past the last frame of the drop: after the last fitted flight, the first frame below
    the floor (the ball rolls towards the camera) or after a gap of ``gap_s`` without the ball,
    or ``rest_s`` after the ball came to rest on the floor."""
    if not flights:
        return row.size
    i = int(flights[-1][0][-1]) + 1
    rest = None
    while i < row.size:
        if row[i] > contact_row + tol_px or t[i] - t[i - 1] > gap_s:
            break
        if abs(row[i] - contact_row) <= tol_px:
            rest = t[i] if rest is None else rest
            if t[i] - rest > rest_s:
                break
        else:
            rest = None
        i += 1
    return i


def track_video(path, *, diameter_m, roi=None, color=None, fps=None, scale_m_per_px=None, progress=None):
    """Track the ball in a video of a drop (see the module docstring).

    Parameters
    ----------
    path : str or Path
        the video
    diameter_m : float
        the ball's diameter [m]: its apparent diameter gives the scale
    roi : tuple or str or None
        ``(x, y, w, h)`` pixels of the full frame to search in
    color : str or tuple or None
        the ball's colour (see :func:`parse_color`); None learns it
    fps : float or None
        frame rate [Hz] overriding the container's time stamps (slow-motion videos)
    scale_m_per_px : float or None
        metres per pixel overriding the scale from the diameter
    progress : callable, optional
        ``progress(fraction, message)``

    Returns
    -------
    VideoTrack
    """
    cv2 = _cv2()
    path = str(path)
    if diameter_m is None and scale_m_per_px is None:
        raise UsageError(f"{path}: the scale of a video comes from the ball's diameter: give --ball or --diameter")
    if diameter_m is not None and not (math.isfinite(diameter_m) and diameter_m > 0):
        raise UsageError(f"--diameter must be a positive length in m, got {diameter_m:g}")
    if fps is not None and not (math.isfinite(fps) and fps > 0):
        raise UsageError(f"--fps must be a positive frame rate in Hz, got {fps:g}")
    if isinstance(roi, str):
        roi = parse_roi(roi)
    given_bgr = parse_color(color) if color is not None else None
    prog = _Progress(progress)
    frames, stamps, full, container_fps, factor, size = _read_pass1(cv2, path, roi, prog)
    n = len(frames)
    notes = [f"video: {size[1]}x{size[0]} px, {n} frames, {container_fps:.3f} fps (container)"
             + (f", region {roi[2]}x{roi[3]} at ({roi[0]}, {roi[1]})" if roi else "")]
    if n < 10:
        raise DataError(f"{path}: only {n} frame(s); a drop needs a video of at least a second")
    bg = _background(frames)
    bg_lab = _lab(cv2, bg)
    min_area = max(4, int(0.00005 * frames[0].shape[0] * frames[0].shape[1]))
    if given_bgr is not None:
        ball_lab = _lab(cv2, np.uint8([[given_bgr]]))[0, 0]
        probe = _coarse_track(cv2, frames[:: max(1, n // 60)], bg, ball_lab, None, lambda *a: None)
        ball_area = float(np.nanmedian(probe[2])) if np.any(np.isfinite(probe[2])) else float(min_area * 4)
        notes.append(f"ball colour: {color} (given)")
        seen = int(np.sum(np.isfinite(probe[2])))
    else:
        diffs = [_distance(cv2, _weighted(_lab(cv2, frames[i])), _weighted(bg_lab))
                 for i in np.linspace(0, n - 1, 8).round().astype(int)]
        thr = _foreground_threshold(np.concatenate([d.ravel() for d in diffs]))
        ball_lab, ball_area, seen = _learn_colour(cv2, frames, bg_lab, thr, min_area)
        if ball_lab is not None:
            b, g, r = (int(v) for v in cv2.cvtColor(np.uint8([[np.clip(ball_lab, 0, 255)]]),
                                                    cv2.COLOR_LAB2BGR)[0, 0])
            notes.append(f"ball colour: #{r:02x}{g:02x}{b:02x} (learnt from the moving blobs; --color to set it)")
    if ball_lab is None or seen < 5:
        raise DataError(f"{path}: no ball found (no compact object moving against the background in 5 frames or "
                        "more); give the ball's colour with --color and a region with --roi")
    coarse = _coarse_track(cv2, frames, bg, ball_lab, ball_area, prog)
    found = np.isfinite(coarse[0])
    if found.sum() < 5:
        raise DataError(f"{path}: the ball is found in only {int(found.sum())} frame(s); "
                        "give its colour with --color and a region with --roi")
    # full-size background from the kept frames
    keys = sorted(full)
    bgmed = _TiledMedian([full[k] for k in keys])
    diameter_small = 2.0 * math.sqrt(np.nanmedian(coarse[2]) / math.pi)
    row, col, area, edge = _refine(cv2, path, roi, factor, coarse, diameter_small, ball_lab, bgmed, prog, n)
    # quality
    area_ref = float(np.nanmedian(area))
    ratio = area / area_ref
    quality = np.where(np.isfinite(ratio), np.minimum(ratio, 1.0 / np.where(ratio > 0, ratio, np.inf)), 0.0)
    quality = np.where(edge, 0.5 * quality, quality)
    quality = np.nan_to_num(quality)
    # repeated frames (a frame-rate conversion): the small frame equals the one before
    mad = np.r_[np.inf, np.mean(np.abs(np.diff(frames.astype(np.int16), axis=0)), axis=(1, 2, 3))]
    typical = float(np.median(mad[1:]))
    repeated = mad < max(0.02, 0.15 * typical)
    if np.all(repeated[1:]):
        repeated[:] = False  # a still video: nothing is "repeated"
    # times
    t, timing_note = _frame_times(stamps, container_fps, fps, repeated)
    notes += timing_note
    # diameter and scale: the median over the good frames between the first and the last big move
    good = (quality >= MIN_QUALITY) & ~repeated & np.isfinite(row)
    if good.sum() < 5:
        raise DataError(f"{path}: the ball is measured well in only {int(good.sum())} frame(s); "
                        "give its colour with --color and a region with --roi")
    gi = np.flatnonzero(good)
    step = np.abs(np.diff(row[gi]))
    moving = gi[1:][step > 0.05 * math.sqrt(area_ref)]
    span = gi[(gi >= moving[0]) & (gi <= moving[-1])] if moving.size >= 3 else gi
    # the slowest half of those frames: the least motion blur (which widens the blob)
    speed = np.abs(np.gradient(row[span])) if span.size > 2 else np.zeros(span.size)
    slow = span[np.argsort(speed)[: max(3, span.size // 2)]]
    diameter_px = 2.0 * math.sqrt(float(np.median(area[slow])) / math.pi)
    if scale_m_per_px is not None:
        scale = float(scale_m_per_px)
        notes.append(f"scale: {scale * 1e3:.4g} mm/px (given); the ball looks {diameter_px:.1f} px wide")
    else:
        scale = diameter_m / diameter_px
        notes.append(f"scale: {scale * 1e3:.4g} mm/px from the ball's apparent diameter {diameter_px:.1f} px "
                     f"and its {diameter_m * 1e3:.4g} mm")
    # repeated frames
    if repeated.any():
        notes.append(f"{int(repeated.sum())} repeated frame(s) dropped (a frame identical to the one before: a "
                     f"frame-rate conversion; frames {_list(np.flatnonzero(repeated))})")
    lost = ~good & ~repeated
    result = _finish(path, t, row, col, quality, good, repeated, lost, scale, diameter_px, notes, n, size, fps,
                     container_fps, stamps)
    result.background = bg
    result.scale_down = factor
    prog(1.0, "done", force=True)
    return result


def _list(idx, most=8):
    s = ", ".join(str(int(i)) for i in idx[:most])
    return s + (", ..." if len(idx) > most else "")


def _frame_times(stamps, container_fps, fps, repeated):
    """Frame times from the container's stamps (checked), or from ``fps``."""
    n = stamps.size
    notes = []
    if fps is not None:
        return np.arange(n) / fps, [f"times from --fps {fps:g} Hz (container stamps ignored)"]
    nominal = 1.0 / container_fps if container_fps > 0 else None
    d = np.diff(stamps)
    ok = np.isfinite(stamps).all() and n > 1 and np.all(d > 0)
    if not ok or nominal is None:
        if nominal is None:
            raise DataError("the video has neither usable time stamps nor a frame rate: give --fps")
        # a few broken stamps at the end (decoder flush) are common: extrapolate them
        good = np.r_[True, np.isfinite(d) & (d > 0)]
        bad = np.flatnonzero(~good)
        if bad.size and bad[0] >= 0.9 * n:
            t = stamps.copy()
            for i in bad:
                t[i] = t[i - 1] + nominal
            for i in range(bad[0], n):
                if not t[i] > t[i - 1]:
                    t[i] = t[i - 1] + nominal
            notes.append(f"times from the container's stamps ({n - bad[0]} stamp(s) at the end extrapolated)")
            return t - t[0], notes
        return np.arange(n) * nominal, [f"times from the frame rate {container_fps:.3f} fps (the container's time "
                                        "stamps are not increasing)"]
    t = stamps - stamps[0]
    gaps = np.flatnonzero(d > 1.5 * np.median(d))
    notes.append("times from the container's time stamps")
    if gaps.size:
        missing = int(np.sum(np.round(d[gaps] / np.median(d)) - 1))
        notes.append(f"{missing} dropped frame(s): gaps in the time stamps after t = "
                     f"{', '.join(f'{t[g]:.3f}' for g in gaps[:6])} s (the times account for them)")
    return t, notes


def _finish(path, t, row, col, quality, good, repeated, lost, scale, diameter_px, notes, n, size, fps,
            container_fps, stamps):
    idx = np.flatnonzero(good)
    tt, rr = t[idx], row[idx]
    # a frame-rate conversion: stamps of the frames left, or the frames evenly spaced over the same span
    if repeated.any() and fps is None:
        keep_all = np.flatnonzero(~repeated)
        spaced = np.full(n, np.nan)
        rate = _source_rate(np.flatnonzero(repeated), n, container_fps if container_fps > 0 else 1 / np.median(
            np.diff(t)))
        spaced[keep_all] = t[keep_all[0]] + np.arange(keep_all.size) / rate
        res_stamp = _flight_residual(tt, rr)
        res_even = _flight_residual(spaced[idx], rr)
        if res_even < res_stamp:
            notes.append(f"the frames left are evenly spaced at {rate:.3f} fps (flight residual {res_even:.2f} px "
                         f"against {res_stamp:.2f} px with the container's stamps)")
            t = spaced
            tt = t[idx]
        else:
            notes.append(f"the frames left keep the container's stamps (flight residual {res_stamp:.2f} px, "
                         f"{res_even:.2f} px if evenly spaced)")
    release = detect_release_index(-rr)
    flights = [(i + release, c, r) for i, c, r in _flights(tt[release:], rr[release:])]
    crossings = _bounce_crossings(tt, flights)
    g_px = [2 * c[0] for i, c, _ in flights if i.size >= 5]
    g_meas = float(np.median(g_px)) * scale if g_px else float("nan")
    if crossings:
        contact_row = float(np.median([c[1] for c in crossings]))
        notes.append(f"floor: the ball's centre at contact is at row {contact_row:.1f} px (median of "
                     f"{len(crossings)} crossings of consecutive flight parabolas); heights are of the ball's "
                     "bottom above the floor, (row_c - row) x scale")
    else:
        contact_row = float(np.max(rr))
        notes.append("floor: fewer than two flights to cross; heights are of the ball's bottom above its lowest "
                     "tracked position")
    if math.isfinite(g_meas):
        ratio = g_meas / STANDARD_GRAVITY
        msg = f"check: the flights give g = {g_meas:.2f} m/s^2 with this scale and these times"
        if abs(ratio - 1) > G_TOLERANCE:
            k = 1.0 / math.sqrt(ratio) if ratio > 0 else float("nan")
            if ratio < 0.5 and math.isfinite(k):
                msg += (f" -- far from 9.81: a slow-motion video? the capture rate would be about "
                        f"{container_fps * k:.0f} fps (give --fps)")
            else:
                msg += (f" -- {abs(ratio - 1) * 100:.0f} % off 9.81: the ball's apparent size (perspective, blur, "
                        "--diameter) or the frame rate (--fps) is off")
        notes.append(msg)
    # the drop only: from the still segment before release to the rest on the floor
    noise = float(np.median([f[2] for f in flights])) if flights else 0.5
    start = 0
    if release > 0:
        still = np.abs(rr[:release] - rr[release - 1]) <= max(2.0, 4 * noise)
        moving = np.flatnonzero(~still)
        start = int(moving[-1]) + 1 if moving.size else 0
    end = _track_end(tt, rr, flights, contact_row, max(2.0, 4 * noise))
    if start > 0:
        notes.append(f"track starts at frame {idx[start]} (the ball moved before its still segment)")
    if end < rr.size:
        notes.append(f"track ends at frame {idx[end - 1]} (t = {tt[end - 1]:.3f} s), after the last bounce; "
                     f"{rr.size - end} later frame(s) left out (the ball rests, rolls or is picked up)")
    sel = idx[start:end]
    kept = np.zeros(n, dtype=bool)
    kept[sel] = True
    n_lost = int(np.sum(lost[sel[0]:sel[-1] + 1]))
    notes.append(f"ball measured in {good.sum()} of {n} frames; {sel.size} kept"
                 + (f"; {n_lost} frame(s) within the track left out (ball lost, hidden or cut by the edge; "
                    f"quality < {MIN_QUALITY})" if n_lost else ""))
    y_m = (contact_row - row[sel]) * scale
    x_m = (col[sel] - col[sel][0]) * scale
    traj = finish_trajectory(path, t[sel], y_m, sel + 1, notes, np.column_stack([y_m, x_m]))
    out = VideoTrack(t_s=t, row_px=row, col_px=col, quality=quality, kept=kept, repeated=repeated,
                     diameter_px=diameter_px, scale_m_per_px=scale, contact_row_px=contact_row,
                     g_measured=g_meas, fps=container_fps if fps is None else fps, size=size, notes=notes,
                     trajectory=traj)
    return out


def _source_rate(repeats, n, fps):
    """Frame rate of the source of a frame-rate conversion [Hz]: with one repeat every k frames
    (24 -> 30 fps: k = 5) it is ``fps (k - 1) / k``; otherwise ``fps`` times the share of frames left."""
    if repeats.size >= 2:
        d = np.diff(repeats)
        k = int(np.median(d))
        if k >= 2 and np.all(np.abs(d - k) <= 0):
            return fps * (k - 1) / k
    return fps * (n - repeats.size) / n


def _flight_residual(t, row):
    flights = _flights(t, row)
    if not flights:
        return float("inf")
    res = np.concatenate([row[i] - np.polyval(c, t[i]) for i, c, _ in flights])
    return float(np.sqrt(np.mean(res ** 2)))


def parse(path, *, diameter_m=None, roi=None, color=None, fs_hz=None, scale_m_per_px=None, progress=None,
          **_ignored):
    """The ``video`` reader: the ball's trajectory (see :func:`track_video`); ``fs_hz`` is ``--fps``."""
    return track_video(path, diameter_m=diameter_m, roi=roi, color=color, fps=fs_hz, scale_m_per_px=scale_m_per_px,
                       progress=progress).trajectory
