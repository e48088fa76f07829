"""Command line: ``vibeam run CASE.toml [--out DIR] [--jobs N]``.

Heavy modules (numba kernels, h5py, matplotlib) are imported only by the
command that needs them, so ``vibeam --help`` and case errors are instant.
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path


def run_case(*args, **kwargs):
    """:func:`vibeam.runner.run_case` (imported when called, so ``vibeam --help`` stays instant)."""
    from .runner import run_case as run

    return run(*args, **kwargs)


def _executor(args):
    from .runner import open_executor

    return open_executor(getattr(args, "scheduler", None))


def cmd_run(args, need_map=False) -> int:
    from .case import CaseError, load_case

    case, text = load_case(args.case)
    if need_map and case.map is None:
        raise CaseError(f"{args.case}: `vibeam map` needs a [map] table (parameter, values); "
                        f"use `vibeam run` for a plain sweep")
    out_dir = Path(args.out) if args.out else Path("results") / (case.name + ("-quick" if args.quick else ""))
    ex, client = _executor(args)
    try:
        run_case(case, text, out_dir, jobs=args.jobs, quiet=args.quiet, plots=not args.no_plots,
                 quick=args.quick, resume=args.resume, executor=ex)
    except KeyboardInterrupt:
        print(f"\nvibeam: interrupted; finished sweep lines are kept in {out_dir / 'results.h5'}; "
              f"rerun with --resume to compute only the rest", file=sys.stderr)
        return 130
    finally:
        if client is not None:
            client.close()
    return 0


def cmd_regress(args) -> int:
    from .case import load_case

    case, text = load_case(args.case)
    from .regress import compare, print_rows
    from .results import read_results

    if args.results:
        new = read_results(args.results)
    else:
        out_dir = Path(args.out) if args.out else Path("results") / (case.name + ("-quick" if args.quick else ""))
        ex, client = _executor(args)
        try:
            run_case(case, text, out_dir, jobs=args.jobs, quiet=True, plots=False, quick=args.quick,
                     executor=ex)
        finally:
            if client is not None:
                client.close()
        new = read_results(out_dir / "results.h5")
    tol = case.regress
    atol = tol.amplitude_atol if args.atol is None else args.atol
    rtol = tol.amplitude_rtol if args.rtol is None else args.rtol
    rows = compare(new, args.reference, atol=atol, rtol=rtol, period=tol.period)
    print(f"\nregression of {case.name} against {args.reference}")
    print_rows(rows, atol, rtol)
    return 0 if rows and all(r.ok for r in rows) else 1


def cmd_cost(args) -> int:
    from .case import load_case

    case, text = load_case(args.case)
    from .cost import cost_tables, plot_work_precision, print_cost, run_cost
    from .results import write_results

    out_dir = Path(args.out) if args.out else Path("results") / case.name
    out_dir.mkdir(parents=True, exist_ok=True)
    res = run_cost(case, ladder=args.ladder, repeats=args.repeats,
                   log=lambda m: print(m, file=sys.stderr))
    print_cost(res)
    h5 = write_results(out_dir / "cost.h5", [], case.name, text, extra={"cost": cost_tables(res)})
    png = plot_work_precision(res, out_dir / "work_precision.png", title=f"{case.name}: work-precision")
    print(f"\ncost table -> {h5} (/cost), plot -> {png}")
    return 0


def _beam_spec(case, command):
    from .case import CaseError

    spec = case.model_spec()
    if spec.fidelity != "beam":
        raise CaseError(f"'model.fidelity' = {spec.fidelity!r}: `vibeam {command}` needs a beam scene "
                        f"(fidelity = \"beam\")")
    return spec


def cmd_derive(args) -> int:
    from .case import load_case

    case, _ = load_case(args.case)
    spec = _beam_spec(case, "derive")
    from .beamscene import derive, sdof_case_text

    d = derive(spec)
    print(f"SDOF parameters of {case.name} by the assumed static mode (paper Eqs. 42-46)\n")
    print(f"{'parameter':<20}{'value':>14}  {'unit':<8}source")
    for name, val, unit, src in d["rows"]:
        print(f"{name:<20}{val:>14.6g}  {unit:<8}{src}")
    if args.write:
        text = sdof_case_text(case, spec, d["reduction"], d["scene"])
        Path(args.write).write_text(text)
        print(f"\nSDOF case written to {args.write}")
    return 0


def cmd_modes(args) -> int:
    from .case import load_case

    case, _ = load_case(args.case)
    spec = _beam_spec(case, "modes")
    from .beamscene import modes_report
    from .models.beam import write_modes

    rep = modes_report(spec, n=args.n)
    md, cm = rep["modes"], rep["contact"]
    tot = rep["total_mass_kg"]
    print(f"modes of {case.name} (FE, {rep['fe'].ndof} DOFs); base excitation, total mass {tot:.4g} kg\n")
    print(f"{'mode':>4}{'f (Hz)':>12}{'m at sensor (kg)':>18}{'Gamma (kg^.5)':>15}{'m_eff (kg)':>12}"
          f"{'m_eff %':>9}{'cum. %':>8}")
    cum = 0.0
    for i, f in enumerate(md.frequencies_hz):
        me = md.effective_mass_kg[i]
        cum += me
        print(f"{i + 1:>4}{f:>12.4f}{rep['sensor_modal_mass_kg'][i]:>18.4g}{md.participation[i]:>15.4g}"
              f"{me:>12.4g}{100 * me / tot:>9.2f}{100 * cum / tot:>8.2f}")
    print("\ncontact modes (beam held at the stop, w(L_m) = 0): " +
          ", ".join(f"{f:.2f}" for f in cm.frequencies_hz[: args.n]) + " Hz")
    out = Path(args.out) if args.out else Path("results") / case.name
    out.mkdir(parents=True, exist_ok=True)
    vtu = write_modes(out / "modes.vtu", rep["fe"], n=min(args.n, len(md.frequencies_hz)))
    png = _plot_modes(rep, out / "modes.png", case.name)
    print(f"mode shapes -> {vtu} (ParaView), {png}")
    return 0


def _plot_modes(rep, path, title):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    fe, md, cm = rep["fe"], rep["modes"], rep["contact"]
    L = fe.geometry.length_m
    x = np.linspace(0, L, 361)
    fig, axes = plt.subplots(1, 2, figsize=(10, 4), sharey=True)
    for ax, m, lab in ((axes[0], md, "free"), (axes[1], cm, "contact (held at the stop)")):
        for i in range(min(4, m.shapes.shape[1])):
            w = fe.deflection(m.shapes[:, i], x)
            ax.plot(x * 1e3, w / np.max(np.abs(w)), label=f"{m.frequencies_hz[i]:.2f} Hz")
        for xp, nm in ((fe.geometry.sensor_position_m, "L_S"), (fe.geometry.mass_position_m, "L_m")):
            ax.axvline(xp * 1e3, color="0.6", ls=":")
            ax.text(xp * 1e3, 1.02, nm, ha="center", fontsize=8)
        ax.set_title(f"{lab} modes")
        ax.set_xlabel("x (mm)")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
    axes[0].set_ylabel("normalised deflection")
    fig.suptitle(title)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return path


def main(argv=None) -> int:
    from . import __version__

    ap = argparse.ArgumentParser(prog="vibeam", description="Vibro-impact structural dynamics of an "
                                 "impacting cantilever beam (multi-fidelity).")
    ap.add_argument("--version", action="version", version=f"vibeam {__version__}")
    sub = ap.add_subparsers(dest="command", required=True)
    def run_args(p):
        p.add_argument("case", help="case file (TOML)")
        p.add_argument("--out", help="output folder (default results/<case name>/)")
        p.add_argument("--jobs", type=int, default=None,
                       help="worker processes of the local pool (default: all cores; 1: inline)")
        p.add_argument("--no-plots", action="store_true", help="skip the PNG plots")
        p.add_argument("--quiet", action="store_true", help="no progress bar")
        p.add_argument("--quick", action="store_true",
                       help="run the case's quick variant ([quick]: fewer points, periods and map values)")
        p.add_argument("--resume", action="store_true",
                       help="continue an interrupted run: keep the sweep lines already in results.h5")
        p.add_argument("--scheduler", metavar="ADDRESS",
                       help="run the sweep lines on a dask.distributed scheduler (e.g. tcp://host:8786)")

    p = sub.add_parser("run", help="run the sweeps (or the [map]) of a case file; write results.h5, plots "
                       "and a table")
    run_args(p)
    p.set_defaults(func=cmd_run)
    p = sub.add_parser("map", help="parameter map of a case with [map] (period-n regions, paper Fig. 18)")
    run_args(p)
    p.set_defaults(func=lambda a: cmd_run(a, need_map=True))
    p = sub.add_parser("regress", help="compare a case's FRCs with reference FRCs (HDF5 or CSV)")
    p.add_argument("case", help="case file (TOML)")
    p.add_argument("--reference", required=True, help="reference results.h5 or CSV")
    p.add_argument("--results", help="compare this results file instead of rerunning the case")
    p.add_argument("--out", help="output folder of the rerun (default results/<case name>/)")
    p.add_argument("--jobs", type=int, default=None)
    p.add_argument("--atol", type=float, default=None, help="override [regress] amplitude_atol")
    p.add_argument("--rtol", type=float, default=None, help="override [regress] amplitude_rtol")
    p.add_argument("--quick", action="store_true",
                   help="rerun the case's quick variant (as the references in tests/references/)")
    p.set_defaults(func=cmd_regress)
    p = sub.add_parser("cost", help="accuracy against time of every run (work-precision table and plot)")
    p.add_argument("case", help="case file (TOML)")
    p.add_argument("--out", help="output folder (default results/<case name>/)")
    p.add_argument("--ladder", action="store_true", help="also a ladder of tolerances per ODE method")
    p.add_argument("--repeats", type=int, default=3, help="timed repetitions (median reported)")
    p.set_defaults(func=cmd_cost)
    p = sub.add_parser("derive", help="SDOF parameters of a beam scene by the assumed static mode")
    p.add_argument("case", help="beam case file (TOML)")
    p.add_argument("--write", metavar="FILE", help="write the SDOF case file of the same scene")
    p.set_defaults(func=cmd_derive)
    p = sub.add_parser("modes", help="natural frequencies, participation, effective and contact modes")
    p.add_argument("case", help="beam case file (TOML)")
    p.add_argument("--out", help="output folder (default results/<case name>/)")
    p.add_argument("-n", type=int, default=6, help="number of modes (default 6)")
    p.set_defaults(func=cmd_modes)
    # ---- vibeam fit (vibeam.fit, vibeam.identify): identification from measurements, paper Secs. 6-7
    p = sub.add_parser("fit", help="fit model parameters to a measured FRC (with standard errors), or the "
                       "linear steps: Eq. 43 around f_n (--linear), beta_S from a free decay (--decay)")
    p.add_argument("case", help="case file (TOML); its [model] values start the fit")
    p.add_argument("--reference", help="measured FRC: CSV 'frequency_hz,amplitude_mm' (or 'Omega,amplitude'), "
                   "optional columns 'direction' (up/down) and 'sigma'; or a results.h5")
    p.add_argument("--reference-run", help="run of an HDF5 reference with several runs")
    p.add_argument("--params", help="comma-separated numeric [model] keys to fit (default gain,R; with "
                   "--linear natural_frequency_hz,damping_ratio,gain)")
    p.add_argument("--run", help="fit this run only (default: every run of the case, one by one)")
    p.add_argument("--out", help="output folder (default results/<case name>-fit/)")
    p.add_argument("--jobs", type=int, default=None, help="worker processes (default: all cores; 1: inline)")
    p.add_argument("--quick", action="store_true", help="sweep with the case's quick variant's periods")
    p.add_argument("--loss", choices=["linear", "soft_l1", "huber", "cauchy", "arctan"], default=None,
                   help="least_squares loss (default soft_l1; --linear: linear)")
    p.add_argument("--f-scale", type=float, default=3.0,
                   help="scale of the robust loss in units of sigma (default 3)")
    p.add_argument("--max-evaluations", type=int, default=60, help="max residual evaluations (sweeps)")
    p.add_argument("--linear", action="store_true", help="fit Eq. 43 without the stop to an FRC around f_n")
    p.add_argument("--decay", metavar="DECAY.csv", help="identify beta_S from a free decay 't_s,U_mm'")
    p.add_argument("--no-plots", action="store_true", help="skip fit.png")
    p.add_argument("--quiet", action="store_true", help="no progress messages")
    p.set_defaults(func=lambda a: __import__("vibeam.fit", fromlist=["main_fit"]).main_fit(a))
    p = sub.add_parser("bench", help="speed and accuracy of the exact solver against solve_ivp (JSON)")
    p.add_argument("--points", type=int, default=101)
    p.add_argument("--periods", type=int, default=500)
    p.add_argument("--repeats", type=int, default=5)
    p.add_argument("--direct-points", type=int, default=None,
                   help="time solve_ivp on this many points only and scale (quick look)")
    p.add_argument("--map", action="store_true",
                   help="instead: parameter-map points per second on 1 and 2 workers and the cost of the "
                        "line checkpoint (JSON)")
    p.add_argument("--scaling", action="store_true",
                   help="instead: how the cost of a sweep grows with periods simulated and with retained modes, "
                        "fitted exponents (JSON)")
    p.add_argument("--effects", action="store_true",
                   help="instead: time a rig sweep (SDOF, FE 2 modes) plain and with each scene effect")
    p.add_argument("--fit", action="store_true",
                   help="instead: time `vibeam fit` (2-parameter SDOF fit on 30 points, goal < 10 s; FE 2 modes)")
    p.add_argument("--jobs", type=int, default=None, help="workers of --fit (default 2)")
    p.set_defaults(func=lambda a: __import__("vibeam.bench", fromlist=["main_bench"]).main_bench(a))
    args = ap.parse_args(argv)
    from .case import CaseError

    try:
        return args.func(args)
    except CaseError as e:
        print(f"vibeam: error: {e}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("\nvibeam: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
