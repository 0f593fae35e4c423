"""Output for people and output for machines, in one place.

Default stdout is for people: short, aligned tables with sensible digits, at most
:data:`MAX_COLUMNS` columns wide. ``--format json|yaml`` (or an ``-o`` file's extension) gives
the full-precision machine file, with a ``schema_version`` (:func:`machine_document`).

* :func:`choose_format` -- the format a command writes, from ``--format`` and ``-o``;
* :func:`number` -- a number to a given count of significant digits, plain where that reads
  better; :func:`ms` -- a time in milliseconds;
* :func:`table` -- an aligned text table (numbers right-aligned, text left-aligned);
* :func:`section` -- a titled block of ``key  value`` lines;
* :func:`wrap` -- a paragraph (or a bullet) wrapped to :data:`MAX_COLUMNS`;
* :func:`longest_line` -- the width of a text, for tests of the 100-column rule;
* :data:`ASCII_FALLBACK` -- the codecs error handler the command line writes its text with: a stdout
  whose encoding lacks a character (latin-1, cp1252) gets its ASCII spelling (ε -> eps), and a file
  name's undecodable byte (a lone surrogate) is written escaped (``\\xe9``);
* :func:`printable_name` -- such a name with its undecodable bytes escaped, for JSON and messages.
"""

from __future__ import annotations

import codecs
import math
import unicodedata
from pathlib import Path

from vrcal.errors import UsageError

#: Widest line of default (human) output.
MAX_COLUMNS = 100

#: Version of the machine files (JSON/YAML) that commands write; raised when a key changes meaning.
SCHEMA_VERSION = 1

#: File extensions and the machine format they select.
EXTENSIONS = {".json": "json", ".yaml": "yaml", ".yml": "yaml", ".txt": "text", ".csv": "csv", ".md": "markdown"}


#: Every file extension vrcal reads or writes, and the format it names: an ``-o`` file whose extension
#: names a format the command does not write is refused (:func:`file_format`).
KNOWN_EXTENSIONS = {**EXTENSIONS, ".xml": "xml", ".mjcf": "xml", ".sdf": "sdf", ".world": "sdf",
                    ".wav": "wav", ".wave": "wav", ".avi": "video", ".mp4": "video", ".m4v": "video",
                    ".mov": "video", ".mkv": "video", ".png": "png", ".pdf": "pdf", ".svg": "svg", ".gif": "gif",
                    ".xlsx": "xlsx", ".xls": "xls", ".tsv": "tsv"}


#: (extension's format, format written) pairs an ``-o`` file may hold: CSV data is text, SDF is XML.
COMPATIBLE_FORMATS = frozenset({("text", "csv"), ("xml", "sdf")})


def choose_format(fmt, output, default="text", allowed=("text", "json", "yaml")):
    """The output format: ``--format`` when given, else the ``-o`` file's extension
    (:func:`file_format`), else ``default``.

    Parameters
    ----------
    fmt : str or None
        the ``--format`` value
    output : str or None
        the ``-o`` path ('-' or None is stdout)
    default : str
        what people get on stdout, and an ``-o`` file whose extension names no format
    allowed : tuple of str
        the formats the command can write

    Raises
    ------
    UsageError
        a ``--format`` the command cannot write; an ``-o`` extension that names one; a ``--format``
        and an ``-o`` extension that name different formats (``--format text -o p.json``)
    """
    if fmt is not None:
        if fmt not in allowed:
            raise UsageError(f"unknown --format '{fmt}' (known: {', '.join(allowed)})")
        suffix = Path(str(output)).suffix.lower() if output not in (None, "-") else ""
        named = KNOWN_EXTENSIONS.get(suffix)
        if named is not None and named != fmt and (named, fmt) not in COMPATIBLE_FORMATS:
            raise UsageError(f"--format {fmt} with -o '{output}', a {suffix} file ({named}): name the file "
                             f"{writes_text((fmt,))} or leave out --format (the extension chooses)")
        return fmt
    if output not in (None, "-"):
        return file_format(output, allowed, default)
    return default


def file_format(output, allowed, default, given=None):
    """The format an ``-o`` file gets from its extension -- the one rule of every command.

    An extension of :data:`KNOWN_EXTENSIONS` whose format is in ``allowed`` chooses it; one whose
    format the command cannot write is a usage error naming the formats (and extensions) it
    writes; an extension vrcal does not know (or none) gets ``default``, and a warning (one line
    on stderr, ``vrcal: warning: ...``) says which format was written.

    Parameters
    ----------
    output : str
        the ``-o`` path
    allowed : tuple of str
        the formats the command writes (names of :data:`KNOWN_EXTENSIONS`' values; others,
        such as a ``text`` table written to a file of any name, are fine too)
    default : str
        the format of a file whose extension names none
    given : str or None
        the option that fixed the format (``--format impacts``): the refusal then names it

    Raises
    ------
    UsageError
        the extension names a format not in ``allowed``
    """
    import warnings

    suffix = Path(str(output)).suffix.lower()
    named = KNOWN_EXTENSIONS.get(suffix)
    if named in allowed:
        return named
    for kind in allowed:   # a .txt file of CSV data (as Tracker and phyphox write), an SDF world in .xml
        if (named, kind) in COMPATIBLE_FORMATS:
            return kind
    if named is not None and given is not None:
        raise UsageError(f"-o '{output}': {given} writes {allowed[0]}, not {named}")
    if named is not None:
        raise UsageError(f"-o '{output}': a {suffix} file is {named}, which this command does not write; it "
                         f"writes {writes_text(allowed)}")
    warnings.warn(f"-o '{output}': the extension '{suffix}' names no format vrcal knows: wrote {default}"
                  if suffix else f"-o '{output}': no extension: wrote {default}", UserWarning, stacklevel=2)
    return default


def writes_text(formats):
    """``'text (.txt), json (.json), yaml (.yaml, .yml)'``: formats and the extensions that choose them."""
    parts = []
    for f in dict.fromkeys(formats):
        exts = [e for e, k in KNOWN_EXTENSIONS.items() if k == f]
        parts.append(f"{f} ({', '.join(exts)})" if exts else f)
    return ", ".join(parts)


def machine_document(data):
    """``data`` (a dict) with ``schema_version`` added first, for a JSON/YAML file."""
    return {"schema_version": SCHEMA_VERSION, **data}


#: Name of the codecs error handler of :func:`_ascii_fallback` (registered when this module is imported).
ASCII_FALLBACK = "vrcal-ascii"

#: ASCII spellings of the characters vrcal writes, for an output encoding without them.
ASCII_SPELLINGS = {
    "ε": "eps", "μ": "u", "µ": "u", "±": "+-", "−": "-", "√": "sqrt", "·": "*", "×": "x", "°": " deg",
    "º": " deg", "σ": "sigma", "Σ": "sum", "Δ": "Delta", "χ": "chi", "τ": "tau", "π": "pi", "ρ": "rho",
    "≤": "<=", "≥": ">=", "≈": "~", "≠": "!=", "→": "->", "←": "<-", "–": "-", "—": "--", "…": "...",
    "ß": "ss", "\u2018": "'", "\u2019": "'", "\u201c": '"', "\u201d": '"', "\u00a0": " ",
}


def _ascii_fallback(exc):
    """Codecs error handler: the characters ``exc`` could not encode in their ASCII spelling.

    Lone surrogates (the bytes of a file name that is not UTF-8, as Python decodes them) become
    ``\\xNN``; superscripts ``^`` and their digits (``s⁻¹`` -> ``s^-1``); the characters of
    :data:`ASCII_SPELLINGS` their spelling; others their compatibility decomposition without
    accents (``ö`` -> ``o``), else ``?``.
    """
    if not isinstance(exc, UnicodeEncodeError):
        raise exc
    out, superscript = [], False
    for ch in exc.object[exc.start:exc.end]:
        if 0xDC80 <= ord(ch) <= 0xDCFF:
            out.append(f"\\x{ord(ch) - 0xDC00:02x}")
            superscript = False
            continue
        is_super = unicodedata.decomposition(ch).startswith("<super>")
        if ch in ASCII_SPELLINGS:
            text = ASCII_SPELLINGS[ch]
        else:
            text = "".join(ASCII_SPELLINGS.get(c, c) for c in unicodedata.normalize("NFKD", ch))
            text = text.encode("ascii", "ignore").decode("ascii") or "?"
        out.append(("^" if is_super and not superscript else "") + text)
        superscript = is_super
    return "".join(out), exc.end


codecs.register_error(ASCII_FALLBACK, _ascii_fallback)


def printable_name(text):
    """``text`` (a file name as Python decodes it) with every undecodable byte -- a lone surrogate,
    invalid in UTF-8 -- written ``\\xNN``: ``printable_name('lat\\udce9.csv') == 'lat\\\\xe9.csv'``."""
    return str(text).encode("utf-8", ASCII_FALLBACK).decode("utf-8")


def number(value, digits=4):
    """``value`` to ``digits`` significant digits, without an exponent between 1e-4 and 1e6.

    ``number(0.76617813) == '0.7662'``; ``number(59.657) == '59.66'``; ``number(123456) == '123456'``;
    ``number(None) == '-'``.
    """
    if value is None:
        return "-"
    v = float(value)
    if not math.isfinite(v):
        return "nan" if math.isnan(v) else ("inf" if v > 0 else "-inf")
    if v == 0:
        return "0"
    mag = math.floor(math.log10(abs(v)))
    if -4 <= mag < 6:
        places = max(digits - 1 - mag, 0)
        return f"{v:.{places}f}"
    return f"{v:.{digits - 1}e}"


def epsilon(value, digits=3):
    """A restitution to ``digits`` significant digits, or more where that would print 1 for a value below
    it: ``epsilon(0.7662) == '0.766'``, ``epsilon(0.9995) == '0.9995'`` (not '1.000')."""
    if value is None:
        return "-"
    v = float(value)
    if 0.0 < v < 1.0:
        digits = min(max(digits, math.ceil(-math.log10(1.0 - v) - 1e-9)), 8)
    return number(v, digits)


def ms(seconds, digits=3):
    """A time in seconds written in milliseconds: ``ms(0.06659) == '66.6 ms'``."""
    if seconds is None:
        return "-"
    return f"{number(float(seconds) * 1e3, digits)} ms"


def mass(kg, digits=3):
    """A mass in grams, or in kilograms from 1 kg up: ``mass(0.0577) == '57.7 g'``, ``mass(3.0) == '3.00 kg'``."""
    kg = float(kg)
    return f"{number(kg, digits)} kg" if kg >= 1.0 else f"{number(kg * 1e3, digits)} g"


def counted(n, noun):
    """'1 bounce', '3 bounces': ``n`` and the noun, plural unless n is 1 (nouns with a plain -s plural)."""
    return f"{n} {noun}" + ("" if n == 1 else "s")


def table(rows, headers, align=None, indent=""):
    """An aligned text table.

    Parameters
    ----------
    rows : list of sequences
        cells (str, or numbers already formatted as str)
    headers : sequence of str
    align : str or None
        one of 'l'/'r' per column; default: right for cells that look numeric, else left
    indent : str
        prefix of every line

    Returns
    -------
    str
        lines joined with newlines, ending with a newline
    """
    cells = [[str(c) for c in row] for row in rows]
    headers = [str(h) for h in headers]
    n = len(headers)
    widths = [max([len(headers[j])] + [len(r[j]) for r in cells if j < len(r)]) for j in range(n)]
    if align is None:
        align = "".join("r" if cells and all(_numeric(r[j]) for r in cells if j < len(r)) else "l"
                        for j in range(n))

    def line(values):
        out = [v.rjust(w) if a == "r" else v.ljust(w) for v, w, a in zip(values, widths, align)]
        return (indent + "  ".join(out)).rstrip()

    return "\n".join([line(headers)] + [line(r) for r in cells]) + "\n"


def section(title, items, indent="  "):
    """A titled block: ``title`` then one ``key  value`` line per item, keys aligned."""
    items = [(str(k), str(v)) for k, v in items]
    width = max((len(k) for k, _ in items), default=0)
    lines = [title] + [f"{indent}{k.ljust(width)}  {v}".rstrip() for k, v in items]
    return "\n".join(lines) + "\n"


def wrap(text, first="", rest=None, width=MAX_COLUMNS):
    """``text`` wrapped to ``width`` columns: the first line starts with ``first``, the others
    with ``rest`` (default: as many blanks as ``first`` is long). Ends with a newline.

    ``wrap("a long note ...", first="  - ")`` is a bullet whose lines align under its text.
    """
    import textwrap

    rest = " " * len(first) if rest is None else rest
    lines = textwrap.wrap(" ".join(str(text).split()), width=width, initial_indent=first,
                          subsequent_indent=rest, break_on_hyphens=False) or [first.rstrip()]
    return "\n".join(lines) + "\n"


def longest_line(text):
    """The number of characters of the longest line of ``text``."""
    return max((len(line) for line in str(text).splitlines()), default=0)


def _numeric(text):
    t = text.strip().split(" ")[0].replace("..", "")
    try:
        float(t)
        return True
    except ValueError:
        return t in ("-", "nan", "inf")


def csv_text(header, rows):
    """CSV text (the csv module: a cell with a comma, a quote or a newline is quoted); None is empty."""
    import csv
    import io

    buf = io.StringIO()
    writer = csv.writer(buf, lineterminator="\n")
    writer.writerow(header)
    writer.writerows(["" if c is None else c for c in row] for row in rows)
    return buf.getvalue()
