"""PhysX, Unity and Box2D: the value to type in and the combine mode to choose. Export only.

No runtime of these engines is used; the numbers follow each engine's documented mixing rule:

* PhysX (``PxMaterial``) and Unity (``PhysicMaterial`` / ``PhysicsMaterial``): combine modes
  Average (default), Minimum, Multiply, Maximum; when the two materials differ the mode of
  higher priority wins (Average < Minimum < Multiply < Maximum). Bounce threshold 2 m/s
  (PhysX ``bounceThresholdVelocity``, Unity ``Physics.bounceThreshold``).
* Box2D: ``b2MixRestitution`` = max of the two fixtures; restitution threshold 1 m/s.
"""

from __future__ import annotations

from vrcal.engines.common import constant_engine_notes, constant_epsilon

#: What these engines are called in notes.
ENGINES_NAME = "PhysX, Unity and Box2D"


def table(setup, pair=None):
    """Rows (engine, body, restitution, combine mode, threshold, how) as a list of dicts; the scene's
    gravity is ``setup.g_m_per_s2`` [m/s^2] (the restitution itself does not depend on it).

    A speed-dependent epsilon gets the constant nearest it over the setup's impacts
    (:func:`vrcal.engines.common.constant_epsilon`): these engines take one value per material.
    """
    e_pair = constant_epsilon(setup) if setup.drop_height_m is not None else float(setup.epsilon)
    e_ball = e_pair / setup.floor_epsilon
    e_floor = f"{setup.floor_epsilon:.4f} (Eq. 6: the floor's own factor)" if setup.floor_epsilon != 1 else "1 (rigid)"
    rows = [
        {"engine": "PhysX", "body": setup.ball, "restitution": e_ball, "combine": "Multiply",
         "threshold_m_per_s": 0.01,
         "how": "PxMaterial::setRestitution; setRestitutionCombineMode(PxCombineMode::eMULTIPLY); "
                "PxSceneDesc::bounceThresholdVelocity (default 2 m/s) below your slowest impact"},
        {"engine": "PhysX", "body": "floor", "restitution": setup.floor_epsilon, "combine": "Multiply",
         "threshold_m_per_s": 0.01, "how": f"floor material: restitution {e_floor}, eMULTIPLY"},
        {"engine": "Unity", "body": setup.ball, "restitution": e_ball, "combine": "Multiply",
         "threshold_m_per_s": 0.01,
         "how": "PhysicMaterial.bounciness; bounceCombine = PhysicMaterialCombine.Multiply; "
                "Physics.bounceThreshold (default 2 m/s) below your slowest impact"},
        {"engine": "Unity", "body": "floor", "restitution": setup.floor_epsilon, "combine": "Multiply",
         "threshold_m_per_s": 0.01, "how": f"floor material: bounciness {e_floor}, Multiply"},
        {"engine": "Box2D", "body": setup.ball, "restitution": e_pair, "combine": "max (built in)",
         "threshold_m_per_s": 0.01,
         "how": "b2FixtureDef.restitution (v2.4) / b2ShapeDef restitution (v3); floor restitution 0 so "
                "max() gives the ball's value; b2_velocityThreshold / restitutionThreshold (1 m/s) lowered"},
        {"engine": "Box2D", "body": "floor", "restitution": 0.0, "combine": "max (built in)",
         "threshold_m_per_s": 0.01, "how": "floor restitution 0 (max rule)"},
    ]
    if pair:
        ball2 = pair["ball2"]
        for eng in ("PhysX", "Unity"):
            rows.append({"engine": eng, "body": ball2, "restitution": pair["epsilon_ball2"], "combine": "Multiply",
                         "threshold_m_per_s": 0.01, "how": "the second ball's material: its epsilon against a "
                         "rigid floor, Multiply"})
        rows.append({"engine": "Box2D", "body": ball2, "restitution": pair["pairs"][f"{ball2}/floor"],
                     "combine": "max (built in)", "threshold_m_per_s": 0.01,
                     "how": "the second ball's fixture: its value on this floor (floor restitution 0, max rule)"})
        rows.append({
            "engine": "Box2D", "body": pair["name"], "restitution": pair["epsilon"], "combine": "custom",
            "threshold_m_per_s": 0.01,
            "how": "max() cannot multiply: replace b2MixRestitution (v2.4, b2_contact.h) or set "
                   "b2WorldDef.restitutionCallback (v3) to return a*b" + (
                       "" if setup.floor_epsilon == 1 else
                       f" of the balls' rigid-floor values ({setup.ball_epsilon:.4f} x {pair['epsilon_ball2']:.4f}; "
                       "the fixtures hold each ball's value on this floor)"),
        })
        for eng in ("PhysX", "Unity"):
            rows.append({"engine": eng, "body": pair["name"], "restitution": pair["epsilon"],
                         "combine": "Multiply", "threshold_m_per_s": 0.01,
                         "how": "with every material on Multiply the pair gets the product by itself"})
    return rows


def format_table(setup, pair=None):
    """A short aligned table of :func:`table` for people (<= 100 columns); the how-to lines below it."""
    import textwrap

    from vrcal.textout import table as text_table

    rows = table(setup, pair)
    floor = ("on a rigid floor" if setup.floor_epsilon == 1 else
             f"with its floor ({setup.ball_epsilon:.4f} x floor {setup.floor_epsilon:.4f})")
    head = ("\n".join(textwrap.wrap(f"{setup.ball}: target epsilon {setup.epsilon:.4f} {floor}; Eq. 6: a pair's "
                                    "epsilon is the product of the bodies' (same K), so Multiply carries the "
                                    "calibration. No runtime was run.", 100)) + "\n"
            f"Set the scene's gravity to (0, -{setup.g_m_per_s2:g}, 0) m/s^2 (Box2D: (0, -{setup.g_m_per_s2:g})).\n")
    cells = [[r["engine"], r["body"], f"{r['restitution']:.4f}", r["combine"], f"{r['threshold_m_per_s']:g}"]
             for r in rows]
    body = text_table(cells, ["engine", "body", "restitution", "combine", "threshold m/s"])
    for line in constant_engine_notes(setup, ENGINES_NAME):
        head += "\n".join(textwrap.wrap(line, 100)) + "\n"
    if setup.drop_height_m is not None:
        v = setup.impact_speeds_m_per_s
        head += (f"{len(v)} bounce(s) from {setup.drop_height_m:.4g} m hit at {float(v[0]):.3g}..{float(v[-1]):.3g} "
                 "m/s: keep each bounce threshold below your slowest impact\n")
    how = ["how:"]
    for r in rows:
        if r["body"] == setup.ball or r["combine"] == "custom":
            label = f"  {r['engine']:<6} " + ("pair  " if r["combine"] == "custom" else "")
            how += textwrap.wrap(r["how"], 100, initial_indent=label, subsequent_indent=" " * 9)
    return head + body + "\n".join(how) + "\n"
