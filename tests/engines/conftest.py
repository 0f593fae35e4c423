"""Fixtures of the engine tests: a discover result written as ``vrcal discover --json`` writes it."""

import json

import pytest


def discover_document(effects=None, epsilon=0.86, drop_height_m=1.5, mass_kg=0.0027, diameter_m=0.04,
                      name="table_tennis", **extra):
    """A discover result with planted effects (``{effect: {param: value}}``), the keys discover writes."""
    effects = effects or {}
    doc = {
        "ball": {"name": name, "mass_kg": mass_kg, "diameter_m": diameter_m},
        "g_m_per_s2": 9.80665,
        "effects": list(effects),
        "parameters": effects,
        "epsilon": epsilon,
        "epsilon_baseline": epsilon - 0.1,
        "model": {"drop_height_m": drop_height_m, "release_time_s": 0.25, "epsilon": epsilon},
        "baseline": {"drop_height_m": drop_height_m, "release_time_s": 0.25, "epsilon": epsilon - 0.1},
        "data": {"kind": "trajectory", "source": "planted", "n": 300},
        "noise_floor": 0.0005,
        "notes": [],
    }
    doc.update(extra)
    return doc


@pytest.fixture
def write_discover(tmp_path):
    """``write_discover(**kwargs)`` -> path of a discover JSON (see :func:`discover_document`)."""
    counter = [0]

    def write(**kwargs):
        counter[0] += 1
        path = tmp_path / f"discover{counter[0]}.json"
        path.write_text(json.dumps(discover_document(**kwargs)))
        return str(path)

    return write
