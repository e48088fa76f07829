"""One style for every vibeam figure (matplotlib).

Conventions (README, "Plots"):

* every axis and colour bar has a quantity and its unit in parentheses, ``(–)``
  for a nondimensional one (Omega, q, Q, shares);
* the figure's title is the case, its subtitle the case's parameters
  (:func:`subtitle`), legends sit outside the data (right of the axes);
* a run has one colour in every figure of a case (:func:`colours`, the order of the
  case's ``[[run]]`` tables; Okabe-Ito's colour-blind-safe palette);
* up sweeps are solid lines with filled markers, down sweeps dashed lines with open
  markers (:data:`DIRECTIONS`);
* the period of a point is its marker shape (:data:`PERIOD_MARKERS`): circle
  period-1, triangle period-2, square period-n (3..8), small dot no impact; a
  non-periodic point is a cross with a bar over the range of its per-period
  amplitude (when the run stored it: ``amplitude_min``, ``amplitude_max``);
  failed points are red crosses along the bottom of the axes.

Every figure is built inside :func:`context` and returned as a
:class:`matplotlib.figure.Figure`; :func:`vibeam.plots.sweep.save_figure` writes it.
"""
from __future__ import annotations

import contextlib
import re
import textwrap

import matplotlib
import numpy as np
from cycler import cycler
from matplotlib.lines import Line2D
from matplotlib.ticker import MaxNLocator

# Okabe & Ito (2008), colour-blind safe; yellow last (poor on white)
PALETTE = ("#0072B2", "#D55E00", "#009E73", "#CC79A7", "#E69F00", "#56B4E9", "#000000", "#F0E442")
DIRECTIONS = {"up": {"ls": "-", "fill": True, "label": "up sweep (solid line, filled markers)"},
              "down": {"ls": "--", "fill": False, "label": "down sweep (dashed line, open markers)"}}
PERIOD_MARKERS = {1: ("o", "period-1"), 2: ("^", "period-2"), 3: ("s", "period-n (3..8)"),
                  0: ("x", "non-periodic (bar: range of $Q_k$)"), -1: (".", "no impact")}
FAILED_COLOUR = "#CC0000"
#: a bifurcation diagram's samples: small dots without an edge, as the field draws them (a
#: chaotic band stays a cloud of points, not a blob of overlapping rings)
DOT_SIZE = 1.2
#: the branches of a continuation run by period (1, 2, 4, 8: the period-doubling cascade; others
#: cycle through the rest): a colour and a marker each, so they stay apart in grey print too
BRANCH_STYLES = {1: ("#0072B2", "o"), 2: ("#D55E00", "^"), 4: ("#009E73", "s"), 8: ("#CC79A7", "p")}
_OTHER_BRANCH_STYLES = (("#E69F00", "v"), ("#56B4E9", "h"), ("#882255", "<"), ("#44AA99", ">"))
#: the line style of a stop's position drawn across an axes (upper, lower)
STOP_LINES = {"upper": (0, (6, 2, 1, 2)), "lower": (0, (1, 1.5))}
NODIM = "–"          # the unit of a nondimensional quantity
DISPLACEMENT = "$U(L_S)$"          # the sensor's displacement (paper Sec. 6), mathtext
VELOCITY = r"$\dot U(L_S)$"        # its velocity

RC = {
    "figure.dpi": 100, "savefig.dpi": 150, "figure.constrained_layout.use": True,
    "font.size": 9, "axes.titlesize": 9, "axes.labelsize": 9, "xtick.labelsize": 8, "ytick.labelsize": 8,
    "legend.fontsize": 8, "legend.frameon": False, "figure.titlesize": 10,
    "axes.grid": True, "grid.alpha": 0.3, "grid.linewidth": 0.5, "axes.spines.top": False,
    "axes.spines.right": False, "lines.linewidth": 1.2, "lines.markersize": 4.5,
    "axes.prop_cycle": None,
}


@contextlib.contextmanager
def context():
    """matplotlib (Agg) with vibeam's style, for building one figure."""
    matplotlib.use("Agg")

    rc = dict(RC, **{"axes.prop_cycle": cycler(color=list(PALETTE))})
    with matplotlib.rc_context(rc):
        yield


def colours(names) -> dict:
    """Colour of each run name, in the given order (the case's runs): the same in every figure.

    Up to 8 runs: Okabe-Ito's palette; more: matplotlib's ``tab20`` (20 distinct hues), and
    beyond that evenly spaced ``turbo`` colours, so no two runs share a colour."""
    names = list(dict.fromkeys(names))
    if len(names) <= len(PALETTE):
        pal = list(PALETTE)
    else:
        cmap = matplotlib.colormaps["tab20" if len(names) <= 20 else "turbo"]
        pal = [matplotlib.colors.to_hex(cmap(i / max(len(names) - 1, 1) if len(names) > 20 else i))
               for i in range(len(names))]
    return {n: pal[i] for i, n in enumerate(names)}


def run_names(case=None, runs=()) -> list:
    """Names of the case's runs in case order (the colour order), then any other run's."""
    names = [r.name for r in getattr(case, "run", [])] if case is not None else []
    return names + [r.name for r in runs if r.name not in names]


def period_marker(p: int) -> tuple:
    """(marker, label) of a period-n class (1, 2, 3..8 as period-n, 0 non-periodic, -1 no impact)."""
    p = int(p)
    return PERIOD_MARKERS[3 if p >= 3 else p] if (p >= 3 or p in PERIOD_MARKERS) else PERIOD_MARKERS[0]


def branch_style(n: int) -> tuple:
    """(colour, marker) of a continuation branch of period ``n`` (:data:`BRANCH_STYLES`)."""
    n = int(n)
    if n in BRANCH_STYLES:
        return BRANCH_STYLES[n]
    return _OTHER_BRANCH_STYLES[n % len(_OTHER_BRANCH_STYLES)]


def unit_text(udunits: str | None) -> str:
    """A UDUNITS unit as read in a figure: ``V-1`` -> ``1/V``, ``kg m-3`` -> ``kg/m^3``, ``N m2`` ->
    ``N m^2``, ``mm`` as it is; ``1`` (nondimensional), ``""`` and None -> ``""``."""
    if not udunits or udunits.strip() == "1":
        return ""
    num, den = [], []
    for tok in udunits.split():
        m = re.fullmatch(r"([A-Za-z]+)(-?\d+)?", tok)
        if m is None:
            return udunits                    # not a product of powers: as written
        sym, p = m.group(1), int(m.group(2) or 1)
        (num if p > 0 else den).append(sym if abs(p) == 1 else f"{sym}^{abs(p)}")
    return (" ".join(num) or "1") + ("/" + (den[0] if len(den) == 1 else "(" + " ".join(den) + ")") if den else "")


def estimate_text(name: str, value: float, se: float, udunits: str | None = None) -> str:
    """``gain = 5.4e-04 ± 2.1e-06 1/V``: a fitted parameter with its standard error and unit
    (:func:`unit_text`; none for a nondimensional one)."""
    u = unit_text(udunits)
    return f"{name} = {value:.4g} ± {se:.2g}" + (f" {u}" if u else "")


def label(quantity: str, unit: str | None) -> str:
    """An axis label ``quantity (unit)``; ``unit`` None or '1': ``(–)``."""
    return f"{quantity} ({NODIM if unit in (None, '', '1') else unit})"


_SYMBOLS = (  # model key -> (symbol, unit, format)
    ("beta", "β", "", "{:g}"), ("B", "B", "", "{:g}"), ("R", "R", "", "{:g}"), ("Delta", "Δ", "", "{:g}"),
    ("natural_frequency_hz", "$f_n$", " Hz", "{:g}"), ("damping_ratio", "ζ", "", "{:g}"),
    ("gap_mm", "gap", " mm", "{:g}"), ("contact_gap_mm", "contact gap", " mm", "{:g}"),
    ("gain", "γ", " /V", "{:.3g}"), ("voltage", "V", " V", "{:g}"), ("length_mm", "L", " mm", "{:g}"),
    ("n_modes", "modes", "", "{}"), ("n_elements", "elements", "", "{}"),
)


def subtitle(case=None, model: dict | None = None, runs=(), exclude=(), sweep: bool = True) -> str:
    """The scene's parameters in one line (paper symbols and units), e.g.
    ``SDOF: β = 0.015, B = 0.0005, R = 0.9, Δ = 0; 400 + 64 periods per point, up and down``.

    Parameters
    ----------
    case : vibeam.case.schema.Case, optional
        Its ``[model]`` (and ``[sweep]``: periods and directions).
    model : dict, optional
        A model table (e.g. the ``attrs["model"]`` a run stored), used when there is no
        case and no run.
    runs : sequence, optional
        The runs of the figure: with one run its own model (``attrs["model"]``) is shown;
        with several, parameters that differ between them are left out (the legend names
        the runs).
    exclude : sequence of str
        Keys left out (a map's parameter, which is an axis).
    sweep : bool
        Add the case's ``[sweep]`` windows and directions (False for a figure that draws no
        sweep, e.g. a continuation run without sweeps overlaid).
    """
    models = [getattr(r, "attrs", {}).get("model") for r in runs]
    models = [x for x in models if isinstance(x, dict)]
    if models and len(models) == len(runs):
        m = dict(models[0])      # the model as run (stops resolved: [[model.stop]] -> gap, R, stop)
    elif case is not None:
        m = dict(case.model)
    elif model is not None:
        m = dict(model)
    elif models:
        m = dict(models[0])
    else:
        return ""
    for other in models if len(runs) > 1 else ():
        for k in list(m):
            if k in other and other[k] != m[k]:
                m.pop(k)
    for k in exclude:
        m.pop(k, None)
    fid = str(m.get("fidelity", "")).upper().replace("BEAM", "FE beam")
    parts = []
    for key, sym, unit, fmt in _SYMBOLS:
        if key in m and m[key] is not None and not isinstance(m[key], dict):
            v = m[key]
            parts.append(f"{sym} = {fmt.format(v) if isinstance(v, (int, float)) and not isinstance(v, bool) else v}"
                         f"{unit}")
    out = (f"{fid}: " if fid else "") + ", ".join(parts)
    st = stops_text(m)
    if st:
        out += "; " + st
    if case is not None and sweep:
        sw = case.sweep
        d = {"both": "up and down", "up": "up", "down": "down"}[sw.direction]
        out += f"; {sw.transient_periods} + {sw.record_periods} periods per point, {d}"
    return out


_LAW_KEYS = (("stiffness", "$k_c$", ""), ("stiffness_n_m", "$k_c$", " N/m"), ("exponent", "p", ""),
             ("damping_ratio", r"$\zeta_c$", ""), ("R", "R", ""), ("mass_kg", "m", " kg"))


def law_text(table, R=None) -> str:
    """A stop's contact law in words, e.g. ``restitution R = 0.9`` or ``linear, $k_c$ = 1e+06
    N/m`` (``table``: a ``[model.contact]``-like dict; None: Newton's law with ``R``)."""
    t = dict(table or {})
    law = t.get("law", "restitution")
    if law == "restitution":
        r = t.get("R", R)
        return "restitution" + (f" R = {r:g}" if isinstance(r, (int, float)) else "")
    keys = [f"{sym} = {t[k]:g}{unit}" for k, sym, unit in _LAW_KEYS if isinstance(t.get(k), (int, float))
            and not isinstance(t.get(k), bool)]
    return ", ".join([law.replace("_", "-")] + keys)


def _gap_text(t: dict) -> str:
    for k, txt in (("Delta", "Δ = {:g}"), ("gap_mm", "gap {:g} mm"), ("contact_gap_mm", "contact gap {:g} mm")):
        if isinstance(t.get(k), (int, float)):
            return txt.format(t[k])
    return ""


def stops_text(m: dict) -> str:
    """The scene's stops beyond the paper's upper one (a model table ``m``): the lower stop
    (its offset and law: ``lower stop: Δ_lower = 0.002, restitution R = 0.9``), every
    ``[[model.stop]]`` (side, position, gap, law) and a compliant upper law; '' for the paper's
    single Newton stop."""
    parts = []
    up = m.get("contact")
    if isinstance(up, dict) and up.get("law", "restitution") != "restitution":
        parts.append("contact: " + law_text(up, m.get("R")))
    lower = next(((fmt.format(m[k])) for k, fmt in (("Delta_lower", "$\\Delta_{{lower}}$ = {:g}"),
                                                     ("gap_lower_mm", "gap {:g} mm"),
                                                     ("contact_gap_lower_mm", "contact gap {:g} mm"))
                  if isinstance(m.get(k), (int, float))), None)
    if lower is not None:
        lo = m.get("contact_lower")
        law = law_text(lo, m.get("R")) if isinstance(lo, dict) else (
            law_text(up, m.get("R")) if isinstance(up, dict) else law_text(None, m.get("R")))
        parts.append(f"lower stop: {lower}, {law}")
    for st in m.get("stop") or ():
        if not isinstance(st, dict):
            continue
        where = f" at {st['position_mm']:g} mm" if isinstance(st.get("position_mm"), (int, float)) else ""
        bits = [b for b in (_gap_text(st), law_text(st, m.get("R"))) if b]
        parts.append(f"{st.get('side', 'upper')} stop{where}: " + ", ".join(bits))
    return "; ".join(parts)


def stop_lines(m: dict) -> list:
    """Where the stops lie on the FRC's amplitude axis ``Q = Delta - min q`` (the distance below
    the upper stop; mm at the sensor for a physical scene): ``[(Q, label), ...]`` for a scene with
    a lower stop at the attached mass whose gap is given in the plotted coordinate (``Delta`` and
    ``Delta_lower``, or ``gap_mm`` and ``gap_lower_mm`` at the sensor): the upper stop at Q = 0
    and the lower one at ``Delta + Delta_lower``; [] otherwise (a stop elsewhere on a beam has no
    one position on the sensor's axis)."""
    pairs = (("Delta", "Delta_lower", "{:g}"), ("gap_mm", "gap_lower_mm", "{:g} mm"))
    if not isinstance(m, dict):
        return []
    for up, lo, fmt in pairs:
        if isinstance(m.get(lo), (int, float)):
            u = m.get(up) if isinstance(m.get(up), (int, float)) else (0.0 if up == "Delta" else None)
            if u is None:
                return []
            q = float(u) + float(m[lo])
            return [(0.0, "upper stop (Q = 0)"), (q, "lower stop (Q = " + fmt.format(q) + ")")]
    return []


def motion_text(period, status: str = "ok") -> str:
    """One point's motion in words for a title: ``period-2``, ``no impact``, ``not periodic
    within 8 periods`` when it settled (``status`` ok), else the status first: ``chatter`` (not
    ``period 0, chatter``), ``period-1, sticking``, ``no impact, unsettled``."""
    try:
        p = int(period)
    except (TypeError, ValueError):
        p = 0
    status = str(status or "ok")
    if status == "ok":
        return {0: "not periodic within 8 periods", -1: "no impact"}.get(p, f"period-{p}")
    if p == 0:
        return status
    return f"{'no impact' if p == -1 else f'period-{p}'}, {status}"


#: the least gap between neighbouring tick labels, in ems of their font: labels closer than this read
#: as one number ("-0.0016-0.0014", 1.5 pixels apart, did in the two-sided Poincaré section)
TICK_GAP_EM = 0.5


def tick_labels_overlap(fig, ax, which: str = "x", gap_em: float = TICK_GAP_EM) -> bool:
    """Whether two visible tick labels of ``ax``'s ``which`` axis inside its view overlap, or stand
    closer than ``gap_em`` ems of their font (drawn ``fig``)."""
    fig.canvas.draw()
    r = fig.canvas.get_renderer()
    lo, hi = sorted(getattr(ax, f"get_{which}lim")())
    labels = [t for t in getattr(ax, f"get_{which}ticklabels")() if t.get_visible() and t.get_text()
              and lo <= t.get_position()[0 if which == "x" else 1] <= hi]
    if not labels:
        return False
    pad = 0.5 * gap_em * labels[0].get_fontsize() * fig.dpi / 72.0        # half the gap on each label
    boxes = [t.get_window_extent(r).padded(pad) for t in labels]
    return any(a.overlaps(b) for i, a in enumerate(boxes) for b in boxes[i + 1:])


def thin_ticks(fig, axes, which=("x", "y")) -> None:
    """Fewer ticks where an axis's tick labels overlap or run together (long labels of a collapsed
    section, e.g. -0.01825 ... -0.01675 without an offset; :func:`tick_labels_overlap`): the
    locator's bins are halved until they clear."""
    for ax in axes:
        for w in which:
            nb = 8
            while nb > 2 and tick_labels_overlap(fig, ax, w):
                nb = max(2, nb // 2) if nb > 4 else nb - 1
                getattr(ax, f"{w}axis").set_major_locator(MaxNLocator(nbins=nb, steps=[1, 2, 2.5, 5, 10]))


def stop_positions(m: dict) -> list:
    """Where the stops lie on a displacement axis (``q``, or ``U(L_S)`` in mm for a physical
    scene: the bifurcation diagram): ``[(q, label), ...]``, the upper stop at ``Delta`` (``gap_mm``)
    and the lower one at ``-Delta_lower`` (``-gap_lower_mm``), for a scene with a lower stop at the
    attached mass given in the plotted coordinate; [] otherwise (as :func:`stop_lines`)."""
    lines = stop_lines(m)
    if not lines:
        return []
    q_low = lines[1][0]
    up = next((float(m[k]) for k in ("Delta", "gap_mm") if isinstance(m.get(k), (int, float))), 0.0)
    return [(up, "upper stop"), (up - q_low, "lower stop")]


def wrap_phrases(text: str, width: int) -> list:
    """``text`` in lines of at most ``width`` characters, broken only between phrases: at the
    separators ``' · '`` and ``'; '`` first, within a phrase longer than a line at ``', '``,
    and only a clause longer than a line between words (:func:`textwrap.wrap`)."""
    def pack(parts, seps, w):
        lines, cur = [], ""
        for part, sep in zip(parts, seps):
            if cur and len(cur) + len(part) > w:
                lines.append(cur.rstrip())
                cur = ""
            cur += part + sep
        if cur.strip():
            lines.append(cur.rstrip())
        return lines

    def split(t, pattern):
        bits = re.split(f"({pattern})", t)
        return bits[0::2], bits[1::2] + [""]

    out = []
    parts, seps = split(text, r" · |; ")
    for line in pack(parts, seps, width):
        if len(line) <= width:
            out.append(line)
            continue
        cl, cs = split(line, r", ")
        for sub in pack(cl, cs, width):
            out += [sub] if len(sub) <= width else textwrap.wrap(sub, width)
    return out


def titles(fig, title: str = "", sub: str = "") -> None:
    """Figure title (the case) and below it the parameters, left-aligned and wrapped to the
    figure's width at phrase boundaries (:func:`wrap_phrases`; constrained layout keeps them
    clear of the axes)."""
    width = max(40, int(fig.get_figwidth() * 13))
    text = "\n".join(wrap_phrases(title, width) + wrap_phrases(sub, width)) if (title or sub) else ""
    if text:
        fig.suptitle(text, x=0.01, ha="left", fontsize=9)


def legend_outside(fig, handles, loc: str = "outside right center", **kw):
    """A figure legend outside the axes (constrained layout makes room for it); entries
    without a label are dropped."""
    handles = [h for h in handles if h is not None and h.get_label() and not h.get_label().startswith("_")]
    if not handles:
        return None
    return fig.legend(handles=handles, loc=loc, **kw)


def proxy(colour="0.3", ls="none", marker=None, fill=True, label="", ms=5, lw=1.2):
    """A legend handle (a Line2D not drawn on any axes)."""
    return Line2D([], [], color=colour, ls=ls, marker=marker, ms=ms, lw=lw,
                  mfc=colour if fill else "none", mec=colour, label=label)


def cell_edges(c):
    """Cell edges around increasing centres ``c`` (n,) -> (n + 1,); one centre gets a cell of
    +-5 % of its value (+-0.05 at 0), so a map with one value or one frequency is drawn."""
    c = np.asarray(c, float)
    if c.size == 1:
        w = 0.05 * abs(c[0]) or 0.05
        return np.array([c[0] - w, c[0] + w])
    mid = 0.5 * (c[1:] + c[:-1])
    return np.concatenate([[c[0] - (mid[0] - c[0])], mid, [c[-1] + (c[-1] - mid[-1])]])
