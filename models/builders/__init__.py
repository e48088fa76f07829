"""Builders of modal systems from structures the user describes (issue 58).

* :mod:`.matrices` -- a lumped or finite-element model given by its mass, stiffness and damping
  matrices (dense or ``scipy.sparse``), reduced to its lowest undamped modes with named degrees of
  freedom for the sensor, the contact points and the static deflection ratios.

Builders are table-free: numbers in SI, no case keys; they return plain data and import nothing of
the framework.
"""
