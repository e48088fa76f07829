"""Builders of modal systems from structures the user describes (issue 58).

* :mod:`.matrices` -- a lumped or finite-element model given by its mass, stiffness and damping
  matrices (dense or ``scipy.sparse``), reduced to its lowest undamped modes with named degrees of
  freedom for the sensor, the contact points and the static deflection ratios.
* :mod:`.continuum` -- a 3D linear-elastic solid (the rig from its geometry, or a mesh meshio reads
  with named regions), a rigid body tied to it for the contact, reduced through :mod:`.matrices`
  (issue 59).

Builders are table-free: numbers in SI, no case keys; they return plain data and import nothing of
the framework.
"""
