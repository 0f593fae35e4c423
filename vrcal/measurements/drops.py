"""A table of drop and rebound heights: the classroom experiment, one row per trial.

The header names which column is which (case matters only for ``H`` and ``h``):

* the drop height: ``H``, ``H0``, ``h0``, ``drop``, ``drop height``, ``release height``,
  ``initial height``;
* the first rebound: ``h``, ``h1``, ``rebound``, ``rebound height``, ``bounce height``,
  ``first rebound``; further rebounds of the same trial may follow as ``h2``, ``h3``, ...;
* other columns (``trial``, ``n``, a comment) are ignored.

Units in brackets (``H (cm)``, ``h [mm]``; m when none). A height column without a unit takes
the unit of the other height columns when they agree on one (with a note). Every row is a
run of its own (its own drop); :class:`vrcal.measurements.types.Runs` of
:class:`vrcal.measurements.types.ApexHeights` (bounce 0 = the drop height) are fitted jointly
by ``vrcal discover``: one epsilon and one set of effects for all the rows, a drop height per
row. The speed changes from row to row, which is what tells air drag and a speed-dependent
epsilon apart.
"""

from __future__ import annotations

import re

import numpy as np

from vrcal.measurements.table import (
    BOUNCE_NAMES,
    LENGTH_UNITS,
    TIME_NAMES,
    column_values,
    fail,
    find_column,
    header_columns,
    parse_table,
    row_lines,
)
from vrcal.measurements.types import ApexHeights, Runs

DROP_NAMES = ("h0", "h 0", "drop", "drop height", "release height", "initial height", "height of drop",
              "hdrop", "h drop", "drop h", "h release")
REBOUND_NAMES = ("h1", "h 1", "rebound", "rebound height", "bounce height", "first rebound", "hrebound",
                 "h rebound", "return height", "rebound h")
_MORE = re.compile(r"^h\s*(\d+)$")


def _height_columns(cols):
    """{bounce number: Column} of a drop table, or None when the columns are not one."""
    drop = next((c for c in cols if c.raw in ("H", "H0", "H 0")), None) or find_column(cols, DROP_NAMES)
    if drop is None:
        return None
    rebound = find_column(cols, REBOUND_NAMES) or next((c for c in cols if c.raw == "h"), None)
    if rebound is None or rebound.index == drop.index:
        return None
    out = {0: drop, 1: rebound}
    for c in cols:
        m = _MORE.match(c.name)
        if m and int(m.group(1)) >= 2 and c.index not in (drop.index, rebound.index):
            out.setdefault(int(m.group(1)), c)
    return out


def detect(text):
    cols = header_columns(text)
    if not cols or find_column(cols, BOUNCE_NAMES) is not None or find_column(cols, TIME_NAMES) is not None:
        return False
    return _height_columns(cols) is not None


def parse(text, *, scale_m_per_px=None, y_down=False, fs_hz=None):
    path = text.path
    table = parse_table(text)
    heights = _height_columns(table.cols)
    if heights is None:
        fail(path, table.header_line, "a drop table needs a drop-height column ('H', 'drop') and a rebound "
              "column ('h', 'rebound')")
    if not table.rows:
        fail(path, table.header_line, "header but no data rows")
    names = ", ".join(f"'{c.raw}'" for _, c in sorted(heights.items()))
    notes = [f"format: drop table (one trial per row; drop and rebound heights from columns {names})"]
    units = {c.unit for c in heights.values() if c.unit}
    factors = {}
    for b, c in heights.items():
        unit = c.unit
        if not unit and len(units) == 1:
            unit = next(iter(units))
            notes.append(f"column '{c.raw}' has no unit: taken as {unit} like the other heights")
        if unit not in LENGTH_UNITS or LENGTH_UNITS[unit] is None:
            fail(path, table.header_line, f"unknown length unit '{unit}' of column '{c.raw}' (known: m, cm, mm)")
        factors[b] = LENGTH_UNITS[unit]
    if scale_m_per_px is not None:
        factors = {b: float(scale_m_per_px) for b in factors}
        notes.append(f"heights scaled by --scale {scale_m_per_px:g} m per file unit")
    elif units - {"m"}:
        notes.append(f"heights converted from {', '.join(sorted(units - {'m'}))} to m")
    values = {b: column_values(path, table, c, what="height", allow_empty=b >= 2) * factors[b]
              for b, c in heights.items()}
    line_numbers = row_lines(table)
    runs, labels = [], []
    for k, no in enumerate(line_numbers):
        bounces = [b for b in sorted(values) if np.isfinite(values[b][k])]
        if bounces[:2] != [0, 1]:
            fail(path, int(no), "a trial needs its drop height and its first rebound")
        h = np.array([values[b][k] for b in bounces])
        bad = np.flatnonzero(h <= 0)
        if bad.size:
            fail(path, int(no), f"height {h[bad[0]]:g} m is not positive")
        runs.append(ApexHeights(bounce=np.array(bounces), h_m=h, source=f"{path}:{int(no)}",
                                notes=(), lines=np.full(len(bounces), int(no))))
        labels.append(f"row {k + 1} (line {int(no)})")
    H = values[0]
    notes.append(f"{len(runs)} trial(s), drop heights {np.min(H):.3g}-{np.max(H):.3g} m")
    return Runs(runs=tuple(runs), source=path, notes=tuple(notes), labels=tuple(labels))
