"""The mode shapes of a 3D continuum (``modes.png`` of ``vibeam modes`` on a ``builder = "continuum"``
scene, issue 59)."""
from __future__ import annotations

import numpy as np

from vibeam.plots import style
from vibeam.plots.lazy import plt

__all__ = ["continuum_modes_figure"]


def continuum_modes_figure(rep: dict, title: str = ""):
    """The continuum's mode shapes (the first four): the bending deflection ``u_z`` along the strip's
    centreline (and ``u_y`` of a lateral mode) and ``u_z`` across its width at the tip (torsion), each
    over its largest displacement; a Figure (``modes.png``
    of ``vibeam modes``).  ``rep``: :func:`vibeam.case.structure.modes_report`."""
    mesh, md = rep["mesh"], rep["modes"]
    P = mesh.points
    y_mid = P[np.argmin(np.abs(P[:, 1])), 1]
    centre = np.flatnonzero(np.isclose(P[:, 1], y_mid))
    xs, inv = np.unique(np.round(P[centre, 0], 12), return_inverse=True)
    tip = np.flatnonzero(np.isclose(P[:, 0], P[:, 0].max()))
    ys, inv_t = np.unique(np.round(P[tip, 1], 12), return_inverse=True)
    with style.context():
        fig, axes = plt.subplots(1, 2, figsize=(10, 4.4), gridspec_kw={"width_ratios": [2, 1]})
        for i in range(min(4, md.shapes.shape[2])):
            u = md.shapes[:, :, i]
            scale = max(float(np.max(np.linalg.norm(u, axis=1))), 1e-300)   # the largest displacement: 1
            line = np.bincount(inv, u[centre, 2]) / np.bincount(inv)        # mean over the thickness
            side = np.bincount(inv, u[centre, 1]) / np.bincount(inv)
            across = np.bincount(inv_t, u[tip, 2]) / np.bincount(inv_t)
            lab = f"{md.frequencies_hz[i]:.2f} Hz"
            ln, = axes[0].plot(xs * 1e3, line / scale, label=lab)
            if np.max(np.abs(side)) > 0.05 * scale:                         # a lateral (in-plane) mode
                axes[0].plot(xs * 1e3, side / scale, ls="--", color=ln.get_color(), label=f"{lab}, u_y")
            axes[1].plot(ys * 1e3, across / scale, label=lab)
        axes[0].set_title("along the strip's centreline (u_z; dashed: u_y)", loc="left")
        axes[0].set_xlabel(style.label("position along the strip x", "mm"))
        axes[0].set_ylabel(style.label("normalised displacement", None))
        axes[1].set_title("across the width at the tip", loc="left")
        axes[1].set_xlabel(style.label("position across the strip y", "mm"))
        axes[0].legend(loc="upper center", bbox_to_anchor=(0.5, -0.16), ncol=4, title="mode")
        style.titles(fig, title, "mode shapes of the 3D continuum")
    return fig
