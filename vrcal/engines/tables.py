"""PhysX, Unity and Box2D: the value to type in and the combine mode to choose. Export only.

No runtime of these engines is used; the numbers follow each engine's documented mixing rule:

* PhysX (``PxMaterial``) and Unity (``PhysicMaterial`` / ``PhysicsMaterial``): combine modes
  Average (default), Minimum, Multiply, Maximum; when the two materials differ the mode of
  higher priority wins (Average < Minimum < Multiply < Maximum). Bounce threshold 2 m/s
  (PhysX ``bounceThresholdVelocity``, Unity ``Physics.bounceThreshold``).
* Box2D: ``b2MixRestitution`` = max of the two fixtures; restitution threshold 1 m/s.
"""

from __future__ import annotations


def table(setup, pair=None):
    """Rows (engine, body, restitution, combine mode, threshold, how) as a list of dicts; the scene's
    gravity is ``setup.g_m_per_s2`` [m/s^2] (the restitution itself does not depend on it)."""
    e_ball = setup.ball_epsilon if setup.ball_epsilon is not None else setup.epsilon
    rows = [
        {"engine": "PhysX", "body": setup.ball, "restitution": e_ball, "combine": "Multiply",
         "threshold_m_per_s": 0.01,
         "how": "PxMaterial::setRestitution; setRestitutionCombineMode(PxCombineMode::eMULTIPLY); "
                "PxSceneDesc::bounceThresholdVelocity (default 2 m/s) below your slowest impact"},
        {"engine": "PhysX", "body": "floor", "restitution": setup.floor_epsilon, "combine": "Multiply",
         "threshold_m_per_s": 0.01, "how": "floor material: restitution 1, eMULTIPLY"},
        {"engine": "Unity", "body": setup.ball, "restitution": e_ball, "combine": "Multiply",
         "threshold_m_per_s": 0.01,
         "how": "PhysicMaterial.bounciness; bounceCombine = PhysicMaterialCombine.Multiply; "
                "Physics.bounceThreshold (default 2 m/s) below your slowest impact"},
        {"engine": "Unity", "body": "floor", "restitution": setup.floor_epsilon, "combine": "Multiply",
         "threshold_m_per_s": 0.01, "how": "floor material: bounciness 1, Multiply"},
        {"engine": "Box2D", "body": setup.ball, "restitution": setup.epsilon, "combine": "max (built in)",
         "threshold_m_per_s": 0.01,
         "how": "b2FixtureDef.restitution (v2.4) / b2ShapeDef restitution (v3); floor restitution 0 so "
                "max() gives the ball's value; b2_velocityThreshold / restitutionThreshold (1 m/s) lowered"},
        {"engine": "Box2D", "body": "floor", "restitution": 0.0, "combine": "max (built in)",
         "threshold_m_per_s": 0.01, "how": "floor restitution 0 (max rule)"},
    ]
    if pair:
        rows.append({
            "engine": "Box2D", "body": pair["name"], "restitution": pair["epsilon"], "combine": "custom",
            "threshold_m_per_s": 0.01,
            "how": "max() cannot multiply: replace b2MixRestitution (v2.4, b2_contact.h) or set "
                   "b2WorldDef.restitutionCallback (v3) to return a*b",
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
    head = (f"{setup.ball}: target epsilon {setup.epsilon:.4f} on a rigid floor; Eq. 6: a pair's epsilon is the "
            "product\nof the bodies' (same K), so Multiply carries the calibration. No runtime was run.\n"
            f"Set the scene's gravity to (0, -{setup.g_m_per_s2:g}, 0) m/s^2 (Box2D: (0, -{setup.g_m_per_s2:g})).\n")
    cells = [[r["engine"], r["body"], f"{r['restitution']:.4f}", r["combine"], f"{r['threshold_m_per_s']:g}"]
             for r in rows]
    body = text_table(cells, ["engine", "body", "restitution", "combine", "threshold m/s"])
    if setup.drag_coefficient or setup.restitution_exponent:
        head += ("these engines get no air drag and one restitution per material: add the drag force yourself, or\n"
                 "use the discover baseline's effective epsilon (vrcal export --epsilon EPS_BASELINE)\n")
    how = ["how:"]
    for r in rows:
        if r["body"] == setup.ball or r["combine"] == "custom":
            label = f"  {r['engine']:<6} " + ("pair  " if r["combine"] == "custom" else "")
            how += textwrap.wrap(r["how"], 100, initial_indent=label, subsequent_indent=" " * 9)
    return head + body + "\n".join(how) + "\n"
