"""Assessments (``[assess]`` of a case) and the ``sensor`` effect's identification.

:func:`hooks` returns the per-point assessment callables that the sweep applies
to each recorded :class:`vibeam.engine.records.Trajectory` (empty when the case asks
for none: nothing extra is computed or stored); :func:`collect` moves what is not
a per-point quantity (time series) out of the per-point table after a run;
:func:`finish` writes what needs the whole case (plots overlaying runs, the
identified-R-versus-noise table).

Per-point outputs (HDF5 ``/runs/<run>/``):

``[assess] spectra = true``
    ``peaks_frequency`` (n, P: Hz for physical scenes, Omega units otherwise; NaN-padded),
    ``peaks_displacement`` (mm), ``peaks_velocity`` (mm/s): the P largest peaks of the
    Hann-windowed spectrum of the sensor velocity that are neither harmonics nor
    subharmonics ``k/n Omega`` (``n <= subharmonic_order``) of the forcing;
    ``peaks_mode`` (1-based index of the nearest mode within ``mode_tolerance``, 0 none)
    and ``peaks_family`` (1 free mode, 2 contact mode (beam held at the stop), 0 none);
    ``spectrum_velocity`` (n, 400): the velocity spectrum max-pooled on the fixed axis of
    the run attribute ``spectrum_frequency``; ``hfc_*`` (beam fidelity, event method):
    the high-frequency component of the sensor signal, i.e. the part carried by modes
    ``>= 2`` (``sum_{i>=2} s_i eta_i``): ``hfc_velocity_mm_s`` (mean over impacts of the
    peak velocity after the impact, the paper's "mean peak velocity amplitude"),
    ``hfc_displacement_mm`` (the same for the displacement), ``hfc_frequency`` (its
    dominant spectral line) and ``band_velocity_mm_s`` (largest line of the total sensor
    velocity in ``hfc_band``: what the rig's spectrum shows near 100 Hz).
``[assess] participation = true``
    ``participation_displacement`` (n, N): RMS of ``s_i eta_i`` over the record over the
    sum of those RMS; ``participation_energy`` (n, N): mean modal energy
    ``(eta_i-dot^2 + omega_i^2 eta_i^2) / 2`` over its sum.  Both sum to 1.
``[assess] time_series = [f, ...]``
    ``time_series/<label>/<direction>`` (m, 3) in the run's data: time, displacement, velocity
    of the last
    ``time_series_periods`` recorded periods at the grid point nearest to ``f``; ``<label>`` is
    that grid point's frequency (:func:`ts_label`), never a requested value off the grid
    (a request outside the grid, or two on one grid point, is a case error:
    :func:`vibeam.case.schema.check_time_series`); stored as the group ``time_series/<label>``
    (:mod:`vibeam.io.results`).
``[effects.sensor]``
    see :class:`vibeam.engine.sensor.SensorHook`.
"""
from __future__ import annotations

import math
from pathlib import Path

import matplotlib
import numpy as np
from matplotlib.patches import Patch
from matplotlib.ticker import FixedLocator, LogLocator, NullFormatter, NullLocator

from vibeam.engine.sensor import DEFAULT_LADDER_MM, SensorHook, required_samples_per_period
from vibeam.errors import CaseError
from vibeam.io.outdir import replace_file
from vibeam.models.registry import fidelity
from vibeam.models.scene import held_modes, outputs
from vibeam.plots import style
from vibeam.plots.lazy import plt
from vibeam.plots.style import cell_edges, colours, label, run_names
from vibeam.plots.sweep import save_close

N_MAP = 400                      # bins of the stored spectrum map
TS_MAX_PER_PERIOD = 256          # time series: at most this many samples per period


# ============================================================================ helpers
def _scales(scene):
    """(f_ref in Hz or None, L in m or None, physical?) of a scene (:func:`vibeam.models.scene.outputs`)."""
    o = outputs(scene)
    fn, L = o.natural_frequency_hz, o.length_m
    return fn, L, bool(fn and L)


def _units(scene):
    """Frequency unit factor (Omega -> output), displacement and velocity factors."""
    fn, L, phys = _scales(scene)
    if phys:
        return fn, L * 1e3, L * 1e3 * 2 * math.pi * fn
    return 1.0, 1.0, 1.0


def _caps(spec):
    """The fidelity registry's entry of a model spec (capabilities, :mod:`vibeam.models.registry`)."""
    return fidelity(spec)


def _mode_freqs(scene):
    """Free and contact modal frequencies in output units, shapes (n,) and (n - 1,): the
    system's ``omega`` and those of the system held on its first contact row (the attached
    mass; :func:`vibeam.models.scene.held_modes`).  The one-mode oscillator gives its natural
    frequency and no contact mode."""
    fu, _, _ = _units(scene)
    s = scene.system
    om = np.asarray(s.omega, float)
    _, nu2 = held_modes(np.asarray(s.contacts, float)[0], np.diag(om ** 2))
    return om * fu, np.sqrt(np.maximum(nu2, 0.0)) * fu


def hann_spectrum(y, fs):
    """Single-sided amplitude spectrum of ``y`` with a Hann window.

    Returns ``(f, A)`` with ``A`` scaled so that a sinusoid of amplitude ``a`` centred on a
    bin reads ``a`` (divide by the window's coherent gain ``sum(w)/2``)."""
    n = y.size
    w = np.hanning(n + 1)[:-1]        # periodic Hann: harmonics on bins leak into 3 bins only
    X = np.fft.rfft((y - y.mean()) * w)
    return np.fft.rfftfreq(n, 1.0 / fs), 2.0 * np.abs(X) / w.sum()


def interpolate_peak(A, k):
    """Frequency offset (bins) and amplitude of a Hann-windowed sinusoid from bins k-1, k, k+1.

    With ``alpha`` the larger neighbour over the peak bin, the offset is
    ``delta = (2 alpha - 1) / (alpha + 1)`` and the amplitude ``A_k / |W(delta)|``,
    ``W(d) = sinc(d) / (1 - d^2)`` (Hann kernel, ``W(0) = 1``)."""
    if k <= 0 or k >= A.size - 1:
        return 0.0, A[k]
    l, c, r = A[k - 1], A[k], A[k + 1]
    if c <= 0:
        return 0.0, c
    if r >= l:
        a = r / c
        d = (2 * a - 1) / (a + 1)
    else:
        a = l / c
        d = -(2 * a - 1) / (a + 1)
    d = float(np.clip(d, -0.5, 0.5))
    W = np.sinc(d) / (1 - d * d) if abs(d) < 1 else 0.5
    return d, c / W


def is_harmonic(f, f_force, max_order=8, tol=0.0):
    """True if ``f`` lies within ``tol`` of ``k/n f_force`` for some ``n <= max_order``."""
    for n in range(1, max_order + 1):
        k = round(f * n / f_force)
        if abs(f - k * f_force / n) <= tol:
            return True
    return False


def nonharmonic_peaks(x, v, fs, f_force, n_peaks=5, max_order=8, rel_floor=1e-4):
    """Largest peaks of the velocity spectrum that are not (sub)harmonics of ``f_force``.

    A peak is a local maximum over +-2 bins, above ``rel_floor`` times the spectrum's
    maximum and above the spectrum 4 bins away on both sides (Hann side lobes of nearby
    lines fail this); it is a (sub)harmonic when its interpolated frequency lies within
    0.3 bins of ``k/n f_force``.  Returns (freq, displacement amp, velocity amp), each
    (n_peaks,), NaN-padded, sorted by decreasing velocity amplitude.
    """
    f, Av = hann_spectrum(v, fs)
    _, Ax = hann_spectrum(x, fs)
    df = f[1] - f[0]
    top = Av.max() if Av.size else 0.0
    cand = []
    for k in range(4, Av.size - 4):
        a = Av[k]
        if a <= rel_floor * top or a < Av[k - 2:k + 3].max():
            continue
        if not (a > Av[k - 4] and a > Av[k + 4]):
            continue
        d, amp = interpolate_peak(Av, k)
        fk = (k + d) * df
        if is_harmonic(fk, f_force, max_order, 0.3 * df):
            continue
        _, ampx = interpolate_peak(Ax, k)
        cand.append((amp, fk, ampx))
    cand.sort(reverse=True)
    out = np.full((3, n_peaks), np.nan)
    for i, (amp, fk, ampx) in enumerate(cand[:n_peaks]):
        out[:, i] = fk, ampx, amp
    return out[0], out[1], out[2]


def assign_modes(freqs, free, contact, rtol):
    """Nearest modal frequency within ``rtol`` (relative): (mode index 1-based, family)."""
    idx = np.zeros(len(freqs), dtype=np.int64)
    fam = np.zeros(len(freqs), dtype=np.int64)
    for i, fp in enumerate(freqs):
        if not np.isfinite(fp):
            continue
        best = (np.inf, 0, 0)
        for family, fs in ((1, free), (2, contact)):
            for j, fm in enumerate(fs):
                e = abs(fp - fm) / fm
                if e < best[0]:
                    best = (e, j + 1, family)
        if best[0] <= rtol:
            idx[i], fam[i] = best[1], best[2]
    return idx, fam


def participation_shares(modal_states, sensor_row, k_nd):
    """Shares of each mode in the sensor displacement and in the energy.

    ``modal_states`` (m, 2N) of ``(eta, eta')`` at the samples (nondimensional time);
    displacement share ``rms(s_i eta_i) / sum_j rms(s_j eta_j)``, energy share
    ``mean(eta_i'^2 + k_i eta_i^2) / sum`` (``k_i = (omega_i / omega_ref)^2``; the common
    factor ``omega_ref^2 / 2`` cancels)."""
    N = sensor_row.size
    eta, etad = modal_states[:, :N], modal_states[:, N:2 * N]
    rms = np.sqrt(np.mean((eta * sensor_row) ** 2, axis=0))
    en = np.mean(etad ** 2 + k_nd * eta ** 2, axis=0)
    sd = rms.sum()
    se = en.sum()
    return (rms / sd if sd > 0 else np.full(N, np.nan)), (en / se if se > 0 else np.full(N, np.nan))


def ts_label(x: float) -> str:
    """Label (group and file name part) of a time series at the grid frequency ``x``."""
    return f"{float(x):.10g}"


def not_applicable(case, run, spec, time_domain: bool = True) -> list[str]:
    """Messages for the ``[assess]`` items a run asks for that do not apply to it (one line
    each; the runner prints them once and those items are not computed for the run); ``spec``
    is the run's model spec (its fidelity's capabilities)."""
    a = case.assess
    out = []
    what = f"run '{run.name}' ({_caps(spec).name}, {run.method})"
    if not time_domain:
        for k in ("spectra", "participation", "time_series"):
            if getattr(a, k):
                out.append(f"[assess] {k} does not apply to {what}: the method computes no time history")
        return out
    if a.participation and not _participation_applies(spec, run.method):
        caps = _caps(spec)
        ms = caps.modal_state_methods
        why = ("a single degree of freedom has no modes to share" if not caps.modes else
               f"only the {caps.name}'s {' and '.join(ms) or 'no'} method{'s' if len(ms) > 1 else ''} "
               f"record{'' if len(ms) > 1 else 's'} the modal states")
        out.append(f"[assess] participation does not apply to {what}: {why}")
    return out


def _participation_applies(spec, method) -> bool:
    caps = _caps(spec)
    return caps.modes and method in caps.modal_state_methods


# ============================================================================ hooks
class SpectraHook:
    """Per-point spectra, non-harmonic peaks and the high-frequency component (picklable)."""

    def __init__(self, assess, scene, modes: bool):
        self.a = assess
        self.fu, self.xu, self.vu = _units(scene)
        self.free, self.contact = _mode_freqs(scene)
        fn, L, phys = _scales(scene)
        self.phys = phys
        self.fmax = assess.spectrum_max or (250.0 if phys else 30.0)
        band = assess.hfc_band or ((50.0, 500.0) if phys else (6.0, 60.0))
        self.band = (float(band[0]), float(band[1]))
        self.beam = bool(modes)   # the high-frequency component needs modes
        self.sensor_row = np.asarray(scene.system.sensor, float)
        self.L = L or 1.0

    def __call__(self, traj) -> dict:
        P = self.a.peaks
        nan = float("nan")
        out = dict(peaks_frequency=np.full(P, nan), peaks_displacement=np.full(P, nan),
                   peaks_velocity=np.full(P, nan), peaks_mode=np.zeros(P, np.int64),
                   peaks_family=np.zeros(P, np.int64), spectrum_velocity=np.full(N_MAP, nan),
                   band_velocity_mm_s=nan, band_frequency=nan)
        if self.beam:
            out.update(hfc_velocity_mm_s=nan, hfc_displacement_mm=nan, hfc_frequency=nan)
        if traj.status == "failed" or not np.isfinite(traj.samples).all():
            return out
        f_force = traj.Omega * self.fu
        fs = f_force * traj.samples_per_period
        x = traj.samples[:, 0] * self.xu
        v = traj.samples[:, 1] * self.vu
        pf, px, pv = nonharmonic_peaks(x, v, fs, f_force, P, self.a.subharmonic_order)
        idx, fam = assign_modes(pf, self.free, self.contact, self.a.mode_tolerance)
        out.update(peaks_frequency=pf, peaks_displacement=px, peaks_velocity=pv, peaks_mode=idx,
                   peaks_family=fam)
        f, Av = hann_spectrum(v, fs)
        edges = np.linspace(0.0, self.fmax, N_MAP + 1)
        b = np.searchsorted(edges, f, side="right") - 1
        ok = (b >= 0) & (b < N_MAP)
        m = np.full(N_MAP, nan)
        np.fmax.at(m, b[ok], Av[ok])
        m[edges[1:] > fs / 2] = nan
        out["spectrum_velocity"] = m
        inb = (f >= self.band[0]) & (f <= self.band[1])
        if inb.any():
            k = int(np.nonzero(inb)[0][np.argmax(Av[inb])])
            d, amp = interpolate_peak(Av, k)
            out.update(band_velocity_mm_s=float(amp), band_frequency=float((k + d) * (f[1] - f[0])))
        ms = traj.extra.get("modal_states")
        if self.beam and ms is not None and ms.shape[0] == traj.samples.shape[0]:
            N = self.sensor_row.size
            if N >= 2:
                xh = ms[:, 1:N] @ self.sensor_row[1:] / self.L * self.xu
                vh = ms[:, N + 1:2 * N] @ self.sensor_row[1:] / self.L * self.vu
                spp = traj.samples_per_period
                # impact positions in samples; the peak after each impact until the next one
                it = np.asarray(traj.impact_times, float) * traj.Omega / (2 * math.pi) * spp
                starts = np.unique(np.ceil(it).astype(int))
                starts = starts[(starts >= 0) & (starts < vh.size)]
                if starts.size:
                    ends = np.append(starts[1:], vh.size)
                    pv_ = [np.abs(vh[s:e]).max() for s, e in zip(starts, ends) if e > s]
                    px_ = [np.abs(xh[s:e]).max() for s, e in zip(starts, ends) if e > s]
                    out["hfc_velocity_mm_s"] = float(np.mean(pv_))
                    out["hfc_displacement_mm"] = float(np.mean(px_))
                else:
                    out["hfc_velocity_mm_s"] = float(np.abs(vh).max())
                    out["hfc_displacement_mm"] = float(np.abs(xh).max())
                fh, Ah = hann_spectrum(vh, fs)
                sel = fh > 1.5 * self.free[0]
                if sel.any() and Ah[sel].max() > 0:
                    k = int(np.nonzero(sel)[0][np.argmax(Ah[sel])])
                    d, _ = interpolate_peak(Ah, k)
                    out["hfc_frequency"] = float((k + d) * (fh[1] - fh[0]))
            else:
                out.update(hfc_velocity_mm_s=0.0, hfc_displacement_mm=0.0)
        return out


class ParticipationHook:
    """Per-point modal shares in the sensor displacement and the energy (picklable)."""

    def __init__(self, scene):
        s = scene.system
        self.N = int(s.omega.size)
        self.sensor_row = np.asarray(s.sensor, float)
        self.k_nd = np.asarray(s.omega, float) ** 2

    def __call__(self, traj) -> dict:
        ms = traj.extra.get("modal_states")
        if ms is None or traj.status == "failed" or ms.shape[1] != 2 * self.N:
            nan = np.full(self.N, np.nan)
            return dict(participation_displacement=nan, participation_energy=nan.copy())
        d, e = participation_shares(ms, self.sensor_row, self.k_nd)
        return dict(participation_displacement=d, participation_energy=e)


class TimeSeriesHook:
    """Keeps the last periods of the grid points nearest to the requested frequencies (picklable)."""

    def __init__(self, targets, grid, scene, periods):
        self.fu, self.xu, self.vu = _units(scene)
        grid = np.asarray(grid, float)
        self.keep = []
        for i, f in enumerate(targets):
            W = grid[int(np.argmin(np.abs(grid * self.fu - f)))]
            self.keep.append((i, float(W)))
        self.periods = int(periods)

    def __call__(self, traj) -> dict:
        out = {}
        for i, W in self.keep:
            if not np.isclose(traj.Omega, W, rtol=1e-12, atol=0):
                continue
            spp = traj.samples_per_period
            P = min(self.periods, traj.n_record)
            step = max(1, int(math.ceil(spp / TS_MAX_PER_PERIOD)))
            s = traj.samples[-P * spp:][::step]
            T = 2 * math.pi / traj.Omega / (2 * math.pi * self.fu) if self.fu != 1.0 else 2 * math.pi / traj.Omega
            t = np.arange(s.shape[0]) * (T * step / spp)
            out[f"_ts_{i}"] = np.column_stack([t, s[:, 0] * self.xu, s[:, 1] * self.vu])
        return out


def _sensor_hook(case, run, scene):
    eff = case.effects_for(run)
    sp = eff.sensor
    fn, L, phys = _scales(scene)
    if not phys:
        raise CaseError(f"run '{run.name}': [effects.sensor] needs a physical scene (frequency_hz, "
                        f"length_mm), the sensor samples in Hz and its noise is in mm")
    vf = 1.0 / float(outputs(scene).phi_contact)    # the kernel's contact velocity -> the sensor's
    return SensorHook(sp, fn, L, scene.stops[0].law, eff.restitution_law, velocity_factor=vf)


def hooks(case, spec, run, scene) -> tuple:
    """Per-point assessment callables for one run (empty: nothing extra is computed): its
    model ``spec`` (the fidelity's capabilities) and ``scene`` (units, modes, rows, stops)."""
    a = case.assess
    out = []
    if a.spectra:
        out.append(SpectraHook(a, scene, _caps(spec).modes))
    if a.participation and _participation_applies(spec, run.method):
        out.append(ParticipationHook(scene))
    if a.time_series:
        grid = case.sweep.grid(outputs(scene).natural_frequency_hz)
        out.append(TimeSeriesHook(a.time_series, grid, scene, a.time_series_periods))
    sp = case.effects_for(run).sensor
    if sp is not None and sp.identify_R:
        out.append(_sensor_hook(case, run, scene))
    if solver_options(case, run, spec):
        out.append(_drop_modal_states)   # recorded for the hooks only: not stored per point
    return tuple(out)


def _drop_modal_states(traj) -> dict:
    """Last hook: the modal states asked for by the assessments are not a per-point output."""
    return {"modal_states": None}


def samples_per_period(case, run, scene, Omega) -> int:
    """Recorded samples per period the run needs (the sweep's unless the sensor needs more)."""
    n = case.sweep.samples_per_period
    sp = case.effects_for(run).sensor
    fn = outputs(scene).natural_frequency_hz
    if sp is not None and fn:
        n = max(n, required_samples_per_period(sp.sampling_hz, float(np.min(Omega)) * fn, sp.oversample))
    return n


def solver_options(case, run, spec) -> dict:
    """Extra solver settings the assessments need (modal states of the beam event solver);
    ``spec``: the run's model spec or its fidelity's name."""
    a = case.assess
    if (a.spectra or a.participation) and run.method in _caps(spec).modal_state_methods:
        return {"record_modal_states": True}
    return {}


def solver_effects(effects):
    """The run's effects that act on the solver: the sensor is a post-processing effect."""
    if getattr(effects, "sensor", None) is None:
        return effects
    return effects.model_copy(update={"sensor": None})


def collect(case, run, res) -> None:
    """After a run: move time series out of the per-point table into ``time_series/...``
    datasets, add the axes of the per-point assessments as run attributes."""
    a = case.assess
    d = res.data
    if solver_options(case, run, res.fidelity):
        d.pop("modal_states", None)
    for i, f in enumerate(a.time_series):
        key = f"_ts_{i}"
        arr = d.pop(key, None)
        if arr is None:
            continue
        for j in range(arr.shape[0]):
            if np.isfinite(arr[j]).all():
                label = ts_label(d["frequency_hz"][j] if "frequency_hz" in d else d["Omega"][j])
                dname = str(d["direction"][j]) if "direction" in d else "up"
                d[f"time_series/{label}/{dname}"] = arr[j]
                d[f"time_series/{label}/{dname}_Omega"] = np.float64(d["Omega"][j])
    if a.spectra:
        fmax = a.spectrum_max or (250.0 if "frequency_hz" in d else 30.0)
        e = np.linspace(0, fmax, N_MAP + 1)
        res.attrs["spectrum_frequency"] = 0.5 * (e[1:] + e[:-1])
        res.attrs["peaks_family_codes"] = "0 none, 1 free mode, 2 contact mode"
    sp = case.effects_for(run).sensor
    if sp is not None and sp.identify_R:
        res.attrs["noise_ladder_mm"] = np.asarray(sp.noise_ladder_mm if sp.noise_ladder_mm is not None
                                                  else DEFAULT_LADDER_MM, float)
        res.attrs["sensor"] = sp.model_dump()


# ============================================================================ finish
#: the files :func:`finish` may write (:func:`vibeam.io.outdir.check_outputs` patterns)
OUTPUT_NAMES = ("spectra.png", "participation.png", "time_series_*.png", "sensor_R_vs_noise.csv",
                "sensor_R_vs_noise.png")


def finish(case, runs, out_dir) -> list:
    """Case-level assessment outputs (plots, tables); returns the written paths."""
    out_dir = Path(out_dir)
    paths = []
    a = case.assess
    col = colours(run_names(case, runs))
    if a.spectra:
        p = plot_spectra(runs, out_dir / "spectra.png", case.name, case)
        if p:
            paths.append(p)
        print_hfc(runs)
    if a.participation:
        p = plot_participation(runs, out_dir / "participation.png", case.name, case)
        if p:
            paths.append(p)
    labels = []
    for r in runs:
        for k in r.data:
            if k.startswith("time_series/") and k.count("/") == 2 and not k.endswith("_Omega"):
                lab = k.split("/")[1]
                if lab not in labels:
                    labels.append(lab)
    for lab in labels:
        p = plot_time_series(runs, lab, out_dir / f"time_series_{lab}.png", case.name, case, col)
        if p:
            paths.append(p)
    if any("R_identified_ladder" in r.data for r in runs):
        rows = sensor_table(runs)
        print_sensor_table(rows)
        csv = out_dir / "sensor_R_vs_noise.csv"

        replace_file(csv, "run,noise_mm,points,identified,median_abs_error,max_abs_error,rms_error,"
                     "mean_R_identified,mean_R_model,mean_R_sensor_exact\n"
                     + "".join(",".join(str(x) for x in r) + "\n" for r in rows))
        paths.append(csv)
        p = plot_sensor(rows, out_dir / "sensor_R_vs_noise.png", case.name, case, col, runs)
        if p:
            paths.append(p)
    if paths:
        print("assessments: " + ", ".join(str(p) for p in paths))
    return paths


def _x(r):
    d = r.data
    return ((np.asarray(d["frequency_hz"], float), label("forcing frequency f", "Hz")) if "frequency_hz" in d
            else (np.asarray(d["Omega"], float), label(r"forcing frequency $\Omega = f/f_n$", None)))


def _plt():
    matplotlib.use("Agg")
    return plt


def sensor_table(runs):
    """Rows (run, noise, points, identified, median |dR|, max |dR|, rms dR) over period-1
    points (all points when none is period-1)."""
    rows = []
    for r in runs:
        d = r.data
        if "R_identified_ladder" not in d:
            continue
        lad = np.asarray(r.attrs.get("noise_ladder_mm", []), float)
        per = np.asarray(d.get("period", np.ones(r.n_points)))
        sel = per == 1
        if not sel.any():
            sel = np.ones(r.n_points, bool)
        Rse = np.asarray(d.get("R_sensor_exact", np.full(r.n_points, np.nan)))[sel]
        Rse = float(np.nanmean(Rse)) if np.isfinite(Rse).any() else np.nan
        Rid = d["R_identified_ladder"][sel]
        Rtr = d["R_true_ladder"][sel]
        for j, s in enumerate(lad):
            err = Rid[:, j] - Rtr[:, j]
            ok = np.isfinite(err)
            e = np.abs(err[ok])
            rows.append((r.name, float(s), int(sel.sum()), int(ok.sum()),
                         float(np.median(e)) if e.size else np.nan, float(e.max()) if e.size else np.nan,
                         float(np.sqrt(np.mean(e**2))) if e.size else np.nan,
                         float(np.nanmean(Rid[:, j])) if ok.any() else np.nan,
                         float(np.nanmean(Rtr[:, j])) if ok.any() else np.nan, Rse))
    return rows


def print_sensor_table(rows):
    print("\nCoR identified from the simulated sensor (Sec. 5.1 method) against the model's R")
    print("(period-1 points; R at sensor: -v+/v- of the exact sensor velocity at the impact)")
    w = max([30] + [len(r[0]) + 2 for r in rows])        # as wide as the longest run name
    head = (f"{'run':<{w}}{'noise (mm)':>11}{'points':>7}{'found':>6}{'median|dR|':>11}{'max|dR|':>9}"
            f"{'rms dR':>9}{'mean R_id':>10}{'R model':>8}{'R at sensor':>12}")
    print(head)
    print("-" * len(head))
    for name, s, n, k, med, mx, rms, rid, rtr, rse in rows:
        print(f"{name:<{w}}{s:>11.4g}{n:>7}{k:>6}{med:>11.4g}{mx:>9.4g}{rms:>9.4g}{rid:>10.4g}{rtr:>8.4g}"
              f"{rse:>12.4g}")


def sensor_figure(rows, title="", case=None, colours=None, runs=()):
    """Error of the identified R against the sensor noise, per run (median and max over the
    period-1 points; the noise-free error as a marker at the left edge); a Figure, or None
    when no row has a finite error."""
    plt = _plt()
    names = list(dict.fromkeys(r[0] for r in rows))
    col = colours or style.colours(style.run_names(case) + names)
    with style.context():
        fig, ax = plt.subplots(figsize=(7.5, 4.2))
        handles = []
        drawn = False
        for nm in names:
            rr = [r for r in rows if r[0] == nm]
            s = np.array([r[1] for r in rr], float)
            med = np.array([r[4] for r in rr], float)
            mx = np.array([r[5] for r in rr], float)
            c = col.get(nm, "0.3")
            pos = (s > 0) & np.isfinite(med)
            if pos.any():
                ax.plot(s[pos], med[pos], "o-", color=c)
                ax.plot(s[pos], mx[pos], "^--", color=c, mfc="none")
                handles.append(style.proxy(c, ls="-", marker="o", label=f"{nm}"))
                drawn = True
            zero = (s == 0) & np.isfinite(med) & (med > 0)
            if zero.any():
                ax.axhline(med[zero][0], color=c, lw=0.8, ls=":")
                drawn = True
        if not drawn:
            plt.close(fig)
            return None
        ax.set_xscale("log")
        ax.set_yscale("log")

        # ticks at the noise levels of the ladder (labelled once each, no minor labels)
        levels = sorted({float(r[1]) for r in rows if float(r[1]) > 0})
        ax.xaxis.set_major_locator(FixedLocator(levels))
        ax.xaxis.set_major_formatter(plt.FuncFormatter(lambda v, _: f"{v:g}"))
        ax.xaxis.set_minor_locator(NullLocator())
        ax.yaxis.set_major_locator(LogLocator(base=10, numticks=8))
        ax.yaxis.set_minor_formatter(NullFormatter())
        ax.set_xlabel(style.label("sensor noise, standard deviation", "mm"))
        ax.set_ylabel(style.label(r"error of the identified CoR $|R_{id} - R|$", None))
        handles += [style.proxy("0.25", ls="-", marker="o", label="median over period-1 points"),
                    style.proxy("0.25", ls="--", marker="^", fill=False, label="largest"),
                    style.proxy("0.25", ls=":", label="noise-free median")]
        style.legend_outside(fig, handles)
        style.titles(fig, (title + ": " if title else "") + "CoR identified from the sensor (Sec. 5.1) vs noise",
                     style.subtitle(case, runs=runs))
    return fig


def plot_sensor(rows, path, title="", case=None, colours=None, runs=()):
    """:func:`sensor_figure` saved to ``path`` (``sensor_R_vs_noise.png``); None if empty."""
    return save_close(sensor_figure(rows, title, case, colours, runs), path)


def spectra_figure(runs, title="", case=None):
    """Per run: velocity spectrum (colour, log10 of mm/s) against the forcing frequency
    (up branch), non-harmonic peaks as circles; a Figure, or None without spectra."""
    plt = _plt()
    runs = [r for r in runs if "spectrum_velocity" in r.data]
    if not runs:
        return None
    with style.context():
        fig, axes = plt.subplots(len(runs), 1, figsize=(8.0, 2.7 * len(runs) + 1.0), squeeze=False, sharex=True)
        for ax, r in zip(axes[:, 0], runs):
            d = r.data
            x, xl = _x(r)
            phys = "frequency_hz" in d
            up = np.array([str(s) != "down" for s in d.get("direction", ["up"] * r.n_points)])
            if not up.any():
                up[:] = True
            o = np.argsort(x[up])
            xs = x[up][o]
            S = d["spectrum_velocity"][up][o]
            fy = np.asarray(r.attrs.get("spectrum_frequency"), float)
            with np.errstate(divide="ignore", invalid="ignore"):
                Z = np.log10(np.where(S > 0, S, np.nan)).T

            top = np.nanmax(Z) if np.isfinite(Z).any() else 0.0
            im = ax.pcolormesh(cell_edges(xs), cell_edges(fy), Z, cmap="viridis", vmin=top - 4, vmax=top)
            fig.colorbar(im, ax=ax, label=style.label(r"velocity amplitude, $\log_{10}$", "mm/s" if phys else None))
            pf = d["peaks_frequency"][up][o]
            xx = np.repeat(xs[:, None], pf.shape[1], axis=1)
            ax.plot(xx.ravel(), pf.ravel(), ls="none", marker="o", mfc="none", mec="#D55E00", ms=4)
            ax.set_ylabel(style.label("frequency", "Hz") if phys else style.label("frequency / $f_n$", None))
            ax.set_title(f"{r.name}: sensor velocity spectrum (up branch)", loc="left")
            ax.set_ylim(0, fy[-1] if fy.size else None)
            ax.grid(False)
        axes[-1, 0].set_xlabel(xl)
        style.legend_outside(fig, [style.proxy("#D55E00", marker="o", fill=False, label="non-harmonic peaks")],
                             loc="outside lower center")
        style.titles(fig, title, style.subtitle(case, runs=runs))
    return fig


def plot_spectra(runs, path, title="", case=None):
    """:func:`spectra_figure` saved to ``path`` (``spectra.png``)."""
    return save_close(spectra_figure(runs, title, case), path)


def print_hfc(runs):
    """Table of the high-frequency component per run (ranges over the points)."""
    rows = [r for r in runs if "band_velocity_mm_s" in r.data]
    if not rows:
        return
    print("\nhigh-frequency component at the sensor (min .. max over the points)")
    phys = all("frequency_hz" in r.data for r in rows)
    hz, v, x = (" (Hz)", " (mm/s)", " (mm)") if phys else (" (/f_n)", "", "")
    w = max([26] + [len(r.name) + 2 for r in rows])      # as wide as the longest run name
    head = (f"{'run':<{w}}{'band line' + hz:>16}{'band line' + v:>18}{'HFC f' + hz:>14}"
            f"{'HFC peak v' + v:>19}{'HFC peak x' + x:>17}{'peaks':>7}")
    print(head)
    print("-" * len(head))

    def rng(a, fmt):
        a = np.asarray(a, float)
        a = a[np.isfinite(a)]
        return "-" if not a.size else (f"{a.min():{fmt}}" if np.isclose(a.min(), a.max()) else
                                       f"{a.min():{fmt}}..{a.max():{fmt}}")
    for r in rows:
        d = r.data
        npk = int(np.isfinite(d["peaks_frequency"]).sum())
        print(f"{r.name:<{w}}{rng(d['band_frequency'], '.1f'):>16}{rng(d['band_velocity_mm_s'], '.2f'):>18}"
              f"{rng(d.get('hfc_frequency', []), '.1f'):>14}{rng(d.get('hfc_velocity_mm_s', []), '.2f'):>19}"
              f"{rng(d.get('hfc_displacement_mm', []), '.4f'):>17}{npk:>7}")


def participation_figure(runs, title="", case=None):
    """Stacked shares of the modes against the forcing frequency (up branch), per run; a
    Figure, or None when no run has more than one mode."""
    plt = _plt()
    runs = [r for r in runs if "participation_displacement" in r.data
            and r.data["participation_displacement"].shape[1] > 1]
    if not runs:
        return None
    with style.context():
        fig, axes = plt.subplots(len(runs), 2, figsize=(10, 2.6 * len(runs) + 1.0), squeeze=False)
        n_max = max(r.data["participation_displacement"].shape[1] for r in runs)
        for (a1, a2), r in zip(axes, runs):
            d = r.data
            x, xl = _x(r)
            up = np.array([str(s) != "down" for s in d.get("direction", ["up"] * r.n_points)])
            if not up.any():
                up[:] = True
            o = np.argsort(x[up])
            for ax, key, lab in ((a1, "participation_displacement", "share of the sensor displacement (RMS)"),
                                 (a2, "participation_energy", "share of the modal energy")):
                P = np.nan_to_num(d[key][up][o])
                ax.stackplot(x[up][o], P.T, colors=[style.PALETTE[i % len(style.PALETTE)] for i in range(P.shape[1])])
                ax.set_ylim(0, 1)
                ax.set_title(f"{r.name}" if ax is a1 else "", loc="left")
                ax.set_xlabel(xl)
                ax.set_ylabel(style.label(lab, None))
                hi = 1.0 - P[:, 0]
                ax.text(0.03, 0.06, f"modes >= 2: {hi.min():.2e} .. {hi.max():.2e}", transform=ax.transAxes,
                        fontsize=7, bbox=dict(facecolor="w", alpha=0.8, lw=0))

        style.legend_outside(fig, [Patch(facecolor=style.PALETTE[i % len(style.PALETTE)], label=f"mode {i + 1}")
                                   for i in range(n_max)])
        style.titles(fig, title, style.subtitle(case, runs=runs))
    return fig


def plot_participation(runs, path, title="", case=None):
    """:func:`participation_figure` saved to ``path`` (``participation.png``); None if nothing."""
    return save_close(participation_figure(runs, title, case), path)


def time_series_figure(runs, label, title="", case=None, colours=None):
    """Time series (displacement, velocity; last two periods) and phase portrait of every run
    at the grid frequency ``label`` (:func:`ts_label`); a Figure, or None."""
    plt = _plt()
    label = label if isinstance(label, str) else ts_label(label)
    items = []
    for r in runs:
        for dname in ("up", "down"):
            k = f"time_series/{label}/{dname}"
            if k in r.data:
                items.append((r, dname, r.data[k], float(r.data[k + "_Omega"])))
    if not items:
        return None
    phys = "frequency_hz" in runs[0].data
    col = colours or style.colours(style.run_names(case, runs))
    with style.context():
        fig, axes = plt.subplots(1, 3, figsize=(12, 3.6))
        handles = []
        for r, dname, a, W in items:
            fn = r.attrs.get("natural_frequency_hz", 1.0) if phys else 1.0
            T = 1.0 / (W * fn) if phys else 2 * math.pi / W
            z = a[:, 0] >= a[-1, 0] - 2 * T          # time panels: the last two periods
            c = col.get(r.name, "0.3")
            ls = style.DIRECTIONS[dname]["ls"]
            axes[0].plot(a[z, 0], a[z, 1], color=c, ls=ls, lw=0.9)
            axes[1].plot(a[z, 0], a[z, 2], color=c, ls=ls, lw=0.9)
            axes[2].plot(a[:, 1], a[:, 2], color=c, ls=ls, lw=0.7)
            handles.append(style.proxy(c, ls=ls, label=f"{r.name} ({dname} sweep)"))
        tu = "s" if phys else None
        xu, vu = ("mm", "mm/s") if phys else (None, None)
        axes[0].set_xlabel(style.label("time t", tu))
        axes[0].set_ylabel(style.label(style.DISPLACEMENT if phys else "$q$", xu))
        axes[1].set_xlabel(style.label("time t", tu))
        axes[1].set_ylabel(style.label(style.VELOCITY if phys else r"$\dot q$", vu))
        axes[2].set_xlabel(style.label(style.DISPLACEMENT if phys else "$q$", xu))
        axes[2].set_ylabel(style.label(style.VELOCITY if phys else r"$\dot q$", vu))
        axes[0].set_title("displacement (last 2 periods)", loc="left")
        axes[1].set_title("velocity (last 2 periods)", loc="left")
        axes[2].set_title("phase portrait (all stored periods)", loc="left")
        style.legend_outside(fig, handles)
        style.titles(fig, f"{title + ': ' if title else ''}{label}{' Hz' if phys else ''}",
                     style.subtitle(case, runs=[r for r, *_ in items]))
    return fig


def plot_time_series(runs, label, path, title="", case=None, colours=None):
    """:func:`time_series_figure` saved to ``path`` (``time_series_<label>.png``); None if none."""
    return save_close(time_series_figure(runs, label, title, case, colours), path)
