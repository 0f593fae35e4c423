"""Figures 4-7 of [1], drawn from the model equations in :mod:`vrcal.model.restitution`.

Every plot function takes ``ax=None`` (a new figure when None) and returns the ax; this
module never saves files (the command line does, through
:func:`vrcal.fileio.atomic_savefig`). Import pyplot lazily so the backend can be chosen
first.

* Fig. 4: epsilon vs T, Eq. (7).
* Fig. 5: epsilon vs v_A2 for three x_A, x_B and v_B2 fixed, Eqs. (6) and (7).
* Fig. 6: epsilon vs x_A for three v_A2, x_B and v_B2 fixed, Eqs. (6) and (7).
* Fig. 7: v vs x of one ball's virtual bodies, v = x/(2T) (Eq. 10) for epsilon min,
  nominal, max of its drop test (Eq. 9), T from Eq. (7); x from 0 to the ball's radius.

Departures from [1]
-------------------
[1] does not state the values it used for Figs. 4-6 (K, x_B, v_B2, the three x_A and
v_A2, the ranges); vrcal's defaults are listed in :data:`FIG5_DEFAULTS` and
:data:`FIG6_DEFAULTS` and printed in each legend and title. [1]'s Fig. 7 shows one
line for the basketball; vrcal shows the epsilon min..max band of the drop test, and says on
the figure that T and (x, v) are the model's (they depend on the assumed K), not measured.
"""

from __future__ import annotations

import numpy as np

from vrcal.errors import UsageError
from vrcal.inverse import DEFAULT_K_PER_S, check_K
from vrcal.model import restitution as eq
from vrcal.model.standards import ball_epsilon, get_ball

#: Fig. 5: body B fixed, three depths of body A, its speed varied.
FIG5_DEFAULTS = {"x_b_m": 0.01, "v_b_m_per_s": 0.1, "x_a_m": (0.005, 0.01, 0.02), "v_a_range_m_per_s": (0.01, 0.5)}
#: Fig. 6: body B fixed, three speeds of body A, its depth varied.
FIG6_DEFAULTS = {"x_b_m": 0.01, "v_b_m_per_s": 0.1, "v_a_m_per_s": (0.05, 0.1, 0.2), "x_a_range_m": (0.0, 0.05)}
#: Number of points per curve.
N_POINTS = 200

#: Fig. 7's label: its contact times and (x, v) lines are the model's, not measured.
MODEL_ONLY_NOTE = ("model only: the drop test measures ε alone;\nT = −ln ε / K and the (x, v) lines "
                   "assume K = {K:g} 1/s")

#: File names written by ``vrcal plot curves`` (fig7 gets the ball key appended).
FILE_NAMES = {
    "fig4": "fig4_epsilon_vs_T.png",
    "fig5": "fig5_epsilon_vs_vA.png",
    "fig6": "fig6_epsilon_vs_xA.png",
    "fig7": "fig7_family_{ball}.png",
}


#: What each file of ``vrcal plot curves`` shows (printed beside its path).
DESCRIPTIONS = {
    "fig4": "Fig. 4: ε = exp(−K T) (Eq. 7)",
    "fig5": "Fig. 5: ε against v_A2 for three x_A (Eqs. 6, 7)",
    "fig6": "Fig. 6: ε against x_A for three v_A2 (Eqs. 6, 7)",
    "fig7": "Fig. 7: the {ball}'s virtual bodies v = x/(2T) (model only)",
}


def _new_ax(ax):
    if ax is not None:
        return ax
    import matplotlib.pyplot as plt

    _fig, ax = plt.subplots(figsize=(6.4, 4.8))
    return ax


def _style(ax, xlabel, ylabel, title):
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    ax.set_title(title, fontsize=10)
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8)
    return ax


def _range(name, lo_hi, allow_zero=False):
    lo, hi = (float(v) for v in lo_hi)
    if not (np.isfinite(lo) and np.isfinite(hi) and hi > lo and (lo >= 0 if allow_zero else lo > 0)):
        bound = ">= 0" if allow_zero else "> 0"
        raise UsageError(f"{name} must be (low, high) with {bound} low < high, got ({lo:g}, {hi:g})")
    return lo, hi


def plot_epsilon_vs_T(K_per_s=DEFAULT_K_PER_S, T_max_s=None, ax=None):
    """Fig. 4 of [1]: epsilon = exp(-K T), Eq. (7).

    Parameters
    ----------
    K_per_s : float
        rate constant K [1/s], > 0
    T_max_s : float, optional
        largest contact time shown [s], > 0; default 4/K (epsilon down to exp(-4) = 0.018)
    ax : matplotlib Axes, optional

    Returns
    -------
    ax : matplotlib Axes
        one line
    """
    K = check_K(K_per_s)
    T_max = 4.0 / K if T_max_s is None else _range("T_max_s", (0.0, T_max_s), allow_zero=True)[1]
    ax = _new_ax(ax)
    T = np.linspace(0.0, T_max, N_POINTS)
    ax.plot(T, eq.epsilon_from_contact_time(T, K), label=f"K = {K:g} 1/s")
    ax.set_xlim(0.0, T_max)
    ax.set_ylim(0.0, 1.02)
    return _style(ax, "contact time of the virtual bodies T [s]", "coefficient of restitution ε [-]",
                  r"Fig. 4: $\varepsilon = e^{-KT}$ (Eq. 7)")


def plot_epsilon_vs_v_a(K_per_s=DEFAULT_K_PER_S, x_a_m=FIG5_DEFAULTS["x_a_m"], x_b_m=FIG5_DEFAULTS["x_b_m"],
                        v_b_m_per_s=FIG5_DEFAULTS["v_b_m_per_s"],
                        v_a_range_m_per_s=FIG5_DEFAULTS["v_a_range_m_per_s"], ax=None):
    """Fig. 5 of [1]: epsilon vs the speed v_A2 of body A's virtual body, Eqs. (6) and (7).

    Parameters
    ----------
    K_per_s : float
        rate constant K [1/s], > 0
    x_a_m : sequence of float
        depths of body A's virtual body [m], >= 0, one line each
    x_b_m : float
        depth of body B's virtual body [m], >= 0
    v_b_m_per_s : float
        speed of body B's virtual body [m/s], > 0
    v_a_range_m_per_s : (float, float)
        range of v_A2 [m/s], 0 < low < high
    ax : matplotlib Axes, optional

    Returns
    -------
    ax : matplotlib Axes
        one line per x_A
    """
    K = check_K(K_per_s)
    lo, hi = _range("v_a_range_m_per_s", v_a_range_m_per_s)
    ax = _new_ax(ax)
    v_a = np.linspace(lo, hi, N_POINTS)
    for x_a in x_a_m:
        eps = eq.epsilon_pair(x_a, v_a, x_b_m, v_b_m_per_s, K)
        ax.plot(v_a, np.broadcast_to(eps, v_a.shape), label=f"$x_A$ = {x_a:g} m")
    ax.set_xlim(lo, hi)
    ax.set_ylim(0.0, 1.02)
    title = (r"Fig. 5: $\varepsilon = \exp[-K(\frac{x_A}{2v_{A2}} + \frac{x_B}{2v_{B2}})]$ (Eqs. 6, 7)"
             f"\n$x_B$ = {x_b_m:g} m, $v_{{B2}}$ = {v_b_m_per_s:g} m/s, K = {K:g} 1/s")
    return _style(ax, "speed of virtual body A2, $v_{A2}$ [m/s]", "coefficient of restitution ε [-]", title)


def plot_epsilon_vs_x_a(K_per_s=DEFAULT_K_PER_S, v_a_m_per_s=FIG6_DEFAULTS["v_a_m_per_s"],
                        x_b_m=FIG6_DEFAULTS["x_b_m"], v_b_m_per_s=FIG6_DEFAULTS["v_b_m_per_s"],
                        x_a_range_m=FIG6_DEFAULTS["x_a_range_m"], ax=None):
    """Fig. 6 of [1]: epsilon vs the depth x_A of body A's virtual body, Eqs. (6) and (7).

    Parameters
    ----------
    K_per_s : float
        rate constant K [1/s], > 0
    v_a_m_per_s : sequence of float
        speeds of body A's virtual body [m/s], > 0, one line each
    x_b_m : float
        depth of body B's virtual body [m], >= 0
    v_b_m_per_s : float
        speed of body B's virtual body [m/s], > 0
    x_a_range_m : (float, float)
        range of x_A [m], 0 <= low < high
    ax : matplotlib Axes, optional

    Returns
    -------
    ax : matplotlib Axes
        one line per v_A2
    """
    K = check_K(K_per_s)
    lo, hi = _range("x_a_range_m", x_a_range_m, allow_zero=True)
    ax = _new_ax(ax)
    x_a = np.linspace(lo, hi, N_POINTS)
    for v_a in v_a_m_per_s:
        eps = eq.epsilon_pair(x_a, v_a, x_b_m, v_b_m_per_s, K)
        ax.plot(x_a, np.broadcast_to(eps, x_a.shape), label=f"$v_{{A2}}$ = {v_a:g} m/s")
    ax.set_xlim(lo, hi)
    ax.set_ylim(0.0, 1.02)
    title = (r"Fig. 6: $\varepsilon = \exp[-K(\frac{x_A}{2v_{A2}} + \frac{x_B}{2v_{B2}})]$ (Eqs. 6, 7)"
             f"\n$x_B$ = {x_b_m:g} m, $v_{{B2}}$ = {v_b_m_per_s:g} m/s, K = {K:g} 1/s")
    return _style(ax, "depth of virtual body A2, $x_A$ [m]", "coefficient of restitution ε [-]", title)


def plot_ball_family(ball="basketball", K_per_s=DEFAULT_K_PER_S, as_paper=False, standards=None, ax=None):
    """Fig. 7 of [1]: the virtual bodies (x, v) of a ball, v = x/(2T), Eqs. (7), (9), (10).

    Parameters
    ----------
    ball : Ball or str
        a ball of the standards, or its key
    K_per_s : float
        rate constant K [1/s], > 0
    as_paper : bool
        epsilon from the paper's Table 1 heights as printed (see
        :func:`vrcal.model.standards.ball_epsilon`)
    standards : dict, optional
        where to look a ball key up; the shipped standards when None
    ax : matplotlib Axes, optional

    Returns
    -------
    ax : matplotlib Axes
        three lines (epsilon min, nominal, max) and the band between min and max,
        x from 0 to the ball's nominal radius
    """
    if isinstance(ball, str):
        ball = get_ball(ball, standards)
    K = check_K(K_per_s)
    window = ball_epsilon(ball, as_paper=as_paper)
    if window.max >= 1.0:
        raise UsageError(f"'{ball.key}' has epsilon max = 1: T = 0 and v is unbounded; nothing to plot")
    R = ball.radius_m
    x = np.linspace(0.0, R, N_POINTS)
    T = {k: eq.contact_time_from_epsilon_s(e, K) for k, e in window.as_dict().items()}
    # v = x/(2T) is Eq. (10) solved for v; x = 0 (on the surface) gives v = 0.
    v = {k: np.concatenate([[0.0], eq.virtual_speed_m_per_s(x[1:], t)]) for k, t in T.items()}
    ax = _new_ax(ax)
    # one ε (the paper's basketball prints no max): one line, no band
    levels = ("nominal",) if window.max - window.min < 5e-4 else ("max", "nominal", "min")
    if len(levels) > 1:
        ax.fill_between(x, v["min"], v["max"], color="C0", alpha=0.2,
                        label=f"ε {window.min:.3f}..{window.max:.3f} (drop-test window)")
    styles = {"min": ("C0", "--"), "nominal": ("C1", "-"), "max": ("C2", "--")}
    for k in levels:
        color, ls = styles[k]
        ax.plot(x, v[k], color=color, ls=ls,
                label=f"ε {k} = {window.as_dict()[k]:.3f}, T = {T[k] * 1e3:.1f} ms")
    ax.set_xlim(0.0, R)
    ax.set_ylim(0.0, None)
    ax.text(0.98, 0.03, MODEL_ONLY_NOTE.format(K=K), transform=ax.transAxes, ha="right", va="bottom", fontsize=7,
            bbox={"boxstyle": "round", "fc": "white", "ec": "0.6", "alpha": 0.9})
    source = "paper's Table 1 as printed" if as_paper else "bottom-to-bottom heights"
    title = (rf"Fig. 7: {ball.name}, $v = x/(2T)$ (Eq. 10), $T = -\ln\varepsilon/K$ (Eq. 7)"
             f"\nK = {K:g} 1/s, ε from Eq. 9 ({source}), x up to R = {R:.3g} m")
    return _style(ax, "depth of the virtual body x [m]", "speed of the virtual body v [m/s]", title)


def curve_figures(K_per_s=DEFAULT_K_PER_S, ball="basketball", as_paper=False, standards=None):
    """The four figures of ``vrcal plot curves``, each a new matplotlib Figure.

    Parameters
    ----------
    K_per_s : float
        rate constant K [1/s], > 0
    ball : str
        ball of Fig. 7
    as_paper : bool
        Fig. 7 uses the paper's Table 1 heights as printed
    standards : dict, optional
        the standards to look the ball up in; the shipped ones when None

    Returns
    -------
    dict
        file name -> Figure, sorted by name (the caller saves and closes them); each Figure's
        ``vrcal_description`` says what it shows (from :data:`DESCRIPTIONS`)
    """
    import matplotlib.pyplot as plt

    K = check_K(K_per_s)
    b = get_ball(ball, standards) if isinstance(ball, str) else ball
    makers = {
        FILE_NAMES["fig4"]: lambda ax: plot_epsilon_vs_T(K, ax=ax),
        FILE_NAMES["fig5"]: lambda ax: plot_epsilon_vs_v_a(K, ax=ax),
        FILE_NAMES["fig6"]: lambda ax: plot_epsilon_vs_x_a(K, ax=ax),
        FILE_NAMES["fig7"].format(ball=b.key): lambda ax: plot_ball_family(b, K, as_paper=as_paper, ax=ax),
    }
    descriptions = {FILE_NAMES[k].format(ball=b.key): DESCRIPTIONS[k].format(ball=b.key) for k in FILE_NAMES}
    figures = {}
    try:
        for name in sorted(makers):
            fig, ax = plt.subplots(figsize=(6.4, 4.8))
            figures[name] = fig
            fig.vrcal_description = descriptions[name]
            makers[name](ax)
            fig.tight_layout()
    except BaseException:
        for fig in figures.values():
            plt.close(fig)
        raise
    return figures
