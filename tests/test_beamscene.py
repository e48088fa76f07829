"""Beam scenes: validation, `vibeam derive` (static-mode SDOF, Eqs. 42-46) and `vibeam modes`."""
import math
from pathlib import Path

import numpy as np
import pytest

from vibeam.case.beamscene import derive, modes_report, scene_of
from vibeam.case.schema import CaseError, parse_case
from vibeam.cli import main
from vibeam.models.builders.sdof import sdof
from vibeam.models.scene import one_mode, outputs

RIG = """
name = "rig-fe"
[model]
fidelity = "beam"
length_mm = 180.0
sensor_position_mm = 100.0
mass_position_mm = 132.0
EI_n_m2 = 0.38465
rhoA_kg_m = 0.157
mass_kg = 0.2
rotary_inertia_kg_m2 = 2.103e-5
R = 0.72
gap_mm = 0.1
gain = 5.16e-4
voltage = 0.6
damping_ratio = 0.017
n_modes = 2
n_elements = 24
[sweep]
frequency_hz = [14.0, 17.0, 4]
[[run]]
name = "fe"
method = "event"
"""


def test_derive_matches_closed_forms():
    """omega_n^2 = 3 EI / (m L_m^3) (static stiffness at the mass over m); the gap
    at the stop is phi(x_m) times the gap at the sensor, phi(x_m) from the
    cantilever point-load deflection y(x) = x^2 (3 x_m - x) / 6 (x <= x_m),
    y(x) = x_m^2 (3 x - x_m) / 6 (x >= x_m); gamma round-trips (Eq. 46)."""
    spec = parse_case(RIG).model_spec()
    d = derive(spec)
    red, sc = d["reduction"], d["scene"]
    EI, m, Lm, L, Ls = 0.38465, 0.2, 0.132, 0.18, 0.100
    assert red.omega_n_rad_s == pytest.approx(math.sqrt(3 * EI / (m * Lm**3)), rel=1e-12)
    xm, xs = Lm / L, Ls / L
    phim = (xm**3 / 3) / (xs**2 * (3 * xm - xs) / 6)
    assert red.phi_at_mass == pytest.approx(phim, rel=1e-12)
    assert sc.Delta_C_m == pytest.approx(phim * 0.1e-3, rel=1e-12)
    assert red.Delta == pytest.approx(0.1e-3 / L, rel=1e-12)
    assert red.gamma_per_V == pytest.approx(5.16e-4, rel=1e-12)
    # beta_S = D omega_n / 2 with D = 2 beta_1 / omega_1 (FE)
    assert red.beta_S == pytest.approx(0.017 * red.omega_n_rad_s / (2 * math.pi * sc.f1_hz), rel=1e-12)
    # the static mode neglects the beam mass: its frequency is above the FE one,
    # and adding the beam's modal mass brings it within 1 %
    assert red.f_n_hz > sc.f1_hz
    assert abs(d["with_beam_mass"].f_n_hz / sc.f1_hz - 1) < 0.01


def test_derive_write_emits_a_valid_sdof_case(tmp_path):
    path = tmp_path / "rig.toml"
    path.write_text(RIG)
    out = tmp_path / "sdof.toml"
    assert main(["derive", str(path), "--write", str(out)]) == 0
    case = parse_case(out.read_text(), str(out))
    sc = case.model_spec().scene()
    red = derive(parse_case(RIG).model_spec())["reduction"]
    assert outputs(sc).natural_frequency_hz == pytest.approx(red.f_n_hz, rel=1e-9)
    assert one_mode(sc).Delta == pytest.approx(red.Delta, rel=1e-9)
    assert one_mode(sc).B == pytest.approx(red.gamma_per_V * 0.6, rel=1e-9)


def test_calibration_in_a_case_reaches_the_targets():
    spec = parse_case(RIG.replace("n_elements = 24", "n_elements = 24\n[model.calibrate]\nf1_hz = 7.6\nf2_hz = 98.75")
                      ).model_spec()
    sc = scene_of(spec)
    assert sc.calibration is not None
    assert sc.calibration.frequencies_hz[:2] == pytest.approx([7.6, 98.75], rel=1e-8)
    assert sc.f1_hz == pytest.approx(7.6, rel=1e-8)


def test_modes_effective_masses_and_contact_modes(tmp_path):
    spec = parse_case(RIG).model_spec()
    rep = modes_report(spec, n=6)
    md, cm = rep["modes"], rep["contact"]
    # effective masses are positive and never exceed the total mass
    assert np.all(md.effective_mass_kg > 0)
    assert md.effective_mass_kg.sum() < rep["total_mass_kg"]
    # holding the beam at the stop removes the first mode: contact modes interlace
    assert np.all(cm.frequencies_hz[:4] > md.frequencies_hz[:4])
    assert np.all(cm.frequencies_hz[:4] < md.frequencies_hz[1:5])
    path = tmp_path / "rig.toml"
    path.write_text(RIG)
    assert main(["modes", str(path), "--out", str(tmp_path), "-n", "4"]) == 0
    assert (tmp_path / "modes.vtu").exists() and (tmp_path / "modes.png").exists()


@pytest.mark.parametrize("old,new,needle", [
    ("mass_kg = 0.2\n", "", "mass_kg or as a [model.discs]"),
    ("gap_mm = 0.1", "gap_mm = 0.1\ncontact_gap_mm = 0.1", "exactly one of gap_mm"),
    ("mass_position_mm = 132.0", "mass_position_mm = 232.0", "beyond length_mm"),
    ("n_modes = 2", "n_modes = \"some\"", "model.n_modes"),
    ("n_elements = 24", "n_elements = 24\n[model.discs]\ncount = 4\nthick_mm = 7", "unknown key 'model.discs.thick_mm'"),
])
def test_bad_beam_case(old, new, needle):
    with pytest.raises(CaseError) as e:
        parse_case(RIG.replace(old, new), "b.toml")
    assert needle in str(e.value), str(e.value)


def test_derive_on_an_sdof_case_is_a_clear_error(tmp_path, capsys):
    p = Path(__file__).parent.parent / "cases" / "paper-fig7.toml"
    assert main(["derive", str(p)]) == 2
    assert "needs a beam scene" in capsys.readouterr().err


def test_beam_case_runs_the_fidelity_ladder_and_costs_it(tmp_path):
    """`vibeam run` and `vibeam cost` on a small beam scene: static mode, 1 and 2 modes.

    The static-mode run is the paper's SDOF model (Eqs. 42-47): its FRC must equal
    the SDOF event solver's on the derived parameters (beam mass excluded) to 1e-9.
    """
    from vibeam.case.schema import parse_case as pc
    from vibeam.analysis.cost import run_cost
    from vibeam.models import make_solver
    from vibeam.engine.records import summarize
    from vibeam.io.results import read_results

    text = RIG.replace("[14.0, 17.0, 4]", "[15.0, 16.0, 3]").replace("n_elements = 24", "n_elements = 8") \
        .replace('[[run]]\nname = "fe"\nmethod = "event"\n',
                 '[[run]]\nname = "static"\nmethod = "event"\n[run.model]\nn_modes = "static"\n'
                 '[[run]]\nname = "fe1"\nmethod = "event"\n[run.model]\nn_modes = 1\n'
                 '[[run]]\nname = "fe2"\nmethod = "event"\n[run.model]\nn_modes = 2\n') \
        .replace("[sweep]", "[sweep]\ntransient_periods = 150\nrecord_periods = 8\ncontinuation = false")
    path = tmp_path / "ladder.toml"
    path.write_text(text)
    assert main(["run", str(path), "--out", str(tmp_path), "--jobs", "1", "--quiet", "--no-plots"]) == 0
    r = read_results(tmp_path / "results.h5")
    assert set(r["runs"]) == {"static", "fe1", "fe2"}
    assert all(r["runs"][k]["attrs"]["fidelity"] == "beam" for k in r["runs"])
    assert r["runs"]["fe2"]["mode_amplitudes"].shape == (3, 2)
    assert r["runs"]["fe1"]["attrs"]["EI_n_m2"] == pytest.approx(0.38465)
    assert r["runs"]["fe1"]["attrs"]["f1_fe_hz"] > 0
    # static mode == SDOF model with the derived parameters
    red = derive(pc(text).model_spec())["reduction"]
    sc = scene_of(pc(text).model_spec())
    sd = sdof(red.beta_S, red.gamma_per_V * 0.6, red.Delta, 0.72)
    for i, f in enumerate(r["runs"]["static"]["frequency_hz"]):
        tr = make_solver(sd, "event").point(f / red.f_n_hz, None, 150, 8)
        A = summarize(tr, one_mode(sd).Delta)["amplitude"]
        assert r["runs"]["static"]["amplitude"][i] == pytest.approx(A, rel=1e-9)
    # cost: errors of each rung against the finest FE model (all modes, 2x mesh)
    res = run_cost(pc(text), repeats=1, log=lambda m: None)
    errs = {row.run: row.err_max for row in res["rows"]}
    assert set(errs) == {"static", "fe1", "fe2"}
    assert all(np.isfinite(e) and e > 0 for e in errs.values())
    assert res["claims"] == []


def test_derive_of_a_two_sided_beam_swept_in_omega(tmp_path):
    """`vibeam derive` of a beam with a lower stop and its sweep in Omega = f / f_1 (FE): the lower
    stop's rows by the same static-mode conversion as the upper's (Eq. 45: Delta_C,lower = phi(x_m)
    Delta_G,lower, Delta_lower = Delta_G,lower / L), and the written SDOF case sweeps the same
    frequencies in Hz, f = Omega f_1, to its 6 significant digits (rel 1e-6), the lower gap at the
    sensor to 1e-9."""
    text = RIG.replace("gap_mm = 0.1\n", "gap_mm = 0.1\ngap_lower_mm = 0.25\n").replace(
        "frequency_hz = [14.0, 17.0, 4]", "Omega = [1.7, 2.3, 4]")
    spec = parse_case(text).model_spec()
    d = derive(spec)
    red, sc = d["reduction"], d["scene"]
    rows = {r[0]: r[1] for r in d["rows"]}
    L = 0.18
    assert rows["Delta_C,lower"] == pytest.approx(red.phi_at_mass * 0.25, rel=1e-12)
    assert rows["Delta_G,lower"] == pytest.approx(0.25, rel=1e-12)
    assert rows["Delta_lower"] == pytest.approx(0.25e-3 / L, rel=1e-12)
    path = tmp_path / "two.toml"
    path.write_text(text)
    out = tmp_path / "sdof.toml"
    assert main(["derive", str(path), "--write", str(out)]) == 0
    case = parse_case(out.read_text(), str(out))
    lo, hi, n = case.sweep.frequency_hz
    assert (lo, hi, int(n)) == (pytest.approx(1.7 * sc.f1_hz, rel=1e-6), pytest.approx(2.3 * sc.f1_hz, rel=1e-6), 4)
    assert one_mode(case.model_spec().scene()).Delta_lower == pytest.approx(0.25e-3 / L, rel=1e-9)


def test_each_continuation_key_is_its_paths_value_over_its_factor():
    """conversions (issue 58): for every key of a two-sided beam that moves a stop or the drive, the
    value at its path in the built scene is ``factor * key`` (the chain rule of the continuation
    rests on it): gap_mm and gap_lower_mm times phi(x_m) 1e-3 (Eq. 45), voltage times gain phi(x_m)
    L (Eq. 46 inverted), gain times voltage phi(x_m) L; to 1e-15 (one rounding apart)."""
    spec = parse_case(RIG.replace("gap_mm = 0.1\n", "gap_mm = 0.1\ngap_lower_mm = 0.25\n")).model_spec()
    sc = spec.scene()
    at = {"stops[0].relation.offset": sc.stops[0].relation.offset,
          "stops[1].relation.offset": sc.stops[1].relation.offset,
          "system.base_amplitude": sc.system.base_amplitude}
    for key, value in (("gap_mm", 0.1), ("gap_lower_mm", 0.25), ("voltage", 0.6), ("gain", 5.16e-4)):
        path, factor, damping = spec.scene_parameter(key)
        assert damping is None and factor * value == pytest.approx(at[path], rel=1e-15, abs=0), key


def test_an_eccentric_contact_moves_the_stop_and_the_platform_modes_are_signed():
    """effects_scene: an eccentric contact's stop is at ``gap_mm`` seen at the sensor times its own
    static ratio phi_c = phi(x_m) (1 + 3 e / (2 L_m)) (the scene's contact_static[0] too); a
    coupled platform's modes are signed so that the platform moves with each (platform_row >= 0,
    the record's convention), and the scene's drive is the shaker's force (base amplitude 0)."""
    from vibeam.case.beamscene import contact_factor
    from vibeam.case.schema import EffectsSpec

    spec = parse_case(RIG).model_spec()
    e = 4e-3
    new, coupled = spec.effect_scene(EffectsSpec.model_validate({"eccentric_impact": {"offset_mm": 4.0}}),
                                     spec.scene())
    phic = contact_factor(spec, e)
    assert phic == pytest.approx(scene_of(spec).phi_at_mass * (1 + 1.5 * e / 0.132), rel=1e-15)
    assert coupled is None and new.stops[0].relation.offset == pytest.approx(0.1e-3 * phic, rel=1e-15)
    assert new.system.contact_static[0] == phic
    new, coupled = spec.effect_scene(EffectsSpec.model_validate({"platform": {"level": "coupled", "mass_kg": 3.0}}),
                                     spec.scene())
    assert np.all(coupled.platform_row >= 0) and np.any(coupled.platform_row > 0)
    assert new.system.base_amplitude == 0.0 and coupled.platform_force_n > 0


def test_vibeam_modes_sensor_modal_masses_sum_to_the_flexibility_of_the_sensor():
    """modes_report with every mode: sum_i 1 / m_i of the sensor's modal masses m_i = 1 / (s^T
    phi_i)^2 is s^T M^-1 s (completeness of the mass-normalised modes), to 1e-9 (the eigenvectors'
    orthonormality)."""
    spec = parse_case(RIG).model_spec()
    fe = modes_report(spec, 1)["fe"]
    r = modes_report(spec, fe.ndof)
    s = fe.sensor_row
    assert np.sum(1.0 / r["sensor_modal_mass_kg"]) == pytest.approx(s @ np.linalg.solve(fe.M, s), rel=1e-9)
