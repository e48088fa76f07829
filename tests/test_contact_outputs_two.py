"""Per-stop contact outputs of two-sided scenes (issue 13): ``contact_duration``,
``contact_force_max``, ``penetration_max``, ``energy_per_impact`` are the upper stop's and
``*_lower`` the lower stop's; one-stop results keep their meaning.

Oracles: the closed forms of an isolated impact on each stop (undamped Kelvin-Voigt: peak
force ``sqrt(k_c) v_in``, duration ``pi / sqrt(k_c)``, no energy lost; Newton's law: energy
lost ``(1 - R_k^2) v_k^2 / 2`` per unit mass), and the solve_ivp reference's own contact rows
(each tagged with its stop where the contact closes, independently of the kernel).
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from vibeam.models.compliant import LinearContact
from vibeam.models import EventSolver
from vibeam.models.builders.sdof import sdof
from vibeam.models.contact import Restitution
from vibeam.models.core.isolated import isolated_contact
from vibeam.models.scene import one_mode
from vibeam.models.paper.ode import DirectSolver
from vibeam.engine.records import CONTACT_OUTPUTS, CONTACT_OUTPUTS_LOWER, summarize

K_UP, K_LO = 1e4, 3e3


def _kv_two():
    """Upper stop Kelvin-Voigt k_c = 1e4 with target R = 0.8; lower stop undamped, k_c = 3e3."""
    return sdof(beta=0.015, B=5e-3, Delta=0.002, law=LinearContact.from_restitution(K_UP, 0.8), Delta_lower=0.003,
                lower_law=LinearContact.from_damping_ratio(K_LO, 0.0))


def test_two_compliant_stops_of_different_stiffness_give_each_stop_its_contact_outputs():
    """An orbit with contacts on both stops (6 upper, 4 lower in 4 periods).  Per stop, against
    the isolated-impact closed forms of the stop's own law at each contact's entry velocity:
    peak force, duration and energy to 3 % (the forcing B sin(Omega t) and the spring force
    q ~ Delta act during the contact: (B + Delta) / f_peak ~ 2 %; measured <= 1.4 %), and the
    undamped lower stop takes no energy (its work is round-off, <= 1e-12).  Against the
    solve_ivp reference's rows of the same stop: 1e-6 relative (measured ~1e-9)."""
    m = _kv_two()
    a = EventSolver(m).point(1.0, None, 4, 4, 32)
    b = DirectSolver(m).point(1.0, None, 4, 4, 32)
    assert a.status == b.status == "ok"
    np.testing.assert_array_equal(a.contact_stops, b.contact_stops)
    Delta = one_mode(m).Delta
    sa, sb = summarize(a, Delta), summarize(b, Delta)
    for k in CONTACT_OUTPUTS + CONTACT_OUTPUTS_LOWER:
        assert sa[k] == pytest.approx(sb[k], rel=1e-6, abs=1e-12), k
    c, ks = b.contacts, b.contact_stops            # the reference's rows, per stop
    up, lo = c[ks == 0], c[ks == 1]
    assert up.shape[0] >= 4 and lo.shape[0] >= 3
    # upper stop: damped, target R = 0.8
    law = m.stops[0].law
    iso = np.array([isolated_contact(law, v) for v in up[:, 4]])
    assert sa["contact_force_max"] == pytest.approx(np.max(iso[:, 2]), rel=3e-2)
    assert sa["contact_duration"] == pytest.approx(np.mean(iso[:, 1]), rel=3e-2)
    assert sa["energy_per_impact"] == pytest.approx(np.mean(0.5 * (1 - 0.8 ** 2) * up[:, 4] ** 2), rel=3e-2)
    assert sa["penetration_max"] == pytest.approx(np.max(iso[:, 3]), rel=3e-2)
    # lower stop: undamped
    assert sa["contact_force_max_lower"] == pytest.approx(math.sqrt(K_LO) * np.max(lo[:, 4]), rel=3e-2)
    assert sa["contact_duration_lower"] == pytest.approx(math.pi / math.sqrt(K_LO), rel=3e-2)
    assert sa["penetration_max_lower"] == pytest.approx(np.max(lo[:, 4]) / math.sqrt(K_LO), rel=3e-2)
    assert abs(sa["energy_per_impact_lower"]) <= 1e-12
    # the two stops' outputs are their own: the stiffer, damped upper stop has the larger force
    # per entry speed and the shorter contacts
    assert sa["contact_duration"] < 0.6 * sa["contact_duration_lower"]
    assert sa["contact_force_max"] != pytest.approx(sa["contact_force_max_lower"], rel=0.1)


def test_two_restitution_stops_give_each_stop_its_energy_per_impact():
    """Newton's law with R = 0.8 above and R_lower = 0.5 below: the energy lost per impact on
    each stop is the mean of (1 - R_k^2) v_k^2 / 2 over that stop's impacts (the impulse's
    closed form; rel 1e-12, round-off), duration and penetration 0, force NaN (an impulse)."""
    m = sdof(beta=0.015, B=5e-3, Delta=0.002, R=0.8, Delta_lower=0.003, lower_law=Restitution(0.5))
    t = EventSolver(m).point(1.0, None, 20, 8, 32)
    s = summarize(t, one_mode(m).Delta)
    v, k = t.impact_velocities, t.impact_stops
    assert np.sum(k == 0) >= 8 and np.sum(k == 1) >= 8
    assert s["energy_per_impact"] == pytest.approx(np.mean(0.5 * (1 - 0.8 ** 2) * v[k == 0] ** 2), rel=1e-12)
    assert s["energy_per_impact_lower"] == pytest.approx(np.mean(0.5 * (1 - 0.5 ** 2) * v[k == 1] ** 2), rel=1e-12)
    for sfx in ("", "_lower"):
        assert s["contact_duration" + sfx] == 0.0 and s["penetration_max" + sfx] == 0.0
        assert math.isnan(s["contact_force_max" + sfx])


def _impact_jumps(sc, t, Omega, ns, stop):
    """Pre- and post-impact speeds of the recorded impacts on ``stop`` (0 upper, 1 lower) from the
    kernel's *samples*, not its impact records: solve_ivp (DOP853, rtol 1e-12) of the free flight
    q'' + 2 beta q' + q = Omega^2 B sin(Omega t) forward from the sample before each impact and
    backward from the sample after it, to the stop (an event on q = Delta or q = -Delta_lower).
    Only impacts alone between their two samples are used.  Returns rows
    ``(t_impact, forward crossing time, backward crossing time, |q'-|, q'+ normal)``."""
    from scipy.integrate import solve_ivp

    m = one_mode(sc)
    T = 2 * math.pi / Omega
    ts = np.arange(t.samples.shape[0]) * T / ns
    F = Omega * Omega * m.B
    qs = m.Delta if stop == 0 else -m.Delta_lower
    sgn = 1.0 if stop == 0 else -1.0               # the stop's normal

    def rhs(tt, y):
        return [y[1], F * math.sin(Omega * tt) - 2 * m.beta * y[1] - y[0]]

    def hit(tt, y):
        return y[0] - qs
    hit.terminal = True

    rows = []
    imp, ks = t.impact_times, t.impact_stops
    for ti in imp[ks == stop]:
        a, b = np.searchsorted(ts, ti) - 1, np.searchsorted(ts, ti)
        if b >= ts.size or np.sum((imp > ts[a]) & (imp < ts[b])) != 1:
            continue
        opts = dict(method="DOP853", rtol=1e-12, atol=1e-16, events=hit, max_step=T / ns / 32)
        fw = solve_ivp(rhs, (ts[a], ts[b]), t.samples[a], **opts)
        bw = solve_ivp(rhs, (ts[b], ts[a]), t.samples[b], **opts)
        assert fw.t_events[0].size == 1 and bw.t_events[0].size == 1
        rows.append((ti, fw.t_events[0][0], bw.t_events[0][0], sgn * fw.y_events[0][0][1],
                     sgn * bw.y_events[0][0][1]))
    return np.array(rows).reshape(-1, 5)


@pytest.mark.parametrize("mixed", [False, True])
def test_each_stop_rebounds_with_its_own_R_in_the_trajectory(mixed):
    """The kernel's *motion* obeys each stop's own Newton law (R = 0.8 above, R_lower = 0.5 below;
    ``mixed``: a Kelvin-Voigt upper stop, k_c = 1e4, beside the restitution lower stop, method
    ``event`` of the compliant kernel): around every recorded impact alone between two samples,
    the free flight integrated by solve_ivp from the samples (forward from the one before,
    backward from the one after) meets the stop at the recorded impact time on both sides (1e-9;
    measured <= 1e-12), arrives with the recorded speed (1e-9 relative) and leaves with -R_k times
    it (1e-9; measured <= 6e-11, the slowest impact 2e-5), and the kinetic energy lost, (v-^2 -
    v+^2) / 2, averages to the stop's ``energy_per_impact`` (1e-9; measured 3e-14).  Scenario:
    13 upper and 8 lower impacts in 8 periods (8 lower in the mixed scene), each alone between
    two samples (32 per period).  Unlike the closed form
    (1 - R_k^2) v_k^2 / 2 on the kernel's own v_k, this fails if the kernel's lower impact uses the
    upper stop's R (the samples after it then leave at 0.8 v-)."""
    Omega, ns = 1.0, 32
    if mixed:
        m = sdof(beta=0.015, B=5e-3, Delta=0.002, law=LinearContact.from_restitution(1e4, 0.8), Delta_lower=0.003,
                 lower_law=Restitution(0.5))
        t = EventSolver(m).point(Omega, None, 20, 8, ns)
    else:
        m = sdof(beta=0.015, B=5e-3, Delta=0.002, R=0.8, Delta_lower=0.003, lower_law=Restitution(0.5))
        t = EventSolver(m).point(Omega, None, 20, 8, ns)
    assert t.status == "ok"
    s = summarize(t, one_mode(m).Delta)
    for stop, R, sfx in ((0, 0.8, ""), (1, 0.5, "_lower")):
        if mixed and stop == 0:
            continue                               # the compliant stop: contacts of finite duration
        j = _impact_jumps(m, t, Omega, ns, stop)
        assert j.shape[0] == np.sum(t.impact_stops == stop) >= 8     # every impact alone between two samples
        np.testing.assert_allclose(j[:, 1], j[:, 0], rtol=0, atol=1e-9)
        np.testing.assert_allclose(j[:, 2], j[:, 0], rtol=0, atol=1e-9)
        v_rec = t.impact_velocities[np.isin(t.impact_times, j[:, 0])]
        np.testing.assert_allclose(j[:, 3], v_rec, rtol=1e-9)
        np.testing.assert_allclose(-j[:, 4] / j[:, 3], R, rtol=1e-9)
        assert s["energy_per_impact" + sfx] == pytest.approx(np.mean(0.5 * (j[:, 3] ** 2 - j[:, 4] ** 2)), rel=1e-9)


def test_one_stop_results_have_no_lower_contact_outputs():
    """One stop: the unprefixed outputs cover its contacts as before, no ``*_lower`` keys."""
    m = sdof(beta=0.015, B=5e-4, Delta=0.0, law=LinearContact.from_restitution(1e4, 0.9))
    t = EventSolver(m).point(2.0, None, 8, 8, 32)
    s = summarize(t, one_mode(m).Delta)
    assert not any(k in s for k in CONTACT_OUTPUTS_LOWER)
    assert s["energy_per_impact"] == pytest.approx(np.mean(t.contacts[:, 3]), rel=1e-15)
    assert s["contact_force_max"] == np.max(t.contacts[:, 1])
