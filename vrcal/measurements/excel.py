"""Spreadsheets (phyphox's Excel exports, ``.xlsx`` and the older ``.xls``) and zip archives of CSV files
(phyphox's CSV export) read as text tables.

A sheet becomes the same :class:`vrcal.measurements.table.Text` a CSV file gives (cells joined by
tabs, one line per row, the sheet's row numbers as line numbers), so every layout of
:data:`vrcal.measurements.reader.FORMATS` reads spreadsheets too. Which sheet: the one named with
``sheet``; else phyphox's ``All`` (every event of the Acoustic Stopwatch) when there is one; else
the first sheet with a table in it. A zip archive (phyphox's *Export Data* as CSV: one file per data
set, ``All.csv``, ``Simple.csv``, ..., and ``meta/``) is read the same way, its CSV files taking the
place of the sheets (:func:`load_archive_text`; no extra needed). Needs the optional extra ``excel``
(openpyxl for ``.xlsx``, xlrd for ``.xls``); without it the error says so in one line.
"""

from __future__ import annotations

import dataclasses
import os
from pathlib import Path

from vrcal.errors import DataError, UsageError, install_hint
from vrcal.fileio import MAX_TEXT_BYTES
from vrcal.measurements.table import Text, empty_rows_notes, text_from_bytes

#: File signatures: zip (xlsx) and OLE2 compound documents (xls).
_XLSX_MAGIC = b"PK\x03\x04"
_XLS_MAGIC = b"\xd0\xcf\x11\xe0\xa1\xb1\x1a\xe1"

#: Sheets preferred when none is named (phyphox: "All" holds every event).
PREFERRED_SHEETS = ("All",)

#: Most rows read from a sheet.
MAX_ROWS = 1_000_000



def container_kind(path):
    """'xlsx', 'xls', 'zip' (an archive that is no workbook) or None, from the file's first bytes (and, for
    a zip, its name: an .xlsx is a zip too)."""
    if os.path.exists(path) and not os.path.isfile(path):
        return None  # a FIFO or a device is read once, by the text reader: no peeking
    try:
        with open(path, "rb") as fh:
            head = fh.read(8)
    except OSError:
        return None
    if head.startswith(_XLSX_MAGIC):
        return "xlsx" if str(path).lower().endswith((".xlsx", ".xlsm")) else "zip"
    if head == _XLS_MAGIC:
        return "xls"
    return None


def spreadsheet_kind(path):
    """'xlsx', 'xls' or None, from the file's first bytes (:func:`container_kind`)."""
    kind = container_kind(path)
    return kind if kind in ("xlsx", "xls") else None


def _cell(value):
    if value is None:
        return ""
    if isinstance(value, float):
        return repr(value)
    return str(value).replace("\t", " ").replace("\n", " ").strip()


def _sheets(path, kind):
    """[(name, rows)] with rows as lists of cell values."""
    if kind == "xlsx":
        try:
            import openpyxl
        except ImportError:
            hint = install_hint("openpyxl", "excel")
            raise UsageError(f"{path}: reading .xlsx files needs openpyxl: {hint}") from None
        try:
            wb = openpyxl.load_workbook(path, read_only=True, data_only=True)
        except Exception as exc:  # noqa: BLE001 - any failure of the library is a bad file
            raise DataError(f"{path}: not a readable .xlsx workbook ({type(exc).__name__})") from None
        try:
            return [(ws.title, _fill_merged([list(r) for r in ws.iter_rows(values_only=True, max_row=MAX_ROWS)],
                                            _merged_ranges(path, getattr(ws, "_worksheet_path", None))))
                    for ws in wb.worksheets]
        finally:
            wb.close()
    try:
        import xlrd
    except ImportError:
        raise UsageError(f"{path}: reading .xls files needs xlrd: {install_hint('xlrd', 'excel')}") from None
    try:
        book = xlrd.open_workbook(path, on_demand=True)
    except Exception as exc:  # noqa: BLE001
        raise DataError(f"{path}: not a readable .xls workbook ({type(exc).__name__})") from None
    out = []
    for sh in book.sheets():
        out.append((sh.name, [sh.row_values(i) for i in range(min(sh.nrows, MAX_ROWS))]))
    return out


def _merged_ranges(path, member):
    """The merged cell ranges ``[(min_col, min_row, max_col, max_row)]`` (1-based) of the worksheet stored as
    ``member`` of the .xlsx ``path`` (a read-only workbook does not give them; its sheets' own XML does), or []."""
    import re
    import zipfile

    from openpyxl.utils.cell import range_boundaries

    if not member:
        return []
    try:
        with zipfile.ZipFile(path) as zf:
            xml = zf.read(member.lstrip("/")).decode("utf-8", "replace")
    except (KeyError, OSError, zipfile.BadZipFile):
        return []
    out = []
    for ref in re.findall(r'<(?:\w+:)?mergeCell\s+ref="([A-Z]+\d+:[A-Z]+\d+)"', xml):
        try:
            out.append(range_boundaries(ref))
        except ValueError:
            continue
    return out


def _fill_merged(rows, ranges):
    """``rows`` (lists of cell values) with the value of each merged range that spans rows (a drop height merged
    over the rows of its trials) written into the cells below its first row, as the spreadsheet shows it; a range
    across columns of one row (a title over the table) stays one cell."""
    for min_col, min_row, max_col, max_row in ranges:
        if min_row > len(rows) or min_col > len(rows[min_row - 1]):
            continue
        value = rows[min_row - 1][min_col - 1]
        for r in range(min_row + 1, min(max_row, len(rows)) + 1):
            row = rows[r - 1]
            row.extend([None] * (max_col - len(row)))
            for c in range(min_col, max_col + 1):
                row[c - 1] = value
    return rows


def load_sheet_text(path, sheet=None):
    """The chosen sheet of a spreadsheet as a :class:`Text` (path shown as ``FILE[SHEET]``).

    Raises
    ------
    UsageError
        the reader library is missing (the message says how to install it), or ``sheet``
        names no sheet (the message lists them)
    DataError
        an unreadable workbook, or no sheet with a table
    """
    kind = spreadsheet_kind(path)
    sheets = _sheets(str(path), kind)
    names = [name for name, _ in sheets]

    def as_text(name, rows):
        lines, empty = [], []
        for i, row in enumerate(rows, start=1):
            cells = [_cell(v) for v in row]
            while cells and cells[-1] == "":
                cells.pop()
            if any(cells):
                lines.append((i, "\t".join(cells)))
            else:
                empty.append(i)
        return Text(f"{path}[{name.strip()}]", lines, notes=empty_rows_notes(empty, lines))

    if sheet is not None:
        for name, rows in sheets:
            if name == sheet or name.strip() == str(sheet).strip():
                text = as_text(name, rows)
                if not text.lines:
                    raise DataError(f"{path}: sheet '{name.strip()}' is empty")
                return text
        raise UsageError(f"{path}: no sheet '{sheet}' (sheets: {', '.join(repr(n.strip()) for n in names)})")
    order = [s for s in sheets if s[0].strip() in PREFERRED_SHEETS] + sheets
    for name, rows in order:
        text = as_text(name, rows)
        if len(text.lines) >= 2:
            return text
    raise DataError(f"{path}: no sheet holds a table (sheets: {', '.join(repr(n.strip()) for n in names)})")


#: Names of workbook files (a file so named that is no workbook is refused with what it is).
WORKBOOK_SUFFIXES = (".xlsx", ".xlsm", ".xls")


def _looks_like(head, layout=None):
    """What a file's first bytes show it to be, for the error of a file named as a workbook that is none
    (``layout()``, asked only of text: the format it reads as, or None)."""
    if head.startswith(_XLSX_MAGIC):
        return "it is a zip archive (an .xlsx workbook named .xls? rename it to .xlsx)"
    if not head.strip():
        return "it is empty"
    if b"\x00" in head:
        return "it is a binary file of another kind (save the sheet from the spreadsheet program as .xlsx or .csv)"
    if head.lstrip()[:1] == b"<":
        return ("it is an HTML or XML document (a web page saved as .xls?): open it in a spreadsheet "
                "program and save it as .xlsx or .csv")
    name = layout() if layout is not None else None
    return ("it is text (a CSV or text table named as a workbook?): rename it to .csv, or give "
            + (f"--format {name}" if name else "--format with its layout"))


def check_workbook_name(path, layout=None):
    """Refuse a file named as a workbook (``.xlsx``, ``.xls``) whose bytes are no workbook, saying what it
    looks like and how to read it; a workbook, or a file named otherwise, passes.

    ``layout(path)``, when given, names the format of a text file so named (None when none reads it), which the
    error then gives to ``--format``.

    Raises
    ------
    DataError
        "FILE: not an Excel workbook: it is text (...): rename it to .csv, or give --format drops"
    """
    if not str(path).lower().endswith(WORKBOOK_SUFFIXES) or is_spreadsheet(path):
        return
    if os.path.exists(path) and not os.path.isfile(path):
        return  # a FIFO or a device: read once, by the text reader
    try:
        with open(path, "rb") as fh:
            head = fh.read(4096)
    except OSError:
        return  # the text reader names the problem
    raise DataError(f"{path}: not an Excel workbook: "
                    f"{_looks_like(head, (lambda: layout(path)) if layout is not None else None)}")


def is_spreadsheet(path):
    """True for an .xlsx or .xls workbook (by its first bytes)."""
    return spreadsheet_kind(Path(path)) is not None


#: Files of an archive read as tables (phyphox's ``meta/`` folder, the device and the times, is not one).
_TABLE_SUFFIXES = (".csv", ".txt", ".tsv", ".dat")




def load_archive_text(path, member=None):
    """One table of a zip archive as a :class:`Text` (path shown as ``FILE[MEMBER]``): the one named
    ``member`` (its name with or without the folder and the ending); else phyphox's ``All.csv``; else the
    archive's only table. A note names the table read and the others.

    Raises
    ------
    UsageError
        ``member`` names no table of the archive (the message lists them)
    DataError
        a corrupt archive, one with no table, several tables and none chosen (the message lists them and
        says how to choose), an Excel workbook named .zip
    """
    import zipfile

    path = str(path)
    try:
        with zipfile.ZipFile(path) as zf:
            infos = zf.infolist()
            names = [i.filename for i in infos]
            if "[Content_Types].xml" in names and any(n.startswith("xl/") for n in names):
                raise DataError(f"{path}: an Excel workbook named as a zip archive: rename it to .xlsx")
            if "content.xml" in names and "mimetype" in names and \
                    zf.read("mimetype")[:64].startswith(b"application/vnd.oasis.opendocument"):
                what = "spreadsheet (LibreOffice or OpenOffice Calc, .ods)" \
                    if b"spreadsheet" in zf.read("mimetype")[:80] else "document (LibreOffice or OpenOffice)"
                raise DataError(f"{path}: an OpenDocument {what}, which vrcal does not read: save it as .xlsx "
                                f"or .csv (File > Save As)")
            tables = [i for i in infos if not i.is_dir() and i.filename.lower().endswith(_TABLE_SUFFIXES)
                      and not i.filename.startswith(("meta/", "__MACOSX/"))
                      and not Path(i.filename).name.startswith(".")]
            listed = ", ".join(repr(i.filename) for i in tables)
            if not tables:
                raise DataError(f"{path}: a zip archive with no CSV or text table in it "
                                f"({len(names)} file(s): {', '.join(names[:6])}{', ...' if len(names) > 6 else ''})")
            if member is not None:
                chosen = [i for i in tables if str(member).strip() in (i.filename, Path(i.filename).name,
                                                                       Path(i.filename).stem)]
                if not chosen:
                    raise UsageError(f"{path}: no table '{member}' in the archive (tables: {listed})")
            else:
                chosen = [i for i in tables if Path(i.filename).stem in PREFERRED_SHEETS] or \
                    (tables if len(tables) == 1 else [])
                if not chosen:
                    raise DataError(f"{path}: a zip archive of {len(tables)} tables ({listed}): give --sheet NAME "
                                    f"to read one, or unzip it and give the CSV")
            info = chosen[0]
            if info.file_size > MAX_TEXT_BYTES:
                raise DataError(f"{path}: '{info.filename}' is larger than the limit of "
                                f"{MAX_TEXT_BYTES >> 20} MiB for a measurement file")
            raw = zf.read(info)
    except (zipfile.BadZipFile, OSError, RuntimeError, NotImplementedError, EOFError) as exc:
        raise DataError(f"{path}: not a readable zip archive ({str(exc).strip() or type(exc).__name__})") from None
    text = text_from_bytes(f"{path}[{info.filename}]", raw)
    others = [i.filename for i in tables if i is not info]
    note = (f"zip archive: '{info.filename}' read" + (f" (also in it: {', '.join(repr(n) for n in others)}; --sheet "
                                                      f"to read another)" if others else ""))
    return dataclasses.replace(text, notes=(note,) + tuple(text.notes))
