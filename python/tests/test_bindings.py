"""The bindings: models and their attributes, model files, M, every registered solver, out=."""
import gc

import numpy as np
import pytest

import minv


def test_serial_tree_attributes():
    model = minv.random_tree("serial", 5, seed=3)
    assert (model.nb, model.nv, model.nq) == (5, 5, 5)
    assert model.parents == [-1, 0, 1, 2, 3]
    assert model.dof_parent == [-1, 0, 1, 2, 3]
    assert model.dof_names == model.q_names == [f"j{k}" for k in range(5)]
    assert model.body_names == [f"b{k}" for k in range(5)]
    assert model.joint_types == ["revolute"] * 5
    assert not model.floating_base
    assert model.max_depth == 5
    assert "nv=5" in repr(model)


def test_floating_mixed_tree_attributes():
    model = minv.random_tree("branched", 32, seed=2, floating_base=True, joints="mixed")
    assert model.floating_base
    assert model.joint_types[0] == "floating"
    assert model.nb == 33
    assert model.nq > model.nv > 32 + 6 - 1
    assert len(model.q_names) == model.nq and len(model.dof_names) == model.nv
    assert model.q_names[:7] == ["base_x", "base_y", "base_z", "base_qw", "base_qx", "base_qy",
                                 "base_qz"]
    assert model.max_depth < model.nb
    q0 = model.neutral()
    assert q0.shape == (model.nq,) and q0[3] == 1.0
    model.check_configuration(q0)


def test_centipede():
    model = minv.centipede(3)
    assert model.nv == 9 * 3 + 5 and model.floating_base
    assert minv.centipede(2, segment_joint="spherical").nv == 6 + 3 + 16


@pytest.mark.parametrize("ext", ["json", "urdf"])
def test_model_files_round_trip(tmp_path, ext):
    model = minv.random_tree("branched", 12, seed=5)
    path = tmp_path / f"tree.{ext}"
    minv.save_model(model, path)
    back = minv.load_model(str(path))
    assert back.parents == model.parents and back.nv == model.nv
    q = minv.random_configuration(model, 4)
    np.testing.assert_allclose(minv.mass_matrix(back, q), minv.mass_matrix(model, q),
                               rtol=1e-12, atol=1e-12)
    if ext == "json":
        assert minv.load_model(path, floating_base=True).nv == model.nv + 5


def test_a_floating_base_saved_as_urdf_is_dropped_with_a_warning(tmp_path):
    """URDF has no floating joint: the saved file reads back fixed unless asked, and the caller
    is told so (it was dropped silently)."""
    model = minv.random_tree("branched", 6, seed=5, floating_base=True)
    path = tmp_path / "tree.urdf"
    with pytest.warns(UserWarning, match="has no floating joint"):
        minv.save_model(model, path)
    assert minv.load_model(path).nv == model.nv - 6
    assert minv.load_model(path, floating_base=True).nv == model.nv


def test_read_configuration(tmp_path):
    model = minv.random_tree("serial", 4)
    q = minv.random_configuration(model, 9)
    (tmp_path / "q.txt").write_text(" ".join(repr(float(v)) for v in q) + "\n")
    np.testing.assert_array_equal(minv.read_configuration(model, tmp_path / "q.txt"), q)
    (tmp_path / "named.txt").write_text("# two named entries\nj1 0.5\nj3 -1\n")
    np.testing.assert_array_equal(minv.read_configuration(model, tmp_path / "named.txt"),
                                  [0, 0.5, 0, -1])


def test_random_configuration_is_seeded():
    model = minv.random_tree("serial", 6, floating_base=True)
    np.testing.assert_array_equal(minv.random_configuration(model, 3),
                                  minv.random_configuration(model, 3))
    assert not np.array_equal(minv.random_configuration(model, 3),
                              minv.random_configuration(model, 4))


@pytest.mark.parametrize("topology", ["serial", "branched"])
@pytest.mark.parametrize("floating", [False, True])
def test_mass_matrix_is_symmetric_positive_definite(topology, floating):
    model = minv.random_tree(topology, 20, seed=7, floating_base=floating, joints="mixed")
    M = minv.mass_matrix(model, minv.random_configuration(model, 1))
    assert M.shape == (model.nv, model.nv) and M.dtype == np.float64
    np.testing.assert_allclose(M, M.T, rtol=0, atol=1e-12 * np.abs(M).max())
    assert np.linalg.eigvalsh(M).min() > 0


def test_solver_registry():
    entries = minv.solvers()
    assert all(isinstance(e, tuple) and len(e) == 2 for e in entries)
    names = minv.solver_names()
    assert names == [name for name, _ in entries]
    assert {"abi", "lapack", "ltl", "ltdl", "naive", "eigen"} <= set(names)
    assert "abi" in minv.counted_solvers()


def _problem(topology="branched", n=20, floating=True):
    model = minv.random_tree(topology, n, seed=11, floating_base=floating, joints="mixed")
    q = minv.random_configuration(model, 2)
    return model, q, minv.mass_matrix(model, q)


def _configured(name):
    """(model, q, M, solver) with the solver prepared for _problem()'s model and configured."""
    model, q, M = _problem()
    solver = minv.make_solver(name)
    solver.prepare(model)
    solver.configure(q)
    return model, q, M, solver


def _configured_or_skip(name, topology="branched", floating=True):
    """(model, q, M, solver) for a 20-link tree, or the test skipped if the solver refuses it."""
    model, q, M = _problem(topology, 20, floating)
    solver = minv.make_solver(name)
    ok, why = solver.supports(model)
    if not ok:
        pytest.skip(f"{name} does not support the tree: {why}")
    solver.prepare(model)
    solver.configure(q)
    return model, q, M, solver


@pytest.mark.parametrize("name", minv.solver_names())
@pytest.mark.parametrize("topology,floating", [("serial", False), ("branched", True)])
def test_every_solver_inverts_M(name, topology, floating):
    model, q, M, solver = _configured_or_skip(name, topology, floating)
    X = solver.inverse()
    assert X.shape == (model.nv, model.nv) and X.flags.f_contiguous
    # Backward-stable: |M X - I| / |I| within a generous multiple of nv·cond(M)·eps.
    tol = 100 * model.nv * np.linalg.cond(M) * np.finfo(float).eps
    eye = np.eye(model.nv)
    assert np.linalg.norm(M @ X - eye) / np.sqrt(model.nv) < tol
    R = np.random.default_rng(0).standard_normal((model.nv, 3))
    XR = X @ R
    assert np.linalg.norm(solver.solve(R) - XR) / np.linalg.norm(XR) < tol


def test_solve_shapes_and_conversions():
    model, q, M, solver = _configured("abi")
    X = solver.inverse()
    nv = model.nv
    r = np.arange(nv, dtype=float)
    x = solver.solve(r)
    assert x.shape == (nv,)
    np.testing.assert_allclose(x, X @ r, rtol=1e-10)
    # C order, integers, a list and a strided view are converted.
    R = np.random.default_rng(1).standard_normal((nv, 4))
    np.testing.assert_allclose(solver.solve(np.ascontiguousarray(R)), X @ R, rtol=1e-10)
    np.testing.assert_allclose(solver.solve(np.ones((nv, 2), dtype=int)), X @ np.ones((nv, 2)),
                               rtol=1e-10)
    np.testing.assert_allclose(solver.solve(list(r)), X @ r, rtol=1e-10)
    np.testing.assert_allclose(solver.solve(R[:, ::2]), X @ R[:, ::2], rtol=1e-10)
    assert solver.solve(np.zeros((nv, 0))).shape == (nv, 0)


def test_inverse_out_writes_in_place():
    model, q, M, solver = _configured("abi")
    nv = model.nv
    X = np.full((nv, nv), np.nan, order="F")
    address = X.ctypes.data
    result = solver.inverse(out=X)
    assert result is X and X.ctypes.data == address
    np.testing.assert_allclose(X, solver.inverse(), rtol=0, atol=0)
    # A column-major view with a larger column stride: written in place, the rest untouched.
    big = np.full((nv + 2, nv), -7.0, order="F")
    view = big[:nv, :]
    solver.inverse(out=view)
    np.testing.assert_array_equal(view, X)
    assert (big[nv:, :] == -7.0).all()


@pytest.mark.parametrize("name", minv.solver_names())
def test_inverse_upper_triangle(name):
    model, q, M, solver = _configured_or_skip(name)
    nv = model.nv
    ref = np.linalg.inv(M)
    tol = 100 * nv * np.linalg.cond(M) * np.finfo(float).eps * np.abs(ref).max()
    iu = np.triu_indices(nv)
    U = solver.inverse(upper=True)
    assert U.shape == (nv, nv) and U.flags.f_contiguous
    assert np.abs(U[iu] - ref[iu]).max() < tol
    # abi and lapack write the upper triangle alone: a new array's lower part stays zero and
    # out's is left as it was.
    if name in ("abi", "lapack"):
        il = np.tril_indices(nv, -1)
        assert (U[il] == 0).all()
        X = np.full((nv, nv), -7.0, order="F")
        assert solver.inverse(out=X, upper=True) is X
        assert (X[il] == -7.0).all() and np.abs(X[iu] - ref[iu]).max() < tol


def test_solve_out_writes_in_place():
    model, q, M, solver = _configured("lapack")
    nv = model.nv
    R = np.asfortranarray(np.random.default_rng(2).standard_normal((nv, 5)))
    Y = np.empty((nv, 5), order="F")
    address = Y.ctypes.data
    assert solver.solve(R, out=Y) is Y and Y.ctypes.data == address
    np.testing.assert_allclose(Y, np.linalg.solve(M, R), rtol=1e-9, atol=1e-12)
    y = np.empty(nv)
    solver.solve(R[:, 0], out=y)
    np.testing.assert_allclose(y, Y[:, 0], rtol=1e-12)


@pytest.mark.parametrize("make_bad", [
    lambda nv: np.empty((nv, nv)),                              # C order
    lambda nv: np.empty((nv, nv), dtype=np.float32, order="F"),  # float32
    lambda nv: np.empty((nv, nv + 1), order="F"),                # shape
    lambda nv: np.empty((nv * nv,)),                             # 1-D
    lambda nv: np.empty((2 * nv, nv), order="F")[::2],           # strided rows
    lambda nv: np.empty((nv, nv), dtype=">f8", order="F"),       # big-endian
    lambda nv: np.empty((nv, nv), dtype=complex, order="F"),     # complex
    lambda nv: [[0.0] * nv] * nv,                                # not an array
], ids=["C", "float32", "shape", "1-D", "strided", "big-endian", "complex", "list"])
def test_inverse_rejects_bad_out(make_bad):
    model, q, M, solver = _configured("abi")
    nv = model.nv
    with pytest.raises(ValueError, match=rf"out must be a writeable float64 array of shape "
                                         rf"\({nv}, {nv}\) in Fortran order: "
                                         rf"numpy.empty\(\({nv}, {nv}\), order='F'\)"):
        solver.inverse(out=make_bad(nv))


def test_out_read_only_and_overlap_rejected():
    model, q, M, solver = _configured("abi")
    nv = model.nv
    X = np.empty((nv, nv), order="F")
    X.flags.writeable = False
    with pytest.raises(ValueError, match="read-only"):
        solver.inverse(out=X)
    R = np.ones((nv, 2), order="F")
    with pytest.raises(ValueError, match="shape \\(" + str(nv) + ", 2\\)"):
        solver.solve(R, out=np.empty((nv, 3), order="F"))
    with pytest.raises(ValueError, match="must not share memory with R"):
        solver.solve(R, out=R)


def test_threads_and_supports():
    model, q, M = _problem()
    solver = minv.make_solver("abi")
    assert solver.threads == 1
    solver.set_threads(2)
    assert solver.threads in (1, 2)
    with pytest.raises(ValueError):
        solver.set_threads(0)
    assert solver.supports(model) == (True, "")
    assert "not prepared" in repr(solver)
    solver.prepare(model)
    solver.configure(q)
    assert "configured" in repr(solver) and solver.nv == model.nv
    X = solver.inverse()
    assert np.linalg.norm(M @ X - np.eye(model.nv)) < 1e-8


@pytest.mark.parametrize("n", [20, 250])
def test_set_threads_keeps_the_configuration(n):
    # abi remakes its per-thread copies of the configuration (two of them from 192 DOFs).
    model, q, M = _problem("serial", n)
    solver = minv.make_solver("abi")
    solver.prepare(model)
    solver.configure(q)
    for threads in (2, 1, 2):
        solver.set_threads(threads)
        X = solver.inverse()
        assert np.linalg.norm(M @ X - np.eye(model.nv)) < 1e-8 * np.linalg.cond(M)


def test_solver_keeps_its_model_alive():
    solver = minv.make_solver("abi")
    solver.prepare(minv.random_tree("serial", 30, seed=4))
    gc.collect()
    model = solver.model
    q = minv.random_configuration(model, 1)
    solver.configure(q)
    X = solver.inverse()
    np.testing.assert_allclose(minv.mass_matrix(model, q) @ X, np.eye(30), atol=1e-8)
    # A second prepare releases the first model and holds the new one.
    solver.prepare(minv.random_tree("serial", 5))
    assert solver.model.nv == 5


def test_flops():
    model = minv.random_tree("serial", 8)
    q = minv.random_configuration(model, 1)
    counts = minv.flops("abi", model, q)
    assert counts and all(set(c) == {"mul", "add", "div", "sqrt", "cmp", "trig", "flops",
                                     "documented"} for c in counts.values())
    assert all(c["documented"] is False for c in counts.values())
    assert sum(c["mul"] for c in counts.values()) > 0
    stage = next(iter(counts.values()))
    assert stage["flops"] == sum(stage[k] for k in ("mul", "add", "div", "sqrt", "trig"))
    lapack = minv.flops("lapack", model, q, m=3)
    assert any(c["documented"] for c in lapack.values())
    with pytest.raises(ValueError):
        minv.flops("abi-generic", model, q)
    with pytest.raises(ValueError):
        minv.flops("abi", model, q, m=-1)
