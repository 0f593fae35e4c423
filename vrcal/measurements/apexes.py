"""Apex heights of successive bounces of one drop: a header ``bounce,h`` (bounce 0 is the drop
height; ``h`` in m unless the header names cm, mm or px), or a single column ``h`` (one row per
bounce, the first the drop height). Two rows (drop and first rebound) give epsilon and nothing
more.
"""

from __future__ import annotations

import numpy as np

from vrcal.errors import UsageError
from vrcal.measurements.cleanup import printed_resolution
from vrcal.measurements.table import (
    BOUNCE_NAMES,
    H_NAMES,
    LENGTH_UNITS,
    check_increasing,
    column_cells,
    column_values,
    fail,
    find_column,
    header_columns,
    parse_table,
    row_lines,
    unit_factor,
)
from vrcal.measurements.types import ApexHeights

#: Fewest apex rows (the drop height and one rebound give epsilon; a third row is needed to test an effect).
MIN_APEXES = 2


def detect(text):
    cols = header_columns(text)
    if not cols:
        return False
    if len(cols) == 1:
        return find_column(cols, H_NAMES) is not None
    return find_column(cols, BOUNCE_NAMES) is not None and find_column(cols, H_NAMES) is not None



def parse(text, *, scale_m_per_px=None, y_down=False, fs_hz=None):
    path = text.path
    table = parse_table(text)
    b_col, h_col = find_column(table.cols, BOUNCE_NAMES), find_column(table.cols, H_NAMES)
    if h_col is None or (b_col is None and len(table.cols) > 1):
        fail(path, table.header_line, "an apex file needs the columns 'bounce,h' (or one column 'h')")
    if b_col is not None and b_col.unit and b_col.unit in LENGTH_UNITS:
        fail(path, table.header_line, f"column '{b_col.raw}' is in {b_col.unit}: a height, not a bounce number (a "
                                      f"table of drop and rebound heights is the format 'drops')")
    if not table.rows:
        fail(path, table.header_line, "header but no data rows")
    line_numbers = row_lines(table)
    if b_col is None:
        bounce = np.arange(len(table.rows), dtype=float)
    else:
        bounce = column_values(path, table, b_col, what="bounce number")
    nonint = np.flatnonzero(bounce != np.round(bounce))
    if nonint.size:
        fail(path, int(line_numbers[nonint[0]]), f"bounce number {bounce[nonint[0]]:g} is not an integer (if "
                                                 f"'{b_col.raw}' holds rebound heights, write its unit, e.g. "
                                                 f"'{b_col.raw} (cm)', or name the columns 'Drop height', "
                                                 f"'Rebound height')")
    check_increasing(path, bounce, line_numbers, "bounce number")
    if np.any(bounce < 0):
        fail(path, int(line_numbers[0]), f"bounce number {bounce[0]:g} is negative (bounce 0 = drop height)")
    h = column_values(path, table, h_col, what="apex height")
    factor = scale_m_per_px if scale_m_per_px is not None and h_col.unit not in LENGTH_UNITS else \
        unit_factor(path, table, h_col, LENGTH_UNITS, "length", heights=True)
    notes = ["format: apexes (bounce, h; bounce 0 = drop height)" if b_col is not None else
             "format: apexes (one column of heights: the drop height, then one apex per bounce)"]
    if factor is None:
        if scale_m_per_px is None:
            raise UsageError(f"{path}: column 'h' is in pixels: give --scale M_PER_PX")
        factor = scale_m_per_px
    elif scale_m_per_px is not None:
        factor = scale_m_per_px
        notes.append(f"heights scaled by --scale {factor:g} m per file unit")
    elif factor != 1.0:
        notes.append(f"heights converted from {h_col.unit} to m")
    h_m = h * factor
    nonpos = np.flatnonzero(h_m <= 0)
    if nonpos.size:
        fail(path, int(line_numbers[nonpos[0]]), f"apex height {h[nonpos[0]]:g} is not positive")
    if h_m.size < MIN_APEXES:
        fail(path, int(line_numbers[-1]), f"only {h_m.size} apex row(s); at least {MIN_APEXES} are needed")
    if bounce[0] != 0:
        notes.append(f"first row is bounce {int(bounce[0])}, not 0 (the drop height)")
    gaps = np.flatnonzero(np.diff(bounce) > 1)
    if gaps.size:
        notes.append(f"bounce numbers skip after bounce {int(bounce[gaps[0]])}")
    step = printed_resolution(h, max_decimals=6, written=column_cells(table, h_col))   # '0.500': 1 mm
    return ApexHeights(bounce=bounce.astype(int), h_m=h_m, source=path, notes=tuple(notes), lines=line_numbers,
                       resolution_m=None if step is None else step * factor)

