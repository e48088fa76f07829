"""``vibeam bench --map``: the throughput of a parameter map on 1 and 2 workers and the cost of
its checkpoint (:func:`run_map_bench`)."""
from __future__ import annotations

import contextlib
import io
import os
import statistics
import tempfile
import time
from pathlib import Path

import numpy as np

from vibeam.bench.common import goal, root
from vibeam.case.schema import load_case
from vibeam.runner import run_case


def run_map_bench(case_file: str | None = None, frequencies: int = 61, values: int = 8, repeats: int = 1,
                  log=None) -> dict:
    """Throughput of a parameter map on 1 and 2 local workers, and the cost of checkpointing.

    The map is the Fig. 18 scene of ``case_file`` (default ``cases/paper-fig18-tight.toml``:
    chatter, sticking and lift-off make its points uneven in cost, as in a real map) thinned
    to ``frequencies`` x ``values`` points per direction, run through
    :func:`vibeam.runner.run_case` as ``vibeam map`` runs it (each worker loads the numba
    kernels from the on-disk cache; a warm-up map fills that cache first).

    Returns
    -------
    dict
        ``points``, ``lines``; ``points_per_s`` for 1 and 2 workers (checkpointed) and their
        ratio ``speedup_2_workers``; ``checkpoint_cost_ratio`` = time with the line
        checkpoint / time without it (1 worker), with the number of checkpoint writes and
        the final file size.
    """
    path = Path(case_file) if case_file else root() / "cases" / "paper-fig18-tight.toml"
    base, text = load_case(path)
    data = base.model_dump()
    key = "frequency_hz" if base.sweep.frequency_hz is not None else "Omega"
    g = getattr(base.sweep, key)
    data["sweep"] = dict(data["sweep"], **{key: [g[0], g[1], frequencies]})
    data["map"] = dict(data["map"], values=[base.map.values[0], base.map.values[1], values])
    case = type(base).model_validate(data)
    say = log or (lambda m: None)

    def timed(jobs, checkpoint):
        ts = []
        for _ in range(repeats):
            with tempfile.TemporaryDirectory() as tmp:
                t0 = time.perf_counter()
                with contextlib.redirect_stdout(io.StringIO()):   # keep stdout for the JSON
                    m = run_case(case, text, tmp, jobs=jobs, quiet=True, plots=False, checkpoint=checkpoint)[0]
                ts.append(time.perf_counter() - t0)
                size = (Path(tmp) / "results.h5").stat().st_size
        return statistics.median(ts), m, size

    with tempfile.TemporaryDirectory() as tmp:   # warm-up: compile / fill the numba cache
        small = type(base).model_validate(dict(data, sweep=dict(data["sweep"], **{key: [g[0], g[1], 2]}),
                                               map=dict(data["map"], values=[base.map.values[0],
                                                                             base.map.values[0], 1])))
        with contextlib.redirect_stdout(io.StringIO()):
            run_case(small, text, tmp, jobs=1, quiet=True, plots=False)
    out = {"case": str(path), "frequencies": frequencies, "values": values,
           "directions": 2 if case.sweep.direction == "both" else 1, "repeats": repeats}
    n_pts = frequencies * values * out["directions"]
    n_lines = values * out["directions"]
    t_plain, _, _ = timed(1, False)
    say(f"map {n_pts} points, 1 worker, no checkpoint: {t_plain:.2f} s")
    t1, m, size = timed(1, True)
    say(f"map {n_pts} points, 1 worker, checkpoint: {t1:.2f} s")
    t2, m2, _ = timed(2, True)
    say(f"map {n_pts} points, 2 workers, checkpoint: {t2:.2f} s")
    same = all(np.array_equal(m.data[k], m2.data[k], equal_nan=m.data[k].dtype.kind == "f")
               for k in ("classification", "amplitude", "period"))
    out.update(points=n_pts, lines=n_lines, time_s={"1_worker": t1, "2_workers": t2, "1_worker_no_checkpoint": t_plain},
               points_per_s={"1_worker": n_pts / t1, "2_workers": n_pts / t2},
               speedup_2_workers=t1 / t2, checkpoint_cost_ratio=t1 / t_plain, checkpoint_writes=n_lines,
               results_file_kB=size / 1024, results_equal_1_and_2_workers=bool(same),
               cores=os.cpu_count())
    return out


def map_goals(out: dict) -> list:
    """Goals of :func:`run_map_bench` (README, "What it costs")."""
    g = [goal("the line checkpoint costs at most 10 % (1 worker)", f"ratio {out['checkpoint_cost_ratio']:.3f}",
              out["checkpoint_cost_ratio"] <= 1.10, timing=True),
         goal("1 and 2 workers give the same map, bit for bit", str(out["results_equal_1_and_2_workers"]),
              out["results_equal_1_and_2_workers"])]
    if (out.get("cores") or 1) >= 2:
        g.append(goal("2 workers at least 1.6x faster than 1 (2 cores)", f"{out['speedup_2_workers']:.2f}x",
                      out["speedup_2_workers"] >= 1.6, timing=True))
    return g
