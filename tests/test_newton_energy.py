"""Energy lost per impact under Newton's law on the modal beam (issue 13, per-point contact outputs).

Oracle: the jump of the modal kinetic energy ``|eta'|^2 / 2`` (mass-normalised modes) over each
impact, measured on the state of the solve_ivp solver (method ``direct``) before and after the
impulse; the event kernel's rows come from the closed form ``(1 - R^2) m_eff U-^2 / 2``
(:func:`vibeam.models.core.event.newton_contact_rows`); for the one-mode rung the SDOF's
``(1 - R^2) U-^2 / 2`` (paper Eqs. 42-46).
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from vibeam.models.builders.beam_fe import BeamFE, BeamGeometry
from vibeam.models.core.direct import BeamODESolver
from vibeam.models import BeamEventSolver
from vibeam.models import EventSolver
from vibeam.models.builders.beam import fe_beam, mass_stops, static_mode_beam
from vibeam.models.builders.sdof import sdof
from vibeam.models.contact import Restitution
from vibeam.models.scene import outputs
from vibeam.engine.records import summarize
from vibeam.reductions.static_mode import reduce_static_mode, static_mode_shape

L, LS, LM = 0.18, 0.10, 0.132
D_S = 2 * 0.017 / (2 * math.pi * 7.6)
PHIM = float(static_mode_shape(LM / L, LM / L, LS / L))
Y = 5.16e-4 * PHIM * L * 0.6


def _geom():
    return BeamGeometry(length_m=L, EI_n_m2=0.38465, rhoA_kg_m=0.157, mass_kg=0.2,
                        rotary_inertia_kg_m2=2.103e-5, mass_position_m=LM, sensor_position_m=LS)


@pytest.fixture(scope="module")
def fe():
    return BeamFE(_geom(), n_elements=24, damping_D_s=D_S)


def _rows_formula(v, R):
    return 0.5 * (1.0 - R ** 2) * v ** 2


@pytest.mark.parametrize("gap, gap_lower, R_lower, f_hz", [(0.0, None, None, 15.5), (0.1e-3, 0.1e-3, 0.4, 15.0)])
def test_beam_newton_energy_is_the_modal_kinetic_energy_jump(fe, gap, gap_lower, R_lower, f_hz):
    """Two modes (one stop; two stops with their own R): ``direct`` records the kinetic-energy
    jump of its modal state at each impact, which equals (1 - R_k^2) v^2 / 2 of the stop hit to
    1e-12 relative (an identity of the impulse through the mass matrix: round-off only, measured
    <= 3e-15); the event kernel's rows (closed form) equal direct's impact by impact to 1e-7
    (both trajectories agree to 1e-8 in the impact speeds, tests/test_two_sided.py; measured
    <= 6e-12); and summarize's ``energy_per_impact`` is their mean (two stops: the upper stop's
    rows, ``energy_per_impact_lower`` the lower stop's)."""
    m = fe_beam(fe, 2, mass_stops(gap, Restitution(0.72), gap_lower,
                                  None if R_lower is None else Restitution(R_lower)), base_amplitude_m=Y)
    s0 = np.zeros(5)
    s0[0] = -0.05e-3 / m.system.contacts[0][0]
    W = f_hz / m.system.reference_hz
    a = BeamEventSolver(m).point(W, s0, 20, 8, 32)
    b = BeamODESolver(m, solver="DOP853", rtol=1e-10, atol=1e-14).point(W, s0, 20, 8, 32)
    assert a.n_impacts == b.n_impacts >= 8 and a.status == b.status == "ok"
    Rk = np.full(b.n_impacts, 0.72)
    if gap_lower is not None:
        assert b.n_impacts_lower > 0
        Rk[b.impact_stops == 1] = R_lower
        np.testing.assert_array_equal(a.impact_stops, b.impact_stops)
    np.testing.assert_allclose(b.contacts[:, 3], _rows_formula(b.impact_velocities, Rk), rtol=1e-12)
    np.testing.assert_allclose(a.contacts[:, 3], b.contacts[:, 3], rtol=1e-7)
    np.testing.assert_allclose(a.contacts[:, 4], a.impact_velocities, rtol=0)
    out = summarize(a, outputs(m).Delta)
    if gap_lower is None:
        assert out["energy_per_impact"] == pytest.approx(np.mean(a.contacts[:, 3]), rel=1e-15)
    else:   # two stops: the unprefixed outputs are the upper stop's, *_lower the lower stop's
        k = a.impact_stops
        assert out["energy_per_impact"] == pytest.approx(np.mean(a.contacts[k == 0, 3]), rel=1e-15)
        assert out["energy_per_impact_lower"] == pytest.approx(np.mean(a.contacts[k == 1, 3]), rel=1e-15)
    assert out["contact_duration"] == 0.0 and out["penetration_max"] == 0.0
    assert math.isnan(out["contact_force_max"])


@pytest.mark.parametrize("R, R_lower, gap, gap_lower, f", [(0.72, None, 0.0, None, 15.3),
                                                          (0.72, 0.3, 0.1e-3, 0.1e-3, 14.0)])
def test_one_mode_beam_energy_is_the_sdof_energy(R, R_lower, gap, gap_lower, f):
    """The static-mode beam is the SDOF of its derived parameters (paper Eqs. 42-46, m_eff = m,
    time unit 1 / omega_n): the same impacts, so the same energy lost per impact, to 1e-9
    relative (the impact speeds agree to round-off amplified by the orbit; measured <= 6e-15).
    The units differ by the coordinate only: the beam's row is per m_eff L^2 with the contact
    speed U_C = phi_c q' (phi_c = phi(x_m) / phi(x_s), the static mode normalised at the
    sensor), the SDOF's per unit mass of q, so beam = phi_c^2 SDOF (the same joules:
    m_eff U_C^2 = (phi_c^2 m_eff) q'^2)."""
    g = _geom()
    sm = static_mode_beam(g, mass_stops(gap, Restitution(R), gap_lower, None if R_lower is None else Restitution(R_lower)),
                          base_amplitude_m=Y, damping_D_s=D_S)
    red = reduce_static_mode(g, damping_D_s=D_S, gap_contact_m=gap, gamma_tilde_m_per_V=Y)
    sd = sdof(red.beta_S, red.gamma_per_V, red.Delta, R,
              Delta_lower=None if gap_lower is None else gap_lower / PHIM / L,
              lower_law=None if R_lower is None else Restitution(R_lower))
    W = f / sm.system.reference_hz
    a = BeamEventSolver(sm).point(W, None, 200, 8, 64)
    b = EventSolver(sd).point(W, None, 200, 8, 64)
    assert a.n_impacts == b.n_impacts > 0
    if gap_lower is not None:
        assert a.n_impacts_lower > 0
    phi_c = float(sm.system.contact_static[0])
    pc2 = phi_c ** 2
    np.testing.assert_allclose(a.impact_velocities, phi_c * b.impact_velocities, rtol=1e-9)
    np.testing.assert_allclose(a.contacts[:, 3], pc2 * b.contacts[:, 3], rtol=1e-9)
    assert summarize(a, outputs(sm).Delta)["energy_per_impact"] == pytest.approx(
        pc2 * summarize(b, red.Delta)["energy_per_impact"], rel=1e-9)


def test_physical_beam_scene_records_joules():
    """A physical beam run stores ``energy_per_impact_j``: for a period-1 orbit it is the
    modal kinetic energy lost at the impact in SI, (1 - R^2) m_eff U-^2 / 2 with m_eff = 1 /
    |w|^2 in kg and U- in m/s (the kernel's ``impact_velocity_m_s``), to 1e-8."""
    from vibeam.case.schema import load_case
    from vibeam.models import make_solver
    from vibeam.engine.sweep import Sweep, run_sweep

    case, _ = load_case("cases/rig-fe-neutral.toml")
    m = case.model_spec({"n_modes": 2}).scene()
    W = 16.0 / m.system.reference_hz
    res = run_sweep(make_solver(m, "event"), Sweep(Omega=np.array([W]), transient_periods=300,
                                                   record_periods=4), jobs=1)
    d = res.data
    assert d["period"][0] == 1 and d["impacts_per_period"][0] == 1
    tr = make_solver(m, "event").point(W, None, 300, 4, 64)
    U = tr.extra["impact_velocity_m_s"]
    # the sweep settles the same orbit (its own transient) to far better than 1e-8
    R, m_eff = m.stops[0].law.R, outputs(m).m_eff
    assert d["energy_per_impact_j"][0] == pytest.approx(0.5 * (1 - R ** 2) * m_eff * U ** 2, rel=1e-8)
