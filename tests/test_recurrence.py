"""The exact recurrence (vibeam.models.core.integrator): a transient whose state at a period start
recurs bit for bit is ended early, a record's cycle is copied to its end, and every output must be
that of the run that integrates every period, bit for bit (the kernel is a deterministic function
of that state).

The reference is the same kernel with the recurrence off (``recurrence=False``) and, as a second
independent switch, with the event log on (which turns it off: its rows would be missing).
Equality is exact (``np.array_equal``, ``==``): a skip that lands one period off, or counters
advanced by a wrong cycle count, changes the samples, the final state or the step and impact
counts.  Each scene is checked to skip something, so the comparison is not vacuous.
"""
import math
from pathlib import Path

import numpy as np
import pytest

from vibeam.case.schema import load_case
from vibeam.models import make_solver
from vibeam.models.builders.sdof import sdof, sdof_physical
from vibeam.models.contact import Restitution
from vibeam.models.core.event import EventIntegrator
from vibeam.models.core.integrator import CYCLE_LOG, new_record
from vibeam.models.scene import one_mode

ROOT = Path(__file__).resolve().parents[1]
SCALARS = ("status", "n_impacts", "s_min", "s_max", "n_chatter", "stuck_time", "held_end", "n_impacts_total",
           "gap_max", "n_steps")


def _sdof(name):
    return {
        "fig7": sdof(beta=0.015, B=0.5e-3, R=0.9, Delta=0.0),
        "two-sided": sdof(beta=0.015, B=0.5e-3, R=0.9, Delta=0.0, Delta_lower=1e-3, lower_law=Restitution(0.6)),
        # the rig's SDOF oscillator in its sticking band: chatter sequences and holds in every period
        "sticking": sdof_physical(7.6, 0.017, -0.1, 180.0, 5.16e-4, 0.35, 0.72),
    }[name]


def _core(name):
    """The kernel's data, the modes, and two forcing frequencies where the transient recurs
    exactly natively and under NUMBA_CPU_NAME=generic (whether a chattering orbit's transient
    recurs within 400 periods depends on the last bits: the tight beam at 15 Hz does natively,
    not under generic)."""
    if name == "beam-2-modes":
        m = load_case(ROOT / "cases" / "rig-fe-tight.toml")[0].model_spec({"n_modes": 2}).scene()
        f_ref = m.system.reference_hz
        return EventIntegrator(m), 2, (16.0 / f_ref, 16.5 / f_ref)
    sc = _sdof(name)
    Om = {"fig7": (1.5, 2.1), "two-sided": (1.9, 2.1), "sticking": (14.0 / 7.6, 14.5 / 7.6)}[name]
    return EventIntegrator(sc), 1, Om


def _run(core, n, Om, n_transient, n_record, max_impacts=10**7, max_steps=4 * 10**6, **kw):
    z = np.zeros(n)
    return core.run(Om, z, z, 0, n_transient, n_record, 16, 64, 2 * math.pi / Om / 16, max_impacts, max_steps,
                    1e-7, **kw)


def _assert_identical(a, b):
    for f in SCALARS:
        assert getattr(a, f) == getattr(b, f), f
    np.testing.assert_array_equal(a.eta, b.eta)
    np.testing.assert_array_equal(a.etad, b.etad)
    for f in ("samples", "pmin", "modamp", "n_imp_stop"):
        np.testing.assert_array_equal(getattr(a.record, f), getattr(b.record, f), err_msg=f)
    k = min(a.n_impacts, a.record.imp_t.shape[0])
    for f in ("imp_t", "imp_v", "imp_k", "imp_tl", "imp_rp"):
        np.testing.assert_array_equal(getattr(a.record, f)[:k], getattr(b.record, f)[:k], err_msg=f)
    c = min(a.n_chatter, a.record.chat_t.shape[0])
    np.testing.assert_array_equal(a.record.chat_t[:c], b.record.chat_t[:c])


@pytest.mark.parametrize("name", ["fig7", "sticking"])
def test_work_arrays_kept_across_frequencies_give_a_fresh_integrators_outputs(name):
    """EventIntegrator.run keeps its work arrays and compiled entry for the next call whose
    tables have the same sizes (work_sizes), whatever the frequency: across the frequencies
    where the sub-steps per grid step change (with h_cap = 2 pi / 16 the transient's grid step
    T / 16 is h_cap / Om: one sub-step above Om = 1, k below Om = 1 / (k - 1)), within
    round-off of such a change, and back, every output equals a fresh integrator's bit for
    bit; a used integrator pickles (to a pool worker) and runs the same."""
    import pickle

    sc = _sdof(name)
    core = EventIntegrator(sc)
    h_cap = 2 * math.pi / 16
    z = np.zeros(1)
    for Om in (1.9, 1.5, 0.9, 0.5 * (1 + 1e-13), 0.5, 0.5 * (1 - 1e-13), 0.34, 1 / 3, 0.3, 1.0, 2.1):
        a = core.run(Om, z, z, 0, 60, 6, 16, 64, h_cap, 10 ** 6, 10 ** 7, 1e-7)
        b = EventIntegrator(sc).run(Om, z, z, 0, 60, 6, 16, 64, h_cap, 10 ** 6, 10 ** 7, 1e-7)
        _assert_identical(a, b)
    c = pickle.loads(pickle.dumps(core))
    _assert_identical(c.run(1.7, z, z, 0, 60, 6, 16, 64, h_cap, 10 ** 6, 10 ** 7, 1e-7),
                      core.run(1.7, z, z, 0, 60, 6, 16, 64, h_cap, 10 ** 6, 10 ** 7, 1e-7))


@pytest.mark.parametrize("name", ["fig7", "two-sided", "sticking", "beam-2-modes"])
def test_a_recurring_transient_ends_early_with_the_outputs_of_every_period(name):
    """Newton stops, one and two of them, with sticking and chatter (the Zeno guard's window
    is live with two modes): outputs equal to both references at both frequencies, and at
    least one of them skips over 100 periods."""
    core, n, Oms = _core(name)
    skipped = []
    for Om in Oms:
        a = _run(core, n, Om, 400, 32)
        b = _run(core, n, Om, 400, 32, recurrence=False)
        c = _run(core, n, Om, 400, 32, log_events=1)
        assert b.periods_skipped == 0 and c.periods_skipped == 0
        _assert_identical(a, b)
        _assert_identical(a, c)
        skipped.append(a.periods_skipped)
        if name in ("sticking", "beam-2-modes"):
            assert a.stuck_time > 0.0 and a.n_chatter > 0     # the scene does stick and chatter
    assert max(skipped) > 100, skipped


def test_a_call_without_record_ends_on_the_skipped_period():
    """``n_record = 0`` (a call that only settles): a skip may end the call; the final state and
    counters are those of every period (the first version ran one period beyond the call here)."""
    core, n, (Om, _) = _core("fig7")
    for n_tr in (300, 301, 317):
        a = _run(core, n, Om, n_tr, 0)
        b = _run(core, n, Om, n_tr, 0, recurrence=False)
        assert a.periods_skipped > 0
        _assert_identical(a, b)


@pytest.mark.parametrize("buffer", [4096, 7])
def test_a_recurring_record_is_copied_to_its_end(buffer):
    """A run that is all record (no transient): once the recorded state recurs, whole cycles are
    copied (samples, modal states, per-period minima, impacts and their times, also when the
    impact buffer fills up mid-copy), identical to integrating every period."""
    core, n, (Om, Om2) = _core("fig7")
    for W in (Om, Om2):
        a = _run(core, n, W, 0, 300, impact_buffer=buffer, modal_states=True)
        b = _run(core, n, W, 0, 300, impact_buffer=buffer, modal_states=True, recurrence=False)
        assert a.periods_skipped > 30 and b.periods_skipped == 0
        assert a.n_impacts > buffer or buffer > 300
        _assert_identical(a, b)
        np.testing.assert_array_equal(a.record.msamp, b.record.msamp)


@pytest.mark.parametrize("rows, buffer", [(CYCLE_LOG, 4096), (CYCLE_LOG, 7), (3, 4096)])
def test_a_record_that_holds_and_chatters_is_copied_with_its_sums_replayed(rows, buffer):
    """A recorded cycle that adds time held and chatter sequences (the sticking scene: a chattering
    orbit) is copied with the record's cycle log replayed: the time held summed and the
    accumulation points rebuilt in the full run's order, identical to integrating every period
    (also when the chatter buffer fills up mid-copy, ``buffer`` 7).  With a cycle log too short
    for one cycle (3 rows) the record is integrated to its end, identical."""
    core, n, (Om, _) = _core("sticking")
    rec = new_record(n, 1, 200, 64, buffer)._replace(cycle=np.empty((rows, 4)))
    a = _run(core, n, Om, 400, 200, record=rec, impact_buffer=buffer)
    b = _run(core, n, Om, 400, 200, recurrence=False, impact_buffer=buffer)
    assert a.stuck_time > 0.0 and a.n_chatter > 0
    assert a.n_chatter > buffer or buffer > 7
    if rows == CYCLE_LOG:
        assert a.periods_skipped > 400 + 150     # the transient and most of the record
    else:
        assert 0 < a.periods_skipped <= 400      # the transient only
    _assert_identical(a, b)


def test_no_skip_past_a_guard_the_full_run_would_hit():
    """An impact or step budget that the full run exhausts in the transient: no skip jumps over
    it; the point fails as the full run does, with the same counts."""
    core, n, (Om, _) = _core("fig7")
    full = _run(core, n, Om, 400, 8, recurrence=False)
    per_period_steps = full.n_steps / 408
    for guard in ({"max_impacts": 300}, {"max_steps": int(300 * per_period_steps)}):
        a = _run(core, n, Om, 400, 8, **guard)
        b = _run(core, n, Om, 400, 8, recurrence=False, **guard)
        assert a.status == b.status == 3      # ST_FAILED
        _assert_identical(a, b)


def test_the_sweep_outputs_do_not_depend_on_the_recurrence():
    """Through the solver and the per-point summary: every output of the Fig. 7 scene's points."""
    from vibeam.engine.records import summarize

    sc = _sdof("fig7")
    on, off = make_solver(sc, "event"), make_solver(sc, "event", recurrence=False)
    for W in (1.5, 1.8, 2.2):
        a, b = on.point(W, None, 436, 64), off.point(W, None, 436, 64)
        sa, sb = summarize(a, one_mode(sc).Delta), summarize(b, one_mode(sc).Delta)
        assert sa.keys() == sb.keys()
        for k in sa:
            np.testing.assert_array_equal(np.asarray(sa[k]), np.asarray(sb[k]), err_msg=k)
        np.testing.assert_array_equal(a.final_state, b.final_state)


@pytest.mark.parametrize("case", ["rig-fe-neutral", "rig-fe-tight"])
def test_a_beam_sweep_in_chunks_does_not_depend_on_the_recurrence(case, monkeypatch):
    """The sweep engine cuts a beam point into calls of ``chunk_periods`` (here 50: eight calls of
    the 400-period transient, each with its own snapshots): every output of the sweep, a
    two-mode rig beam at 14-17 Hz both ways (the tight rig sticks and chatters), is the same."""
    from vibeam.engine.sweep import Sweep, run_sweep

    m = load_case(ROOT / "cases" / f"{case}.toml")[0].model_spec({"n_modes": 2}).scene()
    sw = Sweep(Omega=np.linspace(14.0, 17.0, 4) / m.system.reference_hz, direction="both", transient_periods=400,
               record_periods=32)
    skipped = []
    inner = EventIntegrator.run

    def counting(self, *a, **k):
        r = inner(self, *a, **k)
        skipped.append(r.periods_skipped)
        return r

    monkeypatch.setattr(EventIntegrator, "run", counting)
    out = []
    for rec in (True, False):
        solver = make_solver(m, "event", recurrence=rec)
        solver.chunk_periods = 50
        out.append(run_sweep(solver, sw, jobs=1).data)
    assert len(skipped) == 2 * 64 and sum(skipped[64:]) == 0
    assert sum(skipped[:64]) > 300              # measured 1732 (neutral), 664 (tight) of 3456
    a, b = out
    assert a.keys() == b.keys()
    for k in a:
        if k != "wall_time_s":
            np.testing.assert_array_equal(np.asarray(a[k]), np.asarray(b[k]), err_msg=k)


@pytest.mark.parametrize("name, Om", [("fig7", 1.5), ("fig7", 2.1), ("two-sided", 1.9),
                                      ("sticking", 14.0 / 7.6), ("sticking", 14.5 / 7.6)])
def test_the_dense_record_equals_the_record_on_its_own_grid(name, Om):
    """A one-mode record whose 64 samples refine the transient's 16-point grid steps on that grid
    and evaluates the samples inside a free step by the closed-form flow (dense output); held
    steps and the chatter policy see the rest of the record's grid step.  Reference: the same
    record on its own grid (``ns_transient = ns_record = 64``), from one settled state, eight
    periods, every period integrated.  Both are the exact flow, so they differ only by the
    rounding of differently split steps (ulps per step over ~100 steps a period, amplified by the
    flow over 8 periods): measured <= 3e-14 of the motion's scale with impacts, chatter and
    sticking; the tolerance 1e-12 leaves a 30x margin (other CPUs, numba's generic target).  A
    sample missed, taken twice, or at a wrong time or phase is off by 1e-3 or more; a policy
    that saw the transient's longer step would change the chatter and hold counts."""
    core, n, _ = _core(name)
    h = 2 * math.pi / Om / 16
    z = np.zeros(n)
    settled = core.run(Om, z, z, 0, 400, 0, 16, 64, h, 10 ** 7, 10 ** 8, 1e-7)
    runs = [core.run(Om, settled.eta.copy(), settled.etad.copy(), 0, 0, 8, ns, 64, h, 10 ** 7, 10 ** 8, 1e-7,
                     recurrence=False) for ns in (16, 64)]
    a, b = runs
    assert a.n_steps < b.n_steps                  # the dense record did step on the coarser grid
    for f in ("status", "n_impacts", "n_chatter", "held_end", "n_impacts_total"):
        assert getattr(a, f) == getattr(b, f), f
    scale = np.max(np.abs(b.record.samples))
    np.testing.assert_allclose(a.record.samples, b.record.samples, rtol=0, atol=1e-12 * scale)
    np.testing.assert_allclose(a.record.pmin, b.record.pmin, rtol=0, atol=1e-12 * scale)
    np.testing.assert_allclose([a.s_min, a.s_max], [b.s_min, b.s_max], rtol=0, atol=1e-12 * scale)
    k = min(a.n_impacts, a.record.imp_t.shape[0])
    T = 2 * math.pi / Om
    np.testing.assert_allclose(a.record.imp_t[:k], b.record.imp_t[:k], rtol=0, atol=1e-12 * 8 * T)
    np.testing.assert_allclose(a.stuck_time, b.stuck_time, rtol=0, atol=1e-12 * 8 * T)
    if name == "sticking":
        assert a.stuck_time > 0.0 and a.n_chatter > 0


@pytest.mark.parametrize("Om", [1.5, 2.1])
def test_a_settled_transient_makes_the_record_a_copy_of_its_cycle(Om):
    """The dense record continues the transient's floating-point cycle (the same steps): once the
    transient recurs, the record integrates one cycle (and the period its snapshot waits for) and
    copies the rest.  On the record's own grid the orbit settled anew first: ~30 of 64 periods
    integrated on average over the Fig. 7 sweep; here at most 12 (a count, not a time)."""
    core, n, _ = _core("fig7")
    transient = _run(core, n, Om, 400, 0)
    full = _run(core, n, Om, 400, 64)
    assert transient.periods_skipped > 100
    assert full.periods_skipped - transient.periods_skipped >= 64 - 12
