"""Replay a measured drop in an engine: ``vrcal verify --from DISCOVER.json --against DATA``.

The record is read exactly as ``vrcal discover`` read it (the same reader options, and the
same floor reference: :func:`vrcal.discovery.ranking.floor_referenced`). Three models of it
are compared with the data, each released at the discover result's release state:

* **engine** -- the export of the discover result (its air drag, its speed-dependent epsilon
  as the engine allows, its release height), run in the engine;
* **vrcal** -- vrcal's own extended model (every named effect, closed-form flights):
  :func:`vrcal.drop.simulate.simulate_drops`;
* **constant** -- the constant-epsilon export of the baseline (the paper's model: epsilon and
  release state of the discover baseline, no effects), run in the same engine.

For each the gap (RMS of model - data over the samples after release) and each rebound apex
against the measured one are reported. The engine's heights are its ball's bottom plus the
discover result's ``height_offset`` (the tracked point).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np

from vrcal.engines import get_engine, load, require_runtime
from vrcal.engines.common import DEFAULT_TOLERANCE
from vrcal.errors import DataError, UsageError

#: Each rebound apex of the engine should lie within this fraction of the measured one.
APEX_GOAL = 0.03


@dataclass
class Replay:
    """The outcome of :func:`replay`.

    Attributes
    ----------
    engine, engine_version : str
    dt_s : float
    t_s, y_m : ndarray
        the record, floor-referenced as ``vrcal discover`` did
    release_index : int
        first sample after the still segment
    curves : dict
        ``{"engine" | "vrcal" | "constant": heights at t_s [m]}``
    apex_measured_m : ndarray (n_rebounds,)
    apexes : dict
        ``{name: apex heights of each rebound [m]}``
    gaps_m : dict
        ``{name: RMS of model - data after release [m]}``
    notes : list of str
    """

    engine: str
    engine_version: str
    dt_s: float
    t_s: np.ndarray
    y_m: np.ndarray
    release_index: int
    curves: dict
    apex_measured_m: np.ndarray
    apexes: dict
    gaps_m: dict
    notes: list = field(default_factory=list)

    def apex_errors(self, name):
        """(model apex / measured apex - 1) of each rebound."""
        return np.asarray(self.apexes[name]) / self.apex_measured_m - 1.0

    @property
    def within_goal(self):
        """Every engine rebound apex within :data:`APEX_GOAL` of the measured one."""
        return bool(np.all(np.abs(self.apex_errors("engine")) <= APEX_GOAL))

    apex_goal = APEX_GOAL

    def worst_apex(self):
        """(rebound number from 1, relative error) of the engine's apex farthest from the measured one."""
        errors = self.apex_errors("engine")
        k = int(np.argmax(np.abs(errors)))
        return k + 1, float(errors[k])

    def as_dict(self):
        return {
            "engine": self.engine, "engine_version": self.engine_version, "dt_s": self.dt_s,
            "apex_measured_m": self.apex_measured_m.tolist(),
            "apex_m": {k: np.asarray(v).tolist() for k, v in self.apexes.items()},
            "apex_relative_error": {k: self.apex_errors(k).tolist() for k in self.apexes},
            "gap_m": dict(self.gaps_m), "apex_goal": APEX_GOAL, "within_goal": self.within_goal,
            "notes": list(self.notes),
        }


def read_record(path, *, fmt=None, scale_m_per_px=None, y_down=False, fs_hz=None, floor_m=None, doc=None):
    """The record as ``vrcal discover`` read it: (Trajectory, notes).

    Reader options not given are taken from the discover result's ``data.read_options`` when it
    has one (a key that newer discover results may carry), and so is ``floor_m``
    (``data.floor_shift_m``); otherwise the floor is referenced by the same rule as discover's.
    """
    from vrcal.discovery.ranking import floor_referenced
    from vrcal.measurements import read_measurement
    from vrcal.model.body import BallProperties

    saved = ((doc or {}).get("data") or {}) if isinstance((doc or {}).get("data"), dict) else {}
    opts = saved.get("read_options") if isinstance(saved.get("read_options"), dict) else {}
    fmt = fmt if fmt is not None else opts.get("format")
    scale_m_per_px = scale_m_per_px if scale_m_per_px is not None else opts.get("scale_m_per_px")
    y_down = y_down or bool(opts.get("y_down", False))
    fs_hz = fs_hz if fs_hz is not None else opts.get("fs_hz")
    if floor_m is None and isinstance(saved.get("floor_shift_m"), (int, float)):
        floor_m = float(saved["floor_shift_m"])
    data = read_measurement(path, fmt, scale_m_per_px=scale_m_per_px, y_down=y_down, fs_hz=fs_hz)
    if data.kind != "trajectory":
        raise UsageError(f"--against replays a trajectory (heights against time); {path} holds {data.kind}")
    ball = (doc or {}).get("ball")
    props = BallProperties(float(ball["mass_kg"]), float(ball["diameter_m"]), str(ball.get("name", "ball"))) \
        if isinstance(ball, dict) else None
    data, note = floor_referenced(data, floor_m, props)
    return data, [note] if note else []


def release_state(doc, against):
    """The release state (drop_height_m, release_time_s, epsilon) of the record ``against``.

    A discover result of several records (a ``runs`` list, each with its ``source`` and release
    state) gives the run whose source is that file; otherwise the result's ``model``.
    """
    import os

    model = dict(doc["model"])
    runs = doc.get("runs")
    if isinstance(runs, list):
        target = os.path.realpath(str(against))
        for run in runs:
            if not isinstance(run, dict):
                continue
            source = run.get("source") or (run.get("data") or {}).get("source")
            if source and (os.path.realpath(str(source)) == target
                           or os.path.basename(str(source)) == os.path.basename(target)):
                state = run.get("model") if isinstance(run.get("model"), dict) else run
                for key in ("drop_height_m", "release_time_s"):
                    if isinstance(state.get(key), (int, float)) and math.isfinite(state[key]):
                        model[key] = float(state[key])
                break
    return model


def _flights(t_s, impacts_s, t_end):
    """(start, end) of each rebound flight: between consecutive impacts (the last up to t_end)."""
    edges = list(impacts_s) + [t_end]
    return [(edges[k], edges[k + 1]) for k in range(len(impacts_s))]


def _apex_in(t_s, y_m, start, end):
    mask = (t_s > start) & (t_s < end)
    if not np.any(mask):
        return math.nan, False
    idx = np.flatnonzero(mask)
    i = idx[np.argmax(y_m[idx])]
    complete = idx[0] < i < idx[-1]          # the apex lies inside the flight, not at its edge
    return float(y_m[i]), complete


def replay(from_json, against, engine="mujoco", *, dt_s=None, integrator=None, tolerance=DEFAULT_TOLERANCE,
           max_penetration_m=None, stiffness=None, fmt=None, scale_m_per_px=None, y_down=False, fs_hz=None,
           floor_m=None, standards=None, exported_text=None, file_name=None):
    """Replay the record ``against`` in ``engine`` with the export of the discover result ``from_json``.

    Parameters
    ----------
    from_json : str
        a ``vrcal discover --json`` result
    against : str
        the measurement file discover read
    engine : str
        mujoco, ode or bullet
    dt_s, integrator, tolerance, max_penetration_m, stiffness
        as for :func:`vrcal.engines.export.export`
    fmt, scale_m_per_px, y_down, fs_hz, floor_m
        the reader options discover was given (see :func:`read_record`)
    exported_text, file_name : str, optional
        a file written by ``vrcal export`` (``--file``) and its name: the **engine** curve runs
        this file (its ball, contact, drag and speed law; at ``dt_s`` when given) instead of a
        fresh export of ``from_json``, released at the discover result's release state

    Returns
    -------
    Replay
    """
    from vrcal.drop.simulate import simulate_drops
    from vrcal.engines.export import export, parse_exported
    from vrcal.model.body import BallProperties, read_discover_json

    eng = get_engine(engine)
    version = require_runtime(eng.name)
    doc = read_discover_json(from_json)
    data, notes = read_record(against, fmt=fmt, scale_m_per_px=scale_m_per_px, y_down=y_down, fs_hz=fs_hz,
                              floor_m=floor_m, doc=doc)
    t, y = np.asarray(data.t_s, dtype=float), np.asarray(data.y_m, dtype=float)
    i0 = int(getattr(data, "release_index", 0) or 0)
    ball = doc["ball"]
    props = BallProperties(float(ball["mass_kg"]), float(ball["diameter_m"]), str(ball["name"]))
    g = float(doc["g_m_per_s2"])
    model = release_state(doc, against)
    effects = {e: dict(doc["parameters"].get(e, {})) for e in doc["effects"]}
    t_end = float(t[-1])
    # vrcal's own model: enough bounces to pass the end of the record
    n = 1
    while True:
        drops = simulate_drops(float(model["drop_height_m"]), float(model["epsilon"]), n, props,
                               effects=effects or None, g_m_per_s2=g, release_time_s=float(model["release_time_s"]))
        if drops.impact_times_s[0, -1] > t_end or n >= 60:
            break
        n += 1
    impacts = drops.impact_times_s[0]
    impacts = impacts[impacts < t_end]
    if impacts.size == 0:
        raise DataError(f"{against}: the record ends before the first impact of the discover model")
    n_bounces = int(impacts.size)
    flights = _flights(t, impacts, t_end)
    measured = [_apex_in(t, y, a, b) for a, b in flights]
    complete = [k for k, (_, ok) in enumerate(measured) if ok]
    if not complete:
        raise DataError(f"{against}: no complete rebound flight in the record to compare apexes with")
    apex_measured = np.array([measured[k][0] for k in complete])
    # a record without a floor: its contact level, fitted with every model of discover (0 with a floor)
    level = float(doc["floor_level_m"]) if isinstance(doc.get("floor_level_m"), (int, float)) else 0.0
    curves = {"vrcal": drops.height_m(t)[0] + level}

    # the engine: the export of the discover result, and the constant-epsilon export of its baseline
    common = dict(dt_s=dt_s, integrator=integrator, tolerance=tolerance, max_penetration_m=max_penetration_m,
                  stiffness=stiffness, standards=standards)
    if exported_text is None:
        ex = export(None, eng.name, from_json=from_json, drop_height_m=float(model["drop_height_m"]), **common)
        engine_run = (ex.setup, parse_exported(eng.name, ex.text))
    else:
        engine_run = _file_run(eng.name, exported_text, file_name, from_json, props, model, common, notes)
    base = doc.get("baseline") if isinstance(doc.get("baseline"), dict) else {}
    eps0 = base.get("epsilon", doc.get("epsilon_baseline"))
    H0, t0 = base.get("drop_height_m"), base.get("release_time_s")
    if not all(isinstance(x, (int, float)) and math.isfinite(x) for x in (eps0, H0, t0)):
        raise DataError(f"{from_json}: the baseline (epsilon, drop_height_m, release_time_s) is missing")
    base_options = dict(mass_kg=props.mass_kg, diameter_m=props.diameter_m, epsilon=float(eps0),
                        drop_height_m=float(H0), g_m_per_s2=g, **{k: v for k, v in common.items() if k != "standards"})
    try:
        ex0 = export(None, eng.name, **base_options)
    except UsageError:
        # only a comparison: run the constant-epsilon export at this step anyway, and say so
        base_options.update(tolerance=1.0, max_penetration_m=props.diameter_m)
        ex0 = export(None, eng.name, **base_options)
        notes.append("the constant-epsilon export misses --tolerance or --max-penetration at this step: "
                     "it is run anyway, for the comparison only")
    module = load(eng.name)
    for name, (setup, runnable), release, offset in (
            ("engine", engine_run, float(model["release_time_s"]), engine_run[0].height_offset_m),
            ("constant", (ex0.setup, parse_exported(eng.name, ex0.text)), float(t0), level)):
        setup = replace(setup, n_bounces=n_bounces)
        duration = max(t_end - release, setup.dt_s) + 0.05
        steps = int(math.ceil(duration / setup.dt_s))
        if steps > eng.max_steps:
            raise UsageError(f"the replay needs {steps:,} {eng.name} steps at --dt {setup.dt_s:g} s "
                             f"(limit {eng.max_steps:,}): use a larger --dt")
        z, _v = run_once(eng.name, module, runnable, setup, duration)
        tz = release + setup.dt_s * np.arange(z.size)
        curve = np.where(t < release, setup.drop_height_m, np.interp(t, tz, z)) + offset
        curves[name] = curve
    apexes = {}
    for name, curve in curves.items():
        apexes[name] = np.array([_apex_in(t, curve, *flights[k])[0] for k in complete])
    gaps = {name: float(np.sqrt(np.mean((curve[i0:] - y[i0:]) ** 2))) for name, curve in curves.items()}
    notes = notes + [f"gap: RMS of model - data over the {t.size - i0} samples after release"]
    if len(complete) < len(flights):
        notes.append(f"{len(flights) - len(complete)} rebound flight(s) not complete in the record: no apex compared")
    return Replay(eng.name, version, engine_run[0].dt_s, t, y, i0, curves, apex_measured, apexes, gaps, notes)


def _file_run(engine, text, file_name, from_json, props, model, common, notes):
    """(DropSetup, what the engine runs) of the user's exported file, released as the record was.

    The file fixes the ball, the contact, the drag and the speed law; ``--dt`` runs it at another
    step. The release height and the tracked point's offset are the discover result's; a file of
    another ball than the discover result's is run all the same, and a note says so.
    """
    from vrcal.engines.export import build_setup
    from vrcal.engines.verify import _load_file

    options = dict(epsilon=None, dt_s=common["dt_s"], floor=None, mass_kg=None, diameter_m=None,
                   drop_height_m=None, impact_speed=None, g_m_per_s2=None, from_json=None,
                   integrator=common["integrator"], max_penetration_m=None, stiffness=common["stiffness"],
                   tolerance=None)
    _loaded, runnable, setup = _load_file(engine, text, None, options)
    H = float(model["drop_height_m"])
    pre = build_setup(None, engine, None, setup.dt_s, None, common["standards"], tolerance=common["tolerance"],
                      from_json=from_json, drop_height_m=H)
    name = file_name or "the file"
    notes.append(f"engine: {name} ({setup.ball}, target epsilon {setup.epsilon:.4f}"
                 + (f", speed law p = {setup.restitution_exponent:.3g}" if setup.restitution_exponent else "")
                 + f"), released as the record: {H:.4g} m at {float(model['release_time_s']):.4g} s")
    if not (math.isclose(setup.mass_kg, props.mass_kg, rel_tol=1e-3)
            and math.isclose(2 * setup.radius_m, props.diameter_m, rel_tol=1e-3)):
        notes.append(f"{name} holds another ball than {from_json}: {1e3 * setup.mass_kg:.4g} g, "
                     f"D {2e3 * setup.radius_m:.4g} mm (discover: {1e3 * props.mass_kg:.4g} g, "
                     f"D {1e3 * props.diameter_m:.4g} mm)")
    notes.extend(n for n in setup.notes if n.startswith("run at --dt"))
    return replace(setup, drop_height_m=H, height_offset_m=pre.height_offset_m), runnable


def run_once(engine, module, loaded, setup, duration_s):
    """One drop of an exported file from its release state: (z_m, v_m_per_s) at every step."""
    if engine == "mujoco":
        z, v, _dt, _g = module.run_drops(loaded, setup.drop_height_m, [0.0], duration_s, setup.radius_m)
        return z[0], v[0]
    z, v, _dt, _g = module.run_drop(loaded, setup.drop_height_m, duration_s)
    return z, v


def format_replay(r):
    """The replay as a short aligned text for people (<= 100 columns)."""
    from vrcal.textout import table

    names = [("engine", f"{r.engine} export"), ("vrcal", "vrcal model"), ("constant", "constant eps")]
    head = (f"replay in {r.engine} {r.engine_version}, dt {r.dt_s:g} s: {len(r.apex_measured_m)} rebound apex(es), "
            f"{r.t_s.size - r.release_index} samples after release\n")
    rows = []
    for k, measured in enumerate(r.apex_measured_m):
        row = [str(k + 1), f"{measured:.4f}"]
        for key, _ in names:
            row.append(f"{r.apexes[key][k]:.4f} ({100 * r.apex_errors(key)[k]:+.1f} %)")
        rows.append(row)
    text = head + table(rows, ["rebound", "measured m"] + [label + " m" for _, label in names])
    text += "gap (RMS)  " + "   ".join(f"{label} {1e3 * r.gaps_m[key]:.3g} mm" for key, label in names) + "\n"
    worst = float(np.max(np.abs(r.apex_errors("engine"))))
    text += (f"engine apexes within {100 * APEX_GOAL:g} % of the measured ones: "
             f"{'yes' if r.within_goal else 'no'} (worst {100 * worst:.1f} %)\n")
    import textwrap

    for n in r.notes:
        text += "\n".join(textwrap.wrap(f"note: {n}", 100, subsequent_indent="  ")) + "\n"
    return text


def replay_figure(r, ax=None):
    """Heights against time (data, engine, vrcal model, constant epsilon) and their residuals.

    Returns the heights' axes (a new figure with a residual panel below when ``ax`` is None).
    """
    import matplotlib.pyplot as plt

    if ax is None:
        _, (ax, ax2) = plt.subplots(2, 1, figsize=(8, 6), sharex=True, gridspec_kw={"height_ratios": [3, 2]})
    else:
        ax2 = None
    ax.plot(r.t_s, r.y_m, ".", color="0.5", ms=3, label="data")
    styles = {"engine": ("-", f"{r.engine} (exported)"), "vrcal": ("--", "vrcal model"),
              "constant": (":", "constant epsilon")}
    for key, (ls, label) in styles.items():
        ax.plot(r.t_s, r.curves[key], ls, label=f"{label}, gap {1e3 * r.gaps_m[key]:.3g} mm")
        if ax2 is not None:
            ax2.plot(r.t_s[r.release_index:], 1e3 * (r.curves[key] - r.y_m)[r.release_index:], ls, label=label)
    ax.set_ylabel("height [m]")
    ax.legend(fontsize=8)
    ax.set_title(f"replay in {r.engine}, dt {r.dt_s:g} s")
    if ax2 is not None:
        ax2.axhline(0.0, color="0.5", lw=0.8)
        ax2.set_ylabel("model - data [mm]")
        ax2.set_xlabel("time [s]")
    else:
        ax.set_xlabel("time [s]")
    return ax
