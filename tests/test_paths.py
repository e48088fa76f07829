"""Parameters named by path into the scene (issue 43, first step): ``[map] parameter`` and
``vibeam fit --params`` reach numbers no flat key names -- the second stop's law stiffness, a
point stop's position on the beam -- through one resolver (:mod:`vibeam.case.paths`).

The oracle of each run is the same scene with the value written in the case file: a path sets
exactly the key it stands for, so the two must agree to the last bit (the tolerance 1e-10 of the
issue is met with 0); the fit's oracle is the truth its synthetic data were made at."""
from __future__ import annotations

import copy
import tomllib
from pathlib import Path

import numpy as np
import pytest

import vibeam
from vibeam.case.paths import get_value, parameter_paths, set_value
from vibeam.errors import CaseError

ROOT = Path(__file__).resolve().parents[1]
#: two Kelvin-Voigt stops of the SDOF (tests/test_matrix.py's row "sdof linear two")
SDOF = {"fidelity": "sdof", "beta": 0.015, "B": 5e-3, "R": 0.8, "Delta": 0.002, "Delta_lower": 0.003,
        "contact": {"law": "linear", "stiffness": 1e4}, "contact_lower": {"law": "linear", "stiffness": 3e3}}
BEAM = tomllib.loads((ROOT / "cases" / "rig-fe-neutral.toml").read_text())["model"]


def beam_with_point_stop(position_mm: float) -> dict:
    """The [model] table of the 2-mode rig beam with the paper's stop at the mass and a Newton stop
    (R 0.9, 0.6 mm gap) below the beam at ``position_mm`` (tests/test_matrix.py's 'point' row)."""
    model = dict(BEAM, n_modes=2)
    up = {"side": "upper", "R": model.pop("R"), "gap_mm": model.pop("gap_mm")}
    return dict(model, stop=[up, {"side": "lower", "position_mm": position_mm, "contact_gap_mm": 0.6, "R": 0.9}])


def _sdof_case(model, **extra):
    return {"name": "paths", "model": model,
            "sweep": {"Omega": [0.75, 0.95, 3], "transient_periods": 60, "record_periods": 8},
            "run": [{"name": "event", "method": "event"}], **extra}


# ----------------------------------------------------------------------------- the resolver
def test_a_path_sets_the_one_key_it_stands_for():
    """Shorthand tables: stops[0] is the paper's stop, stops[1] the lower one at the mass; the
    lower stop's law key lands in [model.contact_lower] (made from the upper table when the lower
    stop takes the upper stop's law), its Newton R in contact_lower.R; [[model.stop]] tables:
    the stop's own key.  The table given is not changed."""
    m = copy.deepcopy(SDOF)
    assert set_value(m, "stops[1].law.stiffness", 5e3)["contact_lower"] == {"law": "linear", "stiffness": 5e3}
    assert set_value(m, "stops[0].law.R", 0.7)["R"] == 0.7
    assert set_value(m, "stops[1].Delta", 0.004)["Delta_lower"] == 0.004
    assert set_value(m, "system.beta", 0.02)["beta"] == 0.02
    assert set_value(m, "excitation.B", 1e-3)["B"] == 1e-3
    assert m == SDOF
    implicit = {k: v for k, v in SDOF.items() if k != "contact_lower"}       # the lower stop takes the upper law
    assert get_value(implicit, "stops[1].law.stiffness") == 1e4
    assert set_value(implicit, "stops[1].law.stiffness", 2e3)["contact_lower"] == {"law": "linear", "stiffness": 2e3}
    newton = {"fidelity": "sdof", "beta": 0.015, "B": 5e-3, "R": 0.8, "Delta": 0.002, "Delta_lower": 0.003}
    assert get_value(newton, "stops[1].law.R") == 0.8
    assert set_value(newton, "stops[1].law.R", 0.5)["contact_lower"] == {"law": "restitution", "R": 0.5}
    listed = {"fidelity": "sdof", "beta": 0.015, "B": 5e-3,
              "stop": [{"side": "upper", "Delta": 0.002, "R": 0.8},
                       {"side": "lower", "Delta": 0.003, "R": 0.8, "law": "linear", "stiffness": 3e3}]}
    out = set_value(listed, "stops[1].law.stiffness", 7e3)
    assert out["stop"][1]["stiffness"] == 7e3 and listed["stop"][1]["stiffness"] == 3e3
    assert parameter_paths(listed) == ["stops[0].Delta", "stops[0].law.R", "stops[1].Delta", "stops[1].law.R",
                                       "stops[1].law.stiffness"]
    assert parameter_paths(SDOF) == ["stops[0].Delta", "stops[0].law.R", "stops[0].law.stiffness",
                                     "stops[1].Delta", "stops[1].law.R", "stops[1].law.stiffness"]
    # a compliant lower stop's own target R (issue 43: it had to be the upper stop's)
    assert set_value(m, "stops[1].law.R", 0.6)["contact_lower"] == {"law": "linear", "stiffness": 3e3, "R": 0.6}
    assert get_value(m, "stops[1].law.R") == 0.8 and get_value(set_value(m, "stops[1].law.R", 0.6),
                                                               "stops[1].law.R") == 0.6


def test_a_path_stands_for_the_flat_key_of_its_stop():
    """alias_of: by the stop's role at the attached mass, in shorthand and [[model.stop]] tables
    (a listed table's first upper stop at the mass is the paper's, whatever its index); a point
    stop and a law's stiffness have no flat key."""
    from vibeam.case.paths import alias_of

    listed = {"fidelity": "beam", "stop": [{"side": "lower", "position_mm": 180.0, "contact_gap_mm": 0.6, "R": 0.9},
                                           {"side": "lower", "gap_mm": 0.3, "R": 0.7},
                                           {"side": "upper", "gap_mm": 0.1, "R": 0.8}]}
    assert alias_of(listed, "stops[2].law.R") == "R" and alias_of(listed, "stops[2].gap_mm") == "gap_mm"
    assert alias_of(listed, "stops[1].law.R") == "R_lower" and alias_of(listed, "stops[1].gap_mm") == "gap_lower_mm"
    assert alias_of(listed, "stops[0].law.R") == "stops[0].law.R"           # a point stop: the path itself
    assert alias_of(SDOF, "stops[0].law.R") == "R" and alias_of(SDOF, "stops[1].Delta") == "Delta_lower"
    assert alias_of(SDOF, "stops[1].law.stiffness") == "stops[1].law.stiffness"
    assert alias_of(SDOF, "excitation.B") == "B" and alias_of(SDOF, "voltage") == "voltage"


@pytest.mark.parametrize("path,needle", [
    ("stops[2].law.R", "the scene has 2 stop(s)"),
    ("stops[0].gap_mm", "gives its gap as Delta"),
    ("stops[0].law.exponent", "takes R, stiffness"),
    ("stops[0].R", "a law's key: stops[0].law.R"),
    ("system.R", "a stop's key"),
    ("system.voltage", "excitation.voltage"),
    ("stops[0].position_mm", "[[model.stop]] tables"),
    ("stop[1].law.R", "not a parameter path"),
])
def test_a_path_the_scene_does_not_have_is_one_line(path, needle):
    with pytest.raises(ValueError, match=None) as e:
        set_value(SDOF, path, 1.0)
    msg = str(e.value)
    assert "\n" not in msg and repr(path) in msg and needle in msg, msg


def test_a_map_of_an_unknown_path_is_refused_naming_it():
    d = _sdof_case(copy.deepcopy(SDOF), map={"parameter": "stops[1].law.exponent", "values": [1.0, 2.0, 2]})
    with pytest.raises(CaseError, match=r"'map.parameter' = 'stops\[1\].law.exponent'.*stops\[1\].law.stiffness"):
        vibeam.load_case(d)


# ----------------------------------------------------------------------------- map and fit by path
def _map_and_written(tmp_path, d_map, model_of, values):
    """The map of ``d_map`` and, per value, the same scene with the value written in its model."""
    res = vibeam.run(d_map, jobs=1, out=tmp_path / "map")
    m = res.maps[0]
    for j, v in enumerate(values):
        d = copy.deepcopy(d_map)
        d.pop("map")
        d["model"] = model_of(v)
        one = vibeam.run(d, jobs=1, out=tmp_path / f"v{j}").runs[0]
        for key in ("amplitude", "period", "impacts_per_period"):
            a = np.asarray(m.data[key])[:, j]                      # (direction, value, Omega) -> value j
            b = np.asarray(one.data[key]).reshape(a.shape)
            np.testing.assert_array_equal(a, b, err_msg=f"{key} at value {v}")
    return res


def test_the_second_stops_stiffness_is_mapped_by_path(tmp_path):
    """The SDOF's lower Kelvin-Voigt stop stiffness (no flat key names it) mapped over
    2e3 ... 6e3: each line equals the scene with ``[model.contact_lower] stiffness`` written;
    the map's coordinate is the path, unit '1' (a nondimensional stiffness ratio)."""
    values = [2e3, 6e3]
    d = _sdof_case(copy.deepcopy(SDOF), map={"parameter": "stops[1].law.stiffness", "values": [2e3, 6e3, 2]})
    res = _map_and_written(tmp_path, d, lambda v: dict(SDOF, contact_lower={"law": "linear", "stiffness": v}),
                           values)
    ds = res.maps[0].to_xarray()
    assert "stops[1].law.stiffness" in ds.coords and ds["stops[1].law.stiffness"].attrs["units"] == "1"
    np.testing.assert_array_equal(ds["stops[1].law.stiffness"].values, values)


def test_a_point_stops_position_on_the_beam_is_mapped_by_path(tmp_path):
    """The 2-mode rig beam with the paper's stop at the mass and a Newton stop below the tip
    (tests/test_matrix.py's 'point' row): the second stop's position_mm mapped over 160 and 175 mm
    equals the scene with position_mm written; coordinate unit mm."""
    model_of = beam_with_point_stop

    d = {"name": "paths-beam", "model": model_of(180.0),
         "sweep": {"frequency_hz": [15.0, 15.5, 2], "transient_periods": 40, "record_periods": 4},
         "map": {"parameter": "stops[1].position_mm", "values": [160.0, 175.0, 2]},
         "run": [{"name": "event", "method": "event"}]}
    res = _map_and_written(tmp_path, d, model_of, [160.0, 175.0])
    assert res.maps[0].to_xarray()["stops[1].position_mm"].attrs["units"] == "mm"


def test_the_second_stops_stiffness_is_fitted_by_path():
    """vibeam fit of ``stops[1].law.stiffness`` alone: exact synthetic data made at 4e3 (the
    case-file value written), started at 3e3, recover 4e3 within the first-order propagation of
    the sweep's measured accuracy (x 2) plus 10 x xtol |x| for the optimizer's stop, as
    tests/test_fit.py's exact-data test bounds it, and within 1e-8 relative (1.2e-10 measured).
    The same data made through the path instead of the written value are bit for bit the same."""
    from vibeam.identify.fit import fit_case, synthetic_reference

    truth = vibeam.load_case(_sdof_case(dict(SDOF, contact_lower={"law": "linear", "stiffness": 4e3})))
    Om = np.linspace(0.75, 0.85, 6)          # every point period-1 (measured; above 0.875 not periodic)
    ref = synthetic_reference(truth, Om)
    case = vibeam.load_case(_sdof_case(copy.deepcopy(SDOF)))
    res = fit_case(case, ref, ["stops[1].law.stiffness"], x0={"stops[1].law.stiffness": 3e3}, loss="linear",
                   jobs=1)
    assert res.parameters == ["stops[1].law.stiffness"] and res.units == ["1"]
    P = np.linalg.pinv(res.jacobian[res.used])
    bound = np.abs(P) @ (np.nan_to_num(res.accuracy[res.used], nan=0.0) / res.sigma[res.used])
    assert abs(res.estimate[0] - 4e3) <= 2 * bound[0] + 10 * 1e-8 * 4e3, (res.estimate, bound)
    assert res.estimate[0] == pytest.approx(4e3, rel=1e-8), res.estimate
    np.testing.assert_array_equal(synthetic_reference(case, Om, {"stops[1].law.stiffness": 4e3}).y, ref.y)


def test_a_point_stops_position_on_the_beam_is_fitted_by_path():
    """vibeam fit of ``stops[1].position_mm`` alone on the 2-mode beam (``beam_with_point_stop``):
    exact synthetic data made at 125 mm (the position written in the [[model.stop]] table), started
    at 124 mm, recover 125 mm within the first-order propagation of the sweep's measured accuracy
    (x 2) plus 10 x xtol |x| for the optimizer's stop, and within 1e-10 relative (1.8e-13
    measured; 2e-15 ... 1.8e-13 from starts 122 ... 127 mm).  The same data made through the path
    instead of the written value are bit for bit the same.

    The scene is where the fit's observable, the amplitude Q = Delta - min q, is smooth in the
    position and sees it (maps at 0.1 mm with these sweep settings): swept up from 17.5 Hz, every
    point of 17.5 ... 20 Hz is a period-1 orbit with one impact on each stop for positions
    122 ... 126.5 mm, and Q is smooth over 123.5 ... 126.5 mm (slope -0.0048 ... -0.0058 mm/mm,
    0.6 sigma a mm; below a kink at 123.1-123.4 mm the slope is -0.015; at 17.5 Hz the period
    doubles from 126.6 mm).  Not the 170 mm of the continuation test: there the point stop takes
    3-10 impacts a period, their number changes every 1-2 mm, and at 14.5-15.5 Hz the orbits are
    period 2, 4, 8 or not periodic, the period-2 bands 1-2 mm wide, so the FRC is not smooth in
    the position (a fit at 17-18 Hz stopped at 169.21 mm).  A sweep started at 18 Hz or above
    stays on a coexisting orbit that never reaches the point stop, whose Q does not depend on the
    position at all: the test asserts that the fitted orbits hit it and that every point sees
    the position."""
    from vibeam.identify.fit import fit_case, synthetic_reference

    f_hz = [17.5, 18.0, 18.5, 19.0, 19.5, 20.0]

    def case_at(position_mm):
        return vibeam.load_case({"name": "paths-fit-beam", "model": beam_with_point_stop(position_mm),
                                 "sweep": {"frequency_hz": [17.5, 20.0, 6], "transient_periods": 400,
                                           "record_periods": 16},
                                 "run": [{"name": "event", "method": "event"}]})

    truth = 125.0
    ref = synthetic_reference(case_at(truth), f_hz)
    case = case_at(124.0)
    res = fit_case(case, ref, ["stops[1].position_mm"], x0={"stops[1].position_mm": 124.0}, loss="linear",
                   jobs=1)
    assert res.parameters == ["stops[1].position_mm"] and res.units == ["mm"]
    # every fitted point a period-1 orbit with one impact on the paper's stop and one on the point stop
    assert list(res.model_period) == [1] * len(f_hz), res.model_period
    hits = np.asarray(res.final.data["stop_impacts_per_period"])   # stops: 0 upper, 1 lower at the mass, 2 point
    np.testing.assert_array_equal(hits[:, [0, 2]], 1.0)
    # the data see the position: 1 mm moves every point by more than 0.3 sigma (0.61 ... 0.67 measured);
    # all derivatives central (no period change or jump within a step)
    assert np.all(np.abs(res.jacobian[:, 0]) > 0.3), res.jacobian
    assert res.jacobian_info["one_sided"] == 0 and res.jacobian_info["zeroed"] == 0, res.jacobian_info
    P = np.linalg.pinv(res.jacobian[res.used])
    bound = np.abs(P) @ (np.nan_to_num(res.accuracy[res.used], nan=0.0) / res.sigma[res.used])
    assert abs(res.estimate[0] - truth) <= 2 * bound[0] + 10 * 1e-8 * truth, (res.estimate, bound)
    assert res.estimate[0] == pytest.approx(truth, rel=1e-10), res.estimate
    np.testing.assert_array_equal(synthetic_reference(case, f_hz, {"stops[1].position_mm": truth}).y, ref.y)


# ----------------------------------------------------------------------------- continuation by path
def _continued(tmp_path, parameter, tag):
    """Continuation of the two-sided Fig. 7 scene (Newton stops, R = R_lower = 0.9) in
    ``parameter`` at Omega = 2.0 over [0.6, 0.9], from the sweep's settled orbit."""
    d = tomllib.loads((ROOT / "cases" / "paper-fig7-two-sided.toml").read_text())
    d.pop("quick", None)
    d.pop("map", None)
    d.pop("basins", None)
    d["name"] = "paths-cont"
    d["sweep"] = {"Omega": [1.9, 2.1, 3], "transient_periods": 400, "record_periods": 16}
    d["run"] = [{"name": "c", "method": "continuation", "parameter": parameter, "at": 2.0, "range": [0.6, 0.9],
                 }]
    res = vibeam.continuation(d, jobs=1, out=tmp_path / tag)
    return res.branches[0]


def test_continuation_in_the_lower_stops_R_by_path_is_the_flat_keys(tmp_path):
    """``stops[1].law.R`` stands for ``R_lower`` (the lower stop at the mass): the continued
    branches are the same to the last bit; the results name the path, unit '1'."""
    a = _continued(tmp_path, "R_lower", "flat")
    b = _continued(tmp_path, "stops[1].law.R", "path")
    assert b.parameter == "stops[1].law.R" and a.parameter == "R_lower"
    assert len(a.branches) == len(b.branches) >= 1
    for x, y in zip(a.branches, b.branches):
        assert set(x["data"]) == set(y["data"])
        for k in x["data"]:
            np.testing.assert_array_equal(np.asarray(x["data"][k]), np.asarray(y["data"][k]), err_msg=k)
    assert b.attrs["parameter"] == "stops[1].law.R"
    assert sum(len(x["data"]["parameter"]) for x in b.branches) > 10      # not two empty branches
    import h5py

    with h5py.File(tmp_path / "path" / "results.h5") as f:
        g = f["branches/c"]
        assert g.attrs["parameter"] == "stops[1].law.R" and g["parameter"].attrs["units"] == "1"


def test_continuation_in_a_path_the_scene_does_not_set_is_one_line():
    """A law key the case leaves to its default (the Kelvin-Voigt damping ratio, set by R) has no
    value to start from: refused in one line naming the path; a stop the scene does not have too."""
    d = _sdof_case(copy.deepcopy(SDOF))
    for path, needle in (("stops[1].law.damping_ratio", "is not set in this scene"),
                         ("stops[2].law.stiffness", "the scene has 2 stop(s)")):
        d["run"] = [{"name": "c", "method": "continuation", "parameter": path, "at": 0.8, "range": [0.01, 0.1]}]
        with pytest.raises(CaseError) as e:
            vibeam.load_case(d)
        msg = str(e.value)
        assert f"'run[0].parameter' = '{path}'" in msg and needle in msg and "\n" not in msg, msg


def test_continuation_in_the_second_stops_stiffness_gives_orbits_of_the_scene_with_it_written():
    """Issue 43, 'continue a parameter only a path can name': the SDOF's lower Kelvin-Voigt
    stiffness continued at Omega = 0.8 over [2e3, 6e3] (d x / d k by central differences of the
    scene's shots).  Oracle: at points along the branch, the scene built with that stiffness
    *written* in [model.contact_lower] and its event integrator -- one forcing period from the
    branch's state returns to it to 1e-8 of the state (tests/test_matrix.py's bound: the shot
    converges to 1e-10, one period grows an error by at most max|mu|).  The results name the
    path."""
    from vibeam.models import make_solver

    d = _sdof_case(copy.deepcopy(SDOF))
    d["run"] = [{"name": "k", "method": "continuation", "parameter": "stops[1].law.stiffness", "at": 0.8,
                 "range": [2e3, 6e3], "start": "sweep", "start_at": 3e3}]
    res = vibeam.continuation(d, jobs=1)
    r = res.branches[0]
    assert r.parameter == "stops[1].law.stiffness" and r.status == "ok", (r.status, r.message)
    b, n = r.branches[0]["data"], int(r.branches[0]["n"])             # the sweep start's period-n orbit
    k = np.asarray(b["parameter"])
    assert k.min() <= 2.0e3 + 1e-6 and k.max() >= 6.0e3 - 1e-6, (k.min(), k.max())   # the whole range
    assert len(k) >= 5 and n >= 1
    for i in np.linspace(0, len(k) - 1, 4).astype(int):
        sc = vibeam.load_case(_sdof_case(dict(SDOF, contact_lower={"law": "linear", "stiffness": float(k[i])}))
                              ).model_spec().scene()
        x = np.asarray(b["state"][i])
        one = make_solver(sc, "event").point(0.8, np.concatenate([x, [0.0]]), 0, n, 32)
        assert np.max(np.abs(one.final_state[:-1] - x)) <= 1e-8 * np.max(np.abs(x)), (k[i], one.final_state, x)


@pytest.mark.parametrize("parameter, rng, needle", [
    ("stops[1].position_mm", [150.0, 190.0], "lies beyond length_mm"),
    ("stops[0].law.R", [0.5, 1.2], "R"),
])
def test_a_continuation_range_the_scene_cannot_take_is_one_line(parameter, rng, needle):
    """Each end of a continuation's range must be a scene the model accepts: a point stop moved
    beyond the beam's end (180 mm) or R above 1 is refused when the case is loaded, in one line
    naming 'run[0].range', the parameter and the value (it was a branch that failed with the
    model's multi-line validation error as its message)."""
    d = {"name": "paths-range", "model": beam_with_point_stop(170.0),
         "sweep": {"frequency_hz": [15.0, 15.5, 2], "transient_periods": 40, "record_periods": 4},
         "run": [{"name": "c", "method": "continuation", "parameter": parameter, "at": 15.0, "range": rng,
                  "start": "sweep", "start_at": rng[0]}]}
    with pytest.raises(CaseError) as e:
        vibeam.load_case(d)
    msg = str(e.value)
    assert f"'run[0].range' = {rng}: {parameter} = {rng[1]:g} is not allowed" in msg, msg
    assert needle in msg and "\n" not in msg, msg
    rng_ok = [rng[0], 175.0 if "position" in parameter else 0.95]
    d["run"][0]["range"] = rng_ok
    vibeam.load_case(d)                  # the same run with a range the scene takes loads


@pytest.mark.slow
def test_continuation_in_a_point_stops_position_on_the_beam_gives_orbits_of_the_scene_with_it_written(tmp_path):
    """Issue 43, 'continue a parameter only a path can name' on the 2-mode beam: the position of a
    Newton stop below the beam (tests/test_matrix.py's 'point' row, 0.6 mm gap, R 0.9) continued
    at 15 Hz over [160, 178] mm from the sweep's orbit at 170 mm (d x / d position by central
    differences of the scene's shots, each shot a scene rebuilt on the shared FE model).

    Oracle: at four points along the branch, the scene built with that position *written* in its
    [[model.stop]] table and its event integrator -- n forcing periods from the branch's state
    return to it to 1e-8 of the state (tests/test_matrix.py's bound; measured 8e-16 to 3e-12).
    The branch covers the range, and the results name the path with its unit, mm."""
    from vibeam.models import make_solver

    model_of = beam_with_point_stop

    d = {"name": "paths-position", "model": model_of(170.0),
         "sweep": {"frequency_hz": [14.5, 15.5, 3], "transient_periods": 300, "record_periods": 8},
         "run": [{"name": "x", "method": "continuation", "parameter": "stops[1].position_mm", "at": 15.0,
                  "range": [160.0, 178.0], "start": "sweep", "start_at": 170.0, "switch": False,
                  "curves": False}]}
    res = vibeam.continuation(d, jobs=1, out=tmp_path / "out")
    r = res.branches[0]
    assert r.parameter == "stops[1].position_mm" and r.status == "ok", (r.status, r.message)
    b, n = r.branches[0]["data"], int(r.branches[0]["n"])
    x_mm = np.asarray(b["parameter"])
    assert x_mm.min() <= 160.0 + 1e-6 and x_mm.max() >= 178.0 - 1e-6, (x_mm.min(), x_mm.max())
    assert len(x_mm) >= 5 and n >= 1
    Om = float(r.attrs["Omega"])
    for i in np.linspace(0, len(x_mm) - 1, 4).astype(int):
        m = vibeam.load_case(dict(d, model=model_of(float(x_mm[i])))).model_spec().scene()
        x = np.asarray(b["state"][i])
        one = make_solver(m, "event").point(Om, np.concatenate([x, [0.0]]), 0, n, 32)
        assert one.status == "ok", (x_mm[i], one.status)
        assert np.max(np.abs(one.final_state[:-1] - x)) <= 1e-8 * np.max(np.abs(x)), (x_mm[i], one.final_state, x)
    import h5py

    with h5py.File(tmp_path / "out" / "results.h5") as f:
        g = f["branches/x"]
        assert g.attrs["parameter"] == "stops[1].position_mm" and g.attrs["parameter_units"] == "mm"
        assert g["parameter"].attrs["units"] == "mm"


def test_a_continuation_range_in_a_flat_key_the_spec_has_no_field_of_is_checked_by_its_path():
    """``R_lower`` (the flat name of ``stops[1].law.R``, which the SDOF spec holds in its lower
    stop's table, not as a field) over [0.6, 1.5] is refused when the case loads, in one line naming
    'run[0].range' and the value, as the path is; it was accepted and left to the branch."""
    d = tomllib.loads((ROOT / "cases" / "paper-fig7-two-sided.toml").read_text())
    for k in ("quick", "map", "basins"):
        d.pop(k, None)
    d["run"] = [{"name": "c", "method": "continuation", "parameter": "R_lower", "at": 2.0, "range": [0.6, 1.5]}]
    with pytest.raises(CaseError) as e:
        vibeam.load_case(d)
    msg = str(e.value)
    assert "'run[0].range' = [0.6, 1.5]: R_lower = 1.5 is not allowed" in msg and "\n" not in msg, msg
    d["run"][0]["range"] = [0.6, 0.9]
    vibeam.load_case(d)
