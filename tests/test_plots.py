"""Every figure of every shipped case's quick variant: non-empty, labelled axes with units,
titles, legends without empty entries (the matplotlib Figure objects, not pixels); the data
each figure draws, read back from its artists, equal to its results file (read with h5py);
and the plot conventions (range bars at non-periodic points, up/down, colours, one-value maps).

The data checks (``check_*_data``, :func:`assert_png_shows_results`, :func:`written_figures`)
are used by the tests of the command line's PNGs in other modules too."""
from __future__ import annotations

import contextlib
import re
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402

from vibeam.engine import assess
from vibeam.api import Results  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
CASES = sorted((ROOT / "cases").glob("*.toml"))
UNIT = re.compile(r"\(.+\)$")          # "quantity (unit)", "(–)" for a nondimensional one


def check_figure(fig, what=""):
    """A figure a paper could show: every data axes has data, x and y labels ending in a unit
    (a shared axis may carry it once), every colour bar a label with a unit, a title, a
    legend whose entries all have a label and a drawn handle."""
    assert fig is not None, what
    title = fig._suptitle.get_text() if fig._suptitle is not None else ""
    assert title.strip(), f"{what}: no title"
    data_axes = [ax for ax in fig.axes if ax.get_label() != "<colorbar>"]
    assert data_axes, f"{what}: no axes"
    for ax in fig.axes:
        if ax.get_label() == "<colorbar>":
            lab = ax.get_ylabel() or ax.get_xlabel()
            assert UNIT.search(lab), f"{what}: colour bar label {lab!r} has no unit"
            continue
        assert ax.has_data(), f"{what}: empty axes {ax.get_title()!r}"
        for which in ("x", "y"):
            get = getattr(ax, f"get_{which}label")
            sib = getattr(ax, f"get_shared_{which}_axes")().get_siblings(ax)
            labels = [getattr(a, f"get_{which}label")() for a in sib if a.get_label() != "<colorbar>"]
            lab = get() or next((l for l in labels if l), "")
            assert UNIT.search(lab), f"{what}: {which} label {lab!r} of {ax.get_title()!r} has no unit"
    legends = list(fig.legends) + [ax.get_legend() for ax in fig.axes if ax.get_legend() is not None]
    assert legends, f"{what}: no legend"
    for leg in legends:
        texts = [t.get_text() for t in leg.get_texts()]
        assert texts and all(t.strip() for t in texts), f"{what}: empty legend entry in {texts}"
        assert len(texts) == len(set(texts)), f"{what}: repeated legend entries {texts}"
        assert len(leg.legend_handles) == len(texts), what


def figures(res: Results) -> dict:
    """Every figure the command line draws for these results (None where it draws nothing)."""
    out = {}
    if res.runs:
        from vibeam.plots.sweep import impacts_figure

        out["frc"] = res.plot_frc()
        out["bifurcation"] = res.plot_bifurcation()
        out["impacts"] = impacts_figure(res.runs, getattr(res.case, "name", ""), res.case)
        out["spectra"] = res.plot_spectra()
        out["participation"] = res.plot_participation()
        for lab in sorted({k.split("/")[1] for r in res.runs for k in r.data if k.startswith("time_series/")}):
            out[f"time_series {lab}"] = res.plot_time_series(lab)
        if any("R_identified_ladder" in r.data for r in res.runs):
            out["sensor"] = assess.sensor_figure(assess.sensor_table(res.runs), res.case.name, res.case,
                                                 runs=res.runs)
    for m in res.maps:
        out[f"map {m.name}"] = res.plot_map(m.name)
    if len(res.maps) > 1:
        out["agreement"] = res.plot_agreement()
    return out


# ============================================================================ the data in the figure
# The figures are read back from their matplotlib artists (Line2D data, LineCollection segments,
# QuadMesh arrays and colours, stack polygons) and compared with the results file read here with
# plain h5py (not through vibeam's loader, which the figures use).  Exact equality where the
# figure shows a stored number; rtol 1e-12 where the figure converts units (one product: the
# measured differences are <= 2 ulp, 4e-16) -- a 1 % error (test_the_data_checks_can_fail) is
# 1e10 times larger.

# README "Plots" / vibeam.plots.style: the marker of a point is its period class
_PERIOD_SHAPE = {1: "o", 2: "^", 0: "x", -1: "."}   # 3..8: square "s"
_RED = "#cc0000"                                  # failed points (style.FAILED_COLOUR)


def _shape(p) -> str:
    return "s" if int(p) >= 3 else _PERIOD_SHAPE.get(int(p), "x")


def _strings(a) -> np.ndarray:
    return np.array([s.decode() if isinstance(s, bytes) else str(s) for s in np.ravel(a)]).reshape(np.shape(a))


def file_data(path) -> dict:
    """A results file read with h5py: ``{"runs": {name: run}, "maps": {name: map}}``.

    A run is flattened to its points (any order; the plots sort by frequency): every
    per-point dataset along the first axis, ``direction`` and ``status`` as str, ``x`` the
    frequency axis of the plots (``frequency_hz`` where the run has ``amplitude_mm``, else
    ``Omega``) and ``y`` the amplitude (``amplitude_mm``, else ``amplitude``); both layouts
    of the writer ((direction, Omega) grid, or one row per point).  ``time_series`` keeps its
    groups; ``attrs`` the group's attributes.  A map keeps its (direction, value, frequency)
    arrays, with ``values`` (the parameter's dataset) and ``attrs``.
    """
    import h5py

    out = {"runs": {}, "maps": {}}
    with h5py.File(path, "r") as f:
        for name, g in (f["runs"].items() if "runs" in f else ()):
            v = {k: d[()] for k, d in g.items() if isinstance(d, h5py.Dataset)}
            dirs = _strings(v["direction"])
            n_f = len(v["Omega"])
            ref = v.get("amplitude", v.get("period"))
            r = {"attrs": dict(g.attrs)}
            if ref.shape[:2] == (len(dirs), n_f) and ref.ndim >= 2:        # (direction, Omega) grid
                n = len(dirs) * n_f
                for k, a in v.items():
                    if a.shape[:2] == (len(dirs), n_f):
                        r[k] = a.reshape((n,) + a.shape[2:])
                r["Omega"] = np.tile(v["Omega"], len(dirs))
                if "frequency_hz" in v and v["frequency_hz"].shape == (n_f,):
                    r["frequency_hz"] = np.tile(v["frequency_hz"], len(dirs))
                r["direction"] = np.repeat(dirs, n_f)
            else:                                                           # one row per point
                n = len(dirs)
                r.update({k: a for k, a in v.items() if a.shape[:1] == (n,)})
                r["direction"] = dirs
            r["coords"] = {k: a for k, a in v.items() if k not in r}
            for k in ("status", "message"):
                if k in r:
                    r[k] = _strings(r[k])
            phys = "amplitude_mm" in r and "frequency_hz" in r
            r["x"] = np.asarray(r["frequency_hz"] if phys else r["Omega"], float)
            if "amplitude" in r:
                r["y"] = np.asarray(r["amplitude_mm"] if phys else r["amplitude"], float)
            r["physical"] = phys
            if "time_series" in g:
                r["time_series"] = {lab: {k: d[()] for k, d in gl.items()} for lab, gl in g["time_series"].items()}
                r["time_series_dirs"] = dirs
            out["runs"][name] = r
        for name, g in (f["maps"].items() if "maps" in f else ()):
            m = {k: d[()] for k, d in g.items() if isinstance(d, h5py.Dataset)}
            m["attrs"] = dict(g.attrs)
            m["direction"] = _strings(m["direction"])
            m["values"] = np.asarray(m[str(g.attrs["parameter"])], float)
            out["maps"][name] = m
    return out


def _hex(c) -> str:
    from matplotlib.colors import to_hex

    return to_hex(c)


def _no_marker(line) -> bool:
    return line.get_marker() in (None, "", "None", " ", "none")


def _is_open(line) -> bool:
    return isinstance(line.get_markerfacecolor(), str) and line.get_markerfacecolor() == "none"


def legend_colours(fig) -> dict:
    """Legend label -> colour of its handle (the figure's legends)."""
    out = {}
    for leg in fig.legends:
        for t, h in zip(leg.get_texts(), leg.legend_handles):
            c = h.get_facecolor() if hasattr(h, "get_facecolor") and not hasattr(h, "get_xdata") else h.get_color()
            out[t.get_text()] = _hex(c)
    return out


def _run_colour(fig, name, r) -> str:
    lab = f"{name} ({r['attrs'].get('method', '')})"
    col = legend_colours(fig)
    assert lab in col, f"run {lab!r} not in the legend {sorted(col)}"
    return col[lab]


def _mm_factor(r) -> float:
    """The file's own conversion of a run's displacements to the plotted unit: amplitude_mm /
    amplitude (one number for the run; 1 for a nondimensional run)."""
    if not r["physical"]:
        return 1.0
    a, am = np.asarray(r["amplitude"], float), np.asarray(r["amplitude_mm"], float)
    ok = np.isfinite(a) & np.isfinite(am) & (a != 0)
    if not ok.any():
        return np.nan
    k = am[ok] / a[ok]
    np.testing.assert_allclose(k, np.median(k), rtol=1e-12, err_msg="amplitude_mm / amplitude is not one factor")
    return float(np.median(k))


def _in_mm(r, key):
    """``key`` in the plotted unit: the file's ``key_mm`` where it has it, else key x the run's factor."""
    if r["physical"] and f"{key}_mm" in r:
        return np.asarray(r[f"{key}_mm"], float)
    return np.asarray(r[key], float) * _mm_factor(r)


def _by_x(x, *ys):
    o = np.argsort(x, kind="stable")
    return (x[o],) + tuple(y[o] for y in ys)


def _pairs(x, y):
    """(x, y) pairs with a finite y, sorted by x then y (a multiset of plotted points)."""
    x, y = np.asarray(x, float).ravel(), np.asarray(y, float).ravel()
    k = np.isfinite(y)
    x, y = x[k], y[k]
    o = np.lexsort((y, x))
    return x[o], y[o]


def check_frc_data(fig, data: dict):
    """The FRC shows every run of the file: per run (its legend colour) and direction one line
    through the file's (x, y) sorted by frequency (solid up, dashed down; NaN where the file
    has NaN), a marker at every finite point whose shape is the file's period class (filled up,
    open down; the no-impact dot is drawn filled in both directions), a bar from
    amplitude_min to amplitude_max at every non-periodic point (solid up, dashed down), the
    averaging lower branch dotted, failed points as red crosses at their frequency -- and
    nothing else.  With several runs every run has its own panel (small multiples): the
    artists of all panels are read; the stops' horizontal lines (gid ``stop``) are not data."""
    runs = data["runs"]
    want_lines, want_marks, want_bars, want_lower, want_failed = {}, {}, {}, {}, []
    for name, r in runs.items():
        c = _run_colour(fig, name, r)
        x, y, d = r["x"], r["y"], r["direction"]
        per = np.asarray(r.get("period", np.ones(len(x), int)))
        failed = r["status"] == "failed" if "status" in r else np.zeros(len(x), bool)
        want_failed += list(x[failed])
        lo = _in_mm(r, "amplitude_min") if "amplitude_min" in r else None
        hi = _in_mm(r, "amplitude_max") if "amplitude_max" in r else None
        for dname in np.unique(d):
            s = d == dname
            want_lines[(c, dname)] = _by_x(x[s], y[s])
            for i in np.flatnonzero(s & ~failed & np.isfinite(y)):
                mk = _shape(per[i])
                want_marks.setdefault(c, []).append((x[i], y[i], mk, dname == "down" and mk != "."))
                if int(per[i]) == 0 and lo is not None and np.isfinite(lo[i]) and np.isfinite(hi[i]):
                    want_bars.setdefault(c, []).append((x[i], lo[i], hi[i], dname == "down"))
        if "amplitude_lower" in r:
            want_lower[c] = _pairs(x, _in_mm(r, "amplitude_lower"))
    got_lines, got_marks, got_bars, got_lower, got_failed = {}, {}, {}, {}, []
    for line in [l for ax in fig.axes for l in ax.get_lines() if l.get_gid() != "stop"]:
        c, ls = _hex(line.get_color()), line.get_linestyle()
        x, y = np.asarray(line.get_xdata(), float), np.asarray(line.get_ydata(), float)
        if _no_marker(line):
            if ls == ":":
                assert c not in got_lower, f"two lower-branch lines of colour {c}"
                got_lower[c] = _pairs(x, y)
            else:
                key = (c, {"-": "up", "--": "down"}[ls])
                assert key not in got_lines, f"two sweep lines {key}"
                got_lines[key] = (x, y)
        elif c == _RED:
            got_failed += list(x)
        else:
            got_marks.setdefault(c, []).extend((xi, yi, line.get_marker(), _is_open(line))
                                               for xi, yi in zip(x, y) if np.isfinite(yi))
    for coll in [c for ax in fig.axes for c in ax.collections]:
        if coll.__class__.__name__ == "LineCollection":
            c = _hex(coll.get_colors()[0])
            dashed = coll.get_linestyle()[0][1] is not None
            got_bars.setdefault(c, []).extend((s[0, 0], min(s[:, 1]), max(s[:, 1]), dashed)
                                              for s in coll.get_segments())
    assert sorted(got_lines) == sorted(want_lines), "runs x directions drawn differ from the file's"
    for key, (wx, wy) in want_lines.items():
        np.testing.assert_array_equal(got_lines[key][0], wx, err_msg=f"x of the line {key}")
        np.testing.assert_array_equal(got_lines[key][1], wy, err_msg=f"y of the line {key}")
    assert sorted(got_marks) == sorted(want_marks), "colours with markers differ"
    for c in want_marks:
        assert sorted(got_marks[c]) == sorted(want_marks[c]), f"markers of {c}: (x, y, period shape, open)"
    assert sorted(got_bars) == sorted(want_bars), "colours with range bars differ"
    for c in want_bars:
        g, w = np.array(sorted(got_bars[c]), float), np.array(sorted(want_bars[c]), float)
        assert g.shape == w.shape, f"range bars of {c}: {len(g)} drawn, {len(w)} in the file"
        np.testing.assert_array_equal(g[:, [0, 3]], w[:, [0, 3]], err_msg=f"bars of {c}: x, dashed")
        np.testing.assert_allclose(g[:, 1:3], w[:, 1:3], rtol=1e-12, atol=0, err_msg=f"bars of {c}: min, max")
    assert sorted(got_lower) == sorted(want_lower), "lower-branch lines differ"
    for c, (wx, wy) in want_lower.items():
        np.testing.assert_array_equal(got_lower[c][0], wx)
        np.testing.assert_allclose(got_lower[c][1], wy, rtol=1e-12, atol=0)
    assert sorted(got_failed) == sorted(want_failed), "failed points (red crosses) differ"
    # every period class drawn has its marker in the legend
    shapes = {h.get_marker() for leg in fig.legends for h in leg.legend_handles if hasattr(h, "get_marker")}
    assert {m[2] for ms in want_marks.values() for m in ms} <= shapes, "a drawn period class is not in the legend"


def check_bifurcation_data(fig, data: dict):
    """One row of panels per run with stroboscopic samples (left title ``name (method)``), one
    panel per direction (right title ``up sweep`` / ``down sweep``): the (x, q at phase 0)
    pairs of every recorded period, per direction, equal to the file's ``strobe[..., 0]`` in
    the FRC's unit (the file's amplitude_mm / amplitude)."""
    runs = {f"{n} ({r['attrs'].get('method', '')})": r for n, r in data["runs"].items()
            if "strobe" in r and np.isfinite(r["strobe"]).any()}
    panels = {}
    for ax in fig.axes:
        panels.setdefault(ax.get_title(loc="left"), []).append(ax)
    assert sorted(panels) == sorted(runs), "bifurcation panels differ from the runs with strobe data"
    for title, r in runs.items():
        s = np.asarray(r["strobe"], float)[..., 0] * _mm_factor(r)
        got = {}
        for ax in panels[title]:
            dname = ax.get_title(loc="right").removesuffix(" sweep")
            for line in ax.get_lines():
                if line.get_gid() != "stop":          # the stops' horizontal lines are not data
                    got.setdefault(dname, []).append(line)
        assert sorted(got) == sorted(np.unique(r["direction"])), f"{title}: directions drawn"
        for dname, lines in got.items():
            assert len(lines) == 1, (title, dname)
            sel = r["direction"] == dname
            wx, wy = _pairs(np.repeat(r["x"][sel][:, None], s.shape[1], axis=1), s[sel])
            gx, gy = _pairs(lines[0].get_xdata(), lines[0].get_ydata())
            np.testing.assert_array_equal(gx, wx, err_msg=f"{title} {dname}: frequencies")
            np.testing.assert_allclose(gy, wy, rtol=1e-12, atol=0, err_msg=f"{title} {dname}: strobe")


def check_impacts_data(fig, data: dict):
    """Two-sided runs: mean pre-impact speed (top) and impacts per period (bottom) against
    frequency, per run colour and direction (filled up, open down), upper stop solid and lower
    stop dotted, equal to the file's impact_velocity(_lower), impacts_per_period(_lower).  Physical
    runs (frequency in Hz): the speeds in mm/s (x L 2 pi f_n 1e3 from the group's attributes, and
    the y label says mm/s); nondimensional runs: against Omega, the speed nondimensional (issue 42
    item 10: a nondimensional speed was drawn against Hz)."""
    ax1, ax2 = fig.axes[:2]
    want = {}
    two = {n: r for n, r in data["runs"].items() if "impacts_per_period_lower" in r}
    phys = all(r["physical"] and r["attrs"].get("length_m") and r["attrs"].get("natural_frequency_hz")
               for r in two.values())
    assert ax1.get_ylabel().endswith("(mm/s)" if phys else "(–)"), ax1.get_ylabel()
    assert ax2.get_xlabel().endswith("(Hz)" if phys else "(–)"), ax2.get_xlabel()
    for name, r in two.items():
        c = _run_colour(fig, name, r)
        k = float(r["attrs"]["length_m"]) * 2.0 * np.pi * float(r["attrs"]["natural_frequency_hz"]) * 1e3 \
            if phys else 1.0
        x = r["x"] if phys else np.asarray(r["Omega"], float)
        for dname in np.unique(r["direction"]):
            s = r["direction"] == dname
            for ax, key, f in ((0, "impact_velocity", k), (1, "impacts_per_period", 1.0)):
                for suffix, ls in (("", "-"), ("_lower", ":")):
                    want[(ax, c, dname, ls)] = _by_x(x[s], np.asarray(r[key + suffix], float)[s] * f)
    got = {}
    for i, ax in enumerate((ax1, ax2)):
        for line in ax.get_lines():
            key = (i, _hex(line.get_color()), "down" if _is_open(line) else "up", line.get_linestyle())
            assert key not in got, key
            got[key] = (np.asarray(line.get_xdata(), float), np.asarray(line.get_ydata(), float))
    assert sorted(got) == sorted(want)
    for key, (wx, wy) in want.items():
        np.testing.assert_array_equal(got[key][0], wx, err_msg=str(key))
        np.testing.assert_allclose(got[key][1], wy, rtol=1e-12, atol=0, err_msg=str(key))


def _mesh_cells_hold(mesh, x, y, what):
    """Every data point (x[i, j], y[i]) lies inside its cell of the QuadMesh (the cells are
    where the data are: frequencies along the columns, values along the rows)."""
    X = mesh.get_coordinates()
    x = np.broadcast_to(np.asarray(x, float), (len(y), X.shape[1] - 1))
    assert X.shape[:2] == (len(y) + 1, x.shape[1] + 1), what
    assert np.all((X[:-1, :-1, 0] < x) & (x < X[:-1, 1:, 0])), f"{what}: a frequency outside its cell"
    y = np.asarray(y, float)
    assert np.all((X[:-1, 0, 1] < y) & (y < X[1:, 0, 1])), f"{what}: a value outside its cell"


def _mesh_array(mesh):
    return np.ma.filled(np.ma.asarray(mesh.get_array(), float), np.nan)


def _class_names(m) -> dict:
    """Class code -> name, from the file (attribute ``classes``: ``"0 no impact; 1 period-1; ..."``)."""
    out = {}
    for item in str(m["attrs"]["classes"]).split(";"):
        code, name = item.strip().split(" ", 1)
        out[int(code)] = name
    return out


def check_map_data(fig, m: dict):
    """A class map: one panel per direction whose cells hold the file's classification (the
    mesh array) and are painted the legend's colour of the file's class name (the file's
    ``classes``); cells around the file's frequencies and parameter values; the hysteresis
    panel marks every point whose class differs between up and down and no point where both
    the class and the amplitude are the same."""
    x = m["frequency_hz"] if "frequency_hz" in m else m["Omega"]
    names = _class_names(m)
    legend = legend_colours(fig)
    panels = {ax.get_title(loc="left"): ax for ax in fig.axes}
    c = np.asarray(m["classification"])
    for k, dname in enumerate(m["direction"]):
        ax = panels[f"{dname} sweep"]
        mesh = ax.collections[0]
        mesh.update_scalarmappable()                     # face colours from the colour map (no draw)
        np.testing.assert_array_equal(_mesh_array(mesh), c[k], err_msg=f"{dname}: classes")
        _mesh_cells_hold(mesh, x, m["values"], f"map {dname}")
        faces = np.array([_hex(f) for f in mesh.get_facecolors()]).reshape(c[k].shape)
        want = np.vectorize(lambda code: legend[names[int(code)]], otypes=[object])(c[k])
        assert (faces == want).all(), f"{dname}: a cell's colour is not its class's legend colour"
    if len(m["direction"]) == 2:
        h = _mesh_array(panels["hysteresis"].collections[0]).astype(bool)
        a = np.asarray(m["amplitude"], float)
        assert h[c[0] != c[1]].all(), "a point whose class differs is not marked"
        same = (c[0] == c[1]) & (a[0] == a[1])
        assert not h[same].any(), "a point with the same class and amplitude is marked"


def check_agreement_data(fig, maps: dict):
    """Each panel ('<other>' vs '<ref>', <direction> sweep): cells where the two files' classes
    agree show the 'same class' colour of the legend, the others the legend colour 'differs:
    <class of the other map>'; the title's count equals the file's number of differing points
    of that direction."""
    legend = legend_colours(fig)
    for ax in fig.axes:
        t = ax.get_title(loc="left")
        ax.collections[0].update_scalarmappable()        # face colours from the colour map (no draw)
        other, ref, dname = re.match(r"'(.+)' vs '(.+)', (\w+) sweep: (\d+) of", t).group(1, 2, 3)
        k = [str(v) for v in maps[ref]["direction"]].index(dname)
        a, b = np.asarray(maps[ref]["classification"])[k], np.asarray(maps[other]["classification"])[k]
        names = _class_names(maps[other])
        faces = np.array([_hex(f) for f in ax.collections[0].get_facecolors()]).reshape(a.shape)
        want = np.where(a == b, legend[f"same class as '{ref}'"],
                        np.vectorize(lambda code: legend.get(f"differs: {names[int(code)]}", "?"), otypes=[object])(b))
        assert (faces == want).all(), t
        assert f": {int((a != b).sum())} of {a.size} differ" in t, t


def _up(r):
    up = r["direction"] != "down"
    return up if up.any() else np.ones(len(up), bool)


def check_spectra_data(fig, data: dict):
    """Per run with spectra (panel ``name: sensor velocity spectrum ...``): the image is
    log10 of the file's spectrum_velocity on the up points (frequency along x, spectrum
    frequency along y; not positive: blank), its cells around the file's frequencies, and the
    circles are the file's peaks_frequency."""
    runs = {n: r for n, r in data["runs"].items() if "spectrum_velocity" in r}
    panels = {ax.get_title(loc="left").split(": sensor velocity spectrum")[0]: ax
              for ax in fig.axes if ax.get_label() != "<colorbar>"}
    assert sorted(panels) == sorted(runs)
    for name, r in runs.items():
        ax, up = panels[name], _up(r)
        x = np.asarray(r["frequency_hz"] if "frequency_hz" in r else r["Omega"], float)
        xs, S, pf = _by_x(x[up], np.asarray(r["spectrum_velocity"], float)[up],
                          np.asarray(r["peaks_frequency"], float)[up])
        with np.errstate(divide="ignore", invalid="ignore"):
            Z = np.where(S > 0, np.log10(S), np.nan).T
        mesh = ax.collections[0]
        np.testing.assert_array_equal(_mesh_array(mesh), Z, err_msg=name)
        # cells: frequencies along x, the spectrum's frequency axis (a coordinate of the file) along y
        _mesh_cells_hold(mesh, xs, r["coords"]["spectrum_frequency"], f"spectrum {name}")
        (line,) = ax.get_lines()
        gx, gy = _pairs(line.get_xdata(), line.get_ydata())
        wx, wy = _pairs(np.repeat(xs[:, None], pf.shape[1], axis=1), pf)
        np.testing.assert_array_equal(gx, wx)
        np.testing.assert_array_equal(gy, wy)


def check_participation_data(fig, data: dict):
    """Per run with more than one mode: two stacks (displacement, energy) over the up points
    whose layer k spans the cumulative shares k-1..k of the file (a missing share as 0)."""
    runs = {n: r for n, r in data["runs"].items() if "participation_displacement" in r
            and np.shape(r["participation_displacement"])[1] > 1}
    axes = fig.axes
    seen = set()
    for i in range(0, len(axes), 2):
        name = axes[i].get_title(loc="left")
        assert name in runs, name
        seen.add(name)
        r = runs[name]
        up = _up(r)
        for ax, key in ((axes[i], "participation_displacement"), (axes[i + 1], "participation_energy")):
            xs, P = _by_x(r["x"][up], np.nan_to_num(np.asarray(r[key], float)[up]))
            cum = np.vstack([np.zeros(len(xs)), np.cumsum(P, axis=1).T])
            layers = [c for c in ax.collections if c.__class__.__name__.endswith("PolyCollection")]
            assert len(layers) == P.shape[1], (name, key)
            for k, layer in enumerate(layers):
                v = layer.get_paths()[0].vertices
                for j, xj in enumerate(xs):
                    yj = v[v[:, 0] == xj, 1]
                    np.testing.assert_allclose([yj.min(), yj.max()], [cum[k, j], cum[k + 1, j]], rtol=1e-12,
                                               atol=1e-15, err_msg=f"{name} {key} mode {k + 1} at {xj}")
    assert seen == set(runs)


def check_time_series_data(fig, data: dict, label: str):
    """Time series at the grid frequency ``label``: per run (legend ``name (dir sweep)``) the
    phase portrait is the file's (displacement, velocity) of the stored window, and the time
    panels are the file's last samples, over two periods of the label's frequency."""
    legend = legend_colours(fig)
    lines = {(_hex(l.get_color()), l.get_linestyle(), i): l for i, ax in enumerate(fig.axes[:3])
             for l in ax.get_lines()}
    n_items = 0
    for name, r in data["runs"].items():
        ts = r.get("time_series", {}).get(label)
        if ts is None:
            continue
        for i, dname in enumerate(r["time_series_dirs"]):
            disp, vel = np.asarray(ts["displacement"][i], float), np.asarray(ts["velocity"][i], float)
            keep = np.isfinite(disp)
            if not keep.any():
                continue
            n_items += 1
            n = int(np.flatnonzero(keep)[-1]) + 1
            t = np.asarray(ts["t"][i] if "t" in ts else ts["time"], float)[:n]
            disp, vel = disp[:n], vel[:n]
            c = legend[f"{name} ({dname} sweep)"]
            ls = {"up": "-", "down": "--"}[dname]
            ph = lines[(c, ls, 2)]
            np.testing.assert_array_equal(ph.get_xdata(), disp, err_msg=f"{name} {dname} portrait")
            np.testing.assert_array_equal(ph.get_ydata(), vel, err_msg=f"{name} {dname} portrait")
            W = float(np.asarray(ts["point_Omega"])[i])
            f = (float(r["x"][np.flatnonzero(r["Omega"] == W)[0]]) if r["physical"] else W / (2 * np.pi))
            for ax_i, y in ((0, disp), (1, vel)):
                tl = lines[(c, ls, ax_i)]
                m = len(tl.get_xdata())
                np.testing.assert_array_equal(tl.get_xdata(), t[n - m:])
                np.testing.assert_array_equal(tl.get_ydata(), y[n - m:])
                # the last two periods: the first sample shown is within 2/f of the end, the one before is not
                assert t[-1] - t[n - m] <= 2 / f * (1 + 1e-12)
                assert m == n or t[-1] - t[n - m - 1] > 2 / f * (1 - 1e-12)
    assert n_items and len(lines) == 3 * n_items


def check_figure_data(kind: str, fig, data: dict):
    """The data check of one figure of :func:`figures` against its results file."""
    if kind == "frc":
        check_frc_data(fig, data)
    elif kind == "bifurcation":
        check_bifurcation_data(fig, data)
    elif kind == "impacts":
        check_impacts_data(fig, data)
    elif kind.startswith("map "):
        check_map_data(fig, data["maps"][kind[4:]])
    elif kind == "agreement":
        check_agreement_data(fig, data["maps"])
    elif kind == "spectra":
        check_spectra_data(fig, data)
    elif kind == "participation":
        check_participation_data(fig, data)
    elif kind.startswith("time_series "):
        check_time_series_data(fig, data, kind.split(" ", 1)[1])
    else:
        return False
    return True


def assert_png_shows(png, fig, dpi: int = 150):
    """The PNG file is ``fig`` rendered at ``dpi`` (vibeam.plots.sweep.save_figure's): a valid image of
    the figure's size in pixels, the same as rendering ``fig`` again (so the figure whose artists
    were checked is the one written) but for anti-aliasing: two renderings of one figure were
    measured to differ in a few edge pixels now and then (the work-precision figure, 5 of 10
    times), so at most 0.1 % of the pixels may differ; another data set moves whole lines and
    markers (thousands of pixels)."""
    import io

    import matplotlib.image as mpimg

    a = mpimg.imread(png)
    w, h = fig.get_size_inches() * dpi
    assert a.shape == (round(h), round(w), 4), (a.shape, w, h)
    buf = io.BytesIO()
    fig.savefig(buf, dpi=dpi, format="png")
    buf.seek(0)
    b = mpimg.imread(buf)
    assert a.shape == b.shape, f"{png} is not the figure checked"
    differ = np.any(np.abs(a - b) > 1.5 / 255, axis=-1)
    assert differ.mean() <= 1e-3, f"{png} is not the figure checked ({differ.sum()} pixels differ)"


def assert_png_shows_results(png, results, kind: str):
    """A figure written by `vibeam run` (``frc``, ``bifurcation``, ``impacts``, ``map <name>``):
    the same figure built from the results file plots the file's data (:func:`check_figure_data`)
    and the PNG is that figure (:func:`assert_png_shows`)."""
    from vibeam.plots.sweep import impacts_figure

    res = Results.from_file(results)
    title = getattr(res.case, "name", "")
    fig = {"frc": res.plot_frc, "bifurcation": res.plot_bifurcation,
           "impacts": lambda: impacts_figure(res.runs, title, res.case)}.get(kind, lambda: res.plot_map(kind[4:]))()
    try:
        assert_png_shows(png, fig)                 # rendered fresh, as the writer did
        check_figure(fig, f"{png}")
        check_figure_data(kind, fig, file_data(results))
    finally:
        plt.close(fig)


@contextlib.contextmanager
def written_figures():
    """The figures vibeam saves while the block runs (every writer goes through
    vibeam.plots.sweep.save_figure): file name -> Figure, for reading their artists back."""
    from unittest import mock

    from vibeam.plots import sweep as plots

    figs, orig = {}, plots.save_figure

    def keep(fig, path, *a, **k):
        figs[Path(path).name] = fig
        return orig(fig, path, *a, **k)

    with mock.patch.object(plots, "save_figure", keep):
        yield figs


def check_work_precision_data(fig, cost_h5):
    """``vibeam cost``'s work-precision figure against its ``cost.h5``: per run (legend colour)
    one series through the file's (wall_time_s, error_max) of the run's rows in time order: the
    error against the converged reference (issue 42 item 10: not error_method_max, each method
    against its own reference, which put every event rung at 1e-16); an error below 1e-16 or 0
    drawn on the 1e-16 floor, as the figure's docstring says; and a horizontal line at each
    model's transient truncation model_transient_error_max."""
    import h5py

    with h5py.File(cost_h5, "r") as f:
        g = f["cost"]
        run, method = g["run"].asstr()[()], g["method"].asstr()[()]
        t, e = g["wall_time_s"][()], g["error_max"][()]
        trans = g["model_transient_error_max"][()] if "model_transient_error_max" in g else np.array([])
    ax = fig.axes[0]
    legend = legend_colours(fig)
    series = [l for l in ax.get_lines() if l.get_transform() is ax.transData]
    hlines = sorted(float(l.get_ydata()[0]) for l in ax.get_lines() if l.get_transform() is not ax.transData)
    got = {_hex(l.get_color()): l for l in series}
    assert len(got) == len(series) == len(set(run)), "one series per run"
    for name in dict.fromkeys(run):
        k = run == name
        line = got[legend[f"{name} ({method[k][0]}; vs converged)"]]
        o = np.argsort(t[k], kind="stable")
        want = np.where(np.isfinite(e[k]), np.maximum(e[k], 1e-16), np.nan)[o]
        np.testing.assert_array_equal(line.get_xdata(), t[k][o], err_msg=name)
        np.testing.assert_array_equal(line.get_ydata(), want, err_msg=name)
    want_h = sorted([1e-16] + [float(v) for v in trans if np.isfinite(v) and v > 0])
    assert hlines == want_h, (hlines, want_h)
    assert "converged reference" in ax.get_ylabel(), ax.get_ylabel()


def check_fit_data(fig, fit_h5):
    """``vibeam fit``'s figure against its ``fit.h5``: per direction the data points, the
    fitted model's FRC and the residuals (lower panel) equal the file's (x, data), (x,
    model_<y>) and (x, residuals), sorted by frequency."""
    import h5py

    with h5py.File(fit_h5, "r") as f:
        g = f["fit"]
        xk = "frequency_hz" if "frequency_hz" in g else "Omega"
        yk = "amplitude_mm" if "amplitude_mm" in g else "amplitude"
        x, y, model, res = g[xk][()], g[yk][()], g["model_" + yk][()], g["residuals"][()]
        d = g["direction"].asstr()[()]
    ax, axr = fig.axes[:2]

    def labelled(a, lab):
        found = [l for l in a.get_lines() if l.get_label() == lab]
        found += [c.lines[0] for c in a.containers if c.get_label() == lab]
        assert len(found) == 1, (lab, len(found))
        return found[0]

    for dname in np.unique(d):
        k = d == dname
        xs, ys, ms, rs = _by_x(x[k], y[k], model[k], res[k])
        for a, lab, want in ((ax, f"data ({dname})", ys), (ax, f"fitted model ({dname})", ms), (axr, dname, rs)):
            line = labelled(a, lab)
            np.testing.assert_array_equal(line.get_xdata(), xs, err_msg=lab)
            np.testing.assert_array_equal(line.get_ydata(), want, err_msg=lab)


def assert_png_image(png, size_inches, dpi: int = 150):
    """A PNG written by another process: a valid image of ``size_inches`` at ``dpi``, not blank."""
    import matplotlib.image as mpimg

    a = mpimg.imread(png)
    w, h = np.asarray(size_inches, float) * dpi
    assert a.shape == (round(h), round(w), 4), (a.shape, w, h)
    assert np.ptp(a[..., :3]) > 0.5, f"{png} is blank"


# the two tight FE ladders (~20-30 s each for their quick results) run in the slow step
_SLOW_CASES = {"rig-fe-tight-continuation", "rig-fe-tight"}


@pytest.mark.parametrize("path", [pytest.param(p, marks=pytest.mark.slow) if p.stem in _SLOW_CASES else p
                                  for p in CASES], ids=[p.stem for p in CASES])
def test_every_figure_of_every_quick_case(path, quick_results):
    """Every figure is labelled (:func:`check_figure`) and draws its results file's data
    (:func:`check_figure_data`: FRC, bifurcation, impacts, maps, agreement, spectra,
    participation, time series; the sensor figure draws a table derived from the file and
    only gets the label checks)."""
    out = quick_results(path)
    res = Results.from_file(out / "results.h5")
    data = file_data(out / "results.h5")
    figs = figures(res)
    drawn = {k: f for k, f in figs.items() if f is not None}
    try:
        if res.runs:
            assert "frc" in drawn
        if res.maps:
            assert all(f"map {m.name}" in drawn for m in res.maps)
        if res.case.assess.spectra:
            assert "spectra" in drawn
        if any("impacts_per_period_lower" in r for r in data["runs"].values()):
            assert "impacts" in drawn
        for k, fig in drawn.items():
            check_figure(fig, f"{path.stem}: {k}")
            assert check_figure_data(k, fig, data) or k == "sensor", f"{path.stem}: no data check for {k}"
        # a run has one colour in every figure: the FRC's legend line and the bifurcation panel
        if "bifurcation" in drawn and "frc" in drawn:
            frc = {t.get_text().split(" (")[0]: h.get_color() for t, h in
                   zip(drawn["frc"].legends[0].get_texts(), drawn["frc"].legends[0].legend_handles)}
            bif = {t.get_text().split(" (")[0]: h.get_color() for t, h in
                   zip(drawn["bifurcation"].legends[0].get_texts(), drawn["bifurcation"].legends[0].legend_handles)}
            for name in set(frc) & set(bif) & {r.name for r in res.runs}:
                assert frc[name] == bif[name], name
    finally:
        for f in drawn.values():
            plt.close(f)


def _run(name, Omega, amp, period, direction, **extra):
    from vibeam.engine.sweep import SweepResult

    data = dict(Omega=np.asarray(Omega, float), amplitude=np.asarray(amp, float), period=np.asarray(period),
                direction=np.asarray(direction, dtype=object),
                status=np.array(["ok"] * len(Omega), dtype=object), **extra)
    return SweepResult(name=name, fidelity="sdof", method="event", settings={}, data=data, wall_time_s=0.0)


def test_frc_range_bars_up_down_and_failed_points():
    """Non-periodic points get a bar over amplitude_min..amplitude_max; up is solid with filled
    markers, down dashed with open ones; failed points are red crosses at the bottom."""
    from vibeam.plots.sweep import frc_figure

    W = np.array([1.0, 1.5, 2.0, 2.5, 2.5, 2.0, 1.5, 1.0])
    r = _run("a", W, [1.0, 2.0, 3.0, 4.0, 4.0, 3.0, 2.5, 1.0], [1, 0, 2, 1, 1, 2, 0, 1],
             ["up"] * 4 + ["down"] * 4,
             amplitude_min=np.array([1.0, 1.2, 3.0, 4.0, 4.0, 3.0, 1.9, 1.0]),
             amplitude_max=np.array([1.0, 2.0, 3.0, 4.0, 4.0, 3.0, 2.5, 1.0]))
    r.data["status"][7] = "failed"
    r.data["amplitude"][7] = np.nan
    fig = frc_figure([r], title="t")
    try:
        check_figure(fig, "synthetic FRC")
        ax = fig.axes[0]
        bars = [c for c in ax.collections if c.__class__.__name__ == "LineCollection"]
        segs = [s for c in bars for s in c.get_segments()]
        assert sorted((float(s[0, 0]), float(s[0, 1]), float(s[1, 1])) for s in segs) == \
            [(1.5, 1.2, 2.0), (1.5, 1.9, 2.5)]
        lines = [l for l in ax.get_lines() if len(l.get_xdata()) > 1 and l.get_marker() in ("None", "")]
        assert {l.get_linestyle() for l in lines} == {"-", "--"}
        filled = {l.get_markerfacecolor() != "none" for l in ax.get_lines() if l.get_marker() == "o"}
        assert filled == {True, False}
        red = [l for l in ax.get_lines() if l.get_marker() == "x" and l.get_color() == "#CC0000"]
        assert red and list(red[0].get_xdata()) == [1.0]
        labels = [t.get_text() for t in fig.legends[0].get_texts()]
        assert any("failed (1 points)" in t for t in labels) and any("non-periodic" in t for t in labels)
    finally:
        plt.close(fig)


def test_run_colours_follow_the_case_order():
    from vibeam.plots.sweep import bifurcation_figure, frc_figure
    from vibeam.plots.style import PALETTE, colours

    a = _run("a", [1.0, 2.0], [1, 2], [1, 1], ["up", "up"], strobe=np.ones((2, 4, 2)))
    b = _run("b", [1.0, 2.0], [1, 3], [1, 1], ["up", "up"], strobe=np.ones((2, 4, 2)))
    col = colours(["b", "a"])                       # the case lists b first
    assert col == {"b": PALETTE[0], "a": PALETTE[1]}
    for make in (frc_figure, bifurcation_figure):
        fig = make([a], colours=col)
        try:
            h = fig.legends[0].legend_handles[0]
            assert h.get_color() == PALETTE[1]           # a keeps its colour when drawn alone
        finally:
            plt.close(fig)
    many = colours([f"r{i}" for i in range(12)])
    assert len(set(many.values())) == 12            # more runs than the palette: still distinct


def _map(n_values, n_freq, classes):
    from vibeam.analysis.maps import MapResult

    W = np.linspace(1.5, 2.5, n_freq)
    c = np.asarray(classes, dtype=np.int8).reshape(1, n_values, n_freq)
    data = {"values": np.linspace(0.2, 0.7, n_values), "direction": np.array(["up"], dtype=object),
            "Omega": np.broadcast_to(W, (1, n_values, n_freq)).copy(), "classification": c,
            "amplitude": np.ones(c.shape), "period": np.ones(c.shape, int)}
    return MapResult(name="m", fidelity="sdof", method="event", settings={}, parameter="voltage", data=data,
                     wall_time_s=0.0)


@pytest.mark.parametrize("shape", [(1, 1), (1, 5), (4, 1)])
def test_map_with_one_value_or_one_frequency_is_drawn(shape):
    """A map of one value (or one frequency) has cells of finite size, not a blank panel."""
    from vibeam.analysis.maps import NON_PERIODIC, map_figure

    m = _map(*shape, np.full(shape, NON_PERIODIC))
    fig = map_figure(m, "one value")
    try:
        check_figure(fig, f"map {shape}")
        mesh = fig.axes[0].collections[0]
        X = mesh.get_coordinates()
        assert np.ptp(X[..., 0]) > 0 and np.ptp(X[..., 1]) > 0
        assert fig.axes[0].get_ylabel() == "voltage V (V)"
        # non-periodic is not the background colour
        face = mesh.get_facecolors()[0][:3]
        assert not np.allclose(face, 1.0)
    finally:
        plt.close(fig)


def test_map_hysteresis_panel_and_agreement_have_legends():
    from vibeam.analysis.maps import PERIOD_1, PERIOD_2, agreement_figure, map_figure

    m = _map(2, 3, [PERIOD_1] * 6)
    m.data = {k: (np.concatenate([v, v]) if k not in ("values", "direction") else v) for k, v in m.data.items()}
    m.data["direction"] = np.array(["up", "down"], dtype=object)
    m.data["classification"][1, 0, 0] = PERIOD_2
    fig = map_figure(m)
    try:
        check_figure(fig, "map with hysteresis")
        hyst = fig.axes[2]
        assert hyst.get_legend() is not None and "up ≠ down (1)" in hyst.get_legend().get_texts()[0].get_text()
    finally:
        plt.close(fig)
    other = _map(2, 3, [PERIOD_2] + [PERIOD_1] * 5)
    fig = agreement_figure([_map(2, 3, [PERIOD_1] * 6), other], "agree")
    try:
        check_figure(fig, "agreement")
        texts = [t.get_text() for t in fig.legends[0].get_texts()]
        assert texts[0].startswith("same class") and "differs: period-2" in texts
        assert "1 of 6 differ" in fig.axes[0].get_title(loc="left")
    finally:
        plt.close(fig)


def test_a_figure_without_units_fails_the_check():
    """The check itself can fail: a label without a unit, an empty legend entry."""
    fig, ax = plt.subplots()
    ax.plot([0, 1], [0, 1], label="x")
    ax.set_xlabel("frequency")
    ax.set_ylabel("amplitude (mm)")
    fig.suptitle("t")
    fig.legend()
    try:
        with pytest.raises(AssertionError, match="x label 'frequency'"):
            check_figure(fig)
        ax.set_xlabel("f (Hz)")
        check_figure(fig)
        ax.plot([0, 1], [1, 0], label=" ")
        fig.legends[0].remove()
        fig.legend()
        with pytest.raises(AssertionError, match="empty legend entry"):
            check_figure(fig)
    finally:
        plt.close(fig)


@pytest.mark.parametrize("name", ["paper-fig13-continuation", "rig-map-gap-continuation"])
def test_continuation_figures_are_labelled(name, tmp_path, monkeypatch):
    """The continuation FRC (stable solid, unstable dashed, bifurcations) and the two-parameter
    curves, drawn by `vibeam continue --quick` of the shipped continuation cases: the same checks."""
    from vibeam.analysis import branches
    from vibeam.cli import main

    figs = []
    for fname in ("continuation_figure", "curves_figure"):
        orig = getattr(branches, fname)

        def keep(*a, _orig=orig, **k):
            fig = _orig(*a, **k)
            figs.append(fig)
            return fig
        monkeypatch.setattr(branches, fname, keep)
    monkeypatch.setattr(plt, "close", lambda *a, **k: None)      # keep them for the checks
    assert main(["continue", str(ROOT / "cases" / f"{name}.toml"), "--quick", "--out", str(tmp_path), "--quiet",
                 "--jobs", "1"]) == 0
    try:
        assert figs
        for fig in figs:
            check_figure(fig, f"{name}: {fig._suptitle.get_text()[:40]}")
    finally:
        monkeypatch.undo()
        for fig in figs:
            plt.close(fig)


def _fails(check, *args):
    with pytest.raises(AssertionError) as e:
        check(*args)
    return str(e.value)


def _other_class_at_first_cell(c):
    c = c.copy()
    c.flat[0] = 2 if c.flat[0] == 1 else 1
    return c


def test_the_data_checks_can_fail(quick_results):
    """The data checks catch a wrong figure: each check passes on the file it was drawn from
    and fails against the same file with one thing changed by 1 % (amplitudes, range bars,
    strobe samples, spectra, time series), one period class, one map cell, one missing sweep
    direction, one impact count, or two swapped modal shares."""
    import copy

    def changed(data, run_or_map, key, fn, kind="runs"):
        d = copy.deepcopy(data)
        items = d[kind] if run_or_map is None else {run_or_map: d[kind][run_or_map]}
        for r in items.values():
            r[key] = fn(np.array(r[key]))
            if kind == "runs" and key in ("amplitude", "amplitude_mm"):
                r["y"] = np.asarray(r["amplitude_mm"] if r["physical"] else r["amplitude"], float)
        return d

    cases = {n: quick_results(ROOT / "cases" / f"{n}.toml") / "results.h5"
             for n in ("paper-fig8", "rig-loose", "paper-fig7-two-sided", "rig-fe-hfc", "paper-fig18-fe")}
    figs = []
    try:
        # FRC and bifurcation: nondimensional (periods -1, 0, 1, 3; up and down) and physical (mm, Hz)
        for n in ("paper-fig8", "rig-loose"):
            data, res = file_data(cases[n]), Results.from_file(cases[n])
            frc, bif = res.plot_frc(), res.plot_bifurcation()
            figs += [frc, bif]
            check_frc_data(frc, data)
            check_bifurcation_data(bif, data)
            amp = "amplitude_mm" if n == "rig-loose" else "amplitude"
            _fails(check_frc_data, frc, changed(data, None, amp, lambda a: a * 1.01))
            per = data["runs"]["exact"]["period"]
            i = int(np.flatnonzero(per == 1)[0])
            _fails(check_frc_data, frc, changed(data, "exact", "period", lambda p: np.where(np.arange(p.size) == i, 3, p)))
            lo = "amplitude_min_mm" if n == "rig-loose" else "amplitude_min"
            j = int(np.flatnonzero(per == 0)[0])
            _fails(check_frc_data, frc, changed(data, "exact", lo, lambda a: np.where(np.arange(a.size) == j, a * 1.01, a)))
            _fails(check_bifurcation_data, bif, changed(data, None, "strobe", lambda a: a * 1.01))
            up_only = Results.from_file(cases[n])
            for r in up_only.runs:
                keep = np.asarray(r.data["direction"]).astype(str) == "up"
                assert 0 < keep.sum() < keep.size
                r.data = {k: (np.asarray(v)[keep] if np.shape(v)[:1] == keep.shape else v) for k, v in r.data.items()}
            one = up_only.plot_frc()
            figs.append(one)
            _fails(check_frc_data, one, data)                       # the down sweep is missing
        # impacts per stop
        data, res = file_data(cases["paper-fig7-two-sided"]), Results.from_file(cases["paper-fig7-two-sided"])
        from vibeam.plots.sweep import impacts_figure

        imp = impacts_figure(res.runs)
        figs.append(imp)
        check_impacts_data(imp, data)
        _fails(check_impacts_data, imp, changed(data, None, "impacts_per_period_lower", lambda a: a + 1))
        # spectra, participation, time series
        data, res = file_data(cases["rig-fe-hfc"]), Results.from_file(cases["rig-fe-hfc"])
        sp, pa, ts = res.plot_spectra(), res.plot_participation(), res.plot_time_series("15")
        figs += [sp, pa, ts]
        check_spectra_data(sp, data)
        check_participation_data(pa, data)
        check_time_series_data(ts, data, "15")
        _fails(check_spectra_data, sp, changed(data, None, "spectrum_velocity", lambda a: a * 1.01))
        _fails(check_participation_data, pa, changed(data, None, "participation_displacement", lambda a: a[..., ::-1]))
        d = copy.deepcopy(data)
        for r in d["runs"].values():
            r["time_series"]["15"]["displacement"] = r["time_series"]["15"]["displacement"] * 1.01
        _fails(check_time_series_data, ts, d, "15")
        # maps and their agreement: one cell of one map changed
        data, res = file_data(cases["paper-fig18-fe"]), Results.from_file(cases["paper-fig18-fe"])
        ref, other = res.maps[0].name, res.maps[1].name
        mp, ag = res.plot_map(ref), res.plot_agreement()
        figs += [mp, ag]
        check_map_data(mp, data["maps"][ref])
        check_agreement_data(ag, data["maps"])
        for name in (ref, other):
            bad = changed(data, name, "classification", _other_class_at_first_cell, kind="maps")
            if name == ref:
                _fails(check_map_data, mp, bad["maps"][ref])
            _fails(check_agreement_data, ag, bad["maps"])
    finally:
        for f in figs:
            plt.close(f)


# ============================================================================ issue 42, item 10
def test_frc_of_several_runs_is_small_multiples_on_shared_axes():
    """Issue 42 item 10: the ladder's five runs overlaid in one axes (x 2 directions, markers,
    range bars) hid each other under the 1-mode branch.  Several runs: one panel per run (its
    name and method as the panel's title, only its colour), all on the same x and y axes."""
    from vibeam.plots.sweep import frc_figure
    from vibeam.plots.style import colours

    W = [1.0, 1.5, 2.0, 2.0, 1.5, 1.0]
    runs = [_run(n, W, np.array([1.0, 2.0, 3.0, 3.0, 2.5, 1.0]) * (i + 1), [1, 0, 1, 1, 0, 1],
                 ["up"] * 3 + ["down"] * 3, amplitude_min=np.full(6, 0.5), amplitude_max=np.full(6, 4.0))
            for i, n in enumerate(("a", "b", "c"))]
    fig = frc_figure(runs, title="ladder")
    try:
        check_figure(fig, "small multiples")
        assert len(fig.axes) == len(runs)
        col = colours(["a", "b", "c"])
        for ax, r in zip(fig.axes, runs):
            assert ax.get_title(loc="left") == f"{r.name} ({r.method})"
            drawn = {_hex(l.get_color()) for l in ax.get_lines()} | \
                {_hex(c.get_colors()[0]) for c in ax.collections if len(c.get_colors())}
            assert drawn == {_hex(col[r.name])}, (r.name, drawn)
        ylims = {ax.get_ylim() for ax in fig.axes}
        xlims = {ax.get_xlim() for ax in fig.axes}
        assert len(ylims) == 1 and len(xlims) == 1, "the panels do not share their axes"
        assert max(ylims.pop()) >= 9.0                 # the largest run's amplitude fits every panel
    finally:
        plt.close(fig)
    one = frc_figure(runs[:1], title="one run")
    try:
        assert len(one.axes) == 1
    finally:
        plt.close(one)


def test_frc_names_the_lower_stop_and_marks_it():
    """Issue 42 item 10: the subtitle omitted the lower stop and no line marked it.  The
    subtitle names its offset and law (restitution R, or a compliant law's stiffness); the FRC
    draws a horizontal line at each stop's amplitude Q (upper Q = 0, lower Q = Delta +
    Delta_lower), with a legend entry; a physical scene's gaps in mm at the sensor."""
    from vibeam.plots.sweep import frc_figure
    from vibeam.plots.style import subtitle

    r = _run("two", [1.5, 2.0], [1e-3, 2.5e-3], [1, 1], ["up", "up"])
    r.attrs["model"] = {"fidelity": "sdof", "beta": 0.015, "B": 5e-4, "R": 0.9, "Delta": 5e-4,
                        "Delta_lower": 2e-3, "contact_lower": {"law": "restitution", "R": 0.8}}
    fig = frc_figure([r], title="two-sided")
    try:
        check_figure(fig, "two-sided FRC")
        sub = fig._suptitle.get_text()
        assert "lower stop" in sub and "0.002" in sub and "restitution R = 0.8" in sub, sub
        stops = sorted(float(l.get_ydata()[0]) for l in fig.axes[0].get_lines() if l.get_gid() == "stop")
        np.testing.assert_allclose(stops, [0.0, 2.5e-3], rtol=1e-12)
        texts = [t.get_text() for t in fig.legends[0].get_texts()]
        assert any(t.startswith("lower stop") for t in texts), texts
    finally:
        plt.close(fig)
    # the bifurcation diagram's axis is the displacement q: the stops at q = Delta and -Delta_lower
    from vibeam.plots.sweep import bifurcation_figure

    r.data["strobe"] = np.full((2, 4, 2), -1e-3)
    fig = bifurcation_figure([r], title="two-sided")
    try:
        stops = sorted(float(l.get_ydata()[0]) for l in fig.axes[0].get_lines() if l.get_gid() == "stop")
        np.testing.assert_allclose(stops, [-2e-3, 5e-4], rtol=1e-12)
        assert any(t.get_text().startswith("lower stop") for t in fig.legends[0].get_texts())
    finally:
        plt.close(fig)
    kv = subtitle(model={"fidelity": "beam", "gap_mm": 0.0, "gap_lower_mm": 1.2,
                         "contact_lower": {"law": "linear", "stiffness_n_m": 1e6}})
    assert "lower stop: gap 1.2 mm, linear, $k_c$ = 1e+06 N/m" in kv, kv
    tip = subtitle(model={"fidelity": "beam", "stop": [
        {"side": "upper", "gap_mm": 0.0, "R": 0.72},
        {"side": "lower", "position_mm": 180.0, "contact_gap_mm": 1.2, "R": 0.9}]})
    assert "lower stop at 180 mm: contact gap 1.2 mm, restitution R = 0.9" in tip, tip
    # several runs of a case with [[model.stop]] tables: the runs' resolved model names the stop
    import vibeam

    case = vibeam.load_case(ROOT / "cases" / "rig-fe-tip-stop.toml")
    runs = [_run(n, [1.5, 2.0], [1e-3, 2e-3], [1, 1], ["up", "up"]) for n in ("FE 2 modes", "FE 4 modes")]
    for i, r in enumerate(runs):
        r.attrs["model"] = {"fidelity": "beam", "R": 0.72, "gap_mm": 0.0, "n_modes": 2 * (i + 1), "stop": [
            {"side": "lower", "position_mm": 180.0, "contact_gap_mm": 1.2, "law": "restitution", "R": 0.9}]}
    both = subtitle(case, runs=runs)
    assert "lower stop at 180 mm: contact gap 1.2 mm, restitution R = 0.9" in both and "R = 0.72" in both, both
    single = frc_figure([_run("one", [1.5, 2.0], [1e-3, 2e-3], [1, 1], ["up", "up"])], title="single")
    try:
        assert not [l for l in single.axes[0].get_lines() if l.get_gid() == "stop"]
        assert "stop" not in single._suptitle.get_text()
    finally:
        plt.close(single)


def test_impacts_speed_and_frequency_in_one_system_of_units():
    """Issue 42 item 10: impacts.png drew the nondimensional speed |q'-| against Hz.  A physical
    two-sided run: mm/s against Hz (the speed x L 2 pi f_n); a nondimensional one: (–) against
    Omega."""
    from vibeam.plots.sweep import impacts_figure

    W = np.array([1.8, 2.0, 2.2])
    extra = dict(impact_velocity=np.array([0.01, 0.02, 0.03]), impact_velocity_lower=np.array([0.005, 0.0, 0.01]),
                 impacts_per_period=np.ones(3), impacts_per_period_lower=np.array([1.0, 0.0, 1.0]))
    r = _run("tip", W, [0.1, 0.2, 0.3], [1, 1, 1], ["up"] * 3, frequency_hz=W * 7.6,
             amplitude_mm=np.array([0.1, 0.2, 0.3]) * 180.0, **extra)
    r.attrs.update(length_m=0.18, natural_frequency_hz=7.6)
    fig = impacts_figure([r], "tip")
    try:
        check_figure(fig, "physical impacts")
        ax1, ax2 = fig.axes[:2]
        assert ax1.get_ylabel().endswith("(mm/s)") and ax2.get_xlabel().endswith("(Hz)")
        up = next(l for l in ax1.get_lines() if l.get_linestyle() == "-")
        np.testing.assert_allclose(up.get_xdata(), W * 7.6, rtol=1e-15)
        np.testing.assert_allclose(up.get_ydata(), extra["impact_velocity"] * 0.18 * 2 * np.pi * 7.6 * 1e3, rtol=1e-12)
    finally:
        plt.close(fig)
    nd = _run("nd", W, [0.1, 0.2, 0.3], [1, 1, 1], ["up"] * 3, **extra)
    fig = impacts_figure([nd], "nd")
    try:
        check_figure(fig, "nondimensional impacts")
        assert fig.axes[0].get_ylabel().endswith("(–)") and "Omega" in fig.axes[1].get_xlabel()
    finally:
        plt.close(fig)


def _overlapping_tick_labels(fig):
    """(axes title, axis) of every axis with two visible tick labels whose boxes overlap."""
    fig.canvas.draw()
    r = fig.canvas.get_renderer()
    out = []
    for ax in fig.axes:
        for w in ("x", "y"):
            b = [t.get_window_extent(r) for t in getattr(ax, f"get_{w}ticklabels")() if t.get_visible() and t.get_text()]
            if any(p.overlaps(q) for i, p in enumerate(b) for q in b[i + 1:]):
                out.append((ax.get_title(loc="left"), w))
    return out


def test_poincare_figure_layout_labels_and_title():
    """Issue 42 item 10: Poincaré plots overlapped their tick labels (a collapsed section's
    -0.01825 ... -0.01675 without an offset), printed U(L_S), L_S literally, mixed q' with the
    other figures' q-dot, lacked the case name and titled a chatter point 'period 0, chatter'."""
    from vibeam.analysis.poincare import PoincareSection, poincare_figure

    one = dict(Omega=2.0, strobe_q=-0.0175 + 1e-9 * np.arange(8), strobe_dq=np.full(8, -9.4e-4),
               impact_phase=np.full(8, 3.14), impact_velocity=np.full(8, 0.0184))
    for phys in (False, True):
        scales = dict(length_m=0.18, natural_frequency_hz=7.6) if phys else {}
        p = PoincareSection(**one, **scales, period=0, status="chatter", name="rig-tight")
        fig = poincare_figure(p)
        try:
            assert all(UNIT.search(ax.get_xlabel()) and UNIT.search(ax.get_ylabel()) for ax in fig.axes)
            assert not _overlapping_tick_labels(fig), _overlapping_tick_labels(fig)
            a0, a1 = fig.axes[:2]
            if phys:
                assert (a0.get_xlabel(), a0.get_ylabel()) == ("$U(L_S)$ (mm)", r"$\dot U(L_S)$ (mm/s)")
            else:
                assert (a0.get_xlabel(), a0.get_ylabel()) == ("$q$ (–)", r"$\dot q$ (–)")
            for lab in (a0.get_xlabel(), a0.get_ylabel(), a1.get_ylabel()):
                assert "'" not in lab and not re.search(r"(?<!\$)L_S(?![^$]*\$)", lab.replace("$U(L_S)$", "")), lab
            title = fig._suptitle.get_text()
            assert title.startswith("rig-tight: Poincaré sections"), title
            assert title.split("\n")[-1] == "chatter", title
            assert "period 0" not in title and "Omega" not in title.replace(r"$\Omega$", ""), title
        finally:
            plt.close(fig)


def test_motion_text():
    from vibeam.plots.style import motion_text

    assert motion_text(0, "chatter") == "chatter"
    assert motion_text(1, "ok") == "period-1"
    assert motion_text(2, "sticking") == "period-2, sticking"
    assert motion_text(-1, "unsettled") == "no impact, unsettled"
    assert motion_text(0, "ok") == "not periodic within 8 periods"


def test_simulation_and_poincare_of_a_case_name_it_and_keep_status_out_of_the_legend():
    """Issue 42 item 10: Simulation.plot()'s legend said 'ok' (the status); the Poincaré plot of
    `vibeam poincare` / vibeam.poincare had no case name in its title."""
    import vibeam

    fig7 = ROOT / "cases" / "paper-fig7.toml"
    sim = vibeam.simulate(fig7, Omega=2.0, periods=4, transient=200)
    assert sim.status == "ok"
    fig = sim.plot()
    try:
        check_figure(fig, "simulation")
        texts = [t.get_text() for leg in fig.legends for t in leg.get_texts()]
        assert not any(re.search(r"\bok\b", t) for t in texts), texts
        title = fig._suptitle.get_text()
        assert title.startswith("paper-fig7: ") and "period-1" in title, title
    finally:
        plt.close(fig)
    sec = vibeam.poincare(fig7, Omega=2.0, periods=4, transient=200)
    fig = sec.plot()
    try:
        assert fig._suptitle.get_text().startswith("paper-fig7: Poincaré sections")
        assert not _overlapping_tick_labels(fig), _overlapping_tick_labels(fig)
    finally:
        plt.close(fig)


def test_decay_figure_house_style_and_data_above_the_fit(tmp_path):
    """Issue 42 item 10: decay.png ignored the house style (no figure title, labels without the
    quantity's symbol, legends inside the data) and hid the data (pixel markers, drawn first)
    under the fit.  Now: the record's dots above a thin fit line, a figure legend outside the
    axes, titles, the style's labels."""
    from vibeam.identify.linear import _plot_decay, damped_response, fit_decay, log_decrement

    t = np.arange(0, 2.0, 1 / 1000)
    U = damped_response(t, 7.75, 0.02, 1.0, 0.0, 0.0) + np.random.default_rng(1).normal(0, 0.01, t.size)
    ld = log_decrement(t, U)
    fd = fit_decay(t, U, ld)
    with written_figures() as figs:
        _plot_decay(t, U, ld, fd, tmp_path / "decay.png", "rig-neutral: free decay")
    fig = figs["decay.png"]
    check_figure(fig, "decay")
    assert fig._suptitle.get_text().startswith("rig-neutral: free decay")
    ax = fig.axes[0]
    data = next(l for l in ax.get_lines() if len(l.get_xdata()) == t.size and np.array_equal(l.get_ydata(), U))
    fit = next(l for l in ax.get_lines() if l is not data and len(l.get_xdata()) == t.size)
    assert data.get_zorder() > fit.get_zorder(), "the fit is drawn over the data"
    assert data.get_marker() not in (",", "", "None") and data.get_linestyle() in ("None", "none", "")
    assert fit.get_linewidth() <= 0.8
    assert ax.get_ylabel() == "displacement $U(L_S)$ (mm)" and fig.axes[1].get_xlabel() == "time t (s)"
    assert not [a.get_legend() for a in fig.axes if a.get_legend() is not None], "legend inside the data"
    assert not ax.spines["top"].get_visible()          # the house style's rc (style.RC)


def test_basin_plot_attractor_dots_are_in_the_legend():
    """Issue 42 item 10: the basin plot drew each attractor's stroboscopic samples as black dots
    over the basins without a legend entry.  Every kind of artist drawn has its entry: the
    basins' colours, the attractors' dots (issue 56: in each attractor's colour, a handle with the
    dots' marker and colour naming the attractor), the stops; the grid's velocity is q-dot as in
    every other figure."""
    import vibeam
    from vibeam.analysis.attractors import basins_figure

    r = vibeam.basins(ROOT / "cases" / "paper-fig7-two-sided.toml", Omega=2.0, grid=(6, 5), lyapunov_periods=0)
    fig = basins_figure(r, 0)
    try:
        dots = [l for l in fig.axes[0].lines if l.get_gid() == "attractor" and l.get_linestyle() in ("None", "none")]
        assert dots, "no attractor dots drawn"
        hs = [(h, t.get_text()) for leg in fig.legends for h, t in zip(leg.legend_handles, leg.get_texts())]
        dot_entries = [t for h, t in hs if hasattr(h, "get_marker") and h.get_marker() == dots[0].get_marker()
                       and _hex(h.get_markerfacecolor()) == _hex(dots[0].get_markerfacecolor())]
        assert dot_entries and "attractor" in dot_entries[0], [t for _, t in hs]
        assert fig.axes[0].get_ylabel() == r"$\dot q$ (–)"
    finally:
        plt.close(fig)
    s = vibeam.basins(ROOT / "cases" / "paper-fig7-two-sided.toml", Omega=2.0, samples=20, seed=1,
                      lyapunov_periods=0)
    fig = basins_figure(s, 0)                  # sampled states: the coloured dots have their entry too
    try:
        texts = [t.get_text() for leg in fig.legends for t in leg.get_texts()]
        assert any(t.startswith("starting state") for t in texts), texts
    finally:
        plt.close(fig)


def test_work_precision_plots_the_error_against_the_converged_reference():
    """Issue 42 item 10: `vibeam cost`'s work_precision.png drew each row's own-method error
    (event against event with the same transient: 0, on the 1e-16 floor for every rung of a
    ladder) where the README speaks of the error against the mesh-converged model.  The figure
    draws error_max (against the converged reference; for a beam the finest FE model), says so
    on its axis and names the reference."""
    from vibeam.analysis.cost import CostRow, ModelSources, work_precision_figure

    def row(run, t, err):
        return CostRow(run=run, method="event", settings={}, time_s=t, err_max=err, err_rms=err / 2,
                       n_period_diff=0, n_points=5, n_nonperiodic_ref=0, time_rel_event=1.0, err_method_max=0.0,
                       err_method_rms=0.0, against="event, same transient", model_key=run)
    rows = [row("FE 1 mode", 0.5, 0.30), row("FE 2 modes", 1.0, 0.12), row("FE all modes", 9.0, 2e-3)]
    models = {r.run: ModelSources(key=r.run, label=r.run, event_time_s=r.time_s, transient_periods=300,
                                  reference_periods=2000, transient_max=1e-9, transient_rms=1e-10, n_compared=5,
                                  model_max=r.err_max) for r in rows}
    fig = work_precision_figure({"rows": rows, "models": models, "reference_periods": 2000}, "ladder")
    try:
        check_figure(fig, "work-precision")
        ax = fig.axes[0]
        series = {_hex(l.get_color()): l for l in ax.get_lines() if l.get_transform() is ax.transData}
        legend = legend_colours(fig)
        for r in rows:
            line = series[next(c for lab, c in legend.items() if lab.startswith(f"{r.run} (event"))]
            np.testing.assert_array_equal(line.get_ydata(), [r.err_max])
        assert "converged reference" in ax.get_ylabel()
        assert "finest FE model" in fig._suptitle.get_text()
    finally:
        plt.close(fig)


def test_modes_figure_marks_the_positions_in_mathtext():
    """Issue 42 item 10: modes.png printed 'L_S' and 'L_m' literally at the sensor's and the
    mass's lines; they are mathtext ($L_S$, $L_m$)."""
    import vibeam

    fig = vibeam.modes(ROOT / "cases" / "rig-fe-neutral.toml", n=4).plot()
    try:
        texts = [t.get_text() for ax in fig.axes for t in ax.texts]
        assert "$L_S$" in texts and "$L_m$" in texts, texts
        assert not [t for t in texts if "_" in re.sub(r"\$[^$]*\$", "", t)], texts
    finally:
        plt.close(fig)
