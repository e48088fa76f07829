"""Tool-generated mutation testing (issue 46): cosmic-ray's mutation operators over the modules
where a wrong line gives a wrong answer, on a sample of mutants, each against its module's tests.

Why cosmic-ray (8.x) and not mutmut 3: mutmut 3 runs every mutant of a function from one
"trampolined" copy of it, chosen at run time by an environment variable -- a numba kernel
(``@njit``) cannot hold that trampoline, and most of ``models/core`` is kernels.  cosmic-ray
edits the source file itself, one mutant at a time, runs a test command in a fresh process and
restores the file, so a mutated kernel is compiled from the mutated source; with
``NUMBA_CACHE_DIR`` a fresh folder per mutant of a kernel module (``models/``, ``reductions/``),
no compiled kernel of another mutant (or of the clean source) can run in its place.  Mutants of
the framework's pure-Python modules share one cache: their kernels are the clean source's.

The run never touches this checkout: the tracked files are copied to a scratch folder laid out
as the installed package (``models/`` as ``vibeam/models``, ``reductions/`` as
``vibeam/reductions``, the package-dir mapping of pyproject.toml) and put first on
``PYTHONPATH``; the tests run from the copy (its ``cases/`` and ``tests/``).  Usage::

    .venv/bin/python -m tests.mutation --sample 200 --seed 1          # every listed module
    .venv/bin/python -m tests.mutation --sample 6 --seed 1 --modules vibeam/io/store.py
    .venv/bin/python -m tests.mutation --list                          # mutants per module

Each mutant's tests are its module's test files (:data:`MODULES`: a selection by what the
tests exercise, written down here, not by measured coverage) run with ``pytest -x -q -n 0``;
a mutant is *killed* when they fail or exceed the time limit (an endless loop), *survived* when
they pass, *equivalent* when it is listed in :data:`EQUIVALENT` with the reason (left out of the
score); *incompetent* (the mutated module does not import) counts as killed, as cosmic-ray
counts it.  The sample is a fixed-seed draw of ``--sample`` mutants per module (all when fewer);
the report (``--out``, JSON) lists each mutant's diff and outcome, the score per module and the
survivors, which ``tests/README.md`` ("Tool-generated mutants") answers one by one: a test that
kills it, or why it is equivalent.  ``--min-score`` makes the exit code 1 when a module's score
is below it (CI's small fixed sample).
"""
from __future__ import annotations

import argparse
import json
import os
import random
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

#: module (path in the repository) -> the tests that exercise it (run from the copy's root)
MODULES = {
    "vibeam/io/store.py": [
        "tests/test_store.py",
    ],
    "vibeam/io/h5check.py": [
        "tests/test_store.py",
    ],
    "vibeam/analysis/regress.py": [
        "tests/test_oracles.py::test_regress_fails_a_point_that_is_nan_on_one_side_only",
        "tests/test_regress.py",
        "tests/test_statistics.py",
    ],
    "vibeam/analysis/attractors.py": [
        "tests/test_basins.py",
        "tests/test_basins_region.py",
    ],
    "vibeam/engine/effects.py": [
        "tests/test_oracles.py::test_the_platform_filter_is_normalised_at_its_reference_frequency",
        "tests/test_effects.py",
    ],
    "vibeam/case/paths.py": [
        "tests/test_paths.py",
    ],
    "models/lyapunov.py": [
        "tests/test_oracles.py::test_lyapunov_exponents_of_period_2_and_3_orbits_are_their_floquet_exponents",
        "tests/test_lyapunov.py",
        "tests/test_lyapunov_errors.py",
    ],
    "models/compliant.py": [
        "tests/test_oracles.py::test_a_hertz_exponent_of_the_case_is_the_power_of_the_force",
        "tests/test_compliant.py",
        "tests/test_lankarani_nikravesh.py",
    ],
    "models/continuation.py": [
        "tests/test_oracles.py::test_the_continuation_step_is_capped_at_ds_max",
        "tests/test_oracles.py::test_the_multipliers_of_a_continued_branch_through_its_period_doubling_against_lapack",
        "tests/test_continuation_cli.py::test_map_curves_follow_the_closed_form_grazing_and_the_one_parameter_fold",
        "tests/test_continuation.py",
    ],
    "models/continuation_kernels.py": [
        "tests/test_oracles.py::test_floquet_multipliers_of_a_2x2_monodromy_against_lapack",
        "tests/test_continuation.py",
    ],
    "models/core/laws.py": [
        "tests/test_compliant.py",
        "tests/test_energy_balance.py",
    ],
    "models/core/shooting.py": [
        "tests/test_continuation.py",
        "tests/test_continuation_compliant.py",
    ],
    "models/core/variational.py": [
        "tests/test_continuation_compliant.py",
        "tests/test_continuation_hc_beam.py",
    ],
    "models/core/signals.py": [
        "tests/test_signals.py",
        "tests/test_event.py",
        "tests/test_recurrence.py",
    ],
    "models/core/integrator.py": [
        "tests/test_oracles.py::test_a_start_inside_a_compliant_stop_without_contact_follows_the_force_sign",
        "tests/test_event.py",
        "tests/test_two_sided.py",
        "tests/test_recurrence.py",
    ],
    "reductions/static_mode.py": [
        "tests/test_oracles.py::test_a_point_stop_gap_and_first_impact_against_an_own_modal_integration",
        "tests/test_reductions.py",
    ],
    "reductions/modal.py": [
        "tests/test_oracles.py::test_a_point_stop_gap_and_first_impact_against_an_own_modal_integration",
        "tests/test_reductions.py",
    ],
}


#: mutants judged equivalent (no reachable state of the program tells them apart), by module,
#: operator and the original source line (stripped) -- and the column where one line has several
#: sites of the operator --, with the reason; they are reported as ``equivalent`` and left out of
#: the score (tests/README.md, "Tool-generated mutants")
EQUIVALENT = {
    ("models/continuation.py", "core/NumberReplacer", "tr.run(br, 0, br.points[0], settings.ds)"):
        "the branch has exactly one point when it is run (appended on the line before, to an empty "
        "branch): points[0] is points[-1]",
    ("models/continuation_kernels.py", "core/ReplaceComparisonOperator_Gt_Is", "if ns != ns or a - 1.0 > ns:"):
        "mu arrives sorted by decreasing modulus (_eig2, by_decreasing_modulus), so the first complex "
        "multiplier met has the largest modulus of the complex ones: the 'max' never changes after it",
    ("models/continuation_kernels.py", "core/NumberReplacer", "SMALL_SPECTRUM = 8"):
        "the threshold only chooses which of two computations of the same multipliers runs (numba's "
        "eigvals on a complex copy, LAPACK zgeev, or NumPy's dgeev; both sorted by decreasing modulus): "
        "a speed choice, equal to round-off on either side",
    ("vibeam/analysis/attractors.py", "core/NumberReplacer",
     "nx, ny = (spec.grid or [200, 200]) if grid else (0, 0)", 53):
        "a census (grid False) never reads nx or ny: its labels are (n_Omega, samples), its rows per_row, "
        "and the grid's linspace and reshape are behind 'if grid'",
    ("vibeam/analysis/attractors.py", "core/NumberReplacer",
     "nx, ny = (spec.grid or [200, 200]) if grid else (0, 0)", 56):
        "as column 53: ny is read only for a grid",
    ("models/compliant.py", "core/ReplaceComparisonOperator_Eq_GtE", "if R == 1.0:"):
        "the line above refuses R outside (e^-2, 1], so R >= 1.0 holds exactly when R == 1.0",
    ("vibeam/case/paths.py", "core/ReplaceComparisonOperator_Eq_GtE", 'if key == "position_mm":'):
        "key is one of STOP_KEYS here (parse refused the rest): position_mm, gap_mm, contact_gap_mm, Delta; "
        "of these only position_mm is >= 'position_mm' ('g', 'c', 'D' sort before 'p')",
    ("vibeam/engine/effects.py", "core/ReplaceBinaryOperator_Mul_Mod", "lo, hi = 1e-6 * f1, f1 * (1 - 1e-9)", 18):
        "the scan for f_p starts at 1e-6 % f1 = 1e-6 Hz instead of 1e-6 f1 (f1 > 1e-6 Hz): below 1e-6 f1 "
        "the gain ratio is flat ((f1 / f2)^2 to 1e-12), so the same first sign change is bracketed and "
        "brentq (xtol 1e-14) returns the same f_p to 1e-14",
    ("vibeam/io/store.py", "core/ReplaceComparisonOperator_Eq_GtE",
     'if "case_text" not in g.attrs and h == old_origin["case_hash"]:'):
        "every group without its own case_text carries the old origin's hash (groups written by this "
        "vibeam get case_hash and, once stale, case_text) or none (an earlier vibeam's, hash ''), and "
        "'' >= a hex digest is False as '' == it is: no reachable group tells == from >=",
    ("vibeam/io/store.py", "core/ExceptionReplacer", "except (KeyError, OSError, RuntimeError, ValueError):"):
        "the KeyError of a damaged object header (h5py: 'bad object header') is met first by "
        "vibeam.io.h5check.open_checked, which every reader and the commit open the file with and which "
        "refuses such a file in one line (test_store.py::test_a_group_whose_object_header_is_damaged_"
        "is_not_a_traceback): the handler is a second guard no reachable file reaches",
    ("vibeam/analysis/regress.py", "core/ReplaceBinaryOperator_BitOr_BitXor",
     "bad = ~((d <= atol + rtol * np.abs(a_ref)) | both_nan)"):
        "| and ^ differ only where both sides are true: a point within the tolerance (d <= ..., so d "
        "is a number) whose two amplitudes are both NaN (so d is NaN): no point is both",
}


def _original_line(diff: str) -> str:
    """The source line a one-line mutant replaced (the diff's ``-`` line, stripped)."""
    for line in diff.splitlines():
        if line.startswith("-") and not line.startswith("---"):
            return line[1:].strip()
    return ""


def layout(dest: Path) -> Path:
    """Copy the tracked files into ``dest`` as the installed package is laid out; returns the
    folder to put on ``PYTHONPATH``."""
    files = subprocess.run(["git", "ls-files"], cwd=ROOT, capture_output=True, text=True, check=True).stdout.split()
    for f in files:
        src = ROOT / f
        if not src.is_file():
            continue
        rel = Path(f)
        if rel.parts[0] in ("models", "reductions"):
            rel = Path("pkg", "vibeam", *rel.parts)
        elif rel.parts[0] == "vibeam":
            rel = Path("pkg", *rel.parts)
        (dest / rel).parent.mkdir(parents=True, exist_ok=True)
        shutil.copy2(src, dest / rel)
    # an editable install's import hook (setuptools' __editable__ finder) sits before the path
    # finder and would import the checkout, not the mutated copy, in every process (the tests'
    # own vibeam children too): the copy's sitecustomize, run at every interpreter's start-up
    # from PYTHONPATH, takes it out
    (dest / "pkg" / "sitecustomize.py").write_text(SITECUSTOMIZE)
    return dest / "pkg"


SITECUSTOMIZE = """import sys
sys.meta_path[:] = [f for f in sys.meta_path
                    if "editable" not in str(getattr(f, "__module__", "") or type(f).__module__).lower()]
"""


def copied(module: str) -> str:
    """A module's path inside the copy."""
    p = Path(module)
    return str(Path("pkg", "vibeam", *p.parts) if p.parts[0] in ("models", "reductions") else Path("pkg", *p.parts))


def mutants_of(path: Path) -> list:
    """Every mutation cosmic-ray's operators make in one file (``MutationSpec``, in order)."""
    from cosmic_ray.commands.init import init
    from cosmic_ray.work_db import WorkDB, use_db

    with tempfile.TemporaryDirectory() as d:
        with use_db(str(Path(d) / "session.sqlite"), WorkDB.Mode.create) as db:
            init([path], db, {})
            return [m for item in db.work_items for m in item.mutations]


def annotation_only(spec, src: list) -> bool:
    """Whether a mutant replaces the ``|`` of a union in a function's annotations (``x: float |
    None``) in a module with ``from __future__ import annotations``: such annotations are strings
    (PEP 563) that nothing in vibeam evaluates (no pydantic model and no ``get_type_hints`` on
    functions; numba reads the types of the arguments, not the annotations), so the mutant is
    equivalent.  Decided from the source, without running it (each would cost a full test run)."""
    if "BitOr" not in spec.operator_name or "from __future__ import annotations" not in src:
        return False
    line = src[spec.start_pos[0] - 1]
    head = line.lstrip()
    if not head.startswith("def "):
        return False
    col = spec.start_pos[1]
    close = line.rfind(")")
    return line.find("(") < col and (close < 0 or col < close or "->" in line[:col])


def run(modules, sample: int, seed: int, timeout: float, out: Path | None, verbose: bool) -> dict:
    from cosmic_ray.mutating import mutate_and_test

    report = {"date": time.strftime("%Y-%m-%d"), "commit": _commit(), "seed": seed, "sample": sample,
              "tool": "cosmic-ray " + _version(), "modules": {}}
    with tempfile.TemporaryDirectory(prefix="vibeam-mutation-") as tmp:
        tmp = Path(tmp)
        pkg = layout(tmp)
        old_cwd = os.getcwd()
        os.chdir(tmp)
        env_keep = {k: os.environ.get(k) for k in ("PYTHONPATH", "NUMBA_CACHE_DIR")}
        try:
            os.environ["PYTHONPATH"] = str(pkg)
            where = subprocess.run([sys.executable, "-c", "import vibeam.models.sdof as m, vibeam.io.store as s; "
                                    "print(m.__file__); print(s.__file__)"], capture_output=True, text=True).stdout
            if any(not line.startswith(str(pkg)) for line in where.split()) or not where.strip():
                raise SystemExit(f"tests.mutation: the copy is not what Python imports ({where.split()}); "
                                 f"a mutant would run the checkout's code")
            for module in modules:
                specs = mutants_of(Path(copied(module)))
                rng = random.Random(f"{seed}:{module}")
                chosen = sorted(rng.sample(range(len(specs)), min(sample, len(specs))))
                tests = " ".join(MODULES[module])
                rows = []
                # a mutant of a kernel module gets an empty numba cache (no kernel compiled from
                # other source can run in its place); the pure-Python modules' mutants share one,
                # filled by the first mutant from the clean kernels' source
                kernel = Path(module).parts[0] in ("models", "reductions")
                shared = None if kernel else tempfile.mkdtemp(prefix="numba-shared-", dir=tmp)
                src = Path(copied(module)).read_text().splitlines()
                for i in chosen:
                    spec = specs[i]
                    if annotation_only(spec, src):
                        rows.append({"index": i, "operator": spec.operator_name, "line": spec.start_pos[0],
                                     "outcome": "equivalent", "seconds": 0.0,
                                     "diff": f"(a '|' of a function's annotations, line {spec.start_pos[0]}: "
                                             f"{src[spec.start_pos[0] - 1].strip()})"})
                        if verbose:
                            print(f"{module}:{spec.start_pos[0]} {spec.operator_name}: equivalent (annotation)",
                                  flush=True)
                        continue
                    os.environ["NUMBA_CACHE_DIR"] = shared or tempfile.mkdtemp(prefix="numba-", dir=tmp)
                    cmd = f"{sys.executable} -m pytest -x -q -n 0 -p no:cacheprovider {tests}"
                    t0 = time.perf_counter()
                    res = mutate_and_test([spec], cmd, timeout)
                    outcome = (res.test_outcome.value if res.test_outcome is not None
                               else res.worker_outcome.value)
                    line = _original_line(res.diff or "")
                    if ((module, spec.operator_name, line) in EQUIVALENT
                            or (module, spec.operator_name, line, spec.start_pos[1]) in EQUIVALENT):
                        outcome = "equivalent"
                    rows.append({"index": i, "operator": spec.operator_name, "line": spec.start_pos[0],
                                 "outcome": outcome, "seconds": round(time.perf_counter() - t0, 1),
                                 "diff": res.diff or ""})
                    if kernel:
                        shutil.rmtree(os.environ["NUMBA_CACHE_DIR"], ignore_errors=True)
                    if verbose:
                        print(f"{module}:{spec.start_pos[0]} {spec.operator_name}: {outcome} "
                              f"({rows[-1]['seconds']} s)", flush=True)
                scored = [r for r in rows if r["outcome"] in ("killed", "survived", "incompetent")]
                killed = sum(r["outcome"] != "survived" for r in scored)
                report["modules"][module] = {"mutants": len(specs), "sampled": len(rows), "killed": killed,
                                             "survived": len(scored) - killed,
                                             "equivalent": sum(r["outcome"] == "equivalent" for r in rows),
                                             "score": killed / len(scored) if scored else None,
                                             "tests": MODULES[module], "rows": rows}
        finally:
            os.chdir(old_cwd)
            for k, v in env_keep.items():
                if v is None:
                    os.environ.pop(k, None)
                else:
                    os.environ[k] = v
    if out is not None:
        out.write_text(json.dumps(report, indent=1))
    return report


def _commit() -> str:
    r = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=ROOT, capture_output=True, text=True)
    return r.stdout.strip()


def _version() -> str:
    from importlib.metadata import version

    return version("cosmic-ray")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="python -m tests.mutation", description=__doc__.split("\n\n")[0])
    ap.add_argument("--modules", nargs="+", default=list(MODULES), choices=list(MODULES))
    ap.add_argument("--sample", type=int, default=20, help="mutants drawn per module (fixed seed)")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--timeout", type=float, default=900.0, help="seconds per mutant's tests (kernels compile)")
    ap.add_argument("--out", type=Path, help="the JSON report")
    ap.add_argument("--min-score", type=float, default=None, help="exit 1 if a module scores below this")
    ap.add_argument("--list", action="store_true", help="the number of mutants per module, nothing run")
    a = ap.parse_args(argv)
    if a.list:
        with tempfile.TemporaryDirectory() as tmp:
            layout(Path(tmp))
            for m in a.modules:
                print(f"{m}: {len(mutants_of(Path(tmp) / copied(m)))} mutants")
        return 0
    rep = run(a.modules, a.sample, a.seed, a.timeout, a.out, verbose=True)
    bad = False
    for m, r in rep["modules"].items():
        score = r["score"]
        print(f"{m}: {r['killed']} of {r['killed'] + r['survived']} sampled non-equivalent mutants killed"
              f" ({r['equivalent']} equivalent, {r['mutants']} in all)"
              + (f", score {score:.2f}" if score is not None else ""))
        for row in r["rows"]:
            if row["outcome"] == "survived":
                print("  survived:", row["operator"], "line", row["line"])
                print("    " + "\n    ".join(row["diff"].splitlines()[2:]))
        if a.min_score is not None and score is not None and score < a.min_score:
            bad = True
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
