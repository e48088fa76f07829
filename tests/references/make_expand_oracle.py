"""Record what the shorthand ``[model]`` spec classes built, for ``tests/test_expand.py``.

Issue 58 deletes the shorthand spec classes (``SDOFModelSpec``, ``BeamModelSpec``, which read
``fidelity = "sdof"`` / ``"beam"`` tables directly, with ``vibeam.case.contact.stops_as_keys`` for
``[[model.stop]]``): a shorthand table is validated by its expansion (``vibeam.case.expand``) with
the canonical specs.  ``tests/test_expand.py`` compared the two paths in one process; this script
ran ONCE, on the last commit that had the old classes, and wrote what the old path produced into
``tests/references/expand_oracle.npz``, which the test now compares the canonical path against:

- for every shipped case, every ``[[run]]`` override and the ends of its ``[map]`` (the tables as
  ``model_with`` makes them), the shuffled ``[[model.stop]]`` table of the stop-order test, and the
  test's own tables (two-sided, compliant, mixed, physical, stop tables in any order);
- per table: the table itself (the lookup key), the shorthand's names read on the spec
  (``beta``, ``R``, ``contact``, ...), ``physical``, ``two_sided``, ``mixed_stops``, ``fidelity``,
  ``dofs()``, ``stiffness_key()``, a beam's point stop tables, an SDOF's continuation parameters
  (``native_parameter``: the value or the message), and the built model packed as the kernels read
  it (``_packed`` of the test: ``KernelSystem``, ``KernelStops``, ``HeldSets``, the modal system,
  the output codes, units and initial state).

Arrays are stored as they were (dtype, shape, bits: the test compares them bit for bit); every
other value as JSON with its type name (floats exactly: ``repr`` round-trips).  It cannot be run
again after the deletion (the classes are gone); it is kept as the record of how the oracle was made.

Run: ``python tests/references/make_expand_oracle.py``.
"""
from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
from pydantic import BaseModel

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))

OUT = HERE / "expand_oracle.npz"
#: the continuation parameters the test asks an SDOF spec for
NATIVE_KEYS = ("Omega", "B", "Delta", "R", "beta", "voltage", "gain", "gap_mm", "damping_ratio", "R_lower",
               "Delta_lower", "gap_lower_mm")


def table_key(table: dict) -> str:
    """The lookup key of a ``[model]`` table: its JSON with sorted keys."""
    return json.dumps(table, sort_keys=True)


def encode(v, arrays: dict):
    """``v`` as JSON with its type name; an array stored once in ``arrays`` (by its dtype, shape
    and bytes) and referred to by its index."""
    if isinstance(v, np.ndarray):
        if v.dtype == object:
            raise TypeError(f"object array: {v!r}")
        i = arrays.setdefault((v.dtype.str, v.shape, v.tobytes()), len(arrays))
        return {"t": "ndarray", "v": i}
    if isinstance(v, BaseModel):
        return {"t": type(v).__name__, "v": encode(v.model_dump(), arrays)}
    if isinstance(v, dict):
        return {"t": "dict", "v": {str(k): encode(w, arrays) for k, w in v.items()}}
    if isinstance(v, (tuple, list)):
        return {"t": type(v).__name__, "v": [encode(w, arrays) for w in v]}
    if isinstance(v, float):
        return {"t": "float", "v": float(v)}
    if isinstance(v, np.generic):
        return {"t": type(v).__name__, "v": v.item()}
    if v is None or isinstance(v, (bool, int, str)):
        return {"t": type(v).__name__, "v": v}
    raise TypeError(f"cannot record {type(v).__name__}: {v!r}")


def record(table: dict, old, packed: dict, arrays: dict) -> dict:
    """What the test compares, of the shorthand spec ``old`` of ``table`` and its model."""
    names = [k for k in type(old).model_fields if k not in ("fidelity", "stop")]
    entry = {"table": table,
             "names": {k: encode(getattr(old, k), arrays) for k in names},
             "hooks": {k: encode(getattr(old, k), arrays) for k in ("physical", "two_sided", "mixed_stops",
                                                                   "fidelity")},
             "dofs": encode(old.dofs(), arrays), "stiffness_key": encode(old.stiffness_key(), arrays),
             "packed": {k: encode(v, arrays) for k, v in packed.items()}}
    if old.fidelity == "beam":
        entry["point_stops"] = encode([s.model_dump() for s in old.stop or ()], arrays)
    if old.fidelity == "sdof":
        native = {}
        for k in NATIVE_KEYS:
            try:
                native[k] = {"ok": encode(old.native_parameter(k), arrays)}
            except ValueError as e:
                native[k] = {"err": str(e)}
        entry["native"] = native
    return entry


def main() -> None:
    import test_expand as t
    from vibeam.api.cases import load_case
    from vibeam.case.contact import model_with
    from vibeam.case.schema import MODEL_SPECS

    tables = []                              # (label, table)
    for path in t.CASES:
        case = load_case(path)
        for label, overrides in t._variants(case):
            table = model_with(case.model, overrides)
            if "fidelity" in table:
                tables.append((f"{path.stem}: {label}", table))
    tip = load_case(next(p for p in t.CASES if p.stem == "rig-fe-tip-stop")).model
    stops = tip["stop"]
    tables.append(("rig-fe-tip-stop: shuffled", dict(tip, stop=[stops[1], {"side": "lower", "gap_mm": 0.5, "R": 0.6},
                                                                 stops[0]])))
    tables += list(t._TABLES.items())

    arrays, entries, seen = {}, {}, set()
    for label, table in tables:
        key = table_key(table)
        if key in seen:                      # the same table twice (a run without overrides)
            continue
        seen.add(key)
        old = MODEL_SPECS[table["fidelity"]].model_validate(table)
        old.check("model")
        entries[key] = dict(record(table, old, t._packed(old.build()), arrays), label=label)
        print(label, flush=True)
    meta = json.dumps({"entries": list(entries.values())}, sort_keys=True)
    stored = {f"a{i}": np.frombuffer(b, dtype=np.dtype(d)).reshape(shape) for (d, shape, b), i in arrays.items()}
    np.savez_compressed(OUT, meta=np.array(meta), **stored)
    print(f"{OUT}: {len(entries)} tables, {len(arrays)} arrays")


if __name__ == "__main__":
    main()
