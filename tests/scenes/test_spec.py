"""Tests of vrcal.scenes.spec (schema, loader, epsilon per pair), vrcal.scenes.output and the `vrcal scene` command."""

import copy
import csv
import io
import math
from pathlib import Path

import numpy as np
import pytest
import yaml
from click.testing import CliRunner

from vrcal.cli import main
from vrcal.errors import DataError, UsageError
from vrcal.inverse import pair
from vrcal.model import restitution as eq
from vrcal.scenes.spec import contact_epsilon, load_scene, validate_scene

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"
EXAMPLE_FILES = sorted(EXAMPLES.glob("*.yaml"))

GOOD = {
    "K_per_s": 4.0, "duration_s": 1.0, "floor": {"material": "steel"},
    "bodies": [
        {"name": "b1", "ball": "basketball", "position_m": [0, 0, 1.0]},
        {"name": "b2", "mass_kg": 0.1, "radius_m": 0.05, "virtual_body": {"x_m": 0.01, "v_m_per_s": 0.2},
         "position_m": [1.0, 0, 1.0]},
    ],
}


def doc_with(path, value, delete=False):
    doc = copy.deepcopy(GOOD)
    *head, last = path
    target = doc
    for key in head:
        target = target[key]
    if delete:
        del target[last]
    else:
        target[last] = value
    return doc


def test_example_scenes_exist_and_load():
    names = {p.stem for p in EXAMPLE_FILES}
    assert {"figure8-basketball", "figure9-five-balls", "stack-drop"} <= names
    for path in EXAMPLE_FILES:
        scene = load_scene(path)
        assert scene.bodies and scene.duration_s > 0


def test_ball_kind_gets_the_virtual_body_of_vrcal_pair():
    """A `ball:` body has the nominal mass and radius of its standard and the same virtual body as `vrcal pair`."""
    scene = validate_scene(GOOD, "s.yaml")
    b1 = scene.bodies[0]
    ref = pair("basketball", "floor", 4.0)["bodies"][0]
    assert (b1.x_m, b1.v_m_per_s) == (ref["x_m"], ref["v_m_per_s"])
    assert b1.inertia_factor == pytest.approx(2 / 3)  # a sports ball is a hollow shell
    eps = scene.epsilon_matrix()
    assert eps[0, -1] == pytest.approx(ref["epsilon_on_rigid_floor"], rel=1e-12)


def test_pair_epsilon_is_eq6_then_eq7_and_the_product_of_floor_epsilons():
    scene = validate_scene(GOOD, "s.yaml")
    eps = scene.epsilon_matrix()
    a, b = scene.bodies
    T = a.x_m / (2 * a.v_m_per_s) + b.x_m / (2 * b.v_m_per_s)
    assert eps[0, 1] == pytest.approx(math.exp(-4.0 * T), rel=1e-12)
    assert eps[0, 1] == pytest.approx(eps[0, -1] * eps[1, -1], rel=1e-12)
    assert eps[0, 1] == eps[1, 0]
    assert eps[-1, -1] == 1.0


def test_contact_epsilon_scalar_and_array_agree():
    x = np.array([0.0, 0.01, 0.05])
    v = np.array([0.0, 0.1, 0.3])
    arr = contact_epsilon(x, v, 0.02, 0.2, 4.0)
    for k in range(3):
        assert arr[k] == contact_epsilon(float(x[k]), float(v[k]), 0.02, 0.2, 4.0)
    assert arr[0] == pytest.approx(eq.epsilon_single(0.02, 0.2, 4.0))


def test_floor_with_an_explicit_virtual_body_lowers_every_epsilon():
    soft = validate_scene(doc_with(["floor"], {"x_m": 0.01, "v_m_per_s": 0.1}), "s.yaml")
    steel = validate_scene(GOOD, "s.yaml")
    factor = math.exp(-4.0 * 0.01 / 0.2)
    np.testing.assert_allclose(soft.epsilon_matrix()[:2, -1], steel.epsilon_matrix()[:2, -1] * factor, rtol=1e-12)


def test_position_of_bottom_lifts_the_centre_by_the_radius():
    scene = validate_scene(doc_with(["bodies", 1, "position_of"], "bottom"), "s.yaml")
    assert scene.bodies[1].position_m[2] == pytest.approx(1.05)


BAD = [
    (["bodies", 1, "radius_m"], -0.1, "s.yaml: bodies[1] (name 'b2').radius_m: must be > 0, got -0.1"),
    (["bodies", 1, "mass_kg"], "heavy", "bodies[1] (name 'b2').mass_kg: must be a number"),
    (["bodies", 0, "ball"], "basketbal", "bodies[0] (name 'b1').ball: unknown ball 'basketbal'; did you mean"),
    (["bodies", 1, "virtual_body"], None, "bodies[1] (name 'b2').virtual_body: missing"),
    (["bodies", 1, "virtual_body"], {"x_m": 0.2, "v_m_per_s": 1.0}, "virtual_body.x_m: the virtual body lies inside"),
    (["bodies", 1, "virtual_body"], {"x_m": 0.01}, "bodies[1] (name 'b2').virtual_body.v_m_per_s: missing"),
    (["bodies", 1, "position_m"], [0, 0], "bodies[1] (name 'b2').position_m: must be a list of 3 numbers"),
    (["bodies", 1, "position_m"], [0, 0, 0.01], "bodies[1] (name 'b2').position_m: the sphere reaches below"),
    (["bodies", 1, "position_m"], [0.1, 0, 1.0], "bodies[1] (name 'b2').position_m: overlaps bodies[0] (name 'b1')"),
    (["bodies", 1, "colour"], "red", "bodies[1] (name 'b2'): unknown field(s) ['colour']"),
    (["bodies", 1, "inertia"], "cube", "bodies[1] (name 'b2').inertia: must be one of ['hollow', 'solid']"),
    (["bodies", 1, "name"], "b1", "bodies[1].name: duplicate name 'b1'"),
    (["bodies", 1, "name"], "floor", "bodies[1].name: must be a non-empty text other than 'floor'"),
    (["floor"], {"material": "rubber"}, "floor.material: unknown material 'rubber' (known: steel, rigid"),
    (["floor"], {"x_m": 0.01}, "floor.v_m_per_s: missing"),
    (["K_per_s"], 0, "K_per_s: must be > 0"),
    (["duration_s"], None, "duration_s: missing"),
    (["bodies"], [], "bodies: must be a non-empty list"),
    (["gravity"], 9.8, "top level: unknown field(s) ['gravity']"),
    (["frction_mu"], 0.5, "top level: unknown field(s) ['frction_mu']; did you mean 'friction_mu'?"),
]


@pytest.mark.parametrize("path,value,message", BAD, ids=[m.split(":")[-2][-30:] + str(i) for i, (_p, _v, m) in
                                                          enumerate(BAD)])
def test_bad_scene_names_the_body_and_the_field(path, value, message):
    doc = doc_with(path, value, delete=value is None)
    with pytest.raises(DataError) as err:
        validate_scene(doc, "s.yaml")
    assert message in str(err.value)


def test_malformed_yaml_gives_file_and_line(tmp_path):
    path = tmp_path / "bad.yaml"
    path.write_text("K_per_s: 4\nbodies: [\n  {name: a\n")
    with pytest.raises(DataError, match=r"bad.yaml:\d+: malformed YAML"):
        load_scene(path)


def test_missing_scene_file_is_a_usage_error(tmp_path):
    with pytest.raises(UsageError, match="no such scene file"):
        load_scene(tmp_path / "nope.yaml")


# --------------------------------------------------------------------------- outputs and the command line


def short_scene_file(tmp_path, duration=1.2):
    doc = {"name": "two", "K_per_s": 4.0, "duration_s": duration, "sample_dt_s": 0.02, "floor": {"material": "steel"},
           "bodies": [{"name": "big", "ball": "basketball", "position_m": [0, 0, 0.8], "position_of": "bottom"},
                      {"name": "small", "ball": "tennis", "position_m": [0.5, 0, 0.5], "position_of": "bottom",
                       "velocity_m_per_s": [-0.3, 0, 0]}]}
    path = tmp_path / "two.yaml"
    path.write_text(yaml.safe_dump(doc))
    return path


def test_cli_scene_writes_csv_plot_and_animation(tmp_path):
    path = short_scene_file(tmp_path)
    out = tmp_path / "out"
    result = CliRunner().invoke(main, ["scene", str(path), "-o", str(out)])
    assert result.exit_code == 0, result.output
    assert "contacts in 1.2 s" in result.output and "big - floor" in result.output
    assert sorted(p.name for p in out.iterdir()) == ["two-contacts.csv", "two-trajectories.csv", "two.gif", "two.png"]
    rows = list(csv.DictReader(io.StringIO((out / "two-trajectories.csv").read_text())))
    assert list(rows[0]) == ["t_s", "body", "x_m", "y_m", "z_m", "bottom_m", "vx_m_per_s", "vy_m_per_s",
                             "vz_m_per_s", "wx_rad_per_s", "wy_rad_per_s", "wz_rad_per_s"]
    assert [r["body"] for r in rows[:2]] == ["big", "small"]
    assert len(rows) == 2 * (int(round(1.2 / 0.02)) + 1)
    assert float(rows[0]["bottom_m"]) == pytest.approx(0.8)
    contacts = list(csv.DictReader(io.StringIO((out / "two-contacts.csv").read_text())))
    assert contacts[0]["body_b"] == "floor" and 0 < float(contacts[0]["epsilon"]) < 1
    gif = (out / "two.gif").read_bytes()
    assert gif[:6] == b"GIF89a"
    from PIL import Image

    with Image.open(out / "two.gif") as im:
        assert 10 <= im.n_frames <= 150
    assert (out / "two.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_cli_scene_output_is_repeatable(tmp_path):
    path = short_scene_file(tmp_path, duration=0.5)
    texts = []
    for name in ("a", "b"):
        result = CliRunner().invoke(main, ["scene", str(path), "-o", str(tmp_path / name), "--no-animation"])
        assert result.exit_code == 0, result.output
        folder = tmp_path / name
        texts.append((folder / "two-trajectories.csv").read_text() + (folder / "two-contacts.csv").read_text())
    assert texts[0] == texts[1]


def test_cli_bad_scene_is_one_line_error_naming_body_and_field(tmp_path):
    doc = doc_with(["bodies", 1, "radius_m"], 0)
    path = tmp_path / "scene.yaml"
    path.write_text(yaml.safe_dump(doc))
    result = CliRunner().invoke(main, ["scene", str(path), "-o", str(tmp_path / "o")])
    assert result.exit_code == 1
    assert result.output.strip().splitlines() == [
        f"vrcal: error: {path}: bodies[1] (name 'b2').radius_m: must be > 0, got 0"]
    assert not (tmp_path / "o").exists()


def test_cli_default_output_directory_is_named_after_the_scene_file(tmp_path, monkeypatch):
    path = short_scene_file(tmp_path, duration=0.3)
    work = tmp_path / "work"
    work.mkdir()
    monkeypatch.chdir(work)
    result = CliRunner().invoke(main, ["scene", str(path), "--no-animation"])
    assert result.exit_code == 0, result.output
    assert (work / "two" / "two-trajectories.csv").exists()


def test_plot_heights_returns_the_axes_with_one_line_per_body():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from vrcal.scenes.multibody import simulate_scene
    from vrcal.scenes.output import plot_heights

    res = simulate_scene(load_scene(EXAMPLES / "figure9-five-balls.yaml"))
    ax = plot_heights(res)
    assert len(ax.get_lines()) == 5
    # the line holds every sample and touches the floor (0) at each of the body's floor contacts
    line = ax.get_lines()[0]
    t_line, z_line = line.get_xdata(), line.get_ydata()
    name = res.scene.names[0]
    t_floor = [c.t_s for c in res.contacts if c.body_a == name and c.body_b == "floor"]
    assert t_floor and t_line.size == res.t_s.size + len(t_floor)
    assert np.all(np.diff(t_line) >= 0)
    sampled = ~np.isin(t_line, t_floor)
    np.testing.assert_allclose(z_line[sampled], res.bottom_height_m()[:, 0])
    np.testing.assert_array_equal(z_line[np.isin(t_line, t_floor)], 0.0)
    plt.close(ax.figure)


def test_a_typo_of_name_is_named_as_a_typo_not_a_missing_name():
    # the probe's errs/missing_name.yaml: `nam: tennis` used to say "bodies[1].name: must be a non-empty text"
    doc = doc_with(["bodies", 1, "name"], None, delete=True)
    doc["bodies"][1]["nam"] = "b2"
    with pytest.raises(DataError) as err:
        validate_scene(doc, "s.yaml")
    assert "bodies[1]: unknown field(s) ['nam']; did you mean 'name'?" in str(err.value)


def test_a_balls_radius_override_rescales_its_virtual_body_into_the_ball():
    """`ball: basketball, radius_m: 0.05` printed x 60.84 mm (outside the 50 mm ball) and ran, while an
    explicit virtual_body with x > R is refused: now x = R/2 = 25 mm, the same contact time and epsilon."""
    doc = {"name": "r", "K_per_s": 4.0, "duration_s": 1.0, "floor": {"material": "steel"},
           "bodies": [{"name": "b", "ball": "basketball", "radius_m": 0.05, "position_m": [0, 0, 1]},
                      {"name": "c", "ball": "basketball", "position_m": [1, 0, 1]}]}
    scene = validate_scene(doc, "r.yaml")
    small, own = scene.bodies
    assert small.radius_m == 0.05 and small.x_m == pytest.approx(0.025) and small.x_m <= small.radius_m
    assert small.contact_time_s == pytest.approx(own.contact_time_s)
    eps = scene.epsilon_matrix()
    assert eps[0, -1] == pytest.approx(eps[1, -1])
    assert any("radius_m 0.05 m instead of the ball's" in n for n in scene.notes)
    # a radius written to four digits (0.1217 for 0.121674 m) is the ball's: rescaled, without a note
    doc["bodies"][0]["radius_m"] = 0.1217
    rounded = validate_scene(doc, "r.yaml")
    assert rounded.bodies[0].contact_time_s == pytest.approx(own.contact_time_s)
    assert not any("instead of the ball's" in n for n in rounded.notes)


def test_k_defaults_like_pair_center_is_centre_and_anchors_copy_a_body(tmp_path):
    """A scene without K_per_s failed 'K_per_s: missing' (pair defaults to 4); 'position_of: center' was
    refused; anchors and merge keys were refused ('aliases are not allowed')."""
    path = tmp_path / "row.yaml"
    path.write_text("duration_s: 0.5\nfloor: {material: steel}\nbodies:\n"
                    "  - &b {name: a, mass_kg: 0.2, radius_m: 0.1, virtual_body: {x_m: 0.01, v_m_per_s: 0.1},\n"
                    "        position_m: [0, 0, 0], position_of: bottom}\n"
                    "  - {<<: *b, name: c, position_m: [0.3, 0, 0.1], position_of: center}\n")
    scene = load_scene(path)
    assert scene.K_per_s == 4.0
    a, c = scene.bodies
    assert (c.mass_kg, c.radius_m, c.x_m, c.v_m_per_s) == (a.mass_kg, a.radius_m, a.x_m, a.v_m_per_s)
    assert a.position_m == (0.0, 0.0, 0.1) and c.position_m == (0.3, 0.0, 0.1)


@pytest.mark.parametrize("bearing_z, shown", [(0.1, "bearing  apexes [m]: 0.100, 0.0903, 0.0815, 0.0735, ..."),
                                               (0.01, "bearing  apexes [m]: 0.0100, 0.00903, 0.00815, 0.00735, ...")])
def test_the_summary_prints_apexes_with_digits_that_resolve_them(tmp_path, bearing_z, shown):
    """A clay ball (epsilon 0.1) from 1 m and a 5 mm bearing (0.95) from 10 cm or 1 cm: the summary printed
    the clay's apexes '1.000, 0.010, 0.000' (the third is 0.1 mm) and the 1 cm drop's '0.010, 0.009, 0.008'."""
    scene = {"name": "edge", "K_per_s": 4.0, "duration_s": 1.2, "sample_dt_s": 0.001, "friction_mu": 0.5,
             "floor": {"material": "steel"},
             "bodies": [{"name": "bearing", "mass_kg": 0.0005, "radius_m": 0.0025,
                         "virtual_body": {"x_m": 0.00125, "v_m_per_s": 0.04875},
                         "position_m": [0.0, 0.0, bearing_z], "position_of": "bottom"},
                        {"name": "clay", "mass_kg": 0.05, "radius_m": 0.02,
                         "virtual_body": {"x_m": 0.01, "v_m_per_s": 0.0086859},
                         "position_m": [0.5, 0.0, 1.0], "position_of": "bottom"}]}
    path = tmp_path / "edge.yaml"
    path.write_text(yaml.safe_dump(scene))
    result = CliRunner().invoke(main, ["scene", str(path), "--no-animation", "-o", str(tmp_path / "out")])
    assert result.exit_code == 0, result.output
    assert shown in result.output
    assert "clay     apexes [m]: 1.000, 0.0100, 0.000100" in result.output
