"""Kernels compiled ahead in a forked child (:mod:`vibeam.models.core.ahead`, issue 44).

Each check runs in a fresh interpreter (one thread, as the command line) on its own empty numba
cache, with small kernels written to a temporary module, so that it can see what the parent
compiled (numba's ``"numba:compile"`` events and the dispatchers' overloads):

* a child compiles the kernels of its plan into numba's cache; the parent's first call then
  compiles nothing of its own (the wait is reported as one compile event of the kernel) and
  returns what a kernel compiled in the parent returns;
* a gate holds the kernels after it until :func:`~vibeam.models.core.ahead.proceed`;
* a child that dies saves nothing, and the parent compiles the kernel itself;
* nothing is forked when the kernel is cached already, with ``VIBEAM_COMPILE_AHEAD=0`` or with a
  second thread running;
* the child ends with its parent, whether the parent leaves by an exception or is killed.

The continuation's use of it (the tangent and the corrector compiled beside the shots) is
checked end to end, bit for bit against a run that compiles everything in one process, by the
slow test at the end.
"""
from __future__ import annotations

import json
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import numba
import numpy as np
import pytest

#: compiling ahead forks (:func:`vibeam.models.core.ahead.enabled`): elsewhere the parent compiles all
LINUX_ONLY = pytest.mark.skipif(not sys.platform.startswith("linux"), reason="compiling ahead forks: Linux only")

KERNELS = textwrap.dedent('''
    import numpy as np
    from numba import njit

    @njit(cache=True)
    def shared(a, k):
        s = 0.0
        for i in range(a.shape[0]):
            s += a[i] ** k
        return s

    @njit(cache=True)
    def first(a):
        return shared(a, 2) + 1.0

    @njit(cache=True)
    def second(a, b):
        return shared(a, 3) * b
''')

DRIVER = textwrap.dedent('''
    import json, os, sys, threading, time
    sys.path.insert(0, sys.argv[1])
    import numpy as np
    from numba.core import event
    import vibeam.models  # noqa: F401
    from vibeam.models.core import ahead
    import toy
    compiled = []
    class L(event.Listener):
        def on_start(self, ev):
            compiled.append(ev.data["dispatcher"].py_func.__name__)
        def on_end(self, ev):
            pass
    event.register("numba:compile", L())
    a = np.arange(5.0)
    out = {}
    scenario = sys.argv[2]
    if scenario == "thread":
        t = threading.Thread(target=time.sleep, args=(2.0,))
        t.start()
    if scenario == "gate":
        out["started"] = ahead.start([(toy.first, (a,)), ahead.GATE, (toy.second, (a, 2.0))])
        time.sleep(float(sys.argv[3]))
        out["second_cached_before_proceed"] = toy.second._cache.load_overload(
            (toy.second.typeof_pyval(a), toy.second.typeof_pyval(2.0)), toy.second.targetctx) is not None
        ahead.proceed(toy.second)
    elif scenario == "killed":
        out["started"] = ahead.start([ahead.GATE, (toy.second, (a, 2.0))])
        import signal
        pid = ahead.pending()[toy.second]
        os.kill(pid, signal.SIGKILL)
    else:
        out["started"] = ahead.start([(toy.first, (a,)), (toy.second, (a, 2.0))])
    out["pending"] = sorted(d.py_func.__name__ for d in ahead.pending())
    if scenario != "killed":
        ahead.wait(toy.first, (a,))
    ahead.wait(toy.second, (a, 2.0))
    out["first"] = toy.first(a)
    out["second"] = toy.second(a, 2.0)
    out["compiled"] = compiled
    print(json.dumps(out))
''')


def _run(tmp_path, scenario, *extra, env=None):
    mod = tmp_path / "mod"
    mod.mkdir(exist_ok=True)
    (mod / "toy.py").write_text(KERNELS)
    e = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path / "cache"))
    e.pop("VIBEAM_COMPILE_AHEAD", None)
    e.update(env or {})
    r = subprocess.run([sys.executable, "-c", DRIVER, str(mod), scenario, *map(str, extra)], env=e,
                       capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    return json.loads(r.stdout.strip().splitlines()[-1])


def _expected():
    a = np.arange(5.0)
    return float(np.sum(a ** 2) + 1.0), float(np.sum(a ** 3) * 2.0)


@LINUX_ONLY
@pytest.mark.xfail(tuple(int(x) for x in numba.__version__.split(".")[:2]) < (0, 68), strict=False,
                   reason="numba 0.61.2 (the pinned range's low end, CI's last step, 2026-11-27): a second process "
                          "forks and compiles again instead of loading the child's cache entries (a wasted compile, "
                          "not a wrong result); left open")
def test_the_child_compiles_and_the_parent_only_loads(tmp_path):
    out = _run(tmp_path, "plain")
    assert out["started"] is True
    assert out["pending"] == ["first", "second"]
    # the parent's compile events: the two waits, nothing nested (no kernel compiled here)
    assert out["compiled"] == ["first", "second"]
    assert (out["first"], out["second"]) == _expected()
    # a second process loads both from the cache: nothing forked, nothing compiled
    again = _run(tmp_path, "plain")
    assert again["started"] is False and again["pending"] == [] and again["compiled"] == []
    assert (again["first"], again["second"]) == _expected()


ORPHAN = textwrap.dedent('''
    import os, signal, sys, time
    sys.path.insert(0, sys.argv[1])
    import numpy as np
    import vibeam.models  # noqa: F401
    from vibeam.models.core import ahead
    import toy
    toy.first.compile = lambda sig: time.sleep(120)      # a compile that outlasts the parent
    a = np.arange(5.0)
    assert ahead.start([(toy.first, (a,))])
    print(ahead.pending()[toy.first], flush=True)
    time.sleep(0.5)
    if sys.argv[2] == "killed":
        os.kill(os.getpid(), signal.SIGKILL)
    raise KeyboardInterrupt                              # an interrupted command leaves by its exception
''')


def _alive(pid: int) -> bool:
    """Whether process ``pid`` runs (a zombie left to a container's init, which may not reap it,
    counts as ended)."""
    try:
        with open(f"/proc/{pid}/stat") as f:
            return f.read().rsplit(")", 1)[1].split()[0] != "Z"
    except OSError:
        return False


@LINUX_ONLY
@pytest.mark.parametrize("how", ["interrupted", "killed"])
def test_the_child_ends_with_its_parent(tmp_path, how):
    """Issue 57 (7): SIGINT or SIGTERM to a cold command ended the parent in about a second while
    the child kept compiling under ppid 1 for 10-25 s.  A child whose compile would take 120 s is
    gone within 5 s of its parent's end, whether the parent leaves by an exception (the atexit hook
    kills it) or is killed outright (PR_SET_PDEATHSIG)."""
    import time

    mod = tmp_path / "mod"
    mod.mkdir()
    (mod / "toy.py").write_text(KERNELS)
    e = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path / "cache"))
    e.pop("VIBEAM_COMPILE_AHEAD", None)
    out = tmp_path / "out.txt"
    with open(out, "w") as f:           # a file, not a pipe: waiting for a pipe's end waits for the child
        p = subprocess.Popen([sys.executable, "-c", ORPHAN, str(mod), how], env=e, stdout=f,
                             stderr=subprocess.DEVNULL)
        assert p.wait(timeout=300) != 0
    child = int(out.read_text().split()[0])
    t0 = time.monotonic()
    while _alive(child) and time.monotonic() - t0 < 5.0:
        time.sleep(0.05)
    assert not _alive(child), f"the child {child} outlived its parent by 5 s"


@LINUX_ONLY
def test_a_gate_holds_what_follows_it_until_proceed(tmp_path):
    out = _run(tmp_path, "gate", 3.0)
    assert out["started"] is True
    # 3 s is ample for the child to have compiled ``second`` had the gate not held it
    assert out["second_cached_before_proceed"] is False
    assert out["compiled"] == ["first", "second"]
    assert (out["first"], out["second"]) == _expected()


@LINUX_ONLY
def test_a_child_that_dies_leaves_the_compile_to_the_parent(tmp_path):
    out = _run(tmp_path, "killed")
    assert out["started"] is True
    # the wait's event, then the parent's own compilation of ``second`` and of its callee inside it
    # (then ``first``, which no child compiled, at its call)
    assert out["compiled"][:3] == ["second", "second", "shared"]
    assert out["second"] == _expected()[1]


@pytest.mark.parametrize("scenario, env", [("plain", {"VIBEAM_COMPILE_AHEAD": "0"}), ("thread", {})])
def test_nothing_is_forked_when_off_or_threaded(tmp_path, scenario, env):
    out = _run(tmp_path, scenario, env=env)
    assert out["started"] is False and out["pending"] == []
    assert out["compiled"] == ["first", "shared", "second", "shared"]
    assert (out["first"], out["second"]) == _expected()


CONTINUE = textwrap.dedent('''
    import json, sys
    from numba.core import event
    compiled = []
    class L(event.Listener):
        def on_start(self, ev):
            compiled.append(ev.data["dispatcher"].py_func.__name__)
        def on_end(self, ev):
            pass
    event.register("numba:compile", L())
    from vibeam.cli import main
    rc = main(["continue", sys.argv[1], "--quick", "--out", sys.argv[2], "--no-plots", "--quiet", "--jobs", "1"])
    print(json.dumps(dict(rc=rc, compiled=compiled)))
''')


def _cold_with_and_without(driver, case, tmp_path):
    """``driver`` on ``case`` in two fresh processes on empty caches, compiling ahead and not:
    ``(events with, events without, results.h5 with, results.h5 without)``."""
    runs = {}
    for mode in ("1", "0"):
        e = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path / f"cache{mode}"), VIBEAM_COMPILE_AHEAD=mode)
        out = tmp_path / f"out{mode}"
        r = subprocess.run([sys.executable, "-c", driver, str(case), str(out)], env=e, capture_output=True,
                           text=True, timeout=1800)
        assert r.returncode == 0, r.stderr
        runs[mode] = (json.loads(r.stdout.strip().splitlines()[-1])["compiled"], out / "results.h5")
    return runs["1"][0], runs["0"][0], runs["1"][1], runs["0"][1]


def _assert_same_arrays(h5_a, h5_b):
    """Every dataset of the two files equal bit for bit (NaN equal to NaN), the points' wall times
    (timings, not results) apart."""
    import h5py

    arrays = []
    for h5 in (h5_a, h5_b):
        with h5py.File(h5, "r") as f:
            got = {}
            f.visititems(lambda name, obj: got.__setitem__(name, obj[()]) if isinstance(obj, h5py.Dataset) else None)
        arrays.append(got)
    assert arrays[0].keys() == arrays[1].keys() and len(arrays[0]) > 0
    for k in arrays[0]:
        if k.endswith("wall_time_s"):
            continue
        a, b = np.asarray(arrays[0][k]), np.asarray(arrays[1][k])
        if a.dtype.kind in "fc":
            assert np.array_equal(a, b, equal_nan=True), k
        else:
            assert np.array_equal(a, b), k


@LINUX_ONLY
@pytest.mark.slow
def test_a_first_continuation_compiles_its_corrector_beside_and_gives_the_same_bits(tmp_path):
    """The Fig. 13 continuation, cold, with and without compiling ahead: the same arrays in
    results.h5 bit for bit; with it, the parent never compiles the tangent and the corrector's own
    callees (the child did), and its corrector's compile event is the wait alone (nothing
    nested)."""
    case = Path(__file__).resolve().parents[1] / "cases" / "paper-fig13-continuation.toml"
    ahead_, plain, h5_a, h5_b = _cold_with_and_without(CONTINUE, case, tmp_path)
    for k in ("tangent", "floquet_spectrum_small", "bordered_tangent", "_bordered_step"):
        assert k in plain and k not in ahead_, k
    i = ahead_.index("correct_frequency")
    assert ahead_[i + 1:i + 2] != ["correct_frequency"]
    _assert_same_arrays(h5_a, h5_b)
