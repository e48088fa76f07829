"""``vibeam fit``: identify model parameters from a measured FRC (paper Secs. 6-7), with
standard errors, for every fidelity.

The paper fitted gamma around 2 f_n by hand, one gap at a time (Sec. 7, Fig. 31: 3.78,
5.16 and 7.66e-4 /V), with R from the sensor's time series (Table 1).  :func:`fit_case`
does this by nonlinear least squares of the model's FRC to the measured points, for any
numeric key of the case's ``[model]`` (``gain``, ``R``, ``damping_ratio``,
``natural_frequency_hz``, ``gap_mm``, ...) and any fidelity or method a case can run.

One evaluation of the residuals is one sweep
    The model is swept *at the data frequencies*, in the measured direction(s) (``up``
    and/or ``down``, as continuation chains when the case's ``[sweep] continuation`` is on,
    like the rig's sweep that dwelt on exactly those frequencies), through the one sweep
    engine :func:`vibeam.engine.sweep.run_lines` with the solvers built as the runner builds them
    (:func:`vibeam.runner.make_job`).  Not on the case's grid and interpolated: a vibro-impact
    FRC jumps, and an interpolated value next to a jump belongs to neither branch; the
    data frequencies are also where the residual is needed, so no point is wasted.

The Jacobian: central differences over parallel sweeps (:func:`finite_difference_jacobian`)
    All ``2 p`` perturbed sweeps of one Jacobian are submitted to the executor together.
    Step ``h_j = eps^(1/3) typ_j`` (the optimum of a central difference whose function
    values carry relative errors ``eps``), ``typ_j`` the parameter's magnitude (or a
    typical value when it is zero), and ``eps`` the sweep's own accuracy: the largest
    change of a periodic point's amplitude when the transient is doubled, measured once
    at the start, relative to the largest amplitude, and at least 1e-13 (the event
    solvers' round-off).  The function is kept behind ``jacobian=`` so that continuation
    sensitivities can replace it.

What a vibro-impact FRC does to least squares, and what is done about it
    * *Jumps and hysteresis.*  A small change of a parameter can move a point to the
      other branch (a fold moved past it) or change its period-n.  Such a point's
      residual is discontinuous: a finite difference across it is not a derivative.  For
      each point and parameter the two one-sided differences are compared: equal period-n
      on both sides and agreeing slopes give the central difference; a side with another
      period-n, or with a slope far from the other side's, is dropped (one-sided
      difference); with neither side usable the entry is zero.  The counts are reported.
      The robust loss (default ``soft_l1``) bounds the pull of a point left on the wrong
      branch.
    * *Non-periodic points.*  The model's amplitude at a point that is not periodic
      (period 0) is one sample of an attractor, not a function of the parameters.  Its
      residual is divided by ``sqrt(sigma^2 + spread^2)`` with ``spread`` the standard
      deviation of the per-period amplitude over the recorded window (the model's own
      uncertainty there), and its Jacobian row is zero (it carries no information on the
      parameters into the covariance).
    * *Failed points* (a numerical failure, a lost worker): the model explains nothing
      there, so the residual is the data over sigma (the optimizer is never rewarded for a
      failure); the point is left out of the variance and covariance.
    All three are counted in the report, with the reasons the standard errors may be
    unreliable (rank deficiency, a bound reached, more than a quarter of the derivatives
    one-sided or zero, more than a quarter of the points down-weighted by the loss, i.e.
    a model that misses the data).

Weights and loss
    Residuals ``r_i = (A_model - A_data) / sigma_i`` with ``sigma_i`` from the data's
    ``sigma`` column (mm) or, without it, :data:`DEFAULT_SIGMA_FRACTION` of the largest
    measured amplitude for every point.  ``loss = "soft_l1"`` with ``f_scale = 3``
    (:data:`DEFAULT_F_SCALE`): residuals up to ~3 sigma count as in least squares, larger
    ones about linearly.  ``--loss linear`` is plain least squares.

Uncertainty
    :func:`vibeam.identify.linear.uncertainty`: ``s^2 (J^T J)^-1`` at the solution; with a robust
    loss Huber's covariance of an M-estimator (``psi``, ``psi'`` of the loss in place of the
    residual and 1).
"""
from __future__ import annotations

import dataclasses
import math
import re
import sys
import time
import typing
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from vibeam.case.contact import ContactSpec, StopSpec, model_with
from vibeam.case.expand import alias
from vibeam.case.paths import canonical, flat_key, get_value, is_canonical, is_path, key_of
from vibeam.case.paths import parse as parse_path
from vibeam.case.schema import AssessSpec, load_case, parse_case
from vibeam.case.text import case_dump, to_toml  # noqa: F401 (re-exported)
from vibeam.engine.jobs import make_job
from vibeam.engine import sweep
from vibeam.engine.sweep import assemble, default_executor, plan_lines, run_sweep
from vibeam.errors import CaseError, case_error
from vibeam.identify.linear import (CONVERGED_STEP_SE, NOISE_TEST_LEVEL, irls_weights, loss_cost, loss_psi,
                                    noise_consistent, noise_interval, param_unit, remaining_step, report_decay,
                                    report_linear, uncertainty)
from vibeam.io.outdir import OutputLock, check_folder, check_outputs, default_folder, write_text_file
from vibeam.io.reference import Reference, read_reference  # noqa: F401 (re-exported)
from vibeam.io.results import write_results
from vibeam.models.scene import outputs
from vibeam.plots import style
from vibeam.plots.lazy import plt
from vibeam.plots.sweep import save_close

DEFAULT_LOSS = "soft_l1"
#: f_scale of the robust loss, in units of sigma
DEFAULT_F_SCALE = 3.0
#: sigma of every point when the data have no ``sigma`` column: this fraction of the largest amplitude
DEFAULT_SIGMA_FRACTION = 0.02
#: floor of the sweep's relative accuracy: round-off of the event solvers
EPS_FLOOR = 1e-13
#: the range of ``f_scale`` (units of sigma): below it every residual is an outlier of the loss and
#: ``(r / f_scale)^2`` overflows; above it the robust loss is least squares (``--loss linear``) and
#: scipy's cost ``f_scale^2 rho`` loses its precision
F_SCALE_RANGE = (1e-3, 1e3)
#: a measured amplitude more than this many times the model's largest at the start is refused (not an
#: amplitude of the scene: another unit, a corrupted value)
DATA_SCALE_LIMIT = 1e6
#: magnitude used for a parameter's finite-difference step when its value is zero
TYPICAL_SCALE = {"gap_mm": 0.01, "contact_gap_mm": 0.01, "Delta": 1e-4, "damping_ratio": 0.01, "beta": 0.01,
                 "rayleigh_alpha_1_s": 0.1, "R": 0.1, "rotary_inertia_kg_m2": 1e-6}
#: two one-sided differences agree when they differ by less than this fraction of the larger
SLOPE_AGREEMENT = 0.5
LOSSES = ("linear", "soft_l1", "huber", "cauchy", "arctan")


# ============================================================================ parameters
def owner_of(name: str, model_spec_cls) -> tuple:
    """``(pydantic class, field)`` whose bounds bound the number ``name`` (a flat key or a
    parameter path, :mod:`vibeam.case.paths`): a law's key the contact table's
    (:class:`vibeam.case.contact.ContactSpec`), a stop's own key the stop table's
    (:class:`vibeam.case.contact.StopSpec`), any other the model table's ``model_spec_cls``."""
    if not is_path(name):
        return model_spec_cls, name
    kind, _, key = parse_path(name)
    return {"law": ContactSpec, "stop": StopSpec}.get(kind, model_spec_cls), key


def _nested_tables(spec) -> bool:
    """Whether the validated ``[model]`` ``spec`` keeps the canonical tables as tables (a structure
    given by its matrices, the continuum, a mesh: ``spec.system``, ``spec.stop``,
    ``spec.excitation``) rather than expanding them into flat keys (the SDOF's and the beam's)."""
    return all(k in type(spec).model_fields for k in ("system", "stop", "excitation"))


def start_and_owner(spec, table: dict, name: str) -> tuple[float, type, str]:
    """``(value, pydantic class, field)`` of the fitted number ``name`` (a flat key or a path, as
    :func:`check_params` returns it): its start value, the case's (as written, else the
    validated default), and the class and field whose schema bounds bound it
    (:func:`schema_bounds`).  On nested canonical tables (:func:`_nested_tables`) a flat key is
    the alias of the path it stands for (``amplitude_mm`` -> ``excitation.amplitude_mm``, ``R``
    -> ``stops[0].law.R``) and a system's or excitation's key is bounded by its own table's class.

    Raises
    ------
    vibeam.case.schema.CaseError
        A number the case does not give and has no default for (one line naming ``name``).
    """
    nested = _nested_tables(spec)
    if nested and not is_canonical(table) and not is_path(name):
        # a flat key of the shorthand (vibeam.case.expand): its value as the scene reads it (given, or
        # the validated default), bounded by the canonical table it expands into (R -> stops[0].law.R)
        path = alias(spec.fidelity, name) or name
        v = spec.shorthand().get(name)
    else:
        path = canonical(table, name) if nested else name
        v = get_value(table, path) if is_path(path) else None
    cls, key = owner_of(path, type(spec))
    if is_path(path) and nested:
        kind, i, key = parse_path(path)
        if kind == "model":
            owner = spec.excitation if path.startswith("excitation.") else spec.system
            cls = type(owner)
            if v is None:
                v = getattr(owner, key, None)
        elif v is None:
            v = getattr(spec.stop[i], key, None)
    elif not is_path(path):
        v = spec.model_dump().get(name)
    if not isinstance(v, (int, float)) or isinstance(v, bool):
        raise case_error(f"'--params' = {name!r}: the case gives no number for it (value {v!r}); allowed: a "
                         f"number the case's [model] gives")
    return float(v), cls, key


def schema_bounds(spec_cls, name: str) -> tuple[float, float, bool, bool]:
    """``(lower, upper, lower_open, upper_open)`` of a model key from the case schema
    (pydantic ``ge``/``gt``/``le``/``lt``); +-inf when unbounded."""
    lo, hi, lo_open, hi_open = -np.inf, np.inf, False, False
    f = spec_cls.model_fields[name]
    metas = list(f.metadata)

    def walk(ann):
        for a in typing.get_args(ann):
            if hasattr(a, "metadata"):
                metas.extend(a.metadata)
            walk(a)
        if hasattr(ann, "__metadata__"):
            for m in ann.__metadata__:
                metas.extend(getattr(m, "metadata", [m]))

    walk(f.annotation)
    for m in metas:
        if getattr(m, "ge", None) is not None:
            lo, lo_open = max(lo, float(m.ge)), False
        if getattr(m, "gt", None) is not None:
            lo, lo_open = max(lo, float(m.gt)), True
        if getattr(m, "le", None) is not None:
            hi, hi_open = min(hi, float(m.le)), False
        if getattr(m, "lt", None) is not None:
            hi, hi_open = min(hi, float(m.lt)), True
    return lo, hi, lo_open, hi_open


def check_params(case, params, source: str = "") -> list[str]:
    """Validate ``--params`` against the numeric keys of the case's ``[model]``: the names as the fit
    uses them (``system.<key>`` / ``excitation.<key>`` as their flat key), each parameter once
    (an alias and its path, ``R`` and ``stops[0].law.R``, are one parameter:
    :func:`vibeam.case.paths.canonical`).

    Raises
    ------
    vibeam.case.schema.CaseError
        Naming the parameter and the allowed keys.
    """
    allowed = case.map_parameters()
    where = f"{source}: " if source else ""
    if not params:
        raise case_error(f"{where}'--params' is empty; allowed: {', '.join(allowed)}")
    out = []
    for p in params:
        try:
            q = flat_key(p)          # system.<key> / excitation.<key>: the flat key
        except ValueError as e:
            raise case_error(f"{where}'--params' = {p!r}: {e}") from None
        if q not in allowed:
            raise case_error(f"{where}'--params' = {p!r} is not a numeric key of [model]; allowed: "
                             f"{', '.join(allowed)}")
        out.append(q)
    seen: dict = {}
    for p, q in zip(params, out):
        c = canonical(case.model, q)
        if c in seen:
            same = "repeated" if seen[c] == p else f"names the same parameter as {seen[c]!r} ({c})"
            raise case_error(f"{where}'--params' = {p!r} {same}; allowed: each parameter once")
        seen[c] = p
    return out


def default_params(case) -> list[str]:
    """The drive's amplitude and R (Sec. 7 fitted gamma and R): ``gain, R`` for a physical scene,
    ``B, R`` for a nondimensional one; on nested canonical tables (a structure given by its
    matrices, a continuum, a mesh: :func:`_nested_tables`) ``excitation.<the amplitude key of its
    kind>`` and ``stops[0].law.R``."""
    spec = case.model_spec()
    if _nested_tables(spec) and is_canonical(case.model):
        ex = spec.excitation
        return [f"excitation.{ex.AMPLITUDE_KEYS[ex.kind]}", "stops[0].law.R"]
    return ["gain", "R"] if getattr(spec, "physical", False) else ["B", "R"]


# ============================================================================ the sweep at the data
def amplitude_spread(traj) -> dict:
    """Sweep assessment hook: the spread of the per-period amplitude over the recorded window,
    the standard deviation over recorded periods of each period's minimum of the sampled q
    (nondimensional; ~0 for a period-1 orbit, the attractor's spread for a non-periodic one)."""
    try:
        spp, n = traj.samples_per_period, traj.n_record
        if traj.status == "failed" or n < 2:
            return {"amplitude_spread": math.nan}
        m = traj.samples[: n * spp, 0].reshape(n, spp).min(axis=1)
        return {"amplitude_spread": float(np.std(m))}
    except Exception:  # pragma: no cover - a malformed record of a failed point
        return {"amplitude_spread": math.nan}


@dataclass
class Evaluation:
    """The model's FRC at the data points for one parameter vector (one sweep).

    ``amplitude``, ``spread`` in the data's units; ``period`` (-1 no impact, 0 not periodic,
    n); ``status`` (``failed`` also when the model could not be built, ``message`` says why).
    """

    x: np.ndarray
    amplitude: np.ndarray
    period: np.ndarray
    status: np.ndarray
    spread: np.ndarray
    message: str = ""
    messages: np.ndarray | None = None
    line_rows: list | None = None
    job: object = None
    sweeps: list | None = None

    @property
    def failed(self) -> np.ndarray:
        return (self.status == "failed") | ~np.isfinite(self.amplitude)

    @property
    def nonperiodic(self) -> np.ndarray:
        return (self.period == 0) & ~self.failed


class FitProblem:
    """A case's run, measured points and fitted parameters: builds and runs the sweeps.

    Parameters
    ----------
    case : vibeam.case.schema.Case
    run : run spec of ``case``
    ref : Reference
    params : list of str
        Numeric model keys to fit (validated by :func:`check_params`).
    executor : concurrent.futures.Executor
        Where the sweep lines run (:func:`vibeam.engine.sweep.run_lines`).
    source : str
        Case file name for messages.

    Raises
    ------
    vibeam.case.schema.CaseError
        If the data lie outside the case's frequency range or need a physical scene.
    """

    def __init__(self, case, run, ref: Reference, params, executor, source: str = ""):
        # the fit needs the FRC only: no assessments (spectra, sensor record) are computed
        self.case = case.model_copy(update={"assess": AssessSpec()})
        self.run = run
        self.ref = ref
        self.params = list(params)
        self.executor = executor
        self.source = source
        self.base = dict(run.model)
        spec = case.model_spec(self.base) if self.base else case.model_spec()
        self.spec_cls = type(spec)
        table = model_with(case.model, self.base)
        # a flat key from the validated table; a parameter path from the table as written
        starts = [start_and_owner(spec, table, p) for p in self.params]
        self.x0 = np.array([v for v, _, _ in starts])
        b = [schema_bounds(cls, key) for _, cls, key in starts]
        self.lb = np.array([v[0] for v in b])
        self.ub = np.array([v[1] for v in b])
        typ = np.array([abs(v) if v != 0 else TYPICAL_SCALE.get(key_of(p), 1.0) for p, v in zip(self.params, self.x0)])
        # open bounds (gt/lt) are kept a relative hair away
        self.lb_eff = np.where([v[2] for v in b], self.lb + 1e-9 * typ, self.lb)
        self.ub_eff = np.where([v[3] for v in b], self.ub - 1e-9 * typ, self.ub)
        self.typ = typ
        self.evaluations = 0
        self._cache: dict = {}
        self.eps_rel = EPS_FLOOR
        self.accuracy = np.zeros(ref.n)
        try:
            out0 = outputs(spec.scene())
        except CaseError as e:      # a model that cannot be built: name the case file, as `vibeam run`
            if source and not str(e).startswith(f"{source}: "):
                raise case_error(f"{source}: {e}") from None
            raise
        self.physical = bool(out0.natural_frequency_hz and out0.length_m)
        if ref.physical and not self.physical:
            raise case_error(f"{ref.source}: 'frequency_hz,amplitude_mm' data need a physical scene; "
                         f"{source or case.name} is nondimensional (use 'Omega,amplitude')")
        self._check_range(out0.natural_frequency_hz)
        if ref.sigma is None and not float(np.max(np.abs(ref.y))) > 0.0:
            raise case_error(f"{ref.source}: every '{ref.y_name}' is 0: without a 'sigma' column the residuals are "
                         f"scaled by {DEFAULT_SIGMA_FRACTION:.0%} of the largest amplitude, which is 0; give a "
                         f"'sigma' column (> 0) or data with a response")
        self.sigma = ref.sigma if ref.sigma is not None else \
            np.full(ref.n, DEFAULT_SIGMA_FRACTION * float(np.max(np.abs(ref.y))))
        self.directions = [d for d in ("up", "down") if (ref.direction == d).any()]

    # ------------------------------------------------------------------ checks
    def _check_range(self, fn):
        sw = self.case.sweep
        if sw.frequency_hz is not None:
            a, b, _ = sw.frequency_hz
            key, unit = "frequency_hz", "Hz"
            x = self.ref.x if self.ref.x_name == "frequency_hz" else self.ref.x * fn
        else:
            a, b, _ = sw.Omega
            key, unit = "Omega", ""
            x = self.ref.x if self.ref.x_name == "Omega" else self.ref.x / fn
        lo, hi = min(a, b), max(a, b)
        tol = 1e-9 * max(abs(lo), abs(hi))
        bad = np.flatnonzero((x < lo - tol) | (x > hi + tol))
        if bad.size:
            i = int(bad[0])
            raise case_error(f"{self.ref.source}: '{self.ref.x_name}' = {self.ref.x[i]:g} (point {i + 1}) is outside "
                         f"the case's sweep range {lo:g} ... {hi:g}{(' ' + unit) if unit else ''} "
                         f"({self.source or self.case.name} [sweep] {key}); allowed: points inside the swept "
                         f"range (widen [sweep] {key} or leave the point out)")

    # ------------------------------------------------------------------ building sweeps
    def overrides(self, x) -> dict:
        return dict(self.base, **{p: float(v) for p, v in zip(self.params, x)})

    def job(self, x):
        """The runner's job (solver and sweep) of the run at parameters ``x``."""
        return make_job(self.case, self.run, self.overrides(x))

    def _sweeps(self, job, transient_factor: int = 1):
        """One :class:`vibeam.engine.sweep.Sweep` per measured direction, at the data's frequencies."""
        fn = outputs(job.solver.scene).natural_frequency_hz
        out = []
        for d in self.directions:
            sel = self.ref.direction == d
            xs = np.unique(self.ref.x[sel])
            Om = xs / fn if self.ref.x_name == "frequency_hz" else xs
            sw = dataclasses.replace(job.sweep, Omega=Om, direction=d, assess=(amplitude_spread,),
                                     samples_per_period=self.case.sweep.samples_per_period,
                                     transient_periods=max(job.sweep.transient_periods, 1) * transient_factor
                                     if transient_factor > 1 else job.sweep.transient_periods)
            out.append((d, xs, sw))
        return out

    def evaluate_many(self, xs, transient_factors=None) -> list[Evaluation]:
        """Sweep the model at each parameter vector in ``xs``: all lines go to the executor in
        one :func:`vibeam.engine.sweep.run_lines` call (``transient_factors``: per vector, a multiple
        of the case's transient periods; default 1)."""
        plans = []
        all_lines = []
        factors = list(transient_factors) if transient_factors is not None else [1] * len(xs)
        for x, transient_factor in zip(xs, factors):
            x = np.asarray(x, float)
            tag = f"e{self.evaluations}"
            self.evaluations += 1
            try:
                job = self.job(x)
                sweeps = self._sweeps(job, transient_factor)
            except CaseError as e:
                plans.append((x, None, None, str(e), []))
                continue
            lines = []
            for d, xd, sw in sweeps:
                lines.extend(plan_lines(job.solver, sw, run=tag))
            plans.append((x, job, sweeps, "", lines))
            all_lines.extend(lines)
        done = sweep.run_lines(all_lines, executor=self.executor) if all_lines else {}
        return [self._collect(x, job, sweeps, msg, lines, done) for x, job, sweeps, msg, lines in plans]

    def _collect(self, x, job, sweeps, msg, lines, done) -> Evaluation:
        n = self.ref.n
        amp = np.full(n, np.nan)
        per = np.zeros(n, dtype=np.int64)
        st = np.array(["failed"] * n, dtype=object)
        spread = np.full(n, np.nan)
        msgs = np.array([""] * n, dtype=object)
        if job is None:
            return Evaluation(x, amp, per, st, spread, msg or "model could not be built")
        yf = outputs(job.solver.scene).length_m * 1e3 if self.ref.y_name == "amplitude_mm" else 1.0
        value = {}
        line_rows = []
        for l in lines:
            rows = done[(l.run, l.key)]
            line_rows.append(rows)
            for W, row in zip(l.Omega, rows):
                value[(l.direction, float(W))] = row
        fn = outputs(job.solver.scene).natural_frequency_hz
        for i in range(n):
            xi = self.ref.x[i]
            W = xi / fn if self.ref.x_name == "frequency_hz" else xi
            row = value.get((self.ref.direction[i], float(W)))
            if row is None:
                continue
            st[i] = row.get("status", "failed")
            amp[i] = float(row.get("amplitude", np.nan)) * yf
            per[i] = int(row.get("period", 0) or 0)
            spread[i] = float(row.get("amplitude_spread", np.nan)) * yf
            msgs[i] = str(row.get("message", "") or "")
        return Evaluation(x, amp, per, st, spread, "", msgs, line_rows, job, sweeps)

    def evaluate(self, x) -> Evaluation:
        key = np.asarray(x, float).tobytes()
        if key not in self._cache:
            self._cache[key] = self.evaluate_many([x])[0]
        return self._cache[key]

    def remember(self, ev: Evaluation) -> None:
        self._cache[np.asarray(ev.x, float).tobytes()] = ev

    # ------------------------------------------------------------------ residuals
    def scale(self, ev: Evaluation) -> np.ndarray:
        """Per-point divisor: sigma, widened by the model's spread at non-periodic points."""
        s = self.sigma.copy()
        np_ = ev.nonperiodic
        sp = np.nan_to_num(ev.spread, nan=0.0)
        s[np_] = np.sqrt(s[np_] ** 2 + sp[np_] ** 2)
        return s

    def residuals(self, ev: Evaluation) -> np.ndarray:
        """``(A_model - A_data) / s``; failed points ``-A_data / sigma`` (module doc)."""
        r = (ev.amplitude - self.ref.y) / self.scale(ev)
        f = ev.failed
        r[f] = -self.ref.y[f] / self.sigma[f]
        return r

    def measure_accuracy(self, ev0: Evaluation, ev2: Evaluation) -> None:
        """The sweep's accuracy from a sweep with twice the transient (module doc)."""
        ok = ~ev0.failed & ~ev2.failed & (ev0.period != 0) & (ev0.period == ev2.period)
        d = np.abs(ev2.amplitude - ev0.amplitude)
        self.accuracy = np.where(ok, d, np.nan)
        amax = float(np.nanmax(np.abs(ev0.amplitude))) if np.isfinite(ev0.amplitude).any() else 1.0
        meas = float(np.nanmax(d[ok]) / amax) if ok.any() else EPS_FLOOR
        self.eps_measured = meas
        self.eps_rel = max(meas, EPS_FLOOR)
        self.accuracy = np.where(ok, np.maximum(d, EPS_FLOOR * amax), np.nan)

    @property
    def steps(self) -> np.ndarray:
        """Finite-difference steps ``eps^(1/3) typ_j``."""
        return self.eps_rel ** (1.0 / 3.0) * self.typ


# ============================================================================ the Jacobian
def finite_difference_jacobian(problem: FitProblem, x, base: Evaluation) -> tuple[np.ndarray, dict]:
    """Jacobian of the residuals by central differences over parallel sweeps (module doc).

    Parameters
    ----------
    problem : FitProblem
    x : ndarray, shape (p,)
    base : Evaluation
        The sweep at ``x``.

    Returns
    -------
    J : ndarray, shape (n, p)
        d r_i / d x_j (zero rows at failed and non-periodic points).
    info : dict
        ``one_sided`` and ``zeroed`` (entries), ``method``, ``steps``.
    """
    p = len(problem.params)
    h = problem.steps
    xs, where = [], []
    for j in range(p):
        for sgn in (1.0, -1.0):
            xp = np.array(x, float)
            xp[j] += sgn * h[j]
            if problem.lb_eff[j] <= xp[j] <= problem.ub_eff[j]:
                where.append((j, sgn))
                xs.append(xp)
    evs = problem.evaluate_many(xs)
    side = {k: ev for k, ev in zip(where, evs)}
    A0 = base.amplitude
    s = problem.scale(base)
    acc = np.nan_to_num(problem.accuracy, nan=0.0)
    dead = base.failed | base.nonperiodic
    J = np.zeros((problem.ref.n, p))
    one_sided = zeroed = 0
    for j in range(p):
        d = {}
        for sgn in (1.0, -1.0):
            ev = side.get((j, sgn))
            if ev is None:
                continue
            ok = ~ev.failed & (ev.period == base.period) & ~dead
            d[sgn] = (np.where(ok, (ev.amplitude - A0) * sgn / h[j], np.nan))
        dp = d.get(1.0, np.full(A0.size, np.nan))
        dm = d.get(-1.0, np.full(A0.size, np.nan))
        both = np.isfinite(dp) & np.isfinite(dm)
        noise = 4 * acc / h[j]
        agree = both & (np.abs(dp - dm) <= SLOPE_AGREEMENT * np.maximum(np.abs(dp), np.abs(dm)) + noise)
        col = np.where(agree, 0.5 * (dp + dm), np.nan)
        # disagreeing sides: the smaller slope (the other side jumped); a single side as it is
        pick = np.where(np.abs(dp) <= np.abs(dm), dp, dm)
        col = np.where(both & ~agree, pick, col)
        col = np.where(~both & np.isfinite(dp), dp, col)
        col = np.where(~both & np.isfinite(dm), dm, col)
        live = ~dead
        one_sided += int(np.sum(live & np.isfinite(col) & ~agree))
        zeroed += int(np.sum(live & ~np.isfinite(col)))
        J[:, j] = np.where(np.isfinite(col), col, 0.0) / s
    J[dead] = 0.0
    return J, {"method": "central differences over parallel sweeps", "one_sided": one_sided,
               "zeroed": zeroed, "steps": h.copy()}


# ============================================================================ the fit
@dataclass
class FitResult:
    """Result of :func:`fit_case`.

    Attributes
    ----------
    case_name, run, reference : str
    parameters : list of str
    units : list of str
    initial, estimate, standard_error : ndarray, shape (p,)
    correlation, covariance : ndarray, shape (p, p)
    lower_bound, upper_bound : ndarray, shape (p,)
    x_name, y_name : str
        Data columns (``frequency_hz``/``amplitude_mm`` or ``Omega``/``amplitude``).
    x, y, sigma : ndarray, shape (n,)
        Data (``sigma`` as used: given or the default).
    direction : ndarray of str, shape (n,)
    model, model_spread : ndarray, shape (n,)
        The fitted FRC at the data points and its spread at non-periodic points.
    model_period : ndarray of int, shape (n,)
    model_status : ndarray of str, shape (n,)
    residuals : ndarray, shape (n,)
        ``model - data`` (units of ``y``).
    normalized_residuals : ndarray, shape (n,)
        Residuals as fitted (divided by sigma or the widened sigma).
    used : ndarray of bool, shape (n,)
        Points in the variance and covariance (not failed).
    loss_weight : ndarray, shape (n,)
        IRLS weight of the robust loss at the solution (1 = full least-squares weight).
    jacobian : ndarray, shape (n, p)
    accuracy : ndarray, shape (n,)
        The sweep's accuracy at each point (units of ``y``; NaN at non-periodic points).
    n_points, n_used, n_nonperiodic, n_failed, n_downweighted, dof : int
    s2, cost : float
    evaluations : int
        Model sweeps (parameter vectors) run, the accuracy sweep included.
    nfev, njev : int
        Residual and Jacobian evaluations of ``least_squares``.
    wall_time_s : float
    reliable : bool
        The standard errors can be trusted: the rule of :func:`verdict` (finite, a converged
        optimizer, residuals consistent with the data's sigma, ...).
    notes : list of str
        Why the standard errors may be unreliable, and what was excluded.
    message : str
        ``least_squares``'s message.
    eps_rel : float
        Relative accuracy of the sweep used for the steps.
    steps : ndarray, shape (p,)
    jacobian_info : dict
    loss, f_scale : str, float
    fitted_case_text : str
        The case with the fitted values (loads with :func:`vibeam.case.schema.parse_case`).
    final : vibeam.engine.sweep.SweepResult
        The fitted FRC as a run (for ``/runs`` of ``fit.h5``).
    """

    case_name: str
    run: str
    reference: str
    parameters: list
    units: list
    initial: np.ndarray
    estimate: np.ndarray
    standard_error: np.ndarray
    correlation: np.ndarray
    covariance: np.ndarray
    lower_bound: np.ndarray
    upper_bound: np.ndarray
    x_name: str
    y_name: str
    x: np.ndarray
    y: np.ndarray
    sigma: np.ndarray
    direction: np.ndarray
    model: np.ndarray
    model_spread: np.ndarray
    model_period: np.ndarray
    model_status: np.ndarray
    residuals: np.ndarray
    normalized_residuals: np.ndarray
    used: np.ndarray
    loss_weight: np.ndarray
    jacobian: np.ndarray
    accuracy: np.ndarray
    n_points: int
    n_used: int
    n_nonperiodic: int
    n_failed: int
    n_downweighted: int
    dof: int
    s2: float
    cost: float
    evaluations: int
    nfev: int
    njev: int
    wall_time_s: float
    reliable: bool
    notes: list
    message: str
    eps_rel: float
    eps_measured: float
    steps: np.ndarray
    jacobian_info: dict
    loss: str
    f_scale: float
    sigma_given: bool
    fitted_case_text: str = ""
    final: object = None
    paths: dict = field(default_factory=dict)

    @property
    def values(self) -> dict:
        return dict(zip(self.parameters, (float(v) for v in self.estimate)))

    def summary(self) -> str:
        """The report printed by ``vibeam fit``."""
        xl = "f (Hz)" if self.x_name == "frequency_hz" else "Omega"
        yu = "mm" if self.y_name == "amplitude_mm" else ""
        dirs = ", ".join(f"{int(np.sum(self.direction == d))} {d}" for d in ("up", "down")
                         if np.any(self.direction == d))
        out = [f"fit of {self.case_name}, run '{self.run}', against {self.reference}",
               f"  {self.n_points} points ({dirs}), {xl} {np.min(self.x):g} ... {np.max(self.x):g}; "
               f"sigma {'from the data' if self.sigma_given else f'{self.sigma[0]:.3g} {yu} for every point (no sigma column: {DEFAULT_SIGMA_FRACTION:.0%} of the largest amplitude)'}",
               f"  loss {self.loss}" + (f" (f_scale {self.f_scale:g} sigma)" if self.loss != "linear" else ""),
               ""]
        head = f"  {'parameter':<22}{'initial':>12}{'estimate':>14}{'std. error':>13}{'rel.':>9}  unit"
        out.append(head)
        for n, x0, x, s, u in zip(self.parameters, self.initial, self.estimate, self.standard_error, self.units):
            rel = f"{abs(s / x):9.2%}" if x != 0 and np.isfinite(s) else f"{'-':>9}"
            out.append(f"  {n:<22}{x0:>12.6g}{x:>14.6g}{s:>13.3g}{rel}  {u}")
        p = len(self.parameters)
        if p > 1:
            out.append("\n  correlation")
            out.append("  " + " " * 22 + "".join(f"{n[:10]:>11}" for n in self.parameters))
            for i, n in enumerate(self.parameters):
                out.append(f"  {n:<22}" + "".join(f"{self.correlation[i, j]:>11.3f}" for j in range(p)))
        rms = float(np.sqrt(np.mean(self.residuals[self.used] ** 2))) if self.used.any() else math.nan
        out += ["",
                f"  points used {self.n_used} of {self.n_points} (p = {p}, dof = {self.dof}); model not periodic at "
                f"{self.n_nonperiodic} (down-weighted by their spread), failed at {self.n_failed}; "
                f"{self.n_downweighted} point(s) down-weighted by the loss (weight < 0.5)",
                f"  residual rms {rms:.4g} {yu}, s^2 = {self.s2:.4g} (in sigma^2), cost {self.cost:.4g} ({self.loss} "
                f"loss: f_scale^2/2 sum rho((r/f_scale)^2), as in the progress lines; 0.5 sum r^2 = "
                f"{0.5 * float(np.sum(self.normalized_residuals[self.used] ** 2)):.4g})",
                f"  evaluations: {self.evaluations} sweeps (least_squares: {self.nfev} residual, {self.njev} "
                f"Jacobian evaluations), wall time {self.wall_time_s:.2f} s",
                f"  Jacobian: {self.jacobian_info.get('method', '')}, step eps^(1/3) |x| with eps = "
                f"{self.eps_rel:.2g} (the sweep's accuracy, measured {self.eps_measured:.2g} by doubling the "
                f"transient; floor {EPS_FLOOR:g}); {self.jacobian_info.get('one_sided', 0)} one-sided and "
                f"{self.jacobian_info.get('zeroed', 0)} zero entries at periodic points",
                f"  {verdict(self)}",
                f"  optimizer: {self.message}"]
        return "\n".join(out)

    # ------------------------------------------------------------------ files
    def h5_tables(self) -> tuple[dict, dict]:
        """``extra`` and ``extra_attrs`` of :func:`vibeam.io.results.write_results` for ``/fit``."""
        yu = "mm" if self.y_name == "amplitude_mm" else "1"
        t = {"parameters": np.array(self.parameters, dtype=object), "units": np.array(self.units, dtype=object),
             "initial": self.initial, "estimate": self.estimate, "standard_error": self.standard_error,
             "correlation": self.correlation, "covariance": self.covariance,
             "lower_bound": self.lower_bound, "upper_bound": self.upper_bound, "step": self.steps,
             self.x_name: self.x, self.y_name: self.y, "direction": np.array(self.direction, dtype=object),
             "sigma": self.sigma, "model_" + self.y_name: self.model, "model_spread": self.model_spread,
             "model_period": self.model_period, "model_status": np.array(self.model_status, dtype=object),
             "residuals": self.residuals, "normalized_residuals": self.normalized_residuals,
             "used": self.used.astype(np.int8), "loss_weight": self.loss_weight, "jacobian": self.jacobian,
             "sweep_accuracy": self.accuracy}
        per_param = "per parameter: /fit/units"
        a = {"fit": {"case": self.case_name, "run": self.run, "reference": self.reference, "loss": self.loss,
                     "f_scale": self.f_scale, "n_points": self.n_points, "n_used": self.n_used,
                     "n_nonperiodic": self.n_nonperiodic, "n_failed": self.n_failed,
                     "n_downweighted": self.n_downweighted, "n_parameters": len(self.parameters),
                     "dof": self.dof, "s2": self.s2, "cost": self.cost, "evaluations": self.evaluations,
                     "nfev": self.nfev, "njev": self.njev, "wall_time_s": self.wall_time_s,
                     "reliable": self.reliable, "notes": "; ".join(self.notes), "message": self.message,
                     "eps_rel": self.eps_rel, "eps_measured": self.eps_measured,
                     "jacobian_method": self.jacobian_info.get("method", ""),
                     "jacobian_one_sided": self.jacobian_info.get("one_sided", 0),
                     "jacobian_zeroed": self.jacobian_info.get("zeroed", 0),
                     "sigma_given": self.sigma_given,
                     "cor_identification": "R from the sensor's time series (paper Sec. 5.1): [effects.sensor] "
                                           "identify_R, vibeam.engine.sensor (cases/README.md, 'Effects and the sensor')"}}
        # UDUNITS units (CF); an array over parameters of different units has none, its comment
        # names the per-parameter units, and each array says what it is in long_name
        what = {"initial": "parameter value at the start of the fit", "estimate": "fitted parameter value",
                "standard_error": "standard error of the fitted parameter", "lower_bound": "lower bound of the "
                "parameter", "upper_bound": "upper bound of the parameter", "step": "finite-difference step of "
                "the parameter"}
        for k, ln in what.items():
            a[f"fit/{k}"] = {"long_name": ln, "comment": per_param}
        a["fit/covariance"] = {"long_name": "covariance of the fitted parameters",
                               "comment": "units: the product of the two parameters' units (/fit/units)"}
        a["fit/correlation"] = {"units": "1", "long_name": "correlation of the fitted parameters"}
        for k, ln in (("sigma", "standard deviation of the data"), ("model_" + self.y_name, "fitted model's "
                      + self.y_name.removesuffix("_mm")), ("model_spread", "fitted model's spread over the "
                      "record (non-periodic points)"), ("sweep_accuracy", "sweep's accuracy at the point")):
            a[f"fit/{k}"] = {"units": yu, "long_name": ln}
        a[f"fit/{self.y_name}"] = {"units": yu, "long_name": "measured " + self.y_name.removesuffix("_mm")}
        a["fit/used"] = {"units": "1", "long_name": "point used by the fit (1 used, 0 left out)"}
        a["fit/residuals"] = {"units": yu, "long_name": "residual, model - data"}
        a["fit/normalized_residuals"] = {"units": "1", "long_name": "normalized residual, residual / sigma "
                                         "(sigma widened at non-periodic points)"}
        a["fit/jacobian"] = {"long_name": "Jacobian of the normalized residuals",
                             "comment": "units: 1 / the parameter's unit (/fit/units), per column"}
        a["fit/loss_weight"] = {"units": "1", "long_name": "IRLS weight rho' of the robust loss"}
        a[f"fit/{self.x_name}"] = ({"units": "Hz", "long_name": "forcing frequency"} if self.x_name == "frequency_hz"
                                   else {"units": "1", "long_name": "forcing frequency / natural frequency, Omega"})
        a["fit/model_period"] = {"units": "1", "long_name": "fitted model's period-n (forcing periods)",
                                 "comment": "0 = not periodic within 8 periods, -1 = no impact"}
        return t, a

    def write(self, out_dir, case_text: str = "", plots: bool = True) -> dict:
        """Write ``fit.h5`` (through :func:`vibeam.io.results.write_results`), ``fit.png`` and the
        fitted case ``<case>-fit.toml`` into ``out_dir``; returns their paths."""
        out_dir = Path(out_dir)
        out_dir.mkdir(parents=True, exist_ok=True)
        tables, attrs = self.h5_tables()
        runs = [self.final] if self.final is not None else []
        h5 = write_results(out_dir / "fit.h5", runs, self.case_name, case_text, extra={"fit": tables},
                           extra_attrs=attrs)
        paths = {"h5": h5}
        if self.fitted_case_text:
            cp = out_dir / f"{self.case_name}-fit.toml"
            write_text_file(cp, self.fitted_case_text)
            paths["case"] = cp
        if plots:
            paths["png"] = plot_fit(self, out_dir / "fit.png")
        return paths


def fit_case(case, reference, params=None, run=None, executor=None, jobs: int | None = 1,
             loss: str = DEFAULT_LOSS, f_scale: float = DEFAULT_F_SCALE, max_evaluations: int = 60,
             source: str = "", reference_run: str | None = None, jacobian=finite_difference_jacobian,
             x0: dict | None = None, xtol: float = 1e-8, log=None) -> FitResult:
    """Fit model parameters of one run of a case to measured FRC points (module doc).

    Parameters
    ----------
    case : vibeam.case.schema.Case
        The scene (its quick variant for ``--quick``); its ``[model]`` values start the fit.
    reference : Reference or str or Path
        Measured points or a file :func:`read_reference` reads.
    params : sequence of str, optional
        Numeric ``[model]`` keys to fit; default :func:`default_params`.
    run : str, optional
        Name of the run to fit (default: the first).
    executor : concurrent.futures.Executor, optional
        Where sweep lines run; default a local pool of ``jobs`` workers (inline for 1).
    jobs : int or None
        Workers of the default executor.
    loss, f_scale : str, float
        ``scipy.optimize.least_squares`` loss (``soft_l1`` default, ``linear``, ``huber``,
        ``cauchy``, ``arctan``) and its scale in units of sigma.
    max_evaluations : int
        ``max_nfev`` of ``least_squares`` (residual evaluations, i.e. base sweeps).
    source : str
        Case file name (for messages and the fitted case's comment).
    reference_run : str, optional
        Run of an HDF5 reference.
    jacobian : callable
        ``jacobian(problem, x, base) -> (J, info)``; default :func:`finite_difference_jacobian`.
    x0 : dict, optional
        Starting values (default: the case's).
    xtol : float
        ``least_squares`` xtol (ftol = xtol, gtol = 1e-10).
    log : callable, optional
        Progress messages (e.g. ``print`` to stderr).

    Returns
    -------
    FitResult

    Raises
    ------
    vibeam.case.schema.CaseError
        On a parameter that is not a numeric model key, data outside the case's frequency
        range, an unknown run or loss, or unreadable data.
    """
    # lazy: keeps scipy.optimize (0.35 s) out of `vibeam regress` and `vibeam cost`
    from scipy.optimize import least_squares

    t0 = time.perf_counter()
    if loss not in LOSSES:
        raise case_error(f"'--loss' = {loss!r} is not allowed; allowed: {', '.join(LOSSES)}")
    check_f_scale(f_scale)
    ref = reference if isinstance(reference, Reference) else read_reference(reference, reference_run)
    params = check_params(case, list(params) if params else default_params(case), source)
    r = _pick_run(case, run, source)
    own = executor is None
    ex = default_executor(jobs, 2 * len(params) + 1) if own else executor
    try:
        prob = FitProblem(case, r, ref, params, ex, source)
        if ref.n < len(params):
            raise case_error(f"{ref.source}: {ref.n} points cannot determine {len(params)} parameters")
        start = prob.x0.copy()
        if x0:
            for k, v in x0.items():          # by the name check_params gives (excitation.gain -> gain)
                start[params.index(flat_key(k))] = float(v)
        start = np.clip(start, prob.lb_eff, prob.ub_eff)
        if log:
            log(f"[fit {case.name} / {r.name}] {ref.n} points, parameters {', '.join(params)}: measuring the "
                f"sweep's accuracy (transient x 2)")
        ev0, ev2 = prob.evaluate_many([start, start], transient_factors=[1, 2])
        prob.remember(ev0)
        prob.measure_accuracy(ev0, ev2)
        with np.errstate(over="ignore", invalid="ignore"):
            r0 = prob.residuals(ev0)
            # the cost sums their squares, the loss those of r / f_scale
            r0[~np.isfinite(np.square(r0 / min(1.0, f_scale)))] = np.inf
        amax = float(np.nanmax(np.abs(ev0.amplitude))) if np.isfinite(ev0.amplitude).any() else 0.0
        huge = np.abs(ref.y) > DATA_SCALE_LIMIT * amax if amax > 0 else np.zeros(ref.n, bool)
        if huge.any() or not np.isfinite(r0).all():
            bad = np.flatnonzero(huge) if huge.any() else np.flatnonzero(~np.isfinite(r0))
            raise case_error(_start_residual_error(ref, prob, ev0, int(bad[0])))
        jac_cache: dict = {}
        info_last: dict = {}

        def fun(x):
            return prob.residuals(prob.evaluate(x))

        def jac(x):
            key = np.asarray(x, float).tobytes()
            if key not in jac_cache:
                J, info = jacobian(prob, np.asarray(x, float), prob.evaluate(x))
                jac_cache[key] = (J, info)
                if log:
                    log(f"  x = {np.array2string(np.asarray(x), precision=6)}, cost "
                        f"{loss_cost(fun(x), loss, f_scale):.6g} ({loss} loss) (Jacobian {len(jac_cache)}, "
                        f"{prob.evaluations} sweeps so far; at most {max_evaluations} residual evaluations)")
            info_last.update(jac_cache[key][1])
            return jac_cache[key][0]

        res = least_squares(fun, start, jac=jac, bounds=(prob.lb_eff, prob.ub_eff), loss=loss, f_scale=f_scale,
                            x_scale=prob.typ, xtol=xtol, ftol=xtol, gtol=1e-10, max_nfev=max_evaluations)
        x = res.x
        ev = prob.evaluate(x)
        J = jac(x)
        info = jac_cache[x.tobytes()][1]
        rr = prob.residuals(ev)
        used = ~ev.failed
        w = irls_weights(rr, loss, f_scale)
        psi, dpsi = loss_psi(rr, loss, f_scale)
        at_bound = (res.active_mask != 0) | np.isclose(x, prob.lb_eff, rtol=0, atol=1e-12 * prob.typ) | \
            np.isclose(x, prob.ub_eff, rtol=0, atol=1e-12 * prob.typ)
        unc = uncertainty(J[used], rr[used], params, psi=psi[used] if loss != "linear" else None,
                          dpsi=dpsi[used], at_bound=at_bound)
        notes = list(unc.notes) + list(ref.notes)
        n_np, n_f = int(ev.nonperiodic.sum()), int(ev.failed.sum())
        n_dw = int(np.sum(used & (w < 0.5)))
        live = int(np.sum(used & ~ev.nonperiodic)) * len(params)
        bad_d = info.get("one_sided", 0) + info.get("zeroed", 0)
        reliable = unc.reliable and res.status > 0
        if n_f:
            notes.append(f"{n_f} point(s) failed in the model (left out; message: "
                         f"{_first_message(ev)})")
        if n_np:
            notes.append(f"{n_np} point(s) not periodic in the model: residual down-weighted by the "
                         f"attractor's spread, no derivative")
        if live and bad_d > 0.25 * live:
            reliable = False
            notes.append(f"{bad_d} of {live} derivatives one-sided or zero (jumps or period changes within "
                         f"one step): the FRC is not smooth in the parameters here")
        if n_dw > 0.25 * max(int(used.sum()), 1):
            reliable = False
            notes.append(f"{n_dw} of {int(used.sum())} points down-weighted by the loss (weight < 0.5; soft_l1: "
                         f"|r| > 1.7 f_scale): the model misses much of the data (a shifted resonance, another "
                         f"branch); the estimate is a compromise")
        if used.sum() - n_np < len(params):
            reliable = False
            notes.append("fewer periodic points than parameters")
        if prob.eps_rel > 1e-4:
            notes.append(f"the sweep has not settled (relative accuracy {prob.eps_rel:.2g}): raise "
                         f"[sweep] transient_periods")
        if res.status <= 0:
            notes.append(f"optimizer stopped: {res.message}")
        # the rule of a reliable verdict (verdict's docstring): finite standard errors, a converged
        # optimizer, residuals that scatter as the data's sigma says
        se = unc.standard_error
        bad_se = [n_ for n_, v in zip(params, se) if not np.isfinite(v)]
        if bad_se:
            reliable = False
        if bad_se and unc.reliable:      # (rank deficiency and no degrees of freedom have their notes)
            notes.append("standard error not a finite number for " + ", ".join(
                f"{n_} ({float(v):g})" for n_, v in zip(params, se) if not np.isfinite(v)))
        step = remaining_step(J[used], rr[used], w[used])
        slack = 10 * xtol * np.maximum(np.abs(x), prob.typ)
        sef = np.where(np.isfinite(se), se, 0.0)
        moving = ~at_bound & ~(np.abs(step) <= CONVERGED_STEP_SE * sef + slack)
        if moving.any():
            reliable = False
            j = int(np.argmax(np.where(moving, np.abs(step) / np.maximum(sef, 1e-300), -1.0)))
            far = (f"{abs(step[j]) / sef[j]:.3g} standard errors (allowed: {CONVERGED_STEP_SE:g})"
                   if sef[j] > 0 and np.isfinite(step[j]) else
                   f"{float(step[j]):.3g} {param_unit(params[j])} (its standard error is {float(se[j]):g})")
            notes.append(f"the optimizer did not reach the minimum: a Gauss-Newton step from the estimate would "
                         f"still move {params[j]} by {far}; it stopped after "
                         f"{res.nfev} residual evaluation(s){' at the starting values' if np.array_equal(x, start) else ''} "
                         f"({res.message})")
        if ref.sigma is None:
            notes.append("no sigma column: standard errors from the residual scatter")
        elif not noise_consistent(unc.s2, unc.dof):
            reliable = False
            lo, hi = noise_interval(unc.dof)
            why = ("the residuals are far smaller than sigma: sigma overstates the noise (or the model "
                   "interpolates the data)" if unc.s2 < lo else
                   "the residuals exceed sigma: the model does not describe the data within their scatter "
                   "(s^2 scales the standard errors)")
            notes.append(f"s^2 = {unc.s2:.3g} (in sigma^2) is outside [{lo:.3g}, {hi:.3g}], the chi-square "
                         f"spread of {unc.dof} degrees of freedom (level {NOISE_TEST_LEVEL:g}): {why}")
        final = None
        if ev.line_rows is not None:
            final = assemble(ev.job.solver, ev.sweeps[0][2], r.name, ev.line_rows,
                             float(time.perf_counter() - t0))
            final.attrs["model"] = ev.job.spec.as_written()
        text = fitted_case_text(case, r, dict(zip(params, map(float, x))), source, ref.source,
                                unc.standard_error)
        return FitResult(
            case.name, r.name, ref.source, list(params), [param_unit(p) for p in params], start.copy(), x.copy(),
            unc.standard_error, unc.correlation, unc.covariance, prob.lb, prob.ub, ref.x_name, ref.y_name,
            ref.x.copy(), ref.y.copy(), prob.sigma.copy(), ref.direction.copy(), ev.amplitude.copy(),
            np.where(ev.nonperiodic, ev.spread, np.nan), ev.period.copy(), ev.status.copy(),
            ev.amplitude - ref.y, rr, used, w, J, prob.accuracy.copy(), ref.n, int(used.sum()), n_np, n_f, n_dw,
            unc.dof, unc.s2, float(res.cost), prob.evaluations, int(res.nfev), int(res.njev or 0),
            time.perf_counter() - t0, bool(reliable), notes, str(res.message), prob.eps_rel,
            float(getattr(prob, "eps_measured", EPS_FLOOR)), prob.steps.copy(), info, loss, f_scale,
            ref.sigma is not None, text, final)
    finally:
        if own:
            ex.shutdown(wait=True, cancel_futures=True)


def check_f_scale(f_scale) -> float:
    """``--f-scale`` / ``f_scale``: a number in :data:`F_SCALE_RANGE` (units of sigma).

    Raises
    ------
    vibeam.case.schema.CaseError
        One line naming the option, the value and the range.
    """
    lo, hi = F_SCALE_RANGE
    try:
        v = float(f_scale)
    except (TypeError, ValueError):
        v = math.nan
    if not lo <= v <= hi:
        raise case_error(f"'--f-scale' = {f_scale!r} is not allowed; allowed: a number from {lo:g} to {hi:g} "
                         f"(the robust loss's scale in units of sigma; default {DEFAULT_F_SCALE:g})")
    return v


def _start_residual_error(ref, prob, ev0, i: int) -> str:
    """Why the normalised residual of point ``i`` is not finite at the start, naming what is wrong:
    the data's amplitude, the model's, or sigma."""
    y, a, sg = float(ref.y[i]), float(ev0.amplitude[i]), float(prob.sigma[i])
    yu = " mm" if ref.y_name == "amplitude_mm" else ""
    where = f"{ref.source}: point {i + 1} ({ref.x_name} = {float(ref.x[i]):g})"
    if not math.isfinite(a):
        return f"{where}: the model amplitude at the start is {a:g}; allowed: a finite amplitude (check the case)"
    scale = max(abs(a), float(np.nanmax(np.abs(ev0.amplitude))) if np.isfinite(ev0.amplitude).any() else 0.0)
    if scale > 0 and abs(y) > DATA_SCALE_LIMIT * scale:
        return (f"{where}: {ref.y_name} = {y:g}{yu} is not an amplitude of this scene: {abs(y) / scale:.3g} times "
                f"the model's largest at the start ({scale:g}{yu}); allowed: amplitudes up to {DATA_SCALE_LIMIT:g} "
                f"times the model's (is the column in another unit?)")
    return (f"{where}: sigma = {sg:g}{yu} is too small for the difference between the model amplitude {a:g}{yu} "
            f"and the data {y:g}{yu} (its square overflows); allowed: sigma values of the data's scale")


def _first_message(ev) -> str:
    """The reason of the first failed point (or of a model that could not be built)."""
    if ev.message:
        return ev.message
    for i in np.flatnonzero(ev.failed):
        if ev.messages is not None and ev.messages[i]:
            return str(ev.messages[i])
    return "see model_status in fit.h5"


def _pick_run(case, run, source=""):
    names = [r.name for r in case.run]
    if run is None:
        return case.run[0]
    for r in case.run:
        if r.name == run:
            return r
    where = f"{source}: " if source else ""
    raise case_error(f"{where}'--run' = {run!r} is not a run of the case; allowed: {', '.join(repr(n) for n in names)}")


# ============================================================================ fitted case file
def fitted_case_text(case, run, values: dict, source: str = "", reference: str = "", se=None) -> str:
    """The case with the fitted values: ``[model]`` updated, the fitted run alone (its overrides
    of fitted keys removed), a ``[map]`` of a fitted key dropped; validated before it is
    returned (:func:`vibeam.case.schema.parse_case`)."""
    data = case_dump(case)
    data["name"] = f"{case.name}-fit"
    fitted = ", ".join(f"{k} = {v:.6g}" + (f" +- {s:.2g}" if se is not None and np.isfinite(s) else "")
                       for (k, v), s in zip(values.items(), se if se is not None else [None] * len(values)))
    data["description"] = f"{case.name} run '{run.name}' with {fitted} (vibeam fit)"
    model = model_with(case.model, values)
    data["model"] = model
    rd = run.model_dump(exclude_unset=True, exclude_none=True)
    if "model" in rd:
        rd["model"] = {k: v for k, v in rd["model"].items() if k not in values}
        if not rd["model"]:
            del rd["model"]
    data["run"] = [rd]
    if case.map is not None and case.map.parameter in values:
        data.pop("map", None)
    order = ["name", "description", "model", "effects", "sweep", "quick", "regress", "assess", "map", "run"]
    data = {k: data[k] for k in order if k in data}
    head = (f"# fitted by `vibeam fit` from {source or case.name} (run '{run.name}') against {reference}\n"
            f"# {fitted}\n")
    text = head + to_toml(data) + "\n"
    parse_case(text, f"{case.name}-fit.toml")
    return text


# ============================================================================ plot
def verdict(res: FitResult) -> str:
    """The fit's verdict in one line, as ``vibeam fit`` prints it: ``standard errors reliable``
    or ``standard errors NOT reliable: <the reasons>`` (``res.notes``).

    ``res.reliable`` (:func:`fit_case`) requires all of:

    * finite standard errors (no rank deficiency, no degrees of freedom missing, no NaN);
    * a converged optimizer: ``least_squares`` stopped by a tolerance (not by
      ``max_evaluations``), and the Gauss-Newton step still left at the estimate
      (:func:`vibeam.identify.linear.remaining_step`, with the loss's IRLS weights) is at most
      :data:`~vibeam.identify.linear.CONVERGED_STEP_SE` = 0.1 standard error of each parameter
      (plus 10 xtol |x|) -- a fit that stopped where it started because its cost was flat
      (``gtol`` is absolute, so a huge sigma flattens it) fails this;
    * with a ``sigma`` column, residuals consistent with the noise: ``s^2 = chi^2 / dof`` (in
      sigma^2, Huber-corrected for a robust loss) inside the chi-square spread
      :func:`vibeam.identify.linear.noise_interval` ``[chi2.ppf(0.0005, dof), chi2.ppf(0.9995,
      dof)] / dof`` (level :data:`~vibeam.identify.linear.NOISE_TEST_LEVEL` = 0.001; 48 dof:
      [0.46, 1.81]); without a sigma column ``s^2`` is estimated from the scatter and not tested;
    * no estimate on a bound, a well-conditioned Jacobian, at most a quarter of its entries
      one-sided or zero, at most a quarter of the points down-weighted by the loss, at least
      as many periodic points as parameters.
    """
    v = "standard errors reliable" if res.reliable else "standard errors NOT reliable"
    return v + (": " + "; ".join(res.notes) if res.notes else "")


def fit_figure(res: FitResult, title: str = ""):
    """Data against the fitted FRC, with a residual panel, in vibeam's style
    (:mod:`vibeam.plots.style`): the up sweep in the first colour with filled markers and a
    solid model line drawn on top, the down sweep in the second colour with open markers and a
    dashed line drawn below it; units on both axes, the legend outside the data, and the
    estimates and the verdict (:func:`verdict`, with its reasons) written under the title.
    A Figure."""
    phys = res.x_name == "frequency_hz"
    xl = style.label("forcing frequency f", "Hz") if phys else style.label(r"forcing frequency $\Omega = f/f_n$", None)
    yl = (style.label(f"amplitude at the sensor, {style.DISPLACEMENT}", "mm") if phys else
          style.label(r"amplitude $Q = \Delta - \min q$", None))
    ru = "mm" if phys else None
    with style.context():
        fig, (ax, axr) = plt.subplots(2, 1, figsize=(8.6, 6.2), sharex=True, gridspec_kw={"height_ratios": [3, 1.3]})
        handles = {}
        for d in ("down", "up"):              # the down sweep first: the up sweep is drawn over it
            sel = res.direction == d
            if not sel.any():
                continue
            up = d == "up"
            c = style.PALETTE[0] if up else style.PALETTE[1]
            z = 4 if up else 2
            mk = dict(marker="o", ms=4.5 if up else 6.0, mec=c, mfc=c if up else "none", mew=1.0)
            o = np.argsort(res.x[sel], kind="stable")
            xs, ys, ms = res.x[sel][o], res.y[sel][o], res.model[sel][o]
            if res.sigma_given:
                ax.errorbar(xs, ys, yerr=res.sigma[sel][o], ls="none", color=c, lw=0.8, zorder=z + 1,
                            label=f"data ({d})", **mk)
            else:
                ax.plot(xs, ys, ls="none", color=c, zorder=z + 1, label=f"data ({d})", **mk)
            ax.plot(xs, ms, ls=style.DIRECTIONS[d]["ls"], color=c, lw=1.3, zorder=z, label=f"fitted model ({d})")
            handles[f"data ({d})"] = style.proxy(c, marker="o", fill=up, label=f"data, {d} sweep "
                                                 f"({'filled' if up else 'open'} markers)")
            handles[f"model ({d})"] = style.proxy(c, ls=style.DIRECTIONS[d]["ls"],
                                                  label=f"fitted model, {d} sweep "
                                                        f"({'solid' if up else 'dashed'})")
            npr = (res.model_period[sel][o] == 0) & np.isfinite(ms)
            if npr.any():
                ax.errorbar(xs[npr], ms[npr], yerr=np.nan_to_num(res.model_spread[sel][o][npr]), fmt="x", color=c,
                            ms=6, lw=0.8, zorder=z, label=f"model not periodic ({d}): spread")
                handles["np"] = style.proxy("0.3", marker="x", label="model not periodic: bar = its spread")
            axr.plot(xs, res.residuals[sel][o], ls="none", color=c, zorder=z, label=d, **mk)
            fail = ~np.isfinite(ms)
            if fail.any():
                ax.plot(xs[fail], np.zeros(fail.sum()), ls="none", marker="|", color="k", ms=10,
                        transform=ax.get_xaxis_transform(), label="model failed")
                handles["failed"] = style.proxy("k", marker="|", label="model failed", ms=10)
        if res.sigma_given:
            o = np.argsort(res.x)
            axr.plot(res.x[o], res.sigma[o], ":", color="0.5", lw=0.8)
            axr.plot(res.x[o], -res.sigma[o], ":", color="0.5", lw=0.8, label=r"$\pm\sigma$")
            handles["sigma"] = style.proxy("0.5", ls=":", label=r"residual panel: $\pm\sigma$ of the data")
        axr.axhline(0.0, color="0.3", lw=0.8)
        ax.set_ylabel(yl)
        axr.set_xlabel(xl)
        axr.set_ylabel(style.label("model − data", ru))
        order = ["data (up)", "model (up)", "data (down)", "model (down)", "np", "failed", "sigma"]
        style.legend_outside(fig, [handles[k] for k in order if k in handles])
        ests = ", ".join(style.estimate_text(n, x, s, u) for n, x, s, u in zip(res.parameters, res.estimate,
                                                                                res.standard_error, res.units))
        style.titles(fig, title or f"{res.case_name}: fit of run '{res.run}' against {res.reference}",
                     f"{ests}; {verdict(res)}")
    return fig


def plot_fit(res: FitResult, path, title: str = "") -> Path:
    """:func:`fit_figure` saved to ``path`` (``fit.png``); returns the path."""
    return save_close(fit_figure(res, title), Path(path))


# ============================================================================ several runs
def fit_runs(case, reference, params=None, runs=None, out_dir=None, case_text: str = "", plots: bool = True,
             log=None, on_result=None, **kw) -> list[FitResult]:
    """Fit each run of ``runs`` (default: all runs of the case) one by one against the same
    reference, writing each one's files into ``out_dir/<run>/`` (or ``out_dir`` for a single
    run; ``on_result(res)`` as each finishes); returns the results in order.  Keyword
    arguments go to :func:`fit_case`."""
    names = runs or [r.name for r in case.run]
    out = []
    for name in names:
        res = fit_case(case, reference, params, run=name, log=log, **kw)
        if out_dir is not None:
            d = Path(out_dir) if len(names) == 1 else Path(out_dir) / _safe(name)
            res.paths = res.write(d, case_text, plots=plots)
        if on_result is not None:
            on_result(res)
        out.append(res)
    return out


def _safe(name: str) -> str:
    return re.sub(r"[^A-Za-z0-9_.+-]+", "_", name).strip("_") or "run"


def fidelity_table(results: list[FitResult]) -> str:
    """One line per fitted run: each parameter's estimate +- standard error (the apparent
    parameter per fidelity of a ladder)."""
    params = results[0].parameters
    head = f"{'run':<24}" + "".join(f"{p + ' +- s.e.':>26}" for p in params) + f"{'rms':>11}{'evals':>7}{'time (s)':>10}  reliable"
    lines = [head, "-" * len(head)]
    for r in results:
        cells = "".join(f"{f'{x:.5g} +- {s:.2g}':>26}" for x, s in zip(r.estimate, r.standard_error))
        rms = float(np.sqrt(np.mean(r.residuals[r.used] ** 2))) if r.used.any() else math.nan
        lines.append(f"{r.run:<24}{cells}{rms:>11.4g}{r.evaluations:>7}{r.wall_time_s:>10.1f}  "
                     f"{'yes' if r.reliable else 'no'}")
    return "\n".join(lines)


# ============================================================================ command line
def main_fit(args) -> int:
    """``vibeam fit``: the linear steps (``--linear``, ``--decay``) or the vibro-impact fit."""
    case, text = load_case(args.case)
    log = None if getattr(args, "quiet", False) else (lambda m: print(m, file=sys.stderr))
    if not args.reference and not args.decay:
        raise case_error(f"{args.case}: `vibeam fit` needs --reference DATA (an FRC) or --decay DECAY.csv "
                     f"(a free decay)")
    check_f_scale(args.f_scale)
    if args.max_evaluations < 1:
        raise case_error(f"'--max-evaluations' = {args.max_evaluations!r}: must be at least 1")
    if args.params is not None and not [p for p in args.params.split(",") if p.strip()]:
        raise case_error(f"{args.case}: '--params' = {args.params!r} names no parameter; allowed: "
                     f"{', '.join(case.map_parameters())}")

    if args.reference and not args.linear and args.params is not None:     # before the folder is made
        check_params(case, [p.strip() for p in args.params.split(",") if p.strip()], args.case)
    out_dir = check_folder(Path(args.out) if args.out else default_folder(case.name, "@fit"))
    with OutputLock(out_dir):
        check_outputs(out_dir, fit_outputs(case.name, args))     # before anything is computed
        return _main_fit_locked(args, case, text, out_dir, log)


def fit_outputs(name: str, args) -> list:
    """The files ``vibeam fit`` (``args``: its options) writes into its folder for the case
    ``name``: the results file, its plot, the fitted case file (and the table of several runs)."""
    out = []
    if args.decay:
        out += ["decay.h5", "decay.png", f"{name}-decay.toml"]
    if args.reference and args.linear:
        out += ["linear.h5", "linear.png", f"{name}-linear.toml"]
    elif args.reference:
        out += ["fit.h5", "fit.h5.partial", "fit.png", "fit_table.txt", f"{name}-fit.toml"]
    return out


def _main_fit_locked(args, case, text, out_dir, log) -> int:
    if args.decay:
        report_decay(case, text, args.decay, out_dir, source=args.case)
    if args.reference and args.linear:
        params = [p.strip() for p in args.params.split(",") if p.strip()] if args.params else None
        report_linear(case, text, args.reference, out_dir, params=params, loss=args.loss or "linear",
                      f_scale=args.f_scale, source=args.case)
    elif args.reference:
        params = [p.strip() for p in args.params.split(",") if p.strip()] if args.params is not None else None
        if args.quick:
            case = case.quick_variant()
        ref = read_reference(args.reference, args.reference_run)

        check_params(case, params or default_params(case), args.case)
        runs = [args.run] if args.run else None
        if args.run:
            _pick_run(case, args.run, args.case)
        def show(res):
            print(res.summary())
            print("  -> " + ", ".join(str(p) for p in res.paths.values()))
            print("  R from the sensor's time series (paper Sec. 5.1, Table 1): [effects.sensor] identify_R "
                  "(vibeam.engine.sensor; cases/README.md, 'Effects and the sensor')\n", flush=True)

        ex = default_executor(args.jobs, 2)
        try:
            results = fit_runs(case, ref, params, runs=runs, out_dir=out_dir, case_text=text,
                               plots=not args.no_plots, log=log, on_result=show, executor=ex,
                               loss=args.loss or DEFAULT_LOSS, f_scale=args.f_scale,
                               max_evaluations=args.max_evaluations, source=args.case)
        finally:
            ex.shutdown(wait=True, cancel_futures=True)
        if len(results) > 1:
            print(f"apparent parameters per run (fidelity) of {case.name}, against {ref.source}:")
            tab = fidelity_table(results)
            print(tab)
            write_text_file(out_dir / "fit_table.txt", tab + "\n")
    return 0


# ============================================================================ synthetic data
def synthetic_reference(case, frequencies, values: dict | None = None, run: str | None = None,
                        directions=("up",), sigma: float = 0.0, seed: int | None = 0, jobs: int | None = 1,
                        transient_periods: int | None = None) -> Reference:
    """Measured-like points from the model itself (tests, benchmarks, the fidelity ladder).

    The run's FRC at ``values`` (model keys; default the case's), swept at ``frequencies``
    (Hz for a physical scene, else Omega) in each direction as the fit sweeps it, plus
    Gaussian noise of standard deviation ``sigma`` (data units; seeded by ``seed``).

    Returns
    -------
    Reference
        With ``sigma`` per point when ``sigma > 0`` (else no sigma column).
    """
    r = _pick_run(case, run)
    spec0 = case.model_spec(dict(r.model)) if r.model else case.model_spec()
    phys = bool(getattr(spec0, "physical", False))

    job = make_job(case, r, dict(r.model, **(values or {})))
    fn = outputs(job.solver.scene).natural_frequency_hz if phys else None
    xs = np.asarray(frequencies, float)
    rng = np.random.default_rng(seed)
    X, Y, D = [], [], []
    for d in directions:
        sw = dataclasses.replace(job.sweep, Omega=xs / fn if phys else xs, direction=d, assess=(),
                                 transient_periods=transient_periods if transient_periods is not None
                                 else job.sweep.transient_periods)
        res = run_sweep(job.solver, sw, jobs=jobs)
        xk, yk = ("frequency_hz", "amplitude_mm") if phys else ("Omega", "amplitude")
        x = np.asarray(res.data[xk], float)
        if phys:   # the requested frequencies exactly (Omega * f_n can differ from them by an ulp)
            x = xs[np.argsort(xs)] if d == "up" else xs[np.argsort(xs)][::-1]
        X.append(x)
        Y.append(np.asarray(res.data[yk], float))
        D += [d] * x.size
    y = np.concatenate(Y)
    if sigma > 0:
        y = y + rng.normal(0.0, sigma, y.size)
    names = ("frequency_hz", "amplitude_mm") if phys else ("Omega", "amplitude")
    return Reference(f"synthetic ({case.name}, {', '.join(f'{k} = {v:g}' for k, v in (values or {}).items())}"
                     f"{f', noise {sigma:g}' if sigma > 0 else ''})", names[0], names[1], np.concatenate(X), y,
                     np.array(D, dtype=object), np.full(y.size, sigma) if sigma > 0 else None)
