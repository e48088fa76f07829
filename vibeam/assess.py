"""Assessments (``[assess]`` of a case): spectra, modal participation, time series.

:func:`hooks` returns the per-point assessment callables that the sweep applies
to each recorded :class:`vibeam.records.Trajectory` (empty when the case asks
for none); :func:`finish` writes what needs the whole case (plots overlaying
runs).
"""
from __future__ import annotations


def hooks(case, spec, run, model) -> tuple:
    """Per-point assessment callables for one run (empty: nothing extra is computed)."""
    return ()


def finish(case, runs, out_dir) -> list:
    """Case-level assessment outputs (plots); returns the written paths."""
    return []
