"""Independent oracles for properties the suite did not guard (issue 46).

Each test checks vibeam against something that shares no code with it: a closed form, an
own ``solve_ivp`` integration with events, LAPACK (``numpy.linalg.eigvals``), a hand-written
formula.  Each was run against the one-line mutation the issue describes and failed there
(recorded in the commit that added it).
"""
from __future__ import annotations
from vibeam.models import shooting_problem

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from vibeam.analysis.regress import compare
from vibeam.case.schema import parse_case
from vibeam.models.builders.sdof import sdof
from vibeam.models.scene import outputs

# ------------------------------------------------------------------ 1. a Hertz-family exponent

HC_CASE = '''
name = "hc"
[model]
fidelity = "sdof"
beta = 0.015
B = 0.5e-3
R = 0.9
Delta = 0.2e-3
[model.contact]
law = "hunt_crossley"
stiffness = {k}
exponent = {p}
[sweep]
Omega = [1.8, 2.2, 3]
transient_periods = 0
record_periods = 6
[[run]]
name = "exact"
method = "event"
'''


def _hertz_sdof_ivp(beta, B, Delta, W, k, p, chi, periods, spp):
    """The SDOF (paper Eq. 1) with a hysteretic-Hertz stop ``f = k g^p (1 + chi g' / v_in)``,
    ``g = q - Delta``, integrated here phase by phase by solve_ivp (DOP853) with events: a
    contact begins where ``g`` rises through 0 (``v_in`` = the entry speed) and ends where ``g``
    falls through 0 (the damping factor never reaches 0 at R = 0.9: asserted).  Returns the
    samples ``(q, q')`` at ``j T / spp`` and per contact ``(entry time, duration, largest
    penetration, entry speed)``."""
    T = 2 * math.pi / W
    F = W * W * B
    t_end = periods * T
    t_s = np.arange(periods * spp) * T / spp

    def free(t, y):
        return [y[1], -2 * beta * y[1] - y[0] + F * math.sin(W * t)]

    def contact(vin):
        def rhs(t, y):
            g = max(y[0] - Delta, 0.0)
            f = k * g ** p * (1.0 + chi * y[1] / vin)
            return [y[1], -2 * beta * y[1] - y[0] + F * math.sin(W * t) - f]
        return rhs

    def gap(t, y):
        return y[0] - Delta

    def factor(vin):
        return lambda t, y: 1.0 + chi * y[1] / vin

    def turn(t, y):               # g' = 0: the largest penetration
        return y[1]

    samples = np.full((t_s.size, 2), np.nan)
    contacts = []
    t, y = 0.0, np.array([0.0, 0.0])
    inside, vin, t_in, pen = False, 0.0, 0.0, 0.0
    tol = dict(method="DOP853", rtol=1e-12, atol=1e-16, dense_output=True)
    while t < t_end:
        if inside:
            ev_gap = lambda t_, y_: gap(t_, y_)
            ev_gap.terminal, ev_gap.direction = True, -1
            ev_f = factor(vin)
            ev_f.terminal, ev_f.direction = True, -1
            turn.terminal, turn.direction = False, -1
            # steps of 1/50 of the isolated contact's duration scale, so no sign change is missed
            scale = ((p + 1) * vin * vin / (2 * k)) ** (1 / (p + 1)) / vin
            sol = solve_ivp(contact(vin), (t, t_end), y, events=[ev_gap, ev_f, turn],
                            max_step=scale / 50, **tol)
            assert sol.t_events[1].size == 0      # the contact ends at g = 0, not by its damping
            for te in sol.t_events[2]:
                pen = max(pen, sol.sol(te)[0] - Delta)
        else:
            ev_gap = lambda t_, y_: gap(t_, y_)
            ev_gap.terminal, ev_gap.direction = True, +1
            sol = solve_ivp(free, (t, t_end), y, events=[ev_gap], max_step=T / 64, **tol)
        sel = (t_s >= t) & (t_s <= sol.t[-1])
        if sel.any():
            samples[sel] = sol.sol(t_s[sel]).T
        t, y = float(sol.t[-1]), sol.y[:, -1].copy()
        if sol.status == 1:                       # an event ended the phase
            if inside:
                contacts.append((t_in, t - t_in, pen, vin))
                y[0] = Delta                      # on the surface (the located root)
            else:
                y[0] = Delta
                vin, t_in, pen = float(y[1]), t, 0.0
            inside = not inside
    return samples, np.array(contacts)


@pytest.mark.parametrize("p", [1.2, 2.0])
def test_a_hertz_exponent_of_the_case_is_the_power_of_the_force(p):
    """A case's ``exponent`` (Hunt-Crossley, p = 1.2 and 2.0) is the power of the penetration in
    the contact force: the event solver's orbit from rest over 6 periods (Omega = 2, several
    contacts) against an own solve_ivp of ``q'' + 2 beta q' + q = Omega^2 B sin(Omega t) - k g^p (1
    + chi g' / v_in)``, ``chi = 8 (1 - R) / (5 R)`` (Flores et al. 2011, written here).  Samples to
    1e-7 of the orbit (both integrations at rtol ~1e-11 over ~10^3 steps; measured <= 6.6e-10),
    contacts' durations, penetrations, entry times and speeds to 1e-6 relative (event location
    and the contacts' steps; measured <= 3.4e-10).  With p = 1.5 in place of p the contacts'
    durations and penetrations differ by factors (~((p+1) v^2 / 2k)^(1/(p+1)) with v ~ 1e-3)."""
    from vibeam.models import make_solver

    k, R = 1e4, 0.9
    sc = parse_case(HC_CASE.format(k=k, p=p)).model_spec().scene()
    W, periods, spp = 2.0, 6, 32
    tr = make_solver(sc, "event").point(W, np.array([0.0, 0.0, 0.0]), 0, periods, spp)
    chi = 8 * (1 - R) / (5 * R)
    ref, con = _hertz_sdof_ivp(0.015, 0.5e-3, 0.2e-3, W, k, p, chi, periods, spp)
    assert tr.status == "ok" and con.shape[0] >= 4
    # the v_in floor (1e-2 Omega B) must not act, else the law differs from the one written here
    assert con[:, 3].min() > 10 * 1e-2 * W * 0.5e-3
    assert np.max(np.abs(tr.samples - ref)) <= 1e-7 * np.max(np.abs(ref))
    assert tr.contacts.shape[0] == con.shape[0]
    np.testing.assert_allclose(tr.impact_times, con[:, 0], rtol=1e-6)
    np.testing.assert_allclose(tr.contacts[:, 0], con[:, 1], rtol=1e-6)   # duration
    np.testing.assert_allclose(tr.contacts[:, 2], con[:, 2], rtol=1e-6)   # largest penetration
    np.testing.assert_allclose(tr.contacts[:, 4], con[:, 3], rtol=1e-6)   # entry speed
    assert (None if sc.stops[0].law.kind == "impulsive" else sc.stops[0].law).exponent == p


# ------------------------------------------------------------------ 2. Floquet multipliers' order

def _check_spectrum(mu, M):
    """``mu`` is LAPACK's set of eigenvalues of ``M`` (each matched to 1e-13 of the largest
    modulus: round-off of a 2 x 2 closed form against dgeev), by non-increasing modulus (ties
    within round-off), a complex pair with its positive imaginary part first (LAPACK's order)."""
    ref = np.linalg.eigvals(M)
    scale = np.abs(ref).max()
    dist = np.abs(mu[:, None] - ref[None, :])
    assert dist.min(axis=1).max() <= 1e-13 * scale and dist.min(axis=0).max() <= 1e-13 * scale, (mu, ref)
    assert np.all(np.diff(np.abs(mu)) <= 1e-13 * scale), (mu, ref)
    assert abs(mu[0]) == pytest.approx(np.abs(ref).max(), rel=1e-13)
    if abs(ref[0].imag) > 1e-12 * scale:
        assert mu[0].imag > 0.0 and mu[1] == pytest.approx(np.conj(mu[0]), rel=1e-13)


@pytest.mark.parametrize("M", [
    [[-0.9, 0.3], [0.1, -0.2]],          # negative trace, real pair (|mu| 0.94, 0.16)
    [[-1.3, 0.0], [0.0, 0.4]],           # negative trace, a flip beyond -1 and a stable one
    [[-0.1, 0.2], [0.3, -1.7]],          # negative trace, the larger one in the second row
    [[0.2, 0.5], [-0.5, 0.2]],           # complex pair, positive trace
    [[-0.6, 0.9], [-0.4, -0.3]],         # complex pair, negative trace
    [[0.5, 0.0], [0.0, -0.5]],           # real pair of equal modulus, opposite signs, trace 0
    [[-0.5, 1.0], [0.0, -0.5]],          # a double multiplier -0.5 (Jordan block)
    [[0.3, 0.2], [0.2, 0.3]],            # positive trace, real pair
    [[1e-3, 2.0], [-4.0, -1e-3]],        # complex pair of large modulus, trace 0
])
def test_floquet_multipliers_of_a_2x2_monodromy_against_lapack(M):
    """The continuation's 2 x 2 spectrum (closed form, vibeam.models.core.continuation_kernels._eig2
    through floquet_spectrum_small) against numpy.linalg.eigvals (LAPACK dgeev): the same set,
    by decreasing modulus, for negative traces, complex pairs and real pairs of equal modulus;
    ``det(M + I)`` against numpy.linalg.det; ``max |mu| - 1`` over the complex ones written out."""
    from vibeam.models.core.continuation_kernels import floquet_spectrum_small

    M = np.array(M, float)
    mu, pd, ns = floquet_spectrum_small(M)
    _check_spectrum(mu, M)
    assert pd == pytest.approx(np.linalg.det(M + np.eye(2)), rel=1e-13, abs=1e-15)
    ref = np.linalg.eigvals(M)
    if np.abs(ref.imag).max() > 0:
        assert ns == pytest.approx(np.abs(ref).max() - 1.0, rel=1e-12, abs=1e-15)
    else:
        assert math.isnan(ns)


def test_the_multipliers_of_a_continued_branch_through_its_period_doubling_against_lapack():
    """Fig. 13's period-1 branch (beta = 0.015, B = 0.5e-3, R = 0.9, Delta = 0.5e-3) continued in
    Omega from 2.25 across its period doubling (Omega ~ 2.281; one branch, no switching): every
    point's multipliers (the continuation's, stored on the point) are LAPACK's eigenvalues of that
    point's monodromy by decreasing modulus.  The whole branch has a negative trace (measured
    -0.96 ... -2.9): complex pairs before the doubling, a real pair beyond (-1.26 and -0.59 at
    2.285, mu_1 < -1), so both halves of the closed form's negative-trace case are exercised."""
    from vibeam.models.orbits.continuation import Settings, trace
    from vibeam.models import EventSolver

    fig13 = sdof(0.015, 0.5e-3, 0.5e-3, 0.9)
    prob = shooting_problem(fig13, "Omega")
    x0 = EventSolver(fig13).point(2.25, None, 1000, 1, 16).final_state[:2]
    branches = trace(prob, x0, 2.25, 1, 2.2, 2.32, +1, Settings(switch=False, max_points=60))
    pts = branches[0].points
    assert [f.type for f in branches[0].bifurcations] == ["period_doubling"]
    assert all(np.trace(p.shot.M) < 0.0 for p in pts)
    assert sum(abs(p.mu[0].imag) > 0 for p in pts) >= 3 and sum(p.mu[0].real < -1.0 for p in pts) >= 3
    for p in pts:
        _check_spectrum(np.asarray(p.mu), p.shot.M)


# ------------------------------------------------------------------ 3. Lyapunov exponents of period-n orbits

@pytest.mark.parametrize("W,n,impacts", [(2.285, 2, 2), (2.55, 3, 2)])
def test_lyapunov_exponents_of_period_2_and_3_orbits_are_their_floquet_exponents(W, n, impacts):
    """Fig. 13's scene (beta = 0.015, B = 0.5e-3, R = 0.9, Delta = 0.5e-3): a period-2 orbit at
    Omega = 2.285 (past the period doubling at 2.281; the attractor from rest) and a period-3 one at 2.55 (two impacts per
    orbit each), their fixed points of ``P^n`` refined by Newton.  The exact Lyapunov exponents
    of a periodic orbit are ``ln |mu_i| / (n T)``, ``mu`` the eigenvalues (numpy.linalg.eigvals)
    of the monodromy of ``P^n``: the QR estimate with 1, n and 2n forcing periods per shot (the
    model function and ``vibeam.lyapunov``'s ``n``) must lie within ``ln cond(V) / t`` of them
    (the singular values of ``M^K = V D^K V^-1`` are within cond(V) of ``|mu|^K``; module
    docstring of tests/test_lyapunov.py), plus 1e-12 of round-off; the sum within 1e-11 of
    ``sum ln |mu| / (n T)`` (Liouville: exact at every shot).  Measured: 5.9e-4 against a bound
    of 7.4e-4 (period 2), 1.1774e-3 against 1.1810e-3 (period 3; the bound is a theorem, so its
    closeness is no fragility); a shot of n periods counted as one period of time would scale
    the exponents by the periods per shot."""
    import vibeam
    from vibeam.models.orbits.lyapunov import lyapunov_spectrum
    from vibeam.models import EventSolver

    fig13 = sdof(0.015, 0.5e-3, 0.5e-3, 0.9)
    prob = shooting_problem(fig13, "Omega")
    x = EventSolver(fig13).point(W, None, 2000, 1, 16).final_state[:2]
    for _ in range(6):
        s = prob.shot(x, W, n)
        x = x - np.linalg.solve(s.M - np.eye(2), s.x - x)
    s = prob.shot(x, W, n)
    assert s.status == "ok" and s.impact_times.size == impacts
    assert np.max(np.abs(s.x - x)) < 1e-14 and np.max(np.abs(prob.shot(x, W, 1).x - x)) > 1e-5
    if n == 3:
        assert np.max(np.abs(prob.shot(x, W, 2).x - x)) > 1e-5    # not of period 1 or 2
    mu, V = np.linalg.eig(s.M)
    assert np.all(np.abs(mu) < 1.0)
    T = 2 * math.pi / W
    floquet = np.sort(np.log(np.abs(mu)) / (n * T))[::-1]
    periods = 1200
    for per_shot in (1, n, 2 * n):
        sp = lyapunov_spectrum(prob, x, W, periods // per_shot, n=per_shot)
        assert sp.status == "ok"
        bound = math.log(np.linalg.cond(V)) / (periods * T) + 1e-12
        assert np.all(np.abs(sp.exponents - floquet) <= bound), (per_shot, sp.exponents, floquet, bound)
        assert abs(sp.exponents.sum() - floquet.sum()) < 1e-11
        assert sp.time == pytest.approx(periods * T, rel=1e-12)
    # the API starts one period on (vibeam.simulate's final state): the bound of that point's
    # monodromy (the same multipliers, other eigenvectors), the largest over the orbit's points
    conds, y = [], x
    for _ in range(n):
        conds.append(np.linalg.cond(np.linalg.eig(prob.shot(y, W, n).M)[1]))
        y = prob.shot(y, W, 1).x
    api = vibeam.lyapunov(fig13, Omega=W, shots=periods // n, transient=0, state=np.r_[x, 0.0], n=n)
    bound = math.log(max(conds)) / (periods * T) + 1e-12
    assert api.status == "ok" and np.all(np.abs(api.exponents - floquet) <= bound), (api.exponents, floquet)
    assert api.impacts_per_period == pytest.approx(impacts / n, rel=1e-12)


# ------------------------------------------------------------------ 4. vibeam regress on NaN patterns

def _regress_file(tmp_path, name, rows):
    """A results file with one run of the given per-point rows (only what compare reads)."""
    from vibeam.engine.sweep import Sweep, SweepResult, stack
    from vibeam.io.results import write_results

    sw = Sweep(Omega=np.array([r["Omega"] for r in rows]), record_periods=16)
    res = SweepResult(name="exact", fidelity="sdof", method="event", settings={}, data=stack(rows, sw),
                      wall_time_s=0.0)
    return write_results(tmp_path / name, [res], "c", "")


def _regress_row(W, period, amp, mean=None, lo=None, hi=None):
    return dict(Omega=W, direction="up", period=period, status="ok", message="", amplitude=amp,
                amplitude_mean=amp if mean is None else mean, amplitude_std=0.1 if period == 0 else 0.0,
                amplitude_min=amp if lo is None else lo, amplitude_max=amp if hi is None else hi,
                record_periods=16)


NAN = float("nan")


@pytest.mark.parametrize("new,ref", [(NAN, 2.0), (2.0, NAN), (NAN, NAN), (2.0, 2.0)])
@pytest.mark.parametrize("key", ["amplitude", "amplitude_mean", "amplitude_min", "amplitude_max"])
def test_regress_fails_a_point_that_is_nan_on_one_side_only(tmp_path, capsys, key, new, ref):
    """The rule written out here (regress module docstring): a compared value passes when both
    sides are numbers within ``atol + rtol |ref|`` or both are NaN (the same failed point in
    both files); a NaN on one side only is a regression.  For a periodic point (period 1) its
    amplitude is compared, for a non-periodic one (period 0, compared by its spread) the mean,
    smallest and largest per-period amplitude, one of them NaN on one side (both sides NaN: a
    failed point, all of them NaN in both files); through compare() and ``vibeam regress``'s exit
    code (1 = regression)."""
    from vibeam.cli import main
    from vibeam.io.results import read_results

    periodic = key == "amplitude"

    both = new != new and ref != ref

    def row(v):
        if periodic:
            return _regress_row(1.0, 1, v)
        if both:      # a failed point: all its statistics NaN (the same in both files)
            return _regress_row(2.0, 0, NAN, NAN, NAN, NAN)
        vals = dict(amp=3.0, mean=3.0, lo=2.5, hi=3.5)
        vals[{"amplitude_mean": "mean", "amplitude_min": "lo", "amplitude_max": "hi"}[key]] = v + (
            {"amplitude_mean": 1.0, "amplitude_min": 0.5, "amplitude_max": 1.5}[key] if v == v else 0.0)
        return _regress_row(2.0, 0, **vals)

    d = tmp_path / "x"
    d.mkdir()
    f_ref = _regress_file(d, "ref.h5", [row(ref)])
    f_new = _regress_file(d, "new.h5", [row(new)])
    expected_fail = (new != new) != (ref != ref)
    r = compare(read_results(f_new), f_ref, atol=0.0, rtol=1e-6, period=True)[0]
    assert r.failures == int(expected_fail), (key, new, ref, r)
    case = d / "c.toml"
    case.write_text('name = "c"\n[model]\nfidelity = "sdof"\nbeta = 0.05\nB = 0.01\nR = 0.8\nDelta = 0.15\n'
                    '[sweep]\nOmega = [1.0, 2.0, 2]\n[[run]]\nname = "exact"\nmethod = "event"\n')
    assert main(["regress", str(case), "--reference", str(f_ref), "--results", str(f_new)]) == int(expected_fail)
    capsys.readouterr()


# ------------------------------------------------------------------ 5. the platform filter at f_ref != f_n

def test_the_platform_filter_is_normalised_at_its_reference_frequency():
    """``[effects.platform]`` with ``reference_frequency_hz = 12`` (the rig's f_n is 7.6 Hz):
    gamma(f) = gamma_ref |H(f)| / |H(f_ref)|, |H| = 1 / sqrt((1 - r^2)^2 + (2 zeta r)^2), r = f /
    f_p, written out here (paper Sec. 5.2); so gamma(f_ref) = gamma_ref, the scene's gain.  Per
    point (effective_gain) and the run attribute gain_ratio_2fn_to_fn to 1e-13 (round-off of a
    few operations; normalising at f_n instead moves them by |H(12)| / |H(7.6)| ~ 0.35), and the
    point at 14 Hz is the plain scene with its gain set by hand to gamma(14) (amplitude to 1e-12:
    the same computation once the gain is the same)."""
    from vibeam.case.schema import EffectsSpec, load_case
    from vibeam.engine.effects import wrap_solver
    from vibeam.engine.sweep import Sweep, run_sweep
    from vibeam.models import make_solver

    def H(f, fp=3.25, z=0.05):
        r = np.asarray(f, float) / fp
        return 1.0 / np.sqrt((1.0 - r * r) ** 2 + (2.0 * z * r) ** 2)

    case, _ = load_case("cases/rig-neutral.toml")
    spec = case.model_spec({"gain": 1.5e-3})
    sc = spec.scene()
    fn = outputs(sc).natural_frequency_hz
    assert abs(fn - 12.0) > 1.0
    eff = EffectsSpec.model_validate({"platform": {"frequency_hz": 3.25, "damping_ratio": 0.05,
                                                   "reference_frequency_hz": 12.0}})
    s = wrap_solver(make_solver(sc, "event"), sc, spec, eff, {})
    f = np.array([12.0, 14.0, 16.5])
    sw = dict(transient_periods=60, record_periods=8, continuation=False)
    res = run_sweep(s, Sweep(Omega=f / fn, **sw), jobs=1)
    np.testing.assert_allclose(res.data["effective_gain"], 1.5e-3 * H(f) / H(12.0), rtol=1e-13)
    assert res.data["effective_gain"][0] == pytest.approx(1.5e-3, rel=1e-13)
    assert s.run_attrs["gain_ratio_2fn_to_fn"] == pytest.approx(float(H(2 * fn) / H(fn)), rel=1e-13)
    assert s.run_attrs["platform_reference_frequency_hz"] == 12.0
    g14 = float(1.5e-3 * H(14.0) / H(12.0))
    m14 = case.model_spec({"gain": g14}).scene()
    plain = run_sweep(make_solver(m14, "event"), Sweep(Omega=np.array([14.0 / fn]), **sw), jobs=1)
    assert plain.data["amplitude"][0] == pytest.approx(res.data["amplitude"][1], rel=1e-12)


# ------------------------------------------------------------------ 7. a beam point stop (position_mm)

POINT_RIG = """name = "point"
[model]
fidelity = "beam"
length_mm = 180.0
sensor_position_mm = 100.0
mass_position_mm = 132.0
width_mm = 20.0
thickness_mm = 1.0
gain = 5.16e-4
voltage = 0.6
damping_ratio = 0.017
n_modes = {n_modes}
n_elements = 24
[model.discs]
count = 4
thickness_mm = 7.0
diameter_mm = 35.0
mass_kg = 0.2
[model.calibrate]
f1_hz = 7.6
f2_hz = 98.75
[[model.stop]]
side = "upper"
gap_mm = 5.0
R = 0.72
[[model.stop]]
side = "upper"
position_mm = {x}
gap_mm = {gap}
R = 0.9
[sweep]
frequency_hz = [14.0, 17.0, 5]
[[run]]
name = "event"
method = "event"
"""


def _phi_static(x, xm, xs):
    """The cantilever's deflection under a point load at ``xm`` (Timoshenko & Gere), normalised to
    1 at the sensor ``xs``: the static mode of paper Eq. 42, written out here."""
    def y(u):
        return u * u * (3 * xm - u) / 6 if u <= xm else xm * xm * (3 * u - xm) / 6
    return y(x) / y(xs)


def _hermite_row(fe, V, x):
    """Displacement at ``x`` of the free-DOF vectors ``V`` by the cubic Hermite shape functions of
    the element holding ``x`` (written out here; DOFs ``w``, ``w'`` per node)."""
    p = fe.mesh.p[0]
    e = int(np.searchsorted(p, x, side="right") - 1)
    e = min(e, p.size - 2)
    a, b = p[e], p[e + 1]
    h = b - a
    s = (x - a) / h
    N = [1 - 3 * s * s + 2 * s ** 3, h * (s - 2 * s * s + s ** 3), 3 * s * s - 2 * s ** 3, h * (-s * s + s ** 3)]
    full = np.zeros((fe.basis.N, V.shape[1]))
    full[fe.free] = V
    dofs = [fe.basis.nodal_dofs[0, e], fe.basis.nodal_dofs[1, e], fe.basis.nodal_dofs[0, e + 1],
            fe.basis.nodal_dofs[1, e + 1]]
    return sum(Ni * full[d] for Ni, d in zip(N, dofs))


def _first_crossing(rhs, n, row, gap, t_end, max_step):
    """Time at which ``row . eta`` first rises through ``gap`` from rest (solve_ivp, DOP853)."""
    def ev(t, y):
        return row @ y[:n] - gap
    ev.terminal, ev.direction = True, 1
    sol = solve_ivp(rhs, (0.0, t_end), np.zeros(2 * n), method="DOP853", rtol=1e-12, atol=1e-18,
                    events=ev, max_step=max_step)
    assert sol.status == 1
    return float(sol.t_events[0][0])


@pytest.mark.parametrize("n_modes", ["static", 2])
@pytest.mark.parametrize("x_mm", [60.0, 180.0])
def test_a_point_stop_gap_and_first_impact_against_an_own_modal_integration(n_modes, x_mm):
    """A ``[[model.stop]]`` with ``position_mm`` (60 mm, inside an element, and the tip) and
    ``gap_mm = 0.15`` at the sensor, the paper's stop at the mass out of reach (5 mm): its gap at
    the point is ``gap_mm phi(x)`` with the static mode phi written out here; the first impact
    from rest at 15 Hz is where the beam's displacement at that point first reaches the gap in an
    own solve_ivp: for the static mode, ``q'' + D w_n^2 q' + w_n^2 q = Y W^2 sin(W t) / (L
    phi(x_m))`` with ``w_n^2 = 3 EI / (m L_m^3)`` (paper Eqs. 42-47, written out) and ``U(x) = L
    phi(x) q``; for 2 FE modes, the lowest eigenpairs of vibeam's FE matrices by
    scipy.linalg.eigh (of the inverse problem), modal damping ``D w_i^2``, load ``phi_i^T M r`` and the stop's row by
    Hermite interpolation of the shapes (all written here).  The first impact time to 1e-10
    relative (event location at rtol 1e-12 within 2 periods; measured <= 2.4e-14) and the gap
    to 1e-12 (round-off).  Without the static mode's normalisation (phi(x) / sqrt(M_S) in the
    static model, phi(x_S) = 1 in the gap) the stop is hit at another time."""
    import scipy.linalg

    from vibeam.case.beamscene import scene_of
    from vibeam.models.builders.beam_fe import BeamFE
    from vibeam.models import BeamEventSolver

    nm = '"static"' if n_modes == "static" else n_modes
    gap_mm = 0.15
    spec = parse_case(POINT_RIG.format(n_modes=nm, x=x_mm, gap=gap_mm)).model_spec()
    m = spec.scene()
    sc = scene_of(spec)
    g = sc.geometry
    L, xm, xs, x = g.length_m, g.mass_position_m, g.sensor_position_m, x_mm * 1e-3
    phi_x = _phi_static(x / L, xm / L, xs / L)
    gap = gap_mm * 1e-3 * phi_x
    ps = [st for st in m.stops if st.relation.row > 0][0]
    assert ps.relation.offset == pytest.approx(gap, rel=1e-12)
    f_hz, f_ref = 15.0, m.system.reference_hz
    tr = BeamEventSolver(m).point(f_hz / f_ref, None, 0, 4, 32)
    assert tr.status == "ok" and tr.impact_stops.size > 0 and tr.impact_stops[0] == 2  # the point stop first
    Wt = 2 * math.pi * f_hz
    Y = m.system.base_amplitude
    D = sc.damping_D_s          # the case's Rayleigh D (the scene holds c_i = D omega_i^2 only)
    if n_modes == "static":
        phim = _phi_static(xm / L, xm / L, xs / L)
        wn2 = 3 * g.EI_n_m2 / (g.mass_kg * xm ** 3)

        def rhs(t, y):
            return [y[1], -D * wn2 * y[1] - wn2 * y[0] + Y * Wt * Wt * math.sin(Wt * t) / (L * phim)]
        t1 = _first_crossing(rhs, 1, np.array([L * phi_x]), gap, 1.0, 1 / (64 * f_hz))
    else:
        fe = BeamFE(g, n_elements=spec.system.n_elements, damping_D_s=sc.damping_D_s)
        # the lowest modes as the largest of M v = mu K v (mu = 1 / omega^2): K v = omega^2 M v
        # directly loses ~eps omega_max^2 / omega_1^2 ~ 1e-8 of omega_1 on this mesh
        nd = fe.K.shape[0]
        mu, V = scipy.linalg.eigh(fe.M, fe.K, subset_by_index=[nd - 2, nd - 1])
        mu, V = mu[::-1], V[:, ::-1]
        V = V / np.sqrt(np.einsum("ij,ik,kj->j", V, fe.M, V))      # mass-normalised
        om2 = 1.0 / mu
        gam = V.T @ (-fe.base_load)                  # phi_i^T M r (the FE's load vector, input)
        row = _hermite_row(fe, V, x)

        def rhs(t, y):
            eta, v = y[:2], y[2:]
            return np.concatenate([v, -D * om2 * v - om2 * eta + gam * Y * Wt * Wt * math.sin(Wt * t)])
        t1 = _first_crossing(rhs, 2, row, gap, 1.0, 1 / (64 * f_hz))
    assert tr.impact_times[0] == pytest.approx(2 * math.pi * f_ref * t1, rel=1e-10)


# ------------------------------------------------------------------ 9. defaults exercised directly

def test_the_continuation_step_is_capped_at_ds_max():
    """Fig. 13's smooth period-1 branch (Omega 1.5 ... 2.0, no bifurcation) with ``ds_max = 0.02``
    (default 0.05; ``ds = 0.01`` grows by 1.6 per fast step): every accepted step's arclength
    along the previous tangent, ``t_k . (u_{k+1} - u_k)`` (the pseudo-arclength constraint the
    corrector solves; its predictor adds the curvature term ds^2 kappa / 2, nearly normal to t:
    measured 2e-5 of ds beyond it) is at most ds_max (+1e-4 relative), the cap is reached (5 or
    more steps within 1e-4 of it), and the branch needs at least its arclength over ds_max
    steps.  Without the cap the steps grow by 1.6 to 0.05 and beyond."""
    from vibeam.models.orbits.continuation import Settings, trace
    from vibeam.models import EventSolver

    fig13 = sdof(0.015, 0.5e-3, 0.5e-3, 0.9)
    prob = shooting_problem(fig13, "Omega")
    x0 = EventSolver(fig13).point(1.5, None, 400, 1, 16).final_state[:2]
    ds_max = 0.02
    (br,) = trace(prob, x0, 1.5, 1, 1.5, 2.0, +1, Settings(switch=False, ds_max=ds_max))
    assert br.status == "range_end" and not br.bifurcations
    pts = br.points
    steps = np.array([float(a.t @ (b.u - a.u)) for a, b in zip(pts[:-1], pts[1:])])
    assert np.all(steps > 0) and steps.max() <= ds_max * (1 + 1e-4), steps.max()
    assert np.sum(np.abs(steps - ds_max) < 1e-4 * ds_max) >= 5
    length = sum(float(np.linalg.norm(b.u - a.u)) for a, b in zip(pts[:-1], pts[1:]))
    assert len(pts) - 1 >= length / ds_max


@pytest.mark.parametrize("n_modes", ['"static"', 2])
def test_the_beams_lower_gap_is_converted_to_the_contact_point(n_modes):
    """A beam's ``gap_lower_mm`` (at the sensor) is ``gap_lower_mm phi(x_m)`` at the contact point
    in m (phi of the static mode written out, phi(x_S) = 1), ``contact_gap_lower_mm`` (with
    ``contact_gap_mm``) is taken as it is, for the static-mode and the FE models; the upper gap likewise (round-off: 1e-12)."""
    base = POINT_RIG.split("[[model.stop]]")[0].format(n_modes=n_modes)
    sweep = "[sweep]\nfrequency_hz = [14.0, 17.0, 5]\n[[run]]\nname = \"event\"\nmethod = \"event\"\n"
    phim = _phi_static(132.0 / 180.0, 132.0 / 180.0, 100.0 / 180.0)
    for keys, up, low in (("R = 0.8\ngap_mm = 0.1\ngap_lower_mm = 0.3\n", 0.1e-3 * phim, 0.3e-3 * phim),
                          ("R = 0.8\ncontact_gap_mm = 0.2\ncontact_gap_lower_mm = 0.45\n", 0.2e-3, 0.45e-3)):
        text = base.replace("n_elements = 24\n", "n_elements = 24\n" + keys) + sweep
        m = parse_case(text).model_spec().scene()
        assert m.stops[0].relation.offset == pytest.approx(up, rel=1e-12)
        assert m.stops[1].relation.offset == pytest.approx(low, rel=1e-12)


# ------------------------------------------------------------------ 9. a start inside a compliant stop

KV_INSIDE_CASE = '''
name = "kv-inside"
[model]
fidelity = "sdof"
beta = 0.015
B = 0.05
R = 0.8
Delta = -0.5
[model.contact]
law = "linear"
stiffness = 1.0
damping_ratio = 0.5
[sweep]
Omega = [1.8, 2.2, 3]
transient_periods = 0
record_periods = 2
[[run]]
name = "exact"
method = "event"
'''


def _kelvin_voigt_sdof_ivp(beta, B, Delta, W, k, c, y0, periods, spp):
    """The SDOF (paper Eq. 1) with a Kelvin-Voigt stop that pushes and never pulls, ``f = max(0,
    k g + c g')`` for ``g = q - Delta > 0`` (0 outside), integrated here by solve_ivp (DOP853)
    piece by piece between the force's switches: contact begins where ``g`` rises through 0 or,
    inside, where ``k g + c g'`` rises through 0; it ends where either falls through 0.  Returns
    the samples ``(q, q')`` at ``j T / spp`` and the contacts' entry times."""
    T = 2 * math.pi / W
    F = W * W * B
    t_end = periods * T
    t_s = np.arange(periods * spp) * T / spp
    samples = np.full((t_s.size, 2), np.nan)
    entries = []

    def rhs(on):
        def f(t, y):
            push = k * (y[0] - Delta) + c * y[1] if on else 0.0
            return [y[1], -2 * beta * y[1] - y[0] + F * math.sin(W * t) - push]
        return f

    def gap(t, y):
        return y[0] - Delta

    def force(t, y):
        return k * (y[0] - Delta) + c * y[1]

    t, y = 0.0, np.asarray(y0, float)
    on = gap(t, y) > 0 and force(t, y) > 0
    while t < t_end:
        evs = []
        for e, d in ((gap, -1 if on else +1), (force, -1 if on else +1)):
            ev = (lambda e_: lambda t_, y_: e_(t_, y_))(e)
            ev.terminal, ev.direction = True, d
            evs.append(ev)
        sol = solve_ivp(rhs(on), (t, t_end), y, method="DOP853", rtol=1e-12, atol=1e-16, dense_output=True,
                        events=evs)
        t_new = sol.t[-1]
        sel = (t_s >= t) & (t_s <= t_new)
        samples[sel] = sol.sol(t_s[sel]).T
        t, y = t_new, sol.y[:, -1]
        if sol.status != 1:
            break
        # a switch: contact ends, or begins (through the surface, or pressed again from inside;
        # the force's sign turning outside the stop is no contact)
        on = not on and gap(t, y) > -1e-14
        if on:
            entries.append(t)
    return samples, np.array(entries)


def test_a_start_inside_a_compliant_stop_without_contact_follows_the_force_sign():
    """The body starts inside a pre-stressed Kelvin-Voigt stop (``g = 0.1``) moving out of it so
    fast that the stop would pull (``k g + c g' = -0.05``): no contact until the force's sign
    turns, then contact (the stops the body starts inside of, ``_start_compliant``).  The event
    solver's orbit over 2 periods against an own solve_ivp of the push-only law (samples to 1e-9
    of the orbit: both exact to ~1e-12, measured 5.5e-13; the first contact's entry time to 1e-9).  A start that
    ignored "inside" would see a free body beyond the stop's surface."""
    from vibeam.models import make_solver

    sc = parse_case(KV_INSIDE_CASE).model_spec().scene()
    law = None if sc.stops[0].law.kind == "impulsive" else sc.stops[0].law
    k = float(law.stiffness)
    c = 2.0 * float(law.damping_ratio) * math.sqrt(k)
    W, periods, spp = 2.0, 2, 64
    y0 = np.array([-0.4, -0.15])
    assert 0.1 * k - 0.15 * c < 0.0                      # inside, the stop would pull: no contact
    tr = make_solver(sc, "event").point(W, np.array([y0[0], y0[1], 0.0]), 0, periods, spp)
    ref, entries = _kelvin_voigt_sdof_ivp(0.015, 0.05, -0.5, W, k, c, y0, periods, spp)
    assert tr.status == "ok" and entries.size >= 1 and 0.0 < entries[0] < 1.0
    assert np.max(np.abs(tr.samples - ref)) <= 1e-9 * np.max(np.abs(ref))
    assert tr.impact_times[0] == pytest.approx(entries[0], rel=1e-9)
