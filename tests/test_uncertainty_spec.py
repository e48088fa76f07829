"""``[uncertainty]``'s spec (:mod:`vibeam.case.uncertainty`) by its properties, without a sweep: each
distribution has the moments and support its numbers say (closed forms), the designs are the
scrambled Sobol' points through the inverse distribution functions (recomputed here), Saltelli's
rows are A, B and A with one column from B, and every refusal names what is allowed.  Issue 56,
section 2: the survivors of cosmic-ray's mutants of the module, killed here."""
from __future__ import annotations

import math

import numpy as np
import pytest
from pydantic import ValidationError
from scipy import stats

from vibeam.case.uncertainty import (DISTRIBUTIONS, MAX_PARAMETERS, MAX_SAMPLES, SUPPORT_TAIL,
                                     UncertaintyParameterSpec, UncertaintySpec)


def P(**kw):
    return UncertaintyParameterSpec(**kw)


def test_each_distribution_has_the_moments_and_support_its_numbers_say():
    """Closed forms (scipy only evaluates them): normal mean/std; truncnorm's mean
    m + s (phi(a) - phi(b)) / (Phi(b) - Phi(a)); uniform (lo + hi) / 2 and (hi - lo) / sqrt(12);
    lognormal: the parameter's own mean and std; triangular (lo + hi + mode) / 3."""
    d = P(name="R", distribution="normal", mean=0.8, std=0.08).frozen()
    assert d.mean() == pytest.approx(0.8, rel=1e-14) and d.std() == pytest.approx(0.08, rel=1e-14)
    t = P(name="R", distribution="truncnorm", mean=0.8, std=0.08, bounds=[0.7, 1.0])
    a, b = (0.7 - 0.8) / 0.08, (1.0 - 0.8) / 0.08
    phi = lambda x: math.exp(-x * x / 2) / math.sqrt(2 * math.pi)    # noqa: E731
    Phi = lambda x: 0.5 * (1 + math.erf(x / math.sqrt(2)))          # noqa: E731
    assert t.frozen().mean() == pytest.approx(0.8 + 0.08 * (phi(a) - phi(b)) / (Phi(b) - Phi(a)), rel=1e-12)
    assert t.support() == (0.7, 1.0)
    u = P(name="B", distribution="uniform", bounds=[0.005, 0.015])
    assert u.frozen().mean() == pytest.approx(0.01, rel=1e-14)
    assert u.frozen().std() == pytest.approx(0.01 / math.sqrt(12), rel=1e-12)
    assert u.support() == (0.005, 0.015)
    ln = P(name="beta", distribution="lognormal", mean=0.05, std=0.02)
    assert ln.frozen().mean() == pytest.approx(0.05, rel=1e-12) and ln.frozen().std() == pytest.approx(0.02, rel=1e-12)
    lo, hi = ln.support()
    assert lo == 0.0 and hi == pytest.approx(float(ln.frozen().ppf(1 - SUPPORT_TAIL)), rel=1e-14) and hi > 0.05 + 5 * 0.02
    tr = P(name="beta", distribution="triangular", bounds=[0.04, 0.07], mode=0.05)
    assert tr.frozen().mean() == pytest.approx((0.04 + 0.07 + 0.05) / 3, rel=1e-12)
    assert tr.frozen().pdf(0.05) == pytest.approx(2 / 0.03, rel=1e-12)           # the peak at the mode
    assert tr.support() == (0.04, 0.07)
    # a mode at more than twice lo from 0 and hi beyond 2 lo (the shape c = (mode - lo) / (hi - lo) and the
    # scale hi - lo, not mode % lo or hi % lo): [1, 4] with mode 3, c = 2/3, mean 8/3, peak 2/3 at 3
    tr = P(name="beta", distribution="triangular", bounds=[1.0, 4.0], mode=3.0)
    assert tr.frozen().mean() == pytest.approx(8.0 / 3.0, rel=1e-12)
    assert tr.frozen().pdf(3.0) == pytest.approx(2.0 / 3.0, rel=1e-12)
    assert tr.frozen().cdf(3.0) == pytest.approx(2.0 / 3.0, rel=1e-12) and tr.support() == (1.0, 4.0)
    # an unbounded end: its SUPPORT_TAIL quantile (the normal's: mean -+ 7.034 std)
    lo, hi = P(name="R", distribution="normal", mean=0.8, std=0.08).support()
    z = -stats.norm.ppf(SUPPORT_TAIL)
    assert z == pytest.approx(7.034, abs=1e-3)
    # (the upper end's probability 1 - 1e-12 is rounded to a double: 1e-4 of the tail, 2e-7 of the value)
    assert lo == pytest.approx(0.8 - z * 0.08, rel=1e-12) and hi == pytest.approx(0.8 + z * 0.08, rel=1e-6)
    assert isinstance(lo, float) and isinstance(hi, float)


def test_the_design_is_the_sobol_points_through_the_inverse_distribution_functions():
    pars = [{"name": "B", "distribution": "uniform", "bounds": [0.005, 0.015]},
            {"name": "R", "distribution": "normal", "mean": 0.8, "std": 0.05}]
    spec = UncertaintySpec(samples=8, seed=4, parameter=pars)
    u = stats.qmc.Sobol(2, scramble=True, seed=4).random_base2(3)
    want = np.column_stack([0.005 + 0.01 * u[:, 0], stats.norm(0.8, 0.05).ppf(u[:, 1])])
    np.testing.assert_allclose(spec.design(), want, rtol=1e-15, atol=1e-17)
    assert spec.design(2).shape == (2, 2) and spec.design(32).shape == (32, 2)
    np.testing.assert_array_equal(spec.design(1), spec.design(1))
    assert spec.design(1).shape == (1, 2)
    for n in (0, 3, 5, 10, 12):      # 5 and 10: n & (n >> 1) and n & (n << 1) are 0, n & (n - 1) is not
        with pytest.raises(ValueError, match=f"samples = {n}: allowed a power of 2"):
            spec.design(n)
    assert spec.runs_per_sample() == 1


def test_saltellis_rows_are_a_b_and_a_with_one_column_from_b():
    pars = [{"name": "B", "distribution": "uniform", "bounds": [0.005, 0.015]},
            {"name": "beta", "distribution": "triangular", "bounds": [0.04, 0.06], "mode": 0.05},
            {"name": "R", "distribution": "uniform", "bounds": [0.5, 0.9]}]
    spec = UncertaintySpec(samples=8, seed=2, sobol=True, parameter=pars)
    n, d = 8, 3
    rows, roles = spec.saltelli()
    assert spec.runs_per_sample() == d + 2 and rows.shape == (n * (d + 2), d)
    assert roles == ["A"] * n + ["B"] * n + [f"AB:{p}" for p in ("B", "beta", "R") for _ in range(n)]
    # A and B: the two halves of 2d-dimensional scrambled Sobol' points through each column's ppf
    u = stats.qmc.Sobol(2 * d, scramble=True, seed=2).random_base2(3)
    ppf = [p.frozen().ppf for p in spec.parameter]
    A = np.column_stack([ppf[k](u[:, k]) for k in range(d)])
    B = np.column_stack([ppf[k](u[:, d + k]) for k in range(d)])
    np.testing.assert_allclose(rows[:n], A, rtol=1e-15)
    np.testing.assert_allclose(rows[n:2 * n], B, rtol=1e-15)
    for i in range(d):
        ab = rows[(2 + i) * n:(3 + i) * n]
        np.testing.assert_array_equal(np.delete(ab, i, axis=1), np.delete(A, i, axis=1))
        np.testing.assert_array_equal(ab[:, i], B[:, i])
    assert spec.saltelli(2)[0].shape == (2 * (d + 2), d)
    # two parameters: A's column k is point column k, B's column k is point column d + k (k % d, for
    # every d; with d = 3 the bits of k < d are those of d, so k & d = k too: d = 2 tells them apart)
    two = UncertaintySpec(samples=8, seed=5, sobol=True, parameter=pars[:2])
    u = stats.qmc.Sobol(4, scramble=True, seed=5).random_base2(3)
    rows, roles = two.saltelli()
    ppf = [q.frozen().ppf for q in two.parameter]
    np.testing.assert_allclose(rows[:n], np.column_stack([ppf[k](u[:, k]) for k in range(2)]), rtol=1e-15)
    np.testing.assert_allclose(rows[n:2 * n], np.column_stack([ppf[k](u[:, 2 + k]) for k in range(2)]), rtol=1e-15)
    for bad in (1, 5, 6, 10):       # 5 and 10: n & (n >> 1) and n & (n << 1) are 0, n & (n - 1) is not
        with pytest.raises(ValueError, match=f"samples = {bad}: allowed a power of 2"):
            spec.saltelli(bad)


def test_refusals_say_what_is_allowed():
    def refused(**kw):
        with pytest.raises(ValidationError) as e:
            P(**kw)
        return str(e.value)

    assert "allowed: [lo, hi] with lo < hi, got [1.0, 1.0]" in refused(name="R", distribution="uniform", bounds=[1.0, 1.0])
    assert "allowed: [lo, hi] with lo < hi, got [0.5]" in refused(name="R", distribution="uniform", bounds=[0.5])
    assert "allowed: [lo, hi]" in refused(name="R", distribution="uniform", bounds=[0.1, 0.5, 0.9])
    assert "allowed: [lo, hi] with lo < hi, got [0.9, 0.5]" in refused(name="R", distribution="uniform",
                                                                         bounds=[0.9, 0.5])
    P(name="R", distribution="uniform", bounds=[0.5, 0.5000001])                 # lo < hi: accepted
    # hi - lo must be a finite double (the scale): 2e308 overflows, 2e200 does not (while the sum
    # hi + lo of the first is 0, the product of the second -inf and 1e308 ** -1e308 is 0.0)
    assert "allowed: [lo, hi] with hi - lo a finite number" in refused(name="R", distribution="uniform",
                                                                         bounds=[-1e308, 1e308])
    assert P(name="R", distribution="uniform", bounds=[-1e200, 1e200]).support() == (-1e200, 1e200)
    P(name="R", distribution="uniform", bounds=[1e308, 1.7e308])                 # hi + lo overflows, hi - lo not
    msg = refused(name="R", distribution="truncnorm", mean=0.8, bounds=[0.0, 1.0], mode=0.5)
    assert "distribution 'truncnorm' takes mean, std, bounds; missing std; not mode" in msg
    assert "distribution 'normal' takes mean, std; not bounds" in refused(name="R", distribution="normal", mean=0.8,
                                                                          std=0.1, bounds=[0, 1])
    assert "distribution 'uniform' takes bounds; missing bounds" in refused(name="R", distribution="uniform")
    assert "its mean must be > 0, got 0.0" in refused(name="k", distribution="lognormal", mean=0.0, std=1.0)
    assert "its mean must be > 0, got -1.0" in refused(name="k", distribution="lognormal", mean=-1.0, std=1.0)
    P(name="k", distribution="lognormal", mean=1e-9, std=1.0)
    assert "mode = 0.3 lies outside bounds = [0.4, 0.6]" in refused(name="x", distribution="triangular",
                                                                    bounds=[0.4, 0.6], mode=0.3)
    assert "mode = 0.7 lies outside" in refused(name="x", distribution="triangular", bounds=[0.4, 0.6], mode=0.7)
    for mode in (0.4, 0.6):                                                       # the ends are allowed
        P(name="x", distribution="triangular", bounds=[0.4, 0.6], mode=mode)
    # truncnorm: bounds that hold no probability of the normal (8 std away: 6e-16), and some (6 std: 1e-9)
    assert "hold no probability of the normal (mean 0.0, std 1.0)" in refused(
        name="x", distribution="truncnorm", mean=0.0, std=1.0, bounds=[8.0, 9.0])
    P(name="x", distribution="truncnorm", mean=0.0, std=1.0, bounds=[6.0, 9.0])
    P(name="x", distribution="truncnorm", mean=0.0, std=1.0, bounds=[-9.0, -6.0])
    assert "std" in refused(name="x", distribution="normal", mean=0.0, std=0.0)
    assert "at least 1 character" in refused(name="", distribution="normal", mean=0.0, std=1.0)
    assert set(DISTRIBUTIONS) == {"normal", "truncnorm", "uniform", "lognormal", "triangular"}


def test_the_spec_takes_a_power_of_two_of_samples_and_each_parameter_once():
    par = [{"name": "R", "distribution": "uniform", "bounds": [0.5, 0.9]}]
    with pytest.raises(ValidationError, match=r"allowed: a power of 2 \(the balance of scrambled Sobol' points\), "
                                              r"e.g. 8 or 16"):
        UncertaintySpec(samples=12, parameter=par)
    with pytest.raises(ValidationError, match="e.g. 64 or 128"):
        UncertaintySpec(samples=100, parameter=par)
    for n, near in ((5, "4 or 8"), (10, "8 or 16")):   # n & (n >> 1) and n & (n << 1) are 0, n & (n - 1) not
        with pytest.raises(ValidationError, match=f"allowed: a power of 2 .*e.g. {near}"):
            UncertaintySpec(samples=n, parameter=par)
    for n in (2, 4, MAX_SAMPLES):
        assert UncertaintySpec(samples=n, parameter=par).samples == n
    for n in (1, 2 * MAX_SAMPLES):
        with pytest.raises(ValidationError):
            UncertaintySpec(samples=n, parameter=par)
    s = UncertaintySpec(parameter=par)
    assert (s.samples, s.seed, s.sobol) == (64, 0, False)
    with pytest.raises(ValidationError, match=r"each parameter once; \['R'\] given twice"):
        UncertaintySpec(parameter=par * 2)
    many = [{"name": f"p{i}", "distribution": "uniform", "bounds": [0, 1]} for i in range(MAX_PARAMETERS + 1)]
    UncertaintySpec(parameter=many[:MAX_PARAMETERS])
    with pytest.raises(ValidationError):
        UncertaintySpec(parameter=many)


def test_the_limits_cases_readme_states():
    """cases/README.md's [uncertainty] table: samples a power of 2 in [2, 65536], seed >= 0, 1 to 32
    parameters (the constants are read here as literals: a limit moved without its documentation
    fails)."""
    par = [{"name": "R", "distribution": "uniform", "bounds": [0.5, 0.9]}]
    assert (MAX_SAMPLES, MAX_PARAMETERS) == (65536, 32)
    assert UncertaintySpec(samples=65536, parameter=par).samples == 65536
    with pytest.raises(ValidationError):
        UncertaintySpec(samples=131072, parameter=par)
    assert UncertaintySpec(seed=0, parameter=par).seed == 0
    with pytest.raises(ValidationError):
        UncertaintySpec(seed=-1, parameter=par)
    with pytest.raises(ValidationError):
        UncertaintySpec(parameter=[])


def test_a_truncated_normal_is_refused_below_1e_12_of_probability_in_its_bounds():
    """The probability the normal puts in the bounds, 0.5 (erf(hi) - erf(lo)) with the bounds in units
    of std sqrt(2), against scipy's tail: [7.13, 9] std holds 5.0e-13 (refused), [7.0, 9] 1.28e-12
    (accepted); the threshold is 1e-12."""
    assert stats.norm.sf(7.13) - stats.norm.sf(9) == pytest.approx(5.018e-13, rel=1e-3)
    assert stats.norm.sf(7.0) - stats.norm.sf(9) == pytest.approx(1.2798e-12, rel=1e-3)
    with pytest.raises(ValidationError, match="hold no probability of the normal"):
        P(name="x", distribution="truncnorm", mean=1.0, std=2.0, bounds=[1.0 + 2 * 7.13, 1.0 + 2 * 9.0])
    P(name="x", distribution="truncnorm", mean=1.0, std=2.0, bounds=[1.0 + 2 * 7.0, 1.0 + 2 * 9.0])
    P(name="x", distribution="truncnorm", mean=1.0, std=2.0, bounds=[1.0 - 2 * 9.0, 1.0 - 2 * 7.0])
    with pytest.raises(ValidationError, match="hold no probability"):
        P(name="x", distribution="truncnorm", mean=1.0, std=2.0, bounds=[1.0 - 2 * 9.0, 1.0 - 2 * 7.13])


def test_a_truncated_normal_with_exactly_1e_12_of_probability_in_its_bounds_is_refused():
    """The threshold is strict: bounds [0, x] of the normal (0, 1/sqrt 2), x the double whose erf is
    exactly 2e-12 (erf is 2 x / sqrt(pi) to 1e-24 there), hold 0.5 erf(x) = 1e-12 exactly."""
    x, std = 1.772453850905516e-12, 0.7071067811865475
    assert std * math.sqrt(2.0) == 1.0 and 0.5 * (math.erf(x) - math.erf(0.0)) == 1e-12
    with pytest.raises(ValidationError, match="hold no probability"):
        P(name="x", distribution="truncnorm", mean=0.0, std=std, bounds=[0.0, x])
    P(name="x", distribution="truncnorm", mean=0.0, std=std, bounds=[0.0, 2 * x])     # 2e-12: accepted


def test_a_spec_is_strict_frozen_and_finite_and_its_names_are_flat_keys():
    """Types as given (no "64" for 64, no 1 for true, no "0.8" for 0.8), no change after validation,
    no NaN or infinity; a system.<key> / excitation.<key> path stands for its flat key (and is then
    the same parameter), a key of the other group is refused."""
    par = {"name": "R", "distribution": "normal", "mean": 0.8, "std": 0.1}
    for bad in ({"samples": "64"}, {"samples": 64.0}, {"sobol": 1}, {"seed": "1"}):
        with pytest.raises(ValidationError):
            UncertaintySpec(parameter=[par], **bad)
    for bad in ({"mean": "0.8"}, {"mean": float("nan")}, {"mean": float("inf")}, {"std": float("inf")},
                {"distribution": "uniform", "mean": None, "std": None, "bounds": [0.0, float("inf")]}):
        with pytest.raises(ValidationError):
            P(**dict(par, **bad))
    spec = UncertaintySpec(parameter=[par])
    with pytest.raises(ValidationError, match="frozen"):
        spec.samples = 8
    with pytest.raises(ValidationError, match="frozen"):
        spec.parameter[0].mean = 0.5
    assert (spec.samples, spec.parameter[0].mean) == (64, 0.8)
    assert P(**dict(par, name="system.beta")).name == "beta"
    assert P(**dict(par, name="excitation.voltage")).name == "voltage"
    with pytest.raises(ValidationError, match="beta is a key of the system"):
        P(**dict(par, name="excitation.beta"))
    with pytest.raises(ValidationError, match=r"each parameter once; \['beta'\] given twice"):
        UncertaintySpec(parameter=[dict(par, name="beta"), dict(par, name="system.beta")])


def test_a_distributions_name_is_the_modules_own_string():
    """What makes ``d is "normal"`` the same as ``d == "normal"`` (tests/mutation.py, EQUIVALENT):
    pydantic's Literal check returns the annotation's own string, not the one it was given (a TOML
    parser's, a joined one)."""
    import tomllib

    for name in DISTRIBUTIONS:
        given = tomllib.loads(f'd = "{name}"')["d"]
        own = next(k for k in DISTRIBUTIONS if k == name)
        kw = {"mean": 1.0, "std": 0.5, "bounds": [0.0, 2.0], "mode": 1.0}
        p = P(name="x", distribution="".join(given), **{k: kw[k] for k in DISTRIBUTIONS[name]})
        assert p.distribution == name and p.distribution is own
