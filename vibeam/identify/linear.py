"""Identification of the rig's linear parameters (paper Sec. 6.1) and the statistics shared
with the vibro-impact fit (:mod:`vibeam.identify.fit`).

The paper identifies its rig model step by step (Secs. 6.1 and 7):

1. the damping ratio beta_S from a free decay (Fig. 30a): :func:`log_decrement` (the decay
   of the extrema, logarithmic decrement) and :func:`fit_decay` (least squares of the damped
   response), each with a standard error;
2. the natural frequency f_n and the gain gamma by fitting Eq. 43 without the stop to the
   FRC measured around f_n (Fig. 30c): :func:`fit_linear`, closed form :func:`eq43_amplitude`;
3. R and gamma around 2 f_n from the vibro-impact FRC (Sec. 7, Fig. 31):
   :func:`vibeam.identify.fit.fit_case`.

The coefficient of restitution picked from the sensor's time series (Sec. 5.1, Table 1) is
the ``sensor`` effect's identification, :mod:`vibeam.engine.sensor`.

Standard errors (:func:`uncertainty`) are the usual linearised ones: the covariance
``s^2 (J^T J)^-1`` at the solution, ``J`` the Jacobian of the weighted residuals and
``s^2 = sum r^2 / (n - p)`` the residual variance (Seber & Wild, *Nonlinear Regression*,
1989, Sec. 2.1); with a robust loss Huber's covariance of an M-estimator (Huber, *Robust
Statistics*, 1981, Sec. 7.6), which uses the loss's psi and psi' in place of r and 1.
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from pathlib import Path

import matplotlib
import numpy as np

from vibeam.case.contact import model_with
from vibeam.case.schema import parse_case
from vibeam.case.text import case_dump, to_toml
from vibeam.errors import case_error
from vibeam.io.inputs import column_floats as floats, read_csv_table
from vibeam.io.netcdf import parameter_units
from vibeam.io.outdir import write_text_file
from vibeam.io.reference import read_reference
from vibeam.io.results import write_results
from vibeam.models import linear_amplitude
from vibeam.models.scene import outputs
from vibeam.plots import style
from vibeam.plots import sweep as plot_sweep
from vibeam.plots.lazy import plt
from vibeam.plots.sweep import save_close

#: a singular value of the column-scaled Jacobian below this fraction of the largest is
#: treated as zero: finite-difference Jacobians carry relative errors of ~1e-7 (step ~ eps^(1/3)),
#: so a smaller singular value cannot be told from a direction the data do not determine
RANK_RTOL = 1e-8

#: the three parameters of Eq. 43 fitted by :func:`fit_linear` (case-file names)
EQ43_PARAMS = ("natural_frequency_hz", "damping_ratio", "gain")

def param_unit(name: str) -> str:
    """Unit of a model key or parameter path in UDUNITS syntax (``gain`` -> ``V-1``, ``gap_mm``
    -> ``mm``, ...): :func:`vibeam.io.netcdf.parameter_units`, the results' one table."""
    return parameter_units(name)


# ============================================================================ statistics
@dataclass
class Uncertainty:
    """Linearised uncertainty of a least-squares estimate.

    Attributes
    ----------
    covariance : ndarray, shape (p, p)
        ``s^2 (J^T J)^-1`` (pseudo-inverse when rank deficient).
    standard_error : ndarray, shape (p,)
        Square roots of the diagonal; ``inf`` for a parameter the data do not determine,
        NaN when there are no degrees of freedom left.
    correlation : ndarray, shape (p, p)
    s2 : float
        Residual variance ``sum w r^2 / (n - p)`` (in units of the weighted residual squared).
    dof : int
        ``n - p``.
    rank : int
        Numerical rank of the column-scaled Jacobian (threshold :data:`RANK_RTOL`).
    condition : float
        Its condition number.
    reliable : bool
        False when the estimate's standard errors should not be trusted; ``notes`` say why.
    notes : list of str
    """

    covariance: np.ndarray
    standard_error: np.ndarray
    correlation: np.ndarray
    s2: float
    dof: int
    rank: int
    condition: float
    reliable: bool
    notes: list = field(default_factory=list)


def loss_psi(r, loss: str, f_scale: float) -> tuple[np.ndarray, np.ndarray]:
    """``psi(r)`` and ``psi'(r)`` of scipy's losses (cost ``f_scale^2 rho((r/f_scale)^2) / 2`` per
    residual): ``psi = r rho'(z)``, ``psi' = rho'(z) + 2 z rho''(z)``, ``z = (r / f_scale)^2``.

    Raises
    ------
    vibeam.case.schema.CaseError
        On a loss scipy does not have.
    """
    r = np.asarray(r, float)
    z = (r / f_scale) ** 2
    if loss == "linear":
        d1, d2 = np.ones_like(z), np.zeros_like(z)
    elif loss == "soft_l1":
        d1, d2 = (1 + z) ** -0.5, -0.5 * (1 + z) ** -1.5
    elif loss == "huber":
        big = z > 1
        zz = np.where(big, z, 1.0)
        d1, d2 = np.where(big, zz ** -0.5, 1.0), np.where(big, -0.5 * zz ** -1.5, 0.0)
    elif loss == "cauchy":
        d1, d2 = 1 / (1 + z), -1 / (1 + z) ** 2
    elif loss == "arctan":
        d1, d2 = 1 / (1 + z * z), -2 * z / (1 + z * z) ** 2
    else:
        raise case_error(f"'--loss' = {loss!r} is not allowed; allowed: linear, soft_l1, huber, cauchy, arctan")
    return r * d1, d1 + 2 * z * d2


def uncertainty(J, r, names=(), psi=None, dpsi=None, at_bound=None) -> Uncertainty:
    """Standard errors and correlations from the Jacobian at a least-squares solution.

    Parameters
    ----------
    J : ndarray, shape (n, p)
        Jacobian of the residuals (already divided by each point's sigma) with respect to
        the parameters, at the solution.  Rows of points left out must be zero and their
        residuals zero, and they must not be counted in ``n`` (pass only the used rows).
    r : ndarray, shape (n,)
        Residuals at the solution.
    names : sequence of str
        Parameter names (for the notes).
    psi, dpsi : ndarray, shape (n,), optional
        ``psi(r)`` and ``psi'(r)`` of a robust loss (:func:`loss_psi`); None: least squares.
    at_bound : ndarray of bool, shape (p,), optional
        Parameters whose estimate sits on a bound.

    Returns
    -------
    Uncertainty
        ``s^2 (J^T J)^-1`` with ``s^2 = sum r^2 / (n - p)`` (Seber & Wild 1989, Sec. 2.1);
        for a robust loss Huber's M-estimator covariance, ``s^2 = K^2 [sum psi^2 / (n - p)] /
        [mean psi']^2`` with ``K = 1 + (p / n) var(psi') / mean(psi')^2`` (Huber, *Robust
        Statistics*, 1981, Sec. 7.6), which reduces to the former for ``psi = r``.  Computed
        by an SVD of the column-scaled Jacobian so that parameters of very different units
        do not fake a rank deficiency.
    """
    J = np.asarray(J, float)
    r = np.asarray(r, float)
    n, p = J.shape
    names = list(names) or [f"x{j}" for j in range(p)]
    ps = r if psi is None else np.asarray(psi, float)
    dps = np.ones(n) if dpsi is None else np.asarray(dpsi, float)
    Jw = J
    notes = []
    dof = n - p
    s2 = float(np.sum(ps * ps) / dof) if dof > 0 else float("nan")
    if psi is not None and n > 0:
        m = float(np.mean(dps))
        if m > 0:
            K = 1.0 + (p / n) * float(np.var(dps)) / m ** 2
            s2 = K * K * s2 / (m * m)
        else:
            s2 = float("nan")
            notes.append("the robust loss gives no weight to the residuals at the solution")
    if dof <= 0:
        notes.append(f"no degrees of freedom (n = {n} points for p = {p} parameters): no residual variance")
    col = np.sqrt(np.sum(Jw * Jw, axis=0))
    zero = col == 0
    scale = np.where(zero, 1.0, col)
    Js = Jw / scale
    if n == 0:
        S, Vt = np.zeros(0), np.eye(p)
    else:
        _, S, Vt = np.linalg.svd(Js, full_matrices=False)
    S_full = np.zeros(p)
    S_full[: S.size] = S
    smax = S_full.max() if p else 0.0
    keep = S_full > RANK_RTOL * smax if smax > 0 else np.zeros(p, bool)
    rank = int(keep.sum())
    cond = float(smax / S_full[keep].min()) if rank == p and rank else float("inf")
    Vt_full = np.zeros((p, p))
    Vt_full[: Vt.shape[0]] = Vt
    inv = np.zeros(p)
    with np.errstate(over="ignore", divide="ignore", invalid="ignore"):   # underflowing J: NaN, reported
        inv[keep] = 1.0 / S_full[keep] ** 2
        cov_s = (Vt_full.T * inv) @ Vt_full
        cov = s2 * cov_s / np.outer(scale, scale)
    se = np.sqrt(np.clip(np.diag(cov), 0.0, None))
    if rank < p:
        null = Vt_full[~keep] if Vt.shape[0] == p else np.eye(p)
        involved = [names[j] for j in range(p) if zero[j] or np.max(np.abs(null[:, j])) > 0.1]
        se = se.copy()
        for j in range(p):
            if names[j] in involved:
                se[j] = np.inf
        notes.append(f"rank deficient (rank {rank} < {p} parameters): the data do not determine "
                     f"{', '.join(involved)} separately")
    elif cond > 1e6:
        notes.append(f"ill-conditioned (condition number {cond:.2g} of the column-scaled Jacobian)")
    if at_bound is not None and np.any(at_bound):
        notes.append("estimate on a bound: " + ", ".join(n_ for n_, b in zip(names, at_bound) if b)
                     + " (the standard error assumes an interior minimum)")
    with np.errstate(invalid="ignore", divide="ignore"):
        corr = cov / np.outer(se, se)
    corr[~np.isfinite(corr)] = np.nan
    np.fill_diagonal(corr, np.where(np.isfinite(se) & (se > 0), 1.0, np.nan))
    if dof <= 0:
        se = np.full(p, np.nan)
    reliable = dof > 0 and rank == p and cond <= 1e6 and not (at_bound is not None and np.any(at_bound))
    return Uncertainty(cov, se, corr, s2, dof, rank, cond, bool(reliable), notes)


#: two-sided level of the test of the residual variance against the data's sigma
#: (:func:`noise_consistent`): a fit whose model and sigma are right fails it once in 1000
NOISE_TEST_LEVEL = 1e-3
#: the Gauss-Newton step still left at a converged solution, in standard errors, at most
#: (:func:`remaining_step`): a step of 0.1 SE changes the cost by ~0.005 (in sigma^2 units), far
#: more than ``least_squares``' ftol leaves
CONVERGED_STEP_SE = 0.1


def noise_interval(dof: int, level: float = NOISE_TEST_LEVEL) -> tuple[float, float]:
    """The range of ``s^2 = chi^2 / dof`` that residuals of the stated sigma reach with probability
    ``1 - level``: ``[chi2.ppf(level/2, dof) / dof, chi2.ppf(1 - level/2, dof) / dof]`` (``chi^2``
    the sum of the squared normalised residuals, chi-square distributed with ``dof`` degrees of
    freedom for a correct model and Gaussian noise of standard deviation sigma; e.g. dof = 48:
    [0.46, 1.81]).  ``(nan, nan)`` for ``dof < 1``."""
    from scipy.stats import chi2  # lazy: keeps scipy.stats (0.7 s) out of `vibeam regress` and `vibeam cost`

    if dof < 1:
        return math.nan, math.nan
    return float(chi2.ppf(level / 2, dof) / dof), float(chi2.ppf(1 - level / 2, dof) / dof)


def noise_consistent(s2: float, dof: int, level: float = NOISE_TEST_LEVEL) -> bool:
    """True when ``s2`` lies in :func:`noise_interval` ``(dof, level)``: the residuals scatter as the
    data's sigma says (False for NaN, no degrees of freedom, or ``s2`` outside)."""
    lo, hi = noise_interval(dof, level)
    return bool(math.isfinite(s2) and lo <= s2 <= hi)


def remaining_step(J, r, w=None) -> np.ndarray:
    """The Gauss-Newton step still left at ``x``: ``dx`` minimising ``sum w_i (r_i + J_i dx)^2``.

    Parameters
    ----------
    J : ndarray, shape (n, p)
        Jacobian of the (sigma-normalised) residuals at ``x``.
    r : ndarray, shape (n,)
        Residuals at ``x``.
    w : ndarray, shape (n,), optional
        IRLS weights of a robust loss (:func:`irls_weights`; default 1): with them ``dx = 0``
        exactly where the robust cost's gradient ``J^T (w r)`` vanishes.

    Returns
    -------
    ndarray, shape (p,)
        In the parameters' units; zero where the data do not determine a direction
        (minimum-norm solution).  Scale-free: the same for residuals and Jacobian both divided
        by a common sigma.
    """
    J = np.asarray(J, float)
    r = np.asarray(r, float)
    sw = np.sqrt(np.ones_like(r) if w is None else np.asarray(w, float))
    A = J * sw[:, None]
    col = np.sqrt(np.sum(A * A, axis=0))
    scale = np.where(col > 0, col, 1.0)
    if A.size == 0 or not np.isfinite(A).all() or not np.isfinite(r).all():
        return np.full(J.shape[1], np.nan)
    dx, *_ = np.linalg.lstsq(A / scale, -sw * r, rcond=RANK_RTOL)
    return dx / scale


# ============================================================================ CSV input
#: time steps and times of a free decay (s): a step below 1 ns (a sampling above 1 GHz) or a time beyond
#: 1e6 s (11.6 days) is not a record of the rig, and their powers in the fits underflow or overflow
DECAY_TIME_RANGE = (1e-9, 1e6)
#: largest displacement of a free decay (mm) whose squares the fits can sum without overflow
DECAY_MAX_MM = 1e100


def read_decay(path) -> tuple[np.ndarray, np.ndarray]:
    """A free-decay record: CSV with header ``t_s,U_mm`` (time in s, sensor displacement in mm).

    Returns
    -------
    t : ndarray, shape (n,)
        Increasing times (s).
    U : ndarray, shape (n,)
        Displacement at the sensor (mm).

    Raises
    ------
    vibeam.case.schema.CaseError
        On another header, a value that is not a finite number, times that do not increase,
        fewer than 20 samples, times or steps outside :data:`DECAY_TIME_RANGE`, or a displacement
        beyond :data:`DECAY_MAX_MM`; values are quoted as plain numbers.
    """
    head, rows = read_csv_table(path, "decay file")
    if sorted(head) != ["U_mm", "t_s"]:
        raise case_error(f"{path}: header {head!r} not allowed; a free decay has the columns 't_s,U_mm' (time in s, "
                     f"displacement at the sensor in mm) and no others")
    t = floats(path, head, rows, "t_s", what="decay file")
    U = floats(path, head, rows, "U_mm", what="decay file")
    if t.size < 20:
        raise case_error(f"{path}: {t.size} samples; a free decay needs at least 20")
    bad = np.flatnonzero(np.diff(t) <= 0)
    if bad.size:
        i = int(bad[0]) + 1
        raise case_error(f"{path}: 't_s' = {float(t[i])!r} (data row {i + 1}) after {float(t[i - 1])!r}: times must "
                         f"increase")
    lo, hi = DECAY_TIME_RANGE
    far = np.flatnonzero(np.abs(t) > hi)
    if far.size:
        i = int(far[0])
        raise case_error(f"{path}: 't_s' = {float(t[i])!r} (data row {i + 1}) is not allowed; allowed: times within "
                         f"+-{hi:g} s (a free decay of the rig lasts seconds)")
    dt = np.diff(t)
    if dt.min() < lo:
        i = int(np.flatnonzero(dt < lo)[0]) + 1
        raise case_error(f"{path}: 't_s' = {float(t[i])!r} (data row {i + 1}) is {float(dt[i - 1]):g} s after the row "
                         f"before; allowed: time steps of at least {lo:g} s")
    big = np.flatnonzero(np.abs(U) > DECAY_MAX_MM)
    if big.size:
        i = int(big[0])
        raise case_error(f"{path}: 'U_mm' = {float(U[i])!r} (data row {i + 1}) is not allowed; allowed: displacements "
                         f"within +-{DECAY_MAX_MM:g} mm")
    return t, U


# ============================================================================ Eq. 43 (linear)
def eq43_amplitude(f_hz, natural_frequency_hz, damping_ratio, gain, length_mm, voltage):
    """Steady-state amplitude at the sensor of Eq. 43 without the stop (mm).

    ``U = L q``, ``q = gamma V Omega^2 / sqrt((1 - Omega^2)^2 + (2 beta_S Omega)^2)`` with
    ``Omega = f / f_n`` (paper Eqs. 43-46 and Sec. 6: the sensor reads ``U(L_S) = q L``).

    Parameters
    ----------
    f_hz : array_like, shape (n,)
        Forcing frequencies (Hz).
    natural_frequency_hz, damping_ratio, gain : float
        f_n (Hz), beta_S, gamma (1/V).
    length_mm, voltage : float
        Beam length L (mm) and voltage amplitude V (V).

    Returns
    -------
    ndarray, shape (n,)
        Amplitude (half peak-to-peak) of the sensor displacement relative to the base (mm).
    """
    Om = np.asarray(f_hz, float) / natural_frequency_hz
    return length_mm * linear_amplitude(damping_ratio, gain * voltage, Om)


def eq43_jacobian(f_hz, natural_frequency_hz, damping_ratio, gain, length_mm, voltage):
    """Derivatives of :func:`eq43_amplitude` with respect to ``(f_n, beta_S, gamma)``, shape (n, 3).

    With ``D = (1 - W^2)^2 + (2 b W)^2``: ``dA/dgamma = A / gamma``,
    ``dA/db = -4 b W^2 A / D``, ``dA/dW = A (2 / W - D'(W) / (2 D))`` with
    ``D' = -4 W (1 - W^2) + 8 b^2 W`` and ``dW/df_n = -W / f_n``.
    """
    W = np.asarray(f_hz, float) / natural_frequency_hz
    b = damping_ratio
    D = (1 - W * W) ** 2 + (2 * b * W) ** 2
    A = eq43_amplitude(f_hz, natural_frequency_hz, damping_ratio, gain, length_mm, voltage)
    dD = -4 * W * (1 - W * W) + 8 * b * b * W
    dA_dW = A * (2.0 / W - 0.5 * dD / D)
    with np.errstate(invalid="ignore", divide="ignore"):
        dA_dg = np.where(gain != 0, A / gain, length_mm * voltage * W * W / np.sqrt(D))
    return np.column_stack([dA_dW * (-W / natural_frequency_hz), -4 * b * W * W * A / D, dA_dg])


@dataclass
class LinearFit:
    """Result of :func:`fit_linear` (Eq. 43 fitted to an FRC around f_n)."""

    parameters: list
    estimate: np.ndarray
    standard_error: np.ndarray
    correlation: np.ndarray
    values: dict              # all three Eq. 43 parameters (fitted and fixed)
    frequency_hz: np.ndarray
    amplitude_mm: np.ndarray
    sigma_mm: np.ndarray
    model_mm: np.ndarray
    residuals: np.ndarray     # model - data (mm)
    n_points: int
    s2: float
    cost: float
    evaluations: int
    message: str
    reliable: bool
    notes: list
    loss: str
    f_scale: float
    wall_time_s: float = 0.0
    length_mm: float = 0.0
    voltage: float = 0.0

    def table(self) -> str:
        return _param_table(self.parameters, self.estimate, self.standard_error)


def _param_table(names, est, se) -> str:
    lines = [f"{'parameter':<24}{'estimate':>14}{'std. error':>14}{'rel.':>9}  unit"]
    for n, x, s in zip(names, est, se):
        rel = f"{abs(s / x):9.2%}" if x != 0 and np.isfinite(s) else f"{'-':>9}"
        lines.append(f"{n:<24}{x:>14.6g}{s:>14.3g}{rel}  {param_unit(n)}")
    return "\n".join(lines)


def _initial_eq43(f, A, length_mm, voltage, fixed):
    """Starting values from the data: the peak (f_n), the half-power band (beta_S), the peak
    height ``L gamma V / (2 beta_S)`` (gamma); a value the data cannot give falls back to ``fixed``."""
    k = int(np.argmax(A))
    fn = float(f[k])
    if 0 < k < f.size - 1:   # vertex of the parabola through the peak and its neighbours
        x, y = f[k - 1:k + 2], A[k - 1:k + 2]
        c = np.polyfit(x, y, 2)
        if c[0] < 0:
            fn = float(np.clip(-c[1] / (2 * c[0]), x[0], x[-1]))
    half = A[k] / math.sqrt(2.0)
    lo = np.flatnonzero(A[:k] < half)
    hi = np.flatnonzero(A[k:] < half)
    beta = fixed.get("damping_ratio")
    if lo.size and hi.size:
        i, j = lo[-1], k + hi[0]
        f1 = np.interp(half, [A[i], A[i + 1]], [f[i], f[i + 1]])
        f2 = np.interp(half, [A[j], A[j - 1]], [f[j], f[j - 1]])
        if f2 > f1:
            beta = (f2 - f1) / (2 * fn)
    if not beta or beta <= 0:
        beta = 0.02
    beta = min(beta, 0.5)
    gain = A[k] * 2 * beta / (length_mm * voltage) if length_mm * voltage > 0 else fixed.get("gain", 1.0)
    return {"natural_frequency_hz": fn, "damping_ratio": beta, "gain": gain}


def fit_linear(f_hz, amplitude_mm, length_mm: float, voltage: float, sigma_mm=None,
               params=EQ43_PARAMS, fixed: dict | None = None, x0: dict | None = None,
               loss: str = "linear", f_scale: float = 3.0) -> LinearFit:
    """Fit Eq. 43 without the stop to an FRC measured around f_n (paper Sec. 6.1, Fig. 30c).

    Parameters
    ----------
    f_hz, amplitude_mm : array_like, shape (n,)
        Measured forcing frequencies (Hz) and amplitudes at the sensor (mm).
    length_mm, voltage : float
        L (mm) and the voltage amplitude V (V) of the measurement.
    sigma_mm : array_like, shape (n,), optional
        Standard deviation of each amplitude (mm); None: equal weights (the standard errors
        then come from the scatter of the residuals alone).
    params : sequence of str
        The fitted subset of ``("natural_frequency_hz", "damping_ratio", "gain")``.
    fixed : dict, optional
        Values of the parameters not fitted (and fall-back starting values).
    x0 : dict, optional
        Starting values; default from the data (:func:`_initial_eq43`).
    loss, f_scale : str, float
        ``scipy.optimize.least_squares`` loss and its scale in units of sigma.

    Returns
    -------
    LinearFit

    Raises
    ------
    vibeam.case.schema.CaseError
        On a parameter name outside Eq. 43's three, or fewer points than parameters.
    """
    # lazy: keeps scipy.optimize (0.35 s) out of `vibeam regress` and `vibeam cost`
    from scipy.optimize import least_squares

    t0 = time.perf_counter()
    f = np.asarray(f_hz, float)
    A = np.asarray(amplitude_mm, float)
    o = np.argsort(f)
    f, A = f[o], A[o]
    sig = np.ones_like(f) if sigma_mm is None else np.asarray(sigma_mm, float)[o]
    params = list(params)
    for p in params:
        if p not in EQ43_PARAMS:
            raise case_error(f"'--params' = {p!r} is not a parameter of Eq. 43; allowed: {', '.join(EQ43_PARAMS)}")
    if len(set(params)) != len(params):
        raise case_error(f"'--params' = {','.join(params)!r}: a parameter is repeated")
    if f.size < len(params):
        raise case_error(f"{f.size} points cannot determine {len(params)} parameters")
    fixed = dict(fixed or {})
    start = _initial_eq43(f, A, length_mm, voltage, fixed)
    start.update({k: v for k, v in fixed.items() if k not in params})
    start.update(x0 or {})
    idx = [EQ43_PARAMS.index(p) for p in params]
    lb = np.array([0.0, 0.0, 0.0])[idx]
    ub = np.array([np.inf, 1.0 - 1e-9, np.inf])[idx]
    xs = np.array([start[p] for p in params], float)
    xs = np.clip(xs, lb + 1e-12 * np.maximum(np.abs(xs), 1e-300), ub)

    def full(x):
        v = dict(start)
        v.update(zip(params, x))
        return v

    def fun(x):
        v = full(x)
        return (eq43_amplitude(f, v["natural_frequency_hz"], v["damping_ratio"], v["gain"], length_mm, voltage)
                - A) / sig

    def jac(x):
        v = full(x)
        J = eq43_jacobian(f, v["natural_frequency_hz"], v["damping_ratio"], v["gain"], length_mm, voltage)
        return J[:, idx] / sig[:, None]

    res = least_squares(fun, xs, jac=jac, bounds=(lb, ub), loss=loss, f_scale=f_scale, x_scale="jac",
                        xtol=1e-12, ftol=1e-12, gtol=1e-12, max_nfev=200)
    r = fun(res.x)
    psi, dpsi = loss_psi(r, loss, f_scale)
    unc = uncertainty(jac(res.x), r, params, psi=psi if loss != "linear" else None, dpsi=dpsi,
                      at_bound=res.active_mask != 0)
    v = full(res.x)
    model = eq43_amplitude(f, v["natural_frequency_hz"], v["damping_ratio"], v["gain"], length_mm, voltage)
    notes = list(unc.notes)
    if sigma_mm is None:
        notes.append("no 'sigma' column: equal weights, standard errors from the residual scatter")
    if res.status <= 0:
        notes.append(f"optimizer did not converge: {res.message}")
    # the rule of vibeam.identify.fit.verdict: finite standard errors, residuals consistent with sigma
    reliable = unc.reliable and res.status > 0 and bool(np.all(np.isfinite(unc.standard_error)))
    if sigma_mm is not None and not noise_consistent(unc.s2, unc.dof):
        reliable = False
        lo, hi = noise_interval(unc.dof)
        notes.append(f"s^2 = {unc.s2:.3g} (in sigma^2) is outside [{lo:.3g}, {hi:.3g}], the chi-square spread of "
                     f"{unc.dof} degrees of freedom (level {NOISE_TEST_LEVEL:g}): the residuals do not scatter as "
                     f"the data's sigma says")
    return LinearFit(params, res.x.copy(), unc.standard_error, unc.correlation, v, f, A, sig, model, model - A,
                     f.size, unc.s2, float(res.cost), int(res.nfev), str(res.message),
                     reliable, notes, loss, f_scale, time.perf_counter() - t0,
                     length_mm, voltage)


def loss_cost(r, loss: str, f_scale: float) -> float:
    """The cost ``scipy.optimize.least_squares`` reports (``res.cost``) for residuals ``r``:
    ``f_scale^2 / 2 sum rho((r / f_scale)^2)`` with scipy's ``rho`` of ``loss`` (``linear``:
    ``0.5 sum r^2``).  NaN for a loss scipy does not have."""
    z = (np.asarray(r, float) / f_scale) ** 2
    with np.errstate(over="ignore", invalid="ignore"):
        if loss == "linear":
            rho = z
        elif loss == "soft_l1":
            rho = 2.0 * (np.sqrt(1.0 + z) - 1.0)
        elif loss == "huber":
            rho = np.where(z <= 1.0, z, 2.0 * np.sqrt(z) - 1.0)
        elif loss == "cauchy":
            rho = np.log1p(z)
        elif loss == "arctan":
            rho = np.arctan(z)
        else:
            return math.nan
        return float(0.5 * f_scale ** 2 * np.sum(rho))


def irls_weights(r, loss: str, f_scale: float) -> np.ndarray:
    """``rho'(z)``, ``z = (r / f_scale)^2``, of scipy's losses: the weight a robust loss gives each
    residual in its iteratively reweighted least-squares form (1 for ``linear``)."""
    z = (np.asarray(r, float) / f_scale) ** 2
    if loss == "linear":
        return np.ones_like(z)
    if loss == "soft_l1":
        return 1.0 / np.sqrt(1.0 + z)
    if loss == "huber":
        return np.where(z <= 1.0, 1.0, 1.0 / np.sqrt(np.maximum(z, 1.0)))
    if loss == "cauchy":
        return 1.0 / (1.0 + z)
    if loss == "arctan":
        return 1.0 / (1.0 + z * z)
    raise case_error(f"'--loss' = {loss!r} is not allowed; allowed: linear, soft_l1, huber, cauchy, arctan")


# ============================================================================ free decay
@dataclass
class DecayEstimate:
    """beta_S (and f_n) from a free decay, with standard errors.

    ``method`` is ``"log_decrement"`` (:func:`log_decrement`) or ``"damped_fit"``
    (:func:`fit_decay`).  ``extra`` holds method-specific arrays for the report and plot.
    """

    method: str
    damping_ratio: float
    damping_ratio_se: float
    natural_frequency_hz: float
    natural_frequency_hz_se: float
    damped_frequency_hz: float
    n_used: int
    notes: list = field(default_factory=list)
    extra: dict = field(default_factory=dict)


def _noise_std(U) -> float:
    """Robust noise estimate of a densely sampled record: the MAD of second differences
    (a smooth signal's second difference is ~ (omega dt)^2 of it) over sqrt(6)."""
    d2 = np.diff(np.asarray(U, float), 2)
    if d2.size == 0:
        return 0.0
    return float(1.4826 * np.median(np.abs(d2 - np.median(d2))) / math.sqrt(6.0))


def _dominant_frequency(t, U) -> float:
    """Frequency (Hz) of the largest spectral line of ``U - mean`` (Hann window, zero padding
    and a parabola through the peak bin)."""
    dt = float(np.median(np.diff(t)))
    x = (U - U.mean()) * np.hanning(U.size)
    nfft = 1 << int(math.ceil(math.log2(U.size * 8)))
    X = np.abs(np.fft.rfft(x, nfft))
    k = int(np.argmax(X[1:])) + 1
    if 1 <= k < X.size - 1:
        a, b, c = np.log(X[k - 1:k + 2] + 1e-300)
        k = k + 0.5 * (a - c) / (a - 2 * b + c) if (a - 2 * b + c) != 0 else k
    return float(k / (nfft * dt))


def _extrema(t, U, f_d: float):
    """Times and values of the alternating extrema of a decaying oscillation, each refined by
    a least-squares parabola over +-1/10 of a damped period (averages the noise)."""
    from scipy.signal import find_peaks  # lazy: keeps scipy.signal (0.75 s) out of `vibeam regress` and `vibeam cost`

    dt = float(np.median(np.diff(t)))
    per = 1.0 / f_d
    dist = max(1, int(0.7 * per / dt))
    half = max(2, int(0.1 * per / dt))
    out = []
    for sign in (1.0, -1.0):
        idx, _ = find_peaks(sign * U, distance=dist)
        for i in idx:
            lo, hi = max(0, i - half), min(U.size, i + half + 1)
            if hi - lo < 5:
                continue
            tt = t[lo:hi] - t[i]
            c = np.polyfit(tt, U[lo:hi], 2)
            if sign * c[0] >= 0:          # not a maximum (minimum) after all
                continue
            tv = -c[1] / (2 * c[0])
            if abs(tv) > (t[hi - 1] - t[lo]) / 2:
                continue
            out.append((t[i] + tv, np.polyval(c, tv), sign))
    out.sort()
    # keep an alternating sequence (max, min, max, ...)
    seq = []
    for e in out:
        if seq and seq[-1][2] == e[2]:
            if e[2] * e[1] > seq[-1][2] * seq[-1][1]:
                seq[-1] = e
            continue
        seq.append(e)
    if not seq:
        return np.zeros(0), np.zeros(0)
    a = np.array(seq)
    return a[:, 0], a[:, 1]


def log_decrement(t, U, min_snr: float = 10.0) -> DecayEstimate:
    """beta_S by the logarithmic decrement of a free decay (paper Sec. 6.1, Fig. 30a).

    The extrema of a damped oscillation ``c + A exp(-sigma t) cos(omega_d t + phi)`` are
    equally spaced by ``pi / omega_d``, and their peak-to-peak differences ``p_k = |U_{k+1} -
    U_k|`` decay as ``exp(-sigma t_k)`` whatever the offset ``c`` (the logarithmic decrement
    ``delta = sigma 2 pi / omega_d``).  A weighted straight line through ``ln p_k`` against
    ``t_k`` starts ``sigma``; since neighbouring differences share an extremum, their errors are
    correlated and the final ``sigma`` and its standard error come from the extrema themselves,
    ``E_k = c +- a exp(-sigma t_k)`` by least squares (independent errors: each extremum is the
    vertex of its own parabola).  A line through the extremum times gives ``omega_d``.  Then ``omega_n = sqrt(omega_d^2 + sigma^2)``, ``beta_S = sigma /
    omega_n`` (logarithmic decrement ``delta = sigma 2 pi / omega_d``), errors propagated to
    first order.  Pairs with ``p_k`` below ``min_snr`` times the noise (MAD of the record's
    second differences) are not used: there ``ln p`` is biased by the noise.

    Parameters
    ----------
    t, U : ndarray, shape (n,)
        Time (s) and displacement (any unit).
    min_snr : float
        Smallest peak-to-peak difference used, in noise standard deviations.

    Returns
    -------
    DecayEstimate
        ``extra``: ``extremum_time_s``, ``extremum_value``, ``used`` (pairs), ``log_decrement``.

    Raises
    ------
    vibeam.case.schema.CaseError
        If fewer than four extrema stand above the noise.
    """
    t = np.asarray(t, float)
    U = np.asarray(U, float)
    f0 = _dominant_frequency(t, U)
    te, ue = _extrema(t, U, f0)
    noise = _noise_std(U)
    if te.size < 4:
        raise case_error(f"free decay: found {te.size} extrema; the log decrement needs at least 4 (is the "
                     f"record a decaying oscillation of a few periods?)")
    p = np.abs(np.diff(ue))
    tk = te[:-1]
    use = p > min_snr * max(noise, 1e-300)
    # only the first run of pairs above the noise floor: later pairs are noise-dominated
    i0 = int(np.argmax(use)) if use.any() else 0
    i1 = i0
    while i1 < use.size and use[i1]:
        i1 += 1
    use[:] = False
    use[i0:i1] = True
    k_used = i1 - i0
    if k_used < 3:
        raise case_error(f"free decay: only {k_used} peak-to-peak differences stand {min_snr:g} noise "
                     f"deviations ({noise:.3g}) above the noise; need at least 3")
    # starting decay rate: weighted straight line through ln p_k (weights p_k^2)
    X = np.column_stack([np.ones(k_used), tk[use]])
    y = np.log(p[use])
    w = p[use] ** 2
    sw = np.sqrt(w)
    coef, *_ = np.linalg.lstsq(X * sw[:, None], y * sw, rcond=None)
    # adjacent differences share an extremum (correlated errors): the decay rate and its error
    # come from the extrema themselves, E_k = c + s_k a exp(-sigma (t_k - t_0)), s_k = +-1,
    # whose errors are independent (disjoint parabola windows)
    # lazy: keeps scipy.optimize (0.35 s) out of `vibeam regress` and `vibeam cost`
    from scipy.optimize import least_squares

    te_used = te[i0:i1 + 1]
    ev = ue[i0:i1 + 1]
    sg = np.where(np.arange(ev.size) % 2 == 0, 1.0, -1.0) * np.sign(ev[0] - np.mean(ev))
    tr = te_used - te_used[0]

    def fe(x):
        return x[0] + sg * x[1] * np.exp(-x[2] * tr) - ev

    def je(x):
        e = np.exp(-x[2] * tr)
        return np.column_stack([np.ones_like(tr), sg * e, -sg * x[1] * tr * e])

    c0 = float(np.mean(ev[-2:])) if ev.size >= 2 else 0.0
    x0 = np.array([c0, abs(ev[0] - c0), max(-coef[1], 1e-12)])
    sol = least_squares(fe, x0, jac=je, xtol=1e-14, ftol=1e-14, gtol=1e-14)
    ue_unc = uncertainty(je(sol.x), fe(sol.x), ["offset", "a", "sigma"])
    sigma, se_sigma = float(sol.x[2]), float(ue_unc.standard_error[2])
    # damped period from the extremum times: t_k = t_0 + k pi / omega_d
    n_used_ext = te_used.size
    kk = np.arange(n_used_ext)
    Xt = np.column_stack([np.ones(n_used_ext), kk])
    ct, *_ = np.linalg.lstsq(Xt, te_used, rcond=None)
    rt = te_used - Xt @ ct
    s2t = float(rt @ rt / (n_used_ext - 2)) if n_used_ext > 2 else float("nan")
    covt = s2t * np.linalg.inv(Xt.T @ Xt)
    half_T, se_half_T = ct[1], math.sqrt(max(covt[1, 1], 0.0))
    wd = math.pi / half_T
    se_wd = wd * se_half_T / half_T
    wn = math.hypot(wd, sigma)
    beta = sigma / wn
    dbeta_ds, dbeta_dwd = wd * wd / wn ** 3, -sigma * wd / wn ** 3
    se_beta = math.hypot(dbeta_ds * se_sigma, dbeta_dwd * se_wd)
    se_wn = math.hypot(wd * se_wd, sigma * se_sigma) / wn
    notes = [f"{k_used} peak-to-peak differences of {te.size - 1} used (noise {noise:.3g}, threshold "
             f"{min_snr:g} x noise)"]
    return DecayEstimate("log_decrement", beta, se_beta, wn / (2 * math.pi), se_wn / (2 * math.pi),
                         wd / (2 * math.pi), k_used, notes,
                         extra={"extremum_time_s": te, "extremum_value": ue, "used": use,
                                "peak_to_peak": p, "log_decrement": sigma * 2 * math.pi / wd,
                                "noise_std": noise, "sigma_1_s": sigma})


def damped_response(t, natural_frequency_hz, damping_ratio, a, b, c):
    """``c + exp(-beta w_n t) (a cos w_d t + b sin w_d t)``, ``w_d = w_n sqrt(1 - beta^2)``: the
    free response of Eq. 43 without forcing and stop (``t`` from the record's start)."""
    wn = 2 * math.pi * natural_frequency_hz
    sg = damping_ratio * wn
    wd = wn * math.sqrt(1 - damping_ratio ** 2)
    return c + np.exp(-sg * t) * (a * np.cos(wd * t) + b * np.sin(wd * t))


def fit_decay(t, U, start: DecayEstimate | None = None) -> DecayEstimate:
    """beta_S and f_n by least squares of the damped free response to the whole record.

    Model :func:`damped_response` (5 parameters: f_n, beta_S, a, b, offset c), started from
    the logarithmic decrement (amplitudes by linear least squares), solved by
    ``scipy.optimize.least_squares`` with the analytic Jacobian; standard errors
    ``s^2 (J^T J)^-1`` (:func:`uncertainty`), the noise being white.

    Returns
    -------
    DecayEstimate
        ``extra``: ``parameters``, ``estimate``, ``standard_error``, ``correlation``,
        ``residual_rms``, ``model`` (fitted record).
    """
    # lazy: keeps scipy.optimize (0.35 s) out of `vibeam regress` and `vibeam cost`
    from scipy.optimize import least_squares

    t = np.asarray(t, float)
    U = np.asarray(U, float)
    s = start if start is not None else log_decrement(t, U)
    tt = t - t[0]
    fn0, b0 = s.natural_frequency_hz, s.damping_ratio

    def basis(fn, beta):
        wn = 2 * math.pi * fn
        wd = wn * math.sqrt(1 - beta * beta)
        e = np.exp(-beta * wn * tt)
        return np.column_stack([e * np.cos(wd * tt), e * np.sin(wd * tt), np.ones_like(tt)])

    lin, *_ = np.linalg.lstsq(basis(fn0, b0), U, rcond=None)
    x0 = np.array([fn0, b0, *lin])

    def fun(x):
        return damped_response(tt, *x) - U

    def jac(x):
        fn, beta, a, b, _ = x
        wn = 2 * math.pi * fn
        q = math.sqrt(1 - beta * beta)
        wd = wn * q
        sg = beta * wn
        e = np.exp(-sg * tt)
        cs, sn = np.cos(wd * tt), np.sin(wd * tt)
        osc = a * cs + b * sn
        d_sg = -tt * e * osc                      # d/d sigma
        d_wd = tt * e * (-a * sn + b * cs)        # d/d omega_d
        d_fn = 2 * math.pi * (d_sg * beta + d_wd * q)
        d_beta = d_sg * wn + d_wd * (-wn * beta / q)
        return np.column_stack([d_fn, d_beta, e * cs, e * sn, np.ones_like(tt)])

    res = least_squares(fun, x0, jac=jac, bounds=([0, 0, -np.inf, -np.inf, -np.inf],
                                                  [np.inf, 1 - 1e-9, np.inf, np.inf, np.inf]),
                        x_scale="jac", xtol=1e-12, ftol=1e-12, gtol=1e-12)
    names = ["natural_frequency_hz", "damping_ratio", "a", "b", "offset"]
    unc = uncertainty(jac(res.x), fun(res.x), names, at_bound=res.active_mask != 0)
    fn, beta = res.x[0], res.x[1]
    notes = list(unc.notes)
    if res.status <= 0:
        notes.append(f"optimizer did not converge: {res.message}")
    return DecayEstimate("damped_fit", float(beta), float(unc.standard_error[1]), float(fn),
                         float(unc.standard_error[0]), float(fn * math.sqrt(1 - beta * beta)), int(t.size), notes,
                         extra={"parameters": names, "estimate": res.x.copy(), "standard_error": unc.standard_error,
                                "correlation": unc.correlation, "residual_rms": float(math.sqrt(unc.s2)),
                                "model": damped_response(tt, *res.x), "reliable": unc.reliable})


# ============================================================================ reports (vibeam fit)
def _model_values(case):
    """``(spec, L_mm, V, {f_n, beta_S, gamma})`` of a physical scene (SDOF or beam)."""
    spec = case.model_spec()
    if not getattr(spec, "physical", False):
        raise case_error(f"{case.name}: the linear steps need a physical scene (natural_frequency_hz or a beam, "
                     f"length_mm, gain, voltage), not the nondimensional keys")
    L_mm = float(spec.system.length_mm)
    gain, voltage = spec.excitation.shaker(L_mm)
    return spec, L_mm, float(voltage), {
        "natural_frequency_hz": float(outputs(spec.scene()).natural_frequency_hz),
        "damping_ratio": float(spec.system.damping_ratio), "gain": float(gain)}


def _case_updates(spec, values: dict) -> tuple[dict, list]:
    """``[model]`` updates for Eq. 43 values: f_n is ``natural_frequency_hz`` of an SDOF scene and
    ``calibrate.f1_hz`` of a calibrated beam (an uncalibrated beam's f_n is not a key: noted)."""
    upd, notes = {}, []
    for k, v in values.items():
        u, n = spec.case_update(k, v)
        upd.update(u)
        notes += n
    return upd, notes


def _write_case(case, updates, suffix, comment, out_dir) -> Path:
    data = case_dump(case)
    data["name"] = f"{case.name}-{suffix}"
    model = model_with(case.model, updates)
    data["model"] = model
    data["description"] = f"{case.name} with {comment} (vibeam fit)"
    order = ["name", "description", "model", "effects", "sweep", "quick", "regress", "assess", "map", "run"]
    data = {k: data[k] for k in order if k in data}
    text = f"# {comment}\n" + to_toml(data) + "\n"
    parse_case(text, f"{case.name}-{suffix}.toml")
    path = Path(out_dir) / f"{case.name}-{suffix}.toml"
    write_text_file(path, text)
    return path


def report_linear(case, case_text, reference, out_dir, params=None, loss="linear", f_scale=3.0,
                  source="") -> LinearFit:
    """``vibeam fit CASE --linear --reference FRC``: fit Eq. 43 around f_n, print, write
    ``linear.h5`` (``/fit``), ``linear.png`` and ``<case>-linear.toml``."""
    ref = read_reference(reference)
    if not ref.physical:
        raise case_error(f"{ref.source}: the linear fit needs 'frequency_hz,amplitude_mm' data")
    spec, L, V, vals = _model_values(case)
    params = list(params) if params else list(EQ43_PARAMS)
    res = fit_linear(ref.x, ref.y, L, V, sigma_mm=ref.sigma, params=params, fixed=vals, loss=loss,
                     f_scale=f_scale)
    print(f"linear fit of Eq. 43 (no stop; paper Sec. 6.1) to {ref.source}: {res.n_points} points, "
          f"{ref.x.min():g} ... {ref.x.max():g} Hz, L = {L:g} mm, V = {V:g} V, loss {loss}")
    fixed = [k for k in EQ43_PARAMS if k not in params]
    if fixed:
        print("  fixed: " + ", ".join(f"{k} = {vals[k]:g}" for k in fixed))
    print("  " + res.table().replace("\n", "\n  "))
    if len(params) > 1:
        print("  correlation: " + "; ".join(f"{params[i]}/{params[j]} {res.correlation[i, j]:+.3f}"
                                            for i in range(len(params)) for j in range(i + 1, len(params))))
    rms = float(np.sqrt(np.mean(res.residuals ** 2)))
    print(f"  residual rms {rms:.4g} mm, s^2 = {res.s2:.4g}, {res.evaluations} evaluations, "
          f"{res.wall_time_s:.3f} s; standard errors {'reliable' if res.reliable else 'NOT reliable'}"
          + (": " + "; ".join(res.notes) if res.notes else ""))
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    upd, notes = _case_updates(spec, {k: res.values[k] for k in params})
    for n in notes:
        print(f"  note: {n}")
    comment = "identified around f_n by Eq. 43 (vibeam fit --linear): " + ", ".join(
        f"{k} = {res.values[k]:.6g}" for k in params)
    cpath = _write_case(case, upd, "linear", comment, out_dir) if upd else None
    table = {"parameters": np.array(params, dtype=object), "units": np.array([param_unit(p) for p in params],
                                                                              dtype=object),
             "estimate": res.estimate, "standard_error": res.standard_error, "correlation": res.correlation,
             "frequency_hz": res.frequency_hz, "amplitude_mm": res.amplitude_mm, "sigma": res.sigma_mm,
             "model_amplitude_mm": res.model_mm, "residuals": res.residuals}
    attrs = {"fit": {"kind": "linear (Eq. 43, no stop)", "reference": ref.source, "n_points": res.n_points,
                     "n_parameters": len(params), "s2": res.s2, "cost": res.cost, "evaluations": res.evaluations,
                     "wall_time_s": res.wall_time_s, "reliable": res.reliable, "notes": "; ".join(res.notes),
                     "loss": loss, "length_mm": L, "voltage": V},
             "fit/residuals": {"units": "mm", "long_name": "residual, model - data"},
             "fit/model_amplitude_mm": {"units": "mm", "long_name": "fitted Eq. 43 amplitude"},
             "fit/frequency_hz": {"units": "Hz", "long_name": "forcing frequency"},
             "fit/amplitude_mm": {"units": "mm", "long_name": "measured amplitude"},
             "fit/sigma": ({"units": "mm", "long_name": "standard deviation of the data"} if ref.sigma is not None
                           else {"units": "1", "long_name": "weight of the data (no sigma: equal weights)"}),
             "fit/estimate": {"long_name": "fitted parameter value", "comment": "per parameter: /fit/units"},
             "fit/standard_error": {"long_name": "standard error of the fitted parameter",
                                    "comment": "per parameter: /fit/units"},
             "fit/correlation": {"units": "1", "long_name": "correlation of the fitted parameters"}}
    h5 = write_results(out_dir / "linear.h5", [], case.name, case_text, extra={"fit": table}, extra_attrs=attrs)
    png = _plot_linear(res, out_dir / "linear.png", f"{case.name}: Eq. 43 fitted around f_n")
    print("  -> " + ", ".join(str(p) for p in (h5, png, cpath) if p))
    return res


def _plot_linear(res: LinearFit, path, title=""):
    matplotlib.use("Agg")

    fig, (ax, axr) = plt.subplots(2, 1, figsize=(7, 5.5), sharex=True, gridspec_kw={"height_ratios": [3, 1.2]})
    ff = np.linspace(res.frequency_hz.min(), res.frequency_hz.max(), 400)
    v = res.values
    ax.plot(res.frequency_hz, res.amplitude_mm, "o", mfc="none", ms=4, label="data")
    ax.plot(ff, eq43_amplitude(ff, v["natural_frequency_hz"], v["damping_ratio"], v["gain"], res.length_mm,
                               res.voltage), "-", lw=1.2, label="Eq. 43 fitted")
    ax.set_ylabel("amplitude at the sensor (mm)")
    ax.set_title(title + "\n" + ", ".join(style.estimate_text(n, x, s, parameter_units(n)) for n, x, s in
                                           zip(res.parameters, res.estimate, res.standard_error)), fontsize=9)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    axr.plot(res.frequency_hz, res.residuals, "o", ms=3)
    axr.axhline(0, color="0.3", lw=0.8)
    axr.set_xlabel("forcing frequency (Hz)")
    axr.set_ylabel("model − data (mm)")
    axr.grid(alpha=0.3)
    fig.tight_layout()
    plot_sweep.save_figure(fig, path)
    plt.close(fig)
    return Path(path)


def report_decay(case, case_text, decay_csv, out_dir, source="") -> tuple[DecayEstimate, DecayEstimate]:
    """``vibeam fit CASE --decay DECAY.csv``: beta_S (and f_n) from a free decay by the logarithmic
    decrement and by a fit of the damped response; print, write ``decay.h5`` (``/decay``),
    ``decay.png`` and ``<case>-decay.toml`` (``damping_ratio`` of the damped fit)."""
    t, U = read_decay(decay_csv)
    ld = log_decrement(t, U)
    fd = fit_decay(t, U, ld)
    print(f"free decay {decay_csv}: {t.size} samples over {t[-1] - t[0]:.4g} s (paper Sec. 6.1, Fig. 30a)")
    print(f"  {'method':<22}{'beta_S':>12}{'std. error':>12}{'f_n (Hz)':>12}{'std. error':>12}")
    for e in (ld, fd):
        print(f"  {e.method:<22}{e.damping_ratio:>12.6g}{e.damping_ratio_se:>12.3g}{e.natural_frequency_hz:>12.6g}"
              f"{e.natural_frequency_hz_se:>12.3g}")
    print(f"  logarithmic decrement delta = {ld.extra['log_decrement']:.6g}; " + "; ".join(ld.notes))
    print(f"  damped fit: residual rms {fd.extra['residual_rms']:.4g} mm" + ("; " + "; ".join(fd.notes)
                                                                             if fd.notes else ""))
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    spec = case.model_spec()
    cpath = None
    if getattr(spec, "physical", False):
        cpath = _write_case(case, {"damping_ratio": float(fd.damping_ratio)}, "decay",
                            f"damping_ratio = {fd.damping_ratio:.6g} +- {fd.damping_ratio_se:.2g} from the free decay "
                            f"{Path(decay_csv).name} (vibeam fit --decay)", out_dir)
    methods = [ld.method, fd.method]
    table = {"t_s": t, "U_mm": U, "model_U_mm": fd.extra["model"], "method": np.array(methods, dtype=object),
             "damping_ratio": np.array([ld.damping_ratio, fd.damping_ratio]),
             "damping_ratio_se": np.array([ld.damping_ratio_se, fd.damping_ratio_se]),
             "natural_frequency_hz": np.array([ld.natural_frequency_hz, fd.natural_frequency_hz]),
             "natural_frequency_hz_se": np.array([ld.natural_frequency_hz_se, fd.natural_frequency_hz_se]),
             "extremum_time_s": ld.extra["extremum_time_s"], "extremum_U_mm": ld.extra["extremum_value"],
             "pair_used": ld.extra["used"].astype(np.int8)}
    attrs = {"decay": {"source": str(decay_csv), "log_decrement": ld.extra["log_decrement"],
                       "noise_std_mm": ld.extra["noise_std"], "residual_rms_mm": fd.extra["residual_rms"],
                       "notes": "; ".join(ld.notes + fd.notes)},
             "decay/t_s": {"units": "s", "long_name": "time"},
             "decay/U_mm": {"units": "mm", "long_name": "measured displacement U"},
             "decay/model_U_mm": {"units": "mm", "long_name": "model U: the fitted damped free vibration"},
             "decay/natural_frequency_hz": {"units": "Hz", "long_name": "natural frequency (log decrement, fit)"},
             "decay/natural_frequency_hz_se": {"units": "Hz", "long_name": "standard error of the natural "
                                               "frequency"},
             "decay/damping_ratio": {"units": "1", "long_name": "damping ratio (log decrement, fit)"},
             "decay/damping_ratio_se": {"units": "1", "long_name": "standard error of the damping ratio"},
             "decay/extremum_time_s": {"units": "s", "long_name": "time of an extremum of U"},
             "decay/extremum_U_mm": {"units": "mm", "long_name": "extremum of U"},
             "decay/pair_used": {"units": "1", "long_name": "extremum pair used by the log decrement (1 used)"}}
    h5 = write_results(out_dir / "decay.h5", [], case.name, case_text, extra={"decay": table}, extra_attrs=attrs)
    png = _plot_decay(t, U, ld, fd, out_dir / "decay.png", f"{case.name}: free decay")
    print("  -> " + ", ".join(str(p) for p in (h5, png, cpath) if p))
    return ld, fd


def decay_figure(t, U, ld, fd, title=""):
    """The free decay (top: the record as dots over the damped fit, a thin line beneath them) and
    the log decrement (bottom: the peak-to-peak differences over their straight line), in the
    house style (:mod:`vibeam.plots.style`: title and subtitle, units, legend outside); a Figure."""
    c_data, c_fit, c_skip = "0.15", style.PALETTE[1], "0.55"
    with style.context():
        fig, (ax, ax2) = plt.subplots(2, 1, figsize=(8.0, 6.0), sharex=True)
        # the data above the fit: dots on top (zorder 3), the fit a thin line beneath (zorder 2)
        ax.plot(t, U, ls="none", marker="o", ms=1.2, mew=0, color=c_data, zorder=3, label="data")
        ax.plot(t, fd.extra["model"], "-", lw=0.7, color=c_fit, zorder=2, label="damped fit")
        ax.set_ylabel(style.label(f"displacement {style.DISPLACEMENT}", "mm"))
        ax.set_title("free decay", loc="left")
        te, p, use = ld.extra["extremum_time_s"][:-1], ld.extra["peak_to_peak"], ld.extra["used"]
        ax2.semilogy(te[use], p[use], ls="none", marker="o", ms=3.5, color=style.PALETTE[0], zorder=3,
                     label="peak-to-peak, used")
        if (~use).any():
            ax2.semilogy(te[~use], p[~use], ls="none", marker="x", ms=3.5, color=c_skip, zorder=3,
                         label="peak-to-peak, below the noise threshold")
        s = ld.extra["sigma_1_s"]
        if use.any():
            c = np.exp(np.average(np.log(p[use]) + s * te[use], weights=p[use] ** 2))
            ax2.semilogy(te[use], c * np.exp(-s * te[use]), "-", color=c_fit, lw=0.7, zorder=2,
                         label="log decrement fit")
        ax2.set_xlabel(style.label("time t", "s"))
        ax2.set_ylabel(style.label("peak-to-peak difference", "mm"))
        ax2.set_title("logarithmic decrement", loc="left")
        ax2.grid(True, which="both")
        handles = [style.proxy(c_data, marker="o", ms=3, label="data (the record)"),
                   style.proxy(c_fit, ls="-", lw=0.7, label=rf"damped fit: $\beta_S$ = {fd.damping_ratio:.4g} ± "
                                                           rf"{fd.damping_ratio_se:.2g}"),
                   style.proxy(style.PALETTE[0], marker="o", label="peak-to-peak, used")]
        if (~use).any():
            handles.append(style.proxy(c_skip, marker="x", label="peak-to-peak, below the noise threshold"))
        if use.any():
            handles.append(style.proxy(c_fit, ls="-", lw=0.7, label=rf"log decrement: $\beta_S$ = "
                                                                  rf"{ld.damping_ratio:.4g} ± {ld.damping_ratio_se:.2g}"))
        style.legend_outside(fig, handles, loc="outside lower center", ncol=2)
        style.titles(fig, title or "free decay",
                     f"{t.size} samples over {t[-1] - t[0]:.4g} s; damped fit: $f_n$ = {fd.natural_frequency_hz:.5g} ± "
                     f"{fd.natural_frequency_hz_se:.2g} Hz")
    return fig


def _plot_decay(t, U, ld, fd, path, title=""):
    """:func:`decay_figure` saved to ``path`` (``decay.png``, atomically) and closed."""
    save_close(decay_figure(t, U, ld, fd, title), path)
    return Path(path)
