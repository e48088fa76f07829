"""The composable core of vibeam's dynamics (issue 20): one system, stops, one event integrator.

Layout follows the mathematics (Siconos' split of a nonsmooth simulation):

* :mod:`vibeam.models.system` -- the one dynamical system, a base-excited modal system (the SDOF
  is its one-mode case, the FE beam its ``N``-mode case);
* :mod:`.stops` -- stops as (relation, law) pairs in kernel form, and the system held on any set
  of them;
* :mod:`.signals` -- signals of a linear flow and their certified scan (event location);
* :mod:`.integrator` -- the one event integrator (numba), its output record and event log;
* :mod:`.event` -- its Python driver (:class:`~.event.EventIntegrator`).
"""
