"""Rewrite the metadata (``units``, ``long_name``) of the reference files' per-point outputs from
:func:`vibeam.io.results.describe`, the results writer's own rule; the data are not touched.

Run when the description of an output changed (issue 42 item 5: ``contact_force_max_n`` had
units ``1`` and long_name ``N``, ``amplitude_mean_mm`` the long_name ``at the sensor``,
``mode_amplitudes`` the units ``m kg0.5``, which UDUNITS reads as 0.5 m).  Only the variables of
``/runs/<run>`` and ``/maps/<run>`` named in :data:`vibeam.io.outputs.UNITS` or
:data:`vibeam.io.results.VARIABLES` are relabelled (a map's parameter coordinate keeps its label); every dataset's values are compared before
and after (exactly, NaN = NaN).  Usage::

    python tests/references/relabel.py            # every tests/references/*.h5
    python tests/references/relabel.py --check    # list what would change, change nothing
"""
from __future__ import annotations

import sys
from pathlib import Path

import h5py
import numpy as np

HERE = Path(__file__).resolve().parent


def _text(v):
    return v.decode("utf-8") if isinstance(v, bytes) else (None if v is None else str(v))


def _values(f) -> dict:
    out = {}
    f.visititems(lambda n, o: out.__setitem__(n, o[()]) if isinstance(o, h5py.Dataset) else None)
    return out


def relabel(path: Path, write: bool = True) -> list:
    """The changes ``(dataset, attribute, old, new)`` of one file (made when ``write``)."""
    from vibeam.io.outputs import UNITS
    from vibeam.io.results import VARIABLES, describe

    changes = []
    with h5py.File(path, "r+" if write else "r") as f:
        before = _values(f)
        for top in ("runs", "maps"):
            for g in f.get(top, {}).values():
                physical = "frequency_hz" in g
                mapped = _text(g.attrs.get("parameter"))     # a map's parameter keeps its own label
                for name, ds in g.items():
                    if not isinstance(ds, h5py.Dataset) or (name not in UNITS and name not in VARIABLES) \
                            or name == mapped:
                        continue
                    u, ln = describe(name, physical)
                    new = {"long_name": ln}
                    if "units" in ds.attrs:          # text variables have none
                        new["units"] = u
                    for k, v in new.items():
                        if _text(ds.attrs.get(k)) != v:
                            changes.append((ds.name, k, _text(ds.attrs.get(k)), v))
                            if write:
                                ds.attrs[k] = v
        if write:
            after = _values(f)
            assert before.keys() == after.keys(), path
            for k in before:
                a, b = np.asarray(before[k]), np.asarray(after[k])
                assert a.shape == b.shape and (np.array_equal(a, b, equal_nan=True) if a.dtype.kind in "fc"
                                                else (a == b).all()), (path, k)
    return changes


if __name__ == "__main__":
    check = "--check" in sys.argv[1:]
    for p in sorted(HERE.glob("*.h5")):
        for c in relabel(p, write=not check):
            print(p.name, *c, sep=" | ")
