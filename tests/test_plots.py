"""Every figure of every shipped case's quick variant: non-empty, labelled axes with units,
titles, legends without empty entries (the matplotlib Figure objects, not pixels); and the
plot conventions (range bars at non-periodic points, up/down, colours, one-value maps)."""
from __future__ import annotations

import re
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402

from vibeam import assess  # noqa: E402
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
        out["frc"] = res.plot_frc()
        out["bifurcation"] = res.plot_bifurcation()
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


# the two tight FE ladders (~20-30 s each for their quick results) run in the slow step
_SLOW_CASES = {"rig-fe-tight-continuation", "rig-fe-tight"}


@pytest.mark.parametrize("path", [pytest.param(p, marks=pytest.mark.slow) if p.stem in _SLOW_CASES else p
                                  for p in CASES], ids=[p.stem for p in CASES])
def test_every_figure_of_every_quick_case(path, quick_results):
    out = quick_results(path)
    res = Results.from_file(out / "results.h5")
    figs = figures(res)
    drawn = {k: f for k, f in figs.items() if f is not None}
    try:
        if res.runs:
            assert "frc" in drawn
        if res.maps:
            assert all(f"map {m.name}" in drawn for m in res.maps)
        if res.case.assess.spectra:
            assert "spectra" in drawn
        for k, fig in drawn.items():
            check_figure(fig, f"{path.stem}: {k}")
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
    from vibeam.sweep import SweepResult

    data = dict(Omega=np.asarray(Omega, float), amplitude=np.asarray(amp, float), period=np.asarray(period),
                direction=np.asarray(direction, dtype=object),
                status=np.array(["ok"] * len(Omega), dtype=object), **extra)
    return SweepResult(name=name, fidelity="sdof", method="event", settings={}, data=data, wall_time_s=0.0)


def test_frc_range_bars_up_down_and_failed_points():
    """Non-periodic points get a bar over amplitude_min..amplitude_max; up is solid with filled
    markers, down dashed with open ones; failed points are red crosses at the bottom."""
    from vibeam.plots import frc_figure

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
    from vibeam.plots import bifurcation_figure, frc_figure
    from vibeam.style import PALETTE, colours

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
    from vibeam.maps import MapResult

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
    from vibeam.maps import NON_PERIODIC, map_figure

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
    from vibeam.maps import PERIOD_1, PERIOD_2, agreement_figure, map_figure

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
    from vibeam import branches
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
