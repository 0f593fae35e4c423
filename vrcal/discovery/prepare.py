"""From a record as read to the runs that are fitted: floor reference, plausibility, and the bounces
that do not belong.

``vrcal discover`` fits one model to every run of a record at once (shared contact, one release
state per run). This module decides what the runs are:

* a trajectory's heights are referred to the floor (:func:`floor_referenced`);
* a long trajectory is decimated (:func:`decimate`): its noise is measured on every sample, then
  every k-th sample is fitted (at most :data:`MAX_FIT_SAMPLES`), with a note giving k; the fit's
  statistics (chi-square, the noise's share of the gap, the evidence) refer to the samples fitted;
* the record is checked against physics (:func:`vrcal.measurements.plausibility.check`: units,
  orientation, g, frame rate, rebounds below drops); what cannot be fitted stops here in one
  line, what only looks off becomes a warning (the verdict "suspect input");
* a bounce that does not belong is cut out, and the pieces around it become runs: in a
  trajectory, a bounce whose contact lies far above the floor level of the others (it hit
  something), whose flight lost or gained energy out of line with the rest, or whose flight is
  no free flight (:func:`odd_bounces`, :func:`unfree_flights`); in impact times, the reader's
  chains of consecutive bounces (:func:`vrcal.measurements.cleanup.impact_chains`). Every cut
  is a note naming the file's lines.
"""

from __future__ import annotations

import dataclasses
import math
from typing import NamedTuple

import numpy as np

from vrcal.drop.effects import drag_constant_per_m, flight_expectation, surface_of
from vrcal.errors import DataError, UsageError
from vrcal.measurements.cleanup import third_difference_sigma
from vrcal.measurements.plausibility import FLIGHT_G_SPREAD, UNIT_QUESTION
from vrcal.measurements.trajectory import release_with_noise
from vrcal.model.restitution import SPHERE_DRAG_COEFFICIENT, STANDARD_GRAVITY_M_PER_S2

#: A trajectory whose lowest sample after release lies outside this band [m] is not
#: referenced to the floor (no tracked point is that far below or above the floor).
FLOOR_BAND_M = (-0.05, 0.3)

#: A contact this many ball diameters above the floor level of the other bounces hit something else.
ODD_CONTACT_DIAMETERS = 0.5

#: A bounce is judged (odd or not) only while the flights on both sides of it rise this many noise
#: sigmas above the floor: a lower flight's bounce is found and timed by the noise as much as by the
#: ball (a low bounce can be missed among the noise, or a noise dip taken for one), so the low last
#: bounces of a record are fitted as they are, never called odd.
RESOLVED_SIGMAS = 20.0

#: A flight is no free flight when its acceleration changes (its jerk) beyond what air drag can do
#: (the registry's physical limits of ``air_drag`` and ``buoyancy``) by this many standard errors,
#: and out of line with the other flights of the record by as many (:func:`unfree_flights`).
FREE_FLIGHT_SIGMAS = 5.0

#: A flight out of line by :data:`FREE_FLIGHT_SIGMAS` is still kept as free when its jerk beyond the range the
#: drag and the other flights allow changes the speeds at its contacts, against the parabola that fits it, by
#: less than this fraction (:func:`unfree_flights`): a long, sharply sampled fall shows a jerk of a few m/s^3
#: (a lens's slight distortion) at 10 standard errors that moves its impact speed by 0.4 %, far less than a
#: bounce's own speed ratio is known to; cut, it took the record's best-resolved bounce with it.
FREE_FLIGHT_SPEED_EFFECT = 0.01

#: Relative spread of the flights' apparent g above which the reason a flight is no free flight quotes it (a
#: length scale that changes across the picture makes the high flights' g differ from the low ones'): the
#: spread at which the plausibility check says the flights disagree on g.
SCALE_SPREAD = FLIGHT_G_SPREAD

#: Fewest samples of a flight (clear of its contacts) whose jerk is judged.
FREE_FLIGHT_MIN_SAMPLES = 7

#: Most samples of the trajectories fitted together: a longer record is decimated to every k-th
#: sample (:func:`decimate`). 20,000 samples hold every bounce a drop makes many times over; fitting
#: them takes seconds, while a 10^6-sample record fitted whole takes minutes.
MAX_FIT_SAMPLES = 20_000

#: Decimation never lowers the sampling rate below this [Hz] (a phone video's rate).
MIN_FIT_RATE_HZ = 60.0

#: Most runs fitted jointly (drops of a table, files, chains of impacts, pieces of a record): a
#: joint fit has a release state per run, and its time grows as the cube of the runs (100 runs take
#: a few seconds, 300 a minute).
MAX_RUNS = 100


class Prepared(NamedTuple):
    """The record ready for the fit."""

    data: object          # one measurement, or vrcal.measurements.Runs
    labels: tuple         # a label per run
    notes: tuple          # what was done (floor shift, cuts)
    warnings: tuple       # what looks off (the verdict "suspect input")
    floor_shifts_m: tuple  # subtracted from the heights of each trajectory as read [m] (0 when none)
    decimation: int = 1   # every k-th sample of the trajectories is fitted (1: all)
    noise_m: float | None = None  # noise of one height measured on every sample before decimation [m]


def floor_band(ball=None):
    """Where the lowest sample after release of a floor-referenced trajectory can lie [m]: (lo, hi).

    With the ball, the physical limits of the tracked point, ``height_offset.offset_m`` of the
    registry (-D to D + max(0.1 D, 5 mm): a tracked point on the ball); a lowest sample beyond them
    cannot be explained by the tracked point, so the record is not referenced to the floor (a
    Tracker origin at the picture's corner, 10 cm below the floor, was taken as the floor).
    Without it, :data:`FLOOR_BAND_M`.
    """
    if ball is None:
        return FLOOR_BAND_M
    from vrcal.drop.effects import EFFECTS

    (param,) = EFFECTS["height_offset"].parameters
    return param.physical_limits(ball)


def floor_referenced(data, floor_m=None, ball=None, y_down=False):
    """A trajectory with heights above the floor, and a note saying what was done (or None).

    Parameters
    ----------
    data : Trajectory or ImpactTimes or ApexHeights
        only trajectories are changed
    floor_m : float or None
        height of the floor in the file's frame [m]: along its y axis, so with ``y_down`` the floor's
        distance below the file's origin (a motion detector above the ball: the floor's distance from the
        sensor, 1.9 for 1.9 m); subtracted from every height. None:
        keep the heights when the lowest sample after release lies in
        :func:`floor_band` (of ``ball``), otherwise subtract the lowest sample (the data's origin is
        then the lowest tracked position; :func:`vrcal.discovery.ranking.discover` fits the
        contact's level from there with the baseline).
    ball : BallProperties or None
        the ball, whose size bounds where a tracked point can be (:func:`floor_band`)
    y_down : bool
        the reader turned the file's y axis over (height = -y), so the floor's height is ``-floor_m``

    Returns
    -------
    (data, note) ; the shift is ``data.y_m_before - data.y_m_after``

    Raises
    ------
    UsageError
        when the floor given lies above most of the samples after release, beyond where any tracked point of
        the ball can be (:func:`floor_band`): a floor in the wrong frame or unit (1.9 for a motion
        detector's -1.9 before the file's axis was read as pointing down printed epsilon = 1 ± 1519)
    """
    if data.kind != "trajectory":
        if floor_m is not None:
            raise UsageError(f"--floor applies to trajectories, not to {data.kind} data")
        return data, None
    y = np.asarray(data.y_m, dtype=float)
    if floor_m is not None:
        if not math.isfinite(floor_m):
            raise UsageError(f"--floor must be a finite height in m, got {floor_m!r}")
        shift = -float(floor_m) if y_down else float(floor_m)
        frame = f", the file's y pointing down: the floor at height {shift:+.4f} m" if y_down else ""
        note = f"heights shifted by {-shift:+.4f} m (--floor {float(floor_m):g} m{frame})"
        _check_floor_given(data, shift, floor_m, ball, y_down)
    else:
        low = _lowest_after_release(data)
        lo, hi = floor_band(ball)
        if lo <= low <= hi:
            return data, None
        shift = low
        note = (f"heights are not referenced to the floor (lowest sample after release at {low:+.4f} m): "
                f"shifted by {-shift:+.4f} m so that the lowest sample is at 0 (give --floor to set the floor)")
    return dataclasses.replace(data, y_m=y - shift), note


def _check_floor_given(data, floor_height_m, floor_m, ball, y_down):
    """Raise when the floor at ``floor_height_m`` [m] cannot be the one the ball bounced on: most samples
    after release lie below it beyond where a tracked point of the ball can be (:func:`floor_band`; a
    bouncing ball spends most of its time above the floor), or the lowest sample after release lies further
    above it than a tracked point plus what one sampling interval can miss of a contact (the flight's
    fastest speed times half the interval: the sample nearest a contact is at most that far from it)."""
    t = np.asarray(data.t_s, dtype=float)
    y = np.asarray(data.y_m, dtype=float) - floor_height_m
    keep = np.arange(y.size) >= int(getattr(data, "release_index", 0) or 0)
    keep &= np.isfinite(y) & np.isfinite(t)
    t, y = t[keep], y[keep]
    if not y.size:
        return
    lo, hi = floor_band(ball)
    given = f"--floor {float(floor_m):g} m"
    axis = ("the file's y points down (--y-down or its format), so the floor is its distance below the file's "
            "origin, as a motion detector above the ball gives it" if y_down else
            "the file's y points up; with a y axis pointing down (a motion detector above the ball, image rows) "
            "add --y-down and give the floor's distance below the origin")
    if float(np.median(y)) < lo:
        below = float(np.mean(y < lo))
        raise UsageError(f"{given} lies above {100 * below:.0f} % of the samples after the release "
                         f"(their median {float(np.median(y)):+.3f} m from it, their highest "
                         f"{float(np.max(y)):+.3f} m): "
                         f"give the floor's height in the file's frame, in m; {axis}")
    steps = np.diff(t)
    steps = steps[steps > 0]
    if not steps.size:
        return
    low = float(np.min(y))
    fastest_m_per_s = math.sqrt(2.0 * STANDARD_GRAVITY_M_PER_S2 * max(float(np.max(y)) - low, 0.0))
    reach_m = hi + 0.5 * fastest_m_per_s * float(np.median(steps))
    if low > reach_m:
        raise UsageError(f"{given} lies {low:.3f} m below the lowest sample after the release; a tracked point "
                         f"of this ball, sampled every {1e3 * float(np.median(steps)):.3g} ms, comes within "
                         f"{reach_m:.3f} m of a floor it bounces on: give the floor's height in the file's frame, in m "
                         f"({axis}), or leave --floor out to fit the contact's level")


def _lowest_after_release(run):
    """The lowest height of a trajectory from its release on [m]."""
    return float(np.min(np.asarray(run.y_m, dtype=float)[int(getattr(run, "release_index", 0) or 0):]))


def _common_floor(runs, ball):
    """(lowest, highest) [m] of the lowest samples after release of trajectories none of which is
    referenced to the floor (:func:`floor_referenced`): the lowest is the one shift for all; None when one
    run is referenced (or the runs are not trajectories).

    Each run's lowest sample lies above the contact by where its samples happen to fall in its bounces
    (up to v dt / 2: 44 mm at 4.4 m/s and 50 Hz); shifted each by its own, two runs of one motion
    detector were 9.8 mm apart, which the one contact level fitted to all runs could not follow
    ('unexplained', 3.9 times the noise; each run alone, or both at one level, explained)."""
    if any(run.kind != "trajectory" for run in runs):
        return None
    lows = [_lowest_after_release(run) for run in runs]
    lo, hi = floor_band(ball)
    if any(lo <= low <= hi for low in lows):
        return None
    return min(lows), max(lows)


def decimation_factor(n_samples, dt_s, max_samples=None):
    """Keep every k-th sample: the k that leaves at most ``max_samples`` (default
    :data:`MAX_FIT_SAMPLES`) of ``n_samples`` (1 when they fit), but never a sampling interval beyond
    1 / :data:`MIN_FIT_RATE_HZ` (``dt_s`` [s] the median interval as read)."""
    max_samples = MAX_FIT_SAMPLES if max_samples is None else max_samples
    n = int(n_samples)
    if n <= max_samples or not (dt_s > 0):
        return 1
    k = -(-n // int(max_samples))
    return int(max(1, min(k, math.floor(1.0 / (MIN_FIT_RATE_HZ * dt_s)))))


def decimate(data, factor):
    """Every ``factor``-th sample of a trajectory (from the first); the release index and the file's
    line numbers follow the samples kept."""
    k = int(factor)
    if k <= 1 or data.kind != "trajectory":
        return data
    lines = getattr(data, "lines", None)
    return dataclasses.replace(data, t_s=np.asarray(data.t_s)[::k], y_m=np.asarray(data.y_m)[::k],
                               release_index=-(-int(getattr(data, "release_index", 0) or 0) // k),
                               lines=None if lines is None else np.asarray(lines)[::k])


def _decimated(record, notes, progress=None):
    """The record with its trajectories decimated (:func:`decimate`), the factor, and the noise [m]
    measured on every sample before (None when nothing was decimated)."""
    from vrcal.discovery.residuals import noise_floor
    from vrcal.measurements import Runs

    runs = list(record.runs) if isinstance(record, Runs) else [record]
    if runs[0].kind != "trajectory":
        return record, 1, None
    total = sum(len(r.t_s) for r in runs)
    dt = float(np.median(np.diff(np.asarray(runs[0].t_s, dtype=float)))) if len(runs[0].t_s) > 1 else 0.0
    k = decimation_factor(total, dt)
    if k <= 1:
        return record, 1, None
    if progress is not None:
        progress(0.2, f"measuring the noise on {total:,} samples")
    noise = noise_floor(record)
    thinned = [decimate(r, k) for r in runs]
    kept = sum(len(r.t_s) for r in thinned)
    noise_text = f"{noise * 1e3:.3g} mm, measured on all samples" if noise else "not measurable in the samples"
    notes.append(f"decimated: every {k}th sample is fitted ({kept:,} of {total:,}; {1.0 / (k * dt):,.0f} of "
                 f"{1.0 / dt:,.0f} samples/s), which keeps the fit to seconds. The noise ({noise_text}) is "
                 f"that of one sample, so chi-square, the evidence and the uncertainties refer to the "
                 f"{kept:,} samples fitted (all samples would shrink the uncertainties about "
                 f"{math.sqrt(k):.2g} times)")
    out = (Runs(runs=tuple(thinned), source=record.source, notes=record.notes, labels=record.labels)
           if isinstance(record, Runs) else thinned[0])
    return out, k, noise


def _line(data, i):
    lines = getattr(data, "lines", None)
    return f"line {int(lines[i])}" if lines is not None and 0 <= i < len(lines) else f"sample {i + 1}"


def _flight_line(t, y, lo, hi, g):
    """(a, b) of the flight y = a + b t - g t^2 / 2 through samples lo..hi-1 (least squares), or None."""
    if hi - lo < 2:
        return None
    ts = t[lo:hi]
    z = y[lo:hi] + 0.5 * g * ts * ts
    if hi - lo == 2:
        b = (z[1] - z[0]) / (ts[1] - ts[0])
        return z[0] - b * ts[0], b
    b, a = np.polyfit(ts, z, 1)
    return a, b


def _contact_windows(edges, k, m):
    """(lo_in, hi_in, lo_out, hi_out): the samples of the flight lines before and after bounce ``k`` at sample
    ``m`` (up to six a side, within the flights' ``edges``; the sample at the bounce in neither)."""
    return max(edges[k], m - 6), m, m + 1, min(edges[k + 2], m + 7)


def contact_points(t_s, y_m, minima, release_index, g_m_per_s2, speeds=False):
    """Time and height of each contact: where the flight before a bounce meets the flight after it.

    Each flight is a parabola of curvature -g through its samples (leaving out the sample
    at the bounce); two such parabolas meet where their straight parts do. A bounce with
    fewer than two samples on a side (the first bounce of a record that starts just before it)
    keeps the time of its lowest sample and an unknown height (NaN): the contact lies anywhere
    below that sample (a frame at 30 fps is 4 cm above the floor at 1.3 m/s).

    Returns
    -------
    (t_c, y_c) : ndarrays, one entry per minimum; with ``speeds`` also (v_in, v_out): the two flights'
    speeds there [m/s] (NaN where a flight is not known)
    """
    t = np.asarray(t_s, dtype=float)
    y = np.asarray(y_m, dtype=float)
    g = float(g_m_per_s2)
    edges = [int(release_index)] + [int(m) for m in minima] + [t.size]
    tc, yc, v_in, v_out = [], [], [], []
    for k, m in enumerate(minima):
        lo_in, hi_in, lo_out, hi_out = _contact_windows(edges, k, m)
        before, after = _flight_line(t, y, lo_in, hi_in, g), _flight_line(t, y, lo_out, hi_out, g)
        if before is None or after is None or before[1] == after[1]:
            tc.append(float(t[m]))
            yc.append(float(y[m]) if before is not None and after is not None else math.nan)
            v_in.append(math.nan)
            v_out.append(math.nan)
            continue
        tm = (after[0] - before[0]) / (before[1] - after[1])
        if not (t[max(m - 1, 0)] - 0.5 * (t[m] - t[max(m - 1, 0)]) <= tm <= t[min(m + 1, t.size - 1)] + 1e-12):
            tm = float(t[m])
        tc.append(float(tm))
        yc.append(float(before[0] + before[1] * tm - 0.5 * g * tm * tm))
        v_in.append(abs(before[1] - g * tm))
        v_out.append(abs(after[1] - g * tm))
    if speeds:
        return np.asarray(tc), np.asarray(yc), np.asarray(v_in), np.asarray(v_out)
    return np.asarray(tc), np.asarray(yc)


#: A sample at a bounce this many noise sigmas deeper than the deepest contact of the ball can take its tracked
#: point is off the ball (:func:`samples_below_contacts`).
BELOW_CONTACT_SIGMAS = 5.0


def samples_below_contacts(data, ball, g_m_per_s2, sigma_m=0.0, surface="rigid"):
    """Samples at a bounce that lie deeper below its contact than the ball can go: [(sample index, reason)].

    A contact of duration tau at speeds v_in, v_out takes the ball at most (v_in + v_out) tau / (2 pi) below the
    level where its flights meet (the registry's ``contact_duration`` dip); with tau its physical limit
    (:func:`vrcal.drop.effects.contact_time_limit_s`, for the ``surface``), a bounce's lowest sample deeper
    than that by :data:`BELOW_CONTACT_SIGMAS` noise sigmas (``sigma_m`` [m]) is no position of the ball: a
    motion detector's echo off the floor (a basketball's top read 0.24 m low, the floor's distance), or a
    tracker on something else. The flights on both sides are fitted without it (:func:`contact_points`), so
    they say where the contact was. None are when more than half the bounces have one: such a record is not
    what it seems (a pixel track read as metres), and the checks of its units say so.
    """
    from vrcal.discovery.residuals import impacts_in_trajectory
    from vrcal.drop.effects import contact_time_limit_s

    r = int(getattr(data, "release_index", 0) or 0)
    y = np.asarray(data.y_m, dtype=float)
    minima = impacts_in_trajectory(data.t_s, y, r, sigma_m or None)
    if minima.size == 0:
        return []
    tc, yc, v_in, v_out = contact_points(data.t_s, y, minima, r, g_m_per_s2, speeds=True)
    tau = contact_time_limit_s(float(np.mean(ball.mass_kg)), float(np.mean(ball.diameter_m)), surface)
    out = []
    for m, t_c, y_c, a, b in zip(minima, tc, yc, v_in, v_out):
        if not (math.isfinite(y_c) and math.isfinite(a) and math.isfinite(b)):
            continue
        dip = (a + b) * tau / (2.0 * math.pi)
        depth = y_c - float(y[m])
        if depth > dip + BELOW_CONTACT_SIGMAS * float(sigma_m or 0.0) and depth > 0.0:
            out.append((int(m), f"{_line(data, int(m))} (t = {float(data.t_s[m]):.4g} s) lies {depth:.3g} m below "
                                f"where the flights on both sides meet, deeper than a contact of this ball can "
                                f"take it ({dip * 1e3:.3g} mm at {a:.3g} m/s): no position of the ball (a motion "
                                f"detector's echo off the floor, a tracker on something else)"))
    # a sample off the ball at most bounces is no glitch: the record itself is not what it seems
    return out if len(out) <= max(1, (minima.size + 1) // 2) else []


def _line_sd_at(t, lo, hi, tm, sigma):
    """Standard error [m] at time ``tm`` of the line :func:`_flight_line` fits through samples lo..hi-1 with
    noise ``sigma`` [m] (inf with fewer than three samples)."""
    if hi - lo < 3:
        return math.inf
    x = np.vander(t[lo:hi] - tm, 2)
    return float(sigma) * math.sqrt(float(np.linalg.inv(x.T @ x)[1, 1]))


def contact_level_errors(t_s, y_m, minima, release_index, g_m_per_s2, contact_t_s, sigma_m):
    """Standard error [m] of each contact's height from :func:`contact_points`.

    The contact is where the flight before a bounce (speed v_in < 0 there) meets the one after it
    (v_out > 0); errors dy_in, dy_out of the two lines at that time move the meeting point's height by
    (v_out dy_in - v_in dy_out) / (v_out - v_in). The noise of a sample is the larger of ``sigma_m`` and
    the lines' own scatter about their parabolas.
    """
    t = np.asarray(t_s, dtype=float)
    y = np.asarray(y_m, dtype=float)
    g = float(g_m_per_s2)
    edges = [int(release_index)] + [int(m) for m in minima] + [t.size]
    out = []
    for k, (m, tm) in enumerate(zip(minima, contact_t_s)):
        lo_in, hi_in, lo_out, hi_out = _contact_windows(edges, k, int(m))
        before, after = _flight_line(t, y, lo_in, hi_in, g), _flight_line(t, y, lo_out, hi_out, g)
        if before is None or after is None or hi_in - lo_in < 3 or hi_out - lo_out < 3:
            out.append(math.inf)
            continue
        scatter = [y[a:b] - (line[0] + line[1] * t[a:b] - 0.5 * g * t[a:b] ** 2)
                   for line, a, b in ((before, lo_in, hi_in), (after, lo_out, hi_out))]
        sd = max(float(sigma_m), math.sqrt(float(np.mean(np.concatenate(scatter) ** 2))))
        v_in, v_out = before[1] - g * tm, after[1] - g * tm
        if not v_in < 0 < v_out:
            out.append(math.inf)
            continue
        e_in, e_out = _line_sd_at(t, lo_in, hi_in, tm, sd), _line_sd_at(t, lo_out, hi_out, tm, sd)
        out.append(math.hypot(v_out * e_in, v_in * e_out) / (v_out - v_in))
    return np.asarray(out, dtype=float)


#: The contact level drifts when a straight line through the contacts' heights against the bounce number
#: changes by this many standard errors and by at least one ball radius / 10 over the bounces
#: (:func:`contact_level_drift`).
CONTACT_DRIFT_SIGMAS = 5.0
CONTACT_DRIFT_DIAMETERS = 0.05


def _contact_drift(t_s, y_m, minima, release_index, g_m_per_s2, sigma_m):
    """(change [m], its standard error [m], indices of the bounces used, their contact heights [m]) of a
    weighted straight line through the contacts' heights (:func:`contact_points`, :func:`contact_level_errors`)
    against the bounce number, over the bounces; None with fewer than three contacts of known height."""
    if len(minima) < 3:
        return None
    tc, yc = contact_points(t_s, y_m, minima, release_index, g_m_per_s2)
    se = contact_level_errors(t_s, y_m, minima, release_index, g_m_per_s2, tc, sigma_m)
    ok = np.isfinite(yc) & np.isfinite(se) & (se > 0)
    if np.sum(ok) < 3:
        return None
    n = np.flatnonzero(ok).astype(float)
    w = 1.0 / se[ok] ** 2
    x = np.vander(n, 2)
    cov = np.linalg.inv(x.T @ (w[:, None] * x))
    slope, icpt = (float(c) for c in cov @ x.T @ (w * yc[ok]))
    span = n[-1] - n[0]
    off_line = float(np.sqrt(np.mean((yc[ok] - (slope * n + icpt)) ** 2)))
    return slope * span, math.sqrt(float(cov[0, 0])) * span, np.flatnonzero(ok), yc[ok], off_line


def contact_level_drift(data, minima, g_m_per_s2, sigma_m, diameter_m, model_y_m=None):
    """A note when the bounces of a trajectory touch at levels that drift from bounce to bounce beyond what
    a model's heights show, else None.

    Each contact's height is where the parabolas of g through its flights meet (:func:`contact_points`,
    with :func:`contact_level_errors`); a weighted straight line through them against the bounce number
    changes over the bounces by some amount. The same estimator on a fitted model's heights at the same
    samples (``model_y_m``) drifts too -- a contact's duration lowers the meeting point in proportion to
    the impact speed, drag bends the flights near it -- and the difference is what the model's one
    contact level cannot follow when it exceeds :data:`CONTACT_DRIFT_SIGMAS` standard errors and
    :data:`CONTACT_DRIFT_DIAMETERS` ball diameters. A soft floor that compresses under the bounces (a
    stack of paper, foam) does so, and so does a tilted floor under a ball that moves sideways (a marble
    on 30 sheets of A5 paper sank 5.3 mm over three bounces, and the fit left a gap of 1.7 mm at 0.07 mm of
    noise). The bounces' own speed ratios (out/in, where free parabolas through their flights meet; the
    table of ``--details``) hold no contact level and remain the epsilon of each bounce.

    Parameters
    ----------
    data : Trajectory
        heights [m], times [s], release index
    minima : sequence of int
        the bounces' sample indices
    g_m_per_s2 : float
        gravity [m/s^2]
    sigma_m : float
        noise of one height [m]
    diameter_m : float
        the ball's diameter [m]
    model_y_m : ndarray or None
        a model's heights [m] at the samples (None: the data's drift is judged against none)

    Returns
    -------
    str or None
    """
    r = int(getattr(data, "release_index", 0) or 0)
    found = _contact_drift(data.t_s, data.y_m, minima, r, g_m_per_s2, sigma_m)
    if found is None:
        return None
    change, err, used, yc, off_line = found
    if abs(change) <= CONTACT_DRIFT_SIGMAS * err:
        return None   # the data's own level does not move: a model that drifts is no soft floor
    own = 0.0
    if model_y_m is not None:
        model = _contact_drift(data.t_s, model_y_m, [minima[i] for i in used], r, g_m_per_s2, sigma_m)
        if model is None:
            return None
        own = model[0]
    beyond = change - own
    if abs(beyond) <= max(CONTACT_DRIFT_SIGMAS * err, CONTACT_DRIFT_DIAMETERS * diameter_m):
        return None
    first, last = int(used[0]) + 1, int(used[-1]) + 1
    levels = ", ".join(f"{1e3 * (v - yc[0]):+.2f}" for v in yc[:8]) + (", ..." if yc.size > 8 else "")
    model_text = "" if model_y_m is None else f"; the model's line {1e3 * own:+.2f} mm"
    where = f"bounces {first} to {last}, {_line(data, int(minima[used[0]]))} to {_line(data, int(minima[used[-1]]))}"
    tail = ("the model has one contact level and cannot follow it; the bounces' own speed ratios (--details) "
            "need none")
    if off_line > 0.5 * abs(change):   # up and down: no drift a line describes
        return (f"the contact level varies from bounce to bounce ({where}; each contact against the first: "
                f"{levels} mm): a tracked point that moves on the ball, a camera or floor that moves; {tail}")
    why = ("a soft floor that gives under the bounces (paper, foam), or a floor tilted while the ball moves "
           "sideways" if change < 0 else
           "a floor tilted while the ball moves sideways, or a camera or tracked point that moves")
    return (f"the contact level {'sinks' if change < 0 else 'rises'} by {1e3 * abs(change):.3g} ± {1e3 * err:.2g} "
            f"mm along a line through the contacts ({where}; each against the first: {levels} mm{model_text}): "
            f"{why}; {tail}")


def flight_jerks(t_s, y_m, release_index, contact_t_s, floor_m, sigma_m=0.0):
    """The jerk (rate of change of the acceleration) of each flight of a trajectory, from a cubic
    through its samples clear of the contacts.

    Flight 0 runs from the release to the first contact, flight k from contact k to contact k+1.
    Flight 0 keeps only the samples clearly below its top (by 10 noise sigmas and 1 % of the
    drop): a still segment the release detection missed is no part of the fall.
    A ball in free flight with quadratic drag has a = -g - k v|v|, so its jerk is -2 k |v| a,
    about 2 k g |v| >= 0: a flight's jerk over 2 g times its mean speed is the drag constant k
    it shows.

    Parameters
    ----------
    t_s, y_m : ndarray
        sample times [s] and heights above the floor [m]
    release_index : int
        first sample after the still segment
    contact_t_s : ndarray
        time of each contact [s] (:func:`contact_points`)
    floor_m : float
        contact height [m]; samples at or below it (a soft contact's dip) are left out
    sigma_m : float
        noise of one height [m]; the standard error uses the larger of it and the cubic's scatter

    Returns
    -------
    list of (jerk [m/s^3], standard error [m/s^3], mean speed [m/s], first sample, last sample, g [m/s^2]:
    the flight's downward acceleration at its middle, duration [s] and the larger speed at its two ends
    [m/s]) or None for a flight with fewer than
    :data:`FREE_FLIGHT_MIN_SAMPLES` samples clear of its contacts (the sample next to each contact is
    left out)
    """
    t = np.asarray(t_s, dtype=float)
    y = np.asarray(y_m, dtype=float)
    r = int(release_index)
    dt = float(np.median(np.diff(t)))
    index = np.arange(t.size)
    starts = [None] + [float(c) for c in contact_t_s[:-1]]
    out = []
    for start, end in zip(starts, contact_t_s):
        inside = (t < end - 0.99 * dt) & (y > floor_m + 2.0 * sigma_m)
        if start is None:
            top = float(np.max(y[r:][t[r:] < end], initial=floor_m))
            inside &= (index >= r) & (top - y > max(10.0 * sigma_m, 0.01 * (top - floor_m)))
        else:
            inside &= t > start + 1.01 * dt
        idx = np.flatnonzero(inside)
        if idx.size < FREE_FLIGHT_MIN_SAMPLES:
            out.append(None)
            continue
        mid, half = 0.5 * (t[idx[0]] + t[idx[-1]]), 0.5 * (t[idx[-1]] - t[idx[0]])
        u = (t[idx] - mid) / half
        basis = np.vander(u, 4)
        coef, rss, *_ = np.linalg.lstsq(basis, y[idx], rcond=None)
        scatter = math.sqrt(float(rss[0]) / (idx.size - 4)) if rss.size else 0.0
        sd = max(scatter, float(sigma_m), 1e-9)
        var = np.linalg.inv(basis.T @ basis)[0, 0] * sd * sd
        speed = np.abs(np.polyval(np.polyder(coef), u)) / half
        out.append((6.0 * float(coef[0]) / half ** 3, 6.0 * math.sqrt(float(var)) / half ** 3, float(np.mean(speed)),
                    int(idx[0]), int(idx[-1]), -2.0 * float(coef[1]) / half ** 2, 2.0 * half,
                    float(max(speed[0], speed[-1]))))
    return out


def unfree_flights(data, jerks, mass_kg, diameter_m, g_m_per_s2):
    """Flights that are no free flight: [(flight index, reason)].

    A flight's jerk (:func:`flight_jerks`) must lie between 0 and what the strongest physical
    drag gives (``air_drag``'s largest C_d in the densest air of ``buoyancy``'s limits) within
    :data:`FREE_FLIGHT_SIGMAS` standard errors, or match the drag constant the other flights show
    within as many: a length scale that drifts across the picture bends every flight alike, a
    hand at release or a touch in flight bends one. Judged only with another flight to compare.
    A scale that changes across the picture unevenly (a lens's distortion, perspective) bends the
    flights differently too: the reason names it, with the spread of the flights' apparent g when
    that exceeds :data:`SCALE_SPREAD` (a marble on paper filmed at 200 fps: 9.5-9.96 m/s^2).

    The decision is on the size of the effect as well as its significance: a jerk j beyond that range
    over a flight of duration T moves the flight's end speeds off the parabola that best fits it by
    j T^2 / 10 (a cubic's end slope less that of its least-squares parabola), and a flight whose end
    speeds move by less than :data:`FREE_FLIGHT_SPEED_EFFECT` of themselves is a free flight to what
    the fit takes from it (the speeds into and out of its bounces).
    """
    from vrcal.drop.effects import drag_constant_per_m, get_effect

    cd_max = get_effect("air_drag").parameters[0].physical_limits()[1]
    rho_max = get_effect("buoyancy").parameters[0].physical_limits()[1]
    k_max = float(drag_constant_per_m(cd_max, diameter_m, mass_kg, rho_max))
    g = float(g_m_per_s2)
    known = [(i, j) for i, j in enumerate(jerks) if j is not None and j[2] > 0]
    if len(known) < 2:
        return []
    gs = [j[5] for _, j in known]
    spread = (max(gs) - min(gs)) / float(np.median(gs)) if min(gs) > 0 else 0.0
    shown = f": the flights' g ranges {min(gs):.3g}-{max(gs):.3g} m/s^2, {100 * spread:.2g} %"
    scale = ("; or the length scale changes across the picture (a lens's distortion, perspective"
             + (shown if spread > SCALE_SPREAD else "") + ")")
    k = {i: j[0] / (2.0 * g * j[2]) for i, j in known}
    se = {i: j[1] / (2.0 * g * j[2]) for i, j in known}
    z = FREE_FLIGHT_SIGMAS
    out = []
    for i, (jerk, err, speed, lo, hi, _, duration, end_speed) in known:
        w = np.array([1.0 / se[o] ** 2 for o, _ in known if o != i])
        k_others = float(np.sum(w * np.array([k[o] for o, _ in known if o != i])) / np.sum(w))
        apart = (k[i] - k_others) / math.hypot(se[i], 1.0 / math.sqrt(float(np.sum(w))))
        j_max = 2.0 * k_max * g * speed
        if not ((jerk - j_max > z * err and apart > z) or (jerk < -z * err and apart < -z)):
            continue
        j_others = 2.0 * k_others * g * speed
        excess = min(abs(jerk - min(max(jerk, 0.0), j_max)), abs(jerk - j_others))
        if excess * duration ** 2 / 10.0 < FREE_FLIGHT_SPEED_EFFECT * end_speed:
            continue
        what = "the first fall" if i == 0 else f"the flight after bounce {i}"
        cause = ("the ball was pushed, spun or still held at release" if i == 0 else
                 "it touched something, or the tracker followed something else")
        out.append((i, f"{what} ({_line(data, lo)} to {_line(data, hi)}) is no free flight: its acceleration "
                       f"changes at {jerk:.3g} ± {err:.2g} m/s^3, where air drag allows 0 to {j_max:.3g} and the "
                       f"other flights show {j_others:.3g} at its speed: {cause}{scale}"))
    return out


def odd_bounces(data, ball, g_m_per_s2, sigma_m=0.0):
    """Bounces of a trajectory that do not belong: [(minimum's sample index, reason)], and the
    minima (sample indices of the bounces).

    * a contact more than max(:data:`ODD_CONTACT_DIAMETERS` D, 2 cm, 5 robust sd) above the
      median contact height of the bounces: the ball hit something above the floor;
    * a bounce whose flights are out of line with the others (the chain test of the impact
      times, :func:`vrcal.measurements.cleanup.impact_chains`, on the contact times): a kick,
      a second surface, a sudden loss;
    * the bounces at the ends of a flight that is no free flight (:func:`unfree_flights`): the
      first fall when the ball was pushed or held at release, a flight that touched something.

    ``ball`` gives the mass [kg] and diameter [m]. Only the bounces before the first flight that
    stays within :data:`RESOLVED_SIGMAS` noise sigmas (``sigma_m``) of the floor level are judged
    (and the flights up to it): below that the noise decides where a bounce seems
    to be.
    """
    from vrcal.discovery.residuals import impacts_in_trajectory
    from vrcal.measurements.cleanup import impact_chains

    r = int(getattr(data, "release_index", 0) or 0)
    y = np.asarray(data.y_m, dtype=float)
    diameter_m = float(np.mean(ball.diameter_m))
    minima = impacts_in_trajectory(data.t_s, y, r, sigma_m or None)
    if minima.size < 2:
        return [], minima
    tc, yc = contact_points(data.t_s, y, minima, r, g_m_per_s2)
    # the flight after each bounce rises to apex[k]; a bounce is resolved while both its flights are high
    ends = [int(m) for m in minima[1:]] + [y.size]
    apex = np.array([float(np.max(y[int(a):b])) for a, b in zip(minima, ends)])
    seen = np.where(np.isnan(yc), y[minima], yc)   # where a contact's height is unknown, its lowest sample
    low = np.flatnonzero(apex - float(np.median(seen)) < RESOLVED_SIGMAS * float(sigma_m or 0.0))
    judged = int(low[0]) if low.size else int(minima.size)   # bounces before the first low flight
    known = yc[:max(judged, 1)][~np.isnan(yc[:max(judged, 1)])]
    # the contact level of the judged bounces
    floor = float(np.median(known)) if known.size else float(np.min(seen[:max(judged, 1)]))
    odd = {}
    # flights 0..judged are resolved (flight k > 0 follows bounce k); each ends at a contact
    flights = tc[:min(judged + 1, tc.size)]
    jerks = flight_jerks(data.t_s, y, r, flights, floor, float(sigma_m or 0.0))
    for i, why in unfree_flights(data, jerks, float(np.mean(ball.mass_kg)), diameter_m, g_m_per_s2):
        odd[int(minima[i])] = why
        if i > 0:
            odd.setdefault(int(minima[i - 1]), why)
    if judged < 2:
        return sorted(odd.items()), minima
    spread = 1.4826 * float(np.median(np.abs(known - floor))) if known.size else 0.0
    limit = max(ODD_CONTACT_DIAMETERS * diameter_m, 0.02, 5.0 * spread)
    for k, (m, h) in enumerate(zip(minima[:judged], yc[:judged])):
        if h - floor > limit:
            odd.setdefault(int(m), f"bounce {k + 1} ({_line(data, int(m))}, t = {tc[k]:.3f} s) touches at "
                           f"{h - floor:.3f} m above the floor level of the other bounces: the ball hit something")
    if judged >= 4:
        labels = [f"bounce {k + 1} ({_line(data, int(m))})" for k, m in enumerate(minima[:judged])]
        found = impact_chains(tc[:judged], labels=labels, tolerance=0.15,
                              timing_sigma_s=0.5 * float(np.median(np.diff(data.t_s))))
        for idx, why in found.anomalies:
            odd.setdefault(int(minima[idx]), why)
    return sorted(odd.items()), minima


def split_trajectory(data, odd, minima):
    """The pieces of a trajectory around its odd bounces: [(piece, label)] and notes.

    A piece ends at the sample before an odd bounce; the next starts at the apex after it
    (the ball is at rest there, vertically: a release from that height). Pieces without a
    normal bounce inside say nothing about the contact and are left out. One note per run of
    samples left out, naming the file's lines.
    """
    t = np.asarray(data.t_s, dtype=float)
    y = np.asarray(data.y_m, dtype=float)
    n = t.size
    bad = [m for m, _ in odd]
    starts, ends = [0], []
    for m in bad:
        ends.append(m)          # exclusive: up to the sample before the odd contact
        following = [x for x in minima if x > m]
        nxt = following[0] if following else n
        apex = m + int(np.argmax(y[m:nxt])) if nxt > m + 1 else m + 1
        starts.append(apex)
    ends.append(n)
    pieces, kept = [], np.zeros(n, dtype=bool)
    for a, b in zip(starts, ends):
        inside = [x for x in minima if a < x < b - 1 and x not in bad]
        if b - a < 10 or not inside:
            continue
        piece = dataclasses.replace(
            data, t_s=t[a:b], y_m=y[a:b], release_index=int(data.release_index) if a == 0 else 0,
            lines=None if data.lines is None else np.asarray(data.lines)[a:b])
        pieces.append((piece, f"{_line(data, a)} to {_line(data, b - 1)}"))
        kept[a:b] = True
    # every sample left out, in runs: the odd bounces, the rise after each (a piece restarts at
    # the apex) and the pieces without a whole bounce
    edges = np.flatnonzero(np.diff(np.concatenate([[0], (~kept).astype(np.int8), [0]])))
    notes = [f"samples {a + 1}-{b} ({_line(data, a)} to {_line(data, b - 1)}) left out"
             + ("" if b == n or not kept[b:].any() else f"; the fit restarts at the apex ({_line(data, b)})")
             for a, b in zip(edges[::2], edges[1::2])]
    return pieces, notes


def without_samples(data, indices):
    """A trajectory without the samples at ``indices``; its release index and file lines follow."""
    keep = np.ones(len(data.t_s), dtype=bool)
    keep[np.asarray(indices, dtype=int)] = False
    release = int(getattr(data, "release_index", 0) or 0)
    lines = getattr(data, "lines", None)
    return dataclasses.replace(data, t_s=np.asarray(data.t_s)[keep], y_m=np.asarray(data.y_m)[keep],
                               release_index=int(np.count_nonzero(keep[:release])),
                               lines=None if lines is None else np.asarray(lines)[keep])


def _impact_runs(data, label):
    chains = getattr(data, "chains", ()) or ()
    if len(chains) <= 1:
        return [(data, label)]
    out = []
    events = data.events if data.events is not None else np.arange(1, len(data.t_s) + 1)
    for a, b in chains:
        sub = dataclasses.replace(data, t_s=np.asarray(data.t_s)[a:b], chains=(), events=np.asarray(events)[a:b],
                                  lines=None if data.lines is None else np.asarray(data.lines)[a:b])
        name = f"events {int(events[a])}-{int(events[b - 1])}"
        out.append((sub, f"{label} {name}".strip()))
    return out


def _of_run(label, note):
    """``note`` said of the run ``label`` of a joint fit ("Run 2: ..."); as it is for a lone run."""
    return f"{label}: {note}" if label else note


#: The least drag coefficient of a ball (a smooth sphere below the drag crisis is 0.4-0.5; the registry's
#: physical lower limit): a rebound above what a ball of epsilon 1 reaches with it cannot be in metres.
LEAST_DRAG_COEFFICIENT = 0.2
#: Drops above this [m] are no class's (a stairwell at most), and are checked against air drag: below it a
#: drag-free simulation of a light ball (a ping-pong ball from 2 m, epsilon 0.97) must pass.
HIGHEST_LAB_DROP_M = 5.0


def _drag_constant_per_m(ball, drag_coefficient):
    """The drag constant k [1/m] of a ball (its mean mass and diameter) at ``drag_coefficient``
    (:func:`vrcal.drop.effects.drag_constant_per_m`): what the unit checks of falls and rebounds hold it to."""
    return float(drag_constant_per_m(drag_coefficient, float(np.mean(ball.diameter_m)), float(np.mean(ball.mass_kg))))


def fastest_fall(t_s, y_m):
    """The fastest fall of a trajectory, as its mean speed: the height lost from the highest sample before
    it over the time since (falls of at least a quarter of the record's span), with the two samples.

    Parameters
    ----------
    t_s, y_m : ndarray
        sample times [s] and heights [m]

    Returns
    -------
    (speed [m/s], from sample, to sample), or None when no fall spans a quarter of the record
    """
    t, y = np.asarray(t_s, dtype=float), np.asarray(y_m, dtype=float)
    if y.size < 2:
        return None
    top = np.maximum.accumulate(y)
    at = np.maximum.accumulate(np.where(y >= top, np.arange(y.size), 0))
    drop, dt = top - y, t - t[at]
    ok = (drop >= 0.25 * float(np.ptp(y))) & (dt > 0) & (drop > 0)
    if not np.any(ok):
        return None
    speed = np.where(ok, drop / np.where(ok, dt, 1.0), 0.0)
    j = int(np.argmax(speed))
    return float(speed[j]), int(at[j]), j


def falls_faster_than_air_lets(runs, ball, g_m_per_s2=STANDARD_GRAVITY_M_PER_S2):
    """Warnings for trajectories whose ball falls, on average over a fall, faster than its terminal speed
    in air ``sqrt(g / k)`` (a sphere's drag, :data:`vrcal.model.restitution.SPHERE_DRAG_COEFFICIENT`; a
    ping-pong ball's 9 m/s): no ball dropped from rest does. Pixels or millimetres read as metres do (a
    ping-pong ball's 180 "m" fall in 0.5 s, and a drop fitted from 100 m with 44 m/s impacts).

    Parameters
    ----------
    runs : sequence of Trajectory
    ball : BallProperties
    g_m_per_s2 : float
        g [m/s^2]

    Returns
    -------
    list of str
        one warning naming the first such run, and how many there are; [] when none
    """
    k = _drag_constant_per_m(ball, SPHERE_DRAG_COEFFICIENT)
    terminal = math.sqrt(g_m_per_s2 / k) if k > 0 else math.inf
    bad = []
    for run in runs:
        fall = fastest_fall(run.t_s, run.y_m)
        if fall is not None and fall[0] > terminal:
            bad.append((run, *fall))
    if not bad:
        return []
    run, v, i, j = bad[0]
    lines = getattr(run, "lines", None)
    where = (f"lines {int(lines[i])} to {int(lines[j])}" if lines is not None and len(lines) == len(run.t_s)
             else f"samples {i} to {j}")
    y = np.asarray(run.y_m, dtype=float)
    return [f"{len(bad)} of {len(runs)} runs fall faster than air lets this ball ({float(y[i] - y[j]):.3g} m in "
            f"{float(run.t_s[j] - run.t_s[i]):.3g} s, {where}: {v:.3g} m/s on average, beyond its terminal "
            f"speed of {terminal:.2g} m/s with a sphere's drag): {UNIT_QUESTION} Pixels or millimetres "
            f"read as metres fall that fast: write the unit in the header, e.g. 'y (mm)', or give --scale M_PER_PX"]


def rebounds_beyond_drag(runs, ball):
    """Warnings for apex heights a ball cannot reach through air: from a drop above
    :data:`HIGHEST_LAB_DROP_M`, a first rebound above what epsilon 1 gives with the least drag a ball
    has (:data:`LEAST_DRAG_COEFFICIENT`). In metres, heights written in inches or centimetres
    without a unit are drops of tens of metres, from which air drag keeps any ball far lower (a
    tennis ball's 40 "m" drop and 29 "m" rebound needs epsilon 1.09). A trajectory's twin is
    :func:`falls_faster_than_air_lets`.

    Parameters
    ----------
    runs : sequence of ApexHeights
        bounce 0 the drop height [m], then the rebounds
    ball : BallProperties

    Returns
    -------
    list of str
        one warning naming the first such run, and how many there are; [] when none
    """
    from vrcal.drop.effects import epsilon_from_heights_with_drag

    k = _drag_constant_per_m(ball, LEAST_DRAG_COEFFICIENT)
    bad = []
    for i, run in enumerate(runs):
        h = np.asarray(run.h_m, dtype=float)
        if h.size >= 2 and h[0] > max(h[1], HIGHEST_LAB_DROP_M) and h[1] > 0 and \
                float(epsilon_from_heights_with_drag(h[1], h[0], k, allow_above_one=True)) > 1.0:
            bad.append((i, h[0], h[1]))
    if not bad:
        return []
    i, H, h = bad[0]
    return [f"{len(bad)} of {len(runs)} drops rebound higher than air lets a ball of epsilon 1 (from {H:.3g} m, "
            f"{h:.3g} m; drag of a smooth sphere at least): {UNIT_QUESTION} Write the unit in the "
            f"header, e.g. 'H (in)', 'H (cm)'"]


def heights_to_bottom(data, diameter_m, drop_measured_to=None, rebound_measured_to=None):
    """Apex heights (one drop's, or the rows of a drop table) with each height brought to the ball's
    bottom, which the model's heights are: a class that reads the top of the ball against a ruler
    reads one diameter more (:func:`vrcal.model.restitution.height_to_bottom_m`).

    Parameters
    ----------
    data : ApexHeights or Runs of ApexHeights
        as read; bounce 0 of each run is the drop height, the others rebounds
    diameter_m : float
        ball diameter D [m]
    drop_measured_to, rebound_measured_to : {"bottom", "centre", "top"} or None
        the point of the ball the drop heights and the rebound heights were measured to; None: not
        stated (taken as the bottom, and discover tries a height offset)

    Returns
    -------
    ApexHeights or Runs
        ``data`` itself when neither is stated, else a copy with the heights moved (when not at the
        bottom) and a note
    """
    from vrcal.measurements.types import Runs
    from vrcal.model.restitution import height_to_bottom_m

    if drop_measured_to is None and rebound_measured_to is None:
        return data
    drop_to, rebound_to = drop_measured_to or "bottom", rebound_measured_to or "bottom"
    runs = data.runs if isinstance(data, Runs) else (data,)
    if runs[0].kind != "apexes":
        why = (": a trajectory's tracked point is found by discover (height_offset)" if runs[0].kind == "trajectory"
               else " (impact times hold no heights)")
        raise UsageError(f"--drop-measured-to and --rebound-measured-to apply to heights (a drop table or the apex "
                         f"heights of one drop), not to {runs[0].kind}{why}")
    moved = []
    for run in runs:
        h = np.asarray(run.h_m, dtype=float)
        first = np.asarray(run.bounce) == 0
        to = np.where(first, height_to_bottom_m(h, drop_to, diameter_m), height_to_bottom_m(h, rebound_to, diameter_m))
        moved.append(dataclasses.replace(run, h_m=to))
    shift = {"bottom": "", "centre": f", -{diameter_m * 500:.1f} mm", "top": f", -{diameter_m * 1e3:.1f} mm"}
    note = (f"heights measured to the ball's {drop_to} (drops{shift[drop_to]}) and {rebound_to} (rebounds"
            f"{shift[rebound_to]})" + ("" if drop_to == rebound_to == "bottom" else
                                       f", brought to its bottom (D = {diameter_m * 1e3:.1f} mm)") +
            "; the point is given, so a height offset is not tried")
    if isinstance(data, Runs):
        return dataclasses.replace(data, runs=tuple(moved), notes=(*data.notes, note))
    return dataclasses.replace(moved[0], notes=(*moved[0].notes, note))


def prepare(data, ball, g_m_per_s2, *, floor_m=None, y_down=False, sigma_m=None, progress=None):
    """The runs to fit, with notes and warnings (see the module docstring).

    Parameters
    ----------
    data : Trajectory or ImpactTimes or ApexHeights or Runs
    ball : BallProperties
    g_m_per_s2 : float
    floor_m : float or None
        see :func:`floor_referenced`
    y_down : bool
        the reader turned the y axis over: the frame of ``floor_m``, and the hint of an upside-down record
    sigma_m : float or None
        noise of one height [m] when known
    progress : callable or None
        ``progress(fraction, message)`` at each stage of a long record

    Returns
    -------
    Prepared
    """
    from vrcal.measurements import Runs, plausibility

    runs = list(data.runs) if isinstance(data, Runs) else [data]
    if sigma_m is not None:   # the release of a trajectory at the noise given, not the reader's estimate
        runs = [release_with_noise(run, sigma_m) if run.kind == "trajectory" else run for run in runs]
    labels = list(data.labels) if isinstance(data, Runs) and data.labels else (
        [f"run {i + 1}" for i in range(len(runs))] if len(runs) > 1 else [""])
    notes, shifted = list(getattr(data, "notes", ()) if isinstance(data, Runs) else ()), []
    shifts = []
    common = _common_floor(runs, ball) if floor_m is None and len(runs) > 1 else None
    if common is not None:
        notes.append(f"heights are not referenced to the floor in any run (lowest samples after release "
                     f"{common[0]:+.4f} to {common[1]:+.4f} m): all shifted by {-common[0]:+.4f} m, one level "
                     f"for all runs, so that the lowest sample is at 0 (a level per run would differ by where "
                     f"each run's samples fall in its bounces; give --floor to set the floor)")
    for run, label in zip(runs, labels):
        if common is not None:
            new, note = dataclasses.replace(run, y_m=np.asarray(run.y_m, dtype=float) - common[0]), None
            shifts.append(common[0])
        else:
            new, note = floor_referenced(run, floor_m, ball, y_down=y_down)
            shifts.append(float(np.asarray(run.y_m)[0] - np.asarray(new.y_m)[0]) if note else 0.0)
        if note:
            notes.append(_of_run(label, note))
        shifted.append(new)
    record = Runs(runs=tuple(shifted), source=data.source, labels=tuple(labels)) if isinstance(data, Runs) \
        else shifted[0]
    diameter = float(np.mean(ball.diameter_m))
    if shifted[0].kind == "trajectory":
        for run in shifted:   # the frame rate as recorded (decimation lowers it)
            plausibility.check_sampling(run.t_s, run.source)
    record, factor, full_noise = _decimated(record, notes, progress)
    sigma = sigma_m if sigma_m is not None else full_noise
    if sigma is None and shifted[0].kind == "trajectory":
        first = record.runs[0] if isinstance(record, Runs) else record
        sigma = third_difference_sigma(np.asarray(first.t_s, float), np.asarray(first.y_m, float))
    if progress is not None:
        progress(0.5, "checking the record and finding its bounces")
    g_flight, drag_per_m = flight_expectation(float(np.mean(ball.mass_kg)), diameter, g_m_per_s2)
    checked = plausibility.check(record, diameter, g_m_per_s2, y_down=y_down, sigma_m=sigma or 0.0,
                                 g_expected_m_per_s2=g_flight, drag_per_m=drag_per_m)
    notes += list(checked.notes)
    warnings = list(checked.warnings)
    record = checked.data
    runs = list(record.runs) if isinstance(record, Runs) else [record]
    labels = list(record.labels) if isinstance(record, Runs) else [""]
    if runs[0].kind == "apexes":
        warnings += rebounds_beyond_drag(runs, ball)
    elif runs[0].kind == "trajectory":
        warnings += falls_faster_than_air_lets(runs, ball, g_m_per_s2)
    out = []
    for run, label in zip(runs, labels):
        if run.kind == "impacts":
            out += _impact_runs(run, label)
        elif run.kind == "trajectory":
            odd, minima = odd_bounces(run, ball, g_m_per_s2, sigma or 0.0)
            pieces = [(run, label)]
            if odd:
                for _, why in odd:
                    notes.append(_of_run(label, why + "; left out"))
                split, cut_notes = split_trajectory(run, odd, minima)
                notes += [_of_run(label, n) for n in cut_notes]
                pieces = [(p, f"{label} {lab}".strip()) for p, lab in split]
                if not pieces:
                    warnings.append(f"{run.source}: every bounce is odd; fitting the record as it is")
                    pieces = [(run, label)]
            for piece, name in pieces:
                # within what is fitted (a hold's junk is cut above); a record in the wrong unit has no contact
                # to be below (a pixel track read as metres)
                below = [] if warnings else samples_below_contacts(piece, ball, g_m_per_s2, sigma or 0.0,
                                                                   surface_of(ball))
                if below:
                    notes += [_of_run(name, why + "; left out") for _, why in below]
                    piece = without_samples(piece, [i for i, _ in below])
                out.append((piece, name))
        else:
            out.append((run, label))
    if len(out) > MAX_RUNS:
        what = {"impacts": "chains of consecutive bounces (drops)", "apexes": "trials"}.get(out[0][0].kind, "runs")
        raise DataError(f"{data.source}: {len(out):,} {what} to fit jointly, more than {MAX_RUNS} (a joint fit's "
                        f"time grows as the cube of its runs): split the record into files of at most {MAX_RUNS} "
                        f"drops")
    if len(out) == 1:
        fitted = out[0][0]
    else:
        fitted = Runs(runs=tuple(r for r, _ in out), source=data.source, labels=tuple(lab for _, lab in out))
    return Prepared(fitted, tuple(lab for _, lab in out), tuple(notes), tuple(warnings), tuple(shifts), factor,
                    full_noise)
