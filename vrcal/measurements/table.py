"""Reading text tables as people write them: loading, separators, decimal commas, headers,
column names with units, and line-accurate errors.

Every reader module of :mod:`vrcal.measurements` parses its file through these helpers, so
a malformed file gives the same one-line message ``FILE:LINE: what is wrong``
(:class:`vrcal.errors.DataError`) whatever its layout.
"""

from __future__ import annotations

import csv
import dataclasses
import io
import re
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import NamedTuple

import numpy as np

from vrcal.errors import DataError
from vrcal.fileio import MAX_TEXT_BYTES, read_bytes_bounded

_NUMBER_WITH_DECIMAL_COMMA = re.compile(r"^[+-]?\d*,\d+([eE][+-]?\d+)?$")
_NAME_UNIT = re.compile(r"^(?P<name>.*?)\s*(?:[\(\[](?P<unit>[^\)\]]*)[\)\]])?$")

#: Time columns named after the clock that wrote them, and their unit: an Arduino sketch's ``millis()`` and
#: ``micros()`` (``millis,distance_cm``).
CLOCK_UNITS = {"millis": "ms", "micros": "us"}
#: Names of a time column; a class writes its own language's word too (Zeit, temps, tiempo, tempo, tijd: Coach's
#: ``Tijd (s)``).
TIME_NAMES = ("t", "time", "timestamp", "time stamp", "event time", "impact time", "time of impact", "collision time",
              "zeit", "aufprallzeit", "ereigniszeit", "temps", "tiempo", "tempo", "tijd", *CLOCK_UNITS)
#: Names of a trajectory's height column (a motion sensor's "Position (m)" or "Distance", a video tracker's
#: "height" and a 3D tracker's "z" too; a class's own language: Höhe, Abstand, Weg, hauteur, altura, altezza,
#: hoogte, afstand, positie; CASSY Lab's distance channels ``s_A1``, ``s_B1``, of its inputs A1 and B1; the first
#: of them in the file's column order is taken).
Y_NAMES = ("y", "height", "h", "position", "y position", "vertical position", "distance", "z",
           "höhe", "hoehe", "abstand", "weg", "hauteur", "altura", "altezza", "hoogte", "afstand", "positie",
           "s a1", "s b1")
#: How a failing look-up tells the columns may be named (``--format trajectory`` on a file without them).
Y_NAMING = "'y', 'height', 'position', 'z', 'Höhe', 'hauteur', 'altura', 'altezza' or 'hoogte'"
TIME_NAMING = "'t', 'time', 'timestamp', 'Zeit', 'temps', 'tiempo', 'tempo' or 'tijd'"
#: Names of a frame-number column (times = frame / --fs when the file has no time column).
FRAME_NAMES = ("frame", "frames", "frame number", "frame no", "frame index")
X_NAMES = ("x",)
BOUNCE_NAMES = ("bounce", "n", "bounce number")
H_NAMES = ("h", "height", "apex", "apex height")
TIME_UNITS = {"": 1.0, "s": 1.0, "sec": 1.0, "ms": 1e-3, "us": 1e-6}
#: Length units [m per unit], the one table every reader takes them from: metric, and the inches and feet
#: a US class measures in; pixels (None) need ``--scale``.
LENGTH_UNITS = {"": 1.0, "m": 1.0, "cm": 1e-2, "mm": 1e-3, "in": 0.0254, "inch": 0.0254, "inches": 0.0254,
                "ft": 0.3048, "foot": 0.3048, "feet": 0.3048, "px": None, "pixel": None, "pixels": None}


#: Units written out, in English, German or French, and their symbol (``Drop height in centimetres``,
#: ``h [Zentimeter]``); a trailing full stop is dropped too (``(in.)``, ``(cm.)``).
UNIT_SPELLINGS = {
    **dict.fromkeys(("meter", "meters", "metre", "metres", "mètre", "mètres"), "m"),
    **dict.fromkeys(("centimeter", "centimeters", "centimetre", "centimetres", "zentimeter", "centimètre",
                     "centimètres"), "cm"),
    **dict.fromkeys(("millimeter", "millimeters", "millimetre", "millimetres", "millimètre", "millimètres"), "mm"),
    **dict.fromkeys(("second", "seconds", "sekunde", "sekunden", "seconde", "secondes", "secs"), "s"),
    **dict.fromkeys(("millisecond", "milliseconds", "millisekunde", "millisekunden", "milliseconde",
                     "millisecondes"), "ms"),
    "zoll": "in", "pouce": "in", "pouces": "in",
}


def unit_symbol(unit):
    """The symbol of a unit as written (lower case): ``centimetres`` -> ``cm``, ``in.`` -> ``in``."""
    unit = unit.strip().lower()
    unit = unit[:-1] if unit.endswith(".") and len(unit) > 1 else unit
    return UNIT_SPELLINGS.get(unit, unit)


def known_units(units):
    """The units of a unit table for an error message (``m, cm, mm, in, ...``)."""
    return ", ".join(u for u in units if u)

#: Units of other quantities a table's units row may name beside times and lengths (a velocity, an
#: acceleration, an angle, a force, a mass, a level, a ratio; ``-`` for a number without a unit).
_OTHER_UNIT = re.compile(r"^(?:(?:m|cm|mm|ft|in)/s(?:\^?2|²)?|deg|°|rad|n|kg|g|j|hz|db|%|-)$")


def unit_of_cell(cell):
    """The unit a cell of a units row names, as :func:`unit_symbol` writes it (``cm``, ``(cm)``, ``[s]``,
    ``metres``, ``m/s``), or None when the cell is no unit."""
    c = strip_cell(cell)
    if len(c) >= 2 and c[0] in "([" and c[-1] in ")]":
        c = c[1:-1].strip()
    symbol = unit_symbol(c)
    if symbol and (symbol in TIME_UNITS or symbol in LENGTH_UNITS or _OTHER_UNIT.match(symbol)):
        return symbol
    return None


#: A unit written after the name instead of in brackets: ``t_s``, ``y_cm``, ``t/s`` (quantity / unit,
#: ISO 80000-1), ``height in mm``; only a unit of the tables above counts (``bounce_no`` keeps its name),
#: and not ``in`` (``y_in`` keeps its name: inches are ``y (in)``, ``y_inch``, ``height in inches``).
_SUFFIX_UNIT = re.compile(r"^(?P<name>.*?[^\s_/])(?:\s*/\s*|_|\s+in\s+)(?P<unit>[A-Za-z]+)$")
_SUFFIX_UNITS = ({u for u in (*TIME_UNITS, *LENGTH_UNITS) if u} | set(UNIT_SPELLINGS)) - {"in"}

#: The data set's name before a column's in a Vernier (Logger Pro, Graphical Analysis) export:
#: ``Run 1: Time (s)``, ``Latest: Position (m)``.
_DATA_SET = re.compile(r"^(?P<set>[^:()\[\]]{1,40}):\s+(?=\S)")
#: ... or after it, in a PASCO (Capstone, SPARKvue) export: ``Time (s) Run #1``, ``Position (m) Run 2`` (a run's
#: number after the unit; ``Run #N`` after a name without one too).
_RUN_AFTER = re.compile(r"(?:(?<=[)\]])\s*|\s+(?=run\s*#))(?P<set>run\s*#?\s*\d+)$", re.IGNORECASE)


class Column(NamedTuple):
    index: int
    name: str      # lower case, runs of blanks and '_' as one blank
    unit: str      # lower case, from brackets: 't (ms)', 'y [cm]'
    raw: str = ""  # the name as written (case kept: 'H' and 'h' differ in a drop table)
    data_set: str = ""  # the data set's name before it, as written ('Run 2' of 'Run 2: Time (s)')


@dataclass
class Text:
    """A file's non-blank lines with their 1-based line numbers."""

    path: str
    lines: list  # [(lineno, text)]
    multi: bool = False  # a Tracker '#multi:' export
    meta: dict = field(default_factory=dict)  # {key: (lineno, text)} of '# vrcal KEY = VALUE' comments
    notes: tuple = ()  # what loading did (rows of empty cells skipped, the member of an archive read)


#: A comment line carrying what a reader of the file should know (``vrcal track`` writes the tracker's
#: uncertainties so: ``# vrcal systematic_m = 0.00013``).
_META = re.compile(r"^#\s*vrcal\s+([a-z_]+)\s*=\s*(\S.*?)\s*$")


def fail(path, line, what):
    where = f"{path}:{line}" if line else f"{path}"
    raise DataError(f"{where}: {what}")


def load_text(path):
    """The non-blank lines of a text file (:class:`Text`); UTF-8 (a BOM allowed), UTF-16 with its BOM (Excel's
    "Unicode Text") or Latin-1."""
    path_s = str(path)
    try:
        raw = read_bytes_bounded(Path(path), MAX_TEXT_BYTES, "measurement")
    except IsADirectoryError:
        raise DataError(f"{path_s}: is a directory, not a measurement file") from None
    except OSError as exc:
        raise DataError(f"{path_s}: cannot read: {exc.strerror or exc}") from None
    return text_from_bytes(path_s, raw)


#: What a binary file that is no table is told.
BINARY = "binary file, not a text table (save it as CSV or text, UTF-8)"


def text_from_bytes(path_s, raw):
    """:class:`Text` of the bytes ``raw`` of the file (or archive member) ``path_s`` (see :func:`load_text`)."""
    if raw[:2] in (b"\xff\xfe", b"\xfe\xff"):   # UTF-16 with its byte order mark (Excel's "Unicode Text")
        try:
            raw = raw.decode("utf-16").encode("utf-8")
        except UnicodeDecodeError:
            fail(path_s, 0, BINARY)
    if not raw.strip():
        fail(path_s, 0, "empty file")
    if raw[:4] == b"PK\x03\x04":
        fail(path_s, 0, "a zip archive: unzip it and give the CSV inside (phyphox: 'All.csv')")
    if b"\x00" in raw[:8192]:
        fail(path_s, 0, BINARY)
    try:
        text = raw.decode("utf-8-sig")
    except UnicodeDecodeError:
        text = raw.decode("latin-1")
    printable = sum(ch.isprintable() or ch in "\r\n\t" for ch in text[:4096])
    if printable < 0.95 * len(text[:4096]):
        fail(path_s, 0, BINARY)
    lines, multi, meta, empty = [], False, {}, []
    for i, line in enumerate(text.splitlines(), start=1):
        if _EMPTY_ROW.match(line):   # ',,' or ';;': a row of empty cells, as Excel and LibreOffice save them
            empty.append(i)
            continue
        first = line[:1]
        if first in ("#", "") or first.isspace():   # a comment or blank line, perhaps indented
            stripped = line.strip()
            if not stripped:
                continue
            if stripped.startswith("#"):
                multi = multi or stripped.lower().startswith("#multi")
                found = _META.match(stripped)
                if found:
                    meta[found.group(1)] = (i, found.group(2))
                continue
        lines.append((i, line))
    if not lines:
        fail(path_s, 0, "no data (only comments, blank lines or rows of empty cells)")
    return Text(path_s, lines, multi, meta, empty_rows_notes(empty, lines))


#: A line of empty cells: separators and blanks only (at least one separator).
_EMPTY_ROW = re.compile(r"^[ \t]*[,;\t][ \t,;]*$")


def empty_rows_notes(numbers, lines):
    """``(note,)`` naming the rows of empty cells (line ``numbers``) skipped inside a table of ``lines``
    ([(lineno, text)]), or ``()``: those before or after it are a spreadsheet's formatted but empty
    cells, not worth a note."""
    rows = [n for n in numbers if lines and lines[0][0] < n < lines[-1][0]]
    if not rows:
        return ()
    return (f"{said_lines(rows)}: a row of empty cells, skipped" if len(rows) == 1
            else f"{said_lines(rows)}: {len(rows)} rows of empty cells, skipped",)


def said_lines(numbers, most=8):
    """``'line 51'``, ``'lines 51, 77, 102'``: the file's line ``numbers`` for a note, the first ``most`` of
    them (``, ...`` after)."""
    numbers = [int(n) for n in numbers]
    said = ", ".join(str(n) for n in numbers[:most]) + (", ..." if len(numbers) > most else "")
    return f"line {said}" if len(numbers) == 1 else f"lines {said}"


def meta_length(text, key, limit_m=1.0):
    """A length [m] from a ``# vrcal KEY = VALUE`` comment of ``text`` (0 when absent); a value that is
    not a number in [0, ``limit_m``] is an error naming its line."""
    return meta_number(text, key, limit_m, "a length in m")


def meta_number(text, key, limit, what):
    """A number from a ``# vrcal KEY = VALUE`` comment of ``text`` (vrcal's own writers put the uncertainties
    of what they tracked there), 0 when absent; one that is not in [0, ``limit``] is an error naming its line
    and ``what`` it should be ('a time in s')."""
    if key not in text.meta:
        return 0.0
    line, raw = text.meta[key]
    value = to_float(raw, False)
    if value is None or not (0.0 <= value <= limit):
        fail(text.path, line, f"'{key} = {raw}': give {what} between 0 and {limit:g}")
    return float(value)


def strip_cell(cell):
    cell = cell.strip()
    if len(cell) >= 2 and cell[0] == cell[-1] and cell[0] in "\"'":
        cell = cell[1:-1].strip()
    return cell


def sniff(header, sample):
    """Separator (',', ';', '\\t', ' ' for whitespace runs, or None for one column) and decimal comma."""
    everything = [header] + sample
    if any("\t" in s for s in everything):
        sep = "\t"
    elif any(";" in s for s in everything):
        sep = ";"
    elif "," in unquoted(header):
        sep = ","
    elif len(unquoted(header).split()) > 1 and sample and all(
            len(s.split()) == len(unquoted(header).split()) for s in sample):
        sep = " "
    else:
        sep = None
    # with comma separators only a quoted cell can hold a comma ('"0,52"': Google Sheets' CSV in a decimal-comma
    # locale), and split_cells keeps it whole
    decimal_comma = any(_NUMBER_WITH_DECIMAL_COMMA.match(strip_cell(c)) for s in sample for c in split_cells(s, sep)
                        if sep != "," or '"' in s)
    return sep, decimal_comma


def unquoted(text):
    return re.sub(r'"[^"]*"', "", text)


def loose_cells(line):
    """The non-blank cells of a line split at any comma, semicolon or tab outside double quotes (before the
    separator is known: is a first line numbers, or a title?)."""
    return [strip_cell(c) for c in _LOOSE_SEPARATOR.split(line) if c.strip()]


#: A comma, semicolon or tab outside double quotes ('"0,52","0,61"' is two cells).
_LOOSE_SEPARATOR = re.compile(r'[,;\t](?=(?:[^"]*"[^"]*")*[^"]*$)')


def split_cells(line, sep):
    if sep is None:
        cells = [line]
    elif sep == " ":
        cells = line.split()
    elif sep == "\t":
        cells = line.strip("\r\n ").split("\t")
    elif '"' in line:   # quoted cells may hold the separator ('"0,52"' in a comma-separated file)
        cells = next(csv.reader([line], delimiter=sep, skipinitialspace=True))
    else:
        cells = line.split(sep)
    cells = [strip_cell(c) for c in cells]
    while cells and cells[-1] == "":
        cells.pop()  # a trailing delimiter
    return cells


def to_float(cell, decimal_comma):
    """A cell as a float, or None when it is not a number."""
    text = cell.replace(",", ".") if decimal_comma else cell
    if "_" in text:
        return None
    try:
        return float(text)
    except ValueError:
        return None


def is_numeric_row(cells, decimal_comma=True):
    return bool(cells) and all(to_float(c, decimal_comma) is not None for c in cells)


def columns(cells):
    """The :class:`Column` of each header cell: its name and its unit, from brackets (``t (s)``,
    ``y [cm]``) or written after the name (``t_s``, ``t/s``, ``height in mm``, see ``_SUFFIX_UNIT``);
    a data set's name before it (``Run 1: Time (s)``) or a run's after it (``Time (s) Run #1``) is not part of
    the name."""
    cols = []
    for i, cell in enumerate(cells):
        cell = cell.strip()
        data_set = _DATA_SET.match(cell)
        run_after = None if data_set else _RUN_AFTER.search(cell)
        if run_after:
            cell, data_set = cell[:run_after.start()].rstrip(), run_after
        m = _NAME_UNIT.match(cell[data_set.end() if data_set and not run_after else 0:])
        name = (m.group("name") or "").strip()
        unit = unit_symbol(m.group("unit") or "")
        suffix = _SUFFIX_UNIT.match(name) if not unit else None
        if suffix and suffix.group("unit").lower() in _SUFFIX_UNITS:
            name, unit = suffix.group("name"), unit_symbol(suffix.group("unit"))
        raw = re.sub(r"[\s_]+", " ", name).strip()
        unit = unit or CLOCK_UNITS.get(raw.lower(), "")
        cols.append(Column(i, raw.lower(), unit, raw, data_set.group("set").strip() if data_set else ""))
    return cols


def repeated_columns(cols, col):
    """Every column of ``cols`` with the name and unit of ``col`` (itself included), in file order: runs
    side by side repeat their columns (``Event time (s)`` twice, ``Run 1: Time (s)``, ``Run 2: Time (s)``)."""
    return [] if col is None else [c for c in cols if c.name == col.name and c.unit == col.unit]


def find_column(cols, names, *, contains=None):
    """The first column of ``cols`` named one of ``names``; else the first whose words are all such names (a
    name followed by its symbol: ``Zeit t``, ``Höhe h``, ``temps t``); else, with ``contains``, the first
    whose name contains it."""
    for c in cols:
        if c.name in names:
            return c
    for c in cols:
        words = c.name.split()
        if len(words) >= 2 and all(w in names for w in words):
            return c
    if contains:
        for c in cols:
            if contains in c.name:
                return c
    return None


class Rows(Sequence):
    """A table's data rows ``[(lineno, cells)]``, split into cells only when first asked for (a
    numeric table is read by numpy at once, :func:`parse_table`; its cells are split only for an error
    message naming a line)."""

    def __init__(self, lines, sep):
        self._lines, self._sep, self._cells = lines, sep, None

    def _split(self):
        if self._cells is None:
            self._cells = [(no, split_cells(s, self._sep)) for no, s in self._lines]
        return self._cells

    def __len__(self):
        return len(self._lines)

    def __getitem__(self, i):
        return self._split()[i]

    def __iter__(self):
        return iter(self._split())

    @property
    def numbers(self):
        """The file's line number of each row (ndarray of int)."""
        return np.fromiter((no for no, _ in self._lines), dtype=np.int64, count=len(self._lines))


class Table(NamedTuple):
    header_line: int
    cols: list
    rows: Sequence  # [(lineno, cells)]
    sep: object
    decimal_comma: bool
    preamble: list  # [(lineno, text)] before the header
    numeric: object = None  # (n_rows, n_cols) floats when every cell is a plain number (read at once), else None


def row_lines(table):
    """The file's line number of each data row of ``table`` (ndarray of int)."""
    rows = table.rows
    if isinstance(rows, Rows):
        return rows.numbers
    return np.array([no for no, _ in rows], dtype=np.int64)


def _numeric_block(body, sep, decimal_comma, width):
    """Every cell of ``body`` (``[(lineno, text)]``) as floats, shape (rows, width), when each line holds
    ``width`` plain numbers (no quotes, no ``_``) -- read by numpy in one go -- else None (the caller
    then splits the lines one by one and names the line of any problem)."""
    if not body or width < 1 or sep not in (None, " ", "\t", ",", ";"):
        return None
    joined = "\n".join(s for _, s in body)
    if any(ch in joined for ch in "\"'_#"):
        return None
    if decimal_comma:
        if sep == ",":
            return None
        joined = joined.replace(",", ".")
    if sep is None and (" " in joined.strip() or "\t" in joined):
        return None
    try:
        values = np.loadtxt(io.StringIO(joined), delimiter=None if sep in (None, " ") else sep, comments=None,
                            ndmin=2, dtype=float)
    except ValueError:
        return None
    if values.shape != (len(body), width):
        return None
    return values


def parse_table(text, header_at=0, headerless=None):
    """Split a text into header, columns and rows (cells as strings).

    ``headerless``: column names (e.g. ``("t", "y")``) for a file whose first line already
    holds numbers with that many cells; without it such a file is an error.
    """
    lines = text.lines
    if header_at >= len(lines):
        fail(text.path, lines[-1][0], "no header row")
    header_no, header = lines[header_at]
    body = lines[header_at + 1:]
    sep, decimal_comma = sniff(header, [s for _, s in body[:20]])
    head_cells = split_cells(header, sep)
    if is_numeric_row(head_cells, decimal_comma):
        if headerless is not None and len(head_cells) == len(headerless):
            numeric = _numeric_block(lines[header_at:], sep, decimal_comma, len(headerless))
            if numeric is not None:
                return Table(0, columns(list(headerless)), Rows(lines[header_at:], sep), sep, decimal_comma,
                             lines[:header_at], numeric)
            rows = [(no, split_cells(s, sep)) for no, s in lines[header_at:]]
            for no, cells in rows:
                if len(cells) > len(headerless):
                    fail(text.path, no, f"{len(cells)} cells but the first line holds {len(headerless)}")
            return Table(0, columns(list(headerless)), rows, sep, decimal_comma, lines[:header_at])
        fail(text.path, header_no, "no header row: the first line holds numbers; name the columns "
              "(e.g. 't,y', 't', 'bounce,h')")
    numeric = _numeric_block(body, sep, decimal_comma, len(head_cells))
    if numeric is not None:
        return Table(header_no, columns(head_cells), Rows(body, sep), sep, decimal_comma, lines[:header_at], numeric)
    rows = [(no, split_cells(s, sep)) for no, s in body]
    for no, cells in rows:
        if len(cells) > len(head_cells):
            hint = " (a decimal comma with comma separators?)" if sep == "," else ""
            fail(text.path, no, f"{len(cells)} cells but the header names {len(head_cells)} columns{hint}")
    return Table(header_no, columns(head_cells), rows, sep, decimal_comma, lines[:header_at])


def column_values(path, table, col, *, what, allow_empty=False):
    """Float values of one column with line-accurate errors; NaN where empty and allowed."""
    i = col.index
    if table.numeric is not None:   # every cell a plain number, read at once (parse_table)
        fast = table.numeric[:, i]
        if np.all(np.isfinite(fast)):
            return fast.copy()
    try:   # the common case, all cells numbers: one conversion by numpy
        cells = [cells[i] for _, cells in table.rows]
        if table.decimal_comma:
            cells = [c.replace(",", ".") for c in cells]
        if not any("_" in c for c in cells):
            fast = np.array(cells, dtype=float)
            if np.all(np.isfinite(fast)):
                return fast
    except (IndexError, ValueError):
        pass
    out = np.empty(len(table.rows))
    label = col.raw or f"column {col.index + 1}"
    for k, (no, cells) in enumerate(table.rows):
        if col.index >= len(cells) or cells[col.index] == "":
            if allow_empty:
                out[k] = np.nan
                continue
            fail(path, no, f"empty cell in column '{label}' ({what})")
        value = to_float(cells[col.index], table.decimal_comma)
        if value is None:
            cell = cells[col.index]
            fail(path, no, f"'{cell}' is not a number (column '{label}'){_unit_in_cell(cell, col)}")
        if not np.isfinite(value):
            fail(path, no, f"{cells[col.index]} in column '{label}': every value must be a finite number")
        out[k] = value
    return out


#: A number followed by a unit in one cell (``0.50 m``, ``12,5cm``).
_NUMBER_UNIT = re.compile(r"^[+-]?(?:\d+[.,]?\d*|[.,]\d+)(?:[eE][+-]?\d+)?\s*(?P<unit>[A-Za-zµ]+\.?)$")


def _unit_in_cell(cell, col):
    """The advice for a cell that holds a number and its unit (``0.50 m``): the unit goes into the header, once
    for the column (``'H (m)'``); '' for any other cell."""
    m = _NUMBER_UNIT.match(cell.strip())
    if m is None:
        return ""
    unit = unit_symbol(m.group("unit"))
    if unit not in TIME_UNITS and unit not in LENGTH_UNITS:
        return ""
    if col.unit:
        return f": remove the unit from the cells (the header gives it: '{col.raw} ({col.unit})')"
    return f": remove the unit from the cells; put it in the header: '{col.raw} ({unit})'"


def column_cells(table, col):
    """The filled cells of column ``col`` of ``table`` as the file writes them (``'0.500'``, not 0.5)."""
    i = col.index
    return [cells[i] for _, cells in table.rows if i < len(cells) and cells[i] != ""]


def unit_factor(path, table, col, units, kind, unit=None, heights=False):
    """Factor to SI of column ``col``'s unit (``unit`` when given: a unit the column takes from the others)
    in ``units``, or a DataError naming the known ones. An unknown length unit ('bricks') is told what to do:
    write the numbers in a known one, or give --scale (metres per unit); ``heights``: drop and rebound heights,
    whose epsilon = sqrt(h/H) needs no unit, though air drag does."""
    unit = col.unit if unit is None else unit
    if unit not in units:
        fix = ""
        if kind == "length":
            why = ("; epsilon = sqrt(h/H) needs no unit, but air drag does" if heights else "")
            fix = (f": write the heights in one of them (e.g. '{col.raw} (cm)'), or give --scale M_PER_UNIT (metres "
                   f"per '{unit}'){why}")
        fail(path, table.header_line, f"unknown {kind} unit '{unit}' of column '{col.raw}' "
              f"(known: {known_units(units)}){fix}")
    return units[unit]


def check_increasing(path, values, line_numbers, label):
    d = np.diff(values)
    bad = np.flatnonzero(~(d > 0))
    if bad.size:
        j = int(bad[0]) + 1
        fail(path, int(line_numbers[j]), f"{label} not increasing ({values[j]:g} after {values[j - 1]:g})")



def merge_units_row(text, max_title_lines=5):
    """``(text, note)``: a table whose header is followed by a row of units (``Trial,Drop height,Rebound
    height`` over ``,cm,cm``, as a class's spreadsheet is often laid out) with the units written into the
    header (``Drop height (cm)``) and the units row gone, and a note saying so; ``(text, None)`` when the
    text has no such row.

    The units row lies below the header, under at most ``max_title_lines`` title lines, above the first
    line with a number: every filled cell a unit (:func:`unit_of_cell`), one at least a time or length
    unit, each below a named header cell, and the line after it holds a number. A header cell that
    already has a unit keeps it when the row agrees; a disagreement is an error naming both.
    """
    lines = text.lines
    for k in range(1, min(max_title_lines + 1, len(lines) - 2) + 1):
        if has_number(lines[k - 1][1]):
            return text, None
        (header_no, header), (units_no, units) = lines[k - 1], lines[k]
        if has_number(units) or not has_number(lines[k + 1][1]):
            continue
        sep, _ = sniff(header, [units] + [s for _, s in lines[k + 1:k + 21]])
        names, cells = split_cells(header, sep), split_cells(units, sep)
        found = [(i, unit_of_cell(c)) for i, c in enumerate(cells) if c]
        if not found or any(u is None for _, u in found) or not any(u in TIME_UNITS or u in LENGTH_UNITS
                                                                      for _, u in found) \
                or any(i >= len(names) or not names[i] for i, _ in found):
            continue
        merged = list(names)
        for i, unit in found:
            written = strip_cell(cells[i])   # as the row writes it, without brackets, for the header
            written = written[1:-1].strip() if written[:1] in "([" and written[-1:] in ")]" else written
            col = columns([names[i]])[0]
            if col.unit and written != "-" and col.unit != unit:
                fail(text.path, units_no, f"column '{col.raw}' is in {col.unit} by its header (line {header_no}) "
                                          f"and in {written} by the units row below it: correct one of them")
            if not col.unit and written != "-":   # '-': a number without a unit
                merged[i] = f"{names[i]}({written})" if sep == " " else f"{names[i]} ({written})"
        line = merged[0] if sep is None else sep.join(f'"{c}"' if sep in c else c for c in merged)
        new = [(no, line if no == header_no else s) for no, s in lines[:k]] + lines[k + 1:]
        added = [merged[i] for i, _ in found if merged[i] != names[i]]
        row = ", ".join(strip_cell(cells[i]) for i, _ in found)
        note = (f"line {units_no} is a row of units ({row}): read into the header "
                f"({', '.join(repr(c) for c in added)})" if added else
                f"line {units_no} is a row of units ({row}) that repeats the header's: skipped")
        return dataclasses.replace(text, lines=new), note
    return text, None


def merge_two_row_header(text, max_title_lines=5):
    """``(text, note)``: a header of two rows -- names, some spanning the columns to their right (a merged cell
    saved as a name and empty cells: ``Fallhöhe (cm);Rückprallhöhe (cm);;``), over the names of the spanned
    columns (``;1. Versuch;2. Versuch;3. Versuch``) -- written as one row, each spanned column named by the row
    below with the unit of the name above (``1. Versuch (cm)``), and a note saying so; ``(text, None)`` when the
    text has no such header.

    The two rows lie under at most ``max_title_lines`` title lines, above a line of numbers as wide as the lower
    row; a name of the upper row that spans no column stands over an empty cell, and every name of the lower row
    stands under a spanning one, and one name at least spans no column (a title spans them all).
    """
    lines = text.lines
    for k in range(1, min(max_title_lines + 1, len(lines) - 2) + 1):
        (upper_no, upper), (lower_no, lower), (_, first) = lines[k - 1], lines[k], lines[k + 1]
        if has_number(upper) or has_number(lower) or not has_number(first):
            continue
        sep, _ = sniff(upper, [lower, first])
        if sep in (None, " "):
            continue
        names, subs = split_cells(upper, sep), split_cells(lower, sep)
        width = len(split_cells(first, sep))
        if len(subs) != width or len(names) > width or sum(1 for c in subs if c) < 2:
            continue
        names += [""] * (width - len(names))
        spans, above = [], ""
        for i, name in enumerate(names):
            above = name or above
            spans.append(above if subs[i] else "")
        alone = [i for i, name in enumerate(names) if name and (i + 1 == width or names[i + 1])]
        if not alone or any(subs[i] for i in alone) or not all(spans[i] for i, c in enumerate(subs) if c):
            continue   # (a title over the header spans every column: no name stands alone)
        merged = []
        for i, sub in enumerate(subs):
            if not sub:
                merged.append(names[i])
                continue
            unit, own = columns([spans[i]])[0].unit, columns([sub])[0].unit
            merged.append(f"{sub} ({unit})" if unit and not own else sub)
        line = sep.join(merged)
        note = (f"lines {upper_no}-{lower_no} are a header of two rows: read as one "
                f"({', '.join(repr(c) for c in merged)})")
        new = [(no, line if no == upper_no else s) for no, s in lines if no != lower_no]
        return dataclasses.replace(text, lines=new), note
    return text, None


def has_number(line):
    """True when a cell of ``line`` (split at any comma, semicolon or tab) is a number."""
    return any(is_numeric_row([cell]) for cell in loose_cells(line))


def header_columns(text, header_at=0):
    """The columns named by line ``header_at``, or None when it holds numbers (no header)."""
    if header_at >= len(text.lines):
        return None
    header = text.lines[header_at][1]
    sample = [s for _, s in text.lines[header_at + 1:header_at + 21]]
    sep, dc = sniff(header, sample)
    cells = split_cells(header, sep)
    if is_numeric_row(cells, dc):
        return None
    return columns(cells)


def numeric_width(text, n_lines=20):
    """Cells per line of a headerless numeric file (the same count on the first ``n_lines``
    lines, every cell a number), or 0 when the file has a header or is not such a table."""
    head = [s for _, s in text.lines[:n_lines]]
    sep, dc = sniff(head[0], head[1:])
    widths = set()
    for line in head:
        cells = split_cells(line, sep)
        if not is_numeric_row(cells, dc):
            return 0
        widths.add(len(cells))
    return widths.pop() if len(widths) == 1 else 0



#: A number with its thousands grouped by '.' (``1.200``, ``12.500``, ``1.200,5`` with a decimal comma).
_GROUPED = re.compile(r"^[+-]?[1-9]\d{0,2}(?:\.\d{3})+(?:,\d+)?$")
#: ... somewhere in a text (a cheap look before splitting its lines).
_GROUPED_IN_TEXT = re.compile(r"(?<![\d.,])[1-9]\d{0,2}(?:\.\d{3})+(?![\d.])")
_INTEGER = re.compile(r"^[+-]?\d+$")


def ungroup_thousands(text):
    """``(text, note)``: the numbers of ``text`` whose thousands are grouped by '.' written without it
    (``1.200`` -> ``1200``, ``1.200,5`` -> ``1200,5``) and a note saying so; ``(text, None)`` when none is.

    A '.' followed by exactly three digits groups thousands, column by column: in a file with a decimal comma
    (its decimals cannot use '.'), and in a column whose other cells are whole numbers of three digits or more
    (``800`` above ``1.200``: one column is not written with three decimals in some rows and none in others)
    while the file writes no decimal with a '.' (``1;0.562`` over ``1.500;0.844`` is 1.5 m: a decimal
    point, beside drops of 1 and 2 m). A
    semicolon-separated column (the decimal-comma locale's CSV) of such numbers only, in a file with no other
    decimal, may be either (``2.000``: 2000 or 2.0): an error saying so, naming the line.
    """
    lines = text.lines
    if len(lines) < 2 or not any(_GROUPED_IN_TEXT.search(s) for _, s in lines):
        return text, None
    sep, decimal_comma = sniff(lines[0][1], [s for _, s in lines[1:200]])
    if sep == ",":
        return text, None
    rows = [(no, split_cells(s, sep)) for no, s in lines]
    decimal_comma = decimal_comma or any("," in c and _GROUPED.match(c) for _, cells in rows for c in cells)

    def number(c):
        return c == "" or _GROUPED.match(c) is not None or to_float(c, decimal_comma) is not None

    data = [(k, cells) for k, (_, cells) in enumerate(rows) if cells and all(number(c) for c in cells)]
    width = max((len(cells) for _, cells in data), default=0)
    # a '.' the file uses as a decimal point elsewhere ('0.562'): it is no thousands separator there either
    point_decimals = not decimal_comma and any("." in c and not _GROUPED.match(c) for _, cells in data for c in cells)
    grouped_columns = set()
    for j in range(width):
        filled = [(k, cells[j]) for k, cells in data if j < len(cells) and cells[j] != ""]
        grouped = [(k, c) for k, c in filled if _GROUPED.match(c)]
        if not grouped:
            continue
        integers = [abs(int(c)) for _, c in filled if _INTEGER.match(c)]
        if decimal_comma or (integers and min(integers) >= 100 and not point_decimals
                             and all(_GROUPED.match(c) or _INTEGER.match(c) for _, c in filled)):
            grouped_columns.add(j)
        elif sep == ";" and len(grouped) == len(filled) and not point_decimals:
            k, cell = grouped[0]
            header = rows[data[0][0] - 1][1] if data[0][0] > 0 else []   # the line above the first row of numbers
            name = header[j] if j < len(header) else f"column {j + 1}"
            fail(text.path, rows[k][0], f"'{cell}' in column '{name}': a '.' before three digits groups thousands "
                                        f"({cell.replace('.', '')}) or is a decimal point ({float(cell):g}); write "
                                        f"the numbers without thousands separators, or with a decimal comma")
    if not grouped_columns:
        return text, None
    changed, example = {}, None
    for k, cells in data:
        new = [c.replace(".", "") if j in grouped_columns and _GROUPED.match(c) else c for j, c in enumerate(cells)]
        if new != cells:
            example = example or next((a, b) for a, b in zip(cells, new) if a != b)
            joiner = " " if sep == " " else (sep or "")
            changed[rows[k][0]] = joiner.join(f'"{c}"' if sep and sep in c else c for c in new)
    new_lines = [(no, changed.get(no, s)) for no, s in lines]
    note = (f"'.' before three digits read as a thousands separator ('{example[0]}' = {example[1]}; "
            f"{len(changed)} line(s))")
    return dataclasses.replace(text, lines=new_lines), note
