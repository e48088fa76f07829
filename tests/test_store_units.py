"""The results store (:mod:`vibeam.io.store`) by its invariants, with tiny groups written by hand (no
command, no kernel): a commit keeps every group, marks stale exactly the groups of another case (and
un-marks them when their case comes back), notes each newly stale group once; a checkpoint adds to
``<file>.partial`` and drops its kind once when asked; reading a checkpoint returns only the groups
of the identity asked for, checked first; consumed checkpoints are removed and the file with them
when nothing is left.  Issue 56, section 2: the survivors of cosmic-ray's mutants of the module
against tests/test_store.py's tests, killed here (tests/README.md, "Tool-generated mutants")."""
from __future__ import annotations

import hashlib
import os
import re
import signal

import h5py
import numpy as np
import pytest

from vibeam.errors import InputError
from vibeam.io.netcdf import var
from vibeam.io.store import (CHECKPOINTS, PARTIAL_SUFFIX, RESULTS_NAME, Store, build_file, case_hash, current_units,
                             file_info, signals_deferred, units_of, write_file)


def unit(path, value=1.0):
    """A writer of a group ``path`` holding one dataset ``x`` = ``value``."""
    def fill(f):
        f.require_group(path).create_dataset("x", data=np.array([value]))
    return fill


def state(path):
    """``{unit: (x, stale, case_hash, case_text)}`` of a file."""
    out = {}
    with h5py.File(path, "r") as f:
        for p, g in units_of(f).items():
            a = g.attrs
            out[p] = (float(g["x"][0]) if "x" in g else None, int(np.asarray(a.get("stale", 0)).ravel()[0]),
                      str(a.get("case_hash", "")), str(a.get("case_text", "")))
    return out


def test_case_hash_is_the_first_16_hex_digits_of_sha256():
    assert case_hash('{"a": 1}') == hashlib.sha256(b'{"a": 1}').hexdigest()[:16]
    assert len(case_hash("")) == 16 and case_hash("x") != case_hash("y")


def test_a_commit_keeps_every_group_and_marks_stale_exactly_those_of_another_case(tmp_path):
    notes = []
    s = Store(tmp_path, log=notes.append)
    with pytest.raises(RuntimeError, match="written only inside `with Store"):
        s.commit({"runs/a": unit("runs/a")}, "A", "text A", "json A")
    with s:
        assert not s.exists() and s.info() == {"attrs": {}, "units": {}}
        p = s.commit({"runs/a": unit("runs/a", 1.0), "cost": unit("cost", 2.0)}, "A", "text A", "json A")
        assert p == tmp_path / RESULTS_NAME and s.exists()
        ha, hb = case_hash("json A"), case_hash("json B")
        assert state(p) == {"runs/a": (1.0, 0, ha, ""), "cost": (2.0, 0, ha, "")}
        info = s.info()
        assert info["attrs"]["case_name"] == "A" and info["attrs"]["case_text"] == "text A"
        assert bool(info["attrs"]["complete"]) and info["attrs"]["vibeam_layout"] == 2
        created = info["attrs"]["created"]
        assert sorted(s.current("json A")) == ["cost", "runs/a"] and s.current("json B") == []
        # another case: its group written, the others kept and marked stale with their own case's text
        s.commit({"runs/b": unit("runs/b", 3.0)}, "B", "text B", "json B")
        st = state(p)
        assert st["runs/b"] == (3.0, 0, hb, "") and st["runs/a"] == (1.0, 1, ha, "text A")
        assert st["cost"] == (2.0, 1, ha, "text A")
        assert notes and notes[-1].count("runs/a") == 1 and "2 group(s)" in notes[-1] and "cost" in notes[-1]
        assert sorted(s.stale_noted) == ["cost", "runs/a"]
        with h5py.File(p) as f:
            why = f["runs/a"].attrs["stale_reason"]
            assert f"case_hash {ha}" in why and f"(case_hash {hb})" in why and "case A" in why
            assert f["runs/a"].attrs["case_json"] == "json A" and f.attrs["created"] == created
        assert s.current("json B") == ["runs/b"] and sorted(s.current("json C", aliases=["json A"])) == ["cost", "runs/a"]
        # B again: nothing newly stale, no note
        n = len(notes)
        s.commit({"runs/b": unit("runs/b", 4.0)}, "B", "text B", "json B")
        assert len(notes) == n and state(p)["runs/b"][0] == 4.0 and state(p)["runs/a"][1] == 1
        # back to A (or an alias of it): its groups fresh again, stale marks and copied texts gone
        s.commit({}, "A", "text A2", "json A2", aliases=["json A"])
        st = state(p)
        assert st["runs/a"] == (1.0, 0, ha, "") and st["cost"] == (2.0, 0, ha, "")
        assert st["runs/b"] == (4.0, 1, hb, "text B")
        with h5py.File(p) as f:
            assert "stale_reason" not in f["runs/a"].attrs and "case_json" not in f["runs/a"].attrs
            assert f.attrs["case_text"] == "text A2"
        assert notes[-1].count("runs/b") == 1 and "1 group(s)" in notes[-1]


def test_the_note_names_six_stale_groups_and_counts_the_rest(tmp_path):
    notes = []
    with Store(tmp_path, log=notes.append) as s:
        s.commit({f"runs/r{i}": unit(f"runs/r{i}") for i in range(9)}, "A", "", "A")
        s.commit({"runs/x": unit("runs/x")}, "B", "", "B")
    assert "9 group(s)" in notes[-1] and "runs/r5 and 3 more;" in notes[-1] and "runs/r6" not in notes[-1]
    notes.clear()
    with Store(tmp_path / "six", log=notes.append) as s:
        s.commit({f"runs/r{i}": unit(f"runs/r{i}") for i in range(6)}, "A", "", "A")
        s.commit({"runs/x": unit("runs/x")}, "B", "", "B")
    assert "runs/r5: " in notes[-1] or "runs/r5;" in notes[-1]
    assert "more" not in notes[-1]


def test_an_earlier_vibeams_groups_get_the_files_case(tmp_path):
    """A group without case_hash (an earlier vibeam's file) has the file's case: stale after a commit
    of another case, with that case's text; fresh after a commit of the same case."""
    p = tmp_path / RESULTS_NAME
    with h5py.File(p, "w") as f:
        f.attrs["case_json"] = "json old"
        f.attrs["case_name"] = "old"
        f.attrs["case_text"] = "text old"
        f.create_group("runs/a").create_dataset("x", data=[5.0])
        f.create_group("maps/m").create_dataset("x", data=[6.0])
    info = file_info(p)
    assert {u["case_hash"] for u in info["units"].values()} == {case_hash("json old")}
    assert current_units(p, "json old") == ["maps/m", "runs/a"]
    with Store(tmp_path) as s:
        s.commit({"runs/b": unit("runs/b")}, "new", "text new", "json new")
    st = state(p)
    assert st["runs/a"] == (5.0, 1, case_hash("json old"), "text old") and st["maps/m"][1] == 1
    with h5py.File(p) as f:
        assert f["runs/a"].attrs["case_name"] == "old"
    q = tmp_path / "same"
    q.mkdir()
    with h5py.File(q / RESULTS_NAME, "w") as f:
        f.attrs["case_json"] = "json old"
        f.create_group("runs/a").create_dataset("x", data=[5.0])
    with Store(q) as s:
        s.commit({}, "old", "", "json old")
    assert state(q / RESULTS_NAME)["runs/a"] == (5.0, 0, case_hash("json old"), "")
    # a file without any case: its groups have the hash "" and are stale under any case
    r = tmp_path / "none"
    r.mkdir()
    with h5py.File(r / RESULTS_NAME, "w") as f:
        f.create_group("runs/a").create_dataset("x", data=[5.0])
    assert file_info(r / RESULTS_NAME)["units"]["runs/a"]["case_hash"] == ""
    with Store(r) as s:
        s.commit({}, "x", "", "json x")
    assert state(r / RESULTS_NAME)["runs/a"][:3] == (5.0, 1, "")
    with h5py.File(r / RESULTS_NAME) as f:
        assert "case_hash ?" in f["runs/a"].attrs["stale_reason"] and "(case ?," in f["runs/a"].attrs["stale_reason"]


def test_a_writer_that_writes_no_group_is_refused_and_the_file_kept(tmp_path):
    with Store(tmp_path) as s:
        s.commit({"runs/a": unit("runs/a")}, "A", "", "A")
        before = (tmp_path / RESULTS_NAME).read_bytes()
        with pytest.raises(RuntimeError, match="the writer of runs/b wrote no group runs/b"):
            s.commit({"runs/b": lambda f: None}, "A", "", "A")
        with pytest.raises(RuntimeError, match="would lose"):
            s.commit({"runs/b": lambda f: f.__delitem__("runs/a") or unit("runs/b")(f)}, "A", "", "A")
    assert (tmp_path / RESULTS_NAME).read_bytes() == before


def test_fresh_starts_a_new_file_and_a_new_checkpoint(tmp_path):
    with Store(tmp_path) as s:
        s.commit({"runs/a": unit("runs/a")}, "A", "", "A")
        s.checkpoint("lines", {"k1": ({"x": var(("n",), np.arange(2))}, {"case_hash": "h"})})
    with Store(tmp_path, fresh=True) as s:
        assert not s.exists() and s.info() == {"attrs": {}, "units": {}}
        assert s.read_checkpoint("lines", "case_hash", "h")[1].keys() == {"k1"}     # the checkpoint is read
        s.checkpoint("lines", {"k2": ({"x": var(("n",), np.arange(3))}, {"case_hash": "h"})})
        assert sorted(s.read_checkpoint("lines", "case_hash", "h")[1]) == ["k2"]     # the old one not kept
        s.commit({"runs/b": unit("runs/b")}, "A", "", "A")
        assert not s.fresh and s.exists()
    assert sorted(state(tmp_path / RESULTS_NAME)) == ["runs/b"]


def test_checkpoints_add_up_drop_their_kind_once_and_are_read_by_identity(tmp_path):
    v = {"x": var(("n",), np.arange(3.0))}
    partial = tmp_path / (RESULTS_NAME + PARTIAL_SUFFIX)
    with Store(tmp_path) as s:
        assert s.checkpoint_attrs() == {} and s.read_checkpoint("lines", "case_hash", "h") == ({}, {})
        out = s.checkpoint("lines", {"a": (v, {"case_hash": "h"})}, case_name="C", case_json="J", start=True)
        assert out == partial and s.checkpoint_attrs()["case_name"] == "C"
        assert not bool(s.checkpoint_attrs()["complete"])
        s.checkpoint("lines", {"b": (v, {"case_hash": "h"}), "c": (v, {"case_hash": "other"})}, start=True)
        s.checkpoint("basin_lines/r", {"row0": (v, {"case_hash": "h"})}, start=True)
        attrs, got = s.read_checkpoint("lines", "case_hash", "h")
        assert sorted(got) == ["a", "b"] and np.array_equal(got["a"]["x"], np.arange(3.0))
        assert sorted(s.read_checkpoint("basin_lines/r", "case_hash", "h")[1]) == ["row0"]
        assert s.read_checkpoint("basin_lines/q", "case_hash", "h")[1] == {}
        assert s.read_checkpoint("lines", "case_hash", "nobody") == (attrs, {})
    with Store(tmp_path) as s:                      # the next command, not resuming: the kind starts afresh
        s.checkpoint("lines", {"d": (v, {"case_hash": "h"})}, start=True)
        s.checkpoint("lines", {"e": (v, {"case_hash": "h"})}, start=True)     # once per command and kind
        assert sorted(s.read_checkpoint("lines", "case_hash", "h")[1]) == ["d", "e"]
        assert sorted(s.read_checkpoint("basin_lines/r", "case_hash", "h")[1]) == ["row0"]
        # the commit removes what it consumed; the file goes when nothing is left
        s.commit({"runs/a": unit("runs/a")}, "A", "", "A", done=["lines", "basin_lines/q"])
        with h5py.File(partial) as f:
            assert "lines" not in f and "basin_lines/r" in f
        s.commit({}, "A", "", "A", done=["basin_lines/r"])
        assert not partial.exists()


def _dimids(path):
    out = []
    with h5py.File(path) as f:
        f.visititems(lambda name, obj: out.append((name, int(np.asarray(obj.attrs["_Netcdf4Dimid"]).ravel()[0])))
                     if "_Netcdf4Dimid" in obj.attrs else None)
    return sorted(out)


def test_checkpoints_count_their_dimension_ids_on_instead_of_visiting_the_file(tmp_path, monkeypatch):
    """A checkpoint onto the file the store wrote last starts from the next free netCDF dimension
    id it counted (issue 60: visiting every object of the growing checkpoint for the largest id
    made a 200 x 200 basin grid's flushes O(rows^2), 41 of 95 s of a profiled run): the file is
    visited once, for the first checkpoint, and every group gets the ids of a visit each time
    (exact integers: netCDF needs them unique in the file); a checkpoint file this store did not
    write last (another process's, replaced) is visited again."""
    import vibeam.io.netcdf as netcdf
    import vibeam.io.store as store

    visits = []
    real = netcdf._next_dimid
    monkeypatch.setattr(netcdf, "_next_dimid", lambda f: visits.append(1) or real(f))
    v = {"x": var(("n",), np.arange(3.0)), "y": var(("n", "m"), np.zeros((3, 2)))}

    def fill(folder):
        with Store(folder) as s:
            s.checkpoint("lines", {"a": (v, {"case_hash": "h"})}, start=True)
            for k in "bcd":
                s.checkpoint("lines", {k: (v, {"case_hash": "h"})})
            s.checkpoint("basin_lines/r", {"row0": (v, {"case_hash": "h"})}, start=True)
        return _dimids(folder / (RESULTS_NAME + PARTIAL_SUFFIX))

    counted = fill(tmp_path / "counted")
    assert len(visits) == 1
    visits.clear()
    monkeypatch.setattr(store, "_signature", lambda path: object())      # never the same file: visit each time
    visited = fill(tmp_path / "visited")
    assert len(visits) == 5
    assert counted == visited and len(counted) == 10
    assert len({i for _, i in counted}) == len(counted)                    # unique in the file
    # another writer's file in between: visited again
    monkeypatch.undo()
    monkeypatch.setattr(netcdf, "_next_dimid", lambda f: visits.append(1) or real(f))
    visits.clear()
    folder = tmp_path / "counted"
    with Store(folder) as s:
        s.checkpoint("lines", {"e": (v, {"case_hash": "h"})})
        partial = folder / (RESULTS_NAME + PARTIAL_SUFFIX)
        data = partial.read_bytes()
        partial.unlink()
        partial.write_bytes(data)                # a successor (a new inode) with the same content
        s.checkpoint("lines", {"f": (v, {"case_hash": "h"})})
    assert len(visits) == 2
    ids = [i for _, i in _dimids(partial)]
    assert len(set(ids)) == len(ids) == 14


def test_consumed_checkpoints_are_removed_group_by_group(tmp_path):
    v = {"x": var(("n",), np.arange(3.0))}
    partial = tmp_path / (RESULTS_NAME + PARTIAL_SUFFIX)
    with Store(tmp_path) as s:
        s.checkpoint("basin_lines/r", {"row0": (v, {"case_hash": "h"})})
        s.checkpoint("basin_lines/q", {"row0": (v, {"case_hash": "h"})})
        s.checkpoint("uncertainty_samples/r", {"blk": (v, {"case_hash": "h"})})
        s.commit({}, "A", "", "A", done=["basin_lines/r", "uncertainty_samples"])
        with h5py.File(partial) as f:
            assert sorted(f) == ["basin_lines"] and sorted(f["basin_lines"]) == ["q"]
        s.commit({}, "A", "", "A", done=["basin_lines/q"])
        assert not partial.exists()
        # a consumed group the checkpoint does not hold does not stop the ones after it from going
        s.checkpoint("lines", {"k": (v, {"case_hash": "h"})})
        s.checkpoint("basin_lines/r", {"row0": (v, {"case_hash": "h"})})
        s.commit({}, "A", "", "A", done=["basin_lines/absent", "uncertainty_samples", "lines"])
        with h5py.File(partial) as f:
            assert sorted(f) == ["basin_lines"]
        # an earlier vibeam kept a checkpoint in the file itself: a commit that consumes it removes it
    p = tmp_path / RESULTS_NAME
    with h5py.File(p, "a") as f:
        f.create_group("basin_lines/r").create_group("row0").attrs["case_hash"] = "h"
        f.create_group("basin_lines/q").create_group("row0").attrs["case_hash"] = "h"
        f.create_group("lines/k").attrs["case_hash"] = "h"
    with Store(tmp_path) as s:
        assert sorted(s.read_checkpoint("basin_lines/r", "case_hash", "h")[1]) == ["row0"]
        s.commit({}, "A", "", "A", done=["basin_lines/r", "lines"])
    with h5py.File(p) as f:
        assert "lines" not in f and sorted(f["basin_lines"]) == ["q"]
    with Store(tmp_path) as s:
        s.commit({}, "A", "", "A", done=["basin_lines/q"])
    with h5py.File(p) as f:
        assert "basin_lines" not in f and "runs" not in f or True
        assert "basin_lines" not in f


def test_a_checkpoint_group_is_checked_before_its_values_are_read(tmp_path):
    v = {"x": var(("n",), np.arange(3.0)), "y": var(("n",), np.arange(3))}
    calls = []

    def check(key, meta, data):
        calls.append((key, sorted(meta), None if data is None else sorted(data)))
        assert meta["x"] == ((3,), np.dtype(float))
        return "wrong" if data is not None and key == "bad" else None

    with Store(tmp_path) as s:
        s.checkpoint("lines", {"good": (v, {"case_hash": "h"})})
        assert sorted(s.read_checkpoint("lines", "case_hash", "h", check)[1]) == ["good"]
        assert calls == [("good", ["x", "y"], None), ("good", ["x", "y"], ["x", "y"])]
        s.checkpoint("lines", {"bad": (v, {"case_hash": "h"})})
        with pytest.raises(InputError) as e:
            s.read_checkpoint("lines", "case_hash", "h", check)
        msg = str(e.value)
        assert "\n" not in msg and msg.startswith("--resume: ") and "/lines/bad: wrong; this vibeam never writes that" in msg
        assert RESULTS_NAME + PARTIAL_SUFFIX in msg
        with pytest.raises(InputError, match="/lines/bad: shapes only"):
            s.read_checkpoint("lines", "case_hash", "h", lambda k, m, d: "shapes only" if k == "bad" else None)


def test_links_are_not_units(tmp_path):
    """Soft links to groups are left out of a file's units (the structure check refuses such files
    before the store opens them; this is the second guard)."""
    with h5py.File(tmp_path / "l.h5", "w") as f:
        f.create_group("runs/r").attrs["case_hash"] = "h"
        f["runs"]["l"] = h5py.SoftLink("/runs/r")
        f["top"] = h5py.SoftLink("/runs")
        f["dangling"] = h5py.SoftLink("/nowhere")
        f["runs"]["dangling"] = h5py.SoftLink("/nowhere")
        assert sorted(units_of(f)) == ["runs/r"]


def test_units_of_a_file_are_its_groups_and_the_children_of_the_unit_parents(tmp_path):
    p = tmp_path / "f.h5"
    with h5py.File(p, "w") as f:
        for g in ("runs/a", "runs/b", "maps/m", "branches/c", "basins/d", "uncertainty/u", "cost", "fit"):
            f.create_group(g)
        f.create_group("runs/a/inner")
        for c in CHECKPOINTS:
            f.create_group(f"{c}/x")
        f.create_dataset("plain", data=[1])
        f["runs"].create_dataset("table", data=[1])
        assert sorted(units_of(f)) == ["basins/d", "branches/c", "cost", "fit", "maps/m", "runs/a", "runs/b",
                                       "uncertainty/u"]


def test_build_file_writes_a_whole_file_or_leaves_the_old_one(tmp_path):
    p = tmp_path / "sub" / "x.h5"
    assert build_file(p, lambda f: f.create_group("a")) == p
    with h5py.File(p) as f:
        assert list(f) == ["a"]
    before = p.read_bytes()
    with pytest.raises(ZeroDivisionError):
        build_file(p, lambda f: 1 / 0, base=p)
    assert p.read_bytes() == before
    out = build_file(tmp_path / "y.h5", lambda f: f.create_group("b"), base=p)      # from the old one's bytes
    with h5py.File(out) as f:
        assert sorted(f) == ["a", "b"]
    assert p.read_bytes() == before
    junk = tmp_path / "junk.h5"
    junk.write_bytes(b"not hdf5 at all" * 10)
    with pytest.raises(InputError) as e:
        build_file(tmp_path / "z.h5", lambda f: None, base=junk)
    assert "not an HDF5 file vibeam can keep" in str(e.value) and "\n" not in str(e.value) and "--fresh" in str(e.value)
    # the reason is HDF5's message without its parenthesised detail ("Unable to [synchronously ]open file
    # (file signature not found)"): the text before the first "("
    assert re.search(r"can keep \(Unable to [a-z ]*open file\); move it away", str(e.value)), str(e.value)

    def fails(f):
        raise OSError(28, "No space left on device")

    with pytest.raises(OSError) as e:
        build_file(p, fails, base=p)
    assert e.value.filename == str(p) and e.value.errno == 28 and e.value.strerror == "No space left on device"

    def fails_named(f):
        raise OSError(5, "I/O error", str(p))

    with pytest.raises(OSError) as e:
        build_file(p, fails_named)
    assert e.value.filename == str(p)

    class DiskFull(OSError):
        pass

    err = DiskFull(28, "No space left on device", str(p))    # names the file already: passed on as it is
    with pytest.raises(DiskFull) as e:
        build_file(p, lambda f: (_ for _ in ()).throw(err))
    assert e.value is err and e.value.__cause__ is None

    def fails_bare(f):
        raise OSError("h5py says: unable to write\nsecond line")

    with pytest.raises(OSError) as e:
        build_file(p, fails_bare)
    assert e.value.filename == str(p) and e.value.strerror == "h5py says: unable to write"
    with pytest.raises(BrokenPipeError) as e:
        build_file(p, lambda f: (_ for _ in ()).throw(BrokenPipeError(32, "pipe")))
    assert e.value.filename is None
    assert p.read_bytes() == before


def test_signals_are_held_back_while_a_file_is_written_and_delivered_after():
    """(Sent to the main thread: a signal sent to the process is taken by any thread that does not
    block it, e.g. a BLAS worker's, and its handler then runs in the main thread between two
    bytecodes; the file is still safe, being replaced whole.)"""
    import threading

    got = []
    old = signal.signal(signal.SIGTERM, lambda *a: got.append("term"))
    try:
        with signals_deferred():
            signal.pthread_kill(threading.main_thread().ident, signal.SIGTERM)
            assert got == []
            assert signal.SIGTERM in signal.pthread_sigmask(signal.SIG_BLOCK, [])
        assert got == ["term"] and signal.SIGTERM not in signal.pthread_sigmask(signal.SIG_BLOCK, [])
    finally:
        signal.signal(signal.SIGTERM, old)


def test_a_store_refuses_an_input_that_is_its_own_file_and_files_it_cannot_keep(tmp_path):
    with Store(tmp_path) as s:
        s.commit({"runs/a": unit("runs/a")}, "A", "", "A")
    with pytest.raises(InputError) as e:
        Store(tmp_path, inputs=[(tmp_path / RESULTS_NAME, "--reference")]).__enter__()
    msg = str(e.value)
    assert msg.startswith(f"--reference {tmp_path / RESULTS_NAME}: is the file this command writes") and "\n" not in msg
    with pytest.raises(InputError, match="is the file this command writes"):
        Store(tmp_path, inputs=[(tmp_path / RESULTS_NAME, "")]).__enter__()
    with Store(tmp_path, inputs=[(tmp_path / "other.h5", "--reference"), (None, "--x")]) as s:      # not ours: fine
        assert s.exists()
    with Store(tmp_path) as s, s:                   # a step of the command that holds it already
        assert s._depth == 1
    (tmp_path / RESULTS_NAME).write_bytes(b"garbage" * 100)
    with pytest.raises(InputError) as e:
        Store(tmp_path).__enter__()
    assert "results.h5 is kept as it is: move it away, use another --out, or --fresh to replace it" in str(e.value)
    # a folder the lock refuses (a file): the inputs noted for the command are released with it
    from vibeam.io.outdir import read_by_command
    ref, not_a_folder = tmp_path / "ref.h5", tmp_path / "a-file"
    ref.write_bytes(b"x")
    not_a_folder.write_text("")
    with pytest.raises(InputError, match="is a file, not a folder"):
        Store(not_a_folder, inputs=[(ref, "--reference")]).__enter__()
    assert read_by_command(ref) is None
    with Store(tmp_path, fresh=True) as s:           # --fresh replaces it
        s.commit({"runs/a": unit("runs/a")}, "A", "", "A")
    assert sorted(state(tmp_path / RESULTS_NAME)) == ["runs/a"]


def test_write_file_gives_each_group_the_case(tmp_path):
    p = write_file(tmp_path / "w.h5", {"runs/a": unit("runs/a"), "/cost/": unit("cost")}, case_name="n",
                   case_json="J")
    info = file_info(p)
    assert info["attrs"]["case_name"] == "n" and bool(info["attrs"]["complete"])
    assert {k: u["case_hash"] for k, u in info["units"].items()} == {"runs/a": case_hash("J"), "cost": case_hash("J")}
    assert {u["case_name"] for u in info["units"].values()} == {"n"}


def test_the_hold_of_a_store_and_its_notes_on_stderr(tmp_path, capsys):
    s = Store(tmp_path)
    with s:
        with s:                                     # a step of the command: the hold is shared
            s.commit({"/runs/a/": unit("runs/a")}, "A", "", "A")
        s.commit({"runs/b": unit("runs/b")}, "B", "", "B")          # still held after the inner exit
    assert "vibeam: note: " in capsys.readouterr().err
    with pytest.raises(RuntimeError, match="written only inside"):
        s.commit({}, "A", "", "A")                  # after the outer exit: not held
    with pytest.raises(RuntimeError, match="written only inside"):
        s.checkpoint("lines", {})
    # a refused entry releases the folder's lock: the next store enters
    with pytest.raises(InputError):
        Store(tmp_path, inputs=[(tmp_path / RESULTS_NAME, "--reference")]).__enter__()
    with Store(tmp_path) as t:
        assert t.exists() and sorted(t.info()["units"]) == ["runs/a", "runs/b"]
    with h5py.File(tmp_path / RESULTS_NAME) as f:
        assert f.attrs["Conventions"] == "CF-1.10" and "vibeam_version" in f.attrs and "modified" in f.attrs


def test_text_attributes_of_an_earlier_vibeam_as_bytes_or_one_element_arrays(tmp_path):
    p = tmp_path / RESULTS_NAME
    with h5py.File(p, "w") as f:
        f.attrs["case_json"] = np.bytes_(b"json old")
        f.attrs["case_name"] = np.array([b"old"])
        f.attrs["case_text"] = np.array(["text old"], dtype=h5py.string_dtype())
        f.attrs["created"] = np.bytes_(b"2020-01-01")
        f.create_group("runs/a").create_dataset("x", data=[5.0])
    assert file_info(p)["units"]["runs/a"]["case_hash"] == case_hash("json old")
    with Store(tmp_path) as s:
        s.commit({"runs/b": unit("runs/b")}, "new", "", "json new")
    with h5py.File(p) as f:
        a = f["runs/a"].attrs
        assert a["case_name"] == "old" and a["case_text"] == "text old" and a["case_json"] == "json old"
        assert int(a["stale"]) == 1 and f.attrs["created"] == "2020-01-01"


def test_a_damaged_checkpoint_is_left_for_a_later_resume_to_judge(tmp_path):
    v = {"x": var(("n",), np.arange(3.0))}
    with Store(tmp_path) as s:
        s.checkpoint("lines", {"a": (v, {"case_hash": "h"})})
    partial = tmp_path / (RESULTS_NAME + PARTIAL_SUFFIX)
    partial.write_bytes(b"damaged" * 50)
    with Store(tmp_path, fresh=True) as s:           # (not kept: --fresh)
        s.commit({"runs/a": unit("runs/a")}, "A", "", "A", done=["lines"])
    assert partial.read_bytes() == b"damaged" * 50


def test_signals_are_not_touched_off_the_main_thread():
    import threading

    out = []

    def body():
        with signals_deferred():
            out.append(signal.pthread_sigmask(signal.SIG_BLOCK, []))

    t = threading.Thread(target=body)
    t.start()
    t.join()
    assert out and signal.SIGTERM not in out[0] and signal.SIGINT not in out[0]


def test_a_checkpoint_dataset_hdf5_cannot_read_is_refused_in_one_line(tmp_path):
    """A dataset the structure check accepts but HDF5 cannot read (chunks of a compression filter this
    machine lacks): one line naming the group and HDF5's reason, cut at 80 characters."""
    from vibeam.errors import one_line

    partial = tmp_path / (RESULTS_NAME + PARTIAL_SUFFIX)
    with h5py.File(partial, "w") as f:
        g = f.create_group("lines/k")
        g.attrs["case_hash"] = "h"
        ds = g.create_dataset("x", shape=(4,), dtype="f8", chunks=(4,), compression=32001, allow_unknown_filter=True)
        ds.id.write_direct_chunk((0,), b"bytes no filter wrote")
    with h5py.File(partial) as f:
        with pytest.raises(OSError) as hdf5:
            f["lines/k/x"][()]
    reason = one_line(str(hdf5.value))[:80]
    with Store(tmp_path) as s:
        with pytest.raises(InputError) as e:
            s.read_checkpoint("lines", "case_hash", "h")
    msg = str(e.value)
    assert "\n" not in msg and f"/lines/k: cannot be read ({reason}); this vibeam never writes that" in msg


class _Unreadable:
    """A file (the part :func:`units_of` reads) with one top-level name that h5py cannot resolve:
    its link (``stage = "link"``) or, behind a hard link, its object raises ``exc``."""

    def __init__(self, exc, stage):
        self.exc, self.stage = exc, stage

    def keys(self):
        return ["broken"]

    def get(self, name, getlink=False):
        if self.stage == "link":
            raise self.exc(f"cannot read the link of {name}")
        return h5py.HardLink()

    def __getitem__(self, name):
        raise self.exc(f"cannot read the object {name}")


@pytest.mark.parametrize("stage, exc", [("link", KeyError), ("link", OSError), ("link", RuntimeError),
                                        ("object", KeyError), ("object", OSError), ("object", RuntimeError),
                                        ("object", ValueError)])
def test_a_name_whose_link_or_object_h5py_cannot_read_is_not_a_unit(stage, exc):
    """A top-level name whose link or object h5py cannot resolve (each error h5py raises for a
    damaged or foreign file) is skipped by ``units_of``, not a traceback: the file's other units
    are still read (the seven mutants of ``_hard``'s two handlers that no real file reached)."""
    assert units_of(_Unreadable(exc, stage)) == {}
