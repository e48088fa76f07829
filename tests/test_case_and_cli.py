"""Case validation, the sweep interface and `vibeam run` end to end."""
import subprocess
import sys
from pathlib import Path

import h5py
import numpy as np
import pytest

from vibeam.case.schema import CaseError, parse_case
from vibeam.cli import main
from vibeam.models import linear_amplitude, make_solver
from vibeam.models.builders.sdof import sdof
from vibeam.models.scene import one_mode, outputs
from vibeam.io.results import read_results
from vibeam.engine.sweep import Sweep, run_sweep

GOOD = """
name = "t"
[model]
fidelity = "sdof"
beta = 0.015
B = 0.5e-3
R = 0.9
Delta = 0.0
[sweep]
Omega = [1.8, 2.2, 5]
direction = "both"
transient_periods = 200
record_periods = 16
[[run]]
name = "exact"
method = "event"
"""

PHYSICAL = """
name = "rig"
[model]
fidelity = "sdof"
natural_frequency_hz = 7.6
damping_ratio = 0.017
R = 0.72
gap_mm = 0.0
length_mm = 180.0
gain = 5.16e-4
voltage = 0.6
[sweep]
frequency_hz = [15.0, 15.0, 1]
transient_periods = 300
record_periods = 8
[[run]]
name = "exact"
method = "event"
"""


def test_good_case_parses():
    case = parse_case(GOOD)
    assert case.name == "t"
    assert case.sweep.grid().tolist() == pytest.approx([1.8, 1.9, 2.0, 2.1, 2.2])
    sc = case.model_spec().scene()
    m = one_mode(sc)
    assert (m.beta, m.B, sc.stops[0].law.R, m.Delta) == (0.015, 0.5e-3, 0.9, 0.0)


def test_physical_scene_converts_by_paper_eqs_43_46():
    case = parse_case(PHYSICAL)
    sc = case.model_spec().scene()
    m = one_mode(sc)
    assert m.B == pytest.approx(5.16e-4 * 0.6)
    assert m.Delta == 0.0 and m.beta == 0.017
    assert case.sweep.grid(outputs(sc).natural_frequency_hz)[0] == pytest.approx(15.0 / 7.6)


@pytest.mark.parametrize("old,new,needles", [
    ("R = 0.9", "R = 1.5", ["model.R", "1.5", "less than or equal to 1"]),
    ("R = 0.9", "R = \"high\"", ["model.R", "'high'", "number"]),
    ("beta = 0.015", "beta = -0.1", ["model.beta", "-0.1", "greater than or equal to 0"]),
    ("B = 0.5e-3", "B = 0.5e-3\ngap = 3", ["unknown key 'model.gap'", "allowed keys", "Delta"]),
    ("record_periods = 16", "record_periods = 16\nperiods = 3", ["unknown key 'sweep.periods'",
                                                                  "transient_periods"]),
    ("Omega = [1.8, 2.2, 5]", "Omega = [1.8, 2.2, 0]", ["sweep.Omega", "whole number >= 1"]),
    ("direction = \"both\"", "direction = \"sideways\"", ["sweep.direction", "sideways", "'up'"]),
    ("method = \"event\"", "method = \"rk4\"", ["run[0]", "rk4", "event"]),
    ("method = \"event\"", "method = \"event\"\nchatter = 1", ["unknown key 'run[0].chatter'",
                                                               "chatter_tol"]),
])
def test_bad_case_names_key_value_and_allowed(old, new, needles):
    assert old in GOOD
    with pytest.raises(CaseError) as e:
        parse_case(GOOD.replace(old, new), "bad.toml")
    msg = str(e.value)
    assert msg.startswith("bad.toml")
    for n in needles:
        assert n in msg, (n, msg)


def test_cli_exits_nonzero_with_the_message_and_no_traceback(tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text(GOOD.replace("R = 0.9", "R = -2"))
    p = subprocess.run([sys.executable, "-m", "vibeam.cli", "run", str(bad), "--out", str(tmp_path)],
                       capture_output=True, text=True)
    assert p.returncode == 2
    assert "model.R" in p.stderr and "-2" in p.stderr
    assert "Traceback" not in p.stderr


def test_sweep_both_directions_and_linear_limit():
    """Far from the stop every point of an up/down sweep equals the linear FRC."""
    m = sdof(beta=0.05, B=0.01, Delta=10.0, R=0.8)
    om = one_mode(m)
    Om = np.linspace(0.5, 1.5, 6)
    res = run_sweep(make_solver(m, "event"), Sweep(Omega=Om, direction="both", transient_periods=500,
                                                   record_periods=8), name="lin")
    d = res.data
    assert res.n_points == 12
    assert list(d["direction"][:6]) == ["up"] * 6 and list(d["direction"][6:]) == ["down"] * 6
    assert np.allclose(d["amplitude"] - om.Delta, linear_amplitude(om.beta, om.B, d["Omega"]), rtol=1e-9)
    assert np.all(d["period"] == -1)
    assert d["strobe"].shape == (12, 8, 2) and d["harmonics"].shape == (12, 6)


def test_independent_points_in_a_process_pool_equal_inline():
    m = sdof(beta=0.015, B=0.5e-3, Delta=0.0, R=0.9)
    sw = Sweep(Omega=np.array([1.9, 2.0, 2.1]), transient_periods=300, record_periods=8, continuation=False)
    a = run_sweep(make_solver(m, "event"), sw, jobs=1)
    b = run_sweep(make_solver(m, "event"), sw, jobs=2)
    assert np.array_equal(a.data["amplitude"], b.data["amplitude"])


def test_run_end_to_end_writes_results_plots_and_table(tmp_path, capsys):
    case = tmp_path / "rig.toml"
    case.write_text(PHYSICAL.replace("[15.0, 15.0, 1]", "[14.0, 17.0, 4]").replace(
        'name = "exact"\nmethod = "event"',
        'name = "exact"\nmethod = "event"\n[[run]]\nname = "looser"\nmethod = "event"\n[run.model]\nR = 0.5'))
    out = tmp_path / "out"
    assert main(["run", str(case), "--out", str(out), "--jobs", "1"]) == 0  # not --quiet: this reads the tables it prints (--quiet drops them, issue 42 item 7)
    r = read_results(out / "results.h5")
    assert r["attrs"]["case_name"] == "rig" and "natural_frequency_hz" in r["attrs"]["case_text"]
    run = r["runs"]["exact"]
    assert run["attrs"]["method"] == "event" and run["attrs"]["fidelity"] == "sdof"
    for k in ["Omega", "amplitude", "q_max", "q_min", "period", "impacts_per_period", "impact_velocity",
              "strobe", "harmonics", "direction", "status", "frequency_hz", "amplitude_mm"]:
        assert k in run, k
    assert np.allclose(run["frequency_hz"], [14, 15, 16, 17])
    assert np.allclose(run["amplitude_mm"], run["amplitude"] * 180.0)
    assert r["runs"]["looser"]["attrs"]["method"] == "event"
    with h5py.File(out / "results.h5") as f:
        assert f["runs/exact/frequency_hz"].attrs["units"] == "Hz"
    from test_plots import assert_png_shows_results      # the PNGs are the file's data, drawn

    for kind in ("frc", "bifurcation"):
        assert_png_shows_results(out / f"{kind}.png", out / "results.h5", kind)
    table = capsys.readouterr().out
    assert "exact" in table and "looser" in table and "reference" in table


def test_shipped_cases_are_valid():
    for path in sorted(Path(__file__).parent.parent.joinpath("cases").glob("*.toml")):
        parse_case(path.read_text(), str(path))
