"""Is the record physically possible? Plausibility checks from physics, in one place.

A file can be read without error and still be wrong in a way no parser sees: heights in mm
under a header that says m, impact times in ms under ``s``, a track upside down, a list of
"impacts" whose intervals grow. Fitted as they are, they give confident nonsense. Each check
here ends in one of three ways:

* nothing to say (the record is plausible), or a note;
* a **warning** (:class:`Finding` with level "warning"): something looks off but the record
  can still be fitted (g from the flights 12 % off 9.81); ``vrcal discover`` then gives the
  verdict "suspect input" and names what looks wrong;
* a one-line :class:`vrcal.errors.DataError` (exit status 1) naming what looks wrong and the
  fix ("the record looks upside down: use --y-down", "heights look like mm, not m: ...").

The checks (each a function below):

* the sampling: a frame rate between :data:`FRAME_RATE_HZ` (a video at 1 frame per second is
  no drop record, nor is one at 10^14 frames per second; times in ms read as s give the one,
  times scaled by 1e-12 the other) (:func:`check_sampling`);
* g from the flights of a trajectory (a parabola through each flight between bounces)
  against the g the fit assumes: its sign tells a record upside down, its size the units of
  heights and times (mm read as m give 1000 g) and the frame rate (:func:`flight_gravity`);
* the bounces shrink: the impact intervals of a bouncing ball shrink (epsilon <= 1), its
  apexes fall, a rebound stays below its drop (:func:`check_impact_times`, :func:`check_apexes`);
  in a drop table (:class:`vrcal.measurements.types.Runs` of apexes) a trial whose rebound is
  above its drop is left out with a warning naming its line, and most trials so are an error
  (the columns swapped) (:func:`check`);
* the ball's size against the record's scale: drop heights between half a ball diameter and
  :data:`MAX_DROP_M` (a drop table in cm read as m has drops of 110 m).
"""

from __future__ import annotations

import math
from dataclasses import replace
from typing import NamedTuple

import numpy as np

from vrcal.errors import DataError
from vrcal.measurements.cleanup import (
    bounce_height_m,
    prominent_minima,
    still_level,
    third_difference_sigma,
    toss_top_index,
)
from vrcal.model.restitution import STANDARD_GRAVITY_M_PER_S2
from vrcal.textout import number

#: Sampling rates a drop record can have [Hz]: a slow video to a fast tracker or a sound card.
FRAME_RATE_HZ = (2.0, 2e5)

#: Highest plausible drop height [m] (a drop from a building; beyond it the units are wrong).
MAX_DROP_M = 50.0

#: Flight durations of a plausible first rebound [s]: 10 ms (a rebound of 0.1 mm) to 6 s (44 m).
FLIGHT_S = (0.01, 6.0)

#: |g from the flights| / g: inside this band the record is plausible (air drag and buoyancy
#: change the mean curvature of a flight by a few per cent); outside it but inside the wider
#: one a warning; beyond it an error.
G_OK = (0.85, 1.2)
G_WARN = (0.6, 1.6)

#: Impact intervals whose median ratio (one flight over the one before) is at least this do not
#: shrink: epsilon would be 1 (equally spaced times are a clock's ticks or a sensor's samples, not a
#: ball bouncing; the bounciest balls on a floor shrink their flights by several per cent a bounce).
EQUAL_INTERVALS_RATIO = 0.995

#: Unit mix-ups tried when a scale is far off: (factor by which the record is too large, what it means).
LENGTH_MIXUPS = ((1e3, "mm", 1e-3), (1e2, "cm", 1e-2), (1e-2, "m under a header in cm", 1e2),
                 (1e-3, "m under a header in mm", 1e3))


#: Frame rates cameras record at [Hz]: film and TV (24-60), phones' and action cameras' slow motion (120-960).
STANDARD_FRAME_RATES_HZ = (24.0, 25.0, 30.0, 48.0, 50.0, 60.0, 90.0, 100.0, 120.0, 180.0, 200.0, 240.0, 300.0,
                           480.0, 960.0, 1000.0)


def standard_frame_rate(rate_hz, tolerance=0.04):
    """The standard frame rate (:data:`STANDARD_FRAME_RATES_HZ`) within ``tolerance`` (a fraction) of ``rate_hz``
    [Hz], the nearest; None when there is none (a motion that fits 246 fps was most likely filmed at 240)."""
    rate = float(rate_hz)
    if not (math.isfinite(rate) and rate > 0):
        return None
    best = min(STANDARD_FRAME_RATES_HZ, key=lambda r: abs(math.log(r / rate)))
    return best if abs(best / rate - 1.0) <= tolerance else None


def _slow_clock(ratio, t_s, g_fit):
    """What a record whose flights fall at ``g_fit`` [m/s^2], ``ratio`` times this ball's (well below 1), says of
    its clock when the lengths are right: times k = 1/sqrt(ratio) too long, a slow-motion clip read at its
    playback rate when k is near a ratio of standard frame rates (240 fps shown at 30: 8); --g at the flights'
    g fits it as it is."""
    k = 1.0 / math.sqrt(ratio)
    dt = float(np.median(np.diff(t_s))) if np.size(t_s) > 1 else float("nan")
    shown = 1.0 / dt if dt > 0 else float("nan")
    recorded = standard_frame_rate(shown * k) if math.isfinite(shown) else None
    played = standard_frame_rate(shown) if math.isfinite(shown) else None
    rates = (f" (recorded at {recorded:g} fps, written at {played:g}: a slow-motion clip at its playback rate?)"
             if recorded and played and recorded > played else "")
    fix = f"--fs {recorded:g}" if recorded else f"--fs {shown * k:.3g}"
    return (f"; if the lengths are right, the times are {k:.3g} times too long{rates}: divide the time column by "
            f"{k:.3g} ({fix} where the times come from --fs), or give --g {g_fit:.4g} to fit the record as it is "
            f"(epsilon does not depend on the time scale)")


class Finding(NamedTuple):
    """One result of a check: level "note" or "warning", and what was found."""

    level: str
    text: str


class Checked(NamedTuple):
    """The record after the checks (runs that cannot be physical left out) and what was found."""

    data: object
    findings: tuple

    @property
    def warnings(self):
        return tuple(f.text for f in self.findings if f.level == "warning")

    @property
    def notes(self):
        return tuple(f.text for f in self.findings if f.level == "note")


#: The question a warning asks when the heights' unit is the likely cause of what looks wrong (:func:`unit_suspected`).
UNIT_QUESTION = "are the heights in metres?"
#: What to check instead of the ball's mass and diameter when the heights' unit is suspected.
CHECK_UNIT_FIRST = "check the heights' unit first: a unit misread, not the ball, is the likely cause (see the warning)"


def unit_suspected(warnings):
    """Whether a warning (of a record's, :data:`UNIT_QUESTION`) names the heights' unit as the likely cause:
    then the ball's mass and diameter are not to be blamed for what the unit explains."""
    return any(UNIT_QUESTION in str(w) for w in warnings or ())


def _fail(source, text):
    raise DataError(f"{source}: {text}")


# --------------------------------------------------------------------------- sampling and g


def check_sampling(t_s, source="data"):
    """The sample interval of a trajectory must give a plausible frame rate.

    Parameters
    ----------
    t_s : ndarray
        sample times [s], increasing
    source : str
        the file (for messages)

    Raises
    ------
    DataError
        a frame rate outside :data:`FRAME_RATE_HZ`, naming the likely unit mix-up
    """
    t = np.asarray(t_s, dtype=float)
    if t.size < 2:
        return
    dt = float(np.median(np.diff(t)))
    fs = 1.0 / dt if dt > 0 else math.inf
    lo, hi = FRAME_RATE_HZ
    if fs < lo:
        hint = (": the times look like ms, not s (write 't (ms)' in the header)" if lo <= fs * 1e3 <= hi else
                ": the times are not in seconds")
        _fail(source, f"samples are {dt:.4g} s apart ({fs:.3g} frames/s){hint}")
    if fs > hi:
        hint = (": the times look like s under a header in ms" if lo <= fs / 1e3 <= hi else
                ": the times are not in seconds (a video runs at 24-1000 frames/s)")
        _fail(source, f"samples are {dt:.3g} s apart (a frame rate of {fs:.3g} Hz){hint}")


#: Fewest samples of a flight, clear of its contacts, that the plausibility checks fit a parabola through.
FLIGHT_MIN_SAMPLES = 7


def _flight_edges(z, sigma):
    """Indices bounding the flights of ``z``: its start, its prominent minima, its end. Without a minimum
    but with a top, the whole record is one flight: a record cut inside one flight is a parabola upright,
    and turned over its top is a minimum between two "flights" that meet without a cusp (the turned-over
    record must not win on them: 'upside down' for a ball that never bounced). None without either."""
    if z.size < 8:
        return []
    prominence = max(8.0 * sigma, 0.05 * float(np.ptp(z)))
    minima = prominent_minima(z, prominence)
    if not minima.size and not prominent_minima(-z, prominence).size:
        return []      # no top either: a fall alone, or no motion
    return [0] + [int(m) for m in minima] + [z.size - 1]


def _flight_segments(t, y, sign, release, sigma, between_bounces=False):
    """The flights of ``sign * y`` between its prominent minima, the samples next to a contact left out:
    [(times from the segment's start [s], heights [unit])] of those with :data:`FLIGHT_MIN_SAMPLES`;
    ``between_bounces``: only those with a minimum at both ends."""
    z = sign * y[release:]
    tt = t[release:]
    edges = _flight_edges(z, sigma)
    if between_bounces:
        edges = edges[1:-1]
    out = []
    for a, b in zip(edges[:-1], edges[1:]):
        lo, hi = a + 2, b - 1      # leave out the samples next to a contact
        if hi - lo >= FLIGHT_MIN_SAMPLES - 1:
            out.append((tt[lo:hi] - tt[lo], z[lo:hi]))
    return out


def _clean(rms, z, sigma):
    """A flight fits its curve to the noise (one with a small bounce or a cusp inside does not)."""
    return rms <= max(4.0 * sigma, 0.01 * float(np.ptp(z)))


def _flight_fits(t, y, sign, release, sigma, between_bounces=False):
    """Parabolas through the flights of ``sign * y`` between its prominent minima:
    [(curvature y'' [unit/s^2], rms residual [unit], samples, standard error of the curvature [unit/s^2])]
    (the error from the larger of the parabola's scatter and ``sigma``); ``between_bounces``: see
    :func:`_flight_segments`."""
    out = []
    for ts, z in _flight_segments(t, y, sign, release, sigma, between_bounces):
        coef, res, *_ = np.polyfit(ts, z, 2, full=True)
        rms = math.sqrt(float(res[0]) / z.size) if res.size else 0.0
        if _clean(rms, z, sigma):
            u = (ts - ts.mean()) / max(float(np.ptp(ts)), 1e-12)
            sd = max(rms * math.sqrt(z.size / max(z.size - 3, 1)), float(sigma))
            se = 2.0 * sd * math.sqrt(float(np.linalg.inv(np.vander(u, 3).T @ np.vander(u, 3))[0, 0])) \
                / max(float(np.ptp(ts)), 1e-12) ** 2
            out.append((2.0 * float(coef[0]), rms, z.size, se))
    return out


def flight_curvatures(t_s, y_m, release_index=0, sigma_m=0.0, between_bounces=False):
    """The parabolas through the flights of an upright trajectory (between its bounces, the samples next to a
    contact left out) that fit to the noise: [(curvature y'' [m/s^2], rms residual [m], samples, standard
    error of the curvature [m/s^2])]; ``between_bounces``: only the flights with a bounce at both ends (not
    the first fall, nor a flight the record ends in).

    Parameters
    ----------
    t_s, y_m : array_like
        sample times [s] and heights [m]
    release_index : int
        first sample after the still segment
    sigma_m : float
        noise of one height [m]
    """
    return _flight_fits(np.asarray(t_s, dtype=float), np.asarray(y_m, dtype=float), 1.0, int(release_index),
                        float(sigma_m), between_bounces)


def _weighted_median_g(fits):
    """Minus the sample-weighted median curvature of [(curvature, rms, samples)] [m/s^2]."""
    curv = np.array([f[0] for f in fits])
    weights = np.array([f[2] for f in fits], dtype=float)
    order = np.argsort(curv)
    cum = np.cumsum(weights[order])
    return -float(curv[order][np.searchsorted(cum, 0.5 * cum[-1])])


def drag_flight_height_m(t_s, g_m_per_s2, k_per_m, apex_time_s, apex_height_m):
    """Height of a ball in free flight with quadratic air drag, about its apex [m].

    Parameters
    ----------
    t_s : float or ndarray
        time [s]
    g_m_per_s2 : float
        the downward acceleration without drag [m/s^2], > 0 (g, or g less buoyancy)
    k_per_m : float
        drag constant k of ``a = -g - k v|v|`` [1/m], > 0
    apex_time_s, apex_height_m : float
        time [s] and height [m] of the apex (of the release, for a fall from rest)

    Returns
    -------
    height_m : float or ndarray
        ``h0 + ln cos(s) / k`` rising (s < 0), ``h0 - ln cosh(s) / k`` falling, s = sqrt(g k) (t - t0)

    Notes
    -----
    Not in [1] (drag-free flights). The rise is cut at s = -pi/2 (an infinite launch speed).
    """
    s = math.sqrt(g_m_per_s2 * k_per_m) * (np.asarray(t_s, dtype=float) - apex_time_s)
    rising = np.log(np.cos(np.clip(s, -0.5 * math.pi + 1e-9, 0.0)))
    falling = -(np.logaddexp(s, -s) - math.log(2.0))   # -ln cosh(s), no overflow
    out = apex_height_m + np.where(s < 0, rising, falling) / k_per_m
    return float(out) if out.ndim == 0 else out


def _drag_fit_g(segments, k_per_m, sigma):
    """g that flights with drag k need, fitted to each segment (g, apex time and height free): the
    sample-weighted median over the segments that fit to the noise, and how many did (None, 0 if none)."""
    from scipy.optimize import least_squares

    fits = []
    for ts, z in segments:
        a, b, c = np.polyfit(ts, z, 2)
        t0 = float(np.clip(-b / (2.0 * a), ts[0] - ts[-1], 2.0 * ts[-1])) if a < 0 else float(ts[0])
        x0 = (max(-2.0 * a, 0.1), t0, float(np.max(z)))

        def resid(p, ts=ts, z=z):
            return drag_flight_height_m(ts, p[0], k_per_m, p[1], p[2]) - z

        try:
            sol = least_squares(resid, x0, bounds=([1e-6, -np.inf, -np.inf], np.inf), x_scale="jac")
        except ValueError:
            continue
        rms = math.sqrt(float(np.mean(sol.fun ** 2)))
        if sol.success and _clean(rms, z, sigma):
            fits.append((-float(sol.x[0]), rms, z.size))
    return (_weighted_median_g(fits), len(fits)) if fits else (None, 0)


def release_fall_sign(t_s, y_m, release_index=0):
    """Which way the ball falls from its release, without assuming parabolic flights.

    A ball let go moves away from where it was held and accelerates the same way: downward. From the
    release to where the record has moved a quarter of its span, the direction of the motion and the
    sign of a quadratic's curvature must agree. A tossed ball accelerates upward in the hand, as a record
    turned over falls; its first motion turns and comes back past where it started, which a fall into a
    bounce never does (:func:`~vrcal.measurements.cleanup.toss_top_index`): then that motion was upward.

    Parameters
    ----------
    t_s, y_m : ndarray
        sample times [s] and heights [m]
    release_index : int
        first sample after the still segment

    Returns
    -------
    int
        +1: falls as y decreases (upright); -1: as y increases (upside down); 0: cannot tell (too few
        samples, or a record that starts moving one way and accelerating the other: thrown, or mid-flight; or
        one that first moves the other way: it starts at a bounce)
    """
    level = still_level(y_m, release_index) if np.size(y_m) > int(release_index) else None
    top = toss_top_index(t_s, y_m, release_index, level)
    if top is not None:
        # tossed (or rising at the first sample): the first motion turned and came back past its start,
        # which no bounce does; it went up
        return 1 if y_m[top] > level else -1
    start = max(int(release_index) - 1, 0)
    t = np.asarray(t_s, dtype=float)[start:]
    y = np.asarray(y_m, dtype=float)[start:]
    span = float(np.ptp(y)) if y.size else 0.0
    if span <= 0:
        return 0
    moved = np.flatnonzero(np.abs(y - y[0]) >= 0.25 * span)
    if moved.size == 0 or moved[0] < 3:
        return 0
    j = int(moved[0])
    # a ball let go moves away from where it was held; one that first goes the other way (beyond the noise)
    # was in flight: a record that starts falling into a bounce rises from it, its V curving upward
    back = float(np.max(y[:j + 1]) - y[0]) if y[j] < y[0] else float(y[0] - np.min(y[:j + 1]))
    if back > max(5.0 * (third_difference_sigma(t, y) or 0.0), 1e-3 * span):
        return 0
    curvature = float(np.polyfit(t[:j + 1] - t[0], y[:j + 1], 2)[0])
    direction = float(np.sign(y[j] - y[0]))
    return int(-direction) if direction == np.sign(curvature) else 0


def flight_gravity(t_s, y_m, release_index=0, sigma_m=0.0):
    """g seen in the flights of a trajectory, and whether the record is upside down.

    Parabolas are fitted to the flights between the bounces (prominent minima) of the record
    and of the record turned over, and kept where they fit to the noise; the orientation with
    more samples on such parabolas is the true one (turned over, each "flight" has a bounce's
    cusp inside).

    Parameters
    ----------
    t_s, y_m : ndarray
        sample times [s] and heights [m]
    release_index : int
        first sample after the still segment
    sigma_m : float
        noise of one height [m] (sets the least prominence of a bounce)

    Returns
    -------
    (g_m_per_s2, upside_down, n_flights) : (float or None, bool, int)
        g = minus the median curvature of the flights (None when no flight has 7 samples
        clear of the contacts); upside_down when the turned-over record is the one with parabolic flights
    """
    t = np.asarray(t_s, dtype=float)
    y = np.asarray(y_m, dtype=float)
    up = _flight_fits(t, y, 1.0, release_index, sigma_m)
    down = _flight_fits(t, y, -1.0, release_index, sigma_m)

    def samples(fits):
        return sum(f[2] for f in fits)

    # the true orientation has its flights between the bounces: more samples on clean parabolas
    fits, upside = up, False
    if samples(down) > 1.5 * samples(up):
        fits, upside = down, True
    if not fits:
        return None, False, 0
    return _weighted_median_g(fits), upside, len(fits)


#: Relative spread of the flights' g (their parabolas' curvatures) beyond which, and beyond
#: :data:`FLIGHT_G_SIGMAS` of their standard errors, the flights disagree on g (:func:`flight_g_disagreement`).
FLIGHT_G_SPREAD = 0.03
FLIGHT_G_SIGMAS = 5.0


def flight_g_disagreement(fits):
    """How the flights' parabolas disagree on g, as a phrase, or None when they agree.

    Each flight's g is minus its parabola's curvature; one g for all cannot fit flights whose g differ
    by more than :data:`FLIGHT_G_SPREAD` of their median and by :data:`FLIGHT_G_SIGMAS` combined standard
    errors: the length scale changes across the picture (a lens's distortion, perspective, the ball
    moving towards or away from the camera), or the time scale drifts. Their median alone had hidden that:
    a marble's 39-sample fall in a vacuum chamber at 9.81 m/s^2 and its 53-sample rise at 9.06 gave
    "g from the parabolas of 1 of 2 flights: 9.06".

    Parameters
    ----------
    fits : list of (curvature [m/s^2], rms [m], samples, standard error [m/s^2])
        the flights' parabolas (:func:`_flight_fits`)

    Returns
    -------
    str or None
    """
    if len(fits) < 2:
        return None
    g = np.array([-f[0] for f in fits])
    se = np.array([f[3] for f in fits])
    lo, hi = int(np.argmin(g)), int(np.argmax(g))
    middle = float(np.median(g))
    if middle <= 0 or (g[hi] - g[lo]) / middle <= FLIGHT_G_SPREAD:
        return None
    if g[hi] - g[lo] <= FLIGHT_G_SIGMAS * math.hypot(se[hi], se[lo]):
        return None
    return (f"the flights disagree on g: {number(g[lo], 3)} ± {se[lo]:.2g} to {number(g[hi], 3)} ± {se[hi]:.2g} "
            f"m/s^2 ({100 * (g[hi] - g[lo]) / middle:.2g} %), more than their noise allows; one g fits none of "
            "them well: the length scale changes across the picture (a lens's distortion, perspective, the ball "
            "moving towards or away from the camera) or the frame rate is not steady")


#: Drag matters to the flights' shape when ``1 - exp(-2 k H)`` (how far below the drag-free one the squared
#: impact speed of a fall from the record's height lies) is at least this: the orientation then is told by
#: the fall from the release (:func:`release_fall_sign`) when the parabolas disagree, and g by flights with
#: drag when the parabolas miss it.
DRAG_MATTERS = 0.05


def check_trajectory(data, g_m_per_s2=STANDARD_GRAVITY_M_PER_S2, *, y_down=False, sigma_m=0.0,
                     g_expected_m_per_s2=None, drag_per_m=()):
    """Sampling, orientation and g of a trajectory: a list of :class:`Finding`, or a DataError.

    ``g_expected_m_per_s2`` is the acceleration this ball's flights should show without drag (g less
    its buoyancy, with its added mass: ``g_m_per_s2`` when None); ``drag_per_m`` the drag constants k
    [1/m] of this ball over the plausible drag coefficients (empty: drag not considered). The flights
    are judged against them, not against bare g: a balloon falls with 0.59 g and its flights are no
    parabolas.
    """
    check_sampling(data.t_s, data.source)
    t = np.asarray(data.t_s, dtype=float)
    y = np.asarray(data.y_m, dtype=float)
    release = getattr(data, "release_index", 0) or 0
    g_exp = float(g_expected_m_per_s2 or g_m_per_s2)
    ks = tuple(float(k) for k in np.atleast_1d(drag_per_m) if k > 0)
    span = float(np.ptp(y[release:])) if y.size > release else 0.0
    dragged = bool(ks) and -math.expm1(-2.0 * max(ks) * span) >= DRAG_MATTERS
    g_fit, upside, n = flight_gravity(t, y, release, sigma_m)
    fall = release_fall_sign(t, y, release) if dragged else 0
    fix = "remove --y-down" if y_down else "use --y-down"
    if fall > 0 and (upside or g_fit is None):
        # drag-dominated flights are no parabolas (and a resting tail's small bounces look like an
        # upside-down record's): the ball falls downward from its release, so it is upright
        fits = _flight_fits(t, y, 1.0, release, sigma_m)
        g_fit, upside, n = (_weighted_median_g(fits), False, len(fits)) if fits else (None, False, 0)
    if upside:
        _fail(data.source, f"the record looks upside down (its flights curve upward, {abs(g_fit):.3g} m/s^2): {fix}")
    if fall < 0:
        _fail(data.source, f"the record looks upside down (the ball falls upward from its release): {fix}")
    if g_fit is None and not dragged:
        return [Finding("note", "g cannot be checked: no flight has 7 samples clear of the contacts")]
    # named where buoyancy matters (a light ball); the judgement is against g_exp all the same
    expected = "" if abs(g_exp / g_m_per_s2 - 1.0) < 0.05 else f"; this ball's {g_exp:.3g} with buoyancy"
    ratio = None     # the parabolas' g over the expected one, when they curve downward
    apart = None     # how the flights disagree on g (flight_g_disagreement)
    if g_fit is not None and g_fit >= 0:
        ratio = g_fit / g_exp
        flights = max(len(_flight_edges(y[release:], sigma_m)) - 1, n)
        which = f"{n} flight(s)" if flights <= n else (
            f"{n} of {flights} flights (each alone; the others hold fewer than {FLIGHT_MIN_SAMPLES} samples clear "
            f"of their contacts, or no one parabola)")
        text = f"g from the parabolas of {which}: {number(g_fit, 3)} m/s^2 ({g_fit / g_m_per_s2:.3f} x " \
               f"{g_m_per_s2:.4g}{expected})"
        # flights that disagree on g beyond drag's doing (a light ball's high flights curve less), said where g
        # is about right (a wrong frame rate or unit is told first)
        apart = None if dragged else flight_g_disagreement(_flight_fits(t, y, 1.0, release, sigma_m))
        if G_OK[0] <= ratio <= G_OK[1]:
            return [Finding("note", f"{text}; {apart}" if apart else text)]
    if dragged:
        segments = _flight_segments(t, y, 1.0, release, sigma_m)
        drag_fits = [(_drag_fit_g(segments, k, sigma_m), k) for k in ks]
        drag_fits = [(g, nd, k) for (g, nd), k in drag_fits if g is not None and g > 0]
        if drag_fits:
            g_d, n_d, k = min(drag_fits, key=lambda f: abs(math.log(f[0] / g_exp)))
            drag_text = (f"g from {n_d} flight(s) with this ball's air drag (k = {k:.3g} 1/m): {number(g_d, 3)} m/s^2 "
                         f"({g_d / g_m_per_s2:.3f} x {g_m_per_s2:.4g}{expected})")
            if G_OK[0] <= g_d / g_exp <= G_OK[1]:
                return [Finding("note", drag_text)]
            if ratio is None or (G_WARN[0] <= g_d / g_exp <= G_WARN[1] and not G_WARN[0] <= ratio <= G_WARN[1]):
                # judged by the flights of this ball, not parabolas (which judge a record far off as before)
                g_fit, ratio, text = g_d, g_d / g_exp, drag_text
        elif g_fit is None:
            # heights in another unit scale the drag constant too: flights with k / factor fall with g x factor
            k = ks[len(ks) // 2]
            for factor, unit, scale in LENGTH_MIXUPS:
                g_u, _ = _drag_fit_g(segments, k / factor, sigma_m)
                if g_u is not None and G_OK[0] <= g_u / g_exp / factor <= G_OK[1]:
                    _fail(data.source, f"heights look like {unit}, not as read: the flights fall as this ball's "
                                       f"would with {g_u:.3g} m/s^2 ({g_u / g_m_per_s2:.3g} x g) (write the unit in "
                                       f"the header, e.g. 'y (mm)', or give --scale {scale:g})")
            return [Finding("note", "g cannot be checked: no flight fits a parabola or a flight with this ball's "
                                    "air drag")]
    if g_fit < 0:
        return [Finding("note", "g cannot be checked: the flights do not curve one way")]
    if G_WARN[0] <= ratio <= G_WARN[1]:
        said = f"{text}; {apart}" if apart and text.startswith("g from the parabolas") else text
        return [Finding("warning", f"{said}: the frame rate or the length scale looks off (check --fs, --scale "
                                   f"and the units in the header)")]
    drop = float(np.ptp(data.y_m))
    for factor, unit, scale in LENGTH_MIXUPS:
        if G_OK[0] <= ratio / factor <= G_OK[1]:
            _fail(data.source, f"heights look like {unit}, not as read: the flights fall with {g_fit:.3g} m/s^2 "
                               f"({g_fit / g_m_per_s2:.3g} x g) and the drop would be {drop:.3g} m "
                               f"(write the unit in the header, e.g. 'y (mm)', or give --scale {scale:g})")
    for factor, unit in ((1e-6, "ms"), (1e6, "s under a header in ms")):
        if G_OK[0] <= ratio / factor <= G_OK[1]:
            _fail(data.source, f"times look like {unit}: the flights fall with {g_fit:.3g} m/s^2 "
                               f"({g_fit / g_m_per_s2:.3g} x g)")
    pixels = (f"; if the heights are pixels, --scale {1.0 / ratio:.3g} (m per pixel) makes the flights fall "
              f"with g at this frame rate") if ratio > 20.0 else ""
    clock = _slow_clock(ratio, t, g_fit) if 1e-3 < ratio < G_WARN[0] else ""
    _fail(data.source, f"{text}: the heights or the times are not in the units read (check --fs, --scale and the "
                       f"units in the header){pixels}{clock}")


# --------------------------------------------------------------------------- impacts and apexes


#: What a list of equally spaced "impact times" is told about reading a trajectory instead.
TRAJECTORY_HINT = ("a trajectory's height column is named 'y', 'height', 'position' or 'Höhe'; or give --format "
                   "trajectory")


def check_impact_times(t_s, source="data", trajectory_hint=TRAJECTORY_HINT):
    """Impact times of one drop must be those of a bouncing ball: intervals that shrink (not equally
    spaced: :data:`EQUAL_INTERVALS_RATIO`; not growing), the longest of the first three flights between
    10 ms and 6 s. Raises DataError otherwise (naming the likely unit mix-up; equally spaced times end with
    ``trajectory_hint``, how to read the file as a trajectory)."""
    t = np.asarray(t_s, dtype=float)
    if t.size < 2:
        return
    dt = np.diff(t)
    if dt.size >= 2 and np.all(dt > 0):
        ratio = float(np.median(dt[1:] / dt[:-1]))
        if EQUAL_INTERVALS_RATIO <= ratio <= 1.0:
            _fail(source, f"the intervals between impacts do not shrink ({dt.size:,} intervals of about "
                          f"{float(np.median(dt)):.4g} s, median ratio {ratio:.4f}): epsilon would be 1, and no "
                          f"ball bounces like that; these look like a clock's ticks or a sensor's samples, not "
                          f"impact times ({trajectory_hint})")
    first = float(np.max(dt[:3]))   # the longest of the first flights (an echo may shorten one)
    lo, hi = FLIGHT_S
    height = float(bounce_height_m(first))
    if first > hi or first < lo:
        if lo <= first * 1e-3 <= hi:
            hint = "the times look like ms, not s (write 't (ms)' in the header)"
        elif lo <= first * 1e3 <= hi:
            hint = "the times look like s under a header in ms"
        else:
            hint = "the times are not in seconds"
        _fail(source, f"the first flights last up to {first:.3g} s, a rebound {height:.3g} m high: {hint}")
    if dt.size >= 3:
        ratio = float(np.median(dt[1:] / dt[:-1]))
        if ratio > 1.0:
            _fail(source, f"the intervals between impacts grow (median ratio {ratio:.3f}): a ball bouncing on a "
                          f"floor makes them shrink (epsilon <= 1); are these impact times of one drop, in order?")


def _drop_scale(h_m, diameter_m, source, label=""):
    """Drop height against the ball and the world: DataError for a unit mix-up; a warning text or None."""
    H = float(np.max(h_m))
    where = f"{label}: " if label else ""
    if H > MAX_DROP_M:
        best = min((abs(math.log10(H * s)), unit, s) for _, unit, s in LENGTH_MIXUPS if s < 1)
        _fail(source, f"{where}a drop of {H:.4g} m is not a lab drop: heights look like {best[1]} (write "
                      f"'H ({best[1]})' in the header, or give --scale {best[2]:g})")
    if diameter_m and H < 0.5 * diameter_m:
        return (f"{where}the drop ({H * 100:.3g} cm) is less than half the ball's diameter ({diameter_m * 100:.3g} "
                f"cm): {UNIT_QUESTION} (not cm or mm)")
    return None


def _check_above_floor(runs, source, diameter_m):
    """A height at or below the floor is impossible: the readers refuse one as written, so it comes from
    bringing heights measured to the ball's top or centre down to its bottom
    (:func:`vrcal.model.restitution.height_to_bottom_m`, ``--drop-measured-to``). DataError naming the
    first such height, its line, and how many; a rebound above such a drop is not blamed on swapped
    columns."""
    low = [(run, k) for run in runs if run.kind == "apexes" for k in np.flatnonzero(np.asarray(run.h_m) <= 0)]
    if not low:
        return
    run, k = low[0]
    lines = getattr(run, "lines", None)
    at = f" of line {int(lines[k])}" if lines is not None else ""
    what = {0: "drop", 1: "rebound"}.get(int(run.bounce[k]), f"apex {int(run.bounce[k])}")
    size = f" ({diameter_m * 100:.3g} cm)" if diameter_m else ""
    n = sum(len(run.h_m) for run in runs)
    _fail(source, f"{len(low)} of {n} heights lie at or below the floor once brought to the ball's bottom (the "
                  f"{what}{at}: {run.h_m[k] * 100:.3g} cm): a height measured to the ball's top cannot be less than "
                  f"its diameter{size}, nor one to its centre less than its radius: were they measured to the "
                  f"bottom? (--drop-measured-to, --rebound-measured-to)")


def check_apexes(data, diameter_m=None, label=""):
    """One drop's apex heights: the rebound below the drop and the apexes falling.

    Returns (data, findings): a later apex that rises ends the record there (a note);
    DataError when the first rebound is above the drop or the drop is out of scale.
    """
    findings = []
    _check_above_floor((data,), data.source, diameter_m)
    h = np.asarray(data.h_m, dtype=float)
    warn = _drop_scale(h, diameter_m, data.source, label)
    if warn:
        findings.append(Finding("warning", warn))
    rise = np.flatnonzero(np.diff(h) > 0)
    if rise.size == 0:
        return data, findings
    k = int(rise[0])
    lines = getattr(data, "lines", None)
    at = f" (line {int(lines[k + 1])})" if lines is not None else ""
    if k == 0:
        _fail(data.source, f"{label + ': ' if label else ''}the rebound{at}, {h[1]:.4g} m, is higher than the drop, "
                           f"{h[0]:.4g} m: a ball cannot bounce above the height it fell from (epsilon > 1); "
                           f"are the columns or rows swapped?")
    findings.append(Finding("note", f"{label + ': ' if label else ''}apex {int(data.bounce[k + 1])}{at} is higher "
                                    f"than apex {int(data.bounce[k])}: impossible for a ball bouncing on a floor; "
                                    f"the apexes from there on are left out"))
    return replace(data, bounce=data.bounce[:k + 1], h_m=h[:k + 1],
                   lines=None if lines is None else lines[:k + 1]), findings


# --------------------------------------------------------------------------- the whole record


#: Largest rebound / drop of a drop table whose columns are swapped: 1 / epsilon^2 of the deadest ball a class
#: drops (epsilon 0.3); a rebound many times more than that is in another unit than its drop.
SWAPPED_RATIO_MAX = 1 / 0.3 ** 2


def _higher_rebound_cause(ratios):
    """What makes most rebounds higher than their drops, from their ``ratios`` (rebound / drop): swapped columns,
    or -- when the rebound is many times the drop (:data:`SWAPPED_RATIO_MAX`) -- a rebound in cm or mm beside a
    drop in m (``H (m),h`` over ``1.00,55``)."""
    ratio = float(np.median(ratios))
    if ratio <= SWAPPED_RATIO_MAX:
        return "are the drop and rebound columns swapped?"
    unit = "cm" if ratio < 300 else "mm"
    return (f"{ratio:.0f} times the drop (the median), which no swap explains: is the rebound in {unit} and the "
            f"drop in m? write each height column's unit in its header ('h ({unit})', 'H (m)')")


def check(data, diameter_m=None, g_m_per_s2=STANDARD_GRAVITY_M_PER_S2, *, y_down=False, sigma_m=0.0,
          g_expected_m_per_s2=None, drag_per_m=()):
    """Every check that applies to ``data`` (one run, or :class:`vrcal.measurements.Runs`).

    Parameters
    ----------
    data : Trajectory or ImpactTimes or ApexHeights or Runs
    diameter_m : float or None
        the ball's diameter [m] (the ruler of records without time)
    g_m_per_s2 : float
        the gravity the fit will assume [m/s^2]
    y_down : bool
        the reader turned the y axis over (for the upside-down hint)
    sigma_m : float
        noise of one height [m], 0 when unknown
    g_expected_m_per_s2, drag_per_m : float or None, sequence of float
        the ball's flights: see :func:`check_trajectory`

    Returns
    -------
    Checked
        the record (runs or apexes that cannot be physical left out, with a note; trials of a drop table
        so, with a warning) and the findings

    Raises
    ------
    DataError
        a record that cannot be fitted as it is (one line: what looks wrong and the fix)
    """
    from vrcal.measurements.types import Runs

    flights = {"g_expected_m_per_s2": g_expected_m_per_s2, "drag_per_m": drag_per_m}
    if isinstance(data, Runs):
        runs, labels, findings = [], [], []
        dropped, equal, ratios = [], False, []
        _check_above_floor(data.runs, data.source, diameter_m)
        for run, label in zip(data.runs, data.labels or [f"run {i + 1}" for i in range(len(data.runs))]):
            if run.kind == "apexes" and len(run.h_m) >= 2 and run.h_m[1] >= run.h_m[0]:
                equal = equal or run.h_m[1] == run.h_m[0]   # epsilon 1: the drop written twice?
                lines = getattr(run, "lines", None)
                at = f" (line {int(lines[1])})" if lines is not None and "(line " not in label else ""
                dropped.append(f"{label}{at} {run.h_m[1]:.4g} m from {run.h_m[0]:.4g} m")
                ratios.append(run.h_m[1] / run.h_m[0])
                continue
            checked = _check_one(run, diameter_m, g_m_per_s2, y_down, sigma_m, label, flights)
            runs.append(checked.data)
            labels.append(label)
            findings += checked.findings
        if dropped:
            higher = "as high as the drop or higher" if equal else "higher than the drop"
            if len(dropped) * 2 > len(data.runs):
                _fail(data.source, f"the rebound is {higher} in {len(dropped)} of {len(data.runs)} "
                                   f"trials: {_higher_rebound_cause(ratios)}")
            higher = "as high as its drop or higher (epsilon >= 1)" if equal else "higher than its drop"
            findings.append(Finding("warning", f"{len(dropped)} of {len(data.runs)} trials left out: a rebound "
                                               f"{higher} is impossible for a ball (a misread or "
                                               f"swapped entry? read at the ball's top: --rebound-measured-to "
                                               f"top): {'; '.join(dropped)}"))
        return Checked(replace(data, runs=tuple(runs), labels=tuple(labels)), tuple(findings))
    return _check_one(data, diameter_m, g_m_per_s2, y_down, sigma_m, "", flights)


def _check_one(data, diameter_m, g, y_down, sigma_m, label, flights):
    if data.kind == "trajectory":
        findings = check_trajectory(data, g, y_down=y_down, sigma_m=sigma_m, **flights)
        return Checked(data, tuple(f._replace(text=f"{label}: {f.text}") if label else f for f in findings))
    if data.kind == "impacts":
        chains = getattr(data, "chains", ()) or ((0, len(data.t_s)),)
        for a, b in chains:
            check_impact_times(np.asarray(data.t_s)[a:b], data.source)
        said = tuple(Finding("warning", f"{label}: {text}" if label else text)
                     for text in getattr(data, "suspect", ()))
        return Checked(data, said)
    checked, findings = check_apexes(data, diameter_m, label)
    return Checked(checked, tuple(findings))
