"""Impact times, e.g. a phyphox *Acoustic Stopwatch* / *(In)elastic collision* export: a (possibly
quoted) header such as ``"Event time (s)"``, separators comma, semicolon or tab, decimal point or
comma, scientific notation. One column is read as impact times whatever its name (``t``,
``t_impact``, ``time``), or with no header at all; with several columns the time column is picked
by its name. Units ``s`` or ``ms`` in the header. ``vrcal simulate --format impacts`` writes ``t``.

The events are split into chains of consecutive bounces
(:func:`vrcal.measurements.cleanup.impact_chains`): echoes and a first event that is no impact
(a clap before the release, :func:`vrcal.measurements.cleanup.leading_intruder`) are removed, a
missed impact or a bounce that does not belong ends a chain and the next starts after it; every event left out is
named by its number in the file and its line (:func:`impact_times_from_events`, which a reader
of raw sound can call too).
"""

from __future__ import annotations

import dataclasses
import re

import numpy as np

from vrcal.errors import DataError
from vrcal.measurements.cleanup import TIMING_SIGMA_S, impact_chains, printed_resolution, time_grid
from vrcal.measurements.plausibility import TRAJECTORY_HINT, check_impact_times
from vrcal.measurements.table import (
    BOUNCE_NAMES,
    H_NAMES,
    LENGTH_UNITS,
    TIME_NAMES,
    TIME_NAMING,
    TIME_UNITS,
    X_NAMES,
    Y_NAMES,
    check_increasing,
    column_cells,
    column_values,
    fail,
    find_column,
    header_columns,
    meta_number,
    numeric_width,
    parse_table,
    repeated_columns,
    row_lines,
    said_lines,
    unit_factor,
)
from vrcal.measurements.types import ImpactTimes, Runs
from vrcal.textout import counted

_DECIMAL_COMMA = re.compile(r"^[+-]?\d+,\d+$")

#: Fewest impacts in a chain (and in a file).
MIN_IMPACTS = 3

#: Most events of an impact file. A drop gives tens of impacts and a joint fit takes at most
#: :data:`vrcal.discovery.prepare.MAX_RUNS` drops; more events are a sensor's samples or several
#: sessions in one file (refused at once, before any work).
MAX_IMPACT_EVENTS = 20_000


#: Column names of positions: a lone column named so is no list of impact times.
POSITION_NAMES = (*X_NAMES, "z", "position", "pos", "distance", "length", "depth", "width")


def _other_layout(cols):
    """True when the columns name heights or bounces: another layout's file."""
    return any(find_column(cols, names) is not None for names in (Y_NAMES, BOUNCE_NAMES, H_NAMES))


def _position_column(col):
    """True when a column's name or unit says it holds positions (x, z, a length unit), not times."""
    return col.name in POSITION_NAMES or (bool(col.unit) and col.unit in LENGTH_UNITS)


def detect(text):
    cols = header_columns(text)
    if cols is None:
        return numeric_width(text) == 1 or _one_decimal_comma_column(text)
    if _other_layout(cols):
        return False
    if len(cols) == 1 and _position_column(cols[0]):
        return False
    return len(cols) == 1 or find_column(cols, TIME_NAMES, contains="time") is not None


def _one_decimal_comma_column(text):
    """A headerless file of numbers such as ``0,2804`` (one column, decimal comma): read as two
    columns, the first would not increase; read as decimals, the values do."""
    if numeric_width(text) != 2:
        return False
    rows = [line.strip() for _, line in text.lines[:50]]
    if not all(_DECIMAL_COMMA.match(row) for row in rows):
        return False
    first = np.array([float(r.split(",")[0]) for r in rows])
    joined = np.array([float(r.replace(",", ".")) for r in rows])
    return bool(np.any(np.diff(first) <= 0) and np.all(np.diff(joined) > 0))


def parse(text, *, scale_m_per_px=None, y_down=False, fs_hz=None):
    path = text.path
    notes = ["format: impacts (one impact time per row)"]
    if header_columns(text) is None:
        if _one_decimal_comma_column(text):
            text = type(text)(text.path, [(no, line.replace(",", ".")) for no, line in text.lines], text.multi)
        table = parse_table(text, headerless=("t",))
        notes.append("no header: one column read as impact times in s")
    else:
        table = parse_table(text)
    col = find_column(table.cols, TIME_NAMES, contains="time")
    if col is None:
        if len(table.cols) == 1 and _position_column(table.cols[0]):
            c = table.cols[0]
            fail(path, table.header_line, f"column '{c.raw}'{f' ({c.unit})' if c.unit else ''} holds positions, "
                                          f"not impact times; name a column of impact times 't' or 'time'")
        if len(table.cols) == 1:
            col = table.cols[0]
        else:
            fail(path, table.header_line, f"no time column (columns: {', '.join(c.raw for c in table.cols)}); "
                  f"name it {TIME_NAMING}")
    if not table.rows:
        fail(path, table.header_line, "header but no data rows")
    if table.decimal_comma:
        notes.append("decimal comma")
    same = repeated_columns(table.cols, col)
    if len(same) > 1:   # runs side by side (a spreadsheet with one column per trial)
        runs, labels = [], []
        for k, c in enumerate(same, start=1):
            t, lines, printed_s, left_out = _times(path, table, c)
            run = impact_times_from_events(f"{path} (column {c.index + 1})", t, lines,
                                           [*notes, f"impact times from column {c.index + 1} '{c.raw}'", *left_out],
                                           printed_s=printed_s)
            runs.append(run)
            labels.append(f"column {c.index + 1}")
        return Runs(runs=tuple(runs), source=path, labels=tuple(labels),
                    notes=(f"{len(same)} columns '{col.raw}': one run each, fitted jointly",
                           *_unread_notes(path, table, same)))
    if len(table.cols) > 1:
        notes.append(f"impact times from column '{col.raw or col.name}'" + (f" ({col.unit})" if col.unit else ""))
        notes.extend(_unread_notes(path, table, [col]))
    t, line_numbers, printed_s, left_out = _times(path, table, col)
    notes.extend(left_out)
    if col.unit not in ("", "s", "sec"):
        notes.append(f"impact times converted from {col.unit} to s")
    found = impact_times_from_events(path, t, line_numbers, notes, printed_s=printed_s,
                                     trajectory_hint=_trajectory_hint(table.cols))
    # vrcal track's file of a lossless recording says how well its onsets are timed
    instrument = meta_number(text, "instrument_sd_s", 0.1, "a time in s")
    if instrument:
        found = dataclasses.replace(found, instrument_sd_s=instrument)
    # ... and what its tracking found suspect
    return dataclasses.replace(found, suspect=(text.meta["suspect"][1],)) if "suspect" in text.meta else found


#: Column names of the intervals between events (phyphox's Acoustic Stopwatch writes ``Interval (s)`` beside
#: ``Event time (s)``; ``Intervall``, ``intervalo`` in a class's own language): they follow from the times.
INTERVAL_NAMES = ("interval", "dt", "delta t", "δt")


def _unread_notes(path, table, time_cols):
    """The notes naming the columns of ``table`` besides the time columns ``time_cols``, which are not read: an
    interval column (:data:`INTERVAL_NAMES`) with whether its intervals agree with the times
    (:func:`_interval_check`), the others by name."""
    read = {c.index for c in time_cols}
    intervals = [c for c in table.cols if c.index not in read
                 and (c.name in INTERVAL_NAMES or INTERVAL_NAMES[0] in c.name)]
    others = [c.raw or f"column {c.index + 1}" for c in table.cols if c.index not in read and c not in intervals]
    notes = []
    for c in intervals:
        # the time column it belongs to: the nearest before it (runs side by side repeat both)
        t_col = max((t for t in time_cols if t.index < c.index), key=lambda t: t.index, default=time_cols[0])
        named = (c.raw or c.name) + (f" ({c.unit})" if c.unit else "")
        notes.append(f"column '{named}' not read: the intervals follow from the times"
                     + _interval_check(path, table, c, t_col))
    if others:
        notes.append(f"column(s) {', '.join(repr(n) for n in others)} not read (impact times are read from one "
                     f"column)")
    return notes


def _interval_check(path, table, col, t_col):
    """'' when the interval column ``col`` agrees with the times of ``t_col`` (each interval the time to the next
    event, or since the last, to the digits both are written to; a 0 is no interval, as phyphox ends its
    column), or when that cannot be told (a unit that is no time, a cell that is no number: the times are read
    all the same); else a clause naming the first line that disagrees."""
    if col.unit not in TIME_UNITS or t_col.unit not in TIME_UNITS:
        return ""
    try:
        iv = column_values(path, table, col, what="interval", allow_empty=True) * TIME_UNITS[col.unit]
        t = column_values(path, table, t_col, what="impact time", allow_empty=True) * TIME_UNITS[t_col.unit]
    except DataError:
        return ""
    steps = [printed_resolution(v[np.isfinite(v)], 9, written=column_cells(table, c)) for v, c in ((iv, col),
                                                                                                 (t, t_col))]
    tol = 2.0 * sum(step * TIME_UNITS[c.unit] for step, c in zip(steps, (col, t_col)) if step) + 1e-9
    d = np.diff(t)
    lines = row_lines(table)
    found = []
    for which, given, first_row in (("to the next", iv[:-1], 0), ("since the last", iv[1:], 1)):
        used = np.isfinite(given) & np.isfinite(d) & (given != 0)
        off = np.flatnonzero(used & (np.abs(given - d) > tol))
        if not np.any(used):
            return ""
        if off.size == 0:
            return ""
        found.append((off.size, which, given, first_row, int(off[0])))
    _, which, given, first_row, k = min(found, key=lambda f: f[0])
    return (f"; they disagree with them (line {int(lines[k + first_row])}: {given[k]:.6g} s, the time {which} event "
            f"{d[k]:.6g} s): the times are read")


def _times(path, table, col):
    """(times [s], their lines, the step [s] they were written to or None, notes) of one column: empty cells after
    its last time end it (a shorter run beside a longer one), those before are left out, named by their lines in
    ``notes``."""
    t = column_values(path, table, col, what="impact time", allow_empty=True)
    factor = unit_factor(path, table, col, TIME_UNITS, "time")
    step = printed_resolution(t[np.isfinite(t)], 6, written=column_cells(table, col))
    t = t * factor
    line_numbers = row_lines(table)
    ok = np.isfinite(t)
    inside = ~ok & (np.arange(t.size) < (np.flatnonzero(ok)[-1] if np.any(ok) else 0))
    notes = [f"{counted(int(inside.sum()), 'row')} with no impact time left out: {said_lines(line_numbers[inside])}"
             ] if np.any(inside) else []
    t, line_numbers = t[ok], line_numbers[ok]
    check_increasing(path, t, line_numbers, "impact time")
    return t, line_numbers, None if step is None else step * factor, notes


def _trajectory_hint(cols):
    """How to read a table of equally spaced times as a trajectory: by ``--format trajectory`` when a column is
    named as heights (``Position (m)``, read as impact times with ``--format impacts``), else by naming one so
    (:data:`vrcal.measurements.plausibility.TRAJECTORY_HINT`)."""
    height = find_column(cols, Y_NAMES)
    if height is None:
        return TRAJECTORY_HINT
    return f"column '{height.raw}' holds the heights of a trajectory: give --format trajectory"


def impact_times_from_events(path, t_s, lines=None, notes=(), labels=None, printed_s=None,
                             trajectory_hint=TRAJECTORY_HINT):
    """ImpactTimes from a file's events: chains of consecutive bounces, the rest named and left out.

    Parameters
    ----------
    path : str
        the file (for messages)
    t_s : ndarray
        every event's time [s], strictly increasing, in file order
    lines : ndarray of int or None
        the file's line of each event
    notes : sequence of str
        the reader's notes so far
    labels : sequence of str or None
        how the file names each event (``"'Bounce 2' (line 2)"``); default ``"event i (line n)"``
    printed_s : float or None
        the step [s] the file wrote the times to, from their text (trailing zeros count); None: read
        from the times themselves (:func:`vrcal.measurements.cleanup.time_grid`)
    trajectory_hint : str
        how to read the file as a trajectory, told when the times are equally spaced

    Raises
    ------
    DataError
        fewer than three impacts, or no chain of three consecutive bounces
    """
    t = np.asarray(t_s, dtype=float)
    lines = None if lines is None else np.asarray(lines, dtype=int)
    notes = list(notes)

    def label(i):
        if labels is not None:
            return str(labels[i])
        return f"event {i + 1}" + (f" (line {int(lines[i])})" if lines is not None else "")

    where = int(lines[-1]) if lines is not None and lines.size else 0
    if t.size < MIN_IMPACTS:
        fail(path, where, f"only {t.size} impact(s); at least {MIN_IMPACTS} are needed")
    # units and shrinking intervals first: a list in ms or backwards stops here
    check_impact_times(t, path, trajectory_hint)
    if t.size > MAX_IMPACT_EVENTS:
        fail(path, where, f"{t.size:,} impact times, more than the {MAX_IMPACT_EVENTS:,} a file of drops can hold "
                          f"(a drop gives tens of impacts): are these a sensor's samples? Split the file into "
                          f"files of one or a few drops each")
    grid = time_grid(t, printed_s=printed_s)
    timing = grid.sigma_s if grid is not None and grid.sigma_s > TIMING_SIGMA_S else 0.0
    if timing:
        notes.append(f"impact times on a {grid.period_s * 1e3:.4g} ms grid ({grid.what}): each is uncertain by "
                     f"{timing * 1e3:.2g} ms (step/sqrt(12)), more than a stopwatch's {TIMING_SIGMA_S * 1e3:g} ms")
    found = impact_chains(t, labels=[label(i) for i in range(t.size)], timing_sigma_s=max(timing, TIMING_SIGMA_S),
                          leading=True)
    for _, why in found.anomalies:
        notes.append(why)
    if not found.chains:
        fail(path, where, f"no {MIN_IMPACTS} consecutive bounces: " + "; ".join(w for _, w in found.anomalies[:2]))
    in_chain = np.zeros(t.size, dtype=bool)
    for a, b in found.chains:
        in_chain[a:b + 1] = True
    keep = [int(i) for i in found.kept if in_chain[i]]
    pos = {i: k for k, i in enumerate(keep)}
    chains = tuple((pos[a], pos[b] + 1) for a, b in found.chains)
    if len(chains) > 1:
        parts = ", ".join(f"events {a + 1}-{b + 1}" for a, b in found.chains)
        notes.append(f"{len(chains)} chains of consecutive bounces ({parts}), fitted jointly: one epsilon, "
                     "one release state per chain")
    left_out = [i for i, _, _ in found.rejected]
    if left_out:
        notes.append(f"left out: {', '.join(label(i) for i in left_out[:8])}"
                     + (", ..." if len(left_out) > 8 else ""))
    return ImpactTimes(t_s=t[keep], source=path, notes=tuple(notes), rejected=found.rejected,
                       chains=chains if len(chains) > 1 else (), events=np.asarray(keep) + 1,
                       lines=None if lines is None else lines[keep], timing_sd_s=timing)
