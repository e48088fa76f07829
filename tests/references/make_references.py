"""Make the reference FRCs in ``tests/references/``: one ``<case name>.h5`` per shipped case.

For every case file in ``cases/`` the reference is the FRC of the case's *quick
variant* (:meth:`vibeam.case.schema.Case.quick_variant`: the same grid, directions and
run names as ``vibeam run --quick``) computed with converged settings:

* every time-domain run (``event``, and the ODE methods ``direct``,
  ``zhuravlev``, ``ivanov``, whose reference is the exact ``event`` solver of
  the same model) uses the exact event-driven solver with 3000 (SDOF) or 1000
  (FE beam) transient periods per point (where the quick variant uses
  ``transient_periods = "auto"``: auto with 4 x its ``max_transient_periods``;
  exceptions in ``REFERENCE_TRANSIENT_OVERRIDE``): the transient decays at least like
  ``exp(-beta t)``, i.e. by ``exp(-0.015 * 3000 * 2 pi / 2.5) < 1e-49`` for the
  SDOF scenes and ``exp(-0.017 * 1000 * 2 pi / 2.3) < 1e-20`` for the beam, so
  wherever the orbit is an attractor the reference holds it to round-off
  (where the motion is not periodic, the reference is one sample of the
  attractor, and regressions compare the spread of its per-period amplitude);
* ``averaging`` and ``mapping`` runs are closed-form/Newton and run as they are;
* ``continuation`` runs are left out: the regression compares FRCs of sweeps (their branches
  are regressed by ``tests/test_continuation*.py`` against the oracles there); a case with
  continuation runs only gets no reference (``BRANCH_REGRESSED`` in ``tests/test_references.py``).

Before a reference is written it is checked against the independent oracles
that apply, and nothing is written if one fails (:func:`check_runs`):

* period-1 one-impact points of SDOF event runs: the fixed point of the impact
  map found by Newton on the closed-form flow (``newton_fixed_point``, started
  from the reference's own impact), admissible, with its exact minimum:
  amplitude to ``1e-8`` relative;
* period-n points (n = 1..8) of SDOF event runs with k impacts per n periods
  (all but the one-impact period-1 points): the fixed point of the k-fold impact map, each impact found by
  the pointwise mapping's ``next_impact`` (the closed-form flight with the certified scans of
  ``vibeam.models.core.signals``, not the event kernel's stepping, impact handling or chatter policy),
  solved by ``scipy.optimize.fsolve`` for ``(phase, velocity)`` with the k flights summing to n
  periods; amplitude from the exact minima of the k flights, ``1e-8`` relative;
* points without impact (``period = -1``): the linear steady state
  ``Delta + C(Omega)`` (``linear_amplitude``; for beam runs the modal sum
  ``linear_sensor_amplitude_m``), ``1e-8`` relative;
* ``R >= 0.99`` near ``Omega = 2`` (``|Omega - 2| <= 0.1``), period 1: averaging
  (Eqs. 18-27), loose: ``3 %`` relative (averaging is first order in the
  stop's influence; measured 0.003 % at ``Omega = 2``);
* beam runs with ``n_modes = "static"``: the SDOF event solver of the derived
  parameters (``vibeam derive``: f_n, beta_S, B = gamma V, Delta; paper
  Eqs. 42-46) on the same frequencies in Hz, ``1e-8`` relative, where both are
  periodic with the same period (elsewhere chaos amplifies round-off); and their
  periodic points against the impact-map oracles above on the derived SDOF;
* FE beam runs (1 to 4 modes; more modes make the ODE stiff for an explicit
  integrator): up to two periodic, impacting points per run against the
  ``direct`` beam solver (``BeamODESolver``, solve_ivp DOP853 with rtol 1e-10,
  terminal contact events, the same impact law), started on the event
  solver's orbit and run 20 + 4 periods: amplitude to ``1e-7`` relative (the
  ODE tolerance; an orbit that is not a solution would drift away);
* parameter maps (``[map]``) are checked line by line, each parameter value
  with its own model, by the oracles above, plus, for SDOF maps on a
  pre-stressed stop, the closed-form lift-off: a point is "held on the stop"
  iff ``Omega^2 B <= |Delta|``.

Runs with an effect that changes the dynamics (every effect but the sensor) and
closed-form runs are not oracle-checked.  The observed errors are printed and
stored in the file's ``/reference`` group (``checks``: one JSON line per oracle
and run).  ``tests/test_references.py`` recomputes the cheap oracles from the
stored data (:func:`check_stored`), so a reference edited by hand or made by a
broken generator fails there.  To keep the files small a reference keeps the
per-point outputs of the README (amplitude and its spread, period, strobe,
...) and drops assessment extras (spectra, sensor identification; listed in
``/reference/dropped_datasets``).  The FE references take several minutes
('FE all modes' chatters on the tight rig).  Usage::

    python tests/references/make_references.py            # every case in cases/
    python tests/references/make_references.py cases/paper-fig7.toml --check-only
"""
from __future__ import annotations

import argparse
import json
import math
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[1]
CASES = ROOT / "cases"
# transient periods of the references: the slowest decay is exp(-beta t) of the first mode, so
# SDOF (beta >= 0.015, Omega <= 2.5): exp(-0.015 * 3000 * 2 pi / 2.5) < 1e-49; beam (beta_1 =
# 0.017, Omega <= 2.3, higher modes damped more by Eq. 39): exp(-0.017 * 1000 * 2 pi / 2.3) < 1e-20
REFERENCE_TRANSIENT = {"sdof": 3000, "beam": 1000, "matrices": 1000, "continuum": 1000, "mesh": 1000}
# matrices (cases/chain-3dof: zeta_1 = 0.02, Omega <= 1.35): exp(-0.02 * 1000 * 2 pi / 1.35) < 1e-40
# mesh (cases/plate-tip-stop: zeta = 0.02 on every mode, Omega <= 130 / 82.8 = 1.57): exp(-0.02 * 1000 * 2 pi / 1.57) < 1e-34
# per-case exceptions: "quick" = the quick variant's own transient.  The pre-stressed FE rig is
# multistable on its down sweep (1.84-1.94 Hz: chaos, period-1, -2 and -6 coexist): a reference with
# more transient periods than the quick run reaches other coexisting attractors there, so its
# reference is the quick run itself (300 periods leave 2e-13 of the transient on its periodic
# points, which the oracles check); regressions then detect changes of the code.
# The rig as a continuum (cases/rig-continuum) with the same pre-stressed stop: chaotic points among its
# periodic ones as well (13-17 Hz), so the same choice.
REFERENCE_TRANSIENT_OVERRIDE: dict[str, int | str] = {"rig-fe-tight": "quick", "rig-tight-uncertainty": "quick",
                                                      "rig-continuum": "quick"}
# quick variants with transient_periods = "auto": the reference runs "auto" too, with this many times
# the quick variant's max_transient_periods (a non-periodic point is accepted after half of it)
REFERENCE_AUTO_FACTOR = 4
TIME_DOMAIN = ("event", "direct", "zhuravlev", "ivanov")
TOL_MAPPING = 1e-8
TOL_LINEAR = 1e-8
TOL_AVERAGING = 0.03
TOL_STATIC = 1e-8
TOL_DIRECT = 1e-7
# two-sided SDOF points against two_sided_ode (DOP853, rtol 1e-12, 2 n periods from the stored
# strobe state): its global error over 2 x 8 periods stays ~1e-11 relative; the stored state is
# within 1e-3 period_rtol = 1e-8 of the orbit where the reference's transient is "auto" (measured:
# amplitudes <= 5e-14, strobe returns <= 2.3e-9 next to the period doubling of paper-fig7-two-sided)
TOL_TWO_SIDED = 1e-8
DIRECT_MAX_MODES = 4      # more modes: stiff for DOP853 (the high modes are overdamped, Eq. 39)
DIRECT_POINTS = 2         # FE points checked against the direct solver per run
SAME_ORBIT = 1e-5         # the event solver from rest on the stored orbit (see _direct_check)
# effects that leave the dynamics alone (the oracles still apply)
PASSIVE_EFFECTS = {"sensor"}
# the per-point outputs a reference keeps (README, "Per-point outputs"); assessment and
# method-specific extras (spectra, sensor records, ...) are left out to keep the files small
KEPT = ("Omega", "amplitude", "amplitude_mean", "amplitude_std", "amplitude_min", "amplitude_max",
        "amplitude_sem", "amplitude_sem_dof", "amplitude_sem_mm", "record_periods", "effective_gain", "transient_periods_used", "q_max", "q_min", "period", "impacts_per_period",
        "impact_velocity", "strobe", "harmonics", "direction", "status", "message", "wall_time_s",
        "stuck_fraction", "frequency_hz", "amplitude_mm", "amplitude_mean_mm", "amplitude_std_mm",
        "amplitude_min_mm", "amplitude_max_mm", "amplitude_lower", "stable", "impacts_per_period_lower",
        "impact_velocity_lower")


MAP_KEPT = ("classification", "values")


def reference_case(case):
    """The converged counterpart of ``case.quick_variant()`` (same grid and run names)."""
    from vibeam.case.schema import Case

    data = case.quick_variant().model_dump()
    fid = case.model_spec().fidelity
    n = REFERENCE_TRANSIENT_OVERRIDE.get(case.name, REFERENCE_TRANSIENT[fid])
    tp = data["sweep"]["transient_periods"]
    if tp == "auto":
        data["sweep"]["max_transient_periods"] *= REFERENCE_AUTO_FACTOR
    elif n != "quick":
        data["sweep"]["transient_periods"] = max(n, int(tp))
    runs = []
    for r in data["run"]:
        if r["method"] == "continuation":
            continue
        if r["method"] in TIME_DOMAIN and r["method"] != "event":
            r = dict(name=r["name"], method="event", model=r["model"], effects=r["effects"])
        runs.append(r)
    data["run"] = runs
    return Case.model_validate(data)


# ----------------------------------------------------------------------------- oracles
class Check:
    """Largest relative error of one oracle on one run."""

    def __init__(self, run, oracle, tol, floor=1e-300):
        self.run, self.oracle, self.tol, self.floor = run, oracle, tol, floor
        self.n = 0
        self.err = 0.0
        self.failures = []

    def add(self, Omega, direction, value, expected):
        self.n += 1
        err = abs(value - expected) / max(abs(expected), self.floor) if np.isfinite(expected) else math.inf
        self.err = max(self.err, err)
        if not err <= self.tol:
            self.failures.append(f"Omega {Omega:.6g} ({direction}): {value!r} vs {expected!r} "
                                 f"(rel. error {err:.2e} > {self.tol:g})")

    def as_dict(self):
        return dict(run=self.run, oracle=self.oracle, points=self.n, max_rel_error=self.err,
                    tolerance=self.tol, failures=len(self.failures))


def two_sided_ode(sc, Omega, x0, n_periods, rtol=1e-12, u_stick=1e-6, max_impacts=20000):
    """Independent reference of the SDOF oscillator between two stops (or one): scipy's
    ``solve_ivp`` (DOP853) with terminal events, written without the event kernel's code.

    Free flight integrates paper Eq. 1; the events are the stops ``q = Delta`` (rising) and
    ``q = -Delta_lower`` (falling), each re-armed only after the mass has turned away from it
    (an event on ``q' = 0``), and Newton's law (Eq. 2) with each stop's R maps the velocity.
    An impact slower than ``u_stick`` times the largest impact speed so far, into a contact
    force that presses the mass on (``F sin(Omega t) - Delta > 0`` above, ``-F sin(Omega t) -
    Delta_lower > 0`` below), ends a chatter sequence: the rest of the sequence, whose rebound
    speeds ``R^k u`` fall geometrically under the contact acceleration ``a``, lasts
    ``2 R u / (a (1 - R))`` (Budd & Dux 1994), a correction of relative size ~``u_stick`` whose
    own error, ``O(D^2)``, is below 1e-13 here; then the mass is held on the stop until the contact
    force turns negative, located by ``brentq`` on a sampled sign change (not the kernel's closed
    form).  The sequence cannot be resolved by events much further: below a rebound speed
    ``sqrt(2 a eps |Delta|)`` (~4e-12 on the stops of the tests) the flight's apex lies within
    the round-off of ``q``, and the neglected rest would then be ~4e-8.  A held mass leaves the
    stop with the same state whenever it was put there, so everything after a release is exact
    again.

    Parameters
    ----------
    sc : vibeam.models.scene.Scene
        The SDOF oscillator (:func:`vibeam.models.builders.sdof.sdof`), one or two stops with
        Newton's law; constant R only.
    Omega : float
    x0 : array_like, shape (2,) or (3,)
        ``(q, q'[, held])`` at forcing phase 0 (``held``: 1 on the upper stop, -1 on the lower).
    n_periods : int
    rtol, u_stick : float
        DOP853 tolerance; the chatter cut (module text above).
    max_impacts : int
        RuntimeError beyond this many impacts (a Zeno sequence the cut does not end).

    Returns
    -------
    dict
        ``impacts`` (k, 3): time, stop (0 upper, 1 lower), pre-impact speed ``|q'-|``;
        ``sticks`` and ``releases`` (times, with their stop); ``q_min``, ``q_max`` over the
        run (root-found on the dense output); ``period_min`` (n_periods,); ``strobe``
        (n_periods + 1, 2) at the forcing periods; ``final`` ``(q, q', held)``.
    """
    from scipy.integrate import solve_ivp
    from scipy.optimize import brentq

    from vibeam.models.scene import one_mode

    om = one_mode(sc)
    beta, F = om.beta, Omega * Omega * om.B
    D_up = om.Delta
    two = om.Delta_lower is not None
    D_lo = om.Delta_lower if two else math.inf
    R_up = sc.stops[0].law.R
    R_lo = sc.stops[1].law.R if two else R_up     # the lower stop's own law, or the upper one's
    T = 2 * math.pi / Omega
    t_end = n_periods * T
    scale = max(abs(D_up), abs(D_lo) if two else 0.0, F, 1e-300)
    atol = 1e-15 * scale

    def rhs(t, y):
        return [y[1], F * math.sin(Omega * t) - 2.0 * beta * y[1] - y[0]]

    def force(t, side):   # contact force per unit mass holding the mass on a stop
        return F * math.sin(Omega * t) - D_up if side == 0 else -F * math.sin(Omega * t) - D_lo

    def release(t0, side):
        if force(t0, side) < 0.0:
            return t0
        ts = t0 + np.arange(1, 4001) * (T / 2000.0)
        f = np.array([force(t, side) for t in ts])
        k = np.flatnonzero(f < 0.0)
        if not k.size:
            return math.inf
        k = int(k[0])
        lo = ts[k - 1] if k else t0
        return brentq(lambda t: force(t, side), lo, ts[k], xtol=1e-15 * T, rtol=1e-15)

    q, v = float(x0[0]), float(x0[1])
    held = int(round(x0[2])) if len(x0) > 2 else 0
    side = 0 if held >= 0 else 1
    t = 0.0
    arm = [True, two]
    impacts, sticks, releases = [], [], []
    extrema = []        # (t, q) of located extrema and contacts
    strobe_t = np.arange(n_periods + 1) * T
    strobe_x = np.full((n_periods + 1, 2), np.nan)
    u_max = 0.0
    if held:
        # held at the start (as the kernel's state): until the contact force turns negative
        tr = release(t, side)
        qs = D_up if side == 0 else -D_lo
        sel = (strobe_t >= t) & (strobe_t <= min(tr, t_end))
        strobe_x[sel] = (qs, 0.0)
        extrema += [(t, qs), (min(tr, t_end), qs)]
        q, v, t = qs, 0.0, min(tr, t_end)
        releases.append((t, side))
        arm[side] = False
    while t < t_end:
        evs = []
        if arm[0]:
            e = lambda tt, y: y[0] - D_up
            e.terminal, e.direction = True, 1.0
            evs.append(("up", e))
        if two and arm[1]:
            e = lambda tt, y: -y[0] - D_lo
            e.terminal, e.direction = True, 1.0
            evs.append(("lo", e))
        if not arm[0]:        # re-arm the upper stop at the next minimum of q
            e = lambda tt, y: y[1]
            e.terminal, e.direction = True, 1.0
            evs.append(("min", e))
        if two and not arm[1]:   # the lower one at the next maximum
            e = lambda tt, y: y[1]
            e.terminal, e.direction = True, -1.0
            evs.append(("max", e))
        ext = lambda tt, y: y[1]     # every extremum (not terminal)
        sol = solve_ivp(rhs, (t, t_end), [q, v], method="DOP853", rtol=rtol, atol=atol,
                        events=[e for _, e in evs] + [ext], dense_output=True, max_step=T / 16)
        if sol.status < 0:
            raise RuntimeError(sol.message)
        for te in sol.t_events[-1]:
            extrema.append((te, float(sol.sol(te)[0])))
        t1 = float(sol.t[-1])
        sel = (strobe_t >= t) & (strobe_t <= t1) & np.isnan(strobe_x[:, 0])
        if sel.any():
            strobe_x[sel] = sol.sol(strobe_t[sel]).T
        q, v = (float(x) for x in sol.y[:, -1])
        extrema.append((t1, q))
        t = t1
        if sol.status != 1:
            break
        fired = [name for (name, _), te in zip(evs, sol.t_events[:-1]) if te.size and te[-1] == t1]
        name = fired[0]
        if name == "min":
            arm[0] = True
            continue
        if name == "max":
            arm[1] = True
            continue
        k = 0 if name == "up" else 1
        qs = D_up if k == 0 else -D_lo
        U = abs(v)
        impacts.append((t, k, U))
        if len(impacts) > max_impacts:   # a Zeno sequence that never presses the mass on
            raise RuntimeError(f"more than {max_impacts} impacts before t = {t:.6g}")
        extrema.append((t, qs))
        u_max = max(u_max, U)
        arm[k] = False
        arm[1 - k] = k == 1 or two    # the mass has left the other stop
        Rk = R_up if k == 0 else R_lo
        if U <= u_stick * u_max and force(t, k) > 0.0 and Rk < 1.0:
            # the rest of the chatter sequence in closed form: rebound R U, acceleration onto the
            # stop with the rebound's damping force
            acc = force(t, k) + 2.0 * beta * Rk * U
            t = t + 2.0 * Rk * U / (acc * (1.0 - Rk))
            sticks.append((t, k))
            tr = release(t, k)
            sel = (strobe_t > t) & (strobe_t <= min(tr, t_end))
            strobe_x[sel] = (qs, 0.0)
            extrema.append((min(tr, t_end), qs))
            q, v, t = qs, 0.0, min(tr, t_end)
            if tr < t_end:
                releases.append((t, k))
            else:
                held = 1 if k == 0 else -1
                break
            continue
        q = qs
        v = -(R_up if k == 0 else R_lo) * v
        held = 0
    ok = np.isfinite(strobe_x[:, 0])
    ex = np.array(extrema + list(zip(strobe_t[ok], strobe_x[ok, 0])))
    pmin = np.full(n_periods, np.nan)
    for i in range(n_periods):
        s = (ex[:, 0] >= i * T - 1e-12 * T) & (ex[:, 0] <= (i + 1) * T + 1e-12 * T)
        pmin[i] = ex[s, 1].min() if s.any() else np.nan
    return dict(impacts=np.array(impacts).reshape(-1, 3), sticks=sticks, releases=releases,
                q_min=float(ex[:, 1].min()), q_max=float(ex[:, 1].max()), period_min=pmin,
                strobe=strobe_x, final=np.array([q, v, float(held if t >= t_end else 0)]))


def _impacts_from_strobe(sc, W, d, i, n):
    """Impacts ``(phase, pre-impact velocity)`` of the n periods after the last strobe sample of
    point i (event solver; only a starting guess for the oracles)."""
    from vibeam.models import EventSolver

    q0, v0 = d["strobe"][i][-1]
    tr = EventSolver(sc).point(W, np.array([q0, v0, 0.0]), 0, n, 8)
    return tr, (W * tr.impact_times) % (2 * math.pi), tr.impact_velocities


def k_fold_fixed_point(sc, W, phi0, v0, k, n):
    """Fixed point of the k-fold impact map whose k flights last n forcing periods together.

    Each flight is found by :func:`vibeam.models.mapping.next_impact` (the mapping's flight search,
    independent of the event kernel's stepping); ``fsolve`` on ``(phase, velocity)``; the exact
    minimum from the flights' extremes (:meth:`vibeam.models.mapping.orbit.SectionMap.fly`).  Returns
    ``(q_min of the orbit, (phi, v))`` or None.
    """
    from scipy.optimize import fsolve

    from vibeam.models.mapping import next_impact
    from vibeam.models.mapping.orbit import SectionMap

    T = 2 * math.pi / W

    def flights(x):
        phi, v, out = x[0], x[1], []
        for _ in range(k):
            r = next_impact(sc, W, phi, v, max_periods=n + 1.0)
            if r is None:
                return None
            out.append((phi, v, r[0]))
            phi, v = r[1], r[2]
        return out, phi, v

    def resid(x):
        f = flights(x)
        if f is None:
            return np.array([1.0, 1.0])
        fl, _, v = f
        return np.array([(sum(t for _, _, t in fl) - n * T) / T, (v - x[1]) / max(abs(x[1]), 1e-300)])

    x, info, ier, _ = fsolve(resid, np.array([phi0, v0]), full_output=True, xtol=1e-14)
    # converged when the residual is at round-off (fsolve may report that xtol 1e-14 could not be
    # met when it starts there)
    if np.max(np.abs(resid(x))) > 1e-11:
        return None
    fl, _, _ = flights(x)
    sm = SectionMap(sc, W, n)
    ext = np.array([np.inf, -np.inf, np.inf, -np.inf])
    for phi, v, tau in fl:       # each flight to its next impact, its extremes in ext
        pas = sm.passage(0, phi / W, v)
        sm.fly(0, pas, pas.t + tau, ext)
    return ext[0], x


def _sdof_checks(name, sc, d):
    from vibeam.models import linear_amplitude
    from vibeam.models.paper.averaging import solve as averaging
    from vibeam.models.mapping import is_admissible, newton_fixed_point, orbit_extremes
    from vibeam.models.scene import one_mode

    model, R = one_mode(sc), sc.stops[0].law.R

    c_map = Check(name, "period-1 points vs impact-map fixed point (Newton)", TOL_MAPPING)
    c_kn = Check(name, "period-n points, k impacts, vs k-fold impact-map fixed point (fsolve)",
                 TOL_MAPPING)
    c_lin = Check(name, "no-impact points vs linear_amplitude", TOL_LINEAR)
    c_avg = Check(name, "R -> 1 near Omega = 2 vs averaging", TOL_AVERAGING)
    for i, W in enumerate(d["Omega"]):
        W = float(W)
        A, p, direc = float(d["amplitude"][i]), int(d["period"][i]), str(d["direction"][i])
        if str(d["status"][i]) != "ok":
            continue
        if p == -1:
            c_lin.add(W, direc, A, model.Delta + float(linear_amplitude(model.beta, model.B, W)))
            continue
        if p == 1 and abs(float(d["impacts_per_period"][i]) - 1.0) <= 1e-12:
            tr, ph, vv = _impacts_from_strobe(sc, W, d, i, 1)
            if tr.n_impacts != 1:
                c_map.failures.append(f"Omega {W:.6g} ({direc}): {tr.n_impacts} impacts in the period "
                                      f"after the last strobe sample")
                continue
            x = newton_fixed_point(sc, W, np.array([ph[0], vv[0]]), 1)
            ok, why = (False, "Newton did not converge") if x is None else is_admissible(sc, W, x, 1)
            if not ok:
                c_map.failures.append(f"Omega {W:.6g} ({direc}): no admissible fixed point ({why})")
                continue
            q_min, _ = orbit_extremes(sc, W, x, 1)
            c_map.add(W, direc, A, model.Delta - q_min)
            if R >= 0.99 and abs(W - 2.0) <= 0.1 + 1e-9:
                avg = averaging(W, model.beta, model.B, R, model.Delta, 1)
                c_avg.add(W, direc, A, float(avg["amplitude"]))
        elif p >= 1:
            tr, ph, vv = _impacts_from_strobe(sc, W, d, i, p)
            if tr.n_impacts < 1 or tr.n_impacts > 8 * p:
                continue   # chatter-like orbits: not a finite impact map
            r = k_fold_fixed_point(sc, W, ph[0], vv[0], tr.n_impacts, p)
            if r is None:
                c_kn.failures.append(f"Omega {W:.6g} ({direc}): no fixed point of the {tr.n_impacts}-fold "
                                     f"impact map over {p} periods")
                continue
            c_kn.add(W, direc, A, model.Delta - r[0])
    return [c_map, c_kn, c_lin, c_avg]


def _beam_checks(name, spec, sc, d, sweep, expensive=True):
    """A beam case's event runs (``sc`` its scene): its no-impact points against the modal linear
    steady state; the static mode against the SDOF of its derived parameters; an FE run's periodic
    points against the direct solver."""
    from dataclasses import replace

    from vibeam.case.beamscene import derive
    from vibeam.models import make_solver
    from vibeam.models.builders.sdof import sdof as sdof_scene
    from vibeam.models.registry import law_name
    from vibeam.models.scene import outputs
    from vibeam.engine.sweep import run_sweep

    o = outputs(sc)
    mass = [st for st in sc.stops if st.relation.row == 0]       # the stops at the attached mass
    c_lin = Check(name, "no-impact points vs modal linear_sensor_amplitude_m", TOL_LINEAR)
    for i, W in enumerate(d["Omega"]):
        if int(d["period"][i]) == -1 and str(d["status"][i]) == "ok":
            lin = _linear_sensor_q(sc, float(W))
            c_lin.add(float(W), str(d["direction"][i]), float(d["amplitude"][i]), o.Delta + lin)
    out = [c_lin]
    if spec.system.n_modes == "static" and law_name(sc) == "restitution":
        red = derive(spec)["reduction"]
        lower = {}
        if len(mass) == 2:   # the lower stop at the sensor: Delta_C,lower / (phi L)
            lower = dict(Delta_lower=mass[1].relation.offset / o.phi_contact / o.length_m,
                         lower_law=None if mass[1].law is mass[0].law else mass[1].law)
        sdof = sdof_scene(red.beta_S, red.gamma_per_V * spec.excitation.voltage, red.Delta, spec.stop[0].R, **lower)
        f = np.asarray(d["frequency_hz"], float)
        up = np.unique(f)
        sw = replace(sweep, Omega=up / red.f_n_hz, assess=())
        res = run_sweep(make_solver(sdof, "event"), sw, jobs=1)
        # relative to max(|A|, |Delta|): a mass held on a pre-stressed stop has A = Delta - q_min = 0
        # up to the round-off of the modal coordinates (1e-19 here)
        c_st = Check(name, "static mode vs SDOF event solver of the derived parameters", TOL_STATIC,
                     floor=abs(o.Delta))
        key = {(str(dr), round(float(w) * red.f_n_hz, 9)): j
               for j, (dr, w) in enumerate(zip(res.data["direction"], res.data["Omega"]))}
        for i, fi in enumerate(f):
            j = key[(str(d["direction"][i]), round(float(fi), 9))]
            p, p_sdof = int(d["period"][i]), int(res.data["period"][j])
            if p != p_sdof or p == 0:
                continue  # not periodic: chaos tells the two round-offs apart
            if not _reproducible_start(i, d, res.data, key):
                continue  # after a chaotic point a multistable point may land on another orbit
            c_st.add(float(d["Omega"][i]), str(d["direction"][i]), float(d["amplitude"][i]),
                     float(res.data["amplitude"][j]))
        out.append(c_st)
        out.append(_static_statistics_check(name, d, res.data, key))
        # the same oracles as an SDOF run, on the derived SDOF (frequency and strobe velocity in
        # its time unit 1 / omega_n; q = U(L_S) / L is the same coordinate)
        r = red.f_n_hz / sc.system.reference_hz
        d2 = dict(d, Omega=np.asarray(d["Omega"], float) / r,
                  strobe=np.asarray(d["strobe"], float) * np.array([1.0, 1.0 / r]))
        if len(sdof.stops) > 1:
            out += _two_sided_checks(name, sdof, d2)
        else:
            out += [c for c in _sdof_checks(name, sdof, d2) if "averaging" not in c.oracle]
    elif o.n_modes <= DIRECT_MAX_MODES and (expensive or law_name(sc) != "restitution"
                                             or any(st.relation.row > 0 for st in sc.stops)):
        # every compliant FE run, and every run with stops away from the mass, gets its direct
        # check, one point in the default test step (the restitution FE runs with their stops at
        # the mass have the static-mode, one-mode and shooting oracles of the tests)
        out.append(_direct_check(name, sc, d, sweep, DIRECT_POINTS if expensive else 1))
    return out


def _reproducible_start(i, d, sdof_data, key) -> bool:
    """Point ``i`` of a beam sweep starts from a reproducible state in both sweeps (the beam's
    ``d`` and the derived SDOF's): it is the first of its line, or the point before it is periodic
    in both.  After a non-periodic (chaotic) point the start is decided by round-off, and a
    multistable point may land on another attractor -- even one of the same period."""
    f = np.asarray(d["frequency_hz"], float)
    dirs = np.array([str(x) for x in d["direction"]])
    same = np.flatnonzero(dirs == dirs[i])
    before = same[f[same] < f[i]] if dirs[i] != "down" else same[f[same] > f[i]]
    if not before.size:
        return True
    k = before[np.argmax(f[before])] if dirs[i] != "down" else before[np.argmin(f[before])]
    kj = key[(dirs[k], round(float(f[k]), 9))]
    return int(d["period"][k]) != 0 and int(sdof_data["period"][kj]) != 0


def _static_statistics_check(name, d, sdof_data, key):
    """Non-periodic points of a static-mode beam run against the derived SDOF's (the same
    equations; chaos tells their round-offs apart, so only the statistics can agree): the means
    of Q_k by Welch's test on batch-means errors at 4 sigma (vibeam.engine.records.means_agree).  Only
    points that start from reproducible states in both sweeps: the first of each line, or after
    a periodic point in both (after a chaotic one a multistable point may land elsewhere)."""
    from vibeam.engine.records import means_agree

    c = Check(name, "static mode vs SDOF, non-periodic points: means of Q_k (Welch, batch means, 4 sigma)",
              1.0, floor=1.0)
    need = ("amplitude_mean", "amplitude_sem", "amplitude_sem_dof")
    if not all(k in d and k in sdof_data for k in need):
        return c
    f = np.asarray(d["frequency_hz"], float)
    dirs = np.array([str(x) for x in d["direction"]])
    for i in range(f.size):
        j = key[(dirs[i], round(float(f[i]), 9))]
        if int(d["period"][i]) != 0 or int(sdof_data["period"][j]) != 0:
            continue
        if not _reproducible_start(i, d, sdof_data, key):
            continue
        m1, m2 = float(d["amplitude_mean"][i]), float(sdof_data["amplitude_mean"][j])
        ok = bool(means_agree(m1, float(d["amplitude_sem"][i]), int(d["amplitude_sem_dof"][i]),
                              m2, float(sdof_data["amplitude_sem"][j]), int(sdof_data["amplitude_sem_dof"][j])))
        # the check's "error": 0 when Welch's test passes, else the relative difference of the means
        c.add(float(d["Omega"][i]), dirs[i], 0.0 if ok else 1.0 + abs(m1 - m2) / max(abs(m2), 1e-300), 0.0)
    return c


def _direct_check(name, model, d, sweep, n_points=DIRECT_POINTS):
    """FE periodic impacting points: the ``direct`` solver (solve_ivp DOP853) against the event
    solver on this machine's model, at points where the event solver from rest lands on the stored
    orbit (amplitude within :data:`SAME_ORBIT` of the stored one: a continuum's or a mesh's modes, from
    ARPACK on a factorised K, differ between BLAS kernels by ~3e-8 in frequency, ~2e-7 in such an
    amplitude; another orbit differs by far more)."""
    from vibeam.models import make_solver
    from vibeam.models.scene import outputs
    from vibeam.engine.records import summarize

    Delta = outputs(model).Delta     # model: a scene
    c = Check(name, "FE periodic points vs direct solve_ivp DOP853 (rtol 1e-10)", TOL_DIRECT)
    cand = [i for i in range(len(d["Omega"])) if int(d["period"][i]) == 1 and str(d["status"][i]) == "ok"
            and float(d["impacts_per_period"][i]) == 1.0]
    # spread the checked points over the grid; the others after them, should these land elsewhere from rest
    picks = [cand[j] for j in sorted(set(np.linspace(0, len(cand) - 1, min(len(cand), 2 * n_points))
                                         .round().astype(int)))] if cand else []
    picks += [i for i in cand if i not in picks][:2 * n_points]
    spp = sweep.samples_per_period
    for i in picks:
        if c.n >= n_points:
            break
        W = float(d["Omega"][i])
        n_tr = REFERENCE_TRANSIENT["beam"] if sweep.auto else max(int(sweep.transient_periods), 300)
        # the model's own event and direct solvers (a compliant stop has its own: the registry's
        # contact_laws; vibeam.models.make_solver)
        ev = make_solver(model, "event").point(W, None, n_tr, 2, spp)
        a_ev = summarize(ev, Delta)
        stored = float(d["amplitude"][i])
        if a_ev["period"] != 1 or abs(a_ev["amplitude"] - stored) > SAME_ORBIT * abs(a_ev["amplitude"]):
            continue   # from rest this point lands on another orbit than the sweep: try another
        di = make_solver(model, "direct", solver="DOP853", rtol=1e-10, atol=1e-14).point(W, ev.final_state, 20, 4, spp)
        a_di = summarize(di, Delta)
        if a_di["period"] != 1:
            c.failures.append(f"Omega {W:.6g}: the direct solver leaves the event solver's period-1 orbit "
                              f"(period {a_di['period']}, {di.status})")
            continue
        c.add(W, str(d["direction"][i]), float(a_ev["amplitude"]), float(a_di["amplitude"]))
    return c


def _held_check(name, sc, d):
    """Pre-stressed stop: a point is 'held on the stop' iff Omega^2 B <= |Delta| (the forcing
    cannot make q'' = Omega^2 B sin(Omega t) - Delta negative on the stop)."""
    from vibeam.analysis.maps import HELD, classify
    from vibeam.models.scene import one_mode

    model = one_mode(sc)
    c = Check(name, "held on a pre-stressed stop iff Omega^2 B <= |Delta|", 0.0)
    if model.Delta >= 0:
        return c
    cls = classify(d["period"], d["status"])
    for i, W in enumerate(d["Omega"]):
        held = float(cls[i] == HELD)
        c.add(float(W), str(d["direction"][i]), held, float(float(W) ** 2 * model.B <= -model.Delta))
    return c


def check_runs(ref_case, data: dict, expensive: bool = True) -> list[Check]:
    """Every oracle that applies to the reference datasets ``data`` of ``ref_case``.

    ``data`` maps run names (map lines: ``<run>@<parameter>=<value>``, as
    :func:`vibeam.analysis.maps.all_runs`) to per-point datasets.  ``expensive = False``
    leaves out the direct FE solver (for the tests).
    """
    from vibeam.engine.sweep import Sweep

    sw = ref_case.sweep
    sweep = Sweep(Omega=np.zeros(1), **sw.engine_options())
    checks = []
    if ref_case.map is not None:
        par = ref_case.map.parameter
        items = [(r, f"{r.name}@{par}={float(v):.6g}", dict(r.model, **{par: float(v)}))
                 for r in ref_case.run for v in ref_case.map.grid()]
    else:
        items = [(r, r.name, dict(r.model)) for r in ref_case.run]
    for r, name, overrides in items:
        d = data[name]
        bad = [float(w) for w, st in zip(d["Omega"], d["status"]) if str(st) == "failed"]
        if bad:
            c = Check(name, "no failed points", 0.0)
            c.failures.append(f"failed at Omega {bad}")
            checks.append(c)
        if r.method != "event":
            continue  # closed-form runs are their own oracle
        spec = ref_case.model_spec(overrides) if overrides else ref_case.model_spec()
        effects = ref_case.effects_for(r)
        active = set(effects.active()) - PASSIVE_EFFECTS
        platform = PLATFORM_ORACLES.get(spec.fidelity)
        if active == {"platform"} and effects.platform.level == "filter" and effects.platform.gains is None \
                and platform is not None:
            checks += platform(name, spec, effects.platform, d)
            continue
        if active:
            continue  # the other effects change the model point by point (tests/test_effects.py)
        oracles = ORACLES.get(spec.fidelity)
        if oracles is not None:
            checks += oracles(name, spec, d, sweep, expensive, ref_case.map is not None)
    return checks


def _platform_checks(name, spec, plat, d):
    """A platform filter between shaker and clamp (Sec. 5.2, ``[effects.platform] level =
    "filter"``): each point is the plain SDOF at the gain the filter predicts there.  The gain is
    recomputed here from its definition, a force-driven second-order platform ``|1 / (1 - r^2 +
    2 i zeta r)|``, ``r = f / f_p``, scaled to the scene's gain at the natural frequency (1e-12
    against the stored ``effective_gain``); then the SDOF oracles (impact-map fixed points, the
    linear steady state) on the model with ``B = gamma(f) V`` (Eq. 43) point by point."""
    from vibeam.models.builders.sdof import sdof
    from vibeam.models.scene import one_mode

    f_ref = plat.reference_frequency_hz or spec.system.natural_frequency_hz

    def H(f):
        r = f / plat.frequency_hz
        return 1.0 / abs(complex(1.0 - r * r, 2.0 * plat.damping_ratio * r))

    c_gain = Check(name, "platform filter gain vs |H(f)| / |H(f_n)| of a second-order platform", 1e-12)
    sc = spec.scene()
    base, R = one_mode(sc), sc.stops[0].law.R
    out = {}
    for i, W in enumerate(d["Omega"]):
        f = float(d["frequency_hz"][i])
        g = spec.excitation.gain * H(f) / H(f_ref)
        if "effective_gain" in d:
            c_gain.add(float(W), str(d["direction"][i]), float(d["effective_gain"][i]), g)
        m = sdof(base.beta, g * spec.excitation.voltage, base.Delta, R)
        one = {k: np.asarray(v)[i:i + 1] for k, v in d.items() if k != "attrs" and np.ndim(v) >= 1
               and len(v) == len(d["Omega"])}
        for c in _sdof_checks(name, m, one):
            if "averaging" in c.oracle:
                continue
            key = c.oracle + " (platform filter: B = gamma(f) V)"
            acc = out.setdefault(key, Check(name, key, c.tol))
            acc.n += c.n
            acc.err = max(acc.err, c.err)
            acc.failures += c.failures
    return [c_gain, *out.values()]


def _two_sided_checks(name, sc, d):
    """Periodic points of a two-sided SDOF run against :func:`two_sided_ode` started on the
    stored orbit (the last strobe sample, phase 0): over ``2 n`` periods the oracle must return
    to it after ``n`` and ``2 n`` periods (the orbit is a period-n solution of the independent
    integration) and give the stored amplitude ``Delta - min q`` and impacts per period on each
    stop.  No-impact points: the linear steady state, as one-sided."""
    from vibeam.models import linear_amplitude
    from vibeam.models.scene import one_mode

    model = one_mode(sc)
    c_per = Check(name, "two-sided period-n points vs solve_ivp with events (DOP853)", TOL_TWO_SIDED)
    # the stored strobe state against the oracle's after n and 2 n periods, relative to the orbit's
    # size (|Delta| + its velocity scale: the largest strobe component)
    c_ret = Check(name, "two-sided period-n strobe state vs solve_ivp after n, 2n periods", TOL_TWO_SIDED,
                  floor=1.0)
    c_lin = Check(name, "no-impact points vs linear_amplitude", TOL_LINEAR)
    for i, W in enumerate(d["Omega"]):
        W = float(W)
        A, p, direc = float(d["amplitude"][i]), int(d["period"][i]), str(d["direction"][i])
        if str(d["status"][i]) != "ok":
            continue
        if p == -1:
            c_lin.add(W, direc, A, model.Delta + float(linear_amplitude(model.beta, model.B, W)))
            continue
        if p < 1:
            continue
        x0 = np.asarray(d["strobe"][i][-1], float)
        o = two_sided_ode(sc, W, x0, 2 * p)
        scale = max(float(np.max(np.abs(x0))), abs(A), 1e-300)
        back = max(float(np.max(np.abs(o["strobe"][p] - x0))), float(np.max(np.abs(o["strobe"][2 * p] - x0))))
        c_ret.add(W, direc, back / scale, 0.0)
        if not back <= TOL_TWO_SIDED * scale:
            continue
        k = o["impacts"][:, 1] if o["impacts"].size else np.zeros(0)
        n_up, n_lo = float(np.sum(k == 0)) / (2 * p), float(np.sum(k == 1)) / (2 * p)
        # the stored counts are over the record (n_rec periods, not a multiple of p in general):
        # they may differ from the orbit's by the impacts of one orbit, spread over n_rec periods
        n_rec = np.asarray(d["strobe"][i]).shape[0]
        slack = (n_up + n_lo) * p / n_rec + 1e-12
        if (abs(n_up - float(d["impacts_per_period"][i])) > slack
                or abs(n_lo - float(d["impacts_per_period_lower"][i])) > slack):
            c_per.failures.append(f"Omega {W:.6g} ({direc}): impacts per period (upper, lower) {n_up:g}, {n_lo:g} "
                                  f"against stored {float(d['impacts_per_period'][i]):g}, "
                                  f"{float(d['impacts_per_period_lower'][i]):g}")
            continue
        c_per.add(W, direc, A, model.Delta - o["q_min"])
    return [c_per, c_ret, c_lin]


def _sdof_oracles(name, spec, d, sweep, expensive, is_map):
    sc = spec.scene()
    if len(sc.stops) > 1:
        return _two_sided_checks(name, sc, d)
    if sc.stops[0].law.kind != "impulsive":
        return []   # the impact-map oracles are Newton's law's (compliant laws: tests/test_compliant.py)
    out = _sdof_checks(name, sc, d)
    if is_map:
        out.append(_held_check(name, sc, d))
    return out


def _linear_sensor_q(sc, W: float) -> float:
    """The steady-state sensor amplitude of ``sc`` without its stops, in units of q: the modal sum
    ``|s^T H|`` with ``H_i = Gamma_i F(W) / (omega_i^2 - W^2 + i W c_i)`` (metres) over ``L``."""
    from vibeam.models.system import forcing   # lazy: the kernels' module, loaded by the checks only

    sy = sc.system
    H = sy.participation * forcing(sy, W) / (sy.omega ** 2 - W ** 2 + 1j * W * sy.damping)
    return float(abs(sy.sensor @ H)) / float(sy.length_unit_m)


def _matrices_checks(name, spec, model, d, sweep, expensive=True):
    """A structure given by its matrices (``model`` its scene): its no-impact points against the
    modal linear steady state, its period-1 impacting points against the direct solver (solve_ivp
    DOP853); the independent physical integration is tests/test_chain_matrices.py's."""
    from vibeam.models.scene import outputs   # lazy: the kernels' package, loaded by the checks only

    c_lin = Check(name, "no-impact points vs modal linear_sensor_amplitude_m", TOL_LINEAR)
    Delta = outputs(model).Delta
    for i, W in enumerate(d["Omega"]):
        if int(d["period"][i]) == -1 and str(d["status"][i]) == "ok":
            c_lin.add(float(W), str(d["direction"][i]), float(d["amplitude"][i]), Delta + _linear_sensor_q(model, float(W)))
    out = [c_lin]
    if outputs(model).n_modes <= DIRECT_MAX_MODES:
        out.append(_direct_check(name, model, d, sweep, DIRECT_POINTS if expensive else 1))
    return out


# the oracles of each fidelity's plain event runs (a fidelity without an entry gets the generic
# checks only): (name, spec, datasets, sweep, expensive, is a map line) -> [Check]
ORACLES = {
    "sdof": _sdof_oracles,
    "beam": lambda name, spec, d, sweep, expensive, is_map: _beam_checks(name, spec, spec.scene(), d, sweep,
                                                                         expensive),
    "matrices": lambda name, spec, d, sweep, expensive, is_map: _matrices_checks(name, spec, spec.scene(), d, sweep,
                                                                                 expensive),
    # the continuum is a structure in modal coordinates too (the rig's solid reduced to its modes)
    "continuum": lambda name, spec, d, sweep, expensive, is_map: _matrices_checks(name, spec, spec.scene(), d, sweep,
                                                                                  expensive),
    # a user's mesh likewise (cases/plate-tip-stop: a part from a Gmsh file reduced to its modes)
    "mesh": lambda name, spec, d, sweep, expensive, is_map: _matrices_checks(name, spec, spec.scene(), d, sweep,
                                                                             expensive),
}


# the oracles of runs whose only effect is a platform filter (Sec. 5.2), per fidelity
PLATFORM_ORACLES = {"sdof": _platform_checks}


def check_stored(path, expensive: bool = False) -> list[Check]:
    """Recompute the oracles of a stored reference file from its own datasets and case text."""
    import h5py

    from vibeam.case.schema import parse_case
    from vibeam.analysis.maps import all_runs
    from vibeam.io.results import read_results

    with h5py.File(path, "r") as f:
        case = parse_case(f.attrs["case_text"], base=CASES)   # the shipped cases: their files beside them
    return check_runs(reference_case(case), all_runs(read_results(path)), expensive)


# ----------------------------------------------------------------------------- main
def make_reference(path, out_dir=HERE, jobs=None, write=True, log=print) -> tuple[bool, list[Check]]:
    """Compute, check and (if every check passes) write the reference of one case file."""
    from vibeam.case.schema import load_case
    from vibeam.cli import run_case
    from vibeam.analysis.maps import map_lines
    from vibeam.io.results import write_results

    case, text = load_case(path)
    ref_case = reference_case(case)
    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory() as tmp:
        runs = run_case(ref_case, text, tmp, jobs=jobs, quiet=True, plots=False)
    log(f"[{case.name}] reference computed in {time.perf_counter() - t0:.1f} s "
        f"({ref_case.sweep.transient_periods} transient periods, at most "
        f"{ref_case.sweep.max_transient_periods} with auto)")
    if ref_case.map is not None:
        data = map_lines({"maps": {m.name: dict(m.data, attrs=m.attrs) for m in runs}})
    else:
        data = {res.name: res.data for res in runs}
    t0 = time.perf_counter()
    checks = check_runs(ref_case, data)
    log(f"  oracles in {time.perf_counter() - t0:.1f} s")
    ok = True
    for c in checks:
        if c.n == 0 and not c.failures:
            continue
        verdict = "ok" if not c.failures else "FAILED"
        log(f"  {c.run:<22}{c.oracle:<62}{c.n:>4} pts  max rel. error {c.err:.2e}  "
            f"(tol {c.tol:g})  {verdict}")
        for msg in c.failures[:5]:
            log(f"      {msg}")
        ok &= not c.failures
    if not ok:
        log(f"[{case.name}] oracle check FAILED: reference not written")
        return False, checks
    if write:
        maps, runs = (runs, []) if ref_case.map is not None else ([], runs)
        dropped = sorted({k for res in runs + maps for k in res.data if k not in KEPT + MAP_KEPT})
        for res in runs + maps:
            res.data = {k: v for k, v in res.data.items() if k in KEPT + MAP_KEPT}
        extra = {"reference": reference_table(
            dropped, ref_case.sweep.transient_periods, [f"{r.name}: {r.method}" for r in ref_case.run],
            [json.dumps(c.as_dict()) for c in checks if c.n], ref_case.sweep.max_transient_periods)}
        out = write_results(Path(out_dir) / f"{case.name}.h5", runs, case.name, text, extra=extra, maps=maps)
        log(f"[{case.name}] -> {out} ({out.stat().st_size / 1024:.0f} kB)")
    return True, checks


def reference_table(dropped, transient_periods, methods, checks, max_transient_periods=None) -> dict:
    """The ``/reference`` group of a reference file (netCDF variables with units and names)."""
    from vibeam.io.results import var

    out = {
        "dropped_datasets": var(("dropped_dataset",), np.array(list(dropped), dtype=object), None,
                                "per-point outputs of the runs not kept in the reference"),
        "transient_periods": var((), np.array(str(transient_periods), dtype=object), None,
                                 "transient forcing periods per point of the reference (a number or auto)"),
        "methods": var(("case_run",), np.array(list(methods), dtype=object), None,
                       "run: method of the case (time-domain runs are referenced by event)"),
        "checks": var(("check",), np.array(list(checks), dtype=object), None,
                      "oracle checks passed (JSON: run, oracle, points, max_rel_error, tolerance, failures)")}
    if max_transient_periods is not None:
        out["max_transient_periods"] = var((), np.array(int(max_transient_periods)), "1",
                                           "most transient periods of transient_periods = auto")
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("cases", nargs="*", help="case files (default: every cases/*.toml)")
    ap.add_argument("--out", default=str(HERE), help="output folder (default tests/references/)")
    ap.add_argument("--jobs", type=int, default=None)
    ap.add_argument("--check-only", action="store_true", help="compute and check, write nothing")
    args = ap.parse_args(argv)
    paths = [Path(p) for p in args.cases] or sorted(CASES.glob("*.toml"))
    failed = []
    from vibeam.case.schema import load_case
    for p in paths:
        if all(r.method == "continuation" for r in load_case(p)[0].run):
            print(f"[{p}] continuation runs only: no reference FRC (its branches are regressed by "
                  f"tests/test_references.py:BRANCH_REGRESSED)")
            continue
        ok, _ = make_reference(p, args.out, jobs=args.jobs, write=not args.check_only)
        if not ok:
            failed.append(str(p))
    if failed:
        print(f"\noracle checks failed for: {', '.join(failed)}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
