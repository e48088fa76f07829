"""The averaging start of the shooting problem (:data:`vibeam.models.registry.STARTS`): the paper's
averaged period-1 orbit of the one-mode oscillator (Sec. 4.1) refined on its impact map (Sec. 4.2).

It lives beside the map it is refined on, above the core whose shooting problem asks for it by
name (:meth:`vibeam.models.core.scene_shooting.SceneShooting.start`).
"""
from __future__ import annotations

import math

import numpy as np

from ..paper.averaging import solve
from ..scene import one_mode
from ..system import modal_flow
from .paper import is_admissible, newton_fixed_point


def shooting_start(prob, scene, system, Omega, p):
    """The averaging start of the shooting problem (:data:`vibeam.models.registry.STARTS`): the
    upper averaging branch (paper Eqs. 18-23, ``k = 1``), refined where it converges to an
    admissible orbit by Newton on the impact map (Eqs. 33-34,
    :func:`vibeam.models.mapping.newton_fixed_point`), turned into the post-impact state and
    carried by the free flow to the next forcing phase 0.

    Parameters
    ----------
    prob : vibeam.models.core.scene_shooting.SceneShooting
        The shooting problem (its ``parameter`` names the value in messages; its ``shot`` checks a
        two-stop scene's lower stop).
    scene : vibeam.models.scene.Scene
        The one-mode scene at ``p`` (:func:`vibeam.models.scene.one_mode`).
    system : vibeam.models.system.ModalSystem
        Its modal system.
    Omega : float
        Forcing frequency (nondimensional).
    p : float
        The parameter's value.

    Returns
    -------
    x0 : ndarray, shape (2,) or None
        ``(q, q')`` at forcing phase 0 (nondimensional).
    reason : str
        Empty when the orbit exists, else why not (no real averaged amplitude; the orbit reaches
        the lower stop).

    Raises
    ------
    ValueError
        If ``scene`` is not the one-mode oscillator.
    """
    one = one_mode(scene, "the averaging start")
    R, Delta = float(one.stops[0].law.R), float(one.Delta)
    r = solve(Omega, one.beta, one.B, R, Delta, 1)
    Q = float(r["amplitude"])
    if not np.isfinite(Q):
        return None, f"averaging has no real amplitude at {prob.parameter} = {p:.6g}"
    phi, v = float(r["impact_phase"]), Q
    fp = newton_fixed_point(scene, Omega, (phi, v), 1)
    if fp is not None and is_admissible(scene, Omega, fp, 1)[0]:
        phi, v = float(fp[0]), float(fp[1])
    two_pi = 2.0 * math.pi
    t = ((two_pi - phi) % two_pi) / Omega
    q, w = modal_flow(system, phi / Omega, phi / Omega + t, np.array([Delta]), np.array([-R * v]), Omega)
    x0 = np.array([q[0], w[0]])
    if len(scene.stops) > 1:
        # the averaged orbit is a one-stop orbit: admissible only if it stays off the lower stop
        sh = prob.shot(x0, p, 1)
        Dl = float(one.Delta_lower)
        if sh.status != "ok" or np.any(sh.extra["impact_stops"] == 1) or sh.q_min <= -Dl:
            return None, (f"the averaging orbit reaches the lower stop Delta_lower = {Dl:.6g} at "
                          f"{prob.parameter} = {p:.6g}")
    return x0, ""
