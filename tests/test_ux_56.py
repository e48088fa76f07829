"""What a careful new user still tripped on (issue 56, section 3, items 2, 3, 5, 6 and 10).

Each test failed before its fix.  Oracles are independent of the code under test: the streams a
command writes (captured), the files it leaves (listed), the results file read back with h5py-backed
readers, numbers recomputed here with numpy, and the figures' matplotlib artists and texts (colours,
legend entries, axis labels, tick-label bounding boxes) -- never pixels.
"""
from __future__ import annotations

import re
import types
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402
import pytest  # noqa: E402
from matplotlib.collections import PolyCollection  # noqa: E402
from matplotlib.colors import to_hex, to_rgb, to_rgba  # noqa: E402

from vibeam.cli import main  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
CASES = ROOT / "cases"

#: a physical SDOF rig scene on 3 frequencies, both directions (a sweep of a few hundred ms)
TINY = """
name = "tiny"
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
frequency_hz = [14.0, 17.0, 3]
direction = "both"
transient_periods = 30
record_periods = 8
"""
RUN = '[[run]]\nname = "{name}"\nmethod = "event"\n'
#: the Fig. 7 scene with a gap, continued from the low end of a 3-point range
CONT = """
name = "cont"
[model]
fidelity = "sdof"
beta = 0.015
B = 0.5e-3
R = 0.9
Delta = 0.7e-3
[sweep]
Omega = [1.5, 2.5, 3]
direction = "both"
transient_periods = 300
record_periods = 16
[[run]]
name = "branches"
method = "continuation"
start_at = "low"
"""


def _write(folder: Path, name: str, text: str) -> Path:
    p = folder / name
    p.write_text(text)
    return p


def _close(fig):
    plt.close(fig)


def _colour_distance(a, b) -> float:
    return float(np.linalg.norm(np.subtract(to_rgb(a), to_rgb(b))))


# ============================================================================ item 2: --quiet, --no-plots
def test_quiet_run_map_continue_and_regress_say_nothing(tmp_path, capsys):
    """`run`, `continue`, `map` and `regress` --quiet printed `[tiny] 1 run(s), 2 sweep lines, 6
    points` (and the lines about compiling kernels) on standard error: now both streams stay empty
    and the files are written; without --quiet the header is there (what --quiet drops)."""
    case = _write(tmp_path, "tiny.toml", TINY + RUN.format(name="exact"))
    mapped = _write(tmp_path, "map.toml", TINY.replace('name = "tiny"', 'name = "tinymap"')
                    + '[map]\nparameter = "R"\nvalues = [0.6, 0.8, 2]\n' + RUN.format(name="exact"))
    cont = _write(tmp_path, "cont.toml", CONT)
    quiet = ["--jobs", "1", "--quiet", "--no-plots"]
    capsys.readouterr()
    for argv, made in ((["run", str(case), "--out", str(tmp_path / "r")], tmp_path / "r" / "results.h5"),
                       (["map", str(mapped), "--out", str(tmp_path / "m")], tmp_path / "m" / "results.h5"),
                       (["continue", str(cont), "--out", str(tmp_path / "c")], tmp_path / "c" / "results.h5"),
                       (["regress", str(case), "--reference", str(tmp_path / "r" / "results.h5"),
                         "--out", str(tmp_path / "g")], tmp_path / "g" / "results.h5")):
        assert main(argv + (quiet if argv[0] != "regress" else quiet[:-1])) == 0, argv    # regress draws no plot
        cap = capsys.readouterr()
        assert cap.err == "" and cap.out == "", (argv[0], cap.err, cap.out)
        assert made.is_file(), argv
    # the control: without --quiet the run's header is on standard error
    assert main(["run", str(case), "--out", str(tmp_path / "r2"), "--jobs", "1", "--no-plots"]) == 0
    assert "[tiny] 1 run(s), 2 sweep lines, 6 points" in capsys.readouterr().err


def test_quiet_keeps_an_error_on_one_line(tmp_path, capsys):
    case = _write(tmp_path, "tiny.toml", TINY + RUN.format(name="exact"))
    (tmp_path / "a_file").write_text("x")
    assert main(["run", str(case), "--out", str(tmp_path / "a_file"), "--jobs", "1", "--quiet"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("vibeam: error: ") and "a_file" in err, err


def test_no_plots_is_taken_by_modes_poincare_and_cost(tmp_path, capsys):
    """`modes`, `poincare` and `cost` write PNGs but refused --no-plots (exit 2): now they take it
    and write no PNG -- modes keeps modes.vtu, cost keeps cost.h5, poincare writes nothing."""
    case = _write(tmp_path, "tiny.toml", TINY + RUN.format(name="exact"))
    out = tmp_path / "modes"
    assert main(["modes", str(CASES / "rig-fe-tight.toml"), "-n", "2", "--out", str(out), "--no-plots"]) == 0
    assert sorted(p.name for p in out.iterdir() if not p.name.startswith(".")) == ["modes.vtu"]
    out = tmp_path / "poincare"
    assert main(["poincare", str(case), "--frequency-hz", "15", "--periods", "8", "--transient", "30",
                 "--out", str(out), "--no-plots"]) == 0
    assert not out.exists()
    assert "stroboscopic: 8 samples" in capsys.readouterr().out
    out = tmp_path / "cost"
    assert main(["cost", str(case), "--repeats", "1", "--jobs", "1", "--out", str(out), "--no-plots", "--quiet"]) == 0
    names = sorted(p.name for p in out.iterdir() if not p.name.startswith("."))
    assert "cost.h5" in names and not any(n.endswith(".png") for n in names), names
    # the same commands without --no-plots write their figures (the option is what drops them)
    assert main(["modes", str(CASES / "rig-fe-tight.toml"), "-n", "2", "--out", str(tmp_path / "m2")]) == 0
    assert (tmp_path / "m2" / "modes.png").is_file()


# ============================================================================ item 3: export
PORTABLE = re.compile(r"^[A-Za-z0-9._-]+$")


def test_exported_file_names_are_portable_and_index_names_each_run(tmp_path):
    """`runs.static mode (SDOF)@direction-Omega-harmonic.csv`: spaces, parentheses and '@' in file
    names.  Now every name is in A-Z a-z 0-9 . _ - (POSIX's portable set), unique also without
    regard to case, and index.csv gives each file's run by its own name."""
    out = tmp_path / "csv"
    assert main(["export", str(ROOT / "tests" / "references" / "rig-fe-tight.h5"), "--csv", str(out)]) == 0
    names = [p.name for p in out.iterdir()]
    bad = [n for n in names if not PORTABLE.match(n)]
    assert not bad, bad
    assert len({n.lower() for n in names}) == len(names)
    index = pd.read_csv(out / "index.csv", keep_default_na=False)
    assert "run" in index.columns
    runs = index[index["group"].str.startswith("runs/")]
    assert set(runs["run"]) == {"FE 1 mode", "FE 2 modes", "FE 4 modes", "FE all modes", "static mode (SDOF)"}
    for _, row in runs.iterrows():
        assert row["group"] == f"runs/{row['run']}", row
    assert set(index.loc[~index["group"].str.startswith("runs/"), "run"]) == {""}      # /reference: no run


def test_run_names_that_differ_only_in_their_odd_characters_keep_their_own_files(tmp_path):
    """Run names `a b`, `a+b`, `a (b)` and `(a b)` (distinct plot file names, so a valid case) all
    become `a_b` in the portable set: each table still gets a file of its own (a suffix -2, -3, ...),
    and index.csv says which run each file holds."""
    names = ["a b", "a+b", "a (b)", "(a b)"]
    text = TINY + "".join(f'[[run]]\nname = "{n}"\nmethod = "event"\n[run.model]\nR = {0.6 + 0.05 * i}\n'
                          for i, n in enumerate(names))
    case = _write(tmp_path, "c.toml", text)
    assert main(["run", str(case), "--out", str(tmp_path / "D"), "--jobs", "1", "--quiet", "--no-plots"]) == 0
    from vibeam.io.results import read_results

    stored = read_results(tmp_path / "D" / "results.h5")["runs"]
    csv = tmp_path / "csv"
    assert main(["export", str(tmp_path / "D" / "results.h5"), "--csv", str(csv)]) == 0
    index = pd.read_csv(csv / "index.csv", keep_default_na=False)
    assert all(PORTABLE.match(f) for f in index["file"]) and len({f.lower() for f in index["file"]}) == len(index)
    for n in names:
        rows = index[(index["run"] == n) & (index["dimensions"] == "direction Omega")]
        assert len(rows) == 1, (n, index)
        table = pd.read_csv(csv / rows["file"].iloc[0])
        np.testing.assert_array_equal(np.sort(table["amplitude"].to_numpy()), np.sort(stored[n]["amplitude"].ravel()))


def test_export_into_an_existing_file_is_one_line_and_exit_2(tmp_path, capsys):
    """`--csv` naming a file gave a bare `File exists`: now vibeam's one line naming --csv and the
    file, exit 2, and the file and its folder as they were."""
    f = tmp_path / "taken"
    f.write_text("mine\n")
    before = sorted(p.name for p in tmp_path.iterdir())
    rc = main(["export", str(ROOT / "tests" / "references" / "rig-fe-tight.h5"), "--csv", str(f)])
    err = capsys.readouterr().err
    assert rc == 2 and err.count("\n") == 1 and err.startswith("vibeam: error: --csv "), err
    assert str(f) in err and "not a folder" in err, err
    assert f.read_text() == "mine\n" and sorted(p.name for p in tmp_path.iterdir()) == before


# ============================================================================ item 5: the uncertainty table
def test_the_verdict_is_said_in_words():
    """The verdict line gave fractions without a conclusion.  verdict_text reads the figures: a
    median outside the other's band at more than a tenth of the points, or a median jump outside
    the other's 5-95 % spread, is a resolved difference; otherwise hidden by the scatter."""
    from vibeam.analysis.uncertainty import RESOLVED_FRACTION, verdict_text

    base = {"points": 62, "unit": "Hz", "outside_band_a_in_b": 0.0, "outside_band_b_in_a": 0.0,
            "jump_median_a": 16.35, "jump_band_a": [15.0, 17.0], "jump_median_b": 16.05, "jump_band_b": [14.5, 16.9]}
    assert verdict_text(base).startswith("model-form difference hidden by the scatter")
    assert verdict_text(dict(base, outside_band_b_in_a=RESOLVED_FRACTION + 0.01)) == \
        "model-form difference resolved (amplitude beyond the scatter of the sampled parameters)"
    assert "hidden" in verdict_text(dict(base, outside_band_a_in_b=RESOLVED_FRACTION))    # a tenth: not beyond
    jump = dict(base, jump_median_b=14.0, jump_band_b=[13.8, 14.2])
    assert verdict_text(jump) == "model-form difference resolved (jump frequency beyond the scatter of the sampled " \
                                 "parameters)"
    nojump = dict(base, jump_median_a=np.nan, jump_band_a=[np.nan, np.nan])
    assert "hidden" in verdict_text(nojump)                                          # jumps not compared
    assert verdict_text(dict(base, points=0, outside_band_a_in_b=np.nan, outside_band_b_in_a=np.nan)).startswith(
        "no conclusion")


def _result(name, amp, Omega):
    """An UncertaintyResult of given sampled amplitudes, shape (samples, 1, points): down sweep only."""
    from vibeam.analysis.uncertainty import UncertaintyResult

    n = amp.shape[0]
    return UncertaintyResult(name=name, parameters=("R",), design=np.linspace(0.7, 0.9, n)[:, None],
                             directions=("down",), Omega=Omega, amplitude=amp, period=np.ones(amp.shape, np.int64),
                             status=np.full(amp.shape, "ok", dtype=object))


def test_the_table_says_what_the_bands_are_the_jump_share_and_the_verdict(capsys):
    """Two runs of 8 samples on 6 frequencies: in `a` 6 of 8 samples jump (a drop of half the peak),
    in `b` 2 of 8.  The table now has a line saying what the quantiles and bands are, per run the
    share of samples that jump (75 %, 25 %: counted here from the amplitudes), and the verdict in
    words."""
    from vibeam.analysis.uncertainty import verdict
    from vibeam.api.uncertainty import print_uncertainty

    Om = np.linspace(1.0, 2.0, 6)
    rng = np.random.default_rng(3)
    smooth = 1.0 + 0.01 * rng.standard_normal((8, 1, 6))           # changes below 20 % of the peak
    a, b = smooth.copy(), smooth.copy() + 0.002
    a[:6, 0, 3:] *= 0.5                                             # 6 samples jump between points 3 and 4
    b[:2, 0, 3:] *= 0.5
    ra, rb = _result("a", a, Om), _result("b", b, Om)
    v = verdict([ra, rb])["a vs b"]
    assert v["jump_fraction_a"] == 6 / 8 and v["jump_fraction_b"] == 2 / 8       # what the file stores
    capsys.readouterr()
    print_uncertainty([ra, rb])
    out = capsys.readouterr().out
    assert "25-75 %" in out and "5-95 %" in out and "median (50 %)" in out, out
    assert re.search(r"a: 75 % of the samples jump in the down sweep", out), out
    assert re.search(r"b: 25 % of the samples jump in the down sweep", out), out
    line = next(x for x in out.splitlines() if x.strip().startswith("a vs b:"))
    assert "model-form difference" in line and ("hidden" in line or "resolved" in line), line


def test_readme_promises_sobol_indices_only_with_sobol_true():
    """The command table promised Sobol' indices, which the shipped case does not compute."""
    import tomllib

    line = next(x for x in (ROOT / "README.md").read_text().splitlines() if x.startswith("| `vibeam uncertainty"))
    assert "Sobol' indices with `sobol = true`" in line, line
    shipped = tomllib.loads((CASES / "rig-tight-uncertainty.toml").read_text())
    assert not shipped["uncertainty"].get("sobol", False)          # so the README must not promise them


# ============================================================================ item 6: figures
@pytest.fixture(scope="module")
def tight_basins():
    """The tight rig at 16.5 Hz on a 16 x 16 grid: the period-1 orbit and the sticking one (as
    tests/test_basins.py's 40 x 40), the labels checked by long simulation."""
    import vibeam

    r = vibeam.basins(str(CASES / "rig-tight.toml"), frequency_hz=16.5, grid=(16, 16))
    assert sorted(r.attractors["type"][0]) == ["period", "sticking"]
    return r


def test_basins_draw_each_attractor_in_its_colour_and_the_legend_gives_se_and_the_bound(tight_basins):
    """Every attractor was drawn in black.  Now each attractor's stroboscopic samples have a colour
    of their own (at least 0.3 apart in RGB), its basin's cells a tint of it, and its legend entry
    gives the basin fraction with its standard error (the result's numbers) on a swatch of both
    colours; a legend line gives the mislabel rate's upper bound."""
    from vibeam.analysis.attractors import basins_figure

    r = tight_basins
    fig = basins_figure(r)
    try:
        ax = fig.axes[0]
        dots = [l for l in ax.get_lines() if l.get_gid() == "attractor"]
        assert len(dots) == 2
        faces = [to_hex(l.get_markerfacecolor()) for l in dots]
        assert _colour_distance(*faces) >= 0.3 and all(_colour_distance(f, "k") >= 0.3 for f in faces), faces
        texts = [t.get_text() for t in fig.legends[0].get_texts()]
        for k in range(2):
            frac, se = 100 * r.attractors["fraction"][0, k], 100 * r.attractors["fraction_se"][0, k]
            want = f"{frac:.1f} ± {se:.1f} %"
            entry = next(t for t in texts if t.startswith(f"{k}: "))
            assert entry.endswith(want), (entry, want)
        rate, upper = r.mislabel_rate(0)
        assert np.isfinite(upper)
        assert any(f"at most {100 * upper:.1f} %" in t and "labels checked" in t for t in texts), texts
        # each attractor's entry shows its dots' colour on its basin's colour: the legend ties both
        entries = [h for h, t in zip(fig.legends[0].legend_handles, texts) if re.match(r"\d: ", t)]
        assert [to_hex(h.get_markerfacecolor()) for h in entries] == faces
        cmap = ax.images[0].get_cmap()
        for k, h in enumerate(entries):          # the image's value 3 + k is attractor k's basin
            assert to_hex(h.get_color()) == to_hex(cmap(ax.images[0].norm(3 + k)))
            assert _colour_distance(h.get_color(), faces[k]) >= 0.2     # the tint is lighter than the dots
        fig.canvas.draw()                         # the longer entries still fit in the figure
        lb, fb = fig.legends[0].get_window_extent(), fig.bbox
        assert lb.x0 >= fb.x0 and lb.x1 <= fb.x1 and lb.y0 >= fb.y0, (lb, fb)
    finally:
        _close(fig)


def _bands(names, n=64, unit="mm"):
    x = np.linspace(14.0, 17.0, 31)
    out = []
    for i, name in enumerate(names):
        med = 0.2 + 0.1 * i + 0.05 * np.sin(x)
        q = np.stack([med - 0.2, med - 0.1, med, med + 0.1, med + 0.2])[:, None, :].repeat(2, axis=1)
        out.append({"name": name, "x": x, "x_unit": "Hz", "directions": ["up", "down"], "q": q, "unit": unit,
                    "samples": n, "parameters": ["R", "gap_mm"]})
    return out


def test_uncertainty_bands_never_mix_and_the_legend_patches_are_the_bands(tmp_path):
    """uncertainty.png: the two runs' translucent bands overlapped into a colour of neither (brown),
    the legend's grey patches matched no band, the y label said 'amplitude Q (mm)', the sample count
    was missing and the subtitle said '[uncertainty]'.  Now no axes holds the bands of two runs;
    every legend patch has the face colour (with alpha) of a band drawn; the y label names the
    amplitude at the sensor U(L_S) in mm; the subtitle gives the 64 samples and their parameters."""
    from vibeam.plots.uncertainty import band_figure

    fig = band_figure(_bands(["static mode (SDOF)", "FE 4 modes"]), "rig: FRC bands")
    try:
        drawn = set()
        for ax in fig.axes:
            polys = [c for c in ax.collections if isinstance(c, PolyCollection)]
            if not polys:
                continue
            colours = {to_hex(c.get_facecolor()[0][:3]) for c in polys}
            assert len(colours) == 1, colours                          # one run's bands per axes
            drawn |= {tuple(np.round(c.get_facecolor()[0], 6)) for c in polys}
        assert len(drawn) == 4                                         # 2 runs x (50 %, 90 %)
        from matplotlib.patches import Patch

        legend = fig.legends[0]
        patches = [h for h in legend.legend_handles if isinstance(h, Patch)]
        assert len(patches) == 4
        assert {tuple(np.round(to_rgba(p.get_facecolor()), 6)) for p in patches} == drawn
        texts = [t.get_text() for t in legend.get_texts()]
        assert sum("50 % band (25-75 %)" in t for t in texts) == 2 and sum("90 % band (5-95 %)" in t for t in texts) == 2
        assert fig.axes[0].get_ylabel() == "amplitude at the sensor, $U(L_S)$ (mm)"
        sub = fig._suptitle.get_text().replace("\n", " ")
        assert "64 samples of R, gap_mm" in sub and "[uncertainty]" not in sub, sub
    finally:
        _close(fig)
    fig = band_figure(_bands(["exact"], n=16, unit="1"))
    try:
        assert fig.axes[0].get_ylabel() == r"amplitude $Q = \Delta - \min q$ (–)"
    finally:
        _close(fig)


def _two_sided_section(**kw):
    from vibeam.analysis.poincare import PoincareSection

    rng = np.random.default_rng(0)
    # the stroboscopic set of the two-sided Fig. 7 scene at Omega = 2.38 (issue 56): four clusters
    # between q = -0.0017 and -0.0002, whose ticks every 0.0002 ran together
    q = np.concatenate([rng.uniform(a, b, 16) for a, b in ((-0.00172, -0.0015), (-0.00103, -0.0009),
                                                            (-0.0006, -0.00045), (-0.00037, -0.00018))])
    stops = np.tile([0, 0, 1], 33)[:97]
    return PoincareSection(Omega=2.38, strobe_q=q, strobe_dq=rng.uniform(-0.001, 0.0025, 64),
                           impact_phase=rng.uniform(0, 6.28, 97), impact_velocity=rng.uniform(0, 0.003, 97),
                           period=0, name="two-sided", impact_stop=stops, **kw)


def test_poincare_tick_labels_stand_apart_and_each_stop_has_its_colour():
    """The two-sided Poincaré section: its x tick labels ran together (-0.0016-0.0014, 1.5 pixels
    apart) and impacts on both stops shared a colour.  Now neighbouring tick labels are at least a
    quarter em apart on both axes of both panels (their bounding boxes in the drawn figure, at the
    saved figure's 150 dpi), and the impact section has one colour per stop, named with its count."""
    from vibeam.analysis.poincare import poincare_figure

    p = _two_sided_section()
    fig = poincare_figure(p)
    try:
        fig.set_dpi(150)
        fig.canvas.draw()
        r = fig.canvas.get_renderer()
        for ax in fig.axes:
            for which in ("x", "y"):
                lo, hi = sorted(getattr(ax, f"get_{which}lim")())
                labels = [t for t in getattr(ax, f"get_{which}ticklabels")() if t.get_text()
                          and lo <= t.get_position()[0 if which == "x" else 1] <= hi]
                assert len(labels) >= 2, (which, [t.get_text() for t in labels])
                boxes = sorted((t.get_window_extent(r) for t in labels), key=lambda b: b.x0 if which == "x" else b.y0)
                em = labels[0].get_fontsize() * fig.dpi / 72.0
                for a, b in zip(boxes, boxes[1:]):
                    gap = b.x0 - a.x1 if which == "x" else b.y0 - a.y1
                    assert gap >= 0.25 * em, (which, gap, em, [t.get_text() for t in labels])
        impacts = [l for l in fig.axes[1].get_lines() if len(l.get_xdata())]
        assert len(impacts) == 2
        assert _colour_distance(impacts[0].get_color(), impacts[1].get_color()) >= 0.3
        texts = [t.get_text() for t in fig.axes[1].get_legend().get_texts()]
        assert texts == [f"upper stop ({int(np.sum(p.impact_stop == 0))} impacts)",
                         f"lower stop ({int(np.sum(p.impact_stop == 1))} impacts)"], texts
    finally:
        _close(fig)


def test_the_section_takes_each_impacts_stop_from_the_simulation():
    """section() keeps the simulation's stop of each impact (a trajectory's impact_stops): on the
    two-sided Fig. 7 scene at Omega = 2.38 both stops are hit, and the count on the lower stop is
    the trajectory's own n_impacts_lower."""
    import vibeam
    from vibeam.analysis.poincare import section

    sim = vibeam.simulate(str(CASES / "paper-fig7-two-sided.toml"), Omega=2.38, periods=32)
    sec = section(sim)
    assert sec.impact_stop is not None and set(sec.impact_stop.tolist()) == {0, 1}
    assert int(np.sum(sec.impact_stop == 1)) == int(sim.trajectory.n_impacts_lower)
    # a one-stop simulation: no stops recorded, one colour
    fake = types.SimpleNamespace(t=np.arange(8.0), q=np.zeros(8), dq=np.zeros(8), Omega=2.0, impact_times=[1.0],
                                 impact_velocities=[0.1], length_m=None, natural_frequency_hz=None, summary={},
                                 status="ok", trajectory=types.SimpleNamespace(samples_per_period=4, impact_stops=None))
    assert section(fake).impact_stop is None


def _continuation(statuses):
    from vibeam.analysis.branches import ContinuationResult

    branches = []
    for i, st in enumerate(statuses):
        p = np.linspace(1.6, 2.2 + 0.1 * i, 40)
        branches.append(dict(index=i, n=1 + i, status=st, message="", origin="start", bifurcations=[],
                             data={"parameter": p, "amplitude": 0.01 + 0.002 * i + 0.001 * np.sin(3 * p),
                                   "stable": p < 2.0}))
    return ContinuationResult(name="c", fidelity="sdof", parameter="Omega", settings={}, branches=branches,
                              starts=[], curves=[], status="ok", message="", wall_time_s=0.0)


def test_a_branch_that_ends_in_no_convergence_is_marked_at_its_end():
    """Branches that ended in no_convergence looked like branches that end.  Now the last point
    of each such branch carries a marker in a colour apart from every branch colour, named in the
    legend; a branch that ended otherwise (range_end) has none."""
    from vibeam.analysis.branches import continuation_figure

    r = _continuation(["no_convergence", "range_end"])
    fig = continuation_figure(r, [])
    try:
        ax = fig.axes[0]
        ends = [l for l in ax.get_lines() if l.get_gid() == "no_convergence"]
        assert len(ends) == 1
        d = r.branches[0]["data"]
        np.testing.assert_array_equal(ends[0].get_xdata(), [d["parameter"][-1]])
        np.testing.assert_array_equal(ends[0].get_ydata(), [d["amplitude"][-1]])
        branch_colours = {to_hex(l.get_color()) for l in ax.get_lines() if l.get_gid() != "no_convergence"}
        for c in branch_colours:
            assert _colour_distance(ends[0].get_markerfacecolor(), c) >= 0.5, c
        texts = [t.get_text() for t in fig.legends[0].get_texts()]
        assert any("no convergence" in t for t in texts), texts
    finally:
        _close(fig)
    fig = continuation_figure(_continuation(["range_end"]), [])
    try:
        assert not [l for l in fig.axes[0].get_lines() if l.get_gid() == "no_convergence"]
        assert not any("no convergence" in t.get_text() for t in fig.legends[0].get_texts())
    finally:
        _close(fig)


def test_the_fit_figure_gives_the_gain_its_unit():
    """fit.png said `gain = 5.4e-04 ± 2e-06` without a unit: now `1/V` (the result's UDUNITS `V-1`),
    and a nondimensional parameter (R) none."""
    from vibeam.identify.fit import FitResult, fit_figure

    x = np.linspace(14.0, 17.0, 6)
    res = object.__new__(FitResult)
    vals = dict(case_name="rig", run="exact", reference="m.csv", parameters=["gain", "R"], units=["V-1", "1"],
                estimate=np.array([5.4e-4, 0.68]), standard_error=np.array([2.1e-6, 0.012]), x_name="frequency_hz",
                y_name="amplitude_mm", x=x, y=0.1 * x, sigma=np.full(6, 0.005), direction=np.array(["up"] * 6),
                model=0.1 * x, model_spread=np.zeros(6), model_period=np.ones(6, int), residuals=np.zeros(6),
                sigma_given=True, reliable=True, notes=[])
    for k, v in vals.items():
        setattr(res, k, v)
    fig = fit_figure(res)
    try:
        sub = fig._suptitle.get_text().replace("\n", " ")
        assert "gain = 0.00054 ± 2.1e-06 1/V" in sub and re.search(r"R = 0\.68 ± 0\.012(;|,|$)", sub), sub
    finally:
        _close(fig)


# ============================================================================ item 10: bench on a busy machine
def _canned(points, speedup=20.0):
    return {"points": points, "periods_per_point": 500, "event_time_s": 0.1, "speedup_event_vs_direct": speedup,
            "error_ratio_direct_over_event": 1e6, "event_us_per_impact": 0.5, "event_impacts_per_second": 2e6,
            "event_us_per_impact_cpu": 0.5, "event_us_per_impact_every_period": 0.9, "recurrence_speedup": 1.8,
            "recurrence_outputs_identical": True}


@pytest.mark.parametrize("load, strict, code, word", [
    (5.0, False, 0, "NOT CHECKED"),      # load 5 on 2 cores (the machine): a timing cannot be judged
    (5.0, True, 1, "FAIL"),              # --strict judges it anyway
    (0.2, False, 1, "FAIL"),             # a quiet machine: the failed timing is a FAIL
])
def test_a_timing_goal_failed_on_a_busy_machine_is_not_checked(monkeypatch, capsys, load, strict, code, word):
    """`vibeam bench` on a machine with load 5 on 2 cores printed FAIL and exited 1 for a timing it
    could not judge.  With the load recorded (its JSON's `machine`), a failed timing goal is NOT
    CHECKED, the line saying the load; --strict keeps the FAIL; a goal that is not a timing (the
    error ratio) is judged whatever the load, and a timing that passes still passes."""
    import json

    from vibeam import bench

    monkeypatch.setattr(bench, "run_bench", lambda **kw: _canned(kw["points"]))
    monkeypatch.setattr(bench, "machine_state", lambda: {"cores": 2, "load_average": [load, load, load]})
    assert main(["bench", "--repeats", "1", *(["--strict"] if strict else [])]) == code
    cap = capsys.readouterr()
    line = next(x for x in cap.err.splitlines() if ">= 300x faster" in x)
    assert f": {word}  >= 300x faster" in line, line
    if word == "NOT CHECKED":
        assert "load average 5.0 before and 5.0 after" in line and "2 cores" in line and "--strict" in line, line
    data = json.loads(cap.out)
    assert data["machine"]["load_average_before"] == [load] * 3 and data["machine"]["cores"] == 2
    g = {x["goal"][:12]: x for x in data["goals"]}
    assert g[">= 300x fast"]["pass"] is (None if word == "NOT CHECKED" else False)
    assert g[">= 300x fast"]["timing"] is True
    assert g[">= 1000x sma"]["pass"] is True and "timing" not in g[">= 1000x sma"]       # judged at any load
    assert g["event sweep "]["pass"] is True                                            # a passing timing passes
    assert ("PASS  >= 1000x smaller" in cap.err)


def test_the_busy_rule_counts_the_benchmarks_own_process():
    """The rule on recorded loads: on 2 cores, load 1.6 before (+ the benchmark's own process: 2.6 >
    2.5) is busy, 1.4 before is not; a load after the benchmark counts its processes itself (2.4: not
    busy, 2.6: busy); no load average: never busy."""
    from vibeam.bench.common import busy_reason

    def m(b, a, cores=2):
        return {"cores": cores, "load_average_before": [b, b, b], "load_average_after": [a, a, a]}

    assert busy_reason(m(1.6, 0.0)) and not busy_reason(m(1.4, 0.0))
    assert not busy_reason(m(0.1, 2.4)) and busy_reason(m(0.1, 2.6))
    assert not busy_reason({"cores": 2, "load_average_before": None, "load_average_after": None})
    assert "1-minute load average 5.0 before and 5.0 after the benchmark on 2 cores" in busy_reason(m(5.0, 5.0))
