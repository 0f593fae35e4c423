"""Video recordings of a drop (the containers a phone writes, read with OpenCV): the ball's trajectory.

This module owns finding the ball in every frame (:func:`track_video`), the frame times
(container time stamps, repeated and dropped frames), the length scale (from g and the
ball's apparent diameter), the floor from the bounces, and the ``video`` reader of
:data:`vrcal.measurements.FORMATS` (:func:`parse`), which returns a
:class:`~vrcal.measurements.types.Trajectory`. OpenCV is the optional extra ``video``
(the optional extra ``video``, package opencv-python-headless).

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
4. **Centre and area.** In the full-size frame the ball's blob is where its presence (the
   projection on the ball's colour in CIELAB, lightness weighted down) exceeds 0.5, its
   holes (a specular highlight) filled (:func:`ball_blob`). Its coverage of each pixel
   (:func:`ball_coverage`) is 1 inside and, along its edge, the projection of ``(pixel -
   background)`` on ``(ball - background)`` in BGR, with ``ball`` the colour of the
   nearest inside pixels -- so a ball lit from above (lighter on top, darker below) weighs
   its halves alike, and a shadow beside it adds little. Where the ball's colour differs
   from the background's in more than lightness, the coverage is instead the background's
   share of each pixel (fitted on the background's and the ball's colours: shading scales
   only the ball's), also in the tails of a motion-blurred streak up to half the ball's
   travel in a frame interval (pass 1's centres) -- the tails only the ball's dark or lit
   rim passes over, which the blob cuts short. The centre is the centroid of the coverage
   and the area its sum: sub-pixel, and the centre of a blurred ball is the centre at
   mid-exposure (the streak is symmetric about it).
5. **Quality** (per frame, 0..1): the ball's area over its median area, inverted when
   larger, lowered when the blob touches the frame's edge. Frames below
   :data:`MIN_QUALITY` (ball lost, hidden by a hand, cut by the edge) are left out.

Times, scale, floor and the y axis
----------------------------------
* **Times** are the container's time stamps (phones write variable frame rates); a gap of
  more than 1.5 frame intervals is reported as dropped frames (the times stay right). A
  frame identical to the one before (a frame-rate conversion repeats frames) is dropped;
  then the frames left are timed both by their stamps and evenly spaced over the same
  span, and the timing whose flights are better parabolas is kept (``--fps`` overrides
  the container's rate, e.g. for a slow-motion video).
* **The bounces** (:func:`_flights`, :func:`fit_bounces`). A bounce is a lowest point of the
  path that stands out of the centres' noise (:func:`_bounces`: at a high frame rate a wiggle
  of the noise at an apex is no bounce). A gap in the frames (the ball out of the picture, or
  hidden) ends a piece of a flight; the pieces on either side are one flight when one path
  fits them (a ball rising out of the top of the picture: a note says so), else the gap ends
  the flight. The flights between bounces are fitted together
  as parabolas of one curvature that leave and reach one contact row, consecutive ones
  meeting there at the impact: the curvature in px/s² (g over the scale) and the centre's
  row at contact, each with its standard error. The fall from the hand is not in it.
* **Scale** [m/px] (:func:`choose_scale`): two measurements give it -- the flights'
  curvature with standard gravity and the frame clock, and ``diameter_m`` over the ball's
  apparent diameter (the median over the slower half of the flights' frames, uncertain by
  its spread and :data:`EDGE_PX`). When they agree they are averaged with inverse-variance
  weights (the flights usually dominate); when they disagree beyond 3 sigma and the flights
  tell g to 2 %, the scale is the flights' (a clock is trusted over an apparent size, which
  blur, shading, compression and the ball's distance change) and a note gives what the
  diameter would have implied. A g from the diameter's scale more than 25 % off standard
  gravity makes the frame rate itself suspect (a slow-motion video): the diameter's scale
  is kept and a warning names the capture rate that would fit (the ``video`` reader,
  :func:`parse`, which ``vrcal discover`` uses, stops there with it). ``scale_m_per_px`` overrides
  both. A scale from g cannot tell an effect that changes the flights' acceleration alike
  (buoyancy): a note says so.
* **Orientation.** ``rotate`` (``--rotate``) turns each frame clockwise before tracking. A
  ball whose flights run along the columns, or curve upwards, is a video turned without a
  rotation tag: an error names the ``--rotate`` that sets it upright (:func:`_upright_turn`).
* **Floor and y axis.** Image rows grow downwards; heights are ``(row_c - row) * scale``,
  where ``row_c`` is the centre's row at contact from the bounce fit. So ``y`` is the
  height of the ball's bottom above the floor (the centre at contact is one radius above it).
* **The drop only.** The track starts at the still segment before release and ends with
  the last flight resolved (at least four frames): hops too short to resolve, the ball at
  rest or rolling, and a hand picking it up are no flights. A fall from the hand that is
  no free fall with the bounces' g (air drag allowed) -- a hand that still touches the
  ball, a ball held nearer the camera than it bounces -- is left out with a note: the
  track then starts at the first apex. A frame at a bounce whose ball lies above both
  flights' parabolas spans the impact (its blurred image averages the path down and up)
  and is left out.
"""

from __future__ import annotations

import contextlib
import math
import os
import time
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from vrcal.errors import DataError, UsageError, install_hint
from vrcal.measurements.cleanup import detect_release_index, prominent_minima, third_difference_sigma
from vrcal.measurements.plausibility import standard_frame_rate
from vrcal.measurements.trajectory import MIN_TRAJECTORY_SAMPLES, finish_trajectory
from vrcal.model.restitution import STANDARD_GRAVITY_M_PER_S2

#: One-line hint when OpenCV is missing.
VIDEO_HINT = f"reading video needs OpenCV: {install_hint('opencv-python-headless', 'video')}"

#: File name endings read as video.
VIDEO_EXTENSIONS = (".mp4", ".mov", ".m4v", ".avi", ".mkv", ".webm", ".3gp", ".mts", ".m2ts", ".wmv", ".mpg",
                    ".mpeg", ".ogv")

MIN_QUALITY = 0.6          #: frames with a lower quality are left out
STANDARD_GRAVITY = STANDARD_GRAVITY_M_PER_S2  #: the default g [m/s^2] (one g for every command)
LOW_RES_WIDTH = 320        #: width of the pass-1 copies [px] (at least)
BACKGROUND_FRAMES = 24     #: frames in the background median

#: Named colours for ``--color`` (B, G, R).
COLORS = {
    "red": (40, 40, 200), "green": (50, 150, 50), "blue": (180, 80, 30), "yellow": (40, 210, 230),
    "orange": (30, 120, 240), "white": (235, 235, 235), "black": (25, 25, 25), "pink": (170, 110, 240),
    "purple": (140, 50, 110), "cyan": (200, 200, 40),
}


def detect(head, path):
    """An MP4/MOV/3GP (``ftyp``), AVI, Matroska/WebM file, or a video extension. The reader asks the sound
    format first (:data:`vrcal.measurements.reader.FORMATS`), which takes an MP4 of sound alone (its track
    list read once); ``--format video`` on one is refused by :func:`track_video`."""
    if head[4:8] == b"ftyp":
        return True
    if head[:4] == b"RIFF" and head[8:12] == b"AVI ":
        return True
    if head[:4] == b"\x1a\x45\xdf\xa3":
        return True
    return Path(path).suffix.lower() in VIDEO_EXTENSIONS


def _sound_only(head, path):
    """True for an MP4/3GP/MOV file (``head``: its first bytes) that holds sound and no video (a phone's
    ``.m4a`` or ``.3gp`` recording: :func:`vrcal.measurements.sound.detect`)."""
    from vrcal.measurements import sound

    return head[4:8] == b"ftyp" and sound.detect(head, path)


def _cv2():
    """OpenCV, with its own log and FFmpeg's silenced (a corrupt file's 'moov atom not found' would come
    before vrcal's one-line error)."""
    os.environ.setdefault("OPENCV_FFMPEG_LOGLEVEL", "-8")   # AV_LOG_QUIET, read when FFmpeg first opens a file
    os.environ.setdefault("OPENCV_LOG_LEVEL", "OFF")
    try:
        import cv2
    except ImportError:
        raise UsageError(VIDEO_HINT) from None
    with contextlib.suppress(AttributeError):
        cv2.utils.logging.setLogLevel(cv2.utils.logging.LOG_LEVEL_SILENT)
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
    diameter_px: float              # the ball's apparent diameter (median over the slower flight frames)
    scale_m_per_px: float           # the scale used (see choose_scale)
    contact_row_px: float           # the centre's row at contact (the floor)
    g_measured: float               # g from the flights with the diameter's scale (or the given one) [m/s^2]
    fps: float
    size: tuple
    notes: list = field(default_factory=list)
    trajectory: object = None
    background: np.ndarray = None   # small copy of the background (for figures)
    bounces: object = None          # BounceFit of the flights between bounces, or None
    systematic_m: float = 0.0       # the centres' systematic uncertainty in heights [m] (CENTRE_SYSTEMATIC_PX)
    scale_down: float = 1.0
    rate_suspect: str = ""          # why the frame rate is suspect (a slow-motion video), "" when it is not


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


#: ``--rotate``: degrees the picture is turned clockwise before tracking -> OpenCV's code.
ROTATIONS = {0: None, 90: "ROTATE_90_CLOCKWISE", 180: "ROTATE_180", 270: "ROTATE_90_COUNTERCLOCKWISE"}


def _view(cv2, frame, rotate, roi):
    """The frame as tracked: turned ``rotate`` degrees clockwise, then cut to ``roi``."""
    if rotate:
        frame = cv2.rotate(frame, getattr(cv2, ROTATIONS[rotate]))
    if roi is not None:
        x, y, w, h = roi
        frame = frame[y:y + h, x:x + w]
    return frame


def _read_pass1(cv2, path, roi, prog, rotate=0):
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
        whole = frame.shape
        frame = _view(cv2, frame, rotate, roi)
        if frame.shape[0] < 8 or frame.shape[1] < 8:
            turned = f" (turned {rotate} degrees)" if rotate else ""
            raise UsageError(f"--roi {roi} lies outside the {whole[1]}x{whole[0]} video{turned}")
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
    """Mean CIELAB colour and area (small frames) of the ball: the compact moving blob colour seen in most frames.

    A blob's colour is that of its core, the half of its pixels farthest from the background: a fast ball's
    motion blur (the bounces near the floor of a short clip) mixes its edge with the background, whose
    colour would otherwise shift the learnt one off the ball's (a clip of bounces near a white floor then
    found the ball in one frame of 30)."""
    samples = []  # (frame, area, lab colour)
    idx = np.unique(np.linspace(0, len(frames) - 1, min(len(frames), 60)).round().astype(int))
    for i in idx:
        lab = _lab(cv2, frames[i])
        diff = _distance(cv2, _weighted(lab), _weighted(bg_lab))
        mask = diff > thresholds
        for k, a, x, y, w, h, c, labels in _blobs(cv2, mask, min_area):
            inside = labels == k
            core = inside & (diff >= np.median(diff[inside]))
            colour = np.median(lab[core], axis=0)
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


def ball_coverage(cv2, crop, background, blob, travel_px=None):
    """Coverage (0..1) of the ball in each pixel of a crop (see the module docstring, step 4).

    ``blob`` (uint8 0/1) is the ball's blob (:func:`ball_blob`); ``travel_px`` (rows, columns)
    [px] the ball's travel in one frame interval, which bounds a motion-blurred streak (None:
    unknown, no streak beyond the edge band). Where the ball's colour differs from the
    background's in more than lightness, the coverage is :func:`_shading_free_coverage`: the
    background's share of each pixel, which the ball's shading does not change, over the edge
    band (the blob's edge, 2 px in and 3 px out) and the streak's tails beyond it along the
    travel; the interior farther in than a streak's ramp is 1 (a seam or a highlight there is
    ball), and a band pixel off that model falls back to the following. Otherwise (a grey ball
    on a grey wall) the interior (the blob eroded by 2 px) is 1 and a pixel of the edge band
    mixes ball and background, ``pixel = background + f (ball - background)``, where ``ball``
    is the colour of the nearest interior pixels (their Gaussian-weighted mean, sigma 3 px):
    ``f`` is the projection on ``(ball - background)`` in BGR, clipped to 0..1; pixels far off
    that line (a hand) count 0. Either way a ball lit from above (lighter on top, darker
    below) weighs its halves alike: the centroid of the coverage is the centre of the
    silhouette (at mid-exposure for a blurred ball), and its sum the area. The band is narrow,
    and the tails reach only along the travel, so that a shadow beside the ball (which a dark
    ball's colour cannot tell from the ball's edge) adds little.
    """
    ys, xs = np.nonzero(blob)
    streak_x, streak_y = max(0, int(np.ptp(xs)) - int(np.ptp(ys))), max(0, int(np.ptp(ys)) - int(np.ptp(xs)))
    core = cv2.erode(blob, cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (5 + streak_x, 5 + streak_y)))
    if core.sum() < 4:
        core = blob
    img = crop.astype(np.float32)
    back = background.astype(np.float32)
    m = core.astype(np.float32)
    w = cv2.GaussianBlur(m, (0, 0), 3.0)
    local = cv2.GaussianBlur(img * m[..., None], (0, 0), 3.0) / np.maximum(w, 1e-6)[..., None]
    d = img - back
    c = local - back
    denom = np.maximum(np.sum(c * c, axis=2), 100.0)
    f = np.sum(d * c, axis=2) / denom
    perp = np.linalg.norm(d - f[..., None] * c, axis=2)
    f[perp > 0.6 * np.sqrt(denom) + 8.0] = 0.0
    band = cv2.dilate(blob, cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (7 + streak_x, 7 + streak_y)))
    f = np.where((band > 0) & (w > 1e-3), np.clip(f, 0.0, 1.0), 0.0)
    f[core > 0] = 1.0
    shaded = _shading_free_coverage(cv2, img, back, core, blob, band, travel_px)
    return f if shaded is None else np.where(np.isnan(shaded), f, shaded)


#: Least sine of the angle between the ball's colour and the background's (BGR) for the coverage
#: that shading does not change (:func:`_shading_free_coverage`); below it the two hardly differ
#: but in lightness, and the ball's local colour is used.
CHROMA_SIN = 0.15
#: Least coverage counted in a blurred streak's tails beyond the edge band (noise is not ball).
TAIL_COVERAGE = 0.04


def _shading_free_coverage(cv2, img, back, core, blob, band, travel_px=None):
    """Coverage (0..1) that the ball's shading does not change, or None where it cannot be told.

    Shading scales the ball's colour (``ball = k c``, ``k`` brighter on top of a ball lit from
    above), so a pixel is ``(1 - a) background + a k c``: fitted on the two colours (BGR, per
    pixel), the background's share gives the coverage ``a`` whatever ``k`` -- also in the tails of
    a motion-blurred streak, which only the ball's dark (or lit) rim passes over, and which the
    blob (presence > 0.5) cuts short. ``c`` is the colour of the core's most ball-like pixels
    (farthest in colour from the background: in a blurred streak the middle mixes in
    background); a compressed video's duller colours are scaled so that the blob's deepest
    pixels are covered. Counted are the edge band and, beyond it along the travel
    (:func:`_streak_kernel`), the pixels whose coverage is at least :data:`TAIL_COVERAGE`,
    each only where its implied ball brightness ``k`` is the ball's (a shadow, ``k`` about 0,
    or a hand off both colours, count 0; a band pixel off the model is NaN, for the caller's
    local colour); the interior farther in than the travel's half is 1. None when the
    ball's colour is too near the background's (sine below :data:`CHROMA_SIN`) in most of the
    core's surroundings: lightness alone cannot tell shading from coverage.
    """
    P = img[core > 0]
    B = back[core > 0]
    u = P / np.maximum(np.linalg.norm(P, axis=1, keepdims=True), 1.0)
    b = B / np.maximum(np.linalg.norm(B, axis=1, keepdims=True), 1.0)
    dist = np.linalg.norm(u - b, axis=1)
    top = dist >= np.percentile(dist, 90)
    chat = P[top].sum(axis=0)                   # brighter pixels weigh more (less rounded)
    chat /= max(float(np.linalg.norm(chat)), 1e-6)
    bc = back @ chat
    bperp = back - bc[..., None] * chat
    bb = np.sum(bperp * bperp, axis=2)
    reliable = bb > (CHROMA_SIN ** 2) * np.maximum(np.sum(back * back, axis=2), 1.0)
    if np.mean(reliable[core > 0]) < 0.9:
        return None
    pc = img @ chat
    pperp = img - pc[..., None] * chat
    beta = np.sum(pperp * bperp, axis=2) / np.maximum(bb, 1e-6)
    gamma = pc - beta * bc                      # a k: the ball's share along its colour
    # a compressed video's colours are a little duller than the ball's most saturated pixels: the
    # core's best-covered pixels (the ball fully over them) are coverage 1
    depth = cv2.distanceTransform(blob, cv2.DIST_L2, 3)
    full = np.percentile(1.0 - beta[(core > 0) & (depth >= 0.8 * depth.max())], 75)
    a = (1.0 - beta) / float(np.clip(full, 0.8, 1.25))
    resid = np.linalg.norm(pperp - beta[..., None] * bperp, axis=2)
    k = gamma / np.maximum(a, 1e-3)
    k_hi = np.percentile(k[core > 0], 98)
    fits = reliable & (resid < 0.3 * np.sqrt(bb) + 8.0) & (k >= 0.1 * k_hi) & (k <= 1.4 * k_hi)
    kernel = _streak_kernel(cv2, travel_px)
    tail = (cv2.dilate(band, kernel) > 0) & (band == 0) & (a >= TAIL_COVERAGE)
    f = np.where(((band > 0) | tail) & fits, np.clip(a, 0.0, 1.0), 0.0)
    f[(band > 0) & ~fits] = np.nan            # off the model (a compressed edge): the local colour's
    f[cv2.erode(core, kernel) > 0] = 1.0      # farther inside than a streak's ramp: covered (a seam, a highlight)
    return f


def _streak_kernel(cv2, travel_px):
    """Structuring element (uint8) of a motion-blurred streak's reach: a line of half the ball's travel
    in one frame interval, ``travel_px`` = (rows, columns) [px], either way about its centre (an
    exposure lasts at most a frame interval, centred on the ball's centre), 3 px thick; a 3x3
    square when the travel is unknown."""
    if travel_px is None or not np.all(np.isfinite(travel_px)):
        return np.ones((3, 3), np.uint8)
    dy, dx = 0.5 * float(travel_px[0]), 0.5 * float(travel_px[1])
    hy, hx = int(math.ceil(abs(dy))) + 1, int(math.ceil(abs(dx))) + 1
    kernel = np.zeros((2 * hy + 1, 2 * hx + 1), np.uint8)
    cv2.line(kernel, (int(round(hx - dx)), int(round(hy - dy))), (int(round(hx + dx)), int(round(hy + dy))), 1, 1)
    return cv2.dilate(kernel, np.ones((3, 3), np.uint8))


def ball_blob(cv2, presence):
    """The ball's blob (uint8 0/1) in a crop: the largest region of presence > 0.5, opened
    (thin attachments such as a shadow's edge cut off), its holes (a specular highlight)
    filled; None when there is none."""
    mask = (presence > 0.5).astype(np.uint8)
    opened = cv2.morphologyEx(mask, cv2.MORPH_OPEN, cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (3, 3)))
    if opened.sum() >= 4:
        mask = opened
    k, labels, stats, _ = cv2.connectedComponentsWithStats(mask, connectivity=8)
    if k < 2:
        return None, None
    j = 1 + int(np.argmax(stats[1:, 4]))
    blob = (labels == j).astype(np.uint8)
    contours, _ = cv2.findContours(blob, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_NONE)
    filled = np.zeros_like(blob)
    cv2.drawContours(filled, contours, -1, 1, thickness=cv2.FILLED)
    return filled, stats[j]


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


def _travel(rows, cols, i, factor):
    """The ball's travel in one frame interval at frame ``i`` [px at full size], (rows, columns): from
    pass 1's centres of the nearest frames before and after it where the ball is elsewhere (a
    repeated frame gets the travel of the frame it repeats); None when unknown."""
    here = (rows[i], cols[i])

    def nearest(idx):
        return next((j for j in idx if np.isfinite(rows[j]) and (rows[j], cols[j]) != here), None)

    a, b = nearest(range(i - 1, -1, -1)), nearest(range(i + 1, len(rows)))
    if a is None and b is None:
        return None
    a, b = (i, b) if a is None else (a, i) if b is None else (a, b)
    return ((rows[b] - rows[a]) * factor / (b - a), (cols[b] - cols[a]) * factor / (b - a))


def _refine(cv2, path, roi, factor, coarse, diameter_small, ball_lab, bgmed, prog, n, rotate=0):
    """Pass 2: alpha-weighted centroid at full size around each coarse detection."""
    rows, cols, areas = coarse
    row_f, col_f = np.full(n, np.nan), np.full(n, np.nan)
    area_f, edge, blur_f = np.full(n, np.nan), np.zeros(n, dtype=bool), np.full(n, np.nan)
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
        frame = _view(cv2, frame, rotate, roi)
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
        blob, stat = ball_blob(cv2, presence)
        if blob is not None:
            travel = _travel(rows, cols, i, factor)
            a = ball_coverage(cv2, crop, back, blob, travel)
            total = float(a.sum())
            if total > 0:
                yy, xx = np.mgrid[y0:y1, x0:x1]
                row_f[i] = float((a * yy).sum() / total)
                col_f[i] = float((a * xx).sum() / total)
                area_f[i] = total
                blur_f[i] = streak_length(a, yy - row_f[i], xx - col_f[i], travel)
                bx, by, bw, bh = (int(v) for v in stat[:4])
                edge[i] = (y0 + by <= 0) or (x0 + bx <= 0) or (y0 + by + bh >= H) or (x0 + bx + bw >= W)
        i += 1
        prog(0.55 + 0.4 * i / n, f"measuring the ball {i}/{n}")
    cap.release()
    return row_f, col_f, area_f, edge, blur_f


def streak_length(coverage, dy, dx, travel_px):
    """Length [px] of a ball's motion-blurred streak from its coverage: a disc smeared by a box of length L
    along the travel has the variance L²/12 along it beyond the variance across it (both r²/4 for the disc
    alone), so L = sqrt(12 (var_along - var_across)), 0 when not positive.

    Parameters
    ----------
    coverage : ndarray
        the ball's coverage (0..1) in each pixel (:func:`ball_coverage`)
    dy, dx : ndarray
        each pixel's row and column less the coverage's centroid [px]
    travel_px : tuple or None
        the ball's travel in one frame interval (rows, columns) [px]; None or nil: along the rows
    """
    ty, tx = (1.0, 0.0) if travel_px is None or not np.all(np.isfinite(travel_px)) else travel_px
    norm = math.hypot(ty, tx)
    uy, ux = (ty / norm, tx / norm) if norm > 0 else (1.0, 0.0)
    total = float(coverage.sum())
    along = float((coverage * (dy * uy + dx * ux) ** 2).sum()) / total
    across = float((coverage * (dx * uy - dy * ux) ** 2).sum()) / total
    return math.sqrt(max(12.0 * (along - across), 0.0))


#: Least prominence of a bounce in the rows: this many times the rows' noise from frame to frame
#: (:func:`vrcal.measurements.cleanup.third_difference_sigma`), and at least :data:`BOUNCE_MIN_PX`.
#: At a high frame rate the ball barely moves between frames near an apex, and a wiggle of the
#: noise there is a local lowest point like a bounce; its prominence is about the noise's.
BOUNCE_NOISE = 8.0
BOUNCE_MIN_PX = 0.5


def _bounces(row, noise):
    """Indices of the bounces in the rows of the frames kept (rows grow downwards): the lowest
    points of the path (largest rows) whose prominence is at least :data:`BOUNCE_NOISE` times the
    rows' noise ``noise`` [px] and :data:`BOUNCE_MIN_PX` -- and the stops: a fall faster than that
    a frame that halts (a ball that lands and stays). Returns a sorted array of int."""
    least = max(BOUNCE_MIN_PX, BOUNCE_NOISE * noise)
    lowest = prominent_minima(-row, least)
    fall = np.diff(row)
    stops = np.flatnonzero((fall[:-1] > max(1.0, least)) & (fall[1:] < 0.2 * fall[:-1])) + 1
    return np.union1d(lowest, stops).astype(int)


def _one_flight(t, row, a, b, noise):
    """Are the pieces ``a`` and ``b`` (frame indices, ``b`` after ``a``, the ball unseen between
    them) parts of one flight? A cubic through both (a parabola skewed by air drag) must fit
    them within four times the noise (at least :data:`BOUNCE_MIN_PX` RMS), curve downwards as a
    flight does (rows grow downwards), and turn up nowhere between them (no bounce unseen)."""
    idx = np.r_[a, b]
    if idx.size < 5:
        return False
    tt = t[idx] - t[a[-1]]
    coef = np.polyfit(tt, row[idx], 3)
    rms = float(np.sqrt(np.mean((row[idx] - np.polyval(coef, tt)) ** 2)))
    if rms > max(BOUNCE_MIN_PX, 4.0 * noise) or np.polyfit(tt, row[idx], 2)[0] <= 0:
        return False
    d1, d2 = np.polyder(coef), np.polyder(coef, 2)
    turns = [r.real for r in np.roots(d1) if abs(r.imag) < 1e-12 and 0.0 <= r.real <= tt[a.size]]
    return not any(np.polyval(d2, r) < 0 for r in turns)  # a lowest point of the path (a bounce) unseen


def _flights(t, row, min_frames=4):
    """Parabolas ``row = a t^2 + b t + c`` of the flights between bounces.

    Bounces are the lowest points of the path (:func:`_bounces`). A time gap of more than 3.5
    frame intervals (the ball unseen: out of the picture, hidden, or lost) ends a piece of a
    flight; two pieces on either side of a gap are one flight when one path fits them
    (:func:`_one_flight`: a ball that rises out of the top of the picture and falls back in),
    else the gap ends the flight. Returns ``[(indices, coeffs, rms)]`` for flights with at least
    ``min_frames`` frames; the frames at each bounce are left out of both flights (the ball may
    be in contact).
    """
    dt = np.diff(t)
    if dt.size == 0:
        return []
    step = float(np.median(dt))
    noise = third_difference_sigma(t, row) or 0.0
    bounce = set(_bounces(row, noise).tolist())
    gaps = set((np.flatnonzero(dt > 3.5 * step) + 1).tolist())  # a gap without the ball ends a piece
    bounds = [-1] + sorted(bounce | gaps) + [row.size]
    pieces = []  # [indices, joined to the piece before across a gap]
    for a, b in zip(bounds[:-1], bounds[1:]):
        start = a if a in gaps and a not in bounce else a + 1
        idx = np.arange(start, b)
        if idx.size == 0:
            continue
        if pieces and start in gaps and start not in bounce and pieces[-1][0][-1] == start - 1 \
                and _one_flight(t, row, pieces[-1][0], idx, noise):
            pieces[-1][0] = np.r_[pieces[-1][0], idx]
            continue
        pieces.append([idx])
    out = []
    for (idx,) in pieces:
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


def _unseen_notes(t, row, flights, diameter_px):
    """Notes on the gaps within a flight (:func:`_flights` joined the pieces on either side): where
    the ball went out of sight -- out of the top of the picture when it was within a diameter and
    a half of the top edge on either side of the gap."""
    out = []
    step = float(np.median(np.diff(t))) if t.size > 1 else 0.0
    for idx, _, _ in flights:
        for k in np.flatnonzero(np.diff(t[idx]) > 3.5 * step):
            a, b = idx[k], idx[k + 1]
            top = max(row[a], row[b]) < 1.5 * diameter_px
            where = "out of the top of the picture" if top else "out of sight"
            out.append(f"the ball goes {where} at t = {t[a]:.3f} s and comes back at t = {t[b]:.3f} s: one "
                       f"flight{' (its top unseen)' if top else ''}, fitted through the frames on either side -- a "
                       "gap, not a bounce")
    return out


def _upright_turn(t, row, col):
    """Degrees (90, 180, 270) to turn the picture clockwise so that the ball falls down the
    picture, when it does not as it is (a video filmed sideways or upside down, without a
    rotation tag), else 0. A flight here is one of :func:`_flights` that its parabola fits to
    within five times the noise (at least a pixel RMS): the lowest points of the path read along
    a wrong direction cut V-shaped pieces, which fit no parabola. The picture is taken as turned
    when the rows as they are give fewer than two flights and the path read along another
    direction -- the columns (the ball falls towards the right edge: 90, the left: 270) or the
    rows upside down (180) -- gives three or more: a fall and two flights between bounces."""
    if t.size < 8:
        return 0

    def flights(series):
        limit = max(1.0, 5.0 * (third_difference_sigma(t, series) or 0.0))
        return sum(rms <= limit for _, _, rms in _flights(t, series))

    if flights(row) >= 2:
        return 0
    counts = {turn: flights(series) for turn, series in ((90, col), (270, -col), (180, -row))}
    turn = max(counts, key=counts.get)
    return turn if counts[turn] >= 3 else 0


def _starts_with_fall(t, flights):
    """Is the first flight the fall from the hand? So when it starts at its top: the vertex of its
    parabola lies no later than a quarter into its frames (a ball released from rest, or one that
    enters the picture falling). A first flight that rises first starts at a bounce: the fall was
    too short to be a flight (fewer than four frames), or unseen."""
    if not flights:
        return False
    idx, coef, _ = flights[0]
    t0, t1 = t[idx[0]], t[idx[-1]]
    return -coef[1] / (2.0 * coef[0]) <= t0 + 0.25 * (t1 - t0)


def _consecutive(t, i1, i2):
    """Are two flights (frame indices, ``i2`` after ``i1``) consecutive, one impact between them?
    So when the ball is unseen between them for less than half the shorter flight's span: an
    unseen flight between them would last longer (the flights of a bounce sequence shrink by a
    steady ratio). The frames at a bounce, in neither flight, count as unseen."""
    unseen = t[i2[0]] - t[i1[-1]]
    return unseen < 0.5 * min(t[i1[-1]] - t[i1[0]], t[i2[-1]] - t[i2[0]])


def _bounce_crossings(t, flights):
    """(time, row) of the crossing of each pair of consecutive flight parabolas between their frames."""
    out = []
    for (i1, c1, _), (i2, c2, _) in zip(flights[:-1], flights[1:]):
        if not _consecutive(t, i1, i2):
            continue
        t_lo, t_hi = t[i1[-1]], t[i2[0]]
        roots = np.roots(np.asarray(c1) - np.asarray(c2))
        roots = roots[np.isreal(roots)].real
        inside = roots[(roots >= t_lo - 1e-9) & (roots <= t_hi + 1e-9)]
        if inside.size:
            tc = float(inside[0])
            out.append((tc, float(np.polyval(c1, tc))))
    return out


def _track_end(flights, n):
    """One past the last frame of the drop: the last frame of the last flight fitted. What
    follows -- a hop too short to resolve as a flight (fewer than four frames), the ball at
    rest or rolling (a ball with a constant epsilon bounces ever lower and comes to rest at a
    finite time; the frames after the last resolved flight tell little and mislead a model
    that must bounce on), a hand picking it up -- is left out."""
    return int(flights[-1][0][-1]) + 1 if flights else n


def _fall_misfit_px(t, row, fall, curvature):
    """RMS [px] of the fall from the hand about the best fall from rest with the bounces' g
    (``row = row_0 + a tau^2``, ``a`` = ``curvature``) and any quadratic air drag:
    ``row = row_0 + ln cosh(tau sqrt(2 a k)) / k``, ``tau = t - t_release``, fitted over
    ``row_0``, ``t_release`` and ``k >= 0`` [1/px]."""
    from scipy.optimize import least_squares

    tt, rr = t[fall], row[fall]
    g = 2.0 * curvature

    def model(p):
        r0, tr, k = p
        tau = np.maximum(tt - tr, 0.0)
        if k <= 1e-12:
            return r0 + 0.5 * g * tau ** 2
        x = tau * math.sqrt(g * k)
        return r0 + (np.logaddexp(x, -x) - math.log(2.0)) / k

    tr0 = tt[0] - math.sqrt(max(rr[1] - rr[0], 0.0) / max(curvature, 1e-9)) if rr.size > 1 else tt[0]
    r00 = rr[0] - curvature * (tt[0] - tr0) ** 2
    span = max(float(np.ptp(rr)), 1.0)
    sol = least_squares(lambda p: model(p) - rr, [r00, tr0, 0.1 / span],
                        bounds=([-np.inf, -np.inf, 0.0], [np.inf, np.inf, np.inf]),
                        x_scale=[1.0, 0.01, 1.0 / span])
    return float(np.sqrt(np.mean(sol.fun ** 2)))


def track_video(path, *, diameter_m, roi=None, color=None, fps=None, scale_m_per_px=None, progress=None,
                g_m_per_s2=STANDARD_GRAVITY, rotate=0):
    """Track the ball in a video of a drop (see the module docstring).

    Parameters
    ----------
    path : str or Path
        the video
    diameter_m : float or None
        the ball's diameter [m]: its apparent diameter gives a scale; without it (and without
        ``scale_m_per_px``) the scale is the flights' with g alone (:func:`choose_scale`)
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
    g_m_per_s2 : float
        the local gravitational acceleration [m/s^2] (default standard gravity): the flights'
        curvature with it gives a scale (:func:`choose_scale`)
    rotate : {0, 90, 180, 270}
        degrees to turn the picture clockwise before tracking (a video filmed sideways without a
        rotation tag; a tagged one OpenCV turns upright itself); ``roi`` is in the turned picture

    Returns
    -------
    VideoTrack

    Raises
    ------
    DataError
        no ball, too few frames; or a ball whose flights run across the picture or upwards (a
        video turned without a tag): the message names the ``rotate`` that turns it upright
    """
    path = str(path)
    try:
        with open(path, "rb") as fh:
            head = fh.read(16)
    except OSError:
        head = b""   # _open names the problem
    if _sound_only(head, path):
        raise DataError(f"{path}: a sound recording (no video track in it): read its impact times as sound "
                        "(leave out --format video, or give --format sound)")
    cv2 = _cv2()
    if diameter_m is not None and not (math.isfinite(diameter_m) and diameter_m > 0):
        raise UsageError(f"--diameter must be a positive length in m, got {diameter_m:g}")
    if fps is not None and not (math.isfinite(fps) and fps > 0):
        raise UsageError(f"--fps must be a positive frame rate in Hz, got {fps:g}")
    if isinstance(roi, str):
        roi = parse_roi(roi)
    rotate = int(rotate or 0)
    if rotate not in ROTATIONS:
        raise UsageError(f"--rotate {rotate}: give 0, 90, 180 or 270 (degrees clockwise)")
    given_bgr = parse_color(color) if color is not None else None
    prog = _Progress(progress)
    frames, stamps, full, container_fps, factor, size = _read_pass1(cv2, path, roi, prog, rotate)
    n = len(frames)
    notes = [f"video: {size[1]}x{size[0]} px, {n} frames, {container_fps:.3f} fps (container)"
             + (f", turned {rotate} degrees clockwise (--rotate)" if rotate else "")
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
    span = n / container_fps if container_fps > 0 else float("inf")
    remedy = (f"the video is only {span:.1f} s long: film the whole drop and some bounces, or give the ball's "
              "colour with --color and a region with --roi" if span < MIN_VIDEO_S else
              "give its colour with --color and a region with --roi")
    if found.sum() < 5:
        raise DataError(f"{path}: the ball is found in only {int(found.sum())} frame(s) of {n}; {remedy}")
    # full-size background from the kept frames
    keys = sorted(full)
    bgmed = _TiledMedian([full[k] for k in keys])
    diameter_small = 2.0 * math.sqrt(np.nanmedian(coarse[2]) / math.pi)
    row, col, area, edge, blur = _refine(cv2, path, roi, factor, coarse, diameter_small, ball_lab, bgmed, prog, n,
                                         rotate)
    # quality
    area_ref = float(np.nanmedian(area))
    ratio = area / area_ref
    quality = np.where(np.isfinite(ratio), np.minimum(ratio, 1.0 / np.where(ratio > 0, ratio, np.inf)), 0.0)
    quality = np.where(edge, 0.5 * quality, quality)
    quality = np.nan_to_num(quality)
    # repeated frames (a frame-rate conversion): the small frame equals the one before, while the
    # ones before and after it changed (a still scene -- a noise-free video with the ball at rest or
    # out of view -- repeats nothing)
    mad = np.r_[np.inf, np.mean(np.abs(np.diff(frames.astype(np.int16), axis=0)), axis=(1, 2, 3)), np.inf]
    typical = float(np.median(mad[1:-1]))
    same = mad < max(0.02, 0.15 * typical)
    repeated = np.r_[False, same[1:-1] & ~same[:-2] & ~same[2:]]
    # ... and the ball's centre is the same to the last bit (a slow ball in a noise-free video
    # can leave the small copy unchanged, not the full frame)
    repeated[1:] &= (row[1:] == row[:-1]) & (col[1:] == col[:-1])
    # times
    t, timing_note = _frame_times(stamps, container_fps, fps, repeated)
    notes += timing_note
    good = (quality >= MIN_QUALITY) & ~repeated & np.isfinite(row)
    if good.sum() < 5:
        raise DataError(f"{path}: the ball is measured well in only {int(good.sum())} frame(s) of {n}; {remedy}")
    # repeated frames
    if repeated.any():
        notes.append(f"{int(repeated.sum())} repeated frame(s) dropped (a frame identical to the one before: a "
                     f"frame-rate conversion; frames {_list(np.flatnonzero(repeated))})")
    lost = ~good & ~repeated
    turn = _upright_turn(t[good], row[good], col[good])
    if turn:
        total = (rotate + turn) % 360
        fix = (f"give --rotate {total} (turns the picture {total} degrees clockwise before tracking)" if total else
               "track it without --rotate")
        turned = f" (as turned by --rotate {rotate})" if rotate else ""
        raise DataError(f"{path}: " + (
            f"the ball's flights curve upwards{turned}: is the video upside down? {fix.capitalize()}" if turn == 180
            else f"the ball moves across the picture{turned}, not up and down (it falls towards the "
            f"{'right' if turn == 90 else 'left'} edge): is the video rotated? {fix.capitalize()}"))
    bottom_px = roi[1] + roi[3] if roi else size[0]
    result = _finish(path, t, row, col, area, quality, good, repeated, lost, notes, n, size, fps, container_fps,
                     diameter_m, scale_m_per_px, g_m_per_s2, bottom_px, blur)
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


#: A ball found in fewer than this share of a video's frames barely stands out from the background: its
#: apparent size, not the frame rate, is then the suspect when the two disagree (:func:`choose_scale`).
FOUND_WELL = 0.5

#: A video shorter than this [s] cannot hold a drop and some bounces (a 0.5 m drop and its bounces last 2-3 s).
MIN_VIDEO_S = 2.0


def _too_few_frames(path, sel, good, n, t, row, diameter_px, bottom_px):
    """The one-line refusal of a track with fewer frames kept than a trajectory needs, with its cause:
    the floor below the picture (the ball reaches its bottom edge), a clip too short for a drop, or a
    ball measured well in too few frames."""
    kept = (f"only {sel.size} frames of the ball kept (frames {int(sel[0])}-{int(sel[-1])} of {n}; measured well in "
            f"{int(good.sum())}), a track needs {MIN_TRAJECTORY_SAMPLES}" if sel.size else
            f"no frame of the ball kept (measured well in {int(good.sum())} of {n})")
    seen = np.flatnonzero(good)
    lowest = int(seen[np.argmax(row[seen])]) if seen.size else -1
    span = float(t[-1] - t[0]) if t.size > 1 else 0.0
    if lowest >= 0 and row[lowest] + diameter_px > bottom_px:   # the ball's bottom within half a diameter of the edge
        why = (f"the floor is not in the picture (the ball reaches its bottom edge, frame {lowest}, and its bounces "
               "are not seen): film with the floor and the whole drop in the picture (camera farther away or lower)")
    elif span < MIN_VIDEO_S:
        why = f"the video is only {span:.1f} s long: film the whole drop and some bounces"
    else:
        why = "give the ball's colour with --color and a region with --roi"
    return DataError(f"{path}: {kept}: {why}")


def _finish(path, t, row, col, area, quality, good, repeated, lost, notes, n, size, fps, container_fps, diameter_m,
            scale_m_per_px, g_m_per_s2=STANDARD_GRAVITY, bottom_px=None, blur=None):
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
    fit = fit_bounces(tt, rr, flights)
    # the ball's apparent diameter: the slower half of the frames of the flights (the least motion blur)
    in_flight = np.concatenate([i for i, _, _ in flights]) if flights else np.arange(rr.size)
    speed = np.abs(np.gradient(rr, tt))[in_flight] if rr.size > 2 else np.zeros(in_flight.size)
    slow = idx[in_flight[np.argsort(speed)[: max(3, in_flight.size // 2)]]]
    d_frames = 2.0 * np.sqrt(area[slow] / math.pi)
    diameter_px = float(np.median(d_frames))
    diameter_sd_px = math.hypot(EDGE_PX, 1.4826 * float(np.median(np.abs(d_frames - diameter_px))))
    fall = flights[0] if _starts_with_fall(tt, flights) else None
    fall_g_px = 2.0 * fall[1][0] if fall is not None and fall[0].size >= 5 else float("nan")
    notes += _unseen_notes(tt, rr, flights, diameter_px)
    try:
        scale, g_meas, rate_suspect = choose_scale(diameter_m, diameter_px, diameter_sd_px, fit, scale_m_per_px,
                                                   fps if fps is not None else container_fps, fps is not None, notes,
                                                   fall_g_px, g_m_per_s2, found=(idx.size, n))
    except UsageError as err:
        raise UsageError(f"{path}: {err}") from None
    if fit is not None and fit.n_flights >= 2:
        contact_row = fit.contact_row_px
        notes.append(f"floor: the ball's centre at contact is at row {contact_row:.2f} +/- "
                     f"{fit.contact_row_sd_px:.2f} px (where the {fit.n_flights} flights between bounces, fitted "
                     "together, meet); heights are of the ball's bottom above the floor, "
                     "(row_c - row) x scale")
    else:
        contact_row = float(np.max(rr[release:])) if release < rr.size else float(np.max(rr))
        notes.append("floor: fewer than two flights between bounces; heights are of the ball's bottom above its "
                     "lowest tracked position")
    # the drop only: from the still segment before release to the rest on the floor
    noise = float(np.median([f[2] for f in flights])) if flights else 0.5
    start = 0
    if release > 0:
        still = np.abs(rr[:release] - rr[release - 1]) <= max(2.0, 4 * noise)
        moving = np.flatnonzero(~still)
        start = int(moving[-1]) + 1 if moving.size else 0
    end = _track_end(flights, rr.size)
    # the fall from the hand must be a fall: else the track starts at the first apex
    fall_note = None
    if fit is not None and fall is not None and fall[0].size >= 5 and fit.n_flights >= 2:
        misfit = _fall_misfit_px(tt, rr, fall[0], fit.curvature_px_per_s2)
        flight_rms = float(np.median([f[2] for f in flights[1:]]))
        if misfit > max(FALL_MISFIT_PX, 4.0 * flight_rms):
            _, t0, t1 = fit.flights[0]
            apex = 0.5 * (t0 + t1)
            first = int(np.searchsorted(tt, apex))
            d_hold = (2.0 * math.sqrt(float(np.median(area[idx[start:release]])) / math.pi)
                      if release - start >= 3 else float("nan"))
            nearer = "nearer" if d_hold > diameter_px else "farther from"
            why = (f"; the ball looks {d_hold:.1f} px wide in the hand and {diameter_px:.1f} px in the bounces: it "
                   f"was held {abs(d_hold / diameter_px - 1) * 100:.0f} % {nearer} the camera than its bounces"
                   if abs(d_hold / diameter_px - 1) > 0.02 else
                   "; a hand that still touches it, or a ball that moves towards or away from the camera")
            fall_note = (f"the fall from the hand is left out (frames {idx[start]}-{idx[first - 1]}): it is no free "
                         f"fall with the bounces' g -- its frames lie {misfit:.1f} px RMS from the best such fall, "
                         f"air drag allowed, while a flight between bounces lies {flight_rms:.2f} px from its "
                         f"parabola{why}; the track starts at the first apex (t = {apex:.3f} s)")
            start = first
    if fall_note:
        notes.append(fall_note)
    elif start > 0:
        notes.append(f"track starts at frame {idx[start]} (the ball moved before its still segment)")
    if end < rr.size:
        notes.append(f"track ends at frame {idx[end - 1]} (t = {tt[end - 1]:.3f} s), with the last flight "
                     f"resolved; {rr.size - end} later frame(s) left out (hops too short to resolve, the ball at "
                     "rest, rolling or picked up)")
    keep = np.zeros(rr.size, dtype=bool)
    keep[start:end] = True
    straddle = _straddling(tt, rr, flights)
    if np.any(straddle & keep):
        keep &= ~straddle
        notes.append(f"{int(np.sum(straddle[start:end]))} frame(s) at a bounce left out (frames "
                     f"{_list(idx[straddle])}): the ball's image lies above both flights there -- the exposure "
                     "spans the impact, and the blurred image averages the path down and up")
    sel = idx[keep]
    if sel.size < MIN_TRAJECTORY_SAMPLES:
        raise _too_few_frames(path, sel, good, n, t, row, diameter_px, size[0] if bottom_px is None else bottom_px)
    kept = np.zeros(n, dtype=bool)
    kept[sel] = True
    n_lost = int(np.sum(lost[sel[0]:sel[-1] + 1]))
    notes.append(f"ball measured in {good.sum()} of {n} frames; {sel.size} kept"
                 + (f"; {n_lost} frame(s) within the track left out (ball lost, hidden or cut by the edge; "
                    f"quality < {MIN_QUALITY})" if n_lost else ""))
    streak = float(np.sqrt(np.nanmean(blur[sel] ** 2))) if blur is not None and np.any(np.isfinite(blur[sel])) else 0.0
    systematic_px = centre_systematic_px(streak)
    notes.append(f"the centres are uncertain by about {systematic_px:.2g} px ({systematic_px * scale * 1e3:.2g} mm) "
                 f"beyond their noise from frame to frame (blur, compression, shading; the ball's streaks are "
                 f"{streak:.1f} px long, RMS): smaller effects are not resolved")
    y_m = (contact_row - row[sel]) * scale
    x_m = (col[sel] - col[sel][0]) * scale
    traj = finish_trajectory(path, t[sel], y_m, sel + 1, notes, np.column_stack([y_m, x_m]))
    if traj.t_s.size < sel.size:        # frames it left out (a glitch of the tracker): no longer kept
        kept[:] = False
        kept[np.asarray(traj.lines) - 1] = True
    # what the tracker knows of its own errors: the centres' systematic error, and the floor (the contact
    # row of the bounce fit) uncertain by its standard error and that systematic error
    floor_sd_px = (math.hypot(fit.contact_row_sd_px, systematic_px) if fit is not None and fit.n_flights >= 2
                   else 0.0)
    traj = replace(traj, systematic_m=systematic_px * scale, floor_sd_m=floor_sd_px * scale)
    out = VideoTrack(t_s=t, row_px=row, col_px=col, quality=quality, kept=kept, repeated=repeated,
                     diameter_px=diameter_px, scale_m_per_px=scale, contact_row_px=contact_row,
                     g_measured=g_meas, fps=container_fps if fps is None else fps, size=size, notes=notes,
                     rate_suspect=rate_suspect,
                     trajectory=traj, bounces=fit, systematic_m=systematic_px * scale)
    return out


def centre_systematic_px(streak_px):
    """Systematic error [px] of the ball's centres beyond their noise from frame to frame, for streaks
    ``streak_px`` [px] long (RMS over the frames kept; :func:`streak_length`): :data:`CENTRE_SYSTEMATIC_PX`
    (a still ball's: shading, compression) and :data:`CENTRE_SYSTEMATIC_PER_STREAK` of the streak's length
    (a blurred streak's tails are faint, and a little of the leading or trailing one is lost) in quadrature."""
    return math.hypot(CENTRE_SYSTEMATIC_PX, CENTRE_SYSTEMATIC_PER_STREAK * streak_px)


#: Systematic error of a still (unblurred) ball's centre [px] beyond the frame-to-frame noise
#: (compression, shading): the mean error of the centres in the synthetic videos of
#: ``benchmarks/bench_track.py`` is 0.01-0.05 px, and a speed-dependent pattern of about 0.01 px
#: in the probe's unblurred renders (H.264 and MJPEG).
CENTRE_SYSTEMATIC_PX = 0.03
#: Systematic error of a blurred ball's centre per px of its streak's length (:func:`centre_systematic_px`):
#: in the probe's renders lit from above (0.4-frame exposure, H.264, MJPEG, MPEG-4), the part of the
#: centres' errors that follows the ball's speed and height was 0.02-0.09 px RMS for streaks of 2-15 px RMS
#: (0.004-0.007 per px).
CENTRE_SYSTEMATIC_PER_STREAK = 0.007
#: Uncertainty of the ball's apparent diameter from where its edge is drawn [px] (gamma,
#: compression, optical blur), added to the spread of the diameter over the frames.
EDGE_PX = 0.5
#: Beyond this relative disagreement of g (from the flights with the diameter's scale) with
#: standard gravity, no ball's apparent size can be that wrong: the frame rate is suspect.
FRAME_RATE_SUSPECT = 0.25
#: The flights tell g when its relative uncertainty from them is below this.
G_TELLS = 0.02
#: A fall from the hand that misses the best free fall (with the bounces' g, drag allowed) by
#: more than this RMS [px] (and four times the bounce flights' RMS) is left out.
FALL_MISFIT_PX = 1.0


@dataclass
class BounceFit:
    """The flights between bounces fitted together (:func:`fit_bounces`), in image rows (down)."""

    curvature_px_per_s2: float     # a: row = row_c - a (t - t_start)(t_end - t); g = 2 a x scale
    curvature_sd_px_per_s2: float
    contact_row_px: float          # the centre's row at contact
    contact_row_sd_px: float
    impact_times_s: np.ndarray     # the starts and ends of the flights
    flights: list                  # [(frame indices, t_start, t_end)]
    rms_px: float
    n_flights: int

    @property
    def g_px_per_s2(self):
        return 2.0 * self.curvature_px_per_s2

    def row_at(self, t_s):
        """The fitted centre row at ``t_s`` (the flight that contains it, else the nearest), NaN
        outside the fitted bounces."""
        t_s = np.asarray(t_s, dtype=float)
        out = np.full(t_s.shape, np.nan)
        for _, t0, t1 in self.flights:
            inside = (t_s >= t0) & (t_s <= t1)
            out[inside] = self.contact_row_px - self.curvature_px_per_s2 * (t_s[inside] - t0) * (t1 - t_s[inside])
        return out


def fit_bounces(t, row, flights):
    """The flights between bounces as one model: curves of one curvature ``a`` that leave and
    reach the same contact row ``row_c``, each consecutive pair meeting there at the impact::

        row = row_c - tau (T - tau) (a + s_i (2 tau - T) / T),  tau = t - t_i,  T = t_{i+1} - t_i

    between impacts ``t_i`` and ``t_{i+1}``: a parabola, skewed by ``s_i`` (one per flight)
    as air drag skews a flight (faster up than down), which would otherwise bias ``row_c``
    where the flights are extrapolated to the floor. The fall from the hand (the first
    flight, when it starts at its top: :func:`_starts_with_fall`) is left out: a hand may still
    touch it, and the ball may start nearer the camera. Least
    squares over all the flights' frames (the frames at a bounce are in no flight) give
    ``a``, ``row_c`` and their standard errors. A contact that lasts (the ball resting on
    the floor between landing and lift-off) is not modelled: the flights then meet above
    the floor, by about the contact time times the impact speed over two.

    Parameters
    ----------
    t : ndarray
        frame times [s]
    row : ndarray
        the ball centre's image row [px]
    flights : list
        :func:`_flights` of these frames

    Returns
    -------
    BounceFit or None
        None without a flight between two bounces
    """
    from scipy.optimize import least_squares

    chain = [f for f in (flights[1:] if _starts_with_fall(t, flights) else flights) if f[0].size >= 4]
    if not chain:
        return None
    # impact-time parameters: consecutive flights share one
    owner, times = [], []
    a0 = float(np.median([c[0] for _, c, _ in chain]))
    crossings = _bounce_crossings(t, flights)
    r0 = float(np.median([c[1] for c in crossings])) if crossings else float(max(np.max(row[i]) for i, _, _ in chain))
    prev = None
    for i, c, _ in chain:
        roots = np.sort(np.roots(np.asarray(c, float) - [0.0, 0.0, r0]).real)
        lo, hi = (roots[0], roots[-1]) if roots.size == 2 else (t[i[0]], t[i[-1]])
        joined = bool(times) and _consecutive(t, prev, i)
        if joined:
            times[-1] = 0.5 * (times[-1] + min(lo, t[i[0]]))
        else:
            times.append(min(lo, t[i[0]]))
        times.append(max(hi, t[i[-1]]))
        owner.append((len(times) - 2, len(times) - 1))
        prev = i
    frames = [i for i, _, _ in chain]

    nt = len(times)

    def residual(p):
        a, rc = p[0], p[1]
        ts, skew = p[2:2 + nt], p[2 + nt:]
        out = []
        for n, (i, (j0, j1)) in enumerate(zip(frames, owner)):
            tau, span = t[i] - ts[j0], ts[j1] - ts[j0]
            out.append(row[i] - (rc - tau * (span - tau) * (a + skew[n] * (2.0 * tau - span) / span)))
        return np.concatenate(out)

    p0 = np.r_[a0, r0, times, np.zeros(len(chain))]
    sol = least_squares(residual, p0, method="lm",
                        x_scale=np.r_[a0, 1.0, np.full(nt, 0.01), np.full(len(chain), 0.01 * a0)])
    res = sol.fun
    dof = max(res.size - sol.x.size, 1)
    s2 = float(res @ res) / dof
    try:
        cov = np.linalg.inv(sol.jac.T @ sol.jac) * s2
        sd = np.sqrt(np.clip(np.diag(cov), 0.0, None))
    except np.linalg.LinAlgError:
        sd = np.full(sol.x.size, np.nan)
    ts = sol.x[2:2 + nt]
    return BounceFit(curvature_px_per_s2=float(sol.x[0]), curvature_sd_px_per_s2=float(sd[0]),
                     contact_row_px=float(sol.x[1]), contact_row_sd_px=float(sd[1]), impact_times_s=ts,
                     flights=[(i, ts[j0], ts[j1]) for i, (j0, j1) in zip(frames, owner)],
                     rms_px=float(np.sqrt(np.mean(res ** 2))), n_flights=len(chain))


#: Why a video without a diameter or a scale cannot be scaled (the flights do not tell g), and what to give.
NO_SCALE = ("the scale of this video (m per pixel) comes from the flights between bounces with g, the ball's "
            "apparent size or a given scale, and the flights do not tell g: give --ball or --diameter, or "
            "--scale M_PER_PX")


def choose_scale(diameter_m, diameter_px, diameter_sd_px, fit, scale_m_per_px, fps, fps_given, notes,
                 fall_g_px=float("nan"), g_m_per_s2=STANDARD_GRAVITY, found=None):
    """The length scale [m/px] of a video, and g [m/s^2] from the flights with the diameter's scale.

    Two measurements give the scale: the ball's apparent diameter (``diameter_m`` over
    ``diameter_px``, uncertain by ``diameter_sd_px``: blur, shading, compression and the
    ball's distance changing), and the flights' curvature with standard gravity and the
    frame clock (:func:`fit_bounces`). They are combined with inverse-variance weights when
    they agree; when they disagree beyond their uncertainty (3 sigma) and the flights tell
    g (to :data:`G_TELLS`), the scale is the flights' alone -- a clock is trusted over a
    blurred size -- and a note gives what the diameter would have implied. When g from the
    diameter's scale (or the fall's, without flights between bounces) is off by more than
    :data:`FRAME_RATE_SUSPECT` the frame rate itself is suspect (a slow-motion video): the
    diameter's scale is kept, with a warning. A scale
    from the flights takes g as known: an effect that changes the flights' acceleration
    alike (buoyancy) cannot then be told from the video. Without a flight between bounces,
    the fall's curvature (``fall_g_px``) only checks the diameter's scale.

    Parameters
    ----------
    diameter_m : float or None
        the ball's diameter [m]; without it (and without ``scale_m_per_px``) the scale is the flights'
        with g when they tell g, else a :class:`~vrcal.errors.UsageError` (:data:`NO_SCALE`)
    diameter_px, diameter_sd_px : float
        its apparent diameter and the uncertainty of it [px]
    fit : BounceFit or None
        the flights between bounces
    scale_m_per_px : float or None
        a scale given by the user [m/px]: used as it is
    fps : float
        the frame rate of the times [Hz] (for the notes)
    fps_given : bool
        the rate is the user's ``--fps``, not the container's
    notes : list of str
        appended to
    fall_g_px : float
        twice the curvature of the fall [px/s^2], NaN when none
    g_m_per_s2 : float
        the local g [m/s^2] the flights' scale takes as known (default standard gravity)
    found : (int, int) or None
        frames the ball was found in, of all: below :data:`FOUND_WELL` of them the warning blames the
        ball's apparent size (a ball barely standing out), not the frame rate

    Returns
    -------
    (float, float, str)
        the scale [m/px], g from the flights with the diameter's (or the given) scale [m/s^2], and
        what makes the frame rate suspect ("" when it is not)
    """
    g_px = fit.g_px_per_s2 if fit is not None else fall_g_px
    g_rel = fit.curvature_sd_px_per_s2 / fit.curvature_px_per_s2 if fit is not None else float("inf")
    if not math.isfinite(g_rel):
        g_rel = float("inf")
    d_rel = diameter_sd_px / diameter_px
    seen = f"the ball's apparent diameter, {diameter_px:.1f} +/- {diameter_sd_px:.1f} px"
    clock = f"{'--fps' if fps_given else 'the container'}'s {fps:.3f} fps"
    curved = (f"the curvature of the {fit.n_flights} flight(s) between bounces, {g_px:.5g} px/s^2 +/- "
              f"{g_rel * 100:.2g} %" if fit is not None else "")
    if scale_m_per_px is None and diameter_m is None:
        if not (math.isfinite(g_px) and g_rel < G_TELLS):
            raise UsageError(NO_SCALE + (f" (the {fit.n_flights} flight(s) between bounces give it to {g_rel:.1%} only)"
                                         if fit is not None else " (no flight between bounces is seen)"))
        scale = g_m_per_s2 / g_px
        notes.append(f"scale: {scale * 1e3:.4g} mm/px from g ({g_m_per_s2:g} m/s^2 with {clock}) and {curved}; "
                     f"{seen}, not checked (no --diameter)")
        notes.append("the heights are scaled with g known: an effect that changes every flight's acceleration alike "
                     "(buoyancy) cannot be told from this video")
        return scale, float("nan"), ""
    if scale_m_per_px is not None:
        scale = float(scale_m_per_px)
        g_meas = g_px * scale
        notes.append(f"scale: {scale * 1e3:.4g} mm/px (given); {seen}")
        if math.isfinite(g_meas):
            notes.append(f"check: the flights give g = {g_meas:.2f} m/s^2 with this scale and {clock}")
        return scale, g_meas, ""
    scale_d = diameter_m / diameter_px
    seen += f" for its {diameter_m * 1e3:.4g} mm"
    g_meas = g_px * scale_d
    ratio = g_meas / g_m_per_s2
    who = "flights give" if fit is not None else "fall gives"
    if math.isfinite(ratio) and abs(ratio - 1) > FRAME_RATE_SUSPECT:
        k = 1.0 / math.sqrt(ratio) if ratio > 0 else float("nan")
        notes.append(f"scale: {scale_d * 1e3:.4g} mm/px from {seen}")
        standard = standard_frame_rate(fps * k)
        give = (f"give --fps {standard:g} (the nearest standard rate), or check --diameter" if standard else
                f"give --fps {fps * k:.0f}, or check --diameter")
        if found is not None and found[0] < FOUND_WELL * found[1]:
            # a ball found in few frames is a ball that barely stands out: its measured size is what is wrong (a
            # grey ball on a grey wall, found in 32 of 120 frames at 18.6 px for 25.5, was sent to --fps 25)
            suspect = (f"the {who} g = {g_meas:.2f} m/s^2 with the scale of the ball's apparent diameter and "
                       f"{clock}, {abs(ratio - 1) * 100:.0f} % off {g_m_per_s2:.2f}, and the ball was found in only "
                       f"{found[0]} of {found[1]} frames: it barely stands out from the background, and its "
                       f"apparent size is likely wrong: give the ball's colour with --color and a region with "
                       f"--roi, or the scale with --scale; if this is a slow-motion video, the motion fits "
                       f"{fps * k:.0f} fps")
        else:
            suspect = (f"the {who} g = {g_meas:.2f} m/s^2 with the scale of the ball's apparent diameter and "
                       f"{clock}, {abs(ratio - 1) * 100:.0f} % off {g_m_per_s2:.2f} -- no apparent size is that wrong: "
                       f"the frame rate is suspect (a slow-motion video?); the motion fits a capture rate of about "
                       f"{fps * k:.0f} fps: {give}")
        notes.append(f"WARNING: {suspect}")
        return scale_d, g_meas, suspect
    if not (math.isfinite(g_meas) and g_rel < G_TELLS):
        notes.append(f"scale: {scale_d * 1e3:.4g} mm/px from {seen}; "
                     + ("too few flights between bounces to tell g" if fit is not None else
                        "no flight between bounces to tell g"))
        if math.isfinite(g_meas):
            notes.append(f"check: the {who} g = {g_meas:.2f} m/s^2 with this scale and {clock}")
        return scale_d, g_meas, ""
    sigma = math.hypot(g_rel, d_rel)
    scale_g = g_m_per_s2 / g_px
    from_g = f"g ({g_m_per_s2:g} m/s^2 with {clock}) and {curved}"
    if abs(ratio - 1) > 3 * sigma:
        notes.append(f"scale: {scale_g * 1e3:.4g} mm/px from {from_g}")
        notes.append(f"not used: {seen}, which gives {scale_d * 1e3:.4g} mm/px and with it g = {g_meas:.2f} m/s^2 "
                     f"from the flights, {abs(ratio - 1) / sigma:.0f} sigma off (blur, shading, perspective or a wrong "
                     "--diameter bias an apparent size; a clock is trusted over it)")
        notes.append("the heights are scaled with g known: an effect that changes every flight's acceleration alike "
                     "(buoyancy) cannot be told from this video")
        return scale_g, g_meas, ""
    w_g, w_d = 1.0 / g_rel ** 2, 1.0 / d_rel ** 2
    scale = math.exp((w_g * math.log(scale_g) + w_d * math.log(scale_d)) / (w_g + w_d))
    share = w_g / (w_g + w_d)
    notes.append(f"scale: {scale * 1e3:.4g} mm/px, {share * 100:.0f} % from {from_g} ({scale_g * 1e3:.4g} mm/px), "
                 f"{100 - share * 100:.0f} % from {seen} ({scale_d * 1e3:.4g} mm/px, with which the flights give "
                 f"g = {g_meas:.2f} m/s^2): they agree")
    if share > 0.5:
        notes.append("the heights are scaled mostly with g known: an effect that changes every flight's acceleration "
                     "alike (buoyancy) cannot be told from this video")
    return scale, g_meas, ""


def _straddling(t, row, flights, min_px=0.3):
    """Frames at a bounce (between two consecutive flights, in neither) whose ball lies above
    both flights' parabolas (row smaller) by more than ``min_px`` and 4 flight RMS: their
    exposure spans the impact. The path near an impact is the higher of the two parabolas
    (the fall, then the rise); a blurred image averages the path down and up over the
    exposure, which lies above the path at mid-exposure."""
    out = np.zeros(row.size, dtype=bool)
    for (i1, c1, r1), (i2, c2, r2) in zip(flights[:-1], flights[1:]):
        between = np.arange(i1[-1] + 1, i2[0])
        if between.size == 0 or between.size > 3:
            continue
        model = np.minimum(np.polyval(c1, t[between]), np.polyval(c2, t[between]))
        out[between] = model - row[between] > max(min_px, 4.0 * max(r1, r2))
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
          g_m_per_s2=STANDARD_GRAVITY, rotate=0, **_ignored):
    """The ``video`` reader: the ball's trajectory (see :func:`track_video`); ``fs_hz`` is ``--fps``.
    A video whose frame rate is suspect (a slow-motion video read at its container's rate: g from
    its flights with the ball's apparent diameter for scale more than :data:`FRAME_RATE_SUSPECT`
    off) is a DataError naming the capture rate that fits (``vrcal track`` writes it with a warning)."""
    vt = track_video(path, diameter_m=diameter_m, roi=roi, color=color, fps=fs_hz, scale_m_per_px=scale_m_per_px,
                     progress=progress, g_m_per_s2=g_m_per_s2, rotate=rotate)
    if vt.rate_suspect:
        raise DataError(f"{path}: {vt.rate_suspect}")
    return vt.trajectory
