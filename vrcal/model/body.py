"""One description of a body for every command: a ball of the standards, or any mass and diameter.

:class:`BallProperties` is what the simulator and the fitter need of a ball (mass [kg] and
diameter [m], floats or arrays over drops); :func:`ball_from_options` builds it from what a
user types (``BALL``, ``--mass``, ``--diameter``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from vrcal.errors import UsageError
from vrcal.model.standards import get_ball, load_standards


@dataclass(frozen=True)
class BallProperties:
    """Mass and diameter of the simulated ball (floats, or arrays broadcast over the drops).

    Parameters
    ----------
    mass_kg : float or ndarray
        ball mass [kg], > 0
    diameter_m : float or ndarray
        ball diameter [m], > 0
    name : str
        label used in reports
    """

    mass_kg: float
    diameter_m: float
    name: str = "ball"

    @classmethod
    def from_ball(cls, ball):
        """Nominal mass and diameter of a :class:`vrcal.model.standards.Ball`."""
        return cls(float(ball.mass_kg.nominal), float(ball.diameter_m.nominal), ball.key)


def ball_properties(ball):
    """A :class:`BallProperties` from itself or a :class:`vrcal.model.standards.Ball`."""
    if isinstance(ball, BallProperties):
        return ball
    if hasattr(ball, "mass_kg") and hasattr(getattr(ball, "mass_kg"), "nominal"):
        return BallProperties.from_ball(ball)
    raise UsageError(f"ball must be a BallProperties or a standards Ball, got {type(ball).__name__}")


def ball_from_options(name, standards=None, mass_kg=None, diameter_m=None):
    """The simulated ball from a command line: a standard's ball, or a free name with mass and diameter.

    Parameters
    ----------
    name : str
        a ball of the standards, or any name when both ``mass_kg`` and ``diameter_m`` are given
    standards : dict or None
        :func:`vrcal.model.standards.load_standards` output (the shipped file when None)
    mass_kg, diameter_m : float or None
        override the standard's nominal values [kg], [m]

    Returns
    -------
    (BallProperties, Ball or None)
        the standard's Ball when ``name`` is one, else None
    """
    standards = load_standards() if standards is None else standards
    for label, value in (("--mass", mass_kg), ("--diameter", diameter_m)):
        if value is not None and not (math.isfinite(value) and value > 0):
            raise UsageError(f"{label} must be a number > 0, got {value:g}")
    norm = str(name).strip().lower().replace("-", "_").replace(" ", "_")
    if norm in standards:
        std = standards[norm]
        props = BallProperties.from_ball(std)
        return BallProperties(props.mass_kg if mass_kg is None else float(mass_kg),
                              props.diameter_m if diameter_m is None else float(diameter_m), std.key), std
    if mass_kg is None or diameter_m is None:
        try:
            get_ball(name, standards)
        except UsageError as exc:
            raise UsageError(f"{exc}; for another ball give --mass and --diameter") from None
    return BallProperties(float(mass_kg), float(diameter_m), str(name)), None
