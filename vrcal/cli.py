"""The ``vrcal`` command line: a thin click layer.

Each command parses its options, calls one library function, and writes sorted,
repeatable output. Library errors (:class:`vrcal.errors.VrcalError`) become a one-line
message on stderr and an exit status in one place, :class:`VrcalGroup`.
"""

from __future__ import annotations

import sys

import click

from vrcal import __version__
from vrcal.errors import VrcalError

# --------------------------------------------------------------------------- the group


class VrcalGroup(click.Group):
    """Turns every library error into ``vrcal: error: MESSAGE`` and its exit status."""

    def invoke(self, ctx):
        try:
            return super().invoke(ctx)
        except VrcalError as exc:
            click.echo(f"vrcal: error: {exc}", err=True)
            ctx.exit(exc.exit_code)
        except KeyboardInterrupt:  # pragma: no cover
            click.echo("vrcal: interrupted", err=True)
            ctx.exit(130)


@click.group(cls=VrcalGroup, context_settings={"help_option_names": ["-h", "--help"], "max_content_width": 100})
@click.version_option(__version__, "--version", prog_name="vrcal")
@click.option("--standards", "standards_file", type=click.Path(dir_okay=False), default=None,
              help="Use this standards YAML instead of the shipped one (same schema).")
@click.pass_context
def main(ctx, standards_file):
    """Calibrate the coefficient of restitution with the virtual-body method.

    \b
    Examples:
      vrcal fit basketball
      vrcal fit tennis --K 4 --x 0.01 --format json -o tennis.json
      vrcal pair basketball volleyball
      vrcal plot curves -o figures
      vrcal table2 --compare-paper
    """
    ctx.obj = {"standards_file": standards_file}


def standards_of(ctx):
    """The standards the user chose (``--standards FILE``) or the shipped ones."""
    from vrcal.standards import load_standards

    return load_standards(ctx.find_root().obj.get("standards_file"))


def emit(text, output):
    """Write command output to a file atomically, or to stdout."""
    from vrcal.fileio import atomic_write

    if output in (None, "-"):
        click.echo(text, nl=not text.endswith("\n"))
    else:
        atomic_write(output, text)
        click.echo(f"wrote {output}", err=True)


K_OPTION = click.option("--K", "K", type=float, default=None, show_default="4.0",
                        help="Rate constant K of Eq. 7 [1/s].")


# --------------------------------------------------------------------------- core (standards, inverse)


@main.command()
@click.argument("ball")
@K_OPTION
@click.option("--x", "x_m", type=float, default=None, help="Fix the virtual body's depth x [m]; gives v.")
@click.option("--v", "v_m_per_s", type=float, default=None, help="Fix the virtual body's speed v [m/s]; gives x.")
@click.option("--n", "n", type=int, default=11, show_default=True, help="Number of (x, v) family members.")
@click.option("--as-paper", is_flag=True, help="Use the paper's Table 1 heights as printed (no point correction).")
@click.option("--format", "fmt", type=click.Choice(["yaml", "json"]), default="yaml", show_default=True)
@click.option("-o", "--output", type=click.Path(dir_okay=False), default=None, help="Write here instead of stdout.")
@click.pass_context
def fit(ctx, ball, K, x_m, v_m_per_s, n, as_paper, fmt, output):
    """Parameter file of BALL: epsilon (Eq. 9), T (Eq. 7) and virtual bodies (x, v) (Eq. 10).

    \b
    Examples:
      vrcal fit basketball
      vrcal fit basketball --as-paper
      vrcal fit football --K 4 --x 0.02 --format json -o football.json
    """
    from vrcal.fileio import dumps
    from vrcal.inverse import DEFAULT_K_PER_S, fit_ball
    from vrcal.standards import get_ball

    b = get_ball(ball, standards_of(ctx))
    result = fit_ball(b, DEFAULT_K_PER_S if K is None else K, x_m=x_m, v_m_per_s=v_m_per_s, n=n, as_paper=as_paper)
    emit(dumps(result, fmt), output)


@main.command()
@click.argument("body_a")
@click.argument("body_b")
@K_OPTION
@click.option("--as-paper", is_flag=True, help="Balls use the paper's Table 1 heights as printed.")
@click.option("--format", "fmt", type=click.Choice(["yaml", "json"]), default="yaml", show_default=True)
@click.pass_context
def pair(ctx, body_a, body_b, K, as_paper, fmt):
    """epsilon of two colliding bodies from their virtual bodies (Eqs. 6 and 7).

    A body is a ball of the standards, 'floor' (rigid, x = 0), or 'x=DEPTH,v=SPEED'.

    \b
    Examples:
      vrcal pair basketball basketball
      vrcal pair tennis floor
      vrcal pair x=0.01,v=0.1 x=0.02,v=0.5 --K 4
    """
    from vrcal.fileio import dumps
    from vrcal.inverse import DEFAULT_K_PER_S
    from vrcal.inverse import pair as pair_epsilon

    result = pair_epsilon(body_a, body_b, DEFAULT_K_PER_S if K is None else K, standards_of(ctx), as_paper)
    emit(dumps(result, fmt), None)


# --------------------------------------------------------------------------- plots and Table 2 (part: plots/table2)

# (plot group and table2 command go here)

# --------------------------------------------------------------------------- simulate and discover (part: simulate/discover)

# (simulate and discover commands go here)

# --------------------------------------------------------------------------- engines (part: export/verify)

# (export and verify commands go here)

# --------------------------------------------------------------------------- scenes (part: scene)

# (scene command goes here)



def run():  # pragma: no cover - used by python -m
    main(prog_name="vrcal")


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
