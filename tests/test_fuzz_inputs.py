"""Property tests over every input vrcal reads (issue 10): the YAML loaders (standards, scenes) and
the measurement readers, fed arbitrary text, arbitrary numbers and mutated valid files. Whatever
the input, the only exceptions are vrcal's own (:class:`vrcal.errors.VrcalError`), which the
command line turns into one line and an exit status.

Kept fast: 60 examples a property and no deadline (the suite must stay well under ten minutes);
``VRCAL_FUZZ_EXAMPLES=2000`` runs a longer search (about three minutes).
"""

import math
import os
import tempfile
from importlib import resources

import pytest
from helpers import EXAMPLES
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from vrcal.errors import VrcalError
from vrcal.fileio import parse_yaml
from vrcal.measurements import read_measurement
from vrcal.model.standards import validate_standards
from vrcal.scenes.spec import validate_scene

FAST = settings(max_examples=int(os.environ.get("VRCAL_FUZZ_EXAMPLES", "60")), deadline=None,
                suppress_health_check=[HealthCheck.too_slow])

STANDARDS_TEXT = resources.files("vrcal").joinpath("standards.yaml").read_text(encoding="utf-8")
SCENE_TEXTS = [p.read_text(encoding="utf-8") for p in sorted(EXAMPLES.glob("*.yaml"))]
DATA_TEXTS = [p.read_text(encoding="utf-8", errors="replace") for p in sorted((EXAMPLES / "data").glob("*"))
              if p.suffix in (".csv", ".txt")]


def _only_vrcal_errors(fn, *args, **kwargs):
    try:
        return fn(*args, **kwargs)
    except VrcalError:
        return None


# --------------------------------------------------------------------------- mutations of valid files


@st.composite
def mutated(draw, texts):
    """A valid file with a few edits: a span deleted, duplicated or replaced, a character swapped."""
    text = draw(st.sampled_from(texts))
    for _ in range(draw(st.integers(1, 4))):
        n = len(text)
        i = draw(st.integers(0, n))
        j = draw(st.integers(i, min(n, i + 80)))
        op = draw(st.sampled_from(["delete", "duplicate", "replace", "insert"]))
        if op == "delete":
            text = text[:i] + text[j:]
        elif op == "duplicate":
            text = text[:j] + text[i:j] + text[j:]
        else:
            new = draw(st.one_of(
                st.text(max_size=12),
                st.sampled_from(["nan", "-inf", "1e308", "-1", "0", "1e-320", ":", "- ", "&a", "*a", "[", "{",
                                 "\n", "\t", ",", ";", "\x00", "'", '"', "#", "!!binary", "999999999999999999999",
                                 "1" + "0" * 400]),
                st.floats(allow_nan=True, allow_infinity=True).map(repr)))
            text = text[:i] + new + (text[j:] if op == "replace" else text[i:])
    return text


# --------------------------------------------------------------------------- YAML loaders


def _load_standards(text):
    return validate_standards(parse_yaml(text, "fuzz.yaml"), "fuzz.yaml")


def _load_scene(text):
    return validate_scene(parse_yaml(text, "fuzz.yaml"), "fuzz.yaml")


@FAST
@given(st.text(max_size=400))
def test_standards_loader_on_arbitrary_text(text):
    _only_vrcal_errors(_load_standards, text)


@FAST
@given(mutated([STANDARDS_TEXT]))
def test_standards_loader_on_mutated_standards(text):
    _only_vrcal_errors(_load_standards, text)


@FAST
@given(st.text(max_size=400))
def test_scene_loader_on_arbitrary_text(text):
    _only_vrcal_errors(_load_scene, text)


@FAST
@given(mutated(SCENE_TEXTS))
def test_scene_loader_on_mutated_scenes(text):
    _only_vrcal_errors(_load_scene, text)


JSONISH = st.recursive(
    st.none() | st.booleans() | st.integers() | st.just(10**400) | st.floats(allow_nan=True, allow_infinity=True)
    | st.text(max_size=8),
    lambda children: st.lists(children, max_size=4) | st.dictionaries(st.text(max_size=8), children, max_size=4),
    max_leaves=20)
NUMBER = st.one_of(st.integers(-10**6, 10**6), st.integers(), st.sampled_from([10**400, -(10**309), 2**1024]),
                   st.floats(allow_nan=True, allow_infinity=True), st.text(max_size=4))


@FAST
@given(st.fixed_dictionaries({
    "K_per_s": NUMBER, "duration_s": NUMBER, "sample_dt_s": NUMBER, "gravity_m_per_s2": NUMBER,
    "floor": st.one_of(st.just({"material": "steel"}), st.fixed_dictionaries({"x_m": NUMBER, "v_m_per_s": NUMBER}),
                       JSONISH),
    "bodies": st.lists(st.fixed_dictionaries(
        {"name": st.text(max_size=10), "position_m": st.one_of(st.lists(NUMBER, max_size=4), JSONISH)},
        optional={"ball": st.sampled_from(["tennis", "basketball", "nonsense"]), "mass_kg": NUMBER,
                  "radius_m": NUMBER, "virtual_body": JSONISH, "velocity_m_per_s": st.lists(NUMBER, max_size=4),
                  "inertia": st.sampled_from(["hollow", "solid", "x"]), "position_of": st.text(max_size=7)}),
        max_size=3),
}))
def test_scene_validation_on_arbitrary_numbers(doc):
    scene = _only_vrcal_errors(validate_scene, doc, "fuzz.yaml")
    if scene is not None:
        assert math.isfinite(scene.K_per_s) and scene.K_per_s > 0 and scene.duration_s > 0
        assert all(b.radius_m > 0 and b.mass_kg > 0 for b in scene.bodies)


@FAST
@given(JSONISH)
def test_standards_validation_on_arbitrary_documents(doc):
    _only_vrcal_errors(validate_standards, {"schema_version": 1, "balls": {"ball": doc}}, "fuzz.yaml")
    _only_vrcal_errors(validate_standards, doc, "fuzz.yaml")


# --------------------------------------------------------------------------- measurement readers


def _read(content, fmt=None, **options):
    with tempfile.TemporaryDirectory() as d:
        p = os.path.join(d, "data.csv")
        with open(p, "wb" if isinstance(content, bytes) else "w", **({} if isinstance(content, bytes) else
                                                                    {"encoding": "utf-8", "newline": ""})) as fh:
            fh.write(content)
        return _only_vrcal_errors(read_measurement, p, fmt, **options)


FORMATS = [None, "trajectory", "impacts", "apexes", "tracker", "pixels-ref"]


@FAST
@given(st.one_of(st.text(max_size=300), st.binary(max_size=300)), st.sampled_from(FORMATS))
def test_readers_on_arbitrary_text(content, fmt):
    _read(content, fmt, fs_hz=60.0)


@FAST
@given(st.sampled_from(["t,y", "t", "bounce,h", "t;y (mm)", "time (s)\ty (cm)", "t,y (px)"]),
       st.lists(st.lists(st.one_of(st.floats(allow_nan=True, allow_infinity=True), st.integers(-10**20, 10**20)),
                         min_size=1, max_size=3), max_size=30),
       st.sampled_from(FORMATS))
def test_readers_on_arbitrary_numbers(header, rows, fmt):
    sep = "\t" if "\t" in header else (";" if ";" in header else ",")
    text = header + "\n" + "".join(sep.join(repr(v) for v in row) + "\n" for row in rows)
    data = _read(text, fmt, fs_hz=60.0, scale_m_per_px=0.001)
    if data is not None:
        for name in ("t_s", "y_m", "h_m"):
            values = getattr(data, name, None)
            if values is not None:
                assert all(math.isfinite(v) for v in values), name


@FAST
@given(mutated(DATA_TEXTS), st.sampled_from(FORMATS))
def test_readers_on_mutated_valid_files(text, fmt):
    _read(text, fmt, fs_hz=60.0)


@pytest.mark.parametrize("path", sorted((EXAMPLES / "data").glob("*.[ct][sx][vt]")), ids=lambda p: p.name)
def test_the_valid_files_the_mutations_start_from_are_read(path):
    assert read_measurement(path, fs_hz=60.0) is not None
