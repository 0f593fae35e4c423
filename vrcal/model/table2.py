"""Table 2 of [1] regenerated from the standards, and the paper's own Table 2 checked.

Table 2 of [1] ("Sample of selection for virtual velocity and virtual position") gives,
for four balls, an epsilon and one virtual body (x, v). vrcal regenerates it
deterministically from ``standards.yaml``:

* epsilon min / nominal / max: Eq. (9) through :func:`vrcal.model.standards.ball_epsilon`
  (drop and rebound both to the bottom of the ball), beside the paper's Table 1 epsilon
  (heights as printed) and the paper's Table 2 epsilon;
* T nominal = -ln(epsilon nominal) / K (Eq. 7);
* the rule for the virtual body: x = R/2, the ball's nominal radius halved (the same
  member :func:`vrcal.inverse.parse_body` uses), and v = x / (2 T) (Eq. 10) for the
  nominal epsilon, with the v range that gives epsilon min..max at that x.

:func:`compare_paper` reads the paper's Table 2 rows (``balls.<key>.paper.table2``)
and gives the K that each row implies under Eq. (10) as printed, T = x/(2v), and
under the reading with x and v interchanged, T = v/(2x); for each reading it fits
one K to all rows by least squares (``scipy.optimize.least_squares`` on
exp(-K T) - epsilon) and reports the largest |epsilon error| it leaves.

Departures from [1]
-------------------
The paper's Table 2 follows T = v/(2x), not its Eq. (10); vrcal follows the equations
as printed. The paper states no units for x and v; vrcal's regenerated table is in SI.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.optimize import least_squares

from vrcal.errors import UsageError
from vrcal.fileio import dumps
from vrcal.model import restitution as eq
from vrcal.model.restitution import DEFAULT_K_PER_S, check_K
from vrcal.model.standards import BOTTOM_CONVENTION, PAPER_CONVENTION, ball_epsilon
from vrcal.textout import csv_text as _csv_text
from vrcal.textout import machine_document, table, wrap

#: text: aligned table for people (<= 100 columns); markdown: the docs' page; csv, json, yaml: machines.
FORMATS = ("text", "markdown", "csv", "json", "yaml")

#: The two readings of Eq. (10) applied to the paper's Table 2: name -> (formula, T(x, v)).
READINGS = {
    "printed": ("T = x/(2v)", lambda x, v: eq.contact_time_single_s(x, v)),
    "swapped": ("T = v/(2x)", lambda x, v: eq.contact_time_single_s(v, x)),
}

UNITS_NOTE = (
    "the paper states no units for x and v, and the dimensions do not decide between the readings: each "
    "divides a depth by twice a speed. Printed, the x column is the depth and v the speed: with x in m and v "
    "in m/s, T = x/(2v) is a time [s] and K is in 1/s. Swapped, the x column holds the speed and the v column "
    "the depth: T = v/(2x) is a time as well and K is in 1/s (basketball: 0.42 m / (2 * 5 m/s) = 0.042 s, "
    "K = 3.87 1/s). Any one length unit for both columns (cm and cm/s) gives the same T and K"
)

RULE = ("x = R/2 (nominal radius halved); v = x/(2T) (Eq. 10) with T = -ln(epsilon)/K (Eq. 7); "
        "v range for epsilon min..max at the same x")


# --------------------------------------------------------------------------- equations


def implied_K_per_s(epsilon, T_s):
    """Rate constant K that makes exp(-K T) equal epsilon: Eq. (7) of [1] solved for K.

    Parameters
    ----------
    epsilon : float or ndarray
        coefficient of restitution, in (0, 1]
    T_s : float or ndarray
        contact time [s], > 0

    Returns
    -------
    K_per_s : float or ndarray
        ``-ln(epsilon) / T`` [1/s]
    """
    T = np.asarray(T_s, dtype=float)
    if np.any(~np.isfinite(T) | (T <= 0)):
        raise UsageError("T_s must be a finite number > 0 to imply a K")
    # The inverse of Eq. (7) with K = 1 is -ln(eps); divide by T.
    K = np.asarray(eq.contact_time_from_epsilon_s(epsilon, 1.0)) / T
    return float(K) if K.ndim == 0 else K


def least_squares_K_per_s(epsilon, T_s):
    """The single K that fits exp(-K T_i) to epsilon_i for all rows, by least squares.

    Parameters
    ----------
    epsilon : ndarray
        coefficients of restitution, in (0, 1]
    T_s : ndarray
        contact times [s], > 0, same shape

    Returns
    -------
    K_per_s : float
        minimiser of sum_i (exp(-K T_i) - epsilon_i)^2 [1/s]
    max_abs_error : float
        largest |exp(-K T_i) - epsilon_i| at that K
    residuals : ndarray
        exp(-K T_i) - epsilon_i

    Notes
    -----
    Below the smallest row K every residual is positive and the sum of squares falls
    with K; above the largest it rises; so the minimum lies between them. The fit
    (``scipy.optimize.least_squares``) is bounded to that interval and starts at the
    median row K, which makes it deterministic.
    """
    eps = np.asarray(epsilon, dtype=float)
    T = np.asarray(T_s, dtype=float)
    K_rows = np.asarray(implied_K_per_s(eps, T), dtype=float).ravel()
    lo, hi = float(K_rows.min()), float(K_rows.max())

    def residual(k):
        return np.asarray(eq.epsilon_from_contact_time(T, k[0])) - eps

    if hi - lo <= 1e-12 * max(hi, 1.0):
        K = lo
    else:
        fit = least_squares(residual, x0=[float(np.median(K_rows))], bounds=([lo], [hi]),
                            xtol=1e-15, ftol=1e-15, gtol=1e-15)
        K = float(fit.x[0])
    res = residual([K])
    return K, float(np.max(np.abs(res))), res


# --------------------------------------------------------------------------- the paper's rows


def paper_rows(standards):
    """The paper's Table 2 rows recorded in the standards, in file order.

    Returns
    -------
    list of dict
        ``{"ball", "name", "epsilon", "x", "v"}``; balls without a Table 2 row are left out.
    """
    rows = []
    for key, ball in standards.items():
        if ball.paper is not None and ball.paper.table2 is not None:
            t2 = ball.paper.table2
            rows.append({"ball": key, "name": ball.name, "epsilon": t2["epsilon"], "x": t2["x"], "v": t2["v"]})
    return rows


def compare_paper(standards):
    """K implied by each row of the paper's Table 2 under both readings of Eq. (10).

    Parameters
    ----------
    standards : dict
        the result of :func:`vrcal.model.standards.load_standards`

    Returns
    -------
    dict
        JSON-ready: ``rows`` (per ball: epsilon, x, v, and per reading T and K),
        ``readings`` (per reading: formula, least-squares K, the epsilon it gives per
        row, largest |epsilon error|), ``best`` (the reading with the smaller error)
        and ``finding`` (plain text).

    Raises
    ------
    UsageError
        when the standards hold fewer than two Table 2 rows.
    """
    rows = paper_rows(standards)
    if len(rows) < 2:
        raise UsageError(f"the standards hold {len(rows)} row(s) of the paper's Table 2 "
                         "(balls.<key>.paper.table2); at least 2 are needed to compare")
    eps = np.array([r["epsilon"] for r in rows])
    x = np.array([r["x"] for r in rows], dtype=float)
    v = np.array([r["v"] for r in rows], dtype=float)
    readings = {}
    for name, (formula, T_of) in READINGS.items():
        T = np.asarray(T_of(x, v), dtype=float)
        K_rows = np.asarray(implied_K_per_s(eps, T), dtype=float)
        K, err, res = least_squares_K_per_s(eps, T)
        for i, row in enumerate(rows):
            row[f"T_{name}"] = float(T[i])
            row[f"K_{name}"] = float(K_rows[i])
            row[f"epsilon_at_K_ls_{name}"] = float(eps[i] + res[i])
        readings[name] = {
            "formula": formula,
            "K_least_squares": K,
            "max_abs_epsilon_error": err,
            "K_row_min": float(K_rows.min()),
            "K_row_max": float(K_rows.max()),
            "K_row_spread": float(K_rows.max() / K_rows.min()),
        }
    best = min(readings, key=lambda n: readings[n]["max_abs_epsilon_error"])
    other = "printed" if best == "swapped" else "swapped"
    return {
        "rows": rows,
        "readings": readings,
        "best": best,
        "finding": _finding(readings, best, other),
        "units": UNITS_NOTE,
    }


def _finding(readings, best, other):
    b, o = readings[best], readings[other]
    follows = "its own Eq. (10) as printed" if best == "printed" else "x and v interchanged"
    text = (
        f"The paper's Table 2 follows {b['formula']} ({follows}): read that way its rows imply "
        f"K = {b['K_row_min']:.3g}..{b['K_row_max']:.3g} (max/min {b['K_row_spread']:.2f}), "
        f"one least-squares K = {b['K_least_squares']:.3g} leaves |epsilon error| <= {b['max_abs_epsilon_error']:.2g}. "
        f"Read as {o['formula']} the rows imply K = {o['K_row_min']:.3g}..{o['K_row_max']:.3g} "
        f"(max/min {o['K_row_spread']:.2f}) and the best single K = {o['K_least_squares']:.3g} "
        f"leaves |epsilon error| up to {o['max_abs_epsilon_error']:.2g}. "
        "The paper states no units for x and v: a change of units (a length unit of one column "
        "only) rescales every row's K by the same factor, so it cannot remove the spread. "
        "vrcal follows Eq. (10) as printed, T = x/(2v)."
    )
    return text


# --------------------------------------------------------------------------- regenerated table


def regenerate(standards, K_per_s=DEFAULT_K_PER_S, as_paper=False):
    """Table 2 regenerated from the standards: epsilon, T and one virtual body per ball.

    Parameters
    ----------
    standards : dict
        the result of :func:`vrcal.model.standards.load_standards`; every ball, in file order
    K_per_s : float
        rate constant K of Eq. (7) [1/s], > 0
    as_paper : bool
        take epsilon min/nominal/max from the paper's Table 1 heights as printed
        (see :func:`vrcal.model.standards.ball_epsilon`) instead of bottom-to-bottom heights

    Returns
    -------
    dict
        JSON-ready: ``K_per_s``, ``convention``, ``rule`` and ``rows``; each row has
        ``epsilon`` {min, nominal, max}, ``epsilon_paper_table1`` {min, max} or None,
        ``epsilon_paper_table2`` or None, ``T_nominal_s``, ``x_m``,
        ``v_m_per_s`` {min, nominal, max} (v for epsilon min, nominal, max at x; inf
        where epsilon = 1).
    """
    K = check_K(K_per_s)
    rows = []
    convention = PAPER_CONVENTION if as_paper else BOTTOM_CONVENTION
    for key, ball in standards.items():
        window = ball_epsilon(ball, as_paper=as_paper)
        eps = window.as_dict()
        T = {k: eq.contact_time_from_epsilon_s(e, K) for k, e in eps.items()}
        x = ball.radius_m / 2.0
        v = {k: (math.inf if t == 0 else eq.virtual_speed_m_per_s(x, t)) for k, t in T.items()}
        paper1 = None
        if ball.paper is not None and ball.paper.rebound_min_m is not None:
            p = ball_epsilon(ball, as_paper=True)
            # a blank max cell (basketball) stays blank: the window's max is its min there
            paper1 = {"min": p.min, "max": p.max if ball.paper.rebound_max_m is not None else None}
        paper2 = ball.paper.table2["epsilon"] if ball.paper is not None and ball.paper.table2 else None
        rows.append({
            "ball": key,
            "name": ball.name,
            "epsilon": eps,
            "epsilon_paper_table1": paper1,
            "epsilon_paper_table2": paper2,
            "T_nominal_s": T["nominal"],
            "x_m": x,
            "v_m_per_s": v,
        })
    return {"K_per_s": K, "convention": convention, "rule": RULE, "rows": rows}


# --------------------------------------------------------------------------- formatting


def _f(value, spec):
    if value is None:
        return "-"
    if math.isinf(value):
        return "inf"
    return format(value, spec)


def _sig(value):
    """A number of a machine file (csv, json, yaml) at full precision (``repr``); inf as text, None kept."""
    if value is None or not math.isfinite(value):
        return None if value is None else str(value)
    return float(value)


def _rounded(obj):
    if isinstance(obj, float):
        return _sig(obj)
    if isinstance(obj, dict):
        return {k: _rounded(v) for k, v in obj.items()}
    if isinstance(obj, list):
        return [_rounded(v) for v in obj]
    return obj


def _paper1_text(p):
    if p is None:
        return "-"
    if p["max"] is None or abs(p["max"] - p["min"]) < 5e-4:
        return f"{p['min']:.3f}"
    return f"{p['min']:.3f}-{p['max']:.3f}"


def _table_markdown(table, as_paper):
    K = table["K_per_s"]
    cmd = ("vrcal table2" + ("" if K == DEFAULT_K_PER_S else f" --K {K:g}")
           + (" --as-paper" if as_paper else "") + " --format markdown")
    lines = [
        f"# Table 2 of [1], regenerated (K = {K:g} 1/s)",
        "",
        f"Generated by `{cmd}` from the standards file; do not edit by hand.",
        "",
        "| ball | ε min | ε nominal | ε max | ε [1] Table 1 | ε [1] Table 2 | T nominal [s] | x [m] "
        "| v nominal [m/s] | v for ε min..max [m/s] |",
        "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for r in table["rows"]:
        e, v = r["epsilon"], r["v_m_per_s"]
        lines.append(
            f"| {r['ball']} | {e['min']:.3f} | {e['nominal']:.3f} | {e['max']:.3f} "
            f"| {_paper1_text(r['epsilon_paper_table1'])} | {_f(r['epsilon_paper_table2'], '.2f')} "
            f"| {_f(r['T_nominal_s'], '#.4g')} | {_f(r['x_m'], '#.4g')} | {_f(v['nominal'], '#.4g')} "
            f"| {_f(v['min'], '#.4g')}..{_f(v['max'], '#.4g')} |"
        )
    lines += [
        "",
        f"- ε min, nominal, max: Eq. (9), ε = √(h/H), {table['convention']}.",
        "- ε [1] Table 1: Eq. (9) with the paper's Table 1 heights as printed (typos corrected); "
        "ε [1] Table 2: the paper's Table 2 column.",
        f"- T = −ln(ε)/K (Eq. 7) with K = {K:g} 1/s.",
        "- Virtual body: x = R/2, the ball's nominal radius halved; v = x/(2T) (Eq. 10) for ε nominal; "
        "the last column gives v for ε min..max at the same x.",
        "- The paper's own Table 2 values follow T = v/(2x) instead (its x column read as a speed and its v column "
        "as a depth: T is still a time and K comes out in 1/s, about 4.1); see `vrcal table2 --compare-paper` and "
        "[paper.md](paper.md).",
        "",
    ]
    return "\n".join(lines)


def _table_text(table_):
    """Table 2 for people: an aligned table within 100 columns, then the rule in a few lines."""
    K = table_["K_per_s"]
    rows = []
    for r in table_["rows"]:
        e, v = r["epsilon"], r["v_m_per_s"]
        rows.append([r["ball"], f"{e['min']:.3f}", f"{e['nominal']:.3f}", f"{e['max']:.3f}",
                     _paper1_text(r["epsilon_paper_table1"]), _f(r["epsilon_paper_table2"], ".2f"),
                     _f(r["T_nominal_s"] * 1e3, ".2f"), _f(r["x_m"] * 1e3, ".2f"), _f(v["nominal"], ".4f"),
                     f"{_f(v['min'], '.4f')}..{_f(v['max'], '.4f')}"])
    head = ["ball", "ε min", "ε nom", "ε max", "[1] Tab. 1", "[1] Tab. 2", "T [ms]", "x [mm]", "v [m/s]",
            "v min..max"]
    text = f"Table 2 of [1], regenerated (K = {K:g} 1/s)\n\n"
    text += table(rows, head, align="lrrrrrrrrr")
    text += "\n" + wrap(f"ε: Eq. (9), ε = √(h/H), {table_['convention']}; [1] Tab. 1: the same with the paper's "
                         "Table 1 heights as printed; [1] Tab. 2: the paper's Table 2 column.")
    text += wrap("T = −ln(ε)/K (Eq. 7). Virtual body: x = R/2 (the nominal radius halved), v = x/(2T) "
                 "(Eq. 10) for ε nominal; v min..max: the v for ε min..max at the same x. The paper's "
                 "own Table 2 follows T = v/(2x) instead: vrcal table2 --compare-paper.")
    return text


def _compare_text(cmp):
    """The paper's Table 2 under the two readings of Eq. (10), for people (within 100 columns)."""
    p, s = cmp["readings"]["printed"], cmp["readings"]["swapped"]
    rows = [[r["ball"], f"{r['epsilon']:g}", f"{r['x']:g}", f"{r['v']:g}", f"{r['T_printed']:#.4g}",
             f"{r['K_printed']:#.4g}", f"{r['T_swapped']:#.4g}", f"{r['K_swapped']:#.4g}"] for r in cmp["rows"]]
    text = "The paper's Table 2 under the two readings of Eq. (10)\n\n"
    text += table(rows, ["ball", "ε", "x", "v", f"printed {p['formula']}", "K", f"swapped {s['formula']}", "K"],
                  align="lrrrrrrr")
    rows = [[name, rd["formula"], f"{rd['K_row_min']:#.4g}..{rd['K_row_max']:#.4g}", f"{rd['K_least_squares']:#.4g}",
             f"{rd['max_abs_epsilon_error']:.4f}"] for name, rd in cmp["readings"].items()]
    text += "\n" + table(rows, ["reading", "formula", "K of the rows", "least-squares K", "largest |ε error|"],
                          align="llrrr")
    text += "\n" + wrap(cmp["finding"]) + "\n" + wrap(f"Units: {cmp['units']}.")
    return text


_TABLE_CSV_HEADER = [
    "ball", "epsilon_min", "epsilon_nominal", "epsilon_max", "epsilon_paper_table1_min",
    "epsilon_paper_table1_max", "epsilon_paper_table2", "K_per_s", "T_nominal_s", "x_m",
    "v_nominal_m_per_s", "v_at_epsilon_min_m_per_s", "v_at_epsilon_max_m_per_s",
]


def _table_csv(table):
    out = []
    for r in table["rows"]:
        p1 = r["epsilon_paper_table1"] or {"min": None, "max": None}
        e, v = r["epsilon"], r["v_m_per_s"]
        out.append([r["ball"]] + [_sig(c) for c in (
            e["min"], e["nominal"], e["max"], p1["min"], p1["max"], r["epsilon_paper_table2"],
            table["K_per_s"], r["T_nominal_s"], r["x_m"], v["nominal"], v["min"], v["max"])])
    return _csv_text(_TABLE_CSV_HEADER, out)


def _compare_markdown(cmp):
    p, s = cmp["readings"]["printed"], cmp["readings"]["swapped"]
    lines = [
        "# The paper's Table 2 under the two readings of Eq. (10)",
        "",
        f"| ball | ε | x | v | printed: {p['formula']} | K (printed) | swapped: {s['formula']} | K (swapped) |",
        "|---|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for r in cmp["rows"]:
        lines.append(
            f"| {r['ball']} | {r['epsilon']:g} | {r['x']:g} | {r['v']:g} | {r['T_printed']:#.4g} "
            f"| {r['K_printed']:#.4g} | {r['T_swapped']:#.4g} | {r['K_swapped']:#.4g} |"
        )
    lines += [
        "",
        "| reading | formula | row K min..max | least-squares K | largest abs ε error |",
        "|---|---|---:|---:|---:|",
    ]
    for name, rd in cmp["readings"].items():
        lines.append(
            f"| {name} | {rd['formula']} | {rd['K_row_min']:#.4g}..{rd['K_row_max']:#.4g} "
            f"| {rd['K_least_squares']:#.4g} | {rd['max_abs_epsilon_error']:.4f} |"
        )
    lines += ["", f"Units: {cmp['units']}.", "", cmp["finding"], ""]
    return "\n".join(lines)


def _compare_csv(cmp):
    header = ["reading", "formula", "ball", "epsilon_paper", "x_paper", "v_paper", "T", "K_row",
              "K_least_squares", "epsilon_at_K_least_squares", "epsilon_error"]
    out = []
    for name, rd in cmp["readings"].items():
        for r in cmp["rows"]:
            e_fit = r[f"epsilon_at_K_ls_{name}"]
            out.append([name, rd["formula"], r["ball"], r["epsilon"], r["x"], r["v"]] + [_sig(c) for c in (
                r[f"T_{name}"], r[f"K_{name}"], rd["K_least_squares"], e_fit, e_fit - r["epsilon"])])
    return _csv_text(header, out)


def table2_text(standards, K_per_s=DEFAULT_K_PER_S, fmt="text", compare=False, as_paper=False):
    """Table 2 as text: regenerated (default) or the paper's rows compared (``compare``).

    Parameters
    ----------
    standards : dict
        the result of :func:`vrcal.model.standards.load_standards`
    K_per_s : float
        rate constant K of Eq. (7) [1/s], > 0 (not used by ``compare``)
    fmt : {"text", "markdown", "csv", "json", "yaml"}
    compare : bool
        report the paper's Table 2 under both readings of Eq. (10) (:func:`compare_paper`)
    as_paper : bool
        regenerate with the paper's Table 1 heights as printed

    Returns
    -------
    str
        deterministic text ending in a newline; numbers at fixed precision (text, markdown) or at
        full precision (csv, json, yaml: Python's shortest round-trip ``repr``; json and yaml carry
        ``schema_version``).
    """
    if fmt not in FORMATS:
        raise UsageError(f"unknown format '{fmt}' (known: {', '.join(FORMATS)})")
    data = compare_paper(standards) if compare else regenerate(standards, K_per_s, as_paper=as_paper)
    if fmt in ("json", "yaml"):
        return dumps(machine_document(_rounded(data)), fmt)
    writers = {True: {"text": _compare_text, "csv": _compare_csv, "markdown": _compare_markdown},
               False: {"text": _table_text, "csv": _table_csv,
                       "markdown": lambda t: _table_markdown(t, as_paper)}}
    return writers[bool(compare)][fmt](data)
