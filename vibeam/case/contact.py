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
family is in the fidelity registry (``contact_laws``).  Nothing here names a law.
"""
from __future__ import annotations

import math
from typing import Annotated

from pydantic import BaseModel, ConfigDict, Field, field_validator, model_validator

from vibeam.models.registry import IMPLEMENTED_LAWS, LAWS, is_compliant, law_class


class ContactSpec(BaseModel):
    """``[model.contact]`` (the stop of the paper) or ``[model.contact_lower]`` (a second stop
    below, default the upper stop's law: law ``restitution`` with its own ``R`` beside a
    restitution upper stop, or a compliant law with its own stiffness beside a compliant one;
    its target restitution is ``[model] R``): module docstring."""

    model_config = ConfigDict(extra="forbid", strict=True, frozen=True, allow_inf_nan=False)

    law: str = "restitution"
    R: Annotated[float, Field(ge=0.0, le=1.0)] | None = None
    stiffness: Annotated[float, Field(gt=0.0)] | None = None
    stiffness_n_m: Annotated[float, Field(gt=0.0)] | None = None
    damping_ratio: Annotated[float, Field(ge=0.0, lt=1.0)] | None = None
    exponent: Annotated[float, Field(gt=0.0)] | None = None
    mass_kg: Annotated[float, Field(gt=0.0)] | None = None

    @field_validator("law")
    @classmethod
    def _known(cls, v):
        if v not in IMPLEMENTED_LAWS:
            raise ValueError(f"not a contact law; allowed: {', '.join(IMPLEMENTED_LAWS)}")
        return v

    @model_validator(mode="after")
    def _consistent(self):
        own = LAWS[self.law].keys
        if not is_compliant(self.law):
            given = [k for k in ("stiffness", "stiffness_n_m", "damping_ratio", "exponent")
                     if getattr(self, k) is not None and k not in own]
            if given:
                raise ValueError(f"law = \"{self.law}\" takes no {', '.join(given)} (it uses [model] R)")
            return self
        if self.R is not None:
            raise ValueError(f"R is a key of law = \"restitution\" (a lower stop's own R); law = \"{self.law}\" "
                             f"takes its target restitution from [model] R")
        if (self.stiffness is None) == (self.stiffness_n_m is None):
            raise ValueError(f"law = \"{self.law}\" needs exactly one of stiffness (nondimensional, ratio to the "
                             f"oscillator's) or stiffness_n_m (N/m, physical scenes)")
        for key in ("exponent", "damping_ratio"):
            if getattr(self, key) is not None and key not in own:
                laws = " or ".join(f'"{n}"' for n, law in LAWS.items() if key in law.keys)
                raise ValueError(f"{key} is a key of law = {laws} only: {key} = {getattr(self, key)!r} with "
                                 f"law = \"{self.law}\"; allowed keys: law, {', '.join(own)}")
        return self


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
