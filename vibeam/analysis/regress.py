"""``vibeam regress``: compare new FRCs with reference FRCs, point by point.

A reference is either a vibeam results file (HDF5; runs compared by name, points
by direction and forcing frequency) or a CSV of measured/digitised points with a
header naming its columns: ``frequency_hz,amplitude_mm`` (physical) or
``Omega,amplitude`` (nondimensional); the new FRC of each run (its ``up``
branch) is then interpolated linearly at the CSV frequencies.

A point that is the same orbit in both (the same period 1..8, or no impact, and
settled) passes when ``|A - A_ref| <= atol + rtol |A_ref|``.  Any other point
of an HDF5 reference (non-periodic, ``unsettled``, or of another period) is one
sample of an attractor, reproducible only in its statistics (a chaotic
trajectory differs after a few hundred periods between CPUs, BLAS kernels and
compilers), and is compared by the spread of its per-period amplitude ``Q_k``
(:func:`vibeam.engine.records.amplitude_spread`, measured over ``[sweep]
statistics_periods`` periods for a non-periodic point):

* the means agree by Welch's two-sample test with batch-means standard errors
  (:func:`vibeam.engine.records.means_agree`: the ``Q_k`` of a chaotic attractor are
  correlated over a few periods, so ``std / sqrt(n)`` would understate the
  error; the critical value is Student's t at the false-alarm probability of
  ``sigmas`` normal deviations, so a short record widens the bound rather than
  raising false alarms);
* the smallest and the largest ``Q_k`` agree within ``spread_range`` times the
  larger of the two ranges ``max - min`` (a different attractor, e.g. the
  no-impact orbit against chaos, moves them by the whole range);

each plus ``atol + rtol |ref|``.  With ``period = true`` the period-n
classifications must agree too.  A value that is NaN in both files (the same
failed point) passes; NaN in one file only is a regression.

Multistability: in a continuation sweep each point starts from the previous
point's final state.  After a non-periodic point (or an unsettled one) that
state is reproducible only in its statistics, so where several attractors
coexist the next point may land on another one on another machine, or leave a
chaotic transient at another time.  A point whose predecessor on its sweep line
is non-periodic or unsettled in either file, and whose attractor differs
(another period classification) or which is unsettled in either file, is
therefore reported as *multistable* (another attractor, or a transient, reached
from an irreproducible state), counted, and not a regression.  So is a point that
is non-periodic in both files and unsettled in either, wherever it starts: the
length of a chaotic transient is not reproducible from one machine to another (a
model's round-off, e.g. a continuum's modes from ARPACK on another BLAS kernel,
grows exponentially along it), so one file may record its attractor and the other
the transient.  Every other point is compared as above.  The first point of each
line and every point after a periodic one start from reproducible states and
are compared strictly.

Tolerances come from the case's ``[regress]`` table (defaults: atol 0, rtol
1e-6, period true, spread_sigmas 4, spread_range 0.5).  A file without
``amplitude_sem`` (made before it existed) takes the other file's ratio of
batch-means to i.i.d. standard error for its own (the same attractor has the
same correlation), or the i.i.d. one when neither has it.  A reference without
the spread datasets is compared by the amplitude at every point.
"""
from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from vibeam.analysis.maps import all_runs
from vibeam.engine.records import means_agree
from vibeam.errors import InputError, quote_value
from vibeam.io.inputs import FRCTable, check_input_file, read_frc_table
from vibeam.io.results import read_results


@dataclass
class RegressRow:
    run: str
    points: int
    failures: int
    max_abs: float
    max_rel: float
    period_mismatch: int
    note: str = ""
    spread_points: int = 0      # points compared by their spread (non-periodic, unsettled, ...)
    spread_failures: int = 0
    multistable: int = 0        # other attractor after a non-periodic predecessor (not a failure)

    @property
    def ok(self) -> bool:
        return self.failures == 0 and self.points > 0


def read_csv_reference(path):
    """A CSV reference: :func:`vibeam.io.inputs.read_frc_table`, the one reader of measured and
    reference tables (``vibeam fit`` reads them too).

    Returns
    -------
    vibeam.io.inputs.FRCTable

    Raises
    ------
    InputError
        If the file is not a regular file of at most 10 MB, is empty, its header is not
        ``frequency_hz,amplitude_mm`` or ``Omega,amplitude`` (optionally ``direction`` and
        ``sigma``), a row has missing or extra values, or a value is out of range.
    """
    return read_frc_table(path, "reference file", "--reference")


def load_results(path, option: str = "--results") -> dict:
    """:func:`vibeam.io.results.read_results` of a file that must be a vibeam results file.

    Raises
    ------
    InputError
        If the file is missing, empty, truncated, not HDF5, or holds no runs or maps
        with amplitudes.
    """
    path = check_input_file(path, "results file", option)
    try:
        res = read_results(path)
    except (OSError, KeyError, ValueError) as e:
        why = getattr(e, "strerror", None) or (str(e).splitlines()[0] if str(e) else type(e).__name__)
        raise InputError(f"{option} {path}: not a readable results file ({why})") from None

    runs = all_runs(res)
    if not runs:
        raise InputError(f"{option} {path}: holds no runs or maps (an interrupted run? finish it with --resume)")
    for name, r in runs.items():
        for k in ("amplitude", "direction", "Omega"):
            if k not in r:
                raise InputError(f"{option} {path}: run {name!r} has no {k!r} dataset")
    return res


def read_reference(path):
    """Check a reference (CSV or results file) before anything runs; returns it read.

    Raises
    ------
    InputError
        If it is missing or unreadable (see :func:`read_csv_reference`, :func:`load_results`).
    """
    path = Path(path)
    if path.suffix.lower() == ".csv":
        return read_csv_reference(path)
    return load_results(path, "--reference")


def compare(new: dict, ref_path, atol: float = 0.0, rtol: float = 1e-6, period: bool = True, *,
            sigmas: float = 4.0, spread_range: float = 0.5, continuation: bool = True) -> list[RegressRow]:
    """Compare ``new`` (``read_results`` layout: ``{"runs": {name: datasets}}``) with a reference.

    Parameter maps are compared line by line (:func:`vibeam.analysis.maps.map_lines`).
    ``sigmas`` and ``spread_range`` are the tolerances of the points compared by
    their spread (module docstring).  ``continuation``: the sweeps handed each
    point's final state to the next (``[sweep] continuation``), so a point after a
    non-periodic one may land on another coexisting attractor (module docstring).
    Returns one :class:`RegressRow` per compared run or map line (or per new run
    for CSV).
    """
    ref_path = Path(ref_path)
    new = dict(new, runs=all_runs(new))
    rows = []
    if ref_path.suffix.lower() == ".csv":
        return _compare_csv(new, read_csv_reference(ref_path), atol, rtol)
    ref = load_results(ref_path, "--reference")
    for name, r in all_runs(ref).items():
        if name not in new["runs"]:
            rows.append(RegressRow(name, 0, 1, np.nan, np.nan, 0, "run missing from the new results"))
            continue
        n = new["runs"][name]
        idx_n, idx_r = match_points(n, r)
        if not idx_n:
            rows.append(RegressRow(name, 0, 1, np.nan, np.nan, 0, "no common frequency points"))
            continue
        pn = n["period"][idx_n] if period and "period" in n and "period" in r else None
        pr = r["period"][idx_r] if pn is not None else None
        sampled = _sampled(n, r, idx_n, idx_r)
        other = _other_attractor(n, r, idx_n, idx_r) if continuation else np.zeros(len(idx_n), bool)
        bad_spread = _spread_bad(n, r, idx_n, idx_r, sampled & ~other, atol, rtol, sigmas, spread_range)
        row = _row(name, n["amplitude"][idx_n], r["amplitude"][idx_r], atol, rtol, pn, pr,
                   mask=~sampled & ~other, extra_bad=bad_spread, excused=other)
        row.spread_points, row.spread_failures = int((sampled & ~other).sum()), int(bad_spread.sum())
        row.multistable = int(other.sum())
        rows.append(row)
    return rows


def _compare_csv(new: dict, t, atol: float, rtol: float) -> list[RegressRow]:
    """Each run's FRC interpolated linearly at the table's points, on the sweep of each point's
    direction (``up`` without a ``direction`` column), against the table's amplitudes."""
    rows = []
    where = f"--reference {t.source}"
    for name, run in new["runs"].items():
        if t.x_name not in run or t.y_name not in run:
            raise InputError(f"{where}: the columns '{t.x_name},{t.y_name}' are not in the results of run "
                             f"{name!r} (a nondimensional scene has 'Omega,amplitude' only); allowed: a table "
                             f"in the scene's units")
        xr = np.asarray(run[t.x_name], float)
        dirs = np.array([str(d) for d in run["direction"]]) if "direction" in run else np.full(xr.size, "up")
        y_new = np.full(t.x.size, np.nan)
        inside = np.zeros(t.x.size, bool)
        for d in np.unique(t.direction):
            sel = dirs == d
            if not sel.any():
                raise InputError(f"{where}: points swept '{d}'{'' if t.has_direction else ' (no direction column: up)'}"
                                 f" but run {name!r} has no '{d}' sweep; allowed: the directions of [sweep] direction "
                                 f"({', '.join(sorted(set(dirs)))})")
            xs, ys = xr[sel], np.asarray(run[t.y_name], float)[sel]
            o = np.argsort(xs)
            m = (t.direction == d) & (t.x >= xs[o][0]) & (t.x <= xs[o][-1])
            y_new[m] = np.interp(t.x[m], xs[o], ys[o])
            inside |= m
        if not inside.any():
            raise InputError(f"{where}: none of its {t.x.size} points lies inside the sweep of run {name!r} "
                             f"({t.x_name} {xr.min():g} ... {xr.max():g}); allowed: points inside the swept range")
        note = f"{int(inside.sum())} of {t.x.size} CSV points inside the sweep"
        if t.sigma is not None:
            note += "; its sigma column is not used (tolerances: [regress])"
        rows.append(_row(name, y_new[inside], t.y[inside], atol, rtol, None, None, note=note))
    return rows


def _identity(d: dict) -> dict:
    """What makes a case dump (``Case.model_dump``) the same scene for ``regress --results``:
    the name, the model, the effects, the mapped parameter and the runs (name, method, model
    and effects overrides); None values dropped.  The grid, periods and tolerances are left out:
    a quick variant is the same case, and a grid that differs shows as points not in common."""
    def clean(v):
        if isinstance(v, dict):
            return {k: clean(x) for k, x in v.items() if x is not None and x != {}}
        if isinstance(v, list):
            return [clean(x) for x in v]
        return v

    runs = [{k: r.get(k) for k in ("name", "method", "model", "effects")} for r in d.get("run", [])]
    m = d.get("map") or {}
    return clean({"name": d.get("name"), "model": d.get("model"), "effects": d.get("effects"),
                  "map": m.get("parameter"), "run": runs})


def _first_difference(a, b, key=""):
    """The first key path where two nested values differ, with both values."""
    if isinstance(a, dict) and isinstance(b, dict):
        for k in list(a) + [k for k in b if k not in a]:
            if a.get(k) != b.get(k):
                return _first_difference(a.get(k), b.get(k), f"{key}.{k}" if key else str(k))
    if isinstance(a, list) and isinstance(b, list) and len(a) == len(b):
        for i, (x, y) in enumerate(zip(a, b)):
            if x != y:
                return _first_difference(x, y, f"{key}[{i}]")
    return key, a, b


def check_results_of_case(case, res: dict, path, source: str = "", option: str = "--results") -> None:
    """Refuse a results file (``vibeam regress --results``, or a results-file ``--reference``)
    written by another case.

    The case stored in the file (``case_json``, the case as run) must be the same scene as
    ``case`` (:func:`_identity`: name, model, effects, mapped parameter, runs); a file
    without the stored case is checked by its case name.

    Parameters
    ----------
    case : vibeam.case.schema.Case
    res : dict
        The file as :func:`load_results` reads it.
    path : str or Path
    source : str
        The case file's name (for the message).
    option : str
        The option that named the file (``--results`` or ``--reference``).

    Raises
    ------
    InputError
        Naming the option, the file, the first differing key and both values.
    """
    attrs = res.get("attrs", {})
    where = f"{option} {path}"
    mine = _identity(json.loads(case.model_dump_json()))
    stored = str(attrs.get("case_json", "") or "")
    if stored:
        try:
            theirs = _identity(json.loads(stored))
        except (ValueError, AttributeError, TypeError):
            raise InputError(f"{where}: the case stored in the file cannot be read; allowed: a results file "
                             f"of {source or case.name}") from None
        if theirs == mine:
            return
        key, a, b = _first_difference(theirs, mine)
        raise InputError(f"{where}: written by another case ('{key}' = {quote_value(a)} in the file, {quote_value(b)} in "
                         f"{source or case.name}); allowed: results of {source or case.name} (vibeam run)")
    name = str(attrs.get("case_name", "") or "")
    if name and name != case.name:
        raise InputError(f"{where}: written by case {name!r}, not {case.name!r}; allowed: results of "
                         f"{source or case.name} (vibeam run)")


def check_reference_of_case(case, ref, path, source: str = "") -> None:
    """Refuse a CSV reference (:class:`vibeam.io.inputs.FRCTable`) that cannot be compared with the
    case's runs: physical columns for a nondimensional scene, or a direction the case does not
    sweep.  A results-file reference is compared by run name and left alone here.

    Raises
    ------
    InputError
        Naming the file, the column or direction and what is allowed.
    """
    if not isinstance(ref, FRCTable):
        return
    where = f"--reference {path}"
    spec = case.model_spec()
    if ref.physical and not getattr(spec, "physical", False):
        raise InputError(f"{where}: the columns 'frequency_hz,amplitude_mm' need a physical scene; "
                         f"{source or case.name} is nondimensional; allowed: 'Omega,amplitude'")
    swept = {"up": ("up",), "down": ("down",), "both": ("up", "down")}[case.sweep.direction]
    for d in ("up", "down"):
        if (ref.direction == d).any() and d not in swept:
            raise InputError(f"{where}: points swept '{d}'{'' if ref.has_direction else ' (no direction column: up)'}"
                             f" but {source or case.name} sweeps [sweep] direction = {case.sweep.direction!r}; "
                             f"allowed: {', '.join(swept)}")


SPREAD_KEYS = ("amplitude_mean", "amplitude_std", "amplitude_min", "amplitude_max", "record_periods")


def _sampled(n: dict, r: dict, idx_n, idx_r) -> np.ndarray:
    """Points that are samples of an attractor rather than the same orbit in both runs: not
    the same period (1..8 or no impact), or not settled in one of them.  False everywhere when
    a run lacks the spread datasets (then every point is compared by its amplitude)."""
    if not all(k in n and k in r for k in SPREAD_KEYS) or "period" not in n or "period" not in r:
        return np.zeros(len(idx_n), bool)
    pn, pr = np.asarray(n["period"])[idx_n], np.asarray(r["period"])[idx_r]
    orbit = (pn == pr) & ((pn >= 1) | (pn == -1))
    if "status" in n and "status" in r:
        sn = np.array([str(s) for s in np.asarray(n["status"])[idx_n]])
        sr = np.array([str(s) for s in np.asarray(r["status"])[idx_r]])
        orbit &= (sn != "unsettled") & (sr != "unsettled")
    return ~orbit


def _line_predecessors(run: dict, idx) -> np.ndarray:
    """For the points ``idx`` of a run, the index of the point visited just before each on its
    sweep line (same direction; ``up`` in increasing, ``down`` in decreasing Omega), -1 for the
    first point of a line."""
    x = np.asarray(run["Omega"], float)
    d = np.asarray([str(v) for v in run["direction"]])
    out = np.full(len(idx), -1)
    for k, i in enumerate(idx):
        same = np.flatnonzero(d == d[i])
        before = same[x[same] < x[i]] if d[i] != "down" else same[x[same] > x[i]]
        if before.size:
            out[k] = before[np.argmax(x[before])] if d[i] != "down" else before[np.argmin(x[before])]
    return out


def _irreproducible(run: dict, j: np.ndarray) -> np.ndarray:
    """Were the points ``j`` (-1: none) non-periodic or unsettled, i.e. is their final state
    reproducible only in its statistics?"""
    j = np.asarray(j)
    has = j >= 0
    jj = np.where(has, j, 0)
    p = np.asarray(run["period"])[jj] == 0
    if "status" in run:
        p |= np.array([str(s) == "unsettled" for s in np.asarray(run["status"])[jj]], bool)
    return has & p


def _other_attractor(n: dict, r: dict, idx_n, idx_r) -> np.ndarray:
    """Points whose predecessor on the sweep line is non-periodic or unsettled in either run and
    whose period classification differs, or which are unsettled in either: another attractor of
    a multistable point, or a chaotic transient, reached from a state that no two machines share;
    and points non-periodic in both runs and unsettled in either, wherever they start: a chaotic
    transient whose length no two machines share (module docstring)."""
    if "period" not in n or "period" not in r or "direction" not in n or "direction" not in r:
        return np.zeros(len(idx_n), bool)
    after = _irreproducible(n, _line_predecessors(n, idx_n)) | _irreproducible(r, _line_predecessors(r, idx_r))
    differ = np.asarray(n["period"])[idx_n] != np.asarray(r["period"])[idx_r]
    unsettled = np.zeros(len(idx_n), bool)
    for run, idx in ((n, idx_n), (r, idx_r)):
        if "status" in run:
            unsettled |= np.array([str(x) == "unsettled" for x in np.asarray(run["status"])[idx]], bool)
    transient = unsettled & _irreproducible(n, np.asarray(idx_n)) & _irreproducible(r, np.asarray(idx_r))
    return (after & (differ | unsettled)) | transient


def _standard_errors(g: dict, h: dict) -> tuple:
    """Batch-means standard errors and degrees of freedom of two spread samples ``g``, ``h``
    (arrays); a side without ``amplitude_sem`` takes the other's inflation over the i.i.d.
    error, or the i.i.d. error when neither has it (module docstring)."""
    def iid(s):
        n = np.maximum(np.asarray(s["record_periods"], float), 1.0)
        return np.asarray(s["amplitude_std"], float) / np.sqrt(n), n - 1.0

    def own(s):
        if "amplitude_sem" not in s:
            return None
        return np.asarray(s["amplitude_sem"], float), np.asarray(s.get("amplitude_sem_dof", 0), float)

    a, b = own(g), own(h)
    if a is None and b is None:
        return (*iid(g), *iid(h))
    if a is None or b is None:
        have, lack = (h, g) if a is None else (g, h)
        sem, dof = own(have)
        i_have, _ = iid(have)
        i_lack, _ = iid(lack)
        with np.errstate(invalid="ignore", divide="ignore"):
            infl = np.where(i_have > 0, np.maximum(sem / i_have, 1.0), 1.0)
        est = (i_lack * infl, dof)
        return (*est, sem, dof) if a is None else (sem, dof, *est)
    return (*a, *b)


def _spread_bad(n: dict, r: dict, idx_n, idx_r, sel, atol, rtol, sigmas, spread_range) -> np.ndarray:
    """Points of ``sel`` (samples of an attractor) whose spread disagrees with the reference's."""
    bad = np.zeros(len(idx_n), bool)
    if not sel.any():
        return bad
    opt = ("amplitude_sem", "amplitude_sem_dof")
    g = {k: np.asarray(n[k], float)[idx_n][sel] for k in SPREAD_KEYS + opt if k in n}
    h = {k: np.asarray(r[k], float)[idx_r][sel] for k in SPREAD_KEYS + opt if k in r}
    sg, vg, sh, vh = _standard_errors(g, h)
    rng = np.maximum(g["amplitude_max"] - g["amplitude_min"], h["amplitude_max"] - h["amplitude_min"])

    def within(a, b, tol):
        with np.errstate(invalid="ignore"):
            return (np.abs(a - b) <= tol + atol + rtol * np.abs(b)) | (np.isnan(a) & np.isnan(b))

    # the mean: Welch's test, widened by the amplitude tolerance atol + rtol |ref|
    mean_ok = (within(g["amplitude_mean"], h["amplitude_mean"], 0.0)
               | means_agree(g["amplitude_mean"], sg, vg, h["amplitude_mean"], sh, vh, sigmas))
    ok = (mean_ok & within(g["amplitude_min"], h["amplitude_min"], spread_range * rng)
          & within(g["amplitude_max"], h["amplitude_max"], spread_range * rng))
    bad[sel] = ~ok
    return bad


def match_points(new: dict, ref: dict, rel: float = 1e-6) -> tuple[list, list]:
    """Indices ``(i_new, i_ref)`` of the points common to two runs.

    Points are matched by direction and by the grid's own coordinate:
    ``frequency_hz`` when both runs have it (a physical grid is given in Hz;
    its ``Omega = f / f_n`` carries the round-off of the model's ``f_n``, which
    for a calibrated FE model differs between library versions at ~1e-11),
    otherwise ``Omega``.  Two points match when they differ by less than
    ``rel`` times the smallest grid spacing (or ``rel`` times the value for a
    one-point grid), so a different grid never matches by accident.
    """
    key = "frequency_hz" if "frequency_hz" in new and "frequency_hz" in ref else "Omega"
    xn = np.asarray(new[key], float)
    xr = np.asarray(ref[key], float)
    dn = np.asarray([str(d) for d in new["direction"]])
    dr = np.asarray([str(d) for d in ref["direction"]])
    grid = np.unique(np.concatenate([xn, xr]))
    steps = np.diff(grid)
    steps = steps[steps > 1e-9 * max(np.max(np.abs(grid)), 1e-300)] if steps.size else steps
    tol = rel * (np.min(steps) if steps.size else max(np.max(np.abs(grid)), 1e-300))
    idx_n, idx_r = [], []
    used = set()
    for i in range(xn.size):
        cand = np.flatnonzero((dr == dn[i]) & (np.abs(xr - xn[i]) <= tol))
        cand = [j for j in cand if j not in used]
        if cand:
            j = min(cand, key=lambda j: abs(xr[j] - xn[i]))
            used.add(j)
            idx_n.append(i)
            idx_r.append(j)
    return idx_n, idx_r


def _row(name, a, a_ref, atol, rtol, p, p_ref, note="", mask=None, extra_bad=None, excused=None):
    """Amplitude check (on the points of ``mask``, default all), period check (all points but the
    ``excused`` ones: another attractor of a multistable point) and any other failed points
    (``extra_bad``)."""
    a, a_ref = np.asarray(a, float), np.asarray(a_ref, float)
    d = np.abs(a - a_ref)
    both_nan = np.isnan(a) & np.isnan(a_ref)
    bad = ~((d <= atol + rtol * np.abs(a_ref)) | both_nan)
    if mask is not None:
        bad &= mask
        d = np.where(mask, d, np.nan)
    if extra_bad is not None:
        bad |= extra_bad
    pm = 0
    if p is not None:
        mism = np.asarray(p) != np.asarray(p_ref)
        if excused is not None:
            mism &= ~excused
        pm = int(mism.sum())
        bad |= mism
    with np.errstate(invalid="ignore", divide="ignore"):
        rel = d / np.abs(a_ref)
    return RegressRow(name, len(a), int(bad.sum()),
                      float(np.nanmax(d)) if np.isfinite(d).any() else np.nan,
                      float(np.nanmax(rel)) if np.isfinite(rel).any() else np.nan, pm, note)


def print_rows(rows, atol, rtol, sigmas: float | None = None, spread_range: float | None = None) -> None:
    print(f"tolerance: |A - A_ref| <= {atol:g} + {rtol:g} |A_ref|")
    if sigmas is not None and any(r.spread_points for r in rows):
        print(f"non-periodic / unsettled / other-period points by their spread: means by Welch's test at "
              f"{sigmas:g} sigma (batch-means errors), min and max within {spread_range:g} of the range")
    if any(r.multistable for r in rows):
        print("multistable: another attractor reached after a non-periodic predecessor (its start state is "
              "reproducible only in statistics); not a regression")
    w = max([24] + [len(r.run) + 2 for r in rows])       # as wide as the longest run name
    head = f"{'run':<{w}}{'points':>7}{'failed':>8}{'max |dA|':>12}{'max rel':>11}{'period diff':>12}  verdict"
    print(head)
    print("-" * len(head))
    for r in rows:
        verdict = "ok" if r.ok else "REGRESSION"
        note = r.note
        if r.spread_points:
            note = (note + "; " if note else "") + (f"{r.spread_points} point(s) by spread, "
                                                     f"{r.spread_failures} failed")
        if r.multistable:
            note = (note + "; " if note else "") + f"{r.multistable} multistable"
        print(f"{r.run:<{w}}{r.points:>7}{r.failures:>8}{r.max_abs:>12.3e}{r.max_rel:>11.3e}"
              f"{r.period_mismatch:>12}  {verdict}" + (f"  ({note})" if note else ""))
