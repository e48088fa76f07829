"""Structural matrices from files: NumPy ``.npz`` archives and MatrixMarket files (issue 58).

A structure given by its matrices (:func:`vibeam.models.builders.matrices.build_matrices`) is read
from either

* one ``.npz`` archive (``numpy.savez``) holding the arrays ``M`` and ``K`` (required), ``C``
  (the damping matrix, optional), ``dofs`` (the DOFs' names, strings, optional), ``r`` (the base's
  influence vector) or ``Mr`` (the base load ``M r`` itself), optional; any other name is refused;
  arrays holding Python objects (pickles) are never loaded;
* or one MatrixMarket file per array (:func:`scipy.io.mmread`: ``coordinate`` files are read as
  sparse, ``array`` files as dense; real or integer fields, any symmetry), named by the same keys.

Paths are relative to ``base`` (the case file's folder).  Every file is an input file
(:func:`vibeam.io.inputs.check_input_file`: an existing regular file).  The arrays are checked
once, by the models' own check (:func:`vibeam.models.builders.matrices.matrix_problem`): ``M``,
``K``, ``C`` square, of one size, finite, symmetric (to
:data:`~vibeam.models.builders.matrices.SYMMETRY_RTOL` of the largest entry; the mean with the
transpose is kept), ``M`` positive definite, ``K`` positive semi-definite; ``dofs`` distinct
non-empty names, one per DOF; ``r``, ``Mr`` finite vectors of one entry per DOF, not both.  A
refusal is one :class:`vibeam.errors.InputError` line naming the file, the key, its value and
what is allowed: ``<file>: 'K' = 3 x 4 matrix: not a square matrix (shape 3x4); allowed: ...``.

References
----------
NIST MatrixMarket exchange format (R. F. Boisvert, R. Pozo, K. A. Remington, 1996),
https://math.nist.gov/MatrixMarket/formats.html; NumPy ``.npy``/``.npz`` format (NEP 1).
"""
from __future__ import annotations

import zipfile
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import scipy.io
import scipy.sparse

from vibeam.errors import InputError, one_line
from vibeam.io.inputs import check_input_file
from vibeam.models.builders.matrices import as_matrix, matrix_problem

__all__ = ["Matrices", "read_matrices", "inline_matrices", "KEYS"]

#: the arrays a matrices file may hold, and what each is
KEYS = {"M": "mass matrix (kg), d x d, symmetric positive definite",
        "K": "stiffness matrix (N/m), d x d, symmetric positive semi-definite",
        "C": "damping matrix (N s/m), d x d, symmetric",
        "dofs": "the DOFs' names, d distinct strings",
        "r": "influence vector of the base translation, d numbers",
        "Mr": "base load per unit base acceleration M r (kg), d numbers"}
_WHAT = "matrix file"


@dataclass(frozen=True)
class Matrices:
    """The arrays of a structure read from files (SI).

    Attributes
    ----------
    M, K : ndarray or scipy.sparse.csr_array, shape (d, d)
        Mass and stiffness, symmetric (float64).
    C : ndarray or scipy.sparse.csr_array, shape (d, d), or None
        Damping.
    dofs : tuple of str or None
        The DOFs' names.
    r, Mr : ndarray, shape (d,), or None
        The base's influence vector, or its load ``M r``.
    sources : dict
        ``{key: Path}``: the file each array came from.
    """

    M: object
    K: object
    C: object = None
    dofs: tuple | None = None
    r: np.ndarray | None = None
    Mr: np.ndarray | None = None
    sources: dict = field(default_factory=dict)

    @property
    def size(self) -> int:
        """``d``, the number of DOFs."""
        return int(self.M.shape[0])


def _fail(path, key, value, why):
    return InputError(one_line(f"{path}: '{key}' = {value}: {why}"))


def _describe(a) -> str:
    shape = getattr(a, "shape", None)
    if shape is None:
        return type(a).__name__
    kind = "sparse matrix" if scipy.sparse.issparse(a) else ("matrix" if len(shape) == 2 else "array")
    return (" x ".join(map(str, shape)) if shape else "scalar") + f" {kind}" + (
        f" of {a.dtype}" if getattr(a, "dtype", None) is not None and a.dtype.kind not in "fiu" else "")


def _resolve(path, base) -> Path:
    p = Path(path)
    return p if p.is_absolute() or base is None else Path(base) / p


def _read_npz(path: Path) -> dict:
    try:
        with np.load(path, allow_pickle=False) as z:
            keys = list(z.files)
            unknown = [k for k in keys if k not in KEYS]
            if unknown:
                raise _fail(path, unknown[0], "an array", f"no such key; allowed: {', '.join(KEYS)}")
            out = {}
            for k in keys:
                try:
                    out[k] = z[k]
                except ValueError:
                    raise _fail(path, k, "Python objects", "arrays holding Python objects (pickles) are "
                                "not read; allowed: numeric arrays and, for 'dofs', an array of strings") from None
            return out
    except InputError:
        raise
    except (zipfile.BadZipFile, ValueError, OSError, EOFError) as e:
        raise InputError(one_line(f"{path}: cannot read {_WHAT}: not a NumPy .npz archive ({e}); allowed: "
                                  f"an archive written by numpy.savez with the keys {', '.join(KEYS)}")) from None


def _read_mtx(path: Path, key: str):
    try:
        info = scipy.io.mminfo(path)
        if info[4] not in ("real", "integer"):
            raise _fail(path, key, f"a MatrixMarket {info[4]} {info[3]}",
                        "allowed: a real or integer field (not complex, not pattern)")
        a = scipy.io.mmread(path)
    except InputError:
        raise
    except (ValueError, OSError, EOFError, IndexError, TypeError) as e:
        raise InputError(one_line(f"{path}: cannot read {_WHAT}: not a MatrixMarket file ({e}); allowed: a "
                                  f"file written by scipy.io.mmwrite (coordinate or array, real)")) from None
    return scipy.sparse.csr_array(a) if scipy.sparse.issparse(a) else np.asarray(a)


def _vector(path, key, a, d):
    if scipy.sparse.issparse(a):
        a = a.toarray()
    v = np.asarray(a)
    if v.ndim == 2 and 1 in v.shape:
        v = v.reshape(-1)
    if v.ndim != 1 or v.size != d or v.dtype.kind not in "fiu":
        raise _fail(path, key, _describe(a), f"allowed: {d} numbers, one per DOF ({KEYS[key]})")
    v = v.astype(float)
    if not np.all(np.isfinite(v)):
        raise _fail(path, key, _describe(a), f"{int(np.sum(~np.isfinite(v)))} entries not finite; allowed: "
                    f"finite numbers")
    return v


def _names(path, a, d):
    v = np.asarray(a)
    if v.ndim != 1 or v.dtype.kind not in "US" or v.size != d:
        raise _fail(path, "dofs", _describe(a), f"allowed: {d} names (strings), one per DOF")
    names = tuple(x.decode() if isinstance(x, bytes) else str(x) for x in v.tolist())
    for i, s in enumerate(names):
        if not s.strip():
            raise _fail(path, "dofs", _describe(a), f"name {i} is empty; allowed: non-empty names")
        if names.index(s) != i:
            raise _fail(path, "dofs", _describe(a), f"{s!r} appears twice; allowed: distinct names")
    return names


def read_matrices(source, base=None) -> Matrices:
    """Read and check the matrices of a structure.

    Parameters
    ----------
    source : str, Path or mapping
        An ``.npz`` archive, or ``{key: path}`` of MatrixMarket files (keys of :data:`KEYS` but
        ``dofs``: the names come from the case); ``M`` and ``K`` are required.
    base : str, Path or None
        The folder relative paths start from (the case file's).

    Returns
    -------
    Matrices
        ``M``, ``K``, ``C`` symmetric (the mean with the transpose), dense or sparse as stored.

    Raises
    ------
    vibeam.errors.InputError
        One line naming the file, the key and what is allowed: no such file or not a regular file;
        not an ``.npz`` archive or MatrixMarket file; an unknown or missing key; an array of Python
        objects; a matrix not square, of another size than ``M``, not real, not finite, not
        symmetric; ``M`` not positive definite, ``K`` not positive semi-definite; ``dofs`` of the
        wrong count, empty or repeated; ``r`` or ``Mr`` not ``d`` finite numbers, or both given.
    """
    if isinstance(source, Mapping):
        files = {}
        for k, p in source.items():
            if k not in KEYS or k == "dofs":
                allowed = ", ".join(x for x in KEYS if x != "dofs")
                raise InputError(one_line(f"'{k}' = {str(p)!r}: no such matrix key; allowed: {allowed} (one "
                                          f"MatrixMarket file each)"))
            files[k] = check_input_file(_resolve(p, base), _WHAT)
        for k in ("M", "K"):
            if k not in files:
                raise InputError(one_line(f"'{k}': missing; allowed: a MatrixMarket file of the {KEYS[k]} (the "
                                          f"matrices: {', '.join(repr(x) for x in files)})"))
        raw = {k: _read_mtx(p, k) for k, p in files.items()}
    else:
        path = check_input_file(_resolve(source, base), _WHAT)
        raw = _read_npz(path)
        files = {k: path for k in raw}
        for k in ("M", "K"):
            if k not in raw:
                raise _fail(path, k, "missing", f"allowed: the {KEYS[k]} (arrays of the archive: "
                            f"{', '.join(raw) or 'none'})")
    return _checked(raw, files)


def inline_matrices(tables: Mapping, where: str = "model.system") -> Matrices:
    """Check matrices given inline in a case (``M = [[...], ...]``), as :func:`read_matrices` checks
    a file's.

    Parameters
    ----------
    tables : mapping
        ``{key: rows}`` with keys of :data:`KEYS` (``M``, ``K`` required; ``C`` optional), each a
        list of rows of numbers (a matrix) or of numbers (``r``, ``Mr``).
    where : str
        The case's table, named in messages.

    Raises
    ------
    vibeam.errors.InputError
        One line naming the key and what is allowed (as :func:`read_matrices`).
    """
    raw, files = {}, {}
    for k, v in tables.items():
        if k not in KEYS or k == "dofs":
            raise InputError(one_line(f"'{where}.{k}': no such matrix key; allowed: M, K, C"))
        try:
            raw[k] = np.array(v, dtype=float)
        except (TypeError, ValueError):
            raise InputError(one_line(f"'{where}.{k}': not a table of numbers; allowed: a list of rows of "
                                      f"numbers ({KEYS[k]})")) from None
        files[k] = f"'{where}.{k}'"
    for k in ("M", "K"):
        if k not in raw:
            raise InputError(one_line(f"'{where}.{k}': missing; allowed: the {KEYS[k]}"))
    return _checked(raw, files)


def _checked(raw: dict, files: dict) -> Matrices:
    out = {}
    d = None
    for k, definite in (("M", "positive"), ("K", "semi"), ("C", None)):
        if k not in raw:
            continue
        try:
            A = as_matrix(raw[k])
        except ValueError as e:
            raise _fail(files[k], k, _describe(raw[k]), f"{e}; allowed: a {KEYS[k]}") from None
        p = matrix_problem(A, definite, size=d)
        if p is not None:
            raise _fail(files[k], k, _describe(raw[k]), f"{p[0]}; allowed: {p[1]} ({KEYS[k]})")
        out[k] = (A + A.T) * 0.5
        d = A.shape[0] if d is None else d
    if "dofs" in raw:
        out["dofs"] = _names(files["dofs"], raw["dofs"], d)
    for k in ("r", "Mr"):
        if k in raw:
            out[k] = _vector(files[k], k, raw[k], d)
    if "r" in out and "Mr" in out:
        raise _fail(files["Mr"], "Mr", _describe(raw["Mr"]), "given with 'r'; allowed: one of 'r' (the "
                    "influence vector) and 'Mr' (its load M r)")
    return Matrices(sources=dict(files), **out)
