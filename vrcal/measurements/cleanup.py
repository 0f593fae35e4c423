"""Clean-up of raw records, one pure function each: the still segment before release,
duplicated video frames, the noise of a trajectory (third differences), its bounces (prominent
minima), and echoes, missed impacts and odd bounces in a series of impact times (chains of
consecutive bounces).
"""

from __future__ import annotations

import bisect
import math
import re
from typing import NamedTuple

import numpy as np

from vrcal.model.restitution import STANDARD_GRAVITY_M_PER_S2


def resolution_step(y):
    """The smallest non-zero step between successive samples of ``y`` [unit of ``y``]: the resolution the
    series was written or tracked to (1 px for pixel data); 0 for a constant series."""
    steps = np.abs(np.diff(np.asarray(y, dtype=float)))
    steps = steps[steps > 0]
    return float(steps.min()) if steps.size else 0.0


def detect_release_index(y, *, window=10, n_sigma=5.0, min_still=3, n_fit=400, sigma=None):
    """Index of the first sample after the still segment that precedes a release.

    The still level at sample i is the median of the ``window`` samples before it. The
    departure is the first sample that, with the two after it, lies more than
    ``n_sigma`` noise sigmas (and at least two resolution steps) from that level on
    the same side, and after which no sample of the next ``window`` comes back within
    that threshold of the level: a ball let go moves away for good, while a held ball's
    jitter (a 0.8 px shift of a marble's track for three frames) returns. The release
    is then backed up to the start of the departure: a
    body released from rest departs as ``|y - level| = a (t - t_r)^2``, so
    ``sqrt(|y - level|)`` is a straight line in the sample index; a least-squares line
    through the departure (at most ``n_fit`` samples, while it keeps growing and stays
    below 25 thresholds) crosses zero at the release ``i_r``, and the still level is
    re-estimated from the ``window`` samples before ``i_r`` (three passes). The result
    is the first sample at or after ``i_r``, never after the departure; when fewer than
    three samples are usable it is one after the last sample within the noise band
    (2 sigma, at least one resolution step) of the still level.

    Parameters
    ----------
    y : array_like
        heights [m] (any length unit works), in sample order
    window : int
        samples in the trailing median that gives the still level
    n_sigma : float
        departure threshold in noise sigmas
    min_still : int
        fewest still samples for a still segment; a shorter one gives 0
    n_fit : int
        most samples of the departure used to extrapolate back to the release
    sigma : float or None
        noise of one sample [unit of ``y``] when known (given by the user, or measured); None:
        estimated as in the notes

    Returns
    -------
    int
        the release index, 0 when the record does not start with a still segment.

    Notes
    -----
    Without ``sigma``, the noise sigma is estimated robustly from second differences of the whole record,
    ``sigma = 1.4826 MAD(diff(y, 2)) / sqrt(6)`` (free flight has a constant second
    difference, bounces are outliers), floored at the resolution step / sqrt(12); the
    resolution step is the smallest non-zero |diff(y)| (1 px for pixel data). Within
    the first samples after release the ball moves less than the noise, so the index
    is uncertain by a sample or two; the fitter refines the release time.
    """
    y = np.asarray(y, dtype=float)
    n = y.size
    if n < min_still + 3:
        return 0
    quantum = resolution_step(y)
    if sigma is None:
        d2 = np.diff(y, 2)
        sigma = 1.4826 * float(np.median(np.abs(d2 - np.median(d2)))) / np.sqrt(6.0) if d2.size else 0.0
    sigma = max(float(sigma), quantum / np.sqrt(12.0))
    threshold = max(n_sigma * sigma, 2.0 * quantum)
    band = max(2.0 * sigma, quantum)
    padded = np.concatenate([np.full(window, np.nan), y])
    windows = np.lib.stride_tricks.sliding_window_view(padded, window)[:n]  # windows[i] = y[i-window:i]
    count = np.sum(~np.isnan(windows), axis=1)
    level = np.full(n, np.nan)
    ok = count >= min_still
    full = min(window, n)    # windows from sample `window` on hold no NaN: the plain median is much faster
    head = ok[:full]
    level[:full][head] = np.nanmedian(windows[:full][head], axis=1) if np.any(head) else np.nan
    if n > full:
        lo, hi = (window - 1) // 2, window // 2      # the median: the middle one or two of each window
        part = np.partition(windows[full:], (lo, hi), axis=1)
        level[full:] = 0.5 * (part[:, lo] + part[:, hi])
    dev = y - level
    beyond = np.where(np.isnan(dev), 0, np.sign(dev) * (np.abs(dev) > threshold))
    persistent = (beyond[:-2] != 0) & (beyond[:-2] == beyond[1:-1]) & (beyond[:-2] == beyond[2:])
    # the first that moves away for good (in flight nearly every sample is a hit: stop at the first)
    i = next((int(h) for h in np.flatnonzero(persistent)
              if not np.any(np.abs(y[h + 3:h + 3 + window] - level[h]) <= threshold)), None)
    if i is None:
        return 0
    within = np.flatnonzero(np.abs(y[:i] - level[i]) <= band)
    release = int(within[-1]) + 1 if within.size else 0
    still_level = level[i]
    for _ in range(3):  # refine: the level from the samples before the estimated release
        depart = np.abs(y[i:i + n_fit] - still_level)
        peak = np.maximum.accumulate(depart)
        usable = np.cumprod((depart > peak - 3.0 * band) & (depart <= 25.0 * threshold)).astype(bool)
        j = np.arange(i, i + depart.size)[usable]
        if j.size < 3:
            break
        slope, intercept = np.polyfit(j, np.sqrt(depart[usable]), 1)
        if slope <= 0:
            break
        release = int(np.clip(np.ceil(-intercept / slope), 0, i))
        before = y[max(0, release - window):release]
        if before.size < min_still:
            break
        still_level = float(np.median(before))
    held = release >= min_still and _held_still(y[:release], still_level, threshold, window, min_still)
    return release if held else 0


def still_level(y, start):
    """Where a motion starting at sample ``start`` starts from [unit of ``y``]: the median of the ten
    samples before it (the still segment), or ``y[start]`` at the record's first sample."""
    r = int(start)
    y = np.asarray(y, dtype=float)
    return float(np.median(y[max(0, r - 10):r])) if r > 0 else float(y[r])


def toss_top_index(t, y, start=0, level=None):
    """Index of the top of a toss, or None: a ball held, then thrown, rises, turns at the top of a free
    flight and falls past where it left the hand, to the floor below it.

    From ``start`` the ball moves one way; at the first turn of that motion (the first sample after which
    it comes back by more than 5 noise sigmas, 5 % of the record's span and 10 % of the excursion) it is a
    toss's top when the record later comes back past the starting level by more than that: a ball let go
    falls into a bounce instead, and no bounce brings it back to its drop height (epsilon < 1). Which way is
    up need not be known: in either orientation of the file a toss's first motion is up (away from the
    floor). At the top the ball is at rest in free flight: the model's drop from rest, so the release is
    taken there (the samples held, thrown and rising are no drop from rest).

    Parameters
    ----------
    t : ndarray
        sample times [s]
    y : ndarray
        heights [m] (any length unit; either orientation)
    start : int
        first sample of the motion (the release after a still segment, :func:`detect_release_index`); 0: the
        first three samples must hold still (within 5 noise sigmas and 2 % of the span), or a record that
        starts in flight, falling into a bounce, would rise past its first sample
    level : float or None
        where the motion starts (the still level) [unit of ``y``]; None: :func:`still_level`

    Returns
    -------
    int or None
        the sample at the top (the farthest of the first excursion)
    """
    r = int(start)
    t = np.asarray(t, dtype=float)
    y = np.asarray(y, dtype=float)
    if y.size - r < 6:
        return None
    if level is None:
        level = still_level(y, r)
    span = float(np.ptp(y[r:]))
    if span <= 0:
        return None
    noise = third_difference_sigma(t, y) or 0.0
    if r == 0 and np.any(np.abs(y[:3] - level) > max(5.0 * noise, 0.02 * span)):
        return None     # no still start: a record that starts in flight may rise past its first sample
    moved = np.abs(y[r:] - level) >= 0.25 * span
    if not np.any(moved):
        return None
    e = np.sign(y[r + int(np.argmax(moved))] - level) * (y[r:] - level)
    tol = np.maximum(max(5.0 * noise, 0.05 * span), 0.1 * np.maximum.accumulate(e))
    back = np.flatnonzero(e < np.maximum.accumulate(e) - tol)
    if back.size == 0:
        return None
    top = int(np.argmax(e[:back[0]]))
    past = e[top:] < -tol[top]
    return r + top if e[top] > 0 and np.any(past) else None


def _held_still(before, level, threshold, window, min_still):
    """Whether the samples before a release hold still: at least ``min_still`` of the last ``window``
    and most of them lie within ``threshold`` of the still level (a record that starts in flight has a
    few samples that a trailing median takes for a level, but they are spread over the flight)."""
    last = np.asarray(before[-window:], dtype=float)
    near = int(np.sum(np.abs(last - level) <= threshold))
    return near >= min_still and 2 * near > last.size


#: A number as written: sign, whole part, decimals after a point or a comma, exponent.
_WRITTEN_NUMBER = re.compile(r"^\s*[+-]?\d*(?:[.,](\d*))?(?:[eE]([+-]?\d+))?\s*$")


def written_decimals(cells):
    """The most decimals among numbers as written (``'0.500'``: 3, trailing zeros count; ``'5.0e-3'``: 4;
    ``'500'``: 0), or None when no cell is a plain number."""
    most = None
    for cell in cells:
        m = _WRITTEN_NUMBER.match(str(cell))
        if m is None or not any(ch.isdigit() for ch in str(cell)):
            continue
        d = max(0, len(m.group(1) or "") - int(m.group(2) or 0))
        most = d if most is None else max(most, d)
    return most


def printed_resolution(t, max_decimals=9, written=None):
    """The step numbers were printed to (0.001 for three decimals), or None when they hold more than
    ``max_decimals`` decimals: whole multiples of 10^-d up to 1e-6 of a step, or up to float rounding
    (1e-15 relative) for values beyond 1e9 steps.

    ``written``: the same numbers as the file writes them (its cells' text), when known. Their decimals
    decide, trailing zeros included: ``0.500`` is written to 0.001 (a millimetre read in metres), which
    its float 0.5 cannot tell from ``0.5`` (written to 0.1)."""
    if written is not None:
        d = written_decimals(written)
        if d is not None:
            return 10.0**-d if d <= max_decimals else None
    t = np.asarray(t, dtype=float)
    if t.size == 0:   # no number (a column of empty cells): no step to tell
        return None
    for d in range(max_decimals + 1):
        q = t * 10.0**d
        if np.all(np.abs(q - np.round(q)) < 1e-6 * max(1.0, float(np.max(np.abs(q))) * 1e-9)):
            return 10.0**-d
    return None


class RegularTimes(NamedTuple):
    """Sample times put back on their frame grid by :func:`regular_frame_times`."""

    t_s: np.ndarray      # t0 + k step, in the unit of the input
    resolution: float    # the step the input was printed to (0.001 for three decimals)
    step: float          # the frame period
    largest_change: float


def regular_frame_times(t, *, coarse_fraction=0.02, max_decimals=9, written=None):
    """Sample times printed with too few digits for their frame rate, put back on their grid.

    A tracker that writes ``0.017, 0.033, 0.050`` for 60 frames/s moves each sample by up to half a
    millisecond, which at 5 m/s is 2.5 mm: as much as the tracking noise. When every time is a
    multiple of a printed resolution at least ``coarse_fraction`` of the frame period (and at most a
    quarter of it, so that the frame numbers follow from the intervals), and a regular
    grid t0 + k step (k integers increasing, frames not tracked leave gaps, at least half the frames
    tracked) lies within 0.8 resolution of every time, the grid's times are returned (t0 and step by
    least squares);
    otherwise None (times printed finely enough, or truly irregular: a phone's variable frame rate).

    Parameters
    ----------
    t : array_like
        sample times, increasing, in any unit
    coarse_fraction : float
        printed resolution over frame period below which the times are left as they are
    max_decimals : int
        most decimals tried for the printed resolution
    written : sequence of str, optional
        the times as the file writes them (:func:`printed_resolution`: trailing zeros count)

    Returns
    -------
    RegularTimes or None
    """
    t = np.asarray(t, dtype=float)
    if t.size < 8 or not np.all(np.isfinite(t)):
        return None
    dt = np.diff(t)
    if np.any(dt <= 0):
        return None
    step = float(np.median(dt[dt < 1.5 * dt.min()]))   # one frame (longer intervals are frames missed)
    resolution = printed_resolution(t, max_decimals, written)
    # (the first step is a median of printed intervals, itself off by up to a resolution: a loose bound
    # here, the strict one on the fitted period below)
    if resolution is None or resolution < coarse_fraction * step or resolution > 0.4 * step:
        return None   # printed finely enough, or too coarsely to tell the frames apart
    for _ in range(3):   # frame numbers from the intervals, then the period from the frame numbers
        k = np.concatenate([[0.0], np.cumsum(np.maximum(np.round(dt / step), 1.0))])
        A = np.column_stack([np.ones_like(k), k])
        (t0, step), *_ = np.linalg.lstsq(A, t, rcond=None)
        step = float(step)
        if not step > 0:
            return None
    if k[-1] > 2.0 * (t.size - 1) or resolution > 0.25 * step or resolution < coarse_fraction * step:
        return None   # more frames missing than tracked (the intervals do not pin the frame numbers down),
        # or the fitted period says the printing is too coarse, or fine enough
    grid = t0 + step * k
    change = float(np.max(np.abs(grid - t)))
    if change > 0.8 * resolution:
        # the least-squares line of a short record can miss its grid at the ends (20 frames at 142 fps
        # printed to 1 ms: 0.81 ms); the grid closest to every time (minimax) is within half a resolution
        grid, step = _minimax_grid(k, t)
        change = float(np.max(np.abs(grid - t)))
    if change > 0.8 * resolution or change < 1e-12:   # rounding moves a time by 0.5 at most; the fitted line
        # is itself a little off at the record's ends
        return None
    return RegularTimes(grid, resolution, step, change)


def _minimax_grid(k, t):
    """(grid, step): the line t0 + step k whose largest distance to the times ``t`` is least (a linear
    program: minimise e with |t0 + step k_i - t_i| <= e)."""
    from scipy.optimize import linprog

    scale = float(np.max(np.abs(t))) or 1.0
    A = np.column_stack([np.ones_like(k), k, -np.ones_like(k)])
    A_ub = np.vstack([A, A * [-1, -1, 1]])
    b_ub = np.concatenate([t, -t]) / scale
    out = linprog([0.0, 0.0, 1.0], A_ub=A_ub, b_ub=b_ub, bounds=[(None, None), (None, None), (0, None)],
                  method="highs")
    if not out.success:
        return np.full_like(t, np.inf), math.nan
    t0, step = out.x[0] * scale, out.x[1] * scale
    return t0 + step * k, float(step)


#: Frame rates of cameras and phones [Hz], slowest first: impact times read off a video lie on a grid
#: of one of them.
VIDEO_FRAME_RATES_HZ = (24.0, 25.0, 30000 / 1001, 30.0, 50.0, 60000 / 1001, 60.0, 100.0, 120.0, 240.0, 480.0,
                        960.0)


class TimeGrid(NamedTuple):
    """The grid a list of event times lies on (:func:`time_grid`)."""

    period_s: float   # the grid's step [s]
    what: str         # "a 29.97 fps video's frames", "times printed to 0.01 s"

    @property
    def sigma_s(self):
        """Standard deviation [s] of a time rounded to the grid: period / sqrt(12)."""
        return self.period_s / 12**0.5


#: The largest chance that times at random lie on a frame grid within the printed rounding, for the
#: grid to be taken (one frame rate; about 10 are tried).
GRID_CHANCE = 1e-4


def _chance_on_grid(width, n):
    """Chance that n times at random fall in one band ``width`` periods wide (the band's place free)."""
    return n * min(width, 1.0) ** (n - 1)


def time_grid(t_s, *, min_times=6, tolerance=0.02, min_period_s=1.5e-3, printed_s=None):
    """The coarsest grid that impact times lie on, or None: the frames of a video (times read off
    a camera at one of :data:`VIDEO_FRAME_RATES_HZ` with a period of at least ``min_period_s``:
    t = t0 + k / fps, k whole, every time within ``tolerance`` of a frame period of the grid, or
    within the printed rounding when that is at most a tenth of the period or when so many times
    fall on the grid that chance cannot put them there (:data:`GRID_CHANCE`: a 240 fps video printed
    to 1 ms, from 11 times on)) or the printed
    resolution (``0.45, 1.22, 1.88``: 0.01 s, from 1 ms up). Grids finer than ``min_period_s``
    (0.43 ms standard deviation) are below an acoustic stopwatch's own timing noise.

    A list of times with such a grid is only as good as the grid: each time is off by up to half a
    step, a standard deviation of step/sqrt(12) (9.6 ms at 30 fps), however well the sound or the
    tracker timed the event. Times at random fall within the slack of a grid with a chance of about
    (2 slack / period) per time: below 1e-5 for ``min_times`` times.

    ``printed_s``: the step [s] the file wrote the times to, when its text is known
    (:func:`printed_resolution` of the cells: trailing zeros count); else it is read from the floats.
    """
    t = np.asarray(t_s, dtype=float)
    if t.size < min_times or not np.all(np.isfinite(t)):
        return None
    printed = (printed_s if printed_s is not None else printed_resolution(t, 6)) or 0.0
    found = []
    for fps in VIDEO_FRAME_RATES_HZ:
        period = 1.0 / fps
        if period < min_period_s:
            continue
        k = np.round((t - t[0]) / period)
        if np.any(np.diff(k) < 1):
            continue
        dev = 0.5 * float(np.ptp(t - k * period))      # from the band's middle
        rounded = dev <= 0.6 * printed and (0.6 * printed <= 0.1 * period
                                            or _chance_on_grid(1.2 * printed / period, t.size) <= GRID_CHANCE)
        if dev <= tolerance * period or rounded:
            found.append((period, dev, fps))
    if found:
        coarsest = max(p for p, _, _ in found)
        period, _, fps = min((f for f in found if f[0] > 0.99 * coarsest), key=lambda f: f[1])
        if abs(period - printed) > 0.01 * period:   # else the grid is the printing's (0.01 s: 100 fps)
            return TimeGrid(period, f"the frames of a {fps:.4g} fps video")
    if printed >= 1e-3:
        return TimeGrid(printed, f"times printed to {printed:g} s")
    return None


def find_duplicated_frames(positions, release_index=0):
    """Indices of duplicated video frames: a repeat of the previous frame while the ball moves.

    Parameters
    ----------
    positions : array_like, shape (n,) or (n, k)
        tracked coordinates per frame (y, or y and x), in any length unit
    release_index : int
        first sample after the still segment: repeats before it are the ball at rest

    Returns
    -------
    ndarray of int
        indices i (0 < i < n - 1) of frames to drop.

    Notes
    -----
    Frame i is a duplicate of frame i-1 when all its coordinates repeat frame i-1
    exactly, frame i-1 is at or after the release, and the ball moved both into frame
    i-1 and out of frame i (non-zero steps on both sides). With a single coordinate a
    repeat at an apex or from rounding is common, so there the steps on both sides
    must also have the same sign and exceed one resolution step (the smallest non-zero
    step); with two coordinates (y and x) an exact repeat in flight is taken as a
    duplicated frame.
    """
    p = np.asarray(positions, dtype=float)
    if p.ndim == 1:
        p = p[:, None]
    n = p.shape[0]
    if n < 4:
        return np.zeros(0, dtype=int)
    d = np.diff(p, axis=0)  # d[j] = p[j+1] - p[j]
    moved = np.any(d != 0, axis=1)
    i = np.arange(2, n - 1)
    repeat = ~moved[i - 1]
    dup = repeat & moved[i - 2] & moved[i] & (i - 1 >= release_index)
    if p.shape[1] == 1:
        quantum = resolution_step(p[:, 0])
        before, after = d[i - 2, 0], d[i, 0]
        dup &= (np.sign(before) == np.sign(after)) & (np.abs(before) > quantum) & (np.abs(after) > quantum)
    return i[dup]


#: A tracker's glitch: a run of at most this many samples off the smooth path of its neighbours
#: (:func:`tracker_glitches`).
GLITCH_MAX_RUN = 3
#: ... the neighbours fitted on each side of the run.
GLITCH_NEIGHBOURS = 4
#: ... each sample of the run this many noise sigmas off the neighbours' quadratic, and this many times
#: their own scatter about it (while that scatter stays within :data:`GLITCH_SMOOTH_SIGMAS` sigmas).
GLITCH_SIGMAS = 10.0
GLITCH_SMOOTH_SIGMAS = 3.0
#: Passes over the record: each mends the glitches found, so that one among another's neighbours is found next.
GLITCH_PASSES = 4


def tracker_glitches(t, y, sigma=None):
    """Samples a tracker put off the ball: runs of one to :data:`GLITCH_MAX_RUN` samples that leave the
    smooth path of their neighbours and come back.

    The :data:`GLITCH_NEIGHBOURS` samples on each side of a run are fitted with one quadratic in t
    (a free flight, or the ball at rest); the run is a glitch when those neighbours lie on it within
    :data:`GLITCH_SMOOTH_SIGMAS` noise sigmas and every sample of the run lies off it, on one side, by
    :data:`GLITCH_SIGMAS` sigmas, as many times the neighbours' own scatter and two resolution steps.
    A ball in flight or at rest cannot do that (it needs an acceleration far beyond g for a sample or
    three); a contact can, below the path, and only there, at the floor: a run below the path is no
    glitch unless its lowest sample lies above the floor (the record's lowest percentile of heights) by
    twice its depth. Heights point up (as the readers give them).
    Only runs whose neighbours are equally spaced in time are judged. The neighbours may hold one sample
    off the quadratic (the one that fits worst is left out when that helps: two glitches close together
    hide each other otherwise); each pass mends the glitches found with the quadratic, and the next looks
    again (:data:`GLITCH_PASSES`). Longer runs are tried first (all their samples must be off).

    Parameters
    ----------
    t : array_like
        sample times [s], increasing
    y : array_like
        heights (any length unit; pixels work)
    sigma : float or None
        noise of one sample [unit of ``y``]; None: :func:`third_difference_sigma` (floored at the
        resolution step / sqrt(12))

    Returns
    -------
    list of (int, int, float)
        ``(start, stop, offset)``: index ranges of the glitches (stop exclusive), in order, and the
        largest distance of a sample of each from its neighbours' path [unit of ``y``]
    """
    t = np.asarray(t, dtype=float)
    y = np.asarray(y, dtype=float)
    k = GLITCH_NEIGHBOURS
    n = y.size
    if n < 2 * k + 1:
        return []
    quantum = resolution_step(y)
    if sigma is None:
        sigma = third_difference_sigma(t, y) or 0.0
    sigma = max(float(sigma), quantum / math.sqrt(12.0))
    if not sigma > 0:
        return []
    dt = np.diff(t)
    step = float(np.median(dt))
    even = np.abs(dt - step) <= 0.01 * step
    taken = np.zeros(n, dtype=bool)
    found = []
    work = y.copy()
    floor = float(np.percentile(y, 1.0))   # the contacts' level (heights up)
    for _ in range(GLITCH_PASSES):      # a glitch among another's neighbours is found once that one is mended
        new = 0
        for run in range(GLITCH_MAX_RUN, 0, -1):    # all of a longer run must be off: it goes first
            width = 2 * k + run
            if n < width:
                break
            offsets = np.r_[np.arange(-k, 0), np.arange(run, run + k)].astype(float)
            windows = np.lib.stride_tricks.sliding_window_view(work, width)  # windows[i] = work[i:i + width]
            around = np.concatenate([windows[:, :k], windows[:, k + run:]], axis=1)
            # the quadratic through all neighbours, or through all but the one that fits worst (a glitch
            # among them, found in the next pass once this one is mended); that one is tried only where the
            # first leaves the neighbours or the run off the path (near a bounce, a glitch): elsewhere all of
            # them agree
            scatter, predicted = _neighbours_path(around, offsets, run, np.ones(2 * k, dtype=bool))
            odd = np.flatnonzero((scatter > GLITCH_SMOOTH_SIGMAS * sigma) | np.any(
                np.abs(windows[:, k:k + run] - predicted) >= GLITCH_SMOOTH_SIGMAS * sigma, axis=1))
            for drop in range(2 * k):
                use = np.arange(2 * k) != drop
                s_j, p_j = _neighbours_path(around[odd], offsets, run, use)
                better = s_j < scatter[odd]
                scatter[odd[better]], predicted[odd[better]] = s_j[better], p_j[better]
            off = windows[:, k:k + run] - predicted
            size = np.min(np.abs(off), axis=1)
            one_side = np.all(np.sign(off) == np.sign(off[:, :1]), axis=1)
            regular = np.all(np.lib.stride_tricks.sliding_window_view(even, width - 1), axis=1)
            # below the path is where a contact takes the ball: there only a run clear of the floor by more
            # than its depth is no contact
            lowest = np.min(windows[:, k:k + run], axis=1)
            contact = (off[:, 0] < 0) & (lowest - floor < 2.0 * size)
            hit = (regular & one_side & ~contact & (scatter <= GLITCH_SMOOTH_SIGMAS * sigma)
                   & (size >= GLITCH_SIGMAS * sigma) & (size >= GLITCH_SIGMAS * scatter) & (size >= 2.0 * quantum))
            for i in np.flatnonzero(hit):
                a, b = int(i) + k, int(i) + k + run
                if not taken[a:b].any():
                    taken[a:b] = True
                    work[a:b] = predicted[i]      # mended, for the runs near it in the next pass
                    found.append((a, b, float(np.max(np.abs(off[i])))))
                    new += 1
        if not new:
            break
    runs = []
    for a, b, size in sorted(found):      # a glitch found in two pieces is one
        if runs and a <= runs[-1][1]:
            runs[-1] = (runs[-1][0], max(b, runs[-1][1]), max(size, runs[-1][2]))
        else:
            runs.append((a, b, size))
    return runs


def _neighbours_path(around, offsets, run, use):
    """Scatter of the neighbours ``around[:, use]`` about their least-squares quadratic, and the run's
    samples it predicts (:func:`tracker_glitches`)."""
    design = np.vander(offsets[use], 3)
    fit = np.linalg.pinv(design)
    used = around if use.all() else around[:, use]
    # contiguous right-hand factors: a transposed view makes the product 7 times slower
    resid = used @ np.ascontiguousarray((np.eye(design.shape[0]) - design @ fit).T)
    scatter = np.sqrt(np.einsum("ij,ij->i", resid, resid) / (int(use.sum()) - 3))
    return scatter, used @ np.ascontiguousarray((np.vander(np.arange(run, dtype=float), 3) @ fit).T)


def third_difference_sigma(t, y):
    """Robust noise σ of one sample of a near-parabolic series (a trajectory's heights [m], a
    video's image rows [px]; the unit of ``y``), from its third differences, which vanish on a
    parabola: 1.4826 x their median absolute deviation over sqrt(20) (the third difference of
    white noise has variance 20 σ²), over runs of four equally spaced samples only. A bounce
    or a lost frame spoils a few of them; the median ignores those.

    Parameters
    ----------
    t : ndarray
        sample times [s]
    y : ndarray
        the series (any unit)

    Returns
    -------
    float or None
        σ in the unit of ``y``; None with fewer than 8 samples or 5 usable differences, or when
        σ is below a millionth of the range of ``y`` (rounding: a simulation, no measurement)
    """
    t = np.asarray(t, dtype=float)
    y = np.asarray(y, dtype=float)
    if t.size < 8:
        return None
    dt = np.diff(t)
    step = np.median(dt)
    d3 = np.diff(y, 3)
    # keep only third differences over four equally spaced samples
    even = np.abs(dt - step) <= 0.01 * step
    ok = even[:-2] & even[1:-1] & even[2:]
    d3 = d3[ok]
    if d3.size < 5:
        return None
    sigma = _mad_sigma(d3)
    for _ in range(THIRD_DIFFERENCE_PASSES):
        # a bounce spoils the three or four differences around it, far beyond the noise: at 30 frames/s
        # with bounces every 10-15 frames they are a quarter of all and inflated the median absolute
        # deviation by 25-50 % (1.5 mm planted, 1.85-2.28 mm measured); the noise's own are kept
        kept = d3[np.abs(d3 - np.median(d3)) <= THIRD_DIFFERENCE_CUT * sigma * math.sqrt(20.0)]
        if kept.size < 5:
            break
        sigma = _mad_sigma(kept) / THIRD_DIFFERENCE_CUT_BIAS
    return float(sigma) if sigma > 1e-6 * float(np.ptp(y)) else None


#: Third differences beyond this many of their standard deviations are a bounce's or the release's, not the
#: noise's (:func:`third_difference_sigma`), cut in :data:`THIRD_DIFFERENCE_PASSES` passes.
THIRD_DIFFERENCE_CUT = 4.0
THIRD_DIFFERENCE_PASSES = 2
#: The median absolute deviation of a normal sample cut at +-4 sigma over that of the whole: sigma is
#: divided by it (a cut normal's MAD is a hair smaller).
THIRD_DIFFERENCE_CUT_BIAS = 0.99993


def _mad_sigma(d3):
    """σ of one sample from third differences: 1.4826 x their median absolute deviation over sqrt(20)."""
    return 1.4826 * float(np.median(np.abs(d3 - np.median(d3)))) / math.sqrt(20.0)


def prominent_minima(y, prominence):
    """Indices of the local minima of ``y`` whose prominence is at least ``prominence``.

    The prominence of a minimum is how far it lies below the lower of the two highest
    points between it and the nearest lower sample on either side (or the end of the
    record), as ``scipy.signal.find_peaks(-y, prominence=...)`` defines it; a flat
    minimum (equal samples) counts once, at its middle. Written with numpy alone: importing
    scipy.signal costs more than a whole ``vrcal discover`` run.

    Parameters
    ----------
    y : array_like
        the series (heights [m], any unit)
    prominence : float
        least prominence, in the unit of ``y``

    Returns
    -------
    ndarray of int
    """
    y = np.asarray(y, dtype=float)
    n = y.size
    if n < 3:
        return np.zeros(0, dtype=int)
    # candidate minima: a sample lower than its left neighbour that starts a plateau closed by a rise
    d = np.diff(y)
    nonzero = np.flatnonzero(d != 0)
    down = np.flatnonzero(d < 0) + 1                  # y[i] < y[i-1]
    k = np.searchsorted(nonzero, down)                # first change at or after i
    ok = k < nonzero.size
    down, k = down[ok], k[ok]
    ends = nonzero[k]
    rises = d[ends] > 0
    starts, ends = down[rises], ends[rises]           # y[starts..ends] equal, y[ends + 1] > y[ends]
    if starts.size == 0:
        return np.zeros(0, dtype=int)
    values = y.tolist()
    prev_lower = _previous_lower(values)
    next_lower = _previous_lower(values[::-1])[::-1]
    next_lower = [n - 1 - j if j >= 0 else n for j in next_lower]
    table = _range_max_table(y)
    left_lo = np.array([prev_lower[i] + 1 for i in starts])     # first sample after the nearest lower one
    right_hi = np.array([next_lower[j] - 1 for j in ends])      # last sample before the next lower one
    left = np.where(starts > left_lo, _range_max(table, left_lo, starts - 1), -np.inf)
    right = np.where(right_hi > ends, _range_max(table, ends + 1, right_hi), -np.inf)
    prom = np.minimum(left, right) - y[starts]
    keep = prom >= prominence
    return ((starts[keep] + ends[keep]) // 2).astype(int)


def _previous_lower(values):
    """For each i, the last j < i with values[j] < values[i] (-1 when none): one pass with a stack."""
    out, stack = [-1] * len(values), []
    for i, v in enumerate(values):
        while stack and values[stack[-1]] >= v:
            stack.pop()
        out[i] = stack[-1] if stack else -1
        stack.append(i)
    return out


def _range_max_table(y):
    """Sparse table of running maxima: level j holds max(y[i : i + 2**j])."""
    table = [np.asarray(y, dtype=float)]
    span = 1
    while 2 * span <= y.size:
        prev = table[-1]
        table.append(np.maximum(prev[:-span], prev[span:]))
        span *= 2
    return table


def _range_max(table, lo, hi):
    """max(y[lo..hi]) (inclusive) for arrays of ranges with lo <= hi (other entries are garbage)."""
    lo = np.asarray(lo)
    hi = np.maximum(np.asarray(hi), lo)
    length = hi - lo + 1
    level = np.floor(np.log2(np.maximum(length, 1))).astype(int)
    out = np.empty(lo.size)
    for j in np.unique(level):
        m = level == j
        row = table[j]
        out[m] = np.maximum(row[lo[m]], row[hi[m] - (1 << j) + 1])
    return out


class ImpactChains(NamedTuple):
    """What :func:`impact_chains` finds in a series of impact times."""

    chains: tuple     # ((first, last), ...) indices (inclusive) into the events of consecutive bounces
    kept: np.ndarray  # indices of the events kept (not echoes)
    rejected: tuple   # ((index, time_s, reason), ...) events in no chain
    anomalies: tuple  # ((index, reason), ...) every anomaly found, at the event it concerns


#: Most ratios whose pairs give the Theil-Sen slope of :func:`_trend_ratio` (evenly spread over the record).
_THEIL_SEN_POINTS = 400


def _trend_ratio(q):
    """Robust straight line through ln q (Theil-Sen over the plausible ratios): expected q_i."""
    i = np.arange(q.size, dtype=float)
    ok = (q > 0.3) & (q < 1.0)
    if ok.sum() < 2:
        return np.full(q.size, float(np.median(q)))
    level, slope = _theil_sen(i[ok], np.log(q[ok]))
    return np.exp(level + slope * i)


def _theil_sen(x, v, min_points=4):
    """``(level, slope)`` of the robust straight line ``v = level + slope x`` (Theil-Sen: the median of the
    pairwise slopes, at most :data:`_THEIL_SEN_POINTS` points evenly spread; flat with fewer than
    ``min_points`` points)."""
    n = x.size
    if n > _THEIL_SEN_POINTS:    # the slope from evenly spread points: pairs grow as the square
        pick = np.linspace(0, n - 1, _THEIL_SEN_POINTS).round().astype(int)
        x, v = x[pick], v[pick]
    a, b = np.triu_indices(x.size, 1)
    step = x[b] - x[a]
    apart = step != 0    # points at one x (the same interval in two drops) give no slope
    slope = float(np.median((v[b] - v[a])[apart] / step[apart])) if apart.any() else 0.0
    slope = 0.0 if n < min_points else slope    # too few points for a trend
    return float(np.median(v - slope * x)), slope


#: Timing noise of an acoustic stopwatch's impact times [s] (phyphox-like): what the readers assume
#: unless the times' own grid is coarser (:func:`time_grid`), and what ``vrcal discover`` judges at.
TIMING_SIGMA_S = 2e-4


#: How far a real ball's first interval ratio lies off the line of the later ones beyond their own
#: scatter (1 %: up to 0.8 % in the phyphox records of ``../shared/data``, whose later ratios scatter by 0.1-0.6 %).
FIRST_RATIO_SPREAD = 0.01
#: Standard deviations off the later bounces' line that make a first event no impact (:func:`leading_intruder`).
LEADING_SIGMAS = 4.0


#: How :func:`leading_intruder`'s reasons start.
NOT_AN_IMPACT = "no impact of the bounce sequence"


def leading_intruder(t_s, *, timing_sigma_s=TIMING_SIGMA_S, n_sigma=LEADING_SIGMAS):
    """Why the first of a series of impact times is no impact of the bounce sequence (a clap or a word
    0.3-0.6 s before the release), or None when it may be one; the reason starts with
    :data:`NOT_AN_IMPACT`.

    The first interval ratio ``q_0 = dt_1 / dt_0`` is compared with the ratio the later bounces give
    for a flight as long as ``dt_0``: the robust straight line (Theil-Sen) through their ``ln q_i``
    against the interval before each, ``dt_i`` (which grows with the impact speed), at ``dt_0`` (flat, their
    median, with three of them: a line through three points passes through two and shows no scatter), and
    never above a ratio of 1, which no floor gives. Its
    standard deviation there is ``sigma = sqrt(u_0^2 + s^2 (1 + l) + FIRST_RATIO_SPREAD^2)``: ``u_0``
    the ratio's timing uncertainty (``sqrt(2) timing_sigma_s sqrt(1/dt_0^2 + 1/dt_1^2)``), ``s`` the
    later ratios' own scatter about their line (1.4826 times the median absolute residual), ``l`` the
    line's prediction variance one point beyond them over ``s^2`` (``1/m + (dt_0 - mean)^2 / S_xx``), and
    :data:`FIRST_RATIO_SPREAD`. So the test scales with the record: a clean recording (0.2 ms timing,
    ratios steady to 0.1 %) refuses a clap 5 % off the line, a ball whose bounces scatter by 2 % keeps a
    first ratio 6 % off it.

    The physics is one-sided. Air drag, an epsilon that falls with the impact speed and a finite contact
    all lower the ratios of the fastest (first) bounces, by more than a straight line says when they grow
    faster than linearly with the speed: a first ratio *below* the line is an intruder only beyond
    ``n_sigma sigma`` plus the line's own change from the second interval to the first (the curvature may
    double it). None of them makes the first ratio higher than the later ones, but a law whose ``1 - eps``
    grows slower than linearly with the speed (``1 - eps ~ v^p``, ``p < 1``: viscoelastic spheres have
    ``p = 1/5``) flattens at the fastest bounces, so the first ratio may lie well *above* the straight
    line (7 % for a tennis ball with ``p = 0.3`` dropped from 2.5 m): one above the line is judged against
    the ratio the line gives at the second interval (the fastest later bounce, which an epsilon that
    never rises with the speed makes the highest a first ratio can reach) and is an intruder beyond
    ``n_sigma sigma`` above that. Judged from six events on (three later ratios).

    Parameters
    ----------
    t_s : array_like
        event times [s], increasing
    timing_sigma_s : float
        standard deviation of the timing of one event [s]
    n_sigma : float
        standard deviations off the line that make the first event an intruder

    Returns
    -------
    str or None
    """
    t = np.asarray(t_s, dtype=float)
    if t.size < 6:
        return None
    dt = np.diff(t)
    if not np.all(dt > 0):
        return None
    q = dt[1:] / dt[:-1]
    u = np.sqrt(2.0) * timing_sigma_s * np.hypot(1.0 / dt[1:], 1.0 / dt[:-1])
    judged = (u < 0.25) & (q > 0.3) & (q < 1.0)
    judged[0] = False
    x, v = dt[:-1][judged], np.log(q[judged])
    if x.size < 3:
        return None
    level, slope = _theil_sen(x, v)   # flat through 3 ratios: a line through them leaves no scatter to see
    s = 1.4826 * float(np.median(np.abs(v - level - slope * x)))
    spread = float(np.sum((x - x.mean()) ** 2))
    line = 1.0 / x.size + ((dt[0] - x.mean()) ** 2 / spread if spread > 0 else 0.0)
    sigma = math.sqrt(u[0] ** 2 + s ** 2 * (1.0 + line) + FIRST_RATIO_SPREAD ** 2)
    expected = min(level + slope * dt[0], 0.0)   # no ratio above 1 on a floor, however the line runs
    dev = math.log(q[0]) - expected
    if not (math.isfinite(dev) and math.isfinite(sigma)):
        return None
    if dev > 0:   # above the line: judged against the ratio of the fastest later bounce, which none exceeds
        expected = min(max(expected, level + slope * dt[1]), 0.0)
        dev = max(math.log(q[0]) - expected, 0.0)
    bend = abs(slope * (dt[0] - dt[1])) if dev < 0 else 0.0
    if abs(dev) <= n_sigma * sigma + bend:
        return None
    side = "below" if dev < 0 else "above"
    return (f"{NOT_AN_IMPACT}: the first interval ratio "
            f"{q[0]:.3f} lies {abs(math.expm1(dev)):.1%} {side} the {math.exp(expected):.3f} the later bounces give "
            f"({(abs(dev) - bend) / sigma:.1f} standard deviations: their ratios scatter by {s:.2%}, the timing by "
            f"{u[0]:.2%}, a first bounce by {FIRST_RATIO_SPREAD:.0%}): a clap or a sound before the drop; left out")


#: Lowest bounce [m] the longest flight of a recorded drop rises to: a ball dropped from a few mm is no drop
#: test (and a voice's pulses, 3-12 ms apart, chain into "flights" of tens of ms that rise a few mm).
MIN_BOUNCE_M = 0.01
#: How :func:`no_recorded_drop`'s reasons start.
NOT_A_DROP = "no recorded drop"
#: Periods of a voice's pitch pulses or a mains hum [s] (400 Hz down to 50 Hz).
PULSE_PERIODS_S = (2.5e-3, 20e-3)


def bounce_height_m(flight_s, g_m_per_s2=STANDARD_GRAVITY_M_PER_S2):
    """Height a ball rises to in a free flight of ``flight_s`` from the floor back to it, ``g T^2 / 8``.

    Parameters
    ----------
    flight_s : float or ndarray
        flight time [s]
    g_m_per_s2 : float
        gravity [m/s^2]

    Returns
    -------
    float or ndarray
        height [m] (inf for a flight too long for a float's square: an absurd time read from a file)
    """
    with np.errstate(over="ignore"):
        return g_m_per_s2 * np.asarray(flight_s, dtype=float) ** 2 / 8.0


def voice_pulses(t_s, level_db=None, *, periods_s=PULSE_PERIODS_S, min_intervals=3, tolerance=0.15, max_ratio=0.98,
                 louder_db=5.0):
    """Which sound events are a voice's (or a hum's) pitch pulses: a mask over ``t_s``.

    A voiced sound is a train of pulses one pitch period apart (2.5-20 ms, :data:`PULSE_PERIODS_S`), the
    period gliding slowly (a voice's 130 Hz pulses in a probe's recording: 6.9-8.7 ms, 1 % from one to the
    next); each pulse is a sound event, hundreds in a few seconds of talking. An event is one when it
    belongs to a run of at least ``min_intervals`` intervals in ``periods_s``, each within ``tolerance``
    (relative) of the one before. A bouncing ball's last bounces can come that close, but their intervals
    shrink by epsilon at each bounce: a run whose intervals all shrink, by ``max_ratio`` or more on average
    (:func:`vrcal.measurements.sound.bounce_sequence`'s limit), is a ball's and not marked. An impact heard
    through the talking can fall on a pulse's place; it is louder than the pulses about it (an impact 7 dB
    over its train in a probe's recording), so an event ``louder_db`` over the median of the three events on
    either side of it in its train is not marked.

    Parameters
    ----------
    t_s : array_like
        event times [s], increasing
    level_db : array_like or None
        the events' levels [dB] (None: every event of a train is marked)
    periods_s : (float, float)
        shortest and longest pitch period [s]
    min_intervals : int
        fewest intervals of a train
    tolerance : float
        largest relative change of one interval from the one before in a train
    max_ratio : float
        a run whose every interval is shorter than the one before, by this mean ratio or less, is a
        ball's bounces
    louder_db : float
        an event of a train this much louder than the events about it is not marked [dB]

    Returns
    -------
    ndarray of bool
    """
    t = np.asarray(t_s, dtype=float)
    mark = np.zeros(t.size, dtype=bool)
    dt = np.diff(t)
    if dt.size < min_intervals:
        return mark
    lv = None if level_db is None else np.asarray(level_db, dtype=float)
    in_band = (dt >= periods_s[0]) & (dt <= periods_s[1])
    ratio = dt[1:] / np.where(dt[:-1] > 0, dt[:-1], np.inf)
    steady = (ratio >= 1.0 / (1.0 + tolerance)) & (ratio <= 1.0 + tolerance)
    # link[i]: intervals i and i + 1 belong to one train
    link = in_band[:-1] & in_band[1:] & steady
    i = 0
    while i < dt.size:
        if not in_band[i]:
            i += 1
            continue
        j = i
        while j < link.size and link[j]:
            j += 1
        # intervals i..j form a run
        if j - i + 1 >= min_intervals:
            r = ratio[i:j]
            ball = bool(np.all(r < 1.0)) and float(np.exp(np.mean(np.log(r)))) <= max_ratio
            if not ball:
                mark[i:j + 2] = True
                if lv is not None:
                    for k in range(i, j + 2):
                        about = np.r_[lv[max(i, k - 3):k], lv[k + 1:min(j + 2, k + 4)]]
                        if about.size and lv[k] > float(np.median(about)) + louder_db:
                            mark[k] = False
        i = j + 1
    return mark


#: Periods of a steady beat [s]: music's quarter and eighth notes (300 down to 30 bpm), a clock's ticks.
BEAT_PERIODS_S = (0.1, 2.0)


def steady_beat(t_s, *, periods_s=BEAT_PERIODS_S, tolerance_s=3e-3, min_events=8, min_filled=0.5):
    """Which sound events keep a steady beat (music's drums, a clock): a mask over ``t_s``.

    A beat puts its events on a grid t_0 + k P: the best grid through any event and a period taken from the
    intervals to its next three events (``periods_s``), holding the most events within ``tolerance_s``, is
    a beat when it holds at least ``min_events`` events and at least ``min_filled`` of its slots between its
    first and last event. A bouncing ball is never on a grid (its intervals shrink by epsilon), but a
    drum's hits 4, 2 and 1 eighth notes apart shrink by 0.5 like a ball's, and with the ball's impacts
    between them made a chain of ratio 0.5 (epsilon 0.500 "explained" for a tennis ball's 0.76). A ball's
    impact falls on a beat's grid by chance once in P / (2 ``tolerance_s``) (once in 40 for a 124 bpm
    eighth note) and is then left out with it. The beat found is taken out and the rest searched again.

    Parameters
    ----------
    t_s : array_like
        event times [s], increasing
    periods_s : (float, float)
        shortest and longest period of a beat [s]
    tolerance_s : float
        largest distance of an event from its grid slot [s]
    min_events : int
        fewest events of a beat
    min_filled : float
        smallest share of a beat's slots (first to last event) holding an event

    Returns
    -------
    ndarray of bool
    """
    t = np.asarray(t_s, dtype=float)
    mark = np.zeros(t.size, dtype=bool)
    while True:
        free = np.flatnonzero(~mark)
        best = None
        for a, i in enumerate(free):
            for b in free[a + 1:a + 4]:
                period = t[b] - t[i]
                if not periods_s[0] <= period <= periods_s[1]:
                    continue
                k = np.round((t[free] - t[i]) / period)
                on = free[np.abs(t[free] - t[i] - k * period) <= tolerance_s]
                if on.size >= min_events and (best is None or on.size > best[0].size):
                    # the slots from its first to its last event, of which min_filled must hold one
                    k_on = np.round((t[on] - t[i]) / period)
                    slots = int(k_on.max() - k_on.min()) + 1
                    if on.size >= min_filled * slots:
                        best = (on, period)
        if best is None:
            return mark
        mark[best[0]] = True


def pulse_period(dt_s, *, periods_s=PULSE_PERIODS_S, max_multiple=12, tolerance=0.3):
    """``(period, multiples)`` when every interval is a whole multiple of one period of a voice or a hum
    (``dt_i = n_i P`` within ``tolerance`` of a period, ``n_i`` at most ``max_multiple``, ``P`` in
    ``periods_s``), else None. ``P`` is tried as the shortest interval over 1, 2, 3.

    Parameters
    ----------
    dt_s : array_like
        intervals between events [s]
    periods_s : (float, float)
        shortest and longest period tried [s]
    max_multiple : int
        largest whole multiple accepted
    tolerance : float
        largest deviation from a whole multiple [periods]

    Returns
    -------
    (float, ndarray of int) or None
    """
    dt = np.asarray(dt_s, dtype=float)
    if dt.size < 2 or not np.all(dt > 0):
        return None
    for k in (1, 2, 3):
        period = float(dt.min()) / k
        if not periods_s[0] <= period <= periods_s[1]:
            continue
        n = np.round(dt / period)
        if n.max() <= max_multiple and np.all(np.abs(dt / period - n) <= tolerance):
            return float(dt.sum() / n.sum()), n.astype(int)
    return None


def no_recorded_drop(t_s, *, min_bounce_m=MIN_BOUNCE_M, g_m_per_s2=STANDARD_GRAVITY_M_PER_S2):
    """Why a chain of impact times is no recorded drop, or None when it may be one; the reason starts
    with :data:`NOT_A_DROP`.

    A drop's longest flight (the first one recorded) rises :func:`bounce_height_m`; below
    ``min_bounce_m`` (:data:`MIN_BOUNCE_M`) the "impacts" are no ball's. The pulses of a voice (or a
    hum) are such a chain: their intervals, whole multiples of one period (:func:`pulse_period`), can
    shrink by a steady-looking ratio (9, 7, 5, 4, 3, 2 periods), but tens of ms at most.

    Parameters
    ----------
    t_s : array_like
        impact times [s], increasing (at least two)
    min_bounce_m : float
        lowest bounce of a recorded drop's longest flight [m]
    g_m_per_s2 : float
        gravity [m/s^2]

    Returns
    -------
    str or None
    """
    dt = np.diff(np.asarray(t_s, dtype=float))
    if dt.size == 0:
        return None
    longest = float(dt.max())
    height = float(bounce_height_m(longest, g_m_per_s2))
    if height >= min_bounce_m:
        return None
    why = f"{NOT_A_DROP}: its longest flight, {longest * 1e3:.1f} ms, is a bounce {height * 1e3:.1f} mm high"
    pulses = pulse_period(dt)
    if pulses is not None:
        period, n = pulses
        why += f", its intervals {', '.join(str(int(k)) for k in n)} times {period * 1e3:.1f} ms (a voice or a hum)"
    return why


def _after_missed(dt, r, tolerance, max_missed):
    """The interval expected after each interval ``dt[k-1]`` (k >= 2) that held missed impacts.

    A flight f before a span holding j missed impacts: the span is f r (1 + r + ... + r^j), the
    flight after it f r^(j+2). ``inf`` where ``dt[k-1]`` is no such span (against ``dt[k-2]``).
    Without it the flight after a missed impact at a record's end (no interval after it to judge
    from) is short against the long span and was called an echo.
    """
    ratio = dt[1:-1] / (r * dt[:-2])
    spans = np.cumsum(r ** np.arange(max_missed + 1))[1:]           # 1+r, 1+r+r^2, ...
    with np.errstate(divide="ignore", invalid="ignore"):   # a zero interval fits no span (nan or inf: no fit)
        miss = np.abs(np.log(ratio[:, None] / spans[None, :]))
    j = np.argmin(miss, axis=1)
    fits = (miss[np.arange(j.size), j] < np.log1p(tolerance)) & (ratio > 1.0 + tolerance)
    return np.where(fits, dt[:-2] * r ** (j + 3.0), np.inf)


def impact_chains(t_s, *, tolerance=0.12, timing_sigma_s=TIMING_SIGMA_S, echo_fraction=0.5, max_missed=3, labels=None,
                  leading=False):
    """Split a series of impact times into chains of consecutive bounces.

    Between impacts the flight times dt_i = t_{i+1} - t_i shrink geometrically,
    dt_{i+1} = q_i dt_i with q_i close to epsilon and changing slowly (air drag, a
    speed-dependent epsilon and a finite contact all move it gradually). Found here:

    * an echo or spurious event: an interval shorter than ``echo_fraction`` times the
      expected one (an event right after the first one is judged from the interval after
      it). The event is removed and the chain goes on;
    * every ratio q_i off the robust trend of the ratios (a Theil-Sen line through ln q)
      by more than ``tolerance + 4 u_i`` (``u_i = sqrt(2) timing_sigma_s sqrt(1/dt_i^2 +
      1/dt_{i+1}^2)``, the relative timing uncertainty of the ratio; 5 u_i), or above 1 (a flight
      longer than the one before it: impossible for a ball bouncing on a floor): a missed
      impact (the interval is about (1 + q + ... + q^k) times the expected one), a bounce
      that lost or gained energy it should not have (a kick, a second surface, a late
      event). A ratio whose timing uncertainty u_i is 0.25 or more (intervals of a few
      timing sigmas, at a record's end) cannot be judged and is never called an anomaly.

    The chains are the runs of consecutive good ratios (a good ratio links three events):
    a chain ends before an anomaly and the next one starts after it; they may share the
    event between them (a lossy bounce leaves both its neighbours' flights intact).

    Parameters
    ----------
    t_s : array_like
        impact times [s], strictly increasing
    tolerance : float
        relative deviation of a ratio from the trend still counted as clean
    timing_sigma_s : float
        standard deviation of the timing of one impact [s]
    echo_fraction : float
        an interval shorter than this fraction of the expected one is an echo
    max_missed : int
        most consecutive missed impacts tried when explaining a long interval
    labels : sequence of str or None
        how to name each event in the reasons ("event 10 (line 11)"); default "event i+1"
    leading : bool
        also judge whether the first event (after the echoes) is an impact at all
        (:func:`leading_intruder`: a clap before the release is removed like an echo); for events
        detected in a recording or by a stopwatch, not for the bounces of a trajectory

    Returns
    -------
    ImpactChains
    """
    t = np.asarray(t_s, dtype=float)
    n = t.size
    name = (lambda i: labels[i]) if labels is not None else (lambda i: f"event {i + 1}")
    kept = np.arange(n)
    anomalies = []
    # 1. echoes, one at a time
    while kept.size >= 4:
        dt = np.diff(t[kept])
        q = dt[1:] / dt[:-1]
        plausible = q[(q > 0.3) & (q < 1.0)]
        r = float(np.median(plausible if plausible.size else q))
        # expected from the interval before and from the one after: an echo is short against both
        # (after a missed impact the next interval is short only against the long one before it)
        before = np.concatenate([[np.inf], r * dt[:-1]])
        before[2:] = np.minimum(before[2:], _after_missed(dt, r, tolerance, max_missed))
        after = np.concatenate([dt[1:] / r, [np.inf]])
        expected = np.minimum(before, after)
        short = np.flatnonzero(dt + 4.0 * np.sqrt(2.0) * timing_sigma_s < echo_fraction * expected)
        if short.size == 0:
            break
        k = int(short[0])
        if k == 0 and dt.size >= 3 and abs(np.log(dt[2] / (r * (dt[0] + dt[1])))) > np.log1p(tolerance + 0.1):
            break   # the first interval is short but the event after it does not look spurious
        idx = int(kept[k + 1])
        anomalies.append((idx, f"{name(idx)} at t = {t[idx]:.4f} s is an echo or a spurious event: only "
                               f"{dt[k] * 1e3:.1f} ms after {name(int(kept[k]))}, where about "
                               f"{expected[k] * 1e3:.0f} ms were expected; removed"))
        kept = np.delete(kept, k + 1)
    while leading and kept.size >= 6:
        why = leading_intruder(t[kept], timing_sigma_s=timing_sigma_s)
        if why is None:
            break
        anomalies.append((int(kept[0]), f"{name(int(kept[0]))} at t = {t[kept[0]]:.4f} s is {why}"))
        kept = kept[1:]
    m = kept.size
    if m < 4:
        chains = ((0, m - 1),) if m >= 3 else ()
    else:
        dt = np.diff(t[kept])
        q = dt[1:] / dt[:-1]
        u = np.sqrt(2.0) * timing_sigma_s * np.hypot(1.0 / dt[1:], 1.0 / dt[:-1])
        trend = _trend_ratio(q)
        with np.errstate(invalid="ignore", divide="ignore"):   # a zero interval: its ratio is not judged (u = inf)
            dev = np.log(q / trend)
        bad = (np.abs(dev) > np.log1p(tolerance + 5.0 * u)) | (q > 1.0 + 5.0 * u)
        # a ratio of intervals that the timing noise can halve or double tells nothing: the linear
        # bound above fails there (u ~ 0.4 at 1 ms intervals with 0.2 ms jitter), so such short
        # intervals at a record's end are kept as they come instead of being called anomalies
        bad &= u < 0.25
        for i in np.flatnonzero(bad):
            # ratio i = dt[i+1] / dt[i] concerns the bounce at kept event i+1 and the flight after it
            e0, e1, e2 = (int(kept[i + j]) for j in range(3))
            ratio = q[i] / trend[i]
            spans = np.cumsum(trend[i] ** np.arange(max_missed + 1))[1:]   # 1+q, 1+q+q^2, ...
            n_missed = int(np.argmin(np.abs(np.log(ratio / spans)))) + 1
            flight = f"the flight from {name(e1)} to {name(e2)} ({dt[i + 1]:.4f} s)"
            if ratio > 1.0 and abs(np.log(ratio / spans[n_missed - 1])) < np.log1p(tolerance + 5.0 * u[i]):
                what = "a missed impact" if n_missed == 1 else f"{n_missed} missed impacts"
                why = f"{flight} is {ratio:.2f} x the expected {trend[i] * dt[i]:.4f} s: {what}"
            elif q[i] > 1.0:
                why = (f"{flight} is longer than the one before it ({dt[i]:.4f} s): impossible for a ball "
                       f"bouncing on a floor (epsilon > 1): a late or spurious event, or missed impacts")
            elif bad[i - 1] if i > 0 else False:
                continue   # the second ratio of an anomaly already named
            else:
                why = (f"{flight} is {ratio:.2f} x the expected {trend[i] * dt[i]:.4f} s (interval ratio "
                       f"{q[i]:.3f}, trend {trend[i]:.3f}): the bounce at {name(e1)} does not belong "
                       f"(a kick, a second surface, a late event)")
            anomalies.append((e1, why))
        chains = []
        i = 0
        while i < bad.size:
            if bad[i]:
                i += 1
                continue
            j = i
            while j + 1 < bad.size and not bad[j + 1]:
                j += 1
            chains.append((i, j + 2))
            i = j + 1
        chains = tuple(chains)
    in_chain = np.zeros(n, dtype=bool)
    for a, b in chains:
        in_chain[kept[a:b + 1]] = True
    why = dict(anomalies)
    marked = sorted(why)

    def reason(i):
        if i in why:
            return why[i]
        k = bisect.bisect_left(marked, i)      # the anomalies before event i: marked[:k]
        after = f" (after the anomaly at {name(marked[k - 1])})" if k else ""
        return "in no chain of three or more consecutive bounces" + after

    rejected = tuple((int(i), float(t[i]), reason(int(i))) for i in range(n) if not in_chain[i])
    chains = tuple((int(kept[a]), int(kept[b])) for a, b in chains)
    return ImpactChains(chains, kept, rejected, tuple(sorted(anomalies)))


def detect_impact_anomalies(t_s, **options):
    """Find missed impacts and echoes in a series of impact times (the first chain of
    :func:`impact_chains`).

    Returns
    -------
    n_clean : int
        number of leading impacts of the first chain when it starts at the first impact and
        no echo interrupts it (all of them when nothing is found)
    rejected : tuple
        ``((index, time_s, reason), ...)`` for impacts ``n_clean .. n - 1``
    """
    t = np.asarray(t_s, dtype=float)
    n = t.size
    if n < 3:
        return n, ()
    found = impact_chains(t, **options)
    if not found.anomalies and len(found.chains) <= 1 and not found.rejected:
        return n, ()
    first_bad = min([i for i, _ in found.anomalies] + [i for i, _, _ in found.rejected] + [n])
    n_clean = first_bad if found.chains and found.chains[0][0] == 0 else 0
    why = dict(found.anomalies)
    first = min(why) if why else n_clean
    rejected = tuple((j, float(t[j]), why.get(j, f"after the anomaly at event {first + 1} (not fitted)"))
                     for j in range(n_clean, n))
    return n_clean, rejected
