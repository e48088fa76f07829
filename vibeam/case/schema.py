"""Case files: a scene (model, sweep, runs to compare) read from TOML and validated.

A case file names its model with the paper's symbols, e.g.::

    name = "paper-fig7"
    [model]
    fidelity = "sdof"
    beta = 0.015
    B = 0.5e-3
    R = 0.9
    Delta = 0.0
    [sweep]
    Omega = [1.5, 2.5, 101]   # start, stop, number of points
    direction = "up"          # up | down | both
    transient_periods = 400
    record_periods = 64
    [[run]]
    name = "exact"
    method = "event"

or, for a physical scene of the paper's rig (Eqs. 43-46), ``natural_frequency_hz``,
``damping_ratio``, ``R``, ``gap_mm``, ``length_mm``, ``gain``, ``voltage`` with
``[sweep] frequency_hz = [start, stop, n]``.  A run may override model keys in
a ``[run.model]`` table.  Every key is checked: unknown keys, wrong types and
out-of-range values raise :class:`CaseError` with one message that names the
key, the value and what is allowed.
"""
from __future__ import annotations

import dataclasses
import math
import re
import tomllib
import warnings
from pathlib import Path
from typing import Annotated, ClassVar, Literal, Union

import numpy as np
from vibeam.case.uncertainty import UncertaintySpec
from vibeam.case.contact import (ContactSpec, StopSpec, beam_law,  # [model.contact] (issue 13), [[model.stop]]
                                 RestitutionValue, model_with, sdof_law, target_R)
from vibeam.case.expand import SHORTHAND_FIDELITIES, SHORTHAND_KEYS, aliases, expanded, required_keys, user_key
from vibeam.case.paths import alias_of, canonical, flat_key, get_value, is_canonical, is_path, parameter_paths
from vibeam.io.inputs import read_input_text
from vibeam.models.registry import fidelity, is_compliant, law_key, supported_methods
from vibeam.errors import CaseError, InputError, one_line, quote_value  # noqa: F401 (re-exported)
from pydantic import (BaseModel, ConfigDict, Field, PrivateAttr, ValidationError, field_validator,
                      model_validator)


class _Strict(BaseModel):
    # NaN and infinities make no sense anywhere in a scene (grids, physical parameters, tolerances)
    model_config = ConfigDict(extra="forbid", strict=True, frozen=True, allow_inf_nan=False)


# ----------------------------------------------------------------------------- model
#: the nondimensional forcing amplitude ``B`` (``gain x voltage`` of a physical scene, paper
#: Eq. 43) a scene may give, 0 apart.  The model is exactly homogeneous in ``(B, Delta, q)``
#: (Eqs. 1-2), so nothing is lost by rescaling a scene into this range; outside it the numbers
#: are not computable in double precision: the kernels form squares and fourth powers of the
#: motion's scale (energies ``(1 - R^2) v^2 / 2``, the envelope ``sqrt(x^2 + w^2)``, the
#: bounds ``C Omega^4`` of the certified scan), which overflow from ``B ~ 1e154`` (measured:
#: ``amplitude / B`` drifts by 2e-5 at B = 1e200 at Delta = 0), and below ``~1e-154`` they fall
#: into subnormals, where precision is lost and no step can be certified (``B = 1e-310``: the
#: period changes and a point takes 10^3 times longer; ``B = 5e-320`` never returns).  The
#: bounds leave a factor 1e54 of headroom for the powers of Omega in those products.
B_RANGE = (1e-100, 1e100)
#: largest stiffness of a compliant stop in kernel units (SDOF: ``k_c / k``): the contact's
#: natural frequency ``sqrt(1 + k_c)`` must leave its steps (1/16 of its period) resolvable
#: against the time within a forcing period (an ulp of 2 pi is 9e-16; at 1e20 a step is 4e-11)
#: and the bounds of the contact scan (``~k_c^3.5`` times the scale) finite; ``1e300`` hung
#: every kernel.  Stiffer stops than ~1e8 are refused or failed by the work limit anyway.
MAX_CONTACT_STIFFNESS = 1e20


def check_scale(value: float, key: str) -> None:
    """Refuse a forcing amplitude outside :data:`B_RANGE` (0 allowed).

    Raises
    ------
    CaseError
        Naming ``key``, the value and the allowed range.
    """
    lo, hi = B_RANGE
    if value != 0.0 and not lo <= abs(value) <= hi:
        raise CaseError(f"{key} = {value:.6g}: not computable in double precision; allowed: 0 or "
                        f"{lo:g} <= |B| <= {hi:g} (the model is homogeneous in B and Delta: rescale "
                        f"the scene's lengths instead)")


#: the largest gap of a stop in the model's own units (the nondimensional ``Delta``; a physical gap
#: over the beam's length): the model is homogeneous in ``(B, Delta, q)`` (Eqs. 1-2), so a gap is
#: computable exactly where a forcing amplitude is (:data:`B_RANGE`): the kernels square the
#: motion's scale, which the gap sets once the stop is far (``Delta = 1e308``: every point failed
#: with infinite spreads, exit 3; ``1e200`` an amplitude no later check can tell from an overflow)
GAP_MAX = B_RANGE[1]


def check_gap(value, key: str, length_mm: float | None = None) -> None:
    """Refuse a stop's gap beyond :data:`GAP_MAX` (``value`` nondimensional, or in mm over
    ``length_mm``); None passes.

    Raises
    ------
    CaseError
        Naming ``key``, the value and the allowed range.
    """
    if value is None:
        return
    g = value / length_mm if length_mm else value
    if not abs(g) <= GAP_MAX:
        what = f" ({g:.3g} beam lengths)" if length_mm else ""
        raise CaseError(f"{key} = {value:.6g}{what}: not computable in double precision; allowed: |gap| <= "
                        f"{GAP_MAX:g}{' lengths' if length_mm else ''} (the model is homogeneous in B and Delta, "
                        f"as B's range: rescale the scene instead)")


def check_stiffness(law, key: str) -> None:
    """Refuse a compliant law stiffer than :data:`MAX_CONTACT_STIFFNESS` (kernel units)."""
    k = getattr(law, "stiffness", None)
    if k is not None and not k <= MAX_CONTACT_STIFFNESS:
        raise CaseError(f"{key}: the stop's stiffness is {k:.6g} in kernel units (k_c / k), whose contact "
                        f"cannot be resolved in double precision; allowed: at most {MAX_CONTACT_STIFFNESS:g}")


class _StopsSpec(_Strict):
    """What the model tables of both fidelities share: the stops' case keys as continuation
    parameters."""

    #: the fidelity of the shorthand the table was written in (:func:`_validate_model`), else None
    _shorthand: str | None = PrivateAttr(default=None)

    def as_written(self, exclude_unset: bool = False) -> dict:
        """The validated ``[model]`` a run stores with its results (``attrs["model"]``, read by the
        figures' subtitles): the canonical tables, or, written in the shorthand, its keys with the
        scene's values (:data:`vibeam.case.expand.SHORTHAND_KEYS`; the stops away from the attached
        mass as ``stop``)."""
        if self._shorthand is None:
            return self.model_dump(exclude_unset=exclude_unset)
        out = {"fidelity": self._shorthand}
        values = self.shorthand()
        for k in SHORTHAND_KEYS[self._shorthand][1:]:      # after fidelity
            v = values.get(k)                               # "stop": the point stops, below
            out[k] = v.model_dump() if isinstance(v, BaseModel) else v
        points = getattr(self, "point_stop_tables", None)
        out["stop"] = [st.model_dump() for st in points] or None if points is not None else None
        return out

    def stiffness_key(self):
        """``(case key, value)`` of the paper's stop's contact stiffness when the case gives it in
        N/m^p (``model.contact.stiffness_n_m``); None otherwise (Newton's law, or a stiffness
        given nondimensional, whose key is ``model.contact.stiffness``)."""
        t = mass_law_tables(self)[0]
        if t is not None and t.stiffness is None and t.stiffness_n_m is not None:
            return "model.contact.stiffness_n_m", float(t.stiffness_n_m)
        return None

    def scene(self):
        """The :class:`vibeam.models.scene.Scene` this table describes: what every method takes
        (its ``builder`` names the fidelity; :func:`vibeam.models.make_solver`).

        Raises
        ------
        CaseError
            If the scene cannot be built from these values (:func:`build_or_refuse`).
        """
        return build_or_refuse(self, self._scene)


def build_or_refuse(spec, build):
    """``build()``, the scene (or the reduced structure) of a ``[model]`` spec; a value its builder
    cannot use (it raises ValueError, or an arithmetic error such as an overflow) becomes a
    :class:`CaseError` of one line naming the fidelity and the reason, so a case whose
    numbers pass the table's validators but make no model is refused like any bad input
    (``vibeam`` exit 2; a fit counts such a trial as a failed evaluation).  Warnings of a
    build that fails are dropped (the error says what went wrong); those of a build that
    succeeds are issued as they were."""
    with warnings.catch_warnings(record=True) as caught:   # kept back: a refused build says one line
        warnings.simplefilter("always")
        try:
            model = build()
        except CaseError:
            raise
        except (ValueError, ArithmeticError) as e:
            raise CaseError(one_line(f"'model' (fidelity {spec.fidelity!r}): the model cannot be built from these "
                                      f"values: {type(e).__name__}: {e}")) from None
    for w in caught:                                        # a model that builds: its warnings as they were
        warnings.warn_explicit(w.message, w.category, w.filename, w.lineno, source=w.source)
    return model


class DiscsSpec(_Strict):
    """``[model.discs]``: the attached mass as a stack of discs (paper Sec. 5: 4 steel discs)."""

    count: Annotated[int, Field(ge=1)]
    thickness_mm: Annotated[float, Field(gt=0.0)]
    diameter_mm: Annotated[float, Field(gt=0.0)]
    density_kg_m3: Annotated[float, Field(gt=0.0)] = 7850.0
    mass_kg: Annotated[float, Field(gt=0.0)] | None = None  # measured mass overrides the discs'


class CalibrateSpec(_Strict):
    """``[model.calibrate]``: fit EI (and J) to measured bending frequencies (paper Sec. 5)."""

    f1_hz: Annotated[float, Field(gt=0.0)]
    f2_hz: Annotated[float, Field(gt=0.0)] | None = None


def _beam_length(v):
    """A beam's ``length_mm`` within :attr:`BeamSceneSpec.LENGTH_RANGE_MM` (ValueError otherwise)."""
    lo, hi = BeamSceneSpec.LENGTH_RANGE_MM
    if not lo <= v <= hi:
        raise ValueError(f"allowed: {lo:g} ... {hi:g} mm (the FE mesh locates nodes to 1e-8 m: a shorter "
                         f"beam's elements cannot be resolved)")
    return v


class SystemSpec(_Strict):
    """``[model.system]`` with ``builder = "matrices"``: a linear structure given by its mass,
    stiffness and damping matrices (issue 58; :func:`vibeam.models.builders.matrices.build_matrices`)
    in SI units over named DOFs (m for a translation), base-excited along ``base`` and reduced to its
    ``n_modes`` lowest undamped modes.

    The matrices are inline tables of rows (``M = [[...], ...]``), MatrixMarket files (``M = "M.mtx"``,
    :func:`scipy.io.mmread`) or one ``.npz`` archive (``matrices = "chain.npz"`` holding ``M``, ``K``
    and optionally ``C``, ``dofs``, ``r``); file paths are relative to the case file's folder.  The
    damping is ``C`` (classically damped: refused when the modes do not diagonalise it) or
    ``damping_ratios`` (one per kept mode, or one for all).
    """

    builder: Literal["matrices"]
    matrices: str | None = None
    M: str | list[list[float]] | None = None
    K: str | list[list[float]] | None = None
    C: str | list[list[float]] | None = None
    dofs: list[str] | None = None
    damping_ratios: Annotated[float, Field(ge=0.0, lt=1.0)] | list[Annotated[float, Field(ge=0.0, lt=1.0)]] | None = None
    base: Literal["all"] | list[float] = "all"
    sensor: str
    n_modes: Annotated[int, Field(ge=1)] | Literal["all"] = "all"
    f_ref_hz: Annotated[float, Field(gt=0.0)] | None = None
    length_mm: Annotated[float, Field(gt=0.0, le=1e8)] = 1.0

    @model_validator(mode="after")
    def _one_source(self):
        inline = [k for k in ("M", "K", "C") if getattr(self, k) is not None]
        if (self.matrices is None) == (not inline):
            raise ValueError("give the matrices either as matrices = \"<file>.npz\" or as M and K (inline rows or "
                             "MatrixMarket files), exactly one of them")
        if self.matrices is None and (self.M is None or self.K is None):
            raise ValueError("give both M and K")
        return self


class StructureStopSpec(StopSpec):
    """One ``[[model.stop]]`` of a structure given by its matrices: ``at`` names the DOF it acts on
    (default the sensor's), ``side`` which way, ``contact_gap_mm`` its gap at that DOF (or ``gap_mm``
    seen at the sensor: times the static ratio of the DOF, Eq. 45), and its law with the law's
    keys (``R``: Newton's, or a compliant law's target)."""

    at: str | None = None


class ExcitationSpec(_Strict):
    """``[model.excitation]``: the harmonic drive at the sweep's frequency ``f``.
    ``kind = "base_displacement"`` with ``amplitude_mm`` (the base moves as ``Y sin(2 pi f t)``:
    the forcing grows as ``f^2``, the paper's shaker); ``"base_acceleration"`` with
    ``amplitude_m_s2`` (``b'' = -a sin(2 pi f t)``, a fixed amplitude at every frequency, what a
    shaker controller holds); ``"force"`` with ``amplitude_n`` at the DOF ``at`` (``F0 sin(2 pi f t)``
    along the DOF) (:func:`vibeam.models.scene.driven`)."""

    kind: Literal["base_displacement", "base_acceleration", "force"] = "base_displacement"
    amplitude_mm: Annotated[float, Field(ge=0.0)] | None = None
    amplitude_m_s2: Annotated[float, Field(ge=0.0)] | None = None
    amplitude_n: Annotated[float, Field(ge=0.0)] | None = None
    at: str | None = None
    # the SDOF's and the beam's base displacement (builders "sdof", "beam"): the nondimensional
    # amplitude B (in lengths L, paper Eq. 1), or the paper's shaker gamma V (Eqs. 43, 46)
    amplitude: Annotated[float, Field(ge=0.0)] | None = None
    gain: Annotated[float, Field(ge=0.0)] | None = None
    voltage: Annotated[float, Field(ge=0.0)] | None = None

    #: the amplitude key of each kind
    AMPLITUDE_KEYS: ClassVar[dict] = {"base_displacement": "amplitude_mm", "base_acceleration": "amplitude_m_s2",
                                      "force": "amplitude_n"}

    @model_validator(mode="after")
    def _one_amplitude(self):
        shaker = [k for k in ("amplitude", "gain", "voltage") if getattr(self, k) is not None]
        if shaker:      # the paper's forms of a base displacement (the SDOF's and the beam's builders)
            others = [k for k in self.AMPLITUDE_KEYS.values() if getattr(self, k) is not None]
            if self.kind != "base_displacement" or others or shaker not in (["amplitude"], ["gain", "voltage"]):
                raise ValueError(f"a base displacement takes its amplitude as one of amplitude_mm, amplitude "
                                 f"(nondimensional B) or gain and voltage (the shaker's gamma V); got "
                                 f"{', '.join(others + shaker)} with kind = \"{self.kind}\"")
            return self
        key = self.AMPLITUDE_KEYS[self.kind]
        given = [k for k in self.AMPLITUDE_KEYS.values() if getattr(self, k) is not None]
        if given != [key]:
            raise ValueError(f"kind = \"{self.kind}\" takes its amplitude as {key} (and no other amplitude); got "
                             f"{', '.join(given) or 'none'}")
        if (self.kind == "force") != (self.at is not None):
            raise ValueError("at = \"<DOF>\" names a force's point; allowed: at with kind = \"force\" only (and "
                             "always with it)")
        return self

    @property
    def base_amplitude_m(self) -> float:
        """The base displacement amplitude ``Y`` (m); 0 for the other kinds."""
        return self.amplitude_mm * 1e-3 if self.kind == "base_displacement" else 0.0

    def shaker(self, length_mm: float | None = None) -> tuple:
        """``(gain, voltage)`` of the paper's shaker, whose base displacement is ``gamma V`` (paper
        Eq. 43; the SDOF's ``B = gamma V`` in lengths L): the table's ``gain`` and ``voltage``; a
        base displacement given as ``amplitude_mm``, with the normalising length ``length_mm`` (mm),
        as ``(amplitude_mm / length_mm, 1)``; ``(0, 0)`` for a drive that is not a base displacement."""
        if self.kind != "base_displacement":
            return 0.0, 0.0
        if self.amplitude_mm is not None and length_mm is not None:
            return self.amplitude_mm / length_mm, 1.0
        return self.gain, self.voltage


class MatricesModelSpec(_StopsSpec):
    """``[model]`` of a structure given by its matrices (issue 58): the canonical tables
    ``[model.system]`` (:class:`SystemSpec`), ``[[model.stop]]`` (:class:`StructureStopSpec`, one
    or more) and ``[model.excitation]`` (:class:`ExcitationSpec`).

    The first stop is the reference stop (the paper's: the amplitude ``Q`` is measured from it),
    an upper one; a lower stop at its DOF is the scene's second stop (any law); stops at other DOFs
    take any law too (a compliant one in N/m^p at their DOF).  Physical: the sweep in Hz (``Omega = f / f_ref``, ``f_ref`` the first kept mode's
    unless given), the reported displacement the sensor's over ``length_mm``.
    """

    system: SystemSpec
    stop: Annotated[list[StructureStopSpec], Field(min_length=1)]
    excitation: ExcitationSpec

    fidelity: ClassVar[str] = "matrices"
    physical: ClassVar[bool] = True

    @model_validator(mode="after")
    def _stops_consistent(self):
        paper = [k for k in ("amplitude", "gain", "voltage") if getattr(self.excitation, k) is not None]
        if paper:
            raise ValueError(f"excitation: {', '.join(paper)} give the SDOF's and the beam's drive; allowed here: "
                             f"amplitude_mm, amplitude_m_s2 or amplitude_n")
        first = self.stop[0]
        if first.side != "upper":
            raise ValueError("stop[0] is the reference stop (the amplitude Q is measured from it): give an upper "
                             "stop first")
        at0 = self.stop_at(first)
        lower = 0
        for i, st in enumerate(self.stop):
            if st.position_mm is not None or st.Delta is not None:
                raise ValueError(f"stop[{i}]: a structure's stop is placed by at = \"<DOF>\" and given its gap by "
                                 f"contact_gap_mm (at the DOF) or gap_mm (seen at the sensor); position_mm and Delta "
                                 f"are for beams and SDOF scenes")
            at = self.stop_at(st)
            if i == 0:
                continue
            if at == at0 and st.side == "lower":
                lower += 1
                if lower > 1:
                    raise ValueError(f"stop[{i}]: a second lower stop at {at0!r}; allowed: one upper and one lower "
                                     f"stop at the reference stop's DOF")
                if i != 1:
                    raise ValueError(f"stop[{i}]: the lower stop at the reference stop's DOF comes second (stop[1])")
            elif at == at0:
                raise ValueError(f"stop[{i}]: a second upper stop at {at0!r}; allowed: one upper and one lower stop "
                                 f"there, further stops at other DOFs")
        if self.two_sided:
            up, lo = self.stop[0], self.stop[1]
            if (up.gap_mm is None) != (lo.gap_mm is None):
                raise ValueError("give both stops at the reference DOF their gap the same way: gap_mm (at the "
                                 "sensor) or contact_gap_mm (at the stop)")
            tot = (up.gap_mm if up.gap_mm is not None else up.contact_gap_mm) + \
                (lo.gap_mm if lo.gap_mm is not None else lo.contact_gap_mm)
            if not tot > 0.0:
                raise ValueError(f"the stops overlap: the upper and lower gaps add to {tot:g} mm; allowed: > 0 (both "
                                 f"are distances from the static equilibrium, the lower one downwards)")
        return self

    @property
    def two_sided(self) -> bool:
        """A lower stop at the reference stop's DOF (``stop[1]``)."""
        at0 = self.stop_at(self.stop[0])
        return len(self.stop) > 1 and self.stop[1].side == "lower" and self.stop_at(self.stop[1]) == at0

    def stop_at(self, st) -> str:
        """Where stop ``st`` (a :class:`StructureStopSpec` of this table) acts: its ``at`` (a DOF's
        name), else the sensor's DOF."""
        return st.at or self.system.sensor

    @property
    def further_stops(self) -> list:
        """The stops away from the reference stop's DOF (after ``stop[0]`` and a lower stop there),
        each with its own law."""
        return list(self.stop[1 + int(self.two_sided):])

    @property
    def mixed_stops(self) -> bool:
        """A restitution stop beside a compliant one at the reference DOF (:func:`mixed_stops`)."""
        return mixed_stops(self)

    def scene_parameter(self, key: str):
        """``(path, factor, damping)`` of a continuation parameter its scene's shooting problem
        carries with its exact ``d x / d p``: ``Omega``; a Newton stop's ``stops[k].law.R``; a stop's
        ``stops[k].contact_gap_mm`` (its ``relation.offset``, 1e-3 m/mm); a base drive's amplitude
        (``excitation.amplitude_mm``, ``excitation.amplitude_m_s2``: the system's ``base_amplitude``
        per unit, :func:`vibeam.models.scene.driven`).  The case's ``[[model.stop]]`` are the scene's
        stops in order (:func:`vibeam.case.structure.scene`).  The other numbers of the stops
        and the drive are continued by their paths with central differences (:func:`continued_key`).

        Raises
        ------
        ValueError
            Any other key, naming what is allowed.
        """
        if key == "Omega":
            return "Omega", 1.0, None
        ex = self.excitation
        m = re.fullmatch(r"stops\[(\d+)\]\.(law\.R|contact_gap_mm)", key)
        if m is not None and int(m.group(1)) < len(self.stop):
            k, what = int(m.group(1)), m.group(2)
            st = self.stop[k]
            if what == "law.R" and not is_compliant(st.law):
                return key, 1.0, None
            if what == "contact_gap_mm" and st.contact_gap_mm is not None:
                return f"stops[{k}].relation.offset", 1e-3, None
        if ex.kind != "force" and key == f"excitation.{ex.AMPLITUDE_KEYS[ex.kind]}":
            from vibeam.models.scene import Excitation, driven   # lazy: keeps numpy-heavy models out of load_case

            unit = 1e-3 if ex.kind == "base_displacement" else 1.0      # mm to m
            per = driven(self.scene().system, Excitation(ex.kind, unit)).base_amplitude
            return "system.base_amplitude", float(per), None
        raise ValueError("cannot be continued in a structure given by its matrices; allowed: Omega, or the path "
                         "of a stop's or the drive's number (stops[0].law.R, excitation.amplitude_m_s2)")


    def matrix_model(self):
        """The reduced structure, :class:`vibeam.models.builders.matrices.MatrixModel` (contact
        rows: the reference stop's DOF, then each further stop's; :mod:`vibeam.case.structure`)."""
        return _structure().matrix_model(self)

    def _scene(self):
        # straight from the tables (vibeam.case.structure.scene): the reduced structure, its stops, its drive
        return _structure().scene(self)

    def dofs(self) -> int:
        """Degrees of freedom simulated (work estimate): the kept modes (``"all"``: a bound, the
        matrices' size is read when built)."""
        n = self.system.n_modes
        return int(n) if n != "all" else max(1, len(self.system.dofs or ()) or 4)

    def check(self, prefix: str) -> None:
        """The stops' gaps and laws computable (:func:`check_gap`, the compliant law built)."""
        L = self.system.length_mm
        for j, st in enumerate(self.stop):
            for k in ("gap_mm", "contact_gap_mm"):
                check_gap(getattr(st, k, None), f"'{prefix}.stop[{j}].{k}'", L)
            if is_compliant(st.law):
                try:
                    beam_law(ContactSpec(**st.law_table()), st.R)
                except ValueError as e:
                    raise CaseError(f"'{prefix}.stop[{j}]': {e}") from None
        check_gap(self.excitation.amplitude_mm, f"'{prefix}.excitation.amplitude_mm'", L)
        for k in ("amplitude_m_s2", "amplitude_n"):
            check_scale(getattr(self.excitation, k) or 0.0, f"'{prefix}.excitation.{k}'")

    def result_attrs(self) -> dict:
        """The structure's kept frequencies (Hz) and damping ratios, stored with its results."""
        mm = build_or_refuse(self, self.matrix_model)
        return {"frequencies_hz": np.asarray(mm.frequencies_hz), "damping_ratios": np.asarray(mm.damping_ratios),
                "dofs": ",".join(mm.dofs), "contact_static": np.asarray(mm.contact_static)}

    def converged_reference(self, table: dict, overrides: dict):
        """Model table of a cost table's converged reference: every mode of the structure."""
        fine = model_with(table, overrides)
        fine["system"] = dict(fine["system"], n_modes="all")
        return fine

    def effect_scene(self, effects, scene):
        """``(scene, None)``, unchanged: the structural effects of the rig (eccentric contact,
        platform) are the beam's; a velocity-dependent R is not yet wired here."""
        return scene, None

    def case_update(self, key: str, value: float) -> tuple[dict, list]:
        """A fitted value written back: not yet for this builder (noted)."""
        return {}, [f"{key} not written: a structure given by its matrices takes fitted values by path"]


class ContinuumSystemSpec(_Strict):
    """``[model.system]`` with ``builder = "continuum"``: the rig (paper Sec. 5, Fig. 15) as a 3D
    linear-elastic continuum from its geometry alone (issue 59;
    :func:`vibeam.models.builders.continuum.build_rig`): a strip clamped at ``x = 0`` (steel unless
    given), the disc stack a rigid body tied to it over its footprint (the stops act on it, well
    posed), the sensor the strip's mid-plane at ``sensor_position_mm``; quadratic hexahedra of size
    ``element_size_mm`` in the strip's plane and ``layers`` through its thickness; its ``n_modes``
    lowest modes kept; the base translates along the bending direction.  Built once per geometry
    and mesh (cached by content hash: ``$VIBEAM_CACHE_DIR/continuum``).  Lengths in mm, as the beam
    case gives them; no calibration (the point of this rung).
    """

    builder: Literal["continuum"]
    length_mm: Annotated[float, Field(gt=0.0, le=1e5)]
    width_mm: Annotated[float, Field(gt=0.0, le=1e5)]
    thickness_mm: Annotated[float, Field(gt=0.0, le=1e5)]
    sensor_position_mm: Annotated[float, Field(gt=0.0)]
    mass_position_mm: Annotated[float, Field(gt=0.0)]
    youngs_modulus_gpa: Annotated[float, Field(gt=0.0, le=1e4)] = 200.0
    poisson_ratio: Annotated[float, Field(gt=-1.0, lt=0.5)] = 0.3
    density_kg_m3: Annotated[float, Field(gt=0.0, le=1e6)] = 7850.0
    discs: DiscsSpec
    discs_above: Annotated[int, Field(ge=0)] | None = None
    contact_offset_mm: Annotated[list[float], Field(min_length=2, max_length=2)] = [0.0, 0.0]
    element_size_mm: Annotated[float, Field(gt=0.0)] = 2.5
    layers: Annotated[int, Field(ge=1, le=8)] = 1
    n_modes: Annotated[int, Field(ge=1, le=200)] = 4
    damping_ratios: Annotated[float, Field(ge=0.0, lt=1.0)] | list[Annotated[float, Field(ge=0.0, lt=1.0)]] | None = None
    rayleigh: Annotated[list[Annotated[float, Field(ge=0.0)]], Field(min_length=2, max_length=2)] | None = None
    f_ref_hz: Annotated[float, Field(gt=0.0)] | None = None

    #: the most hexahedra of a mesh (``ceil(L / h) ceil(b / h) layers``): 20,000 is ~330,000 DOFs,
    #: minutes and GBs of a sparse factorisation on 2 cores (h = 1.25 mm, one layer: 2,300 cells, 23 s)
    MAX_CELLS: ClassVar[int] = 20_000

    @model_validator(mode="after")
    def _a_rig(self):
        L, R = self.length_mm, 0.5 * self.discs.diameter_mm
        if (self.damping_ratios is None) == (self.rayleigh is None):
            raise ValueError("give the damping as damping_ratios (one for every mode, or one per kept mode) or as "
                             "rayleigh = [a, b] (C = a M + b K), exactly one of them")
        if isinstance(self.damping_ratios, list) and len(self.damping_ratios) != self.n_modes:
            raise ValueError(f"damping_ratios: {len(self.damping_ratios)} values for n_modes = {self.n_modes}; "
                             f"allowed: one per kept mode, or one for all")
        if not self.sensor_position_mm <= L:
            raise ValueError(f"sensor_position_mm = {self.sensor_position_mm:g}: allowed on the strip, <= length_mm "
                             f"= {L:g}")
        if not (self.mass_position_mm - R > 0.0 and self.mass_position_mm + R <= L):
            raise ValueError(f"mass_position_mm = {self.mass_position_mm:g}: the discs' footprint (diameter "
                             f"{self.discs.diameter_mm:g} mm) must lie on the strip, 0 < x <= length_mm = {L:g}")
        if self.discs_above is not None and self.discs_above > self.discs.count:
            raise ValueError(f"discs_above = {self.discs_above}: allowed 0 ... discs.count = {self.discs.count}")
        h = self.element_size_mm
        cells = math.ceil(L / h) * math.ceil(self.width_mm / h) * self.layers
        if not (h <= min(self.width_mm, L) and cells <= self.MAX_CELLS):
            raise ValueError(f"element_size_mm = {h:g}: {cells} cells; allowed: at most the strip's width and at "
                             f"most {self.MAX_CELLS} cells (ceil(length / h) ceil(width / h) layers)")
        return self


class ContinuumModelSpec(MatricesModelSpec):
    """``[model]`` of the rig as a 3D elastic continuum (issue 59): the canonical tables
    ``[model.system]`` (:class:`ContinuumSystemSpec`, ``builder = "continuum"``), ``[[model.stop]]``
    and ``[model.excitation]`` as for a structure given by its matrices (:class:`MatricesModelSpec`),
    the stops on the disc stack (``at = "stack"`` or none): the reference (upper) stop on its top
    face at ``contact_offset_mm`` from its axis, a lower stop at the same point.  ``gap_mm`` is seen
    at the sensor (times the stack's static ratio ``K^-1 M r``, Eq. 45), ``contact_gap_mm`` at the
    stack.
    """

    system: ContinuumSystemSpec

    fidelity: ClassVar[str] = "continuum"

    @model_validator(mode="after")
    def _stops_on_the_stack(self):
        for i, st in enumerate(self.stop):
            if st.at not in (None, "stack"):
                raise ValueError(f"stop[{i}]: at = {st.at!r}; allowed: \"stack\" (the default: a continuum's stops "
                                 f"act on the rigid disc stack, a point of the solid itself has no finite effective "
                                 f"mass)")
        if len(self.stop) > 1 + int(self.two_sided):
            raise ValueError(f"{len(self.stop)} stops; allowed on a continuum: an upper stop on the disc stack and "
                             f"optionally a lower one (stop[1])")
        return self

    def stop_at(self, st) -> str:
        """``"stack"``: every stop of a continuum acts on its rigid disc stack."""
        return "stack"

    def matrix_model(self):
        """The continuum reduced to its modes, :class:`vibeam.models.builders.matrices.MatrixModel`
        (contact row 0: the stack's top face at the contact point; :func:`vibeam.case.structure.continuum_model`)."""
        return _structure().continuum_model(self)[0]

    def dofs(self) -> int:
        """Degrees of freedom simulated (work estimate): the kept modes."""
        return int(self.system.n_modes)

    def result_attrs(self) -> dict:
        """The continuum's kept frequencies (Hz) and damping ratios, the stack's static ratio and the mesh."""
        mm = build_or_refuse(self, self.matrix_model)
        sy = self.system
        return {"frequencies_hz": np.asarray(mm.frequencies_hz), "damping_ratios": np.asarray(mm.damping_ratios),
                "contact_static": np.asarray(mm.contact_static),
                "mesh": f"element_size_mm = {sy.element_size_mm:g}, layers = {sy.layers}, {len(mm.dofs)} DOFs"}

    def converged_reference(self, table: dict, overrides: dict):
        """Model table of a cost table's converged reference: twice the modes (at least 12) on a mesh
        half as coarse (one size down: the f1, f2 of the rig move < 0.3 % from 2.5 to 1.25 mm)."""
        fine = model_with(table, overrides)
        sy = fine["system"]
        fine["system"] = dict(sy, n_modes=max(12, 2 * int(sy.get("n_modes", 4))),
                              element_size_mm=0.5 * float(sy.get("element_size_mm", 2.5)))
        return fine

    def modes_report(self, n: int = 8) -> dict:
        """Modes, participation, effective masses and the contact modes within the kept modes
        (``vibeam modes``; :func:`vibeam.case.structure.modes_report`)."""
        return _structure().modes_report(self, n)


#: three numbers: a point (mm) or a direction
Vec3 = Annotated[list[float], Field(min_length=3, max_length=3)]


def _nonzero(v, what):
    if v is not None and not (all(math.isfinite(x) for x in v) and any(x != 0.0 for x in v)):
        raise ValueError(f"{what} = {v}: allowed: three finite numbers, not all 0 (a direction)")
    return v


class MaterialSpec(_Strict):
    """``[model.system.materials.<region>]``: the isotropic linear-elastic material of a region of
    a user's mesh (steel unless given: 200 GPa, 0.3, 7850 kg/m^3, as the rig's cases assume it)."""

    youngs_modulus_gpa: Annotated[float, Field(gt=0.0, le=1e4)] = 200.0
    poisson_ratio: Annotated[float, Field(gt=-1.0, lt=0.5)] = 0.3
    density_kg_m3: Annotated[float, Field(gt=0.0, le=1e6)] = 7850.0


class MeshSystemSpec(_Strict):
    """``[model.system]`` with ``builder = "mesh"``: a user's part as a 3D linear-elastic continuum
    (issue 59), its mesh read by meshio from ``file`` (Gmsh ``.msh``, ``.vtu``, ``.xdmf``, ...:
    :func:`vibeam.models.builders.continuum.read_mesh`; the path relative to the case file's folder),
    its named regions (Gmsh physical groups, meshio cell sets) naming the clamp, the materials and a
    rigid region; built by :func:`vibeam.models.builders.continuum.build_continuum` (quadratic
    elements on the mesh's hexahedra or tetrahedra) and reduced to its ``n_modes`` lowest modes;
    cached per content hash (the file's bytes in the key: ``$VIBEAM_CACHE_DIR/continuum``).

    The mesh's coordinates are in metres (points of the case in mm).  The base translates along
    ``drive_direction``; the sensor reads the displacement at ``sensor_mm`` along
    ``sensor_direction``, over ``length_mm`` for ``q``.  Regions are checked against the mesh when
    the model is built (a name the mesh does not have is refused, listing the mesh's regions).
    """

    builder: Literal["mesh"]
    file: Annotated[str, Field(min_length=1)]
    clamp: Annotated[str, Field(min_length=1)] | Annotated[list[str], Field(min_length=1)] | dict[str, str]
    materials: dict[str, MaterialSpec] = {}
    rigid: Annotated[str, Field(min_length=1)] | None = None
    body_point_mm: Vec3 | None = None
    sensor_mm: Vec3
    sensor_direction: Vec3 = [0.0, 0.0, 1.0]
    drive_direction: Vec3 = [0.0, 0.0, 1.0]
    length_mm: Annotated[float, Field(gt=0.0, le=1e8)] = 1.0
    n_modes: Annotated[int, Field(ge=1, le=200)] = 4
    damping_ratios: Annotated[float, Field(ge=0.0, lt=1.0)] | list[Annotated[float, Field(ge=0.0, lt=1.0)]] | None = None
    rayleigh: Annotated[list[Annotated[float, Field(ge=0.0)]], Field(min_length=2, max_length=2)] | None = None
    f_ref_hz: Annotated[float, Field(gt=0.0)] | None = None
    element: Literal["serendipity", "lagrange"] = "serendipity"

    @field_validator("clamp", mode="before")
    @classmethod
    def _clamp_kind(cls, v):
        ok = ((isinstance(v, str) and v) or (isinstance(v, list) and v and all(isinstance(x, str) and x for x in v))
              or (isinstance(v, dict) and v and all(isinstance(x, str) for x in v.values())))
        if not ok:
            raise ValueError("allowed: a region's name, a list of names, or a table {region = \"<components>\"} "
                             "(a non-empty subset of \"xyz\")")
        return v

    @model_validator(mode="after")
    def _a_part(self):
        if (self.damping_ratios is None) == (self.rayleigh is None):
            raise ValueError("give the damping as damping_ratios (one for every mode, or one per kept mode) or as "
                             "rayleigh = [a, b] (C = a M + b K), exactly one of them")
        if isinstance(self.damping_ratios, list) and len(self.damping_ratios) != self.n_modes:
            raise ValueError(f"damping_ratios: {len(self.damping_ratios)} values for n_modes = {self.n_modes}; "
                             f"allowed: one per kept mode, or one for all")
        for k in ("sensor_direction", "drive_direction"):
            _nonzero(getattr(self, k), k)
        for k in ("sensor_mm", "body_point_mm"):
            v = getattr(self, k)
            if v is not None and not all(math.isfinite(x) and abs(x) <= 1e8 for x in v):
                raise ValueError(f"{k} = {v}: allowed: three finite numbers (mm), |x| <= 1e8")
        if isinstance(self.clamp, dict):
            for r, c in self.clamp.items():
                if not c or any(ch not in "xyz" for ch in c) or len(set(c)) != len(c):
                    raise ValueError(f"clamp.{r} = {c!r}: the components held; allowed: a non-empty subset of "
                                     f"\"xyz\" (\"xyz\": clamped; \"yz\": free along x)")
        if self.body_point_mm is not None and self.rigid is None:
            raise ValueError("body_point_mm is the rigid region's reference point; allowed only with rigid = "
                             "\"<region>\"")
        return self

    def clamp_supports(self) -> list:
        """``[(region, components), ...]`` of :attr:`clamp` (a name or a list of names: every
        component held)."""
        if isinstance(self.clamp, str):
            return [(self.clamp, "xyz")]
        if isinstance(self.clamp, list):
            return [(r, "xyz") for r in self.clamp]
        return list(self.clamp.items())


class MeshStopSpec(StopSpec):
    """One ``[[model.stop]]`` of a user's mesh: ``at = "body"`` (a point of the rigid region, the
    default when there is one: its effective mass is finite, so Newton's law is well posed) or
    ``"node"`` (the displacement of the solid interpolated at a point: its effective mass goes to 0
    as the mesh is refined, so only a compliant law, whose contact force stays finite); ``point_mm``
    where it acts (on the reference stop: a lower stop acts at the same point) and ``normal`` the
    direction in which the part moves towards the stop (default the sensor's); the stop is met when
    the displacement there along ``normal`` reaches the gap (``contact_gap_mm``, or ``gap_mm`` at the
    sensor times the static ratio, Eq. 45)."""

    at: Literal["body", "node"] | None = None
    point_mm: Vec3 | None = None
    normal: Vec3 | None = None

    @model_validator(mode="after")
    def _a_direction(self):
        _nonzero(self.normal, "normal")
        if self.point_mm is not None and not all(math.isfinite(x) and abs(x) <= 1e8 for x in self.point_mm):
            raise ValueError(f"point_mm = {self.point_mm}: allowed: three finite numbers (mm), |x| <= 1e8")
        return self


class MeshModelSpec(ContinuumModelSpec):
    """``[model]`` of a user's part read from a mesh file (issue 59): ``[model.system]``
    (:class:`MeshSystemSpec`, ``builder = "mesh"``), ``[[model.stop]]`` (:class:`MeshStopSpec`: an upper
    stop, optionally a lower one at the same point) and ``[model.excitation]`` as for a structure given
    by its matrices.  A Newton stop acts on the rigid region (``rigid``); a stop on a point of the solid
    (``at = "node"``) takes a compliant law only (its effective mass vanishes under refinement: the
    impulse of Newton's law there is not defined).
    """

    system: MeshSystemSpec
    stop: Annotated[list[MeshStopSpec], Field(min_length=1)]

    fidelity: ClassVar[str] = "mesh"

    @model_validator(mode="after")
    def _stops_on_the_stack(self):      # replaces the continuum's (stops on its disc stack) by name
        first = self.stop[0]
        if first.point_mm is None:
            raise ValueError("stop[0]: point_mm = [x, y, z] (mm), where the stop acts, is required")
        at = self.stop_kind(first)
        if at == "body" and self.system.rigid is None:
            raise ValueError("stop[0]: at = \"body\" needs a rigid region; allowed: [model.system] rigid = "
                             "\"<region>\", or at = \"node\" with a compliant law")
        for i, st in enumerate(self.stop):
            if i and any(getattr(st, k) not in (None, getattr(first, k)) for k in ("at", "point_mm", "normal")):
                raise ValueError(f"stop[{i}]: at, point_mm and normal are the reference stop's (stop[0]): a lower "
                                 f"stop acts at the same point; allowed: omit them, or give stop[0]'s")
            if at == "node" and not is_compliant(st.law):
                raise ValueError(f"stop[{i}]: at = \"node\" with law = {st.law!r}: Newton's law on a point of "
                                 f"the solid meets an effective mass that goes to 0 as the mesh is refined (its "
                                 f"impulse is not defined); allowed: at = \"body\" (a rigid region, [model.system] "
                                 f"rigid) or a compliant law (law = \"kelvin_voigt\", \"hertz\", ...)")
        if len(self.stop) > 1 + int(self.two_sided):
            raise ValueError(f"{len(self.stop)} stops; allowed on a mesh: an upper stop and optionally a lower one "
                             f"at the same point (stop[1])")
        return self

    def stop_kind(self, st) -> str:
        """``"body"`` or ``"node"``: where the reference stop acts (``at``, default ``"body"`` when
        there is a rigid region); every stop acts where the reference stop does."""
        at = self.stop[0].at
        return at if at is not None else ("body" if self.system.rigid is not None else "node")

    def stop_normal(self) -> list:
        """The reference stop's ``normal`` (default the sensor's direction)."""
        n = self.stop[0].normal
        return list(n) if n is not None else list(self.system.sensor_direction)

    def stop_at(self, st) -> str:
        """Where every stop acts: the reference stop's point, on the rigid body or the solid."""
        p = self.stop[0].point_mm or [float("nan")] * 3
        return f"{self.stop_kind(st)} at ({p[0]:g}, {p[1]:g}, {p[2]:g}) mm"

    def matrix_model(self):
        """The part reduced to its modes, :class:`vibeam.models.builders.matrices.MatrixModel`
        (contact row 0: the reference stop's point along its normal; :func:`vibeam.case.structure.mesh_model`)."""
        return _structure().mesh_model(self)[0]

    def result_attrs(self) -> dict:
        """The part's kept frequencies (Hz) and damping ratios, the stop's static ratio and the mesh."""
        mm, info, _ = build_or_refuse(self, lambda: _structure().mesh_model(self))
        return {"frequencies_hz": np.asarray(mm.frequencies_hz), "damping_ratios": np.asarray(mm.damping_ratios),
                "contact_static": np.asarray(mm.contact_static),
                "contact_effective_mass_kg": np.asarray(info.contact_effective_mass_kg),
                "mesh": f"{Path(self.system.file).name}, {info.n_cells} cells, {info.n_dofs} DOFs"}

    def converged_reference(self, table: dict, overrides: dict):
        """Model table of a cost table's converged reference: twice the modes (at least 12) on the
        same mesh (a user's mesh is not refined here: converge it in the mesh generator)."""
        fine = model_with(table, overrides)
        sy = fine["system"]
        fine["system"] = dict(sy, n_modes=max(12, 2 * int(sy.get("n_modes", 4))))
        return fine

    def modes_report(self, n: int = 8) -> dict:
        """Modes, participation, effective masses and the contact modes within the kept modes
        (``vibeam modes``; :func:`vibeam.case.structure.mesh_modes_report`)."""
        return _structure().mesh_modes_report(self, n)


# ----------------------------------------------------------------------------- the paper's builders
#: the law keys of a stop table (:class:`vibeam.case.contact.ContactSpec`'s fields)
_LAW_KEYS = tuple(ContactSpec.model_fields)


def _law_of(st, with_R: bool):
    """The ``[model.contact]``-style table of stop table ``st`` (its law keys as given, ``R`` with
    ``with_R``), None when it gives none."""
    keys = [k for k in _LAW_KEYS if k in st.model_fields_set and (with_R or k != "R")]
    return ContactSpec(**{k: getattr(st, k) for k in keys}) if keys else None


def mass_law_tables(spec) -> tuple:
    """``(upper, lower)``: the law tables (:class:`vibeam.case.contact.ContactSpec`) of the stops at
    the reference point of a canonical model spec (``stop[0]``, and ``stop[1]`` when the spec is
    ``two_sided``): the upper one's law keys as given (None: Newton's law with its ``R``), the lower
    one's with its ``R`` (None: it gives neither, and its law is the upper stop's)."""
    st = spec.stop
    return _law_of(st[0], with_R=False), (_law_of(st[1], with_R=True) if spec.two_sided else None)


def _mixed(up, low) -> bool:
    """A compliant upper law table beside a restitution lower one, or the reverse."""
    if low is None:
        return False
    return (up is not None and is_compliant(up.law)) != is_compliant(low.law)


def mixed_stops(spec) -> bool:
    """A compliant upper stop beside a restitution lower one at the reference point, or a
    restitution upper stop above a compliant lower one (:func:`mass_law_tables`)."""
    return _mixed(*mass_law_tables(spec))


def lower_law_spec(up, low):
    """The lower stop's law table ``low`` of a compliant two-sided scene with the upper table's
    ``mass_kg`` when it gives none (the oscillator's effective mass is one); None when the lower
    stop's law is not compliant (:func:`mass_law_tables` gives ``up`` and ``low``)."""
    if low is None or not is_compliant(low.law):
        return None
    if low.mass_kg is None and up is not None and up.mass_kg is not None:
        low = low.model_copy(update={"mass_kg": up.mass_kg})
    return low


def _R_lower(up, low, R: float):
    """The R of a Newton lower stop with its own law table (its ``R``; beside a compliant upper stop
    its ``R``, else the upper stop's ``R``), None otherwise (no table: it follows the upper stop;
    a compliant lower law)."""
    if low is None or (is_compliant(low.law) and not (up is not None and is_compliant(up.law))):
        return None
    if _mixed(up, low):   # Newton's law below a compliant upper stop: its R, else the upper stop's
        return R if low.R is None else low.R
    return low.R


class SceneStopSpec(StopSpec):
    """One ``[[model.stop]]`` of the SDOF or the beam (``builder = "sdof"`` / ``"beam"``): as
    :class:`vibeam.case.contact.StopSpec`; the lower stop at the attached mass (``stop[1]``) may give
    neither ``R`` nor a law: it then has the upper stop's law (and follows it: an R table, a
    continuation in R), as the shorthand's ``Delta_lower`` without ``[model.contact_lower]``."""

    @model_validator(mode="after")
    def _gap(self):
        given = [k for k in ("gap_mm", "contact_gap_mm", "Delta") if getattr(self, k) is not None]
        if len(given) != 1:
            raise ValueError(f"give the stop's gap once: exactly one of gap_mm (at the sensor), contact_gap_mm (at "
                             f"the stop, beam scenes) or Delta (nondimensional SDOF scenes); got {given or 'none'}")
        return self


def _scene_stops(spec, at_mass) -> int:
    """Check the order of a canonical SDOF or beam spec's stops (``at_mass(st)``: the stop is at
    the attached mass): ``stop[0]`` the upper one there, ``stop[1]`` optionally the lower one there,
    the others away from it; every stop but that lower one with its ``R``.  Returns the number
    of stops at the mass (1 or 2); raises ValueError naming the stop."""
    st = spec.stop
    if st[0].side != "upper" or not at_mass(st[0]):
        missing = "" if any(s.side == "upper" and at_mass(s) for s in st) else "no upper stop at the attached mass: "
        raise ValueError(f"{missing}stop[0] is the paper's stop (the amplitude Q is measured from it): the upper stop "
                         f"at the attached mass (side = \"upper\", no position_mm)")
    n = 2 if len(st) > 1 and st[1].side == "lower" and at_mass(st[1]) else 1
    for i, s in enumerate(st):
        if i >= n and at_mass(s):
            if s.side == "lower" and n == 1:
                raise ValueError(f"stop[{i}]: the lower stop at the attached mass comes second (stop[1])")
            first = 0 if s.side == "upper" else 1
            raise ValueError(f"stop[{i}]: two {s.side} stops at the attached mass (stop[{first}] and stop[{i}]); "
                             f"allowed: one upper stop there (stop[0]) and one lower (stop[1])")
        if s.R is None and not (i == 1 and n == 2):
            raise ValueError(f"stop[{i}]: give the stop's R (Newton's coefficient of restitution, or a compliant "
                             f"law's target)")
    return n


class SDOFSystemSpec(_Strict):
    """``[model.system]`` with ``builder = "sdof"``: the paper's one-degree-of-freedom impact
    oscillator (Eqs. 1-2), nondimensional (``damping_ratio`` alone: the paper's beta) or the rig's
    physical form (Eqs. 43-46: with ``natural_frequency_hz`` and ``length_mm``, the normalising
    length L of the gaps and the amplitude)."""

    builder: Literal["sdof"]
    damping_ratio: Annotated[float, Field(ge=0.0, lt=1.0)]
    natural_frequency_hz: Annotated[float, Field(gt=0.0)] | None = None
    length_mm: Annotated[float, Field(gt=0.0)] | None = None

    @model_validator(mode="after")
    def _units(self):
        if (self.natural_frequency_hz is None) != (self.length_mm is None):
            raise ValueError("give natural_frequency_hz and length_mm together (a physical scene, paper Eqs. 43-46) "
                             "or neither (nondimensional, Eqs. 1-2)")
        return self


class SDOFSceneSpec(_StopsSpec):
    """``[model]`` of the SDOF in the canonical tables (``[model.system] builder = "sdof"``,
    :class:`SDOFSystemSpec`): ``[[model.stop]]`` (:class:`SceneStopSpec`: the upper stop, then
    optionally the lower one; ``Delta`` or, physical, ``gap_mm``) and ``[model.excitation]`` (a base
    displacement: ``amplitude`` = B nondimensional; physical ``gain`` and ``voltage``, B = gamma V,
    or ``amplitude_mm``, B = Y / L).  What the shorthand (``fidelity = "sdof"``, ``beta``, ``B``,
    ``R``, ``Delta``, ...) expands into (:func:`vibeam.case.expand.expand`); its checks, build and
    hooks read the tables."""

    system: SDOFSystemSpec
    stop: Annotated[list[SceneStopSpec], Field(min_length=1, max_length=2)]
    excitation: ExcitationSpec

    fidelity: ClassVar[str] = "sdof"

    @model_validator(mode="after")
    def _one_parameter_set(self):
        # the tables' own checks first (naming the canonical keys), then the SDOF's (naming the
        # shorthand's keys as well: the nondimensional and the physical sets of paper Eqs. 1-2, 43-46)
        for i, st in enumerate(self.stop):
            for key in ("position_mm", "contact_gap_mm"):
                if getattr(st, key) is not None:
                    raise ValueError(f"stop[{i}]: {key} is a beam key (the SDOF has one coordinate, at the sensor); "
                                     f"allowed: side, Delta or gap_mm, R and the law's keys")
        _scene_stops(self, lambda st: True)
        ex, sy, phys = self.excitation, self.system, self.physical
        allowed = ("gain", "amplitude_mm") if phys else ("amplitude",)
        if ex.kind != "base_displacement" or all(getattr(ex, k) is None for k in allowed):
            raise ValueError(f"excitation: the SDOF is driven by a base displacement given as "
                             f"{' and voltage, or '.join(allowed)}"
                             f"{'' if phys else ' (nondimensional B)'}")
        up, lo = self.stop[0], (self.stop[1] if self.two_sided else None)
        gain, voltage = ex.shaker(sy.length_mm) if phys else (None, None)
        nondim = {"beta": None if phys else sy.damping_ratio, "B": None if phys else ex.amplitude, "Delta": up.Delta}
        physical = {"natural_frequency_hz": sy.natural_frequency_hz, "damping_ratio": sy.damping_ratio if phys else None,
                    "gap_mm": up.gap_mm, "length_mm": sy.length_mm, "gain": gain, "voltage": voltage}
        given_n = [k for k, v in nondim.items() if v is not None]
        given_p = [k for k, v in physical.items() if v is not None]
        if lo is not None and lo.Delta is not None:
            given_n.append("Delta_lower")
        if lo is not None and lo.gap_mm is not None:
            given_p.append("gap_lower_mm")
        if given_n and given_p:
            raise ValueError(f"give either the nondimensional keys {sorted(nondim)} or the physical keys "
                             f"{sorted(physical)}, not both (got {given_n + given_p})")
        if given_p:
            missing = [k for k in physical if physical[k] is None]
            if missing:
                raise ValueError(f"physical SDOF scene is missing {missing}")
        else:
            missing = [k for k in nondim if nondim[k] is None]
            if missing:
                raise ValueError(f"nondimensional SDOF scene is missing {missing}")
        if lo is not None:
            upper, lower = (up.gap_mm, lo.gap_mm) if given_p else (up.Delta, lo.Delta)
            if not upper + lower > 0.0:
                k = ("gap_mm", "gap_lower_mm") if given_p else ("Delta", "Delta_lower")
                raise ValueError(f"the stops overlap: {k[0]} + {k[1]} = {upper + lower:g} must be > 0 (both are "
                                 f"distances from the static equilibrium, the lower one downwards)")
        return self

    @property
    def physical(self) -> bool:
        """The rig's physical form (paper Eqs. 43-46: ``[model.system] natural_frequency_hz``)."""
        return self.system.natural_frequency_hz is not None

    @property
    def two_sided(self) -> bool:
        """A second stop below (``stop[1]``)."""
        return len(self.stop) > 1

    @property
    def mixed_stops(self) -> bool:
        """A restitution stop beside a compliant one (:func:`mixed_stops`)."""
        return mixed_stops(self)

    def shorthand(self) -> dict:
        """The shorthand's keys (:data:`vibeam.case.expand.SHORTHAND_KEYS`, ``fidelity`` and
        ``stop`` apart) with the scene's values, None where the scene has none: what
        :meth:`as_written` stores for a table written in the shorthand (the inverse of
        :func:`vibeam.case.expand.expand`; a physical scene's ``gain`` and ``voltage`` as
        :meth:`ExcitationSpec.shaker`)."""
        sy, ex, phys = self.system, self.excitation, self.physical
        up, lo = self.stop[0], (self.stop[1] if self.two_sided else None)
        gain, voltage = ex.shaker(sy.length_mm)
        contact, contact_lower = mass_law_tables(self)
        return {"beta": None if phys else sy.damping_ratio, "B": None if phys else ex.amplitude, "R": up.R,
                "Delta": up.Delta, "natural_frequency_hz": sy.natural_frequency_hz,
                "damping_ratio": sy.damping_ratio if phys else None, "gap_mm": up.gap_mm, "length_mm": sy.length_mm,
                "gain": gain, "voltage": voltage, "Delta_lower": None if lo is None else lo.Delta,
                "gap_lower_mm": None if lo is None else lo.gap_mm, "contact": contact, "contact_lower": contact_lower}

    def _units(self) -> tuple:
        """``(natural_frequency_hz, L)`` of a physical scene (L in m, the normalising length, Eq. 43),
        else ``(None, None)``."""
        return (self.system.natural_frequency_hz, self.system.length_mm * 1e-3) if self.physical else (None, None)

    def _B(self) -> float:
        """The nondimensional forcing amplitude ``B`` (``gamma V``, or ``Y / L``: paper Eq. 43)."""
        if not self.physical:
            return self.excitation.amplitude
        gain, voltage = self.excitation.shaker(self.system.length_mm)
        return gain * voltage

    # continuation parameters: key -> (path into the scene, factor d path / d key, damping)
    def scene_parameter(self, key: str):
        """``(path, factor, damping)`` of a continuation parameter: the path into the scene its
        shooting problem continues (:class:`vibeam.models.core.scene_shooting.SceneShooting`), the
        path's value being ``factor * value`` (paper Eqs. 43-46: ``B = gamma V``, ``Delta = gap /
        L``, ``beta = damping ratio``, ``Omega = f / f_n``), and for the damping ratio its
        direction ``(beta, [2])`` (``c = 2 beta``, Eq. 1).  ``R`` moves the lower stop's R too
        when its law follows the upper stop's.  Raises ValueError naming the allowed keys."""
        up, low = mass_law_tables(self)
        R = ("stops[0].law.R", "stops[1].law.R") if self.two_sided and _R_lower(up, low, self.stop[0].R) is None \
            and lower_law_spec(up, low) is None else "stops[0].law.R"
        beta = ("system.damping", 1.0, (float(self.system.damping_ratio), np.array([2.0])))
        if self.physical:
            gain, voltage = self.excitation.shaker(self.system.length_mm)
            table = {"Omega": ("Omega", 1.0, None), "voltage": ("system.base_amplitude", gain, None),
                     "gain": ("system.base_amplitude", voltage, None),
                     "gap_mm": ("stops[0].relation.offset", 1.0 / self.system.length_mm, None), "damping_ratio": beta,
                     "R": (R, 1.0, None)}
        else:
            table = {"Omega": ("Omega", 1.0, None), "B": ("system.base_amplitude", 1.0, None),
                     "Delta": ("stops[0].relation.offset", 1.0, None), "R": (R, 1.0, None), "beta": beta}
        if self.two_sided:
            # the lower stop's offset and R (its Newton R, or a compliant law's target R)
            table["gap_lower_mm" if self.physical else "Delta_lower"] = (
                "stops[1].relation.offset", 1.0 / self.system.length_mm if self.physical else 1.0, None)
            table["R_lower"] = ("stops[1].law.R", 1.0, None)
        if up is not None and is_compliant(up.law):
            # a compliant stop: a case continues it in the forcing and the gaps only
            table = {k: v for k, v in table.items() if v[0] in ("Omega", "system.base_amplitude")
                     or str(v[0]).endswith(".relation.offset")}
        if key not in table:
            raise ValueError(f"cannot be continued in this scene; allowed: {', '.join(table)}")
        return table[key]

    def _scene(self):
        # straight from the tables by the SDOF builder (a physical scene by paper Eqs. 43-46)
        from vibeam.models.builders.sdof import sdof, sdof_physical  # lazy: keeps scipy.linalg (0.2 s) out of load_case
        from vibeam.models.contact import Restitution  # lazy: keeps the impact kernels out of load_case

        fn, L = self._units()
        up_st = self.stop[0]
        lo_st = self.stop[1] if self.two_sided else None
        R = up_st.R
        up, low = mass_law_tables(self)
        law = sdof_law(up, R, self.physical, fn, L)
        lo = lower_law_spec(up, low)
        lower = None if lo is None else sdof_law(lo, target_R(lo, R), self.physical, fn, L)
        R_lower = _R_lower(up, low, R)
        if lower is None and R_lower is not None:
            lower = Restitution(R_lower)
        lower_gap = None if lo_st is None else (lo_st.gap_mm if self.physical else lo_st.Delta)
        if lower_gap is None and getattr(lower, "kind", "") != "compliant":
            lower = None        # Newton's law of a lower stop that is not there
        stop = dict(R=R) if law is None else dict(law=law)
        mass = None if up is None else up.mass_kg
        if self.physical:
            gain, voltage = self.excitation.shaker(self.system.length_mm)
            return sdof_physical(fn, self.system.damping_ratio, up_st.gap_mm, self.system.length_mm, gain, voltage,
                                 gap_lower_mm=lower_gap, lower_law=lower, mass_kg=mass, **stop)
        return sdof(self.system.damping_ratio, self.excitation.amplitude, up_st.Delta, Delta_lower=lower_gap,
                    lower_law=lower, mass_kg=mass, **stop)

    # ---- what is specific to this fidelity (see CANONICAL_SPECS)
    def dofs(self) -> int:
        """Degrees of freedom simulated (work estimate)."""
        return 1

    def check(self, prefix: str) -> None:
        """Checks beyond the table's validators: the stops' laws can be built, and the forcing
        amplitude (:data:`B_RANGE`), the gaps (:data:`GAP_MAX`) and the stop's stiffness
        (:data:`MAX_CONTACT_STIFFNESS`) can be computed in double precision."""
        if self.physical:
            check_scale(self._B(), f"'{prefix}.gain' x '{prefix}.voltage' (B = gain x voltage)")
        else:
            check_scale(self.excitation.amplitude, f"'{prefix}.B'")
        length_mm = self.system.length_mm
        for st, (delta, gap) in zip(self.stop, (("Delta", "gap_mm"), ("Delta_lower", "gap_lower_mm"))):
            check_gap(st.Delta, f"'{prefix}.{delta}'")
            check_gap(st.gap_mm, f"'{prefix}.{gap}'", length_mm)
        fn, L = self._units()
        up, low = mass_law_tables(self)
        R = self.stop[0].R
        for key, table in (("contact", up), ("contact_lower", lower_law_spec(up, low))):
            try:
                law = sdof_law(table, target_R(table, R), self.physical, fn, L)
            except ValueError as e:
                raise CaseError(f"'{prefix}.{key}': {e}") from None
            if table is not None and law is not None:
                given = "stiffness" if table.stiffness is not None else "stiffness_n_m"
                check_stiffness(law, f"'{prefix}.{key}.{given}' = {getattr(table, given):g}")

    #: methods that integrate the equations of motion (no closed-form forced response) or do not
    #: use the flow at Omega = 1 (averaging, near Omega = 2k): undamped resonance is theirs
    RESONANCE_SAFE: ClassVar[tuple] = ("direct", "zhuravlev", "ivanov", "averaging")

    def check_sweep(self, sweep, method: str, where: str, i: int) -> None:
        """No damping (``beta`` or ``damping_ratio`` 0) with Omega = 1 on the grid: the
        closed-form flow of ``event``, ``mapping`` and ``continuation`` divides by ``(1 -
        Omega^2)^2 + (2 beta Omega)^2 = 0`` there (undamped resonance grows as ``t cos t``: no
        periodic forced response), so such a run is refused in one line
        (:func:`vibeam.models.core.oscillator.undamped_resonance` is the model's own guard)."""
        key = "damping_ratio" if self.physical else "beta"
        if method in self.RESONANCE_SAFE or self.system.damping_ratio != 0.0:
            return
        Om = sweep.grid(self.system.natural_frequency_hz)
        if np.any(1.0 - Om * Om == 0.0):
            grid = "sweep.Omega" if sweep.Omega is not None else "sweep.frequency_hz"
            what = f"'{where}.{key}' = 0" if where != "map.values" else f"'map.values': {key} = 0"
            raise CaseError(f"{what} with Omega = 1 in '{grid}' (run[{i}], method {method!r}): undamped exact "
                            f"resonance has no periodic forced response (it grows as t cos t), which the "
                            f"closed-form methods cannot compute; allowed: {key} > 0, a grid without Omega = 1, "
                            f"or method 'direct'")

    def result_attrs(self) -> dict:
        """Derived values stored with a run's results: none."""
        return {}

    def converged_reference(self, table: dict, overrides: dict):
        """Model table of the converged reference of a cost table; None: the run's own
        model (the SDOF reference differs only in its transient)."""
        return None

    def effect_scene(self, effects, scene):
        """``(scene, None)``: ``scene`` with the structural effects of a run, a velocity-dependent
        R (``restitution_law``: Newton's law of the upper stop, and of the lower one when its law
        follows the upper's, with the ``R(q'-)`` table; sensor velocity in mm/s to ``q'``:
        ``U(L_S)' = q' L omega_n``, paper Eq. 43); no coupled platform (the beam's)."""
        if effects.restitution_law is None:
            return scene, None
        from vibeam.models.contact import Restitution  # lazy: keeps the impact kernels out of load_case
        from vibeam.models.scene import outputs        # lazy: as above

        t = effects.restitution_law
        out = outputs(scene)
        scale = 1e-3 / (out.length_m * 2 * math.pi * out.natural_frequency_hz)  # mm/s -> q'
        up = scene.stops[0].law
        law = Restitution(up.R, tuple(v * scale for v in t.velocity_mm_s), tuple(t.R))
        stops = tuple(dataclasses.replace(s, law=law) if s.law is up else s for s in scene.stops)
        return scene._replace(stops=stops), None

    def case_update(self, key: str, value: float) -> tuple[dict, list]:
        """``[model]`` keys that set a fitted value (``vibeam fit --linear``), and notes."""
        return {key: float(value)}, []


class BeamSystemSpec(_Strict):
    """``[model.system]`` with ``builder = "beam"``: the clamped FE cantilever with its attached
    mass (paper Eqs. 39-41, Fig. 15): geometry, section (``width_mm``/``thickness_mm`` with
    ``youngs_modulus_gpa``, ``density_kg_m3``, or ``EI_n_m2``/``rhoA_kg_m``), attached mass
    (``mass_kg`` with ``rotary_inertia_kg_m2``, or ``[model.system.discs]``), calibration
    (``[model.system.calibrate]``), damping (``damping_ratio`` of the first mode, giving the
    stiffness-proportional D of Eq. 39, and ``rayleigh_alpha_1_s``) and the kept modes (``n_modes``: a
    number, ``"all"`` or ``"static"``: the paper's single assumed static mode, i.e. the SDOF model of
    Eqs. 42-47; on ``n_elements`` elements); lengths in mm, masses in kg.  The shorthand's
    (``fidelity = "beam"``) keys of the structure."""

    builder: Literal["beam"]
    length_mm: Annotated[float, Field(gt=0.0)]
    sensor_position_mm: Annotated[float, Field(gt=0.0)]
    mass_position_mm: Annotated[float, Field(gt=0.0)]
    width_mm: Annotated[float, Field(gt=0.0)] | None = None
    thickness_mm: Annotated[float, Field(gt=0.0)] | None = None
    youngs_modulus_gpa: Annotated[float, Field(gt=0.0)] = 200.0
    density_kg_m3: Annotated[float, Field(gt=0.0)] = 7850.0
    EI_n_m2: Annotated[float, Field(gt=0.0)] | None = None
    rhoA_kg_m: Annotated[float, Field(gt=0.0)] | None = None
    mass_kg: Annotated[float, Field(ge=0.0)] | None = None
    rotary_inertia_kg_m2: Annotated[float, Field(ge=0.0)] = 0.0
    discs: DiscsSpec | None = None
    calibrate: CalibrateSpec | None = None
    damping_ratio: Annotated[float, Field(ge=0.0, lt=1.0)] = 0.0
    rayleigh_alpha_1_s: Annotated[float, Field(ge=0.0)] = 0.0
    n_modes: Annotated[int, Field(ge=1)] | Literal["all", "static"] = 4
    n_elements: Annotated[int, Field(ge=2, le=2000)] = 36

    @field_validator("length_mm")
    @classmethod
    def _length_in_range(cls, v):
        return _beam_length(v)


class BeamSceneSpec(_StopsSpec):
    """``[model]`` of the FE beam in the canonical tables (``[model.system] builder = "beam"``,
    :class:`BeamSystemSpec`): ``[[model.stop]]`` (:class:`SceneStopSpec`: the upper stop at the
    attached mass, optionally the lower one there, then Newton stops at other points by
    ``position_mm``, output codes 0, 1, 2 + i as the shorthand's) and ``[model.excitation]`` (a base
    displacement by the shaker's ``gain`` and ``voltage``: ``gamma~ V``, ``gamma~ = gain phi(x_m)
    L``, the paper's normalised gain in 1/V; or a base acceleration).  A stop's gap is ``gap_mm`` (the
    grazing gap seen at the sensor, Delta_G, as for the SDOF rig scenes) or ``contact_gap_mm``
    (Delta_C at the stop).  What the shorthand (``fidelity = "beam"`` and its keys) expands into
    (:func:`vibeam.case.expand.expand`); its checks, build and hooks read the tables."""

    system: BeamSystemSpec
    stop: Annotated[list[SceneStopSpec], Field(min_length=1)]
    excitation: ExcitationSpec

    fidelity: ClassVar[str] = "beam"
    physical: ClassVar[bool] = True

    #: allowed ``length_mm``: the FE mesh (scikit-fem) locates the clamp and the attached mass
    #: by position to an absolute 1e-8 m, so its elements (down to L / 2000 with ``n_elements``
    #: <= 2000) must be far longer: from 1 mm (elements of 5e-7 m; measured: every model builds
    #: at 1 mm, none below 1e-4 mm, ``n_modes = "all"`` fails from 0.01 mm) to 100 m, beyond any
    #: cantilever of this kind (calibrations to the rig's f2/f1 stop being reachable from ~20 m)
    LENGTH_RANGE_MM: ClassVar[tuple] = (1.0, 1e5)
    #: allowed bending stiffness EI (N m^2) and mass per length rho A (kg/m), given or derived from
    #: the section: their ratio over h^4 (h: the element length, 5e-7 ... 5e4 m) is the FE model's
    #: eigenvalue scale, which stays a normal double within this range (a subnormal EI, e.g.
    #: width_mm = 5e-320, leaves the eigensolver without any mode)
    SECTION_RANGE: ClassVar[tuple] = (1e-100, 1e100)

    def at_mass(self, st) -> bool:
        """Stop table ``st`` acts at the attached mass (no ``position_mm``, or the mass's)."""
        mass = self.system.mass_position_mm
        return st.position_mm is None or abs(st.position_mm - mass) <= 1e-9 * max(mass, 1.0)

    @model_validator(mode="after")
    def _consistent(self):
        # the tables' own checks first (naming the canonical keys), then the beam's
        for i, st in enumerate(self.stop):
            if st.Delta is not None:
                raise ValueError(f"stop[{i}]: Delta is an SDOF key; give gap_mm (at the sensor) or contact_gap_mm "
                                 f"(at the stop)")
            if not self.at_mass(st) and is_compliant(st.law):
                raise ValueError(f"stop at position_mm = {st.position_mm:g}: law = {st.law!r} away from the attached "
                                 f"mass is not implemented; allowed there: law = \"restitution\"")
        _scene_stops(self, self.at_mass)
        ex = self.excitation
        if not (ex.kind == "base_displacement" and ex.gain is not None or ex.kind == "base_acceleration"):
            raise ValueError("excitation: the beam is driven by a base displacement given as gain and voltage (the "
                             "shaker's gamma V) or by a base acceleration (kind = \"base_acceleration\", "
                             "amplitude_m_s2)")
        sy = self.system
        sec = sy.width_mm is not None or sy.thickness_mm is not None
        direct = sy.EI_n_m2 is not None or sy.rhoA_kg_m is not None
        if sec == direct:
            raise ValueError("give the section either as width_mm and thickness_mm or as EI_n_m2 and "
                             "rhoA_kg_m")
        if sec and (sy.width_mm is None or sy.thickness_mm is None):
            raise ValueError("the section needs both width_mm and thickness_mm")
        if direct and (sy.EI_n_m2 is None or sy.rhoA_kg_m is None):
            raise ValueError("the section needs both EI_n_m2 and rhoA_kg_m")
        if (sy.mass_kg is None) == (sy.discs is None):
            raise ValueError("give the attached mass either as mass_kg or as a [model.discs] table")
        up = self.stop[0]
        if (up.gap_mm is None) == (up.contact_gap_mm is None):
            raise ValueError("give exactly one of gap_mm (at the sensor) or contact_gap_mm (at the stop)")
        if self.two_sided:
            lo = self.stop[1]
            pair = ("gap_mm", "gap_lower_mm") if up.gap_mm is not None else ("contact_gap_mm", "contact_gap_lower_mm")
            given = getattr(lo, pair[0])
            if given is None:
                raise ValueError(f"give the lower stop's gap where the upper one's is given: {pair[1]} (with "
                                 f"{pair[0]})")
            tot = getattr(up, pair[0]) + given
            if not tot > 0.0:
                raise ValueError(f"the stops overlap: {pair[0]} + {pair[1]} = {tot:g} must be > 0 (both are "
                                 f"distances from the static equilibrium, the lower one downwards)")
        for k in ("sensor_position_mm", "mass_position_mm"):
            if getattr(sy, k) > sy.length_mm:
                raise ValueError(f"{k} = {getattr(sy, k)} lies beyond length_mm = {sy.length_mm}")
        for i, p in enumerate(self.point_stop_tables):
            if p.position_mm > sy.length_mm:
                raise ValueError(f"stop at position_mm = {p.position_mm:g} lies beyond length_mm = {sy.length_mm}")
            if (p.gap_mm is None) == (p.contact_gap_mm is None):
                raise ValueError(f"stop at position_mm = {p.position_mm:g}: give exactly one of gap_mm (at the "
                                 f"sensor) or contact_gap_mm (at the stop)")
        lo, hi = self.SECTION_RANGE
        if sec:     # the section's EI and rho A as vibeam.case.beamscene.geometry_of derives them
            b, t = sy.width_mm * 1e-3, sy.thickness_mm * 1e-3
            derived = {"EI_n_m2": (sy.youngs_modulus_gpa * 1e9 * b * (t * t * t) / 12.0,   # inf, not OverflowError
                                   "youngs_modulus_gpa, width_mm, thickness_mm"),
                       "rhoA_kg_m": (sy.density_kg_m3 * b * t, "density_kg_m3, width_mm, thickness_mm")}
        else:
            derived = {"EI_n_m2": (sy.EI_n_m2, "EI_n_m2"), "rhoA_kg_m": (sy.rhoA_kg_m, "rhoA_kg_m")}
        for name, (v, keys) in derived.items():
            if not lo <= v <= hi:
                raise ValueError(f"{name} = {v:g} (from {keys}) is outside {lo:g} ... {hi:g}: the FE matrices "
                                 f"(EI / h^3, rho A h) would leave double precision; allowed: a section within "
                                 f"that range")
        if sy.calibrate and sy.calibrate.f2_hz is not None and sy.calibrate.f2_hz <= sy.calibrate.f1_hz:
            raise ValueError("calibrate.f2_hz must exceed calibrate.f1_hz")
        return self

    @property
    def two_sided(self) -> bool:
        """A second stop below at the attached mass (``stop[1]``)."""
        return len(self.stop) > 1 and self.stop[1].side == "lower" and self.at_mass(self.stop[1])

    @property
    def point_stop_tables(self) -> list:
        """The stops away from the attached mass (after ``stop[0]`` and the lower one there)."""
        return list(self.stop[1 + int(self.two_sided):])

    @property
    def mixed_stops(self) -> bool:
        """A restitution stop beside a compliant one (:func:`mixed_stops`)."""
        return mixed_stops(self)

    @property
    def drive(self):
        """The drive when it is not the shaker's base displacement: ``(kind, amplitude)`` in SI
        (``("base_acceleration", a)``, m/s^2, :func:`vibeam.models.scene.driven`); None for ``gamma V``."""
        ex = self.excitation
        return None if ex.kind == "base_displacement" else (ex.kind, float(ex.amplitude_m_s2))

    def shorthand(self) -> dict:
        """The shorthand's keys (:data:`vibeam.case.expand.SHORTHAND_KEYS`, ``fidelity`` and
        ``stop`` apart) with the scene's values, None where the scene has none: what
        :meth:`as_written` stores for a table written in the shorthand (the inverse of
        :func:`vibeam.case.expand.expand`; ``gain`` and ``voltage`` 0 when the base is driven by an
        acceleration: :meth:`ExcitationSpec.shaker`)."""
        up, lo = self.stop[0], (self.stop[1] if self.two_sided else None)
        gain, voltage = self.excitation.shaker()
        contact, contact_lower = mass_law_tables(self)
        out = {k: getattr(self.system, k) for k in type(self.system).model_fields if k != "builder"}
        out.update(R=up.R, gap_mm=up.gap_mm, contact_gap_mm=up.contact_gap_mm,
                   gap_lower_mm=None if lo is None else lo.gap_mm,
                   contact_gap_lower_mm=None if lo is None else lo.contact_gap_mm, contact=contact,
                   contact_lower=contact_lower, gain=gain, voltage=voltage)
        return out

    # continuation parameters besides the frequency (Omega, with its range in Hz): keys that
    # act on the modal model without changing its modes (vibeam.case.beamscene.conversions)
    _CONTINUABLE: ClassVar[tuple] = ("voltage", "gain", "gap_mm", "contact_gap_mm", "damping_ratio", "R",
                                     "rayleigh_alpha_1_s")

    def scene_parameter(self, key: str):
        """``(path, factor, damping)`` of a continuation parameter: the path into the scene its
        shooting problem continues, the path's value being ``factor * value``, and a damping
        path's direction (:func:`vibeam.case.beamscene.conversions`: the base amplitude ``gamma~
        V`` with ``gamma~ = gain phi(x_m) L``, the stop's offset ``phi(x_m) gap_mm 1e-3`` (Eq.
        45), ``D = 2 beta / omega_1`` (Eq. 39), ``R``).

        Raises
        ------
        ValueError
            Naming the key and what is allowed: a key that changes the FE model (its modes and
            shapes, e.g. ``length_mm``, ``n_modes``), the gap key the scene does not use, or a
            key that is not a model key.
        """
        # lazy: keeps the beam kernels (scipy.linalg: 0.3 s) out of load_case
        from vibeam.case.beamscene import REBUILD_KEYS, conversions

        up = self.stop[0]
        gap_key = "gap_mm" if up.gap_mm is not None else "contact_gap_mm"
        allowed = ("Omega",) + tuple(k for k in self._CONTINUABLE
                                     if k == gap_key or k not in ("gap_mm", "contact_gap_mm"))
        if self.two_sided:
            # the lower stop's gap (the key the scene uses) and its R
            allowed += ("gap_lower_mm" if self.stop[1].gap_mm is not None else "contact_gap_lower_mm", "R_lower")
        if any(t is not None and is_compliant(t.law) for t in mass_law_tables(self)):
            # a compliant stop: a case continues it in the forced response only (Omega,
            # base_amplitude_m; the one shooting problem, vibeam.models.core.shooting)
            allowed = ("Omega", "voltage", "gain")
        if key in REBUILD_KEYS:
            raise ValueError(f"changes the FE model (its modes and shapes): a beam scene cannot be continued "
                             f"in it; allowed: {', '.join(allowed)}")
        if key == "frequency_hz":
            raise ValueError(f"is continued as 'Omega' (range and start_at in Hz); allowed: {', '.join(allowed)}")
        if key not in allowed:
            raise ValueError(f"cannot be continued in this scene; allowed: {', '.join(allowed)}")
        if self.drive is not None and key != "Omega":
            # the shooting problem's drive is gamma V; an acceleration-driven beam: the frequency only
            raise ValueError("cannot be continued in a beam driven by a base acceleration; allowed: Omega")
        if key == "Omega":
            return "Omega", 1.0, None
        gain, voltage = self.excitation.shaker()
        return conversions(self, self.scene(), gain_per_V=gain, voltage=voltage)[key]

    def _scene(self):
        # lazy: keeps skfem and the beam kernels (0.4 s) out of load_case
        from vibeam.case.beamscene import scene

        return scene(self, *self.laws())

    def laws(self) -> tuple:
        """``(upper, lower)``: the SI laws of the stops at the attached mass (a compliant stiffness
        in N/m^p at the contact point, :func:`vibeam.case.contact.beam_law`), the lower one None when
        it is the upper one's: Newton's with ``R`` or the upper stop's compliant law; below it
        its own (a compliant law, or Newton's with its ``R`` beside a compliant upper stop, or its
        ``R`` alone)."""
        # lazy: keeps the impact kernels (vibeam.models.impact) out of load_case
        from vibeam.models.contact import Restitution

        R = self.stop[0].R
        up, low = mass_law_tables(self)
        law = beam_law(up, R)
        lo = lower_law_spec(up, low)
        lower = beam_law(lo, target_R(lo, R))
        if law is None:
            if lower is None and low is not None and low.R is not None:
                lower = Restitution(float(low.R))
            return Restitution(float(R)), lower
        if _mixed(up, low):   # Newton's law below the compliant upper stop: its R, else the upper one's
            lower = Restitution(R if low.R is None else low.R)
        return law, lower

    # ---- what is specific to this fidelity (see CANONICAL_SPECS)
    def dofs(self) -> int:
        """Degrees of freedom simulated (work estimate): the retained modes (1 for the static
        mode, the mesh's ``2 n_elements`` for ``"all"``)."""
        n = self.system.n_modes
        if n == "static":
            return 1
        return 2 * int(self.system.n_elements) if n == "all" else int(n)

    def check(self, prefix: str) -> None:
        """``n_modes``: at most the mesh's free DOFs (2 per element: deflection and slope of
        each node but the clamped one); the drive's amplitude, the gaps and the laws computable."""
        sy = self.system
        n = sy.n_modes
        dofs = 2 * int(sy.n_elements)

        gain, voltage = self.excitation.shaker()
        check_scale(gain * voltage, f"'{prefix}.gain' x '{prefix}.voltage' (B = gain x voltage)")
        if self.drive is not None:
            check_scale(self.drive[1], f"'{prefix}.excitation.amplitude_m_s2'")
        names = (("gap_mm", "contact_gap_mm"), ("gap_lower_mm", "contact_gap_lower_mm"))
        for st, keys in zip(self.stop[:1 + int(self.two_sided)], names):
            for k, name in zip(("gap_mm", "contact_gap_mm"), keys):
                check_gap(getattr(st, k), f"'{prefix}.{name}'", sy.length_mm)
        for j, st in enumerate(self.point_stop_tables):
            for k in ("gap_mm", "contact_gap_mm"):
                check_gap(getattr(st, k, None), f"'{prefix}.stop[{j}].{k}'", sy.length_mm)
            check_gap(getattr(st, "Delta", None), f"'{prefix}.stop[{j}].Delta'")

        up, low = mass_law_tables(self)
        R = self.stop[0].R
        for key, table in (("contact", up), ("contact_lower", lower_law_spec(up, low))):
            try:
                beam_law(table, target_R(table, R))
            except ValueError as e:
                raise CaseError(f"'{prefix}.{key}': {e}") from None
        if isinstance(n, int) and n > dofs:
            raise CaseError(f"'{prefix}.n_modes' = {n}: more than the {dofs} degrees of freedom of the mesh "
                            f"('{prefix}.n_elements' = {sy.n_elements}); allowed: 1 ... {dofs}, \"all\" or "
                            f"\"static\"")

    def result_attrs(self) -> dict:
        """Calibrated and derived values of the scene, stored with its results."""
        from vibeam.case.beamscene import scene_of  # lazy: keeps skfem and the beam kernels (0.4 s) out of load_case

        sc = scene_of(self)
        g = sc.geometry
        out = {"EI_n_m2": g.EI_n_m2, "rotary_inertia_kg_m2": g.rotary_inertia_kg_m2,
               "rhoA_kg_m": g.rhoA_kg_m, "mass_kg": g.mass_kg, "f1_fe_hz": sc.f1_hz,
               "damping_D_s": sc.damping_D_s, "Delta_C_m": sc.Delta_C_m, "Delta_G_m": sc.Delta_G_m,
               "gamma_tilde_m_per_V": sc.gamma_tilde_m_per_V, "calibrated": sc.calibration is not None}
        if sc.calibration is not None:
            out["calibrated_frequencies_hz"] = np.asarray(sc.calibration.frequencies_hz)
        return out

    def converged_reference(self, table: dict, overrides: dict):
        """Model table of the converged reference of a cost table: the finest FE model of the
        scene, all modes on a mesh twice as fine, so every rung of the fidelity ladder (static
        mode, 1, 2, 4 ... modes, coarser meshes) is measured against the same thing."""
        fine = model_with(table, {k: v for k, v in overrides.items() if k not in ("n_modes", "n_elements")})
        fine.update(n_modes="all", n_elements=2 * int(fine.get("n_elements", 36)))
        return fine

    def effect_scene(self, effects, scene):
        """``(scene, coupled)``: ``scene`` with the structural effects of a run (eccentric contact,
        coupled platform, R table: :func:`vibeam.case.beamscene.effects_scene`,
        driven as the case says), and the coupled platform's record
        (:class:`vibeam.case.beamscene.CoupledPlatform`) or None; ``scene`` itself when no effect
        changes the structure."""
        plat = effects.platform
        coupled = plat is not None and plat.level == "coupled"
        if effects.eccentric_impact is None and not coupled and effects.restitution_law is None:
            return scene, None
        # lazy: keeps skfem and the beam kernels (0.4 s) out of load_case
        from vibeam.case.beamscene import effects_scene

        return effects_scene(self, effects, *self.laws())

    def case_update(self, key: str, value: float) -> tuple[dict, list]:
        """``[model]`` keys that set a fitted value, and notes: f_n is ``calibrate.f1_hz`` of a
        calibrated beam (an uncalibrated beam's f_n follows from EI: not written)."""
        if key == "natural_frequency_hz":
            cal = self.system.calibrate
            if cal is not None:
                return {"calibrate": dict(cal.model_dump(exclude_none=True), f1_hz=float(value))}, []
            return {}, ["f_n not written: the beam has no [model.calibrate] (its f_n follows from EI)"]
        return {key: float(value)}, []


#: the spec class of each ``[model.system] builder`` (the canonical tables, issue 58), by its
#: fidelity's name in the fidelity registry (:mod:`vibeam.models.registry`; a shorthand ``[model]``
#: is validated by the spec of the builder it expands into, :func:`_validate_model`).  A spec class
#: validates the table (pydantic) and is the framework's one place for what is specific to its
#: fidelity: ``physical``, ``dofs()`` (degrees of freedom, for the work
#: estimate), ``result_attrs()`` (derived values stored with a run), ``converged_reference(table)``
#: (the model table a cost table measures errors against), ``scene()`` (the scene every method
#: takes), ``effect_scene(effects, scene)`` (the scene with the structural effects of a run),
#: ``case_update(key, value)`` (a fitted value written back as case keys) and ``check(prefix)``
#: (checks beyond the table itself)
CANONICAL_SPECS = {"sdof": SDOFSceneSpec, "beam": BeamSceneSpec, "matrices": MatricesModelSpec,
                   "continuum": ContinuumModelSpec, "mesh": MeshModelSpec}


def _structure():
    """:mod:`vibeam.case.structure`, the builder of a structure's model from its tables."""
    from vibeam.case import structure  # lazy: keeps scipy.io, scipy.sparse.linalg and the N-mode kernels out of load_case

    return structure


ModelSpec = Union[SDOFSceneSpec, BeamSceneSpec, MatricesModelSpec, ContinuumModelSpec, MeshModelSpec]


def fidelity_methods(name: str) -> tuple:
    """Methods a case may ask for with fidelity ``name``, from the fidelity registry (pure
    Python: validating a case loads no solver).  ``continuation`` is open to every fidelity
    here and checked against the shooting problems registered in ``vibeam.models.SHOOTING``
    when the run is planned."""
    return fidelity(name).method_names


# ----------------------------------------------------------------------------- sweep
MAX_GRID_POINTS = 1_000_000   # points of a [sweep] grid
MAX_MAP_VALUES = 10_000       # values of a [map] parameter (each one is a whole sweep)
#: the largest forcing frequency ratio Omega: the exact flows' coefficients hold Omega^2 and
#: Omega^4 (the particular solution of the forced linear oscillator), which overflow double
#: precision above ~1e77; 1e8 times the natural frequency is beyond any beam model's validity
OMEGA_MAX = 1e8
#: ``[basins]``: the smallest forcing frequency (every state runs up to ``max_periods`` periods of
#: 1/Omega natural periods each), the box's largest magnitude and finest relative width, and the
#: most initial states of one computation (labels, final states and cells in memory: ~1 GB)
BASINS_OMEGA_MIN = 1e-3
BOX_MAX = 1e12
BOX_RESOLUTION = 1e-9
MAX_BASIN_STATES = 20_000_000


def _check_grid(v, positive: bool, max_n: int = MAX_GRID_POINTS, sweep: bool = False):
    """``[start, stop, number of points]`` (``None`` passes): finite ends, a whole number of
    points from 1 to ``max_n``, ``start < stop`` (the order of the sweep is ``[sweep]
    direction``, not the order of the ends, so a reversed range is refused rather than
    sorted), and ``start == stop`` for a single point only (n equal values would give a
    coordinate with repeated values)."""
    if v is None:
        return v
    if len(v) != 3:
        raise ValueError("must be [start, stop, number of points]")
    start, stop, n = (float(x) for x in v)
    if not (math.isfinite(start) and math.isfinite(stop)):
        raise ValueError("start and stop must be finite numbers")
    if positive and not (start > 0 and stop > 0):
        raise ValueError("start and stop must be positive")
    if not (math.isfinite(n) and n == int(n) and 1 <= n <= max_n):
        raise ValueError(f"the number of points must be a whole number >= 1 and <= {max_n}")
    if n == 1 and start != stop:
        raise ValueError("a single-point grid needs start == stop")
    if n > 1 and not start < stop:
        if start == stop:
            raise ValueError(f"start == stop gives {int(n)} equal values; allowed: start < stop, or a single point "
                             f"[{start:g}, {stop:g}, 1]")
        order = "; the order of the sweep is [sweep] direction" if sweep else ""
        raise ValueError(f"start > stop; allowed: start < stop (give the range in increasing order: "
                         f"[{stop:g}, {start:g}, {int(n)}]{order})")
    if n > 1 and not math.isfinite(stop - start):
        raise ValueError(f"stop - start = {stop - start} overflows; allowed: a range whose width is a finite number")
    if n > 1 and not np.all(np.diff(np.linspace(start, stop, int(n))) > 0):
        raise ValueError(f"{int(n)} points between {start!r} and {stop!r} are closer than the resolution of double "
                         f"precision (repeated values); allowed: fewer points or a wider range")
    return v


def check_grid(v, positive: bool, max_n: int = MAX_GRID_POINTS, sweep: bool = False):
    """The rule of a grid ``[start, stop, number of points]`` of a case (``[sweep] Omega`` /
    ``frequency_hz``, ``[map] values``), for other inputs held to it (the API's frequencies,
    :mod:`vibeam.case.arguments`); raises ValueError saying what is wrong."""
    return _check_grid(v, positive, max_n, sweep)


class SweepSpec(_Strict):
    """``[sweep]``: the frequency grid and how each point is simulated.

    ``transient_periods = "auto"`` extends each point's transient until the
    stroboscopic map settles, up to ``max_transient_periods`` (default 10000;
    :func:`vibeam.engine.sweep.settle_transient`); ``settle = true`` ends it as soon as the map has
    settled, after at least ``min_transient_periods`` (default 16) and at most
    ``transient_periods`` (:func:`vibeam.engine.sweep.settle_early`; a point that does not settle
    runs the whole transient, as without it); ``point_time_limit_s`` ends a point that runs
    longer as ``failed`` (default: no limit).  A point whose record is not periodic is
    continued until its spread is measured over ``statistics_periods`` periods (default
    256; 0 or at most ``record_periods``: the record alone), the sample its regression
    statistics need (:func:`vibeam.engine.records.batch_means`).  ``lyapunov = true`` adds each
    time-domain point's Lyapunov spectrum over ``lyapunov_periods`` periods (default 1000)
    from its final state (:mod:`vibeam.models.orbits.lyapunov`; variables ``lyapunov`` and
    ``lyapunov_error`` on (direction, Omega, exponent)).
    """

    Omega: list[float] | None = None
    frequency_hz: list[float] | None = None
    direction: Literal["up", "down", "both"] = "up"
    transient_periods: Annotated[int, Field(ge=0)] | Literal["auto"] = 400
    max_transient_periods: Annotated[int, Field(ge=1)] = 10000
    settle: bool = False
    min_transient_periods: Annotated[int, Field(ge=0)] = 16
    record_periods: Annotated[int, Field(ge=1)] = 64
    statistics_periods: Annotated[int, Field(ge=0)] = 256
    samples_per_period: Annotated[int, Field(ge=16, le=4096)] = 64
    continuation: bool = True
    period_rtol: Annotated[float, Field(gt=0.0, lt=1.0)] = 1e-5
    point_time_limit_s: Annotated[float, Field(gt=0.0)] | None = None
    lyapunov: bool = False
    lyapunov_periods: Annotated[int, Field(ge=2, le=100000)] = 1000

    def engine_options(self) -> dict:
        """The :class:`vibeam.engine.sweep.Sweep` settings of this table (all but the grid)."""
        return dict(direction=self.direction, transient_periods=self.transient_periods,
                    max_transient_periods=self.max_transient_periods, record_periods=self.record_periods,
                    settle=self.settle, min_transient_periods=self.min_transient_periods,
                    statistics_periods=self.statistics_periods,
                    samples_per_period=self.samples_per_period, continuation=self.continuation,
                    period_rtol=self.period_rtol, point_time_limit_s=self.point_time_limit_s,
                    lyapunov_shots=self.lyapunov_periods if self.lyapunov else 0)

    @field_validator("Omega", "frequency_hz")
    @classmethod
    def _grid(cls, v, info):
        _check_grid(v, positive=True, sweep=True)
        if info.field_name == "Omega" and v is not None and float(v[1]) > OMEGA_MAX:
            raise ValueError(f"stop = {float(v[1])!r} is above Omega's limit; allowed: Omega <= {OMEGA_MAX:g} (the "
                             f"exact flows' Omega^4 terms overflow double precision)")
        return v

    @model_validator(mode="after")
    def _exactly_one_grid(self):
        if (self.Omega is None) == (self.frequency_hz is None):
            raise ValueError("give exactly one of 'Omega' (nondimensional) or 'frequency_hz'")
        if self.settle and self.transient_periods == "auto":
            raise ValueError("settle = true ends a transient of at most transient_periods early; allowed: an "
                             "integer transient_periods with it (\"auto\" lengthens the transient instead)")
        return self

    def grid(self, natural_frequency_hz=None) -> np.ndarray:
        """Forcing frequencies Omega (nondimensional), shape (n,)."""
        if self.Omega is not None:
            start, stop, n = self.Omega
            return np.linspace(start, stop, int(n))
        start, stop, n = self.frequency_hz
        return np.linspace(start, stop, int(n)) / natural_frequency_hz


# ----------------------------------------------------------------------------- runs
class _RunBase(_Strict):
    # an HDF5 group name: no '/', no control characters, not '.' or '..'
    name: Annotated[str, Field(min_length=1, max_length=200, pattern=r"^[^/\x00-\x1f\x7f]+$")]
    model: dict = Field(default_factory=dict)
    effects: dict = Field(default_factory=dict)

    @field_validator("name")
    @classmethod
    def _not_dots(cls, v):
        if v.strip(".") == "" or v != v.strip():
            raise ValueError("a run name cannot be only dots or start or end with a space")
        return v


class EventRun(_RunBase):
    """Method ``event``: the exact event-driven solver."""

    method: Literal["event"]
    transient_samples: Annotated[int, Field(ge=4, le=1024)] = 16
    chatter_tol: Annotated[float, Field(gt=0.0, lt=1.0)] = 1e-7
    max_impacts_per_period: Annotated[int, Field(ge=1)] = 20000
    recurrence: bool = True


class ODERun(_RunBase):
    """Methods ``direct``, ``zhuravlev``, ``ivanov`` (scipy ``solve_ivp``)."""

    method: Literal["direct", "zhuravlev", "ivanov"]
    solver: Literal["RK23", "RK45", "DOP853", "Radau", "LSODA"] = "RK23"
    rtol: Annotated[float, Field(gt=0.0, lt=1.0)] = 1e-4
    atol: Annotated[float, Field(gt=0.0)] = 1e-8
    max_step: Annotated[float, Field(gt=0.0)] | None = None


class AveragingRun(_RunBase):
    """Method ``averaging`` (paper Eqs. 18-27) for the resonance Omega ~ 2k."""

    method: Literal["averaging"]
    k: Literal[1, 2, 3] = 1


class MappingRun(_RunBase):
    """Method ``mapping``: pointwise mapping (paper Sec. 4.2)."""

    method: Literal["mapping"]
    n: Annotated[int, Field(ge=1, le=4)] = 1
    form: Literal["full", "simplified"] = "full"


class ContinuationRun(_RunBase):
    """Method ``continuation``: pseudo-arclength continuation of periodic orbits with stability
    and bifurcations (:mod:`vibeam.models.orbits.continuation`) over the ``[sweep]`` range.

    ``parameter``: ``Omega`` (the forcing frequency, default) or a numeric model key (``B``,
    ``Delta``, ``R``, ``beta``; physical scenes ``voltage``, ``gain``, ``gap_mm``,
    ``damping_ratio``, ``R``); ``range = [low, high]`` in the parameter's units -- for the
    frequency in those of ``[sweep]`` (Hz for physical scenes) -- (default: the ``[sweep]``
    range for the frequency, the ``[map]`` values for the mapped key; required otherwise);
    ``at``: the forcing frequency of a continuation in another key (Hz for physical scenes,
    Omega otherwise); ``start``: ``sweep`` (the settled state of an event run and its
    detected period), ``averaging`` (paper Eqs. 18-23), ``linear`` (the non-impacting orbit) or
    ``auto`` (every one that exists there; duplicates dropped); ``start_at``: ``low``,
    ``high``, ``both`` ends of the range or a value (units as ``range``); ``n``: period of a linear or averaging start;
    step controls ``ds``, ``ds_min``, ``ds_max``, ``max_points``; ``max_period`` bounds the
    period-doubling branch switching; ``curves``: two-parameter curves of folds, period
    doublings and grazings in a ``[map]`` case (of orbits up to period ``curve_max_period``),
    seeded by the branches at the scene's value of the map key and at ``slices`` values
    inside the map range; ``curve_points`` bounds each curve.
    """

    method: Literal["continuation"]
    parameter: Annotated[str, Field(min_length=1)] = "Omega"
    range: Annotated[list[float], Field(min_length=2, max_length=2)] | None = None
    at: Annotated[float, Field(gt=0.0)] | None = None
    start: Literal["sweep", "averaging", "linear", "auto"] = "auto"
    start_at: Literal["low", "high", "both"] | float = "both"
    n: Annotated[int, Field(ge=1, le=64)] = 1
    ds: Annotated[float, Field(gt=0.0, le=1.0)] = 0.01
    ds_min: Annotated[float, Field(gt=0.0, le=1.0)] = 1e-9
    ds_max: Annotated[float, Field(gt=0.0, le=1.0)] = 0.05
    max_points: Annotated[int, Field(ge=2, le=100_000)] = 2000
    max_period: Annotated[int, Field(ge=1, le=64)] = 8
    switch: bool = True
    curves: bool = True
    slices: Annotated[int, Field(ge=0, le=50)] = 3
    curve_points: Annotated[int, Field(ge=2, le=10_000)] = 200
    curve_max_period: Annotated[int, Field(ge=1, le=64)] = 2

    @model_validator(mode="after")
    def _steps(self):
        if not self.ds_min <= self.ds <= self.ds_max:
            raise ValueError(f"need ds_min <= ds <= ds_max (got {self.ds_min}, {self.ds}, {self.ds_max})")
        if self.range is not None and not (math.isfinite(self.range[0]) and self.range[1] > self.range[0]):
            raise ValueError(f"range = {self.range} must be [low, high] with low < high")
        return self


RunSpec = Annotated[Union[EventRun, ODERun, AveragingRun, MappingRun, ContinuationRun],
                    Field(discriminator="method")]


# ----------------------------------------------------------------------------- effects
_Pair = Annotated[list[float], Field(min_length=2, max_length=2)]


class PlatformSpec(_Strict):
    """``[effects.platform]``: the shaker drives a platform that carries the clamp (paper Sec. 5.2).

    ``level = "filter"``: the base displacement is the platform's second-order
    transfer function times ``gamma~ V``, normalised to 1 at
    ``reference_frequency_hz`` (where ``gain`` was identified; default the
    scene's natural frequency), with ``frequency_hz``/``damping_ratio`` of the
    platform mode (3.25 Hz in the paper) or identified from two measured
    ``gains = [[f1_hz, g1], [f2_hz, g2]]``.  ``level = "coupled"``: the
    platform is a DOF of mass ``mass_kg`` (beam fidelity) loaded by the beam's
    reaction.
    """

    level: Literal["filter", "coupled"] = "filter"
    frequency_hz: Annotated[float, Field(gt=0.0)] = 3.25
    damping_ratio: Annotated[float, Field(ge=0.0, lt=1.0)] = 0.05
    reference_frequency_hz: Annotated[float, Field(gt=0.0)] | None = None
    gains: Annotated[list[_Pair], Field(min_length=2, max_length=2)] | None = None
    mass_kg: Annotated[float, Field(gt=0.0)] | None = None


class EccentricImpactSpec(_Strict):
    """``[effects.eccentric_impact]``: contact point ``offset_mm`` from the mass centre along
    the beam, so each impact also applies a moment to the attached mass (paper Sec. 5)."""

    offset_mm: float


class GapDriftSpec(_Strict):
    """``[effects.gap_drift]``: the gap changes during a sweep (paper Fig. 21).

    Either a prescribed ``table = [[frequency_hz, gap_mm], ...]`` (linear
    interpolation, constant outside), or ``law = "sliding"``: after each
    frequency point the stop slides away by ``slide_mm_per_impulse`` times the
    normalised impulse delivered in that point, at most ``max_drift_mm``.
    """

    table: Annotated[list[_Pair], Field(min_length=1)] | None = None
    law: Literal["sliding"] | None = None
    slide_mm_per_impulse: Annotated[float, Field(ge=0.0)] = 0.0
    max_drift_mm: Annotated[float, Field(ge=0.0)] = 0.1

    @model_validator(mode="after")
    def _one(self):
        if (self.table is None) == (self.law is None):
            raise ValueError("give either a 'table' of [frequency_hz, gap_mm] or law = \"sliding\"")
        return self


class RestitutionLawSpec(_Strict):
    """``[effects.restitution_law]``: R as a piecewise linear function of the pre-impact
    velocity at the sensor (paper Fig. 26), constant beyond the table's ends."""

    velocity_mm_s: Annotated[list[float], Field(min_length=2)]
    R: Annotated[list[RestitutionValue], Field(min_length=2)]

    @model_validator(mode="after")
    def _table(self):
        if len(self.velocity_mm_s) != len(self.R):
            raise ValueError("velocity_mm_s and R must have the same length")
        if any(b <= a for a, b in zip(self.velocity_mm_s, self.velocity_mm_s[1:])):
            raise ValueError("velocity_mm_s must increase")
        return self


class SensorSpec(_Strict):
    """``[effects.sensor]``: the displacement sensor at L_S sampled at ``sampling_hz`` (5 kHz in
    the paper) with Gaussian ``noise_mm``; velocity by central differences; the paper's CoR
    identification R = -U'+/U'- (Sec. 5.1) run on the simulated record."""

    sampling_hz: Annotated[float, Field(gt=0.0)] = 5000.0
    noise_mm: Annotated[float, Field(ge=0.0)] = 0.0
    seed: int = 0
    identify_R: bool = True
    # the identification repeated at each noise level (same draw, scaled): R error vs noise
    noise_ladder_mm: list[Annotated[float, Field(ge=0.0)]] | None = None  # None: 0 ... 0.01 mm
    impacts: Literal["first3", "all"] = "first3"   # impacts used per point (paper: first three)
    oversample: Annotated[int, Field(ge=1, le=16)] = 2  # recorded samples per sensor sample


class EffectsSpec(_Strict):
    """``[effects]``: each effect is off unless its table is present."""

    platform: PlatformSpec | None = None
    eccentric_impact: EccentricImpactSpec | None = None
    gap_drift: GapDriftSpec | None = None
    restitution_law: RestitutionLawSpec | None = None
    sensor: SensorSpec | None = None

    def active(self) -> list[str]:
        return [k for k in type(self).model_fields if getattr(self, k) is not None]


class AssessSpec(_Strict):
    """``[assess]``: assessments written by ``vibeam run`` when asked.

    ``spectra``: windowed FFT of the sensor displacement and velocity per point,
    with the peaks that are not harmonics of the forcing listed (and, for the
    FE fidelity, the mode each belongs to); ``participation``: share of each
    mode in the sensor displacement and energy along the sweep;
    ``time_series``: frequencies (Hz for physical scenes, Omega otherwise) at
    which time series and phase portraits of every run are plotted overlaid.
    """

    spectra: bool = False
    participation: bool = False
    time_series: list[Annotated[float, Field(gt=0.0)]] = Field(default_factory=list)
    peaks: Annotated[int, Field(ge=1, le=50)] = 5             # non-harmonic peaks listed per point
    subharmonic_order: Annotated[int, Field(ge=1, le=16)] = 8  # k/n Omega with n <= this are harmonics
    mode_tolerance: Annotated[float, Field(gt=0.0, lt=1.0)] = 0.1  # relative, peak -> mode
    hfc_band: _Pair | None = None   # band of the high-frequency component (Hz / Omega units)
    spectrum_max: Annotated[float, Field(gt=0.0)] | None = None  # top of the stored map
    time_series_periods: Annotated[int, Field(ge=1)] = 8


class MapSpec(_Strict):
    """``[map]``: a parameter map (paper Fig. 18) over the sweep's frequency grid and one model
    parameter.

    ``parameter`` is a numeric key of the ``[model]`` table (e.g. ``voltage``,
    ``gap_mm``, ``R`` for a rig scene; ``B``, ``Delta``, ``R``, ``beta`` for a
    nondimensional one; ``system.<key>`` / ``excitation.<key>`` name the same key, and a stop's
    number its path, :mod:`vibeam.case.paths`) and ``values = [start, stop, number of points]`` its
    grid.  Every value gives one up and/or down sweep line along the frequency
    axis (``[sweep] direction``), so hysteresis shows.
    """

    parameter: Annotated[str, Field(min_length=1)]
    values: list[float]

    @field_validator("parameter")
    @classmethod
    def _flat(cls, v):
        return flat_key(v)          # system.<key> / excitation.<key>: the flat key (vibeam.case.paths)

    @field_validator("values")
    @classmethod
    def _grid(cls, v):
        return _check_grid(v, positive=False, max_n=MAX_MAP_VALUES)

    def grid(self) -> np.ndarray:
        """The parameter values, shape (n,)."""
        start, stop, n = self.values
        return np.linspace(start, stop, int(n))


class BasinsSpec(_Strict):
    """``[basins]``: basins of attraction (a grid of initial states) or the census of attractors
    (``samples`` random initial states, seeded) at one or more forcing frequencies
    (:mod:`vibeam.analysis.attractors`).

    ``Omega`` / ``frequency_hz``: a number or a list (omitted: every frequency of the sweep's
    grid, a census along the sweep); ``grid = [nx, ny]`` (default 200 x 200) or ``samples``;
    ``x_range``/``y_range``: the box in the grid's units (SDOF: ``q``, ``q'``, or for a
    physical scene ``U`` mm and ``U'`` mm/s; beam: the modal ``coordinates = [i, j]`` or
    ``"sensor"``, U and U' at the sensor in the static deflection shape), default a box
    around the stop; ``run``: the run whose model and solver are used (default the first
    time-domain run).  Recurrence settings (:mod:`vibeam.models.orbits.attractors`): ``recurrences``
    consecutive revisits find an attractor, ``locate_periods`` samples describe it,
    ``max_periods`` bound a trajectory (else ``unsettled``), ``basin_hits`` decides by the basin
    cells of earlier states after ``hit_basin`` consecutive visits (default 50: with 10, 12 of
    2000 census states of the two-sided Fig. 7 scene at Omega = 2.38 were labelled chaotic on
    their way to the period-1 orbit; with 20, 2; with 50, none, as without basin hits).
    ``verify`` labelled states per frequency are followed ``verify_periods`` more periods and
    matched to the attractors found: the estimated mislabel rate, reported with the fractions
    (0: no check).  ``record_periods``: the simulation describing each attractor;
    ``lyapunov_periods``: its Lyapunov spectrum (0: none).  ``along = "map"``: in a ``[map]``
    case, the census at one forcing frequency along the mapped parameter's values (each value its
    own model), instead of along the frequency.
    """

    Omega: Annotated[float, Field(gt=0.0)] | Annotated[list[Annotated[float, Field(gt=0.0)]], Field(min_length=1)] | None = None
    frequency_hz: Annotated[float, Field(gt=0.0)] | Annotated[list[Annotated[float, Field(gt=0.0)]], Field(min_length=1)] | None = None
    grid: Annotated[list[Annotated[int, Field(ge=2, le=2000)]], Field(min_length=2, max_length=2)] | None = None
    samples: Annotated[int, Field(ge=1, le=1_000_000)] | None = None
    seed: Annotated[int, Field(ge=0, le=2**63 - 1)] = 0
    x_range: _Pair | None = None
    y_range: _Pair | None = None
    coordinates: Annotated[list[Annotated[int, Field(ge=0)]], Field(min_length=2, max_length=2)] | Literal["sensor"] | None = None
    run: str | None = None
    recurrences: Annotated[int, Field(ge=2, le=100_000)] = 100
    locate_periods: Annotated[int, Field(ge=1, le=100_000)] = 1000
    max_periods: Annotated[int, Field(ge=10, le=10_000_000)] = 20000
    hit_attractor: Annotated[int, Field(ge=1, le=10_000)] = 2
    hit_basin: Annotated[int, Field(ge=1, le=10_000)] = 50
    basin_hits: bool = True
    verify: Annotated[int, Field(ge=0, le=100_000)] = 50
    verify_periods: Annotated[int, Field(ge=100, le=10_000_000)] = 5000
    record_periods: Annotated[int, Field(ge=8, le=100_000)] = 256
    lyapunov_periods: Annotated[int, Field(ge=0, le=1_000_000)] = 1000
    along: Literal["frequency", "map"] = "frequency"

    @model_validator(mode="after")
    def _one_of(self):
        if self.Omega is not None and self.frequency_hz is not None:
            raise ValueError("give at most one of 'Omega' (nondimensional) or 'frequency_hz'")
        if self.grid is not None and self.samples is not None:
            raise ValueError("give 'grid' (basins on a grid) or 'samples' (random initial states), not both")
        for k in ("x_range", "y_range"):
            r = getattr(self, k)
            if r is None:
                continue
            lo, hi = float(r[0]), float(r[1])
            big = max(1.0, abs(lo), abs(hi))
            if not hi > lo:
                raise ValueError(f"{k} = {list(r)}: [low, high] with high > low")
            if big > BOX_MAX or not (hi - lo) >= BOX_RESOLUTION * big:
                raise ValueError(f"{k} = {list(r)}: allowed: |low|, |high| <= {BOX_MAX:g} and high - low >= "
                                 f"{BOX_RESOLUTION:g} x max(1, |low|, |high|) (a box whose cells double precision "
                                 f"can tell apart)")
        return self

    def states(self) -> int:
        """Initial states per frequency: ``samples``, or the grid's cells (default 200 x 200)."""
        if self.samples is not None:
            return int(self.samples)
        nx, ny = self.grid if self.grid is not None else (200, 200)
        return int(nx) * int(ny)

    def frequencies(self, sweep: SweepSpec, natural_frequency_hz=None) -> np.ndarray:
        """Forcing frequencies Omega (nondimensional), shape (n,): this table's or the sweep's."""
        v = self.Omega if self.Omega is not None else self.frequency_hz
        if v is None:
            return sweep.grid(natural_frequency_hz)
        v = np.atleast_1d(np.asarray(v, float))
        if self.frequency_hz is not None:
            if not natural_frequency_hz:
                raise ValueError(f"[basins] frequency_hz = {self.frequency_hz}: needs a physical scene "
                                 f"(natural_frequency_hz); give Omega")
            v = v / natural_frequency_hz
        bad = v[(v < BASINS_OMEGA_MIN) | (v > OMEGA_MAX)]
        if bad.size:
            raise ValueError(f"[basins] Omega = {float(bad[0])!r}: allowed: {BASINS_OMEGA_MIN:g} <= Omega <= "
                             f"{OMEGA_MAX:g} (each state runs up to max_periods forcing periods, each of 1/Omega "
                             f"natural periods)")
        if v.size * self.states() > MAX_BASIN_STATES:
            raise ValueError(f"[basins]: {v.size} frequencies x {self.states()} states = {v.size * self.states()} "
                             f"initial states; allowed: at most {MAX_BASIN_STATES:g} (their labels and final "
                             f"states are held in memory): fewer frequencies, a smaller grid or fewer samples")
        return v


class QuickSpec(_Strict):
    """``[quick]``: the quick variant of a case (``vibeam run --quick``; regressed by the tests)."""

    points: Annotated[int, Field(ge=1)] = 11
    map_values: Annotated[int, Field(ge=1)] = 3   # parameter values of a [map] kept
    transient_periods: Annotated[int, Field(ge=0)] | Literal["auto"] | None = None
    max_transient_periods: Annotated[int, Field(ge=1)] | None = None
    record_periods: Annotated[int, Field(ge=1)] | None = None
    statistics_periods: Annotated[int, Field(ge=0)] | None = None


class RegressSpec(_Strict):
    """``[regress]``: tolerances of ``vibeam regress`` (amplitude in the FRC's own units).

    ``spread_sigmas`` and ``spread_range`` are the tolerances of the points compared by
    the spread of their per-period amplitude (non-periodic, unsettled or of another
    period; :mod:`vibeam.analysis.regress`): the means within ``spread_sigmas`` standard errors,
    the smallest and largest per-period amplitude within ``spread_range`` of the range.
    """

    amplitude_atol: Annotated[float, Field(ge=0.0)] = 0.0
    amplitude_rtol: Annotated[float, Field(ge=0.0)] = 1e-6
    period: bool = True
    spread_sigmas: Annotated[float, Field(gt=0.0)] = 4.0
    spread_range: Annotated[float, Field(ge=0.0)] = 0.5


class Case(_Strict):
    """A whole scene."""

    name: Annotated[str, Field(min_length=1, pattern=r"^[A-Za-z0-9_.+-]+$")]
    description: str = ""
    model: dict
    sweep: SweepSpec
    run: Annotated[list[RunSpec], Field(min_length=1)]
    regress: RegressSpec = Field(default_factory=RegressSpec)
    effects: EffectsSpec = Field(default_factory=EffectsSpec)
    assess: AssessSpec = Field(default_factory=AssessSpec)
    quick: QuickSpec = Field(default_factory=QuickSpec)
    map: MapSpec | None = None
    basins: BasinsSpec | None = None
    uncertainty: UncertaintySpec | None = None

    @field_validator("name")
    @classmethod
    def _name_in_results(cls, v):
        # the output folder is results/<name>: "." and ".." (any name of dots only) would write
        # into results/ itself or outside it
        if v.strip(".") == "":
            raise ValueError("a case name of dots only would write into results/ itself or outside it "
                             "(results/<name>); allowed: letters, digits, '_', '.', '+', '-', not only dots")
        return v

    @field_validator("run")
    @classmethod
    def _unique_names(cls, runs):
        names = [r.name for r in runs]
        dup = sorted({n for n in names if names.count(n) > 1})
        if dup:
            raise ValueError(f"run names must be unique; repeated: {dup}")
        # file names made from run names (map_<run>.png) must differ too, also on a file
        # system that ignores case: "a b" and "a_b", or "Up" and "up", would overwrite each other
        stems: dict = {}
        for n in names:
            stem = re.sub(r"[^A-Za-z0-9_.+-]+", "_", n).casefold()
            if stem in stems:
                raise ValueError(f"run names {stems[stem]!r} and {n!r} give the same file name "
                                 f"(map_{stem}.png); rename one")
            stems[stem] = n
        return runs

    # the model table is validated by its fidelity's spec (below)
    def model_spec(self, overrides: dict | None = None):
        data = model_with(self.model, overrides)
        return _validate_model(data, prefix="model" if not overrides else "run.model")

    def effects_for(self, run) -> EffectsSpec:
        """Effects of a run: the case's ``[effects]`` with the run's ``[run.effects]`` tables
        replacing or adding whole effects (``effect = {}`` cannot switch one off; use a
        case without it)."""
        if not run.effects:
            return self.effects
        data = self.effects.model_dump(exclude_none=True)
        data.update(run.effects)
        try:
            return EffectsSpec.model_validate(data)
        except ValidationError as e:
            raise CaseError(validation_message(e, f"run '{run.name}'.effects", EffectsSpec)) from None

    def run_settings(self, run) -> dict:
        """Method settings of a run (everything but name, method and model overrides; unset
        optional settings are left to the solver's defaults)."""
        return {k: v for k, v in run.model_dump(exclude={"name", "method", "model", "effects"}).items()
                if v is not None}

    def quick_variant(self) -> "Case":
        """The quick variant of this case (``vibeam run --quick``; regressed by the tests).

        The sweep grid becomes ``[quick] points`` frequencies spread evenly over
        the case's grid, both ends included (the case's own grid if it has no
        more points than that; one point: the start), and ``[quick]
        transient_periods`` / ``max_transient_periods`` / ``record_periods`` /
        ``statistics_periods`` replace the
        sweep's where given.
        Name, model, runs, effects, assessments and tolerances are unchanged.
        """
        q, sw = self.quick, self.sweep
        key = "Omega" if sw.Omega is not None else "frequency_hz"
        start, stop, n = getattr(sw, key)
        points = min(int(q.points), int(n))
        sweep = {key: [start, stop if points > 1 else start, points]}
        if q.transient_periods is not None:
            sweep["transient_periods"] = q.transient_periods
        if q.record_periods is not None:
            sweep["record_periods"] = q.record_periods
        if q.statistics_periods is not None:
            sweep["statistics_periods"] = q.statistics_periods
        if q.max_transient_periods is not None:
            sweep["max_transient_periods"] = q.max_transient_periods
        data = self.model_dump()
        data["sweep"] = dict(data["sweep"], **sweep)
        if self.map is not None:
            m0, m1, mn = self.map.values
            k = min(int(q.map_values), int(mn))
            data["map"] = dict(data["map"], values=[m0, m1 if k > 1 else m0, k])
        if self.basins is not None:
            # the quick variant's basins: a 40 x 40 grid (or 40 samples) at most, 200 Lyapunov periods
            b = dict(data["basins"])
            if b.get("samples") is not None:
                b["samples"] = min(int(b["samples"]), 40)
            else:
                b["grid"] = [min(int(n), 40) for n in (b.get("grid") or [200, 200])]
            b["lyapunov_periods"] = min(int(b["lyapunov_periods"]), 200)
            data["basins"] = b
        return Case.model_validate(data)

    def map_parameters(self) -> list[str]:
        """What a ``[map]`` (and ``vibeam fit``) may vary: the numeric (float) keys set in
        ``[model]``, then the paths of the stops' numbers (:func:`vibeam.case.paths.parameter_paths`:
        ``stops[1].law.stiffness_n_m``, ``stops[0].gap_mm``, ...)."""
        spec = self.model_spec()
        if is_canonical(self.model):
            # the canonical tables: the numbers of [model.system] and [model.excitation] by their keys,
            # and the flat keys that are aliases of a number the table gives (R, gap_mm, beta, B, ...)
            flat = {k for t in (spec.system, getattr(spec, "excitation", None)) if t is not None
                    for k, v in t.model_dump().items() if isinstance(v, float) and not isinstance(v, bool)}
            paths = parameter_paths(self.model)
            given = [*aliases(self.model["system"]["builder"]).items(),
                     *((alias_of(self.model, p), p) for p in paths)]
            flat |= {k for k, p in given if not is_path(k) and k not in flat and _is_number(self.model, p)}
            return sorted(flat) + paths
        # the shorthand: its flat keys whose number the scene has (given, or a default: youngs_modulus_gpa)
        values = spec.shorthand()
        return sorted(k for k in aliases(self.model["fidelity"]) if isinstance(values.get(k), float)
                      and not isinstance(values[k], bool)) + parameter_paths(self.model)


def _is_number(model: dict, path: str) -> bool:
    """The number ``path`` names is given in ``model`` (a ``[model]`` table)."""
    try:
        v = get_value(model, path)
    except ValueError:          # a stop the scene does not have
        return False
    return isinstance(v, (int, float)) and not isinstance(v, bool)


def _validate_model(data: dict, prefix: str = "model"):
    """The spec of a ``[model]`` table: the shorthand (``fidelity = "sdof"`` / ``"beam"``) expanded
    into the canonical tables (:func:`vibeam.case.expand.expanded`), which the spec of their
    ``[model.system] builder`` validates; a message names the key the user wrote
    (:func:`vibeam.case.expand.user_key`).  Raises CaseError in one line."""
    allowed = ", ".join(repr(k) for k in CANONICAL_SPECS)
    if not isinstance(data, dict):
        raise CaseError(f"'{prefix}' = {quote_value(data)}: must be a table with fidelity = {allowed}")
    origins, shorthand, refused = {}, None, []
    if "fidelity" in data:
        fid = data["fidelity"]
        if not isinstance(fid, str) or fid not in CANONICAL_SPECS:
            raise CaseError(f"'{prefix}.fidelity' = {quote_value(fid)} is not allowed; allowed: {allowed}")
        if fid not in SHORTHAND_FIDELITIES:     # a builder without a shorthand: its spec names the wrong key
            try:
                return CANONICAL_SPECS[fid].model_validate(data)
            except ValidationError as e:
                raise CaseError(validation_message(e, prefix, CANONICAL_SPECS[fid])) from None
        refused = [f"unknown key '{prefix}.{one_line(str(k))}' (value {quote_value(v)}); allowed keys: "
                   f"{', '.join(sorted(SHORTHAND_KEYS[fid]))}" for k, v in data.items() if k not in SHORTHAND_KEYS[fid]]
        data = {k: v for k, v in data.items() if k in SHORTHAND_KEYS[fid]}
        # a required number the shorthand lacks is named by its key; a stand-in lets the other errors show
        for k in required_keys(fid, data):
            if k not in data:
                refused.append(f"missing key '{prefix}.{k}'")
                data[k] = 1.0 if k in ("R", "natural_frequency_hz", "length_mm") else 0.0
        for k in ("contact", "contact_lower"):      # the shorthand's law tables, named as written
            if isinstance(data.get(k), dict):
                try:
                    ContactSpec.model_validate(data[k])
                except ValidationError as e:
                    raise CaseError(validation_message(e, f"{prefix}.{k}", ContactSpec)) from None
        try:
            data, origins = expanded(data)
            origins = {("system",): "model", ("excitation",): "model", **origins}
        except ValueError as e:
            raise CaseError(f"'{prefix}': {one_line(str(e))}") from None
        shorthand = fid
    system = data.get("system")
    if not (isinstance(system, dict) and "builder" in system):
        raise CaseError(f"missing key '{prefix}.fidelity'; allowed: {allowed}")
    # the canonical tables (issue 58): [model.system] builder = ...
    fid = system["builder"]
    if not isinstance(fid, str) or fid not in CANONICAL_SPECS:
        raise CaseError(f"'{prefix}.system.builder' = {quote_value(fid)} is not allowed; allowed: "
                        f"{', '.join(chr(34) + k + chr(34) for k in CANONICAL_SPECS)}")
    try:
        spec = CANONICAL_SPECS[fid].model_validate(data)
    except ValidationError as e:
        raise CaseError("; ".join([validation_message(e, prefix, CANONICAL_SPECS[fid], origins=origins,
                                                      shorthand=shorthand), *refused])) from None
    if refused:
        raise CaseError("; ".join(refused))
    spec.check(prefix)
    if shorthand is not None:
        spec._shorthand = shorthand
    return spec


_RUN_BY_METHOD = {m: c for c in (EventRun, ODERun, AveragingRun, MappingRun, ContinuationRun)
                  for m in c.model_fields["method"].annotation.__args__}


def _allowed_keys(model_cls, loc) -> list[str]:
    """Keys allowed at ``loc`` (a pydantic error location) inside ``model_cls``."""
    cls = model_cls
    for part in loc[:-1]:
        if isinstance(part, int):
            continue
        if part in _RUN_BY_METHOD and cls is Case:
            cls = _RUN_BY_METHOD[part]
            continue
        if cls is EffectsSpec and part in EffectsSpec.model_fields:
            ann = EffectsSpec.model_fields[part].annotation
            cls = next(c for c in ann.__args__ if isinstance(c, type) and issubclass(c, BaseModel))
            continue
        f = getattr(cls, "model_fields", {}).get(part)
        if f is None:
            continue
        if part == "run":
            continue  # the discriminator tag that follows picks the class
        ann = f.annotation
        if isinstance(ann, type) and issubclass(ann, BaseModel):
            cls = ann
            continue
        for cand in getattr(ann, "__args__", (ann,)):
            if isinstance(cand, type) and issubclass(cand, BaseModel):
                cls = cand
                break
    return sorted(getattr(cls, "model_fields", {}))


def _untagged(loc) -> tuple:
    """A pydantic error location without the method tag pydantic inserts after a run's index and
    the member names of a scalar union (e.g. transient_periods: int or "auto")."""
    return tuple(p for i, p in enumerate(loc)
                 if not (i >= 2 and loc[i - 2] == "run" and isinstance(loc[i - 1], int) and p in _RUN_BY_METHOD)
                 and not (isinstance(p, str) and (p.startswith("literal[") or p in _UNION_MEMBERS)))


def _key(loc, tags: bool = True) -> str:
    """Dotted key of a pydantic error location, e.g. ``run[0].chatter_tol`` (with ``tags``, the
    method tag that pydantic inserts after a run's index is left out)."""
    parts = []
    for p in (_untagged(loc) if tags else loc):
        if isinstance(p, int):
            parts.append(f"[{p}]")
        else:
            parts.append(("." if parts else "") + one_line(str(p)))
    return "".join(parts)


_MAX_DEPTH = 32
_UNION_MEMBERS = {"constrained-int", "constrained-float", "int", "float", "str", "bool", "none"}


def _check_ints(data, loc=()) -> None:
    """TOML integers are 64-bit (tomllib reads any size): a larger one is an error, not a
    silent overflow in a solver; no scene nests tables or arrays more than a few levels."""
    if len(loc) > _MAX_DEPTH:
        raise CaseError(f"'{_key(loc[:_MAX_DEPTH], tags=False)}': tables or arrays nested more than "
                        f"{_MAX_DEPTH} levels deep")
    if isinstance(data, dict):
        for k, v in data.items():
            _check_ints(v, (*loc, k))
    elif isinstance(data, list):
        for i, v in enumerate(data):
            _check_ints(v, (*loc, i))
    elif isinstance(data, int) and not isinstance(data, bool) and not -2**63 <= data < 2**63:
        raise CaseError(f"'{_key(loc, tags=False)}' = {quote_value(data)}: an integer must fit in 64 bits "
                        f"(-2**63 ... 2**63 - 1)")


_METHODS = ", ".join(repr(m) for m in _RUN_BY_METHOD)


def validation_message(err: ValidationError, prefix: str, root_cls, origins: dict | None = None,
                       shorthand: str | None = None) -> str:
    """One line naming, for every error, the key, the value and what is allowed; for a ``[model]``
    table written in the shorthand of fidelity ``shorthand``, the key the user wrote (``origins`` of
    its expansion, :func:`vibeam.case.expand.user_key`)."""
    msgs = []
    for e in err.errors():
        key = _key(e["loc"]) if shorthand is None else one_line(user_key(origins or {}, _untagged(e["loc"]),
                                                                          shorthand))
        if prefix and key:
            where = prefix + ("" if key.startswith("[") else ".") + key
        else:
            where = prefix or key
        val = e.get("input")
        if e["type"] == "extra_forbidden":
            allowed = _allowed_keys(root_cls, e["loc"])
            if shorthand is not None and re.fullmatch(r"contact(_lower)?\.[^.\[]+", key):
                allowed = sorted(ContactSpec.model_fields)      # a law table of the shorthand
            elif shorthand is not None and "." not in key and "[" not in key:
                allowed = sorted(SHORTHAND_KEYS[shorthand])
            msgs.append(f"unknown key '{where}' (value {quote_value(val)}); allowed keys: {', '.join(allowed)}")
        elif e["type"] == "missing":
            msgs.append(f"missing key '{where}'")
        elif e["type"] == "union_tag_invalid":     # a run's method
            tag = val.get("method") if isinstance(val, dict) else e.get("ctx", {}).get("tag")
            msgs.append(f"'{where}.method' = {quote_value(tag)} is not a method; allowed: {_METHODS}")
        elif e["type"] == "union_tag_not_found":
            msgs.append(f"missing key '{where}.method'; allowed: {_METHODS}")
        else:
            msg = one_line(e["msg"].removeprefix("Value error, "))
            if isinstance(val, dict):
                msgs.append(f"'{where}': {msg}")
            elif msgs and msgs[-1].startswith(f"'{where}' = {quote_value(val)}: "):
                msgs[-1] += f", or {msg[:1].lower()}{msg[1:]}"   # another member of a union
            else:
                msgs.append(f"'{where}' = {quote_value(val)}: {msg}")
    return "; ".join(msgs)


#: keys of ``[model.system]`` that name files (relative to the case file's folder)
FILE_KEYS = ("matrices", "M", "K", "C", "file")


def with_absolute_files(data: dict, base) -> dict:
    """``data`` (a case's TOML tables) with the relative file names of ``[model.system]`` (and of
    each run's ``[run.model.system]``) made absolute against ``base``, the case file's folder, so
    that the case reads the same files from any working directory."""
    def fix(model):
        if not isinstance(model, dict) or not isinstance(model.get("system"), dict):
            return model
        sy = dict(model["system"])
        for k in FILE_KEYS:
            v = sy.get(k)
            if isinstance(v, str) and v and not Path(v).is_absolute():
                sy[k] = str(Path(base) / v)
        return dict(model, system=sy)

    out = dict(data)
    out["model"] = fix(data.get("model"))
    if isinstance(data.get("run"), list):
        out["run"] = [dict(r, model=fix(r["model"])) if isinstance(r, dict) and "model" in r else r
                      for r in data["run"]]
    return out


def parse_case(text: str, source: str = "<case>", base=None) -> Case:
    """Parse and validate the text of a case file.

    Parameters
    ----------
    text : str
        TOML text.
    source : str
        Name used in error messages.
    base : str or Path, optional
        The case file's folder: relative file names in the case (``[model.system]`` matrices)
        are made absolute against it (:func:`with_absolute_files`).

    Returns
    -------
    Case

    Raises
    ------
    CaseError
        On a TOML syntax error, an unknown key, a wrong type or a value out of
        range; the message names the key, the value and what is allowed.
    """
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as e:
        raise CaseError(one_line(f"{source}: not valid TOML: {e}")) from None
    except RecursionError:
        raise CaseError(one_line(f"{source}: not valid TOML: arrays or tables nested too deeply")) from None
    try:
        _check_ints(data)
        if base is not None:
            data = with_absolute_files(data, base)
        try:
            case = Case.model_validate(data)
        except ValidationError as e:
            raise CaseError(validation_message(e, "", Case)) from None
        spec = case.model_spec()
        for i, r in enumerate(case.run):
            allowed = fidelity_methods(spec.fidelity)
            if r.method not in allowed:
                raise CaseError(f"'run[{i}].method' = {r.method!r} is not available for fidelity "
                                f"{spec.fidelity!r}; allowed: {', '.join(allowed)}")
            run_spec = spec
            if r.model:
                if "fidelity" in r.model and r.model["fidelity"] != case.model.get("fidelity"):
                    raise CaseError(f"'run[{i}].model.fidelity' = {quote_value(r.model['fidelity'])}: a run "
                                    f"cannot change the fidelity; put it in another case")
                run_spec = _validate_model(model_with(case.model, r.model), prefix=f"run[{i}].model")
            _check_contact_method(run_spec, i, r)
            _check_resonance(case, i, r, run_spec, f"run[{i}].model" if r.model else "model")
            _check_method_values(run_spec, i, r, "run[%d].model" % i if r.model else "model")
            if r.effects:
                case.effects_for(r)
            _check_two_sided(case, i, r)
            if r.method == "continuation":
                _check_continuation(case, i, r)
        if case.map is not None:
            _check_map(case)
        if case.uncertainty is not None:
            _check_uncertainty(case)
        check_time_series(case, hz_per_omega=getattr(spec.system, "natural_frequency_hz", None))
        if case.sweep.frequency_hz is not None and not getattr(spec, "physical", False):
            raise CaseError("'sweep.frequency_hz' needs a physical model (natural_frequency_hz, ...); "
                            "use 'sweep.Omega' for a nondimensional one")
    except CaseError as e:
        raise CaseError(one_line(f"{source}: {e}")) from None
    return case


def _check_resonance(case, i: int, r, spec, prefix: str) -> None:
    """The run's scene against its sweep grid (the spec's optional ``check_sweep``, e.g. the
    SDOF's undamped exact resonance), for its own model and, with a ``[map]``, at every mapped
    value."""
    specs = [(spec, prefix)]
    m = case.map
    if (m is not None and getattr(spec, "check_sweep", None) is not None and m.parameter not in r.model
            and m.parameter in case.map_parameters()):
        specs = []
        for v in m.grid():
            try:
                specs.append((_validate_model(model_with(case.model, {**r.model, m.parameter: float(v)}), prefix),
                              "map.values"))
            except CaseError:
                pass            # _check_map names the value
    for sp, where in specs:
        check = getattr(sp, "check_sweep", None)
        if check is not None:
            check(case.sweep, r.method, where, i)


def _check_method_values(spec, i: int, r, prefix: str) -> None:
    """Values of the model a run's method cannot take (fidelity registry: ``positive_R_methods``
    need R > 0)."""
    fid = fidelity(spec.fidelity)
    R = spec.stop[0].R
    if r.method in fid.positive_R_methods and R is not None and not R > 0.0:
        others = [m for m in fid.method_names if m not in fid.positive_R_methods]
        raise CaseError(f"'{prefix}.R' = {quote_value(R)}: method {r.method!r} (run[{i}]) needs R > 0 (its transformation "
                        f"divides by K_N = 0 at R = 0); allowed: 0 < R <= 1, or another method ({', '.join(others)})")


def _stop_laws(spec) -> tuple:
    """``(upper, lower)`` law names of the stops at the attached mass of a model spec (lower None
    without a second stop; a lower stop without its own table takes the upper stop's law)."""
    contact, lo = mass_law_tables(spec)
    up = "restitution" if contact is None else contact.law
    if not spec.two_sided:
        return up, None
    return up, (up if lo is None else lo.law)


def _check_contact_method(spec, i: int, r) -> None:
    """The run's method simulates the upper stop's law and the laws of the stops away from the
    reference stop's point (``further_stops``; the one capability function,
    :func:`vibeam.models.registry.supported_methods`)."""
    law, _ = _stop_laws(spec)
    allowed = supported_methods(spec.fidelity, law_key(law))
    if r.method not in allowed:
        raise CaseError(f"'run[{i}].method' = {r.method!r} does not simulate contact.law = \"{law}\" of fidelity "
                        f"{spec.fidelity!r}; allowed: {', '.join(allowed) or 'none'}")
    further = getattr(spec, "further_stops", ())
    for j, st in enumerate(further):
        allowed = supported_methods(spec.fidelity, law_key(law), law_key(st.law))
        if r.method not in allowed:
            raise CaseError(f"'run[{i}].method' = {r.method!r} does not simulate law = \"{st.law}\" of "
                            f"stop[{len(spec.stop) - len(further) + j}] beside the reference stop's law; allowed: "
                            f"{', '.join(allowed) or 'none'}")


def check_time_series(case: Case, source: str = "", hz_per_omega: float | None = None) -> None:
    """``[assess] time_series`` frequencies lie within the sweep's grid and on distinct grid points.

    Each requested frequency is recorded at the nearest grid point and labelled with that
    point's frequency; a request outside the grid, or two requests that share a grid point
    (closer than the grid spacing), would record something else than asked under the asked
    label, so both are errors.

    Parameters
    ----------
    case : Case
        The case as run (e.g. its quick variant).
    source : str
        File name for messages.
    hz_per_omega : float, optional
        The scene's natural frequency (Hz) when the grid is given as ``sweep.Omega`` but the
        scene is physical (time series in Hz); without it such a case is not checked here
        (the runner checks it with the built model).

    Raises
    ------
    CaseError
        Naming ``assess.time_series[i]``, its value and the allowed range or the clash.
    """
    ts = case.assess.time_series
    if not ts:
        return
    sw = case.sweep
    key = "Omega" if sw.Omega is not None else "frequency_hz"
    start, stop, n = getattr(sw, key)
    grid = np.linspace(start, stop, int(n))
    physical = bool(getattr(case.model_spec(), "physical", False))
    if key == "Omega" and physical:
        if hz_per_omega is None:
            return
        grid = grid * hz_per_omega
    unit = " Hz" if physical else ""
    lo, hi = float(grid.min()), float(grid.max())
    tol = 1e-9 * max(abs(lo), abs(hi))
    spacing = float(np.min(np.diff(np.sort(grid)))) if grid.size > 1 else 0.0
    where = f"{source}: " if source else ""
    seen: dict = {}
    for i, f in enumerate(ts):
        if not lo - tol <= f <= hi + tol:
            raise CaseError(f"{where}'assess.time_series[{i}]' = {f:g}: outside the sweep's grid; allowed: "
                            f"{lo:g} ... {hi:g}{unit} ('sweep.{key}')")
        j = int(np.argmin(np.abs(grid - f)))
        if j in seen:
            raise CaseError(f"{where}'assess.time_series[{i}]' = {f:g}: on the same grid point ({grid[j]:.10g}{unit}) "
                            f"as 'assess.time_series[{seen[j]}]' = {ts[seen[j]]:g}; the grid spacing is "
                            f"{spacing:g}{unit}: give frequencies on distinct grid points")
        seen[j] = i


def _check_two_sided(case: Case, i: int, r) -> None:
    """A run of a two-sided scene (a lower stop) uses a method that simulates it (the fidelity's
    :func:`vibeam.models.registry.supported_methods` of its stops' laws) and no effect that assumes
    one stop."""
    table = model_with(case.model, dict(r.model)) if r.model else case.model
    spec = case.model_spec(dict(r.model)) if r.model else case.model_spec()
    law, low = _stop_laws(spec)
    if low is None:
        return
    allowed = supported_methods(spec.fidelity, law_key(law), law_key(low))
    what = "" if not is_compliant(law) else f" with contact.law = \"{law}\""
    if low != law:
        what += f" and contact_lower.law = \"{low}\""
    if r.method not in allowed:
        raise CaseError(f"'run[{i}].method' = {r.method!r} cannot simulate a second stop{what} (the scene has a "
                        f"lower stop: {_lower_key(spec, table)}); allowed with two stops: {', '.join(allowed) or 'none'}")
    eff = case.effects_for(r)
    if eff.sensor is not None:
        raise CaseError(f"'effects.sensor' (run[{i}]): the sensor's R identification assumes one stop (paper "
                        f"Sec. 5.1); the scene has a lower stop ({_lower_key(spec, table)})")
    low = spec.stop[1].gap_mm      # the lower stop's gap at the sensor (None: given at the stop)
    if eff.gap_drift is not None and eff.gap_drift.table is not None and low is not None:
        # the drift moves the upper stop (gap at the sensor); it must not pass the lower one
        for j, (f, g) in enumerate(eff.gap_drift.table):
            if not g + low > 0.0:
                raise CaseError(f"'effects.gap_drift.table[{j}]' = [{f:g}, {g:g}] (run[{i}]): the upper stop would "
                                f"overlap the lower one (gap_lower_mm = {low:g}); gap_mm + gap_lower_mm must be > 0")


def _lower_key(spec, table: dict) -> str:
    """``key = value`` of the gap of a two-sided spec's lower stop as the ``[model]`` table ``table``
    writes it (``Delta_lower`` of the shorthand, ``stop[1].Delta`` of the tables: messages)."""
    origins = expanded(table)[1]
    for k in ("Delta", "gap_mm", "contact_gap_mm"):
        v = getattr(spec.stop[1], k, None)
        if v is not None:
            return f"{user_key(origins, ('stop', 1, k))} = {v:g}"
    return "a lower stop"


def _path_of_alias(table: dict, name: str) -> str | None:
    """The parameter path of a ``[model]`` table that the flat key ``name`` stands for
    (:func:`vibeam.case.paths.alias_of`; ``R_lower`` -> ``stops[1].law.R``), or None."""
    for p in parameter_paths(table):
        try:
            if alias_of(table, p) == name:
                return p
        except ValueError:
            continue
    return None


def continued_key(spec, table: dict, name: str) -> str:
    """The key a continuation in ``name`` runs in: the flat key the scene's shooting problem
    carries (its ``scene_parameter``, with ``d x / d p`` of its own), else, for a path into a
    stop or the excitation (``stops[1].law.stiffness_n_m``, a force's ``excitation.amplitude_n``),
    the path itself: carried by the scene's problem when the spec's ``scene_parameter`` takes it
    (a matrix scene's ``stops[0].law.R``), else continued by central differences of the scene's
    shots (:class:`vibeam.models.orbits.continuation.FiniteDifferenceParameter`).  A path
    into ``system`` that the shooting problem does not carry changes the structure's modes (their
    signs and order, not smooth in the parameter) and stays refused.

    Parameters
    ----------
    spec : the run's model spec (with ``scene_parameter``)
    table : dict
        The run's ``[model]`` table as written (overrides applied).
    name : str
        The run's ``parameter``: a flat key or a path (:mod:`vibeam.case.paths`).

    Raises
    ------
    ValueError
        What the scene allows (the spec's message), a path it does not have, or a path whose
        value the table does not give as a number.
    """
    key = alias_of(table, name)
    if not is_path(key):
        try:
            spec.scene_parameter(key)
            return key
        except ValueError:
            if not (is_path(name) and name.startswith(("stops", "excitation."))):
                raise
        key = name
    # a number only a path names (a law's stiffness, a stop's position, a drive's amplitude)
    if not isinstance(get_value(table, key), (int, float)) or isinstance(get_value(table, key), bool):
        raise ValueError("is not set in this scene's [model]; continue a number the case gives")
    return key


def _check_continuation(case: Case, i: int, r) -> None:
    """A continuation run names a parameter its scene can continue, with a range and a
    frequency where they are needed, and no scene effects."""
    spec = case.model_spec(dict(r.model)) if r.model else case.model_spec()
    if case.effects_for(r).active():
        raise CaseError(f"'run[{i}]' (continuation) cannot use [effects] ({', '.join(case.effects_for(r).active())}); "
                        f"continue the plain scene")
    hz = case.sweep.frequency_hz is not None
    fn = getattr(spec.system, "natural_frequency_hz", None) if hz else 1.0    # a beam's: at planning (its modes)
    if r.parameter == "Omega" and r.range is not None:
        check_frequency_range(r.range, f"run[{i}].range", hz, fn)
    if r.at is not None:
        check_frequency_range([r.at, r.at], f"run[{i}].at", hz, fn)
    native = getattr(spec, "scene_parameter", None)
    if native is not None:
        table = model_with(case.model, dict(r.model))
        try:
            continued_key(spec, table, r.parameter)
        except ValueError as e:
            raise CaseError(f"'run[{i}].parameter' = {quote_value(r.parameter)} {e}") from None
    if r.parameter != "Omega":
        if r.at is None:
            unit = "Hz" if case.sweep.frequency_hz is not None else "Omega"
            raise CaseError(f"'run[{i}].at' is missing: continuation in {r.parameter!r} needs the forcing "
                            f"frequency at which it runs ({unit})")
        if r.range is None and not (case.map is not None and case.map.parameter == r.parameter):
            raise CaseError(f"'run[{i}].range' is missing: give [low, high] of {r.parameter!r}")
        table = model_with(case.model, dict(r.model))
        name = r.parameter if is_path(r.parameter) or r.parameter in type(spec).model_fields else \
            _path_of_alias(table, r.parameter)
        if r.range is not None and native is not None and name is not None:
            # each end of the range is a scene the model must accept (a stop beyond the beam's
            # length, R above 1, a negative stiffness): refused here in one line, not found by the
            # branch as a failed point; a flat name the spec has no field of (R_lower) is checked
            # through the path it stands for (stops[1].law.R)
            for v in r.range:
                try:
                    _validate_model(model_with(table, {name: float(v)}),
                                    prefix=f"run[{i}].model" if r.model else "model")
                except (CaseError, ValueError) as e:
                    raise CaseError(f"'run[{i}].range' = {quote_value(list(r.range))}: {r.parameter} = {v:g} is "
                                    f"not allowed ({e})") from None
    if case.map is not None and r.parameter != "Omega":
        raise CaseError(f"'run[{i}].parameter' = {quote_value(r.parameter)}: in a [map] case a continuation runs "
                        f"in the frequency ('Omega') and draws curves over (frequency, {case.map.parameter})")
    if not isinstance(r.start_at, str):
        if r.range is not None:
            lo, hi = r.range
        elif r.parameter == "Omega":
            start, stop, _ = case.sweep.Omega or case.sweep.frequency_hz
            lo, hi = min(start, stop), max(start, stop)
        else:
            v = case.map.grid() if case.map is not None else [r.start_at]
            lo, hi = min(v), max(v)
        if not lo <= r.start_at <= hi:
            raise CaseError(f"'run[{i}].start_at' = {quote_value(r.start_at)} lies outside the range [{lo}, {hi}]")


def check_frequency_range(values, key: str, hz: bool, fn: float | None) -> None:
    """The forcing frequencies of a continuation (``range`` in Omega, ``at``): finite, positive,
    Omega at most :data:`OMEGA_MAX` (as a ``[sweep]`` grid); ``hz``: given in Hz, ``fn`` the scene's
    natural frequency in Hz (None: the upper bound is left to the caller that knows it).

    Raises
    ------
    CaseError
        ``'<key>' = <values>: <what is allowed>``, one line.
    """
    unit = " Hz" if hz else ""
    shown = quote_value(values[0] if values[0] == values[-1] and key.endswith(".at") else list(values))
    for v in values:
        if not (math.isfinite(v) and v > 0.0):
            raise CaseError(f"'{key}' = {shown}: {v:g}{unit} is not a forcing frequency; allowed: positive finite "
                            f"frequencies{' (Hz)' if hz else ' (Omega)'}")
        if fn is not None and not v / fn <= OMEGA_MAX:
            top = OMEGA_MAX * fn
            raise CaseError(f"'{key}' = {shown}: {v:g}{unit} is above Omega's limit; allowed: at most {top:g}{unit} "
                            f"(Omega <= {OMEGA_MAX:g}: the exact flows' Omega^4 terms overflow double precision)")


def _check_map(case: Case) -> None:
    """A ``[map]`` names a numeric model key, no run overrides it, and every value is valid."""
    m = case.map
    allowed = case.map_parameters()
    if m.parameter not in allowed:
        raise CaseError(f"'map.parameter' = {quote_value(m.parameter)} is not a numeric key of [model]; "
                        f"allowed: {', '.join(allowed)}")
    for i, r in enumerate(case.run):
        for k in r.model:            # by any name of the same parameter (R, stops[0].law.R)
            if canonical(case.model, k) == canonical(case.model, m.parameter):
                raise CaseError(f"'run[{i}].model.{k}' overrides the mapped parameter ({m.parameter}); "
                                f"remove it or map another parameter")
    grid = m.grid()
    values = [grid[0], grid[-1], *grid[1:-1]]     # the ends first: most bad ranges fail there
    overrides = []                                # one model per distinct [run.model]
    for i, r in enumerate(case.run):
        if r.model not in [o for _, o in overrides]:
            overrides.append((i, r.model))
    for v in values:
        for i, o in overrides:
            data = model_with(case.model, {**o, m.parameter: float(v)})
            try:
                spec = _validate_model(data, prefix=f"run[{i}].model" if o else "model")
                for j, r in enumerate(case.run):
                    if r.model == o:
                        _check_method_values(spec, j, r, f"run[{j}].model" if o else "model")
            except CaseError as e:
                raise CaseError(f"'map.values' = {quote_value(m.values)}: {m.parameter} = {v:g} is not "
                                f"allowed ({e})") from None


def _check_uncertainty(case: Case) -> None:
    """Each ``[[uncertainty.parameter]]`` names what a ``[map]`` may vary, no run overrides it, and
    every value its distribution can give (its support, an unbounded end at the
    :data:`vibeam.case.uncertainty.SUPPORT_TAIL` quantile) makes a valid model for every run."""
    allowed = case.map_parameters()
    runs = [r for r in case.run if r.method != "continuation"]
    if not runs:
        raise CaseError("'uncertainty': the case has no sweep run to sample (continuation runs are not "
                        "sampled); allowed: a [[run]] with a sweep method")
    seen: dict = {}
    for k, p in enumerate(case.uncertainty.parameter):
        key = f"uncertainty.parameter[{k}]"
        if p.name not in allowed:
            raise CaseError(f"'{key}.name' = {quote_value(p.name)} is not a parameter of this scene; allowed: "
                            f"{', '.join(allowed)}")
        c = canonical(case.model, p.name)
        if c in seen:          # an alias and its path (R, stops[0].law.R): one parameter sampled twice
            raise CaseError(f"'{key}.name' = {quote_value(p.name)} is the parameter of "
                            f"'uncertainty.parameter[{seen[c]}].name' = "
                            f"{quote_value(case.uncertainty.parameter[seen[c]].name)} ({c}); allowed: each "
                            f"parameter once")
        seen[c] = k
        for i, r in enumerate(runs):
            for o in r.model:
                if canonical(case.model, o) == c:
                    raise CaseError(f"'run[{case.run.index(r)}].model.{o}' overrides the sampled parameter "
                                    f"'{key}.name' = {quote_value(p.name)}; remove it or sample another parameter")
        for v in p.support():
            for r in runs:
                j = case.run.index(r)
                try:
                    spec = _validate_model(model_with(case.model, {**r.model, p.name: float(v)}),
                                           prefix=f"run[{j}].model" if r.model else "model")
                    _check_method_values(spec, j, r, f"run[{j}].model" if r.model else "model")
                except CaseError as e:
                    raise CaseError(f"'{key}.distribution' = {quote_value(p.distribution)}: its support reaches "
                                    f"{p.name} = {v:g}, which is not allowed ({e}); allowed: a distribution "
                                    f"inside the parameter's range (truncnorm or uniform with bounds)") from None


def load_case(path) -> tuple[Case, str]:
    """Read and validate a case file; returns the case and its text.

    Raises
    ------
    CaseError
        If the file cannot be read (not a regular file, larger than 10 MB, not UTF-8:
        :func:`vibeam.io.inputs.read_input_text`) or is invalid (see :func:`parse_case`).
    """
    text = read_input_text(path, "case file")
    return parse_case(text, str(path), base=Path(path).resolve().parent), text
