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

Every mutant of the named modules (issue 56), not a sample, one run each::

    .venv/bin/python -m tests.mutation --all --modules vibeam/case/paths.py --out paths.json --csv paths.csv
    .venv/bin/python -m tests.mutation --all --modules vibeam/case/paths.py --retest paths.json --out paths2.json

A mutant of a framework module (pure Python) runs in a forked child of the driver
(:class:`ForkRunner`): the driver runs the module's tests once on the clean source (compiling the
kernels they meet, with a numba cache under ``--workdir`` that stays valid from run to run), and
each child imports afresh only the mutated module, the modules that import it and the test files,
so a mutant costs its tests' own time (1-3 s on the 2 busy cores), not the 15-20 s of starting
Python and importing numba, scipy and the framework.  The clean run is traced (``sys.settrace``
on the module's file): a mutant on a line no test reaches is recorded ``survived`` (``why``: not
executed) without a run.  ``--retest REPORT`` keeps the killed and equivalent mutants of an
earlier report (matched by what they change, so the module may have changed since) and runs the
others again: after tests were written for the survivors.  A kernel module's mutant still runs in
a fresh process with an empty numba cache (``--runner subprocess``).

Each mutant's tests are its module's test files (:data:`MODULES`: a selection by what the
tests exercise, written down here, not by measured coverage) run with ``pytest -x -q``;
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
import ast
import contextlib
import csv
import hashlib
import json
import os
import random
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

#: module (path in the repository) -> the tests that exercise it (run from the copy's root)
MODULES = {
    "vibeam/io/store.py": [
        "tests/test_store_units.py",
        "tests/test_store.py",
        # the successor's compaction (issue 57 item 4): a rerun keeps the file's size
        "tests/test_files_read_written.py::test_a_successor_holds_only_live_objects",
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
    # a beam's table to its scene (issue 58): gaps, laws, point stops, effects, continuation conversions
    "vibeam/case/beamscene.py": [
        "tests/test_beamscene.py",
        "tests/test_periodic_beam.py::test_conversions_and_refused_keys",
        "tests/test_expand.py",
        "tests/test_oracles.py::test_a_point_stop_gap_and_first_impact_against_an_own_modal_integration",
        "tests/test_oracles.py::test_the_beams_lower_gap_is_converted_to_the_contact_point",
        "tests/test_effects.py",
    ],
    # a structure's tables to its scene (issue 58): the chain's stops, drives and refusals, the mesh's
    "vibeam/case/structure.py": [
        "tests/test_chain_matrices.py",
        "tests/test_mesh_case.py",
        "tests/test_continuum_case.py",
    ],
    "vibeam/case/paths.py": [
        "tests/test_paths.py::test_a_path_sets_the_one_key_it_stands_for",
        "tests/test_paths.py::test_a_path_stands_for_the_flat_key_of_its_stop",
        "tests/test_paths.py::test_a_path_the_scene_does_not_have_is_one_line",
        "tests/test_paths.py::test_continuation_in_a_path_the_scene_does_not_set_is_one_line",
        "tests/test_paths.py::test_a_continuation_range_the_scene_cannot_take_is_one_line",
        "tests/test_paths.py::test_a_continuation_range_in_a_flat_key_the_spec_has_no_field_of_is_checked_by_its_path",
        "tests/test_paths_resolver.py",
    ],
    # the property tests on synthetic samples (no kernel; first: a mutant's run stops at its first
    # failure), then the default suite's tests of the uncertainty layer that run no more than a few
    # dozen sampled sweeps (the sdof event kernel, compiled once by the clean run)
    "vibeam/case/uncertainty.py": [
        "tests/test_uncertainty_spec.py",
        "tests/test_uncertainty.py::test_bad_uncertainty_input_is_refused_in_one_line_naming_the_key",
        "tests/test_uncertainty.py::test_a_truncated_normal_R_inside_its_range_is_accepted",
        "tests/test_uncertainty.py::test_every_sample_and_statistic_equals_the_closed_form_linear_frc",
    ],
    "vibeam/analysis/uncertainty.py": [
        "tests/test_uncertainty_properties.py",
        "tests/test_uncertainty.py::test_every_sample_and_statistic_equals_the_closed_form_linear_frc",
        "tests/test_uncertainty.py::test_the_verdict_of_two_runs_counts_the_points_outside_the_band",
        "tests/test_uncertainty.py::test_resume_refuses_a_checkpoint_vibeam_did_not_write",
        "tests/test_uncertainty.py::test_sample_runs_inline_gives_every_run_its_rows_roles_and_attrs",
        "tests/test_uncertainty.py::test_sample_runs_of_a_physical_scene_are_on_its_frequency_axis",
    ],
    "models/orbits/lyapunov.py": [
        "tests/test_oracles.py::test_lyapunov_exponents_of_period_2_and_3_orbits_are_their_floquet_exponents",
        "tests/test_lyapunov.py",
        "tests/test_lyapunov_errors.py",
    ],
    "models/compliant.py": [
        "tests/test_oracles.py::test_a_hertz_exponent_of_the_case_is_the_power_of_the_force",
        "tests/test_compliant.py",
        "tests/test_lankarani_nikravesh.py",
    ],
    "models/orbits/continuation.py": [
        "tests/test_oracles.py::test_the_continuation_step_is_capped_at_ds_max",
        "tests/test_oracles.py::test_the_multipliers_of_a_continued_branch_through_its_period_doubling_against_lapack",
        "tests/test_continuation_cli.py::test_map_curves_follow_the_closed_form_grazing_and_the_one_parameter_fold",
        "tests/test_continuation.py",
    ],
    "models/core/continuation_kernels.py": [
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
    "models/core/scene_shooting.py": [
        "tests/test_scene_shooting.py",
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
    ("models/core/scene_shooting.py", "core/ReplaceComparisonOperator_Eq_LtE",
     "self._undamped = np.asarray(s.damping, float) == 0.0"):
        "a modal system's damping coefficients are >= 0 (models.system.modal_system refuses others): "
        "c <= 0 is c == 0",
    ("models/orbits/continuation.py", "core/NumberReplacer", "tr.run(br, 0, br.points[0], settings.ds)"):
        "the branch has exactly one point when it is run (appended on the line before, to an empty "
        "branch): points[0] is points[-1]",
    ("models/core/continuation_kernels.py", "core/ReplaceComparisonOperator_Gt_Is", "if ns != ns or a - 1.0 > ns:"):
        "mu arrives sorted by decreasing modulus (_eig2, by_decreasing_modulus), so the first complex "
        "multiplier met has the largest modulus of the complex ones: the 'max' never changes after it",
    ("models/core/continuation_kernels.py", "core/NumberReplacer", "SMALL_SPECTRUM = 8"):
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
    # vibeam/case/paths.py (issue 56: every mutant run; each of these survived, and no input the resolver is given tells it apart)
    ("vibeam/case/paths.py", "core/ReplaceBinaryOperator_Add_LShift", 'n = 1 + any(lo in model for _, lo in _SHORT_GAPS.values())'):
        '1 << b equals 1 + b for a bool b (1 or 2 stops)',
    ("vibeam/case/paths.py", "core/ReplaceComparisonOperator_Eq_LtE", 'if (group == "excitation") != (key in EXCITATION_KEYS):', 18):
        "group is 'system' or 'excitation' (the regex): 'system' <= 'excitation' is False",
    ("vibeam/case/paths.py", "core/ReplaceComparisonOperator_NotEq_IsNot", 'if (group == "excitation") != (key in EXCITATION_KEYS):', 35):
        "both sides are bools, singletons: 'is not' is '!='",
    ("vibeam/case/paths.py", "core/ReplaceComparisonOperator_Eq_LtE", 'if i == 0:', 9):
        'i is a parsed index (\\d+), never negative: i <= 0 is i == 0',
    ("vibeam/case/paths.py", "core/ReplaceComparisonOperator_Eq_LtE", 'if i == 0:', 13):
        'i is a parsed index (\\d+), never negative: i <= 0 is i == 0',
    ("vibeam/case/paths.py", "core/ReplaceComparisonOperator_Eq_LtE", 'where = "contact" if i == 0 else "contact_lower"     # the lower stop\'s own table from now on'):
        'i is a parsed index (\\d+), never negative: i <= 0 is i == 0',
    ("vibeam/case/paths.py", "core/ReplaceComparisonOperator_Eq_LtE", 'if key == "R":'):
        "key is a law key (parse): only 'R' sorts <= 'R', the others being lower case",
    ("vibeam/case/paths.py", "core/ReplaceComparisonOperator_Eq_Is", 'if key == "R":'):
        "CPython keeps one object per one-character string: a key 'R' cut from the path is the literal 'R'",
    ("vibeam/case/paths.py", "core/ReplaceComparisonOperator_Eq_LtE", 'if i == 1 and where == "contact_lower" and table.get("R") is not None:', 13):
        "a shorthand stop's index is 0 or 1, and at 0 where is 'contact', so the condition is False either way",
    ("vibeam/case/paths.py", "core/ReplaceComparisonOperator_Eq_GtE", 'if i == 1 and where == "contact_lower" and table.get("R") is not None:', 13):
        "a shorthand stop's index is 0 or 1: i >= 1 is i == 1",
    ("vibeam/case/paths.py", "core/ReplaceComparisonOperator_Eq_GtE", 'if i == 1 and where == "contact_lower" and table.get("R") is not None:', 28):
        "where is 'contact' or 'contact_lower': 'contact' >= 'contact_lower' is False",
    ("vibeam/case/paths.py", "core/ReplaceComparisonOperator_Eq_Is", 'if i == 1 and where == "contact_lower" and table.get("R") is not None:', 28):
        "where is one of the module's two literals (interned, the same objects)",
    ("vibeam/case/paths.py", "core/ReplaceComparisonOperator_Eq_LtE", 'lo = [j for j in at_mass if stops[j].get("side", "upper") == "lower"]'):
        "side is 'upper' or 'lower' (the schema): 'upper' <= 'lower' is False",
    ("vibeam/case/paths.py", "core/ReplaceComparisonOperator_Eq_GtE", 'up = [j for j in at_mass if stops[j].get("side", "upper") == "upper"]'):
        "side is 'upper' or 'lower' (the schema): 'lower' >= 'upper' is False",
    ("vibeam/case/paths.py", "core/ReplaceComparisonOperator_Eq_LtE", 'if kind == "stop" and key in _SHORT_GAPS:'):
        "kind is 'stop' or 'law' here, and no law key is a gap key (parse): the 'and' is False for a law either way",
    ("vibeam/case/paths.py", "core/ReplaceComparisonOperator_Eq_GtE", 'if kind == "stop" and key in _SHORT_GAPS:'):
        "kind is 'stop' or 'law' here: 'law' >= 'stop' is False",
    ("vibeam/case/paths.py", "core/ReplaceComparisonOperator_Eq_Is", 'if kind == "stop" and key in _SHORT_GAPS:'):
        'kind is a literal parse returns (interned, the same object)',
    ("vibeam/case/paths.py", "core/ReplaceComparisonOperator_Eq_LtE", 'if kind == "law" and key == "R":', 12):
        "kind is 'stop' or 'law' here: 'stop' <= 'law' is False",
    ("vibeam/case/paths.py", "core/ReplaceComparisonOperator_Eq_GtE", 'if kind == "law" and key == "R":', 12):
        "kind is 'stop' or 'law' here, and a stop's own keys (parse) are never 'R': the 'and' is False for a stop either way",
    ("vibeam/case/paths.py", "core/ReplaceComparisonOperator_Eq_Is", 'if kind == "law" and key == "R":', 12):
        'kind is a literal parse returns (interned, the same object)',
    ("vibeam/case/paths.py", "core/ReplaceComparisonOperator_Eq_LtE", 'if kind == "law" and key == "R":', 29):
        "key is a law key (parse): only 'R' sorts <= 'R'",
    ("vibeam/case/paths.py", "core/ReplaceComparisonOperator_Eq_Is", 'if kind == "law" and key == "R":', 29):
        "CPython keeps one object per one-character string: a key 'R' cut from the path is the literal 'R'",
    ("vibeam/case/paths.py", "core/ReplaceComparisonOperator_Eq_GtE", 'if kind == "stop":'):
        "kind is 'stop' or 'law' here ('model' returned before): 'law' >= 'stop' is False",
    ("vibeam/case/paths.py", "core/ReplaceComparisonOperator_Eq_Is", 'if kind == "stop":'):
        'kind is a literal parse returns (interned, the same object)',
    ("vibeam/case/paths.py", "core/ReplaceComparisonOperator_Eq_Is", 'if kind == "model":'):
        'kind is a literal parse returns (interned, the same object)',
    ("vibeam/case/paths.py", "core/ReplaceComparisonOperator_NotEq_Gt", 'return ("R",) + tuple(k for k in LAWS[law].keys if k != "R")'):
        "the registry's keys are 'R' or lower case, and lower case sorts after 'R'",
    ("vibeam/case/paths.py", "core/ReplaceComparisonOperator_NotEq_IsNot", 'return ("R",) + tuple(k for k in LAWS[law].keys if k != "R")'):
        "the registry's keys are literals (interned): 'R' there is the literal 'R'",
    ("vibeam/case/paths.py", "core/ReplaceComparisonOperator_NotEq_Gt", 'elif key != "R" and key not in LAWS[law].keys:'):
        "key is a law key (parse): 'R' or lower case, which sorts after 'R'",
    ("vibeam/case/paths.py", "core/ReplaceComparisonOperator_NotEq_IsNot", 'elif key != "R" and key not in LAWS[law].keys:'):
        "a key 'R' cut from the path is the cached one-character string 'R'; every other key differs from it by identity as by value",
    ("vibeam/case/paths.py", "core/NumberReplacer", 'return name.rsplit(".", 1)[-1] if is_path(name) else name', 28):
        'the last part is the same for any maxsplit >= 1',
    # vibeam/analysis/uncertainty.py (issue 56): the bootstrap's batch size only says how many resamples
    # are drawn at once (memory); the draws are one stream whatever the batches
    # (test_uncertainty_properties.py::test_the_bootstraps_batches_do_not_change_its_draws)
    ("vibeam/analysis/uncertainty.py", "core/ReplaceBinaryOperator_FloorDiv_Add", "batch = max(1, BOOTSTRAP_BATCH // m)"):
        "the batch size changes how many resamples are drawn at once, not the draws (one stream): the "
        "intervals are the same bit for bit; max(1, .) keeps any result a valid size",
    ("vibeam/analysis/uncertainty.py", "core/ReplaceBinaryOperator_FloorDiv_Sub", "batch = max(1, BOOTSTRAP_BATCH // m)"):
        "the batch size changes how many resamples are drawn at once, not the draws (one stream): the "
        "intervals are the same bit for bit; max(1, .) keeps any result a valid size",
    ("vibeam/analysis/uncertainty.py", "core/ReplaceBinaryOperator_FloorDiv_Mul", "batch = max(1, BOOTSTRAP_BATCH // m)"):
        "the batch size changes how many resamples are drawn at once, not the draws (one stream): the "
        "intervals are the same bit for bit; max(1, .) keeps any result a valid size",
    ("vibeam/analysis/uncertainty.py", "core/ReplaceBinaryOperator_FloorDiv_Div", "batch = max(1, BOOTSTRAP_BATCH // m)"):
        "the batch size changes how many resamples are drawn at once, not the draws (one stream): the "
        "intervals are the same bit for bit; max(1, .) keeps any result a valid size",
    ("vibeam/analysis/uncertainty.py", "core/ReplaceBinaryOperator_FloorDiv_Mod", "batch = max(1, BOOTSTRAP_BATCH // m)"):
        "the batch size changes how many resamples are drawn at once, not the draws (one stream): the "
        "intervals are the same bit for bit; max(1, .) keeps any result a valid size",
    ("vibeam/analysis/uncertainty.py", "core/ReplaceBinaryOperator_FloorDiv_Pow", "batch = max(1, BOOTSTRAP_BATCH // m)"):
        "the batch size changes how many resamples are drawn at once, not the draws (one stream): the "
        "intervals are the same bit for bit; max(1, .) keeps any result a valid size",
    ("vibeam/analysis/uncertainty.py", "core/ReplaceBinaryOperator_FloorDiv_RShift", "batch = max(1, BOOTSTRAP_BATCH // m)"):
        "the batch size changes how many resamples are drawn at once, not the draws (one stream): the "
        "intervals are the same bit for bit; max(1, .) keeps any result a valid size",
    ("vibeam/analysis/uncertainty.py", "core/ReplaceBinaryOperator_FloorDiv_LShift", "batch = max(1, BOOTSTRAP_BATCH // m)"):
        "the batch size changes how many resamples are drawn at once, not the draws (one stream): the "
        "intervals are the same bit for bit; max(1, .) keeps any result a valid size",
    ("vibeam/analysis/uncertainty.py", "core/ReplaceBinaryOperator_FloorDiv_BitOr", "batch = max(1, BOOTSTRAP_BATCH // m)"):
        "the batch size changes how many resamples are drawn at once, not the draws (one stream): the "
        "intervals are the same bit for bit; max(1, .) keeps any result a valid size",
    ("vibeam/analysis/uncertainty.py", "core/ReplaceBinaryOperator_FloorDiv_BitAnd", "batch = max(1, BOOTSTRAP_BATCH // m)"):
        "the batch size changes how many resamples are drawn at once, not the draws (one stream): the "
        "intervals are the same bit for bit; max(1, .) keeps any result a valid size",
    ("vibeam/analysis/uncertainty.py", "core/ReplaceBinaryOperator_FloorDiv_BitXor", "batch = max(1, BOOTSTRAP_BATCH // m)"):
        "the batch size changes how many resamples are drawn at once, not the draws (one stream): the "
        "intervals are the same bit for bit; max(1, .) keeps any result a valid size",
    ("vibeam/analysis/uncertainty.py", "core/NumberReplacer", "batch = max(1, BOOTSTRAP_BATCH // m)"):
        "max(1, .)'s 1 as 2 or 0: BOOTSTRAP_BATCH // m >= 64 for the at most 65536 samples, so the batch "
        "is the same",
    ("vibeam/analysis/uncertainty.py", "core/ReplaceBinaryOperator_LShift_Add", "BOOTSTRAP_BATCH = 1 << 22"):
        "the largest batch of resample values (memory): any size gives the same draws (one stream)",
    ("vibeam/analysis/uncertainty.py", "core/ReplaceBinaryOperator_LShift_Sub", "BOOTSTRAP_BATCH = 1 << 22"):
        "the largest batch of resample values (memory): any size gives the same draws (one stream)",
    ("vibeam/analysis/uncertainty.py", "core/ReplaceBinaryOperator_LShift_Mul", "BOOTSTRAP_BATCH = 1 << 22"):
        "the largest batch of resample values (memory): any size gives the same draws (one stream)",
    ("vibeam/analysis/uncertainty.py", "core/ReplaceBinaryOperator_LShift_Div", "BOOTSTRAP_BATCH = 1 << 22"):
        "the largest batch of resample values (memory): any size gives the same draws (one stream)",
    ("vibeam/analysis/uncertainty.py", "core/ReplaceBinaryOperator_LShift_FloorDiv", "BOOTSTRAP_BATCH = 1 << 22"):
        "the largest batch of resample values (memory): any size gives the same draws (one stream)",
    ("vibeam/analysis/uncertainty.py", "core/ReplaceBinaryOperator_LShift_Mod", "BOOTSTRAP_BATCH = 1 << 22"):
        "the largest batch of resample values (memory): any size gives the same draws (one stream)",
    ("vibeam/analysis/uncertainty.py", "core/ReplaceBinaryOperator_LShift_Pow", "BOOTSTRAP_BATCH = 1 << 22"):
        "the largest batch of resample values (memory): any size gives the same draws (one stream)",
    ("vibeam/analysis/uncertainty.py", "core/ReplaceBinaryOperator_LShift_RShift", "BOOTSTRAP_BATCH = 1 << 22"):
        "the largest batch of resample values (memory): any size gives the same draws (one stream)",
    ("vibeam/analysis/uncertainty.py", "core/ReplaceBinaryOperator_LShift_BitOr", "BOOTSTRAP_BATCH = 1 << 22"):
        "the largest batch of resample values (memory): any size gives the same draws (one stream)",
    ("vibeam/analysis/uncertainty.py", "core/ReplaceBinaryOperator_LShift_BitAnd", "BOOTSTRAP_BATCH = 1 << 22"):
        "the largest batch of resample values (memory): any size gives the same draws (one stream)",
    ("vibeam/analysis/uncertainty.py", "core/ReplaceBinaryOperator_LShift_BitXor", "BOOTSTRAP_BATCH = 1 << 22"):
        "the largest batch of resample values (memory): any size gives the same draws (one stream)",
    ("vibeam/analysis/uncertainty.py", "core/NumberReplacer", "BOOTSTRAP_BATCH = 1 << 22"):
        "the largest batch of resample values (memory): any size gives the same draws (one stream)",
    ("vibeam/analysis/uncertainty.py", "core/ReplaceBinaryOperator_BitOr_Add", 'return (r == "A") | (r == "B")'):
        "a row's role is one value: the masks 'A' and 'B' are never both true, where numpy's bool + (or) "
        "and ^ equal |",
    ("vibeam/analysis/uncertainty.py", "core/ReplaceBinaryOperator_BitOr_Add",
     '"outside_band_a_in_b": float(np.mean((med_a[ok] < lo_b[ok]) | (med_a[ok] > hi_b[ok]))) if ok.any() else np.nan,'):
        "a median below the band's 5 % end is never above its 95 % end (quantiles are ordered): never both "
        "true, where numpy's bool + (or) and ^ equal |",
    ("vibeam/analysis/uncertainty.py", "core/ReplaceBinaryOperator_BitOr_Add",
     '"outside_band_b_in_a": float(np.mean((med_b[ok] < lo_a[ok]) | (med_b[ok] > hi_a[ok]))) if ok.any() else np.nan}'):
        "as the line above: below the 5 % and above the 95 % end are never both true",
    ("vibeam/analysis/uncertainty.py", "core/ReplaceBinaryOperator_BitOr_BitXor", 'return (r == "A") | (r == "B")'):
        "a row's role is one value: the masks 'A' and 'B' are never both true, where numpy's bool + (or) "
        "and ^ equal |",
    ("vibeam/analysis/uncertainty.py", "core/ReplaceBinaryOperator_BitOr_BitXor",
     '"outside_band_a_in_b": float(np.mean((med_a[ok] < lo_b[ok]) | (med_a[ok] > hi_b[ok]))) if ok.any() else np.nan,'):
        "a median below the band's 5 % end is never above its 95 % end (quantiles are ordered): never both "
        "true, where numpy's bool + (or) and ^ equal |",
    ("vibeam/analysis/uncertainty.py", "core/ReplaceBinaryOperator_BitOr_BitXor",
     '"outside_band_b_in_a": float(np.mean((med_b[ok] < lo_a[ok]) | (med_b[ok] > hi_a[ok]))) if ok.any() else np.nan}'):
        "as the line above: below the 5 % and above the 95 % end are never both true",
    ("vibeam/analysis/uncertainty.py", "core/ReplaceBinaryOperator_BitAnd_Mul", 'ok = np.isfinite(fA).all(axis=1) & np.isfinite(fB).all(axis=1) & np.isfinite(fAB).all(axis=(0, 2))', 45):
        "numpy's * of two bool arrays is their and",
    ("vibeam/analysis/uncertainty.py", "core/ReplaceBinaryOperator_BitAnd_Mul", 'ok = np.isfinite(fA).all(axis=1) & np.isfinite(fB).all(axis=1) & np.isfinite(fAB).all(axis=(0, 2))', 75):
        "numpy's * of two bool arrays is their and",
    ("vibeam/analysis/uncertainty.py", "core/ReplaceBinaryOperator_BitAnd_Add", 'ok = np.isfinite(fA).all(axis=1) & np.isfinite(fB).all(axis=1) & np.isfinite(fAB).all(axis=(0, 2))', 45):
        "(A ok + B ok) & AB ok differs only where A or B holds a NaN, and the next line's variance of A and "
        "B is then NaN, not > 0: the point is left out either way",
    ("vibeam/analysis/uncertainty.py", "core/ReplaceBinaryOperator_BitAnd_Add", 'ok = np.isfinite(med_a) & np.isfinite(med_b) & np.isfinite(lo_a) & np.isfinite(lo_b)', 32):
        "a run's median and its 5 % quantile are NaN at the same points (no finite sample there), so the "
        "four tests are two, each twice: any and/or/+/* of them that keeps one of each pair is the same mask",
    ("vibeam/analysis/uncertainty.py", "core/ReplaceBinaryOperator_BitAnd_Add", 'ok = np.isfinite(med_a) & np.isfinite(med_b) & np.isfinite(lo_a) & np.isfinite(lo_b)', 53):
        "a run's median and its 5 % quantile are NaN at the same points (no finite sample there), so the "
        "four tests are two, each twice: any and/or/+/* of them that keeps one of each pair is the same mask",
    ("vibeam/analysis/uncertainty.py", "core/ReplaceBinaryOperator_BitAnd_Add", 'ok = np.isfinite(med_a) & np.isfinite(med_b) & np.isfinite(lo_a) & np.isfinite(lo_b)', 73):
        "a run's median and its 5 % quantile are NaN at the same points (no finite sample there), so the "
        "four tests are two, each twice: any and/or/+/* of them that keeps one of each pair is the same mask",
    ("vibeam/analysis/uncertainty.py", "core/ReplaceBinaryOperator_BitAnd_Mul", 'ok = np.isfinite(med_a) & np.isfinite(med_b) & np.isfinite(lo_a) & np.isfinite(lo_b)', 32):
        "a run's median and its 5 % quantile are NaN at the same points (no finite sample there), so the "
        "four tests are two, each twice: any and/or/+/* of them that keeps one of each pair is the same mask",
    ("vibeam/analysis/uncertainty.py", "core/ReplaceBinaryOperator_BitAnd_Mul", 'ok = np.isfinite(med_a) & np.isfinite(med_b) & np.isfinite(lo_a) & np.isfinite(lo_b)', 53):
        "a run's median and its 5 % quantile are NaN at the same points (no finite sample there), so the "
        "four tests are two, each twice: any and/or/+/* of them that keeps one of each pair is the same mask",
    ("vibeam/analysis/uncertainty.py", "core/ReplaceBinaryOperator_BitAnd_Mul", 'ok = np.isfinite(med_a) & np.isfinite(med_b) & np.isfinite(lo_a) & np.isfinite(lo_b)', 73):
        "a run's median and its 5 % quantile are NaN at the same points (no finite sample there), so the "
        "four tests are two, each twice: any and/or/+/* of them that keeps one of each pair is the same mask",
    ("vibeam/analysis/uncertainty.py", "core/ReplaceBinaryOperator_BitAnd_BitOr", 'ok = np.isfinite(med_a) & np.isfinite(med_b) & np.isfinite(lo_a) & np.isfinite(lo_b)', 32):
        "a run's median and its 5 % quantile are NaN at the same points (no finite sample there), so the "
        "four tests are two, each twice: any and/or/+/* of them that keeps one of each pair is the same mask",
    ("vibeam/analysis/uncertainty.py", "core/ReplaceBinaryOperator_BitAnd_BitOr", 'ok = np.isfinite(med_a) & np.isfinite(med_b) & np.isfinite(lo_a) & np.isfinite(lo_b)', 53):
        "a run's median and its 5 % quantile are NaN at the same points (no finite sample there), so the "
        "four tests are two, each twice: any and/or/+/* of them that keeps one of each pair is the same mask",
    ("vibeam/analysis/uncertainty.py", "core/ReplaceBinaryOperator_BitAnd_BitOr", 'ok = np.isfinite(med_a) & np.isfinite(med_b) & np.isfinite(lo_a) & np.isfinite(lo_b)', 73):
        "a run's median and its 5 % quantile are NaN at the same points (no finite sample there), so the "
        "four tests are two, each twice: any and/or/+/* of them that keeps one of each pair is the same mask",
    ("vibeam/analysis/uncertainty.py", "core/ReplaceComparisonOperator_Eq_LtE", 'cols = np.repeat(cols, 2) if cols.size == 1 else cols'):
        "cols holds at least one column (ok.any()): size <= 1 is size == 1",
    ("vibeam/analysis/uncertainty.py", "core/ReplaceComparisonOperator_Eq_LtE", 'return (r == "A") | (r == "B")', 18):
        "a row's role is 'A', 'B' or 'AB:<name>': only 'A' sorts <= 'A' ('AB:...' after it), and nothing sorts after 'B' but 'B' (its >= is its ==)",
    ("vibeam/analysis/uncertainty.py", "core/ReplaceComparisonOperator_Eq_GtE", 'return (r == "A") | (r == "B")', 31):
        "a row's role is 'A', 'B' or 'AB:<name>': only 'A' sorts <= 'A' ('AB:...' after it), and nothing sorts after 'B' but 'B' (its >= is its ==)",
    ("vibeam/analysis/uncertainty.py", "core/ReplaceComparisonOperator_Eq_LtE", 'n, d = int(np.sum(roles == "A")), len(self.parameters)'):
        "a row's role is 'A', 'B' or 'AB:<name>': only 'A' sorts <= 'A' ('AB:...' after it), and nothing sorts after 'B' but 'B' (its >= is its ==)",
    ("vibeam/analysis/uncertainty.py", "core/ReplaceComparisonOperator_Eq_LtE", 'fA, fB = Y[roles == "A"].T, Y[roles == "B"].T', 29):
        "a row's role is 'A', 'B' or 'AB:<name>': only 'A' sorts <= 'A' ('AB:...' after it), and nothing sorts after 'B' but 'B' (its >= is its ==)",
    ("vibeam/analysis/uncertainty.py", "core/ReplaceComparisonOperator_Eq_GtE", 'fA, fB = Y[roles == "A"].T, Y[roles == "B"].T', 48):
        "a row's role is 'A', 'B' or 'AB:<name>': only 'A' sorts <= 'A' ('AB:...' after it), and nothing sorts after 'B' but 'B' (its >= is its ==)",
    ("vibeam/analysis/uncertainty.py", "core/ReplaceComparisonOperator_Eq_LtE", 'nd = 2 if self.case.sweep.direction == "both" else 1'):
        "the direction is 'up', 'down' or 'both' (the schema): only 'both' sorts <= 'both'",
    ("vibeam/analysis/uncertainty.py", "core/ReplaceComparisonOperator_NotEq_Lt", 'if i.size and (i.min() < 0 or i.max() >= rows or np.unique(i).size != i.size):'):
        'np.unique(i) never has more elements than i: != is <',
    ("vibeam/analysis/uncertainty.py", "core/ReplaceComparisonOperator_Gt_NotEq", 'return np.where(n > 0, mean, np.nan), np.where(n > 1, np.sqrt(var_), np.nan), n', 24):
        "n counts samples, never negative: n != 0 is n > 0",
    ("vibeam/analysis/uncertainty.py", "core/ReplaceComparisonOperator_Gt_NotEq", 'ok &= (np.var(np.concatenate([fA, fB], axis=1), axis=1) > 0)'):
        "a variance is >= 0, or NaN where A or B holds a NaN, and those points are out already (the line "
        "above): != 0 is > 0 on what is left",
    # vibeam/analysis/uncertainty.py, the survivors of its full pass (issue 56) that no reachable input tells apart
    ("vibeam/analysis/uncertainty.py", "core/ReplaceComparisonOperator_Gt_NotEq", 'return np.where(n > 0, mean, np.nan), np.where(n > 1, np.sqrt(var_), np.nan), n', 26):
        "n counts samples, never negative: n != 0 is n > 0",
    ("vibeam/analysis/uncertainty.py", "core/ReplaceComparisonOperator_Gt_GtE", 'return np.where(n > 0, mean, np.nan), np.where(n > 1, np.sqrt(var_), np.nan), n', 26):
        "where n == 0 the mean is 0 / 0, NaN (the errstate above), the value np.where puts there",
    ("vibeam/analysis/uncertainty.py", "core/NumberReplacer", 'return np.where(n > 0, mean, np.nan), np.where(n > 1, np.sqrt(var_), np.nan), n', 28):
        "n > -1 keeps n == 0 too, where the mean is 0 / 0, NaN already",
    ("vibeam/analysis/uncertainty.py", "core/ReplaceComparisonOperator_Gt_GtE", 'return np.where(n > 0, mean, np.nan), np.where(n > 1, np.sqrt(var_), np.nan), n', 57):
        "where n == 1 the variance is 0 / (n - 1) = 0 / 0, NaN already (n == 2 is tested: a std)",
    ("vibeam/analysis/uncertainty.py", "core/NumberReplacer", 'return np.where(n > 0, mean, np.nan), np.where(n > 1, np.sqrt(var_), np.nan), n', 59):
        "n > 0 keeps n == 1, where the variance is 0 / 0, NaN already (n > 2 is killed: two samples have a std)",
    ("vibeam/analysis/uncertainty.py", "core/NumberReplacer", 'cols = np.repeat(cols, 2) if cols.size == 1 else cols'):
        "the single output goes in 3 times instead of 2 and only the first is kept: scipy's estimates are per "
        "output and its bootstrap resamples the rows, common to all outputs; checked bit for bit (indices and "
        "intervals of a one-point result, 2 against 3 copies)",
    ("vibeam/analysis/uncertainty.py", "core/ReplaceUnaryOperator_USub_Invert", 'first, total, first_ci, total_ci = indices(self.amplitude.reshape(len(roles), -1))'):
        "numpy (2.4 here) infers a dimension given as any negative number, not only -1: reshape(n, -2) is reshape(n, -1)",
    ("vibeam/analysis/uncertainty.py", "core/NumberReplacer", 'first, total, first_ci, total_ci = indices(self.amplitude.reshape(len(roles), -1))'):
        "numpy (2.4 here) infers a dimension given as any negative number, not only -1: reshape(n, -2) is reshape(n, -1)",
    ("vibeam/analysis/uncertainty.py", "core/NumberReplacer", 'jf, jt, _, _ = indices(self.jumps()[:, d_jump:d_jump + 1])'):
        "a sweep's directions are ('up',), ('down',) or ('up', 'down') (visiting order): with down d_jump is the "
        "last column, without it there is one; d_jump + 2 slices the same single column",
    ("vibeam/analysis/uncertainty.py", "core/NumberReplacer", '"jump_first": jf[:, 0], "jump_total": jt[:, 0]}'):
        "jf and jt have one column (the jump frequency of one direction): [:, -1] is [:, 0]",
    ("vibeam/analysis/uncertainty.py", "core/ReplaceOrWithAnd", 'if x.size < 2 or not np.isfinite(x).any():'):
        "either way the next test stops such a sample: one point has no neighbour (np.diff is empty) and a sample "
        "without a finite amplitude has no finite change, so 'not np.isfinite(dA).any()' continues",
    ("vibeam/analysis/uncertainty.py", "core/NumberReplacer", 'if x.size < 2 or not np.isfinite(x).any():', 24):
        "x.size < 1 lets a one-point sweep through to np.diff, empty, which the next test stops (size < 3 is killed: "
        "a 2-point jump is tested)",
    ("vibeam/analysis/uncertainty.py", "core/NumberReplacer", 'return self.lost_rows(None, 0)'):
        "lost_rows reads neither its error nor its attempts (a refused solver's row is the same whatever they are)",
    ("vibeam/analysis/uncertainty.py", "core/NumberReplacer", 'done[task.run][task.index] = rows[0]'):
        "a SampleTask's compute and lost_rows return exactly one row (its arrays): rows[-1] is rows[0]",
    ("vibeam/analysis/uncertainty.py", "core/NumberReplacer", 'on_sample(task.run, task.index, rows[0])'):
        "a SampleTask's compute and lost_rows return exactly one row (its arrays): rows[-1] is rows[0]",
    ("vibeam/analysis/uncertainty.py", "core/NumberReplacer", 'd = r.directions.index("down") if "down" in r.directions else 0'):
        "without 'down' the directions are ('up',), one: index -1 is index 0",
    ("vibeam/analysis/uncertainty.py", "core/ReplaceBinaryOperator_Sub_BitXor", 'extra = sorted(set(meta) - {"sample", "amplitude", "period", "status"})'):
        "the four names are in meta here (the loop above returned otherwise): the symmetric difference is the difference",
    ("vibeam/analysis/uncertainty.py", "core/ReplaceComparisonOperator_Eq_LtE", 'if np.dtype(dt).kind not in kinds or (k == "amplitude" and np.dtype(dt).itemsize != 8):'):
        "k is 'amplitude', 'period' or 'status' (the loop's literals): only 'amplitude' sorts <= 'amplitude'",
    ("vibeam/analysis/uncertainty.py", "core/ReplaceComparisonOperator_Eq_Is", 'if np.dtype(dt).kind not in kinds or (k == "amplitude" and np.dtype(dt).itemsize != 8):'):
        "k is one of the module's literals (interned, the same object as 'amplitude')",
    ("vibeam/analysis/uncertainty.py", "core/ReplaceBinaryOperator_BitOr_Add", '(live & np.isnan(a) & ((per != -1) | time_domain), "nan"),'):
        "numpy's + of a bool array and a bool is their or",
    ("vibeam/analysis/uncertainty.py", "core/ReplaceComparisonOperator_NotEq_Gt", '(live & np.isnan(a) & ((per != -1) | time_domain), "nan"),'):
        "a period below -1 was refused above: per > -1 is per != -1 on what is left",
    ("vibeam/analysis/uncertainty.py", "core/ReplaceBinaryOperator_BitAnd_Mul", 'checks = ((live & np.isinf(a), "infinite"),'):
        "numpy's * of two bool arrays is their and",
    ("vibeam/analysis/uncertainty.py", "core/ReplaceBinaryOperator_BitAnd_Mul", '(live & np.isnan(a) & ((per != -1) | time_domain), "nan"),'):
        "numpy's * of two bool arrays is their and",
    ("vibeam/analysis/uncertainty.py", "core/ReplaceBinaryOperator_BitAnd_Mul", '(live & (np.abs(a) > MOTION_MAX), f"beyond {MOTION_MAX:g} in magnitude (its square overflows)"))'):
        "numpy's * of two bool arrays is their and",
    ("vibeam/analysis/uncertainty.py", "core/ReplaceBinaryOperator_BitAnd_FloorDiv", 'checks = ((live & np.isinf(a), "infinite"),'):
        "numpy's // of two bool arrays is their and as integers (x // False is 0, with a divide warning): np.any "
        "of it is the same",
    ("vibeam/analysis/uncertainty.py", "core/ReplaceBinaryOperator_BitAnd_FloorDiv", '(live & np.isnan(a) & ((per != -1) | time_domain), "nan"),'):
        "numpy's // of two bool arrays is their and as integers (x // False is 0, with a divide warning): np.any "
        "of it is the same",
    ("vibeam/analysis/uncertainty.py", "core/ReplaceBinaryOperator_BitAnd_FloorDiv", '(live & (np.abs(a) > MOTION_MAX), f"beyond {MOTION_MAX:g} in magnitude (its square overflows)"))'):
        "numpy's // of two bool arrays is their and as integers (x // False is 0, with a divide warning): np.any "
        "of it is the same",
    ("vibeam/analysis/uncertainty.py", "core/ReplaceComparisonOperator_NotEq_IsNot", 'if ua != ub or xa.shape != xb.shape or not np.allclose(xa, xb, rtol=1e-12, atol=0) \\'):
        "the units are the literals 'Hz' or '1' of UncertaintyResult.axis (interned, one object each): 'is not' is '!='",
    # vibeam/case/uncertainty.py (issue 56: every mutant run; these survived and no input tells them apart)
    ('vibeam/case/uncertainty.py', 'core/ReplaceComparisonOperator_Eq_LtE', 'if self.distribution == "lognormal" and not self.mean > 0.0:'):
        "the distribution is one of the Literal's five names, and every other one ('normal', 'truncnorm', 'uniform', 'triangular') sorts after 'lognormal': <= is ==",
    ('vibeam/case/uncertainty.py', 'core/ReplaceComparisonOperator_Eq_LtE', 'if d == "lognormal":         # the parameter\'s own mean and std: sigma^2 = ln(1 + (s/m)^2)'):
        "normal, truncnorm and uniform returned above: d is 'lognormal' or 'triangular', which sorts after it",
    ('vibeam/case/uncertainty.py', 'core/ReplaceComparisonOperator_Eq_GtE', 'if d == "uniform":'):
        "normal and truncnorm returned above: d is 'uniform', 'lognormal' or 'triangular', the last two sort before 'uniform'",
    ('vibeam/case/uncertainty.py', 'core/ReplaceComparisonOperator_Eq_Is', 'if self.distribution == "lognormal" and not self.mean > 0.0:'):
        "pydantic's Literal check returns the annotation's own string (interned), not the one it was given (test_uncertainty_spec.py::test_a_distributions_name_is_the_modules_own_string): 'is' is '=='",
    ('vibeam/case/uncertainty.py', 'core/ReplaceComparisonOperator_Eq_Is', 'if self.distribution == "triangular" and not self.bounds[0] <= self.mode <= self.bounds[1]:'):
        "pydantic's Literal check returns the annotation's own string (interned), not the one it was given (test_uncertainty_spec.py::test_a_distributions_name_is_the_modules_own_string): 'is' is '=='",
    ('vibeam/case/uncertainty.py', 'core/ReplaceComparisonOperator_Eq_Is', 'if self.distribution == "truncnorm":'):
        "pydantic's Literal check returns the annotation's own string (interned), not the one it was given (test_uncertainty_spec.py::test_a_distributions_name_is_the_modules_own_string): 'is' is '=='",
    ('vibeam/case/uncertainty.py', 'core/ReplaceComparisonOperator_Eq_Is', 'if d == "normal":'):
        "pydantic's Literal check returns the annotation's own string (interned), not the one it was given (test_uncertainty_spec.py::test_a_distributions_name_is_the_modules_own_string): 'is' is '=='",
    ('vibeam/case/uncertainty.py', 'core/ReplaceComparisonOperator_Eq_Is', 'if d == "truncnorm":'):
        "pydantic's Literal check returns the annotation's own string (interned), not the one it was given (test_uncertainty_spec.py::test_a_distributions_name_is_the_modules_own_string): 'is' is '=='",
    ('vibeam/case/uncertainty.py', 'core/ReplaceComparisonOperator_Eq_Is', 'if d == "uniform":'):
        "pydantic's Literal check returns the annotation's own string (interned), not the one it was given (test_uncertainty_spec.py::test_a_distributions_name_is_the_modules_own_string): 'is' is '=='",
    ('vibeam/case/uncertainty.py', 'core/ReplaceComparisonOperator_Eq_Is', 'if d == "lognormal":         # the parameter\'s own mean and std: sigma^2 = ln(1 + (s/m)^2)'):
        "pydantic's Literal check returns the annotation's own string (interned), not the one it was given (test_uncertainty_spec.py::test_a_distributions_name_is_the_modules_own_string): 'is' is '=='",
    ('vibeam/case/uncertainty.py', 'core/ReplaceComparisonOperator_Gt_NotEq', 'dup = sorted({n for n in names if names.count(n) > 1})'):
        'n is taken from names, so names.count(n) >= 1: != 1 is > 1',
    ('vibeam/case/uncertainty.py', 'core/NumberReplacer', 'if v & (v - 1):'):
        'v >= 2 here (Field(ge=2) is checked before the validator), and for v >= 2 v & (v - 2) is 0 exactly for the powers of 2, as v & (v - 1) (an even v that is not one keeps a set bit above the one v - 2 borrows from; an odd v shares bit 0 with v - 2)',
    ('vibeam/case/uncertainty.py', 'core/NumberReplacer', 'if n < 2 or n & (n - 1):'):
        "n >= 2 past 'n < 2 or': for n >= 2, n & (n - 2) is 0 exactly for the powers of 2, as n & (n - 1)",
    ('vibeam/case/uncertainty.py', 'core/RemoveDecorator', '@classmethod'):
        "pydantic's field_validator makes a function whose first parameter is cls a classmethod itself (pydantic._internal._decorators.ensure_classmethod_based_on_signature)",
    ('vibeam/case/uncertainty.py', 'core/ReplaceFalseWithTrue', 'model_config = ConfigDict(extra="forbid", strict=True, frozen=True, allow_inf_nan=False)'):
        "UncertaintySpec's own fields are ints, a bool and a list of UncertaintyParameterSpec, which has its own config: allow_inf_nan has no float to act on there (the same line of UncertaintyParameterSpec, whose fields are floats, is killed by test_uncertainty_spec.py::test_a_spec_is_strict_frozen_and_finite_and_its_names_are_flat_keys: this entry applies only to a survivor)",
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
    ("vibeam/io/store.py", "core/NumberReplacer", "v = v.ravel()[0]"):
        "v.size == 1 (the line above): its first element is its last, [-1] is [0]",
    ("vibeam/io/store.py", "core/NumberReplacer", 'parent = d.rsplit("/", 1)[0] if "/" in d else None'):
        "a consumed checkpoint is 'lines', 'uncertainty_samples' or 'basin_lines/<run>' (runner.py, "
        "analysis/attractors.py, api/uncertainty.py) and a run's name has no '/' (vibeam/case/schema.py, the run name field of _RunBase): "
        "d has at most one '/', where rsplit's maxsplit 1 and 2 give the same first part",
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
    None``, on any line of a signature) or in a dataclass field's, in a module with ``from
    __future__ import annotations``: such annotations are strings (PEP 563) that nothing in vibeam
    evaluates (no ``get_type_hints``; numba reads the types of the arguments, dataclasses only look
    for ``ClassVar`` in the text; a pydantic model's fields are evaluated, and are not classed
    here), so the mutant is equivalent.  Decided from the source, without running it."""
    if "BitOr" not in spec.operator_name:
        return False
    text = "\n".join(src)
    if "from __future__ import annotations" not in text:
        return False
    pos = tuple(spec.start_pos)
    return any(a <= pos < b for a, b in _annotation_spans(text))


_SPANS: dict = {}


def _annotation_spans(text: str) -> list:
    """``[((line, col), (end line, end col))]`` of the annotations of every function's arguments
    and return, and of the fields of classes decorated ``@dataclass``."""
    if text not in _SPANS:
        spans = []
        for node in ast.walk(ast.parse(text)):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                a = node.args
                anns = [x.annotation for x in a.posonlyargs + a.args + a.kwonlyargs + [a.vararg, a.kwarg]
                        if x is not None and x.annotation is not None] + ([node.returns] if node.returns else [])
            elif isinstance(node, ast.ClassDef) and any(
                    "dataclass" in ast.unparse(d) for d in node.decorator_list):
                anns = [x.annotation for x in node.body if isinstance(x, ast.AnnAssign)]
            else:
                continue
            spans += [((x.lineno, x.col_offset), (x.end_lineno, x.end_col_offset)) for x in anns]
        _SPANS[text] = spans
    return _SPANS[text]


def _statement_lines(src_text: str) -> dict:
    """``{line: lines}``: for each line of a module, the lines of the innermost statement that holds
    it, without the lines of statements nested in its body (for a compound statement: its header,
    decorators included).  A mutant changes the program only if one of those lines runs."""
    tree = ast.parse(src_text)
    out: dict = {}

    def visit(node, depth=0):
        for child in ast.iter_child_nodes(node):
            if isinstance(child, ast.stmt):
                lo = min([child.lineno] + [d.lineno for d in getattr(child, "decorator_list", [])])
                hi = child.end_lineno or child.lineno
                nested = set()
                for f in ("body", "orelse", "finalbody", "handlers"):
                    for sub in getattr(child, f, None) or []:
                        nested |= set(range(sub.lineno, (sub.end_lineno or sub.lineno) + 1))
                own = frozenset(set(range(lo, hi + 1)) - nested) or frozenset({lo})
                for line in own:
                    out[line] = own
            visit(child, depth + 1)

    visit(tree)
    return out


def _import_lines(src_text: str) -> set:
    """The lines that run when the module is imported (before any test, so untraced): its top-level
    statements, those of its classes' bodies, and the headers (decorators, defaults) of its
    functions."""
    out: set = set()

    def visit(body):
        for n in body:
            if isinstance(n, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
                lo = min([n.lineno] + [d.lineno for d in n.decorator_list])
                out.update(range(lo, n.body[0].lineno))
                if isinstance(n, ast.ClassDef):
                    visit(n.body)
            else:
                out.update(range(n.lineno, (n.end_lineno or n.lineno) + 1))

    visit(ast.parse(src_text).body)
    return out


def _line_tracer(filename: str, per_test: dict, current: list):
    """A ``sys.settrace`` function that adds every line of ``filename`` that runs to
    ``per_test[current[0]]`` (the node id of the test running, None outside tests)."""
    def local(frame, event, arg):
        if event == "line":
            per_test.setdefault(current[0], set()).add(frame.f_lineno)
        return local

    def glob(frame, event, arg):
        if frame.f_code.co_filename == filename:
            per_test.setdefault(current[0], set()).add(frame.f_lineno)
            return local
        return None
    return glob


class _CurrentTest:
    """A pytest plugin that keeps the node id of the test running in ``current[0]`` and the order
    in which the tests ran."""

    def __init__(self, current: list, order: list):
        self.current, self.order = current, order

    def pytest_runtest_logstart(self, nodeid, location):
        self.current[0] = nodeid
        self.order.append(nodeid)

    def pytest_runtest_logfinish(self, nodeid, location):
        self.current[0] = None


def _import_graph(pkg: Path) -> dict:
    """``{module: modules of vibeam it imports at its top level}`` of the copy (imports inside a
    function run at call time through ``sys.modules``, so they bind nothing at import)."""
    files = {}
    for py in (pkg / "vibeam").rglob("*.py"):
        parts = list(py.relative_to(pkg).with_suffix("").parts)
        if parts[-1] == "__init__":
            parts = parts[:-1]
        files[".".join(parts)] = py

    def top(body):
        for n in body:
            if isinstance(n, (ast.FunctionDef, ast.AsyncFunctionDef, ast.Lambda)):
                continue
            yield n
            for f in ("body", "orelse", "finalbody", "handlers"):
                sub = getattr(n, f, None)
                if isinstance(sub, list):
                    yield from top(sub)

    graph = {}
    for name, py in files.items():
        deps = set()
        for n in top(ast.parse(py.read_text()).body):
            if isinstance(n, ast.Import):
                deps |= {a.name for a in n.names}
            elif isinstance(n, ast.ImportFrom):
                if n.level:
                    base = name.split(".") if py.name == "__init__.py" else name.split(".")[:-1]
                    base = base[:len(base) - (n.level - 1)]
                    mod = ".".join(base + ([n.module] if n.module else []))
                else:
                    mod = n.module or ""
                deps.add(mod)
                deps |= {f"{mod}.{a.name}" for a in n.names}
        graph[name] = {d for d in deps if d in files}
    return graph


def _dependents(graph: dict, target: str) -> set:
    """``target`` and every module that imports it at its top level, directly or through others,
    and every submodule of a package among them: what a process must import afresh to run the
    mutated ``target``."""
    out = {target}
    grew = True
    while grew:
        grew = False
        for m, deps in graph.items():
            if m not in out and (deps & out or any(m.startswith(p + ".") for p in out if p != target)):
                out.add(m)
                grew = True
    return out


class _FirstFailure:
    """A pytest plugin that writes the node id of the first failing test to a file."""

    def __init__(self, path: str):
        self.path = path

    def pytest_runtest_logreport(self, report):
        if report.failed and not os.path.exists(self.path):
            with open(self.path, "w") as fh:
                fh.write(report.nodeid)

    def pytest_collectreport(self, report):
        if report.failed and not os.path.exists(self.path):
            with open(self.path, "w") as fh:
                fh.write("collecting " + str(report.nodeid))


class ForkRunner:
    """Runs a module's tests once in this process on the clean source (the kernels they use
    compile once, here), then each mutant's tests in a forked child that imports afresh the
    mutated module, every module that imports it (:func:`_dependents`) and the test files: the
    rest (numpy, scipy, h5py, numba and the compiled kernels of ``vibeam.models``, which never
    import the framework) is inherited, so a mutant costs its tests' own time, not the 10-20 s
    of starting Python and importing them.  For the framework's pure-Python modules only (a
    kernel module's mutant must be compiled from its mutated source: :func:`run` runs those in a
    fresh process each, with an empty numba cache)."""

    def __init__(self, pkg: Path, root: Path):
        self.pkg, self.root = pkg, root
        self.graph = _import_graph(pkg)

    def args(self, tests) -> list:
        """pytest's arguments: stop at the first failure; no plugin but hypothesis' (no xdist: one
        process), and none of the plugins that run a full garbage collection at the end (1 s of
        the numba-sized heap, more than the tests of a killed mutant)."""
        os.environ["PYTEST_DISABLE_PLUGIN_AUTOLOAD"] = "1"
        return ["-x", "-q", "-p", "no:cacheprovider", "-p", "no:unraisableexception", "-p", "no:threadexception",
                "-p", "_hypothesis_pytestplugin", "--no-header", "-o", "addopts=-m 'not slow'", *tests]

    def baseline(self, module: str, tests, trace: bool) -> tuple[float, dict | None, list]:
        """The clean source's run (must pass) in this process: its seconds, with ``trace`` the
        module's lines each test ran (``{node id or None: lines}``, None: outside a test), and the
        node ids in the order they ran."""
        import pytest

        filename = str((self.root / copied(module)).resolve())
        tdir = str(self.root / "tests")

        def forget_tests():                          # test files are collected afresh by each run
            for k, m in list(sys.modules.items()):
                if k == "conftest" or (getattr(m, "__file__", None) or "").startswith(tdir):
                    del sys.modules[k]

        forget_tests()
        per_test: dict = {}
        current: list = [None]
        order: list = []
        if trace:                   # the kernels compile untraced first (numba's compiler is Python)
            if pytest.main(self.args(tests)) != 0:
                raise SystemExit(f"tests.mutation: the clean source fails its tests ({' '.join(tests)})")
            forget_tests()
        t0 = time.perf_counter()
        if trace:
            import threading
            tracer = _line_tracer(filename, per_test, current)
            threading.settrace(tracer)
            sys.settrace(tracer)
        try:
            rc = pytest.main(self.args(tests), plugins=[_CurrentTest(current, order)])
        finally:
            if trace:
                sys.settrace(None)
                import threading
                threading.settrace(None)
        if rc != 0:
            raise SystemExit(f"tests.mutation: the clean source fails its tests ({' '.join(tests)}): exit {rc}")
        return time.perf_counter() - t0, (per_test if trace else None), order

    def purge(self, module: str) -> None:
        """Drop from ``sys.modules`` (and from their packages' attributes) what a child imports
        afresh."""
        name = ".".join(Path(copied(module)).relative_to("pkg").with_suffix("").parts)
        fresh = _dependents(self.graph, name)
        tests = str(self.root / "tests")
        for k, m in list(sys.modules.items()):
            f = getattr(m, "__file__", None) or ""
            if k in fresh or k == "conftest" or k == "tests" or k.startswith("tests.") or f.startswith(tests):
                del sys.modules[k]
                parent, _, leaf = k.rpartition(".")
                if parent in sys.modules and getattr(sys.modules[parent], leaf, None) is m:
                    delattr(sys.modules[parent], leaf)

    @contextlib.contextmanager
    def _applied(self, spec, mutator):
        """The mutant written over the module's file for the block, the file restored after."""
        path = Path(spec.module_path)
        orig = path.read_text()
        mutated = mutator.mutated(spec)
        try:
            if mutated is not None:
                path.write_text(mutated)
            yield orig, mutated
        finally:
            path.write_text(orig)

    def mutant(self, module: str, spec, tests, timeout: float, mutator=None):
        """``(outcome, diff, first failing test)`` of one mutant: killed, survived, incompetent
        (the mutated module does not import: counted as killed) or timeout (killed)."""
        if mutator is None:
            mutator = _Mutator(Path(spec.module_path).read_text())
        with self._applied(spec, mutator) as (orig, mutated):
            if mutated is None:
                return "no-test", "", ""
            diff = "".join(__import__("difflib").unified_diff(orig.splitlines(True), mutated.splitlines(True),
                                                              str(spec.module_path), str(spec.module_path)))
            try:
                compile(mutated, str(spec.module_path), "exec")
            except SyntaxError:
                return "incompetent", diff, "syntax"
            fd, fail = tempfile.mkstemp(prefix="first-failure-")
            os.close(fd)
            os.unlink(fail)
            sys.stdout.flush()
            sys.stderr.flush()
            import gc
            gc.collect()
            gc.freeze()                  # the inherited heap: never scanned again, never copied by the gc
            pid = os.fork()
            if pid == 0:                                       # the child: never returns
                code = 3
                try:
                    os.setpgid(0, 0)
                    null = os.open(os.devnull, os.O_WRONLY)
                    os.dup2(null, 1)
                    os.dup2(null, 2)
                    sys.dont_write_bytecode = True             # never a stale .pyc of another mutant
                    self.purge(module)
                    import pytest
                    code = int(pytest.main(self.args(tests), plugins=[_FirstFailure(fail)]))
                except BaseException:
                    code = 4
                finally:
                    os._exit(code)
            t_end = time.monotonic() + timeout
            status = None
            while time.monotonic() < t_end:
                done, status = os.waitpid(pid, os.WNOHANG)
                if done:
                    break
                time.sleep(0.05)
            else:
                for sig in (signal.SIGTERM, signal.SIGKILL):
                    try:
                        os.killpg(pid, sig)
                    except ProcessLookupError:
                        pass
                    time.sleep(0.5)
                os.waitpid(pid, 0)
                return "killed", diff, "timeout"
            rc = os.waitstatus_to_exitcode(status)
            first = Path(fail).read_text() if os.path.exists(fail) else ""
            if os.path.exists(fail):
                os.unlink(fail)
            if rc == 0:
                return "survived", diff, ""
            if rc == 1:
                return "killed", diff, first
            return "incompetent", diff, first or f"exit {rc}"


def _change_key(operator: str, diff: str) -> tuple:
    """A mutant by what it changes: its operator and its diff's removed and added lines."""
    return (operator, tuple(x for x in diff.splitlines() if x[:1] in "+-" and not x.startswith(("---", "+++"))))


def _diff_of(spec, src_text: str, mutator=None) -> str:
    """The diff of a mutant, made in memory (nothing written)."""
    import difflib

    mutated = (mutator or _Mutator(src_text)).mutated(spec)
    if mutated is None:
        return ""
    return "".join(difflib.unified_diff(src_text.splitlines(True), mutated.splitlines(True),
                                        str(spec.module_path), str(spec.module_path)))


class _Mutator:
    """Mutated sources of one module without re-parsing it per mutant (cosmic-ray's own
    ``mutate_code`` parses and walks the whole file each time: about 1 s of a busy core for a
    700-line module, more than a killed mutant's tests).  The file is parsed once; the k-th
    mutation of an operator is its k-th position in the tree's pre-order, as cosmic-ray's visitor
    counts them; the operator mutates a copy of that node and the copy's code replaces the
    node's (prefix included) in the text.  Checked against ``mutate_code`` by
    tests/test_mutation_driver.py."""

    def __init__(self, src: str):
        from cosmic_ray.ast import ast_nodes, get_ast

        self.src = src
        self.lines = src.splitlines(keepends=True)
        self.nodes = list(ast_nodes(get_ast(src)))
        self.positions: dict = {}

    def _offset(self, pos) -> int:
        line, col = pos
        return sum(len(x) for x in self.lines[:line - 1]) + col

    def mutated(self, spec) -> str | None:
        import copy

        import cosmic_ray.plugins

        op = cosmic_ray.plugins.get_operator(spec.operator_name)(**(getattr(spec, "operator_args", None) or {}))
        if spec.operator_name not in self.positions:
            self.positions[spec.operator_name] = [(n, i) for n in self.nodes
                                                  for i, _ in enumerate(op.mutation_positions(n))]
        found = self.positions[spec.operator_name]
        if spec.occurrence >= len(found):
            return None
        node, index = found[spec.occurrence]
        parent = node.parent
        node.parent = None
        try:
            twin = copy.deepcopy(node)
        finally:
            node.parent = parent
        twin.parent = parent
        new = op.mutate(twin, index)
        text = "" if new is None else new.get_code()
        a, b = self._offset(node.get_start_pos_of_prefix()), self._offset(node.end_pos)
        return self.src[:a] + text + self.src[b:]


def workdir_default() -> Path:
    """The scratch copy's folder, the same on every run of this checkout (its numba cache, beside
    it, stays valid across runs: the kernels' source does not change)."""
    tag = hashlib.sha256(str(ROOT).encode()).hexdigest()[:8]
    return Path(tempfile.gettempdir()) / f"vibeam-mutation-{os.getuid()}-{tag}"


def run(modules, sample: int | None, seed: int, timeout: float, out: Path | None, verbose: bool,
        runner: str = "auto", workdir: Path | None = None, retest: dict | None = None, trace: bool = True,
        csv_out: Path | None = None) -> dict:
    """Mutants of ``modules`` against their tests (:data:`MODULES`); ``sample`` None: every
    mutant.  ``retest``: an earlier report (same module source) whose killed and equivalent mutants
    are carried over and whose other mutants run again (after tests were added)."""
    from cosmic_ray.mutating import mutate_and_test

    report = {"date": time.strftime("%Y-%m-%d"), "commit": _commit(), "seed": seed, "sample": sample,
              "tool": "cosmic-ray " + _version(), "modules": {}}
    workdir = Path(workdir or workdir_default())
    workdir.mkdir(parents=True, exist_ok=True)
    import fcntl
    lock = open(workdir / "lock", "w")
    try:                                # one run per scratch folder: a second would delete the copy
        fcntl.flock(lock, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except OSError:
        raise SystemExit(f"tests.mutation: {workdir} is in use by another run; give another --workdir") from None
    tmp = workdir / "copy"
    shutil.rmtree(tmp, ignore_errors=True)
    tmp.mkdir(parents=True)
    cache = workdir / "numba-cache"
    cache.mkdir(exist_ok=True)
    pkg = layout(tmp)
    old_cwd = os.getcwd()
    os.chdir(tmp)
    keep = ("PYTHONPATH", "NUMBA_CACHE_DIR", "VIBEAM_COMPILE_AHEAD", "OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS")
    env_keep = {k: os.environ.get(k) for k in keep}
    try:
        os.environ["PYTHONPATH"] = str(pkg)
        # one process at a time per mutant (the 2-core machine; compile-ahead's child off)
        os.environ.update(VIBEAM_COMPILE_AHEAD="0", OMP_NUM_THREADS="1", OPENBLAS_NUM_THREADS="1")
        where = subprocess.run([sys.executable, "-c", "import vibeam.models.scene as m, vibeam.io.store as s; "
                                "print(m.__file__); print(s.__file__)"], capture_output=True, text=True).stdout
        if any(not line.startswith(str(pkg)) for line in where.split()) or not where.strip():
            raise SystemExit(f"tests.mutation: the copy is not what Python imports ({where.split()}); "
                             f"a mutant would run the checkout's code")
        forked = None
        for module in modules:
            specs = mutants_of(Path(copied(module)))
            rng = random.Random(f"{seed}:{module}")
            chosen = (list(range(len(specs))) if sample is None
                      else sorted(rng.sample(range(len(specs)), min(sample, len(specs)))))
            tests = MODULES[module]
            rows = []
            kernel = Path(module).parts[0] in ("models", "reductions")
            use_fork = (runner == "fork" or (runner == "auto" and not kernel)) and hasattr(os, "fork")
            if kernel and use_fork:
                raise SystemExit(f"tests.mutation: {module} holds kernels: its mutants run in a fresh process each")
            src_text = Path(copied(module)).read_text()
            src = src_text.splitlines()
            mutator = _Mutator(src_text)
            earlier = {}
            if retest is not None and module in retest["modules"]:
                # by what the mutant changes (operator, line, text): the module may have changed since
                earlier = {_change_key(r["operator"], r["diff"]): r for r in retest["modules"][module]["rows"]
                           if r.get("why") != "not executed" and r["outcome"] in ("killed", "incompetent", "equivalent")}
            os.environ["NUMBA_CACHE_DIR"] = str(cache)
            ran_lines = None
            base_s = None
            everyone: set = set()
            if use_fork:
                if forked is None:
                    sys.path.insert(0, str(pkg))
                    exec(SITECUSTOMIZE, {})                  # the editable install's finder out of this process
                    forked = ForkRunner(pkg, tmp)
                base_s, per_test, order = forked.baseline(module, tests, trace)
                if per_test is not None:
                    # lines run at import or outside a test reach every test: those mutants run them all
                    everyone = _import_lines(src_text) | per_test.get(None, set())
                    ran_lines = set().union(everyone, *per_test.values())
                stmt = _statement_lines(src_text)
                if verbose:
                    print(f"{module}: clean run {base_s:.1f} s (traced), {len(chosen)} mutants, "
                          f"{len(ran_lines or ())} lines ran", flush=True)
            t_module = time.perf_counter()
            for n_done, i in enumerate(chosen):
                spec = specs[i]
                row = {"index": i, "operator": spec.operator_name, "line": spec.start_pos[0],
                       "column": spec.start_pos[1], "outcome": "", "seconds": 0.0, "killed_by": "", "diff": ""}
                if earlier:
                    prev = earlier.get(_change_key(spec.operator_name, _diff_of(spec, src_text, mutator)))
                    if prev is not None:
                        rows.append(dict(prev, index=i, line=spec.start_pos[0], carried=True))
                        continue
                if annotation_only(spec, src):
                    row.update(outcome="equivalent", why="annotation",
                               diff=f"(a '|' of a function's annotations, line {spec.start_pos[0]}: "
                                    f"{src[spec.start_pos[0] - 1].strip()})")
                    rows.append(row)
                    continue
                t0 = time.perf_counter()
                if use_fork:
                    own = stmt.get(spec.start_pos[0], frozenset({spec.start_pos[0]}))
                    if ran_lines is not None and not (own & ran_lines):
                        outcome, diff, first = "survived", "", ""
                        row["why"] = "not executed"
                        line_text = src[spec.start_pos[0] - 1].strip()
                        diff = f"(line {spec.start_pos[0]} never runs in the tests: {line_text})"
                    else:
                        # the tests that reach the mutant's statement, in their order (all of them for a
                        # line run at import): a line no test reaches cannot change a test's outcome
                        chosen_tests = tests if ran_lines is None or own & everyone else \
                            [t for t in order if per_test.get(t, set()) & own]
                        outcome, diff, first = forked.mutant(module, spec, chosen_tests, timeout, mutator)
                else:
                    os.environ["NUMBA_CACHE_DIR"] = str(cache) if not kernel else \
                        tempfile.mkdtemp(prefix="numba-", dir=workdir)
                    cmd = f"{sys.executable} -m pytest -x -q -n 0 -p no:cacheprovider {' '.join(tests)}"
                    res = mutate_and_test([spec], cmd, timeout)
                    outcome = (res.test_outcome.value if res.test_outcome is not None
                               else res.worker_outcome.value)
                    diff, first = res.diff or "", ""
                    if kernel:
                        shutil.rmtree(os.environ["NUMBA_CACHE_DIR"], ignore_errors=True)
                line = _original_line(diff)
                if outcome == "survived" and ((module, spec.operator_name, line) in EQUIVALENT
                                              or (module, spec.operator_name, line, spec.start_pos[1]) in EQUIVALENT):
                    outcome = "equivalent"
                    row["why"] = EQUIVALENT.get((module, spec.operator_name, line)) or \
                        EQUIVALENT[(module, spec.operator_name, line, spec.start_pos[1])]
                row.update(outcome=outcome, seconds=round(time.perf_counter() - t0, 2), killed_by=first, diff=diff)
                rows.append(row)
                if out is not None and len(rows) % 50 == 0:      # a long run keeps what it did
                    report["modules"][module] = {"mutants": len(specs), "partial": True, "rows": rows}
                    out.write_text(json.dumps(report, indent=1))
                if verbose:
                    left = (time.perf_counter() - t_module) / (n_done + 1) * (len(chosen) - n_done - 1)
                    print(f"[{n_done + 1}/{len(chosen)}, ~{left / 60:.0f} min left] {module}:{spec.start_pos[0]} "
                          f"{spec.operator_name}: {outcome} ({row['seconds']} s) {first}", flush=True)
            scored = [r for r in rows if r["outcome"] in ("killed", "survived", "incompetent")]
            killed = sum(r["outcome"] != "survived" for r in scored)
            report["modules"][module] = {
                "mutants": len(specs), "sampled": len(rows), "killed": killed,
                "survived": len(scored) - killed,
                "not_executed": sum(r.get("why") == "not executed" for r in rows),
                "equivalent": sum(r["outcome"] == "equivalent" for r in rows),
                "score": killed / len(scored) if scored else None, "clean_seconds": base_s,
                "seconds": round(time.perf_counter() - t_module, 1), "tests": tests, "rows": rows}
            if out is not None:                           # after each module: a long run keeps what it did
                out.write_text(json.dumps(report, indent=1))
    finally:
        os.chdir(old_cwd)
        for k, v in env_keep.items():
            if v is None:
                os.environ.pop(k, None)
            else:
                os.environ[k] = v
    if out is not None:
        out.write_text(json.dumps(report, indent=1))
    if csv_out is not None:
        with open(csv_out, "w", newline="") as fh:
            w = csv.writer(fh)
            w.writerow(["module", "index", "line", "column", "operator", "outcome", "why", "killed_by", "change"])
            for m, r in report["modules"].items():
                for row in r["rows"]:
                    change = " | ".join(x[1:].strip() for x in row["diff"].splitlines()
                                        if x[:1] in "+-" and not x.startswith(("---", "+++")))
                    w.writerow([m, row["index"], row["line"], row.get("column", ""), row["operator"],
                                row["outcome"], row.get("why", ""), row.get("killed_by", ""), change or row["diff"]])
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
    ap.add_argument("--all", action="store_true", help="every mutant of each module, not a sample")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--timeout", type=float, default=900.0, help="seconds per mutant's tests (kernels compile)")
    ap.add_argument("--out", type=Path, help="the JSON report")
    ap.add_argument("--csv", type=Path, help="one row per mutant: module, line, operator, outcome, ...")
    ap.add_argument("--runner", choices=("auto", "fork", "subprocess"), default="auto",
                    help="auto: a forked child per mutant of a pure-Python module, a fresh process per kernel "
                         "module's mutant")
    ap.add_argument("--workdir", type=Path, help="the scratch copy and its numba cache (default: a fixed folder "
                                                 "of the temporary directory, reused by every run)")
    ap.add_argument("--retest", type=Path, help="an earlier JSON report: its killed and equivalent mutants are "
                                                "kept, the others run again")
    ap.add_argument("--no-trace", action="store_true",
                    help="run every mutant, also those on lines the clean run never reaches")
    ap.add_argument("--min-score", type=float, default=None, help="exit 1 if a module scores below this")
    ap.add_argument("--list", action="store_true", help="the number of mutants per module, nothing run")
    ap.add_argument("--table", type=Path, nargs="+", metavar="REPORT",
                    help="print tests/README.md's table rows of JSON reports or CSV records (of --all runs), nothing run")
    a = ap.parse_args(argv)
    if a.table:
        print("| module | mutants | killed | survived, equivalent | survived, other | score |")
        print("|---|---|---|---|---|---|")
        for path in a.table:
            if path.suffix == ".csv":            # the per-mutant record (--csv): counted here
                mods: dict = {}
                with open(path, newline="") as fh:
                    for row in csv.DictReader(fh):
                        mods.setdefault(row["module"], []).append(row["outcome"])
                for m, outs in mods.items():
                    k = sum(o in ("killed", "incompetent") for o in outs)
                    e, sv = outs.count("equivalent"), outs.count("survived")
                    print(f"| `{m}` | {len(outs)} | {k} | {e} | {sv} | {k / (k + sv):.3f} |")
                continue
            for m, r in json.loads(path.read_text())["modules"].items():
                print(f"| `{m}` | {r['mutants']} | {r['killed']} | {r['equivalent']} | {r['survived']} | "
                      f"{r['score']:.3f} |")
        return 0
    if a.list:
        with tempfile.TemporaryDirectory() as tmp:
            layout(Path(tmp))
            for m in a.modules:
                print(f"{m}: {len(mutants_of(Path(tmp) / copied(m)))} mutants")
        return 0
    retest = json.loads(a.retest.read_text()) if a.retest else None
    rep = run(a.modules, None if a.all else a.sample, a.seed, a.timeout, a.out, verbose=True, runner=a.runner,
              workdir=a.workdir, retest=retest, trace=not a.no_trace, csv_out=a.csv)
    bad = False
    for m, r in rep["modules"].items():
        score = r["score"]
        print(f"{m}: {r['killed']} of {r['killed'] + r['survived']} non-equivalent mutants killed"
              f" ({r['equivalent']} equivalent, {r['sampled']} run of {r['mutants']}; "
              f"{r['not_executed']} survivors on lines the tests never reach)"
              + (f", score {score:.2f}" if score is not None else ""))
        for row in r["rows"]:
            if row["outcome"] == "survived":
                print("  survived:", row["operator"], "line", row["line"], row.get("why", ""))
                print("    " + "\n    ".join(row["diff"].splitlines()[2:]))
        if a.min_score is not None and score is not None and score < a.min_score:
            bad = True
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
