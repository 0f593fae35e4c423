"""What a scene run produces: trajectory and contact CSV text, the height-vs-time plot (Figure 8
of [1]), the side-view animation (Figure 9), and the printed summary.

Nothing here writes files: text and bytes are returned and the command line writes them
atomically. :func:`run_scene` runs a scene file with the chosen engine(s) and returns all
outputs by file name.

Layouts
-------
``trajectories.csv`` (long format: one row per sample time and body, bodies in scene order)::

    t_s,body,x_m,y_m,z_m,bottom_m,vx_m_per_s,vy_m_per_s,vz_m_per_s,wx_rad_per_s,wy_rad_per_s,wz_rad_per_s

(x, y, z) is the sphere's centre, ``bottom_m = z - R`` the height of its bottom.

``contacts.csv``::

    t_s,body_a,body_b,impact_speed_m_per_s,epsilon,normal_impulse_N_s,tangential_impulse_N_s,note

``body_b`` is ``floor`` for the floor; the impact speed is the normal approach speed.
"""

from __future__ import annotations

import io
from dataclasses import dataclass, field

import numpy as np

from vrcal.textout import csv_text

TRAJECTORY_COLUMNS = ("t_s", "body", "x_m", "y_m", "z_m", "bottom_m", "vx_m_per_s", "vy_m_per_s", "vz_m_per_s",
                      "wx_rad_per_s", "wy_rad_per_s", "wz_rad_per_s")
CONTACT_COLUMNS = ("t_s", "body_a", "body_b", "impact_speed_m_per_s", "epsilon", "normal_impulse_N_s",
                   "tangential_impulse_N_s", "note")


def _g(x):
    return f"{float(x):.10g}"


def trajectories_csv(result):
    """The sampled trajectories as CSV text (layout in the module docstring)."""
    names = result.scene.names
    bottom = result.bottom_height_m()
    rows = []
    for k, t in enumerate(result.t_s):
        for b, name in enumerate(names):
            p, v, w = result.position_m[k, b], result.velocity_m_per_s[k, b], result.spin_rad_per_s[k, b]
            rows.append([_g(t), name, *map(_g, p), _g(bottom[k, b]), *map(_g, v), *map(_g, w)])
    return csv_text(TRAJECTORY_COLUMNS, rows)  # names quoted where they hold a comma or a newline


def contacts_csv(result):
    """Every contact as CSV text (layout in the module docstring)."""
    rows = [[_g(c.t_s), c.body_a, c.body_b, _g(c.impact_speed_m_per_s), _g(c.epsilon),
             _g(c.normal_impulse_N_s), _g(c.tangential_impulse_N_s), c.note] for c in result.contacts]
    return csv_text(CONTACT_COLUMNS, rows)


def plot_heights(result, ax=None, other=None):
    """Height of every body's bottom against time, the paper's Figure 8.

    Parameters
    ----------
    result : vrcal.scenes.spec.SceneResult
    ax : matplotlib Axes or None
        draw here; a new figure when None
    other : vrcal.scenes.spec.SceneResult or None
        a second run of the same scene (e.g. ODE), drawn dashed on top

    Returns
    -------
    matplotlib Axes
    """
    import matplotlib.pyplot as plt

    if ax is None:
        _fig, ax = plt.subplots(figsize=(7, 4))
    colours = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    for b, name in enumerate(result.scene.names):
        c = colours[b % len(colours)]
        ax.plot(*_bottom_with_floor_contacts(result, b), color=c, lw=1.4, label=f"{name} ({result.engine})")
        if other is not None:
            ax.plot(*_bottom_with_floor_contacts(other, b), color=c, lw=1.0, ls="--",
                    label=f"{name} ({other.engine})")
    ax.set_xlabel("time t [s]")
    ax.set_ylabel("height of the ball's bottom [m]")
    ax.set_title(f"{result.scene.name}: bounces (K = {result.scene.K_per_s:g} 1/s)")
    ax.set_ylim(bottom=0)
    ax.grid(alpha=0.3)
    if len(result.scene.names) <= 12:  # a longer legend would cover the plot
        ax.legend(fontsize=7, loc="upper right")
    return ax


def _bottom_with_floor_contacts(result, b):
    """Times [s] and bottom heights [m] of body ``b``: the samples plus its floor contacts.

    The samples are ``sample_dt_s`` apart and miss the instant of each floor contact, so a
    curve through them alone turns above the floor; at a floor contact the bottom is at 0.
    """
    name = result.scene.names[b]
    t_contact = np.array([c.t_s for c in result.contacts if c.body_a == name and c.body_b == "floor"], dtype=float)
    t = np.concatenate([result.t_s, t_contact])
    z = np.concatenate([result.bottom_height_m()[:, b], np.zeros_like(t_contact)])
    order = np.argsort(t, kind="stable")
    return t[order], z[order]


def animation_gif(result, *, max_frames=150, fps=None, dpi=80):
    """A side view (x-z plane) of the scene as an animated GIF, the paper's Figure 9.

    Parameters
    ----------
    result : vrcal.scenes.spec.SceneResult
    max_frames : int
        at most this many frames (sample times are thinned evenly)
    fps : float or None
        frames per second of the GIF; None: real time (frames / duration), within 5-30
    dpi : int
        resolution of the frames

    Returns
    -------
    bytes
        the GIF file

    Notes
    -----
    The frames are drawn by matplotlib with blitting (the static axes drawn once, the balls
    redrawn per frame) and written by Pillow, the library behind matplotlib's ``PillowWriter``;
    ``FuncAnimation.save`` re-renders the whole figure per frame and is about 5 times slower.
    Each ball carries a radius line that turns with its spin about the y axis.
    """
    import matplotlib.pyplot as plt
    from matplotlib.patches import Circle, Patch
    from PIL import Image

    n_t = len(result.t_s)
    frames = np.unique(np.linspace(0, n_t - 1, min(max_frames, n_t)).round().astype(int))
    pos = result.position_m
    radii = np.array([b.radius_m for b in result.scene.bodies])
    x_lo = float(np.min(pos[:, :, 0] - radii)) - 0.1
    x_hi = float(np.max(pos[:, :, 0] + radii)) + 0.1
    z_hi = float(np.max(pos[:, :, 2] + radii)) * 1.08
    width = max(3.0, min(8.0, 3.6 * (x_hi - x_lo) / z_hi + 1.0))
    fig, ax = plt.subplots(figsize=(width + 1.6, 4.0), dpi=dpi)
    ax.set_xlim(x_lo, x_hi)
    ax.set_ylim(-0.03 * z_hi, z_hi)
    ax.set_aspect("equal")
    ax.axhline(0.0, color="0.3", lw=2)
    ax.set_xlabel("x [m]")
    ax.set_ylabel("z [m]")
    ax.set_title(f"{result.scene.name} ({result.engine})", fontsize=9)
    colours = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    ax.legend(handles=[Patch(fc=colours[b % len(colours)], ec="k", label=body.name)
                       for b, body in enumerate(result.scene.bodies)],
              loc="upper left", bbox_to_anchor=(1.02, 1.0), fontsize=7, frameon=False)
    fig.tight_layout()
    circles, marks = [], []
    for b in range(len(result.scene.bodies)):
        c = Circle((0.0, 0.0), radii[b], fc=colours[b % len(colours)], ec="k", alpha=0.85, animated=True)
        ax.add_patch(c)
        circles.append(c)
        (line,) = ax.plot([], [], color="k", lw=1, animated=True)
        marks.append(line)
    clock = ax.text(0.02, 0.96, "", transform=ax.transAxes, va="top", fontsize=8, animated=True)
    canvas = fig.canvas
    canvas.draw()
    background = canvas.copy_from_bbox(fig.bbox)
    images = []
    for k in frames:
        canvas.restore_region(background)
        for b in range(len(circles)):
            cx, cz = pos[k, b, 0], pos[k, b, 2]
            circles[b].center = (cx, cz)
            a = result.angle_y_rad[k, b]
            marks[b].set_data([cx, cx + radii[b] * np.cos(a)], [cz, cz - radii[b] * np.sin(a)])
            ax.draw_artist(circles[b])
            ax.draw_artist(marks[b])
        clock.set_text(f"t = {result.t_s[k]:.2f} s")
        ax.draw_artist(clock)
        rgb = np.asarray(canvas.buffer_rgba())[:, :, :3].copy()
        images.append(Image.fromarray(rgb).quantize(colors=16, method=Image.Quantize.MEDIANCUT))
    plt.close(fig)
    buf = io.BytesIO()
    if fps is None:
        fps = min(30.0, max(5.0, len(frames) / max(result.t_s[-1] - result.t_s[0], 1e-9)))
    images[0].save(buf, format="GIF", save_all=True, append_images=images[1:], duration=int(round(1000 / fps)),
                   loop=0)
    return buf.getvalue()


def summary_text(result):
    """A sectioned text summary of one run: scene, pairs' epsilon, contacts, apexes."""
    s = result.scene
    lines = [f"[[Scene]] {s.name} ({result.engine})"]
    if s.description:
        lines.append(f"    {s.description}")
    lines += [
        f"    K = {s.K_per_s:g} 1/s, duration {s.duration_s:g} s, g = {s.g_m_per_s2:g} m/s^2, "
        f"friction mu = {s.friction_mu:g}, rest below {s.rest_speed_m_per_s:g} m/s",
        f"    floor: x = {s.floor_x_m:g} m, v = {s.floor_v_m_per_s:g} m/s",
        "[[Bodies]]  epsilon on the floor = exp(-K (x/(2v) + T_floor))  (Eqs. 6, 7)",
    ]
    eps = s.epsilon_matrix()
    for b, body in enumerate(s.bodies):
        kind = f"ball {body.ball}" if body.ball else "explicit"
        lines.append(f"    {body.name:<14} {kind:<18} m = {body.mass_kg:.4g} kg, R = {body.radius_m:.4g} m, "
                     f"I = {body.inertia_factor:.3g} m R^2, x = {body.x_m:.4g} m, v = {body.v_m_per_s:.4g} m/s, "
                     f"epsilon(floor) = {eps[b, -1]:.4f}")
    pairs = [(a, b) for a in range(len(s.bodies)) for b in range(a + 1, len(s.bodies))]
    if pairs:
        lines.append("[[Pairs]]  epsilon = exp(-K (x_A/(2 v_A) + x_B/(2 v_B)))")
        for a, b in pairs:
            lines.append(f"    {s.bodies[a].name} - {s.bodies[b].name}: epsilon = {eps[a, b]:.4f}")
    lines.append(f"[[Contacts]]  {len(result.contacts)} in {s.duration_s:g} s (first 12; all in contacts.csv)")
    lines.append(f"    {'t [s]':>9}  {'bodies':<28} {'speed [m/s]':>11} {'epsilon':>8}  note")
    for c in result.contacts[:12]:
        lines.append(f"    {c.t_s:9.4f}  {c.body_a + ' - ' + c.body_b:<28} {c.impact_speed_m_per_s:11.4f} "
                     f"{c.epsilon:8.4f}  {c.note}")
    lines.append("[[Apexes]]  highest bottom height of each body's flights (first 4 per body)")
    for name in s.names:
        ap = [(t, h) for n, t, h in result.apexes if n == name][:4]
        lines.append(f"    {name:<14} " + ", ".join(f"{h:.4f} m at {t:.3f} s" for t, h in ap))
    for note in result.notes:
        lines.append(f"[[Note]] {note}")
    return "\n".join(lines) + "\n"


def heights_png(result, other=None, dpi=100):
    """The Figure-8 plot rendered to PNG bytes."""
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7, 4))
    plot_heights(result, ax=ax, other=other)
    fig.tight_layout()
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=dpi)
    plt.close(fig)
    return buf.getvalue()


@dataclass
class SceneRun:
    """Everything ``vrcal scene`` prints and writes."""

    summary: str
    files: dict = field(default_factory=dict)   # file name -> str or bytes
    results: dict = field(default_factory=dict)  # engine -> SceneResult
    comparison: object = None


def run_scene(path, *, engine="vrcal", compare=False, ode_dt_s=None, standards=None, animate=True):
    """Load a scene file, run it, and render every output.

    Parameters
    ----------
    path : str or Path
        the scene file
    engine : {"vrcal", "ode"}
        the simulator whose run gives the files (with ``compare``: both run, files of both)
    compare : bool
        run both and compare apex heights and impact times
    ode_dt_s : float or None
        ODE's fixed time step [s]; :data:`vrcal.scenes.ode.DEFAULT_DT_S` when None
    standards : dict or None
        ball standards for ``ball:`` bodies
    animate : bool
        render the GIF (the slowest output)

    Returns
    -------
    SceneRun
    """
    from vrcal.errors import UsageError
    from vrcal.scenes.spec import load_scene

    if engine not in ("vrcal", "ode"):
        raise UsageError(f"unknown engine {engine!r} (known: vrcal, ode)")
    scene = load_scene(path, standards)
    engines = ("vrcal", "ode") if compare else (engine,)
    results = {}
    for name in engines:
        if name == "vrcal":
            from vrcal.scenes.multibody import simulate_scene

            results[name] = simulate_scene(scene)
        else:
            from vrcal.scenes.ode import DEFAULT_DT_S, simulate_scene_ode

            results[name] = simulate_scene_ode(scene, dt_s=DEFAULT_DT_S if ode_dt_s is None else ode_dt_s)
    run = SceneRun(summary="", results=results)
    texts = []
    for name, res in results.items():
        suffix = "" if len(results) == 1 else f"-{name}"
        run.files[f"trajectories{suffix}.csv"] = trajectories_csv(res)
        run.files[f"contacts{suffix}.csv"] = contacts_csv(res)
        texts.append(summary_text(res))
    main = results[engine] if not compare else results["vrcal"]
    other = results["ode"] if compare else None
    run.files["figure8.png"] = heights_png(main, other=other)
    if animate:
        run.files["scene.gif"] = animation_gif(main)
    if compare:
        from vrcal.scenes.compare import compare_results, comparison_text

        run.comparison = compare_results(results["vrcal"], results["ode"])
        texts.append(comparison_text(run.comparison))
    run.summary = "\n".join(texts)
    return run
