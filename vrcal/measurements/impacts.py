"""Impact times, e.g. a phyphox *Acoustic Stopwatch* / *(In)elastic collision* CSV export: a
(possibly quoted) header such as ``"Event time (s)"``, separators comma, semicolon or tab,
decimal point or comma, scientific notation. With several columns the time column is picked
by its name. ``vrcal simulate --format impacts`` writes ``t``. Missed impacts and echoes are
screened (:func:`vrcal.measurements.cleanup.detect_impact_anomalies`); the clean prefix is kept.
"""

from __future__ import annotations

import numpy as np

from vrcal.measurements.cleanup import detect_impact_anomalies
from vrcal.measurements.table import (
    BOUNCE_NAMES,
    TIME_NAMES,
    TIME_UNITS,
    Y_NAMES,
    check_increasing,
    column_values,
    fail,
    find_column,
    header_columns,
    parse_table,
    unit_factor,
)
from vrcal.measurements.types import ImpactTimes

#: Fewest impacts after removing anomalies.
MIN_IMPACTS = 3

def detect(text):
    cols = header_columns(text)
    return (bool(cols) and find_column(cols, Y_NAMES) is None and find_column(cols, BOUNCE_NAMES) is None
            and find_column(cols, TIME_NAMES, contains="time") is not None)



def parse(text, *, scale_m_per_px=None, y_down=False, fs_hz=None):
    path = text.path
    table = parse_table(text)
    col = find_column(table.cols, TIME_NAMES, contains="time")
    if col is None:
        if len(table.cols) == 1:
            col = table.cols[0]
        else:
            fail(path, table.header_line, f"no time column (columns: {', '.join(c.name for c in table.cols)}); "
                  "name it 't' or 'time'")
    if not table.rows:
        fail(path, table.header_line, "header but no data rows")
    notes = ["format: impacts (one impact time per row)"]
    if len(table.cols) > 1:
        notes.append(f"impact times from column '{col.name}'" + (f" ({col.unit})" if col.unit else ""))
    if table.decimal_comma:
        notes.append("decimal comma")
    t = column_values(path, table, col, what="impact time")
    t = t * unit_factor(path, table, col, TIME_UNITS, "time")
    line_numbers = np.array([no for no, _ in table.rows])
    check_increasing(path, t, line_numbers, "impact time")
    if t.size < MIN_IMPACTS:
        fail(path, int(line_numbers[-1]), f"only {t.size} impact(s); at least {MIN_IMPACTS} are needed")
    n_clean, rejected = detect_impact_anomalies(t)
    if rejected:
        idx, t0, reason = rejected[0]
        notes.append(f"impact {idx} at t = {t0:.4f} s (line {int(line_numbers[idx])}): {reason}; "
                     f"fitting the {n_clean} impacts before it, {len(rejected)} rejected")
    if n_clean < MIN_IMPACTS:
        idx, t0, reason = rejected[0]
        fail(path, int(line_numbers[idx]), f"only {n_clean} impact(s) before an anomaly ({reason}); "
              f"at least {MIN_IMPACTS} are needed")
    return ImpactTimes(t_s=t[:n_clean], source=path, notes=tuple(notes), rejected=rejected)

