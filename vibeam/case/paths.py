"""Parameters named by path into the scene (issue 43): one resolver for ``[map] parameter``,
``vibeam fit --params`` and ``[basins] along = "map"``.

A path names a number of the scene as the case file holds it::

    stops[1].law.stiffness_n_m   # the second stop's law: its stiffness (N/m)
    stops[1].law.R               # the second stop's R (Newton's coefficient, or a compliant law's target)
    stops[0].gap_mm              # the first stop's gap at the sensor (its gap key: gap_mm,
                                 # contact_gap_mm or Delta, as the stop gives it)
    stops[2].position_mm         # where a point stop sits on the beam
    system.damping_ratio         # a key of the modal system ([model])
    excitation.voltage           # a key of the excitation (voltage, gain, B)

The stops are counted as the case file gives them: the ``[[model.stop]]`` tables in their order,
or, for a scene given by the shorthand keys, ``stops[0]`` the paper's stop (``R``, ``Delta`` /
``gap_mm`` / ``contact_gap_mm``, ``[model.contact]``) and ``stops[1]`` the lower stop at the
attached mass (``Delta_lower`` / ``gap_lower_mm`` / ``contact_gap_lower_mm``,
``[model.contact_lower]``).  A path sets exactly the key it stands for (:func:`set_value`), so a
value set by path and the same value written in the case file give the same scene.  The flat
keys (``R``, ``gap_mm``, ``Delta_lower``, ``voltage``, ...) stay as they are: aliases of the
paths they stand for.

Plain functions over plain dicts (the ``[model]`` table as read); nothing here names a law.
"""
from __future__ import annotations

import re

from vibeam.case.expand import alias as shorthand_alias
from vibeam.models.registry import LAWS, is_compliant

#: a stop table's own numbers (where it is and its gap); the rest of its numbers are its law's
STOP_KEYS = ("position_mm", "gap_mm", "contact_gap_mm", "Delta")
#: the model keys of the excitation (``excitation.<key>``: the shorthand's and the canonical
#: ``[model.excitation]`` table's numbers); every other model key is the system's
EXCITATION_KEYS = ("voltage", "gain", "B", "amplitude", "amplitude_mm", "amplitude_m_s2", "amplitude_n")
#: the shorthand keys of the two stops at the attached mass: (upper, lower) per stop key
_SHORT_GAPS = {"Delta": ("Delta", "Delta_lower"), "gap_mm": ("gap_mm", "gap_lower_mm"),
               "contact_gap_mm": ("contact_gap_mm", "contact_gap_lower_mm")}
_SHORTHAND = ("R", "contact", "contact_lower", *(k for pair in _SHORT_GAPS.values() for k in pair))
_STOP = re.compile(r"^stops\[(\d+)\]\.(?:(law)\.)?([A-Za-z_][A-Za-z0-9_]*)$")
_GROUP = re.compile(r"^(system|excitation)\.([A-Za-z_][A-Za-z0-9_]*)$")
_FORMS = ("stops[i].law.<key>, stops[i].<gap or position key>, system.<key>, excitation.<key>")


def is_path(name) -> bool:
    """Whether ``name`` is written as a path (``stops[...]``, ``system.``, ``excitation.``)
    rather than a flat ``[model]`` key."""
    return isinstance(name, str) and (name.startswith("stops") or _GROUP.match(name) is not None
                                      or name.startswith(("system.", "excitation.")))


def is_canonical(model) -> bool:
    """Whether ``model`` (a ``[model]`` table) is written in the canonical tables (``[model.system]
    builder``, no ``fidelity``: :mod:`vibeam.case.expand`), where ``system.<key>`` and
    ``excitation.<key>`` name the keys of those tables."""
    return (isinstance(model, dict) and "fidelity" not in model and isinstance(model.get("system"), dict)
            and "builder" in model["system"])


def path_of(model: dict, name: str) -> str | None:
    """The path a flat key stands for in the canonical tables ``model`` (:func:`is_canonical`): a key
    of ``[model.system]`` or ``[model.excitation]`` given there (``n_modes`` -> ``system.n_modes``),
    a shorthand key as the expansion maps it (:func:`vibeam.case.expand.alias`: ``beta`` ->
    ``system.damping_ratio``, ``B`` -> ``excitation.amplitude``, ``R`` -> ``stops[0].law.R``,
    ``Delta_lower`` -> ``stops[1].Delta``), or the flat name of a stop's number (``R_lower`` ->
    ``stops[1].law.R``, :func:`alias_of`); a path is returned as it is.  None where nothing maps
    ``name`` (or ``model`` is not canonical)."""
    if is_path(name):
        return name
    if not is_canonical(model) or not isinstance(name, str):
        return None
    for group in ("system", "excitation"):
        t = model.get(group)
        if isinstance(t, dict) and name in t and name != "builder" and (group == "excitation") == (name in EXCITATION_KEYS):
            return f"{group}.{name}"
    p = shorthand_alias(model["system"]["builder"], name)
    if p is not None:
        return p
    stops = model.get("stop")
    for i, s in enumerate(stops if isinstance(stops, list) else []):
        if not isinstance(s, dict):
            continue
        for q in (*(f"stops[{i}].{k}" for k in STOP_KEYS if k in s), f"stops[{i}].law.R"):
            if alias_of(model, q) == name:
                return q
    return None


def _group(key: str) -> str:
    return "excitation" if key in EXCITATION_KEYS else "system"


def parse(name: str) -> tuple:
    """``(kind, index, key)`` of a path: ``("law", i, key)``, ``("stop", i, key)`` or
    ``("model", None, key)``.

    Raises
    ------
    ValueError
        One line naming the path and the forms allowed.
    """
    m = _STOP.match(name)
    if m:
        i, law, key = int(m.group(1)), m.group(2), m.group(3)
        if law is None and key not in STOP_KEYS:
            hint = f" (a law's key: stops[{i}].law.{key})" if key in _law_keys() else ""
            raise ValueError(f"{name!r}: a stop's own keys are {', '.join(STOP_KEYS)}{hint}")
        if law is not None and key not in _law_keys():
            raise ValueError(f"{name!r}: a law's keys are {', '.join(_law_keys())}")
        return ("law" if law else "stop", i, key)
    m = _GROUP.match(name)
    if m:
        group, key = m.groups()
        if key in _SHORTHAND:
            raise ValueError(f"{name!r}: {key} is a stop's key; name it by its stop (stops[i]....)")
        if (group == "excitation") != (key in EXCITATION_KEYS):
            want = "excitation" if key in EXCITATION_KEYS else "system"
            raise ValueError(f"{name!r}: {key} is a key of the {want} ({want}.{key})")
        return ("model", None, key)
    raise ValueError(f"{name!r} is not a parameter path; allowed forms: {_FORMS}")


def flat_key(name):
    """The flat ``[model]`` key a ``system.<key>`` or ``excitation.<key>`` path names (``excitation.voltage``
    -> ``voltage``): the key a ``[map]``, ``[[uncertainty.parameter]]`` or ``vibeam fit --params`` then
    varies, the same as with the flat name.  Any other name is returned as it is.

    Raises
    ------
    ValueError
        A key of the other group (``excitation.beta``) or a stop's key (``system.R``), one line.
    """
    if isinstance(name, str) and _GROUP.match(name):
        try:
            return parse(name)[2]
        except ValueError as e:          # the caller names the key and the value
            msg = str(e)
            raise ValueError(msg[len(repr(name)) + 2:] if msg.startswith(f"{name!r}: ") else msg) from None
    return name


def canonical(model: dict, name: str) -> str:
    """The one path a parameter stands for in the ``[model]`` table ``model``, however it is named:
    ``R`` and ``stops[0].law.R`` -> ``stops[0].law.R``, ``beta`` and ``system.beta`` ->
    ``system.beta``, ``voltage`` and ``excitation.voltage`` -> ``excitation.voltage``; two names
    with one canonical path are one parameter.  A name that is no valid path is returned as it is
    (refused elsewhere, naming its own key)."""
    if not is_path(name) and is_canonical(model):
        name = path_of(model, name) or name
    if is_path(name):
        try:
            kind, i, key = parse(name)
        except ValueError:
            return name
        if kind == "model":
            return f"{'excitation' if key in EXCITATION_KEYS else 'system'}.{key}"
        return f"stops[{i}].law.{key}" if kind == "law" else f"stops[{i}].{key}"
    for p in parameter_paths(model):
        try:
            if alias_of(model, p) == name:
                return p
        except ValueError:
            continue
    if name in _SHORTHAND or name.endswith("_lower"):
        return name
    return f"{'excitation' if name in EXCITATION_KEYS else 'system'}.{name}"


def _law_keys() -> tuple:
    """Every law's numeric keys (the registry's), R first."""
    out = ["R"]
    for law in LAWS.values():
        out += [k for k in law.keys if k not in out]
    return tuple(out)


def _keys_of(law: str) -> tuple:
    """A law's keys as paths name them: R, then its registry keys."""
    return ("R",) + tuple(k for k in LAWS[law].keys if k != "R")


# ----------------------------------------------------------------------------- the stops of a table
def _short_stops(model: dict) -> list:
    """The stops of a shorthand table: the paper's stop, and the lower one at the mass if given."""
    n = 1 + any(lo in model for _, lo in _SHORT_GAPS.values())
    return list(range(n))


def _law_of_short(model: dict, i: int) -> tuple[str, dict, str]:
    """``(law name, table, key)`` of shorthand stop ``i``: its law, the table that holds its
    keys (``contact`` or ``contact_lower``; the upper table when the lower stop takes the upper
    stop's law), and the key of that table in ``[model]``."""
    up = model.get("contact") or {}
    if i == 0:
        return up.get("law", "restitution"), up, "contact"
    lo = model.get("contact_lower")
    if lo is None:   # the lower stop takes the upper stop's law (restitution with [model] R, or its table)
        return up.get("law", "restitution"), up, "contact"
    return lo.get("law", "restitution"), lo, "contact_lower"


def _count(model: dict) -> int:
    stops = model.get("stop")
    return len(stops) if isinstance(stops, list) else len(_short_stops(model))


def _refuse_index(name: str, i: int, model: dict) -> None:
    n = _count(model)
    if i >= n:
        raise ValueError(f"{name!r}: the scene has {n} stop(s) (stops[0]{f' ... stops[{n - 1}]' if n > 1 else ''})")


def get_value(model: dict, name: str):
    """The value ``name`` has in the ``[model]`` table ``model`` (a path or a flat key); None
    where it is not given (a key left to its default).

    Raises
    ------
    ValueError
        A path that is not valid or names a stop or key the scene does not have (one line).
    """
    if not is_path(name):
        p = path_of(model, name)
        return model.get(name) if p is None else get_value(model, p)
    kind, i, key = parse(name)
    if kind == "model":
        if is_canonical(model):
            t = model.get(_group(key))
            return t.get(key) if isinstance(t, dict) else None
        return model.get(key)
    _refuse_index(name, i, model)
    stops = model.get("stop")
    if isinstance(stops, list):
        return stops[i].get(key)
    if kind == "stop":
        return model.get(_SHORT_GAPS[key][i]) if key in _SHORT_GAPS else None
    if key == "R":
        _, table, where = _law_of_short(model, i)
        if i == 1 and where == "contact_lower" and table.get("R") is not None:
            return table["R"]
        return model.get("R")
    return _law_of_short(model, i)[1].get(key)


def set_value(model: dict, name: str, value) -> dict:
    """``model`` (a ``[model]`` table) with the number ``name`` (a path) set to ``value``: the one
    key the path stands for (``[[model.stop]]`` tables: the stop's key; shorthand tables: ``R``,
    ``Delta_lower``, ``[model.contact_lower] stiffness_n_m``, ...).  A new dict; ``model`` is
    not changed.

    Raises
    ------
    ValueError
        One line naming the path: not a valid path; a stop the scene does not have; a key its
        stop or law does not take (a gap given as another key, a restitution law's stiffness).
    """
    kind, i, key = parse(name)
    out = dict(model)
    if kind == "model":
        if is_canonical(model):
            group = _group(key)
            out[group] = {**(model.get(group) or {}), key: value}
        else:
            out[key] = value
        return out
    _refuse_index(name, i, model)
    stops = model.get("stop")
    if isinstance(stops, list):
        stops = [dict(s) if isinstance(s, dict) else s for s in stops]
        s = stops[i]
        law = s.get("law", "restitution")
        if kind == "stop":
            if key not in s:
                given = [k for k in STOP_KEYS if k in s]
                raise ValueError(f"{name!r}: stop[{i}] has no {key} (it gives {', '.join(given) or 'none'})")
        elif key != "R" and key not in LAWS[law].keys:
            raise ValueError(f"{name!r}: law = {law!r} of stop[{i}] takes {', '.join(_keys_of(law))}")
        s[key] = value
        out["stop"] = stops
        return out
    if kind == "stop":
        if key == "position_mm":
            raise ValueError(f"{name!r}: a stop given by the shorthand keys sits at the attached mass; give the "
                             f"stops as [[model.stop]] tables to place one by position_mm")
        short = _SHORT_GAPS[key][i]
        if short not in model:
            given = [k for k, pair in _SHORT_GAPS.items() if pair[i] in model]
            raise ValueError(f"{name!r}: stop[{i}] gives its gap as {', '.join(given)} "
                             f"(stops[{i}].{given[0] if given else 'gap_mm'})")
        out[short] = value
        return out
    law, table, where = _law_of_short(model, i)
    if key == "R":
        if i == 0:
            out["R"] = value
        else:            # the lower stop's own R: Newton's, or its compliant law's target R
            lo = dict(model.get("contact_lower") or ({"law": "restitution"} if not is_compliant(law) else table))
            lo["R"] = value
            out["contact_lower"] = lo
        return out
    if key not in LAWS[law].keys:
        raise ValueError(f"{name!r}: law = {law!r} of stop[{i}] takes {', '.join(_keys_of(law))}")
    where = "contact" if i == 0 else "contact_lower"     # the lower stop's own table from now on
    out[where] = {**table, key: value}
    return out


def parameter_paths(model: dict) -> list[str]:
    """The paths of the stops' numbers given in ``model`` (a ``[model]`` table): each stop's gap
    and position, its law's R and the law's keys that are set."""
    out = []
    stops = model.get("stop")
    if isinstance(stops, list):
        for i, s in enumerate(stops):
            if not isinstance(s, dict):
                continue
            out += [f"stops[{i}].{k}" for k in STOP_KEYS if isinstance(s.get(k), (int, float))]
            law = s.get("law", "restitution")
            keys = _keys_of(law) if law in LAWS else ("R",)
            out += [f"stops[{i}].law.{k}" for k in keys if isinstance(s.get(k), (int, float))]
        return out
    for i in _short_stops(model):
        out += [f"stops[{i}].{k}" for k, pair in _SHORT_GAPS.items() if isinstance(model.get(pair[i]), (int, float))]
        law, table, _ = _law_of_short(model, i)
        out.append(f"stops[{i}].law.R")
        if law in LAWS:
            out += [f"stops[{i}].law.{k}" for k in _keys_of(law)[1:] if isinstance(table.get(k), (int, float))]
    return out


def key_of(name: str) -> str:
    """The key a name ends in (``stops[1].law.stiffness_n_m`` -> ``stiffness_n_m``): what its unit
    and its schema bounds are looked up by."""
    return name.rsplit(".", 1)[-1] if is_path(name) else name



def _role(model: dict, i: int) -> int | None:
    """0 for the paper's stop (the first upper stop at the attached mass), 1 for the lower stop
    at the mass, None for a stop elsewhere (a point stop on the beam)."""
    stops = model.get("stop")
    if not isinstance(stops, list):
        return i
    at_mass = [j for j, s in enumerate(stops) if isinstance(s, dict) and "position_mm" not in s]
    up = [j for j in at_mass if stops[j].get("side", "upper") == "upper"]
    lo = [j for j in at_mass if stops[j].get("side", "upper") == "lower"]
    if up and i == up[0]:
        return 0
    if lo and i == lo[0]:
        return 1
    return None


def alias_of(model: dict, name: str) -> str:
    """The flat key a parameter path stands for in ``model`` (a ``[model]`` table), where one
    exists: ``stops[0].law.R`` -> ``R``, ``stops[1].law.R`` -> ``R_lower``, ``stops[1].Delta``
    -> ``Delta_lower``, ``stops[0].gap_mm`` -> ``gap_mm``, ``system.damping_ratio`` ->
    ``damping_ratio``, ...; the name itself otherwise (a flat key, or a path no flat key names:
    a law's stiffness, a point stop's position).  What a method that knows the flat keys (the
    continuation's shooting problems) is given.

    Raises
    ------
    ValueError
        A path that is not valid or names a stop the scene does not have.
    """
    if not is_path(name):
        return name
    kind, i, key = parse(name)
    if kind == "model":
        return key
    _refuse_index(name, i, model)
    role = _role(model, i)
    if role is None:
        return name
    if kind == "stop" and key in _SHORT_GAPS:
        return _SHORT_GAPS[key][role]
    if kind == "law" and key == "R":
        return ("R", "R_lower")[role]
    return name
