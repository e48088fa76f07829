"""A shipped shorthand case and its canonical twin give the same results (issue 58, step 6b).

The twin of a case is its ``[model]`` table expanded into the canonical tables
(:func:`vibeam.case.expand.expand`: ``[model.system] builder``, ``[[model.stop]]``,
``[model.excitation]``) with the same sweep, runs, ``[map]`` and settings; its run overrides are
written as the paths they stand for (``Delta_lower`` -> ``stops[1].Delta``, ``n_modes`` ->
``system.n_modes``: :func:`vibeam.case.expand.alias`) or kept as the flat shorthand keys (aliases of
those paths on a canonical table).  ``vibeam run --quick``, ``vibeam continue`` (in Omega and in a
stop's number: ``stops[0].gap_mm``, ``stops[0].law.R``, ``stops[1].law.R``) and ``vibeam map
--quick`` must write the same arrays for both: bit for bit, because the two tables build the same
model bit for bit (tests/test_expand.py) and every command then runs the same arithmetic (the
tolerance is 0: any difference means one of the commands read the two tables differently).
"""
from __future__ import annotations

import copy
import json
import tomllib
from pathlib import Path

import h5py
import numpy as np
import pytest

from vibeam.case.expand import alias, expand
from vibeam.case.paths import get_value, path_of, set_value
from vibeam.case.schema import parse_case
from vibeam.cli import main

CASES = Path(__file__).resolve().parent.parent / "cases"


def _toml(d: dict, prefix: str = "") -> str:
    """TOML text of a case dict (tables, arrays of tables, inline tables for a run's overrides)."""
    def val(v):
        if isinstance(v, bool):
            return "true" if v else "false"
        if isinstance(v, str):
            return json.dumps(v)
        if isinstance(v, (list, tuple)):
            return "[" + ", ".join(val(x) for x in v) + "]"
        if isinstance(v, dict):
            return "{" + ", ".join(f"{json.dumps(k)} = {val(x)}" for k, x in v.items()) + "}"
        return repr(v)

    lines, tables = [], []
    for k, v in d.items():
        if isinstance(v, dict) and not (prefix.startswith("run") and k == "model"):
            tables.append((k, v))
        elif isinstance(v, list) and v and all(isinstance(x, dict) for x in v):
            tables.append((k, v))
        elif v is not None:
            lines.append(f"{k if k.isidentifier() else json.dumps(k)} = {val(v)}")
    out = "\n".join(lines) + "\n"
    for k, v in tables:
        name = f"{prefix}{k}"
        if isinstance(v, dict):
            out += f"\n[{name}]\n" + _toml(v, name + ".")
        else:
            for item in v:
                out += f"\n[[{name}]]\n" + _toml(item, name + ".")
    return out


def shipped(name: str, runs=None, **extra) -> dict:
    """The case dict of ``cases/<name>.toml`` (its runs cut to ``runs``, indices; ``extra`` keys
    replacing the case's)."""
    d = tomllib.loads((CASES / f"{name}.toml").read_text())
    if runs is not None:
        d["run"] = [d["run"][i] for i in runs]
    d.update(copy.deepcopy(extra))
    return d


def twin(data: dict, flat_overrides: bool = False) -> dict:
    """The canonical twin of shorthand case dict ``data`` (module docstring)."""
    d = copy.deepcopy(data)
    builder = data["model"]["fidelity"]
    d["model"] = expand(data["model"])
    assert "fidelity" not in d["model"] and d["model"]["system"]["builder"] == builder
    if not flat_overrides:
        for r in d["run"]:
            if r.get("model"):
                r["model"] = {alias(builder, k): v for k, v in r["model"].items()}
                assert None not in r["model"]
    return d


def _arrays(path: Path) -> dict:
    """Every dataset of a results file (attributes left out: they hold the case text)."""
    out = {}
    with h5py.File(path, "r") as f:
        f.visititems(lambda k, o: out.__setitem__(k, o[()]) if isinstance(o, h5py.Dataset) else None)
    return out


def _same_arrays(a: Path, b: Path) -> None:
    x, y = _arrays(a), _arrays(b)
    assert sorted(x) == sorted(y)
    n = 0
    for k in x:
        if "wall_time" in k or k.endswith("_s_per_point"):
            continue
        u, v = np.asarray(x[k]), np.asarray(y[k])
        assert u.shape == v.shape, k
        if u.dtype.kind in "fc":
            np.testing.assert_array_equal(u, v, err_msg=k)      # NaN == NaN; bit for bit
            n += u.size
        else:
            assert (u == v).all(), k
    assert n > 0


def _both(tmp_path, data: dict, cmd: list, **twin_kw) -> None:
    """``vibeam <cmd>`` on the shorthand case and on its twin: the same arrays."""
    out = {}
    for tag, d in (("short", data), ("canon", twin(data, **twin_kw))):
        f = tmp_path / f"{tag}.toml"
        f.write_text(_toml(d))
        assert main([cmd[0], str(f), *cmd[1:], "--out", str(tmp_path / tag), "--jobs", "1", "--quiet",
                     "--no-plots"]) == 0, tag
        out[tag] = tmp_path / tag / "results.h5"
    _same_arrays(out["short"], out["canon"])


# ----------------------------------------------------------------------------- vibeam run --quick
@pytest.mark.parametrize("name,runs", [("paper-fig7", None), ("rig-tight", None), ("paper-fig7-two-sided", [0, 1])])
def test_run_quick_of_twin_equals_shorthand(tmp_path, name, runs):
    _both(tmp_path, shipped(name, runs), ["run", "--quick"])


def test_run_overrides_as_flat_aliases_on_the_canonical_table(tmp_path):
    # [run.model] Delta, Delta_lower written as they are on the canonical table: aliases of
    # stops[0].Delta, stops[1].Delta
    _both(tmp_path, shipped("paper-fig7-two-sided", [1]), ["run", "--quick"], flat_overrides=True)


# ----------------------------------------------------------------------------- vibeam continue
def test_continue_in_omega_of_twin_equals_shorthand(tmp_path):
    _both(tmp_path, shipped("rig-tight-continuation", [1, 2]), ["continue"])


def test_continue_fe_rungs_of_twin_equals_shorthand(tmp_path):
    # two cheap rungs: the static mode and one FE mode ([run.model] n_modes -> system.n_modes)
    _both(tmp_path, shipped("rig-fe-tight-continuation", [0, 1]), ["continue"])


def test_continue_two_sided_of_twin_equals_shorthand(tmp_path):
    d = shipped("paper-fig7-two-sided", [3])
    d["run"][0]["max_points"] = 200
    _both(tmp_path, d, ["continue"])


RIG_PARAMETER_RUNS = [
    {"name": "in the gap", "method": "continuation", "parameter": "stops[0].gap_mm", "at": 16.5,
     "range": [-0.15, -0.05], "start_at": -0.1, "max_period": 1, "max_points": 60},
    {"name": "in R", "method": "continuation", "parameter": "stops[0].law.R", "at": 16.5,
     "range": [0.7, 0.9], "start_at": 0.8, "max_period": 1, "max_points": 60},
    {"name": "in the flat R", "method": "continuation", "parameter": "R", "at": 16.5,
     "range": [0.7, 0.9], "start_at": 0.8, "max_period": 1, "max_points": 60},
]


def test_continue_in_a_stops_number_of_twin_equals_shorthand(tmp_path):
    _both(tmp_path, shipped("rig-tight", run=RIG_PARAMETER_RUNS), ["continue"])


def test_continue_in_the_lower_stops_R_of_twin_equals_shorthand(tmp_path):
    run = {"name": "in R lower", "method": "continuation", "parameter": "stops[1].law.R", "at": 1.8,
           "range": [0.3, 0.9], "start_at": 0.6, "max_period": 1, "max_points": 60}
    d = shipped("paper-fig7-two-sided", run=[run])
    _both(tmp_path, d, ["continue"])
    # and the branch is not empty (the blocker: 0 branches on the canonical table)
    with h5py.File(tmp_path / "canon" / "results.h5", "r") as f:
        assert f["branches/in R lower/parameter"].size > 0


# ----------------------------------------------------------------------------- vibeam map --quick
@pytest.mark.parametrize("parameter", ["gap_mm", "stops[0].gap_mm"])
def test_map_quick_of_twin_equals_shorthand(tmp_path, parameter):
    # the map's axis is named as the case names its parameter: the same name in both files
    d = shipped("rig-map-gap")
    d["map"]["parameter"] = parameter
    _both(tmp_path, d, ["map", "--quick"])


# ----------------------------------------------------------------------------- the aliases
def test_flat_keys_are_aliases_of_paths_on_the_canonical_table():
    for name in ("paper-fig7-two-sided", "rig-tight", "rig-fe-tight-continuation"):
        d = shipped(name)
        short, canon = d["model"], expand(d["model"])
        case_short = parse_case(_toml(d), f'{name}.toml')
        case_canon = parse_case(_toml(twin(d)), f'{name}-canon.toml')
        # every flat key [map] may vary on the shorthand case may be varied on its twin, and
        # names the same number there
        allowed = case_canon.map_parameters()
        for k in case_short.map_parameters():
            assert k in allowed, (name, k)
            p = path_of(canon, k)
            if k in short:
                assert p is not None and get_value(canon, p) == short[k], (name, k)
                assert get_value(canon, k) == short[k]
        # a flat key set on the canonical table sets the path it stands for
        for k in ("R", "voltage", "B", "beta", "damping_ratio"):
            p = alias(canon["system"]["builder"], k)
            if p is not None and get_value(canon, p) is not None:
                assert case_canon.model_spec({k: 0.5}).model_dump() == case_canon.model_spec({p: 0.5}).model_dump()
                assert get_value(set_value(canon, p, 0.5), k) == 0.5
