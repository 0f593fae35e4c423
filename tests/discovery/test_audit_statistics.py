"""A referee's audit of ``vrcal discover`` reports (statistics and consistency), its records rebuilt here:
an effect named on a misfit, the bounces' scatter counted from timing noise, a +- below an assumed timing
noise, a held drag's epsilon quoted at a speed the ball never reaches, the digits of epsilon(v) and g, the
drag-free effective epsilon, and a joint report's headline."""

import re

import numpy as np
import pytest

from vrcal.discovery.ranking import Thresholds, discover_file, gap_removed_enough
from vrcal.discovery.report import engine_advice, fit_report

G = 9.80665


def bounces_with_a_linear_speed_law(path, seed=20240):
    """A tennis ball (57 g, 67 mm) held at 2 m for 0.2 s, then dropped: no drag, epsilon(v) = 0.85 - 0.03 v
    (a line, which the registry's power law cannot follow exactly), 240 Hz, 1 mm noise (the probe's record b,
    rebuilt analytically: its flights are parabolas)."""
    t = np.arange(0.0, 4.0, 1.0 / 240.0)
    y = np.full(t.size, 2.0)
    t0, y0, v0 = 0.2, 2.0, 0.0
    while t0 < 4.0:
        # the flight y0 + v0 s - g s^2 / 2 until it reaches the floor
        s_hit = (v0 + np.sqrt(v0**2 + 2.0 * G * y0)) / G
        m = (t >= t0) & (t < t0 + s_hit)
        y[m] = np.maximum(y0 + v0 * (t[m] - t0) - 0.5 * G * (t[m] - t0) ** 2, 0.0)
        v_in = G * s_hit - v0      # the speed down at the floor
        t0, y0, v0 = t0 + s_hit, 0.0, (0.85 - 0.03 * v_in) * v_in
        if v_in < 0.05:
            y[t >= t0] = 0.0
            break
    y = y + np.random.default_rng(seed).normal(0.0, 0.001, t.size)
    np.savetxt(path, np.c_[t, y], delimiter=",", header="t,y", comments="", fmt="%.6f")
    return path


def golf_times(path, jitter_s, seed=None):
    """15 impact times of a golf ball dropped from 1 m, a constant epsilon 0.78, no drag, instantaneous contacts;
    ``jitter_s`` of timing noise (0: exact)."""
    times, v = [np.sqrt(2.0 / G)], np.sqrt(2.0 * G)
    while len(times) < 15:
        v *= 0.78
        times.append(times[-1] + 2.0 * v / G)
    times = np.asarray(times)
    if jitter_s:
        times = times + np.random.default_rng(seed).normal(0.0, jitter_s, times.size)
    np.savetxt(path, times, header="t (s)", comments="", fmt="%.7f")
    return path


def test_a_misfit_does_not_let_any_added_parameter_count():
    """Removing 0.2 noise sigma (in quadrature) from a gap of 5 sigma is what following a sliver of the misfit
    does: judged so, drag was named with C_d 0.35 on a record without drag."""
    th = Thresholds()
    assert not gap_removed_enough(5.157, 5.010, 0.993, th)          # the probe's record: 1.22 mm removed
    assert gap_removed_enough(1.0, 0.979, 1.0, th)                   # at the noise: 0.2 sigma removed counts
    assert gap_removed_enough(5.157, 1.0, 0.993, th)                 # a misfit removed to the noise counts
    assert gap_removed_enough(5.157, 4.6, 0.993, th)                 # a shrink by 0.9 counts


def test_no_drag_is_named_on_a_record_without_drag(tmp_path):
    path = bounces_with_a_linear_speed_law(tmp_path / "b.csv")
    d = discover_file(str(path), None, mass_kg=0.057, diameter_m=0.067)
    assert d.effects == ["velocity_dependent_restitution"], d.effects
    text = " ".join(fit_report(d, details=True).split())
    assert "air drag found here" not in text
    assert ("the gap shrinks (x0.9; or the gap removed, sqrt(before^2 - after^2), is at least sqrt((0.2 sigma)^2 + "
            "(1 - 0.9^2) m^2), m = sqrt(before^2 - sigma^2) the misfit beyond the noise)") in text
    # one speed and one epsilon for the first bounce (the spurious drag made the speeds line say 6.18 m/s)
    lo, hi = d.speed_range()
    first = d.bounce_epsilons[0]
    assert hi == pytest.approx(first["impact_speed_m_per_s"], abs=0.03)
    assert hi == pytest.approx(np.sqrt(2 * G * 2.0), abs=0.03)
    # epsilon(v) with a +-, which holds the truth at the slowest impact
    m = re.search(r"epsilon\(v\): (0\.\d+) ± ([\d.]+) at ([\d.]+) m/s", text)
    assert m, text
    eps, unc, v = map(float, m.groups())
    assert abs(eps - (0.85 - 0.03 * v)) < 2 * unc


def test_timing_noise_is_not_the_bounces_scatter(tmp_path):
    """Golf impact times of 0.2 ms jitter and no scatter: the robust scatter of their ratios (0.67 %) was taken
    as the ball's, above the 0.41 % the times allow, and the verdict's tolerance was 24 times the noise."""
    scatters = []
    for seed in range(6):
        path = golf_times(tmp_path / f"c{seed}.csv", 2e-4, seed)
        doc = discover_file(str(path), None, mass_kg=0.0459, diameter_m=0.0427).as_dict()
        if doc["scatter_upper_limit"] is not None:
            assert (doc["scatter"] or 0.0) <= doc["scatter_upper_limit"] + 1e-12, (seed, doc["scatter"])
        scatters.append(doc["scatter"] or 0.0)
        assert doc["verdict"] == "explained"
    assert np.median(scatters) < 0.001, scatters


def test_an_assumed_timing_noise_is_the_floor_of_the_uncertainty(tmp_path):
    """Noise-free golf times judged at the assumed 0.2 ms: epsilon = 0.780000 +- 4e-09 beside 'noise 0.200 ms
    (assumed)'; the +- that noise implies is 3e-5."""
    path = golf_times(tmp_path / "exact.csv", 0.0)
    d = discover_file(str(path), None, mass_kg=0.0459, diameter_m=0.0427)
    assert d.noise_source.startswith("assumed")
    assert 1.5e-5 < d.epsilon_uncertainty < 6e-5
    assert abs(d.epsilon - 0.78) < 1e-6


#: The probe's drop table of a 2.7 g, 40 mm ball (C_d 0.47 and a speed law planted; three trials at five heights).
DRAG_TABLE = """drop height (cm),rebound height (cm)
20.0,13.74
20.0,13.63
20.0,13.85
52.5,29.88
52.5,30.02
52.5,29.82
85.0,41.19
85.0,41.15
85.0,41.45
117.5,50.38
117.5,50.11
117.5,49.81
150.0,56.69
150.0,57.21
150.0,56.93
"""


def test_a_held_drags_epsilon_is_quoted_at_the_speed_the_ball_reaches(tmp_path):
    """The speed law's pivot is sqrt(2 g H) of the highest drop without drag (5.42 m/s); with a sphere's drag
    held the ball lands at 4.93 m/s, where the same law gives 0.7046 (quoted before: 0.6815 at 5.42 m/s)."""
    path = tmp_path / "table.csv"
    path.write_text(DRAG_TABLE)
    d = discover_file(str(path), None, mass_kg=0.0027, diameter_m=0.04)
    sys_ = d.systematic
    assert "air_drag.drag_coefficient" in sys_["held"]
    fastest = sys_["fastest_impact"]
    held = d.held_fit(sys_["held"])
    assert fastest["speed_m_per_s"] == pytest.approx(d.speed_range(held)[1])
    assert fastest["speed_m_per_s"] < d.reference_speed - 0.3
    text = " ".join(" ".join(engine_advice(d)).split())
    assert f"epsilon {fastest['epsilon']:.4f} at {fastest['speed_m_per_s']:.2f} m/s" in text
    assert abs(fastest["epsilon"] - 0.7034) < 0.01
    assert d.as_dict()["epsilon_systematic"]["fastest_impact"] == fastest


def test_g_is_written_to_three_significant_digits():
    from vrcal.textout import number

    assert number(9.797, 3) == "9.80" and number(9.806, 3) == "9.81" and number(0.879, 3) == "0.879"


def _heights_misfit(eps, drops, bounces):
    """H eps^(2n) / h_n - 1 of the apexes of ``drops`` (their first ``bounces`` rebounds) for a constant eps."""
    apex = drops.apex_heights_m[0]
    n = np.arange(1, bounces + 1)
    return apex[0] * eps ** (2 * n) / apex[1:bounces + 1] - 1


def test_the_drag_free_effective_epsilon_is_fitted_to_the_bottom_s_heights(tmp_path):
    """A tennis ball tracked at its centre with drag: an engine without drag gets the constant that reproduces
    the heights of the ball's bottom, which the offset vrcal names does not move (the baseline's was 0.7351
    where the offset held gives 0.7358, 15 times the +-). It was a refit of the whole record without drag,
    which put the flights' timing into epsilon with the heights; it is fitted to the model's apexes now."""
    from vrcal.drop.simulate import simulate_drops
    from vrcal.engines.replay import APEX_GOAL
    from vrcal.model.body import BallProperties
    from vrcal.model.restitution import AIR_DENSITY_KG_PER_M3, constant_epsilon_for_heights

    t = np.arange(0.0, 4.0, 1.0 / 240.0)
    path = tmp_path / "centre.csv"
    data = _tennis_with_drag_at_its_centre(t)
    np.savetxt(path, data, delimiter=",", header="t,y", comments="", fmt="%.6f")
    d = discover_file(str(path), None, mass_kg=0.057, diameter_m=0.067)
    assert set(d.effects) == {"height_offset", "air_drag"}, d.effects
    eff = d.effective_without_drag
    n = eff["bounces"]
    assert 2 <= n <= eff["of"]
    truth = simulate_drops(2.0, 0.75, eff["of"], BallProperties(0.057, 0.067),
                           effects={"air_drag": {"drag_coefficient": 0.5 * 1.2 / AIR_DENSITY_KG_PER_M3}})
    own, _ = constant_epsilon_for_heights(2.0, truth.apex_heights_m[0, 1:n + 1], np.arange(1, n + 1))
    assert eff["epsilon"] == pytest.approx(own, abs=5e-4)
    assert np.max(np.abs(_heights_misfit(eff["epsilon"], truth, n))) <= APEX_GOAL + 2e-3
    text = " ".join(" ".join(engine_advice(d)).split())
    assert f"with the effective epsilon = {eff['epsilon']:.4f}" in text
    assert d.as_dict()["epsilon_effective_without_drag"] == eff["epsilon"]


@pytest.mark.parametrize("args, drop, epsilon, ball, effects, bounces", [
    # an exercise ball with drag and buoyancy (the probe's): the baseline's 0.8238 was offered, 11.6 % to
    # 35.7 % too high at its five rebounds
    (["--mass", "1.2", "--diameter", "0.65", "--drop", "1", "--epsilon", "0.82", "--bounces", "5",
      "--effect", "air_drag:drag_coefficient=0.47", "--effect", "buoyancy"], 1.0, 0.82, (1.2, 0.65),
     {"air_drag": {"drag_coefficient": 0.47}, "buoyancy": {}}, 3),
    # a table-tennis ball with drag only: the baseline's 0.8871 was 3.5 % to 5.7 % too high at its first five
    (["table_tennis", "--drop", "0.305", "--epsilon", "0.9", "--effect", "air_drag"], 0.305, 0.9, (0.0027, 0.04),
     {"air_drag": {"drag_coefficient": 0.5}}, 5),
])
def test_the_drag_free_advice_reproduces_the_bounce_heights(tmp_path, args, drop, epsilon, ball, effects, bounces):
    """The constant epsilon offered for an engine without drag reproduces the record's bounce heights within
    the goal of ``vrcal verify`` over the bounces it names, where the baseline's (a fit of the whole record,
    whose timing buoyancy and drag stretch) did not."""
    from click.testing import CliRunner

    from vrcal.cli import main
    from vrcal.drop.simulate import simulate_drops
    from vrcal.engines.replay import APEX_GOAL
    from vrcal.model.body import BallProperties

    rec = tmp_path / "rec.csv"
    made = CliRunner().invoke(main, ["simulate", *args, "--noise", "0.001", "-o", str(rec)])
    assert made.exit_code == 0, made.output
    d = discover_file(str(rec), None, mass_kg=ball[0], diameter_m=ball[1])
    assert "air_drag" in d.effects
    eff = d.effective_without_drag
    assert eff["bounces"] == bounces and eff["of"] > bounces
    truth = simulate_drops(drop, epsilon, eff["of"], BallProperties(*ball), effects=effects)
    assert np.max(np.abs(_heights_misfit(eff["epsilon"], truth, bounces))) <= APEX_GOAL + 2e-3
    assert np.max(np.abs(_heights_misfit(d.epsilon_baseline, truth, bounces))) > APEX_GOAL
    text = " ".join(" ".join(engine_advice(d)).split())
    assert (f"an engine without drag reproduces the first {bounces} bounce heights within "
            f"{100 * eff['misfit']:.1f} % with the effective epsilon = {eff['epsilon']:.4f}") in text
    assert f"no constant reproduces all {eff['of']} within 3 %" in text


def _tennis_with_drag_at_its_centre(t, seed=20240):
    """The probe's record a: held at 2 m for 0.2 s, epsilon 0.75, drag k = 1.2 C_d pi D^2 / (8 m) with C_d 0.5,
    the centre tracked (D / 2 above the bottom), 1 mm noise; integrated here with a fine Runge-Kutta step."""
    m, D = 0.057, 0.067
    k = 1.2 * 0.5 * np.pi * D**2 / (8 * m)
    dt = 1e-5
    y, v, now = 2.0, 0.0, 0.2
    out = np.full(t.size, 2.0)
    i = int(np.searchsorted(t, now))

    def acc(v):
        return -G - k * v * abs(v)

    while i < t.size:
        # RK4 of (y, v) over dt; a contact when y crosses 0 going down
        k1y, k1v = v, acc(v)
        k2y, k2v = v + 0.5 * dt * k1v, acc(v + 0.5 * dt * k1v)
        k3y, k3v = v + 0.5 * dt * k2v, acc(v + 0.5 * dt * k2v)
        k4y, k4v = v + dt * k3v, acc(v + dt * k3v)
        y_new = y + dt / 6 * (k1y + 2 * k2y + 2 * k3y + k4y)
        v_new = v + dt / 6 * (k1v + 2 * k2v + 2 * k3v + k4v)
        if y_new < 0.0 and v_new < 0:
            frac = y / (y - y_new)
            v_hit = v + frac * (v_new - v)
            y_new, v_new = 0.0, -0.75 * v_hit
            if abs(v_hit) < 0.05:
                v_new = 0.0
        now += dt
        y, v = y_new, v_new
        while i < t.size and t[i] <= now:
            out[i] = max(y, 0.0)
            i += 1
    return np.c_[t, out + D / 2 + np.random.default_rng(seed).normal(0.0, 0.001, t.size)]


#: Impact times of ten drops of a table-tennis ball read off a 60 fps video (a probe's, 59 times).
TRIALS = ["0.6000 1.1500 1.6333 2.0833 2.5000", "0.5833 1.1166 1.5999 2.0499 2.4666",
          "0.6000 1.1500 1.6333 2.0833 2.5000", "0.6000 1.1167 1.6167 2.0667 2.4834",
          "0.6000 1.1500 1.6333 2.0833 2.5000", "0.6000 1.1333 1.6166 2.0666 2.4833",
          "0.6000 1.1333 1.6166 2.0666 2.4833", "0.6000 1.1333 1.6333 2.0833 2.5000",
          "0.6000 1.1500 1.6333 2.0833 2.5000", "0.6000 1.1500 1.6333 2.0833 2.5000"]


def test_a_joint_report_leads_with_the_value_to_use(tmp_path):
    """Its headline was the named drag's 0.974 +- 0.018, a rival's speed law 'p = 1.000' at its limit unmarked,
    and 'Most probable ... 0.9578 ... Use this' below them: a reader top-down took the headline."""
    paths = []
    for i, row in enumerate(TRIALS):
        p = tmp_path / f"trial{i + 1}_impacts.csv"
        p.write_text("t\n0.0000\n" + "\n".join(row.split()) + "\n")
        paths.append(p)
    d = discover_file([str(p) for p in paths], "table_tennis")
    doc = d.as_dict()
    lines = engine_advice(d)
    text = " ".join(fit_report(d).split())
    if doc["prior_split"] is not None:
        assert "the most probable value" in lines[0] and "Use this." in lines[0]
        assert lines[1].startswith("Rivals, each one explanation alone")
        assert all(line.startswith("- with ") for line in lines[2:4])
        assert "Use this; each value above" not in text
    marked = 0
    for rivals in doc["ambiguous_epsilon"].values():
        for rival, alt in rivals.items():
            for name in alt["at_limit"]:
                assert "(at its physical limit)" in text, (rival, name)
                marked += 1
    assert marked, doc["ambiguous_epsilon"]   # the speed law's exponent held at 1
