"""Verify an export in the real engine: the drop test, several bounces and contact phases.

:func:`verify` exports (or reads an exported file, :mod:`vrcal.engines.files`), loads it into
the engine, drops the ball ``n_phases`` times with the impact moved across one time step, and
measures ``n_bounces`` bounces against vrcal's own model of the same drop
(:mod:`vrcal.engines.common`). :func:`format_report` is the short text for people.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from vrcal.engines import get_engine, load, require_runtime, runtime
from vrcal.engines.bullet import PYBULLET_CONTACT_SLOP_M
from vrcal.engines.common import (
    CONFIRM_PHASES,
    DEFAULT_TOLERANCE,
    N_BOUNCES,
    DropSetup,
    VerifyResult,
    check_counts,
    check_max_penetration,
    check_positive,
    check_steps,
)
from vrcal.engines.export import check_drop_height, export, parse_exported
from vrcal.errors import DataError, UsageError

#: Contact phases of ``vrcal verify`` unless ``--phases``: as many as an export confirms a step with.
DEFAULT_PHASES = CONFIRM_PHASES

#: The refusal of ``vrcal verify --engine gazebo`` without a world to run.
GAZEBO_NEEDS_FILE = ("--engine gazebo runs an SDF world (its surfaces combined as Gazebo classic does, in libode): "
                     "give --file WORLD.sdf, e.g. vrcal export BALL --engine gazebo -o world.sdf && vrcal verify "
                     "--engine gazebo --file world.sdf")


def verify(ball=None, engine="mujoco", *, epsilon=None, dt_s=None, floor=None, standards=None,
           tolerance=None, n_bounces=None, n_phases=DEFAULT_PHASES, exported_text=None,
           mass_kg=None, diameter_m=None, drop_height_m=None, impact_speed=None, g_m_per_s2=None,
           from_json=None, integrator=None, max_penetration_m=None, stiffness=None, K_per_s=None, file_name=None,
           ball_geom=None, floor_geom=None, substeps=None):
    """Run the drop test of a body in ``engine`` with the exported settings.

    Parameters
    ----------
    ball, epsilon, dt_s, floor, standards, mass_kg, diameter_m, drop_height_m, impact_speed,
    g_m_per_s2, from_json, integrator, max_penetration_m, stiffness, K_per_s
        as for :func:`vrcal.engines.export.export`
    engine : str
        mujoco, ode or bullet (pybullet)
    tolerance : float or None
        largest accepted |achieved - target| (None: the file's ``vrcal_tolerance`` with
        ``exported_text``, else 0.01)
    n_bounces, n_phases : int
        bounces per drop (1 ... 50; default 3, or as many as ``impact_speed`` needs) and contact
        phases across one step (1 ... 64)
    exported_text : str, optional
        a file written by ``vrcal export`` to load instead of a fresh export: its ball, contact,
        step, gravity and target are used; ``dt_s``, ``g_m_per_s2`` and ``drop_height_m`` run it at
        another step, gravity or height, ``epsilon`` judges it against another target; the body,
        integrator, stiffness, floor and impact speed are fixed by the file (UsageError)
    file_name : str, optional
        where ``exported_text`` was read from, named in the errors of a file that is no export
    ball_geom, floor_geom : str, optional
        MuJoCo, with ``exported_text``: the names of the ball's sphere geom and the floor's geom in
        a model of the user's (``--ball-geom``, ``--floor-geom``); default: 'ball' and 'floor', or the
        geoms of the model's one ``<pair>`` (:func:`vrcal.engines.mujoco.scene_of`)
    substeps : int, optional
        PyBullet's ``numSubSteps`` (``--substeps``): a fresh export's (see
        :func:`vrcal.engines.export.build_setup`), or, with ``exported_text``, instead of the file's

    Returns
    -------
    VerifyResult
    """
    eng = get_engine(engine)
    geoms = _check_geom_options(eng.name, exported_text, ball_geom, floor_geom)
    if eng.name == "gazebo":                     # an SDF world runs in libode with Gazebo's contact
        if exported_text is None:
            raise UsageError(GAZEBO_NEEDS_FILE)
        require_runtime(runtime(eng.name).name)
        version = load(eng.name).version()
    else:
        version = require_runtime(eng.name)
    run_in = runtime(eng.name)
    asked = n_bounces
    n_bounces, n_phases = check_counts(N_BOUNCES if asked is None else asked, n_phases)
    if tolerance is not None:
        tolerance = check_positive(tolerance, "--tolerance")
    options = dict(epsilon=epsilon, dt_s=dt_s, floor=floor, standards=standards, mass_kg=mass_kg,
                   diameter_m=diameter_m, drop_height_m=drop_height_m, impact_speed=impact_speed,
                   g_m_per_s2=g_m_per_s2, from_json=from_json, integrator=integrator,
                   max_penetration_m=max_penetration_m, K_per_s=K_per_s)
    if exported_text is not None:
        from vrcal.engines.export import check_substeps

        check_substeps(substeps, eng.name)
        try:
            loaded, runnable, setup = _load_file(eng.name, exported_text, ball,
                                                 dict(options, stiffness=stiffness, tolerance=tolerance,
                                                      substeps=substeps), geoms)
        except DataError as exc:   # a file that is no export of this engine: say which file
            if file_name is None or str(exc).startswith(str(file_name)):
                raise
            raise DataError(f"{file_name}: {exc}") from None
        tolerance = setup.tolerance
    else:
        from vrcal.engines.export import build_setup

        tolerance = DEFAULT_TOLERANCE if tolerance is None else tolerance
        export_tolerance = max(tolerance, DEFAULT_TOLERANCE)   # a tight tolerance fails the test, not the export
        pre = build_setup(ball, eng.name, epsilon, dt_s, floor, standards, K_per_s, tolerance=export_tolerance,
                          mass_kg=mass_kg,
                          diameter_m=diameter_m, drop_height_m=drop_height_m, impact_speed=impact_speed,
                          g_m_per_s2=g_m_per_s2, from_json=from_json, integrator=integrator,
                          max_penetration_m=max_penetration_m, n_bounces=asked, substeps=substeps)
        check_steps(pre, n_phases, run_in.label, run_in.max_steps)
        ex = export(ball, eng.name, tolerance=export_tolerance, stiffness=stiffness, n_bounces=asked,
                    substeps=substeps, **options)
        loaded = runnable = parse_exported(eng.name, ex.text)        # what a user loads: the file's text
        setup = ex.setup
    if asked is None:
        n_bounces = setup.n_bounces                    # 3, or as many as --impact-speed LO:HI needs
    setup = replace(setup, n_bounces=n_bounces, tolerance=tolerance)
    from vrcal.engines.export import _check_bounces_reachable

    _check_bounces_reachable(setup)
    check_steps(setup, n_phases, run_in.label, run_in.max_steps)
    try:
        runs = load(eng.name).drop_test(runnable, setup, n_bounces, n_phases)
    except DataError as exc:
        other_step = next((n for n in setup.notes if n.startswith("run at --dt")), None)
        if other_step is None:
            raise
        raise DataError(f"{exc}; {other_step}: export again with --dt {setup.dt_s:g}") from None
    others, unverified, pair = ((), (), None) if exported_text is None else \
        _other_contacts(eng.name, exported_text, loaded, runnable, setup, n_bounces, n_phases, geoms)
    return VerifyResult(
        engine=eng.name, engine_version=version, ball=setup.ball, target=setup.epsilon, dt_s=setup.dt_s,
        tolerance=tolerance, runs=runs, max_penetration_m=setup.penetration_limit_m,
        **_settings(eng.name, loaded, runnable, setup), notes=setup.notes, g_m_per_s2=setup.g_m_per_s2,
        impact_speeds_m_per_s=tuple(float(v) for v in setup.impact_speeds_m_per_s[:n_bounces]),
        holds_down_to_m_per_s=_holds_down_to(eng.name, loaded), drop_height_m=setup.drop_height_m,
        others=others, unverified=unverified, pair=pair, apex_goal=setup.apex_goal, apex_floor_m=setup.apex_floor_m,
        from_record=bool(setup.drag_coefficient or setup.restitution_exponent or setup.apex_goal is not None),
    )


def _other_contacts(engine, text, loaded, runnable, setup, n_bounces, n_phases, geoms):
    """(drop tests of the file's other balls on the floor, the contacts not tested, the pair test) of a file.

    An ``--against`` export writes three contacts: ball/floor, ball2/floor and the pair ball/ball2.
    Its second ball (MuJoCo: the model's 'ball2' and ``vrcal_ball2_epsilon``; ODE and PyBullet: the
    file's ``ball2`` body and its contact) is dropped on the floor like the ball (a
    :class:`VerifyResult`), and the two balls meet head-on in the engine (:func:`_pair_test`, a
    :class:`vrcal.engines.common.PairResult` judged against the file's Eq. 6 epsilon). A file of an older
    vrcal without ball2's target or body, and Gazebo's world, name those contacts as not verified.
    """
    if engine == "mujoco":
        from vrcal.engines.files import read_mjcf
        from vrcal.engines.mujoco import ball_of, geom_names, scene_of

        info = read_mjcf(text)
        if geoms.get("ball_geom") is not None or "ball2" not in geom_names(runnable.model):
            return (), (), None
        target = info["target"]
        name2 = info["texts"].get("ball2", "ball2")
        pair = f"{setup.ball}/{name2}"
        if "ball2_epsilon" not in target:
            return (), (f"{name2}/floor and {pair}: the file carries no target for them (an export of an older "
                        "vrcal): export again",), None
        scene2 = scene_of(runnable.model, ball_geom="ball2", floor_geom=runnable.floor_geom)
        radius2, mass2 = ball_of(scene2)
        eps2 = float(target["ball2_epsilon"])
        other = _second_drop(engine, scene2, setup, name2, mass2, radius2, eps2, eps2, n_bounces, n_phases)
        if "pair_epsilon" not in target:
            return (other,), (f"{pair}: the file carries no target for it (an export of an older vrcal): "
                              "export again",), None
        return (other,), (), _pair_test(engine, runnable, setup, name2, mass2, radius2, target["pair_epsilon"],
                                        n_phases)
    if engine == "gazebo":
        if 'name="ball2"' not in text:
            return (), (), None
        return (), ("ball2/floor and ball/ball2 (the world's second ball): this drop test runs the ball only",), None
    pair, pairs = loaded.get("pair"), loaded.get("pairs") or {}
    if not isinstance(pair, dict) or "ball2" not in pair:
        return (), (), None
    b2 = str(pair["ball2"])[:80]
    floor2 = pairs.get(f"{b2}/floor", math.nan)
    body2 = loaded.get("ball2")
    if not isinstance(body2, dict) or "mass_kg" not in body2 or "radius_m" not in body2 or \
            (engine == "ode" and not isinstance(loaded.get("contact_pair"), dict)):
        return (), (f"{b2}/floor (epsilon {floor2:.4f}) and {pair.get('name', 'the pair')} (epsilon "
                    f"{pair.get('epsilon', math.nan):.4f}, Eq. 6): the file carries no second body (ball2's mass "
                    f"and radius{' and contact_pair' if engine == 'ode' else ''}; an export of an older vrcal): "
                    "export again",), None
    mass2, radius2 = float(body2["mass_kg"]), float(body2["radius_m"])
    eps2_floor = _file_epsilon(floor2, f"the file's pairs.{b2}/floor")
    eps2 = _file_epsilon(pair.get("epsilon_ball2", eps2_floor), "the file's pair.epsilon_ball2")
    params2 = {k: v for k, v in runnable.items() if k not in ("drag", "restitution_law")}   # the ball's own
    params2["ball"] = dict(runnable["ball"], name=b2, mass_kg=mass2, radius_m=radius2)
    if engine == "ode":
        params2["contact"] = dict(runnable["contact"], bounce=eps2_floor)      # the snippet's ball2 bounce
    else:
        params2["changeDynamics"] = dict(runnable["changeDynamics"], ball=runnable["changeDynamics"]["ball2"])
    other = _second_drop(engine, params2, setup, b2, mass2, radius2, eps2_floor, eps2, n_bounces, n_phases)
    target = _file_epsilon(pair.get("epsilon"), "the file's pair.epsilon")
    return (other,), (), _pair_test(engine, runnable, setup, b2, mass2, radius2, target, n_phases)


def _file_epsilon(value, what):
    """An epsilon a file carries, as a float in (0, 1]; DataError (one line) naming ``what`` otherwise."""
    from vrcal.engines.common import check_epsilon

    try:
        return check_epsilon(value, what)
    except UsageError as exc:
        raise DataError(f"{exc}: export again") from None


def _second_drop(engine, runnable2, setup, name2, mass2, radius2, eps2, eps2_rigid, n_bounces, n_phases):
    """The drop test of an ``--against`` file's second ball on the floor: a :class:`VerifyResult`."""
    from vrcal.engines.export import second_setup

    setup2 = second_setup(setup, name2, mass2, radius2, eps2, eps2_rigid)
    check_steps(setup2, n_phases, runtime(engine).label, runtime(engine).max_steps)
    try:
        runs2 = load(engine).drop_test(runnable2, setup2, n_bounces, n_phases)
    except DataError as exc:
        raise DataError(f"ball2 ({name2}) on the floor: {exc}") from None
    return VerifyResult(engine=engine, engine_version="", ball=f"ball2 ({name2})", target=eps2, dt_s=setup.dt_s,
                        tolerance=setup.tolerance, runs=runs2, max_penetration_m=setup2.penetration_limit_m,
                        g_m_per_s2=setup.g_m_per_s2, drop_height_m=setup.drop_height_m,
                        impact_speeds_m_per_s=tuple(float(v) for v in setup2.impact_speeds_m_per_s[:n_bounces]))


def _pair_test(engine, runnable, setup, name2, mass2, radius2, target, n_phases):
    """The two balls of an ``--against`` file meeting head-on in the engine at the ball's first impact
    speed, over ``n_phases`` contact phases: a :class:`vrcal.engines.common.PairResult`."""
    from vrcal.engines.common import pair_setup

    pair = pair_setup(setup, name2, mass2, radius2, _file_epsilon(target, "the file's pair epsilon"))
    return load(engine).pair_test(runnable, pair, n_phases)


def _holds_down_to(engine, loaded):
    """The slowest impact [m/s] an exported file's contact was measured to hold epsilon at (its
    ``holds_down_to_m_per_s`` target number, :class:`vrcal.engines.export.SpeedCoverage`); None for
    a file without it (a user's model, an older export, a speed-dependent epsilon)."""
    if engine == "mujoco":
        from vrcal.engines.files import read_mjcf

        value = read_mjcf(loaded)["target"].get("holds_down_to_m_per_s")
    else:
        value = (loaded.get("target") or {}).get("holds_down_to_m_per_s")
    return float(value) if isinstance(value, (int, float)) and value > 0 else None


#: Options whose value an exported file fixes (option key, as typed): verify --file refuses them.
FIXED_BY_FILE = (("ball", "BALL"), ("mass_kg", "--mass"), ("diameter_m", "--diameter"), ("from_json", "--from"),
                 ("integrator", "--integrator"), ("stiffness", "--stiffness"), ("floor", "--floor"),
                 ("impact_speed", "--impact-speed"), ("K_per_s", "--K"))

#: What applies with --file (named in the refusal).
APPLY_TO_FILE = ("--dt, --g, --drop-height, --epsilon, --tolerance, --max-penetration, --bounces and --phases "
                 "(and PyBullet's --substeps)")


def _check_geom_options(engine, exported_text, ball_geom, floor_geom):
    """``{"ball_geom": .., "floor_geom": ..}`` of ``--ball-geom``/``--floor-geom``; a one-line UsageError
    where they do not apply (they name geoms of an MJCF ``--file``)."""
    given = [flag for flag, value in (("--ball-geom", ball_geom), ("--floor-geom", floor_geom)) if value is not None]
    if given and (engine != "mujoco" or exported_text is None):
        raise UsageError(f"{' and '.join(given)} name{'s a geom' if len(given) == 1 else ' geoms'} of a MuJoCo model: "
                         "give --engine mujoco and --file MODEL.xml")
    return {"ball_geom": ball_geom, "floor_geom": floor_geom}


def _refuse_fixed(options, keys):
    """One-line UsageError naming every option of ``keys`` given with ``--file``, and what applies."""
    given = [flag for key, flag in FIXED_BY_FILE if key in keys and options.get(key) is not None]
    if given:
        names = given[0] if len(given) == 1 else ", ".join(given[:-1]) + " and " + given[-1]
        raise UsageError(f"{names} {'is' if len(given) == 1 else 'are'} fixed by the exported file: with --file only "
                         f"{APPLY_TO_FILE} apply (export again for another body or contact)")


def _load_file(engine, text, ball, options, geoms=None):
    """(the file as read, what the engine runs, DropSetup) of an exported file's text.

    The file fixes the body, the contact and the integrator (the options that would change them
    are refused in one line, :func:`_refuse_fixed`); ``--dt`` and ``--g`` run the file's model at
    another step or gravity (what a user does who pastes it into a model with another step),
    ``--drop-height`` drops it from another height, ``--epsilon`` judges it against another
    target, and the notes say so. ``geoms`` (MuJoCo) names the ball's and the floor's geoms of a
    user's model (:func:`vrcal.engines.mujoco.scene_of`); a model without vrcal's numbers takes its
    body from the ball geom unless BALL, ``--mass``/``--diameter`` or ``--from`` give one.
    """
    from vrcal.engines.common import check_dt, check_epsilon
    from vrcal.engines.files import read_mjcf

    options = dict(options, ball=ball)
    _refuse_other_engine(engine, text)
    if engine == "mujoco":
        info = read_mjcf(text)
        file_dt, integrator, target = info["timestep"], info["integrator"], info["target"]
        name = info["ball"]
        loaded = text
    elif engine == "gazebo":
        from vrcal.engines.files import read_sdf
        from vrcal.engines.gazebo import ode_params

        sdf = read_sdf(text)
        loaded = ode_params(sdf["world"], sdf["ball"], sdf["floor"], sdf["floor_has_body"])
        target = {k: v for k, v in sdf["target"].items() if k != "ball"}
        loaded["target"] = target
        file_dt, integrator = loaded["world"]["dt"], None
        target.setdefault("drop_height_m", loaded["ball"]["drop_height_m"])
        radius, mass = loaded["ball"]["radius_m"], loaded["ball"]["mass_kg"]
        name = str(sdf["target"].get("ball", loaded["ball"]["name"]))[:80]
    else:
        loaded = parse_exported(engine, text)
        file_dt = loaded["world"]["dt"] if engine == "ode" else loaded["setPhysicsEngineParameter"]["fixedTimeStep"]
        integrator = None
        target = dict(loaded.get("target") or {})
        target["epsilon"] = loaded["target_epsilon"]
        target.setdefault("drop_height_m", loaded["ball"]["drop_height_m"])
        radius, mass, name = loaded["ball"]["radius_m"], loaded["ball"]["mass_kg"], str(loaded["ball"].get("name"))
    vrcal_file = "epsilon" in target
    _refuse_fixed(options, [k for k, _ in FIXED_BY_FILE] if vrcal_file else ("integrator", "stiffness"))
    file_dt = check_dt(file_dt, "the file's time step")
    dt = file_dt if options["dt_s"] is None else check_dt(options["dt_s"])
    file_sub = sub = 0
    if engine == "bullet":           # numSubSteps N: the engine steps dt/N; the notes speak of stepSimulation's dt
        from vrcal.engines.bullet import substeps_of

        file_sub = substeps_of(loaded)[0]
        sub = file_sub if options.get("substeps") is None else int(options["substeps"])
    runnable, file_g = _runnable(engine, loaded, geoms)
    if engine == "mujoco":
        from vrcal.engines.mujoco import ball_of

        radius, mass = ball_of(runnable)
    g = file_g if options["g_m_per_s2"] is None else float(options["g_m_per_s2"])
    notes = []
    if dt != file_dt:
        what = "its contact is tuned to that step" if engine == "mujoco" else "it was checked at that step"
        notes.append(f"run at --dt {dt:g} s; the file is for {file_dt:g} s ({what})")
    if sub != file_sub:
        notes.append(f"run with --substeps {sub:d}: a step of {dt / max(sub, 1):g} s; the file's numSubSteps is "
                     f"{file_sub:d} (it was checked at {file_dt / max(file_sub, 1):g} s)")
    if sub:
        runnable["setPhysicsEngineParameter"]["numSubSteps"] = sub
    if g != file_g:
        notes.append(f"run at --g {g:g} m/s^2; the file holds {file_g:g} m/s^2")
    _set_step_and_gravity(engine, runnable, dt, g)
    if not vrcal_file:                             # a model of the user's: the body and target from options
        from vrcal.engines.export import build_setup

        opts = {k: v for k, v in options.items() if k not in ("ball", "stiffness", "tolerance")}
        opts.update(dt_s=dt, g_m_per_s2=g, integrator=integrator if engine == "mujoco" else None,
                    substeps=sub or None)
        if options.get("tolerance") is not None:
            opts["tolerance"] = options["tolerance"]
        if engine in ("mujoco", "gazebo"):
            body_given = ball is not None or any(options.get(k) is not None
                                                 for k in ("mass_kg", "diameter_m", "from_json"))
            if not body_given:
                if options.get("epsilon") is None:
                    raise UsageError("the file is a model of yours (no vrcal_* numbers of an export): give the "
                                     "target --epsilon and --drop-height (or --impact-speed) to drop its ball with")
                opts.update(mass_kg=mass, diameter_m=2.0 * radius)
                if engine == "gazebo":
                    if opts.get("drop_height_m") is None and opts.get("impact_speed") is None:
                        opts["drop_height_m"] = check_drop_height(target["drop_height_m"])
                    notes.insert(0, f"ball: the model '{loaded['ball']['name']}' of the world ({1e3 * mass:.4g} g, "
                                    f"D {2e3 * radius:.4g} mm), dropped from its pose")
                else:
                    notes.insert(0, f"ball: the geom '{runnable.ball_geom}' of the file ({1e3 * mass:.4g} g, D "
                                    f"{2e3 * radius:.4g} mm); floor: '{runnable.floor_geom}'")
        setup = build_setup(ball, engine, **opts)
        if engine == "mujoco":
            _check_ball_size(setup, radius, runnable.ball_geom)
        return loaded, runnable, replace(setup, notes=setup.notes + tuple(notes))
    if options["epsilon"] is not None:
        eps = check_epsilon(options["epsilon"], "--epsilon")
        notes.insert(0, f"target epsilon {eps:.4f} given with --epsilon (the file's: {target['epsilon']:.4f})")
    else:
        eps = check_epsilon(target["epsilon"], "the file's epsilon")
        notes.insert(0, f"target epsilon {eps:.4f} from the file")
    H = target.get("drop_height_m") if options["drop_height_m"] is None else check_drop_height(options["drop_height_m"])
    if H is None or not H > 0:
        raise DataError("the file carries no drop height: give --drop-height")
    if options["drop_height_m"] is not None and H != target.get("drop_height_m"):
        notes.append(f"dropped from --drop-height {H:g} m (the file's: {target.get('drop_height_m', math.nan):g} m)")
    tolerance = options.get("tolerance")
    if tolerance is None:
        tolerance = float(target.get("tolerance", DEFAULT_TOLERANCE))
    setup = DropSetup(
        ball=name, mass_kg=float(mass), radius_m=float(radius), drop_height_m=float(H), epsilon=eps,
        dt_s=dt / max(sub, 1), g_m_per_s2=g, ball_epsilon=eps, substeps=sub,
        notes=tuple(notes), n_bounces=max(int(target.get("n_bounces", N_BOUNCES)), 1),
        drag_coefficient=float(target.get("drag_coefficient", 0.0)),
        restitution_exponent=float(target.get("restitution_exponent", 0.0)),
        max_penetration_m=check_max_penetration(options["max_penetration_m"], float(radius)) or
        check_max_penetration(target.get("max_penetration_m"), float(radius), "the file's max_penetration_m"),
        tolerance=tolerance,
        integrator=integrator, release_time_s=float(target.get("release_time_s", 0.0)),
        height_offset_m=float(target.get("height_offset_m", 0.0)),
        apex_goal=_apex_goal(target.get("apex_goal")),
        apex_floor_m=float(target.get("apex_floor_m") or 0.0) if target.get("apex_goal") is not None else 0.0,
    )
    if not (0 <= setup.drag_coefficient <= 3 and -1 <= setup.restitution_exponent <= 2 and setup.g_m_per_s2 > 0):
        raise DataError("the file's vrcal_* numbers are out of range (drag_coefficient, restitution_exponent, g)")
    return loaded, runnable, setup


def _apex_goal(value):
    """The file's ``apex_goal`` (a fraction in (0, 1)), None when it has none; DataError when it is no such number."""
    if value is None:
        return None
    if not isinstance(value, (int, float)) or isinstance(value, bool) or not 0 < value < 1:
        raise DataError(f"the file's apex_goal must be a fraction between 0 and 1, got {value!r}")
    return float(value)


def _refuse_other_engine(engine, text):
    """DataError (one line) naming the ``--engine`` of a file written for another engine."""
    import json

    head = text.lstrip()
    other = None
    if head.startswith("<") and engine != "mujoco":
        if "<mujoco" in head:
            other = "an MJCF (MuJoCo) file: use --engine mujoco"
        elif engine != "gazebo":
            other = ("an SDF world (Gazebo): use --engine gazebo, which runs it in libode with Gazebo classic's "
                     "contact" if "<sdf" in head else "an XML file, not a vrcal export of this engine")
    elif head.startswith("{") and engine == "gazebo":
        other = "JSON, not an SDF world: --engine gazebo runs a world written by vrcal export --engine gazebo"
    elif head.startswith("{"):
        try:
            name = json.loads(text).get("engine")
        except (ValueError, AttributeError, RecursionError):
            name = None
        if isinstance(name, str) and name in ("ode", "bullet") and name != engine:
            other = f"a vrcal {name} export: use --engine {name}"
    if other:
        raise DataError(f"--engine {engine}: the file is {other}")


def _check_ball_size(setup, radius_m, geom):
    """UsageError (one line) when the body given for a model's ball is another size than its geom
    (vrcal would place and model another ball than MuJoCo drops)."""
    if not math.isclose(setup.radius_m, radius_m, rel_tol=1e-3):
        raise UsageError(f"the model's ball geom '{geom}' has D {2e3 * radius_m:.4g} mm, the body given "
                        f"{2e3 * setup.radius_m:.4g} mm: leave out BALL, --mass and --diameter to take the geom's")


def _runnable(engine, loaded, geoms=None):
    """(what the engine runs, the downward gravity it sets [m/s^2]) of an exported file as read.

    MuJoCo: the compiled model with its ball's and floor's geoms (a
    :class:`vrcal.engines.mujoco.Scene`, compiled once: its gravity is read from it and its step
    and gravity are set on it); ODE, PyBullet: a copy of the JSON.
    """
    if engine == "mujoco":
        from vrcal.engines.mujoco import load_model, scene_of

        model = load_model(loaded)
        return scene_of(model, **(geoms or {})), -float(model.opt.gravity[2])
    import copy

    out = copy.deepcopy(loaded)
    return out, -float(out["world"]["gravity"][2] if engine in ("ode", "gazebo") else out["setGravity"][2])


def _set_step_and_gravity(engine, runnable, dt_s, g_m_per_s2):
    """Set the time step [s] and the downward gravity [m/s^2] of :func:`_runnable`'s model: MuJoCo's
    ``opt.timestep`` and ``opt.gravity``; the JSON's ``world.dt``/``fixedTimeStep`` and gravity."""
    if engine == "mujoco":
        runnable.model.opt.timestep = dt_s
        runnable.model.opt.gravity[:] = (0.0, 0.0, -g_m_per_s2)
    elif engine in ("ode", "gazebo"):
        runnable["world"]["dt"] = dt_s
        runnable["world"]["gravity"] = [0.0, 0.0, -g_m_per_s2]
        if "gazebo" in runnable:                 # Gazebo derives soft_erp and soft_cfm from kp, kd and the step
            from vrcal.engines.gazebo import at_step

            at_step(runnable, dt_s)
    else:
        runnable["setPhysicsEngineParameter"]["fixedTimeStep"] = dt_s
        runnable["setGravity"] = [0.0, 0.0, -g_m_per_s2]


def _settings(engine, loaded, runnable, setup):
    """What the engine was given: ``{"settings": for machines, "settings_text": for people}``.

    ``settings`` holds numbers in SI (the unit in the key, ``margin_m``) at full precision, lists for
    vectors (``solref``), keys without spaces; ``settings_text`` the short ``{name: text}`` the report prints.
    """
    if engine == "mujoco":
        from vrcal.engines.mujoco import as_scene, contact_values, integrator_name

        values = {"integrator": integrator_name(setup), **contact_values(as_scene(runnable))}
        text = {"integrator": values["integrator"]}
        if "solref" in values:
            text.update({"solref": " ".join(f"{x:.5g}" for x in values["solref"]),
                         "margin": f"{1e3 * values['margin_m']:.3g} mm"})
        else:
            text["contact"] = values["contact"]
        return {"settings": values, "settings_text": text}
    if engine == "gazebo":
        c, gz, w = runnable["contact"], runnable["gazebo"], runnable["world"]
        values = {"bounce": float(c["bounce"]), "bounce_vel_m_per_s": float(c["bounce_vel"]),
                  "kp_n_per_m": float(gz["kp"]), "kd_n_s_per_m": float(gz["kd"]), "soft_erp": float(c["soft_erp"]),
                  "soft_cfm": float(c["soft_cfm"]),
                  "contact_max_correcting_vel_m_per_s": float(w["contact_max_correcting_vel"]), "solver": w["step"]}
        text = {"bounce min(ball, floor)": f"{c['bounce']:.6g}", "bounce_vel": f"{c['bounce_vel']:g}",
                "kp": f"{gz['kp']:.3g}", "kd": f"{gz['kd']:g}", "soft_erp": f"{c['soft_erp']:.6g}",
                "soft_cfm": f"{c['soft_cfm']:.3g}", "max_vel": f"{w['contact_max_correcting_vel']:g}",
                "solver": w["step"]}
        return {"settings": values, "settings_text": text}
    if engine == "ode":
        c, w = loaded["contact"], loaded["world"]
        values = {"mode": list(c["mode"]), "bounce": float(c["bounce"]), "bounce_vel_m_per_s": float(c["bounce_vel"])}
        values.update({k: float(c[k]) for k in ("soft_erp", "soft_cfm") if k in c})
        values.update({f"world_{k}": float(w[k]) for k in ("erp", "cfm") if k in w})
        text = {"mode": "|".join(c["mode"]), "bounce": f"{c['bounce']:.6g}", "bounce_vel": c["bounce_vel"]}
        text.update({k: f"{c[k]:g}" for k in ("soft_erp", "soft_cfm") if k in c})
        text.update({f"world {k}": f"{w[k]:g}" for k in ("erp", "cfm") if k in w})
        return {"settings": values, "settings_text": text}
    dyn = loaded["changeDynamics"]
    slop = loaded["setPhysicsEngineParameter"].get("contactSlop")
    values = {"restitution_ball": float(dyn["ball"]["restitution"]),
              "restitution_floor": float(dyn["floor"]["restitution"]),
              "contact_slop_m": float(PYBULLET_CONTACT_SLOP_M if slop is None else slop),
              "contact_slop_is_default": slop is None}
    text = {"restitution ball": f"{dyn['ball']['restitution']:.6g}", "floor": f"{dyn['floor']['restitution']:.6g}",
            "contactSlop": f"{PYBULLET_CONTACT_SLOP_M:g} (PyBullet's default)" if slop is None else f"{slop:g}"}
    return {"settings": values, "settings_text": text}


def _range(values, digits=4):
    lo, hi = float(np.min(values)), float(np.max(values))
    return f"{lo:.{digits}f}" if abs(hi - lo) < 0.5 * 10 ** -digits else f"{lo:.{digits}f}..{hi:.{digits}f}"


def format_report(result):
    """A short aligned report of a :class:`VerifyResult` for people (<= 100 columns)."""
    from vrcal.engines.common import error_text
    from vrcal.textout import table

    r, runs = result, result.runs
    settings = ", ".join([*(f"{k} {v}" for k, v in r.settings_text.items()), f"g {r.g_m_per_s2:g} m/s^2"])
    lines = [f"{r.engine} {r.engine_version}: {r.ball}, dt {r.dt_s:g} s, {runs.apex_ratios.shape[0]} contact "
             f"phase(s) x {runs.apex_ratios.shape[1]} bounce(s)"]
    import textwrap

    for line in [settings, *r.notes]:
        lines += textwrap.wrap(line, 100, initial_indent="  ", subsequent_indent="    ")
    rows = []
    for k, err in enumerate(runs.bounce_errors):
        rows.append([str(k + 1), _range(runs.target_epsilons[:, k]), _range(runs.velocity_ratios[:, k]),
                     _range(runs.target_apex_ratios[:, k]), _range(runs.apex_ratios[:, k]), f"{err:.4f}"])
    text = "\n".join(lines) + "\n" + table(rows, ["bounce", "eps target", "v_out/v_in", "apex ratio target",
                                                  "apex ratio", "worst error"])
    verdict = "PASSED" if r.passed else "FAILED"
    text += (f"worst error {error_text(r.error)} (tolerance {r.tolerance:g}), median {error_text(r.median_error)}\n"
             f"penetration {r.penetration_m * 1e3:.3g} mm, hover {r.hover_m * 1e3:.3g} mm "
             f"(limit {r.max_penetration_m * 1e3:.3g} mm)\n")
    if runs.height_ratio_text():
        text += runs.height_ratio_text() + " (the epsilon error is absolute)\n"
    if r.apex_goal is not None:
        text += (runs.apex_text(r.apex_goal, r.apex_floor_m)
                 + " (judged: each bounce's error compounds in the heights)\n")
    elif r.from_record:
        text += "\n".join(textwrap.wrap(
            f"{runs.apex_text()}, not judged: the verdict checks each bounce's epsilon (--tolerance), not the heights "
            f"of a record, where each bounce's error compounds; judge those: vrcal verify --from RESULT.json "
            f"--against RECORD --engine {r.engine} --file FILE", 100)) + "\n"
    if runs.gain is not None:
        text += runs.gain_text() + "\n"
    if r.others or r.unverified or r.pair is not None:
        first = f"ball ({r.ball})" if r.engine == "mujoco" else r.ball
        tested = [f"{first}/floor"] + [f"{o.ball}/floor (target {o.target:.4f}: worst error {o.error:.4f}, "
                                        f"penetration {o.penetration_m * 1e3:.3g} mm, hover {o.hover_m * 1e3:.3g} mm"
                                        f"{'' if o.passed else ', FAILED'})" for o in r.others]
        if r.pair is not None:
            tested.append(format_pair(r.pair))
        text += "\n".join(textwrap.wrap("contacts verified: " + "; ".join(tested), 100, subsequent_indent="  ")) + "\n"
        for line in r.unverified:
            text += "\n".join(textwrap.wrap("not verified: " + line, 100, subsequent_indent="  ")) + "\n"
    return text + f"{verdict}\n"


def format_pair(result):
    """The pair test of a :class:`vrcal.engines.common.PairResult` in a few words, for the report."""
    p, eps = result.pair, result.runs.epsilons
    return (f"{p.name} (the two balls head-on at {p.speed_m_per_s:.3g} m/s, gravity off, {eps.size} phase(s); "
            f"Eq. 6 target {p.target:.4f}: v_out/v_in {_range(eps)}, worst error {result.error:.4f}, overlap "
            f"{result.overlap_m * 1e3:.3g} mm{'' if result.passed else ', FAILED'})")
