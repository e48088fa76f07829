"""Frequency-response bands from a scene's measured parameter spread (``[uncertainty]``), and the
verdict on model-form error against it.

Each sample of the design (:meth:`vibeam.case.uncertainty.UncertaintySpec.design`: scrambled Sobol'
points through the parameters' inverse distribution functions) is the case's model with the
sampled values set by name or path (the resolver of ``[map]``), swept by every sweep run through the
one sweep engine (:func:`vibeam.engine.sweep.run_lines`: inline or on the local pool, one line per
sample and direction).  Per run and per point of its (direction, Omega) grid the samples give the
amplitude's mean, standard deviation and quantiles (5, 25, 50, 75, 95 %), the probability of each
outcome class (the classes of a ``[map]``: period-1, period-2, period-n, non-periodic, held, no
impact, failed; and of the statuses chatter and sticking), and per sample and direction the jump
frequency (the largest jump of the amplitude between neighbouring points, kept where it exceeds
20 % of the run's peak, as the run summary's jumps).

For a case with several runs (a fidelity ladder) :func:`verdict` compares each pair: the fraction
of the swept points where one run's median amplitude lies outside the other's 90 % band (5-95 %),
and the difference of their median down-sweep jump frequencies against the spread (5-95 %) of each.

References
----------
A. Saltelli et al., *Global Sensitivity Analysis: The Primer*, Wiley 2008, Ch. 1 (sampling-based
uncertainty propagation); Hyndman & Fan, Am. Stat. 50 (1996) 361-365 (sample quantiles: numpy's
default, their definition 7).
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from itertools import combinations

import numpy as np

from vibeam.analysis.maps import CLASSES, classify
from vibeam.engine.jobs import make_job
from vibeam.engine.sweep import assemble, plan_lines, run_lines
from vibeam.io.netcdf import var

__all__ = ["QUANTILES", "JUMP_FRACTION", "UncertaintyResult", "sample_runs", "verdict", "uncertainty_variables"]

#: the stored quantiles of the amplitude
QUANTILES = (0.05, 0.25, 0.5, 0.75, 0.95)
#: a jump is a change of the amplitude between neighbouring points larger than this fraction of the
#: run's peak (the run summary's rule, :mod:`vibeam.analysis.summary`)
JUMP_FRACTION = 0.2
#: the statuses whose probability is stored beside the classes
STATUS_OUTCOMES = ("chatter", "sticking", "failed")


@dataclass
class UncertaintyResult:
    """The sampled sweeps of one run.

    Attributes
    ----------
    name : str
        The run.
    parameters : tuple of str
        The sampled names or paths.
    design : ndarray, shape (n_samples, n_parameters)
        The sampled values, in the parameters' case units.
    directions : tuple of str
        ``up`` and/or ``down``.
    Omega : ndarray, shape (n_Omega,)
        The increasing frequency grid (nondimensional).
    amplitude, period, status : ndarray, shape (n_samples, n_directions, n_Omega)
        Amplitude ``Q`` (nondimensional, paper Sec. 4.1), period of the stroboscopic map (-1 no
        impact, 0 not periodic), status per sample and point.
    frequency_hz : ndarray or None
        ``Omega f_n`` of a physical scene.
    length_m : float or None
        The scene's normalising length (amplitudes in mm are ``Q L 1e3``).
    attrs : dict
        Fidelity, method, samples, seed, wall time and the verdicts (:func:`verdict`).
    """

    name: str
    parameters: tuple
    design: np.ndarray
    directions: tuple
    Omega: np.ndarray
    amplitude: np.ndarray
    period: np.ndarray
    status: np.ndarray
    frequency_hz: np.ndarray | None = None
    length_m: float | None = None
    attrs: dict = field(default_factory=dict)
    roles: tuple = ()

    @property
    def base(self) -> np.ndarray:
        """The rows that sample the distributions (all, or Saltelli's ``A`` and ``B``): the rows of every
        statistic but the Sobol' indices."""
        r = np.asarray(self.roles if self.roles else ["A"] * self.amplitude.shape[0])
        return (r == "A") | (r == "B")

    @property
    def axis(self) -> tuple[np.ndarray, str]:
        """``(grid, unit)``: the frequency in Hz of a physical scene (runs of a ladder share it, their
        ``Omega`` being over each run's own f_n), else ``Omega``."""
        return (self.frequency_hz, "Hz") if self.frequency_hz is not None else (self.Omega, "1")

    @property
    def classification(self) -> np.ndarray:
        """Outcome class per sample and point (:func:`vibeam.analysis.maps.classify`), int8."""
        return classify(self.period, self.status)

    def quantiles(self) -> np.ndarray:
        """Amplitude quantiles :data:`QUANTILES` over the samples with a finite amplitude, shape
        ``(n_quantiles, n_directions, n_Omega)``; NaN where no sample has one."""
        a = self.amplitude[self.base]
        out = np.full((len(QUANTILES),) + a.shape[1:], np.nan)
        ok = np.isfinite(a)
        for j in np.ndindex(a.shape[1:]):
            v = a[(slice(None),) + j][ok[(slice(None),) + j]]
            if v.size:
                out[(slice(None),) + j] = np.quantile(v, QUANTILES)
        return out

    def moments(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(mean, std, n)`` of the finite amplitudes per point (``std`` with ``n - 1``; NaN below 2)."""
        a = self.amplitude[self.base]
        ok = np.isfinite(a)
        n = ok.sum(axis=0)
        s = np.where(ok, a, 0.0)
        with np.errstate(invalid="ignore", divide="ignore"):
            mean = s.sum(axis=0) / n
            var_ = np.where(ok, (a - mean) ** 2, 0.0).sum(axis=0) / (n - 1)
        return np.where(n > 0, mean, np.nan), np.where(n > 1, np.sqrt(var_), np.nan), n

    def probabilities(self) -> tuple[list, np.ndarray]:
        """``(names, p)``: the fraction of samples in each outcome (the classes of
        :data:`vibeam.analysis.maps.CLASSES`, then the statuses :data:`STATUS_OUTCOMES`) per point,
        ``p`` of shape ``(n_outcomes, n_directions, n_Omega)``."""
        c, st = self.classification[self.base], self.status[self.base]
        names = list(CLASSES.values()) + list(STATUS_OUTCOMES)
        p = [np.mean(c == k, axis=0) for k in CLASSES] + [np.mean(st == s, axis=0) for s in STATUS_OUTCOMES]
        return names, np.asarray(p)

    def sobol(self, confidence: float = 0.95, resamples: int = 199) -> dict | None:
        """Sobol' indices of the amplitude at every point and of the down-sweep jump frequency (else the
        up sweep's), by scipy.stats.sobol_indices (Saltelli et al. 2010's estimators) on Saltelli's design
        of the rows; None without that design.

        Returns
        -------
        dict
            ``first``, ``total``: shape ``(n_parameters, n_directions, n_Omega)``; ``first_ci``,
            ``total_ci``: shape ``(2, n_parameters, n_directions, n_Omega)`` (bootstrap, ``confidence``);
            ``jump_first``, ``jump_total``: shape ``(n_parameters,)``.  A point where a run gave no
            finite amplitude has NaN indices.
        """
        from scipy.stats import sobol_indices  # lazy: keeps scipy.stats out of the engine's start-up

        roles = np.asarray(self.roles)
        if not any(r.startswith("AB:") for r in roles):
            return None
        n, d = int(np.sum(roles == "A")), len(self.parameters)
        shape = self.amplitude.shape[1:]

        def indices(Y):                         # Y: (rows, s) -> (first, total, first_ci, total_ci), (d, s)
            fA, fB = Y[roles == "A"].T, Y[roles == "B"].T
            fAB = np.stack([Y[roles == f"AB:{p}"].T for p in self.parameters])
            ok = np.isfinite(fA).all(axis=1) & np.isfinite(fB).all(axis=1) & np.isfinite(fAB).all(axis=(0, 2))
            ok &= (np.var(np.concatenate([fA, fB], axis=1), axis=1) > 0)
            out = [np.full((d, Y.shape[1]), np.nan) for _ in range(2)] + \
                  [np.full((2, d, Y.shape[1]), np.nan) for _ in range(2)]
            if ok.any():
                res = sobol_indices(func={"f_A": fA[ok], "f_B": fB[ok], "f_AB": fAB[:, ok]}, n=n)
                ci = res.bootstrap(confidence_level=confidence, n_resamples=resamples)
                out[0][:, ok], out[1][:, ok] = res.first_order.T, res.total_order.T
                for k, c in ((2, ci.first_order), (3, ci.total_order)):
                    out[k][0][:, ok], out[k][1][:, ok] = c.confidence_interval.low.T, c.confidence_interval.high.T
            return out

        first, total, first_ci, total_ci = indices(self.amplitude.reshape(len(roles), -1))
        d_jump = self.directions.index("down") if "down" in self.directions else 0
        jf, jt, _, _ = indices(self.jumps()[:, d_jump:d_jump + 1])
        return {"first": first.reshape((d,) + shape), "total": total.reshape((d,) + shape),
                "first_ci": first_ci.reshape((2, d) + shape), "total_ci": total_ci.reshape((2, d) + shape),
                "jump_first": jf[:, 0], "jump_total": jt[:, 0]}

    def jumps(self) -> np.ndarray:
        """The jump frequency (on :attr:`axis`: Hz, else Omega) of each sample and direction, shape
        ``(n_samples, n_directions)``: the midpoint of the neighbouring points with the largest change
        of the amplitude, where it exceeds :data:`JUMP_FRACTION` of the sample's peak; NaN otherwise."""
        a = self.amplitude
        out = np.full(a.shape[:2], np.nan)
        x = self.axis[0]
        mid = 0.5 * (x[1:] + x[:-1])
        for i, d in np.ndindex(a.shape[:2]):
            x = a[i, d]
            if x.size < 2 or not np.isfinite(x).any():
                continue
            dA = np.abs(np.diff(x))
            if not np.isfinite(dA).any():
                continue
            k = int(np.nanargmax(dA))
            if dA[k] > JUMP_FRACTION * np.nanmax(np.abs(x)):
                out[i, d] = mid[k]
        return out


def sample_runs(case, spec=None, samples: int | None = None, jobs: int | None = 1, executor=None,
                progress: bool = False) -> list[UncertaintyResult]:
    """Sweep every sweep run of ``case`` at every sample of its ``[uncertainty]`` design.

    Parameters
    ----------
    case : vibeam.case.schema.Case
        With an ``[uncertainty]`` table (or ``spec`` given).
    spec : vibeam.case.uncertainty.UncertaintySpec, optional
        Instead of ``case.uncertainty``.
    samples : int, optional
        Instead of the spec's ``samples`` (a power of 2).
    jobs, executor :
        Where the lines run (:func:`vibeam.engine.sweep.run_lines`: inline for ``jobs = 1``).
    progress : bool
        A progress bar over all points.

    Returns
    -------
    list of UncertaintyResult
        One per sweep run, in the case's order, with the pairwise verdicts in ``attrs``.

    Raises
    ------
    vibeam.errors.CaseError
        A run whose solver cannot take a sampled value (one line naming the run and the values).
    """
    spec = case.uncertainty if spec is None else spec
    design, roles = spec.saltelli(samples) if spec.sobol else (spec.design(samples), [])
    names = tuple(p.name for p in spec.parameter)
    runs = [r for r in case.run if r.method != "continuation"]
    plan = []                                       # (run, sample, job, lines)
    for r in runs:
        for i, row in enumerate(design):
            job = make_job(case, r, dict(r.model, **{n: float(v) for n, v in zip(names, row)}), i)
            lines = [dataclasses.replace(l, key=f"{i:05d}-{l.key}") for l in plan_lines(job.solver, job.sweep, r.name)]
            plan.append((r, i, job, lines))
    done = run_lines([l for *_, ls in plan for l in ls], executor=executor, jobs=jobs, progress=progress,
                     desc=f"{case.name} uncertainty")
    out = []
    for r in runs:
        mine = [(i, job, ls) for rr, i, job, ls in plan if rr is r]
        res = [assemble(job.solver, job.sweep, r.name, [done[(l.run, l.key)] for l in ls], 0.0) for _, job, ls in mine]
        out.append(_result(r, names, design, res, spec))
        out[-1].roles = tuple(roles)
    verdict(out)
    return out


def _result(run, names, design, res, spec) -> UncertaintyResult:
    """The samples' sweep results of one run on one (direction, Omega) layout."""
    first = res[0].data
    direc = np.asarray([str(x) for x in first["direction"]])
    dirs = tuple(dict.fromkeys(direc.tolist()))
    om = np.asarray(first["Omega"], float)
    order = {d: np.flatnonzero(direc == d)[np.argsort(om[direc == d], kind="stable")] for d in dirs}
    grid = om[order[dirs[0]]]

    def lay(key, fill, dtype=float):
        a = np.full((len(res), len(dirs), grid.size), fill, dtype=dtype)
        for i, r in enumerate(res):
            v = np.asarray(r.data[key])
            for j, d in enumerate(dirs):
                a[i, j] = v[order[d]]
        return a

    amp = lay("amplitude", np.nan)
    fn = res[0].attrs.get("natural_frequency_hz")
    return UncertaintyResult(
        name=run.name, parameters=names, design=np.asarray(design, float), directions=dirs, Omega=grid,
        amplitude=amp, period=lay("period", 0, np.int64), status=lay("status", "", object),
        frequency_hz=grid * fn if fn else None, length_m=res[0].attrs.get("length_m"),
        attrs={"fidelity": res[0].fidelity, "method": res[0].method, "samples": len(res), "seed": spec.seed})


def verdict(results: list) -> dict:
    """The model-form verdict of each pair of runs, set in their ``attrs`` and returned.

    For runs ``a`` and ``b`` on the same grid (:attr:`UncertaintyResult.axis`: the frequency in Hz of
    physical scenes, else Omega): ``outside_band`` the fraction of the points (both directions) where
    ``a``'s median amplitude lies outside ``b``'s 90 % band (its 5 and 95 % quantiles), and the same of
    ``b`` in ``a``'s; ``jump_median`` of each (the median down-sweep jump frequency, else the up
    sweep's; in the grid's unit ``unit``) with ``jump_band`` (5 and 95 % of the samples' jump
    frequencies) and their difference.  Runs on different grids are not compared (no entry).

    Returns
    -------
    dict
        ``{"<a> vs <b>": {...}}``.
    """
    out = {}
    q = {r.name: r.quantiles() for r in results}
    for a, b in combinations(results, 2):
        (xa, ua), (xb, ub) = a.axis, b.axis
        if ua != ub or xa.shape != xb.shape or not np.allclose(xa, xb, rtol=1e-12, atol=0) \
                or a.directions != b.directions:
            continue
        med_a, med_b = q[a.name][2], q[b.name][2]
        lo_a, hi_a, lo_b, hi_b = q[a.name][0], q[a.name][-1], q[b.name][0], q[b.name][-1]
        ok = np.isfinite(med_a) & np.isfinite(med_b) & np.isfinite(lo_a) & np.isfinite(lo_b)
        v = {"points": int(ok.sum()), "unit": ua,
             "outside_band_a_in_b": float(np.mean((med_a[ok] < lo_b[ok]) | (med_a[ok] > hi_b[ok]))) if ok.any() else np.nan,
             "outside_band_b_in_a": float(np.mean((med_b[ok] < lo_a[ok]) | (med_b[ok] > hi_a[ok]))) if ok.any() else np.nan}
        for tag, r in (("a", a), ("b", b)):
            d = r.directions.index("down") if "down" in r.directions else 0
            j = r.jumps()[r.base, d]
            j = j[np.isfinite(j)]
            v[f"jump_median_{tag}"] = float(np.median(j)) if j.size else np.nan
            v[f"jump_band_{tag}"] = [float(x) for x in np.quantile(j, (0.05, 0.95))] if j.size else [np.nan, np.nan]
            v[f"jump_fraction_{tag}"] = float(j.size / np.sum(r.base))
        v["jump_difference"] = v["jump_median_b"] - v["jump_median_a"]
        out[f"{a.name} vs {b.name}"] = dict(v, a=a.name, b=b.name)
        for r, other in ((a, b), (b, a)):
            r.attrs[f"verdict_{other.name}"] = dict(v, a=a.name, b=b.name)
    return out


def uncertainty_variables(r: UncertaintyResult) -> dict:
    """The variables of ``/uncertainty/<run>/`` (:func:`vibeam.io.netcdf.write_group`): the design on
    (sample, parameter), every sampled sweep on (sample, direction, Omega), and the statistics on
    (direction, Omega) with the extra dimensions ``quantile`` and ``outcome``."""
    mean, std, n = r.moments()
    names, p = r.probabilities()
    g = ("direction", "Omega")
    v = {
        "sample": var(("sample",), np.arange(r.design.shape[0]), long_name="sample of the design"),
        "parameter": var(("parameter",), np.asarray(r.parameters, dtype=object), long_name="sampled name or path"),
        "direction": var(("direction",), np.asarray(r.directions, dtype=object), long_name="sweep direction"),
        "Omega": var(("Omega",), r.Omega, "1", "forcing frequency over the natural frequency"),
        "quantile": var(("quantile",), np.asarray(QUANTILES), "1", "probability of the amplitude quantile"),
        "outcome": var(("outcome",), np.asarray(names, dtype=object), long_name="outcome class or status"),
        "design": var(("sample", "parameter"), r.design, long_name="sampled values (case units)"),
        "sample_amplitude": var(("sample",) + g, r.amplitude, "1", "amplitude Q of each sample (Sec. 4.1)"),
        "sample_period": var(("sample",) + g, r.period, "1", "period of the stroboscopic map (-1 no impact)"),
        "sample_status": var(("sample",) + g, r.status.astype(str).astype(object), long_name="status"),
        "amplitude_mean": var(g, mean, "1", "mean amplitude over the samples"),
        "amplitude_std": var(g, std, "1", "standard deviation of the amplitude over the samples"),
        "amplitude_samples": var(g, n, "1", "samples with a finite amplitude"),
        "amplitude_quantile": var(("quantile",) + g, r.quantiles(), "1", "amplitude quantiles over the samples"),
        "outcome_probability": var(("outcome",) + g, p, "1", "fraction of the samples in each outcome"),
        "jump_frequency": var(("sample", "direction"), r.jumps(), r.axis[1],
                              "jump frequency of each sample, Hz or Omega (NaN: none)"),
    }
    if r.roles:
        v["sample_role"] = var(("sample",), np.asarray(r.roles, dtype=object),
                               long_name="Saltelli's design: A, B, or AB:<parameter> (A with that column from B)")
    si = r.sobol()
    if si is not None:
        v["sobol_first"] = var(("parameter",) + g, si["first"], "1", "first-order Sobol' index of the amplitude")
        v["sobol_total"] = var(("parameter",) + g, si["total"], "1", "total Sobol' index of the amplitude")
        v["sobol_first_ci"] = var(("bound", "parameter") + g, si["first_ci"], "1", "95 % bootstrap interval")
        v["sobol_total_ci"] = var(("bound", "parameter") + g, si["total_ci"], "1", "95 % bootstrap interval")
        v["jump_sobol_first"] = var(("parameter",), si["jump_first"], "1", "first-order index of the jump frequency")
        v["jump_sobol_total"] = var(("parameter",), si["jump_total"], "1", "total index of the jump frequency")
    if r.frequency_hz is not None:
        v["frequency_hz"] = var(("Omega",), r.frequency_hz, "Hz", "forcing frequency")
    if r.length_m:
        v["amplitude_quantile_mm"] = var(("quantile",) + g, r.quantiles() * r.length_m * 1e3, "mm",
                                         "amplitude quantiles over the samples")
    return v
