"""Make the reference FRCs in ``tests/references/``: one ``<case name>.h5`` per shipped case.

For every case file in ``cases/`` the reference is the FRC of the case's *quick
variant* (:meth:`vibeam.case.Case.quick_variant`: the same grid, directions and
run names as ``vibeam run --quick``) computed with converged settings:

* every time-domain run (``event``, and the ODE methods ``direct``,
  ``zhuravlev``, ``ivanov``, whose reference is the exact ``event`` solver of
  the same model) uses the exact event-driven solver with 3000 (SDOF) or 1000
  (FE beam) transient periods per point: the transient decays at least like
  ``exp(-beta t)``, i.e. by ``exp(-0.015 * 3000 * 2 pi / 2.5) < 1e-49`` for the
  SDOF scenes and ``exp(-0.017 * 1000 * 2 pi / 2.3) < 1e-20`` for the beam, so
  wherever the orbit is an attractor the reference holds it to round-off
  (where the motion is not periodic, the reference is one sample of the
  attractor);
* ``averaging`` and ``mapping`` runs are closed-form/Newton and run as they are.

Before a reference is written it is checked against the analytic oracles that
apply, and nothing is written if one fails:

* period-1 one-impact points of SDOF event runs: the fixed point of the impact
  map found by Newton on the closed-form flow (``MappingSolver``'s
  ``newton_fixed_point``, started from the reference's own impact), admissible,
  with its exact minimum: amplitude to ``1e-8`` relative;
* points without impact (``period = -1``): the linear steady state
  ``Delta + C(Omega)`` (``linear_amplitude``; for beam runs the modal sum
  ``linear_sensor_amplitude_m``), ``1e-8`` relative;
* ``R >= 0.99`` near ``Omega = 2`` (``|Omega - 2| <= 0.1``), period 1: averaging
  (Eqs. 18-27), loose: ``3 %`` relative (averaging is first order in the
  stop's influence; measured 0.003 % at ``Omega = 2``);
* beam runs with ``n_modes = "static"``: the SDOF event solver of the derived
  parameters (``vibeam derive``: f_n, beta_S, B = gamma V, Delta; paper
  Eqs. 42-46) on the same frequencies in Hz, ``1e-8`` relative, where both are
  periodic with the same period (elsewhere chaos amplifies round-off).

* parameter maps (``[map]``) are checked line by line, each parameter value
  with its own model, by the oracles above, plus, for SDOF maps on a
  pre-stressed stop, the closed-form lift-off: a point is "held on the stop"
  iff ``Omega^2 B <= |Delta|``.
Runs with an effect that changes the dynamics (every effect but the sensor) and
closed-form runs are not oracle-checked.  The observed errors are printed and
stored in the file's ``/reference`` group (``checks``: one JSON line per oracle
and run).  To keep the files small a reference keeps the per-point outputs of
the README (amplitude, period, strobe, ...) and drops assessment extras
(spectra, sensor identification; listed in ``/reference/dropped_datasets``).
The FE references take a few minutes ('FE all modes' chatters on the tight
rig).  Usage::

    python tests/references/make_references.py            # every case in cases/
    python tests/references/make_references.py cases/paper-fig7.toml --check-only
"""
from __future__ import annotations

import argparse
import json
import math
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[1]
CASES = ROOT / "cases"
# transient periods of the references: the slowest decay is exp(-beta t) of the first mode, so
# SDOF (beta >= 0.015, Omega <= 2.5): exp(-0.015 * 3000 * 2 pi / 2.5) < 1e-49; beam (beta_1 =
# 0.017, Omega <= 2.3, higher modes damped more by Eq. 39): exp(-0.017 * 1000 * 2 pi / 2.3) < 1e-20
REFERENCE_TRANSIENT = {"sdof": 3000, "beam": 1000}
REFERENCE_TRANSIENT_OVERRIDE: dict[str, int] = {}  # per-case exceptions (none needed)
TIME_DOMAIN = ("event", "direct", "zhuravlev", "ivanov")
TOL_MAPPING = 1e-8
TOL_LINEAR = 1e-8
TOL_AVERAGING = 0.03
TOL_STATIC = 1e-8
# effects that leave the dynamics alone (the oracles still apply)
PASSIVE_EFFECTS = {"sensor"}
# the per-point outputs a reference keeps (README, "Per-point outputs"); assessment and
# method-specific extras (spectra, sensor records, ...) are left out to keep the files small
KEPT = ("Omega", "amplitude", "q_max", "q_min", "period", "impacts_per_period", "impact_velocity",
        "strobe", "harmonics", "direction", "status", "message", "wall_time_s", "stuck_fraction",
        "frequency_hz", "amplitude_mm", "amplitude_lower", "stable")


MAP_KEPT = ("classification", "values")


def reference_case(case):
    """The converged counterpart of ``case.quick_variant()`` (same grid and run names)."""
    from vibeam.case import Case

    data = case.quick_variant().model_dump()
    fid = case.model_spec().fidelity
    n = REFERENCE_TRANSIENT_OVERRIDE.get(case.name, REFERENCE_TRANSIENT[fid])
    data["sweep"]["transient_periods"] = max(n, int(data["sweep"]["transient_periods"]))
    runs = []
    for r in data["run"]:
        if r["method"] in TIME_DOMAIN and r["method"] != "event":
            r = dict(name=r["name"], method="event", model=r["model"], effects=r["effects"])
        runs.append(r)
    data["run"] = runs
    return Case.model_validate(data)


# ----------------------------------------------------------------------------- oracles
class Check:
    """Largest relative error of one oracle on one run."""

    def __init__(self, run, oracle, tol, floor=1e-300):
        self.run, self.oracle, self.tol, self.floor = run, oracle, tol, floor
        self.n = 0
        self.err = 0.0
        self.failures = []

    def add(self, Omega, direction, value, expected):
        self.n += 1
        err = abs(value - expected) / max(abs(expected), self.floor) if np.isfinite(expected) else math.inf
        self.err = max(self.err, err)
        if not err <= self.tol:
            self.failures.append(f"Omega {Omega:.6g} ({direction}): {value!r} vs {expected!r} "
                                 f"(rel. error {err:.2e} > {self.tol:g})")

    def as_dict(self):
        return dict(run=self.run, oracle=self.oracle, points=self.n, max_rel_error=self.err,
                    tolerance=self.tol, failures=len(self.failures))


def _sdof_checks(name, model, d):
    from vibeam.models import EventSolver, linear_amplitude
    from vibeam.models.sdof_averaging import solve as averaging
    from vibeam.models.sdof_mapping import is_admissible, newton_fixed_point, orbit_extremes

    c_map = Check(name, "period-1 points vs impact-map fixed point (Newton)", TOL_MAPPING)
    c_lin = Check(name, "no-impact points vs linear_amplitude", TOL_LINEAR)
    c_avg = Check(name, "R -> 1 near Omega = 2 vs averaging", TOL_AVERAGING)
    ev = EventSolver(model)
    for i, W in enumerate(d["Omega"]):
        W = float(W)
        A, p, direc = float(d["amplitude"][i]), int(d["period"][i]), str(d["direction"][i])
        if str(d["status"][i]) != "ok":
            continue
        if p == -1:
            c_lin.add(W, direc, A, model.Delta + float(linear_amplitude(model.beta, model.B, W)))
            continue
        if p != 1 or abs(float(d["impacts_per_period"][i]) - 1.0) > 1e-12:
            continue
        q0, v0 = d["strobe"][i][-1]
        tr = ev.point(W, np.array([q0, v0, 0.0]), 0, 1, 8)
        if tr.n_impacts != 1:
            c_map.failures.append(f"Omega {W:.6g} ({direc}): {tr.n_impacts} impacts in the period after "
                                  f"the last strobe sample")
            continue
        guess = np.array([(W * tr.impact_times[0]) % (2 * math.pi), tr.impact_velocities[0]])
        x = newton_fixed_point(model, W, guess, 1)
        ok, why = (False, "Newton did not converge") if x is None else is_admissible(model, W, x, 1)
        if not ok:
            c_map.failures.append(f"Omega {W:.6g} ({direc}): no admissible fixed point ({why})")
            continue
        q_min, _ = orbit_extremes(model, W, x, 1)
        c_map.add(W, direc, A, model.Delta - q_min)
        if model.R >= 0.99 and abs(W - 2.0) <= 0.1 + 1e-9:
            avg = averaging(W, model.beta, model.B, model.R, model.Delta, 1)
            c_avg.add(W, direc, A, float(avg["amplitude"]))
    return [c_map, c_lin, c_avg]


def _beam_checks(name, spec, model, d, sweep):
    from dataclasses import replace

    from vibeam.beamscene import derive
    from vibeam.models import SDOF, EventSolver
    from vibeam.sweep import run_sweep

    c_lin = Check(name, "no-impact points vs modal linear_sensor_amplitude_m", TOL_LINEAR)
    for i, W in enumerate(d["Omega"]):
        if int(d["period"][i]) == -1 and str(d["status"][i]) == "ok":
            lin = float(np.abs(model.linear_sensor_amplitude_m(float(W)))) / model.length_m
            c_lin.add(float(W), str(d["direction"][i]), float(d["amplitude"][i]), model.Delta + lin)
    out = [c_lin]
    if spec.n_modes == "static":
        red = derive(spec)["reduction"]
        sdof = SDOF(beta=red.beta_S, B=red.gamma_per_V * spec.voltage, R=spec.R, Delta=red.Delta)
        f = np.asarray(d["frequency_hz"], float)
        up = np.unique(f)
        sw = replace(sweep, Omega=up / red.f_n_hz, assess=())
        res = run_sweep(EventSolver(sdof), sw, jobs=1)
        # relative to max(|A|, |Delta|): a mass held on a pre-stressed stop has A = Delta - q_min = 0
        # up to the round-off of the modal coordinates (1e-19 here)
        c_st = Check(name, "static mode vs SDOF event solver of the derived parameters", TOL_STATIC,
                     floor=abs(model.Delta))
        key = {(str(dr), round(float(w) * red.f_n_hz, 9)): j
               for j, (dr, w) in enumerate(zip(res.data["direction"], res.data["Omega"]))}
        for i, fi in enumerate(f):
            j = key[(str(d["direction"][i]), round(float(fi), 9))]
            p, p_sdof = int(d["period"][i]), int(res.data["period"][j])
            if p != p_sdof or p == 0:
                continue  # not periodic: chaos tells the two round-offs apart
            c_st.add(float(d["Omega"][i]), str(d["direction"][i]), float(d["amplitude"][i]),
                     float(res.data["amplitude"][j]))
        out.append(c_st)
    return out


def _held_check(name, model, d):
    """Pre-stressed stop: a point is 'held on the stop' iff Omega^2 B <= |Delta| (the forcing
    cannot make q'' = Omega^2 B sin(Omega t) - Delta negative on the stop)."""
    from vibeam.maps import HELD, classify

    c = Check(name, "held on a pre-stressed stop iff Omega^2 B <= |Delta|", 0.0)
    if model.Delta >= 0:
        return c
    cls = classify(d["period"], d["status"])
    for i, W in enumerate(d["Omega"]):
        held = float(cls[i] == HELD)
        c.add(float(W), str(d["direction"][i]), held, float(float(W) ** 2 * model.B <= -model.Delta))
    return c


def check_map(ref_case, maps) -> list[Check]:
    """The oracles of a parameter map, line by line (one model per parameter value)."""
    from vibeam.maps import map_lines
    from vibeam.sweep import Sweep

    checks = []
    par = ref_case.map.parameter
    for r, m in zip(ref_case.run, maps):
        lines = map_lines({"maps": {m.name: dict(m.data, attrs=m.attrs)}})
        for (lname, d), v in zip(lines.items(), ref_case.map.grid()):
            spec = ref_case.model_spec(dict(r.model, **{par: float(v)}))
            if r.method != "event" or set(ref_case.effects_for(r).active()) - PASSIVE_EFFECTS:
                continue
            model = spec.build()
            if spec.fidelity == "sdof":
                checks += _sdof_checks(lname, model, d) + [_held_check(lname, model, d)]
            else:
                sw = ref_case.sweep
                sweep = Sweep(Omega=np.zeros(1), direction=sw.direction, transient_periods=sw.transient_periods,
                              record_periods=sw.record_periods, samples_per_period=sw.samples_per_period,
                              continuation=sw.continuation, period_rtol=sw.period_rtol)
                checks += _beam_checks(lname, spec, model, d, sweep)
    return checks


def check_reference(case, ref_case, runs) -> list[Check]:
    """Every oracle that applies to the reference ``runs`` of ``ref_case``."""
    if ref_case.map is not None:
        return check_map(ref_case, runs)
    from vibeam.sweep import Sweep

    checks = []
    sw = ref_case.sweep
    for r, res in zip(ref_case.run, runs):
        spec = ref_case.model_spec(r.model) if r.model else ref_case.model_spec()
        d = res.data
        bad = [float(w) for w, s in zip(d["Omega"], d["status"]) if str(s) == "failed"]
        if bad:
            c = Check(r.name, "no failed points", 0.0)
            c.failures.append(f"failed at Omega {bad}")
            checks.append(c)
        if r.method != "event" or set(ref_case.effects_for(r).active()) - PASSIVE_EFFECTS:
            continue  # closed-form runs are their own oracle; effects change the model
        model = spec.build()
        if spec.fidelity == "sdof":
            checks += _sdof_checks(r.name, model, d)
        else:
            sweep = Sweep(Omega=np.zeros(1), direction=sw.direction, transient_periods=sw.transient_periods,
                          record_periods=sw.record_periods, samples_per_period=sw.samples_per_period,
                          continuation=sw.continuation, period_rtol=sw.period_rtol)
            checks += _beam_checks(r.name, spec, model, d, sweep)
    return checks


# ----------------------------------------------------------------------------- main
def make_reference(path, out_dir=HERE, jobs=None, write=True, log=print) -> tuple[bool, list[Check]]:
    """Compute, check and (if every check passes) write the reference of one case file."""
    from vibeam.case import load_case
    from vibeam.cli import run_case
    from vibeam.results import write_results

    case, text = load_case(path)
    ref_case = reference_case(case)
    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory() as tmp:
        runs = run_case(ref_case, text, tmp, jobs=jobs, quiet=True, plots=False)
    log(f"[{case.name}] reference computed in {time.perf_counter() - t0:.1f} s "
        f"({ref_case.sweep.transient_periods} transient periods)")
    checks = check_reference(case, ref_case, runs)
    ok = True
    for c in checks:
        if c.n == 0 and not c.failures:
            continue
        verdict = "ok" if not c.failures else "FAILED"
        log(f"  {c.run:<22}{c.oracle:<58}{c.n:>4} pts  max rel. error {c.err:.2e}  "
            f"(tol {c.tol:g})  {verdict}")
        for msg in c.failures[:5]:
            log(f"      {msg}")
        ok &= not c.failures
    if not ok:
        log(f"[{case.name}] oracle check FAILED: reference not written")
        return False, checks
    if write:
        maps, runs = (runs, []) if ref_case.map is not None else ([], runs)
        dropped = sorted({k for res in runs + maps for k in res.data if k not in KEPT + MAP_KEPT})
        for res in runs + maps:
            res.data = {k: v for k, v in res.data.items() if k in KEPT + MAP_KEPT}
        extra = {"reference": reference_table(
            dropped, ref_case.sweep.transient_periods, [f"{r.name}: {r.method}" for r in ref_case.run],
            [json.dumps(c.as_dict()) for c in checks if c.n])}
        out = write_results(Path(out_dir) / f"{case.name}.h5", runs, case.name, text, extra=extra, maps=maps)
        log(f"[{case.name}] -> {out} ({out.stat().st_size / 1024:.0f} kB)")
    return True, checks


def reference_table(dropped, transient_periods, methods, checks) -> dict:
    """The ``/reference`` group of a reference file (netCDF variables with units and names)."""
    from vibeam.results import var

    return {
        "dropped_datasets": var(("dropped_dataset",), np.array(list(dropped), dtype=object), None,
                                "per-point outputs of the runs not kept in the reference"),
        "transient_periods": var((), np.array(int(transient_periods)), "1",
                                 "transient forcing periods per point of the reference"),
        "methods": var(("case_run",), np.array(list(methods), dtype=object), None,
                       "run: method of the case (time-domain runs are referenced by event)"),
        "checks": var(("check",), np.array(list(checks), dtype=object), None,
                      "oracle checks passed (JSON: run, oracle, points, max_rel_error, tolerance, failures)")}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("cases", nargs="*", help="case files (default: every cases/*.toml)")
    ap.add_argument("--out", default=str(HERE), help="output folder (default tests/references/)")
    ap.add_argument("--jobs", type=int, default=None)
    ap.add_argument("--check-only", action="store_true", help="compute and check, write nothing")
    args = ap.parse_args(argv)
    paths = [Path(p) for p in args.cases] or sorted(CASES.glob("*.toml"))
    failed = []
    for p in paths:
        ok, _ = make_reference(p, args.out, jobs=args.jobs, write=not args.check_only)
        if not ok:
            failed.append(str(p))
    if failed:
        print(f"\noracle checks failed for: {', '.join(failed)}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
