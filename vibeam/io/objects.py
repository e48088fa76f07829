"""The result objects of runs and maps: plain data that the engine fills, the results writer
writes and reads back (:func:`vibeam.io.results.load_results`), and the plots draw.

:class:`SweepResult` (a run: per-point arrays over the visited frequencies; built by
:func:`vibeam.engine.sweep.run_sweep`) and :class:`MapResult` (a parameter map; built by
:func:`vibeam.analysis.maps.assemble_map`) live here, below the engine and the analyses, so that
reading a results file needs neither.
"""
from __future__ import annotations

from dataclasses import dataclass, field


@dataclass
class SweepResult:
    """Per-point outputs of one run; ``data`` maps dataset names to arrays of length n_points."""

    name: str
    fidelity: str
    method: str
    settings: dict
    data: dict
    wall_time_s: float
    attrs: dict = field(default_factory=dict)

    @property
    def n_points(self) -> int:
        return len(self.data["Omega"])

    def __repr__(self) -> str:
        """``SweepResult('exact': event, 202 points, 25 variables)``: never the arrays."""
        return f"{type(self).__name__}({self.name!r}: {self.method}, {self.n_points} points, {len(self.data)} variables)"



@dataclass
class MapResult:
    """One run of a parameter map.

    Attributes
    ----------
    name, fidelity, method : str
    settings : dict
        Method settings.
    parameter : str
        The mapped model key (e.g. ``voltage``, V; ``gap_mm``, mm).
    data : dict
        ``values`` (n_values,), ``direction`` (n_directions,), and per-point
        datasets of shape ``(n_directions, n_values, n_frequencies, ...)`` in
        increasing frequency: ``Omega``, ``classification``, ``period``,
        ``amplitude``, ``impacts_per_period``, ``status``, ``message``, and
        ``frequency_hz``/``amplitude_mm`` for physical scenes.
    wall_time_s : float
        Compute time summed over the map's points (s).
    attrs : dict
    """

    name: str
    fidelity: str
    method: str
    settings: dict
    parameter: str
    data: dict
    wall_time_s: float
    attrs: dict = field(default_factory=dict)

    @property
    def shape(self) -> tuple:
        return self.data["classification"].shape

    def __repr__(self) -> str:
        """``MapResult('exact': gap_mm, shape (2, 8, 61), 20 variables)``: never the arrays."""
        return (f"{type(self).__name__}({self.name!r}: {self.parameter}, shape {self.shape}, "
                f"{len(self.data)} variables)")
