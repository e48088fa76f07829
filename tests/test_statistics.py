"""Statistics of non-periodic points (issue: tests that pass on any machine).

A chaotic attractor is reproducible only in its statistics, so the per-period amplitudes
``Q_k`` of a non-periodic point are compared by the mean with a batch-means standard error
(:func:`vibeam.engine.records.batch_means`) and Welch's two-sample test at Student's critical value
(:func:`vibeam.engine.records.means_agree`), in ``vibeam regress``, in ``transient_periods = "auto"``
and in the tests alike.  Oracles: the exact asymptotic standard error of an AR(1) series and
the nominal false-alarm probability of the test; closed-form quantiles; bit-for-bit sweeps.
"""
from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.signal import lfilter

from vibeam.models import make_solver
from vibeam.models.builders.sdof import sdof
from vibeam.engine.records import (amplitude_spread, batch_means, critical_value, mean_std, means_agree,
                            spread_agrees, window_verdict)
from vibeam.analysis.regress import compare
from vibeam.engine.sweep import Sweep, run_sweep


def ar1(rng, shape, phi):
    """Stationary AR(1) series ``x_k = phi x_(k-1) + e_k`` (unit innovations) along the last axis:
    variance ``1 / (1 - phi^2)``, integrated autocorrelation time ``(1 + phi) / (1 - phi)``."""
    e = rng.standard_normal(shape[:-1] + (shape[-1] + 200,))
    return lfilter([1.0], [1.0, -phi], e, axis=-1)[..., 200:]


@pytest.mark.parametrize("n", [2, 3, 8, 63, 64, 129, 1000, 4097])
def test_mean_std_is_numpys_two_pass_mean_and_sample_std(n):
    """mean_std (the per-point spread's mean and ddof = 1 standard deviation, without NumPy's
    Python layers) against x.mean() and x.std(ddof=1): equal to 1e-15 relative (both are the
    two-pass formula over NumPy's pairwise sums, equal bit for bit on the NumPy of this writing;
    the tolerance leaves room for another summation order only), on series with a large offset
    (the amplitudes Q_k of a settled orbit: a mean of 1 with a spread of 1e-12, where a one-pass
    formula would lose every digit of the spread), on constant series and on wide ones."""
    rng = np.random.default_rng(n)
    for x in (1.0 + 1e-12 * rng.standard_normal(n), np.full(n, 0.1), 1e3 * rng.standard_normal(n),
              rng.uniform(0, 1e-300, n)):
        m, s = mean_std(x)
        assert m == pytest.approx(x.mean(), rel=1e-15, abs=0.0)
        assert s == pytest.approx(x.std(ddof=1), rel=1e-15, abs=1e-300)
    if n >= 63:     # the spread itself, not round-off: within 4 standard errors 1 / sqrt(2 n) of 1e-12
        x = 1.0 + 1e-12 * rng.standard_normal(n)
        assert mean_std(x)[1] == pytest.approx(1e-12, rel=4.0 / math.sqrt(2 * n))


def test_critical_value_is_students_t_at_the_normal_false_alarm_probability():
    """sigmas = 4 is p = 6.3e-5 two-sided: 4.0 for infinitely many degrees of freedom (normal),
    Student's t quantiles for few (tabulated: t_(1 - 3.17e-5; 6) = 9.84, t_(...; 30) = 4.65)."""
    assert critical_value(4.0, 1e12) == pytest.approx(4.0, rel=1e-6)
    assert critical_value(2.0, 1e12) == pytest.approx(2.0, rel=1e-6)
    np.testing.assert_allclose(critical_value(4.0, [6, 30]), [9.844, 4.645], rtol=1e-3)
    assert math.isnan(critical_value(4.0, 0))


def test_batch_means_estimates_the_standard_error_of_correlated_means():
    """AR(1) with phi = 0.5 (integrated autocorrelation time 3, as the tight rig's chattering
    attractors: 0.1-2.5 periods measured), 256 values: the exact standard error of the mean is
    sqrt(tau / ((1 - phi^2) n)).  Over 2000 series the median batch-means estimate is within 15 %
    of it (measured -7 %: batches of 16 values leave a bias ~tau / 16), while the i.i.d.
    std / sqrt(n) is low by sqrt(3) (measured -42 %)."""
    rng = np.random.default_rng(20261122)
    phi, n = 0.5, 256
    x = ar1(rng, (2000, n), phi)
    exact = math.sqrt((1 + phi) / (1 - phi) / ((1 - phi * phi) * n))
    sem = np.array([batch_means(r)[0] for r in x])
    iid = x.std(axis=1, ddof=1) / math.sqrt(n)
    assert abs(np.median(sem) / exact - 1) < 0.15
    assert np.median(iid) / exact < 0.65
    assert batch_means(x[0])[1] == 15                    # 16 batches of 16
    assert batch_means(np.ones(64)) == (0.0, 7)
    assert batch_means([1.0, 2.0, 3.0]) == (pytest.approx(1 / math.sqrt(3)), 2)   # 3 batches of 1
    s, d = batch_means([1.0])
    assert math.isnan(s) and d == 0                      # fewer than 2 batches


def test_welch_test_on_batch_means_keeps_its_false_alarm_rate_on_correlated_series():
    """Two independent AR(1) series (phi = 0.5) of the same attractor, 256 values each, 2000
    pairs, at sigmas = 2 (nominal p = 4.55 %): the batch-means test raises 4-7 % false alarms
    (measured 5.5 %; binomial sd 0.5 %), the i.i.d. test of the former vibeam regress ~25 %
    (measured 27 %).  At sigmas = 4, a shift of the mean by 10 exact standard errors is found in
    > 90 % of the pairs (measured 85 % at 8, the critical value being 4.6 sqrt(2) = 6.6)."""
    rng = np.random.default_rng(7)
    phi, n, R = 0.5, 256, 2000
    a, b = ar1(rng, (R, n), phi), ar1(rng, (R, n), phi)
    sa, sb = zip(*[batch_means(r) for r in a]), zip(*[batch_means(r) for r in b])
    (sa, da), (sb, db) = (np.array(v) for v in sa), (np.array(v) for v in sb)
    fa = 1 - np.mean(means_agree(a.mean(1), sa, da, b.mean(1), sb, db, sigmas=2.0))
    iid = lambda x: x.std(axis=1, ddof=1) / math.sqrt(n)
    fa_iid = 1 - np.mean(means_agree(a.mean(1), iid(a), n - 1, b.mean(1), iid(b), n - 1, sigmas=2.0))
    assert 0.04 <= fa <= 0.07, fa
    assert fa_iid > 0.15, fa_iid
    exact = math.sqrt((1 + phi) / (1 - phi) / ((1 - phi * phi) * n))
    hit = 1 - np.mean(means_agree(a.mean(1) + 10 * exact, sa, da, b.mean(1), sb, db, sigmas=4.0))
    assert hit > 0.9, hit


def test_spread_agreement_uses_the_batch_means_error_and_students_t():
    """spread_agrees of amplitude_spread outputs: the bound is t_crit(Welch dof) sqrt(sem_a^2 +
    sem_b^2); equal errors with 15 degrees of freedom each give dof 30, t_crit(4 sigma) = 4.645.
    A sample without amplitude_sem (written before it existed) is taken as i.i.d."""
    a = dict(amplitude_mean=1.0, amplitude_std=0.2, amplitude_sem=0.02, amplitude_sem_dof=15, record_periods=256)
    c = critical_value(4.0, 30) * 0.02 * math.sqrt(2)
    assert spread_agrees(a, dict(a, amplitude_mean=1.0 + 0.99 * c))
    assert not spread_agrees(a, dict(a, amplitude_mean=1.0 + 1.01 * c))
    old = dict(amplitude_mean=1.0, amplitude_std=0.2, record_periods=64)     # i.i.d.: se 0.025, dof 63
    c_old = critical_value(4.0, 126) * 0.2 * math.sqrt(2 / 64)
    assert spread_agrees(old, dict(old, amplitude_mean=1.0 + 0.99 * c_old))
    assert not spread_agrees(old, dict(old, amplitude_mean=1.0 + 1.01 * c_old))
    s = amplitude_spread([1.0, 2.0, 3.0])
    assert (s["amplitude_mean"], s["amplitude_std"], s["record_periods"]) == (2.0, 1.0, 3)
    assert s["amplitude_sem"] == pytest.approx(1 / math.sqrt(3)) and s["amplitude_sem_dof"] == 2
    # periodic samples (std 0) agree within the 1e-9 floor only
    p = dict(amplitude_mean=1.0, amplitude_std=0.0, amplitude_sem=0.0, amplitude_sem_dof=15, record_periods=16)
    assert spread_agrees(p, dict(p, amplitude_mean=1.0 + 5e-10))
    assert not spread_agrees(p, dict(p, amplitude_mean=1.0 + 2e-9))


# ----------------------------------------------------------------------------- the sweep
FIG13 = sdof(beta=0.015, B=0.5e-3, Delta=0.5e-3, R=0.9)


def test_a_non_periodic_point_is_measured_over_statistics_periods_without_changing_the_chain():
    """Fig. 13 scene, Omega = 2.5 (chaotic) then 1.5 and 1.2 (period 1): with statistics_periods =
    256 the chaotic point's spread covers 256 periods (record_periods = 256, batch-means error with
    15 degrees of freedom, amplitude = largest Q_k = Delta - min q over the window), while its
    strobe stays the 16-period record and the later points of the chain are bit for bit those
    of the sweep without the window (the window is a look-ahead: the chain continues from the
    record's end).  The window's mean lies within the record's range."""
    W = np.array([2.5, 1.5, 1.2])
    kw = dict(Omega=W, transient_periods=1500, record_periods=16, direction="down")
    a = run_sweep(make_solver(FIG13, "event"), Sweep(**kw, statistics_periods=256)).data
    b = run_sweep(make_solver(FIG13, "event"), Sweep(**kw)).data
    i = list(a["Omega"]).index(2.5)
    assert a["period"][i] == b["period"][i] == 0                    # the scenario: chaos at 2.5
    assert a["record_periods"][i] == 256 and b["record_periods"][i] == 16
    assert a["amplitude_sem_dof"][i] == 15 and a["amplitude_sem"][i] > 0
    assert a["amplitude"][i] == pytest.approx(a["amplitude_max"][i], rel=1e-12)
    assert a["amplitude_max"][i] >= b["amplitude_max"][i] and a["amplitude_min"][i] <= b["amplitude_min"][i]
    np.testing.assert_array_equal(a["strobe"][i], b["strobe"][i])
    rest = [k for k in range(3) if k != i]
    assert all(a["period"][k] == 1 for k in rest)
    for key in ("amplitude", "strobe", "amplitude_mean", "record_periods"):
        np.testing.assert_array_equal(np.asarray(a[key])[rest], np.asarray(b[key])[rest])


def test_a_window_that_is_not_one_attractor_is_named():
    """window_verdict: a stationary AR(1) window of 256 values passes; the same window with its
    second half shifted by 12 exact standard errors of a half's mean fails (the halves' means);
    a window whose last periods repeat (period 2 within rtol) ends on a periodic orbit; the
    no-impact orbit likewise when its free motion repeats."""
    rng = np.random.default_rng(3)
    phi = 0.5
    q = 1.0 + 0.01 * ar1(rng, (256,), phi)
    chaos_tail = rng.standard_normal((16, 2))
    assert window_verdict(q, chaos_tail, 1.0, 1e-5) == ""
    se_half = 0.01 * math.sqrt((1 + phi) / (1 - phi) / ((1 - phi * phi) * 128))
    shifted = q.copy()
    shifted[128:] += 12 * se_half
    assert "halves" in window_verdict(shifted, chaos_tail, 1.0, 1e-5)
    p2 = np.tile([[0.3, 0.1], [-0.2, 0.4]], (8, 1))
    assert "period-2" in window_verdict(q, p2, 1.0, 1e-5)
    p1 = np.tile([[0.3, 0.1]], (16, 1))
    assert "no-impact" in window_verdict(q, p1, 1.0, 1e-5, no_impact=True)
    assert window_verdict(q, chaos_tail, 1.0, 1e-5, no_impact=True) == ""


# ----------------------------------------------------------------------------- regress
def _run(Omega, period, mean, status=None, sem=1e-3, direction="up"):
    n = len(Omega)
    status = status or ["ok"] * n
    mean = np.asarray(mean, float)
    return dict(Omega=np.asarray(Omega, float), direction=np.array([direction] * n, dtype=object),
                period=np.asarray(period), status=np.array(status, dtype=object),
                amplitude=mean.copy(), amplitude_mean=mean, amplitude_std=np.full(n, 0.01),
                amplitude_min=mean - 0.02, amplitude_max=mean + 0.02, amplitude_sem=np.full(n, sem),
                amplitude_sem_dof=np.full(n, 15), record_periods=np.full(n, 256))


def _regress(tmp_path, new, ref, **kw):
    from vibeam.io.results import write_results
    from vibeam.engine.sweep import SweepResult

    res = SweepResult(name="r", fidelity="sdof", method="event", settings={}, data=ref, wall_time_s=0.0)
    path = write_results(tmp_path / "ref.h5", [res], "c", 'name = "c"')
    return compare({"runs": {"r": new}}, path, **kw)[0]


def test_regress_excuses_only_other_attractors_reached_from_irreproducible_states(tmp_path):
    """Up line 1.0, 1.1, 1.2, 1.3.  Another attractor (period 2 against period 1) at 1.2, right
    after a chaotic point (period 0 at 1.1), is 'multistable': not a regression.  The same change
    after a periodic point, or at the first point of the line, is a regression; so is a chaotic
    mean 10 standard errors off, and another period after a chaotic point when the sweep did not
    hand states on (continuation = false)."""
    W = [1.0, 1.1, 1.2, 1.3]
    ref = _run(W, [1, 0, 1, 1], [1.0, 1.5, 1.2, 1.3])
    row = _regress(tmp_path, _run(W, [1, 0, 2, 1], [1.0, 1.5, 1.25, 1.3]), ref)
    assert row.ok and row.multistable == 1 and row.spread_points == 1
    row = _regress(tmp_path, _run(W, [1, 0, 1, 2], [1.0, 1.5, 1.2, 1.35]), ref)     # after a periodic point
    assert not row.ok and row.multistable == 0
    row = _regress(tmp_path, _run(W, [2, 0, 1, 1], [1.05, 1.5, 1.2, 1.3]), ref)     # the first point
    assert not row.ok
    row = _regress(tmp_path, _run(W, [1, 0, 1, 1], [1.0, 1.5 + 10 * math.sqrt(2) * 1e-3, 1.2, 1.3]), ref)
    assert not row.ok and row.spread_failures == 1
    row = _regress(tmp_path, _run(W, [1, 0, 2, 1], [1.0, 1.5, 1.25, 1.3]), ref, continuation=False)
    assert not row.ok and row.multistable == 0
    # an unsettled point after a chaotic one: a transient from an irreproducible state
    st = ["ok", "ok", "unsettled", "ok"]
    row = _regress(tmp_path, _run(W, [1, 0, 0, 1], [1.0, 1.5, 1.4, 1.3], status=st), ref)
    assert row.ok and row.multistable == 1
    # a down line: the predecessor of 1.2 is 1.3
    ref_d = _run(W, [1, 1, 1, 0], [1.0, 1.1, 1.2, 1.3], direction="down")
    row = _regress(tmp_path, _run(W, [1, 1, 2, 0], [1.0, 1.1, 1.25, 1.3], direction="down"), ref_d)
    assert row.ok and row.multistable == 1


def test_regress_excuses_a_chaotic_transient_of_another_length_wherever_it_starts(tmp_path):
    """A point non-periodic in both files and unsettled in one (a chaotic transient that outlasted
    the cap on one machine and reached its chaotic attractor on the other: rig-continuum's first
    point at 13 Hz, chatter in the reference and unsettled on a Sapphire Rapids host whose BLAS
    kernels give the continuum's modes 3e-8 apart) is 'multistable', also at the first point of a
    line, however far its mean is.  Unsettled against a periodic orbit at the first point, or after
    a periodic point, stays a regression; so does a chaotic mean 10 standard errors off when both
    files settled."""
    W = [1.0, 1.1, 1.2, 1.3]
    ref = _run(W, [0, 1, 1, 0], [1.5, 1.1, 1.2, 1.3], status=["chatter", "ok", "ok", "ok"])
    first = ["unsettled", "ok", "ok", "ok"]
    row = _regress(tmp_path, _run(W, [0, 1, 1, 0], [1.9, 1.1, 1.2, 1.3], status=first), ref)
    assert row.ok and row.multistable == 1
    row = _regress(tmp_path, ref, _run(W, [0, 1, 1, 0], [1.9, 1.1, 1.2, 1.3], status=first))   # either file
    assert row.ok and row.multistable == 1
    # unsettled where the other file has a periodic orbit: the first point, and after a periodic one
    ref_p = _run(W, [1, 1, 1, 0], [1.0, 1.1, 1.2, 1.3])
    row = _regress(tmp_path, _run(W, [0, 1, 1, 0], [1.9, 1.1, 1.2, 1.3], status=first), ref_p)
    assert not row.ok and row.multistable == 0
    row = _regress(tmp_path, _run(W, [1, 1, 0, 0], [1.0, 1.1, 1.9, 1.3], status=["ok", "ok", "unsettled", "ok"]),
                   ref_p)
    assert not row.ok and row.multistable == 0
    # both settled and chaotic at the first point: compared by their spread
    row = _regress(tmp_path, _run(W, [0, 1, 1, 0], [1.5 + 10 * math.sqrt(2) * 1e-3, 1.1, 1.2, 1.3],
                                  status=["chatter", "ok", "ok", "ok"]), ref)
    assert not row.ok and row.spread_failures == 1
