"""Continuation runs in the framework: case files, `vibeam run` / `vibeam continue`, the HDF5
layout, physical keys (chain rule), two-parameter curves against closed forms, bad requests."""
import h5py
import numpy as np
import pytest

from vibeam.case.schema import CaseError, parse_case
from vibeam.cli import main
from vibeam.models import linear_amplitude, shooting_problem
from vibeam.models.orbits.continuation import trace
from vibeam.models.core.scene_shooting import SceneShooting
from vibeam.models.builders.sdof import sdof_physical
from vibeam.models.scene import one_mode
from vibeam.io.results import read_results

FIG8 = """
name = "fig8c"
[model]
fidelity = "sdof"
beta = 0.015
B = 0.5e-3
R = 0.9
Delta = 0.7e-3
[sweep]
Omega = [1.5, 2.5, 11]
direction = "both"
transient_periods = 300
record_periods = 16
[[run]]
name = "exact"
method = "event"
[[run]]
name = "branches"
method = "continuation"
start_at = "low"
"""

RIG = """
name = "rigc"
[model]
fidelity = "sdof"
natural_frequency_hz = 7.6
damping_ratio = 0.017
R = 0.80
gap_mm = -0.1
length_mm = 180.0
gain = 3.78e-4
voltage = 0.6
[sweep]
frequency_hz = [16.0, 17.0, 5]
direction = "down"
transient_periods = 300
record_periods = 16
[[run]]
name = "exact"
method = "event"
[[run]]
name = "period-1"
method = "continuation"
start_at = "high"
"""


def _write(tmp_path, text, name="case.toml"):
    p = tmp_path / name
    p.write_text(text)
    return p


def test_run_writes_branches_with_units(tmp_path, capsys):
    case = _write(tmp_path, FIG8)
    out = tmp_path / "out"
    assert main(["run", str(case), "--out", str(out), "--jobs", "1"]) == 0  # not --quiet: it reads the report (--quiet drops it, issue 42 item 7)
    text = capsys.readouterr().out
    assert "fold" in text and "grazing" in text and "continuation 'branches'" in text
    # labelled data: the branches on (branch, point), the bifurcations on (bifurcation), units
    import xarray as xr

    from vibeam.testing import check_labelled

    check_labelled(out / "results.h5")
    with xr.open_datatree(out / "results.h5", engine="h5netcdf") as t:
        g = t["branches/branches"].to_dataset(inherit=False)
        for k in ("parameter", "amplitude", "impact_velocity", "multipliers", "stable", "period",
                  "impacts_per_period", "state"):
            assert k in g and "units" in g[k].attrs, k
        assert g["amplitude"].dims == ("branch", "point") and g["stable"].dtype == bool
        assert g["multipliers"].dtype == np.complex128 and g.sizes["state_component"] == 2
        assert str(g["branch_status"].values[0]) == "range_end"
        bt = t["branches/branches/bifurcations"].to_dataset(inherit=False)
        assert list(bt["type"].values) == ["fold", "grazing"] and bt["type"].dims == ("bifurcation",)
        assert float(bt["parameter"][0]) == pytest.approx(1.98500220, abs=1e-7)
    with h5py.File(out / "results.h5", "r") as f:
        assert "runs/exact" in f                                 # the sweep beside it
    assert (out / "continuation_branches.png").is_file()
    res = read_results(out / "results.h5")
    assert "00-period1" in res["branches"]["branches"]


def test_physical_scene_and_the_fold_of_the_tight_rig(tmp_path, capsys):
    case = _write(tmp_path, RIG)
    out = tmp_path / "out"
    assert main(["continue", str(case), "--out", str(out), "--jobs", "1", "--quiet", "--no-plots"]) == 0
    g = read_results(out / "results.h5")["branches"]["period-1"]
    b = g["01-period1"] if "01-period1" in g else g["00-period1"]
    assert "frequency_hz" in b and "amplitude_mm" in b
    np.testing.assert_allclose(b["frequency_hz"], b["parameter"] * 7.6, rtol=1e-15)
    np.testing.assert_allclose(b["amplitude_mm"], b["amplitude"] * 180.0, rtol=1e-12)
    f_fold = g["bifurcations"]["frequency_hz"]
    assert len(f_fold) == 1 and 16.25 < f_fold[0] < 16.27


def test_continue_keeps_the_sweeps_of_the_same_case(tmp_path):
    case = _write(tmp_path, FIG8)
    out = tmp_path / "out"
    assert main(["run", str(case), "--out", str(out), "--jobs", "1", "--quiet", "--no-plots"]) == 0
    before = read_results(out / "results.h5")["runs"]["exact"]["amplitude"]
    assert main(["continue", str(case), "--out", str(out), "--jobs", "1", "--quiet", "--no-plots"]) == 0
    after = read_results(out / "results.h5")
    np.testing.assert_array_equal(after["runs"]["exact"]["amplitude"], before)
    assert "branches" in after["branches"]


def test_continue_keeps_the_sweeps_of_an_earlier_vibeams_file_of_the_same_case(tmp_path):
    """The same, when the results file was written before a defaulted [[run]] key existed (its
    stored case lacks `recurrence`): still the same case, its sweeps kept (they used to be
    replaced by a file of branches only) and its case text left as written."""
    import json

    case = _write(tmp_path, FIG8)
    out = tmp_path / "out"
    assert main(["run", str(case), "--out", str(out), "--jobs", "1", "--quiet", "--no-plots"]) == 0
    h5 = out / "results.h5"
    d = json.loads(read_results(h5)["attrs"]["case_json"])
    assert [r.pop("recurrence") for r in d["run"] if "recurrence" in r] == [True]     # the event run's
    with h5py.File(h5, "a") as f:
        f.attrs["case_json"] = old = json.dumps(d)
    before = read_results(h5)["runs"]["exact"]["amplitude"]
    assert main(["continue", str(case), "--out", str(out), "--jobs", "1", "--quiet", "--no-plots"]) == 0
    after = read_results(h5)
    np.testing.assert_array_equal(after["runs"]["exact"]["amplitude"], before)
    assert "branches" in after["branches"] and after["attrs"]["case_json"] == old


def test_continuation_through_a_process_pool_equals_inline(tmp_path):
    case = _write(tmp_path, FIG8)
    a, b = tmp_path / "a", tmp_path / "b"
    assert main(["continue", str(case), "--out", str(a), "--jobs", "1", "--quiet", "--no-plots"]) == 0
    text2 = FIG8.replace('start_at = "low"', 'start_at = "low"\n[[run]]\nname = "again"\nmethod = '
                                             '"continuation"\nstart_at = "low"')
    case2 = _write(tmp_path, text2, "case2.toml")
    assert main(["continue", str(case2), "--out", str(b), "--jobs", "2", "--quiet", "--no-plots"]) == 0
    ra, rb = read_results(a / "results.h5")["branches"], read_results(b / "results.h5")["branches"]
    for name in ("branches", "again"):
        np.testing.assert_array_equal(ra["branches"]["00-period1"]["state"], rb[name]["00-period1"]["state"])


def test_voltage_continuation_is_the_chain_rule_of_B():
    """Continuation in the rig's voltage (physical key, B = gamma V, paper Eq. 44) finds the same
    grazing as the nondimensional model continued in B, at B = gamma V (to 1e-10 relative)."""
    from vibeam.analysis.branches import problem
    spec = parse_case(RIG.replace("gap_mm = -0.1", "gap_mm = 0.05")).model_spec()
    Omega = 2.0
    prob_v = problem(spec, "voltage", Omega)
    gamma = spec.excitation.gain
    sc = spec.scene()
    # the non-impacting orbit at low voltage grazes where C(Omega) B / B0 = Delta
    V0 = 0.2
    x0, why = prob_v.start("linear", V0)
    assert why == ""
    (bv,) = trace(prob_v, x0, V0, 1, 0.1, 1.5, +1)
    (bB,) = trace(shooting_problem(sc, "system.base_amplitude", Omega=Omega), x0, gamma * V0, 1, 0.1 * gamma,
                  1.5 * gamma, +1)
    gv = [f.parameter for f in bv.bifurcations if f.type == "grazing"]
    gB = [f.parameter for f in bB.bifurcations if f.type == "grazing"]
    assert gv and gB and gB[0] == pytest.approx(gamma * gv[0], rel=1e-10)
    # closed form: C(Omega; B) = Delta
    C1 = float(linear_amplitude(one_mode(sc).beta, 1.0, Omega))
    assert gB[0] == pytest.approx(one_mode(sc).Delta / C1, rel=1e-8)


def test_map_curves_follow_the_closed_form_grazing_and_the_one_parameter_fold(tmp_path):
    """Omega x gap map (rig at 0.6 V): every point of the grazing curve of the non-impacting
    orbit satisfies C(f) L = gap (closed form, 1e-8 relative); a point of the fold curve equals
    the fold of a one-parameter continuation at that gap."""
    text = """
name = "gapc"
[model]
fidelity = "sdof"
natural_frequency_hz = 7.6
damping_ratio = 0.017
R = 0.72
gap_mm = 0.076
length_mm = 180.0
gain = 5.16e-4
voltage = 0.6
[sweep]
frequency_hz = [14.0, 16.0, 3]
direction = "up"
transient_periods = 200
record_periods = 16
[map]
parameter = "gap_mm"
values = [0.06, 0.14, 3]
[[run]]
name = "curves"
method = "continuation"
slices = 1
curve_points = 40
"""
    case = _write(tmp_path, text)
    out = tmp_path / "out"
    assert main(["continue", str(case), "--out", str(out), "--jobs", "1", "--quiet", "--no-plots"]) == 0
    g = read_results(out / "results.h5")["branches"]["curves"]["curves"]
    kinds = {k: v for k, v in g.items() if k != "attrs"}
    graze = [v for v in kinds.values() if v["attrs"]["type"] == "grazing"]
    fold = [v for v in kinds.values() if v["attrs"]["type"] == "fold"]
    assert graze and fold
    # every curve stays in the (frequency, gap) box, and one that leaves it ends on its edge (the
    # edge point is relocated on the edge the predictor crossed: a mutant that swapped the two
    # edges survived the test files)
    W_box, g_box = (14.0 / 7.6, 16.0 / 7.6), (0.06, 0.14)
    ended = 0
    for c in kinds.values():
        W, gap = np.asarray(c["parameter"]), np.asarray(c["gap_mm"])
        assert np.all((W >= W_box[0] - 1e-9) & (W <= W_box[1] + 1e-9)), (W.min(), W.max())
        assert np.all((gap >= g_box[0] - 1e-12) & (gap <= g_box[1] + 1e-12)), (gap.min(), gap.max())
        if c["attrs"]["status"] == "box":
            ends = [(W[0], gap[0]), (W[-1], gap[-1])]
            on_edge = [min(abs(w - W_box[0]), abs(w - W_box[1])) <= 1e-9 or min(abs(g - g_box[0]), abs(g - g_box[1]))
                       <= 1e-12 for w, g in ends]
            assert all(on_edge), (c["attrs"]["type"], ends)
            ended += 1
    assert ended >= 1
    B = 5.16e-4 * 0.6
    for c in graze:
        W, gap = c["parameter"], c["gap_mm"]
        C = linear_amplitude(0.017, B, W) * 180.0
        if np.all(np.abs(C - gap) <= 1e-8 * np.abs(gap)):
            break
    else:
        pytest.fail("no grazing curve of the non-impacting orbit")
    assert len(W) >= 5 and (W.max() - W.min()) * 7.6 > 1.0
    c = fold[0]
    k = len(c["parameter"]) // 2
    gap_k, W_k = float(c["gap_mm"][k]), float(c["parameter"][k])
    m = sdof_physical(7.6, 0.017, gap_k, 180.0, 5.16e-4, 0.6, 0.72)
    pr = shooting_problem(m, "Omega")
    from vibeam.models import EventSolver
    tr = EventSolver(m).point(14 / 7.6, None, 1000, 4, 8)
    bs = trace(pr, tr.final_state[:2], 14 / 7.6, 1, 14 / 7.6, 16 / 7.6, +1)
    folds = [f.parameter for b in bs for f in b.bifurcations if f.type == "fold"]
    assert folds and min(abs(f - W_k) for f in folds) < 1e-8


@pytest.mark.parametrize("extra,match", [
    ('parameter = "Gamma"', r"'run\[1\]\.parameter' = 'Gamma' cannot be continued in this scene; allowed: Omega"),
    ('parameter = "B"', r"'run\[1\]\.at' is missing"),
    ('parameter = "B"\nat = 2.0', r"'run\[1\]\.range' is missing"),
    ('start = "middle"', r"'run\[1\]\.start' = 'middle'"),
    ('ds = 0.5\nds_max = 0.1', r"need ds_min <= ds <= ds_max"),
    ('range = [2.0, 1.0]', r"must be \[low, high\]"),
])
def test_bad_continuation_settings_give_one_clear_error(tmp_path, capsys, extra, match):
    case = _write(tmp_path, FIG8.replace('start_at = "low"', extra))
    with pytest.raises(CaseError, match=match):
        parse_case(case.read_text())
    assert main(["continue", str(case), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("vibeam: error:")
    assert not (tmp_path / "o" / "results.h5").exists()


def test_a_fidelity_or_start_that_cannot_be_served(tmp_path, capsys, monkeypatch):
    """The beam has no registered shooting problem (yet): one error naming the key, before any
    computation; a start the problem does not offer: one error naming 'start'."""
    import vibeam.models as models
    monkeypatch.setitem(models.SHOOTING, "sdof", models.SHOOTING["sdof"])
    case = _write(tmp_path, FIG8)
    monkeypatch.delitem(models.SHOOTING, "sdof")
    assert main(["run", str(case), "--out", str(tmp_path / "o"), "--jobs", "1"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "'run[1].method' = 'continuation' is not available for fidelity 'sdof'" in err[0]
    monkeypatch.setitem(models.SHOOTING, "sdof", SceneShooting)
    monkeypatch.setattr(SceneShooting, "offered_starts", staticmethod(lambda scene: ("linear",)))
    case = _write(tmp_path, FIG8.replace('start_at = "low"', 'start = "averaging"'))
    assert main(["continue", str(case), "--out", str(tmp_path / "o2"), "--jobs", "1"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "'run[1].start' = 'averaging' is not available for fidelity 'sdof'" in err[0]


def test_no_continuation_run_and_a_branch_that_cannot_start(tmp_path, capsys):
    case = _write(tmp_path, FIG8.split("[[run]]\nname = \"branches\"")[0])
    assert main(["continue", str(case), "--out", str(tmp_path / "o")]) == 2
    assert "no run has method = \"continuation\"" in capsys.readouterr().err
    # the linear orbit does not exist at Omega = 1.5 here: a recorded status, not a traceback
    case = _write(tmp_path, FIG8.replace('start_at = "low"', 'start = "linear"\nstart_at = "low"'))
    out = tmp_path / "o3"
    assert main(["continue", str(case), "--out", str(out), "--jobs", "1", "--no-plots"]) == 0  # not --quiet: it reads the report (--quiet drops it, issue 42 item 7)
    text = capsys.readouterr().out
    assert "not_available" in text and "does not exist" in text
    with h5py.File(out / "results.h5", "r") as f:
        g = f["branches/branches"]
        assert g.attrs["status"] == "failed" and "no branch could start" in g.attrs["message"]


def test_physical_keys_in_a_case_file(tmp_path):
    """Continuation in the voltage at a frequency in Hz, and in the frequency from a start given
    in Hz (the units of [sweep]); the parameter is stored with its unit."""
    text = RIG.replace('frequency_hz = [16.0, 17.0, 5]', 'frequency_hz = [16.0, 17.5, 4]').split(
        "[[run]]\nname = \"period-1\"")[0] + """
[[run]]
name = "voltage"
method = "continuation"
parameter = "voltage"
at = 16.5
range = [0.4, 1.0]
start_at = 0.6
max_period = 1
[[run]]
name = "from 16.6 Hz"
method = "continuation"
start_at = 16.6
"""
    case = _write(tmp_path, text)
    out = tmp_path / "out"
    assert main(["continue", str(case), "--out", str(out), "--jobs", "1", "--quiet", "--no-plots"]) == 0
    with h5py.File(out / "results.h5", "r") as f:
        g = f["branches/voltage"]
        assert g["parameter"].attrs["units"] == "V"
        assert g.attrs["frequency_hz"] == pytest.approx(16.5)
        V = read_results(out / "results.h5")["branches"]["voltage"]["00-period1"]["parameter"]
        assert V.min() >= 0.4 - 1e-12 and V.max() <= 1.0 + 1e-12 and np.any(np.isclose(V, 0.6))
        h = f["branches/from 16.6 Hz"]
        fb = h["bifurcations/frequency_hz"][()]
        assert len(fb) == 1 and fb[0] == pytest.approx(16.257819, abs=1e-6)
    bad = _write(tmp_path, text.replace("start_at = 16.6", "start_at = 18.0"), "bad.toml")
    with pytest.raises(CaseError, match=r"'run\[2\]\.start_at' = 18\.0 lies outside the range \[16\.0, 17\.5\]"):
        parse_case(bad.read_text())
