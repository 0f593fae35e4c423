"""Vernier text exports (Logger Pro *File > Export As > Text*, and what Vernier's Arduino sketches
print): line 1 ``Vernier Format 2``, line 2 a description (the file and the date), line 3 the data
set (``Run 1``, ``Data Set``; several runs side by side name each over its columns), then the long
column names (``Time``, ``Position``), then the short names (``t``, ``x``) and/or the units (``s``,
``m``, or spelled out: ``seconds``, ``centimeters``), then tab-separated numbers.

The header is rebuilt as one line of names with their units (``Run 1: Time (s)``,
``Run 1: Position (m)``) and read as a trajectory (:mod:`vrcal.measurements.trajectory`): a motion
detector's position, runs side by side fitted jointly.
"""

from __future__ import annotations

import dataclasses

from vrcal.measurements import trajectory
from vrcal.measurements.table import fail, is_numeric_row, unit_of_cell

#: Units spelled out as Vernier's sketches print them, and their symbols.
SPELLED_UNITS = {"seconds": "s", "second": "s", "sec": "s", "milliseconds": "ms", "meters": "m", "metres": "m",
                 "meter": "m", "metre": "m", "centimeters": "cm", "centimetres": "cm", "millimeters": "mm",
                 "millimetres": "mm"}


def detect(text):
    return bool(text.lines) and text.lines[0][1].strip().lower().startswith("vernier format")


def _cells(line):
    return [c.strip() for c in line.split("\t")]


def _is_units(cells):
    """A line of units: every non-empty cell a unit symbol or a spelled-out unit."""
    filled = [c for c in cells if c]
    return bool(filled) and all(unit_of_cell(c) is not None for c in filled)


def parse(text, *, scale_m_per_px=None, y_down=False, fs_hz=None):
    lines = text.lines
    first_data = next((i for i, (_, line) in enumerate(lines) if i > 0 and is_numeric_row(
        [c for c in _cells(line) if c])), None)
    if first_data is None or first_data < 4:
        fail(text.path, lines[0][0], "a Vernier text export needs a description, a data set line, the column "
                                     "names and numbers below them")
    data_set = _cells(lines[2][1])
    names = _cells(lines[3][1])
    units = [""] * len(names)
    for _, line in lines[4:first_data]:          # short names and/or units
        cells = _cells(line)
        if _is_units(cells):
            units = [SPELLED_UNITS.get(c.lower(), c) for c in cells] + [""] * (len(names) - len(cells))
    sets, current = [], ""
    for i in range(len(names)):                  # a data set's name stands over its first column
        if i < len(data_set) and data_set[i]:
            current = data_set[i]
        sets.append(current)
    several = len({s for s in sets if s}) > 1
    header = "\t".join(f"{s + ': ' if several else ''}{n}{f' ({u})' if u else ''}"
                       for n, u, s in zip(names, units, sets))
    body = dataclasses.replace(text, lines=[(lines[3][0], header)] + list(lines[first_data:]))
    got = trajectory.parse(body, scale_m_per_px=scale_m_per_px, y_down=y_down, fs_hz=fs_hz)
    description, data_set = (" ".join(lines[i][1].split()) for i in (1, 2))   # a tab shown as one blank
    note = f"format: Vernier text export ('{description}', data set '{data_set}')"
    return dataclasses.replace(got, notes=(note,) + tuple(n for n in got.notes if not n.startswith("format:")))
