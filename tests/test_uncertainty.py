"""``[uncertainty]`` (issue 45): sampled FRC bands against closed forms, the ladder verdict, bad input.

The oracle is the linear oscillator: with a stop far beyond the response (no impact) the settled
amplitude of paper Sec. 4.1, ``Q = Delta - min q``, is ``Delta + X`` with the closed-form linear
amplitude ``X = Omega^2 B / sqrt((1 - Omega^2)^2 + (2 beta Omega)^2)`` (Eq. 1 without the stop), so
every sampled sweep, and every statistic of the samples, has an exact value.
"""
from __future__ import annotations

import copy
import math
import subprocess
import sys

import h5py
import numpy as np
import pytest
from scipy import stats

import vibeam
from vibeam.case.schema import CaseError

BETA, DELTA = 0.05, 1.0
OMEGA = [0.6, 1.4, 5]
LINEAR = {"name": "linear-band", "model": {"fidelity": "sdof", "beta": BETA, "B": 0.01, "R": 0.8, "Delta": DELTA},
          "sweep": {"Omega": OMEGA, "transient_periods": 200, "record_periods": 4, "direction": "both"},
          "run": [{"name": "exact", "method": "event"}],
          "uncertainty": {"samples": 16, "seed": 3,
                          "parameter": [{"name": "B", "distribution": "uniform", "bounds": [0.005, 0.015]},
                                        {"name": "beta", "distribution": "triangular", "bounds": [0.04, 0.06],
                                         "mode": 0.05}]}}
#: the settled amplitude's accuracy: the engine settles the transient to ~1e-7 of the amplitude
#: (vibeam.engine.records, SETTLED_MARGIN); the closed form is exact
RTOL = 1e-6


def _X(Om, B, beta):
    return Om * Om * B / np.hypot(1.0 - Om * Om, 2.0 * beta * Om)


def test_every_sample_and_statistic_equals_the_closed_form_linear_frc():
    res = vibeam.uncertainty(LINEAR, quiet=True)
    assert len(res) == 1
    r = res[0]
    # the design: scrambled Sobol' points through the inverse distribution functions, recomputed here
    u = stats.qmc.Sobol(2, scramble=True, seed=3).random_base2(4)
    B = 0.005 + 0.01 * u[:, 0]
    beta = stats.triang(0.5, loc=0.04, scale=0.02).ppf(u[:, 1])
    np.testing.assert_allclose(r.design, np.column_stack([B, beta]), rtol=4e-16, atol=0)   # ppf's rounding
    Om = np.linspace(*OMEGA[:2], OMEGA[2])
    np.testing.assert_allclose(r.Omega, Om, rtol=0, atol=1e-15)
    exact = DELTA + _X(Om[None, :], B[:, None], beta[:, None])          # (sample, Omega)
    for d in range(len(r.directions)):
        np.testing.assert_allclose(r.amplitude[:, d], exact, rtol=RTOL)
    q = r.quantiles()
    mean, std, n = r.moments()
    np.testing.assert_allclose(q[:, 0], np.quantile(exact, [0.05, 0.25, 0.5, 0.75, 0.95], axis=0), rtol=RTOL)
    np.testing.assert_allclose(mean[0], exact.mean(axis=0), rtol=RTOL)
    np.testing.assert_allclose(std[0], exact.std(axis=0, ddof=1), rtol=1e-4)   # a difference of ~1e-3 of Q
    assert (n == 16).all()
    names, p = r.probabilities()
    assert (p[names.index("no impact")] == 1.0).all() and p.sum(axis=0).max() == pytest.approx(1.0)
    assert np.isnan(r.jumps()).all()                     # a linear FRC without impact has no jump


def test_the_verdict_of_two_runs_counts_the_points_outside_the_band():
    """Two runs of one scene, one of them with the stop moved: a shift beyond the band puts every
    median outside the other run's 90 % band; the same scene twice, none."""
    case = copy.deepcopy(LINEAR)
    case["uncertainty"]["samples"] = 8
    case["run"] = [{"name": "a", "method": "event"}, {"name": "b", "method": "event"},
                   {"name": "c", "method": "event", "model": {"Delta": DELTA + 0.1}}]
    res = {r.name: r for r in vibeam.uncertainty(case, quiet=True)}
    # the band's width is below 0.1 everywhere: (X(B = 0.015) - X(B = 0.005)) at Omega = 1.4, beta 0.04
    assert _X(1.4, 0.015, 0.04) - _X(1.4, 0.005, 0.04) < 0.1
    ab, ac = res["a"].attrs["verdict_b"], res["a"].attrs["verdict_c"]
    assert ab["outside_band_a_in_b"] == 0.0 and ab["outside_band_b_in_a"] == 0.0 and ab["points"] == 10
    assert ac["outside_band_a_in_b"] == 1.0 and ac["outside_band_b_in_a"] == 1.0
    assert math.isnan(ac["jump_median_a"]) and ac["jump_fraction_a"] == 0.0


@pytest.mark.parametrize("change, words", [
    ({"samples": 12}, "'uncertainty.samples' = 12"),
    ({"parameter": [{"name": "nope", "distribution": "uniform", "bounds": [0, 1]}]}, "'uncertainty.parameter[0].name'"),
    ({"parameter": [{"name": "R", "distribution": "normal", "mean": 0.8, "std": 0.08}]}, "R = 1.36"),
    ({"parameter": [{"name": "R", "distribution": "uniform", "mean": 0.8, "bounds": [0.5, 0.9]}]}, "not mean"),
    ({"parameter": [{"name": "beta", "distribution": "lognormal", "mean": 0.05}]}, "missing std"),
])
def test_bad_uncertainty_input_is_refused_in_one_line_naming_the_key(change, words):
    case = copy.deepcopy(LINEAR)
    case["uncertainty"].update(change)
    with pytest.raises(CaseError) as e:
        vibeam.load_case(case)
    msg = str(e.value)
    assert "\n" not in msg and words in msg and ("allowed" in msg or "not implemented" in msg
                                                 or "takes" in msg), msg


def test_a_truncated_normal_R_inside_its_range_is_accepted():
    case = copy.deepcopy(LINEAR)
    case["uncertainty"]["parameter"] = [{"name": "R", "distribution": "truncnorm", "mean": 0.8, "std": 0.08,
                                         "bounds": [0.0, 1.0]}]
    assert vibeam.load_case(case).uncertainty.parameter[0].support() == (0.0, 1.0)


def _toml(d):
    from vibeam.api.cases import case_text

    return case_text(vibeam.load_case(d))


def test_the_command_line_writes_the_group_and_jobs_do_not_change_it(tmp_path):
    path = tmp_path / "band.toml"
    path.write_text(_toml(LINEAR))
    out1, out2 = tmp_path / "o1", tmp_path / "o2"
    run = [sys.executable, "-m", "vibeam.cli"]
    subprocess.run(run + ["run", str(path), "--out", str(out1), "--no-plots", "--quiet", "--jobs", "1"], check=True)
    for out, jobs in ((out1, "1"), (out2, "2")):
        p = subprocess.run(run + ["uncertainty", str(path), "--samples", "4", "--out", str(out), "--jobs", jobs],
                           capture_output=True, text=True)
        assert p.returncode == 0, p.stderr
    with h5py.File(out1 / "results.h5") as f1, h5py.File(out2 / "results.h5") as f2:
        assert "runs/exact" in f1 and "uncertainty/exact" in f1          # the sweep kept
        a1, a2 = f1["uncertainty/exact/sample_amplitude"][()], f2["uncertainty/exact/sample_amplitude"][()]
        assert a1.shape == (4, 2, 5) and np.array_equal(a1, a2)
        assert f1["uncertainty/exact/amplitude_quantile"].shape == (5, 2, 5)


def _sobol_reference(Om, n=64):
    """S1 and ST of f(B, beta) = B g(beta), g = Om^2 / |1 - Om^2 + 2 i beta Om|, B and beta uniform on
    LINEAR's bounds, by a 64 x 64 Gauss-Legendre tensor quadrature (exact to round-off for this smooth
    integrand: g is analytic on the beta interval)."""
    x, w = np.polynomial.legendre.leggauss(n)
    Bs, ws = 0.010 + 0.005 * x, w / 2.0                        # uniform [0.005, 0.015]
    bs = 0.05 + 0.01 * x                                      # uniform [0.04, 0.06]
    F = DELTA + _X(Om, Bs[:, None], bs[None, :])              # (B, beta)
    W = ws[:, None] * ws[None, :]
    mean = np.sum(W * F)
    var_ = np.sum(W * (F - mean) ** 2)
    eB = F @ ws                                               # E[f | B]
    eb = ws @ F                                               # E[f | beta]
    S1 = np.array([np.sum(ws * (eB - mean) ** 2), np.sum(ws * (eb - mean) ** 2)]) / var_
    # total: E_beta[Var_B(f | beta)] / Var and E_B[Var_beta(f | B)] / Var
    var_B_given_b = ws @ (F - eb[None, :]) ** 2               # (beta,)
    var_b_given_B = ((F - eB[:, None]) ** 2) @ ws             # (B,)
    ST = np.array([np.sum(ws * var_B_given_b), np.sum(ws * var_b_given_B)]) / var_
    return S1, ST


def test_sobol_indices_equal_a_tensor_quadrature_of_the_closed_form():
    """Issue 45: first-order and total Sobol' indices of the amplitude (B and beta uniform) on the
    non-impacting scene, against a dense tensor-product quadrature of the closed-form linear FRC (no
    scipy estimator in the reference), at 3 frequencies: the issue asks <= 0.02 absolute; measured
    <= 4e-4 at 512 Saltelli samples, so 0.005 (a first-order index taken for a total one is off by 0.012
    at Omega = 1 and fails)."""
    case = copy.deepcopy(LINEAR)
    case["sweep"]["Omega"] = [0.8, 1.2, 3]
    case["sweep"]["direction"] = "up"
    case["uncertainty"] = {"samples": 512, "seed": 5, "sobol": True,
                           "parameter": [{"name": "B", "distribution": "uniform", "bounds": [0.005, 0.015]},
                                         {"name": "beta", "distribution": "uniform", "bounds": [0.04, 0.06]}]}
    r = vibeam.uncertainty(case, quiet=True, jobs=2)[0]
    assert r.amplitude.shape[0] == 512 * 4 and r.base.sum() == 1024
    assert r.attrs["samples"] == 512               # the design's N, not its N (d + 2) rows
    si = r.sobol()
    for k, Om in enumerate(np.linspace(0.8, 1.2, 3)):
        S1, ST = _sobol_reference(Om)
        np.testing.assert_allclose(si["first"][:, 0, k], S1, atol=0.005)
        np.testing.assert_allclose(si["total"][:, 0, k], ST, atol=0.005)
        assert (si["first_ci"][0, :, 0, k] <= si["first"][:, 0, k]).all()
    # the reference is not trivial: near resonance beta matters, away from it B alone
    assert _sobol_reference(1.0)[0][1] > 0.1 and _sobol_reference(0.8)[0][0] > 0.9


def test_the_api_takes_the_command_lines_default_jobs(monkeypatch):
    """``vibeam uncertainty`` without --jobs uses every core (None), as ``vibeam.run`` does: the API's
    default is the same, and it checks ``jobs`` by the rule of --jobs."""
    import inspect

    import vibeam.cli as cli

    assert inspect.signature(vibeam.uncertainty).parameters["jobs"].default is None
    assert inspect.signature(vibeam.run).parameters["jobs"].default is None
    seen = []
    monkeypatch.setattr(cli, "cmd_uncertainty", lambda a: seen.append(a.jobs) or 0)
    assert cli.main(["uncertainty", "any.toml"]) == 0 and seen == [None]
    with pytest.raises(ValueError, match="jobs = 0"):
        vibeam.uncertainty(LINEAR, jobs=0, quiet=True)


def test_samples_build_their_solvers_one_at_a_time(monkeypatch):
    """Memory stays bounded: a solver is built where its sample runs and dropped after it, so 16
    samples swept inline never hold more than two solvers at once (the first sample's, kept for the
    layout, and the running one); building every sample's solver up front held 16."""
    import gc
    import weakref

    import vibeam.analysis.uncertainty as unc

    alive, peak, real = [], [0], unc.make_job

    def counted(*a, **k):
        job = real(*a, **k)
        gc.collect()
        alive.append(weakref.ref(job.solver))
        peak[0] = max(peak[0], sum(w() is not None for w in alive))
        return job

    monkeypatch.setattr(unc, "make_job", counted)
    r = vibeam.uncertainty(LINEAR, jobs=1, quiet=True)[0]
    assert len(alive) == 17 and peak[0] <= 2, (len(alive), peak[0])
    assert r.amplitude.shape == (16, 2, 5)


def _exact_quantiles(Om, probs):
    """Quantiles of f = Delta + B g(beta) (B uniform on [0.005, 0.015], beta triangular on [0.04, 0.06]
    with mode 0.05: LINEAR's design) by inverting its distribution function
    F(y) = int F_B((y - Delta) / g(beta)) p(beta) dbeta, a composite Gauss-Legendre rule of 100 panels x
    32 nodes on each side of the mode (the integrand is piecewise smooth: F_B is clipped), and brentq."""
    from scipy import optimize

    x, w = np.polynomial.legendre.leggauss(32)
    nodes, weights = [], []
    for lo, hi in ((0.04, 0.05), (0.05, 0.06)):
        edges = np.linspace(lo, hi, 101)
        for a, b in zip(edges[:-1], edges[1:]):
            nodes.append(0.5 * (a + b) + 0.5 * (b - a) * x)
            weights.append(0.5 * (b - a) * w)
    beta, wb = np.concatenate(nodes), np.concatenate(weights)
    wb = wb * stats.triang(0.5, loc=0.04, scale=0.02).pdf(beta)
    g = _X(Om, 1.0, beta)

    def cdf(y):
        return float(np.sum(wb * np.clip(((y - DELTA) / g - 0.005) / 0.01, 0.0, 1.0)))

    lo, hi = DELTA + 0.005 * g.min(), DELTA + 0.015 * g.max()
    return np.array([optimize.brentq(lambda y: cdf(y) - p, lo, hi, xtol=1e-14) for p in probs]), \
        DELTA + 0.01 * float(np.sum(wb * g))


def test_bootstrap_intervals_hold_the_exact_quantiles_and_shrink_as_one_over_sqrt_n():
    """The percentile-bootstrap intervals (95 %, 999 resamples) of the amplitude's quantiles and mean on
    the non-impacting scene: each holds the exact value (the closed-form amplitude's distribution
    inverted by quadrature, :func:`_exact_quantiles`) at 256 and 1024 samples, and going from 256 to
    1024 samples narrows them by sqrt(4) = 2: measured 1.59-2.28 per quantile and frequency, median 2.03;
    asserted within 1.3-3 each and 1.7-2.4 for the median (an interval that did not shrink, or shrank
    as 1/N, fails).  The intervals are not trivially wide: at 1024 samples each is below a quarter
    of the 5-95 % spread."""
    case = copy.deepcopy(LINEAR)
    case["sweep"]["Omega"] = [0.8, 1.2, 3]
    case["sweep"]["direction"] = "up"
    probs = [0.05, 0.25, 0.5, 0.75, 0.95]
    exact = [_exact_quantiles(Om, probs) for Om in np.linspace(0.8, 1.2, 3)]
    width = {}
    for n in (256, 1024):
        case["uncertainty"]["samples"] = n
        r = vibeam.uncertainty(case, quiet=True, jobs=2)[0]
        ci = r.bootstrap()
        assert ci["quantile_ci"].shape == (2, 5, 1, 3) and ci["mean_ci"].shape == (2, 1, 3)
        for k, (q, mean) in enumerate(exact):
            lo, hi = ci["quantile_ci"][0, :, 0, k], ci["quantile_ci"][1, :, 0, k]
            assert np.all((lo <= q) & (q <= hi)), (n, k, lo, q, hi)
            assert ci["mean_ci"][0, 0, k] <= mean <= ci["mean_ci"][1, 0, k], (n, k, ci["mean_ci"][:, 0, k], mean)
            assert ci["std_ci"][0, 0, k] > 0 and ci["std_ci"][0, 0, k] < ci["std_ci"][1, 0, k]
        width[n] = ci["quantile_ci"][1, :, 0] - ci["quantile_ci"][0, :, 0]
        if n == 1024:
            spread = np.array([q[-1] - q[0] for q, _ in exact])
            assert np.all(width[n] < 0.25 * spread[None, :]), width[n] / spread
    ratio = width[256] / width[1024]
    assert np.all((1.3 < ratio) & (ratio < 3.0)), ratio
    assert 1.7 < np.median(ratio) < 2.4, ratio
    # reproducible: the same draws on every call (seeded per point)
    np.testing.assert_array_equal(r.bootstrap()["quantile_ci"], ci["quantile_ci"])


def _arrays(h5) -> dict:
    """Every dataset of every group of ``/uncertainty`` as bytes (numbers) or text, and each group's
    attributes: what an interrupted and resumed run must reproduce bit for bit."""
    out = {}
    with h5py.File(h5, "r") as f:
        def visit(name, obj):
            if isinstance(obj, h5py.Dataset):
                v = obj[()]
                out[name] = (v.dtype.str, v.shape, v.tobytes()) if isinstance(v, np.ndarray) and v.dtype != object \
                    else repr(obj.asstr()[()] if v.dtype == object else v)
            else:
                out[name + "/@"] = {k: repr(v) for k, v in obj.attrs.items() if k not in ("DIMENSION_LIST",
                                                                                             "REFERENCE_LIST")}
        f["uncertainty"].visititems(visit)
    return out


def test_an_interrupted_uncertainty_resumes_to_the_same_file_bit_for_bit(tmp_path, monkeypatch, capsys):
    """Ctrl-C after 7 of 32 sampled sweeps (the Saltelli design of 8 samples of B and beta: the Sobol'
    indices and their intervals too): results.h5 (a sweep written before) is byte for byte as it was,
    the 7 samples are in results.h5.partial, and --resume computes only the other 25 and gives a file
    whose /uncertainty arrays and attributes equal an uninterrupted run's bit for bit (the sweep kept);
    the checkpoint is then gone.  Interrupts are injected as tests/test_store.py does (the engine
    finishes some units, hands them on, raises KeyboardInterrupt)."""
    from vibeam.cli import main
    from vibeam.engine import sweep

    case = copy.deepcopy(LINEAR)
    case["uncertainty"] = dict(case["uncertainty"], samples=8, sobol=True)
    path = tmp_path / "band.toml"
    path.write_text(_toml(case))
    whole, part = tmp_path / "whole", tmp_path / "part"
    for out in (whole, part):
        assert main(["run", str(path), "--out", str(out), "--jobs", "1", "--quiet", "--no-plots"]) == 0
    assert main(["uncertainty", str(path), "--out", str(whole), "--jobs", "1", "--quiet", "--no-plots"]) == 0
    before = (part / "results.h5").read_bytes()
    real = sweep.run_lines

    def interrupted(units, on_line=None, **kw):
        for u in list(units)[:7]:
            for _, rows in real([u], jobs=1).items():
                on_line(u, rows)
        raise KeyboardInterrupt

    monkeypatch.setattr(sweep, "run_lines", interrupted)
    assert main(["uncertainty", str(path), "--out", str(part), "--jobs", "1", "--quiet", "--no-plots"]) == 130
    err = capsys.readouterr().err
    assert "is as it was" in err and "--resume" in err and "results.h5.partial" in err, err
    assert (part / "results.h5").read_bytes() == before
    with h5py.File(part / "results.h5.partial") as f:
        kept = f["uncertainty_samples/exact"]
        assert sum(g["sample"].shape[0] for g in kept.values()) == 7
    calls = []

    def counted(units, **kw):
        calls.extend(units)
        return real(units, **kw)

    monkeypatch.setattr(sweep, "run_lines", counted)
    assert main(["uncertainty", str(path), "--out", str(part), "--jobs", "2", "--quiet", "--no-plots",
                 "--resume"]) == 0
    assert len(calls) == 25 and "resuming: 7 sampled sweeps done" in capsys.readouterr().err
    assert not (part / "results.h5.partial").exists()
    a, b = _arrays(whole / "results.h5"), _arrays(part / "results.h5")
    assert "exact/sobol_first_ci" in a and "exact/amplitude_quantile_ci" in a and a["exact/sample_amplitude"][1] == (32, 2, 5)
    assert a.keys() == b.keys() and all(a[k] == b[k] for k in a), [k for k in a if a[k] != b[k]]
    with h5py.File(part / "results.h5") as f:
        assert "runs/exact" in f and not int(f["runs/exact"].attrs.get("stale", 0))


def test_resume_refuses_a_checkpoint_vibeam_did_not_write(tmp_path, monkeypatch):
    """A checkpointed block with a status vibeam never writes: --resume refuses it in one line naming
    the file and the dataset, and writes nothing."""
    from vibeam.cli import main
    from vibeam.engine import sweep

    path = tmp_path / "band.toml"
    path.write_text(_toml(LINEAR))
    real = sweep.run_lines

    def interrupted(units, on_line=None, **kw):
        for u in list(units)[:3]:
            for _, rows in real([u], jobs=1).items():
                on_line(u, rows)
        raise KeyboardInterrupt

    monkeypatch.setattr(sweep, "run_lines", interrupted)
    assert main(["uncertainty", str(path), "--out", str(tmp_path), "--jobs", "1", "--quiet", "--no-plots"]) == 130
    with h5py.File(tmp_path / "results.h5.partial", "r+") as f:
        (g,) = f["uncertainty_samples/exact"].values()
        g["status"][0, 0, 0] = "bogus"
    monkeypatch.setattr(sweep, "run_lines", real)
    partial = (tmp_path / "results.h5.partial").read_bytes()
    with pytest.raises(vibeam.errors.InputError) as e:
        vibeam.uncertainty(str(path), out=tmp_path, resume=True, quiet=True)
    msg = str(e.value)
    assert "\n" not in msg and "results.h5.partial" in msg and "status" in msg and "'bogus'" in msg, msg
    assert (tmp_path / "results.h5.partial").read_bytes() == partial and not (tmp_path / "results.h5").exists()


def test_vibeam_uncertainty_stays_the_function_once_its_module_is_imported():
    """``vibeam.uncertainty`` is the API function although its module has the same name: after the
    command line imported ``vibeam.api.uncertainty`` (the package attribute is then that module),
    ``vibeam.uncertainty(...)`` failed with "'module' object is not callable"."""
    code = ("import vibeam.api.uncertainty, vibeam, sys\n"
            "sys.exit(0 if callable(vibeam.uncertainty) and vibeam.uncertainty.__name__ == 'uncertainty' else 1)\n")
    assert subprocess.run([sys.executable, "-c", code]).returncode == 0


def test_results_uncertainty_round_trips_the_stored_arrays_and_draws_its_figures(tmp_path, monkeypatch):
    """``vibeam uncertainty`` writes uncertainty.png, uncertainty_sobol.png and uncertainty_outcomes.png
    beside results.h5; ``open_results(...).uncertainty`` reads every run back: its ``to_xarray()`` holds
    every dataset of ``/uncertainty/<run>/`` with the values h5py reads (numbers bit for bit), the
    in-memory result of ``vibeam.uncertainty`` gives the same Dataset, and ``plot(kind=...)`` draws the
    band, Sobol' and outcome figures.  ``--resume`` of the complete computation recomputes nothing."""
    from vibeam.cli import main
    from vibeam.engine import sweep

    case = copy.deepcopy(LINEAR)
    case["uncertainty"] = dict(case["uncertainty"], samples=8, sobol=True)
    path = tmp_path / "band.toml"
    path.write_text(_toml(case))
    assert main(["uncertainty", str(path), "--out", str(tmp_path), "--jobs", "1", "--quiet"]) == 0
    for png in ("uncertainty.png", "uncertainty_sobol.png", "uncertainty_outcomes.png"):
        assert (tmp_path / png).stat().st_size > 10_000, png
    res = vibeam.open_results(tmp_path / "results.h5")
    (u,) = res.uncertainty
    assert u.name == "exact" and res.groups["uncertainty/exact"] is u and "uncertainty: 'exact'" in repr(res)
    ds = u.to_xarray()
    with h5py.File(tmp_path / "results.h5") as f:
        g = f["uncertainty/exact"]
        stored = {k: (d.asstr()[()] if d.dtype == object else d[()]) for k, d in g.items()}
        attrs = dict(g.attrs)
    assert set(stored) == set(ds.variables), set(stored) ^ set(ds.variables)
    assert {"sample_amplitude", "amplitude_quantile_ci", "sobol_first_ci", "outcome_probability", "design"} <= set(stored)
    for k, v in stored.items():
        x = ds[k].values
        if np.asarray(v).dtype.kind in "fiu":
            assert x.dtype == v.dtype and x.tobytes() == v.tobytes(), k
        else:
            assert np.array_equal(x.astype(str), np.asarray(v).astype(str)), k
    assert ds["amplitude_quantile_ci"].dims == ("bound", "quantile", "direction", "Omega")
    assert list(ds["bound"].values) == ["low", "high"] and ds.attrs["samples"] == attrs["samples"] == 8
    # the result read back is the result computed; the in-memory one gives the same Dataset
    mem = vibeam.uncertainty(case, jobs=1, quiet=True)[0]
    for k in ("amplitude", "period", "design"):
        assert np.array_equal(getattr(u, k), getattr(mem, k), equal_nan=k != "period"), k
    assert list(u.status.ravel()) == list(mem.status.ravel()) and u.roles == mem.roles and u.attrs == mem.attrs
    dm = mem.to_xarray()
    for k in stored:
        assert np.array_equal(dm[k].values, ds[k].values, equal_nan=dm[k].dtype.kind == "f"), k
    import matplotlib.figure

    for kind in ("bands", "sobol", "outcomes"):
        assert isinstance(u.plot(tmp_path / f"{kind}.png", kind=kind), matplotlib.figure.Figure)
        assert (tmp_path / f"{kind}.png").is_file()
    with pytest.raises(ValueError, match="allowed: bands, sobol, outcomes"):
        u.plot(kind="nope")
    assert vibeam.uncertainty(LINEAR, jobs=1, quiet=True)[0].plot(kind="sobol") is None   # no Saltelli design
    stamp = (tmp_path / "results.h5").stat().st_mtime_ns
    monkeypatch.setattr(sweep, "run_lines", lambda *a, **k: pytest.fail("--resume of a complete run computed"))
    assert main(["uncertainty", str(path), "--out", str(tmp_path), "--jobs", "1", "--quiet", "--no-plots",
                 "--resume"]) == 0
    assert (tmp_path / "results.h5").stat().st_mtime_ns == stamp


#: the SDOF scene of paper Fig. 7 (cases/paper-fig7.toml: beta = 0.015, B = 0.5e-3, R = 0.9, Delta = 0,
#: 400 + 64 periods per point) with R spread as a normal of std 0.05 truncated to [0.7, 1], swept up at 5
#: frequencies: period-1 up to Omega = 2.25, period-1, period-n and non-periodic mixed at 2.5 (a
#: two-mode amplitude distribution)
FIG7_R = {"name": "fig7-R", "model": {"fidelity": "sdof", "beta": 0.015, "B": 0.5e-3, "R": 0.9, "Delta": 0.0},
          "sweep": {"Omega": [1.5, 2.5, 5], "direction": "up", "transient_periods": 400, "record_periods": 64},
          "run": [{"name": "exact", "method": "event"}],
          "uncertainty": {"samples": 1024, "seed": 7,
                          "parameter": [{"name": "R", "distribution": "truncnorm", "mean": 0.9, "std": 0.05,
                                         "bounds": [0.7, 1.0]}]}}


def _plain_monte_carlo(case, n, seed, mean=0.9):
    """``n`` independent draws of R (scipy's truncnorm.rvs, not the design's inverse distribution
    function), each swept as a sample is: amplitudes of shape (n, 1, n_Omega)."""
    from vibeam.analysis.uncertainty import SampleTask
    from vibeam.engine import sweep

    c = vibeam.load_case(case)
    a, b = (0.7 - mean) / 0.05, (1.0 - mean) / 0.05
    R = stats.truncnorm(a, b, loc=mean, scale=0.05).rvs(size=n, random_state=np.random.default_rng(seed))
    n_pts = case["sweep"]["Omega"][2]
    tasks = [SampleTask(f"{i:06d}", "exact", c, c.run[0], (("R", float(v)),), i, n_pts) for i, v in enumerate(R)]
    done = sweep.run_lines(tasks, jobs=2)
    return R, np.stack([done[("exact", t.key)][0]["amplitude"] for t in tasks])


@pytest.mark.slow   # 16,384 + 1,024 sampled sweeps of 5 points: 100 s on 2 cores
def test_qmc_quantiles_agree_with_plain_monte_carlo_within_the_bootstrap_intervals():
    """Issue 45: on the Fig. 7 scene with R uncertain, the amplitude quantiles (5-95 %) of the scrambled
    Sobol' design (1024 samples) against plain Monte Carlo with 16,384 independent draws, at 5
    frequencies: each Monte Carlo quantile (numpy's, computed here) lies inside the QMC estimate's 95 %
    bootstrap interval and the two intervals overlap; the Monte Carlo intervals are about
    sqrt(16) = 4 times narrower (median of the width ratios > 2.5).  Measured: |MC - QMC| at most 0.26
    of the QMC interval's half-width (the QMC intervals are conservative: the bootstrap treats the
    points as independent); drawing the Monte Carlo R from a mean shifted by 0.01 (a fifth of its std)
    puts 23 of the 25 Monte Carlo quantiles outside (up to 2.6 half-widths away).  Runtime 100 s on
    the 2-core machine, shared."""
    from vibeam.analysis.uncertainty import UncertaintyResult

    q = vibeam.uncertainty(FIG7_R, jobs=2, quiet=True)[0]
    assert q.amplitude.shape == (1024, 1, 5)
    R, amp = _plain_monte_carlo(FIG7_R, 16384, seed=2026)
    assert np.isfinite(amp).all() and np.isfinite(q.amplitude).all()
    probs = [0.05, 0.25, 0.5, 0.75, 0.95]
    q_mc = np.quantile(amp[:, 0], probs, axis=0)                  # (quantile, Omega)
    mc = UncertaintyResult(name="mc", parameters=("R",), design=R[:, None], directions=("up",), Omega=q.Omega,
                           amplitude=amp, period=np.zeros(amp.shape, np.int64),
                           status=np.full(amp.shape, "ok", dtype=object), attrs={"seed": 11})
    ci_q, ci_m = q.bootstrap()["quantile_ci"][:, :, 0], mc.bootstrap()["quantile_ci"][:, :, 0]
    inside = (ci_q[0] <= q_mc) & (q_mc <= ci_q[1])
    assert inside.all(), (q.quantiles()[:, 0], q_mc, ci_q)
    assert (np.maximum(ci_q[0], ci_m[0]) <= np.minimum(ci_q[1], ci_m[1])).all()
    ratio = (ci_q[1] - ci_q[0]) / (ci_m[1] - ci_m[0])
    assert np.median(ratio) > 2.5, ratio


def test_samples_on_a_dask_cluster_give_the_local_file(tmp_path):
    """`vibeam uncertainty --scheduler ADDRESS`: the samples run on a dask.distributed LocalCluster
    (loopback, 2 worker processes) through the same executor as every sweep; every stored array
    equals the inline run's bit for bit (same code, same inputs)."""
    distributed = pytest.importorskip("distributed")
    path = tmp_path / "band.toml"
    path.write_text(_toml(LINEAR))
    from vibeam.cli import main
    assert main(["uncertainty", str(path), "--samples", "4", "--out", str(tmp_path / "one"), "--jobs", "1",
                 "--quiet", "--no-plots"]) == 0
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1",
                                  dashboard_address=None) as cluster:
        assert main(["uncertainty", str(path), "--samples", "4", "--out", str(tmp_path / "dask"), "--scheduler",
                     cluster.scheduler_address, "--quiet", "--no-plots"]) == 0
        assert cluster.scheduler.transition_counter > 0         # the samples went through the cluster
    with h5py.File(tmp_path / "one" / "results.h5") as f1, h5py.File(tmp_path / "dask" / "results.h5") as f2:
        g1, g2 = f1["uncertainty/exact"], f2["uncertainty/exact"]
        names = sorted(k for k in g1 if isinstance(g1[k], h5py.Dataset))
        assert "sample_amplitude" in names and names == sorted(k for k in g2 if isinstance(g2[k], h5py.Dataset))
        for k in names:
            a, b = g1[k][()], g2[k][()]
            if a.dtype.kind == "f":
                assert np.array_equal(a, b, equal_nan=True), k
            else:
                assert np.array_equal(a, b), k


def test_sample_runs_inline_gives_every_run_its_rows_roles_and_attrs():
    """:func:`vibeam.analysis.uncertainty.sample_runs` inline (jobs=1) on the non-impacting scene with
    Saltelli's design (4 samples of B: 4 x 3 rows), two runs (a continuation run left out): each run's
    rows, roles, the design's N as ``samples`` (not its rows), the grid, no physical units on the
    nondimensional SDOF; ``done`` rows are not computed again and ``on_sample`` sees each computed
    one once, in this process."""
    from vibeam.analysis.uncertainty import sample_runs
    from vibeam.engine import sweep

    d = copy.deepcopy(LINEAR)
    d["sweep"]["Omega"] = [0.6, 1.4, 3]
    d["run"] = [{"name": "a", "method": "event"}, {"name": "b", "method": "event", "model": {"Delta": 2.0}},
                {"name": "c", "method": "".join(["contin", "uation"]), "parameter": "B", "at": 0.8,
                 "range": [0.005, 0.02]}]                       # (a method read from a file: not the literal)
    d["uncertainty"] = {"samples": 4, "seed": 2, "sobol": True,
                        "parameter": [{"name": "B", "distribution": "uniform", "bounds": [0.005, 0.015]}]}
    case = vibeam.load_case(d)
    seen = []
    res = sample_runs(case, jobs=1, on_sample=lambda run, i, arr: seen.append((run, i, arr["amplitude"].shape)))
    assert [r.name for r in res] == ["a", "b"]
    a, b = res
    assert sorted(seen) == sorted([(r, i, (2, 3)) for r in "ab" for i in range(12)])
    rows, roles = case.uncertainty.saltelli()
    np.testing.assert_array_equal(a.design, rows)
    assert a.roles == tuple(roles) and a.parameters == ("B",) and a.directions == ("up", "down")
    assert {k: v for k, v in a.attrs.items() if k != "verdict_b"} == {"fidelity": "sdof", "method": "event",
                                                                     "samples": 4, "seed": 2}
    assert isinstance(a.attrs["samples"], int)                  # a count of samples, not 4.0
    assert a.frequency_hz is None and a.length_m is None and a.axis[1] == "1"
    np.testing.assert_allclose(a.Omega, [0.6, 1.0, 1.4], rtol=0, atol=1e-15)
    Om = a.Omega
    exact = DELTA + _X(Om[None, :], rows[:, :1], BETA)
    np.testing.assert_allclose(a.amplitude[:, 0], exact, rtol=RTOL)
    np.testing.assert_allclose(b.amplitude[:, 1], exact + 1.0, rtol=RTOL)
    assert "verdict_b" in a.attrs and a.attrs["verdict_b"]["outside_band_a_in_b"] == 1.0
    # resumed: the rows given are kept as they are, only the others computed
    done = {"a": {i: {"amplitude": np.full((2, 3), -1.0), "period": np.full((2, 3), -1, np.int64),
                      "status": np.full((2, 3), "ok", dtype=object)} for i in range(10)}}
    calls = []
    real = sweep.run_lines

    def counted(units, **kw):
        calls.extend(u.key for u in units)
        return real(units, **kw)

    sweep.run_lines = counted
    try:
        again = sample_runs(case, jobs=1, done=done)
    finally:
        sweep.run_lines = real
    assert len(calls) == 2 + 12
    assert (again[0].amplitude[:10] == -1.0).all() and np.array_equal(again[0].amplitude[10:], a.amplitude[10:])
    np.testing.assert_array_equal(again[1].amplitude, b.amplitude)


def test_sample_runs_of_a_physical_scene_are_on_its_frequency_axis():
    """A physical SDOF (fig. 18's rig numbers, the gap opened to 50 mm: no impact): the samples'
    frequency axis is Omega f_n in Hz and the normalising length the scene's, 0.18 m."""
    from vibeam.analysis.uncertainty import sample_runs

    d = {"name": "phys", "model": {"fidelity": "sdof", "natural_frequency_hz": 7.6, "damping_ratio": 0.017,
                                   "R": 0.72, "gap_mm": 50.0, "length_mm": 180.0, "gain": 5.16e-4, "voltage": 0.6},
         "sweep": {"frequency_hz": [4.0, 6.0, 3], "direction": "up", "transient_periods": 100, "record_periods": 4},
         "run": [{"name": "p", "method": "event"}],
         "uncertainty": {"samples": 2, "parameter": [{"name": "voltage", "distribution": "uniform",
                                                      "bounds": [0.5, 0.7]}]}}
    (r,) = sample_runs(vibeam.load_case(d), jobs=1)
    assert r.length_m == pytest.approx(0.18, rel=1e-15) and r.axis[1] == "Hz"
    np.testing.assert_allclose(r.frequency_hz, [4.0, 5.0, 6.0], rtol=1e-14)
    np.testing.assert_allclose(r.frequency_hz, r.Omega * 7.6, rtol=1e-15)
