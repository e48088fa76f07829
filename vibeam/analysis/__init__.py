"""Analyses built on the engine: parameter maps, continuation runs, basins of attraction and
attractors, assessments, the cost of accuracy and regression against references."""
