"""`vibeam regress` against HDF5 and CSV references."""
import h5py
import numpy as np

from vibeam.cli import main
from vibeam.models import linear_amplitude

CASE = """
name = "reg"
[model]
fidelity = "sdof"
beta = 0.05
B = 0.01
R = 0.8
Delta = 5.0
[sweep]
Omega = [0.5, 1.5, 201]
transient_periods = 300
record_periods = 4
[regress]
amplitude_rtol = 1e-3
[[run]]
name = "exact"
method = "event"
"""


def test_regress_hdf5_self_passes_and_perturbed_fails(tmp_path, capsys):
    case = tmp_path / "reg.toml"
    case.write_text(CASE)
    out = tmp_path / "a"
    assert main(["run", str(case), "--out", str(out), "--jobs", "1", "--quiet", "--no-plots"]) == 0
    ref = out / "results.h5"
    assert main(["regress", str(case), "--reference", str(ref), "--results", str(ref)]) == 0
    bad = tmp_path / "bad.h5"
    bad.write_bytes(ref.read_bytes())
    with h5py.File(bad, "r+") as f:
        a = f["runs/exact/amplitude"]      # (direction, Omega)
        v = a[()]
        v[0, 100] *= 1.01  # 1 % off at one point, above rtol 1e-3
        a[...] = v
    capsys.readouterr()
    assert main(["regress", str(case), "--reference", str(bad), "--results", str(ref)]) == 1
    assert "REGRESSION" in capsys.readouterr().out


def test_regress_against_an_analytic_csv(tmp_path):
    """Far from the stop the FRC is Delta + C(Omega) (closed form), sampled off the grid."""
    case = tmp_path / "reg.toml"
    case.write_text(CASE)
    W = np.linspace(0.52, 1.48, 37)
    csv = tmp_path / "ref.csv"
    csv.write_text("Omega,amplitude\n" + "\n".join(f"{w},{5.0 + linear_amplitude(0.05, 0.01, w)}"
                                                    for w in W))
    out = tmp_path / "b"
    assert main(["regress", str(case), "--reference", str(csv), "--out", str(out), "--jobs", "1"]) == 0
    # and a CSV that is 1 % off fails
    csv.write_text("Omega,amplitude\n" + "\n".join(f"{w},{1.01 * (5.0 + linear_amplitude(0.05, 0.01, w))}"
                                                    for w in W))
    assert main(["regress", str(case), "--reference", str(csv),
                 "--results", str(out / "results.h5")]) == 1
