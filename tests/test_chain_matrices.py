"""A structure of the user's own, given by its matrices (issue 58): ``cases/chain-3dof.toml``.

The 3-DOF chain (three 0.2 kg masses on 2000 N/m springs, 2 % modal damping, a harmonic base
acceleration of 0.1 m/s^2, a Newton stop 0.5 mm above mass 3 with R = 0.8 and a Hunt-Crossley stop
0.15 mm below mass 1, k = 1e7 N/m^1.5, target R = 0.7) is read from its MatrixMarket files through
the canonical tables (``[model.system] builder = "matrices"``, ``[[model.stop]] at``,
``[model.excitation]``), reduced to its modes and simulated by the exact event-driven modal
integrator.  The oracle is an independent integration of the physical equations written here,

    ``M x'' + C x' + K x = -M 1 b''(t) + e_1 F_HC``   (x relative to the base, ``b'' = -a sin W t``),
    ``x_3 = gap_3, x_3' > 0  ->  x_3' <- -R x_3'``    (Newton's law on mass 3),
    ``F_HC = k d^p (1 + chi d' / v_in)``, ``d = -x_1 - gap_1 > 0`` and ``F_HC > 0``
                                                      (Hunt-Crossley on mass 1, upwards),

by :func:`scipy.integrate.solve_ivp` (DOP853, rtol 1e-12) with event location: the Newton impact a
terminal event; the Hunt-Crossley contact a phase of its own between terminal events (entry where
``d`` rises through 0, recording ``v_in = d'``, floored at ``V_FLOOR`` times the base velocity
amplitude ``a / W``; exit where ``d`` falls through 0 or the force's factor
``1 + chi d' / v_in`` does; after a factor exit the mass is inside the stop without force until
``d`` falls through 0 or ``d' + v_in / chi`` rises through 0, a new contact with the same
``v_in``: Hunt & Crossley 1975, ``chi = 8 (1 - R) / (5 R)`` of Flores et al. 2011), with
``C = M Phi diag(2 zeta omega) Phi^T M`` (the same modal damping, built from numpy's own
eigenvectors).  With every mode kept the modal impulse along ``M^-1 w`` is exactly the physical one
(mass 3's velocity reversed by R, the others unchanged) and the modal contact force along ``w_1``
is the physical force on mass 1, so the two must agree to the integrators' accuracy on a settled
period-1 orbit.
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
import scipy.io
import scipy.linalg
from scipy.integrate import solve_ivp

from vibeam.case.schema import load_case, parse_case
from vibeam.errors import CaseError
from vibeam.models import make_solver, shooting_problem
from vibeam.models.scene import outputs
from vibeam.models.system import forcing

ROOT = Path(__file__).resolve().parents[1]
CASE = ROOT / "cases" / "chain-3dof.toml"
TWO_PI = 2.0 * math.pi
#: the case's numbers (cases/chain-3dof.toml)
A_BASE = 0.1                     # m/s^2, the base acceleration's amplitude
GAP3, R3 = 0.5e-3, 0.8           # the Newton stop above mass 3
GAP1, K_HC, P_HC, R_HC = 0.15e-3, 1e7, 1.5, 0.7     # the Hunt-Crossley stop below mass 1
CHI = 8.0 * (1.0 - R_HC) / (5.0 * R_HC)            # Flores et al. 2011
V_FLOOR = 1e-2                   # the entry-velocity floor's factor (vibeam.models.core.laws.V_FLOOR)


def _case_text():
    """The case file without its ``[uncertainty]`` tables: a test that changes the drive or the runs
    would leave them sampling a key (``excitation.amplitude_m_s2``) or runs the case no longer has,
    which the schema refuses."""
    text = CASE.read_text()
    i = text.index("\n[uncertainty]\n")
    return text[:i] + text[text.index("\n[[run]]\n", i):]


def _linear_sensor_amplitude_m(sc, Omega):
    """Steady-state sensor amplitude (m) of the scene without its stops, from the modal sum of its
    driven system (the forcing ``f F(Omega)`` of :func:`vibeam.models.system.forcing`)."""
    sy = sc.system
    H = sy.participation * forcing(sy, Omega) / (sy.omega ** 2 - Omega ** 2 + 1j * Omega * sy.damping)
    return float(abs(sy.sensor @ H))


def _physical():
    M = np.asarray(scipy.io.mmread(ROOT / "cases" / "chain-3dof" / "M.mtx"))
    K = np.asarray(scipy.io.mmread(ROOT / "cases" / "chain-3dof" / "K.mtx"))
    lam, Phi = scipy.linalg.eigh(K, M)
    om = np.sqrt(lam)
    C = M @ Phi @ np.diag(2 * 0.02 * om) @ Phi.T @ M
    return M, K, C


def _orbit(x0, v0, f_hz, periods, load=None, hc=True, v_floor=None, v_in0=None):
    """The physical chain's motion from (x0, v0) at t = 0 (mass 1 not inside the Hunt-Crossley
    stop) over ``periods`` forcing periods: the state at each period's end, the lowest/highest x_3
    of the last period and the contacts ``(stop, count)`` of the last period.  ``load``: the
    amplitude (N) of the force ``load sin(W t)`` on the masses (default the base acceleration's
    ``M 1 a``); ``hc`` False: without the Hunt-Crossley stop; ``v_floor`` the entry-velocity floor
    (default ``V_FLOOR a / W``, the base velocity's amplitude along mass 1's normal); ``v_in0``: the
    entry velocity of a contact the motion starts inside of (mass 1 inside the stop)."""
    M, K, C = _physical()
    Minv = np.linalg.inv(M)
    W = TWO_PI * f_hz
    load = M @ np.ones(3) * A_BASE if load is None else np.asarray(load, float)
    v_floor = V_FLOOR * A_BASE / W if v_floor is None else v_floor
    FREE, CONTACT, INSIDE = 0, 1, 2
    mode, v_in = FREE, 0.0
    if hc and -x0[0] - GAP1 > 0.0:
        if v_in0 is None:
            raise ValueError("the orbit starts inside the Hunt-Crossley stop (its v_in unknown here)")
        mode, v_in = CONTACT, v_in0

    def hc_force(y):
        d, dd = -y[0] - GAP1, -y[3]
        return K_HC * max(d, 0.0) ** P_HC * (1.0 + CHI * dd / v_in)

    def rhs(t, y):
        x, v = y[:3], y[3:]
        f = load * math.sin(W * t) - C @ v - K @ x
        if mode == CONTACT:
            f = f + np.array([hc_force(y), 0.0, 0.0])
        return np.concatenate([v, Minv @ f])

    def newton(t, y):
        return y[2] - GAP3
    newton.terminal, newton.direction = True, 1.0

    def enter(t, y):                 # d up through 0
        return -y[0] - GAP1
    enter.terminal, enter.direction = True, 1.0

    def leave(t, y):                 # d down through 0
        return -y[0] - GAP1
    leave.terminal, leave.direction = True, -1.0

    def factor(t, y):                # the force's factor down through 0
        return 1.0 + CHI * (-y[3]) / v_in
    factor.terminal, factor.direction = True, -1.0

    def again(t, y):                 # inside without force: d' + v_in / chi up through 0
        return -y[3] + v_in / CHI
    again.terminal, again.direction = True, 1.0

    T = 1.0 / f_hz
    y = np.concatenate([x0, v0]).astype(float)
    t = 0.0
    ends, lo, hi = [], np.inf, -np.inf
    counts = np.zeros(2, int)
    for p in range(periods):
        t_end = (p + 1) * T
        last = p == periods - 1
        while True:
            events = [newton] + ([] if not hc else [enter] if mode == FREE else [leave, factor] if mode == CONTACT
                                 else [leave, again])
            sol = solve_ivp(rhs, (t, t_end), y, method="DOP853", rtol=1e-12, atol=1e-16, events=events,
                            dense_output=last)
            if last:
                tt = np.linspace(sol.t[0], sol.t[-1], 2001)
                x3 = sol.sol(tt)[2]
                lo, hi = min(lo, x3.min()), max(hi, x3.max())
            y = sol.y[:, -1].copy()
            t = sol.t[-1]
            if sol.status != 1:
                break
            hit = next(i for i, e in enumerate(sol.t_events) if e.size)
            name = events[hit].__name__
            if name == "newton":         # Newton's law on mass 3
                y[2] = GAP3
                y[5] = -R3 * y[5]
                counts[0] += last
            elif name == "enter":
                y[0] = -GAP1
                v_in = max(-y[3], v_floor)
                mode = CONTACT
                counts[1] += last
            elif name == "leave":
                y[0] = -GAP1
                mode = FREE
            elif name == "factor":
                mode = INSIDE
            else:                        # "again": a new contact inside the stop, the same v_in
                mode = CONTACT
                counts[1] += last
        ends.append(y.copy())
    if mode != FREE:
        raise ValueError("the orbit ends inside the Hunt-Crossley stop")
    return np.array(ends), lo, hi, counts


def _held_period(x0, v0, held, f_hz, a):
    """One forcing period of the physical chain with its Newton stop on mass 3 alone, plastic (R =
    0): a free flight to ``x_3 = gap_3`` (terminal event), where mass 3 stops; held there while the
    stop pushes, i.e. while the force ``mu = -(M^-1 f)_3 / (M^-1)_33`` that keeps ``x_3'' = 0``
    (``f = M 1 a sin(W t) - C x' - K x``) is negative (the stop is above the mass), released where
    ``mu`` rises through 0.  The whole damping matrix ``C`` acts while held.  Returns the state at
    the period's end and the time held."""
    M, K, C = _physical()
    Minv = np.linalg.inv(M)
    W = TWO_PI * f_hz
    load = M @ np.ones(3) * a

    def force(t, y):
        return load * math.sin(W * t) - C @ y[3:] - K @ y[:3]

    def mu(t, y):
        return -(Minv @ force(t, y))[2] / Minv[2, 2]
    mu.terminal, mu.direction = True, 1.0

    def rhs(t, y):
        f = force(t, y)
        if state["held"]:
            f = f + np.array([0.0, 0.0, mu(t, y)])
        return np.concatenate([y[3:], Minv @ f])

    def newton(t, y):
        return y[2] - GAP3
    newton.terminal, newton.direction = True, 1.0

    state = {"held": bool(held)}
    T = 1.0 / f_hz
    y = np.concatenate([x0, v0]).astype(float)
    t, stuck = 0.0, 0.0
    while t < T:
        sol = solve_ivp(rhs, (t, T), y, method="DOP853", rtol=1e-12, atol=1e-16,
                        events=[mu] if state["held"] else [newton])
        if state["held"]:
            stuck += sol.t[-1] - t
        y, t = sol.y[:, -1].copy(), sol.t[-1]
        if sol.status != 1:
            break
        if state["held"]:
            state["held"] = False            # released: mu rose through 0
        else:
            y[2], y[5] = GAP3, 0.0          # plastic impact on mass 3
            state["held"] = mu(t, y) < 0.0
    return y, stuck


@pytest.mark.parametrize("f_hz", [6.5, 8.0])
def test_held_motion_with_modal_damping_direct_is_exact_and_event_says_it_is_not(f_hz):
    """Sticking with non-proportional damping: the chain's 2 % modal damping, its Newton stop on
    mass 3 alone made plastic (R = 0) and a base acceleration of 0.3 m/s^2 stick mass 3 on its stop
    for 3 to 10 % of each period.  Held on that stop, the damping of the two held coordinates
    ``Psi^T C Psi`` is not diagonal (its off-diagonal part is 2.5e-2 of the diagonal).  From the
    event integrator's state after 300 periods, one period by ``direct`` equals the independent
    physical integration (:func:`_held_period`, the whole ``C`` while held) to 1e-8 of the gap
    (measured 1.2e-9: direct's rtol 1e-9); before the held phase took the whole held damping, direct
    shared the event integrator's diagonal and missed it by 5e-5 to 1.8e-4 of the gap.  The event
    integrator's held flow keeps the diagonal only: its point says so in its message (status
    sticking), and its error stays below 1e-3 of the gap (measured 1.8e-4)."""
    text = _case_text().replace(HC_STOP, "").replace("contact_gap_mm = 0.5\nR = 0.8", "contact_gap_mm = 0.5\nR = 0.0")
    text = text.replace('amplitude_m_s2 = 0.1', 'amplitude_m_s2 = 0.3')
    assert "R = 0.0" in text and "amplitude_m_s2 = 0.3" in text
    sc = parse_case(text.replace('"chain-3dof/', f'"{ROOT}/cases/chain-3dof/')).model_spec().scene()
    mm = load_case(CASE)[0].model_spec().matrix_model()
    f_ref, N = outputs(sc).natural_frequency_hz, outputs(sc).n_modes
    event, direct = make_solver(sc, "event"), make_solver(sc, "direct")
    Om = f_hz / f_ref
    s0 = event.point(Om, None, 300, 1).final_state
    x0, v0 = mm.shapes @ s0[:N], mm.shapes @ s0[N:2 * N] * (TWO_PI * f_ref)
    y, stuck = _held_period(x0, v0, s0[2 * N] != 0, f_hz, 0.3)
    assert 0.03 < stuck * f_hz < 0.11

    def error(tr):
        x, v = mm.shapes @ tr.final_state[:N], mm.shapes @ tr.final_state[N:2 * N] * (TWO_PI * f_ref)
        return max(np.max(np.abs(x - y[:3])) / GAP3, np.max(np.abs(v - y[3:])) / (GAP3 * TWO_PI * f_hz))

    d, e = direct.point(Om, s0, 0, 1), event.point(Om, s0, 0, 1)
    assert d.status == e.status == "sticking"
    assert error(d) < 1e-8
    assert abs(d.extra["stuck_fraction"] - stuck * f_hz) < 1e-8
    assert "held damping is not diagonal" in e.message and "up to 0.025 of the diagonal" in e.message
    assert "held damping" not in d.message
    assert 1e-6 < error(e) < 1e-3


def test_a_rayleigh_damped_scene_drops_no_held_damping():
    """The FE rig's 4 modes (Rayleigh damping: ``Psi^T C Psi`` diagonal on any held set, measured
    off-diagonal 3.8e-16 of it) drop nothing and their held points carry no note."""
    from vibeam.models.core.event import HELD_DAMPING_NOTED, EventIntegrator

    sc = load_case(ROOT / "cases" / "rig-fe-neutral.toml")[0].model_spec().scene()
    assert EventIntegrator(sc).held_dropped == 0.0 < HELD_DAMPING_NOTED


def test_the_case_reads_the_canonical_tables_and_builds_the_structure():
    case, _ = load_case(CASE)
    spec = case.model_spec()
    sc = spec.scene()
    s = sc.system
    assert sc.builder == "matrices" and s.omega.shape[0] == 3
    w_ref = 2 * math.pi * s.reference_hz
    # the chain's closed-form frequencies: 2 sqrt(k/m) sin((2j-1) pi / 14), j = 1, 2, 3
    f = np.sort(s.omega * w_ref) / TWO_PI
    exact = 2 * math.sqrt(2000 / 0.2) * np.sin(np.array([1, 3, 5]) * math.pi / 14) / TWO_PI
    assert np.allclose(f, exact, rtol=1e-12, atol=0)
    assert np.allclose(s.damping * w_ref, 2 * 0.02 * 2 * math.pi * exact, rtol=1e-12)
    assert math.isclose(outputs(sc).natural_frequency_hz, exact[0], rel_tol=1e-12)
    assert sc.stops[0].relation.offset == 0.5e-3 and spec.excitation.base_amplitude_m == 0.0
    # the base acceleration folded into the system (vibeam.models.scene.driven): f = Gamma, p = 0,
    # A = a T^2 / u (u = length_unit_m / coordinate_scale, 1 m)
    mm = case.model_spec().matrix_model()
    assert np.array_equal(s.participation, mm.system.participation) and s.drive_power == 0
    assert s.base_amplitude == A_BASE * s.time_unit_s * s.time_unit_s / (s.length_unit_m / s.coordinate_scale)
    # the second stop: Hunt-Crossley below m1 (contact row 1, normal -w_1), its law's numbers as given
    # (the scene's stiffness in the system's units: N/m^p over omega_ref^2)
    (up, lo) = sc.stops
    assert (up.relation.sign, up.relation.offset, up.law.R) == (1.0, GAP3, R3)
    assert (lo.relation.sign, lo.relation.offset, lo.relation.row) == (-1.0, GAP1, 1)
    assert (lo.law.name, lo.law.stiffness, lo.law.exponent, lo.law.R) == ("hunt_crossley", K_HC / w_ref ** 2, P_HC,
                                                                          R_HC)
    shapes = mm.shapes
    assert np.array_equal(s.contacts, shapes[[2, 0]])           # the rows of m3 and m1
    one = case.model_spec(dict(case.run[1].model))   # [run.model.system] n_modes = 1, merged key by key
    assert one.system.builder == "matrices" and one.scene().system.omega.shape[0] == 1


#: period-1 points of the sweep (cases/chain-3dof.toml; from rest, 8.0 Hz on the up sweep from 7.5 Hz:
#: from rest it settles on the branch without contact) and the contacts per period of each stop
#: (Newton on m3, Hunt-Crossley on m1): no contact, the compliant stop alone (one and two contacts
#: a period), both stops
PERIOD_ONE = {6.0: (0, 0), 6.5: (0, 1), 6.8: (0, 2), 7.5: (1, 1), 8.0: (1, 2)}


@pytest.mark.parametrize("f_hz", sorted(PERIOD_ONE))
def test_event_orbit_equals_an_independent_physical_integration(f_hz):
    """A settled period-1 orbit of the event integrator (the case's FRC points by ``event``) is, in
    physical coordinates, a fixed point of the independent integration over one period, with the
    same contacts and the same extremes of x_3.  Tolerance 1e-8 of the gap: solve_ivp at rtol
    1e-12 over one period carries ~1e-11 of the state; the event integrator is exact between
    events and integrates a Hunt-Crossley contact by its own Runge-Kutta phase at rtol 1e-11
    (vibeam.models.core.laws.RTOL), ~1e-10 of the motion after a few contacts."""
    case, _ = load_case(CASE)
    sc = case.model_spec().scene()
    f_ref = outputs(sc).natural_frequency_hz
    sol = make_solver(sc, "event")
    Om = f_hz / f_ref
    start = None if f_hz < 8.0 else sol.point(7.5 / f_ref, None, 600, 8, 64).final_state
    tr = sol.point(Om, start, 600, 8, 64)
    assert tr.status == "ok"
    N = outputs(sc).n_modes
    assert tr.final_state[2 * N] == 0                                  # free at the period's start
    eta, etad = tr.final_state[:N], tr.final_state[N:2 * N]
    # modal -> physical: x = Phi eta, the shapes of the reduction (t = omega_ref t~)
    mm = case.model_spec().matrix_model()
    x0 = mm.shapes @ eta
    v0 = mm.shapes @ etad * (TWO_PI * f_ref)
    ends, lo, hi, counts = _orbit(x0, v0, f_hz, 1)
    tol = 1e-8 * GAP3
    assert np.max(np.abs(ends[-1][:3] - x0)) < tol
    assert np.max(np.abs(ends[-1][3:] - v0)) < tol * TWO_PI * f_hz
    # the same contacts: the kernel's per stop (codes 0 upper at m3, 2 the stop at m1) over 8 periods
    codes = np.asarray(tr.impact_stops, int) if tr.n_impacts else np.zeros(0, int)
    kernel = (int(np.sum(codes == 0)) // 8, int(np.sum(codes == 2)) // 8)
    assert tuple(counts) == kernel == PERIOD_ONE[f_hz]
    L = 1e-3
    # the oracle's extremes from 2001 samples of its dense output per segment (a sampled extreme
    # of a swing of ~1 mm at 2001 samples is within ~1e-6 of it: (pi / 2000)^2 / 2)
    assert abs(tr.q_max * L - hi) < 2e-6 * GAP3
    assert abs(tr.q_min * L - lo) < 2e-6 * GAP3
    if counts[0]:
        assert abs(hi - GAP3) < 1e-12                                  # it reaches the stop every period
    else:
        assert hi < GAP3


def test_a_run_starting_inside_the_hunt_crossley_contact_on_a_rebound_takes_its_entry_velocity():
    """A run that starts inside a Hunt-Crossley contact (a sweep point continuing from a state in
    contact, a shot from a section inside it) has not seen its entry: it takes the entry velocity
    of the isolated conservative contact through its state (vibeam.models.core.laws.start_velocity),
    ``v_in^2 = U^2 + 2 k d^(p+1) / ((p + 1) m_eff)``, ``m_eff = 1 / (M^-1)_11`` with all modes.  With
    that ``v_in`` the independent physical integration (``_orbit``) and the event integrator agree
    over one period (1e-8 of the gap, as the period-1 test).  Before, a start on a rebound (``U <
    0``) took the floor ``V_FLOOR a / W`` (~2e-5 m/s instead of ~1e-2): a damping ~500 times too large
    (cases/chain-3dof.toml's up sweep failed at 8.2-8.5 Hz with a step collapse)."""
    case, _ = load_case(CASE)
    sc = case.model_spec().scene()
    f_ref = outputs(sc).natural_frequency_hz
    sol = make_solver(sc, "event")
    f_hz = 8.3
    M, _K, _C = _physical()
    mm = case.model_spec().matrix_model()
    d, u = 1.5e-5, 0.01                    # penetration (m) and rebound speed (m/s) of mass 1
    x0 = np.array([-GAP1 - d, -0.05e-3, 0.1e-3])
    v0 = np.array([u, 0.0, -0.02])
    m_eff = 1.0 / np.linalg.inv(M)[0, 0]
    v_in = math.sqrt(u * u + 2.0 * K_HC * d ** (P_HC + 1.0) / ((P_HC + 1.0) * m_eff))
    assert v_in > 1.1 * u                  # the spring's energy counts: not |U| alone
    ends, lo, hi, counts = _orbit(x0, v0, f_hz, 1, v_in0=v_in)
    eta = np.linalg.solve(mm.shapes, x0)
    etad = np.linalg.solve(mm.shapes, v0) / (TWO_PI * f_ref)
    start = np.concatenate([eta, etad, [-1.0]])          # held code -1: in contact with stop 1
    tr = sol.point(f_hz / f_ref, start, 0, 1, 64)
    assert tr.status == "ok", tr.status
    N = outputs(sc).n_modes
    x1 = mm.shapes @ tr.final_state[:N]
    v1 = mm.shapes @ tr.final_state[N:2 * N] * (TWO_PI * f_ref)
    tol = 1e-8 * GAP3
    assert np.max(np.abs(x1 - ends[-1][:3])) < tol, np.abs(x1 - ends[-1][:3])
    assert np.max(np.abs(v1 - ends[-1][3:])) < tol * TWO_PI * f_hz


def test_bad_structure_tables_are_refused_in_one_line(tmp_path):
    text = CASE.read_text()
    for old, new, msg in (
            ('sensor = "m3"', 'sensor = "m9"', "m9"),
            ('at = "m3"', 'at = "m7"', "m7"),
            ('builder = "matrices"', 'builder = "beams"', "system.builder"),
            ('damping_ratios = 0.02', 'damping_ratios = 1.5', "damping_ratios"),
            ('side = "upper"', 'side = "lower"', "upper stop first")):
        bad = tmp_path / "bad.toml"
        bad.write_text(text.replace(old, new))
        (tmp_path / "chain-3dof").mkdir(exist_ok=True)
        for f in ("M.mtx", "K.mtx"):
            (tmp_path / "chain-3dof" / f).write_bytes((ROOT / "cases" / "chain-3dof" / f).read_bytes())
        with pytest.raises(CaseError) as e:
            c, _ = load_case(bad)
            c.model_spec().scene()
        assert msg in str(e.value) and "\n" not in str(e.value), str(e.value)


def test_inline_matrices_give_the_same_structure():
    text = CASE.read_text().replace('M = "chain-3dof/M.mtx"', "M = [[0.2, 0.0, 0.0], [0.0, 0.2, 0.0], [0.0, 0.0, 0.2]]")
    text = text.replace('K = "chain-3dof/K.mtx"', "K = [[4000.0, -2000.0, 0.0], [-2000.0, 4000.0, -2000.0], "
                                                  "[0.0, -2000.0, 2000.0]]")
    a = parse_case(text).model_spec().scene().system
    b = load_case(CASE)[0].model_spec().scene().system
    # the frequencies as the scene holds them: omega per unit time and the reference frequency
    assert np.array_equal(a.omega, b.omega) and a.reference_hz == b.reference_hz
    assert np.array_equal(a.contacts[0], b.contacts[0])


def test_continuation_multipliers_equal_finite_differences_of_the_physical_period_map(tmp_path):
    """The continuation of the chain's impacting period-1 orbit (from the sweep at 7.1 Hz) through
    the framework: at a point in the middle of the branch the Floquet
    multipliers of the shooting problem (monodromy with saltation matrices) are the eigenvalues of
    a central-difference Jacobian of the independent physical integration over one period (6 x 6,
    h = 1e-7 of the state's scale: the oracle's rtol 1e-12 over h leaves ~1e-5 in the Jacobian's
    entries, so the multipliers agree to 1e-4; the Floquet multipliers do not depend on the
    coordinates)."""
    import contextlib
    import io

    from vibeam.runner import run_case

    text = _case_text().replace('"chain-3dof/', f'"{ROOT}/cases/chain-3dof/')
    head = text.split("\n[[run]]\n")[0]
    text = head + '\n[[run]]\nname = "3 modes"\nmethod = "continuation"\nstart = "sweep"\nstart_at = 7.5\nswitch = false\n'
    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
        conts = run_case(parse_case(text), text, tmp_path, jobs=1, quiet=True, plots=False, continuation_only=True)
    (r,) = conts
    case, _ = load_case(CASE)
    sc = case.model_spec().scene()
    f_ref = outputs(sc).natural_frequency_hz
    mm = case.model_spec().matrix_model()

    prob = shooting_problem(sc)
    d = r.branches[0]["data"]
    k = len(d["parameter"]) // 2
    assert int(d["impacts"][k]) >= 1                                  # an impacting orbit
    x, W = np.asarray(d["state"][k], float), float(d["parameter"][k])
    f_hz = W * f_ref
    shot = prob.shot(x, W, 1, derivatives=False)
    assert np.max(np.abs(shot.x - x)) < 1e-9 * np.max(np.abs(x))     # a periodic orbit
    N = outputs(sc).n_modes
    w_ref = TWO_PI * f_ref
    to_phys = np.block([[mm.shapes, np.zeros((3, N))], [np.zeros((3, N)), mm.shapes * w_ref]])
    y0 = to_phys @ x[:2 * N]
    h = 1e-7 * np.max(np.abs(y0))
    J = np.column_stack([(_orbit((y0 + h * e)[:3], (y0 + h * e)[3:], f_hz, 1)[0][-1]
                          - _orbit((y0 - h * e)[:3], (y0 - h * e)[3:], f_hz, 1)[0][-1]) / (2 * h)
                         for e in np.eye(6)])
    fd = np.linalg.eigvals(J)
    an = np.asarray(d["multipliers"][k])
    fd_big, an_big = fd[np.abs(fd) > 1e-3], an[np.abs(an) > 1e-3]
    assert fd_big.size == an_big.size
    dist = max(np.min(np.abs(an_big - z)) for z in fd_big)
    assert dist < 1e-4, (np.sort_complex(fd_big), np.sort_complex(an_big))


HC_STOP = ('\n[[model.stop]]\nat = "m1"\nside = "lower"\ncontact_gap_mm = 0.15\nlaw = "hunt_crossley"\n'
           'stiffness_n_m = 1e7\nexponent = 1.5\nR = 0.7\n')


def _drive(kind, hc=True, **amp):
    text = _case_text()
    assert HC_STOP in text
    text = (text if hc else text.replace(HC_STOP, "")).replace(
        'kind = "base_acceleration"\namplitude_m_s2 = 0.1', f'kind = "{kind}"\n' + "".join(
            f"{k} = {v!r}\n" for k, v in amp.items()))
    return parse_case(text.replace('"chain-3dof/', f'"{ROOT}/cases/chain-3dof/')).model_spec().scene()


def test_a_base_acceleration_of_omega_squared_y_is_the_displacement_drive_at_that_frequency():
    """``[model.excitation] kind = "base_acceleration"``, ``a = (2 pi f)^2 Y``: at that frequency the
    forcing is the displacement drive's (the same double up to the rounding of a and A), so the
    event integrator's orbit is the same to round-off (1e-12 of the gap); at another frequency it
    differs (the acceleration is held, the displacement's forcing grows as f^2)."""
    f = 7.5
    a = (TWO_PI * f) ** 2 * 0.05e-3
    acc = _drive("base_acceleration", amplitude_m_s2=a)
    disp = _drive("base_displacement", amplitude_mm=0.05)
    f_ref = outputs(disp).natural_frequency_hz
    for W, same in ((f / f_ref, True), (6.0 / f_ref, False)):
        ta = make_solver(acc, "event").point(W, None, 300, 4, 64)
        td = make_solver(disp, "event").point(W, None, 300, 4, 64)
        diff = np.max(np.abs(ta.samples - td.samples))
        assert (diff < 1e-12 * 0.5) == same, diff
    lin = _linear_sensor_amplitude_m(acc, 6.0 / outputs(acc).natural_frequency_hz)
    M, K, C = _physical()
    w = TWO_PI * 6.0
    exact = np.linalg.solve(K - w * w * M + 1j * w * C, M @ np.ones(3) * a)[2]
    assert abs(lin - abs(exact)) < 1e-12 * abs(exact)


def test_a_point_force_orbit_equals_the_independent_physical_integration():
    """``kind = "force"``, 1.5 N on m2 (``at = "m2"``), the chain with its Newton stop on m3 alone
    (the force drives m1 into the Hunt-Crossley stop at every frequency of its impacting orbits, and
    these orbits are in that contact at the period's start, where the oracle cannot know its entry
    velocity): the settled impacting orbit of the event integrator is a fixed point of the physical
    integration with the force ``e_2 F0 sin(W t)`` and Newton's law on mass 3, to 1e-9 of the gap
    (as the base drive's test)."""
    m = _drive("force", hc=False, amplitude_n=1.5, at="m2")
    mm = load_case(CASE)[0].model_spec().matrix_model()
    f_hz = 7.1
    f_ref = outputs(m).natural_frequency_hz
    tr = make_solver(m, "event").point(f_hz / f_ref, None, 600, 8, 64)
    assert tr.status == "ok" and tr.n_impacts >= 8
    N = outputs(m).n_modes
    x0 = mm.shapes @ tr.final_state[:N]
    v0 = mm.shapes @ tr.final_state[N:2 * N] * (TWO_PI * f_ref)
    assert tr.final_state[2 * N] == 0                                  # free at the period's start
    ends, lo, hi, counts = _orbit(x0, v0, f_hz, 1, load=[0.0, 1.5, 0.0], hc=False)
    assert np.max(np.abs(ends[-1][:3] - x0)) < 1e-9 * GAP3
    assert np.max(np.abs(ends[-1][3:] - v0)) < 1e-9 * GAP3 * TWO_PI * f_hz
    assert abs(hi - GAP3) < 1e-12
    assert counts[0] == tr.n_impacts // 8 and counts[1] == 0


def test_bad_excitations_are_refused_in_one_line():
    for kind, amp, msg in (("force", {"amplitude_n": 1.0}, "at"), ("force", {"amplitude_n": 1.0, "at": "m9"}, "m9"),
                           ("base_acceleration", {"amplitude_mm": 1.0}, "amplitude_m_s2")):
        with pytest.raises(CaseError) as e:
            _drive(kind, **amp)
        assert msg in str(e.value) and "\n" not in str(e.value), str(e.value)


def test_a_method_that_does_not_simulate_the_compliant_stop_is_refused_in_one_line():
    """The modal mapping passes Newton and Kelvin-Voigt stops only: with the Hunt-Crossley stop on m1
    it is refused, by the case check and by make_solver (the one capability function), naming what
    is allowed; event, direct and continuation simulate it."""
    text = CASE.read_text().replace('"chain-3dof/', f'"{ROOT}/cases/chain-3dof/')
    with pytest.raises(CaseError) as e:
        parse_case(text.replace('method = "event"', 'method = "mapping"', 1))
    msg = str(e.value)
    assert "hunt_crossley" in msg and "stop[1]" in msg and "event, direct, continuation" in msg and "\n" not in msg
    m = load_case(CASE)[0].model_spec().scene()
    with pytest.raises(ValueError, match="hysteretic_hertz.*allowed: event, direct, continuation"):
        make_solver(m, "mapping")
    parse_case(text.replace('method = "event"', 'method = "direct"', 1))


@pytest.mark.parametrize("U", [-0.3, 0.2, 0.0])
def test_the_start_velocity_partials_equal_central_differences(U):
    """``laws.start_velocity``'s partials (the shot's tangent row of ``v_in``, shooting.tangent) equal
    central differences of its value (step 1e-6 relative: truncation ~1e-12, round-off ~1e-10 of the
    value; tolerance 1e-7 relative); Kelvin-Voigt has no ``v_in`` (``|U|``, no g or k partial)."""
    from vibeam.models.core.laws import start_velocity
    from vibeam.models.contact import LAW_HYSTERETIC_HERTZ, LAW_LINEAR

    sv = start_velocity.py_func
    g, k, p, nn = 0.04, 7.0, 1.5, 2.5
    v, vg, vU, vk = sv(LAW_HYSTERETIC_HERTZ, g, U, k, p, nn)
    assert math.isclose(v * v, U * U + 2 * k * nn * g ** 2.5 / 2.5, rel_tol=1e-14)
    for i, dv in ((0, vg), (1, vU), (2, vk)):
        x = [g, U, k]
        h = 1e-6 * max(abs(x[i]), 1e-3)
        hi, lo = list(x), list(x)
        hi[i] += h
        lo[i] -= h
        fd = (sv(LAW_HYSTERETIC_HERTZ, hi[0], hi[1], hi[2], p, nn)[0]
              - sv(LAW_HYSTERETIC_HERTZ, lo[0], lo[1], lo[2], p, nn)[0]) / (2 * h)
        assert math.isclose(dv, fd, rel_tol=1e-7, abs_tol=1e-9), (i, dv, fd)
    assert sv(LAW_HYSTERETIC_HERTZ, -0.01, U, k, p, nn)[:3] == (U, 0.0, 1.0)      # outside: U itself
    assert sv(LAW_LINEAR, g, U, k, p, nn)[0] == abs(U) and sv(LAW_LINEAR, g, U, k, p, nn)[1] == 0.0


def test_continuation_in_the_drive_amplitude_gives_orbits_of_the_scene_with_it_written(tmp_path):
    """Issue 58, 'one parameter vocabulary': a matrix scene continued in the path of its drive's
    amplitude (``excitation.amplitude_m_s2``; first by central differences of the scene's shots,
    now the scene's problem's own path, ``system.base_amplitude``), at 7.5 Hz over [0.144, 0.15] m/s^2 from the sweep's orbit at 0.15 (the upper
    period-1 branch, which folds back at 0.1424).  Before: refused at load ('cannot be continued in
    a structure given by its matrices; allowed: Omega').

    Oracle: at four points along the branch, the chain with that amplitude *written* in its
    [model.excitation] table and its event integrator -- one forcing period from the branch's state
    returns to it to 1e-8 of the state (tests/test_paths.py's bound: the shot converges to 1e-10,
    one period grows an error by at most max|mu|).  The results name the path."""
    import contextlib
    import io

    from vibeam.runner import run_case

    text = _case_text().replace('"chain-3dof/', f'"{ROOT}/cases/chain-3dof/')
    head = text.split("\n[[run]]\n")[0]
    text = head + ('\n[[run]]\nname = "in a"\nmethod = "continuation"\nparameter = "excitation.amplitude_m_s2"\n'
                   'at = 7.5\nrange = [0.144, 0.15]\nstart = "sweep"\nstart_at = 0.15\nswitch = false\n')
    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
        conts = run_case(parse_case(text), text, tmp_path, jobs=1, quiet=True, plots=False, continuation_only=True)
    (r,) = conts
    assert r.parameter == "excitation.amplitude_m_s2" and r.status == "ok", (r.status, r.message)
    b = r.branches[0]["data"]
    a = np.asarray(b["parameter"])
    assert a.min() <= 0.144 + 1e-9 and a.max() >= 0.15 - 1e-9 and len(a) >= 4, (a.min(), a.max(), len(a))
    for i in np.linspace(0, len(a) - 1, 4).astype(int):
        written = text.replace("amplitude_m_s2 = 0.1\n", f"amplitude_m_s2 = {float(a[i])!r}\n", 1)
        assert written != text
        model = parse_case(written).model_spec().scene()
        x = np.asarray(b["state"][i])
        one = make_solver(model, "event").point(7.5 / outputs(model).natural_frequency_hz,
                                                np.concatenate([x, [0.0]]), 0, 1, 32)
        assert np.max(np.abs(one.final_state[:-1] - x)) <= 1e-8 * np.max(np.abs(x)), (a[i], one.final_state, x)


@pytest.mark.parametrize("key", ["stops[0].law.R", "stops[0].contact_gap_mm", "stops[1].contact_gap_mm",
                                 "excitation.amplitude_m_s2"])
def test_the_scene_problem_carries_a_stop_and_the_drive_of_the_case_exactly(key):
    """Issue 58, 'one parameter vocabulary': the case's paths of the Newton stop's R, a stop's gap
    and the drive's amplitude are paths of the scene's shooting problem (its exact ``d x / d p``;
    before: central differences of shots, FiniteDifferenceParameter), the compliant stop's R is
    not (its law's numbers stay finite-difference paths).

    Oracle: ``d P / d p`` at a settled 7.5 Hz state against central differences of one period of
    the chain rebuilt from the case with the value *written* (h = 1e-5 of the value: truncation
    ~1e-10, the event location's 1e-12 over h ~1e-7 of the entries), 1e-5 of the largest entry
    (measured: R and the amplitude 9e-10, 7e-10; the gaps 5e-8, 1.7e-7).  A gap's factor off by 1 %
    fails it."""
    from vibeam.analysis.branches import _carried, problem
    from vibeam.case.contact import model_with
    from vibeam.case.expand import expand
    from vibeam.case.paths import get_value

    case = parse_case(_case_text().replace('"chain-3dof/', f'"{ROOT}/cases/chain-3dof/'))
    spec = case.model_spec()
    table = case.model
    assert _carried(spec, key) and not _carried(spec, "stops[1].law.R")
    sc = spec.scene()
    W = 7.5 / outputs(sc).natural_frequency_hz
    x = make_solver(sc, "event").point(W, None, 300, 1, 1).final_state[:-1]
    p0 = float(get_value(table, key))
    s = problem(spec, key, W).shot(x, p0, 1)
    assert s.status == "ok" and s.n_impacts >= 1, s.message

    def written(v):
        sp = type(spec).model_validate(expand(model_with(table, {key: float(v)})))
        return problem(sp, "Omega", W).shot(x, W, 1).x

    h = 1e-5 * p0
    fd = (written(p0 + h) - written(p0 - h)) / (2 * h)
    assert np.max(np.abs(s.x_p - fd)) <= 1e-5 * np.max(np.abs(fd)), (key, s.x_p, fd)


def test_a_lower_stop_at_the_reference_dof_is_the_second_relation_on_its_row():
    """A lower stop at the first stop's DOF (m3), Newton's with its own R, given at the stop
    (``contact_gap_mm``) or at the sensor (``gap_mm``, times the DOF's static ratio, paper Eq. 45):
    the scene's stops are the upper one (+1, row 0), the lower one (-1, row 0, its own law, not
    the upper's), then the Hunt-Crossley stop below m1 on row 1; the gap at the sensor is m3's own
    (the sensor is m3: ratio 1)."""
    text = CASE.read_text().replace('"chain-3dof/', f'"{ROOT}/cases/chain-3dof/')
    upper = 'side = "upper"\ncontact_gap_mm = 0.5\nR = 0.8\n'
    assert upper in text
    for key in ("contact_gap_mm", "gap_mm"):           # both stops at m3 give their gap the same way
        lower = f'\n[[model.stop]]\nat = "m3"\nside = "lower"\n{key} = 0.4\nR = 0.6\n'
        both = upper.replace("contact_gap_mm", key) + lower
        sc = parse_case(text.replace(upper, both)).model_spec().scene()
        (up, lo, hc) = sc.stops
        assert (up.relation.sign, up.relation.row, up.law.R) == (1.0, 0, R3)
        assert up.relation.offset == pytest.approx(GAP3, rel=1e-15)
        assert (lo.relation.sign, lo.relation.row, lo.law.kind, lo.law.R) == (-1.0, 0, "impulsive", 0.6)
        assert lo.relation.offset == pytest.approx(0.4e-3, rel=1e-15)
        assert lo.law is not up.law and (hc.relation.sign, hc.relation.row, hc.law.name) == (-1.0, 1, "hunt_crossley")
