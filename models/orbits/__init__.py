"""Dynamics of the stroboscopic map built on the core's one shooting problem.

* :mod:`.continuation` -- pseudo-arclength continuation of period-n orbits, their Floquet
  multipliers and bifurcations (fold, period doubling, Neimark-Sacker, grazing).
* :mod:`.lyapunov` -- Lyapunov exponents of the map from the monodromy along an orbit.
* :mod:`.attractors` -- attractors of the map by recurrences on a cell grid, and their basins of
  attraction.

Each takes a shooting problem (contract: :mod:`vibeam.models.core.periodic`) or a map, and knows
nothing of the structure or the fidelity.
"""
