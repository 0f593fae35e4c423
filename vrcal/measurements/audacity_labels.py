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
impact times (echoes and bounces that do not belong are named by their label and line). A file that
starts as a label export but has a bad line further down is an error naming that line and its bad
cell (:func:`explain`, which the layout detection calls before giving up).
"""

from __future__ import annotations

import numpy as np

from vrcal.measurements.impacts import impact_times_from_events
from vrcal.measurements.table import fail, to_float

#: Lines the detector reads (a long file is checked in full by the parser).
_MAX_LINES_CHECKED = 200


def _label_rows(text, limit=None):
    """``(rows, bad)``: ``rows`` = [(line, start, end, label)] of a label file; ``bad`` = None, or
    (the first line that is no label line, what is wrong with it).

    Every line but the spectral ones (first cell ``\\``) must be ``start<TAB>end[<TAB>text]`` with two
    numbers, ``end >= start``; the label text may hold anything but a tab.
    """
    rows = []
    for no, line in text.lines[:limit]:
        cells = line.rstrip("\r\n").split("\t")
        if cells[0].strip() == "\\":
            if len(cells) != 3 or any(to_float(c.strip(), True) is None for c in cells[1:]):
                return rows, (no, "a spectral line is '\\<TAB>low<TAB>high' (Hz)")
            continue
        if len(cells) not in (2, 3):
            return rows, (no, f"{len(cells)} tab-separated cells, not 2 or 3")
        start, end = (to_float(c.strip(), "," in c and "." not in c) for c in cells[:2])
        for value, cell, what in ((start, cells[0], "start"), (end, cells[1], "end")):
            if value is None or not np.isfinite(value):
                return rows, (no, f"the {what} {cell.strip()!r} is not a time in s")
        if end < start:
            return rows, (no, f"the end {end:g} s is before the start {start:g} s")
        rows.append((no, start, end, cells[2].strip() if len(cells) == 3 else ""))
    return rows, None


def starts_as_labels(text):
    """True when the first line of ``text`` is a label line ``start<TAB>end<TAB>text`` whose text is no
    number (a headerless table of numbers never is one, nor is a title line)."""
    cells = text.lines[0][1].rstrip("\r\n").split("\t")
    if len(cells) != 3 or not cells[2].strip() or to_float(cells[2].strip(), True) is not None:
        return False
    rows, _ = _label_rows(text, 1)
    return bool(rows)


def explain(text):
    """Fail naming the first bad line of a file that starts as a label export (its first line
    ``start<TAB>end<TAB>text`` with a text that is no number, which a headerless table of numbers never
    has) but is not one through to the end: the detector turned it down, and "cannot tell the layout
    from the header" would blame the good first line. Returns None for a file that does not start so."""
    if not starts_as_labels(text):
        return
    rows, bad = _label_rows(text)
    if bad is not None:
        fail(text.path, bad[0], f"{_NOT_A_LABEL}: {bad[1]}")
    _check_order(text.path, rows)


#: What a label line must be (the errors' start).
_NOT_A_LABEL = "not an Audacity label line ('start<TAB>end<TAB>text', times in s, end >= start)"


def _check_order(path, rows):
    """Fail naming the first label that starts before the one above it."""
    t = np.array([r[1] for r in rows], dtype=float)
    order_ok = np.diff(t) > 0
    if not np.all(order_ok):
        k = int(np.argmin(order_ok)) + 1
        fail(path, rows[k][0], f"label start not increasing ({t[k]:g} after {t[k - 1]:g}): sort the labels "
                               f"by time in Audacity's Labels editor")


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
        fail(path, bad[0], f"{_NOT_A_LABEL}: {bad[1]}")
    if not rows:
        fail(path, 0, "no labels (only spectral-selection lines)")
    _check_order(path, rows)
    t = np.array([r[1] for r in rows], dtype=float)
    lines = np.array([r[0] for r in rows], dtype=int)
    regions = sum(r[2] > r[1] for r in rows)
    notes = [f"format: Audacity label export ({len(rows)} labels"
             + (f", {regions} of them regions" if regions else "") + "): impact time = start of each label"]
    labels = [f"label {k + 1}" + (f" '{r[3]}'" if r[3] else "") + f" (line {r[0]})" for k, r in enumerate(rows)]
    return impact_times_from_events(path, t, lines, notes, labels=labels)
