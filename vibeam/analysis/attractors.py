"""Basins of attraction and the census of attractors at a forcing frequency (``[basins]``).

A grid of initial states at forcing phase 0 (or ``samples`` random ones, seeded) is labelled
by the attractor of the stroboscopic map each state reaches, found by recurrences on a cell
grid (:mod:`vibeam.models.orbits.attractors`; Datseris & Wagemakers, Chaos 32, 2022) with the case's
exact event solver as the map.  Every attractor found is then described once: simulated over
``record`` periods (:func:`vibeam.engine.records.summarize`: amplitude ``Q``, period-n, status),
a periodic one refined to its fixed point by the shooting problem of the model (Newton on
``P^n(x) - x``, :func:`vibeam.models.orbits.continuation.start_point`) with its Floquet multipliers,
and its Lyapunov spectrum computed (:func:`vibeam.models.orbits.lyapunov.lyapunov_spectrum`: exact
flows and saltation matrices, Müller 1995).  Types:

``period``          a period-n orbit (n in ``attractor_period``), no sticking phase;
``sticking``        a motion with phases held on a stop (chatter ending in sticking
                    included), or rest on a stop; ``attractor_period`` n where it is periodic
                    to machine precision (confirmed on a second time grid of the solver),
                    else 0;
``chaotic``         not periodic, ``lambda_1 > 0`` beyond its error;
``quasi_periodic``  not periodic, ``|lambda_1|`` within its error;
``non_periodic``    not periodic within 8 periods and neither of the above (a long period,
                    a slow transient, or exponents the shooting problem could not compute).

States that do not settle within ``max_periods`` are labelled ``-2`` (``unsettled``), states
whose periods the solver could not compute ``-3`` (``failed``): they are counted, never forced
into an attractor.

Coordinates of the grid: the SDOF's ``(q, q')`` (nondimensional), or for a physical SDOF scene
the sensor's ``(U, U')`` in mm and mm/s; a beam's modal pair ``coordinates = [i, j]`` of its
state ``(eta_1 ... eta_N, eta_1' ... eta_N')`` (kernel units; default the first mode's
displacement and velocity), the other coordinates at rest.
"""
from __future__ import annotations

import json
import math
import os
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from matplotlib.colors import ListedColormap, to_rgb
from matplotlib.lines import Line2D
from matplotlib.patches import Patch

from vibeam.engine.jobs import file_stem, make_job
from vibeam.engine.records import summarize
from vibeam.engine import sweep
from vibeam.errors import CaseError
from vibeam.io.netcdf import json_default, parameter_units, var, write_group
from vibeam.io.results import case_hash
from vibeam.io.store import Store
from vibeam.models.orbits.attractors import FAILED, UNSETTLED, Recurrences, set_distance
from vibeam.models.orbits.continuation import start_point
from vibeam.models.orbits.lyapunov import classify_spectrum, floquet_exponents, lyapunov_spectrum
from vibeam.models.scene import one_mode, outputs, rest_state
from vibeam.models.core.oscillator import largest_gap, particular_coefficients
from vibeam.plots.lazy import plt
from vibeam.plots.sweep import save_figure
from vibeam.plots.style import NODIM, PALETTE, context, legend_outside

TYPES = ("period", "sticking", "chaotic", "quasi_periodic", "non_periodic")
#: label of an initial state that lies behind a rigid (impulsive) stop: outside the admissible
#: region, so it is neither simulated nor counted in the basin fractions
BEHIND_STOP = -4
LABELS = {UNSETTLED: "unsettled", FAILED: "failed", BEHIND_STOP: "behind a stop (not simulated)"}


@dataclass
class Axes:
    """The two coordinates of a basin grid and how they map to the model's state.

    ``index`` (2,): the state coordinates they set; ``factor`` (2,): axis value = factor x
    state coordinate; ``names``, ``units``, ``labels``: for files and plots.  Physical
    coordinates of a beam (``coordinates = "sensor"``) are not state coordinates: ``write``
    (2, 2n) is the mechanical state per unit of each axis and ``read`` (2, 2n) the covectors
    giving the axis values (``read @ write = I``); ``index``/``factor`` are then unused."""

    index: tuple
    factor: tuple
    names: tuple
    units: tuple
    labels: tuple
    write: np.ndarray | None = None
    read: np.ndarray | None = None

    def to_state(self, P, base) -> np.ndarray:
        """States (m, d) of the axis values ``P`` (m, 2): ``base`` (d,) with the two axes set."""
        P = np.asarray(P, float)
        S = np.repeat(np.asarray(base, float)[None, :], len(P), 0)
        if self.write is None:
            S[:, self.index[0]] = P[:, 0] / self.factor[0]
            S[:, self.index[1]] = P[:, 1] / self.factor[1]
        else:
            k = self.write.shape[1]
            S[:, :k] = P @ self.write
        return S

    def values(self, S) -> np.ndarray:
        """Axis values (m, 2) of states ``S`` (m, d)."""
        S = np.atleast_2d(np.asarray(S, float))
        if self.read is None:
            return np.column_stack([S[:, self.index[0]] * self.factor[0], S[:, self.index[1]] * self.factor[1]])
        return S[:, :self.read.shape[1]] @ self.read.T


@dataclass
class BasinsResult:
    """Basins of attraction, or the census of attractors, at one or more forcing frequencies.

    Attributes
    ----------
    name : str
        The run whose model and solver were used.
    Omega : ndarray, shape (n_Omega,)
        Forcing frequency of each slice (nondimensional); ``frequency_hz`` the same in Hz
        (physical scenes).  A slice is one frequency, or (``values``) one value of the ``[map]``
        parameter at one frequency.
    axes : Axes
    x, y : ndarray, shape (nx,), (ny,)
        Grid coordinates (axis units); empty for a census of random states.
    labels : ndarray of int, shape (n_Omega, ny, nx) or (n_Omega, samples)
        The attractor index each initial state reaches, ``-2`` unsettled, ``-3`` failed.
    initial : ndarray, shape (samples, 2)
        A census's initial states in axis units (empty for a grid).
    attractors : dict
        Per attractor (index = position), arrays over (n_Omega, n_attractors): ``type``
        (str), ``period``, ``amplitude`` (``Q``, nondimensional), ``amplitude_min``,
        ``amplitude_max``, ``stable`` (1, 0; -1 unknown), ``fraction``, ``fraction_se``,
        ``lyapunov`` (n_Omega, n_attractors, d), ``lyapunov_error``; ``samples``: list per
        Omega of lists of (m, d) stroboscopic sets; ``fixed_point`` (n_Omega, n_att, d).
    periods : ndarray, shape (n_Omega,)
        Map iterations spent per frequency; ``wall_time_s`` the time per frequency.
    stop : float or None
        The upper stop's position on the grid's first axis (SDOF), else None.
    stops : tuple of (float, float)
        Every stop's position on the grid's first axis and its side ``d`` (:func:`axis_stops`:
        states with ``d (x - position) > 0`` lie behind it); drawn in the basin plot.
    labels_checked, labels_wrong : ndarray of int, shape (n_Omega,), or None
        Labels checked by long simulation per slice and how many of them were wrong
        (:func:`verify_labels`; :meth:`mislabel_rate`).
    grazing : ndarray, shape (n_Omega, ny, nx), or None
        SDOF grids: the largest gap ``q - Delta`` of the free flight over the first forcing
        period from each initial state (:func:`first_period_gap`); its zero contour is the set
        of initial states whose next period grazes the stop, drawn over the basins.
    amplitude_scale_mm : float or None
        ``Q`` times this is mm (physical scenes).
    time_scale_s : float or None
        Exponents per unit time divided by this are per second (physical scenes).
    parameter : str
        ``Omega``, or the ``[map]`` parameter the slices run along (``[basins] along = "map"``).
    values : ndarray, shape (n_Omega,), or None
        The parameter's value of each slice (None: the slices run along the frequency).
    """

    name: str
    Omega: np.ndarray
    frequency_hz: np.ndarray | None
    axes: Axes
    x: np.ndarray
    y: np.ndarray
    labels: np.ndarray
    initial: np.ndarray
    attractors: dict
    periods: np.ndarray
    wall_time_s: np.ndarray
    amplitude_scale_mm: float | None = None
    time_scale_s: float | None = None
    settings: dict = field(default_factory=dict)
    stop: float | None = None
    grazing: np.ndarray | None = None
    parameter: str = "Omega"
    values: np.ndarray | None = None
    stops: tuple = ()
    labels_checked: np.ndarray | None = None
    labels_wrong: np.ndarray | None = None

    def sizes(self) -> str:
        """``1 frequencies, initial states 40 x 40, 3 attractors`` (the most found at one slice)."""
        return (f"{np.size(self.Omega)} frequencies, initial states "
                f"{' x '.join(map(str, np.shape(self.labels)[1:]))}, {self.n_attractors} attractors")

    def __repr__(self) -> str:
        """``BasinsResult('exact': 1 frequencies, initial states 40 x 40, 3 attractors)``: sizes,
        never the arrays (the dataclass's own repr printed every label)."""
        return f"{type(self).__name__}({self.name!r}: {self.sizes()})"

    def mislabel_rate(self, i: int = 0) -> tuple[float, float]:
        """The estimated share of wrong labels at slice ``i`` from the check by long simulation
        (:func:`verify_labels`): ``(wrong / checked, one-sided 95 % Clopper-Pearson upper
        bound)``; ``(nan, nan)`` when nothing was checked."""
        if self.labels_checked is None or int(self.labels_checked[i]) == 0:
            return math.nan, math.nan
        return mislabel_bound(int(self.labels_wrong[i]), int(self.labels_checked[i]))

    @property
    def along(self) -> str:
        """The dimension the slices run along: ``Omega``, or the ``[map]`` parameter."""
        return self.parameter if self.values is not None else "Omega"

    def slice_text(self, i: int) -> str:
        """Where slice ``i`` is, e.g. ``16.5 Hz`` or ``gap_mm = -0.1 at 16.5 Hz``."""
        f = f"{self.frequency_hz[i]:.4g} Hz" if self.frequency_hz is not None else f"Omega = {self.Omega[i]:.4g}"
        return f if self.values is None else f"{self.parameter} = {self.values[i]:.4g} at {f}"

    @property
    def grid(self) -> bool:
        return self.labels.ndim == 3

    @property
    def n_attractors(self) -> int:
        return len(self.attractors["type"][0]) if self.attractors["type"] else 0

    def fractions(self, i: int = 0) -> dict:
        """``{label: fraction}`` of the admissible initial states at frequency ``i`` (unsettled,
        failed included; states behind a stop, :data:`BEHIND_STOP`, are not counted)."""
        lab = self.labels[i].ravel()
        lab = lab[lab != BEHIND_STOP]
        return {int(k): float(np.mean(lab == k)) for k in np.unique(lab)}

    def behind_stop(self, i: int = 0) -> int:
        """How many initial states at frequency ``i`` lie behind a stop (not simulated, not counted)."""
        return int(np.sum(self.labels[i] == BEHIND_STOP))

    def to_xarray(self):
        """The result as an :class:`xarray.Dataset` (the variables of ``/basins/<run>/``)."""
        import xarray as xr  # lazy: xarray (with pandas: 0.35 s) loads only when labelled data are asked for

        v = basins_variables(self)
        dims = {d for x in v.values() for d in x.dims}
        coords = {k: (x.dims, x.data, x.attrs) for k, x in v.items()
                  if k in dims or x.attrs.get("aux")}
        return xr.Dataset({k: (x.dims, x.data, {a: b for a, b in x.attrs.items() if a != "aux"})
                           for k, x in v.items() if k not in coords},
                          coords={k: (d, x, {a: b for a, b in at.items() if a != "aux"})
                                  for k, (d, x, at) in coords.items()})


# ---------------------------------------------------------------------------- the map
def strobe(solver, Omega: float, d: int):
    """The stroboscopic map of ``solver`` at ``Omega`` as ``step(x, n)`` for
    :meth:`vibeam.models.orbits.attractors.Recurrences.label`: the states (shape (n, d)) after ``1 ...
    n`` forcing periods from ``x``, or None when the solver reports ``failed``.

    When the solver's samples are the whole state but its flag (the SDOF's ``(q, q')``, ``d =
    3``), one call gives ``n`` periods and the flag of the intermediate states is read from the
    state (held on a stop: exactly at the stop with zero velocity); otherwise one call per
    period (the beam's samples are the sensor's, not the modes').  A solver with a lean
    stroboscopic map (``solver.stroboscopic(Omega)``, :meth:`vibeam.models.core.event.EventSolver.stroboscopic`)
    gives those samples and final states without a trajectory per call: the same numbers."""
    Omega = float(Omega)
    osc = _oscillator(solver.scene)      # the one-mode oscillator: its samples are its state but the flag
    Delta = math.nan if osc is None else float(osc.Delta)
    Dl = None if osc is None else osc.Delta_lower
    Dl = None if Dl is None or not math.isfinite(Dl) else float(Dl)

    def one(x, n):
        out = np.empty((n, d))
        for k in range(n):
            tr = solver.point(Omega, x, 0, 1, 1)
            if tr.status == "failed" or tr.final_state.shape[0] != d:
                return None
            x = out[k] = tr.final_state
        return out

    # the solver's lean map where it has one (the same kernel call as point's, without building a
    # trajectory per call: issue 60), else point's samples and final state
    sections = solver.stroboscopic(Omega) if hasattr(solver, "stroboscopic") else None

    def many(x, n):
        if sections is not None:
            got = sections(x, n)
            if got is None:
                return None
            S, final = got
        else:
            tr = solver.point(Omega, x, 0, n, 1)
            if tr.status == "failed":
                return None
            S, final = tr.samples, tr.final_state
        out = np.empty((n, d))
        out[:-1, :2] = S[1:, :2]
        flag = np.zeros(n - 1)
        held = (S[1:, 1] == 0.0)
        flag[held & (S[1:, 0] == Delta)] = 1.0
        if Dl is not None:
            flag[held & (S[1:, 0] == -Dl)] = -1.0
        out[:-1, 2] = flag
        out[-1] = final
        return out

    if osc is None:
        return one
    probe = solver.point(Omega, rest_state(solver.scene), 0, 1, 1)
    if d == 3 and probe.samples.shape[1] == 2:
        return many
    return one


def _oscillator(scene):
    """The scene's one-mode oscillator (:func:`vibeam.models.scene.one_mode`), or None for a modal
    structure: what the SDOF's grid, map and grazing curve are read from."""
    try:
        return one_mode(scene)
    except ValueError:
        return None


def state_size(solver) -> int:
    """The size ``2 n + 1`` of the solver's state (``n`` modes and the held flag)."""
    return 2 * outputs(solver.scene).n_modes + 1


def first_period_gap(osc, Omega: float, q0, v0, samples: int = 256) -> np.ndarray:
    """The largest ``q - Delta`` over one forcing period of the SDOF's free flight (no stop) from
    each initial state ``(q0, v0)`` at forcing phase 0 (arrays of one shape, nondimensional;
    paper Eq. 28, :func:`vibeam.models.core.oscillator.largest_gap` on ``samples`` times): positive
    where the state meets the upper stop within a period, negative where it does not, zero on
    the states whose next period grazes it.  ``osc``: the oscillator
    (:func:`vibeam.models.scene.one_mode`)."""
    beta, Delta = float(osc.beta), float(osc.Delta)
    a, b = particular_coefficients(beta, float(Omega) ** 2 * float(osc.B), float(Omega))
    t = np.linspace(0.0, 2 * math.pi / float(Omega), int(samples))
    q0, v0 = np.broadcast_arrays(np.asarray(q0, float), np.asarray(v0, float))
    out = largest_gap(t, np.ascontiguousarray(q0.ravel()), np.ascontiguousarray(v0.ravel()), beta, a, b,
                      float(Omega), Delta)
    return out.reshape(q0.shape)


# ---------------------------------------------------------------------------- grid of states
def axes_of(scene, coordinates=None) -> Axes:
    """The grid's coordinates for ``scene`` (module docstring).

    A beam takes two of its modal state coordinates (``coordinates = [i, j]``, default the
    first mode's displacement and velocity, the other modes at rest) or ``"sensor"``: the
    displacement ``U`` (mm) and velocity (mm/s) at the sensor, the beam in its static deflection
    shape under a load at the contact point (the assumed static mode of paper Eqs. 39-42:
    ``eta_k`` proportional to ``W_k / omega_k^2``) moving in that shape.  The SDOF's grid is
    ``(q, q')`` or, for a physical scene, ``(U, U')`` at the sensor (``"sensor"`` says the same).

    Raises
    ------
    ValueError
        ``coordinates`` out of range, or modal indices for the SDOF (one line).
    """
    out = outputs(scene)
    n = out.n_modes
    modal = _oscillator(scene) is None
    if modal and coordinates == "sensor":
        s = scene.system
        u = s.contacts[0] / s.omega ** 2          # static deflection under a unit load at the contact
        shape = u / float(s.sensor @ u)            # ... scaled to 1 m at the sensor
        z = np.zeros(n)
        mm, mm_s = 1e3, 1e3 / s.time_unit_s
        write = np.array([np.r_[shape / mm, z], np.r_[z, shape / mm_s]])
        read = np.array([np.r_[s.sensor * mm, z], np.r_[z, s.sensor * mm_s]])
        return Axes((0, n), (1.0, 1.0), ("U", "U_dot"), ("mm", "mm/s"), (r"$U(L_S)$ (mm)", r"$\dot U(L_S)$ (mm/s)"),
                    write=write, read=read)
    if modal:
        i, j = (0, n) if coordinates is None else (int(coordinates[0]), int(coordinates[1]))
        for c in (i, j):
            if not 0 <= c < 2 * n:
                raise ValueError(f"[basins] coordinates = {list(coordinates)}: state indices 0 ... {2 * n - 1} "
                                 f"(eta_1 ... eta_{n} are 0 ... {n - 1}, their velocities {n} ... {2 * n - 1}) "
                                 f"or \"sensor\"")
        name = lambda c: f"eta_{c + 1}" if c < n else f"eta_{c - n + 1}_dot"
        lab = lambda c: fr"$\eta_{{{c + 1}}}$" if c < n else fr"$\dot\eta_{{{c - n + 1}}}$"
        return Axes((i, j), (1.0, 1.0), (name(i), name(j)), ("1", "1"), (lab(i) + f" ({NODIM})", lab(j) + f" ({NODIM})"))
    if coordinates is not None and coordinates != "sensor":
        raise ValueError(f"[basins] coordinates = {list(coordinates)}: modal indices are keys of beam scenes "
                         f"only (the SDOF's grid is (q, q'), or (U, U') at the sensor)")
    L, fn = out.length_m, out.natural_frequency_hz
    if L and fn:
        s = L * 1e3
        return Axes((0, 1), (s, s * 2 * math.pi * fn), ("U", "U_dot"), ("mm", "mm/s"),
                    (r"$U$ (mm)", r"$\dot U$ (mm/s)"))
    if coordinates == "sensor":
        raise ValueError("[basins] coordinates = \"sensor\": needs a physical scene (natural_frequency_hz, "
                         "length_mm); a nondimensional SDOF's grid is (q, q')")
    return Axes((0, 1), (1.0, 1.0), ("q", "q_dot"), ("1", "1"), (rf"$q$ ({NODIM})", rf"$\dot q$ ({NODIM})"))


def stop_gaps(scene, states) -> np.ndarray:
    """The gap of every stop at each state: ``g_k = s_k W[row_k] @ eta - offset_k`` (< 0 free,
    > 0 behind the stop; paper Eq. 2's ``q - Delta`` for the SDOF's upper stop).

    Parameters
    ----------
    scene : vibeam.models.scene.Scene
    states : array_like, shape (m, d) or (d,)
        States ``(eta, eta', ...)``; the first ``n_modes`` entries are the modal
        coordinates (the SDOF's ``q``).

    Returns
    -------
    ndarray, shape (m, n_stops)
        In the system's row units (the SDOF: nondimensional; the beam: metres).
    """
    s, stops = scene.system, scene.stops
    n = s.omega.size
    S = np.atleast_2d(np.asarray(states, float))
    eta = S[:, :n]
    out = np.empty((S.shape[0], len(stops)))
    for k, st in enumerate(stops):
        r = st.relation
        out[:, k] = r.sign * (eta @ s.contacts[r.row]) - r.offset
    return out


def behind_stop(scene, states) -> np.ndarray:
    """Whether each state lies behind a rigid (impulsive, Newton's law) stop: outside the region
    the motion can reach, so the event kernels would project it onto the stop.  A compliant
    stop admits penetration (its contact phase), so a state behind it is admissible.

    Parameters
    ----------
    scene : vibeam.models.scene.Scene
    states : array_like, shape (m, d) or (d,)

    Returns
    -------
    ndarray of bool, shape (m,)
        True where some impulsive stop's gap (:func:`stop_gaps`) exceeds 1e-12 of the larger of
        the stop's offset and the contact coordinate (round-off of a state placed on the stop).
    """
    s, stops = scene.system, scene.stops
    n = s.omega.size
    S = np.atleast_2d(np.asarray(states, float))
    g = stop_gaps(scene, S)
    out = np.zeros(S.shape[0], bool)
    for k, st in enumerate(stops):
        if getattr(st.law, "kind", "") == "compliant":
            continue
        scale = np.maximum(abs(st.relation.offset), np.abs(S[:, :n] @ s.contacts[st.relation.row]))
        out |= g[:, k] > 1e-12 * np.maximum(scale, 1e-300)
    return out


def axis_stops(scene, axes: Axes, k: int = 0) -> list:
    """Where each stop closes on axis ``k`` of a basin grid, the other coordinates at rest:
    ``[(position, d)]`` in axis units, a state with ``d (x - position) > 0`` lying behind the
    stop (``d = +1``: an upper bound of the admissible region, ``-1`` a lower one).  Stops whose
    contact coordinate does not move along the axis (a velocity axis) are left out."""
    s, stops = scene.system, scene.stops
    n = s.omega.size
    out = []
    for st in stops:
        r = st.relation
        W = s.contacts[r.row]
        if axes.write is not None:
            wc = float(W @ axes.write[k, :n])              # contact displacement per axis unit
        else:
            i = int(axes.index[k])
            if i >= n:
                continue
            wc = float(W[i]) / float(axes.factor[k])
        a = r.sign * wc
        if a == 0.0 or not math.isfinite(a):
            continue
        out.append((float(r.offset) / a, 1.0 if a > 0 else -1.0))
    return out


def _admissible_interval(scene, axes: Axes, k: int, span: float, centre: float = 0.0) -> tuple:
    """The default range of axis ``k``: from the nearest upper bound (a stop) ``span`` down, not
    past a lower bound (a second stop), or from a lower bound ``span`` up; ``centre +- span``
    without a stop on the axis."""
    st = axis_stops(scene, axes, k)
    upper = [p for p, d in st if d > 0]
    lower = [p for p, d in st if d < 0]
    if upper:
        hi = min(upper)
        lo = hi - span
        if lower:
            lo = max(lo, max(lower))
        return (lo, hi)
    if lower:
        lo = max(lower)
        return (lo, lo + span)
    return (centre - span, centre + span)


def _sensor_stop(scene, axes: Axes):
    """The first stop's position on a beam's ``U`` axis (mm): where the static shape closes its
    gap at the contact point; None where the contact row does not move in that shape."""
    s = scene.system
    n = s.omega.size
    wc = float(s.contacts[0] @ axes.write[0, :n])      # contact displacement (m) per mm at the sensor
    return float(scene.stops[0].relation.offset) / wc if wc != 0.0 else None


def default_ranges(scene, axes: Axes, Omega: float) -> tuple:
    """A box around the stop holding the attractors of a usual scene, inside the admissible
    region: for the SDOF ``q`` over ``[Delta - 8 A, Delta]``, ``q'`` over ``[-8 A Omega, 8 A
    Omega]`` with ``A = max(|Delta|, X)`` (``X`` the linear response amplitude without the
    stop); for a beam's modal coordinate the same with the mode's own ``X`` and the value at
    which it alone closes the gap at the contact row.  A second stop (a two-sided scene) bounds
    the range from the other side (:func:`axis_stops`): no state of the default box lies behind
    a stop."""
    osc = _oscillator(scene)
    gap = float(scene.stops[0].relation.offset)      # the first stop's offset (the contact row's unit)
    if osc is None and axes.write is not None:     # U, U' at the sensor
        s = scene.system
        resp = s.sensor * s.participation * Omega ** 2 * s.base_amplitude / (s.omega ** 2 - Omega ** 2
                                                                             + 1j * s.damping * Omega)
        X = abs(complex(np.sum(resp))) * 1e3                  # linear response at the sensor, mm
        stop = _sensor_stop(scene, axes)
        A = max(X, abs(stop) if stop is not None else 0.0, 1e-300)
        V = 8 * A * Omega / (s.time_unit_s * 1.0)              # mm/s: Omega per unit of kernel time
        return (_admissible_interval(scene, axes, 0, 8 * A), (-V, V))
    if osc is None:
        s = scene.system
        n = s.omega.size
        rng = []
        for c_ in axes.index:
            i, vel = c_ % n, c_ >= n
            w, c, G = float(s.omega[i]), float(s.damping[i]), float(s.participation[i])
            X = abs(G) * Omega ** 2 * s.base_amplitude / math.hypot(w * w - Omega ** 2, c * Omega)
            wc = float(s.contacts[0, i])
            stop = gap / wc if wc != 0.0 else math.nan
            A = max(X, abs(stop) if math.isfinite(stop) else 0.0, 1e-300)
            if vel:
                rng.append((-8 * A * Omega, 8 * A * Omega))
            else:
                # the admissible side of the stops: the mode's contact-row entries set it
                rng.append(_admissible_interval(scene, axes, len(rng), 8 * A))
        return tuple(rng)
    X = Omega ** 2 * osc.B / max(math.hypot(1 - Omega ** 2, 2 * osc.beta * Omega), 1e-300)
    A = max(abs(osc.Delta), X, 1e-12)
    f0, f1 = axes.factor
    return (_admissible_interval(scene, axes, 0, f0 * 8 * A), (-f1 * 8 * A * Omega, f1 * 8 * A * Omega))


# ---------------------------------------------------------------------------- the work
# worker-local memory of cells and attractors, kept between the lines of one computation
_MEMORY: dict = {}


@dataclass
class BasinLine:
    """Initial states of one grid row (or census slice): a unit of work of the sweep engine."""

    key: str
    run: str
    token: str
    solver: object
    Omega: float
    states: np.ndarray
    recurrence: dict
    skip: np.ndarray | None = None        # states behind a stop: labelled BEHIND_STOP, not simulated

    @property
    def n_points(self) -> int:
        return len(self.states)

    def compute(self) -> list:
        mem = _MEMORY.get(self.token)
        if mem is None:
            _MEMORY.clear()
            d = self.states.shape[1]
            rec = Recurrences(**self.recurrence)
            mem = _MEMORY[self.token] = (rec, strobe(self.solver, self.Omega, d))
        rec, step = mem
        t0 = time.perf_counter()
        p0 = rec.periods
        skip = self.skip if self.skip is not None else np.zeros(len(self.states), bool)
        labels = np.array([BEHIND_STOP if sk else rec.label(step, x) for x, sk in zip(self.states, skip)], np.int64)
        pid = os.getpid()
        att = {("new", pid, int(k)): rec.attractors[k] for k in np.unique(labels) if k >= 0}
        return [dict(labels=labels, attractors=att, pid=pid, periods=rec.periods - p0,
                     wall_time_s=time.perf_counter() - t0)]

    def lost_rows(self, err, attempts):
        return [dict(labels=np.full(len(self.states), FAILED, np.int64), attractors={}, pid=0, periods=0,
                     wall_time_s=0.0, message=f"worker lost {attempts} time(s): {err}")]


def _spread(X) -> float:
    """Spread of a stroboscopic set: the larger of its halves' distance (:func:`set_distance`: a
    chaotic set whose consecutive samples visit its parts slowly) and its spacing, the mean
    distance from each of its distinct points to the nearest other one (a long orbit whose halves
    coincide).  0 for a period-1 orbit; about what two samples of one attractor are apart by."""
    X = np.asarray(X, float)
    X = X[np.all(np.isfinite(X), axis=1)]
    h = X.shape[0] // 2
    halves = set_distance(X[:h], X[h:], 1.0) if h >= 1 else 0.0
    return max(halves, _spacing(X))


def _spacing(X) -> float:
    X = X[:: max(1, X.shape[0] // 200)]            # the sampling of set_distance
    U = np.unique(np.round(X, 12), axis=0)
    if U.shape[0] < 2:
        return 0.0
    D = np.sqrt(((U[:, None, :] - U[None, :, :]) ** 2).sum(-1))
    np.fill_diagonal(D, np.inf)
    return float(D.min(1).mean())


def verify_labels(solver, Omega: float, d: int, states, labels, groups, width, n: int, periods: int,
                  rng) -> tuple[int, int]:
    """Check ``n`` labels by long simulation: how many of them are wrong.

    ``n`` states with an attractor label (picked by ``rng`` among ``labels >= 0``) are followed
    by the stroboscopic map (:func:`strobe`, the event kernel) in chunks of 500 periods, up to
    ``periods``; after each chunk its last 64 samples are matched to the attractors' sets
    ``groups`` (:func:`set_distance` in cells of ``width``, within one cell plus twice the sets'
    spreads, as :func:`merge_attractors` groups them).  A state whose chunk lies on a periodic
    attractor stops there; any other is followed the whole length.  A label is wrong when the
    attractor matched at the end is another one, or none (a state still on its transient, or a
    set the census did not find).

    Parameters
    ----------
    solver : time-domain solver
    Omega : float
        Forcing frequency (nondimensional).
    d : int
        State size.
    states : ndarray, shape (m, d)
        The slice's initial states.
    labels : ndarray of int, shape (m,)
        Their labels (local attractor indices; negative: none).
    groups : list of ndarray
        Each attractor's stroboscopic set, shape (k, d).
    width : ndarray, shape (d,)
        Cell widths.
    n, periods : int
        States checked (0: none) and the longest simulation (periods).
    rng : numpy.random.Generator

    Returns
    -------
    (int, int)
        States checked and labels found wrong.
    """
    idx = np.flatnonzero(np.asarray(labels) >= 0)
    if n <= 0 or idx.size == 0 or not groups:
        return 0, 0
    pick = np.sort(rng.choice(idx, size=min(int(n), idx.size), replace=False))
    step = strobe(solver, float(Omega), d)
    width = np.asarray(width, float)
    spreads = [_spread(G / width) for G in groups]
    wrong = 0
    for i in pick:
        x = np.asarray(states[i], float).copy()
        found, done = -1, 0
        while done < periods:
            m = min(500, periods - done)
            X = step(x, m)
            if X is None or not np.all(np.isfinite(X)):
                found = -1
                break
            done += m
            x = X[-1]
            tail = X[-min(64, m):]
            sx = _spread(tail / width)
            dist = [set_distance(tail, G, width) - (1.0 + 2.0 * max(sx, sg)) for G, sg in zip(groups, spreads)]
            k = int(np.argmin(dist))
            found = k if dist[k] <= 0.0 else -1
            if found >= 0 and spreads[found] < 0.5 and sx < 0.5:     # settled on a periodic attractor
                break
        wrong += int(found != int(labels[i]))
    return int(pick.size), int(wrong)


def mislabel_bound(wrong: int, checked: int) -> tuple[float, float]:
    """``(wrong / checked, upper)``: the estimated mislabel rate and its one-sided 95 %
    Clopper-Pearson upper bound (``1 - 0.05^(1/n)``, about ``3 / n``, when none was wrong)."""
    # the Beta(wrong + 1, checked - wrong) quantile is the inverse of the regularized incomplete beta
    # function, scipy.stats.beta.ppf's own numbers (equal on every checked <= 2000, wrong < 30);
    # scipy.special, not scipy.stats, whose import cost 3-5 s of a basin command (issue 60)
    from scipy.special import betaincinv  # lazy: keeps scipy.special out of `vibeam run` and the API's start-up

    if checked <= 0:
        return math.nan, math.nan
    upper = 1.0 if wrong >= checked else float(betaincinv(wrong + 1, checked - wrong, 0.95))
    return wrong / checked, upper


def merge_attractors(sets: dict, width, first: dict | None = None) -> tuple:
    """Group the stroboscopic sets found by different workers (``{key: (m, d) array}``, keys
    ``(origin, pid, index)`` tuples) into distinct attractors: two sets are one attractor when
    their distance (in cells) is at most one cell plus twice the larger self-distance.  The sets
    are taken in the order of ``first`` (``{key: (line, state)}``: where the grid first meets
    each set's label), else of their keys; the first set of a group is its attractor's set.
    Returns ``(groups, mapping)``: the list of one set per attractor and ``{key: index}``.

    Ordered by ``first``, neither the groups nor their sets depend on which worker computed which
    line (a key's process id does; issue 57: ``basins --jobs 2`` described its attractors from
    other sets from run to run)."""
    width = np.asarray(width, float)
    groups: list = []
    spreads: list = []
    mapping: dict = {}
    first = first or {}
    for key in sorted(sets, key=lambda k: (first.get(k, (math.inf, math.inf)), k)):
        X = sets[key]
        sx = _spread(X / width)
        for g, (Y, sy) in enumerate(zip(groups, spreads)):
            if set_distance(X, Y, width) <= 1.0 + 2.0 * max(sx, sy):
                mapping[key] = g
                break
        else:
            mapping[key] = len(groups)
            groups.append(X)
            spreads.append(sx)
    return groups, mapping


def set_period(X, rtol: float) -> int:
    """The smallest ``n <= m / 3`` with ``|X[i + n] - X[i]| <= rtol * scale`` over the
    stroboscopic set ``X`` (shape (m, d), consecutive samples; scale: the set's largest
    coordinate range, per coordinate), 0 if none: a long period-n orbit (e.g. one through a
    sticking phase, which resets the state) that a record of a few periods cannot show."""
    X = np.asarray(X, float)
    m = X.shape[0]
    if m < 3:
        return 0
    sc = np.maximum(np.ptp(X, axis=0), np.max(np.abs(X), axis=0) * 1e-12)
    sc[sc == 0] = 1.0
    for n in range(1, m // 3 + 1):
        if np.all(np.abs(X[n:] - X[:-n]) <= rtol * sc):
            return n
    return 0


def describe_attractor(solver, X, Omega, Delta, record: int, shots: int, period_rtol: float,
                       samples_per_period: int = 64) -> dict:
    """Type, period, amplitude, stability and Lyapunov spectrum of the attractor whose
    stroboscopic set is ``X`` (shape (m, d); its last sample is on it).  From that sample the
    motion is settled ``m`` more periods; the period test of the set (:func:`set_period`) is
    made on the ``m`` stroboscopic samples that follow, the record of ``record`` periods
    (:func:`vibeam.engine.records.summarize`) and the spectrum start at their end."""
    if len(X) == 0:
        # a set the recurrence recorded without a sample (its states' integration failed): nothing
        # of it can be described, and a number for it would be made up
        dprob = 2 * outputs(solver.scene).n_modes
        nan = np.nan
        return dict(period=0, impacts_per_period=nan, amplitude=nan, amplitude_min=nan, amplitude_max=nan,
                    stable=-1, fixed_point=np.full(dprob + 1, nan), status="failed",
                    message="the set has no stroboscopic sample (its states' integration failed)",
                    lyapunov=np.full(dprob, nan), lyapunov_error=np.full(dprob, nan),
                    lyapunov_impacts_per_period=nan, type="non_periodic")
    x = np.asarray(X[-1], float)
    # the set was located once its cells recurred, which on a coarse grid can be before the
    # motion has settled: settle as many periods again, and take the stroboscopic samples there
    m = max(int(X.shape[0]), 8)
    tr0 = solver.point(float(Omega), x, m, m, 1)
    if tr0.status != "failed":
        x = np.asarray(tr0.final_state, float)
        X = tr0.samples
    tr = solver.point(float(Omega), x, 0, int(record), int(samples_per_period))
    s = summarize(tr, float(Delta), period_rtol)
    n = int(s["period"])
    periodic = n != 0 and s["status"] in ("ok", "chatter", "sticking")
    why_not = ""
    if not periodic and s["status"] in ("ok", "chatter", "sticking", "unsettled"):
        # a period beyond the record's test (n <= 8): the stroboscopic set itself repeats; it
        # counts only if the solver on another time grid (16 steps per period) repeats it too
        n = set_period(X, period_rtol)
        if n > 0:
            trc = solver.point(float(Omega), x, 0, 3 * n, 16)
            S = trc.samples[::16]
            sc = np.maximum(np.ptp(S, axis=0), 1e-300)
            periodic = trc.status != "failed" and bool(np.all(np.abs(S[n:] - S[:-n]) <= period_rtol * sc))
            if not periodic:
                why_not = (f"its stroboscopic samples repeat after {n} periods on one time grid of the solver "
                           f"and not on another: round-off decides the period (not periodic to machine "
                           f"precision)")
                n = 0
    dprob = 2 * outputs(solver.scene).n_modes
    out = dict(period=max(n, 1) if periodic else 0, impacts_per_period=float(s["impacts_per_period"]), amplitude=float(s["amplitude"]),
               amplitude_min=float(s["amplitude_min"]), amplitude_max=float(s["amplitude_max"]),
               stable=-1, fixed_point=np.full(x.size, np.nan), status=s["status"], message=s["message"],
               lyapunov=np.full(dprob, np.nan), lyapunov_error=np.full(dprob, np.nan),
               lyapunov_impacts_per_period=np.nan)
    try:
        prob = sweep.shooting_at(solver, float(Omega))
    except ValueError as e:
        prob = None
        out["message"] = (out["message"] + "; " if out["message"] else "") + f"no shooting problem: {e}"
    if why_not:
        out["message"] = (out["message"] + "; " if out["message"] else "") + why_not
    # phases held on a stop anywhere in the periods looked at (settling and record): on a
    # chaotic attractor that chatters now and then, a record alone may or may not show one, and
    # the type would depend on which trajectory located the attractor
    stuck = (s["status"] in ("chatter", "sticking") or tr0.status in ("chatter", "sticking")
             or (x.size > dprob and x[dprob] != 0.0))
    floquet = None
    if prob is not None and periodic and n <= 64:
        pt, why = start_point(prob, x[:dprob], float(Omega), max(n, 1), 0.5 * Omega, 2.0 * Omega)
        if pt is not None and np.size(pt.mu) == dprob:
            floquet = floquet_exponents(pt.mu, max(n, 1), float(Omega))
        if pt is not None:
            out["fixed_point"][:dprob] = pt.x
            out["stable"] = int(bool(np.max(np.abs(pt.mu)) < 1.0)) if pt.mu.size else 1
            gap = getattr(pt.shot, "gap", np.nan)
            if np.isfinite(gap) and n > 0:
                out["amplitude"] = out["amplitude_min"] = out["amplitude_max"] = float(gap - pt.shot.q_min)
        elif why:
            out["message"] = (out["message"] + "; " if out["message"] else "") + f"shooting: {why}"
    if prob is not None and shots >= 2:
        sp = lyapunov_spectrum(prob, x[:dprob], float(Omega), int(shots), 0, 1)
        if sp.status == "ok":
            out["lyapunov"], out["lyapunov_error"] = sp.exponents, sp.error
            out["lyapunov_impacts_per_period"] = sp.impacts / max(sp.shots * sp.periods_per_shot, 1)
            if floquet is not None:        # a refined periodic orbit: its exact exponents (QR: the check)
                out["lyapunov"], out["lyapunov_error"] = floquet, np.zeros(dprob)
    if stuck:
        out["type"] = "sticking"
    elif periodic:
        out["type"] = "period"
    else:
        out["type"] = classify_spectrum(out["lyapunov"], out["lyapunov_error"]) or "non_periodic"
    return out


# ---------------------------------------------------------------------------- the computation
def _pick_solver(case, run_name):
    """The job of the case's run ``run_name`` (default: the first time-domain run)."""
    names = [r.name for r in case.run]
    if run_name is not None:
        r = next((x for x in case.run if x.name == run_name), None)
        if r is None:
            raise CaseError(f"[basins] run = {run_name!r}: no run of that name; allowed: {names}")
        job = make_job(case, r, dict(r.model))
        if not getattr(job.solver, "time_domain", False):
            raise CaseError(f"[basins] run = {run_name!r}: method {job.solver.name!r} has no time history; "
                            f"basins need a time-domain run (event, direct)")
        return r.name, job
    for r in case.run:
        if getattr(r, "method", "") == "continuation":
            continue
        job = make_job(case, r, dict(r.model))
        if getattr(job.solver, "time_domain", False):
            return r.name, job
    raise CaseError(f"[basins]: the case has no time-domain run (event, direct) among {names}; add one or "
                    f"name it with [basins] run")


def _cell_widths(step, d, axes: Axes, xs, ys, x_state, Omega):
    """Cell widths: the grid's spacing in its two coordinates, 1 in the flag, and in every other
    coordinate 1/200 of its range over 200 periods from three states of the box."""
    w = np.full(d, np.nan)
    if axes.write is None:       # physical axes: every modal coordinate's width from its range
        w[axes.index[0]] = (xs[1] - xs[0]) / axes.factor[0] if len(xs) > 1 else abs(xs[0]) / 100 or 1e-6
        w[axes.index[1]] = (ys[1] - ys[0]) / axes.factor[1] if len(ys) > 1 else abs(ys[0]) / 100 or 1e-6
    n_mech = d - 1               # the state (eta, eta', flag)
    if d > n_mech:
        w[n_mech:] = 1.0
    rest = [i for i in range(n_mech) if not np.isfinite(w[i])]
    if rest:
        lo = np.full(d, np.inf)
        hi = np.full(d, -np.inf)
        for x in x_state:
            X = step(np.asarray(x, float), 200)
            if X is not None:
                lo = np.minimum(lo, X.min(0))
                hi = np.maximum(hi, X.max(0))
        for i in rest:
            span = hi[i] - lo[i]
            w[i] = span / 200 if np.isfinite(span) and span > 0 else 1e-9
    return w


def checkpoint_ident(case, spec, name: str) -> str:
    """What a basin checkpoint belongs to: the case as run, the ``[basins]`` table and the run."""
    return case_hash(case.model_dump_json() + spec.model_dump_json() + name)


def _line_variables(row: dict) -> dict:
    keys = sorted(row["attractors"])
    sets = [row["attractors"][k] for k in keys]
    d = sets[0].shape[1] if sets else 1
    return {"labels": var(("point",), np.asarray(row["labels"], np.int64), "1", "local attractor index"),
            "set_pid": var(("set",), np.array([k[1] for k in keys], np.int64), "1", "process of the set"),
            "set_index": var(("set",), np.array([k[2] for k in keys], np.int64), "1", "local index of the set"),
            "set_length": var(("set",), np.array([x.shape[0] for x in sets], np.int64), "1", "samples per set"),
            "sets": var(("sample", "coordinate"), np.concatenate(sets) if sets else np.zeros((0, d)), "1",
                        "stroboscopic sets, concatenated"),
            "pid": var((), np.int64(row["pid"]), "1", "process"),
            "periods": var((), np.int64(row["periods"]), "1", "map iterations"),
            "wall_time_s": var((), float(row["wall_time_s"]), "s", "wall time")}


def checkpoint_groups(rows: dict, ident: str) -> dict:
    """Finished lines ``{line key: row}`` as checkpoint groups ``{key: (variables, attrs)}``
    (:meth:`vibeam.io.store.Store.checkpoint` of ``basin_lines/<run>``), each marked with ``ident``."""
    return {key: (_line_variables(row), {"basins_ident": ident}) for key, row in rows.items()}


def check_row(meta: dict, data: dict | None, n_states: int | None, n_coordinates: int | None = None) -> str | None:
    """What is wrong with a checkpointed basin row, or None: what :func:`_line_variables` writes.

    ``labels`` one whole number per state, each an attractor index the row has a set of or one of
    the codes ``BEHIND_STOP``, ``UNSETTLED``, ``FAILED``; the sets those of the row's process
    (``set_pid`` = ``pid``), one per attractor index the labels use (``set_index`` once each),
    ``n_coordinates`` numbers per sample (the model's state), their lengths adding up to the
    samples, finite; ``periods`` and ``pid`` not negative; ``wall_time_s`` finite, not negative, at
    most the time since 1970.  ``meta`` ``{dataset: (shape, dtype)}``, ``data`` the values (None:
    shapes only); ``n_states`` the row's states, ``n_coordinates`` the model's state size (None:
    not checked)."""
    need = {"labels": 1, "set_pid": 1, "set_index": 1, "set_length": 1, "sets": 2, "pid": 0, "periods": 0,
            "wall_time_s": 0}
    for k, nd in need.items():
        if k not in meta:
            return f"dataset {k} is missing"
        shape, dtype = meta[k]
        if len(shape) != nd or np.dtype(dtype).kind not in ("iu" if k != "wall_time_s" and k != "sets" else "f"):
            return f"dataset {k} has shape {tuple(shape)} and type {np.dtype(dtype)}, not what vibeam writes"
    extra = sorted(set(meta) - set(need))
    if extra:
        return f"dataset {extra[0]} is not one vibeam writes there ({', '.join(need)})"
    if n_states is not None and meta["labels"][0] != (n_states,):
        return f"dataset labels has shape {tuple(meta['labels'][0])}; the row has {n_states} state(s)"
    ns = meta["set_length"][0]
    if meta["set_pid"][0] != ns or meta["set_index"][0] != ns:
        return "datasets set_pid, set_index and set_length differ in length"
    cols = meta["sets"][0][1]
    if n_coordinates is not None and cols != n_coordinates and not (ns == (0,) and cols == 1):
        return f"dataset sets has {cols} coordinate(s) per sample; the model's state has {n_coordinates}"
    if data is None:
        return None
    lengths = np.asarray(data["set_length"])
    if np.any(lengths < 0) or int(lengths.sum()) != np.shape(data["sets"])[0]:
        return "dataset set_length does not add up to the samples of sets"
    if not np.all(np.isfinite(np.asarray(data["sets"], float))):
        return "dataset sets holds a value that is not finite"
    if int(data["periods"]) < 0:
        return "dataset periods is negative"
    pid = int(data["pid"])
    if pid < 0:
        return "dataset pid is negative"
    w = float(data["wall_time_s"])
    if not (0.0 <= w <= time.time()):
        return f"dataset wall_time_s is {w:g}; allowed: a finite time, at most the time since 1970"
    if np.any(np.asarray(data["set_pid"]) != pid):
        return f"dataset set_pid holds another process than the row's pid = {pid}"
    index = np.asarray(data["set_index"], np.int64)
    labels = np.asarray(data["labels"], np.int64)
    used = np.unique(labels[labels >= 0])
    if np.unique(index).size != index.size or not np.array_equal(np.sort(index), used):
        return (f"dataset set_index ({np.sort(index)[:6].tolist()}) is not one set per attractor index the labels "
                f"use ({used[:6].tolist()})")
    codes = (BEHIND_STOP, UNSETTLED, FAILED)
    bad = labels[(labels < 0) & ~np.isin(labels, codes)]
    if bad.size:
        return f"dataset labels holds {int(bad[0])}; allowed: an attractor index or {', '.join(map(str, codes))}"
    return None


def rows_from_checkpoint(got: dict) -> dict:
    """The rows of :meth:`BasinLine.compute` from checkpointed groups ``{key: {dataset: array}}``
    (their sets keyed ``("stored", pid, index)``)."""
    out = {}
    for key, d in got.items():
        ends = np.cumsum(d["set_length"])
        sets = np.split(np.asarray(d["sets"], float), ends[:-1]) if len(ends) else []
        pid = int(d["pid"])
        out[key] = dict(labels=np.asarray(d["labels"], np.int64), pid=pid, periods=int(d["periods"]),
                        wall_time_s=float(d["wall_time_s"]), stored=True,
                        attractors={("stored", int(p), int(k)): X
                                    for p, k, X in zip(d["set_pid"], d["set_index"], sets)})
    return out


def compute(case, run: str | None = None, jobs: int | None = 1, executor=None, progress: bool = False,
            spec=None, checkpoint=None, resume: bool = False, checkpoint_interval_s: float = 0.5,
            case_text: str = "") -> BasinsResult:
    """Basins of attraction (or the census of attractors) of a case (module docstring).

    Parameters
    ----------
    case : vibeam.case.schema.Case
        With a ``[basins]`` table, or give ``spec``.
    run : str, optional
        The run whose model and solver are used (default: ``[basins] run``, else the first
        time-domain run).
    jobs : int or None
        Workers of the local pool (1: in this process; None: all cores).
    executor : concurrent.futures.Executor, optional
        E.g. a dask.distributed client's executor (as the sweeps).
    progress : bool
        A progress bar of initial states.
    spec : vibeam.case.schema.BasinsSpec, optional
        Replaces the case's ``[basins]``.
    checkpoint : vibeam.io.store.Store, optional
        The results store the command holds: finished grid rows (census slices) are kept in its
        checkpoint (``results.h5.partial``, ``/basin_lines/<run>/``) as they finish (at most every
        ``checkpoint_interval_s``, and on an interrupt), so that an interrupted computation loses
        at most that much finished work.
    resume : bool
        Take the rows already in ``checkpoint`` for this case, ``[basins]`` table and run
        (validated: :func:`check_row`), and compute only the rest (the cell grid is the same:
        it depends on the table alone).

    Returns
    -------
    BasinsResult

    Raises
    ------
    vibeam.errors.CaseError
        No ``[basins]``, no time-domain run, or a key that does not fit the scene (one line).
    """
    spec = spec if spec is not None else case.basins
    if spec is None:
        raise CaseError(f"case {case.name}: no [basins] table (frequency_hz or Omega, grid or samples)")
    name, job = _pick_solver(case, spec.run if run is None else run)
    slices = _slices(case, spec, name, job)
    solver = job.solver
    Omegas = np.array([W for W, _, _ in slices])
    fns = [outputs(j.solver.scene).natural_frequency_hz for _, j, _ in slices]
    try:
        axes = axes_of(solver.scene, spec.coordinates)
    except ValueError as e:
        raise CaseError(str(e)) from None
    d = state_size(solver)
    ident = checkpoint_ident(case, spec, name)
    grid = spec.samples is None
    nx, ny = (spec.grid or [200, 200]) if grid else (0, 0)
    per_row = max(1, int(math.ceil(int(spec.samples or 0) / 16))) if not grid else nx

    def n_states(key: str):
        try:
            k = int(key.split("-")[1])
        except (IndexError, ValueError):
            return -1
        return nx if grid else max(0, min(per_row, int(spec.samples) - k * per_row))

    stored = {}
    if checkpoint is not None and resume:
        _, got = checkpoint.read_checkpoint(f"basin_lines/{name}", "basins_ident", ident,
                                            lambda key, meta, data: check_row(meta, data, n_states(key), d))
        stored = rows_from_checkpoint(got)
    rng = np.random.default_rng(spec.seed)
    labels = np.zeros((len(Omegas), ny, nx) if grid else (len(Omegas), int(spec.samples or 0)), np.int64)
    per_Omega = []
    grazing: list = []
    periods = np.zeros(len(Omegas), np.int64)
    checked = np.zeros(len(Omegas), np.int64)
    wrong = np.zeros(len(Omegas), np.int64)
    wall = np.zeros(len(Omegas))
    xs = ys = np.zeros(0)
    initial = np.zeros((0, 2))
    for iO, (Omega, job_i, value) in enumerate(slices):
        t0 = time.perf_counter()
        solver = job_i.solver
        r0 = default_ranges(solver.scene, axes, float(Omega))
        xr = tuple(spec.x_range) if spec.x_range is not None else r0[0]
        yr = tuple(spec.y_range) if spec.y_range is not None else r0[1]
        if grid:
            xs, ys = np.linspace(xr[0], xr[1], nx), np.linspace(yr[0], yr[1], ny)
            pts = [np.column_stack([xs, np.full(nx, y)]) for y in ys]
            wx, wy = xs[1] - xs[0], ys[1] - ys[0]
        else:
            if iO == 0:
                initial = np.column_stack([rng.uniform(*xr, spec.samples), rng.uniform(*yr, spec.samples)])
            per = max(1, int(math.ceil(len(initial) / 16)))
            pts = [initial[k:k + per] for k in range(0, len(initial), per)]
            wx, wy = (xr[1] - xr[0]) / 200, (yr[1] - yr[0]) / 200
            xs, ys = np.array([xr[0], xr[0] + wx]), np.array([yr[0], yr[0] + wy])
        base = np.zeros(d)

        def to_state(P):
            return axes.to_state(P, base)

        step = strobe(solver, float(Omega), d)
        corners = to_state(np.array([[xr[0], yr[0]], [xr[1], yr[1]], [0.5 * (xr[0] + xr[1]), 0.0]]))
        width = _cell_widths(step, d, axes, xs, ys, corners, Omega)
        origin = np.zeros(d)
        n_mech = d - 1
        if axes.write is None:
            origin[axes.index[0]] = xs[0] / axes.factor[0] - 0.5 * width[axes.index[0]]
            origin[axes.index[1]] = ys[0] / axes.factor[1] - 0.5 * width[axes.index[1]]
        else:                    # the cells' lattice through the box's first state
            origin[:n_mech] = to_state(np.array([[xs[0], ys[0]]]))[0, :n_mech] - 0.5 * width[:n_mech]
        origin[n_mech:] = -0.5
        recurrence = dict(origin=origin, width=width, n_found=spec.recurrences, n_locate=spec.locate_periods,
                          n_hit_attractor=spec.hit_attractor, n_hit_basin=spec.hit_basin,
                          max_periods=spec.max_periods, basin_hits=spec.basin_hits)
        token = f"{case.name}/{name}/{float(Omega)!r}/{value!r}/{os.getpid()}/{time.time_ns()}"
        lines = [BasinLine(key=f"{iO:04d}-{k:04d}", run=name, token=token, solver=solver, Omega=float(Omega),
                           states=to_state(P), recurrence=recurrence, skip=behind_stop(solver.scene, to_state(P)))
                 for k, P in enumerate(pts)]
        todo = [l for l in lines if l.key not in stored]
        buffer: dict = {}
        last = [time.perf_counter()]

        def flush():
            if checkpoint is not None and buffer:
                checkpoint.checkpoint(f"basin_lines/{name}", checkpoint_groups(buffer, ident), case.name,
                                      case_text, case.model_dump_json(), start=not resume)
                buffer.clear()
            last[0] = time.perf_counter()

        def on_line(line, rows):
            buffer[line.key] = rows[0]
            if time.perf_counter() - last[0] >= checkpoint_interval_s:
                flush()

        try:
            res = sweep.run_lines(todo, executor=executor, jobs=jobs, progress=progress, on_line=on_line,
                                  desc=f"basins {case.name} Omega={float(Omega):.4g}"
                                       + ("" if value is None else f" {case.map.parameter}={value:.4g}"))
        finally:
            flush()
        for l in lines:
            if l.key in stored:
                res[(l.run, l.key)] = [stored[l.key]]
        sets, first = {}, {}
        for li, l in enumerate(lines):         # the grid's order, not the workers'
            row = res[(l.run, l.key)][0]
            origin = "stored" if row.get("stored") else "new"
            lab = np.asarray(row["labels"])
            for key, X in row["attractors"].items():
                sets.setdefault(key, X)         # the set of the line that meets it first
            for k in np.unique(lab[lab >= 0]):
                first.setdefault((origin, row["pid"], int(k)), (li, int(np.argmax(lab == k))))
        groups, mapping = merge_attractors(sets, width, first)
        flat = []
        for l in lines:
            row = res[(l.run, l.key)][0]
            pid = row["pid"]
            origin = "stored" if row.get("stored") else "new"
            flat.append(np.array([mapping[(origin, pid, int(k))] if k >= 0 else k for k in row["labels"]], np.int64))
            periods[iO] += row["periods"]
        lab = np.concatenate(flat)
        labels[iO] = lab.reshape(ny, nx) if grid else lab
        desc = [describe_attractor(solver, X, float(Omega), outputs(solver.scene).Delta, spec.record_periods,
                                   spec.lyapunov_periods, case.sweep.period_rtol) for X in groups]
        checked[iO], wrong[iO] = verify_labels(solver, float(Omega), d, np.concatenate([l.states for l in lines]),
                                               lab, groups, width, spec.verify, spec.verify_periods,
                                               np.random.default_rng([int(spec.seed), iO]))
        counted = lab[lab != BEHIND_STOP]          # the fractions of the admissible states
        for k, dsc in enumerate(desc):
            dsc["samples"] = groups[k]
            dsc["fraction"] = float(np.mean(counted == k)) if counted.size else math.nan
            dsc["fraction_se"] = (math.sqrt(dsc["fraction"] * (1 - dsc["fraction"]) / counted.size)
                                  if counted.size else math.nan)
        per_Omega.append((desc, width))
        osc = _oscillator(solver.scene)
        if grid and axes.names[0] in ("q", "U") and osc is not None:
            Q0, V0 = np.meshgrid(xs / axes.factor[0], ys / axes.factor[1])
            grazing.append(first_period_gap(osc, float(Omega), Q0, V0))
        wall[iO] = time.perf_counter() - t0
    attractors = _track(per_Omega, labels)
    L = outputs(solver.scene).length_m
    fn = fns[-1]
    return BasinsResult(name=name, Omega=np.asarray(Omegas, float),
                        frequency_hz=np.asarray(Omegas) * np.asarray(fns, float) if fn else None,
                        axes=axes, x=xs if grid else np.zeros(0), y=ys if grid else np.zeros(0), labels=labels,
                        initial=initial, attractors=attractors, periods=periods, wall_time_s=wall,
                        amplitude_scale_mm=L * 1e3 if L else None,
                        time_scale_s=1.0 / (2 * math.pi * fn) if fn else None,
                        settings=spec.model_dump(),
                        stop=(_sensor_stop(solver.scene, axes) if axes.write is not None else
                              outputs(solver.scene).Delta * axes.factor[0] if axes.names[0] in ("q", "U") else None),
                        grazing=np.array(grazing) if grazing else None,
                        stops=tuple(axis_stops(solver.scene, axes, 0)),
                        labels_checked=checked, labels_wrong=wrong,
                        parameter=case.map.parameter if spec.along == "map" else "Omega",
                        values=np.array([v for _, _, v in slices], float) if spec.along == "map" else None)


def _slices(case, spec, name: str, job) -> list:
    """``(Omega, job, value)`` of each slice of a basins computation: the table's frequencies
    with the run's job (``value`` None), or (``along = "map"``) one frequency at each value of the
    ``[map]`` parameter, each value its own job.

    Raises
    ------
    vibeam.errors.CaseError
        ``along = "map"`` without a ``[map]`` table or with other than one frequency; a frequency
        in Hz for a nondimensional scene (one line each).
    """
    def frequencies(solver):
        try:
            return spec.frequencies(case.sweep, outputs(solver.scene).natural_frequency_hz)
        except ValueError as e:
            raise CaseError(f"case {case.name}: {e}") from None

    if spec.along == "frequency":
        return [(float(W), job, None) for W in frequencies(job.solver)]
    if case.map is None:
        raise CaseError(f"case {case.name}: [basins] along = \"map\": the case has no [map] table; "
                        f"allowed: along = \"frequency\", or add a [map]")
    r = next(x for x in case.run if x.name == name)
    out = []
    for j, v in enumerate(case.map.grid()):
        jb = make_job(case, r, dict(r.model, **{case.map.parameter: float(v)}), j)
        W = frequencies(jb.solver)
        if len(W) != 1:
            raise CaseError(f"case {case.name}: [basins] along = \"map\" needs one forcing frequency "
                            f"(frequency_hz or Omega), got {len(W)}; allowed: one value")
        out.append((float(W[0]), jb, float(v)))
    return out


#: attractors at neighbouring frequencies are one when their stroboscopic sets are this many cells
#: apart or less (plus twice their spacing): 15 % of a 200-cell box, about what a period-1 orbit
#: of the tight rig moves between two frequencies 0.5 Hz apart (17 cells)
MATCH_CELLS = 30.0


def _track(per_Omega: list, labels: np.ndarray) -> dict:
    """Attractors matched from one frequency to the next by their stroboscopic sets (those of the
    same type and period first, then the nearest, within :data:`MATCH_CELLS` plus twice the
    sets' spacing), relabelling ``labels`` in place to the
    matched indices; arrays over (n_Omega, n_attractors) (module docstring of
    :class:`BasinsResult`)."""
    tracks: list = []      # per track: last set and width
    index_of: list = []    # per Omega: local -> track
    for desc, width in per_Omega:
        cand = []
        for k, dsc in enumerate(desc):
            X = dsc["samples"]
            sx = _spread(X / width)
            for t, (Y, sy, typ) in enumerate(tracks):
                dist = set_distance(X, Y, width)
                if dist <= MATCH_CELLS + 2.0 * max(sx, sy):
                    # one of the same type and period first, then the nearest
                    cand.append(((dsc["type"], dsc["period"]) != typ, dist, k, t))
        cand.sort()
        local: dict = {}
        used = set()
        for _, dist, k, t in cand:
            if k in local or t in used:
                continue
            local[k] = t
            used.add(t)
        for k, dsc in enumerate(desc):
            if k not in local:
                local[k] = len(tracks)
                tracks.append(None)
            tracks[local[k]] = (dsc["samples"], _spread(dsc["samples"] / width), (dsc["type"], dsc["period"]))
        index_of.append(local)
    nO, nA = len(per_Omega), len(tracks)
    d = max((dsc["samples"].shape[1] for desc, _ in per_Omega for dsc in desc), default=1)
    dl = max((dsc["lyapunov"].size for desc, _ in per_Omega for dsc in desc), default=1)
    m = max((dsc["samples"].shape[0] for desc, _ in per_Omega for dsc in desc), default=0)
    out = dict(type=[[""] * nA for _ in range(nO)], period=np.zeros((nO, nA), np.int64),
               amplitude=np.full((nO, nA), np.nan), amplitude_min=np.full((nO, nA), np.nan),
               amplitude_max=np.full((nO, nA), np.nan), stable=np.full((nO, nA), -1, np.int64),
               impacts_per_period=np.full((nO, nA), np.nan), lyapunov_impacts_per_period=np.full((nO, nA), np.nan),
               fraction=np.zeros((nO, nA)), fraction_se=np.zeros((nO, nA)),
               lyapunov=np.full((nO, nA, dl), np.nan), lyapunov_error=np.full((nO, nA, dl), np.nan),
               fixed_point=np.full((nO, nA, d), np.nan), samples=np.full((nO, nA, m, d), np.nan),
               message=[[""] * nA for _ in range(nO)])
    for iO, ((desc, _), local) in enumerate(zip(per_Omega, index_of)):
        lab = labels[iO]
        new = lab.copy()
        for k, dsc in enumerate(desc):
            t = local[k]
            new[lab == k] = t
            out["type"][iO][t] = dsc["type"]
            out["message"][iO][t] = dsc["message"]
            for key in ("period", "amplitude", "amplitude_min", "amplitude_max", "stable", "fraction",
                        "fraction_se", "impacts_per_period", "lyapunov_impacts_per_period"):
                out[key][iO, t] = dsc[key]
            out["lyapunov"][iO, t, :dsc["lyapunov"].size] = dsc["lyapunov"]
            out["lyapunov_error"][iO, t, :dsc["lyapunov"].size] = dsc["lyapunov_error"]
            out["fixed_point"][iO, t, :dsc["fixed_point"].size] = dsc["fixed_point"]
            S = dsc["samples"]
            out["samples"][iO, t, :S.shape[0], :S.shape[1]] = S
        labels[iO] = new
    return out


# ---------------------------------------------------------------------------- file and plots
def basins_variables(r: BasinsResult) -> dict:
    """The netCDF variables of ``/basins/<run>/`` (names and units of the module docstring)."""
    D = r.along
    if r.values is None:
        out = {"Omega": var(("Omega",), r.Omega, "1", "forcing frequency over the natural frequency")}
    else:
        out = {D: var((D,), r.values, parameter_units(D), f"{D} (the [map] parameter)"),
               "Omega": var((D,), r.Omega, "1", "forcing frequency over the natural frequency", aux=True)}
    if r.frequency_hz is not None:
        out["frequency_hz"] = var((D,), r.frequency_hz, "Hz", "forcing frequency", aux=True)
    ax = r.axes
    if r.grid:
        out["state_1"] = var(("state_1",), r.x, ax.units[0], f"initial {ax.names[0]}")
        out["state_2"] = var(("state_2",), r.y, ax.units[1], f"initial {ax.names[1]}")
        out["basin"] = var((D, "state_2", "state_1"), r.labels.astype(np.int32), "1",
                           "attractor reached (-2 unsettled, -3 failed, -4 behind a stop)")
    else:
        out["initial_state_1"] = var(("sample",), r.initial[:, 0], ax.units[0], f"initial {ax.names[0]}")
        out["initial_state_2"] = var(("sample",), r.initial[:, 1], ax.units[1], f"initial {ax.names[1]}")
        out["label"] = var((D, "sample"), r.labels.astype(np.int32), "1",
                           "attractor reached (-2 unsettled, -3 failed, -4 behind a stop)")
    a = r.attractors
    nA = r.n_attractors
    out["attractor"] = var(("attractor",), np.arange(nA, dtype=np.int32), "1", "attractor index")
    out["attractor_type"] = var((D, "attractor"), np.array(a["type"], dtype=object).reshape(len(r.Omega), nA),
                                None, "period, sticking, chaotic, quasi_periodic, non_periodic (empty: absent)")
    out["attractor_period"] = var((D, "attractor"), a["period"].astype(np.int32), "1",
                                  "period n of a periodic attractor (0: not periodic)")
    mm = r.amplitude_scale_mm
    for k in ("amplitude", "amplitude_min", "amplitude_max"):
        if mm:
            out[f"attractor_{k}_mm"] = var((D, "attractor"), a[k] * mm, "mm", f"attractor {k} Q at the sensor")
        else:
            out[f"attractor_{k}"] = var((D, "attractor"), a[k], "1", f"attractor {k} Q = Delta - min q")
    out["attractor_stable"] = var((D, "attractor"), a["stable"].astype(np.int8), "1",
                                  "shooting-refined orbit stable (1), unstable (0), not refined (-1)")
    out["impacts_per_period"] = var((D, "attractor"), a["impacts_per_period"], "1", "impacts per period")
    out["lyapunov_impacts_per_period"] = var((D, "attractor"), a["lyapunov_impacts_per_period"], "1",
                                             "impacts per period over the Lyapunov record")
    out["basin_fraction"] = var((D, "attractor"), a["fraction"], "1", "fraction of the initial states")
    out["basin_fraction_se"] = var((D, "attractor"), a["fraction_se"], "1",
                                   "binomial standard error of basin_fraction")
    lam, err = a["lyapunov"], a["lyapunov_error"]
    unit = "1"
    if r.time_scale_s:
        lam, err, unit = lam / r.time_scale_s, err / r.time_scale_s, "1/s"
    out["lyapunov"] = var((D, "attractor", "exponent"), lam, unit, "Lyapunov spectrum of the stroboscopic map")
    out["lyapunov_error"] = var((D, "attractor", "exponent"), err, unit,
                                "standard error by batch means (0: Floquet exponents of a periodic orbit)")
    out["attractor_samples"] = var((D, "attractor", "strobe_sample", "coordinate"), a["samples"], "1",
                                   "stroboscopic set (model state, NaN padded)")
    out["attractor_fixed_point"] = var((D, "attractor", "coordinate"), a["fixed_point"], "1",
                                       "shooting-refined fixed point of P^n (NaN: not refined)")
    out["attractor_message"] = var((D, "attractor"), np.array(a["message"], dtype=object).reshape(len(r.Omega), nA),
                                   None, "what the description of the attractor met (solver, shooting)")
    lab = r.labels.reshape(len(r.Omega), -1)
    n_ok = np.maximum(np.sum(lab != BEHIND_STOP, axis=1), 1)
    out["unsettled_fraction"] = var((D,), np.sum(lab == UNSETTLED, axis=1) / n_ok, "1",
                                    "share of the admissible states not settled")
    out["failed_fraction"] = var((D,), np.sum(lab == FAILED, axis=1) / n_ok, "1",
                                 "share of the admissible states the solver failed on")
    out["states_behind_stop"] = var((D,), np.sum(lab == BEHIND_STOP, axis=1).astype(np.int64), "1",
                                    "initial states behind a rigid stop: not simulated, not counted")
    if r.labels_checked is not None:
        out["labels_checked"] = var((D,), np.asarray(r.labels_checked, np.int64), "1",
                                    "labels checked by long simulation")
        out["labels_wrong"] = var((D,), np.asarray(r.labels_wrong, np.int64), "1",
                                  "checked labels found wrong (another attractor, or none, at the end)")
        out["mislabel_rate_upper95"] = var((D,), np.array([r.mislabel_rate(i)[1] for i in range(len(r.Omega))]),
                                           "1", "one-sided 95 % upper bound of the share of wrong labels")
    out["periods"] = var((D,), r.periods, "1", "stroboscopic-map iterations spent")
    out["wall_time_s"] = var((D,), r.wall_time_s, "s", "wall time")
    if r.grazing is not None and r.grid:
        out["grazing_gap"] = var((D, "state_2", "state_1"), r.grazing, "1",
                                 "largest gap q - Delta of the free flight over the first forcing period")
    return out


def _axes_attrs(r: BasinsResult) -> dict:
    """What :func:`basins_from_dataset` needs to rebuild the result: the axes' state indices,
    factors and labels, the scales and the stop (``/basins/<run>/`` attributes)."""
    a = {"axes_names": json.dumps(list(r.axes.names)), "axes_index": json.dumps([int(i) for i in r.axes.index]),
         "axes_factor": json.dumps([float(x) for x in r.axes.factor]),
         **({} if r.axes.write is None else {"axes_write": json.dumps(np.asarray(r.axes.write).tolist()),
                                              "axes_read": json.dumps(np.asarray(r.axes.read).tolist())}),
         "axes_units": json.dumps(list(r.axes.units)), "axes_labels": json.dumps(list(r.axes.labels))}
    for k in ("amplitude_scale_mm", "time_scale_s", "stop"):
        if getattr(r, k) is not None:
            a[k] = float(getattr(r, k))
    if r.stops:
        a["stops"] = json.dumps([[float(p), float(d)] for p, d in r.stops])
    return a


def basins_from_dataset(ds, name: str | None = None) -> BasinsResult:
    """A :class:`BasinsResult` from its ``/basins/<run>/`` group (:func:`read_basins`), so that
    :func:`basins_figure`, :func:`census_figure` and :func:`print_basins` work on a file as on
    a fresh computation.

    Parameters
    ----------
    ds : xarray.Dataset
        The group as :func:`read_basins` returns it.
    name : str, optional
        The run (default the group's ``run`` attribute).

    Returns
    -------
    BasinsResult
        ``attractors["samples"]`` as stored (NaN padded); ``settings`` from the group.  Files
        written before the axes attributes were stored get unit factors (axis = state).
    """
    at = dict(ds.attrs)
    # ("coordinates" is taken by the CF decoding of xarray: the names are also in "axes_names")
    names = tuple(json.loads(at.get("axes_names", at.get("coordinates", '["x", "y"]'))))
    get = lambda k, d: tuple(json.loads(at[k])) if k in at else d
    grid = "basin" in ds
    units = get("axes_units", (str(ds["state_1"].attrs.get("units", "1")), str(ds["state_2"].attrs.get("units", "1")))
                if grid else (str(ds["initial_state_1"].attrs.get("units", "1")),
                              str(ds["initial_state_2"].attrs.get("units", "1"))))
    axes = Axes(get("axes_index", (0, 1)), get("axes_factor", (1.0, 1.0)), names, units,
                get("axes_labels", tuple(f"{n} ({u})" for n, u in zip(names, units))),
                write=np.array(json.loads(at["axes_write"])) if "axes_write" in at else None,
                read=np.array(json.loads(at["axes_read"])) if "axes_read" in at else None)
    mm = at.get("amplitude_scale_mm")
    ts = at.get("time_scale_s")
    along = str(at.get("along", "Omega"))
    nO = ds.sizes[along]
    v = lambda k: np.asarray(ds[k].values)
    sfx = "_mm" if mm else ""
    amp = {k: v(f"attractor_{k}{sfx}") / (float(mm) if mm else 1.0) for k in ("amplitude", "amplitude_min", "amplitude_max")}
    lam, err = v("lyapunov"), v("lyapunov_error")
    if ts:
        lam, err = lam * float(ts), err * float(ts)
    types = v("attractor_type").astype(str).reshape(nO, -1)
    msgs = v("attractor_message").astype(str).reshape(nO, -1)
    attractors = dict(type=[list(t) for t in types], period=v("attractor_period").astype(np.int64),
                      stable=v("attractor_stable").astype(np.int64), fraction=v("basin_fraction"),
                      fraction_se=v("basin_fraction_se"), impacts_per_period=v("impacts_per_period"),
                      lyapunov_impacts_per_period=v("lyapunov_impacts_per_period"), lyapunov=lam,
                      lyapunov_error=err, samples=v("attractor_samples"), fixed_point=v("attractor_fixed_point"),
                      message=[list(m) for m in msgs], **amp)
    settings = at.get("settings", "{}")
    return BasinsResult(
        name=name or str(at.get("run", "")), Omega=v("Omega").astype(float),
        frequency_hz=v("frequency_hz").astype(float) if "frequency_hz" in ds else None, axes=axes,
        x=v("state_1") if grid else np.zeros(0), y=v("state_2") if grid else np.zeros(0),
        labels=(v("basin") if grid else v("label")).astype(np.int64),
        initial=np.zeros((0, 2)) if grid else np.column_stack([v("initial_state_1"), v("initial_state_2")]),
        attractors=attractors, periods=v("periods").astype(np.int64), wall_time_s=v("wall_time_s").astype(float),
        amplitude_scale_mm=float(mm) if mm else None, time_scale_s=float(ts) if ts else None,
        settings=json.loads(settings) if isinstance(settings, str) else dict(settings),
        stop=float(at["stop"]) if "stop" in at else None,
        stops=tuple(tuple(x) for x in json.loads(at["stops"])) if "stops" in at else (),
        grazing=v("grazing_gap") if "grazing_gap" in ds else None,
        labels_checked=v("labels_checked").astype(np.int64) if "labels_checked" in ds else None,
        labels_wrong=v("labels_wrong").astype(np.int64) if "labels_wrong" in ds else None,
        parameter=along, values=None if along == "Omega" else v(along).astype(float))


def basins_group(r):
    """The writer of ``/basins/<run>/`` of one result (a ``fill(file)`` for
    :meth:`vibeam.io.store.Store.commit`)."""
    attrs = {"run": r.name, "coordinates": json.dumps(list(r.axes.names)), "along": r.along,
             "settings": json.dumps(r.settings, default=json_default), "kind": "grid" if r.grid else "census",
             **_axes_attrs(r)}

    def fill(f):
        write_group(f, f"basins/{r.name}", basins_variables(r), attrs)
    return fill


def write_basins(store, results: list, case_name: str = "", case_text: str = "", case_json: str = "", aliases=()):
    """Write each result to ``/basins/<run>/`` of the store's file (every other group kept; the
    checkpoint rows of these runs removed).  ``store`` is a held :class:`vibeam.io.store.Store`,
    or a path (a store is opened for the write)."""
    if not isinstance(store, Store):
        path = Path(store)
        with Store(path.parent, path.name) as st:
            return write_basins(st, results, case_name, case_text, case_json, aliases)
    return store.commit({f"basins/{r.name}": basins_group(r) for r in results}, case_name, case_text, case_json,
                        done=[f"basin_lines/{r.name}" for r in results], aliases=aliases)


def read_basins(path, run: str):
    """``/basins/<run>/`` of a results file as an :class:`xarray.Dataset`."""
    import xarray as xr  # lazy: xarray (with pandas: 0.35 s) loads only when labelled data are asked for

    with xr.open_dataset(path, group=f"basins/{run}", engine="h5netcdf") as ds:
        return ds.load()


def _lambda_text(r: BasinsResult, i: int, k: int) -> str:
    """``lambda_1`` of attractor ``k`` at frequency ``i`` with its error: the batch-means standard
    error of the QR estimate, or 0 for the Floquet exponent of a refined periodic orbit (its
    stored error, :func:`describe`); "not computed" without a spectrum (``lyapunov_periods = 0``)."""
    lam = float(r.attractors["lyapunov"][i, k, 0])
    err = float(r.attractors["lyapunov_error"][i, k, 0])
    if not np.isfinite(lam) and not lam == -np.inf:
        return "lambda_1 not computed"
    unit = " 1/s" if r.time_scale_s else ""
    if r.time_scale_s:
        lam, err = lam / r.time_scale_s, err / r.time_scale_s
    how = "Floquet exponent of the orbit" if err == 0 else "QR, batch-means standard error"
    return f"lambda_1 = {lam:.4g} +- {err:.2g}{unit} ({how})"


def _legend_text(r: BasinsResult, i: int, k: int, se: bool = False) -> str:
    """``k: period-1, Q = 0.753 mm, 68.7 %`` (``se``, the figure's legend: ``k: period-1 attractor, Q =
    0.753 mm, basin 68.7 ± 1.2 %``, with the fraction's standard error)."""
    a = r.attractors
    t = a["type"][i][k]
    n = int(a["period"][i, k])
    name = {"period": f"period-{n}",
            "sticking": f"sticking, period-{n}" if n else "sticking, not periodic"}.get(t, t.replace("_", "-"))
    amp = a["amplitude"][i, k] * (r.amplitude_scale_mm or 1.0)
    unit = " mm" if r.amplitude_scale_mm else ""
    if se:
        return (f"{k}: {name} attractor, Q = {amp:.3g}{unit}, basin {100 * a['fraction'][i, k]:.1f} ± "
                f"{100 * a['fraction_se'][i, k]:.1f} %")
    return f"{k}: {name}, Q = {amp:.3g}{unit}, {100 * a['fraction'][i, k]:.1f} %"


#: how much of white a basin's cells mix into their attractor's colour: the cells are a light tint, the
#: attractor's own stroboscopic samples over them the full colour (with a thin black rim), so each
#: attractor is seen on its basin and no two attractors share a colour
BASIN_TINT = 0.55


def _tint(colour, white: float = BASIN_TINT):
    """``colour`` mixed with ``white`` parts of white (an RGB tuple)."""
    return tuple((1.0 - white) * c + white for c in to_rgb(colour))


def basins_figure(r: BasinsResult, i: int = 0, title: str = ""):
    """The basin image at frequency ``i``: each attractor its own colour (:data:`PALETTE`), its basin
    in a light tint of it and its stroboscopic set in the full colour over it; unsettled/failed grey;
    the stop's position marked (SDOF).  The legend gives each attractor's basin fraction with its
    standard error and, where the labels were checked by long simulation, the mislabel rate's upper
    bound (:meth:`BasinsResult.mislabel_rate`)."""
    with context():
        return _basins_figure(r, i, title)


def _basins_figure(r, i, title):
    fig, ax = plt.subplots(figsize=(6.4, 5.0))
    nA = r.n_attractors
    present = [k for k in range(nA) if r.attractors["type"][i][k]]
    full = [PALETTE[k % len(PALETTE)] for k in range(nA)]
    colours = ["0.55", "0.8"] + [_tint(c) for c in full]
    # image values: 0 failed, 1 unsettled, 2 behind a stop (white), 3 + k attractor k
    img = np.where(r.labels[i] == BEHIND_STOP, -1, r.labels[i]) + 3 if r.grid else None
    handles = []
    if r.grid:
        ax.imshow(img, origin="lower", aspect="auto", interpolation="nearest",
                  extent=(r.x[0] - 0.5 * (r.x[1] - r.x[0]), r.x[-1] + 0.5 * (r.x[1] - r.x[0]),
                          r.y[0] - 0.5 * (r.y[1] - r.y[0]), r.y[-1] + 0.5 * (r.y[1] - r.y[0])),
                  cmap=ListedColormap(colours[:1] + colours[1:2] + ["white"] + colours[2:]),
                  vmin=-0.5, vmax=len(colours) + 0.5)
    else:
        lab = r.labels[i]
        ax.scatter(r.initial[:, 0], r.initial[:, 1], s=6,
                   c=[colours[l + 2] if l >= 0 else "white" if l == BEHIND_STOP else colours[0 if l == FAILED else 1]
                      for l in lab], edgecolors=["0.5" if l == BEHIND_STOP else "none" for l in lab], linewidths=0.5)
    for k in present:
        S = r.attractors["samples"][i, k]
        S = S[np.isfinite(S[:, 0])]
        XY = r.axes.values(S)
        few = len(np.unique(np.round(XY, 12), axis=0)) <= 16        # a periodic orbit's few points: larger
        ax.plot(XY[:, 0], XY[:, 1], ls="none", marker="o", ms=5 if few else 2.5, color=full[k], mfc=full[k], mec="k",
                mew=0.4, zorder=3, gid="attractor")
        # one entry per attractor: its basin's tint as a broad bar, its dots' colour as the marker on it
        handles.append(Line2D([], [], ls="-", lw=7, color=colours[k + 2], marker="o", ms=6, mfc=full[k], mec="k",
                              mew=0.4, label=_legend_text(r, i, k, se=True)))
    if not r.grid:  # sampled states: coloured dots, not cells
        handles.append(Line2D([], [], ls="none", marker="o", ms=3, color="0.45",
                              label="starting state, coloured by the attractor it reaches"))
    if present:     # what the entries above show
        handles.append(Line2D([], [], ls="none", label="dots: an attractor's stroboscopic samples; basin: its colour, "
                                                       "lighter (fraction ± standard error)"))
    rate, upper = r.mislabel_rate(i)
    if math.isfinite(rate):
        handles.append(Line2D([], [], ls="none", label=f"labels checked by long simulation: "
                                                      f"{int(r.labels_wrong[i])} of {int(r.labels_checked[i])} wrong, "
                                                      f"mislabelled at most {100 * upper:.1f} % (95 %)"))
    lab = r.labels[i]
    for code, c in ((UNSETTLED, colours[1]), (FAILED, colours[0])):
        if np.any(lab == code):
            handles.append(Patch(color=c, label=f"{LABELS[code]}, {100 * np.mean(lab == code):.1f} %"))
    if np.any(lab == BEHIND_STOP):
        handles.append(Patch(color="white", ec="0.5", label=f"{LABELS[BEHIND_STOP]}: {int(np.sum(lab == BEHIND_STOP))} "
                                                              f"states"))
    if r.grazing is not None and r.grid and np.nanmin(r.grazing[i]) < 0 < np.nanmax(r.grazing[i]):
        ax.contour(r.x, r.y, r.grazing[i], levels=[0.0], colors="k", linewidths=0.8, linestyles=":")
        handles.append(Line2D([], [], color="k", lw=0.8, ls=":", label="grazing within one period"))
    drawn = [p for p, _ in r.stops] or ([r.stop] if r.stop is not None else [])
    for j, p in enumerate(drawn):                   # every stop (a two-sided scene: both)
        ax.axvline(p, color="k", lw=0.8, ls="--")
    if drawn:
        handles.append(Line2D([], [], color="k", lw=0.8, ls="--", label="stops" if len(drawn) > 1 else "stop"))
    ax.set_xlabel(r.axes.labels[0])
    ax.set_ylabel(r.axes.labels[1])
    ax.set_title(title or f"basins of attraction at {r.slice_text(i)} (run {r.name})")
    if handles:
        legend_outside(fig, handles, loc="outside lower center", ncol=1)
    return fig


def _branch_lines(branches: dict):
    """``(n, Omega, amplitude, stable)`` of every branch of ``{run: read_branch_group dict}`` that
    is continued in Omega (other groups skipped)."""
    for run, d in (branches or {}).items():
        for name, b in d.items():
            if not isinstance(b, dict) or not {"parameter", "amplitude", "stable", "attrs"} <= set(b):
                continue
            if str(b["attrs"].get("parameter", "Omega")) not in ("Omega", ""):
                continue
            yield (int(b["attrs"].get("n", 1)), np.asarray(b["parameter"], float),
                   np.asarray(b["amplitude"], float), np.asarray(b["stable"], bool), run)


def branch_distance(r: BasinsResult, branches: dict) -> np.ndarray:
    """How far each periodic attractor lies from the stable continuation branches of its period,
    shape (n_Omega, n_attractors): ``|Q - Q_b| / Q`` with ``Q_b`` the branch amplitude linearly
    interpolated between the two stable branch points that bracket the frequency (the nearest
    such branch); NaN for an attractor that is not periodic or where no stable branch of its
    period passes.  ``branches``: ``{run: group}`` as :func:`vibeam.io.results.read_results` gives
    them (``["branches"]``), continued in Omega over the same model.  A stable periodic attractor
    must lie on a stable branch (issue 21)."""
    out = np.full((len(r.Omega), r.n_attractors), np.nan)
    lines = list(_branch_lines(branches))
    for i, W in enumerate(r.Omega):
        for k in range(r.n_attractors):
            n = int(r.attractors["period"][i, k])
            Q = r.attractors["amplitude"][i, k]
            if n < 1 or not np.isfinite(Q):
                continue
            best = np.inf
            for nb, p, A, st, _ in lines:
                if nb != n:
                    continue
                for j in range(len(p) - 1):
                    if (p[j] - W) * (p[j + 1] - W) <= 0 and p[j] != p[j + 1] and st[j] and st[j + 1]:
                        Ab = A[j] + (A[j + 1] - A[j]) * (W - p[j]) / (p[j + 1] - p[j])
                        best = min(best, abs(Q - Ab) / abs(Q))
            if np.isfinite(best):
                out[i, k] = best
    return out


def census_figure(r: BasinsResult, title: str = "", branches: dict | None = None):
    """Basin fractions as a stacked area over the frequency, and each attractor's amplitude over
    the continuation branches of ``branches`` (``{run: group}``, stable solid, unstable dashed)."""
    with context():
        x = r.values if r.values is not None else r.frequency_hz if r.frequency_hz is not None else r.Omega
        fig, (a1, a2) = plt.subplots(2, 1, sharex=True, figsize=(6.4, 6.0))
        if r.values is not None:      # continuation branches are drawn over the frequency only
            branches = None
        fx = (r.frequency_hz[0] / r.Omega[0]) if r.frequency_hz is not None else 1.0
        fy = r.amplitude_scale_mm or 1.0
        for n, p, A, st, run in _branch_lines(branches):
            lo, hi = np.min(x) / fx, np.max(x) / fx
            keep = (p >= lo - 0.1 * (hi - lo)) & (p <= hi + 0.1 * (hi - lo))
            for stab, ls in ((True, "-"), (False, "--")):
                y = np.where(st == stab, A, np.nan) * fy
                a2.plot(p * fx, np.where(keep, y, np.nan), ls=ls, color="0.6", lw=0.9, zorder=0,
                        label=f"branches ({'stable' if stab else 'unstable'})")
        _census_axes(r, x, a1, a2, title)
        h, labels = a2.get_legend_handles_labels()
        uniq = dict(zip(labels, h))
        a2.legend(uniq.values(), uniq.keys(), loc="upper left", bbox_to_anchor=(1.0, 1.0))
        return fig


def _census_axes(r, x, a1, a2, title):
    fr = r.attractors["fraction"]
    a1.stackplot(x, fr.T, colors=[PALETTE[k % len(PALETTE)] for k in range(fr.shape[1])],
                 labels=[f"attractor {k}" for k in range(fr.shape[1])])
    a1.set_ylim(0, 1)
    amp = r.attractors["amplitude"] * (r.amplitude_scale_mm or 1.0)
    for k in range(amp.shape[1]):
        a2.plot(x, amp[:, k], "o-", ms=3, color=PALETTE[k % len(PALETTE)], label=f"attractor {k}")
    a2.set_ylabel("amplitude Q (mm)" if r.amplitude_scale_mm else f"amplitude Q ({NODIM})")
    if r.values is not None:
        unit = parameter_units(r.parameter)
        a2.set_xlabel(f"{r.parameter} ({NODIM if unit == '1' else unit})")
        where = f"{r.parameter} at {r.slice_text(0).split(' at ')[-1]}"
    else:
        a2.set_xlabel("frequency (Hz)" if r.frequency_hz is not None else rf"$\Omega$ ({NODIM})")
        where = "the frequency"
    a1.set_ylabel(f"basin fraction ({NODIM})")
    a1.legend(loc="upper left", bbox_to_anchor=(1.0, 1.0))
    a1.set_title(title or f"attractors along {where} (run {r.name})")


#: the files :func:`plot_basins` writes (:func:`vibeam.io.outdir.check_outputs` patterns)
OUTPUT_NAMES = ("basins_*.png", "census_*.png")


def plot_basins(r: BasinsResult, out_dir, title: str = "", branches: dict | None = None) -> list:
    """Write ``basins_<run>[_<i>].png`` (and ``census_<run>.png`` for several frequencies, over
    the continuation ``branches`` when given)."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    paths = []
    stem = file_stem(r.name)
    for i in range(len(r.Omega)):
        fig = basins_figure(r, i, title)
        p = out_dir / (f"basins_{stem}.png" if len(r.Omega) == 1 else f"basins_{stem}_{i:03d}.png")
        try:
            paths.append(save_figure(fig, p, dpi=120))       # atomically, never into a pipe or a link
        finally:
            plt.close(fig)
    if len(r.Omega) > 1:
        fig = census_figure(r, title, branches)
        try:
            paths.append(save_figure(fig, out_dir / f"census_{stem}.png", dpi=120))
        finally:
            plt.close(fig)
    return paths


def print_basins(r: BasinsResult) -> None:
    """One line per attractor and frequency."""
    for i, W in enumerate(r.Omega):
        lab = r.labels[i]
        print(f"basins of run {r.name} at {r.slice_text(i)}: {lab.size} initial states, {int(r.periods[i])} periods, "
              f"{r.wall_time_s[i]:.2f} s")
        for k in range(r.n_attractors):
            if r.attractors["type"][i][k]:
                print(f"  {_legend_text(r, i, k)} (+- {100 * r.attractors['fraction_se'][i, k]:.1f} %), "
                      f"{_lambda_text(r, i, k)}")
        n_ok = max(int(np.sum(lab != BEHIND_STOP)), 1)
        for code in (UNSETTLED, FAILED):
            if np.any(lab == code):
                print(f"  {LABELS[code]}: {100 * np.sum(lab == code) / n_ok:.1f} %")
        if np.any(lab == BEHIND_STOP):
            print(f"  {int(np.sum(lab == BEHIND_STOP))} of {lab.size} initial states lie behind a stop: not "
                  f"simulated, not counted in the fractions")
        rate, upper = r.mislabel_rate(i)
        if math.isfinite(rate):
            print(f"  labels checked by long simulation: {int(r.labels_wrong[i])} of {int(r.labels_checked[i])} "
                  f"wrong (mislabel rate {100 * rate:.1f} %, at most {100 * upper:.1f} % at 95 %)")
