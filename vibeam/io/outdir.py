"""The output folder of a run: one vibeam process at a time, and no leftovers of killed writes.

:class:`OutputLock` holds the lock file ``<out>/.vibeam.lock`` for as long as a
run (or ``vibeam cost``) writes into the folder.  The file holds the process
id, host, start time and command line of its holder (JSON), and the holder
keeps an exclusive ``flock`` on it, which the kernel drops when the process
ends in any way, ``kill -9`` included.  A second process refuses the folder
with one message naming it and the running process; a lock left by a process
that is gone (a *stale* lock) is taken over.  On a file system without
``flock`` the holder's pid (and its start time, against pid reuse) decides.

The lock file is created with ``O_CREAT | O_EXCL | O_NOFOLLOW`` and an existing one is
opened with ``O_NOFOLLOW``: a lock path that is a symbolic link, a hard link to another
file or not a regular file is refused, so the lock never writes through a link into a
file it did not create.

Every file vibeam writes goes through :func:`replace_file`: a temporary file in the same
folder (``.vibeam-tmp-*``), written in full, flushed to the disk (``fsync``) and only then
renamed over the old file, so a failed write (a full disk, a file-size limit, a read-only
folder, an interrupt) leaves the previous file byte for byte.  While it holds the lock, the
process removes the temporary files that a killed write leaves behind (:data:`TMP_PATTERNS`).

:func:`default_folder` is where a command writes without ``--out``: ``results/<name>``,
never outside ``results/``.  A folder :func:`check_folder` made for a command that then fails
before its first file (a model that cannot be built) is removed again, with the parents it made
(:func:`removing_empty_folders`, around every command of ``vibeam`` with an output folder): a
failed command changes nothing on the disk.

No command writes a file it reads (issue 57): the command line names the files a command
reads (:func:`reading`: its case file, ``--reference``, ``--results``, ...) and
:func:`check_output_file` -- through which :func:`replace_file` and the results store pass
every name -- refuses any of them, by identity (device and inode: a hard link, another
spelling of the path), whatever the name.  A command checks every name it will write
before it computes anything (:func:`check_outputs`).
"""
from __future__ import annotations

import contextlib
import errno
import fnmatch
import json
import os
import socket
import stat
import sys
import tempfile
import time
from datetime import datetime, timezone
from pathlib import Path

from vibeam.errors import InputError, stop_if_signalled

LOCK_NAME = ".vibeam.lock"
TMP_PREFIX = ".vibeam-tmp-"
"""Start of the name of every temporary file :func:`replace_file` writes."""
TMP_PATTERNS = (TMP_PREFIX + "*", ".results-*.h5.tmp")
"""Leftovers of killed writes removed by the lock's holder (the second: earlier versions)."""

_held_fds: set[int] = set()
#: the locks this process holds: real path of the folder -> its OutputLock (nested uses share it)
_held_locks: dict = {}


def _close_in_child() -> None:
    # a forked child (a pool worker) must not keep the parent's lock alive after the parent ends
    for fd in list(_held_fds):
        try:
            os.close(fd)
        except OSError:
            pass
    _held_fds.clear()
    _held_locks.clear()


def holds_lock(folder) -> bool:
    """Whether this process holds the lock of ``folder`` (:class:`OutputLock`)."""
    lock = _held_locks.get(os.path.realpath(folder))
    return lock is not None and lock.fd is not None


if hasattr(os, "register_at_fork"):
    os.register_at_fork(after_in_child=_close_in_child)


def _proc_start(pid: int) -> str | None:
    """Start time of a process (clock ticks since boot, Linux ``/proc``), None if unknown."""
    try:
        with open(f"/proc/{pid}/stat") as f:
            return f.read().rsplit(")", 1)[1].split()[19]
    except (OSError, IndexError):
        return None


def _alive(info: dict) -> bool:
    """Whether the process recorded in a lock may still run (True when it cannot be told)."""
    try:
        pid = int(info.get("pid"))
    except (TypeError, ValueError):
        return False
    if info.get("host") != socket.gethostname():
        return True                        # another machine: cannot tell, assume it runs
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        pass
    start = info.get("pid_start")
    return start is None or _proc_start(pid) in (None, start)


def describe(info: dict) -> str:
    """The holder of a lock in words: ``pid 123 on host, started ..., command ...``."""
    if not info:
        return "a process that left no details"
    cmd = info.get("command") or "?"
    if len(cmd) > 160:
        cmd = cmd[:157] + "..."
    return f"pid {info.get('pid', '?')} on {info.get('host', '?')}, started {info.get('started', '?')}: {cmd}"


def default_folder(name: str, suffix: str = "", root="results") -> Path:
    """The output folder of a command without ``--out``: ``results/<name><suffix>``.

    Raises
    ------
    InputError
        If the folder would not be a folder inside ``root`` (a name such as ``..`` or
        ``.``, a separator): a case name never writes outside ``results/``.
    """
    leaf = f"{name}{suffix}"
    if not leaf or leaf.strip(".") == "" or os.sep in leaf or (os.altsep and os.altsep in leaf) \
            or Path(leaf).name != leaf or "\x00" in leaf:
        raise InputError(f"name = {name!r}: the output folder results/{leaf} would lie outside "
                         f"results/; allowed: a name that is not only dots, of letters, digits, "
                         f"'_', '.', '+', '-'")
    return Path(root) / leaf


#: the scopes of :func:`removing_empty_folders` open in this process, innermost last: each the list
#: of the folders :func:`check_folder` created while it was open
_made_scopes: list[list[Path]] = []


@contextlib.contextmanager
def removing_empty_folders():
    """Folders :func:`check_folder` creates inside the block are removed when it ends if still empty.

    A command that fails before it writes its first file (a model that cannot be built, an
    interrupt) leaves nothing on the disk: the output folder it made (``results/<case>``, and
    ``results/`` if that was made too) goes again.  Only folders this process created (its own
    ``mkdir`` succeeded) are removed, deepest first, and only when empty (``os.rmdir``): a folder
    that was there before, or holds anything, stays as it is.

    Yields
    ------
    list of Path
        The folders created so far inside the block (absolute).
    """
    made: list[Path] = []
    _made_scopes.append(made)
    try:
        yield made
    finally:
        for i in range(len(_made_scopes) - 1, -1, -1):
            if _made_scopes[i] is made:
                del _made_scopes[i]
                break
        for p in sorted(set(made), key=lambda q: len(q.parts), reverse=True):
            try:
                os.rmdir(p)            # only an empty folder; anything else stays
            except OSError:
                pass


def check_folder(folder, option: str = "--out") -> Path:
    """``folder`` exists (created if needed) and is a writable folder.

    The folders it creates are recorded for :func:`removing_empty_folders`.

    Parameters
    ----------
    folder : str or Path
    option : str
        The option that named it, for the message (default ``--out``).

    Raises
    ------
    InputError
        If it names a file, cannot be created or cannot be written.
    """
    folder = Path(folder)
    if folder.exists() and not folder.is_dir():
        raise InputError(f"{option} {folder}: is a file, not a folder")
    missing = []                       # the folder and its parents that are not there, deepest first
    p = Path(os.path.abspath(folder))
    while not os.path.lexists(p) and p.parent != p:
        missing.append(p)
        p = p.parent
    try:
        for p in reversed(missing):    # one level at a time: a folder is ours only if our mkdir made it
            try:
                os.mkdir(p)
            except FileExistsError:
                continue
            if _made_scopes:
                _made_scopes[-1].append(p)
        folder.mkdir(parents=True, exist_ok=True)     # exists now; a name in the way raises as before
    except OSError as e:
        raise InputError(f"{option} {folder}: cannot create the folder: {e.strerror or e}") from None
    if not os.access(folder, os.W_OK | os.X_OK):
        raise InputError(f"{option} {folder}: cannot write in the folder: permission denied")
    return folder


class OutputLock:
    """Exclusive use of an output folder by this process (a context manager).

    Parameters
    ----------
    folder : str or Path
        The output folder (created if needed).
    command : str, optional
        What runs (stored in the lock; default the command line).
    option : str
        The option that named the folder, for messages (``--csv`` of ``vibeam export``).

    Attributes
    ----------
    stale : dict or None
        The lock taken over from a process that is gone, if any.
    removed_tmp : list of Path
        Temporary files of killed writes removed on acquiring.

    Raises
    ------
    InputError
        On entering: the folder is used by another running process (the
        message names the folder and that process), or cannot be created or
        written.

    Notes
    -----
    Nested use in one process is allowed: a lock of a folder this process already holds
    shares that hold (a command holds its folder from start to end, and the steps it calls
    -- a run, then its basins -- take the lock again); the folder is released when the
    outermost holder releases it.
    """

    def __init__(self, folder, command: str | None = None, option: str = "--out"):
        self.folder = Path(folder)
        self.option = option
        self.path = self.folder / LOCK_NAME
        self.command = command if command is not None else " ".join([Path(sys.argv[0]).name, *sys.argv[1:]])
        self.fd: int | None = None
        self.stale: dict | None = None
        self.removed_tmp: list[Path] = []
        self._outer: "OutputLock | None" = None       # the holder this nested use shares

    # ------------------------------------------------------------------ acquire
    def _read(self, fd) -> dict:
        try:
            os.lseek(fd, 0, os.SEEK_SET)
            raw = b""
            while chunk := os.read(fd, 65536):
                raw += chunk
            return json.loads(raw.decode("utf-8", "replace")) if raw.strip() else {}
        except (OSError, ValueError):
            return {}

    def _open(self) -> int | None:
        """The lock file, opened for reading and writing: a new one created exclusively, an
        existing one opened without following a link; None if it vanished in between.

        Raises
        ------
        InputError
            If the lock path is a symbolic link, a hard link to another file or not a
            regular file, or cannot be written.
        """
        flags = os.O_RDWR | getattr(os, "O_NOFOLLOW", 0) | getattr(os, "O_CLOEXEC", 0)
        try:
            return os.open(self.path, flags | os.O_CREAT | os.O_EXCL, 0o644)
        except FileExistsError:
            pass
        except OSError as e:
            self._cannot(e)
        try:
            # O_NONBLOCK: a FIFO in its place must not block the open (it is refused below)
            fd = os.open(self.path, flags | getattr(os, "O_NONBLOCK", 0))
        except FileNotFoundError:
            return None
        except OSError as e:
            if e.errno == errno.ELOOP or os.path.islink(self.path):
                self._not_ours("is a symbolic link" + self._target())
            self._cannot(e)
        st = os.fstat(fd)

        if not stat.S_ISREG(st.st_mode) or st.st_nlink != 1:
            os.close(fd)
            self._not_ours("is not a regular file" if not stat.S_ISREG(st.st_mode)
                           else f"is a hard link ({st.st_nlink} names for one file)")
        if hasattr(os, "set_blocking"):
            os.set_blocking(fd, True)
        return fd

    def _target(self) -> str:
        try:
            return f" (to {os.readlink(self.path)})"
        except OSError:
            return ""

    def _not_ours(self, what: str):
        raise InputError(f"{self.option} {self.folder}: the lock file {self.path} {what}; vibeam writes its lock "
                         f"only into a plain file of its own: remove {self.path} or use another {self.option}")

    def _cannot(self, e: OSError):
        raise InputError(f"{self.option} {self.folder}: cannot write the lock file {self.path}: "
                         f"{e.strerror or e}") from None

    def _refuse(self, info):
        raise InputError(f"{self.option} {self.folder} is in use by another vibeam process ({describe(info)}); "
                         f"wait for it to end or use another {self.option} (lock file {self.path})")

    def acquire(self) -> "OutputLock":
        import fcntl  # lazy: fcntl is POSIX-only: vibeam.io.outdir imports on every platform

        check_folder(self.folder, self.option)
        key = os.path.realpath(self.folder)
        outer = _held_locks.get(key)
        if outer is not None and outer.fd is not None:     # this process holds it already
            self._outer = outer
            return self
        deadline = time.monotonic() + 2.0
        while True:
            fd = self._open()
            if fd is None:
                continue                   # removed between two looks: look again
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
                flocked = True
            except BlockingIOError:
                info = self._read(fd)
                os.close(fd)
                if not _alive(info) and time.monotonic() < deadline:
                    time.sleep(0.1)        # its orphaned workers are exiting: the lock drops soon
                    continue
                self._refuse(info)
            except OSError as e:           # no flock on this file system: decide by the pid
                if e.errno not in (errno.ENOLCK, errno.EOPNOTSUPP, errno.ENOTSUP, errno.EINVAL):
                    os.close(fd)
                    raise
                flocked = False
            # the file may have been removed (released) between open and flock: lock the real one
            try:
                same = os.fstat(fd).st_ino == os.lstat(self.path).st_ino
            except FileNotFoundError:
                same = False
            if not same:
                os.close(fd)
                continue
            break
        prev = self._read(fd)
        if prev and prev.get("pid") != os.getpid():
            if not flocked and _alive(prev):
                os.close(fd)
                self._refuse(prev)
            self.stale = prev
        info = {"pid": os.getpid(), "host": socket.gethostname(), "pid_start": _proc_start(os.getpid()),
                "started": datetime.now(timezone.utc).isoformat(timespec="seconds"),
                "command": self.command}
        self.fd = fd
        _held_fds.add(fd)
        _held_locks[key] = self
        try:
            os.ftruncate(fd, 0)
            os.lseek(fd, 0, os.SEEK_SET)
            os.write(fd, (json.dumps(info) + "\n").encode())
        except OSError as e:               # a full disk: no lock is left behind
            self.release()
            self._cannot(e)
        for pattern in TMP_PATTERNS:                   # leftovers of killed writes
            for p in self.folder.glob(pattern):
                try:
                    if p.is_symlink() or p.is_file():
                        p.unlink()
                        self.removed_tmp.append(p)
                except OSError:
                    pass
        return self

    def release(self) -> None:
        """Remove the lock file and drop the lock (idempotent); a nested use only ends itself."""
        if self._outer is not None:
            self._outer = None
            return
        if self.fd is None:
            return
        _held_locks.pop(os.path.realpath(self.folder), None)
        try:
            if os.path.lexists(self.path) and os.lstat(self.path).st_ino == os.fstat(self.fd).st_ino:
                os.unlink(self.path)
        except OSError:
            pass
        _held_fds.discard(self.fd)
        try:
            os.close(self.fd)
        except OSError:
            pass
        self.fd = None

    def __enter__(self):
        self.acquire()
        if self.stale:
            print(f"vibeam: note: took over the stale lock of {self.folder} ({describe(self.stale)}; "
                  f"that process is gone)", file=sys.stderr)
        return self

    def __exit__(self, *exc):
        self.release()
        return False


#: the files the running command reads: ``(st_dev, st_ino) -> (path, option)`` (:func:`reading`)
_READING: dict = {}


@contextlib.contextmanager
def reading(inputs):
    """The files a command reads, for the block: :func:`check_output_file` refuses to write any
    of them (by device and inode, so under any name: a hard link, ``./`` or ``../`` spellings).

    Parameters
    ----------
    inputs : iterable of (str or Path or None, str)
        ``(path, option)``: the file and the option or argument that named it (``"--reference"``,
        ``"case file"``); None or a name that does not exist (yet) is skipped.
    """
    added = []
    for path, option in inputs:
        if path is None:
            continue
        try:
            st = os.stat(path)
        except (OSError, ValueError):
            continue
        key = (st.st_dev, st.st_ino)
        if key not in _READING:
            _READING[key] = (str(path), str(option))
            added.append(key)
    try:
        yield
    finally:
        for key in added:
            _READING.pop(key, None)


def read_by_command(path) -> tuple | None:
    """``(path, option)`` of the input of the running command that ``path`` is (the same file,
    :func:`reading`), or None."""
    if not _READING:
        return None
    try:
        st = os.stat(path)
    except (OSError, ValueError):
        return None
    return _READING.get((st.st_dev, st.st_ino))


_OUT_KINDS = ((stat.S_ISDIR, "a folder"), (stat.S_ISCHR, "a character device"), (stat.S_ISBLK, "a block device"),
              (stat.S_ISFIFO, "a named pipe"), (stat.S_ISSOCK, "a socket"))


def check_output_file(path, option: str = "") -> Path:
    """``path`` is a name vibeam may write: nothing there yet, or a regular file (not a link).

    A device (``/dev/null``), a named pipe, a socket, a folder or a symbolic link at ``path``
    is refused whatever the user's privileges: replacing it would swap a system file for a
    regular one (``/dev/null`` as root) or write where the link points.

    Parameters
    ----------
    path : str or Path
    option : str
        The option that named the file (``--write``), for the message.

    Returns
    -------
    Path

    Raises
    ------
    InputError
        One line naming the file, what it is, and what is allowed.
    """
    path = Path(path)
    opt = f"{option} " if option else ""
    try:
        st = os.lstat(path)
    except FileNotFoundError:
        return path
    except OSError as e:
        raise InputError(f"{opt}{path}: cannot write: {e.strerror or e}") from None
    allowed = "allowed: a regular file or a new name"
    if stat.S_ISLNK(st.st_mode):
        try:
            to = f" (to {os.readlink(path)})"
        except OSError:
            to = ""
        raise InputError(f"{opt}{path}: is a symbolic link{to}; vibeam never writes over or through a link; "
                         f"{allowed}")
    if not stat.S_ISREG(st.st_mode):
        kind = next((name for test, name in _OUT_KINDS if test(st.st_mode)), "not a regular file")
        what = "not a file" if kind == "a folder" else "not a regular file"
        raise InputError(f"{opt}{path}: is {kind}, {what}; vibeam would replace it; {allowed}")
    read = read_by_command(path)
    if read is not None:
        same = "" if os.path.abspath(read[0]) == os.path.abspath(path) else f" ({read[0]}, the same file)"
        raise InputError(f"{opt}{path}: is the {read[1]} this command reads{same}; a command never writes a "
                         f"file it reads: give another name or folder")
    return path


def check_outputs(folder, names) -> None:
    """Every file a command will write in ``folder`` may be written (:func:`check_output_file`):
    checked before anything is computed, so a command never computes (or replaces one file)
    and then fails on the next name.

    Parameters
    ----------
    folder : str or Path
    names : iterable of str
        File names, or :mod:`fnmatch` patterns for names that depend on the results
        (``map_*.png``): every existing entry of ``folder`` that matches is checked.

    Raises
    ------
    InputError
        One line naming the first file that is not a regular file or a new name, or that
        the command reads.
    """
    folder = Path(folder)
    if not folder.is_dir():
        return                  # nothing is there yet (or not a folder: the folder's own check says so)
    names = list(names)
    exact = [n for n in names if not any(c in n for c in "*?[")]
    patterns = [n for n in names if n not in exact]
    for n in exact:
        check_output_file(folder / n)
    if patterns:
        try:
            entries = sorted(os.listdir(folder))
        except OSError:
            return
        for e in entries:
            if any(fnmatch.fnmatchcase(e, p) for p in patterns):
                check_output_file(folder / e)


def replace_file(path, content, keep_on_signal: bool = False) -> Path:
    """Replace ``path`` by a complete successor: the one way vibeam writes a file.

    ``content`` goes to a temporary file in the same folder (``.vibeam-tmp-XXXXXXXX-<name>``,
    so its suffix is that of ``path``), which is flushed to the disk (``fsync``), given the
    mode ``0666 & ~umask`` and renamed over ``path`` (:func:`os.replace`, atomic); the folder
    is then flushed too.  Until the rename ``path`` is untouched, byte for byte; a rename
    replaces a symbolic link at ``path`` itself, never the file it points to.  Right before
    the rename a signal the command recorded (:func:`vibeam.errors.stop_if_signalled`, also
    one held back while the signals are blocked) stops the write: an interrupted command
    never replaces a file, even where the interrupt itself was swallowed (issue 57).

    Parameters
    ----------
    path : str or Path
        The file to write; its folder must exist.
    content : bytes, bytearray, memoryview, str or callable
        The new content (a str is written as UTF-8), or ``write(tmp_path)`` writing it.
    keep_on_signal : bool
        Write it even after a signal: a checkpoint of finished work, which an interrupted
        command writes on its way out.

    Returns
    -------
    Path

    Raises
    ------
    InputError
        If ``path`` is not a regular file or a new name (:func:`check_output_file`): nothing is
        written.
    KeyboardInterrupt
        A signal was recorded (:class:`vibeam.errors.Terminated` for SIGTERM): nothing is
        written.
    OSError
        If the file cannot be written in full (a full disk, a file-size limit, permissions);
        its ``filename`` is ``path``, not the temporary file, and the temporary file is gone.
        Any other error of ``write`` is raised as it is, after the same clean-up.
    """
    path = check_output_file(path)
    try:
        fd, tmp = tempfile.mkstemp(prefix=TMP_PREFIX, suffix=f"-{path.name}", dir=path.parent)
    except OSError as e:
        raise OSError(e.errno, e.strerror or str(e), str(path)) from None
    try:
        try:
            if callable(content):
                os.close(fd)
                fd = -1
                content(Path(tmp))
                fd = os.open(tmp, os.O_RDONLY)
            else:
                data = content.encode("utf-8") if isinstance(content, str) else content
                view = memoryview(data).cast("B")
                while view:
                    n = os.write(fd, view)
                    view = view[n:]
            os.fsync(fd)
        finally:
            if fd >= 0:
                os.close(fd)
        os.chmod(tmp, 0o666 & ~_umask())       # mkstemp makes 0600; results are shared
        if not keep_on_signal:
            stop_if_signalled()
        os.replace(tmp, path)
    except BaseException as e:
        try:
            os.unlink(tmp)
        except OSError:
            pass
        if isinstance(e, OSError) and not isinstance(e, BrokenPipeError) and e.filename != str(path):
            # name the file being written (not the temporary one) in the one-line error
            why = e.strerror or (str(e).splitlines()[0] if str(e) else type(e).__name__)
            raise OSError(e.errno, why, str(path)) from e
        raise
    _sync_folder(path.parent)
    return path


def _sync_folder(folder) -> None:
    """Flush a folder's entries (a rename) to the disk; a no-op where folders cannot be opened."""
    try:
        fd = os.open(folder, os.O_RDONLY | getattr(os, "O_DIRECTORY", 0))
    except OSError:
        return
    try:
        os.fsync(fd)
    except OSError:
        pass
    finally:
        os.close(fd)


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def write_text_file(path, text: str, option: str = "") -> Path:
    """Write a text file atomically (:func:`replace_file`).

    Raises
    ------
    InputError
        If ``path`` is a folder, its folder is missing or cannot be written; ``option`` (e.g.
        ``--write``) prefixes the message.
    OSError
        If the file cannot be written in full (a full disk); ``path`` is left as it was.
    """
    path = Path(path)
    opt = f"{option} " if option else ""
    if path.is_dir():
        raise InputError(f"{opt}{path}: is a folder; give a file name")
    if not path.parent.is_dir():
        raise InputError(f"{opt}{path}: the folder {path.parent} does not exist")
    if not os.access(path.parent, os.W_OK | os.X_OK):
        raise InputError(f"{opt}{path}: cannot write in {path.parent}: permission denied")
    return replace_file(path, text)
