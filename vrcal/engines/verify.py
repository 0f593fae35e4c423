"""Verify an export in the real engine: the drop test, several bounces and contact phases.

:func:`verify` exports (or reads an exported file, :mod:`vrcal.engines.files`), loads it into
the engine, drops the ball ``n_phases`` times with the impact moved across one time step, and
measures ``n_bounces`` bounces against vrcal's own model of the same drop
(:mod:`vrcal.engines.common`). :func:`format_report` is the short text for people.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from vrcal.engines import get_engine, load, require_runtime
from vrcal.engines.common import (
    DEFAULT_TOLERANCE,
    N_BOUNCES,
    N_PHASES,
    DropSetup,
    VerifyResult,
    check_counts,
    check_positive,
    check_steps,
)
from vrcal.engines.export import export, parse_exported
from vrcal.errors import DataError, UsageError

DEFAULT_PHASES = N_PHASES


def verify(ball=None, engine="mujoco", *, epsilon=None, dt_s=None, floor=None, standards=None,
           tolerance=DEFAULT_TOLERANCE, n_bounces=None, n_phases=N_PHASES, exported_text=None,
           mass_kg=None, diameter_m=None, drop_height_m=None, impact_speed=None, g_m_per_s2=None,
           from_json=None, integrator=None, max_penetration_m=None, stiffness=None):
    """Run the drop test of a body in ``engine`` with the exported settings.

    Parameters
    ----------
    ball, epsilon, dt_s, floor, standards, mass_kg, diameter_m, drop_height_m, impact_speed,
    g_m_per_s2, from_json, integrator, max_penetration_m, stiffness
        as for :func:`vrcal.engines.export.export`
    engine : str
        mujoco, ode or bullet (pybullet)
    tolerance : float
        largest accepted |achieved - target|
    n_bounces, n_phases : int
        bounces per drop (1 ... 50; default 3, or as many as ``impact_speed`` needs) and contact
        phases across one step (1 ... 64)
    exported_text : str, optional
        a file written by ``vrcal export`` to load instead of a fresh export: its time step,
        ball and target are used (``--epsilon`` overrides the target)

    Returns
    -------
    VerifyResult
    """
    eng = get_engine(engine)
    version = require_runtime(eng.name)
    asked = n_bounces
    n_bounces, n_phases = check_counts(N_BOUNCES if asked is None else asked, n_phases)
    tolerance = check_positive(tolerance, "--tolerance")
    export_tolerance = max(tolerance, DEFAULT_TOLERANCE)   # a tight tolerance fails the test, not the export
    options = dict(epsilon=epsilon, dt_s=dt_s, floor=floor, standards=standards, mass_kg=mass_kg,
                   diameter_m=diameter_m, drop_height_m=drop_height_m, impact_speed=impact_speed,
                   g_m_per_s2=g_m_per_s2, from_json=from_json, integrator=integrator,
                   max_penetration_m=max_penetration_m)
    if exported_text is not None:
        loaded, setup = _load_file(eng.name, exported_text, ball, options)
    else:
        from vrcal.engines.export import build_setup

        pre = build_setup(ball, eng.name, epsilon, dt_s, floor, standards, tolerance=export_tolerance,
                          mass_kg=mass_kg,
                          diameter_m=diameter_m, drop_height_m=drop_height_m, impact_speed=impact_speed,
                          g_m_per_s2=g_m_per_s2, from_json=from_json, integrator=integrator,
                          max_penetration_m=max_penetration_m, n_bounces=asked)
        check_steps(pre, n_phases, eng.name, eng.max_steps)
        ex = export(ball, eng.name, tolerance=export_tolerance, stiffness=stiffness, **options)
        loaded = parse_exported(eng.name, ex.text)        # what a user loads: the file's text
        setup = ex.setup
    if asked is None:
        n_bounces = setup.n_bounces                    # 3, or as many as --impact-speed LO:HI needs
    setup = replace(setup, n_bounces=n_bounces, tolerance=tolerance)
    from vrcal.engines.export import _check_bounces_reachable

    _check_bounces_reachable(setup)
    check_steps(setup, n_phases, eng.name, eng.max_steps)
    runs = load(eng.name).drop_test(loaded, setup, n_bounces, n_phases)
    return VerifyResult(
        engine=eng.name, engine_version=version, ball=setup.ball, target=setup.epsilon, dt_s=setup.dt_s,
        tolerance=tolerance, runs=runs, max_penetration_m=setup.penetration_limit_m,
        settings=_settings(eng.name, loaded, setup), notes=setup.notes, g_m_per_s2=setup.g_m_per_s2,
    )


def _load_file(engine, text, ball, options):
    """(what the engine loads, DropSetup) of an exported file's text."""
    from vrcal.engines.export import build_setup
    from vrcal.engines.files import read_mjcf

    given = ball is not None or options["from_json"] is not None or (
        options["mass_kg"] is not None and options["diameter_m"] is not None)
    if engine == "mujoco":
        info = read_mjcf(text)
        dt, integrator, target = info["timestep"], info["integrator"], info["target"]
        radius, mass, name = info["radius_m"], info["mass_kg"], info["ball"]
        loaded = text
    else:
        loaded = parse_exported(engine, text)
        dt = loaded["world"]["dt"] if engine == "ode" else loaded["setPhysicsEngineParameter"]["fixedTimeStep"]
        integrator = None
        target = dict(loaded.get("target") or {})
        target["epsilon"] = loaded["target_epsilon"]
        target.setdefault("drop_height_m", loaded["ball"]["drop_height_m"])
        radius, mass, name = loaded["ball"]["radius_m"], loaded["ball"]["mass_kg"], str(loaded["ball"].get("name"))
    if given:
        opts = dict(options, dt_s=dt)
        if engine == "mujoco":
            opts["integrator"] = integrator
        setup = build_setup(ball, engine, **opts)
        return loaded, setup
    if "epsilon" not in target and options["epsilon"] is None:
        raise UsageError("the file carries no vrcal target: give BALL (or --mass and --diameter) and --epsilon")
    if mass is None:
        raise DataError("the MJCF ball geom has no mass: give BALL (or --mass and --diameter)")
    from vrcal.engines.common import check_epsilon
    from vrcal.model.restitution import STANDARD_GRAVITY_M_PER_S2

    eps = check_epsilon(options["epsilon"] if options["epsilon"] is not None else target["epsilon"], "epsilon")
    H = target.get("drop_height_m")
    if H is None or not H > 0:
        raise DataError("the file carries no drop height: give BALL or --drop-height")
    n_b = target.get("n_bounces", N_BOUNCES)
    setup = DropSetup(
        ball=name, mass_kg=float(mass), radius_m=float(radius), drop_height_m=float(H), epsilon=eps,
        dt_s=float(dt), g_m_per_s2=float(target.get("g_m_per_s2", STANDARD_GRAVITY_M_PER_S2)), ball_epsilon=eps,
        notes=(f"target epsilon {eps:.4f} from the file",), n_bounces=max(int(n_b), 1),
        drag_coefficient=float(target.get("drag_coefficient", 0.0)),
        restitution_exponent=float(target.get("restitution_exponent", 0.0)),
        max_penetration_m=options["max_penetration_m"] or target.get("max_penetration_m"),
        integrator=integrator, release_time_s=float(target.get("release_time_s", 0.0)),
        height_offset_m=float(target.get("height_offset_m", 0.0)),
    )
    if not (0 <= setup.drag_coefficient <= 3 and -1 <= setup.restitution_exponent <= 2 and setup.g_m_per_s2 > 0):
        raise DataError("the file's vrcal_* numbers are out of range (drag_coefficient, restitution_exponent, g)")
    return loaded, setup


def _settings(engine, loaded, setup):
    """What the engine was given, for people: a short ``{name: text}``."""
    if engine == "mujoco":
        import re

        from vrcal.engines.mujoco import integrator_name, read_solref

        m = re.search(r'<pair geom1="ball" geom2="floor"[^>]*margin="([^"]+)"', loaded)
        solref = " ".join(f"{float(x):.5g}" for x in read_solref(loaded).split()) if read_solref(loaded) != "?" \
            else "?"
        margin = f"{1e3 * float(m.group(1)):.3g} mm" if m else "0"
        return {"integrator": integrator_name(setup), "solref": solref, "margin": margin}
    if engine == "ode":
        c = loaded["contact"]
        return {"mode": "|".join(c["mode"]), "bounce": f"{c['bounce']:.6g}", "bounce_vel": c["bounce_vel"],
                "erp": loaded["world"]["erp"], "cfm": loaded["world"]["cfm"]}
    return {"restitution ball": f"{loaded['changeDynamics']['ball']['restitution']:.6g}",
            "floor": f"{loaded['changeDynamics']['floor']['restitution']:.6g}"}


def _range(values, digits=4):
    lo, hi = float(np.min(values)), float(np.max(values))
    return f"{lo:.{digits}f}" if abs(hi - lo) < 0.5 * 10 ** -digits else f"{lo:.{digits}f}..{hi:.{digits}f}"


def format_report(result):
    """A short aligned report of a :class:`VerifyResult` for people (<= 100 columns)."""
    from vrcal.textout import table

    r, runs = result, result.runs
    settings = ", ".join([*(f"{k} {v}" for k, v in r.settings.items()), f"g {r.g_m_per_s2:g} m/s^2"])
    lines = [f"{r.engine} {r.engine_version}: {r.ball}, dt {r.dt_s:g} s, {runs.apex_ratios.shape[0]} contact "
             f"phase(s) x {runs.apex_ratios.shape[1]} bounce(s)"]
    import textwrap

    for line in [settings, *r.notes]:
        lines += textwrap.wrap(line, 100, initial_indent="  ", subsequent_indent="    ")
    rows = []
    for k in range(runs.apex_ratios.shape[1]):
        err = max(float(np.max(np.abs(runs.apex_ratios[:, k] - runs.target_apex_ratios[:, k]))),
                  float(np.max(np.abs(runs.velocity_ratios[:, k] - runs.target_epsilons[:, k]))))
        rows.append([str(k + 1), _range(runs.target_epsilons[:, k]), _range(runs.velocity_ratios[:, k]),
                     _range(runs.target_apex_ratios[:, k]), _range(runs.apex_ratios[:, k]), f"{err:.4f}"])
    text = "\n".join(lines) + "\n" + table(rows, ["bounce", "eps target", "v_out/v_in", "apex ratio target",
                                                  "apex ratio", "worst error"])
    verdict = "PASSED" if r.passed else "FAILED"
    text += (f"worst error {r.error:.4f} (tolerance {r.tolerance:g}), median {r.median_error:.4f}\n"
             f"penetration {r.penetration_m * 1e3:.3g} mm, hover {r.hover_m * 1e3:.3g} mm "
             f"(limit {r.max_penetration_m * 1e3:.3g} mm)\n"
             f"{verdict}\n")
    return text
