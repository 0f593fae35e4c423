"""Side by side: the same scene in vrcal's event-driven simulator and in ODE.

Contacts are matched per pair of bodies in time order (the k-th floor impact of a ball in
one run with the k-th in the other), apexes per body in time order. The report gives the
differences in impact time and apex height and explains where they come from.

Impact times and apex heights miss what happens sideways (friction, rolling, a row of balls
passing momentum on), so every body's state is compared too: its largest distance between the two
runs over the whole run (horizontal included) and its final position and velocity. A body beyond
:func:`state_tolerances` is flagged ("DIFFERENT"); when vrcal resolved touching contacts at one
instant one after another (sequential impulses) the report names that order dependence.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

#: Apexes lower than this [m] are left out of the relative difference (the last tiny bounces).
MIN_APEX_FOR_RELATIVE_M = 0.05

#: A body's state differs between the runs when its position differs by more than
#: max(POSITION_TOLERANCE_M, POSITION_TOLERANCE_PER_STEP_M_PER_S * dt) at some sample time ...
POSITION_TOLERANCE_M = 0.01
POSITION_TOLERANCE_PER_STEP_M_PER_S = 30.0
#: ... or its final velocity by more than max(VELOCITY_TOLERANCE_M_PER_S, VELOCITY_TOLERANCE_PER_STEP_M_PER_S2 * dt).
#: Measured (ODE step 1e-4 s / 1e-3 s) on the example scenes whose physics agree: at most 3 mm / 23 mm
#: and 0.005 / 0.05 m/s; a reordered Newton's cradle differs by 0.6 m and 1 m/s.
VELOCITY_TOLERANCE_M_PER_S = 0.05
VELOCITY_TOLERANCE_PER_STEP_M_PER_S2 = 100.0


def state_tolerances(dt_s):
    """The position [m] and velocity [m/s] differences beyond which a body's runs differ.

    Parameters
    ----------
    dt_s : float
        ODE's time step [s] (nan: the fixed parts alone)

    Returns
    -------
    (float, float)
        ``max(0.01 m, 30 m/s * dt)`` and ``max(0.05 m/s, 100 m/s^2 * dt)``: ODE's time
        discretisation shifts positions by about v dt per bounce and velocities by about g dt.
    """
    dt = dt_s if np.isfinite(dt_s) else 0.0
    return (max(POSITION_TOLERANCE_M, POSITION_TOLERANCE_PER_STEP_M_PER_S * dt),
            max(VELOCITY_TOLERANCE_M_PER_S, VELOCITY_TOLERANCE_PER_STEP_M_PER_S2 * dt))


#: Why an ODE run differs from the exact event-driven one (printed with every comparison).
EXPLANATIONS = (
    "time step: ODE sees a contact only at the end of the step in which the spheres already "
    "overlap, so its impact times are late by up to one step (dt) and each rebound starts from a "
    "point up to v*dt lower; vrcal finds each contact time exactly (roots of the flight quadratics).",
    "ODE's bounce: the LCP sets the outgoing normal speed to bounce * incoming speed at the start of "
    "the step; gravity's dt*g during the contact step and the ERP push-out (capped at 0.1 m/s) change "
    "the rebound speed by O(g dt) -- apex heights differ by O(dt), impact times accumulate the error.",
    "rest: a floor impact slower than the scene's rest_speed_m_per_s does not bounce in either run (ODE: "
    "bounce_vel on floor contacts; vrcal puts the ball at rest), but ODE's late contact step changes the "
    "speed it compares, so the last, tiny floor bounces can differ in number. Ball-ball contacts "
    "bounce at any speed in both (ODE: bounce_vel 0).",
    "simultaneous contacts (stacks): vrcal applies the impulses one after another (sequential "
    "impulses); ODE's LCP solves all contacts of a step together -- the results agree when the "
    "contacts are separated by more than one step (e.g. a small gap), and can differ when not.",
    "divergence: in multi-body scenes a small difference in an oblique ball-ball contact grows with "
    "every later contact, so compare the first contacts; single balls stay close.",
)


@dataclass
class SceneComparison:
    """Matched impacts and apexes of two runs of one scene."""

    engines: tuple
    impacts: list = field(default_factory=list)   # (pair label, k, t_a, t_b, speed_a, speed_b)
    apexes: list = field(default_factory=list)    # (body, k, t_a, h_a, t_b, h_b)
    unmatched: list = field(default_factory=list)  # text
    dt_s: float = float("nan")
    solver_messages: int = 0                      # messages ODE's solver reported during run b
    # (body, largest |dp| [m], its time [s], final |dp| [m], final v_a [m/s] (3,), final v_b (3,), differs)
    states: list = field(default_factory=list)
    simultaneous: list = field(default_factory=list)  # (t [s], [pair labels]) resolved one after another in a

    @property
    def differing_bodies(self):
        """Names of the bodies whose states differ beyond :func:`state_tolerances`."""
        return [r[0] for r in self.states if r[6]]

    @property
    def max_position_difference_m(self):
        d = [r[1] for r in self.states]
        return max(d) if d else float("nan")

    @property
    def max_impact_time_difference_s(self):
        d = [abs(r[3] - r[2]) for r in self.impacts]
        return max(d) if d else float("nan")

    @property
    def max_apex_difference_m(self):
        d = [abs(r[5] - r[3]) for r in self.apexes]
        return max(d) if d else float("nan")

    @property
    def max_apex_relative_difference(self):
        """Largest |dh|/h over the apexes higher than :data:`MIN_APEX_FOR_RELATIVE_M`."""
        d = [abs(r[5] - r[3]) / abs(r[3]) for r in self.apexes if abs(r[3]) >= MIN_APEX_FOR_RELATIVE_M]
        return max(d) if d else float("nan")


def _by_key(contacts):
    out = {}
    for c in contacts:
        if c.epsilon == 0.0:      # rest / no bounce: not an impact both runs need to share
            continue
        out.setdefault(f"{c.body_a} - {c.body_b}", []).append(c)
    return out


def compare_states(a, b, dt_s):
    """Every body's largest position difference and final states of two runs (same sample times).

    Returns
    -------
    list of tuple
        (body, largest |p_b - p_a| [m], the time of it [s], final |p_b - p_a| [m], final v_a [m/s],
        final v_b [m/s], differs): ``differs`` when the position or the final velocity differs by
        more than :func:`state_tolerances`
    """
    tol_p, tol_v = state_tolerances(dt_s)
    pb = np.stack([np.stack([np.interp(a.t_s, b.t_s, b.position_m[:, k, c]) for c in range(3)], axis=1)
                   for k in range(len(a.scene.names))], axis=1)
    dist = np.linalg.norm(pb - a.position_m, axis=2)
    out = []
    for k, name in enumerate(a.scene.names):
        worst = int(np.argmax(dist[:, k]))
        va, vb = a.velocity_m_per_s[-1, k], b.velocity_m_per_s[-1, k]
        differs = bool(dist[worst, k] > tol_p or np.linalg.norm(vb - va) > tol_v)
        out.append((name, float(dist[worst, k]), float(a.t_s[worst]), float(dist[-1, k]), va.copy(), vb.copy(),
                    differs))
    return out


def simultaneous_contacts(result):
    """Instants at which a run resolved two or more contacts, at least one between balls.

    Returns
    -------
    list of (float, list of str)
        (t [s], the contacts "a - b" in the order they were resolved)
    """
    groups = {}
    for c in result.contacts:
        groups.setdefault(c.t_s, []).append(c)
    return [(t, [f"{c.body_a} - {c.body_b}" for c in cs]) for t, cs in sorted(groups.items())
            if len(cs) > 1 and any(c.body_b != "floor" for c in cs)]


def compare_results(a, b):
    """Match the impacts and apexes of two runs of the same scene.

    Parameters
    ----------
    a, b : vrcal.scenes.spec.SceneResult
        e.g. vrcal's run and ODE's

    Returns
    -------
    SceneComparison
    """
    cmp = SceneComparison(engines=(a.engine, b.engine), dt_s=float(b.settings.get("dt_s", np.nan)),
                          solver_messages=int(b.settings.get("ode_messages", 0)))
    ca, cb = _by_key(a.contacts), _by_key(b.contacts)
    for key in sorted(set(ca) | set(cb)):
        la, lb = ca.get(key, []), cb.get(key, [])
        for k, (x, y) in enumerate(zip(la, lb)):
            cmp.impacts.append((key, k + 1, x.t_s, y.t_s, x.impact_speed_m_per_s, y.impact_speed_m_per_s))
        if len(la) != len(lb):
            cmp.unmatched.append(f"{key}: {len(la)} impacts ({a.engine}) vs {len(lb)} ({b.engine})")
    for name in a.scene.names:
        pa = [(t, h) for n, t, h in a.apexes if n == name]
        pb = [(t, h) for n, t, h in b.apexes if n == name]
        for k, (x, y) in enumerate(zip(pa, pb)):
            cmp.apexes.append((name, k, x[0], x[1], y[0], y[1]))
        if len(pa) != len(pb):
            cmp.unmatched.append(f"{name}: {len(pa)} apexes ({a.engine}) vs {len(pb)} ({b.engine})")
    cmp.states = compare_states(a, b, cmp.dt_s)
    cmp.simultaneous = simultaneous_contacts(a)
    return cmp


def difference_flags(cmp):
    """Short lines naming what differs beyond the tolerances (empty when the runs agree): for the
    text and the figure."""
    if not cmp.differing_bodies:
        return []
    ea, eb = cmp.engines
    tol_p, tol_v = state_tolerances(cmp.dt_s)
    worst = max(cmp.states, key=lambda r: r[1])
    lines = [f"DIFFERENT: {', '.join(cmp.differing_bodies)} end in other states (tolerance {tol_p * 1e3:g} mm, "
             f"{tol_v:g} m/s); largest |Δposition| {worst[1]:.3g} m ({worst[0]}, t = {worst[2]:.3g} s)"]
    if cmp.simultaneous:
        t, pairs = cmp.simultaneous[0]
        lines.append(f"order dependence: at t = {t:.4g} s {ea} resolved {len(pairs)} touching contacts one after "
                     f"another ({', '.join(pairs)}: sequential impulses), "
                     f"{'ODE' if eb == 'ode' else eb}'s LCP solves them together in one "
                     "step -- for touching balls (Newton's cradle) the two give different, equally momentum-"
                     "conserving outcomes")
    return lines


def _first_per_key(matches, max_rows):
    """The first ``max_rows`` of ``matches`` (tuples whose first item is the key) for each key, in order."""
    shown, out = {}, []
    for m in matches:
        shown[m[0]] = shown.get(m[0], 0) + 1
        if shown[m[0]] <= max_rows:
            out.append(m)
    return out


def comparison_text(cmp, max_rows=5):
    """The comparison for people (at most 100 columns): the largest differences first, then the
    first ``max_rows`` impacts of each pair and apexes of each body, then why the runs differ."""
    from vrcal.textout import number, table, wrap

    ea, eb = cmp.engines
    step = f" (ODE step {cmp.dt_s:g} s)" if np.isfinite(cmp.dt_s) else ""
    text = wrap(f"{ea} against {eb}{step}:")
    if cmp.impacts:
        dt = cmp.max_impact_time_difference_s
        steps = f" = {number(dt / cmp.dt_s, 3)} steps" if np.isfinite(cmp.dt_s) else ""
        text += wrap(f"{len(cmp.impacts)} matched impacts, largest |Δt| = {number(dt * 1e3, 3)} ms{steps}",
                     first="  ")
    else:
        text += "  no matched impacts\n"
    if cmp.apexes:
        rel = cmp.max_apex_relative_difference
        share = (f" (at most {number(100 * rel, 3)} % of the apexes above {100 * MIN_APEX_FOR_RELATIVE_M:g} cm)"
                 if np.isfinite(rel) else "")
        text += wrap(f"{len(cmp.apexes)} matched apexes, largest |Δh| = {number(cmp.max_apex_difference_m * 1e3, 3)} "
                     f"mm{share}", first="  ")
    else:
        text += "  no matched apexes\n"
    if cmp.states:
        tol_p, tol_v = state_tolerances(cmp.dt_s)
        largest = number(cmp.max_position_difference_m * 1e3, 3)
        text += wrap(f"{len(cmp.states)} bodies, largest |Δposition| = {largest} "
                     f"mm (horizontal too; tolerance {tol_p * 1e3:g} mm, end velocity {tol_v:g} m/s)", first="  ")
    for line in difference_flags(cmp):
        text += wrap(line, first="  ")
    if cmp.solver_messages:
        text += wrap(f"WARNING: ODE's solver reported {cmp.solver_messages} messages (see the notes above): "
                     "its run is unreliable there", first="  ")
    rows = [[key, str(k), f"{ta:.6f}", f"{tb:.6f}", f"{(tb - ta) * 1e3:+.3f}"]
            for key, k, ta, tb, _sa, _sb in _first_per_key(cmp.impacts, max_rows)]
    if rows:
        text += "\n" + table(rows, ["impact", "k", f"t {ea} [s]", f"t {eb} [s]", "Δt [ms]"], align="lrrrr")
    rows = [[name, str(k), f"{ha:.6f}", f"{hb:.6f}", f"{(hb - ha) * 1e3:+.3f}"]
            for name, k, _ta, ha, _tb, hb in _first_per_key(cmp.apexes, max_rows)]
    if rows:
        text += "\n" + table(rows, ["apex of", "k", f"h {ea} [m]", f"h {eb} [m]", "Δh [mm]"], align="lrrrr")
    rows = [[name, f"{d * 1e3:.2f}", f"{t:.3f}", f"{dend * 1e3:.2f}", _vector_text(va), _vector_text(vb),
             "DIFFERENT" if differs else ""]
            for name, d, t, dend, va, vb, differs in cmp.states[:3 * max_rows]]
    if rows:
        text += "\n" + table(rows, ["body", "max |Δp| [mm]", "at t [s]", "end |Δp| [mm]", f"end v {ea} [m/s]",
                                    f"end v {eb} [m/s]", ""], align="lrrrlll")
    for line in cmp.unmatched:
        text += wrap(f"unmatched: {line}")
    text += "\nwhy they differ:\n" + "".join(wrap(e, first="  - ") for e in EXPLANATIONS)
    return text


def _vector_text(v):
    return " ".join(f"{round(float(x), 3) + 0.0:+.3f}" for x in v)
