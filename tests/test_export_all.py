"""`vibeam export` round-trips every group of every shipped case (issue 42, item 1).

It crashed on every physical-unit results file (frequency_hz, on Omega only, broadcast against
(direction, Omega, harmonic)), exited 1 and left a partial set of CSVs without index.csv.  Here
every reference file of tests/references (the shipped cases' quick variants; the one case
without a reference, rig-fe-tight-continuation, writes the groups of rig-tight-continuation's
kind) is exported, and every CSV is read back and compared with the group's variables as xarray
reads them: the same numbers (NaN as empty cells), the same strings, one row per stored value.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest

REFS = sorted(Path("tests/references").glob("*.h5"))


@pytest.mark.parametrize("ref", REFS, ids=[p.stem for p in REFS])
def test_export_round_trips_every_group(tmp_path, ref):
    import vibeam
    from vibeam.cli import main

    out = tmp_path / "csv"
    assert main(["export", str(ref), "--csv", str(out)]) == 0
    index = pd.read_csv(out / "index.csv")
    assert len(index) == len(set(index["file"])) and len(index) > 0
    tree = vibeam.open_results(ref).tree()
    groups_with_data = {n.path.strip("/") for n in tree.subtree if n.to_dataset(inherit=False).data_vars}
    assert set(index["group"]) == groups_with_data
    for _, row in index.iterrows():
        table = pd.read_csv(out / row["file"], keep_default_na=False, na_values=[""])
        ds = tree[row["group"]].to_dataset()
        dims = str(row["dimensions"]).split() if isinstance(row["dimensions"], str) else []
        assert len(table) == int(row["rows"]) == int(np.prod([ds.sizes[d] for d in dims]) if dims else 1)
        for col in table.columns:
            name = col[:-5] if col.endswith(("_real", "_imag")) and col[:-5] in ds.variables else col
            if name in dims or name not in ds.variables:
                continue
            v = ds[name]
            want = np.broadcast_to(v.transpose(*[d for d in dims if d in v.dims]).values,
                                   [ds.sizes[d] for d in dims if d in v.dims]) if v.dims else np.asarray(v.values)
            if v.dims and tuple(d for d in dims if d in v.dims) != tuple(dims):
                continue                     # a coordinate on fewer dimensions: gathered (checked below)
            want = np.asarray(want).reshape(-1)
            got = table[col].to_numpy()
            if np.iscomplexobj(want):
                want = want.real if col.endswith("_real") else want.imag
            if want.dtype.kind in "fc" or (want.dtype.kind in "iub" and got.dtype.kind == "f"):
                np.testing.assert_allclose(got.astype(float), want.astype(float), rtol=1e-15, atol=0,
                                           equal_nan=True, err_msg=f"{ref.stem} {row['file']} {col}")
            elif want.dtype.kind in "iub":
                np.testing.assert_array_equal(got.astype(np.int64), want.astype(np.int64))
            else:
                assert [("" if isinstance(x, float) and np.isnan(x) else str(x)) for x in got] == \
                    [str(x) for x in want], (ref.stem, row["file"], col)
        if "frequency_hz" in table.columns and "Omega" in table.columns and "frequency_hz" in ds and \
                ds["frequency_hz"].dims == ("Omega",):
            f = dict(zip(ds["Omega"].values.tolist(), ds["frequency_hz"].values.tolist()))
            np.testing.assert_allclose(table["frequency_hz"], [f[o] for o in table["Omega"]], rtol=1e-15)


def test_a_failing_export_writes_no_file_and_one_line(tmp_path, monkeypatch, capsys):
    """A table that cannot be built (injected on the third) leaves no CSV behind: every table is
    built before any file is written; exit 2 and one line naming the file."""
    import vibeam.api.tables as api     # export's module (vibeam.api is a package of topics)
    from vibeam.cli import main

    real = api._tidy_tables
    calls = []

    def failing(*a, **k):
        for t in real(*a, **k):
            calls.append(1)
            if len(calls) == 3:
                raise ValueError("injected")
            yield t

    monkeypatch.setattr(api, "_tidy_tables", failing)
    ref = "tests/references/rig-fe-tight.h5"
    rc = main(["export", ref, "--csv", str(tmp_path / "csv")])
    err = capsys.readouterr().err
    assert rc == 2 and err.count("\n") == 1 and ref in err and "injected" in err, err
    assert not (tmp_path / "csv").exists() or not list((tmp_path / "csv").iterdir())
