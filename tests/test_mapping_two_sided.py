"""Pointwise mapping between two stops (paper Sec. 4.2 with the second stop of Sec. 8;
:mod:`vibeam.models.mapping`).

Oracles: the exact event kernel (its settled orbits: amplitudes, impacts and speeds per stop),
central differences of the event kernel's stroboscopic map (the Floquet multipliers), Liouville's
formula ``det M = prod R_k^2 exp(-2 beta n T)``, and the one-stop mapping (a lower stop that is
never reached changes nothing, bit for bit).
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from vibeam.models import EventSolver
from vibeam.models.builders.sdof import sdof
from vibeam.models.contact import Restitution
from vibeam.models.scene import one_mode
from vibeam.models.mapping import MappingSolver
from vibeam.engine.records import summarize

# (Delta, Delta_lower, R_lower, Omega, q0): paper-fig7-two-sided-like scenes (beta = 0.015,
# B = 5e-4, R = 0.9) and what each exercises; q0: start of the event run (None: rest)
SCENES = [
    (0.0, 2e-3, None, 1.5, None),      # period 1 on the upper stop only (the one-stop mapping's orbit)
    (0.0, 2e-3, None, 1.7, None),      # period 3: 3 upper impacts, 1 lower
    (0.0, 2e-3, 0.7, 2.0, None),       # period 2: upper, upper, lower; the lower stop with its own R
    (0.0, 2e-3, 0.7, 2.5, None),       # period 1, one impact on each stop
    (2e-3, 2e-3, None, 1.5, None),     # the symmetric scene: one impact on each stop per period
    (2e-3, 2e-3, None, 2.0, 2.5e-3),   # symmetric, the impacting orbit beside the free one (started on it)
]
N_REC = 12   # recorded periods: a multiple of every period above


def _model(D, Dl, Rl):
    return sdof(beta=0.015, B=0.5e-3, Delta=D, R=0.9, Delta_lower=Dl,
                lower_law=None if Rl is None else Restitution(float(Rl)))


def _settled(m, W, q0):
    s0 = None if q0 is None else np.array([q0, 0.0, 0.0])
    tr = EventSolver(m).point(W, s0, 3000, N_REC, 64)
    out = summarize(tr, one_mode(m).Delta)
    return tr, out


@pytest.mark.parametrize("D, Dl, Rl, W, q0", SCENES)
def test_two_sided_mapping_equals_the_event_kernel(D, Dl, Rl, W, q0):
    """The mapping's period-n orbit is the event kernel's settled orbit: the same period and
    impacts per period on each stop; amplitude, q_max and the mean impact speed on each stop to
    1e-9 relative.  Both are exact flows with impacts located to a few ulps; the event run is
    settled (its strobe repeats after n periods to 1e-11 of the orbit, asserted: 3000 periods
    with multipliers <= 0.96), so what is left is round-off amplified along the orbit (measured
    <= 3e-14).  The sequence found is then handed on as the next point's guess (continuation)."""
    m = _model(D, Dl, Rl)
    tr, ev = _settled(m, W, q0)
    n = ev["period"]
    assert ev["status"] == "ok" and n >= 1
    st = tr.strobe
    scale = np.max(np.abs(st))
    assert np.max(np.abs(st[n:] - st[:-n])) < 1e-11 * scale
    s = MappingSolver(m, n=n)
    if q0 is None:
        out = s.point(W, None, 0, 0)
    else:   # the free orbit coexists: the guess is the event run's impact sequence
        seq = np.column_stack([W * tr.impact_times[-2:], tr.impact_velocities[-2:], tr.impact_stops[-2:]]).ravel()
        out = s.point(W, seq, 0, 0)
    assert out["status"] == "ok", out["message"]
    assert out["period"] == n and out["stable"]
    assert out["impacts_per_period"] == ev["impacts_per_period"]
    assert out["impacts_per_period_lower"] == ev["impacts_per_period_lower"]
    for key in ("amplitude", "q_max", "impact_velocity", "impact_velocity_lower"):
        if math.isnan(ev[key]):
            assert math.isnan(out[key])
        else:
            assert out[key] == pytest.approx(ev[key], rel=1e-9), key
    # continuation: the orbit is its own guess, and is found again from it
    again = s.point(W, {"final_state": out["final_state"]}, 0, 0)
    assert again["amplitude"] == pytest.approx(out["amplitude"], rel=1e-13)


def _strobe_map(m, W, n, x):
    return EventSolver(m).point(W, np.array([x[0], x[1], 0.0]), 0, n, 8).final_state[:2]


@pytest.mark.parametrize("D, Dl, Rl, W, q0", [SCENES[1], SCENES[2], SCENES[3], SCENES[4], SCENES[5]])
def test_two_sided_multipliers_against_the_event_stroboscopic_map(D, Dl, Rl, W, q0):
    """Floquet multipliers (monodromy of saltation matrices and flows, and the composed impact-map
    Jacobian) against central differences of the event kernel's n-period stroboscopic map at its
    settled fixed point (step 1e-6 of the orbit: truncation ~1e-12, round-off ~1e-16 / 1e-6;
    compared to 1e-6, measured <= 6e-10), and Liouville's det M = prod R_k^2 exp(-2 beta n T)
    to 1e-12."""
    m = _model(D, Dl, Rl)
    tr, ev = _settled(m, W, q0)
    n = ev["period"]
    x0 = tr.final_state[:2]
    seq = np.column_stack([W * tr.impact_times, tr.impact_velocities, tr.impact_stops]).ravel()
    k = int(round(ev["impacts_per_period"] * n + ev["impacts_per_period_lower"] * n))
    out = MappingSolver(m, n=n).point(W, seq[-3 * k:], 0, 0)
    assert out["status"] == "ok", out["message"]
    h = 1e-6 * np.max(np.abs(tr.strobe))
    J = np.column_stack([(_strobe_map(m, W, n, x0 + h * e) - _strobe_map(m, W, n, x0 - h * e)) / (2 * h)
                         for e in np.eye(2)])
    fd = np.sort_complex(np.linalg.eigvals(J).astype(complex))
    mu = np.sort_complex(out["multipliers"])
    assert np.max(np.abs(fd - mu)) < 1e-6, (fd, mu)
    assert np.max(np.abs(np.sort_complex(out["map_eigenvalues"]) - mu)) < 1e-10
    Rl_ = 0.9 if Rl is None else Rl
    nl = int(round(ev["impacts_per_period_lower"] * n))
    nu = int(round(ev["impacts_per_period"] * n))
    det = 0.9 ** (2 * nu) * Rl_ ** (2 * nl) * math.exp(-2 * 0.015 * n * 2 * math.pi / W)
    assert np.prod(out["multipliers"]).real == pytest.approx(det, rel=1e-12)


@pytest.mark.parametrize("W, n", [(1.8, 1), (2.0, 1), (2.2, 1), (2.6, 2), (1.5, 1)])
def test_far_lower_stop_reproduces_the_one_stop_mapping(W, n):
    """Fig. 7 (Delta = 0) with a lower stop at 1e3 that is never reached: every output of the
    one-stop mapping, bit for bit (the same guess from the bit-identical event kernel, the same
    one-impact route), the lower stop's counts 0 / NaN."""
    one = sdof(beta=0.015, B=0.5e-3, Delta=0.0, R=0.9)
    two = sdof(beta=0.015, B=0.5e-3, Delta=0.0, R=0.9, Delta_lower=1e3, lower_law=Restitution(0.5))
    a = MappingSolver(one, n=n).point(W, None, 0, 0)
    b = MappingSolver(two, n=n).point(W, None, 0, 0)
    assert a["status"] == b["status"]
    for key, val in a.items():
        if isinstance(val, str):
            assert b[key] == val or a["status"] == "failed"   # the reasons of a failure may differ
        else:
            np.testing.assert_array_equal(np.asarray(b[key]), np.asarray(val), err_msg=key)
    if a["status"] == "ok":
        assert b["impacts_per_period_lower"] == 0.0 and math.isnan(b["impact_velocity_lower"])


def test_two_sided_mapping_case_runs_a_continued_frc(tmp_path):
    """A two-sided case accepts method ``mapping`` (registry ``two_sided_methods``); the sweep
    continues the orbit from point to point (the flat impact sequence as state) and stores the
    lower stop's counts; the period-2 branch of Fig. 7 with a lower stop at 2e-3 (1.9 ... 2.2)
    agrees with the event run of the same case point by point (amplitude and speeds to 1e-9)."""
    from vibeam.case.schema import parse_case
    from vibeam.models import make_solver
    from vibeam.engine.sweep import Sweep, run_sweep

    text = """name = "x"
[model]
fidelity = "sdof"
beta = 0.015
B = 0.5e-3
R = 0.9
Delta = 0.0
Delta_lower = 2e-3
[model.contact_lower]
R = 0.7
[sweep]
Omega = [1.9, 2.2, 4]
[[run]]
name = "map"
method = "mapping"
n = 2
"""
    case = parse_case(text, "x.toml")
    sc = case.model_spec().scene()
    W = np.linspace(1.9, 2.2, 4)
    res = run_sweep(make_solver(sc, "mapping", n=2), Sweep(Omega=W, direction="up"), jobs=1)
    d = res.data
    assert np.all(d["status"] == "ok") and np.all(d["period"] == 2)
    np.testing.assert_array_equal(d["impacts_per_period_lower"], 0.5)
    for i, w in enumerate(W):
        ev = summarize(EventSolver(sc).point(w, None, 3000, N_REC, 64), one_mode(sc).Delta)
        assert d["impact_velocity_lower"][i] == pytest.approx(ev["impact_velocity_lower"], rel=1e-9)
        assert d["impact_velocity"][i] == pytest.approx(ev["impact_velocity"], rel=1e-9)
