"""Method ``mapping`` of the one-mode system: period-n orbits of the pointwise map (paper Sec. 4.2).

One solver for every law and stops where the map is defined (:mod:`vibeam.models.mapping.orbit`):
guesses (the previous point's orbit, the sections of the last ``n`` periods of a short event run,
averaging), Newton on the multiple-shooting residual, admissibility, the multipliers and the
point's outputs.  The paper's formulas (Eqs. 29-37) are reported where they apply: one Newton stop
hit once per ``n`` periods (:mod:`vibeam.models.mapping.paper`).
"""
from __future__ import annotations

import math

import numpy as np

from ..core.event import EventSolver
from ..scene import one_mode
from ..paper.averaging import averaging_guess
from ..core.oscillator import undamped_resonance
from .orbit import DEFAULT_TOL, SectionMap, check_stops, law_key, minimal_period
from .paper import paper_verdicts
from .phases import TWO_PI

#: transient periods of the event run that gives the first guess, by the laws of the stops
GUESS_PERIODS = {"impulsive": 200, "kelvin_voigt": 300, "hysteretic_hertz": 300}
#: the paper's stability outputs (one Newton stop hit once per n periods; NaN / False elsewhere)
PAPER_KEYS = ("det_full", "tr_full", "stable_full", "disagree_full", "det_simplified", "tr_simplified",
              "stable_simplified", "disagree_simplified")
#: per-stop contact outputs (as the event runs', ``vibeam.engine.records``)
CONTACT_KEYS = ("contact_duration", "contact_force_max", "penetration_max", "energy_per_impact")


def event_sections(scene, Omega, n, n_transient):
    """The sections of the last ``n`` periods of an event run from rest (``n_transient`` periods
    first, then ``2 n`` recorded: the event method, :class:`vibeam.models.core.event.EventSolver`,
    with its default settings): ndarray (m, 3) of ``(phase, normal speed, stop)`` and whether
    the run has settled on them (the ``n`` periods before had the same sections, phases and
    speeds to 1e-6); None without a section (or a failed run)."""
    tr = EventSolver(scene).point(float(Omega), None, int(n_transient), 2 * n, 8)
    k = min(tr.n_impacts, tr.impact_times.shape[0])
    if k == 0 or tr.status == "failed" or k != tr.n_impacts:
        return None
    stops = tr.impact_stops if tr.impact_stops is not None else np.zeros(k)
    sec = np.column_stack([Omega * tr.impact_times, tr.impact_velocities, stops])
    late = sec[:, 0] >= (1.0 - 1e-12) * TWO_PI * n
    last, before = sec[late], sec[~late]
    if not last.shape[0]:
        return None
    settled = (before.shape == last.shape and np.array_equal(before[:, 2], last[:, 2])
               and np.allclose(before[:, 0] + TWO_PI * n, last[:, 0], rtol=0, atol=1e-6 * TWO_PI)
               and np.allclose(before[:, 1], last[:, 1], rtol=1e-6, atol=0))
    return last, settled


def event_guess(scene, Omega, n=1, n_transient=200):
    """``(phase, velocity)`` of the last section of a short event run (a guess), or None."""
    s = event_sections(scene, Omega, n, n_transient)
    return None if s is None else np.array([s[0][-1, 0] % TWO_PI, s[0][-1, 1]])


def unresolved(om, Omega: float, Q: float, v: float, tol: float) -> str:
    """Why an orbit of amplitude ``Q`` and speed ``v`` is not resolved by the forcing, or ''.

    Newton's residual is accepted at ``tol`` times the arrival speed, so the forcing's effect on one
    flight must stand above it: the forced velocity amplitude ``Omega C`` (``C = Omega^2 B /
    sqrt((1 - Omega^2)^2 + (2 beta Omega)^2)``, paper Eq. 28) must exceed 1e3 ``tol`` times the
    orbit's scale (``Q`` or ``v / Omega``).  An orbit beyond that -- more than ``1e-3 / tol`` times
    ``C``, or not finite -- is Newton losing the forcing in round-off: e.g. the undamped, elastic
    scene (``beta = 0``, ``R = 1``) at its impacting resonance ``Omega = 2k``, where no bounded
    orbit exists and Newton drifts to ``v ~ 1e13 ... 1e22``.  ``om``: the scene's
    :func:`vibeam.models.scene.one_mode`.
    """
    from ..core.oscillator import linear_amplitude

    C = float(linear_amplitude(om.beta, om.B, Omega))
    size = np.nanmax([abs(Q), abs(v) / Omega])
    limit = 1e-3 / tol
    if np.isfinite(size) and size <= limit * max(C, 1e-300):
        return ""
    return (f"the orbit found (amplitude {Q:.3g}, impact velocity {v:.3g}) is {size / max(C, 1e-300):.2g} times the "
            f"forced amplitude C = {C:.3g}, beyond {limit:.0e} = 1e-3 / tol: the forcing is below Newton's tolerance, "
            f"so no bounded orbit is resolved (beta = {om.beta:g}, R = {om.stops[0].law.R:g}: an undamped "
            f"resonance?)")


def contact_means(records, on, suffix):
    """Contact outputs of one stop from the records of its sections (``on``: which are its)."""
    c = np.array([r for r, o in zip(records, on) if o], float).reshape(-1, 4)
    if not c.shape[0]:
        return {k + suffix: math.nan for k in CONTACT_KEYS}
    force = float(np.max(c[:, 1])) if np.all(np.isfinite(c[:, 1])) else math.nan
    return dict(zip((k + suffix for k in CONTACT_KEYS),
                    (float(np.mean(c[:, 0])), force, float(np.max(c[:, 2])), float(np.mean(c[:, 3])))))


def failed_outputs(reasons, n_multipliers, state_size, lower, det_trace=False) -> dict:
    """The outputs of a failed mapping point, every number NaN (one helper for the SDOF's
    :class:`MappingSolver` and the N-mode map's
    :class:`~vibeam.models.mapping.modal.ModalMappingSolver`).

    Parameters
    ----------
    reasons : list of str
        Why each guess failed, joined by ``"; "`` into ``message`` (none: no initial guess).
    n_multipliers : int
        Size of ``multipliers`` (complex NaN): the state's dimension.
    state_size : int
        Size of ``final_state`` (NaN).
    lower : bool
        Add the lower stop's ``impacts_per_period_lower``, ``impact_velocity_lower`` and the
        ``_lower`` contact outputs (two stops).
    det_trace : bool, optional
        Add ``det_true`` and ``tr_true`` after ``multipliers`` (the N-mode map's order of the
        outputs; the SDOF adds them with the paper's outputs of Newton stops).

    Returns
    -------
    dict
        ``amplitude`` ... ``message`` in the order of the solvers' outputs, ``period`` 0,
        ``stable`` False and ``status`` ``"failed"``.
    """
    nan = math.nan
    out = dict(amplitude=nan, q_min=nan, q_max=nan, period=0, impacts_per_period=nan, impact_velocity=nan,
               impact_phase=nan, stable=False, multipliers=np.full(n_multipliers, nan, dtype=complex))
    if det_trace:
        out.update(det_true=nan, tr_true=nan)
    out.update({k: nan for k in CONTACT_KEYS}, final_state=np.full(state_size, nan), status="failed",
               message="; ".join(reasons) if reasons else "no initial guess (no impacts)")
    if lower:
        out.update(impacts_per_period_lower=nan, impact_velocity_lower=nan,
                   **{k + "_lower": nan for k in CONTACT_KEYS})
    return out


class MappingSolver:
    """Method ``mapping``: period-n orbits of the pointwise map of the one-mode system, any laws
    on one or two stops (paper Sec. 4.2; :mod:`vibeam.models.mapping.orbit`).

    Parameters
    ----------
    scene : vibeam.models.scene.Scene
        The one-mode oscillator and its stops (:func:`vibeam.models.scene.one_mode`; Newton's law
        with a constant ``R``, or compliant laws).
    n : int, optional
        Forcing periods of the orbit (1..4).
    form : {"full", "simplified"}, optional
        Which of the paper's Jacobian formulas is ``stable_paper`` (one Newton stop; both are
        reported as ``stable_full`` / ``stable_simplified``).
    guess : {"event", "averaging"}, optional
        The first source of Newton guesses when no continuation state is given (the other next).
    guess_periods : int, optional
        Transient periods of the event run that gives a guess (default by the laws:
        :data:`GUESS_PERIODS`).
    tol : float, optional
        Newton's tolerance on the residual relative to the arrival speeds (default by the laws:
        :data:`vibeam.models.mapping.orbit.DEFAULT_TOL`).

    Raises
    ------
    ValueError
        For ``n`` outside 1..4, an unknown ``form`` or ``guess``, a scene that is not the one-mode
        oscillator or stops the map cannot pass (:class:`vibeam.models.mapping.orbit.SectionMap`).
    """

    name = "mapping"
    time_domain = False

    def __init__(self, scene, n: int = 1, form: str = "full", guess: str = "event", guess_periods: int | None = None,
                 tol: float | None = None):
        if int(n) != n or not 1 <= n <= 4:
            raise ValueError(f"n must be an integer in 1..4, got {n!r}")
        if form not in ("full", "simplified"):
            raise ValueError(f"form must be 'full' or 'simplified', got {form!r}")
        if guess not in ("event", "averaging"):
            raise ValueError(f"guess must be 'event' or 'averaging', got {guess!r}")
        self.one = one_mode(scene, "the mapping")
        keys = {law_key(s.law) for s in self.one.stops}
        check_stops(self.one.stops)
        self.scene, self.n, self.form, self.guess = scene, int(n), form, guess
        self.guess_periods = int(max(GUESS_PERIODS[k] for k in keys) if guess_periods is None else guess_periods)
        self.tol = float(max(DEFAULT_TOL[k] for k in keys) if tol is None else tol)
        self.impulsive = keys == {"impulsive"}
        self.n_stops = len(self.one.stops)

    def settings(self) -> dict:
        return dict(n=self.n, form=self.form, guess=self.guess, guess_periods=self.guess_periods, tol=self.tol)

    def _guesses(self, Omega, state0):
        """Guesses ``(m, 3)`` of ``(phase, speed, stop)``: the continuation state (``(phase, v)`` of
        one section on stop 0 or a flat ``(3m,)`` sequence), then the sections of an event run's
        last ``n`` periods -- all of them first where the run has settled on them, else one
        section per ``n`` periods from the last one first when all are on one stop (the paper's
        Eqs. 33-34); a chatter sequence (more than 16 per period) is no guess but a reason -- and
        averaging (``n = 1``)."""
        s0 = state0.get("final_state") if isinstance(state0, dict) else state0
        if s0 is not None:
            s = np.asarray(s0, float).ravel()
            if s.shape == (2,) and np.all(np.isfinite(s)) and s[1] > 0:
                yield np.array([[s[0], s[1], 0.0]])
            elif s.size and s.size % 3 == 0 and np.all(np.isfinite(s)):
                yield s.reshape(-1, 3)
        for source in (("event", "averaging") if self.guess == "event" else ("averaging", "event")):
            if source == "averaging":
                x = averaging_guess(self.one, Omega) if self.n == 1 else None
                if x is not None:
                    yield np.array([[x[0], x[1], 0.0]])
                continue
            ev = event_sections(self.scene, Omega, self.n, self.guess_periods)
            if ev is None:
                continue
            seq, settled = ev
            one = [seq[-1:]] if np.all(seq[:, 2] == seq[0, 2]) else []
            if seq.shape[0] > 16 * self.n:
                yield from one
                yield (f"the event run has {seq.shape[0]} arrivals in {self.n} period(s) (chatter?): not a guess "
                       f"of the map")
            elif seq.shape[0] > 1:
                yield from ([seq] + one if settled else one + [seq])
            else:
                yield seq

    def point(self, Omega: float, state0, n_transient: int, n_record: int, samples_per_period: int = 64) -> dict:
        """The period-n orbit at one frequency, its stability and its contact records.

        Parameters
        ----------
        Omega : float
            Forcing frequency (nondimensional).
        state0 : None, ndarray or dict with ``final_state``
            The previous point's ``final_state`` (continuation); anything else is ignored.
        n_transient, n_record, samples_per_period :
            Ignored (interface compatibility).

        Returns
        -------
        dict
            ``amplitude`` (``Delta - q_min``), ``q_min``, ``q_max``, ``period`` (``n``; 0 when
            failed), ``impacts_per_period`` and ``impact_velocity`` (stop 0's sections, mean normal
            speed), ``impact_phase`` (forcing phase of the first section), ``stable``,
            ``multipliers`` (complex (2,), by decreasing modulus: of the monodromy where every law
            is Newton's, else of the composed section map), the contact outputs
            (``contact_duration`` ... ``energy_per_impact``, as the event runs'), ``final_state``
            (``(phase, v)`` (2,) of one section on stop 0, else ``(phase_j, v_j, stop_j)`` flat
            (3m,)), ``status`` (``"ok"`` / ``"failed"``) and ``message``.  Two stops add
            ``impacts_per_period_lower``, ``impact_velocity_lower`` and the ``_lower`` contact
            outputs; Newton stops only add ``map_eigenvalues``, ``det_true``, ``tr_true`` and the
            paper's ``det_full`` ... ``disagree_simplified`` and ``stable_paper`` (Eqs. 29-37; NaN
            / False unless one section on stop 0).  A failure is a status with the reasons, never
            an exception.
        """
        Omega = float(Omega)
        why = undamped_resonance(self.one.beta, Omega)
        if why:
            return self._failed([why])
        scene = SectionMap(self.scene, Omega, self.n)
        reasons = []
        for g in self._guesses(Omega, state0):
            out = g if isinstance(g, str) else self._solve(scene, g)
            if isinstance(out, dict):
                v = out["impact_velocity"] if np.isfinite(out["impact_velocity"]) else out.get("impact_velocity_lower")
                why = unresolved(self.one, Omega, out["amplitude"], v, self.tol)
                return self._failed([why]) if why else out
            reasons.append(out)
        return self._failed(reasons)

    def _solve(self, scene, seq):
        """The orbit from the guess ``seq`` (m, 3): its outputs, or the reason why none."""
        Om = scene.Omega
        stops = tuple(int(k) for k in seq[:, 2])
        if not all(0 <= k < self.n_stops for k in stops):
            return f"the guess names stops {stops} of a scene with {self.n_stops}"
        phi = seq[:, 0] - TWO_PI * math.floor(seq[0, 0] / TWO_PI)
        for j in range(1, phi.size):            # consecutive sections of one orbit: phases increase
            phi[j] += TWO_PI * max(0.0, math.floor((phi[j - 1] - phi[j]) / TWO_PI) + 1.0)
        m, n = len(stops), self.n
        x, ok = scene.newton(np.concatenate([phi / Om, seq[:, 1]]), stops, n, self.tol)
        if not ok:
            return (unresolved(self.one, Om, math.nan, np.max(np.abs(x[m:])), self.tol) or
                    f"Newton did not converge from {np.array2string(seq[:, :2].ravel(), precision=4)} (sections on "
                    f"stops {stops} in {n} periods)")
        p = minimal_period(np.concatenate([Om * x[:m], x[m:]]), stops, n)
        if p < n:
            return f"the orbit found has period {p}, not n = {n} (sections on stops {stops[:m * p // n]})"
        an = scene.analyse(x, stops, n)
        if isinstance(an, str):
            return an
        return self._outputs(scene, x, stops, an)

    def _outputs(self, scene, x, stops, an):
        Om, n, m = scene.Omega, self.n, len(stops)
        st = np.asarray(stops)
        v = x[m:]
        phis = Om * x[:m] - TWO_PI * math.floor(Om * x[0] / TWO_PI)
        J = an["J"]
        by_mod = lambda z: np.asarray(z, complex)[np.argsort(-np.abs(z))]   # noqa: E731
        mu = by_mod(np.linalg.eigvals(an["M"] if an["M"] is not None else J))
        stable = bool(np.max(np.abs(mu)) < 1.0)
        up = v[st == 0]
        out = dict(amplitude=float(self.one.Delta) - an["q_min"], q_min=an["q_min"], q_max=an["q_max"], period=n,
                   impacts_per_period=up.size / n, impact_velocity=float(np.mean(up)) if up.size else math.nan,
                   impact_phase=float(phis[0]), stable=stable, multipliers=mu,
                   **contact_means(an["records"], st == 0, ""),
                   final_state=(np.array([phis[0], v[0]]) if m == 1 and stops[0] == 0 else
                                np.column_stack([phis, v, st]).ravel()), status="ok", message="")
        if self.n_stops == 2:
            lo = v[st == 1]
            out.update(impacts_per_period_lower=lo.size / n,
                       impact_velocity_lower=float(np.mean(lo)) if lo.size else math.nan,
                       **contact_means(an["records"], st == 1, "_lower"))
        if self.impulsive:
            M = an["M"]
            out.update(map_eigenvalues=by_mod(np.linalg.eigvals(J)), det_true=float(np.linalg.det(M)),
                       tr_true=float(np.trace(M)))
            if m == 1 and stops[0] == 0:
                out.update(paper_verdicts(self.scene, Om, phis[0], v[0], n, stable))
            else:
                out.update({k: (False if k.startswith(("stable", "disagree")) else math.nan) for k in PAPER_KEYS})
            out["stable_paper"] = out["stable_" + self.form]
        return out

    def _failed(self, reasons) -> dict:
        nan = math.nan
        out = failed_outputs(reasons, 2, 2, self.n_stops == 2)
        if self.impulsive:
            out.update(map_eigenvalues=np.full(2, nan, dtype=complex), det_true=nan, tr_true=nan, stable_paper=False,
                       **{k: (False if k.startswith(("stable", "disagree")) else nan) for k in PAPER_KEYS})
        return out

    def evaluate(self, Omega, t0, v0, want_record=False, stop=0):
        """The map from the section ``(t0, v0)`` on ``stop`` to the next arrival (at any stop).

        Returns
        -------
        tuple or None
            ``(t1, v1, J, record)``: the arrival's time and normal speed, ``J = d(t1, v1) / d(t0,
            v0)`` (2, 2) and ``record`` (``stop`` of the arrival; ``duration``, ``force``,
            ``penetration``, ``energy`` of the passage); None without an arrival within ``n + 1``
            periods or with contact again before the body leaves the stop.  ``want_record`` is
            accepted for compatibility (the record is always given).
        """
        sc = SectionMap(self.scene, Omega, self.n)
        r = sc.section_map(stop, float(t0), float(v0), sc.t_max)
        if isinstance(r, str):
            return None
        rec = dict(zip(("duration", "force", "penetration", "energy"), r["passage"].record), stop=r["stop"])
        return r["t"], r["v"], r["J"], rec
