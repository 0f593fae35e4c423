"""Physical plausibility of a ball and of a drop test: the one set of rules every entry point uses.

A ball reaches vrcal by ``--mass``/``--diameter`` (:mod:`vrcal.model.body`), by a drop test of one's
own (``vrcal fit --drop-height/--rebound-height``, :mod:`vrcal.inverse`) or by an entry of a standards
file (the shipped ``standards.yaml`` or ``--standards FILE``, :mod:`vrcal.model.standards`). The same
rules apply to all of them, and a value out of range is refused naming the likely unit slip
(:func:`vrcal.errors.unit_hint`: grams for kilograms, millimetres or centimetres for metres):

* the ball's mean density lies in :data:`BALL_DENSITY_KG_PER_M3` (:func:`check_ball_size`);
* a drop or rebound height is at most :data:`MAX_DROP_TEST_M` (:func:`check_drop_test_height`).
"""

from __future__ import annotations

import math

import numpy as np

from vrcal.errors import UsageError, unit_hint
from vrcal.textout import number

#: Mean densities a ball can have [kg/m^3]: above the air's (a lighter one floats away), below
#: osmium's (22,590, the densest element). A beach ball is about 3, a table-tennis ball 80, a
#: tennis ball 370, a golf ball 1,130, a steel ball 7,850.
BALL_DENSITY_KG_PER_M3 = (1.2, 23_000.0)

#: A ball's typical mean density [kg/m^3] (between a basketball's 80 and a golf ball's 1,130): of two
#: unit slips that both give a ball that can exist, the one nearer this is named.
TYPICAL_BALL_DENSITY_KG_PER_M3 = 400.0

#: Density of steel [kg/m^3]: a ball denser than any material is told what a solid steel ball of its
#: size weighs (a 5 mm bearing: 0.51 g), so a mass that is simply wrong shows as such.
STEEL_DENSITY_KG_PER_M3 = 7850.0

#: Highest drop or rebound of a drop test [m]: of one's own (``vrcal fit --drop-height``) or of a
#: standard (the associations drop from 0.3-2.6 m).
MAX_DROP_TEST_M = 20.0


def ball_density_kg_per_m3(mass_kg, diameter_m):
    """Mean density of a ball [kg/m^3].

    Parameters
    ----------
    mass_kg : float or ndarray
        mass of the ball [kg]
    diameter_m : float or ndarray
        diameter of the ball [m]
    """
    return np.asarray(mass_kg, dtype=float) / (np.pi / 6.0 * np.asarray(diameter_m, dtype=float) ** 3)


def check_ball_size(mass_kg, diameter_m, *, mass_label="--mass", size_label="--diameter", size_per_diameter=1.0,
                    where=None, error=UsageError):
    """Refuse a ball whose mean density no ball can have, naming the likely unit slip.

    Parameters
    ----------
    mass_kg : float
        mass [kg], > 0
    diameter_m : float
        diameter [m], > 0
    mass_label, size_label : str
        how the mass and the size were given (``--mass``, ``balls.tennis.diameter_m``)
    size_per_diameter : float
        the size as given per diameter: 1 for a diameter, pi for a circumference
    where : str or None
        a file the fields are in: the message then starts ``FILE: FIELD:`` with the suspect field
    error : type
        the exception raised (UsageError for options, DataError for a file)

    Raises
    ------
    error
        one line: the density, and the field and unit most likely slipped (``--diameter is in m:
        40 mm = 0.04``), else both fields' units
    """
    m, D = float(mass_kg), float(diameter_m)
    rho = float(ball_density_kg_per_m3(m, D))
    lo, hi = BALL_DENSITY_KG_PER_M3
    if lo <= rho <= hi:
        return
    short = (lambda label: label.rsplit(".", 1)[-1]) if where is not None else (lambda label: label)
    if rho > hi:   # the mass in grams?
        m_max = hi * math.pi / 6.0 * D**3
        slips = [(mass_label, unit_hint(m, m_max, short(mass_label), "kg", "g", 1000), m / 1000, D)]
    else:          # the size in centimetres or millimetres?
        size_max = (6.0 * m / (math.pi * lo)) ** (1.0 / 3.0) * size_per_diameter
        slips = [(size_label, unit_hint(D * size_per_diameter, size_max, short(size_label), "m", u, f), m, D / f)
                 for f, u in ((100, "cm"), (1000, "mm"))]
    fits = [(abs(math.log(float(ball_density_kg_per_m3(m2, D2)) / TYPICAL_BALL_DENSITY_KG_PER_M3)), label, hint)
            for label, hint, m2, D2 in slips if hint and lo <= ball_density_kg_per_m3(m2, D2) <= hi]
    what = "lighter than air" if rho < lo else "denser than any material"
    steel = STEEL_DENSITY_KG_PER_M3 * math.pi / 6.0 * D**3
    steel_text = f"{number(steel, 3)} kg" if steel >= 1 else f"{number(steel * 1000, 3)} g"
    scale = f"; solid steel that size weighs {steel_text}" if rho > hi else ""
    text = f"a ball of {m:g} kg and {D:g} m would be {what} ({rho:.3g} kg/m^3{scale})"
    if fits:
        _, label, hint = min(fits)
        text += hint
    else:   # both slipped (grams and centimetres or millimetres), or neither would do
        both = [(unit_hint(m, m / 1000, short(mass_label), "kg", "g", 1000)
                 + unit_hint(D * size_per_diameter, D * size_per_diameter / f, short(size_label), "m", u, f))
                for f, u in ((100, "cm"), (1000, "mm")) if lo <= ball_density_kg_per_m3(m / 1000, D / f) <= hi]
        label = None
        text += both[0] if both else (f": {short(mass_label)} is in kg and {short(size_label)} in m")
    if where is not None:
        text = f"{where}: {label + ': ' if label else ''}{text}"
    raise error(text)


def check_drop_test_height(height_m, label, *, where=None, field=None, error=UsageError):
    """Refuse a drop or rebound height above :data:`MAX_DROP_TEST_M`, naming the likely slip (cm for m).

    Parameters
    ----------
    height_m : float
        the height as given [m]
    label : str
        how it was given (``--drop-height``, ``balls.tennis.drop_height_m``)
    where : str or None
        the file it is in: the message then starts ``FILE: LABEL:``
    field : str or None
        the name the unit hint gives it (``rebound_m``; default ``label``)
    error : type
        the exception raised (UsageError for options, DataError for a file)
    """
    h = float(height_m)
    if h <= MAX_DROP_TEST_M:
        return
    hint = unit_hint(h, MAX_DROP_TEST_M, field or label, "m", "cm", 100)
    if where is not None:
        raise error(f"{where}: {label}: {h:g} m is higher than a drop test is made from (at most "
                    f"{MAX_DROP_TEST_M:g} m){hint}")
    raise error(f"{label} must be at most {MAX_DROP_TEST_M:g} m (higher than a drop test is made from), "
                f"got {h:g}{hint}")
