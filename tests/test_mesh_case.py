"""A user's mesh in a case (issue 59, item 4): ``cases/plate-tip-stop.toml``.

``[model.system] builder = "mesh"`` reads a part from a mesh file through meshio (here Gmsh's MSH 2.2,
``cases/plate-tip-stop/plate.msh``, written by meshio from ``make_plate.py`` beside it: a steel plate
strip 120 x 40 x 2 mm clamped at x = 0, a brass pad 10 x 40 x 6 mm under its tip tied as a rigid
body, a Newton stop under the pad), builds it with
:func:`vibeam.models.builders.continuum.build_continuum` and reduces it to the N-mode impact model
(fidelity ``"mesh"``).  Checked here: the shipped mesh is what its script writes and read_mesh reads
its physical groups back; the case's model is build_continuum's on the same file, bit for bit; the
first bending frequency between the Euler-Bernoulli frequency equation's with the beam's and the
plate's stiffness (solved here) and converged under refinement; the stop's effective mass on the
rigid pad converges while a node's falls (why Newton's law is refused on a node); the event
integrator's no-impact orbit against the modal closed form; an impacting period-1 orbit against the
direct solver (solve_ivp DOP853); ``vibeam modes``; bad tables refused in one line.  The mesh is
coarse (1125 DOFs, built in ~0.5 s) and every build goes into a temporary cache.
"""
from __future__ import annotations

import importlib.util
import math
from pathlib import Path

import meshio
import numpy as np
import pytest
import scipy.optimize

from vibeam.case.schema import parse_case
from vibeam.cli import main
from vibeam.engine.records import summarize
from vibeam.errors import CaseError
from vibeam.models import make_solver
from vibeam.models.builders.continuum import STEEL, Material, build_continuum, read_mesh
from vibeam.models.scene import outputs

ROOT = Path(__file__).resolve().parents[1]
CASES = ROOT / "cases"
CASE = CASES / "plate-tip-stop.toml"
MESH = CASES / "plate-tip-stop" / "plate.msh"
TWO_PI = 2.0 * math.pi
BRASS = Material(100e9, 0.34, 8500.0)
SENSOR = ((0.115, 0.0, 0.0), (0.0, 0.0, -1.0))
STOP = ("body", (0.115, 0.0, -0.007), (0.0, 0.0, -1.0))


def _script():
    """cases/plate-tip-stop/make_plate.py, the mesh's generator (cases/ is not a package)."""
    spec = importlib.util.spec_from_file_location("make_plate", MESH.with_name("make_plate.py"))
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


@pytest.fixture(scope="module", autouse=True)
def _cache(tmp_path_factory):
    """Every build of this module into one temporary model cache (a second build loads it)."""
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("VIBEAM_CACHE_DIR", str(tmp_path_factory.mktemp("cache")))
        yield


def _case(*edits):
    text = CASE.read_text()
    for old, new in edits:
        assert old in text, old
        text = text.replace(old, new)
    return parse_case(text, "plate-tip-stop.toml", base=CASES)


def _build(path=MESH, n_modes=4, contacts=(STOP,), **kw):
    return build_continuum(path, {"plate": STEEL, "pad": BRASS, "*": STEEL}, n_modes=n_modes, damping_ratios=0.02,
                           clamp="clamp", rigid="pad", sensor=SENSOR, contacts=list(contacts), cache=False,
                           length_m=0.12, **kw)


def test_the_shipped_mesh_is_its_scripts_gmsh_file_with_its_regions(tmp_path):
    """plate.msh is byte for byte what make_plate.py writes (the script is its source); Gmsh's MSH 2.2
    with the physical groups plate, pad (volumes) and clamp (the face x = 0), which read_mesh reads
    back as cell sets and a point set."""
    out = _script().write(tmp_path / "plate.msh")
    assert out.read_bytes() == MESH.read_bytes()
    assert MESH.read_text().startswith("$MeshFormat\n2.2 0 8\n")
    mesh = read_mesh(MESH)
    assert mesh.cell_type == "hexahedron" and len(mesh.cells) == 52 and len(mesh.points) == 140
    assert {k: len(v) for k, v in mesh.cell_sets.items()} == {"plate": 48, "pad": 4}
    assert set(mesh.point_sets) == {"clamp"} and len(mesh.point_sets["clamp"]) == 10
    assert np.all(mesh.points[mesh.point_sets["clamp"], 0] == 0.0)
    pad = mesh.points[mesh.nodes_of("pad")]
    assert np.allclose(pad.min(axis=0), [0.110, -0.020, -0.007]) and np.allclose(pad.max(axis=0), [0.120, 0.020, -0.001])


def test_the_case_builds_build_continuums_model_bit_for_bit():
    case = _case()
    spec = case.model_spec()
    sc = spec.scene()
    s, out = sc.system, outputs(sc)
    assert type(spec).__name__ == "MeshModelSpec" and sc.builder == "mesh" and s.omega.shape[0] == 4
    mm, info = _build(base_amplitude_m=0.005e-3)
    # the scene holds omega_i / omega_ref (omega_ref = 2 pi f_ref): compared bit for bit against that
    assert np.array_equal(s.omega, TWO_PI * mm.frequencies_hz / (TWO_PI * s.reference_hz))
    assert np.array_equal(s.contacts[0], mm.system.contacts[0]) and np.array_equal(s.sensor, mm.system.sensor)
    assert np.array_equal(s.participation, mm.system.participation)
    assert sc.stops[0].relation.offset == 0.05e-3 and sc.stops[0].law.R == 0.7 and out.length_m == 0.12
    assert s.base_amplitude == 0.005e-3
    assert math.isclose(out.natural_frequency_hz, mm.frequencies_hz[0], rel_tol=1e-15)
    # the run override [run.model.system] n_modes = 2, merged key by key
    two = case.model_spec(dict(case.run[0].model)).scene()
    assert two.system.omega.shape[0] == 2 and np.array_equal(two.system.omega, s.omega[:2])
    attrs = spec.result_attrs()
    assert np.array_equal(attrs["frequencies_hz"], mm.frequencies_hz) and attrs["mesh"].startswith("plate.msh, 52 cells")
    # the brass pad's density is the case's: steel would make it 11 % lighter and f1 higher
    steel_pad, _ = build_continuum(MESH, STEEL, n_modes=1, damping_ratios=0.02, rigid="pad", sensor=SENSOR,
                                   cache=False)
    assert steel_pad.frequencies_hz[0] > mm.frequencies_hz[0] * 1.005


def _euler_bernoulli_f1(EI, rhoA, l, m, S, J):
    """First frequency (Hz) of a cantilever of length ``l`` carrying at its end a rigid body of mass
    ``m``, static moment ``S`` and moment of inertia ``J`` about the beam's end (Euler-Bernoulli):
    ``W = A (cosh bx - cos bx) + B (sinh bx - sin bx)`` (clamped at 0), the body's equations
    ``EI W''' = -w^2 (m W + S W')`` and ``EI W'' = w^2 (J W' + S W)`` at ``x = l``; the determinant's
    first root."""
    def det(w):
        b = (rhoA * w * w / EI) ** 0.25
        ch, sh, c, s = np.cosh(b * l), np.sinh(b * l), np.cos(b * l), np.sin(b * l)
        W, W1 = np.array([ch - c, sh - s]), b * np.array([sh + s, ch - c])
        W2, W3 = b ** 2 * np.array([ch + c, sh + s]), b ** 3 * np.array([sh - s, ch + c])
        rows = np.array([EI * W3 + w * w * (m * W + S * W1), EI * W2 - w * w * (J * W1 + S * W)])
        return np.linalg.det(rows) / (EI * b ** 3) ** 2
    ws = np.linspace(1.0, 5000.0, 5000)
    d = np.array([det(w) for w in ws])
    k = int(np.flatnonzero(np.sign(d[:-1]) != np.sign(d[1:]))[0])
    return scipy.optimize.brentq(det, ws[k], ws[k + 1], xtol=1e-12) / TWO_PI


def test_first_bending_frequency_between_the_beams_and_the_plates_and_converged(tmp_path):
    """The plate strip's f1 against the Euler-Bernoulli frequency equation (solved here) of the plate
    free over l = 110 mm carrying the pad and the plate under it (110 ... 120 mm) as a rigid body
    (mass, static moment and moment of inertia about the end of the free length, the pad's offset
    below the mid-plane included).  The tolerance is a bracket, not a fitted number: a strip 40 mm
    wide (b / L = 1/3) bends with the beam's stiffness E I where its anticlastic curvature is free
    and with the plate's E I / (1 - nu^2) (+4.8 %) where the clamp holds it (over about a width
    from the clamp), so the 3D solid lies between the two (shear and the bond's compliance under
    the pad lower it by less: (t / L)^2 ~ 3e-4); the discretisation error is an upper bound by
    Rayleigh-Ritz and shrinks: the coarse mesh of the case (10 x 10 x 2 mm elements) is within 1 %
    of a mesh twice as fine in every direction (measured +0.77 %; 4 x finer along x: 82.05 Hz).
    Measured: 82.79 Hz coarse, 82.16 Hz twice as fine; the bracket 80.56 ... 84.45 Hz."""
    E, nu, rho = 200e9, 0.3, 7850.0
    b, t, L, lp, hp, rho_pad = 0.040, 0.002, 0.120, 0.010, 0.006, 8500.0
    l = L - lp
    m_plate, m_pad = rho * b * t * lp, rho_pad * b * hp * lp
    m = m_plate + m_pad
    S = m * 0.5 * lp                                                 # both centred 5 mm beyond x = l
    zc = 0.5 * (t + hp)                                              # the pad's centre below the mid-plane
    J = m_plate * (lp ** 2 / 3 + t ** 2 / 12) + m_pad * (lp ** 2 / 3 + hp ** 2 / 12 + zc ** 2)
    I = b * t ** 3 / 12
    f_beam = _euler_bernoulli_f1(E * I, rho * b * t, l, m, S, J)
    f_plate = _euler_bernoulli_f1(E * I / (1 - nu ** 2), rho * b * t, l, m, S, J)
    # the equation's limits: no body -> the cantilever's 1.8751^2 sqrt(EI / rhoA) / (2 pi l^2)
    bare = _euler_bernoulli_f1(E * I, rho * b * t, l, 0.0, 0.0, 0.0)
    assert math.isclose(bare, 1.8751040687 ** 2 * math.sqrt(E * I / (rho * b * t)) / (TWO_PI * l * l), rel_tol=1e-9)
    coarse, _ = _build(n_modes=1)
    fine_path = _script().write(tmp_path / "fine.msh", nx=24, ny=8, nz=2, nz_pad=2)
    fine, _ = _build(fine_path, n_modes=1)
    f_c, f_f = float(coarse.frequencies_hz[0]), float(fine.frequencies_hz[0])
    print(f"f1: coarse {f_c:.3f} Hz, twice as fine {f_f:.3f} Hz; Euler-Bernoulli {f_beam:.3f} (E I) ... "
          f"{f_plate:.3f} Hz (E I / (1 - nu^2))")
    assert f_beam < f_f < f_c < f_plate
    assert f_c - f_f < 0.01 * f_f


def test_the_pads_effective_mass_converges_and_a_nodes_falls(tmp_path):
    """Why a Newton stop acts on the rigid pad and not on a point of the solid: the effective mass
    ``1 / (w M^-1 w^T)`` of the pad's contact point is about the pad and the plate it carries, less
    what its rotation gives way, and moves < 3 % from the case's mesh to one twice as fine (measured
    0.02123 and 0.02081 kg, 2.0 %; the pad and the plate under it weigh 0.0267 kg), while that of a
    point on the plate's top face at x = 60 mm falls with the element size (quadratic elements: the
    consistent mass a vertex carries ~ h^3 in 3D, h^2 here with one layer through the plate going to
    two; measured 2.5e-5 -> 3.5e-6 kg, a factor 7.2: > 4 asserted)."""
    node = ("node", (0.060, 0.0, 0.001), (0.0, 0.0, 1.0))
    fine_path = _script().write(tmp_path / "fine.msh", nx=24, ny=8, nz=2, nz_pad=2)
    _, coarse = _build(n_modes=1, contacts=(STOP, node))
    _, fine = _build(fine_path, n_modes=1, contacts=(STOP, node))
    (pc, nc), (pf, nf) = coarse.contact_effective_mass_kg, fine.contact_effective_mass_kg
    print(f"effective mass: pad {pc:.5f} -> {pf:.5f} kg, node {nc:.3e} -> {nf:.3e} kg")
    assert 0.015 < pf < pc < 0.0267 and pc - pf < 0.03 * pf
    assert nf < nc / 4 and nc < 0.05 * pc


def test_event_orbit_without_impacts_equals_the_modal_closed_form():
    """A gap of 5 mm under the pad is never reached at 60 Hz (the tip moves ~0.007 mm): the event
    integrator's settled state at a period's end is the steady state of the base-excited modes,
    ``eta_i = Im H_i``, ``eta_i' = W Re H_i``, ``H_i = Gamma_i W^2 Y / (omega_i^2 - W^2 + 2 i zeta W omega_i)``
    (the base at ``Y sin(W t)``, the case's modal damping ratio zeta = 0.02 applied here to the
    build's frequencies), to 1e-9 of the largest ``|H_i|``: 400 transient periods at 60 Hz leave
    exp(-0.02 * 2 pi * 82.8 * 400 / 60) ~ 1e-30 of the start from rest; the flow between samples is
    the closed form of the modal equations, exact to round-off (measured ~1e-13)."""
    case = _case(("contact_gap_mm = 0.05", "contact_gap_mm = 5.0"))
    spec = case.model_spec()
    sc = spec.scene()
    out = outputs(sc)
    mm = spec.matrix_model()
    f = 60.0
    tr = make_solver(sc, "event").point(f / out.natural_frequency_hz, None, 400, 4, 64)
    assert tr.status == "ok" and tr.n_impacts == 0
    W, om, Y = TWO_PI * f, TWO_PI * mm.frequencies_hz, 0.005e-3
    H = mm.system.participation * W ** 2 * Y / (om ** 2 - W ** 2 + 2j * 0.02 * W * om)
    N, w_ref = out.n_modes, TWO_PI * out.natural_frequency_hz
    eta, etad = tr.final_state[:N], tr.final_state[N:2 * N] * w_ref     # d/dt~ = w_ref d/dt
    scale = np.max(np.abs(H))
    assert np.max(np.abs(eta - H.imag)) < 1e-9 * scale
    assert np.max(np.abs(etad - W * H.real)) < 1e-9 * scale * W
    # the sensor's swing: 2 |s . H| (sampled at 64 a period: within (pi / 64)^2 / 2 below it, to
    # round-off when a sample falls on the extremes)
    amp = abs(mm.system.sensor @ H)
    assert 2e-6 < amp < 2e-5
    assert -1e-9 * 2 * amp <= 2 * amp - (tr.q_max - tr.q_min) * out.length_m < 1.3e-3 * 2 * amp


def test_impacting_period_one_orbit_equals_the_direct_solver():
    """At 90 Hz the 4-mode plate settles on a period-1 orbit with one impact a period on the stop
    under its pad (the FRC's branch, 82-96 Hz going up); the direct solver (solve_ivp DOP853, rtol
    1e-10, the impact by event location) from its final state stays on it: amplitudes to 1e-7
    (make_references' TOL_DIRECT)."""
    sc = _case().model_spec().scene()
    out = outputs(sc)
    W = 90.0 / out.natural_frequency_hz
    ev = make_solver(sc, "event").point(W, None, 300, 2, 64)
    a_ev = summarize(ev, out.Delta)
    assert a_ev["period"] == 1 and ev.n_impacts >= 2
    di = make_solver(sc, "direct", solver="DOP853", rtol=1e-10, atol=1e-14).point(W, ev.final_state, 20, 4, 64)
    a_di = summarize(di, out.Delta)
    assert a_di["period"] == 1 and di.n_impacts >= 4
    assert abs(a_di["amplitude"] - a_ev["amplitude"]) < 1e-7 * abs(a_ev["amplitude"])


def test_vibeam_modes_prints_the_modes_and_writes_the_shapes(tmp_path, capsys):
    assert main(["modes", str(CASE), "-n", "4", "--out", str(tmp_path / "m")]) == 0
    out = capsys.readouterr().out
    mm, info = _build()
    for f in mm.frequencies_hz:
        assert f"{f:.4f}" in out
    assert "3D continuum from plate.msh" in out and "0.09576 kg" in out    # 7850 x 9.6e-6 + 8500 x 2.4e-6 m^3
    rows = [ln.split() for ln in out.splitlines() if ln.strip()[:1].isdigit() and len(ln.split()) == 7]
    share = [float(r[5]) for r in rows]
    # mode 1 bends (66 % of the mass), mode 2 twists (none), the sum below 100 %
    assert len(rows) == 4 and 60.0 < share[0] < 70.0 and share[1] < 1e-6 and sum(share) < 100.0
    vtu = meshio.read(tmp_path / "m" / "modes.vtu")
    assert vtu.points.shape == (140, 3) and {"mode_1", "mode_4"} <= set(vtu.point_data)
    np.testing.assert_array_equal(vtu.point_data["mode_1"], info.nodal_shapes[:, :, 0])
    assert (tmp_path / "m" / "modes.png").stat().st_size > 10_000


@pytest.mark.parametrize("edits,msg", [
    ([('file = "plate-tip-stop/plate.msh"', 'file = "plate-tip-stop/missing.msh"')],
     f"'model.system.file' = '{CASES / 'plate-tip-stop' / 'missing.msh'}': no such file"),
    ([('file = "plate-tip-stop/plate.msh"', 'file = "plate-tip-stop/make_plate.py"')], "cannot be read as a volume mesh"),
    ([('clamp = "clamp"', 'clamp = "root"')],
     "'model.system.clamp' = 'root': plate.msh has no region of that name; allowed: one of its regions (clamp, pad, "
     "plate)"),
    ([('clamp = "clamp"', 'clamp = {clamp = "xyw"}')], "non-empty subset"),
    ([('rigid = "pad"', 'rigid = "tip"')], "'model.system.rigid' = 'tip'"),
    ([("[model.system.materials.pad]", "[model.system.materials.pads]")], "'model.system.materials' = 'pads'"),
    ([("density_kg_m3 = 8500.0", "density = 8500.0")], "density"),
    ([("sensor_mm = [115.0, 0.0, 0.0]", "sensor_mm = [215.0, 0.0, 0.0]")], "'model.system.sensor_mm'"),
    ([("normal = [0.0, 0.0, -1.0]", "normal = [0.0, 0.0, 0.0]")], "normal"),
    ([('rigid = "pad"\n', "")], "Newton's law on a point of the solid"),      # the stop then acts on a node
    ([('rigid = "pad"\n', ""), ("point_mm = [115.0", 'at = "body"\npoint_mm = [115.0')], "needs a rigid region"),
    ([("point_mm = [115.0", 'at = "node"\npoint_mm = [115.0')], "Newton's law on a point of the solid"),
    ([('rigid = "pad"', 'rigid = "clamp"')], "touches the clamp"),
    ([("damping_ratios = 0.02", "damping_ratios = 0.02\nrayleigh = [0.0, 1e-5]")], "exactly one"),
])
def test_bad_mesh_tables_are_refused_in_one_line(edits, msg):
    with pytest.raises(CaseError) as e:
        _case(*edits).model_spec().scene()
    assert msg in str(e.value) and "\n" not in str(e.value), str(e.value)


def test_a_compliant_stop_on_a_node_is_accepted_and_a_missing_file_refused_by_the_cli(tmp_path, capsys):
    """A compliant stop on a point of the solid is well posed (finite contact force): accepted, its
    contact row the displacement interpolated there; ``vibeam run`` on a case whose mesh is missing
    exits 2 with one line naming the key and writes no file (the output folder is made before the
    model is built, as for every structure: left empty)."""
    spec = _case(("point_mm = [115.0, 0.0, -7.0]", 'at = "node"\nlaw = "linear"\nstiffness_n_m = 1e6\n'
                  'point_mm = [115.0, 0.0, -7.0]')).model_spec()
    sc = spec.scene()
    mm, _ = _build(contacts=[("node", (0.115, 0.0, -0.007), (0.0, 0.0, -1.0))], base_amplitude_m=0.005e-3)
    law = sc.stops[0].law
    contact_law = "restitution" if law.kind == "impulsive" else law.name      # the old model's contact_law
    assert contact_law == "linear" and np.array_equal(sc.system.contacts[0], mm.system.contacts[0])
    path = tmp_path / "plate.toml"
    path.write_text(CASE.read_text())                   # plate-tip-stop/plate.msh is not beside it
    assert main(["run", str(path), "--quick", "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and "'model.system.file' = " in err and "no such file" in err, err
    assert not (tmp_path / "out").exists() or not any((tmp_path / "out").iterdir())


def test_the_contact_modes_are_the_kept_modes_held_at_the_contact_row():
    """``vibeam modes``' contact modes of a continuum or a mesh (:func:`vibeam.case.structure._held_modes`):
    the kept modes held at the contact row ``w`` (``w . eta = 0``).  Two modes: the one held
    frequency in closed form, ``omega^2 = (w_2^2 omega_1^2 + w_1^2 omega_2^2) / |w|^2`` (the null space
    of ``w`` is ``(-w_2, w_1)``), here below 1 rad/s as well as above; a row moving one mode only
    leaves the other's frequency; three modes: the two held ``omega^2`` are the roots of the secular
    equation ``sum_i w_i^2 / (omega_i^2 - lam) = 0`` (Rayleigh-Ritz on a rank-one constraint; Golub
    1973), interlacing the free ones.  Tolerance 1e-12 relative: one 2 x 2 or 3 x 3 eigenproblem."""
    from vibeam.case.structure import _held_modes

    for om, w in (([0.3, 0.8], [1.0, 2.0]), ([30.0, 80.0], [-0.5, 1.5])):
        (om1, om2), (w1, w2) = om, w
        want = math.sqrt((w2 * w2 * om1 * om1 + w1 * w1 * om2 * om2) / (w1 * w1 + w2 * w2)) / (2 * math.pi)
        (got,) = _held_modes(np.array(om), np.array(w))
        assert got == pytest.approx(want, rel=1e-12), (om, w, got, want)
    assert _held_modes(np.array([2.0, 5.0]), np.array([1.0, 0.0]))[0] == pytest.approx(5.0 / (2 * math.pi), rel=1e-12)
    om, w = np.array([1.0, 2.0, 3.0]), np.array([0.5, -1.0, 0.8])
    lam = (2 * math.pi * _held_modes(om, w)) ** 2
    assert lam.shape == (2,) and om[0] ** 2 < lam[0] < om[1] ** 2 < lam[1] < om[2] ** 2
    for x in lam:
        assert abs(np.sum(w * w / (om * om - x))) <= 1e-12 * np.sum(w * w / np.abs(om * om - x))


def test_a_rayleigh_damping_of_the_case_gives_each_mode_its_closed_form_ratio():
    """``[model.system] rayleigh = [a, b]`` (``C = a M + b K``): mode ``i`` gets ``c_i = a + b omega_i^2``
    (1/s), the damping ratio ``zeta_i = (a / omega_i + b omega_i) / 2`` (classical normal modes:
    Caughey & O'Kelly 1965) in the results' attributes, and the scene's damping per unit time
    ``c_i / omega_ref``; ``a`` and ``b`` chosen so that each term is a third or more of the first mode's.
    Tolerance 1e-7 relative: the modes' mass normalisation by the eigen-solver (measured 4e-9 on the
    first mode, 3e-10 on the others); ``a`` and ``b`` swapped changes ``zeta_1`` a hundredfold."""
    a, b = 3.0, 2e-5
    spec = _case(("damping_ratios = 0.02", f"rayleigh = [{a!r}, {b!r}]")).model_spec()
    om = 2 * math.pi * np.asarray(spec.result_attrs()["frequencies_hz"])
    zeta = np.asarray(spec.result_attrs()["damping_ratios"])
    np.testing.assert_allclose(zeta, 0.5 * (a / om + b * om), rtol=1e-7)
    assert a / om[0] > 0.3 * b * om[0] and b * om[0] > 0.3 * a / om[0]
    s = spec.scene().system
    np.testing.assert_allclose(s.damping * (2 * math.pi * s.reference_hz), a + b * om * om, rtol=1e-7)
