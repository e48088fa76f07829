"""Figures fit for a paper and output people read (issue 22), checked on the shipped quick cases
(small point counts) by reading matplotlib's artists back: marker sizes and edges, shared
axes, legend positions, label text, line styles, both sweep directions; and the printed run
summary and `vibeam cost` text against the results file they report on.

Oracles are independent of the code under test: the results file read with h5py-backed
:class:`vibeam.api.Results` and recomputed with numpy (peaks, counts, differences, agreement
counts), the console text parsed back, and the figures' artists."""
from __future__ import annotations

import dataclasses
import re
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402
from matplotlib.colors import to_hex, to_rgb  # noqa: E402

from vibeam.api import Results  # noqa: E402
from vibeam.cli import main  # noqa: E402
from vibeam.plots import style  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
CASES = ROOT / "cases"


def _run(case: str, out: Path, capsys=None, tables: bool = False) -> tuple:
    """``vibeam run CASE --quick --no-plots`` (inline) into ``out``; (Results, its stdout).  --quiet
    only when the stdout is not read (capsys, or ``tables`` for a caller that captures it): --quiet
    drops the tables (issue 42 item 7)."""
    quiet = capsys is None and not tables
    assert main(["run", str(CASES / f"{case}.toml"), "--quick", "--out", str(out), "--jobs", "1",
                 *(["--quiet"] if quiet else []), "--no-plots"]) == 0
    printed = capsys.readouterr().out if capsys is not None else ""
    return Results.from_file(out / "results.h5"), printed


def _texts(fig) -> list:
    """Every text a reader sees, ticks aside: suptitle, axis labels, titles, legend entries and titles."""
    out = [fig._suptitle.get_text()] if fig._suptitle is not None else []
    for ax in fig.axes:
        out += [ax.get_xlabel(), ax.get_ylabel()] + [ax.get_title(loc=k) for k in ("left", "center", "right")]
        out += [t.get_text() for t in ax.texts]
        if ax.get_legend() is not None:
            out += [t.get_text() for t in ax.get_legend().get_texts()]
    for leg in fig.legends:
        out += [t.get_text() for t in leg.get_texts()] + [leg.get_title().get_text()]
    return [t for t in out if t]


def _raw_underscores(fig, names=()) -> list:
    """Texts with an underscore outside mathtext ($...$), run names removed (a run's name is
    the user's and shown as written)."""
    bad = []
    for t in _texts(fig):
        plain = re.sub(r"\$[^$]*\$", "", t)
        for n in names:
            plain = plain.replace(n, "")
        if "_" in plain:
            bad.append(t)
    return bad


@pytest.fixture(scope="module")
def fe_loose(tmp_path_factory):
    """rig-fe-loose's quick ladder (5 rungs x 5 points, up and down) with its printed summary."""
    import contextlib
    import io

    out = tmp_path_factory.mktemp("fe-loose")
    buf = io.StringIO()
    with contextlib.redirect_stdout(buf):
        res, _ = _run("rig-fe-loose", out, tables=True)
    return res, buf.getvalue()


# ----------------------------------------------------------------------------- 1. bifurcation
def test_bifurcation_dots_are_small_without_edges_and_the_ladder_shares_y(fe_loose):
    """Every sample a dot of markersize <= 1.5 and no edge (mew 0, or an edge colour equal to
    the face); all stacked panels share one y axis (and x); both sweep directions drawn for
    every rung; the mathtext labels carry no raw underscore."""
    res, _ = fe_loose
    fig = res.plot_bifurcation()
    try:
        axes = fig.axes
        assert len(axes) == 2 * len(res.runs)
        drawn = {}
        for ax in axes:
            assert axes[0].get_shared_y_axes().joined(axes[0], ax), ax.get_title(loc="left")
            assert axes[0].get_shared_x_axes().joined(axes[0], ax)
            for line in ax.get_lines():
                if line.get_gid() == "stop":     # a stop's horizontal line (two-sided scenes), not a sample
                    continue
                assert line.get_markersize() <= 1.5, line.get_markersize()
                assert line.get_markeredgewidth() == 0 or \
                    to_hex(line.get_markeredgecolor()) == to_hex(line.get_markerfacecolor())
                assert line.get_linestyle() in ("None", "none", "")
                drawn.setdefault(ax.get_title(loc="left"), set()).add(ax.get_title(loc="right"))
        assert drawn == {f"{r.name} ({r.method})": {"up sweep", "down sweep"} for r in res.runs}
        assert not _raw_underscores(fig, [r.name for r in res.runs])
        # the y label is mathtext: U(L_S) with a subscript, not the literal "L_S"
        assert "$U(L_S)$" in axes[0].get_ylabel()
    finally:
        plt.close(fig)


# ----------------------------------------------------------------------------- 2. labels, subtitles
def test_subtitle_wraps_between_phrases_not_inside_them():
    """A subtitle of phrases ('; ' and ' · ' separators) wrapped to a narrow figure: every phrase
    shorter than a line stays whole on one line; a phrase longer than a line breaks only at
    ', '.  (textwrap alone breaks mid-phrase here: checked, so the test can fail.)"""
    import textwrap

    sub = ("FE beam: R = 0.59, ζ = 0.017, gap = 0.1 mm, γ = 0.000766 /V, V = 0.6 V, L = 180 mm, "
           "elements = 24; 100 + 16 periods per point, up and down · sweeps overlaid (grey)")
    fig = plt.figure(figsize=(4.0, 3.0))           # 52 characters a line
    try:
        style.titles(fig, "case", sub)
        lines = fig._suptitle.get_text().split("\n")[1:]
        width = max(40, int(4.0 * 13))
        assert all(len(l) <= width for l in lines), lines
        phrases = re.split(r"; | · ", sub)
        for p in phrases:
            if len(p) <= width:
                assert any(p in l for l in lines), (p, lines)
            else:                                    # broken at ', ' only
                clauses = p.split(", ")
                assert all(any(c in l for l in lines) for c in clauses), (p, lines)
        naive = textwrap.wrap(sub, width)
        assert not all(any(p in l for l in naive) for p in phrases if len(p) <= width)
    finally:
        plt.close(fig)


def test_shipped_figures_have_mathtext_labels_and_phrase_wrapped_subtitles(fe_loose, tmp_path):
    """The FRC, bifurcation, map and agreement figures of shipped quick cases: no raw
    underscore outside $...$; the subtitle's last phrase ('100 + 16 periods per point, up and
    down') whole on one line."""
    res, _ = fe_loose
    maps, _ = _run("paper-fig18-fe", tmp_path / "fe18")
    figs = [res.plot_frc(), res.plot_bifurcation(), maps.plot_map(maps.maps[0].name), maps.plot_agreement()]
    try:
        names = [r.name for r in res.runs] + [m.name for m in maps.maps]
        for fig in figs:
            assert not _raw_underscores(fig, names), _raw_underscores(fig, names)
        for fig in figs[:2]:
            lines = fig._suptitle.get_text().split("\n")
            assert any("100 + 16 periods per point, up and down" in l for l in lines), lines
    finally:
        for f in figs:
            plt.close(f)


# ----------------------------------------------------------------------------- 3. continuation
@pytest.fixture(scope="module")
def fig13_branches():
    """The continuation of paper-fig13-continuation's quick variant (periods 1, 2, 4, 8)."""
    from vibeam.analysis import branches
    from vibeam.case.schema import load_case

    case, _ = load_case(CASES / "paper-fig13-continuation.toml")
    case = case.quick_variant()
    r = next(r for r in case.run if r.method == "continuation")
    task = branches.plan(case, r)
    return case, branches.assemble(task, branches.run_continuation(task))


def _colour_distance(a, b) -> float:
    """Euclidean distance of two colours in RGB (0..1 per channel; black-white = 1.73)."""
    return float(np.linalg.norm(np.subtract(to_rgb(a), to_rgb(b))))


def test_continuation_branches_distinguishable_and_markers_apart(fig13_branches):
    """Periods 1, 2, 4, 8 each with a colour and a marker of their own; stable stretches solid,
    unstable dashed, both said in the legend; the period-doubling markers in a colour at least
    0.5 (RGB distance; the palette's nearest pair, blue-green, is 0.58) from every branch
    colour, none closer than MARKER_SPACING of the axes to another, drawn above the branches;
    without sweeps the subtitle promises none."""
    from vibeam.analysis.branches import MARKER_SPACING, MARKERS, continuation_figure

    case, r = fig13_branches
    assert sorted({b["n"] for b in r.branches}) == [1, 2, 4, 8]
    fig = continuation_figure(r, [], title=case.name, case=case)
    try:
        ax = fig.axes[0]
        lines = [l for l in ax.get_lines() if l.get_linestyle() not in ("None", "none", "")]
        by_colour = {}
        for l in lines:
            by_colour.setdefault(to_hex(l.get_color()), set()).add(l.get_marker())
            assert l.get_linestyle() in ("-", "--"), l.get_linestyle()
        assert len(by_colour) == 4, by_colour                       # one colour per period
        marks = [next(iter(m)) for m in by_colour.values()]
        assert all(len(m) == 1 for m in by_colour.values()) and len(set(marks)) == 4   # one marker per period
        legend = [t.get_text() for t in fig.legends[0].get_texts()]
        assert {f"period-{n} branch" for n in (1, 2, 4, 8)} <= set(legend)
        assert any(t.startswith("stable (solid") for t in legend) and any(t.startswith("unstable (dashed")
                                                                           for t in legend)
        # the stability of the drawn stretches: the period-1 branch is stable at its start, and
        # unstable past its period doubling (dashed there)
        p1 = to_hex(style.branch_style(1)[0])
        assert {l.get_linestyle() for l in lines if to_hex(l.get_color()) == p1} == {"-", "--"}
        pd_colour = MARKERS["period_doubling"][1]
        pds = [l for l in ax.get_lines() if l.get_marker() == "D"]
        assert len(pds) == 1
        pd = pds[0]
        for c in by_colour:
            assert _colour_distance(pd_colour, c) >= 0.5, (pd_colour, c)
        assert to_hex(pd.get_markerfacecolor()) == to_hex(pd_colour)
        assert pd.get_zorder() > max(l.get_zorder() for l in lines)
        (x0, x1), (y0, y1) = ax.get_xlim(), ax.get_ylim()
        px = (np.asarray(pd.get_xdata(), float) - x0) / (x1 - x0)
        py = (np.asarray(pd.get_ydata(), float) - y0) / (y1 - y0)
        for i in range(len(px)):
            for j in range(i):
                assert max(abs(px[i] - px[j]), abs(py[i] - py[j])) >= MARKER_SPACING, (i, j)
        sub = fig._suptitle.get_text()
        assert "periods per point" not in sub and "overlaid (grey)" not in sub and "no sweep overlaid" in sub
    finally:
        plt.close(fig)


def test_continuation_subtitle_names_the_sweeps_it_overlays(fig13_branches):
    """With a sweep overlaid, the subtitle gives the sweep's settings and says so."""
    from vibeam.analysis.branches import continuation_figure

    case, r = fig13_branches

    class Sweep:
        name = "exact"
        data = {"Omega": np.array([1.6, 2.0, 2.4]), "amplitude": np.array([0.003, 0.017, 0.003]),
                "direction": np.array(["up", "up", "down"], dtype=object)}

    fig = continuation_figure(r, [Sweep()], title=case.name, case=case)
    try:
        sub = fig._suptitle.get_text().replace("\n", " ")
        assert "periods per point" in sub and "sweeps overlaid (grey)" in sub
    finally:
        plt.close(fig)


# ----------------------------------------------------------------------------- 4. maps agreement
def test_maps_agreement_both_directions_console_count_and_legend(tmp_path, capsys):
    """paper-fig18-fe (two maps, up and down): one panel per direction whose count is the
    file's number of differing cells of that direction; the figure's title gives the console's
    count (parsed from `vibeam run`'s output) which is the file's over both directions; the
    legend says whose class the colours show."""
    res, printed = _run("paper-fig18-fe", tmp_path / "o", capsys)
    ref, other = res.maps[0], res.maps[1]
    m = re.search(rf"'{re.escape(other.name)}' vs '{re.escape(ref.name)}': classes differ at (\d+) of (\d+) "
                  rf"points", printed)
    assert m, printed
    n, of = int(m.group(1)), int(m.group(2))
    a, b = np.asarray(ref.data["classification"]), np.asarray(other.data["classification"])
    assert (n, of) == (int((a != b).sum()), a.size)          # the console against the file
    fig = res.plot_agreement()
    try:
        assert f"'{other.name}' {n} of {of} points" in fig._suptitle.get_text().replace("\n", " ")
        dirs = {}
        for ax in fig.axes:
            t = ax.get_title(loc="left")
            d = re.search(r", (up|down) sweep: (\d+) of (\d+) differ", t)
            assert d, t
            k = list(ref.data["direction"]).index(d.group(1))
            assert int(d.group(2)) == int((a[k] != b[k]).sum()) and int(d.group(3)) == a[k].size
            dirs[d.group(1)] = int(d.group(2))
        assert sorted(dirs) == ["down", "up"] and sum(dirs.values()) == n
        title = fig.legends[0].get_title().get_text()
        assert f"the class of '{other.name}'" in title and f"differs from '{ref.name}'" in title
    finally:
        plt.close(fig)


# ----------------------------------------------------------------------------- 5. fit.png
@pytest.fixture(scope="module")
def loose_fit():
    """A one-parameter fit (gain) of rig-loose's quick variant to 8 synthetic points per
    direction with seeded noise (~6 s)."""
    from vibeam.case.schema import load_case
    from vibeam.identify.fit import fit_case, synthetic_reference

    case, _ = load_case(CASES / "rig-loose.toml")
    case = case.quick_variant()
    ref = synthetic_reference(case, np.linspace(14.0, 16.5, 8), values={"gain": 7.66e-4},
                              directions=("up", "down"), sigma=0.01, seed=1)
    return fit_case(case, ref, params=["gain"], x0={"gain": 7.3e-4}, max_evaluations=20)


def test_fit_figure_house_style_legend_outside_up_on_top_and_verdict(loose_fit):
    """fit.png: up sweep in the palette's first colour, filled, drawn above the down sweep
    (second colour, open markers, dashed model); one figure legend whose box lies outside
    every axes; the verdict with its reason in the figure's text (reliable, and a copy made
    NOT reliable with a note)."""
    from vibeam.identify.fit import fit_figure

    res = loose_fit
    fig = fit_figure(res)
    try:
        ax, axr = fig.axes[:2]
        by = {l.get_label(): l for l in ax.get_lines()}
        by.update({c.get_label(): c.lines[0] for c in ax.containers})      # data with error bars
        up, down = by["data (up)"], by["data (down)"]
        assert to_hex(up.get_color()) == to_hex(style.PALETTE[0]) and to_hex(down.get_color()) == \
            to_hex(style.PALETTE[1])
        assert up.get_markerfacecolor() != "none" and down.get_markerfacecolor() == "none"
        assert up.get_zorder() > down.get_zorder()
        assert by["fitted model (up)"].get_zorder() > by["fitted model (down)"].get_zorder()
        assert by["fitted model (up)"].get_linestyle() == "-" and by["fitted model (down)"].get_linestyle() == "--"
        assert not any(a.get_legend() for a in fig.axes) and len(fig.legends) == 1
        fig.canvas.draw()
        lb = fig.legends[0].get_window_extent()
        for a in (ax, axr):
            assert not lb.overlaps(a.get_window_extent()), "the legend covers data"
        sub = fig._suptitle.get_text().replace("\n", " ")
        assert ("standard errors NOT reliable" in sub) == (not res.reliable)
        assert "standard errors reliable" in sub or "NOT reliable" in sub
        assert not _raw_underscores(fig)
    finally:
        plt.close(fig)
    bad = dataclasses.replace(res, reliable=False, notes=["fewer periodic points than parameters"])
    fig = fit_figure(bad)
    try:
        sub = fig._suptitle.get_text().replace("\n", " ")
        assert "standard errors NOT reliable: fewer periodic points than parameters" in sub
    finally:
        plt.close(fig)


# ----------------------------------------------------------------------------- 6. run summary
def _section(printed: str, name: str) -> list:
    """The physics lines of run ``name`` in the printed summary."""
    lines = printed.split("\n")
    i = lines.index(f"  {name}")
    return lines[i + 1:i + 4]


def test_ladder_summary_prints_physics_against_the_all_modes_rung(fe_loose):
    """rig-fe-loose: the comparison column is against 'FE all modes' (the rung with the most
    modes) and each rung's number is max |dA| against it, recomputed from the file; each run's
    peak amplitude and frequency per direction, its counts per period-n and status equal the
    file's; both sweeps' jumps are reported."""
    res, printed = fe_loose
    assert "max |dA| vs FE all modes (mm)" in printed
    ref = next(r for r in res.runs if r.name == "FE all modes")
    for r in res.runs:
        row = next(l for l in printed.split("\n") if l.startswith(r.name + " ") and "event" in l)
        if r is ref:
            assert "reference" in row
        else:
            want = np.nanmax(np.abs(np.asarray(r.data["amplitude_mm"]) - np.asarray(ref.data["amplitude_mm"])))
            assert f"{want:.3e}" in row, (row, want)
        peak, points, jumps = _section(printed, r.name)
        x, a = np.asarray(r.data["frequency_hz"]), np.asarray(r.data["amplitude_mm"])
        d = np.asarray(r.data["direction"]).astype(str)
        for dname in ("up", "down"):
            s = d == dname
            i = np.nanargmax(a[s])
            assert f"{a[s][i]:.4g} mm at {x[s][i]:.4g} Hz ({dname})" in peak, peak
        per, n = np.unique(np.asarray(r.data["period"]), return_counts=True)
        for p, k in zip(per, n):
            name = {-1: "no impact", 0: "non-periodic"}.get(int(p), f"period-{int(p)}")
            assert f"{name} {k}" in points, points
        st, n = np.unique(np.asarray(r.data["status"]).astype(str), return_counts=True)
        for s_, k in zip(st, n):
            assert f"{s_} {k}" in points
        assert jumps.startswith("    jumps: up sweep") and "; down sweep" in jumps, jumps
    # the rungs' peaks against the all-modes rung: a signed difference in brackets
    assert re.search(r"\[[+-]\d+\.\d%, [+-]", _section(printed, "static mode (SDOF)")[0])


def test_one_run_summary_has_no_reference_error(tmp_path, capsys):
    """rig-loose (one run): no comparison column and no 'reference' printed; its physics is."""
    res, printed = _run("rig-loose", tmp_path / "o", capsys)
    table = printed.split("\nphysics")[0]
    assert "reference" not in table and "max |dA|" not in table
    assert "peak amplitude: " in printed and "jumps: up sweep" in printed


# ----------------------------------------------------------------------------- 7. vibeam cost
def test_time_ratios_read_as_ratios():
    """0.98 -> '0.98x the time of direct', 1/45 -> '45x faster than direct', 2.5 -> 2.5x the
    time; never a negative or 100 % 'less time'."""
    from vibeam.analysis.cost import time_ratio

    assert time_ratio(0.98) == "0.98x the time of direct"
    assert time_ratio(1 / 45) == "45x faster than direct"
    assert time_ratio(2.5) == "2.5x the time of direct"
    assert time_ratio(0.2) == "5x faster than direct"


def test_cost_claims_as_ratios_and_a_shared_reason_once(capsys):
    """The paper's time claims with measured times 1.02x and 1/45 of direct's: printed as
    ratios ('1x the time', '45x faster'), no '% less'; ivanov and zhuravlev share their reason,
    printed once (the second says 'as for ivanov above')."""
    from vibeam.analysis.cost import CostRow, paper_claims, print_cost

    def row(method, t):
        return CostRow(run=method, method=method, settings={"solver": "RK23", "rtol": 1e-4}, time_s=t,
                       err_max=0.0, err_rms=0.0, n_period_diff=0, n_points=3, n_nonperiodic_ref=0, case_settings=True)

    rows = [row("direct", 1.0), row("ivanov", 1.02), row("zhuravlev", 1 / 45)]
    claims = [c for c in paper_claims(rows, None) if c["claim"].split(":")[0] in ("ivanov", "zhuravlev")]
    assert len(claims) == 2
    print_cost({"rows": rows, "models": {}, "reference_periods": 2000, "transient_periods": 150,
                "claims": claims})
    out = capsys.readouterr().out
    assert "less time" not in out and "% less" not in out
    assert "1x the time of direct" in out and "45x faster than direct" in out
    assert "5x faster than direct (paper" in out                 # ivanov: 80 % saved = 0.2x the time
    why = claims[0]["why"]
    assert why and claims[1]["why"] == why                      # the shared reason...
    assert out.count(why) == 1 and "why: as for ivanov above" in out   # ...printed once
