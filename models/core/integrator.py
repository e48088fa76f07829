"""The one event integrator: the modal system with any number of stops, exact between events.

vibeam's event-driven method for every fidelity with impulsive stops is this kernel (the SDOF
is the system's one-mode case, the FE beam its ``N``-mode case).  It integrates whole forcing
periods of

    eta_i'' + c_i eta_i' + omega_i^2 eta_i = Gamma_i Omega^2 B sin(Omega t)        (free flight)

(:mod:`vibeam.models.system`; paper Eq. 28 per mode) with the stops of
:mod:`vibeam.models.core.stops`, each a relation (a row of the system at any point, a side, an
offset) and a law, and it switches between two kinds of phase:

free flight
    every mode moves in closed form (:func:`vibeam.models.system.advance_count`); every stop's
    gap ``g_k = n_k^T eta - D_k`` is a signal (:mod:`vibeam.models.core.signals`) scanned with
    certified bounds, so no contact is missed (grazing included); the first crossing of any
    stop is the event;
held on a set of stops
    the constrained system (:class:`~vibeam.models.core.stops.HeldSets`) moves in closed form;
    the constraint forces of the held stops are scanned for their release (first upward zero
    crossing of ``lambda_k``), the gaps of the other stops for a contact.

At a contact the stop's law acts (:func:`vibeam.models.impact.restitution_coefficient`: Newton,
``U+ = -R(U-) U-``) through the mass matrix along the stop's normal (or its projection on the
held constraints), and the one chatter / sticking policy of :mod:`vibeam.models.core.contact_policy`
decides what follows: rebound, sticking (the stop joins the held set), or a chatter sequence
summed in closed form to its accumulation point.  The time grid is aligned with the forcing
phase (``ns`` points per period, the recorded samples); steps inside a grid interval are at
most ``h_cap`` and grow by doubling after a certification shortened them.

A transient that settles in floating point ends early, with the same numbers: the loop's whole
state at a period start (modal state, free arc, carried gaps and bounds, step length, flags) is
compared bit for bit with two snapshots, one retaken every :data:`RECUR_MAX` periods and one every
:data:`RECUR_FAST` (a short cycle is then found soon after it begins); once it
recurs after ``L`` periods, every later period repeats the last ``L`` exactly (the kernel is a
deterministic function of that state and the phase), so whole multiples of ``L`` are skipped up
to the record and the step and impact counters advance by their counts over the cycle (the last
impact's time by the skipped time, for the Zeno guard's window).  In the record (a snapshot taken
in it) a cycle is copied to the record's end in whole cycles: samples, per-period minima, impacts
(their times rebuilt as the kernel computes them, from their periods and times within them).  A
cycle that holds or chatters (sticking, chatter sequences: a chattering orbit's record) adds to the
record's sums; the record's cycle log (:class:`Record` ``cycle``: each held step's length, each
chatter sequence's period, time and accumulation interval, in the order the kernel meets them) is
replayed for every copied cycle, so the time held and the accumulation points are summed and
rebuilt in the full run's order and arithmetic (the last impact's time, read by the Zeno guard's
window only, is advanced by the copied time, as in a transient's skip).  The outputs are those of
the full run bit for bit; ``periods_skipped`` says how many periods were not integrated.  Not with
compliant stops or the event and apex logs (whose rows would be missing).

The record of a one-mode system with Newton stops steps on the transient's grid when the record's
samples refine it (``ns_record`` a multiple of ``ns_transient``, one sub-step per grid step of
each): the samples inside a free step are the closed-form flow evaluated there from the step's
parts (dense output: the homogeneous part carried from sample to sample by the record grid's
tabulated transition, the formula of a step's end, so equal to steps to them up to round-off); a
held step or a contact event sees the rest of the record's grid step, as on the record's own
grid.  The record then continues the transient's floating-point cycle, so the recurrence copies it
after one cycle instead of waiting for the orbit to settle anew on a finer grid.

Outputs go to one :class:`Record` (arrays allocated by the caller: samples at the phase grid of
the recorded periods, impacts, per-period minima, chatter points, an optional event log for the
shooting problem); the kernel returns its scalars as a :class:`RunScalars` (:func:`integrate_work`, in work arrays
of the caller's, :func:`new_work` and :func:`compliant_work`).

Event log (rows ``[kind, t, aux, stop, eta (n), eta' (n)]``, ``t`` from the start of the call)
    ``EV_START``  the initial state was put on stop ``stop`` (aux 1: held, position and velocity;
                  0: position only); the logged state is the projected one;
    ``EV_IMPACT`` an impact on ``stop``; the state just before it (on the stop, pre-impact
                  velocity), aux ``U-``;
    ``EV_STICK``  sticking on ``stop`` entered without an impact (touching with ``U = 0``,
                  pressed); the state before the velocity projection;
    ``EV_STICK_IMPACT`` the impact logged just before ends in sticking (plastic entry, chatter,
                  ``R = 0``); aux the chatter hold time (0 if none);
    ``EV_RELEASE`` release of ``stop``; aux the contact force at the release (0 at a located
                  zero crossing, > 0 when released at a step start).
    Apex log rows ``[t, g, stop]``: interior maxima of a stop's gap in free flight (and in held
    phases, of the gaps of the stops not held).
"""
from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numba import njit

from .contact_policy import (BURST_DT, CHATTER, CHATTER_GUARD, REBOUND, STICK, burst_limit, impact_outcome,
                              release_now, zeno_burst)
from ..contact import LAW_LINEAR
from ..impact import newton_restitution
from ..system import advance_count, drive_displacement, drive_force, increment_of, transition_increment
from .contact_phase import (EK_EXIT, EK_FAIL, EK_GAPDOWN, EK_NONE, EK_RELEASE, linear_step,
                            phase_harmonics, rk_phase_step, rk_scales)
from .laws import force, hertz_floor, inside_sign, is_compliant, newton_coefficient, start_velocity
from .signals import (ROOT_APEX, bounds, extremes, extremes_from, hermite_guess, homogeneous, homogeneous_bounds,
                      mode_ends, root_value, scan, scan_from, signal, signal_start)

__all__ = ["Record", "RunScalars", "integrate_work", "as_tuple", "scalars", "new_work", "compliant_work", "work_fits", "new_record", "ST_OK", "ST_CHATTER", "ST_STICKING", "ST_FAILED",
           "STATUS_NAMES", "EV_START", "EV_IMPACT", "EV_STICK", "EV_STICK_IMPACT", "EV_RELEASE", "EV_ENTRY",
           "EV_EXIT", "LOG_HEAD", "C_DURATION", "C_FORCE", "C_PENETRATION", "C_ENERGY", "C_VELOCITY"]

TWO_PI = 2.0 * math.pi
ST_OK, ST_CHATTER, ST_STICKING, ST_FAILED = 0, 1, 2, 3
STATUS_NAMES = ("ok", "chatter", "sticking", "failed")
EV_START, EV_IMPACT, EV_STICK, EV_STICK_IMPACT, EV_RELEASE, EV_ENTRY, EV_EXIT = 0, 1, 2, 3, 4, 5, 6
#: columns of a compliant contact's record: duration, peak force, largest penetration, work done on the
#: stop, entry velocity (system units)
C_DURATION, C_FORCE, C_PENETRATION, C_ENERGY, C_VELOCITY = range(5)
#: columns of an event-log row before the state
LOG_HEAD = 4
#: rows of the record's cycle log (:class:`Record` ``cycle``) and its kinds
CYCLE_LOG = 4096
CY_HELD, CY_GUARD, CY_CHATTER = 0.0, 1.0, 2.0


class Record(NamedTuple):
    """What one call of :func:`integrate_work` writes (arrays allocated by :func:`new_record`).

    Attributes
    ----------
    samples : ndarray, shape (n_record * ns_record, 2)
        Sensor displacement and velocity ``(s^T eta, s^T eta')`` (row units) at the phase grid of
        the recorded periods.
    msamp : ndarray, shape (n_record * ns_record, 2n) or (0, 2n)
        Modal state at the samples (0 rows: not recorded).
    modamp : ndarray, shape (n,)
        Largest ``|eta_i|`` over the samples.
    pmin : ndarray, shape (n_record,)
        Minimum of the sensor signal over each recorded period (exact: root-found).
    imp_t, imp_v : ndarray, shape (cap,)
        Time (from the start of the record) and normal pre-impact speed ``U-`` of the first
        ``cap`` recorded impacts.
    imp_k : ndarray of int64, shape (cap,)
        Their stops.
    imp_tl, imp_rp : ndarray, shape (cap,)
        Their times within their periods (nondimensional) and the periods' indices in the record
        (int64): ``imp_t = imp_rp * T + imp_tl`` as the kernel computes it, ``T = 2 pi / Omega``
        (kept so that the recurrence can rebuild the times of the impacts it copies).
    n_imp_stop : ndarray of int64, shape (n_s,)
        Recorded impacts per stop.
    chat_t : ndarray, shape (cap_c,)
        Accumulation points of the first chatter sequences of the record.
    evlog : ndarray, shape (cap_e, LOG_HEAD + 2n)
        Event log (0 rows: off).
    aplog : ndarray, shape (cap_a, 3)
        Apex log (0 rows: off).
    nlog : ndarray of int64, shape (2,)
        Events and apexes logged (counted beyond the capacities).
    con : ndarray, shape (cap, 5) or (0, 5)
        Per recorded contact of a compliant stop (row: its index among the recorded impacts and
        contacts): duration, peak force, largest penetration, work done on the stop, entry velocity
        (:data:`C_DURATION` ...; system units); NaN rows for Newton impacts and contacts still open
        at the end.
    cycle : ndarray, shape (cap_y, 4)
        The record's cycle log (module docstring; scratch, read by the exact recurrence only): rows
        ``[kind, a, b, c]``, kind :data:`CY_HELD` (``a``: a held step's length, added to the time
        held), :data:`CY_GUARD` or :data:`CY_CHATTER` (a chatter sequence: ``a`` its record period,
        ``b`` its time within it, ``c`` its accumulation interval).  Past ``cap_y`` rows the log
        stops and a cycle that holds or chatters is integrated.
    """

    samples: np.ndarray
    msamp: np.ndarray
    modamp: np.ndarray
    pmin: np.ndarray
    imp_t: np.ndarray
    imp_v: np.ndarray
    imp_k: np.ndarray
    imp_tl: np.ndarray
    imp_rp: np.ndarray
    n_imp_stop: np.ndarray
    chat_t: np.ndarray
    evlog: np.ndarray
    aplog: np.ndarray
    nlog: np.ndarray
    con: np.ndarray
    cycle: np.ndarray


class RunScalars(NamedTuple):
    """The scalars one call of :func:`integrate_work` returns (its arrays are in the :class:`Record`).

    Attributes
    ----------
    status : int
        :data:`ST_OK`, :data:`ST_CHATTER`, :data:`ST_STICKING` or :data:`ST_FAILED`.
    n_imp_record : int
        Impacts and contacts in the record.
    s_min, s_max : float
        Sensor extremes over the record (row units).
    n_chatter : int
        Chatter sequences in the record.
    stuck_time : float
        Time held in the record (nondimensional; chatter holds excluded).
    held_end : int
        Bit mask of the stops held or in contact at the end.
    n_imp_total : int
        All impacts and contacts (-1: the forced response is not finite; -2: the motion's scale
        is subnormal, below 1e-290).
    gmax : float
        The largest gap of a Newton stop at the end of an event-free step (a certificate: positive
        beyond round-off only if a crossing had been stepped over).
    n_steps : int
        Steps taken.
    contact_time : float
        Time in compliant contact during the record.
    periods_skipped : int
        Periods not integrated thanks to the exact recurrence (module docstring; the counters and
        the record include them).
    """

    status: int
    n_imp_record: int
    s_min: float
    s_max: float
    n_chatter: int
    stuck_time: float
    held_end: int
    n_imp_total: int
    gmax: float
    n_steps: int
    contact_time: float
    periods_skipped: int


def new_record(n, n_stops, n_record, ns_record, impact_buffer=4096, modal_states=False, log_events=0,
               log_apexes=0, compliant=False) -> Record:
    """A :class:`Record` for ``n`` modes, ``n_stops`` stops and ``n_record`` recorded periods of
    ``ns_record`` samples; ``log_events`` / ``log_apexes``: capacities of the logs (0: off);
    ``compliant``: with the per-contact records of compliant stops."""
    ns = int(n_record) * int(ns_record)
    # the impact and chatter buffers are read up to the kernel's counts only: not cleared (at the
    # default 4096 entries, clearing them cost ~10 us per point of a sweep)
    return Record(np.zeros((ns, 2)), np.zeros((ns if modal_states else 0, 2 * n)), np.zeros(n),
                  np.zeros(int(n_record)), np.empty(impact_buffer), np.empty(impact_buffer),
                  np.empty(impact_buffer, np.int64), np.empty(impact_buffer), np.empty(impact_buffer, np.int64),
                  np.zeros(n_stops, np.int64), np.empty(impact_buffer),
                  np.zeros((int(log_events), LOG_HEAD + 2 * n)), np.zeros((int(log_apexes), 3)),
                  np.zeros(2, np.int64), np.full((impact_buffer if compliant else 0, 5), np.nan),
                  np.empty((CYCLE_LOG, 4)))


# ============================================================================ work arrays
# The kernel is a set of separately compiled functions (numba and LLVM compile several functions of
# moderate size far faster than one of a thousand lines, issue 20): :func:`integrate_work` prepares
# a call (:func:`_frequency`, :func:`_start_compliant`) and runs the loop, which takes each free step
# itself, a held one by :func:`_held_step` and a compliant contact by :func:`_contact_phase`, and
# resolves a contact by :func:`_impact` or :func:`_entry`.  Nothing wraps it for Python: numba
# links a callee's code into its caller and compiles it again there, so a wrapper above the loop
# cost ~3 s of the quick start's compile.  They share
# the state of the call through small work arrays (rows by index, no views kept):
#
# ``wn`` (_NWN, n)  per mode: the particular solution, the free arc's homogeneous parts and their
#                   increments, the held phase's coordinates, copies of the system's rows;
# ``wk`` (_NWK, ns) per stop: harmonic parts, carried gaps and their derivatives, bounds;
# ``fs`` (_NFS,)    the loop's floats (clock, times, sensor extremes);
# ``ist`` (_NIS,)   its integers and flags (held set, contact set, counters).
#
# Every function but the two that allocate (:func:`new_work`, :func:`compliant_work`) is compiled
# without reference counting (``_nrt=False``: an array argument costs nothing per call) and, but
# :func:`integrate_work`, without a Python wrapper (called from compiled code only), each for one
# argument signature (the
# compliant data ``cw`` is None for a scene of Newton stops, whose functions then hold no
# compliant code: numba prunes the branches on ``cw is not None``).
(_AF, _BF, _GF, _ZERO, _XF, _YF, _DXV, _DYV, _X2V, _X3V, _X0, _Y0, _ZETA, _ZETAD, _SENS, _CM, _KM,
 _NWN) = range(18)
(_SAF, _SBF, _CSF, _G, _V, _G1, _V1, _G2, _G3, _G21, _G31, _M2F, _M3F, _M4F, _LAM0, _LAMP0, _OFF, _MEFF,
 _NWK) = range(19)
(_PHI, _TLOC, _REM, _HLAST, _HOLD, _GMAX, _STUCK, _TCON, _TLAST, _PT, _T0, _SASF, _SBSF, _PEXT, _PEXT1,
 _EXT, _EXT1, _WAIT, _NFS) = range(19)
(_H, _C, _INSIDE, _RELAXED, _CMASK, _FRESH, _BSTALE, _ATGRID, _JSTUCK, _JREL, _QFRESH, _QLAST, _BURST,
 _NSTEPS, _NIMPT, _NIMPR, _NCHAT, _EXITED, _RDEL, _RP, _NCYC, _NIS) = range(22)
# ``lp`` (_NLP,)    the period loop's counters (period, the recurrence's snapshot periods, samples
#                   taken, periods skipped, samples per recorded period, the cycle log's length
#                   at each snapshot), read and written at
#                   period starts.  The counters of a step (the grid's sub-step and its tables, the
#                   dense record's next and last sample) are the loop's local variables, handed to
#                   the phases and returned by them: kept in ``lp`` they were stored and reloaded
#                   on every step (numba's arrays may alias: LLVM keeps no array element in a
#                   register across a store to another array), +24 M instructions (+5 %) in the
#                   event kernel's Fig. 7 sweep
(_LPP, _LSNAP, _LSNAPB, _LKS, _LSKIP, _LNSREC, _LCYA, _LCYB, _NLP) = range(9)
#: longest exact cycle of the period-start state that the recurrence finds (periods; skipped in a
#: transient, copied in a record): the cadence of its first snapshot
RECUR_MAX = 16
#: the cadence of its second snapshot (periods): a cycle of at most this length is found at most
#: ``RECUR_FAST + L`` periods after it began, not ``RECUR_MAX + L``
RECUR_FAST = 4
# the statuses and a zero as int64 constants: every field of a RunScalars one type at every return
_ST_OK, _ST_CHATTER, _ST_STICKING, _ST_FAILED, _I0 = (np.int64(k) for k in (ST_OK, ST_CHATTER, ST_STICKING,
                                                                         ST_FAILED, 0))
# the event kinds and the root kind of an apex as int64 constants: a literal int argument would
# compile the callee once per value
_K_START, _K_IMPACT, _K_STICK, _K_STICK_IMPACT, _K_RELEASE, _K_ENTRY, _K_EXIT = (np.int64(k) for k in range(7))
#: the internal functions: called from compiled code only (no Python or C wrapper), no reference counting
_kernel = njit(cache=True, _nrt=False, error_model="numpy", no_cpython_wrapper=True, no_cfunc_wrapper=True)
#: the event loop's phases (:func:`integrate_work`): inlined into the loop at numba's IR (compiled
#: on their own, a call per step with its ~40 array arguments made the Fig. 7 sweep 1.7x slower;
#: the free step inlined and the other phases called, 1.05x)
_inline = njit(cache=True, _nrt=False, error_model="numpy", inline="always")


class _CompliantWork(NamedTuple):
    """The compliant stops' data and work arrays of one call (None for Newton stops only)."""

    st: object
    cp: object
    pax: np.ndarray
    pbx: np.ndarray
    pay: np.ndarray
    pby: np.ndarray
    vr: np.ndarray
    vfl: np.ndarray
    cs: np.ndarray
    crow: np.ndarray
    rkc: np.ndarray
    xq: np.ndarray
    yq: np.ndarray
    hbq: np.ndarray
    wpa: np.ndarray
    wra: np.ndarray
    wpb: np.ndarray
    wrb: np.ndarray
    ext2: np.ndarray
    ry0: np.ndarray
    ry1: np.ndarray
    rtmp: np.ndarray
    ryt: np.ndarray
    ryw: np.ndarray
    rye: np.ndarray
    racc: np.ndarray
    rK: np.ndarray
    con: np.ndarray


# ============================================================================ helpers
@njit(cache=True, _nrt=False, error_model="numpy", inline="always")
def _clock(phi, t_loc, rem, s, Om, T):
    """Advance the forcing phase, the time within the period and the rest of the grid step."""
    rem -= s
    if rem < 1e-15 * T:
        rem = 0.0
    phi += Om * s            # 0 <= Om s <= 2 pi (steps within a period): one wrap, exact (Sterbenz)
    if phi >= TWO_PI:
        phi -= TWO_PI
    return phi, t_loc + s, rem


@_kernel
def _contact_acc(phi, Om, eta, etad, d, c, k, GF):
    """Free acceleration along ``d``, ``a = d^T (Gamma F sin - C eta' - K eta)``, and its time
    derivative ``d^T (Gamma F Omega cos - C eta'' - K eta')`` (forcing term included)."""
    s = math.sin(phi)
    co = Om * math.cos(phi)
    acc = 0.0
    jerk = 0.0
    for i in range(eta.shape[0]):
        ai = GF[i] * s - c[i] * etad[i] - k[i] * eta[i]
        acc += d[i] * ai
        jerk += d[i] * (GF[i] * co - c[i] * ai - k[i] * etad[i])
    return acc, jerk


@_kernel
def _release_wait(phi, Om, eta, etad, d, wn, GF, wait, T):
    """How long a release into free flight along ``d`` waits (``T`` the forcing period): 0, none;
    > 0, hold on that long (no release check) and release at the next step's start; < 0, the free
    flow pulls away now.

    The force lambda (the held set's coordinates) and the free flow's normal acceleration ``a``
    (:func:`_contact_acc`) are one quantity in two representations; where they differ by their
    round-off (many modes), lambda can cross zero a hair before the free flow turns, which would
    touch the stop again at zero speed.  While ``a`` presses (``a > 0``) and turns (``a' < 0``)
    the wait is ``2 a / -a'``, at least twice the last wait ``wait`` for the same release: where
    both are within their round-off of zero (their signs noise for ~1e-10 T) the wait grows until
    the free flow has turned beyond it (re-waiting the same short wait crept ~1e-10 T a crossing,
    ~5e4 steps a period, with some BLAS kernels).  Not a wait (0): below the clock's resolution
    (1e-14 T) or longer than a round-off disagreement (1e-9 T); released where lambda says."""
    acc, jerk = _contact_acc(phi, Om, eta, etad, d, wn[_CM], wn[_KM], GF)
    if release_now(acc, jerk):
        return -1.0
    if not (acc > 0.0 and jerk < 0.0):
        return 0.0
    early = max(2.0 * acc / -jerk, 2.0 * wait)
    return early if 1e-14 * T <= early <= 1e-9 * T else 0.0


@njit(cache=True, _nrt=False, error_model="numpy", inline="always")
def _far(g0, g1, M2, h):
    """A gap negative at both ends of a step stays negative inside when it is far from zero:
    linear interpolation is off by at most ``M2 h^2 / 8`` (``M2`` bounds ``|g''|``)."""
    return max(g0, g1) + 0.125 * M2 * h * h < 0.0


@_kernel
def _dot(a, b):
    r = 0.0
    for i in range(a.shape[0]):
        r += a[i] * b[i]
    return r


@_kernel
def _log_event(evlog, nlog, kind, t, aux, stop, eta, etad):
    k = nlog[0]
    if k < evlog.shape[0]:
        N = eta.shape[0]
        evlog[k, 0] = kind
        evlog[k, 1] = t
        evlog[k, 2] = aux
        evlog[k, 3] = stop
        for i in range(N):
            evlog[k, 4 + i] = eta[i]
            evlog[k, 4 + N + i] = etad[i]
    nlog[0] = k + 1


@_kernel
def _log_apex(aplog, nlog, t, h, phi0, Om, x0, y0, mp, p, zero, Sa, Sb, f0, fp0, m, stop, fpp0, fp1, fpp1):
    """Locate the maximum of a gap inside ``[0, h]`` (slope ``fp0 > 0`` at 0, ``fp1 <= 0`` at h) and
    log it; the search starts at the :func:`hermite_guess` of the slope from its derivatives
    ``fpp0``, ``fpp1`` at the ends (NaN: unknown, the midpoint)."""
    k = nlog[1]
    if k < aplog.shape[0]:
        s0 = -1.0 if fpp0 != fpp0 else hermite_guess(0.0, h, -fp0, -fpp0, -fp1, -fpp1)
        sa, ga = root_value(ROOT_APEX, 0.0, h, s0, phi0, Om, x0, y0, mp, p, zero, Sa, Sb, f0, fp0, m)
        aplog[k, 0] = t + sa
        aplog[k, 1] = ga
        aplog[k, 2] = stop
    nlog[1] = k + 1


@_kernel
def _sensor_extreme(h, phi, Om, x0, y0, mp, sens, zero, Sa, Sb, q0, qp0, qp1, x2e, ext, m):
    """The sensor's interior extreme in a free step of length ``h`` whose slope turns (``qp0``,
    ``qp1`` of opposite signs) into ``ext = [min, max]``: the root of the slope, started at the
    :func:`hermite_guess` from the slope's derivatives at both ends (homogeneous parts ``x0, y0`` at
    the start, their second derivatives ``x2e`` at the end).  A separate function: the hot loop
    keeps no more values live for it."""
    sp0 = math.sin(phi)
    cp0 = math.cos(phi)
    sp1 = math.sin(phi + Om * h)
    cp1 = math.cos(phi + Om * h)
    W2 = Om * Om
    qa0 = -W2 * (Sa * sp0 + Sb * cp0)
    qa1 = -W2 * (Sa * sp1 + Sb * cp1)
    for i in range(m):
        qa0 += sens[i] * (-2.0 * mp[i, 0] * y0[i] - mp[i, 1] * x0[i])
        qa1 += sens[i] * x2e[i]
    sgn = 1.0 if qp0 < 0.0 else -1.0
    s0 = hermite_guess(0.0, h, sgn * qp0, sgn * qa0, sgn * qp1, sgn * qa1)
    extremes_from(h, phi, Om, x0, y0, mp, sens, zero, Sa, Sb, q0, qp0, qp0, qp1, s0, ext, m)


@njit(cache=True, _nrt=False, error_model="numpy", inline="always")
def _gap_ends(Pm, k, Sa, Sb, f0, fp0, Om, dx, dy, x2, x3, dsin, dcos, sp1, cp1, m, g1, v1, g21, g31):
    """Value, slope, 2nd and 3rd derivative at the end of a free step of the gap signal with
    weights ``Pm[k]`` (no velocity weights) and harmonic part ``Sa sin + Sb cos``, from the modes'
    increments (:func:`vibeam.models.core.signals.mode_ends`) and the phase's; into row ``k``."""
    f = f0 + Sa * dsin + Sb * dcos
    f1 = fp0 + Om * (Sa * dcos - Sb * dsin)
    f2 = 0.0
    f3 = 0.0
    for j in range(m):
        f += Pm[k, j] * dx[j]
        f1 += Pm[k, j] * dy[j]
        f2 += Pm[k, j] * x2[j]
        f3 += Pm[k, j] * x3[j]
    W2 = Om * Om
    g1[k] = f
    v1[k] = f1
    g21[k] = f2 - W2 * (Sa * sp1 + Sb * cp1)
    g31[k] = f3 - W2 * Om * (Sa * cp1 - Sb * sp1)


@_kernel
def _free_bounds(x, y, mp, hb, Nrm, Cs, Om, M2, M3, M4, n, ns):
    """Bounds of the 2nd-4th derivatives of every stop's gap over the rest of a free arc, from the
    modes' homogeneous parts ``x, y`` now (:func:`vibeam.models.core.signals.homogeneous_bounds`)."""
    for i in range(n):
        homogeneous_bounds(x[i], y[i], mp[i, 0], mp[i, 1], int(mp[i, 2]), mp[i, 3], mp[i, 4], mp[i, 5], hb[i])
    W2 = Om * Om
    for k in range(ns):
        a2 = Cs[k] * W2
        a3 = a2 * Om
        a4 = a3 * Om
        for i in range(n):
            ap = abs(Nrm[k, i])
            a2 += ap * hb[i, 2]
            a3 += ap * hb[i, 3]
            a4 += ap * hb[i, 4]
        f = 1.0 + 1e-9
        M2[k] = a2 * f + 1e-300
        M3[k] = a3 * f + 1e-300
        M4[k] = a4 * f + 1e-300


@_kernel
def _particular(c, k, G, F, Om, a, b, m):
    """``a sin + b cos``, the steady response of ``x'' + c x' + k x = G F sin(Om t)``; False if
    not finite (a mode at undamped exact resonance)."""
    ok = True
    for j in range(m):
        num = G[j] * F
        dr = k[j] - Om * Om
        di = c[j] * Om
        if num == 0.0:
            a[j] = 0.0
            b[j] = 0.0
            continue
        if dr == 0.0 and di == 0.0:
            a[j] = np.inf
            b[j] = np.inf
            ok = False
            continue
        z = num / complex(dr, di)
        a[j] = z.real
        b[j] = z.imag
        if not (math.isfinite(a[j]) and math.isfinite(b[j])):
            ok = False
    return ok


@njit(cache=True, _nrt=False, error_model="numpy", inline="always")
def _failed(fs, ist, skipped):
    """The :class:`RunScalars` of a call that gave up (:data:`ST_FAILED`)."""
    return RunScalars(_ST_FAILED, ist[_NIMPR], min(fs[_EXT], fs[_PEXT]), max(fs[_EXT1], fs[_PEXT1]), ist[_NCHAT],
                      fs[_STUCK], ist[_H] | ist[_C], ist[_NIMPT], fs[_GMAX], ist[_NSTEPS], fs[_TCON], skipped)


# ============================================================================ preparing a call
@njit(cache=True, _nrt=False, error_model="numpy", inline="always")
def substeps(Om, ns_transient, ns_record, h_cap):
    """The sub-steps per grid step of the record and of the transient ``(sub_r, sub_t)`` (a grid
    step split into ``sub`` of at most ``h_cap``)."""
    T = TWO_PI / Om
    sub_t = max(1, int(math.ceil((T / ns_transient) / h_cap * (1.0 - 1e-12))))
    sub_r = max(1, int(math.ceil((T / ns_record) / h_cap * (1.0 - 1e-12))))
    return sub_r, sub_t


@njit(cache=True, error_model="numpy", no_cfunc_wrapper=True)
def new_work(n, ns, S, Om, ns_transient, ns_record, h_cap, recur):
    """The work arrays of one call (:func:`_frequency` fills them), the sub-steps per grid step
    of the transient and of the record (:func:`substeps`), and the snapshot of the exact
    recurrence (module docstring; empty, so off, when ``recur`` is False)."""
    sub_r, sub_t = substeps(Om, ns_transient, ns_record, h_cap)
    nt_t = ns_transient * sub_t
    nt_r = ns_record * sub_r
    one = nt_t == nt_r and ns_transient == ns_record     # one grid (a shot): the same tables
    P_r = np.empty((n, 4))
    tab_r = np.empty((nt_r + 1, 2))
    P_t = P_r if one else np.empty((n, 4))
    tab_t = tab_r if one else np.empty((nt_t + 1, 2))
    return (np.empty((_NWN, n)), np.empty((_NWK, ns)), np.empty((n, 6)), np.empty((2 * S, n)),
            np.empty((6 * S, ns)), np.empty((2, S)), P_r, tab_r, P_t, tab_t, np.empty(_NFS),
            np.empty(_NIS, np.int64), sub_r, sub_t,
            np.empty(2 * (_snap_fs(n, ns) + _NFS) if recur else 0), np.empty(2 * (_NIS + ns) if recur else 0, np.int64),
            np.zeros(_NLP, np.int64))


@_kernel
def _state_sample(samples, msamp, modamp, fs, k, sens, eta, etad, n):
    """Sample ``k`` of the record from the current modal state ``eta, eta'`` (shape ``(n,)``): the
    sensor ``(s^T eta, s^T eta')`` (row units), the modes' amplitudes, the period's extremes."""
    qs = 0.0
    qd = 0.0
    for i in range(n):
        qs += sens[i] * eta[i]
        qd += sens[i] * etad[i]
    for i in range(n):
        if abs(eta[i]) > modamp[i]:
            modamp[i] = abs(eta[i])
    samples[k, 0] = qs
    samples[k, 1] = qd
    if msamp.shape[0] > 0:
        for i in range(n):
            msamp[k, i] = eta[i]
            msamp[k, n + i] = etad[i]
    if qs < fs[_PEXT]:
        fs[_PEXT] = qs
    if qs > fs[_PEXT1]:
        fs[_PEXT1] = qs


@_kernel
def _dense_samples(samples, msamp, modamp, fs, wn, mp, P_r, tab_r, samp, step, Om, n):
    """The record's samples inside one free step (dense output; module docstring): ``samp = (k0,
    j_next, j_end, base)``, ``step = (t_loc, s_mv, h_rs, from_grid)``; samples ``base + j`` of the
    period for ``j = j_next ..`` below ``j_end`` whose time ``(base + j) h_rs`` (from the period's
    start) lies before the step's end ``t_loc + s_mv``, into rows ``k0 ..`` of the record, as
    :func:`_state_sample` takes them.

    Each mode's homogeneous part ``xF, yF`` (rows of ``wn``, at the step's start ``t_loc``) is
    carried to the first sample by the transition increment over the time to it (the tabulated
    one ``P_r`` when the step starts at the grid point, ``from_grid``), then from sample to sample
    by ``P_r``, as steps on the record's own grid would carry it; the particular part is read at the
    sample's phase (``tab_r``, the record grid's sines and cosines).  The closed form of paper
    Eq. 28 per mode, the formula of a step's end.  Returns the number of samples taken."""
    k0, j_next, j_end, base = samp
    t_loc, s_mv, h_rs, from_grid = step
    sens, aF, bF, xF, yF = wn[_SENS], wn[_AF], wn[_BF], wn[_XF], wn[_YF]
    m = 0
    while j_next + m < j_end and (base + j_next + m) * h_rs - t_loc < s_mv:
        m += 1
    if m == 0:
        return 0
    for q in range(m):
        samples[k0 + q, 0] = 0.0
        samples[k0 + q, 1] = 0.0
    for i in range(n):
        x = xF[i]
        y = yF[i]
        a11, a12, a21, a22 = increment_of(from_grid, P_r, i, max((base + j_next) * h_rs - t_loc, 0.0), mp)
        for q in range(m):
            if q > 0:
                a11 = P_r[i, 0]
                a12 = P_r[i, 1]
                a21 = P_r[i, 2]
                a22 = P_r[i, 3]
            dx = a11 * x + a12 * y
            dy = a21 * x + a22 * y
            x += dx
            y += dy
            kd = base + j_next + q
            sp = tab_r[kd, 0]
            cp = tab_r[kd, 1]
            e = aF[i] * sp + bF[i] * cp + x
            ed = Om * (aF[i] * cp - bF[i] * sp) + y
            samples[k0 + q, 0] += sens[i] * e
            samples[k0 + q, 1] += sens[i] * ed
            if abs(e) > modamp[i]:
                modamp[i] = abs(e)
            if msamp.shape[0] > 0:
                msamp[k0 + q, i] = e
                msamp[k0 + q, n + i] = ed
    for q in range(m):
        qs = samples[k0 + q, 0]
        if qs < fs[_PEXT]:
            fs[_PEXT] = qs
        if qs > fs[_PEXT1]:
            fs[_PEXT1] = qs
    return m


@njit(cache=True, _nrt=False, error_model="numpy", inline="always")
def _snap_fs(n, ns):
    """Where the loop's floats ``fs`` start in a snapshot (:func:`_snapshot`)."""
    return 8 * n + _NWN * n + _NWK * ns


@_kernel
def _snapshot(sf, si, fo, io, eta, etad, wn, wk, hb, fs, ist, n_imp_stop):
    """Copy the loop's state at a period start into ``sf`` from ``fo`` on (floats) and ``si``
    from ``io`` on (integers, then the recorded impacts per stop)."""
    j = fo
    for i in range(eta.shape[0]):
        sf[j] = eta[i]
        sf[j + 1] = etad[i]
        j += 2
    for a in (wn, wk, hb):
        for r in range(a.shape[0]):
            for c in range(a.shape[1]):
                sf[j] = a[r, c]
                j += 1
    for i in range(_NFS):
        sf[j + i] = fs[i]
    for i in range(_NIS):
        si[io + i] = ist[i]
    for k in range(n_imp_stop.shape[0]):
        si[io + _NIS + k] = n_imp_stop[k]


@njit(cache=True, _nrt=False, error_model="numpy", inline="always")
def _same(a, b):
    """``a`` and ``b`` are the same float: signed zeros told apart, two NaNs the same (an entry
    of the work arrays that a scene never writes keeps what ``np.empty`` left there, a NaN
    included: it must not decide at random whether a transient is ended early)."""
    if a == b:
        return a != 0.0 or math.copysign(1.0, a) == math.copysign(1.0, b)
    return a != a and b != b


@njit(cache=True, _nrt=False, error_model="numpy", inline="always")
def _cycle_log(cyc, ist, kind, a, b, c):
    """A row of the record's cycle log (:class:`Record` ``cycle``), while it is on (``ist[_NCYC]
    >= 0``); past its capacity it turns off for the rest of the call (-1)."""
    k = ist[_NCYC]
    if k < 0:
        return
    if k >= cyc.shape[0]:
        ist[_NCYC] = -1
        return
    cyc[k, 0] = kind
    cyc[k, 1] = a
    cyc[k, 2] = b
    cyc[k, 3] = c
    ist[_NCYC] = k + 1


@_kernel
def _replay_cycle(cyc, p0, p1, m, L, T, fs, ist, chat_t):
    """The sums of ``m`` more cycles of ``L`` periods whose rows of the cycle log are ``[p0,
    p1)``: each held step's length added to the time held, each chatter sequence counted and its
    accumulation point written, in the order and arithmetic of the full run (:func:`_impact`:
    ``t = (rp * T + t_loc) + D``)."""
    for c in range(1, m + 1):
        for e in range(p0, p1):
            kind = cyc[e, 0]
            if kind == CY_HELD:
                fs[_STUCK] += cyc[e, 1]
                continue
            n_chatter = ist[_NCHAT] + 1
            ist[_NCHAT] = n_chatter
            if n_chatter <= chat_t.shape[0]:
                t_imp = (np.int64(cyc[e, 1]) + c * L) * T + cyc[e, 2]
                chat_t[n_chatter - 1] = t_imp if kind == CY_GUARD else t_imp + cyc[e, 3]


@_kernel
def _recurs(sf, si, fo, io, eta, etad, wn, wk, hb, fs, ist):
    """Whether the loop's state equals the snapshot of :func:`_snapshot` at ``fo`` / ``io`` bit
    for bit, but for the quantities that only count, sum or stamp (steps, impacts, chatter
    sequences, the largest gap, the record's extremes, its last period's and times held and in
    contact, the clock's period offsets and record period, the last impact's time, the cycle
    log's length)."""
    j = fo
    for i in range(eta.shape[0]):
        if not (_same(sf[j], eta[i]) and _same(sf[j + 1], etad[i])):
            return False
        j += 2
    for a in (wn, wk, hb):
        for r in range(a.shape[0]):
            for c in range(a.shape[1]):
                if not _same(sf[j], a[r, c]):
                    return False
                j += 1
    for i in range(_NFS):
        if (i == _GMAX or i == _STUCK or i == _TCON or i == _TLAST or i == _PT or i == _T0 or i == _EXT
                or i == _EXT1 or i == _PEXT or i == _PEXT1):
            continue
        if not _same(sf[j + i], fs[i]):
            return False
    for i in range(_NIS):
        if i == _NSTEPS or i == _NIMPT or i == _NIMPR or i == _NCHAT or i == _RP or i == _NCYC:
            continue
        if si[io + i] != ist[i]:
            return False
    return True


@_kernel
def _repeat_record(rec, r0, L, m, ns_record, q0, d_rec, stop0, T, pext):
    """Write the record of ``m`` more cycles of ``L`` periods from record period ``r0`` on as
    copies of the cycle just recorded (its last period's minimum ``pext`` not yet stored):
    samples, per-period minima, the impacts after the ``q0`` recorded ones (``d_rec`` a cycle;
    their times as the kernel computes them, from their periods and times within them) and
    impacts per stop (``stop0``: at the cycle's start)."""
    pmin = rec.pmin
    pmin[r0 - 1] = pext
    for r in range(r0, r0 + m * L - 1):
        pmin[r] = pmin[r - L]
    lag = L * ns_record
    for k in range(r0 * ns_record, (r0 + m * L) * ns_record):
        for c in range(rec.samples.shape[1]):
            rec.samples[k, c] = rec.samples[k - lag, c]
        if rec.msamp.shape[0] > 0:
            for c in range(rec.msamp.shape[1]):
                rec.msamp[k, c] = rec.msamp[k - lag, c]
    n0 = rec.n_imp_stop.shape[0]
    for q in range(q0, min(q0 + m * d_rec, rec.imp_t.shape[0])):
        src = q - d_rec
        rec.imp_v[q] = rec.imp_v[src]
        rec.imp_k[q] = rec.imp_k[src]
        rec.imp_tl[q] = rec.imp_tl[src]
        rp = rec.imp_rp[src] + L
        rec.imp_rp[q] = rp
        rec.imp_t[q] = rp * T + rec.imp_tl[q]
    for k in range(n0):
        rec.n_imp_stop[k] += m * (rec.n_imp_stop[k] - stop0[k])


@_kernel
def _frequency(sy, st, hs, Om, eta, etad, rec, work, sub_r, sub_t, ns_transient, ns_record, h_cap):
    """Per-frequency data (particular solutions, the harmonic parts of every signal, the tables of
    the sub-steps ``sub_r, sub_t`` at ``Om``) into the work arrays ``work`` of :func:`new_work`;
    the record and the loop's state reset.  Returns 0, or -1 (the forced response is not finite)
    / -2 (the motion's scale is subnormal), the record then untouched."""
    (wn, wk, _hb, hab, hsig, hss, P_r, tab_r, P_t, tab_t, fs, ist, _sub_r, _sub_t, _sf, _si, _lp) = work
    n = eta.shape[0]
    ns = st.offset.shape[0]
    S = hs.valid.shape[0]
    T = TWO_PI / Om
    F = drive_force(sy.p, sy.B, Om)
    mp = sy.mp
    nt_t = ns_transient * sub_t
    nt_r = ns_record * sub_r
    for i in range(n):
        wn[_ZERO, i] = 0.0
    for j in range(_NFS):
        fs[j] = 0.0
    for j in range(_NIS):
        ist[j] = 0
    # ---- per-frequency data: particular solutions and the harmonic parts of every signal
    aF = wn[_AF]
    bF = wn[_BF]
    GF = wn[_GF]
    for i in range(n):
        GF[i] = sy.gam[i] * F
    if not _particular(sy.c, sy.k, sy.gam, F, Om, aF, bF, n):
        return -1
    # a motion at the scale of subnormal numbers (below 2.2e-308, i.e. with fewer than 53
    # significant bits) cannot be computed to the kernel's precision: failed at once (n_imp_total
    # -2), not a number with a few bits
    scale_f = 0.0
    for i in range(n):
        scale_f = max(scale_f, abs(aF[i]), abs(bF[i]), abs(eta[i]), abs(etad[i]))
    for k in range(ns):
        scale_f = max(scale_f, abs(st.offset[k]))
    if 0.0 < scale_f < 1e-290:
        return -2
    SaF = wk[_SAF]
    SbF = wk[_SBF]
    CsF = wk[_CSF]
    for k in range(ns):
        SaF[k] = _dot(st.normal[k], aF)
        SbF[k] = _dot(st.normal[k], bF)
        CsF[k] = math.sqrt(SaF[k] * SaF[k] + SbF[k] * SbF[k])
    fs[_SASF] = _dot(sy.sensor, aF)
    fs[_SBSF] = _dot(sy.sensor, bF)
    for m in range(1, S):
        if hs.valid[m] == 0:
            continue
        nc = hs.nc[m]
        aC = hab[m]
        bC = hab[S + m]
        if not _particular(hs.c[m], hs.nu2[m], hs.gam[m], F, Om, aC, bC, nc):
            return -1
        for k in range(ns):
            pa = 0.0
            pb = 0.0
            ra = 0.0
            rb = 0.0
            ga = 0.0
            gb = 0.0
            for j in range(nc):
                pa += hs.pL[m, k, j] * aC[j]
                pb += hs.pL[m, k, j] * bC[j]
                ra += hs.rL[m, k, j] * aC[j]
                rb += hs.rL[m, k, j] * bC[j]
                ga += hs.pG[m, k, j] * aC[j]
                gb += hs.pG[m, k, j] * bC[j]
            SaL = hs.lamF[m, k] * F + pa - Om * rb
            SbL = pb + Om * ra
            hsig[m, k] = SaL
            hsig[S + m, k] = SbL
            hsig[2 * S + m, k] = math.sqrt(SaL ** 2 + SbL ** 2)
            hsig[3 * S + m, k] = ga
            hsig[4 * S + m, k] = gb
            hsig[5 * S + m, k] = math.sqrt(ga * ga + gb * gb)
        sa = 0.0
        sb = 0.0
        for j in range(nc):
            sa += hs.pS[m, j] * aC[j]
            sb += hs.pS[m, j] * bC[j]
        hss[0, m] = sa
        hss[1, m] = sb
    # ---- the sub-steps' transition increments and forcing phases, tabulated once: a free step
    # over a whole sub-step that meets no event costs no transcendental function call
    for i in range(n):
        P_r[i, 0], P_r[i, 1], P_r[i, 2], P_r[i, 3] = transition_increment(
            T / (ns_record * sub_r), mp[i, 0], mp[i, 1], int(mp[i, 2]), mp[i, 3], mp[i, 4], mp[i, 5])
    for kk in range(nt_r + 1):
        tab_r[kk, 0] = math.sin(TWO_PI * kk / nt_r)
        tab_r[kk, 1] = math.cos(TWO_PI * kk / nt_r)
    if not (nt_t == nt_r and ns_transient == ns_record):
        for i in range(n):
            P_t[i, 0], P_t[i, 1], P_t[i, 2], P_t[i, 3] = transition_increment(
                T / (ns_transient * sub_t), mp[i, 0], mp[i, 1], int(mp[i, 2]), mp[i, 3], mp[i, 4], mp[i, 5])
        for kk in range(nt_t + 1):
            tab_t[kk, 0] = math.sin(TWO_PI * kk / nt_t)
            tab_t[kk, 1] = math.cos(TWO_PI * kk / nt_t)
    # ---- copies of the rows the steps read (the stops' offsets and effective masses, the
    # system's damping, stiffness and sensor)
    for i in range(n):
        wn[_SENS, i] = sy.sensor[i]
        wn[_CM, i] = sy.c[i]
        wn[_KM, i] = sy.k[i]
    for k in range(ns):
        wk[_OFF, k] = st.offset[k]
        wk[_MEFF, k] = st.m_eff[k]
    # ---- the record and the loop's state
    rec.nlog[0] = 0
    rec.nlog[1] = 0
    for k in range(ns):
        rec.n_imp_stop[k] = 0
    for i in range(n):
        rec.modamp[i] = 0.0
    for i in range(rec.pmin.shape[0]):
        rec.pmin[i] = np.inf
    fs[_EXT] = np.inf
    fs[_EXT1] = -np.inf
    fs[_PEXT] = np.inf
    fs[_PEXT1] = -np.inf
    fs[_HLAST] = h_cap
    fs[_GMAX] = -np.inf
    fs[_TLAST] = -1e300
    ist[_FRESH] = 1
    ist[_QFRESH] = 1
    ist[_QLAST] = -1
    return 0


@_kernel
def _rk_scales(itab, H, C, sy, st, hs, vr, rk):
    """:func:`vibeam.models.core.contact_phase.rk_scales` of a Runge-Kutta contact phase entered
    now; ``itab`` None (a scene that reaches no such phase,
    :class:`vibeam.models.core.phases.Compliant`): nothing, and nothing compiled."""
    if itab is not None:
        rk_scales(H, C, sy, st, hs, vr, rk)


@njit(cache=True, error_model="numpy", no_cfunc_wrapper=True)
def compliant_work(cp, st, n, rec):
    """The compliant stops' work arrays of a call (:class:`_CompliantWork`; :func:`_start_compliant`
    fills them at its frequency): ``cp`` the compliant stops' data, ``n`` the modes, ``rec`` the
    record (its contact rows)."""
    ns = st.offset.shape[0]
    Qn = cp.ph.m.shape[0]
    Lr = 2 * n + ns
    return _CompliantWork(st, cp, np.zeros((Qn, n)), np.zeros((Qn, n)), np.zeros((Qn, n)), np.zeros((Qn, n)),
                          np.zeros(ns), np.zeros(ns), np.zeros((ns, 5)), np.full(ns, -1, np.int64), np.zeros(4),
                          np.zeros(n), np.zeros(n), np.empty((n, 6)), np.empty(n), np.empty(n), np.empty(n),
                          np.empty(n), np.empty(2), np.empty(Lr), np.empty(Lr), np.empty(Lr), np.empty(Lr),
                          np.empty(Lr), np.empty(Lr), np.empty(Lr), np.empty((cp.tab.c.shape[0], Lr)), rec.con)


@_kernel
def _start_compliant(cw, sy, st, hs, Om, eta, etad, held0, ist, rec):
    """The compliant stops' work (:func:`compliant_work`) at this frequency: the linear contact
    phases' forced response, the entry-velocity floors, the contacts open at the start (from the
    state as given, before any projection) and the stops the body starts inside of."""
    ns = st.offset.shape[0]
    S = hs.valid.shape[0]
    F = drive_force(sy.p, sy.B, Om)
    cp = cw.cp
    # ---- compliant stops (a contact phase each; vibeam.models.core.contact_phase): the set in
    # contact C, the stops the body is inside of without contact, those left by a hysteretic-Hertz
    # stop's damping factor
    lph = cp.ph
    pax = cw.pax
    pbx = cw.pbx
    pay = cw.pay
    pby = cw.pby
    pax[:] = 0.0
    pbx[:] = 0.0
    pay[:] = 0.0
    pby[:] = 0.0
    phase_harmonics(cp.lin, Om, F, pax, pbx, pay, pby)
    vr = cw.vr                 # the open contacts' entry velocities (hysteretic Hertz: floored)
    vfl = cw.vfl
    cs = cw.cs                 # the open contacts' records (C_DURATION ...; column 0 the entry time)
    crow = cw.crow
    vr[:] = 0.0
    vfl[:] = 0.0
    cs[:] = 0.0
    crow[:] = -1
    cw.xq[:] = 0.0
    cw.yq[:] = 0.0
    cmask = 0
    for k in range(ns):
        if is_compliant(st.law[k]):
            cmask |= 1 << k
            vfl[k] = hertz_floor(Om, drive_displacement(sy.p, sy.B, Om), _dot(st.normal[k], sy.gam), cp.vfall,
                                  cp.vfac)
    rkc = cw.rkc
    rkc[:] = 0.0
    con = rec.con
    for r in range(con.shape[0]):
        for c in range(5):
            con[r, c] = np.nan
    H = held0 & ~cmask
    if H < 0 or H >= S or hs.valid[H] == 0:
        H = 0
    C = held0 & cmask if 0 <= held0 < S else 0
    inside = 0
    for k in range(ns):
        if (C >> k) & 1:
            U = _dot(st.normal[k], etad)
            gk = _dot(st.normal[k], eta) - st.offset[k]
            # the entry this run has not seen: v_in of the state's isolated contact (laws.start_velocity)
            vr[k] = max(start_velocity(st.law[k], gk, U, st.kc[k], st.pe[k], 1.0 / st.m_eff[k])[0], vfl[k])
            cs[k, 0] = 0.0
            cs[k, 1] = force(st.law[k], gk, U, st.kc[k], st.cc[k], st.pe[k], vr[k])
            cs[k, 2] = gk
            cs[k, 3] = 0.0
            cs[k, 4] = U
        elif (cmask >> k) & 1 and _dot(st.normal[k], eta) - st.offset[k] > 0.0:
            inside |= 1 << k
    if C != 0 and lph.index[H, C] < 0:
        _rk_scales(cp.itab, H, C, sy, st, hs, vr, rkc)
    ist[_CMASK] = cmask
    ist[_C] = C
    ist[_INSIDE] = inside


# ============================================================================ the steps
@_kernel
def _inside_touch(cw, Nrm, D, off, eta, etad, g, v, inside, relaxed, exited, phi, Om, wn, GF):
    """At a step's start, the compliant stops the state lies inside of without a contact (the
    ``inside`` mask): each is left (its gap back below zero: out of ``inside`` and ``relaxed``) or
    touched now (its force's sign up through zero, or at zero and rising; ``D[k]`` the direction
    of the free acceleration along stop ``k``: its normal in free flight, the held set's
    projection of it when held).  The gaps ``g`` and normal velocities ``v`` of the stops looked
    at are refreshed from the state.  Returns ``(k touched or -1, inside, relaxed)``."""
    st = cw.st
    vr = cw.vr
    for k in range(Nrm.shape[0]):
        if (inside >> k) & 1 == 0:
            continue
        gk = _dot(Nrm[k], eta) - off[k]
        vk = _dot(Nrm[k], etad)
        g[k] = gk
        v[k] = vk
        if gk <= 0.0:
            inside &= ~(1 << k)
            relaxed &= ~(1 << k)
            continue
        r0, r1, roff = inside_sign(st.law[k], st.kc[k], st.cc[k], vr[k], (relaxed >> k) & 1 == 1)
        acc, jerk = _contact_acc(phi, Om, eta, etad, D[k], wn[_CM], wn[_KM], GF)
        sg = r0 * gk + r1 * vk + roff
        tol = 1e-13 * (abs(r0 * gk) + abs(r1 * vk) + abs(roff))
        if (exited >> k) & 1:
            sg = 0.0      # just left it: the force is zero there to round-off
        if sg > tol or (sg >= -tol and r0 * vk + r1 * acc > 0.0):
            return k, inside, relaxed
    return -1, inside, relaxed


@_kernel
def _held_step(hs, Nrm, wn, wk, hb, hab, hsig, hss, eta, etad, fs, ist, evlog, aplog, nlog, cyc, Om, T, recording,
               cw):
    """One step held on the set ``H`` (no compliant contact): the constrained system in closed form,
    the held stops' forces scanned for their release, the other stops' gaps for a contact.
    Returns the stop of a contact (-1: none, the step was taken or the held set changed)."""
    n = eta.shape[0]
    ns = Nrm.shape[0]
    phi = fs[_PHI]
    t_loc = fs[_TLOC]
    rem = fs[_REM]
    h_last = fs[_HLAST]
    gmax = fs[_GMAX]
    hold = fs[_HOLD]
    stuck_time = fs[_STUCK]
    pT = fs[_PT]
    H = ist[_H]
    inside = ist[_INSIDE]
    relaxed = ist[_RELAXED]
    cmask = ist[_CMASK]
    just_released = ist[_JREL] != 0
    just_stuck = ist[_JSTUCK] != 0
    logging = evlog.shape[0] > 0
    apexes = aplog.shape[0] > 0
    h_try = min(rem, 2.0 * h_last)
    pext = fs[_PEXT:_PEXT1 + 1]
    GF = wn[_GF]
    zeroN = wn[_ZERO]
    x0 = wn[_X0]
    y0 = wn[_Y0]
    zeta = wn[_ZETA]
    zetad = wn[_ZETAD]
    g = wk[_G]
    v = wk[_V]
    lam0 = wk[_LAM0]
    lamp0 = wk[_LAMP0]
    off = wk[_OFF]
    S = hs.valid.shape[0]
    # the per-frequency data of the set H (rows of _frequency's arrays): the particular solution of
    # its coordinates; the harmonic parts of the held stops' forces (L) and of the gaps (G)
    aC = hab[H]
    bC = hab[S + H]
    SaL = hsig[H]
    SbL = hsig[S + H]
    CsL = hsig[2 * S + H]
    SaG = hsig[3 * S + H]
    SbG = hsig[4 * S + H]
    CsG = hsig[5 * S + H]
    SaS = hss[0, H]
    SbS = hss[1, H]
    ist[_FRESH] = 1
    ist[_ATGRID] = 0
    nc = hs.nc[H]
    Psi = hs.Psi[H]
    etc = hs.eta_c[H]
    mpC = hs.mp[H]
    eC = hs.e[H]
    # a stop not held that the system touches and does not leave: impact or stick
    touched = -1
    if cw is not None and inside != 0:
        touched, inside, relaxed = _inside_touch(cw, Nrm, hs.dirn[H], off, eta, etad, g, v, inside, relaxed,
                                                 ist[_EXITED], phi, Om, wn, GF)
    for j in range(ns):
        if touched >= 0:
            break
        if (H >> j) & 1 == 1 or hs.moves[H, j] == 0 or (inside >> j) & 1:
            continue
        if g[j] >= 0.0 and v[j] >= 0.0:
            g[j] = 0.0
            if v[j] > 0.0:
                touched = j
                break
            if not just_released:
                acc, jerk = _contact_acc(phi, Om, eta, etad, hs.dirn[H, j], wn[_CM], wn[_KM], GF)
                if (cmask >> j) & 1:
                    if acc > 0.0 or (acc == 0.0 and jerk > 0.0):
                        touched = j     # pressed onto a compliant stop: a contact
                        break
                elif not release_now(acc, jerk) and hs.valid[H | (1 << j)] == 1:
                    if logging:
                        _log_event(evlog, nlog, _K_STICK, pT + t_loc, 0.0, j, eta, etad)
                    H = H | (1 << j)
                    v[j] = 0.0
                    ist[_JSTUCK] = 1
                    touched = -2
                    break
    if touched != -1:
        ist[_H] = H
        ist[_INSIDE] = inside
        ist[_RELAXED] = relaxed
        return touched if touched >= 0 else -1
    for j in range(nc):
        zz = 0.0
        zd = 0.0
        for i in range(n):
            zz += Psi[i, j] * (eta[i] - etc[i])
            zd += Psi[i, j] * etad[i]
        zeta[j] = zz
        zetad[j] = zd
    homogeneous(phi, Om, zeta, zetad, aC, bC, eC, x0, y0, nc)
    # the shared release rule: lambda > 0 pulls the system off the stop
    for k in range(ns):
        if (H >> k) & 1 == 0:
            continue
        l0, lp0 = signal_start(phi, Om, x0, y0, mpC, hs.pL[H, k], hs.rL[H, k], SaL[k],
                               SbL[k], hs.cL[H, k], nc)
        waited = (ist[_RDEL] >> k) & 1 == 1 and hold <= 0.0     # after a wait the free flow decides
        if (release_now(-l0, -lp0) or waited and _release_wait(phi, Om, eta, etad, Nrm[k], wn, GF, -1.0, T) < 0.0) \
                and not just_stuck and hold <= 0.0:
            lam0[k] = l0
            if logging:
                # a release held back by a round-off (below) is its located zero crossing: aux 0
                _log_event(evlog, nlog, _K_RELEASE, pT + t_loc, 0.0 if (ist[_RDEL] >> k) & 1 else lam0[k], k,
                           eta, etad)
            ist[_RDEL] = 0
            ist[_H] = H & ~(1 << k)
            ist[_JREL] = 1
            ist[_INSIDE] = inside
            ist[_RELAXED] = relaxed
            g[k] = 0.0
            v[k] = 0.0
            return -1
        lam0[k] = l0 if l0 <= 0.0 else 0.0
        lamp0[k] = lp0
    ist[_RDEL] &= H     # a release waited for stays marked until its stop is released (_release_wait)
    fs[_WAIT] = fs[_WAIT] if ist[_RDEL] else 0.0
    for j in range(nc):
        homogeneous_bounds(x0[j], y0[j], mpC[j, 0], mpC[j, 1], int(mpC[j, 2]), mpC[j, 3],
                           mpC[j, 4], mpC[j, 5], hb[j])
    # the hold is the rest of a chatter sequence (impacts accumulating), not
    # sticking: no release check, not counted in stuck_time
    in_hold = hold > 0.0
    s_ev = -1.0
    k_ev = -1
    ev_release = False
    h = h_try
    if in_hold:
        h = min(h_try, hold)
    else:
        for k in range(ns):
            if (H >> k) & 1 == 0:
                continue
            M2, M3, M4 = bounds(hb, hs.pL[H, k], hs.rL[H, k], CsL[k], Om, nc)
            hk = h if s_ev < 0.0 else s_ev
            sk, hk2 = scan(hk, 1e-13 * T, phi, Om, x0, y0, mpC, hs.pL[H, k], hs.rL[H, k],
                           SaL[k], SbL[k], lam0[k], lamp0[k], M2, M3, M4, nc)
            if sk >= 0.0:
                s_ev = sk
                k_ev = k
                ev_release = True
            elif hk2 < hk:
                s_ev = -1.0
                k_ev = -1
                h = hk2
    ev_in = 0
    for j in range(ns):
        if (H >> j) & 1 == 1 or hs.moves[H, j] == 0:
            continue
        if cw is not None and (inside >> j) & 1:
            # inside a compliant stop: the sign of its force up, its gap down
            st = cw.st
            vr = cw.vr
            wpa = cw.wpa
            wra = cw.wra
            r0, r1, roff = inside_sign(st.law[j], st.kc[j], st.cc[j], vr[j],
                                       (relaxed >> j) & 1 == 1)
            for i in range(nc):
                wpa[i] = r0 * hs.pG[H, j, i]
                wra[i] = r1 * hs.pG[H, j, i]
            Sa = r0 * SaG[j] - r1 * Om * SbG[j]
            Sb = r0 * SbG[j] + r1 * Om * SaG[j]
            M2, M3, M4 = bounds(hb, wpa, wra, math.sqrt(Sa * Sa + Sb * Sb), Om, nc)
            f0, fp0 = signal_start(phi, Om, x0, y0, mpC, wpa, wra, Sa, Sb,
                                   r0 * hs.cG[H, j] + roff, nc)
            hk = h if s_ev < 0.0 else s_ev
            sk, hk2 = scan(hk, 1e-13 * T, phi, Om, x0, y0, mpC, wpa, wra, Sa, Sb, f0, fp0,
                           M2, M3, M4, nc)
            if sk >= 0.0:
                s_ev = sk
                k_ev = j
                ev_release = False
                ev_in = 1
            elif hk2 < hk:
                s_ev = -1.0
                k_ev = -1
                ev_in = 0
                h = hk2
            for i in range(nc):
                wpa[i] = -hs.pG[H, j, i]
            M2, M3, M4 = bounds(hb, wpa, zeroN, CsG[j], Om, nc)
            hk = h if s_ev < 0.0 else s_ev
            sk, hk2 = scan(hk, 1e-13 * T, phi, Om, x0, y0, mpC, wpa, zeroN, -SaG[j],
                           -SbG[j], -g[j], -v[j], M2, M3, M4, nc)
            if sk >= 0.0:
                s_ev = sk
                k_ev = j
                ev_release = False
                ev_in = 2
            elif hk2 < hk:
                s_ev = -1.0
                k_ev = -1
                ev_in = 0
                h = hk2
            continue
        M2, M3, M4 = bounds(hb, hs.pG[H, j], zeroN, CsG[j], Om, nc)
        hk = h if s_ev < 0.0 else s_ev
        sk, hk2 = scan(hk, 1e-13 * T, phi, Om, x0, y0, mpC, hs.pG[H, j], zeroN, SaG[j],
                       SbG[j], g[j], v[j], M2, M3, M4, nc)
        if sk >= 0.0:
            s_ev = sk
            k_ev = j
            ev_release = False
            ev_in = 0
        elif hk2 < hk:
            s_ev = -1.0
            k_ev = -1
            ev_in = 0
            h = hk2
    if s_ev < 0.0 and not in_hold:
        h_last = h if h < h_try else max(h_last, h)
    s_mv = s_ev if s_ev >= 0.0 else h
    for j in range(ns):
        if (H >> j) & 1 == 1 or hs.moves[H, j] == 0:
            continue
        gj, vj, _a, _b, _c = signal(s_mv, phi, Om, x0, y0, mpC, hs.pG[H, j], zeroN, SaG[j],
                                    SbG[j], g[j], v[j], nc)
        if apexes and not (s_ev >= 0.0 and k_ev == j) and v[j] > 0.0 and vj <= 0.0:
            _log_apex(aplog, nlog, pT + t_loc, s_mv, phi, Om, x0, y0, mpC, hs.pG[H, j],
                      zeroN, SaG[j], SbG[j], g[j], v[j], nc, j, np.nan, 0.0, np.nan)
        if (inside >> j) & 1:
            g[j] = gj
            v[j] = vj
            continue
        if gj > gmax and not (s_ev >= 0.0 and k_ev == j):
            gmax = gj
        g[j] = gj if gj < 0.0 else 0.0
        v[j] = vj
    if recording:
        q0s, qp0s = signal_start(phi, Om, x0, y0, mpC, hs.pS[H], zeroN, SaS, SbS,
                                 hs.cS[H], nc)
        q1s, qp1s, _a, _b, _c = signal(s_mv, phi, Om, x0, y0, mpC, hs.pS[H], zeroN, SaS,
                                       SbS, q0s, qp0s, nc)
        extremes(s_mv, phi, Om, x0, y0, mpC, hs.pS[H], zeroN, SaS, SbS, q0s, qp0s, qp0s,
                 qp1s, pext, nc)
        if q1s < pext[0]:
            pext[0] = q1s
        if q1s > pext[1]:
            pext[1] = q1s
        if not in_hold:
            stuck_time += s_mv
            _cycle_log(cyc, ist, CY_HELD, s_mv, 0.0, 0.0)
    if in_hold:
        hold -= s_mv
        if hold < 1e-15 * T:
            hold = 0.0
    advance_count(s_mv, phi, Om, zeta, zetad, mpC, aC, bC, eC, nc)
    for i in range(n):
        zz = etc[i]
        zd = 0.0
        for j in range(nc):
            zz += Psi[i, j] * zeta[j]
            zd += Psi[i, j] * zetad[j]
        eta[i] = zz
        etad[i] = zd
    phi, t_loc, rem = _clock(phi, t_loc, rem, s_mv, Om, T)
    if s_mv > 0.0:
        ist[_JSTUCK] = 0
        ist[_JREL] = 0
        ist[_EXITED] = 0
    k_imp = -1
    if s_ev >= 0.0:
        early = 0.0
        if ev_release and H == 1 << k_ev:
            early = max(_release_wait(phi, Om, eta, etad, Nrm[k_ev], wn, GF, fs[_WAIT], T), 0.0)
        if ev_release and early > 0.0:
            hold = early
            ist[_RDEL] = 1 << k_ev
            fs[_WAIT] = early
        elif ev_release:
            if logging:
                _log_event(evlog, nlog, _K_RELEASE, pT + t_loc, 0.0, k_ev, eta, etad)
            H = H & ~(1 << k_ev)
            ist[_RDEL] &= ~(1 << k_ev)
            fs[_WAIT] = 0.0
            ist[_JREL] = 1
            g[k_ev] = 0.0
            v[k_ev] = 0.0
        elif ev_in == 2:
            inside &= ~(1 << k_ev)
            relaxed &= ~(1 << k_ev)
            g[k_ev] = 0.0
        else:
            k_imp = k_ev
    fs[_PHI] = phi
    fs[_TLOC] = t_loc
    fs[_REM] = rem
    fs[_HLAST] = h_last
    fs[_GMAX] = gmax
    fs[_HOLD] = hold
    fs[_STUCK] = stuck_time
    ist[_H] = H
    ist[_INSIDE] = inside
    ist[_RELAXED] = relaxed
    return k_imp


@_kernel
def _contact_phase(sy, st, hs, cw, wk, eta, etad, fs, ist, evlog, nlog, Om, T, recording):
    """One step in contact with the compliant stops ``C`` (held on ``H``; a linear phase exactly,
    another by Runge-Kutta: :mod:`vibeam.models.core.contact_phase`) and its event.  Returns the
    stop of a contact to resolve (an entry or a Newton impact), -1 (none), -2 (failed)."""
    ns = st.offset.shape[0]
    cp = cw.cp
    lph = cp.ph
    cs = cw.cs
    vr = cw.vr
    crow = cw.crow
    con = cw.con
    phi = fs[_PHI]
    t_loc = fs[_TLOC]
    rem = fs[_REM]
    H = ist[_H]
    C = ist[_C]
    inside = ist[_INSIDE]
    relaxed = ist[_RELAXED]
    cmask = ist[_CMASK]
    qfresh = ist[_QFRESH] != 0
    q_last = ist[_QLAST]
    logging = evlog.shape[0] > 0
    pext = fs[_PEXT:_PEXT1 + 1]
    g = wk[_G]
    v = wk[_V]
    F = drive_force(sy.p, sy.B, Om)
    ist[_FRESH] = 1
    ist[_ATGRID] = 0
    qq = lph.index[H, C]
    if qq >= 0:
        if qq != q_last:
            qfresh = True
            q_last = qq
        s_mv, ekind, kk, eaux = linear_step(qq, H, C, inside, relaxed, rem, 1e-13 * T, phi, Om, F,
                                            eta, etad, st, hs, cp.lin, cw, qfresh, recording, pext)
        qfresh = False
    else:
        q_last = -1
        s_mv, ekind, kk, eaux = rk_phase_step(H, C, inside, relaxed, rem, phi, Om, F, eta, etad, sy,
                                              st, hs, cp.itab, cw, recording, pext)
    ist[_QFRESH] = qfresh
    ist[_QLAST] = q_last
    if ekind == EK_FAIL:
        return -2
    if recording:
        fs[_TCON] += s_mv
        if H != 0:
            fs[_STUCK] += s_mv
    phi, t_loc, rem = _clock(phi, t_loc, rem, s_mv, Om, T)
    fs[_PHI] = phi
    fs[_TLOC] = t_loc
    fs[_REM] = rem
    if s_mv > 0.0:
        ist[_JSTUCK] = 0
        ist[_JREL] = 0
        ist[_EXITED] = 0
    for j in range(ns):
        if (H >> j) & 1 == 1:
            g[j] = 0.0
            v[j] = 0.0
        else:
            g[j] = _dot(st.normal[j], eta) - st.offset[j]
            v[j] = _dot(st.normal[j], etad)
            if g[j] > 0.0 and (cmask >> j) & 1 == 0:
                g[j] = 0.0      # a Newton stop is never penetrated (round-off)
    if ekind == EK_NONE:
        return -1
    ist[_QFRESH] = 1
    if ekind == EK_EXIT:
        C &= ~(1 << kk)
        ist[_EXITED] |= 1 << kk
        if g[kk] > 0.0:
            inside |= 1 << kk
            if eaux == 1:
                relaxed |= 1 << kk
        r = crow[kk]
        if r >= 0:
            if r < con.shape[0]:
                con[r, 0] = fs[_T0] + t_loc - cs[kk, 0]
                for c in range(1, 5):
                    con[r, c] = cs[kk, c]
            crow[kk] = -1
        if logging:
            _log_event(evlog, nlog, _K_EXIT, fs[_PT] + t_loc, float(eaux), kk, eta, etad)
        if C != 0 and lph.index[H, C] < 0:
            _rk_scales(cp.itab, H, C, sy, st, hs, vr, cw.rkc)
        ist[_C] = C
        ist[_INSIDE] = inside
        ist[_RELAXED] = relaxed
        return -1
    if ekind == EK_GAPDOWN:
        ist[_INSIDE] = inside & ~(1 << kk)
        ist[_RELAXED] = relaxed & ~(1 << kk)
        g[kk] = 0.0
        return -1
    if ekind == EK_RELEASE:
        if logging:
            _log_event(evlog, nlog, _K_RELEASE, fs[_PT] + t_loc, 0.0, kk, eta, etad)
        ist[_H] = H & ~(1 << kk)
        ist[_JREL] = 1
        g[kk] = 0.0
        v[kk] = 0.0
        return -1
    return kk         # an entry (EK_ENTRY) or a Newton impact (EK_IMPACT)


@_kernel
def _entry(sy, st, hs, cw, wk, eta, etad, fs, ist, rec, kk, max_impacts, recording):
    """A compliant stop's contact begins (held set ``H`` kept).  Returns True when the impacts and
    contacts exceed ``max_impacts`` (failed)."""
    cs = cw.cs
    vr = cw.vr
    crow = cw.crow
    g = wk[_G]
    v = wk[_V]
    t_loc = fs[_TLOC]
    t_period0 = fs[_T0]
    H = ist[_H]
    ist[_FRESH] = 1
    ist[_ATGRID] = 0
    ist[_QFRESH] = 1
    U = _dot(st.normal[kk], etad)
    gk = _dot(st.normal[kk], eta) - st.offset[kk]
    if rec.evlog.shape[0] > 0:
        _log_event(rec.evlog, rec.nlog, _K_ENTRY, fs[_PT] + t_loc, U, kk, eta, etad)
    C = ist[_C] | 1 << kk
    ist[_C] = C
    ist[_INSIDE] &= ~(1 << kk)
    ist[_RELAXED] &= ~(1 << kk)
    vr[kk] = max(U if st.law[kk] != LAW_LINEAR else abs(U), cw.vfl[kk])
    cs[kk, 0] = t_period0 + t_loc
    cs[kk, 1] = force(st.law[kk], gk, U, st.kc[kk], st.cc[kk], st.pe[kk], vr[kk])
    cs[kk, 2] = gk
    cs[kk, 3] = 0.0
    cs[kk, 4] = U
    g[kk] = gk
    v[kk] = U
    n_imp_total = ist[_NIMPT] + 1
    ist[_NIMPT] = n_imp_total
    crow[kk] = -1
    if recording:
        n_imp_rec = ist[_NIMPR]
        if n_imp_rec < rec.imp_t.shape[0]:
            rec.imp_t[n_imp_rec] = t_period0 + t_loc
            rec.imp_tl[n_imp_rec] = t_loc
            rec.imp_rp[n_imp_rec] = ist[_RP]
            rec.imp_v[n_imp_rec] = U
            rec.imp_k[n_imp_rec] = kk
        crow[kk] = n_imp_rec
        ist[_NIMPR] = n_imp_rec + 1
        rec.n_imp_stop[kk] += 1
    if n_imp_total > max_impacts:
        return True
    if cw.cp.ph.index[H, C] < 0:
        _rk_scales(cw.cp.itab, H, C, sy, st, hs, vr, cw.rkc)
    return False


@_kernel
def _impact(st, dirn, meff, ceff, keff, valid, wn, wk, eta, etad, fs, ist, rec, Om, T, k_imp, max_impacts,
            chatter_tol, recording, cw):
    """The contact event on Newton stop ``k_imp`` (held set ``H`` kept): the stop's law, then the one
    chatter / sticking policy (:mod:`vibeam.models.core.contact_policy`).  Returns True when the impacts
    exceed ``max_impacts`` (failed)."""
    n = eta.shape[0]
    ns = st.offset.shape[0]
    phi = fs[_PHI]
    t_loc = fs[_TLOC]
    rem = fs[_REM]
    t_period0 = fs[_T0]
    H = ist[_H]
    C = ist[_C]
    g = wk[_G]
    v = wk[_V]
    GF = wn[_GF]
    evlog = rec.evlog
    nlog = rec.nlog
    logging = evlog.shape[0] > 0
    chat_t = rec.chat_t
    ist[_FRESH] = 1
    ist[_ATGRID] = 0
    if H != 0:
        d = dirn[H, k_imp]
        me = meff[H, k_imp]
        c_eff = ceff[H, k_imp]
        k_eff = keff[H, k_imp]
    else:
        d = st.normal[k_imp]
        me = st.m_eff[k_imp]
        c_eff = st.c_eff[k_imp]
        k_eff = st.k_eff[k_imp]
    nk = st.normal[k_imp]
    vk = v[k_imp]
    # Re-sync the state with the carried contact signal: ``g, v`` are carried as value +
    # increment (no cancellation), so they differ from the state's ``n^T eta - D, n^T eta'``
    # by round-off that nothing contracts (the impact resets ``g`` to 0 and maps the
    # velocity offset to itself): on a periodic orbit it would shift the stop seen by the
    # state linearly with the periods of a call.  Project the state onto the event
    # (contact at gap 0 with velocity v) along d (d keeps the held constraints).
    gs = (_dot(nk, eta) - st.offset[k_imp]) * me
    vs = (_dot(nk, etad) - vk) * me
    for i in range(n):
        eta[i] -= d[i] * gs
        etad[i] -= d[i] * vs
    g[k_imp] = 0.0
    Um = vk if vk > 0.0 else 0.0
    if logging:
        _log_event(evlog, nlog, _K_IMPACT, fs[_PT] + t_loc, Um, k_imp, eta, etad)
    # CONTACT EVENT: the stop's law (Newton's, impulsive), impulse along d
    Rc = newton_coefficient(st, k_imp, Um)
    Up = newton_restitution(Um, Rc)
    # the impulse in two parts, the normal velocity first removed, then U+ added: a
    # rebound far slower than U- (R -> 0) is not lost to the rounding of U+ - U-
    P0 = -me * vk
    P1 = me * Up
    for i in range(n):
        etad[i] += d[i] * P0
    for i in range(n):
        etad[i] += d[i] * P1
    for j in range(ns):
        if j != k_imp and (H >> j) & 1 == 0:
            v[j] = _dot(st.normal[j], etad)
    v[k_imp] = Up
    n_imp_total = ist[_NIMPT] + 1
    ist[_NIMPT] = n_imp_total
    if recording:
        n_imp_rec = ist[_NIMPR]
        if n_imp_rec < rec.imp_t.shape[0]:
            rec.imp_t[n_imp_rec] = t_period0 + t_loc
            rec.imp_tl[n_imp_rec] = t_loc
            rec.imp_rp[n_imp_rec] = ist[_RP]
            rec.imp_v[n_imp_rec] = Um
            rec.imp_k[n_imp_rec] = k_imp
        ist[_NIMPR] = n_imp_rec + 1
        rec.n_imp_stop[k_imp] += 1
    if n_imp_total > max_impacts:
        return True
    # the shared policy (vibeam.models.core.contact_policy), R at the current impact velocity:
    # the jerk beyond the one-DOF flow part -c_eff a + k_eff u is the forcing term plus the
    # modal remainder (zero for one mode); a chatter jumps only to an accumulation point
    # inside the current grid step; the Zeno guard is on
    u = -Up
    acc, jerk = _contact_acc(phi, Om, eta, etad, d, wn[_CM], wn[_KM], GF)
    if cw is not None and C != 0:
        # the compliant stops in contact push too (their force along d)
        vr = cw.vr
        for c in range(ns):
            if (C >> c) & 1:
                fc = force(st.law[c], _dot(st.normal[c], eta) - st.offset[c], _dot(st.normal[c], etad),
                           st.kc[c], st.cc[c], st.pe[c], vr[c])
                acc -= _dot(d, st.normal[c]) * fc
    t_imp = t_period0 + t_loc
    burst = zeno_burst(ist[_BURST], t_imp, fs[_TLAST], BURST_DT * T)
    fs[_TLAST] = t_imp
    can_hold = valid[H | (1 << k_imp)] == 1
    action, D = impact_outcome(u, can_hold and not release_now(acc, jerk), acc, jerk + c_eff * acc - k_eff * u,
                               c_eff, k_eff, Rc, chatter_tol, rem, burst, burst_limit(n, Rc))
    if not can_hold:
        action = REBOUND
    stick_now = action != REBOUND
    if action == STICK or action == CHATTER_GUARD:
        burst = 0
    ist[_BURST] = burst
    if action == CHATTER_GUARD:
        if recording:
            n_chatter = ist[_NCHAT] + 1
            ist[_NCHAT] = n_chatter
            if n_chatter <= chat_t.shape[0]:
                chat_t[n_chatter - 1] = t_imp
            _cycle_log(rec.cycle, ist, CY_GUARD, float(ist[_RP]), t_loc, 0.0)
    elif action == CHATTER:
        fs[_HOLD] = D if C == 0 else 0.0     # (beside a compliant contact: stick at once)
        if recording:
            n_chatter = ist[_NCHAT] + 1
            ist[_NCHAT] = n_chatter
            if n_chatter <= chat_t.shape[0]:
                chat_t[n_chatter - 1] = t_imp + D
            _cycle_log(rec.cycle, ist, CY_CHATTER, float(ist[_RP]), t_loc, D)
    if stick_now:
        if logging:
            _log_event(evlog, nlog, _K_STICK_IMPACT, fs[_PT] + t_loc, fs[_HOLD], k_imp, eta, etad)
        corr = Up * me
        for i in range(n):
            etad[i] -= d[i] * corr
        v[k_imp] = 0.0
        H = H | (1 << k_imp)
        ist[_H] = H
        ist[_JSTUCK] = 1
        for j in range(ns):
            if (H >> j) & 1 == 0:
                v[j] = _dot(st.normal[j], etad)   # the projection moved them too
    return False


# ============================================================================ the kernel
# ============================================================================ the loop
@_kernel
def _initial_state(st, hs, eta, etad, held0, wn, wk, ist, rec):
    """Phase *start*: the initial state held on its set ``held0`` (projected onto the constraint),
    or put on a Newton stop it lies on within round-off (position only); the carried gaps and
    normal velocities ``wk``, the held set ``ist[_H]`` (the event log: :data:`EV_START` rows)."""
    n = eta.shape[0]
    ns = st.offset.shape[0]
    S = hs.valid.shape[0]
    logging = rec.evlog.shape[0] > 0
    cmask = ist[_CMASK]
    H = held0 & ~cmask
    if H < 0 or H >= S or hs.valid[H] == 0:
        H = 0
    eta_norm = math.sqrt(_dot(eta, eta))
    if H != 0:
        nc = hs.nc[H]
        for j in range(nc):
            zz = 0.0
            zd = 0.0
            for i in range(n):
                zz += hs.Psi[H, i, j] * (eta[i] - hs.eta_c[H, i])
                zd += hs.Psi[H, i, j] * etad[i]
            wn[_ZETA, j] = zz
            wn[_ZETAD, j] = zd
        for i in range(n):
            zz = hs.eta_c[H, i]
            zd = 0.0
            for j in range(nc):
                zz += hs.Psi[H, i, j] * wn[_ZETA, j]
                zd += hs.Psi[H, i, j] * wn[_ZETAD, j]
            eta[i] = zz
            etad[i] = zd
        if logging:
            for k in range(ns):
                if (H >> k) & 1 == 1:
                    _log_event(rec.evlog, rec.nlog, _K_START, 0.0, 1.0, k, eta, etad)
    for k in range(ns):
        wk[_G, k] = _dot(st.normal[k], eta) - st.offset[k]
        wk[_V, k] = _dot(st.normal[k], etad)
        if (H >> k) & 1 == 1:
            wk[_G, k] = 0.0
            wk[_V, k] = 0.0
    if H == 0 and ist[_C] == 0:
        for k in range(ns):
            if (cmask >> k) & 1:
                continue
            scale = abs(st.offset[k]) + math.sqrt(_dot(st.normal[k], st.normal[k])) * eta_norm + 1e-300
            if wk[_G, k] > -1e-13 * scale:
                corr = wk[_G, k] * st.m_eff[k]
                for i in range(n):
                    eta[i] -= st.normal[k, i] * corr
                for j in range(ns):
                    wk[_G, j] = _dot(st.normal[j], eta) - st.offset[j]
                wk[_G, k] = 0.0
                if logging:
                    _log_event(rec.evlog, rec.nlog, _K_START, 0.0, 0.0, k, eta, etad)
                break
    ist[_H] = H


@_inline
def _recurrence(eta, etad, work, rec, lp, n_transient, n_total, T, max_steps, max_impacts):
    """Phase *recurrence*, at a period start (module docstring): the state compared bit for bit
    with the two snapshots; a cycle found in the transient is skipped up to the record, one found
    in the record is copied to its end (whole cycles; the counters advance by theirs), or a
    snapshot is taken when one is due.  The loop's counters live in ``lp`` (period, the
    snapshots' periods, samples taken, periods skipped).  True when periods were skipped (the
    caller starts again at the new period ``lp[_LPP]``)."""
    (wn, wk, hb, _hab, _hsig, _hss, _P_r, _tab_r, _P_t, _tab_t, fs, ist, _sub_r, _sub_t, snap_f, snap_i, _lp) = work
    n = eta.shape[0]
    ns = wk.shape[1]
    ns_record = lp[_LNSREC]
    pp = lp[_LPP]
    snap_pp = lp[_LSNAP]
    snapb_pp = lp[_LSNAPB]
    k_sample = lp[_LKS]
    skipped = lp[_LSKIP]
    j_fs = _snap_fs(n, ns)
    nsf = snap_f.shape[0] // 2      # the two snapshots: [0, nsf) and [nsf, 2 nsf)
    nsi = snap_i.shape[0] // 2
    in_rec = pp >= n_transient
    s_pp = -1
    fo = 0
    io = 0
    p0 = -1         # the cycle log's length at the snapshot found
    for b in range(2):
        b_pp = snap_pp if b == 0 else snapb_pp
        if b_pp >= 0 and (b_pp >= n_transient or not in_rec) and \
                _recurs(snap_f, snap_i, b * nsf, b * nsi, eta, etad, wn, wk, hb, fs, ist):
            s_pp = b_pp
            fo = b * nsf
            io = b * nsi
            p0 = lp[_LCYA] if b == 0 else lp[_LCYB]
            break
    if s_pp >= 0:
        L = pp - s_pp
        m = ((n_total if in_rec else n_transient) - pp) // L
        d_steps = ist[_NSTEPS] - snap_i[io + _NSTEPS]
        d_imp = ist[_NIMPT] - snap_i[io + _NIMPT]
        ok = m > 0 and ist[_NSTEPS] + m * d_steps <= max_steps and ist[_NIMPT] + m * d_imp <= max_impacts
        p1 = ist[_NCYC]
        logged = p0 >= 0 and p1 >= p0
        if in_rec:
            # the record's sums over the cycle: none (no time held or in contact, no chatter), or
            # the cycle log's rows to replay (no compliant contact: the recurrence is off there)
            ok = ok and fs[_TCON] == snap_f[fo + j_fs + _TCON] and (logged or (
                ist[_NCHAT] == snap_i[io + _NCHAT] and fs[_STUCK] == snap_f[fo + j_fs + _STUCK]))
        if ok:
            if in_rec:
                d_rec = ist[_NIMPR] - snap_i[io + _NIMPR]
                _repeat_record(rec, pp - n_transient, L, m, ns_record, ist[_NIMPR], d_rec,
                               snap_i[io + _NIS:io + nsi], T, fs[_PEXT])
                ist[_NIMPR] += m * d_rec
                k_sample += m * L * ns_record
                if logged and p1 > p0:
                    _replay_cycle(rec.cycle, p0, p1, m, L, T, fs, ist, rec.chat_t)
            ist[_NSTEPS] += m * d_steps
            ist[_NIMPT] += m * d_imp
            if fs[_TLAST] > -1e299:
                fs[_TLAST] += (m * L) * T
            pp += m * L
            skipped += m * L
            snap_pp = -1
            snapb_pp = -1
            lp[_LPP] = pp
            lp[_LSNAP] = snap_pp
            lp[_LSNAPB] = snapb_pp
            lp[_LKS] = k_sample
            lp[_LSKIP] = skipped
            return True     # (the call may end here)
        if in_rec or m > 0:
            snap_pp = -2    # a guard, or a record whose cycle log is full: integrate on
    else:
        # (not at the call's first period start: the loop's flags are those of a fresh start
        # there, e.g. the free arc's parts about to be recomputed, which a settled orbit's
        # later period starts do not repeat: a short call, a sweep engine's chunk, would
        # then wait RECUR_MAX periods for its first useful snapshot)
        for b in range(2):      # one snapshot a period: the first that is due
            b_pp = snap_pp if b == 0 else snapb_pp
            if (b_pp == -1 and pp > 0) or pp - b_pp >= (RECUR_MAX if b == 0 else RECUR_FAST) or \
                    (in_rec and b_pp < n_transient):
                _snapshot(snap_f, snap_i, b * nsf, b * nsi, eta, etad, wn, wk, hb, fs, ist, rec.n_imp_stop)
                if b == 0:
                    snap_pp = pp
                    lp[_LCYA] = ist[_NCYC]
                else:
                    snapb_pp = pp
                    lp[_LCYB] = ist[_NCYC]
    lp[_LPP] = pp
    lp[_LSNAP] = snap_pp
    lp[_LSNAPB] = snapb_pp
    lp[_LKS] = k_sample
    lp[_LSKIP] = skipped
    return False


@_inline
def _period_start(fs, ist, pmin, pp, n_transient, T):
    """A period's start: its times (from the record's start, and from the call's), and the
    sensor's extremes of the period that ended (the record: its minimum, the running extremes)."""
    ist[_RP] = pp - n_transient
    fs[_T0] = (pp - n_transient) * T
    fs[_PT] = pp * T
    if pp > n_transient:
        pmin[pp - n_transient - 1] = fs[_PEXT]
        fs[_EXT] = min(fs[_EXT], fs[_PEXT])
        fs[_EXT1] = max(fs[_EXT1], fs[_PEXT1])
        fs[_PEXT] = np.inf
        fs[_PEXT1] = -np.inf


@_inline
def _held_phase(hs, st, cw, work, rec, eta, etad, dense, Om, T, recording):
    """Phase *held* on the set ``ist[_H]``: one step (:func:`_held_step`), with a dense record up to
    the record's next sample, as on its own grid.  ``dense``: ``(j_next, j_end, base, h_rs)``, the
    dense record's next sample ``base + j_next`` (none when ``j_next >= j_end``), ``h_rs`` apart.
    Returns the stop of a contact, or -1."""
    (wn, wk, hb, hab, hsig, hss, _P_r, _tab_r, _P_t, _tab_t, fs, ist, _sub_r, _sub_t, _snap_f, _snap_i, _lp) = work
    j_next, j_end, base, h_rs = dense
    rem_full = fs[_REM]
    cut = rem_full
    if j_next < j_end:
        cut = min(rem_full, (base + j_next) * h_rs - fs[_TLOC])
        fs[_REM] = cut
    k_imp = _held_step(hs, st.normal, wn, wk, hb, hab, hsig, hss, eta, etad, fs, ist, rec.evlog, rec.aplog, rec.nlog,
                       rec.cycle, Om, T, recording, cw)
    if cut != rem_full:
        rest = rem_full - (cut - fs[_REM])
        fs[_REM] = rest if rest >= 1e-15 * T else 0.0
    return k_imp


@_inline
def _contact_event(sy, st, hs, cw, work, rec, eta, etad, dense, recording, k_imp, Om, guards):
    """Phase *contact* at the current time on stop ``k_imp``: a compliant stop's contact begins
    (:func:`_entry`), or a Newton stop's impact and the chatter / sticking policy act
    (:func:`_impact`; a dense record: the policy sees the rest of the record's grid step).
    ``dense``: ``(j_next, j_end, base, h_rs)`` as :func:`_held_phase`'s; ``guards``:
    ``(max_impacts, chatter_tol)``.  True when the call failed."""
    (wn, wk, _hb, _hab, _hsig, _hss, _P_r, _tab_r, _P_t, _tab_t, fs, ist, _sub_r, _sub_t, _snap_f, _snap_i, _lp) = work
    max_impacts, chatter_tol = guards
    j_next, j_end, base, h_rs = dense
    if cw is not None and (ist[_CMASK] >> k_imp) & 1:
        return _entry(sy, st, hs, cw, wk, eta, etad, fs, ist, rec, k_imp, max_impacts, recording)
    T = TWO_PI / Om
    rem_full = fs[_REM]
    if j_next < j_end:
        fs[_REM] = min(rem_full, (base + j_next) * h_rs - fs[_TLOC])
    failed = _impact(st, hs.dirn, hs.meff, hs.ceff, hs.keff, hs.valid, wn, wk, eta, etad, fs, ist, rec, Om, T,
                     k_imp, max_impacts, chatter_tol, recording, cw)
    fs[_REM] = rem_full
    return failed


@_inline
def _free_touch(st, cw, wn, wk, fs, ist, rec, eta, etad, Om):
    """The stops touched at a free step's start: a stop reached with ``U > 0`` (a contact), a
    compliant stop pressed onto (a contact) or a Newton stop pressed onto by the release rule
    (sticking entered: the stop joins the held set); inside a compliant stop, its force's sign
    (:func:`_inside_touch`).  Returns the stop of a contact, -2 (sticking entered) or -1; the
    stops the body is inside of go to ``ist``."""
    n = eta.shape[0]
    ns = st.offset.shape[0]
    Nrm = st.normal
    evlog = rec.evlog
    nlog = rec.nlog
    logging = evlog.shape[0] > 0
    phi = fs[_PHI]
    t_loc = fs[_TLOC]
    pT = fs[_PT]
    inside = ist[_INSIDE]
    relaxed = ist[_RELAXED]
    cmask = ist[_CMASK]
    just_released = ist[_JREL] != 0
    GF = wn[_GF]
    g = wk[_G]
    v = wk[_V]
    off = wk[_OFF]
    touched = -1
    if cw is not None and inside != 0:
        touched, inside, relaxed = _inside_touch(cw, Nrm, Nrm, off, eta, etad, g, v, inside,
                                                 relaxed, ist[_EXITED], phi, Om, wn, GF)
    # the stops reached, each in turn, only where one is: _contact_acc's sin and cos of the forcing
    # phase are loop-invariant and speculatable, and LLVM hoists them before the loop, where they
    # cost a sincos call on every free step (~200 instructions: 9 % of a Fig. 7 sweep's) though
    # most steps reach no stop
    reached = False
    for k in range(ns):
        reached = reached or ((inside >> k) & 1 == 0 and g[k] >= 0.0 and v[k] >= 0.0)
    if reached:
        for k in range(ns):
            if touched >= 0:
                break
            if (inside >> k) & 1 or not (g[k] >= 0.0 and v[k] >= 0.0):
                continue
            g[k] = 0.0
            if v[k] > 0.0:
                touched = k
                break
            if just_released:
                continue
            acc, jerk = _contact_acc(phi, Om, eta, etad, Nrm[k], wn[_CM], wn[_KM], GF)
            if (cmask >> k) & 1:
                if acc > 0.0 or (acc == 0.0 and jerk > 0.0):
                    touched = k     # pressed onto a compliant stop: a contact
                    break
            elif not release_now(acc, jerk):     # pressed (the release rule)
                if logging:
                    _log_event(evlog, nlog, _K_STICK, pT + t_loc, 0.0, k, eta, etad)
                ist[_H] = 1 << k
                ist[_JSTUCK] = 1
                corr = v[k] * wk[_MEFF, k]
                for i in range(n):
                    etad[i] -= Nrm[k, i] * corr
                v[k] = 0.0
                for j in range(ns):
                    if j != k:
                        v[j] = _dot(Nrm[j], etad)
                touched = -2
                break
    ist[_INSIDE] = inside
    ist[_RELAXED] = relaxed
    if touched == -2:
        ist[_FRESH] = 1
    return touched


@_inline
def _free_arc(sy, st, work, eta, etad, tab, Ptab, kg, Om):
    """A free step's length and the flow at its end: a new free arc's homogeneous parts, their
    bounds (valid along the whole arc: the homogeneous envelope only decays) and each gap's
    curvature when the arc is fresh; the step ``h`` (at most twice the last, to the sub-step's
    end), the forcing's increments over it (tabulated on the grid's sub-step) and the modes'
    increments and derivatives at ``h`` (``wn``).  Returns ``(h, dsin, dcos, sp1, cp1, bstale)``."""
    (wn, wk, hb, _hab, _hsig, _hss, _P_r, _tab_r, _P_t, _tab_t, fs, ist, _sub_r, _sub_t, _sf, _si, _lp) = work
    n = eta.shape[0]
    ns = st.offset.shape[0]
    mp = sy.mp
    Nrm = st.normal
    phi = fs[_PHI]
    rem = fs[_REM]
    h_try = min(rem, 2.0 * fs[_HLAST])
    fresh = ist[_FRESH] != 0
    bstale = ist[_BSTALE] != 0
    at_grid = ist[_ATGRID] != 0
    aF = wn[_AF]
    bF = wn[_BF]
    zeroN = wn[_ZERO]
    xF = wn[_XF]
    yF = wn[_YF]
    dxv = wn[_DXV]
    dyv = wn[_DYV]
    x2v = wn[_X2V]
    x3v = wn[_X3V]
    SaF = wk[_SAF]
    SbF = wk[_SBF]
    CsF = wk[_CSF]
    g = wk[_G]
    v = wk[_V]
    G2 = wk[_G2]
    G3 = wk[_G3]
    M2F = wk[_M2F]
    M3F = wk[_M3F]
    M4F = wk[_M4F]
    if fresh:
        # a new free arc: homogeneous parts, their bounds (valid along the whole
        # arc: the homogeneous envelope only decays), curvature of each gap
        homogeneous(phi, Om, eta, etad, aF, bF, zeroN, xF, yF, n)
        _free_bounds(xF, yF, mp, hb, Nrm, CsF, Om, M2F, M3F, M4F, n, ns)
        for k in range(ns):
            _f, _f1, G2[k], G3[k], _f4 = signal(0.0, phi, Om, xF, yF, mp, Nrm[k], zeroN,
                                                SaF[k], SbF[k], g[k], v[k], n)
        fresh = False
        bstale = False
    h = h_try
    tabd = at_grid and h == rem
    if tabd:
        sp0 = tab[kg, 0]
        cp0 = tab[kg, 1]
        sp1 = tab[kg + 1, 0]
        cp1 = tab[kg + 1, 1]
        dsin = sp1 - sp0
        dcos = cp1 - cp0
    else:
        half = 0.5 * Om * h
        sh = math.sin(half)
        ph = phi + half
        dsin = 2.0 * sh * math.cos(ph)
        dcos = -2.0 * sh * math.sin(ph)
        sp1 = math.sin(phi + Om * h)
        cp1 = math.cos(phi + Om * h)
    # the modes' increments and derivatives at h
    for j in range(n):
        a11, a12, a21, a22 = increment_of(tabd, Ptab, j, h, mp)
        ddx = a11 * xF[j] + a12 * yF[j]
        ddy = a21 * xF[j] + a22 * yF[j]
        xe = xF[j] + ddx
        ye = yF[j] + ddy
        dxv[j] = ddx
        dyv[j] = ddy
        xx2 = -2.0 * mp[j, 0] * ye - mp[j, 1] * xe
        x2v[j] = xx2
        x3v[j] = -2.0 * mp[j, 0] * xx2 - mp[j, 1] * ye
    return h, dsin, dcos, sp1, cp1, bstale


@_inline
def _scan_inside(sy, cw, wn, wk, hb, inside, relaxed, phi, Om, T, h_ok):
    """The events of the compliant stops the body is inside of over a free step of ``h_ok``: each
    stop's force's sign up through zero (a contact, ``ev_in`` 1) or its gap down through zero
    (below it again, ``ev_in`` 2), scanned with certified bounds.  Returns ``(s_ev, k_ev, ev_in,
    h_ok)``: the first event's time and stop (-1: none) and the certified step."""
    n = sy.mp.shape[0]
    mp = sy.mp
    ns = cw.st.offset.shape[0]
    Nrm = cw.st.normal
    zeroN = wn[_ZERO]
    xF = wn[_XF]
    yF = wn[_YF]
    SaF = wk[_SAF]
    SbF = wk[_SBF]
    g = wk[_G]
    v = wk[_V]
    M2F = wk[_M2F]
    M3F = wk[_M3F]
    M4F = wk[_M4F]
    off = wk[_OFF]
    s_ev = -1.0
    k_ev = -1
    ev_in = 0
    st = cw.st
    vr = cw.vr
    wpa = cw.wpa
    wra = cw.wra
    for k in range(ns):
        if (inside >> k) & 1 == 0:
            continue
        r0, r1, roff = inside_sign(st.law[k], st.kc[k], st.cc[k], vr[k],
                                   (relaxed >> k) & 1 == 1)
        for j in range(n):
            wpa[j] = r0 * Nrm[k, j]
            wra[j] = r1 * Nrm[k, j]
        Sa = r0 * SaF[k] - r1 * Om * SbF[k]
        Sb = r0 * SbF[k] + r1 * Om * SaF[k]
        f0, fp0 = signal_start(phi, Om, xF, yF, mp, wpa, wra, Sa, Sb,
                               roff - r0 * off[k], n)
        M2, M3, M4 = bounds(hb, wpa, wra, math.sqrt(Sa * Sa + Sb * Sb), Om, n)
        hk = h_ok if s_ev < 0.0 else s_ev
        sk, hk2 = scan(hk, 1e-13 * T, phi, Om, xF, yF, mp, wpa, wra, Sa, Sb, f0, fp0, M2, M3,
                       M4, n)
        if sk >= 0.0:
            s_ev = sk
            k_ev = k
            ev_in = 1
        elif hk2 < hk:
            s_ev = -1.0
            k_ev = -1
            ev_in = 0
            h_ok = hk2
        for j in range(n):
            wpa[j] = -Nrm[k, j]
        hk = h_ok if s_ev < 0.0 else s_ev
        sk, hk2 = scan(hk, 1e-13 * T, phi, Om, xF, yF, mp, wpa, zeroN, -SaF[k], -SbF[k],
                       -g[k], -v[k], M2F[k], M3F[k], M4F[k], n)
        if sk >= 0.0:
            s_ev = sk
            k_ev = k
            ev_in = 2
        elif hk2 < hk:
            s_ev = -1.0
            k_ev = -1
            ev_in = 0
            h_ok = hk2
    return s_ev, k_ev, ev_in, h_ok


@_inline
def _scan_stops(sy, st, wn, wk, hb, inside, Om, T, step, ev, bstale):
    """The events of the stops not inside over a free step: each gap's first upward zero crossing,
    scanned with certified bounds (:mod:`vibeam.models.core.signals`; from the step's ends when the
    step is the tabulated one, far stops skipped by the interpolation bound).  ``step``: ``(phi,
    h, dsin, dcos, sp1, cp1)``; ``ev``: ``(s_ev, k_ev, ev_in, h_ok)`` so far.  Returns them updated
    and ``bstale``."""
    phi, h, dsin, dcos, sp1, cp1 = step
    s_ev, k_ev, ev_in, h_ok = ev
    n = sy.mp.shape[0]
    ns = st.offset.shape[0]
    mp = sy.mp
    Nrm = st.normal
    W2 = Om * Om
    zeroN = wn[_ZERO]
    xF = wn[_XF]
    yF = wn[_YF]
    dxv = wn[_DXV]
    dyv = wn[_DYV]
    x2v = wn[_X2V]
    x3v = wn[_X3V]
    SaF = wk[_SAF]
    SbF = wk[_SBF]
    CsF = wk[_CSF]
    g = wk[_G]
    v = wk[_V]
    g1 = wk[_G1]
    v1 = wk[_V1]
    G2 = wk[_G2]
    G3 = wk[_G3]
    G21 = wk[_G21]
    G31 = wk[_G31]
    M2F = wk[_M2F]
    M3F = wk[_M3F]
    M4F = wk[_M4F]
    for k in range(ns):
        if (inside >> k) & 1:
            continue
        hk = h_ok if s_ev < 0.0 else s_ev
        if hk == h:
            f = g[k] + SaF[k] * dsin + SbF[k] * dcos
            f1 = v[k] + Om * (SaF[k] * dcos - SbF[k] * dsin)
            f2 = 0.0
            f3 = 0.0
            for j in range(n):
                f += Nrm[k, j] * dxv[j]
                f1 += Nrm[k, j] * dyv[j]
                f2 += Nrm[k, j] * x2v[j]
                f3 += Nrm[k, j] * x3v[j]
            g1[k] = f
            v1[k] = f1
            G21[k] = f2 - W2 * (SaF[k] * sp1 + SbF[k] * cp1)
            G31[k] = f3 - W2 * Om * (SaF[k] * cp1 - SbF[k] * sp1)
            far = _far(g[k], g1[k], M2F[k], hk)
            if not far and bstale:
                # the bounds of the arc's start (valid: the homogeneous
                # envelope only decays) are loose once fast modes have
                # decayed: near a stop, take them from the current state
                _free_bounds(xF, yF, mp, hb, Nrm, CsF, Om, M2F, M3F, M4F, n, ns)
                bstale = False
                far = _far(g[k], g1[k], M2F[k], hk)
            if far:
                sk = -1.0        # far from the stop (interpolation bound)
                hk2 = hk
            else:
                sk, hk2 = scan_from(hk, 1e-13 * T, phi, Om, xF, yF, mp, Nrm[k], zeroN,
                                    SaF[k], SbF[k], g[k], v[k], (g[k], v[k], G2[k], G3[k]), (g1[k], v1[k],
                                    G21[k], G31[k]), M2F[k], M3F[k], M4F[k], n)
        else:
            sk, hk2 = scan(hk, 1e-13 * T, phi, Om, xF, yF, mp, Nrm[k], zeroN, SaF[k],
                           SbF[k], g[k], v[k], M2F[k], M3F[k], M4F[k], n)
        if sk >= 0.0:
            s_ev = sk
            k_ev = k
            ev_in = 0
        elif hk2 < hk:
            s_ev = -1.0
            k_ev = -1
            ev_in = 0
            h_ok = hk2
    return s_ev, k_ev, ev_in, h_ok, bstale


@_inline
def _flow_at(sy, st, wn, wk, Ptab, phi, Om, s_mv):
    """The flow at ``s_mv``, a free step ended before the tabulated one (an event, a certified
    shorter step): the forcing's and the modes' increments (``wn``) and the gaps' ends (``wk``).
    Returns ``(dsin, dcos, sp1, cp1)``."""
    n = sy.mp.shape[0]
    ns = st.offset.shape[0]
    mp = sy.mp
    Nrm = st.normal
    xF = wn[_XF]
    yF = wn[_YF]
    dxv = wn[_DXV]
    dyv = wn[_DYV]
    x2v = wn[_X2V]
    x3v = wn[_X3V]
    SaF = wk[_SAF]
    SbF = wk[_SBF]
    g = wk[_G]
    v = wk[_V]
    g1 = wk[_G1]
    v1 = wk[_V1]
    G21 = wk[_G21]
    G31 = wk[_G31]
    tabd = False
    half = 0.5 * Om * s_mv
    sh = math.sin(half)
    ph = phi + half
    dsin = 2.0 * sh * math.cos(ph)
    dcos = -2.0 * sh * math.sin(ph)
    sp1 = math.sin(phi + Om * s_mv)
    cp1 = math.cos(phi + Om * s_mv)
    mode_ends(s_mv, xF, yF, mp, Ptab, False, dxv, dyv, x2v, x3v, n)
    for k in range(ns):
        _gap_ends(Nrm, k, SaF[k], SbF[k], g[k], v[k], Om, dxv, dyv, x2v, x3v,
                  dsin, dcos, sp1, cp1, n, g1, v1, G21, G31)
    return dsin, dcos, sp1, cp1


@_inline
def _free_outputs(sy, st, work, rec, eta, etad, samp, Om, T, recording, step, flags):
    """A free step's outputs before the state moves: the record's samples inside it (dense output),
    the apexes of the gaps (no event) and the sensor's extremes (root-found where its slope turns).
    ``samp``: ``(k_sample, j_next, j_end, base, h_rs)``, the samples taken and the dense record's
    next sample (:func:`_held_phase`); ``step``: ``(phi, t_loc, s_mv, dsin, dcos)``; ``flags``:
    ``(s_ev, at_grid, inside)``.  Returns ``(k_sample, j_next)`` advanced past the samples taken."""
    (wn, wk, _hb, _hab, _hsig, _hss, P_r, tab_r, _P_t, _tab_t, fs, _ist, _sub_r, _sub_t, _sf, _si, _lp) = work
    phi, t_loc, s_mv, dsin, dcos = step
    s_ev, at_grid, inside = flags
    n = eta.shape[0]
    ns = st.offset.shape[0]
    mp = sy.mp
    Nrm = st.normal
    aplog = rec.aplog
    nlog = rec.nlog
    apexes = aplog.shape[0] > 0
    samples = rec.samples
    msamp = rec.msamp
    modamp = rec.modamp
    pT = fs[_PT]
    SaSF = fs[_SASF]
    SbSF = fs[_SBSF]
    pext = fs[_PEXT:_PEXT1 + 1]
    sens = wn[_SENS]
    k_sample, j_next, j_end, base, h_rs = samp
    zeroN = wn[_ZERO]
    xF = wn[_XF]
    yF = wn[_YF]
    dxv = wn[_DXV]
    dyv = wn[_DYV]
    x2v = wn[_X2V]
    SaF = wk[_SAF]
    SbF = wk[_SBF]
    g = wk[_G]
    v = wk[_V]
    v1 = wk[_V1]
    G2 = wk[_G2]
    G21 = wk[_G21]
    if j_next < j_end:
        # the record's samples inside the step: the flow evaluated there
        taken = _dense_samples(samples, msamp, modamp, fs, wn, mp, P_r, tab_r, (k_sample, j_next, j_end, base),
                               (t_loc, s_mv, h_rs, at_grid), Om, n)
        k_sample += taken
        j_next += taken
    if apexes and s_ev < 0.0:
        for k in range(ns):
            if v[k] > 0.0 and v1[k] <= 0.0 and (inside >> k) & 1 == 0:
                _log_apex(aplog, nlog, pT + t_loc, s_mv, phi, Om, xF, yF, mp, Nrm[k],
                          zeroN, SaF[k], SbF[k], g[k], v[k], n, k, G2[k], v1[k], G21[k])
    if recording:
        # the sensor's extremes inside the step (root-found where its slope turns)
        q0s = _dot(sens, eta)
        qp0s = _dot(sens, etad)
        q1s = q0s + _dot(sens, dxv) + SaSF * dsin + SbSF * dcos
        qp1s = qp0s + _dot(sens, dyv) + Om * (SaSF * dcos - SbSF * dsin)
        if (qp0s < 0.0 < qp1s) or (qp0s > 0.0 > qp1s):
            _sensor_extreme(s_mv, phi, Om, xF, yF, mp, sens, zeroN, SaSF, SbSF, q0s, qp0s,
                            qp1s, x2v, pext, n)
    return k_sample, j_next


@_inline
def _free_advance(st, wn, wk, fs, eta, etad, inside, Om, recording, sp1, cp1):
    """The state at a free step's end, recomposed from its parts (put back on a stop it rounds
    past), and the sensor's value there for the period's extremes."""
    n = eta.shape[0]
    ns = st.offset.shape[0]
    Nrm = st.normal
    sens = wn[_SENS]
    pext = fs[_PEXT:_PEXT1 + 1]
    aF = wn[_AF]
    bF = wn[_BF]
    xF = wn[_XF]
    yF = wn[_YF]
    dxv = wn[_DXV]
    dyv = wn[_DYV]
    off = wk[_OFF]
    for i in range(n):
        xF[i] += dxv[i]
        yF[i] += dyv[i]
        eta[i] = aF[i] * sp1 + bF[i] * cp1 + xF[i]
        etad[i] = Om * (aF[i] * cp1 - bF[i] * sp1) + yF[i]
    for k in range(ns):
        # the state recomposed from its parts may round past a stop that the
        # carried gap (value + increments) has not reached: put it back on it
        if (inside >> k) & 1:
            continue
        gs = _dot(Nrm[k], eta) - off[k]
        if gs > 0.0:
            gs *= wk[_MEFF, k]
            for i in range(n):
                eta[i] -= Nrm[k, i] * gs
    if recording:
        # the step's end as the next sample will read it
        q1s = _dot(sens, eta)
        if q1s < pext[0]:
            pext[0] = q1s
        if q1s > pext[1]:
            pext[1] = q1s


@_inline
def _carry_gaps(st, wk, eta, etad, inside, s_ev, k_ev, gmax):
    """The gaps, their rates and curvatures carried to a free step's end (the stop of an event on
    it; inside a compliant stop, from the state); ``gmax`` the largest gap at an event-free end (a
    certificate).  Returns ``gmax``."""
    ns = st.offset.shape[0]
    Nrm = st.normal
    g = wk[_G]
    v = wk[_V]
    g1 = wk[_G1]
    v1 = wk[_V1]
    G2 = wk[_G2]
    G3 = wk[_G3]
    G21 = wk[_G21]
    G31 = wk[_G31]
    off = wk[_OFF]
    for k in range(ns):
        if (inside >> k) & 1:
            g[k] = _dot(Nrm[k], eta) - off[k]
            v[k] = _dot(Nrm[k], etad)
            continue
        if s_ev >= 0.0 and k == k_ev:
            g[k] = 0.0
        else:
            if g1[k] > gmax:
                gmax = g1[k]
            g[k] = g1[k] if g1[k] < 0.0 else 0.0
        v[k] = v1[k]
        G2[k] = G21[k]
        G3[k] = G31[k]
    return gmax


@_inline
def _free_step(sy, st, cw, work, rec, eta, etad, grid, samp, Om, T, recording):
    """Phase *free flight* (held set empty, no compliant contact): one step of at most the rest of
    the grid's sub-step ``kg`` of ``grid = (tab, Ptab, kg)`` (the forcing's and the modes' tables of
    the grid; ``samp`` as :func:`_free_outputs`'s): the stops touched at its start
    (:func:`_free_touch`), else the arc and the step (:func:`_free_arc`), every stop's event scanned
    with certified bounds (:func:`_scan_inside`, :func:`_scan_stops`), the flow moved to the first
    event or the step's end (:func:`_flow_at`, :func:`_free_outputs`, :func:`_free_advance`,
    :func:`_carry_gaps`).  Returns ``(k_imp, k_sample, j_next)``: the stop of a contact at the
    step's end (or -1) and the record's counters advanced."""
    (wn, wk, hb, _hab, _hsig, _hss, _P_r, _tab_r, _P_t, _tab_t, fs, ist, _sub_r, _sub_t, _snap_f, _snap_i, _lp) = work
    tab, Ptab, kg = grid
    touched = _free_touch(st, cw, wn, wk, fs, ist, rec, eta, etad, Om)
    if touched != -1:
        return (touched if touched >= 0 else -1), samp[0], samp[1]
    phi = fs[_PHI]
    t_loc = fs[_TLOC]
    rem = fs[_REM]
    h_last = fs[_HLAST]
    inside = ist[_INSIDE]
    relaxed = ist[_RELAXED]
    at_grid = ist[_ATGRID] != 0
    h, dsin, dcos, sp1, cp1, bstale = _free_arc(sy, st, work, eta, etad, tab, Ptab, kg, Om)
    s_ev = -1.0
    k_ev = -1
    ev_in = 0
    h_ok = h
    if cw is not None and inside != 0:
        s_ev, k_ev, ev_in, h_ok = _scan_inside(sy, cw, wn, wk, hb, inside, relaxed, phi, Om, T, h_ok)
    s_ev, k_ev, ev_in, h_ok, bstale = _scan_stops(sy, st, wn, wk, hb, inside, Om, T, (phi, h, dsin, dcos, sp1, cp1),
                                                  (s_ev, k_ev, ev_in, h_ok), bstale)
    s_mv = s_ev if s_ev >= 0.0 else h_ok
    if s_ev < 0.0:
        # shrink to a halved step; a step cut by the sub-grid says nothing
        h_last = h_ok if h_ok < h else max(h_last, h)
    if s_mv != h:
        dsin, dcos, sp1, cp1 = _flow_at(sy, st, wn, wk, Ptab, phi, Om, s_mv)
    k_sample, j_next = _free_outputs(sy, st, work, rec, eta, etad, samp, Om, T, recording,
                                     (phi, t_loc, s_mv, dsin, dcos), (s_ev, at_grid, inside))
    _free_advance(st, wn, wk, fs, eta, etad, inside, Om, recording, sp1, cp1)
    if s_mv != rem:
        at_grid = False
    phi, t_loc, rem = _clock(phi, t_loc, rem, s_mv, Om, T)
    if s_mv > 0.0:
        ist[_JSTUCK] = 0
        ist[_JREL] = 0
        ist[_EXITED] = 0
    gmax = _carry_gaps(st, wk, eta, etad, inside, s_ev, k_ev, fs[_GMAX])
    k_imp = -1
    fresh = False
    if s_ev >= 0.0:
        if ev_in == 2:
            inside &= ~(1 << k_ev)
            relaxed &= ~(1 << k_ev)
            wk[_G, k_ev] = 0.0
            fresh = True
        else:
            k_imp = k_ev
    fs[_PHI] = phi
    fs[_TLOC] = t_loc
    fs[_REM] = rem
    fs[_HLAST] = h_last
    fs[_GMAX] = gmax
    ist[_INSIDE] = inside
    ist[_RELAXED] = relaxed
    ist[_FRESH] = fresh
    ist[_BSTALE] = True
    ist[_ATGRID] = at_grid
    return k_imp, k_sample, j_next



@_inline
def as_tuple(r):
    """A :class:`RunScalars` as the plain tuple of its fields in order, what :func:`integrate_work`
    returns: numba boxes a NamedTuple by calling its Python class, and a signal handler that runs
    there (Ctrl-C during a run) raises inside the boxing, which numba does not check (the process
    died of a segmentation fault instead of stopping with the interrupt); a plain tuple is boxed
    without running Python code."""
    return (r.status, r.n_imp_record, r.s_min, r.s_max, r.n_chatter, r.stuck_time, r.held_end, r.n_imp_total,
            r.gmax, r.n_steps, r.contact_time, r.periods_skipped)


@_inline
def scalars(t):
    """The :class:`RunScalars` of :func:`integrate_work`'s tuple ``t`` (its fields by name, for the
    shots).  Inlined at numba's IR: the shots call the one compiled event loop."""
    return RunScalars(t[0], t[1], t[2], t[3], t[4], t[5], t[6], t[7], t[8], t[9], t[10], t[11])


@njit(cache=True, _nrt=False, error_model="numpy", no_cfunc_wrapper=True)
def integrate_work(sy, st, hs, cw, Om, eta, etad, held0, n_transient, n_record, ns_transient, ns_record, h_cap,
                   max_impacts, max_steps, chatter_tol, rec, work):
    """Integrate ``n_transient + n_record`` forcing periods from phase 0 (numba core), in the
    caller's work arrays: no allocation and no reference counting.

    The event loop in named phases (Siconos' event-driven simulation names its phases alike):
    the per-frequency data (:func:`_frequency`), the compliant stops' start (``cw`` not None),
    the initial state (:func:`_initial_state`), then the periods (:func:`_recurrence`,
    :func:`_period_start`), their grid and sub-steps, a step at a time in the phase the state is
    in -- compliant contact (:func:`_contact_phase`), held (:func:`_held_phase`) or free flight
    (:func:`_free_step`) -- and the contact that ends a step (:func:`_contact_event`).  Called from
    Python by the sweep (:class:`vibeam.models.core.event.EventIntegrator`) and from compiled
    callers that run many calls (the shots of a corrector).

    Parameters
    ----------
    sy : KernelSystem
    st : KernelStops
    hs : HeldSets
        :mod:`vibeam.models.core.stops`.
    cw : _CompliantWork or None
        The compliant stops' work arrays (:func:`compliant_work`, from the compliant stops' data
        :class:`vibeam.models.core.phases.Compliant`); None for a scene with Newton stops only,
        whose compiled specialisation then holds no compliant code (numba prunes the branches on
        ``cw is None``).
    Om : float
        Forcing frequency (per unit nondimensional time).
    eta, etad : ndarray, shape (n,)
        Initial modal state, overwritten with the final one.
    held0 : int
        Bit mask of the stops the system is held on (Newton stops) or in contact with (compliant
        stops) at the start (0 free).
    n_transient, n_record : int
        Forcing periods discarded, then recorded.
    ns_transient, ns_record : int
        Grid points per period (the recorded samples).
    h_cap : float
        Largest step.
    max_impacts, max_steps : int
        Guards: beyond them the call returns :data:`ST_FAILED`.
    chatter_tol : float
        Accuracy of the chatter accumulation estimate (:mod:`vibeam.models.core.contact_policy`).
    rec : Record
        Outputs.
    work : tuple
        The work arrays of :func:`new_work` (a caller that reuses them at another ``Om`` runs one
        grid, ``ns_transient == ns_record``, and checks :func:`work_fits`; the sub-steps are those
        of ``Om``).  With a snapshot (``recur``), the exact recurrence is on.

    Returns
    -------
    tuple
        The call's :class:`RunScalars` (status, impacts, sensor extremes, ...) named at every
        return and handed over as the plain tuple of its fields (:func:`as_tuple`; a NamedTuple
        boxed for Python ran Python code where a Ctrl-C could crash the process); the shots name
        them again (:func:`scalars`, inlined), the sweep in Python (``RunScalars(*out)``).  One
        compiled loop serves both: a Python entry compiled as a wrapper around a compiled loop
        re-optimised the loop's LLVM module inside the wrapper (a cold quick start's compiling
        +9 %, 2026-11-27).
    """
    (wn, wk, _hb, _hab, _hsig, _hss, P_r, tab_r, P_t, tab_t, fs, ist, _sub_r, _sub_t, snap_f, _snap_i, lp) = work
    sub_r, sub_t = substeps(Om, ns_transient, ns_record, h_cap)
    status = _frequency(sy, st, hs, Om, eta, etad, rec, work, sub_r, sub_t, ns_transient, ns_record, h_cap)
    if status != 0:
        return as_tuple(RunScalars(_ST_FAILED, _I0, np.inf, -np.inf, _I0, 0.0, np.int64(held0), np.int64(status),
                                   -np.inf, _I0, 0.0, _I0))
    if cw is not None:
        _start_compliant(cw, sy, st, hs, Om, eta, etad, held0, ist, rec)
    _initial_state(st, hs, eta, etad, held0, wn, wk, ist, rec)
    n = eta.shape[0]
    T = TWO_PI / Om
    n_total = n_transient + n_record
    logging = rec.evlog.shape[0] > 0
    # the loop's counters (_L*): the exact recurrence's snapshot periods (-1: none yet, -2: off;
    # the second, cadence RECUR_FAST), samples taken, periods skipped
    lp[_LSNAP] = -2 if (cw is not None or logging or rec.aplog.shape[0] > 0 or snap_f.shape[0] == 0) else -1
    lp[_LSNAPB] = -1
    lp[_LKS] = 0
    lp[_LSKIP] = 0
    lp[_LNSREC] = ns_record
    lp[_LCYA] = -1
    lp[_LCYB] = -1
    # the record's cycle log: on with the recurrence (-1: off)
    ist[_NCYC] = -1 if lp[_LSNAP] == -2 else 0
    # a step's counters are local variables, handed to the phases and returned (see ``lp``)
    # the record on the transient's grid, its samples inside a free step by dense output (module
    # docstring): r_d samples per grid step of the transient, h_rs apart
    r_d = ns_record // ns_transient
    dense = cw is None and n == 1 and sub_t == 1 and sub_r == 1 and r_d > 1 and r_d * ns_transient == ns_record
    h_rs = T / ns_record
    eps_t = 1e-15 * T
    failed = False
    lp[_LPP] = 0
    guards = (max_impacts, chatter_tol)
    while lp[_LPP] < n_total:
        if lp[_LSNAP] != -2 and _recurrence(eta, etad, work, rec, lp, n_transient, n_total, T, max_steps,
                                            max_impacts):
            continue
        pp = lp[_LPP]
        recording = pp >= n_transient
        fine = recording and not dense      # on the record's own grid
        ns_grid = ns_record if fine else ns_transient
        h_grid = T / ns_grid
        sub = sub_r if fine else sub_t
        h_sub = h_grid / sub
        Ptab = P_r if fine else P_t         # the grid's tables
        tab = tab_r if fine else tab_t
        j_end = r_d if recording and dense else 0
        k_sample = lp[_LKS]
        _period_start(fs, ist, rec.pmin, pp, n_transient, T)
        for jg in range(ns_grid):
            if recording:
                _state_sample(rec.samples, rec.msamp, rec.modamp, fs, k_sample, wn[_SENS], eta, etad, n)
                k_sample += 1
            j_next = 1      # the next sample inside the grid step (dense record: < j_end)
            base = jg * r_d
            for isub in range(sub):
                kg = jg * sub + isub
                fs[_PHI] = TWO_PI * kg / (ns_grid * sub)
                fs[_TLOC] = jg * h_grid + isub * h_sub
                fs[_REM] = h_sub
                ist[_ATGRID] = 1          # still on the tabulated sub-step (no event yet)
                while fs[_REM] > 0.0:
                    while j_next < j_end and (base + j_next) * h_rs <= fs[_TLOC] + eps_t:
                        # a sample reached by a step's end (a held step cut there, an event on it)
                        _state_sample(rec.samples, rec.msamp, rec.modamp, fs, k_sample, wn[_SENS], eta, etad, n)
                        k_sample += 1
                        j_next += 1
                    ist[_NSTEPS] += 1
                    if ist[_NSTEPS] > max_steps:
                        failed = True
                        break
                    if cw is not None and ist[_C] != 0:
                        # in contact with the compliant stops C (held on H); -2: failed
                        k_imp = _contact_phase(sy, st, hs, cw, wk, eta, etad, fs, ist, rec.evlog, rec.nlog, Om, T,
                                               recording)
                    elif ist[_H] != 0:
                        k_imp = _held_phase(hs, st, cw, work, rec, eta, etad, (j_next, j_end, base, h_rs), Om, T,
                                            recording)
                    else:
                        k_imp, k_sample, j_next = _free_step(sy, st, cw, work, rec, eta, etad, (tab, Ptab, kg),
                                                             (k_sample, j_next, j_end, base, h_rs), Om, T, recording)
                    # a contact at the current time on stop k_imp
                    failed = k_imp == -2 or (k_imp >= 0 and _contact_event(
                        sy, st, hs, cw, work, rec, eta, etad, (j_next, j_end, base, h_rs), recording, k_imp, Om,
                        guards))
                    if failed:
                        break
                if failed:
                    break
            if failed:
                break
        if failed:
            break
        lp[_LKS] = k_sample
        lp[_LPP] += 1
    if failed:
        return as_tuple(_failed(fs, ist, lp[_LSKIP]))
    if n_record > 0:
        rec.pmin[n_record - 1] = fs[_PEXT]
        fs[_EXT] = min(fs[_EXT], fs[_PEXT])
        fs[_EXT1] = max(fs[_EXT1], fs[_PEXT1])
    status = _ST_OK
    if n_record > 0:
        if ist[_NCHAT] > 0:
            status = _ST_CHATTER
        elif fs[_STUCK] > 0.0:
            status = _ST_STICKING
    return as_tuple(RunScalars(status, ist[_NIMPR], fs[_EXT], fs[_EXT1], ist[_NCHAT], fs[_STUCK], ist[_H] | ist[_C],
                               ist[_NIMPT], fs[_GMAX], ist[_NSTEPS], fs[_TCON], lp[_LSKIP]))




@_kernel
def work_fits(work, Om, ns, h_cap):
    """Whether the work arrays of :func:`new_work` for one grid of ``ns`` points (``work``,
    transient and record alike) serve a call at ``Om``: a table long enough for its sub-steps."""
    sub_r, _sub_t = substeps(Om, ns, ns, h_cap)
    return ns * sub_r + 1 <= work[7].shape[0]
