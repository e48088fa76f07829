"""Builders of scenes (issue 58): each makes a :class:`vibeam.models.scene.Scene` (a modal system, its
stops, its drive) from what describes a structure; its module's ``BUILDERS`` names the fidelities.

* :mod:`.sdof` -- the paper's SDOF impact oscillator (Eqs. 1-2, 43-47).
* :mod:`.beam` -- the FE cantilever with its attached mass, any number of modes, or its static mode
  (Eqs. 39-47).
* :mod:`.matrices` -- a lumped or finite-element model given by its mass, stiffness and damping
  matrices (dense or ``scipy.sparse``), reduced to its lowest undamped modes with named degrees of
  freedom for the sensor, the contact points and the static deflection ratios; and
  :func:`.matrices.modal_scene`, the one packing of a reduced structure into a scene.
* :mod:`.continuum` -- a 3D linear-elastic solid (the rig from its geometry, or a mesh meshio reads
  with named regions), a rigid body tied to it for the contact, reduced through :mod:`.matrices`
  (issue 59).

Builders are table-free: numbers in SI, no case keys; they return plain data and import nothing of
the framework.
"""
