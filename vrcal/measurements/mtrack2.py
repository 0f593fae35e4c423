"""ImageJ MTrack2 exports (Nico Stuurman's MTrack2 plugin for ImageJ/Fiji, imagej.net/MTrack2; its results
saved to a file, or its Results window saved as text or CSV).

Layout: a header ``Frame, X1, Y1, Flag1, X2, Y2, Flag2, ...`` (tab- or comma-separated, or one blank
between cells where an editor turned each tab into a blank: an empty cell is then two blanks in a row); a line
``Tracks 1 to N`` before each block of tracks (a block holds as many tracks as the header names; a
further block repeats the frames for the next tracks in the same columns); one row per frame of the
image stack (frames counted from 1), a track's cells blank where it was not found, its flag ``*`` where
another object lay as close (MTrack2 took the closest); then, when path lengths were asked for, a summary
``Track, Length, Distance traveled, Nr of Frames`` with a row per track, which is skipped.

Positions are pixels of the image, whose y axis points down: the file needs the frame rate (``--fs``:
t = frame / fs) and the pixel scale (``--scale``). Of several tracks the one that moves most up and down
is read (the ball; a mark on the wall or a speck of dust stays put), or the one named by ``track``
(``--sheet N`` on the command line), with a note naming them all.
"""

from __future__ import annotations

import re

import numpy as np

from vrcal.errors import UsageError
from vrcal.measurements.table import Column, Table, fail, sniff, split_cells
from vrcal.measurements.trajectory import trajectory_from_table

#: One track's columns in the header: X<k>, Y<k>, Flag<k>.
_TRIPLE = ("x{}", "y{}", "flag{}")
_BLOCK = re.compile(r"^\s*tracks\s+(\d+)\s+to\s+(\d+)\s*$", re.IGNORECASE)
_SUMMARY = re.compile(r"^\s*track\s+length\b", re.IGNORECASE)
#: The separator of an export whose tabs an editor turned into single blanks (each blank one cell boundary).
_ONE_BLANK = "one blank"


def _separator(header):
    """The export's separator: MTrack2's tab, a CSV save's comma or semicolon, or :data:`_ONE_BLANK` when an
    editor turned each tab into one blank (the header's words one blank apart); None for no MTrack2 layout."""
    sep = sniff(header, [])[0]
    if sep is None and "  " not in header.strip() and len(header.split()) > 1:
        sep = _ONE_BLANK
    return sep


def _cells(line, sep):
    """The line's cells; one blank apart, each blank is the tab it replaced, so an empty cell stays empty
    ('8 151.8 32.3 * 140.2 ...' and '9 151.4 35.6    ' with track 2 not found)."""
    return split_cells(line.replace(" ", "\t"), "\t") if sep == _ONE_BLANK else split_cells(line, sep)


def _n_tracks(header):
    """Tracks the header names (its X<k>, Y<k>, Flag<k> triples after ``Frame``), or 0 when it is no MTrack2
    header."""
    cells = [c.lower() for c in _cells(header, _separator(header))]
    if len(cells) < 4 or cells[0] != "frame" or (len(cells) - 1) % 3:
        return 0
    n = (len(cells) - 1) // 3
    want = [name.format(k) for k in range(1, n + 1) for name in _TRIPLE]
    return n if cells[1:] == want else 0


def detect(text):
    return len(text.lines) >= 2 and _n_tracks(text.lines[0][1]) > 0


def _words(line, sep):
    """The line's cells joined by single blanks (a CSV save splits 'Tracks 1 to 2' into cells)."""
    return " ".join(c for c in _cells(line, sep) if c)


def read_tracks(text):
    """``({track: (frames, x, y, flags, line numbers)}, summary line or None)`` of an MTrack2 export."""
    path = text.path
    header_no, header = text.lines[0]
    sep = _separator(header)
    per_block = _n_tracks(header)
    if not per_block:      # --format mtrack2 on another file
        fail(path, header_no, f"expected MTrack2's header 'Frame, X1, Y1, Flag1, ...', found {header.strip()[:60]!r}")
    first = 1                     # the track in the first triple of the current block
    rows = {}
    summary = None
    for no, line in text.lines[1:]:
        words = _words(line, sep)
        block = _BLOCK.match(words)
        if block:
            first = int(block.group(1))
            continue
        if _SUMMARY.match(words):
            summary = no
            break
        cells = _cells(line, sep)
        try:
            frame = int(float(cells[0]))
        except (ValueError, OverflowError, IndexError):   # not a number, inf/nan, or no cell (no frame)
            fail(path, no, f"expected a frame number and {per_block} track(s) of X, Y, Flag, found "
                           f"{line.strip()[:60]!r}")
        for k in range(per_block):
            x, y, flag = (cells + [""] * 3 * per_block)[1 + 3 * k:4 + 3 * k]
            if not y:
                continue          # the track was not found in this frame
            try:
                xv, yv = float(x), float(y)
            except ValueError:
                fail(path, no, f"track {first + k}: X {x!r}, Y {y!r} are no numbers")
            rows.setdefault(first + k, []).append((frame, xv, yv, flag == "*", no))
    if not rows:
        fail(path, header_no, "an MTrack2 export without positions (no track was found in any frame)")
    tracks = {}
    for n, found in sorted(rows.items()):
        found.sort()
        frames, xs, ys, flags, lines = (np.array(v) for v in zip(*found))
        tracks[n] = (frames.astype(float), xs.astype(float), ys.astype(float), flags.astype(bool),
                     lines.astype(int))
    return tracks, summary


def choose_track(path, tracks, track=None):
    """``(number, note)``: the track named by ``track`` (a number, or a string of one), or the one whose y
    spans most (the ball); a UsageError naming the tracks for one the file does not hold."""
    names = ", ".join(str(n) for n in tracks)
    if track is not None:
        try:
            n = int(str(track).strip())
        except ValueError:
            raise UsageError(f"{path}: an MTrack2 export's tracks are numbered ({names}); got {track!r}") from None
        if n not in tracks:
            raise UsageError(f"{path}: no track {n} in this MTrack2 export (tracks: {names})")
        how = "as asked"
    else:
        n = max(tracks, key=lambda k: (float(np.ptp(tracks[k][2])), -k))
        how = "the one that moves most up and down: the ball"
    if len(tracks) == 1:
        return n, f"track {n}, {tracks[n][0].size} frames"
    said = "; ".join(f"{k}: {v[0].size} frames, y {np.min(v[2]):.0f}-{np.max(v[2]):.0f} px" for k, v in tracks.items())
    return n, f"track {n} of {len(tracks)} ({how}; another: --sheet N); tracks {said}"


def parse(text, *, scale_m_per_px=None, y_down=True, fs_hz=None, track=None):
    path = text.path
    tracks, summary = read_tracks(text)
    n, which = choose_track(path, tracks, track)
    if fs_hz is None:
        raise UsageError(f"{path}: an MTrack2 export counts frames, not seconds: give the frame rate with --fs HZ")
    frames, x, y, flags, lines = tracks[n]
    notes = [f"format: ImageJ MTrack2 export, {which}"]
    if np.any(flags):
        notes.append(f"{int(flags.sum())} frame(s) of track {n} flagged '*' by MTrack2 (another object as close; "
                     f"it took the closest)")
    if summary is not None:
        notes.append(f"MTrack2's summary of the tracks (from line {summary}) skipped")
    cols = [Column(0, "frame", "", raw="Frame"), Column(1, "y", "px", raw=f"Y{n}"), Column(2, "x", "px", raw=f"X{n}")]
    rows = [(int(no), [f"{f:.17g}", f"{yv:.17g}", f"{xv:.17g}"]) for f, yv, xv, no in zip(frames, y, x, lines)]
    table = Table(text.lines[0][0], cols, rows, ",", False, [])
    return trajectory_from_table(path, table, scale_m_per_px=scale_m_per_px, y_down=True, fs_hz=fs_hz, notes=notes)
