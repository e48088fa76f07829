"""A case against references, as ``vibeam regress``, ``cost`` and ``fit``: its FRCs against
reference FRCs (:func:`regress`), the accuracy of every run against its time with a converged
reference (:func:`cost`), and its parameters fitted to a measured FRC (:func:`fit`)."""
from __future__ import annotations

import math
import tempfile
from dataclasses import dataclass, field
from pathlib import Path

from vibeam.analysis.cost import (check_cost_work, cost_tables, plot_work_precision, run_cost,
                                  work_precision_figure)
from vibeam.analysis.regress import (check_reference_of_case, check_results_of_case, compare, load_results,
                                     print_rows, read_reference)
from vibeam.api.cases import case_and_source, case_text
from vibeam.api.common import check_run_args, saved
from vibeam.case.arguments import check_case_value, check_path, check_whole
from vibeam.case.schema import RegressSpec
from vibeam.engine.sweep import default_executor
from vibeam.errors import CaseError
from vibeam.identify.fit import DEFAULT_LOSS, check_params, default_params, fit_runs
from vibeam.identify.fit import read_reference as read_measurement
from vibeam.io.outdir import OutputLock, check_folder, check_outputs
from vibeam.io.results import table_variables, write_results
from vibeam.runner import run_case


@dataclass
class Regression:
    """A case's FRCs against reference FRCs (:func:`regress`).

    Attributes
    ----------
    case : Case
    reference : Path
    rows : list of vibeam.analysis.regress.RegressRow
        One per run: points compared, failures, max |dA| and relative, period mismatches.
    atol, rtol : float
        The amplitude tolerances used (``[regress]`` or the arguments).
    ok : bool
        Every run within the tolerances (``vibeam regress`` exits 0).
    """

    case: object
    reference: Path
    rows: list
    atol: float
    rtol: float

    @property
    def ok(self) -> bool:
        return bool(self.rows) and all(r.ok for r in self.rows)

    def print(self) -> None:
        """The table of ``vibeam regress``."""
        tol = self.case.regress
        print(f"\nregression of {self.case.name} against {self.reference}")
        print_rows(self.rows, self.atol, self.rtol, tol.spread_sigmas, tol.spread_range)


def regress(case, reference, results=None, out=None, jobs: int | None = None, executor=None,
            atol: float | None = None, rtol: float | None = None, quick: bool = False,
            force: bool = False, quiet: bool = False) -> Regression:
    """Compare a case's FRCs with reference FRCs (``vibeam regress``): rerun the case (or take
    ``results``) and compare amplitudes point by point (``[regress]`` tolerances).

    Parameters
    ----------
    case : Case, str, Path or dict
    reference : str or Path
        Reference ``results.h5`` or CSV (``Omega,amplitude`` or ``frequency_hz,amplitude_mm``).
    results : str or Path, optional
        Compare this results file instead of rerunning the case.
    out : str or Path, optional
        Folder of the rerun (default: a temporary folder, removed afterwards).
    jobs, executor, quick, force
        As :func:`run`.
    atol, rtol : float, optional
        Override ``[regress] amplitude_atol`` / ``amplitude_rtol``; checked by those keys' rule
        (a finite number >= 0).
    quiet : bool
        The rerun says nothing on standard error (``--quiet``: no header line, no lines about
        compiling kernels); it never draws a progress bar.

    Returns
    -------
    Regression

    Raises
    ------
    vibeam.case.schema.InputError
        A reference or results file that is not of this case or not readable (one line): a
        results-file reference (or ``results``) written by another case (another name, model,
        effects or runs: :func:`vibeam.analysis.regress.check_results_of_case`).
    TypeError, ValueError
        ``atol`` / ``rtol`` not a finite number >= 0 (NaN, infinite, negative).
    """
    jobs, out = check_run_args(jobs, out, executor, quick=quick, force=force, quiet=quiet)
    if atol is not None:
        atol = check_case_value(atol, "atol", RegressSpec, "amplitude_atol")
    if rtol is not None:
        rtol = check_case_value(rtol, "rtol", RegressSpec, "amplitude_rtol")
    reference = check_path(reference, "reference", optional=False)
    results = check_path(results, "results")
    c, source = case_and_source(case)
    ref = read_reference(reference)    # a bad reference is refused before anything runs
    check_reference_of_case(c, ref, reference, source)
    if results is not None:
        new = load_results(results, "--results")
        check_results_of_case(c, new, results, source)
    if isinstance(ref, dict):          # a results-file reference: of this case too
        check_results_of_case(c, ref, reference, source, option="--reference")
    if results is None:
        # the rerun goes to its own folder: out, or a temporary one removed afterwards --
        # never results/<case>/, where it would replace the results of the user's run, and never
        # into the reference it is compared with
        with tempfile.TemporaryDirectory(prefix=f"vibeam-regress-{c.name}-") as tmp:
            out_dir = check_folder(Path(out) if out else Path(tmp))
            run_case(c, case_text(c), out_dir, jobs=jobs, quiet=True, announce=not quiet, plots=False, quick=quick,
                     executor=executor, force=force, source=source, inputs=[(reference, "--reference")])
            new = load_results(out_dir / "results.h5", "results")
    tol = c.regress
    atol = tol.amplitude_atol if atol is None else atol
    rtol = tol.amplitude_rtol if rtol is None else rtol
    rows = compare(new, reference, atol=atol, rtol=rtol, period=tol.period, sigmas=tol.spread_sigmas,
                   spread_range=tol.spread_range, continuation=c.sweep.continuation)
    return Regression(c, Path(reference), rows, atol, rtol)


@dataclass
class Cost:
    """Accuracy against time of every run (:func:`cost`): ``result`` as
    :func:`vibeam.analysis.cost.run_cost` returns it (``rows``: method, settings, seconds,
    errors against the converged reference; the paper's claims), ``paths`` written."""

    case: object
    result: dict
    paths: dict = field(default_factory=dict)

    @property
    def rows(self) -> list:
        return self.result["rows"]

    def to_xarray(self):
        """The cost table (the variables of ``cost.h5`` ``/cost``) as an :class:`xarray.Dataset`."""
        import xarray as xr  # lazy: xarray (with pandas: 0.35 s) loads only when labelled data are asked for

        v = table_variables(cost_tables(self.result))
        return xr.Dataset({k: (x.dims, x.data, x.attrs) for k, x in v.items()})

    def plot(self, path=None):
        """The work-precision figure (``work_precision.png``)."""
        return saved(work_precision_figure(self.result, title=self.case.name, case=self.case), path)


def cost(case, out=None, ladder: bool = False, repeats: int = 3, quick: bool = False, jobs: int | None = None,
         force: bool = False, log=None, plots: bool = True) -> Cost:
    """Accuracy against time of every run (``vibeam cost``): each run's sweep timed (median of
    ``repeats``, inline) and its error against a converged reference.

    Parameters
    ----------
    case : Case, str, Path or dict
    out : str or Path, optional
        A folder: ``cost.h5`` (``/cost``) and ``work_precision.png`` written there atomically.
    ladder : bool
        Also a ladder of tolerances per ODE method.
    repeats : int
        Timed repetitions (>= 1).
    quick, jobs, force
        As :func:`run` (``jobs``: the workers of the converged references).
    log : callable, optional
        Progress messages (default: none).
    plots : bool
        With ``out``: also ``work_precision.png`` (``--no-plots``: ``cost.h5`` only).

    Returns
    -------
    Cost

    Raises
    ------
    vibeam.case.schema.CaseError
        Work above the limit without ``force``; a bad case.
    """
    jobs, out = check_run_args(jobs, out, None, ladder=ladder, quick=quick, force=force, plots=plots)
    repeats = check_whole(repeats, "repeats", 1, 10 ** 6)
    c, source = case_and_source(case)
    text = case_text(c)
    if quick:
        c = c.quick_variant()
    check_cost_work(c, force=force, source=source)
    log = log or (lambda m: None)
    if out is None:
        return Cost(c, run_cost(c, ladder=ladder, repeats=repeats, jobs=jobs, log=log))

    folder = check_folder(Path(out))
    with OutputLock(folder):
        check_outputs(folder, ("cost.h5", "cost.h5.partial", "work_precision.png"))   # before computing
        res = run_cost(c, ladder=ladder, repeats=repeats, jobs=jobs, log=log)
        h5 = write_results(folder / "cost.h5", [], c.name, text, extra={"cost": cost_tables(res)},
                           case_json=c.model_dump_json())
        png = plot_work_precision(res, folder / "work_precision.png", title=c.name, case=c) if plots else None
    return Cost(c, res, {"h5": h5, "png": png} if png is not None else {"h5": h5})


def fit(case, reference=None, params=None, run: str | None = None, out=None, jobs: int | None = 1,
        quick: bool = False, loss: str | None = None, f_scale: float = 3.0, max_evaluations: int = 60,
        reference_run: str | None = None, plots: bool = True, log=None):
    """Fit model parameters to a measured FRC (``vibeam fit``), with standard errors.

    Parameters
    ----------
    case : Case, str, Path or dict
        Its ``[model]`` values start the fit.
    reference : str or Path
        Measured FRC: CSV ``frequency_hz,amplitude_mm`` (or ``Omega,amplitude``), optional
        ``direction`` and ``sigma`` columns; or a results.h5 (``reference_run`` names its run).
    params : list of str or str, optional
        Numeric ``[model]`` keys to fit (default ``gain, R``; a comma-separated str too).
    run : str, optional
        Fit this run only (default: every run, one by one).
    out : str or Path, optional
        A folder for each fit's files (fitted case, table, ``fit.png``); default none written.
    jobs : int or None
        Workers (1: inline).
    quick : bool
        Sweep with the quick variant's periods.
    loss, f_scale, max_evaluations
        As ``--loss`` (default soft_l1), ``--f-scale`` (units of sigma), ``--max-evaluations``.

    Returns
    -------
    list of vibeam.identify.fit.FitResult
        One per run: ``estimate``, ``standard_error``, ``correlation``, ``residuals``, ...

    Raises
    ------
    vibeam.case.schema.CaseError
        A parameter that is not a numeric key of the scene, an unreadable reference (one line).
    """
    out = check_path(out, "out")
    reference = check_path(reference, "reference", optional=False)
    if not (isinstance(f_scale, (int, float)) and math.isfinite(f_scale) and f_scale > 0):
        raise CaseError(f"f_scale = {f_scale!r}: must be a finite positive number (units of sigma)")
    c, source = case_and_source(case)
    text = case_text(c)
    if isinstance(params, str):
        params = [p.strip() for p in params.split(",") if p.strip()]
    if quick:
        c = c.quick_variant()
    ref = read_measurement(reference, reference_run)
    check_params(c, params or default_params(c), source)
    ex = default_executor(jobs, 2)
    try:
        if out is None:
            return fit_runs(c, ref, params, runs=[run] if run else None, case_text=text, plots=False, log=log,
                            executor=ex, loss=loss or DEFAULT_LOSS, f_scale=f_scale,
                            max_evaluations=max_evaluations, source=source)

        folder = check_folder(Path(out))
        with OutputLock(folder):
            return fit_runs(c, ref, params, runs=[run] if run else None, out_dir=folder, case_text=text,
                            plots=plots, log=log, executor=ex, loss=loss or DEFAULT_LOSS, f_scale=f_scale,
                            max_evaluations=max_evaluations, source=source)
    finally:
        ex.shutdown(wait=True, cancel_futures=True)
