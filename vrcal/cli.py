"""The ``vrcal`` command line: a thin click layer.

Each command parses its options, calls one library function, and writes sorted,
repeatable output. Library errors (:class:`vrcal.errors.VrcalError`) become a one-line
message on stderr and an exit status in one place, :class:`VrcalGroup`.
"""

from __future__ import annotations

import contextlib
import io
import os
import signal
import sys
import warnings

import click

from vrcal import __version__
from vrcal import options as opt
from vrcal.engines import default_steps_text
from vrcal.errors import VrcalError

# --------------------------------------------------------------------------- the group


class VrcalGroup(click.Group):
    """Turns every error into one line ``vrcal: error: MESSAGE`` on stderr and an exit status.

    Library errors (:class:`VrcalError`) exit 1 (data) or 2 (usage); click's own usage
    errors (a bad option value, a missing argument) exit 2 -- without click's
    multi-line usage block. SIGTERM is handled as SIGINT (temporary files removed, exit 143);
    numpy's floating-point RuntimeWarnings never reach the user (the error that follows does),
    other warnings are one line ``vrcal: warning: ...``.
    """

    command_class = opt.FiniteCommand
    group_class = type  # subgroups (plot) are VrcalGroups too, so their commands refuse nan/inf

    def main(self, args=None, prog_name=None, complete_var=None, standalone_mode=True, **extra):
        if not standalone_mode:
            return super().main(args, prog_name, complete_var, standalone_mode=False, **extra)
        try:
            with _terminate_as_interrupt() as signalled, warnings.catch_warnings(), _text_streams():
                warnings.filterwarnings("ignore", category=RuntimeWarning, module="numpy")
                warnings.filterwarnings("ignore", category=RuntimeWarning, message=_NUMPY_WARNINGS)
                warnings.showwarning = _show_warning
                rv = super().main(args, prog_name, complete_var, standalone_mode=False, **extra)
            if signalled:  # a SIGTERM that landed where Python swallows exceptions (a weakref callback)
                click.echo("vrcal: terminated", err=True)
                sys.exit(143)
        except _NO_ARGS_IS_HELP as exc:   # click >= 8.2: `vrcal` alone (or `vrcal plot`) shows the help
            click.echo(exc.format_message())
            sys.exit(0)
        except click.ClickException as exc:
            command = exc.ctx.command_path if getattr(exc, "ctx", None) is not None else "vrcal"
            if command == "vrcal":   # an option's missing value is raised without the subcommand's context
                named = [a for a in (sys.argv[1:] if args is None else list(args)) if a in self.commands]
                command = f"vrcal {named[0]}" if named else command
            hint = f" (see '{command} --help')" if isinstance(exc, click.UsageError) else ""
            if isinstance(exc, click.NoSuchOption) and exc.option_name in ("-o", "--output"):
                hint = _NO_OUTPUT_OPTION.get(command.split(" ")[-1], hint)
            click.echo(f"vrcal: error: {_one_line(exc.format_message())}{hint}", err=True)
            sys.exit(exc.exit_code)
        except click.Abort as exc:
            terminated = isinstance(exc.__context__, _Terminated)
            click.echo("vrcal: terminated" if terminated else "vrcal: aborted", err=True)
            sys.exit(143 if terminated else 1)
        except OSError as exc:   # a write to stdout or stderr failed (a full disk); a broken pipe is click's
            stream = _failed_stream(exc)
            if stream is None:
                raise
            _discard(stream)
            with contextlib.suppress(OSError):
                click.echo(f"vrcal: error: cannot write to {stream}: {exc.strerror or exc}", err=True)
            sys.exit(2)
        sys.exit(rv if isinstance(rv, int) else 0)

    def invoke(self, ctx):
        try:
            return super().invoke(ctx)
        except VrcalError as exc:
            click.echo(f"vrcal: error: {_one_line(str(exc))}", err=True)
            ctx.exit(exc.exit_code)
        except _Terminated:
            click.echo("vrcal: terminated", err=True)
            ctx.exit(143)
        except KeyboardInterrupt:  # pragma: no cover
            click.echo("vrcal: interrupted", err=True)
            ctx.exit(130)


#: What ``-o`` given to a command without it is told (click's "No such option: -o" is kept).
_NO_OUTPUT_OPTION = {
    "verify": " (verify prints its report: --format json for the machine file, > FILE to keep it)",
    "discover": " (discover writes its files with --json FILE and --report DIR)",
}
#: click >= 8.2 raises this for a group called without a command (8.1 printed the help itself).
_NO_ARGS_IS_HELP = getattr(click.exceptions, "NoArgsIsHelpError", ())
#: numpy's floating-point warnings (overflow, invalid value, division by zero, underflow).
_NUMPY_WARNINGS = r"(overflow|invalid value|divide by zero|underflow) encountered"
#: Longest error message printed; a longer one (a huge value quoted) keeps its start and end. Room for
#: a refusal that says what was measured and what to do (an engine's step: about 450 characters).
MAX_MESSAGE_CHARS = 1000


def _show_warning(message, category, filename, lineno, file=None, line=None):
    """A library's warning (matplotlib, ...) as one line ``vrcal: warning: ...``, without source lines."""
    click.echo(f"vrcal: warning: {_one_line(str(message))}", err=True)


def _one_line(message):
    """An error message as one line of at most :data:`MAX_MESSAGE_CHARS` characters."""
    text = " ".join(str(message).split())
    if len(text) > MAX_MESSAGE_CHARS:
        text = f"{text[:MAX_MESSAGE_CHARS - 120]} ... [{len(text):,} characters] ... {text[-100:]}"
    return text


@contextlib.contextmanager
def _text_streams():
    """stdout and stderr write what their encoding cannot hold in ASCII spellings (``ε`` -> ``eps`` on a
    latin-1 or cp1252 stdout) and a file name's undecodable bytes as ``\\xNN``
    (:data:`vrcal.textout.ASCII_FALLBACK`), for the command's run."""
    from vrcal.textout import ASCII_FALLBACK

    restore = []
    for stream in (sys.stdout, sys.stderr):
        try:
            errors = stream.errors
            stream.reconfigure(errors=ASCII_FALLBACK)
            restore.append((stream, errors))
        except (AttributeError, ValueError, OSError):   # not a TextIOWrapper (a test's capture), or closed
            pass
    try:
        yield
    finally:
        for stream, errors in restore:
            with contextlib.suppress(AttributeError, ValueError, OSError):
                stream.reconfigure(errors=errors)


def _failed_stream(exc):
    """'stdout' or 'stderr' when ``exc`` (an OSError) was raised writing to it, else None: the innermost
    frame of its traceback (click.echo, or the command) holds the stream it wrote to."""
    tb = exc.__traceback__
    while tb is not None and tb.tb_next is not None:
        tb = tb.tb_next
    if tb is None:
        return None
    held = [id(v) for v in tb.tb_frame.f_locals.values()]
    for name in ("stdout", "stderr"):
        stream = getattr(sys, name)
        if any(id(s) in held for s in (stream, getattr(stream, "buffer", None)) if s is not None):
            return name
    return None


def _discard(name):
    """Point the failed stream ``name`` at /dev/null: the text it still buffers would fail again at exit."""
    stream = getattr(sys, name)
    try:
        null = os.open(os.devnull, os.O_WRONLY)
        os.dup2(null, stream.fileno())
        os.close(null)
    except (AttributeError, ValueError, OSError, io.UnsupportedOperation):   # a test's capture: nothing at exit
        pass


class _Terminated(KeyboardInterrupt):
    """SIGTERM, raised like SIGINT's KeyboardInterrupt so that every cleanup runs."""


@contextlib.contextmanager
def _terminate_as_interrupt():
    """Handle SIGTERM as SIGINT while the command runs (only the main thread can set handlers).

    Yields a list that is non-empty once a SIGTERM came: where Python swallows the exception (a
    ``__del__`` or weakref callback) the command runs on, and the caller still exits 143.
    """
    signalled = []

    def handler(_signum, _frame):
        signalled.append(True)
        raise _Terminated()

    def unraisable(info):  # no "Exception ignored in ..." traceback for a swallowed SIGTERM
        if not isinstance(info.exc_value, _Terminated):
            previous_hook(info)

    try:
        previous = signal.signal(signal.SIGTERM, handler)
    except ValueError:  # not the main thread (a test runner's worker)
        yield signalled
        return
    previous_hook, sys.unraisablehook = sys.unraisablehook, unraisable
    try:
        yield signalled
    finally:
        signal.signal(signal.SIGTERM, previous)
        sys.unraisablehook = previous_hook


@click.group(cls=VrcalGroup, context_settings={"help_option_names": ["-h", "--help"], "max_content_width": 100})
@click.version_option(__version__, "--version", prog_name="vrcal")
@click.option("--standards", "standards_file", type=click.Path(dir_okay=False), default=None,
              help="Use this standards YAML instead of the shipped one (same schema; 'vrcal standards' prints "
                   "the shipped one).")
@click.pass_context
def main(ctx, standards_file):
    """Calibrate the coefficient of restitution with the virtual-body method.

    From a standard's drop test (fit), or a measured record -- a video track, impact
    times, rebound heights, or the raw sound or video (track) -- to the effect a constant
    epsilon misses (discover), and into a physics engine (export, verify).

    \b
    Examples:
      vrcal fit basketball
      vrcal discover drop.csv --ball tennis --json drop.json
      vrcal track drop.wav -o impacts.csv
      vrcal export --from drop.json --engine mujoco -o drop.xml
      vrcal verify basketball --engine mujoco
      vrcal pair basketball volleyball
      vrcal table2 --compare-paper
    """
    ctx.obj = {"standards_file": standards_file}


def standards_of(ctx):
    """The standards the user chose (``--standards FILE``) or the shipped ones."""
    from vrcal.model.standards import load_standards

    return load_standards((ctx.find_root().obj or {}).get("standards_file"))


def _remember_standards(ctx, _param, value):
    if value is not None:
        root = ctx.find_root()
        root.obj = dict(root.obj or {}, standards_file=value)
    return value


#: ``--standards FILE`` on a command (the same as the group's option).
STANDARDS_OPTION = click.option(
    "--standards", "standards_file", type=click.Path(dir_okay=False), default=None, expose_value=False,
    is_eager=True, callback=_remember_standards, help="Use this standards YAML instead of the shipped one.",
)


def emit(text, output):
    """Write command output to a file atomically, or to stdout."""
    from vrcal.fileio import atomic_write

    if output in (None, "-"):
        click.echo(text, nl=not text.endswith("\n"))
    else:
        atomic_write(output, text)
        click.echo(f"wrote {output}", err=True)


def emit_result(data, human, fmt, output, file_default="yaml"):
    """Write a command's result: ``human(data)`` for people on stdout (the default), or the
    full-precision machine file (``schema_version`` added) for ``--format json|yaml`` or an
    ``-o`` file's extension (:func:`vrcal.textout.choose_format`); an ``-o`` file with another
    extension gets ``file_default``."""
    from vrcal.fileio import dumps
    from vrcal.textout import choose_format, machine_document

    to_file = output not in (None, "-")
    kind = choose_format(fmt, output, default=file_default if to_file else "text",
                         allowed=("text", "json", "yaml"))
    emit(human(data) if kind == "text" else dumps(machine_document(data), kind), output)


#: ``--format`` of a command with a result for people and for machines.
FORMAT_OPTION = click.option(
    "--format", "fmt", type=click.Choice(["text", "yaml", "json"]), default=None, show_default="text",
    help="text: a table for people (stdout's default); yaml, json: the full-precision machine file "
         "(also chosen by -o's extension: .yaml/.yml/.json, and .txt for the table; an extension of "
         "another format, such as .csv, or one that contradicts --format is refused; an unknown "
         "extension gets yaml, with a warning).")


K_OPTION = click.option("--K", "K", type=opt.K_PER_S, default=None, show_default="4.0",
                        help="Rate constant K of Eq. 7 [1/s].")

# the one body description (vrcal.model.body.describe_body, docs/body.md): BALL, --mass/--diameter, --from
MASS_OPTION = click.option("--mass", "mass_kg", type=opt.MASS_KG, default=None,
                           help="Ball mass [kg] (with --diameter: a ball of your own; overrides a standard's).")
DIAMETER_OPTION = click.option("--diameter", "diameter_m", type=opt.DIAMETER_M, default=None,
                               help="Ball diameter [m] (with --mass: a ball of your own; overrides a standard's).")

# one's own drop test (vrcal.inverse.drop_test), read the same way by fit and export
REBOUND_HEIGHT_OPTION = click.option(
    "--rebound-height", "rebound_height_m", type=opt.HEIGHT_M, default=None,
    help="Your own drop test: the rebound height h [m] from --drop-height H; epsilon = sqrt(h/H) (Eq. 9) with both "
         "heights of the ball's bottom.")
DROP_MEASURED_TO_OPTION = click.option(
    "--drop-measured-to", type=opt.BALL_POINT, default=None, show_default="bottom",
    help="Your own drop test: the point of the ball the drop height was read to (needs the ball's diameter).")
REBOUND_MEASURED_TO_OPTION = click.option(
    "--rebound-measured-to", type=opt.BALL_POINT, default=None, show_default="bottom",
    help="Your own drop test: the point of the ball the rebound height was read to (needs the ball's diameter).")


def from_option(what):
    """``--from DISCOVER.json``: a ``vrcal discover --json`` result, of which the command takes ``what``."""
    return click.option("--from", "from_json", type=opt.INPUT_FILE, default=None,
                        metavar="DISCOVER.json", help=f"A 'vrcal discover --json' result: {what}.")


def g_option(from_json=True):
    """``--g``: gravity [m/s^2]; 9.80665 unless given (or, with ``from_json``, a ``--from`` result's).

    The default is resolved in one place, :meth:`vrcal.model.body.Body.gravity_m_per_s2`.
    """
    return click.option("--g", "g_m_per_s2", type=opt.GRAVITY_M_PER_S2, default=None,
                        show_default="the --from result's, else 9.80665" if from_json else "9.80665",
                        help="Gravity [m/s^2].")


def body_of(ctx, ball=None, mass_kg=None, diameter_m=None, from_json=None, **labels):
    """The command's body from what the user typed (:func:`vrcal.model.body.describe_body`)."""
    from vrcal.model.body import describe_body

    return describe_body(ball, mass_kg=mass_kg, diameter_m=diameter_m, from_json=from_json,
                         standards=standards_of(ctx), **labels)


# --------------------------------------------------------------------------- core (standards, inverse)


@main.command(short_help="Parameter file of a body: epsilon, T and its (x, v) family.")
@click.argument("ball", required=False)
@MASS_OPTION
@DIAMETER_OPTION
@from_option("its ball and its epsilon")
@click.option("--epsilon", type=opt.EPSILON, default=None,
              help="The body's epsilon against a rigid floor (instead of a standard's window or the --from "
                   "result's); needed for a ball of your own.")
@click.option("--drop-height", "drop_height_m", type=opt.HEIGHT_M, default=None,
              help="Your own drop test: the drop height H [m] (with --rebound-height), at most 20 m.")
@REBOUND_HEIGHT_OPTION
@DROP_MEASURED_TO_OPTION
@REBOUND_MEASURED_TO_OPTION
@click.option("--height-sd", "height_sd_m", type=opt.HEIGHT_SD_M, default=None,
              show_default="H 2 mm; h the larger of 2 mm and 1 % of it",
              help="Standard uncertainty of each height of your drop test [m]; gives the ± of epsilon.")
@K_OPTION
@click.option("--x", "x_m", type=opt.DEPTH_M, default=None, help="Fix the virtual body's depth x [m]; gives v.")
@click.option("--v", "v_m_per_s", type=opt.SPEED_M_PER_S, default=None,
              help="Fix the virtual body's speed v [m/s]; gives x.")
@click.option("--n", "n", type=opt.FAMILY_SIZE, default=11, show_default=True, help="Number of (x, v) family members.")
@click.option("--as-paper", is_flag=True,
              help="Use the paper's Table 1 heights as printed (its typos corrected: 0.13 m is 1.3 m, 0.12 m is "
                   "1.2 m; no point correction, no air drag).")
@FORMAT_OPTION
@click.option("-o", "--output", type=opt.OUTPUT_FILE, default=None, help="Write here instead of stdout.")
@STANDARDS_OPTION
@click.pass_context
def fit(ctx, ball, mass_kg, diameter_m, from_json, epsilon, drop_height_m, rebound_height_m, drop_measured_to,
        rebound_measured_to, height_sd_m, K, x_m, v_m_per_s, n, as_paper, fmt, output):
    """Parameter file of a body: epsilon (Eq. 9), T (Eq. 7) and virtual bodies (x, v) (Eq. 10).

    The body is BALL (a ball of the standards: its drop test's epsilon window), or --mass and
    --diameter with --epsilon or your own drop test's --drop-height and --rebound-height (a ball
    of your own: one epsilon), or --from a discover result (its ball and measured epsilon). Your
    drop test's heights alone give epsilon and T (no body: no air-drag check, no (x, v) family).
    Prints a table for people; --format yaml|json (or -o FILE.yaml|.json) gives the
    full-precision parameter file with schema_version and a unit in every key.

    \b
    Examples:
      vrcal fit basketball
      vrcal fit basketball --as-paper
      vrcal fit basketball --format yaml
      vrcal fit football --K 4 --x 0.02 -o football.json
      vrcal fit --mass 0.0459 --diameter 0.0427 --epsilon 0.78
      vrcal fit --mass 0.0577 --diameter 0.067 --drop-height 1 --rebound-height 0.55
      vrcal fit --drop-height 1 --rebound-height 0.64
      vrcal fit tennis --drop-height 1.07 --rebound-height 0.63 --drop-measured-to top
      vrcal fit tennis --drop-height 1 --rebound-height 0.6 --height-sd 0.005
      vrcal fit --from result.json
    """
    from vrcal.inverse import DEFAULT_K_PER_S, fit_ball, fit_text

    own_test_alone = (ball, mass_kg, diameter_m, from_json) == (None,) * 4 and (drop_height_m, rebound_height_m) \
        != (None, None)   # Eq. 9 needs no body (fit_ball notes what does)
    body = None if own_test_alone else body_of(ctx, ball, mass_kg, diameter_m, from_json)
    result = fit_ball(body, DEFAULT_K_PER_S if K is None else K, x_m=x_m, v_m_per_s=v_m_per_s, n=n, as_paper=as_paper,
                      epsilon=epsilon, drop_height_m=drop_height_m, rebound_height_m=rebound_height_m,
                      drop_measured_to=drop_measured_to, rebound_measured_to=rebound_measured_to,
                      height_sd_m=height_sd_m)
    emit_result(result, fit_text, fmt, output)


@main.command(short_help="epsilon of two colliding bodies (Eqs. 6 and 7).")
@click.argument("body_a")
@click.argument("body_b")
@K_OPTION
@click.option("--as-paper", is_flag=True, help="Balls use the paper's Table 1 heights as printed.")
@FORMAT_OPTION
@click.option("-o", "--output", type=opt.OUTPUT_FILE, default=None, help="Write here instead of stdout.")
@STANDARDS_OPTION
@click.pass_context
def pair(ctx, body_a, body_b, K, as_paper, fmt, output):
    """epsilon of two colliding bodies from their virtual bodies (Eqs. 6 and 7).

    A body is a ball of the standards, 'floor' (rigid, x = 0), 'x=DEPTH,v=SPEED', or
    'from=DISCOVER.json' (the ball of a 'vrcal discover --json' result and its epsilon); a
    ball's virtual body sits at x = R/2.

    \b
    Examples:
      vrcal pair basketball basketball
      vrcal pair tennis floor
      vrcal pair x=0.01,v=0.1 x=0.02,v=0.5 --K 4
      vrcal pair from=result.json basketball
      vrcal pair basketball volleyball --format json
    """
    from vrcal.inverse import DEFAULT_K_PER_S, pair_text
    from vrcal.inverse import pair as pair_epsilon

    result = pair_epsilon(body_a, body_b, DEFAULT_K_PER_S if K is None else K, standards_of(ctx), as_paper)
    emit_result(result, pair_text, fmt, output)


# --------------------------------------------------------------------------- plots and Table 2 (part: plots/table2)

@main.group(short_help="Figures 4-7 of the paper (plot curves).")
def plot():
    """Figures of the paper (Figs. 4-7) drawn from the model equations.

    \b
    Examples:
      vrcal plot curves -o figures
    """


def _output_dir(path):
    """The -o directory of ``plot curves``, checked: a directory, or nothing yet (it is created then, with its
    missing parents, as every command creates an output directory: ``scene -o``, ``discover --report``)."""
    from pathlib import Path

    from vrcal.errors import UsageError

    d = Path(path)
    if d.is_dir():
        return d
    if d.exists():
        raise UsageError(f"-o '{d}' exists and is not a directory")
    return d


@plot.command("curves", short_help="Write Figs. 4-7 of the paper as PNGs.")
@click.option("-o", "--output", "out_dir", type=opt.OUTPUT_DIRECTORY, default=".", show_default=True,
              help="Directory for the PNGs (created, with missing parents).")
@K_OPTION
@click.option("--ball", default="basketball", show_default=True, help="Ball of Fig. 7.")
@click.option("--as-paper", is_flag=True, help="Fig. 7 uses the paper's Table 1 heights as printed.")
@STANDARDS_OPTION
@click.pass_context
def plot_curves(ctx, out_dir, K, ball, as_paper):
    """Write Figs. 4-7 as PNGs: ε vs T, ε vs v_A2, ε vs x_A, and a ball's (x, v) band.

    \b
    Examples:
      vrcal plot curves -o figures
      vrcal plot curves -o figures --K 4 --ball table_tennis
      vrcal plot curves -o figures --ball basketball --as-paper
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from vrcal.fileio import figure_bytes, write_files
    from vrcal.inverse import DEFAULT_K_PER_S
    from vrcal.plots import curve_figures
    from vrcal.textout import table

    figures = curve_figures(DEFAULT_K_PER_S if K is None else K, ball, as_paper, standards_of(ctx))
    try:
        d = _output_dir(out_dir)
        write_files({d / name: figure_bytes(figures[name], dpi=120)
                     for name in sorted(figures)}, directories=[d])  # all of them or none
        click.echo(table([[str(d / name), figures[name].vrcal_description] for name in sorted(figures)],
                         ["wrote", "what"], align="ll"), nl=False)
    finally:
        for fig in figures.values():
            plt.close(fig)


@main.command(short_help="Table 2 regenerated from the standards; --compare-paper checks the paper's.")
@K_OPTION
@click.option("--format", "fmt", type=click.Choice(["text", "markdown", "csv", "json", "yaml"]), default=None,
              show_default="text", help="text: a table for people (stdout's default); markdown: the page "
              "docs/table2.md; csv, json, yaml: for machines (also chosen by -o's extension; one that "
              "contradicts --format is refused; an unknown extension gets markdown, with a warning).")
@click.option("--compare-paper", is_flag=True,
              help="Check the paper's Table 2: K per row under T = x/(2v) and T = v/(2x), least-squares K.")
@click.option("--as-paper", is_flag=True, help="ε from the paper's Table 1 heights as printed.")
@click.option("-o", "--output", type=opt.OUTPUT_FILE, default=None, help="Write here instead of stdout.")
@STANDARDS_OPTION
@click.pass_context
def table2(ctx, K, fmt, compare_paper, as_paper, output):
    """Table 2 regenerated from the standards: ε, T (Eq. 7) and a virtual body x, v (Eq. 10).

    Every ball of the standards, in file order; x = R/2, v = x/(2T). With
    --compare-paper: the K each row of the paper's Table 2 implies under Eq. (10) as
    printed and with x and v interchanged, and the least-squares K of each reading.

    \b
    Examples:
      vrcal table2
      vrcal table2 --K 4 --format csv
      vrcal table2 --compare-paper
      vrcal table2 --format markdown -o table2.md
    """
    from vrcal.inverse import DEFAULT_K_PER_S
    from vrcal.model.table2 import FORMATS, table2_text
    from vrcal.textout import choose_format

    if compare_paper and (as_paper or K is not None):
        from vrcal.errors import UsageError

        given = [o for o, on in (("--K", K is not None), ("--as-paper", as_paper)) if on]
        verb, them = ("does", "it") if len(given) == 1 else ("do", "them")
        raise UsageError(f"--compare-paper reads the paper's own Table 2 (each row's K, and the least-squares K of "
                         f"both readings): {' and '.join(given)} {verb} not apply; drop {them}, or drop "
                         "--compare-paper for the regenerated table")
    kind = choose_format(fmt, output, default="text" if output in (None, "-") else "markdown", allowed=FORMATS)
    text = table2_text(standards_of(ctx), DEFAULT_K_PER_S if K is None else K, kind, compare_paper, as_paper)
    emit(text, output)


# --------------------------------------------------------------------------- simulate and discover


@main.command(short_help="Simulate a drop test (exact impacts, optional effects) and write CSV data.")
@click.argument("ball", required=False)
@MASS_OPTION
@DIAMETER_OPTION
@from_option("simulate the discovered model (its ball, epsilon, drop height, release time, effects and g)")
@click.option("--drop", "--drop-height", "drop_m", type=opt.HEIGHT_M, default=None,
              help="Drop height of the ball's bottom [m] (default: the standard's, or the --from result's).")
@click.option("--bounces", type=opt.BOUNCES, default=10, show_default=True, help="Number of floor impacts.")
@click.option("--epsilon", type=opt.EPSILON, default=None,
              help="Restitution (default: the standard's nominal, Eq. 9, or the --from result's).")
@K_OPTION
@click.option("--x", "x_m", type=opt.DEPTH_M, default=None,
              help="Virtual body depth x [m] (with --v: epsilon by Eq. 7/10).")
@click.option("--v", "v_m_per_s", type=opt.SPEED_M_PER_S, default=None, help="Virtual body speed v [m/s] (with --x).")
@click.option("--effect", "effects", multiple=True, metavar="NAME[:PARAM=VALUE,...]",
              help="Add an effect (repeatable): air_drag, velocity_dependent_restitution, contact_duration, "
                   "height_offset, buoyancy.")
@g_option()
@click.option("--fs", "fs_hz", type=opt.RATE_HZ, default=None, show_default="240 (trajectory), 48000 (wav), 30 (video)",
              help="Frame rate of a trajectory or video, sample rate of a sound [Hz] (wav: 8000-384000, what "
                   "'vrcal track' reads; video: 10 or more, at most 10,000 frames).")
@click.option("--noise", "noise_m", type=opt.NOISE_M, default=0.0, show_default=True,
              help="Gaussian noise on heights [m].")
@click.option("--jitter", "jitter_s", type=opt.JITTER_S, default=0.0, show_default=True,
              help="Gaussian noise on impact times [s].")
@click.option("--seed", type=opt.SEED, default=0, show_default=True, help="Seed of the noise.")
@click.option("--still", "still_s", type=opt.STILL_S, default=None, show_default="0.2, or the --from record's release",
              help="Still segment before release [s].")
@click.option("--format", "fmt", type=click.Choice(["trajectory", "impacts", "apexes", "wav", "video"]),
              default="trajectory", show_default=True,
              help="CSV data, or a recording to try 'vrcal track' on: wav (the impacts' sound in a room with "
                   "noise, hum and an echo) or video (an .avi of the ball, needs vrcal[video]); these need -o.")
@click.option("-o", "--output", type=opt.OUTPUT_FILE, default=None, help="Write here instead of stdout.")
@STANDARDS_OPTION
@click.pass_context
def simulate(ctx, ball, mass_kg, diameter_m, from_json, drop_m, bounces, epsilon, K, x_m, v_m_per_s, effects,
             g_m_per_s2, fs_hz, noise_m, jitter_s, seed, still_s, fmt, output):
    """Simulate a drop test (event-driven, exact impacts) and write CSV data.

    The body is BALL (a ball of the standards), or --mass and --diameter (a ball of your own,
    with --epsilon and --drop), or --from a discover result: then the discovered model is
    simulated -- measurement, model, synthetic record.

    \b
    Examples:
      vrcal simulate table_tennis --bounces 5 --format apexes
      vrcal simulate table_tennis --effect air_drag --noise 0.001 -o tt.csv
      vrcal simulate basketball --effect contact_duration:contact_time_s=0.008 --format impacts
      vrcal simulate --mass 0.005 --diameter 0.016 --drop 0.5 --epsilon 0.6
      vrcal simulate --from result.json --noise 0.001 -o again.csv
      vrcal simulate tennis --format wav -o drop.wav
    """
    from vrcal.drop.simulate import simulate_csv

    body = body_of(ctx, ball, mass_kg, diameter_m, from_json)
    drop = dict(drop_height_m=drop_m, n_bounces=bounces, epsilon=epsilon, K_per_s=K, x_m=x_m, v_m_per_s=v_m_per_s,
                effects=list(effects), still_s=still_s, g_m_per_s2=g_m_per_s2)
    if output not in (None, "-"):
        from vrcal.textout import file_format

        if ctx.get_parameter_source("fmt") is not click.core.ParameterSource.COMMANDLINE:
            # no --format: the file's extension chooses among what simulate writes (drop.wav: a WAV)
            chosen = file_format(output, ("csv", "wav", "video"), "csv")
            fmt = chosen if chosen in ("wav", "video") else fmt
        else:
            written = {"wav": "wav", "video": "video"}.get(fmt, "csv")
            file_format(output, (written,), written, given=f"--format {fmt}")
    if fmt in ("wav", "video"):
        from vrcal.drop.render import simulate_recording
        from vrcal.errors import UsageError

        if output in (None, "-"):
            raise UsageError(f"--format {fmt} writes a binary file: give -o FILE")
        click.echo(simulate_recording(output, body, fmt, fs_hz=fs_hz, seed=seed, **drop), err=True)
        return
    text = simulate_csv(body, kind=fmt, fs_hz=240.0 if fs_hz is None else fs_hz, noise_m=noise_m, jitter_s=jitter_s,
                        seed=seed, **drop)
    emit(text, output)


@main.command()
@click.argument("data", nargs=-1, required=True, type=opt.INPUT_FILE_OR_STDIN)
@click.option("--ball", default=None,
              help="A ball of the standards (or any name with --mass and --diameter); without it give --mass and "
                   "--diameter.")
@MASS_OPTION
@DIAMETER_OPTION
@click.option("--format", "fmt", type=opt.MEASUREMENT_FORMAT, default=None, metavar="FORMAT",
              help=f"Format of DATA (default: detected from the file): {', '.join(opt.MEASUREMENT_FORMATS)} "
                   "(docs/measurements.md).")
@click.option("--sheet", default=None, help="Sheet of an .xlsx/.xls workbook, table of a zip archive of CSV files "
              "(default: 'All', else the first table), or track of an ImageJ MTrack2 export (its number; default: "
              "the one that moves most up and down).")
@click.option("--scale", "scale_m_per_px", type=opt.SCALE_M_PER_PX, default=None,
              help="Metres per pixel of a video track.")
@click.option("--y-down", is_flag=True, help="The data's y axis points down (image coordinates).")
@click.option("--fs", "--fps", "fs_hz", type=opt.RATE_HZ, default=None,
              help="Frame rate [Hz] when the file has no time column (a video: overrides its time stamps).")
@click.option("--rotate", type=opt.ROTATION, default=None,
              help="A video: turn the picture this many degrees clockwise first (filmed sideways, no rotation tag).")
@click.option("--roi", default=None, metavar="X,Y,W,H",
              help="A video: search the ball only in this region [px] (as vrcal track).")
@click.option("--color", default=None,
              help="A video: the ball's colour (a name like 'green', #RRGGBB or B,G,R) (as vrcal track).")
@click.option("--floor", "floor_m", type=opt.FLOOR_M, default=None,
              help="Height of the floor along the file's y axis [m]: with --y-down its distance below the "
                   "file's origin (a motion detector above the ball: its distance to the floor) (default: the "
                   "data's 0, or the lowest sample when the heights are clearly not floor-referenced).")
@click.option("--surface", type=opt.SURFACE, default="rigid", show_default=True,
              help="What the floor is: rigid (concrete, stone, a plate: the ball sets the contact time) or soft "
                   "(a stack of paper, a foam or gym mat, carpet, turf, sand: contacts of up to 50 ms are "
                   "physical).")
@click.option("--noise", type=opt.DATA_NOISE, default=None,
              help="Noise of one datum, in m for heights or s for impact times, whatever unit the file uses "
                   "(5 mm: 0.005) [default: estimated from a trajectory; 0.2 ms for impacts, 2 mm for apexes].")
@click.option("--drop-measured-to", type=opt.BALL_POINT, default=None,
              help="Point of the ball the drop heights were measured to (heights only) [default: not stated: the "
                   "bottom, and a height offset is tried].")
@click.option("--rebound-measured-to", type=opt.BALL_POINT, default=None,
              help="Point of the ball the rebound heights were measured to (a ruler read at the ball's top: top).")
@g_option(from_json=False)
@click.option("--details", is_flag=True, help="Add the statistics of every candidate and the gap per bounce.")
@click.option("--json", "json_file", type=opt.OUTPUT_FILE, default=None,
              help="Also write the result as JSON (sorted keys, full precision) here ('-' for stdout).")
@click.option("--report", "report_dir", type=opt.OUTPUT_DIRECTORY, default=None,
              help="Write report.txt, discover.json and the figure discover.png into this directory.")
@click.option("-q", "--quiet", is_flag=True, help="No progress lines on stderr.")
@STANDARDS_OPTION
@click.pass_context
def discover(ctx, data, ball, mass_kg, diameter_m, fmt, sheet, scale_m_per_px, y_down, fs_hz, rotate, roi, color,
             floor_m, surface, noise, drop_measured_to, rebound_measured_to, g_m_per_s2, details, json_file, report_dir,
             quiet):
    """Name the effect(s) a constant-epsilon model misses in DATA and give the epsilon to use.

    Fits the paper's baseline (constant epsilon), then each candidate effect on top, ranked
    by their evidence with a materiality test and hard physical limits; repeats until nothing
    material is left. Prints the answer, the verdict (explained / unexplained / untested /
    suspect input) and the epsilon for an engine. Several DATA files of one ball (or a table of drop and
    rebound heights, one trial per row) are fitted jointly: one epsilon, a drop height each.

    \b
    Examples:
      vrcal simulate tennis --effect air_drag --noise 0.002 -o drop.csv
      vrcal discover drop.csv --ball tennis
      vrcal discover drop.csv --ball tennis --details --json result.json --report out
      vrcal discover heights.csv --mass 0.0459 --diameter 0.0427
      vrcal discover heights.csv --ball tennis --rebound-measured-to top   # rebounds read at the ball's top
      vrcal discover run80cm.csv run100cm.csv --ball golf --mass 0.0459 --diameter 0.0427
      vrcal discover marble.csv --mass 0.0054 --diameter 0.016 --surface soft   # dropped on a paper stack
      vrcal discover drop.wav --ball tennis          # a sound recording: see 'vrcal track'
      vrcal discover drop.mp4 --ball tennis          # a video; needs vrcal[video]
    """
    import os

    from vrcal.discovery.ranking import discover_file
    from vrcal.discovery.report import REPORT_FILES, discovery_figure, fit_report
    from vrcal.fileio import dumps, figure_bytes, write_files
    from vrcal.measurements.reader import spooled
    from vrcal.textout import printable_name, wrap

    def progress(rnd, i, n, name):
        if not quiet:
            click.echo(f"discover: round {rnd}, candidate {i}/{n}: fitting {name}", err=True)

    with contextlib.ExitStack() as stack:   # stdin ('-') or a FIFO: read once into a temporary copy
        readable = [stack.enter_context(spooled(d)) for d in data]
        result = discover_file(readable, ball, fmt=fmt, mass_kg=mass_kg, diameter_m=diameter_m,
                               g_m_per_s2=g_m_per_s2, standards=standards_of(ctx), scale_m_per_px=scale_m_per_px,
                               y_down=y_down, fs_hz=fs_hz, progress=progress, floor_m=floor_m, noise=noise,
                               sheet=sheet,
                               read_options={"progress": None if quiet else tracking_progress("discover"),
                                             "rotate": None if rotate is None else int(rotate),
                                             **({"roi": roi} if roi else {}), **({"color": color} if color else {})},
                               drop_measured_to=drop_measured_to, rebound_measured_to=rebound_measured_to,
                               surface=surface)

    def named(text):   # the inputs as the user named them (not their temporary copies), as JSON writes names
        for copy, given in zip(readable, data):
            text = text.replace(copy, printable_name(given)) if copy != given else text
        return text

    text = fit_report(result, details=details)
    if readable != list(data):   # the heading names the input: wrap it again with the user's name in it
        head, sep, rest = text.partition("\n\n")
        text = wrap(named(" ".join(head.split("\n")))).rstrip("\n") + sep + named(rest)
    for warning in result.warnings:
        click.echo(f"vrcal: warning: {named(warning)}", err=True)
    files = {json_file: named(dumps(result.as_dict(), "json"))} if json_file and json_file != "-" else {}
    if report_dir:
        files[os.path.join(report_dir, REPORT_FILES["text"])] = named(fit_report(result, details=True))
        files[os.path.join(report_dir, REPORT_FILES["json"])] = named(dumps(result.as_dict(), "json"))
        files[os.path.join(report_dir, REPORT_FILES["figure"])] = figure_bytes(discovery_figure(result), dpi=120)
    write_files(files, directories=[report_dir] if report_dir else [])  # all of them or none
    if json_file == "-":
        click.echo(named(dumps(result.as_dict(), "json")), nl=False)
    elif json_file:
        click.echo(f"wrote {json_file}", err=True)
    if report_dir:
        click.echo(f"wrote {report_dir}/{{{', '.join(sorted(REPORT_FILES.values()))}}}", err=True)
    if json_file != "-":
        emit(text, None)

def tracking_progress(command):
    """A ``progress(fraction, message)`` printing to stderr when it is a terminal, from 1 s on."""
    import time

    if not sys.stderr.isatty():
        return None
    start = time.monotonic()

    def report(fraction, message):
        if time.monotonic() - start >= 1.0:
            click.echo(f"\r{command}: {message} ({fraction * 100:3.0f} %)\033[K", err=True, nl=fraction >= 1.0)

    return report


@main.command(short_help="A sound or video recording -> the measurement file vrcal reads.")
@click.argument("recording", type=opt.INPUT_FILE_OR_STDIN)
@click.option("-o", "--output", type=opt.OUTPUT_FILE, default=None,
              help="Write the measurement (CSV, notes as # comments) here; without it, to stdout.")
@click.option("--plot", "plot_file", type=click.Path(dir_okay=False), default=None,
              help="Also draw what was detected (signal and impacts, or the ball's path) into this PNG/PDF/SVG.")
@click.option("--format", "fmt", type=click.Choice(["sound", "video"]), default=None,
              help="What the recording is (default: from its content; 'sound' takes a video's sound track).")
@click.option("--ball", default=None, help="Video: a ball of the standards (its diameter gives the scale).")
@click.option("--diameter", "diameter_m", type=opt.DIAMETER_M, default=None, help="Video: the ball's diameter [m].")
@click.option("--roi", default=None, metavar="X,Y,W,H", help="Video: search the ball only in this region [px].")
@click.option("--color", default=None, help="Video: the ball's colour (a name like 'green', #RRGGBB or B,G,R).")
@click.option("--fps", "fps", type=opt.RATE_HZ, default=None,
              help="Video: frame rate [Hz] overriding the container's time stamps (a slow-motion video).")
@click.option("--scale", "scale_m_per_px", type=opt.SCALE_M_PER_PX, default=None,
              help="Video: metres per pixel overriding the scale from the diameter.")
@click.option("--rotate", type=opt.ROTATION, default=None,
              help="Video: turn the picture this many degrees clockwise first (filmed sideways, no rotation tag).")
@g_option(from_json=False)
@click.option("-q", "--quiet", is_flag=True, help="No progress on stderr and no summary.")
@STANDARDS_OPTION
@click.pass_context
def track(ctx, recording, output, plot_file, fmt, ball, diameter_m, roi, color, fps, scale_m_per_px, rotate,
          g_m_per_s2, quiet):
    """Turn RECORDING (a sound or a video of a drop) into the measurement file vrcal reads.

    A sound (WAV; m4a, mp3, ogg, flac with vrcal[audio]) gives the impact times; a video
    (mp4, mov, avi, mkv; needs vrcal[video]) the ball's trajectory, scaled by the flights
    with g and the ball's diameter (--ball, --diameter; or --scale).
    The file records how it was made in '#' comment lines. 'vrcal discover RECORDING'
    does the same tracking by itself.

    \b
    Examples:
      vrcal simulate tennis --format wav -o drop.wav
      vrcal track drop.wav -o impacts.csv
      vrcal track drop.mp4 --ball tennis -o drop.csv --plot drop.png
      vrcal track drop.mp4 --diameter 0.0687 --color green --roi 800,0,400,1080
      vrcal track sideways.mp4 --ball tennis --rotate 90 -o drop.csv
    """
    from vrcal.fileio import figure_bytes, write_files
    from vrcal.measurements.recording import track as track_recording
    from vrcal.measurements.recording import track_figure
    from vrcal.textout import file_format

    if output not in (None, "-"):
        file_format(output, ("csv",), "csv")
    plot_fmt = file_format(plot_file, ("png", "pdf", "svg"), "png") if plot_file else None
    if ball is not None and diameter_m is None:
        diameter_m = body_of(ctx, ball, ball_label="--ball", from_label=None).diameter_m
    result = track_recording(recording, fmt, diameter_m=diameter_m, roi=roi, color=color, fps=fps,
                             scale_m_per_px=scale_m_per_px, g_m_per_s2=g_m_per_s2,
                             rotate=None if rotate is None else int(rotate),
                             progress=None if quiet else tracking_progress("track"))
    files = {}
    if plot_file:
        import matplotlib.pyplot as plt

        fig = track_figure(result)
        try:
            files[plot_file] = figure_bytes(fig, plot_fmt, dpi=110)
        finally:
            plt.close(fig)
    if output not in (None, "-"):
        files[output] = result.text
    write_files(files)  # the plot and the measurement, or neither
    if output in (None, "-"):
        click.echo(result.text, nl=False)
        return
    if not quiet:
        click.echo(result.summary(), nl=False)
    click.echo(f"wrote {output}" + (f" and {plot_file}" if plot_file else ""), err=True)


# --------------------------------------------------------------------------- engines (part: export/verify)

# (export and verify commands go here)

_ENGINE_NAMES = ["mujoco", "ode", "bullet", "pybullet", "gazebo", "tables", "physx", "unity", "box2d"]


def _engine_options(f):
    """The options export and verify share: the body, the speeds, the step and the limits."""
    options = [
        MASS_OPTION,
        DIAMETER_OPTION,
        from_option("its ball, release state, drag and epsilon"),
        click.option("--epsilon", type=opt.EPSILON, default=None,
                     help="Target epsilon (0-1] (default: the standard's, or the --from result's)."),
        click.option("--drop-height", "drop_height_m", type=opt.HEIGHT_M, default=None,
                     help="Drop height of the ball's bottom [m] (default: the standard's)."),
        click.option("--impact-speed", "impact_speed", default=None, metavar="LO[:HI]",
                     help="Impact speeds to calibrate for [m/s] (instead of --drop-height): LO:HI drops from the "
                          "height that gives HI and bounces down to LO; one value: the first impact's speed."),
        g_option(),
        click.option("--dt", "dt_s", type=opt.TIME_STEP_S, default=None,
                     help=f"Engine time step [s] (default: the engine's: {default_steps_text()})."),
        click.option("--substeps", "substeps", type=opt.Count(1, 1000), default=None,
                     help="PyBullet's numSubSteps: each stepSimulation() advances --dt in this many steps of "
                          "--dt/N, the step checked (default: none; verify --file: the file's)."),
        click.option("--integrator", type=click.Choice(["euler", "implicit", "implicitfast", "rk4"],
                                                       case_sensitive=False), default=None,
                     help="MuJoCo's integrator [default: euler, MuJoCo's own]."),
        click.option("--stiffness", type=opt.STIFFNESS, default=None,
                     help="MuJoCo contact stiffness S [1/s^2]; 0 = the one-step damper (see --trade-off)."),
        click.option("--tolerance", type=opt.TOLERANCE, default=None, show_default="0.01; verify --file: the file's",
                     help="Largest accepted |achieved - target| epsilon (--engine tables: only against a "
                          "speed-dependent epsilon, which its one constant must stay within)."),
        click.option("--max-penetration", "max_penetration_m", type=opt.PENETRATION_M, default=None,
                     help="Largest accepted penetration (or hover) [m] [default: a quarter of the radius, "
                          "about what a real ball deforms at drop-test speed]."),
        click.option("--floor", default=None, help="'rigid' (default), a ball, or 'x=DEPTH,v=SPEED' (Eq. 6 pair)."),
    ]
    for option in reversed(options):
        f = option(f)
    return f


@main.command("export")
@click.argument("ball", required=False)
@click.option("--engine", "engine", type=opt.NamedChoice(_ENGINE_NAMES, case_sensitive=False), required=True,
              help="Engine to export for (pybullet = bullet; physx/unity/box2d = tables).")
@_engine_options
@REBOUND_HEIGHT_OPTION
@DROP_MEASURED_TO_OPTION
@REBOUND_MEASURED_TO_OPTION
@click.option("--against", default=None, help="A second ball: export the pair value of Eq. 6 too.")
@click.option("--bounces", "n_bounces", type=opt.POSITIVE_COUNT, default=None,
              show_default="3, or as --impact-speed needs",
              help="Bounces to calibrate and check (1-50; each must rise at least 1 mm).")
@K_OPTION
@click.option("--trade-off", "trade_off", is_flag=True,
              help="MuJoCo: print the achievable (step, stiffness, epsilon error, penetration) table.")
@click.option("--format", "fmt", type=click.Choice(["text", "json"]), default=None,
              help="text: the engine's own file (MJCF, SDF, the settings JSON, a table; -o: its extension or "
                   ".txt); json: the machine file (tables rows, MuJoCo's achieved numbers; -o: .json) [default: "
                   "the engine's file, or as -o's extension says].")
@click.option("-o", "--output", type=opt.OUTPUT_FILE, default=None, help="Write here instead of stdout.")
@STANDARDS_OPTION
@click.pass_context
def export_cmd(ctx, ball, engine, mass_kg, diameter_m, from_json, epsilon, drop_height_m, impact_speed, g_m_per_s2,
               dt_s, substeps, integrator, stiffness, tolerance, max_penetration_m, floor, rebound_height_m,
               drop_measured_to, rebound_measured_to, against, n_bounces, K, trade_off, fmt, output):
    """Export a ball's calibrated bounce to a physics engine's own file.

    BALL is a ball of the standards; without it give --mass and --diameter (and --epsilon and
    --drop-height or --impact-speed), or --from a discover result. mujoco: MJCF model, contact
    calibrated by running MuJoCo at --dt; ode, bullet: JSON settings with a paste-ready snippet;
    gazebo: SDF world; tables: PhysX/Unity/Box2D values and combine modes.

    \b
    Examples:
      vrcal export basketball --engine mujoco -o basketball.xml
      vrcal export --mass 0.0459 --diameter 0.0427 --epsilon 0.78 --drop-height 1 --engine mujoco
      vrcal export --mass 0.058 --diameter 0.062 --drop-height 1.2 --rebound-height 0.71 --engine bullet --substeps 4
      vrcal export tennis --engine mujoco --trade-off
      vrcal export --from pp.json --engine mujoco --dt 0.001 -o pp.xml
      vrcal export tennis --engine ode --dt 2e-4 -o tennis-ode.json
      vrcal export tennis --engine ode --epsilon 0.3 --drop-height 0.05 --dt 1e-4 --bounces 1
      vrcal export basketball --engine tables --against volleyball
    """
    from vrcal.engines.export import export, format_trade_off
    from vrcal.engines.export import trade_off as run_trade_off
    from vrcal.fileio import check_writable, dumps
    from vrcal.textout import choose_format, file_format, machine_document

    options = dict(epsilon=epsilon, dt_s=dt_s, floor=floor, standards=standards_of(ctx),
                   K_per_s=K, mass_kg=mass_kg, diameter_m=diameter_m,
                   drop_height_m=drop_height_m, impact_speed=impact_speed, g_m_per_s2=g_m_per_s2,
                   from_json=from_json, integrator=integrator,
                   tolerance=tolerance, max_penetration_m=max_penetration_m, n_bounces=n_bounces,
                   substeps=substeps, rebound_height_m=rebound_height_m, drop_measured_to=drop_measured_to,
                   rebound_measured_to=rebound_measured_to)
    form = choose_format(fmt, None, default="text", allowed=("text", "json"))
    if output not in (None, "-"):
        from vrcal.engines import get_engine

        # text is the engine's own file (MJCF, SDF, the settings JSON, a table), named by the engine's
        # extension or .txt; json the machine file: the extension chooses, or must agree with --format
        native = get_engine(engine).fmt
        if fmt is None:
            form = "json" if file_format(output, (native, "text", "json"), native) == "json" != native else "text"
        elif fmt == "json":
            choose_format(fmt, output, allowed=("text", "json"))
        else:
            file_format(output, (native, "text"), native, given=f"--format text ({native})")
        check_writable(output)                     # before the calibration, which takes seconds
    if trade_off:
        setup, rows = run_trade_off(ball, engine, against=against, stiffness=stiffness, **options)
        emit(format_trade_off(setup, rows) if form == "text" else
             dumps(machine_document({"engine": "mujoco", "ball": setup.ball, "target_epsilon": setup.epsilon,
                                     "rows": rows}), "json"), output)
        return
    result = export(ball, engine, against=against, stiffness=stiffness, **options)
    if result.summary:
        click.echo(result.summary, err=True)
    if form == "json":
        emit(dumps(machine_document(result.data), "json"), output)
    else:
        emit(result.text, output)


@main.command("verify")
@click.argument("ball", required=False)
@click.option("--engine", "engine", type=opt.NamedChoice(["mujoco", "ode", "bullet", "pybullet", "gazebo"],
                                                        case_sensitive=False),
              default=None, help="Engine to run the drop test in (gazebo: an SDF world given with --file, run in "
                                 "libode with its surfaces combined as Gazebo classic does); with --file, the file's "
                                 "by default.")
@_engine_options
@click.option("--file", "file", type=click.Path(exists=True, dir_okay=False), default=None,
              help="Verify this file written by 'vrcal export' instead of a fresh export (--dt, --g, "
                   "--drop-height run it at your step, gravity, height; body and contact options are refused).")
@click.option("--ball-geom", "ball_geom", default=None, metavar="NAME",
              help="--file: the ball's sphere geom in your MuJoCo model (on a body with a free joint) [default: "
                   "'ball', or the one sphere in the model's <pair> elements].")
@click.option("--floor-geom", "floor_geom", default=None, metavar="NAME",
              help="--file: the floor's geom (a plane or box) in your MuJoCo model [default: the other geom of the "
                   "ball's one <pair>, or 'floor'].")
@click.option("--against", "against", type=opt.INPUT_FILE, default=None,
              help="With --from: replay this measured record (the file discover read) in the engine.")
@click.option("--data-format", "data_fmt", default=None,
              help="--against: the record's format (as discover's --format).")
@click.option("--fs", "fs_hz", type=opt.RATE_HZ, default=None,
              help="--against: frame rate [Hz] of a file without times.")
@click.option("--scale", "scale_m_per_px", type=opt.SCALE_M_PER_PX, default=None, help="--against: metres per pixel.")
@click.option("--y-down", is_flag=True, help="--against: the record's y axis points down.")
@click.option("--data-floor", "data_floor_m", type=opt.FLOOR_M, default=None,
              help="--against: height of the floor in the record's frame [m] (as discover's --floor).")
@click.option("--plot", "plot_file", type=click.Path(dir_okay=False), default=None,
              help="--against: also draw the replay (heights and model - data) into this PNG/PDF/SVG.")
@click.option("--bounces", "n_bounces", type=opt.POSITIVE_COUNT, default=None,
              show_default="3, or as --impact-speed needs",
              help="Bounces per drop (1-50).")
@click.option("--phases", "n_phases", type=opt.POSITIVE_COUNT, default=16, show_default=True,
              help="Drops with the impact moved across one time step (1-64; export confirms a step with 16).")
@K_OPTION
@click.option("--format", "fmt", type=click.Choice(["text", "json"]), default="text", show_default=True)
@STANDARDS_OPTION
@click.pass_context
def verify_cmd(ctx, ball, engine, mass_kg, diameter_m, from_json, epsilon, drop_height_m, impact_speed, g_m_per_s2,
               dt_s, substeps, integrator, stiffness, tolerance, max_penetration_m, floor, file, ball_geom, floor_geom,
               against, data_fmt, fs_hz, scale_m_per_px, y_down, data_floor_m, plot_file, n_bounces, n_phases, K, fmt):
    """Load the exported settings into the real engine and run the drop test (or replay a record).

    Drops the ball --phases times with the impact moved across one time step and compares
    each of --bounces bounces with vrcal's model of the same drop (epsilon, and the apex
    heights with air drag); exit status 1 when the error exceeds --tolerance or the ball
    turns farther from the floor than --max-penetration. With --from and --against: replay
    the measured record in the engine beside vrcal's model and the constant-epsilon export.

    \b
    Examples:
      vrcal verify basketball --engine mujoco
      vrcal verify --mass 0.0459 --diameter 0.0427 --epsilon 0.78 --drop-height 1 --engine mujoco
      vrcal verify tennis --engine ode --dt 2e-4 --tolerance 0.002
      vrcal export basketball --engine bullet --dt 1e-3 -o b.json && vrcal verify --engine bullet --file b.json
      vrcal verify --engine bullet --file b.json --dt 5e-4
      vrcal verify --file b.json --bounces 5
      vrcal verify --engine mujoco --file robot.xml --ball-geom toy --epsilon 0.7 --drop-height 1
      vrcal verify --from pp.json --against raw.txt --fs 100 --engine mujoco --dt 0.001 --plot pp.png
    """
    from vrcal.fileio import dumps
    from vrcal.textout import machine_document

    if engine is None:
        from vrcal.engines.files import engine_of_file, read_file
        from vrcal.errors import UsageError

        if file is None:
            raise UsageError("give --engine (mujoco, ode, bullet, gazebo): the engine to run the drop test in")
        engine = engine_of_file(read_file(file), file)
    if against is not None:
        from vrcal.engines.replay import format_replay, replay, replay_figure
        from vrcal.errors import UsageError

        if from_json is None:
            raise UsageError("--against replays a record with the export of a discover result: give --from too")
        _refuse_in_replay(ctx, file)
        from vrcal.engines.common import DEFAULT_TOLERANCE
        from vrcal.engines.files import read_file

        result = replay(from_json, against, engine, dt_s=dt_s, integrator=integrator,
                        tolerance=DEFAULT_TOLERANCE if tolerance is None else tolerance,
                        max_penetration_m=max_penetration_m, stiffness=stiffness, fmt=data_fmt,
                        scale_m_per_px=scale_m_per_px, y_down=y_down, fs_hz=fs_hz, floor_m=data_floor_m,
                        standards=standards_of(ctx), exported_text=read_file(file) if file else None,
                        file_name=file, ball_geom=ball_geom, floor_geom=floor_geom)
        if plot_file:
            from vrcal.fileio import atomic_savefig

            atomic_savefig(replay_figure(result).figure, plot_file, dpi=120)
            click.echo(f"wrote {plot_file}", err=True)
        emit(format_replay(result) if fmt == "text" else dumps(machine_document(result.as_dict()), "json"), None)
        if not result.within_goal:
            click.echo(f"vrcal: error: {result.failure()}", err=True)
            return 1
        return 0
    if plot_file:
        from vrcal.errors import UsageError

        raise UsageError("--plot draws a replay: give --from and --against")
    from vrcal.engines.files import read_file
    from vrcal.engines.verify import format_report, verify

    text = read_file(file) if file else None
    result = verify(ball, engine, epsilon=epsilon, dt_s=dt_s, floor=floor, standards=standards_of(ctx),
                    tolerance=tolerance, n_bounces=n_bounces, n_phases=n_phases, exported_text=text,
                    mass_kg=mass_kg, diameter_m=diameter_m, drop_height_m=drop_height_m, impact_speed=impact_speed,
                    g_m_per_s2=g_m_per_s2, from_json=from_json, integrator=integrator,
                    max_penetration_m=max_penetration_m, stiffness=stiffness, K_per_s=K, file_name=file,
                    ball_geom=ball_geom, floor_geom=floor_geom, substeps=substeps)
    emit(format_report(result) if fmt == "text" else dumps(machine_document(result.as_dict()), "json"), None)
    if not result.passed:
        click.echo(f"vrcal: error: {result.failure()}", err=True)
        return 1
    return 0


#: verify's options a replay (--from with --against) takes from the discover result or does not run.
_NOT_IN_REPLAY = (("ball", "BALL"), ("mass_kg", "--mass"), ("diameter_m", "--diameter"), ("epsilon", "--epsilon"),
                  ("drop_height_m", "--drop-height"), ("impact_speed", "--impact-speed"), ("g_m_per_s2", "--g"),
                  ("floor", "--floor"), ("n_bounces", "--bounces"), ("n_phases", "--phases"), ("K", "--K"),
                  ("substeps", "--substeps"))


def _refuse_in_replay(ctx, file):
    """One-line UsageError for an option given to a replay that it would ignore."""
    from click.core import ParameterSource

    from vrcal.errors import UsageError

    given = [flag for key, flag in _NOT_IN_REPLAY
             if ctx.get_parameter_source(key) not in (None, ParameterSource.DEFAULT)]
    if file:
        given += [flag for key, flag in (("integrator", "--integrator"), ("stiffness", "--stiffness"))
                  if ctx.params.get(key) is not None]
    if given:
        names = given[0] if len(given) == 1 else ", ".join(given[:-1]) + " and " + given[-1]
        applies = ("--file, --dt, " + ("" if file else "--integrator, --stiffness, ") + "--tolerance, "
                   "--max-penetration, the reader options (--data-format, --fs, --scale, --y-down, --data-floor) "
                   "and --plot")
        raise UsageError(f"{names} {'does' if len(given) == 1 else 'do'} not apply to a replay (--against): it "
                         f"takes the ball, release and epsilon from --from; only {applies} apply")


@main.command("standards", short_help="Print the standards YAML (the balls of Table 1), or where it is.")
@click.option("--path", "show_path", is_flag=True, help="Print the file's path instead of its text.")
@click.option("-o", "--output", type=opt.OUTPUT_FILE, default=None,
              help="Write a copy here (to edit and give to --standards) instead of stdout.")
@STANDARDS_OPTION
@click.pass_context
def standards_cmd(ctx, show_path, output):
    """Print the standards file vrcal uses: the shipped one (in the installed package), or --standards FILE's.

    Copy it, edit it (a ball of your own, another rebound window) and give the copy to --standards;
    docs/standards.md describes its schema.

    \b
    Examples:
      vrcal standards -o mine.yaml
      vrcal standards --path
    """
    from vrcal.errors import UsageError
    from vrcal.model.standards import standards_file

    if show_path and output is not None:
        raise UsageError("give --path (print where the file is) or -o FILE (write a copy), not both")
    path, text = standards_file((ctx.find_root().obj or {}).get("standards_file"))
    emit(path + "\n" if show_path else text, output)


@main.command("engines")
def engines_cmd():
    """List the engines vrcal exports to, and which of them it can run here.

    \b
    Examples:
      vrcal engines
    """
    from vrcal.engines import engine_table

    emit(engine_table(), None)

# --------------------------------------------------------------------------- scenes (part: scene)

@main.command()
@click.argument("scene_file", type=opt.INPUT_FILE)
@click.option("-o", "--output", "out_dir", type=opt.OUTPUT_DIRECTORY, default=None,
              help="Directory for the outputs [default: ./NAME, NAME = the scene file's name without suffix].")
@click.option("--engine", type=click.Choice(["vrcal", "ode"]), default="vrcal", show_default=True,
              help="vrcal's event-driven simulator, or the real ODE library (libode8).")
@click.option("--compare", is_flag=True, help="Run both engines and report where they differ (apexes, impacts).")
@click.option("--ode-dt", "ode_dt_s", type=opt.ODE_TIME_STEP_S, default=None, show_default="1e-4",
              help="ODE's fixed time step [s].")
@click.option("--no-animation", is_flag=True, help="Skip the GIF (the slowest output).")
@STANDARDS_OPTION
@click.pass_context
def scene(ctx, scene_file, out_dir, engine, compare, ode_dt_s, no_animation):
    """Run a multi-body SCENE_FILE (YAML): spheres bouncing on a floor and on each other.

    At every contact epsilon comes from the two bodies' virtual bodies (Eqs. 6, 7) and the
    impulse from Eq. 5. Prints a summary; writes NAME.png (height vs time, Figure 8; with
    --compare a difference panel), NAME.gif (side view, Figure 9), NAME-trajectories.csv and
    NAME-contacts.csv into the output directory (NAME = the scene file's name). The scene file
    schema is in docs/scene.md and examples/*.yaml.

    \b
    Examples:
      vrcal scene examples/figure8-basketball.yaml
      vrcal scene examples/stack-drop.yaml --engine ode -o stack-ode
      vrcal scene examples/figure9-five-balls.yaml --compare -o five
    """
    from pathlib import Path

    from vrcal.fileio import write_files
    from vrcal.scenes.output import run_scene

    run = run_scene(scene_file, engine=engine, compare=compare, ode_dt_s=ode_dt_s, standards=standards_of(ctx),
                    animate=not no_animation)
    directory = Path(out_dir) if out_dir else Path(Path(scene_file).stem)
    write_files({directory / name: run.files[name] for name in sorted(run.files)}, directories=[directory])
    click.echo(run.summary, nl=False)
    for name in sorted(run.files):
        click.echo(f"wrote {directory / name}", err=True)



def run():  # pragma: no cover - used by python -m
    main(prog_name="vrcal")


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
