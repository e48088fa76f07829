"""Modal truncation of the finite-element beam.

With ``u = Phi_N q`` (``Phi_N``: the ``N`` lowest mass-normalised modes of
:meth:`vibeam.models.builders.beam_fe.BeamFE.modes`) the FE equations
``M u'' + C u' + K u = F b''`` (``F = -M r``, paper Eq. 39) become::

    q'' + Phi_N^T C Phi_N q' + diag(omega^2) q = (Phi_N^T F) b''

and the contact/sensor displacements are ``w(L_m) = (w^T Phi_N) q``,
``w(L_S) = (s^T Phi_N) q``.  The apparent (effective) mass at the contact point,
which sets the velocity jump of an impulsive contact force, is
``m_eff = 1 / (w^T M^-1 w)``; in the retained basis ``M^-1 ~ Phi_N Phi_N^T`` so
``m_eff(N) = 1 / sum_{i<=N} (w^T phi_i)^2``.  It *decreases* monotonically with ``N``
(every mode adds a non-negative term) to the full-model value ``1 / (w^T M^-1 w)``
at ``N = ndof``, which itself tends to the attached mass ``m`` from above as the
mesh is refined (``O(rhoA h)``).

References
----------
M. Geradin, D. Rixen, *Mechanical Vibrations*, 3rd ed., Wiley 2015, Ch. 2 (modal
superposition, effective masses); paper Eq. 39, 42.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from vibeam.models.builders.beam_fe import BeamFE

__all__ = ["ModalReduction", "modal_reduction", "contact_effective_mass_kg"]


@dataclass(frozen=True)
class ModalReduction:
    """Reduced-order model in modal coordinates ``q`` (units sqrt(kg) m).

    Attributes
    ----------
    n_modes : int
    omega_rad_s, frequencies_hz : ndarray, shape (N,)
    shapes : ndarray, shape (ndof, N)
        Mass-normalised modes (1/sqrt(kg)).
    M : ndarray, shape (N, N)
        Identity.
    K : ndarray, shape (N, N)
        ``diag(omega^2)`` (1/s^2).
    C : ndarray, shape (N, N)
        ``Phi^T C Phi`` (1/s); diagonal ``2 zeta_i omega_i`` for Rayleigh damping,
        with ``zeta_i = D omega_i / 2`` for ``C = D K``.
    load : ndarray, shape (N,)
        ``Phi^T F`` per unit base acceleration, ``= -Gamma`` (sqrt(kg)).
    contact_row, sensor_row : ndarray, shape (N,)
        ``w^T Phi``, ``s^T Phi`` (1/sqrt(kg)).
    contact_effective_mass_kg : float
        ``1 / sum_i (w^T phi_i)^2``.
    """

    n_modes: int
    omega_rad_s: np.ndarray
    frequencies_hz: np.ndarray
    shapes: np.ndarray
    M: np.ndarray
    K: np.ndarray
    C: np.ndarray
    load: np.ndarray
    contact_row: np.ndarray
    sensor_row: np.ndarray
    contact_effective_mass_kg: float

    def physical(self, q) -> np.ndarray:
        """Back to FE free DOFs: ``Phi q``; ``q`` shape ``(N,)`` or ``(N, k)``."""
        return self.shapes @ np.asarray(q)


def _n(fe: BeamFE, n_modes) -> int:
    if isinstance(n_modes, str):
        if n_modes != "all":
            raise ValueError(f"n_modes must be a positive int or 'all', got {n_modes!r}")
        return fe.ndof
    n = int(n_modes)
    if not 1 <= n <= fe.ndof:
        raise ValueError(f"n_modes must be in 1..{fe.ndof}, got {n}")
    return n


def modal_reduction(fe: BeamFE, n_modes: int | str = "all") -> ModalReduction:
    """Truncate the FE model to its ``n_modes`` lowest modes.

    Parameters
    ----------
    fe : BeamFE
    n_modes : int or "all"

    Returns
    -------
    ModalReduction

    Raises
    ------
    ValueError
        If ``n_modes`` is not ``"all"`` or an int in ``1..ndof``.
    """
    n = _n(fe, n_modes)
    md = fe.modes(n)
    P = md.shapes
    cw = fe.contact_row @ P
    return ModalReduction(
        n_modes=n, omega_rad_s=md.omega_rad_s, frequencies_hz=md.frequencies_hz, shapes=P,
        M=np.eye(n), K=np.diag(md.omega_rad_s**2), C=P.T @ fe.C @ P, load=P.T @ fe.base_load,
        contact_row=cw, sensor_row=fe.sensor_row @ P,
        contact_effective_mass_kg=float(1.0 / np.sum(cw**2)))


def contact_effective_mass_kg(fe: BeamFE, n_modes: int | str = "all") -> float:
    """``m_eff = 1 / sum_{i<=N} (w^T phi_i)^2`` (kg); ``"all"`` equals
    :meth:`BeamFE.contact_effective_mass_kg`.

    Raises
    ------
    ValueError
        As :func:`modal_reduction`.
    """
    n = _n(fe, n_modes)
    cw = fe.contact_row @ fe.modes(n).shapes
    return float(1.0 / np.sum(cw**2))
