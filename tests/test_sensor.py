"""The sensor effect: resampling, central differences and the paper's CoR picking (Sec. 5.1)."""
import math

import numpy as np
import pytest

from vibeam.case.schema import SensorSpec, parse_case
from vibeam.models import make_solver
from vibeam.models.builders.sdof import sdof_physical
from vibeam.engine.sensor import (SensorHook, central_velocity, identify, identify_impacts, physical_record,
                           required_samples_per_period, resample)

FN, L_M, R = 7.6, 0.18, 0.72     # rig-neutral (Sec. 7): f_n (Hz), L (m), R
RIG = sdof_physical(FN, 0.017, 0.0, 180.0, 5.16e-4, 0.6, R)


def _traj(f_hz, fs, n_record=12):
    spp = required_samples_per_period(fs, f_hz, 2)
    return make_solver(RIG, "event").point(f_hz / FN, None, 300, n_record, spp)


def _bound(traj, fs):
    """(1 + R) 2 dt max|a| / min U'- near the impacts, from the exact record (module doc)."""
    t, x, v = physical_record(traj, FN, L_M)
    a = np.diff(v) / np.diff(t)
    om = 2 * math.pi * FN
    ti = traj.impact_times / om
    k = np.searchsorted(t, ti)
    win = int(4 * (1 / fs) / (t[1] - t[0])) + 2
    near = np.zeros(a.size, bool)
    for kk in k:
        near[max(kk - win, 0):kk + win] = True
        near[max(kk - 2, 0):kk + 1] = False      # the interval holding the jump itself
    amax = np.abs(a[near]).max()
    umin = (traj.impact_velocities * L_M * 1e3 * om).min()
    return (1 + R) * 2 * amax * 1e-3 / umin * 1e3 / fs


@pytest.mark.parametrize("fs", [5000.0, 50000.0])
def test_noise_free_identification_within_the_sampling_bound(fs):
    tr = _traj(15.0, fs)
    assert tr.status == "ok" and tr.n_impacts >= 10
    r = identify(tr, FN, L_M, fs, impacts="all", R_const=R)
    assert r["n_identified"] == tr.n_impacts and r["n_false"] == 0
    tol = _bound(tr, fs)
    assert abs(r["R_identified"] - R) <= tol, (r["R_identified"], tol)
    assert r["R_true"] == pytest.approx(R)
    # SDOF: sensor = contact; exact samples h = dt / 2 either side of the impact
    assert r["R_sensor_exact"] == pytest.approx(R, abs=tol / 2)
    # the bound is not vacuous: at 5 kHz it is ~1e-2, at 50 kHz ~1e-3
    assert tol < (0.03 if fs == 5000.0 else 0.003)
    # the picked U'- is the pre-impact velocity to the same order
    assert r["identified_velocity_mm_s"] == pytest.approx(r["true_velocity_mm_s"], rel=tol)


def test_denser_sampling_is_more_accurate():
    errs = []
    for fs in (2000.0, 5000.0, 20000.0):
        tr = _traj(15.0, fs, 6)
        errs.append(abs(identify(tr, FN, L_M, fs, impacts="all",
                                 R_const=R)["R_identified"] - R))
    assert errs[0] > errs[1] > errs[2]


def test_error_grows_with_noise():
    fs = 5000.0
    tr = _traj(15.0, fs, 16)
    levels = (0.0, 0.0002, 0.001)
    rms = []
    for s in levels:
        e = []
        for seed in range(6):
            r = identify(tr, FN, L_M, fs, noise_mm=s,
                         rng=np.random.default_rng(seed), impacts="first3", R_const=R)
            e.append(r["R_identified"] - R)
        rms.append(float(np.sqrt(np.mean(np.square(e)))))
    assert rms[0] < rms[1] < rms[2], rms
    assert rms[2] > 5 * rms[0]


def test_resampling_keeps_the_jump_sharp():
    """Across an impact the Hermite interpolant would smear the jump; the one-sided
    extrapolation keeps the sampled displacement within O(a h^2) of the truth."""
    fs = 5000.0
    tr = _traj(15.0, fs, 2)
    fine = make_solver(RIG, "event").point(15.0 / FN, None, 300, 2, 20 * tr.samples_per_period)
    om = 2 * math.pi * FN
    t, x, v = physical_record(tr, FN, L_M)
    tf, xf, _ = physical_record(fine, FN, L_M)
    ts, xs = resample(t, x, v, fs, tr.impact_times / om)
    ref = np.interp(ts, tf, xf)   # dense reference (linear over 1/20 of the record step)
    assert np.abs(xs - ref).max() < 2e-5   # mm


def test_identify_impacts_on_a_synthetic_jump():
    fs = 1000.0
    t = np.arange(400) / fs
    ti = 0.2003
    Um, R = 40.0, 0.6
    x = np.where(t < ti, Um * (t - ti), -R * Um * (t - ti))   # mm, constant velocities
    v = central_velocity(x, fs)
    idx, um, up = identify_impacts(v)
    assert idx.size == 1 and um[0] == pytest.approx(Um) and -up[0] / um[0] == pytest.approx(R)


def test_sensor_hook_ladder_and_case_validation():
    tr = _traj(15.0, 5000.0, 8)
    sp = SensorSpec(noise_ladder_mm=[0.0, 0.001])
    out = SensorHook(sp, FN, L_M, RIG.stops[0].law)(tr)
    assert out["R_identified_ladder"].shape == (2,) and out["R_identified"] == out["R_identified_ladder"][0]
    assert out["R_n_identified"] == 3
    from vibeam.case.schema import CaseError
    with pytest.raises(CaseError, match="impacts"):
        parse_case('name="x"\n[model]\nfidelity="sdof"\nbeta=0.01\nB=0.1\nR=0.8\nDelta=0.0\n'
                   '[sweep]\nOmega=[2,2,1]\n[effects.sensor]\nimpacts="some"\n[[run]]\nname="a"\nmethod="event"\n')
