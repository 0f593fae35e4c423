"""Tests of vrcal.model.table2: the paper's Table 2 checked under both readings of Eq. (10),
and Table 2 regenerated from the standards (deterministic, equal to docs/table2.md)."""

import json
import math
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from vrcal.cli import main
from vrcal.errors import UsageError
from vrcal.inverse import DEFAULT_K_PER_S
from vrcal.model import restitution as eq
from vrcal.model.restitution import epsilon_single
from vrcal.model.standards import ball_epsilon, get_ball, load_standards
from vrcal.model.table2 import (
    compare_paper,
    implied_K_per_s,
    least_squares_K_per_s,
    paper_rows,
    regenerate,
    table2_text,
)

ROOT = Path(__file__).resolve().parents[2]

# Table 2 of [1], as printed: ball -> (epsilon, x, v).
PAPER_TABLE2 = {
    "basketball": (0.85, 5, 0.42),
    "volleyball": (0.78, 6, 0.72),
    "football": (0.81, 3, 0.3),
    "table_tennis": (0.9, 1, 0.05),
}


def run(*args):
    return CliRunner().invoke(main, list(args))


def test_paper_rows_are_table2_of_the_paper():
    """Table 2 of [1] has four rows (no tennis row); the standards record them."""
    rows = paper_rows(load_standards())
    assert {r["ball"]: (r["epsilon"], r["x"], r["v"]) for r in rows} == PAPER_TABLE2


@pytest.mark.parametrize("ball", sorted(PAPER_TABLE2))
def test_row_K_under_both_readings(ball):
    """Table 2 of [1], e.g. basketball row: epsilon 0.85, x 5, v 0.42 implies K = -ln(0.85)/(5/(2*0.42))
    = 0.0273 under T = x/(2v) (Eq. 10 as printed) and K = -ln(0.85)/(0.42/(2*5)) = 3.87 under T = v/(2x)."""
    eps, x, v = PAPER_TABLE2[ball]
    row = next(r for r in compare_paper(load_standards())["rows"] if r["ball"] == ball)
    assert row["K_printed"] == pytest.approx(-math.log(eps) * 2 * v / x, rel=1e-12)
    assert row["K_swapped"] == pytest.approx(-math.log(eps) * 2 * x / v, rel=1e-12)
    # the implied K reproduces the row's epsilon through the model equation, Eq. (7) + (10)
    assert epsilon_single(x, v, row["K_printed"]) == pytest.approx(eps, rel=1e-12)
    assert epsilon_single(v, x, row["K_swapped"]) == pytest.approx(eps, rel=1e-12)


def test_basketball_row_numbers():
    """Table 2 of [1], basketball: epsilon 0.85, x 5, v 0.42 -> K = 0.0273 (printed), 3.87 (swapped)."""
    row = compare_paper(load_standards())["rows"][0]
    assert row["ball"] == "basketball"
    assert round(row["K_printed"], 4) == 0.0273
    assert round(row["K_swapped"], 2) == 3.87


def test_the_swapped_reading_is_dimensionally_sound():
    """Swapped, the x column holds the speed and the v column the depth: T = v/(2x) is a depth over twice a
    speed, a time [s], and K is in 1/s, as printed -- basketball 0.42 m / (2 * 5 m/s) = 0.042 s,
    K = -ln 0.85 / 0.042 = 3.87 1/s. The units note says so and never that K comes out in s."""
    cmp = compare_paper(load_standards())
    row = cmp["rows"][0]
    assert row["T_swapped"] == pytest.approx(eq.contact_time_single_s(0.42, 5.0)) == pytest.approx(0.042)
    assert row["K_swapped"] == pytest.approx(-math.log(0.85) / 0.042)
    units = cmp["units"]
    assert "K is in 1/s" in units and "in s:" not in units and "not the dimensions" not in units
    assert "0.042 s" in units and "3.87 1/s" in units


def test_least_squares_finding():
    """The paper's Table 2 follows T = v/(2x): one K near 4.1 fits all four rows within 0.01 in epsilon
    (the table prints epsilon to 2 digits); read as printed, no single K fits better than 0.12."""
    cmp = compare_paper(load_standards())
    sw, pr = cmp["readings"]["swapped"], cmp["readings"]["printed"]
    assert cmp["best"] == "swapped"
    assert sw["K_least_squares"] == pytest.approx(4.11, abs=0.005)
    assert sw["max_abs_epsilon_error"] < 0.01
    assert pr["K_least_squares"] == pytest.approx(0.0241, abs=0.0001)
    assert pr["max_abs_epsilon_error"] > 0.12
    assert "T = v/(2x)" in cmp["finding"] and "no units" in cmp["finding"]


def test_least_squares_is_the_minimum():
    """The fitted K minimises the sum of squares: nudging it either way makes the fit worse."""
    eps = np.array([v[0] for v in PAPER_TABLE2.values()])
    T = np.array([v[2] / (2 * v[1]) for v in PAPER_TABLE2.values()])
    K, err, res = least_squares_K_per_s(eps, T)
    ssr = lambda k: float(np.sum((np.exp(-k * T) - eps) ** 2))  # noqa: E731
    assert ssr(K) < ssr(K * 1.001) and ssr(K) < ssr(K * 0.999)
    assert err == pytest.approx(np.max(np.abs(res)))


def test_least_squares_recovers_a_planted_K():
    """Rows generated with K = 2.5 exactly give back K = 2.5 and zero error."""
    T = np.array([0.01, 0.05, 0.1, 0.3])
    K, err, _ = least_squares_K_per_s(np.exp(-2.5 * T), T)
    assert K == pytest.approx(2.5, rel=1e-9)
    assert err < 1e-12


def test_implied_K_scalar_and_array_agree():
    arr = implied_K_per_s(np.array([0.85, 0.9]), np.array([0.042, 0.025]))
    assert implied_K_per_s(0.85, 0.042) == arr[0]
    assert isinstance(implied_K_per_s(0.85, 0.042), float)
    with pytest.raises(UsageError):
        implied_K_per_s(0.85, 0.0)


def test_regenerated_rows_follow_the_rule():
    """Every ball of the file, in file order; x = R/2, v = x/(2T), T = -ln(eps)/K, eps from ball_epsilon."""
    std = load_standards()
    table = regenerate(std, 4.0)
    assert [r["ball"] for r in table["rows"]] == list(std)
    for r in table["rows"]:
        ball = get_ball(r["ball"])
        eps = ball_epsilon(ball)
        assert r["epsilon"]["nominal"] == eps.nominal
        assert r["x_m"] == pytest.approx(ball.radius_m / 2)
        assert r["T_nominal_s"] == pytest.approx(-math.log(eps.nominal) / 4.0, rel=1e-12)
        # round trip through the model: the virtual body gives back the nominal epsilon
        assert epsilon_single(r["x_m"], r["v_m_per_s"]["nominal"], 4.0) == pytest.approx(eps.nominal, rel=1e-12)
        assert epsilon_single(r["x_m"], r["v_m_per_s"]["min"], 4.0) == pytest.approx(eps.min, rel=1e-12)
        assert r["v_m_per_s"]["min"] < r["v_m_per_s"]["nominal"] < r["v_m_per_s"]["max"]
    tennis = next(r for r in table["rows"] if r["ball"] == "tennis")
    assert tennis["epsilon_paper_table2"] is None


def test_as_paper_uses_table1_heights():
    """Table 1 of [1], basketball: sqrt(1.3/1.8) = 0.85 when heights are taken as printed."""
    row = regenerate(load_standards(), 4.0, as_paper=True)["rows"][0]
    assert row["epsilon"]["nominal"] == pytest.approx(0.85, abs=0.001)


def test_K_scales_T_and_v():
    """Doubling K halves T and doubles v at the same x (Eqs. 7 and 10)."""
    a, b = (regenerate(load_standards(), K)["rows"][2] for K in (2.0, 4.0))
    assert b["T_nominal_s"] == pytest.approx(a["T_nominal_s"] / 2)
    assert b["v_m_per_s"]["nominal"] == pytest.approx(2 * a["v_m_per_s"]["nominal"])


@pytest.mark.parametrize("K", [0.0, -1.0, math.nan, math.inf])
def test_bad_K_is_a_usage_error(K):
    with pytest.raises(UsageError, match="K must be"):
        regenerate(load_standards(), K)


@pytest.mark.parametrize("fmt", ["text", "markdown", "csv", "json", "yaml"])
@pytest.mark.parametrize("compare", [False, True])
def test_output_is_deterministic(fmt, compare):
    std = load_standards()
    first = table2_text(std, 4.0, fmt, compare)
    assert first == table2_text(load_standards(), 4.0, fmt, compare)
    assert first.endswith("\n")
    if fmt in ("json", "yaml"):
        import yaml

        assert yaml.safe_load(first)["schema_version"] == 1
    if fmt == "text":
        assert max(len(line) for line in first.splitlines()) <= 100


def test_committed_table_equals_the_command_output():
    """CI diffs docs/table2.md against `vrcal table2 --format markdown`; keep them equal."""
    result = run("table2", "--format", "markdown")
    assert result.exit_code == 0, result.output
    assert (ROOT / "docs" / "table2.md").read_text(encoding="utf-8") == result.output


def test_cli_two_runs_byte_identical_and_default_is_a_table_for_people(tmp_path):
    a, b = run("table2"), run("table2")
    assert a.exit_code == 0 and a.output == b.output
    assert a.output == run("table2", "--format", "text", "--K", str(DEFAULT_K_PER_S)).output
    assert a.output.startswith("Table 2 of [1], regenerated (K = 4 1/s)")
    assert run("table2", "-o", str(tmp_path / "t.md")).exit_code == 0
    assert (tmp_path / "t.md").read_text(encoding="utf-8").startswith("# Table 2 of [1], regenerated")


def test_cli_compare_paper():
    result = run("table2", "--compare-paper", "--format", "markdown")
    assert result.exit_code == 0
    assert "| basketball | 0.85 | 5 | 0.42 | 5.952 | 0.02730 | 0.04200 | 3.869 |" in result.output
    assert "| swapped | T = v/(2x) | 3.869..4.214 | 4.109 | 0.0085 |" in result.output
    data = json.loads(run("table2", "--compare-paper", "--format", "json").output)
    assert data["best"] == "swapped"
    lines = run("table2", "--compare-paper", "--format", "csv").output.splitlines()
    assert len(lines) == 1 + 2 * len(PAPER_TABLE2)


def test_cli_csv_has_every_ball():
    lines = run("table2", "--format", "csv").output.splitlines()
    assert lines[0].startswith("ball,epsilon_min,epsilon_nominal,epsilon_max")
    assert [ln.split(",")[0] for ln in lines[1:]] == list(load_standards())


def test_cli_honours_standards_file(tmp_path):
    """--standards FILE: a file with only two of the paper's balls gives two rows and a compare of two."""
    from importlib import resources

    import yaml

    doc = yaml.safe_load(resources.files("vrcal").joinpath("standards.yaml").read_text())
    doc["balls"] = {k: doc["balls"][k] for k in ("table_tennis", "football")}
    f = tmp_path / "two.yaml"
    f.write_text(yaml.safe_dump(doc, sort_keys=False))
    out = run("--standards", str(f), "table2", "--format", "csv").output.splitlines()
    assert [ln.split(",")[0] for ln in out[1:]] == ["table_tennis", "football"]
    assert run("table2", "--standards", str(f), "--format", "csv").output.splitlines() == out
    doc["balls"] = {"football": doc["balls"]["football"]}
    f.write_text(yaml.safe_dump(doc, sort_keys=False))
    res = run("--standards", str(f), "table2", "--compare-paper")
    assert res.exit_code == 2 and "at least 2" in res.output


@pytest.mark.parametrize("args, code, text", [
    (["table2", "--K", "0"], 2, "--K must be a number between"),
    (["table2", "--K", "abc"], 2, "--K must be a number between 1e-06 and 1e+06 [1/s], got 'abc'"),
    (["table2", "--format", "xml"], 2, "Invalid value for '--format'"),
    (["table2", "-o", "/nonexistent-dir/t.md"], 2, "does not exist"),
])
def test_cli_bad_input(args, code, text):
    result = run(*args)
    assert result.exit_code == code
    assert text in result.output
    assert "Traceback" not in result.output
    assert len(result.output.strip().splitlines()) == 1


def test_no_single_K_reproduces_all_four_printed_digits():
    """Table 2 of [1] prints epsilon to 2 digits. Under T = v/(2x) with x, v exact, the basketball row
    (0.85) needs K <= -ln(0.845)/0.042 = 4.010 and the volleyball row (0.78) needs K > -ln(0.785)/0.06
    = 4.035: the intervals are disjoint, hence the least-squares error above the 0.005 rounding."""
    rows = {r["ball"]: r for r in compare_paper(load_standards())["rows"]}
    k_max_basketball = -math.log(rows["basketball"]["epsilon"] - 0.005) / rows["basketball"]["T_swapped"]
    k_min_volleyball = -math.log(rows["volleyball"]["epsilon"] + 0.005) / rows["volleyball"]["T_swapped"]
    assert k_max_basketball < k_min_volleyball
    assert compare_paper(load_standards())["readings"]["swapped"]["max_abs_epsilon_error"] > 0.005
    # football and table tennis imply the very same K: ln 0.81 = 2 ln 0.9 and 2x/v = 20 and 40
    assert rows["football"]["K_swapped"] == pytest.approx(rows["table_tennis"]["K_swapped"], rel=1e-12)


def test_the_papers_blank_basketball_max_stays_blank_in_machine_output():
    """[1] Table 1 prints no maximum for the basketball (rebound max and epsilon max blank); the CSV's
    epsilon_paper_table1_max copied the minimum, 0.8498."""
    import csv
    import io

    from vrcal.model.standards import load_standards
    from vrcal.model.table2 import table2_text

    rows = {r["ball"]: r for r in csv.DictReader(io.StringIO(table2_text(load_standards(), 4.0, "csv")))}
    assert rows["basketball"]["epsilon_paper_table1_max"] == ""
    assert float(rows["basketball"]["epsilon_paper_table1_min"]) == pytest.approx(math.sqrt(1.3 / 1.8), abs=1e-9)
    assert float(rows["volleyball"]["epsilon_paper_table1_max"]) == pytest.approx(math.sqrt(0.66 / 1.0), abs=1e-9)


def test_compare_paper_refuses_options_it_would_ignore():
    """'table2 --compare-paper --as-paper --K 7' printed the comparison unchanged, exit 0: the options were
    silently ignored."""
    for extra, named in ((["--K", "7"], "--K does not apply"), (["--as-paper"], "--as-paper does not apply"),
                         (["--as-paper", "--K", "7"], "--K and --as-paper do not apply")):
        result = CliRunner().invoke(main, ["table2", "--compare-paper", *extra])
        assert result.exit_code == 2 and named in result.output and result.output.count("\n") == 1
