"""Poincaré sections of one forcing frequency (``vibeam poincare``, :func:`vibeam.poincare`).

Two sections of the settled motion:

* the stroboscopic section: the state ``(q, q')`` sampled once per forcing period, at forcing
  phase 0 (``Omega t = 2 pi k``); a period-n orbit leaves n points, a chaotic one a fractal set;
* the impact section: every impact as its forcing phase ``phi = Omega t mod 2 pi`` against its
  pre-impact velocity ``q'- >= 0`` (the impact map of the paper's Eqs. 28-37, Sec. 3.2: the
  state of the pointwise mapping is exactly (phase, velocity) at impact).

Both come from one simulation of the case's exact solver (:func:`vibeam.api.simulate`: the
event kernel's samples on a grid aligned with the forcing phase, and its impact log), after a
transient.  Units are the scene's: nondimensional ``q``, ``q'`` (time unit ``1/omega_n``), or for
a physical scene the sensor's ``U`` (mm) and ``U'`` (mm/s).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from vibeam.plots import style
from vibeam.plots import sweep as plot_sweep
from vibeam.plots.lazy import plt


@dataclass
class PoincareSection:
    """The stroboscopic and impact sections of one forcing frequency.

    Attributes
    ----------
    Omega : float
        Forcing frequency over the natural frequency; ``frequency_hz`` (Hz) for a physical scene.
    strobe_q, strobe_dq : ndarray, shape (periods,)
        ``q`` and ``q'`` at forcing phase 0 of each recorded period (nondimensional).
    impact_phase : ndarray, shape (k,)
        ``Omega t mod 2 pi`` of each impact in the record (rad, in [0, 2 pi)).
    impact_velocity : ndarray, shape (k,)
        Pre-impact velocity ``q'-`` of each impact (nondimensional, >= 0).
    length_m, natural_frequency_hz : float or None
        Scales of a physical scene: ``U = q L`` (mm: x 1e3), ``U' = q' L 2 pi f_n``.
    period, status : int, str
        Period-n of the record (:func:`vibeam.engine.records.summarize`: 0 not periodic within 8
        periods, -1 no impact) and the point's outcome as a sweep records it (``ok``,
        ``unsettled``, ``chatter``, ...); :attr:`period_text` says the period in words.
    name : str
        The case (and run) simulated, the figure's title ('' for a model).
    impact_stop : ndarray of int, shape (k,), or None
        A scene with several stops: the stop of each impact (0 the upper stop, 1 the lower one, 2 + i
        the beam's point stop i; ``models.trajectory.Trajectory.impact_stops``); None with one stop.
    """

    Omega: float
    strobe_q: np.ndarray
    strobe_dq: np.ndarray
    impact_phase: np.ndarray
    impact_velocity: np.ndarray
    length_m: float | None = None
    natural_frequency_hz: float | None = None
    period: int = 0
    status: str = "ok"
    name: str = ""
    impact_stop: np.ndarray | None = None

    @property
    def period_text(self) -> str:
        """``period-n``, ``not periodic within 8 periods`` or ``no impact``."""
        return {0: "not periodic within 8 periods", -1: "no impact"}.get(self.period, f"period-{self.period}")

    @property
    def physical(self) -> bool:
        return bool(self.length_m and self.natural_frequency_hz)

    @property
    def frequency_hz(self) -> float | None:
        return self.Omega * self.natural_frequency_hz if self.natural_frequency_hz else None

    @property
    def scales(self) -> tuple:
        """``(displacement, velocity)`` factors to the plotted units (mm, mm/s), or (1, 1)."""
        if not self.physical:
            return 1.0, 1.0
        s = self.length_m * 1e3
        return s, s * 2.0 * math.pi * self.natural_frequency_hz

    def plot(self, path=None, title: str = ""):
        """The two sections (:func:`poincare_figure`); saved atomically when ``path`` is given."""
        fig = poincare_figure(self, title)
        if path is not None:
            plot_sweep.save_figure(fig, path)
        return fig

    def to_xarray(self):
        """An :class:`xarray.Dataset` on ``strobe`` (periods) and ``impact``, with units."""
        import xarray as xr  # lazy: xarray (with pandas: 0.35 s) loads only when labelled data are asked for

        fx, fv = self.scales
        xu, vu = ("mm", "mm s-1") if self.physical else ("1", "1")
        ds = xr.Dataset(
            {"strobe_displacement": ("strobe", self.strobe_q * fx, {"units": xu, "long_name": "displacement at "
                                                                    "forcing phase 0"}),
             "strobe_velocity": ("strobe", self.strobe_dq * fv, {"units": vu, "long_name": "velocity at forcing "
                                                                "phase 0"}),
             "impact_phase": ("impact", self.impact_phase, {"units": "rad", "long_name": "forcing phase Omega t "
                                                           "mod 2 pi of the impact"}),
             "impact_velocity": ("impact", self.impact_velocity * fv, {"units": vu,
                                                                       "long_name": "pre-impact velocity"})},
            attrs={"Omega": self.Omega, "period": self.period, "status": self.status})
        if self.frequency_hz:
            ds.attrs["frequency_hz"] = self.frequency_hz
        return ds


def section(sim) -> PoincareSection:
    """The sections of a simulated record (:class:`vibeam.api.Simulation`: ``t`` from the start
    of the record at forcing phase 0, ``samples_per_period`` samples a period)."""
    # the record's samples lie at forcing phases 2 pi j / samples_per_period (phase 0 first)
    spp = int(getattr(sim.trajectory, "samples_per_period", 0) or 0)
    if spp < 1:
        spp = int(round(2.0 * math.pi / sim.Omega / (sim.t[1] - sim.t[0])))
    idx = np.arange(0, sim.t.size, spp)
    ti = np.asarray(sim.impact_times, float)
    stops = getattr(getattr(sim, "trajectory", None), "impact_stops", None)
    stops = np.asarray(stops, np.int64).copy() if stops is not None and len(stops) == ti.size else None
    return PoincareSection(Omega=float(sim.Omega), strobe_q=np.asarray(sim.q)[idx].copy(),
                           strobe_dq=np.asarray(sim.dq)[idx].copy(),
                           impact_phase=np.mod(sim.Omega * ti, 2.0 * math.pi),
                           impact_velocity=np.asarray(sim.impact_velocities, float).copy(),
                           length_m=sim.length_m, natural_frequency_hz=sim.natural_frequency_hz,
                           period=int(sim.summary.get("period", 0)), status=str(sim.status),
                           name=str(getattr(sim, "name", "") or ""), impact_stop=stops)


def stop_name(code: int) -> str:
    """The stop of an impact code (:attr:`PoincareSection.impact_stop`): ``upper stop``, ``lower stop``,
    ``point stop i``."""
    return {0: "upper stop", 1: "lower stop"}.get(int(code), f"point stop {int(code) - 1}")


def poincare_figure(p: PoincareSection, title: str = ""):
    """Stroboscopic section (left) and impact section (right); a Figure.  With several stops the
    impacts on each stop have their own colour and marker (a legend names them); tick labels are
    thinned until neighbouring ones stand apart (:func:`vibeam.plots.style.thin_ticks`)."""
    fx, fv = p.scales
    xu, vu = ("mm", "mm/s") if p.physical else (None, None)
    x_sym, v_sym = (style.DISPLACEMENT, style.VELOCITY) if p.physical else ("$q$", r"$\dot q$")
    with style.context():
        fig, axes = plt.subplots(1, 2, figsize=(10.0, 4.2))
        c0, c1 = style.PALETTE[0], style.PALETTE[1]
        axes[0].plot(p.strobe_q * fx, p.strobe_dq * fv, ls="none", marker="o", ms=3, color=c0)
        axes[0].set_xlabel(style.label(x_sym, xu))
        axes[0].set_ylabel(style.label(v_sym, vu))
        axes[0].set_title(f"stroboscopic section ({p.strobe_q.size} periods)", loc="left")
        several = p.impact_stop is not None
        codes = sorted(set(int(c) for c in p.impact_stop)) if several else [None]
        for j, code in enumerate(codes):    # one colour and marker per stop (the palette after the strobe's)
            sel = slice(None) if code is None else np.asarray(p.impact_stop) == code
            c = style.PALETTE[(1 + (code if code is not None else 0)) % len(style.PALETTE)]
            n = int(np.sum(sel)) if code is not None else p.impact_phase.size
            axes[1].plot(p.impact_phase[sel], p.impact_velocity[sel] * fv, ls="none", marker="os^vD"[j % 5], ms=3,
                         color=c, label=f"{stop_name(code)} ({n} impacts)" if code is not None else None)
        axes[1].set_xlim(0.0, 2.0 * math.pi)
        axes[1].set_xlabel(style.label(r"impact phase $\Omega t$ mod $2\pi$", "rad"))
        axes[1].set_ylabel(style.label((r"pre-impact speed at a stop $|v^-|$" if several else
                                        r"pre-impact speed at the stop $|v^-|$") if p.physical else
                                       r"pre-impact speed $|\dot q^-|$", vu))
        axes[1].set_title(f"impact section ({p.impact_phase.size} impacts)", loc="left")
        if several and p.impact_phase.size:
            axes[1].legend(loc="best", fontsize=8)
        for ax in axes:
            ax.ticklabel_format(useOffset=False)       # a collapsed section: its values, not offsets
        f = f"{p.frequency_hz:.4g} Hz, " if p.frequency_hz else ""
        head = f"{p.name}: " if p.name else ""
        style.titles(fig, title or f"{head}Poincaré sections at {f}$\\Omega$ = {p.Omega:.6g}",
                     style.motion_text(p.period, p.status))
        style.thin_ticks(fig, axes)                    # after the titles: on the final layout
    return fig
