"""Convert reference files of the first results layout to the netCDF layout (``vibeam_layout = 2``).

Run once when the results layout changed (vibeam.results): every per-point value
is read with the reader of the old layout and written by the one results writer,
then the two are compared dataset by dataset (exactly, NaN = NaN) before the file
is replaced; the numbers never change.  The original ``created`` time is kept.
Usage::

    python tests/references/convert_layout.py            # every tests/references/*.h5
"""
from __future__ import annotations

import sys
from pathlib import Path

import h5py
import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))


def _same(a, b, where=""):
    assert sorted(k for k in a if k != "attrs") == sorted(k for k in b if k != "attrs"), where
    for k in a:
        if k == "attrs":
            continue
        if isinstance(a[k], dict):
            _same(a[k], b[k], f"{where}/{k}")
            continue
        x, y = np.asarray(a[k]), np.asarray(b[k])
        assert x.shape == y.shape, (where, k)
        if x.dtype.kind in "fc":
            np.testing.assert_array_equal(x, y, err_msg=f"{where}/{k}")
        else:
            assert (x == y).all(), (where, k)


def convert(path: Path) -> bool:
    from make_references import reference_table
    from vibeam.results import layout_of, load_results, read_results, write_results

    if layout_of(path) >= 2:
        return False
    before = read_results(path)
    runs, maps, attrs = load_results(path)
    known = ("dropped_datasets", "transient_periods", "methods", "checks", "max_transient_periods")
    with h5py.File(path, "r") as f:
        ref = f["reference"]
        tp = ref["transient_periods"]
        table = reference_table(ref["dropped_datasets"].asstr()[()],
                                tp.asstr()[()] if h5py.check_string_dtype(tp.dtype) else int(tp[()]),
                                ref["methods"].asstr()[()], ref["checks"].asstr()[()],
                                int(ref["max_transient_periods"][()]) if "max_transient_periods" in ref else None)
        for k, d in ref.items():          # anything else in /reference is kept as it is
            if k not in known and isinstance(d, h5py.Dataset):
                table[k] = d.asstr()[()] if h5py.check_string_dtype(d.dtype) else d[()]
    tmp = path.with_suffix(".new.h5")
    write_results(tmp, runs, str(attrs["case_name"]), str(attrs["case_text"]), maps=maps,
                  case_json=str(attrs.get("case_json", "")), extra={"reference": table},
                  extra_attrs={"/": {"created": str(attrs["created"])}})
    after = read_results(tmp)
    for kind in ("runs", "maps"):
        assert sorted(before[kind]) == sorted(after[kind]), (path, kind)
        for name in before[kind]:
            _same(before[kind][name], after[kind][name], f"{path.name}:{kind}/{name}")
    with h5py.File(path, "r") as a, h5py.File(tmp, "r") as b:
        for k, d in a["reference"].items():
            x, y = d[()], b["reference"][k]
            y = y.asstr()[()] if h5py.check_string_dtype(y.dtype) else y[()]
            if h5py.check_string_dtype(d.dtype):
                x = d.asstr()[()]
            elif k == "transient_periods":
                x = str(x)                   # a number of the first layout, text ("3000" or "auto") now
            np.testing.assert_array_equal(np.asarray(x), np.asarray(y), err_msg=f"{path}: /reference/{k}")
    tmp.replace(path)
    return True


def main() -> int:
    for p in sorted(HERE.glob("*.h5")):
        print(f"{p.name}: {'converted' if convert(p) else 'already layout 2'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
