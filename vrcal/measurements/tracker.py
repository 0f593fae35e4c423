"""Tracker data exports (physlets.org/tracker, *File > Export > Data*): line 1 the track name
with spaces turned into ``_`` (``mass_A``), line 2 the column names (``t``, ``x``, ``y``, ...),
then numbers such as ``1.245986911E-1``, joined by the chosen delimiter (tab, space, comma or
semicolon; a decimal comma in such a locale). A ``#multi:`` export uses the first track's
columns. Rows of frames that were not marked (empty ``y``) are skipped.
"""

from __future__ import annotations

from vrcal.measurements.table import (
    TIME_NAMES,
    Y_NAMES,
    find_column,
    header_columns,
    is_numeric_row,
    loose_cells,
    parse_table,
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
    return bool(cols) and find_column(cols, TIME_NAMES) is not None and find_column(cols, Y_NAMES) is not None



def parse(text, *, scale_m_per_px=None, y_down=False, fs_hz=None):
    track = strip_cell(text.lines[0][1].strip().strip(";,\t"))
    at = 1
    cols = header_columns(text, 1)
    if text.multi and (cols is None or find_column(cols, Y_NAMES) is None):
        at = 2
    table = parse_table(text, header_at=at)
    notes = [f"format: Tracker data export (track '{track}')"]
    if text.multi:
        notes = [f"format: Tracker multi-track export; using the first track's columns ({track})"]
    ys = [c for c in table.cols if c.name in Y_NAMES]
    if len(ys) > 1:
        notes.append(f"{len(ys)} 'y' columns: using the first")
    if scale_m_per_px is None and not y_down:
        notes.append("positions taken as metres (Tracker's calibrated units; use --scale for other units)")
    return trajectory_from_table(text.path, table, scale_m_per_px=scale_m_per_px, y_down=y_down, fs_hz=fs_hz,
                                  notes=notes, skip_empty_y=True)

