"""The one results writer (netCDF4/CF in HDF5, h5py dimension scales) for every fidelity and method.

``results.h5`` is a netCDF4 file: every array has named dimensions (HDF5
dimension scales), coordinates, ``units`` and ``long_name`` (CF conventions),
strings are UTF-8.  So it opens with plain h5py, with netCDF tools, and as
labelled data::

    import xarray as xr
    ds = xr.open_dataset("results.h5", group="runs/exact", engine="h5netcdf")
    ds.amplitude.sel(direction="up").plot()            # amplitude against Omega

or all groups at once: ``vibeam.open_results(path)`` (an :class:`xarray.DataTree`).

Layout (``vibeam_layout = 2``, root attribute)::

    /                        attrs: vibeam_version, vibeam_layout, case_name, case_text, case_json,
                             created, complete (1 = finished, 0 = only the checkpoint), Conventions
    /runs/<run>/             one run (attrs: fidelity, method, settings (JSON), wall_time_s,
                             run attrs; ``json_attrs`` names those stored as JSON)
        direction (direction)            'up', 'down' (the sweep directions run)
        Omega (Omega)                    forcing frequency / natural frequency, increasing
        frequency_hz (Omega)             physical scenes: f = Omega f_n (auxiliary coordinate)
        <per-point> (direction, Omega)   amplitude, period, status, message, wall_time_s, ...
        strobe (direction, Omega, record_period, state)
        harmonics (direction, Omega, harmonic)
        mode_amplitudes, participation_* (direction, Omega, mode)      beam scenes
        peaks_* (direction, Omega, peak); spectrum_velocity (direction, Omega, spectrum_frequency)
        R_*_ladder (direction, Omega, noise_level)                      sensor effect
        multipliers (…, multiplier); map_eigenvalues (…, eigenvalue)    mapping method
        time_series/<f>/         [assess] time_series at grid frequency <f>:
            time (time); displacement, velocity (direction, time); point_Omega (direction)
    /maps/<run>/             a parameter map ([map]); attrs as a run, plus ``parameter``
        direction (direction); <parameter> (<parameter>)   e.g. voltage (V), gap_mm (mm)
        Omega (Omega) and frequency_hz (Omega)   when Omega is the same on every value line;
            otherwise frequency_hz (frequency_hz) and Omega (<parameter>, frequency_hz)
        <per-point> (direction, <parameter>, Omega|frequency_hz[, ...])   classification, ...
    /branches/<run>/         continuation branches (vibeam.analysis.branches)
    /basins/<run>/           basins of attraction (vibeam.analysis.attractors)
    /<extra>/                tables of other commands (``cost``, ``fit``), e.g. (row)

Every unit (``runs/<run>``, ``maps/<run>``, ``branches/<run>``, ``basins/<run>``, a table)
has the attributes ``case_hash`` and ``case_name`` of the case it was computed from; a unit of
another case than the file's is marked ``stale = 1`` (``stale_reason``, and its own
``case_text`` and ``case_json``) -- :mod:`vibeam.io.store`.

The checkpoint of a running command is a file of its own beside the results file,
``results.h5.partial`` (root attribute ``complete = 0``)::

    /lines/<run>/<line>/         each finished sweep line's per-point arrays along ``point``
                                 (visiting order); attrs: case_hash
    /basin_lines/<run>/<row>/    finished rows of a basin computation; attrs: basins_ident
    /uncertainty_samples/<run>/<block>/   finished samples of ``vibeam uncertainty``: sample (sample);
                                 amplitude, period, status (sample, direction, Omega); attrs: case_hash

A run's points of every direction lie on one grid: ``up`` visits the ``Omega``
coordinate in increasing order and ``down`` in decreasing order; both are stored
along the increasing coordinate.  :func:`read_results` returns the old flat
per-point table (points in visiting order: up, then down), which every FRC tool
(regression, plots) reads, and also reads files of the first layout (no
dimensions; ``tests/references`` were converted once by
``tests/references/convert_layout.py``).

When a command completes, what it consumed of the checkpoint is removed: the data is
stored once, in the results file.  ``--resume`` of a complete run recomputes nothing (the
runs are read back: :func:`load_results`).

Every write goes through the results store (:class:`vibeam.io.store.Store`): the folder's
lock for the whole command, the whole successor built in memory from the old file and
renamed over it once complete (:func:`vibeam.io.outdir.replace_file`), every group kept.
An interrupted or killed run, a full disk or a file-size limit therefore leaves the
previous complete file byte for byte, and ``--resume`` recomputes only the lines missing
from the checkpoint; HDF5 never meets a failing write.

Any other group (continuation branches, fit tables) is written through
:func:`vibeam.io.netcdf.write_group`: a dict of :class:`~vibeam.io.netcdf.Variable` (dims, data, units, long_name)
becomes one netCDF group with its dimensions and coordinates.
"""
from __future__ import annotations

import json
import tomllib
from pathlib import Path

import h5py
import numpy as np

from vibeam.io.h5check import open_checked
from vibeam.io.netcdf import (Variable, dataset_values, is_dim_only, json_default,  # noqa: F401
                     parameter_units, read_attrs, read_plain, set_attrs, var, write_group)
from vibeam.io.objects import MapResult, SweepResult
from vibeam.io.outputs import UNITS
from vibeam.io.store import LAYOUT_VERSION, PARTIAL_SUFFIX, Store, case_hash  # noqa: F401 (re-exported)



# ============================================================================ what each variable is
# (units, long_name) of the per-point outputs; units are UDUNITS strings ("1": dimensionless).
# ``None`` units: the unit of the scene's axes (Hz / mm / mm s-1 for physical scenes, "1" otherwise),
# resolved by :func:`describe`.  Names not listed fall back to vibeam.io.outputs.UNITS ("unit (text)").
VARIABLES = {
    "Omega": ("1", "forcing frequency over natural frequency, Omega = f / f_n"),
    "frequency_hz": ("Hz", "forcing frequency f"),
    "direction": ("", "sweep direction (up: increasing Omega, down: decreasing)"),
    "amplitude": ("1", "amplitude Q = Delta - min q over the record (paper Sec. 4.1)"),
    "amplitude_mm": ("mm", "amplitude at the sensor U(L_S) = Q L (paper Sec. 6)"),
    "amplitude_lower": ("1", "lower (unstable) branch of P(Q) = 0, averaging (paper Eq. 21)"),
    "q_max": ("1", "largest displacement q over the record"),
    "q_min": ("1", "smallest displacement q over the record"),
    "period": ("1", "period-n of the stroboscopic map (1..8; 0 not periodic within 8, -1 no impact)"),
    "impacts_per_period": ("1", "impacts per forcing period (two stops: on the upper stop)"),
    "impact_velocity": ("1", "mean pre-impact velocity q'- (two stops: on the upper stop)"),
    "impacts_per_period_lower": ("1", "impacts per forcing period on the lower stop of a two-sided scene"),
    "impact_velocity_lower": ("1", "mean pre-impact speed |q'-| on the lower stop of a two-sided scene"),
    "strobe": ("1", "stroboscopic samples (q, q') at forcing phase 0 of each recorded period"),
    "harmonics": ("1", "amplitudes of the harmonics 0, Omega, ..., 5 Omega of q (paper Fig. 20)"),
    "status": ("", "outcome of the point: ok, chatter, sticking, unsettled, failed"),
    "message": ("", "detail of the status (empty when ok)"),
    "wall_time_s": ("s", "compute time of the point"),
    "stuck_fraction": ("1", "share of the recorded window spent on the stop"),
    "effective_gain": ("V-1", "gamma at this frequency (platform filter)"),
    "gap_mm": ("mm", "grazing gap at the sensor at this point (gap drift)"),
    "gap_drift_mm": ("mm", "drift of the gap at the sensor"),
    "impulse_per_period": ("1", "sum of (1 + R) U- per forcing period"),
    # averaging (paper Sec. 4.1, Eqs. 18-27)
    "theta": ("rad", "phase theta of the averaged solution (paper Eq. 23)"),
    "impact_phase": ("rad", "forcing phase of the impact"),
    "stable": ("1", "1 if the orbit is stable (Floquet multipliers; averaging: upper branch)"),
    "Q_star": ("1", "amplitude Q* at the turning point of the averaged FRC (paper Eq. 25)"),
    "Delta_max": ("1", "largest gap with impacting solutions near Omega = 2k (paper Eq. 26)"),
    # mapping (paper Eqs. 28-37)
    "stable_full": ("1", "1 if stable by the paper's full Jacobian (Eqs. 29-32)"),
    "stable_simplified": ("1", "1 if stable by the paper's simplified Jacobian (Eqs. 35-37)"),
    "stable_paper": ("1", "1 if stable by the paper's Jacobian of the run's form"),
    "disagree_full": ("1", "1 if Eqs. 29-32 and the Floquet multipliers disagree on stability"),
    "disagree_simplified": ("1", "1 if Eqs. 35-37 and the Floquet multipliers disagree on stability"),
    "multipliers": ("1", "Floquet multipliers (monodromy with the saltation matrix)"),
    "lyapunov": ("1", "Lyapunov exponents of the stroboscopic map per unit nondimensional time, largest first "
                      "(vibeam.models.orbits.lyapunov)"),
    "lyapunov_error": ("1", "standard error of each Lyapunov exponent by batch means over the record (0: Floquet "
                            "exponents of a periodic orbit)"),
    "lyapunov_qr": ("1", "Lyapunov exponents by the QR method, kept as a check beside Floquet exponents"),
    "lyapunov_method": ("", "floquet (the periodic orbit's Floquet exponents) or qr (the QR method on the record)"),
    "lyapunov_message": ("", "why the Lyapunov exponents are NaN (empty when computed)"),
    "lyapunov_class": ("", "periodic, chaotic, quasi_periodic or non_periodic from the Lyapunov spectrum "
                           "(vibeam.models.orbits.lyapunov.classify_spectrum; empty: not computed)"),
    "map_eigenvalues": ("1", "eigenvalues of the paper's impact-map Jacobian"),
    "det_full": ("1", "determinant of the Jacobian of Eqs. 29-32"),
    "tr_full": ("1", "trace of the Jacobian of Eqs. 29-32"),
    "det_simplified": ("1", "determinant of the Jacobian of Eqs. 35-37"),
    "tr_simplified": ("1", "trace of the Jacobian of Eqs. 35-37"),
    "det_true": ("1", "determinant of the exact impact-map Jacobian"),
    "tr_true": ("1", "trace of the exact impact-map Jacobian"),
    "nfev": ("1", "Newton iterations (function evaluations) of the fixed point"),
    # beam
    # eta_i is in m kg^(1/2), which UDUNITS cannot write (no fractional powers: "m kg0.5" reads as
    # 0.5 m): the variable is eta_i / sqrt(1 kg), the same numbers, in m
    "mode_amplitudes": ("m", "largest |eta_i| / sqrt(1 kg) of each mass-normalised modal coordinate "
                             "(eta_i in m kg^(1/2))"),
    "mode_contact_amplitudes": ("1", "largest |w_i eta_i| / L of each mode at the contact"),
    "contact_gap_max": ("1", "largest unclamped contact gap of an event-free step / L (certificate)"),
    "impact_velocity_m_s": ("m s-1", "mean pre-impact contact velocity"),
    "steps_per_period": ("1", "solver steps per forcing period"),
    # assessments and the sensor
    "peaks_frequency": (None, "frequencies of the largest non-harmonic spectral peaks"),
    "peaks_displacement": ("mm", "displacement amplitude of the non-harmonic peaks"),
    "peaks_velocity": ("mm s-1", "velocity amplitude of the non-harmonic peaks"),
    "peaks_mode": ("1", "nearest mode of the peak (1-based; 0 none)"),
    "peaks_family": ("1", "family of the peak's mode: 1 free mode, 2 contact mode, 0 none"),
    "spectrum_velocity": ("mm s-1", "sensor velocity spectrum, max-pooled on spectrum_frequency"),
    "band_velocity_mm_s": ("mm s-1", "largest line of the sensor velocity in hfc_band"),
    "band_frequency": (None, "frequency of that line"),
    "hfc_velocity_mm_s": ("mm s-1", "high-frequency component: mean peak velocity after the impacts"),
    "hfc_displacement_mm": ("mm", "high-frequency component: mean peak displacement after the impacts"),
    "hfc_frequency": (None, "dominant frequency of the high-frequency component"),
    "participation_displacement": ("1", "share of each mode in the sensor displacement (RMS)"),
    "participation_energy": ("1", "share of each mode in the mean modal energy"),
    "R_identified": ("1", "CoR identified from the simulated sensor (paper Sec. 5.1)"),
    "R_identified_std": ("1", "standard deviation of the identified CoR over the picked impacts"),
    "R_true": ("1", "the model's R at the matched impacts"),
    "R_sensor_exact": ("1", "-v(t+)/v(t-) of the exact sensor velocity at the impacts"),
    "identified_velocity_mm_s": ("mm s-1", "mean picked pre-impact sensor velocity U'-"),
    "true_velocity_mm_s": ("mm s-1", "mean true pre-impact sensor velocity"),
    "R_n_identified": ("1", "impacts picked from the sensor signal"),
    "R_n_false": ("1", "picks that match no true impact"),
    "R_identified_ladder": ("1", "identified CoR at each sensor noise level"),
    "R_true_ladder": ("1", "model R at the impacts matched at each noise level"),
    # maps
    "classification": ("1", "class of the point (flag_values, flag_meanings)"),
    # coordinates of extra dimensions
    "record_period": ("1", "recorded forcing period (0 = first)"),
    "state": ("", "component of the state: q, q'"),
    "harmonic": ("1", "harmonic order k (frequency k Omega)"),
    "mode": ("1", "mode number (1 = first)"),
    "peak": ("1", "rank of the peak (1 = largest)"),
    "spectrum_frequency": (None, "frequency axis of spectrum_velocity (bin centres)"),
    "noise_level": ("mm", "standard deviation of the sensor noise"),
    "multiplier": ("1", "index of the Floquet multiplier"),
    "exponent": ("1", "index of the Lyapunov exponent (1 = largest)"),
    "eigenvalue": ("1", "index of the eigenvalue"),
    "time": (None, "time from the start of the stored window"),
    "displacement": ("mm", "sensor displacement U(L_S)"),
    "velocity": ("mm s-1", "sensor velocity U'(L_S)"),
    "point_Omega": ("1", "Omega of the grid point of the time series"),
    "point": ("1", "index of the point along the line, in visiting order"),
}
_SCALED = {"peaks_displacement", "peaks_velocity", "spectrum_velocity", "band_velocity_mm_s",
           "hfc_velocity_mm_s", "hfc_displacement_mm", "displacement", "velocity"}

# extra dimensions of per-point arrays beyond (direction, Omega): name -> dims of the trailing axes
EXTRA_DIMS = {
    "strobe": ("record_period", "state"),
    "harmonics": ("harmonic",),
    "mode_amplitudes": ("mode",), "mode_contact_amplitudes": ("mode",),
    "participation_displacement": ("mode",), "participation_energy": ("mode",),
    "peaks_frequency": ("peak",), "peaks_displacement": ("peak",), "peaks_velocity": ("peak",),
    "peaks_mode": ("peak",), "peaks_family": ("peak",),
    "spectrum_velocity": ("spectrum_frequency",),
    "R_identified_ladder": ("noise_level",), "R_true_ladder": ("noise_level",),
    "multipliers": ("multiplier",), "map_eigenvalues": ("eigenvalue",),
    "lyapunov": ("exponent",), "lyapunov_error": ("exponent",), "lyapunov_qr": ("exponent",),
    "stop_impacts": ("stop",), "stop_impacts_per_period": ("stop",), "stop_impact_velocity": ("stop",),
}
# run attributes that are the coordinate of an extra dimension (stored once, as the coordinate)
ATTR_COORDS = {"spectrum_frequency": "spectrum_frequency", "noise_level": "noise_ladder_mm"}

def describe(name: str, physical: bool = False) -> tuple[str, str]:
    """``(units, long_name)`` of a per-point output or coordinate.

    Parameters
    ----------
    name : str
        Dataset name (e.g. ``amplitude``, ``peaks_frequency``).
    physical : bool
        A physical scene (frequencies in Hz, displacements in mm at the sensor); the
        spectral outputs of a nondimensional scene are in Omega units and q.

    Names not in :data:`VARIABLES` take :data:`vibeam.io.outputs.UNITS` (``"unit (text)"``);
    unknown names get units ``"1"`` and their name as long_name.
    """
    if name in VARIABLES:
        u, ln = VARIABLES[name]
        if u is None:
            u = ("s" if name == "time" else "Hz") if physical else "1"
        elif name in _SCALED and not physical:
            u = "1"
        return u, ln

    text = UNITS.get(name)
    if text:
        head, _, rest = text.partition(" (")
        if " " in head:                       # a count described in words: "forcing periods recorded (...)"
            return "1", text
        if rest:
            return head, rest[:-1] if rest.endswith(")") else rest
        return head, _name_words(name)        # a bare unit: the long_name is the name, never the unit
    for suffix, unit in _NAME_SUFFIX_UNITS:
        if name.endswith(suffix):
            return unit, _name_words(name)
    return "1", name.replace("_", " ")


#: units of a name's suffix (``contact_force_max_n`` N): the fall-back of :func:`describe`, longest first
_NAME_SUFFIX_UNITS = (("_mm_s", "mm s-1"), ("_m_s", "m s-1"), ("_mm", "mm"), ("_hz", "Hz"), ("_s", "s"),
                      ("_n", "N"), ("_j", "J"))


def _name_words(name: str) -> str:
    """A long_name from a dataset name: its words without the unit suffix (``energy_per_impact_j``
    -> ``energy per impact``)."""
    for suffix, _ in _NAME_SUFFIX_UNITS:
        if name.endswith(suffix):
            name = name[: -len(suffix)]
            break
    return name.replace("_", " ")


def table_variables(table: dict) -> dict:
    """Variables of a plain table ``{name: array or Variable}`` (the ``extra`` groups): a
    Variable is kept; an array gets dims ``<name>_dim<i>`` and units from :func:`describe`."""
    out = {}
    for k, v in table.items():
        if isinstance(v, Variable):
            out[k] = v
            continue
        a = np.asarray(v)
        u, ln = describe(k)
        out[k] = var(tuple(f"{k}_dim{i}" for i in range(a.ndim)), a,
                     None if a.dtype == object or a.dtype.kind in "US" else u, ln)
    return out


# ============================================================================ runs and maps as variables
def _physical(data: dict) -> bool:
    return "frequency_hz" in data


def _point_var(name, dims, data, physical) -> Variable:
    u, ln = describe(name, physical)
    a = np.asarray(data)
    text = a.dtype == object or a.dtype.kind in "US"
    return var(dims, a, None if text or not u else u, ln)


def _extra_dims(name, shape, taken: dict) -> tuple:
    """Names of the trailing axes of a per-point array (:data:`EXTRA_DIMS`), renamed when a
    dimension of that name already has another size in the group."""
    base = EXTRA_DIMS.get(name)
    if base is None or len(base) != len(shape):
        base = tuple(f"{name}_dim{i}" for i in range(len(shape)))
    out = []
    for d, n in zip(base, shape):
        if taken.setdefault(d, n) != n:
            d = f"{d}_{name}"
            taken.setdefault(d, n)
        out.append(d)
    return tuple(out)


def _extra_coords(taken: dict, attrs: dict, physical: bool) -> dict:
    """Coordinates of the extra dimensions that have one."""
    out = {}
    for d, n in taken.items():
        if d == "record_period" or d == "harmonic":
            out[d] = _point_var(d, (d,), np.arange(n), physical)
        elif d in ("mode", "peak", "multiplier", "eigenvalue", "exponent"):
            out[d] = _point_var(d, (d,), np.arange(1, n + 1), physical)
        elif d == "state" and n == 2:
            out[d] = _point_var(d, (d,), np.array(["q", "q'"], dtype=object), physical)
        elif d in ATTR_COORDS and ATTR_COORDS[d] in attrs and np.size(attrs[ATTR_COORDS[d]]) == n:
            out[d] = _point_var(d, (d,), np.asarray(attrs[ATTR_COORDS[d]], float), physical)
    return out


def _grid_order(d: dict):
    """Per direction, the indices of its points along the increasing grid, or None when the
    directions do not share one grid (then the flat point layout is written)."""
    direc = np.asarray([str(x) for x in d["direction"]])
    dirs = list(dict.fromkeys(direc.tolist()))
    om = np.asarray(d["Omega"], float)
    idx = {}
    for k in dirs:
        i = np.flatnonzero(direc == k)
        idx[k] = i[::-1] if k == "down" else i
    grid = om[idx[dirs[0]]]
    if np.any(np.diff(grid) < 0) or any(not np.array_equal(om[i], grid) for i in idx.values()):
        return None, dirs
    return idx, dirs


def run_variables(data: dict, attrs: dict | None = None) -> tuple[dict, dict]:
    """The variables (and time-series subgroups) of one run, laid out on (direction, Omega).

    Parameters
    ----------
    data : dict
        Per-point arrays in visiting order (:attr:`vibeam.engine.sweep.SweepResult.data`).
    attrs : dict, optional
        Run attributes (the spectrum and noise axes become coordinates).

    Returns
    -------
    (variables, groups)
        For :func:`write_group`.  If the directions' points are not on one increasing grid
        (never for a sweep of :mod:`vibeam.engine.sweep`), the flat layout along ``point`` is
        returned instead, with ``direction`` and ``Omega`` per point.
    """
    attrs = attrs or {}
    phys = _physical(data)
    idx, dirs = _grid_order(data) if "direction" in data and len(data.get("Omega", ())) else (None, [])
    taken: dict = {}
    out: dict = {}
    groups: dict = {}
    if idx is None:
        for k, v in data.items():
            if "/" in k:
                continue
            a = np.asarray(v)
            out[k] = _point_var(k, ("point",) + _extra_dims(k, a.shape[1:], taken), a, phys)
        out.update(_extra_coords(taken, attrs, phys))
        return out, groups
    order = np.concatenate([idx[k] for k in dirs])
    n_d, n_f = len(dirs), len(idx[dirs[0]])
    out["direction"] = _point_var("direction", ("direction",), np.array(dirs, dtype=object), phys)
    out["Omega"] = _point_var("Omega", ("Omega",), np.asarray(data["Omega"], float)[idx[dirs[0]]], phys)
    if "frequency_hz" in data:
        f = np.asarray(data["frequency_hz"], float)
        if all(np.array_equal(f[i], f[idx[dirs[0]]]) for i in idx.values()):
            v = _point_var("frequency_hz", ("Omega",), f[idx[dirs[0]]], phys)
            v.attrs["aux"] = True
            out["frequency_hz"] = v
    for k, v in data.items():
        if k in out or "/" in k:
            continue
        a = np.asarray(v)
        a = a[order].reshape((n_d, n_f) + a.shape[1:])
        out[k] = _point_var(k, ("direction", "Omega") + _extra_dims(k, a.shape[2:], taken), a, phys)
    out.update(_extra_coords(taken, attrs, phys))
    ts = sorted({k.split("/")[1] for k in data if k.startswith("time_series/") and k.count("/") == 2})
    for label in ts:
        groups[f"time_series/{label}"] = (_time_series_variables(data, label, dirs, phys), {"label": label})
    return out, groups


def _time_series_variables(data, label, dirs, phys) -> dict:
    series = {d: np.asarray(data[f"time_series/{label}/{d}"], float) for d in dirs
              if f"time_series/{label}/{d}" in data}
    m = max(a.shape[0] for a in series.values())
    disp = np.full((len(dirs), m), np.nan)
    vel = np.full((len(dirs), m), np.nan)
    om = np.full(len(dirs), np.nan)
    t = None
    same = True
    for i, d in enumerate(dirs):
        if d not in series:
            continue
        a = series[d]
        disp[i, :a.shape[0]] = a[:, 1]
        vel[i, :a.shape[0]] = a[:, 2]
        om[i] = float(data[f"time_series/{label}/{d}_Omega"])
        if t is None:
            t = np.full(m, np.nan)
            t[:a.shape[0]] = a[:, 0]
        elif not np.array_equal(t[:a.shape[0]], a[:, 0]):
            same = False
    out = {}
    if same:
        out["time"] = _point_var("time", ("time",), t, phys)
    else:
        tt = np.full((len(dirs), m), np.nan)
        for i, d in enumerate(dirs):
            if d in series:
                tt[i, :series[d].shape[0]] = series[d][:, 0]
        out["t"] = _point_var("time", ("direction", "time"), tt, phys)
    out["displacement"] = _point_var("displacement", ("direction", "time"), disp, phys)
    out["velocity"] = _point_var("velocity", ("direction", "time"), vel, phys)
    out["point_Omega"] = _point_var("point_Omega", ("direction",), om, phys)
    if not phys:
        out["displacement"].attrs["long_name"] = "displacement q"
        out["velocity"].attrs["long_name"] = "velocity q'"
    return out


def map_variables(m) -> dict:
    """The variables of a parameter map (:class:`vibeam.analysis.maps.MapResult`), on
    (direction, <parameter>, Omega) -- or (direction, <parameter>, frequency_hz) when Omega
    differs between the values (a mapped parameter that changes f_n)."""
    d = m.data
    phys = _physical(d)
    par = m.parameter
    dirs = [str(x) for x in d["direction"]]
    vals = np.asarray(d["values"], float)
    om = np.asarray(d["Omega"], float)
    out = {"direction": _point_var("direction", ("direction",), np.array(dirs, dtype=object), phys)}
    out[par] = var((par,), vals, parameter_units(par), f"mapped parameter {par}")
    same_om = bool(np.all(om == om[:1, :1, :]))
    fq = np.asarray(d["frequency_hz"], float) if "frequency_hz" in d else None
    same_f = fq is not None and bool(np.all(fq == fq[:1, :1, :]))
    if same_om:
        fdim = "Omega"
        out["Omega"] = _point_var("Omega", ("Omega",), om[0, 0], phys)
        if fq is not None:
            if same_f:
                out["frequency_hz"] = _point_var("frequency_hz", ("Omega",), fq[0, 0], phys)
            else:
                out["frequency_hz"] = _point_var("frequency_hz", (par, "Omega"), fq[0], phys)
            out["frequency_hz"].attrs["aux"] = True
    elif same_f:
        fdim = "frequency_hz"
        out["frequency_hz"] = _point_var("frequency_hz", ("frequency_hz",), fq[0, 0], phys)
        out["Omega"] = _point_var("Omega", (par, "frequency_hz"), om[0], phys)
        out["Omega"].attrs["aux"] = True
    else:
        fdim = "frequency"
        out["Omega"] = _point_var("Omega", (par, "frequency"), om[0], phys)
        out["Omega"].attrs["aux"] = True
        if fq is not None:
            out["frequency_hz"] = _point_var("frequency_hz", (par, "frequency"), fq[0], phys)
            out["frequency_hz"].attrs["aux"] = True
    taken: dict = {}
    for k, v in d.items():
        if k in ("values", "direction", "Omega", "frequency_hz"):
            continue
        a = np.asarray(v)
        name = k if k not in out else f"{k}_at_point"
        x = _point_var(k, ("direction", par, fdim) + _extra_dims(k, a.shape[3:], taken), a, phys)
        if name != k:
            x.attrs["vibeam_name"] = k
        if k == "classification" and m.attrs.get("classes"):
            # "0 no impact; 1 period-1; ..." (vibeam.analysis.maps.CLASSES, in the map's attrs)
            classes = [c.strip().split(" ", 1) for c in str(m.attrs["classes"]).split(";")]
            x.attrs["flag_values"] = np.array([int(c[0]) for c in classes], dtype=np.int8)
            x.attrs["flag_meanings"] = " ".join(c[1].split(" (")[0].replace(" ", "_").replace("-", "_")
                                                for c in classes)
        out[name] = x
    out.update(_extra_coords(taken, m.attrs, phys))
    return out


def line_variables(data: dict) -> dict:
    """The checkpoint of one sweep line: per-point arrays along ``point`` (visiting order)."""
    taken: dict = {}
    phys = _physical(data)
    return {k: _point_var(k, ("point",) + _extra_dims(k, np.shape(v)[1:], taken), v, phys)
            for k, v in data.items()}


# ============================================================================ groups (written by the store)
def run_group(r):
    """The writer of ``/runs/<name>`` of one run (a ``fill(file)`` for :meth:`vibeam.io.store.Store.commit`)."""
    def fill(f, ids=None):
        v, groups = run_variables(r.data, r.attrs)
        write_group(f, f"runs/{r.name}", v, _group_attrs(r), groups, _ids=ids)
    return fill


def map_group(m):
    """The writer of ``/maps/<name>`` of one parameter map."""
    def fill(f, ids=None):
        write_group(f, f"maps/{m.name}", map_variables(m), _group_attrs(m, parameter=m.parameter), _ids=ids)
    return fill


def table_group(gpath: str, table: dict, attrs: dict | None = None):
    """The writer of a plain table ``{name: array or Variable}`` at ``gpath`` (:func:`table_variables`),
    with ``attrs = {path: {name: value}}`` set last on the group or its variables (paths below
    ``gpath``, e.g. ``{"fit/residuals": {"units": "mm"}}``)."""
    def fill(f, ids=None):
        write_group(f, gpath, table_variables(table), _ids=ids)
        for apath, a in (attrs or {}).items():
            obj = f[apath] if apath in f else f.require_group(apath)
            set_attrs(obj, a)
    return fill


def line_group(data: dict, case_json: str) -> tuple:
    """``(variables, attrs)`` of one checkpointed sweep line (:meth:`vibeam.io.store.Store.checkpoint`)."""
    return line_variables(data), {"case_hash": case_hash(case_json)}


def read_lines(path, case_json: str | None = None) -> tuple[dict, dict]:
    """The checkpoint of a results file: ``(root attrs, {run: {line key: {dataset: array}}})``.

    The checkpoint is ``<path>.partial`` (:mod:`vibeam.io.store`); without one, the file's own
    ``/lines`` (where an earlier vibeam kept its checkpoint).  With ``case_json``, only the
    lines whose ``case_hash`` attribute is that of ``case_json`` (:func:`case_hash`) are
    returned: a line of another case, or one without the attribute, is never kept.  A complete
    file has no lines.  The root attributes are those of the file read (the checkpoint's
    ``complete`` is 0).
    """
    path = Path(path)
    partial = path.with_name(path.name + PARTIAL_SUFFIX)
    src = partial if partial.is_file() else path
    out = {}
    ident = None if case_json is None else case_hash(case_json)
    with open_checked(src, "checkpoint") as f:
        attrs = read_attrs(f)
        lines = f.get("lines", getlink=True)
        if isinstance(lines, h5py.HardLink):
            for run, g in f["lines"].items():
                got = {key: read_plain(gl) for key, gl in g.items()
                       if ident is None or str(gl.attrs.get("case_hash", "")) == ident}
                if got:
                    out[run] = got
    return attrs, out


def write_results(path, runs: list, case_name: str = "", case_text: str = "",
                  extra: dict | None = None, maps: list | None = None, case_json: str = "",
                  branches: list | None = None, extra_attrs: dict | None = None, fresh: bool = False) -> Path:
    """Write runs, maps, continuation branches and tables into the results file ``path``,
    through its folder's results store (:class:`vibeam.io.store.Store`: under the folder's
    lock, every other group of an existing file kept, the whole file replaced atomically).

    Parameters
    ----------
    path : str or Path
        Target HDF5 (netCDF4) file; its folder is created if needed.
    runs : list of vibeam.engine.sweep.SweepResult
        Completed runs, written to ``/runs/<name>`` (:func:`run_variables`).
    case_name, case_text : str
        Stored as root attributes (the case text makes the file reproducible).
    extra : dict, optional
        Additional groups: ``{group_path: {name: array or Variable}}`` (e.g. the table
        of ``vibeam cost``; :func:`table_variables`).
    maps : list of vibeam.analysis.maps.MapResult, optional
        Parameter maps, written to ``/maps/<name>`` (:func:`map_variables`).
    case_json : str
        The validated case (as run, e.g. its quick variant) as JSON: the identity of the
        groups written (``case_hash``).
    branches : list of vibeam.analysis.branches.ContinuationResult, optional
        Continuation runs, written to ``/branches/<run>/``.
    extra_attrs : dict, optional
        Attributes set last on groups or variables of ``extra``, ``{path: {name: value}}``
        (e.g. ``{"fit/residuals": {"units": "mm"}}``).
    fresh : bool
        Start a new file (the old one's groups are not kept).

    Returns
    -------
    Path
        The written file.

    Raises
    ------
    ValueError
        An ``extra_attrs`` path that lies in none of the ``extra`` groups.
    """
    path = Path(path)
    with Store(path.parent, path.name, fresh=fresh) as store:
        return store.commit(result_groups(runs, maps, branches, extra, extra_attrs), case_name, case_text,
                            case_json)


def result_groups(runs=(), maps=(), branches=(), extra=None, extra_attrs=None) -> dict:
    """``{unit path: fill}`` of runs, maps, continuation branches and tables (for
    :meth:`vibeam.io.store.Store.commit`)."""
    groups = {}
    for r in runs or []:
        groups[f"runs/{r.name}"] = run_group(r)
    for m in maps or []:
        groups[f"maps/{m.name}"] = map_group(m)
    for b in branches or []:
        groups[f"branches/{b.name}"] = b.write       # a continuation run writes its own group
    extra = extra or {}
    for apath in extra_attrs or {}:
        if not any(apath == g or apath.startswith(g.rstrip("/") + "/") for g in extra):
            raise ValueError(f"extra_attrs {apath!r}: lies in none of the groups {sorted(extra)}")
    for gpath, table in extra.items():
        own = {k: v for k, v in (extra_attrs or {}).items() if k == gpath or k.startswith(gpath.rstrip("/") + "/")}
        groups[gpath.strip("/")] = table_group(gpath, table, own)
    return groups


def _group_attrs(r, **more) -> dict:
    a = {"fidelity": r.fidelity, "method": r.method, "settings": json.dumps(r.settings, default=json_default),
         "wall_time_s": r.wall_time_s}
    for k, v in r.attrs.items():
        if k in ATTR_COORDS.values():
            continue                       # stored once, as the coordinate of its dimension
        a[k] = v
    a.update(more)
    return a


# ============================================================================ reading
def read_branch_group(g) -> dict:
    """One ``/branches/<run>/`` group back as nested dicts, one per branch (the shape of the
    first layout): ``{"<index>-period<n>": {dataset: array, "attrs": {index, n, status, message,
    origin}}, "bifurcations": {...}, "curves": {"<i>-<type>": {...}}}``; padding removed."""
    flat = read_plain(g, attrs=True)
    if "n_points" not in flat:            # the first layout: one group per branch already
        return flat
    out = {}
    n = flat.pop("n_points")
    meta = {k: flat.pop(k) for k in ("branch", "branch_period", "branch_status", "branch_message", "branch_origin")}
    subs = {k: flat.pop(k) for k in ("bifurcations", "curves") if k in flat}
    for i in range(len(n)):
        b = {"index": int(meta["branch"][i]), "n": int(meta["branch_period"][i])}
        d = {k: a[i][: int(n[i])] for k, a in flat.items() if isinstance(a, np.ndarray) and a.ndim >= 2}
        for k, a in d.items():
            if a.ndim > 1:                  # trailing axes padded to the longest branch: as stored
                d[k] = a
        d["attrs"] = dict(b, status=str(meta["branch_status"][i]), message=str(meta["branch_message"][i]),
                          origin=str(meta["branch_origin"][i]))
        out[branch_name(b)] = d
    if "bifurcations" in subs:
        bt = subs["bifurcations"]
        out["bifurcations"] = {("branch" if k == "bifurcation_branch" else k): v for k, v in bt.items()}
    if "curves" in subs:
        c = subs["curves"]
        key2 = str(c["attrs"].get("curve_parameter", "parameter2"))
        cs = {}
        for i in range(len(c["n_curve_points"])):
            m = int(c["n_curve_points"][i])
            item = {"parameter": c["parameter"][i][:m], key2: c[key2][i][:m]}
            if "frequency_hz" in c:
                item["frequency_hz"] = c["frequency_hz"][i][:m]
            item["attrs"] = {"type": str(c["curve_type"][i]), "status": str(c["curve_status"][i]),
                             "message": str(c["curve_message"][i]), "period": int(c["curve_period"][i])}
            cs[f"{i:02d}-{item['attrs']['type']}"] = item
        cs["attrs"] = c.get("attrs", {})
        out["curves"] = cs
    return out


def branch_name(b: dict) -> str:
    return f"{b['index']:02d}-period{b['n']}"


def layout_of(path) -> int:
    """``vibeam_layout`` of a results file: 2 (netCDF dimensions) or 1 (the first, flat layout)."""
    with open_checked(path) as f:
        return int(read_attrs(f).get("vibeam_layout", 1))


def read_results(path) -> dict:
    """Read a results file into the flat per-point table of every run and map.

    Returns
    -------
    dict
        ``{"attrs": {...}, "runs": {name: {"attrs": {...}, dataset: array}},
        "maps": {name: {...}}}``.  Run datasets are 1-D per point (plus trailing axes),
        in visiting order (the up sweep in increasing Omega, then the down sweep in
        decreasing Omega), with ``direction`` and ``Omega`` (and ``frequency_hz``) per
        point; map datasets have shape (n_directions, n_values, n_frequencies, ...)
        with ``values`` and ``direction``; time series as
        ``run["time_series"][label][direction]`` (m, 3: time, displacement, velocity).
        Strings come back as arrays of ``str``, flags as ``bool``.  The checkpoint
        ``/lines`` is read by :func:`read_lines`.  Files of the first layout
        (no dimensions) are read as well.
    """
    out = {"attrs": {}, "runs": {}, "maps": {}, "branches": {}}
    with open_checked(path) as f:
        out["attrs"] = read_attrs(f)
        v2 = int(out["attrs"].get("vibeam_layout", 1)) >= 2
        for kind in ("runs", "maps", "branches"):
            for name, g in f.get(kind, {}).items():
                if kind == "branches":
                    run = read_branch_group(g)
                elif not v2:
                    run = read_plain(g)
                elif kind == "runs":
                    run = _flat_run(g)
                else:
                    run = _flat_map(g)
                run["attrs"] = dict(read_attrs(g), **run.pop("_coord_attrs", {}))
                out[kind][name] = run
    return out


def _dim_names(g) -> dict:
    """netCDF dimension id -> name of the dimension scales visible in ``g`` (own and parents')."""
    out = {}
    chain = [g]
    while chain[-1].name != "/":
        chain.append(chain[-1].parent)
    for grp in reversed(chain):          # inner groups shadow outer ones
        for k, d in grp.items():
            if isinstance(d, h5py.Dataset) and "_Netcdf4Dimid" in d.attrs and d.attrs.get("CLASS") == b"DIMENSION_SCALE":
                out[int(np.asarray(d.attrs["_Netcdf4Dimid"]).ravel()[0])] = k
    return out


def _dims(d, names: dict | None = None) -> tuple:
    """Dimension names of a dataset: from ``_Netcdf4Coordinates`` and the scales' ids
    (``names``: :func:`_dim_names` of its group), else from the attached scales."""
    if names is not None and "_Netcdf4Coordinates" in d.attrs:
        try:
            return tuple(names[int(i)] for i in np.asarray(d.attrs["_Netcdf4Coordinates"]).ravel())
        except KeyError:
            pass
    return tuple(dim[0].name.rsplit("/", 1)[-1] if len(dim) else "" for dim in d.dims)


def _flat_run(g) -> dict:
    """A run group of layout 2 back to the flat per-point table (visiting order)."""
    vals = {k: d for k, d in g.items() if isinstance(d, h5py.Dataset) and not is_dim_only(d)}
    names = _dim_names(g)
    dims = {k: _dims(d, names) for k, d in vals.items()}
    out = {}
    if "direction" in vals and dims["direction"] == ("point",):
        for k, d in vals.items():
            if dims[k][:1] == ("point",):
                out[str(d.attrs.get("vibeam_name", k))] = dataset_values(d)
        _restore_coords(out, vals, dims)
        return out
    dirs = [str(x) for x in dataset_values(vals["direction"])]
    n_f = vals["Omega"].shape[0]
    # visiting order: up along the grid, down against it
    flip = [d == "down" for d in dirs]

    def flat(a):
        parts = [a[i][::-1] if flip[i] else a[i] for i in range(len(dirs))]
        return np.concatenate(parts) if parts else a.reshape((0,) + a.shape[2:])

    for k, d in vals.items():
        if dims[k][:2] == ("direction", "Omega"):
            out[str(d.attrs.get("vibeam_name", k))] = flat(dataset_values(d))
    om = dataset_values(vals["Omega"])
    out["Omega"] = flat(np.broadcast_to(om, (len(dirs), n_f)))
    out["direction"] = flat(np.broadcast_to(np.array(dirs, dtype=object)[:, None], (len(dirs), n_f)))
    if "frequency_hz" in vals and dims["frequency_hz"] == ("Omega",):
        out["frequency_hz"] = flat(np.broadcast_to(dataset_values(vals["frequency_hz"]), (len(dirs), n_f)))
    if "time_series" in g:
        ts = {}
        for label, gl in g["time_series"].items():
            t = dataset_values(gl["time"]) if "time" in gl and not is_dim_only(gl["time"]) else None
            disp, vel, om_p = dataset_values(gl["displacement"]), dataset_values(gl["velocity"]), dataset_values(gl["point_Omega"])
            tt = dataset_values(gl["t"]) if "t" in gl else None
            item = {}
            for i, dname in enumerate(dirs):
                x = disp[i]
                keep = np.isfinite(x)
                if not keep.any():
                    continue
                n = int(np.flatnonzero(keep)[-1]) + 1
                ti = (t if tt is None else tt[i])[:n]
                item[dname] = np.column_stack([ti, x[:n], vel[i][:n]])
                item[dname + "_Omega"] = np.float64(om_p[i])
            ts[label] = item
        out["time_series"] = ts
    _restore_coords(out, vals, dims)
    return out


def _restore_coords(out: dict, vals: dict, dims: dict) -> None:
    """Coordinates that were run attributes (spectrum and noise axes) back into ``attrs``
    of the run dict (``out["_coord_attrs"]``, merged by the readers)."""
    extra = {}
    for dim, attr in ATTR_COORDS.items():
        if dim in vals and dims.get(dim) == (dim,):
            extra[attr] = np.asarray(dataset_values(vals[dim]), float)
        out.pop(dim, None)
    for dim in ("record_period", "state", "harmonic", "mode", "peak", "multiplier", "eigenvalue", "exponent",
                "point"):
        out.pop(dim, None)
    if extra:
        out["_coord_attrs"] = extra


def _flat_map(g) -> dict:
    """A map group of layout 2 back to the arrays (direction, value, frequency, ...)."""
    par = str(g.attrs.get("parameter", "value"))
    vals = {k: d for k, d in g.items() if isinstance(d, h5py.Dataset) and not is_dim_only(d)}
    names = _dim_names(g)
    dims = {k: _dims(d, names) for k, d in vals.items()}
    dirs = [str(x) for x in dataset_values(vals["direction"])]
    values = np.asarray(dataset_values(vals[par]), float)
    out = {"values": values, "direction": np.array(dirs, dtype=object)}
    per = [k for k in vals if dims[k][:2] == ("direction", par)]
    if not per:
        return out
    n_f = vals[per[0]].shape[2]
    shape = (len(dirs), len(values), n_f)
    for k in per:
        out[str(vals[k].attrs.get("vibeam_name", k))] = dataset_values(vals[k])
    for k in ("Omega", "frequency_hz"):
        if k in vals:
            a = np.asarray(dataset_values(vals[k]), float)
            out[k] = np.broadcast_to(a if a.ndim == 2 else a[None, :], shape[1:])[None].repeat(len(dirs), 0)
    _restore_coords(out, vals, dims)
    return out


# ============================================================================ results objects back
def load_results(path) -> tuple[list, list, dict]:
    """The runs and maps of a results file as :class:`vibeam.engine.sweep.SweepResult` and
    :class:`vibeam.analysis.maps.MapResult` (as a run returned them), and the root attributes.

    Dict attributes stored as JSON (``json_attrs``) and the spectrum and noise axes
    (stored as coordinates) are restored, so plots and tables work on them as on a
    fresh run.
    """
    res = read_results(path)
    order = _run_order(res["attrs"])
    for kind in ("runs", "maps"):             # the case's order (HDF5 lists groups by name)
        res[kind] = dict(sorted(res[kind].items(), key=lambda kv: order.get(kv[0], len(order))))
    runs, maps = [], []
    for kind, items in (("runs", res["runs"]), ("maps", res["maps"])):
        for name, d in items.items():
            d = dict(d)
            a = _decode_attrs(d.pop("attrs"))
            ts = d.pop("time_series", {})
            for label, item in ts.items():
                for k, v in item.items():
                    d[f"time_series/{label}/{k}"] = v
            common = dict(name=name, fidelity=str(a.pop("fidelity", "")), method=str(a.pop("method", "")),
                          settings=json.loads(a.pop("settings", "{}") or "{}"),
                          wall_time_s=float(a.pop("wall_time_s", 0.0)), data=d)
            if kind == "runs":
                runs.append(SweepResult(attrs=a, **common))
            else:
                maps.append(MapResult(parameter=str(a.get("parameter", "value")), attrs=a, **common))
    return runs, maps, res["attrs"]


def _run_order(attrs: dict) -> dict:
    """Run name -> position in the case of a results file (empty if its text does not parse)."""
    try:
        runs = tomllib.loads(str(attrs.get("case_text", ""))).get("run", [])
        return {r["name"]: i for i, r in enumerate(runs)}
    except Exception:
        return {}


def _decode_attrs(a: dict) -> dict:
    a = dict(a)
    for k in str(a.pop("json_attrs", "")).split():
        if k in a:
            try:
                a[k] = json.loads(a[k])
            except (TypeError, ValueError):
                pass
    for k, v in list(a.items()):
        if isinstance(v, np.generic):
            a[k] = v.item()
    return a

