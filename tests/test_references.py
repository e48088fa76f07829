"""Every shipped case's quick variant regressed against its converged reference FRC.

The references in ``tests/references/<case name>.h5`` are made (and checked
against the analytic oracles: impact-map fixed points, the linear steady state,
averaging, the static-mode SDOF, the direct FE solver) by
``tests/references/make_references.py``; the cheap oracles are recomputed here
from the stored data.  Two checks per case:

1. ``vibeam regress CASE --reference tests/references/<name>.h5 --quick``
   with the case's ``[regress]`` tolerances on every point (non-periodic or
   unsettled points by the spread of their per-period amplitude, ``period`` is
   off where the classification is fragile);
2. on the points where quick run and reference have the same period (1..8, or
   no impact) the amplitude agrees to ``amplitude_rtol`` alone: there the only
   difference is the remaining transient (or the ODE tolerance).
"""
from __future__ import annotations

import importlib.util
import shutil
from pathlib import Path

import h5py
import numpy as np
import pytest

from vibeam.case.schema import load_case, parse_case
from vibeam.cli import main
from vibeam.analysis.maps import all_runs
from vibeam.analysis.regress import match_points
from vibeam.io.results import read_results
from vibeam.testing import check_labelled

ROOT = Path(__file__).resolve().parents[1]
ALL_CASES = sorted((ROOT / "cases").glob("*.toml"))
REFS = ROOT / "tests" / "references"

#: cases with continuation runs only: a reference FRC compares sweeps, so their branches are
#: regressed by the named test module instead (against its oracles)
BRANCH_REGRESSED = {"rig-fe-tight-continuation": "tests/test_continuation_beam.py",
                    "rig-continuum-continuation": "tests/test_continuum_branches.py"}


def _has_sweeps(path) -> bool:
    return any(r.method != "continuation" for r in load_case(path)[0].run)


CASES = [p for p in ALL_CASES if _has_sweeps(p)]


def reference_for(case_path) -> Path:
    """The reference FRC of a case file; fails loudly when there is none."""
    case, _ = load_case(case_path)
    ref = REFS / f"{case.name}.h5"
    if not ref.is_file():
        pytest.fail(f"case {case_path} ('{case.name}') has no reference FRC {ref}: make it with "
                    f"`python tests/references/make_references.py {case_path}` (it checks the reference "
                    f"against the analytic oracles) and commit it", pytrace=False)
    return ref


@pytest.mark.parametrize("path", CASES, ids=[p.stem for p in CASES])
def test_quick_variant_regresses_against_its_reference(path, quick_results, capsys):
    """``vibeam run CASE --quick`` (the session's quick results, also read by test_plots)
    regressed by ``vibeam regress CASE --reference REF --results``; its results file opens
    with xarray as labelled data."""
    ref = reference_for(path)
    tmp_path = quick_results(path)
    capsys.readouterr()
    rc = main(["regress", str(path), "--reference", str(ref), "--results", str(tmp_path / "results.h5")])
    out = capsys.readouterr().out
    assert rc == 0, out
    # the results are labelled data: xarray sees named dimensions, coordinates, units, str
    check_labelled(tmp_path / "results.h5")
    # periodic points with the same period: the amplitude to amplitude_rtol alone
    case, _ = load_case(path)
    rtol = case.regress.amplitude_rtol
    sparse_modes = case.model_spec().fidelity in ("continuum", "mesh")
    new, old = all_runs(read_results(tmp_path / "results.h5")), all_runs(read_results(ref))
    assert set(new) == set(old) and new
    for name, r in old.items():
        n = new[name]
        # the same grid point by point (physical grids in Hz; Omega = f / f_n of a calibrated FE
        # model carries ~1e-11 of library-dependent round-off, see vibeam.analysis.regress.match_points;
        # a continuum's or a mesh's f_n comes from ARPACK in shift-invert mode on a factorised K of
        # 10^4-10^5 DOFs, ~cond(K) eps: 2.8e-8 between OpenBLAS's Haswell and Sapphire Rapids kernels
        # on one host, 3.6e-9 between two hosts)
        i_n, i_r = match_points(n, r)
        assert i_n == list(range(len(n["Omega"]))) and i_r == list(range(len(r["Omega"])))
        np.testing.assert_allclose(n["Omega"], r["Omega"], rtol=1e-7 if sparse_modes else 1e-9)
        same = (n["period"] == r["period"]) & ((r["period"] >= 1) | (r["period"] == -1))
        same &= np.array([str(a) == "ok" and str(b) == "ok" for a, b in zip(n["status"], r["status"])])
        a, a_ref = n["amplitude"][same], r["amplitude"][same]
        bad = np.abs(a - a_ref) > rtol * np.abs(a_ref)
        assert not bad.any(), (f"run '{name}': periodic points off by more than rtol {rtol:g} at Omega "
                               f"{n['Omega'][same][bad]} ({a[bad]} vs {a_ref[bad]})")


def test_every_case_has_a_reference_and_every_reference_a_case():
    names = {load_case(p)[0].name for p in CASES}
    branch_only = {load_case(p)[0].name for p in ALL_CASES if p not in CASES}
    unregressed = sorted(branch_only - set(BRANCH_REGRESSED))
    assert not unregressed, (f"cases with continuation runs only have no reference FRC; regress their branches "
                             f"in a test and list them in BRANCH_REGRESSED: {unregressed}")
    for name, module in BRANCH_REGRESSED.items():
        assert name in branch_only and name in (ROOT / module).read_text(), (name, module)
    missing = sorted(n for n in names if not (REFS / f"{n}.h5").is_file())
    stale = sorted(p.stem for p in REFS.glob("*.h5") if p.stem not in names)
    assert not missing, (f"cases without a reference FRC in {REFS}: {missing}; run "
                         f"`python tests/references/make_references.py` and commit the files")
    assert not stale, f"references without a case in cases/: {stale}"


def test_a_case_without_reference_fails_loudly(tmp_path):
    case = tmp_path / "new.toml"
    case.write_text((ROOT / "cases" / "paper-fig7.toml").read_text()
                    .replace('name = "paper-fig7"', 'name = "a-new-case-without-reference"'))
    with pytest.raises(pytest.fail.Exception, match="make_references.py"):
        reference_for(case)


@pytest.mark.parametrize("ref", sorted(REFS.glob("*.h5")), ids=lambda p: p.stem)
def test_references_are_labelled_data(ref):
    """The shipped references are in the netCDF layout (converted once by convert_layout.py,
    numbers unchanged) and open with xarray like any results file."""
    import xarray as xr

    check_labelled(ref)
    with xr.open_dataset(ref, group="reference", engine="h5netcdf") as ds:
        assert ds["checks"].dims == ("check",) and ds["transient_periods"].dims == ()


def _generator():
    """tests/references/make_references.py as a module (its oracles)."""
    spec = importlib.util.spec_from_file_location("make_references", REFS / "make_references.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


POINT_ORACLES = ("Newton", "k-fold", "linear", "static mode")


@pytest.mark.parametrize("ref", sorted(REFS.glob("*.h5")), ids=[p.stem for p in sorted(REFS.glob("*.h5"))])
def test_reference_passes_its_oracles_recomputed(ref):
    """The oracles are recomputed here from the stored datasets and case text (Newton and
    k-fold impact-map fixed points, linear steady states, the static mode's SDOF, the held
    lift-off, the platform filter's gain, the static-mode statistics of chaotic points, one
    direct-solver point per compliant FE run), not read back from the generator's verdict; the
    direct FE checks of restitution runs are left to the generator and to a slow test.  A
    reference is never trusted vacuously: every reference must have had oracle checks, and one
    whose plain event runs have periodic or no-impact points must have had some of those
    checked."""
    with h5py.File(ref, "r") as f:
        # 1000 (FE) or 3000 (SDOF), "auto" where the quick variant has it, the quick variant's own
        # for the exceptions; see REFERENCE_TRANSIENT in make_references.py
        tp = f["reference/transient_periods"].asstr()[()]
        case = parse_case(f.attrs["case_text"])
    quick = case.quick_variant().sweep.transient_periods
    assert tp == "auto" if quick == "auto" else int(tp) >= quick
    checks = _generator().check_stored(ref, expensive=False)
    failures = [f"{c.run}: {c.oracle}: {m}" for c in checks for m in c.failures]
    assert not failures, failures[:10]
    assert sum(c.n for c in checks) > 0, f"{ref.name}: no oracle checked any point of this reference"
    plain = [r.name for r in case.run
             if r.method == "event" and not set(case.effects_for(r).active()) - {"sensor"}
             and (case.model.get("fidelity") == "sdof" or r.model.get("n_modes") == "static")]
    runs = all_runs(read_results(ref))
    plain = [n for n in runs if n.split("@")[0] in plain]
    ok = [(np.isin(runs[n]["period"], (1, -1)) & (runs[n]["status"] == "ok")).any() for n in plain]
    if any(ok):
        assert sum(c.n for c in checks if any(o in c.oracle for o in POINT_ORACLES)) > 0


def test_a_tampered_reference_fails_its_oracles(tmp_path):
    """The recomputed oracles catch a reference changed by 1e-7 at one period-1 point (the
    tolerance is 1e-8) or a period-3 point changed by 1e-6."""
    mr = _generator()
    for name, period, rel in (("paper-fig7", 1, 1e-7), ("paper-fig13", 3, 1e-6)):
        bad = tmp_path / f"{name}.h5"
        shutil.copy(REFS / f"{name}.h5", bad)
        with h5py.File(bad, "r+") as f:
            a = f["runs/exact/amplitude"]
            v = a[()]                                   # (direction, Omega)
            i = int(np.flatnonzero(f["runs/exact/period"][()] == period)[0])
            v.flat[i] *= 1 + rel
            a[...] = v
        failed = [c for c in mr.check_stored(bad) if c.failures]
        assert failed and all(c.run == "exact" for c in failed), name


@pytest.mark.slow
def test_fe_reference_against_the_direct_solver():
    """The FE rungs (1, 2, 4 modes) of the neutral rig against solve_ivp (DOP853, rtol 1e-10)
    started on the event solver's orbit: amplitude to 1e-7 (measured 2e-11)."""
    checks = _generator().check_stored(REFS / "rig-fe-neutral.h5", expensive=True)
    direct = [c for c in checks if "direct" in c.oracle]
    assert len(direct) == 3 and all(c.n == 2 and not c.failures for c in direct)


def test_perturbed_reference_fails(tmp_path, capsys):
    case = ROOT / "cases" / "paper-fig7.toml"
    ref = reference_for(case)
    out = tmp_path / "run"
    assert main(["run", str(case), "--quick", "--out", str(out), "--jobs", "1", "--quiet", "--no-plots"]) == 0
    res = out / "results.h5"
    assert main(["regress", str(case), "--reference", str(ref), "--results", str(res)]) == 0
    tol = load_case(case)[0].regress
    bad = tmp_path / "bad.h5"
    shutil.copy(ref, bad)
    with h5py.File(bad, "r+") as f:
        a = f["runs/exact/amplitude"]
        v = a[()]                                   # (direction, Omega)
        v[0, 3] *= 1 + 10 * tol.amplitude_rtol + 1e-9  # ten tolerances off at one point
        a[...] = v
    capsys.readouterr()
    assert main(["regress", str(case), "--reference", str(bad), "--results", str(res)]) == 1
    assert "REGRESSION" in capsys.readouterr().out
    # a changed period classification fails too (period = true for this case)
    assert tol.period
    shutil.copy(ref, bad)
    with h5py.File(bad, "r+") as f:
        p = f["runs/exact/period"]
        v = p[()]
        v[0, 5] = 2
        p[...] = v
    assert main(["regress", str(case), "--reference", str(bad), "--results", str(res)]) == 1


def test_quick_variant_grid_and_overrides():
    case = parse_case("""
name = "q"
[model]
fidelity = "sdof"
beta = 0.05
B = 0.01
R = 0.8
Delta = 0.0
[sweep]
Omega = [1.0, 3.0, 101]
transient_periods = 300
record_periods = 32
[quick]
points = 5
transient_periods = 50
[[run]]
name = "exact"
method = "event"
""")
    q = case.quick_variant()
    np.testing.assert_allclose(q.sweep.grid(), [1.0, 1.5, 2.0, 2.5, 3.0])
    assert (q.sweep.transient_periods, q.sweep.record_periods) == (50, 32)
    assert q.run == case.run and q.name == case.name and q.quick == case.quick
    # a grid with fewer points than [quick] points is kept
    few = case.model_copy(update={"quick": case.quick.model_copy(update={"points": 500})}).quick_variant()
    np.testing.assert_allclose(few.sweep.grid(), case.sweep.grid())
