"""Shared helper of the engine tests: skip an engine that is not installed, unless CI requires it.

With ``VRCAL_REQUIRE_ENGINES=1`` (set in CI) a missing engine FAILS the test instead.
"""

import os

import pytest

from vrcal.errors import EngineUnavailable

EPSILONS = (0.5, 0.7, 0.85, 0.9, 0.95)


def require_engine(name):
    """Return the engine's version string; skip (or fail under VRCAL_REQUIRE_ENGINES=1) if absent."""
    from vrcal.engines import require_runtime

    try:
        return require_runtime(name)
    except EngineUnavailable as exc:
        if os.environ.get("VRCAL_REQUIRE_ENGINES") == "1":
            pytest.fail(f"VRCAL_REQUIRE_ENGINES=1 but {name} is unavailable: {exc}")
        pytest.skip(str(exc))
