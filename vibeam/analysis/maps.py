"""Parameter maps (paper Fig. 18): the period-n classification, amplitude and impacts per
period over the frequency grid of ``[sweep]`` and one model parameter of ``[map]``.

A map is made of sweep lines (:class:`vibeam.engine.sweep.Line`): for every value of
the mapped parameter one up and/or one down continuation sweep along the
frequency axis, so that hysteresis (coexisting orbits reached from below or
from above) shows as a difference between the up and down maps.  The lines
run through the one sweep engine (:func:`vibeam.engine.sweep.run_lines`); this module
only assembles their rows into arrays and plots them.
"""
from __future__ import annotations


import numpy as np
from matplotlib.colors import BoundaryNorm, ListedColormap
from matplotlib.patches import Patch

from vibeam.analysis.branches import plot_curves_on
from vibeam.engine.sweep import MM_KEYS, Sweep, stack
from vibeam.io.netcdf import parameter_units
from vibeam.io.objects import MapResult  # noqa: F401 (re-exported)
from vibeam.models.scene import outputs
from vibeam.plots import style
from vibeam.plots.lazy import plt
from vibeam.plots.style import cell_edges, label
from vibeam.plots.sweep import save_close

# classification codes of a map point (dataset ``classification``)
NO_IMPACT, PERIOD_1, PERIOD_2, PERIOD_N, NON_PERIODIC, FAILED, HELD, CHAOTIC, QUASI_PERIODIC = range(9)
CLASSES = {NO_IMPACT: "no impact", PERIOD_1: "period-1", PERIOD_2: "period-2",
           PERIOD_N: "period-n (3 <= n <= 8)", NON_PERIODIC: "non-periodic", FAILED: "failed",
           HELD: "held on the stop", CHAOTIC: "chaotic (largest Lyapunov exponent > 0)",
           QUASI_PERIODIC: "quasi-periodic (largest Lyapunov exponent = 0)"}
# no impact light grey, period-1 blue, period-2 vermillion, period-n orange, non-periodic reddish purple
# (never the white background), failed black, held on the stop dark grey (Okabe-Ito hues)
# chaotic wine, quasi-periodic teal (Tol's muted scheme): the non-periodic points whose Lyapunov
# spectrum was computed ([sweep] lyapunov = true)
CLASS_COLOURS = ("#DDDDDD", "#0072B2", "#D55E00", "#E69F00", "#CC79A7", "#000000", "#777777", "#882255",
                 "#44AA99")
HYSTERESIS_COLOUR = "#009E73"
SAME_COLOUR = "#F4F4F4"


def classify(period, status, lyapunov_class=None) -> np.ndarray:
    """Map-point classes from the period-n test and the solver status.

    Parameters
    ----------
    period : array_like of int
        Period of the stroboscopic map (``-1`` no impact, ``0`` not periodic
        within 8 forcing periods, else n), as in :func:`vibeam.engine.records.summarize`.
    status : array_like of str, same shape
        ``ok``, ``chatter``, ``sticking`` or ``failed``.
    lyapunov_class : array_like of str, same shape, optional
        The points' ``lyapunov_class`` (:func:`vibeam.models.orbits.lyapunov.classify_spectrum`): a
        non-periodic point becomes :data:`CHAOTIC` or :data:`QUASI_PERIODIC` where its spectrum
        says so.

    Returns
    -------
    ndarray of int8, same shape
        Codes :data:`NO_IMPACT`, :data:`PERIOD_1`, :data:`PERIOD_2`,
        :data:`PERIOD_N`, :data:`NON_PERIODIC`, :data:`FAILED` and :data:`HELD`
        (no impact because the mass stays on a pre-stressed stop; paper Fig.
        18(a), "no imp." at low voltage) -- names in :data:`CLASSES`.  Chatter
        and sticking orbits keep their period class; their status is stored
        beside it.
    """
    p = np.asarray(period)
    st = np.asarray(status, dtype=object)
    c = np.full(p.shape, NON_PERIODIC, dtype=np.int8)
    c[p == -1] = NO_IMPACT
    c[p == 1] = PERIOD_1
    c[p == 2] = PERIOD_2
    c[p >= 3] = PERIOD_N
    c[(p == -1) & (st == "sticking")] = HELD
    if lyapunov_class is not None:
        lc = np.asarray(lyapunov_class, dtype=object)
        c[(c == NON_PERIODIC) & (lc == "chaotic")] = CHAOTIC
        c[(c == NON_PERIODIC) & (lc == "quasi_periodic")] = QUASI_PERIODIC
    c[st == "failed"] = FAILED
    return c


def assemble_map(name: str, solvers: list, sweep: Sweep, parameter: str, values, directions,
                 line_rows: dict) -> MapResult:
    """A :class:`MapResult` from the rows of its lines.

    Parameters
    ----------
    name : str
        Run name.
    solvers : list, length n_values
        The solver of each parameter value (its model gives the scales).
    sweep : Sweep
        The sweep of every line.
    parameter : str
        Mapped key.
    values : ndarray, shape (n_values,)
    directions : list of str
        ``['up']``, ``['down']`` or ``['up', 'down']``.
    line_rows : dict
        ``{(j, direction): rows in visiting order}``.
    """
    rows = []
    for d in directions:
        for j in range(len(values)):
            rs = line_rows[(j, d)]
            rows.extend(rs if d == "up" else rs[::-1])
    flat = stack(rows, sweep)
    n_d, n_v = len(directions), len(values)
    data = {k: v.reshape((n_d, n_v, -1) + v.shape[1:]) for k, v in flat.items() if k != "direction"}
    data["classification"] = classify(data["period"], data["status"] if "status" in data else
                                      np.full(data["period"].shape, "ok", dtype=object),
                                      data.get("lyapunov_class"))
    outs = [outputs(s.scene) for s in solvers]
    fn = [o.natural_frequency_hz for o in outs]
    L = [o.length_m for o in outs]
    if all(fn):
        data["frequency_hz"] = data["Omega"] * np.asarray(fn)[None, :, None]
    if all(L):
        for k in MM_KEYS:
            if k in data:
                data[k + "_mm"] = data[k] * np.asarray(L)[None, :, None] * 1e3
    data["values"] = np.asarray(values, float)
    data["direction"] = np.array(directions, dtype=object)
    wall = float(np.nansum(flat.get("wall_time_s", 0.0)))
    s0 = solvers[0]
    attrs = {"parameter": parameter, "classes": "; ".join(f"{k} {v}" for k, v in CLASSES.items())}
    return MapResult(name=name, fidelity=s0.scene.builder, method=s0.name, settings=s0.settings(),
                     parameter=parameter, data=data, wall_time_s=wall, attrs=attrs)


def hysteresis(m: MapResult, rtol: float = 1e-3) -> np.ndarray | None:
    """Points where the up and down sweeps end on different orbits, shape (n_values, n_frequencies).

    Different class, or the same periodic (or no-impact, held) class with
    amplitudes differing by more than ``rtol`` of the larger; None for a
    one-direction map.
    """
    d = list(m.data["direction"])
    if len(d) < 2:
        return None
    c, a = m.data["classification"], np.asarray(m.data["amplitude"], float)
    scale = np.maximum(np.abs(a[0]), np.abs(a[1]))
    # two samples of non-periodic motion differ anyway: only orbits (periodic, no impact, held)
    # are compared by amplitude
    orbit = (c[0] != NON_PERIODIC) & (c[0] != FAILED)
    with np.errstate(invalid="ignore"):
        return (c[0] != c[1]) | (orbit & (np.abs(a[0] - a[1]) > rtol * scale))


def _mesh(x, y):
    """Corner arrays (n_values + 1, n_freq + 1) of a map whose frequency grid ``x``
    (n_values, n_freq) may differ between the values ``y`` (n_values,)."""
    xe = np.array([cell_edges(row) for row in np.atleast_2d(x)])
    ye = cell_edges(y)
    X = np.vstack([xe, xe[-1:]])
    Y = np.repeat(ye[:, None], X.shape[1], axis=1)
    return X, Y


def _axes_labels(m):
    phys = "frequency_hz" in m.data
    xl = label("forcing frequency f", "Hz") if phys else label(r"forcing frequency $\Omega = f/f_n$", None)
    names = {"voltage": "voltage V", "gap_mm": "gap at the sensor", "gain": r"gain $\gamma$", "R": "R",
             "B": "B", "Delta": r"$\Delta$", "beta": r"$\beta$"}
    yl = label(names.get(m.parameter, m.parameter), parameter_units(m.parameter))
    return phys, xl, yl


def _class_handles(present) -> list:
    return [Patch(facecolor=CLASS_COLOURS[i], edgecolor="0.5", lw=0.5, label=CLASSES[i])
            for i in sorted(present)]


def map_figure(m: MapResult, title: str = "", case=None, curves=()):
    """Fig. 18-style class map: one panel per direction and one of the hysteresis (points
    where up and down end on different orbits), class legend outside; two-parameter
    bifurcation curves of continuation runs (``curves``) overlaid.  A Figure."""
    d = m.data
    phys, xl, yl = _axes_labels(m)
    x = np.asarray((d["frequency_hz"] if phys else d["Omega"])[0], float)
    y = np.asarray(d["values"], float)
    dirs = [str(v) for v in d["direction"]]
    hyst = hysteresis(m)
    n_pan = len(dirs) + (hyst is not None)
    X, Y = _mesh(x, y)
    with style.context():
        fig, axes = plt.subplots(1, n_pan, figsize=(3.3 * n_pan + 2.2, 3.6), sharey=True, squeeze=False)
        cmap = ListedColormap(CLASS_COLOURS)
        norm = BoundaryNorm(np.arange(-0.5, len(CLASSES) + 0.5), cmap.N)
        present = set()
        for ax, k in zip(axes[0], range(len(dirs))):
            c = np.asarray(d["classification"][k])
            present |= set(np.unique(c).tolist())
            ax.pcolormesh(X, Y, c, cmap=cmap, norm=norm, edgecolors="face", lw=0)
            ax.set_title(f"{dirs[k]} sweep", loc="left")
        handles = _class_handles(present)
        if hyst is not None:
            ax = axes[0][-1]
            ax.pcolormesh(X, Y, hyst.astype(float), cmap=ListedColormap([SAME_COLOUR, HYSTERESIS_COLOUR]),
                          vmin=0, vmax=1, edgecolors="face", lw=0)
            ax.set_title("hysteresis", loc="left")
            ax.legend(handles=[Patch(facecolor=HYSTERESIS_COLOUR, label=f"up ≠ down ({int(hyst.sum())})"),
                               Patch(facecolor=SAME_COLOUR, edgecolor="0.6", lw=0.5, label="same orbit")],
                      loc="upper left", bbox_to_anchor=(0.0, -0.2), fontsize=7)
        if curves:
            for ax in axes[0]:
                xl_, yl_ = ax.get_xlim(), ax.get_ylim()
                h = plot_curves_on(ax, [c for c in curves if c.attrs.get("curve_parameter") == m.parameter], phys)
                ax.set_xlim(xl_)
                ax.set_ylim(yl_)
            handles += h
        for ax in axes[0]:
            ax.set_xlabel(xl)
            ax.grid(False)
        axes[0][0].set_ylabel(yl)
        style.legend_outside(fig, handles, title="class")
        style.titles(fig, f"{title + ': ' if title else ''}{m.name} ({m.method})",
                     style.subtitle(case, runs=[m], exclude=(m.parameter,)))
    return fig


def plot_map(m: MapResult, path, title: str = "", case=None, curves=()):
    """:func:`map_figure` saved to ``path`` (``map_<run>.png``); returns the path."""
    return save_close(map_figure(m, title, case, curves), path)


def class_agreement(a: MapResult, b: MapResult) -> np.ndarray | None:
    """Where two maps of the same grid (e.g. two fidelities) give the same class, shape
    (n_directions, n_values, n_frequencies) of bool; None if the grids differ."""
    ca, cb = a.data["classification"], b.data["classification"]
    if ca.shape != cb.shape or not np.allclose(a.data["values"], b.data["values"]):
        return None
    return ca == cb


def agreement_counts(a: MapResult, b: MapResult) -> dict | None:
    """Points where the classes of two maps of the same grid differ: ``{"total": (n, of),
    "<direction>": (n, of), ...}`` (over both sweep directions, and per direction); None if
    the grids differ.  The console (:func:`agreement_text`) and ``maps_agreement.png`` give
    these numbers."""
    same = class_agreement(a, b)
    if same is None:
        return None
    out = {"total": (int((~same).sum()), int(same.size))}
    for k, d in enumerate(a.data["direction"]):
        out[str(d)] = (int((~same[k]).sum()), int(same[k].size))
    return out


def agreement_text(a: MapResult, b: MapResult) -> str | None:
    """``"'b' vs 'a': classes differ at n of N points (up n1 of N1, down n2 of N2)"``; None if the
    grids differ."""
    c = agreement_counts(a, b)
    if c is None:
        return None
    dirs = [str(d) for d in a.data["direction"]]
    per = f" ({', '.join(f'{d} {c[d][0]} of {c[d][1]}' for d in dirs)})" if len(dirs) > 1 else ""
    return f"'{b.name}' vs '{a.name}': classes differ at {c['total'][0]} of {c['total'][1]} points{per}"


def agreement_figure(maps: list, title: str = "", case=None):
    """Class of every map against the first one's: one row of panels per other map, one
    column per sweep direction; light grey where both agree, the other map's class colour
    where they differ (the legend says whose class the colour is).  Each panel's title gives
    its count, the figure's title the total over both directions -- the numbers the console
    prints (:func:`agreement_text`).  None if fewer than two maps share a grid.  A Figure."""
    if not maps:
        return None
    ref = maps[0]
    others = [m for m in maps[1:] if class_agreement(ref, m) is not None]
    if not others:
        return None
    d = ref.data
    phys, xl, yl = _axes_labels(ref)
    x = np.asarray((d["frequency_hz"] if phys else d["Omega"])[0], float)
    X, Y = _mesh(x, d["values"])
    dirs = [str(v) for v in d["direction"]]
    cmap = ListedColormap(CLASS_COLOURS + (SAME_COLOUR,))
    norm = BoundaryNorm(np.arange(-0.5, len(CLASSES) + 1.5), cmap.N)
    with style.context():
        fig, axes = plt.subplots(len(others), len(dirs), figsize=(3.6 * len(dirs) + 3.2, 3.0 * len(others) + 1.0),
                                 squeeze=False, sharex=True, sharey=True)
        present = set()
        totals = []
        for row, m in zip(axes, others):
            same_all = class_agreement(ref, m)
            totals.append(f"'{m.name}' {int((~same_all).sum())} of {same_all.size} points")
            for k, ax in enumerate(row):
                same = same_all[k]
                cls = m.data["classification"][k]
                show = np.where(same, len(CLASSES), cls)
                present |= set(np.unique(cls[~same]).tolist())
                ax.pcolormesh(X, Y, show, cmap=cmap, norm=norm, edgecolors="face", lw=0)
                ax.set_title(f"'{m.name}' vs '{ref.name}', {dirs[k]} sweep: {int((~same).sum())} of {same.size} "
                             f"differ", loc="left")
                ax.grid(False)
            row[0].set_ylabel(yl)
        for ax in axes[-1]:
            ax.set_xlabel(xl)
        handles = [Patch(facecolor=SAME_COLOUR, edgecolor="0.6", lw=0.5, label=f"same class as '{ref.name}'")]
        handles += [Patch(facecolor=CLASS_COLOURS[i], edgecolor="0.5", lw=0.5, label=f"differs: {CLASSES[i]}")
                    for i in sorted(present)]
        names = " / ".join(f"'{m.name}'" for m in others)
        style.legend_outside(fig, handles, title=f"colour: the class of {names}\nwhere it differs from '{ref.name}'")
        style.titles(fig, f"{title + ': ' if title else ''}classes that differ from '{ref.name}' "
                          f"(up and down sweeps): {'; '.join(totals)}",
                     style.subtitle(case, runs=maps, exclude=(ref.parameter,)))
    return fig


def plot_agreement(maps: list, path, title: str = "", case=None):
    """:func:`agreement_figure` saved to ``path`` (``maps_agreement.png``); None if fewer than
    two maps share a grid."""
    return save_close(agreement_figure(maps, title, case), path)


def print_map(m: MapResult) -> None:
    """Counts of each class per direction, and the number of hysteresis points."""
    d = m.data
    for k, dname in enumerate(d["direction"]):
        c = d["classification"][k]
        counts = ", ".join(f"{CLASSES[i]} {int((c == i).sum())}" for i in CLASSES if (c == i).any())
        print(f"  {m.name} {dname}: {c.size} points: {counts}")
    h = hysteresis(m)
    if h is not None:
        print(f"  {m.name}: up and down sweeps differ at {int(h.sum())} of {h.size} points")


def map_lines(results: dict) -> dict:
    """The maps of a results file (:func:`vibeam.io.results.read_results`) as one run-like dict
    per parameter value, named ``<run>@<parameter>=<value>``: 1-D per-point datasets
    (``direction``, ``Omega``, ``amplitude``, ``period``, ...), the up line then the down line,
    each in increasing frequency -- the layout of ``/runs``, so FRC tools (regression,
    plots) treat a map's lines like runs.  Values that agree to 6 digits get their full
    ``repr`` instead, so no line replaces another."""
    out = {}
    for name, m in results.get("maps", {}).items():
        dirs = [str(d) for d in m["direction"]]
        par = m["attrs"].get("parameter", "value") if "attrs" in m else "value"
        for j, v in enumerate(m["values"]):
            run = {"attrs": dict(m.get("attrs", {}), map_value=float(v))}
            nf = m["classification"].shape[2]
            for k, arr in m.items():
                if k in ("attrs", "values", "direction") or not isinstance(arr, np.ndarray) \
                        or arr.ndim < 3 or arr.shape[:2] != (len(dirs), len(m["values"])):
                    continue
                run[k] = np.concatenate([arr[i, j] for i in range(len(dirs))])
            run["direction"] = np.repeat(np.array(dirs, dtype=object), nf)
            key = f"{name}@{par}={float(v):.6g}"
            if key in out:                       # values closer than 6 digits: never overwrite
                key = f"{name}@{par}={float(v)!r}"
            out[key] = run
    return out


def all_runs(results: dict) -> dict:
    """``/runs`` and the lines of ``/maps`` (:func:`map_lines`) of a results dict together."""
    return {**results.get("runs", {}), **map_lines(results)}
