"""A structure of the user's own, given by its matrices (issue 58): ``cases/chain-3dof.toml``.

The 3-DOF chain (three 0.2 kg masses on 2000 N/m springs, 2 % modal damping, base displacement
0.05 mm, a Newton stop 0.5 mm above the last mass, R = 0.8) is read from its MatrixMarket files
through the canonical tables (``[model.system] builder = "matrices"``, ``[[model.stop]] at``,
``[model.excitation]``), reduced to its modes and simulated by the exact event-driven modal
integrator.  The oracle is an independent integration of the physical equations written here,

    ``M x'' + C x' + K x = M 1 Omega~^2 Y sin(Omega~ t~)``   (x relative to the base),
    ``x_3 = gap, x_3' > 0  ->  x_3' <- -R x_3'``             (Newton's law on mass 3),

by :func:`scipy.integrate.solve_ivp` (DOP853, rtol 1e-12) with event location, with
``C = M Phi diag(2 zeta omega) Phi^T M`` (the same modal damping, built from numpy's own
eigenvectors).  With every mode kept the modal impulse along ``M^-1 w`` is exactly the physical
one (mass 3's velocity reversed by R, the others unchanged), so the two must agree to the
integrators' accuracy on a settled period-1 orbit.
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
from vibeam.models import make_solver

ROOT = Path(__file__).resolve().parents[1]
CASE = ROOT / "cases" / "chain-3dof.toml"
TWO_PI = 2.0 * math.pi


def _physical():
    M = np.asarray(scipy.io.mmread(ROOT / "cases" / "chain-3dof" / "M.mtx"))
    K = np.asarray(scipy.io.mmread(ROOT / "cases" / "chain-3dof" / "K.mtx"))
    lam, Phi = scipy.linalg.eigh(K, M)
    om = np.sqrt(lam)
    C = M @ Phi @ np.diag(2 * 0.02 * om) @ Phi.T @ M
    return M, K, C


def _orbit(x0, v0, f_hz, periods, Y=0.05e-3, gap=0.5e-3, R=0.8, load=None):
    """The physical chain's motion from (x0, v0) over ``periods`` forcing periods: the state at
    each period's end and the lowest/highest x_3 of the last period.  ``load``: the amplitude (N)
    of the force ``load sin(W t)`` on the masses (default the base displacement's ``M 1 W^2 Y``)."""
    M, K, C = _physical()
    Minv = np.linalg.inv(M)
    W = TWO_PI * f_hz
    load = M @ np.ones(3) * W * W * Y if load is None else np.asarray(load, float)

    def rhs(t, y):
        x, v = y[:3], y[3:]
        return np.concatenate([v, Minv @ (load * math.sin(W * t) - C @ v - K @ x)])

    def hit(t, y):
        return y[2] - gap
    hit.terminal = True
    hit.direction = 1.0

    T = 1.0 / f_hz
    y = np.concatenate([x0, v0])
    t = 0.0
    ends, lo, hi = [], np.inf, -np.inf
    for p in range(periods):
        t_end = (p + 1) * T
        while True:
            sol = solve_ivp(rhs, (t, t_end), y, method="DOP853", rtol=1e-12, atol=1e-16, events=hit,
                            dense_output=p == periods - 1)
            if p == periods - 1:
                tt = np.linspace(sol.t[0], sol.t[-1], 2001)
                x3 = sol.sol(tt)[2]
                lo, hi = min(lo, x3.min()), max(hi, x3.max())
            y = sol.y[:, -1].copy()
            t = sol.t[-1]
            if sol.status == 1:          # the stop: Newton's law on mass 3
                y[2] = gap
                y[5] = -R * y[5]
                continue
            break
        ends.append(y.copy())
    return np.array(ends), lo, hi


def test_the_case_reads_the_canonical_tables_and_builds_the_structure():
    case, _ = load_case(CASE)
    spec = case.model_spec()
    m = spec.build()
    assert m.fidelity == "matrices" and m.n_modes == 3
    # the chain's closed-form frequencies: 2 sqrt(k/m) sin((2j-1) pi / 14), j = 1, 2, 3
    f = np.sort(m.omega_rad_s) / TWO_PI
    exact = 2 * math.sqrt(2000 / 0.2) * np.sin(np.array([1, 3, 5]) * math.pi / 14) / TWO_PI
    assert np.allclose(f, exact, rtol=1e-12, atol=0)
    assert np.allclose(m.c_phys, 2 * 0.02 * 2 * math.pi * exact, rtol=1e-12)
    assert math.isclose(m.f_ref_hz, exact[0], rel_tol=1e-12)
    assert m.gap_contact_m == 0.5e-3 and m.base_amplitude_m == 0.05e-3
    one = case.model_spec(dict(case.run[1].model))   # [run.model.system] n_modes = 1, merged key by key
    assert one.system.builder == "matrices" and one.build().n_modes == 1


@pytest.mark.parametrize("f_hz", [7.1, 6.0])
def test_event_orbit_equals_an_independent_physical_integration(f_hz):
    """A settled orbit of the event integrator (a period-1 impacting one at 7.1 Hz, a linear one at
    6.0 Hz) is, in physical coordinates, a fixed point of the independent integration over one
    period, and its extremes of x_3 are the same: to 1e-9 of the gap (solve_ivp at rtol 1e-12
    with located events over one period of ~10 impacts' worth of dynamics carries ~1e-11 of the
    state; the event integrator is exact to round-off)."""
    case, _ = load_case(CASE)
    m = case.model_spec().build()
    sol = make_solver(m, "event")
    Om = f_hz / m.f_ref_hz
    tr = sol.point(Om, None, 600, 8, 64)
    assert tr.status == "ok"
    N = m.n_modes
    eta, etad = tr.final_state[:N], tr.final_state[N:2 * N]
    # modal -> physical: x = Phi eta, the shapes of the reduction (t = omega_ref t~)
    mm = case.model_spec().matrix_model()
    x0 = mm.shapes @ eta
    v0 = mm.shapes @ etad * (TWO_PI * m.f_ref_hz)
    ends, lo, hi = _orbit(x0, v0, f_hz, 1)
    scale = 0.5e-3
    assert np.max(np.abs(ends[-1][:3] - x0)) < 1e-9 * scale
    assert np.max(np.abs(ends[-1][3:] - v0)) < 1e-9 * scale * TWO_PI * f_hz
    L = 1e-3
    # the oracle's extremes from 2001 samples of its dense output over the period (a sampled extreme
    # of a swing of ~1 mm at 2001 samples is within ~1e-6 of it: (pi / 2000)^2 / 2)
    assert abs(tr.q_max * L - hi) < 2e-6 * scale
    assert abs(tr.q_min * L - lo) < 2e-6 * scale
    if f_hz == 7.1:
        assert tr.n_impacts >= 8 and abs(hi - 0.5e-3) < 1e-12       # it reaches the stop every period
    else:
        assert tr.n_impacts == 0 and hi < 0.5e-3


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
            c.model_spec().build()
        assert msg in str(e.value) and "\n" not in str(e.value), str(e.value)


def test_inline_matrices_give_the_same_structure():
    text = CASE.read_text().replace('M = "chain-3dof/M.mtx"', "M = [[0.2, 0.0, 0.0], [0.0, 0.2, 0.0], [0.0, 0.0, 0.2]]")
    text = text.replace('K = "chain-3dof/K.mtx"', "K = [[4000.0, -2000.0, 0.0], [-2000.0, 4000.0, -2000.0], "
                                                  "[0.0, -2000.0, 2000.0]]")
    a = parse_case(text).model_spec().build()
    b = load_case(CASE)[0].model_spec().build()
    assert np.array_equal(a.omega_rad_s, b.omega_rad_s) and np.array_equal(a.contact_row, b.contact_row)


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

    text = CASE.read_text().replace('"chain-3dof/', f'"{ROOT}/cases/chain-3dof/')
    head = text.split("\n[[run]]\n")[0]
    text = head + '\n[[run]]\nname = "3 modes"\nmethod = "continuation"\nstart = "sweep"\nstart_at = 7.1\nswitch = false\n'
    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
        conts = run_case(parse_case(text), text, tmp_path, jobs=1, quiet=True, plots=False, continuation_only=True)
    (r,) = conts
    case, _ = load_case(CASE)
    m = case.model_spec().build()
    mm = case.model_spec().matrix_model()
    from vibeam.models.periodic_beam import BeamContinuation

    prob = BeamContinuation(m)
    d = r.branches[0]["data"]
    k = len(d["parameter"]) // 2
    assert int(d["impacts"][k]) >= 1                                  # an impacting orbit
    x, W = np.asarray(d["state"][k], float), float(d["parameter"][k])
    f_hz = W * m.f_ref_hz
    shot = prob.shot(x, W, 1, derivatives=False)
    assert np.max(np.abs(shot.x - x)) < 1e-9 * np.max(np.abs(x))     # a periodic orbit
    N = m.n_modes
    w_ref = TWO_PI * m.f_ref_hz
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


def _drive(kind, **amp):
    text = CASE.read_text().replace('kind = "base_displacement"\namplitude_mm = 0.05', f'kind = "{kind}"\n' + "".join(
        f"{k} = {v!r}\n" for k, v in amp.items()))
    return parse_case(text.replace('"chain-3dof/', f'"{ROOT}/cases/chain-3dof/')).model_spec().build()


def test_a_base_acceleration_of_omega_squared_y_is_the_displacement_drive_at_that_frequency():
    """``[model.excitation] kind = "base_acceleration"``, ``a = (2 pi f)^2 Y``: at that frequency the
    forcing is the displacement drive's (the same double up to the rounding of a and A), so the
    event integrator's orbit is the same to round-off (1e-12 of the gap); at another frequency it
    differs (the acceleration is held, the displacement's forcing grows as f^2)."""
    f = 7.1
    a = (TWO_PI * f) ** 2 * 0.05e-3
    acc = _drive("base_acceleration", amplitude_m_s2=a)
    disp = load_case(CASE)[0].model_spec().build()
    for W, same in ((f / disp.f_ref_hz, True), (6.0 / disp.f_ref_hz, False)):
        ta = make_solver(acc, "event").point(W, None, 300, 4, 64)
        td = make_solver(disp, "event").point(W, None, 300, 4, 64)
        diff = np.max(np.abs(ta.samples - td.samples))
        assert (diff < 1e-12 * 0.5) == same, diff
    lin = acc.linear_sensor_amplitude_m(6.0 / acc.f_ref_hz)
    M, K, C = _physical()
    w = TWO_PI * 6.0
    exact = np.linalg.solve(K - w * w * M + 1j * w * C, M @ np.ones(3) * a)[2]
    assert abs(lin - abs(exact)) < 1e-12 * abs(exact)


def test_a_point_force_orbit_equals_the_independent_physical_integration():
    """``kind = "force"``, 1.5 N on m2 (``at = "m2"``): the settled impacting orbit of the event
    integrator is a fixed point of the physical integration with the force ``e_2 F0 sin(W t)``
    and Newton's law on mass 3, to 1e-9 of the gap (as the base drive's test)."""
    m = _drive("force", amplitude_n=1.5, at="m2")
    mm = load_case(CASE)[0].model_spec().matrix_model()
    f_hz = 7.1
    tr = make_solver(m, "event").point(f_hz / m.f_ref_hz, None, 600, 8, 64)
    assert tr.status == "ok" and tr.n_impacts >= 8
    N = m.n_modes
    x0 = mm.shapes @ tr.final_state[:N]
    v0 = mm.shapes @ tr.final_state[N:2 * N] * (TWO_PI * m.f_ref_hz)
    ends, lo, hi = _orbit(x0, v0, f_hz, 1, load=[0.0, 1.5, 0.0])
    assert np.max(np.abs(ends[-1][:3] - x0)) < 1e-9 * 0.5e-3
    assert np.max(np.abs(ends[-1][3:] - v0)) < 1e-9 * 0.5e-3 * TWO_PI * f_hz
    assert abs(hi - 0.5e-3) < 1e-12


def test_bad_excitations_are_refused_in_one_line():
    for kind, amp, msg in (("force", {"amplitude_n": 1.0}, "at"), ("force", {"amplitude_n": 1.0, "at": "m9"}, "m9"),
                           ("base_acceleration", {"amplitude_mm": 1.0}, "amplitude_m_s2")):
        with pytest.raises(CaseError) as e:
            _drive(kind, **amp)
        assert msg in str(e.value) and "\n" not in str(e.value), str(e.value)
