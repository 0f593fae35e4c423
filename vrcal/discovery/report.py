"""The text report and the figure of ``vrcal discover`` (a :class:`vrcal.discovery.ranking.Discovery`).

:func:`fit_report` writes a sectioned text report in the manner of lmfit's
``fit_report``: [[Data]], [[Baseline]], [[Candidates]], [[Named effects]], [[Gap]],
[[Engine]], [[Notes]]. The plot functions take ``ax=None`` and return the ax;
:func:`discovery_figure` draws both panels on a new figure. This module never writes
files (the command line saves with :func:`vrcal.fileio.atomic_savefig`).
"""

from __future__ import annotations

import math

import numpy as np

#: File names written by ``vrcal discover --report DIR``.
REPORT_FILES = {"text": "report.txt", "figure": "discover.png", "json": "discover.json"}

_UNIT_SCALE = {"m": (1e3, "mm"), "s": (1e3, "ms")}


def _fmt_gap(value, unit):
    scale, name = _UNIT_SCALE[unit]
    return f"{value * scale:.3f} {name}"


def _pm(value, unc, unit=""):
    unit = "" if unit in ("", "1") else f" {unit}"
    if unc is None or not math.isfinite(unc) or unc <= 0:
        return f"{value:.6g}{unit}"
    digits = max(0, 2 - int(math.floor(math.log10(unc))) - 1)
    digits = min(digits, 9)
    return f"{value:.{digits}f} +/- {unc:.2g}{unit}"


def reference_sigma(discovery):
    """σ [data unit] used for the χ² column: the data's noise floor, else the final model's
    residual standard deviation sqrt(RSS/(n - k))."""
    if discovery.noise_floor:
        return float(discovery.noise_floor)
    f = discovery.final
    return math.sqrt(f.rss / max(f.n - f.k, 1))


def _param_lines(fit, effect, indent="    "):
    from vrcal.drop.effects import EFFECTS

    lines = []
    for p, v, u in zip(fit.layout, fit.values, fit.uncertainties):
        if p.effect != effect:
            continue
        label = p.name if effect is None else p.name
        unit = "" if p.unit in ("", "1") else f" {p.unit}"
        extra = ""
        if effect is not None:
            density = EFFECTS[effect].parameter(p.name).prior_description(fit.problem.ball)
            extra = f"   (prior {p.prior[0]:g} .. {p.prior[1]:g}{unit}; density {density})"
        lines.append(f"{indent}{label:<24s} = {_pm(float(v), float(u), p.unit)}{extra}")
    return lines


def _odds_text(odds):
    return ", ".join(f"{r} {o:.3g}:1" if o < 1e4 else f"{r} >1e4:1" for r, o in odds.items())


def fit_report(discovery):
    """The sectioned text report of a discovery (a string ending with a newline)."""
    from vrcal.drop.effects import EFFECTS

    d = discovery
    unit = d.unit
    data = d.data
    ball = d.ball
    sigma = reference_sigma(d)
    lines = ["[[Data]]"]
    lines.append(f"    source       = {data.source}")
    lines.append(f"    kind         = {data.kind} ({d.baseline.n} data; residuals in {unit})")
    lines.append(f"    ball         = {getattr(ball, 'name', 'ball')} (m = {float(ball.mass_kg):.4g} kg, "
                 f"D = {float(ball.diameter_m):.4g} m)")
    lines.append(f"    g            = {d.g_m_per_s2:.6g} m/s^2 (known)")
    if d.noise_floor:
        lines.append(f"    noise floor  = {_fmt_gap(d.noise_floor, unit)} ({d.noise_source or 'given'})")
    else:
        lines.append(f"    noise floor  = unknown; final model's residual sigma {_fmt_gap(sigma, unit)} is used")
    for note in getattr(data, "notes", ()) or ():
        lines.append(f"    reader note  : {note}")
    lines.append("[[Baseline]]  the paper's model: constant epsilon (Eq. (3) of [1]), g known")
    lines += _param_lines(d.baseline, None)
    b = d.baseline
    lines.append(f"    gap (RMS)                = {_fmt_gap(b.gap, unit)}   chi-square = {b.rss / sigma**2:.1f}   "
                 f"BIC = {b.bic:.1f}   (n = {b.n}, k = {b.k})")
    th = d.thresholds
    lines.append("[[Candidates]]  ranked within each round by the evidence Z (Laplace; prior densities of the "
                 "registry); d2lnZ = 2 ln(Z_best/Z)")
    lines.append("                (0 = best; odds exp(d2lnZ/2) against); material = dBIC >= "
                 f"{th.delta_bic:g}, p <= {th.p_value:g} (chi2 or F test),")
    lines.append(f"                parameter inside its prior, gap x{th.gap_factor:g} or "
                 f"{th.removed_noise_fraction:g} noise floor removed; the material one with the highest Z is named")
    scale, uname = _UNIT_SCALE[unit]
    head = (f"    {'rnd':>3s}  {'effect':<31s} {'k':>2s} {'RSS':>10s} {'chi2':>10s} {'AIC':>10s} {'BIC':>10s} "
            f"{'dBIC':>8s} {'d2lnZ':>8s} {'gap ' + uname:>10s}  verdict")
    lines.append(head)
    best = {}
    for c in d.candidates:
        best[c.round] = min(best.get(c.round, math.inf), c.score)
    for c in d.candidates:
        f = c.fit
        lines.append(f"    {c.round:>3d}  {c.name:<31s} {f.k:>2d} {f.rss:>10.3e} {f.rss / sigma**2:>10.1f} "
                     f"{f.aic:>10.1f} {f.bic:>10.1f} {c.delta_bic:>8.1f} {c.score - best[c.round]:>8.1f} "
                     f"{f.gap * scale:>10.3f}  {c.verdict}")
    lines.append("[[Named effects]]")
    from vrcal.discovery.ranking import MISFIT_FACTOR

    misfit = d.noise_floor and d.gap_after > MISFIT_FACTOR * d.noise_floor
    if not d.effects and not misfit:
        lines.append("    none: the constant-epsilon baseline explains the data down to the noise")
    elif not d.effects:
        lines.append(f"    none material -- but the baseline does NOT fit: its gap is {d.gap_after / d.noise_floor:.0f} "
                     f"times the noise floor (see [[Notes]])")
    for name in d.effects:
        eff = EFFECTS[name]
        lines.append(f"    {name}: {eff.equation}")
        lines += _param_lines(d.final, name, indent="        ")
        lines.append(f"        ({eff.description})")
        if name in d.ambiguous:
            odds = d.ambiguous_odds.get(name, {})
            lines.append(f"        AMBIGUOUS: {', '.join(d.ambiguous[name])} also explain(s) these {data.kind} data; "
                         f"a trajectory tells them apart")
            if odds:
                lines.append(f"        posterior odds for {name} (registry priors): {_odds_text(odds)}")
    lines.append("[[Gap]]  RMS of data - model")
    lines.append(f"    before = {_fmt_gap(d.gap_before, unit)}, after = {_fmt_gap(d.gap_after, unit)}"
                 + (f", noise floor = {_fmt_gap(d.noise_floor, unit)}" if d.noise_floor else ""))
    before, after = d.gap_per_bounce()
    label = "flight" if data.kind == "trajectory" else ("impact" if data.kind == "impacts" else "bounce")
    lines.append(f"    {label:>8s} {'before ' + uname:>12s} {'after ' + uname:>12s}")
    idx = (np.asarray(data.bounce) if data.kind == "apexes"
           else np.arange(len(before)) + (0 if data.kind == "trajectory" else 1))
    for i, bb, aa in zip(idx, before, after):
        lines.append(f"    {int(i):>8d} {bb * scale:>12.3f} {aa * scale:>12.3f}")
    lines.append("[[Engine]]")
    lines += ["    " + s for s in engine_advice(d)]
    if d.notes:
        lines.append("[[Notes]]")
        lines += [f"    {n}" for n in d.notes]
    lines.append("[1] The Graphical Method for Decision of Restitution Coefficient and Its Applications.")
    return "\n".join(lines) + "\n"


def engine_advice(discovery):
    """Lines saying which ε to put in a physics engine, and why."""
    d = discovery
    f = d.final
    eps = d.epsilon
    i_eps = [p.key for p in f.layout].index("epsilon")
    out = [f"epsilon = {_pm(eps, float(f.uncertainties[i_eps]))}  (the extended model's contact restitution)"]
    if not d.effects:
        out.append("The baseline suffices: this constant epsilon reproduces the record in any engine.")
        return out
    drops = f.model()
    v = np.asarray(drops.impact_speeds_m_per_s)[0]
    e = np.asarray(drops.epsilons)[0]
    if "velocity_dependent_restitution" in d.effects:
        out.append(f"epsilon depends on the impact speed; it is {eps:.4f} at the first impact speed "
                   f"{v[0]:.2f} m/s and {e[min(len(e) - 1, 4)]:.4f} at {v[min(len(v) - 1, 4)]:.2f} m/s:")
        out.append("choose the value at the impact speeds of your simulation.")
    if "air_drag" in d.effects:
        out.append("Use it in an engine that also applies the air drag found here (a force -k v|v|);")
        out.append(f"an engine without drag reproduces the observed bounce heights better with the baseline's "
                   f"effective epsilon = {d.epsilon_baseline:.4f}")
        out.append("(it folds the flight losses into the contact).")
    elif "height_offset" in d.effects or "contact_duration" in d.effects:
        out.append(f"The baseline's epsilon {d.epsilon_baseline:.4f} is biased by the effect(s) named above; "
                   f"use {eps:.4f}.")
    return out


# --------------------------------------------------------------------------- figure


def _new_ax(ax):
    if ax is not None:
        return ax
    from matplotlib.figure import Figure

    return Figure(figsize=(7.0, 4.0)).add_subplot()


def _effects_label(d):
    return "baseline + " + " + ".join(d.effects) if d.effects else "baseline (no effect named)"


def plot_fit(discovery, ax=None):
    """Data, baseline and extended model: heights vs time (trajectory), impact intervals vs
    impact number (impacts) or apex heights vs bounce (apexes). Returns the ax."""
    ax = _new_ax(ax)
    d = discovery
    data = d.data
    if data.kind == "trajectory":
        t = np.asarray(data.t_s, dtype=float)
        ax.plot(t, data.y_m, ".", ms=2.5, color="0.35", label=f"data ({data.source})")
        tt = np.linspace(t[0], t[-1], max(2000, 4 * t.size))
        ax.plot(tt, d.baseline.predict_at(tt), "-", lw=1.0, color="tab:orange", label="baseline (constant ε)")
        ax.plot(tt, d.final.predict_at(tt), "-", lw=1.2, color="tab:blue", label=_effects_label(d))
        ax.set_xlabel("time t [s]")
        ax.set_ylabel("height y [m]")
    elif data.kind == "impacts":
        t = np.asarray(data.t_s, dtype=float)
        n = np.arange(2, t.size + 1)
        ax.plot(n, np.diff(t) * 1e3, "o", color="0.35", label=f"data ({data.source})")
        for fit, style, color, label in ((d.baseline, "--", "tab:orange", "baseline (constant ε)"),
                                         (d.final, "-", "tab:blue", _effects_label(d))):
            model = t - fit.residuals
            ax.plot(n, np.diff(model) * 1e3, style, marker=".", color=color, label=label)
        ax.set_xlabel("impact number")
        ax.set_ylabel("interval to the previous impact [ms]")
    else:
        b = np.asarray(data.bounce)
        h = np.asarray(data.h_m, dtype=float)
        ax.semilogy(b, h, "o", color="0.35", label=f"data ({data.source})")
        for fit, style, color, label in ((d.baseline, "--", "tab:orange", "baseline (constant ε)"),
                                         (d.final, "-", "tab:blue", _effects_label(d))):
            ax.semilogy(b, h - fit.residuals, style, marker=".", color=color, label=label)
        ax.set_xlabel("bounce")
        ax.set_ylabel("apex height [m]")
    ax.set_title(f"vrcal discover: {', '.join(d.effects) or 'no effect named'}; ε = {d.epsilon:.4f}", fontsize=10)
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8)
    return ax


def plot_residuals(discovery, ax=None):
    """Residuals (data - model) of the baseline and of the extended model. Returns the ax."""
    ax = _new_ax(ax)
    d = discovery
    data = d.data
    scale, uname = _UNIT_SCALE[d.unit]
    if data.kind == "trajectory":
        x = np.asarray(data.t_s, dtype=float)
        xlabel, style = "time t [s]", "."
    elif data.kind == "impacts":
        x = np.arange(1, len(data.t_s) + 1)
        xlabel, style = "impact number", "o"
    else:
        x = np.asarray(data.bounce)
        xlabel, style = "bounce", "o"
    ax.plot(x, d.baseline.residuals * scale, style, ms=3, color="tab:orange",
            label=f"before: RMS {d.gap_before * scale:.3g} {uname}")
    ax.plot(x, d.final.residuals * scale, style, ms=3, color="tab:blue",
            label=f"after: RMS {d.gap_after * scale:.3g} {uname}")
    if d.noise_floor:
        ax.axhspan(-d.noise_floor * scale, d.noise_floor * scale, color="0.85", zorder=0, label="noise floor ±1σ")
    ax.axhline(0.0, color="0.3", lw=0.8)
    ax.set_xlabel(xlabel)
    ax.set_ylabel(f"data - model [{uname}]")
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8)
    return ax


def discovery_figure(discovery):
    """A new matplotlib Figure: :func:`plot_fit` above :func:`plot_residuals`."""
    from matplotlib.figure import Figure

    fig = Figure(figsize=(8.0, 7.0), constrained_layout=True)
    ax1, ax2 = fig.subplots(2, 1, gridspec_kw={"height_ratios": [3, 2]})
    plot_fit(discovery, ax1)
    plot_residuals(discovery, ax2)
    return fig

