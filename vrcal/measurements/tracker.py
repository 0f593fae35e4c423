"""Tracker data exports (physlets.org/tracker, *File > Export > Data*): line 1 the track name
with spaces turned into ``_`` (``mass_A``), line 2 the column names (``t``, ``x``, ``y``, ...),
then numbers such as ``1.245986911E-1``, joined by the chosen delimiter (tab, space, comma or
semicolon; a decimal comma in such a locale). A ``#multi:`` export (a row of track names above the
column names) uses the track whose ``y`` moves furthest -- the ball, not a calibration point or a
marker on the floor -- and a note names it and the others. Rows of frames that were not marked (empty
``y``) are skipped.
"""

from __future__ import annotations

import numpy as np

from vrcal.measurements.table import (
    TIME_NAMES,
    X_NAMES,
    Y_NAMES,
    column_values,
    find_column,
    header_columns,
    is_numeric_row,
    loose_cells,
    parse_table,
    split_cells,
    strip_cell,
    unquoted,
)
from vrcal.measurements.trajectory import trajectory_from_table


def detect(text):
    if len(text.lines) < 3:
        return False
    first = unquoted(text.lines[0][1]).strip()
    if not first or is_numeric_row(loose_cells(first)):
        return False
    at = 1
    cols = header_columns(text, at)
    if cols and text.multi and find_column(cols, Y_NAMES) is None:  # '#multi:' then a row of track names
        at, cols = 2, header_columns(text, 2)
    # Tracker names its columns without units ('t', 'x', 'y'): a title above 't (s), y (cm)' is no track name
    return bool(cols) and find_column(cols, TIME_NAMES) is not None and find_column(cols, Y_NAMES) is not None \
        and not any(c.unit for c in cols)



def parse(text, *, scale_m_per_px=None, y_down=False, fs_hz=None):
    track = strip_cell(text.lines[0][1].strip().strip(";,\t"))
    at = 1
    cols = header_columns(text, 1)
    if text.multi and (cols is None or find_column(cols, Y_NAMES) is None):
        at = 2
    table = parse_table(text, header_at=at)
    notes = [f"format: Tracker data export (track '{track}')"]
    ys = [c for c in table.cols if c.name in Y_NAMES]
    y_col = x_col = None
    if text.multi:
        names = split_cells(text.lines[at - 1][1], table.sep)   # the row of track names above the columns
        if len(names) == len(table.cols) - 1:
            names = ["", *names]    # the time column's empty name lost to a blank separator
        tracks = [strip_cell(names[c.index]) if c.index < len(names) else "" for c in table.cols]
        for i in range(1, len(tracks)):   # a name above a track's first column only: its other columns follow
            tracks[i] = tracks[i] or tracks[i - 1]
        y_col, x_col, note = _moving_track(text.path, table, tracks, ys)
        notes = [f"format: Tracker multi-track export; {note}"]
    elif len(ys) > 1:
        notes.append(f"{len(ys)} 'y' columns: using the first")
    shown = y_col or find_column(table.cols, Y_NAMES)   # None: trajectory_from_table says what is missing
    if scale_m_per_px is None and not y_down and not (shown is not None and shown.unit):
        notes.append("positions taken as metres (Tracker's calibrated units; use --scale for other units)")
    return trajectory_from_table(text.path, table, scale_m_per_px=scale_m_per_px, y_down=y_down, fs_hz=fs_hz,
                                  notes=notes, skip_empty_y=True, y_column=y_col, x_column=x_col)


def _moving_track(path, table, tracks, ys):
    """(y column, its track's x column or None, note) of a multi-track export: the track whose ``y`` spans the
    most (the falling ball; a calibration point or a floor marker stays put). ``tracks``: the track name of
    each column (the row above the column names)."""
    spans = []
    for c in ys:
        y = column_values(path, table, c, what="height", allow_empty=True)
        spans.append(float(np.nanmax(y) - np.nanmin(y)) if np.any(np.isfinite(y)) else 0.0)
    best = int(np.argmax(spans))
    y_col = ys[best]
    name = tracks[y_col.index] or f"column {y_col.index + 1}"
    x_col = next((c for c in table.cols if c.name in X_NAMES and tracks[c.index] == tracks[y_col.index]), None)
    others = [f"'{tracks[c.index] or f'column {c.index + 1}'}' ({spans[i]:.3g})" for i, c in enumerate(ys)
              if i != best]
    if not others:
        return y_col, x_col, f"track '{name}'"
    return y_col, x_col, (f"track '{name}', whose y spans the most ({spans[best]:.3g}); not "
                          f"{', '.join(others)} (delete a track's columns to choose another)")

