"""A results file as tidy CSV tables, as ``vibeam export RESULTS.h5 --csv DIR``: :func:`export`."""
from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pandas as pd

from vibeam.api.results import open_results
from vibeam.case.arguments import check_path
from vibeam.errors import InputError
from vibeam.io.outdir import OutputLock, check_folder, check_output_file, replace_file
from vibeam.io.store import UNIT_PARENTS


def export(path, csv_dir) -> list:
    """Every group of a results file as tidy CSV files (``vibeam export RESULTS.h5 --csv DIR``).

    Long format: one row per point, the dimensions' coordinates as the first columns, one column
    per variable.  A group whose variables lie on several sets of dimensions (a run's per-point
    outputs on (direction, Omega), its strobe on (direction, Omega, record_period, state), ...)
    gives one file per set: ``<group>.csv`` for the set with most variables, else
    ``<group>__<dim>-<dim>.csv`` (``/`` in a group's path is ``.``).  File names are portable: only
    ``A-Z a-z 0-9 . _ -`` (:func:`portable_stem`: any other character of a run's name -- a space,
    parentheses, ``@``, a non-ASCII letter -- becomes ``_``, ``runs.static_mode_SDOF.csv`` for the
    run ``static mode (SDOF)``); where two tables would get one name (run names ``a`` and
    ``a.units``, ``a b`` and ``a_b``, names that differ only in case), the later one gets ``-2``,
    ``-3``, ... before ``.csv``, so every table has a file of its own.  ``index.csv`` lists each
    file once, with its group, the run's own name as written in the case (``run``; empty for a
    table that is not a run's), dimensions and rows.  Complex values are
    two columns ``<name>_real``, ``<name>_imag``.  Units and long names are in a sidecar
    ``<file>.units.csv`` (``column,units,long_name``; ``1`` is nondimensional).  Padding (NaN
    beyond a branch's ``n_points``) is kept as empty cells, so every row maps to one stored
    value.  Every table is built before any file is written; then each file goes to a
    temporary file, flushed and renamed (:func:`vibeam.io.outdir.replace_file`): a file is never
    left partial, and a results file that cannot be read in full writes no file at all.  The
    folder is held while the files are written (:class:`vibeam.io.outdir.OutputLock`): a folder
    another vibeam command writes into is refused in one line.

    Parameters
    ----------
    path : str or Path
        A results file (layout 2).
    csv_dir : str or Path
        Output folder (created if missing; a file there is refused).

    Returns
    -------
    list of Path
        The CSV files written (data files; each with its ``.units.csv``).

    Raises
    ------
    ValueError
        Not a results file of layout 2, or one whose structure vibeam refuses (links, data
        beyond the size bounds; :mod:`vibeam.io.h5check`): one line naming the file
        (:class:`vibeam.errors.InputError`); ``csv_dir`` names a file, or a folder that cannot
        be created or written (:class:`vibeam.errors.InputError`, naming ``--csv``).
    """
    csv_dir = check_path(csv_dir, "csv_dir", optional=False)
    folder = Path(csv_dir)
    if folder.exists() and not folder.is_dir():        # refused before the results file is read
        raise InputError(f"--csv {folder}: is a file, not a folder; give a folder for the CSV files (created "
                         f"if missing)")
    res = open_results(path)
    tree = res.tree()

    files, index, used = [], [], set()
    for node in tree.subtree:
        ds = node.to_dataset(inherit=False)
        if not ds.data_vars:
            continue
        group = node.path.strip("/")
        parts = group.split("/")
        run = parts[1] if len(parts) > 1 and parts[0] in UNIT_PARENTS else ""
        gname = ".".join(portable_stem(x) for x in parts)
        for stem, dims, table, units in _tidy_tables(node.to_dataset(), ds, gname):
            stem = _unique_stem(stem, used)
            files.append((f"{stem}.csv", table.to_csv(index=False)))
            files.append((f"{stem}.units.csv", units.to_csv(index=False)))
            index.append((f"{stem}.csv", group, run, " ".join(dims), len(table)))
    # what each file holds: its group in results.h5, the run's own name and its dimensions (the
    # coordinate columns)
    files.append(("index.csv", pd.DataFrame(index, columns=["file", "group", "run", "dimensions", "rows"])
                  .to_csv(index=False)))
    check_folder(folder, "--csv")
    written = []
    # the folder held as every writer holds its folder: never into one another vibeam command writes
    with OutputLock(folder, option="--csv"):
        for name, _ in files:
            check_output_file(folder / name)
        for name, text in files:
            p = replace_file(folder / name, text)
            if name != "index.csv" and not name.endswith(".units.csv"):
                written.append(p)
    return written


#: the longest file stem export writes (characters, all ASCII; file systems allow 255 bytes per name)
MAX_STEM_BYTES = 200


def portable_stem(name: str) -> str:
    """``name`` in the portable file-name characters ``A-Z a-z 0-9 . _ -`` (POSIX's portable
    filename character set): every run of other characters becomes one ``_``, and ``_`` at
    either end is dropped (``static mode (SDOF)`` -> ``static_mode_SDOF``); a name with none
    left is ``_``.  Not unique by itself: :func:`_unique_stem` makes the file names so."""
    out = re.sub(r"[^A-Za-z0-9._-]+", "_", str(name)).strip("_")
    return out if out.strip(".") else "_"


def _unique_stem(stem: str, used: set) -> str:
    """``stem`` made unique among ``used`` (and added to it), compared without regard to case (a
    file system that ignores it): no two tables share a data file, and no data file is another's
    ``.units.csv`` sidecar; cut to :data:`MAX_STEM_BYTES`."""
    stem = stem[:MAX_STEM_BYTES]
    names = lambda s: {s.lower(), f"{s}.units".lower()}
    cand, k = stem, 1
    while names(cand) & used or cand.lower() == "index" or any(cand.lower() == f"{u}.units" for u in used):
        k += 1
        cand = f"{stem}-{k}"
    used |= names(cand)
    return cand


def _tidy_tables(full, own, gname: str):
    """``(stem, DataFrame, units DataFrame)`` per set of dimensions of a group's own variables."""
    sets: dict = {}
    for k, v in own.data_vars.items():
        sets.setdefault(tuple(v.dims), []).append(k)
    main = max(sets, key=lambda d: (len(sets[d]), -len(d)))
    for dims, names in sets.items():
        stem = gname if dims == main else f"{gname}__{'-'.join(portable_stem(d) for d in dims) or 'scalar'}"
        # the coordinates on exactly these dimensions (e.g. frequency_hz on Omega) as columns too
        coords = [c for c in full.coords if set(full[c].dims) <= set(dims) and c not in dims]
        cols, meta = {}, []
        shape = tuple(full.sizes[d] for d in dims)
        grids = np.meshgrid(*[np.arange(n) for n in shape], indexing="ij") if dims else []
        for d, g in zip(dims, grids):
            vals = full[d].values if d in full.coords else np.arange(full.sizes[d])
            cols[d] = np.asarray(vals)[g.ravel()]
            a = full[d].attrs if d in full.coords else {}
            meta.append((d, a.get("units", ""), a.get("long_name", "index")))
        for k in coords + names:
            v = full[k]
            if not v.dims:
                a = np.broadcast_to(np.asarray(v.values), shape)
            elif tuple(v.dims) == dims:
                a = np.asarray(v.values)
            else:                   # a coordinate on fewer dimensions (frequency_hz on Omega): gathered
                idx = tuple(g for d, g in zip(dims, grids) if d in v.dims)
                a = np.asarray(v.transpose(*[d for d in dims if d in v.dims]).values)[idx]
            a = np.asarray(a).reshape(-1)
            u, ln = v.attrs.get("units", ""), v.attrs.get("long_name", "")
            if np.iscomplexobj(a):
                cols[f"{k}_real"], cols[f"{k}_imag"] = a.real, a.imag
                meta += [(f"{k}_real", u, f"{ln} (real part)"), (f"{k}_imag", u, f"{ln} (imaginary part)")]
            else:
                cols[k] = a
                meta.append((k, u, ln))
        yield stem, dims, pd.DataFrame(cols), pd.DataFrame(meta, columns=["column", "units", "long_name"])
