"""What a scene run produces: trajectory and contact CSV text, the height-vs-time plot (Figure 8
of [1]), the side-view animation (Figure 9), and the printed summary.

Nothing here writes files: text and bytes are returned and the command line writes them
atomically. :func:`run_scene` runs a scene file with the chosen engine(s) and returns all
outputs by file name; every name starts with the scene file's name (``NAME.png``,
``NAME.gif``, ``NAME-trajectories.csv``, ``NAME-contacts.csv``; with ``--compare`` the CSV
names end in ``-vrcal`` / ``-ode``).

The plot shows the height of each ball's bottom against time (Figure 8); a scene in which no
ball leaves the floor (a row of balls rolling, like ``examples/cradle.yaml``) shows the
horizontal position instead. With a second run (``--compare``) a lower panel shows the
difference between the two runs.

Layouts
-------
``NAME-trajectories.csv`` (long format: one row per sample time and body, bodies in scene order)::

    t_s,body,x_m,y_m,z_m,bottom_m,vx_m_per_s,vy_m_per_s,vz_m_per_s,wx_rad_per_s,wy_rad_per_s,wz_rad_per_s

(x, y, z) is the sphere's centre, ``bottom_m = z - R`` the height of its bottom.

``NAME-contacts.csv``::

    t_s,body_a,body_b,impact_speed_m_per_s,epsilon,normal_impulse_N_s,tangential_impulse_N_s,note

``body_b`` is ``floor`` for the floor; the impact speed is the normal approach speed. The
impulses are on body_a: vrcal's are exact (Eq. 5 and friction); ODE's come from its joint
feedback over the impact step (force x dt, so they include m g dt of support). A touch that does
not approach (a ball placed on the floor) is not a contact.
"""

from __future__ import annotations

import io
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from vrcal.textout import csv_text, number, table, wrap

#: A ball whose bottom never rises above this [m] stays on the floor: the plot shows x instead.
ON_FLOOR_M = 1e-3

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
    """Every contact as CSV text (layout in the module docstring); an impulse not known is left empty."""
    def known(x):
        return _g(x) if np.isfinite(x) else ""

    rows = [[_g(c.t_s), c.body_a, c.body_b, _g(c.impact_speed_m_per_s), _g(c.epsilon),
             known(c.normal_impulse_N_s), known(c.tangential_impulse_N_s), c.note] for c in result.contacts]
    return csv_text(CONTACT_COLUMNS, rows)


def leaves_floor(result):
    """True when some ball's bottom rises more than :data:`ON_FLOOR_M` above the floor."""
    return bool(np.max(result.bottom_height_m()) > ON_FLOOR_M)


def plot_heights(result, ax=None, other=None):
    """Height of every body's bottom against time, the paper's Figure 8.

    A scene in which no ball leaves the floor shows each ball's horizontal position x instead.

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
        one line per body (and per body of ``other``); the legend names the bodies (colours)
        and the line styles (engines): at most n + 2 entries
    """
    import matplotlib.pyplot as plt
    from matplotlib.lines import Line2D

    if ax is None:
        _fig, ax = plt.subplots(figsize=(7, 4))
    colours = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    vertical = leaves_floor(result) or (other is not None and leaves_floor(other))
    curve = _bottom_with_floor_contacts if vertical else _horizontal_position
    handles = []
    for b, name in enumerate(result.scene.names):
        c = colours[b % len(colours)]
        ax.plot(*curve(result, b), color=c, lw=1.4)
        if other is not None:
            ax.plot(*curve(other, b), color=c, lw=1.0, ls="--")
        handles.append(Line2D([], [], color=c, lw=1.4, label=name))
    if other is not None:
        handles += [Line2D([], [], color="0.3", lw=1.4, label=result.engine),
                    Line2D([], [], color="0.3", lw=1.0, ls="--", label=other.engine)]
    ax.set_xlabel("time t [s]")
    if vertical:
        ax.set_ylabel("height of the ball's bottom [m]")
        ax.set_ylim(bottom=0)
        what = "bounces"
    else:
        ax.set_ylabel("horizontal position x of the centre [m]")
        what = "no ball leaves the floor: horizontal positions"
    ax.set_title(f"{result.scene.name}: {what} (K = {result.scene.K_per_s:g} 1/s)", fontsize=10)
    ax.grid(alpha=0.3)
    if len(result.scene.names) <= 12:  # a longer legend would cover the plot
        ax.legend(handles=handles, fontsize=7, loc="upper right" if vertical else "best")
    return ax


def plot_difference(result, other, ax=None, flags=()):
    """The difference ``other - result`` of the plotted quantity (bottom height, or x) per body [mm]
    (solid) and, dotted, the horizontal distance between the two runs' centres [mm].

    ``other`` is interpolated to ``result``'s sample times; ``flags`` (lines of text, e.g.
    :func:`vrcal.scenes.compare.difference_flags`) are written in red on the panel. Returns the
    Axes (one or two lines per body).
    """
    import matplotlib.pyplot as plt

    if ax is None:
        _fig, ax = plt.subplots(figsize=(7, 2))
    colours = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    vertical = leaves_floor(result) or leaves_floor(other)
    a = result.bottom_height_m() if vertical else result.position_m[:, :, 0]
    b = other.bottom_height_m() if vertical else other.position_m[:, :, 0]
    for k in range(a.shape[1]):
        diff = np.interp(result.t_s, other.t_s, b[:, k]) - a[:, k]
        ax.plot(result.t_s, diff * 1e3, color=colours[k % len(colours)], lw=1.0)
        dxy = [np.interp(result.t_s, other.t_s, other.position_m[:, k, c]) - result.position_m[:, k, c]
               for c in (0, 1)]
        horizontal = np.hypot(*dxy)
        if np.any(horizontal > 1e-6):
            ax.plot(result.t_s, horizontal * 1e3, color=colours[k % len(colours)], lw=1.0, ls=":")
    ax.axhline(0.0, color="0.3", lw=0.8)
    if flags:
        import textwrap

        ax.text(0.01, 0.97, "\n".join(textwrap.fill(f, 110) for f in flags), transform=ax.transAxes, va="top",
                fontsize=6, color="tab:red", bbox={"fc": "white", "ec": "tab:red", "alpha": 0.85})
    ax.set_xlabel("time t [s]")
    ax.set_ylabel(f"{'height' if vertical else 'x'}: {other.engine} − {result.engine} [mm]\n"
                  "(dotted: horizontal distance)", fontsize=7)
    ax.grid(alpha=0.3)
    return ax


def _horizontal_position(result, b):
    """Times [s] and horizontal positions x [m] of body ``b``'s centre."""
    return result.t_s, result.position_m[:, b, 0]


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
    # a flat scene (balls rolling on the floor) gets a flat figure, not a wide white margin
    height = min(4.0, max(1.8, width * 1.03 * z_hi / (x_hi - x_lo) + 1.1))
    fig, ax = plt.subplots(figsize=(width + 1.6, height), dpi=dpi)
    ax.set_xlim(x_lo, x_hi)
    ax.set_ylim(-0.03 * z_hi, z_hi)
    ax.set_aspect("equal")
    ax.axhline(0.0, color="0.3", lw=2)
    ax.set_xlabel("x [m]")
    ax.set_ylabel("z [m]")
    ax.set_title(f"{result.scene.name} ({result.engine})", fontsize=9)
    colours = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    ax.legend(handles=[Patch(fc=colours[b % len(colours)], ec="k", label=body.name)
                       for b, body in enumerate(result.scene.bodies[:12])],  # more would not fit
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


def summary_text(result, contacts_file="contacts.csv", max_contacts=10):
    """A short summary of one run for people (at most 100 columns): the scene, its bodies, every
    pair's epsilon, the first contacts, and each body's apexes or, for a ball that stays on the
    floor, where it ends and how fast.

    ``contacts_file`` names the file that lists every contact.
    """
    s = result.scene
    eps = s.epsilon_matrix()
    floor = ("rigid" if s.floor_x_m == 0
             else f"x = {number(s.floor_x_m * 1e3, 4)} mm, v = {number(s.floor_v_m_per_s, 4)} m/s")
    text = wrap(f"{s.name} ({result.engine})" + (f": {s.description}" if s.description else ""))
    text += wrap(f"K = {s.K_per_s:g} 1/s, {s.duration_s:g} s, g = {s.g_m_per_s2:g} m/s², friction μ = "
                 f"{s.friction_mu:g}, at rest below {s.rest_speed_m_per_s:g} m/s; floor {floor}")
    rows = [[b.name, b.ball or "-", number(b.mass_kg * 1e3, 4), number(b.radius_m * 1e3, 4), number(b.x_m * 1e3, 4),
             number(b.v_m_per_s, 4), number(eps[i, -1], 4)] for i, b in enumerate(s.bodies)]
    text += "\n" + table(rows, ["body", "ball", "m [g]", "R [mm]", "x [mm]", "v [m/s]", "ε on the floor"],
                          align="llrrrrr")
    text += _pairs_text(s, eps)
    shown = result.contacts[:max_contacts]
    text += "\n" + wrap(f"{len(result.contacts)} contacts in {s.duration_s:g} s"
                         + (f" (the first {len(shown)}; all in {contacts_file}):" if len(shown) < len(result.contacts)
                            else ":"))
    if shown:
        text += table([[f"{c.t_s:.4f}", f"{c.body_a} - {c.body_b}", f"{c.impact_speed_m_per_s:.3f}",
                        number(c.epsilon, 4), c.note] for c in shown],
                      ["t [s]", "contact", "speed [m/s]", "ε", "note"], align="rlrrl")
    text += "\n" + _motion_text(result)
    for note in (*s.notes, *result.notes):
        text += wrap(f"note: {note}")
    return text


def _pairs_text(scene, eps):
    """Every pair's epsilon (Eqs. 6, 7): a triangle when it fits in 100 columns, else a list."""
    names = scene.names
    n = len(names)
    if n < 2:
        return ""
    head = "\n" + wrap("ε of each pair of bodies, exp(−K (x_A/(2 v_A) + x_B/(2 v_B))) (Eqs. 6, 7):")
    rows = [[names[a], *("" if b <= a else number(eps[a, b], 4) for b in range(1, n))] for a in range(n - 1)]
    text = table(rows, ["", *names[1:]], align="l" + "r" * (n - 1))
    if max(len(line) for line in text.splitlines()) <= 100:
        return head + text
    rows = [[f"{names[a]} - {names[b]}", number(eps[a, b], 4)] for a in range(n) for b in range(a + 1, n)]
    return head + table(rows, ["pair", "ε"], align="lr")


def _height(h_m):
    """A height [m] to millimetres from 0.1 m on (1.057), else to three significant digits (0.0100, 0.000100:
    a clay ball's 0.1 mm third apex and a 1 cm drop's apexes were 0.000 and 0.010, 0.009, 0.008)."""
    return f"{h_m:.3f}" if h_m >= 0.1 else number(h_m, 3)


def _motion_text(result, n_apexes=4):
    """Each body's first apexes (bottom height [m]), or where a ball that stays on the floor ends."""
    rows = []
    for b, name in enumerate(result.scene.names):
        ap = [h for n, _t, h in result.apexes if n == name]
        if ap and max(ap) > ON_FLOOR_M:
            shown = ", ".join(_height(h) for h in ap[:n_apexes]) + (", ..." if len(ap) > n_apexes else "")
            rows.append([name, f"apexes [m]: {shown}"])
        else:
            x, v = result.position_m[-1, b, 0], result.velocity_m_per_s[-1, b]
            rows.append([name, f"stays on the floor; at {result.t_s[-1]:g} s x = {x:.3f} m, "
                               f"speed {float(np.hypot(v[0], v[1])):.3f} m/s"])
    return table(rows, ["body", "bottom height at each apex (bounce 0 = start), or the end"], align="ll")


def heights_png(result, other=None, dpi=100, flags=()):
    """The Figure-8 plot rendered to PNG bytes; with ``other`` a difference panel below it, with
    ``flags`` (what differs beyond the tolerances) written on it in red."""
    import matplotlib.pyplot as plt

    if other is None:
        fig, ax = plt.subplots(figsize=(7, 4))
        plot_heights(result, ax=ax)
    else:
        fig, (ax, ax_diff) = plt.subplots(2, 1, figsize=(7, 5.5), sharex=True,
                                          gridspec_kw={"height_ratios": [3, 1.3]})
        plot_heights(result, ax=ax, other=other)
        ax.set_xlabel("")
        plot_difference(result, other, ax=ax_diff, flags=flags)
    fig.tight_layout()
    from vrcal.fileio import figure_bytes

    try:
        return figure_bytes(fig, "png", dpi=dpi)
    finally:
        plt.close(fig)


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
    if ode_dt_s is not None and engine == "vrcal" and not compare:
        raise UsageError("--ode-dt sets ODE's time step and has no effect with --engine vrcal: "
                         "add --compare or --engine ode, or leave it out")
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
    stem = Path(path).stem
    for name, res in results.items():
        suffix = "" if len(results) == 1 else f"-{name}"
        run.files[f"{stem}-trajectories{suffix}.csv"] = trajectories_csv(res)
        run.files[f"{stem}-contacts{suffix}.csv"] = contacts_csv(res)
    main = results[engine] if not compare else results["vrcal"]
    other = results["ode"] if compare else None
    flags = []
    if compare:
        from vrcal.scenes.compare import compare_results, difference_flags

        run.comparison = compare_results(results["vrcal"], results["ode"])
        flags = difference_flags(run.comparison)
    run.files[f"{stem}.png"] = heights_png(main, other=other, flags=flags)
    if animate:
        run.files[f"{stem}.gif"] = animation_gif(main)
    texts = [summary_text(main, f"{stem}-contacts{'-vrcal' if compare else ''}.csv")]
    if compare:
        from vrcal.scenes.compare import comparison_text

        texts.append(wrap(f"{other.scene.name} (ode): {len(other.contacts)} contacts")
                     + "".join(wrap(f"note: {note}") for note in other.notes))
        texts.append(comparison_text(run.comparison))
    run.summary = "\n".join(texts)
    return run
