"""Inputs refused in one line, and parameter names that mean one key (issue 57, items 10-12).

* item 10: ``vibeam uncertainty --samples`` takes the range of ``[uncertainty] samples`` (a power of 2
  from 2 to 65536: 2^40 was a MemoryError traceback, 0 silently the case's count); one parameter
  named twice -- an alias and its path, ``R`` and ``stops[0].law.R`` -- is refused where it was
  sampled twice (only one of them changed the model) or fitted twice ("rank deficient").
* item 11: a continuation's frequencies are positive, finite and within Omega's limit (``[14,
  1e308]`` Hz printed a traceback as the run's message, ``[-5, 17]`` started at -5 Hz), a gap at
  most 1e100 (``Delta = 1e308`` failed every point, exit 3): refused when the case is loaded.
* item 12: the documented forms ``system.<key>`` and ``excitation.<key>`` name the flat key
  (``excitation.voltage`` gave "not a numeric key of [model]"): the case they give is the flat
  key's, bit for bit.

The oracle of item 12 is the flat form: the same validated case (its JSON, the identity of a
results file) and the same map, to the last bit.
"""
from __future__ import annotations

import copy
import json
from pathlib import Path

import h5py
import numpy as np
import pytest

import vibeam
from vibeam.case.paths import canonical, flat_key
from vibeam.cli import main
from vibeam.errors import CaseError

ROOT = Path(__file__).resolve().parents[1]
QUIET = ["--jobs", "1", "--quiet", "--no-plots"]

RIG = {"name": "rig", "model": {"fidelity": "sdof", "natural_frequency_hz": 7.6, "damping_ratio": 0.017, "R": 0.72,
                                "gap_mm": -0.05, "length_mm": 180.0, "gain": 5.16e-4, "voltage": 0.6},
       "sweep": {"frequency_hz": [14.0, 17.0, 3], "transient_periods": 20, "record_periods": 16},
       "run": [{"name": "exact", "method": "event"}]}
SCENE = {"name": "scene", "model": {"fidelity": "sdof", "beta": 0.05, "B": 0.01, "R": 0.8, "Delta": 1.0},
         "sweep": {"Omega": [0.6, 1.4, 3], "transient_periods": 50, "record_periods": 4},
         "run": [{"name": "exact", "method": "event"}]}


def _toml(d) -> str:
    from vibeam.api.cases import case_text

    return case_text(vibeam.load_case(d))


def _write(tmp_path, d, name="case.toml") -> Path:
    p = tmp_path / name
    p.write_text(_toml(d))
    return p


def _one_line(capsys) -> str:
    err = [l for l in capsys.readouterr().err.splitlines() if l.strip() and not l.startswith("[")]
    assert len(err) == 1 and err[0].startswith("vibeam: error: ") and "Traceback" not in err[0], err
    return err[0]


# ----------------------------------------------------------------------------- item 10
def _band(**unc):
    d = copy.deepcopy(SCENE)
    d["uncertainty"] = {"samples": 4, "parameter": [{"name": "B", "distribution": "uniform",
                                                     "bounds": [0.005, 0.015]}], **unc}
    return d


@pytest.mark.parametrize("n", [2 ** 40, 0, -2, 3, 2 ** 17])
def test_samples_option_has_the_range_of_the_case_key(tmp_path, capsys, n):
    """2^40 was a MemoryError traceback and 0 ran the case's 4 samples (exit 0); -2 was refused,
    in other words.  Now each is one line naming the option and the key's range, nothing
    written."""
    case = _write(tmp_path, _band())
    out = tmp_path / "out"
    assert main(["uncertainty", str(case), "--samples", str(n), "--out", str(out), *QUIET]) == 2
    line = _one_line(capsys)
    assert f"'--samples' = {n}" in line and "a power of 2 from 2 to 65536" in line, line
    assert not out.exists()


def test_samples_argument_of_the_api_is_refused_alike():
    for bad in (0, 2 ** 40):
        with pytest.raises(CaseError, match=r"^'--samples' = .*from 2 to 65536"):
            vibeam.uncertainty(_band(), samples=bad, quiet=True)
    with pytest.raises(TypeError):
        vibeam.uncertainty(_band(), samples=4.0, quiet=True)


@pytest.mark.parametrize("names", [("R", "stops[0].law.R"), ("stops[0].law.R", "R"), ("beta", "system.beta"),
                                   ("excitation.B", "B")])
def test_one_parameter_sampled_under_two_names_is_refused(tmp_path, capsys, names):
    """R and stops[0].law.R sampled together were accepted, and only one of them changed the
    model; now one line naming both (the alias resolved to its path)."""
    d = _band()
    d["uncertainty"]["parameter"] = [{"name": n, "distribution": "uniform",
                                      "bounds": [0.6, 0.7] if "R" in n else [0.01, 0.02]} for n in names]
    case = tmp_path / "u.toml"
    case.write_text(_toml(_band()).replace('name = "B"', f'name = "{names[0]}"', 1)
                    .replace('bounds = [0.005, 0.015]', f'bounds = {d["uncertainty"]["parameter"][0]["bounds"]}', 1)
                    + f'\n[[uncertainty.parameter]]\nname = "{names[1]}"\ndistribution = "uniform"\n'
                      f'bounds = {d["uncertainty"]["parameter"][1]["bounds"]}\n')
    assert main(["uncertainty", str(case), "--out", str(tmp_path / "out"), *QUIET]) == 2
    line = _one_line(capsys)
    # (a path of the system or excitation is its flat key from the start: the list holds that key twice)
    assert "uncertainty.parameter" in line and "each parameter once" in line and flat_key(names[1]) in line, line
    assert not (tmp_path / "out").exists()


def test_one_parameter_fitted_under_two_names_is_refused(tmp_path, capsys):
    """``fit --params R,stops[0].law.R`` ran the whole fit and reported it rank deficient; now
    one line before any sweep."""
    csv = tmp_path / "d.csv"
    csv.write_text("frequency_hz,amplitude_mm\n15.0,0.5\n16.0,0.4\n")
    case = ROOT / "cases" / "rig-neutral.toml"
    for params, words in (("R,stops[0].law.R", "names the same parameter as 'R' (stops[0].law.R)"),
                          ("gain,excitation.gain", "names the same parameter as 'gain' (excitation.gain)"),
                          ("R,R", "repeated")):
        assert main(["fit", str(case), "--reference", str(csv), "--params", params, "--quiet",
                     "--out", str(tmp_path / "out")]) == 2
        line = _one_line(capsys)
        assert words in line and "each parameter once" in line and str(case) in line, line
    assert not (tmp_path / "out").exists()


def test_a_run_overriding_the_mapped_parameter_by_its_other_name_is_refused():
    d = copy.deepcopy(RIG)
    d["map"] = {"parameter": "stops[0].law.R", "values": [0.6, 0.8, 2]}
    d["run"][0]["model"] = {"R": 0.5}
    with pytest.raises(CaseError, match=r"'run\[0\]\.model\.R' overrides the mapped parameter \(stops\[0\]\.law\.R\)"):
        vibeam.load_case(d)


def test_every_name_of_a_parameter_has_one_canonical_path():
    rig = RIG["model"]
    assert {canonical(rig, n) for n in ("R", "stops[0].law.R", "stops[00].law.R")} == {"stops[0].law.R"}
    assert {canonical(rig, n) for n in ("gap_mm", "stops[0].gap_mm")} == {"stops[0].gap_mm"}
    assert {canonical(rig, n) for n in ("voltage", "excitation.voltage")} == {"excitation.voltage"}
    assert {canonical(rig, n) for n in ("damping_ratio", "system.damping_ratio")} == {"system.damping_ratio"}
    assert len({canonical(rig, n) for n in ("R", "gap_mm", "voltage", "gain", "damping_ratio")}) == 5


# ----------------------------------------------------------------------------- item 11
def _continuation(**run):
    d = copy.deepcopy(RIG)
    d["run"].append({"name": "branches", "method": "continuation", **run})
    return d


@pytest.mark.parametrize("run, words", [
    ({"range": [14.0, 1e308]}, "'run[1].range' = [14.0, 1e+308]: 1e+308 Hz is above Omega's limit; allowed: at most"),
    ({"range": [-5.0, 17.0]}, "'run[1].range' = [-5.0, 17.0]: -5 Hz is not a forcing frequency; allowed: positive"),
    ({"range": [0.0, 17.0]}, "0 Hz is not a forcing frequency"),
    ({"parameter": "voltage", "range": [0.5, 0.7], "at": 1e300}, "'run[1].at' = 1e+300: 1e+300 Hz is above Omega's"),
])
def test_a_continuation_beyond_the_frequencies_is_refused_at_load(run, words):
    """[14, 1e308] Hz exited 0 with a traceback as the run's message; [-5, 17] Hz exited 0 with a
    failed start at -5 Hz.  Now one line when the case is loaded."""
    with pytest.raises(CaseError) as e:
        vibeam.load_case(_continuation(**run))
    assert words in str(e.value) and "\n" not in str(e.value), str(e.value)


@pytest.mark.parametrize("model, key", [({"Delta": 1e308}, "'model.Delta' = 1e+308"),
                                        ({"Delta": -1e101}, "'model.Delta' = -1e+101"),
                                        ({"Delta_lower": 1e200}, "'model.Delta_lower' = 1e+200")])
def test_a_gap_beyond_the_computable_range_is_refused_at_load(model, key):
    """Delta = 1e308 failed every point at run time (infinite spreads, exit 3); 1e200 gave
    amplitudes no double can square.  The bound is B's (the model is homogeneous in B and Delta)."""
    d = copy.deepcopy(SCENE)
    d["model"].update(model)
    with pytest.raises(CaseError) as e:
        vibeam.load_case(d)
    assert key in str(e.value) and "allowed: |gap| <= 1e+100" in str(e.value), str(e.value)
    d["model"].update({k: 1e100 for k in model})
    vibeam.load_case(d)                   # the bound itself is a scene


def test_a_continuation_in_the_gap_beyond_it_is_refused_at_load():
    d = copy.deepcopy(SCENE)
    d["run"].append({"name": "branches", "method": "continuation", "parameter": "Delta", "range": [0.5, 1e308],
                     "at": 1.2})
    with pytest.raises(CaseError, match=r"'run\[1\]\.range' = \[0\.5, 1e\+308\]: Delta = 1e\+308 is not allowed"):
        vibeam.load_case(d)


def test_a_beams_continuation_beyond_omegas_limit_is_refused_before_computing():
    """A beam's natural frequency is known once its modes are: the limit is checked when the
    continuation is planned, before anything runs."""
    from vibeam.analysis.branches import plan

    case, _ = vibeam.api.cases.case_and_source(str(ROOT / "cases" / "rig-fe-tight-continuation.toml"))
    r = next(r for r in case.run if r.method == "continuation")
    bad = case.model_copy(update={"run": [r.model_copy(update={"range": [14.0, 1e200]}) if x is r else x
                                          for x in case.run]})
    with pytest.raises(CaseError, match=r"1e\+200 Hz is above Omega's limit"):
        plan(bad, bad.run[case.run.index(r)])


# ----------------------------------------------------------------------------- item 12
FORMS = [(RIG, "excitation.voltage", "voltage", [0.5, 0.7, 2]),
         (RIG, "excitation.gain", "gain", [5e-4, 6e-4, 2]),
         (RIG, "system.natural_frequency_hz", "natural_frequency_hz", [7.4, 7.8, 2]),
         (RIG, "system.damping_ratio", "damping_ratio", [0.01, 0.02, 2]),
         (SCENE, "system.beta", "beta", [0.04, 0.06, 2]),
         (SCENE, "excitation.B", "B", [0.01, 0.02, 2])]


@pytest.mark.parametrize("base, path, flat, values", FORMS, ids=[f[1] for f in FORMS])
def test_the_documented_path_forms_are_the_flat_keys(base, path, flat, values):
    """Each form gave "not a numeric key of [model]"; now the case it gives is the flat key's: the
    same validated case, to its JSON (the identity of its results)."""
    d = copy.deepcopy(base)
    d["map"] = {"parameter": path, "values": values}
    f = copy.deepcopy(base)
    f["map"] = {"parameter": flat, "values": values}
    a, b = vibeam.load_case(d), vibeam.load_case(f)
    assert a.map.parameter == flat
    assert a.model_dump_json() == b.model_dump_json()
    # the same in [[uncertainty.parameter]] and fit --params
    u = copy.deepcopy(base)
    u["uncertainty"] = {"samples": 4, "parameter": [{"name": path, "distribution": "uniform", "bounds": values[:2]}]}
    assert vibeam.load_case(u).uncertainty.parameter[0].name == flat
    from vibeam.identify.fit import check_params

    assert check_params(vibeam.load_case(base), [path]) == [flat]


def test_a_map_by_the_excitation_path_equals_the_flat_keys_map(tmp_path):
    """The map of ``excitation.voltage`` and of ``voltage``: the same file contents, bit for bit
    (but wall times)."""
    out = {}
    for name in ("excitation.voltage", "voltage"):
        d = copy.deepcopy(RIG)
        d["map"] = {"parameter": name, "values": [0.5, 0.7, 2]}
        case = _write(tmp_path, d, f"{name}.toml")
        assert main(["map", str(case), "--out", str(tmp_path / name), *QUIET]) == 0
        with h5py.File(tmp_path / name / "results.h5") as h:
            g = h["maps/exact"]
            out[name] = {k: g[k][()].tobytes() for k in g if isinstance(g[k], h5py.Dataset)
                         and g[k].dtype != object and "wall_time" not in k}
            assert g.attrs["parameter"] == "voltage"
    assert out["excitation.voltage"] == out["voltage"]


@pytest.mark.parametrize("path, words", [("excitation.beta", "beta is a key of the system (system.beta)"),
                                         ("system.voltage", "voltage is a key of the excitation (excitation.voltage)"),
                                         ("system.R", "R is a stop's key")])
def test_a_path_of_the_other_group_is_one_line(path, words):
    d = copy.deepcopy(RIG)
    d["map"] = {"parameter": path, "values": [0.5, 0.7, 2]}
    with pytest.raises(CaseError) as e:
        vibeam.load_case(d)
    assert f"'map.parameter' = {path!r}: {words}" in str(e.value), str(e.value)
    with pytest.raises(ValueError, match=words.split(" (")[0]):
        flat_key(path)
