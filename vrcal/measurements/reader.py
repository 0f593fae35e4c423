"""The one entry point of :mod:`vrcal.measurements`: :func:`read_measurement`, and the
registry of layouts :data:`FORMATS` (one reader module per layout, as pvlib's ``iotools``).
:func:`read_measurements` reads several files of one ball into :class:`Runs` for a joint fit.
Spreadsheets (``.xlsx``, ``.xls``) are read through :mod:`vrcal.measurements.excel` and then
parsed like any text table.
"""

from __future__ import annotations

import contextlib
import dataclasses
import hashlib
import os
from typing import Callable, NamedTuple

from vrcal.errors import DataError, UsageError
from vrcal.measurements import (
    apexes,
    audacity_labels,
    drops,
    excel,
    impacts,
    mtrack2,
    phyphox_collision,
    pixels_ref,
    sound,
    tracker,
    trajectory,
    vernier,
    video,
)
from vrcal.measurements.table import (
    TIME_NAMES,
    columns,
    fail,
    find_column,
    has_number,
    is_numeric_row,
    load_text,
    loose_cells,
    merge_two_row_header,
    merge_units_row,
    strip_cell,
    ungroup_thousands,
)
from vrcal.measurements.types import Runs
from vrcal.model.restitution import check_number

# --------------------------------------------------------------------------- registry and entry point


class Format(NamedTuple):
    """One file layout: ``detector(text) -> bool``, ``parser(text, **options) -> result``.

    A *recording* (``recording=True``: sound, video) is binary: ``detector(head, path)`` gets
    the file's first 64 bytes and its path, ``parser(path, **options)`` the path and every option.
    """

    detector: Callable
    parser: Callable
    description: str
    recording: bool = False


#: Known layouts, in auto-detection order (the first detector that accepts a file wins).
FORMATS = {
    "pixels-ref": Format(pixels_ref.detect, pixels_ref.parse,
                         "reference-length pixel file: line 1 'LENGTH_M;LENGTH_PX', then 'y_img;x_img;' per frame "
                         "(image y down; needs --fs)"),
    "audacity-labels": Format(audacity_labels.detect, audacity_labels.parse,
                              "Audacity label export (no header; 'start<TAB>end<TAB>text' per label): the labels' "
                              "starts are the impact times"),
    "vernier": Format(vernier.detect, vernier.parse,
                      "Vernier text export (Logger Pro 'Export As Text'): 'Vernier Format 2', a description, the data "
                      "set, long names, short names and/or units, then tab-separated numbers"),
    "mtrack2": Format(mtrack2.detect, mtrack2.parse,
                      "ImageJ MTrack2 export: header 'Frame, X1, Y1, Flag1, ...', a 'Tracks 1 to N' line, pixels with "
                      "image y down (needs --fs and --scale; --sheet N reads track N)"),
    "tracker": Format(tracker.detect, tracker.parse,
                      "Tracker data export: line 1 the track name (mass_A), then columns t, x, y "
                      "(tab, space, comma or semicolon)"),
    "phyphox-collision": Format(phyphox_collision.detect, phyphox_collision.parse,
                                "phyphox one-row export: (In)elastic collision ('Bounce 0 (s)', 'Height 0 (m)', "
                                "..., 'Bounce 5 (s)'; the impact times are read) or Acoustic Stopwatch "
                                "('Start (s)', 'Stop 1 (s)', ..., 'Stop 5 (s)')"),
    "drops": Format(drops.detect, drops.parse,
                    "drop table: one trial per row, drop and rebound heights ('H,h', 'drop,rebound'; m, cm, mm)"),
    "apexes": Format(apexes.detect, apexes.parse, "apex heights: header 'bounce,h' (bounce 0 = drop height, m)"),
    "trajectory": Format(trajectory.detect, trajectory.parse,
                         "trajectory: header 't,y' (s, m; x optional; units like 'y (cm)', 'y (px)' + --scale), "
                         "or two numeric columns without a header"),
    "impacts": Format(impacts.detect, impacts.parse,
                      "impact times: one column (any name or none), or a time column ('time', \"Event time (s)\")"),
    "sound": Format(sound.detect, sound.parse,
                    "a sound recording (WAV; m4a, mp3, ogg, flac with vrcal[audio]): the impact times", recording=True),
    "video": Format(video.detect, video.parse,
                    "a video (mp4, mov, avi, mkv; needs vrcal[video]): the ball's trajectory, scale from its "
                    "diameter", recording=True),
}

#: Options of the readers (``read_measurement(..., **options)``) and what a replay needs to read a
#: file again the same way (``vrcal discover`` writes them into its JSON).
READER_OPTIONS = ("scale_m_per_px", "y_down", "fs_hz", "sheet")
#: Options only the recording readers (sound, video) take.
RECORDING_OPTIONS = ("diameter_m", "roi", "color", "progress", "g_m_per_s2", "rotate")


def format_help():
    """One line per format, for ``--format`` help texts."""
    return "; ".join(f"{name}: {fmt.description}" for name, fmt in FORMATS.items())


def detect_format(path):
    """Name of the first format in :data:`FORMATS` whose detector accepts the file (or the table below
    its title lines)."""
    name = _detect_recording(path)
    if name is not None:
        return name
    excel.check_workbook_name(path, _text_layout)
    return _detect_below_title(_units_into_header(_load(path))[0])[1]


def _text_layout(path):
    """The format the text file ``path`` reads as (detected), or None (a file named as a workbook that is text:
    the error names it for ``--format``)."""
    try:
        return _detect_below_title(_units_into_header(load_text(path))[0])[1]
    except (DataError, UsageError):
        return None


#: Largest input read from a pipe, a FIFO or stdin ('-') [bytes] (a phone's video of a drop is tens of MB).
MAX_STREAM_BYTES = 2 << 30


@contextlib.contextmanager
def spooled(path):
    """A path that can be opened more than once for the input ``path``.

    A regular file (or a device) is itself. stdin (``-``), a FIFO or a pipe (``/dev/stdin``) can be read once
    only, and a recording is opened several times (its first bytes tell its format, then a
    decoder reads it): its bytes (at most :data:`MAX_STREAM_BYTES`) are copied once into a
    temporary file of the same name, removed afterwards. An error about the copy names ``path``.

    Yields
    ------
    str
        the path to read
    """
    import stat
    import sys
    import tempfile

    path = str(path)
    try:
        piped = path == "-" or stat.S_ISFIFO(os.stat(path).st_mode)
    except OSError:
        piped = False    # the reader says what is wrong
    if not piped:        # a regular file, or a device (/dev/zero: the readers' size limits apply)
        yield path
        return
    name = "stdin" if path == "-" or os.path.basename(path) == "stdin" else os.path.basename(path)
    with tempfile.TemporaryDirectory(prefix="vrcal-") as tmp:
        copy = os.path.join(tmp, name)
        try:
            with (open(path, "rb") if path != "-" else contextlib.nullcontext(sys.stdin.buffer)) as src, \
                    open(copy, "wb") as dst:
                n = 0
                while chunk := src.read(1 << 20):
                    n += len(chunk)
                    if n > MAX_STREAM_BYTES:
                        raise DataError(f"{path}: more than {MAX_STREAM_BYTES >> 30} GiB; save it to a file")
                    dst.write(chunk)
        except OSError as exc:
            raise DataError(f"{path}: cannot read: {exc.strerror or exc}") from None
        try:
            yield copy
        except (DataError, UsageError) as exc:
            raise type(exc)(str(exc).replace(copy, path)) from None


def _detect_recording(path):
    """The recording format (sound, video) a file's first bytes or its name show, or None."""
    try:
        if os.path.exists(path) and not os.path.isfile(path):
            head = b""  # a FIFO or a device is read once, by load_text: no peeking (only the name tells)
        else:
            with open(path, "rb") as fh:
                head = fh.read(64)
    except OSError:
        return None  # load_text reports it
    for name, fmt in FORMATS.items():
        if fmt.recording and fmt.detector(head, str(path)):
            return name
    return None


#: What the first character of a file that is no table shows it to be.
_DOCUMENTS = {"{": "a JSON document (a 'vrcal discover --json' result, an export?)",
              "[": "a JSON document", "<": "an XML or HTML document (a MuJoCo or Gazebo export, a web page?)"}


#: XML files of the programs whose text export vrcal reads: (what the document holds, file name ending, the
#: program's step to that export and the section of docs/measurements.md on it). A Tracker project's root
#: object is of class org.opensourcephysics.cabrillo.tracker.TrackerPanel; a Logger Pro file's columns are
#: <DataColumn> elements.
_PROGRAM_DOCUMENTS = (
    (("org.opensourcephysics.cabrillo.tracker",), ".trk", "a Tracker project",
     "in Tracker, File > Export > Data writes the track's table, which vrcal reads (docs/measurements.md, "
     "'Tracker')"),
    (("<datacolumn", "<dataobjectname"), ".cmbl", "a Logger Pro file",
     "in Logger Pro, File > Export As > Text writes its table, which vrcal reads (docs/measurements.md, "
     "'Vernier')"),
)


def _program_document(text):
    """What to do with the XML file of a program whose text export vrcal reads (:data:`_PROGRAM_DOCUMENTS`),
    by its content or its name: one line, or None."""
    head = " ".join(s for _, s in text.lines[:40]).lower()
    name = str(text.path).lower()
    for marks, ending, what, fix in _PROGRAM_DOCUMENTS:
        if name.endswith(ending) or any(m in head for m in marks):
            return f"{what} ({ending}, XML), not its data: {fix}"
    return None


#: Most title lines above a table's header (a class's sheet: the experiment, the group, the date).
MAX_TITLE_LINES = 5


def _detect(text, below=None):
    """(text, name): the first format of :data:`FORMATS` whose detector accepts ``below`` (the text under
    its title lines, when given) or, tried next by the same format, ``text``; an error naming the header
    otherwise."""
    no, line = text.lines[0]
    what = _DOCUMENTS.get(line.lstrip()[:1])
    if what is None and any(s.startswith("schema_version:") for _, s in text.lines):
        what = "a YAML document of vrcal (a 'vrcal fit' or 'vrcal discover' result, an export?)"
    if what is not None and line.lstrip().startswith("<"):
        program = _program_document(text)
        if program is not None:
            fail(text.path, no, program)
    if what is not None:
        fail(text.path, no, f"{what}, not a measurement: give the measured file (a table of times, "
                            f"heights or positions, a sound or a video; docs/measurements.md)")
    for name, fmt in FORMATS.items():
        if fmt.recording:
            continue
        if below is not None and fmt.detector(below):
            return below, name
        if fmt.detector(text):
            return text, name
    audacity_labels.explain(below or text)   # a label export with a bad line: name that line
    if below is not None:
        no, line = below.lines[0]
    if is_numeric_row(loose_cells(line)) or is_numeric_row(line.split()):   # commas, semicolons, tabs or blanks
        fail(text.path, no, drops.no_header_message(drops.headerless_hint(below or text)))
    if drops.transposed(below or text) is not None:   # a class's sheet with the trials side by side
        fail(text.path, no, drops.transposed_hint(below or text))
    if drops.looks_like_heights(below or text):   # the known formats' list would push the hint past a line
        fail(text.path, no, f"cannot tell the layout from the header {line.strip()!r}: for drop and rebound "
                            f"heights, {drops.NAMING} (other layouts: see --format)")
    fail(text.path, no, f"cannot tell the layout from the header {line.strip()!r} "
          f"(known formats: {', '.join(FORMATS)}; see --format)")


def _title_lines(text):
    """How many lines (up to :data:`MAX_TITLE_LINES`) above the header are a title: each with no number in
    it, above a header with no number and a number in the line below it; the header has two or more cells
    and each title line fewer, or the header is one cell naming a time column (``"Event time (s)"``: a
    one-column file of impact times, whose title cannot have fewer cells). 0 when the file does not start
    so (a JSON or XML document never does)."""
    lines = text.lines
    if lines[0][1].lstrip()[:1] in _DOCUMENTS:
        return 0
    for k in range(1, min(MAX_TITLE_LINES, len(lines) - 2) + 1):
        if has_number(lines[k - 1][1]):
            return 0
        header = loose_cells(lines[k][1])
        if has_number(lines[k][1]) or not has_number(lines[k + 1][1]):
            continue
        if len(header) >= 2 and all(len(loose_cells(s)) < len(header) for _, s in lines[:k]):
            return k
        if len(header) == 1 and _names_time(lines[k][1]):
            return k
    return 0


def _names_time(line):
    """True when ``line`` is one header cell naming a time column (``t``, ``time``, ``Event time (s)``)."""
    cols = columns([strip_cell(line)])
    return find_column(cols, TIME_NAMES, contains="time") is not None


def read_measurement(path, fmt=None, **options):
    """Read a measurement file into a Trajectory, ImpactTimes, ApexHeights or Runs.

    Parameters
    ----------
    path : str or Path
        the file to read (a text table, or an .xlsx/.xls workbook)
    fmt : str or None
        a key of :data:`FORMATS`; None detects it from the file
    **options
        ``scale_m_per_px`` (float or None): metres per unit of the file's position column
        (pixels); overrides the header unit and the reference line of a ``pixels-ref`` file
        [m/px]; ``y_down`` (bool): the file's y axis points down (image rows): height = -y *
        scale; ``fs_hz`` (float or None): sampling (frame) rate for files without a time
        column [Hz] (for a video, the frame rate overriding the container's time
        stamps: a slow-motion video); ``sheet`` (str or None): the sheet of a workbook (default: phyphox's
        ``All``, else the first with a table)
        Recordings (sound, video) also take ``diameter_m`` (video: the ball's diameter [m], which
        gives the scale), ``roi``, ``color``, ``rotate``, ``g_m_per_s2`` (the g that scales a video from
        its flights; :func:`vrcal.measurements.video.track_video`) and ``progress`` (a callable
        ``progress(fraction, message)``); the text layouts ignore them.

    Returns
    -------
    Trajectory or ImpactTimes or ApexHeights or Runs
        ``.kind`` is "trajectory", "impacts" or "apexes"; a drop table (one trial per row)
        gives :class:`Runs` of ApexHeights.

    Raises
    ------
    DataError
        "FILE:LINE: what is wrong" for an unreadable, empty, binary or malformed file.
    UsageError
        an unknown ``fmt`` (the message names the known ones), a missing ``fs_hz`` or
        ``scale_m_per_px`` that the file needs, a workbook without its reader library.
    """
    if fmt is not None and fmt not in FORMATS:
        raise UsageError(f"unknown measurement format '{fmt}' (known: {', '.join(FORMATS)})")
    unknown = sorted(set(options) - set(READER_OPTIONS) - set(RECORDING_OPTIONS))
    if unknown:
        raise UsageError(f"unknown reader option(s) {', '.join(unknown)} (known: {', '.join(READER_OPTIONS)})")
    for key, what, unit in (("fs_hz", "--fs", "[Hz]"), ("scale_m_per_px", "--scale", "[m/px]")):
        if options.get(key) is not None:
            options[key] = check_number(options[key], what, unit=unit)
    name = fmt or _detect_recording(path)
    if name is not None and FORMATS[name].recording:
        passed = {k: v for k, v in options.items() if k not in ("y_down", "sheet") and v is not None}
        return FORMATS[name].parser(str(path), **passed)
    video_only = [flag for flag, key in (("--rotate", "rotate"), ("--roi", "roi"), ("--color", "color"))
                  if options.get(key)]
    for key in RECORDING_OPTIONS:
        options.pop(key, None)
    sheet = options.pop("sheet", None)
    if fmt is None:
        excel.check_workbook_name(path, _text_layout)   # a CSV named .xlsx: say so, not 'header but no data rows'
    container = excel.container_kind(path) in ("xlsx", "xls", "zip")
    text = _load(path, sheet if container else None)
    parsed = {k: v for k, v in options.items() if v is not None}
    parsed.setdefault("y_down", False)
    try:
        data, text, title, units_note = _read_text(path, text, name, fmt, parsed, sheet, container)
    except (DataError, UsageError):
        found = None if sheet is not None else _below_preamble(text, fmt, parsed)
        if found is None:
            raise
        data, text, title, units_note = found
    kind = data.runs[0].kind if isinstance(data, Runs) else data.kind
    unused = [flag for flag, key in (("--fs", "fs_hz"), ("--scale", "scale_m_per_px"), ("--y-down", "y_down"))
              if options.get(key) and kind != "trajectory"]
    if unused:
        data = dataclasses.replace(data, notes=tuple(data.notes) + (
            f"{', '.join(unused)} ignored: {'they apply' if len(unused) > 1 else 'it applies'} to trajectories, "
            f"and this file holds {kind}",))
    if video_only:
        data = dataclasses.replace(data, notes=tuple(data.notes) + (
            f"{', '.join(video_only)} ignored: {'they apply' if len(video_only) > 1 else 'it applies'} to videos",))
    said = [_title_note(title) if title is not None else None, units_note, *text.notes]
    if any(said):
        data = dataclasses.replace(data, notes=tuple(n for n in said if n) + tuple(data.notes))
    return data


def _read_text(path, text, name, fmt, parsed, sheet, container):
    """``(data, text, title, units_note)`` of a loaded text: its units row or two-row header merged, its
    format ``name`` (``fmt``, or detected below its title lines) and its parser's result."""
    title = None
    text, units_note = _units_into_header(text, name)
    if name is None:
        text, name, title = _detect_below_title(text)
    elif not FORMATS[name].recording:
        text, title = _below_title_for(FORMATS[name], text)
    if sheet is not None and not container:
        if name != "mtrack2":
            raise UsageError(f"{path}: --sheet applies to .xlsx/.xls workbooks, zip archives and MTrack2 exports "
                             f"(a track's number) only")
        parsed = {**parsed, "track": sheet}
    return _parse(FORMATS, name, text, parsed, given=fmt is not None), text, title, units_note


#: Most lines of a header above the first rows of numbers under a preamble (a Vernier text export's five).
MAX_HEADER_LINES = 6


def _below_preamble(text, fmt, options):
    """``(data, text, title, note)`` of a table under a preamble that no reader takes for a title (an Arduino
    sketch's banner of asterisks and prose copied from the Serial Monitor above its 'Vernier Format 2' header):
    its header found as the line(s) just above the first rows of numbers -- the nearest start above them that
    a reader reads (format ``fmt``, or detected) at a header of two cells or more or naming a time column, as
    for a title (:func:`_title_lines`), ``note`` naming the lines skipped; None when there is no such preamble
    or no start reads."""
    lines = text.lines
    numeric = [is_numeric_row(loose_cells(s)) or is_numeric_row(s.split()) for _, s in lines]
    first = next((i for i in range(1, len(lines) - 1) if numeric[i] and numeric[i + 1]), None)
    if first is None or first < 2 or any(numeric[:first]):
        return None
    for k in range(first - 1, max(0, first - MAX_HEADER_LINES - 1), -1):
        if len(loose_cells(lines[k][1])) < 2 and not _names_time(lines[k][1]):
            continue   # a one-column file's header above is its own, unless it names a time (_title_lines)
        below = dataclasses.replace(text, lines=lines[k:], notes=())
        try:
            below, units_note = _units_into_header(below, fmt)
            name, title = fmt, None
            if fmt is None:
                below, name, title = _detect_below_title(below)
            data = FORMATS[name].parser(below, **options)
        except (DataError, UsageError):
            continue
        shown = lines[0][1].strip()
        shown = shown if len(shown) <= 40 else shown[:37] + "..."
        where = f"line {lines[0][0]}" if k == 1 else f"lines {lines[0][0]}-{lines[k - 1][0]}"
        note = f"{where} above the header (line {lines[k][0]}) skipped: a preamble ('{shown}'{' ...' if k > 1 else ''})"
        return data, dataclasses.replace(below, notes=text.notes), title, "; ".join(
            n for n in (note, units_note) if n)
    return None


def _parse(formats, name, text, options, given):
    """``formats[name].parser(text, **options)``; when the format was given (``--format``) and its parser
    refuses a file another format reads, the error says which (an MTrack2 export read as a Tracker one was
    told '7 cells but the header names 4 columns'). Another format is named only when its parser reads the
    file: one whose detector takes it but whose parser refuses it would send the user from one refusal to
    another."""
    try:
        return formats[name].parser(text, **options)
    except DataError as exc:
        if not given:
            raise
        other = next((o for o, fmt in formats.items() if o != name and not fmt.recording and fmt.detector(text)
                      and _reads(fmt, text, options)), None)
        if other is None:
            raise
        raise DataError(f"{exc} (the file reads as {other}: --format {other})") from None


def _reads(fmt, text, options):
    """Does the format's parser read ``text`` (with the reader options given)?"""
    try:
        fmt.parser(text, **options)
    except (DataError, UsageError):
        return False
    return True


def _load(path, sheet=None):
    """The :class:`Text` of a text file, of a workbook's sheet or of a zip archive's table (``sheet`` names
    which)."""
    kind = excel.container_kind(path)
    if kind in ("xlsx", "xls"):
        return excel.load_sheet_text(path, sheet)
    if kind == "zip":
        return excel.load_archive_text(path, sheet)
    if sheet is not None:
        raise UsageError(f"{path}: --sheet applies to .xlsx/.xls workbooks and zip archives only")
    return load_text(path)


def _units_into_header(text, name=None):
    """``(text, note)``: a units row below the header written into it (:func:`merge_units_row`), except in
    a Vernier export, whose reader joins its own names and units; else a header of two rows written as one
    (:func:`merge_two_row_header`); thousands grouped by '.' ungrouped (:func:`ungroup_thousands`; the notes
    joined)."""
    text, grouped = ungroup_thousands(text)
    if name == "vernier" or (name is None and vernier.detect(text)):
        return text, grouped
    text, units = merge_units_row(text, MAX_TITLE_LINES)
    if units is None:
        text, units = merge_two_row_header(text, MAX_TITLE_LINES)
    return text, "; ".join(n for n in (units, grouped) if n) or None


def _below_title_for(fmt, text):
    """``(text, title)``: the text below its title lines (:func:`_title_lines`) when the format given
    (``--format``) reads that and not the whole text (a Tracker export's track name above its columns is
    no title), else ``(text, None)``."""
    k = _title_lines(text)
    if not k:
        return text, None
    below = dataclasses.replace(text, lines=text.lines[k:])
    if fmt.detector(below) and not fmt.detector(text):
        return below, text.lines[:k]
    return text, None


def _title_note(title):
    """The note of the title lines ``[(lineno, line)]`` skipped above a table's header."""
    said = ", ".join(repr(line.strip().rstrip(",;\t ")) for _, line in title)   # a sheet's empty cells after it
    if len(title) == 1:
        return f"line {title[0][0]} {said} is a title: skipped"
    return f"lines {title[0][0]}-{title[-1][0]} ({said}) are a title: skipped"


def _detect_below_title(text):
    """(text, format, title): the format of ``text``, or of the text below its title lines (a class's sheet
    starts with 'Ball bounce lab - group 3' above its header): each format in :data:`FORMATS` order tries
    the text below the title, then the whole text (a Tracker export's first line, its track's name, looks
    like a title, and the Tracker format reads it). Title lines are those of :func:`_title_lines`, or else
    one line above a header no format reads as it is ('Golf ball, 1 m, group 3' above 't,y'); title is
    [(lineno, line)] or None."""
    k = _title_lines(text)
    if k:
        found, name = _detect(text, dataclasses.replace(text, lines=text.lines[k:]))
        return found, name, (text.lines[:k] if found is not text else None)
    try:
        return (*_detect(text), None)
    except DataError:
        if len(text.lines) < 3 or text.lines[0][1].lstrip()[:1] in _DOCUMENTS:
            raise
        if is_numeric_row(loose_cells(text.lines[0][1])) or is_numeric_row(loose_cells(text.lines[1][1])) \
                or audacity_labels.starts_as_labels(text):   # a label line is no title
            raise
        below = dataclasses.replace(text, lines=text.lines[1:])
        try:
            return (*_detect(below), text.lines[:1])
        except DataError:
            pass
        raise


def read_measurements(paths, fmt=None, **options):
    """Read several files of one ball into :class:`Runs` (one file: what :func:`read_measurement` gives).

    Every file is read with the same ``fmt`` and ``options``; a file that is itself several runs
    (a drop table) adds all of them. The runs must be of one kind (a joint fit compares data of
    one unit).

    Raises
    ------
    UsageError
        files of different kinds; a file given twice (the same resolved path): its data would count
        twice and shrink every uncertainty (files of identical content are kept, with a note)
    """
    paths = [str(p) for p in paths]
    if len(paths) == 1:
        return read_measurement(paths[0], fmt, **options)
    runs, labels, notes = [], [], _repeated_files(paths)
    for path in paths:
        data = read_measurement(path, fmt, **options)
        if isinstance(data, Runs):
            runs += list(data.runs)
            labels += [f"{path} {label}" for label in data.labels]
            notes += [f"{path}: {n}" for n in data.notes]
        else:
            runs.append(data)
            labels.append(path)
    kinds = sorted({r.kind for r in runs})
    if len(kinds) > 1:
        names = {k: sorted({lab.split(" ")[0] for r, lab in zip(runs, labels) if r.kind == k}) for k in kinds}
        by_kind = "; ".join(f"{k}: {', '.join(names[k])}" for k in kinds)
        raise UsageError(f"a joint fit needs files of one kind, got {' and '.join(kinds)} ({by_kind}): "
                         "run them separately")
    return Runs(runs=tuple(runs), source=", ".join(paths), notes=tuple(notes), labels=tuple(labels))


def _repeated_files(paths):
    """Notes on files of identical content among ``paths``, after raising :class:`UsageError` when one file
    is given twice (the same resolved path): a joint fit would count its data twice, shrink every
    uncertainty and take its rows for repeated trials. Two files of one content are kept (trials read off a
    video's frame grid repeat to the frame), with a note in case one is a copy."""
    seen, by_path, notes = {}, {}, []
    for path in paths:
        real = os.path.realpath(path)
        if real in by_path:
            same = "given twice" if path == by_path[real] else f"the same file as {by_path[real]}"
            raise UsageError(f"{path} is {same}: give each file once (a file given twice counts its data twice "
                             "and shrinks every uncertainty)")
        by_path[real] = path
        try:
            with open(path, "rb") as fh:
                key = hashlib.sha256(fh.read()).hexdigest()
        except OSError:
            continue   # the reader says what is wrong with it
        if key in seen:
            notes.append(f"{path} has the same content as {seen[key]}: fitted as a repeated trial (if it is a "
                         "copy, give it once: it counts twice and shrinks every uncertainty)")
        else:
            seen[key] = path
    return notes
