"""``[model.contact]`` / ``[model.contact_lower]``: the contact law of a stop (issue 13).

::

    [model]
    R = 0.9                      # the target restitution of a compliant law
    [model.contact]
    law = "linear"               # "restitution" (default: Newton's law, paper Eq. 2) or a compliant law
    stiffness = 1e4              # k_c / k of the oscillator (nondimensional scenes)
    # stiffness_n_m = 2e5        # physical SDOF scenes: N/m (N/m^p for a law with an exponent), with mass_kg
    # exponent = 1.5             # hysteretic-Hertz laws: F = k delta^p (1 + chi delta' / v_in)
    # damping_ratio = 0.05       # Kelvin-Voigt: else the dashpot gives an isolated impact the model's R
    # mass_kg = 0.2              # physical SDOF: effective mass (forces in N, stiffness_n_m)

The laws, their keys and their classes are the one table :data:`vibeam.models.registry.LAWS`
(the classes in :mod:`vibeam.models.compliant`); which fidelities and methods simulate a law's
family is in the fidelity registry (``supported_methods``).  Nothing here names a law.
"""
from __future__ import annotations

import math
from typing import Annotated, NamedTuple

from pydantic import AfterValidator, BaseModel, ConfigDict, Field, field_validator, model_validator

from vibeam.case.paths import is_canonical, is_path, path_of, set_value
from vibeam.models.contact import R_RANGE, restitution_problem
from vibeam.models.registry import IMPLEMENTED_LAWS, LAWS, is_compliant, law_class


#: the force exponents ``p`` of a Hertz-family law a case accepts (:func:`check_exponent`)
EXPONENT_RANGE = (1.0, 3.0)


def check_restitution(v: float) -> float:
    """A case's coefficient of restitution, checked by the law's own test
    (:func:`vibeam.models.contact.restitution_problem`: the one range check of R).

    Raises
    ------
    ValueError
        Outside ``[0, 1]``; pydantic names the key the user wrote.
    """
    problem = restitution_problem(v)
    if problem:
        raise ValueError(problem)
    return v


class Bounds(NamedTuple):
    """A key's closed range as data, for what reads a schema's bounds (the fit's start and box:
    :func:`vibeam.identify.fit.schema_bounds`) where a validator, not a pydantic bound, checks it."""

    ge: float
    le: float


#: a case's coefficient of restitution (``[model] R``, a stop's ``R``, ``[effects.restitution_law] R``):
#: checked by the law's function, its range the law module's (:data:`vibeam.models.contact.R_RANGE`)
RestitutionValue = Annotated[float, AfterValidator(check_restitution), Bounds(*R_RANGE)]


def check_exponent(v):
    """A Hertz-family force exponent ``p`` of a case (None passes).

    Hertz-family laws in the literature use p in [1, 3]: 1 (linear), 3/2 (Hertz's sphere-on-plane
    and cylinder contacts, Hunt & Crossley 1975, Lankarani & Nikravesh 1990), up to ~3 for rough or
    conforming surfaces (Machado et al., Mech. Mach. Theory 53, 2012).  Below 1 the contact
    stiffness d(k delta^p)/d delta is unbounded at delta = 0: the contact phase's step control then
    takes ever smaller steps and a point need not end.

    Raises
    ------
    ValueError
        ``p`` outside :data:`EXPONENT_RANGE`, with the reason.
    """
    if v is not None and not (EXPONENT_RANGE[0] <= v <= EXPONENT_RANGE[1]):
        raise ValueError(f"not a Hertz-family exponent; allowed: {EXPONENT_RANGE[0]:g} <= p <= "
                         f"{EXPONENT_RANGE[1]:g} (the Hertz-family laws' range: 1 linear, 1.5 Hertz, up to 3 "
                         f"rough surfaces; below 1 the contact stiffness is unbounded at contact onset)")
    return v


class ContactSpec(BaseModel):
    """``[model.contact]`` (the stop of the paper) or ``[model.contact_lower]`` (a second stop
    below, default the upper stop's law: law ``restitution`` with its own ``R`` beside a
    restitution upper stop, or a compliant law with its own stiffness beside a compliant one;
    a compliant lower stop's target restitution is its own ``R``, default ``[model] R``; the
    upper stop's R is ``[model] R``): module docstring."""

    model_config = ConfigDict(extra="forbid", strict=True, frozen=True, allow_inf_nan=False)

    law: str = "restitution"
    R: RestitutionValue | None = None
    stiffness: Annotated[float, Field(gt=0.0)] | None = None
    stiffness_n_m: Annotated[float, Field(gt=0.0)] | None = None
    damping_ratio: Annotated[float, Field(ge=0.0, lt=1.0)] | None = None
    exponent: float | None = None
    mass_kg: Annotated[float, Field(gt=0.0)] | None = None

    @field_validator("law")
    @classmethod
    def _known(cls, v):
        if v not in IMPLEMENTED_LAWS:
            raise ValueError(f"not a contact law; allowed: {', '.join(IMPLEMENTED_LAWS)}")
        return v

    @field_validator("exponent")
    @classmethod
    def _exponent(cls, v):
        return check_exponent(v)

    @model_validator(mode="after")
    def _consistent(self):
        own = LAWS[self.law].keys
        if not is_compliant(self.law):
            given = [k for k in ("stiffness", "stiffness_n_m", "damping_ratio", "exponent")
                     if getattr(self, k) is not None and k not in own]
            if given:
                raise ValueError(f"law = \"{self.law}\" takes no {', '.join(given)} (it uses [model] R)")
            return self
        if (self.stiffness is None) == (self.stiffness_n_m is None):
            raise ValueError(f"law = \"{self.law}\" needs exactly one of stiffness (nondimensional, ratio to the "
                             f"oscillator's) or stiffness_n_m (N/m, physical scenes)")
        for key in ("exponent", "damping_ratio"):
            if getattr(self, key) is not None and key not in own:
                laws = " or ".join(f'"{n}"' for n, law in LAWS.items() if key in law.keys)
                raise ValueError(f"{key} is a key of law = {laws} only: {key} = {getattr(self, key)!r} with "
                                 f"law = \"{self.law}\"; allowed keys: law, {', '.join(own)}")
        return self


def target_R(table: ContactSpec | None, R: float) -> float:
    """The target restitution of a compliant stop's table: its own ``R`` (a lower stop's), else
    ``R`` (``[model] R``)."""
    return R if table is None or table.R is None else float(table.R)


def sdof_law(contact: ContactSpec | None, R: float, physical: bool, natural_frequency_hz: float | None,
             length_m: float | None = None):
    """The compliant law of an SDOF scene in kernel units, or None for Newton's law.

    Raises
    ------
    ValueError
        Naming the key: ``stiffness_n_m`` without ``mass_kg`` or in a nondimensional scene,
        ``stiffness`` with ... , a target R out of the law's range, a law not implemented.
    """
    if contact is None or not is_compliant(contact.law):
        return None
    cls = law_class(contact.law)
    p = cls.force_exponent(contact.exponent)
    if contact.stiffness_n_m is not None:
        if not physical:
            raise ValueError("contact.stiffness_n_m needs a physical scene; use contact.stiffness (ratio) here")
        if contact.mass_kg is None or length_m is None:
            raise ValueError("contact.stiffness_n_m needs contact.mass_kg (the oscillator's effective mass) "
                             "to form the stiffness ratio; or give contact.stiffness")
        # F = k_phys x^p, x = q L  ->  per unit mass and k: k_phys L^(p-1) / (m omega_n^2) q^p
        k = contact.stiffness_n_m * length_m ** (p - 1.0) / (contact.mass_kg * (2 * math.pi * natural_frequency_hz) ** 2)
    else:
        k = contact.stiffness
    return cls.from_spec(k, R, exponent=contact.exponent, damping_ratio=contact.damping_ratio)


def beam_law(contact: ContactSpec | None, R: float):
    """The compliant law of a beam scene (``stiffness_n_m`` at the contact point: N/m, N/m^p
    for a law with an exponent ``p``), or None.

    Raises
    ------
    ValueError
        ``stiffness`` (a ratio) given, ``mass_kg`` given, a target R out of range.
    """
    if contact is None or not is_compliant(contact.law):
        return None
    if contact.stiffness_n_m is None:
        raise ValueError("beam scenes give the stop's stiffness as contact.stiffness_n_m (N/m at the contact point)")
    if contact.mass_kg is not None:
        raise ValueError("contact.mass_kg is for physical SDOF scenes; the beam's effective mass is 1 / |w|^2")
    # F = k_c delta^p (...), k_c in N/m^p at the contact point (the law's from_spec: damping from R)
    return law_class(contact.law).from_spec(contact.stiffness_n_m, R, exponent=contact.exponent,
                                            damping_ratio=contact.damping_ratio)


class StopSpec(ContactSpec):
    """One ``[[model.stop]]`` table: a stop complete in itself -- where (``side``, ``position_mm``
    on a beam), its gap and its law with the law's keys, its ``R`` included (Newton's R, or the
    target R of a compliant law).

    ::

        [[model.stop]]               # the paper's stop, at the attached mass
        side = "upper"
        gap_mm = 0.1                 # at the sensor (or contact_gap_mm at the stop; Delta nondimensional)
        R = 0.8
        [[model.stop]]               # a second stop at the tip, below the beam
        side = "lower"
        position_mm = 180.0
        contact_gap_mm = 1.2
        R = 0.9

    The first upper stop at the attached mass is the paper's (the amplitude ``Q`` is measured
    from it); a lower stop there is the scene's second stop; a beam takes further Newton stops at
    any other points.  The keys ``Delta``, ``Delta_lower``, ``gap_mm``, ``R``, ``[model.contact]``,
    ``[model.contact_lower]`` stay shorthands for one or two stops at the mass.
    """

    side: str = "upper"
    position_mm: Annotated[float, Field(gt=0.0)] | None = None
    gap_mm: float | None = None
    contact_gap_mm: float | None = None
    Delta: float | None = None

    @field_validator("side")
    @classmethod
    def _side(cls, v):
        if v not in ("upper", "lower"):
            raise ValueError('allowed: "upper" (above the point) or "lower" (below it)')
        return v

    @field_validator("exponent")
    @classmethod
    def _exponent(cls, v):
        return check_exponent(v)

    @model_validator(mode="after")
    def _consistent(self):
        # ContactSpec's check (this overrides it) with R allowed for every law: a stop's R is
        # Newton's R or the compliant law's target R
        if is_compliant(self.law) and self.R is not None:
            return ContactSpec._consistent(self.model_copy(update={"R": None})) and self
        return ContactSpec._consistent(self)

    @model_validator(mode="after")
    def _gap(self):
        given = [k for k in ("gap_mm", "contact_gap_mm", "Delta") if getattr(self, k) is not None]
        if len(given) != 1:
            raise ValueError(f"give the stop's gap once: one of gap_mm (at the sensor), contact_gap_mm (at the "
                             f"stop, beam scenes) or Delta (nondimensional SDOF scenes); got {given or 'none'}")
        if self.R is None:
            raise ValueError("give the stop's R (Newton's coefficient of restitution, or a compliant law's target)")
        return self

    def law_table(self) -> dict:
        """The ``[model.contact]``-style table of its law (no geometry, no R of a compliant law)."""
        d = {k: v for k, v in self.model_dump(exclude_none=True).items()
             if k in ContactSpec.model_fields and k != "R"}
        return d


_UPPER_GAPS = ("gap_mm", "contact_gap_mm", "Delta")
_LOWER_GAPS = {"gap_lower_mm": "gap_mm", "contact_gap_lower_mm": "contact_gap_mm", "Delta_lower": "Delta"}


def model_with(model: dict, values: dict | None) -> dict:
    """``model`` (a ``[model]`` table) with ``values`` set: a ``[run.model]`` override, a
    ``[map]`` value or a fitted value.  On a table whose stops are ``[[model.stop]]`` tables the
    shorthand keys go into the stops they stand for: ``R``, ``Delta``, ``gap_mm``,
    ``contact_gap_mm`` and ``contact`` into the paper's stop (the first upper stop at the attached
    mass), the ``*_lower`` keys and ``contact_lower`` into the lower stop there (added if there is
    none); a gap replaces the stop's gap, a law table replaces its law keys.  A key written as a
    parameter path (``stops[1].law.stiffness_n_m``: :mod:`vibeam.case.paths`) sets the one key it
    stands for; a ``system`` or ``excitation`` table (the canonical tables) is merged key by key
    into the model's.  A new dict; the tables given are not changed.

    Raises
    ------
    ValueError
        A parameter path that is not valid for this table (:func:`vibeam.case.paths.set_value`).
    """
    values = dict(values or {})
    if is_canonical(model):
        # a flat key on the canonical tables: an alias of the path it stands for (beta ->
        # system.damping_ratio, voltage -> excitation.voltage, R_lower -> stops[1].law.R); the
        # stops' shorthand keys (R, the gaps, contact tables) go into their stops below
        for k in [k for k in values if k not in ("system", "stop", "excitation", "R", "contact", "contact_lower",
                                                 *_UPPER_GAPS, *_LOWER_GAPS)]:
            p = path_of(model, k)
            if p is not None:
                values[p] = values.pop(k)
    paths = {k: v for k, v in values.items() if is_path(k)}
    for k, v in paths.items():             # a parameter path sets the one key it stands for
        model = set_value(model, k, v)
    values = {k: v for k, v in (values or {}).items() if k not in paths}
    out = dict(model)
    out.update(values)
    for k in ("system", "excitation"):
        # a canonical table (issue 58) is overridden key by key: [run.model.system] n_modes = 1
        if isinstance(values.get(k), dict) and isinstance(model.get(k), dict):
            out[k] = {**model[k], **values[k]}
    stops = model.get("stop")
    if not isinstance(stops, list) or not values:
        return out
    short = [k for k in values if k in ("R", "contact", "contact_lower", *_UPPER_GAPS, *_LOWER_GAPS)]
    if not short:
        return out
    stops = [dict(s) if isinstance(s, dict) else s for s in stops]
    for k in short:
        del out[k]

    def at_mass(side):
        for s in stops:
            if isinstance(s, dict) and s.get("side", "upper") == side and "position_mm" not in s:
                return s
        if side == "upper":
            return None                       # refused by the canonical validation in one line
        up = at_mass("upper")                 # a new lower stop takes the paper's R, as R_lower does
        s = {"side": "lower", **({"R": up["R"]} if up is not None and "R" in up else {})}
        stops.append(s)
        return s

    for k in short:
        lower = k in _LOWER_GAPS or k == "contact_lower"
        s = at_mass("lower" if lower else "upper")
        if s is None:
            continue
        if k == "R":
            s["R"] = values[k]
        elif k in ("contact", "contact_lower"):
            keep = {q: s[q] for q in ("side", "position_mm", "R", *_UPPER_GAPS) if q in s}
            s.clear()
            s.update(keep)
            s.update(values[k])
        else:
            for q in _UPPER_GAPS:
                s.pop(q, None)
            s[_LOWER_GAPS.get(k, k)] = values[k]
    out["stop"] = stops
    return out
