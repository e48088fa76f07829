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

from dataclasses import dataclass, field
from itertools import combinations

import json

import numpy as np

from vibeam.analysis.maps import CLASS_COLOURS, CLASSES, classify
from vibeam.engine import sweep          # by the module: its run_lines may be replaced (tests)
from vibeam.engine.jobs import make_job
from vibeam.engine.records import PERIOD_MAX, STATUSES
from vibeam.engine.sweep import MOTION_MAX, load_kernels, plan_lines, run_line, stack
from vibeam.errors import CaseError, InputError
from vibeam.io.h5check import open_checked
from vibeam.io.netcdf import json_default, read_attrs, read_plain, var, write_group
from vibeam.io.store import case_hash
from vibeam.models.scene import outputs

__all__ = ["QUANTILES", "JUMP_FRACTION", "BOOTSTRAP_RESAMPLES", "BOOTSTRAP_CONFIDENCE", "UncertaintyResult", "SampleTask", "sample_arrays", "sample_runs", "verdict",
           "RESOLVED_FRACTION", "verdict_text", "jump_share",
           "CHECKPOINT", "checkpoint_ident", "checkpoint_groups", "check_block", "samples_from_checkpoint",
           "uncertainty_group", "read_uncertainty", "bands", "sobol_entries", "outcome_entries", "OUTCOME_COLOURS",
           "uncertainty_variables"]

#: the stored quantiles of the amplitude
QUANTILES = (0.05, 0.25, 0.5, 0.75, 0.95)
#: a jump is a change of the amplitude between neighbouring points larger than this fraction of the
#: run's peak (the run summary's rule, :mod:`vibeam.analysis.summary`)
JUMP_FRACTION = 0.2
#: a pair of runs is told apart by its amplitude (:func:`verdict_text`) when one run's median lies
#: outside the other's 90 % band at more than this fraction of the points: with one model the median
#: leaves the 5-95 % band only by sampling error, at isolated points (a jump, where the band is
#: bimodal), so a tenth of the grid is beyond chance and below it no difference is claimed
RESOLVED_FRACTION = 0.1
#: the statuses whose probability is stored beside the classes
STATUS_OUTCOMES = ("chatter", "sticking", "failed")
#: the colour of each outcome in the outcome figure: the map's class colours (vibeam.analysis.maps), then the
#: statuses chatter (bluish green), sticking (sky blue), failed (black)
OUTCOME_COLOURS = tuple(CLASS_COLOURS[:len(CLASSES)]) + ("#009E73", "#56B4E9", "#000000")
#: resamples of the bootstrap intervals of the quantiles, mean and std (:meth:`UncertaintyResult.bootstrap`)
BOOTSTRAP_RESAMPLES = 999
#: their confidence level
BOOTSTRAP_CONFIDENCE = 0.95
#: the most values one batch of bootstrap resamples holds (resamples x samples; 32 MB of float64)
BOOTSTRAP_BATCH = 1 << 22


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
        Fidelity, method, ``samples`` (the design's N: its rows, or the N of Saltelli's N (d + 2)
        rows), seed and the verdicts (:func:`verdict`).
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

    def bootstrap(self, resamples: int = BOOTSTRAP_RESAMPLES, confidence: float = BOOTSTRAP_CONFIDENCE,
                  seed: int | None = None) -> dict:
        """Percentile-bootstrap confidence intervals of :meth:`quantiles` and of :meth:`moments`'
        mean and std, per point.

        At each point the samples with a finite amplitude (``m`` of them, the rows of :attr:`base`)
        are resampled with replacement ``resamples`` times; each resample gives the quantiles
        :data:`QUANTILES` (numpy's definition 7, as :meth:`quantiles`), the mean and the std (``n - 1``),
        and the interval is the ``(1 - confidence) / 2`` and ``(1 + confidence) / 2`` quantiles of
        those ``resamples`` values (Efron's percentile interval).  The draws are
        ``numpy.random.default_rng([seed, k])`` at the ``k``-th point (row-major over (direction,
        Omega)): the same intervals on every machine, whatever order points are computed in.

        The resampling treats the samples as independent: for scrambled Sobol' points, whose
        estimates err less than independent draws do, the intervals are conservative (wider than the
        estimates' actual error); they shrink as ``1 / sqrt(m)``.

        Parameters
        ----------
        resamples : int
            Bootstrap resamples (default :data:`BOOTSTRAP_RESAMPLES`).
        confidence : float
            Confidence level, in (0, 1) (default :data:`BOOTSTRAP_CONFIDENCE`).
        seed : int, optional
            Default: the design's ``seed`` (``attrs``).

        Returns
        -------
        dict
            ``quantile_ci``: shape ``(2, n_quantiles, n_directions, n_Omega)``; ``mean_ci``,
            ``std_ci``: shape ``(2, n_directions, n_Omega)``; bound 0 the lower end, 1 the upper.
            NaN where fewer than 2 samples have a finite amplitude.  In the amplitude's unit (Q, 1).

        Raises
        ------
        ValueError
            ``resamples`` below 1 or ``confidence`` outside (0, 1).

        References
        ----------
        B. Efron, R. J. Tibshirani, *An Introduction to the Bootstrap*, Chapman & Hall 1993, Ch. 13
        (the percentile interval).
        """
        if int(resamples) < 1 or not 0.0 < float(confidence) < 1.0:
            raise ValueError(f"resamples = {resamples}, confidence = {confidence}: allowed resamples >= 1 and "
                             f"0 < confidence < 1")
        seed = int(self.attrs.get("seed", 0)) if seed is None else int(seed)
        a = self.amplitude[self.base]
        shape = a.shape[1:]
        q_ci = np.full((2, len(QUANTILES)) + shape, np.nan)
        m_ci, s_ci = np.full((2,) + shape, np.nan), np.full((2,) + shape, np.nan)
        ends = (0.5 * (1.0 - confidence), 0.5 * (1.0 + confidence))
        for k, j in enumerate(np.ndindex(shape)):
            v = a[(slice(None),) + j]
            v = v[np.isfinite(v)]
            m = v.size
            if m < 2:
                continue
            rng = np.random.default_rng([seed, k])
            qs, means, stds = [], [], []
            batch = max(1, BOOTSTRAP_BATCH // m)
            for start in range(0, int(resamples), batch):
                x = v[rng.integers(0, m, size=(min(batch, int(resamples) - start), m))]
                qs.append(np.quantile(x, QUANTILES, axis=1))
                means.append(x.mean(axis=1))
                stds.append(x.std(axis=1, ddof=1))
            q_ci[(slice(None), slice(None)) + j] = np.quantile(np.concatenate(qs, axis=1), ends, axis=1)
            m_ci[(slice(None),) + j] = np.quantile(np.concatenate(means), ends)
            s_ci[(slice(None),) + j] = np.quantile(np.concatenate(stds), ends)
        return {"quantile_ci": q_ci, "mean_ci": m_ci, "std_ci": s_ci}

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
            finite amplitude has NaN indices.  The intervals are scipy's BCa bootstrap, whose draws come
            from numpy's global RandomState: seeded here by the design's ``seed`` (and restored), so
            they are the same on every call.
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
                # scipy squeezes its (outputs, parameters) results: a single output gave shape (d,), which
                # does not fit (d, 1), and with one parameter too a scalar it fails on; the single output
                # goes in twice and the copy is dropped (every sample jumps: the jump frequency's indices)
                cols = np.flatnonzero(ok)
                cols = np.repeat(cols, 2) if cols.size == 1 else cols
                res = sobol_indices(func={"f_A": fA[cols], "f_B": fB[cols], "f_AB": fAB[:, cols]}, n=n)
                # its bootstrap draws from numpy's global RandomState (scipy 1.17 takes no rng there):
                # seeded by the design's seed, so the intervals are reproducible, and restored after
                state = np.random.get_state()
                np.random.seed(int(self.attrs.get("seed", 0)))
                try:
                    ci = res.bootstrap(confidence_level=confidence, n_resamples=resamples)
                finally:
                    np.random.set_state(state)
                def put(x):                     # scipy's (outputs, parameters), squeezed -> (d, outputs ok)
                    return np.reshape(x, (cols.size, d)).T[:, :int(ok.sum())]

                out[0][:, ok], out[1][:, ok] = put(res.first_order), put(res.total_order)
                for k, c in ((2, ci.first_order), (3, ci.total_order)):
                    out[k][0][:, ok], out[k][1][:, ok] = put(c.confidence_interval.low), put(c.confidence_interval.high)
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


@dataclass(frozen=True)
class SampleTask:
    """One sample's sweep of one run: a unit of work of :func:`vibeam.engine.sweep.run_lines`.

    The solver is built where the unit runs (a worker of the pool, or this process inline) and
    dropped when its sweep is done, so a design of many samples never holds more solvers than
    there are workers; what comes back is :func:`sample_arrays` of the sweep, not its per-point
    records.

    Attributes
    ----------
    key : str
        ``"<sample index, 6 digits>"`` (unique within the run).
    run : str
        The run's name.
    case : vibeam.case.schema.Case
        The case as run.
    spec_run : object
        Its ``[[run]]`` entry.
    values : tuple of (str, float)
        The sampled names or paths and values.
    index : int
        The sample (row of the design).
    n_points : int
        Points of the sweep (every direction).
    """

    key: str
    run: str
    case: object
    spec_run: object
    values: tuple
    index: int
    n_points: int
    #: the progress bar advances per point (run_line's protocol)
    reports_progress = True

    def compute(self, report=None) -> list:
        """The sample's sweep: ``[sample_arrays(...)]`` (one row).  A solver that refuses the
        sampled values (:class:`vibeam.errors.CaseError` of :func:`vibeam.engine.jobs.make_job`) gives
        every point ``status = 'failed'`` (each parameter's support was checked against its range
        when the case was read; only a combination of values can be refused)."""
        try:
            job = make_job(self.case, self.spec_run, dict(self.spec_run.model, **dict(self.values)), self.index)
        except CaseError:
            return self.lost_rows(None, 0)
        rows = [row for line in plan_lines(job.solver, job.sweep, self.run) for row in run_line(line, report)]
        return [sample_arrays(rows, job.sweep)]

    def lost_rows(self, err, attempts) -> list:
        """Every point failed (a worker lost ``attempts`` times, or a refused solver): the row of
        :meth:`compute` with NaN amplitudes, period 0 and status ``failed``."""
        shape = self.case_shape
        return [{"amplitude": np.full(shape, np.nan), "period": np.zeros(shape, np.int64),
                 "status": np.full(shape, "failed", dtype=object)}]

    @property
    def case_shape(self) -> tuple:
        """``(n_directions, n_Omega)`` of the sample's arrays."""
        nd = 2 if self.case.sweep.direction == "both" else 1
        return nd, self.n_points // nd


def sample_arrays(rows: list, sw) -> dict:
    """One sampled sweep's per-point records (:func:`vibeam.engine.sweep.run_line`, every line in
    plan order) as ``{"amplitude", "period", "status"}``, each of shape ``(n_directions, n_Omega)``
    along the increasing ``Omega`` (directions in visiting order: up, then down)."""
    data = stack(rows, sw)
    direc = np.asarray([str(x) for x in data["direction"]])
    om = np.asarray(data["Omega"], float)
    dirs = list(dict.fromkeys(direc.tolist()))
    order = [np.flatnonzero(direc == d)[np.argsort(om[direc == d], kind="stable")] for d in dirs]
    st = np.asarray(data["status"], dtype=object)
    return {"amplitude": np.stack([np.asarray(data["amplitude"], float)[o] for o in order]),
            "period": np.stack([np.asarray(data["period"], np.int64)[o] for o in order]),
            "status": np.stack([st[o] for o in order]).astype(object)}


@dataclass(frozen=True)
class SamplePlan:
    """The work of an ``[uncertainty]`` design (:func:`plan_samples`).

    Attributes
    ----------
    design : ndarray, shape (rows, d)
        The sampled values (the base design, or Saltelli's rows with ``sobol = true``).
    roles : list of str
        The role of each Saltelli row (empty without ``sobol``).
    names : tuple of str
        The sampled names or paths.
    runs : list
        The case's sweep runs (``[[run]]`` entries), in order.
    tasks : list of SampleTask
        The (run, sample) units not yet done.
    firsts : list
        The first sample's lines of each run with work left (their kernels are loaded first).
    meta : dict
        Per run: directions, Omega, natural frequency (Hz), length (m), fidelity, method.
    """

    design: np.ndarray
    roles: list
    names: tuple
    runs: list
    tasks: list
    firsts: list
    meta: dict


def plan_samples(case, spec=None, samples: int | None = None, done: dict | None = None) -> SamplePlan:
    """The units of work of every sweep run of ``case`` at every sample of its design not in ``done``
    (arguments as :func:`sample_runs`).

    Raises
    ------
    vibeam.errors.CaseError
        A run whose solver cannot be built at the first sample (one line naming the run and the values).
    """
    spec = case.uncertainty if spec is None else spec
    design, roles = spec.saltelli(samples) if spec.sobol else (spec.design(samples), [])
    names = tuple(p.name for p in spec.parameter)
    runs = [r for r in case.run if r.method != "continuation"]
    done = done or {}
    tasks, firsts, meta = [], [], {}
    for r in runs:
        # the first sample's job: the grid, the layout, the scene's units and the kernels to load
        job = make_job(case, r, dict(r.model, **{n: float(v) for n, v in zip(names, design[0])}), 0)
        lines = plan_lines(job.solver, job.sweep, r.name)
        out = outputs(job.solver.scene)
        meta[r.name] = {"dirs": tuple(dict.fromkeys(l.direction for l in lines)),
                        "Omega": np.sort(np.asarray(job.sweep.Omega, float)),
                        "fn": out.natural_frequency_hz, "L": out.length_m,
                        "fidelity": job.solver.scene.builder, "method": job.solver.name}
        n_pts = sum(l.n_points for l in lines)
        todo = [i for i in range(design.shape[0]) if i not in done.get(r.name, {})]
        if todo:
            firsts += lines
        tasks += [SampleTask(f"{i:06d}", r.name, case, r, tuple((n, float(v)) for n, v in zip(names, design[i])), i,
                             n_pts) for i in todo]
    return SamplePlan(design, roles, names, runs, tasks, firsts, meta)


def sample_runs(case, spec=None, samples: int | None = None, jobs: int | None = None, executor=None,
                progress: bool = False, done: dict | None = None, on_sample=None) -> list[UncertaintyResult]:
    """Sweep every sweep run of ``case`` at every sample of its ``[uncertainty]`` design.

    Each (run, sample) is one unit of work (:class:`SampleTask`) on the one engine
    (:func:`vibeam.engine.sweep.run_lines`); its solver is built where it runs, and only the sample's
    amplitude, period and status per (direction, Omega) come back: memory holds those arrays (about
    17 bytes per sampled point) and one solver per worker, whatever the number of samples.

    Parameters
    ----------
    case : vibeam.case.schema.Case
        With an ``[uncertainty]`` table (or ``spec`` given).
    spec : vibeam.case.uncertainty.UncertaintySpec, optional
        Instead of ``case.uncertainty``.
    samples : int, optional
        Instead of the spec's ``samples`` (a power of 2).
    jobs, executor :
        Where the samples run (:func:`vibeam.engine.sweep.run_lines`: None all cores, 1 inline).
    progress : bool
        A progress bar over all sampled points.
    done : dict, optional
        ``{run: {sample: arrays}}`` computed before (a checkpoint, ``--resume``): not computed again.
    on_sample : callable, optional
        ``on_sample(run, sample, arrays)`` in this process as each sample's sweep finishes (in any
        order), ``arrays`` as :func:`sample_arrays` (the checkpoint writer).

    Returns
    -------
    list of UncertaintyResult
        One per sweep run, in the case's order, with the pairwise verdicts in ``attrs``.

    Raises
    ------
    vibeam.errors.CaseError
        A run whose solver cannot be built at the first sample (one line naming the run and the values).
    """
    spec = case.uncertainty if spec is None else spec
    plan = plan_samples(case, spec, samples, done)
    design, roles, names, runs, tasks, meta = plan.design, plan.roles, plan.names, plan.runs, plan.tasks, plan.meta
    done = {r.name: dict((done or {}).get(r.name, {})) for r in runs}
    if tasks and executor is None:
        load_kernels(plan.firsts)   # before the pool forks: its workers inherit the kernels

    def on_line(task, rows):
        done[task.run][task.index] = rows[0]
        if on_sample is not None:
            on_sample(task.run, task.index, rows[0])

    sweep.run_lines(tasks, executor=executor, jobs=jobs, on_line=on_line, progress=progress,
                    desc=f"{case.name} uncertainty")
    n_base = design.shape[0] // spec.runs_per_sample()
    out = []
    for r in runs:
        m, got = meta[r.name], done[r.name]
        rows = [got[i] for i in range(design.shape[0])]
        out.append(UncertaintyResult(
            name=r.name, parameters=names, design=np.asarray(design, float), directions=m["dirs"], Omega=m["Omega"],
            amplitude=np.stack([x["amplitude"] for x in rows]), period=np.stack([x["period"] for x in rows]),
            status=np.stack([x["status"] for x in rows]).astype(object),
            frequency_hz=m["Omega"] * m["fn"] if m["fn"] else None, length_m=m["L"],
            attrs={"fidelity": m["fidelity"], "method": m["method"], "samples": n_base, "seed": spec.seed},
            roles=tuple(roles)))
    verdict(out)
    return out


#: the checkpoint group of finished samples (``results.h5.partial``: ``/uncertainty_samples/<run>/<block>/``)
CHECKPOINT = "uncertainty_samples"


def checkpoint_ident(case_json: str, samples: int) -> str:
    """What marks a checkpointed sample as this computation's: the case as run (its JSON) and the
    number of samples of the design (``--samples`` changes the design, not the case)."""
    return case_hash(f"{case_json}\n[uncertainty] samples = {int(samples)}")


def checkpoint_groups(finished: dict, ident: str) -> dict:
    """Finished samples of one run, ``{sample: arrays}`` (:func:`sample_arrays`), as one checkpoint
    block ``{"<ident>-<first sample>": (variables, attrs)}`` for
    :meth:`vibeam.io.store.Store.checkpoint` of ``uncertainty_samples/<run>``: ``sample`` (k,) and
    ``amplitude``, ``period``, ``status`` of shape (k, n_directions, n_Omega); attribute ``case_hash``
    the ident (:func:`checkpoint_ident`).  A sample is in one block only, so the key is unique."""
    idx = sorted(finished)
    if not idx:
        return {}
    dims = ("sample", "direction", "Omega")
    variables = {
        "sample": var(("sample",), np.asarray(idx, np.int64), long_name="sample of the design"),
        "amplitude": var(dims, np.stack([finished[i]["amplitude"] for i in idx]), "1", "amplitude Q"),
        "period": var(dims, np.stack([finished[i]["period"] for i in idx]), "1", "period (-1 no impact)"),
        "status": var(dims, np.stack([finished[i]["status"] for i in idx]).astype(str).astype(object),
                      long_name="status"),
    }
    return {f"{ident}-{idx[0]:06d}": (variables, {"case_hash": ident})}


def check_block(meta: dict, data: dict | None, rows: int, shape: tuple, time_domain: bool = True,
                period_max: int = PERIOD_MAX) -> str | None:
    """What is wrong with a checkpointed block of samples, or None: what :func:`checkpoint_groups`
    writes.

    Parameters
    ----------
    meta : dict
        ``{dataset: (shape, dtype)}`` of the block (read before any value).
    data : dict or None
        ``{dataset: array}`` once read (None: shapes and types only).
    rows : int
        Sampled sweeps of the design (``sample`` is below it).
    shape : tuple
        ``(directions, frequencies)`` of one sampled sweep.
    time_domain : bool
        The run's method integrates the motion: every point that is not ``failed`` has a finite
        amplitude (else, as the averaging's "no solution", NaN with period -1).
    period_max : int
        The largest period the run's method reports (:data:`vibeam.engine.records.PERIOD_MAX`; the
        averaging's and mapping's own ``k``/``n`` where larger).

    Returns
    -------
    str or None
        One phrase naming the dataset and what is wrong.

    The rules: exactly the datasets ``sample`` (whole numbers from 0 to ``rows - 1``, once each),
    ``amplitude`` (float64), ``period`` (whole numbers, -1 ... ``period_max``) and ``status`` (one of
    :data:`vibeam.engine.records.STATUSES`), each of shape ``(k,) + shape``; at a point that is not
    ``failed`` the amplitude is a number (NaN only with period -1 of a method that is not
    time-domain), never infinite, at most :data:`vibeam.engine.sweep.MOTION_MAX` in magnitude (as a
    sweep line's: :func:`vibeam.engine.sweep.check_line`).  A sample in two blocks is refused by the
    caller (:func:`samples_from_checkpoint` sees every block).
    """
    for k in ("sample", "amplitude", "period", "status"):
        if k not in meta:
            return f"dataset {k} is missing"
    extra = sorted(set(meta) - {"sample", "amplitude", "period", "status"})
    if extra:
        return f"dataset {extra[0]} is not one vibeam writes there (sample, amplitude, period, status)"
    k_ = meta["sample"][0]
    if len(k_) != 1 or np.dtype(meta["sample"][1]).kind not in "iu":
        return f"dataset sample has shape {tuple(k_)} and type {np.dtype(meta['sample'][1])}; allowed: whole numbers"
    for k, kinds in (("amplitude", "f"), ("period", "iu"), ("status", "OSU")):
        sh, dt = meta[k]
        if tuple(sh) != tuple(k_) + tuple(shape):
            return f"dataset {k} has shape {tuple(sh)}; allowed: {tuple(k_) + tuple(shape)} (sample, direction, Omega)"
        if np.dtype(dt).kind not in kinds or (k == "amplitude" and np.dtype(dt).itemsize != 8):
            return f"dataset {k} holds {np.dtype(dt)} values, not what vibeam writes"
    if data is None:
        return None
    i = np.asarray(data["sample"])
    if i.size and (i.min() < 0 or i.max() >= rows or np.unique(i).size != i.size):
        return f"dataset sample holds a value outside 0 ... {rows - 1} or one twice"
    st = np.asarray(data["status"]).astype(str)
    bad = [str(x) for x in st.ravel() if x not in STATUSES]
    if bad:
        return f"dataset status holds {bad[0][:40]!r}; allowed: {', '.join(STATUSES)}"
    per = np.asarray(data["period"])
    if per.size and (per.min() < -1 or per.max() > period_max):
        v = per.min() if per.min() < -1 else per.max()
        return f"dataset period holds {int(v)}; allowed: -1 (no impact), 0 (not periodic) ... {period_max}"
    a = np.asarray(data["amplitude"], float)
    live = st != "failed"
    checks = ((live & np.isinf(a), "infinite"),
              (live & np.isnan(a) & ((per != -1) | time_domain), "nan"),
              (live & (np.abs(a) > MOTION_MAX), f"beyond {MOTION_MAX:g} in magnitude (its square overflows)"))
    for mask, what in checks:
        if np.any(mask):
            j = tuple(int(x[0]) for x in np.nonzero(mask))
            return (f"dataset amplitude is {what} ({a[j]:g}) at sample {int(i[j[0]])}, direction {j[1]}, point "
                    f"{j[2]} whose status is {str(st[j])!r} and period {int(per[j])}; allowed there: a finite number")
    return None


def samples_from_checkpoint(got: dict, where: str = "") -> dict:
    """``{sample: arrays}`` (:func:`sample_arrays`) of checkpointed blocks ``{key: {dataset: array}}``
    (checked by :func:`check_block`).

    Raises
    ------
    InputError
        A sample in two blocks (vibeam writes each sample once): one line naming ``where`` (the
        file and group) and both blocks.
    """
    out, seen = {}, {}
    for key in sorted(got):
        d = got[key]
        for j, i in enumerate(np.asarray(d["sample"], np.int64)):
            if int(i) in seen:
                raise InputError(f"--resume: {where}: sample {int(i)} is in block {seen[int(i)]} and in block {key}; "
                                 f"this vibeam writes each sample once: remove the checkpoint (or run without "
                                 f"--resume) to compute afresh")
            seen[int(i)] = key
            out[int(i)] = {"amplitude": np.asarray(d["amplitude"][j], float),
                           "period": np.asarray(d["period"][j], np.int64),
                           "status": np.asarray(d["status"][j]).astype(str).astype(object)}
    return out


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


def verdict_text(v: dict) -> str:
    """The conclusion of one pair's verdict (:func:`verdict`) in words.

    ``model-form difference resolved (...)`` when the runs differ beyond the scatter of the sampled
    parameters: the amplitude when one run's median lies outside the other's 90 % band at more than
    :data:`RESOLVED_FRACTION` of the points, the jump frequency when one run's median down-sweep
    jump lies outside the other's 5-95 % spread of jumps; ``model-form difference hidden by the
    scatter of the sampled parameters`` otherwise; ``no conclusion`` without a point where both
    runs have a finite band.

    Parameters
    ----------
    v : dict
        One value of :func:`verdict` (or an ``attrs["verdict_<run>"]``).

    Returns
    -------
    str
    """
    amp = [v.get("outside_band_a_in_b"), v.get("outside_band_b_in_a")]
    amp = [float(x) for x in amp if x is not None and np.isfinite(x)]
    if not v.get("points") or not amp:
        return "no conclusion (no point where both runs have a finite band)"
    ja, jb = v.get("jump_median_a", np.nan), v.get("jump_median_b", np.nan)
    (la, ha), (lb, hb) = v.get("jump_band_a", (np.nan, np.nan)), v.get("jump_band_b", (np.nan, np.nan))
    jumps = all(np.isfinite(x) for x in (ja, jb, la, ha, lb, hb))
    resolved = [what for what, yes in (("amplitude", max(amp) > RESOLVED_FRACTION),
                                       ("jump frequency", jumps and not (lb <= ja <= hb and la <= jb <= ha)))
                if yes]
    if resolved:
        return f"model-form difference resolved ({' and '.join(resolved)} beyond the scatter of the sampled parameters)"
    return "model-form difference hidden by the scatter of the sampled parameters"


def jump_share(r: UncertaintyResult) -> tuple[float, str]:
    """The fraction of the samples whose sweep jumps (:meth:`UncertaintyResult.jumps`: a change of the
    amplitude between neighbouring points above :data:`JUMP_FRACTION` of the sample's peak), in the
    down sweep when there is one (else the up sweep), and that direction: ``(fraction, direction)``.
    The value :func:`verdict` stores as ``jump_fraction_a`` / ``_b``."""
    d = r.directions.index("down") if "down" in r.directions else 0
    base = np.asarray(r.base, bool)
    j = r.jumps()[base, d]
    return (float(np.isfinite(j).sum() / base.sum()) if base.any() else float("nan")), r.directions[d]


def uncertainty_variables(r: UncertaintyResult) -> dict:
    """The variables of ``/uncertainty/<run>/`` (:func:`vibeam.io.netcdf.write_group`): the design on
    (sample, parameter), every sampled sweep on (sample, direction, Omega), and the statistics on
    (direction, Omega) with the extra dimensions ``quantile``, ``outcome`` and ``bound`` (the lower and
    upper end of an interval: the bootstrap intervals of :meth:`UncertaintyResult.bootstrap`, the Sobol'
    indices' intervals)."""
    mean, std, n = r.moments()
    names, p = r.probabilities()
    ci = r.bootstrap()
    ci_text = f"{100 * BOOTSTRAP_CONFIDENCE:.0f} % percentile-bootstrap interval ({BOOTSTRAP_RESAMPLES} resamples)"
    g = ("direction", "Omega")
    v = {
        "sample": var(("sample",), np.arange(r.design.shape[0]), long_name="sample of the design"),
        "parameter": var(("parameter",), np.asarray(r.parameters, dtype=object), long_name="sampled name or path"),
        "direction": var(("direction",), np.asarray(r.directions, dtype=object), long_name="sweep direction"),
        "Omega": var(("Omega",), r.Omega, "1", "forcing frequency over the natural frequency"),
        "quantile": var(("quantile",), np.asarray(QUANTILES), "1", "probability of the amplitude quantile"),
        "outcome": var(("outcome",), np.asarray(names, dtype=object), long_name="outcome class or status"),
        "bound": var(("bound",), np.asarray(["low", "high"], dtype=object), long_name="end of an interval"),
        "design": var(("sample", "parameter"), r.design, long_name="sampled values (case units)"),
        "sample_amplitude": var(("sample",) + g, r.amplitude, "1", "amplitude Q of each sample (Sec. 4.1)"),
        "sample_period": var(("sample",) + g, r.period, "1", "period of the stroboscopic map (-1 no impact)"),
        "sample_status": var(("sample",) + g, r.status.astype(str).astype(object), long_name="status"),
        "amplitude_mean": var(g, mean, "1", "mean amplitude over the samples"),
        "amplitude_std": var(g, std, "1", "standard deviation of the amplitude over the samples"),
        "amplitude_samples": var(g, n, "1", "samples with a finite amplitude"),
        "amplitude_quantile": var(("quantile",) + g, r.quantiles(), "1", "amplitude quantiles over the samples"),
        "amplitude_quantile_ci": var(("bound", "quantile") + g, ci["quantile_ci"], "1", ci_text + " of the quantiles"),
        "amplitude_mean_ci": var(("bound",) + g, ci["mean_ci"], "1", ci_text + " of the mean"),
        "amplitude_std_ci": var(("bound",) + g, ci["std_ci"], "1", ci_text + " of the standard deviation"),
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
        v["amplitude_quantile_ci_mm"] = var(("bound", "quantile") + g, ci["quantile_ci"] * r.length_m * 1e3, "mm",
                                            ci_text + " of the quantiles")
    return v


#: attributes of ``/uncertainty/<run>/`` that are the store's or the writer's, not the result's
_STORE_ATTRS = ("run", "case_hash", "case_name", "stale", "stale_reason", "case_text", "case_json", "length_m")


def uncertainty_group(r: UncertaintyResult):
    """The writer of ``/uncertainty/<run>/`` of one result (a ``fill(file)`` for
    :meth:`vibeam.io.store.Store.commit`): :func:`uncertainty_variables`, the result's ``attrs`` (a
    dict or list as JSON text), ``run`` and, on a physical scene, ``length_m`` (m)."""
    attrs = {k: (json.dumps(v, default=json_default) if isinstance(v, (dict, list)) else v) for k, v in r.attrs.items()}
    if r.length_m:
        attrs["length_m"] = float(r.length_m)

    def fill(f):
        write_group(f, f"uncertainty/{r.name}", uncertainty_variables(r), dict(attrs, run=r.name))
    return fill


def read_uncertainty(path) -> list:
    """Every ``/uncertainty/<run>/`` of a results file as :class:`UncertaintyResult` (what
    :func:`uncertainty_group` wrote: the design, every sampled sweep, ``attrs`` with the verdicts);
    the statistics are computed again from the samples (they equal the stored ones).

    Raises
    ------
    vibeam.errors.InputError
        Not an HDF5 file vibeam can read, or a structure :mod:`vibeam.io.h5check` refuses.
    """
    out = []
    with open_checked(path, "results file") as f:
        top = f.get("uncertainty")
        groups = {k: (read_plain(g), read_attrs(g)) for k, g in top.items()} if top is not None else {}
    for name, (d, a) in groups.items():
        attrs = {}
        for k, v in a.items():
            if k in _STORE_ATTRS:
                continue
            if k.startswith("verdict_") and isinstance(v, str):
                v = json.loads(v)
            attrs[k] = v.item() if isinstance(v, np.generic) else v
        length = a.get("length_m")
        out.append(UncertaintyResult(
            name=name, parameters=tuple(str(x) for x in d["parameter"]), design=np.asarray(d["design"], float),
            directions=tuple(str(x) for x in d["direction"]), Omega=np.asarray(d["Omega"], float),
            amplitude=np.asarray(d["sample_amplitude"], float), period=np.asarray(d["sample_period"], np.int64),
            status=np.asarray(d["sample_status"]).astype(str).astype(object),
            frequency_hz=np.asarray(d["frequency_hz"], float) if "frequency_hz" in d else None,
            length_m=float(length) if length is not None else None, attrs=attrs,
            roles=tuple(str(x) for x in d["sample_role"]) if "sample_role" in d else ()))
    return out


def bands(results) -> list:
    """The band of each result for :func:`vibeam.plots.uncertainty.band_figure` (mm on a physical scene)."""
    out = []
    for r in results:
        x, xu = r.axis
        scale = r.length_m * 1e3 if r.length_m else 1.0
        out.append({"name": r.name, "x": x, "x_unit": xu, "directions": list(r.directions),
                    "q": r.quantiles() * scale, "unit": "mm" if r.length_m else "1",
                    "samples": int(np.sum(r.base)), "parameters": list(r.parameters)})
    return out


def sobol_entries(results) -> list:
    """The Sobol' indices of each result with Saltelli's design for
    :func:`vibeam.plots.uncertainty.sobol_figure` (none without that design)."""
    out = []
    for r in results:
        si = r.sobol()
        if si is None:
            continue
        x, xu = r.axis
        out.append({"name": r.name, "x": x, "x_unit": xu, "directions": list(r.directions),
                    "parameters": list(r.parameters), "first": si["first"], "total": si["total"],
                    "first_ci": si["first_ci"], "total_ci": si["total_ci"]})
    return out


def outcome_entries(results) -> list:
    """The outcome probabilities of each result for :func:`vibeam.plots.uncertainty.outcome_figure`:
    the classes stacked, the statuses (:data:`STATUS_OUTCOMES`) as lines."""
    out = []
    for r in results:
        names, p = r.probabilities()
        x, xu = r.axis
        out.append({"name": r.name, "x": x, "x_unit": xu, "directions": list(r.directions), "outcomes": names,
                    "p": p, "colours": list(OUTCOME_COLOURS),
                    # by position: the class "failed" and the status "failed" share a name
                    "stacked": [i < len(CLASSES) for i in range(len(names))]})
    return out
