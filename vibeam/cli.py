"""Command line: ``vibeam run CASE.toml [--out DIR] [--jobs N]``.

Heavy modules (numba kernels, h5py, matplotlib) are imported only by the
command that needs them, so ``vibeam --help`` and case errors are instant.

Exit codes (:data:`EXIT_CODES`): 0 done; 1 ``regress`` found a regression, or a ``bench``
goal FAILed;
2 bad input (case file, option, file or folder: one line ``vibeam: error:
...``, nothing computed is lost and no partial file is left); 3 the run
finished but every point failed (the results file and plots show the
failures); 130 interrupted by Ctrl-C (SIGINT), 143 by SIGTERM (finished
sweep lines are kept: ``--resume``).  Output piped into a program that stops
reading (``vibeam cost ... | head``) is dropped quietly and the command
finishes its files.

``--quiet`` (every command but ``cases`` and ``bench``, whose output is what they are for): no
progress bar and no tables or reports -- standard output stays empty; the files are written as
without it.  Standard error keeps only what the user must know: an error is still its one line
``vibeam: error: ...`` (exit 2), and notes (``vibeam: note: ...``), an interruption's report and
what a ``--resume`` takes from the checkpoint are kept; the ``[case] 1 run(s), ...`` header of a
run and the lines about compiling kernels are not said (issue 56).
"""
from __future__ import annotations

import argparse
import contextlib
import errno
import faulthandler
import os
import signal
import sys
from pathlib import Path

from vibeam.case.arguments import case_value_option, jobs_option, path_option
from vibeam.errors import CaseError, InputError, Terminated, one_line  # noqa: F401 (re-exported)
from vibeam.errors import recording_signals
from vibeam.version import __version__

QUIET_HELP = ("no progress bar and no tables or reports (standard output stays empty; files are written as "
              "without it); errors are still one line on standard error")
#: the commands without --quiet: their output is what they are for
NOT_QUIET = ("cases", "bench")
FRESH_HELP = ("start a new results file: the groups of the one in the output folder are not kept (without it, "
              "every group is kept; those of another case are marked stale)")
EXIT_CODES = {0: "done", 1: "regression found (regress), a goal FAILed (bench)", 2: "bad input", 3: "every point failed",
              130: "interrupted (SIGINT, Ctrl-C)", 143: "terminated (SIGTERM)"}


#: the arguments that name files a command reads, and how a message names each: no command
#: writes one of them, under any name (:func:`vibeam.io.outdir.reading`)
INPUT_ARGS = (("case", "case file"), ("reference", "--reference file"), ("results", "results file"),
              ("decay", "--decay file"))


def _inputs(args) -> list:
    """``(path, what)`` of the files the parsed command reads (:data:`INPUT_ARGS`)."""
    return [(getattr(args, k), what) for k, what in INPUT_ARGS if isinstance(getattr(args, k, None), str)]


def _on_sigterm(signum, frame):
    raise Terminated()


def _interrupt_code(e: BaseException) -> int:
    return 143 if isinstance(e, Terminated) else 130


class _Parser(argparse.ArgumentParser):
    """argparse with errors on one line: ``vibeam: error: <message> (vibeam <cmd> --help)``."""

    def error(self, message):
        self.exit(2, f"vibeam: error: {one_line(message)} (see `{self.prog} --help`)\n")


def _int_at_least(lo: int, name: str = ""):
    def conv(text: str) -> int:
        try:
            v = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{text!r} is not a whole number") from None
        if v < lo:
            raise argparse.ArgumentTypeError(f"{v} is not allowed; allowed: a whole number >= {lo}")
        return v
    conv.__name__ = name or f"integer >= {lo}"
    return conv


class _QuietPipe:
    """stdout that, once its reader has gone (``| head``), drops further output instead of
    raising BrokenPipeError, so the command still finishes its files."""

    def __init__(self, stream):
        self._s = stream
        self.broken = False

    def _gone(self):
        self.broken = True
        try:
            devnull = os.open(os.devnull, os.O_WRONLY)
            os.dup2(devnull, self._s.fileno())
            os.close(devnull)
        except (OSError, ValueError, AttributeError):
            pass

    def write(self, text):
        if self.broken:
            return len(text)
        try:
            return self._s.write(text)
        except BrokenPipeError:
            self._gone()
            return len(text)

    def flush(self):
        if self.broken:
            return
        try:
            self._s.flush()
        except BrokenPipeError:
            self._gone()

    def __getattr__(self, name):
        return getattr(self._s, name)


def run_case(*args, **kwargs):
    """:func:`vibeam.runner.run_case` (imported when called, so ``vibeam --help`` stays instant)."""
    # lazy: keeps the engine (numba, scipy, matplotlib: 1.2 s) out of `vibeam --help`
    from vibeam.runner import run_case as run

    return run(*args, **kwargs)


def _executor(args):
    # lazy: keeps the engine (numba, scipy, matplotlib: 1.2 s) out of `vibeam --help`
    from vibeam.runner import open_executor

    return open_executor(getattr(args, "scheduler", None))


#: the suffix of a quick variant's default folder: '@' is not allowed in a case name, so no case
#: (``qq-quick``) shares the folder of another's quick variant (``qq`` with --quick)
QUICK_SUFFIX = "@quick"


def _out_dir(args, case) -> Path:
    from vibeam.io.outdir import default_folder  # lazy: keeps vibeam.io.outdir (32 modules) out of `vibeam --help`

    return Path(args.out) if args.out else default_folder(case.name, QUICK_SUFFIX if args.quick else "")


def _file_state(path: Path):
    """What identifies a file's version on the disk (inode, size, modification time), or None."""
    try:
        st = os.stat(path)
    except OSError:
        return None
    return st.st_ino, st.st_size, st.st_mtime_ns


def _interrupted_left(h5: Path, before, partial_before=None) -> str:
    """What an interrupted run left on the disk, as read afterwards (``before``,
    ``partial_before``: :func:`_file_state` of the results file and of its checkpoint
    ``results.h5.partial`` when the run started)."""
    from vibeam.io.store import PARTIAL_SUFFIX  # lazy: keeps numpy and h5py (0.17 s) out of `vibeam --help`

    partial = h5.with_name(h5.name + PARTIAL_SUFFIX)
    now = _file_state(h5)
    kept = (f"{h5} is as it was" if now == before and now is not None else
            "no results file was written" if now is None else f"the results are complete in {h5}")
    pnow = _file_state(partial)
    if pnow is None or pnow == partial_before:
        return f"no sweep line had finished; {kept}"
    try:
        from vibeam.io.results import read_lines  # lazy: keeps numpy and h5py (0.17 s) out of `vibeam --help`

        _, lines = read_lines(h5)
    except Exception:
        return f"{kept}; see {partial}"
    n = sum(len(v) for v in lines.values())
    return (f"{kept}; {n} finished sweep line{'s are' if n != 1 else ' is'} kept in {partial}; "
            f"rerun with --resume to compute only the rest")


def cmd_run(args, need_map=False, continuation_only=False) -> int:
    # lazy: keeps the case schema (pydantic, numba: 0.4 s) out of `vibeam --help`
    from vibeam.case.schema import load_case
    from vibeam.io.outdir import check_folder  # lazy: keeps vibeam.io.outdir (32 modules) out of `vibeam --help`
    # lazy: keeps the engine (numba, scipy, matplotlib: 1.2 s) out of `vibeam --help`
    from vibeam.runner import failure_summary, output_names

    case, text = load_case(args.case)
    if need_map and case.map is None:
        raise CaseError(f"{args.case}: `vibeam map` needs a [map] table (parameter, values); "
                        f"use `vibeam run` for a plain sweep")
    from vibeam.io.store import PARTIAL_SUFFIX, Store  # lazy: keeps numpy and h5py (0.17 s) out of `vibeam --help`

    _check_fresh(args)
    out_dir = check_folder(_out_dir(args, case))
    h5 = out_dir / "results.h5"
    basins = case.basins is not None and not need_map and not continuation_only
    outputs = output_names(plots=not args.no_plots, basins=basins)
    # the results store holds the folder for the whole command: the sweeps, then the [basins];
    # every name the command writes is checked before it computes
    with Store(out_dir, fresh=getattr(args, "fresh", False), outputs=outputs) as store:
        before = _file_state(h5)
        partial_before = _file_state(h5.with_name(h5.name + PARTIAL_SUFFIX))
        ex, client = _executor(args)
        try:
            res = run_case(case, text, out_dir, jobs=args.jobs, quiet=args.quiet, plots=not args.no_plots,
                           quick=args.quick, resume=getattr(args, "resume", False), executor=ex,
                           force=args.force, source=args.case, continuation_only=continuation_only, store=store)
        except KeyboardInterrupt as e:
            sig = "SIGTERM" if isinstance(e, Terminated) else "Ctrl-C"
            print(f"vibeam: interrupted ({sig}); {_interrupted_left(h5, before, partial_before)}",
                  file=sys.stderr)
            return _interrupt_code(e)
        finally:
            if client is not None:
                client.close()
        if basins:
            code = _basins(args, case.quick_variant() if args.quick else case, text, out_dir, None, store)
            if code:
                return code
    bad = failure_summary(res)
    if bad:
        print(f"vibeam: error: {args.case}: {bad}; the results file and plots in {out_dir} show them",
              file=sys.stderr)
        return 3
    return 0


def _check_fresh(args) -> None:
    if getattr(args, "fresh", False) and getattr(args, "resume", False):
        raise InputError("--fresh and --resume: choose one (--fresh starts a new results file, --resume "
                         "continues the checkpoint of an interrupted run)")


def _basins(args, case, text, out_dir, spec, store) -> int:
    """Basins of a case into ``out_dir``: ``/basins/<run>/`` of results.h5, plots, a table
    (:func:`vibeam.api.run_basins`), through the command's results store."""
    from vibeam.api import run_basins  # lazy: keeps the engine (numba, scipy, matplotlib: 1.2 s) out of `vibeam --help`

    ex, client = _executor(args)
    partial = store.partial
    before, partial_before = _file_state(store.path), _file_state(partial)
    try:
        run_basins(case, text, out_dir, spec, jobs=args.jobs, executor=ex, progress=not args.quiet,
                   resume=getattr(args, "resume", False), plots=not args.no_plots, store=store)
    except KeyboardInterrupt as e:
        sig = "SIGTERM" if isinstance(e, Terminated) else "Ctrl-C"
        now, pnow = _file_state(store.path), _file_state(partial)
        kept = (f"{store.path} is as it was" if now == before and now is not None else
                "no results file was written" if now is None else f"the results are complete in {store.path}")
        # the rows are said to be kept only where the checkpoint holds them (written by this command)
        left = ("no row of the basins had finished" if pnow is None else
                f"no row of the basins had finished; {partial} is as it was" if pnow == partial_before else
                f"the finished rows of the basins are kept in {partial} (/basin_lines); rerun `vibeam basins` "
                f"with --resume to compute only the rest")
        print(f"vibeam: interrupted ({sig}); {kept}; {left}", file=sys.stderr)
        return _interrupt_code(e)
    finally:
        if client is not None:
            client.close()
    return 0


def cmd_uncertainty(args) -> int:
    """``vibeam uncertainty CASE``: the FRC bands of the case's ``[uncertainty]`` into
    ``/uncertainty/<run>/`` of results.h5 (:func:`vibeam.api.uncertainty.uncertainty`)."""
    # lazy: keeps the case schema (pydantic, numba: 0.4 s) out of `vibeam --help`
    from vibeam.case.schema import load_case
    from vibeam.io.outdir import check_folder  # lazy: keeps vibeam.io.outdir (32 modules) out of `vibeam --help`

    case, text = load_case(args.case)
    if case.uncertainty is None:
        raise CaseError(f"{args.case}: no [uncertainty] table; add one ([[uncertainty.parameter]] name, "
                        f"distribution, ...)")
    # lazy: keeps the engine (numba, scipy, matplotlib: 1.2 s) out of `vibeam --help`
    from vibeam.api.uncertainty import check_samples, uncertainty

    from vibeam.io.store import PARTIAL_SUFFIX  # lazy: keeps numpy and h5py (0.17 s) out of `vibeam --help`

    _check_fresh(args)
    check_samples(args.samples)      # before the folder is made
    out_dir = check_folder(_out_dir(args, case))
    h5 = out_dir / "results.h5"
    partial = h5.with_name(h5.name + PARTIAL_SUFFIX)
    before, partial_before = _file_state(h5), _file_state(partial)
    ex, client = _executor(args)
    try:
        uncertainty(case, samples=args.samples, jobs=args.jobs, executor=ex, out=out_dir, quick=args.quick,
                    progress=not args.quiet, fresh=args.fresh, quiet=args.quiet, plots=not args.no_plots,
                    resume=args.resume)
    except KeyboardInterrupt as e:
        sig = "SIGTERM" if isinstance(e, Terminated) else "Ctrl-C"
        now = _file_state(h5)
        kept = ("no results file was written" if now is None else f"{h5} is as it was" if now == before else
                f"the results are complete in {h5}")
        pnow = _file_state(partial)
        left = ("no sample had finished" if pnow is None or pnow == partial_before else
                f"the finished samples are kept in {partial} (/uncertainty_samples); rerun with --resume to "
                f"compute only the rest")
        print(f"vibeam: interrupted ({sig}); {kept}; {left}", file=sys.stderr)
        return _interrupt_code(e)
    finally:
        if client is not None:
            client.close()
    return 0


def cmd_basins(args) -> int:
    from pydantic import ValidationError  # lazy: keeps pydantic (43 modules) out of `vibeam --help`

    # lazy: keeps the case schema (pydantic, numba: 0.4 s) out of `vibeam --help`
    from vibeam.case.schema import BasinsSpec, load_case, validation_message
    from vibeam.io.outdir import check_folder  # lazy: keeps vibeam.io.outdir (32 modules) out of `vibeam --help`

    case, text = load_case(args.case)
    if args.quick:
        case = case.quick_variant()
    data = case.basins.model_dump(exclude_none=True) if case.basins is not None else {}
    if args.frequency_hz is not None or args.Omega is not None:
        data.pop("frequency_hz", None)
        data.pop("Omega", None)
        data.update({"frequency_hz": args.frequency_hz} if args.frequency_hz is not None else {"Omega": args.Omega})
    if args.grid is not None:
        data.pop("samples", None)
        data["grid"] = list(args.grid)
    if args.samples is not None:
        data.pop("grid", None)
        data["samples"] = args.samples
    for k in ("seed", "run", "along"):
        if getattr(args, k) is not None:
            data[k] = getattr(args, k)
    if not data:
        raise CaseError(f"{args.case}: no [basins] table; give --frequency-hz (or --Omega), or add [basins]")
    try:
        spec = BasinsSpec.model_validate(data)
    except ValidationError as e:
        raise CaseError(f"{args.case}: " + validation_message(e, "basins", BasinsSpec)) from None
    if spec.frequency_hz is None and (spec.Omega is not None or case.sweep.Omega is not None):
        try:        # the frequencies' range and the number of states, before any model is built
            spec.frequencies(case.sweep)
        except ValueError as e:
            raise CaseError(f"{args.case}: {e}") from None
    from vibeam.io.store import Store  # lazy: keeps numpy and h5py (0.17 s) out of `vibeam --help`

    _check_fresh(args)
    out_dir = check_folder(_out_dir(args, case))
    with Store(out_dir, fresh=args.fresh) as store:
        return _basins(args, case, text, out_dir, spec, store)


def cmd_regress(args) -> int:
    from vibeam.api import regress  # lazy: keeps the engine (numba, scipy, matplotlib: 1.2 s) out of `vibeam --help`

    ex, client = _executor(args)
    try:
        res = regress(args.case, args.reference, results=args.results, out=args.out, jobs=args.jobs, executor=ex,
                      atol=args.atol, rtol=args.rtol, quick=args.quick, force=args.force, quiet=args.quiet)
    finally:
        if client is not None:
            client.close()
    res.print()
    return 0 if res.ok else 1


def cmd_cost(args) -> int:
    # lazy: keeps the engine (numba, scipy, matplotlib: 1.2 s) out of `vibeam --help`
    from vibeam.analysis.cost import print_cost
    from vibeam.api import cost  # lazy: keeps the engine (numba, scipy, matplotlib: 1.2 s) out of `vibeam --help`
    # lazy: keeps the case schema (pydantic, numba: 0.4 s) out of `vibeam --help`
    from vibeam.case.schema import load_case

    case, _ = load_case(args.case)
    out_dir = _out_dir(args, case.quick_variant() if args.quick else case)
    res = cost(args.case, out=out_dir, ladder=args.ladder, repeats=args.repeats, quick=args.quick, jobs=args.jobs,
               force=args.force, log=(lambda m: None) if args.quiet else (lambda m: print(m, file=sys.stderr)),
               plots=not args.no_plots)
    print_cost(res.result)
    png = f", plot -> {res.paths['png']}" if res.paths.get("png") else ""
    print(f"\ncost table -> {res.paths['h5']} (/cost){png}")
    return 0


def cmd_derive(args) -> int:
    from vibeam.api import derive  # lazy: keeps the engine (numba, scipy, matplotlib: 1.2 s) out of `vibeam --help`

    d = derive(args.case, write=args.write)
    print(f"SDOF parameters of {d.case.name} by the assumed static mode (paper Eqs. 42-46)\n")
    print(f"{'parameter':<20}{'value':>14}  {'unit':<8}source")
    for name, val, unit, src in d.rows:
        print(f"{name:<20}{val:>14.6g}  {unit:<8}{src}")
    if args.write:
        print(f"\nSDOF case written to {args.write}")
    return 0


def cmd_modes(args) -> int:
    from vibeam.api import modes  # lazy: keeps the engine (numba, scipy, matplotlib: 1.2 s) out of `vibeam --help`
    # lazy: keeps the case schema (pydantic, numba: 0.4 s) out of `vibeam --help`
    from vibeam.case.schema import load_case
    from vibeam.io.outdir import default_folder  # lazy: keeps vibeam.io.outdir (32 modules) out of `vibeam --help`

    case, _ = load_case(args.case)
    rep = modes(case, n=args.n, out=Path(args.out) if args.out else default_folder(case.name), plots=not args.no_plots)
    md, cm = rep.modes, rep.contact
    tot = rep.total_mass_kg
    r = rep.report
    kind = r.get("kind") or f"FE, {rep.fe.ndof} DOFs"
    if r.get("info") is not None:          # a continuum: built now or loaded from its cache, how long
        print(r["info"].summary())
    print(f"modes of {case.name} ({kind}); base excitation, total mass {tot:.4g} kg\n")
    print(f"{'mode':>4}{'f (Hz)':>12}{'m at sensor (kg)':>18}{'Gamma (kg^.5)':>15}{'m_eff (kg)':>12}"
          f"{'m_eff %':>9}{'cum. %':>8}")
    cum = 0.0
    for i, f in enumerate(md.frequencies_hz):
        me = md.effective_mass_kg[i]
        cum += me
        print(f"{i + 1:>4}{f:>12.4f}{rep.sensor_modal_mass_kg[i]:>18.4g}{md.participation[i]:>15.4g}"
              f"{me:>12.4g}{100 * me / tot:>9.2f}{100 * cum / tot:>8.2f}")
    print(f"\ncontact modes ({r.get('contact_note', 'beam held at the stop, w(L_m) = 0')}): " +
          ", ".join(f"{f:.2f}" for f in cm.frequencies_hz[: args.n]) + " Hz")
    print(f"mode shapes -> {rep.paths['vtu']} (ParaView)" + (f", {rep.paths['png']}" if rep.paths.get("png") else ""))
    return 0


def cmd_cases(args) -> int:
    # lazy: keeps the case schema (pydantic, numba: 0.4 s) out of `vibeam --help`
    from vibeam.case.reference import catalogue_text

    folder = Path(args.folder) if args.folder else Path("cases")
    if args.folder is None and not folder.is_dir():    # the cases shipped beside the package
        folder = Path(__file__).resolve().parents[1] / "cases"
    if not folder.is_dir() or not any(folder.glob("*.toml")):
        raise InputError(f"{folder}: no case files (*.toml) in this folder; give a folder of cases")
    print(catalogue_text(folder))
    return 0


def cmd_export(args) -> int:
    from vibeam.api import export  # lazy: keeps the engine (numba, scipy, matplotlib: 1.2 s) out of `vibeam --help`

    try:
        files = export(args.results, args.csv)
    except CaseError:
        raise
    except (ValueError, KeyError, TypeError, IndexError) as e:
        # a group that cannot be laid out as tables: one line, and no file was written (every
        # table is built before the first file is)
        raise InputError(one_line(f"{args.results}: cannot export: {type(e).__name__}: {e}; no CSV file was "
                                  f"written")) from None
    for p in files:
        print(f"{p} (units: {p.with_suffix('.units.csv').name})")
    print(f"{len(files)} CSV file(s) -> {args.csv}")
    return 0


def cmd_poincare(args) -> int:
    from vibeam.api import poincare  # lazy: keeps the engine (numba, scipy, matplotlib: 1.2 s) out of `vibeam --help`
    # lazy: keeps the case schema (pydantic, numba: 0.4 s) out of `vibeam --help`
    from vibeam.case.schema import load_case
    # lazy: keeps vibeam.io.outdir (32 modules) out of `vibeam --help`
    from vibeam.io.outdir import check_folder, check_output_file

    case, _ = load_case(args.case)
    if (args.frequency_hz is None) == (args.Omega is None):
        raise CaseError(f"{args.case}: `vibeam poincare` needs one of --frequency-hz F or --Omega W")
    if args.quick:                   # the quick variant's transient (and its folder), as run --quick
        case = case.quick_variant()
    # --no-plots: the sections are printed and nothing is written (the folder is not even created)
    out_dir = check_folder(_out_dir(args, case)) if not args.no_plots else None
    f = args.frequency_hz if args.frequency_hz is not None else args.Omega
    stem = f"poincare_{'f' if args.frequency_hz is not None else 'Omega'}{f:g}"
    if out_dir is not None:
        check_output_file(out_dir / f"{stem}.png")  # before anything is computed
    try:
        sec = poincare(case, Omega=args.Omega, frequency_hz=args.frequency_hz, periods=args.periods,
                       transient=args.transient, run=args.run if args.run is not None else 0,
                       out=out_dir / f"{stem}.png" if out_dir is not None else None, force=args.force)
    except (TypeError, ValueError) as e:
        raise CaseError(f"{args.case}: {e}") from None
    fx, fv = sec.scales
    xu, vu = ("mm", "mm/s") if sec.physical else ("-", "-")
    where = f"{sec.frequency_hz:.6g} Hz (Omega {sec.Omega:.8g})" if sec.frequency_hz else f"Omega = {sec.Omega:.8g}"
    print(f"Poincare sections of {case.name} at {where}: {sec.period_text}, {sec.status}")
    print(f"  stroboscopic: {sec.strobe_q.size} samples, q in [{sec.strobe_q.min() * fx:.6g}, "
          f"{sec.strobe_q.max() * fx:.6g}] {xu}, q' in [{sec.strobe_dq.min() * fv:.6g}, {sec.strobe_dq.max() * fv:.6g}] {vu}")
    if sec.impact_phase.size:
        print(f"  impacts: {sec.impact_phase.size}, phase in [{sec.impact_phase.min():.6f}, "
              f"{sec.impact_phase.max():.6f}] rad, velocity in [{sec.impact_velocity.min() * fv:.6g}, "
              f"{sec.impact_velocity.max() * fv:.6g}] {vu}")
    else:
        print("  impacts: none")
    if out_dir is not None:
        print(f"plot: {out_dir / (stem + '.png')}")
    return 0


def main(argv=None) -> int:
    ap = _Parser(prog="vibeam", description="Vibro-impact structural dynamics of an "
                 "impacting cantilever beam (multi-fidelity).",
                 epilog="exit codes: " + "; ".join(f"{k} {v}" for k, v in EXIT_CODES.items()))
    ap.add_argument("--version", action="version", version=f"vibeam {__version__}")
    sub = ap.add_subparsers(dest="command", required=True)
    force_help = ("run even if the estimated work is above the limit (vibeam.runner.MAX_WORK_STEPS: "
                  "Omega near 0, huge transient_periods, ...)")

    def run_args(p):
        p.add_argument("case", help="case file (TOML)")
        p.add_argument("--out", type=path_option("--out"), help="output folder (default results/<case name>/)")
        p.add_argument("--jobs", type=jobs_option, default=None,
                       help="worker processes of the local pool (default: all cores; 1: inline)")
        p.add_argument("--no-plots", action="store_true", help="skip the PNG plots")
        p.add_argument("--quiet", action="store_true", help=QUIET_HELP)
        p.add_argument("--quick", action="store_true",
                       help="run the case's quick variant ([quick]: fewer points, periods and map values)")
        p.add_argument("--resume", action="store_true",
                       help="continue an interrupted run: keep the sweep lines already in the checkpoint "
                            "results.h5.partial (of this case, also when an earlier vibeam wrote them)")
        p.add_argument("--fresh", action="store_true", help=FRESH_HELP)
        p.add_argument("--scheduler", metavar="ADDRESS",
                       help="run the sweep lines on a dask.distributed scheduler (e.g. tcp://host:8786)")
        p.add_argument("--force", action="store_true", help=force_help)

    p = sub.add_parser("run", help="run the sweeps (or the [map]) of a case file; write results.h5, plots "
                       "and a table", formatter_class=argparse.RawDescriptionHelpFormatter, epilog="Example:\n  vibeam run cases/paper-fig7.toml --jobs 2\n  vibeam run cases/rig-tight.toml --quick --out results/tight-quick")
    run_args(p)
    p.set_defaults(func=cmd_run)
    p = sub.add_parser("continue", help="run the continuation runs of a case (method = \"continuation\"): "
                       "branches of periodic orbits with stability and bifurcations",
                       formatter_class=argparse.RawDescriptionHelpFormatter, epilog="Example:\n  vibeam continue cases/paper-fig13-continuation.toml")
    p.add_argument("case", help="case file (TOML)")
    p.add_argument("--out", type=path_option("--out"),
                   help="output folder (default results/<case name>/; a results.h5 there keeps its other "
                   "groups, only /branches/<run> of these runs is replaced)")
    p.add_argument("--fresh", action="store_true", help=FRESH_HELP)
    p.add_argument("--jobs", type=jobs_option, default=None,
                   help="worker processes of the local pool (default: all cores; 1: inline)")
    p.add_argument("--no-plots", action="store_true", help="skip the PNG plots")
    p.add_argument("--quiet", action="store_true", help=QUIET_HELP)
    p.add_argument("--quick", action="store_true", help="the case's quick variant")
    p.add_argument("--scheduler", metavar="ADDRESS",
                   help="run on a dask.distributed scheduler (e.g. tcp://host:8786)")
    p.add_argument("--force", action="store_true", help=force_help)
    p.set_defaults(func=lambda a: cmd_run(a, continuation_only=True))
    p = sub.add_parser("map", help="parameter map of a case with [map] (period-n regions, paper Fig. 18)",
                       formatter_class=argparse.RawDescriptionHelpFormatter, epilog="Example:\n  vibeam map cases/rig-map-gap.toml --quick")
    run_args(p)
    p.set_defaults(func=lambda a: cmd_run(a, need_map=True))
    p = sub.add_parser("uncertainty", help="FRC bands from the case's [uncertainty] (scrambled Sobol' samples "
                       "of its parameters' distributions): quantiles, outcome probabilities, jump frequencies, "
                       "and per pair of runs the verdict", formatter_class=argparse.RawDescriptionHelpFormatter,
                       epilog="Example:\n  vibeam uncertainty cases/rig-tight-uncertainty.toml --samples 64 --jobs 2")
    p.add_argument("case", help="case file (TOML) with an [uncertainty] table")
    p.add_argument("--samples", type=int, metavar="N", help="samples instead of [uncertainty] samples (a power of 2)")
    p.add_argument("--out", type=path_option("--out"), help="output folder (default results/<case name>/; its "
                   "results.h5 keeps its other groups, /uncertainty/<run> is replaced)")
    p.add_argument("--jobs", type=jobs_option, default=None,
                   help="worker processes of the local pool (default: all cores; 1: inline)")
    p.add_argument("--quiet", action="store_true", help=QUIET_HELP)
    p.add_argument("--quick", action="store_true", help="the case's quick variant, at 8 samples")
    p.add_argument("--no-plots", action="store_true", help="skip uncertainty.png (the FRC bands)")
    p.add_argument("--fresh", action="store_true", help=FRESH_HELP)
    p.add_argument("--resume", action="store_true",
                   help="continue an interrupted run: keep the samples already in the checkpoint results.h5.partial "
                        "(of this case and number of samples); the results are those of an uninterrupted run")
    p.add_argument("--scheduler", metavar="ADDRESS",
                   help="run the samples on a dask.distributed scheduler (e.g. tcp://host:8786)")
    p.set_defaults(func=cmd_uncertainty)
    p = sub.add_parser("basins", help="basins of attraction (or the census of attractors) at a forcing "
                       "frequency: every attractor, its type, period, amplitude, basin fraction and Lyapunov "
                       "exponents", formatter_class=argparse.RawDescriptionHelpFormatter,
                       epilog="Example:\n  vibeam basins cases/rig-tight.toml --frequency-hz 16.5 --grid 200 200\n"
                       "  vibeam basins cases/paper-fig7-two-sided.toml --Omega 2.38 --samples 400 --seed 1\n"
                       "  vibeam basins cases/rig-map-gap.toml --frequency-hz 16.5 --samples 100 --along map")
    p.add_argument("case", help="case file (TOML); its [basins] table gives the defaults")
    p.add_argument("--frequency-hz", dest="frequency_hz", type=float, nargs="+", metavar="F",
                   help="forcing frequencies in Hz (physical scenes)")
    p.add_argument("--Omega", type=float, nargs="+", metavar="W", help="forcing frequencies (nondimensional)")
    p.add_argument("--grid", type=int, nargs=2, metavar=("NX", "NY"), help="initial states on a grid (default 200 200)")
    p.add_argument("--samples", type=int, metavar="N", help="N random initial states instead of a grid")
    p.add_argument("--seed", type=int, help="seed of the random initial states")
    p.add_argument("--run", help="the run whose model and solver are used (default: the first time-domain run)")
    p.add_argument("--along", choices=("frequency", "map"),
                   help="a census along the frequencies (default) or, in a [map] case, at one frequency along "
                   "the mapped parameter's values")
    p.add_argument("--out", type=path_option("--out"), help="output folder (default results/<case name>/; "
                   "its results.h5 keeps its other groups, /basins/<run> is replaced)")
    p.add_argument("--jobs", type=jobs_option, default=None,
                   help="worker processes of the local pool (default: all cores; 1: inline)")
    p.add_argument("--no-plots", action="store_true", help="skip the PNG plots")
    p.add_argument("--quiet", action="store_true", help=QUIET_HELP)
    p.add_argument("--quick", action="store_true", help="the case's quick variant (a 40 x 40 grid at most)")
    p.add_argument("--resume", action="store_true",
                   help="continue an interrupted computation: keep the grid rows already in results.h5.partial")
    p.add_argument("--fresh", action="store_true", help=FRESH_HELP)
    p.add_argument("--scheduler", metavar="ADDRESS",
                   help="run on a dask.distributed scheduler (e.g. tcp://host:8786)")
    p.set_defaults(func=cmd_basins)
    p = sub.add_parser("regress", help="compare a case's FRCs with reference FRCs (HDF5 or CSV); exit 1 on a "
                       "regression, 2 on bad input",
                       formatter_class=argparse.RawDescriptionHelpFormatter, epilog="Example:\n  vibeam regress cases/paper-fig7.toml --reference tests/references/paper-fig7.h5 --quick")
    p.add_argument("case", help="case file (TOML)")
    p.add_argument("--reference", type=path_option("--reference"), required=True,
                   help="reference results.h5 or CSV")
    p.add_argument("--results", type=path_option("--results"),
                   help="compare this results file instead of rerunning the case")
    p.add_argument("--out", type=path_option("--out"),
                   help="output folder of the rerun (default: a temporary folder, removed afterwards; "
                   "the results of `vibeam run` in results/<case name>/ are never touched)")
    p.add_argument("--jobs", type=jobs_option, default=None,
                   help="worker processes of the rerun's local pool (default: all cores; 1: inline)")
    p.add_argument("--scheduler", metavar="ADDRESS",
                   help="run the rerun on a dask.distributed scheduler (e.g. tcp://host:8786)")
    p.add_argument("--atol", type=case_value_option("--atol", "RegressSpec", "amplitude_atol"), default=None,
                   help="override [regress] amplitude_atol (a finite number >= 0)")
    p.add_argument("--rtol", type=case_value_option("--rtol", "RegressSpec", "amplitude_rtol"), default=None,
                   help="override [regress] amplitude_rtol (a finite number >= 0)")
    p.add_argument("--quick", action="store_true",
                   help="rerun the case's quick variant (as the references in tests/references/)")
    p.add_argument("--force", action="store_true", help=force_help)
    p.set_defaults(func=cmd_regress)
    p = sub.add_parser("cost", help="accuracy against time of every run (work-precision table and plot)",
                       formatter_class=argparse.RawDescriptionHelpFormatter, epilog="Example:\n  vibeam cost cases/paper-fig7-methods.toml --quick --repeats 1")
    p.add_argument("case", help="case file (TOML)")
    p.add_argument("--out", type=path_option("--out"), help="output folder (default results/<case name>/)")
    p.add_argument("--ladder", action="store_true", help="also a ladder of tolerances per ODE method")
    p.add_argument("--repeats", type=_int_at_least(1), default=3, help="timed repetitions (median reported)")
    p.add_argument("--quick", action="store_true",
                   help="the case's quick variant ([quick]: fewer points and periods)")
    p.add_argument("--jobs", type=jobs_option, default=None,
                   help="worker processes for the converged references (default: all cores); the timed "
                        "sweeps always run inline, one at a time")
    p.add_argument("--force", action="store_true", help=force_help)
    p.add_argument("--no-plots", action="store_true", help="skip work_precision.png (cost.h5 is written)")
    p.set_defaults(func=cmd_cost)
    p = sub.add_parser("derive", help="SDOF parameters of a beam scene by the assumed static mode",
                       formatter_class=argparse.RawDescriptionHelpFormatter, epilog="Example:\n  vibeam derive cases/rig-fe-tight.toml --write rig-sdof.toml")
    p.add_argument("case", help="beam case file (TOML)")
    p.add_argument("--write", type=path_option("--write"), metavar="FILE",
                   help="write the SDOF case file of the same scene")
    p.set_defaults(func=cmd_derive)
    p = sub.add_parser("modes", help="natural frequencies, participation, effective and contact modes",
                       formatter_class=argparse.RawDescriptionHelpFormatter, epilog="Example:\n  vibeam modes cases/rig-fe-tight.toml -n 4")
    p.add_argument("case", help="beam case file (TOML)")
    p.add_argument("--out", type=path_option("--out"), help="output folder (default results/<case name>/)")
    p.add_argument("-n", type=_int_at_least(1), default=6, help="number of modes (default 6)")
    p.add_argument("--no-plots", action="store_true", help="skip modes.png (modes.vtu is written)")
    p.set_defaults(func=cmd_modes)
    # ---- vibeam fit (vibeam.identify.fit, vibeam.identify.linear): identification from measurements, paper Secs. 6-7
    p = sub.add_parser("fit", help="fit model parameters to a measured FRC (with standard errors), or the "
                       "linear steps: Eq. 43 around f_n (--linear), beta_S from a free decay (--decay)",
                       formatter_class=argparse.RawDescriptionHelpFormatter, epilog="Example:\n  vibeam fit cases/rig-tight.toml --reference measured.csv --params gain,R --jobs 2\n  vibeam fit cases/rig-tight.toml --decay decay.csv")
    p.add_argument("case", help="case file (TOML); its [model] values start the fit")
    p.add_argument("--reference", type=path_option("--reference"),
                   help="measured FRC: CSV 'frequency_hz,amplitude_mm' (or 'Omega,amplitude'), "
                   "optional columns 'direction' (up/down) and 'sigma'; or a results.h5")
    p.add_argument("--reference-run", help="run of an HDF5 reference with several runs")
    p.add_argument("--params", help="comma-separated numeric [model] keys to fit (default gain,R; on a "
                   "structure's or continuum's tables the excitation's amplitude and stops[0].law.R; with "
                   "--linear natural_frequency_hz,damping_ratio,gain)")
    p.add_argument("--run", help="fit this run only (default: every run of the case, one by one)")
    p.add_argument("--out", type=path_option("--out"), help="output folder (default results/<case name>@fit/)")
    p.add_argument("--jobs", type=jobs_option, default=None, help="worker processes (default: all cores; 1: inline)")
    p.add_argument("--quick", action="store_true", help="sweep with the case's quick variant's periods")
    p.add_argument("--loss", choices=["linear", "soft_l1", "huber", "cauchy", "arctan"], default=None,
                   help="least_squares loss (default soft_l1; --linear: linear)")
    p.add_argument("--f-scale", type=float, default=3.0,
                   help="scale of the robust loss in units of sigma (default 3)")
    p.add_argument("--max-evaluations", type=_int_at_least(1), default=60, help="max residual evaluations (sweeps)")
    p.add_argument("--linear", action="store_true", help="fit Eq. 43 without the stop to an FRC around f_n")
    p.add_argument("--decay", type=path_option("--decay"), metavar="DECAY.csv",
                   help="identify beta_S from a free decay 't_s,U_mm'")
    p.add_argument("--no-plots", action="store_true", help="skip fit.png")
    p.add_argument("--quiet", action="store_true", help=QUIET_HELP)
    p.set_defaults(func=lambda a: __import__("vibeam.identify.fit", fromlist=["main_fit"]).main_fit(a))
    p = sub.add_parser("cases", help="the shipped cases, one line each: file, fidelity, what it shows",
                       formatter_class=argparse.RawDescriptionHelpFormatter,
                       epilog="Example:\n  vibeam cases\n  vibeam cases my-cases/")
    p.add_argument("folder", nargs="?", default=None,
                   help="folder of case files (default ./cases, else the cases shipped with vibeam)")
    p.set_defaults(func=cmd_cases)
    p = sub.add_parser("export", help="write every group of a results file as tidy CSV files (one row per "
                       "point, coordinates as columns, units in a .units.csv sidecar)",
                       formatter_class=argparse.RawDescriptionHelpFormatter, epilog="Example:\n  vibeam export results/paper-fig7/results.h5 --csv results/paper-fig7/csv")
    p.add_argument("results", type=path_option("RESULTS.h5"), help="results file (results.h5)")
    p.add_argument("--csv", type=path_option("--csv"), metavar="DIR", required=True,
                   help="output folder of the CSV files (created if missing; files replaced atomically)")
    p.set_defaults(func=cmd_export)
    p = sub.add_parser("poincare", help="Poincare sections at one forcing frequency: stroboscopic samples "
                       "(q, q') after the transient and the impact map (impact phase against impact velocity)",
                       formatter_class=argparse.RawDescriptionHelpFormatter, epilog="Example:\n  vibeam poincare cases/paper-fig7.toml --Omega 2.0\n  vibeam poincare cases/rig-tight.toml --frequency-hz 16.5 --periods 200")
    p.add_argument("case", help="case file (TOML)")
    p.add_argument("--frequency-hz", dest="frequency_hz", type=float, metavar="F",
                   help="forcing frequency in Hz (physical scenes)")
    p.add_argument("--Omega", type=float, metavar="W", help="forcing frequency (nondimensional)")
    p.add_argument("--periods", type=_int_at_least(1), default=64,
                   help="forcing periods recorded: stroboscopic samples (default 64)")
    p.add_argument("--transient", type=_int_at_least(0), default=None,
                   help="periods simulated first (default: the case's transient_periods; 2000 for \"auto\")")
    p.add_argument("--quick", action="store_true",
                   help="the case's quick variant: its [quick] transient_periods (default folder "
                        "results/<case name>@quick/)")
    p.add_argument("--run", help="the run whose model and solver are used (default: the first)")
    p.add_argument("--out", type=path_option("--out"), help="output folder (default results/<case name>/)")
    p.add_argument("--force", action="store_true", help=force_help)
    p.add_argument("--no-plots", action="store_true", help="print the sections only: no PNG, nothing written")
    p.set_defaults(func=cmd_poincare)
    p = sub.add_parser("bench", help="speed and accuracy against the stated goals: JSON on stdout, a PASS/FAIL "
                       "line per goal on stderr (NOT CHECKED outside the goal's configuration, and for a timing that fails on a "
                       "busy machine unless --strict); exit 1 after a FAIL",
                       description="Default: the exact event solver against solve_ivp (direct RK23, rtol 1e-4, "
                       "atol 1e-8) on the Fig. 7 scene, inline, with the goals: event sweep under 1 s, >= 300x "
                       "faster, >= 1000x smaller error.  The other modes (--cli, --map, --scaling, --effects, "
                       "--shooting, --continuation, --fit, --latency, --compile, --basins, --continuum, --estimate) replace it.",
                       formatter_class=argparse.RawDescriptionHelpFormatter, epilog="Example:\n  vibeam bench --points 21 --repeats 1\n  vibeam bench --continuation")
    p.add_argument("--points", type=_int_at_least(1), default=101,
                   help="frequencies of the Fig. 7 sweep (default 101)")
    p.add_argument("--periods", type=_int_at_least(65), default=500,
                   help="forcing periods per point, transient + the 64 recorded ones (> 64; default 500)")
    p.add_argument("--repeats", type=_int_at_least(1), default=5,
                   help="timed repetitions, the median is reported (default 5; --cli: runs of the command)")
    p.add_argument("--direct-points", type=_int_at_least(1), default=None,
                   help="time solve_ivp on this many points only and scale (quick look; --cli default 11)")
    p.add_argument("--cli", action="store_true",
                   help="instead: `vibeam run cases/paper-fig7.toml` in fresh processes, its own reported run time "
                        "per point against direct RK23 per point (goal >= 300x)")
    p.add_argument("--map", action="store_true",
                   help="instead: parameter-map points per second on 1 and 2 workers and the cost of the "
                        "line checkpoint (goals: checkpoint <= 10 %%, 2 workers >= 1.6x, same maps)")
    p.add_argument("--scaling", action="store_true",
                   help="instead: how the cost of a sweep grows with periods simulated and with retained modes, "
                        "fitted exponents (goals: linear in periods, at most linear in modes)")
    p.add_argument("--shooting", action="store_true",
                   help="instead: cost of the beam's periodic-orbit shots (with and without the monodromy) "
                        "and of Newton solves against the event solver")
    p.add_argument("--effects", action="store_true",
                   help="instead: time a rig sweep (SDOF, FE 2 modes) plain and with each scene effect "
                        "(goal: no effect more than doubles the sweep)")
    p.add_argument("--continuation", action="store_true",
                   help="instead: the continuation of an SDOF period-1 branch through its fold (~500 points, "
                        "goal < 0.1 s) and its cost per FRC point against a sweep of equal accuracy")
    p.add_argument("--fit", action="store_true",
                   help="instead: time `vibeam fit` (2-parameter SDOF fit on 30 points, goal < 10 s; FE 2 modes)")
    p.add_argument("--latency", action="store_true",
                   help="instead: seconds from SIGINT to exit of an inline long point and of a --jobs 2 map, "
                        "and the overshoot of point_time_limit_s (goal: each within 1 s)")
    p.add_argument("--uncertainty", action="store_true",
                   help="instead: sampled sweep points per second of [uncertainty] against the plain sweeps of the "
                        "same samples (SDOF tight rig, R and gap sampled, 61 frequencies; goals: the layer costs "
                        "<= 5 %%, 1024 samples on 2 cores in <= 60 s; --samples N)")
    p.add_argument("--compile", action="store_true",
                   help="instead: numba compile time of the quick start, a first compliant SDOF point, the first "
                        "FE 2- and 4-mode points and the first SDOF `vibeam continue` (inline, and on a pool of 2), "
                        "cold (empty NUMBA_CACHE_DIR) and warm, in fresh processes: JSON with the cold compile time "
                        "of each kernel specialisation a scenario uses (key kernel_specialisations) and of every "
                        "compiled function (goals: quick start <= 5 s; each scenario compiles only the event "
                        "integrator's specialisation it uses; pool workers and warm runs compile nothing)")
    p.add_argument("--settling", action="store_true",
                   help="instead: forcing periods simulated per sweep point (mean, max) with the fixed transient and "
                   "with [sweep] settle = true: the Fig. 7 sweep, the tight rig's ladder (quick), the --uncertainty "
                   "scene (--samples, default 16)")
    p.add_argument("--basins", action="store_true",
                   help="instead: a 200 x 200 SDOF basin of the tight rig at 16.5 Hz and one of the two-sided Fig. 7 "
                        "scene's symmetric run at Omega 2.0 (goal < 20 s on 2 cores each), "
                        "basin hits against full trajectories, and a 50 x 50 basin of the 4-mode FE rig")
    p.add_argument("--continuum", action="store_true",
                   help="instead: the rig's continuum (cases/rig-continuum.toml) built cold into an empty model cache "
                        "(goal <= 30 s on 2 cores) and loaded from it (<= 1 s), and its sweep cost per impact against "
                        "the FE beam with as many modes (neutral gap, same Omega band; goal within 1.25x)")
    p.add_argument("--estimate", action="store_true",
                   help="instead: the work estimate that decides inline against pool, against the run time it "
                        "estimates, on the cell matrix's scenes (SDOF and 2-mode beam, each law, one or two stops; "
                        "goal: every ratio within 10x)")
    p.add_argument("--jobs", type=jobs_option, default=None, help="workers of --fit, --basins and --uncertainty "
                   "(default 2)")
    p.add_argument("--samples", type=int, default=None, help="samples of --uncertainty (default 1024)")
    p.add_argument("--strict", action="store_true",
                   help="judge timing goals on a busy machine too (default: a timing goal that fails while the "
                        "1-minute load average, the benchmark's own process included, is above 1.25 per core is "
                        "NOT CHECKED, the load said; the JSON's 'machine' records it)")
    p.set_defaults(func=lambda a: __import__("vibeam.bench", fromlist=["main_bench"]).main_bench(a))
    for name, sp in sub.choices.items():          # --quiet means the same for every command (module doc)
        if name not in NOT_QUIET and not any("--quiet" in a.option_strings for a in sp._actions):
            sp.add_argument("--quiet", action="store_true", help=QUIET_HELP)
    args = ap.parse_args(argv)
    return _dispatch(args)


@contextlib.contextmanager
def _reading(args):
    """The command's input files, for :func:`vibeam.io.outdir.check_output_file` (no command
    writes a file it reads); and a command with an output folder leaves no empty folder it
    created: one that fails (or is interrupted) before its first file changes nothing on the disk
    (:func:`vibeam.io.outdir.removing_empty_folders`)."""
    inputs = _inputs(args)
    writes = hasattr(args, "out")
    if not inputs and not writes:
        yield
        return
    # lazy: keeps vibeam.io.outdir (32 modules) out of `vibeam cases`
    from vibeam.io.outdir import reading, removing_empty_folders

    with reading(inputs) if inputs else contextlib.nullcontext(), \
            removing_empty_folders() if writes else contextlib.nullcontext():
        yield


def _interrupted_by(exc: type) -> int:
    """The one line and exit code of a recorded signal whose interrupt was lost on its way."""
    print(f"vibeam: interrupted ({'SIGTERM' if issubclass(exc, Terminated) else 'Ctrl-C'})", file=sys.stderr)
    return 143 if issubclass(exc, Terminated) else 130


def _report_crashes() -> None:
    """A crash in native code (SIGSEGV, SIGFPE, SIGABRT, SIGBUS, SIGILL) prints the Python
    traceback of every thread to stderr before the process dies (:mod:`faulthandler`), so that a
    user's report, or CI's, says where; nothing where stderr has no file descriptor."""
    if faulthandler.is_enabled() or sys.__stderr__ is None:
        return
    try:
        faulthandler.enable(file=sys.__stderr__, all_threads=True)
    except (AttributeError, ValueError, OSError):    # io.UnsupportedOperation is an OSError and a ValueError
        pass


def _dispatch(args) -> int:
    """Run a parsed command: errors as one line and exit 2, interrupts as 130/143."""
    _report_crashes()
    stdout = sys.stdout
    dropped = open(os.devnull, "w") if getattr(args, "quiet", False) else None     # --quiet: no tables
    sys.stdout = dropped if dropped is not None else _QuietPipe(stdout)
    # SIGINT and SIGTERM are recorded before they raise: an interrupt that compiled code or a
    # broad except swallowed still stops the work at its next step and wins over success below
    installed: list = []

    def recorded():
        return next((h.recorded for h in installed if h.recorded is not None), None)

    try:
        with recording_signals({signal.SIGTERM: lambda signum, frame: _on_sigterm(signum, frame)}) as installed, \
                _reading(args):
            code = args.func(args)
        if recorded() is not None and code not in (130, 143):     # swallowed on its way: it still wins
            return _interrupted_by(recorded())
        return code
    except CaseError as e:
        if recorded() is not None:
            return _interrupted_by(recorded())
        print(f"vibeam: error: {one_line(str(e))}", file=sys.stderr)
        return 2
    except KeyboardInterrupt as e:
        print(f"vibeam: interrupted ({'SIGTERM' if isinstance(e, Terminated) else 'Ctrl-C'})", file=sys.stderr)
        return _interrupt_code(e)
    except OSError as e:
        # a file system error (full disk, permissions, a folder where a file should be): one line
        # naming the file; nothing written is partial (every writer goes through a temporary file)
        if recorded() is not None:
            return _interrupted_by(recorded())
        if isinstance(e, BrokenPipeError):
            return 0
        what = e.filename or ""
        why = e.strerror or str(e)
        if e.errno == errno.ENOSPC:
            why = "no space left on the device"
        elif e.errno == errno.EFBIG:
            why = "file too large (the file system's or the process's file-size limit, ulimit -f)"
        elif e.errno == errno.EDQUOT:
            why = "disk quota exceeded"
        print(f"vibeam: error: {one_line(f'{what}: {why}' if what else why)}", file=sys.stderr)
        return 2
    except Exception:
        # the error of a signal's handler that ran inside compiled code (numba's unboxing turned the
        # interrupt into a TypeError): the recorded signal wins over it
        if recorded() is None:
            raise
        return _interrupted_by(recorded())
    finally:
        try:
            sys.stdout.flush()
        except Exception:
            pass
        sys.stdout = stdout
        if dropped is not None:
            dropped.close()


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
