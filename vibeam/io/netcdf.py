"""The generic netCDF-4 file on h5py that the results file is made of, and the units of model
parameters.

:func:`write_group` writes a dict of :class:`Variable` (dims, data, units, long_name) as one
netCDF-4 group with its dimensions and coordinates; :func:`read_attrs` and :func:`read_plain`
read groups back.  :mod:`vibeam.io.results` (runs, maps, the checkpoint), :mod:`vibeam.analysis.branches`
and the other writers of groups build on this module, which imports nothing of vibeam.
"""
from __future__ import annotations

import json
from dataclasses import dataclass, field

import h5py
import numpy as np

_DIM_ONLY = "This is a netCDF dimension but not a netCDF variable"


def json_default(o):
    """``default`` of :func:`json.dumps`: numpy scalars and arrays as Python numbers and lists,
    anything else as its ``str``."""
    if isinstance(o, np.generic):
        return o.item()
    if isinstance(o, np.ndarray):
        return o.tolist()
    return str(o)


# units of the parameters a map may vary (by name, then by suffix)
PARAMETER_UNITS = {"voltage": "V", "gain": "V-1", "natural_frequency_hz": "Hz", "damping_ratio": "1",
                   "R": "1", "B": "1", "beta": "1", "Delta": "1", "youngs_modulus_gpa": "GPa",
                   "density_kg_m3": "kg m-3", "rhoA_kg_m": "kg m-1", "EI_n_m2": "N m2",
                   "rotary_inertia_kg_m2": "kg m2", "rayleigh_alpha_1_s": "s-1"}
_SUFFIX_UNITS = (("_mm", "mm"), ("_hz", "Hz"), ("_kg", "kg"), ("_s", "s"), ("_n_m", "N m-1"), ("_m", "m"))


def parameter_units(name: str) -> str:
    """UDUNITS string of a model key or a parameter path's last key (``voltage`` V, ``gap_mm``
    mm, ``R`` 1, ``stops[1].law.stiffness_n_m`` N m-1 (N m-p for a law with an exponent p: the
    key's unit at p = 1), ...)."""
    name = name.rsplit(".", 1)[-1]
    if name in PARAMETER_UNITS:
        return PARAMETER_UNITS[name]
    for suf, u in _SUFFIX_UNITS:
        if name.endswith(suf):
            return u
    return "1"


# ============================================================================ the generic writer
@dataclass
class Variable:
    """One netCDF variable: named dimensions, data and attributes.

    Attributes
    ----------
    dims : tuple of str
        One name per axis of ``data`` (``()`` for a scalar).
    data : ndarray
        Numbers, complex numbers, booleans (stored as int8 with ``dtype = "bool"``, as xarray
        encodes them) or strings (UTF-8).
    attrs : dict
        ``units`` and ``long_name`` (CF), and any other attribute; dicts are stored as JSON.
    """

    dims: tuple
    data: np.ndarray
    attrs: dict = field(default_factory=dict)


def var(dims, data, units: str | None = None, long_name: str | None = None, **attrs) -> Variable:
    """A :class:`Variable` with ``units`` and ``long_name`` (omitted when None)."""
    a = {}
    if units is not None:
        a["units"] = units
    if long_name is not None:
        a["long_name"] = long_name
    a.update(attrs)
    return Variable(tuple(dims), np.asarray(data), a)


def _attr_value(v):
    """An attribute value netCDF can hold: bools as int8, dicts (and ragged lists) as JSON."""
    if isinstance(v, (bool, np.bool_)):
        return np.int8(bool(v))
    if isinstance(v, dict):
        return json.dumps(v, default=json_default)
    if isinstance(v, (list, tuple)):
        try:
            a = np.asarray(v)
        except ValueError:
            return json.dumps(v, default=json_default)
        if a.dtype == object:
            return json.dumps(v, default=json_default)
        v = a
    if isinstance(v, np.ndarray):
        if v.dtype == bool:
            return v.astype(np.int8)
        if v.dtype.kind in "US":
            return [str(x) for x in v.ravel()]
        if v.dtype == object:
            return json.dumps(v.tolist(), default=json_default)
    return v


def set_attrs(obj, attrs: dict) -> None:
    """Set attributes on an HDF5 group or dataset (None values skipped; see :func:`_attr_value`)."""
    for k, v in attrs.items():
        if v is None:
            continue
        v = _attr_value(v)
        if isinstance(v, list):
            v = np.array(v, dtype=h5py.string_dtype())
        obj.attrs[k] = v


def _next_dimid(f) -> int:
    """One more than the largest netCDF dimension id (``_Netcdf4Dimid``) in the file."""
    ids = [-1]

    def visit(name, obj):
        if obj.attrs.get("CLASS") == b"DIMENSION_SCALE" and "_Netcdf4Dimid" in obj.attrs:
            ids.append(int(np.asarray(obj.attrs["_Netcdf4Dimid"]).ravel()[0]))

    f.file.visititems(visit)
    return max(ids) + 1


def _find_scale(g, dim: str, size: int):
    """The dimension scale ``dim`` of ``size`` in ``g`` or its parents (netCDF scoping), or None."""
    while True:
        d = g.get(dim)
        if isinstance(d, h5py.Dataset) and h5py.h5ds.is_scale(d.id) and d.shape == (size,):
            return d
        if g.name == "/":
            return None
        g = g.parent


class DimIds:
    """The next free netCDF dimension id of an open file (found once, then counted).

    ``start``: the next free id when the caller knows it (the file is one it wrote itself and
    counted: :meth:`vibeam.io.store.Store.checkpoint`); None finds it by visiting the file
    (:func:`_next_dimid`, every object: O(file) per call)."""

    def __init__(self, start: int | None = None):
        self.next = None if start is None else int(start)

    def take(self, g) -> int:
        if self.next is None:
            self.next = _next_dimid(g)
        self.next += 1
        return self.next - 1


def write_group(parent, name: str, variables: dict, attrs: dict | None = None, groups: dict | None = None,
                _ids: DimIds | None = None):
    """Write one netCDF4 group with HDF5 dimension scales (h5py ``make_scale`` / ``attach_scale``).

    Parameters
    ----------
    parent : h5py.File or h5py.Group
        Where the group is created (``name`` may be a path, e.g. ``"runs/exact"``;
        missing groups on the way are created).
    name : str
        Group name or path below ``parent``.
    variables : dict
        ``{name: Variable}``.  A 1-D variable named like its dimension is that
        dimension's coordinate (the dimension scale holds its values); any other
        dimension is a netCDF dimension without a variable.  Dimensions are declared
        from the shapes; a dimension of a parent group with the same name and size is
        reused (netCDF scoping), so a subgroup can share its parent's ``direction``.
        A variable with ``aux = True`` in its attrs is an auxiliary coordinate: every
        variable whose dimensions include its dimensions lists it in the CF
        ``coordinates`` attribute.
    attrs : dict, optional
        Group attributes (dicts stored as JSON; their names listed in ``json_attrs``).
    groups : dict, optional
        Subgroups ``{name: (variables, attrs)}``, written the same way.

    Returns
    -------
    h5py.Group

    Raises
    ------
    ValueError
        If a variable's dims do not match its shape, or two variables give one
        dimension two sizes.

    Notes
    -----
    The netCDF-4 conventions followed (as netCDF-C and h5netcdf write them): a
    dimension without a variable is a float32 dataset of its length whose scale NAME
    is ``"This is a netCDF dimension but not a netCDF variable." + "%10d" % size``;
    every scale has the file-unique ``_Netcdf4Dimid``; every variable lists the ids
    of its dimensions in ``_Netcdf4Coordinates``.  Strings are variable-length UTF-8;
    booleans int8 with ``dtype = "bool"`` (decoded by xarray).  h5netcdf writes the
    same but costs ~13 ms per variable, too slow for a checkpoint of many lines.
    """
    ids = _ids or DimIds()
    sizes: dict = {}
    for k, v in variables.items():
        shape = np.shape(v.data)
        if len(shape) != len(v.dims):
            raise ValueError(f"variable {k!r}: dims {v.dims} do not match shape {shape}")
        for d, n in zip(v.dims, shape):
            if sizes.setdefault(d, n) != n:
                raise ValueError(f"dimension {d!r} has sizes {sizes[d]} and {n} (variable {k!r})")
    g = parent.require_group(name.strip("/")) if name else parent
    scales, dimid = {}, {}
    for d, n in sizes.items():
        coord = variables.get(d)
        is_coord = coord is not None and coord.dims == (d,)
        if not is_coord and g.name != "/" and d not in g:
            sc = _find_scale(g.parent, d, n)
            if sc is not None:            # the parent's dimension (netCDF scoping)
                scales[d] = sc
                dimid[d] = int(np.asarray(sc.attrs["_Netcdf4Dimid"]).ravel()[0])
                continue
        if is_coord:
            sc = _create(g, d, coord)
            sc.make_scale(d)
        else:
            sc = g.create_dataset(d, shape=(n,), dtype=">f4")
            sc.make_scale(f"{_DIM_ONLY}.{n:10d}")
        i = ids.take(g)
        sc.attrs["_Netcdf4Dimid"] = np.int32(i)
        if is_coord:
            sc.attrs["_Netcdf4Coordinates"] = np.array([i], np.int32)
        scales[d], dimid[d] = sc, i
    aux = [k for k, v in variables.items() if v.attrs.get("aux")]
    for k, v in variables.items():
        a = {kk: vv for kk, vv in v.attrs.items() if kk != "aux"}
        if np.asarray(v.data).dtype == bool:
            a["dtype"] = "bool"
        if k in sizes and v.dims == (k,):
            ds = scales[k]
        else:
            ds = _create(g, k, v)
            for i, d in enumerate(v.dims):
                ds.dims[i].attach_scale(scales[d])
            if v.dims:
                ds.attrs["_Netcdf4Coordinates"] = np.array([dimid[d] for d in v.dims], np.int32)
            cs = [c for c in aux if c != k and set(variables[c].dims) <= set(v.dims)]
            if cs:
                a["coordinates"] = " ".join(cs)
        set_attrs(ds, a)
    if attrs:
        js = [k for k, v in attrs.items() if isinstance(v, dict)]
        set_attrs(g, dict(attrs, **({"json_attrs": " ".join(js)} if js else {})))
    for sub, (sv, sa) in (groups or {}).items():
        write_group(g, sub, sv, sa, _ids=ids)
    return g


def _create(g, name, v: Variable):
    """The HDF5 dataset of one variable (strings as UTF-8, bools as int8)."""
    data = np.asarray(v.data)
    if data.dtype == bool:
        return g.create_dataset(name, data=data.astype(np.int8))
    if data.dtype == object or data.dtype.kind in "US":
        txt = np.array([str(x) for x in data.ravel()], dtype=object).reshape(data.shape)
        return g.create_dataset(name, data=txt, dtype=h5py.string_dtype())
    return g.create_dataset(name, data=data)


# ============================================================================ reading
def read_attrs(obj) -> dict:
    """Attributes as Python values (netCDF bookkeeping left out)."""
    out = {}
    for k, v in obj.attrs.items():
        if k in ("_NCProperties", "DIMENSION_LIST", "REFERENCE_LIST", "CLASS", "NAME", "_Netcdf4Dimid",
                 "_Netcdf4Coordinates"):
            continue
        if isinstance(v, bytes):
            v = v.decode()
        if isinstance(v, np.ndarray) and v.shape == (1,) and v.dtype.kind in "biuf":
            v = v[0]                       # netCDF stores a scalar attribute as a 1-element array
        out[k] = v
    return out


def is_dim_only(d) -> bool:
    """Whether a dataset is a netCDF dimension without a variable (left out when reading)."""
    n = d.attrs.get("NAME")
    if isinstance(n, bytes):
        n = n.decode(errors="replace")
    return isinstance(n, str) and n.startswith(_DIM_ONLY)


def dataset_values(d):
    """A dataset's values: strings as ``str``, int8 flags written from bools as ``bool``."""
    if d.dtype.kind == "O" or h5py.check_string_dtype(d.dtype):
        return d.asstr()[()]
    v = d[()]
    if str(d.attrs.get("dtype", "")) == "bool":
        v = np.asarray(v).astype(bool)
    return v


def read_plain(g, attrs: bool = False) -> dict:
    """Datasets of a group as they are; subgroups (e.g. ``time_series/<f>/<direction>``) as
    nested dicts (with ``attrs``: each subgroup's attributes under ``"attrs"``, as for
    ``/branches``); netCDF dimension-only datasets left out."""
    out = {}
    for k, d in g.items():
        if isinstance(d, h5py.Dataset):
            if not is_dim_only(d):
                out[k] = dataset_values(d)
        elif isinstance(d, h5py.Group):
            out[k] = read_plain(d, attrs)
            if attrs:
                out[k]["attrs"] = read_attrs(d)
    return out
