"""The mesh of ``cases/plate-tip-stop.toml``: a clamped steel plate strip with a brass pad at its tip,
written in Gmsh's format (MSH 2.2, ASCII) by meshio, with its physical groups.

The part (millimetres in the text, metres in the file): a steel plate strip 120 x 40 x 2 mm
(``x`` along it from the clamp, ``y`` across, ``z`` through its thickness, ``|z| <= 1``), clamped over
its end face ``x = 0``; a brass pad 10 x 40 x 6 mm bonded under its tip (``110 <= x <= 120``,
``-7 <= z <= -1``), which the case ties as a rigid body and a stop under it hits.  Trilinear hexahedra
on a tensor grid (the case builds 20-node ones on them: scikit-fem adds the edge nodes), conforming
between plate and pad.

Physical groups (what a user's Gmsh model would name):
    ``plate`` (3D, the plate's hexahedra), ``pad`` (3D, the pad's), ``clamp`` (2D, the quadrilaterals
    of the face ``x = 0``).

Usage::

    python cases/plate-tip-stop/make_plate.py            # writes cases/plate-tip-stop/plate.msh

:func:`plate_mesh` gives the same part on any grid (tests/test_mesh_case.py: a finer one for the
mesh convergence).
"""
from __future__ import annotations

import sys
from pathlib import Path

import meshio
import numpy as np

#: the part (m)
LENGTH, WIDTH, THICKNESS = 0.120, 0.040, 0.002
PAD_LENGTH, PAD_THICKNESS = 0.010, 0.006


def plate_mesh(nx: int = 12, ny: int = 4, nz: int = 1, nz_pad: int = 1) -> meshio.Mesh:
    """The plate and its pad as a :class:`meshio.Mesh` with Gmsh physical groups.

    Parameters
    ----------
    nx : int
        Elements along the plate (a multiple of 12: the pad's edge ``x = 110 mm`` a grid line).
    ny, nz, nz_pad : int
        Elements across the width, through the plate's thickness and through the pad's.

    Returns
    -------
    meshio.Mesh
        Points (m); cell blocks ``hexahedron`` (plate then pad) and ``quad`` (the clamp's face);
        ``cell_data["gmsh:physical"]`` / ``["gmsh:geometrical"]`` and ``field_data`` ``{name: [tag, dim]}``.
    """
    if nx % 12:
        raise ValueError(f"nx = {nx}: allowed a multiple of 12")
    xs = np.linspace(0.0, LENGTH, nx + 1)
    ys = np.linspace(-0.5 * WIDTH, 0.5 * WIDTH, ny + 1)
    zs = np.concatenate([np.linspace(-0.5 * THICKNESS - PAD_THICKNESS, -0.5 * THICKNESS, nz_pad + 1)[:-1],
                         np.linspace(-0.5 * THICKNESS, 0.5 * THICKNESS, nz + 1)])
    X, Y, Z = np.meshgrid(xs, ys, zs, indexing="ij")
    pts = np.stack([X.ravel(), Y.ravel(), Z.ravel()], axis=1)
    node = np.arange(len(pts)).reshape(X.shape)
    i, j, k = np.meshgrid(np.arange(nx), np.arange(ny), np.arange(nz_pad + nz), indexing="ij")
    i, j, k = i.ravel(), j.ravel(), k.ravel()
    # VTK / Gmsh hexahedron order: the bottom face counter-clockwise, then the top face
    hexa = np.stack([node[i, j, k], node[i + 1, j, k], node[i + 1, j + 1, k], node[i, j + 1, k],
                     node[i, j, k + 1], node[i + 1, j, k + 1], node[i + 1, j + 1, k + 1], node[i, j + 1, k + 1]],
                    axis=1)
    in_plate = k >= nz_pad
    in_pad = ~in_plate & (xs[i] >= LENGTH - PAD_LENGTH - 1e-12)
    used = np.concatenate([hexa[in_plate], hexa[in_pad]])
    jj, kk = np.meshgrid(np.arange(ny), np.arange(nz_pad, nz_pad + nz), indexing="ij")
    jj, kk = jj.ravel(), kk.ravel()
    clamp = np.stack([node[0, jj, kk], node[0, jj + 1, kk], node[0, jj + 1, kk + 1], node[0, jj, kk + 1]], axis=1)
    # drop the grid's nodes under the plate that no pad cell uses
    keep = np.unique(used)
    new = -np.ones(len(pts), dtype=np.int64)
    new[keep] = np.arange(keep.size)
    n_plate, n_pad = int(in_plate.sum()), int(in_pad.sum())
    tags = [np.r_[np.full(n_plate, 1), np.full(n_pad, 2)], np.full(len(clamp), 3)]
    return meshio.Mesh(pts[keep], [("hexahedron", new[used]), ("quad", new[clamp])],
                       cell_data={"gmsh:physical": tags, "gmsh:geometrical": tags},
                       field_data={"plate": np.array([1, 3]), "pad": np.array([2, 3]), "clamp": np.array([3, 2])})


def write(path, **grid) -> Path:
    """Write :func:`plate_mesh` to ``path`` as Gmsh MSH 2.2 (ASCII)."""
    path = Path(path)
    meshio.write(path, plate_mesh(**grid), file_format="gmsh22", binary=False)
    return path


if __name__ == "__main__":
    out = Path(sys.argv[1]) if len(sys.argv) > 1 else Path(__file__).with_name("plate.msh")
    print(f"wrote {write(out)}")
