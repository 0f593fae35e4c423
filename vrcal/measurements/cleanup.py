"""Clean-up of raw records, one pure function each: the still segment before release,
duplicated video frames, and missed impacts and echoes in a series of impact times.
"""

from __future__ import annotations

import numpy as np


def detect_release_index(y, *, window=10, n_sigma=5.0, min_still=3, n_fit=400):
    """Index of the first sample after the still segment that precedes a release.

    The still level at sample i is the median of the ``window`` samples before it. The
    departure is the first sample that, with the two after it, lies more than
    ``n_sigma`` noise sigmas (and at least two resolution steps) from that level on
    the same side. The release is then backed up to the start of the departure: a
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

    Returns
    -------
    int
        the release index, 0 when the record does not start with a still segment.

    Notes
    -----
    The noise sigma is estimated robustly from second differences of the whole record,
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
    step = np.abs(np.diff(y))
    step = step[step > 0]
    quantum = float(step.min()) if step.size else 0.0
    d2 = np.diff(y, 2)
    sigma = 1.4826 * float(np.median(np.abs(d2 - np.median(d2)))) / np.sqrt(6.0) if d2.size else 0.0
    sigma = max(sigma, quantum / np.sqrt(12.0))
    threshold = max(n_sigma * sigma, 2.0 * quantum)
    band = max(2.0 * sigma, quantum)
    padded = np.concatenate([np.full(window, np.nan), y])
    windows = np.lib.stride_tricks.sliding_window_view(padded, window)[:n]  # windows[i] = y[i-window:i]
    count = np.sum(~np.isnan(windows), axis=1)
    level = np.full(n, np.nan)
    ok = count >= min_still
    level[ok] = np.nanmedian(windows[ok], axis=1)
    dev = y - level
    beyond = np.where(np.isnan(dev), 0, np.sign(dev) * (np.abs(dev) > threshold))
    persistent = (beyond[:-2] != 0) & (beyond[:-2] == beyond[1:-1]) & (beyond[:-2] == beyond[2:])
    hits = np.flatnonzero(persistent)
    if hits.size == 0:
        return 0
    i = int(hits[0])
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
    return release if release >= min_still else 0


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
        steps = np.abs(d[:, 0])
        nonzero = steps[steps > 0]
        quantum = nonzero.min() if nonzero.size else 0.0
        before, after = d[i - 2, 0], d[i, 0]
        dup &= (np.sign(before) == np.sign(after)) & (np.abs(before) > quantum) & (np.abs(after) > quantum)
    return i[dup]


def _first_interval_anomaly(dt, r, labels, tolerance, timing_sigma_s, echo_fraction, max_missed):
    """(k, kind, reason) of the first anomalous interval dt[k] of one chain, or None.

    ``labels[j]`` names event j of the chain (its index in the file); kind is "echo",
    "missed" or "off-trend"; the event after interval k (``labels[k + 1]``) is the anomaly.
    """
    if dt.size < 2:
        return None
    q = dt[1:] / dt[:-1] / r  # q[i-1] = dt_i / dt_exp_i for intervals i = 1..
    u = np.sqrt(2.0) * timing_sigma_s * np.hypot(1.0 / dt[1:], 1.0 / dt[:-1])
    bad = np.abs(np.log(q)) > np.log1p(tolerance + 4.0 * u)
    if dt[0] < echo_fraction * dt[1] / r and (  # an echo after the chain's first event
            dt.size < 3 or abs(np.log(dt[2] / (r * (dt[0] + dt[1])))) < np.log1p(tolerance + 4.0 * u[1])):
        return 0, "echo", (f"echo or spurious event: only {dt[0] * 1e3:.1f} ms after impact {labels[0]}, "
                           f"the next interval suggests about {dt[1] / r * 1e3:.0f} ms")
    if not np.any(bad):
        return None
    k = int(np.flatnonzero(bad)[0]) + 1
    expected = r * dt[k - 1]
    ratio = dt[k] / expected
    trend = f"(interval ratio {dt[k] / dt[k - 1]:.2f}, trend {r:.2f})"
    spans = np.cumsum(r ** np.arange(max_missed + 1))[1:]  # 1+r, 1+r+r^2, ...
    n_missed = int(np.argmin(np.abs(np.log(ratio / spans)))) + 1
    if ratio < echo_fraction:
        return k, "echo", (f"echo or spurious event: only {dt[k] * 1e3:.1f} ms after impact {labels[k]}, "
                           f"expected about {expected * 1e3:.0f} ms {trend}")
    if abs(np.log(ratio / spans[n_missed - 1])) < np.log1p(tolerance + 4.0 * u[k - 1]):
        what = "a missed impact" if n_missed == 1 else f"{n_missed} missed impacts"
        return k, "missed", (f"follows {what}: interval {dt[k]:.4f} s after impact {labels[k]} is {ratio:.2f} x "
                             f"the expected {expected:.4f} s {trend}")
    return k, "off-trend", (f"interval {dt[k]:.4f} s after impact {labels[k]} is {ratio:.2f} x the expected "
                            f"{expected:.4f} s {trend}")


def detect_impact_anomalies(t_s, *, tolerance=0.25, timing_sigma_s=2e-4, echo_fraction=0.5, max_missed=3):
    """Find missed impacts and echoes in a series of impact times.

    Between impacts the flight times dt_i = t_{i+1} - t_i fall geometrically,
    dt_{i+1} ~ r dt_i with r roughly constant (r = epsilon without drag, 0 < r < 1).
    The reference ratio r is the median of the ratios that lie in (0.3, 1) (all
    ratios if none do); the expected interval is ``dt_exp_i = r dt_{i-1}``.

    * a missed impact: dt_i ~ dt_exp_i (1 + r + ... + r^k) for k = 1..``max_missed``
      missed impacts (an interval ratio near 2 followed by one near 0.5);
    * an echo (or a spurious event): dt_i < ``echo_fraction`` dt_exp_i;
    * anything else outside ``dt_exp_i (1 +- tol_i)``: an interval off the trend.

    ``tol_i = tolerance + 4 u_i`` widens with the timing noise: ``u_i = sqrt(2)
    timing_sigma_s sqrt(1/dt_i^2 + 1/dt_{i-1}^2)`` is the relative uncertainty of the
    ratio dt_i / dt_{i-1}, which matters for the millisecond intervals at the end of a run.
    A first interval already too short compared with the second (dt_0 <
    ``echo_fraction`` dt_1 / r, and dt_2 ~ r (dt_0 + dt_1) when known) marks impact 1
    as an echo.

    After an anomaly the search goes on, so that later ones are diagnosed too: an echo
    is removed and the chain continues; after a missed impact (or an off-trend
    interval) a new chain starts at the event that follows it. Only the impacts before
    the first anomaly are clean.

    Parameters
    ----------
    t_s : array_like
        impact times [s], strictly increasing
    tolerance : float
        relative deviation from the expected interval still counted as clean
    timing_sigma_s : float
        standard deviation of the timing of one impact [s] (sound onset detection)
    echo_fraction : float
        an interval shorter than this fraction of the expected one is an echo
    max_missed : int
        most consecutive missed impacts tried when explaining a long interval

    Returns
    -------
    n_clean : int
        number of leading impacts before the first anomaly (all of them when none)
    rejected : tuple
        ``((index, time_s, reason), ...)`` for impacts ``n_clean .. n - 1``: an anomaly
        carries its diagnosis, the others are rejected as following the first anomaly.
    """
    t = np.asarray(t_s, dtype=float)
    n = t.size
    dt = np.diff(t)
    if dt.size < 2:
        return n, ()
    ratios = dt[1:] / dt[:-1]
    plausible = ratios[(ratios > 0.3) & (ratios < 1.0)]
    r = float(np.median(plausible if plausible.size else ratios))
    chain = np.arange(n)
    found = {}
    while chain.size >= 3:
        hit = _first_interval_anomaly(np.diff(t[chain]), r, chain, tolerance, timing_sigma_s, echo_fraction,
                                      max_missed)
        if hit is None:
            break
        k, kind, reason = hit
        found[int(chain[k + 1])] = reason
        chain = np.delete(chain, k + 1) if kind == "echo" else chain[k + 1:]
    if not found:
        return n, ()
    first = min(found)
    rejected = tuple((j, float(t[j]), found.get(j, f"after the anomaly at impact {first} (not fitted)"))
                     for j in range(first, n))
    return first, rejected

