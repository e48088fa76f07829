"""The figures of ``vibeam uncertainty``: the FRC bands (per run the median amplitude over the samples
with its 50 % and 90 % bands, one row per run and one panel per sweep direction, the other runs'
medians over each band), the
Sobol' indices against frequency and the outcome probabilities against frequency (one panel per run
and direction)."""
from __future__ import annotations

import numpy as np

from vibeam.plots import style
from vibeam.plots.lazy import plt
from vibeam.plots.sweep import save_close

__all__ = ["band_figure", "plot_bands", "sobol_figure", "plot_sobol", "outcome_figure", "plot_outcomes"]


#: the opacity of a run's 90 % band (5-95 %) and of its 50 % band (25-75 %) over it
BAND_ALPHA = {90: 0.22, 50: 0.45}


def band_figure(bands, title: str = ""):
    """The figure of ``bands``, or None without a finite quantile.

    One row of panels per run and one column per sweep direction, sharing both axes: each panel holds
    its run's 90 % band (5-95 %), its 50 % band (25-75 %) and its median in the run's colour, so no
    two runs' bands are ever drawn over each other (their translucent colours would mix into a colour
    of neither); the other runs' medians are drawn over it as thin dashed lines of their colours, to
    compare against the band.  The legend's band patches are the bands' own colours.  Amplitude at the
    sensor ``U(L_S)`` in mm on a physical scene (the quantiles of ``Q`` times ``L``), else ``Q``.

    Parameters
    ----------
    bands : sequence of dict
        One per run: ``name``, ``x`` (shape ``(n,)``, the frequency grid), ``x_unit`` (``"Hz"`` or
        ``"1"``), ``directions`` (``up``/``down``), ``q`` (shape ``(5, n_directions, n)``: the 5, 25,
        50, 75 and 95 % quantiles of the amplitude), ``unit`` (``"mm"`` or ``"1"``) and, optionally,
        ``samples`` (the number of samples) and ``parameters`` (the sampled names), said in the
        subtitle.
    title : str
        The figure's title.
    """
    bands = [b for b in bands if np.isfinite(b["q"]).any()]
    if not bands:
        return None
    dirs = [d for d in ("up", "down") if any(d in b["directions"] for b in bands)]
    from matplotlib.patches import Patch  # lazy: the legend's band patches (matplotlib loads with the figure)

    with style.context():
        col = style.colours([b["name"] for b in bands])
        fig, axes = plt.subplots(len(bands), len(dirs), figsize=(4.6 * len(dirs) + 2.6, 2.7 * len(bands) + 1.2),
                                 squeeze=False, sharex=True, sharey=True)
        handles = []
        for i, b in enumerate(bands):
            c = col[b["name"]]
            n = f", {b['samples']} samples" if b.get("samples") else ""
            handles += [style.proxy(c, ls="-", lw=1.6, label=f"{b['name']}: median{n} (thin dashed in the other "
                                                             f"runs' panels)" if len(bands) > 1 else
                                    f"{b['name']}: median{n}"),
                        Patch(facecolor=c, alpha=BAND_ALPHA[50], lw=0, label=f"{b['name']}: 50 % band (25-75 %)"),
                        Patch(facecolor=c, alpha=BAND_ALPHA[90], lw=0, label=f"{b['name']}: 90 % band (5-95 %)")]
            for j, d in enumerate(dirs):
                ax = axes[i][j]
                ax.set_title(f"{b['name']}: {d} sweep", loc="right", color=c)
                if d not in b["directions"]:
                    ax.set_visible(False)
                    continue
                q = b["q"][:, b["directions"].index(d)]
                ax.fill_between(b["x"], q[0], q[4], facecolor=c, alpha=BAND_ALPHA[90], lw=0, zorder=1)
                ax.fill_between(b["x"], q[1], q[3], facecolor=c, alpha=BAND_ALPHA[50], lw=0, zorder=2)
                ax.plot(b["x"], q[2], color=c, lw=1.6, zorder=4, label=f"{b['name']} median")
                for o in bands:               # the other runs' medians over this run's band
                    if o is not b and d in o["directions"]:
                        ax.plot(o["x"], o["q"][2, o["directions"].index(d)], color=col[o["name"]], lw=0.9,
                                ls="--", zorder=3, label=f"{o['name']} median")
                if i == len(bands) - 1:
                    ax.set_xlabel(style.label("forcing frequency f", "Hz") if b["x_unit"] == "Hz" else
                                  style.label(r"forcing frequency $\Omega = f/f_n$", None))
            axes[i][0].set_ylabel(style.label(r"amplitude at the sensor, $U(L_S)$", "mm") if b["unit"] == "mm"
                                  else style.label(r"amplitude $Q = \Delta - \min q$", None))
        style.legend_outside(fig, handles, loc="outside lower center", ncol=len(bands))   # a column per run
        ns = sorted({b["samples"] for b in bands if b.get("samples")})
        params = list(dict.fromkeys(p for b in bands for p in b.get("parameters", ())))
        over = (f"over {' or '.join(map(str, ns))} samples" if ns else "over the samples") + \
            (f" of {', '.join(params)}" if params else "")
        style.titles(fig, title, f"median and bands of the amplitude {over}; 50 % band: 25-75 %, 90 % band: 5-95 % "
                                 f"of the samples at each frequency")
    return fig


def plot_bands(bands, path, title: str = ""):
    """:func:`band_figure` saved to ``path`` (``uncertainty.png``); returns the path, or None."""
    return save_close(band_figure(bands, title), path)


def _grid(entries, dirs, height=2.6):
    """A figure of one row per entry (run) and one column per direction, sharing the frequency axis."""
    fig, axes = plt.subplots(len(entries), len(dirs), figsize=(4.6 * len(dirs) + 2.4, height * len(entries) + 1.0),
                             squeeze=False, sharex=True)
    for i, e in enumerate(entries):
        for j, d in enumerate(dirs):
            ax = axes[i][j]
            ax.set_title(f"{e['name']}: {d} sweep", loc="right")
            if i == len(entries) - 1:
                ax.set_xlabel(style.label("frequency" if e["x_unit"] == "Hz" else "Omega",
                                          "Hz" if e["x_unit"] == "Hz" else None))
    return fig, axes


def _panels(entries, dirs, axes):
    """``(e, k, ax, first_column)`` for every panel of :func:`_grid` whose run has the direction
    (``k``: its index in the run's directions); a panel of a direction the run lacks is hidden."""
    for i, e in enumerate(entries):
        for j, d in enumerate(dirs):
            ax = axes[i][j]
            if d not in e["directions"]:
                ax.set_visible(False)
                continue
            yield e, e["directions"].index(d), ax, j == 0


def sobol_figure(entries, title: str = ""):
    """Sobol' indices of the amplitude against frequency, or None without a finite index.

    Parameters
    ----------
    entries : sequence of dict
        One per run: ``name``, ``x`` (shape ``(n,)``), ``x_unit`` (``"Hz"`` or ``"1"``),
        ``directions``, ``parameters`` (``d`` names), ``first`` and ``total`` (shape
        ``(d, n_directions, n)``), ``first_ci`` and ``total_ci`` (shape ``(2, d, n_directions, n)``:
        the intervals' lower and upper ends).  First-order indices are solid lines with their
        interval shaded, total indices dashed.
    title : str
        The figure's title.
    """
    entries = [e for e in entries if np.isfinite(e["first"]).any() or np.isfinite(e["total"]).any()]
    if not entries:
        return None
    dirs = [d for d in ("up", "down") if any(d in e["directions"] for e in entries)]
    names = list(dict.fromkeys(p for e in entries for p in e["parameters"]))
    with style.context():
        col = style.colours(names)
        fig, axes = _grid(entries, dirs)
        for e, k, ax, first_column in _panels(entries, dirs, axes):
            for p, name in enumerate(e["parameters"]):
                c = col[name]
                ax.fill_between(e["x"], e["first_ci"][0, p, k], e["first_ci"][1, p, k], color=c, alpha=0.2, lw=0)
                ax.plot(e["x"], e["first"][p, k], color=c, lw=1.4)
                ax.plot(e["x"], e["total"][p, k], color=c, lw=1.2, ls="--")
            ax.set_ylim(-0.05, 1.05)
            if first_column:
                ax.set_ylabel(style.label("Sobol' index", None))
        handles = [style.proxy(col[n], ls="-", label=n) for n in names]
        handles += [style.proxy("0.3", ls="-", label="first order (95 % interval shaded)"),
                    style.proxy("0.3", ls="--", label="total")]
        style.legend_outside(fig, handles)
        style.titles(fig, title, "Sobol' indices of the amplitude over Saltelli's design of the sampled parameters")
    return fig


def plot_sobol(entries, path, title: str = ""):
    """:func:`sobol_figure` saved to ``path`` (``uncertainty_sobol.png``); returns the path, or None."""
    return save_close(sobol_figure(entries, title), path)


def outcome_figure(entries, title: str = ""):
    """Outcome probabilities against frequency, or None without samples.

    Parameters
    ----------
    entries : sequence of dict
        One per run: ``name``, ``x`` (shape ``(n,)``), ``x_unit``, ``directions``, ``outcomes``
        (names), ``p`` (shape ``(n_outcomes, n_directions, n)``: the fraction of the samples in each),
        ``colours`` (one per outcome) and ``stacked`` (one bool per outcome: the classes, which add up
        to 1, are stacked areas; the statuses, which overlap them, dashed lines).  Outcomes that no
        sample reaches are left out.
    title : str
        The figure's title.
    """
    entries = [e for e in entries if np.size(e["p"])]
    if not entries:
        return None
    dirs = [d for d in ("up", "down") if any(d in e["directions"] for e in entries)]
    with style.context():
        fig, axes = _grid(entries, dirs)
        seen = {}
        for e, k, ax, first_column in _panels(entries, dirs, axes):
            used = [m for m in range(len(e["outcomes"])) if np.nanmax(e["p"][m, k]) > 0]
            areas = [m for m in used if e["stacked"][m]]
            if areas:
                ax.stackplot(e["x"], *[e["p"][m, k] for m in areas], colors=[e["colours"][m] for m in areas],
                             lw=0, alpha=0.85)
            for m in used:
                if not e["stacked"][m]:
                    ax.plot(e["x"], e["p"][m, k], color=e["colours"][m], lw=1.3, ls="--")
                seen.setdefault((e["outcomes"][m], e["stacked"][m]), e["colours"][m])
            ax.set_ylim(0.0, 1.0)
            if first_column:
                ax.set_ylabel(style.label("probability", None))
        from matplotlib.patches import Patch  # lazy: the legend's area patches (matplotlib loads with the figure)

        handles = [Patch(color=c, label=n) if area else style.proxy(c, ls="--", label=f"status {n}")
                   for (n, area), c in seen.items()]
        style.legend_outside(fig, handles)
        style.titles(fig, title, "fraction of the samples in each outcome")
    return fig


def plot_outcomes(entries, path, title: str = ""):
    """:func:`outcome_figure` saved to ``path`` (``uncertainty_outcomes.png``); returns the path, or None."""
    return save_close(outcome_figure(entries, title), path)
