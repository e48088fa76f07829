"""The shorthand of a ``[model]`` table, expanded into the canonical tables (issue 58).

The canonical form of a model is three tables: ``[model.system]`` (the linear structure, its
``builder``: ``"sdof"``, ``"beam"``, ``"matrices"``, ``"continuum"``), ``[[model.stop]]`` (one table
per stop: where, its gap, its law and the law's numbers) and ``[model.excitation]`` (the drive).
The paper's shorthand stays valid input and means exactly this (:func:`expand`):

===========================================  ==================================================
shorthand                                    canonical
===========================================  ==================================================
``fidelity = "sdof"`` / ``"beam"``           ``[model.system] builder``
``beta`` (nondimensional SDOF),              ``[model.system] damping_ratio``
``damping_ratio``
``natural_frequency_hz``, ``length_mm``;     ``[model.system]`` (the same names)
the beam's geometry, section, mass,
``discs``, ``calibrate``, damping,
``n_modes``, ``n_elements``
``B``                                        ``[model.excitation] amplitude`` (a base displacement)
``gain``, ``voltage``                        ``[model.excitation] gain``, ``voltage``
``R``, ``Delta`` / ``gap_mm`` /              ``stop[0]``: the paper's (upper) stop at the attached
``contact_gap_mm``, ``[model.contact]``      mass: ``R``, its gap, its law's keys
``Delta_lower`` / ``gap_lower_mm`` /         ``stop[1]``: the lower stop there (``Delta``,
``contact_gap_lower_mm``,                    ``gap_mm``, ``contact_gap_mm``; its law's keys and R;
``[model.contact_lower]``                    without ``[model.contact_lower]`` no R and no law: the
                                             upper stop's law)
``[[model.stop]]`` beside ``fidelity``       reordered: the upper stop at the mass first, the lower
                                             one there second, the point stops (``position_mm``)
                                             after them in their order (output codes 0, 1, 2 + i)
===========================================  ==================================================

A table already canonical (``[model.system] builder`` and no ``fidelity``) is returned as it is.
The expansion records where each canonical key came from (:func:`expanded`, :func:`user_key`), so
a message about a canonical key names the key the user wrote.
"""
from __future__ import annotations

import copy

__all__ = ["expand", "expanded", "alias", "aliases", "user_key", "required_keys", "SHORTHAND_FIDELITIES",
           "SHORTHAND_KEYS"]

#: the fidelities whose ``[model]`` table has a shorthand (``fidelity = ...``), expanded into the
#: ``[model.system] builder`` of the same name
SHORTHAND_FIDELITIES = ("sdof", "beam")

#: shorthand key -> key of ``[model.system]``, per fidelity (``beta`` is the SDOF's damping ratio)
_SYSTEM = {
    "sdof": {"beta": "damping_ratio", "damping_ratio": "damping_ratio",
             "natural_frequency_hz": "natural_frequency_hz", "length_mm": "length_mm"},
    "beam": {k: k for k in ("length_mm", "sensor_position_mm", "mass_position_mm", "width_mm", "thickness_mm",
                            "youngs_modulus_gpa", "density_kg_m3", "EI_n_m2", "rhoA_kg_m", "mass_kg",
                            "rotary_inertia_kg_m2", "discs", "calibrate", "damping_ratio", "rayleigh_alpha_1_s",
                            "n_modes", "n_elements")},
}
#: shorthand key -> key of ``[model.excitation]`` (a base displacement)
_EXCITATION = {"B": "amplitude", "gain": "gain", "voltage": "voltage"}
#: the upper stop's gap keys (as in its table) and the lower stop's (-> its table's key)
_UPPER_GAPS = ("Delta", "gap_mm", "contact_gap_mm")
_LOWER_GAPS = {"Delta_lower": "Delta", "gap_lower_mm": "gap_mm", "contact_gap_lower_mm": "contact_gap_mm"}
#: the shorthand keys of the stops (refused beside ``[[model.stop]]``)
_STOP_KEYS = ("R", *_UPPER_GAPS, *_LOWER_GAPS, "contact", "contact_lower")
#: the keys a shorthand ``[model]`` table of each fidelity may have (others are refused by name), in
#: the order the case-file reference (``cases/README.md``, :mod:`vibeam.case.reference`) lists them and
#: a run stores them (``attrs["model"]``): ``fidelity``, the system's keys, the stops' and the drive's
#: (each in the table :func:`expand` puts it in; ``tests/test_expand.py`` checks they are these)
SHORTHAND_KEYS = {
    "sdof": ("fidelity", "beta", "B", "R", "Delta", "natural_frequency_hz", "damping_ratio", "gap_mm", "length_mm",
             "gain", "voltage", "Delta_lower", "gap_lower_mm", "contact", "contact_lower", "stop"),
    "beam": ("fidelity", "length_mm", "sensor_position_mm", "mass_position_mm", "width_mm", "thickness_mm",
             "youngs_modulus_gpa", "density_kg_m3", "EI_n_m2", "rhoA_kg_m", "mass_kg", "rotary_inertia_kg_m2", "discs",
             "calibrate", "R", "gap_mm", "contact_gap_mm", "gap_lower_mm", "contact_gap_lower_mm", "contact",
             "contact_lower", "stop", "gain", "voltage", "damping_ratio", "rayleigh_alpha_1_s", "n_modes",
             "n_elements"),
}


def expand(model: dict) -> dict:
    """The canonical tables of a ``[model]`` table (module docstring: the one definition of the
    shorthand).

    Parameters
    ----------
    model : dict
        A ``[model]`` table as read from a case file (with a run's overrides applied): the
        shorthand (``fidelity = "sdof"`` or ``"beam"`` and its keys, with or without
        ``[[model.stop]]``) or already canonical.

    Returns
    -------
    dict
        ``{"system": {...}, "stop": [...], "excitation": {...}}`` for a shorthand table (a new
        dict; ``model`` is not changed); ``model`` itself when it is canonical, or when it is not
        a shorthand table this function knows (no ``fidelity``, another fidelity: the case's
        validation says what is wrong).

    Raises
    ------
    ValueError
        Only where the shorthand cannot be expanded, naming the key: the stops given both as
        ``[[model.stop]]`` tables and by shorthand keys, ``[model.contact] R`` (the upper stop's R
        is ``[model] R``), ``[model.contact_lower]`` without a lower gap.  A value that is not valid is left for the canonical validation.
    """
    return expanded(model)[0]


def expanded(model: dict) -> tuple[dict, dict]:
    """``(expand(model), origins)``: ``origins`` maps a canonical location (a tuple of keys and
    stop indices, e.g. ``("system", "damping_ratio")``, ``("stop", 1, "R")``) to the key the user
    wrote (``"beta"``, ``"contact_lower.R"``, ``"stop[2].gap_mm"``); locations it does not map were
    written as they are (:func:`user_key`).  Raises as :func:`expand`."""
    if not isinstance(model, dict):
        return model, {}
    fid = model.get("fidelity")
    if not isinstance(fid, str) or fid not in SHORTHAND_FIDELITIES:
        return model, {}
    system: dict = {"builder": fid}
    excitation: dict = {"kind": "base_displacement"}
    origins: dict = {("system", "builder"): "fidelity"}
    names = _SYSTEM[fid]
    for k, v in model.items():
        if k in ("fidelity", "stop") or k in _STOP_KEYS:
            continue
        if k in _EXCITATION:
            excitation[_EXCITATION[k]] = copy.deepcopy(v)
            origins[("excitation", _EXCITATION[k])] = k
        elif k in ("system", "excitation") and isinstance(v, dict):   # canonical tables beside the keys
            target = system if k == "system" else excitation
            for q, w in v.items():
                if q != "builder":
                    target[q] = copy.deepcopy(w)
        else:
            # a system key, or one no table has: left in [model.system] (refused there, by its name)
            key = names.get(k, k)
            if key in system and key != k:       # beta and damping_ratio both: the second keeps its name
                key = k
            system[key] = copy.deepcopy(v)
            origins[("system", key)] = k
    if "stop" in model:
        stops, o = _stop_tables(model, fid)
    else:
        stops, o = _shorthand_stops(model)
    origins.update(o)
    return {"system": system, "stop": stops, "excitation": excitation}, origins


def _shorthand_stops(model: dict) -> tuple[list, dict]:
    """The stops of the shorthand keys: ``stop[0]`` from ``R``, the upper gap and
    ``[model.contact]``; ``stop[1]`` from the lower gap and ``[model.contact_lower]``."""
    origins: dict = {}
    up: dict = {"side": "upper"}
    for k in _UPPER_GAPS:
        if model.get(k) is not None:        # None (an override in Python): the key not given
            up[k] = model[k]
            origins[("stop", 0, k)] = k
    if "R" in model:
        up["R"] = model["R"]
        origins[("stop", 0, "R")] = "R"
    contact = model.get("contact")
    if isinstance(contact, dict):
        if "R" in contact:
            raise ValueError("'contact.R': the R of the first stop is [model] R")
        for k, v in contact.items():
            up[k] = copy.deepcopy(v)
            origins[("stop", 0, k)] = f"contact.{k}"
    elif contact is not None:
        up["contact"] = contact                    # not a table: refused by the stop table, named
        origins[("stop", 0, "contact")] = "contact"
    stops = [up]
    origins[("stop", 0)] = "model"
    lower_keys = [k for k in _LOWER_GAPS if model.get(k) is not None]
    lower = model.get("contact_lower")
    if lower is not None and not lower_keys:
        raise ValueError(f"[model.contact_lower] needs a lower stop: give one of {list(_LOWER_GAPS)}")
    if lower_keys or lower is not None:
        lo: dict = {"side": "lower"}
        for k in lower_keys:
            lo[_LOWER_GAPS[k]] = model[k]
            origins[("stop", 1, _LOWER_GAPS[k])] = k
        if isinstance(lower, dict):
            for k, v in lower.items():
                lo[k] = copy.deepcopy(v)
                origins[("stop", 1, k)] = f"contact_lower.{k}"
        elif lower is not None:
            lo["contact_lower"] = lower
            origins[("stop", 1, "contact_lower")] = "contact_lower"
        origins[("stop", 1)] = "contact_lower" if lower is not None else lower_keys[0]
        stops.append(lo)
    return stops, origins


def _stop_tables(model: dict, fid: str) -> tuple[list, dict]:
    """``[[model.stop]]`` beside ``fidelity``: the upper stop at the attached mass first, the lower
    one there second, the others after them in their order; the law keys as the shorthand they
    stood for (a Newton upper stop's ``law`` and ``mass_kg`` dropped; the lower stop's ``law`` always
    given, its ``R`` dropped when it is a compliant law's target equal to the upper stop's)."""
    stops = model["stop"]
    short = [k for k in _STOP_KEYS if k in model]
    if short:
        raise ValueError(f"give the stops either as [[model.stop]] tables or by the shorthand keys, not both "
                         f"(got [[model.stop]] and {short})")
    if not isinstance(stops, list) or not all(isinstance(s, dict) for s in stops):
        return stops, {}                          # refused by the canonical validation
    mass = model.get("mass_position_mm") if fid == "beam" else None

    def at_mass(s):
        p = s.get("position_mm")
        if p is None:
            return True
        try:
            return mass is not None and abs(p - mass) <= 1e-9 * max(mass, 1.0)
        except TypeError:
            return False

    side = [s.get("side", "upper") for s in stops]
    up = [i for i, s in enumerate(stops) if at_mass(s) and side[i] == "upper"]
    lo = [i for i, s in enumerate(stops) if at_mass(s) and side[i] == "lower"]
    order = up[:1] + lo[:1] + [i for i in range(len(stops)) if i not in up[:1] + lo[:1]]
    out, origins = [], {}
    for j, i in enumerate(order):
        s = copy.deepcopy(stops[i])
        if up and i == up[0] and s.get("law", "restitution") == "restitution":
            s.pop("law", None)                    # Newton's law (the shorthand's [model] R alone)
            s.pop("mass_kg", None)
        if lo and i == lo[0]:
            s.setdefault("law", "restitution")
            if up and s["law"] != "restitution" and s.get("R") == stops[up[0]].get("R"):
                s.pop("R", None)                  # a compliant law's target R: the upper stop's
        out.append(s)
        origins[("stop", j)] = f"stop[{i}]"
        for k in s:
            origins[("stop", j, k)] = f"stop[{i}].{k}"
    return out, origins


def alias(builder: str, key: str) -> str | None:
    """The parameter path (:mod:`vibeam.case.paths`) the flat shorthand key ``key`` stands for in the
    canonical tables of a ``[model.system] builder``, as :func:`expand` maps it: ``R`` ->
    ``stops[0].law.R``, ``Delta`` / ``gap_mm`` / ``contact_gap_mm`` -> ``stops[0].<key>``,
    ``Delta_lower`` -> ``stops[1].Delta`` (``gap_lower_mm``, ``contact_gap_lower_mm`` alike), ``beta``
    -> ``system.damping_ratio``, ``B`` -> ``excitation.amplitude``, ``voltage`` ->
    ``excitation.voltage``, a system key of the builder's shorthand -> ``system.<key>``.  None for a
    key the shorthand does not have (or a builder without one, or a table key: ``contact``)."""
    if builder not in SHORTHAND_FIDELITIES or not isinstance(key, str) or key not in _flat_keys(builder):
        return None
    _, origins = expanded({"fidelity": builder, key: 0.0})
    loc = next((loc for loc, k in origins.items() if k == key), None)
    if loc is None:
        return None
    if loc[0] == "stop":
        return f"stops[{loc[1]}].{'law.' if loc[2] == 'R' else ''}{loc[2]}"
    return f"{loc[0]}.{loc[1]}"


def aliases(builder: str) -> dict:
    """``{flat shorthand key: path}`` of every flat key of the shorthand of ``builder``
    (:func:`alias`); {} for a builder without a shorthand."""
    if builder not in SHORTHAND_FIDELITIES:
        return {}
    return {k: alias(builder, k) for k in _flat_keys(builder)}


def _flat_keys(builder: str) -> tuple:
    """The flat keys of the shorthand of ``builder`` that name one number (not a table)."""
    return (*(k for k in _SYSTEM[builder] if k not in ("discs", "calibrate")), *_EXCITATION, "R", *_UPPER_GAPS,
            *_LOWER_GAPS)


def user_key(origins: dict, loc: tuple, builder: str | None = None) -> str:
    """The key the user wrote for canonical location ``loc`` (a pydantic error location inside
    ``[model]``, e.g. ``("system", "damping_ratio")``, ``("stop", 1, "R")``): the origin of its
    longest mapped prefix with the rest appended (``("system", "discs", "count")`` ->
    ``"discs.count"``); with ``builder`` (a shorthand fidelity), a location the user did not write
    (a missing key) by the shorthand key that gives it (``("stop", 0, "R")`` -> ``"R"``); ``loc``
    written as a dotted key where nothing maps it."""
    loc = tuple(loc)
    if builder in SHORTHAND_FIDELITIES:
        full = expanded({"fidelity": builder, **{k: 0.0 for k in _flat_keys(builder)}})[1]
        origins = {**{k: v for k, v in full.items() if len(k) > 1 or k == ("stop",)}, **origins}
    for n in range(len(loc), 0, -1):
        if loc[:n] in origins:
            head = origins[loc[:n]]
            head = "" if head == "model" else head
            return head + _dotted(loc[n:], lead=bool(head))
    return _dotted(loc, lead=False)


def _dotted(parts, lead: bool) -> str:
    out = ""
    for p in parts:
        if isinstance(p, int):
            out += f"[{p}]"
        else:
            out += ("." if out or lead else "") + str(p)
    return out


def required_keys(fidelity: str, model: dict) -> tuple:
    """The keys a shorthand ``[model]`` table of ``fidelity`` (``"sdof"`` or ``"beam"``) must give,
    by their shorthand names: the drive (``gain``, ``voltage``), ``R`` and, for the SDOF, the
    damping and the gap of the nondimensional (``beta``, ``B``, ``Delta``: paper Eqs. 1-2) or the
    physical form (Eqs. 43-46) the table is written in; the stops' keys not where ``[[model.stop]]``
    tables give the stops."""
    out = ("gain", "voltage")
    if fidelity == "sdof":
        phys = ("natural_frequency_hz", "damping_ratio", "gap_mm", "length_mm", "gain", "voltage")
        nondim = ("beta", "B", "Delta")
        given_p, given_n = any(k in model for k in phys), any(k in model for k in nondim)
        out = phys if given_p and not given_n else () if given_p else nondim
    return tuple(k for k in (*out, "R") if "stop" not in model or k not in ("R", "Delta", "gap_mm"))
