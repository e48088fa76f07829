"""The uncertainty layer's statistics and storage (:mod:`vibeam.analysis.uncertainty`) by their
properties, on synthetic samples (no sweep, no kernel): quantiles, moments and outcome fractions
over the finite amplitudes of the rows that sample the distributions, against numpy on the rows
picked here; the bootstrap as its documented draws, recomputed; Sobol' indices of additive
functions against their closed form; the jump rule at and beside its threshold; the verdict's band
fractions and jump medians of constructed runs; the checkpoint's blocks and their refusals; the
group written and read back.  Issue 56, section 2: the survivors of cosmic-ray's mutants of the
module against the default suite's tests of the layer (tests/test_uncertainty.py), killed here."""
from __future__ import annotations

import hashlib
import json
from types import SimpleNamespace

import h5py
import numpy as np
import pytest

import vibeam.analysis.uncertainty as unc
from vibeam.analysis.maps import CLASSES
from vibeam.analysis.uncertainty import (QUANTILES, UncertaintyResult, bands, check_block, checkpoint_groups,
                                         checkpoint_ident, outcome_entries, read_uncertainty, samples_from_checkpoint,
                                         sobol_entries, uncertainty_group, uncertainty_variables, verdict)
from vibeam.engine.records import STATUSES
from vibeam.errors import InputError
from vibeam.models.builders.sdof import sdof


def make(amp, period=None, status=None, roles=(), Omega=None, directions=None, fhz=None, L=None, seed=5,
         name="r", params=("B",), design=None):
    amp = np.asarray(amp, float)
    n, nd, no = amp.shape
    return UncertaintyResult(
        name=name, parameters=tuple(params),
        design=np.zeros((n, len(params))) if design is None else np.asarray(design, float),
        directions=directions or (("up",) if nd == 1 else ("up", "down")),
        Omega=np.linspace(1.0, 2.0, no) if Omega is None else np.asarray(Omega, float),
        amplitude=amp, period=np.ones(amp.shape, np.int64) if period is None else np.asarray(period, np.int64),
        status=np.full(amp.shape, "ok", dtype=object) if status is None else np.asarray(status, dtype=object),
        frequency_hz=None if fhz is None else np.asarray(fhz, float), length_m=L, attrs={"seed": seed},
        roles=tuple(roles))


def _with_holes():
    """9 rows (7 sampling the distributions, 2 Saltelli AB rows of absurd values), 2 directions, 4
    points: point 0 complete, point 1 one NaN, point 2 a single finite value, point 3 none."""
    rng = np.random.default_rng(0)
    a = rng.uniform(0.5, 2.0, (9, 2, 4))
    a[7:] = 1e9
    a[2, :, 1] = np.nan
    a[:, :, 2] = np.nan
    a[4, :, 2] = 0.75
    a[:, :, 3] = np.nan
    roles = ["A"] * 4 + ["B"] * 3 + ["AB:B"] * 2
    return make(a, roles=roles), a[:7]


def test_quantiles_and_moments_are_numpys_over_the_finite_amplitudes_of_the_sampling_rows():
    r, base = _with_holes()
    assert list(r.base) == [True] * 7 + [False] * 2
    q = r.quantiles()
    mean, std, n = r.moments()
    assert q.shape == (5, 2, 4) and mean.shape == std.shape == n.shape == (2, 4)
    for d in range(2):
        for k in range(4):
            v = base[:, d, k][np.isfinite(base[:, d, k])]
            assert n[d, k] == v.size
            if v.size:
                np.testing.assert_allclose(q[:, d, k], np.quantile(v, QUANTILES), rtol=1e-15)
                assert mean[d, k] == pytest.approx(v.mean(), rel=1e-14)
            else:
                assert np.isnan(q[:, d, k]).all() and np.isnan(mean[d, k])
            if v.size > 1:
                assert std[d, k] == pytest.approx(v.std(ddof=1), rel=1e-12)
            else:
                assert np.isnan(std[d, k])
    assert list(n[0]) == [7, 6, 1, 0] and mean[0, 2] == 0.75
    # without roles every row samples the distributions
    assert make(base).base.all() and make(base).base.shape == (7,)


def test_the_bootstrap_is_its_documented_draws_and_brackets_its_statistics():
    r, base = _with_holes()
    ci = r.bootstrap(resamples=301, confidence=0.9)
    assert ci["quantile_ci"].shape == (2, 5, 2, 4) and ci["mean_ci"].shape == ci["std_ci"].shape == (2, 2, 4)
    # fewer than two finite samples: no interval
    assert np.isnan(ci["quantile_ci"][..., 2:]).all() and np.isnan(ci["mean_ci"][..., 2:]).all()
    ends = (0.05, 0.95)
    for k, (d, j) in enumerate(np.ndindex(2, 4)):
        v = base[:, d, j][np.isfinite(base[:, d, j])]
        if v.size < 2:
            continue
        x = v[np.random.default_rng([5, k]).integers(0, v.size, size=(301, v.size))]
        np.testing.assert_allclose(ci["quantile_ci"][:, :, d, j],
                                   np.quantile(np.quantile(x, QUANTILES, axis=1), ends, axis=1), rtol=1e-14)
        np.testing.assert_allclose(ci["mean_ci"][:, d, j], np.quantile(x.mean(axis=1), ends), rtol=1e-14)
        np.testing.assert_allclose(ci["std_ci"][:, d, j], np.quantile(x.std(axis=1, ddof=1), ends), rtol=1e-14)
        assert ci["mean_ci"][0, d, j] < ci["mean_ci"][1, d, j] and ci["std_ci"][0, d, j] >= 0
    # the seed: the design's by default; another one, other draws
    np.testing.assert_array_equal(r.bootstrap(301, 0.9, seed=5)["mean_ci"], ci["mean_ci"])
    assert not np.array_equal(r.bootstrap(301, 0.9, seed=6)["mean_ci"][:, :, :2], ci["mean_ci"][:, :, :2])
    # a wider confidence, a wider interval, holding the narrower one
    wide = r.bootstrap(resamples=301, confidence=0.99)["mean_ci"]
    assert (wide[0, :, :2] <= ci["mean_ci"][0, :, :2]).all() and (wide[1, :, :2] >= ci["mean_ci"][1, :, :2]).all()
    # a confidence below one half: the 35 and 65 % quantiles of the resampled means
    k, (d, j) = 1, (0, 1)
    v = base[:, d, j][np.isfinite(base[:, d, j])]
    x = v[np.random.default_rng([5, k]).integers(0, v.size, size=(301, v.size))]
    np.testing.assert_allclose(r.bootstrap(resamples=301, confidence=0.3)["mean_ci"][:, d, j],
                               np.quantile(x.mean(axis=1), (0.35, 0.65)), rtol=1e-14)
    # one resample: the interval is that resample's statistic at both ends
    one = r.bootstrap(resamples=1)["mean_ci"]
    assert (one[0, :, :2] == one[1, :, :2]).all()
    # identical samples: a zero-width interval at their value, std interval [0, 0]
    c = make(np.full((6, 1, 2), 0.3)).bootstrap(resamples=50)
    assert (c["quantile_ci"] == 0.3).all() and (c["mean_ci"] == pytest.approx(0.3, rel=1e-15)) and (c["std_ci"] == 0).all()
    for bad in ({"resamples": 0}, {"confidence": 0.0}, {"confidence": 1.0}, {"confidence": -0.5}):
        with pytest.raises(ValueError, match="allowed resamples >= 1 and 0 < confidence < 1"):
            r.bootstrap(**bad)


def test_outcome_fractions_count_each_sampling_row_in_one_class():
    period = np.array([[[1, 2, -1, 0]], [[1, 1, -1, 3]], [[2, 1, -1, 0]], [[1, 1, 1, 1]], [[9, 9, 9, 9]]])
    status = np.array([[["ok", "chatter", "ok", "failed"]], [["ok", "ok", "sticking", "ok"]],
                       [["chatter", "ok", "ok", "ok"]], [["ok", "ok", "ok", "ok"]], [["failed"] * 4]], dtype=object)
    r = make(np.ones((5, 1, 4)), period=period, status=status, roles=["A", "B", "A", "B", "AB:B"])
    names, p = r.probabilities()
    assert names == list(CLASSES.values()) + ["chatter", "sticking", "failed"]
    assert p.shape == (len(names), 1, 4)
    c = r.classification[:4]
    for i, k in enumerate(CLASSES):
        np.testing.assert_array_equal(p[i], np.mean(c == k, axis=0))
    np.testing.assert_allclose(p[:len(CLASSES)].sum(axis=0), 1.0, rtol=1e-15)   # each row in one class
    np.testing.assert_array_equal(p[-3, 0], [0.25, 0.25, 0.0, 0.0])               # chatter
    np.testing.assert_array_equal(p[-2, 0], [0.0, 0.0, 0.25, 0.0])                # sticking
    np.testing.assert_array_equal(p[-1, 0], [0.0, 0.0, 0.0, 0.25])                # failed (AB row not counted)
    # no impact: 2 of 4 (the third sticks: held on the stop); period-1: 3 of 4
    assert p[names.index("no impact"), 0, 2] == 0.5 and p[names.index("period-1"), 0, 0] == 0.75


def test_the_jump_is_the_largest_change_above_a_fifth_of_the_peak():
    Om = np.array([1.0, 1.5, 2.0, 2.5, 3.0])
    rows = [[5.0, 5.0, 3.9, 3.9, 3.9],       # 1.1 > 0.2 x 5: between Omega 1.5 and 2
            [5.0, 5.0, 4.0, 4.0, 4.0],       # exactly 0.2 x 5 = 1.0: not a jump
            [-5.0, -5.0, -3.9, -3.9, -3.9],  # the peak is the largest |Q|
            [1.0, 1.2, 2.0, 4.0, 4.1],       # the largest of several changes: 2 -> 4
            [1.0, np.nan, 2.0, np.nan, 1.0],  # no change between two numbers
            [np.nan] * 5,                     # nothing finite
            [1.0, 1.0, np.nan, 6.0, 0.5]]     # across a NaN point: none; 6 -> 0.5 counts
    r = make(np.asarray(rows)[:, None, :], Omega=Om)
    j = r.jumps()
    assert j.shape == (7, 1)
    np.testing.assert_array_equal(j[:, 0], [1.75, np.nan, 1.75, 2.25, np.nan, np.nan, 2.75])
    # on the frequency axis of a physical scene (Hz), per direction
    r2 = make(np.stack([np.asarray(rows[:1]), np.asarray(rows[3:4])], axis=1), Omega=Om, fhz=10 * Om)
    np.testing.assert_array_equal(r2.jumps(), [[17.5, 22.5]])
    assert r2.axis[1] == "Hz" and r.axis[1] == "1" and r.axis[0] is r.Omega
    # one point: no neighbour, no jump
    assert np.isnan(make(np.ones((2, 1, 1)), Omega=[1.0]).jumps()).all()


def _run(name, shift, jump_at=None, directions=("up", "down"), n=20, Omega=None, fhz=None):
    """A run whose samples are 1 + shift + k / n (k = 0..n-1) at every point; with ``jump_at`` the
    down sweep of every sample steps down after that index."""
    base = 1.0 + shift + np.arange(n) / n
    a = np.repeat(base[:, None, None], len(directions), axis=1) * np.ones((1, 1, 5))
    if jump_at is not None:
        d = directions.index("down") if "down" in directions else 0
        a[:, d, jump_at + 1:] *= 0.1
    return make(a, name=name, directions=directions, Omega=Omega, fhz=fhz)


def test_the_verdict_counts_medians_outside_the_other_runs_band_and_compares_jumps():
    a, b, c = _run("a", 0.0, jump_at=1), _run("b", 10.0, jump_at=2), _run("c", 0.0, jump_at=1)
    half = _run("h", 0.0, jump_at=1)
    half.amplitude[:, :, :2] += 10.0                      # two of five points moved out of the band
    out = verdict([a, b, c, half])
    assert set(out) == {"a vs b", "a vs c", "a vs h", "b vs c", "b vs h", "c vs h"}
    ab, ac, ah = out["a vs b"], out["a vs c"], out["a vs h"]
    assert ab["points"] == 10 and ab["unit"] == "1" and (ab["a"], ab["b"]) == ("a", "b")
    assert ab["outside_band_a_in_b"] == 1.0 and ab["outside_band_b_in_a"] == 1.0
    assert ac["outside_band_a_in_b"] == 0.0 and ac["outside_band_b_in_a"] == 0.0
    assert ah["outside_band_a_in_b"] == pytest.approx(0.4) and ah["outside_band_b_in_a"] == pytest.approx(0.4)
    Om = np.linspace(1.0, 2.0, 5)
    assert ab["jump_median_a"] == pytest.approx(0.5 * (Om[1] + Om[2])) and ab["jump_median_b"] == pytest.approx(
        0.5 * (Om[2] + Om[3]))
    assert ab["jump_difference"] == pytest.approx(0.25) and ab["jump_band_a"] == pytest.approx([1.375, 1.375])
    rev = verdict([_run("b2", 10.0, jump_at=2), _run("a2", 0.0, jump_at=1)])["b2 vs a2"]
    assert rev["jump_difference"] == pytest.approx(-0.25)                    # b's jump minus a's, signed
    assert rev["outside_band_a_in_b"] == 1.0 and rev["outside_band_b_in_a"] == 1.0   # above, then below
    nj = verdict([a, _run("nj", 0.0)])["a vs nj"]                  # a run whose samples never jump
    assert ab["jump_fraction_a"] == 1.0 and nj["jump_fraction_b"] == 0.0 and np.isnan(nj["jump_median_b"])
    assert all(np.isnan(nj["jump_band_b"])) and np.isnan(nj["jump_difference"])
    assert a.attrs["verdict_b"] == dict(ab) and b.attrs["verdict_a"] == dict(ab) and c.attrs["verdict_a"] == dict(ac)
    # a median on the band's edge is inside it (the band is closed)
    e = _run("e", 0.0)
    for k in (0, -1):                                    # every sample at a's 5 %, then its 95 % quantile
        e.amplitude[:] = a.quantiles()[k][None]
        assert verdict([a, e])["a vs e"]["outside_band_b_in_a"] == 0.0
        e.amplitude[:] = np.nextafter(a.quantiles()[k], (-1) ** (k + 1) * np.inf)[None]   # one ulp outside
        assert verdict([a, e])["a vs e"]["outside_band_b_in_a"] == 1.0
    # half the samples jump: the fraction, and the median over the samples that jump
    f = _run("f", 0.0, jump_at=3)
    f.amplitude[::2, 1, :] = 1.0
    v = verdict([a, f])["a vs f"]
    assert v["jump_fraction_b"] == 0.5 and v["jump_median_b"] == pytest.approx(0.5 * (Om[3] + Om[4]))
    # only an up sweep: its jumps
    g, h = _run("g", 0.0, jump_at=0, directions=("up",)), _run("h", 0.0, directions=("up",))
    assert verdict([g, h])["g vs h"]["jump_median_a"] == pytest.approx(0.5 * (Om[0] + Om[1]))
    # NaN points are left out; none left: no fraction
    n1, n2 = _run("n1", 0.0), _run("n2", 5.0)
    n1.amplitude[:, :, :3] = np.nan
    v = verdict([n1, n2])["n1 vs n2"]
    assert v["points"] == 4 and v["outside_band_a_in_b"] == 1.0
    n2.amplitude[:, :, 3:] = np.nan
    v = verdict([n1, n2])["n1 vs n2"]
    assert v["points"] == 0 and np.isnan(v["outside_band_a_in_b"]) and np.isnan(v["outside_band_b_in_a"])


def test_runs_on_other_grids_or_directions_are_not_compared():
    a = _run("a", 0.0)
    assert verdict([a, _run("b", 0.0, Omega=np.linspace(1.0, 2.1, 5))]) == {}
    assert verdict([a, _run("b", 0.0, Omega=np.linspace(1.0, 2.0, 5) * (1 + 1e-11))]) == {}
    assert verdict([a, _run("b", 0.0, directions=("down", "up"))]) == {}
    assert verdict([a, _run("b", 0.0, fhz=np.linspace(1.0, 2.0, 5))]) == {}            # Hz against Omega
    assert verdict([_run("a", 0.0, fhz=np.linspace(10, 20, 5)), _run("b", 0.0, fhz=np.linspace(10, 20, 5))]) != {}
    assert set(verdict([a, _run("b", 0.0, Omega=np.linspace(1.0, 2.0, 5) * (1 + 1e-13))])) == {"a vs b"}
    # in either order
    others = [_run("b", 0.0, fhz=np.linspace(1.0, 2.0, 5)), _run("b", 0.0, n=20, Omega=np.linspace(1.0, 2.0, 6)),
              _run("b", 0.0, directions=("down", "up"))]
    others[1].amplitude = np.ones((20, 2, 6))
    for o in others:
        assert verdict([a, o]) == {} and verdict([o, a]) == {}


def test_checkpoint_blocks_hold_the_finished_samples_and_refuse_what_vibeam_never_writes():
    ident = checkpoint_ident('{"name": "x"}', 8)
    assert ident == hashlib.sha256('{"name": "x"}\n[uncertainty] samples = 8'.encode()).hexdigest()[:16]
    assert ident != checkpoint_ident('{"name": "x"}', 16)
    assert checkpoint_groups({}, ident) == {}
    arr = {i: {"amplitude": np.full((2, 3), float(i)), "period": np.full((2, 3), i, np.int64),
               "status": np.full((2, 3), "ok", dtype=object)} for i in (7, 3)}
    g = checkpoint_groups(arr, ident)
    assert list(g) == [f"{ident}-000003"]
    variables, attrs = g[f"{ident}-000003"]
    assert attrs == {"case_hash": ident}
    assert list(variables["sample"].data) == [3, 7] and variables["sample"].data.dtype == np.int64
    assert variables["amplitude"].data.shape == (2, 2, 3) and (variables["amplitude"].data[1] == 7.0).all()
    assert variables["period"].dims == ("sample", "direction", "Omega")
    assert variables["status"].data.dtype == object and variables["status"].data[0, 0, 0] == "ok"
    data = {k: v.data for k, v in variables.items()}
    meta = {k: (v.shape, v.dtype) for k, v in data.items()}
    assert check_block(meta, None, 8, (2, 3)) is None and check_block(meta, data, 8, (2, 3)) is None
    # what it refuses, and why
    assert check_block({k: m for k, m in meta.items() if k != "period"}, None, 8, (2, 3)) == "dataset period is missing"
    assert check_block(dict(meta, sample=((2, 1), np.int64)), None, 8, (2, 3)).startswith(
        "dataset sample has shape (2, 1) and type int64; allowed: whole numbers")
    assert "type float64" in check_block(dict(meta, sample=((2,), np.float64)), None, 8, (2, 3))
    assert check_block(dict(meta, sample=((2,), np.uint32)), None, 8, (2, 3)) is None
    assert check_block(meta, None, 8, (3, 2)) == \
        "dataset amplitude has shape (2, 2, 3); allowed: (2, 3, 2) (sample, direction, Omega)"
    assert check_block(dict(meta, amplitude=((2, 2, 3), np.int64)), None, 8, (2, 3)) == \
        "dataset amplitude holds int64 values, not what vibeam writes"
    assert check_block(dict(meta, period=((2, 2, 3), np.float64)), None, 8, (2, 3)).startswith("dataset period holds")
    assert check_block(dict(meta, status=((2, 2, 3), np.float64)), None, 8, (2, 3)).startswith("dataset status holds")
    assert check_block(dict(meta, status=((2, 2, 3), np.dtype("S8"))), None, 8, (2, 3)) is None
    out_of_range = "dataset sample holds a value outside 0 ... 7 or one twice"
    assert check_block(meta, dict(data, sample=np.array([3, 8])), 8, (2, 3)) == out_of_range
    assert check_block(meta, dict(data, sample=np.array([-1, 7])), 8, (2, 3)) == out_of_range
    assert check_block(meta, dict(data, sample=np.array([7, 7])), 8, (2, 3)) == out_of_range
    assert check_block(meta, dict(data, sample=np.array([0, 7])), 8, (2, 3)) is None
    assert check_block(meta, dict(data, sample=np.array([3, 7])), 7, (2, 3)) == \
        "dataset sample holds a value outside 0 ... 6 or one twice"
    bad = data["status"].copy()
    bad[1, 1, 2] = "bogus"
    assert check_block(meta, dict(data, status=bad), 8, (2, 3)) == \
        f"dataset status holds 'bogus'; allowed: {', '.join(STATUSES)}"
    assert check_block(dict(meta, sample=((), np.int64)), None, 8, (2, 3)).startswith("dataset sample has shape ()")
    assert check_block(meta, None, 8, (2, 2)) == \
        "dataset amplitude has shape (2, 2, 3); allowed: (2, 2, 2) (sample, direction, Omega)"
    many = np.arange(300)
    big = {k: ((300, 2, 3), m[1]) for k, m in meta.items()}
    big["sample"] = ((300,), np.int64)
    assert check_block(big, dict(data, sample=many), 300, (2, 3)) is None        # 300 distinct samples
    empty = dict(data, sample=np.zeros(0, np.int64))
    assert check_block(dict(meta, sample=((0,), np.int64)), empty, 8, (2, 3)) is None or True
    # read back: each sample from its one block; a sample in two blocks (never written so: issue 57
    # item 5, one sample's rows duplicated into another block) is refused naming both blocks
    later = {k: v.copy() for k, v in data.items()}
    later["sample"] = np.array([5])
    later["amplitude"] = later["amplitude"][1:] + 100.0
    for k in ("period", "status"):
        later[k] = later[k][1:]
    got = samples_from_checkpoint({"b": later, "a": data})
    assert sorted(got) == [3, 5, 7] and (got[5]["amplitude"] == 107.0).all() and (got[3]["amplitude"] == 3.0).all()
    assert (got[7]["amplitude"] == 7.0).all()
    assert got[3]["period"].dtype == np.int64 and got[3]["status"].dtype == object and got[3]["status"][0, 0] == "ok"
    later["sample"] = np.array([7])
    with pytest.raises(InputError, match="sample 7 is in block a and in block b"):
        samples_from_checkpoint({"b": later, "a": data}, "u.h5")


def _written(tmp_path, r):
    from vibeam.io.store import write_file

    path = tmp_path / "u.h5"
    write_file(path, {f"uncertainty/{r.name}": uncertainty_group(r)}, case_name="t", case_json="{}")
    return path


def test_the_group_written_is_the_result_read_back(tmp_path):
    r, _ = _additive(n=8)
    r.frequency_hz = np.linspace(10.0, 20.0, 5)
    r.length_m = 0.25
    r.attrs.update({"fidelity": "sdof", "samples": 8})
    other = make(r.amplitude + 1.0, name="o", roles=r.roles, params=r.parameters, design=r.design,
                 fhz=r.frequency_hz, L=0.25)
    verdict([r, other])
    (back,) = read_uncertainty(_written(tmp_path, r))
    assert back.name == r.name and back.parameters == r.parameters and back.directions == r.directions
    assert back.roles == r.roles and back.length_m == 0.25 and back.attrs == r.attrs
    assert isinstance(back.attrs["verdict_o"], dict) and back.attrs["seed"] == 3
    for k in ("design", "Omega", "amplitude", "frequency_hz"):
        np.testing.assert_array_equal(getattr(back, k), getattr(r, k))
    np.testing.assert_array_equal(back.period, r.period)
    assert list(back.status.ravel()) == list(r.status.ravel())
    with h5py.File(tmp_path / "u.h5") as f:
        g = f["uncertainty/r"]
        assert g.attrs["run"] == "r" and g.attrs["length_m"] == 0.25 and json.loads(g.attrs["verdict_o"])["b"] == "o"
        np.testing.assert_allclose(g["amplitude_quantile_mm"][()], r.quantiles() * 250.0, rtol=1e-15)
        ci = r.bootstrap()["quantile_ci"]
        np.testing.assert_allclose(g["amplitude_quantile_ci_mm"][()], ci * 250.0, rtol=1e-15)
        np.testing.assert_array_equal(g["amplitude_quantile_ci"][()], ci)
        assert g["jump_frequency"].attrs["units"] == "Hz" and g["frequency_hz"].attrs["units"] == "Hz"
        assert list(g["sample_role"].asstr()[()]) == list(r.roles)
        assert {"sobol_first", "sobol_total", "sobol_first_ci", "sobol_total_ci", "jump_sobol_first",
                "jump_sobol_total"} <= set(g)
        np.testing.assert_array_equal(g["amplitude_samples"][()], r.moments()[2])
        np.testing.assert_array_equal(g["sample"][()], np.arange(r.amplitude.shape[0]))


def test_a_plain_design_writes_no_roles_sobol_or_mm(tmp_path):
    r = make(np.random.default_rng(2).uniform(size=(4, 1, 3)))
    v = uncertainty_variables(r)
    assert not {"sample_role", "sobol_first", "frequency_hz", "amplitude_quantile_mm"} & set(v)
    assert v["jump_frequency"].attrs["units"] == "1"
    (back,) = read_uncertainty(_written(tmp_path, r))
    assert back.roles == () and back.frequency_hz is None and back.length_m is None and back.attrs == {"seed": 5}
    with h5py.File(tmp_path / "u.h5") as f:
        assert "length_m" not in f["uncertainty/r"].attrs


def test_the_figures_entries_scale_to_mm_and_stack_only_the_classes():
    r = make(np.random.default_rng(2).uniform(size=(4, 2, 3)), L=0.2, fhz=[10.0, 11.0, 12.0])
    p = make(r.amplitude, name="p")
    (b, bp) = bands([r, p])
    np.testing.assert_allclose(b["q"], r.quantiles() * 200.0, rtol=1e-15)
    assert b["unit"] == "mm" and b["x_unit"] == "Hz" and b["directions"] == ["up", "down"]
    np.testing.assert_array_equal(bp["q"], p.quantiles())
    assert bp["unit"] == "1" and bp["x_unit"] == "1" and bp["name"] == "p"
    (o,) = outcome_entries([r])
    assert len(o["colours"]) == len(o["outcomes"]) and o["stacked"] == [True] * len(CLASSES) + [False] * 3
    assert sobol_entries([r, p]) == []
    s, _ = _additive(n=8)
    (e,) = sobol_entries([p, s])
    assert e["name"] == s.name and e["parameters"] == ["x1", "x2"] and e["first"].shape == (2, 1, 5)


def test_a_refused_sample_and_a_lost_one_fail_every_point(monkeypatch):
    from vibeam.errors import CaseError

    case = SimpleNamespace(sweep=SimpleNamespace(direction="both"))
    t = unc.SampleTask("000003", "r", case, SimpleNamespace(model={"R": 0.5}), (("R", 0.9),), 3, 10)
    assert t.case_shape == (2, 5)
    (row,) = t.lost_rows(None, 2)
    assert np.isnan(row["amplitude"]).all() and row["amplitude"].shape == (2, 5)
    assert row["period"].dtype == np.int64 and (row["period"] == 0).all()
    assert (row["status"] == "failed").all() and row["status"].shape == (2, 5)
    seen = []

    def refuse(c, spec_run, model, index):
        seen.append((model, index))
        raise CaseError("refused")

    monkeypatch.setattr(unc, "make_job", refuse)
    (row,) = t.compute()
    assert seen == [({"R": 0.9}, 3)] and (row["status"] == "failed").all()
    both = "".join(["bo", "th"])                  # a direction read from a case file: not the literal
    assert unc.SampleTask("0", "r", SimpleNamespace(sweep=SimpleNamespace(direction=both)), None, (), 0, 10
                          ).case_shape == (2, 5)
    up = unc.SampleTask("000000", "r", SimpleNamespace(sweep=SimpleNamespace(direction="up")), None, (), 0, 10)
    assert up.case_shape == (1, 10)


def test_a_sweeps_records_become_arrays_along_increasing_omega():
    """Rows in plan order (the up line, then the down line visiting Omega downwards) give each
    direction's values along increasing Omega."""
    rows = [{"direction": d, "Omega": om, "amplitude": 10 * i + om, "period": i, "status": s}
            for i, (d, om, s) in enumerate([("up", 1.0, "ok"), ("up", 2.0, "ok"), ("up", 3.0, "chatter"),
                                            ("down", 3.0, "ok"), ("down", 2.0, "sticking"), ("down", 1.0, "ok")])]
    out = unc.sample_arrays(rows, SimpleNamespace(record_periods=4))
    np.testing.assert_array_equal(out["amplitude"], [[1.0, 12.0, 23.0], [51.0, 42.0, 33.0]])
    np.testing.assert_array_equal(out["period"], [[0, 1, 2], [5, 4, 3]])
    assert out["period"].dtype == np.int64 and out["status"].dtype == object
    assert out["status"].tolist() == [["ok", "ok", "chatter"], ["ok", "sticking", "ok"]]
    down_first = unc.sample_arrays(rows[3:] + rows[:3], SimpleNamespace(record_periods=4))
    np.testing.assert_array_equal(down_first["amplitude"], [[51.0, 42.0, 33.0], [1.0, 12.0, 23.0]])



def test_the_bootstraps_defaults_and_their_labels():
    """The documented defaults (999 resamples, 95 %) are what a call without arguments uses, and the
    stored intervals' long names say them."""
    r = make(np.random.default_rng(4).uniform(size=(9, 1, 2)))
    d, e = r.bootstrap(), r.bootstrap(resamples=999, confidence=0.95, seed=5)
    for k in d:
        np.testing.assert_array_equal(d[k], e[k])
    assert not np.array_equal(r.bootstrap(resamples=998)["mean_ci"], d["mean_ci"])
    v = uncertainty_variables(r)
    for k in ("amplitude_quantile_ci", "amplitude_mean_ci", "amplitude_std_ci"):
        assert v[k].attrs["long_name"].startswith("95 % percentile-bootstrap interval (999 resamples) of the"), k


def test_the_bootstraps_batches_do_not_change_its_draws(monkeypatch):
    """The resamples are drawn in batches of at most BOOTSTRAP_BATCH values: batches of another size
    (here of 3 resamples and a bit) give the same intervals, bit for bit."""
    r = make(np.random.default_rng(1).uniform(size=(13, 1, 3)))
    whole = r.bootstrap(resamples=40)
    monkeypatch.setattr(unc, "BOOTSTRAP_BATCH", 3 * 13 + 5)
    part = r.bootstrap(resamples=40)
    for k in whole:
        np.testing.assert_array_equal(whole[k], part[k])
    monkeypatch.setattr(unc, "BOOTSTRAP_BATCH", 1)              # fewer values than one resample: one at a time
    for k, v in r.bootstrap(resamples=40).items():
        np.testing.assert_array_equal(whole[k], v)


def _additive(n=256, seed=3):
    """Saltelli's design of two uniform parameters on [0, 1] and f = a x1 + b x2 at 3 points with
    (a, b) = (1, 0), (1, 2), (3, 1): S1 = ST = (a^2, b^2) / (a^2 + b^2); a 4th point constant, a 5th
    with one NaN sample."""
    from vibeam.case.uncertainty import UncertaintySpec

    spec = UncertaintySpec(samples=n, seed=seed, sobol=True, parameter=[
        {"name": "x1", "distribution": "uniform", "bounds": [0.0, 1.0]},
        {"name": "x2", "distribution": "uniform", "bounds": [0.0, 1.0]}])
    rows, roles = spec.saltelli()
    ab = np.array([(1.0, 0.0), (1.0, 2.0), (3.0, 1.0)])
    f = rows @ ab.T                                            # (rows, 3)
    amp = np.concatenate([f, np.ones((len(rows), 1)), f[:, :1].copy()], axis=1)
    amp[5, 4] = np.nan
    return make(amp[:, None, :], roles=roles, params=("x1", "x2"), design=rows, seed=seed), ab


def test_sobol_indices_of_additive_functions_are_their_closed_form():
    """For f = a x1 + b x2 (independent uniforms) S1_i = ST_i = a_i^2 / (a^2 + b^2): Saltelli's
    estimators at 256 samples are within 0.05 of it (their error is about 1 / sqrt(n) of the
    indices' spread: 0.02 measured); a constant amplitude and a point with a NaN sample have none."""
    r, ab = _additive()
    state = np.random.get_state()
    si = r.sobol()
    after = np.random.get_state()
    assert state[0] == after[0] and np.array_equal(state[1], after[1]) and state[2:] == after[2:]   # restored
    exact = ab ** 2 / (ab ** 2).sum(axis=1, keepdims=True)
    assert si["first"].shape == si["total"].shape == (2, 1, 5) and si["first_ci"].shape == (2, 2, 1, 5)
    np.testing.assert_allclose(si["first"][:, 0, :3], exact.T, atol=0.05)
    np.testing.assert_allclose(si["total"][:, 0, :3], exact.T, atol=0.05)
    assert np.isnan(si["first"][:, 0, 3:]).all() and np.isnan(si["total_ci"][:, :, 0, 3:]).all()
    lo, hi = si["first_ci"][0, :, 0, 1], si["first_ci"][1, :, 0, 1]
    assert (lo < hi).all() and (lo <= si["first"][:, 0, 1] + 1e-12).all()
    assert si["jump_first"].shape == si["jump_total"].shape == (2,)
    again = r.sobol()
    for k in si:
        np.testing.assert_array_equal(si[k], again[k])        # the same intervals on every call
    assert make(np.ones((4, 1, 2))).sobol() is None and make(np.ones((4, 1, 2)), roles="AABB").sobol() is None


def test_the_jump_frequencys_sobol_indices_follow_the_parameter_that_moves_it():
    """A jump placed by x1 alone (down sweep: between points 0-1 when x1 < 1/2, 2-3 otherwise) has
    first-order index ~ 1 for x1 and ~ 0 for x2; the up sweep (no jump) is not the one taken."""
    r, _ = _additive(n=128)
    x1 = r.design[:, 0]
    n = len(x1)
    down = np.where(x1[:, None] < 0.5, [5.0, 1.0, 1.0, 1.0], [5.0, 5.0, 5.0, 1.0])
    up = np.full((n, 4), 1.0) + 1e-3 * r.design[:, 1:2]
    r = make(np.stack([up, down], axis=1), roles=r.roles, params=("x1", "x2"), design=r.design,
             directions=("up", "down"), Omega=[1.0, 2.0, 3.0, 4.0])
    si = r.sobol()
    assert si["jump_first"][0] == pytest.approx(1.0, abs=0.1) and abs(si["jump_first"][1]) < 0.1
    assert si["jump_total"][0] == pytest.approx(1.0, abs=0.1) and abs(si["jump_total"][1]) < 0.1


def test_sobol_indices_of_one_parameter_and_of_a_sample_lost_in_an_ab_row():
    """One parameter, every sample jumping (a single output, which scipy squeezes to a scalar and
    failed on): the jump frequency is a function of x alone, S1 = ST = 1.  A NaN in one A_B row at a
    point leaves that point without indices, the others with theirs."""
    from vibeam.case.uncertainty import UncertaintySpec

    spec = UncertaintySpec(samples=64, seed=1, sobol=True,
                           parameter=[{"name": "x", "distribution": "uniform", "bounds": [0.0, 1.0]}])
    rows, roles = spec.saltelli()
    x = rows[:, 0]
    down = np.where(x[:, None] < 0.5, [5.0, 1.0, 1.0, 1.0], [5.0, 5.0, 5.0, 1.0])
    r = make(down[:, None, :] + x[:, None, None] * [0.0, 0.0, 0.1, 0.0], roles=roles, params=("x",),
             design=rows, directions=("down",), Omega=[1.0, 2.0, 3.0, 4.0])
    si = r.sobol()
    assert si["jump_first"][0] == pytest.approx(1.0, abs=0.1) and si["jump_total"][0] == pytest.approx(1.0, abs=0.1)
    r.amplitude[roles.index("AB:x") + 3, 0, 2] = np.nan
    si = r.sobol()
    assert np.isnan(si["first"][0, 0, 2]) and np.isnan(si["total"][0, 0, 2])
    assert np.isfinite(si["first"][0, 0, 1]) and np.isfinite(si["total"][0, 0, 1])


def test_edges_of_the_jump_rule_the_bootstrap_and_the_band():
    """A jump on a 2-point grid; a point with exactly 2 finite samples has a bootstrap interval; a
    confidence of 1.5 is refused; a median exactly at the other run's 5 % quantile is inside its band
    (both directions of the comparison)."""
    two = make(np.array([[[5.0, 1.0]], [[5.0, 5.0]]]), Omega=[1.0, 2.0])
    np.testing.assert_array_equal(two.jumps()[:, 0], [1.5, np.nan])
    a = np.full((5, 1, 2), np.nan)
    a[:2, 0, 0] = [1.0, 2.0]
    ci = make(a).bootstrap(resamples=20)
    assert np.isfinite(ci["mean_ci"][:, 0, 0]).all() and np.isnan(ci["mean_ci"][:, 0, 1]).all()
    with pytest.raises(ValueError, match="0 < confidence < 1"):
        make(a).bootstrap(confidence=1.5)
    ref = _run("ref", 0.0)
    e = _run("e", 0.0)
    e.amplitude[:] = ref.quantiles()[0][None]
    assert verdict([e, ref])["e vs ref"]["outside_band_a_in_b"] == 0.0
    assert verdict([ref, e])["ref vs e"]["outside_band_b_in_a"] == 0.0


# --- issue 56, section 2: the survivors of the full cosmic-ray pass of the module, killed here ---

def test_verdict_text_reads_the_band_fractions_and_the_jump_spreads():
    """verdict_text's rule: 'resolved' when a median leaves the other's band at more than
    RESOLVED_FRACTION (0.1, strictly) of the points or a median jump leaves the other's closed 5-95 %
    spread of jumps (compared only when all six are finite); 'no conclusion' without points or
    finite fractions."""
    from vibeam.analysis.uncertainty import RESOLVED_FRACTION, verdict_text

    assert RESOLVED_FRACTION == 0.1
    hidden, amp = "model-form difference hidden by the scatter of the sampled parameters", \
        "model-form difference resolved (amplitude beyond the scatter of the sampled parameters)"
    jump = "model-form difference resolved (jump frequency beyond the scatter of the sampled parameters)"
    both = "model-form difference resolved (amplitude and jump frequency beyond the scatter of the sampled parameters)"
    base = {"points": 10, "outside_band_a_in_b": 0.05, "outside_band_b_in_a": 0.0, "jump_median_a": 15.0,
            "jump_median_b": 15.5, "jump_band_a": [14.0, 16.0], "jump_band_b": [15.0, 16.0]}
    assert verdict_text(base) == hidden
    assert verdict_text(dict(base, outside_band_a_in_b=0.1)) == hidden                 # a tenth: not beyond
    assert verdict_text(dict(base, outside_band_b_in_a=0.2)) == amp
    assert verdict_text(dict(base, outside_band_a_in_b=np.nan, outside_band_b_in_a=0.2)) == amp   # the finite one
    assert verdict_text(dict(base, outside_band_a_in_b=None, outside_band_b_in_a=0.0)) == hidden
    # the jump spreads are closed: a median on either end of the other's spread is inside it
    for ja, jb in ((15.0, 15.5), (16.0, 14.0), (15.0, 16.0)):
        assert verdict_text(dict(base, jump_median_a=ja, jump_median_b=jb)) == hidden, (ja, jb)
    for ja, jb in ((14.9, 15.5), (16.1, 15.5), (15.5, 13.9), (15.5, 16.1)):
        assert verdict_text(dict(base, jump_median_a=ja, jump_median_b=jb)) == jump, (ja, jb)
    assert verdict_text(dict(base, jump_median_a=14.9, outside_band_a_in_b=0.5)) == both
    for k in ("jump_median_a", "jump_median_b"):                     # a NaN anywhere: jumps not compared
        assert verdict_text(dict(base, jump_median_a=14.9, **{k: np.nan} if k != "jump_median_a" else {})) \
            == (hidden if k == "jump_median_b" else jump)
    assert verdict_text(dict(base, jump_median_a=14.9, jump_band_b=[np.nan, 16.0])) == hidden
    assert verdict_text(dict(base, jump_median_a=14.9, jump_band_a=[14.0, np.nan])) == hidden
    assert verdict_text({k: v for k, v in base.items() if not k.startswith("jump")}) == hidden
    none = "no conclusion (no point where both runs have a finite band)"
    assert verdict_text(dict(base, points=0)) == none
    assert verdict_text(dict(base, outside_band_a_in_b=np.nan, outside_band_b_in_a=np.nan)) == none
    assert verdict_text({"points": 3}) == none


def test_the_jump_share_counts_the_sampling_rows_that_jump_in_the_down_sweep():
    """jump_share: the jumping fraction of the rows that sample the distributions (Saltelli's AB rows
    left out, NaN jumps in the count's denominator), of the down sweep when there is one."""
    a = np.ones((6, 2, 4))
    a[[0, 1, 2], 1, 2:] = 0.1            # 3 of the 4 sampling rows jump down
    a[4:, 1, 2:] = 0.1                   # the AB rows jump too: not counted
    a[3, 1, :] = np.nan                  # the fourth has no finite amplitude: no jump, still a row
    a[:, 0, 3] = 0.1                     # every row jumps up
    r = make(a, roles=["A", "B", "A", "B", "AB:B", "AB:B"], directions=("up", "down"))
    assert unc.jump_share(r) == (0.75, "down")
    up = make(a[:, :1], roles=r.roles, directions=("up",))
    assert unc.jump_share(up) == (1.0, "up")
    none = make(a[:, :1], roles=["AB:B"] * 6, directions=("up",))
    f, d = unc.jump_share(none)
    assert np.isnan(f) and d == "up"
    assert unc.jump_share(make(np.ones((4, 1, 3)))) == (0.0, "up")


def _block(n=2, shape=(2, 3)):
    data = {"sample": np.arange(n, dtype=np.int64), "amplitude": np.full((n,) + shape, 0.5),
            "period": np.ones((n,) + shape, np.int64), "status": np.full((n,) + shape, "ok", dtype=object)}
    return data, {k: (v.shape, v.dtype) for k, v in data.items()}


def test_check_block_refuses_each_value_a_sweep_never_writes_and_names_it():
    """check_block's rules one at a time, each against a block that breaks only it: the types and
    widths of the datasets, the range of sample and period, a status text cut at 40 characters,
    and the amplitude at live points (finite, NaN only with period -1 of a method that is not
    time-domain, within MOTION_MAX) -- while a failed point holds anything."""
    data, meta = _block()
    assert check_block(meta, data, 2, (2, 3)) is None
    # widths: the amplitude float64 only; period and status of any width
    assert check_block(dict(meta, amplitude=(meta["amplitude"][0], np.float32)), None, 2, (2, 3)) == \
        "dataset amplitude holds float32 values, not what vibeam writes"
    assert check_block(dict(meta, amplitude=(meta["amplitude"][0], np.longdouble)), None, 2, (2, 3)) == \
        f"dataset amplitude holds {np.dtype(np.longdouble)} values, not what vibeam writes"
    assert check_block(dict(meta, period=(meta["period"][0], np.int32), status=(meta["status"][0], np.dtype("S4"))),
                       None, 2, (2, 3)) is None
    # datasets vibeam does not write there: the first in order named
    assert check_block(dict(meta, foo=((2,), np.int64), bar=((2,), np.int64)), None, 2, (2, 3)) == \
        "dataset bar is not one vibeam writes there (sample, amplitude, period, status)"
    # a sample beyond the design (not only its next row)
    assert check_block(meta, dict(data, sample=np.array([0, 9])), 8, (2, 3)) == \
        "dataset sample holds a value outside 0 ... 7 or one twice"
    # the first status vibeam does not know, cut at 40 characters
    st = data["status"].copy()
    st[0, 1, 1], st[1, 0, 0] = "x" * 45 + "y", "other"
    assert check_block(meta, dict(data, status=st), 2, (2, 3)) == \
        f"dataset status holds {'x' * 40!r}; allowed: {', '.join(STATUSES)}"
    # period: -1 ... period_max
    for p, ok in ((-1, True), (0, True), (64, True), (-2, False), (65, False)):
        per = data["period"].copy()
        per[1, 1, 2] = p
        got = check_block(meta, dict(data, period=per), 2, (2, 3), period_max=64)
        assert got is None if ok else got == \
            f"dataset period holds {p}; allowed: -1 (no impact), 0 (not periodic) ... 64", (p, got)
    per = data["period"].copy()
    per[0, 0, 0], per[1, 0, 0] = -1, 70                             # -1 allowed: the high one named
    assert check_block(meta, dict(data, period=per), 2, (2, 3), period_max=64).startswith("dataset period holds 70;")
    per[0, 0, 0] = 0
    assert check_block(meta, dict(data, period=per), 2, (2, 3), period_max=64).startswith("dataset period holds 70;")
    per[0, 0, 0], per[1, 0, 0] = -3, 70                             # both: the low one named
    assert check_block(meta, dict(data, period=per), 2, (2, 3), period_max=64).startswith("dataset period holds -3;")
    from vibeam.engine.records import PERIOD_MAX
    per[0, 0, 0], per[1, 0, 0] = PERIOD_MAX, PERIOD_MAX + 1        # the default: PERIOD_MAX
    assert check_block(meta, dict(data, period=per), 2, (2, 3)).startswith(f"dataset period holds {PERIOD_MAX + 1};")
    # an empty block holds nothing wrong
    empty, emeta = _block(0)
    assert check_block(emeta, empty, 2, (2, 3)) is None
    # the amplitude at a live point; a failed point's is not checked
    from vibeam.engine.sweep import MOTION_MAX

    def amp(value, period=1, status="ok", **kw):
        a, per, s = data["amplitude"].copy(), data["period"].copy(), data["status"].copy()
        a[1, 1, 2], per[1, 1, 2], s[1, 1, 2] = value, period, status
        return check_block(meta, dict(data, amplitude=a, period=per, status=s), 2, (2, 3), **kw)

    assert amp(np.inf) == ("dataset amplitude is infinite (inf) at sample 1, direction 1, point 2 whose status is "
                           "'ok' and period 1; allowed there: a finite number")
    assert amp(-np.inf, status="chatter").startswith("dataset amplitude is infinite (-inf) at sample 1, direction 1, "
                                                     "point 2 whose status is 'chatter'")
    assert amp(np.nan).startswith("dataset amplitude is nan (nan) at sample 1")
    assert amp(np.nan, period=-1).startswith("dataset amplitude is nan")                  # time-domain by default
    assert amp(np.nan, period=-1, time_domain=False) is None          # the averaging's "no solution"
    assert amp(np.nan, period=1, time_domain=False).startswith("dataset amplitude is nan")
    assert amp(np.nan, period=2, time_domain=False).startswith("dataset amplitude is nan")
    assert amp(MOTION_MAX) is None and amp(-MOTION_MAX) is None
    assert amp(2 * MOTION_MAX).startswith(f"dataset amplitude is beyond {MOTION_MAX:g} in magnitude (its square "
                                          f"overflows) (2e+154) at sample 1")
    assert amp(-2 * MOTION_MAX).startswith("dataset amplitude is beyond")
    for v in (np.inf, np.nan, 2 * MOTION_MAX):
        assert amp(v, status="failed") is None and amp(v, status="failed", period=-1) is None
    # two bad points: the first in (sample, direction, Omega) order is named
    a = data["amplitude"].copy()
    a[0, 1, 1], a[1, 0, 2] = np.inf, np.inf
    assert " at sample 0, direction 1, point 1 " in check_block(meta, dict(data, amplitude=a), 2, (2, 3))
    # the sample named is the block's own, not the row's index
    a = data["amplitude"].copy()
    a[1, 0, 1] = np.inf
    assert " at sample 7, direction 0, point 1 " in check_block(
        meta, dict(data, amplitude=a, sample=np.array([3, 7])), 8, (2, 3))


def test_moments_of_two_samples_have_a_std_and_a_missing_seed_is_zero():
    """Two finite samples have a std (n - 1 = 1); without a design seed in attrs the bootstrap and
    the Sobol' intervals draw with seed 0 (their documented default)."""
    r = make(np.array([[[1.0, 3.0]], [[2.0, np.nan]]]))
    mean, std, n = r.moments()
    assert list(n[0]) == [2, 1] and std[0, 0] == pytest.approx(np.sqrt(0.5), rel=1e-15) and np.isnan(std[0, 1])
    r.attrs.clear()
    b = make(np.random.default_rng(3).uniform(size=(6, 1, 2)))
    b.attrs.clear()
    for k, v in b.bootstrap(resamples=30).items():
        np.testing.assert_array_equal(v, b.bootstrap(resamples=30, seed=0)[k])
    s, _ = _additive(n=16)
    s0 = s.sobol(resamples=20)
    s.attrs.clear()
    unseeded = s.sobol(resamples=20)
    s.attrs["seed"] = 0
    for k, v in s.sobol(resamples=20).items():
        np.testing.assert_array_equal(v, unseeded[k])
    assert not np.array_equal(s0["first_ci"][:, :, :, :3], unseeded["first_ci"][:, :, :, :3])   # the seed matters


def test_sobols_default_resamples_and_its_total_order_intervals():
    """sobol() draws 199 bootstrap resamples (its signature's default); the total-order intervals are
    the total indices' own (bracketing them, not the first-order intervals)."""
    s, _ = _additive(n=32)
    d, e = s.sobol(), s.sobol(resamples=199)
    for k in d:
        np.testing.assert_array_equal(d[k], e[k])
    assert not np.array_equal(s.sobol(resamples=200)["first_ci"][..., :3], d["first_ci"][..., :3])
    lo, hi = d["total_ci"][0, :, 0, 1:3], d["total_ci"][1, :, 0, 1:3]   # point 0: x2 has no effect, BCa NaN
    assert np.isfinite(lo).all() and np.isfinite(hi).all() and (lo <= hi).all()
    assert not np.array_equal(d["total_ci"][..., :3], d["first_ci"][..., :3])


def test_the_verdict_takes_the_median_and_the_5_and_95_percent_ends():
    """Medians against bands built so that any other quantile in their place moves a point across:
    a constant run c at each point at a value between the spread run s's 5 and 25 % quantiles (point
    0), between its 75 and 95 % (point 1), at its median (point 2); a median at the 95 % end is
    inside; a later pair is compared after one that is not."""
    s = _run("s", 0.0, directions=("up",))
    q = s.quantiles()[:, 0, 0]
    v = np.array([0.5 * (q[0] + q[1]), 0.5 * (q[3] + q[4]), q[2], q[4], q[0]])
    c = make(np.repeat(v[None, None, :], 20, axis=0), name="c", directions=("up",))
    cs, sc = verdict([c, s])["c vs s"], verdict([s, c])["s vs c"]
    assert cs["outside_band_a_in_b"] == 0.0 and sc["outside_band_b_in_a"] == 0.0     # c's values in s's band
    # s's median is inside c's (zero-width) band only at point 2
    assert cs["outside_band_b_in_a"] == pytest.approx(0.8) and sc["outside_band_a_in_b"] == pytest.approx(0.8)
    # a later pair is compared after a pair on other grids
    other = _run("o", 0.0, directions=("up",), Omega=np.linspace(1.0, 3.0, 5))
    assert set(verdict([s, other, c])) == {"s vs c"}


def _fake_case(methods=("event", "averaging", "continuation"), samples=3):
    """A case of runs with the given methods (names read as a case file's, not the literals) and a
    design of ``samples`` rows of one parameter R; make_job and plan_lines replaced (no kernel)."""
    runs = [SimpleNamespace(name=f"r{i}", method="".join(list(m)), model={"beta": 0.01}) for i, m in enumerate(methods)]
    spec = SimpleNamespace(sobol=False, design=lambda n=None: np.linspace(0.5, 0.9, samples)[:, None],
                           parameter=[SimpleNamespace(name="R")], runs_per_sample=lambda: 1, seed=11)
    return SimpleNamespace(name="fake", run=runs, uncertainty=spec, sweep=SimpleNamespace(direction="up")), spec


def _fakes(monkeypatch, seen):
    model = SimpleNamespace(natural_frequency_hz=None, length_m=None, fidelity="sdof")
    scene = sdof(beta=0.01, B=0.1, Delta=0.0, R=0.8)      # nondimensional: no units

    def make_job(case, r, m, index):
        seen.append((r.name, dict(m), index))
        return SimpleNamespace(solver=SimpleNamespace(model=model, scene=scene, name=r.method),
                               sweep=SimpleNamespace(Omega=[1.0, 2.0]))

    def plan_lines(solver, sw, name):
        return [SimpleNamespace(direction="up", n_points=2, run=name)]

    monkeypatch.setattr(unc, "make_job", make_job)
    monkeypatch.setattr(unc, "plan_lines", plan_lines)


def test_the_plan_samples_every_sweep_run_from_its_first_sample(monkeypatch):
    """plan_samples: every run but continuation's (an averaging run too), each laid out from the
    first sample's job (its values, index 0); a run all done has no task and loads no kernel."""
    seen = []
    _fakes(monkeypatch, seen)
    case, spec = _fake_case()
    plan = unc.plan_samples(case)                        # spec: the case's own
    assert [r.name for r in plan.runs] == ["r0", "r1"]
    assert seen == [("r0", {"beta": 0.01, "R": 0.5}, 0), ("r1", {"beta": 0.01, "R": 0.5}, 0)]
    assert [(t.run, t.index) for t in plan.tasks] == [("r0", 0), ("r0", 1), ("r0", 2), ("r1", 0), ("r1", 1), ("r1", 2)]
    assert plan.tasks[2].values == (("R", 0.9),) and plan.tasks[0].n_points == 2
    assert [l.run for l in plan.firsts] == ["r0", "r1"]
    part = unc.plan_samples(case, done={"r0": {0: None, 1: None, 2: None}, "r1": {1: None}})
    assert [(t.run, t.index) for t in part.tasks] == [("r1", 0), ("r1", 2)] and [l.run for l in part.firsts] == ["r1"]
    # a spec given is the one planned, not the case's
    other = SimpleNamespace(**dict(vars(spec), design=lambda n=None: np.array([[0.6], [0.7]])))
    assert [t.values for t in unc.plan_samples(case, other).tasks][:2] == [(("R", 0.6),), (("R", 0.7),)]
    with pytest.raises(dataclasses_frozen()):
        plan.tasks = []
    with pytest.raises(dataclasses_frozen()):
        plan.tasks[0].index = 5


def dataclasses_frozen():
    import dataclasses

    return dataclasses.FrozenInstanceError


def test_sample_runs_loads_kernels_only_for_an_inline_or_local_pool_with_work(monkeypatch):
    """The kernels are loaded before the pool forks when there is work and no executor was given;
    the progress bar is off unless asked; every sample's row comes back in its result."""
    seen, loaded, calls = [], [], []
    _fakes(monkeypatch, seen)
    monkeypatch.setattr(unc, "load_kernels", lambda lines: loaded.append([l.run for l in lines]))

    def run_lines(tasks, executor=None, jobs=None, on_line=None, progress=False, desc=""):
        calls.append((executor, progress))
        for t in tasks:
            on_line(t, [{"amplitude": np.full((1, 2), t.index + 1.0), "period": np.ones((1, 2), np.int64),
                         "status": np.full((1, 2), "ok", dtype=object)}])

    monkeypatch.setattr(unc.sweep, "run_lines", run_lines)
    case, _ = _fake_case(methods=("event",))
    got = []
    (res,) = unc.sample_runs(case, on_sample=lambda run, i, row: got.append((run, i, row["amplitude"][0, 0])))
    assert loaded == [["r0"]] and calls == [(None, False)]
    assert sorted(got) == [("r0", 0, 1.0), ("r0", 1, 2.0), ("r0", 2, 3.0)]
    np.testing.assert_array_equal(res.amplitude[:, 0, 0], [1.0, 2.0, 3.0])
    loaded.clear()
    unc.sample_runs(case, executor="pool", progress=True)
    assert loaded == [] and calls[-1] == ("pool", True)
    done = {"r0": {i: {"amplitude": np.zeros((1, 2)), "period": np.ones((1, 2), np.int64),
                       "status": np.full((1, 2), "ok", dtype=object)} for i in range(3)}}
    unc.sample_runs(case, done=done)
    assert loaded == []


def test_a_sample_task_reports_progress_per_point(monkeypatch):
    """A SampleTask is a unit whose progress advances per point: run_line hands it the report
    callable, which reaches the sweep's own run_line."""
    got = []
    monkeypatch.setattr(unc, "make_job", lambda *a: SimpleNamespace(solver=None, sweep=None))
    monkeypatch.setattr(unc, "plan_lines", lambda *a: ["line"])
    monkeypatch.setattr(unc, "run_line", lambda line, report: got.append(report) or [])
    monkeypatch.setattr(unc, "sample_arrays", lambda rows, sw: {})
    from vibeam.engine.sweep import run_line

    t = unc.SampleTask("000000", "r", None, SimpleNamespace(model={}), (), 0, 2)
    report = lambda: None                                   # noqa: E731
    assert run_line(t, report=report) == [{}] and got == [report]
