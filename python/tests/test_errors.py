"""Errors: every bad input is a Python exception with the C++ (and `minv` command's) message,
and the interpreter survives."""
import os
import stat
import subprocess
import sys
import textwrap

import numpy as np
import pytest

import minv
from conftest import cli_path

CLI = cli_path()


def cli_error(*args):
    """The message of `minv <args>` ("minv: error: <message>" on stderr, exit 2)."""
    run = subprocess.run([str(CLI), *map(str, args)], capture_output=True, text=True)
    assert run.returncode == 2, run.stderr
    line = run.stderr.strip().splitlines()[-1]
    assert line.startswith("minv: error: ")
    return line[len("minv: error: "):]


@pytest.fixture
def files(tmp_path):
    """A good model file, bad model files and bad configuration files."""
    good = tmp_path / "good.json"
    minv.save_model(minv.random_tree("serial", 5), good)
    broken = tmp_path / "broken.json"
    broken.write_text("{not json")
    negative = tmp_path / "negative.json"
    negative.write_text(good.read_text().replace('"mass":', '"mass":-', 1))
    short_q = tmp_path / "short.txt"
    short_q.write_text("0.1 0.2 0.3\n")
    nan_q = tmp_path / "nan.txt"
    nan_q.write_text("0.1 nan 0.3 0.4 0.5\n")
    return dict(good=good, broken=broken, negative=negative, missing=tmp_path / "missing.json",
                short_q=short_q, nan_q=nan_q, out=tmp_path / "out.h5")


@pytest.mark.parametrize("which", ["missing", "broken", "negative"])
def test_bad_model_file(files, which):
    with pytest.raises(minv.ModelError) as error:
        minv.load_model(files[which])
    assert isinstance(error.value, ValueError)
    assert str(files[which].name) in str(error.value)
    if CLI:
        assert str(error.value) == cli_error("solve", "--model", files[which], "--out",
                                             files["out"])


@pytest.mark.parametrize("which", ["short_q", "nan_q"])
def test_bad_configuration_file(files, which):
    model = minv.load_model(files["good"])
    with pytest.raises(minv.ModelError) as error:
        minv.read_configuration(model, files[which])
    if CLI:
        assert str(error.value) == cli_error("solve", "--model", files["good"], "--q",
                                             files[which], "--out", files["out"])


def test_unknown_solver(files):
    with pytest.raises(ValueError, match=r"^unknown solver 'nope' \(known: abi, ") as error:
        minv.make_solver("nope")
    assert not isinstance(error.value, minv.ModelError)
    if CLI:
        assert str(error.value) == cli_error("solve", "--model", files["good"], "--solver", "nope",
                                             "--out", files["out"])
    with pytest.raises(ValueError, match="unknown solver 'nope'"):
        minv.flops("nope", minv.random_tree("serial", 2), np.zeros(2))


def test_bad_configurations():
    model = minv.random_tree("serial", 5)
    solver = minv.make_solver("abi")
    solver.prepare(model)
    q = minv.random_configuration(model, 1)
    # Wrong size, NaN: the messages of Model::checkConfiguration (the CLI's final check).
    with pytest.raises(minv.ModelError, match=r"^configuration has 4 entries, model needs 5$"):
        solver.configure(q[:4])
    bad = q.copy()
    bad[2] = np.nan
    with pytest.raises(minv.ModelError, match=r"^configuration entry q\[2\] is not finite$"):
        solver.configure(bad)
    with pytest.raises(minv.ModelError, match="not finite"):
        minv.mass_matrix(model, bad)
    with pytest.raises(minv.ModelError, match="not finite"):
        model.check_configuration(bad)
    # A zero quaternion.
    floating = minv.random_tree("serial", 2, floating_base=True)
    qf = floating.neutral()
    qf[3:7] = 0
    with pytest.raises(minv.ModelError, match="zero quaternion"):
        floating.check_configuration(qf)
    solver.prepare(floating)
    with pytest.raises(minv.ModelError, match="zero quaternion"):
        solver.configure(qf)


def test_bad_generator_arguments():
    with pytest.raises(minv.ModelError, match="ring"):
        minv.random_tree("ring", 5)
    with pytest.raises(minv.ModelError):
        minv.random_tree("serial", 0)
    with pytest.raises(minv.ModelError, match="twisty"):
        minv.random_tree("serial", 3, joints="twisty")
    with pytest.raises(ValueError, match="seed"):
        minv.random_tree("serial", 3, seed=-1)
    with pytest.raises(ValueError, match="seed"):
        minv.random_configuration(minv.random_tree("serial", 3), 2**64)
    with pytest.raises(minv.ModelError):
        minv.centipede(0)
    # The command's size limits hold here too; an int beyond C's is a ValueError naming it
    # (pybind11's own int gave a TypeError listing the signatures).
    with pytest.raises(minv.ModelError, match="at most 300000, got 300001"):
        minv.random_tree("serial", 300001)
    with pytest.raises(minv.ModelError, match="between 1 and 10000, got 10001"):
        minv.centipede(10001)
    for call in (lambda: minv.random_tree("serial", 2**70), lambda: minv.centipede(-2**40),
                 lambda: minv.make_solver("abi").set_threads(2**31)):
        with pytest.raises(ValueError, match="out of range: an int argument lies in"):
            call()
    assert minv.random_tree("serial", np.int64(3)).nv == 3  # numpy's ints are ints


def test_life_cycle_order():
    model = minv.random_tree("serial", 4)
    solver = minv.make_solver("lapack")
    with pytest.raises(RuntimeError, match="needs prepare"):
        solver.inverse()
    with pytest.raises(RuntimeError, match="needs prepare"):
        solver.configure(model.neutral())
    with pytest.raises(TypeError, match="minv.Model"):
        solver.prepare("model.json")
    solver.prepare(model)
    with pytest.raises(RuntimeError, match="needs configure"):
        solver.inverse()
    with pytest.raises(RuntimeError, match="needs configure"):
        solver.solve(np.ones(4))
    solver.configure(model.neutral())
    assert solver.inverse().shape == (4, 4)


def test_bad_right_hand_sides():
    model = minv.random_tree("serial", 4)
    solver = minv.make_solver("abi")
    solver.prepare(model)
    solver.configure(model.neutral())
    with pytest.raises(ValueError, match=r"shape \(nv,\) or \(nv, m\) with nv = 4; got shape \(3,"):
        solver.solve(np.ones((3, 2)))
    with pytest.raises(ValueError, match="got shape"):
        solver.solve(np.ones((4, 2, 2)))
    with pytest.raises(ValueError, match="complex"):
        solver.solve(np.ones(4, dtype=complex))
    with pytest.raises(ValueError, match="cannot convert"):
        solver.solve("abcd")
    # A NaN or infinity in R is refused (it came back as NaN in X; lapack blamed M for it).
    for name in minv.solver_names():
        s = minv.make_solver(name)
        if not s.supports(model):
            continue
        s.prepare(model)
        s.configure(model.neutral())
        R = np.ones((4, 2))
        R[2, 1] = np.nan
        with pytest.raises(ValueError, match=r"non-finite entry nan at \(2, 1\)"):
            s.solve(R)
        with pytest.raises(ValueError, match=r"non-finite entry -inf at \(0, 0\)"):
            s.solve(np.array([-np.inf, 0, 0, 0]))
    # Finite R whose M⁻¹R overflows: an error, not infinities in X.
    with pytest.raises(ValueError, match="overflows"):
        solver.solve(np.full(4, 1e308))


class _Unused:
    """A solver that compare refuses to run (its output is not a regular file)."""

    def prepare(self, model):
        raise AssertionError("not to be called")

    configure = inverse = solve = prepare


def test_files_and_sizes_that_are_not_what_they_should_be(tmp_path):
    import h5py
    # A path that is not UTF-8 keeps its message (it was an empty ModelError), bytes escaped.
    with pytest.raises(minv.ModelError, match=r"cannot open '.*\\xffx\.json'"):
        minv.load_model(str(tmp_path) + "/\udcffx.json")
    # A FIFO is neither read (the call blocked) nor replaced by an output.
    fifo = tmp_path / "fifo.json"
    os.mkfifo(fifo)
    with pytest.raises(minv.ModelError, match="not a regular file"):
        minv.load_model(str(fifo))
    with pytest.raises(minv.ModelError, match="exists and is not a regular file"):
        minv.save_model(minv.random_tree("serial", 2), str(fifo))
    fifo_h5 = tmp_path / "fifo.h5"
    os.mkfifo(fifo_h5)
    with pytest.raises(minv.ModelError, match="exists and is not a regular file"):
        minv.compare(_Unused, sizes=(8,), out=str(fifo_h5))
    assert stat.S_ISFIFO(os.stat(fifo).st_mode) and stat.S_ISFIFO(os.stat(fifo_h5).st_mode)
    other = tmp_path / "other.h5"
    with h5py.File(other, "w") as f:
        f.attrs["experiment"] = "flops"
    with pytest.raises(RuntimeError, match="is not a timing-sweep file \\(experiment 'flops'"):
        minv.read_points(str(other))  # it returned {} as if the sweep were empty
    with pytest.raises(minv.ModelError, match="is a directory"):
        minv.read_points(str(tmp_path))  # read in a child process first: the type is kept
    model = minv.random_tree("serial", 4)
    with pytest.raises(ValueError, match="m must be between 0 and 100000, got 1000000000"):
        minv.flops("abi", model, model.neutral(), 10**9)
    q = model.neutral()
    q[0] = 1e300  # a revolute angle: DART aborted the interpreter on it
    with pytest.raises(minv.ModelError, match="rad is beyond"):
        minv.mass_matrix(model, q)
    for name in minv.solver_names():
        s = minv.make_solver(name)
        s.prepare(model)
        with pytest.raises(minv.ModelError, match="rad is beyond"):
            s.configure(q)


def test_complex_configurations_and_thread_counts():
    model = minv.random_tree("serial", 4)
    solver = minv.make_solver("abi")
    solver.prepare(model)
    q = model.neutral().astype(complex) + 1j
    with pytest.raises(ValueError, match="q must be a 1-D array of real numbers; got a complex"):
        solver.configure(q)
    with pytest.raises(ValueError, match="complex"):
        minv.mass_matrix(model, q)
    with pytest.raises(ValueError, match="2 dimensions"):
        solver.configure(np.zeros((4, 1)))
    solver.configure(list(model.neutral()))  # a list of floats is fine
    for n in (0, 513, 65536):
        with pytest.raises(ValueError, match=f"threads must be between 1 and 512, got {n}"):
            solver.set_threads(n)
    solver.set_threads(512)
    assert np.allclose(solver.inverse() @ minv.mass_matrix(model, model.neutral()), np.eye(4))


def test_interpreter_survives_every_error():
    """All the bad inputs in a fresh interpreter, which must then exit normally."""
    script = textwrap.dedent("""
        import numpy as np, minv
        m = minv.random_tree("serial", 6)
        s = minv.make_solver("abi")
        bad = [lambda: minv.load_model("/nonexistent/x.json"), lambda: minv.make_solver("x"),
               lambda: s.inverse(), lambda: s.configure(np.zeros(6)), lambda: s.prepare(None),
               lambda: s.solve(None)]
        s2 = minv.make_solver("abi"); s2.prepare(m); s2.configure(m.neutral())
        bad += [lambda: s2.configure(np.zeros(5)), lambda: s2.configure(np.full(6, np.nan)),
                lambda: s2.inverse(out=np.empty((6, 6))), lambda: s2.inverse(out=np.empty(3)),
                lambda: s2.inverse(out="x"), lambda: s2.solve(np.ones(5)),
                lambda: s2.solve(np.ones(6), out=np.empty((6, 1), dtype=np.float32)),
                lambda: minv.flops("abi-generic", m, m.neutral()),
                lambda: minv.mass_matrix(m, [1, 2])]
        for f in bad:
            try:
                f()
                raise SystemExit("no exception")
            except (ValueError, RuntimeError, TypeError) as e:
                pass
        print("alive", s2.inverse().shape)
    """)
    run = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True)
    assert run.returncode == 0, run.stderr
    assert "alive (6, 6)" in run.stdout


def test_damaged_result_files_raise_and_the_interpreter_survives(tmp_path):
    """A timing file with bytes flipped at random is read, or refused with an exception: libhdf5
    crashed the interpreter on about 1 in 9 such files before the reader read each one in a
    child process first."""
    shard = tmp_path / "shard.h5"
    run = subprocess.run([str(CLI), "time", "--mode", "tiny", "--solvers", "abi", "--min-time",
                          "0.001", "--repetitions", "1", "--shard", "0/20", "--out", str(shard)],
                         capture_output=True, text=True)
    assert run.returncode == 0, run.stderr
    script = textwrap.dedent(f"""
        import random
        import minv
        good = open({str(shard)!r}, "rb").read()
        rng = random.Random(11)
        refused = 0
        for t in range(80):
            b = bytearray(good)
            for _ in range(rng.choice([1, 1, 2, 8])):
                b[rng.randrange(len(b))] = rng.randrange(256)
            path = {str(tmp_path / "damaged.h5")!r}
            open(path, "wb").write(b)
            try:
                minv.read_points(path)
            except (RuntimeError, ValueError):
                refused += 1
        print("refused", refused)
    """)
    run = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True)
    assert run.returncode == 0, run.stderr[-3000:]
    assert int(run.stdout.split()[-1]) > 5, run.stdout


def test_a_damaged_string_heap_is_an_error_not_empty_attributes(tmp_path):
    """Strings live in the file's global heap, which has no checksum: HDF5 reads a damaged
    entry back as "" or as other text without an error, and read_points gave every point an
    empty family, solver and base (a review's file) before it held each point's attributes to
    its name."""
    shard = tmp_path / "shard.h5"
    run = subprocess.run([str(CLI), "time", "--mode", "tiny", "--solvers", "abi", "--min-time",
                          "0.001", "--repetitions", "1", "--shard", "0/20", "--out", str(shard)],
                         capture_output=True, text=True)
    assert run.returncode == 0, run.stderr
    assert minv.read_points(shard)
    good = shard.read_bytes()
    heap = good.find(b"GCOL")
    assert heap >= 0
    size = int.from_bytes(good[heap + 8:heap + 16], "little")
    damaged = tmp_path / "damaged.h5"
    # One solver string "abi" in the heap made "abj"; then the entry after it unfindable (its
    # index, 16 bytes into the collection, flipped, as the review's file had it)
    for offset in (good.find(b"abi", heap, heap + size) + 2, good.find(b"abi", heap) - 16):
        data = bytearray(good)
        data[offset] ^= 0x03 if data[offset] == ord("i") else 0xFF
        damaged.write_bytes(bytes(data))
        with pytest.raises(RuntimeError, match="is damaged"):
            minv.read_points(damaged)


@pytest.mark.parametrize("limit", [3000, 9000])
def test_failed_writes_raise_and_the_interpreter_exits_cleanly(tmp_path, limit):
    """A write that a file-size limit (as a full disk) stops raises RuntimeError, leaves no
    file, and the interpreter exits 0, also where h5py started HDF5 first: HDF5 1.10 kept the
    file whose flush had failed, closed it again at exit and crashed (SIGSEGV) before the
    writer built its files in memory and wrote them itself."""
    pytest.importorskip("h5py")
    script = textwrap.dedent(f"""
        import os, resource, signal
        import h5py
        import numpy as np
        import minv

        class Identity:
            def prepare(self, model): self.n = model.nv
            def configure(self, q): pass
            def inverse(self): return np.eye(self.n)
            def solve(self, R): return R

        out = {str(tmp_path / "out.h5")!r}
        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
        resource.setrlimit(resource.RLIMIT_FSIZE, ({limit}, resource.RLIM_INFINITY))
        try:
            minv.compare(Identity, sizes=(8, 16), topologies="serial", against=("abi",),
                         out=out, repetitions=1, min_time=0.001)
            print("written")
        except RuntimeError as e:
            print("raised:", e)
        print("left:", sorted(os.listdir(os.path.dirname(out))))
    """)
    run = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True)
    assert run.returncode == 0, (run.returncode, run.stdout, run.stderr[-2000:])
    assert "raised: cannot write" in run.stdout and "File too large" in run.stdout, run.stdout
    assert "left: []" in run.stdout, run.stdout
