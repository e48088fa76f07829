"""Measured FRC points that a fit or an identification is compared with (``--reference``):
a CSV table or a run of a vibeam results file."""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from vibeam.errors import case_error
from vibeam.io.inputs import check_input_file, read_frc_table
from vibeam.io.results import read_results


@dataclass
class Reference:
    """Measured FRC points.

    Attributes
    ----------
    source : str
        File (and run) the points come from.
    x_name, y_name : str
        ``frequency_hz`` / ``amplitude_mm`` (physical) or ``Omega`` / ``amplitude``.
    x, y : ndarray, shape (n,)
    direction : ndarray of str, shape (n,)
        ``up`` or ``down``: the sweep direction each point was measured in.
    sigma : ndarray, shape (n,) or None
        Standard deviation of each amplitude (units of ``y``).
    notes : list of str
    """

    source: str
    x_name: str
    y_name: str
    x: np.ndarray
    y: np.ndarray
    direction: np.ndarray
    sigma: np.ndarray | None
    notes: list = field(default_factory=list)

    @property
    def n(self) -> int:
        return int(self.x.size)

    @property
    def physical(self) -> bool:
        return self.x_name == "frequency_hz"


_PAIRS = (("frequency_hz", "amplitude_mm"), ("Omega", "amplitude"))


def read_reference(path, run: str | None = None) -> Reference:
    """Read measured points: a CSV or a vibeam results file (HDF5).

    CSV: :func:`vibeam.io.inputs.read_frc_table`, the one reader of measured and reference
    tables (``vibeam regress`` reads them too): a header naming ``frequency_hz,amplitude_mm``
    (physical) or ``Omega,amplitude``, optionally ``direction`` (``up``/``down``, default
    ``up``) and ``sigma`` (standard deviation of the amplitude, same unit, > 0); frequencies
    > 0, amplitudes >= 0; ``#`` lines are comments.  HDF5: the run ``run`` of a results
    file (or its only run); all its points with both directions,
    ``frequency_hz``/``amplitude_mm`` when present, failed points left out.

    Raises
    ------
    vibeam.case.schema.CaseError
        On a file that is not a regular file or is larger than 10 MB, a missing or unknown
        column, a row with missing or extra values, a value out of range, a direction other
        than up/down, a sigma <= 0, no points, or a run not in the file; ``run`` given for a
        CSV file (it names a run of a results file only).
    """
    path = Path(path)
    if path.suffix.lower() in (".h5", ".hdf5"):
        return _read_h5_reference(path, run)
    if run is not None:
        raise case_error(f"{path}: '--reference-run' = {run!r} is not allowed with a CSV reference; allowed: "
                         f"--reference-run names a run of a results.h5 reference only (leave it out)")

    t = read_frc_table(path, "reference file")
    return Reference(t.source, t.x_name, t.y_name, t.x, t.y, t.direction, t.sigma)


def _read_h5_reference(path: Path, run: str | None) -> Reference:
    check_input_file(path, "results file")
    try:
        res = read_results(path)
    except (OSError, KeyError, ValueError) as e:
        why = getattr(e, "strerror", None) or (str(e).splitlines()[0] if str(e) else type(e).__name__)
        raise case_error(f"{path}: cannot read results file: {why}") from None
    runs = res.get("runs", {})
    if not runs:
        raise case_error(f"{path}: no runs in the results file")
    if run is None:
        if len(runs) > 1:
            raise case_error(f"{path}: {len(runs)} runs; name the reference with --reference-run, one of: "
                         f"{', '.join(repr(r) for r in runs)}")
        run = next(iter(runs))
    if run not in runs:
        raise case_error(f"{path}: '--reference-run' = {run!r} is not a run of the file; allowed: "
                     f"{', '.join(repr(r) for r in runs)}")
    d = runs[run]
    pair = next((p for p in _PAIRS if p[0] in d and p[1] in d), None)
    if pair is None:
        raise case_error(f"{path}: run {run!r} has neither frequency_hz/amplitude_mm nor Omega/amplitude")
    x = np.asarray(d[pair[0]], float)
    y = np.asarray(d[pair[1]], float)
    dirs = np.array([str(v) for v in d.get("direction", ["up"] * x.size)], dtype=object)
    status = np.array([str(v) for v in d.get("status", ["ok"] * x.size)])
    keep = np.isfinite(x) & np.isfinite(y) & (status != "failed")
    notes = []
    if (~keep).any():
        notes.append(f"{int((~keep).sum())} failed reference point(s) left out")
    if not keep.any():
        raise case_error(f"{path}: run {run!r} has no usable points")
    return Reference(f"{path} (run {run!r})", pair[0], pair[1], x[keep], y[keep], dirs[keep], None, notes)
