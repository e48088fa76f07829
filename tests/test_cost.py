"""`vibeam cost`: the work-precision table is measured, stored and compared with the paper."""
import json

import h5py
import numpy as np
import pytest

from vibeam.case.schema import parse_case
from vibeam.cli import main
from vibeam.analysis.cost import run_cost
from vibeam.models.builders.sdof import sdof

CASE = """
name = "tiny-cost"
[model]
fidelity = "sdof"
beta = 0.015
B = 0.5e-3
R = 0.9
Delta = 0.0
[sweep]
Omega = [1.9, 2.1, 3]
transient_periods = 150
record_periods = 8
[[run]]
name = "exact"
method = "event"
[[run]]
name = "loose"
method = "METHOD"
rtol = 1e-3
atol = 1e-7
[[run]]
name = "avg"
method = "averaging"
"""


def test_cost_rows_errors_and_claims(tmp_path):
    # DOP853 keeps the tight end of the ladder cheap (RK23 at rtol 1e-10 takes a minute)
    case = parse_case(CASE.replace('method = "METHOD"', 'method = "direct"\nsolver = "DOP853"'))
    res = run_cost(case, ladder=True, repeats=1, log=lambda m: None)
    rows = res["rows"]
    assert res["reference_periods"] == 2000
    by = {}
    for r in rows:
        by.setdefault(r.method, []).append(r)
    # the event run with 150 transient periods is within the transient remainder
    # exp(-beta * 150 * 2 pi / 2.1) ~ 1e-3 of the reference (impacts damp more)
    assert by["event"][0].err_max < 1e-3
    # the ladder: five tolerances, error falls by orders of magnitude from the
    # loosest to the tightest (measured, not hidden)
    ladder = by["direct"]
    assert [r.settings["rtol"] for r in ladder] == [1e-3, 1e-4, 1e-6, 1e-8, 1e-10]
    assert ladder[-1].err_max < 1e-2 * ladder[0].err_max
    # averaging has no time integration (no timed assertion: its speed is the bench's figure): its
    # solver is not a time-domain one and its row has a time like every other
    from vibeam.models import make_solver

    assert not make_solver(sdof(beta=0.015, B=0.5e-3, Delta=0.0, R=0.9), "averaging").time_domain
    assert by["averaging"][0].time_s > 0 and by["averaging"][0].n_points == ladder[0].n_points
    claims = {c["claim"].split(":")[0]: c for c in res["claims"]}
    assert "averaging" in claims
    assert any("R = 0.6" in c["claim"] for c in res["claims"])


def test_cost_separates_the_method_error_from_the_transient_truncation():
    """A short transient (20 periods: exp(-0.015 * 20 * 2 pi / 2.1) ~ 0.4 of the start is left)
    makes the total error of every time-domain method about the same (the truncation), but
    against event with the same transient the methods differ by orders of magnitude: direct at
    rtol 1e-3 is far off, at rtol 1e-10 close; event itself is exact (0).  A slightly
    pre-stressed stop (Delta = -5e-4): the mass starts held on the stop, which both methods
    represent (at Delta = 0 it starts exactly at the stop, where the ODE methods cannot stick
    and their transient differs from event's at 7e-4 whatever the tolerance)."""
    text = CASE.replace("transient_periods = 150", "transient_periods = 20").replace(
        "Delta = 0.0", "Delta = -0.0005").replace('method = "METHOD"', 'method = "direct"\nsolver = "DOP853"')
    res = run_cost(parse_case(text), ladder=True, repeats=1, log=lambda m: None)
    (src,) = res["models"].values()
    assert src.transient_periods == 20 and src.transient_max > 1e-3      # the truncation is large...
    by = {(r.run, r.settings.get("rtol")): r for r in res["rows"]}
    ev, loose, tight = by[("exact", None)], by[("loose", 1e-3)], by[("loose", 1e-10)]
    assert ev.err_method_max == 0.0 and ev.against == "event, same transient"
    assert ev.err_max == pytest.approx(src.transient_max, rel=1e-12)     # ...and is all of event's total error
    # total errors of loose and tight alike (both carry the truncation), method errors far apart
    assert abs(np.log10(loose.err_max) - np.log10(tight.err_max)) < 1
    assert tight.err_method_max < 1e-3 * loose.err_method_max
    assert tight.err_method_max < 1e-2 * tight.err_max
    avg = by[("avg", None)]
    assert avg.against == "converged event" and avg.err_method_max == avg.err_max
    # each claim once, from the run's own settings (not each rung of the ladder)
    claims = [c["claim"] for c in res["claims"]]
    assert len(claims) == len(set(claims))


def test_cost_table_prints_full_settings_and_long_names(capsys):
    from vibeam.analysis.cost import CostRow, print_cost

    long = "a run name that is much longer than twenty-two characters"
    row = CostRow(run=long, method="direct", settings={"solver": "RK23", "rtol": 1e-4, "atol": 1e-07},
                  time_s=1.0, err_max=1e-3, err_rms=1e-4, n_period_diff=0, n_points=3, n_nonperiodic_ref=0,
                  time_rel_event=500.0, err_method_max=1e-4, err_method_rms=1e-5, against="event, same transient")
    print_cost({"rows": [row], "models": {}, "reference_periods": 2000, "transient_periods": 150,
                "claims": [dict(claim="c", measured="m", reproduced=True, why="")]})
    out = capsys.readouterr().out
    line = next(l for l in out.splitlines() if l.startswith(long))
    assert "solver=RK23, rtol=0.0001, atol=1e-07" in line and "atol=1.0" not in out
    assert out.count("  - c\n") == 1


def test_cost_cli_writes_table_and_plot(tmp_path):
    path = tmp_path / "c.toml"
    path.write_text(CASE.replace("METHOD", "ivanov"))
    from test_plots import check_work_precision_data, written_figures

    with written_figures() as figs:
        assert main(["cost", str(path), "--out", str(tmp_path), "--repeats", "1"]) == 0
    with h5py.File(tmp_path / "cost.h5") as f:
        methods = [m.decode() if isinstance(m, bytes) else m for m in f["cost/method"][()]]
        assert methods == ["event", "ivanov", "averaging"]
        assert np.all(f["cost/wall_time_s"][()] > 0)
        # every run has the same model: the time of each row over its ratio is the one timing of
        # the event solver it was divided by
        t, rel = f["cost/wall_time_s"][()], f["cost/time_relative_to_event"][()]
        assert np.all(rel > 0)
        np.testing.assert_allclose(t / rel, t[0] / rel[0], rtol=1e-12)
        # the exact run against its converged reference (150 vs 2000 transient periods): the
        # remaining transient exp(-0.015 * 150 * 2 pi / 2.1) < 1e-3 (impacts damp more)
        assert f["cost/error_max"][0] < 1e-3
        claims = [json.loads(c) for c in f["cost/claims"].asstr()[()]]
        assert all({"claim", "measured", "reproduced", "why"} <= set(c) for c in claims)
    # the figure written to work_precision.png (caught at save_figure: that file's figure) plots
    # cost.h5's times and errors, read back from its artists; the PNG is a valid image of its size
    # (its pixels are not compared: two renderings differed in 0.28 % of them once under load)
    check_work_precision_data(figs["work_precision.png"], tmp_path / "cost.h5")
    import matplotlib.image as mpimg

    img = mpimg.imread(tmp_path / "work_precision.png")
    w, h = figs["work_precision.png"].get_size_inches() * 150
    assert img.shape == (round(h), round(w), 4)
    # --quick and --jobs; the work-precision figure is labelled
    assert main(["cost", str(path), "--out", str(tmp_path / "q"), "--repeats", "1", "--quick", "--jobs", "2"]) == 0
    import xarray as xr

    with xr.open_dataset(tmp_path / "cost.h5", group="cost", engine="h5netcdf") as ds:
        assert ds["error_method_max"].dims == ("row",) and ds["wall_time_s"].attrs["units"] == "s"


def test_work_precision_figure_is_labelled():
    import matplotlib.pyplot as plt

    from test_plots import check_figure
    from vibeam.analysis.cost import work_precision_figure

    case = parse_case(CASE.replace("METHOD", "ivanov"))
    res = run_cost(case, repeats=1, log=lambda m: None)
    fig = work_precision_figure(res, "tiny", case)
    try:
        check_figure(fig, "work-precision")
        labels = [t.get_text() for t in fig.legends[0].get_texts()]
        assert any(l.startswith("loose (ivanov") for l in labels) and any("transient truncation" in l for l in labels)
        assert any(l.startswith("avg (averaging; vs converged)") for l in labels)
    finally:
        plt.close(fig)
