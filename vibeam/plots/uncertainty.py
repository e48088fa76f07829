"""The FRC band figure of ``vibeam uncertainty``: per run the median amplitude over the samples with
its 50 % and 90 % bands, the runs of a ladder overlaid, one panel per sweep direction."""
from __future__ import annotations

import numpy as np

from vibeam.plots import style
from vibeam.plots.lazy import plt
from vibeam.plots.sweep import save_close

__all__ = ["band_figure", "plot_bands"]


def band_figure(bands, title: str = ""):
    """The figure of ``bands``, or None without a finite quantile.

    Parameters
    ----------
    bands : sequence of dict
        One per run: ``name``, ``x`` (shape ``(n,)``, the frequency grid), ``x_unit`` (``"Hz"`` or
        ``"1"``), ``directions`` (``up``/``down``), ``q`` (shape ``(5, n_directions, n)``: the 5, 25,
        50, 75 and 95 % quantiles of the amplitude) and ``unit`` (``"mm"`` or ``"1"``).
    title : str
        The figure's title.
    """
    bands = [b for b in bands if np.isfinite(b["q"]).any()]
    if not bands:
        return None
    dirs = [d for d in ("up", "down") if any(d in b["directions"] for b in bands)]
    with style.context():
        col = style.colours([b["name"] for b in bands])
        fig, axes = plt.subplots(1, len(dirs), figsize=(4.6 * len(dirs) + 2.4, 3.6), squeeze=False, sharey=True)
        handles = []
        for ax, d in zip(axes[0], dirs):
            ax.set_title(f"{d} sweep", loc="right")
            for b in bands:
                if d not in b["directions"]:
                    continue
                q = b["q"][:, b["directions"].index(d)]
                c = col[b["name"]]
                ax.fill_between(b["x"], q[0], q[4], color=c, alpha=0.15, lw=0, zorder=1)
                ax.fill_between(b["x"], q[1], q[3], color=c, alpha=0.35, lw=0, zorder=2)
                line, = ax.plot(b["x"], q[2], color=c, lw=1.4, zorder=3, label=b["name"])
                if d == dirs[0]:
                    handles.append(line)
            ax.set_xlabel(style.label("frequency" if bands[0]["x_unit"] == "Hz" else "Omega",
                                      "Hz" if bands[0]["x_unit"] == "Hz" else None))
        unit = bands[0]["unit"]
        axes[0][0].set_ylabel(style.label("amplitude Q", "mm" if unit == "mm" else None))
        from matplotlib.patches import Patch  # lazy: the legend's band patches (matplotlib loads with the figure)

        handles += [Patch(color="0.5", alpha=0.35, label="50 % band"), Patch(color="0.5", alpha=0.15, label="90 % band")]
        style.legend_outside(fig, handles)
        style.titles(fig, title, "median line; bands over the samples of [uncertainty]")
    return fig


def plot_bands(bands, path, title: str = ""):
    """:func:`band_figure` saved to ``path`` (``uncertainty.png``); returns the path, or None."""
    return save_close(band_figure(bands, title), path)
