"""One description of a body for every command: a ball of the standards, any mass and diameter,
or the ball of a ``vrcal discover --json`` result.

:class:`BallProperties` is what the simulator and the fitter need of a ball (mass [kg] and
diameter [m], floats or arrays over drops). :func:`describe_body` is the one function that turns
what a user typed (``BALL``, ``--mass``, ``--diameter``, ``--from``) into a :class:`Body`: its
properties, the standard it is based on (drop height, rebound window) and the discover result
it came from (the measured ε, drop height, effects and g). ``fit``, ``discover``, ``simulate``,
``export``, ``verify``, ``pair`` and ``scene`` all resolve their body here (docs/body.md).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

from vrcal.errors import UsageError
from vrcal.model.plausible import check_ball_size
from vrcal.model.restitution import STANDARD_GRAVITY_M_PER_S2, check_number
from vrcal.model.standards import find_ball, get_ball, load_standards, normalised_name


@dataclass(frozen=True)
class BallProperties:
    """Mass and diameter of the simulated ball (floats, or arrays broadcast over the drops).

    Parameters
    ----------
    mass_kg : float or ndarray
        ball mass [kg], > 0
    diameter_m : float or ndarray
        ball diameter [m], > 0
    name : str
        label used in reports
    surface : {"rigid", "soft"}
        the floor it bounces on (:data:`vrcal.drop.effects.SURFACES`): a soft one (paper, a mat, turf,
        sand) holds it longer, which widens the contact time's physical limits
    readout_limit_s_per_m : float or None
        the largest rolling shutter the record's camera can have, |kappa| [s/m]
        (:func:`vrcal.drop.effects.record_readout_limit_s_per_m`: one frame interval over the heights the
        frame held); None: any camera's (:data:`vrcal.drop.effects.READOUT_LIMIT_S_PER_M`)
    """

    mass_kg: float
    diameter_m: float
    name: str = "ball"
    surface: str = "rigid"
    readout_limit_s_per_m: float | None = None

    @classmethod
    def from_ball(cls, ball):
        """Nominal mass and diameter of a :class:`vrcal.model.standards.Ball`."""
        return cls(float(ball.mass_kg.nominal), float(ball.diameter_m.nominal), ball.key)


def ball_properties(ball):
    """A :class:`BallProperties` from itself or a :class:`vrcal.model.standards.Ball`."""
    if isinstance(ball, BallProperties):
        return ball
    if hasattr(ball, "mass_kg") and hasattr(getattr(ball, "mass_kg"), "nominal"):
        return BallProperties.from_ball(ball)
    raise UsageError(f"ball must be a BallProperties or a standards Ball, got {type(ball).__name__}")


def ball_from_options(name, standards=None, mass_kg=None, diameter_m=None):
    """The simulated ball from a command line: a standard's ball, or a free name with mass and diameter.

    Parameters
    ----------
    name : str
        a ball of the standards, or any name when both ``mass_kg`` and ``diameter_m`` are given
    standards : dict or None
        :func:`vrcal.model.standards.load_standards` output (the shipped file when None)
    mass_kg, diameter_m : float or None
        override the standard's nominal values [kg], [m]

    Returns
    -------
    (BallProperties, Ball or None)
        the standard's Ball when ``name`` is one, else None
    """
    standards = load_standards() if standards is None else standards
    mass_kg = _check_size("--mass", mass_kg, "[kg]")
    diameter_m = _check_size("--diameter", diameter_m, "[m]")
    std = find_ball(name, standards)
    if std is not None:
        props = BallProperties.from_ball(std)
        return BallProperties(props.mass_kg if mass_kg is None else float(mass_kg),
                              props.diameter_m if diameter_m is None else float(diameter_m), std.key), std
    if mass_kg is None or diameter_m is None:
        try:
            get_ball(name, standards)
        except UsageError as exc:
            hint = "for another ball give --mass and --diameter"
            if Path(str(name)).suffix or Path(str(name)).exists():
                hint = (f"'{name}' is a file, not a ball (a measurement goes to 'vrcal discover FILE', an export "
                        "to 'vrcal verify --file FILE')")
            raise UsageError(f"{exc}; {hint}") from None
    return BallProperties(float(mass_kg), float(diameter_m), str(name)), None


# --------------------------------------------------------------------------- the one body description


#: ``schema_version`` values of a ``vrcal discover --json`` file that this version reads (None: the
#: files written before discover added the key).
DISCOVER_SCHEMA_VERSIONS = (None, 1, 2)

#: Largest discover JSON file read [bytes] (a result is a few kB; more is not a discover result).
DISCOVER_JSON_MAX_BYTES = 16 * 1024 * 1024


@dataclass(frozen=True)
class Body:
    """What every command knows of the body it works on: a ball of the standards, a user's own
    ball (``--mass``/``--diameter``) or the ball of a ``vrcal discover --json`` result.

    Attributes
    ----------
    properties : BallProperties
        mass [kg], diameter [m] and name, what the simulator and the fitter need
    standard : vrcal.model.standards.Ball or None
        the standard's entry when the body is (or is based on) a ball of the standards: its
        drop height and rebound window give the default target of a drop test
    source : str
        where the description came from, for reports: ``"standard"``, ``"options"`` or the
        discover JSON's path
    discovered : dict or None
        the validated discover result when the body came from one (see :func:`read_discover_json`)
    """

    properties: BallProperties
    standard: object = None
    source: str = "options"
    discovered: dict = None

    @property
    def name(self):
        return self.properties.name

    @property
    def mass_kg(self):
        return float(self.properties.mass_kg)

    @property
    def diameter_m(self):
        return float(self.properties.diameter_m)

    @property
    def radius_m(self):
        return 0.5 * float(self.properties.diameter_m)

    def epsilon(self, as_paper=False):
        """The body's own ε against a rigid floor, or None for a ball of the user's own.

        The discover result's contact ε (``epsilon``: with a speed-dependent ε its value at
        ``epsilon_reference_speed_m_per_s``; with air drag the contact's own, drag apart), else
        the standard's nominal drop-test ε (Eq. 9, :func:`vrcal.model.standards.ball_epsilon`;
        ``as_paper`` reads the paper's Table 1 heights as printed).
        """
        if self.discovered is not None:
            return float(self.discovered["epsilon"])
        if self.standard is not None:
            from vrcal.model.standards import ball_epsilon

            return float(ball_epsilon(self.standard, as_paper=as_paper).nominal)
        return None

    def epsilon_source(self, as_paper=False):
        """Where :meth:`epsilon` comes from, in words (for notes and reports); None without one."""
        if self.discovered is not None:
            if "named" in self.discovered:
                return (f"the contact epsilon of the discover result {self.source}, its most probable value "
                        "(rivals the data cannot tell apart, shared by their priors, as its report advises)")
            return f"the contact epsilon of the discover result {self.source}"
        if self.standard is not None:
            from vrcal.model.standards import ball_epsilon

            window = ball_epsilon(self.standard, as_paper=as_paper)
            return f"nominal of the {self.standard.association} window ({window.convention})"
        return None

    @property
    def drop_height_m(self):
        """Drop height of the ball's bottom [m]: the discover result's release height, else the
        standard's drop-test height, else None."""
        if self.discovered is not None:
            return float(self.discovered["model"]["drop_height_m"])
        if self.standard is not None:
            from vrcal.model.standards import ball_epsilon

            return float(ball_epsilon(self.standard).drop_height_m)
        return None

    @property
    def effects(self):
        """The discover result's named effects ``{name: {param: value}}`` (empty otherwise)."""
        if self.discovered is None:
            return {}
        return {e: dict(self.discovered["parameters"].get(e, {})) for e in self.discovered["effects"]}

    @property
    def reference_speed_m_per_s(self):
        """The impact speed [m/s] at which a discovered speed-dependent ε equals :meth:`epsilon`
        (None: none recorded, the drop's first impact speed is used)."""
        if self.discovered is None:
            return None
        return self.discovered.get("epsilon_reference_speed_m_per_s")

    def gravity_m_per_s2(self, g_m_per_s2=None):
        """g [m/s^2] of a command: the user's ``--g``, else the discover result's world's (its
        ``g_nominal_m_per_s2`` when it fitted a record at the g the record's own flights show, a scale or frame
        rate off: an engine drops the ball in the world's), else standard gravity.

        Raises UsageError for a ``g_m_per_s2`` that is not a number > 0.
        """
        if g_m_per_s2 is not None:
            return _check_size("--g", g_m_per_s2, "[m/s^2]")
        if self.discovered is not None:
            return float(self.discovered.get("g_nominal_m_per_s2") or self.discovered["g_m_per_s2"])
        return STANDARD_GRAVITY_M_PER_S2


def describe_body(ball=None, *, mass_kg=None, diameter_m=None, from_json=None, standards=None,
                  ball_label="BALL", from_label="--from"):
    """The one body description of every command: a standard ball, a user's own, or a discover JSON's.

    Parameters
    ----------
    ball : str or None
        a ball of the standards (``BALL``); any name when ``mass_kg`` and ``diameter_m`` are
        both given; None for a body given by ``mass_kg`` and ``diameter_m`` alone (named
        "ball") or by ``from_json``
    mass_kg, diameter_m : float or None
        the user's ``--mass`` [kg] and ``--diameter`` [m]; override a standard's nominal values
        and the discover JSON's ball
    from_json : str or Path or None
        a file written by ``vrcal discover DATA --ball B --json FILE`` (``--from FILE``): its
        ball is the body (``ball`` must then be None or the same name)
    standards : dict or None
        :func:`vrcal.model.standards.load_standards` output (the shipped file when None)
    ball_label, from_label : str or None
        how the command spells the ball and the discover file in its messages (``BALL`` or
        ``--ball``; ``--from``, or None for a command without it)

    Returns
    -------
    Body

    Raises
    ------
    UsageError
        no body given (no BALL, no ``--from``, and not both ``--mass`` and ``--diameter``),
        a mass or diameter that is not a number > 0, an unknown ball without mass and diameter,
        a BALL that is not the ball of the ``--from`` file
    DataError
        a ``from_json`` file that is not a discover result (see :func:`read_discover_json`)

    Examples
    --------
    >>> describe_body("tennis").properties.name
    'tennis'
    >>> describe_body(mass_kg=0.0459, diameter_m=0.0427).name
    'ball'
    """
    mass_kg = _check_size("--mass", mass_kg, "[kg]")
    diameter_m = _check_size("--diameter", diameter_m, "[m]")
    if from_json is not None:
        doc = read_discover_json(from_json)
        found = doc["ball"]
        standards = load_standards() if standards is None else standards
        if ball is not None and _key(ball, standards) != _key(found["name"], standards):
            raise UsageError(f"{ball_label} '{ball}' differs from the ball of {from_json} ('{found['name']}'): "
                             "give one of them")
        props = BallProperties(float(found["mass_kg"]) if mass_kg is None else float(mass_kg),
                               float(found["diameter_m"]) if diameter_m is None else float(diameter_m),
                               str(found["name"]))
        std = find_ball(found["name"], standards)
        return Body(_plausible(props, mass_kg, diameter_m), std, str(from_json), doc)
    if ball is None:
        others = f"{ball_label}, a ball of the standards" + (f", or {from_label} a discover JSON" if from_label else "")
        if mass_kg is None and diameter_m is None:
            raise UsageError(f"no body: give {ball_label} (a ball of the standards), or --mass and --diameter"
                             + (f", or {from_label} a discover JSON" if from_label else ""))
        if mass_kg is None or diameter_m is None:
            given, missing = ("--mass", "--diameter") if diameter_m is None else ("--diameter", "--mass")
            raise UsageError(f"{given} without {missing}: a ball of your own needs both; or give {others}")
        return Body(_plausible(BallProperties(float(mass_kg), float(diameter_m), "ball"), mass_kg, diameter_m),
                    None, "options")
    props, std = ball_from_options(ball, standards, mass_kg, diameter_m)
    source = "standard" if std is not None and mass_kg is None and diameter_m is None else "options"
    return Body(_plausible(props, mass_kg, diameter_m), std, source)


def read_discover_json(path):
    """Read and check a ``vrcal discover --json`` result: the body, g, the effects and the release state.

    Parameters
    ----------
    path : str or Path
        the JSON file

    Returns
    -------
    dict
        the document, with at least ``ball`` {name, mass_kg, diameter_m}, ``g_m_per_s2``,
        ``effects`` (list of effect names), ``parameters`` {effect: {param: value}},
        ``epsilon`` and ``model`` {drop_height_m, release_time_s (0 when absent or null: a result of
        apex heights or a drop table has no clock), epsilon}, all checked

    Raises
    ------
    DataError
        one line naming what is wrong: not a file, not JSON, not an object, a missing or
        non-numeric key, an unknown ``schema_version``
    """
    import json

    from vrcal.errors import DataError

    where = f"{path}"
    raw = read_limited(path, DISCOVER_JSON_MAX_BYTES, "a discover result")
    try:
        doc = json.loads(raw.decode("utf-8"))
    except UnicodeDecodeError:
        raise DataError(f"{where}: not a discover JSON (binary, or not UTF-8 text)") from None
    except (json.JSONDecodeError, RecursionError) as exc:
        detail = f"line {exc.lineno}: {exc.msg}" if isinstance(exc, json.JSONDecodeError) else "nested too deeply"
        raise DataError(f"{where}: not a discover JSON ({detail}): --from takes the file of 'vrcal discover DATA "
                        f"--ball B --json FILE'") from None
    if not isinstance(doc, dict):
        raise DataError(f"{where}: not a discover JSON: the top level is a {type(doc).__name__}, not an object "
                        "(write one with 'vrcal discover DATA --ball B --json FILE')")
    version = doc.get("schema_version")
    if version not in DISCOVER_SCHEMA_VERSIONS:
        known = ", ".join(str(v) for v in DISCOVER_SCHEMA_VERSIONS if v is not None)
        raise DataError(f"{where}: discover schema_version {str(version)[:20]!r} is not one this vrcal reads "
                        f"(known: {known})")
    missing = [k for k in ("ball", "effects", "parameters", "epsilon", "model", "g_m_per_s2") if k not in doc]
    if missing:
        raise DataError(f"{where}: not a discover JSON: missing {', '.join(missing)} "
                        "(write one with 'vrcal discover DATA --ball B --json FILE')")
    ball = _obj(doc, "ball", where)
    _num(ball, "mass_kg", f"{where}: ball.mass_kg", lo=0.0)
    _num(ball, "diameter_m", f"{where}: ball.diameter_m", lo=0.0)
    if not isinstance(ball.get("name", "ball"), str):
        raise DataError(f"{where}: ball.name must be a text")
    ball.setdefault("name", "ball")
    _num(doc, "g_m_per_s2", f"{where}: g_m_per_s2", lo=0.0)
    _num(doc, "epsilon", f"{where}: epsilon", lo=0.0, hi=1.0)
    model = _obj(doc, "model", where)
    _num(model, "drop_height_m", f"{where}: model.drop_height_m", lo=0.0)
    if model.get("release_time_s") is None:
        model["release_time_s"] = 0.0   # apex heights, a drop table: no clock; the drop starts at t = 0
    _num(model, "release_time_s", f"{where}: model.release_time_s", lo=-math.inf)
    if doc.get("epsilon_reference_speed_m_per_s") is not None:
        _num(doc, "epsilon_reference_speed_m_per_s", f"{where}: epsilon_reference_speed_m_per_s", lo=0.0)
    _effects_and_parameters(doc, where)
    split = doc.get("prior_split")
    if version == 2:   # the top level is the recommended model already (the prior split's, when there is one)
        if isinstance(split, dict):
            doc["named"] = _obj(doc, "named", where)
        else:
            doc.pop("named", None)   # "named" marks a recommended value that is not the named model's
    elif isinstance(split, dict):
        # rivals the data cannot tell apart: the report's advice leads with their most probable sharing
        # ("Use this"), so an engine takes that, not the named model alone (a joint record: 0.973 with
        # C_d 0.74 exported where the report said 0.957 with C_d 0.59 and a speed law)
        _num(split, "epsilon", f"{where}: prior_split.epsilon", lo=0.0, hi=1.0)
        _effects_and_parameters(split, where, "prior_split.")
        doc["named"] = {key: doc[key] for key in ("epsilon", "effects", "parameters")}
        doc.update({key: split[key] for key in ("epsilon", "effects", "parameters")})
    return doc


def _effects_and_parameters(doc, where, prefix=""):
    """Check ``effects`` (a list of effect names) and ``parameters`` ({effect: {parameter: number}}) of a
    discover result, or of its ``prior_split`` (``prefix`` 'prior_split.')."""
    from vrcal.errors import DataError

    effects = doc.get("effects")
    if not isinstance(effects, list) or not all(isinstance(e, str) for e in effects):
        raise DataError(f"{where}: {prefix}effects must be a list of effect names")
    params = _obj(doc, "parameters", where, prefix)
    for name, values in params.items():
        if not isinstance(values, dict):
            raise DataError(f"{where}: {prefix}parameters.{name} must be an object of numbers")
        for key in values:
            _num(values, key, f"{where}: {prefix}parameters.{name}.{key}", lo=-math.inf)


def read_limited(path, max_bytes, what):
    """The bytes of a regular file of at most ``max_bytes``; DataError (one line) otherwise, and
    UsageError (exit 2, as for a missing FILE argument) when nothing is at ``path``.

    ``what`` names the expected content in the message ("a discover result").
    """
    from pathlib import Path

    from vrcal.errors import DataError, UsageError

    p = Path(path)
    if not p.exists():   # a missing input file is a usage error, worded as click's for a FILE argument
        raise UsageError(f"File '{path}' does not exist.")
    try:
        if not p.is_file():
            raise DataError(f"{path}: not a file")
        size = p.stat().st_size
        if size > max_bytes:
            raise DataError(f"{path}: {size} bytes is too large for {what} (limit {max_bytes} bytes)")
        return p.read_bytes()
    except OSError as exc:
        raise DataError(f"{path}: cannot read: {exc.strerror or exc}") from None


def _key(name, standards):
    """The standards' key of a ball named ``name`` (key or alias), else the name normalised."""
    std = find_ball(name, standards)
    return normalised_name(name) if std is None else std.key


def _plausible(props, mass_kg, diameter_m):
    """``props`` when the --mass/--diameter given make a ball that can exist, else a UsageError
    naming the likely slip (grams for kilograms, centimetres for metres;
    :func:`vrcal.model.plausible.check_ball_size`, the rule a standards file's balls follow too)."""
    if mass_kg is not None or diameter_m is not None:
        check_ball_size(props.mass_kg, props.diameter_m)
    return props


def _check_size(label, value, unit=""):
    """``value`` as a float (None stays None): any real number > 0 (:func:`vrcal.model.restitution.check_number`)."""
    return None if value is None else check_number(value, label, unit=unit)


def _obj(doc, key, where, prefix=""):
    """``doc[key]`` when it is an object (a dict); else a DataError naming ``where`` and ``prefix + key``."""
    from vrcal.errors import DataError

    value = doc.get(key)
    if not isinstance(value, dict):
        raise DataError(f"{where}: {prefix}{key} must be an object, got {type(value).__name__}")
    return value


def _num(doc, key, what, lo=0.0, hi=math.inf):
    """Check that ``doc[key]`` is a finite number in (lo, hi] (lo = -inf: any finite number)."""
    from vrcal.errors import DataError

    value = doc.get(key)
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise DataError(f"{what} must be a finite number, got {str(value)[:40]!r}")
    if not (value > lo or lo == -math.inf) or value > hi:
        raise DataError(f"{what} = {value:g} is out of range")
    return float(value)
