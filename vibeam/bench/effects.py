"""``vibeam bench --effects``: the cost of each scene effect on a rig sweep (:func:`run_effects_bench`)."""
from __future__ import annotations

import statistics
import time

import numpy as np

from vibeam.bench.common import goal, root
from vibeam.case.schema import EffectsSpec, load_case
from vibeam.engine.effects import wrap_solver
from vibeam.engine.sweep import Sweep, run_sweep
from vibeam.models import make_solver
from vibeam.models.scene import outputs


#: effects timed by :func:`run_effects_bench` (name, [effects] table, fidelities)
EFFECTS_BENCH = (
    ("platform filter", {"platform": {"frequency_hz": 3.25, "damping_ratio": 0.05}}, ("sdof", "beam")),
    ("platform coupled", {"platform": {"level": "coupled", "mass_kg": 2.0}}, ("beam",)),
    ("eccentric_impact", {"eccentric_impact": {"offset_mm": 5.0}}, ("beam",)),
    ("gap_drift table", {"gap_drift": {"table": [[14.0, 0.0], [15.0, 0.0], [15.2, 0.05], [17.0, 0.06]]}},
     ("sdof", "beam")),
    ("gap_drift sliding", {"gap_drift": {"law": "sliding", "slide_mm_per_impulse": 0.3, "max_drift_mm": 0.1}},
     ("sdof", "beam")),
    ("restitution_law", {"restitution_law": {"velocity_mm_s": [0.0, 30.0, 100.0, 150.0],
                                             "R": [0.85, 0.6, 0.75, 0.8]}}, ("sdof", "beam")),
)


def run_effects_bench(points: int = 61, transient: int = 400, record: int = 64, repeats: int = 3) -> dict:
    """Cost of each scene effect: a rig sweep (14-17 Hz, both directions, continuation,
    inline) of the SDOF scene ``rig-neutral`` and of the FE scene ``rig-fe-neutral`` with 2
    modes, plain and with each effect on; median of ``repeats`` after a warm-up, as ratios
    to plain.  Returns a JSON-ready dict."""
    cases = root() / "cases"
    scenes = {"sdof": ("rig-neutral.toml", None), "beam": ("rig-fe-neutral.toml", {"n_modes": 2})}
    out = {"points": points, "transient_periods": transient, "record_periods": record,
           "direction": "both", "repeats": repeats, "scenes": {}}
    for fid, (fname, over) in scenes.items():
        case, _ = load_case(cases / fname)
        spec = case.model_spec(over)
        scene = spec.scene()
        f_n = outputs(scene).natural_frequency_hz
        grid = np.linspace(case.sweep.frequency_hz[0], case.sweep.frequency_hz[1], points) / f_n
        sw = Sweep(Omega=grid, direction="both", transient_periods=transient, record_periods=record)

        def timed(effects):
            solver = wrap_solver(make_solver(scene, "event"), scene, spec, EffectsSpec.model_validate(effects), {})
            run_sweep(solver, Sweep(Omega=grid[:2], transient_periods=2, record_periods=2), jobs=1)  # warm-up
            ts = []
            for _ in range(repeats):
                t0 = time.perf_counter()
                run_sweep(solver, sw, jobs=1)
                ts.append(time.perf_counter() - t0)
            return statistics.median(ts)

        t_plain = timed({})
        row = {"case": fname + (f" (n_modes = {over['n_modes']})" if over else ""), "plain_time_s": t_plain,
               "time_s": {}, "ratio_to_plain": {}}
        for name, eff, fids in EFFECTS_BENCH:
            if fid not in fids:
                continue
            t = timed(eff)
            row["time_s"][name] = t
            row["ratio_to_plain"][name] = t / t_plain
        out["scenes"][fid] = row
    return out


def effects_goals(out: dict) -> list:
    """Goals of :func:`run_effects_bench`: no scene effect more than doubles the cost of a sweep
    (each changes the forcing, the gap, R or adds one DOF)."""
    return [goal(f"{fid}: '{name}' at most 2x the plain sweep", f"{r:.2f}x", r <= 2.0, timing=True)
            for fid, row in out["scenes"].items() for name, r in row["ratio_to_plain"].items()]
