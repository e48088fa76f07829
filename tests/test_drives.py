"""The drives of the modal system (issue 58, step 1): ``f Omega^p A sin(Omega t)`` with ``p = 2`` (base
displacement, the paper's shaker) or ``p = 0`` (base acceleration, point force), and
:func:`vibeam.models.scene.driven`, which sets ``f``, ``A`` and ``p`` from an SI
:class:`~vibeam.models.scene.Excitation`.

Checks: Fig. 7 by the event integrator and its shots at ``p = 0, A = Omega^2 B`` equal ``p = 2``
bit for bit (the kernels read the drive only through ``F = Omega^p A``, the same double); a
3-DOF chain built from its matrices, driven by a point force and by a base acceleration with its
stop out of reach, against the physical frequency response solved from ``M``, ``C``, ``K``
directly; the tangent's ``dF`` of ``p = 0`` and the compliant floor's slope against central
differences of shots in ``Omega``; the unit conversions and refusals of :func:`driven`.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from vibeam.models.builders.matrices import build_matrices
from vibeam.models.builders.sdof import sdof
from vibeam.models.compliant import HuntCrossley
from vibeam.models.contact import Relation, Restitution, Stop
from vibeam.models.core.event import EventIntegrator, fundamental_step
from vibeam.models.core.shooting import Direction, ModalShooting, Setup, directions
from vibeam.models.scene import Excitation, Scene, driven
from vibeam.models.system import (drive_displacement, drive_force, drive_slope, drive_velocity_slope, forcing,
                                  modal_system)

FIG7 = dict(beta=0.015, B=0.5e-3, R=0.9, Delta=0.0)          # cases/paper-fig7.toml


def _accelerated(system, Om):
    """``system`` driven at ``p = 0`` by the amplitude that gives its displacement drive's forcing
    at ``Om``: ``A = Om * Om * B``, the very double the kernels form for ``p = 2``."""
    return system._replace(base_amplitude=Om * Om * system.base_amplitude, drive_power=0)


def _run(core, Om, n_transient=400, n_record=16, eta=None, etad=None):
    n = core.n
    eta = np.zeros(n) if eta is None else eta
    etad = np.zeros(n) if etad is None else etad
    return core.run(Om, eta, etad, 0, n_transient, n_record, 16, 64, fundamental_step(core.system), 20000 * 500,
                    20000 * 500, 1e-7)


# ============================================================================ the helpers
@pytest.mark.parametrize("p", [0, 2])
def test_drive_helpers_against_their_formulas(p):
    """``F = Omega^p A``, ``dF``, ``B_eq = Omega^(p-2) A`` and ``d log v`` (``v = Omega^(p-1) A``)
    against ``math.pow`` and central differences (step 1e-6 relative: truncation ~1e-12, round-off
    ~1e-10 relative, so rtol 1e-8); ``p = 2`` is the base-displacement expressions bit for bit."""
    A, Om = 0.37, 1.9
    assert drive_force.py_func(p, A, Om) == pytest.approx(Om ** p * A, rel=1e-15)
    assert drive_displacement.py_func(p, A, Om) == pytest.approx(Om ** (p - 2) * A, rel=1e-15)
    h = 1e-6
    for dOm, dA in ((1.0, 0.0), (0.0, 1.0), (0.3, -0.7)):
        fd = (drive_force.py_func(p, A + h * dA, Om + h * dOm) - drive_force.py_func(p, A - h * dA, Om - h * dOm)) / (2 * h)
        assert drive_slope.py_func(p, A, Om, dOm, dA) == pytest.approx(fd, rel=1e-8, abs=1e-12)

        def v(a, om):
            return om * drive_displacement.py_func(p, a, om)

        fd = (math.log(v(A + h * dA, Om + h * dOm)) - math.log(v(A - h * dA, Om - h * dOm))) / (2 * h)
        assert drive_velocity_slope.py_func(p, A, Om, dOm, dA) == pytest.approx(fd, rel=1e-8, abs=1e-12)
    if p == 2:
        assert drive_force.py_func(2, A, Om) == Om * Om * A
        assert drive_slope.py_func(2, A, Om, 0.3, -0.7) == 2.0 * Om * A * 0.3 + Om * Om * -0.7
        assert drive_displacement.py_func(2, A, Om) == A


def test_forcing_and_the_drive_power_field():
    """``forcing`` reads ``Omega^p A``; the default drive is the displacement drive; a drive power
    other than 0 or 2 is refused where a system is built and where the kernels' view is."""
    s = sdof(**FIG7).system
    assert s.drive_power == 2 and forcing(s, 2.1) == 2.1 * 2.1 * s.base_amplitude
    assert forcing(s._replace(drive_power=0), 2.1) == s.base_amplitude
    with pytest.raises(ValueError, match="drive_power = 1; allowed: 0 or 2"):
        modal_system([1.0], [0.1], [1.0], [1.0], [[1.0]], 1.0, drive_power=1)
    from vibeam.models.core.stops import kernel_system
    with pytest.raises(ValueError, match="drive_power = 3"):
        kernel_system(s._replace(drive_power=3))


# ============================================================================ (a) Fig. 7 by the event integrator
def test_fig7_acceleration_drive_equals_displacement_drive_by_the_event_integrator():
    """Fig. 7 (Omega 1.5 to 2.5, 21 points, 400 transient and 16 recorded periods, state carried
    up the sweep): ``p = 0`` with ``A = Omega^2 B`` per point against ``p = 2``.  Tolerance 0: both
    runs reach the kernels with the same ``F`` double, and the kernels read the drive only through
    ``F`` (and the compliant floor, absent here), so every output is the same bit for bit."""
    sc = sdof(**FIG7)
    core2 = EventIntegrator(sc)
    x2 = x0 = (np.zeros(1), np.zeros(1))
    impacts = 0
    for Om in np.linspace(1.5, 2.5, 21):
        Om = float(Om)
        core0 = EventIntegrator(Scene(_accelerated(sc.system, Om), sc.stops))
        a = _run(core2, Om, eta=x2[0], etad=x2[1])
        b = _run(core0, Om, eta=x0[0], etad=x0[1])
        assert a.status == b.status and a.n_impacts == b.n_impacts and a.n_impacts_total == b.n_impacts_total
        assert (a.s_min, a.s_max, a.held_end, a.n_steps) == (b.s_min, b.s_max, b.held_end, b.n_steps)
        np.testing.assert_array_equal(a.record.samples, b.record.samples)
        np.testing.assert_array_equal(np.concatenate([a.eta, a.etad]), np.concatenate([b.eta, b.etad]))
        impacts += a.n_impacts
        x2, x0 = (a.eta, a.etad), (b.eta, b.etad)
    assert impacts > 0          # the sweep impacts (Fig. 7's impacting branch)


def test_fig7_physical_acceleration_through_driven():
    """The physical Fig. 7 (f_n 10 Hz, L 0.1 m) driven by ``a = Omega~^2 Y`` (Y = B L) through
    :func:`driven`: ``A = a T^2 / L`` equals ``Omega^2 B`` to round-off (three roundings, 1e-15
    relative), and the event run's extremes agree to 1e-12 relative (an F that differs by ulps
    moves the period-1 orbit by as much, times the conditioning of the impact map)."""
    sc = sdof(**FIG7, natural_frequency_hz=10.0, length_m=0.1)
    s = sc.system
    Om = 2.0
    a = (Om / s.time_unit_s) ** 2 * (s.base_amplitude * s.length_unit_m)
    sa = driven(s, Excitation("base_acceleration", a))
    assert sa.drive_power == 0 and np.array_equal(sa.participation, s.participation)
    assert sa.base_amplitude == pytest.approx(Om * Om * s.base_amplitude, rel=1e-15)
    sd = driven(s, Excitation("base_displacement", s.base_amplitude * s.length_unit_m))
    assert sd.drive_power == 2 and sd.base_amplitude == pytest.approx(s.base_amplitude, rel=1e-15)
    r2 = _run(EventIntegrator(sc), Om)
    r0 = _run(EventIntegrator(Scene(sa, sc.stops)), Om)
    assert r2.n_impacts == r0.n_impacts > 0
    assert r0.s_min == pytest.approx(r2.s_min, rel=1e-12) and r0.s_max == pytest.approx(r2.s_max, rel=1e-12)


def test_direct_integrator_acceleration_drive_equals_displacement_drive():
    """The direct integrator (solve_ivp with events, :mod:`vibeam.models.core.direct`) on Fig. 7 with
    a Hunt-Crossley stop (k 1e4, target R 0.9) at Omega = 2, 20 transient and 2 recorded periods:
    ``p = 0``, ``A = Omega^2 B`` against ``p = 2``.  The forcing ``F`` is the same double; the
    entry-velocity floor ``Omega B_eq`` differs by at most an ulp (``B_eq = A / Omega^2``), and the
    floor is not reached here (entries far above 1e-2 of the base velocity): samples, contacts and
    end state to 1e-13 relative (measured: equal)."""
    from vibeam.models.core.direct import DirectIntegrator

    sc = sdof(FIG7["beta"], FIG7["B"], FIG7["Delta"], law=HuntCrossley(1e4, 0.9))
    Om = 2.0
    laws_ = [s_.law for s_ in sc.stops]
    out = []
    for system in (sc.system, _accelerated(sc.system, Om)):
        di = DirectIntegrator(EventIntegrator(Scene(system, sc.stops)))
        out.append(di.run(Om, np.zeros(3), 20, 2, 32, 1.0, lambda k: laws_[k]))
    a, b = out
    assert a.status == b.status == "ok" and a.n_impacts == b.n_impacts > 0
    np.testing.assert_allclose(b.samples, a.samples, rtol=0, atol=1e-13 * np.max(np.abs(a.samples)))
    np.testing.assert_allclose(b.final_state, a.final_state, rtol=0, atol=1e-13 * np.max(np.abs(a.final_state)))


# ============================================================================ shots
class _Shots(ModalShooting):
    """Shots of a scene in ``Omega`` (directions: Omega, then the drive's amplitude A)."""

    parameter = "Omega"
    index = 0

    def __init__(self, scene):
        super().__init__()
        self.core = EventIntegrator(scene)
        n, ns = self.core.n, self.core.n_stops
        z = np.zeros(ns)
        self.dim = 2 * n
        self.dirs = directions(self.core, [Direction("Omega", 1.0, 0.0, z, z, np.zeros(n)),
                                           Direction("A", 0.0, 1.0, z, z, np.zeros(n))])

    def setup(self, p):
        st = self.core.stops[0]
        return Setup(self.core, float(p), self.dirs, float(st.relation.offset), self.core.system.coordinate_scale)


def _on_orbit(scene, Om):
    r = _run(EventIntegrator(scene), Om, n_transient=600, n_record=1)
    assert r.n_impacts > 0
    return np.concatenate([r.eta, r.etad])


def test_fig7_shot_state_and_monodromy_equal_at_both_drives():
    """A shot of Fig. 7 at Omega = 2 from a state on its period-1 orbit: ``p = 0``, ``A = Omega^2
    B`` against ``p = 2``: the state, the monodromy and the impacts bit for bit (tolerance 0, as
    the event runs: the same ``F``); the amplitude column ``x_A`` of ``p = 2`` is ``Omega^2`` times
    that of ``p = 0`` (``dF/dB = Omega^2``, ``dF/dA = 1``: 1e-13 relative, one rounding of the
    product and the ulp of ``Omega^2``); the ``Omega`` column differs by design (``dF = 2 Omega B
    dOmega`` against 0)."""
    sc = sdof(**FIG7)
    Om = 2.0
    x0 = _on_orbit(sc, Om)
    s2 = _Shots(sc).shot(x0, Om)
    s0 = _Shots(Scene(_accelerated(sc.system, Om), sc.stops)).shot(x0, Om)
    assert s2.status == s0.status == "ok"
    np.testing.assert_array_equal(s2.x, s0.x)
    np.testing.assert_array_equal(s2.M, s0.M)
    np.testing.assert_array_equal(s2.impact_times, s0.impact_times)
    assert s2.impact_times.size > 0
    xA2, xA0 = s2.extra["x_all_p"][:, 1], s0.extra["x_all_p"][:, 1]
    np.testing.assert_allclose(xA2, Om * Om * xA0, rtol=1e-13, atol=1e-13 * np.max(np.abs(xA2)))
    assert np.max(np.abs(s2.x_p - s0.x_p)) > 1e-3 * np.max(np.abs(s2.x_p))


def _central(prob, x0, Om, h):
    a, b = prob.shot(x0, Om + h, derivatives=False), prob.shot(x0, Om - h, derivatives=False)
    assert a.status == b.status == "ok" and a.impact_times.size == b.impact_times.size
    return (a.x - b.x) / (2 * h)


def test_acceleration_drive_tangent_in_omega_by_central_differences():
    """``d P / d Omega`` of the Fig. 7 SDOF driven at ``p = 0`` (fixed acceleration amplitude: ``dF
    = 0``) against central differences of shots in Omega from a fixed state (h = 1e-6: truncation
    ~h^2 |P'''| ~ 1e-10, round-off ~eps |P| / h ~ 1e-10 relative to |x_p| ~ 1: rtol 1e-6); the
    tangent of the displacement drive's ``dF`` (``2 Omega A``) would be off by the forcing's share,
    checked to be far above the tolerance."""
    sc = sdof(**FIG7)
    Om = 2.0
    sa = Scene(_accelerated(sc.system, Om), sc.stops)
    x0 = _on_orbit(sa, Om)
    prob = _Shots(sa)
    s = prob.shot(x0, Om)
    assert s.status == "ok" and s.impact_times.size > 0
    fd = _central(prob, x0, Om, 1e-6)
    np.testing.assert_allclose(s.x_p, fd, rtol=1e-6, atol=1e-6 * np.max(np.abs(fd)))
    # what the displacement drive's dF = 2 Omega A dOmega would add (x_A = d P / d F at p = 0)
    wrong = s.x_p + 2.0 * Om * sa.system.base_amplitude * s.extra["x_all_p"][:, 1]
    assert np.max(np.abs(wrong - fd)) > 1e-3 * np.max(np.abs(fd))


@pytest.mark.parametrize("floor", [1e-2, 10.0])
def test_acceleration_driven_compliant_sdof_tangent_by_central_differences(floor, monkeypatch):
    """A physical SDOF (f_n 10 Hz, L 0.1 m, beta 0.015, gap 0) with a Hunt-Crossley stop (k 1e4,
    target R 0.9, exponent 1.5), driven through :func:`driven` by a base acceleration of 40 m/s^2:
    the shot's ``d P / d Omega`` (the compliant phase's variational flow with ``dF = 0``) against
    central differences (h 1e-6, the Runge-Kutta phase to rtol 1e-11: rtol 1e-5).  With the
    entry-velocity floor raised from 1e-2 to 10 times the base-velocity amplitude ``A / Omega``
    (as tests/test_continuation_hc_beam.py does for the displacement drive) the contact is entered
    below it, so ``v_in`` is the floor and its slope ``dv/v = -dOmega/Omega`` (``p = 0``; ``+`` for
    ``p = 2``) enters the tangent."""
    import vibeam.models.core.laws as laws

    monkeypatch.setattr(laws, "V_FLOOR", floor)     # read when the scene's kernel data are built
    sc = sdof(beta=0.015, B=0.0, Delta=0.0, law=HuntCrossley(1e4, 0.9), natural_frequency_hz=10.0, length_m=0.1)
    sa = Scene(driven(sc.system, Excitation("base_acceleration", 40.0)), sc.stops)
    assert sa.system.drive_power == 0
    Om = 1.8
    x0 = _on_orbit(sa, Om)
    prob = _Shots(sa)
    s = prob.shot(x0, Om)
    assert s.status == "ok" and s.impact_velocities.size > 0
    v_floor = floor * sa.system.base_amplitude / Om          # |n^T f| = 1
    assert (np.max(s.impact_velocities) < v_floor) == (floor > 1.0)
    fd = _central(prob, x0, Om, 1e-6)
    np.testing.assert_allclose(s.x_p, fd, rtol=1e-5, atol=1e-5 * np.max(np.abs(fd)))


# ============================================================================ (c) a 3-DOF chain from its matrices
def _chain():
    """Masses 1, 2, 1.5 kg; springs 4e3 (to the base), 3e3, 2e3 N/m; Rayleigh C = 0.5 M + 2e-4 K
    (classical: the modal reduction is exact)."""
    m = np.array([1.0, 2.0, 1.5])
    k = np.array([4e3, 3e3, 2e3])
    K = np.zeros((3, 3))
    for i in range(3):
        K[i, i] += k[i]
        if i > 0:
            K[i - 1, i - 1] += k[i]
            K[i, i - 1] = K[i - 1, i] = -k[i]
    M = np.diag(m)
    return M, K, 0.5 * M + 2e-4 * K


@pytest.mark.parametrize("kind", ["force", "base_acceleration"])
def test_chain_linear_response_against_the_physical_closed_form(kind):
    """The chain (sensor mass 2, a Newton stop on mass 3 out of reach, a 2 N point force on mass 1
    or a base acceleration of 3 m/s^2), by the event integrator at 5 frequencies around its modes:
    the sensor's amplitude against ``|s^T (K - w^2 M + i w C)^-1 b|`` with ``b = F0 e_1`` or ``M r
    a`` (physical units, solved without modes).  600 transient periods at Omega >= 0.5 (slowest
    decay exp(-zeta_1 omega_1 t) < 1e-20 there), then exact extremes: rtol 1e-9 (the modal
    reduction's round-off over the conditioning of the response near a mode)."""
    M, K, C = _chain()
    mm = build_matrices(M, K, C=C, dofs=("m1", "m2", "m3"), sensor="m2", contacts=("m3", "m1"))
    s = mm.system
    amp = {"force": 2.0, "base_acceleration": 3.0}[kind]
    sd = driven(s, Excitation(kind, amp, 1 if kind == "force" else None))
    b = np.array([amp, 0.0, 0.0]) if kind == "force" else M @ np.ones(3) * amp
    assert sd.drive_power == 0
    np.testing.assert_array_equal(sd.participation, s.contacts[1] if kind == "force" else s.participation)
    stops = (Stop(Relation(1.0, 1.0, 0), Restitution(0.8)),)          # 1 m above mass 3: never reached
    core = EventIntegrator(Scene(sd, stops))
    om_ref = 1.0 / s.time_unit_s
    for Om in (0.5, 0.9, 1.0, 1.7, 2.4):
        r = _run(core, Om, n_transient=600, n_record=4)
        assert r.n_impacts_total == 0
        w = Om * om_ref
        X = np.linalg.solve(K - w * w * M + 1j * w * C, b)
        ref = abs(X[1])
        assert 0.5 * (r.s_max - r.s_min) == pytest.approx(ref, rel=1e-9)
        # and the modal closed form, |sum_i s_i f_i / (omega_i^2 - Omega^2 + i c_i Omega)| A
        modal = abs(np.sum(s.sensor * sd.participation / (s.omega ** 2 - Om * Om + 1j * s.damping * Om))) \
            * forcing(sd, Om)
        assert modal == pytest.approx(ref, rel=1e-12)


# ============================================================================ driven: units and refusals
def test_driven_units_for_the_sdof():
    """The physical SDOF (f_n 10 Hz, L 0.1 m, m 2 kg): a force F0 gives ``F0 / (m omega_n^2 L)``,
    an acceleration ``a / (omega_n^2 L)``, a displacement ``Y / L`` (1e-15 relative)."""
    s = sdof(**FIG7, natural_frequency_hz=10.0, length_m=0.1, mass_kg=2.0).system
    wn = 2 * math.pi * 10.0
    f = driven(s, Excitation("force", 3.0, 0))
    assert f.drive_power == 0 and f.base_amplitude == pytest.approx(3.0 / (2.0 * wn ** 2 * 0.1), rel=1e-15)
    np.testing.assert_array_equal(f.participation, s.contacts[0])
    a = driven(s, Excitation("base_acceleration", 5.0))
    assert a.base_amplitude == pytest.approx(5.0 / (wn ** 2 * 0.1), rel=1e-15)
    assert driven(s, Excitation("base_displacement", 2e-4)).base_amplitude == pytest.approx(2e-3, rel=1e-15)


@pytest.mark.parametrize("exc, system, message", [
    (Excitation("force", 1.0, 0), "no_mass", "excitation force: the system has no mass unit"),
    (Excitation("shaker", 1.0), "sdof", "excitation kind 'shaker'; allowed: base_displacement, "
                                        "base_acceleration, force"),
    (Excitation("base_acceleration", math.inf), "sdof", "excitation base_acceleration: amplitude = inf; allowed"),
    (Excitation("force", math.nan, 0), "sdof", "excitation force: amplitude = nan"),
    (Excitation("force", 1.0, 1), "sdof", "excitation force: at = 1; allowed: the index of one of"),
    (Excitation("force", 1.0), "sdof", "excitation force: at = None"),
    (Excitation("base_displacement", 1.0, 0), "sdof", "excitation base_displacement: at = 0; allowed: none"),
    (Excitation("base_acceleration", 1.0), "nondim", "excitation base_acceleration: the system has no length"),
])
def test_driven_refuses_in_one_line(exc, system, message):
    kw = dict(sdof=dict(natural_frequency_hz=10.0, length_m=0.1, mass_kg=2.0),
              no_mass=dict(natural_frequency_hz=10.0, length_m=0.1), nondim={})[system]
    s = sdof(**FIG7, **kw).system
    with pytest.raises(ValueError, match=None) as e:
        driven(s, exc)
    assert str(e.value).startswith(message) and "\n" not in str(e.value)
