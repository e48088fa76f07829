"""The pointwise mapping of the N-mode system (vibeam.models.mapping.modal; issue 43's matrix: the
beam's Newton rows).  Oracles: the SDOF's own mapping (other sections, other code: (t, v) sections,
certified scans) on the one-mode system; central differences of the residual for its Jacobian;
Liouville's formula (tests/test_matrix.py) and the event integrator's settled orbits (there)."""
from __future__ import annotations

import copy
import sys
from pathlib import Path

import numpy as np
import pytest

import vibeam
from vibeam.models import make_solver
from vibeam.models.mapping.modal import ModalMap
from vibeam.models.scene import one_mode, outputs

sys.path.insert(0, str(Path(__file__).resolve().parent))
from test_matrix import case_of  # noqa: E402


def _sdof(R=0.8):
    return vibeam.load_case({"name": "m", "model": {"fidelity": "sdof", "beta": 0.015, "B": 5e-3, "R": R,
                                                    "Delta": 0.002},
                             "sweep": {"Omega": [0.75, 0.8, 2]}, "run": [{"name": "m", "method": "mapping"}]}
                            ).model_spec().scene()


@pytest.mark.parametrize("Omega", [0.75, 1.2])
def test_the_one_mode_map_is_the_sdofs_map(Omega):
    """On the SDOF as the one-mode system (its builder's scene), Newton on the N-mode residual from a
    guess 1 % off the SDOF mapping's orbit converges to it: the section's time to 1e-10 of the
    period and its arrival speed to 1e-10 relative (measured <= 9e-16), and the monodromy's Floquet
    multipliers equal the SDOF map's (saltation of paper Eq. 2 times the flow of Eq. 28) to 1e-9
    of the largest (measured <= 2e-14).  Both are exact flows; the bounds leave room for the
    transition entries' relative precision over a period."""
    model = _sdof()
    ref = make_solver(model, "mapping").point(Omega, None, 0, 0)
    assert ref["status"] == "ok" and ref["period"] == 1, ref["message"]
    fs = np.asarray(ref["final_state"], float)
    fs = fs.reshape(1, 2) if fs.size == 2 else fs.reshape(-1, 3)[:, :2]     # (phase, v) per section
    m = fs.shape[0]
    phi, v = fs[:, 0], fs[:, 1]
    mp = ModalMap(model.system, model.stops, Omega)
    stops = (0,) * m
    X0 = np.concatenate([phi / Omega * 1.01, np.column_stack([np.full(m, one_mode(model).Delta), 1.01 * v]).ravel()])
    X, ok = mp.newton(X0, stops, 1)
    assert ok
    xs = X[m:].reshape(m, 2)
    assert np.max(np.abs(X[:m] - phi / Omega)) <= 1e-10 * mp.T
    np.testing.assert_allclose(xs[:, 0], one_mode(model).Delta, rtol=1e-12)
    np.testing.assert_allclose(xs[:, 1], v, rtol=1e-10)
    mu = np.linalg.eigvals(mp.monodromy(X, stops, 1))
    mu = mu[np.argsort(-np.abs(mu))]
    assert np.max(np.abs(mu - ref["multipliers"])) <= 1e-9 * np.max(np.abs(mu)), (mu, ref["multipliers"])


def test_the_residuals_jacobian_is_its_derivative():
    """The analytic Jacobian of the multiple-shooting residual against central differences on the
    2-mode beam with a point stop (the 14 sections of its period-1 orbit at 17 Hz, perturbed so that
    no term vanishes): every column to 1e-6 of the Jacobian's largest entry (the differences'
    truncation and round-off at steps 1e-6 of each unknown's scale: 7e-12 measured)."""
    model = vibeam.load_case(case_of("beam", "restitution", "point", ["mapping"])).model_spec().scene()
    W = 17.0 / model.system.reference_hz
    s = make_solver(model, "mapping")
    out = s.point(W, None, 0, 0)
    assert out["status"] == "ok", out["message"]
    N2 = 2 * outputs(model).n_modes
    fs = out["final_state"].reshape(-1, N2 + 2)
    stops = tuple(int(k) for k in fs[:, -1])
    m = len(stops)
    mp = ModalMap(s.system, s.stops, W)
    rng = np.random.default_rng(1)
    X = np.concatenate([fs[:, 0] / W, fs[:, 1:N2 + 1].ravel()])
    scale = np.concatenate([np.full(m, mp.T), np.full(m * N2, np.max(np.abs(X[m:])))])
    X = X + 1e-3 * scale * rng.uniform(-1, 1, X.size) * np.r_[np.full(m, 1e-2), np.ones(m * N2)]
    _, J = mp.residual(X, stops, 1)
    D = np.empty_like(J)
    for i in range(X.size):
        h = 1e-6 * scale[i]
        e = np.zeros(X.size)
        e[i] = h
        D[:, i] = (mp.residual(X + e, stops, 1, jac=False)[0] - mp.residual(X - e, stops, 1, jac=False)[0]) / (2 * h)
    assert np.max(np.abs(J - D)) <= 1e-6 * np.max(np.abs(J)), np.max(np.abs(J - D)) / np.max(np.abs(J))


def test_a_beam_that_never_reaches_its_stop_is_a_failed_point_not_a_number():
    """The 2-mode beam with its stop 50 mm away never impacts: the mapping has no section, so the
    point is ``failed`` with the reason and every number NaN (no ``ok`` with a number it could not
    compute)."""
    d = case_of("beam", "restitution", "one", ["mapping"])
    d = copy.deepcopy(d)
    d["model"]["gap_mm"] = 50.0
    model = vibeam.load_case(d).model_spec().scene()
    out = make_solver(model, "mapping").point(17.0 / model.system.reference_hz, None, 0, 0)
    assert out["status"] == "failed" and "no impact" in out["message"], out["message"]
    assert np.isnan(out["amplitude"]) and np.isnan(out["impact_velocity"]) and not out["stable"]
    assert np.all(np.isnan(out["multipliers"]))


@pytest.mark.parametrize("law,stops", [("linear", "mixed"), ("restitution", "mixed"), ("linear", "point")])
def test_liouville_through_kelvin_voigt_contact_phases(law, stops):
    """The monodromy composed through Kelvin-Voigt contact phases: ``det M = prod_Newton R_k^2
    exp(-n T sum_i c_i - sum_KV c_c |n_k|^2 tau_j)`` (Liouville: the contact phase's state matrix
    adds ``-c_c n n^T`` to the damping, the entry's saltation has det 1), ``tau_j`` each section's
    contact duration; the beam rows with a compliant stop at 17 Hz, to 1e-8: measured 3.5e-15 on the
    mixed rows, 2e-10 on the point row (19 sections: the determinant of a product of 38 factors whose
    multipliers span 1 ... 1e-8 loses digits to round-off; the formula's terms are exact)."""
    from vibeam.models.core.stops import kernel_stops

    model = vibeam.load_case(case_of("beam", law, stops, ["mapping"])).model_spec().scene()
    W = 17.0 / model.system.reference_hz
    ev = make_solver(model, "event").point(W, None, 600, 4, 32)
    s0 = make_solver(model, "mapping", n=1).point(W, None, 0, 0)
    n = 1 if s0["status"] == "ok" else 2
    s = make_solver(model, "mapping", n=n)
    out = s.point(W, None, 0, 0)
    assert out["status"] == "ok", (out["message"], ev.status)
    N2 = 2 * outputs(model).n_modes
    fs = out["final_state"].reshape(-1, N2 + 2)
    st = tuple(int(k) for k in fs[:, -1])
    mp = ModalMap(s.system, s.stops, W, n)
    X = np.concatenate([fs[:, 0] / W, fs[:, 1:N2 + 1].ravel()])
    ks = kernel_stops(s.system, s.stops)
    log_want = -np.sum(model.system.damping) * n * mp.T
    for j, k in enumerate(st):
        if mp.impulsive[k]:
            log_want += 2.0 * np.log(s.stops[k].law.R)
        else:
            tau = mp.passage(k, X[j], X[len(st):].reshape(-1, N2)[j]).t - X[j]
            assert tau > 0.0
            log_want -= ks.cc[k] * (ks.normal[k] @ ks.normal[k]) * tau
    assert any(not mp.impulsive[k] for k in st), st            # a contact phase is on the orbit
    det = np.linalg.det(mp.monodromy(X, st, n))
    assert abs(det / np.exp(log_want) - 1.0) <= 1e-8, (det, np.exp(log_want))
