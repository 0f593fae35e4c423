"""Verify an export in the real engine: the drop test, several bounces and contact phases.

:func:`verify` exports (or takes an exported file's text), loads it into the engine, drops
the ball ``n_phases`` times with the impact moved across one time step, and measures the
apex and velocity ratios of ``n_bounces`` bounces (see :mod:`vrcal.engines.common`).
"""

from __future__ import annotations

import re

from vrcal.engines import get_engine, load, require_runtime
from vrcal.engines.common import DEFAULT_TOLERANCE, VerifyResult
from vrcal.engines.export import N_BOUNCES, export, parse_exported
from vrcal.errors import UsageError

DEFAULT_PHASES = 4


def verify(ball, engine, *, epsilon=None, dt_s=None, floor=None, standards=None, tolerance=DEFAULT_TOLERANCE,
           n_bounces=N_BOUNCES, n_phases=DEFAULT_PHASES, exported_text=None):
    """Run the drop test of ``ball`` in ``engine`` with the exported settings.

    Parameters
    ----------
    ball, epsilon, dt_s, floor, standards
        as for :func:`vrcal.engines.export.export`
    engine : str
        mujoco, ode or bullet
    tolerance : float
        largest accepted |achieved - target|
    n_bounces, n_phases : int
        bounces per drop (>= 1) and contact phases across one step (>= 1)
    exported_text : str, optional
        a file written by ``vrcal export`` to load instead of a fresh export (its time step
        and, for ode/bullet, its target epsilon are used)

    Returns
    -------
    VerifyResult
    """
    eng = get_engine(engine)
    version = require_runtime(eng.name)
    if int(n_bounces) < 1 or int(n_phases) < 1:
        raise UsageError("--bounces and --phases must be at least 1")
    if not (tolerance > 0):
        raise UsageError(f"--tolerance must be > 0, got {tolerance:g}")
    step_tolerance = max(float(tolerance), DEFAULT_TOLERANCE)   # a tight tolerance fails the test, not the export
    if exported_text is not None:
        dt_file = _time_step_of(eng.name, exported_text)
        ex = export(ball, eng.name, epsilon=epsilon, dt_s=dt_file, floor=floor, standards=standards,
                    tolerance=step_tolerance)
        loaded = parse_exported(eng.name, exported_text)
        setup = ex.setup
        if isinstance(loaded, dict) and "target_epsilon" in loaded:
            from dataclasses import replace

            setup = replace(setup, epsilon=float(loaded["target_epsilon"]))
    else:
        ex = export(ball, eng.name, epsilon=epsilon, dt_s=dt_s, floor=floor, standards=standards,
                    tolerance=step_tolerance)
        loaded = parse_exported(eng.name, ex.text)       # what a user loads: the file's text
        setup = ex.setup
    module = load(eng.name)
    shifts, apex, vel = module.drop_test(loaded, setup, int(n_bounces), int(n_phases))
    return VerifyResult(
        engine=eng.name, engine_version=version, ball=setup.ball, target=setup.epsilon, dt_s=setup.dt_s,
        tolerance=float(tolerance), phases_s=shifts / setup.impact_speed_m_per_s, apex_ratios=apex,
        velocity_ratios=vel, settings=_settings(eng.name, loaded), notes=setup.notes,
    )


def _time_step_of(engine, text):
    if engine == "mujoco":
        m = re.search(r'timestep="([^"]+)"', text)
        if not m:
            raise UsageError("the MJCF file sets no <option timestep=...>")
        return float(m.group(1))
    data = parse_exported(engine, text)
    return float(data["world"]["dt"] if engine == "ode" else data["setPhysicsEngineParameter"]["fixedTimeStep"])


def _settings(engine, loaded):
    if engine == "mujoco":
        m = re.search(r'<pair geom1="ball" geom2="floor"[^>]*solref="([^"]+)"', loaded)
        return {"solref": m.group(1) if m else "?", "integrator": "RK4"}
    if engine == "ode":
        c = loaded["contact"]
        return {"mode": "|".join(c["mode"]), "bounce": c["bounce"], "bounce_vel": c["bounce_vel"],
                "erp": loaded["world"]["erp"], "cfm": loaded["world"]["cfm"]}
    return {"ball": loaded["changeDynamics"]["ball"]["restitution"],
            "floor": loaded["changeDynamics"]["floor"]["restitution"]}


def format_report(result):
    """A sectioned text report (lmfit style) of a :class:`VerifyResult`."""
    r = result
    lines = ["[[Engine]]",
             f"    engine         = {r.engine} ({r.engine_version})",
             f"    ball           = {r.ball}",
             f"    time step      = {r.dt_s:g} s",
             "    settings       = " + ", ".join(f"{k}={v}" for k, v in sorted(r.settings.items())),
             "[[Target]]",
             f"    epsilon        = {r.target:.6f}"]
    lines += [f"    from           = {n}" for n in r.notes]
    nb = r.apex_ratios.shape[1]
    lines += ["[[Achieved]]  apex = sqrt(h_k/h_(k-1)), velocity = v_out/v_in at floor level",
              "    impact at  " + "".join(f"  bounce {k + 1:<9}" for k in range(nb)),
              "    step frac  " + "  apex    vel    " * nb]
    for p, a_row, v_row in zip(r.phases_s, r.apex_ratios, r.velocity_ratios):
        cells = "".join(f"  {a:.5f} {v:.5f}" for a, v in zip(a_row, v_row))
        lines.append(f"    {p / r.dt_s:9.2f}  {cells}")
    lines += ["[[Result]]",
              f"    mean apex      = {r.mean_apex_ratio:.6f}",
              f"    mean velocity  = {r.mean_velocity_ratio:.6f}",
              f"    error          = {r.error:.6f}   (max |achieved - target| over bounces, phases, both ratios)",
              f"    tolerance      = {r.tolerance:g}",
              f"    verdict        = {'PASSED' if r.passed else 'FAILED'}"]
    return "\n".join(line.rstrip() for line in lines) + "\n"
