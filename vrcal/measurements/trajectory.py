"""Trajectories: a header naming a time column (``t``, ``time``) and a height column (``y``,
``height``, ``h``, a motion sensor's ``position``; ``x`` optional), one row per sample; units in
brackets (``t (s)``, ``y [cm]``, ``y (px)``) or after the name (``t_s``, ``y_cm``, ``t/s``,
``height in mm``). Without a time column the sample times come from the frame rate (``--fs``),
and from a ``frame`` column when there is one (frames not tracked leave gaps). A file without a header
whose lines hold two numbers, the first increasing, is read as ``t, y`` in s and m. A header that
repeats its time and height columns (a Vernier export of several runs, ``Run 1: Time (s)``,
``Run 1: Position (m)``, ``Run 2: Time (s)``, ...) holds runs side by side: one run per pair, in
order, fitted jointly (:class:`~vrcal.measurements.types.Runs`).
``vrcal simulate`` writes ``t,y``.

Also the shared last step of every video-track reader (:func:`trajectory_from_table`):
units and scale, the y direction, repeated rows, duplicated frames and the release.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from vrcal.errors import UsageError
from vrcal.measurements.cleanup import (
    detect_release_index,
    find_duplicated_frames,
    regular_frame_times,
    toss_top_index,
    tracker_glitches,
)
from vrcal.measurements.table import (
    FRAME_NAMES,
    LENGTH_UNITS,
    TIME_NAMES,
    TIME_NAMING,
    TIME_UNITS,
    X_NAMES,
    Y_NAMES,
    Y_NAMING,
    check_increasing,
    column_cells,
    column_values,
    fail,
    find_column,
    header_columns,
    meta_length,
    numeric_width,
    parse_table,
    repeated_columns,
    row_lines,
    said_lines,
    sniff,
    split_cells,
    to_float,
    unit_factor,
)
from vrcal.measurements.types import Runs, Trajectory
from vrcal.textout import counted

#: Times [s] from which on a time column is read as a clock's (a time stamp: Unix epoch seconds) and counted
#: from its first sample (a day: no record is that long).
CLOCK_TIME_S = 86400.0

#: Fewest samples a trajectory must have (whether bounces are present is the fitter's business).
MIN_TRAJECTORY_SAMPLES = 20
#: Fewest samples at a new height (not the previous sample's) a trajectory must have: a tracked ball in flight
#: is at a new height nearly every frame; a column of set drop heights (200, 200, ..., 280, 280, ...) is not.
MIN_MOVING_SAMPLES = 10


def _check_moving(path, y, line_numbers, y_col, unread):
    """DataError for a height column that changes at fewer than :data:`MIN_MOVING_SAMPLES` samples: no track,
    whatever its number of rows (a drop height per trial beside hand-timed flight times)."""
    y = np.asarray(y, dtype=float)
    if y.size < MIN_TRAJECTORY_SAMPLES:
        return
    changes = np.flatnonzero(np.diff(y) != 0) + 1
    if changes.size >= MIN_MOVING_SAMPLES:
        return
    lines = ", ".join(str(int(line_numbers[i])) for i in changes[:6]) + (", ..." if changes.size > 6 else "")
    where = f" (line(s) {lines})" if changes.size else ""
    others = f"; column(s) {', '.join(repr(n) for n in unread)} not read" if unread else ""
    fail(path, int(line_numbers[0]) if line_numbers.size else 0,
         f"column '{y_col.raw}' changes at {changes.size} of its {y.size} rows{where}: no ball's track (a tracked "
         f"ball is at a new height nearly every frame in flight){others}; if it holds set drop heights, this is "
         f"no trajectory: see docs/measurements.md for the layouts vrcal reads (drop and rebound heights, impact "
         f"times, a track of t, y)")

def detect(text):
    cols = header_columns(text)
    if cols is None:
        return _headerless_t_y(text)
    return find_column(cols, Y_NAMES) is not None


def _headerless_t_y(text):
    """Two numbers per line, the first strictly increasing (times): a headerless t, y file."""
    if numeric_width(text) != 2:
        return False
    head = [s for _, s in text.lines[:50]]
    sep, dc = sniff(head[0], head[1:])
    first = np.array([to_float(split_cells(s, sep)[0], dc) for s in head])
    return bool(np.all(np.isfinite(first)) and np.all(np.diff(first) > 0))   # inf or nan: no times



def finish_trajectory(path, t_s, y_m, line_numbers, notes, positions=None):
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
    check_increasing(path, t_s, line_numbers, "time")
    # a frame that repeats the one before is a duplicated frame (below), not a tracker's glitch
    glitches = [g for g in tracker_glitches(t_s, y_m) if not np.all(pos[g[0]:g[1]] == pos[g[0] - 1])]
    if glitches:
        keep = np.ones(t_s.size, dtype=bool)
        for a, b, _ in glitches:
            keep[a:b] = False
        notes.append(glitch_note(line_numbers, glitches))
        t_s, y_m, line_numbers, pos = t_s[keep], y_m[keep], line_numbers[keep], pos[keep]
    release = detect_release_index(y_m)
    top = toss_top_index(t_s, y_m, release) if release > 0 else None
    if top is not None:
        # tossed: held, thrown and rising are no drop from rest; the top of the toss is (at rest, in flight)
        if t_s.size - top < MIN_TRAJECTORY_SAMPLES:
            fail(path, int(line_numbers[top]),
                 f"the ball was tossed up to its top here, and only {t_s.size - top} samples follow it; a trajectory "
                 f"from the top of a toss (a drop from rest there) needs at least {MIN_TRAJECTORY_SAMPLES}")
        notes.append(f"the ball was tossed up: samples 0-{top - 1} (line {int(line_numbers[0])} to line "
                     f"{int(line_numbers[top - 1])}: held, thrown and rising) left out; the fit starts at the top "
                     f"of the toss (line {int(line_numbers[top])}), a drop from rest there")
        t_s, y_m, line_numbers, pos = t_s[top:], y_m[top:], line_numbers[top:], pos[top:]
        release = 0
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
        fail(path, int(line_numbers[-1]) if line_numbers.size else 0,
              f"only {t_s.size} samples; a trajectory needs at least {MIN_TRAJECTORY_SAMPLES}")
    notes.append(release_note(t_s, line_numbers, release))
    return Trajectory(t_s=t_s, y_m=y_m, source=path, notes=tuple(notes), release_index=int(release),
                      lines=np.asarray(line_numbers, dtype=int))


def glitch_note(line_numbers, glitches):
    """The note on the samples :func:`~vrcal.measurements.cleanup.tracker_glitches` found, naming the file's
    lines and how far the largest lay off its neighbours' path."""
    where = [f"line {int(line_numbers[a])}" if b - a == 1 else
             f"lines {int(line_numbers[a])}-{int(line_numbers[b - 1])}" for a, b, _ in glitches]
    shown = ", ".join(where[:8]) + (f" and {len(where) - 8} more" if len(where) > 8 else "")
    n = sum(b - a for a, b, _ in glitches)
    jump = max(size for _, _, size in glitches)
    return (f"left out {n} sample(s) that jump off the smooth path of their neighbours and back, up to "
            f"{jump * 1e3:.3g} mm, as no ball in flight or at rest can (a tracker's glitch: another object, a "
            f"reflection, a blurred frame): {shown}")


def release_note(t_s, line_numbers, release):
    """The note on a trajectory's still segment: where the release was detected (``line_numbers``: the file's
    line of each sample, or None), or that none was."""
    if release <= 0:
        return "no still segment before release detected"
    line = "" if line_numbers is None else f", line {int(line_numbers[release])}"
    return (f"still segment: samples 0-{release - 1} (release detected at sample {release}, "
            f"t = {t_s[release]:.4g} s{line}); kept for the fit")


def release_with_noise(run, sigma_m):
    """``run`` (a :class:`Trajectory`) with its release detected again at a known noise of one height
    ``sigma_m`` [m] (the user's, or one measured on the samples; the reader estimated its own), its note
    rewritten; ``run`` itself when the release stays where it was."""
    import dataclasses

    release = detect_release_index(np.asarray(run.y_m, dtype=float), sigma=float(sigma_m))
    if release == int(run.release_index or 0):
        return run
    t = np.asarray(run.t_s, dtype=float)
    note = release_note(t, run.lines, release) + f" (at the noise of {1e3 * sigma_m:.3g} mm)"
    notes = tuple(note if n.startswith(("still segment: ", "no still segment before release")) else n
                  for n in run.notes)
    return dataclasses.replace(run, release_index=int(release), notes=notes)


def trajectory_from_table(path, table, *, scale_m_per_px, y_down, fs_hz, notes, skip_empty_y=False,
                           force_scale=None, empty_rows="frames not marked", y_column=None, x_column=None,
                           name_unread=False, empty_after_end=False):
    """A :class:`Trajectory` of a parsed table: its time (or frame) column and height column (the first of
    :data:`Y_NAMES` unless ``y_column``, with ``x_column``, names the track's own). ``name_unread``: a note
    names the columns not read (a tracker's export has velocity columns by design; a table of other things
    -- a drop height beside hand-timed flights -- is read as a track only in part).

    A row with an empty height or time cell is left out, named by its line in a note (a motion detector's lost
    echo); ``skip_empty_y``: such rows are the file's way (a tracker's frames not marked, ``empty_rows`` says
    why) and are counted only -- after the column's last height alone with ``empty_after_end`` (a shorter run
    beside a longer one). A column with no number at all is an error."""
    cols = table.cols
    t_col = find_column(cols, TIME_NAMES)
    frame_col = find_column(cols, FRAME_NAMES)
    y_col = y_column or find_column(cols, Y_NAMES)
    x_col = x_column if y_column is not None else find_column(cols, X_NAMES)
    if y_col is None:
        fail(path, table.header_line, f"no height column 'y' (columns: {', '.join(c.raw for c in cols)}): name the "
                                      f"height column {Y_NAMING}, with its unit ('y (m)')")
    if not table.rows:
        fail(path, table.header_line, "header but no data rows")
    notes = list(notes)
    y = column_values(path, table, y_col, what="height", allow_empty=True)
    line_numbers = row_lines(table)
    empty = np.isnan(y)
    if np.all(empty):
        fail(path, table.header_line, f"column '{y_col.raw}' (height) holds no number: every cell is empty")
    # time
    if t_col is not None:
        t = column_values(path, table, t_col, what="time", allow_empty=True)
        factor = unit_factor(path, table, t_col, TIME_UNITS, "time")
        ok = np.isfinite(t) & ~empty
        grid = regular_frame_times(t[ok], written=column_cells(table, t_col))
        if grid is not None:
            t = t.copy()
            t[ok] = grid.t_s
            unit = t_col.unit or "s"
            notes.append(f"times printed to {grid.resolution:g} {unit}, coarse for a frame period of "
                         f"{grid.step * factor * 1e3:.4g} ms: put back on the regular grid t0 + k x period "
                         f"(largest change {grid.largest_change * factor * 1e3:.2g} ms)")
        t = t * factor
        first = t[np.isfinite(t)][:1]
        if first.size and first[0] >= CLOCK_TIME_S:
            # a clock's time of day (Unix epoch seconds): squared in a parabola's fit it loses its digits
            t = t - first[0]
            notes.append(f"times are a clock's ({first[0]:.10g} s at the first sample, Unix epoch seconds?): "
                         "counted from the first sample")
        if fs_hz is not None:
            notes.append(f"--fs {fs_hz:g} Hz ignored: the file has a time column")
    else:
        if fs_hz is None:
            what = f" (times = column '{frame_col.raw}' / frame rate)" if frame_col is not None else ""
            named = [c.raw for c in cols if c.raw]
            naming = f" (columns: {', '.join(named)}): name it {TIME_NAMING}, or" if named else ":"
            raise UsageError(f"{path}: no time column{naming} give the frame rate with --fs HZ{what}")
        if not (np.isfinite(fs_hz) and fs_hz > 0):
            raise UsageError(f"--fs must be a positive frame rate in Hz, got {fs_hz:g}")
        if frame_col is not None:   # frames not tracked leave gaps that the frame numbers keep
            t = column_values(path, table, frame_col, what="frame number", allow_empty=True) / float(fs_hz)
            notes.append(f"times = column '{frame_col.raw}' / {fs_hz:g} Hz (no time column)")
        else:
            t = np.arange(y.size) / float(fs_hz)
            notes.append(f"times from the frame rate {fs_hz:g} Hz (no time column)")
    x = column_values(path, table, x_col, what="x", allow_empty=True) if x_col is not None else None
    notes += _empty_notes(line_numbers, empty, np.isnan(t) & ~empty, skip_empty_y, empty_after_end, empty_rows)
    empty |= np.isnan(t)
    keep = ~empty
    t, y, line_numbers = t[keep], y[keep], line_numbers[keep]
    read = {c.index for c in (t_col, y_col, x_col) if c is not None}
    if t_col is None and frame_col is not None:
        read.add(frame_col.index)
    unread = [c.raw or f"column {c.index + 1}" for c in cols if c.index not in read]
    if unread and name_unread:
        notes.append(f"column(s) {', '.join(repr(n) for n in unread)} not read (a trajectory reads a time, a "
                     f"height and an x column)")
    _check_moving(path, y, line_numbers, y_col, unread)
    x = x[keep] if x is not None else None
    # length scale
    if force_scale is not None and scale_m_per_px is None:
        factor = force_scale
    elif scale_m_per_px is not None:
        if not (np.isfinite(scale_m_per_px) and scale_m_per_px > 0):
            raise UsageError(f"--scale must be a positive number of metres per pixel, got {scale_m_per_px:g}")
        factor = float(scale_m_per_px)
        ignored = y_col.unit and y_col.unit not in ("px", "pixel", "pixels")
        extra = f" (header unit '{y_col.unit}' ignored)" if ignored else ""
        notes.append(f"positions scaled by --scale {factor:g} m per file unit{extra}")
    else:
        factor = unit_factor(path, table, y_col, LENGTH_UNITS, "length")
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
    return finish_trajectory(path, t, y_m, line_numbers, notes, positions)


def _empty_notes(line_numbers, no_height, no_time, skip_empty_y, after_end, why):
    """The notes on the rows left out for an empty height (``no_height``) or time (``no_time``) cell: those the
    file leaves empty by its way (``skip_empty_y``; with ``after_end`` only those after the last height) counted
    with ``why``, the others named by their lines."""
    expected = np.zeros(no_height.size, dtype=bool)
    if skip_empty_y:
        expected[:] = True
        if after_end:
            expected[:int(np.flatnonzero(~no_height)[-1]) + 1] = False
    notes = []
    if np.any(no_height & expected):
        notes.append(f"skipped {int(np.sum(no_height & expected))} row(s) without a position ({why})")
    for missing, what in ((no_height & ~expected, "height"), (no_time & ~expected, "time")):
        if np.any(missing):
            n = int(missing.sum())
            notes.append(f"{counted(n, 'row')} with no {what} left out: {said_lines(line_numbers[missing])}")
    return notes


def side_by_side_runs(path, table):
    """[(time column or None, height column, x column or None)] of each run when the header repeats its
    height column (runs side by side), else None. The k-th time (and x) column goes with the k-th height
    column; a header whose time columns do not pair with its height columns is an error."""
    cols = table.cols
    y0, t0, x0 = find_column(cols, Y_NAMES), find_column(cols, TIME_NAMES), find_column(cols, X_NAMES)
    if y0 is None:
        return None

    ys, ts, xs = repeated_columns(cols, y0), repeated_columns(cols, t0), repeated_columns(cols, x0)
    if len(ys) < 2:
        return None
    if ts and len(ts) != len(ys):
        fail(path, table.header_line, f"{len(ys)} columns '{y0.raw}' but {len(ts)} columns '{t0.raw}': runs side "
                                      f"by side need one time column per height column")
    if len(xs) != len(ys):
        xs = []
    return [(ts[k] if ts else None, ys[k], xs[k] if xs else None) for k in range(len(ys))]


def _run_labels(pairs):
    """A label per run: the data set's name before its height column (``Run 2``) and its columns."""
    labels = []
    for t_col, y_col, _ in pairs:
        where = f"columns {t_col.index + 1}, {y_col.index + 1}" if t_col is not None else f"column {y_col.index + 1}"
        labels.append(f"{y_col.data_set} ({where})" if y_col.data_set else where)
    return labels


def _one_scene_body(path, table):
    """``table`` of ``vrcal scene``'s NAME-trajectories.csv (``t_s, body, x_m, y_m, z_m, bottom_m, ...``;
    its ``y_m`` is horizontal) as a t, y table of the bottom's height, when it holds one body; a
    DataError naming the bodies when it holds several (each is another ball: keep one's rows)."""
    body = find_column(table.cols, ("body",))
    bodies = list(dict.fromkeys(cells[body.index].strip() for _, cells in table.rows))
    if len(bodies) > 1:
        fail(path, table.header_line, f"a vrcal scene's trajectories of {len(bodies)} bodies ({', '.join(bodies)}): "
                                      "each is another ball; keep the rows of one (its bottom_m is read as the height)")
    t, bottom = find_column(table.cols, TIME_NAMES), find_column(table.cols, ("bottom",))
    return table._replace(cols=[c for c in (t, bottom._replace(name="y")) if c is not None], numeric=None)


def parse(text, *, scale_m_per_px=None, y_down=False, fs_hz=None):
    notes = ["format: trajectory (t, y columns)"]
    if header_columns(text) is None:
        table = parse_table(text, headerless=("t", "y"))
        notes.append("no header: two columns read as t [s], y [m]")
    else:
        table = parse_table(text)
    if {"body", "bottom"} <= {c.name for c in table.cols}:
        table = _one_scene_body(text.path, table)
        notes.append("a vrcal scene's trajectories: the ball's bottom (bottom_m) read as the height")
    pairs = side_by_side_runs(text.path, table)
    if pairs is not None:
        labels = _run_labels(pairs)
        runs = []
        for label, pair in zip(labels, pairs):
            sub = table._replace(cols=[c for c in pair if c is not None])
            runs.append(trajectory_from_table(f"{text.path} ({label})", sub, scale_m_per_px=scale_m_per_px,
                                              y_down=y_down, fs_hz=fs_hz, notes=tuple(notes), skip_empty_y=True,
                                              empty_rows=f"after the end of {label}", empty_after_end=True))
        return Runs(runs=tuple(runs), source=text.path, labels=tuple(labels),
                    notes=(f"{len(runs)} runs side by side ({', '.join(labels)}): fitted jointly",))
    traj = trajectory_from_table(text.path, table, scale_m_per_px=scale_m_per_px, y_down=y_down, fs_hz=fs_hz,
                                 notes=tuple(notes), name_unread=True)
    # what the tool that made the file knows of its errors ('vrcal track' writes them as comments)
    known = {key: meta_length(text, key) for key in ("systematic_m", "floor_sd_m")}
    if any(known.values()):
        traj = dataclasses.replace(traj, **known)
    return traj


