"""Figures of a sweep (matplotlib, Agg backend, the style of :mod:`vibeam.plots.style`).

* ``frc.png`` (:func:`frc_figure`): the FRC of every run, one colour per run and, with
  several runs, one panel per run on shared axes (small multiples: overlaid, the rungs of a
  ladder hid each other), up sweeps solid with filled markers and down sweeps dashed with open markers; the
  marker is the period class (circle period-1, triangle period-2, square period-n,
  small dot no impact); non-periodic points are crosses with a bar over the range of
  their per-period amplitude Q_k (``amplitude_min`` .. ``amplitude_max``, when the run
  stored them: one sample of an attractor is not one number); failed points (no
  amplitude) are red crosses along the bottom of the axes; a scene with a lower stop has
  both stops drawn as horizontal lines (:func:`vibeam.plots.style.stop_lines`).
* ``bifurcation.png`` (:func:`bifurcation_figure`): stroboscopic displacement against
  the forcing frequency, small dots, one row per time-domain run and one column per sweep
  direction, every panel on the same axes.

The ``*_figure`` functions return a :class:`matplotlib.figure.Figure` (for a notebook,
or a test that inspects it); ``plot_*`` save it through :func:`save_figure` (a
temporary file renamed into place, so a failed or interrupted write never leaves a
partial PNG).
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from vibeam.io.outdir import replace_file
from vibeam.plots import style
from vibeam.plots.lazy import plt


def save_figure(fig, path, dpi: int = 150) -> Path:
    """Save a matplotlib figure atomically (:func:`vibeam.io.outdir.replace_file`: a temporary
    file beside ``path``, flushed, then renamed over it); on any error the temporary file is
    removed, ``path`` is left as it was and the error raised."""
    path = Path(path)
    return replace_file(path, lambda tmp: fig.savefig(tmp, dpi=dpi, format=path.suffix.lstrip(".") or "png"))


def save_close(fig, path):
    """Save ``fig`` to ``path`` (:func:`save_figure`) and close it; None for no figure."""
    if fig is None:
        return None
    try:
        return save_figure(fig, path)
    finally:
        plt.close(fig)


def _mm(r) -> float:
    """Factor from nondimensional displacement to mm (1 for nondimensional scenes)."""
    L = r.attrs.get("length_m")
    return L * 1e3 if L and "amplitude_mm" in r.data else 1.0


def axes_data(r):
    """(x, amplitude, x label, amplitude label) of a run, physical units where it has them."""
    d = r.data
    if "frequency_hz" in d and "amplitude_mm" in d:
        return (np.asarray(d["frequency_hz"], float), np.asarray(d["amplitude_mm"], float),
                style.label("forcing frequency f", "Hz"), style.label(r"amplitude at the sensor, $U(L_S)$", "mm"))
    return (np.asarray(d["Omega"], float), np.asarray(d["amplitude"], float),
            style.label(r"forcing frequency $\Omega = f/f_n$", None),
            style.label(r"amplitude $Q = \Delta - \min q$", None))


def _model_of(r, case=None) -> dict:
    """The model table of run ``r``: the one it stored (``attrs["model"]``), else the case's
    ``[model]`` with the run's overrides; {} without either."""
    m = (getattr(r, "attrs", None) or {}).get("model")
    if isinstance(m, dict):
        return m
    if case is None:
        return {}
    own = next((x.model for x in getattr(case, "run", []) if x.name == r.name), None) or {}
    return dict(case.model, **own)


def _directions(r, n):
    return np.asarray([str(v) for v in r.data.get("direction", ["up"] * n)])


def frc_figure(runs, title: str = "", case=None, colours: dict | None = None):
    """The FRC of every run: one axes for one run, one panel per run (shared axes) for several
    (see the module docstring); a Figure.

    Parameters
    ----------
    runs : list of vibeam.engine.sweep.SweepResult
    title : str
        Figure title (the case name); the case's parameters go in the subtitle.
    case : vibeam.case.schema.Case, optional
        For the subtitle and the run colours (case order).
    colours : dict, optional
        Run name -> colour (default :func:`vibeam.plots.style.colours` of the case's runs).
    """
    with style.context():
        n = len(runs)
        ncol = 1 if n <= 1 else 2
        nrow = max(1, -(-n // ncol))
        if n <= 1:
            fig, ax0 = plt.subplots(figsize=(8.0, 4.6))
            axes = [ax0]
        else:       # small multiples: one panel per run on shared axes (overlaid runs hide each other)
            fig, grid = plt.subplots(nrow, ncol, figsize=(4.2 * ncol + 3.0, 2.1 * nrow + 1.3), sharex=True,
                                     sharey=True, squeeze=False)
            axes = list(grid.ravel())
            for extra in axes[n:]:
                fig.delaxes(extra)
            axes = axes[:n]
            for a in grid.ravel()[max(n - ncol, 0):n]:
                a.xaxis.set_tick_params(labelbottom=True)
        col = colours or style.colours(style.run_names(case, runs))
        classes, dirs_seen, stops_seen = {}, [], {}
        xl = yl = ""
        for ax, r in zip(axes, runs):
            x, y, xl, yl = axes_data(r)
            c = col.get(r.name, "0.3")
            period = np.asarray(r.data.get("period", np.ones(len(x), dtype=int)))
            direc = _directions(r, len(x))
            st = np.asarray([str(v) for v in r.data.get("status", [])])
            failed = st == "failed" if st.size == len(x) else np.zeros(len(x), bool)
            lo = hi = None
            if "amplitude_min" in r.data and "amplitude_max" in r.data:
                lo = np.asarray(r.data["amplitude_min"], float) * _mm(r)
                hi = np.asarray(r.data["amplitude_max"], float) * _mm(r)
            for dname in ("up", "down"):
                sel = direc == dname
                if not sel.any():
                    continue
                ds = style.DIRECTIONS[dname]
                if dname not in dirs_seen:
                    dirs_seen.append(dname)
                o = np.argsort(x[sel])
                ax.plot(x[sel][o], y[sel][o], ls=ds["ls"], color=c, lw=1.0, zorder=2)
                for p in np.unique(period[sel]):
                    mk, lab = style.period_marker(p)
                    s = sel & (period == p) & ~failed
                    if not s.any():
                        continue
                    classes[lab] = mk
                    if int(p) == -1:
                        ax.plot(x[s], y[s], ls="none", marker=mk, color=c, ms=3, zorder=3)
                        continue
                    # up: filled markers; down: larger open rings drawn over them, so where the two
                    # sweeps agree both stay visible (a dot in a ring)
                    ax.plot(x[s], y[s], ls="none", marker=mk, color=c, mec=c, mfc=c if ds["fill"] else "none",
                            ms=(4.0 if ds["fill"] else 7.0) if mk != "x" else 5, mew=1.0 if ds["fill"] else 0.9,
                            zorder=3 if ds["fill"] else 4)
                    if int(p) == 0 and lo is not None:
                        b = s & np.isfinite(lo) & np.isfinite(hi)
                        if b.any():
                            ax.vlines(x[b], lo[b], hi[b], color=c, lw=1.6, alpha=0.55, zorder=2,
                                      linestyles="solid" if ds["fill"] else "dashed")
            if failed.any():   # no amplitude: marked along the bottom of the axes
                ax.plot(x[failed], np.full(int(failed.sum()), 0.02), ls="none", marker="x",
                        color=style.FAILED_COLOUR, ms=6, transform=ax.get_xaxis_transform(), clip_on=False)
                classes[f"failed ({int(failed.sum())} points)"] = "failed"
            if "amplitude_lower" in r.data:
                ax.plot(x, np.asarray(r.data["amplitude_lower"], float) * _mm(r), ":", color=c, lw=1.0)
                classes["lower branch of P(Q) = 0 (dotted)"] = "lower"
            for q, lab in style.stop_lines(_model_of(r, case)):   # the stops' positions on the amplitude axis
                ls = style.STOP_LINES["upper" if q == 0.0 else "lower"]
                ax.axhline(q, color="0.35", ls=ls, lw=0.9, zorder=1, gid="stop")
                stops_seen[lab.split(" (")[0]] = ls
            if n > 1:
                ax.set_title(f"{r.name} ({r.method})", loc="left", color=c)
        for i, ax in enumerate(axes):
            if i + ncol >= n or n <= 1:                  # the lowest panel of each column
                ax.set_xlabel(xl)
        # one amplitude label for the shared axis, at the middle row of the first column
        axes[((nrow - 1) // 2) * ncol if n > 1 else 0].set_ylabel(yl)
        handles = [style.proxy(col[r.name], ls="-", label=f"{r.name} ({r.method})") for r in runs
                   if r.name in col]
        handles += [style.proxy("0.25", ls=style.DIRECTIONS[d]["ls"], marker="o", fill=style.DIRECTIONS[d]["fill"],
                                label=style.DIRECTIONS[d]["label"]) for d in dirs_seen]
        for lab, mk in classes.items():
            if mk == "failed":
                handles.append(style.proxy(style.FAILED_COLOUR, marker="x", label=lab))
            elif mk == "lower":
                handles.append(style.proxy("0.25", ls=":", label=lab))
            else:
                handles.append(style.proxy("0.25", marker=mk, label=lab, ms=3 if mk == "." else 5))
        handles += [style.proxy("0.35", ls=ls, label=f"{lab} (horizontal line)") for lab, ls in stops_seen.items()]
        style.legend_outside(fig, handles)
        style.titles(fig, title or "frequency response curves", style.subtitle(case, runs=runs))
    return fig


def impact_speed_scale(r):
    """Factor from a run's nondimensional impact speeds (``impact_velocity``, per length L and
    time unit 1/omega_n) to mm/s at the stop: ``L 2 pi f_n 1e3`` for a physical run (one whose
    FRC is in Hz and mm, with ``length_m`` and ``natural_frequency_hz``); None for a
    nondimensional one."""
    a = getattr(r, "attrs", {}) or {}
    L, fn = a.get("length_m"), a.get("natural_frequency_hz")
    if "frequency_hz" in r.data and "amplitude_mm" in r.data and L and fn:
        return float(L) * 2.0 * np.pi * float(fn) * 1e3
    return None


def impacts_figure(runs, title: str = "", case=None, colours: dict | None = None):
    """Impacts of two-sided runs per stop against frequency: mean pre-impact speed (top; mm/s
    against Hz for physical runs, nondimensional against Omega otherwise) and impacts per
    period (bottom), upper stop solid, lower stop dotted, up filled and down open
    markers.  Where the lower stop is hit the amplitude ``Delta - min q`` saturates at
    ``Delta + Delta_lower``; these carry the information.  A Figure, or None when no run has a
    lower stop (``impacts_per_period_lower``)."""
    runs = [r for r in runs if "impacts_per_period_lower" in r.data]
    if not runs:
        return None
    with style.context():
        col = colours or style.colours(style.run_names(case, runs))
        fig, (ax1, ax2) = plt.subplots(2, 1, figsize=(8.0, 5.6), sharex=True)
        xl, dirs_seen = "", []
        phys = all(impact_speed_scale(r) is not None for r in runs)
        for r in runs:
            x, _, xl, _ = axes_data(r)
            if not phys:      # one axis for every run: nondimensional against Omega unless all are physical
                x, xl = np.asarray(r.data["Omega"], float), style.label(r"forcing frequency $\Omega = f/f_n$", None)
            k = impact_speed_scale(r) if phys else 1.0
            c = col.get(r.name, "0.3")
            direc = _directions(r, len(x))
            for dname in ("up", "down"):
                sel = direc == dname
                if not sel.any():
                    continue
                if dname not in dirs_seen:
                    dirs_seen.append(dname)
                fill = style.DIRECTIONS[dname]["fill"]
                o = np.argsort(x[sel])
                for key_v, key_n, ls in (("impact_velocity", "impacts_per_period", "-"),
                                         ("impact_velocity_lower", "impacts_per_period_lower", ":")):
                    for ax, key, f in ((ax1, key_v, k), (ax2, key_n, 1.0)):
                        ax.plot(x[sel][o], np.asarray(r.data[key], float)[sel][o] * f, ls=ls, marker="o",
                                ms=3.5, color=c, mec=c, mfc=c if fill else "none", lw=1.0)
        ax1.set_ylabel(style.label(r"mean pre-impact speed $|v^-|$", "mm/s") if phys else
                       style.label(r"mean pre-impact speed $|\dot q^-|$", None))
        ax2.set_ylabel(style.label("impacts per period", None))
        ax2.set_xlabel(xl)
        handles = [style.proxy(col.get(r.name, "0.3"), ls="-", label=f"{r.name} ({r.method})") for r in runs]
        handles += [style.proxy("0.25", ls="-", label="upper stop (solid)"),
                    style.proxy("0.25", ls=":", label="lower stop (dotted)")]
        handles += [style.proxy("0.25", marker="o", fill=style.DIRECTIONS[d]["fill"],
                                label=f"{d} sweep ({'filled' if style.DIRECTIONS[d]['fill'] else 'open'} markers)")
                    for d in dirs_seen]
        style.legend_outside(fig, handles)
        style.titles(fig, (title + ": " if title else "") + "impacts on each stop",
                     style.subtitle(case, runs=runs))
    return fig


def plot_impacts(runs, path, title: str = "", case=None, colours=None) -> Path | None:
    """:func:`impacts_figure` saved to ``path`` (``impacts.png``); None without a two-sided run."""
    return save_close(impacts_figure(runs, title, case, colours), path)


def plot_frc(runs, path, title: str = "", case=None, colours=None) -> Path:
    """:func:`frc_figure` saved to ``path`` (``frc.png``); returns the path."""
    return save_close(frc_figure(runs, title, case, colours), path)


def bifurcation_figure(runs, title: str = "", case=None, colours: dict | None = None):
    """Stroboscopic displacement against frequency (the bifurcation diagram): one row of panels
    per run with strobe samples and one column per sweep direction (up, down), every sample a
    small dot without an edge (:data:`vibeam.plots.style.DOT_SIZE`, as the field draws them: a
    chaotic band stays a cloud) in the run's colour; all panels share the frequency and the
    displacement axis, so the rungs of a ladder compare by eye.  A Figure, or None."""
    runs = [r for r in runs if "strobe" in r.data and np.isfinite(r.data["strobe"]).any()]
    if not runs:
        return None
    dirs = [d for d in ("up", "down") if any((_directions(r, len(r.data["Omega"])) == d).any() for r in runs)]
    with style.context():
        col = colours or style.colours(style.run_names(case, runs))
        fig, axes = plt.subplots(len(runs), len(dirs), figsize=(4.0 * len(dirs) + 2.6, 2.0 * len(runs) + 1.2),
                                 squeeze=False, sharex=True, sharey=True)
        xl, stops_seen = "", {}
        for row, r in zip(axes, runs):
            x, _, xl, _ = axes_data(r)
            s = np.asarray(r.data["strobe"], float)[:, :, 0] * _mm(r)
            direc = _directions(r, len(x))
            c = col.get(r.name, "0.3")
            for ax, dname in zip(row, dirs):
                sel = direc == dname
                ax.set_title(f"{r.name} ({r.method})", loc="left")
                ax.set_title(f"{dname} sweep", loc="right")
                if not sel.any():
                    ax.text(0.5, 0.5, f"no {dname} sweep", transform=ax.transAxes, ha="center", color="0.5")
                    continue
                xs = np.repeat(x[sel][:, None], s.shape[1], axis=1)
                ax.plot(xs.ravel(), s[sel].ravel(), ls="none", marker="o", ms=style.DOT_SIZE, color=c, mfc=c,
                        mew=0, zorder=3)
                for q, lab in style.stop_positions(_model_of(r, case)):   # the stops on the displacement axis
                    ls = style.STOP_LINES["upper" if lab.startswith("upper") else "lower"]
                    ax.axhline(q, color="0.35", ls=ls, lw=0.9, zorder=1, gid="stop")
                    stops_seen[lab] = ls
            phys = "amplitude_mm" in r.data
            row[0].set_ylabel(style.label(f"{style.DISPLACEMENT} at phase 0", "mm") if phys else
                              style.label("$q$ at phase 0", None))
        for ax in axes[-1]:
            ax.set_xlabel(xl)
        handles = [style.proxy(col.get(r.name, "0.3"), marker="o", label=f"{r.name} ({r.method})") for r in runs]
        handles += [style.proxy("0.35", ls=ls, label=f"{lab} (horizontal line)") for lab, ls in stops_seen.items()]
        style.legend_outside(fig, handles)
        style.titles(fig, (title + ": " if title else "") + "bifurcation diagram (stroboscopic map)",
                     style.subtitle(case, runs=runs))
    return fig


def plot_bifurcation(runs, path, title: str = "", case=None, colours=None) -> Path | None:
    """:func:`bifurcation_figure` saved to ``path`` (``bifurcation.png``); None without strobe data."""
    return save_close(bifurcation_figure(runs, title, case, colours), path)


def simulation_figure(sim):
    """Displacement and velocity of one frequency against time, with the impacts, and the
    phase portrait (:func:`vibeam.simulate`); a Figure."""
    with style.context():
        fig, axes = plt.subplots(1, 3, figsize=(11.0, 3.4))
        phys = sim.physical
        t = sim.time_s if phys else sim.t
        x = sim.U_mm if phys else sim.q
        v = sim.dU_mm_s if phys else sim.dq
        ti = sim.impact_times_s if phys else sim.impact_times
        tu, xu, vu = ("s", "mm", "mm/s") if phys else (None, None, None)
        c = style.PALETTE[0]
        axes[0].plot(t, x, color=c)
        axes[1].plot(t, v, color=c)
        axes[2].plot(x, v, color=c, lw=0.8)
        if len(ti):
            xi = np.interp(ti, t, x)
            axes[0].plot(ti, xi, ls="none", marker="v", color=style.PALETTE[1], ms=5, label="impact")
        axes[0].set_xlabel(style.label("time t", tu))
        axes[1].set_xlabel(style.label("time t", tu))
        axes[0].set_ylabel(style.label(style.DISPLACEMENT if phys else "$q$", xu))
        axes[1].set_ylabel(style.label(style.VELOCITY if phys else r"$\dot q$", vu))
        axes[2].set_xlabel(style.label(style.DISPLACEMENT if phys else "$q$", xu))
        axes[2].set_ylabel(style.label(style.VELOCITY if phys else r"$\dot q$", vu))
        axes[0].set_title("displacement", loc="left")
        axes[1].set_title("velocity", loc="left")
        axes[2].set_title("phase portrait", loc="left")
        # the legend names what is drawn; the point's outcome (status) goes in the subtitle
        handles = [style.proxy(c, ls="-", label=f"recorded motion ({len(t)} samples)")]
        if len(ti):
            handles.append(style.proxy(style.PALETTE[1], marker="v", label=f"impacts ({len(ti)})"))
        style.legend_outside(fig, handles)
        f = f"{sim.Omega * sim.natural_frequency_hz:.4g} Hz, " if phys else ""
        name = getattr(sim, "name", "")
        style.titles(fig, f"{name + ': ' if name else ''}one forcing frequency: {f}$\\Omega$ = {sim.Omega:.6g}",
                     f"{style.motion_text(sim.summary.get('period'), sim.status)}, "
                     f"{sim.summary.get('impacts_per_period', 0):.3g} impacts per period")
    return fig
