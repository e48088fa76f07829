"""The one linear dynamical system (vibeam.models.system, issue 20): the SDOF and the FE beam as
its one- and N-mode cases, a lumped (M, C, K) model through the same constructor, and its
closed-form flow and state-transition matrix against independent references (the SDOF's own
closed form, DOP853, the beam's event kernel, central differences, Liouville's formula)."""
import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from vibeam.models import system as msys
from vibeam.models.builders.beam_fe import BeamFE, BeamGeometry
from vibeam.models import BeamEventSolver
from vibeam.models.builders.beam import fe_beam, mass_stops, static_mode_beam
from vibeam.models.builders.matrices import build_matrices, modal_scene, structure_scene
from vibeam.models.builders.sdof import sdof, sdof_physical
from vibeam.models.contact import Relation, Restitution, Stop
from vibeam.models.core.oscillator import particular_coefficients, propagate
from vibeam.reductions.static_mode import reduce_static_mode, static_mode_shape
from vibeam.models.system import ModalSystem, modal_flow, modal_transition

# the rig of tests/test_beam_dynamics.py: 7.6 Hz, beta = 0.017 on the first mode
L, LS, LM = 0.180, 0.100, 0.132
OM1 = 2 * math.pi * 7.6
D = 2 * 0.017 / OM1
PHIM = float(static_mode_shape(LM / L, LM / L, LS / L))
Y = 5.16e-4 * PHIM * L * 0.6


def _geom():
    return BeamGeometry(length_m=L, EI_n_m2=0.38465, rhoA_kg_m=0.157, mass_kg=0.2,
                        rotary_inertia_kg_m2=2.103e-5, mass_position_m=LM, sensor_position_m=LS)


def _three_modes(B=0.3):
    """Under-, critically and over-damped modes (the three branches of the closed form)."""
    om = np.array([1.0, 2.7, 9.0])
    return msys.modal_system(om, [0.04, 2 * 2.7, 30.0], [1.0, -0.6, 0.25], [1.0, 0.5, -0.2],
                        [[1.0, 0.8, 0.3], [0.2, -1.0, 0.5]], B)


def _rhs(system, Omega):
    """The modal equations as a first-order field for solve_ivp (state (eta, eta'))."""
    n = system.omega.size
    k = system.omega ** 2
    F = Omega ** 2 * system.base_amplitude * system.participation

    def f(t, y):
        return np.concatenate([y[n:], F * math.sin(Omega * t) - system.damping * y[n:] - k * y[:n]])
    return f


# --------------------------------------------------------------------------- one mode: SDOF = beam
def test_one_mode_beam_system_equals_the_sdof_system_flow():
    """The paper's static-mode beam (Eqs. 42-46) and the SDOF of its derived parameters (beta =
    D omega_n / 2, B = gamma V, f_n, L) are one system: equal scales, and equal flows of the
    reported q = s eta / coordinate_scale from one state, forced at Omega = 1.1 for up to 12 time
    units.  The two systems' numbers differ in their last bits (omega = omega_n / (2 pi f_n),
    c = D omega_n^2 / omega_ref against 2 beta), which the flow carries over O(10) time units:
    1e-13 of the amplitude (measured ~1e-15)."""
    g = _geom()
    sm = static_mode_beam(g, mass_stops(0.0, Restitution(0.8)), base_amplitude_m=Y, damping_D_s=D)
    red = reduce_static_mode(g, damping_D_s=D, gap_contact_m=0.0, gamma_tilde_m_per_V=Y)
    sd = sdof(beta=red.beta_S, B=red.gamma_per_V, Delta=red.Delta, R=0.8, natural_frequency_hz=red.f_n_hz,
              length_m=L)
    a, b = sm.system, sd.system
    assert a.omega.shape == a.damping.shape == a.sensor.shape == (1,) and a.contacts.shape == (1, 1)
    assert a.omega[0] == pytest.approx(1.0, rel=1e-15) and b.omega[0] == 1.0
    assert a.damping[0] == pytest.approx(b.damping[0], rel=1e-14)
    assert a.time_unit_s == pytest.approx(b.time_unit_s, rel=1e-15)
    assert a.length_unit_m == b.length_unit_m == L
    assert (b.coordinate_scale, a.coordinate_scale) == (1.0, L)
    # the forcing in q units: Gamma B s / coordinate_scale
    fa = a.participation[0] * a.base_amplitude * a.sensor[0] / a.coordinate_scale
    assert fa == pytest.approx(b.base_amplitude, rel=1e-14)
    q0, v0, Om = -0.0123, 0.0321, 1.1
    to_eta = a.coordinate_scale / a.sensor[0]
    scale = 0.0
    errs = []
    for t1 in (0.01, 0.7, 3.0, 12.0):
        ea, eda = modal_flow(a, 0.4, 0.4 + t1, [q0 * to_eta], [v0 * to_eta], Om)
        qb, vb = modal_flow(b, 0.4, 0.4 + t1, [q0], [v0], Om)
        qa, va = ea[0] / to_eta, eda[0] / to_eta
        scale = max(scale, abs(qb[0]), abs(vb[0]))
        errs += [abs(qa - qb[0]), abs(va - vb[0])]
    assert max(errs) < 1e-13 * scale


def test_sdof_system_flow_equals_the_sdof_closed_form():
    """The SDOF scene's system flow against the SDOF's own closed form (vibeam.models.core.oscillator.propagate,
    its own particular solution and transition): two implementations of Eq. 28, 1e-14 of the
    state (measured a few ulps)."""
    beta, B, Om = 0.05, 0.02, 0.8
    s = sdof(beta=beta, B=B, Delta=0.0, R=0.8).system
    assert np.isnan(s.time_unit_s) and np.isnan(s.length_unit_m) and np.isnan(s.mass_unit_kg)
    a, b = particular_coefficients(beta, Om * Om * B, Om)
    for t0, t1 in ((0.0, 0.3), (1.7, 6.2), (-2.0, 9.5)):
        g, v, *_ = propagate(t1 - t0, Om * t0, 0.01, -0.02, beta, a, b, Om, 0.0)
        q1, v1 = modal_flow(s, t0, t1, [0.01], [-0.02], Om)
        assert abs(q1[0] - g) < 1e-14 * 0.05 and abs(v1[0] - v) < 1e-14 * 0.05


def test_flow_is_the_beam_event_kernel_flow():
    """The beam builder's units are the event kernel's: a 2-mode FE beam whose stop is out of reach, run
    by BeamEventSolver for one forcing period from a given modal state, samples q = s eta / L
    and q' at t = k T / 16; modal_flow from the same state gives them to 1e-12 of the amplitude
    (the kernel adds round-off over its grid steps; a wrong time unit, forcing or scale is O(1))."""
    fe = BeamFE(_geom(), n_elements=8, damping_D_s=D, rayleigh_alpha_1_s=0.3)
    m = fe_beam(fe, 2, mass_stops(1.0, Restitution(0.72)), base_amplitude_m=Y)
    s = m.system
    W = 15.5 / s.reference_hz
    eta0 = np.array([2e-4, -3e-6]) / np.abs(s.sensor)
    etad0 = np.array([-1e-4, 5e-6]) / np.abs(s.sensor)
    tr = BeamEventSolver(m).point(W, np.concatenate([eta0, etad0, [0.0]]), 0, 1, 16)
    assert tr.n_impacts == 0 and tr.status == "ok"
    T = 2 * math.pi / W
    got = []
    for k in range(16):
        e, ed = modal_flow(s, 0.0, k * T / 16, eta0, etad0, W)
        got.append([s.sensor @ e / s.coordinate_scale, s.sensor @ ed / s.coordinate_scale])
    got = np.array(got)
    assert np.max(np.abs(got - tr.samples)) < 1e-12 * np.max(np.abs(tr.samples))
    e, ed = modal_flow(s, 0.0, T, eta0, etad0, W)
    np.testing.assert_allclose(np.concatenate([e, ed]), tr.final_state[:4], rtol=0,
                               atol=1e-12 * np.max(np.abs(tr.final_state)))


# --------------------------------------------------------------------------- the flow
@pytest.mark.parametrize("t0, t1", [(0.0, 0.05), (0.3, 4.0), (2.0, 9.0)])
def test_modal_flow_against_dop853(t0, t1):
    """Under-, critically and over-damped modes, forced at Omega = 1.3: the closed form against
    DOP853 at rtol 1e-12 (atol 1e-14 of a state of order 1; global error ~1e-12 per unit time):
    1e-10 of the state's size."""
    s = _three_modes()
    eta0, etad0, Om = np.array([0.4, -0.2, 0.1]), np.array([-0.3, 0.5, 1.0]), 1.3
    e, ed = modal_flow(s, t0, t1, eta0, etad0, Om)
    sol = solve_ivp(_rhs(s, Om), (t0, t1), np.concatenate([eta0, etad0]), method="DOP853",
                    rtol=1e-12, atol=1e-14)
    assert sol.success
    ref = sol.y[:, -1]
    assert np.max(np.abs(np.concatenate([e, ed]) - ref)) <= 1e-10 * max(1.0, np.max(np.abs(ref)))


def test_modal_flow_group_property_identity_and_backward_flight():
    """Flight 0 -> 1.3 -> 5 equals 0 -> 5, a zero flight returns the state bit for bit, and the
    backward flight returns the start (the closed form holds for either sign of t1 - t0): 1e-13
    of the state (round-off of two closed forms, growth exp(sig t) <= e^2 over the damped modes'
    short backward time)."""
    s = _three_modes()
    x0, v0, Om = np.array([0.4, -0.2, 0.1]), np.array([-0.3, 0.5, 1.0]), 1.3
    a = modal_flow(s, 0.0, 5.0, x0, v0, Om)
    b = modal_flow(s, 1.3, 5.0, *modal_flow(s, 0.0, 1.3, x0, v0, Om), Om)
    assert np.max(np.abs(np.concatenate(a) - np.concatenate(b))) < 1e-13
    e, ed = modal_flow(s, 2.0, 2.0, x0, v0, Om)
    assert np.array_equal(e, x0) and np.array_equal(ed, v0)
    back = modal_flow(s, 0.06, 0.0, *modal_flow(s, 0.0, 0.06, x0, v0, Om), Om)
    assert np.max(np.abs(np.concatenate(back) - np.concatenate([x0, v0]))) < 1e-13


def test_modal_transition_against_central_differences():
    """The STM against central differences of the forced flow along each state coordinate.  The
    flow is affine in the state, so the difference has no truncation error, only round-off
    ~eps |x| / h = 2e-12 for h = 1e-4: 1e-10 of the STM's largest entry; a transposed block or a
    wrong sign is O(1)."""
    s = _three_modes()
    x0 = np.array([0.4, -0.2, 0.1, -0.3, 0.5, 1.0])
    for t0, t1 in ((0.2, 0.9), (1.0, 6.0)):
        P = modal_transition(s, t0, t1)
        h = 1e-4
        fd = np.empty((6, 6))
        for j in range(6):
            d = np.zeros(6)
            d[j] = h
            up = np.concatenate(modal_flow(s, t0, t1, (x0 + d)[:3], (x0 + d)[3:], 1.3))
            dn = np.concatenate(modal_flow(s, t0, t1, (x0 - d)[:3], (x0 - d)[3:], 1.3))
            fd[:, j] = (up - dn) / (2 * h)
        assert np.max(np.abs(P - fd)) < 1e-10 * np.max(np.abs(P))
        assert P[0, 1] == P[0, 4] == 0.0    # modes stay uncoupled


@pytest.mark.parametrize("s_time", [0.3, 2.0, 7.0])
def test_liouville_determinant_of_the_transition_matrix(s_time):
    """det STM(t) = exp(trace(A) t) = exp(-sum_i c_i t) (Liouville; the state matrix of mode i is
    [[0, 1], [-omega_i^2, -c_i]]).  Underdamped modes (c = 0.04, 0.5, 1.2): the whole 6 x 6
    determinant to 1e-12 relative (a few roundings per entry, no cancellation: the entries are of
    the size of the determinant's factors).  Each mode's block also of the critically and
    overdamped modes and of the rig's 2-mode beam (its second mode overdamped): there t11 t22 and
    t12 t21 both decay as e^{2 l1 t} while their difference is e^{-c t}, so the block determinant
    is checked within its floating-point bound 8 eps (|t11 t22| + |t12 t21|) + 4 eps e^{-c t}."""
    s = msys.modal_system([1.0, 2.7, 9.0], [0.04, 0.5, 1.2], [1.0, 1.0, 1.0], [1.0, 0.0, 0.0],
                          [[1.0, 1.0, 1.0]], 0.1)
    P = modal_transition(s, 1.0, 1.0 + s_time)
    sign, logdet = np.linalg.slogdet(P)
    assert sign == 1.0
    assert logdet == pytest.approx(-np.sum(s.damping) * s_time, rel=1e-12)
    fe = BeamFE(_geom(), n_elements=8, damping_D_s=D)
    eps = np.finfo(float).eps
    for s in (_three_modes(), fe_beam(fe, 2, mass_stops(0.0, Restitution(0.72)), base_amplitude_m=Y).system):
        P = modal_transition(s, 1.0, 1.0 + s_time)
        n = s.omega.size
        for i in range(n):
            t11, t12, t21, t22 = P[i, i], P[i, n + i], P[n + i, i], P[n + i, n + i]
            exact = math.exp(-s.damping[i] * s_time)
            bound = 8 * eps * (abs(t11 * t22) + abs(t12 * t21)) + 4 * eps * exact
            assert abs(t11 * t22 - t12 * t21 - exact) <= bound, (i, s.damping[i])


# --------------------------------------------------------------------------- constructors
def test_from_beam_frequencies_and_rows_are_the_fe_models():
    """The beam builder's scene of a 4-mode FE beam (fe_beam): omega / time_unit_s are the BeamFE's
    circular frequencies (2 roundings: 1e-15) and the lowest eigenvalues of the full (K, M) by
    scipy's eigh (the direct problem is accurate to eps lam_max / lam_1 ~ 1e-12 here: 1e-9); damping
    c_i = D omega_i^2 / omega_ref, the FE participation and the modal truncation's rows, and the
    force scale (m_eff omega_ref^2 L, the scene's outputs and the closed form) from the system's
    scales; the kernel's numbers are (omega_i / omega_ref)^2 and (alpha + D omega_i^2) / omega_ref
    bit for bit."""
    import scipy.linalg

    from vibeam.models.scene import outputs
    from vibeam.reductions.modal import modal_reduction

    fe = BeamFE(_geom(), n_elements=10, damping_D_s=D)
    m = fe_beam(fe, 4, mass_stops(0.0, Restitution(0.72)), base_amplitude_m=Y)
    s = m.system
    red = modal_reduction(fe, 4)
    md = fe.modes(4)
    np.testing.assert_allclose(s.omega / s.time_unit_s, md.omega_rad_s, rtol=1e-15)
    lam = scipy.linalg.eigh(fe.K, fe.M, eigvals_only=True)[:4]
    np.testing.assert_allclose((s.omega / s.time_unit_s) ** 2, lam, rtol=1e-9)
    np.testing.assert_allclose(s.damping, D * md.omega_rad_s ** 2 * s.time_unit_s, rtol=1e-14)
    np.testing.assert_allclose(s.participation, md.participation, rtol=1e-15)
    np.testing.assert_array_equal(s.contacts[0], red.contact_row)
    np.testing.assert_array_equal(s.sensor, red.sensor_row)
    assert s.omega.flags.c_contiguous and s.contacts.flags.c_contiguous
    m_eff = 1.0 / np.sum(s.contacts[0] ** 2)
    force = m_eff * s.mass_unit_kg * s.length_unit_m / s.time_unit_s ** 2
    assert force == pytest.approx(outputs(m).force_scale_n, rel=1e-14)
    om_ref = 2 * math.pi * float(md.frequencies_hz[0])
    assert force == pytest.approx(float(1.0 / np.sum(red.contact_row ** 2)) * om_ref ** 2 * L, rel=1e-14)
    om = red.omega_rad_s       # the kernel's numbers
    assert np.array_equal(s.omega ** 2, (om / om_ref) ** 2)
    assert np.array_equal(s.damping, (fe.rayleigh_alpha_1_s + fe.damping_D_s * om ** 2) / om_ref)


def _two_dof():
    M = np.diag([2.0, 0.5])
    K = np.array([[3000.0, -1000.0], [-1000.0, 1000.0]])
    return M, 0.3 * M + 2e-4 * K, K


def test_lumped_two_dof_against_a_direct_solve_ivp():
    """A 2-DOF base-excited chain (SI) M x'' + C x' + K x = -M r b'', b = B sin(W t), Rayleigh C:
    build_matrices with contact rows = the identity (so W eta = x) against DOP853 on the physical
    equations at rtol 1e-12 over 0.8 s (~6 periods of the first mode): 1e-9 of the state."""
    M, C, K = _two_dof()
    B, W = 1e-3, 2 * math.pi * 5.0
    s = build_matrices(M, K, C=C, contacts=list(np.eye(2)), sensor=[0.0, 1.0], base_amplitude_m=B).system
    assert s.omega[0] == 1.0 and s.omega[1] > 1.0 and s.coordinate_scale == 1.0
    tu = s.time_unit_s
    x0, v0 = np.array([1e-3, -2e-3]), np.array([0.01, 0.02])
    eta0 = np.linalg.solve(s.contacts, x0)
    etad0 = np.linalg.solve(s.contacts, v0 * tu)
    T1 = 0.8
    e, ed = modal_flow(s, 0.0, T1 / tu, eta0, etad0, W * tu)
    x1, v1 = s.contacts @ e, s.contacts @ ed / tu
    assert s.sensor @ e == pytest.approx(x1[1], rel=1e-14)
    Minv = np.linalg.inv(M)
    r = np.ones(2)

    def f(t, y):
        a_base = -W * W * B * math.sin(W * t)
        return np.concatenate([y[2:], Minv @ (-C @ y[2:] - K @ y[:2]) - r * a_base])
    sol = solve_ivp(f, (0.0, T1), np.concatenate([x0, v0]), method="DOP853", rtol=1e-12, atol=1e-16)
    assert sol.success
    ref = sol.y[:, -1]
    assert np.max(np.abs(x1 - ref[:2])) < 1e-9 * np.max(np.abs(ref[:2]))
    assert np.max(np.abs(v1 - ref[2:])) < 1e-9 * np.max(np.abs(ref[2:]))


def test_build_matrices_refuses_non_proportional_damping_and_bad_matrices():
    """A dashpot on one DOF only is not diagonalised by the undamped modes: one line naming what
    is allowed.  An indefinite K (a rigid-body mode) and mismatched shapes are refused too."""
    M, C, K = _two_dof()
    with pytest.raises(ValueError, match=r"C is not diagonalised by the undamped modes.*allowed: classical damping"):
        build_matrices(M, K, C=np.diag([0.0, 5.0]))
    with pytest.raises(ValueError, match="K is not positive definite"):
        build_matrices(M, np.array([[1.0, -1.0], [-1.0, 1.0]]), C=C)
    with pytest.raises(ValueError, match="C is not a square matrix"):
        build_matrices(M, K, C=C[:1])
    with pytest.raises(ValueError, match="n_modes"):
        build_matrices(M, K, C=C, n_modes=3)
    with pytest.raises(ValueError, match="positive semi-definite"):
        build_matrices(M, K, C=-C)


def test_build_matrices_repeated_frequency_and_truncation():
    """Two equal oscillators with different dashpots along directions rotated by 0.5 rad from the
    coordinates (K = 4 M, C = Q diag(0.1, 0.3) Q^T not diagonal): any basis of the double
    eigenspace is a set of modes, and the one the eigen-solver returns (the coordinates) does not
    diagonalise C; it is rotated to the one that does, so the damping is accepted and each mode
    carries one dashpot.  n_modes keeps the lowest."""
    M = np.eye(2)
    K = 4.0 * np.eye(2)
    c, s_ = math.cos(0.5), math.sin(0.5)
    Q = np.array([[c, -s_], [s_, c]])
    C = Q @ np.diag([0.1, 0.3]) @ Q.T
    s = build_matrices(M, K, C=C, f_ref_hz=1.0 / (2 * math.pi)).system
    np.testing.assert_allclose(np.sort(s.damping), [0.1, 0.3], rtol=1e-13)
    np.testing.assert_allclose(s.omega, [2.0, 2.0], rtol=1e-15)
    M2, C2, K2 = _two_dof()
    assert build_matrices(M2, K2, C=C2, n_modes=1).system.omega.shape == (1,)


def test_modal_flow_refuses_undamped_resonance_and_bad_shapes():
    s = msys.modal_system([1.0, 2.0], [0.0, 0.1], [1.0, 1.0], [1.0, 1.0], [[1.0, 1.0]], 0.1)
    with pytest.raises(ValueError, match="undamped exact resonance"):
        modal_flow(s, 0.0, 1.0, [0.0, 0.0], [0.0, 0.0], 1.0)
    e, _ = modal_flow(s, 0.0, 1.0, [0.1, 0.0], [0.0, 0.0], 0.0)   # free vibration is fine
    assert e[0] == pytest.approx(0.1 * math.cos(1.0), rel=1e-15)
    with pytest.raises(ValueError, match="eta must have shape"):
        modal_flow(s, 0.0, 1.0, [0.0], [0.0, 0.0], 1.0)
    with pytest.raises(ValueError, match="contacts must have shape"):
        msys.modal_system([1.0, 2.0], [0.0, 0.1], [1.0, 1.0], [1.0, 1.0], [[1.0]], 0.1)


def test_a_numba_kernel_takes_the_system_and_the_aliases_are_the_moved_kernels():
    """The system is plain data a numba kernel takes as one argument; the names the kernels' callers
    import are the very same objects (so every caller computes the same bits); the beam model's old
    aliases of them are gone with it."""
    from numba import njit

    import importlib.util

    from vibeam.models.builders import beam_fe as beam
    from vibeam.models.core import contact_phase, integrator, phases, scene_shooting, signals
    from vibeam.models.mapping import phases as map_phases

    @njit
    def stiffness_sum(sy):
        out = 0.0
        for i in range(sy.omega.shape[0]):
            out += sy.omega[i] * sy.omega[i] * sy.contacts[0, i] + sy.base_amplitude
        return out

    s = _three_modes()
    assert isinstance(s, ModalSystem) and isinstance(s, tuple)
    assert stiffness_sum(s) == pytest.approx(np.sum(s.omega ** 2 * s.contacts[0]) + 3 * s.base_amplitude,
                                             rel=1e-15)
    assert integrator.transition_increment is contact_phase.transition_increment is msys.transition_increment
    assert signals.transition_increment is msys.transition_increment
    assert importlib.util.find_spec("vibeam.models.beam_dynamics") is None     # with its aliases
    assert beam._lowest_eigs is msys.lowest_modes
    assert phases.mode_table is map_phases.mode_table is msys.mode_table
    assert map_phases.particular is scene_shooting.particular is msys.particular
    np.testing.assert_allclose(msys.damping_ratios(s), [0.02, 1.0, 30.0 / 18.0], rtol=1e-15)


def test_the_system_owns_its_arrays():
    """The beam builders' packing (modal_scene) copies: changing the arrays it was given afterwards
    leaves the system as built (the static-mode beam's numbers)."""
    g = _geom()
    sm = static_mode_beam(g, mass_stops(0.0, Restitution(0.72)), base_amplitude_m=Y, damping_D_s=D)
    a = sm.system
    om = a.omega / a.time_unit_s
    rows, gam = a.contacts.copy(), a.participation.copy()
    s = modal_scene(om, D * om ** 2, gam, a.sensor, rows, sm.stops, Y, a.reference_hz, L, PHIM, "beam").system
    before = s.contacts.copy(), s.participation.copy()
    rows[:] = 7.0
    gam[:] = 7.0
    assert np.array_equal(s.contacts, before[0]) and np.array_equal(s.participation, before[1])
    assert all(a.flags.c_contiguous and a.dtype == np.float64 for a in s[:5])
    assert all(x.flags.c_contiguous and x.dtype == np.float64 for x in sm.system[:5])


def test_the_scenes_outputs_are_its_units_and_the_gap_seen_at_the_sensor():
    """:func:`vibeam.models.scene.outputs` reads the report's units and the gap ``Delta`` of a
    scene from its system and first stop alone, against closed forms: the physical SDOF's ``f_n``,
    ``L`` and force scale ``m (2 pi f_n)^2 L`` and its ``Delta`` bit for bit; a nondimensional
    SDOF has none of the units; a two-mass chain base--k1--m1--k2--m2 (all modes kept, sensor on
    m1, the stop on m2) has ``m_eff = m2`` (``1 / (M^-1)_22``) and the static ratio of paper Eq. 45
    under the base load, ``u2 / u1 = 1 + m2 k1 / ((m1 + m2) k2)`` (the springs carry ``(m1 + m2)
    a`` and ``m2 a``), so a gap ``g`` at m2 is ``g / (u2 / u1) / L`` at the sensor."""
    from vibeam.models.scene import outputs

    o = outputs(sdof(beta=0.02, B=0.01, Delta=0.013, R=0.8, natural_frequency_hz=7.6, length_m=0.18,
                     mass_kg=0.25))
    assert o.natural_frequency_hz == pytest.approx(7.6, rel=2e-16) and o.length_m == 0.18
    assert o.force_scale_n == pytest.approx(0.25 * (2 * math.pi * 7.6) ** 2 * 0.18, rel=1e-15)
    assert (o.Delta, o.n_modes, o.m_eff, o.phi_contact) == (0.013, 1, 1.0, 1.0)
    o = outputs(sdof(beta=0.02, B=0.01, Delta=-0.2, R=0.8))
    assert (o.natural_frequency_hz, o.length_m, o.force_scale_n, o.Delta) == (None, None, None, -0.2)

    m1, m2, k1, k2, g, Lq = 2.0, 0.5, 3.0e4, 1.2e4, 1.5e-3, 0.1
    M = np.diag([m1, m2])
    K = np.array([[k1 + k2, -k2], [-k2, k2]])
    mm = build_matrices(M, K, damping_ratios=0.02, dofs=["m1", "m2"], sensor="m1", contacts=["m2"], length_m=Lq)
    sc = structure_scene(mm, (Stop(Relation(1.0, g), Restitution(0.7)),), 1e-4)
    o = outputs(sc)
    ratio = 1.0 + m2 * k1 / ((m1 + m2) * k2)
    assert float(sc.system.contact_static[0]) == pytest.approx(ratio, rel=1e-13)
    assert o.phi_contact == pytest.approx(ratio, rel=1e-13)
    assert o.Delta == pytest.approx(g / ratio / Lq, rel=1e-13)
    assert o.m_eff == pytest.approx(m2, rel=1e-13) and o.n_modes == 2 and o.length_m == Lq
    f1 = float(mm.frequencies_hz[0])
    assert o.natural_frequency_hz == pytest.approx(f1, rel=1e-15)
    assert o.force_scale_n == pytest.approx(m2 * (2 * math.pi * f1) ** 2 * Lq, rel=1e-13)


def test_a_built_scene_carries_its_builders_frequency_exactly():
    """The rig's f_n = 7.6 Hz through the time unit, ``1 / (2 pi (1 / (2 pi 7.6)))``, is not 7.6 in
    binary floating point; the scene carries the builder's frequency itself (``reference_hz``), so
    the case's grid (``Omega = f / f_n``) and the reported frequencies are the builder's bit for
    bit (issue 58: the grid no longer reads the model).  A system without it falls back to the
    quotient; a nondimensional one has none."""
    import math

    from vibeam.models.scene import outputs
    from vibeam.models.system import reference_hz

    for sc in (sdof_physical(7.6, 0.02, 0.1, 150.0, 0.2, 0.5, 0.8),
               sdof(beta=0.02, B=0.01, Delta=0.1, R=0.8, natural_frequency_hz=7.6, length_m=0.15)):
        sy = sc.system
        assert 1.0 / (2 * math.pi * sy.time_unit_s) != 7.6
        assert sy.reference_hz == 7.6 and outputs(sc).natural_frequency_hz == 7.6
        assert reference_hz(sy._replace(reference_hz=math.nan)) == 1.0 / (2 * math.pi * sy.time_unit_s)
    nd = sdof(beta=0.02, B=0.01, Delta=0.1, R=0.8)
    assert math.isnan(reference_hz(nd.system)) and outputs(nd).natural_frequency_hz is None
