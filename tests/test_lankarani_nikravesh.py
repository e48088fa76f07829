"""The Lankarani-Nikravesh hysteretic-Hertz stop (issue 20, "Extensibility, shown").

``F = k_c delta^p (1 + chi delta' / v_in)`` with ``chi = 3 (1 - R^2) / 4`` (Lankarani &
Nikravesh, J. Mech. Des. 112 (1990) 369; compared by Flores et al., Mech. Mach. Theory 46
(2011)): one class in ``models/compliant.py`` and one line of ``registry.LAWS``; every kernel of
the hysteretic-Hertz family (SDOF event, direct, mapping, continuation; beam event, direct,
continuation) then serves it unchanged.

Oracles: the hand formula of the force; an independent :func:`scipy.integrate.solve_ivp`
integration of the contact ODE (no kernel code); the ``direct`` solvers (solve_ivp with events,
no shared code with the event kernels); the settled event-kernel orbit against the continued
periodic orbit; the SDOF against the one-mode beam (another kernel in other units).
"""
from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from vibeam.case.schema import CaseError, load_case, parse_case
from vibeam.engine.records import summarize
from vibeam.models.core.scene_shooting import SceneShooting
from vibeam.models import make_solver, shooting_problem
from vibeam.models.registry import law_name, mixed_stops
from vibeam.models.compliant import HuntCrossley, LankaraniNikravesh
from vibeam.models.contact import DAMPING, EXPONENT, LAW, STIFFNESS, Relation, Restitution, Stop, pack
from vibeam.models import BeamEventSolver
from vibeam.models import EventSolver
from vibeam.models.builders.sdof import sdof
from vibeam.models.scene import one_mode, outputs
from vibeam.models.core.isolated import isolated_contact
from vibeam.models.core.laws import force
from vibeam.models.paper.ode import DirectSolver

FIG8 = dict(beta=0.015, B=0.5e-3, Delta=0.7e-3)      # paper Fig. 8 scene (as tests/test_continuation_compliant.py)


def chi_ln(R):
    """``chi = 3 (1 - R^2) / 4`` (Lankarani & Nikravesh 1990, Eq. 21 with D = chi k delta^p / v_in)."""
    return 3.0 * (1.0 - R * R) / 4.0


# ---------------------------------------------------------------------------- (a) the force
def test_force_and_kernel_row_against_the_hand_formula():
    """The law's chi and the force the kernels evaluate from its stop row (``DAMPING`` = chi)
    equal ``k delta^p (1 + 3 (1 - R^2) / 4 delta' / v_in)`` by hand (to rounding, 1e-14): the one
    force of the kernels (:func:`vibeam.models.core.laws.force`, event, direct and shooting)."""
    for R, k, p, d, dd, v in ((0.9, 1e6, 1.5, 2e-4, -3e-3, 0.01), (0.5, 2e4, 1.0, 1e-3, 0.2, 0.5),
                              (0.99, 1e8, 2.0, 3e-6, 1e-4, 1e-3)):
        law = LankaraniNikravesh(k, R, p)
        assert law.chi == pytest.approx(chi_ln(R), rel=1e-15) and law.name == "lankarani_nikravesh"
        row = pack([Stop(Relation(1.0, 0.0), law)])[0][0]
        assert row[STIFFNESS] == k and row[EXPONENT] == p and row[DAMPING] == pytest.approx(chi_ln(R), rel=1e-15)
        hand = k * d ** p * (1.0 + 0.75 * (1.0 - R * R) * dd / v)
        code = int(row[LAW])
        assert force(code, d, dd, row[STIFFNESS], row[DAMPING], row[EXPONENT], v) == pytest.approx(hand, rel=1e-14)
        assert force(code, -d, dd, k, law.chi, p, v) == 0.0          # no force outside the stop
    # the same family as Hunt-Crossley, another chi: 3 (1 - R^2) / 4 vs 8 (1 - R) / (5 R)
    assert LankaraniNikravesh(1.0, 0.8).family == HuntCrossley(1.0, 0.8).family == "hysteretic_hertz"
    assert LankaraniNikravesh(1.0, 0.8).chi == pytest.approx(0.27) and HuntCrossley(1.0, 0.8).chi == pytest.approx(0.4)


# ---------------------------------------------------------------------------- (b) restitution
def _restitution_ivp(k, p, chi, v, ks=0.0):
    """Restitution of one contact entered at ``delta = 0`` with ``delta' = v`` by solve_ivp
    (DOP853, rtol 1e-10): ``delta'' = -ks delta - k delta^p (1 + chi delta' / v)`` until the
    force returns to zero (``delta = 0`` or ``1 + chi delta' / v = 0`` falling); ``ks`` the
    oscillator's own stiffness (the SDOF's, 1; 0 for the stop alone)."""
    def rhs(t, y):
        return [y[1], -ks * y[0] - k * max(y[0], 0.0) ** p * (1.0 + chi * y[1] / v)]

    def gap(t, y):
        return y[0]

    def factor(t, y):
        return 1.0 + chi * y[1] / v

    for e in (gap, factor):
        e.terminal, e.direction = True, -1
    T = 20.0 * ((p + 1.0) * v * v / (2.0 * k)) ** (1.0 / (p + 1.0)) / v     # 20 x the Hertz time scale
    s = solve_ivp(rhs, (0.0, T), [0.0, v], method="DOP853", rtol=1e-10, atol=1e-14 * v * T, events=[gap, factor],
                  first_step=1e-6 * T)
    assert s.status == 1
    y = s.y_events[0][0] if s.t_events[0].size else s.y_events[1][0]
    return -y[1] / v


@pytest.mark.parametrize("R", [0.999, 0.99, 0.95, 0.9, 0.72, 0.5])
def test_isolated_restitution_kernel_against_solve_ivp(R):
    """One contact of a unit mass on the stop alone with the law's chi: the event kernel's own
    contact step (DOPRI5 at rtol 1e-11) against solve_ivp (rtol 1e-10) to 1e-8 (measured
    <= 1.5e-10), independent of k_c and v_in (the damping chi / v_in makes it scale-free)."""
    chi = LankaraniNikravesh(1.0, R).chi
    Rs = []
    for k, v in ((1e4, 1.0), (1e8, 1e-3)):
        Rk = isolated_contact(LankaraniNikravesh(k, R, 1.5), v)[0]
        assert Rk == pytest.approx(_restitution_ivp(k, 1.5, chi, v), abs=1e-8)
        Rs.append(Rk)
    assert abs(Rs[0] - Rs[1]) <= 1e-10


def test_restitution_tends_to_the_target_as_R_tends_to_1_and_is_biased_below():
    """LN's chi comes from a first-order energy balance (valid for 1 - R << 1): the realised
    loss (1 - R_eff) over the target's (1 - R) tends to 1 as R -> 1, with a deficit of about
    1.5 (1 - R) (measured 0.9985 at R = 0.999, 0.985 at 0.99, 0.930 at 0.95, 0.868 at 0.9;
    bounded here by 2 (1 - R)); below, the law under-damps: R_eff = 0.805 for a target 0.72,
    0.725 for 0.5 (the known bias of LN at low R; Flores et al. 2011), while Hunt-Crossley with
    Flores' chi stays within 0.03 (tests/test_compliant.py)."""
    ratios = []
    for R in (0.999, 0.99, 0.95, 0.9):
        Re = isolated_contact(LankaraniNikravesh(1e6, R, 1.5), 0.1)[0]
        ratio = (1.0 - Re) / (1.0 - R)
        assert abs(ratio - 1.0) <= 2.0 * (1.0 - R)
        ratios.append(ratio)
    assert all(a > b for a, b in zip(ratios, ratios[1:]))      # the error grows with 1 - R
    assert ratios[0] > 0.998
    low = {R: isolated_contact(LankaraniNikravesh(1e6, R, 1.5), 0.1)[0] for R in (0.72, 0.5)}
    assert low[0.72] == pytest.approx(0.8052, abs=1e-3) and low[0.5] == pytest.approx(0.7252, abs=1e-3)


def test_sdof_impact_from_rest_event_kernel_against_solve_ivp():
    """The full SDOF event solver, undamped and unforced, released from rest at q = -0.01 below
    a stop at 0 (Lankarani-Nikravesh, k_c = 1e6, R = 0.9): it reaches the stop at v = 0.01,
    and the next entry velocity (free flight conserves energy between two passages through
    q = 0) is R_eff 0.01.  R_eff against solve_ivp of the contact ODE with the oscillator's
    spring (rtol 1e-10) to 1e-7 (measured ~1e-10), and against the work recorded by the kernel,
    R_eff = sqrt(1 - 2 E / v^2), to 1e-8."""
    law = LankaraniNikravesh(1e6, 0.9)
    sc = sdof(beta=0.0, B=0.0, Delta=0.0, law=law)
    tr = EventSolver(sc).point(1.0, np.array([-0.01, 0.0, 0.0]), 0, 1, 64)
    assert tr.status == "ok" and tr.n_impacts >= 2
    v0, v1 = tr.impact_velocities[:2]
    assert v0 == pytest.approx(0.01, rel=1e-12)
    Re = v1 / v0
    assert Re == pytest.approx(_restitution_ivp(law.stiffness, 1.5, law.chi, v0, ks=1.0), abs=1e-7)
    assert Re == pytest.approx(math.sqrt(1.0 - 2.0 * tr.contacts[0, 3] / v0 ** 2), abs=1e-8)
    assert abs(Re - 0.9132) < 1e-3       # the isolated contact's 0.91318, the oscillator's spring adds ~1e-5


# ---------------------------------------------------------------------------- (c) event vs direct
@pytest.mark.parametrize("k,W,Delta", [(1e4, 2.0, 0.0), (1e6, 1.7, 0.0), (1e5, 2.3, 0.001)])
def test_event_agrees_with_direct_on_a_frequency_response_point(k, W, Delta):
    """Free flight exact, contact by DOPRI5 (rtol 1e-11) against solve_ivp DOP853 (rtol 1e-11):
    samples to 1e-7 of the orbit and contact records to 1e-7 relative, the Hunt-Crossley
    test's tolerances (tests/test_compliant.py), through make_solver (the registry's family)."""
    sc = sdof(beta=0.015, B=5e-4, Delta=Delta, law=LankaraniNikravesh(k, 0.9))
    ev, di = make_solver(sc, "event"), make_solver(sc, "direct")
    assert isinstance(ev, EventSolver) and isinstance(di, DirectSolver)
    a = ev.point(W, None, 4, 4, 32)
    b = di.point(W, None, 4, 4, 32)
    assert a.status == b.status == "ok" and a.n_impacts == b.n_impacts >= 3
    assert np.max(np.abs(a.samples - b.samples)) <= 1e-7 * np.max(np.abs(a.samples))
    n = min(a.contacts.shape[0], b.contacts.shape[0])
    np.testing.assert_allclose(a.contacts[:n], b.contacts[:n], rtol=1e-7)


# ---------------------------------------------------------------------------- (d) continuation
def _settled(sc, W, periods=1500, x0=None):
    s0 = None if x0 is None else np.array([x0[0], x0[1], 0.0])
    tr = EventSolver(sc).point(W, s0, periods, 16, 16)
    return np.asarray(tr.final_state[:2], float), summarize(tr, one_mode(sc).Delta)


@pytest.mark.slow     # the Lankarani-Nikravesh shooting tangent: compiled by this test alone (~1 min cold)
def test_continued_orbit_is_the_settled_event_orbit():
    """Fig. 8 scene on a Lankarani-Nikravesh stop (k_c = 1e6, R = 0.9): the family's shooting
    problem (registry) returns the event kernel's settled state at Omega = 1.9 to 1e-9 (DOP853 at
    rtol 1e-12 vs the kernel's DOPRI5 at 1e-11; measured 8.5e-12); the branch traced to 1.95
    ends on a stable orbit whose amplitude is the long event run's from 1 % off it to 1e-9
    (measured 1.4e-10), the Hunt-Crossley checks' tolerance."""
    from vibeam.models.orbits.continuation import Settings, trace

    sc = sdof(**FIG8, law=LankaraniNikravesh(1e6, 0.9))
    x0, sm = _settled(sc, 1.9)
    assert sm["period"] == 1
    prob = shooting_problem(sc, "Omega")
    assert isinstance(prob, SceneShooting) and prob.setup(1.9).core.kstops.cc[0] == pytest.approx(chi_ln(0.9))
    s = prob.shot(x0, 1.9, 1)
    assert s.status == "ok" and s.n_impacts == 1
    assert np.max(np.abs(s.x - x0)) < 1e-9 * np.max(np.abs(x0))
    b = trace(prob, x0, 1.9, 1, 1.9, 1.95, +1, Settings(switch=False))[0]
    assert b.status == "range_end"
    A = b.arrays()
    pt = b.points[-1]
    assert A["stable"][-1] and pt.p == pytest.approx(1.95)
    _, sm = _settled(sc, pt.p, x0=pt.x * 1.01)
    assert sm["period"] == 1 and sm["amplitude"] == pytest.approx(A["amplitude"][-1], rel=1e-9)


# ---------------------------------------------------------------------------- (e) the beam
def _rig(over):
    case, _ = load_case("cases/rig-fe-neutral.toml")
    return case.model_spec(over).scene()


def test_one_mode_beam_is_the_sdof_scene():
    """A one-mode beam on a Lankarani-Nikravesh stop is the SDOF on the mapped stop (the mapping
    of tests/test_beam_hc.py: tau = sqrt(k) t, q = x / L_q, stiffness w^2 k_c L_q^(p-1) / k):
    same samples (velocities times sqrt(k)) to 1e-10 of the orbit, same contact times to 1e-9
    relative, the Hunt-Crossley test's tolerances (two DOPRI5 at rtol 1e-11 in other units)."""
    m = _rig({"n_modes": 1, "contact": {"law": "lankarani_nikravesh", "stiffness_n_m": 1e8}})
    law, sy = m.stops[0].law, m.system
    assert law_name(m) == "lankarani_nikravesh" and law.chi == pytest.approx(chi_ln(law.R))
    k1, c1, w1, s1, G1 = sy.omega[0] ** 2, sy.damping[0], sy.contacts[0, 0], sy.sensor[0], sy.participation[0]
    L, Y, D = sy.length_unit_m, sy.base_amplitude, m.stops[0].relation.offset
    p, kc = 1.5, 1e8 / (2 * math.pi * sy.reference_hz) ** 2
    Lq = w1 * L / s1
    sq = math.sqrt(k1)
    sd = sdof(beta=c1 / (2 * sq), B=w1 * G1 * Y / Lq, Delta=D / Lq,
              law=LankaraniNikravesh(w1 ** 2 * kc * Lq ** (p - 1) / k1, law.R, p))
    W = 15.4 / 7.6
    ev = make_solver(m, "event")
    assert isinstance(ev, BeamEventSolver)
    a = ev.point(W, None, 20, 4, 32)
    b = EventSolver(sd).point(W / sq, None, 20, 4, 32)
    assert a.status == b.status == "ok" and a.n_impacts == b.n_impacts >= 3
    assert np.max(np.abs(a.samples[:, 0] - b.samples[:, 0])) <= 1e-10 * np.max(np.abs(a.samples[:, 0]))
    assert np.max(np.abs(a.samples[:, 1] - sq * b.samples[:, 1])) <= 1e-10 * np.max(np.abs(a.samples[:, 1]))
    np.testing.assert_allclose(sq * a.impact_times, b.impact_times, rtol=1e-9)


def test_two_mode_beam_event_agrees_with_direct():
    """Rig FE beam with 2 modes on a Hertzian Lankarani-Nikravesh stop (1e8 N/m^1.5), 15.4 Hz
    from rest, 1 + 2 periods: exact free flight + DOPRI5 contact against solve_ivp DOP853 on the
    whole system: samples to 1e-8 of the orbit, contact records to 1e-8 relative (the
    Hunt-Crossley beam test's tolerances, tests/test_beam_hc.py)."""
    m = _rig({"n_modes": 2, "contact": {"law": "lankarani_nikravesh", "stiffness_n_m": 1e8}})
    W = 15.4 / m.system.reference_hz
    a = make_solver(m, "event").point(W, None, 1, 2, 32)
    b = make_solver(m, "direct").point(W, None, 1, 2, 32)
    assert a.status == b.status == "ok" and a.n_impacts == b.n_impacts >= 1
    assert np.max(np.abs(a.samples - b.samples)) <= 1e-8 * np.max(np.abs(a.samples))
    n = min(a.contacts.shape[0], b.contacts.shape[0])
    np.testing.assert_allclose(a.contacts[:n], b.contacts[:n], rtol=1e-8)


# ---------------------------------------------------------------------------- (f) two stops, mixed
@pytest.mark.parametrize("lower", ["lankarani_nikravesh", "hunt_crossley", "newton"])
def test_sdof_two_stops_and_beside_a_newton_stop(lower):
    """SDOF with a Lankarani-Nikravesh upper stop and, below, another one, a Hunt-Crossley one
    (two laws of one family, each its own chi) or Newton's law (mixed): event against direct,
    both stops hit, samples to 1e-7 of the orbit (tests/test_matrix.py's tolerance; measured
    1.0e-8, 2.5e-10, 1.3e-10)."""
    kw = {"R_lower": 0.5} if lower == "newton" else \
        {"contact_lower": (LankaraniNikravesh if lower == "lankarani_nikravesh" else HuntCrossley)(3e4, 0.9)}
    lower_law = Restitution(0.5) if lower == "newton" else kw["contact_lower"]
    sc = sdof(beta=0.015, B=5e-3, Delta=0.002, law=LankaraniNikravesh(1e5, 0.8), Delta_lower=0.003,
              lower_law=lower_law)
    assert mixed_stops(sc) == (lower == "newton")
    a = make_solver(sc, "event").point(0.75, None, 4, 4, 32)
    b = make_solver(sc, "direct").point(0.75, None, 4, 4, 32)
    assert a.status == b.status == "ok" and a.n_impacts > a.n_impacts_lower >= 1
    assert np.max(np.abs(a.samples - b.samples)) <= 1e-7 * np.max(np.abs(a.samples))


def test_beam_two_stops_event_and_continuation():
    """Rig FE beam with 2 modes, Lankarani-Nikravesh stops above (1e8 N/m^1.5) and 0.3 mm below
    (3e8 N/m^1.5) at 17 Hz (the scene of tests/test_continuation_hc_beam.py; LN's chi at the
    rig's R = 0.72 is 0.36 against Hunt-Crossley's 0.89, so the orbit settles more slowly:
    1000 periods): the event run settles on a period-2 orbit with two upper contacts and one
    lower contact, and its settled state is a fixed point of the family's two-stop shooting
    problem ``P^2`` to 1e-9 of the orbit (the Hunt-Crossley test's tolerance; measured 1.4e-11)."""
    m = _rig({"n_modes": 2, "gap_lower_mm": 0.3, "contact": {"law": "lankarani_nikravesh", "stiffness_n_m": 1e8},
              "contact_lower": {"law": "lankarani_nikravesh", "stiffness_n_m": 3e8}})
    assert m.stops[1].law.name == "lankarani_nikravesh"
    W = 17.0 / m.system.reference_hz
    tr = make_solver(m, "event").point(W, None, 1000, 4, 16)
    assert tr.status == "ok" and tr.final_state[-1] == 0.0 and tr.n_impacts_lower >= 1
    assert summarize(tr, outputs(m).Delta)["period"] == 2
    x = tr.final_state[:4]
    s = shooting_problem(m, "Omega", Omega=W).shot(x, W, 2)
    assert s.status == "ok" and s.n_impacts == 3 and list(s.extra["impact_stops"]).count(1) == 1, s.message
    assert np.max(np.abs(s.x - x)) < 1e-9 * float(np.max(np.abs(x)))


# ---------------------------------------------------------------------------- (g) case files
CASE = '''name = "ln"
[model]
fidelity = "sdof"
beta = 0.015
B = 5e-4
R = 0.9
Delta = 0.0

[model.contact]
law = "lankarani_nikravesh"
stiffness = 1e6
exponent = 1.5

[sweep]
Omega = [1.8, 2.0, 3]
transient_periods = 20
record_periods = 4

[[run]]
name = "event"
method = "event"
'''


def test_case_file_validates_and_wrong_keys_are_one_line(tmp_path):
    """A case file with law = "lankarani_nikravesh" validates and builds the law (target R from
    [model] R); a key of another law, an unknown law and a method the family lacks are refused
    in one line naming the key, the value and what is allowed."""
    p = tmp_path / "ln.toml"
    p.write_text(CASE)
    case, _ = load_case(str(p))
    sc = case.model_spec().scene()
    law = sc.stops[0].law
    contact = None if law.kind == "impulsive" else law
    assert contact == LankaraniNikravesh(1e6, 0.9, 1.5) and contact.name == "lankarani_nikravesh"
    for method in ("direct", "mapping", "continuation"):
        parse_case(CASE.replace('method = "event"', f'method = "{method}"'))
    bad = {
        CASE.replace("exponent = 1.5", "damping_ratio = 0.1"):
            ("'model.contact'", "damping_ratio = 0.1", "allowed keys: law, stiffness, stiffness_n_m, exponent"),
        CASE.replace('"lankarani_nikravesh"', '"lankarani"'):
            ("'model.contact.law'", "'lankarani'", "allowed: restitution, linear, hunt_crossley, lankarani_nikravesh"),
        CASE.replace("exponent = 1.5", "chi = 0.1"):
            ("'model.contact.chi'", "0.1", "allowed keys:"),
        CASE.replace('method = "event"', 'method = "averaging"'):
            ("'run[0].method'", "'averaging'", "allowed: event, direct, mapping"),
    }
    for text, parts in bad.items():
        with pytest.raises(CaseError) as e:
            parse_case(text)
        msg = str(e.value)
        assert "\n" not in msg and all(s in msg for s in parts), msg
    with pytest.raises(CaseError, match="needs R > 0 .chi = 3 .1 - R\\^2. / 4"):
        parse_case(CASE.replace("R = 0.9", "R = 0.0")).model_spec().scene()


def test_mapping_fixed_point_is_the_settled_event_orbit():
    """Method ``mapping`` (the family's entry-to-entry map, registry) on a Lankarani-Nikravesh
    stop (k_c = 1e4, R = 0.9, Omega = 1.8): its period-1 fixed point is the event kernel's
    orbit settled over 400 periods -- amplitude, entry speed and the contact record to 1e-8
    relative, the Hunt-Crossley test's tolerance (tests/test_hc_mapping.py)."""
    from vibeam.models.mapping import MappingSolver

    sc = sdof(beta=0.015, B=0.5e-3, Delta=0.0, law=LankaraniNikravesh(1e4, 0.9))
    s = make_solver(sc, "mapping")
    assert isinstance(s, MappingSolver)
    out = s.point(1.8, None, 0, 0)
    assert out["status"] == "ok" and out["period"] == 1 and out["stable"]
    se = summarize(EventSolver(sc).point(1.8, None, 400, 8, 64), 0.0)
    assert se["period"] == 1 and se["status"] == "ok"
    for key in ("amplitude", "q_max", "impact_velocity", "contact_duration", "contact_force_max",
                "penetration_max", "energy_per_impact"):
        assert out[key] == pytest.approx(se[key], rel=1e-8), key
