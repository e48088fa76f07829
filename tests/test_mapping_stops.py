"""The one pointwise mapping (:mod:`vibeam.models.mapping`) on the scenes it serves since it was made
one: two compliant stops and a compliant stop beside a Newton one (either above), any families.

Oracles: the event kernel (its settled orbits: sections per stop, amplitude, speeds and contact
records; central differences of its stroboscopic map for the multipliers), Liouville's formula for
the composed section map (the flows' divergence and the Newton resets' ``R^2``), and central
differences of the mapping's own section map for its composed Jacobian (on a lower stop: the
mirrored normal coordinate).
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from vibeam.engine.records import summarize
from vibeam.models.compliant import HuntCrossley, LinearContact
from vibeam.models.contact import Restitution
from vibeam.models.mapping import MappingSolver
from vibeam.models import EventSolver
from vibeam.models.builders.sdof import sdof
from vibeam.models.scene import one_mode

KV = LinearContact.from_restitution(1e4, 0.8)
KV_LOW = LinearContact.from_damping_ratio(3e3, 0.05)
HC = HuntCrossley(1e5, 0.8)
HC_LOW = HuntCrossley(3e4, 0.7)
EXACT = 1e-9      # both flows closed form (Kelvin-Voigt and Newton stops)
INTEGRATED = 1e-8  # a hysteretic-Hertz contact phase: DOP853 at 1e-12 against the kernel's RK at 1e-11

# (upper law, lower law, Omega, tolerance): each stop with its own law
SCENES = [
    (KV, KV_LOW, 0.8, EXACT),              # two Kelvin-Voigt stops
    (KV, Restitution(0.6), 1.0, EXACT),    # Kelvin-Voigt above a Newton stop, period 3
    (None, KV_LOW, 0.8, EXACT),            # Newton above a Kelvin-Voigt stop
    (HC, HC_LOW, 0.8, INTEGRATED),         # two hysteretic-Hertz stops
    (HC, Restitution(0.6), 0.75, INTEGRATED),
    (KV, HC_LOW, 0.8, INTEGRATED),         # two families
]
KEYS = ("amplitude", "q_max", "impact_velocity", "impact_velocity_lower", "contact_duration",
        "contact_duration_lower", "penetration_max", "penetration_max_lower", "energy_per_impact",
        "energy_per_impact_lower", "contact_force_max", "contact_force_max_lower")


def _model(up, low):
    # up None: Newton's law with R = 0.8
    return sdof(beta=0.015, B=5e-3, Delta=0.002, law=Restitution(0.8) if up is None else up, Delta_lower=0.003,
                lower_law=low)


def _settled(m, W):
    tr = EventSolver(m).point(W, None, 2000, 12, 32)
    return tr, summarize(tr, one_mode(m).Delta)


@pytest.mark.parametrize("up, low, W, tol", SCENES)
def test_mapping_finds_the_settled_event_orbit(up, low, W, tol):
    """From rest, the mapping's period-n orbit (n the event run's period) is the event kernel's
    settled orbit (2000 periods, its strobe repeating to 1e-11 of the orbit, asserted): the same
    sections per period on each stop; amplitude, q_max, the mean speed and the contact records of
    each stop to ``tol`` (1e-9 where both flows are exact, measured <= 6e-13; 1e-8 with a
    hysteretic-Hertz stop, the tolerance of tests/test_hc_mapping.py, measured <= 9e-11)."""
    m = _model(up, low)
    tr, ev = _settled(m, W)
    n = ev["period"]
    assert ev["status"] == "ok" and 1 <= n <= 4
    assert np.max(np.abs(tr.strobe[n:] - tr.strobe[:-n])) < 1e-11 * np.max(np.abs(tr.strobe))
    out = MappingSolver(m, n=n).point(W, None, 0, 0)
    assert out["status"] == "ok" and out["period"] == n and out["stable"], out["message"]
    assert out["impacts_per_period"] == ev["impacts_per_period"] > 0
    assert out["impacts_per_period_lower"] == ev["impacts_per_period_lower"] > 0
    for key in KEYS:
        if math.isnan(ev[key]):
            assert math.isnan(out[key]), key
        else:
            assert out[key] == pytest.approx(ev[key], rel=tol, abs=1e-300), key
    # continuation: the orbit is its own guess
    again = MappingSolver(m, n=n).point(W, {"final_state": out["final_state"]}, 0, 0)
    assert again["amplitude"] == pytest.approx(out["amplitude"], rel=1e-12)


@pytest.mark.parametrize("up, low, W, tol", [SCENES[0], SCENES[1], SCENES[2], SCENES[3]])
def test_multipliers_against_the_event_stroboscopic_map(up, low, W, tol):
    """The multipliers (eigenvalues of the composed section map) equal those of central differences
    of the event kernel's n-period stroboscopic map at its settled orbit: step 1e-5 of the orbit,
    compared to 1e-6 (truncation ~1e-10 times the map's third derivatives; the exact flows'
    round-off over the step ~1e-11; measured <= 4.2e-8, the period-4 orbit whose multipliers span
    0.6 to 9e-4) and 3e-7 for hysteretic-Hertz stops (a step of the state moves the kernel's
    Runge-Kutta grid in the contact: up to its 1e-11 tolerance over the 1e-5 step, 1e-6; measured
    4.5e-8)."""
    m = _model(up, low)
    tr, ev = _settled(m, W)
    n = ev["period"]
    out = MappingSolver(m, n=n).point(W, None, 0, 0)
    assert out["status"] == "ok", out["message"]
    x0, held = tr.final_state[:2], tr.final_state[2]
    h = 1e-5 * np.max(np.abs(tr.strobe))

    def strobe(z):
        return EventSolver(m).point(W, np.array([z[0], z[1], held]), 0, n, 8).final_state[:2]

    J = np.column_stack([(strobe(x0 + h * e) - strobe(x0 - h * e)) / (2 * h) for e in np.eye(2)])
    fd = np.sort_complex(np.linalg.eigvals(J).astype(complex))
    bound = 3e-7 if tol == INTEGRATED else 1e-6
    assert np.max(np.abs(fd - np.sort_complex(out["multipliers"]))) < bound, (fd, out["multipliers"])


@pytest.mark.parametrize("up, low, W", [(KV, KV_LOW, 0.8), (KV, Restitution(0.6), 1.0), (None, KV_LOW, 0.8)])
def test_liouville_on_the_composed_section_map(up, low, W):
    """Kelvin-Voigt and Newton stops: the product of the multipliers is ``prod R_k^2 exp(-2 beta n T
    - sum_k c_k tau_k)`` (the Newton resets' ``R^2``; the divergence ``-2 beta`` of the free flow
    over the period and ``-(2 beta + c_k)`` in contact with stop k for its total contact time
    ``tau_k``): to 1e-10 relative (measured <= 8e-13); a wrong passage Jacobian or a lost
    saltation moves it by orders more."""
    m = _model(up, low)
    _, ev = _settled(m, W)
    n = ev["period"]
    out = MappingSolver(m, n=n).point(W, None, 0, 0)
    assert out["status"] == "ok", out["message"]
    T = 2 * math.pi / W
    log_det = -2 * one_mode(m).beta * n * T
    for law, ipp, dur in ((m.stops[0].law, out["impacts_per_period"], out["contact_duration"]),
                          (m.stops[1].law, out["impacts_per_period_lower"], out["contact_duration_lower"])):
        k = int(round(ipp * n))
        log_det += 2 * k * math.log(law.R) if law.kind == "impulsive" else -law.damping * k * dur
    assert np.prod(out["multipliers"]).real == pytest.approx(math.exp(log_det), rel=1e-10)
    assert abs(np.prod(out["multipliers"]).imag) < 1e-12


@pytest.mark.parametrize("up, low, stop", [(KV, KV_LOW, 1), (HC, HC_LOW, 1), (None, KV_LOW, 1), (KV, Restitution(0.6), 0)])
def test_section_map_jacobian_against_finite_differences(up, low, stop):
    """The Jacobian ``d(t1, v1) / d(t0, v0)`` of one section map (passage through ``stop`` -- on the
    lower stop the mirrored normal coordinate -- and the flight to the next arrival) against central
    differences of the map (steps 1e-6 of the period and of the speed: truncation ~1e-12, round-off
    ~1e-10 relative; the integrated contact's tolerance 1e-12 over 1e-6): 1e-6 relative (measured
    <= 1e-8).  The section is one of the orbit's (the event run's period n)."""
    m = _model(up, low)
    W = 0.8
    s = MappingSolver(m, n=_settled(m, W)[1]["period"])
    out = s.point(W, None, 0, 0)
    assert out["status"] == "ok", out["message"]
    fs = out["final_state"]
    fs = np.array([[fs[0], fs[1], 0.0]]) if fs.size == 2 else fs.reshape(-1, 3)
    j = int(np.flatnonzero(fs[:, 2] == stop)[0])
    t0, v0 = fs[j, 0] / W, fs[j, 1]
    t1, v1, J, rec = s.evaluate(W, t0, v0, stop=stop)
    T = 2 * math.pi / W
    Jfd = np.empty((2, 2))
    for c, (dt, dv) in enumerate(((1e-6 * T, 0.0), (0.0, 1e-6 * v0))):
        a, b = s.evaluate(W, t0 + dt, v0 + dv, stop=stop), s.evaluate(W, t0 - dt, v0 - dv, stop=stop)
        assert a[3]["stop"] == b[3]["stop"] == rec["stop"]
        Jfd[:, c] = [(a[0] - b[0]) / (2 * (dt + dv)), (a[1] - b[1]) / (2 * (dt + dv))]
    np.testing.assert_allclose(J, Jfd, rtol=1e-6, atol=1e-6 * np.max(np.abs(J)))


def test_a_chatter_orbit_is_a_failed_point_with_its_reason():
    """Where the event run chatters on the Newton stop (R = 0.5) beside a compliant one (27 arrivals
    in each period, accumulating: the map is not defined on an accumulating sequence), the point is
    ``failed`` with the reasons (the chatter named), never an exception or an ``ok``."""
    m = _model(KV, Restitution(0.5))
    out = MappingSolver(m).point(1.6, None, 0, 0)
    assert out["status"] == "failed" and "chatter" in out["message"], out["message"]
    assert np.isnan(out["amplitude"]) and out["multipliers"].shape == (2,) and np.isnan(out["impact_velocity_lower"])
