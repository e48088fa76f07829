"""The results store: the only code that writes a results file (``results.h5``, and the
``fit.h5``, ``cost.h5``, ... of other commands) and its checkpoint.

Every command that writes results (``run``, ``map``, ``continue``, ``basins``, ``regress
--out``, ``fit``, ``cost``) opens a :class:`Store` on its output folder and keeps it for the
whole command, computation included:

1. **One writer at a time.**  Entering the store takes the folder's lock
   (:class:`vibeam.io.outdir.OutputLock`); a second process is refused in one line.  Steps of
   one command share the hold (a run, then its ``[basins]``).
2. **A complete successor, every group kept.**  :meth:`Store.commit` builds the new file from
   the old one's bytes in memory, replaces only the groups the command computed, copies what
   is live into a fresh image (:func:`live_image`: the replaced groups' space is not carried
   over, so reruns do not grow the file) and hands it to
   :func:`vibeam.io.outdir.replace_file` (write beside, ``fsync``, rename, ``fsync`` the
   folder).  Every group the file had is still there: the successor is checked for that
   before the rename.  An interrupt, a full disk or a crash leaves the old file byte for byte,
   and a signal the command recorded stops the commit before the rename.
3. **Stale, never dropped.**  Each group (a *unit*: ``runs/<run>``, ``maps/<run>``,
   ``branches/<run>``, ``basins/<run>``, or a top-level table such as ``cost``) carries the
   ``case_hash`` of the case it was computed from.  A unit computed from another case than
   the file's current one keeps its data and is marked ``stale = 1`` with ``stale_reason``
   and the text of its own case (``case_name``, ``case_text``, ``case_json``); the command
   prints one line naming such units.  ``fresh=True`` (``--fresh``) starts a new file.
4. **Checkpoints beside the file.**  Finished work of a running command (sweep lines,
   basin rows, sampled sweeps) goes to ``<file>.partial`` (:meth:`Store.checkpoint`), never into the
   complete file; the command's commit removes what it consumed.  ``--resume`` reads a
   checkpoint through :meth:`Store.read_checkpoint`, which refuses links, sizes beyond the
   bounds of :mod:`vibeam.io.h5check`, -- through the caller's check -- any dataset whose
   shape, type or values this vibeam would not have written, and a group whose contents differ
   from what was written there (:func:`checkpoint_digest`).
5. **Only regular files.**  The file, its checkpoint and every other output name the command
   will write (``outputs``, checked on entering, before anything is computed) must be a
   regular file or a new name (:func:`vibeam.io.outdir.check_output_file`); a command never
   writes into a file it reads (``inputs``, and the files the command line names:
   :func:`vibeam.io.outdir.reading`), under any name.

Layout of the files: :mod:`vibeam.io.results`.
"""
from __future__ import annotations

import contextlib
import hashlib
import io
import os
import signal
import sys
import threading
from datetime import datetime, timezone
from pathlib import Path

import h5py
import numpy as np

from vibeam.errors import InputError, one_line, stop_if_signalled
from vibeam.io.h5check import check_tree, file_size_ok, open_checked
from vibeam.io.netcdf import DimIds, is_dim_only, read_attrs, read_plain, set_attrs, write_group
from vibeam.io.outdir import OutputLock, check_output_file, check_outputs, holds_lock, reading, replace_file
from vibeam.version import __version__

RESULTS_NAME = "results.h5"
PARTIAL_SUFFIX = ".partial"
"""The checkpoint of a file ``F`` is ``F.partial`` (``results.h5.partial``)."""
LAYOUT_VERSION = 2
#: top-level groups whose children are the units of a file (``runs/<run>``, ...)
UNIT_PARENTS = ("runs", "maps", "branches", "basins", "uncertainty")
#: checkpoint groups (in ``<file>.partial``; in the file itself only as an earlier vibeam wrote them):
#: sweep lines, basin rows, finished samples of ``vibeam uncertainty``
CHECKPOINTS = ("lines", "basin_lines", "uncertainty_samples")
#: root attributes the store sets (not units' data)
_ROOT_KEYS = ("Conventions", "vibeam_version", "vibeam_layout", "case_name", "case_text", "case_json",
              "created", "modified", "complete")


def case_hash(case_json: str) -> str:
    """Identity of a case as run (its validated JSON): SHA-256, 16 hex digits.

    Every unit of a results file and every checkpointed line carries it (attribute
    ``case_hash``), so a resume keeps only lines computed for the same case and variant, and
    a unit of another case is marked stale."""
    return hashlib.sha256(str(case_json).encode()).hexdigest()[:16]


#: the attribute of a checkpointed group holding :func:`checkpoint_digest` of its contents
DIGEST_ATTR = "vibeam_digest"
#: attributes left out of the digest: HDF5 object references (dimension scales), which name
#: objects by their address in the file, not by their contents
_UNDIGESTED = ("DIMENSION_LIST", "REFERENCE_LIST", DIGEST_ATTR)


def _digest_value(h, v) -> None:
    """Feed one dataset's or attribute's value to the hash ``h``: its type, shape and bytes (texts
    element by element, each with its length, so that no two arrays of texts share a digest)."""
    a = np.asarray(v)
    h.update(f"{a.dtype.kind}{a.dtype.itemsize}{a.shape}".encode())
    if a.dtype.kind == "O":
        for x in a.ravel():
            b = x if isinstance(x, bytes) else str(x).encode("utf-8", "surrogatepass")
            h.update(len(b).to_bytes(8, "little") + b)
    else:
        h.update(np.ascontiguousarray(a).tobytes())


def checkpoint_digest(group, path: str) -> str:
    """SHA-256 of a checkpointed group as it is stored: its path in the file (``lines/<run>/<key>``),
    its attributes (but :data:`DIGEST_ATTR` and object references), and every object below it --
    name, attributes, and for a dataset its type, shape and bytes -- in the order of their names.

    :meth:`Store.checkpoint` keeps it in the group's attribute :data:`DIGEST_ATTR`;
    :meth:`Store.read_checkpoint` refuses a group whose contents no longer give it: a value, type
    or shape changed after vibeam wrote it, a group copied under another key, a sample's rows
    copied into another block.  It guards against a careless edit or a damaged copy, not against
    someone who recomputes it: the values are checked on their own as well (the caller's check).
    A group without the attribute (an earlier vibeam's) is judged by those checks alone."""
    h = hashlib.sha256(str(path).strip("/").encode())

    def attrs(obj):
        for k in sorted(obj.attrs.keys()):
            if k not in _UNDIGESTED:
                h.update(b"\x00@" + k.encode())
                _digest_value(h, obj.attrs[k])

    attrs(group)
    objs = []
    group.visititems(lambda name, obj: objs.append((name, obj)) and None)
    for name, obj in sorted(objs, key=lambda x: x[0]):
        h.update(b"\x00/" + name.encode())
        attrs(obj)
        if isinstance(obj, h5py.Dataset):
            _digest_value(h, obj[()])
    return h.hexdigest()


@contextlib.contextmanager
def signals_deferred():
    """Hold SIGINT/SIGTERM back while a file is written (delivered right after), so Ctrl-C
    never interrupts HDF5 in the middle of a call; a no-op off the main thread or on Windows."""
    if not hasattr(signal, "pthread_sigmask") or threading.current_thread() is not threading.main_thread():
        yield
        return
    sigs = {signal.SIGINT, signal.SIGTERM}
    old = signal.pthread_sigmask(signal.SIG_BLOCK, sigs)
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, old)


def live_image(f) -> io.BytesIO:
    """A new in-memory HDF5 file holding what the open file ``f`` holds, and nothing else: the
    space of objects deleted from ``f`` (a replaced group) is not carried over, as ``h5repack``
    does (HDF5 never reuses the space a file freed in an earlier session, so a successor built
    on the old file's bytes grew with every rerun: issue 57, 181,796 -> 541,100 bytes after
    five reruns of a quick map).

    The root group is copied in one :meth:`h5py.Group.copy` (shared objects stay shared, links
    stay links), its attributes as they are (type and shape).  ``H5Ocopy`` does not carry the
    object references in attributes over, so the netCDF dimension scales (``DIMENSION_LIST``,
    ``REFERENCE_LIST``) are attached again, each variable's scales in their order.

    Returns
    -------
    io.BytesIO
        The image of the new file (closed).
    """
    out = io.BytesIO()
    attached = []                      # (variable path, [[scale path, ...] per axis])

    def note(name, obj):
        if isinstance(obj, h5py.Dataset) and "DIMENSION_LIST" in obj.attrs:
            attached.append((obj.name, [[sc.name for sc in dim.values()] for dim in obj.dims]))

    f.visititems(note)
    with h5py.File(out, "w") as g:
        if len(f):
            f.copy(f["/"], g, "vibeam-live-root")
            for k in list(g["vibeam-live-root"].keys()):
                g.move(f"vibeam-live-root/{k}", k)
            del g["vibeam-live-root"]
        for k in f.attrs:
            aid = f.attrs.get_id(k)
            g.attrs.create(k, f.attrs[k], shape=aid.shape, dtype=aid.dtype)

        def unlink(name, obj):         # the copied references point into the old file
            for a in ("DIMENSION_LIST", "REFERENCE_LIST"):
                if a in obj.attrs:
                    del obj.attrs[a]

        g.visititems(unlink)
        for path, dims in attached:
            ds = g[path]
            for i, scales in enumerate(dims):
                for sc in scales:
                    ds.dims[i].attach_scale(g[sc])
    return out


def _signature(path: Path) -> tuple:
    """What tells a file apart from its successors: inode, size and modification time (ns)."""
    st = os.stat(path)
    return (st.st_ino, st.st_size, st.st_mtime_ns)


def build_file(path: Path, fill, base: Path | None = None, keep_on_signal: bool = False,
               compact: bool = False) -> Path:
    """Write ``path`` as a whole: ``fill(file)`` on an :class:`h5py.File` built in memory (from
    ``base``'s bytes when given), then the image handed to :func:`replace_file`.

    HDF5 itself never writes to the disk: a full disk or a file-size limit fails in a plain
    write of bytes (an :class:`OSError` naming ``path``), never inside the HDF5 library, and
    ``path`` keeps its previous content byte for byte until the complete new file is renamed
    over it.  Only the store (and a private temporary file) call this.  A signal the command
    recorded stops the write before the rename (:func:`replace_file`), unless
    ``keep_on_signal`` (a checkpoint of finished work, written on the way out of an interrupt).
    With ``compact`` the file written holds only the live objects (:func:`live_image`): what
    ``fill`` deleted leaves no space behind.

    Raises
    ------
    InputError
        ``base`` is larger than :data:`vibeam.io.h5check.MAX_FILE_BYTES` or not an HDF5 file;
        ``path`` is not a regular file or a new name.
    OSError
        The file cannot be written in full; its ``filename`` is ``path``.
    """
    path = check_output_file(Path(path))
    path.parent.mkdir(parents=True, exist_ok=True)
    with signals_deferred():
        try:
            if base is not None:
                file_size_ok(base)
                buf = io.BytesIO(Path(base).read_bytes())
                try:
                    f = h5py.File(buf, "r+")
                except OSError as e:
                    raise InputError(one_line(f"{base}: not an HDF5 file vibeam can keep ({str(e).split('(')[0].strip()}); "
                                              f"move it away, use another --out, or --fresh to replace it")) from None
            else:
                buf = io.BytesIO()
                f = h5py.File(buf, "w")
            with f:
                fill(f)
                if compact:
                    buf = live_image(f)
        except OSError as e:
            if isinstance(e, BrokenPipeError) or e.filename == str(path):
                raise
            why = e.strerror or (str(e).splitlines()[0] if str(e) else type(e).__name__)
            raise OSError(e.errno, why, str(path)) from e
        return replace_file(path, buf.getbuffer(), keep_on_signal=keep_on_signal)


def root_attrs(f, case_name: str, case_text: str, case_json: str = "", complete: bool = True,
               created: str | None = None) -> None:
    """Set the root attributes of a vibeam file (layout of :mod:`vibeam.io.results`)."""
    now = datetime.now(timezone.utc).isoformat()
    set_attrs(f, {"Conventions": "CF-1.10", "vibeam_version": __version__, "vibeam_layout": LAYOUT_VERSION,
                  "case_name": case_name, "case_text": case_text, "case_json": case_json,
                  "created": created or now, "modified": now, "complete": bool(complete)})


def _hard(g, name):
    """The object ``name`` of group ``g`` if it is reached by a hard link, else None."""
    try:
        link = g.get(name, getlink=True)
    except (KeyError, OSError, RuntimeError):
        return None
    if not isinstance(link, h5py.HardLink):
        return None
    try:
        return g[name]
    except (KeyError, OSError, RuntimeError, ValueError):
        return None


def units_of(f) -> dict:
    """The units of an open file: ``{path: h5py.Group}`` (module docstring), links skipped."""
    out = {}
    for top in list(f.keys()):
        obj = _hard(f, top)
        if not isinstance(obj, h5py.Group) or top in CHECKPOINTS:
            continue
        if top in UNIT_PARENTS:
            for name in list(obj.keys()):
                u = _hard(obj, name)
                if isinstance(u, h5py.Group):
                    out[f"{top}/{name}"] = u
        else:
            out[top] = obj
    return out


def _text(v) -> str:
    if isinstance(v, bytes):
        return v.decode("utf-8", "replace")
    if isinstance(v, np.ndarray) and v.size == 1:
        v = v.ravel()[0]
        return v.decode("utf-8", "replace") if isinstance(v, bytes) else str(v)
    return "" if v is None else str(v)


class Store:
    """The results file of one output folder, held by this process for one command.

    Parameters
    ----------
    folder : str or Path
        The output folder (created if needed).
    name : str
        The file (``results.h5``; ``fit.h5``, ``cost.h5``, ... for those commands).
    fresh : bool
        Start a new file: the first :meth:`commit` does not keep the old file's groups, the
        first :meth:`checkpoint` of each kind drops the old checkpoint's.
    inputs : iterable of (str or Path, str)
        Files the command reads, with the option that named them (``("ref.h5",
        "--reference")``): if one of them is the file or its checkpoint, entering refuses.
    outputs : iterable of str
        The other files the command will write in the folder (plots, tables: names or
        :mod:`fnmatch` patterns, :func:`vibeam.io.outdir.check_outputs`): checked on entering,
        before anything is computed.
    command : str, optional
        What runs (stored in the lock).
    log : callable, optional
        Where the store's notes go (default: one line on stderr each).

    Raises
    ------
    InputError
        On entering: the folder is in use or cannot be written; the file, its checkpoint or
        one of ``outputs`` is not a regular file or a new name, or is a file the command reads
        (one line each).
    """

    def __init__(self, folder, name: str = RESULTS_NAME, fresh: bool = False, inputs=(), outputs=(), command=None,
                 log=None):
        self.folder = Path(folder)
        self.path = self.folder / name
        self.partial = self.folder / (name + PARTIAL_SUFFIX)
        self.fresh = bool(fresh)
        self.inputs = [(Path(p), str(o)) for p, o in inputs if p is not None]
        self.outputs = list(outputs)
        self.command = command
        self.log = log or (lambda m: print(m, file=sys.stderr))
        self._lock: OutputLock | None = None
        self._depth = 0                    # nested entries of this store still open
        self._started: set = set()         # checkpoint kinds started afresh by this command
        # the checkpoint this store wrote last, ((inode, size, mtime), its next free netCDF dimension
        # id): the next checkpoint onto that very file counts on from there instead of visiting every
        # object of it for the largest id (an O(lines) visit per flush, O(lines^2) a computation:
        # 41 of 95 s of a profiled 200 x 200 basin grid, issue 60)
        self._dimids: tuple | None = None
        self.stale_noted: list = []        # units this command's commits found or made stale

    # ------------------------------------------------------------------ the hold
    def __enter__(self) -> "Store":
        if self._lock is not None:                 # a step of the command that holds it already
            self._depth += 1
            return self
        # what the command reads is never what it writes (whatever the names), checked with the rest
        inputs = reading(self.inputs)
        inputs.__enter__()
        lock = OutputLock(self.folder, self.command)
        try:
            lock.__enter__()
        except BaseException:
            inputs.__exit__(None, None, None)
            raise
        try:
            for p, opt in self.inputs:
                for mine in (self.path, self.partial):
                    if _same_file(p, mine):
                        raise InputError(f"{opt + ' ' if opt else ''}{p}: is the file this command writes "
                                         f"({mine}); a command never writes into a file it reads: give "
                                         f"another --out")
            check_output_file(self.path)
            check_output_file(self.partial)
            check_outputs(self.folder, self.outputs)
            if not self.fresh:              # what will be kept is checked before anything is computed
                for p, what in ((self.path, "results file"), (self.partial, "checkpoint")):
                    if p.is_file():
                        self._keepable(p, what)
        except BaseException:
            lock.__exit__(None, None, None)
            inputs.__exit__(None, None, None)
            raise
        self._lock = lock
        self._reading = inputs
        return self

    def __exit__(self, *exc):
        if self._depth:
            self._depth -= 1
            return False
        if self._lock is not None:
            self._lock.__exit__(*exc)
            self._lock = None
            self._reading.__exit__(None, None, None)
        return False

    def _keepable(self, path: Path, what: str) -> None:
        """``path`` is a file the store can keep: at most :data:`vibeam.io.h5check.MAX_FILE_BYTES`,
        HDF5, a structure :mod:`vibeam.io.h5check` accepts.

        Raises
        ------
        InputError
            One line naming the file and what is wrong (``--fresh`` replaces it).
        """
        try:
            file_size_ok(path, what=what)
            open_checked(path, what).close()
        except InputError as e:
            raise InputError(f"{e}; {path.name} is kept as it is: move it away, use another --out, or --fresh to "
                             f"replace it") from None

    def _held(self) -> None:
        if self._lock is None or not holds_lock(self.folder):
            raise RuntimeError(f"the results store of {self.folder} is written only inside `with Store(...)`")

    # ------------------------------------------------------------------ reading the complete file
    def exists(self) -> bool:
        """Whether the complete file exists (and is not to be replaced by ``fresh``)."""
        return self.path.is_file() and not self.fresh

    def _open(self, path: Path, what: str):
        """``path`` opened read-only after the structure check (caller closes)."""
        return open_checked(path, what)

    def info(self) -> dict:
        """What the complete file holds: ``{"attrs": root attributes, "units": {path: attrs}}``
        (empty when there is none, or with ``fresh``).

        Raises
        ------
        InputError
            The file is not an HDF5 file vibeam can read, or its structure is refused
            (:mod:`vibeam.io.h5check`).
        """
        if not self.exists():
            return {"attrs": {}, "units": {}}
        return file_info(self.path)

    def current(self, case_json: str, aliases=()) -> list:
        """The units of the complete file computed from ``case_json`` (or one of ``aliases``, the
        same case as an earlier vibeam wrote it): not stale."""
        return current_units(self.info(), case_json, aliases)

    # ------------------------------------------------------------------ the commit
    def commit(self, groups: dict, case_name: str, case_text: str, case_json: str, done=(), aliases=()) -> Path:
        """Replace the file by its successor: every group kept, ``groups`` written.

        Parameters
        ----------
        groups : dict
            ``{unit path: fill}``; ``fill(file)`` writes the unit at that path (an old unit
            there is removed first).  Each written unit gets ``case_hash`` and ``case_name``.
        case_name, case_text, case_json : str
            The case the command ran (the root attributes of the successor).
        done : iterable of str
            Checkpoint groups the command consumed (``"lines"``, ``"basin_lines/<run>"``):
            removed from ``<file>.partial`` after the commit, and from the file itself where an
            earlier vibeam kept them there.
        aliases : iterable of str
            Other JSON texts of the same case (as an earlier vibeam wrote it, without keys added
            since: ``vibeam.runner.same_case``): a unit computed from one of them is not stale.

        Returns
        -------
        Path
            The file.

        Raises
        ------
        InputError
            The old file cannot be kept (not HDF5, too large, a refused structure): nothing is
            written.
        OSError
            The successor cannot be written in full: the old file is as it was.
        KeyboardInterrupt
            A signal was recorded (:func:`vibeam.errors.stop_if_signalled`, here and right
            before the rename): the old file is as it was.
        """
        self._held()
        stop_if_signalled()                        # an interrupt swallowed on its way: no commit
        base = self.path if self.exists() else None
        if base is not None:
            with self._open(base, "results file"):
                pass                               # structure checked before its bytes are taken
        ident = case_hash(case_json)
        same = {ident} | {case_hash(a) for a in aliases}
        done = [str(d).strip("/") for d in done]
        newly: list = []

        def fill(f):
            old = read_attrs(f) if base is not None else {}
            old_json = _text(old.get("case_json", "")) if "case_json" in old else None
            old_origin = {"case_hash": case_hash(old_json) if old_json is not None else "",
                          "case_name": _text(old.get("case_name", "")), "case_text": _text(old.get("case_text", "")),
                          "case_json": old_json or ""}
            before = units_of(f)
            for p, g in before.items():              # units of an earlier vibeam: the file's case
                if "case_hash" not in g.attrs:
                    set_attrs(g, {"case_hash": old_origin["case_hash"], "case_name": old_origin["case_name"]})
            was_stale = {p for p, g in before.items() if int(np.asarray(g.attrs.get("stale", 0)).ravel()[0] or 0)}
            for d in done:                           # an earlier vibeam's checkpoint, now consumed
                if d.split("/")[0] in CHECKPOINTS and _hard(f, d.split("/")[0]) is not None and d in f:
                    del f[d]
                    parent = d.rsplit("/", 1)[0] if "/" in d else None
                    if parent and parent in f and not len(f[parent]):
                        del f[parent]
            for p, write in groups.items():
                p = p.strip("/")
                if p in f:
                    del f[p]
                write(f)
                if p not in f:
                    raise RuntimeError(f"the writer of {p} wrote no group {p}")
                set_attrs(f[p], {"case_hash": ident, "case_name": case_name})
            created = _text(old.get("created", "")) or None
            for k in _ROOT_KEYS:
                if k in f.attrs:
                    del f.attrs[k]
            root_attrs(f, case_name, case_text, case_json, complete=True, created=created)
            after = units_of(f)
            for p, g in after.items():
                h = _text(g.attrs.get("case_hash", ""))
                if h in same:
                    for k in ("stale", "stale_reason", "case_text", "case_json"):
                        if k in g.attrs:
                            del g.attrs[k]
                    continue
                if "case_text" not in g.attrs and h == old_origin["case_hash"]:
                    set_attrs(g, {"case_text": old_origin["case_text"], "case_json": old_origin["case_json"]})
                who = _text(g.attrs.get("case_name", "")) or "?"
                set_attrs(g, {"stale": np.int8(1),
                              "stale_reason": f"computed from another case text (case {who}, case_hash {h or '?'}) "
                                              f"than the file's case {case_name} (case_hash {ident}); its own case "
                                              f"is in this group's case_text"})
                if p not in was_stale:
                    newly.append(p)
            lost = sorted(set(before) - set(after))
            if lost:                                  # never: a successor keeps every unit
                raise RuntimeError(f"the successor of {self.path} would lose {lost}")

        build_file(self.path, fill, base, compact=True)
        self.fresh = False
        if newly:
            self.stale_noted += newly
            shown = ", ".join(newly[:6]) + (f" and {len(newly) - 6} more" if len(newly) > 6 else "")
            self.log(f"vibeam: note: {self.path} keeps {len(newly)} group(s) computed from another case text, "
                     f"marked stale (attribute stale): {shown}; --fresh (or another --out) starts a new file")
        if done:
            self._drop_checkpoints(done)
        return self.path

    # ------------------------------------------------------------------ checkpoints
    def checkpoint(self, kind: str, groups: dict, case_name: str = "", case_text: str = "",
                   case_json: str = "", start: bool = False) -> Path:
        """Add finished work to the checkpoint ``<file>.partial`` (atomically, as a whole file).

        Parameters
        ----------
        kind : str
            ``"lines"`` (sweep lines), ``"basin_lines/<run>"`` (basin rows) or
            ``"uncertainty_samples"`` (the finished samples of ``vibeam uncertainty``, keys
            ``<run>/<block>``).
        groups : dict
            ``{path below kind: (variables, attrs)}``, each written by
            :func:`vibeam.io.netcdf.write_group` (an old group at that path is replaced).
        case_name, case_text, case_json : str
            Root attributes of the checkpoint.
        start : bool
            The first checkpoint of a computation that does not resume: the old content of
            ``kind`` is dropped (once per kind and command).

        Raises
        ------
        OSError
            The checkpoint cannot be written in full (the old one is as it was).
        """
        self._held()
        drop = (start or self.fresh) and kind not in self._started
        base = self.partial if self.partial.is_file() else None
        known = self._dimids
        self._dimids = None
        ids = DimIds(known[1] if known is not None and base is not None and _signature(base) == known[0]
                     else None)

        def fill(f):
            if drop and kind in f:
                del f[kind]
            for k in _ROOT_KEYS:
                if k in f.attrs:
                    del f.attrs[k]
            root_attrs(f, case_name, case_text, case_json, complete=False)
            for key, (variables, attrs) in groups.items():
                p = f"{kind}/{key}"
                if p in f:
                    del f[p]
                write_group(f, p, variables, attrs, _ids=ids)
            for key in groups:      # once every group is written (a later one may share a dimension)
                p = f"{kind}/{key}"
                f[p].attrs[DIGEST_ATTR] = checkpoint_digest(f[p], p)

        if self.fresh and not self._started:
            base = None                           # --fresh: the old checkpoint is not kept
            ids = DimIds()
        # a checkpoint that dropped its old content is written without it (only appended to, it is not)
        out = build_file(self.partial, fill, base, keep_on_signal=True, compact=drop and base is not None)
        self._started.add(kind)
        if ids.next is not None:
            self._dimids = (_signature(out), ids.next)
        return out

    def read_checkpoint(self, kind: str, attr: str, ident: str, check=None) -> tuple[dict, dict]:
        """The groups ``kind/<key>`` of the checkpoint whose attribute ``attr`` is ``ident``.

        The checkpoint ``<file>.partial`` is read; where it has no such group, the file itself
        (an earlier vibeam kept its checkpoint there).  Each group's structure is checked first
        (:func:`vibeam.io.h5check.check_tree`: no links, bounded sizes), then ``check(key, meta,
        None)`` with ``meta = {dataset: (shape, dtype)}`` before any value is read, then
        ``check(key, meta, data)`` with the values (``check`` returns None or what is wrong), then
        the group's digest (:func:`checkpoint_digest`, where it has one).

        Returns
        -------
        (dict, dict)
            The root attributes of the file read and ``{key: {dataset: array}}`` (nested
            groups as nested dicts).

        Raises
        ------
        InputError
            One line naming the file and the group or dataset that this vibeam would not have
            written; nothing is written.
        """
        for path in (self.partial, self.path):
            if not path.is_file() or (path == self.path and self.fresh):
                continue
            with self._open(path, "checkpoint" if path == self.partial else "results file") as f:
                attrs = read_attrs(f)
                top = _hard(f, kind.split("/")[0])
                g = top
                for part in kind.split("/")[1:]:
                    g = _hard(g, part) if isinstance(g, h5py.Group) else None
                if not isinstance(g, h5py.Group):
                    continue
                out = {}
                for key in sorted(g.keys()):
                    sub = _hard(g, key)
                    if not isinstance(sub, h5py.Group) or _text(sub.attrs.get(attr, "")) != ident:
                        continue
                    where = f"{path} ({kind}/{key})"
                    check_tree(where, sub, f"/{kind}/{key}")
                    meta = {k: (tuple(d.shape), d.dtype) for k, d in sub.items()
                            if isinstance(d, h5py.Dataset) and not is_dim_only(d)}
                    bad = check(key, meta, None) if check is not None else None
                    if bad is None:
                        try:
                            data = read_plain(sub)
                        except (OSError, ValueError, TypeError, KeyError, RuntimeError) as e:
                            bad = f"cannot be read ({one_line(str(e))[:80]})"
                        else:
                            bad = check(key, meta, data) if check is not None else None
                    if bad is None and DIGEST_ATTR in sub.attrs and \
                            _text(sub.attrs[DIGEST_ATTR]) != checkpoint_digest(sub, f"{kind}/{key}"):
                        bad = ("its contents differ from what vibeam wrote there (the digest in its attribute "
                               f"{DIGEST_ATTR} does not match: changed, or copied from another group)")
                    if bad is not None:
                        raise InputError(one_line(f"--resume: {path}: /{kind}/{key}: {bad}; this vibeam never "
                                                  f"writes that: remove {path.name} (or run without --resume) to "
                                                  f"compute afresh"))
                    out[key] = data
                if out:
                    return attrs, out
        attrs = {}
        for path in (self.partial, self.path):
            if path.is_file() and not (path == self.path and self.fresh):
                with self._open(path, "checkpoint" if path == self.partial else "results file") as f:
                    attrs = read_attrs(f)
                break
        return attrs, {}

    def checkpoint_attrs(self) -> dict:
        """Root attributes of the checkpoint (``<file>.partial``), {} without one."""
        if not self.partial.is_file():
            return {}
        with self._open(self.partial, "checkpoint") as f:
            return read_attrs(f)

    def _drop_checkpoints(self, done) -> None:
        """Remove consumed checkpoint groups (``kind`` or ``kind/<run>``) from ``<file>.partial``;
        the file itself when nothing is left in it."""
        if not self.partial.is_file():
            return

        try:
            with self._open(self.partial, "checkpoint") as f:
                tops = {k: set(g.keys()) for k in f.keys() if isinstance(g := _hard(f, k), h5py.Group)}
        except InputError:
            return                                 # not ours to judge now: a later --resume says why
        present = []
        for d in done:
            head, _, rest = d.partition("/")
            if head not in tops or (rest and rest not in tops[head]):
                continue
            present.append(d)
            if rest:
                tops[head].discard(rest)
            if not rest or not tops[head]:
                tops.pop(head)
        if not present:
            return
        if not tops:
            self.partial.unlink()
            return

        def fill(f):
            for d in present:
                if d in f:
                    del f[d]
                head = d.split("/")[0]
                if "/" in d and head in f and not len(f[head]):
                    del f[head]

        build_file(self.partial, fill, self.partial, keep_on_signal=True, compact=True)


def file_info(path) -> dict:
    """What a results file holds: ``{"attrs": root attributes, "units": {path: attrs}}``; a unit
    without ``case_hash`` (an earlier vibeam's) has the file's case.  Read-only: no lock.

    Raises
    ------
    InputError
        Not an HDF5 file vibeam can read, or a structure :mod:`vibeam.io.h5check` refuses.
    """
    with open_checked(path, "results file") as f:
        attrs = read_attrs(f)
        units = {p: read_attrs(g) for p, g in units_of(f).items()}
    ident = case_hash(_text(attrs.get("case_json", ""))) if attrs.get("case_json") is not None else ""
    for a in units.values():
        a.setdefault("case_hash", ident)
    return {"attrs": attrs, "units": units}


def current_units(info, case_json: str, aliases=()) -> list:
    """The units of :func:`file_info` (or of a file's path) computed from ``case_json`` or one of
    ``aliases`` (the same case as an earlier vibeam wrote it)."""
    if not isinstance(info, dict):
        info = file_info(info)
    same = {case_hash(case_json)} | {case_hash(a) for a in aliases}
    return [p for p, a in info["units"].items() if _text(a.get("case_hash", "")) in same]


def _same_file(a: Path, b: Path) -> bool:
    try:
        return os.path.samefile(a, b)
    except OSError:
        return False


def write_file(path, groups: dict, case_name: str = "", case_text: str = "", case_json: str = "") -> Path:
    """A new file of ``groups`` (``{unit path: fill}``) at ``path``, built whole and renamed in
    place (a private temporary file, e.g. the file behind :meth:`vibeam.api.Results.to_xarray`;
    results in a user's folder go through :class:`Store`)."""
    def fill(f):
        root_attrs(f, case_name, case_text, case_json, complete=True)
        f.require_group("runs")
        for p, write in groups.items():
            write(f)
            set_attrs(f[p.strip("/")], {"case_hash": case_hash(case_json), "case_name": case_name})

    return build_file(Path(path), fill)
