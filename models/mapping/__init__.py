"""Method ``mapping``: one pointwise mapping of the one-mode system (paper Sec. 4.2, Eqs. 28-37).

A section is an arrival at any stop; the passage through the stop is its law's (Newton's reset,
the exact Kelvin-Voigt contact phase, the integrated hysteretic-Hertz one), the flight to the
next arrival the closed-form flow with certified event location; period-n orbits are zeros of one
multiple-shooting residual (:mod:`.orbit`), solved (damped Newton, :mod:`.newton`, shared with the
N-mode map of :mod:`.modal`) and analysed by :class:`MappingSolver` (:mod:`.solver`).  The paper's
impact map of one Newton stop and its formulas are :mod:`.paper`; the phases and their certified
step :mod:`.phases`; the averaging start of the shooting problem :mod:`.start`.
"""
from .paper import (fixed_point_analysis, impact_map, impact_map_jacobian, is_admissible, monodromy,
                    newton_fixed_point, next_impact, orbit_extremes, paper_det_trace, stable_from_det_trace)
from .solver import MappingSolver, event_guess

__all__ = ["MappingSolver", "event_guess", "fixed_point_analysis", "impact_map", "impact_map_jacobian",
           "is_admissible", "monodromy", "newton_fixed_point", "next_impact", "orbit_extremes", "paper_det_trace",
           "stable_from_det_trace"]
