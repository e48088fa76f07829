"""Modal vibro-impact beam solvers (the beam builder's scene, its event and direct methods) against closed forms, the
SDOF event solver, a solve_ivp reference and conservation laws (rig of paper Sec. 5-6)."""
import math

import numpy as np
import pytest

from vibeam.models import BeamEventSolver, EventSolver
from vibeam.models.builders.beam_fe import BeamFE, BeamGeometry
from vibeam.models.core.direct import BeamODESolver
from vibeam.models.builders.beam import fe_beam, mass_stops, static_mode_beam
from vibeam.models.builders.sdof import sdof
from vibeam.models.contact import Restitution
from vibeam.models.impact import newton_restitution, restitution_impulse
from vibeam.models.scene import one_mode, outputs
from vibeam.models.system import forcing
from vibeam.engine.records import summarize
from vibeam.reductions.static_mode import reduce_static_mode, static_mode_shape

L, LS, LM = 0.18, 0.10, 0.132
F1 = 7.6
OM1 = 2 * math.pi * F1
D = 2 * 0.017 / OM1
PHIM = float(static_mode_shape(LM / L, LM / L, LS / L))
Y = 5.16e-4 * PHIM * L * 0.6       # gamma~ V = gamma phi(x_m) L V


def _geom(sensor=LS):
    return BeamGeometry(length_m=L, EI_n_m2=0.38465, rhoA_kg_m=0.157, mass_kg=0.2,
                        rotary_inertia_kg_m2=2.103e-5, mass_position_m=LM, sensor_position_m=sensor)


@pytest.fixture(scope="module")
def fe():
    return BeamFE(_geom(), n_elements=24, damping_D_s=D)


def _beam(fe, n, R=0.72, gap=0.0, gap_lower=None):
    """The FE beam truncated to ``n`` modes with Newton stops at the mass (the builder's scene)."""
    return fe_beam(fe, n, mass_stops(gap, Restitution(R), gap_lower), base_amplitude_m=Y)


def apply_impact(etad, w, U_minus, R, m_eff):
    """Newton's impact along ``w``: ``P = restitution_impulse(U-, R, m_eff)``, ``eta' += w P`` in
    place; returns ``U+`` (the body of the former ``apply_impact`` of vibeam.models.beam_dynamics)."""
    P = restitution_impulse(U_minus, R, m_eff)
    etad += w * P
    return newton_restitution(U_minus, R)


def _omega_rad_s(sy):
    """The modal circular frequencies (rad/s) of a scene's system."""
    return sy.omega / sy.time_unit_s


def _linear_sensor_amplitude_m(sc, Omega):
    """Steady-state sensor amplitude without the stop (m), from the modal sum of the scene's system."""
    sy = sc.system
    H = sy.participation * forcing(sy, Omega) / (sy.omega ** 2 - Omega ** 2 + 1j * Omega * sy.damping)
    return float(abs(sy.sensor @ H))


# --------------------------------------------------------------------------- impact law
def test_impact_law_energy_and_restitution():
    """eta' += w P with P = -(1 + R) m_eff U-: U+ = -R U- and the kinetic energy
    (mass-normalised modes: |eta'|^2 / 2) drops by (1 - R^2) m_eff U-^2 / 2."""
    rng = np.random.default_rng(1)
    for _ in range(200):
        N = int(rng.integers(1, 8))
        w = rng.normal(size=N) * 10 ** rng.uniform(-1, 1)
        etad = rng.normal(size=N)
        Um = float(w @ etad)
        if Um < 0:
            etad, Um = -etad, -Um
        R = float(rng.uniform(0, 1))
        meff = 1.0 / float(w @ w)
        E0 = 0.5 * etad @ etad
        after = etad.copy()
        Up = apply_impact(after, w, Um, R, meff)
        assert Up == -R * Um
        assert w @ after == pytest.approx(-R * Um, rel=1e-12, abs=1e-14 * np.abs(w) @ np.abs(etad))
        dE = 0.5 * after @ after - E0
        assert dE == pytest.approx(-0.5 * (1 - R * R) * meff * Um**2, rel=1e-10, abs=1e-14 * E0)
        # only the component along w changes (never just "the contact DOF")
        t = after - etad
        assert np.allclose(t, w * (t @ w) / (w @ w), rtol=0, atol=1e-14 * np.abs(t).max())


# --------------------------------------------------------------------------- linear limit
@pytest.mark.parametrize("f_hz", [5.0, 15.5])
def test_far_from_stop_equals_fe_frequency_response(f_hz):
    """All modes of a coarse mesh, stop out of reach: the sensor amplitude is the FE
    steady state (K - W^2 M + i W C) u = -W^2 Y (-M r), solved with complex numpy.
    The homogeneous part decays as exp(-0.017 omega_1 t) < 1e-12 after 700 periods."""
    fe = BeamFE(_geom(), n_elements=6, damping_D_s=D, rayleigh_alpha_1_s=0.3)
    m = _beam(fe, "all", gap=1.0)
    f_ref = m.system.reference_hz
    tr = BeamEventSolver(m).point(f_hz / f_ref, None, 700, 4, 64)
    W = 2 * math.pi * f_hz
    u = np.linalg.solve(fe.K - W**2 * fe.M + 1j * W * fe.C, fe.base_load * (-W**2 * Y))
    ref = abs(fe.sensor_row @ u)
    assert tr.n_impacts == 0 and tr.status == "ok"
    assert 0.5 * (tr.q_max - tr.q_min) * L == pytest.approx(ref, rel=1e-9)
    assert -tr.q_min * L == pytest.approx(ref, rel=1e-9)
    assert _linear_sensor_amplitude_m(m, f_hz / f_ref) == pytest.approx(ref, rel=1e-10)


# --------------------------------------------------------------------------- vs solve_ivp
@pytest.mark.slow   # solve_ivp at tight tolerance (~12 s); the two-sided and compliant beams are checked against
# solve_ivp in the default step (tests/test_two_sided.py, tests/test_compliant.py)
def test_event_matches_solve_ivp_two_modes(fe):
    """2-mode rig, impacting period-1 orbit at 15.5 Hz.  Both start from the same state,
    so they must agree along the whole transient too.  DOP853 at rtol 1e-9 has a global
    error ~1e-9 relative per impact-free flight and the impacts are located to ~1e-12 by
    the event search, while the event solver is exact to round-off: 1e-6 is a safe bound
    (observed ~1e-10); a missed impact or a wrong law gives O(1) differences."""
    m = _beam(fe, 2, R=0.72, gap=0.0)
    s0 = np.zeros(5)
    s0[0] = -0.5e-3 / m.system.contacts[0][0]
    W = 15.5 / m.system.reference_hz
    a = BeamEventSolver(m).point(W, s0, 60, 8, 32)
    b = BeamODESolver(m, rtol=1e-9, atol=1e-12).point(W, s0, 60, 8, 32)
    assert a.status == b.status == "ok"
    assert a.n_impacts == b.n_impacts == 8
    Delta = outputs(m).Delta
    Qa, Qb = Delta - a.q_min, Delta - b.q_min
    assert Qa == pytest.approx(Qb, rel=1e-6)
    np.testing.assert_allclose(a.impact_times, b.impact_times, rtol=1e-8)
    np.testing.assert_allclose(a.impact_velocities, b.impact_velocities, rtol=1e-6)
    assert np.max(np.abs(a.samples - b.samples)) < 1e-6 * np.max(np.abs(a.samples))
    # the second mode is excited by the impacts
    assert a.extra["mode_amplitudes"][1] > 1e-3 * a.extra["mode_amplitudes"][0]


# --------------------------------------------------------------------------- vs SDOF
@pytest.mark.parametrize("R, gap", [(0.72, 0.0), (0.0, 0.0)])
def test_static_mode_model_reproduces_sdof_event(R, gap):
    """One assumed shape = static mode (beam mass excluded): identical to the SDOF with
    beta = D omega_n / 2, B = gamma V, Delta = Delta_G / L.  R = 0 exercises sticking on
    the stop and release at the sign change of the contact force (root-found here,
    closed form in the SDOF kernel)."""
    g = _geom()
    sm = static_mode_beam(g, mass_stops(gap, Restitution(R)), base_amplitude_m=Y, damping_D_s=D)
    red = reduce_static_mode(g, damping_D_s=D, gap_contact_m=gap, gamma_tilde_m_per_V=Y)
    sd = sdof(beta=red.beta_S, B=red.gamma_per_V, Delta=red.Delta, R=R)
    o = outputs(sm)
    assert o.Delta == pytest.approx(one_mode(sd).Delta, abs=1e-15)
    assert o.m_eff == pytest.approx(g.mass_kg, rel=1e-13)
    for f in (14.0, 15.3, 16.1, 17.0):
        W = f / sm.system.reference_hz
        a = BeamEventSolver(sm).point(W, None, 300, 16, 64)
        b = EventSolver(sd).point(W, None, 300, 16, 64)
        assert a.status == b.status
        assert a.n_impacts == b.n_impacts
        Qa, Qb = summarize(a, o.Delta)["amplitude"], summarize(b, one_mode(sd).Delta)["amplitude"]
        assert Qa == pytest.approx(Qb, rel=1e-9)
        assert np.max(np.abs(a.samples - b.samples)) < 1e-9 * np.max(np.abs(b.samples))
        assert a.extra["stuck_fraction"] == pytest.approx(b.extra["stuck_fraction"], abs=1e-9)


@pytest.mark.parametrize("f_hz", [15.0, 16.75])
def test_one_mode_beam_chatters_like_the_sdof(f_hz):
    """One chatter policy (vibeam.models.core.contact_policy) for both kernels: the tight rig's
    static-mode beam (pre-stressed stop, R = 0.8; kernel time unit 1 / (2 pi 7.6 Hz), not the
    SDOF's 1 / omega_n: the estimate must not depend on it) and the SDOF of its derived
    parameters resolve the same impacts and jump to the same accumulation points.  From rest,
    16 periods with 1-2 chatter sequences and 119-196 impacts: equal counts, impact and
    accumulation phases to 1e-9 rad (measured <= 4e-10: the two closed forms round
    differently, and the sequences amplify it), stuck fractions to 1e-9.  Before the shared
    policy the beam's estimate lacked the forcing term of the jerk and counted the damping
    twice: 172 against 196 impacts at 15 Hz."""
    from vibeam.case.beamscene import derive
    from vibeam.case.schema import load_case
    from pathlib import Path

    case, _ = load_case(Path(__file__).resolve().parents[1] / "cases" / "rig-fe-tight.toml")
    spec = case.model_spec({"n_modes": "static"})
    beam = spec.scene()
    red = derive(spec)["reduction"]
    sd = sdof(beta=red.beta_S, B=red.gamma_per_V * spec.excitation.voltage, Delta=red.Delta, R=spec.stop[0].R)
    f_ref = beam.system.reference_hz
    assert abs(f_ref / red.f_n_hz - 1) > 0.04    # different time units
    Wb, Ws = f_hz / f_ref, f_hz / red.f_n_hz
    a = BeamEventSolver(beam).point(Wb, None, 0, 16, 64)
    b = EventSolver(sd).point(Ws, None, 0, 16, 64)
    assert a.status == b.status == "chatter"
    assert a.n_impacts == b.n_impacts > 100
    assert a.chatter_times.size == b.chatter_times.size >= 1
    np.testing.assert_allclose(Wb * a.chatter_times, Ws * b.chatter_times, rtol=0, atol=1e-9)
    np.testing.assert_allclose(Wb * a.impact_times, Ws * b.impact_times, rtol=0, atol=1e-9)
    assert a.extra["stuck_fraction"] == pytest.approx(b.extra["stuck_fraction"], abs=1e-9)


def test_chatter_policy_is_invariant_under_the_time_unit():
    """The policy's decision and accumulation time scale with the time unit: D, 1/c_eff and
    1/sqrt(k_eff) are times, jerk/a a rate."""
    from vibeam.models.core.contact_policy import chatter_jump

    u, a, j, c, k, R, tol = 1e-8, 0.3, 0.02, 0.03, 1.0, 0.8, 1e-7   # err = 3e-8
    D = chatter_jump(u, a, j, c, k, R, tol, 1.0)
    assert D == pytest.approx(2 * u / (a * (1 - R)), rel=1e-15)
    for s in (0.5, 1.047, 3.0):   # new time unit = old / s: rates x s, times / s
        Ds = chatter_jump(u * s, a * s * s, j * s**3, c * s, k * s * s, R, tol, 1.0 / s)
        assert Ds == pytest.approx(D / s, rel=1e-14)
    # not accurate enough: resolve the next impact; beyond the step: resolve it too
    assert chatter_jump(1e-3, a, j, c, k, R, tol, 1.0) == -1.0
    assert chatter_jump(u, a, j, c, k, R, tol, 0.5 * D) == -1.0
    assert chatter_jump(u, -a, j, c, k, R, tol, 1.0) == -1.0 and chatter_jump(u, a, j, c, k, 1.0, tol, 1.0) == -1.0


# --------------------------------------------------------------------------- unilateral
def _augmented_matrix(m, Om):
    """Generator of the free modal flow of (eta, eta', sin, cos) of the scene ``m``, for scipy's
    expm (independent of the solver's closed form)."""
    sy = m.system
    N = sy.omega.size
    k, c = sy.omega ** 2, sy.damping
    GF = sy.participation * Om**2 * sy.base_amplitude
    A = np.zeros((2 * N + 2, 2 * N + 2))
    A[:N, N:2 * N] = np.eye(N)
    A[N:2 * N, :N] = -np.diag(k)
    A[N:2 * N, N:2 * N] = -np.diag(c)
    A[N:2 * N, 2 * N] = GF
    A[2 * N, 2 * N + 1] = Om
    A[2 * N + 1, 2 * N] = -Om
    return A


def test_contact_never_beyond_stop():
    """Near-grazing and impacting random scenes (1-3 modes; grazing is where a detector
    that under-bounds the derivatives misses impacts): between consecutive recorded
    states without an impact the exact free flow (matrix exponential, 32 sub-points)
    never takes the contact beyond the stop by more than round-off, and no sample does."""
    from scipy.linalg import expm
    fe = BeamFE(_geom(), n_elements=12, damping_D_s=D)
    rng = np.random.default_rng(7)
    ns, n_sub = 64, 32
    checked = 0
    for trial in range(8):
        n = int(rng.choice([1, 2, 3]))
        R = float(rng.uniform(0.3, 0.9))
        Om = float(rng.uniform(1.6, 2.4))
        s0 = _beam(fe, n, R=R, gap=1.0).system
        om_ref, om = 2 * math.pi * s0.reference_hz, _omega_rad_s(s0)
        H = s0.participation * (Om * om_ref) ** 2 * Y / (
            om**2 - (Om * om_ref) ** 2 + 1j * Om * om_ref * D * om**2)
        amp = abs(s0.contacts[0] @ H)
        gap = amp * (1 - 10 ** rng.uniform(-7, -2)) if trial % 2 == 0 else amp * rng.uniform(0.0, 0.8)
        m = _beam(fe, n, R=R, gap=gap)
        w = m.system.contacts[0]
        tr = BeamEventSolver(m, record_modal_states=True).point(Om, None, 150, 8, ns)
        assert tr.status in ("ok", "chatter", "sticking")
        X = tr.extra["modal_states"]
        U = X[:, :n] @ w
        tol = 1e-12 * (abs(gap) + np.max(np.abs(U)))
        assert np.all(U <= gap + tol)
        assert tr.extra["contact_gap_max"] * L <= tol
        if tr.extra["stuck_fraction"] > 0:
            continue
        A = _augmented_matrix(m, Om)
        E = expm(A * (2 * np.pi / Om / ns / n_sub))
        hT = 2 * np.pi / Om / ns
        for j in range(X.shape[0] - 1):
            t0 = j * hT
            if np.any((tr.impact_times >= t0) & (tr.impact_times <= t0 + hT)):
                continue
            ph = 2 * np.pi * j / ns
            z = np.concatenate([X[j], [math.sin(ph), math.cos(ph)]])
            for _ in range(n_sub):
                z = E @ z
                assert w @ z[:n] <= gap + tol, (trial, j)
            checked += 1
    assert checked > 1000


@pytest.mark.parametrize("n", [1, 2])
def test_grazing_impacts_are_not_missed(n):
    """Stop just inside the linear orbit (gap = (1 - eps) x linear contact amplitude,
    eps = 1e-7, 1e-6): a steady state without impacts would be the linear one, which
    crosses the stop, so every recorded window must contain impacts.  The excursion
    beyond the stop lasts ~1e-3 time units, far below a grid step (~5e-2): only the
    certified derivative bounds find it (dropping the forced part from the bounds misses
    these impacts)."""
    fe = BeamFE(_geom(), n_elements=12, damping_D_s=D)
    s0 = _beam(fe, n, R=0.7, gap=1.0).system
    om_ref, om = 2 * math.pi * s0.reference_hz, _omega_rad_s(s0)
    for eps in (1e-7, 1e-6):
        for Om in (1.7, 2.0, 2.3):
            W = Om * om_ref
            H = s0.participation * W**2 * Y / (om**2 - W**2 + 1j * W * D * om**2)
            gap = abs(s0.contacts[0] @ H) * (1 - eps)
            m = _beam(fe, n, R=0.7, gap=gap)
            tr = BeamEventSolver(m).point(Om, None, 400, 8, 64)
            assert tr.status != "failed"
            assert tr.n_impacts > 0, (eps, Om)
            assert tr.extra["contact_gap_max"] * L <= 1e-12 * gap


# --------------------------------------------------------------------------- sticking
@pytest.mark.parametrize("f_hz, expected", [(15.5, "chatter"), (8.0, "sticking")])
def test_prestressed_stop_sticks_or_chatters(fe, f_hz, expected):
    """Pre-stressed stop (Delta_C = -0.2 mm): chatter ending in sticking at 15.5 Hz,
    permanent sticking at 8 Hz (the constrained beam is held, its contact force never
    changes sign); runs to completion, never beyond the stop."""
    m = _beam(fe, 2, R=0.5, gap=-0.2e-3)
    sy = m.system
    tr = BeamEventSolver(m).point(f_hz / sy.reference_hz, None, 150, 16, 32)
    assert tr.status == expected
    assert tr.extra["stuck_fraction"] > 0
    assert np.all(np.isfinite(tr.samples))
    assert tr.extra["contact_gap_max"] <= 1e-15
    N = outputs(m).n_modes
    eta = tr.final_state[:N]
    gap = m.stops[0].relation.offset
    assert sy.contacts[0] @ eta <= gap + 1e-15
    if expected == "sticking":
        # held for the whole window: the contact stays exactly on the stop
        assert tr.extra["stuck_fraction"] == pytest.approx(1.0, abs=1e-9)
        assert tr.final_state[-1] == 1.0
        assert sy.contacts[0] @ eta == pytest.approx(gap, rel=1e-12)


@pytest.mark.parametrize("gaps", [(-0.2e-3, None), (0.3e-3, -0.1e-3), (0.3e-3, 0.2e-3)])
def test_the_scenes_rest_state_is_the_static_equilibrium_held_on_a_prestressed_stop(fe, gaps):
    """The event solver's default start (:func:`vibeam.models.scene.rest_state`, from the scene
    alone) is the state held statically on a pre-stressed stop at the mass: the contact exactly on
    its stop (``s w^T eta = Delta``) and ``K eta`` along ``w`` (a contact force only: the KKT
    system [K, w; w^T, 0] solved here), zero velocities; rest at the origin when no stop is
    pre-stressed.  The SDOF's scene gives ``q = Delta`` (paper Eq. 2 at rest on the stop)."""
    from vibeam.models.scene import rest_state

    up, lo = gaps
    m = _beam(fe, 3, R=0.5, gap=up, gap_lower=lo)
    x = rest_state(m)
    N = outputs(m).n_modes
    assert x.shape == (2 * N + 1,) and not np.any(x[N:])
    if up > 0 and (lo is None or lo > 0):
        assert not np.any(x)
        return
    sign, D = (1.0, up) if up < 0 else (-1.0, lo)
    w, k = m.system.contacts[0], m.system.omega ** 2
    S = np.zeros((N + 1, N + 1))
    S[:N, :N] = np.diag(k)
    S[:N, N] = S[N, :N] = sign * w
    ref = np.linalg.solve(S, np.concatenate([np.zeros(N), [D]]))[:N]
    np.testing.assert_allclose(x[:N], ref, rtol=1e-12, atol=1e-15 * abs(D))
    assert sign * (w @ x[:N]) == pytest.approx(D, rel=1e-13)
    # the event solver's own start (from None), the same state: the same run bit for bit
    ev = BeamEventSolver(m)
    a, b = ev.point(1.0, None, 0, 1, 8), ev.point(1.0, x, 0, 1, 8)
    np.testing.assert_array_equal(a.samples, b.samples)
    np.testing.assert_array_equal(a.final_state, b.final_state)
    assert rest_state(sdof(beta=0.02, B=0.01, Delta=-0.2, R=0.8))[0] == -0.2


def test_held_beam_is_the_constrained_linear_response(fe):
    """Permanently held on a pre-stressed stop (3 modes, 8 Hz): the steady state is the
    linear response of the constrained system, computed here independently from the
    KKT systems [K - W^2 I + i W C, w; w^T, 0] (harmonic) and [K, w; w^T, 0] (static,
    w^T eta = Delta_C) in modal coordinates.  The contact force from the multiplier
    stays on the pressing side (lambda <= 0) over the period."""
    m = _beam(fe, 3, R=0.5, gap=-0.2e-3)
    sy = m.system
    Om = 8.0 / sy.reference_hz
    tr = BeamEventSolver(m).point(Om, None, 400, 2, 32)
    assert tr.status == "sticking" and tr.extra["stuck_fraction"] == pytest.approx(1.0)
    N = outputs(m).n_modes
    w, k, c = sy.contacts[0], sy.omega ** 2, sy.damping
    Z = np.zeros((N + 1, N + 1), complex)
    Z[:N, :N] = np.diag(k - Om**2 + 1j * Om * c)
    Z[:N, N] = w
    Z[N, :N] = w
    xh = np.linalg.solve(Z, np.concatenate([sy.participation * Om**2 * Y, [0.0]]))
    S = np.zeros((N + 1, N + 1))
    S[:N, :N] = np.diag(k)
    S[:N, N] = w
    S[N, :N] = w
    x0 = np.linalg.solve(S, np.concatenate([np.zeros(N), [m.stops[0].relation.offset]]))
    ph = 2 * np.pi * np.arange(tr.samples.shape[0]) / tr.samples_per_period
    eta = x0[:N, None] + np.imag(xh[:N, None] * np.exp(1j * ph))
    q = sy.sensor @ eta / L
    scale = np.max(np.abs(q))
    np.testing.assert_allclose(tr.samples[:, 0], q, rtol=0, atol=1e-9 * scale)
    # KKT multiplier = -(contact force pushing the beam away): the stop pushes (>= 0)
    push = x0[N] + np.imag(xh[N] * np.exp(1j * ph))
    assert np.all(push > 0)


@pytest.mark.parametrize("gap", [0.0, -0.05e-3])
def test_sticking_and_release_match_solve_ivp(fe, gap):
    """R = 0 (every impact plastic, then held until the contact force changes sign), 2
    modes, 10 Hz: the event solver's closed-form constrained flow and root-found release
    against solve_ivp integrating the same constrained system with a terminal event on
    the contact force (observed agreement ~1e-8; a wrong constrained basis, damping or
    force formula gives O(1e-2..1) differences)."""
    m = _beam(fe, 2, R=0.0, gap=gap)
    W = 10.0 / m.system.reference_hz
    a = BeamEventSolver(m).point(W, None, 40, 4, 32)
    b = BeamODESolver(m).point(W, None, 40, 4, 32)
    assert a.status == b.status == "sticking"
    assert a.n_impacts == b.n_impacts == 4
    assert 0.05 < a.extra["stuck_fraction"] < 0.95
    assert a.extra["stuck_fraction"] == pytest.approx(b.extra["stuck_fraction"], rel=1e-6)
    assert np.max(np.abs(a.samples - b.samples)) < 1e-6 * np.max(np.abs(a.samples))
    np.testing.assert_allclose(a.impact_times, b.impact_times, rtol=1e-7)


def test_many_mode_chatter_does_not_stall():
    """Pre-stressed rig, all modes, 17 Hz: with many modes the geometric chatter
    estimate never reaches its tolerance (the high modes make the contact
    acceleration rough on the scale of the flights) and impacts used to pile up
    by the hundred thousand; the kernel's Zeno guard ends such a burst as a
    plastic impact.  Two successive points (the continuation that stalled) must
    finish, without failing, in few steps per period."""
    from pathlib import Path

    from vibeam.case.schema import load_case
    from vibeam.models import make_solver

    case, _ = load_case(Path(__file__).parent.parent / "cases" / "rig-fe-tight.toml")
    m = case.model_spec({"n_modes": "all"}).scene()
    W = 17.0 / m.system.reference_hz
    s = make_solver(m, "event", max_steps_per_period=3000)
    tr = s.point(W, None, 250, 1, 64)
    assert tr.status != "failed", tr.message
    tr = s.point(W, tr.final_state, 250, 1, 64)
    assert tr.status != "failed", tr.message
    assert tr.extra["steps_per_period"] < 1000
