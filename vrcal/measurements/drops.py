"""A table of drop and rebound heights: the classroom experiment, one row per trial.

The header names which column is which (case matters only for ``H`` and ``h``):

* the drop height: ``H``, ``H0``, ``h0``, ``drop``, ``drop height``, ``release height``,
  ``initial height``, or any name with a word starting as one of :data:`DROP_WORDS`
  (``Height dropped (m)``, ``Dropped from (cm)``, ``Starting height``, ``drop_cm``; in a class's own language
  ``Fallhöhe``, ``hauteur de chute``, ``altura de caída``, ``altezza di caduta``, ``altura de queda``);
* the first rebound: ``h``, ``h1``, ``rebound``, ``rebound height``, ``bounce height``,
  ``first rebound``, or any name with a word starting as one of :data:`REBOUND_WORDS`
  (``Height bounced (m)``, ``Bounced to (cm)``, ``Final height``; ``Rückprallhöhe``, ``Sprunghöhe``, ``hauteur du
  rebond``, ``altura de rebote``, ``altezza di rimbalzo``, ``altura do ressalto``; a ``bounce``
  column with a length unit is a height, not a bounce number); further rebounds of the same trial
  may follow as ``h2``, ``h3``, ... after ``h``; accents are optional (``Fallhoehe``, ``Rueckprallhoehe``,
  ``caida``);
* **trials side by side**: a drop height and several rebound columns numbered 1, 2, ..., N, one rule
  whatever the word and wherever the number (:func:`_numbered_group`): by a trial word (``Trial 1 (cm)``,
  ``Run 3``, ``Versuch 2``, ``1. Versuch``, ``essai 2``: :data:`_TRIAL_WORDS`) they are trials, the classroom
  table with one row per drop height; any other numbered columns (``h1, h2, h3``, ``Rebound 1``,
  ``Rückprallhöhe 2``, ``hauteur de rebond 3``, ``Drop 1`` beside ``Height dropped from``, ``1st bounce``,
  ``Second rebound``) are trials when their values agree (every column within 25 % of the first, row by
  row) and successive rebounds of one drop when each is clearly below the one before; the notes say which;
* a column headed just as a height (``Height (cm)``, ``Höhe``: :data:`_PLAIN_HEIGHTS`) is the drop height
  when the other height columns are rebounds with a length unit (``Height (cm), Rebound height (cm)``,
  ``Height (cm), Bounce (cm)``, ``Height (cm), Bounce 1 (cm), Bounce 2 (cm)``); a rebound column without any
  drop-height column is an error saying so;
* other columns (``trial``, ``n``, an ``Average`` or ``Mean`` of the trials, a comment) are not read;
  a column of numbers other than a trial number is named in a note, and so is a column of text, with its
  values when they differ from row to row (the rows may be different balls); when its name says it holds
  the ball or the surface (:data:`BALL_WORDS`, :data:`SURFACE_WORDS`) differing values are an error: one
  epsilon cannot describe several balls (:func:`_unread_notes`);
* a row without its first rebound (an empty cell) is skipped with a note naming its line.

Units in brackets (``H (cm)``, ``h [mm]``, ``H (in)``) or after the name (``Fallhöhe in cm``,
``drop_cm``; ``drop_in``, ``H_in``: inches, with a note, where a trajectory's ``y_in`` keeps its name,
:func:`_inch_columns`): any length unit of :data:`vrcal.measurements.table.LENGTH_UNITS` (m, cm, mm,
inches, feet; m when none); another unit is an error naming the known ones. A height column without a unit takes
the unit of the other height columns when they agree on one (with a note). Every row is a
run of its own (its own drop); :class:`vrcal.measurements.types.Runs` of
:class:`vrcal.measurements.types.ApexHeights` (bounce 0 = the drop height) are fitted jointly
by ``vrcal discover``: one epsilon and one set of effects for all the rows, a drop height per
row. The speed changes from row to row, which is what tells air drag and a speed-dependent
epsilon apart.
"""

from __future__ import annotations

import re
import unicodedata
from typing import NamedTuple

import numpy as np

from vrcal.errors import UsageError
from vrcal.measurements.cleanup import printed_resolution
from vrcal.measurements.table import (
    BOUNCE_NAMES,
    LENGTH_UNITS,
    TIME_NAMES,
    TIME_UNITS,
    column_cells,
    column_values,
    fail,
    find_column,
    header_columns,
    parse_table,
    row_lines,
    sniff,
    split_cells,
    to_float,
    unit_factor,
)
from vrcal.measurements.types import ApexHeights, Runs

DROP_NAMES = ("h0", "h 0", "drop", "drop height", "release height", "initial height", "height of drop",
              "hdrop", "h drop", "drop h", "h release")
REBOUND_NAMES = ("h1", "h 1", "rebound", "rebound height", "bounce height", "first rebound", "hrebound",
                 "h rebound", "return height", "rebound h")
_MORE = re.compile(r"^h\s*(\d+)$")
#: Word beginnings (lower case, accents off: :func:`_folded`) that mark a drop-height column: English
#: (``Height dropped``, ``Starting height``), German (``Fallhöhe``, ``Abwurfhöhe``, ``Starthöhe``,
#: ``Ausgangshöhe``), French (``hauteur de chute``, ``de lâcher``), Spanish (``altura de caída``, ``inicial``),
#: Italian (``altezza di caduta``, ``iniziale``), Portuguese (``altura de queda``).
DROP_WORDS = ("drop", "releas", "initial", "start", "fall", "abwurf", "ausgangsh", "chute", "lach", "caid",
              "inicial", "cadut", "inizial", "queda", "soltur")
#: Word beginnings that mark a rebound column: English (``Bounced to``, ``Final height``), German (``Rückprallhöhe``,
#: ``Rueckprallhoehe``, ``Sprunghöhe``, ``Rücksprunghöhe``, ``Abprallhöhe``, ``Steighöhe``, ``Endhöhe``,
#: ``Höhe nach dem Aufprall``), French (``hauteur du rebond``), Spanish and Portuguese (``altura de rebote``,
#: ``altura do ressalto``, ``quique``), Italian (``altezza di rimbalzo``).
REBOUND_WORDS = ("rebound", "bounc", "return", "reach", "final", "ruckprall", "rueckprall", "rucksprung",
                 "ruecksprung", "abprall", "sprung", "steigh", "endh", "aufprall", "rebond", "rebot", "ressalt",
                 "quique", "rimbalz")
#: What a drop table's header must name (the error of a table whose columns are not recognised).
NAMING = ("a drop table needs a drop-height column ('H', 'drop', 'Fallhöhe', 'hauteur de chute') and a rebound "
          "column ('h', 'rebound', 'Rückprallhöhe', 'hauteur du rebond')")
#: Words of a height column in any of the languages above (a table of heights the names do not say more of).
_HEIGHT_WORDS = ("height", "hohe", "hoehe", "hauteur", "altura", "altezza", "apex")
#: A rebound column numbered by trial (``Trial 2``), or numbered without saying whether by trial or by
#: bounce (``Rebound 2``, ``Bounce 2``: the values decide, :func:`_trials_or_rebounds`).
_TRIAL_WORDS = ("trial", "run", "try", "attempt", "test", "measurement", "versuch", "messung", "essai", "intento",
                "prova", "tentativo", "tentative", "ensayo", "medicion", "mesure", "durchgang")
_TRIAL = re.compile(rf"^(?:{'|'.join(_TRIAL_WORDS)})\s*#?\s*(\d+)$")
_NUMBERED = re.compile(r"^(?:rebound|bounce|rebound height|bounce height)\s*#?\s*(\d+)$")
#: ... or by an ordinal before it (``1st bounce``, ``Second rebound``, ``3rd bounce height``).
_ORDINAL_WORDS = ("first", "second", "third", "fourth", "fifth", "sixth", "seventh", "eighth", "ninth", "tenth")
_ORDINAL = re.compile(rf"^(?:(\d+)\s*(?:st|nd|rd|th)|({'|'.join(_ORDINAL_WORDS)}))\s+(?:rebound|bounce)(?:\s+height)?$")
#: Any column numbered after its name (``h2``, ``Rückprallhöhe 2``, ``hauteur de rebond 2``, ``Drop 2``,
#: ``Versuch 2``) or by a number before it (``2. Versuch``, ``2nd bounce``, ``2e essai``): the stem and the number
#: (:func:`_stem_number`).
_AFTER = re.compile(r"^(?P<stem>.*?[^\d\s#])\s*#?\s*(?P<n>\d+)$")
_BEFORE = re.compile(r"^(?P<n>\d+)\s*(?:\.|st|nd|rd|th|e|er|re|eme|ème|º|°|o|a)?\s+(?P<stem>\D.*)$")
#: Names of a column that numbers the trials or rows (read by no one, and no note needed).
_INDEX_NAMES = ("trial", "trials", "trial #", "trial no", "trial number", "run", "n", "no", "nr", "#", "number",
                "index", "versuch", "essai", "intento", "prova", "attempt", "try", "test", "measurement")
#: Word beginnings of a text column naming what was dropped (``Ball``, ``Ball type``, ``Balle``, ``Pelota``,
#: ``Object``, ``Material``): rows whose values differ are different balls (:func:`_unread_notes`).
BALL_WORDS = ("ball", "pelota", "palla", "bola", "object", "objekt", "objet", "oggett", "type", "typ", "kind",
              "sorte", "materi")
#: ... and onto what (``Surface``, ``Floor``, ``Boden``, ``Untergrund``, ``Suelo``).
SURFACE_WORDS = ("surface", "floor", "ground", "boden", "untergrund", "suelo", "superfici", "pavimento")
#: Word beginnings (folded, :func:`_folded`) of a column derived from the trials, not read: an average or a mean
#: (``Average``, ``Mean``, ``Mittelwert``, ``Durchschnitt``, ``moyenne``, ``promedio``, ``media``, ``média``).
DERIVED_WORDS = ("average", "mean", "avg", "mittelwert", "durchschn", "moyen", "promedio", "media", "medio")
#: Word beginnings of a column of comments (named in a note whatever its rows hold).
COMMENT_WORDS = ("comment", "note", "remark", "observ", "bemerk", "kommentar", "notiz", "remarque", "comentario",
                 "commento", "nota")
#: A column named just as a height (folded, :func:`_folded`): the drop height when the other height columns are
#: rebounds with a length unit (``Height (cm), Rebound height (cm)``, ``Height (cm), Bounce (cm)``, ``Höhe (cm),
#: Sprunghöhe (cm)``).
_PLAIN_HEIGHTS = ("height", "hohe", "hoehe", "hauteur", "altura", "altezza")


def _length_unit(c):
    """True for a column that may hold heights: no unit, a length unit, or a unit of letters that is no
    time unit (``H (yd)``: the parser then names it with the known ones)."""
    return c.unit == "" or c.unit in LENGTH_UNITS or (c.unit.isalpha() and c.unit not in TIME_UNITS)


def _folded(name):
    """``name`` in lower case without accents (``Rückprallhöhe`` -> ``ruckprallhohe``, ``caída`` -> ``caida``)."""
    decomposed = unicodedata.normalize("NFKD", name.lower().replace("ß", "ss"))
    return "".join(ch for ch in decomposed if not unicodedata.combining(ch))


def _has_word(name, starts):
    return any(word.startswith(starts) for word in re.split(r"[\s/_'-]+", _folded(name)))


class DropColumns(NamedTuple):
    """The height columns of a drop table: the drop height, one ``{bounce: Column}`` per trial of a row
    (bounce 1 the first rebound, 2 the next, ...), and numbered rebound columns whose values must say
    whether they are trials or successive rebounds (then ``trials`` is empty)."""

    drop: object
    trials: list
    numbered: list   # trial-or-rebound columns the values must decide between (``Rebound 1``, ``Rebound 2``)


def _stem_number(name):
    """``(stem, number)`` of a column named with a number after its name or before it (``h2`` -> ``('h', 2)``,
    ``Rückprallhöhe 2`` -> ``('rückprallhöhe', 2)``, ``2. Versuch`` -> ``('versuch', 2)``, ``2nd bounce``,
    ``Second rebound`` -> ``('rebound', 2)``), or None."""
    m = _ORDINAL.match(name)
    if m is not None and m.group(2):
        return name.split(None, 1)[1], _ORDINAL_WORDS.index(m.group(2)) + 1
    m = _AFTER.match(name) or _BEFORE.match(name)
    if m is None:
        return None
    return m.group("stem").strip(" .#-"), int(m.group("n"))


def _numbered_group(heights):
    """``(stem, columns)``: the columns of ``heights`` that number one stem 1, 2, ..., N (N >= 2, in that
    order) -- a trial's or a rebound's columns whatever the word (``h1, h2, h3``, ``Trial 1, ...``, ``Drop 1, ...``,
    ``Rückprallhöhe 1, ...``, ``1. Versuch, ...``) -- or None. The stem is a trial (:data:`_TRIAL_WORDS`), ``h``, or a
    word of a height, a drop or a rebound."""
    groups = {}
    for c in heights:
        found = _stem_number(c.name)
        if found is not None:
            groups.setdefault(_folded(found[0]), []).append((found[1], c))
    for stem, members in groups.items():
        numbers = sorted(n for n, _ in members)
        if len(members) < 2 or numbers != list(range(1, len(members) + 1)):
            continue
        if stem in ("h", *_TRIAL_WORDS) or _has_word(stem, _HEIGHT_WORDS + DROP_WORDS + REBOUND_WORDS):
            return stem, [c for _, c in sorted(members, key=lambda m: m[0])]
    return None


def _height_columns(cols):
    """:class:`DropColumns` of a drop table, or None when the columns are not one."""
    heights = [c for c in cols if _length_unit(c)]
    group = _numbered_group(heights)
    numbered = {c.index for c in group[1]} if group else set()
    drop = _drop_column([c for c in heights if c.index not in numbered])
    if drop is not None:
        return _rebound_columns(drop, heights)
    # a class's 'Height (cm), Rebound height (cm)': the height beside the rebounds is the drop height
    plain = next((c for c in heights if _folded(c.name) in _PLAIN_HEIGHTS and c.index not in numbered), None)
    found = None if plain is None else _rebound_columns(plain, heights)
    if found is None or not all(c.unit or _names_rebound(c) for c in _rebounds_of(found)):
        return None
    return found


def _drop_column(heights):
    """The column of ``heights`` named as the drop height (``H``, :data:`DROP_NAMES`, a word of
    :data:`DROP_WORDS` and none of a rebound), or None."""
    return next((c for c in heights if c.raw in ("H", "H0", "H 0")), None) or find_column(heights, DROP_NAMES) \
        or next((c for c in heights if _has_word(c.name, DROP_WORDS) and not _has_word(c.name, REBOUND_WORDS)),
                None)


def _names_rebound(c):
    """True when column ``c`` is a rebound height by its name alone, without a unit: a word of a rebound and
    one of a height (``Rebound height``, ``Bounce height``, ``Rückprallhöhe``, ``hauteur du rebond``), or
    ``rebound``; not a bare ``bounce`` (an apex file's bounce number), ``Bounce time`` nor ``h1``."""
    folded = _folded(c.name)
    return _has_word(c.name, REBOUND_WORDS) and (c.name in REBOUND_NAMES or any(w in folded for w in _HEIGHT_WORDS))


def _rebounds_of(found):
    """The rebound columns of :class:`DropColumns` ``found``."""
    return found.numbered + [c for trial in found.trials for c in trial.values()]


def _rebound_without_drop(cols):
    """The first column that is a rebound height by its length unit (``Rebound height (cm)``, ``Bounce (cm)``)
    or its name (:func:`_names_rebound`) of a table that has no drop-height column (:func:`_height_columns` is
    None), else None."""
    if _height_columns(cols) is not None:
        return None
    return next((c for c in cols if _length_unit(c) and ((c.unit and _has_word(c.name, REBOUND_WORDS))
                                                         or (not c.unit and _names_rebound(c)))), None)


def _rebound_columns(drop, heights):
    """:class:`DropColumns` of the drop column ``drop`` and the other columns of ``heights``, or None when
    none of them is a rebound."""
    rest = [c for c in heights if c.index != drop.index]
    group = _numbered_group(rest)
    if group is not None:   # one rule for numbered columns: a trial word says trials, else the values decide
        stem, members = group
        return DropColumns(drop, [{1: c} for c in members], []) if stem in _TRIAL_WORDS \
            else DropColumns(drop, [], members)
    trials = [c for c in rest if _TRIAL.match(c.name)]
    if len(trials) >= 2:
        return DropColumns(drop, [{1: c} for c in trials], [])
    numbered = [c for c in rest if _bounce_number(c.name) is not None]
    if len(numbered) >= 2:
        numbered.sort(key=lambda c: _bounce_number(c.name))
        return DropColumns(drop, [], numbered)
    rebound = find_column(rest, REBOUND_NAMES) or next((c for c in rest if c.raw == "h"), None) \
        or next((c for c in rest if _has_word(c.name, REBOUND_WORDS) and c.unit), None) \
        or next((c for c in rest if _has_word(c.name, REBOUND_WORDS) and c.name not in BOUNCE_NAMES), None)
    if rebound is None and len(rest) == 1 and rest[0].name in BOUNCE_NAMES and drop.name != "height":
        rebound = rest[0]   # 'drop, bounce': beside a drop height no bounce number (an apex file has no drop)
    if rebound is None:
        return None
    out = {1: rebound}
    for c in rest:
        m = _MORE.match(c.name)
        if m and int(m.group(1)) >= 2 and c.index != rebound.index:
            out.setdefault(int(m.group(1)), c)
    return DropColumns(drop, [out], [])


def _bounce_number(name):
    """The number of a rebound column numbered after its name (``Bounce 2``) or by an ordinal before it
    (``2nd bounce``, ``Second rebound``), or None."""
    m = _NUMBERED.match(name) or _ORDINAL.match(name)
    if m is None:
        return None
    if m.re is _ORDINAL and m.group(2):
        return _ORDINAL_WORDS.index(m.group(2)) + 1
    return int(m.group(1))


def _inch_columns(cols):
    """``(cols, renamed)``: the columns with a name ending in ``in`` after ``_`` or a blank and no unit
    (``drop_in``, ``H_in``, ``rebound in``) read as inches (``drop (in)``) when the columns so read are a
    drop table whose heights include them; ``renamed`` holds their indices. Else ``(cols, ())``: only a
    drop or rebound column reads ``_in`` so (a trajectory's ``y_in`` keeps its name,
    :data:`vrcal.measurements.table._SUFFIX_UNIT`)."""
    inches = [c._replace(name=c.name[:-3].rstrip(), raw=c.raw[:-3].rstrip(), unit="in")
              if not c.unit and len(c.name) > 3 and c.name.endswith(" in") else c for c in cols]
    renamed = [c.index for c, d in zip(cols, inches) if c is not d]
    found = _height_columns(inches) if renamed else None
    if found is None:
        return cols, ()
    used = {c.index for c in [found.drop, *_rebounds_of(found)]}
    renamed = tuple(i for i in renamed if i in used)
    return (inches, renamed) if renamed else (cols, ())


def _trials_or_rebounds(path, line, values, columns):
    """Numbered rebound columns as trials ([{1: c}, ...]) when their values agree row by row (each
    within 25 % of the first), as successive rebounds of one drop ([{1: c1, 2: c2, ...}]) when every
    one is below the one before; a note says which, and neither is an error naming the header's
    ``line``. ``values``: (rows, columns) heights."""
    first = values[:, :1]
    with np.errstate(invalid="ignore", divide="ignore"):
        agree = np.abs(values / first - 1.0) <= 0.25
        falling = np.diff(values, axis=1) < 0
    finite = np.isfinite(values)   # an empty cell (a trial not made) says nothing either way
    agree, falling = agree[finite & finite[:, :1]].all(), falling[finite[:, 1:] & finite[:, :-1]].all()
    names = ", ".join(f"'{c.raw}'" for c in columns)
    if agree and not falling:
        return [{1: c} for c in columns], f"columns {names}: trials of the row's drop height (their values agree)"
    if falling:
        return [dict(enumerate(columns, start=1))], f"columns {names}: successive rebounds of one drop"
    fail(path, line, f"columns {names} neither agree (trials of one drop height) nor fall one after another "
                     f"(successive rebounds of one drop): name them 'Trial 1', 'Trial 2', ... (trials) or 'h', 'h2', "
                     f"'h3', ... (successive rebounds)")


def _beside_a_drop(cols, bounce):
    """True when the only other column of heights beside ``bounce`` is named as a drop height (``drop,
    bounce``, ``Drop height, Bounce``): the rebound of a drop table, not an apex file's bounce number (an apex
    file has a height column and no drop)."""
    other = [c for c in cols if c.index != bounce.index and _length_unit(c)]
    return len(other) == 1 and _drop_column(other) is not None


def _trial_columns(cols):
    """``cols`` with the data set's name put back after the names of columns that differ by it alone (``Rebound
    (cm) Run 1``, ``Rebound (cm) Run 2``, read by :func:`vrcal.measurements.table.columns` as ``Rebound (cm)`` of
    the data sets ``Run 1`` and ``Run 2``): in a drop table, runs side by side are trials, their data set's name
    tells which (``Rebound Run 1 (cm)``)."""
    if cols is None:
        return None
    count = {}
    for c in cols:
        count[(c.name, c.unit)] = count.get((c.name, c.unit), 0) + 1
    return [c._replace(name=f"{c.name} {c.data_set.lower()}", raw=f"{c.raw} {c.data_set}")
            if c.data_set and count[(c.name, c.unit)] > 1 else c for c in cols]


def _header_columns(text):
    """:func:`vrcal.measurements.table.header_columns` with trials told apart by their data set
    (:func:`_trial_columns`)."""
    return _trial_columns(header_columns(text))


def detect(text):
    cols = _header_columns(text)
    if not cols or find_column(cols, TIME_NAMES) is not None:
        return False
    number = find_column(cols, BOUNCE_NAMES)
    if number is not None and not (number.unit and _length_unit(number)) and not _beside_a_drop(cols, number):
        return False   # a bounce-number column: an apex file
    cols = _inch_columns(cols)[0]
    return _height_columns(cols) is not None or _rebound_without_drop(cols) is not None


def looks_like_heights(text):
    """True when the header names two or more columns of heights (a length unit, or a word of a height,
    a drop or a rebound in a language above) and no time, over a row of numbers there: a drop table
    whose names are not recognised (the error then says how to name them, :data:`NAMING`)."""
    cols = _header_columns(text)
    if not cols or len(text.lines) < 2 or find_column(cols, TIME_NAMES) is not None:
        return False
    heights = [c for c in cols if (c.unit and _length_unit(c))
               or _has_word(c.name, _HEIGHT_WORDS + DROP_WORDS + REBOUND_WORDS)]
    if len(heights) < 2:
        return False
    sep, decimal_comma = sniff(text.lines[0][1], [s for _, s in text.lines[1:21]])
    cells = split_cells(text.lines[1][1], sep)
    return all(c.index < len(cells) and to_float(cells[c.index], decimal_comma) is not None for c in heights)


#: Most lines of a headerless table that :func:`headerless_hint` takes for a class's drop table.
MAX_HINTED_ROWS = 40


def headerless_hint(text):
    """The header that makes a headerless table of three or more numbers per line a drop table
    (``'Drop height (cm),Trial 1 (cm),Trial 2 (cm),Trial 3 (cm),Average (cm)'``, with the file's separator;
    ``'Drop_height_cm Trial_1_cm ...'`` between blanks) when its numbers look like one --
    in every line the first, a drop height, above every other, none of them negative, and the trials of a
    line within a factor 2 of each other; at most :data:`MAX_HINTED_ROWS` lines (a class's table, not a
    track: pixel columns x, y and a time column of 114 lines are no drop table); the last column an
    average when it is the mean of the others in most lines -- else None."""
    if len(text.lines) > MAX_HINTED_ROWS:
        return None
    sep, decimal_comma = sniff(text.lines[0][1], [s for _, s in text.lines[1:21]])
    rows = [[to_float(c, decimal_comma) for c in split_cells(s, sep)] for _, s in text.lines]
    width = len(rows[0])
    if width < 3 or any(len(r) != width or None in r for r in rows):
        return None
    values = np.array(rows, dtype=float)
    if not (np.all(values[:, 1:] > 0) and np.all(values[:, :1] > values[:, 1:])
            and np.all(values[:, 1:].max(axis=1) <= 2.0 * values[:, 1:].min(axis=1))):
        return None
    n = width - 1
    mean = values[:, 1:-1].mean(axis=1)
    if width >= 4 and np.mean(np.abs(values[:, -1] - mean) <= 0.02 * values[:, -1] + 0.01) > 0.8:
        n -= 1   # the last column the trials' average (a wrong one in a line or two: a sheet's typing)
    unit = "cm" if values[:, 0].max() > 3 else "m"
    names = ["Drop height"] + [f"Trial {k}" for k in range(1, n + 1)] + (["Average"] if n < width - 1 else [])
    if sep in (None, " "):   # blanks separate the cells: names without blanks, the unit after '_'
        return " ".join(f"{name.replace(' ', '_')}_{unit}" for name in names)
    return sep.join(f"{name} ({unit})" for name in names)


def no_header_message(header):
    """The error of a file whose first line holds numbers: how to name its columns -- ``header``, the one
    :func:`headerless_hint` gives a drop table, when not None."""
    if header is not None:
        return (f"no header row: the first line holds numbers; for a drop height and its trials, give the file the "
                f"header '{header}' (check the unit)")
    return "no header row: the first line holds numbers; name the columns (e.g. 't,y', 't', 'bounce,h')"


def transposed(text):
    """``(trials, rows)`` of a table written with the trials as columns and the bounces as rows (``Data,Trial
    1,Trial 2,...`` over ``Bounce_1,18.125,17.875,...``), the layout vrcal does not read (one trial per row),
    else None: the header's cells after the first name trials (:data:`_TRIAL`) and every row starts with a
    bounce or a drop (``Bounce_1``, ``2nd bounce``, ``Drop``) before numbers."""
    cols = _header_columns(text)
    if not cols or len(cols) < 3 or not all(_TRIAL.match(c.name) for c in cols[1:]):
        return None
    sep, decimal_comma = sniff(text.lines[0][1], [s for _, s in text.lines[1:21]])
    rows = [split_cells(s, sep) for _, s in text.lines[1:]]
    if not rows or any(len(r) < 2 or to_float(r[1], decimal_comma) is None for r in rows):
        return None
    names = [r[0] for r in rows]
    bounce_like = [_bounce_number(" ".join(_folded(n).replace("_", " ").split())) is not None
                   or _has_word(n, DROP_WORDS) for n in names]
    return ([c.raw for c in cols[1:]], names) if all(bounce_like) else None


def transposed_hint(text):
    """The one-line refusal of a :func:`transposed` table: what vrcal reads instead."""
    trials, rows = transposed(text)
    shown = ", ".join(rows[:3]) + (", ..." if len(rows) > 3 else "")
    return (f"trials as columns ({trials[0]}, ...), bounces as rows ({shown}), no quantity or unit named: write "
            f"one trial per row, e.g. 'Drop height (in),h1 (in),h2 (in)' (flight times: each trial's impact "
            f"times, 't (s)')")


def _unit_factors(path, table, columns, scale_m_per_px, notes):
    """{column index: factor to m} of the height columns (a column without a unit takes the others')."""
    units = {c.unit for c in columns if c.unit}
    factors = {}
    for c in columns:
        unit = c.unit
        if not unit and len(units) == 1:
            unit = next(iter(units))
            notes.append(f"column '{c.raw}' has no unit: taken as {unit} like the other heights")
        if scale_m_per_px is not None:   # metres per file unit, whatever the unit (a brick's height)
            factors[c.index] = float(scale_m_per_px)
            continue
        if unit_factor(path, table, c, LENGTH_UNITS, "length", unit=unit, heights=True) is None:
            raise UsageError(f"{path}: column '{c.raw}' is in pixels: give --scale M_PER_PX")
        factors[c.index] = LENGTH_UNITS[unit]
    if scale_m_per_px is not None:
        notes.append(f"heights scaled by --scale {scale_m_per_px:g} m per file unit")
        return factors
    if units - {"m"}:
        notes.append(f"heights converted from {', '.join(sorted(units - {'m'}))} to m")
    return factors


def _written_step_m(raw, factors, cells):
    """The step [m] the rebounds were written to (``raw``: {column index: the file's numbers} of the
    rebound columns; ``factors``: {column index: factor to m}; ``cells``: {column index: its cells as
    written, whose decimals count, trailing zeros too}): the printed resolution of all of a unit's
    numbers together (one '4' alone looks like whole feet), the coarsest over the units; None when they hold
    more than six decimals. The drop heights are left out: they are set (1 m, 100 cm), not read."""
    steps = []
    for factor in {factors[i] for i in raw}:
        written = np.concatenate([raw[i] for i in raw if factors[i] == factor])
        written = written[np.isfinite(written)]
        text = [c for i in raw if factors[i] == factor for c in cells[i]]
        step = printed_resolution(written, max_decimals=6, written=text) if written.size else None
        if step is None:
            return None
        steps.append(step * factor)
    return max(steps) if steps else None


def _distinct(cells):
    """The distinct ``cells`` in their order, told apart by neither case nor blanks ('Tennis' and 'tennis ' are
    one ball): the first spelling of each."""
    first = {}
    for c in cells:
        first.setdefault(" ".join(c.split()).casefold(), c)
    return list(first.values())


def _unread_notes(path, table, ignored):
    """The notes on the columns of ``table`` a drop table does not read (``ignored``; not a trial number): an
    average, a column of numbers, a column of text. A text column whose rows differ is said with its values:
    the rows may be of different balls, which one epsilon cannot describe; when its name says so (a word of
    :data:`BALL_WORDS` or :data:`SURFACE_WORDS`: ``Ball``, ``Ball type``, ``Surface``) that is an error naming
    the values (one file per ball); a comment column (:data:`COMMENT_WORDS`) is only named."""
    notes = []
    derived = [c.raw for c in ignored if _has_word(c.name, DERIVED_WORDS)]
    if derived:
        notes.append(f"column(s) {', '.join(repr(n) for n in derived)} not read (derived from the trials)")
    ignored = [c for c in ignored if c.raw not in derived]
    cells = {c.index: column_cells(table, c) for c in ignored}
    # a column with a word in it: its distinct cells (numbers too), in their order
    words = {i: _distinct(v) if any(to_float(c, table.decimal_comma) is None for c in v) else []
             for i, v in cells.items()}
    other = [c.raw or f"column {c.index + 1}" for c in ignored if cells[c.index] and not words[c.index]]
    if other:
        one = len(other) == 1
        notes.append(f"column(s) {', '.join(repr(n) for n in other)} not read: not a drop or rebound height by "
                     f"{'its name' if one else 'their names'} (if {'it holds' if one else 'they hold'} rebound "
                     f"heights, name the trials 'Trial 1', 'Trial 2', ... or successive rebounds 'h', 'h2', ...; "
                     f"docs/measurements.md)")
    for c in (c for c in ignored if words[c.index]):
        name, values = c.raw or f"column {c.index + 1}", words[c.index]
        shown = ", ".join(values[:6]) + (", ..." if len(values) > 6 else "")
        if _has_word(c.name, COMMENT_WORDS):
            notes.append(f"column '{name}' not read (comments)")
        elif len(values) == 1:
            notes.append(f"column '{name}' not read (text: '{values[0]}' in every row that fills it)")
        elif _has_word(c.name, BALL_WORDS + SURFACE_WORDS):
            what = "balls" if _has_word(c.name, BALL_WORDS) else "surfaces"
            fail(path, table.header_line, f"column '{name}' names {len(values)} different {what} ({shown}): one "
                                          f"epsilon cannot describe them all; put each {what[:-1]}'s rows in a file "
                                          f"of its own (to fit them as one on purpose, leave the column out)")
        else:
            notes.append(f"column '{name}' not read: its text differs between rows ({shown}); if the rows are "
                         f"different balls or surfaces, one epsilon does not describe them: put each one's rows in "
                         f"a file of its own")
    return notes


def _runs_of_rows(path, table, drop, trials, values, resolution_m):
    """``(runs, labels, skipped, not_made)``: an :class:`ApexHeights` and its label per trial of each row of ``table``
    (``values``: {column index: heights [m], NaN where a cell is empty}), and the file's lines of the rows
    skipped for want of a first rebound (a trial not measured, or a class's sheet with its trial numbers written
    ahead), and the empty cells of trials side by side (``"line 3 'Trial 2'"``: a trial not made). An empty drop
    height beside a rebound is an error naming its line; no trial left is one too."""
    line_numbers = row_lines(table)
    H = values[drop.index]
    per_row = len(trials)
    runs, labels, skipped, not_made = [], [], [], []
    for k, no in enumerate(line_numbers):
        made = [[b for b in sorted(trial) if np.isfinite(values[trial[b].index][k])] for trial in trials]
        if not any(bounces and bounces[0] == 1 for bounces in made):
            skipped.append(int(no))   # no trial of this row has its first rebound
            continue
        if not np.isfinite(H[k]):
            fail(path, int(no), f"empty cell in column '{drop.raw}': a trial needs its drop height")
        for trial, bounces in zip(trials, made):
            if not bounces or bounces[0] != 1:
                not_made.append(f"line {int(no)} '{trial[1].raw}'")
                continue   # trials side by side: a trial not made at this height (an empty cell)
            h = np.array([H[k]] + [values[trial[b].index][k] for b in bounces])
            bad = np.flatnonzero(h <= 0)
            if bad.size:
                fail(path, int(no), f"height {h[bad[0]]:g} m is not positive")
            runs.append(ApexHeights(bounce=np.array([0] + bounces), h_m=h, source=f"{path}:{int(no)}",
                                    notes=(), lines=np.full(len(bounces) + 1, int(no)), resolution_m=resolution_m))
            labels.append(f"row {k + 1} (line {int(no)})" + (f", '{trial[1].raw}'" if per_row > 1 else ""))
    if not runs:
        fail(path, int(line_numbers[-1]), "no trial with a drop height and a rebound")
    return runs, labels, skipped, not_made


def parse(text, *, scale_m_per_px=None, y_down=False, fs_hz=None):
    path = text.path
    header = headerless_hint(text) if header_columns(text) is None else None
    if header is not None:
        fail(path, text.lines[0][0], no_header_message(header))
    table = parse_table(text)
    table = table._replace(cols=_trial_columns(table.cols))
    cols, renamed = _inch_columns(table.cols)
    found = _height_columns(cols)
    if found is None:
        rebound = _rebound_without_drop(cols)
        if rebound is not None:
            fail(path, table.header_line, f"no drop-height column: name it e.g. 'Drop height ({rebound.unit or 'cm'})' "
                                          f"(column '{rebound.raw}' is the rebound height)")
        fail(path, table.header_line, NAMING)
    if not table.rows:
        fail(path, table.header_line, "header but no data rows")
    columns = [found.drop] + _rebounds_of(found)
    notes = []
    if renamed:
        header = split_cells(next(s for no, s in text.lines if no == table.header_line), table.sep)
        notes.append(f"column(s) {', '.join(repr(header[i]) for i in renamed)}: the 'in' after the name read as "
                     f"inches (write the unit in brackets to say so: 'H (in)', 'H (cm)')")
    factors = _unit_factors(path, table, columns, scale_m_per_px, notes)
    raw = {c.index: column_values(path, table, c, what="height", allow_empty=True) for c in columns}
    values = {i: raw[i] * factors[i] for i in raw}
    resolution_m = _written_step_m({i: v for i, v in raw.items() if i != found.drop.index}, factors,
                                   {c.index: column_cells(table, c) for c in columns})
    trials = found.trials
    if found.numbered:
        trials, how = _trials_or_rebounds(path, table.header_line,
                                          np.column_stack([values[c.index] for c in found.numbered]), found.numbered)
        notes.append(how)
    per_row = len(trials)
    names = ", ".join(f"'{c.raw}'" for c in [found.drop] + [c for t in trials for c in t.values()])
    what = "one trial per row" if per_row == 1 else f"{per_row} trials per row, side by side"
    notes.insert(0, f"format: drop table ({what}; drop and rebound heights from columns {names})")
    notes += _unread_notes(path, table, [c for c in table.cols if c.index not in values and c.name not in _INDEX_NAMES])
    runs, labels, skipped, not_made = _runs_of_rows(path, table, found.drop, trials, values, resolution_m)
    if not_made:
        said = ", ".join(not_made[:6]) + (", ..." if len(not_made) > 6 else "")
        count = f"{len(not_made)} in all; " if len(not_made) > 1 else ""
        notes.append(f"{said}: empty, a trial not made ({count}the row's other trials are fitted)")
    if skipped:
        said = ", ".join(str(n) for n in skipped[:8]) + (", ..." if len(skipped) > 8 else "")
        notes.append(f"line {said}: no first rebound (an empty cell): row skipped" if len(skipped) == 1 else
                     f"lines {said}: no first rebound (empty cells): {len(skipped)} rows skipped")
    drops_m = [float(run.h_m[0]) for run in runs]
    lo, hi = f"{min(drops_m):.3g}", f"{max(drops_m):.3g}"
    notes.append(f"{len(runs)} trial(s), " + (f"drop height {lo} m" if lo == hi else f"drop heights {lo}-{hi} m"))
    return Runs(runs=tuple(runs), source=path, notes=tuple(notes), labels=tuple(labels))
