"""The physics of finished sweep runs, as ``vibeam run`` prints it after the timings.

For every run: the peak amplitude and its frequency per sweep direction, the number of points
of each period-n class and of each status, and the jumps of the up and down sweeps (where the
amplitude changes by more than :data:`JUMP_FRACTION` of the run's peak between two neighbouring
points: the grid brackets the jump frequency).  With several runs, the runs are compared with a
reference run (:func:`reference_run`): the highest-fidelity rung of a ladder (most modes, the
all-modes rung), else the first run; a one-run case has no comparison.
"""
from __future__ import annotations

import numpy as np

#: an amplitude change between neighbouring points of a sweep larger than this fraction of the
#: run's peak amplitude is reported as a jump (a saddle-node or grazing jump of the FRC)
JUMP_FRACTION = 0.2


def _axes(r) -> tuple:
    """(x, amplitude, x unit, amplitude name and unit) of a run, physical where it has them."""
    d = r.data
    if "frequency_hz" in d and "amplitude_mm" in d:
        return np.asarray(d["frequency_hz"], float), np.asarray(d["amplitude_mm"], float), "Hz", "mm"
    return np.asarray(d["Omega"], float), np.asarray(d["amplitude"], float), "(Omega)", ""


def _directions(r, n) -> np.ndarray:
    return np.asarray([str(v) for v in r.data.get("direction", ["up"] * n)])


def _class(p: int) -> str:
    p = int(p)
    return "no impact" if p == -1 else "non-periodic" if p == 0 else f"period-{p}"


def reference_run(runs):
    """The run the others are compared with: of runs with modal amplitudes
    (``mode_amplitudes``, one column per mode) the one with the most modes (the all-modes rung
    of a fidelity ladder; the last of equals, as a ladder lists its rungs coarse to fine), else
    the first run; None for fewer than two runs."""
    runs = list(runs)
    if len(runs) < 2:
        return None
    width = [np.shape(r.data["mode_amplitudes"])[-1] if "mode_amplitudes" in r.data else 0 for r in runs]
    if max(width) > 0 and len(set(width)) > 1:
        best = max(width)
        return [r for r, w in zip(runs, width) if w == best][-1]
    return runs[0]


def peaks(r) -> dict:
    """``{direction: (peak amplitude, its frequency)}`` of a run (amplitude in mm or Q,
    frequency in Hz or Omega); NaN where a sweep has no finite amplitude."""
    x, a, _, _ = _axes(r)
    dirs = _directions(r, len(x))
    out = {}
    for d in ("up", "down"):
        s = (dirs == d) & np.isfinite(a)
        if (dirs == d).any():
            out[d] = (float(np.max(a[s])), float(x[s][np.argmax(a[s])])) if s.any() else (np.nan, np.nan)
    return out


def jumps(r, fraction: float = JUMP_FRACTION) -> dict:
    """``{direction: [(x_from, x_to, dA), ...]}``: neighbouring points of each sweep, in the
    order the sweep visits them (up: increasing frequency, down: decreasing), whose amplitudes
    differ by more than ``fraction`` of the run's peak amplitude."""
    x, a, _, _ = _axes(r)
    dirs = _directions(r, len(x))
    top = np.nanmax(np.abs(a)) if np.isfinite(a).any() else np.nan
    out = {}
    for d in ("up", "down"):
        s = np.flatnonzero(dirs == d)
        if not s.size:
            continue
        o = s[np.argsort(x[s], kind="stable")]
        if d == "down":
            o = o[::-1]
        xs, ys = x[o], a[o]
        da = np.diff(ys)
        big = np.isfinite(da) & (np.abs(da) > fraction * top)
        out[d] = [(float(xs[i]), float(xs[i + 1]), float(da[i])) for i in np.flatnonzero(big)]
    return out


def counts(r) -> tuple:
    """(``{period class: n}``, ``{status: n}``) of a run's points, in order of first use."""
    per = [_class(p) for p in np.asarray(r.data.get("period", []))]
    st = [str(s) for s in np.asarray(r.data.get("status", []), dtype=object)]
    pc, sc = {}, {}
    for p in sorted(set(per), key=lambda c: (c == "non-periodic", c == "no impact", len(c), c)):
        pc[p] = per.count(p)
    for s in dict.fromkeys(st):
        sc[s] = st.count(s)
    return pc, sc


def max_difference(r, ref) -> float | None:
    """max |A_r - A_ref| over the points both have (same grid and directions); None if the
    grids differ, NaN if no point has both amplitudes."""
    x, a, _, _ = _axes(r)
    xr, ar, _, _ = _axes(ref)
    if len(a) != len(ar) or not np.allclose(r.data["Omega"], ref.data["Omega"]) or \
            not (_directions(r, len(x)) == _directions(ref, len(xr))).all():
        return None
    d = np.abs(a - ar)
    return float(np.nanmax(d)) if np.isfinite(d).any() else float("nan")


def lines(runs) -> list:
    """The printed summary (a list of lines): the timing table with the comparison column
    (several runs only), then each run's physics (module docstring)."""
    runs = list(runs)
    if not runs:
        return []
    ref = reference_run(runs)
    _, _, xu, au = _axes(runs[0])
    unit = f" ({au})" if au else ""
    wn = max([22] + [len(r.name) + 2 for r in runs])          # columns as wide as the longest name
    wm = max([12] + [len(r.method) + 2 for r in runs])
    head = f"{'run':<{wn}}{'method':<{wm}}{'points':>7}{'compute (s)':>13}"
    wd = 0
    if ref is not None:
        col = f"max |dA| vs {ref.name}{unit}"
        wd = max(30, len(col) + 2)
        head += f"{col:>{wd}}"
    out = [head, "-" * len(head)]
    for r in runs:
        row = f"{r.name:<{wn}}{r.method:<{wm}}{r.n_points:>7}{r.wall_time_s:>13.3f}"
        if ref is not None:
            if r is ref:
                diff = "reference"
            else:
                d = max_difference(r, ref)
                diff = "n/a (different grid)" if d is None else f"{d:.3e}" if np.isfinite(d) else "n/a"
            row += f"{diff:>{wd}}"
        n_bad = int(sum(1 for s in r.data.get("status", []) if s != "ok"))
        out.append(row + (f"  [{n_bad} point(s) not ok]" if n_bad else ""))
    A_ = (lambda v: f"{v:.4g} {au}") if au else (lambda v: f"Q = {v:.4g}")
    X_ = (lambda v: f"{v:.4g} {xu}") if au else (lambda v: f"Omega = {v:.4g}")
    out.append(f"\nphysics of each run (jumps: |dA| > {JUMP_FRACTION:.0%} of the run's peak between neighbouring "
               f"points of a sweep)" + (f"; [difference from '{ref.name}']" if ref is not None else ""))
    ref_peaks = peaks(ref) if ref is not None else {}
    for r in runs:
        out.append(f"  {r.name}")
        parts = []
        for d, (A, f) in peaks(r).items():
            txt = f"{A_(A)} at {X_(f)} ({d})"
            if ref is not None and r is not ref and d in ref_peaks and np.isfinite(ref_peaks[d][0]) \
                    and ref_peaks[d][0] != 0 and np.isfinite(A):
                Ar, fr = ref_peaks[d]
                txt += f" [{(A - Ar) / abs(Ar):+.1%}, {f - fr:+.3g}{' ' + xu if au else ''}]"
            parts.append(txt)
        out.append("    peak amplitude: " + (", ".join(parts) if parts else "none"))
        pc, sc = counts(r)
        out.append("    points: " + ", ".join(f"{k} {v}" for k, v in pc.items())
                   + "; status: " + ", ".join(f"{k} {v}" for k, v in sc.items()))
        txt = []
        for d, items in jumps(r).items():
            if items:
                txt.append(f"{d} sweep " + ", ".join(f"{X_(a)} -> {X_(b)} (d{'A' if au else 'Q'} {dA:+.4g}{' ' + au if au else ''})"
                                                     for a, b, dA in items))
            else:
                txt.append(f"{d} sweep none")
        out.append("    jumps: " + ("; ".join(txt) if txt else "none"))
    return out


def print_summary(runs) -> None:
    """Print :func:`lines`."""
    for line in lines(runs):
        print(line)
