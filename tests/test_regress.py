"""`vibeam regress` against HDF5 and CSV references: periodic points by amplitude, the other
points by the spread of their per-period amplitude."""
import h5py
import pytest
import numpy as np

from vibeam.cli import main
from vibeam.models import linear_amplitude
from vibeam.analysis.regress import compare

# no impact on the whole grid: Delta = 0.15 lies beyond the largest linear amplitude
# C(Omega) <= B / (2 beta) = 0.1, so the FRC is Delta + C(Omega) in closed form.  The response C
# is 0.005-0.1 while the amplitude Q = Delta + C is 0.155-0.25: rtol 1e-6 (4e-7 of the largest Q)
# is 1e-4 of the smallest response, and the remaining transient after 300 periods is
# exp(-0.05 * 300 * 2 pi / 1.5) < 1e-27
CASE = """
name = "reg"
[model]
fidelity = "sdof"
beta = 0.05
B = 0.01
R = 0.8
Delta = 0.15
[sweep]
Omega = [0.5, 1.5, 201]
transient_periods = 300
record_periods = 4
[regress]
amplitude_rtol = 1e-6
[[run]]
name = "exact"
method = "event"
"""


def _response(W):
    return linear_amplitude(0.05, 0.01, W)


def test_regress_hdf5_self_passes_and_a_perturbed_response_fails(tmp_path, capsys):
    case = tmp_path / "reg.toml"
    case.write_text(CASE)
    out = tmp_path / "a"
    assert main(["run", str(case), "--out", str(out), "--jobs", "1", "--quiet", "--no-plots"]) == 0
    ref = out / "results.h5"
    assert main(["regress", str(case), "--reference", str(ref), "--results", str(ref)]) == 0
    bad = tmp_path / "bad.h5"
    for i in (0, 100, 200):   # the smallest, the largest and an intermediate response
        bad.write_bytes(ref.read_bytes())
        with h5py.File(bad, "r+") as f:
            a = f["runs/exact/amplitude"]        # (direction, Omega)
            W = f["runs/exact/Omega"][i]
            v = a[()]
            v[0, i] += 1e-3 * _response(W)   # 0.1 % of the response at one point
            a[...] = v
        capsys.readouterr()
        assert main(["regress", str(case), "--reference", str(bad), "--results", str(ref)]) == 1, i
        assert "REGRESSION" in capsys.readouterr().out


def test_regress_against_an_analytic_csv(tmp_path):
    """Far from the stop the FRC is Delta + C(Omega) (closed form), sampled off the grid; a CSV
    whose response is 0.1 % off fails."""
    case = tmp_path / "reg.toml"
    case.write_text(CASE)
    csv = tmp_path / "ref.csv"
    out = tmp_path / "b"
    # linear interpolation between grid points (spacing 0.005) errs by <= C'' h^2 / 8 ~ 1e-5 of Q
    # near the resonance peak: the CSV points sit on the grid here, so only round-off remains
    W = np.round(np.linspace(0.5, 1.5, 201)[4:-4:5], 12)
    csv.write_text("Omega,amplitude\n" + "\n".join(f"{float(w)!r},{float(0.15 + _response(w))!r}" for w in W))
    assert main(["regress", str(case), "--reference", str(csv), "--out", str(out), "--jobs", "1"]) == 0
    csv.write_text("Omega,amplitude\n" + "\n".join(f"{float(w)!r},{float(0.15 + 1.001 * _response(w))!r}" for w in W))
    assert main(["regress", str(case), "--reference", str(csv),
                 "--results", str(out / "results.h5")]) == 1


def _fake(tmp_path, name, rows):
    """A results file with one run of the given per-point rows (only what compare reads)."""
    from vibeam.io.results import write_results
    from vibeam.engine.sweep import Sweep, SweepResult, stack

    sw = Sweep(Omega=np.array([r["Omega"] for r in rows]), record_periods=16)
    res = SweepResult(name="exact", fidelity="sdof", method="event", settings={}, data=stack(rows, sw),
                      wall_time_s=0.0)
    return write_results(tmp_path / name, [res], "c", "")


def _row(W, period, mean, std, lo, hi, status="ok", amplitude=None):
    return dict(Omega=W, direction="up", period=period, status=status, message="",
                amplitude=hi if amplitude is None else amplitude, amplitude_mean=mean,
                amplitude_std=std, amplitude_min=lo, amplitude_max=hi, record_periods=16)


def test_non_periodic_points_compared_by_their_spread(tmp_path):
    """Non-periodic points (period 0) are two samples of an attractor: their amplitudes (the
    largest Q_k) may differ, their spreads may not.  Means within 4 standard errors of the
    difference (SE = std sqrt(2 / 16) = 0.35 std here) and extremes within half the range
    pass; a mean 5 SE off, a range shifted by its whole width, or a no-impact orbit in place
    of the chaos fail.  Periodic points keep the amplitude check."""
    from vibeam.io.results import read_results

    ref = _fake(tmp_path, "ref.h5", [_row(1.0, 1, 2.0, 0.0, 2.0, 2.0),
                                      _row(2.0, 0, 3.0, 0.4, 2.2, 3.9)])
    se = 0.4 * np.sqrt(2 / 16)

    def verdict(row2, row1=None):
        new = read_results(_fake(tmp_path, "new.h5", [row1 or _row(1.0, 1, 2.0, 0.0, 2.0, 2.0), row2]))
        r = compare(new, ref, atol=0.0, rtol=1e-6, period=False)[0]
        return r.failures, r.spread_points

    # another sample of the same attractor: other amplitude (its largest Q_k), same statistics
    assert verdict(_row(2.0, 0, 3.0 + 3.5 * se, 0.45, 2.4, 3.6)) == (0, 1)
    assert verdict(_row(2.0, 0, 3.0 + 5 * se, 0.4, 2.2, 3.9)) == (1, 1)
    assert verdict(_row(2.0, 0, 3.0, 0.4, 2.2 + 0.9, 3.9 + 0.9)) == (1, 1)   # range moved by 0.9 > 0.85
    # the no-impact orbit instead of the chaos (period -1, std 0): the mean is far off
    assert verdict(_row(2.0, -1, 1.3, 0.0, 1.3, 1.3)) == (1, 1)
    # a periodic point is still held to the amplitude (rtol 1e-6)
    assert verdict(_row(2.0, 0, 3.0, 0.4, 2.2, 3.9), _row(1.0, 1, 2.0, 0.0, 2.0, 2.0 * (1 + 1e-5))) == (1, 1)
    # an unsettled point is compared by its spread even with the same period (here its
    # amplitude is 1e-3 off, its spread equal)
    assert verdict(_row(2.0, 0, 3.0, 0.4, 2.2, 3.9),
                   _row(1.0, 1, 2.0, 0.0, 2.0, 2.0, status="unsettled", amplitude=2.001)) == (0, 2)


def test_a_spread_mean_within_the_amplitude_tolerance_passes_whatever_its_standard_error(tmp_path):
    """The mean of a non-periodic point passes Welch's test *or* the amplitude tolerance atol +
    rtol |ref|: with standard errors of 1e-9 a mean 5e-4 off fails Welch's test and passes at
    atol = 1e-3, fails at atol = 1e-4 (a cosmic-ray mutant that dropped the tolerance's share,
    within(..., -1.0), survived: no test had a mean off by less than atol but by many SE)."""
    from vibeam.io.results import read_results

    ref = _fake(tmp_path, "ref.h5", [_row(2.0, 0, 3.0, 1e-9, 2.9, 3.1)])
    new = read_results(_fake(tmp_path, "new.h5", [_row(2.0, 0, 3.0005, 1e-9, 2.9, 3.1)]))
    assert compare(new, ref, atol=1e-3, rtol=0.0, period=False)[0].failures == 0
    assert compare(new, ref, atol=1e-4, rtol=0.0, period=False)[0].failures == 1


def test_the_table_says_how_many_points_were_compared_by_their_spread(tmp_path, capsys):
    """The printed table's note for a run with non-periodic points: "N point(s) by spread, M
    failed", after any other note (a cosmic-ray mutant that broke this line, a TypeError at
    print time, survived every regress test: none printed such a run)."""
    from vibeam.analysis.regress import print_rows
    from vibeam.io.results import read_results

    ref = _fake(tmp_path, "ref.h5", [_row(1.0, 1, 2.0, 0.0, 2.0, 2.0), _row(2.0, 0, 3.0, 0.4, 2.2, 3.9)])
    new = read_results(_fake(tmp_path, "new.h5", [_row(1.0, 1, 2.0, 0.0, 2.0, 2.0),
                                                  _row(2.0, 0, 3.0 + 5 * 0.4 * np.sqrt(2 / 16), 0.4, 2.2, 3.9)]))
    rows = compare(new, ref, atol=0.0, rtol=1e-6, period=False)
    capsys.readouterr()
    print_rows(rows, 0.0, 1e-6)
    out = capsys.readouterr().out
    assert "(1 point(s) by spread, 1 failed)" in out and "REGRESSION" in out, out
    rows[0].note = "a note"
    print_rows(rows, 0.0, 1e-6)
    assert "(a note; 1 point(s) by spread, 1 failed)" in capsys.readouterr().out


# ----------------------------------------------------------------------------- one table reader (issue 19, item 12)
TABLES = {
    # name: (text, accepted?) -- the same verdict from `vibeam fit` and `vibeam regress`
    "plain": ("Omega,amplitude\n1.0,0.2\n1.2,0.3\n", True),
    "bom": ("\ufeffOmega,amplitude\n1.0,0.2\n", True),                      # Excel's UTF-8: regress refused it
    "comments-blank-lines": ("# rig, 2019\nOmega,amplitude\n\n1.0,0.2\n# end\n", True),
    "direction-and-sigma": ("Omega,amplitude,direction,sigma\n1.0,0.2,up,0.01\n1.0,0.25,Down,0.01\n", True),
    "zero-amplitude": ("Omega,amplitude\n1.0,0.0\n", True),                 # Q = 0: at rest on the stop
    "extra-column": ("Omega,amplitude,note\n1.0,0.2,x\n", False),            # regress ignored it
    "ragged-short": ("Omega,amplitude\n1.0,0.2\n1.2\n", False),              # regress ignored the row's end
    "ragged-long": ("Omega,amplitude\n1.0,0.2,7\n", False),
    "sideways": ("Omega,amplitude,direction\n1.0,0.2,sideways\n", False),   # regress ignored the column
    "negative-Omega": ("Omega,amplitude\n-1.0,0.2\n", False),                # regress accepted it
    "zero-Omega": ("Omega,amplitude\n0,0.2\n", False),
    "negative-amplitude": ("Omega,amplitude\n1.0,-0.2\n", False),           # fit accepted it
    "nan": ("Omega,amplitude\n1.0,nan\n", False),
    "both-pairs": ("Omega,amplitude,frequency_hz,amplitude_mm\n1,0.2,7.6,0.03\n", False),
    "repeated-column": ("Omega,amplitude,amplitude\n1,0.2,0.2\n", False),
    "sigma-zero": ("Omega,amplitude,sigma\n1,0.2,0\n", False),
    "header-only": ("Omega,amplitude\n", False),
    "empty": ("", False),
}


@pytest.mark.parametrize("name", list(TABLES))
def test_fit_and_regress_read_tables_by_one_set_of_rules(tmp_path, name):
    """``vibeam fit`` and ``vibeam regress`` accept the same tables with the same numbers and
    refuse the same ones with the same one-line message (vibeam.io.inputs.read_frc_table)."""
    from vibeam.case.schema import CaseError
    from vibeam.identify.fit import read_reference
    from vibeam.analysis.regress import read_csv_reference

    text, ok = TABLES[name]
    p = tmp_path / f"{name}.csv"
    p.write_bytes(text.encode("utf-8"))
    got = []
    for read in (read_reference, read_csv_reference):
        try:
            t = read(p)
        except CaseError as e:
            msg = str(e)
            assert "\n" not in msg and p.name in msg, msg
            got.append(("refused", msg.split(f"{p.name}: ", 1)[-1]))
        else:
            got.append(("read", t.x_name, list(t.x), list(t.y), list(t.direction)))
    assert got[0] == got[1], got
    assert (got[0][0] == "read") == ok, got


def _two_branches():
    """An FRC whose up and down branches differ (a hysteresis loop), as read_results gives it."""
    W = np.array([1.0, 1.5, 2.0])
    return {"runs": {"exact": {"Omega": np.concatenate([W, W[::-1]]),
                               "direction": np.array(["up"] * 3 + ["down"] * 3, dtype=object),
                               "amplitude": np.array([0.1, 0.2, 0.3, 0.9, 0.8, 0.7])}}}


def test_csv_points_are_compared_with_the_branch_of_their_direction(tmp_path):
    """A point measured sweeping down is compared with the down branch (amplitude 0.8 at 1.5),
    an up point with the up branch (0.2): both pass; swapped, both fail.  Before, every point
    was compared with the up branch."""
    p = tmp_path / "loop.csv"
    p.write_text("Omega,amplitude,direction\n1.5,0.2,up\n1.5,0.8,down\n")
    row, = compare(_two_branches(), p, rtol=1e-9)
    assert row.ok and row.points == 2, row
    p.write_text("Omega,amplitude,direction\n1.5,0.8,up\n1.5,0.2,down\n")
    row, = compare(_two_branches(), p, rtol=1e-9)
    assert row.failures == 2, row


def test_csv_reference_that_cannot_be_compared_is_bad_input(tmp_path):
    """Input errors, not regressions: physical columns against nondimensional results, a direction
    the results do not have, no point inside the sweep."""
    from vibeam.case.schema import InputError

    new = _two_branches()
    for text, needle in (("frequency_hz,amplitude_mm\n15.0,0.2\n", "'frequency_hz,amplitude_mm' are not in"),
                         ("Omega,amplitude\n5.0,0.2\n", "none of its 1 points lies inside")):
        p = tmp_path / "r.csv"
        p.write_text(text)
        with pytest.raises(InputError, match=needle):
            compare(new, p)
    up_only = {"runs": {"exact": {k: v[:3] for k, v in new["runs"]["exact"].items()}}}
    p.write_text("Omega,amplitude,direction\n1.5,0.8,down\n")
    with pytest.raises(InputError, match="no 'down' sweep"):
        compare(up_only, p)
