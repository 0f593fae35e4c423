"""The association ball standards: load, validate, look up, and turn into epsilon (Eq. 9).

``standards.yaml`` (shipped with vrcal) is data with a schema; every load validates it
and a bad field is reported by its path (``balls.tennis.rebound_m.max``), an unknown key
with the closest allowed one. A user file given with ``--standards FILE`` follows the same
schema and replaces the shipped balls. Every ball, shipped or not, must pass the rules of
:mod:`vrcal.model.plausible` that ``--mass``/``--diameter`` and ``fit --drop-height`` pass
(a density a ball can have, heights of a drop test): a unit slip is named, not computed.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

from vrcal.errors import DataError, UsageError, closest_name
from vrcal.fileio import parse_yaml, read_yaml
from vrcal.model.plausible import check_ball_size, check_drop_test_height
from vrcal.model.restitution import POINT_OFFSET_DIAMETERS, epsilon_from_heights, height_to_bottom_m

SCHEMA_VERSION = 1
POINTS = tuple(sorted(POINT_OFFSET_DIAMETERS))
_REQUIRED_STR = ("name", "association", "rule", "floor", "conditions")


@dataclass(frozen=True)
class Range:
    """A closed interval [min, max] with a nominal value inside it."""

    min: float
    max: float
    nominal: float

    def as_dict(self):
        return {"min": self.min, "nominal": self.nominal, "max": self.max}


@dataclass(frozen=True)
class PaperValues:
    """What the paper's Table 1 (and Table 2, where present) prints for a ball."""

    drop_height_m: float
    rebound_min_m: float | None
    rebound_max_m: float | None
    epsilon_min: float | None
    epsilon_max: float | None
    printed: str
    table2: dict | None


@dataclass(frozen=True)
class Ball:
    """One ball of a standard, validated, in SI units."""

    key: str
    name: str
    association: str
    rule: str
    official: bool
    mass_kg: Range
    diameter_m: Range
    drop_height_m: float
    drop_measured_to: str
    rebound_m: Range
    rebound_measured_to: str
    floor: str
    conditions: str
    source: tuple
    paper: PaperValues | None
    departures: tuple
    aliases: tuple = ()
    measured_to_stated: bool = True

    @property
    def radius_m(self):
        """Nominal radius [m]."""
        return self.diameter_m.nominal / 2.0


@dataclass(frozen=True)
class EpsilonWindow:
    """epsilon of a ball's drop test (Eq. 9), with the heights it came from."""

    min: float
    nominal: float
    max: float
    drop_height_m: float
    rebound_m: Range
    convention: str

    def as_dict(self):
        return {"min": self.min, "nominal": self.nominal, "max": self.max}


class Standards(dict):
    """ball key -> :class:`Ball`, in file order, with the file they came from (``path``: None for the
    shipped ``standards.yaml``), so that a failed lookup can say where the balls came from."""

    def __init__(self, balls=(), path=None):
        super().__init__(balls)
        self.path = path


# --------------------------------------------------------------------------- loading


def _default_path():
    """The shipped ``vrcal/standards.yaml`` (beside the package's modules; importlib.resources only
    when the package is not a plain directory, e.g. zipped -- it costs start-up time)."""
    path = Path(__file__).resolve().parents[1] / "standards.yaml"
    if path.is_file():
        return path
    from importlib import resources

    return resources.files("vrcal").joinpath("standards.yaml")


def load_standards(path=None):
    """Load and validate a standards file; the shipped one when ``path`` is None.

    Parameters
    ----------
    path : str or Path or None
        a YAML file following the schema in ``vrcal/standards.yaml``

    Returns
    -------
    Standards
        ball key -> :class:`Ball`, in file order; a user's file replaces the shipped balls

    Raises
    ------
    DataError
        unreadable file, malformed YAML (with file and line), a field that breaks the
        schema (with its path; an unknown key with the closest allowed one), or a ball
        that cannot exist (:mod:`vrcal.model.plausible`: a mass or size in the wrong
        unit, a drop test above 20 m; with the likely unit slip)
    """
    if path is None:
        return _load_default()
    return _load_file(Path(path))


def standards_file(path=None):
    """Where the standards file is and its text: the shipped ``standards.yaml`` when ``path`` is None (the
    file to copy and edit for ``--standards FILE``: in an installed vrcal it lies in the package, not in
    the working directory), else ``path``'s, validated first (:func:`load_standards`).

    Returns
    -------
    (str, str)
        the file's path and its text

    Raises
    ------
    DataError
        ``path`` that cannot be read or breaks the schema (as :func:`load_standards`)
    """
    load_standards(path)
    src = _default_path() if path is None else Path(path)
    return str(src), src.read_text(encoding="utf-8")


@lru_cache(maxsize=1)
def _load_default():
    src = _default_path()
    return validate_standards(parse_yaml(src.read_text(encoding="utf-8"), "vrcal/standards.yaml", trusted=True),
                              "vrcal/standards.yaml")


def _load_file(path):
    out = validate_standards(read_yaml(path, "standards"), str(path))
    out.path = str(path)
    return out


#: The keys of a standards document, of a ball's entry, of a range and of a ball's ``paper:`` block.
_TOP_KEYS = ("schema_version", "balls")
_BALL_KEYS = (*_REQUIRED_STR, "official", "mass_kg", "diameter_m", "circumference_m", "drop_height_m",
              "drop_measured_to", "rebound_m", "rebound_measured_to", "measured_to_stated", "source", "paper",
              "departures", "aliases")
_RANGE_KEYS = ("min", "max", "nominal")
_PAPER_KEYS = ("drop_height_m", "rebound_min_m", "rebound_max_m", "epsilon_min", "epsilon_max", "printed", "table2")


def validate_standards(doc, where="standards"):
    """Validate a parsed standards document and build the :class:`Ball` objects (a :class:`Standards`)."""
    if not isinstance(doc, dict):
        raise DataError(f"{where}: top level must be a mapping with 'schema_version' and 'balls'")
    _known_keys(doc, _TOP_KEYS, where, "")
    version = doc.get("schema_version")
    if version != SCHEMA_VERSION:
        raise DataError(f"{where}: schema_version must be {SCHEMA_VERSION}, got {version!r}")
    balls = doc.get("balls")
    if not isinstance(balls, dict) or not balls:
        raise DataError(f"{where}: 'balls' must be a non-empty mapping of ball key -> fields")
    out = Standards()
    for key, fields in balls.items():
        path = f"balls.{key}"
        if not isinstance(key, str) or not key.replace("_", "").isalnum() or key != key.lower():
            raise DataError(f"{where}: {path}: ball keys must be lower-case words (letters, digits, '_')")
        out[key] = _ball(key, fields, where, path)
    named = {}
    for key, ball in out.items():
        for alias in ball.aliases:
            if alias in out or alias in named:
                raise _err(where, f"balls.{key}.aliases", f"'{alias}' already names the ball "
                                                          f"'{alias if alias in out else named[alias]}'")
            named[alias] = key
    return out


def _err(where, path, msg):
    return DataError(f"{where}: {path}: {msg}")


def _known_keys(fields, allowed, where, path):
    """Refuse a key not in ``allowed`` -- before any required field is missed because of its typo --
    naming the closest allowed key and all of them."""
    unknown = [str(k) for k in fields if str(k) not in allowed]
    if not unknown:
        return
    listed = f"allowed: {', '.join(sorted(allowed))}"
    guesses = {k: closest_name(k, allowed) for k in unknown}
    if len(unknown) == 1:
        k = unknown[0]
        guess = f"; did you mean '{guesses[k]}'?" if guesses[k] else ""
        raise _err(where, f"{path}.{k}" if path else k, f"unknown key{guess} ({listed})")
    named = ", ".join(f"'{k}'" + (f" (did you mean '{guesses[k]}'?)" if guesses[k] else "") for k in unknown)
    raise _err(where, path or "top level", f"unknown keys {named}; {listed}")


def _number(fields, name, where, path, *, positive=True, required=True):
    if name not in fields or fields[name] is None:
        if required:
            raise _err(where, f"{path}.{name}", "missing")
        return None
    value = fields[name]
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not abs(value) <= 1e308:  # nan, inf, huge
        raise _err(where, f"{path}.{name}", f"must be a number, got {value!r}")
    if positive and value <= 0:
        raise _err(where, f"{path}.{name}", f"must be > 0, got {value!r}")
    if value < 0:
        raise _err(where, f"{path}.{name}", f"must be >= 0, got {value!r}")
    return float(value)


def _range(fields, name, where, path, required=True):
    sub = fields.get(name)
    if sub is None:
        if required:
            raise _err(where, f"{path}.{name}", "missing")
        return None
    if not isinstance(sub, dict):
        raise _err(where, f"{path}.{name}", "must be a mapping {min: ..., max: ...}")
    p = f"{path}.{name}"
    _known_keys(sub, _RANGE_KEYS, where, p)
    lo = _number(sub, "min", where, p)
    hi = _number(sub, "max", where, p)
    if lo > hi:
        raise _err(where, p, f"min ({lo:g}) is larger than max ({hi:g})")
    nominal = _number(sub, "nominal", where, p, required=False)
    if nominal is None:
        nominal = 0.5 * (lo + hi)
    elif not lo <= nominal <= hi:
        raise _err(where, f"{p}.nominal", f"{nominal:g} lies outside [{lo:g}, {hi:g}]")
    return Range(lo, hi, nominal)


def _string(fields, name, where, path):
    value = fields.get(name)
    if not isinstance(value, str) or not value.strip():
        raise _err(where, f"{path}.{name}", "missing" if value is None else f"must be text, got {value!r}")
    return value


def _point(fields, name, where, path):
    value = fields.get(name)
    if value not in POINTS:
        raise _err(where, f"{path}.{name}", f"must be one of {list(POINTS)}, got {value!r}")
    return value


def _ball(key, fields, where, path):
    if not isinstance(fields, dict):
        raise _err(where, path, "must be a mapping of fields")
    _known_keys(fields, _BALL_KEYS, where, path)
    strings = {name: _string(fields, name, where, path) for name in _REQUIRED_STR}
    official = fields.get("official", True)
    if not isinstance(official, bool):
        raise _err(where, f"{path}.official", f"must be true or false, got {official!r}")
    mass = _range(fields, "mass_kg", where, path)
    diameter = _range(fields, "diameter_m", where, path, required=False)
    circumference = _range(fields, "circumference_m", where, path, required=False)
    if diameter is None and circumference is None:
        raise _err(where, f"{path}.diameter_m", "missing (give diameter_m or circumference_m)")
    size = "diameter_m" if diameter is not None else "circumference_m"
    if diameter is None:
        diameter = Range(circumference.min / math.pi, circumference.max / math.pi, circumference.nominal / math.pi)
    check_ball_size(mass.nominal, diameter.nominal, mass_label=f"{path}.mass_kg", size_label=f"{path}.{size}",
                    size_per_diameter=1.0 if size == "diameter_m" else math.pi, where=where, error=DataError)
    drop = _number(fields, "drop_height_m", where, path)
    drop_to = _point(fields, "drop_measured_to", where, path)
    rebound = _range(fields, "rebound_m", where, path)
    rebound_to = _point(fields, "rebound_measured_to", where, path)
    stated = fields.get("measured_to_stated", True)
    if not isinstance(stated, bool):
        raise _err(where, f"{path}.measured_to_stated", f"must be true or false, got {stated!r}")
    check_drop_test_height(drop, f"{path}.drop_height_m", where=where, field="drop_height_m", error=DataError)
    for label in ("max", "nominal"):
        check_drop_test_height(getattr(rebound, label), f"{path}.rebound_m.{label}", where=where, field="rebound_m",
                               error=DataError)
    D = diameter.nominal
    H_bottom = height_to_bottom_m(drop, drop_to, D)
    for label, h in (("min", rebound.min), ("max", rebound.max), ("nominal", rebound.nominal)):
        h_bottom = height_to_bottom_m(h, rebound_to, D)
        if h_bottom > H_bottom:
            raise _err(
                where, f"{path}.rebound_m.{label}",
                f"rebound {h:g} m is higher than the drop {drop:g} m (both taken to the ball's bottom): "
                "a ball cannot rebound higher than it fell",
            )
        if h_bottom < 0:
            raise _err(where, f"{path}.rebound_m.{label}",
                       f"rebound {h:g} m to the {rebound_to} is below the ball's resting position")
    source = fields.get("source", [])
    if isinstance(source, str):
        source = [source]
    if not isinstance(source, list) or not all(isinstance(s, str) for s in source):
        raise _err(where, f"{path}.source", "must be a list of text")
    departures = fields.get("departures", [])
    if not isinstance(departures, list) or not all(isinstance(s, str) for s in departures):
        raise _err(where, f"{path}.departures", "must be a list of text")
    aliases = fields.get("aliases", [])
    if not isinstance(aliases, list) or not all(isinstance(s, str) and normalised_name(s) for s in aliases):
        raise _err(where, f"{path}.aliases", "must be a list of names")
    paper = _paper(fields.get("paper"), where, f"{path}.paper")
    return Ball(
        key=key, official=official, mass_kg=mass, diameter_m=diameter, drop_height_m=drop,
        drop_measured_to=drop_to, rebound_m=rebound, rebound_measured_to=rebound_to,
        source=tuple(source), paper=paper, departures=tuple(departures),
        aliases=tuple(normalised_name(a) for a in aliases), measured_to_stated=stated, **strings,
    )


def _paper(fields, where, path):
    if fields is None:
        return None
    if not isinstance(fields, dict):
        raise _err(where, path, "must be a mapping")
    _known_keys(fields, _PAPER_KEYS, where, path)
    table2 = fields.get("table2")
    if table2 is not None:
        if not isinstance(table2, dict):
            raise _err(where, f"{path}.table2", "must be null or a mapping {epsilon, x, v}")
        _known_keys(table2, ("epsilon", "x", "v"), where, f"{path}.table2")
        table2 = {k: _number(table2, k, where, f"{path}.table2") for k in ("epsilon", "x", "v")}
        _epsilon(table2, "epsilon", where, f"{path}.table2")
    values = {k: _number(fields, k, where, path, required=k == "drop_height_m")
              for k in ("drop_height_m", "rebound_min_m", "rebound_max_m", "epsilon_min", "epsilon_max")}
    for k in ("drop_height_m", "rebound_min_m", "rebound_max_m"):
        if values[k] is not None:
            check_drop_test_height(values[k], f"{path}.{k}", where=where, field=k, error=DataError)
    for k in ("epsilon_min", "epsilon_max"):
        _epsilon(values, k, where, path)
    return PaperValues(**values, printed=str(fields.get("printed", "")), table2=table2)


def _epsilon(values, name, where, path):
    """Refuse a coefficient of restitution above 1 (a ball that gains energy)."""
    value = values[name]
    if value is not None and value > 1:
        raise _err(where, f"{path}.{name}", f"must lie in (0, 1] (a coefficient of restitution), got {value:g}")


# --------------------------------------------------------------------------- lookup


def normalised_name(name):
    """A ball's name as looked up: lower case, '-' and ' ' read as '_' ("Table-tennis" -> table_tennis)."""
    return str(name).strip().lower().replace("-", "_").replace(" ", "_")


def find_ball(key, standards):
    """The :class:`Ball` named ``key`` (its key or one of its ``aliases``, see :func:`get_ball`), or None."""
    norm = normalised_name(key)
    if norm in standards:
        return standards[norm]
    return next((ball for ball in standards.values() if norm in ball.aliases), None)


def get_ball(key, standards=None):
    """Look up a ball by key or alias; an unknown key names the valid keys and the closest one.

    Parameters
    ----------
    key : str
        ball key or alias (``ping-pong`` for table_tennis, ``soccer`` for football), case-insensitive;
        '-' and ' ' are read as '_' ("table-tennis")
    standards : dict or None
        the result of :func:`load_standards`; the shipped file when None
    """
    standards = load_standards() if standards is None else standards
    found = find_ball(key, standards)
    if found is not None:
        return found
    path = getattr(standards, "path", None)
    shipped = path is not None and find_ball(key, _load_default()) is not None
    names = list(standards) + [a for ball in standards.values() for a in ball.aliases]
    close = None if shipped else closest_name(normalised_name(key), names, cutoff=0.5)
    hint = f"; did you mean '{find_ball(close, standards).key}'?" if close else ""
    if path is None:
        raise UsageError(f"unknown ball '{key}'{hint} (known: {', '.join(standards)})")
    copy = (f"; to use the shipped '{key}', copy its entry from vrcal/standards.yaml ('vrcal standards' prints it) "
            f"into {path}" if shipped else "")
    raise UsageError(f"unknown ball '{key}'{hint} (known: {', '.join(standards)}, the balls of {path}: --standards "
                     f"replaces the shipped ones){copy}")


# --------------------------------------------------------------------------- epsilon


PAPER_CONVENTION = "as printed in the paper's Table 1 (no point correction)"
#: Where vrcal measures both heights of Eq. (9) (a rule's height to the top or centre brought there).
BOTTOM_CONVENTION = "drop and rebound both to the bottom of the ball"


def ball_epsilon(ball, as_paper=False):
    """epsilon of a ball's drop-test window, Eq. (9) of [1].

    Parameters
    ----------
    ball : Ball
    as_paper : bool
        False (default): heights of the rule, both brought to the bottom of the ball
        (a height to the top loses one diameter), nominal from the window's nominal
        rebound. True: the paper's Table 1 heights as printed (typos corrected, no
        point correction), so basketball gives the paper's 0.85. Where the paper has
        only one rebound value it is min, nominal and max.

    Returns
    -------
    EpsilonWindow
    """
    if as_paper:
        if ball.paper is None or ball.paper.rebound_min_m is None:
            raise UsageError(f"the paper prints no drop test for '{ball.key}'")
        lo = ball.paper.rebound_min_m
        hi = ball.paper.rebound_max_m if ball.paper.rebound_max_m is not None else lo
        H = ball.paper.drop_height_m
        rebound = Range(lo, hi, 0.5 * (lo + hi))
        convention = PAPER_CONVENTION
    else:
        D = ball.diameter_m.nominal
        H = height_to_bottom_m(ball.drop_height_m, ball.drop_measured_to, D)
        r = ball.rebound_m
        to_bottom = [height_to_bottom_m(h, ball.rebound_measured_to, D) for h in (r.min, r.nominal, r.max)]
        rebound = Range(to_bottom[0], to_bottom[2], to_bottom[1])
        if not ball.measured_to_stated:
            convention = (f"{BOTTOM_CONVENTION}, assumed: the rule does not state the point of the ball"
                          if ball.drop_measured_to == ball.rebound_measured_to == "bottom" else
                          f"the drop to the {ball.drop_measured_to} and the rebound to the "
                          f"{ball.rebound_measured_to} of the ball, assumed (the rule does not state the point); "
                          "H and h here are both to its bottom")
        elif ball.drop_measured_to == ball.rebound_measured_to == "bottom":
            convention = f"{BOTTOM_CONVENTION}, as the rule measures them"
        else:
            convention = (f"the rule measures the drop to the {ball.drop_measured_to} and the rebound to the "
                          f"{ball.rebound_measured_to} of the ball; H and h here are both to its bottom")
    eps = epsilon_from_heights([rebound.min, rebound.nominal, rebound.max], H)
    return EpsilonWindow(float(eps[0]), float(eps[1]), float(eps[2]), H, rebound, convention)
