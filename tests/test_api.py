"""The Python API (vibeam.load_case, run, simulate, open_results) and README's notebook example."""
from __future__ import annotations
from vibeam.models import shooting_problem

import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import vibeam
from vibeam.case.schema import CaseError
from vibeam.models.builders.sdof import sdof

ROOT = Path(__file__).resolve().parents[1]
FIG7 = ROOT / "cases" / "paper-fig7.toml"
SMALL = """
name = "small"
[model]
fidelity = "sdof"
beta = 0.015
B = 0.5e-3
R = 0.9
Delta = 0.0
[sweep]
Omega = [1.8, 2.2, 5]
direction = "both"
transient_periods = 100
record_periods = 8
[[run]]
name = "exact"
method = "event"
[[run]]
name = "avg"
method = "averaging"
"""


def test_import_is_lazy():
    """``import vibeam`` loads none of the heavy modules; the API's names load on first use."""
    code = ("import sys, vibeam; heavy = [m for m in ('numba', 'xarray', 'h5py', 'matplotlib', 'scipy', "
            "'vibeam.api') if m in sys.modules]; assert not heavy, heavy; "
            "assert callable(vibeam.run) and 'vibeam.api' in sys.modules")
    subprocess.run([sys.executable, "-c", code], check=True)


def test_load_case_from_path_text_and_dict():
    a = vibeam.load_case(FIG7)
    b = vibeam.load_case(str(FIG7))
    c = vibeam.load_case(FIG7.read_text())
    d = vibeam.load_case(a.model_dump(exclude_none=True))
    assert a == b == c == d
    with pytest.raises(CaseError, match=r"'sweep.direction' = 'sideways'"):
        vibeam.load_case(SMALL.replace('direction = "both"', 'direction = "sideways"'))
    with pytest.raises(CaseError, match="cannot read case file"):
        vibeam.load_case("no/such/case.toml")


@pytest.mark.slow   # two quick sweeps through the API and the CLI (~18 s): slow step
def test_run_returns_labelled_results_equal_to_the_command_line(tmp_path):
    from vibeam.cli import main
    from vibeam.io.results import read_results

    res = vibeam.run(SMALL, jobs=1)
    assert res.names == ["exact", "avg"] and res.path is None
    ds = res.to_xarray("exact")
    assert ds["amplitude"].dims == ("direction", "Omega") and list(ds["direction"].values) == ["up", "down"]
    assert ds["amplitude"].attrs["units"] == "1" and "Q = Delta - min q" in ds["amplitude"].attrs["long_name"]
    tree = res.to_xarray()
    assert set(tree["runs"].children) == {"exact", "avg"}
    # the same numbers as `vibeam run` (bit for bit: same code, same inputs)
    case = tmp_path / "small.toml"
    case.write_text(SMALL)
    assert main(["run", str(case), "--out", str(tmp_path / "cli"), "--quiet", "--no-plots", "--jobs", "1"]) == 0
    cli = read_results(tmp_path / "cli" / "results.h5")["runs"]["exact"]
    np.testing.assert_array_equal(res["exact"].data["amplitude"], cli["amplitude"])
    np.testing.assert_array_equal(ds["amplitude"].sel(direction="down").values, cli["amplitude"][5:][::-1])
    fig = res.plot_frc()
    assert fig.axes[0].get_xlabel().endswith("(–)")
    import matplotlib.pyplot as plt

    plt.close(fig)
    # with an output folder: the results file, readable back as the same Results
    kept = vibeam.run(SMALL, jobs=1, out=tmp_path / "api")
    assert kept.path == tmp_path / "api" / "results.h5" and kept.path.is_file()
    back = vibeam.Results.from_file(kept.path)
    np.testing.assert_array_equal(back["exact"].data["amplitude"], res["exact"].data["amplitude"])
    assert back.case == kept.case
    tree = vibeam.open_results(kept.path)
    np.testing.assert_array_equal(tree["runs/exact"]["amplitude"].values, ds["amplitude"].values)


def test_simulate_time_base_against_the_linear_steady_state():
    """Far from the stop (Delta = 10: no impact) after 3000 transient periods the record is the
    linear steady state q_p(t) = Omega^2 B [(1 - Omega^2) sin Omega t - 2 beta Omega cos Omega t]
    / ((1 - Omega^2)^2 + (2 beta Omega)^2) (Eq. 28, particular part), with t = 0 at forcing phase 0:
    the time vector is in phase with the forcing to 1e-10 (the transient left: exp(-0.05 * 3000 *
    2 pi / 1.3) < 1e-300)."""
    m = sdof(beta=0.05, B=0.01, Delta=10.0, R=0.8)
    W = 1.3
    sim = vibeam.simulate(m, Omega=W, periods=3, transient=3000, samples_per_period=50)
    assert sim.t.shape == (150,) and sim.t[1] == pytest.approx(2 * np.pi / W / 50, rel=1e-15)
    den = (1 - W ** 2) ** 2 + (2 * 0.05 * W) ** 2
    qp = W ** 2 * 0.01 * ((1 - W ** 2) * np.sin(W * sim.t) - 2 * 0.05 * W * np.cos(W * sim.t)) / den
    dqp = W ** 3 * 0.01 * ((1 - W ** 2) * np.cos(W * sim.t) + 2 * 0.05 * W * np.sin(W * sim.t)) / den
    np.testing.assert_allclose(sim.q, qp, atol=1e-10 * np.abs(qp).max())
    np.testing.assert_allclose(sim.dq, dqp, atol=1e-10 * np.abs(dqp).max())
    assert sim.impact_times.size == 0 and sim.summary["period"] == -1 and sim.status == "ok"


def test_simulate_equals_the_sweep_point_and_lists_the_impacts():
    """One frequency of a case: the same record as the sweep's point started from rest (a sweep
    without continuation), its impacts inside the window with q' jumping by -R there."""
    from vibeam.engine.records import summarize
    from vibeam.models import make_solver

    case = vibeam.load_case(SMALL)
    sim = vibeam.simulate(case, Omega=2.0)
    tr = make_solver(case.model_spec().scene(), "event").point(2.0, None, 100, 8, 64)
    assert sim.summary["amplitude"] == summarize(tr, 0.0)["amplitude"]
    np.testing.assert_array_equal(sim.q, tr.samples[:, 0])
    assert sim.impact_times.size == sim.summary["impacts_per_period"] * 8
    assert np.all((sim.impact_times >= 0) & (sim.impact_times <= sim.t[-1] + 2 * np.pi / 2.0 / 64))
    assert np.all(sim.impact_velocities > 0)
    # between samples around an impact, q' goes from +v to about -R v
    k = np.searchsorted(sim.t, sim.impact_times[0])
    assert sim.dq[k - 1] > 0 > sim.dq[k]
    with pytest.raises(ValueError, match="computes no time history"):
        vibeam.simulate(case, Omega=2.0, run="avg")


def test_simulate_a_physical_scene_in_mm_and_seconds():
    case = vibeam.load_case(ROOT / "cases" / "rig-neutral.toml")
    sim = vibeam.simulate(case, frequency_hz=15.0, periods=2)
    fn, L = 7.6, 0.18
    assert sim.Omega == pytest.approx(15.0 / fn)
    np.testing.assert_allclose(sim.U_mm, sim.q * L * 1e3)
    np.testing.assert_allclose(sim.dU_mm_s, sim.dq * L * 1e3 * 2 * np.pi * fn)
    np.testing.assert_allclose(sim.time_s[-1] + sim.time_s[1], 2 / 15.0, rtol=1e-12)   # two forcing periods
    ds = sim.to_xarray()
    assert ds["U"].attrs["units"] == "mm" and ds["time_s"].attrs["units"] == "s" and ds.attrs["frequency_hz"] == 15.0
    with pytest.raises(ValueError, match="physical scene"):
        vibeam.simulate(vibeam.load_case(SMALL), frequency_hz=15.0)


def test_simulate_and_lyapunov_take_the_scene_of_a_case():
    """A case's scene (``model_spec().scene()``, what every method takes) simulated directly gives
    the case's own record bit for bit (the same solver of the same scene: no effects, no settings
    in rig-neutral's event run), in its units; ``lyapunov`` of the scene equals that of the case
    (the same shooting problem from the same state: exact equality, a difference means the two
    entries built different scenes)."""
    case = vibeam.load_case(ROOT / "cases" / "rig-neutral.toml")
    scene = case.model_spec().scene()
    a = vibeam.simulate(case, frequency_hz=15.0, periods=2, transient=50)
    b = vibeam.simulate(scene, frequency_hz=15.0, periods=2, transient=50, samples_per_period=a.t.size // 2)
    assert b.natural_frequency_hz == a.natural_frequency_hz and b.length_m == a.length_m
    np.testing.assert_array_equal(b.q, a.q)
    np.testing.assert_array_equal(b.impact_times, a.impact_times)
    la = vibeam.lyapunov(case, frequency_hz=15.0, shots=20, transient=50)
    lb = vibeam.lyapunov(scene, frequency_hz=15.0, shots=20, transient=50)
    np.testing.assert_array_equal(lb.exponents, la.exponents)


def _python_blocks(text: str) -> list:
    return re.findall(r"```python\n(.*?)```", text, flags=re.S)


def test_readme_python_examples_run(monkeypatch, tmp_path):
    """Every ```python block of README.md runs, in order, in one namespace (as a notebook),
    from the repository's root (the paths of the examples)."""
    import matplotlib

    matplotlib.use("Agg")
    blocks = _python_blocks((ROOT / "README.md").read_text())
    assert blocks, "README.md has no python example"
    monkeypatch.chdir(ROOT)
    ns: dict = {}
    for code in blocks:
        exec(compile(code, "README.md", "exec"), ns)
    import matplotlib.pyplot as plt

    plt.close("all")


def _old_layout_file(path, new):
    """A results file of the first layout (flat per-point datasets, no dimensions) holding the
    runs of ``new`` (a read_results dict), as vibeam wrote them before netCDF."""
    import h5py

    with h5py.File(path, "w") as f:
        for k in ("case_name", "case_text", "case_json"):
            f.attrs[k] = new["attrs"][k]
        f.attrs["complete"] = True
        for name, run in new["runs"].items():
            g = f.create_group(f"runs/{name}")
            for k, v in run.items():
                if k == "attrs" or isinstance(v, dict):
                    continue
                v = np.asarray(v)
                g.create_dataset(k, data=np.array([str(x) for x in v], dtype=h5py.string_dtype())
                                 if v.dtype.kind in "OU" else v)
            for k, v in run["attrs"].items():
                g.attrs[k] = v


def test_files_of_the_first_layout_are_read_and_not_labelled(tmp_path):
    """read_results (and so regress) reads the flat layout of older files; the labelled-data
    check refuses it (no dimensions, no units), open_results says how to convert it."""
    from vibeam.cli import main
    from vibeam.io.results import layout_of, read_results
    from vibeam.testing import check_labelled

    case = tmp_path / "small.toml"
    case.write_text(SMALL)
    assert main(["run", str(case), "--out", str(tmp_path / "new"), "--quiet", "--no-plots", "--jobs", "1"]) == 0
    new = read_results(tmp_path / "new" / "results.h5")
    old = tmp_path / "old.h5"
    _old_layout_file(old, new)
    assert layout_of(old) == 1 and layout_of(tmp_path / "new" / "results.h5") == 2
    back = read_results(old)
    for k in ("Omega", "amplitude", "strobe", "period"):
        np.testing.assert_array_equal(back["runs"]["exact"][k], new["runs"]["exact"][k])
    assert list(back["runs"]["exact"]["direction"]) == list(new["runs"]["exact"]["direction"])
    assert main(["regress", str(case), "--reference", str(old), "--results", str(tmp_path / "new" / "results.h5")]) == 0
    with pytest.raises(AssertionError):
        check_labelled(old)
    with pytest.raises(ValueError, match="first layout"):
        vibeam.open_results(old)
    check_labelled(tmp_path / "new" / "results.h5")
    # a variable without units fails the check
    import h5py

    with h5py.File(tmp_path / "new" / "results.h5", "r+") as f:
        del f["runs/exact/amplitude"].attrs["units"]
    with pytest.raises(AssertionError, match="amplitude: no units"):
        check_labelled(tmp_path / "new" / "results.h5")


def test_write_group_writes_any_labelled_group(tmp_path):
    """The generic writer (for groups other than runs and maps, e.g. continuation branches):
    named dimensions, a dimension coordinate, an auxiliary 2-D coordinate, units, strings, a
    subgroup sharing its parent's dimension; a shape that does not match its dims is refused."""
    import h5py
    import xarray as xr

    from vibeam.io.results import var, write_group

    n_b, n_p = 3, 4
    variables = {
        "branch": var(("branch",), np.arange(n_b), "1", "branch index"),
        "Omega": var(("branch", "point"), np.linspace(1, 2, n_b * n_p).reshape(n_b, n_p), "1",
                     "forcing frequency over natural frequency", aux=True),
        "amplitude": var(("branch", "point"), np.ones((n_b, n_p)), "1", "amplitude Q"),
        "stable": var(("branch", "point"), np.zeros((n_b, n_p), bool), "1", "stable orbit"),
        "branch_status": var(("branch",), np.array(["ok", "fold", "ok"], dtype=object), None, "how it ended"),
    }
    sub = {"bifurcations": ({"branch_of": var(("branch",), np.array([0, 0, 1]), "1", "parent branch")}, {})}
    with h5py.File(tmp_path / "g.h5", "w") as f:
        write_group(f, "branches/cont", variables, {"method": "continuation", "settings": {"ds": 0.01}}, sub)
        with pytest.raises(ValueError, match="dims"):
            write_group(f, "bad", {"x": var(("a",), np.ones((2, 2)), "1", "x")})
    ds = xr.open_dataset(tmp_path / "g.h5", group="branches/cont", engine="h5netcdf")
    assert ds["amplitude"].dims == ("branch", "point") and "Omega" in ds.coords
    assert ds["stable"].dtype == bool and ds["branch_status"].values.tolist() == ["ok", "fold", "ok"]
    assert ds["amplitude"].attrs["units"] == "1" and ds.attrs["json_attrs"] == "settings"
    tree = xr.open_datatree(tmp_path / "g.h5", engine="h5netcdf")
    assert tree["branches/cont/bifurcations"]["branch_of"].dims == ("branch",)
    tree.close()
    ds.close()


# ----------------------------------------------------------------------------- bad arguments (issue 19, item 15)
# Each call raises TypeError (a wrong type) or ValueError (out of range) with one line naming the
# argument, the value and what is allowed, by the same rule as the case key it stands for.  Before,
# Omega=-1 ran backwards in time and reported ok, nan gave `failed` without an error, 0 and inf a
# ZeroDivisionError, periods=0 an amplitude of -inf `ok`, transient=-1 ran, periods=10**12 a
# MemoryError, periods=-3 numpy's message, jobs=0/-1/2.5 were accepted and jobs="2" a bare TypeError.
BAD_SIMULATE = [
    (dict(Omega=-1.0), ValueError, ["Omega = -1.0", "> 0"]),
    (dict(Omega=float("nan")), ValueError, ["Omega = nan", "finite number > 0"]),
    (dict(Omega=0.0), ValueError, ["Omega = 0.0", "> 0"]),
    (dict(Omega=float("inf")), ValueError, ["Omega = inf", "finite"]),
    (dict(Omega="2"), TypeError, ["Omega = '2'", "not a number"]),
    (dict(Omega=True), TypeError, ["Omega = True"]),
    (dict(Omega=2.0, periods=0), ValueError, ["periods = 0", ">= 1", "record_periods"]),
    (dict(Omega=2.0, periods=-3), ValueError, ["periods = -3", ">= 1"]),
    (dict(Omega=2.0, periods=2.5), TypeError, ["periods = 2.5", "whole number"]),
    (dict(Omega=2.0, transient=-1), ValueError, ["transient = -1", ">= 0", "transient_periods"]),
    (dict(Omega=2.0, transient="auto"), ValueError, ["transient = 'auto'", "whole number >= 0"]),
    (dict(Omega=2.0, samples_per_period=8), ValueError, ["samples_per_period = 8", ">= 16"]),
    (dict(Omega=1e-9), ValueError, ["Omega = 1e-09", "limit"]),        # 16 / Omega steps a period
    (dict(Omega=2.0, frequency_hz=3.0), ValueError, ["Omega = 2.0", "frequency_hz = 3.0", "not both"]),
    (dict(), ValueError, ["Omega = None"]),
    (dict(Omega=2.0, run=2), ValueError, ["run = 2", "0 ... 1"]),
    (dict(Omega=2.0, run="nope"), ValueError, ["run = 'nope'", "'exact'"]),
    (dict(Omega=2.0, run=1.0), TypeError, ["run = 1.0"]),
    (dict(Omega=2.0, state=[0.0, float("nan"), 0.0]), ValueError, ["state = ", "3 finite numbers"]),
    # the held flag against the state (issue 56, item 8): a held flag on a free state was snapped
    # onto the stop (q = -0.001 started at q = 0), one naming a stop the one-sided scene lacks was
    # read as free, a fraction was rounded, a held state moving off its stop was stopped
    (dict(Omega=2.0, state=[-0.001, 0.0, 1.0]), ValueError,
     ["state = [-0.001, 0.0, 1.0]", "held flag 1 holds it on the stop", "gap -0.001, free of it", "flag 0"]),
    (dict(Omega=2.0, state=[0.0, 0.0, -1.0]), ValueError,
     ["state = [0.0, 0.0, -1.0]", "held flag -1 names a stop the scene does not have (1 stop)",
      "0 (free) or 1 (on the stop)"]),
    (dict(Omega=2.0, state=[0.0, 0.0, 0.5]), ValueError, ["held flag 0.5 not a whole number"]),
    (dict(Omega=2.0, state=[0.0, 0.0, 2.0]), ValueError, ["held flag 2 names a stop the scene does not have"]),
    (dict(Omega=2.0, state=[0.0, -0.01, 1.0]), ValueError,
     ["held flag 1 holds it on the stop", "moves along the stop's normal (velocity -0.01)"]),
    (dict(Omega=2.0, force="yes"), TypeError, ["force = 'yes'", "True or False"]),
]


@pytest.mark.parametrize("kw,exc,needles", BAD_SIMULATE, ids=[str(b[0]) for b in BAD_SIMULATE])
def test_simulate_refuses_bad_arguments_in_one_line(kw, exc, needles):
    """No solver runs for a refused argument (each call here is refused before the kernel)."""
    case = vibeam.load_case(SMALL)
    with pytest.raises(exc) as e:
        vibeam.simulate(case, **kw)
    msg = str(e.value)
    assert "\n" not in msg and all(n in msg for n in needles), msg


def test_every_entry_taking_a_state_refuses_an_inconsistent_held_flag_and_takes_a_consistent_one():
    """One check for every initial state (vibeam.api.simulation._check_state): simulate, poincare
    and lyapunov refuse the held flag on a free state with the same one line, before any kernel
    runs; a state held on its stop (gap 0, no velocity) is taken -- on the upper stop of the
    one-sided scene and on the lower stop of a two-sided one (flag -1) -- and so is the final
    state of a simulation held on a pre-stressed stop (Delta = -0.1, forcing Omega^2 B = 0.017
    below the preload: the mass stays on the stop, flag 1), passed back as it was returned."""
    bad = [-0.001, 0.0, 1.0]
    lines = []
    for f in (vibeam.simulate, vibeam.poincare, vibeam.lyapunov):
        with pytest.raises(ValueError) as e:
            f(vibeam.load_case(SMALL), Omega=2.0, state=bad)
        lines.append(str(e.value))
    assert len(set(lines)) == 1 and "held flag 1 holds it on the stop" in lines[0], lines
    sim = vibeam.simulate(vibeam.load_case(SMALL), Omega=2.0, periods=2, transient=0, state=[0.0, 0.0, 1.0])
    assert sim.status != "failed"
    two = sdof(beta=0.015, B=0.5e-3, Delta=0.0, R=0.9, Delta_lower=2e-3)
    sim = vibeam.simulate(two, Omega=2.0, periods=2, state=[-2e-3, 0.0, -1.0])
    assert sim.status != "failed"
    with pytest.raises(ValueError, match=r"held flag -1 holds it on the lower stop \(stop 1\), but it is not on it"):
        vibeam.simulate(two, Omega=2.0, periods=2, state=[-1e-3, 0.0, -1.0])
    pre = sdof(beta=0.05, B=0.01, Delta=-0.1, R=0.8)
    held = vibeam.simulate(pre, Omega=1.3, periods=2)
    assert held.final_state[-1] == 1.0 and held.final_state[0] == pytest.approx(-0.1, abs=1e-15)
    again = vibeam.simulate(pre, Omega=1.3, periods=2, state=held.final_state)
    assert again.final_state[-1] == 1.0


def test_simulate_refuses_periods_above_the_work_limit():
    """periods = 10**12 of a case and of a model: refused by the work limit of `vibeam run`.
    Before, a MemoryError, or (with the chunked simulation of the sweep engine) memory growing
    until the kernel's OOM killer ended the process at 24 GB: in a child process whose address
    space is capped at 2 GB, the run bounded (guards only)."""
    code = ("import vibeam\n"
            "from vibeam.models.builders.sdof import sdof\n"
            f"case = vibeam.load_case({SMALL!r})\n"
            "for what in (case, sdof(beta=0.05, B=0.01, Delta=10.0, R=0.8)):\n"
            "    try:\n        vibeam.simulate(what, Omega=2.0, periods=10**12)\n"
            "    except ValueError as e:\n        print('refused:', e)\n")

    def cap():
        import resource

        resource.setrlimit(resource.RLIMIT_AS, (2 << 30, 2 << 30))

    p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300, preexec_fn=cap)
    lines = p.stdout.splitlines()
    assert len(lines) == 2 and all(l.startswith("refused: ") and "periods = 1000000000000" in l
                                   and "force=True" in l for l in lines), (p.stdout, p.stderr[-2000:])


def test_simulate_of_a_model_checks_its_arguments_too():
    m = sdof(beta=0.05, B=0.01, Delta=10.0, R=0.8)
    with pytest.raises(ValueError, match="Omega = 0.0"):
        vibeam.simulate(m, Omega=0.0)
    with pytest.raises(TypeError, match="method = 3"):
        vibeam.simulate(m, Omega=1.3, method=3)


def test_simulate_of_a_compliant_model_counts_its_contact_steps():
    """A pre-stressed stop of stiffness ratio k_c = 1e18 (Delta = -0.1: the mass stays on it)
    steps its contact at 1/16 of the contact period, 8 sqrt(1 + k_c) / Omega = 4e9 steps a
    forcing period at Omega = 2: 40 periods are 1.6e11 steps, above the limit of 1e11 (the
    event grid alone, 40 x 64 samples, is not).  Refused before any kernel runs, like the same
    scene through ``vibeam run`` (runner.estimate_work counts the same contact steps)."""
    from vibeam.models.compliant import LinearContact

    m = sdof(beta=0.015, B=0.5e-3, Delta=-0.1, law=LinearContact.from_restitution(1e18, 0.9))
    with pytest.raises(ValueError, match="about 1.6e\\+11 solver steps.*force=True"):
        vibeam.simulate(m, Omega=2.0, periods=40)


@pytest.mark.parametrize("source,exc,needles", [
    (None, TypeError, ["source = None", "a path to a case file"]),
    (123, TypeError, ["source = 123"]),
    (b"name = 'x'", TypeError, ["source = b"]),
    ("", ValueError, ["empty path"]),
    (str(ROOT / "cases"), ValueError, ["cases", "a directory, not a regular file"]),
], ids=["None", "123", "bytes", "empty", "directory"])
def test_load_case_refuses_what_is_not_a_case(source, exc, needles):
    """Before: None, 123 and a directory all said "not valid TOML"."""
    with pytest.raises(exc) as e:
        vibeam.load_case(source)
    assert all(n in str(e.value) for n in needles) and "not valid TOML" not in str(e.value), str(e.value)


def test_load_case_refuses_a_device_before_reading_it():
    """Before, /dev/zero was read without end (24 GB, killed by the kernel): in a child process
    whose address space is capped at 2 GB and whose run is bounded (guards only)."""
    code = ("import vibeam\n"
            "try:\n    vibeam.load_case('/dev/zero')\nexcept ValueError as e:\n    print('refused:', e)\n")

    def cap():
        import resource

        resource.setrlimit(resource.RLIMIT_AS, (2 << 30, 2 << 30))

    p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120, preexec_fn=cap)
    assert p.stdout.startswith("refused: /dev/zero") and "character device" in p.stdout, (p.stdout, p.stderr)


@pytest.mark.parametrize("kw,exc,needles", [
    (dict(jobs=0), ValueError, ["jobs = 0", "from 1 to"]),
    (dict(jobs=-1), ValueError, ["jobs = -1"]),
    (dict(jobs=2.5), TypeError, ["jobs = 2.5", "whole number"]),
    (dict(jobs="2"), TypeError, ["jobs = '2'"]),
    (dict(jobs=True), TypeError, ["jobs = True"]),
    (dict(jobs=10000), ValueError, ["jobs = 10000", "x the"]),
    (dict(out=""), ValueError, ["out = ''", "empty path"]),
    (dict(out=3), TypeError, ["out = 3"]),
    (dict(quick="no"), TypeError, ["quick = 'no'"]),
    (dict(executor="pool"), TypeError, ["executor = 'pool'"]),
], ids=lambda v: str(v) if isinstance(v, dict) else "")
def test_run_refuses_bad_arguments_before_anything_runs(kw, exc, needles, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    with pytest.raises(exc) as e:
        vibeam.run(SMALL, **kw)
    assert all(n in str(e.value) for n in needles), str(e.value)
    assert list(tmp_path.iterdir()) == []


def test_jobs_cap_is_a_stated_multiple_of_the_cores():
    import os

    from vibeam.case.arguments import JOBS_PER_CORE, check_jobs, max_jobs

    assert max_jobs() == JOBS_PER_CORE * os.cpu_count() and JOBS_PER_CORE == 4
    assert check_jobs(max_jobs()) == max_jobs() and check_jobs(np.int64(1)) == 1 and check_jobs(None) is None
    with pytest.raises(ValueError):
        check_jobs(max_jobs() + 1)


def test_results_files_must_be_regular_files(tmp_path):
    with pytest.raises(ValueError, match="directory, not a regular file"):
        vibeam.open_results(tmp_path)
    with pytest.raises(ValueError, match="no such file"):
        vibeam.Results.from_file(tmp_path / "none.h5")


# ----------------------------------------------------------------------------- issue 22: every group, every command
FIG13C = ROOT / "cases" / "paper-fig13-continuation.toml"
BASINS = {"name": "bas", "model": {"fidelity": "sdof", "beta": 0.015, "B": 0.5e-3, "R": 0.9, "Delta": 0.0},
          "sweep": {"Omega": [1.9, 2.1, 3], "transient_periods": 100, "record_periods": 8},
          "run": [{"name": "exact", "method": "event"}],
          "basins": {"Omega": 2.0, "grid": [8, 8], "x_range": [-0.03, 0.0], "y_range": [-0.05, 0.05],
                     "lyapunov_periods": 0, "record_periods": 16}}


def _close_all():
    import matplotlib.pyplot as plt

    plt.close("all")


@pytest.fixture(scope="module")
def continuation_results(tmp_path_factory):
    """The quick Fig. 13 continuation case, once in memory (out=None) and once into a folder."""
    import matplotlib

    matplotlib.use("Agg")
    out = tmp_path_factory.mktemp("fig13c")
    mem = vibeam.run(FIG13C, quick=True, jobs=1)
    disk = vibeam.run(FIG13C, quick=True, jobs=1, out=out)
    return mem, disk


def test_run_keeps_the_continuation_branches_in_memory_and_in_the_file(continuation_results):
    """Before (issue 22): names == ['exact'], the branches dropped (and lost with out=None).  The
    period-1 branch's period doubling is at Omega = 2.281 (cases/paper-fig13-continuation.toml,
    located to 1e-8 by the continuation: 1e-3 is loose on purpose, the case states 2.281)."""
    mem, disk = continuation_results
    assert mem.path is None and mem.names == ["exact", "branches"]
    assert set(mem.groups) >= {"runs/exact", "branches/branches", "branches/branches/bifurcations"}
    b = mem.branches[0]
    ds = b.to_xarray()
    assert ds["amplitude"].dims == ("branch", "point") and ds["amplitude"].attrs["units"] == "1"
    bif = mem.bifurcations[0].to_xarray()
    pd1 = [float(p) for t, p, n in zip(bif["type"].values, bif["parameter"].values, bif["period"].values)
           if t == "period_doubling" and n == 1]
    assert pd1 and abs(pd1[0] - 2.281) < 1e-3
    # the file holds the same groups; open_results gives the same object back, value for value
    back = vibeam.open_results(disk.path)
    assert isinstance(back, vibeam.Results) and back.names == mem.names and set(back.groups) == set(mem.groups)
    for kind in ("runs/exact", "branches/branches", "branches/branches/bifurcations"):
        a, c = mem.groups[kind].to_xarray(), back.groups[kind].to_xarray()
        for k in a.data_vars:
            if k != "wall_time_s":            # timings differ between the two runs
                np.testing.assert_array_equal(a[k].values, c[k].values, err_msg=f"{kind}/{k}")
    for x, y in zip(mem.branches[0].branches, back.branches[0].branches):
        np.testing.assert_array_equal(x["data"]["amplitude"], y["data"]["amplitude"])
    assert back["runs/exact"]["amplitude"].dims == ("direction", "Omega")      # the DataTree node
    # every group plots (the existing figure functions)
    import matplotlib.figure

    for g in list(mem.groups.values()) + list(back.groups.values()):
        assert isinstance(g.plot(), matplotlib.figure.Figure), g.group
    _close_all()


def test_continuation_function_equals_the_run(continuation_results, tmp_path):
    """vibeam.continuation (`vibeam continue`) gives the same branches as the run's."""
    mem, _ = continuation_results
    con = vibeam.continuation(FIG13C, quick=True, jobs=1)
    assert vibeam.continue_ is vibeam.continuation
    assert con.names == ["branches"] and con.runs == []
    for x, y in zip(mem.branches[0].branches, con.branches[0].branches):
        np.testing.assert_array_equal(x["data"]["parameter"], y["data"]["parameter"])


@pytest.fixture(scope="module")
def basins_results(tmp_path_factory):
    import matplotlib

    matplotlib.use("Agg")
    out = tmp_path_factory.mktemp("bas")
    return vibeam.run(BASINS, jobs=1, out=out)


def test_run_computes_the_basins_of_a_case_and_reads_them_back(basins_results):
    """A case with [basins]: `vibeam run` computed them; now vibeam.run does too, and
    open_results rebuilds the same BasinsResult (labels, attractors, axes) from the file."""
    res = basins_results
    assert [b.name for b in res.basins] == ["exact"] and "basins/exact" in res.groups
    b = res.basins[0]
    assert b.labels.shape == (1, 8, 8) and b.n_attractors >= 1
    ds = b.to_xarray()
    assert ds["basin"].dims == ("Omega", "state_2", "state_1")
    back = vibeam.open_results(res.path).basins[0]
    np.testing.assert_array_equal(back.labels, b.labels)
    np.testing.assert_array_equal(back.x, b.x)
    assert back.axes == b.axes and back.attractors["type"] == b.attractors["type"]
    np.testing.assert_array_equal(back.attractors["amplitude"], b.attractors["amplitude"])
    np.testing.assert_array_equal(back.grazing, b.grazing)
    import matplotlib.figure

    assert isinstance(back.plot(), matplotlib.figure.Figure) and isinstance(b.plot(), matplotlib.figure.Figure)
    _close_all()


def test_export_writes_tidy_csv_equal_to_the_file(continuation_results, basins_results, tmp_path):
    """Round trip: every value of every CSV equals the h5 value at its coordinates (exactly:
    pandas writes floats with repr precision, 17 significant digits)."""
    import pandas as pd
    import xarray as xr

    from vibeam.cli import main

    for res in (continuation_results[1], basins_results):
        d = tmp_path / res.path.parent.name
        files = vibeam.export(res.path, d)
        assert files and all(p.is_file() and p.with_suffix(".units.csv").is_file() for p in files)
        tree = xr.open_datatree(res.path, engine="h5netcdf")
        index = pd.read_csv(d / "index.csv", keep_default_na=False).set_index("file")
        assert sorted(index.index) == sorted(p.name for p in files)
        for p in files:
            ds = tree[index.loc[p.name, "group"]].to_dataset()
            t = pd.read_csv(p, keep_default_na=False, na_values=[""])
            units = pd.read_csv(p.with_suffix(".units.csv"), keep_default_na=False)
            assert list(units["column"]) == list(t.columns)
            dims = index.loc[p.name, "dimensions"].split()
            assert list(t.columns[:len(dims)]) == dims and len(t) == index.loc[p.name, "rows"]
            for col in t.columns:
                name = col[:-5] if col.endswith(("_real", "_imag")) and col[:-5] in ds else col
                if name in dims or name not in ds or ds[name].dims == ():
                    continue
                v = ds[name]
                idx = {d: (t[d].to_numpy() if d in ds.coords else t[d].to_numpy()) for d in v.dims}
                sel = v.sel({d: xr.DataArray(idx[d], dims="row") for d in v.dims if d in ds.coords})
                sel = sel.isel({d: xr.DataArray(idx[d], dims="row") for d in v.dims if d not in ds.coords})
                want = np.asarray(sel.values)
                if col.endswith("_real") and name != col:
                    want = want.real
                elif col.endswith("_imag") and name != col:
                    want = want.imag
                got = t[col].to_numpy()
                if want.dtype.kind in "fc":
                    np.testing.assert_array_equal(got.astype(float), want.astype(float), err_msg=f"{p.name}:{col}")
                elif want.dtype.kind == "b":
                    np.testing.assert_array_equal(got.astype(bool), want, err_msg=f"{p.name}:{col}")
                elif want.dtype.kind in "iu":
                    np.testing.assert_array_equal(got.astype(np.int64), want, err_msg=f"{p.name}:{col}")
                else:
                    np.testing.assert_array_equal(np.where(pd.isna(got), "", got).astype(str), want.astype(str),
                                                  err_msg=f"{p.name}:{col}")
        tree.close()
    # the command: same files; no temporary file left behind
    out = tmp_path / "cli"
    assert main(["export", str(basins_results.path), "--csv", str(out)]) == 0
    assert sorted(x.name for x in out.iterdir()) == sorted(
        x.name for x in (tmp_path / basins_results.path.parent.name).iterdir())


def test_poincare_of_a_period_one_orbit_against_the_shooting_solution(tmp_path):
    """Fig. 7 scene at Omega = 2 (a stable period-1 orbit): after the case's 400 transient
    periods the stroboscopic samples collapse to one point within 1e-8 (the period-1 orbit's
    multipliers, |mu| ~ 0.9 per period, leave ~1e-16 after 400 periods: 1e-8 is the bound
    asked), every impact lies at the phase of the shooting solution's impact (Newton on
    P(x) - x, models.orbits.continuation.start_point) to 1e-8 rad and with its velocity to 1e-8."""
    from vibeam.cli import main
    from vibeam.models.orbits.continuation import start_point

    sec = vibeam.poincare(FIG7, Omega=2.0, periods=32)
    assert sec.strobe_q.shape == (32,) and sec.period == 1
    assert np.ptp(sec.strobe_q) < 1e-8 and np.ptp(sec.strobe_dq) < 1e-8
    case = vibeam.load_case(FIG7)
    prob = shooting_problem(case.model_spec().scene(), "Omega")
    pt, why = start_point(prob, np.array([sec.strobe_q[0], sec.strobe_dq[0]]), 2.0, 1, 1.5, 2.5)
    assert pt is not None, why
    phase = np.mod(2.0 * np.asarray(pt.shot.impact_times), 2 * np.pi)
    assert phase.size == 1 and sec.impact_phase.size == 32
    np.testing.assert_allclose(sec.impact_phase, phase[0], atol=1e-8)
    np.testing.assert_allclose(sec.impact_velocity, abs(pt.shot.impact_velocities[0]), rtol=1e-8)
    np.testing.assert_allclose([sec.strobe_q[0], sec.strobe_dq[0]], pt.x, atol=1e-8)
    # physical units: mm and mm/s of the sensor
    rig = vibeam.poincare(ROOT / "cases" / "rig-neutral.toml", frequency_hz=15.0, periods=4)
    fx, fv = rig.scales
    assert fx == pytest.approx(180.0) and fv == pytest.approx(180.0 * 2 * np.pi * 7.6)
    assert rig.to_xarray()["impact_velocity"].attrs["units"] == "mm s-1"
    # the command writes the PNG (atomically, by the one figure writer)
    assert main(["poincare", str(FIG7), "--Omega", "2.0", "--periods", "8", "--out", str(tmp_path)]) == 0
    assert (tmp_path / "poincare_Omega2.png").stat().st_size > 0
    assert main(["poincare", str(FIG7), "--out", str(tmp_path)]) == 2
    _close_all()


def test_derive_and_modes_need_no_cli_helper():
    """vibeam.derive / vibeam.modes: the rows and modes of vibeam.case.beamscene, and against the
    paper's static-mode formulas and LAPACK (independent oracles); an SDOF case is refused in one
    line."""
    from vibeam.case.beamscene import derive as bs_derive, modes_report

    case = vibeam.load_case(ROOT / "cases" / "rig-fe-tight.toml")
    d = vibeam.derive(case)
    assert d.rows == bs_derive(case)["rows"] == bs_derive(case.model_spec())["rows"]
    assert "[model]" in d.sdof_case_text and vibeam.load_case(d.sdof_case_text).model_spec().fidelity == "sdof"
    m = vibeam.modes(case, n=3)
    np.testing.assert_array_equal(m.modes.frequencies_hz, modes_report(case.model_spec(), 3)["modes"].frequencies_hz)
    # independent of those helpers: the static-mode rows against paper Eqs. 42-46 written out
    # here (the calibrated EI and rho A as input; the case's m, positions, beta, gain, V, gap), to
    # 1e-9 relative (f_1 = 7.6 Hz is the calibration's target, reached to ~5e-12; the rest is
    # round-off), and the modes: f_1, f_2 the calibration's targets, f_3 LAPACK's (the FE
    # matrices' inverse problem M v = K v / omega^2 by scipy.linalg.eigh), to 1e-9
    import scipy.linalg
    from scipy.integrate import quad

    row = {r[0]: float(r[1]) for r in d.rows}
    L, xm, xs, mass, beta, f1 = 0.18, 132.0 / 180.0, 100.0 / 180.0, 0.2, 0.017, 7.6

    def y(u):
        return u * u * (3 * xm - u) / 6 if u <= xm else xm * xm * (3 * u - xm) / 6

    phim = y(xm) / y(xs)
    EI, rhoA = row["EI"], row["rho A"]
    wn = np.sqrt(3 * EI / (mass * (xm * L) ** 3))       # K_S / M_S, beam mass excluded (Eqs. 45-46)
    D = 2 * beta / (2 * np.pi * f1)
    int_phi2 = quad(lambda u: (y(u) / y(xs)) ** 2, 0, xm, epsabs=0, epsrel=1e-13)[0] + \
        quad(lambda u: (y(u) / y(xs)) ** 2, xm, 1, epsabs=0, epsrel=1e-13)[0]
    want = {"phi(x_m)": phim, "M_S": mass * phim ** 2, "K_S": wn ** 2 * mass * phim ** 2, "omega_n": wn,
            "f_n": wn / (2 * np.pi), "D": D, "beta_S": D * wn / 2, "gamma~": 3.78e-4 * phim * L,
            "gamma": 3.78e-4, "B": 3.78e-4 * 0.6, "Delta_C": -0.1 * phim, "Delta_G": -0.1, "Delta": -0.1 / 180.0,
            "f_n with beam mass": np.sqrt(wn ** 2 * mass * phim ** 2 / (mass * phim ** 2 + rhoA * L * int_phi2))
            / (2 * np.pi)}
    for k, v in want.items():
        assert row[k] == pytest.approx(v, rel=1e-9), k
    nd = m.fe.K.shape[0]
    mu = scipy.linalg.eigh(m.fe.M, m.fe.K, eigvals_only=True, subset_by_index=[nd - 3, nd - 1])[::-1]
    np.testing.assert_allclose(m.modes.frequencies_hz, 1 / np.sqrt(mu) / (2 * np.pi), rtol=1e-9)
    np.testing.assert_allclose(m.modes.frequencies_hz[:2], [7.6, 98.75], rtol=1e-9)
    with pytest.raises(CaseError, match="'model.fidelity' = 'sdof'.*needs a beam scene"):
        vibeam.derive(FIG7)
    with pytest.raises(ValueError, match="n = 0"):
        vibeam.modes(case, n=0)


def test_regress_and_cost_return_result_objects(tmp_path):
    """vibeam.regress of the quick Fig. 7 run against its reference passes (as `vibeam regress`);
    vibeam.cost of a one-point SDOF case gives one row per run and writes cost.h5 with out."""
    r = vibeam.regress(FIG7, ROOT / "tests" / "references" / "paper-fig7.h5", quick=True, jobs=1)
    assert r.ok and r.rows and all(row.points > 0 for row in r.rows)
    small = SMALL.replace("Omega = [1.8, 2.2, 5]", "Omega = [2.0, 2.0, 1]")
    c = vibeam.cost(small, repeats=1, jobs=1, out=tmp_path)
    assert {row.run for row in c.rows} >= {"exact"} and c.paths["h5"].is_file()
    assert "run" in c.to_xarray()
    _close_all()


COMMANDS = ["run", "continue", "map", "basins", "regress", "cost", "derive", "modes", "fit", "export", "poincare",
            "bench"]


@pytest.mark.parametrize("cmd", COMMANDS)
def test_every_command_help_has_an_example(cmd, capsys):
    from vibeam.cli import main

    with pytest.raises(SystemExit) as e:
        main([cmd, "--help"])
    assert e.value.code == 0
    text = capsys.readouterr().out
    assert "Example:" in text and f"vibeam {cmd} " in text.split("Example:")[1]
    if cmd == "regress":
        assert "worker processes" in text.split("--jobs JOBS")[-1]


def test_every_public_command_is_in_the_api():
    for name in ("derive", "modes", "regress", "cost", "fit", "continuation", "export", "poincare", "run",
                 "simulate", "open_results", "basins", "load_case"):
        assert callable(getattr(vibeam, name)), name


def test_a_script_beside_a_vibeam_folder_imports_the_package_with_P(tmp_path):
    """README (a): a script run from a folder holding a ``vibeam/`` folder (the clone's parent,
    issue 56 item 9) imports the installed package with ``python -P`` (and ``PYTHONSAFEPATH=1``),
    in a child process started there.  Without it, an editable install loses to the folder:
    setuptools' finder is asked after Python's path search, which makes the folder an empty
    namespace package (setuptools#3557; its strict and compat modes do not serve the
    package-dir mapping of models/ from inside the clone) -- the limit README states."""
    (tmp_path / "vibeam").mkdir()
    (tmp_path / "s.py").write_text("import vibeam\nprint(vibeam.__file__)\nprint(vibeam.open_results.__name__)\n")
    run = lambda *args, **env: subprocess.run([sys.executable, *args, "s.py"], cwd=tmp_path, capture_output=True,
                                              text=True, timeout=600, env={**__import__("os").environ, **env})
    for p in (run("-P"), run(PYTHONSAFEPATH="1")):
        assert p.returncode == 0, p.stderr[-2000:]
        where, name = p.stdout.split()
        assert name == "open_results" and Path(where).name == "__init__.py" and tmp_path not in Path(where).parents
    if Path(vibeam.__file__).resolve().is_relative_to(ROOT):       # an editable install: the limit
        p = run()
        assert p.returncode != 0 and "has no attribute 'open_results'" in p.stderr
    readme = (ROOT / "README.md").read_text()
    assert "`python -P`" in readme and "empty namespace package" in readme
