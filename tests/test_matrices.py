"""A structure given by its matrices (issue 58, step 2): the builder
(:func:`vibeam.models.builders.matrices.build_matrices`) and the file reader
(:func:`vibeam.io.matrices.read_matrices`).

* The 3-DOF spring-mass chain against closed forms (frequencies, mode shapes, static deflection)
  and an independent eigen-solver (:func:`scipy.linalg.eig` of ``M^-1 K``, a nonsymmetric
  solver); Caughey's condition: a dashpot on one mass is refused, classical damping accepted.
* The sparse path (ARPACK shift-invert) on a 2500-mass chain against the closed form.
* The reader's refusals: one line naming the file, the key and what is allowed.
* Done-when 2 of issue 58: the FE cantilever of ``cases/rig-fe-neutral.toml`` written to an
  ``.npz`` archive and to MatrixMarket files, read back and reduced to 2 and 4 modes, is the
  built-in rung: the same modal system and the same FRC by the event integrator, to 1e-10.
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
import scipy.io
import scipy.linalg
import scipy.sparse

from vibeam.errors import InputError
from vibeam.io.matrices import read_matrices
from vibeam.models.builders.matrices import DENSE_MAX, build_matrices, lowest_modes_of, matrix_problem

ROOT = Path(__file__).resolve().parents[1]


def chain(masses, springs):
    """Fixed-free chain: spring i joins mass i to mass i - 1 (spring 0 to the base)."""
    m, k = np.asarray(masses, float), np.asarray(springs, float)
    N = m.size
    K = np.zeros((N, N))
    for i in range(N):
        K[i, i] += k[i]
        if i > 0:
            K[i - 1, i - 1] += k[i]
            K[i, i - 1] = K[i - 1, i] = -k[i]
    return np.diag(m), K


def uniform_chain_closed_form(N, m, k):
    """Fixed-free chain of N equal masses m and springs k: ``omega_j = 2 sqrt(k/m) sin(theta_j/2)``,
    ``theta_j = (2j - 1) pi / (2N + 1)``, shapes ``sin(n theta_j)``, n = 1..N (Meirovitch Ch. 7;
    the free end's condition ``x_{N+1} = x_N`` gives ``cos((2N + 1) theta / 2) = 0``)."""
    j = np.arange(1, N + 1)
    th = (2 * j - 1) * math.pi / (2 * N + 1)
    om = 2.0 * math.sqrt(k / m) * np.sin(th / 2)
    S = np.sin(np.outer(np.arange(1, N + 1), th))
    S = S / np.sqrt(m * np.sum(S ** 2, axis=0))          # mass-normalised
    return om, S


def same_up_to_sign(A, B):
    """Columns of B signed like A's (largest component's sign)."""
    k = np.argmax(np.abs(A), axis=0)
    return B * np.sign(A[k, np.arange(A.shape[1])] * B[k, np.arange(A.shape[1])])


# ============================================================================ the 3-DOF chain
def test_three_mass_chain_against_the_closed_form():
    """Equal masses 2 kg, springs 8000 N/m: frequencies to 1e-14 relative (LAPACK on a 3 x 3
    problem: round-off), mass-normalised shapes to 1e-13; the effective masses sum to the total
    mass (all modes; Meirovitch Ch. 7); the static deflection under the base load K^-1 M r over the
    sensor's (mass 3) is (3, 5, 6) / 6 (spring n carries the (N - n + 1) masses beyond it)."""
    m, k = 2.0, 8000.0
    M, K = chain([m] * 3, [k] * 3)
    mm = build_matrices(M, K, damping_ratios=0.02, dofs=("m1", "m2", "m3"), sensor="m3", contacts=("m3", "m1"),
                        base_amplitude_m=1e-3)
    om, S = uniform_chain_closed_form(3, m, k)
    np.testing.assert_allclose(mm.frequencies_hz * 2 * math.pi, om, rtol=1e-14)
    np.testing.assert_allclose(mm.shapes, same_up_to_sign(mm.shapes, S), rtol=0, atol=1e-13 * np.abs(S).max())
    np.testing.assert_allclose(mm.shapes.T @ M @ mm.shapes, np.eye(3), atol=1e-14)
    s = mm.system
    assert np.sum(s.participation ** 2) == pytest.approx(3 * m, rel=1e-14)
    np.testing.assert_allclose(s.omega, om / om[0], rtol=1e-14)               # f_ref = f_1
    assert s.time_unit_s == pytest.approx(1.0 / om[0], rel=1e-15)
    np.testing.assert_allclose(s.damping, 2 * 0.02 * om / om[0], rtol=1e-14)
    np.testing.assert_array_equal(s.sensor, mm.shapes[2])
    np.testing.assert_array_equal(s.contacts, mm.shapes[[2, 0]])
    assert mm.contact_names == ("m3", "m1") and mm.sensor_name == "m3"
    np.testing.assert_array_equal(mm.damping_ratios, [0.02] * 3)
    assert build_matrices(M, K, damping_ratios=0.02, n_modes="all").n_modes == 3
    np.testing.assert_allclose(mm.static, np.array([3.0, 5.0, 6.0]) / 6.0, rtol=1e-14)
    np.testing.assert_allclose(mm.contact_static, [1.0, 0.5], rtol=1e-14)
    assert mm.contact_gap(1, 2e-3) == pytest.approx(1e-3, rel=1e-14)
    np.testing.assert_array_equal(mm.modal_row("m2"), mm.shapes[1])
    assert s.base_amplitude == 1e-3 and s.length_unit_m == s.coordinate_scale == 1.0 and s.mass_unit_kg == 1.0


def test_unequal_chain_against_an_independent_eigen_solver():
    """Masses 1, 3, 0.5 kg, springs 5e3, 2e3, 4e3 N/m, Rayleigh C: the builder (symmetric LAPACK,
    generalized) against scipy.linalg.eig of M^-1 K (a nonsymmetric solver, shares nothing):
    frequencies to 1e-12 relative, M-normalised shapes to 1e-10 (eigenvectors of a nonsymmetric
    solver: ~cond * eps); c_i = a + b omega_i^2 to 1e-12; an r with a rotation-like zero entry."""
    M, K = chain([1.0, 3.0, 0.5], [5e3, 2e3, 4e3])
    a, b = 0.4, 3e-4
    r = np.array([1.0, 1.0, 0.0])
    mm = build_matrices(M, K, C=a * M + b * K, r=r, sensor=1, f_ref_hz=10.0, length_m=0.1)
    lam, X = scipy.linalg.eig(np.linalg.solve(M, K))
    order = np.argsort(lam.real)
    lam, X = lam.real[order], X.real[:, order]
    X = X / np.sqrt(np.einsum("ij,ij->j", X, M @ X))
    np.testing.assert_allclose((2 * math.pi * mm.frequencies_hz) ** 2, lam, rtol=1e-12)
    np.testing.assert_allclose(mm.shapes, same_up_to_sign(mm.shapes, X), atol=1e-10 * np.abs(X).max())
    s = mm.system
    om_ref = 2 * math.pi * 10.0
    np.testing.assert_allclose(s.damping * om_ref, a + b * lam, rtol=1e-12)
    np.testing.assert_allclose(s.participation, mm.shapes.T @ M @ r, rtol=1e-14)
    assert s.length_unit_m == s.coordinate_scale == 0.1 and mm.caughey_ratio < 1e-12


def test_a_dashpot_on_one_mass_is_refused_and_classical_damping_accepted():
    """Caughey & O'Kelly (1965): a dashpot on mass 1 alone couples the modes (C M^-1 K != K M^-1 C):
    refused in one line naming the mode and its coupling ratio, also when one mode is kept (the
    check covers the modes dropped).  A classical C that is not Rayleigh's (C = M Phi diag(2 zeta
    omega) Phi^T M) is accepted and gives back its ratios to 1e-12 (3 x 3: round-off)."""
    M, K = chain([1.0, 3.0, 0.5], [5e3, 2e3, 4e3])
    C = np.diag([5.0, 0.0, 0.0])
    for n in (None, 1):
        with pytest.raises(ValueError, match=r"C is not diagonalised by the undamped modes: it couples mode \d "
                                             r"\([\d.]+ Hz\) to the others by [\d.e+-]+ of its own damping") as e:
            build_matrices(M, K, C=C, n_modes=n)
        assert "\n" not in str(e.value) and "Caughey" in str(e.value)
    lam, V = scipy.linalg.eigh(K, M)
    zeta = np.array([0.01, 0.05, 0.2])
    Cc = M @ V @ np.diag(2 * zeta * np.sqrt(lam)) @ V.T @ M
    mm = build_matrices(M, K, C=Cc)
    np.testing.assert_allclose(mm.damping_ratios, zeta, rtol=1e-12)
    assert mm.caughey_ratio < 1e-12
    # the same system from the ratios themselves
    mz = build_matrices(M, K, damping_ratios=zeta)
    np.testing.assert_allclose(mz.system.damping, mm.system.damping, rtol=1e-12)
    np.testing.assert_array_equal(mz.system.omega, mm.system.omega)
    with pytest.raises(ValueError, match="negative damping"):
        build_matrices(M, K, C=-Cc)


def test_repeated_frequencies():
    """Two equal oscillators (K = 4 M): any basis of the double eigenspace is a set of modes.
    A C with its dashpots along rotated directions is diagonalised by the rotated basis (accepted,
    each mode carries one dashpot); damping ratios that differ within the repeated frequency, or
    n_modes that splits it, are refused (which mode would get which ratio is arbitrary)."""
    M = np.diag([1.0, 1.0, 2.0])
    K = np.diag([4.0, 4.0, 50.0])
    c_, s_ = math.cos(0.5), math.sin(0.5)
    Q = np.array([[c_, -s_, 0.0], [s_, c_, 0.0], [0.0, 0.0, 1.0]])
    C = Q @ np.diag([0.1, 0.3, 1.0]) @ Q.T
    mm = build_matrices(M, K, C=C, f_ref_hz=1.0 / (2 * math.pi))
    np.testing.assert_allclose(np.sort(mm.system.damping[:2]), [0.1, 0.3], rtol=1e-13)
    np.testing.assert_allclose(mm.system.omega, [2.0, 2.0, 5.0], rtol=1e-15)
    build_matrices(M, K, damping_ratios=[0.1, 0.1, 0.2])
    with pytest.raises(ValueError, match="damping_ratios differ within the repeated frequency"):
        build_matrices(M, K, damping_ratios=[0.1, 0.2, 0.2])
    with pytest.raises(ValueError, match="n_modes = 1 splits a repeated frequency"):
        build_matrices(M, K, damping_ratios=0.1, n_modes=1)
    assert build_matrices(M, K, damping_ratios=0.1, n_modes=2).n_modes == 2


def test_builder_refuses_bad_input_in_one_line():
    M, K = chain([1.0, 3.0, 0.5], [5e3, 2e3, 4e3])
    bad = [
        (dict(M=M, K=K), "exactly one of them"),
        (dict(M=M, K=K, C=0 * M, damping_ratios=0.1), "exactly one of them"),
        (dict(M=M[:2, :2], K=K, damping_ratios=0.1), "K is 3 x 3, not M's size"),
        (dict(M=M, K=K[:, :2], damping_ratios=0.1), "K is not a square matrix"),
        (dict(M=-M, K=K, damping_ratios=0.1), "M is not positive definite"),
        (dict(M=M, K=K - 2e3 * np.eye(3), damping_ratios=0.1), "K is not positive definite"),
        (dict(M=M, K=K + np.triu(K, 1), damping_ratios=0.1), "K is not symmetric"),
        (dict(M=M * np.nan, K=K, damping_ratios=0.1), "not finite"),
        (dict(M=M, K=K, damping_ratios=[0.1, 0.2]), "one per kept mode"),
        (dict(M=M, K=K, damping_ratios=-0.1), "allowed: one ratio >= 0"),
        (dict(M=M, K=K, damping_ratios=0.1, sensor="tip"), "names no DOF"),
        (dict(M=M, K=K, damping_ratios=0.1, contacts=(5,)), "is no DOF index"),
        (dict(M=M, K=K, damping_ratios=0.1, n_modes=4), r"n_modes = 4; allowed: an integer in \[1, 3\]"),
        (dict(M=M, K=K, damping_ratios=0.1, n_modes="two"), r"n_modes = 'two'; allowed"),
        (dict(M=M, K=K, damping_ratios=0.1, n_modes=1.5), r"n_modes = 1.5; allowed"),
        (dict(M=M, K=K, damping_ratios=0.1, dofs=("a", "a", "b")), "appears twice"),
        (dict(M=M, K=K, damping_ratios=0.1, r=[1.0, 1.0]), "r has shape"),
        (dict(M=M, K=K, damping_ratios=0.1, r=[1.0, 1.0, 1.0], Mr=[1.0, 1.0, 1.0]), "not both"),
        (dict(M=M, K=K, damping_ratios=0.1, f_ref_hz=-1.0), "f_ref_hz"),
        (dict(M=M.astype(complex), K=K, damping_ratios=0.1), "not real numbers"),
    ]
    for kw, msg in bad:
        with pytest.raises(ValueError, match=msg) as e:
            build_matrices(**kw)
        assert "\n" not in str(e.value)


# ============================================================================ sparse
def test_a_large_sparse_chain_by_arpack_against_the_closed_form():
    """A 2500-mass chain (sparse, more than DENSE_MAX DOFs): its 4 lowest modes by ARPACK's
    shift-invert mode against the closed form: frequencies to 1e-10 relative and mass-normalised
    shapes to 1e-8 of their largest entry (ARPACK's default tolerance is machine precision on the
    Ritz values; the lowest of this chain are well separated: f_2 / f_1 = 3); the static ratios by
    the sparse solve; n_modes is required."""
    N, m, k = 2500, 0.01, 1e6
    assert N > DENSE_MAX
    main = np.full(N, 2 * k)
    main[-1] = k
    K = scipy.sparse.diags_array([main, np.full(N - 1, -k), np.full(N - 1, -k)], offsets=[0, 1, -1], format="csr")
    M = scipy.sparse.eye_array(N, format="csr") * m
    mm = build_matrices(M, K, damping_ratios=0.01, n_modes=4, sensor=N - 1)
    om, S = uniform_chain_closed_form(N, m, k)
    np.testing.assert_allclose(mm.frequencies_hz * 2 * math.pi, om[:4], rtol=1e-10)
    np.testing.assert_allclose(mm.shapes, same_up_to_sign(mm.shapes, S[:, :4]), atol=1e-8 * np.abs(S).max())
    n = np.arange(1, N + 1)
    static = np.cumsum(N - n + 1.0)               # spring n carries N - n + 1 masses
    np.testing.assert_allclose(mm.static, static / static[-1], rtol=1e-10)
    with pytest.raises(ValueError, match="n_modes: give the number of modes"):
        build_matrices(M, K, damping_ratios=0.01)


def test_the_sparse_solver_and_checks_agree_with_the_dense_ones():
    """A 40-mass chain with unequal masses as sparse input solved by ARPACK (dense_max = 0) and by
    LAPACK: the 5 lowest frequencies to 1e-11, shapes to 1e-9; the sparse checks (pivot signs of a
    symmetric factorisation, Sylvester's inertia) refuse what the dense ones refuse."""
    rng = np.random.default_rng(3)
    M, K = chain(rng.uniform(0.5, 2.0, 40), rng.uniform(1e3, 5e3, 40))
    Ms, Ks = scipy.sparse.csr_array(M), scipy.sparse.csr_array(K)
    ls, Vs = lowest_modes_of(Ks, Ms, 5, dense_max=0)
    ld, Vd = lowest_modes_of(K, M, 5)
    np.testing.assert_allclose(ls, ld, rtol=1e-11)
    np.testing.assert_allclose(Vs, same_up_to_sign(Vs, Vd), atol=1e-9 * np.abs(Vd).max())
    a = build_matrices(Ms, Ks, damping_ratios=0.02, n_modes=5, dense_max=0)
    b = build_matrices(M, K, damping_ratios=0.02, n_modes=5)
    np.testing.assert_allclose(a.system.omega, b.system.omega, rtol=1e-11)
    np.testing.assert_allclose(a.static, b.static, rtol=1e-12)
    singular = scipy.sparse.csr_array(np.array([[1.0, -1.0], [-1.0, 1.0]]))
    indefinite = scipy.sparse.csr_array(np.array([[1.0, 2.0], [2.0, 1.0]]))
    for A, definite, ok in ((Ms, "positive", True), (Ks, "semi", True), (singular, "semi", True),
                            (singular, "positive", False), (indefinite, "semi", False),
                            (indefinite, "positive", False)):
        for dm in (0, DENSE_MAX):
            assert (matrix_problem(A, definite, dense_max=dm) is None) == ok, (A.toarray(), definite, dm)


# ============================================================================ the reader
def _chain_files(tmp_path):
    M, K = chain([1.0, 3.0, 0.5], [5e3, 2e3, 4e3])
    C = 0.4 * M + 3e-4 * K
    return M, K, C


def test_npz_and_matrix_market_round_trip(tmp_path):
    """Arrays written by numpy.savez and scipy.io.mmwrite (dense and coordinate) read back bit for
    bit, relative paths from the case file's folder; the reduction of what is read equals the one
    of the arrays themselves."""
    M, K, C = _chain_files(tmp_path)
    np.savez(tmp_path / "chain.npz", M=M, K=K, C=C, dofs=np.array(["m1", "m2", "m3"]), r=np.ones(3))
    got = read_matrices("chain.npz", base=tmp_path)
    for a, b in ((got.M, M), (got.K, K), (got.C, C)):
        assert isinstance(a, np.ndarray) and np.array_equal(a, b)
    assert got.dofs == ("m1", "m2", "m3") and np.array_equal(got.r, np.ones(3)) and got.Mr is None
    assert got.sources["K"] == tmp_path / "chain.npz" and got.size == 3
    scipy.io.mmwrite(tmp_path / "M.mtx", M)
    scipy.io.mmwrite(tmp_path / "K.mtx", scipy.sparse.coo_array(K))
    scipy.io.mmwrite(tmp_path / "C.mtx", scipy.sparse.coo_array(C))
    scipy.io.mmwrite(tmp_path / "Mr.mtx", (M @ np.ones(3))[:, None])
    mx = read_matrices({"M": "M.mtx", "K": "K.mtx", "C": tmp_path / "C.mtx", "Mr": "Mr.mtx"}, base=tmp_path)
    assert scipy.sparse.issparse(mx.K) and np.array_equal(mx.K.toarray(), K) and np.array_equal(mx.M, M)
    assert np.array_equal(mx.C.toarray(), C) and np.array_equal(mx.Mr, M @ np.ones(3))
    a = build_matrices(got.M, got.K, C=got.C, r=got.r, dofs=got.dofs, sensor="m3")
    b = build_matrices(mx.M, mx.K, C=mx.C, Mr=mx.Mr, sensor=2)
    c = build_matrices(M, K, C=C, sensor=2)
    for x in (a, b):
        for f in ("omega", "damping", "participation", "sensor", "contacts"):
            np.testing.assert_array_equal(getattr(x.system, f), getattr(c.system, f))


def _npz(tmp_path, name="bad.npz", **arrays):
    p = tmp_path / name
    np.savez(p, **arrays)
    return p


def test_the_reader_refuses_bad_files_in_one_line(tmp_path):
    """Each refusal is one InputError line naming the file, the key (as '<key>' = <value>) and what
    is allowed (the CLI prints it as ``vibeam: error: ...``, exit 2)."""
    M, K, C = _chain_files(tmp_path)
    asym = K.copy()
    asym[0, 1] += 1.0
    cases = [
        (dict(M=M, K=K[:, :2]), "'K' = 3 x 2 matrix: not a square matrix"),
        (dict(M=M, K=K[:2, :2]), "'K' = 2 x 2 matrix: 2 x 2, not M's size; allowed: a matrix of 3 x 3"),
        (dict(M=M, K=asym), "'K' = 3 x 3 matrix: not symmetric"),
        (dict(M=M - 2 * np.eye(3), K=K), "'M' = 3 x 3 matrix: not positive definite"),
        (dict(M=M, K=-K), "'K' = 3 x 3 matrix: not positive semi-definite"),
        (dict(M=M, K=K * np.nan), "'K' = 3 x 3 matrix: 9 entries not finite"),
        (dict(M=M, K=K, C=np.ones((2, 2))), "'C' = 2 x 2 matrix"),
        (dict(M=M, K=K, c=C), "'c' = an array: no such key; allowed: M, K, C, dofs, r, Mr"),
        (dict(M=M), "'K' = missing: allowed: the stiffness matrix"),
        (dict(M=M, K=K, dofs=np.array(["a", "b"])), "'dofs' = 2 array of <U1: allowed: 3 names"),
        (dict(M=M, K=K, dofs=np.array(["a", "a", "b"])), "'a' appears twice"),
        (dict(M=M, K=K, r=np.ones(3), Mr=np.ones(3)), "'Mr' = 3 array: given with 'r'"),
        (dict(M=M, K=K, r=np.ones(4)), "'r' = 4 array: allowed: 3 numbers"),
        (dict(M=M, K=K, dofs=np.array([{"a": 1}, 2, 3], dtype=object)), "'dofs' = Python objects"),
        (dict(M=M.astype(complex), K=K), "'M' = 3 x 3 matrix of complex128: values of type complex128 are "
                                         "not real numbers"),
    ]
    for arrays, msg in cases:
        p = _npz(tmp_path, **arrays)
        with pytest.raises(InputError) as e:
            read_matrices(p)
        text = str(e.value)
        assert text.startswith(f"{p}: ") and msg in text and "\n" not in text, text
    # files that are not there or not archives
    with pytest.raises(InputError, match=r"nope.npz: cannot read matrix file: no such file"):
        read_matrices("nope.npz", base=tmp_path)
    (tmp_path / "text.npz").write_text("M = 1\n")
    with pytest.raises(InputError, match=r"text.npz: cannot read matrix file: not a NumPy .npz archive"):
        read_matrices(tmp_path / "text.npz")
    with pytest.raises(InputError, match="cannot read matrix file: .*not a regular file"):
        read_matrices(tmp_path)
    # MatrixMarket
    scipy.io.mmwrite(tmp_path / "M.mtx", M)
    scipy.io.mmwrite(tmp_path / "Kc.mtx", K.astype(complex))
    with pytest.raises(InputError, match=r"Kc.mtx: 'K' = a MatrixMarket complex array: allowed: a real"):
        read_matrices({"M": "M.mtx", "K": "Kc.mtx"}, base=tmp_path)
    (tmp_path / "junk.mtx").write_text("not a matrix\n")
    with pytest.raises(InputError, match=r"junk.mtx: cannot read matrix file: not a MatrixMarket file"):
        read_matrices({"M": "M.mtx", "K": "junk.mtx"}, base=tmp_path)
    with pytest.raises(InputError, match=r"'K': missing; allowed: a MatrixMarket file of the stiffness"):
        read_matrices({"M": "M.mtx"}, base=tmp_path)
    with pytest.raises(InputError, match=r"'dofs' = 'M.mtx': no such matrix key"):
        read_matrices({"M": "M.mtx", "K": "M.mtx", "dofs": "M.mtx"}, base=tmp_path)


# ============================================================================ done-when 2: the rig's FE beam
def _rig(n_modes):
    """The built-in rung of cases/rig-fe-neutral.toml with n_modes modes (its scene) and its BeamFE
    (the one vibeam.case.beamscene.scene reduces: shared_fe of the same arguments)."""
    from vibeam.case.beamscene import scene_of
    from vibeam.case.schema import load_case
    from vibeam.models.builders.beam_fe import shared_fe

    case, _ = load_case(ROOT / "cases" / "rig-fe-neutral.toml")
    spec = case.model_spec({"n_modes": n_modes})
    model = spec.scene()
    sc = scene_of(spec)
    fe = shared_fe(sc.geometry, n_elements=spec.system.n_elements, damping_D_s=sc.damping_D_s,
                   rayleigh_alpha_1_s=spec.system.rayleigh_alpha_1_s)
    return model, fe


def _fe_dof_names(fe):
    """``w<j>`` / ``t<j>``: the deflection and slope DOFs of mesh node j, on the free DOFs."""
    names = np.empty(fe.basis.N, dtype=object)
    names[fe.basis.nodal_dofs[0]] = [f"w{j}" for j in range(fe.basis.nodal_dofs.shape[1])]
    names[fe.basis.nodal_dofs[1]] = [f"t{j}" for j in range(fe.basis.nodal_dofs.shape[1])]
    return tuple(names[fe.free])


def _unit_dof(row, names):
    j = int(np.argmax(np.abs(row)))
    assert row[j] == 1.0 and np.count_nonzero(row) == 1      # the sensor and the mass sit on mesh nodes
    return names[j]


def _signs(a, b):
    """Per-mode signs taking b's shapes to a's (participations, or the first nonzero row entry)."""
    s = np.sign(a.participation * b.participation)
    assert np.all(s != 0)
    return s


@pytest.mark.parametrize("n_modes", [2, 4])
def test_the_rig_beam_read_back_from_files_is_the_built_in_rung(tmp_path, n_modes):
    """Done-when 2 of issue 58.  The FE cantilever of rig-fe-neutral (46 DOFs, C = D K, the base
    load M_full r_full on the free DOFs as Mr since the consistent mass couples the clamp) written
    to an .npz archive and to MatrixMarket files (K sparse), read back and reduced to the rung's
    modes with its f_ref, L and B: the modal system equals the built-in rung's up to each mode's
    sign (a convention: mode 3 differs), omega and rows to 1e-12 (the same LAPACK call on M
    symmetrised, which the FE assembly leaves asymmetric at 1.3e-19 of max |M|: measured equal
    omega, rows within 4e-16), damping to 1e-10 (phi^T C phi carries ~eps lam_max / lam_1 of
    round-off, lam_max / lam_1 = 9.4e8, against the rung's closed form D omega^2: measured 1.5e-11
    on mode 1).  The FRC by the event integrator on a 5-point up-sweep 14-17 Hz (state carried, 100
    transient and 16 recorded periods per point, the quick variant's; one impact per period)
    equals the rung's to 1e-10 relative: sensor extremes (measured 1.7e-12), samples (1.8e-11),
    impacts, held stops, final modal state (1.6e-12)."""
    from vibeam.models.core.event import EventIntegrator, fundamental_step
    from vibeam.models.scene import Scene

    model, fe = _rig(n_modes)
    names = _fe_dof_names(fe)
    sensor, mass = _unit_dof(fe.sensor_row, names), _unit_dof(fe.contact_row, names)
    np.savez(tmp_path / "rig.npz", M=fe.M, K=fe.K, C=fe.C, Mr=-fe.base_load, dofs=np.array(names))
    scipy.io.mmwrite(tmp_path / "M.mtx", fe.M)
    scipy.io.mmwrite(tmp_path / "K.mtx", scipy.sparse.coo_array(fe.K))
    scipy.io.mmwrite(tmp_path / "C.mtx", fe.C)
    scipy.io.mmwrite(tmp_path / "Mr.mtx", -fe.base_load[:, None])
    ref = model.system
    kw = dict(n_modes=n_modes, sensor=sensor, contacts=(mass,), base_amplitude_m=ref.base_amplitude,
              f_ref_hz=ref.reference_hz, length_m=ref.length_unit_m)
    for source in ("rig.npz", {"M": "M.mtx", "K": "K.mtx", "C": "C.mtx", "Mr": "Mr.mtx"}):
        mat = read_matrices(source, base=tmp_path)
        # the FE assembly leaves M and K symmetric to ~1e-18 of their entries: the reader keeps the
        # mean with the transpose (exactly A for an exactly symmetric A)
        assert np.array_equal(mat.M, (fe.M + fe.M.T) * 0.5) and np.array_equal(mat.Mr, -fe.base_load)
        assert np.array_equal(mat.K.toarray() if scipy.sparse.issparse(mat.K) else mat.K, (fe.K + fe.K.T) * 0.5)
        dofs = mat.dofs if mat.dofs is not None else names
        mm = build_matrices(mat.M, mat.K, C=mat.C, Mr=mat.Mr, dofs=dofs, **kw)
        s = mm.system
        sg = _signs(s, ref)
        np.testing.assert_allclose(s.omega, ref.omega, rtol=1e-12, atol=0)     # measured: equal
        np.testing.assert_allclose(s.damping, ref.damping, rtol=1e-10, atol=0)
        np.testing.assert_allclose(s.participation, sg * ref.participation, rtol=1e-12, atol=0)
        np.testing.assert_allclose(s.sensor, sg * ref.sensor, rtol=1e-12, atol=0)
        np.testing.assert_allclose(s.contacts, sg * ref.contacts, rtol=1e-12, atol=0)
        assert 0.0 < mm.caughey_ratio < 1e-8        # C = D K: round-off only (measured 1.7e-9 on mode 1)
        # the gap conversion by K^-1 M r against the rung's point-load static mode (Eq. 42): 0.09 %
        assert mm.contact_static[0] == pytest.approx(float(ref.contact_static[0]), rel=1e-3)
        assert (s.base_amplitude, s.time_unit_s, s.length_unit_m, s.coordinate_scale, s.mass_unit_kg) == \
            (ref.base_amplitude, ref.time_unit_s, ref.length_unit_m, ref.coordinate_scale, ref.mass_unit_kg)
        stops = model.stops
        runs = []
        for scene in (model, Scene(s, stops)):
            core = EventIntegrator(scene)
            h = fundamental_step(core.system, 16)
            n = core.n
            eta, etad, held = np.zeros(n), np.zeros(n), 0
            out = []
            for f in np.linspace(14.0, 17.0, 5):
                run = core.run(f / ref.reference_hz, eta, etad, held, 100, 16, 16, 64, h, 20000 * 116,
                               20000 * 116, 1e-7)
                out.append(run)
                eta, etad, held = run.eta, run.etad, run.held_end
            runs.append(out)
        for a, b in zip(*runs):
            assert a.status == b.status and a.n_impacts == b.n_impacts > 0 and a.held_end == b.held_end
            for x, y in ((a.s_min, b.s_min), (a.s_max, b.s_max)):
                assert abs(x - y) <= 1e-10 * max(abs(a.s_min), abs(a.s_max))
            scale = np.max(np.abs(a.eta))
            assert np.max(np.abs(a.eta - sg * b.eta)) <= 1e-10 * scale
            assert np.max(np.abs(a.record.samples - b.record.samples)) <= 1e-10 * np.max(np.abs(a.record.samples))
