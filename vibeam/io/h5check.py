"""What vibeam reads of an HDF5 file it did not just write: a results file, its checkpoint, a
reference.  The structure is checked before any value is read.

vibeam writes plain netCDF-4 files: groups and datasets reached by hard links only, datasets
of at most a few hundred megabytes, a root attribute ``complete`` that is 0 or 1.  A file
given back to it may have been edited, truncated or built to harm (a soft-link loop, an
external link to another file, a dataset declared with 2^37 elements and compressed to a
few bytes, a sparse tail of gigabytes).  :func:`check_tree` walks such a file's *metadata*
(no dataset is read) and refuses, in one line naming the file and the object, anything this
vibeam would not have written:

* a soft or external link (vibeam writes none; following one reads another file or loops);
* a dataset larger than :data:`MAX_DATASET_BYTES` once decompressed (its shape times its
  item size), or a tree whose datasets add up to more than :data:`MAX_TOTAL_BYTES`;
* more than :data:`MAX_OBJECTS` objects, or a group nested deeper than :data:`MAX_DEPTH`;
* a root attribute ``complete`` that is not a scalar 0 or 1, or ``vibeam_layout`` that is
  not 1 or 2.

:func:`file_size_ok` bounds a file read whole into memory (the results store builds a
file's successor from its bytes).  This module imports nothing of vibeam but its errors.
"""
from __future__ import annotations

import os

import h5py
import numpy as np

from vibeam.errors import InputError, one_line

#: the largest dataset read (bytes, decompressed): a sweep of 1e5 points x 64 recorded periods
#: of strobe samples is 100 MB; a basin grid of 2000 x 2000 states x 1000 frequencies would be
#: 32 GB, which no command writes (the work limits refuse it first)
MAX_DATASET_BYTES = 1 << 30
#: the largest sum of the datasets of one file or group read (bytes, decompressed)
MAX_TOTAL_BYTES = 4 << 30
#: the largest results file read whole into memory to build its successor (bytes)
MAX_FILE_BYTES = 4 << 30
#: the most objects (groups and datasets) walked in one file
MAX_OBJECTS = 200_000
#: the deepest group nesting walked (vibeam writes at most 5 levels)
MAX_DEPTH = 16


def _refuse(path, what: str, why: str, hint: str = "") -> InputError:
    return InputError(one_line(f"{path}: {what}: {why}" + (f"; {hint}" if hint else "")))


def dataset_bytes(d) -> int:
    """The decompressed size of a dataset from its metadata (shape x item size), in bytes."""
    n = 1
    for s in (d.shape or ()):
        n *= int(s)
    try:
        item = int(d.dtype.itemsize)
    except (TypeError, ValueError):
        item = 8
    return n * max(item, 1)


def check_root_attrs(path, attrs) -> None:
    """The root attributes vibeam reads (``complete``, ``vibeam_layout``) have the type it writes.

    Raises
    ------
    InputError
        One line naming the file and the attribute.
    """
    for key, kinds, allowed, what in (("complete", "biu", (0, 1), "a scalar 0 or 1"),
                                      ("vibeam_layout", "iu", (1, 2), "the whole number 1 or 2")):
        if key not in attrs:
            continue
        v = np.asarray(attrs[key])
        if not (v.size == 1 and v.dtype.kind in kinds and int(v.ravel()[0]) in allowed):
            raise _refuse(path, f"root attribute '{key}'", f"{one_line(repr(attrs[key]))[:60]} is not allowed; "
                          f"vibeam writes {what}")


def check_tree(path, group=None, where: str = "/", max_total: int = MAX_TOTAL_BYTES) -> int:
    """Walk the metadata of an open HDF5 file or group and refuse what vibeam never writes.

    Parameters
    ----------
    path : str or Path
        The file's name, for messages.
    group : h5py.Group or h5py.File
        Where the walk starts (the file itself: its root attributes are checked too).
    where : str
        The group's path in the file, for messages.
    max_total : int
        The largest sum of dataset sizes below ``group`` (bytes).

    Returns
    -------
    int
        The decompressed size of every dataset below ``group`` (bytes).

    Raises
    ------
    InputError
        One line naming the file and the object: a soft or external link, a dataset larger than
        :data:`MAX_DATASET_BYTES`, more than ``max_total`` bytes in all, more than
        :data:`MAX_OBJECTS` objects, nesting deeper than :data:`MAX_DEPTH`, a root attribute of
        the wrong type (:func:`check_root_attrs`).
    """
    hint = "vibeam never writes such a file; move it away or give another file"
    if group.name == "/":
        check_root_attrs(path, group.attrs)
    total = 0
    count = 0
    seen: set = set()
    stack = [(group, where.rstrip("/") or "", 0)]
    while stack:
        g, gpath, depth = stack.pop()
        if depth > MAX_DEPTH:
            raise _refuse(path, f"group {gpath or '/'}", f"nested deeper than {MAX_DEPTH} levels", hint)
        try:
            names = list(g.keys())
        except (KeyError, OSError, RuntimeError) as e:
            raise _refuse(path, f"group {gpath or '/'}", f"cannot be listed ({one_line(str(e))[:80]})", hint) from None
        for name in names:
            count += 1
            if count > MAX_OBJECTS:
                raise _refuse(path, f"group {gpath or '/'}", f"more than {MAX_OBJECTS} objects", hint)
            p = f"{gpath}/{name}"
            link = g.get(name, getlink=True)
            if isinstance(link, h5py.SoftLink):
                raise _refuse(path, p, f"a soft link (to {one_line(str(link.path))[:80]})", hint)
            if isinstance(link, h5py.ExternalLink):
                raise _refuse(path, p, f"an external link (to {one_line(str(link.filename))[:80]})", hint)
            try:
                obj = g[name]
            except (KeyError, OSError, RuntimeError, ValueError) as e:
                raise _refuse(path, p, f"cannot be opened ({one_line(str(e))[:80]})", hint) from None
            if isinstance(obj, h5py.Dataset):
                n = dataset_bytes(obj)
                if n > MAX_DATASET_BYTES:
                    raise _refuse(path, f"dataset {p}", f"{n / 2**30:.3g} GiB once decompressed (shape "
                                  f"{tuple(obj.shape)}), more than the {MAX_DATASET_BYTES / 2**30:g} GiB this "
                                  f"vibeam reads", hint)
                total += n
                if total > max_total:
                    raise _refuse(path, f"group {where or '/'}", f"more than {max_total / 2**30:g} GiB of data "
                                  f"once decompressed", hint)
            elif isinstance(obj, h5py.Group):
                key = _addr(obj)
                if key in seen:            # a group hard-linked twice (a cycle): walked once
                    continue
                seen.add(key)
                stack.append((obj, p, depth + 1))
    return total


def _addr(obj):
    try:
        info = h5py.h5o.get_info(obj.id)
        return getattr(info, "addr", None) or getattr(info, "token", None) or id(obj)
    except Exception:          # pragma: no cover - every HDF5 object has an address
        return id(obj)


def file_size_ok(path, limit: int = MAX_FILE_BYTES, what: str = "results file") -> int:
    """The size of a file read whole into memory, refused above ``limit``.

    Raises
    ------
    InputError
        One line naming the file, its size and the limit.
    """
    n = os.stat(path).st_size
    if n > limit:
        raise InputError(f"{path}: the {what} is {n / 2**30:.3g} GiB, more than the {limit / 2**30:g} GiB vibeam "
                         f"reads into memory (vibeam.io.h5check.MAX_FILE_BYTES); vibeam writes far smaller files: "
                         f"move it away or use another --out")
    return n


def open_checked(path, what: str = "results file", option: str = ""):
    """An HDF5 file opened read-only after :func:`check_tree` (the caller closes it).

    Raises
    ------
    InputError
        One line naming the file: not an HDF5 file, or what :func:`check_tree` refuses.
    """
    where = f"{option} {path}" if option else str(path)
    try:
        f = h5py.File(path, "r")
    except (OSError, ValueError) as e:
        why = str(e).split("(")[0].strip().rstrip(",") or type(e).__name__
        raise InputError(one_line(f"{where}: cannot read the {what}: not an HDF5 file vibeam can read "
                                  f"({why})")) from None
    try:
        check_tree(where, f)
    except BaseException:
        f.close()
        raise
    return f

