"""The numeric command-line option types, with their ranges, in one place.

Every numeric option of every command takes one of the types here, so a value that is not a
number, NaN, an infinity, or outside the option's range is refused while the command line is
parsed -- one line, exit status 2, the range in the message -- before any work starts::

    vrcal: error: --floor must be a finite number between -10000 and 10000 [m], got nan (see 'vrcal discover --help')

The ranges are those where vrcal's models mean something and its outputs stay a sensible
size; they are listed in docs/limits.md. The library functions check their own arguments
too; these types are the command line's first and uniform gate.

:class:`FiniteCommand` is the safety net for an option declared with plain ``type=float``:
it refuses NaN and infinities for every float option of a command that uses it.
"""

from __future__ import annotations

import math
import os
import re

import click

from vrcal.errors import closest_name, unit_hint


def _range_text(lo, hi, lo_open=False, hi_open=False, unit=""):
    """'> 0', 'in (0, 1]', 'between 1e-06 and 1e+06 [1/s]', '>= 1' ('' without bounds)."""
    unit = f" [{unit}]" if unit else ""
    if lo is not None and hi is not None:
        if lo_open or hi_open:
            return f"in {'(' if lo_open else '['}{lo:g}, {hi:g}{')' if hi_open else ']'}{unit}"
        return f"between {lo:g} and {hi:g}{unit}"
    if lo is not None:
        return f"{'>' if lo_open else '>='} {lo:g}{unit}"
    if hi is not None:
        return f"{'<' if hi_open else '<='} {hi:g}{unit}"
    return ""


class Real(click.ParamType):
    """A finite real number in [minimum, maximum] (an end excluded with ``min_open``/``max_open``).

    Parameters
    ----------
    minimum, maximum : float or None
        the range; None for no bound on that side
    min_open, max_open : bool
        exclude the bound itself (``> 0`` rather than ``>= 0``)
    unit : str
        the unit, shown in messages and in ``--help`` (e.g. "m", "1/s")
    """

    name = "number"
    numeric_kind = "float"

    def __init__(self, minimum=None, maximum=None, *, min_open=False, max_open=False, unit=""):
        self.minimum, self.maximum = minimum, maximum
        self.min_open, self.max_open = min_open, max_open
        self.unit = unit

    def range_text(self):
        """The range as people write it: '> 0', 'in (0, 1]', 'between 1e-06 and 1e+06 [1/s]'."""
        return _range_text(self.minimum, self.maximum, self.min_open, self.max_open, self.unit)

    def get_metavar(self, param, ctx=None):
        return "NUMBER"

    def convert(self, value, param, ctx):
        if isinstance(value, bool):
            _fail(param, ctx, f"must be a number {self.range_text()}, got {value!r}")
        try:
            x = float(value)
        except (TypeError, ValueError, OverflowError):
            _fail(param, ctx, f"must be a number {self.range_text()}, got {_brief(value)!r}")
        lo, hi = self.minimum, self.maximum
        if (not math.isfinite(x) or (lo is not None and (x < lo or (self.min_open and x == lo)))
                or (hi is not None and (x > hi or (self.max_open and x == hi)))):
            finite = "a finite number" if not math.isfinite(x) else "a number"
            _fail(param, ctx, f"must be {finite} {self.range_text()}, got {_brief(value)}")
        return x

    def __repr__(self):
        return f"Real({self.range_text()})"


class TimeStep(Real):
    """A time step [s]: a :class:`Real` that also takes a fraction such as ``1/240``, and whose
    refusal of a step above the range names the likely slip (milliseconds typed for seconds)."""

    def convert(self, value, param, ctx):
        text = str(value).strip()
        if not isinstance(value, (int, float)) and text.count("/") == 1:
            num, _, den = text.partition("/")
            try:
                value = float(num) / float(den)
            except (ValueError, ZeroDivisionError, OverflowError):
                _fail(param, ctx, f"must be a number {self.range_text()} or a fraction such as 1/240, "
                                  f"got {_brief(text)!r}")
        try:
            return super().convert(value, param, ctx)
        except click.UsageError as exc:
            hint = unit_hint(value, self.maximum, _name(param), "s", "ms", 1000)
            if hint:
                raise click.UsageError(f"{exc.message}{hint}", ctx) from None
            raise


class Count(click.ParamType):
    """A whole number in [minimum, maximum] (None: no bound on that side)."""

    name = "integer"
    numeric_kind = "int"

    def __init__(self, minimum=None, maximum=None):
        self.minimum, self.maximum = minimum, maximum

    def range_text(self):
        """The range as people write it: '>= 0', 'between 1 and 1000'."""
        return _range_text(self.minimum, self.maximum)

    def get_metavar(self, param, ctx=None):
        return "INTEGER"

    def convert(self, value, param, ctx):
        if isinstance(value, bool):
            _fail(param, ctx, f"must be an integer {self.range_text()}, got {value!r}")
        if isinstance(value, int):
            n = value
        else:
            text = str(value).strip()
            if len(text) > 50:
                _fail(param, ctx, f"must be an integer {self.range_text()}, got one of {len(text)} characters")
            try:
                n = int(text)
            except ValueError:
                _fail(param, ctx, f"must be an integer {self.range_text()}, got {_brief(value)!r}")
        if (self.minimum is not None and n < self.minimum) or (self.maximum is not None and n > self.maximum):
            _fail(param, ctx, f"must be an integer {self.range_text()}, got {n}")
        return n

    def __repr__(self):
        return f"Count({self.range_text()})"


def _name(param):
    """The option's first long name (``--drop`` of ``--drop/--drop-height``)."""
    opts = list(param.opts) if param is not None else []
    return next((o for o in opts if o.startswith("--")), max(opts, key=len, default="value"))


def _fail(param, ctx, message):
    """Refuse an option's value: ``--NAME must be ...`` (a usage error, exit status 2), NAME of :func:`_name`."""
    raise click.UsageError(f"{_name(param)} {message}", ctx)


def _brief(value, limit=40):
    text = str(value)
    return text if len(text) <= limit else text[: limit - 3] + "..."


#: What a repeated option (or one given several values) is told, by command and option: where to put
#: several values instead.
REPEAT_HINTS = {
    ("fit", "--rebound-height"): "for several drops write a drop table (H,h rows) and run "
                                 "vrcal discover TABLE.csv --ball BALL",
    ("fit", "--drop-height"): "for several drops write a drop table (H,h rows) and run "
                              "vrcal discover TABLE.csv --ball BALL",
}


def _repeat_hint(ctx, option):
    hint = REPEAT_HINTS.get((ctx.info_name, option))
    return f"; {hint}" if hint else ""


def _value_options(command):
    """``{'--name': param}`` of every option that takes one value (not a flag, a count or ``multiple``)."""
    out = {}
    for p in command.params:
        if isinstance(p, click.Option) and not (p.is_flag or p.count or p.multiple) and p.nargs == 1:
            for name in p.opts + p.secondary_opts:
                out[name] = p
    return out


def refuse_repeated_options(command, ctx, args):
    """UsageError (one line) when an option that takes one value is given more than once: click keeps
    the last silently (``--rebound-height 0.55 --rebound-height 0.54`` ran with 0.54)."""
    options = _value_options(command)
    seen = {}
    for token in args:
        if token == "--":
            break
        name = token.split("=", 1)[0] if token.startswith("--") else token
        param = options.get(name)
        if param is not None:
            seen.setdefault(param.name, []).append(name)
    for names in seen.values():
        if len(names) > 1:
            label = "/".join(dict.fromkeys(names))
            raise click.UsageError(f"{label} given {len(names)} times: it takes one value, and only the last "
                                   f"would count; give it once{_repeat_hint(ctx, names[-1])}", ctx)


def explain_extra_arguments(command, ctx, args, exc):
    """click's 'Got unexpected extra arguments (0.54 0.56)' after an option's value, as what happened:
    the option took its first value only (``--rebound-height 0.55 0.54 0.56``). Other errors unchanged."""
    message = exc.format_message()
    missing = re.search(r"'([^']*)' does not exist", message)   # a number taken for a file argument
    if not message.startswith("Got unexpected extra argument") and not missing:
        return exc
    options = _value_options(command)
    tokens = list(args)
    for k in range(len(tokens) - 2):
        name = tokens[k].split("=", 1)[0]
        if name in options and "=" not in tokens[k] and not tokens[k + 2].startswith("-"):
            extra = []
            for token in tokens[k + 2:]:
                if token.startswith("-"):
                    break
                extra.append(token)
            # click names the extras it could not place: all of them, or the tail after a positional took
            # the first (fit --rebound-height 0.55 0.54 0.56: 0.54 became BALL, '(0.56)' is left)
            said = message[message.rfind("(") + 1:-1].split() if message.endswith(")") else []
            tail = bool(said) and extra[-len(said):] == said
            if missing and _is_number(missing.group(1)) and missing.group(1) in extra:
                tail = True
            if extra and tail and all(_is_number(e) for e in extra):
                return click.UsageError(f"{name} takes one value: {name} {tokens[k + 1]} {' '.join(extra)} gives it "
                                        f"{tokens[k + 1]} and leaves {' '.join(extra)} over"
                                        f"{_repeat_hint(ctx, name)}", ctx)
    return exc


def _is_number(text):
    try:
        float(text)
    except ValueError:
        return False
    return True


def _refuse_number_as_argument(command, ctx, given):
    """A number taken as a positional argument right after an option's value (``fit --rebound-height 0.55
    0.54``: 0.54 became BALL) is refused like extra arguments: the option takes one value."""
    options = _value_options(command)
    for p in command.params:
        value = ctx.params.get(p.name)
        if not isinstance(p, click.Argument) or not isinstance(value, str) or not _is_number(value):
            continue
        if os.path.exists(value):            # a file named like a number is an argument
            continue
        for k in range(2, len(given)):
            if given[k] == value and given[k - 2] in options:
                name = given[k - 2]
                raise click.UsageError(f"{name} takes one value: {name} {given[k - 1]} {value} gives it "
                                       f"{given[k - 1]} and {value} would be {p.human_readable_name}"
                                       f"{_repeat_hint(ctx, name)}", ctx)


class FiniteCommand(click.Command):
    """A command that refuses NaN and infinities for every float option, whatever its declared type,
    and an option that takes one value given more than once (:func:`refuse_repeated_options`).

    The options typed with :class:`Real` already do; this catches one declared ``type=float``.
    """

    def parse_args(self, ctx, args):
        given = list(args)                       # click's parser consumes the list
        if not ctx.resilient_parsing:
            refuse_repeated_options(self, ctx, given)
        try:
            rest = super().parse_args(ctx, args)
        except click.UsageError as exc:
            raise explain_extra_arguments(self, ctx, given, exc) from None
        if not ctx.resilient_parsing:
            _refuse_number_as_argument(self, ctx, given)
        for p in self.params:
            value = ctx.params.get(p.name)
            if isinstance(p.type, click.types.FloatParamType) and isinstance(value, float) \
                    and not math.isfinite(value):
                _fail(p, ctx, f"must be a finite number, got {value}")
        return rest


# --------------------------------------------------------------------------- the options' types

#: Rate constant K of Eq. (7) [1/s].
K_PER_S = Real(1e-6, 1e6, unit="1/s")
#: Depth x of a virtual body [m].
DEPTH_M = Real(0, 10, min_open=True, unit="m")
#: Speed v of a virtual body [m/s].
SPEED_M_PER_S = Real(0, 1e4, min_open=True, unit="m/s")
#: Number of (x, v) family members of ``fit``.
FAMILY_SIZE = Count(1, 10_000)
#: Drop height [m].
HEIGHT_M = Real(1e-6, 1e4, unit="m")
#: Standard uncertainty of a height read against a ruler [m] (0: exact).
HEIGHT_SD_M = Real(0, 1, unit="m")
#: Number of floor impacts of ``simulate`` (after a few hundred bounces a ball is at rest).
BOUNCES = Count(1, 1000)
#: Coefficient of restitution (below 0.001 a ball is dead: nothing to calibrate).
EPSILON = Real(1e-3, 1)
#: Frame (sampling) rate [Hz].
RATE_HZ = Real(1e-3, 1e7, unit="Hz")
#: Noise of simulated heights [m].
NOISE_M = Real(0, 1, unit="m")
#: Noise of simulated impact times [s].
JITTER_S = Real(0, 1, unit="s")
#: Seed of a random generator.
SEED = Count(0, None)
#: Still segment before a release [s].
STILL_S = Real(0, 1000, unit="s")
#: Mass of a ball [kg].
MASS_KG = Real(1e-6, 1e4, unit="kg")
#: Diameter of a ball [m].
DIAMETER_M = Real(1e-4, 10, unit="m")
#: Metres per pixel of a video track [m/px].
SCALE_M_PER_PX = Real(1e-9, 1e3, unit="m/px")
#: Height of the floor in a record's frame [m].
FLOOR_M = Real(-1e4, 1e4, unit="m")
#: Noise of one datum in the data's unit (m, or s for impacts).
DATA_NOISE = Real(1e-9, 1e3)
#: Gravitational acceleration [m/s^2].
GRAVITY_M_PER_S2 = Real(1e-2, 1e3, unit="m/s^2")
#: A physics engine's time step [s]: the range of vrcal.engines.common.check_dt (below 1e-7 s no run
#: ends in reasonable time; above 0.1 s no bounce is resolved).
TIME_STEP_S = TimeStep(1e-7, 0.1, unit="s")
#: ODE's time step in a scene [s].
ODE_TIME_STEP_S = TimeStep(1e-7, 0.1, unit="s")
#: Largest accepted |achieved - target| epsilon.
TOLERANCE = Real(1e-9, 1)
#: MuJoCo's contact stiffness [1/s^2]; 0 is the one-step damper.
STIFFNESS = Real(0, 1e12, unit="1/s^2")
#: Largest accepted penetration (or hover) of a ball in an engine [m].
PENETRATION_M = Real(1e-9, 10, unit="m")
#: A count of at least one (each command may bound it further).
POSITIVE_COUNT = Count(1, None)

#: An input file: a missing file or a directory is a usage error (exit 2), said while the command
#: line is parsed ("Path 'x.csv' does not exist"), before any work.
INPUT_FILE = click.Path(exists=True, dir_okay=False)
#: An input file that may be '-' (stdin, read once into a temporary copy: vrcal.measurements.reader.spooled).
INPUT_FILE_OR_STDIN = click.Path(exists=True, dir_okay=False, allow_dash=True)
#: An output file (``-o``, ``--json``): '-' is stdout, as the help says (never a file named '-').
OUTPUT_FILE = click.Path(dir_okay=False, allow_dash=True)


class OutputDirectory(click.Path):
    """A directory of output files (created when missing); '-' (stdout) is refused: a folder of files cannot be
    written there, and a directory named '-' would shadow stdout for every later ``-o -``."""

    def __init__(self):
        super().__init__(file_okay=False)

    def convert(self, value, param, ctx):
        if value == "-":
            self.fail("'-' is stdout, but this is a directory of several files: give a directory name"
                      + (" (--json - writes the result to stdout)" if param is not None and param.name == "report_dir"
                         else ""), param, ctx)
        return super().convert(value, param, ctx)


#: ``-o DIR`` of plot curves and scene, discover's ``--report DIR``.
OUTPUT_DIRECTORY = OutputDirectory()


#: The points of a ball a height can be measured to (``--drop-measured-to``, ``--rebound-measured-to``; the
#: keys of vrcal.model.restitution.POINT_OFFSET_DIAMETERS, and "center" for "centre").
class NamedChoice(click.Choice):
    """A click.Choice whose refusal says which valid name was probably meant ('mujuco' -> 'mujoco'),
    as the ball names do."""

    def convert(self, value, param, ctx):
        try:
            return super().convert(value, param, ctx)
        except click.BadParameter as exc:
            close = closest_name(str(value).lower(), self.choices)
            if close:
                exc.message = f"{exc.message} (did you mean '{close}'?)"
            raise

class BallPoint(click.Choice):
    """The point of the ball a height was read to: bottom, centre (or center) or top, given as the
    library spells it ("centre")."""

    def __init__(self):
        super().__init__(["bottom", "centre", "center", "top"])

    def convert(self, value, param, ctx):
        point = super().convert(value, param, ctx)
        return "centre" if point == "center" else point


BALL_POINT = BallPoint()

#: The floor a ball bounces on (``vrcal discover --surface``; vrcal.drop.effects.SURFACES, written out so that
#: the CLI starts without importing the effects; a test keeps the two equal).
SURFACE = NamedChoice(["rigid", "soft"])

#: Degrees a video is turned clockwise before tracking (``--rotate``; the keys of
#: vrcal.measurements.video.ROTATIONS).
ROTATION = click.Choice(["0", "90", "180", "270"])

#: The measurement formats of ``--format`` (the keys of vrcal.measurements.reader.FORMATS, written out
#: so that the CLI starts without importing the readers; a test keeps the two equal).
MEASUREMENT_FORMATS = ("pixels-ref", "audacity-labels", "vernier", "mtrack2", "tracker", "phyphox-collision", "drops",
                       "apexes", "trajectory", "impacts", "sound", "video")


class MeasurementFormat(NamedChoice):
    """``discover --format``: the layout of the input file (:data:`MEASUREMENT_FORMATS`). Its refusal of an
    output format ('json', 'yaml') or of a file type ('csv', 'txt') says what was probably meant: the result
    is written with --json, and a CSV's layout is detected."""

    #: What a refused value probably meant: {value: hint}.
    MEANT = {**{name: "--format names the layout of the input file; the result is written as JSON with --json FILE "
                      "('-' for standard output)" for name in ("json", "yaml", "yml", "text", "markdown")},
             **{name: "--format names the layout of the input file, which is detected in a CSV or text file: "
                      "leave it out, or name the layout" for name in ("csv", "txt", "tsv", "dat", "text/csv")}}

    def __init__(self):
        super().__init__(list(MEASUREMENT_FORMATS))

    def convert(self, value, param, ctx):
        hint = self.MEANT.get(str(value).strip().lower())
        if hint is not None:
            self.fail(f"{value!r}: {hint} ({', '.join(self.choices)})", param, ctx)
        return super().convert(value, param, ctx)


MEASUREMENT_FORMAT = MeasurementFormat()
