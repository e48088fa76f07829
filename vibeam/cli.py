"""Command line: ``vibeam run CASE.toml [--out DIR] [--jobs N]``.

Heavy modules (numba kernels, h5py, matplotlib) are imported only by the
command that needs them, so ``vibeam --help`` and case errors are instant.
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path


def _print_table(runs) -> None:
    import numpy as np

    ref = runs[0]
    key = "amplitude_mm" if "amplitude_mm" in ref.data else "amplitude"
    unit = " (mm)" if key == "amplitude_mm" else ""
    head = f"{'run':<22}{'method':<12}{'points':>7}{'wall time (s)':>15}{'max |dA| vs ' + ref.name + unit:>30}"
    print(head)
    print("-" * len(head))
    for r in runs:
        if r is ref:
            diff = "reference"
        elif key in r.data and len(r.data[key]) == len(ref.data[key]) and \
                np.allclose(r.data["Omega"], ref.data["Omega"]):
            d = np.abs(np.asarray(r.data[key], float) - np.asarray(ref.data[key], float))
            diff = f"{np.nanmax(d):.3e}" if np.isfinite(d).any() else "n/a"
        else:
            diff = "n/a (different grid)"
        n_bad = int(sum(1 for s in r.data.get("status", []) if s != "ok"))
        extra = f"  [{n_bad} point(s) not ok]" if n_bad else ""
        print(f"{r.name:<22}{r.method:<12}{r.n_points:>7}{r.wall_time_s:>15.3f}{diff:>30}{extra}")


def cmd_run(args) -> int:
    from .case import load_case

    case, text = load_case(args.case)
    from .models import make_solver
    from .plots import plot_bifurcation, plot_frc
    from .results import write_results
    from .sweep import Sweep, run_sweep

    out_dir = Path(args.out) if args.out else Path("results") / case.name
    out_dir.mkdir(parents=True, exist_ok=True)
    h5 = out_dir / "results.h5"
    base = case.model_spec()
    runs = []
    t_all = time.perf_counter()
    for r in case.run:
        spec = case.model_spec(r.model) if r.model else base
        model = spec.build()
        Omega = case.sweep.grid(getattr(model, "natural_frequency_hz", None))
        sw = Sweep(Omega=Omega, direction=case.sweep.direction,
                   transient_periods=case.sweep.transient_periods,
                   record_periods=case.sweep.record_periods,
                   samples_per_period=case.sweep.samples_per_period,
                   continuation=case.sweep.continuation, period_rtol=case.sweep.period_rtol)
        solver = make_solver(model, r.method, **case.run_settings(r))
        print(f"[{case.name}] run '{r.name}': method {r.method}, {len(Omega)} points, "
              f"direction {sw.direction}", file=sys.stderr)
        res = run_sweep(solver, sw, name=r.name, jobs=args.jobs, progress=not args.quiet)
        res.attrs["model"] = spec.model_dump()
        runs.append(res)
        write_results(h5, runs, case.name, text)  # after every run: nothing computed is lost
    print(f"\ncase {case.name}: {len(runs)} run(s) in {time.perf_counter() - t_all:.2f} s -> {h5}")
    _print_table(runs)
    if not args.no_plots:
        p1 = plot_frc(runs, out_dir / "frc.png", title=case.name)
        p2 = plot_bifurcation(runs, out_dir / "bifurcation.png", title=case.name)
        print(f"plots: {p1}" + (f", {p2}" if p2 else ""))
    return 0


def main(argv=None) -> int:
    from . import __version__

    ap = argparse.ArgumentParser(prog="vibeam", description="Vibro-impact structural dynamics of an "
                                 "impacting cantilever beam (multi-fidelity).")
    ap.add_argument("--version", action="version", version=f"vibeam {__version__}")
    sub = ap.add_subparsers(dest="command", required=True)
    p = sub.add_parser("run", help="run the sweeps of a case file; write results.h5, plots and a table")
    p.add_argument("case", help="case file (TOML)")
    p.add_argument("--out", help="output folder (default results/<case name>/)")
    p.add_argument("--jobs", type=int, default=None, help="worker processes (default: all cores; 1: inline)")
    p.add_argument("--no-plots", action="store_true", help="skip the PNG plots")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=cmd_run)
    p = sub.add_parser("bench", help="speed and accuracy of the exact solver against solve_ivp (JSON)")
    p.add_argument("--points", type=int, default=101)
    p.add_argument("--periods", type=int, default=500)
    p.add_argument("--repeats", type=int, default=5)
    p.add_argument("--direct-points", type=int, default=None,
                   help="time solve_ivp on this many points only and scale (quick look)")
    p.set_defaults(func=lambda a: __import__("vibeam.bench", fromlist=["main_bench"]).main_bench(a))
    args = ap.parse_args(argv)
    from .case import CaseError

    try:
        return args.func(args)
    except CaseError as e:
        print(f"vibeam: error: {e}", file=sys.stderr)
        return 2


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
