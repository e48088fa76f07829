"""The parameter-path resolver (:mod:`vibeam.case.paths`) by its properties, on plain ``[model]``
tables (no scene is built, no kernel runs): a path round-trips (what :func:`set_value` sets,
:func:`get_value` reads back), sets exactly the one key it stands for and leaves the table given
untouched; every refusal is one line naming the path and what is allowed; :func:`alias_of` names
the flat key of a stop's role.  Issue 56, section 2: the survivors of cosmic-ray's mutants of the
module against tests/test_paths.py, killed here (tests/README.md, "Tool-generated mutants")."""
from __future__ import annotations

import copy

import pytest

from vibeam.case.paths import (EXCITATION_KEYS, STOP_KEYS, alias_of, get_value, is_path, key_of, parameter_paths,
                               parse, set_value)
from vibeam.models.registry import LAWS

#: shorthand tables: the paper's stop, a lower stop at the mass, compliant laws on each
SHORT_TWO = {"fidelity": "sdof", "beta": 0.015, "B": 5e-3, "R": 0.8, "Delta": 0.002, "Delta_lower": 0.003,
             "contact": {"law": "linear", "stiffness": 1e4}, "contact_lower": {"law": "hunt_crossley",
                                                                              "stiffness": 3e3, "exponent": 1.5}}
SHORT_ONE = {"fidelity": "beam", "R": 0.7, "gap_mm": 0.1, "voltage": 2.0}
SHORT_NEWTON_TWO = {"fidelity": "sdof", "R": 0.8, "contact_gap_mm": 0.2, "contact_gap_lower_mm": 0.3}
#: [[model.stop]] tables: a point stop on the beam first, then a lower and an upper stop at the mass
LISTED = {"fidelity": "beam", "stop": [{"side": "lower", "position_mm": 180.0, "contact_gap_mm": 0.6, "R": 0.9},
                                       {"side": "lower", "gap_mm": 0.3, "R": 0.7, "law": "linear", "stiffness": 2e3},
                                       {"gap_mm": 0.1, "R": 0.8},
                                       {"side": "upper", "Delta": 0.2, "R": 0.5}]}
TABLES = (SHORT_TWO, SHORT_ONE, SHORT_NEWTON_TWO, LISTED)


def _law_keys() -> list:
    """R, then every law's keys of the registry in order, each once (computed here from LAWS)."""
    out = ["R"]
    for law in LAWS.values():
        out += [k for k in law.keys if k not in out]
    return out


def _changes(a: dict, b: dict) -> list:
    """The (table, key) pairs where two [model] tables differ, nested tables and stop lists opened (a
    missing contact table is one of the default law)."""
    out = []
    for k in sorted(set(a) | set(b)):
        x, y = a.get(k), b.get(k)
        if x is None and isinstance(y, dict):      # a new contact table: the default law unless it says
            x = {"law": "restitution"}
        if isinstance(x, dict) and isinstance(y, dict):
            out += [(k, kk) for _, kk in _changes(x, y)]
        elif isinstance(x, list) and isinstance(y, list) and len(x) == len(y):
            out += [(f"{k}[{i}]", kk) for i, (p, q) in enumerate(zip(x, y)) for _, kk in _changes(p, q)]
        elif x != y:
            out.append(("", k))
    return out


@pytest.mark.parametrize("model", TABLES, ids=["short-two", "short-one", "short-newton-two", "listed"])
def test_every_listed_path_round_trips_and_sets_one_key_leaving_the_table_given(model):
    paths = parameter_paths(model)
    assert paths and len(set(paths)) == len(paths)
    before = copy.deepcopy(model)
    for p in paths:
        v = get_value(model, p)
        new = 0.123 if v is None else (v * 1.5 + 0.25)
        out = set_value(model, p, new)
        assert model == before, p                              # the table given is never changed
        assert get_value(out, p) == new, p                     # the value set is the value read
        ch = _changes(model, out)
        # exactly the one key it stands for: its own, or the flat key of its stop (Delta_lower)
        assert len(ch) == 1 and ch[0][1] in (key_of(p), alias_of(model, p)), (p, ch)
        assert out is not model


def test_parameter_paths_name_each_stops_numbers_as_given():
    assert parameter_paths(SHORT_TWO) == [
        "stops[0].Delta", "stops[0].law.R", "stops[0].law.stiffness",
        "stops[1].Delta", "stops[1].law.R", "stops[1].law.stiffness", "stops[1].law.exponent"]
    assert parameter_paths(SHORT_ONE) == ["stops[0].gap_mm", "stops[0].law.R"]
    assert parameter_paths(SHORT_NEWTON_TWO) == ["stops[0].contact_gap_mm", "stops[0].law.R",
                                                 "stops[1].contact_gap_mm", "stops[1].law.R"]
    assert parameter_paths(LISTED) == [
        "stops[0].position_mm", "stops[0].contact_gap_mm", "stops[0].law.R",
        "stops[1].gap_mm", "stops[1].law.R", "stops[1].law.stiffness",
        "stops[2].gap_mm", "stops[2].law.R", "stops[3].Delta", "stops[3].law.R"]
    # a stop entry that is not a table is skipped; a law the registry does not know names only R
    odd = {"stop": ["nope", {"Delta": 0.1, "R": 0.5, "law": "unknown", "stiffness": 3.0}]}
    assert parameter_paths(odd) == ["stops[1].Delta", "stops[1].law.R"]
    # a text where a number belongs is not a number given
    assert parameter_paths({"R": 0.8, "Delta": "x"}) == ["stops[0].law.R"]


def test_get_value_reads_each_stop_and_key():
    assert get_value(SHORT_TWO, "beta") == 0.015 and get_value(SHORT_TWO, "absent") is None   # flat keys
    assert get_value(SHORT_TWO, "system.beta") == 0.015 and get_value(SHORT_ONE, "excitation.voltage") == 2.0
    assert get_value(SHORT_TWO, "stops[0].Delta") == 0.002 and get_value(SHORT_TWO, "stops[1].Delta") == 0.003
    assert get_value(SHORT_TWO, "stops[0].gap_mm") is None          # a gap key the stop does not give
    assert get_value(SHORT_TWO, "stops[1].position_mm") is None     # no position at the mass
    assert get_value(SHORT_TWO, "stops[0].law.stiffness") == 1e4
    assert get_value(SHORT_TWO, "stops[1].law.stiffness") == 3e3 and get_value(SHORT_TWO, "stops[1].law.exponent") == 1.5
    assert get_value(SHORT_TWO, "stops[0].law.exponent") is None
    # R: the [model] R for the paper's stop and for a lower stop without its own; its own where given
    assert get_value(SHORT_TWO, "stops[0].law.R") == 0.8 and get_value(SHORT_TWO, "stops[1].law.R") == 0.8
    own = dict(SHORT_TWO, contact_lower=dict(SHORT_TWO["contact_lower"], R=0.6), contact=dict(SHORT_TWO["contact"], R=0.3))
    assert get_value(own, "stops[1].law.R") == 0.6 and get_value(own, "stops[0].law.R") == 0.8
    assert get_value(SHORT_NEWTON_TWO, "stops[1].law.R") == 0.8
    # listed stops: the stop's own keys, by index
    assert [get_value(LISTED, f"stops[{i}].law.R") for i in range(4)] == [0.9, 0.7, 0.8, 0.5]
    assert get_value(LISTED, "stops[0].position_mm") == 180.0 and get_value(LISTED, "stops[1].law.stiffness") == 2e3
    assert get_value(LISTED, "stops[2].Delta") is None


def test_set_value_sets_the_key_of_each_kind_of_table():
    # the lower stop takes the upper stop's compliant law when it has no table: its own table from then on
    up_only = {k: v for k, v in SHORT_TWO.items() if k != "contact_lower"}
    out = set_value(up_only, "stops[1].law.stiffness", 2e3)
    assert out["contact_lower"] == {"law": "linear", "stiffness": 2e3} and out["contact"] == SHORT_TWO["contact"]
    assert set_value(up_only, "stops[0].law.stiffness", 2e3)["contact"] == {"law": "linear", "stiffness": 2e3}
    # the lower stop's own R: into contact_lower (a compliant law's target R, or Newton's)
    assert set_value(SHORT_TWO, "stops[1].law.R", 0.6)["contact_lower"] == dict(SHORT_TWO["contact_lower"], R=0.6)
    assert set_value(up_only, "stops[1].law.R", 0.6)["contact_lower"] == {"law": "linear", "stiffness": 1e4, "R": 0.6}
    assert set_value(SHORT_NEWTON_TWO, "stops[1].law.R", 0.6)["contact_lower"] == {"law": "restitution", "R": 0.6}
    assert set_value(SHORT_NEWTON_TWO, "stops[0].law.R", 0.6)["R"] == 0.6
    assert set_value(SHORT_NEWTON_TWO, "stops[1].contact_gap_mm", 0.5)["contact_gap_lower_mm"] == 0.5
    assert set_value(SHORT_ONE, "stops[0].gap_mm", 0.5)["gap_mm"] == 0.5
    assert set_value(SHORT_ONE, "excitation.voltage", 3.0)["voltage"] == 3.0
    out = set_value(LISTED, "stops[3].Delta", 0.25)
    assert out["stop"][3] == {"side": "upper", "Delta": 0.25, "R": 0.5} and LISTED["stop"][3]["Delta"] == 0.2
    assert out["stop"][:3] == LISTED["stop"][:3]
    assert set_value(LISTED, "stops[0].position_mm", 150.0)["stop"][0]["position_mm"] == 150.0
    assert set_value(LISTED, "stops[2].law.R", 0.1)["stop"][2] == {"gap_mm": 0.1, "R": 0.1}
    # a stop entry that is not a table is carried over as it is
    odd = {"stop": ["nope", {"Delta": 0.1, "R": 0.5}]}
    assert set_value(odd, "stops[1].law.R", 0.2)["stop"] == ["nope", {"Delta": 0.1, "R": 0.2}]


def _refused(model, path, value=1.0):
    with pytest.raises(ValueError) as e:
        set_value(model, path, value)
    msg = str(e.value)
    assert "\n" not in msg and repr(path) in msg, msg
    return msg


def test_refusals_name_the_path_and_what_is_allowed():
    keys = ", ".join(_law_keys())
    assert _refused(SHORT_TWO, "stops[0].law.bogus").endswith(f"a law's keys are {keys}")
    assert _refused(SHORT_TWO, "stops[0].bogus").endswith(
        f"a stop's own keys are {', '.join(STOP_KEYS)}")                           # no hint: not a law key
    assert _refused(SHORT_TWO, "stops[0].stiffness").endswith(
        f"a stop's own keys are {', '.join(STOP_KEYS)} (a law's key: stops[0].law.stiffness)")
    assert "stiffness_n_m is a stop's key" not in _refused(SHORT_TWO, "system.Delta_lower")
    assert _refused(SHORT_TWO, "system.Delta_lower").endswith("Delta_lower is a stop's key; name it by its stop "
                                                               "(stops[i]....)")
    assert _refused(SHORT_TWO, "system.contact").endswith("contact is a stop's key; name it by its stop (stops[i]....)")
    assert _refused(SHORT_TWO, "excitation.beta").endswith("beta is a key of the system (system.beta)")
    for k in EXCITATION_KEYS:
        assert _refused(SHORT_TWO, f"system.{k}").endswith(f"{k} is a key of the excitation (excitation.{k})")
    for bad in ("R", "stops[x].R", "stops[0].law.R.x", "stops[0]", "system.", "xstops[0].Delta", "stops[-1].Delta"):
        assert "is not a parameter path; allowed forms: stops[i].law.<key>, stops[i].<gap or position key>, " \
               "system.<key>, excitation.<key>" in _refused(SHORT_TWO, bad), bad
    # an index past the scene's stops: the count and the range
    assert _refused(SHORT_ONE, "stops[1].gap_mm").endswith("the scene has 1 stop(s) (stops[0])")
    assert _refused(SHORT_TWO, "stops[2].Delta").endswith("the scene has 2 stop(s) (stops[0] ... stops[1])")
    assert _refused(LISTED, "stops[4].law.R").endswith("the scene has 4 stop(s) (stops[0] ... stops[3])")
    with pytest.raises(ValueError, match=r"the scene has 4 stop\(s\)"):
        get_value(LISTED, "stops[4].law.R")
    # a stop of a listed table: a gap key it does not give, a law key its law does not take
    assert _refused(LISTED, "stops[1].Delta").endswith("stop[1] has no Delta (it gives gap_mm)")
    assert _refused({"stop": [{"R": 0.5}]}, "stops[0].gap_mm").endswith("stop[0] has no gap_mm (it gives none)")
    assert _refused(LISTED, "stops[2].law.stiffness").endswith("law = 'restitution' of stop[2] takes R")
    assert _refused(LISTED, "stops[1].law.exponent").endswith(
        "law = 'linear' of stop[1] takes R, stiffness, stiffness_n_m, damping_ratio, mass_kg")
    # shorthand: a gap given as another key, a position, a law key the law does not take
    assert _refused(SHORT_TWO, "stops[1].gap_mm").endswith("stop[1] gives its gap as Delta (stops[1].Delta)")
    assert _refused({"R": 0.8}, "stops[0].gap_mm").endswith("stop[0] gives its gap as  (stops[0].gap_mm)")
    assert "[[model.stop]] tables to place one by position_mm" in _refused(SHORT_ONE, "stops[0].position_mm")
    assert _refused(SHORT_ONE, "stops[0].law.stiffness").endswith("law = 'restitution' of stop[0] takes R")
    assert _refused(SHORT_TWO, "stops[1].law.damping_ratio").endswith(
        "law = 'hunt_crossley' of stop[1] takes R, stiffness, stiffness_n_m, exponent, mass_kg")


def test_a_path_parses_to_its_kind_index_and_key():
    assert parse("stops[12].law.stiffness_n_m") == ("law", 12, "stiffness_n_m")
    assert parse("stops[0].contact_gap_mm") == ("stop", 0, "contact_gap_mm")
    assert parse("system.beta") == ("model", None, "beta") and parse("excitation.B") == ("model", None, "B")
    assert [is_path(x) for x in ("stops[0].Delta", "system.beta", "excitation.B", "system.", "stopsy")] == [True] * 5
    assert [is_path(x) for x in ("R", "gap_mm", "systemic", "", 3, None)] == [False] * 6
    assert key_of("stops[1].law.stiffness_n_m") == "stiffness_n_m" and key_of("system.beta") == "beta"
    assert key_of("gap_lower_mm") == "gap_lower_mm"


def test_alias_of_names_the_flat_key_of_the_stops_role():
    assert alias_of(SHORT_TWO, "beta") == "beta" and alias_of(SHORT_TWO, "system.beta") == "beta"
    assert alias_of(SHORT_TWO, "stops[0].law.R") == "R" and alias_of(SHORT_TWO, "stops[1].law.R") == "R_lower"
    assert alias_of(SHORT_TWO, "stops[0].Delta") == "Delta" and alias_of(SHORT_TWO, "stops[1].Delta") == "Delta_lower"
    assert alias_of(SHORT_NEWTON_TWO, "stops[1].contact_gap_mm") == "contact_gap_lower_mm"
    assert alias_of(SHORT_TWO, "stops[0].position_mm") == "stops[0].position_mm"
    assert alias_of(SHORT_TWO, "stops[1].law.exponent") == "stops[1].law.exponent"
    with pytest.raises(ValueError, match="the scene has 2 stop"):
        alias_of(SHORT_TWO, "stops[2].law.R")
    # listed: the first upper stop at the mass is the paper's (side defaults to upper), the first
    # lower one at the mass the lower stop; a point stop, and a second stop of a side, have none
    assert [alias_of(LISTED, f"stops[{i}].law.R") for i in range(4)] == ["stops[0].law.R", "R_lower", "R",
                                                                         "stops[3].law.R"]
    assert alias_of(LISTED, "stops[1].gap_mm") == "gap_lower_mm" and alias_of(LISTED, "stops[2].gap_mm") == "gap_mm"
    assert alias_of(LISTED, "stops[3].Delta") == "stops[3].Delta"
    only_lower = {"stop": [{"side": "lower", "Delta": 0.1, "R": 0.5}, {"side": "lower", "Delta": 0.2, "R": 0.6}]}
    assert alias_of(only_lower, "stops[0].Delta") == "Delta_lower" and alias_of(only_lower, "stops[1].Delta") == \
        "stops[1].Delta"
    only_upper = {"stop": ["nope", {"Delta": 0.1, "R": 0.5}]}
    assert alias_of(only_upper, "stops[1].law.R") == "R" and alias_of(only_upper, "stops[0].law.R") == "stops[0].law.R"


def test_stop_sides_and_indices_compare_by_value_not_identity():
    """Texts read from a case file and indices parsed from a path are new objects, not the literals
    the resolver compares them with: a side written 'upper' at run time, and a stop index past 256
    (beyond CPython's small-integer cache), resolve as the literal ones do."""
    upper, lower = "".join(["up", "per"]), "".join(["lo", "wer"])
    listed = {"stop": [{"side": upper, "Delta": 0.1, "R": 0.5}, {"side": lower, "Delta": 0.2, "R": 0.6}]}
    assert alias_of(listed, "stops[0].law.R") == "R" and alias_of(listed, "stops[1].law.R") == "R_lower"
    assert alias_of(listed, "stops[1].Delta") == "Delta_lower"
    many = {"stop": [{"side": "lower", "position_mm": 10.0, "R": 0.5, "contact_gap_mm": 0.1}] * 299
            + [{"side": "upper", "Delta": 0.1, "R": 0.5}, {"side": "lower", "Delta": 0.3, "R": 0.4}]}
    assert alias_of(many, "stops[299].law.R") == "R" and alias_of(many, "stops[300].Delta") == "Delta_lower"
    assert alias_of(many, "stops[298].law.R") == "stops[298].law.R"
    assert get_value(many, "stops[300].law.R") == 0.4


def test_a_second_stop_of_a_side_and_an_index_far_past_the_stops():
    two_up = {"stop": [{"side": "upper", "Delta": 0.1, "R": 0.5}, {"Delta": 0.2, "R": 0.6},
                       {"side": "lower", "Delta": 0.3, "R": 0.7}]}
    assert alias_of(two_up, "stops[1].law.R") == "stops[1].law.R" and alias_of(two_up, "stops[2].law.R") == "R_lower"
    assert alias_of(two_up, "stops[0].Delta") == "Delta"
    for path in ("stops[7].law.R", "stops[7].Delta", "stops[3].law.stiffness"):
        with pytest.raises(ValueError, match=r"the scene has 2 stop\(s\) \(stops\[0\] \.\.\. stops\[1\]\)"):
            get_value(SHORT_TWO, path)
        with pytest.raises(ValueError, match=r"the scene has 2 stop\(s\)"):
            set_value(SHORT_TWO, path, 1.0)


def test_the_lower_stop_on_the_upper_stops_table_reads_the_models_R():
    """A lower stop without its own table takes the upper stop's law, and its R is [model] R, not a
    target R the upper table gives; a table's own R is listed once."""
    m = {"R": 0.8, "Delta": 0.1, "Delta_lower": 0.2, "contact": {"law": "linear", "stiffness": 1e4, "R": 0.3}}
    assert get_value(m, "stops[1].law.R") == 0.8
    assert parameter_paths(m) == ["stops[0].Delta", "stops[0].law.R", "stops[0].law.stiffness",
                                  "stops[1].Delta", "stops[1].law.R", "stops[1].law.stiffness"]
    # a gap given under two keys (not a case vibeam accepts, but a table the resolver may be handed):
    # the first one it gives is named
    two = {"R": 0.8, "Delta": 0.1, "gap_mm": 0.1}
    assert _refused(two, "stops[0].contact_gap_mm").endswith("stop[0] gives its gap as Delta, gap_mm (stops[0].Delta)")


def test_an_empty_stop_list_and_a_name_without_a_dot():
    with pytest.raises(ValueError) as e:
        get_value({"stop": []}, "stops[0].law.R")
    assert "the scene has 0 stop(s)" in str(e.value) and "stops[-1]" not in str(e.value)
    assert key_of("stops") == "stops" and key_of("system.") == ""
