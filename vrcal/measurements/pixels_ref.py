"""Reference-length pixel files: line 1 ``LENGTH_M;LENGTH_PX`` (a reference length in metres
and the pixels it spans), then ``y_img;x_img;`` per video frame, image y axis pointing down.
The frame rate is not in the file: it needs ``fs_hz``.
"""

from __future__ import annotations

import re

import numpy as np

from vrcal.measurements.table import Column, Table, fail, is_numeric_row
from vrcal.measurements.trajectory import trajectory_from_table


def detect(text):
    if len(text.lines) < 3:
        return False
    first = [c for c in re.split(r"[;,\t ]+", text.lines[0][1].strip()) if c]
    second = [c for c in re.split(r"[;,\t ]+", text.lines[1][1].strip()) if c]
    if len(first) != 2 or not is_numeric_row(first, False) or not is_numeric_row(second, False):
        return False
    length_m, length_px = (float(c) for c in first)
    # a reference length of a few cm to metres spanning many pixels (at most 10 cm per px)
    if not (0 < length_m <= 0.1 * length_px and length_px >= 10 and len(second) in (1, 2)):
        return False
    # a headerless t, y file: line 1's first number starts the evenly spaced times of the next lines
    lead = []
    for _, line in text.lines[:10]:
        cells = [c for c in re.split(r"[;,\t ]+", line.strip()) if c]
        if not cells or not is_numeric_row(cells[:1], False):
            break
        lead.append(float(cells[0]))
    step = np.diff(lead)
    evenly = step.size >= 3 and np.all(step > 0) and np.all(np.abs(step - np.median(step)) <= 0.1 * np.median(step))
    return not evenly


def parse(text, *, scale_m_per_px=None, y_down=True, fs_hz=None):
    path = text.path
    first_no, first = text.lines[0]
    ref = [c for c in re.split(r"[;,\t ]+", first.strip()) if c]
    if len(ref) != 2 or not is_numeric_row(ref, False):
        fail(path, first_no, f"a pixels-ref file starts with 'LENGTH_M;LENGTH_PX', found {len(ref)} cell(s) "
                             f"{first.strip()[:40]!r}")
    length_m, length_px = (float(c) for c in ref)
    if not (np.isfinite(length_m) and np.isfinite(length_px) and length_m > 0 and length_px > 0):
        fail(path, first_no, f"the reference line needs a length > 0 m spanning > 0 px, got {length_m:g} m, "
                             f"{length_px:g} px")
    ref_scale = length_m / length_px
    notes = [f"format: pixels-ref (line {first_no}: {length_m:g} m spans {length_px:g} px, "
             f"{ref_scale * 1e3:.4g} mm per px)"]
    if scale_m_per_px is not None:
        notes.append(f"--scale {scale_m_per_px:g} m/px overrides the reference line")
    rows = []
    for no, line in text.lines[1:]:
        cells = [c for c in re.split(r"[;,\t ]+", line.strip()) if c]
        if len(cells) not in (1, 2):
            fail(path, no, f"expected 'y_img;x_img;', found {len(cells)} cells")
        rows.append((no, cells))
    cols = [Column(0, "y", "px"), Column(1, "x", "px")] if all(len(c) == 2 for _, c in rows) else [
        Column(0, "y", "px")]
    table = Table(first_no, cols, rows, ";", False, [])
    return trajectory_from_table(path, table, scale_m_per_px=scale_m_per_px, y_down=True, fs_hz=fs_hz,
                                  notes=notes, force_scale=ref_scale)

