"""The SDOF builder (issue 58 step e): a case's SDOF table becomes its scene straight from its
values (:func:`vibeam.models.builders.sdof.sdof`, paper Eqs. 1-2 and 43-46), with no model object
between; the scene is the one the SDOF model class built, bit for bit, for every shipped SDOF case
(recorded in ``references/sdof_scenes.json`` before the class was deleted)."""
from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

import vibeam

from vibeam.case.schema import SDOFSceneSpec, load_case
from vibeam.models.builders.sdof import sdof, sdof_physical
from vibeam.models.compliant import LinearContact
from vibeam.models.contact import Restitution

CASES = Path(__file__).resolve().parents[1] / "cases"
RECORDED = json.loads((Path(__file__).resolve().parent / "references" / "sdof_scenes.json").read_text())["scenes"]


def _recorded(sc) -> dict:
    """A scene as ``references/sdof_scenes.json`` holds it: every field of the modal system (floats
    as ``float.hex``, NaN as ``nan``; arrays with their dtype and shape), ``repr`` of the stops (its
    floats round-trip), and which stops hold the upper stop's law object."""
    def enc(x):
        if isinstance(x, np.ndarray):
            return {"dtype": x.dtype.str, "shape": list(x.shape), "hex": [float(v).hex() for v in x.ravel()]}
        if isinstance(x, float):
            return {"float": x.hex()}
        return x

    return {"builder": sc.builder, "system": {k: enc(v) for k, v in sc.system._asdict().items()},
            "stops": repr(sc.stops), "shares_upper_law": [s.law is sc.stops[0].law for s in sc.stops]}


#: SDOF tables the shipped cases do not write (shorthand, expanded at load): a lower stop whose law
#: follows the upper's, nondimensional and physical; a compliant lower stop with its own table below
#: a compliant upper one; Newton's law below a compliant stop (mixed)
TABLES = {
    "follows": dict(fidelity="sdof", beta=0.015, B=0.5e-3, R=0.9, Delta=0.0, Delta_lower=2e-3),
    "follows-physical": dict(fidelity="sdof", natural_frequency_hz=7.6, damping_ratio=0.015, R=0.8, gap_mm=0.9,
                             gap_lower_mm=1.2, length_mm=180.0, gain=1.5e-3, voltage=0.4),
    "compliant-both": dict(fidelity="sdof", beta=0.015, B=0.5e-3, R=0.8, Delta=0.0, Delta_lower=2e-3,
                           contact=dict(law="linear", stiffness=1e4),
                           contact_lower=dict(law="linear", stiffness=2e4)),
    "mixed": dict(fidelity="sdof", beta=0.015, B=0.5e-3, R=0.8, Delta=0.0, Delta_lower=2e-3,
                  contact=dict(law="linear", stiffness=1e4), contact_lower=dict(law="restitution", R=0.5)),
}


def _sdof_specs():
    out = []
    for name, model in TABLES.items():
        case = vibeam.load_case(dict(name=name, model=model, sweep=dict(Omega=[1.8, 2.2, 3]),
                                     run=[dict(name="e", method="event")]))
        out.append(pytest.param(case.model_spec(), id=name))
    for path in sorted(CASES.glob("*.toml")):
        try:
            case, _ = load_case(path)
        except Exception:     # a case that needs files beside it, or demonstrates a refusal
            continue
        for i, over in [(None, {})] + [(i, dict(r.model)) for i, r in enumerate(case.run) if r.model]:
            spec = case.model_spec(over) if over else case.model_spec()
            if isinstance(spec, SDOFSceneSpec):
                out.append(pytest.param(spec, id=path.stem if i is None else f"{path.stem}-run{i}"))
    return out


@pytest.mark.parametrize("spec", _sdof_specs())
def test_every_shipped_sdof_case_builds_the_models_scene(spec, request):
    """Against the scene the SDOF model class built for the table (``spec.build().scene()`` at
    d402333, recorded): nondimensional and physical, one and two stops, Newton's and compliant laws,
    mixed stops; every case recorded is still built (none lost from the comparison)."""
    assert _recorded(spec.scene()) == RECORDED[request.node.callspec.id]


def test_every_recorded_scene_is_compared():
    """The recorded tables and the compared ones are the same set."""
    assert sorted(p.id for p in _sdof_specs()) == sorted(RECORDED)


def test_the_kinds_of_sdof_table_are_all_among_the_shipped_cases():
    """The comparison above covers what the builder branches on: a physical and a nondimensional
    table, a second stop whose law follows the upper's and one with its own, a compliant law."""
    scenes = [p.values[0].scene() for p in _sdof_specs()]
    assert any(math.isnan(s.system.time_unit_s) for s in scenes)
    assert any(not math.isnan(s.system.time_unit_s) for s in scenes)
    two = [s for s in scenes if len(s.stops) == 2]
    assert any(s.stops[1].law is s.stops[0].law for s in two)
    assert any(s.stops[1].law is not s.stops[0].law for s in two)
    assert any(s.stops[0].law.kind != "impulsive" for s in scenes)


def test_the_builder_is_paper_eqs_1_2_and_43_46():
    """``q'' + 2 beta q' + q = Omega^2 B sin(Omega t)``: one mode, omega 1, c = 2 beta, unit rows;
    the stop at q = Delta (normal +1) and one at q = -Delta_lower (normal -1); the rig's numbers
    through Eqs. 43-46 (B = gamma V, Delta = Delta_G / L, time unit 1 / (2 pi f_n), L in m)."""
    sc = sdof(0.015, 0.5e-3, 0.2, 0.9, Delta_lower=0.3, lower_law=Restitution(0.5))
    s = sc.system
    assert (s.omega.tolist(), s.damping.tolist(), s.participation.tolist(), s.sensor.tolist()) == \
        ([1.0], [0.03], [1.0], [1.0])
    assert s.contacts.tolist() == [[1.0]] and s.base_amplitude == 0.5e-3 and sc.builder == "sdof"
    assert [(st.relation.sign, st.relation.offset, st.law.R) for st in sc.stops] == [(1.0, 0.2, 0.9),
                                                                                      (-1.0, 0.3, 0.5)]
    ph = sdof_physical(7.6, 0.015, 0.9, 180.0, 1.5e-3, 0.4, R=0.8, gap_lower_mm=1.8)
    s = ph.system
    assert s.base_amplitude == 1.5e-3 * 0.4 and ph.stops[0].relation.offset == 0.9 / 180.0
    assert ph.stops[1].relation.offset == 1.8 / 180.0 and ph.stops[1].law is ph.stops[0].law
    assert s.time_unit_s == 1.0 / (2.0 * math.pi * 7.6) and s.length_unit_m == 0.18 and s.reference_hz == 7.6


@pytest.mark.parametrize("kw, exc, needle", [
    (dict(), TypeError, "R or its law"),
    (dict(R=0.9, law=Restitution(0.9)), TypeError, "R or its law"),
    (dict(R=1.2), ValueError, "R must lie in"),
    (dict(R=0.9, lower_law=LinearContact.from_restitution(1e4, 0.8)), ValueError, "needs a lower stop"),
    (dict(R=0.9, beta=-0.1), ValueError, "beta must be finite and >= 0"),
])
def test_the_builder_refuses_in_one_line(kw, exc, needle):
    args = dict(beta=0.015, B=0.5e-3, Delta=0.0)
    args.update(kw)
    with pytest.raises(exc, match=needle):
        sdof(**args)
