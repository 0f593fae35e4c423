"""Tests of vrcal.options: every numeric option of every command refuses NaN, infinities and values
out of its range while the command line is parsed -- one line, exit status 2, the range named."""

import math

import click
import pytest
from click.testing import CliRunner
from hypothesis import given, settings
from hypothesis import strategies as st

from vrcal import options as opt
from vrcal.cli import main


def _commands(group=main, path=()):
    for name, cmd in sorted(group.commands.items()):
        if isinstance(cmd, click.Group):
            yield from _commands(cmd, (*path, name))
        else:
            yield (*path, name), cmd


def _numeric_options():
    for path, cmd in _commands():
        for p in cmd.params:
            if isinstance(p, click.Option) and (isinstance(p.type, (click.types.FloatParamType,
                                                                     click.types.IntParamType))
                                                or getattr(p.type, "numeric_kind", None)):
                yield path, cmd, p


def _minimal_args(cmd):
    """Placeholder values for the command's required arguments and options (parsing stops before work)."""
    args = []
    for p in cmd.params:
        if not p.required:
            continue
        value = p.type.choices[0] if isinstance(p.type, click.Choice) else "x"
        args += [value] if isinstance(p, click.Argument) else [max(p.opts, key=len), value]
    return args


NUMERIC = list(_numeric_options())


def test_every_numeric_option_has_a_range_type():
    plain = [f"{' '.join(path)} {max(p.opts, key=len)}" for path, _cmd, p in NUMERIC
             if not isinstance(p.type, (opt.Real, opt.Count))]
    assert plain == [], f"numeric options without a vrcal.options type: {plain}"


@pytest.mark.parametrize("path,cmd,param", NUMERIC, ids=[f"{' '.join(p)} {max(q.opts, key=len)}"
                                                         for p, _c, q in NUMERIC])
def test_every_numeric_option_refuses_nan_and_infinity(path, cmd, param):
    name = max(param.opts, key=len)
    for bad in (["nan", "inf", "-inf"] if getattr(param.type, "numeric_kind", "float") == "float"
                else ["-1e9", "1.5", "x"]):
        result = CliRunner().invoke(main, [*path, *_minimal_args(cmd), f"{name}={bad}"])
        assert result.exit_code == 2, (bad, result.output)
        lines = result.output.strip().splitlines()
        first_long = next((o for o in param.opts if o.startswith("--")), name)   # the name the message gives
        assert len(lines) == 1 and lines[0].startswith(f"vrcal: error: {first_long} must be"), (bad, result.output)
        assert "Traceback" not in result.output


@pytest.mark.parametrize("args, message", [
    (["discover", "d.csv", "--ball", "tennis", "--floor", "nan"],
     "--floor must be a finite number between -10000 and 10000 [m], got nan"),
    (["discover", "d.csv", "--ball", "tennis", "--scale", "nan"], "--scale must be a finite number"),
    (["simulate", "tennis", "--seed", "-1"], "--seed must be an integer >= 0, got -1"),
    (["fit", "basketball", "--n", "10000000"], "--n must be an integer between 1 and 10000, got 10000000"),
    (["simulate", "tennis", "--bounces", "10000000"], "--bounces must be an integer between 1 and 1000"),
    (["simulate", "tennis", "--bounces", "9" * 200], "got one of 200 characters"),
    (["fit", "basketball", "--K", "1e-320"], "--K must be a number between 1e-06 and 1e+06 [1/s], got 1e-320"),
])
def test_the_issue_cases_are_one_line_errors(args, message):
    result = CliRunner().invoke(main, args)
    assert result.exit_code == 2 and message in result.output, result.output
    assert len(result.output.strip().splitlines()) == 1


@pytest.mark.parametrize("args, message", [
    (["export", "tennis", "--engine", "ode", "--dt", "2"], "got 2; --dt is in s: 2 ms = 0.002 s"),
    (["export", "tennis", "--engine", "ode", "--dt", "1/0"], "or a fraction such as 1/240, got '1/0'"),
    (["export", "tennis", "--engine", "ode", "--drop-height", "254"],
     "--drop-height must be at most 100 m (a drop of 254 m hits at 70.6 m/s; faster impacts: --impact-speed), "
     "got 254; --drop-height is in m: 254 cm = 2.54"),
    (["export", "tennis", "--engine", "ode", "--against", "x=0.01,v=0.17"],
     "--against takes a second ball of the standards (a virtual body x=DEPTH,v=SPEED is a --floor): unknown ball"),
    (["discover", "examples/data/apexes.csv", "--ball", "tennis", "--format", "json"],
     "'json': --format names the layout of the input file; the result is written as JSON with --json FILE ('-' for "
     "standard output)"),
    (["discover", "examples/data/apexes.csv", "--ball", "tennis", "--format", "CSV"],
     "'CSV': --format names the layout of the input file, which is detected in a CSV or text file: leave it out"),
    (["verify", "tennis", "--engine", "gazebo"],
     "--engine gazebo runs an SDF world (its surfaces combined as Gazebo classic does, in libode): give --file "
     "WORLD.sdf, e.g. vrcal export BALL --engine gazebo -o world.sdf && vrcal verify --engine gazebo --file "
     "world.sdf"),
])
def test_unit_slips_and_wrong_engines_are_named_in_one_line(args, message):
    """The probe's cases: ms typed for s, cm for m, a virtual body for --against, gazebo for verify, discover's
    --format (the input's layout) given the output's JSON or the file's type."""
    result = CliRunner().invoke(main, args)
    assert result.exit_code == 2 and message in result.output, result.output
    assert len(result.output.strip().splitlines()) == 1


@pytest.mark.parametrize("text, value", [("1/240", 1 / 240), (" 1 / 1000 ", 1e-3), ("0.002", 0.002)])
def test_a_time_step_takes_a_fraction_as_help_writes_bullets_default(text, value):
    assert opt.TIME_STEP_S.convert(text, None, None) == pytest.approx(value, rel=1e-15)
    assert "bullet 1/240" in CliRunner().invoke(main, ["export", "--help"]).output


def test_real_range_text():
    assert opt.Real(0, 1, min_open=True).range_text() == "in (0, 1]"
    assert opt.Real(0, unit="m").range_text() == ">= 0 [m]"
    assert opt.Real(None, 5, max_open=True).range_text() == "< 5"
    assert opt.Real(1e-6, 1e6, unit="1/s").range_text() == "between 1e-06 and 1e+06 [1/s]"


@settings(max_examples=200, deadline=None)
@given(st.one_of(st.floats(allow_nan=True, allow_infinity=True).map(repr), st.text(max_size=20)))
def test_real_accepts_exactly_the_finite_numbers_in_range(text):
    t = opt.Real(0, 10, min_open=True)
    try:
        x = float(text)
    except (ValueError, OverflowError):
        x = None
    try:
        got = t.convert(text, None, None)
    except click.UsageError as exc:
        assert "must be" in exc.message
        assert x is None or not (math.isfinite(x) and 0 < x <= 10)
    else:
        assert got == x and 0 < got <= 10


def test_a_plain_float_option_is_caught_by_the_net():
    @click.command(cls=opt.FiniteCommand)
    @click.option("--h", type=float)
    def cmd(h):
        click.echo(f"h={h}")

    assert CliRunner().invoke(cmd, ["--h", "1.5"]).output == "h=1.5\n"
    result = CliRunner().invoke(cmd, ["--h", "nan"])
    assert result.exit_code == 2 and "--h must be a finite number, got nan" in result.output


def test_docs_limits_lists_every_numeric_option_with_its_range():
    from helpers import ROOT

    text = " ".join((ROOT / "docs" / "limits.md").read_text(encoding="utf-8").split())
    missing = [f"{max(p.opts, key=len)} {p.type.range_text()}" for _path, _cmd, p in NUMERIC
               if f"| `{max(p.opts, key=len)}` | {p.type.range_text()} |" not in text]
    assert missing == [], f"docs/limits.md does not list: {missing}"


def test_the_measurement_formats_of_the_cli_are_the_readers():
    from vrcal.measurements.reader import FORMATS

    assert tuple(FORMATS) == opt.MEASUREMENT_FORMATS


def test_the_surfaces_of_the_cli_are_the_registrys():
    from vrcal.drop.effects import SURFACES

    assert tuple(opt.SURFACE.choices) == SURFACES


@pytest.mark.parametrize("args, message", [
    (["fit", "tennis", "--drop-height", "1", "--rebound-height", "0.55", "--rebound-height", "0.54"],
     "--rebound-height given 2 times: it takes one value, and only the last would count; give it once; for several "
     "drops write a drop table (H,h rows) and run vrcal discover TABLE.csv --ball BALL"),
    (["fit", "tennis", "--drop-height", "1", "--rebound-height", "0.55", "0.54", "0.56"],
     "--rebound-height takes one value: --rebound-height 0.55 0.54 0.56 gives it 0.55 and leaves 0.54 0.56 over; "
     "for several drops"),
    (["fit", "--drop-height", "1", "--rebound-height", "0.55", "0.54"],
     "--rebound-height takes one value: --rebound-height 0.55 0.54 gives it 0.55 and 0.54 would be BALL"),
    # the re-check: with no ball, 0.54 became BALL and click said 'Got unexpected extra argument (0.56)'
    (["fit", "--mass", "0.0577", "--diameter", "0.067", "--drop-height", "1", "--rebound-height", "0.55", "0.54",
      "0.56"], "--rebound-height takes one value: --rebound-height 0.55 0.54 0.56 gives it 0.55 and leaves 0.54 0.56"),
    # ... and a second number after discover's --noise was taken for a DATA file: "File '0.002' does not exist"
    (["discover", "README.md", "--ball", "tennis", "--noise", "0.001", "0.002"],
     "--noise takes one value: --noise 0.001 0.002 gives it 0.001 and leaves 0.002 over"),
    (["pair", "tennis", "floor", "--K=4", "--K", "5"], "--K given 2 times"),
    (["simulate", "tennis", "--drop", "1", "--drop-height", "2"], "--drop/--drop-height given 2 times"),
])
def test_an_option_given_twice_or_with_several_values_is_refused(args, message):
    """click kept the last of a repeated option silently (fit ran with --rebound-height 0.54) and said only
    'Got unexpected extra arguments (0.54 0.56)' for several values."""
    result = CliRunner().invoke(main, args)
    assert result.exit_code == 2 and message in " ".join(result.output.split()), result.output


def test_an_option_given_once_and_a_multiple_option_given_twice_still_run(tmp_path):
    result = CliRunner().invoke(main, ["fit", "tennis", "--drop-height", "1", "--rebound-height", "0.55"])
    assert result.exit_code == 0, result.output
    result = CliRunner().invoke(main, ["simulate", "tennis", "--effect", "air_drag", "--effect",
                                       "velocity_dependent_restitution", "-o", str(tmp_path / "d.csv")])
    assert result.exit_code == 0, result.output
