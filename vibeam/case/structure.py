"""A structure given by its matrices, built from its case tables (issue 58).

The canonical tables of :class:`vibeam.case.schema.MatricesModelSpec` -- ``[model.system]``
(``builder = "matrices"``), ``[[model.stop]]`` and ``[model.excitation]`` -- to the reduced
structure (:func:`matrix_model`: :func:`vibeam.models.builders.matrices.build_matrices` on the
matrices read by :mod:`vibeam.io.matrices`) and to its N-mode impact model (:func:`impact_model`:
:class:`vibeam.models.beam_dynamics.MatrixImpactModel`, every method of the N-mode model).

Loaded only when a structure is built (``load_case`` stays free of scipy.io and the kernels).
"""
from __future__ import annotations

from vibeam.case.contact import ContactSpec, beam_law
from vibeam.io.matrices import inline_matrices, read_matrices
from vibeam.models.beam_dynamics import CompliantBeamModel, MatrixImpactModel, PointStop
from vibeam.models.builders.matrices import MatrixModel, build_matrices
from vibeam.models.contact import Restitution
from vibeam.models.registry import is_compliant

__all__ = ["arrays", "matrix_model", "impact_model"]


def arrays(system) -> dict:
    """``{M, K, C, dofs, r, Mr}`` of a ``[model.system]`` table (:class:`vibeam.case.schema.SystemSpec`),
    read and checked: an ``.npz`` archive, MatrixMarket files (absolute paths: the case's relative
    ones were made absolute at load) or inline rows, each by :mod:`vibeam.io.matrices`' one check.

    Raises
    ------
    vibeam.errors.InputError
        A file that cannot be read or holds what is not allowed (one line).
    """
    given = {k: getattr(system, k) for k in ("M", "K", "C") if getattr(system, k) is not None}
    if system.matrices is not None:
        m = read_matrices(system.matrices)
    elif all(isinstance(v, str) for v in given.values()):
        m = read_matrices(given)
    else:
        m = inline_matrices(given)
    dofs = tuple(system.dofs) if system.dofs is not None else m.dofs
    r = system.base if system.base != "all" else (m.r if m.r is not None else "all")
    return {"M": m.M, "K": m.K, "C": m.C, "dofs": dofs, "r": r, "Mr": m.Mr}


def _at(spec, st) -> str:
    return st.at or spec.system.sensor


def matrix_model(spec) -> MatrixModel:
    """The structure of ``spec`` (:class:`vibeam.case.schema.MatricesModelSpec`) reduced to its
    modes: contact row 0 at the reference stop's DOF, then one row per further stop away from it.

    Raises
    ------
    ValueError
        From :func:`~vibeam.models.builders.matrices.build_matrices` (one line: a DOF that does not
        exist, a damping that couples the modes, ...); :class:`vibeam.errors.InputError` from the reading.
    """
    sy = spec.system
    a = arrays(sy)
    if a["C"] is not None and sy.damping_ratios is not None:
        raise ValueError("give the damping as a matrix C or as damping_ratios, not both")
    others = [_at(spec, st) for st in spec.stop[1 + int(spec.two_sided):]]
    return build_matrices(a["M"], a["K"], C=a["C"], damping_ratios=sy.damping_ratios if a["C"] is None else None,
                          r=a["r"], Mr=a["Mr"], dofs=a["dofs"], sensor=sy.sensor,
                          contacts=[_at(spec, spec.stop[0]), *others], n_modes=sy.n_modes,
                          base_amplitude_m=spec.excitation.amplitude_mm * 1e-3, f_ref_hz=sy.f_ref_hz,
                          length_m=sy.length_mm * 1e-3)


def impact_model(spec):
    """The N-mode impact model of ``spec``: the reference stop (upper) at contact row 0 with its
    law, a lower stop at its DOF with its own (any law), Newton stops at other DOFs; gaps
    ``contact_gap_mm`` at the stop, or ``gap_mm`` at the sensor times the DOF's static ratio
    (paper Eq. 45's ``Delta_C = phi Delta_G``).

    Returns
    -------
    vibeam.models.beam_dynamics.MatrixImpactModel or CompliantBeamModel
        Fidelity ``"matrices"`` either way.
    """
    mm = matrix_model(spec)

    def gap_m(st, k):
        mm_gap = st.contact_gap_mm if st.contact_gap_mm is not None else st.gap_mm * float(mm.contact_static[k])
        return mm_gap * 1e-3

    up = spec.stop[0]
    kw = {}
    if spec.two_sided:
        lo = spec.stop[1]
        kw = dict(gap_contact_lower_m=gap_m(lo, 0), R_lower=None if is_compliant(lo.law) else lo.R)
    first_point = 1 + int(spec.two_sided)
    points = [(PointStop(position_m=float("nan"), sign=1.0 if st.side == "upper" else -1.0,
                         gap_contact_m=gap_m(st, 1 + j), law=Restitution(st.R),
                         label=f"{st.side} at {_at(spec, st)}"), 1 + j)
              for j, st in enumerate(spec.stop[first_point:])]
    m = MatrixImpactModel.from_matrix_model(mm, R=up.R, gap_contact_m=gap_m(up, 0),
                                            base_amplitude_m=spec.excitation.amplitude_mm * 1e-3,
                                            point_stops=points, **kw)
    law = beam_law(spec.contact, up.R)
    lower = None
    if spec.two_sided and is_compliant(spec.stop[1].law):
        lower = beam_law(ContactSpec(**spec.stop[1].law_table()), spec.stop[1].R)
    if law is not None:
        if spec.two_sided and lower is None:
            lower = Restitution(spec.stop[1].R)
        m = CompliantBeamModel.from_model(m, law, lower)
        m.fidelity = "matrices"      # the compliant modal model of this structure
    elif lower is not None:
        m.lower_law = lower
    return m
