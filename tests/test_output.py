"""Output for people first: the default output of fit, pair, table2, scene, plot curves and simulate is
short and within 100 columns; the machine files carry schema_version and keep every key they had;
`vrcal fit` starts without the heavy libraries."""

import json
import subprocess
import sys

import pytest
import yaml
from click.testing import CliRunner
from helpers import EXAMPLES

from vrcal.cli import main
from vrcal.model.standards import load_standards
from vrcal.textout import MAX_COLUMNS, longest_line

BALLS = list(load_standards())


def run(*args):
    result = CliRunner().invoke(main, [str(a) for a in args])
    assert result.exit_code == 0, result.output
    return result


# --------------------------------------------------------------------------- 100 columns

DEFAULT_OUTPUTS = [
    *(("fit", ball) for ball in BALLS),
    ("fit", "basketball", "--as-paper"),
    ("fit", "basketball", "--x", "0.05"),
    ("fit", "tennis", "--v", "0.4", "--n", "40"),
    ("pair", "basketball", "tennis"),
    ("pair", "table_tennis", "floor"),
    ("pair", "x=0.01,v=0.1", "x=0.02,v=0.5"),
    ("table2",),
    ("table2", "--compare-paper"),
    ("table2", "--as-paper", "--K", "3"),
    ("simulate", "table_tennis", "--bounces", "5", "--format", "apexes"),
    ("simulate", "basketball", "--bounces", "4", "--format", "impacts"),
]


@pytest.mark.parametrize("args", DEFAULT_OUTPUTS, ids=" ".join)
def test_default_output_fits_in_100_columns(args):
    text = run(*args).stdout
    assert text.strip()
    assert longest_line(text) <= MAX_COLUMNS, max(text.splitlines(), key=len)


@pytest.mark.parametrize("scene", sorted(p.name for p in EXAMPLES.glob("*.yaml")))
def test_scene_summary_fits_in_100_columns(scene, tmp_path):
    text = run("scene", EXAMPLES / scene, "-o", tmp_path, "--no-animation").stdout
    assert "contacts in" in text
    assert longest_line(text) <= MAX_COLUMNS, max(text.splitlines(), key=len)


def test_scene_compare_fits_in_100_columns(tmp_path):
    from helpers import require_engine

    require_engine("ode")
    doc = yaml.safe_load((EXAMPLES / "stack-drop.yaml").read_text())
    doc["duration_s"] = 1.0
    path = tmp_path / "stack.yaml"
    path.write_text(yaml.safe_dump(doc))
    text = run("scene", path, "--compare", "-o", tmp_path / "o", "--no-animation", "--ode-dt", "5e-4").stdout
    assert "vrcal against ode" in text and "why they differ:" in text
    assert longest_line(text) <= MAX_COLUMNS, max(text.splitlines(), key=len)


def test_plot_curves_output_fits_in_100_columns(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)       # the lines hold the paths written: relative, as a user types them
    text = run("plot", "curves", "-o", "figures").stdout
    assert longest_line(text) <= MAX_COLUMNS


# --------------------------------------------------------------------------- fit for people


def test_fit_basketball_is_at_most_26_lines_epsilon_first():
    """25 lines and one row since the window's ε with air drag (the contact's own, for an engine with drag) is
    shown beside Eq. 9's: a standard ball had no word of drag where the same ball's own heights had a note."""
    lines = run("fit", "basketball").output.splitlines()
    assert len(lines) <= 26
    assert lines[0].startswith("basketball: ε = 0.766 (0.729 .. 0.802)")
    body = "\n".join(lines)
    # then T, the drop test's heights, the family, the notes -- in that order
    order = [body.index(key) for key in ("T [ms]", "H [m]", "h [m]", "x [mm]", "v [m/s]", "notes:")]
    assert order == sorted(order)


def test_fit_table_columns_are_consistent_levels():
    """Each column is one epsilon level (min, nominal, max): epsilon rises, T falls along a row."""
    lines = run("fit", "football").stdout.splitlines()
    eps = [float(v) for v in next(ln for ln in lines if ln.startswith("ε ")).split()[1:4]]
    T = [float(v) for v in next(ln for ln in lines if ln.startswith("T [ms]")).split()[2:5]]
    assert eps == sorted(eps) and eps[0] < eps[2]
    assert T == sorted(T, reverse=True) and T[0] > T[2]


# --------------------------------------------------------------------------- machine files


@pytest.mark.parametrize("fmt", ["json", "yaml"])
def test_fit_machine_file_keeps_every_key_and_adds_schema_version(fmt, tmp_path):
    old_keys = {"K_per_s", "T_s", "association", "ball", "ball_name", "bounds", "convention", "diameter_m",
                "drop_height_m", "epsilon", "equations", "family", "mass_kg", "notes", "official_rule",
                "rebound_height_m"}
    data = yaml.safe_load(run("fit", "basketball", "--format", fmt).output)
    assert old_keys | {"schema_version", "epsilon_with_drag", "drag_coefficient"} == set(data)
    assert set(data["epsilon_with_drag"]) == {"min", "nominal", "max"}
    assert data["epsilon_with_drag"]["nominal"] > data["epsilon"]["nominal"]
    assert data["schema_version"] == 1
    assert data["epsilon"]["nominal"] == pytest.approx(0.7661781385597868, rel=1e-15)   # full precision
    out = tmp_path / f"b.{fmt}"
    run("fit", "basketball", "-o", out)                       # the extension chooses the format
    assert yaml.safe_load(out.read_text()) == data


def test_pair_machine_file_keeps_every_key_and_adds_schema_version():
    data = json.loads(run("pair", "basketball", "tennis", "--format", "json").output)
    assert set(data) == {"K_per_s", "T_s", "bodies", "epsilon", "equations", "notes", "schema_version"}
    assert data["epsilon"] == pytest.approx(0.5707493661430295, rel=1e-15)


def test_pair_text_leads_with_the_pair_epsilon():
    first = run("pair", "basketball", "tennis").output.splitlines()[0]
    assert first == "basketball against tennis: ε = 0.571, T = 140 ms at K = 4 1/s"


# --------------------------------------------------------------------------- figures


def test_fig7_says_it_is_model_only():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from vrcal.plots import plot_ball_family

    ax = plot_ball_family("basketball", 4.0)
    texts = " ".join(t.get_text() for t in ax.texts)
    assert "model only" in texts and "K = 4 1/s" in texts
    plt.close(ax.figure)


def test_cradle_draws_horizontal_positions_and_says_where_balls_end():
    """No ball of the cradle leaves the floor: the figure shows x, the summary where each ball ends."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    from vrcal.scenes.multibody import simulate_scene
    from vrcal.scenes.output import leaves_floor, plot_heights, summary_text
    from vrcal.scenes.spec import load_scene

    res = simulate_scene(load_scene(EXAMPLES / "cradle.yaml"))
    assert not leaves_floor(res)
    ax = plot_heights(res)
    spans = [np.ptp(line.get_ydata()) for line in ax.get_lines()]
    assert max(spans) > 0.5                       # the striker and the last ball move by metres
    assert "horizontal" in ax.get_ylabel()
    plt.close(ax.figure)
    text = summary_text(res)
    assert "b3       stays on the floor; at 1 s x = 1.600 m, speed 2.000 m/s" in text


def test_compare_figure_has_a_difference_panel_and_a_short_legend():
    import io

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from vrcal.scenes.multibody import simulate_scene
    from vrcal.scenes.output import plot_difference, plot_heights
    from vrcal.scenes.spec import load_scene

    scene = load_scene(EXAMPLES / "figure9-five-balls.yaml")
    a = simulate_scene(scene)
    b = simulate_scene(scene)
    b.engine = "other"
    b.position_m = b.position_m + [0.0, 0.0, 0.001]   # 1 mm higher everywhere
    fig, (top, bottom) = plt.subplots(2, 1)
    plot_heights(a, ax=top, other=b)
    plot_difference(a, b, ax=bottom)
    assert len(top.get_legend().get_texts()) == len(scene.bodies) + 2     # bodies, then the two line styles
    diffs = [line.get_ydata() for line in bottom.get_lines()[:len(scene.bodies)]]
    assert all(abs(d - 1.0).max() < 1e-9 for d in diffs)                  # in mm
    fig.savefig(io.BytesIO(), format="png")
    plt.close(fig)


# --------------------------------------------------------------------------- start-up


def test_fit_does_not_import_scipy_or_matplotlib():
    code = ("import sys\nfrom vrcal.cli import main\n"
            "try:\n    main(['fit', 'basketball'])\nexcept SystemExit:\n    pass\n"
            "heavy = sorted(m for m in sys.modules if m.split('.')[0] in ('scipy', 'matplotlib', 'PIL'))\n"
            "print('HEAVY', heavy)\n")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    assert "basketball: ε = 0.766" in done.stdout
    assert done.stdout.strip().splitlines()[-1] == "HEAVY []"


@pytest.mark.parametrize("args, message", [
    (["-o", "p.json", "--format", "text"],
     "--format text with -o 'p.json', a .json file (json): name the file text (.txt) or leave out --format"),
    (["-o", "p.txt", "--format", "yaml"], "--format yaml with -o 'p.txt', a .txt file (text)"),
    (["-o", "p.csv"], "a .csv file is csv, which this command does not write"),
])
def test_pair_o_refuses_a_suffix_that_contradicts_the_format(tmp_path, args, message):
    """`pair -o p.json --format text` wrote text into p.json silently; the help said 'other -o files get
    yaml' while -o p.csv is refused: the help now says which are refused, and the behaviour follows it."""
    args = [a if not a.startswith("p.") else str(tmp_path / a) for a in args]
    result = CliRunner().invoke(main, ["pair", "tennis", "floor", *args])
    assert result.exit_code == 2 and message.replace("p.", str(tmp_path / "p.")) in " ".join(result.output.split())
    assert not list(tmp_path.iterdir())
    help_text = " ".join(CliRunner().invoke(main, ["pair", "--help"]).output.split())
    assert "other -o files get yaml" not in help_text and "such as .csv" in help_text


def test_pair_o_with_a_matching_or_unknown_suffix_writes(tmp_path):
    runner = CliRunner()
    txt = str(tmp_path / "p.txt")
    assert runner.invoke(main, ["pair", "tennis", "floor", "-o", txt, "--format", "text"]).exit_code == 0
    assert (tmp_path / "p.txt").read_text().startswith("tennis against floor")
    assert runner.invoke(main, ["pair", "tennis", "floor", "-o", str(tmp_path / "p.dat")]).exit_code == 0
    assert yaml.safe_load((tmp_path / "p.dat").read_text())["schema_version"] == 1
