"""Readers of real measurements: trajectories, acoustic impact times, apex heights.

One entry point, :func:`read_measurement`, auto-detects the layout of a file (or takes
it from ``fmt``, one of the keys of :data:`FORMATS`) and returns one of three frozen
dataclasses: :class:`Trajectory`, :class:`ImpactTimes` or :class:`ApexHeights`.

Formats (``FORMATS``; ``vrcal ... --format NAME``)
--------------------------------------------------
``trajectory``
    a header row naming a time column (``t``, ``time``) and a height column ``y``
    (``x`` optional), then one row per sample. Units may follow a name in brackets:
    ``t (s)``, ``t [ms]``, ``y (cm)``, ``y (px)``. Without a time column the sample
    times come from ``fs_hz``. ``vrcal simulate`` writes ``t,y`` (s, m).
``tracker``
    a data export of Tracker (physlets.org/tracker, *File > Export > Data*): line 1
    is the track name with spaces turned into ``_`` (``mass_A``), line 2 the column
    names (``t``, ``x``, ``y``, ...), then numbers such as ``1.245986911E-1``, all
    joined by the chosen delimiter (tab, space, comma or semicolon; a decimal comma
    when Tracker runs in such a locale). A ``#multi:`` export (several tracks) uses
    the first track's columns. Rows of frames that were not marked (empty ``y``)
    are skipped.
``pixels-ref``
    a reference-length pixel file: line 1 ``LENGTH_M;LENGTH_PX`` (a reference length
    in metres and the pixels it spans), then ``y_img;x_img;`` per video frame, image
    y axis pointing down. Needs ``fs_hz`` (the frame rate is not in the file).
``impacts``
    impact times, e.g. a phyphox *Acoustic Stopwatch* / *(In)elastic collision* CSV
    export: a (possibly quoted) header such as ``"Event time (s)"``, separators comma,
    semicolon or tab, decimal point or comma, scientific notation. With several
    columns the time column is picked by its name. ``vrcal simulate`` writes ``t``.
``apexes``
    apex heights ``bounce,h``: bounce 0 is the drop height [m].

Conversions and clean-up
------------------------
* Heights: ``y_m = y * scale`` (``scale_m_per_px``, or the unit in the header), and
  ``y_m = -y * scale`` when ``y_down`` (image rows grow downwards; forced for
  ``pixels-ref``). No offset is added: the heights are relative to whatever origin
  the file uses (for an image, its top edge); the fitter's free offset absorbs it.
* The still segment before release is detected (:func:`detect_release_index`) and
  kept; duplicated video frames are dropped (:func:`find_duplicated_frames`).
* Impact times are screened for missed impacts and echoes
  (:func:`detect_impact_anomalies`); only the clean prefix is kept for fitting.

Errors are :class:`vrcal.errors.DataError` with a one-line message
``FILE:LINE: what is wrong``; an unknown format or a missing option is a
:class:`vrcal.errors.UsageError`. Nothing is ever written by this module.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path
from typing import Callable, NamedTuple

import numpy as np

from vrcal.errors import DataError, UsageError

#: Fewest samples a trajectory must have (whether bounces are present is the fitter's business).
MIN_TRAJECTORY_SAMPLES = 20
#: Fewest impacts (after removing anomalies) and fewest apex rows.
MIN_IMPACTS = 3
MIN_APEXES = 3


# --------------------------------------------------------------------------- results


@dataclass(frozen=True)
class Trajectory:
    """Heights of a tracked point of the ball against time.

    Attributes
    ----------
    t_s : ndarray
        sample times [s], strictly increasing (duplicated frames removed)
    y_m : ndarray
        height of the tracked point [m], up-positive, origin as in the file
    source : str
        the file it was read from
    notes : tuple of str
        human-readable remarks (format, conversions, dropped frames, release)
    release_index : int
        index (into ``t_s``) of the first sample after the still segment; 0 when none
        was detected. The still samples are kept: the fitter models the hold.
    """

    t_s: np.ndarray
    y_m: np.ndarray
    source: str
    notes: tuple = ()
    release_index: int = 0
    kind: str = "trajectory"


@dataclass(frozen=True)
class ImpactTimes:
    """Times of the floor impacts of one drop (e.g. from the sound of the bounces).

    Attributes
    ----------
    t_s : ndarray
        impact times kept for fitting [s], strictly increasing: the clean prefix before
        the first detected anomaly
    source : str
        the file it was read from
    notes : tuple of str
        human-readable remarks
    rejected : tuple
        ``((index, time_s, reason), ...)`` for every impact not kept; ``index`` counts
        the file's impacts from 0
    """

    t_s: np.ndarray
    source: str
    notes: tuple = ()
    rejected: tuple = ()
    kind: str = "impacts"


@dataclass(frozen=True)
class ApexHeights:
    """Apex heights of successive bounces; bounce 0 is the drop height.

    Attributes
    ----------
    bounce : ndarray of int
        bounce number, strictly increasing (0 = release)
    h_m : ndarray
        apex height [m]
    source : str
        the file it was read from
    notes : tuple of str
        human-readable remarks
    """

    bounce: np.ndarray
    h_m: np.ndarray
    source: str
    notes: tuple = ()
    kind: str = "apexes"


# --------------------------------------------------------------------------- equations of the clean-up


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


# --------------------------------------------------------------------------- reading text tables

_NUMBER_WITH_DECIMAL_COMMA = re.compile(r"^[+-]?\d*,\d+([eE][+-]?\d+)?$")
_NAME_UNIT = re.compile(r"^(?P<name>.*?)\s*(?:[\(\[](?P<unit>[^\)\]]*)[\)\]])?$")

TIME_NAMES = ("t", "time", "event time", "impact time", "time of impact", "collision time")
Y_NAMES = ("y",)
X_NAMES = ("x",)
BOUNCE_NAMES = ("bounce", "n", "bounce number")
H_NAMES = ("h", "height", "apex", "apex height")
TIME_UNITS = {"": 1.0, "s": 1.0, "sec": 1.0, "ms": 1e-3}
LENGTH_UNITS = {"": 1.0, "m": 1.0, "cm": 1e-2, "mm": 1e-3, "px": None, "pixel": None, "pixels": None}


class _Column(NamedTuple):
    index: int
    name: str
    unit: str


@dataclass
class _Text:
    """A file's non-blank lines with their 1-based line numbers."""

    path: str
    lines: list  # [(lineno, text)]
    multi: bool = False  # a Tracker '#multi:' export


def _fail(path, line, what):
    where = f"{path}:{line}" if line else f"{path}"
    raise DataError(f"{where}: {what}")


def _load(path):
    path_s = str(path)
    try:
        raw = Path(path).read_bytes()
    except IsADirectoryError:
        raise DataError(f"{path_s}: is a directory, not a measurement file") from None
    except OSError as exc:
        raise DataError(f"{path_s}: cannot read: {exc.strerror or exc}") from None
    if not raw.strip():
        _fail(path_s, 0, "empty file")
    if b"\x00" in raw[:8192]:
        _fail(path_s, 0, "binary file, not a text table (save it as CSV or text, UTF-8)")
    try:
        text = raw.decode("utf-8-sig")
    except UnicodeDecodeError:
        text = raw.decode("latin-1")
    printable = sum(ch.isprintable() or ch in "\r\n\t" for ch in text[:4096])
    if printable < 0.95 * len(text[:4096]):
        _fail(path_s, 0, "binary file, not a text table (save it as CSV or text, UTF-8)")
    lines, multi = [], False
    for i, line in enumerate(text.splitlines(), start=1):
        stripped = line.strip()
        if not stripped:
            continue
        if stripped.startswith("#"):
            multi = multi or stripped.lower().startswith("#multi")
            continue
        lines.append((i, line.rstrip("\r\n")))
    if not lines:
        _fail(path_s, 0, "no data (only comments or blank lines)")
    return _Text(path_s, lines, multi)


def _strip_cell(cell):
    cell = cell.strip()
    if len(cell) >= 2 and cell[0] == cell[-1] and cell[0] in "\"'":
        cell = cell[1:-1].strip()
    return cell


def _sniff(header, sample):
    """Separator (',', ';', '\\t', ' ' for whitespace runs, or None for one column) and decimal comma."""
    everything = [header] + sample
    if any("\t" in s for s in everything):
        sep = "\t"
    elif any(";" in s for s in everything):
        sep = ";"
    elif "," in _unquoted(header):
        sep = ","
    elif len(_unquoted(header).split()) > 1 and sample and all(
            len(s.split()) == len(_unquoted(header).split()) for s in sample):
        sep = " "
    else:
        sep = None
    decimal_comma = sep != "," and any(
        _NUMBER_WITH_DECIMAL_COMMA.match(_strip_cell(c)) for s in sample for c in _split(s, sep))
    return sep, decimal_comma


def _unquoted(text):
    return re.sub(r'"[^"]*"', "", text)


def _split(line, sep):
    if sep is None:
        cells = [line]
    elif sep == " ":
        cells = line.split()
    elif sep == "\t":
        cells = line.strip("\r\n ").split("\t")
    else:
        cells = line.split(sep)
    cells = [_strip_cell(c) for c in cells]
    while cells and cells[-1] == "":
        cells.pop()  # a trailing delimiter
    return cells


def _to_float(cell, decimal_comma):
    """A cell as a float, or None when it is not a number."""
    text = cell.replace(",", ".") if decimal_comma else cell
    if "_" in text:
        return None
    try:
        return float(text)
    except ValueError:
        return None


def _is_numeric_row(cells, decimal_comma=True):
    return bool(cells) and all(_to_float(c, decimal_comma) is not None for c in cells)


def _columns(cells):
    cols = []
    for i, cell in enumerate(cells):
        m = _NAME_UNIT.match(cell.strip())
        name = re.sub(r"[\s_]+", " ", (m.group("name") or "").strip().lower())
        unit = (m.group("unit") or "").strip().lower()
        cols.append(_Column(i, name, unit))
    return cols


def _find(cols, names, *, contains=None):
    for c in cols:
        if c.name in names:
            return c
    if contains:
        for c in cols:
            if contains in c.name:
                return c
    return None


class _Table(NamedTuple):
    header_line: int
    cols: list
    rows: list  # [(lineno, cells)]
    sep: object
    decimal_comma: bool
    preamble: list  # [(lineno, text)] before the header


def _table(text, header_at=0):
    """Split a text into header, columns and rows (cells as strings)."""
    lines = text.lines
    if header_at >= len(lines):
        _fail(text.path, lines[-1][0], "no header row")
    header_no, header = lines[header_at]
    body = lines[header_at + 1:]
    sep, decimal_comma = _sniff(header, [s for _, s in body[:20]])
    head_cells = _split(header, sep)
    if _is_numeric_row(head_cells, decimal_comma):
        _fail(text.path, header_no, "no header row: the first line holds numbers; name the columns "
              "(e.g. 't,y', 't', 'bounce,h')")
    rows = [(no, _split(s, sep)) for no, s in body]
    for no, cells in rows:
        if len(cells) > len(head_cells):
            hint = " (a decimal comma with comma separators?)" if sep == "," else ""
            _fail(text.path, no, f"{len(cells)} cells but the header names {len(head_cells)} columns{hint}")
    return _Table(header_no, _columns(head_cells), rows, sep, decimal_comma, lines[:header_at])


def _column_values(path, table, col, *, what, allow_empty=False):
    """Float values of one column with line-accurate errors; NaN where empty and allowed."""
    out = np.empty(len(table.rows))
    label = col.name or f"column {col.index + 1}"
    for k, (no, cells) in enumerate(table.rows):
        if col.index >= len(cells) or cells[col.index] == "":
            if allow_empty:
                out[k] = np.nan
                continue
            _fail(path, no, f"empty cell in column '{label}' ({what})")
        value = _to_float(cells[col.index], table.decimal_comma)
        if value is None:
            _fail(path, no, f"'{cells[col.index]}' is not a number (column '{label}')")
        if not np.isfinite(value):
            _fail(path, no, f"{cells[col.index]} in column '{label}': every value must be a finite number")
        out[k] = value
    return out


def _unit_factor(path, table, col, units, kind):
    if col.unit not in units:
        _fail(path, table.header_line, f"unknown {kind} unit '{col.unit}' of column '{col.name}' "
              f"(known: {', '.join(u for u in units if u)})")
    return units[col.unit]


def _check_increasing(path, values, line_numbers, label):
    d = np.diff(values)
    bad = np.flatnonzero(~(d > 0))
    if bad.size:
        j = int(bad[0]) + 1
        _fail(path, int(line_numbers[j]), f"{label} not increasing ({values[j]:g} after {values[j - 1]:g})")


# --------------------------------------------------------------------------- detectors


def _header_cols(text, header_at=0):
    if header_at >= len(text.lines):
        return None
    header = text.lines[header_at][1]
    sample = [s for _, s in text.lines[header_at + 1:header_at + 21]]
    sep, dc = _sniff(header, sample)
    cells = _split(header, sep)
    if _is_numeric_row(cells, dc):
        return None
    return _columns(cells)


def _detect_apexes(text):
    cols = _header_cols(text)
    return bool(cols) and _find(cols, BOUNCE_NAMES) is not None and _find(cols, H_NAMES) is not None


def _detect_trajectory(text):
    cols = _header_cols(text)
    return bool(cols) and _find(cols, Y_NAMES) is not None


def _detect_impacts(text):
    cols = _header_cols(text)
    return (bool(cols) and _find(cols, Y_NAMES) is None and _find(cols, BOUNCE_NAMES) is None
            and _find(cols, TIME_NAMES, contains="time") is not None)


def _detect_tracker(text):
    if len(text.lines) < 3:
        return False
    first = _unquoted(text.lines[0][1]).strip()
    if not first or _is_numeric_row([c for c in re.split(r"[,;\t]", first) if c.strip()]):
        return False
    at = 1
    cols = _header_cols(text, at)
    if cols and text.multi and _find(cols, Y_NAMES) is None:  # '#multi:' then a row of track names
        at, cols = 2, _header_cols(text, 2)
    return bool(cols) and _find(cols, TIME_NAMES) is not None and _find(cols, Y_NAMES) is not None


def _detect_pixels_ref(text):
    if len(text.lines) < 3:
        return False
    first = [c for c in re.split(r"[;,\t ]+", text.lines[0][1].strip()) if c]
    second = [c for c in re.split(r"[;,\t ]+", text.lines[1][1].strip()) if c]
    if len(first) != 2 or not _is_numeric_row(first, False) or not _is_numeric_row(second, False):
        return False
    length_m, length_px = (float(c) for c in first)
    # a reference length of a few cm to metres spanning many pixels (at most 10 cm per px)
    return 0 < length_m <= 0.1 * length_px and length_px >= 10 and len(second) in (1, 2)


# --------------------------------------------------------------------------- parsers


def _finish_trajectory(path, t_s, y_m, line_numbers, notes, positions=None):
    """Drop duplicates, check time, detect release, build the Trajectory."""
    notes = list(notes)
    # exact repeats of a whole record (same time and same position)
    same_row = np.zeros(t_s.size, dtype=bool)
    pos = y_m[:, None] if positions is None else positions
    same_row[1:] = (t_s[1:] == t_s[:-1]) & np.all(pos[1:] == pos[:-1], axis=1)
    if np.any(same_row):
        lines = ", ".join(str(int(x)) for x in line_numbers[same_row][:10])
        notes.append(f"dropped {int(same_row.sum())} repeated row(s) (same time and position; line(s) {lines})")
        keep = ~same_row
        t_s, y_m, line_numbers, pos = t_s[keep], y_m[keep], line_numbers[keep], pos[keep]
    _check_increasing(path, t_s, line_numbers, "time")
    release = detect_release_index(y_m)
    dup = find_duplicated_frames(pos, release)
    if dup.size:
        lines = ", ".join(str(int(x)) for x in line_numbers[dup][:10])
        more = "" if dup.size <= 10 else ", ..."
        notes.append(f"dropped {dup.size} duplicated frame(s) (position repeats the previous frame in flight; "
                     f"line(s) {lines}{more})")
        keep = np.ones(t_s.size, dtype=bool)
        keep[dup] = False
        t_s, y_m, line_numbers = t_s[keep], y_m[keep], line_numbers[keep]
        release -= int(np.sum(dup < release))
    if t_s.size < MIN_TRAJECTORY_SAMPLES:
        _fail(path, int(line_numbers[-1]) if line_numbers.size else 0,
              f"only {t_s.size} samples; a trajectory needs at least {MIN_TRAJECTORY_SAMPLES}")
    if release > 0:
        notes.append(f"still segment: samples 0-{release - 1} (release detected at sample {release}, "
                     f"t = {t_s[release]:.4g} s, line {int(line_numbers[release])}); kept for the fit")
    else:
        notes.append("no still segment before release detected")
    return Trajectory(t_s=t_s, y_m=y_m, source=path, notes=tuple(notes), release_index=int(release))


def _trajectory_from_table(path, table, *, scale_m_per_px, y_down, fs_hz, notes, skip_empty_y=False,
                           force_scale=None):
    cols = table.cols
    t_col = _find(cols, TIME_NAMES)
    y_col = _find(cols, Y_NAMES)
    x_col = _find(cols, X_NAMES)
    if y_col is None:
        _fail(path, table.header_line, f"no height column 'y' (columns: {', '.join(c.name for c in cols)})")
    if not table.rows:
        _fail(path, table.header_line, "header but no data rows")
    notes = list(notes)
    y = _column_values(path, table, y_col, what="height", allow_empty=skip_empty_y)
    line_numbers = np.array([no for no, _ in table.rows])
    if skip_empty_y:
        empty = np.isnan(y)
        if np.any(empty):
            notes.append(f"skipped {int(empty.sum())} row(s) without a position (frames not marked)")
    else:
        empty = np.zeros(y.size, dtype=bool)
    # time
    if t_col is not None:
        t = _column_values(path, table, t_col, what="time", allow_empty=skip_empty_y)
        t = t * _unit_factor(path, table, t_col, TIME_UNITS, "time")
        if fs_hz is not None:
            notes.append(f"--fs {fs_hz:g} Hz ignored: the file has a time column")
    else:
        if fs_hz is None:
            raise UsageError(f"{path}: no time column: give the frame rate with --fs HZ")
        if not (np.isfinite(fs_hz) and fs_hz > 0):
            raise UsageError(f"--fs must be a positive frame rate in Hz, got {fs_hz:g}")
        t = np.arange(y.size) / float(fs_hz)
        notes.append(f"times from the frame rate {fs_hz:g} Hz (no time column)")
    x = _column_values(path, table, x_col, what="x", allow_empty=True) if x_col is not None else None
    if skip_empty_y and t_col is not None:
        empty |= np.isnan(t)
    keep = ~empty
    t, y, line_numbers = t[keep], y[keep], line_numbers[keep]
    x = x[keep] if x is not None else None
    # length scale
    if force_scale is not None and scale_m_per_px is None:
        factor = force_scale
    elif scale_m_per_px is not None:
        if not (np.isfinite(scale_m_per_px) and scale_m_per_px > 0):
            raise UsageError(f"--scale must be a positive number of metres per pixel, got {scale_m_per_px:g}")
        factor = float(scale_m_per_px)
        extra = f" (header unit '{y_col.unit}' ignored)" if y_col.unit and y_col.unit not in ("px", "pixel", "pixels") else ""
        notes.append(f"positions scaled by --scale {factor:g} m per file unit{extra}")
    else:
        factor = _unit_factor(path, table, y_col, LENGTH_UNITS, "length")
        if factor is None:
            raise UsageError(f"{path}: column 'y' is in pixels: give --scale M_PER_PX")
        if y_col.unit and y_col.unit != "m":
            notes.append(f"heights converted from {y_col.unit} to m")
    y_m = y * factor
    if y_down:
        y_m = -y_m
        notes.append("y axis points down in the file: height = -y * scale (no offset added; "
                     "heights are relative to the file's origin)")
    positions = np.column_stack([y_m, x * factor]) if x is not None and not np.any(np.isnan(x)) else y_m[:, None]
    return _finish_trajectory(path, t, y_m, line_numbers, notes, positions)


def _parse_trajectory(text, *, scale_m_per_px=None, y_down=False, fs_hz=None):
    table = _table(text)
    return _trajectory_from_table(text.path, table, scale_m_per_px=scale_m_per_px, y_down=y_down, fs_hz=fs_hz,
                                  notes=("format: trajectory (t, y columns)",))


def _parse_tracker(text, *, scale_m_per_px=None, y_down=False, fs_hz=None):
    track = _strip_cell(text.lines[0][1].strip().strip(";,\t"))
    at = 1
    cols = _header_cols(text, 1)
    if text.multi and (cols is None or _find(cols, Y_NAMES) is None):
        at = 2
    table = _table(text, header_at=at)
    notes = [f"format: Tracker data export (track '{track}')"]
    if text.multi:
        notes = [f"format: Tracker multi-track export; using the first track's columns ({track})"]
    ys = [c for c in table.cols if c.name in Y_NAMES]
    if len(ys) > 1:
        notes.append(f"{len(ys)} 'y' columns: using the first")
    if scale_m_per_px is None and not y_down:
        notes.append("positions taken as metres (Tracker's calibrated units; use --scale for other units)")
    return _trajectory_from_table(text.path, table, scale_m_per_px=scale_m_per_px, y_down=y_down, fs_hz=fs_hz,
                                  notes=notes, skip_empty_y=True)


def _parse_pixels_ref(text, *, scale_m_per_px=None, y_down=True, fs_hz=None):
    path = text.path
    first_no, first = text.lines[0]
    length_m, length_px = (float(c) for c in re.split(r"[;,\t ]+", first.strip()) if c)
    ref_scale = length_m / length_px
    notes = [f"format: pixels-ref (line {first_no}: {length_m:g} m spans {length_px:g} px, "
             f"{ref_scale * 1e3:.4g} mm per px)"]
    if scale_m_per_px is not None:
        notes.append(f"--scale {scale_m_per_px:g} m/px overrides the reference line")
    rows = []
    for no, line in text.lines[1:]:
        cells = [c for c in re.split(r"[;,\t ]+", line.strip()) if c]
        if len(cells) not in (1, 2):
            _fail(path, no, f"expected 'y_img;x_img;', found {len(cells)} cells")
        rows.append((no, cells))
    cols = [_Column(0, "y", "px"), _Column(1, "x", "px")] if all(len(c) == 2 for _, c in rows) else [
        _Column(0, "y", "px")]
    table = _Table(first_no, cols, rows, ";", False, [])
    return _trajectory_from_table(path, table, scale_m_per_px=scale_m_per_px, y_down=True, fs_hz=fs_hz,
                                  notes=notes, force_scale=ref_scale)


def _parse_impacts(text, *, scale_m_per_px=None, y_down=False, fs_hz=None):
    path = text.path
    table = _table(text)
    col = _find(table.cols, TIME_NAMES, contains="time")
    if col is None:
        if len(table.cols) == 1:
            col = table.cols[0]
        else:
            _fail(path, table.header_line, f"no time column (columns: {', '.join(c.name for c in table.cols)}); "
                  "name it 't' or 'time'")
    if not table.rows:
        _fail(path, table.header_line, "header but no data rows")
    notes = ["format: impacts (one impact time per row)"]
    if len(table.cols) > 1:
        notes.append(f"impact times from column '{col.name}'" + (f" ({col.unit})" if col.unit else ""))
    if table.decimal_comma:
        notes.append("decimal comma")
    t = _column_values(path, table, col, what="impact time")
    t = t * _unit_factor(path, table, col, TIME_UNITS, "time")
    line_numbers = np.array([no for no, _ in table.rows])
    _check_increasing(path, t, line_numbers, "impact time")
    if t.size < MIN_IMPACTS:
        _fail(path, int(line_numbers[-1]), f"only {t.size} impact(s); at least {MIN_IMPACTS} are needed")
    n_clean, rejected = detect_impact_anomalies(t)
    if rejected:
        idx, t0, reason = rejected[0]
        notes.append(f"impact {idx} at t = {t0:.4f} s (line {int(line_numbers[idx])}): {reason}; "
                     f"fitting the {n_clean} impacts before it, {len(rejected)} rejected")
    if n_clean < MIN_IMPACTS:
        idx, t0, reason = rejected[0]
        _fail(path, int(line_numbers[idx]), f"only {n_clean} impact(s) before an anomaly ({reason}); "
              f"at least {MIN_IMPACTS} are needed")
    return ImpactTimes(t_s=t[:n_clean], source=path, notes=tuple(notes), rejected=rejected)


def _parse_apexes(text, *, scale_m_per_px=None, y_down=False, fs_hz=None):
    path = text.path
    table = _table(text)
    b_col, h_col = _find(table.cols, BOUNCE_NAMES), _find(table.cols, H_NAMES)
    if b_col is None or h_col is None:
        _fail(path, table.header_line, "an apex file needs the columns 'bounce,h'")
    if not table.rows:
        _fail(path, table.header_line, "header but no data rows")
    line_numbers = np.array([no for no, _ in table.rows])
    bounce = _column_values(path, table, b_col, what="bounce number")
    nonint = np.flatnonzero(bounce != np.round(bounce))
    if nonint.size:
        _fail(path, int(line_numbers[nonint[0]]), f"bounce number {bounce[nonint[0]]:g} is not an integer")
    _check_increasing(path, bounce, line_numbers, "bounce number")
    if np.any(bounce < 0):
        _fail(path, int(line_numbers[0]), f"bounce number {bounce[0]:g} is negative (bounce 0 = drop height)")
    h = _column_values(path, table, h_col, what="apex height")
    factor = _unit_factor(path, table, h_col, LENGTH_UNITS, "length")
    notes = ["format: apexes (bounce, h; bounce 0 = drop height)"]
    if factor is None:
        if scale_m_per_px is None:
            raise UsageError(f"{path}: column 'h' is in pixels: give --scale M_PER_PX")
        factor = scale_m_per_px
    elif scale_m_per_px is not None:
        factor = scale_m_per_px
        notes.append(f"heights scaled by --scale {factor:g} m per file unit")
    h_m = h * factor
    nonpos = np.flatnonzero(h_m <= 0)
    if nonpos.size:
        _fail(path, int(line_numbers[nonpos[0]]), f"apex height {h[nonpos[0]]:g} is not positive")
    if h_m.size < MIN_APEXES:
        _fail(path, int(line_numbers[-1]), f"only {h_m.size} apex row(s); at least {MIN_APEXES} are needed")
    if bounce[0] != 0:
        notes.append(f"first row is bounce {int(bounce[0])}, not 0 (the drop height)")
    gaps = np.flatnonzero(np.diff(bounce) > 1)
    if gaps.size:
        notes.append(f"bounce numbers skip after bounce {int(bounce[gaps[0]])}")
    rising = np.flatnonzero(np.diff(h_m) >= 0)
    if rising.size:
        notes.append(f"apex height does not fall after bounce {int(bounce[rising[0]])}")
    return ApexHeights(bounce=bounce.astype(int), h_m=h_m, source=path, notes=tuple(notes))


# --------------------------------------------------------------------------- registry and entry point


class Format(NamedTuple):
    """One file layout: ``detector(text) -> bool``, ``parser(text, **options) -> result``."""

    detector: Callable
    parser: Callable
    description: str


#: Known layouts, in auto-detection order (the first detector that accepts a file wins).
FORMATS = {
    "pixels-ref": Format(_detect_pixels_ref, _parse_pixels_ref,
                         "reference-length pixel file: line 1 'LENGTH_M;LENGTH_PX', then 'y_img;x_img;' per frame "
                         "(image y down; needs --fs)"),
    "tracker": Format(_detect_tracker, _parse_tracker,
                      "Tracker data export: line 1 the track name (mass_A), then columns t, x, y "
                      "(tab, space, comma or semicolon)"),
    "apexes": Format(_detect_apexes, _parse_apexes, "apex heights: header 'bounce,h' (bounce 0 = drop height, m)"),
    "trajectory": Format(_detect_trajectory, _parse_trajectory,
                         "trajectory: header 't,y' (s, m; x optional; units like 'y (cm)', 'y (px)' + --scale)"),
    "impacts": Format(_detect_impacts, _parse_impacts,
                      "impact times: a time column ('t', 'time', \"Event time (s)\"), e.g. a phyphox export"),
}


def format_help():
    """One line per format, for ``--format`` help texts."""
    return "; ".join(f"{name}: {fmt.description}" for name, fmt in FORMATS.items())


def detect_format(path):
    """Name of the first format in :data:`FORMATS` whose detector accepts the file."""
    text = _load(path)
    return _detect(text)


def _detect(text):
    for name, fmt in FORMATS.items():
        if fmt.detector(text):
            return name
    no, line = text.lines[0]
    cells = [c for c in re.split(r"[,;\t]", line) if c.strip()]
    if _is_numeric_row(cells):
        _fail(text.path, no, "no header row: the first line holds numbers; name the columns "
              "(e.g. 't,y', 't', 'bounce,h')")
    _fail(text.path, no, f"cannot tell the layout from the header {line.strip()!r} "
          f"(known formats: {', '.join(FORMATS)}; see --format)")


def read_measurement(path, fmt=None, *, scale_m_per_px=None, y_down=False, fs_hz=None):
    """Read a measurement file into a Trajectory, ImpactTimes or ApexHeights.

    Parameters
    ----------
    path : str or Path
        the file to read
    fmt : str or None
        a key of :data:`FORMATS`; None detects it from the file
    scale_m_per_px : float or None
        metres per unit of the file's position column (pixels); overrides the header
        unit and the reference line of a ``pixels-ref`` file [m/px]
    y_down : bool
        the file's y axis points down (image rows): height = -y * scale
    fs_hz : float or None
        sampling (frame) rate for files without a time column [Hz]

    Returns
    -------
    Trajectory or ImpactTimes or ApexHeights
        ``.kind`` is "trajectory", "impacts" or "apexes".

    Raises
    ------
    DataError
        "FILE:LINE: what is wrong" for an unreadable, empty, binary or malformed file.
    UsageError
        an unknown ``fmt`` (the message names the known ones), a missing ``fs_hz`` or
        ``scale_m_per_px`` that the file needs.
    """
    if fmt is not None and fmt not in FORMATS:
        raise UsageError(f"unknown measurement format '{fmt}' (known: {', '.join(FORMATS)})")
    text = _load(path)
    name = fmt or _detect(text)
    return FORMATS[name].parser(text, scale_m_per_px=scale_m_per_px, y_down=y_down, fs_hz=fs_hz)
