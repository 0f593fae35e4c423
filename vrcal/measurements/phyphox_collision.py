"""phyphox's one-row exports of impact times: *(In)elastic collision*, and the *Acoustic Stopwatch*'s
``Multiple`` and ``Simple`` sets.

The experiment listens for up to six impacts of a bouncing ball and exports them (CSV, or a sheet
``Energy`` of an Excel workbook) as one row with the columns ``Bounce 0 (s)``, ``Height 0 (m)``,
``Bounce 1 (s)``, ``Height 1 (m)``, ``Energy 1``, ... ``Bounce 5 (s)``, ``Height 5 (m)``,
``Energy 5`` [1]. Only the ``Bounce k`` times are measurements: the heights (g dt^2 / 8) and
energies ((dt_k / dt_1)^2) are phyphox's own drag-free estimates from the same intervals, so they
are not read (a note says so). A bounce phyphox did not hear is exported as 0 (or left empty) and is
skipped. Several rows (trials pasted below each other) are runs of one ball, fitted jointly.

The *Acoustic Stopwatch* [2] exports its events as the set ``All`` (a column ``Event time (s)``, one
event per row: the ``impacts`` layout) or, when the user picks another set, as one row: ``Multiple``
has ``Start (s)``, ``Stop 1 (s)``, ..., ``Stop 5 (s)`` (six events, read here like the collision's
bounces), ``Simple`` only ``Start (s)``, ``Stop (s)`` and their difference (two events: too few for
epsilon; the error says to export ``All``).

References
----------
[1] phyphox experiment "(In)elastic collision", ``inelastic_collision.phyphox`` of
    github.com/phyphox/phyphox-experiments (its ``<export>`` set "Energy").
[2] phyphox experiment "Acoustic Stopwatch", ``acoustic_stopwatch.phyphox`` of the same repository
    (its ``<export>`` sets "Simple" and "Multiple").
"""

from __future__ import annotations

import re

import numpy as np

from vrcal.measurements.impacts import impact_times_from_events
from vrcal.measurements.table import (
    TIME_UNITS,
    column_values,
    fail,
    header_columns,
    parse_table,
    row_lines,
    unit_factor,
)
from vrcal.measurements.types import Runs

_BOUNCE = re.compile(r"^bounce (\d+)$")
_STOP = re.compile(r"^stop(?: (\d+))?$")

#: Fewest ``Bounce k`` columns that make the collision layout (phyphox writes six).
MIN_BOUNCE_COLUMNS = 3


def _event_number(name):
    """The event number a column name gives (``Bounce 2`` -> 2; the stopwatch's ``Start`` -> 0,
    ``Stop`` -> 1, ``Stop 3`` -> 3) and the export it belongs to, or None."""
    m = _BOUNCE.match(name)
    if m:
        return int(m.group(1)), "collision"
    if name == "start":
        return 0, "stopwatch"
    m = _STOP.match(name)
    if m:
        return int(m.group(1) or 1), "stopwatch"
    return None


def _bounce_columns(cols):
    """({k: Column} of the event time columns, the export's name), or None when the header is not
    one of these layouts: at least three ``Bounce k`` columns, or ``Start`` with a ``Stop``."""
    found = {"collision": {}, "stopwatch": {}}
    for c in cols:
        hit = _event_number(c.name)
        if hit and c.unit in TIME_UNITS and c.unit:
            found[hit[1]].setdefault(hit[0], c)
    if len(found["collision"]) >= MIN_BOUNCE_COLUMNS:
        return found["collision"], "(In)elastic collision"
    stopwatch = found["stopwatch"]
    if 0 in stopwatch and len(stopwatch) >= 2:
        return stopwatch, "Acoustic Stopwatch"
    return None


def detect(text):
    cols = header_columns(text)
    return bool(cols) and _bounce_columns(cols) is not None


def parse(text, *, scale_m_per_px=None, y_down=False, fs_hz=None):
    path = text.path
    table = parse_table(text)
    found = _bounce_columns(table.cols)
    if found is None:
        fail(path, table.header_line,
             "a phyphox one-row export needs the columns 'Bounce 0 (s)', 'Bounce 1 (s)', ... ((In)elastic "
             "collision) or 'Start (s)', 'Stop 1 (s)', ... (Acoustic Stopwatch)")
    cols, export = found
    if not table.rows:
        fail(path, table.header_line, "header but no data rows")
    order = sorted(cols)
    if export == "Acoustic Stopwatch" and len(order) < MIN_BOUNCE_COLUMNS:
        fail(path, table.header_line, "phyphox's Acoustic Stopwatch set 'Simple' holds two events (start and "
                                      "stop), too few for epsilon: export the set 'All' (every event) instead")
    names = f"'{cols[order[0]].raw}' to '{cols[order[-1]].raw}'"
    notes = [f"format: phyphox {export} export (impact times from columns {names})"]
    if export == "(In)elastic collision" and len(table.cols) > len(cols):   # its heights and energies
        notes.append("its heights and energies are phyphox's own drag-free estimates from the same intervals "
                     "(h = g dt^2 / 8): not read")
    values = np.column_stack([column_values(path, table, cols[k], what="impact time", allow_empty=True)
                              * unit_factor(path, table, cols[k], TIME_UNITS, "time") for k in order])
    lines = row_lines(table)
    runs, labels = [], []
    for row, line in zip(values, lines):
        heard = np.isfinite(row) & (row > 0)   # phyphox writes 0 for a bounce it did not hear
        run_notes = list(notes)
        missing = [f"'{cols[k].raw}'" for k, ok in zip(order, heard) if not ok]
        if missing:
            run_notes.append(f"line {int(line)}: {', '.join(missing)} empty or 0 (not heard): skipped")
        source = path if len(values) == 1 else f"{path} (line {int(line)})"
        named = [f"'{cols[k].raw}' (line {int(line)})" for k, ok in zip(order, heard) if ok]
        runs.append(impact_times_from_events(source, row[heard], np.full(int(heard.sum()), int(line)), run_notes,
                                             labels=named))
        labels.append(f"line {int(line)}")
    if len(runs) == 1:
        return runs[0]
    return Runs(runs=tuple(runs), source=path, labels=tuple(labels),
                notes=(f"{len(runs)} rows: one drop each, fitted jointly",))
