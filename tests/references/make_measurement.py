"""Write ``cases/measured/rig-neutral-frc.csv``: a measurement-like FRC for the fit example.

It is synthetic, and says so in its header: the rig's SDOF model (paper Eqs. 43-47) at the
neutral gap with a *true* gain and R that differ from ``cases/rig-neutral.toml``'s, simulated by an
independent code (scipy ``solve_ivp`` with an impact event and Newton's law, no vibeam kernel),
swept up and then down as the rig was (each frequency starts from the previous one's final
state, 400 transient periods), its amplitude Q L_S (Q = Delta - min q, paper Sec. 4.1) taken from
the dense output over 16 periods, plus Gaussian noise of standard deviation ``SIGMA_MM``
(seeded).  Before writing, the noise-free amplitudes are checked against vibeam's event solver
at the same parameters (agreement to 1e-6 relative, the solve_ivp tolerance), so the file's
truth is known to that accuracy.

Run from the repository root: ``python tests/references/make_measurement.py``.
"""
from __future__ import annotations

import io
from pathlib import Path

import numpy as np
from scipy.integrate import solve_ivp
from scipy.optimize import brentq, minimize_scalar

ROOT = Path(__file__).resolve().parents[2]
OUT = ROOT / "cases" / "measured" / "rig-neutral-frc.csv"

#: the true parameters of the synthetic rig (the case file has gain 5.16e-4, R 0.72)
TRUE = dict(gain=5.40e-4, R=0.68)
FN_HZ, ZETA, GAP_MM, L_MM, VOLT = 7.6, 0.017, 0.0, 180.0, 0.6
FREQS_HZ = np.linspace(14.0, 17.0, 25)
SIGMA_MM = 0.005
SEED = 20261123
TRANSIENT, RECORD = 400, 16
V_STICK = 1e-9   # nondimensional impact velocity below which a chatter sequence has ended


def rhs(t, y, Om, B, beta):
    return [y[1], Om * Om * B * np.sin(Om * t) - 2 * beta * y[1] - y[0]]


def hit(t, y, Om, B, beta):
    return y[0] - GAP_MM / L_MM


hit.terminal, hit.direction = True, 1


def advance(y, t0, t1, Om, B, beta, R, dense=False):
    """From (t0, y) to t1 with impacts q' -> -R q' at q = Delta; returns y(t1) and min q.

    An impact slower than ``V_STICK`` ends a chatter sequence: the mass is held on the stop
    (q = Delta, q' = 0) until the contact force changes sign, i.e. until Omega^2 B sin(Omega t)
    - Delta falls below zero (found by brentq on that closed form), as in the standard
    treatment of complete chatter (Budd & Dux 1994)."""
    delta = GAP_MM / L_MM
    qmin, t = np.inf, t0
    while t < t1:
        sol = solve_ivp(rhs, (t, t1), y, method="DOP853", rtol=1e-12, atol=1e-14, events=hit,
                        args=(Om, B, beta), dense_output=dense)
        if dense:
            tt = np.linspace(sol.t[0], sol.t[-1], max(8, int(64 * (sol.t[-1] - sol.t[0]) * Om / (2 * np.pi))))
            qs = sol.sol(tt)[0]
            i = int(np.argmin(qs))
            lo, hi = tt[max(i - 1, 0)], tt[min(i + 1, tt.size - 1)]
            if hi > lo:      # the exact minimum of the dense output between the neighbouring samples
                m = minimize_scalar(lambda s: sol.sol(s)[0], bounds=(lo, hi), method="bounded",
                                    options=dict(xatol=1e-13))
                qmin = min(qmin, float(qs[i]), float(m.fun))
            else:
                qmin = min(qmin, float(qs[i]))
        y, t = sol.y[:, -1].copy(), float(sol.t[-1])
        if sol.status != 1:
            break
        if y[1] > V_STICK:             # impact: Newton's law
            y[1] = -R * y[1]
            continue
        push = lambda s: Om * Om * B * np.sin(Om * s) - delta   # contact force while held
        if push(t) <= 0:               # pulls away already: leave with zero velocity
            y = np.array([delta, 0.0])
            continue
        s, step = t, np.pi / (8 * Om)   # first sign change of the force after t
        while push(s + step) > 0:
            s += step
        t_out = brentq(push, s, s + step, xtol=1e-14)
        y, t = np.array([delta, 0.0]), min(t_out, t1)
    return y, qmin


def sweep(freqs_hz, gain, R):
    beta, B = ZETA, gain * VOLT
    y, out = np.array([-1e-3, 0.0]), []
    for f in freqs_hz:
        Om = f / FN_HZ
        T = 2 * np.pi / Om
        y, _ = advance(y, 0.0, TRANSIENT * T, Om, B, beta, R)
        y, qmin = advance(y, TRANSIENT * T, (TRANSIENT + RECORD) * T, Om, B, beta, R, dense=True)
        out.append((GAP_MM / L_MM - qmin) * L_MM)
    return np.array(out)


def vibeam_amplitudes():
    """vibeam's event solver on the same scene and sweep: amplitude_mm of the up and down sweeps."""
    import tomllib

    import vibeam

    case = tomllib.loads((ROOT / "cases" / "rig-neutral.toml").read_text())
    case["model"].update(TRUE)
    case["sweep"].update(frequency_hz=[float(FREQS_HZ[0]), float(FREQS_HZ[-1]), FREQS_HZ.size],
                         transient_periods=TRANSIENT, record_periods=RECORD)
    d = vibeam.run(case, jobs=1)["exact"].data
    out = []
    for direction in ("up", "down"):
        m = np.asarray(d["direction"]) == direction
        order = np.argsort(np.asarray(d["frequency_hz"])[m])
        out.append(np.asarray(d["amplitude_mm"])[m][order])
    return out


def main():
    up = sweep(FREQS_HZ, **TRUE)
    down = sweep(FREQS_HZ[::-1], **TRUE)[::-1]
    v_up, v_down = vibeam_amplitudes()
    err = max(np.max(np.abs(up - v_up) / v_up), np.max(np.abs(down - v_down) / v_down))
    print(f"independent solve_ivp vs vibeam's event solver: largest relative difference {err:.2e}")
    assert err < 1e-6, "the synthetic truth disagrees with vibeam's event solver"
    rng = np.random.default_rng(SEED)
    rows = []
    for d, amps in (("up", up), ("down", down)):
        noisy = amps + rng.normal(0.0, SIGMA_MM, amps.size)
        rows += [(f, a, d) for f, a in zip(FREQS_HZ, noisy)]
    buf = io.StringIO()
    buf.write("# SYNTHETIC measurement-like FRC (not measured): the rig SDOF model of cases/rig-neutral.toml\n"
              f"# with true gain = {TRUE['gain']:g} 1/V and R = {TRUE['R']:g} (the case file: 5.16e-4, 0.72),\n"
              "# simulated by scipy solve_ivp with an impact event (tests/references/make_measurement.py),\n"
              f"# swept up then down, {TRANSIENT} transient periods per frequency, amplitude over {RECORD} "
              "periods,\n"
              f"# plus Gaussian noise sigma = {SIGMA_MM} mm (seed {SEED}).\n")
    buf.write("frequency_hz,amplitude_mm,direction,sigma\n")
    for f, a, d in rows:
        buf.write(f"{f:.6f},{a:.6f},{d},{SIGMA_MM}\n")
    OUT.parent.mkdir(exist_ok=True)
    from vibeam.io.outdir import write_text_file
    write_text_file(OUT, buf.getvalue())
    return up, down


if __name__ == "__main__":
    up, down = main()
    print(f"wrote {OUT}: {2 * FREQS_HZ.size} points, amplitudes {min(up.min(), down.min()):.4f} .. "
          f"{max(up.max(), down.max()):.4f} mm")
