"""What a time-domain method hands to the sweep for one forcing frequency, and
the one place where it is turned into the per-point outputs of an FRC.

Every time-domain method of every fidelity returns a :class:`Trajectory`;
:func:`summarize` computes the amplitude (paper Sec. 4.1) and its spread over
the recorded periods, period-n from the stroboscopic map, whether the transient
has settled, impacts per period, harmonics (paper Fig. 20), so that those
definitions exist once.
"""
from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from vibeam.models.trajectory import Trajectory  # noqa: F401  (re-exported)

STATUSES = ("ok", "chatter", "sticking", "unsettled", "failed")
# the period-n test passes within period_rtol; between period_rtol and MARGINAL x period_rtol it is
# marginal (a transient still converging).  ``transient_periods = "auto"`` asks for returns within
# SETTLED_MARGIN x period_rtol (1e-8 of the orbit by default) before it stops: the distance to the
# orbit is about returns / (1 - rho) for a Floquet multiplier rho (measured up to 6x the returns on
# the Fig. 13 branch), so the amplitude is then settled to ~1e-7
MARGINAL = 10.0
SETTLED_MARGIN = 1e-3
HARMONICS = 6  # 0 .. 5 Omega
PERIOD_MAX = 8


def natural_time_factors(Omega: float | None) -> np.ndarray:
    """How much of a free vibration the period-n returns of the stroboscopic map see, n = 1..8.

    Settling is a matter of the oscillator's own time, not of forcing periods.  Between
    strobe samples n forcing periods apart (``n T``, ``T = 2 pi / Omega``; the time unit is
    ``1 / omega_n``, so a natural period is ``2 pi``) a free vibration of size ``e`` (what is
    left of the transient, relative to the orbit) moves the sample by ``e |1 - exp(i n T)| <=
    e n T``.  At high Omega (``n T << 1``) the returns therefore shrink with ``n T`` however
    unsettled the motion: at Omega = 1e6 a free vibration as large as the orbit returns within
    6e-6 of it, and the period-n test at 1e-5 would call it periodic (Fig. 7 scene, issue 19).
    A return is therefore divided by ``min(1, n T)`` before it is compared with a tolerance:
    then it measures the size of the transient, not how far it moves in n forcing periods.
    For ``n T >= 1`` (Omega <= 2 pi n, every scene of the paper) nothing changes.

    Parameters
    ----------
    Omega : float or None
        Forcing frequency over the natural frequency; None: no correction (all 1).

    Returns
    -------
    ndarray, shape (8,)
        ``min(1, 2 pi n / Omega)`` for n = 1..8.
    """
    if Omega is None or not np.isfinite(Omega) or Omega <= 0:
        return np.ones(PERIOD_MAX)
    return np.minimum(1.0, 2.0 * np.pi * np.arange(1, PERIOD_MAX + 1) / float(Omega))


def own_time_factor(Omega: float | None, n: int) -> float:
    """``natural_time_factors(Omega)[n - 1]`` as a float (the same number), without the array.

    Parameters
    ----------
    Omega : float or None
        Forcing frequency over the natural frequency; None: no correction (1).
    n : int
        The period, 1..8.
    """
    if Omega is None or not np.isfinite(Omega) or Omega <= 0:
        return 1.0
    return min(1.0, 2.0 * np.pi * n / float(Omega))


def strobe_returns(strobe: np.ndarray, scale: float, Omega: float | None = None) -> np.ndarray:
    """Largest distance of the period-n returns of the stroboscopic map, n = 1..8.

    Parameters
    ----------
    strobe : ndarray, shape (m, 2)
        Stroboscopic samples ``(q, q')``.
    scale : float
        Size of the orbit the distances are divided by.
    Omega : float, optional
        Forcing frequency: the returns are judged in the oscillator's own time, divided by
        :func:`natural_time_factors` (None: not).

    Returns
    -------
    ndarray, shape (8,)
        ``max_k |strobe[k + n] - strobe[k]| / scale`` (max norm over both
        components), over ``min(1, 2 pi n / Omega)`` when ``Omega`` is given; ``inf``
        where the window is too short for that n.
    """
    m = strobe.shape[0]
    out = np.full(PERIOD_MAX, np.inf)
    sc = max(scale, 1e-300)
    for n in range(1, min(PERIOD_MAX, m - 1) + 1):
        d = strobe[n:] - strobe[:-n]
        out[n - 1] = np.abs(d, out=d).max() / sc      # (in place: ~1 us a return fewer per point)
    return out / natural_time_factors(Omega)


def converging(strobe: np.ndarray, n: int, scale: float, rtol: float,
               Omega: float | None = None) -> tuple[bool, float, float]:
    """Are the period-n returns of the stroboscopic map still shrinking (a transient)?

    The distances ``e_k = |strobe[k + n] - strobe[k]| / scale`` are split into
    four consecutive quarters; the returns converge when the largest distance
    of each quarter is smaller than that of the quarter before and the last is
    below a quarter of the first, while still above ``rtol`` (a settled orbit
    repeats to ``rtol``; a chaotic attractor's returns do not shrink steadily:
    four decreasing quarter maxima with a factor 4 between the ends are
    improbable for stationary motion).  Needs ``len(strobe) - n >= 8``.  With ``Omega`` the
    distances are judged in the oscillator's own time (:func:`natural_time_factors`).

    Returns
    -------
    (bool, float, float)
        The verdict and the largest distance of the first and last quarter.
    """
    m = strobe.shape[0]
    if m - n < 8:
        return False, np.nan, np.nan
    d = strobe[n:] - strobe[:-n]
    e = np.maximum.reduce(np.abs(d, out=d), axis=1) / max(scale, 1e-300) / own_time_factor(Omega, n)
    # the maxima of np.array_split(e, 4)'s quarters (the first len % 4 one longer), by one reduceat:
    # the same numbers without array_split's Python layers (it and np.max per quarter were a quarter
    # of a settle = true sweep's time on the rig's chattering points, issue 60)
    k, r = divmod(e.shape[0], 4)
    q0, q1, q2, q3 = np.maximum.reduceat(e, [0, k + (r > 0), 2 * k + min(r, 2), 3 * k + min(r, 3)]).tolist()
    # (q_{i+1} < q_i is np.diff(qmax) < 0 for every float, inf and NaN included)
    conv = q1 < q0 and q2 < q1 and q3 < q2 and q3 < 0.25 * q0 and q3 > rtol
    return conv, q0, q3


def transient_verdict(strobe: np.ndarray, scale: float, rtol: float, no_impact: bool,
                      margin: float = 1.0, Omega: float | None = None) -> tuple[int, str]:
    """Period of the stroboscopic map and whether the transient has settled.

    Parameters
    ----------
    strobe : ndarray, shape (m, 2)
        Stroboscopic samples of the recorded window.
    scale : float
        Size of the orbit.
    rtol : float
        Tolerance of the period-n test (``[sweep] period_rtol``).
    no_impact : bool
        No impact in the window (period -1): the free motion of a linear
        damped oscillator, which must repeat with period 1.
    margin : float
        Factor on ``rtol`` a periodic orbit must meet to count as settled (1 for
        the recorded verdict; :data:`SETTLED_MARGIN` while ``transient_periods =
        "auto"`` decides whether to go on).
    Omega : float, optional
        Forcing frequency: the returns are judged in the oscillator's own time, divided by
        ``min(1, 2 pi n / Omega)`` (:func:`natural_time_factors`), so a free vibration that
        has not decayed is not taken for a periodic orbit at high Omega.  None: as measured
        (the verdict of the recorded strobe alone).

    Returns
    -------
    (int, str)
        The period (1..8; 0 = not periodic within 8; -1 = no impact) and the
        reason the transient is *not* settled ('' when it is):

        * the period-n test is marginal: some n repeats within ``MARGINAL x rtol``
          but not within ``margin x rtol``;
        * the period-n returns still shrink steadily for some n = 1..8
          (:func:`converging`);
        * no impact, yet the free motion does not repeat within ``margin x rtol``
          (a late impact's free decay not over).
    """
    # the common outcome first: the first n whose return is within min(1, margin) rtol, every
    # return before it beyond max(1, margin, MARGINAL) rtol (then neither a marginal nor a
    # converging test can apply), from the returns up to n only; the same values as below
    m = strobe.shape[0]
    if not no_impact and m > 1:
        f = natural_time_factors(Omega)
        sc = max(scale, 1e-300)
        lo = min(1.0, margin) * rtol
        hi = max(1.0, margin, MARGINAL) * rtol
        for n in range(1, min(PERIOD_MAX, m - 1) + 1):
            e = strobe[n:] - strobe[:-n]
            dn = np.abs(e, out=e).max() / sc / f[n - 1]
            if dn <= lo:
                return n, ""
            if not dn > hi:
                break
    return verdict_from_returns(strobe_returns(strobe, scale, Omega), strobe, scale, rtol, no_impact, margin,
                                Omega)


def verdict_from_returns(d: np.ndarray, strobe: np.ndarray, scale: float, rtol: float, no_impact: bool,
                         margin: float = 1.0, Omega: float | None = None) -> tuple[int, str]:
    """The whole rule of :func:`transient_verdict`, from all the returns.

    :func:`transient_verdict` returns this verdict; it computes the returns only up to the
    period when the period is clear, and calls this function otherwise.

    Parameters
    ----------
    d : ndarray, shape (8,)
        ``strobe_returns(strobe, scale, Omega)`` (fractions of the orbit's size).
    strobe, scale, rtol, no_impact, margin, Omega
        As in :func:`transient_verdict`.

    Returns
    -------
    (int, str)
        As :func:`transient_verdict`.
    """
    when = _own_time(Omega)
    if no_impact:
        if d[0] <= margin * rtol or not np.isfinite(d[0]):
            return -1, ""
        return -1, (f"no impact in the window, but the free motion does not repeat yet "
                    f"(period-1 returns {d[0]:.2g} of the orbit > {margin * rtol:.2g}{when})")
    ok = np.flatnonzero(d <= rtol)
    period = int(ok[0]) + 1 if ok.size else 0
    tight = np.flatnonzero(d <= margin * rtol)
    if tight.size and (period == 0 or tight[0] + 1 == period):
        return period, ""
    close = np.flatnonzero(d <= MARGINAL * rtol)
    if close.size:
        n = int(close[0]) + 1
        return period, (f"period-{n} test marginal (returns {d[n - 1]:.2g} of the orbit, "
                        f"> {margin * rtol:.2g}{when})")
    for n in range(1, PERIOD_MAX + 1):
        conv, first, last = converging(strobe, n, scale, rtol, Omega)
        if conv:
            return period, (f"period-{n} returns still shrinking ({first:.2g} -> {last:.2g} of the "
                            f"orbit over the window)")
    return period, ""


def _own_time(Omega) -> str:
    """The note of a verdict judged in the oscillator's own time (Omega > 2 pi), else ''."""
    f = min(1.0, 2.0 * np.pi / float(Omega)) if Omega is not None and np.isfinite(Omega) and Omega > 0 else 1.0
    if f >= 1.0:
        return ""
    return (f"; judged in the oscillator's own time: a forcing period lasts {f:.2g} natural time "
            f"units 1/omega_n, the returns over {f:.2g}")


def mean_std(x: np.ndarray) -> tuple[float, float]:
    """Mean and sample standard deviation (``ddof = 1``), two-pass.

    The mean ``sum(x) / n``, then ``sqrt(sum((x - mean)^2) / (n - 1))``, each sum NumPy's
    pairwise ``np.add.reduce``: the values of ``x.mean()`` and ``x.std(ddof=1)`` (NumPy's own
    two-pass formula), without their Python layers (~10 us per point of a sweep).

    Parameters
    ----------
    x : ndarray, shape (n,), float64, n >= 2
        The series (any units).

    Returns
    -------
    (float, float)
        Mean and standard deviation, in the units of ``x``.
    """
    n = x.shape[0]
    m = np.add.reduce(x) / n
    d = x - m
    with np.errstate(over="ignore"):          # inf: summarize() fails such a point
        return float(m), float(np.sqrt(np.add.reduce(np.multiply(d, d, out=d)) / (n - 1)))


def batch_means(x: np.ndarray) -> tuple[float, int]:
    """Standard error of the mean of a stationary, correlated series by non-overlapping batch means.

    The series (the per-period amplitudes ``Q_k`` of a non-periodic attractor are
    correlated over a few periods: integrated autocorrelation times of 0.1-2.5
    periods were measured on the tight rig's chattering attractors) is cut into
    ``a = n // b`` batches of ``b = floor(sqrt(n))`` consecutive values (the
    oldest ``n - a b`` values are left out); the standard error of the mean is
    ``std(batch means, ddof=1) / sqrt(a)``, an estimate with ``a - 1`` degrees
    of freedom that stays honest when the batches are longer than the
    correlation time (Flegal & Jones, Ann. Statist. 38, 2010: batch length
    ``n^(1/2)``).  The i.i.d. ``std / sqrt(n)`` underestimates it by the square
    root of the statistical inefficiency (``1 + 2 sum rho_k``).

    Parameters
    ----------
    x : ndarray, shape (n,)
        The series (any units).

    Returns
    -------
    (float, int)
        The standard error (the units of ``x``) and its degrees of freedom
        ``a - 1``; ``(nan, 0)`` when there are fewer than 2 batches (n < 2) or a
        value is not finite, ``(0.0, a - 1)`` for a constant series.
    """
    x = np.asarray(x, float)
    n = x.size
    b = max(1, math.isqrt(n))
    a = n // b
    if a < 2 or not np.isfinite(x).all():
        return math.nan, 0
    means = np.add.reduce(x[n - a * b:].reshape(a, b), axis=1) / b      # (the batches' .mean(axis=1))
    return float(mean_std(means)[1] / math.sqrt(a)), a - 1


def amplitude_spread(period_amplitudes: np.ndarray) -> dict:
    """Spread of the per-period amplitude ``Q_k = Delta - min q`` over period k (Sec. 4.1).

    Returns ``amplitude_mean``, ``amplitude_std`` (sample standard deviation,
    ``ddof = 1``; 0 for one period), ``amplitude_min``, ``amplitude_max`` (all
    NaN for an empty or non-finite record), ``amplitude_sem`` and
    ``amplitude_sem_dof`` (standard error of ``amplitude_mean`` and its degrees of
    freedom by batch means, :func:`batch_means`; NaN and 0 for one period) and
    ``record_periods`` (the number of ``Q_k``).
    """
    a = np.asarray(period_amplitudes, float)
    n = a.size
    if n == 0 or not np.isfinite(a).all():
        nan = np.nan
        return dict(amplitude_mean=nan, amplitude_std=nan, amplitude_min=nan, amplitude_max=nan,
                    amplitude_sem=nan, amplitude_sem_dof=0, record_periods=n)
    sem, dof = batch_means(a)
    mean, std = mean_std(a) if n > 1 else (float(a[0]), 0.0)
    return dict(amplitude_mean=mean, amplitude_std=std, amplitude_min=float(np.minimum.reduce(a)),
                amplitude_max=float(np.maximum.reduce(a)), amplitude_sem=sem, amplitude_sem_dof=dof,
                record_periods=n)


def critical_value(sigmas, dof):
    """Two-sided critical value of Student's t with ``dof`` degrees of freedom at the false-alarm
    probability of ``sigmas`` normal standard deviations, ``p = 2 (1 - Phi(sigmas))``.

    ``sigmas = 4`` gives ``p = 6.3e-5``: a critical value of 4.0 for many degrees of
    freedom, 4.6 for 30, 5.5 for 15, 10 for 6.  Array arguments broadcast; ``dof <= 0``
    gives NaN (no error estimate).

    Computed as scipy.stats computes ``t.isf(norm.sf(sigmas), dof)`` (``-stdtrit(dof, ndtr(-sigmas))``,
    bit for bit), by the special functions directly: scipy.stats' argument handling cost ~0.24 ms a
    call, at every non-periodic point's statistics test (issue 60).
    """
    from scipy.special import ndtr, stdtrit  # lazy: keeps scipy.special out of `vibeam run`'s start-up

    dof = np.asarray(dof, float)
    with np.errstate(invalid="ignore"):
        out = -stdtrit(np.where(dof > 0, dof, np.nan), ndtr(-np.asarray(sigmas, float)))
    return out if out.ndim else float(out)


def means_agree(mean_a, sem_a, dof_a, mean_b, sem_b, dof_b, sigmas: float = 4.0):
    """Do two means of (correlated) samples of one attractor agree?  Welch's two-sample test.

    ``|mean_a - mean_b| <= c sqrt(sem_a^2 + sem_b^2) + 1e-9 max(|mean_a|, |mean_b|)``
    with ``c`` the :func:`critical_value` of ``sigmas`` at the Welch-Satterthwaite
    degrees of freedom ``(sa^2 + sb^2)^2 / (sa^4 / dof_a + sb^4 / dof_b)``, so a short
    record widens the bound instead of raising false alarms (the 1e-9 floor is for
    periodic samples, std 0).  Two NaN means agree.  Arguments broadcast.

    Parameters
    ----------
    mean_a, mean_b : float or ndarray
        The means (same units).
    sem_a, sem_b : float or ndarray
        Their standard errors (:func:`batch_means`); NaN = unknown, then the means
        agree only within the floor.
    dof_a, dof_b : int or ndarray
        Degrees of freedom of the standard errors.
    sigmas : float
        The false-alarm probability as normal standard deviations (:func:`critical_value`).

    Returns
    -------
    bool or ndarray of bool
    """
    ma, mb = np.asarray(mean_a, float), np.asarray(mean_b, float)
    sa2, sb2 = np.asarray(sem_a, float) ** 2, np.asarray(sem_b, float) ** 2
    va, vb = np.asarray(dof_a, float), np.asarray(dof_b, float)
    with np.errstate(invalid="ignore", divide="ignore"):
        se2 = sa2 + sb2
        nu = se2 ** 2 / (np.where(sa2 > 0, sa2 ** 2 / va, 0.0) + np.where(sb2 > 0, sb2 ** 2 / vb, 0.0))
        c = critical_value(sigmas, np.where((se2 > 0) & np.isfinite(nu), nu, 1e12))
        bound = np.where(se2 > 0, c * np.sqrt(se2), 0.0)
        ok = np.abs(ma - mb) <= np.nan_to_num(bound, nan=0.0) + 1e-9 * np.maximum(np.abs(ma), np.abs(mb))
    ok = ok | (np.isnan(ma) & np.isnan(mb))
    return ok if ok.ndim else bool(ok)


def spread_agrees(a: dict, b: dict, sigmas: float = 4.0) -> bool:
    """Are two samples of an attractor consistent in the mean of their per-period amplitude?

    :func:`means_agree` of their ``amplitude_mean`` with the batch-means standard errors
    ``amplitude_sem`` (:func:`batch_means`).  A sample without ``amplitude_sem`` (made before
    it existed) is taken as independent values, ``std / sqrt(n)`` with ``n - 1`` degrees of
    freedom.  ``a``, ``b``: the outputs of :func:`amplitude_spread`.
    """
    def se(s):
        if "amplitude_sem" in s:
            return s["amplitude_sem"], s.get("amplitude_sem_dof", 0)
        n = max(int(s["record_periods"]), 1)
        return s["amplitude_std"] / math.sqrt(n), n - 1

    (sa, va), (sb, vb) = se(a), se(b)
    return bool(means_agree(a["amplitude_mean"], sa, va, b["amplitude_mean"], sb, vb, sigmas))


def window_verdict(Q: np.ndarray, tail_strobe: np.ndarray, scale: float, rtol: float,
                   no_impact: bool = False, Omega: float | None = None) -> str:
    """Is a long window of a non-periodic point a sample of one attractor?

    Parameters
    ----------
    Q : ndarray, shape (n,)
        Per-period amplitudes ``Q_k`` over the window (the statistics window of
        ``[sweep] statistics_periods``).
    tail_strobe : ndarray, shape (m, 2)
        Stroboscopic samples of the window's last periods.
    scale : float
        Size of the orbit (as :func:`transient_verdict`).
    rtol : float
        Tolerance of the period-n test.
    no_impact : bool
        No impact in the window's continuation.
    Omega : float, optional
        Forcing frequency (returns judged in the oscillator's own time, :func:`transient_verdict`).

    Returns
    -------
    str
        Why not ('' when it is): the window ends on a periodic orbit (period
        1..8 or the no-impact orbit within ``rtol``: a chaotic or slow transient
        that settled inside the window), or the means of ``Q_k`` over its two
        halves disagree (:func:`spread_agrees`, batch-means errors; checked for
        windows of 32 periods or more).
    """
    Q = np.asarray(Q, float)
    if tail_strobe.shape[0] >= 3:
        period, _ = transient_verdict(tail_strobe, scale, rtol, no_impact, Omega=Omega)
        if period != 0 and (period > 0 or strobe_returns(tail_strobe, scale, Omega)[0] <= rtol):
            what = "the no-impact orbit" if period == -1 else f"a period-{period} orbit"
            return f"the statistics window ends on {what} (a transient that settled inside it)"
    if Q.size >= 32:
        h = Q.size // 2
        a, b = amplitude_spread(Q[:h]), amplitude_spread(Q[h:])
        if not spread_agrees(a, b):
            return (f"the mean of Q_k differs between the halves of the statistics window "
                    f"({a['amplitude_mean']:.6g} then {b['amplitude_mean']:.6g})")
    return ""


def harmonic_amplitudes(q: np.ndarray, samples_per_period: int, n_harmonics: int = HARMONICS) -> np.ndarray:
    """Amplitudes of the harmonics ``0, Omega, ..., (n-1) Omega`` of a periodic record.

    Parameters
    ----------
    q : ndarray, shape (n_record * samples_per_period,)
        Uniform samples over whole forcing periods.
    samples_per_period : int
        Samples per forcing period (must exceed ``2 (n_harmonics - 1)``).

    Returns
    -------
    ndarray, shape (n_harmonics,)
        Mean value (k = 0) and single-sided amplitudes ``2 |X_k| / N`` (k >= 1),
        in the units of ``q``.
    """
    # bin k n_rec of the record's DFT equals bin k of the DFT of the period-averaged record
    # (exp(-2 pi i k n / spp) depends on n mod spp only), so one FFT of length spp suffices
    # whatever the number of periods (an FFT of a length with a large prime factor is slow)
    spp = samples_per_period
    n_rec = q.shape[0] // spp
    X = np.fft.rfft(np.add.reduce(q[: n_rec * spp].reshape(n_rec, spp), axis=0) / n_rec) / spp    # (.mean(axis=0))
    out = np.full(n_harmonics, np.nan)
    k = min(n_harmonics, X.shape[0])
    single = np.full(k, 2.0)
    single[0] = 1.0
    out[:k] = np.abs(X[:k]) * single
    return out


def period_minima(traj: Trajectory) -> np.ndarray:
    """Minimum of ``q`` over each recorded period, shape (n_record,): the method's exact
    ``period_min`` where it has one, else the samples of each period."""
    n_rec, spp = traj.n_record, traj.samples_per_period
    if traj.period_min is not None and np.shape(traj.period_min) == (n_rec,):
        return np.asarray(traj.period_min, float)
    return traj.samples[: n_rec * spp, 0].reshape(n_rec, spp).min(axis=1)


#: per-point contact outputs (issue 13) and the column of ``Trajectory.contacts`` each is made of
CONTACT_OUTPUTS = ("contact_duration", "contact_force_max", "penetration_max", "energy_per_impact")
#: the lower stop's contact outputs of a two-sided scene (the unprefixed ones are then the upper stop's)
CONTACT_OUTPUTS_LOWER = tuple(k + "_lower" for k in CONTACT_OUTPUTS)


def _contact_rows(c, n_impacts: int) -> dict:
    """The :data:`CONTACT_OUTPUTS` of contact rows ``c`` (k, 5), or of none (``c`` None)."""
    nan = np.nan
    if c is None or np.shape(c)[0] == 0:
        zero = 0.0 if n_impacts and c is None else nan
        return dict(contact_duration=zero, contact_force_max=nan, penetration_max=zero, energy_per_impact=nan)
    c = np.asarray(c, float)
    k = c.shape[0]
    force = c[:, 1]
    # (np.add.reduce(x) / k is np.mean(x): NumPy's mean is that sum and division)
    return dict(contact_duration=float(np.add.reduce(c[:, 0]) / k),
                contact_force_max=float(np.maximum.reduce(force)) if np.isfinite(force).all() else nan,
                penetration_max=float(np.maximum.reduce(c[:, 2])),
                energy_per_impact=float(np.add.reduce(c[:, 3]) / k))


def contact_stops(traj: Trajectory) -> np.ndarray | None:
    """The stop of each row of ``traj.contacts`` (0 upper, 1 lower), shape (k,); None for a
    one-stop trajectory or one whose rows cannot be assigned to a stop.

    ``traj.contact_stops`` where the solver gives it, else ``traj.impact_stops`` when the rows
    are one per impact (Newton's law: :func:`vibeam.models.core.event.newton_contact_rows`).
    """
    if traj.impact_stops is None or traj.contacts is None:
        return None
    n = np.shape(traj.contacts)[0]
    for s in (traj.contact_stops, traj.impact_stops):
        if s is not None and np.shape(s) == (n,):
            return np.asarray(s, int)
    return None


def contact_outputs(traj: Trajectory) -> dict:
    """Per-point contact outputs (nondimensional, per unit effective mass of the stop).

    From ``traj.contacts`` (one row per recorded contact: duration, peak force, largest
    penetration, energy lost, entry velocity; :data:`vibeam.models.core.integrator.C_DURATION` ...):
    ``contact_duration`` (mean over the record's contacts), ``contact_force_max`` (largest peak
    force), ``penetration_max`` (largest penetration) and ``energy_per_impact`` (mean energy
    lost per contact: the work done on the stop).  A trajectory without contact rows (an
    impulsive law whose solver records none) gives duration and penetration 0 and force and
    energy NaN when it has impacts; no impact: all NaN.

    Two stops (``traj.impact_stops`` set): the unprefixed outputs are the upper stop's
    contacts only and :data:`CONTACT_OUTPUTS_LOWER` (``contact_duration_lower`` ...) the lower
    stop's, rows assigned by :func:`contact_stops` (NaN for a stop without a recorded
    contact; all NaN when the rows cannot be assigned).  One stop: unchanged.
    """
    c = traj.contacts
    if traj.impact_stops is None:
        return _contact_rows(c, traj.n_impacts)
    ks = contact_stops(traj)
    if ks is None:
        if c is None:   # an impulsive law without rows: per stop as for one stop
            n_lo = traj.n_impacts_lower
            up, lo = _contact_rows(None, traj.n_impacts - n_lo), _contact_rows(None, n_lo)
        else:
            up = lo = {k: np.nan for k in CONTACT_OUTPUTS}
    else:
        c = np.asarray(c, float)
        up, lo = _contact_rows(c[ks == 0], 0), _contact_rows(c[ks == 1], 0)
    return {**up, **{k + "_lower": v for k, v in lo.items()}}


def _infinite(v) -> bool:
    """Whether an output of :func:`summarize` is a float, or an array of floats, holding an
    infinity (a float scalar by :func:`math.isinf`: NumPy's reduction costs ~20,000 instructions
    per scalar, a tenth of a point's summary in a Fig. 7 sweep)."""
    if isinstance(v, float):                    # Python's float and NumPy's float64
        return math.isinf(v)
    if isinstance(v, (np.floating, np.ndarray)) and v.dtype.kind == "f":
        return bool(np.isinf(v).any())
    return False


def summarize(traj: Trajectory, Delta: float, period_rtol: float = 1e-5) -> dict:
    """Per-point FRC outputs of a trajectory (all nondimensional).

    Returns a dict with ``amplitude`` (``Q = Delta - min q``, paper Sec. 4.1),
    its spread over the recorded periods (``amplitude_mean``, ``amplitude_std``,
    ``amplitude_min``, ``amplitude_max`` of ``Q_k = Delta - min q`` over period
    k, exact minima where the method locates them, and ``record_periods``:
    :func:`amplitude_spread`), ``q_max``, ``q_min``, ``period`` (1..8, 0 = not
    periodic within 8, -1 = no impact in the window), ``impacts_per_period``,
    ``impact_velocity`` (mean pre-impact velocity, NaN without impacts),
    ``strobe`` (n_record, 2), ``harmonics`` (6,), the contact outputs of
    :func:`contact_outputs` (:data:`CONTACT_OUTPUTS`), ``status`` and ``message``.
    ``status`` is the trajectory's, or ``unsettled`` when the stroboscopic map
    shows a transient that has not settled (:func:`transient_verdict`; the
    message gives the reason, then the dynamic outcome it replaces).  ``Delta``
    is the scene's gap; ``traj.Delta`` replaces it where an effect moved the stop.

    Two stops (``traj.impact_stops`` set): ``amplitude`` keeps its meaning (the upper stop's
    ``Delta - min q``), ``impacts_per_period`` and ``impact_velocity`` are the upper stop's,
    and ``impacts_per_period_lower``, ``impact_velocity_lower`` (mean normal pre-impact speed
    ``|q'-|``) the lower stop's; ``period`` is -1 only without impacts on either stop.  The
    contact outputs likewise: unprefixed the upper stop's, ``*_lower`` the lower stop's
    (:func:`contact_outputs`).
    """
    n_rec = traj.n_record
    if traj.Delta is not None:
        Delta = traj.Delta
    two = traj.impact_stops is not None
    if traj.status != "failed" and not (math.isfinite(traj.q_min) and math.isfinite(traj.q_max)
                                        and np.isfinite(traj.samples).all()):
        # a state of 1e300 overflows the exact flows: no number of this record is a result
        traj = replace(traj, status="failed", message="the motion's numbers overflow double precision (a "
                       "non-finite state in the record)" + (f"; {traj.status}: {traj.message}"
                                                            if traj.status != "ok" else ""))
    if traj.status == "failed":
        nan = np.nan
        out = dict(amplitude=nan, **amplitude_spread(np.full(n_rec, nan)), q_max=nan, q_min=nan,
                   period=0, impacts_per_period=nan, impact_velocity=nan,
                   strobe=np.full((n_rec, 2), nan), harmonics=np.full(HARMONICS, nan),
                   **{k: nan for k in CONTACT_OUTPUTS}, status=traj.status, message=traj.message)
        if two:
            out.update(impacts_per_period_lower=nan, impact_velocity_lower=nan,
                       **{k: nan for k in CONTACT_OUTPUTS_LOWER})
        if traj.extra.get("stop_impacts") is not None:
            sz = np.shape(traj.extra["stop_impacts"])
            out.update(stop_impacts_per_period=np.full(sz, nan), stop_impact_velocity=np.full(sz, nan))
        return out
    q = traj.samples[:, 0]
    scale = max(traj.q_max - traj.q_min, np.max(np.abs(traj.samples[:, 1])) if q.size else 0.0, 1e-300)
    period, why = transient_verdict(traj.strobe, scale, period_rtol, traj.n_impacts == 0, Omega=traj.Omega)
    status, message = traj.status, traj.message
    if why:
        message = f"unsettled: {why}" + (f"; {status}: {message}" if status != "ok" else "")
        status = "unsettled"
    iv = traj.impact_velocities
    n_up = traj.n_impacts - traj.n_impacts_lower
    per_stop = traj.extra.get("stop_impacts")
    if per_stop is not None:
        # stops at other points (codes 2, 3, ...): the upper stop's outputs are its own impacts
        n_up = int(per_stop[0])
    if two:
        lower = traj.impact_stops == 1
        iv_all, iv, iv_l = iv, iv[traj.impact_stops == 0], iv[lower]
    out = dict(
        amplitude=Delta - traj.q_min,
        **amplitude_spread(Delta - period_minima(traj)),
        q_max=traj.q_max,
        q_min=traj.q_min,
        period=period,
        impacts_per_period=n_up / n_rec if n_rec else np.nan,
        impact_velocity=float(np.mean(iv)) if iv.size else np.nan,
        strobe=traj.strobe.copy(),
        harmonics=harmonic_amplitudes(q, traj.samples_per_period),
        **contact_outputs(traj),
        status=status,
        message=message,
    )
    if two:
        out.update(impacts_per_period_lower=traj.n_impacts_lower / n_rec if n_rec else np.nan,
                   impact_velocity_lower=float(np.mean(iv_l)) if iv_l.size else np.nan)
    if per_stop is not None:
        # every stop by its code (0 upper and 1 lower at the mass, 2 + i the point stop i)
        vel = np.full(per_stop.size, np.nan)
        for c in range(per_stop.size):
            sel = iv_all[traj.impact_stops == c]
            if sel.size:
                vel[c] = float(np.mean(sel))
        out.update(stop_impacts_per_period=np.asarray(per_stop, float) / n_rec if n_rec else
                   np.full(per_stop.size, np.nan), stop_impact_velocity=vel)
    over = sorted(k for k, v in out.items() if _infinite(v))
    if over:
        # an output no double can hold (a start of 1e300: its energy, its spread): the point's
        # numbers are not results -- failed, never ok with a made-up amplitude
        why = f"the motion's numbers overflow double precision ({', '.join(over)} infinite)"
        return summarize(replace(traj, status="failed", message=why + (f"; {status}: {message}" if status != "ok"
                                                                        else "")), Delta, period_rtol)
    return out
