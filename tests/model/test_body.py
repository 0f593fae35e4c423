"""The one body description: a standard ball, a user's own ball, or a discover result's."""

import json

import pytest

from vrcal.errors import DataError, UsageError
from vrcal.model.body import describe_body, read_discover_json


def test_a_standard_ball():
    body = describe_body("Basketball")
    assert body.name == "basketball" and body.standard is not None and body.source == "standard"
    assert body.radius_m == pytest.approx(body.diameter_m / 2)


def test_a_standard_ball_with_its_own_mass():
    body = describe_body("tennis", mass_kg=0.06)
    assert body.mass_kg == 0.06 and body.standard.key == "tennis" and body.source == "options"


def test_a_users_own_ball():
    body = describe_body(mass_kg=0.0459, diameter_m=0.0427)
    assert (body.name, body.mass_kg, body.diameter_m, body.standard) == ("ball", 0.0459, 0.0427, None)
    assert describe_body("golf", mass_kg=0.0459, diameter_m=0.0427).name == "golf"


@pytest.mark.parametrize("kwargs, message", [
    ({}, "no body"),
    ({"mass_kg": 0.05}, "--mass without --diameter"),
    ({"mass_kg": 0.0, "diameter_m": 0.04}, "--mass must be a number > 0"),
    ({"mass_kg": 0.05, "diameter_m": float("nan")}, "--diameter must be a number > 0"),
])
def test_bad_bodies_are_usage_errors(kwargs, message):
    with pytest.raises(UsageError, match=message):
        describe_body(**kwargs)


def _write(tmp_path, doc):
    path = tmp_path / "d.json"
    path.write_text(json.dumps(doc))
    return path


GOOD = {"ball": {"name": "table_tennis", "mass_kg": 0.0027, "diameter_m": 0.04}, "g_m_per_s2": 9.80665,
        "effects": ["air_drag"], "parameters": {"air_drag": {"drag_coefficient": 0.38}}, "epsilon": 0.86,
        "model": {"drop_height_m": 2.65, "release_time_s": 0.28, "epsilon": 0.86}}


def test_a_discover_result(tmp_path):
    body = describe_body(from_json=_write(tmp_path, GOOD))
    assert (body.name, body.mass_kg, body.diameter_m) == ("table_tennis", 0.0027, 0.04)
    assert body.standard.key == "table_tennis" and body.discovered["epsilon"] == 0.86
    assert describe_body(from_json=_write(tmp_path, dict(GOOD, schema_version=1))).mass_kg == 0.0027
    with pytest.raises(UsageError, match="differs from the ball"):
        describe_body("tennis", from_json=_write(tmp_path, GOOD))


@pytest.mark.parametrize("change, message", [
    ({"schema_version": 3}, "schema_version"),   # 2 is read since discover wrote it
    ({"ball": {"name": "x", "mass_kg": -1, "diameter_m": 0.04}}, "ball.mass_kg"),
    ({"ball": "table_tennis"}, "ball must be an object"),
    ({"epsilon": "high"}, "epsilon must be a finite number"),
    ({"epsilon": 1.5}, "out of range"),
    ({"model": {"drop_height_m": 1.0, "release_time_s": "soon"}}, "model.release_time_s"),
    ({"effects": "air_drag"}, "effects must be a list"),
    ({"parameters": {"air_drag": {"drag_coefficient": None}}}, "parameters.air_drag.drag_coefficient"),
    ({"prior_split": {"epsilon": 2.0, "effects": [], "parameters": {}}}, "prior_split.epsilon"),
    ({"prior_split": {"epsilon": 0.9, "effects": "air_drag", "parameters": {}}}, "prior_split.effects must"),
    ({"prior_split": {"epsilon": 0.9, "effects": [], "parameters": {"air_drag": {"drag_coefficient": "x"}}}},
     "prior_split.parameters.air_drag.drag_coefficient"),
])
def test_a_discover_result_with_a_bad_key_is_one_data_error(tmp_path, change, message):
    with pytest.raises(DataError, match=message):
        read_discover_json(_write(tmp_path, dict(GOOD, **change)))


def test_a_result_whose_rivals_are_ambiguous_gives_the_most_probable_sharing_its_report_advises(tmp_path):
    """The report's advice leads with the prior split ("Use this"): an engine takes it, not the named effect
    alone (ten 60 fps impact-time records: 0.973 with C_d 0.74 was exported where the report said 0.957
    with C_d 0.59 and a speed law)."""
    split = {"effects": ["air_drag", "velocity_dependent_restitution"], "epsilon": 0.957,
             "parameters": {"air_drag": {"drag_coefficient": 0.59},
                            "velocity_dependent_restitution": {"exponent": 0.23}}}
    body = describe_body(from_json=_write(tmp_path, dict(GOOD, prior_split=split)))
    assert body.epsilon() == 0.957 and body.effects == split["parameters"]
    assert body.discovered["named"] == {"epsilon": 0.86, "effects": ["air_drag"],
                                        "parameters": {"air_drag": {"drag_coefficient": 0.38}}}
    assert "most probable" in body.epsilon_source()
    plain = describe_body(from_json=_write(tmp_path, dict(GOOD, prior_split=None)))
    assert plain.epsilon() == 0.86 and "named" not in plain.discovered and "most probable" not in plain.epsilon_source()


def test_not_a_discover_result(tmp_path):
    path = tmp_path / "x.json"
    for content, message in ((b"[1]", "top level is a list"), (b"\x00\x01\xff", "binary"), (b"{", "line 1"),
                             (b'{"a": 1}', "missing")):
        path.write_bytes(content)
        with pytest.raises(DataError, match=message):
            read_discover_json(path)
    with pytest.raises(DataError, match="not a file"):
        read_discover_json(tmp_path)


def test_what_a_body_supplies_a_command(tmp_path):
    """epsilon, drop height, effects and g: a discover result's, else a standard's, else none."""
    from vrcal.model.restitution import STANDARD_GRAVITY_M_PER_S2
    from vrcal.model.standards import ball_epsilon

    std = describe_body("tennis")
    window = ball_epsilon(std.standard)
    assert (std.epsilon(), std.drop_height_m) == (window.nominal, window.drop_height_m)
    assert std.epsilon(as_paper=True) == ball_epsilon(std.standard, as_paper=True).nominal
    assert std.effects == {} and std.reference_speed_m_per_s is None
    assert std.gravity_m_per_s2() == STANDARD_GRAVITY_M_PER_S2 and std.gravity_m_per_s2(1.62) == 1.62
    own = describe_body(mass_kg=0.0459, diameter_m=0.0427)
    assert (own.epsilon(), own.drop_height_m, own.epsilon_source()) == (None, None, None)
    found = describe_body(from_json=_write(tmp_path, dict(GOOD, g_m_per_s2=9.81, epsilon_reference_speed_m_per_s=7.0)))
    assert (found.epsilon(), found.drop_height_m, found.gravity_m_per_s2()) == (0.86, 2.65, 9.81)
    assert found.effects == {"air_drag": {"drag_coefficient": 0.38}} and found.reference_speed_m_per_s == 7.0
    assert "discover result" in found.epsilon_source()
    with pytest.raises(UsageError, match=r"--g must be a number > 0 \[m/s\^2\]"):
        found.gravity_m_per_s2(-1.0)


def test_messages_use_the_commands_spelling():
    with pytest.raises(UsageError) as exc:
        describe_body(ball_label="--ball", from_label=None)
    assert str(exc.value) == "no body: give --ball (a ball of the standards), or --mass and --diameter"
    with pytest.raises(UsageError, match=r"^--diameter without --mass: a ball of your own needs both; or give "
                                         r"--ball, a ball of the standards$"):
        describe_body(diameter_m=0.04, ball_label="--ball", from_label=None)


def test_a_bad_reference_speed_in_a_discover_result(tmp_path):
    with pytest.raises(DataError, match="epsilon_reference_speed_m_per_s"):
        read_discover_json(_write(tmp_path, dict(GOOD, epsilon_reference_speed_m_per_s=-2.0)))
