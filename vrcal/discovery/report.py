"""The report and the figure of ``vrcal discover`` (a :class:`vrcal.discovery.ranking.Discovery`).

:func:`fit_report` is written for people: it opens with the answer in plain words ("Air drag
matters here: C_d = 0.38 ± 0.01. With it the gap falls from 60 mm to 4.1 mm; noise is
0.5 mm."), then the verdict, the ε to put in an engine, the named effects with their physical
limits, the runs of a joint fit, and the notes -- every line at most
:data:`vrcal.textout.MAX_COLUMNS` wide, every statement following the one verdict
(:func:`vrcal.discovery.ranking.verdict`). ``details=True`` adds the statistics of every
candidate (χ², AIC, BIC, ΔBIC, p, evidence) and the gap per bounce. The plot functions take
``ax=None`` and return the ax; :func:`discovery_figure` draws both panels on a new figure.
This module never writes files (the command line saves them).
"""

from __future__ import annotations

import math
import textwrap

import numpy as np

from vrcal.discovery.ranking import DRAG_OR_SPEED_LAW, odds_text
from vrcal.model.restitution import SPHERE_DRAG_COEFFICIENT
from vrcal.textout import MAX_COLUMNS, mass, ms, number, table

#: File names written by ``vrcal discover --report DIR``.
REPORT_FILES = {"text": "report.txt", "figure": "discover.png", "json": "discover.json"}

_UNIT_SCALE = {"m": (1e3, "mm"), "s": (1e3, "ms")}

#: How the answer names each effect, and the symbol of its parameter.
PHRASES = {
    "air_drag": ("air drag", "C_d"),
    "velocity_dependent_restitution": ("a speed-dependent epsilon", "exponent p"),
    "contact_duration": ("the contact's duration", "tau_c"),
    "height_offset": ("a height offset (the tracked point is not the ball's bottom)", "offset"),
    "buoyancy": ("buoyancy and the air's added mass", "rho_air"),
    "rolling_shutter": ("a camera's rolling shutter (rows read one after another)", "kappa"),
}

#: Short names of the effects in the --details tables (a legend is printed with them).
SHORT = {"air_drag": "drag", "velocity_dependent_restitution": "eps(v)", "contact_duration": "contact",
         "height_offset": "offset", "buoyancy": "buoyancy", "rolling_shutter": "shutter"}


def _fmt_gap(value, unit):
    """A gap in mm or ms, three significant digits: ``_fmt_gap(0.0596, 'm') == '59.6 mm'``."""
    scale, name = _UNIT_SCALE[unit]
    return f"{number(value * scale, 3) if abs(value) > 1e-12 else '0'} {name}"


def _si_scale(unit):
    """(factor, unit shown) for a parameter unit: seconds in ms, metres in mm."""
    return {"s": (1e3, "ms"), "m": (1e3, "mm")}.get(unit, (1.0, "" if unit in ("", "1") else unit))


def pm(value, unc, unit=""):
    """``value ± unc`` with the uncertainty to 1-2 significant digits, in ms / mm for s / m.

    ``pm(0.38312, 0.0016) == '0.3831 ± 0.0016'``; ``pm(0.005078, 3.9e-5, 's') == '5.078 ± 0.039 ms'``.
    """
    factor, shown = _si_scale(unit)
    v = float(value) * factor
    tail = f" {shown}" if shown else ""
    if unc is None or not math.isfinite(unc) or unc <= 0:
        return f"{number(v, 4)}{tail}"
    u = float(unc) * factor
    digits = 1 - int(math.floor(math.log10(u)))
    if digits > 9:   # a noise-free record: the value is exact to far more digits than anyone needs
        return f"{number(v, 6)} ± {u:.1g}{tail}"
    digits = max(0, digits)
    return f"{v:.{digits}f} ± {u:.{digits}f}{tail}"


def _law_values(d, speeds, fit=None):
    """A speed law's ε at these speeds [m/s] as the report lists them: each with its ± (:meth:`Discovery.
    epsilon_at_uncertainty`, :func:`pm`). Four bare decimals for a trajectory the law does not reproduce put
    "0.8504 at 0.99 m/s" beside a ± of 0.02 (the truth 0.820). ``fit``: another model's law than the final
    model's (the prior split: its ε at each speed with its ±, as :func:`_split_advice` gives them)."""
    if fit is None or fit is d.final:
        eps, unc = d.epsilon_at(speeds), d.epsilon_at_uncertainty(speeds)
    else:
        eps, unc = d.epsilon_at(speeds, fit=fit), np.full(len(speeds), d.recommended_epsilon_uncertainty)
    return [f"{pm(e, u)} at {v:.2f} m/s" for v, e, u in zip(speeds, eps, unc)]


def _limits_text(lo, hi, unit):
    factor, shown = _si_scale(unit)
    tail = f" {shown}" if shown else ""
    return f"{number(lo * factor, 3)} to {number(hi * factor, 3)}{tail}"


def _wrap(text, indent="", first=None):
    return textwrap.fill(text, width=MAX_COLUMNS, initial_indent=indent if first is None else first,
                         subsequent_indent=indent, break_long_words=True, break_on_hyphens=False)


def _effects_phrase(names):
    words = [PHRASES[n][0] for n in names]
    if len(words) == 1:
        return words[0]
    return ", ".join(words[:-1]) + " and " + words[-1]


def _param_values(d, name):
    from vrcal.drop.effects import EFFECTS

    out = []
    values, uncs = d.final.effect_values.get(name, {}), d.final.effect_uncertainties.get(name, {})
    for p in EFFECTS[name].parameters:
        out.append(f"{PHRASES[name][1]} = {pm(values[p.name], uncs.get(p.name), p.unit)}")
    return out


def _noise_text(d):
    """What the gap is compared with, as a phrase: 'noise is 0.513 mm (measured from the samples)'."""
    from vrcal.discovery.ranking import GRID_SOURCE, INSTRUMENT_SOURCE, REPLICATE_SOURCE

    unit = d.unit
    src = "measured from the samples" if d.noise_source.startswith("third") else (
        "given" if d.noise_source == "given" else
        ("measured: the scatter of repeated trials" + (", at least the heights' written step / sqrt(12)"
                                                       if d.noise_source != REPLICATE_SOURCE else ""))
        if d.noise_source.startswith(REPLICATE_SOURCE) else
        "the grid the times were read on" if d.noise_source == GRID_SOURCE else
        INSTRUMENT_SOURCE if d.noise_source.startswith(INSTRUMENT_SOURCE) else "assumed")
    grows = d.height_dependent_noise
    if grows is not None:
        src += (f"; it grows with the height, about {number(100 * grows['relative'], 2)} % of it, and the ± of "
                f"epsilon takes each rebound at its own")
    if d.decimation > 1 and d.noise_source.startswith("third"):
        src = f"measured on all {d.n_read:,} samples"
    if "systematic error" in d.noise_source:
        src += " with the tracker's systematic error"
    if src == "assumed" and d.kind == "apexes":
        why = d.noise_source[len("assumed ("):d.noise_source.index(")")] if d.noise_source.startswith("assumed (") \
            else ""
        src = f"assumed{': ' + why if why else ''}; " + (
            "repeat trials at each drop height to measure it, or give --noise" if len(d.runs) > 1 else "give --noise")
    noise = f"{_fmt_gap(d.noise_floor, unit)} ({src})" if d.noise_floor else "unknown"
    if d.scatter_gap and d.scatter_gap > (d.noise_floor or 0) and d.scatter_assumed:
        return (f"a bounce-to-bounce scatter of {number(100 * d.scatter, 2)} %, which real balls have and these "
                f"times cannot rule out, leaves {_fmt_gap(d.scatter_gap, unit)}; timing noise {noise}")
    if d.scatter_gap and d.scatter_gap > (d.noise_floor or 0):
        return (f"the record's own scatter leaves {_fmt_gap(d.scatter_gap, unit)} (its impact intervals vary by "
                f"{number(100 * d.scatter, 2)} % from bounce to bounce; timing noise {noise})")
    return f"noise is {noise}"


#: What would leave something to test an effect with, per data kind (a record with as many data as parameters);
#: apex heights by what the runs hold (:func:`_more_data`): one drop or several, one rebound each or more.
MORE_DATA = {"trajectory": "a longer record (more bounces)",
             "impacts": "more impact times (a quieter room, the phone nearer the floor), or several drops at once",
             ("apexes", "one drop", "one rebound"): "a second rebound, or drops from other heights (a drop table)",
             ("apexes", "one drop", "rebounds"): "more rebounds, or drops from other heights (a drop table)",
             ("apexes", "drops", "one rebound"): "more drop heights, or a second rebound per drop,",
             ("apexes", "drops", "rebounds"): "more drop heights, or more rebounds per drop,"}


def _more_data(d):
    """The phrase of :data:`MORE_DATA` for the record of discovery ``d``."""
    if d.kind != "apexes":
        return MORE_DATA[d.kind]
    rebounds = "one rebound" if max(run.h_m.size for run in d.runs) <= 2 else "rebounds"
    return MORE_DATA[("apexes", "one drop" if len(d.runs) == 1 else "drops", rebounds)]


#: What a record holds, per data kind, as a phrase.
RECORD_OF_KIND = {"trajectory": "this trajectory", "impacts": "these impact times", "apexes": "these apex heights"}


def answer(discovery):
    """The answer in plain words: the first paragraph of the report (one string, not wrapped)."""
    d = discovery
    unit = d.unit
    v = d.verdict
    before, after = _fmt_gap(d.gap_before, unit), _fmt_gap(d.gap_after, unit)
    parts = []
    if v == "suspect input":
        parts.append("Suspect input (see the verdict): the numbers below assume the input is right.")
    if d.effects:
        phrase = _effects_phrase(d.effects)
        params = ", ".join(p for name in d.effects for p in _param_values(d, name))
        verb = "matters" if len(d.effects) == 1 else "matter"
        parts.append(f"{phrase[0].upper() + phrase[1:]} {verb} here: {params}.")
        it = "it" if len(d.effects) == 1 else "them"
        parts.append(f"With {it} the gap falls from {before} to {after}; {_noise_text(d)}.")
        moved = _named_with_held(d)
        if moved:
            parts.append(moved)
        if any(name in d.ambiguous for name in d.effects):
            rivals = sorted({r for name in d.effects for r in d.ambiguous.get(name, ())})
            drops = "drops over a wider range of heights" if len(d.runs) > 1 else "drops from several heights"
            parts.append(f"But {_effects_phrase(rivals)} would explain {RECORD_OF_KIND[d.kind]} about as well "
                         f"(ambiguous; {'a trajectory or ' if d.kind != 'trajectory' else ''}{drops} tell them "
                         f"apart).")
            if d.split is not None:
                parts.append(f"Most probable is {_effects_phrase(list(d.split.effects))} together, shared as "
                             f"their prior densities say: its epsilon, in the advice for an engine below, is the "
                             f"one to use.")
    elif not d.rounds:
        n, k = d.final.n, d.final.k
        parts.append(f"{n} data and {k} parameters: the paper's constant-epsilon model gives epsilon = "
                     f"{pm(d.epsilon, d.final.uncertainty('epsilon'))} and nothing is left to test an effect "
                     f"with; {_more_data(d)} would.")
        if v == "unexplained":
            parts.append(f"Yet it leaves a gap of {after} ({_noise_text(d)}): it does not reproduce this record.")
        if d.kind == "apexes":
            # 'alone' where the engine section's systematic line holds a speed law beside the drag: two numbers
            # with drag, each saying what it holds
            held = (d.systematic or {}).get("held", {})
            alone = " alone" if len(held) > 1 and "air_drag.drag_coefficient" in held else ""
            if not _excluded_drag_lines(d):
                parts.append(f"With a sphere's air drag{alone} (C_d = {SPHERE_DRAG_COEFFICIENT:g}) the same "
                             f"heights give epsilon = {d.epsilon_with_sphere_drag:.4f}.")
    else:
        if v == "explained" or (v == "suspect input" and d.reproduces):
            parts.append(f"The paper's constant-epsilon model explains this record: epsilon = "
                         f"{pm(d.epsilon, d.epsilon_uncertainty)}. Its gap, {after}, is within what the "
                         f"record allows: {_noise_text(d)}. No effect of the registry is needed.")
        else:
            parts.append(f"The paper's constant-epsilon model leaves a gap of {after} ({_noise_text(d)}), and "
                         f"no effect of the registry explains it.")
    if d.cut:
        cut = _effects_phrase(d.cut)
        parts.append(f"{cut[0].upper() + cut[1:]} would also matter but "
                     f"{'is' if len(d.cut) == 1 else 'are'} not named: at most {d.max_effects} effect(s) are named "
                     f"(max_effects); the values here lack {'it' if len(d.cut) == 1 else 'them'}.")
    elif v == "unexplained" and d.effects:
        ratio = d.gap_after / d.reference_gap if d.reference_gap else math.inf
        parts.append(f"Something else remains: {after} is {ratio:.1f} times the noise, structure that no candidate "
                     f"of the registry removes.")
    final_gap = d.judged_final.judged_gap   # what the candidates' gaps compare with (weighted when judged so)
    # an explained record needs nothing more: a candidate that fits better only beyond its limits chases the
    # noise or the bounces' scatter (a clean golf record "needed C_d 1.83: check the mass")
    for need in [n for n in d.unphysical if n["gap"] < final_gap and v != "explained"][:1]:
        lo, hi = need["limits"]
        from vrcal.drop.effects import EFFECTS

        p = EFFECTS[need["effect"]].parameter(need["parameter"])
        factor, shown = _si_scale(p.unit)
        better = (f"would shrink the gap to {_fmt_gap(need['gap'], unit)}" if d.judged is None else
                  f"would fit better (gap weighted by the scatter {_fmt_gap(need['gap'], unit)} against "
                  f"{_fmt_gap(final_gap, unit)})")
        parts.append(f"{PHRASES[need['effect']][0][0].upper() + PHRASES[need['effect']][0][1:]} {better} "
                     f"but only with {PHRASES[need['effect']][1]} = "
                     f"{number(need['value'] * factor, 3)}{' ' + shown if shown else ''} (physical: "
                     f"{_limits_text(lo, hi, p.unit)}): {need['check']}.")
    return " ".join(parts)


def engine_advice(discovery):
    """Lines saying which ε to put in a physics engine, and why (they follow the verdict)."""
    from vrcal.drop.effects import EFFECTS

    d = discovery
    f = d.final
    eps = d.epsilon
    u = d.epsilon_uncertainty
    out = []
    if d.verdict == "suspect input":
        out.append("(check the input first: these values assume it is right)")
    widened = (f"± with the bounces' scatter, {d.fit_epsilon_uncertainty:.2g} if the times' errors were independent"
               if d.kind == "impacts" and u > 1.5 * d.fit_epsilon_uncertainty else "")
    spread = d.bounce_spread
    by_bounces = [] if spread is None else [
        f"The ± of epsilon is widened from the fit's {f.uncertainty('epsilon'):.2g} to {u:.2g}: the model does not "
        f"reproduce the record, so its residuals are not independent; a bounce's own "
        + ("speed ratio (out/in)" if d.epsilon_uncertainty_basis.endswith("speed ratios") else
           "ratio (out/in) of the speeds where parabolas of g through its flights meet (too few frames near "
           "the contacts for their own speeds)")
        + f" differs from the model's by up to {spread:.2g} beyond its uncertainty ({len(d.bounce_epsilons)} "
        f"bounce{'s' if len(d.bounce_epsilons) > 1 else ''}: "
        + ", ".join(f"{b['epsilon']:.3f} for {b['epsilon_model']:.3f} at {b['impact_speed_m_per_s']:.2f} m/s"
                    for b in d.bounce_epsilons[:6])
        + (", ..." if len(d.bounce_epsilons) > 6 else "") + ")."]
    if d.epsilon_lower_bound:
        by_bounces = [f"{d.epsilon_lower_bound[0].upper()}{d.epsilon_lower_bound[1:]}."]
    if not d.effects:
        out.append(f"epsilon = {pm(eps, u)}" + (f"  ({widened})" if widened else ""))
        out.extend(by_bounces)
        shown = _systematic_lines(d, u)
        out.extend(shown)
        if not d.rounds and d.verdict != "unexplained":
            out.append(f"(nothing tested: an engine without air drag reproduces {RECORD_OF_KIND[d.kind]} with it)")
        elif d.reproduces and shown and "air_drag.drag_coefficient" in d.systematic["held"]:
            out.append("The baseline suffices: this constant epsilon reproduces the record in an engine without "
                       "air drag (with drag, the value above).")
        elif d.reproduces:
            out.append("The baseline suffices: this constant epsilon reproduces the record in any engine.")
        else:
            out.append("The baseline does not reproduce the record to its noise (see above); this is the constant "
                       "that comes closest.")
        return out
    # the value to use first: the most probable sharing when rivals cannot be told apart (d.split), with each
    # explanation alone listed after it as a rival; else the named model's
    split = d.split is not None
    if split:
        out.append(_split_advice(d))
        out.append("Rivals, each one explanation alone (the data cannot tell them apart):")
    lead = "- " if split else ""
    named = ", ".join(p for n in d.effects for p in _param_values(d, n))
    alone = f"with {_effects_phrase(d.effects)} alone ({named}): "
    if "velocity_dependent_restitution" in d.effects:
        lo, hi = d.speed_range(f)     # the named model's own speeds, beside its own law
        fast, slow = _law_values(d, [hi, lo])
        out.append(f"{lead}{alone if split else ''}epsilon depends on the impact speed: {fast}, {slow} (the speeds "
                   f"of this record){'.' if split else ';'}")
        if not split:
            out.append("choose the value at the impact speeds of your simulation.")
    else:
        own = "" if split else "the contact's own restitution"
        why = "; ".join(w for w in (own, widened) if w)
        out.append(f"{lead}{alone if split else ''}epsilon = {pm(eps, u)}" + (f"  ({why})" if why else ""))
    out.extend(by_bounces)
    if not split:   # the most probable sharing holds the rivals at their priors already
        out.extend(_systematic_lines(d, u))
    for name, rivals in d.ambiguous_epsilon.items():
        for rival, alt in rivals.items():
            lo, hi = alt["epsilon"]
            span = f"= {lo:.4f}" if abs(hi - lo) < 5e-5 else f"{lo:.4f} to {hi:.4f} over the bounces"
            params = ", ".join(f"{PHRASES[rival][1]} = {pm(alt['parameters'][p.name], None, p.unit)}"
                               + (" (at its physical limit)" if p.name in alt.get("at_limit", ()) else "")
                               for p in EFFECTS[rival].parameters)
            if split:
                out.append(f"- with {_effects_phrase([rival])} alone ({params}): epsilon {span}.")
            else:
                out.append(f"With {_effects_phrase([rival])} instead of {_effects_phrase([name])} ({params}; the "
                           f"data cannot tell them apart): epsilon {span}.")
    if split and "air_drag" in d.split.effects:
        cd = d.split.effect_values["air_drag"]["drag_coefficient"]
        out.append(f"Use the most probable value in an engine that also applies its air drag (C_d {cd:.2f}, a force "
                   f"-k v|v|);")
    elif "air_drag" in f.effects:
        out.append("Use it in an engine that also applies the air drag found here (a force -k v|v|);")
    if "air_drag" in (d.split if split else f).effects:
        out.append(_without_drag_line(d))
    elif d.split is None and ("height_offset" in d.effects or "contact_duration" in d.effects):
        out.append(f"The baseline's epsilon {d.epsilon_baseline:.4f} is biased by the effect(s) named; use "
                   f"{eps:.4f}.")
    return out


def _without_drag_line(d):
    """What an engine without drag should take (:attr:`Discovery.effective_without_drag`): the constant
    that reproduces the bounce heights, over which bounces, or that none does within the goal."""
    from vrcal.model.restitution import APEX_GOAL

    eff = d.effective_without_drag
    goal = f"{100 * APEX_GOAL:g} %"
    n, of = eff["bounces"], eff["of"]
    if eff["epsilon"] is None:
        return (f"no constant epsilon reproduces the bounce heights in an engine without drag: the nearest misses "
                f"{_heights_of(d, min(2, of), of)} by up to {100 * eff['misfit']:.1f} % (more than {goal}); use one "
                f"that applies the drag.")
    text = (f"an engine without drag reproduces {_heights_of(d, n, of)} within {100 * eff['misfit']:.1f} % with the "
            f"effective epsilon = {eff['epsilon']:.4f} (the constant nearest the model's apexes)")
    if n < of:
        text += f"; no constant reproduces all {of} within {goal}"
    return text + "."


def _heights_of(d, n, of):
    """The first ``n`` of the ``of`` bounce heights per run, as the report names them: 'the first 2 bounce
    heights', 'all 5 bounce heights', 'both bounce heights', 'the bounce height', with 'of the 3 drops' after
    them for several runs; the rows of a drop table, one rebound each, are 'the rebound heights of the 15
    rows' (a table whose every row held one rebound was told 'the nearest misses the first two')."""
    runs = len(d.runs)
    if of == 1:
        if runs == 1:
            return "the bounce height"
        rows = bool(d.labels) and all(str(label).startswith("row ") for label in d.labels)
        return f"the rebound heights of the {runs} {'rows' if rows else 'drops'}"
    which = ("both bounce heights" if n == of == 2 else f"all {of} bounce heights" if n == of
             else f"the first {n} bounce heights")
    return which + (f" of the {runs} drops" if runs > 1 else "")


def _systematic_lines(d, sigma):
    """What ε would be with the effects every ball has held where physics expects them
    (:attr:`Discovery.systematic`), when that moves it by at least half the fit's uncertainty."""
    sys_ = d.systematic
    if sys_ is None:
        return []
    out = _excluded_drag_lines(d)
    shift = sys_["epsilon_shift"]
    band = sys_.get("epsilon_shift_range") or [shift, shift]
    largest = max(abs(band[0]), abs(band[1]), abs(shift))
    if not sys_["held"] or largest < 0.5 * (sigma or 0.0) or largest < 5e-5:
        return out
    ranges = sys_.get("held_range", {})

    def contact(v):
        lo, hi = ranges.get("contact_duration.contact_time_s", (v, v))
        span = f", {ms(lo, 2)} to {ms(hi, 2)} for this kind of ball" if hi > lo else ""
        return f"a contact of the {ms(v, 2)} expected of this ball{span}"

    held = _held_phrase(sys_, contact)
    value, at = d.epsilon + shift, ""
    fastest = sys_.get("fastest_impact")
    if fastest is not None:
        # a speed law: at the fastest impact the held model makes (a drag held slows the ball: not at the
        # law's pivot, which it never reaches), and the shift from the final model's at its fastest impact
        # (the same bounce)
        value, at = fastest["epsilon"], f" at {fastest['speed_m_per_s']:.2f} m/s"
        band = [b + value - d.epsilon - shift for b in band]
        shift = value - d.fastest_impact()[0]
    tail = "a systematic uncertainty beside the ± above"
    if "air_drag.drag_coefficient" in sys_["held"] and abs(shift) > max(0.01, 3 * (sigma or 0.0)):
        # not a small correction: two answers, one for each kind of engine
        tail = ("the contact's own restitution if the ball has that drag, for an engine that applies it; "
                "the value above suits an engine without air drag")
    # four decimals, more when the shift is smaller (two significant digits of it)
    dec = max(4, 1 - math.floor(math.log10(largest)))
    over = (f" ({d.epsilon + band[0]:.{dec}f} to {d.epsilon + band[1]:.{dec}f} over that range)"
            if band[1] - band[0] >= 0.5 * 10.0 ** -dec else "")
    return out + [f"(with {held}, which these data do not resolve: epsilon {value:.{dec}f}{at}, "
                  f"{shift:+.{dec}f}{over}; {tail})"]


def _held_phrase(sys_, contact=None):
    """'a sphere's air drag (C_d 0.47) and ...': what :attr:`Discovery.systematic` holds."""
    what = {"air_drag.drag_coefficient": lambda v: f"a sphere's air drag (C_d {v:.2g})",
            "contact_duration.contact_time_s": contact or (lambda v: f"a contact of {ms(v, 2)}"),
            "velocity_dependent_restitution.exponent":
                lambda v: f"a viscoelastic ball's speed-dependent epsilon (p {v:.2g})"}
    return " and ".join(what[k](v) for k, v in sys_["held"].items())


def _named_with_held(d):
    """The sentence on how far the named effects' parameters move with the effects every ball has held where
    physics puts them (:attr:`Discovery.systematic`), when some moves by more than twice its ±: the data do not
    tell the two apart, and the ± is statistical only. '' otherwise."""
    from vrcal.drop.effects import EFFECTS

    sys_ = d.systematic or {}
    moved = []
    for key, value in (sys_.get("named_with_held") or {}).items():
        effect, name = key.split(".", 1)
        own = d.final.effect_values.get(effect, {}).get(name)
        unc = d.final.effect_uncertainties.get(effect, {}).get(name) or 0.0
        if own is None or abs(value - own) <= 2.0 * unc:
            continue
        p = EFFECTS[effect].parameter(name)
        moved.append(f"{PHRASES[effect][1]} = {pm(value, None, p.unit)}")
    if not moved or not sys_.get("held"):
        return ""
    return (f"With {_held_phrase(sys_)}, which these data do not resolve, {' and '.join(moved)} instead: the data "
            f"do not tell the two apart, and the ± is statistical only.")


def _excluded_drag_lines(d):
    """The line saying that the record rejects a sphere's air drag, which every ball has
    (:attr:`Discovery.systematic`'s ``excluded``): the ball's mass or size is then not the one given."""
    increase = ((d.systematic or {}).get("excluded") or {}).get("air_drag.drag_coefficient")
    if increase is None:
        return []
    from vrcal.measurements.plausibility import CHECK_UNIT_FIRST, unit_suspected

    check = CHECK_UNIT_FIRST if unit_suspected(d.warnings) else "check the ball's mass and diameter"
    return [f"(a sphere's air drag (C_d {SPHERE_DRAG_COEFFICIENT:g}), which every ball has, is excluded by "
            f"{RECORD_OF_KIND[d.kind]}: chi2 +{increase:,.0f} with it; {check})"]


def _split_advice(d):
    """The line on the most probable ε while named effects and rivals cannot be told apart (``d.split``)."""
    from vrcal.drop.effects import EFFECTS

    f = d.split
    shown = [e for e in f.effects if e not in d.nuisance]
    params = ", ".join(f"{PHRASES[e][1]} = {pm(f.effect_values[e][p.name], None, p.unit)}"
                       for e in shown for p in EFFECTS[e].parameters)
    u = d.recommended_epsilon_uncertainty   # its +- widened as the named model's is (the bounces' scatter, a misfit)
    if "velocity_dependent_restitution" in f.effects:
        lo, hi = d.speed_range(f)     # the split's own speeds: its drag may differ from the named model's
        e_lo, e_hi = d.epsilon_at([lo, hi], fit=f)
        eps = f"epsilon depends on the impact speed: {pm(e_hi, u)} at {hi:.2f} m/s, {pm(e_lo, u)} at {lo:.2f} m/s"
    else:
        eps = f"epsilon = {pm(f.value('epsilon'), u)}"
    spread = d.rivals_epsilon_spread
    if spread and u > 0 and spread > 0.05 * u:
        alone = math.sqrt(max(u * u - spread * spread, 0.0))
        params += f"; the ± holds the rivals' spread about it, {number(spread, 2)}: {number(alone, 2)} without"
    return (f"{eps}: the most probable value, with {_effects_phrase(shown)} together, shared as their prior "
            f"densities say (the data fix only what they do together; {params}). Use this.")


def _named_table(d):
    from vrcal.drop.effects import EFFECTS

    rows = []
    held = {(e["effect"], e["parameter"]) for e in d.at_limit}
    for name in d.effects:
        values, uncs = d.final.effect_values[name], d.final.effect_uncertainties[name]
        for p in EFFECTS[name].parameters:
            lo, hi = p.physical_limits(d.ball)
            amb = ", ".join(d.ambiguous.get(name, ())) or "-"
            value = pm(values[p.name], uncs.get(p.name), p.unit) + (" (at limit)" if (name, p.name) in held else "")
            rows.append([name, p.name, value, _limits_text(lo, hi, p.unit), amb])
    return table(rows, ["effect", "parameter", "value", "physical limits", "ambiguous with"], align="lllll",
                 indent="  ")


def _unusual_lines(d):
    """A line per named parameter that is physical but outside what such balls measure
    (:attr:`Discovery.unusual`): what is typical, where that comes from, and what may hide in it."""
    from vrcal.drop.effects import EFFECTS

    out = []
    for u in d.unusual:
        effect = EFFECTS[u["effect"]]
        p = effect.parameter(u["parameter"])
        lo, hi = u["typical"]
        check = effect.check_by_kind.get(d.kind, effect.check)
        unit = "" if p.unit in ("", "1") else f" {p.unit}"
        out.append(_wrap(f"{PHRASES[u['effect']][1]} {number(u['value'], 3)}{unit} is physical but unusual, "
                         f"outside the {number(lo, 2)} to {number(hi, 2)}{unit} (95 %) of a {p.density.basis}: "
                         f"another effect of the same sign that the registry does not hold in this form (a "
                         f"speed-dependent epsilon of another shape) may be inside it; or {check}.", "  "))
    return out


def _runs_table(d):
    rows = []
    for r, (run, label) in enumerate(zip(d.runs, d.labels or [""] * len(d.runs))):
        vals = d.final.run_values(r)
        n = int(np.asarray(run.t_s if run.kind != "apexes" else run.h_m).size)
        rows.append([str(r + 1), label or str(run.source), str(n), f"{vals['drop_height_m']:.4f}"])
    return table(rows, ["run", "what", "data", "fitted drop height m"], align="llrr", indent="  ")


#: The two effects whose rivalry :attr:`vrcal.discovery.ranking.Discovery.speeds_too_narrow` is about.
PAIR = frozenset(DRAG_OR_SPEED_LAW)


def _speed_lines(d):
    lo, hi = d.speed_range()      # the recommended model's, whose epsilon the advice quotes at them
    whose = " (in the most probable model, whose epsilon to use)" if d.split is not None else ""
    lines = [f"  impact speeds covered: {lo:.2f} to {hi:.2f} m/s{whose}"]
    if "velocity_dependent_restitution" in d.effects:
        speeds = np.linspace(lo, hi, 4)
        lines.append(_wrap("epsilon(v): " + ", ".join(_law_values(d, speeds, d.recommended)), "  "))
    if d.speeds_too_narrow:
        more = ("drops from a wider range of heights (the highest separate them best)" if len(d.runs) > 1
                else "drops from other heights (several files, or a drop table)")
        lead = ("Air drag and a speed-dependent epsilon both fit:" if set(d.effects) & PAIR else
                "Neither air drag nor a speed-dependent epsilon is named, and")
        text = (f"{lead} the speeds covered ({lo:.2f}-{hi:.2f} m/s, a factor {hi / lo:.2g}) are too "
                f"narrow to tell them apart (chi2 {number(d.drag_or_speed_law_chi2, 2)} apart); add {more}.")
        pair = d.pair_rival
        if pair is not None and pair["decisive"]:
            from vrcal.drop.effects import EFFECTS

            values = ", ".join(f"{PHRASES[pair['rival']][1]} = {number(pair['parameters'][p.name], 2)}"
                               for p in EFFECTS[pair["rival"]].parameters if p.name in pair["parameters"])
            text += (f" Alone, {PHRASES[pair['rival']][0]} would need {values}, which its prior density makes "
                     f"decisively less probable (odds {odds_text(pair['odds'])} for {PHRASES[pair['named']][0]}): "
                     f"it is not listed as a rival, and the ± leaves it out.")
        lines.append(_wrap(text, "  "))
    return lines


def fit_report(discovery, details=False):
    """The report of a discovery for people (a string ending with a newline; lines <= 100 columns).

    Parameters
    ----------
    discovery : Discovery
    details : bool
        add the statistics of every candidate and the gap per bounce
    """
    d = discovery
    ball = d.ball
    n_data = d.baseline.n
    runs = len(d.runs)
    what = {"trajectory": "samples", "impacts": "impact times", "apexes": "heights"}[d.kind]
    joint = f" in {runs} runs fitted jointly" if runs > 1 else ""
    name = getattr(ball, "name", "ball")
    count = f"{n_data}"
    if d.decimation > 1:
        what += f": every {d.decimation}th of {d.n_read:,} read"
    elif d.n_read and d.n_read > n_data:
        see = "the verdict and the notes" if d.warnings else "the notes"
        count, what = f"{n_data} of {d.n_read}", f"{what} fitted; see {see}"
    head = (f"vrcal discover: {d.data.source} ({d.kind}, {count} {what}{joint}); {'ball ' * (name != 'ball')}{name} "
            f"(m = {mass(float(ball.mass_kg))}, D = {number(float(ball.diameter_m) * 1e3, 3)} mm)")
    lines = [_wrap(head), "", _wrap(answer(d)), "", _wrap(f"Verdict: {d.verdict}: {_verdict_reason(d)}.", "  ", "")]
    lines += ["", "epsilon for an engine"] + [_wrap(s, "    ", "  ") if s.startswith("- ") else _wrap(s, "  ")
                                              for s in engine_advice(d)]
    if d.effects:
        lines += ["", "Named effects", _named_table(d).rstrip("\n"), *_unusual_lines(d)]
    if runs > 1 or "velocity_dependent_restitution" in d.effects or d.ambiguous:
        lines += ["", "Speeds"] + _speed_lines(d)
    if runs > 1:
        lines += ["", "Runs (one epsilon and one set of effects; a drop height each)", _runs_table(d).rstrip("\n")]
    notes = d.all_notes
    if notes:
        lines += ["", "Notes"] + [_wrap(n, "    ", "  - ") for n in notes]
    if details:
        lines += ["", *details_lines(d)]
    else:
        lines += ["", _wrap("More: --details (statistics of every candidate, gap per bounce), --report DIR "
                            "(figure), --json FILE (every number).")]
    return "\n".join(lines) + "\n"


def _verdict_reason(d):
    from vrcal.discovery.ranking import verdict_reason

    return verdict_reason(d)


def details_lines(d):
    """The statistics of every candidate (χ², AIC, BIC, ΔBIC, p, evidence) and the gap per bounce."""
    unit = d.unit
    scale, uname = _UNIT_SCALE[unit]
    sigma = d.reference_sigma
    th = d.thresholds
    b = d.judged_baseline
    out = ["Statistics (--details)"]
    if d.judged is not None:
        out.append(_wrap("Judged by generalized least squares (the bounces scatter, see the notes): gaps, chi2, AIC "
                         "and BIC of the residuals weighted by the times' covariance, in the data's unit at the "
                         "timing noise.", "  "))
    out += [_wrap(f"Baseline (the paper's model: constant epsilon, g = {d.g_m_per_s2:.6g} m/s^2 known): gap "
                  f"{_fmt_gap(b.judged_gap, unit)}, chi2 = {b.rss / sigma**2:.1f} at sigma = {_fmt_gap(sigma, unit)}, "
                  f"AIC = {b.aic:.1f}, BIC = {b.bic:.1f} (n = {b.n}, k = {b.k}).", "  "),
           _wrap(f"A candidate is material when dBIC >= {th.delta_bic:g}, p <= {th.p_value:g} (chi2 or F test), "
                 f"its parameters lie inside their physical limits and the gap shrinks (x{th.gap_factor:g}; or the gap "
                 f"removed, sqrt(before^2 - after^2), is at least sqrt(({th.removed_noise_fraction:g} sigma)^2 + "
                 f"(1 - {th.gap_factor:g}^2) m^2), m = sqrt(before^2 - sigma^2) the misfit beyond the noise); of "
                 f"the material ones the highest evidence Z "
                 f"(Laplace, the registry's prior densities) is named. d2lnZ = 2 ln(Z_best / Z) in its round.", "  "),
           _wrap("Short names: " + ", ".join(f"{v} = {k}" for k, v in SHORT.items() if v != k) + ".", "  ")]
    best = {}
    for c in d.candidates:
        best[c.round] = min(best.get(c.round, math.inf), c.score)
    rows, reasons = [], []
    for c in d.candidates:
        f = c.fit
        name = "+".join(SHORT[m] for m in c.members)
        verdict = "named" if c.verdict.startswith("named") else ("material" if c.material else "no")
        rows.append([str(c.round), name, str(f.k), number(f.judged_gap * scale, 4), number(f.rss / sigma**2, 4),
                     f"{f.aic:.1f}", f"{f.bic:.1f}", f"{c.delta_bic:.1f}", f"{c.p_value:.2g}",
                     f"{c.score - best[c.round]:.1f}", verdict])
        if not c.material and not c.verdict.startswith("named"):
            reasons.append(f"round {c.round}, {name}: {c.verdict.replace('not material: ', '')}")
        elif c.verdict.startswith("named,"):
            reasons.append(f"round {c.round}, {name}: {c.verdict}")
    out.append(table(rows, ["rnd", "effect", "k", f"gap {uname}", "chi2", "AIC", "BIC", "dBIC", "p", "d2lnZ",
                            "verdict"], indent="  ").rstrip("\n"))
    if reasons:
        out.append("  not material:")
        out += [_wrap(r, "      ", "    ") for r in reasons]
    for name in d.effects:
        odds = d.ambiguous_odds.get(name, {})
        if odds:
            text = ", ".join(f"{r} {o:.3g}:1" if o < 1e4 else f"{r} >1e4:1" for r, o in odds.items())
            out.append(_wrap(f"posterior odds for {name} against its ambiguous rivals (registry priors): {text}", "  "))
    before, after = d.gap_per_bounce()
    label = "flight" if d.kind == "trajectory" else ("impact" if d.kind == "impacts" else "bounce")
    if d.kind == "apexes":
        idx = [f"{r + 1}:{int(x)}" if len(d.runs) > 1 else str(int(x))
               for r, run in enumerate(d.runs) for x in run.bounce]
    elif d.kind == "impacts":
        idx = [str(int(e)) for run in d.runs for e in (run.events if run.events is not None
                                                       else np.arange(1, len(run.t_s) + 1))]
    else:
        idx = [str(i) for i in range(len(before))]
    rows = [[i, number(bb * scale, 3), number(aa * scale, 3)] for i, bb, aa in zip(idx, before, after)]
    out += ["", f"Gap per {label} (RMS of data - model, {uname}; before = baseline, after = with the named effects)",
            table(rows, [label, "before", "after"], indent="  ").rstrip("\n")]
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
    impact number (impacts) or apex heights vs bounce (apexes), every run. Returns the ax."""
    ax = _new_ax(ax)
    d = discovery
    kind = d.kind
    runs = d.runs
    slices = d.final.run_slices()
    for r, (run, sl) in enumerate(zip(runs, slices)):
        first = r == 0
        data_label = f"data ({d.data.source})" if first else None
        base_label = "baseline (constant ε)" if first else None
        final_label = _effects_label(d) if first else None
        if kind == "trajectory":
            t = np.asarray(run.t_s, dtype=float)
            ax.plot(t, run.y_m, ".", ms=2.5, color="0.35", label=data_label)
            tt = np.linspace(t[0], t[-1], max(2000, 4 * t.size))
            ax.plot(tt, d.baseline.predict_at(tt, run=r), "-", lw=1.0, color="tab:orange", label=base_label)
            ax.plot(tt, d.final.predict_at(tt, run=r), "-", lw=1.2, color="tab:blue", label=final_label)
        elif kind == "impacts":
            t = np.asarray(run.t_s, dtype=float)
            events = np.asarray(run.events if run.events is not None else np.arange(1, t.size + 1))
            ax.plot(events[1:], np.diff(t) * 1e3, "o", color="0.35", label=data_label)
            for fit, style, color, label in ((d.baseline, "--", "tab:orange", base_label),
                                             (d.final, "-", "tab:blue", final_label)):
                model = t - fit.residuals[sl]
                ax.plot(events[1:], np.diff(model) * 1e3, style, marker=".", color=color, label=label)
        else:
            b = np.asarray(run.bounce) + (0.0 if len(runs) == 1 else 0.0)
            h = np.asarray(run.h_m, dtype=float)
            x = b if len(runs) == 1 else np.full(b.size, float(h[0])) + 0 * b
            if len(runs) == 1:
                ax.semilogy(b, h, "o", color="0.35", label=data_label)
                for fit, style, color, label in ((d.baseline, "--", "tab:orange", base_label),
                                                 (d.final, "-", "tab:blue", final_label)):
                    ax.semilogy(b, h - fit.residuals[sl], style, marker=".", color=color, label=label)
            else:   # a drop table: rebound against drop height
                ax.plot(x[1:], h[1:], "o", color="0.35", label=data_label)
                for fit, marker, color, label in ((d.baseline, "x", "tab:orange", base_label),
                                                  (d.final, "+", "tab:blue", final_label)):
                    ax.plot(x[1:], (h - fit.residuals[sl])[1:], marker, color=color, label=label)
    if kind == "trajectory":
        ax.set_xlabel("time t [s]")
        ax.set_ylabel("height y [m]")
    elif kind == "impacts":
        ax.set_xlabel("event number")
        ax.set_ylabel("interval to the previous impact [ms]")
    elif len(runs) == 1:
        ax.set_xlabel("bounce")
        ax.set_ylabel("apex height [m]")
    else:
        ax.set_xlabel("drop height [m]")
        ax.set_ylabel("rebound height [m]")
    ax.set_title(f"vrcal discover: {', '.join(d.effects) or 'no effect named'}; ε = {d.epsilon:.4f}; {d.verdict}",
                 fontsize=10)
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8)
    return ax


def plot_residuals(discovery, ax=None):
    """Residuals (data - model) of the baseline and of the extended model. Returns the ax."""
    ax = _new_ax(ax)
    d = discovery
    scale, uname = _UNIT_SCALE[d.unit]
    xs = []
    for run in d.runs:
        if d.kind == "trajectory":
            xs.append(np.asarray(run.t_s, dtype=float))
        elif d.kind == "impacts":
            xs.append(np.asarray(run.events if run.events is not None else np.arange(1, len(run.t_s) + 1), float))
        else:
            xs.append(np.asarray(run.bounce, dtype=float) if len(d.runs) == 1 else
                      np.full(len(run.h_m), float(run.h_m[0])))
    x = np.concatenate(xs)
    xlabel = {"trajectory": "time t [s]", "impacts": "event number"}.get(
        d.kind, "bounce" if len(d.runs) == 1 else "drop height [m]")
    style = "." if d.kind == "trajectory" else "o"
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

