"""The exact event-driven solver against closed forms, an independent fixed-point
computation and conservation laws."""
import math

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st
from scipy.linalg import expm
from scipy.optimize import fsolve

from vibeam.models import EventSolver, linear_amplitude
from vibeam.models.builders.sdof import sdof
from vibeam.models.scene import one_mode
from vibeam.engine.records import summarize


def _run(scene, Omega, n_transient, n_record, state0=None, ns=64, **kw):
    return EventSolver(scene, **kw).point(Omega, state0, n_transient, n_record, ns)


# --------------------------------------------------------------------------- linear limit
@pytest.mark.parametrize("Omega", [0.5, 1.0, 1.7, 2.0, 3.3])
def test_far_from_stop_equals_linear_steady_state(Omega):
    """With the stop out of reach the FRC is the linear resonance curve.

    Q = Delta - min q = Delta + C exactly in steady state; after 600 periods the
    homogeneous part has decayed by exp(-0.05 * 600 * 2 pi / Omega) < 1e-24
    (worst case Omega = 3.3), so only round-off remains: rtol 1e-10.
    """
    sc = sdof(beta=0.05, B=0.01, Delta=100.0, R=0.8)
    m = one_mode(sc)
    tr = _run(sc, Omega, 600, 8)
    out = summarize(tr, m.Delta)
    C = linear_amplitude(m.beta, m.B, Omega)
    assert out["period"] == -1  # no impact
    assert out["amplitude"] - m.Delta == pytest.approx(C, rel=1e-10)
    assert out["q_max"] == pytest.approx(C, rel=1e-10)
    # the harmonic analysis sees only the fundamental; the others are at the
    # round-off of q = Delta + (q - Delta), i.e. ~eps * |Delta|
    assert out["harmonics"][1] == pytest.approx(C, rel=1e-10)
    assert np.all(out["harmonics"][[0, 2, 3, 4, 5]] < 100 * np.finfo(float).eps * (m.Delta + C))


# --------------------------------------------------------------------------- period-1 orbit
def _augmented(beta, F, Omega):
    """Linear system for (q, q', sin(Omega t), cos(Omega t)); propagated with expm."""
    return np.array([[0, 1, 0, 0],
                     [-1, -2 * beta, F, 0],
                     [0, 0, 0, Omega],
                     [0, 0, -Omega, 0]], dtype=float)


def _shaw_holmes_fixed_point(beta, B, R, Delta, Omega, guess):
    """Period-1 one-impact orbit (Shaw & Holmes 1983) from the matrix exponential.

    Unknowns: impact phase psi and pre-impact velocity v.  Starting on the stop
    at phase psi with velocity -R v, after one forcing period the orbit must be
    back on the stop with velocity v.  Independent of vibeam's closed form.
    """
    F = Omega**2 * B
    T = 2 * math.pi / Omega
    E = expm(_augmented(beta, F, Omega) * T)

    def res(x):
        psi, v = x
        y = E @ np.array([Delta, -R * v, math.sin(psi), math.cos(psi)])
        return [y[0] - Delta, y[1] - v]

    sol, info, ier, msg = fsolve(res, guess, full_output=True, xtol=1e-14)
    assert ier == 1, msg
    return sol


@pytest.mark.parametrize("Omega", [1.9, 2.0, 2.1])
def test_period_one_orbit_matches_independent_fixed_point(Omega):
    """Steady impact velocity and phase equal the fixed point of the impact map to 1e-8."""
    R = 0.9
    sc = sdof(beta=0.015, B=0.5e-3, Delta=0.0, R=R)
    m = one_mode(sc)
    tr = _run(sc, Omega, 1500, 4)
    assert summarize(tr, m.Delta)["period"] == 1
    assert tr.n_impacts == 4
    T = 2 * math.pi / Omega
    phase = (Omega * tr.impact_times[-1]) % (2 * math.pi)
    v = tr.impact_velocities[-1]
    psi, v_fp = _shaw_holmes_fixed_point(m.beta, m.B, R, m.Delta, Omega, [phase, v])
    assert v == pytest.approx(v_fp, rel=1e-8)
    dpsi = (phase - psi + math.pi) % (2 * math.pi) - math.pi
    assert abs(dpsi) < 1e-8
    # impacts are exactly one forcing period apart
    assert np.allclose(np.diff(tr.impact_times), T, rtol=0, atol=1e-9)


# --------------------------------------------------------------------------- energy
def test_energy_conserved_with_elastic_impacts():
    """R = 1, beta = 0, B = 0: E = (q^2 + q'^2) / 2 is constant through many impacts."""
    sc = sdof(beta=0.0, B=0.0, Delta=0.3, R=1.0)
    state0 = np.array([0.0, 1.0, 0.0])
    tr = _run(sc, 1.3, 0, 200, state0=state0)
    E = 0.5 * (tr.samples[:, 0] ** 2 + tr.samples[:, 1] ** 2)
    assert tr.n_impacts > 150
    assert np.max(np.abs(E - 0.5)) < 1e-12


def test_each_impact_removes_restitution_energy():
    """beta = 0, B = 0: between impacts E is constant; impact i removes (1 - R^2) v_i^2 / 2."""
    R = 0.7
    Delta = 0.2
    sc = sdof(beta=0.0, B=0.0, Delta=Delta, R=R)
    state0 = np.array([0.0, 1.0, 0.0])
    tr = _run(sc, 1.0, 0, 30, state0=state0, ns=256)
    t = np.arange(tr.samples.shape[0]) * (2 * math.pi / 1.0) / 256
    E = 0.5 * (tr.samples[:, 0] ** 2 + tr.samples[:, 1] ** 2)
    dE = 0.5 * (1 - R**2) * tr.impact_velocities**2
    n_before = np.searchsorted(tr.impact_times, t, side="left")
    expected = 0.5 - np.concatenate([[0.0], np.cumsum(dE)])[n_before]
    assert tr.n_impacts >= 5
    assert np.max(np.abs(E - expected)) < 1e-12
    # and the velocities follow the geometric law of a free oscillator,
    # v_{i+1} = R v_i, up to the conditioning of a near-grazing impact: a
    # round-off dg ~ eps |q| in the gap function moves the impact by dg / v
    # and the velocity by Delta dg / v, i.e. a relative error ~ eps (Delta / v)^2
    v = tr.impact_velocities
    rel = np.abs(v[1:] / v[:-1] / R - 1)
    assert np.all(rel < 1e-13 + 32 * np.finfo(float).eps * (Delta / v[1:]) ** 2)


# --------------------------------------------------------------------------- chatter
@pytest.mark.parametrize("R", [0.5, 0.8, 0.9])
def test_chatter_accumulation_time_equals_sum_of_flight_times(R):
    """B = 0, beta = 0, Delta < 0: launched from the stop with speed u0 the k-th
    flight lasts 2 atan(R^k u0 / |Delta|) (closed form of q = Delta cos s - u sin s
    returning to Delta); the sequence accumulates at their sum, then the mass
    sticks for good (the spring presses it on the stop).  The solver jumps to the
    accumulation point once the neglected terms are below chatter_tol, so the
    time agrees to ~1e-9 relative."""
    Delta, u0 = -0.5, 0.3
    sc = sdof(beta=0.0, B=0.0, Delta=Delta, R=R)
    Omega = 1.0
    n_rec = 4
    tr = _run(sc, Omega, 0, n_rec, state0=np.array([Delta, -u0, 0.0]))
    k = np.arange(4000)
    t_acc = np.sum(2 * np.arctan(R**k * u0 / abs(Delta)))
    window = n_rec * 2 * math.pi / Omega
    t_stick = window * (1 - tr.extra["stuck_fraction"])
    assert tr.status == "chatter"
    assert t_stick == pytest.approx(t_acc, rel=1e-9)
    assert np.all(tr.impact_times < t_stick)
    assert tr.final_state[2] == 1.0 and tr.final_state[0] == Delta and tr.final_state[1] == 0.0


def test_sticking_with_zero_restitution_releases_when_force_pulls_away():
    """R = 0: the mass sticks at each impact and leaves when Omega^2 B sin - Delta < 0.

    Release phases satisfy sin(phi) = Delta / F with the force decreasing, i.e.
    phi = pi - asin(Delta / F) (closed form); the q = Delta samples run up to it.
    """
    B, Omega, Delta = 0.2, 1.5, 0.05
    sc = sdof(beta=0.05, B=B, Delta=Delta, R=0.0)
    tr = _run(sc, Omega, 100, 4, ns=512)
    F = Omega**2 * B
    phi_rel = math.pi - math.asin(Delta / F)
    assert tr.status == "sticking"
    phases = 2 * math.pi * np.arange(512) / 512
    q = tr.samples[:512, 0]
    on = q == Delta
    stuck_phases = phases[on]
    assert stuck_phases.size > 0
    # no sample after the release phase (within this period's stuck interval) is on the stop
    assert np.max(stuck_phases[stuck_phases < phi_rel + 1e-12]) <= phi_rel
    assert not np.any(on & (phases > phi_rel) & (phases < phi_rel + 0.5))


def test_prestressed_stop_without_enough_forcing_stays_stuck():
    """Delta < -F: the contact force never changes sign; the run ends stuck, not hanging."""
    Delta = -0.2
    sc = sdof(beta=0.02, B=0.01, Delta=Delta, R=0.8)
    tr = _run(sc, 2.0, 10, 4)
    assert tr.status == "sticking"
    assert np.all(tr.samples[:, 0] == Delta)
    assert tr.extra["stuck_fraction"] == pytest.approx(1.0)


# --------------------------------------------------------------------------- grazing
@pytest.mark.parametrize("delta", [1e-8, 1e-6, 1e-3])
def test_grazing_orbit_is_detected(delta):
    """A linear steady orbit whose peak lies a relative ``delta`` beyond the stop
    must be seen impacting within one period; one whose peak stays ``delta``
    short of it must not."""
    beta, B, Omega = 0.02, 0.01, 1.6
    F = Omega**2 * B
    k, c = 1 - Omega**2, 2 * beta * Omega
    a, b = F * k / (k * k + c * c), -F * c / (k * k + c * c)
    C = math.hypot(a, b)
    state0 = np.array([b, Omega * a, 0.0])  # exactly on the steady orbit at phase 0
    hit = _run(sdof(beta, B, C * (1 - delta), 0.9), Omega, 0, 1, state0=state0)
    miss = _run(sdof(beta, B, C * (1 + delta), 0.9), Omega, 0, 1, state0=state0)
    assert hit.n_impacts >= 1
    assert miss.n_impacts == 0


# --------------------------------------------------------------------------- constraint
@settings(max_examples=25, deadline=None)
@given(beta=st.floats(0.0, 0.3), B=st.floats(1e-4, 0.2), R=st.floats(0.0, 1.0),
       Delta=st.floats(-0.05, 0.05), Omega=st.floats(0.3, 4.5))
def test_no_state_beyond_the_stop(beta, B, R, Delta, Omega):
    """The kernel puts the state back on the stop at the end of a step (``q = min(q, Delta)``),
    so its samples cannot show a crossing it stepped over.  The unclamped gap of every
    event-free step (``contact_gap_max``, transient included) must stay within round-off of
    the stop; independently, the exact flow (matrix exponential of the forced linear system,
    not vibeam's closed form) from every recorded sample over the next sample interval, where
    no impact was recorded, must not cross the stop either and must reach the next sample."""
    if beta < 1e-6 and abs(Omega - 1.0) < 1e-3:
        # (nearly) undamped exact resonance has no steady state; at beta ~ 1e-189 (found by
        # hypothesis) (1 - Omega^2)^2 + (2 beta Omega)^2 underflows to 0 in the particular solution
        Omega = 1.01
    sc = sdof(beta, B, Delta, R)
    ns = 64
    tr = _run(sc, Omega, 30, 4, ns=ns, max_impacts_per_period=2000)
    if tr.status == "failed":
        return  # recorded as data; not a constraint violation
    scale = 1.0 + abs(Delta) + Omega**2 * B
    assert tr.extra["contact_gap_max"] <= 1e-13 * scale
    assert tr.q_max <= Delta + 1e-13 * scale
    T = 2 * math.pi / Omega
    h = T / ns
    F = Omega**2 * B
    sub = np.linspace(0.0, h, 9)
    E = [expm(_augmented(beta, F, Omega) * s) for s in sub]
    t_s = np.arange(tr.samples.shape[0]) * h
    imp = np.asarray(tr.impact_times)
    for j in range(tr.samples.shape[0] - 1):
        q, v = tr.samples[j]
        if q == Delta and v == 0.0:
            continue   # stuck on the stop (the flow would not apply)
        if np.any((imp >= t_s[j] - 1e-12) & (imp <= t_s[j + 1] + 1e-12)) or tr.n_impacts > imp.size:
            continue   # an impact in this interval: the free flow ends there
        ph = Omega * t_s[j]
        y = np.array([E_k @ np.array([q, v, math.sin(ph), math.cos(ph)]) for E_k in E])
        assert np.all(y[:, 0] <= Delta + 1e-10 * scale), f"free flow crosses the stop after sample {j}"
        if tr.samples[j + 1, 0] < Delta:   # the next sample not on the stop (stuck, released)
            assert abs(y[-1, 0] - tr.samples[j + 1, 0]) <= 1e-9 * scale


def test_a_chatter_hold_that_ends_with_the_force_pulling_away_releases_at_once():
    """The release rule after a chatter hold (:mod:`vibeam.models.core.contact_policy`, step 3): the
    kernel jumps to a chatter sequence's accumulation point D = 2 u / (a (1 - R)) and holds the
    mass on the stop without a release check until then.  With a coarse step (2 per period) and
    a loose chatter tolerance (10) the hold is long (2.45 time units here), and the contact force
    turns to pulling the mass off before it ends; the mass must then leave at the hold's end,
    not stay stuck to the force's next zero crossing (as a kernel that keeps its just-stuck flag
    after the hold does).

    Oracle, the closed form of the contact force: held on the stop q = Delta at rest, the
    pressing acceleration of the nondimensional SDOF is a(t) = F sin(Omega t) - Delta
    (F = Omega^2 B, the equation of motion with q = Delta, q' = 0).  Checked on the kernel's
    event log (rows [kind, t, aux, stop, q, q']):

    * the scenario: a stick that ends a chatter (``EV_STICK_IMPACT``, aux its hold D > 0) whose
      hold ends at a(t + D) < -0.1 F (measured -0.12 F);
    * its next event is the release, at t + D to 1e-12 (the hold's end is a step's end: nothing
      is integrated between; measured 1 ulp apart), and the force it logs (aux, the pull) is
      -a(t + D) to 1e-9 (measured equal: the held flow in closed form)."""
    from vibeam.models.core.event import EventIntegrator
    from vibeam.models.core.integrator import EV_RELEASE, EV_STICK_IMPACT

    sc = sdof(beta=0.02, B=0.5, Delta=0.05, R=0.7)
    m = one_mode(sc)
    Om = 0.6
    F = Om * Om * m.B
    core = EventIntegrator(sc)
    r = core.run(Om, [0.0], [0.0], 0, 0, 6, 2, 2, math.pi / Om, 10 ** 5, 10 ** 7, 10.0, log_events=4000)
    log = r.record.evlog[:int(r.record.nlog[0])]
    assert 0 < log.shape[0] < 4000
    kinds = log[:, 0].astype(int)
    holds = [i for i in np.flatnonzero(kinds == EV_STICK_IMPACT) if log[i, 2] > 0.0]
    te = {i: log[i, 1] + log[i, 2] for i in holds}
    pulled = [i for i in holds if F * math.sin(Om * te[i]) - m.Delta < -0.1 * F]
    assert pulled, "no chatter hold ends with the force pulling the mass off"
    for i in pulled:
        a_end = F * math.sin(Om * te[i]) - m.Delta
        assert kinds[i + 1] == EV_RELEASE
        assert log[i + 1, 1] == pytest.approx(te[i], rel=1e-12, abs=0)
        assert log[i + 1, 2] == pytest.approx(-a_end, rel=1e-9, abs=0)

def test_held_at_the_exact_zero_of_a_rising_force_stays_held():
    """The release rule (:func:`vibeam.models.core.contact_policy.release_now`) at a force exactly 0:
    held on the stop Delta = 0 at rest at t = 0, the force needed to hold the mass is
    F sin(Omega t) (F = Omega^2 B; q = q' = 0 leave only the forcing), exactly 0 and rising.
    The mass stays held and leaves when the force falls through zero at Omega t = pi (closed
    form): the event log is the start and that one release, no impact (a rule releasing at
    force <= 0 leaves at t = 0 and chatters back onto the stop)."""
    from vibeam.models.core.event import EventIntegrator
    from vibeam.models.core.integrator import EV_RELEASE, EV_START

    core = EventIntegrator(sdof(beta=0.05, B=0.2, Delta=0.0, R=0.5))
    Om = 1.5
    r = core.run(Om, [0.0], [0.0], 1, 0, 1, 1, 64, 2 * math.pi / 16, 1000, 10000, 1e-7, log_events=32)
    log = r.record.evlog[:r.record.nlog[0]]
    assert [int(k) for k in log[:, 0]] == [EV_START, EV_RELEASE]
    assert log[1, 1] == pytest.approx(math.pi / Om, rel=1e-12, abs=0)
    assert r.n_impacts_total == 0 and r.stuck_time == pytest.approx(math.pi / Om, rel=1e-12)
