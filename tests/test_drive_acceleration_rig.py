"""The rig's FE beam in the canonical tables driven by a base acceleration (issue 58, done-when 3:
``cases/rig-fe-acceleration.toml``, ``[model.system] builder = "beam"`` with ``[model.excitation]
kind = "base_acceleration"``).

Checks, each against the same case with the shaker's drive (``gain`` and ``voltage``, the base
displacement ``Y = gamma~ V`` of Eq. 38) in place of its ``[model.excitation]``: the shipped ``a`` is
``(2 pi f0)^2 Y`` at ``f0 = 15.5 Hz`` (its header); at ``f0`` the two drives give the same
impacting orbit (event integrator, 2 modes); away from ``f0``, with the stop out of reach (linear),
the displacement-driven response is the acceleration-driven one times ``(f / f0)^2`` at every
sample, the transient from rest included (both start at rest, so the response is linear in the
forcing amplitude); with the stop, the impacting orbits differ there.
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from vibeam.case.beamscene import excitation, scene_of
from vibeam.case.schema import load_case, parse_case
from vibeam.errors import CaseError
from vibeam.models import make_solver

CASE = Path(__file__).resolve().parents[1] / "cases" / "rig-fe-acceleration.toml"
F0 = 15.5
ACC = 'kind = "base_acceleration"\namplitude_m_s2 = 0.8214037257202843\n'
SHAKER = 'kind = "base_displacement"\ngain = 5.16e-4\nvoltage = 0.6\n'    # cases/rig-fe-neutral.toml


def _spec(shaker=False, gap_mm=None, n_modes=2):
    text = CASE.read_text()
    assert ACC in text and "gap_mm = 0.0\n" in text
    if shaker:
        text = text.replace(ACC, SHAKER)
    if gap_mm is not None:
        text = text.replace("gap_mm = 0.0\n", f"gap_mm = {gap_mm!r}\n")
    return parse_case(text).model_spec({"n_modes": n_modes})


def _model(shaker=False, gap_mm=None, n_modes=2):
    return _spec(shaker, gap_mm, n_modes).scene()


def _point(model, f_hz, n_transient=60, n_record=4):
    return make_solver(model, "event").point(f_hz / model.system.reference_hz, None, n_transient, n_record, 64)


def test_the_shipped_acceleration_is_the_shaker_drive_at_f0():
    """``a = (2 pi f0)^2 gamma~ V`` (the header's numbers; 1e-15 relative: the case holds ``a`` to
    16 digits), and the two models differ in their drive only (participation, modes)."""
    acc_spec, disp_spec = _spec(), _spec(shaker=True)
    acc, disp = acc_spec.scene(), disp_spec.scene()
    Y = disp.system.base_amplitude
    assert Y == pytest.approx(8.6603e-5, rel=1e-4)
    # the SI drive and shaker amplitude the builder is given (a scene holds the drive in system units)
    assert excitation(acc_spec).amplitude == pytest.approx((2 * math.pi * F0) ** 2 * Y, rel=1e-15)
    assert scene_of(acc_spec).base_amplitude_m == 0.0 and excitation(disp_spec) is None
    sa, sd = acc.system, disp.system
    assert (sa.drive_power, sd.drive_power) == (0, 2)
    np.testing.assert_array_equal(sa.participation, sd.participation)
    np.testing.assert_array_equal(sa.omega, sd.omega)


def test_at_f0_the_acceleration_drive_is_the_displacement_drive():
    """At 15.5 Hz the forcing ``F = A`` equals ``Omega^2 Y`` to the rounding of ``a`` and the units,
    so the impacting orbit (neutral gap: an impact every period) is the same to round-off, amplified
    by the impact map's conditioning: 1e-12 of the orbit's range (as tests/test_drives.py)."""
    ta, td = _point(_model(), F0), _point(_model(shaker=True), F0)
    assert ta.status == td.status == "ok" and ta.n_impacts == td.n_impacts > 0
    scale = float(np.ptp(td.samples))
    assert np.max(np.abs(ta.samples - td.samples)) < 1e-12 * scale


@pytest.mark.parametrize("f_hz", [14.0, 17.0])
def test_away_from_f0_the_linear_response_scales_as_f_over_f0_squared(f_hz):
    """The stop 10 mm away (never reached: the linear beam, ~0.3 mm peak to peak): from rest, the
    shaker's response is the held acceleration's times ``(f / f0)^2`` at every sample (linear in the
    forcing amplitude; 1e-12 of the range: round-off of the exact flow over 64 periods, measured
    2e-16 and 4e-16; at f0 above, 2.7e-15).
    With the stop at its neutral gap the two impacting orbits differ by far more (the drives
    differ by 23 % at 14 Hz, 17 % at 17 Hz)."""
    ta, td = _point(_model(gap_mm=10.0), f_hz), _point(_model(shaker=True, gap_mm=10.0), f_hz)
    assert ta.n_impacts == td.n_impacts == 0
    ratio = (f_hz / F0) ** 2
    scale = float(np.ptp(td.samples))
    assert scale > 0
    assert np.max(np.abs(td.samples - ratio * ta.samples)) < 1e-12 * scale
    ia, idp = _point(_model(), f_hz), _point(_model(shaker=True), f_hz)
    assert ia.n_impacts > 0 and idp.n_impacts > 0
    assert np.max(np.abs(ia.samples - idp.samples)) > 1e-3 * float(np.ptp(idp.samples))


def test_the_beam_refuses_an_excitation_it_cannot_take():
    """A point force on the beam scene (no DOF names there) and a shaker drive given by kind only
    are refused in one line naming what is allowed."""
    text = CASE.read_text()
    for bad in ('kind = "force"\namplitude_n = 1.0\nat = "m1"\n', 'kind = "base_displacement"\namplitude_mm = 0.1\n'):
        with pytest.raises(CaseError, match="base acceleration"):
            parse_case(text.replace(ACC, bad))


def test_the_shipped_case_loads():
    case, _ = load_case(CASE)
    spec = case.model_spec()
    assert spec.drive == ("base_acceleration", 0.8214037257202843)


def test_derive_shows_the_held_acceleration_and_refuses_to_write_a_gamma_v_sdof(tmp_path, capsys):
    """``vibeam derive`` of the acceleration-driven beam: the static-mode numbers of the same beam
    (``f_n`` as rig-fe-neutral's, to round-off), the drive as ``a`` (not ``gamma = B = 0``, which
    read as an undriven SDOF), and ``--write`` refused in one line (the SDOF scene's drive is
    ``gamma V``, Eq. 43), exit 2, nothing written."""
    from vibeam.api import derive
    from vibeam.cli import main

    acc = derive(str(CASE))
    rows = {r[0]: r[1] for r in acc.rows}
    neutral = {r[0]: r[1] for r in derive(str(CASE.parent / "rig-fe-neutral.toml")).rows}
    assert rows["f_n"] == pytest.approx(neutral["f_n"], rel=1e-12)
    assert rows["a"] == 0.8214037257202843 and not {"gamma", "gamma~", "B"} & set(rows)
    assert acc.sdof_case_text == ""
    out = tmp_path / "sdof.toml"
    capsys.readouterr()
    assert main(["derive", str(CASE), "--write", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "'model.excitation.kind' = 'base_acceleration'" in err[0] and "allowed" in err[0]
    assert not out.exists()
