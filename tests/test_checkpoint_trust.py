"""A checkpoint is believed only for what vibeam wrote there (issue 57, items 5 and 6).

``--resume`` takes finished work from ``results.h5.partial``: sweep lines (``/lines``), sampled
sweeps (``/uncertainty_samples``) and basin rows (``/basin_lines``).  Each group carries the digest
of its contents (:func:`vibeam.io.store.checkpoint_digest`), and its values are checked against
what vibeam writes (:func:`vibeam.engine.sweep.check_line`,
:func:`vibeam.analysis.uncertainty.check_block`, :func:`vibeam.analysis.attractors.check_row`).
The issue's probe found values vibeam never writes carried into a file marked complete (amplitude
-1e300 at ok points, inf at chatter points, period -5 or 2^62, a complex amplitude_mean, ...) and
trailing axes that gave tracebacks, some after the rest had been recomputed.  Each is refused here
in one line before anything is computed, the files left byte for byte.  The value rules are
tested on checkpoints without their digest (as an earlier vibeam wrote them, or as a tool that
rewrites the digest leaves them); the digest refuses the rest (a plausible value changed, a group
copied under another key).

The property tests tamper a real checkpoint (a small SDOF map interrupted after 2 of its 4
lines, made once per module by the real writer): with its digest, any dataset's shape, type,
values or a copy of another's values; without it, values vibeam never writes.  Either the resume
is refused in one line (exit 2), or its results equal the untampered resume's.
"""
from __future__ import annotations

import copy
import shutil
import types
from pathlib import Path

import h5py
import numpy as np
import pytest
from hypothesis import HealthCheck, given, note, settings
from hypothesis import strategies as st

import vibeam
from vibeam.cli import main
from vibeam.engine import sweep
from vibeam.errors import InputError
from vibeam.io.store import DIGEST_ATTR

# 2 values of the voltage x 3 frequencies x both directions: 4 lines of 3 points, every point ok
# (period 1 and 4) after 300 transient periods
MAP = """
name = "smap"
description = "a small map"
[model]
fidelity = "sdof"
natural_frequency_hz = 7.6
damping_ratio = 0.017
R = 0.72
gap_mm = -0.05
length_mm = 180.0
gain = 5.16e-4
voltage = 0.6
[sweep]
frequency_hz = [14.0, 17.0, 3]
direction = "both"
transient_periods = 300
record_periods = 16
[map]
parameter = "voltage"
values = [0.5, 0.7, 2]
[[run]]
name = "exact"
method = "event"
"""
QUIET = ["--jobs", "1", "--quiet", "--no-plots"]
LINE = "lines/exact/0000-up"          # a stored line (the first value's up sweep)


def _interrupt_after(mp, finished: int):
    """The engine finishes ``finished`` units, hands them to the checkpoint, raises KeyboardInterrupt
    (as Ctrl-C in the engine does: tests/test_store.py)."""
    real = sweep.run_lines

    def interrupted(lines, on_line=None, **kw):
        for line in list(lines)[:finished]:
            for _, rows in real([line], jobs=1).items():
                if on_line is not None:
                    on_line(line, rows)
        raise KeyboardInterrupt

    mp.setattr(sweep, "run_lines", interrupted)


@pytest.fixture(scope="module")
def stored(tmp_path_factory):
    """A folder holding a real checkpoint: the map interrupted after 2 of its 4 lines."""
    d = tmp_path_factory.mktemp("checkpoint")
    (d / "smap.toml").write_text(MAP)
    with pytest.MonkeyPatch.context() as mp:
        _interrupt_after(mp, 2)
        assert main(["map", str(d / "smap.toml"), "--out", str(d / "D"), *QUIET]) == 130
    with h5py.File(d / "D" / "results.h5.partial", "r") as f:
        assert sorted(f["lines/exact"]) == ["0000-down", "0000-up"]
        assert set(f[LINE]["status"].asstr()[()]) == {"ok"}
    return d


def _copy(stored, tmp_path) -> tuple[Path, Path]:
    shutil.copy(stored / "smap.toml", tmp_path / "smap.toml")
    shutil.copytree(stored / "D", tmp_path / "D")
    return tmp_path / "smap.toml", tmp_path / "D"


def _snapshot(folder: Path) -> dict:
    return {p.name: p.read_bytes() for p in sorted(folder.iterdir()) if p.is_file()}


def _replace(g, name, data):
    """Dataset ``name`` of group ``g`` replaced by ``data`` (texts as HDF5 strings)."""
    data = np.asarray(data)
    if data.dtype.kind in "OU":
        data = data.astype(object)
        dt = h5py.string_dtype()
    else:
        dt = data.dtype
    del g[name]
    g.create_dataset(name, data=data, dtype=dt)


def _set(name, index, value):
    def f(g):
        a = g[name].asstr()[()] if h5py.check_string_dtype(g[name].dtype) else g[name][()]
        a = a.astype(object) if a.dtype.kind in "OU" else a
        a[index] = value
        _replace(g, name, a)
    return f


def _both(*fs):
    def f(g):
        for x in fs:
            x(g)
    return f


def _refused(capsys, monkeypatch, case, out, *words, command="map"):
    """--resume is refused in one line naming the checkpoint and ``words``, before anything is
    computed, and no file changes."""
    before = _snapshot(out)
    calls = []
    monkeypatch.setattr(sweep, "run_lines", lambda lines, **kw: calls.append(lines))
    capsys.readouterr()
    rc = main([command, str(case), "--out", str(out), "--resume", *QUIET])
    err = [l for l in capsys.readouterr().err.splitlines() if l.strip() and not l.startswith("[")]
    assert rc == 2, err
    assert len(err) == 1 and err[0].startswith("vibeam: error: --resume: ") and "Traceback" not in err[0], err
    assert "results.h5.partial" in err[0], err
    for w in words:
        assert w in err[0], (w, err)
    assert not calls
    assert _snapshot(out) == before
    return err[0]


# ----------------------------------------------------------------------------- item 5: values
VALUES = {
    # the measurements
    "amplitude -1e300 at an ok point": (_set("amplitude", 0, -1e300), "amplitude"),
    "inf amplitude at a chatter point": (_both(_set("status", 1, "chatter"), _set("amplitude", 1, np.inf)),
                                         "amplitude"),
    "period -5": (_set("period", 2, -5), "period"),
    "period 2^62": (_set("period", 0, 2 ** 62), "period"),
    "complex amplitude_mean": (lambda g: _replace(g, "amplitude_mean", g["amplitude_mean"][()] * (1 + 1j)),
                               "amplitude_mean"),
    "stuck_fraction 7": (_set("stuck_fraction", 1, 7.0), "stuck_fraction"),
    "q_max below q_min": (lambda g: _set("q_max", 0, g["q_min"][0] - 1e-3)(g), "q_max"),
    "record_periods -3": (_set("record_periods", 2, -3), "record_periods"),
    "NaN impacts_per_period at an ok point": (_set("impacts_per_period", 0, np.nan), "impacts_per_period"),
    "a 1 MB message": (_set("message", 1, "x" * 2 ** 20), "message"),
    # more of the same kind
    "amplitude not Delta - q_min": (lambda g: _set("amplitude", 0, g["amplitude"][0] * 1.5)(g), "amplitude"),
    "amplitude 5": (_set("amplitude", 0, 5.0), "amplitude"),
    "q_min -1e300": (_set("q_min", 0, -1e300), "q_min"),
    "inf energy at an ok point": (_set("energy_per_impact", 0, np.inf), "energy_per_impact"),
    "a negative wall time": (_set("wall_time_s", 0, -7.0), "wall_time_s"),
    "direction of another line": (_set("direction", 0, "down"), "direction"),
    "period 2.5": (lambda g: _replace(g, "period", np.array([1.0, 2.5, 1.0])), "period"),
    "float32 amplitude": (lambda g: _replace(g, "amplitude", g["amplitude"][()].astype(np.float32)), "amplitude"),
    "impacts per period not a count": (_set("impacts_per_period", 1, 1.03), "impacts_per_period"),
    "transient periods of another sweep": (_set("transient_periods_used", 0, 20), "transient_periods_used"),
    "a stroboscopic q beyond q_max": (lambda g: _set("strobe", (0, 3, 0), g["q_max"][0] + 1e-3)(g), "strobe"),
    "a dimension stored as an output": (lambda g: (g.__delitem__("point"),
                                                   g.create_dataset("point", data=np.arange(3.0))), "point"),
}


@pytest.mark.parametrize("tamper", list(VALUES))
def test_resume_refuses_values_vibeam_never_writes(stored, tmp_path, monkeypatch, capsys, tamper):
    """Each value was taken on main (12b4b7f) into a file marked complete (or gave a traceback).
    The checkpoint's digest is removed, as in a checkpoint of an earlier vibeam: the value rules
    alone refuse it, in one line naming the dataset."""
    case, out = _copy(stored, tmp_path)
    f, word = VALUES[tamper]
    with h5py.File(out / "results.h5.partial", "r+") as h:
        f(h[LINE])
        if DIGEST_ATTR in h[LINE].attrs:
            del h[LINE].attrs[DIGEST_ATTR]
    _refused(capsys, monkeypatch, case, out, LINE, word)


# ----------------------------------------------------------------------------- item 6: trailing axes
SHAPES = {"amplitude (3, 3)": ("amplitude", (3, 3)), "strobe (3, 16, 3)": ("strobe", (3, 16, 3)),
          "strobe (3, 2, 2)": ("strobe", (3, 2, 2)), "harmonics (3, 999)": ("harmonics", (3, 999)),
          "q_min (3, 1)": ("q_min", (3, 1))}


@pytest.mark.parametrize("shape", list(SHAPES))
@pytest.mark.parametrize("digest", ["kept", "removed"])
def test_resume_refuses_trailing_axes_before_computing(stored, tmp_path, monkeypatch, capsys, shape, digest):
    """amplitude (n, 3) gave a traceback in check_line; strobe (n, 16, 3) or (n, 2, 2) and harmonics
    (n, 999) failed in stack() after the other lines were computed.  Now: one line naming the
    dataset and the shape allowed, nothing computed."""
    case, out = _copy(stored, tmp_path)
    name, sh = SHAPES[shape]
    with h5py.File(out / "results.h5.partial", "r+") as h:
        g = h[LINE]
        _replace(g, name, np.resize(g[name][()], sh))
        if digest == "removed":
            del g.attrs[DIGEST_ATTR]
    _refused(capsys, monkeypatch, case, out, LINE, f"dataset {name} has shape {sh}")


def test_lines_of_one_run_with_per_point_arrays_of_two_shapes_are_refused(stored, tmp_path, monkeypatch, capsys):
    """An output whose trailing axes the line does not fix (here a peak table) has one shape in a
    run: two stored lines that differ would fail in stack() once the rest is computed; refused
    first, naming both lines."""
    case, out = _copy(stored, tmp_path)
    with h5py.File(out / "results.h5.partial", "r+") as h:
        for key, n in (("0000-up", 4), ("0000-down", 5)):
            g = h[f"lines/exact/{key}"]
            g.create_dataset("peaks_frequency", data=np.full((3, n), np.nan))
            del g.attrs[DIGEST_ATTR]
    _refused(capsys, monkeypatch, case, out, "peaks_frequency", "0000-down", "0000-up")


# ----------------------------------------------------------------------------- the digest
def test_a_plausible_value_or_a_copied_line_is_refused_by_the_digest(stored, tmp_path, monkeypatch, capsys):
    """What no value rule can tell -- an amplitude changed by 1e-6 of itself (and q_min with it),
    the first value's up line copied under the second value's key (the same frequencies) -- is
    refused by the digest of the group's contents."""
    case, out = _copy(stored, tmp_path)
    keep = (out / "results.h5.partial").read_bytes()
    with h5py.File(out / "results.h5.partial", "r+") as h:
        g = h[LINE]
        a, q = g["amplitude"][()], g["q_min"][()]
        g["amplitude"][0] = a[0] * (1 + 1e-6)
        g["q_min"][0] = q[0] - a[0] * 1e-6
    _refused(capsys, monkeypatch, case, out, LINE, "digest")
    (out / "results.h5.partial").write_bytes(keep)
    with h5py.File(out / "results.h5.partial", "r+") as h:
        h.copy(h[LINE], "lines/exact/0001-up")
    _refused(capsys, monkeypatch, case, out, "lines/exact/0001-up", "digest")


def test_an_untampered_checkpoint_resumes_with_its_digest(stored, tmp_path, monkeypatch, capsys):
    """The digest written by the checkpoint is the one read back: the resume computes only the 2
    lines missing, and the file equals an uninterrupted run's (but wall times)."""
    case, out = _copy(stored, tmp_path)
    with h5py.File(out / "results.h5.partial", "r") as h:
        assert all(DIGEST_ATTR in g.attrs for g in h["lines/exact"].values())
    real = sweep.run_lines
    calls = []

    def counted(lines, **kw):
        calls.extend(lines)
        return real(lines, **kw)

    monkeypatch.setattr(sweep, "run_lines", counted)
    assert main(["map", str(case), "--out", str(out), "--resume", *QUIET]) == 0
    assert len(calls) == 2
    assert main(["map", str(case), "--out", str(tmp_path / "whole"), *QUIET]) == 0
    assert _maps(out / "results.h5", wall=False) == _maps(tmp_path / "whole" / "results.h5", wall=False)


def _maps(h5, wall=True) -> dict:
    """Every dataset of /maps as (type, shape, bytes) or text (``wall``: with the wall times)."""
    out = {}
    with h5py.File(h5, "r") as f:
        def visit(name, obj):
            if isinstance(obj, h5py.Dataset) and (wall or "wall_time" not in name):
                v = obj[()]
                out[name] = (v.dtype.str, v.shape, v.tobytes()) if isinstance(v, np.ndarray) and v.dtype != object \
                    else repr(obj.asstr()[()] if getattr(v, "dtype", None) == object else v)
        f["maps"].visititems(visit)
    return out


# ----------------------------------------------------------------------------- uncertainty samples
BAND = {"name": "linear-band", "model": {"fidelity": "sdof", "beta": 0.05, "B": 0.01, "R": 0.8, "Delta": 1.0},
        "sweep": {"Omega": [0.6, 1.4, 5], "transient_periods": 200, "record_periods": 4, "direction": "both"},
        "run": [{"name": "exact", "method": "event"}],
        "uncertainty": {"samples": 16, "seed": 3,
                        "parameter": [{"name": "B", "distribution": "uniform", "bounds": [0.005, 0.015]}]}}


@pytest.fixture(scope="module")
def sampled(tmp_path_factory):
    """A folder with a real checkpoint of ``vibeam uncertainty``: 3 finished samples, one block each."""
    from vibeam.api.cases import case_text

    d = tmp_path_factory.mktemp("samples")
    (d / "band.toml").write_text(case_text(vibeam.load_case(copy.deepcopy(BAND))))
    with pytest.MonkeyPatch.context() as mp:
        _interrupt_after(mp, 3)
        with pytest.raises(KeyboardInterrupt):
            vibeam.uncertainty(str(d / "band.toml"), out=d / "D", jobs=1, quiet=True, checkpoint_interval_s=0.0)
    with h5py.File(d / "D" / "results.h5.partial", "r") as f:
        assert len(f["uncertainty_samples/exact"]) == 3
    return d


def _block(h, i):
    return h["uncertainty_samples/exact"][sorted(h["uncertainty_samples/exact"])[i]]


def _amp(value, where=(0, 0, 0)):
    def f(h):
        g = _block(h, 0)
        a = g["amplitude"][()]
        a[where] = value
        g["amplitude"][...] = a
    return f


def _dup(h):
    """Sample 0's row written into the second block as well, with an amplitude of 123 (the issue)."""
    a, b = _block(h, 0), _block(h, 1)
    rows = {k: np.concatenate([b[k][()], a[k][()][:1]]) for k in ("sample", "amplitude", "period", "status")}
    rows["amplitude"][-1] = 123.0
    for k, v in rows.items():
        _replace(b, k, v.astype(object) if k == "status" else v)


SAMPLES = {
    "nan amplitude at an ok point": (_amp(np.nan), "amplitude is nan"),
    "amplitude -1e300": (_amp(-1e300), "amplitude"),
    "inf amplitude": (_amp(np.inf, (0, 1, 2)), "amplitude is infinite"),
    "period -7": (lambda h: _block(h, 0)["period"].__setitem__((0, 0, 1), -7), "period"),
    "Omega x 10": (lambda h: _replace(_block(h, 0), "Omega", 10 * np.linspace(0.6, 1.4, 5)), "Omega"),
    "a sample in two blocks": (_dup, "sample"),
}


@pytest.mark.parametrize("digest", ["kept", "removed"])
@pytest.mark.parametrize("tamper", list(SAMPLES))
def test_uncertainty_resume_refuses_samples_vibeam_never_writes(sampled, tmp_path, tamper, digest):
    """Each was taken on main into the quantiles (a duplicated sample's 123 replaced the real
    value); now one line naming the checkpoint, nothing written."""
    shutil.copy(sampled / "band.toml", tmp_path / "band.toml")
    shutil.copytree(sampled / "D", tmp_path / "D")
    out = tmp_path / "D"
    f, word = SAMPLES[tamper]
    with h5py.File(out / "results.h5.partial", "r+") as h:
        f(h)
        if digest == "removed":
            for g in h["uncertainty_samples/exact"].values():
                g.attrs.pop(DIGEST_ATTR, None)
    before = _snapshot(out)
    with pytest.raises(InputError) as e:
        vibeam.uncertainty(str(tmp_path / "band.toml"), out=out, jobs=1, quiet=True, resume=True)
    msg = str(e.value)
    assert "\n" not in msg and "results.h5.partial" in msg, msg
    assert (word if digest == "removed" else "uncertainty_samples/exact") in msg, msg
    assert _snapshot(out) == before


# ----------------------------------------------------------------------------- basin rows
BASINS = """
name = "scene"
description = "basins"
[model]
fidelity = "sdof"
beta = 0.015
B = 0.5e-3
R = 0.9
Delta = 0.7e-3
[sweep]
Omega = [1.5, 2.5, 3]
transient_periods = 100
record_periods = 16
[basins]
Omega = 2.0
grid = [4, 3]
lyapunov_periods = 0
record_periods = 8
[[run]]
name = "exact"
method = "event"
"""


def _labels(g, value):
    a = g["labels"][()]
    a[0] = value
    g["labels"][...] = a


ROWS = {"a label without its set": (lambda g: _labels(g, 57), "set_index"),
        "a label code vibeam never gives": (lambda g: _labels(g, -9), "labels"),
        "a set of another process": (lambda g: g["set_pid"].__setitem__(0, g["pid"][()] + 1), "set_pid"),
        "a negative wall time": (lambda g: g["wall_time_s"].__setitem__((), -1.0), "wall_time_s")}


@pytest.mark.parametrize("tamper", list(ROWS))
def test_basins_resume_refuses_rows_vibeam_never_writes(tmp_path, monkeypatch, capsys, tamper):
    """A label pointing at no stored set was a KeyError traceback after the other rows were
    computed; the others were taken as they were.  Now one line before computing."""
    from vibeam.analysis.attractors import BasinLine

    case = tmp_path / "scene.toml"
    case.write_text(BASINS)
    out = tmp_path / "D"
    real, calls = BasinLine.compute, []

    def interrupted(self):
        calls.append(self.key)
        if len(calls) > 2:
            raise KeyboardInterrupt
        return real(self)

    monkeypatch.setattr(BasinLine, "compute", interrupted)
    assert main(["basins", str(case), "--out", str(out), *QUIET]) == 130
    monkeypatch.setattr(BasinLine, "compute", real)
    f, word = ROWS[tamper]
    with h5py.File(out / "results.h5.partial", "r+") as h:
        rows = h["basin_lines/exact"]
        g = next(g for g in rows.values() if g["set_length"].shape[0])   # a row that found an attractor
        f(g)
        del g.attrs[DIGEST_ATTR]
    _refused(capsys, monkeypatch, case, out, "basin_lines/exact", word, command="basins")


# ----------------------------------------------------------------------------- the properties
def _datasets(h5) -> dict:
    with h5py.File(h5, "r") as f:
        g = f[LINE]
        from vibeam.io.netcdf import is_dim_only

        return {k: (d.shape, d.dtype) for k, d in g.items() if isinstance(d, h5py.Dataset) and not is_dim_only(d)}


@pytest.fixture(scope="module")
def baseline(stored, tmp_path_factory):
    """The untampered resume's /maps (recomputed points with wall time 0: :func:`_resume`)."""
    d = tmp_path_factory.mktemp("baseline")
    shutil.copytree(stored / "D", d / "D")
    with pytest.MonkeyPatch.context() as mp:
        rc, _ = _resume(mp, stored / "smap.toml", d / "D")
    assert rc == 0
    return _maps(d / "D" / "results.h5"), _datasets(stored / "D" / "results.h5.partial")


def _resume(mp, case, out):
    """``vibeam map --resume`` with the wall time of every recomputed point 0 (a clock that stands
    still in the sweep engine), so that two resumes give equal files; (exit code, stderr lines)."""
    import io
    import contextlib
    import time

    mp.setattr(sweep, "time", types.SimpleNamespace(perf_counter=lambda: 0.0, time=time.time, sleep=time.sleep))
    err = io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
        rc = main(["map", str(case), "--out", str(out), "--resume", *QUIET])
    return rc, [l for l in err.getvalue().splitlines() if l.strip() and not l.startswith("[")]


def _check(stored, baseline, tmp, tamper, digest: bool):
    """Tamper a copy of the checkpoint, resume: refused in one line, or the untampered results."""
    shutil.rmtree(tmp, ignore_errors=True)
    tmp.mkdir(parents=True)
    case, out = _copy(stored, tmp)
    with h5py.File(out / "results.h5.partial", "r+") as h:
        tamper(h)
        if not digest:
            for g in h["lines/exact"].values():
                g.attrs.pop(DIGEST_ATTR, None)
    before = _snapshot(out)
    with pytest.MonkeyPatch.context() as mp:
        rc, err = _resume(mp, case, out)
    if rc == 2:
        assert len(err) == 1 and err[0].startswith("vibeam: error: --resume: ") and "Traceback" not in err[0], err
        assert _snapshot(out) == before
        return "refused"
    assert rc == 0, err
    assert _maps(out / "results.h5") == baseline[0]
    return "equal"


def _values(dtype, shape):
    """Values of a dataset's type and shape: any numbers (or texts) at all."""
    kind = np.dtype(dtype).kind
    if kind == "f":
        el = st.floats(allow_nan=True, allow_infinity=True, width=64)
    elif kind in "iu":
        el = st.integers(-2 ** 63, 2 ** 63 - 1)
    elif kind == "b":
        el = st.booleans()
    else:
        el = st.text(st.characters(blacklist_categories=("Cs",), blacklist_characters="\x00"), max_size=50)
    n = int(np.prod(shape))
    return st.tuples(st.integers(0, n - 1), el)


def _line_tampers(names: dict):
    """A tampering of the stored line :data:`LINE`: (description, function of the open file)."""
    name = st.sampled_from(sorted(names))

    def value(k):
        return _values(names[k][1], names[k][0]).map(lambda iv, k=k: (f"{k}[{iv[0]}] = {iv[1]!r}", _flat(k, *iv)))

    def retype(k, dt):
        return (f"{k} as {dt}", lambda h: _cast(h[LINE], k, dt))

    def reshape(k, sh):
        return (f"{k} of shape {sh}", lambda h: _replace(h[LINE], k, np.resize(_read(h[LINE], k), sh)))

    def dup(a, b):
        return (f"{a} copied over {b}", lambda h: _replace(h[LINE], b, _read(h[LINE], a)))

    shapes = name.flatmap(lambda k: st.sampled_from([
        (names[k][0][0] + 1,) + names[k][0][1:], (names[k][0][0] - 1,) + names[k][0][1:], names[k][0] + (2,),
        names[k][0][:1] + (3,) * (len(names[k][0]) - 1) if len(names[k][0]) > 1 else (names[k][0][0], 3)]
    ).map(lambda sh, k=k: reshape(k, sh)))
    types_ = st.tuples(name, st.sampled_from(["float32", "float16", "int32", "int64", "complex128", "text", "bool"])
                       ).map(lambda kd: retype(*kd))
    same = [(a, b) for a in names for b in names if a != b and names[a][0] == names[b][0]]
    dups = st.sampled_from(same).map(lambda ab: dup(*ab))
    group = st.just(("the line copied under 0001-up", lambda h: h.copy(h[LINE], "lines/exact/0001-up")))
    return st.one_of(name.flatmap(value), shapes, types_, dups, group)


def _read(g, k):
    return g[k].asstr()[()].astype(object) if h5py.check_string_dtype(g[k].dtype) else g[k][()]


def _flat(k, i, v):
    def f(h):
        a = _read(h[LINE], k).copy()
        a.reshape(-1)[i] = v
        _replace(h[LINE], k, a)
    return f


def _cast(g, k, dt):
    a = _read(g, k)
    if dt == "text":
        _replace(g, k, np.array([str(x) for x in a.ravel()], dtype=object).reshape(a.shape))
        return
    try:
        with np.errstate(all="ignore"):
            b = np.asarray(a).astype(dt)
    except (ValueError, TypeError):
        b = np.zeros(a.shape, dt)
    _replace(g, k, b)


#: values vibeam never writes at the stored points (every point is ok: one settled record of a
#: time-domain method, with impacts), by the rule of vibeam.engine.sweep.check_line that refuses it
NAN, INF = float("nan"), float("inf")
HOSTILE = {
    "Omega": [NAN, 5.0, -1.0],                                             # the line's grid
    "amplitude": [NAN, INF, -INF, 1e300, -1e300, -5.0, 5.0, 0.5e-3],        # finite, bounded, Delta - q_min
    "q_min": [NAN, INF, -1e300, 5.0, -5.0],                                # finite, below q_max, Delta - amplitude
    "q_max": [NAN, INF, 1e300, -5.0],
    "amplitude_mean": [NAN, INF, 1e300, -5.0, 5.0],                        # min <= mean <= max <= amplitude
    "amplitude_min": [NAN, -INF, -5.0, 5.0],
    "amplitude_max": [NAN, INF, -5.0, 5.0],
    "amplitude_std": [INF, -1.0, 5.0],                                     # 0 ... the range of the Q_k
    "amplitude_sem": [INF, -1.0, 5.0],
    "amplitude_sem_dof": [-1, 999999, 2 ** 62],                           # 0 ... record_periods - 1
    "record_periods": [-3, 0, 7, 2 ** 62],                                # record_periods, statistics_periods
    "transient_periods_used": [-1, 20, 2 ** 62],                          # the sweep's transient
    "period": [-5, 9, 2 ** 62],                                           # -1 ... 8
    "impacts_per_period": [NAN, INF, -1.0, 1.03, 1e300],                  # a count over the record
    "impact_velocity": [INF, 1e300],
    "stuck_fraction": [-0.1, 7.0, INF],                                   # a share
    "strobe": [INF, 1e300, 5.0, -5.0],                                    # q within [q_min, q_max]
    "harmonics": [INF, -1.0, 5.0],                                        # 0 ... 2 max |q|
    "energy_per_impact": [INF, -INF], "contact_force_max": [INF], "contact_gap_max": [INF, 1e300],
    "contact_duration": [-1.0, INF], "penetration_max": [-1.0, INF, 1e300],
    "wall_time_s": [NAN, INF, -1.0, 1e300],                               # a time since 1970
    "status": ["bogus", "x" * 5000], "message": ["x" * 5000], "direction": ["down", "bogus"],
}


def _hostile_tampers(names: dict):
    """Without the digest: a value of :data:`HOSTILE` at any point (the stroboscopic ``q`` column),
    a trailing axis added to any dataset, a number stored as a text, complex or a float of fewer
    bits."""
    picks = [(k, v) for k, vs in HOSTILE.items() if k in names for v in vs]

    def value(kv):
        k, v = kv
        n = int(np.prod(names[k][0]))
        idx = st.integers(0, n // 2 - 1).map(lambda i: 2 * i) if k == "strobe" else st.integers(0, n - 1)
        return idx.map(lambda i: (f"{k}[{i}] = {v!r}", _flat(k, i, v)))

    def reshape(k, sh):
        return (f"{k} of shape {sh}", lambda h: _replace(h[LINE], k, np.resize(_read(h[LINE], k), sh)))

    def retype(k, dt):
        return (f"{k} as {dt}", lambda h: _cast(h[LINE], k, dt))

    floats = sorted(k for k, (_, dt) in names.items() if np.dtype(dt).kind == "f" and k in HOSTILE)
    return st.one_of(st.sampled_from(picks).flatmap(value),
                     st.sampled_from(sorted(names)).map(lambda k: reshape(k, names[k][0] + (2,))),
                     st.tuples(st.sampled_from(floats), st.sampled_from(["float32", "float16", "complex128",
                                                                         "text"])).map(lambda kd: retype(*kd)))


@pytest.mark.parametrize("n", [20])
def test_any_tampering_of_a_checkpoint_is_refused_or_changes_nothing(stored, baseline, tmp_path_factory, n):
    """Property (bounded in the default step; the slow step draws many more): with its digest,
    any dataset of a real checkpoint changed in shape, type or values, or overwritten by another's,
    or the line copied under another key: refused in one line, or the results of the untampered
    resume (a value drawn equal to the stored one)."""
    _property(stored, baseline, tmp_path_factory, n, digest=True)


@pytest.mark.parametrize("n", [20])
def test_values_vibeam_never_writes_are_refused_without_a_digest(stored, baseline, tmp_path_factory, n):
    """Property: without the digest (an earlier vibeam's checkpoint), values, trailing axes and
    types vibeam never writes in any dataset: refused in one line, or the untampered results."""
    _property(stored, baseline, tmp_path_factory, n, digest=False)


@pytest.mark.slow
@pytest.mark.parametrize("digest", [True, False])
def test_many_tamperings_are_refused_or_change_nothing(stored, baseline, tmp_path_factory, digest):
    """The two properties above with 150 examples each (about 1-2 min each)."""
    _property(stored, baseline, tmp_path_factory, 150, digest=digest)


def _property(stored, baseline, tmp_path_factory, n, digest):
    tmp = tmp_path_factory.mktemp("tamper")
    names = baseline[1]
    seen = {"refused": 0, "equal": 0}

    @settings(max_examples=n, deadline=None, suppress_health_check=list(HealthCheck))
    @given(_line_tampers(names) if digest else _hostile_tampers(names))
    def prop(t):
        what, tamper = t
        note(what)
        seen[_check(stored, baseline, tmp / "x", tamper, digest)] += 1

    prop()
    print(f"tamperings ({'with' if digest else 'without'} the digest): {seen}")
    assert seen["refused"] > 0, seen
