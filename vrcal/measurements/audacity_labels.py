"""Audacity's label export: impact times marked on a recording of the bounces.

A student who records the bounces with a phone often opens the sound in Audacity, marks every
impact (by hand, or with *Analyze > Label Sounds*) and exports the labels (*File > Export >
Export Labels*). The file has no header; each line is ``start<TAB>end<TAB>text`` in seconds, with
``start == end`` for a point label and ``start < end`` for a region (the text may be empty). A
label made with a spectral selection is followed by a line ``\\<TAB>low<TAB>high`` (its frequency
range in Hz), which is skipped. Audacity writes a decimal point; a decimal comma is read too.

The **start** of each label is read as the impact time: *Label Sounds* starts a region where the
sound rises above its threshold, which is the impact; a region marked by hand starts there too. The
events then go through :func:`vrcal.measurements.impacts.impact_times_from_events` like any list of
impact times (echoes and bounces that do not belong are named by their label and line).
"""

from __future__ import annotations

import numpy as np

from vrcal.measurements.impacts import impact_times_from_events
from vrcal.measurements.table import fail, to_float

#: Lines the detector reads (a long file is checked in full by the parser).
_MAX_LINES_CHECKED = 200


def _label_rows(text, limit=None):
    """([(line, start, end, label)], None) of a label file, or (rows so far, the first line that is no
    label line).

    Every line but the spectral ones (first cell ``\\``) must be ``start<TAB>end[<TAB>text]`` with two
    numbers, ``end >= start``; the label text may hold anything but a tab.
    """
    rows = []
    for no, line in text.lines[:limit]:
        cells = line.rstrip("\r\n").split("\t")
        if cells[0].strip() == "\\":
            if len(cells) != 3 or any(to_float(c.strip(), True) is None for c in cells[1:]):
                return rows, no
            continue
        if len(cells) not in (2, 3):
            return rows, no
        start, end = (to_float(c.strip(), "," in c and "." not in c) for c in cells[:2])
        if start is None or end is None or not (np.isfinite(start) and np.isfinite(end)) or end < start:
            return rows, no
        rows.append((no, start, end, cells[2].strip() if len(cells) == 3 else ""))
    return rows, None


def detect(text):
    """A label export: tab-separated ``start, end[, text]`` lines, no header, the labels one after another
    (each starts at or after the end of the one before; both columns never decrease). A headerless ``t, y``
    trajectory is none: its heights fall and rise."""
    rows, bad = _label_rows(text, _MAX_LINES_CHECKED)
    if bad is not None or len(rows) < 2:
        return False
    start = np.array([r[1] for r in rows])
    end = np.array([r[2] for r in rows])
    return bool(np.all(np.diff(start) > 0) and np.all(start[1:] >= end[:-1]))


def parse(text, *, scale_m_per_px=None, y_down=False, fs_hz=None):
    path = text.path
    rows, bad = _label_rows(text)
    if bad is not None:
        fail(path, bad, "not an Audacity label line ('start<TAB>end<TAB>text', times in s, end >= start)")
    if not rows:
        fail(path, 0, "no labels (only spectral-selection lines)")
    t = np.array([r[1] for r in rows], dtype=float)
    lines = np.array([r[0] for r in rows], dtype=int)
    order_ok = np.diff(t) > 0
    if not np.all(order_ok):
        k = int(np.argmin(order_ok)) + 1
        fail(path, int(lines[k]), f"label start not increasing ({t[k]:g} after {t[k - 1]:g}): sort the labels "
                                  f"by time in Audacity's Labels editor")
    regions = sum(r[2] > r[1] for r in rows)
    notes = [f"format: Audacity label export ({len(rows)} labels"
             + (f", {regions} of them regions" if regions else "") + "): impact time = start of each label"]
    labels = [f"label {k + 1}" + (f" '{r[3]}'" if r[3] else "") + f" (line {r[0]})" for k, r in enumerate(rows)]
    return impact_times_from_events(path, t, lines, notes, labels=labels)
