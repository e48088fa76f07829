"""The period-1 branch of the rig as a 3D continuum (issue 59): ``cases/rig-continuum-continuation.toml``.

Its 4-mode run (the two bending modes, torsion and the in-plane mode of the solid from geometry) is
traced through the framework (``vibeam continue``'s path) and checked against:

* the sweep's own event solver: stable branch points stay put under 400 periods from a state
  1e-6 off (an independent integration of the same orbit; the shooting corrector is not used);
* the fold's defining property: the largest Floquet multiplier crosses +1 there and the branch
  changes stability;
* the regressed fold frequency (a case with continuation runs only has no reference FRC:
  tests/test_references.py BRANCH_REGRESSED names this module).

The 8- and 16-mode runs and the eccentric contact are the README's (measured, not asserted here:
their continuation takes minutes on 2 cores).
"""
from __future__ import annotations

import contextlib
import io
from pathlib import Path

import numpy as np
import pytest

from vibeam.case.schema import parse_case
from vibeam.models import make_solver
from vibeam.models.scene import outputs
from vibeam.runner import run_case

ROOT = Path(__file__).resolve().parents[1]
CASE = ROOT / "cases" / "rig-continuum-continuation.toml"
#: the fold of the large period-1 orbit, 4 modes (measured 2026-11-27, `vibeam continue` on the
#: shipped case: 15.444948 Hz, Q = 0.496 mm)
FOLD_HZ = 15.444948


@pytest.fixture(scope="module")
def four_modes(tmp_path_factory):
    """The shipped case's 4-mode run through the framework, its scene and its case."""
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("VIBEAM_CACHE_DIR", str(tmp_path_factory.mktemp("cache")))
        text = CASE.read_text()
        head, *runs = text.split("\n[[run]]\n")
        kept = [r for r in runs if 'name = "continuum 4 modes"' in r]
        assert len(kept) == 1
        text = head + "\n[[run]]\n" + kept[0]
        case = parse_case(text)
        with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
            conts = run_case(case, text, tmp_path_factory.mktemp("out"), jobs=1, quiet=True, plots=False,
                             continuation_only=True)
        sc = case.model_spec(case.run[0].model).scene()
        yield conts[0], sc, case


@pytest.mark.slow   # the continuum's build (~5 s) and a 110-point continuation (~2 s after compiling): slow step
def test_the_fold_is_where_a_multiplier_crosses_one_and_is_regressed(four_modes):
    res, sc, case = four_modes
    br = res.branches[0]
    assert br["status"] == "range_end"
    folds = [bf for bf in res.bifurcations if bf["type"] == "fold"]
    assert len(folds) == 1
    f_ref = outputs(sc).natural_frequency_hz
    # the fold's Omega is a converged zero of t_p (the corrector's 1e-10); 1e-6 relative allows for
    # the machine's round-off in the continuum's ARPACK modes (fixed start vector) and nothing more
    assert folds[0]["parameter"] * f_ref == pytest.approx(FOLD_HZ, rel=1e-6)
    d = br["data"]
    W = np.asarray(d["parameter"])
    mu = np.max(np.abs(np.asarray(d["multipliers"])), axis=1)
    k = int(np.argmin(np.abs(W - folds[0]["parameter"])))
    # on either side of the fold (along the branch) the stability differs and |mu|max passes 1
    lo, hi = max(k - 2, 0), min(k + 2, len(W) - 1)
    assert bool(d["stable"][lo]) != bool(d["stable"][hi])
    assert (mu[lo] - 1.0) * (mu[hi] - 1.0) < 0


@pytest.mark.slow   # shares the fixture above
def test_stable_branch_points_equal_long_event_simulations(four_modes):
    """State and q_min to 1e-9 after 400 periods from 1e-6 off (the corrector's residual amplified
    by 1 / (1 - max|mu|) <= 20 at the points tested; the perturbation decays below 1e-40)."""
    res, sc, case = four_modes
    d = res.branches[0]["data"]
    mu = np.max(np.abs(np.asarray(d["multipliers"])), axis=1)
    idx = np.flatnonzero(np.asarray(d["stable"]) & (mu < 0.95))
    assert len(idx) >= 8
    solver = make_solver(sc, "event")
    for k in idx[:: max(1, len(idx) // 4)]:
        W, x = float(d["parameter"][k]), np.asarray(d["state"][k])
        tr = solver.point(W, np.r_[x * (1 + 1e-6), 0.0], 400, 2, 16)
        assert np.max(np.abs(tr.final_state[:-1] - x)) < 1e-9 * np.max(np.abs(x)), W
        assert tr.q_min == pytest.approx(float(d["q_min"][k]), rel=1e-9)
