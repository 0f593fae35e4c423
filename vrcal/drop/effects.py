"""The registry of candidate effects that a drop test can hide, shared by simulator and fitter.

Each :class:`Effect` names its parameters (with unit, default, hard bounds, physically
plausible prior), a readable equation, a reference, the data kinds in which it can be
seen, and the parameter values at which it vanishes (``null_values``: the baseline of
the virtual-body model, Eq. (7)/(10) of [1], where every contact has one constant
epsilon and the flights are free falls).

One pure, vectorised equation function per effect lives here too; the event-driven
simulator :mod:`vrcal.drop.simulate` calls them.

References
----------
[1] "The Graphical Method for Decision of Restitution Coefficient and Its Applications".
[2] R. Ramirez, T. Poeschel, N. V. Brilliantov, T. Schwager, "Coefficient of restitution
    of colliding viscoelastic spheres", Phys. Rev. E 60, 4465 (1999); G. Kuwabara,
    K. Kono, Jpn. J. Appl. Phys. 26, 1230 (1987).
[3] R. Cross, "The bounce of a ball", Am. J. Phys. 67, 222 (1999).
[4] R. D. Mehta, "Aerodynamics of sports balls", Annu. Rev. Fluid Mech. 17, 151 (1985);
    R. Cross, C. Lindsey, "Measuring the drag force on a falling ball", Phys. Teach. 52,
    169 (2014).
[5] L. D. Landau, E. M. Lifshitz, Fluid Mechanics, 2nd ed., Sec. 11 (added mass of a
    sphere, half the displaced mass).
[6] E. Achenbach, "Experiments on the flow past spheres at very high Reynolds numbers",
    J. Fluid Mech. 54, 565 (1972) (C_d = 0.4-0.5 below the drag crisis).
[7] K. H. Hunt, F. R. E. Crossley, "Coefficient of restitution interpreted as damping in
    vibroimpact", J. Appl. Mech. 42, 440 (1975) (a Hertz contact whose damping force is
    proportional to the indentation to the same power: 1 - eps = (2/3) alpha v to first order).
[8] C.-K. Liang, L.-W. Chang, H. H. Chen, "Analysis and compensation of rolling shutter effect",
    IEEE Trans. Image Process. 17(8), 1323-1330 (2008) (a CMOS camera exposes its rows one after
    another: each row is sampled at its own time).

Prior densities
---------------
Every parameter has ``bounds`` (what the fitter may try: wide, so that a value an effect
would need is seen even where it is unphysical), hard physical ``limits`` (no effect is named
with a value beyond them: a candidate whose best fit lies beyond is held at the limit when the data
cannot reject it, :func:`vrcal.discovery.ranking.fit_physical`, else ``vrcal discover`` reports the
value it would need; they may depend on the ball, :meth:`Parameter.physical_limits`),
a plausible range ``prior`` and a proper prior *density* (``Parameter.density``; uniform
over ``prior`` when None) that ``vrcal discover`` uses to rank the candidates by their
evidence (:func:`vrcal.discovery.residuals.minus_two_ln_evidence`). The densities come from
physics and the literature, not from the synthetic generator:

* ``air_drag.drag_coefficient``: log-normal, median 0.47 (a sphere below the drag
  crisis, 1e3 < Re < 2e5 [4, 6]; the drops here reach Re ~ 1e4-1e5), sigma_ln 0.3
  (95 %: 0.26-0.85, covering balls lowered towards the crisis by their seams and
  fuzzy tennis balls at 0.55-0.6 [4]);
* ``velocity_dependent_restitution.exponent``: log-normal, median 1/5 (viscoelastic
  spheres [2]), sigma_ln ln 2 (95 %: 0.05-0.8: inflated balls are nearly speed
  independent, plastic impacts steeper);
* ``contact_duration.contact_time_s``: log-normal around the half period of an
  inflated ball, pi sqrt(m / (pi D p)) with a gauge pressure p = 60 kPa
  (:func:`inflated_contact_time_s`: the floor pushes with the gauge pressure on the
  flattened area pi D x), sigma_ln 1 (95 %: 0.14-7 times it: pressures from 30 to
  110 kPa, wall stiffness, solid balls);
* ``height_offset.offset_m``: the tracked point is the bottom (ITTF), the centre
  (video trackers) or the top (FIBA) of the ball: an equal mixture of normals at 0
  (sd 10 mm, a mis-set floor line), D/2 and D (sd max(0.1 D, 5 mm));
* ``buoyancy.air_density_kg_per_m3``: uniform over its plausible range;
* ``rolling_shutter.readout_s_per_m``: normal, mean 0, sd 0.02 s/m (:class:`NormalPrior`). A phone's
  CMOS sensor reads its frame in R = 5-35 ms [8] and a drop test's frame spans 1-2 m of height, so
  kappa = R / H_frame is 0.003-0.035 s/m for a phone held upright (minus that upside down; 0 for a
  global shutter or rows read across the fall): 95 % of the density lies within +-0.04 s/m (a 30 ms
  readout over a 0.75 m frame), centred on 0 because the sign is the phone's orientation and a
  global-shutter camera has none.

Physical limits (hard; ``Parameter.limits``)
--------------------------------------------
* ``air_drag.drag_coefficient``: 0.2-1.0, a sphere over the Reynolds numbers of a drop
  (1e3-3e5: 0.4-0.5 below the drag crisis, down to 0.2 past it, up to about 0.6 for fuzzy
  or seamed balls [4, 6]; 1.0 leaves room for rough balls);
* ``velocity_dependent_restitution.exponent``: 0-1. p is the exponent of 1 - eps against the
  impact speed. A linear spring-dashpot has a constant eps (p = 0); a viscoelastic Hertz contact
  (Kuwabara-Kono, Ramirez et al. [2]) 1 - eps ~ v^(1/5); Hunt-Crossley's Hertz contact [7], whose
  damping grows with the indentation as the elastic force does, 1 - eps ~ v (p = 1). Both are
  first orders in the dissipation: solved through the contact, the local exponent d ln(1 - eps) /
  d ln v of Hunt-Crossley is 0.99 at eps = 0.99, 0.94 at 0.94, 0.89 at 0.88 and 0.80 at 0.79,
  of Kuwabara-Kono 0.199 to 0.17 over the same range (never above its first order); so no
  contact model of a ball gives p > 1, and a fit beyond it (a drop table of a Hunt-Crossley
  basketball with its drag left out: p 1.02) is held at 1 when the data cannot reject that
  (:func:`vrcal.discovery.ranking.fit_physical`);
* ``contact_duration.contact_time_s``: 0 to twice the membrane estimate
  :func:`inflated_contact_time_s` of the ball (its size and a 60 kPa gauge pressure): a
  factor 2 covers 15-240 kPa and the wall's stiffness; a shorter contact (a solid ball)
  is always physical. These assume a rigid floor; on a soft one (``surface="soft"``: a stack of
  paper, a foam or gym mat, carpet, turf, sand) the floor sets the contact: up to
  :data:`SOFT_FLOOR_CONTACT_TIME_S` (50 ms), :func:`contact_time_limit_s`;
* ``height_offset.offset_m``: -D to D + max(0.1 D, 5 mm): the tracked point lies on the ball
  (bottom 0, centre D/2, top D), give or take a mis-set floor line;
* ``buoyancy.air_density_kg_per_m3``: 0.8-1.4 kg/m^3 (air from 3000 m altitude to a cold day);
* ``rolling_shutter.readout_s_per_m``: -0.1 to 0.1 s/m: a 40 ms readout (the slowest phone sensors [8])
  over a 0.4 m frame (the smallest that holds a drop worth fitting), either way up. They are the
  fitter's bounds too: beyond them the rows would be read slower than a fast ball moves (kappa v near 1)
  and a sample would show the ball twice. A record narrows them (``Parameter.record_limits``,
  :func:`record_readout_limit_s_per_m`): a camera reads a frame within one frame interval dt, over a frame
  at least as high as the heights the ball was seen at, so |kappa| <= dt / span (a 100 fps video of a
  2.65 m drop: 0.0038 s/m).

The model of a ball exists over a range of its own (``Parameter.defined``), which caps both the
fitter's bounds and the limits for that ball: ``buoyancy.air_density_kg_per_m3`` below the ball's own
mean density m / V, where it would float (a 0.1 kg, 0.5 m beach ball: 1.53 kg/m^3, inside the fitter's
bounds 0-2): a trial value beyond is never simulated (:func:`buoyancy_defined_range`).

Departures from [1]
-------------------
[1] treats every contact as instantaneous with one epsilon and the flights as drag-free;
each effect here is a named, documented departure that the data can support or reject.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from vrcal.errors import UsageError, closest_name
from vrcal.model.plausible import ball_density_kg_per_m3
from vrcal.model.restitution import (  # noqa: F401 (the air's equations, here with the effects)
    AIR_DENSITY_KG_PER_M3,
    SPHERE_DRAG_COEFFICIENT,
    _added_mass_kg,
    _out,
    added_mass_kg,
    check_array,
    drag_constant_per_m,
    epsilon_from_heights_with_drag,
    sphere_volume_m3,
)

#: Data kinds the simulator can produce and the readers can read.
KINDS = ("trajectory", "impacts", "apexes")


@dataclass(frozen=True)
class LogNormalPrior:
    """Log-normal prior density: ln(x / median) ~ N(0, sigma_ln^2), x > 0.

    ``median`` is a number, or a function of the ball (mass [kg], diameter [m]) giving
    one; ``basis`` says where the numbers come from.
    """

    median: object
    sigma_ln: float
    basis: str = ""

    def center(self, ball=None):
        """The median [parameter unit] (for this ball, and the floor it bounces on, when it depends on
        them: ``median(mass [kg], diameter [m], surface)``)."""
        if callable(self.median):
            if ball is None:
                raise UsageError("this prior depends on the ball: give its mass and diameter")
            return float(self.median(float(np.mean(ball.mass_kg)), float(np.mean(ball.diameter_m)),
                                     surface_of(ball)))
        return float(self.median)

    def pdf(self, x, ball=None):
        """Density at ``x`` [1/parameter unit] (0 for x <= 0)."""
        x = np.asarray(x, dtype=float)
        med, s = self.center(ball), float(self.sigma_ln)
        pos = x > 0
        xs = np.where(pos, x, 1.0)
        z = np.log(xs / med) / s
        return np.where(pos, np.exp(-0.5 * z * z - np.log(xs) - math.log(s * math.sqrt(2.0 * math.pi))), 0.0)

    def deviate(self, x, ball=None):
        """The standard normal deviate ``ln(x / median) / sigma_ln`` of ``x`` (> 0) [1]: the prior is
        normal in ln x, so that a posterior mode adds it to the residuals."""
        return np.log(np.asarray(x, dtype=float) / self.center(ball)) / float(self.sigma_ln)

    def describe(self, ball=None, unit=""):
        unit = "" if unit in ("", "1") else f" {unit}"
        try:
            med = f"{self.center(ball):.3g}{unit}"
        except UsageError:
            med = "ball-dependent"
        return f"log-normal, median {med}, sigma_ln {self.sigma_ln:.2g}"


@dataclass(frozen=True)
class TrackedPointPrior:
    """Prior density of ``height_offset``: the tracked point is the ball's bottom (up to a
    mis-set floor line), its centre or its top -- an equal mixture of three normals at 0
    (sd ``floor_sd_m``), D/2 and D (sd max(``point_sd_fraction`` D, ``min_sd_m``))."""

    floor_sd_m: float = 0.01
    point_sd_fraction: float = 0.1
    min_sd_m: float = 0.005
    basis: str = ""

    def pdf(self, x, ball=None):
        if ball is None:
            raise UsageError("the height_offset prior depends on the ball: give its diameter")
        x = np.asarray(x, dtype=float)
        D = float(np.mean(ball.diameter_m))
        sd = max(self.point_sd_fraction * D, self.min_sd_m)

        def normal(mu, s):
            z = (x - mu) / s
            return np.exp(-0.5 * z * z) / (s * math.sqrt(2.0 * math.pi))

        return (normal(0.0, self.floor_sd_m) + normal(0.5 * D, sd) + normal(D, sd)) / 3.0

    def deviate(self, x, ball=None):
        """``sqrt(2 ln(pdf_max / pdf(x)))`` [1]: 0 at the density's highest mode, growing as a normal
        deviate away from every mode; its square is what -2 ln of the density adds."""
        D = float(np.mean(ball.diameter_m)) if ball is not None else 0.0
        peak = float(np.max(self.pdf(np.linspace(-0.5 * D, 1.5 * D, 2001), ball)))
        pdf = np.maximum(self.pdf(x, ball), 1e-300)
        return np.sqrt(np.maximum(2.0 * np.log(peak / pdf), 0.0))

    def describe(self, ball=None, unit=""):
        return "bottom, centre or top of the ball (mixture of normals at 0, D/2, D)"


@dataclass(frozen=True)
class NormalPrior:
    """Normal prior density: x ~ N(mean, sd^2), for a parameter of either sign (``rolling_shutter``: the
    phone upright or upside down, 0 for a global shutter); ``basis`` says where the numbers come from.

    ``mean`` and ``sd`` are in the parameter's unit (sd > 0).
    """

    mean: float
    sd: float
    basis: str = ""

    def pdf(self, x, ball=None):
        """Density at ``x`` [1/parameter unit]."""
        z = (np.asarray(x, dtype=float) - float(self.mean)) / float(self.sd)
        return np.exp(-0.5 * z * z) / (float(self.sd) * math.sqrt(2.0 * math.pi))

    def deviate(self, x, ball=None):
        """The standard normal deviate ``(x - mean) / sd`` [1]: a posterior mode adds it to the residuals."""
        return (np.asarray(x, dtype=float) - float(self.mean)) / float(self.sd)

    def describe(self, ball=None, unit=""):
        unit = "" if unit in ("", "1") else f" {unit}"
        return f"normal, mean {self.mean:.3g}{unit}, sd {self.sd:.3g}{unit}"


@dataclass(frozen=True)
class Parameter:
    """One parameter of an effect.

    ``bounds``: what the fitter may try; ``limits``: hard physical limits (a tuple, or a
    function of (mass [kg], diameter [m]) giving one; see :meth:`physical_limits`): a
    candidate outside them is never named; ``prior``: the plausible range (the uniform
    density's support); ``density``: a proper prior density (an object with
    ``pdf(x, ball)``; uniform over ``prior`` when None) for the evidence that ranks the
    candidates (see the module docstring, "Prior densities"); ``defined``: None, or a function of
    (mass [kg], diameter [m]) giving the range ``(lo, hi)`` over which the model of this ball exists
    (buoyancy: below the air density at which the ball would float), which caps ``bounds`` and
    ``limits`` for that ball (:meth:`fit_bounds`, :meth:`physical_limits`); ``typical``: the prior density
    says what such balls measure (a sphere's C_d below the drag crisis), so that a value outside its 95 %
    range (:meth:`typical_range`), inside the hard limits, is physical but unusual, and said to be (False
    where the prior is one model's: a speed exponent near 0, an inflated ball's, is common);
    ``record_limits``: None, or a function of the ball (a :class:`vrcal.model.body.BallProperties`, with what it
    carries of the record: its camera's ``readout_limit_s_per_m``) giving the hard limits for that record, inside
    ``limits`` (a rolling shutter reads a frame within one frame interval, :func:`record_readout_limit_s_per_m`).
    """

    name: str
    unit: str
    default: float
    bounds: tuple
    prior: tuple
    description: str
    density: object = None
    limits: object = None
    defined: object = None
    typical: bool = False
    record_limits: object = None

    def physical_limits(self, ball=None):
        """Hard physical limits ``(lo, hi)`` [unit] of the parameter (for this ball where they
        depend on it: ``limits`` is then a function of (mass [kg], diameter [m], surface: the floor,
        :func:`surface_of`)); ``bounds`` when none are set; inside the range where the model of this
        ball exists (``defined``) when a ball is given."""
        lim = self.limits if self.limits is not None else self.bounds
        if callable(lim):
            if ball is None:
                raise UsageError(f"the limits of {self.name} depend on the ball: give its mass and diameter")
            lim = lim(float(np.mean(ball.mass_kg)), float(np.mean(ball.diameter_m)), surface_of(ball))
        if self.record_limits is not None and ball is not None:
            a, b = self.record_limits(ball)
            lim = (max(float(lim[0]), a), min(float(lim[1]), b))
        return self._within_defined(lim, ball)

    def fit_bounds(self, ball=None):
        """What the fitter may try ``(lo, hi)`` [unit]: ``bounds``, for a given ball inside the range where
        its model exists (``defined``: a trial value beyond would fail the simulation, not the fit)."""
        return self._within_defined(self.bounds, ball)

    def _within_defined(self, lim, ball):
        lo, hi = float(lim[0]), float(lim[1])
        if self.defined is not None and ball is not None:
            a, b = self.defined(float(np.min(ball.mass_kg)), float(np.max(ball.diameter_m)))
            lo, hi = max(lo, a), min(hi, b)
        return lo, hi

    def typical_range(self, ball=None):
        """``(lo, hi)`` [unit]: the central 95 % of the log-normal prior density, for a ``typical`` parameter;
        None otherwise."""
        if not self.typical or not isinstance(self.density, LogNormalPrior):
            return None
        from statistics import NormalDist  # here: the module is not worth importing for every command

        z = NormalDist().inv_cdf(0.975)         # the central 95 % of the normal ln x
        med, spread = self.density.center(ball), math.exp(z * float(self.density.sigma_ln))
        return med / spread, med * spread

    def prior_pdf(self, x, ball=None):
        """Prior density at ``x`` [1/unit]; ``ball`` (mass_kg, diameter_m) for ball-dependent priors."""
        x = np.asarray(x, dtype=float)
        if self.density is None:
            lo, hi = self.prior
            return np.where((x >= lo) & (x <= hi), 1.0 / (hi - lo), 0.0)
        return np.asarray(self.density.pdf(x, ball), dtype=float)

    def prior_description(self, ball=None):
        """A short text of the prior density."""
        if self.density is None:
            unit = "" if self.unit in ("", "1") else f" {self.unit}"
            return f"uniform {self.prior[0]:g} .. {self.prior[1]:g}{unit}"
        return self.density.describe(ball, self.unit)


@dataclass(frozen=True)
class Effect:
    """One named candidate effect (see the module docstring). ``check`` says what to check in
    the input when the effect would fit only with an unphysical value; ``check_by_kind`` says it
    for one data kind where that differs ({kind: text}); ``every_flight``: the effect is the record's (a
    camera's), alike in every frame, so a trajectory's flights after its first fall must need it too
    (:func:`vrcal.discovery.ranking.later_flights_gain`): a first fall that alone departs from a free fall
    is no camera's doing."""

    name: str
    parameters: tuple
    equation: str
    description: str
    reference: str
    kinds: tuple
    null_values: dict
    function: object = field(default=None, compare=False, repr=False)
    check: str = ""
    check_by_kind: dict = field(default_factory=dict, compare=False)
    check_rigid: str = ""
    every_flight: bool = False

    def check_for(self, kind, surface="rigid"):
        """What to check in input of ``kind`` ("trajectory", "impacts", "apexes") when the effect would
        fit only with an unphysical value; on a floor said to be rigid (``surface``, :data:`SURFACES`) it
        adds ``check_rigid`` (a soft floor to declare)."""
        text = self.check_by_kind.get(kind, self.check)
        return text + self.check_rigid if surface == "rigid" and self.check_rigid else text

    @property
    def defaults(self):
        """``{parameter name: default value}``."""
        return {p.name: p.default for p in self.parameters}

    def parameter(self, name):
        """The :class:`Parameter` called ``name``; UsageError naming the valid ones otherwise."""
        for p in self.parameters:
            if p.name == name:
                return p
        valid = ", ".join(p.name for p in self.parameters)
        raise UsageError(f"effect '{self.name}' has no parameter '{name}' (valid: {valid})")


# --------------------------------------------------------------------------- equations


def buoyant_gravity_m_per_s2(g_m_per_s2, diameter_m, mass_kg, air_density_kg_per_m3):
    """Effective downward acceleration of a ball in still air with buoyancy and added mass.

    Parameters
    ----------
    g_m_per_s2 : float or ndarray
        gravitational acceleration [m/s^2], > 0
    diameter_m : float or ndarray
        ball diameter D [m], > 0
    mass_kg : float or ndarray
        ball mass m [kg], > 0
    air_density_kg_per_m3 : float or ndarray
        rho [kg/m^3], >= 0 (0 switches the effect off)

    Returns
    -------
    g_eff_m_per_s2 : float or ndarray
        ``g (m - rho V) / (m + rho V / 2)``, V = pi D^3 / 6 [m^3]; negative for a ball lighter than
        the air it displaces (it rises)

    Raises
    ------
    UsageError
        if a value is not finite or outside its range above

    Notes
    -----
    Not in [1]. Archimedes' force rho V g and the added mass rho V / 2 of a sphere [5]
    (quasi-steady; the history force is neglected). Hollow balls are light for their
    size: rho V / m = 1.49 % for a 2.7 g, 40 mm table-tennis ball and for a basketball,
    2.2 % for a volleyball, 1.5 % for a football, 0.33 % for a tennis ball, so g_eff is
    2.2 %, 2.2 %, 3.2 %, 2.3 % and 0.5 % below g. Without drag it leaves the apex ratios
    unchanged (they are energy ratios); it shows in the shape of a trajectory. With drag the added
    mass also divides the drag constant k by (m + rho V / 2) / m (:func:`drag_constant_per_m`'s
    ``added_mass_kg``), which changes the apexes (from rest they depend on k alone: exactly as a C_d
    lower by that factor) and the impact times: a 0.1 kg, 0.5 m beach ball with C_d 0.47 and
    epsilon 0.877 dropped from 2 m rises to 0.470 m without buoyancy and to 0.600 m with it.
    """
    g = check_array("g_m_per_s2", g_m_per_s2)
    D = check_array("diameter_m", diameter_m)
    m = check_array("mass_kg", mass_kg)
    rho = check_array("air_density_kg_per_m3", air_density_kg_per_m3, lo_open=False)
    return _out(_buoyant_gravity_m_per_s2(g, D, m, rho))


def _buoyant_gravity_m_per_s2(g, D, m, rho):
    """:func:`buoyant_gravity_m_per_s2` of checked arrays (the simulator's inner call)."""
    added = _added_mass_kg(D, rho)
    return g * (m - 2.0 * added) / (m + added)


#: Share of a ball's mean density up to which the fitter may try the density of the air around it: at the
#: ball's own density it would float (g_eff = 0, :func:`buoyant_gravity_m_per_s2`), where a drop has no model.
FLOATING_MARGIN = 1e-3


def buoyancy_defined_range(mass_kg, diameter_m):
    """Air densities ``(lo, hi)`` [kg/m^3] at which a ball still falls (the range over which the buoyancy
    model of this ball exists): 0 to just below the ball's mean density m / V, where g_eff reaches 0.

    Parameters
    ----------
    mass_kg : float
        ball mass m [kg], > 0
    diameter_m : float
        ball diameter D [m], > 0
    """
    return 0.0, float(ball_density_kg_per_m3(mass_kg, diameter_m)) * (1.0 - FLOATING_MARGIN)


def restitution_at_speed(epsilon_ref, impact_speed_m_per_s, reference_speed_m_per_s, exponent):
    """Speed-dependent coefficient of restitution, nested in a constant epsilon.

    Parameters
    ----------
    epsilon_ref : float or ndarray
        epsilon at the reference speed, in (0, 1]
    impact_speed_m_per_s : float or ndarray
        impact speed v [m/s], > 0 (>= 0 where p = 0: the constant epsilon needs no speed)
    reference_speed_m_per_s : float or ndarray
        reference speed v_ref [m/s], > 0; vrcal uses each drop's first impact speed
    exponent : float or ndarray
        p, dimensionless, finite; 0 gives the constant epsilon of [1], 1/5 the viscoelastic law [2]

    Returns
    -------
    epsilon : float or ndarray
        ``1 - (1 - eps_ref) (v / v_ref)^p``, clipped to [1e-6, 1]; exactly eps_ref where p = 0

    Raises
    ------
    UsageError
        if a value is not finite or outside its range above

    Notes
    -----
    Departure from [1], whose epsilon = exp(-K x/(2v)) (Eqs. 7, 10) does not depend on
    the impact speed. For viscoelastic spheres 1 - epsilon grows as v^(1/5) to first
    order [2], so slower (later) bounces are more elastic. With v_ref = the first impact
    speed, eps_ref is the epsilon a drop test measures on its first bounce (Eq. 9).
    """
    eps = check_array("epsilon_ref", epsilon_ref, 0.0, 1.0)
    p = check_array("exponent", exponent, -math.inf, lo_open=False)
    v = check_array("impact_speed_m_per_s", impact_speed_m_per_s, lo_open=False)
    check_array("impact_speed_m_per_s", v, where=p != 0, where_text="where exponent != 0")
    v_ref = check_array("reference_speed_m_per_s", reference_speed_m_per_s)
    with np.errstate(divide="ignore", invalid="ignore"):   # v = 0 where p = 0: where() keeps eps_ref
        return _out(_restitution_at_speed(eps, v, v_ref, p))


def _restitution_at_speed(eps, v, v_ref, p):
    """:func:`restitution_at_speed` of checked arrays (the simulator's inner loop)."""
    # eps - (1 - eps)((v/v_ref)^p - 1): exactly eps_ref at p = 0 and at v = v_ref
    eps_v = eps - (1.0 - eps) * np.expm1(p * np.log(v / v_ref))
    return np.where(p == 0, eps, np.clip(eps_v, 1e-6, 1.0))


def observed_height_m(bottom_height_m, offset_m):
    """Height of the tracked point from the height of the ball's bottom [m].

    Parameters
    ----------
    bottom_height_m : float or ndarray
        height of the ball's bottom above the floor [m]
    offset_m : float or ndarray
        tracked point above the bottom [m]: D/2 for the centre, D for the top, or a
        mis-set floor line (negative when the line is drawn too high)

    Returns
    -------
    height_m : float or ndarray
        ``y_bottom + offset``
    """
    return _out(np.asarray(bottom_height_m, dtype=float) + np.asarray(offset_m, dtype=float))


def liftoff_time_s(impact_time_s, contact_time_s):
    """Time the ball leaves the floor after a contact of finite duration [s].

    Parameters
    ----------
    impact_time_s : float or ndarray
        time of first touch [s]
    contact_time_s : float or ndarray
        time spent on the floor [s], >= 0

    Returns
    -------
    t_s : float or ndarray
        ``t_impact + tau_c``

    Notes
    -----
    Departure from [1], whose contacts are instantaneous in the flight timeline. (The
    paper's Eq. (10) T = x/(2v) is the time of its *virtual* bodies, not this one.)
    During the contact the ball's bottom dips below the floor level in a half sine of
    depth ``(v_in + v_out) tau_c / (2 pi)`` (the compression of a linear spring-damper
    contact; :meth:`vrcal.drop.simulate.Drops.height_m`) and leaves with the rebound speed:
    a soft contact's dip is part of this effect, not a height offset.
    """
    return _out(np.asarray(impact_time_s, dtype=float) + np.asarray(contact_time_s, dtype=float))


def sampled_time_s(t_s, height_m, readout_s_per_m):
    """When a rolling-shutter camera saw a ball it shows at ``height_m`` in the frame stamped ``t_s`` [s].

    Parameters
    ----------
    t_s : float or ndarray
        the frame's time stamp [s]
    height_m : float or ndarray
        the ball's height in that frame (the tracked point's, above the floor line) [m]
    readout_s_per_m : float or ndarray
        kappa = R / H_frame [s/m]: the frame's readout time R [s] over the height H_frame [m] it spans;
        > 0 when the rows are read from the top of the scene down (a phone held upright), < 0 upside
        down, 0 for a global shutter or rows read across the fall

    Returns
    -------
    t_s : float or ndarray
        ``t - kappa y``: a frame's rows are read one after another [8], so a ball low in the frame is
        read later than a ball high in it: row y is read at ``t + R (Y_top - y) / H_frame``, whose
        constant part ``R Y_top / H_frame`` is the same for every sample (the release time takes it).
        The ball seen is then ``y_obs(t) = y(t - kappa y_obs(t))`` (:meth:`vrcal.drop.simulate.Drops.height_m`
        solves it).

    Notes
    -----
    Not in [1], whose heights are taken at one instant. A readout of R = 20 ms over a 1.6 m frame
    (kappa 0.0125 s/m) samples a ball 0.8 m up 10 ms before one on the floor: every fall looks
    shorter and every rise longer by about kappa h, the asymmetry air drag gives a flight the other way
    round; a constant-epsilon fit without it took a table-tennis ball of 0.90 for 0.82 and a speed law.
    """
    return _out(np.asarray(t_s, dtype=float) - np.asarray(readout_s_per_m, dtype=float)
                * np.asarray(height_m, dtype=float))


#: The largest rolling shutter of any camera, |kappa| [s/m]: a 40 ms readout (the slowest phone sensors) over a
#: 0.4 m frame (the smallest that holds a drop worth fitting); ``rolling_shutter``'s hard limits and bounds.
READOUT_LIMIT_S_PER_M = 0.1


def record_readout_limit_s_per_m(t_s, height_m):
    """The largest rolling shutter a video record can hold, |kappa| = R / H_frame [s/m].

    Parameters
    ----------
    t_s : ndarray
        the record's sample times [s] (one sample a frame, or fewer)
    height_m : ndarray
        the heights of its samples [m]

    Returns
    -------
    float
        ``dt / span``, at most :data:`READOUT_LIMIT_S_PER_M`: a camera reads a frame's rows within one frame
        interval (R <= dt, the median step of the times: the next frame's readout follows), and its frame
        holds every height the ball was seen at (H_frame >= span, their range). A 100 fps video of a 2.65 m
        drop: 0.0038 s/m; 30 fps of 0.8 m: 0.042 s/m; 240 fps of 1 m: 0.0042 s/m. A record sampled every
        k-th frame gets a limit k times wider (still a limit); :data:`READOUT_LIMIT_S_PER_M` without two
        distinct times or heights.
    """
    t = np.asarray(t_s, dtype=float)
    y = np.asarray(height_m, dtype=float)
    steps = np.diff(t[np.isfinite(t)])
    steps = steps[steps > 0]
    y = y[np.isfinite(y)]
    span = float(np.ptp(y)) if y.size else 0.0
    if not steps.size or not span > 0:
        return READOUT_LIMIT_S_PER_M
    return min(READOUT_LIMIT_S_PER_M, float(np.median(steps)) / span)


def readout_limits(ball):
    """The hard limits ``(lo, hi)`` [s/m] of ``rolling_shutter`` for a record: +- the ball's
    ``readout_limit_s_per_m`` (:func:`record_readout_limit_s_per_m`, set by ``vrcal discover``), or
    +- :data:`READOUT_LIMIT_S_PER_M` without one."""
    lim = getattr(ball, "readout_limit_s_per_m", None)
    lim = READOUT_LIMIT_S_PER_M if lim is None else min(float(lim), READOUT_LIMIT_S_PER_M)
    return -lim, lim


#: Typical gauge pressure of an inflated ball [Pa] (basketball 52-59 kPa, volleyball 29-32 kPa,
#: football 60-110 kPa; a pressurised tennis ball 80-100 kPa), for :func:`inflated_contact_time_s`.
TYPICAL_GAUGE_PRESSURE_PA = 60e3


def inflated_contact_time_s(mass_kg, diameter_m, gauge_pressure_pa=TYPICAL_GAUGE_PRESSURE_PA):
    """Contact time of an inflated ball on a rigid floor, membrane model [s].

    Parameters
    ----------
    mass_kg : float or ndarray
        ball mass m [kg], > 0
    diameter_m : float or ndarray
        ball diameter D [m], > 0
    gauge_pressure_pa : float or ndarray
        inside minus outside pressure p [Pa], > 0

    Returns
    -------
    tau_s : float or ndarray
        ``pi sqrt(m / (pi D p))``: half the period of the spring k = pi D p

    Notes
    -----
    A ball compressed by x against a flat floor touches it on a disc of area about
    pi D x, on which the gas pushes with the gauge pressure: F = pi D p x, a linear
    spring (the wall's bending stiffness and the rise of p are neglected). The contact
    lasts half a period. With p = 60 kPa: table tennis 1.9 ms, tennis 6.7 ms, volleyball
    8.2 ms, football 10 ms, basketball 11 ms -- the scale of measured contact times
    (about 1 ms for table tennis, 4-10 ms for tennis balls and basketballs; see [3]). The
    median of the contact time's prior density of a hollow ball (which is wide: sigma_ln 1;
    :func:`expected_contact_time_s`); it is no model of solid balls.
    """
    m = check_array("mass_kg", mass_kg)
    D = check_array("diameter_m", diameter_m)
    p = check_array("gauge_pressure_pa", gauge_pressure_pa)
    return _out(math.pi * np.sqrt(m / (math.pi * D * p)))


#: Mean density [kg/m^3] above which a ball is solid (golf 1,130, a superball 1,100, a baseball 680),
#: below which it is hollow (a tennis ball 370, table tennis 80, a basketball 80).
SOLID_BALL_DENSITY_KG_PER_M3 = 600.0

#: Effective moduli E* = E / (1 - nu^2) [Pa] of a solid ball's contact by its mean density [kg/m^3], for
#: :func:`expected_contact_time_s` and :func:`contact_time_range_s`: (least density, (softest, typical,
#: stiffest), what). Rubbers, plastics, wood and clay (600-2,300 kg/m^3): putty and plasticine about 1 MPa,
#: soft rubbers 1-10 MPa, a golf ball's core about 100 MPa (its contact: about 0.45 ms measured at 40 m/s),
#: hard plastics (nylon, PMMA) and wood 2-3 GPa. Glass, stone, ceramics and metals (2,300 kg/m^3 and more):
#: E* of glass 73 GPa, steel 220 GPa, tungsten carbide 600 GPa, and the contact's E* also counts the floor's
#: compliance (a steel ball on glass 54 GPa, on steel 110 GPa). Sources: K. L. Johnson, Contact Mechanics
#: (Cambridge 1985), Table 1 of ch. 4 and sec. 11.4; W. Goldsmith, Impact (Arnold 1960), ch. 4.
SOLID_MODULUS_CLASSES = (
    (SOLID_BALL_DENSITY_KG_PER_M3, (1e6, 100e6, 3e9), "rubber, plastic, wood or clay"),
    (2300.0, (50e9, 100e9, 220e9), "glass, stone or metal"),
)

#: The slowest impact speed [m/s] a bounce record holds, for :func:`contact_time_limit_s`.
SLOW_IMPACT_M_PER_S = 0.5


def solid_contact_time_s(mass_kg, diameter_m, modulus_pa=SOLID_MODULUS_CLASSES[0][1][0],
                         speed_m_per_s=SLOW_IMPACT_M_PER_S):
    """Contact time of a solid elastic ball on a rigid floor, Hertz's impact [s].

    Parameters
    ----------
    mass_kg : float or ndarray
        ball mass m [kg], > 0
    diameter_m : float or ndarray
        ball diameter D [m], > 0
    modulus_pa : float or ndarray
        effective modulus E* = E / (1 - nu^2) of the contact [Pa], > 0 (default the softest solid, 1 MPa)
    speed_m_per_s : float or ndarray
        impact speed v [m/s], > 0 (default :data:`SLOW_IMPACT_M_PER_S`)

    Returns
    -------
    tau_s : float or ndarray
        ``2.868 (m^2 / (R E*^2 v))^(1/5)``, R = D / 2 (Landau & Lifshitz, Theory of Elasticity, sec. 9)

    Notes
    -----
    A 12.7 mm steel bearing (E* 100 GPa) at 2.4 m/s: 39 us; a golf ball (100 MPa) at 2 m/s: 1.0 ms.
    """
    m = check_array("mass_kg", mass_kg)
    R = 0.5 * check_array("diameter_m", diameter_m)
    E = check_array("modulus_pa", modulus_pa)
    v = check_array("speed_m_per_s", speed_m_per_s)
    return _out(2.868 * (m * m / (R * E * E * v)) ** 0.2)


#: Impact speed [m/s] of a typical drop test's contact, for :func:`expected_contact_time_s` (Hertz's
#: v^(-1/5) makes the time depend little on it: 0.8 ms for a golf ball at 3 m/s, 1.0 ms at 2 m/s).
TYPICAL_IMPACT_M_PER_S = 2.0


def solid_moduli_pa(mass_kg, diameter_m):
    """The effective moduli (softest, typical, stiffest) [Pa] of a ball's contact from its density
    (:data:`SOLID_MODULUS_CLASSES`), or None for a hollow ball (lighter than
    :data:`SOLID_BALL_DENSITY_KG_PER_M3`)."""
    rho = float(ball_density_kg_per_m3(mass_kg, diameter_m))
    moduli = None
    for least, values, _ in SOLID_MODULUS_CLASSES:
        if rho > least:
            moduli = values
    return moduli


#: The floors a ball may bounce on (``vrcal discover --surface``): "rigid" (concrete, stone, a wooden or
#: steel plate: the ball sets its contact time, :func:`solid_contact_time_s`, :func:`inflated_contact_time_s`)
#: or "soft" (a stack of paper, a foam or gym mat, carpet, turf, sand: the floor sets it,
#: :data:`SOFT_FLOOR_CONTACT_TIME_S`).
SURFACES = ("rigid", "soft")

#: Contact times of a ball on a soft floor [s]: (shortest, typical, longest). There the floor, not the ball,
#: gives way: the ball sinks into it by delta and rises again, a half-sine of tau = pi delta / v at the impact
#: speed v (the dip of this module's contact, :func:`liftoff_time_s`): 1-10 mm at 1-3 m/s give 1-30 ms.
#: Measured: a 16 mm glass marble on a stack of 100 sheets of paper stays 1.7 frames at 200 fps (8 ms) down
#: (XS06, "Bouncing on Paper", github.com/XS06, 2025, ImageJ MTrack2 tracks); a golf ball on a green is
#: rigid beside the turf, whose compliance sets the bounce (S. W. Biber et al., "Measurements and linearized
#: models for golf ball bounce on a green", Sports Eng. 26 (2023), doi:10.1007/s12283-023-00442-4; S. J.
#: Haake, thesis, Aston 1989: spring-damper turf). The longest, 50 ms (the fitter's bound): a marble sinking
#: its radius at 0.5 m/s; a typical 10 ms.
SOFT_FLOOR_CONTACT_TIME_S = (0.002, 0.01, 0.05)


def surface_of(ball):
    """The floor ``ball`` bounces on (its ``surface`` attribute, :data:`SURFACES`; "rigid" without one)."""
    return check_surface(getattr(ball, "surface", "rigid"))


def check_surface(surface):
    """``surface`` when it is one of :data:`SURFACES`; UsageError naming them otherwise."""
    if surface not in SURFACES:
        raise UsageError(f"unknown surface {surface!r} (valid: {', '.join(SURFACES)})")
    return surface


def on_floor_s(ball_s, floor_s):
    """Contact time of a ball on a floor that gives way too [s]: the two springs in series, whose half
    periods add in quadrature (tau = pi sqrt(m (1/k_ball + 1/k_floor)) for linear springs).

    Parameters
    ----------
    ball_s : float or ndarray
        the ball's contact time on a rigid floor [s], >= 0
    floor_s : float or ndarray
        a rigid ball's contact time on the floor [s], >= 0
    """
    return _out(np.hypot(check_array("ball_s", ball_s, lo_open=False), check_array("floor_s", floor_s, lo_open=False)))


def expected_contact_time_s(mass_kg, diameter_m, surface="rigid"):
    """The contact time to expect of a ball [s]: the membrane model of an inflated ball
    (:func:`inflated_contact_time_s`, 60 kPa), or Hertz's time of a solid one
    (:func:`solid_contact_time_s` at the typical modulus of its density class,
    :data:`SOLID_MODULUS_CLASSES`, at :data:`TYPICAL_IMPACT_M_PER_S`): table tennis 1.9 ms, tennis 6.7 ms,
    basketball 11 ms, a golf ball 1.0 ms, a 12.7 mm steel bearing 40 us. On a soft floor (``surface``
    "soft") that time and the soft floor's typical 10 ms (:data:`SOFT_FLOOR_CONTACT_TIME_S`) in series
    (:func:`on_floor_s`). The median of the contact time's prior density.

    Parameters
    ----------
    mass_kg : float
        ball mass [kg]
    diameter_m : float
        ball diameter [m]
    surface : {"rigid", "soft"}
        the floor (:data:`SURFACES`)
    """
    moduli = solid_moduli_pa(mass_kg, diameter_m)
    if moduli is not None:
        own = float(solid_contact_time_s(mass_kg, diameter_m, moduli[1], TYPICAL_IMPACT_M_PER_S))
    else:
        own = float(inflated_contact_time_s(mass_kg, diameter_m))
    return _on_surface(own, surface, SOFT_FLOOR_CONTACT_TIME_S[1])


#: Gauge pressures [Pa] of inflated balls (a volleyball 30 kPa to a football 110 kPa), for
#: :func:`contact_time_range_s`.
GAUGE_PRESSURE_RANGE_PA = (30e3, 110e3)


def contact_time_range_s(mass_kg, diameter_m, surface="rigid"):
    """The plausible contact times of a ball [s], (shortest, longest): Hertz's time of a solid ball at the
    stiffest and softest modulus of its density class (:data:`SOLID_MODULUS_CLASSES`), or the membrane
    model of an inflated one over :data:`GAUGE_PRESSURE_RANGE_PA`, at :data:`TYPICAL_IMPACT_M_PER_S`: a
    golf ball 0.25-6.3 ms, a steel bearing 29-53 us, a tennis ball 5.0-9.5 ms. On a soft floor
    (``surface`` "soft") each in series with the soft floor's shortest and longest
    (:data:`SOFT_FLOOR_CONTACT_TIME_S`, :func:`on_floor_s`).

    Parameters
    ----------
    mass_kg : float
        ball mass [kg]
    diameter_m : float
        ball diameter [m]
    surface : {"rigid", "soft"}
        the floor (:data:`SURFACES`)
    """
    moduli = solid_moduli_pa(mass_kg, diameter_m)
    if moduli is not None:
        own = tuple(float(solid_contact_time_s(mass_kg, diameter_m, e, TYPICAL_IMPACT_M_PER_S))
                    for e in (moduli[2], moduli[0]))
    else:
        own = tuple(float(inflated_contact_time_s(mass_kg, diameter_m, p)) for p in GAUGE_PRESSURE_RANGE_PA[::-1])
    return _on_surface(own, surface, SOFT_FLOOR_CONTACT_TIME_S[::2])


def contact_time_limit_s(mass_kg, diameter_m, surface="rigid"):
    """Largest physical contact time of a ball [s]: twice the membrane estimate of an inflated ball
    (:func:`inflated_contact_time_s`), or Hertz's time of a solid one at the softest modulus of its density
    class (:data:`SOLID_MODULUS_CLASSES`) and a slow impact (:data:`SLOW_IMPACT_M_PER_S`). On a soft floor
    (``surface`` "soft") that in series with the soft floor's longest, 50 ms (:data:`SOFT_FLOOR_CONTACT_TIME_S`,
    :func:`on_floor_s`).

    Parameters
    ----------
    mass_kg : float
        ball mass [kg]
    diameter_m : float
        ball diameter [m]
    surface : {"rigid", "soft"}
        the floor (:data:`SURFACES`)
    """
    moduli = solid_moduli_pa(mass_kg, diameter_m)
    if moduli is not None:
        own = float(solid_contact_time_s(mass_kg, diameter_m, moduli[0], SLOW_IMPACT_M_PER_S))
    else:
        own = 2.0 * float(inflated_contact_time_s(mass_kg, diameter_m))
    return _on_surface(own, surface, SOFT_FLOOR_CONTACT_TIME_S[2])


def _on_surface(own_s, surface, floor_s):
    """A ball's own contact time(s) ``own_s`` [s] (a float, or a tuple) on ``surface``: as they are on a rigid
    floor, in series with the soft floor's ``floor_s`` (as many) on a soft one (:func:`on_floor_s`)."""
    if check_surface(surface) == "rigid":
        return own_s
    if isinstance(own_s, tuple):
        return tuple(float(on_floor_s(t, f)) for t, f in zip(own_s, floor_s))
    return float(on_floor_s(own_s, floor_s))


# --------------------------------------------------------------------------- the registry


EFFECTS = {
    "air_drag": Effect(
        name="air_drag",
        parameters=(
            Parameter("drag_coefficient", "1", 0.5, (0.0, 3.0), (0.1, 1.0),
                      "drag coefficient C_d of the ball (smooth sphere 0.47; 0.1-0.3 past the drag crisis)",
                      LogNormalPrior(SPHERE_DRAG_COEFFICIENT, 0.3,
                                     "sphere below the drag crisis (Achenbach 1972; Mehta 1985)"),
                      limits=(0.2, 1.0), typical=True),
        ),
        equation="a = -g - k v|v|,  k = rho C_d pi D^2 / (8 m),  rho = 1.204 kg/m^3",
        description="quadratic air drag during the flights; lowers each apex below eps^2 times the previous "
                    "one and shortens the flights",
        reference="Mehta, Annu. Rev. Fluid Mech. 17, 151 (1985); Cross & Lindsey, Phys. Teach. 52, 169 (2014)",
        kinds=("trajectory", "impacts", "apexes"),
        null_values={"drag_coefficient": 0.0},
        function=drag_constant_per_m,
        check="check the ball's mass and diameter, the length scale and the frame rate",
        check_by_kind={"impacts": "check the ball's mass and diameter and the time unit of the file"},
    ),
    "velocity_dependent_restitution": Effect(
        name="velocity_dependent_restitution",
        parameters=(
            Parameter("exponent", "1", 0.2, (-1.0, 2.0), (0.0, 0.5),
                      "p in 1 - eps = (1 - eps_ref)(v/v_ref)^p; 1/5 viscoelastic spheres, 1 Hunt-Crossley, "
                      "0 = constant eps",
                      LogNormalPrior(0.2, math.log(2.0), "viscoelastic spheres, p = 1/5 (Ramirez et al. 1999)"),
                      limits=(0.0, 1.0)),
        ),
        equation="eps(v) = 1 - (1 - eps_ref) (v / v_ref)^p,  v_ref = first impact speed",
        description="epsilon depends on the impact speed: slower (later) bounces are more elastic for p > 0",
        reference="Kuwabara & Kono, Jpn. J. Appl. Phys. 26, 1230 (1987); Ramirez, Poeschel, Brilliantov, "
                  "Schwager, Phys. Rev. E 60, 4465 (1999) (viscoelastic, p = 1/5); Hunt & Crossley, J. Appl. "
                  "Mech. 42, 440 (1975) (p = 1, the upper limit)",
        kinds=("trajectory", "impacts", "apexes"),
        null_values={"exponent": 0.0},
        function=restitution_at_speed,
        check="check the time scale and for bounces that do not belong (a kick, a second surface)",
        check_by_kind={"apexes": "check the ball's mass and diameter (air drag makes rebounds fall off with "
                                 "height too), the point of the ball each height was read to, and for trials "
                                 "that do not belong (a misread height, a rebound off something else)"},
    ),
    "contact_duration": Effect(
        name="contact_duration",
        parameters=(
            Parameter("contact_time_s", "s", 0.005, (0.0, 0.05), (0.0, 0.02),
                      "time the ball spends on the floor at each bounce (about 1 ms table tennis, 4-10 ms "
                      "tennis/basketball)",
                      LogNormalPrior(expected_contact_time_s, 1.0,
                                     "half period of an inflated ball at 60 kPa gauge, Hertz's time of a "
                                     "solid one at its density class's typical modulus"),
                      limits=lambda m, D, surface="rigid": (0.0, contact_time_limit_s(m, D, surface))),
        ),
        equation="t_liftoff = t_impact + tau_c;  in contact a half-sine dip of (v_in + v_out) tau_c / (2 pi)",
        description="each contact lasts tau_c: the impact intervals grow by tau_c each, unlike a pure "
                    "geometric series",
        reference="Cross, Am. J. Phys. 67, 222 (1999); solid balls: Hertz (Landau & Lifshitz, Theory of "
                  "Elasticity, sec. 9) with E* by density class: rubber, plastic, wood, clay 600-2,300 kg/m^3: "
                  "1 MPa-3 GPa (typical 100 MPa); glass, stone, metal: 50-220 GPa (typical 100 GPa) (Johnson, "
                  "Contact Mechanics, 1985; Goldsmith, Impact, 1960)",
        kinds=("trajectory", "impacts"),
        null_values={"contact_time_s": 0.0},
        function=liftoff_time_s,
        check="check the frame rate or time scale, and the ball's mass and diameter",
        check_by_kind={"impacts": "check the time unit of the file, for impacts missed or heard twice, and the "
                                  "ball's mass and diameter"},
        check_rigid=", or the floor is soft (paper, a mat, carpet, turf, sand): --surface soft",
    ),
    "height_offset": Effect(
        name="height_offset",
        parameters=(
            Parameter("offset_m", "m", 0.02, (-0.5, 0.5), (-0.05, 0.25),
                      "tracked point above the ball's bottom: D/2 for the centre, D for the top, or a mis-set "
                      "floor line",
                      TrackedPointPrior(basis="ITTF (bottom), video trackers (centre), FIBA (top)"),
                      limits=lambda m, D, surface="rigid": (-D, D + max(0.1 * D, 0.005))),
        ),
        equation="y_observed = y_bottom + offset",
        description="the tracked point is not the bottom of the ball (or the floor line is mis-set): "
                    "ratios of observed heights are no longer eps^2",
        reference="ITTF Technical Leaflet T3 (drop measured to the bottom); FIBA equipment rules "
                  "(rebound to the top); the paper's Table 1 mixes both",
        kinds=("trajectory", "apexes"),
        null_values={"offset_m": 0.0},
        function=observed_height_m,
        check="check the floor line (--floor), the length scale, and for a bounce off something above the floor",
        check_by_kind={"apexes": "check the point of the ball the heights were read to (a rebound read at the "
                                 "ball's top is one diameter high, at its centre half one: --rebound-measured-to "
                                 "top or centre) and the length unit"},
    ),
    "buoyancy": Effect(
        name="buoyancy",
        parameters=(
            Parameter("air_density_kg_per_m3", "kg/m^3", AIR_DENSITY_KG_PER_M3, (0.0, 2.0), (0.9, 1.3),
                      "density of the displacing air (1.204 at 20 C, sea level)", limits=(0.8, 1.4),
                      defined=buoyancy_defined_range),
        ),
        equation="g_eff = g (m - rho V) / (m + rho V / 2),  V = pi D^3 / 6",
        description="Archimedes' force and the added mass of air: a hollow ball falls with a smaller "
                    "acceleration (table tennis and basketball -2.2 % of g, volleyball -3.2 %, tennis -0.5 %); "
                    "the flights are longer; without drag apex ratios are unchanged, with drag the added mass "
                    "lowers k as a lower C_d would (higher apexes)",
        reference="Landau & Lifshitz, Fluid Mechanics, Sec. 11 (added mass of a sphere)",
        kinds=("trajectory",),
        null_values={"air_density_kg_per_m3": 0.0},
        function=buoyant_gravity_m_per_s2,
        check="check the frame rate and the length scale (g from the flights)",
    ),
    "rolling_shutter": Effect(
        name="rolling_shutter",
        parameters=(
            Parameter("readout_s_per_m", "s/m", 0.0125, (-READOUT_LIMIT_S_PER_M, READOUT_LIMIT_S_PER_M),
                      (-0.04, 0.04),
                      "kappa = R / H_frame: the camera's readout time over the height its frame spans (20 ms over "
                      "1.6 m: 0.0125); < 0 for a phone upside down, 0 for a global shutter",
                      NormalPrior(0.0, 0.02, "phone CMOS readouts 5-35 ms over frames of 1-2 m, either way up "
                                             "(Liang, Chang, Chen 2008)"),
                      record_limits=readout_limits),
        ),
        equation="y_observed(t) = y(t - kappa y_observed(t)),  kappa = R / H_frame",
        description="the camera reads its rows one after another (a CMOS rolling shutter): a ball low in the "
                    "frame is seen later than one high in it, so each fall looks shorter and each rise longer",
        reference="Liang, Chang, Chen, IEEE Trans. Image Process. 17(8), 1323 (2008)",
        kinds=("trajectory",),
        null_values={"readout_s_per_m": 0.0},
        function=sampled_time_s,
        check="check the frame rate and whether the camera's rows were read across the fall (turn the phone)",
        every_flight=True,
    ),
}


def get_effect(name):
    """The :class:`Effect` called ``name``; UsageError naming the valid ones otherwise."""
    if name in EFFECTS:
        return EFFECTS[name]
    close = closest_name(name, EFFECTS)
    hint = f"; did you mean '{close}'?" if close else ""
    raise UsageError(f"unknown effect '{name}'{hint} (valid: {', '.join(EFFECTS)})")


def parse_effect_spec(text):
    """Parse ``NAME[:PARAM=VALUE,...]`` into ``(name, {param: value})``.

    Parameters left out take their defaults: ``"air_drag"`` -> ``("air_drag",
    {"drag_coefficient": 0.5})``.

    Raises
    ------
    UsageError
        unknown effect or parameter (naming the valid ones), a value that is not a
        number, or a value outside the parameter's bounds.
    """
    text = str(text).strip()
    name, _, rest = text.partition(":")
    effect = get_effect(name.strip())
    params = effect.defaults
    for item in filter(None, (s.strip() for s in rest.split(","))):
        key, eq, value = item.partition("=")
        if not eq:
            raise UsageError(f"effect '{effect.name}': expected PARAM=VALUE, got '{item}'")
        p = effect.parameter(key.strip())
        try:
            number = float(value)
        except ValueError:
            raise UsageError(f"effect '{effect.name}': {p.name} must be a number, got '{value.strip()}'") from None
        params[p.name] = number
    return effect.name, check_parameters(effect.name, params)


def format_effect_spec(name, params):
    """The inverse of :func:`parse_effect_spec`: ``"air_drag:drag_coefficient=0.5"``."""
    return name + ":" + ",".join(f"{k}={float(v)!r}" for k, v in sorted(params.items()))


def check_parameters(name, params):
    """Validate one effect's parameters (names and bounds); fill in missing ones with defaults.

    Values may be floats or arrays. Returns a new dict.
    """
    effect = get_effect(name)
    out = effect.defaults
    for key, value in dict(params or {}).items():
        p = effect.parameter(key)
        arr = np.asarray(value, dtype=float)
        lo, hi = p.bounds
        bad = ~np.isfinite(arr) | (arr < lo) | (arr > hi)
        if np.any(bad):
            raise UsageError(f"effect '{name}': {p.name} must lie in [{lo:g}, {hi:g}] {p.unit}, "
                             f"got {np.ravel(arr[bad])[0]:g}")
        out[p.name] = value
    return out


def resolve_effects(effects):
    """Validate ``{effect name: {param: value}}`` (or an iterable of names / spec strings).

    Returns ``{name: {param: value}}`` with every parameter present.
    """
    if effects is None:
        return {}
    if isinstance(effects, str):
        effects = [effects]
    if not isinstance(effects, dict):
        out = {}
        for spec in effects:
            name, params = parse_effect_spec(spec)
            if name in out:
                raise UsageError(f"effect '{name}' given twice; give each effect once with all its parameters")
            out[name] = params
        return out
    return {get_effect(name).name: check_parameters(name, params) for name, params in effects.items()}


def flight_expectation(mass_kg, diameter_m, g_m_per_s2, air_density_kg_per_m3=AIR_DENSITY_KG_PER_M3):
    """What this ball's buoyancy, added mass and air drag make of its flights, for the plausibility
    checks of a record (:func:`vrcal.measurements.plausibility.check_trajectory`).

    Parameters
    ----------
    mass_kg, diameter_m : float
        the ball [kg], [m]
    g_m_per_s2 : float
        gravity [m/s^2]
    air_density_kg_per_m3 : float
        rho [kg/m^3]

    Returns
    -------
    (g_eff_m_per_s2, k_per_m) : (float, ndarray)
        the downward acceleration without drag (:func:`buoyant_gravity_m_per_s2`), and the drag constants
        (:func:`drag_constant_per_m`, added mass rho V / 2) at the median of the drag coefficient's prior
        and 2 sigma_ln either side (0.26, 0.47, 0.86: a sphere below the drag crisis, [4, 6])
    """
    rho = float(air_density_kg_per_m3)
    g_eff = float(buoyant_gravity_m_per_s2(g_m_per_s2, diameter_m, mass_kg, rho))
    prior = EFFECTS["air_drag"].parameter("drag_coefficient").density
    cds = prior.center() * np.exp(np.array([-2.0, 0.0, 2.0]) * prior.sigma_ln)
    return g_eff, np.asarray(drag_constant_per_m(cds, diameter_m, mass_kg, rho, added_mass_kg(diameter_m, rho)),
                             dtype=float)
