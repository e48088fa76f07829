"""One isolated contact through the event integrator: the oracle case of a compliant law.

A body of effective mass ``m_eff`` (the free, undamped, unforced modal system: ``omega = c = B = 0``)
hits a stop of a compliant law at normal speed ``v_in`` and leaves it where the contact force
returns to zero.  Its restitution ``R = -U(t_exit) / v_in``, the duration, the peak force, the
largest penetration and the work done on the stop are properties of the law alone (for
Kelvin-Voigt in closed form, :func:`vibeam.models.compliant.restitution_of_damping_ratio` and
:func:`vibeam.models.compliant.contact_duration`; for hysteretic Hertz the first-order energy
balance ``E = (2/3) chi v_in^2`` of :mod:`vibeam.models.compliant`): the tests compare them with
what the kernels' contact phases give, step for step as in a sweep.
"""
from __future__ import annotations

import math

import numpy as np

from ..contact import LAW_LINEAR, Relation, Stop
from ..system import modal_system
from .event import EventIntegrator
from ..scene import Scene

__all__ = ["isolated_contact"]


def isolated_contact(law, v_in: float, row=(1.0,)) -> tuple:
    """One contact of the free modal system with contact row ``row`` (shape (n,); ``m_eff = 1 /
    |row|^2``) on a stop of ``law`` (in the system's units) entered at normal speed ``v_in > 0``.

    Parameters
    ----------
    law : vibeam.models.compliant.LinearContact or HystereticHertz
        The law, its stiffness in the system's units (per unit ``m_eff`` for ``row = (1,)``).
    v_in : float
        Entry speed (row units per unit time).
    row : array_like, shape (n,)
        Contact row of the modes (all ``omega = 0``).

    Returns
    -------
    R, duration, peak_force, penetration, energy : float
        ``-U(t_exit) / v_in`` and the contact's record (system units: forces and works as the
        kernel records them, i.e. per unit of the modal mass).

    Raises
    ------
    ValueError
        If the contact does not end within the run (it always does for these laws).
    """
    w = np.atleast_1d(np.asarray(row, dtype=float))
    n = w.size
    sy = modal_system(np.zeros(n), np.zeros(n), np.zeros(n), w, w[None, :], 0.0)
    core = EventIntegrator(Scene(sy, (Stop(Relation(1.0, 0.0), law),)))
    nn = float(w @ w)
    # the contact's time scale: the undamped linear one, or the Hertz one (penetration over speed)
    p = 1.0 if law.code == LAW_LINEAR else float(law.exponent)
    pen = ((p + 1.0) * v_in * v_in / (2.0 * law.stiffness * nn)) ** (1.0 / (p + 1.0))
    t_c = max(math.pi / math.sqrt(law.stiffness * nn), pen / v_in) if law.code == LAW_LINEAR else pen / v_in
    Om = 2.0 * math.pi / (40.0 * t_c)            # one forcing period: 40 contact time scales
    etad = w * v_in / nn                          # on the stop (g = 0), U = n^T eta' = v_in
    run = core.run(Om, np.zeros(n), etad, 0, 0, 1, 16, 16, 2.0 * math.pi / Om / 16.0, 1000, 10 ** 7, 1e-7)
    con = run.record.con[0]
    if not np.isfinite(con[0]):
        raise ValueError("the isolated contact did not end within the run")
    U = float(w @ run.etad)
    return -U / v_in, float(con[0]), float(con[1]), float(con[2]), float(con[3])
