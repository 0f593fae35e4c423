"""Tests of vrcal.plots (Figs. 4-7 of [1]) and `vrcal plot curves`."""

import math

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402
from click.testing import CliRunner  # noqa: E402

from vrcal import plots  # noqa: E402
from vrcal.cli import main  # noqa: E402
from vrcal.errors import UsageError  # noqa: E402
from vrcal.model.standards import ball_epsilon, get_ball  # noqa: E402


@pytest.fixture
def ax():
    fig, ax = plt.subplots()
    yield ax
    plt.close(fig)


def labelled(ax):
    return ax.get_xlabel() and ax.get_ylabel() and ax.get_title() and ax.get_legend() is not None


def test_fig4_is_eq7(ax):
    out = plots.plot_epsilon_vs_T(4.0, ax=ax)
    assert out is ax and labelled(ax)
    assert "[s]" in ax.get_xlabel() and "Eq. 7" in ax.get_title()
    (line,) = ax.get_lines()
    T, eps = line.get_data()
    assert eps[0] == 1.0 and T[-1] == pytest.approx(1.0)  # default T_max = 4/K
    np.testing.assert_allclose(eps, np.exp(-4.0 * T))


def test_fig5_three_x_a_with_fixed_body_b(ax):
    """Fig. 5 of [1]: x_B and v_B2 fixed, three x_A, v_A2 varied; eps rises with v_A2 towards eps of B alone."""
    out = plots.plot_epsilon_vs_v_a(4.0, x_a_m=(0.005, 0.01, 0.02), x_b_m=0.01, v_b_m_per_s=0.1, ax=ax)
    assert out is ax and labelled(ax)
    lines = ax.get_lines()
    assert len(lines) == 3
    assert "x_B" in ax.get_title() and "0.01 m" in ax.get_title() and "Eqs. 6, 7" in ax.get_title()
    assert [t.get_text() for t in ax.get_legend().get_texts()] == ["$x_A$ = 0.005 m", "$x_A$ = 0.01 m",
                                                                  "$x_A$ = 0.02 m"]
    for line, x_a in zip(lines, (0.005, 0.01, 0.02)):
        v, eps = line.get_data()
        assert np.all(np.diff(eps) > 0)
        np.testing.assert_allclose(eps, np.exp(-4.0 * (x_a / (2 * v) + 0.01 / 0.2)))
        assert eps[-1] < math.exp(-4.0 * 0.05)
    # deeper x_A, lower epsilon at every v_A2
    assert np.all(lines[0].get_ydata() > lines[2].get_ydata())


def test_fig6_three_v_a(ax):
    out = plots.plot_epsilon_vs_x_a(4.0, v_a_m_per_s=(0.05, 0.1, 0.2), ax=ax)
    assert out is ax and labelled(ax)
    lines = ax.get_lines()
    assert len(lines) == 3
    for line in lines:
        x, eps = line.get_data()
        assert x[0] == 0.0 and eps[0] == pytest.approx(math.exp(-4.0 * 0.01 / 0.2))  # body B alone
        assert np.all(np.diff(eps) < 0)
    assert np.all(lines[2].get_ydata()[1:] > lines[0].get_ydata()[1:])  # faster v_A2, higher epsilon


def test_fig7_band_of_the_basketball(ax):
    """Fig. 7 of [1]: v = x/(2T) for the basketball; the band spans epsilon min..max of its drop test."""
    out = plots.plot_ball_family("basketball", 4.0, ax=ax)
    assert out is ax and labelled(ax)
    assert "[m]" in ax.get_xlabel() and "[m/s]" in ax.get_ylabel() and "Eq. 10" in ax.get_title()
    lines = ax.get_lines()
    assert len(lines) == 3 and len(ax.collections) == 1
    ball = get_ball("basketball")
    eps = ball_epsilon(ball)
    slopes = []
    for line in lines:
        x, v = line.get_data()
        assert x[0] == 0.0 and v[0] == 0.0 and x[-1] == pytest.approx(ball.radius_m)
        slopes.append(v[-1] / x[-1])
    # lines drawn max, nominal, min: slope 1/(2T) = -K/(2 ln eps)
    expected = [-4.0 / (2 * math.log(e)) for e in (eps.max, eps.nominal, eps.min)]
    np.testing.assert_allclose(slopes, expected, rtol=1e-12)


def test_fig7_as_paper_changes_the_band(ax):
    """The paper's basketball has one epsilon, 0.85 (Table 1 prints no max): one line, no band (it drew
    three overlapping lines and a band 'epsilon 0.850..0.850')."""
    plots.plot_ball_family("basketball", 4.0, as_paper=True, ax=ax)
    legend = " ".join(t.get_text() for t in ax.get_legend().get_texts())
    assert "0.850" in legend and ".." not in legend
    assert len(ax.get_lines()) == 1 and len(ax.collections) == 0


def test_plot_without_ax_makes_one():
    ax = plots.plot_epsilon_vs_T(2.0)
    assert ax.get_lines()
    plt.close(ax.figure)


@pytest.mark.parametrize("call", [
    lambda: plots.plot_epsilon_vs_T(0.0),
    lambda: plots.plot_epsilon_vs_v_a(4.0, v_a_range_m_per_s=(0.0, 1.0)),
    lambda: plots.plot_epsilon_vs_x_a(4.0, x_a_range_m=(0.1, 0.05)),
    lambda: plots.plot_ball_family("bowling", 4.0),
])
def test_bad_arguments_are_usage_errors(call):
    with pytest.raises(UsageError):
        call()
    plt.close("all")


def test_curve_figures_names_sorted():
    figs = plots.curve_figures(4.0, "table-tennis")
    try:
        assert list(figs) == ["fig4_epsilon_vs_T.png", "fig5_epsilon_vs_vA.png", "fig6_epsilon_vs_xA.png",
                              "fig7_family_table_tennis.png"]
    finally:
        for f in figs.values():
            plt.close(f)


def run(*args):
    return CliRunner().invoke(main, list(args))


def test_cli_writes_four_readable_pngs(tmp_path):
    from PIL import Image

    out = tmp_path / "figs"  # created: its parent exists
    result = run("plot", "curves", "-o", str(out), "--ball", "tennis")
    assert result.exit_code == 0, result.output
    lines = result.output.splitlines()
    assert lines[0].split() == ["wrote", "what"]
    paths = [line.split()[0] for line in lines[1:]]
    assert paths == sorted(paths) and len(paths) == 4
    assert "model only" in lines[-1]
    assert sorted(p.name for p in out.iterdir()) == [p.rsplit("/", 1)[1] for p in paths]
    for p in paths:
        with Image.open(p) as im:
            assert im.format == "PNG" and im.size[0] > 500
    assert paths[-1].endswith("fig7_family_tennis.png")


@pytest.mark.parametrize("args, code, text", [
    (["--K", "0"], 2, "--K must be a number between"),
    (["--K", "abc"], 2, "got 'abc'"),
    (["--ball", "bowling"], 2, "unknown ball 'bowling'"),
])
def test_cli_bad_input(tmp_path, args, code, text):
    result = run("plot", "curves", "-o", str(tmp_path), *args)
    assert result.exit_code == code
    assert text in result.output and "Traceback" not in result.output
    assert len(result.output.strip().splitlines()) == 1
    assert not list(tmp_path.iterdir())


def test_cli_unwritable_output(tmp_path):
    missing = tmp_path / "no" / "such"   # created with its parents, as scene -o and discover --report do
    result = run("plot", "curves", "-o", str(missing))
    assert result.exit_code == 0 and len(list(missing.glob("*.png"))) == 4
    afile = tmp_path / "f"
    afile.write_text("x")
    result = run("plot", "curves", "-o", str(afile))
    assert result.exit_code == 2 and "is a file" in result.output
    assert "Traceback" not in result.output
