"""Frequency-response bands from a scene's measured parameter spread, as ``vibeam uncertainty``:
:func:`uncertainty` (:mod:`vibeam.analysis.uncertainty`)."""
from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np

from vibeam.analysis.uncertainty import (BOOTSTRAP_CONFIDENCE, CHECKPOINT, JUMP_FRACTION, QUANTILES, bands,  # noqa: F401
                                         check_block, checkpoint_groups, checkpoint_ident, jump_share, outcome_entries,
                                         read_uncertainty, sample_runs, samples_from_checkpoint, sobol_entries,
                                         uncertainty_group, verdict_text)
from vibeam.api.cases import case_text, load_case
from vibeam.api.common import check_run_args
from vibeam.engine.jobs import make_job
from vibeam.engine.records import PERIOD_MAX
from vibeam.api.results import Results
from vibeam.case.uncertainty import MAX_SAMPLES
from vibeam.errors import CaseError, InputError
from vibeam.io.store import Store
from vibeam.plots.uncertainty import plot_bands, plot_outcomes, plot_sobol
from vibeam.runner import case_identity, same_case

__all__ = ["uncertainty", "uncertainty_group", "print_uncertainty", "bands", "plot_uncertainty"]


#: what the printed quantiles, bands and jumps are (one line above the table)
LEGEND = (f"quantiles of the amplitude over the samples: the median (50 %), the 50 % band (25-75 %) and the 90 % "
          f"band (5-95 %); the {100 * BOOTSTRAP_CONFIDENCE:.0f} % bootstrap interval is the median's sampling "
          f"error; a sample jumps where its amplitude changes between neighbouring points by more than "
          f"{100 * JUMP_FRACTION:.0f} % of its peak")


def print_uncertainty(results, file=None) -> None:
    """The table of :func:`uncertainty`: a line saying what the quantiles, bands and jumps are
    (:data:`LEGEND`), per run the samples, the median peak amplitude with its 90 % band and the share
    of the samples that jump, and per pair of runs the verdict in words
    (:func:`vibeam.analysis.uncertainty.verdict_text`) with its figures
    (:func:`vibeam.analysis.uncertainty.verdict`)."""
    out = file or sys.stdout
    print(f"  {LEGEND}", file=out)
    for r in results:
        q = r.quantiles()
        scale, unit = (r.length_m * 1e3, "mm") if r.length_m else (1.0, "")
        med = q[2]
        i = divmod(int(_nanargmax(med)), med.shape[1]) if med.size else (0, 0)
        ci = r.bootstrap()["quantile_ci"][:, 2][(slice(None),) + i] * scale
        x = r.frequency_hz if r.frequency_hz is not None else r.Omega
        xu = "Hz" if r.frequency_hz is not None else "(Omega)"
        print(f"  {r.name}: {int(r.base.sum())} samples of {', '.join(r.parameters)}; median peak "
              f"{med[i] * scale:.4g} {unit} ({100 * BOOTSTRAP_CONFIDENCE:.0f} % bootstrap interval {ci[0]:.4g} ... {ci[1]:.4g}; "
              f"90 % band {q[0][i] * scale:.4g} ... {q[-1][i] * scale:.4g}) at "
              f"{x[i[1]]:.4g} {xu} ({r.directions[i[0]]})", file=out)
        share, d = jump_share(r)
        j = r.jumps()[np.asarray(r.base, bool), r.directions.index(d)]
        j = j[np.isfinite(j)]
        where = f", median jump at {np.median(j):.4g} {xu}" if j.size else ""
        print(f"  {r.name}: {100 * share:.0f} % of the samples jump in the {d} sweep{where}", file=out)
    for r in results:
        si = r.sobol()
        if si is not None:
            with np.errstate(all="ignore"):
                peak = [float(np.nanmax(si["first"][k])) if np.isfinite(si["first"][k]).any() else float("nan")
                        for k in range(len(r.parameters))]
            print(f"  {r.name}: Sobol' first-order index of the amplitude, largest over the grid: "
                  + ", ".join(f"{p} {x:.2f}" for p, x in zip(r.parameters, peak))
                  + "; of the jump frequency: "
                  + ", ".join(f"{p} {x:.2f}" for p, x in zip(r.parameters, si["jump_first"])), file=out)
    for r in results:
        for key, v in r.attrs.items():
            if not key.startswith("verdict_") or v["a"] != r.name:
                continue
            unit = "Hz" if v["unit"] == "Hz" else "(Omega)"
            ja, jb = v["jump_median_a"], v["jump_median_b"]
            jumps = ("no sample of either run jumps" if not (np.isfinite(ja) or np.isfinite(jb)) else
                     f"median down-sweep jump {ja:.4g} (5-95 %: {v['jump_band_a'][0]:.4g}-{v['jump_band_a'][1]:.4g}) "
                     f"against {jb:.4g} ({v['jump_band_b'][0]:.4g}-{v['jump_band_b'][1]:.4g}) {unit}")
            print(f"  {v['a']} vs {v['b']}: {verdict_text(v)}: the median of {v['a']} lies outside the 90 % band "
                  f"of {v['b']} at {100 * v['outside_band_a_in_b']:.0f} % of {v['points']} points ({v['b']} in "
                  f"{v['a']}'s: {100 * v['outside_band_b_in_a']:.0f} %); {jumps}", file=out)


def _nanargmax(a):
    return int(np.nanargmax(a)) if np.isfinite(a).any() else 0


def uncertainty(case, samples: int | None = None, jobs: int | None = None, executor=None, out=None,
                quick: bool = False, progress: bool = False, fresh: bool = False, quiet: bool = False,
                plots: bool = False, resume: bool = False, checkpoint_interval_s: float = 0.5) -> list:
    """The FRC bands of a case's ``[uncertainty]`` (``vibeam uncertainty``).

    Parameters
    ----------
    case : Case, str, Path or dict
        Anything :func:`vibeam.load_case` takes, with an ``[uncertainty]`` table.
    samples : int, optional
        Instead of ``[uncertainty] samples``: a power of 2 from 2 to
        :data:`vibeam.case.uncertainty.MAX_SAMPLES` (65536), as that key.
    jobs : int or None
        Workers of the local process pool (None, the default as ``vibeam uncertainty`` and
        :func:`vibeam.run`: all cores; 1: in this process).
    executor : concurrent.futures.Executor, optional
        Where the samples run instead, e.g. ``distributed.Client(...).get_executor()``.
    out : str or Path, optional
        Output folder: ``/uncertainty/<run>/`` of its ``results.h5`` (every other group kept); None:
        nothing written.
    quick : bool
        The case's quick variant (its grid), at 8 samples unless ``samples`` is given.
    progress, quiet : bool
        A progress bar; no table.
    plots : bool
        With ``out``: ``uncertainty.png`` (the FRC bands), ``uncertainty_outcomes.png`` and, with
        ``sobol = true``, ``uncertainty_sobol.png`` (:func:`plot_uncertainty`).
    fresh : bool
        Start a new results file.
    resume : bool
        With ``out``: take the samples already in its checkpoint (``results.h5.partial``,
        ``/uncertainty_samples/<run>/``) that were computed for this case and number of samples
        (validated: :func:`vibeam.analysis.uncertainty.check_block`), and compute only the rest; the
        results are those of an uninterrupted run, bit for bit.
    checkpoint_interval_s : float
        With ``out``: finished samples go to the checkpoint as they finish, those finishing within
        this time of the last write together (and on an interrupt, every finished one), so an
        interrupted computation loses at most this much finished work.

    Returns
    -------
    list of vibeam.api.results.Uncertainty
        One per sweep run (a :class:`vibeam.analysis.uncertainty.UncertaintyResult` with ``to_xarray()``,
        the group ``/uncertainty/<run>/``, and ``plot(kind=...)``).

    Raises
    ------
    vibeam.errors.CaseError
        No ``[uncertainty]`` table, or a bad case (one line).
    vibeam.errors.InputError
        ``resume`` finds a checkpointed block this vibeam would not have written, or a checkpoint of
        another case (one line naming the file; nothing is written).
    TypeError, ValueError
        An argument of the wrong type or out of range (``jobs`` by the rule of ``--jobs``; one line),
        or both ``fresh`` and ``resume``.
    KeyboardInterrupt
        Ctrl-C: the samples finished by then are in the checkpoint (``--resume`` takes them); the
        results file is as it was.
    """
    jobs, out = check_run_args(jobs, out, executor, quick=quick, progress=progress, fresh=fresh, quiet=quiet,
                               plots=plots, resume=resume)
    if fresh and resume:
        raise ValueError("fresh = True and resume = True: choose one (fresh starts a new results file, resume "
                         "continues the checkpoint of an interrupted run)")
    c0 = c = load_case(case)
    if c.uncertainty is None:
        raise CaseError(f"{c.name}: no [uncertainty] table; add one ([[uncertainty.parameter]] name, "
                        f"distribution, ...)")
    samples = check_samples(samples)
    if quick:
        c = c.quick_variant()
        samples = samples if samples is not None else min(8, c.uncertainty.samples)
    if out is None:
        results = sample_runs(c, samples=samples, jobs=jobs, executor=executor, progress=progress)
        if not quiet:
            _print(c, results)
        return _bound(results, c)
    text = case_text(c0)
    with Store(Path(out), fresh=fresh, outputs=PLOT_NAMES if plots else ()) as st:
        cj, aliases = case_identity(st, c.model_dump_json())
        n = int(samples or c.uncertainty.samples)
        ident = checkpoint_ident(cj, n)
        stored = _resumed(st, c, cj, aliases, ident, n) if resume else {}
        buffer: dict = {}
        last = [time.perf_counter()]

        def flush():
            if buffer:
                groups = {f"{run}/{k}": v for run, got in buffer.items() for k, v in checkpoint_groups(got, ident).items()}
                st.checkpoint(CHECKPOINT, groups, c.name, text, cj, start=not resume)
                buffer.clear()
            last[0] = time.perf_counter()

        def on_sample(run, i, arrays):
            buffer.setdefault(run, {})[i] = arrays
            if time.perf_counter() - last[0] >= checkpoint_interval_s:
                flush()

        results = _complete(st, c, cj, aliases, n) if resume and not stored else None
        if results is not None:
            print(f"[{c.name}] {st.path} is complete; resuming recomputes nothing", file=sys.stderr)
            h5 = st.path
        else:
            if stored:
                print(f"[{c.name}] uncertainty: resuming: {sum(len(v) for v in stored.values())} sampled sweeps "
                      f"done", file=sys.stderr)
            try:
                results = sample_runs(c, samples=samples, jobs=jobs, executor=executor, progress=progress,
                                      done=stored, on_sample=on_sample)
            finally:
                flush()          # on an interrupt too: every finished sample is kept
            # the successor of results.h5 (every group kept); the consumed checkpoint is then removed
            h5 = st.commit({f"uncertainty/{r.name}": uncertainty_group(r) for r in results}, c.name, text, cj,
                           done=[CHECKPOINT], aliases=aliases)
    if not quiet:
        _print(c, results)
        print(f"uncertainty -> {h5} (groups {', '.join('/uncertainty/' + r.name for r in results)})")
    if plots:
        for png in plot_uncertainty(results, out, c.name):
            if not quiet:
                print(f"plot: {png}")
    return _bound(results, c, h5)


def check_samples(samples):
    """``samples`` (``--samples``) in the range of ``[uncertainty] samples``: a power of 2 from 2 to
    :data:`vibeam.case.uncertainty.MAX_SAMPLES` (0 was the case's count, 2^40 a MemoryError); None
    passes (the case's count).

    Raises
    ------
    TypeError
        Not a whole number.
    vibeam.errors.CaseError
        Out of that range, one line.
    """
    if samples is None:
        return None
    if isinstance(samples, bool) or not isinstance(samples, (int, np.integer)):
        raise TypeError(f"samples = {samples!r}: not a whole number; allowed: a power of 2 from 2 to {MAX_SAMPLES}")
    if not 2 <= samples <= MAX_SAMPLES or samples & (samples - 1):
        raise CaseError(f"'--samples' = {samples}: allowed: a power of 2 from 2 to {MAX_SAMPLES} (as [uncertainty] "
                        f"samples)")
    return int(samples)


#: the figures :func:`plot_uncertainty` writes
PLOT_NAMES = ("uncertainty.png", "uncertainty_sobol.png", "uncertainty_outcomes.png")


def plot_uncertainty(results, folder, title: str = "") -> list:
    """The figures of ``vibeam uncertainty`` written into ``folder``: ``uncertainty.png`` (the FRC
    bands), ``uncertainty_outcomes.png`` (outcome probabilities against frequency) and, with Saltelli's
    design, ``uncertainty_sobol.png`` (Sobol' indices against frequency).  Returns the paths written."""
    folder = Path(folder)
    made = [plot_bands(bands(results), folder / "uncertainty.png", title=f"{title}: FRC bands"),
            plot_sobol(sobol_entries(results), folder / "uncertainty_sobol.png", title=f"{title}: Sobol' indices"),
            plot_outcomes(outcome_entries(results), folder / "uncertainty_outcomes.png",
                          title=f"{title}: outcome probabilities")]
    return [p for p in made if p is not None]


def _bound(results, case, h5=None) -> list:
    """The results as the API's :class:`vibeam.api.results.Uncertainty` groups (``to_xarray()``,
    ``plot()``) of one :class:`vibeam.api.results.Results`."""
    return Results(case=case, path=h5, uncertainty=list(results)).uncertainty


def _complete(st, c, cj, aliases, n):
    """``--resume`` of a complete computation: the results of every sweep run read back from the
    file when it holds them for this case (not stale) and this number of samples, else None."""
    names = [r.name for r in c.run if r.method != "continuation"]
    if not set(f"uncertainty/{x}" for x in names) <= set(st.current(cj, aliases)):
        return None
    back = {u.name: u for u in read_uncertainty(st.path)}
    if any(int(back[x].attrs.get("samples", -1)) != n for x in names):
        return None
    return [back[x] for x in names]


def _print(c, results) -> None:
    n = sorted({int(np.sum(r.base)) for r in results})
    print(f"[{c.name}] uncertainty: {len(results)} run(s), {' or '.join(map(str, n))} samples each, quantiles "
          f"{list(QUANTILES)}")
    print_uncertainty(results)


def _resumed(st, c, cj, aliases, ident, n) -> dict:
    """``{run: {sample: arrays}}`` of the checkpoint of ``st`` for this case and design (validated).

    Raises
    ------
    InputError
        A block this vibeam would not have written; or no sample of this case while the
        checkpoint or the file was written by another case (``--resume`` would compute afresh over it).
    """
    rows = n * c.uncertainty.runs_per_sample()
    points = (c.sweep.Omega or c.sweep.frequency_hz)[2]
    shape = (2 if c.sweep.direction == "both" else 1, int(points))      # (direction, Omega) of every sample

    out = {}
    for r in c.run:
        if r.method == "continuation":
            continue
        solver = make_job(c, r, dict(r.model), 0).solver      # what its points can hold (no computing)
        td = bool(getattr(solver, "time_domain", True))
        p_max = PERIOD_MAX if td else max(PERIOD_MAX, int(getattr(solver, "k", 0) or 0),
                                          int(getattr(solver, "n", 0) or 0))

        def check(key, meta, data, td=td, p_max=p_max):
            return check_block(meta, data, rows, shape, time_domain=td, period_max=p_max)

        try:
            _, got = st.read_checkpoint(f"{CHECKPOINT}/{r.name}", "case_hash", ident, check)
        except OSError as e:
            raise InputError(f"--resume: cannot read {st.partial}: {e}") from None
        if got:
            out[r.name] = samples_from_checkpoint(got, f"{st.partial} (/{CHECKPOINT}/{r.name})")
    if not out:
        roots = [a.get("case_json") for a in (st.checkpoint_attrs(), st.info()["attrs"]) if a]
        if roots and not any(same_case(x, cj) or str(x) in aliases for x in roots):
            raise InputError(f"--resume: {st.path} was written by another case or variant; run without --resume "
                             f"(its groups are kept, marked stale) or use another --out")
    return out
