"""What several test modules share: where the repository and the shared data are, and the
engine guard.

Real records live in ``../shared/data`` beside the checkout (CI has it there); they are never
copied into the project. A test that needs one calls :func:`shared_file`, which skips when the
folder is absent -- unless ``VRCAL_REQUIRE_SHARED=1`` (set by CI), which makes it fail.
With ``VRCAL_REQUIRE_ENGINES=1`` (set in CI) a missing engine FAILS its test instead of skipping.
"""

import os
from pathlib import Path

import numpy as np
import pytest

from vrcal.model.restitution import STANDARD_GRAVITY_M_PER_S2 as G
from vrcal.model.restitution import impact_speed_m_per_s

ROOT = Path(__file__).resolve().parents[1]
EXAMPLES = ROOT / "examples"
SHARED_DATA = ROOT.parent / "shared" / "data"

EPSILONS = (0.5, 0.7, 0.85, 0.9, 0.95)


def shared_file(relative):
    """Path of ``../shared/data/RELATIVE``; skips the test when it is absent (fails in CI)."""
    path = SHARED_DATA / relative
    if not path.exists():
        if os.environ.get("VRCAL_REQUIRE_SHARED") == "1":
            pytest.fail(f"VRCAL_REQUIRE_SHARED=1 but {path} is absent")
        pytest.skip(f"{path} is absent (the shared data folder lies beside the checkout)")
    return path


def require_engine(name):
    """Return the engine's version string; skip (or fail under VRCAL_REQUIRE_ENGINES=1) if absent."""
    from vrcal.engines import require_runtime
    from vrcal.errors import EngineUnavailable

    try:
        return require_runtime(name)
    except EngineUnavailable as exc:
        if os.environ.get("VRCAL_REQUIRE_ENGINES") == "1":
            pytest.fail(f"VRCAL_REQUIRE_ENGINES=1 but {name} is unavailable: {exc}")
        pytest.skip(str(exc))


def require_extra(module, extra):
    """Import an optional extra's module (``cv2`` of ``video``, ``av`` of ``audio``); skip when it is
    not installed -- or fail under ``VRCAL_REQUIRE_EXTRAS=1`` or ``VRCAL_REQUIRE_ENGINES=1`` (CI installs
    every extra, so the tests that need one run there)."""
    import importlib

    try:
        return importlib.import_module(module)
    except ImportError:
        if "1" in (os.environ.get("VRCAL_REQUIRE_EXTRAS"), os.environ.get("VRCAL_REQUIRE_ENGINES")):
            pytest.fail(f"the '{extra}' extra is required here but {module} is not installed")
        pytest.skip(f"{module} is not installed (pip install '.[{extra}]')")


# --------------------------------------------------------------------------- physics that builds test files


def impact_times(H=1.0, eps=0.85, n=12, release=0.0):
    """Drag-free impact times of a drop from rest from H with constant restitution eps."""
    v0 = impact_speed_m_per_s(H)
    flights = 2.0 * eps ** np.arange(1, n) * v0 / G
    return release + np.sqrt(2.0 * H / G) + np.concatenate([[0.0], np.cumsum(flights)])


def bottom_height(t, H=1.0, eps=0.85, n=8, release=0.0):
    """Drag-free height of the ball's bottom, held at H until ``release``, at rest on the floor after the n-th
    impact."""
    v0 = impact_speed_m_per_s(H)
    hits = impact_times(H, eps, n, release)
    y = np.full(t.shape, H)
    fall = (t >= release) & (t < hits[0])
    y[fall] = H - 0.5 * G * (t[fall] - release) ** 2
    for i in range(n - 1):
        inside = (t >= hits[i]) & (t < hits[i + 1])
        tau = t[inside] - hits[i]
        y[inside] = eps ** (i + 1) * v0 * tau - 0.5 * G * tau ** 2
    y[t >= hits[-1]] = 0.0      # at rest after the last bounce
    return y
