"""Plots a person wants to look at after a sweep (matplotlib, Agg backend).

* ``frc.png``: the FRC of every run overlaid, period-1 as dots, period-2 as
  triangles, higher periods as squares, non-periodic as crosses with a bar over
  the range of the per-period amplitude (min..max of Q_k over the record: one
  sample of an attractor is not one number), no-impact points as small grey
  dots; failed points (no amplitude) as red crosses along the bottom of the axes.
* ``bifurcation.png``: stroboscopic displacement q against the forcing
  frequency, one panel per time-domain run.

Every figure is written through :func:`save_figure` (a temporary file renamed
into place), so a failed or interrupted write never leaves a partial PNG.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from .sweep import SweepResult

MARKERS = {1: ("o", "period 1"), 2: ("^", "period 2"), 0: ("x", "not periodic (n > 8)"),
           -1: (".", "no impact")}


def save_figure(fig, path, dpi: int = 120) -> Path:
    """Save a matplotlib figure atomically: to a temporary file beside ``path``, then
    :func:`os.replace`; on any error the temporary file is removed and the error raised."""
    import os
    import tempfile

    path = Path(path)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.stem}-", suffix=path.suffix + ".tmp", dir=path.parent)
    os.close(fd)
    try:
        fig.savefig(tmp, dpi=dpi, format=path.suffix.lstrip(".") or "png")
        os.chmod(tmp, 0o666 & ~_umask())
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise
    return path


def _umask() -> int:
    import os

    mask = os.umask(0)
    os.umask(mask)
    return mask


def _mm(r: SweepResult) -> float:
    """Factor from nondimensional displacement to mm (1 for nondimensional scenes)."""
    L = r.attrs.get("length_m")
    return L * 1e3 if L and "amplitude_mm" in r.data else 1.0


def _axes_data(r: SweepResult):
    d = r.data
    if "frequency_hz" in d and "amplitude_mm" in d:
        return d["frequency_hz"], d["amplitude_mm"], "forcing frequency (Hz)", "amplitude at sensor (mm)"
    return d["Omega"], d["amplitude"], r"$\Omega$", r"$Q = \Delta - \min q$"


def plot_frc(runs: list[SweepResult], path, title: str = "") -> Path:
    """Overlay the FRCs of ``runs`` with period-n markers; returns the PNG path."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(8, 5))
    colors = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    seen = set()
    for i, r in enumerate(runs):
        x, y, xl, yl = _axes_data(r)
        c = colors[i % len(colors)]
        period = r.data.get("period", np.ones(len(x), dtype=int))
        dirs = r.data.get("direction", np.array(["up"] * len(x), dtype=object))
        for dname in ("up", "down"):
            sel = np.array([str(v) == dname for v in dirs])
            if not sel.any():
                continue
            order = np.argsort(x[sel])
            ls = "-" if dname == "up" else "--"
            ax.plot(x[sel][order], y[sel][order], ls, color=c, lw=1,
                    label=f"{r.name} ({r.method}, {dname})" if sel.any() else None)
        for p in np.unique(period):
            mk, lab = MARKERS.get(int(p), ("s", "period > 2"))
            sel = period == p
            lab_key = (mk, lab)
            ax.plot(x[sel], y[sel], mk, color=c if p != -1 else "0.6", ms=4 if p != -1 else 3,
                    mfc="none" if mk in "^s" else c, linestyle="none",
                    label=lab if lab_key not in seen else None)
            seen.add(lab_key)
        if "amplitude_min" in r.data and "amplitude_max" in r.data:
            lo = np.asarray(r.data["amplitude_min"], float) * _mm(r)
            hi = np.asarray(r.data["amplitude_max"], float) * _mm(r)
            sel = (np.asarray(period) == 0) & np.isfinite(lo) & np.isfinite(hi)
            if sel.any():
                lab = "range of $Q_k$ (not periodic)"
                ax.vlines(x[sel], lo[sel], hi[sel], color=c, lw=1.5, alpha=0.6,
                          label=lab if lab not in seen else None)
                seen.add(lab)
        st = np.asarray([str(v) for v in r.data.get("status", [])])
        bad = st == "failed" if st.size == len(x) else np.zeros(len(x), bool)
        if bad.any():   # failed points have no amplitude: marked along the bottom of the axes
            ax.plot(np.asarray(x, float)[bad], np.full(int(bad.sum()), 0.02), "x", color="r", ms=6,
                    transform=ax.get_xaxis_transform(), linestyle="none",
                    label=f"{r.name}: failed ({int(bad.sum())} points)")
        if "amplitude_lower" in r.data:
            ax.plot(x, r.data["amplitude_lower"] * _mm(r),
                    ":", color=c, lw=1, label=f"{r.name} lower branch")
    ax.set_xlabel(xl)
    ax.set_ylabel(yl)
    ax.set_title(title or "frequency response curves")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, loc="best")
    fig.tight_layout()
    try:
        path = save_figure(fig, path)
    finally:
        plt.close(fig)
    return path


def plot_impacts(runs: list[SweepResult], path, title: str = "") -> Path | None:
    """Impacts of two-sided runs per stop against frequency: mean pre-impact speed (top) and
    impacts per period (bottom), upper stop solid, lower stop dotted.  Where the lower stop is
    hit the amplitude ``Delta - min q`` saturates at ``Delta + Delta_lower``; these carry the
    information.  None when no run has a lower stop (``impacts_per_period_lower``)."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    runs = [r for r in runs if "impacts_per_period_lower" in r.data]
    if not runs:
        return None
    fig, (ax1, ax2) = plt.subplots(2, 1, figsize=(8, 6), sharex=True)
    colors = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    for i, r in enumerate(runs):
        x, _, xl, _ = _axes_data(r)
        c = colors[i % len(colors)]
        dirs = np.asarray([str(v) for v in r.data.get("direction", ["up"] * len(x))])
        for dname, mk in (("up", "o"), ("down", "x")):
            sel = dirs == dname
            if not sel.any():
                continue
            for key_v, key_n, ls, stop in (("impact_velocity", "impacts_per_period", "-", "upper"),
                                           ("impact_velocity_lower", "impacts_per_period_lower", ":", "lower")):
                lab = f"{r.name}, {stop} stop ({dname})"
                ax1.plot(x[sel], np.asarray(r.data[key_v], float)[sel], ls, marker=mk, ms=3, color=c,
                         lw=1, label=lab)
                ax2.plot(x[sel], np.asarray(r.data[key_n], float)[sel], ls, marker=mk, ms=3, color=c, lw=1)
    ax1.set_ylabel("mean pre-impact speed |q'-|")
    ax2.set_ylabel("impacts per period")
    ax2.set_xlabel(xl)
    for ax in (ax1, ax2):
        ax.grid(alpha=0.3)
    ax1.legend(fontsize=7, loc="best")
    fig.suptitle(title or "impacts on each stop")
    fig.tight_layout()
    try:
        path = save_figure(fig, path)
    finally:
        plt.close(fig)
    return path


def plot_bifurcation(runs: list[SweepResult], path, title: str = "") -> Path | None:
    """Stroboscopic q against frequency for each run that has strobe samples."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    runs = [r for r in runs if "strobe" in r.data and np.isfinite(r.data["strobe"]).any()]
    if not runs:
        return None
    fig, axes = plt.subplots(len(runs), 1, figsize=(8, 2.6 * len(runs) + 0.6), squeeze=False, sharex=True)
    for ax, r in zip(axes[:, 0], runs):
        x, _, xl, _ = _axes_data(r)
        s = r.data["strobe"][:, :, 0]
        scale = _mm(r)
        xs = np.repeat(x[:, None], s.shape[1], axis=1)
        ax.plot(xs.ravel(), (s * scale).ravel(), ",k", alpha=0.6)
        ax.plot(xs.ravel(), (s * scale).ravel(), ".", color="k", ms=1)
        ax.set_ylabel("strobe q (mm)" if "amplitude_mm" in r.data else "strobe q")
        ax.set_title(f"{r.name} ({r.method})", fontsize=9)
        ax.grid(alpha=0.3)
    axes[-1, 0].set_xlabel(xl)
    fig.suptitle(title or "bifurcation diagram (stroboscopic map)")
    fig.tight_layout()
    try:
        path = save_figure(fig, path)
    finally:
        plt.close(fig)
    return path
