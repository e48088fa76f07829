"""Input files: how every file vibeam reads as input is opened, and the one table reader.

Every input file -- a case file, a reference or measurement table (CSV), a free-decay
record, a results file given as input -- goes through :func:`check_input_file`: it must be
an existing *regular* file (a symlink to one is fine).  Directories, character devices
(``/dev/zero``, a terminal), named pipes and sockets are refused in one line before
anything is read, so no input can stream without end or block.  Text inputs are read by
:func:`read_input_text` (through :func:`read_input_bytes`): at most
:data:`MAX_INPUT_BYTES` (10 MB; the largest shipped case file is 5 kB, a CSV of 1e5
measured points is about 3 MB), UTF-8 with or without a byte-order mark.  Results files
(HDF5) are checked to be regular files and then read by h5py, which reads only the
datasets asked for, so no size cap applies to them.

Tables of measured or reference points (``vibeam fit --reference``, ``vibeam regress
--reference``; the API's ``read_reference``) are read by :func:`read_frc_table`, with one
set of rules for every command:

* a header line naming the columns: ``frequency_hz,amplitude_mm`` (physical) or
  ``Omega,amplitude`` (nondimensional), optionally ``direction`` and ``sigma``; any other
  or repeated column is refused;
* every data row has one value per column (no missing or extra fields);
* ``frequency_hz`` / ``Omega``: a finite number > 0; ``amplitude_mm`` / ``amplitude``: a
  finite number >= 0 (the amplitude ``Q = Delta - min q`` of paper Sec. 4.1 is never
  negative); ``sigma``: a finite number > 0; ``direction``: ``up`` or ``down`` (default
  ``up`` without the column);
* blank lines and lines starting with ``#`` are skipped; a UTF-8 byte-order mark is
  allowed.

Every refusal is an :class:`vibeam.case.schema.InputError` of one line naming the file (and the
option it was given with), the row or column, the value and what is allowed.
"""
from __future__ import annotations

import csv
import io
import math
import os
import stat
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from vibeam.errors import InputError, one_line, quote_value

#: the largest input file read (bytes): case files, reference and measurement tables
MAX_INPUT_BYTES = 10_000_000

_KINDS = ((stat.S_ISDIR, "a directory"), (stat.S_ISCHR, "a character device"), (stat.S_ISBLK, "a block device"),
          (stat.S_ISFIFO, "a named pipe"), (stat.S_ISSOCK, "a socket"))


def _error(where: str, what: str, why: str, access: bool = True):
    """One line: ``<file>: cannot read <what>: <why>`` (``access``), else ``<file>: <why>``."""
    return InputError(one_line(f"{where}: cannot read {what}: {why}" if access else f"{where}: {why}"))


def _content_error(where: str, what: str, why: str):
    return _error(where, what, why, access=False)


def _where(path, option: str) -> str:
    return f"{option} {path}" if option else f"{path}"


def _kind(mode: int) -> str:
    return next((name for test, name in _KINDS if test(mode)), "not a regular file")


def check_input_file(path, what: str = "input file", option: str = "") -> Path:
    """``path`` as a :class:`~pathlib.Path` if it names an existing regular file.

    Parameters
    ----------
    path : str or Path
        The file (a symlink to a regular file is followed).
    what : str
        What the file is, for messages (``case file``, ``reference file``, ...).
    option : str
        The command-line option that named it (``--reference``), for messages.

    Raises
    ------
    vibeam.case.schema.InputError
        One line naming the file: an empty path, no such file, or not a regular file
        (a directory, a device such as ``/dev/zero``, a named pipe, a socket).
    """
    if isinstance(path, str) and not path.strip():
        raise _error(_where(repr(path), option), what, "an empty path; allowed: the path of a regular file")
    p = Path(path)
    try:
        st = os.stat(p)
    except FileNotFoundError:
        raise _error(_where(p, option), what, "no such file") from None
    except OSError as e:
        raise _error(_where(p, option), what, e.strerror or str(e)) from None
    if not stat.S_ISREG(st.st_mode):
        raise _error(_where(p, option), what, f"{_kind(st.st_mode)}, not a regular file; allowed: a regular file")
    return p


def read_input_bytes(path, what: str = "input file", option: str = "", limit: int = MAX_INPUT_BYTES) -> bytes:
    """The content of an input file: a regular file of at most ``limit`` bytes.

    The file is checked by :func:`check_input_file`, opened without blocking (a named pipe
    put in its place meanwhile is refused by the check on the open file) and read up to
    ``limit + 1`` bytes, so a file that grows while it is read is refused as well.

    Raises
    ------
    vibeam.case.schema.InputError
        One line naming the file: see :func:`check_input_file`; larger than ``limit``
        (the message names the limit); an error while reading.
    """
    p = check_input_file(path, what, option)
    where = _where(p, option)
    too_big = (f"larger than the {limit / 1e6:g} MB limit for input files (vibeam.io.inputs.MAX_INPUT_BYTES); "
               f"allowed: a file of at most {limit} bytes")
    flags = os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_NOCTTY", 0) | getattr(os, "O_CLOEXEC", 0)
    try:
        fd = os.open(p, flags)
    except OSError as e:
        raise _error(where, what, e.strerror or str(e)) from None
    try:
        st = os.fstat(fd)
        if not stat.S_ISREG(st.st_mode):
            raise _error(where, what, f"{_kind(st.st_mode)}, not a regular file; allowed: a regular file")
        if st.st_size > limit:
            raise _error(where, what, f"{st.st_size} bytes, {too_big}")
        chunks, n = [], 0
        while True:
            b = os.read(fd, min(1 << 20, limit + 1 - n))
            if not b:
                break
            chunks.append(b)
            n += len(b)
            if n > limit:
                raise _error(where, what, too_big)
    except OSError as e:
        raise _error(where, what, e.strerror or str(e)) from None
    finally:
        os.close(fd)
    return b"".join(chunks)


def read_input_text(path, what: str = "input file", option: str = "", limit: int = MAX_INPUT_BYTES) -> str:
    """The text of an input file (:func:`read_input_bytes`): UTF-8, a byte-order mark dropped.

    Raises
    ------
    vibeam.case.schema.InputError
        As :func:`read_input_bytes`, or the bytes are not UTF-8 (the message names the byte).
    """
    data = read_input_bytes(path, what, option, limit)
    try:
        return data.decode("utf-8-sig")
    except UnicodeDecodeError as e:
        raise _error(_where(Path(path), option), what, f"not UTF-8 text ({e.reason} at byte {e.start})") from None


# ----------------------------------------------------------------------------- tables (CSV)
def read_csv_table(path, what: str = "data file", option: str = "") -> tuple[list[str], list[list[str]]]:
    """Header and data rows of a CSV input file (values stripped of surrounding blanks).

    Blank lines and lines whose first field starts with ``#`` are skipped.  The header
    names every column once; every data row has exactly one value per column.

    Returns
    -------
    head : list of str
    rows : list of list of str
        The data rows (below the header), each ``len(head)`` long.

    Raises
    ------
    vibeam.case.schema.InputError
        One line naming the file: see :func:`read_input_text`; not CSV (a NUL byte, an
        unclosed quote); no header; an empty or repeated column name; a row with missing
        or extra values (naming the data row, its count and the header's).
    """
    text = read_input_text(path, what, option)
    where = _where(Path(path), option)
    try:
        rows = [[c.strip() for c in r] for r in csv.reader(io.StringIO(text, newline=""), strict=True)
                if r and any(c.strip() for c in r) and not r[0].lstrip().startswith("#")]
    except csv.Error as e:
        raise _error(where, what, f"not a CSV table ({e})") from None
    if not rows:
        raise _error(where, what, "empty; expected a header line naming the columns and one row per point")
    head = rows[0]
    for j, h in enumerate(head):
        if not h:
            raise _content_error(where, what, f"column {j + 1} of the header has no name")
        if head.index(h) != j:
            raise _content_error(where, what, f"column {quote_value(h)} appears twice in the header")
    for i, r in enumerate(rows[1:]):
        if len(r) != len(head):
            raise _content_error(where, what, f"data row {i + 1} has {len(r)} value(s), the header {len(head)} "
                                 f"column(s) ({','.join(head)[:80]}); allowed: one value per column in every row")
    return head, rows[1:]


def column_floats(path, head, rows, name: str, low: float | None = None, low_open: bool = False,
                  what: str = "data file", option: str = "") -> np.ndarray:
    """A numeric column of :func:`read_csv_table` by name: every value a finite number, and
    ``> low`` (``low_open``) or ``>= low`` when ``low`` is given.

    Raises
    ------
    vibeam.case.schema.InputError
        Naming the file, the column, the value, its data row and what is allowed.
    """
    j = head.index(name)
    need = "a finite number" + ("" if low is None else f" {'>' if low_open else '>='} {low:g}")
    out = np.empty(len(rows))
    for i, row in enumerate(rows):
        v = row[j]
        try:
            x = float(v)
        except ValueError:
            x = math.nan
        if not math.isfinite(x) or (low is not None and (x <= low if low_open else x < low)):
            raise _content_error(_where(Path(path), option), what,
                                 f"'{name}' = {quote_value(v)} (data row {i + 1}): allowed: {need}")
        out[i] = x
    return out


#: the column pairs of an FRC table: (frequency column, amplitude column)
FRC_PAIRS = (("frequency_hz", "amplitude_mm"), ("Omega", "amplitude"))
FRC_OPTIONAL = ("direction", "sigma")
DIRECTIONS = ("up", "down")


@dataclass
class FRCTable:
    """Measured or reference FRC points as read by :func:`read_frc_table`.

    Attributes
    ----------
    source : str
        The file.
    x_name, y_name : str
        ``frequency_hz`` / ``amplitude_mm`` (physical) or ``Omega`` / ``amplitude``.
    x, y : ndarray, shape (n,)
        In file order.
    direction : ndarray of str, shape (n,)
        ``up`` or ``down`` (``up`` without a ``direction`` column).
    sigma : ndarray, shape (n,) or None
        Standard deviation of each amplitude (units of ``y``); None without the column.
    columns : list of str
        The header as given.
    """

    source: str
    x_name: str
    y_name: str
    x: np.ndarray
    y: np.ndarray
    direction: np.ndarray
    sigma: np.ndarray | None
    columns: list

    @property
    def physical(self) -> bool:
        return self.x_name == "frequency_hz"

    @property
    def has_direction(self) -> bool:
        return "direction" in self.columns


def read_frc_table(path, what: str = "reference file", option: str = "") -> FRCTable:
    """Read a table of measured or reference FRC points (the rules in the module docstring).

    Parameters
    ----------
    path : str or Path
        The CSV file.
    what, option : str
        What the file is and the option that named it, for messages.

    Returns
    -------
    FRCTable

    Raises
    ------
    vibeam.case.schema.InputError
        One line naming the file and what is wrong (module docstring).
    """
    head, rows = read_csv_table(path, what, option)
    where = _where(Path(path), option)
    allowed = "frequency_hz,amplitude_mm or Omega,amplitude, optionally direction and sigma"
    pairs = [p for p in FRC_PAIRS if p[0] in head and p[1] in head]
    if len(pairs) != 1:
        why = "both column pairs" if pairs else "no column pair"
        raise _content_error(where, what, f"header {','.join(head)[:80]!r} has {why}; allowed columns: "
                             f"{allowed}")
    pair = pairs[0]
    unknown = [h for h in head if h not in (*pair, *FRC_OPTIONAL)]
    if unknown:
        raise _content_error(where, what, f"column {quote_value(unknown[0])} not allowed; allowed columns: {allowed}")
    if not rows:
        raise _content_error(where, what, "no data rows below the header")
    kw = dict(what=what, option=option)
    x = column_floats(path, head, rows, pair[0], low=0.0, low_open=True, **kw)
    y = column_floats(path, head, rows, pair[1], low=0.0, **kw)
    if "direction" in head:
        j = head.index("direction")
        d = np.array([r[j].lower() for r in rows], dtype=object)
        for i, v in enumerate(d):
            if v not in DIRECTIONS:
                raise _content_error(where, what, f"'direction' = {quote_value(rows[i][j])} (data row {i + 1}): "
                                     f"allowed: {', '.join(DIRECTIONS)}")
    else:
        d = np.array(["up"] * len(rows), dtype=object)
    sigma = column_floats(path, head, rows, "sigma", low=0.0, low_open=True, **kw) if "sigma" in head else None
    return FRCTable(str(path), pair[0], pair[1], x, y, d, sigma, list(head))
