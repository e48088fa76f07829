"""Jobs of a case: a run at one value of the mapped parameter as a model, a solver (with the
scene's effects and assessment hooks) and a sweep; and the work a case asks for, estimated and
checked against the limit before anything runs.

Everything that runs a case builds its solvers here (the runner, the basins, the cost study, the
fit), so a run's model, method settings, effects and hooks are the same wherever it runs.
"""
from __future__ import annotations

import re
from dataclasses import dataclass

import numpy as np

from vibeam.engine import assess
from vibeam.engine.effects import wrap_solver
from vibeam.engine.sweep import Sweep
from vibeam.errors import CaseError, InputError, one_line, quote_value
from vibeam.models import make_solver
from vibeam.models.scene import one_mode, outputs


@dataclass
class Job:
    """One run of a case at one value of the mapped parameter (``j`` = None: no map)."""

    run: object
    spec: object
    solver: object
    sweep: object
    j: int | None = None


def make_job(case, r, overrides: dict, j=None) -> Job:
    """The job of run ``r`` of ``case`` with the model keys ``overrides`` (map value ``j``): its
    model spec, its solver with effects and hooks, and its sweep."""
    spec = case.model_spec(overrides) if overrides else case.model_spec()
    scene = spec.scene()
    # the grid from the builder's own frequency (the scene carries it exactly: 1 / (2 pi time_unit_s)
    # can be an ulp off it, and a chaotic point of a quick variant moves with an ulp of Omega)
    Omega = case.sweep.grid(outputs(scene).natural_frequency_hz)
    sw = Sweep(Omega=Omega, **dict(case.sweep.engine_options(),
                                   samples_per_period=assess.samples_per_period(case, r, scene, Omega),
                                   assess=assess.hooks(case, spec, r, scene)))
    settings = dict(case.run_settings(r), **assess.solver_options(case, r, spec))
    try:
        base = make_solver(scene, r.method, **settings)
    except ValueError as e:         # a value the method's solver cannot take: bad input, one line
        where = f" at {', '.join(f'{k} = {v!r}' for k, v in overrides.items())}" if overrides else ""
        raise CaseError(one_line(f"'run[{case.run.index(r)}].method' = {r.method!r}{where}: {e}")) from None
    solver = wrap_solver(base, scene, spec, assess.solver_effects(case.effects_for(r)), settings)
    return Job(r, spec, solver, sw, j)


def case_jobs(case, job=None) -> list[Job]:
    """The jobs of every sweep run of ``case`` (every value of its ``[map]``), built by ``job``
    (default :func:`make_job`); continuation runs are not jobs (they are units of work of their
    own, :class:`vibeam.analysis.branches.BranchTask`)."""
    job = make_job if job is None else job
    out = []
    for r in case.run:
        if r.method == "continuation":
            continue
        if case.map is None:
            out.append(job(case, r, dict(r.model)))
        else:
            for j, v in enumerate(case.map.grid()):
                out.append(job(case, r, dict(r.model, **{case.map.parameter: float(v)}), j))
    return out



def file_stem(name: str) -> str:
    """A run name as part of a file name (``map_<stem>.png``): characters other than letters,
    digits and ``_.+-`` become ``_``.  Case validation refuses two runs with the same stem."""
    return re.sub(r"[^A-Za-z0-9_.+-]+", "_", name)


# ----------------------------------------------------------------------------- work limit
MAX_WORK_STEPS = 1e11
"""Refuse a case whose estimated work exceeds this many event-kernel steps (``--force``
overrides).  One step of the SDOF event kernel costs about 0.1 us on one core of the
development machine (2.5 us per forcing period of 400 + 64 periods at 16 + 64 steps), so
the limit is a few hours on one core; the largest shipped case (``rig-map-gap``) needs
8e7 steps."""
MAX_POINT_VALUES = 1e8
"""Refuse a case whose one point would record more than this many floats (0.8 GB)."""
ODE_STEP_COST = 1000.0
"""Cost of a period of the ``solve_ivp`` methods over one of ``event`` (measured ~700x,
``vibeam bench``), applied per step of the event grid."""
_STEPS_PER_NATURAL_PERIOD = 16     # the event kernels' sub-steps: below 1/16 of a natural period


def _dofs(spec) -> int:
    """Degrees of freedom simulated by a model spec (1 for the SDOF and the static mode)."""
    return int(spec.dofs())


def _work_factor(scene) -> float:
    """The largest ``work_factor`` of the scene's stop laws (1 without stops): what one point
    costs against the event grid's step count (a Newton stop 1, Kelvin-Voigt about 12, the
    hysteretic-Hertz family about 300: their contact phases are integrated; measured on the
    cell matrix by ``vibeam bench --estimate``)."""
    return max([float(getattr(s.law, "work_factor", 1.0)) for s in scene.stops], default=1.0)


def _contact_steps(scene, Omega, spec=None):
    """Steps per forcing period that a compliant first stop of the one-mode oscillator adds
    (:func:`vibeam.models.scene.one_mode`), or None (Newton's law, a modal structure).

    The contact phase is stepped at 1/16 of its own natural period ``2 pi / sqrt(1 + k_c)``
    (about: the event integrator's ``hcap``, :class:`vibeam.models.core.phases.ContactPhases`), so its
    cost grows with the contact stiffness:
    ``16 sqrt(1 + k_c) / (2 pi)`` steps per unit of time in contact.  A stop at or inside the
    rest position (``Delta <= 0``) holds the mass for about half of each forcing period
    (``8 sqrt(1 + k_c) / Omega`` steps); a stop with a gap is met in impacts of half a contact
    period (8 steps each, one per period counted).  Returns ``(steps, key, value)``, steps of
    the shape of ``Omega``, with the case key that sets the stiffness."""
    k = getattr(scene.stops[0].law, "stiffness", None) if scene.stops else None
    if k is None:
        return None
    try:
        one_mode(scene)
    except ValueError:
        return None
    w = np.sqrt(1.0 + float(k))
    steps = 8.0 * w / Omega if outputs(scene).Delta <= 0.0 else np.full(np.shape(Omega), 8.0)
    given = spec.stiffness_key() if hasattr(spec, "stiffness_key") else None
    return (steps, *given) if given is not None else (steps, "model.contact.stiffness", float(k))


def estimate_work(case, jobs_=None) -> dict:
    """Estimate what a case costs before running it.

    Per point of a time-domain run, the event kernels step a fixed grid:
    ``max(samples, 16 / Omega)`` steps per forcing period (``samples`` =
    ``transient_samples`` in the transient, ``samples_per_period`` in the record;
    the kernel sub-steps below 1/16 of the natural period 2 pi, so a forcing
    period at small Omega costs 16 / Omega steps), plus the steps of a compliant stop's
    contact phase, which is stepped at 1/16 of the contact's period ``2 pi / sqrt(1 + k_c)``
    (:func:`_contact_steps`; the SDOF's stiffness ratio ``k_c``).  Scales that double precision
    cannot carry (a subnormal ``B``, a stiffness beyond 1e20) are refused by case validation
    before this (:data:`vibeam.case.schema.B_RANGE`, :data:`vibeam.case.schema.MAX_CONTACT_STIFFNESS`).  The work is the sum over
    points, directions, runs and map values of ``transient x steps + record x
    steps``, times the retained modes for the FE beam and :data:`ODE_STEP_COST`
    for the ``solve_ivp`` methods (``averaging`` and ``mapping`` count one step
    per point).  It is a lower bound: chatter, impacts and high modes add to it.
    ``work_min`` turns the minimum steps into the time they take, in event-step units: the
    event method's steps times the largest ``work_factor`` of the scene's stop laws
    (:func:`_work_factor`: an integrated contact phase costs far more than its steps on the
    grid; calibrated on the cell matrix, ``vibeam bench --estimate``); the limits
    (:func:`check_work`) count steps.

    Parameters
    ----------
    case : vibeam.case.schema.Case
        The case as run (e.g. its quick variant).
    jobs_ : list, optional
        Its jobs (:func:`case_jobs`), to reuse their grids; built if not given.

    Returns
    -------
    dict
        ``steps`` (float), ``steps_min`` (the record's ``record_periods`` only, not a
        non-periodic point's ``statistics_periods``), ``work_min`` (``steps_min`` weighted by
        the laws' cost, for the time it takes), ``point_values`` (most floats recorded by one point),
        and ``culprit`` ``(key, value)``: the case key that contributes most
        beyond a usual case (101 points, 400 + 64 periods, 64 samples, Omega >= 1,
        one mode, the event method, one map value).
    """
    jobs_ = case_jobs(case) if jobs_ is None else jobs_
    sw = case.sweep
    grid_key = "sweep.Omega" if sw.Omega is not None else "sweep.frequency_hz"
    n_dir = 2 if sw.direction == "both" else 1
    steps = steps_min = work_min = 0.0
    point_values = 0.0
    w_min = np.inf
    worst_modes, worst_cost = (None, 1), (None, 1.0)
    worst_contact = (None, None, 0.0)
    for job in jobs_:
        r = job.run
        Om = np.abs(np.asarray(job.sweep.Omega, float))
        Om = Om[Om > 0] if (Om > 0).any() else np.array([1e-300])
        Om = np.maximum(Om, 1e-300)     # a subnormal Omega: 16 / Omega stays finite, the estimate huge
        w_min = min(w_min, float(Om.min()))
        dofs = _dofs(job.spec)
        if r.method in ("averaging", "mapping"):
            steps += n_dir * Om.size
            steps_min += n_dir * Om.size
            work_min += n_dir * Om.size
            continue
        ts = getattr(r, "transient_samples", 16)
        spp = job.sweep.samples_per_period
        sub = _STEPS_PER_NATURAL_PERIOD / Om
        con = _contact_steps(job.solver.scene, Om, job.spec)
        if con is not None and float(np.max(con[0])) > worst_contact[2]:
            worst_contact = (con[1], con[2], float(np.max(con[0])))
        con = 0.0 if con is None else con[0]
        n_tr = job.sweep.max_transient_periods if job.sweep.auto else job.sweep.transient_periods
        # ``settle``: a settled point's transient may be as short as min_transient_periods (the lower bound)
        n_tr_min = min(n_tr, job.sweep.min_transient_periods) if job.sweep.settle else n_tr
        n_rec = max(job.sweep.record_periods, job.sweep.statistics_periods)   # a non-periodic point's window
        # the Lyapunov spectrum's shots: one event run each, with its tangent (counted twice)
        n_ly = 2 * int(getattr(job.sweep, "lyapunov_shots", 0))
        per = (n_tr * (np.maximum(ts, sub) + con) + n_rec * (np.maximum(spp, sub) + con)
               + n_ly * (np.maximum(ts, sub) + con))
        cost = ODE_STEP_COST if r.method in ("direct", "zhuravlev", "ivanov") else 1.0
        factor = _work_factor(job.solver.scene) if cost == 1.0 else 1.0
        steps += n_dir * float(per.sum()) * dofs * cost
        per_min = (n_tr_min * (np.maximum(ts, sub) + con) + job.sweep.record_periods * (np.maximum(spp, sub) + con)
                   + n_ly * (np.maximum(ts, sub) + con))
        steps_min += n_dir * float(per_min.sum()) * dofs * cost
        work_min += n_dir * float(per_min.sum()) * dofs * cost * factor
        point_values = max(point_values, n_rec * spp * 2.0 * (1 + dofs))
        i = case.run.index(r)
        if dofs > worst_modes[1]:
            worst_modes = (f"run[{i}].model.n_modes" if "n_modes" in r.model else "model.n_modes", dofs)
        if cost > worst_cost[1]:
            worst_cost = (f"run[{i}].method", cost)
    n_pts = len(sw.grid(1.0))
    auto = sw.transient_periods == "auto"
    n_tr = sw.max_transient_periods if auto else sw.transient_periods
    tr_key = "sweep.max_transient_periods" if auto else "sweep.transient_periods"
    rec_key, n_rec = max(("sweep.record_periods", sw.record_periods),
                         ("sweep.statistics_periods", sw.statistics_periods), key=lambda c: c[1])
    periods = n_tr + n_rec
    cands = [
        ((tr_key if n_tr >= n_rec else rec_key), (n_tr if n_tr >= n_rec else n_rec), periods / 464),
        (grid_key, getattr(sw, grid_key.split(".")[1]), max(n_pts / 101, 1.0 / max(w_min, 1e-300))),
        ("sweep.samples_per_period", sw.samples_per_period, sw.samples_per_period / 64),
        ("map.values", case.map.values if case.map else None, len(case.map.grid()) if case.map else 0),
        (worst_modes[0], worst_modes[1], worst_modes[1]),
        (worst_cost[0], None, worst_cost[1]),
        (worst_contact[0], worst_contact[1], worst_contact[2] / 64.0),
    ]
    key, val, _ = max((c for c in cands if c[0]), key=lambda c: c[2])
    if key.endswith(".method"):
        val = case.run[int(key[4:key.index("]")])].method
    return {"steps": steps, "steps_min": steps_min, "work_min": work_min, "point_values": point_values,
            "culprit": (key, val)}


def point_work(Omega: float, transient_periods: int, record_periods: int, samples_per_period: int,
               dofs: int = 1, method: str = "event", transient_samples: int = 16, scene=None) -> dict:
    """The work of one time-domain point as :func:`estimate_work` counts it (its per-point
    term, with a compliant stop's contact steps of ``scene``): ``steps`` and
    ``point_values``, for a point simulated outside a case's sweep (:func:`vibeam.api.simulate`
    with a model), checked against the same limits."""
    Om = max(float(Omega), 1e-300)
    sub = _STEPS_PER_NATURAL_PERIOD / Om
    con = _contact_steps(scene, np.array([Om])) if scene is not None else None
    con = float(con[0][0]) if con is not None else 0.0
    cost = ODE_STEP_COST if method in ("direct", "zhuravlev", "ivanov") else 1.0
    steps = (transient_periods * (max(transient_samples, sub) + con)
             + record_periods * (max(samples_per_period, sub) + con))
    return {"steps": float(steps) * dofs * cost,
            "point_values": float(record_periods) * samples_per_period * 2.0 * (1 + dofs)}


def check_model_size(case, force: bool = False, source: str = "") -> None:
    """Refuse, before any model is built, a case whose one point would record more than
    :data:`MAX_POINT_VALUES` floats with the degrees of freedom its model specs ask for
    (``n_modes = "all"`` of a fine mesh: ``2 n_elements`` modes), unless ``force``.  The same
    rule as :func:`check_work`, from the specs alone: a beam of 2000 elements with every mode
    was refused by it only after its modal basis and tables were built (569 s, 2.4 GB).

    Raises
    ------
    InputError
        Naming the run's ``n_modes`` key, its value, the modes it gives and the limit.
    """
    if force:
        return
    sw = case.sweep
    n_rec = max(sw.record_periods, sw.statistics_periods)
    for i, r in enumerate(case.run):
        try:
            spec = case.model_spec(dict(r.model)) if r.model else case.model_spec()
            dofs = _dofs(spec)
        except Exception:            # noqa: BLE001
            continue                 # a spec that does not build is named by the build itself
        values = n_rec * sw.samples_per_period * 2.0 * (1 + dofs)
        # the modes decide only when one degree of freedom would fit: else the record's keys are
        # the culprit, which check_work names
        if values > MAX_POINT_VALUES and n_rec * sw.samples_per_period * 4.0 <= MAX_POINT_VALUES:
            key = f"run[{i}].model.n_modes" if "n_modes" in r.model else "model.n_modes"
            val = r.model.get("n_modes", getattr(spec.system, "n_modes", dofs))
            where = f"{source}: " if source else ""
            raise InputError(f"{where}'{key}' = {quote_value(val)}: {dofs} modes, one point would record "
                             f"{values:.3g} values (limit {MAX_POINT_VALUES:.0e}, {MAX_POINT_VALUES * 8 / 1e9:.1f} "
                             f"GB); refused before the model is built: fewer modes or elements, fewer recorded "
                             f"periods or samples, or pass --force")


def check_work(case, jobs_=None, force: bool = False, source: str = "") -> dict:
    """Refuse a case whose work (:func:`estimate_work`) exceeds :data:`MAX_WORK_STEPS` or whose
    one point records more than :data:`MAX_POINT_VALUES` floats, unless ``force``.

    Raises
    ------
    InputError
        Naming the key that contributes most, its value, the estimate and the limit.
    """
    with np.errstate(over="ignore"):      # an estimate beyond 1e308 is inf: refused, without a warning line
        w = estimate_work(case, jobs_)
    if force:
        return w
    where = f"{source}: " if source else ""
    if w["point_values"] > MAX_POINT_VALUES:
        sw = case.sweep
        rec_key, n_rec = max(("record_periods", sw.record_periods), ("statistics_periods", sw.statistics_periods),
                             key=lambda c: c[1])
        raise InputError(f"{where}'sweep.{rec_key}' = {n_rec}: one point would record "
                         f"{w['point_values']:.3g} values (limit {MAX_POINT_VALUES:.0e}, "
                         f"{MAX_POINT_VALUES * 8 / 1e9:.1f} GB); record fewer periods or samples, or pass --force")
    if w["steps"] > MAX_WORK_STEPS:
        key, val = w["culprit"]
        hours = w["steps"] * 1e-7 / 3600
        raise InputError(f"{where}'{key}' = {quote_value(val)}: the case needs about {w['steps']:.2g} solver steps "
                         f"(~{hours:.3g} h on one core), above the limit of {MAX_WORK_STEPS:.0e}; "
                         f"reduce it, or pass --force to run anyway")
    return w


