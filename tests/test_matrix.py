"""The cell matrix of issue 20: fidelity x contact law x stops x method.

Every cell is a case (a dict, as ``tomllib`` reads a case file) that a user could write:

* fidelity ``sdof`` (the nondimensional scene of ``tests/test_energy_balance.py``: beta = 0.015,
  B = 5e-3, R = 0.8, Delta = 0.002, a lower stop at Delta_lower = 0.003) or ``beam`` (the rig
  FE beam of ``cases/rig-fe-neutral.toml`` with 2 modes, a lower stop 0.3 mm below);
* law of the upper stop ``restitution``, ``linear`` (Kelvin-Voigt), ``hunt_crossley`` or
  ``lankarani_nikravesh`` (the hysteretic-Hertz family: one class and one registry line, issue 20);
* stops ``one``, ``two`` (the lower stop with the same law, its own stiffness), ``mixed``
  (the lower stop with another kind of law: Newton beside a compliant stop, or Kelvin-Voigt
  below a Newton one) or ``point`` (the stop at the attached mass and a Newton stop 0.6 mm below
  the beam's tip, both as ``[[model.stop]]`` tables: stops anywhere);
* method ``event``, ``direct``, ``mapping``, ``averaging`` or ``continuation``.

A cell either works or is refused at validation in one line naming the key and what is
allowed (``vibeam.case.schema.CaseError``).  :data:`WORKING` lists the cells that work: a cell that
starts or stops working must be added or removed here, so the count in the README's
"Architecture" section stays true.  The second test runs every working row through each of its
time-domain methods and checks them against each other (``event``, the exact kernels, against
``direct``, solve_ivp with events, sharing no code); the third every row with ``mapping`` against
``event`` (the mapping's orbit is the settled event orbit); the last builds each SDOF row again as
a one-mode beam and asks for the same trajectory (issue 20: one-mode beam = SDOF to 1e-10).
"""
from __future__ import annotations

import copy
import itertools
import tomllib
from pathlib import Path

import numpy as np
import pytest

import vibeam
from vibeam.errors import CaseError
from vibeam.models.scene import Scene, one_mode, outputs

ROOT = Path(__file__).resolve().parents[1]
FIDELITIES = ("sdof", "beam")
LAWS = ("restitution", "linear", "hunt_crossley", "lankarani_nikravesh")
STOPS = ("one", "two", "mixed", "point")
METHODS = ("event", "direct", "mapping", "averaging", "continuation")
CELLS = list(itertools.product(FIDELITIES, LAWS, STOPS, METHODS))


def built(fid: str, law: str, stops: str, methods) -> Scene:
    """The row's scene (its builder's: the SDOF's, the beam's; issue 58: no class)."""
    spec = vibeam.load_case(case_of(fid, law, stops, methods)).model_spec()
    return spec.scene()


def stops_of(model: Scene) -> tuple:
    """The (relation, law) pairs of a scene."""
    return tuple(model.stops)


def gap_of(model: Scene) -> float:
    """The reference gap of the results (a scene's :func:`outputs`)."""
    return outputs(model).Delta


def _cells(spec: str) -> set:
    """``"sdof restitution one: event direct"`` lines -> a set of cells."""
    out = set()
    for line in spec.strip().splitlines():
        head, methods = line.split(":")
        fid, law, stops = head.split()
        out.update((fid, law, stops, m) for m in methods.split())
    return out


#: the cells that work (measured 2026-11-23: 43 of the 90; with lankarani_nikravesh 56 of the 120: its
#: cells are Hunt-Crossley's, with no source change but its class and registry line; with the stops
#: ``point`` 59 of the 160: Newton stops anywhere on the beam through the one integrator, direct
#: solver and shooting problem; 64 with the compliant laws on the one shooting problem: two Hertz-type
#: SDOF stops and a compliant stop beside a Newton one continue; 66 with the one direct solver for every
#: law: the beam's two Hertz-type stops; 69 with a Newton upper stop above a Kelvin-Voigt lower one on
#: the SDOF; 90 with the beam's stops carrying their own laws: a Newton stop beside a compliant one at
#: the mass, either above, and a compliant stop at the mass beside Newton stops elsewhere on the beam;
#: 97 with the one pointwise mapping: the SDOF's two compliant stops and mixed stops; 113 with the SDOF's
#: point rows as [[model.stop]] tables, a Newton stop of its own R below the mass; 121 with the N-mode
#: pointwise mapping, vibeam.models.mapping.modal: the beam's Newton and Kelvin-Voigt stops at the mass
#: and elsewhere)
WORKING = _cells("""
sdof restitution one: event direct mapping averaging continuation
sdof restitution two: event direct mapping continuation
sdof restitution mixed: event direct mapping continuation
sdof linear one: event direct mapping continuation
sdof linear two: event direct mapping continuation
sdof linear mixed: event direct mapping continuation
sdof hunt_crossley one: event direct mapping continuation
sdof hunt_crossley two: event direct mapping continuation
sdof hunt_crossley mixed: event direct mapping continuation
beam restitution one: event direct mapping continuation
beam restitution two: event direct mapping continuation
beam linear one: event direct mapping continuation
beam linear two: event direct mapping continuation
beam hunt_crossley one: event direct continuation
beam hunt_crossley two: event direct continuation
sdof lankarani_nikravesh one: event direct mapping continuation
sdof lankarani_nikravesh two: event direct mapping continuation
sdof lankarani_nikravesh mixed: event direct mapping continuation
beam lankarani_nikravesh one: event direct continuation
beam lankarani_nikravesh two: event direct continuation
beam restitution point: event direct mapping continuation
beam restitution mixed: event direct mapping continuation
beam linear mixed: event direct mapping continuation
beam hunt_crossley mixed: event direct continuation
beam lankarani_nikravesh mixed: event direct continuation
beam linear point: event direct mapping continuation
beam hunt_crossley point: event direct continuation
beam lankarani_nikravesh point: event direct continuation
sdof restitution point: event direct mapping continuation
sdof linear point: event direct mapping continuation
sdof hunt_crossley point: event direct mapping continuation
sdof lankarani_nikravesh point: event direct mapping continuation
""")

BEAM_MODEL = tomllib.loads((ROOT / "cases" / "rig-fe-neutral.toml").read_text())["model"]


def _law(fid: str, law: str, lower: bool = False):
    """The ``[model.contact]`` (or ``contact_lower``) table of a law; None for the upper stop's
    restitution (``[model] R``)."""
    if law == "restitution":
        return {"law": "restitution", "R": 0.5} if lower else None
    if fid == "sdof":
        return {"law": law, "stiffness": {"linear": 1e4, "hunt_crossley": 1e5, "lankarani_nikravesh": 1e5}[law]
                * (0.3 if lower else 1.0)}
    return {"law": law, "stiffness_n_m": {"linear": 1e5, "hunt_crossley": 1e8, "lankarani_nikravesh": 1e8}[law]
            * (3.0 if lower else 1.0)}


def case_of(fid: str, law: str, stops: str, methods) -> dict:
    """The case of a row of the matrix with one run per method."""
    if fid == "sdof":
        model = {"fidelity": "sdof", "beta": 0.015, "B": 5e-3, "R": 0.8, "Delta": 0.002}
        sweep = {"Omega": [0.75, 0.8, 2], "transient_periods": 20, "record_periods": 4}
        lower = ("Delta_lower", 0.003)
    else:
        model = copy.deepcopy(BEAM_MODEL)
        model["n_modes"] = 2
        sweep = {"frequency_hz": [15.0, 15.5, 2], "transient_periods": 20, "record_periods": 4}
        lower = ("gap_lower_mm", 0.3)
    up = _law(fid, law)
    if stops == "point":
        # every stop a [[model.stop]] table: the upper one at the mass with the law, a Newton stop of
        # its own R below the tip (the SDOF, one point: below the mass, at Delta_lower)
        first = {"side": "upper", "R": model.pop("R"),
                 **({"Delta": model.pop("Delta")} if fid == "sdof" else {"gap_mm": model.pop("gap_mm")})}
        first.update({k: v for k, v in (up or {}).items() if k != "R"})
        second = {"side": "lower", "Delta": lower[1]} if fid == "sdof" else \
            {"side": "lower", "position_mm": 180.0, "contact_gap_mm": 0.6}
        model["stop"] = [first, {**second, "R": 0.9}]
    elif up is not None:
        model["contact"] = up
    if stops not in ("one", "point"):
        model[lower[0]] = lower[1]
        if stops == "mixed":
            model["contact_lower"] = _law(fid, "restitution" if law != "restitution" else "linear", lower=True)
        elif law != "restitution":
            model["contact_lower"] = _law(fid, law, lower=True)
    extra = {"continuation": {"parameter": "Omega"},
             "direct": {"solver": "DOP853", "rtol": 1e-10, "atol": 1e-13}}   # not the paper's RK23 at 1e-4
    runs = [{"name": m, "method": m} | extra.get(m, {}) for m in methods]
    return {"name": f"matrix-{fid}-{law}-{stops}", "model": model, "sweep": sweep, "run": runs}


def test_the_matrix_accepts_exactly_the_working_cells_and_refuses_the_others_in_one_line():
    """Each of the 160 cells validated on its own: a working cell loads, every other one is
    refused with one line naming the key (``run[0].method`` or the model's contact tables)
    and what is allowed."""
    accepted, wrong = set(), []
    for cell in CELLS:
        fid, law, stops, method = cell
        try:
            vibeam.load_case(case_of(fid, law, stops, [method]))
            accepted.add(cell)
        except CaseError as e:
            msg = str(e)
            if "\n" in msg or not ("'run[0].method'" in msg or "'model'" in msg) or "allowed" not in msg and \
                    "not implemented" not in msg:
                wrong.append((cell, msg))
    assert not wrong, wrong
    assert accepted == WORKING, (sorted(accepted - WORKING), sorted(WORKING - accepted))
    # 43 before lankarani_nikravesh (13 cells of its own), 3 with a stop away from the mass, 21 with the
    # beam's mixed stops and compliant stops beside point stops, 7 with the one pointwise mapping (the
    # SDOF's two compliant stops and mixed stops)
    # 16 with the SDOF's [[model.stop]] rows (the point row of the SDOF: a Newton stop of its own R
    # below the mass; they were refused only because the row put it at position_mm, a beam key)
    # 8 with the N-mode pointwise mapping (the beam's Newton and Kelvin-Voigt rows)
    assert len(WORKING) == 121


def _stop_law_keys(fid: str, law: str, stops: str) -> tuple:
    """``(upper, lower)`` registry law keys of a row's stops at the attached mass (case_of)."""
    from vibeam.models.registry import law_key

    up = law_key(law)
    if stops == "one" or (stops == "point" and fid == "beam"):     # the beam's point stop: elsewhere
        return up, None
    if stops == "two":
        return up, up
    if stops == "mixed":
        return up, law_key("linear" if law == "restitution" else "restitution")
    return up, law_key("restitution")          # the SDOF's point row: a Newton stop below the mass


def test_the_working_cells_are_what_the_one_capability_function_says():
    """Issue 43, capabilities derived: the registry's one function
    (:func:`vibeam.models.registry.supported_methods`) from the laws and number of the stops at
    the mass gives exactly the working cells, without a case or a model (the README's count)."""
    from vibeam.models.registry import supported_methods

    derived = {(f, law, st, m) for f, law, st, m in CELLS
               if m in supported_methods(f, *_stop_law_keys(f, law, st))}
    assert derived == WORKING, (sorted(derived - WORKING), sorted(WORKING - derived))
    assert len(derived) == 121


def test_a_method_that_does_not_serve_the_lower_stops_law_is_refused_at_load():
    """A Newton stop above a Hertz-type lower stop on the beam: the N-mode mapping passes Newton and
    Kelvin-Voigt stops only, so the case is refused when it loads, in one line naming the lower
    law (it was accepted and failed when the solver was built: the mixed-stop check did not ask
    for the lower stop's family); the same scene is served by event."""
    d = case_of("beam", "restitution", "mixed", ["mapping"])
    d["model"]["contact_lower"] = {"law": "hunt_crossley", "stiffness_n_m": 3e8}
    with pytest.raises(CaseError) as e:
        vibeam.load_case(d)
    msg = str(e.value)
    assert "\n" not in msg and "'run[0].method' = 'mapping'" in msg and 'contact_lower.law = "hunt_crossley"' in msg
    assert "allowed with two stops: event, direct, continuation" in msg, msg
    d["run"] = [{"name": "event", "method": "event"}]
    vibeam.load_case(d)


@pytest.mark.parametrize("row", sorted({c[:3] for c in WORKING if c[3] == "event"}), ids="-".join)
def test_every_working_row_agrees_across_its_time_domain_methods(row):
    """Each row that has both ``event`` and ``direct`` from rest over 2 forcing periods at the
    sweep's first frequency: the sampled displacement of the two methods (no shared code but the
    model) agrees to 1e-7 of its largest value (``direct`` here is DOP853 at rtol 1e-10 with
    its events, the event kernels exact to ~1e-12 or their contact phase's DOPRI5 at 1e-11;
    measured 1.9e-11 ... 7.0e-11 for the beam rows, 1.1e-10 ... 2.6e-9 for the SDOF ones, the
    largest with Hunt-Crossley stops; the beam's two Hertz-type stops, direct since the one direct
    solver, pass at this tolerance too; the beam's mixed and compliant point rows 6.9e-11 ...
    1.1e-9).  Every stop of the row is hit in these 2 periods (the point rows' tip stop sits 0.6 mm
    below the tip for that: at 1.2 mm it was not reached, so nothing checked it).  A row with
    ``event`` only would be checked for finite samples and contacts here (none is left; each
    law's energy balance per stop is in ``tests/test_energy_balance.py``)."""
    fid, law, stops = row
    methods = [m for m in ("event", "direct") if (fid, law, stops, m) in WORKING]
    case = vibeam.load_case(case_of(fid, law, stops, methods))
    kw = {"Omega": 0.75} if fid == "sdof" else {"frequency_hz": 15.0}
    sims = [vibeam.simulate(case, run=m, periods=2, transient=0, **kw) for m in methods]
    for s in sims:
        assert np.all(np.isfinite(s.q)) and s.summary["status"] in ("ok", "unsettled", "chatter", "sticking")
    assert sims[0].impact_times.size >= 1      # the row's stops are hit, each of them
    stops_hit = sims[0].trajectory.impact_stops
    assert (1 if stops_hit is None else len(set(stops_hit.tolist()))) == (1 if stops == "one" else 2), stops_hit
    if len(sims) == 2:
        a, b = sims
        assert np.max(np.abs(a.q - b.q)) <= 1e-7 * np.max(np.abs(a.q)), (row, np.max(np.abs(a.q - b.q)))


@pytest.mark.parametrize("row", sorted({c[:3] for c in WORKING if c[3] == "mapping"}), ids="-".join)
def test_every_mapping_row_finds_the_event_orbit(row):
    """Each row with ``mapping``: at the sweep's first frequency (Omega = 0.75, where every row's
    event run settles on a period-1 orbit that hits each of its stops; period 2 is allowed) the mapping's
    orbit of that period from rest is the event kernel's, settled over 1500 periods: the same
    sections per period on each stop, and amplitude, q_max, the mean arrival speed and the contact
    records of each stop to 1e-8 relative.  Both compute the same exact flows (Newton's law, the
    Kelvin-Voigt phase) with other code (the mapping: one Newton solve on its sections; the event
    kernel: time stepping with its certified scans), so they agree to round-off there; the
    hysteretic-Hertz contact phase is integrated by both to their tolerances (DOP853 at 1e-12
    against the kernel's Runge-Kutta at 1e-11), so 1e-8 as for one stop (tests/test_hc_mapping.py);
    measured <= 1.6e-13 for the exact rows, <= 1.4e-10 for the Hertz-type ones.  The beam's rows
    (the N-mode map, Newton and Kelvin-Voigt stops, at 17 Hz) agree to <= 1.2e-12 (q_max, a value
    near 0), the rest <= 1e-13; their amplitude, q_max and contact records are the event
    integrator's record of n periods from the map's orbit, so there the check is that the orbit is
    the settled one, and the arrival speeds are the map's own.  A contact record that is NaN for
    the event (a Newton stop's force) is NaN for the mapping too."""
    from vibeam.models import make_solver
    from vibeam.engine.records import summarize

    fid, law, stops = row
    model = built(fid, law, stops, ["mapping"])
    # the beam rows at 17 Hz, where the row 'restitution two' settles on a period-2 orbit hitting both
    # stops (at 15 Hz it is not periodic, below 14 Hz the lower stop is not hit); 'linear two' is not
    # periodic there and at 18 Hz its event record starts inside a lower contact (its last contact
    # is open at the record's end, so the event's mean over the others is not the orbit's): 15.5 Hz
    W = 0.75 if fid == "sdof" else {("linear", "two"): 15.5}.get((law, stops), 17.0) / model.system.reference_hz
    ev = summarize(make_solver(model, "event").point(W, None, 1500, 4, 32), gap_of(model))
    n = ev["period"]
    assert ev["status"] == "ok" and n in (1, 2), (row, ev["status"], n)
    out = make_solver(model, "mapping", n=n).point(W, None, 0, 0)
    assert out["status"] == "ok" and out["period"] == n and out["stable"], (row, out["message"])
    two = stops != "one"
    keys = ["amplitude", "q_max", "impact_velocity", "contact_duration", "contact_force_max", "penetration_max",
            "energy_per_impact"]
    keys += [k + "_lower" for k in keys[2:]] if two else []
    for k in ["impacts_per_period"] + (["impacts_per_period_lower"] if two else []):
        assert out[k] == ev[k], (row, k)
    if "stop_impacts_per_period" in ev:   # stops away from the mass: per stop code (0 upper, 1 lower, 2 + i)
        np.testing.assert_array_equal(out["stop_impacts_per_period"], ev["stop_impacts_per_period"])
        np.testing.assert_allclose(out["stop_impact_velocity"], ev["stop_impact_velocity"], rtol=1e-8)
        from vibeam.models.core.event import stop_codes

        hit = out["stop_impacts_per_period"][stop_codes(model.stops)]
        assert np.all(hit > 0), (row, hit)                                 # every stop of the row is hit
    else:
        assert (out["impacts_per_period_lower"] > 0) if two else True, row     # every stop of the row is hit
    if fid == "beam" and law == "restitution" and stops != "mixed":
        # Liouville: det M = prod R_k^2 exp(-n T sum c_i) (each Newton impact's saltation matrix has
        # det R^2); an oracle of the N-mode map's monodromy (measured <= 2.5e-13, the point row's 14
        # sections in 1 period; bound 1e-9 as the continuation rows')
        R = np.array([st.law.R for st in stops_of(model)])
        k = out["final_state"].reshape(-1, 2 * outputs(model).n_modes + 2)[:, -1].astype(int)
        want = np.prod(R[k] ** 2) * np.exp(-np.sum(model.system.damping) * 2.0 * np.pi * n / W)
        assert abs(out["det_true"] / want - 1.0) <= 1e-9, (row, out["det_true"], want)
    for k in keys:
        if np.isnan(ev[k]):
            assert np.isnan(out[k]), (row, k)
        else:
            assert out[k] == pytest.approx(ev[k], rel=1e-8, abs=1e-300), (row, k, out[k], ev[k])


def _period_one_point(fid, model):
    """A corrected period-1 point of the row's shooting problem (:func:`start_point`, natural
    parameter Omega) from a 600-period event run, at the first of a few forcing frequencies where
    one is found (stable if possible), and the row's event solver."""
    from vibeam.models import make_solver, shooting_problem
    from vibeam.models.orbits.continuation import start_point

    ev = make_solver(model, "event")
    prob = shooting_problem(model, "Omega")
    Ws = [0.75, 0.9, 1.2, 1.6, 2.0] if fid == "sdof" else [f / model.system.reference_hz for f in (15.0, 16.5, 18.0, 13.5)]
    found = None
    for W in Ws:
        tr = ev.point(W, None, 600, 4, 32)
        x0 = np.asarray(tr.final_state[:-1])
        pt, _why = start_point(prob, x0, W, 1, 0.5 * W, 2.0 * W)
        if pt is None:
            continue
        if found is None or np.max(np.abs(pt.mu)) < 0.95:
            found = (W, pt, tr.final_state[-1])
        if np.max(np.abs(pt.mu)) < 0.95:
            break
    return ev, found


@pytest.mark.slow
@pytest.mark.parametrize("row", sorted({c[:3] for c in WORKING if c[3] == "continuation"}), ids="-".join)
def test_every_continuation_row_gives_periodic_orbits_of_the_event_integrator(row):
    """Each row with ``continuation``: the shooting problem's corrected period-1 orbit (from a
    settled event run at one of a few frequencies) is a fixed point of the event integrator's
    one-period map (relative 1e-8 of the state: the shot converges to 1e-10 and one period of the
    map grows an error by at most max|mu| ~ 10), and where it is stable (max|mu| < 0.95) a
    400-period event run from it stays on it to 1e-8 (0.95^400 ~ 1e-9: the transient of the
    shot's residual is gone).  A row where no period-1 orbit is found at these frequencies fails.
    Rows of Newton stops only also check Liouville's formula for det M.
    Measured on the beam rows of mixed and point stops with Hertz-type laws: 1.7e-15 and 2.9e-11."""
    fid, law, stops = row
    model = built(fid, law, stops, ["event"])
    ev, found = _period_one_point(fid, model)
    assert found is not None, row
    W, pt, held = found
    x = pt.x
    scale = np.max(np.abs(x))
    one = ev.point(W, np.concatenate([x, [held]]), 0, 1, 32)
    assert np.max(np.abs(one.final_state[:-1] - x)) <= 1e-8 * scale, (row, W, np.abs(pt.mu).max())
    if np.max(np.abs(pt.mu)) < 0.95:
        long = ev.point(W, np.concatenate([x, [held]]), 400, 4, 32)
        assert np.max(np.abs(long.final_state[:-1] - x)) <= 1e-8 * scale, (row, W)
    if law == "restitution" and stops != "mixed" and pt.shot.stuck_time == 0.0:
        # Liouville: det M = prod R_k^2 exp(-T sum c_i) (each Newton impact's saltation has det
        # R^2; the flow the trace of its state matrix); measured <= 5.8e-12 (the point row's 13
        # impacts), bound 1e-9
        damping = model.system.damping
        R = np.array([st.law.R for st in stops_of(model)])
        hit = np.asarray(pt.shot.extra.get("impact_stops", np.zeros(pt.shot.n_impacts, int)), int)
        want = np.prod(R[hit] ** 2) * np.exp(-np.sum(damping) * 2.0 * np.pi / W)
        assert abs(np.linalg.det(pt.shot.M) / want - 1.0) <= 1e-9, (row, np.linalg.det(pt.shot.M), want)


def _one_mode_beam_of(sd):
    """The SDOF ``sd`` as a one-mode beam of the same ODE, stop by stop: ``f = f_ref`` (k = 1),
    Rayleigh ``alpha = 2 beta omega_ref`` (c = 2 beta), ``w = Gamma = s = 1`` and ``phi(x_m) = L =
    1`` (so ``q = eta``, ``B = Y``, ``Delta = Delta_C``, ``m_eff = 1``); each of its stops keeps its
    side, offset and law, a compliant law's stiffness in N/m^p (``k_c omega_ref^2``: the beam's time
    unit is ``1 / omega_ref``, its modes mass-normalised in kg).  Another builder (the beam's
    packing, :func:`vibeam.models.builders.matrices.modal_scene`, with its stops at the mass,
    :func:`vibeam.models.builders.beam.mass_stops`) and unit conversion than the SDOF's."""
    import dataclasses
    import math

    from vibeam.models.builders.beam import mass_stops
    from vibeam.models.builders.matrices import modal_scene
    from vibeam.models.contact import Restitution

    f = 10.0
    om = 2.0 * math.pi * f

    def si(law):
        return dataclasses.replace(law, stiffness=law.stiffness * om ** 2) if law.kind == "compliant" else law

    up, *rest = sd.stops
    om1 = one_mode(sd)
    lo = rest[0] if rest else None
    newton_pair = lo is not None and up.law.kind == lo.law.kind == "impulsive"
    if up.law.kind == "compliant":
        law, lower = si(up.law), None if lo is None else si(lo.law)
    else:
        law = Restitution(up.law.R)
        lower = Restitution(lo.law.R) if newton_pair else (
            si(lo.law) if lo is not None and lo.law.kind == "compliant" else None)
    alpha = 2.0 * om1.beta * om
    stops = mass_stops(up.relation.offset, law, None if lo is None else lo.relation.offset, lower)
    return modal_scene([om], [alpha + 0.0 * om ** 2], [1.0], [1.0], [[1.0]], stops, om1.B, f, 1.0, 1.0, "beam")


@pytest.mark.parametrize("row", sorted({c[:3] for c in WORKING if c[0] == "sdof" and c[3] == "event"}),
                         ids="-".join)
def test_every_sdof_row_is_its_one_mode_beam(row):
    """Each SDOF row's scene (one, two or mixed stops, every law) built again as a one-mode beam
    (:func:`_one_mode_beam_of`): the same stops and laws in the beam's system, and the beam's event
    solver gives the SDOF's trajectory over 20 + 4 periods at Omega 0.75 and 0.8: samples to 1e-10
    of the orbit, the same impacts (count, stops, times to 1e-10 of the period).  Both run the one
    event integrator, so this checks the beam's model, system builder and unit conversion against
    the SDOF's (issue 20: one-mode beam = SDOF to 1e-10)."""
    from vibeam.models import make_solver

    fid, law, stops = row
    sd = built(fid, law, stops, ["event"])
    beam = _one_mode_beam_of(sd)
    assert [(s.relation.sign, s.law.kind) for s in beam.stops] == [(s.relation.sign, s.law.kind) for s in sd.stops]
    a_sys, b_sys = sd.system, beam.system
    np.testing.assert_allclose(b_sys.damping, a_sys.damping, rtol=1e-14)
    for W in (0.75, 0.8):
        a = make_solver(sd, "event").point(W, None, 20, 4, 32)
        b = make_solver(beam, "event").point(W, None, 20, 4, 32)
        assert a.status == b.status and a.n_impacts == b.n_impacts >= 1, (row, W, a.status, b.status)
        scale = np.max(np.abs(a.samples))
        assert np.max(np.abs(a.samples - b.samples)) <= 1e-10 * scale, (row, W)
        assert np.max(np.abs(a.impact_times - b.impact_times)) <= 1e-10 * 2.0 * np.pi / W, (row, W)
        ka, kb = a.impact_stops, b.impact_stops
        assert (ka is None) == (kb is None) and (ka is None or list(ka) == list(kb)), (row, W)



def _event_core(row):
    """The row's event integrator (:class:`vibeam.models.core.event.EventIntegrator`); its
    ``compliant`` the compliant data it runs on (:class:`vibeam.models.core.phases.Compliant`)."""
    from vibeam.models import make_solver

    model = built(*row, ["event"])
    return make_solver(model, "event")._core


@pytest.mark.parametrize("row, linear, integrated", [
    (("sdof", "linear", "one"), True, False), (("sdof", "linear", "two"), True, False),
    (("sdof", "hunt_crossley", "one"), False, True), (("sdof", "lankarani_nikravesh", "mixed"), False, True),
    # held on the Newton stop, the SDOF has no free coordinate: a Kelvin-Voigt contact then is not a
    # linear phase of pair_modes (the integrator would integrate it), so both kinds stay compiled
    (("sdof", "linear", "mixed"), True, True), (("sdof", "restitution", "mixed"), True, True),
    (("beam", "linear", "mixed"), True, False), (("beam", "linear", "point"), True, False),
    (("beam", "restitution", "mixed"), True, False), (("beam", "hunt_crossley", "two"), False, True),
])
def test_each_row_compiles_the_kinds_of_contact_phase_it_can_reach(row, linear, integrated):
    """A compliant row's event integrator gets the linear phases (``lin``) only if one of its held
    sets and contact sets is a linear phase, and the Runge-Kutta tableau (``itab``) only if one is
    not (:func:`vibeam.models.core.phases.reachable_phases`; numba compiles nothing behind a None).
    The oracle is the phase table itself: every reachable pair, enumerated here again from the stops'
    laws and the held sets, is linear or integrated as ``index`` says.  A kind left out wrongly
    would fail the row's points (``EK_FAIL``), which the agreement test above would catch."""
    from vibeam.models.contact import LAW_RESTITUTION

    core = _event_core(row)
    cp = core.compliant
    assert (cp.lin is not None, cp.itab is not None) == (linear, integrated)
    assert cp.lin is None or cp.lin is cp.ph
    assert cp.itab is None or cp.itab is cp.tab
    law = core.kstops.law
    ns = len(law)
    kinds = set()
    for H in range(1 << ns):
        if core.held.valid[H] and all(law[k] == LAW_RESTITUTION for k in range(ns) if H >> k & 1):
            for C in range(1, 1 << ns):
                if all(law[k] != LAW_RESTITUTION for k in range(ns) if C >> k & 1):
                    kinds.add(bool(cp.ph.index[H, C] >= 0))
    assert kinds == {k for k, on in ((True, linear), (False, integrated)) if on}


def test_the_compiled_entry_of_a_call_tells_the_kinds_of_compliant_data_apart():
    """``compiled_call`` keeps one compiled entry per argument types; two scenes whose compliant
    data differ only in which kinds of phase are None are two specialisations, so they must not
    share an entry (they did at first: the Kelvin-Voigt row's shot ran the Hunt-Crossley row's
    machine code, and the process crashed).  The key tells them apart, nested ones too."""
    from vibeam.models.core.event import _key

    kv, hc, both = (_event_core(("sdof", law, stops)).compliant
                    for law, stops in (("linear", "one"), ("hunt_crossley", "one"), ("linear", "mixed")))
    keys = {_key(kv), _key(hc), _key(both)}
    assert len(keys) == 3
    assert _key((1, kv)) != _key((1, hc)) and _key((1, kv)) == _key((1, kv._replace(vfall=2.0)))
