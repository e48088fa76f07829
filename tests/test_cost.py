"""`vibeam cost`: the work-precision table is measured, stored and compared with the paper."""
import json

import h5py
import numpy as np

from vibeam.case import parse_case
from vibeam.cli import main
from vibeam.cost import run_cost

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
    # averaging has no time integration: much faster than direct
    assert by["averaging"][0].time_s < ladder[0].time_s
    claims = {c["claim"].split(":")[0]: c for c in res["claims"]}
    assert "averaging" in claims
    assert any("R = 0.6" in c["claim"] for c in res["claims"])


def test_cost_cli_writes_table_and_plot(tmp_path):
    path = tmp_path / "c.toml"
    path.write_text(CASE.replace("METHOD", "ivanov"))
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
    assert (tmp_path / "work_precision.png").stat().st_size > 1000
