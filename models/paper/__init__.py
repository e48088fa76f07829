"""The paper's methods for the one-mode scene with one or two stops (Sec. 3-4), above the core.

* :mod:`.ode` -- the three scipy time integrations of Sec. 3: direct with event location
  (``direct``), and after Zhuravlev's (``zhuravlev``, Eqs. 4-8) and Ivanov's (``ivanov``,
  Eqs. 9-15) transformations.
* :mod:`.averaging` -- averaging after Zhuravlev's transformation (Sec. 4.1, Eqs. 16-27).

The pointwise mapping (Sec. 4.2) is its own room, :mod:`vibeam.models.mapping`.  Each method checks
that the scene has its one mode and refuses any other in one line.
"""
