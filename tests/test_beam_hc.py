"""Hunt-Crossley stop on the modal beam (issue 13): free flight exact, contact integrated.

Oracles: the solve_ivp reference (:class:`vibeam.models.core.direct.BeamODESolver` on :mod:`vibeam.models.core.direct`,
sharing no code with the kernel), the SDOF scene (an isolated contact of the free modes along
``w`` is that of one free mass on the law with stiffness ``k / m_eff``,
:func:`vibeam.models.core.isolated.isolated_contact`; a one-mode beam is an SDOF oscillator
after scaling), and the Flores relation's restitution (a function of chi only).
"""
from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from vibeam.models import make_solver
from vibeam.models.compliant import HuntCrossley
from vibeam.models.core.direct import BeamODESolver
from vibeam.models import BeamEventSolver
from vibeam.models.core.isolated import isolated_contact
from vibeam.models import EventSolver
from vibeam.models.builders.sdof import sdof
from vibeam.models.registry import law_name
from vibeam.models.scene import one_mode, outputs

# slow (the default test step's time): the compliant laws' shooting tangents and two-stop
# kernels are compiled by these tests alone (~4 min of cold compile on 2 cores); .ci/run runs them
pytestmark = pytest.mark.slow


def _rig(n_modes, k=1e8, R=None):
    from vibeam.case.schema import load_case

    case, _ = load_case("cases/rig-fe-neutral.toml")
    over = {"n_modes": n_modes, "contact": {"law": "hunt_crossley", "stiffness_n_m": k}}
    if R is not None:
        over["R"] = R
    return case.model_spec(over).scene()


def test_two_mode_beam_hc_event_agrees_with_the_direct_reference_on_one_point():
    """Default-step representative of the slow checks below (the file's scenes are slow only for
    the kernel's first compile, ~20 s once per machine; this one costs ~0.4 s after it): the rig
    FE beam with 2 modes on a Hertzian Hunt-Crossley stop (1e8 N/m^1.5, chi from R = 0.72) at
    15.4 Hz from rest, 1 transient + 2 recorded periods: exact free flight + DOPRI5 contact
    (rtol 1e-11) against solve_ivp DOP853 (rtol 1e-11) on the whole system, sharing no code:
    the same contacts, samples to 1e-8 of the orbit (measured 7.0e-11) and contact records
    (duration, peak force, penetration, work, entry velocity) to 1e-8 relative (measured
    1.5e-10), the slow test's tolerances."""
    m = _rig(2, 1e8)
    assert law_name(m) == "hunt_crossley" and outputs(m).n_modes == 2
    ev, di = make_solver(m, "event"), make_solver(m, "direct")
    assert isinstance(ev, BeamEventSolver) and isinstance(di, BeamODESolver)
    W = 15.4 / 7.6
    a = ev.point(W, None, 1, 2, 32)
    b = di.point(W, None, 1, 2, 32)
    assert a.status == b.status == "ok" and a.n_impacts == b.n_impacts >= 2
    assert a.contacts.shape == b.contacts.shape and a.contacts.shape[0] >= 2
    assert np.max(np.abs(a.samples - b.samples)) <= 1e-8 * np.max(np.abs(a.samples))
    np.testing.assert_allclose(a.contacts, b.contacts, rtol=1e-8)


@pytest.mark.slow
@pytest.mark.parametrize("n_modes,k", [(1, 1e8), (2, 1e8), (2, 1e9)])
def test_beam_hc_event_agrees_with_the_direct_reference(n_modes, k):
    """Rig FE beam on a Hertzian Hunt-Crossley stop (N/m^1.5, chi from R = 0.72) from rest over
    8 periods: exact free flight + DOPRI5 contact (rtol 1e-11) against solve_ivp DOP853 (rtol
    1e-11) on the whole system: same contacts, samples to 1e-8 of the orbit (measured <= 9.8e-10),
    contact records (duration, peak force, penetration, work, entry velocity) to 1e-8 relative
    (measured <= 6.8e-10).  Slow step: the kernel's first compilation takes ~20 s."""
    m = _rig(n_modes, k)
    assert law_name(m) == "hunt_crossley"
    assert isinstance(make_solver(m, "event"), BeamEventSolver)
    W = 15.4 / 7.6
    a = make_solver(m, "event").point(W, None, 4, 4, 32)
    b = make_solver(m, "direct").point(W, None, 4, 4, 32)
    assert isinstance(make_solver(m, "direct"), BeamODESolver)
    assert a.status == b.status == "ok" and a.n_impacts == b.n_impacts >= 3
    assert np.max(np.abs(a.samples - b.samples)) <= 1e-8 * np.max(np.abs(a.samples))
    n = min(a.contacts.shape[0], b.contacts.shape[0])
    np.testing.assert_allclose(a.contacts[:n], b.contacts[:n], rtol=1e-8)


@pytest.mark.parametrize("n_modes,k,v", [pytest.param(2, 1e8, 0.01, marks=pytest.mark.slow),
                                         pytest.param(1, 1e9, 0.003, marks=pytest.mark.slow),
                                         pytest.param(4, 1e9, 0.003, marks=pytest.mark.slow)])
def test_isolated_beam_contact_has_the_sdof_restitution_for_the_same_chi(n_modes, k, v):
    """Along the normal w the stop acts on m_eff = 1 / |w|^2: the isolated contact of the free,
    unforced modes along w gives the restitution and duration of one free mass on the stop of
    stiffness k / m_eff (to 1e-10: both DOPRI5 at rtol 1e-11; measured ~1e-13), and the
    restitution is the Flores relation's value for chi alone (the same at every k and v: 0.7043
    for target 0.72)."""
    m = _rig(n_modes, k)
    law = m.stops[0].law
    kk = k / (2 * math.pi * m.system.reference_hz) ** 2
    assert law.exponent == 1.5
    Rb, dur_b = isolated_contact(replace(law, stiffness=kk), v, m.system.contacts[0])[:2]
    Rs, dur_s = isolated_contact(replace(law, stiffness=kk / outputs(m).m_eff), v)[:2]
    assert Rb == pytest.approx(Rs, abs=1e-10)
    assert dur_b == pytest.approx(dur_s, rel=1e-10)
    R0 = isolated_contact(replace(law, stiffness=1.0), 1.0)[0]
    assert Rb == pytest.approx(R0, abs=1e-10) and abs(Rb - 0.72) < 0.03


@pytest.mark.slow
def test_one_mode_beam_is_the_sdof_hunt_crossley_scene():
    """A one-mode beam ``x'' + c x' + k x + w^2 k_c (x - D)^p (1 + chi x' / v_in) = w Gamma F
    sin`` (``x = w eta``) is the SDOF scene with ``tau = sqrt(k) t``, ``q = x / L_q``
    (``L_q = w L / s``: q is the sensor over L), ``beta = c / (2 sqrt(k))``, ``Omega =
    Om / sqrt(k)``, ``B = w Gamma Y / L_q``, ``Delta = D / L_q`` and stiffness ``w^2 k_c
    L_q^(p-1) / k``; the velocity floors coincide.  Same samples (velocities times sqrt(k)) to
    1e-10 of the orbit (measured 5e-14: both contact phases by DOPRI5 at rtol 1e-11, in
    different variables and error norms), same contact times (measured 1e-15 relative)."""
    m = _rig(1, 1e8)
    sy = m.system
    k1, c1, w1, s1, G1 = sy.omega[0] ** 2, sy.damping[0], sy.contacts[0, 0], sy.sensor[0], sy.participation[0]
    L, Y, D = sy.length_unit_m, sy.base_amplitude, m.stops[0].relation.offset
    p, kc = 1.5, 1e8 / (2 * math.pi * sy.reference_hz) ** 2
    Lq = w1 * L / s1
    sq = math.sqrt(k1)
    sd = sdof(c1 / (2 * sq), w1 * G1 * Y / Lq, D / Lq,
              law=HuntCrossley(w1 ** 2 * kc * Lq ** (p - 1) / k1, m.stops[0].law.R, p))
    assert one_mode(sd).B > 0.0
    W = 15.4 / 7.6
    a = make_solver(m, "event").point(W, None, 20, 4, 32)
    b = EventSolver(sd).point(W / sq, None, 20, 4, 32)
    assert a.status == b.status == "ok" and a.n_impacts == b.n_impacts >= 3
    scale = np.max(np.abs(a.samples[:, 0]))
    assert np.max(np.abs(a.samples[:, 0] - b.samples[:, 0])) <= 1e-10 * scale
    assert np.max(np.abs(a.samples[:, 1] - sq * b.samples[:, 1])) <= 1e-10 * np.max(np.abs(a.samples[:, 1]))
    np.testing.assert_allclose(sq * a.impact_times, b.impact_times, rtol=1e-9)
