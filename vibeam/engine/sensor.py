"""The ``sensor`` effect: what the rig's displacement sensor would have recorded, and the
paper's identification of the coefficient of restitution from it (Sec. 5.1).

The sensor at ``L_S`` is sampled at ``sampling_hz`` (5 kHz in the paper, Sec. 5) with
Gaussian noise of standard deviation ``noise_mm``; the velocity is obtained by central
differences (Sec. 5: "The velocity was obtained from the displacement data using central
finite differences"); the CoR is then picked as in Sec. 5.1: ``R = -U'+ / U'-`` at the
ends of the intervals where the velocity varies abruptly, changing its sign, over the
first three impacts of the record (``impacts = "first3"``, as the paper did for period-1
orbits) or all of them (``"all"``).

Resampling
    The solver records exact ``(q, q')`` at ``samples_per_period`` per forcing period
    (at least ``oversample * sampling_hz / f`` when the sensor is on, see
    :func:`required_samples_per_period`).  The displacement is interpolated to the
    sampling instants ``k / sampling_hz`` by cubic Hermite interpolation (it uses the
    exact velocities), except on the recording intervals that contain an impact: there
    ``q'`` jumps, and each sampling instant is extrapolated from the side of the impact it
    lies on (second-order Taylor with the acceleration of the neighbouring interval), so
    that the interpolation does not smear the jump before the central differences do.

Where the identification's error comes from (noise-free)
    With sampling step ``dt`` and an impact between samples ``j`` and ``j+1``, the central
    differences ``v_j`` and ``v_{j+1}`` straddle the impact (the jump is smeared over two
    samples; the largest single drop is always ``v_j - v_{j+1} = (1 + R) U'- / 2``).  The
    picked velocities are the first clean ones on either side, ``v_{j-1}`` and
    ``v_{j+2}``, taken at most ``2 dt`` away from the impact; they differ from ``U'-`` and
    ``U'+`` by at most ``2 dt max|a|`` (``a`` the acceleration next to the impact) plus the
    central-difference truncation ``dt^2 max|U'''| / 6``.  Hence

        ``|R_id - R| <= (1 + R) 2 dt max|a| / U'-  (+ O(dt^2))``,

    which is what ``tests/test_sensor.py`` checks.  With noise ``sigma`` on the
    displacement the central-difference velocity carries noise ``sigma / (sqrt(2) dt)``
    (3.5 mm/s per micrometre at 5 kHz), so the error of ``R`` grows like
    ``sigma sqrt(1 + R^2) / (sqrt(2) dt U'-)`` until impacts are no longer detected.
"""
from __future__ import annotations

import math

import numpy as np

DEFAULT_LADDER_MM = (0.0, 0.0002, 0.0005, 0.001, 0.002, 0.005, 0.01)


def required_samples_per_period(sampling_hz: float, f_min_hz: float, oversample: int = 2) -> int:
    """Recorded samples per forcing period needed to resample at ``sampling_hz``."""
    return int(math.ceil(oversample * sampling_hz / f_min_hz))


def physical_record(traj, f_ref_hz: float, length_m: float):
    """Time (s), displacement (mm) and velocity (mm/s) of a trajectory's exact samples."""
    om_ref = 2.0 * math.pi * f_ref_hz
    n = traj.samples.shape[0]
    T = 1.0 / (traj.Omega * f_ref_hz)          # forcing period (s)
    t = np.arange(n) * (T / traj.samples_per_period)
    x = traj.samples[:, 0] * length_m * 1e3
    v = traj.samples[:, 1] * length_m * 1e3 * om_ref
    return t, x, v


def resample(t, x, v, sampling_hz: float, impact_times_s=()):
    """Displacement at ``k / sampling_hz`` from exact samples ``(t, x, v)`` (see module doc).

    Returns
    -------
    ts : ndarray
        Sampling instants (s), from ``t[0]`` to at most ``t[-1]``.
    xs : ndarray
        Displacement at ``ts`` (units of ``x``).
    """
    # lazy: keeps scipy.interpolate (0.5 s) out of `vibeam run` (only the sensor needs it)
    from scipy.interpolate import CubicHermiteSpline

    dt = 1.0 / sampling_hz
    ts = t[0] + np.arange(int(math.floor((t[-1] - t[0]) / dt * (1 + 1e-12))) + 1) * dt
    xs = CubicHermiteSpline(t, x, v)(ts)
    h = t[1] - t[0]
    imp = np.asarray(impact_times_s, dtype=float)
    if imp.size:
        r = np.clip(np.floor((imp - t[0]) / h).astype(int), 0, t.size - 2)
        for ti, ri in zip(imp, r):
            lo, hi = t[ri], t[ri + 1]
            sel = (ts > lo) & (ts < hi)
            if not sel.any():
                continue
            # acceleration of the neighbouring intervals (not crossing the impact)
            a_l = (v[ri] - v[ri - 1]) / h if ri >= 1 else 0.0
            a_r = (v[ri + 2] - v[ri + 1]) / h if ri + 2 < t.size else 0.0
            for k in np.nonzero(sel)[0]:
                s = ts[k]
                if s <= ti:
                    d = s - lo
                    xs[k] = x[ri] + v[ri] * d + 0.5 * a_l * d * d
                else:
                    d = s - hi
                    xs[k] = x[ri + 1] + v[ri + 1] * d + 0.5 * a_r * d * d
    return ts, xs


def central_velocity(xs, sampling_hz: float):
    """Central differences ``(x_{k+1} - x_{k-1}) / (2 dt)``; NaN at both ends."""
    v = np.full(xs.shape, np.nan)
    v[1:-1] = (xs[2:] - xs[:-2]) * (0.5 * sampling_hz)
    return v


def identify_impacts(v, max_impacts: int | None = 3):
    """The paper's pick of ``U'-`` and ``U'+`` (Sec. 5.1) from a velocity series.

    An impact is an abrupt, sign-changing drop of the velocity: the middle of the smear
    is the largest one-sample drop ``d_k = v_k - v_{k+1}`` (local maximum, above
    ``max(0.25 max d, 3.5 sigma_d)`` with ``sigma_d`` a robust (MAD) estimate of the
    sample-to-sample scatter), with ``v > 0`` before and ``v < 0`` after.  ``U'-`` is
    ``v_{k-1}`` and ``U'+`` is ``v_{k+2}``: the first samples on either side whose central
    differences do not straddle the impact.

    Returns
    -------
    idx : ndarray of int
        ``k`` of each detected impact (the impact lies between samples ``k`` and ``k+1``).
    u_minus, u_plus : ndarray
        Picked pre- and post-impact velocities.
    """
    n = v.size
    d = np.full(n, -np.inf)
    d[1:-2] = v[1:-2] - v[2:-1]
    fin = np.isfinite(d)
    if not fin.any():
        return np.zeros(0, int), np.zeros(0), np.zeros(0)
    df = d[fin]
    sig = 1.4826 * np.median(np.abs(df - np.median(df)))
    thr = max(0.25 * df.max(), 3.5 * sig, 1e-300)
    idx, um, up = [], [], []
    k = 2
    while k < n - 3:
        if d[k] > thr and d[k] >= d[k - 1] and d[k] >= d[k + 1]:
            a, b = v[k - 1], v[k + 2]
            if a > 0.0 > b:
                idx.append(k)
                um.append(a)
                up.append(b)
                if max_impacts is not None and len(idx) >= max_impacts:
                    break
                k += 3
                continue
        k += 1
    return np.array(idx, int), np.array(um), np.array(up)


def restitution_of(velocity_mm_s, R_const: float, law=None):
    """True R of impacts at pre-impact velocities (the model's constant or its law)."""
    u = np.asarray(velocity_mm_s, dtype=float)
    if law is None:
        return np.full(u.shape, float(R_const))
    return np.interp(u, np.asarray(law.velocity_mm_s, float), np.asarray(law.R, float))


def identify(traj, f_ref_hz: float, length_m: float, sampling_hz: float, noise_mm: float = 0.0,
             rng=None, impacts: str = "first3", R_const: float = 0.0, law=None, noise=None,
             velocity_factor: float = 1.0) -> dict:
    """Simulated sensor record of one point and the CoR identified from it.

    Parameters
    ----------
    traj : vibeam.engine.records.Trajectory
    f_ref_hz, length_m : float
        Time and length scales of the model (``t = 2 pi f_ref t~``, ``q = U / L``).
    sampling_hz, noise_mm : float
        Sensor sampling rate and Gaussian noise (standard deviation, mm).
    rng : numpy.random.Generator, optional
        Source of the noise (ignored when ``noise`` is given).
    noise : ndarray, optional
        Standard-normal noise per sample (scaled by ``noise_mm``), to reuse one draw
        along a noise ladder.
    impacts : {'first3', 'all'}
    R_const, law :
        The true R (constant) or the ``[effects.restitution_law]`` table (on the sensor
        velocity, mm/s).
    velocity_factor : float
        Recorded impact velocity (the contact's for the beam) to sensor velocity
        (``1 / phi(x_m)`` of the static mode for the beam, as the effects do).

    Returns
    -------
    dict
        ``R_identified`` (mean over the picked impacts), ``R_identified_std``,
        ``identified_velocity_mm_s`` (mean picked ``U'-``), ``R_true`` and
        ``true_velocity_mm_s`` (of the matching true impacts), ``R_sensor_exact``
        (``-v(t+)/v(t-)`` of the exact sensor velocity at the true impacts: differs from
        ``R_true`` when several modes move the sensor differently from the contact),
        ``n_identified``, ``n_false`` (picks that match no true impact within 2 samples);
        NaN when nothing was picked.
    """
    t, x, v = physical_record(traj, f_ref_hz, length_m)
    om_ref = 2.0 * math.pi * f_ref_hz
    imp_t = np.asarray(traj.impact_times, float) / om_ref
    imp_u = np.asarray(traj.impact_velocities, float) * length_m * 1e3 * om_ref * velocity_factor
    ts, xs = resample(t, x, v, sampling_hz, imp_t)
    if noise_mm > 0.0:
        if noise is None:
            noise = (rng or np.random.default_rng()).standard_normal(xs.size)
        xs = xs + noise_mm * noise[:xs.size]
    vs = central_velocity(xs, sampling_hz)
    idx, um, up = identify_impacts(vs, 3 if impacts == "first3" else None)
    nan = float("nan")
    out = dict(R_identified=nan, R_identified_std=nan, identified_velocity_mm_s=nan, R_true=nan,
               true_velocity_mm_s=nan, R_sensor_exact=nan, n_identified=0, n_false=0)
    # -v(t+)/v(t-) of the exact sensor velocity at the true impacts (first three or all),
    # from the recorded samples next to each impact (h = dt / oversample either side)
    sens_R = []
    for ti in (imp_t[:3] if impacts == "first3" else imp_t):
        kb = int(np.searchsorted(t, ti, side="right")) - 1   # last sample before
        if 0 <= kb < t.size - 1 and v[kb] > 0:
            sens_R.append(-v[kb + 1] / v[kb])
    if sens_R:
        out["R_sensor_exact"] = float(np.mean(sens_R))
    if idx.size == 0:
        return out
    Rk = -up / um
    t_mid = ts[idx] + 0.5 / sampling_hz
    dt = 1.0 / sampling_hz
    true_R, true_u, n_false = [], [], 0
    for tm in t_mid:
        if imp_t.size:
            j = int(np.argmin(np.abs(imp_t - tm)))
            if abs(imp_t[j] - tm) <= 2.0 * dt:
                true_u.append(imp_u[j])
                true_R.append(float(restitution_of(imp_u[j], R_const, law)))
                continue
        n_false += 1
    out.update(R_identified=float(np.mean(Rk)), R_identified_std=float(np.std(Rk)),
               identified_velocity_mm_s=float(np.mean(um)), n_identified=int(idx.size),
               n_false=int(n_false))
    if true_R:
        out.update(R_true=float(np.mean(true_R)), true_velocity_mm_s=float(np.mean(true_u)))
    return out


class SensorHook:
    """Per-point hook of the sensor effect (picklable; applied by the sweep to each
    Trajectory).  Outputs ``R_identified``, ``R_identified_std``, ``R_true``, ``R_sensor_exact``,
    ``identified_velocity_mm_s``, ``true_velocity_mm_s``, ``R_n_identified``,
    ``R_n_false`` at the case's ``noise_mm``, and ``R_identified_ladder`` /
    ``R_true_ladder`` (one entry per level of ``noise_ladder_mm``, same noise draw).

    ``stop_law`` is the paper's stop's law (:class:`vibeam.models.contact.Restitution` or a
    compliant law: its ``R``, Newton's or the target, is the true R of an impact without
    ``law``); ``law`` the ``[effects.restitution_law]`` table ``R(velocity_mm_s)``, or None."""

    def __init__(self, sensor_spec, f_ref_hz: float, length_m: float, stop_law, law=None,
                 velocity_factor: float = 1.0):
        self.velocity_factor = float(velocity_factor)
        self.spec = sensor_spec
        self.f_ref_hz = float(f_ref_hz)
        self.length_m = float(length_m)
        self.stop_law = stop_law
        self.law = law

    @property
    def ladder(self):
        lad = self.spec.noise_ladder_mm
        return tuple(DEFAULT_LADDER_MM if lad is None else lad)

    def __call__(self, traj) -> dict:
        sp = self.spec
        nl = len(self.ladder)
        nan = float("nan")
        if traj.status == "failed" or not np.isfinite(traj.samples).all():
            return dict(R_identified=nan, R_identified_std=nan, R_true=nan, R_sensor_exact=nan,
                        identified_velocity_mm_s=nan,
                        true_velocity_mm_s=nan, R_n_identified=0, R_n_false=0,
                        R_identified_ladder=np.full(nl, nan), R_true_ladder=np.full(nl, nan))
        # one standard-normal draw per point (seeded by the case seed and the frequency)
        rng = np.random.default_rng([int(sp.seed) & 0xFFFFFFFF, int(round(traj.Omega * 1e9)) & 0xFFFFFFFF])
        n_max = traj.samples.shape[0] + 16
        z = rng.standard_normal(n_max)
        kw = dict(f_ref_hz=self.f_ref_hz, length_m=self.length_m, sampling_hz=sp.sampling_hz,
                  impacts=sp.impacts, R_const=float(self.stop_law.R), law=self.law, noise=z,
                  velocity_factor=self.velocity_factor)
        main = identify(traj, noise_mm=sp.noise_mm, **kw)
        lad_id = np.full(nl, nan)
        lad_tr = np.full(nl, nan)
        for i, s in enumerate(self.ladder):
            r = main if s == sp.noise_mm else identify(traj, noise_mm=s, **kw)
            lad_id[i] = r["R_identified"]
            lad_tr[i] = r["R_true"]
        return dict(R_identified=main["R_identified"], R_identified_std=main["R_identified_std"],
                    R_true=main["R_true"], R_sensor_exact=main["R_sensor_exact"],
                    identified_velocity_mm_s=main["identified_velocity_mm_s"],
                    true_velocity_mm_s=main["true_velocity_mm_s"],
                    R_n_identified=main["n_identified"], R_n_false=main["n_false"],
                    R_identified_ladder=lad_id, R_true_ladder=lad_tr)
