"""Assessments: spectra (non-harmonic peaks), modal participation, time series, no extra work."""
import math

import h5py
import numpy as np
import pytest

from vibeam.engine import assess
from vibeam.case.schema import parse_case

F = 15.0          # forcing (Hz)
N_REC, SPP = 64, 64


def _periodic_record(extra_hz=None, extra_amp_mm_s=0.0):
    """Sensor (x mm, v mm/s) of a periodic impact-like orbit: many harmonics of F, plus an
    optional sinusoid of the velocity at ``extra_hz``."""
    fs = F * SPP
    t = np.arange(N_REC * SPP) / fs
    ph = 2 * math.pi * F * t
    v = 30 * np.cos(ph) + sum(8 / k * np.sin(k * ph + 0.3 * k) for k in range(2, 12))
    x = 30 / (2 * math.pi * F) * np.sin(ph)
    if extra_hz:
        w = 2 * math.pi * extra_hz
        v = v + extra_amp_mm_s * np.cos(w * t)
        x = x + extra_amp_mm_s / w * np.sin(w * t)
    return x, v, fs


def test_harmonics_are_not_peaks_but_an_injected_103_hz_line_is():
    x, v, fs = _periodic_record()
    f, px, pv = assess.nonharmonic_peaks(x, v, fs, F)
    assert np.isnan(f).all()                   # a periodic record has only harmonics
    x, v, fs = _periodic_record(103.0, 2.0)
    f, px, pv = assess.nonharmonic_peaks(x, v, fs, F)
    df = F / N_REC
    assert f[0] == pytest.approx(103.0, abs=0.1 * df)
    # Hann window with the kernel interpolation: amplitude to ~1 % off-bin
    assert pv[0] == pytest.approx(2.0, rel=0.02)
    assert px[0] == pytest.approx(2.0 / (2 * math.pi * 103.0), rel=0.02)
    assert np.isnan(f[1:]).all()


def test_subharmonics_are_not_peaks():
    x, v, fs = _periodic_record()
    t = np.arange(x.size) / fs
    v2 = v + 3.0 * np.cos(2 * math.pi * F * 3.5 * t)     # 7/2 F: a period-2 line
    f, _, _ = assess.nonharmonic_peaks(x, v2, fs, F)
    assert np.isnan(f).all()
    f, _, _ = assess.nonharmonic_peaks(x, v2, fs, F, max_order=1)   # only integer harmonics
    assert f[0] == pytest.approx(3.5 * F, abs=0.05)


def test_mode_assignment():
    idx, fam = assess.assign_modes([103.0, 331.0, 200.0, np.nan], free=np.array([7.6, 98.75, 335.5]),
                                   contact=np.array([97.7, 330.6]), rtol=0.1)
    assert list(idx) == [2, 2, 0, 0] and list(fam) == [1, 2, 0, 0]   # 103: free 98.75 is nearer
    idx, fam = assess.assign_modes([99.0], free=np.array([7.6, 98.75]), contact=np.array([90.0]), rtol=0.1)
    assert idx[0] == 2 and fam[0] == 1


def test_participation_shares_of_sinusoids():
    """Modal states eta_i = A_i sin(Omega t + p_i) sampled uniformly over whole periods: the RMS
    of s_i eta_i is |s_i A_i| / sqrt(2) and the mean of eta_i'^2 + k_i eta_i^2 is
    A_i^2 (Omega^2 + k_i) / 2 exactly (the sample means of sin^2 and cos^2 over a whole number
    of periods with more than 2 samples per period are 1/2), so the shares are known in
    closed form (1e-12)."""
    W, n = 1.3, 8 * 64
    t = np.arange(n) * (2 * math.pi / W) / 64
    A = np.array([1.0, -0.2, 0.03, 0.004])
    p = np.array([0.1, 1.2, -0.7, 2.0])
    s = np.array([1.0, -0.5, 0.3, 0.2])
    k = np.array([1.0, 169.0, 1900.0, 3300.0])
    eta = A * np.sin(W * t[:, None] + p)
    etad = A * W * np.cos(W * t[:, None] + p)
    d, e = assess.participation_shares(np.hstack([eta, etad]), s, k)
    rms = np.abs(s * A) / math.sqrt(2)
    en = A**2 * (W**2 + k) / 2
    np.testing.assert_allclose(d, rms / rms.sum(), rtol=1e-12)
    np.testing.assert_allclose(e, en / en.sum(), rtol=1e-12)


@pytest.mark.slow   # a 24-element beam sweep with spectra (~18 s): slow step
def test_participation_of_a_beam_far_from_the_stop_is_the_modal_frequency_response():
    """Three modes, stop out of reach: after the transient each eta_i is the harmonic response
    Gamma_i F / (k_i - Omega^2 + i c_i Omega) (closed form, independent of the kernel), so the
    hook's shares must be the closed-form shares above with those amplitudes (1e-9: the
    remaining transient after 300 periods is below exp(-c_1 300 T / 2) ~ 1e-14)."""
    from vibeam.models import BeamEventSolver
    from vibeam.models.builders.beam import mass_stops
    from vibeam.models.builders.matrices import modal_scene
    from vibeam.models.contact import Restitution

    w_hz = np.array([7.6, 47.0, 130.0])
    om = 2 * math.pi * w_hz
    m = modal_scene(om, 0.0 + 2 * 0.02 / (2 * math.pi * 7.6) * om ** 2, [0.4, -0.15, 0.05], [2.0, -1.1, 0.7],
                    np.atleast_2d([1.5, 0.8, -0.6]), mass_stops(1.0, Restitution(0.7)), 2e-4, 7.6, 0.18, 1.0, "beam")
    sy = m.system
    W = 1.7
    tr = BeamEventSolver(m, record_modal_states=True).point(W, None, 300, 4, 64)
    assert tr.n_impacts == 0
    out = assess.ParticipationHook(m)(tr)
    F = W**2 * sy.base_amplitude
    H = sy.participation * F / (sy.omega ** 2 - W**2 + 1j * sy.damping * W)
    rms = np.abs(sy.sensor * H) / math.sqrt(2)
    en = np.abs(H) ** 2 * (W**2 + sy.omega ** 2) / 2
    np.testing.assert_allclose(out["participation_displacement"], rms / rms.sum(), rtol=1e-9)
    np.testing.assert_allclose(out["participation_energy"], en / en.sum(), rtol=1e-9)
    assert out["participation_energy"][2] < out["participation_energy"][0]


PLAIN = '''
name = "plain"
[model]
fidelity = "sdof"
natural_frequency_hz = 7.6
damping_ratio = 0.017
R = 0.72
gap_mm = 0.0
length_mm = 180.0
gain = 5.16e-4
voltage = 0.6
[sweep]
frequency_hz = [14.8, 15.2, 3]
transient_periods = 100
record_periods = 8
[[run]]
name = "exact"
method = "event"
'''
EXTRA_KEYS = ("peaks_frequency", "spectrum_velocity", "participation_displacement", "R_identified",
              "time_series", "band_velocity_mm_s")


def test_plain_case_has_no_hooks_and_no_extra_datasets(tmp_path):
    from vibeam.cli import run_case

    case = parse_case(PLAIN)
    spec = case.model_spec()
    sc = spec.scene()
    assert assess.hooks(case, spec, case.run[0], sc) == ()
    assert assess.solver_options(case, case.run[0], spec) == {}
    assert assess.samples_per_period(case, case.run[0], sc, np.array([1.9])) == case.sweep.samples_per_period
    run_case(case, PLAIN, tmp_path, jobs=1, quiet=True, plots=False)
    with h5py.File(tmp_path / "results.h5") as f:
        keys = set(f["runs/exact"].keys())
    assert not keys & set(EXTRA_KEYS)


def test_case_with_assessments_and_sensor(tmp_path, capsys):
    from vibeam.cli import run_case

    text = PLAIN + '''
[effects.sensor]
noise_ladder_mm = [0.0, 0.001]
[assess]
spectra = true
participation = true
time_series = [15.0]
'''
    case = parse_case(text)
    spec = case.model_spec()
    sc = spec.scene()
    # spectra, time series, sensor; participation does not apply to an SDOF scene
    assert len(assess.hooks(case, spec, case.run[0], sc)) == 3
    spp = assess.samples_per_period(case, case.run[0], sc, case.sweep.grid(7.6))
    assert spp >= 2 * 5000 / 14.8
    runs = run_case(case, text, tmp_path, jobs=1, quiet=True, plots=True)
    d = runs[0].data
    assert d["peaks_frequency"].shape == (3, 5) and d["spectrum_velocity"].shape == (3, assess.N_MAP)
    assert "participation_energy" not in d and "participation_displacement" not in d
    notes = [l for l in capsys.readouterr().err.splitlines() if "participation" in l]
    assert len(notes) == 1 and "does not apply to run 'exact'" in notes[0], notes
    assert d["R_identified_ladder"].shape == (3, 2)
    assert np.all(np.abs(d["R_identified"] - 0.72) < 0.03)
    with h5py.File(tmp_path / "results.h5") as f:
        g = f["runs/exact"]
        step = math.ceil(spp / 256)
        n_ts = len(range(0, 8 * spp, step))
        assert g["time_series/15/displacement"].shape == (1, n_ts)       # (direction, time)
        assert g["time_series/15/point_Omega"][0] * 7.6 == pytest.approx(15.0)
        assert "modal_states" not in g
    from vibeam.io.results import read_results
    ts = read_results(tmp_path / "results.h5")["runs"]["exact"]["time_series"]["15"]["up"]
    assert np.array_equal(ts, d["time_series/15/up"]) and ts.shape == (n_ts, 3)
    assert not (tmp_path / "participation.png").exists()   # one mode: nothing to stack
    for name in ("spectra.png", "time_series_15.png", "sensor_R_vs_noise.png",
                 "sensor_R_vs_noise.csv"):
        assert (tmp_path / name).exists(), name
