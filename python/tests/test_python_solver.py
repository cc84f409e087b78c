"""Solvers written in Python: minv.check (the C++ conformance suite), minv.compare (the timing
harness), register_solver; and that the result files suit the harness's reader and plots/."""
import os
import subprocess
import sys

import numpy as np
import pytest
import scipy.linalg

import minv
from conftest import ScipyCholesky, cli_path


class Perturbed(ScipyCholesky):
    """Wrong on purpose: the inverse of M + 1e-6·I."""

    def configure(self, q):
        M = minv.mass_matrix(self.model, q)
        self.factor = scipy.linalg.cho_factor(M + 1e-6 * np.eye(len(M)))


class WrongShape(ScipyCholesky):
    def inverse(self):
        return np.zeros((self.model.nv + 1, self.model.nv))


class NotFinite(ScipyCholesky):
    def inverse(self):
        X = super().inverse()
        X[0, 0] = np.nan
        return X


class Raises(ScipyCholesky):
    def configure(self, q):
        raise ArithmeticError("no configuration today")


class OnlySerial(ScipyCholesky):
    def supports(self, model):
        ok = max(model.parents.count(p) for p in set(model.parents)) <= 1
        return ok, "" if ok else "only serial chains"


def test_check_scipy_cholesky_passes():
    report = minv.check(ScipyCholesky)
    assert report.passed, str(report)
    assert report.failures == 0 and not report.errors and not report.skipped
    cases = {c.case for c in report.checks}
    assert "serial_mixed_floating_n300" in cases and "branched_revolute_fixed_n100_urdf" in cases
    c = report.checks[0]
    assert c.passed and c.value <= c.bound and isinstance(c.check, str)
    assert report.worst is not None and report.worst.value <= report.worst.bound
    text = str(report)
    assert text.startswith("conformance of ScipyCholesky: PASSED")


def test_check_accepts_factories_instances_and_names():
    assert minv.check(lambda: ScipyCholesky(), max_n=7).passed
    instance = ScipyCholesky()
    assert minv.check(instance, max_n=7, urdf=False).passed
    assert minv.check("abi", max_n=7).passed
    with pytest.raises(ValueError, match="unknown solver"):
        minv.check("nope")
    with pytest.raises(TypeError, match="prepare"):
        minv.check(42)
    with pytest.raises(ValueError, match="max_n"):
        minv.check(ScipyCholesky, max_n=0)


def test_check_fails_a_wrong_solver():
    report = minv.check(Perturbed, max_n=32)
    assert not report.passed
    assert report.failures > 0
    failed = {c.check for c in report.checks if not c.passed}
    assert "inverse |MX-I|" in failed
    assert "FAILED" in str(report) and "FAIL inverse" in str(report)


@pytest.mark.parametrize("cls,message", [
    (WrongShape, "WrongShape.inverse() returned an array of shape"),
    (NotFinite, "NotFinite.inverse() returned non-finite entries"),
    (Raises, "Raises.configure(): ArithmeticError: no configuration today"),
])
def test_check_reports_errors(cls, message):
    report = minv.check(cls, max_n=3, urdf=False)
    assert not report.passed
    assert report.errors and all(message in what for _, what in report.errors), report.errors


def test_check_respects_supports():
    report = minv.check(OnlySerial, max_n=7, urdf=False)
    assert report.skipped and all(why == "only serial chains" for _, why in report.skipped)
    assert all(case.startswith("branched") for case, _ in report.skipped)
    assert report.passed


def test_missing_methods():
    class Half:
        def prepare(self, model):
            pass

    with pytest.raises(TypeError, match=r"lacks configure\(\), inverse\(\), solve\(\)"):
        minv.check(Half)
    # A factory is only called case by case: each case records the error.
    report = minv.check(lambda: Half(), max_n=1, urdf=False)
    assert not report.passed and len(report.errors) == 8  # n = 1: 2 topologies × 2 bases × 2
    assert all("lacks configure(), inverse(), solve()" in what for _, what in report.errors)


def test_register_solver_round_trip():
    minv.register_solver("py-cholesky", ScipyCholesky, "scipy Cholesky, for the tests")
    try:
        assert ("py-cholesky", "scipy Cholesky, for the tests") in minv.solvers()
        with pytest.raises(ValueError, match="already registered"):
            minv.register_solver("py-cholesky", ScipyCholesky)
        model = minv.random_tree("branched", 16, seed=3)
        q = minv.random_configuration(model, 1)
        solver = minv.make_solver("py-cholesky")
        solver.prepare(model)
        solver.configure(q)
        X = np.empty((16, 16), order="F")
        solver.inverse(out=X)
        np.testing.assert_allclose(minv.mass_matrix(model, q) @ X, np.eye(16), atol=1e-9)
        assert minv.check("py-cholesky", max_n=7).passed
    finally:
        assert minv.unregister_solver("py-cholesky")
    assert "py-cholesky" not in minv.solver_names()
    with pytest.raises(ValueError, match="character"):
        minv.register_solver("bad name", ScipyCholesky)
    with minv.registered(ScipyCholesky) as name:
        assert name == "scipycholesky" and name in minv.solver_names()
    assert name not in minv.solver_names()


def test_compare_writes_the_expected_points(tmp_path):
    out = tmp_path / "sub" / "compare.h5"
    result = minv.compare(ScipyCholesky, sizes=(4, 8), topologies=("serial", "branched"),
                          against=("abi", "lapack"), out=out, repetitions=2, min_time=0.001)
    assert result.solver == "scipycholesky"
    assert "scipycholesky" not in minv.solver_names()  # unregistered again
    assert os.path.isfile(out) and not os.path.exists(str(out) + ".compare-tmp")
    points = minv.read_points(out)
    expected = {f"pipeline.{s}.{t}.fixed.n{n:05d}.m0.t1"
                for s in ("abi", "lapack", "scipycholesky") for t in ("serial", "branched")
                for n in (4, 8)}
    assert set(points) == expected
    for name, point in points.items():
        a = point["attrs"]
        assert a["status"] == "ok" and a["family"] == "pipeline" and a["repetitions"] == 2
        assert len(point["real_time_s"]) == 2 and (point["real_time_s"] > 0).all()
        assert len(point["parent"]) == a["nb"]
    assert result.stats == {"measured": 12, "skipped": 0, "resumed": 0}
    for solver in ("abi", "lapack", "scipycholesky"):
        assert set(result.times[solver]["serial"]) == {4, 8}
    assert "scipycholesky" in str(result)


def test_compare_root_attributes(tmp_path):
    h5py = pytest.importorskip("h5py")
    out = tmp_path / "c.h5"
    minv.compare(ScipyCholesky, sizes=(4,), topologies=("serial",), against=("abi",), out=out,
                 name="mine", repetitions=1, min_time=0.001)
    with h5py.File(out, "r") as f:
        attrs = {k: v.decode() if isinstance(v, bytes) else v for k, v in f.attrs.items()}
    assert attrs["experiment"] == "timing" and attrs["compare_solver"] == "mine"
    assert attrs["compare_against"] == "abi" and attrs["numpy_version"] == np.__version__
    for key in ("git_sha", "compiler", "cpu_model", "blas_library", "date_utc", "hostname"):
        assert key in attrs


def test_compare_unregisters_on_error(tmp_path):
    out = tmp_path / "fail.h5"
    with pytest.raises(RuntimeError, match="Raises.configure\\(\\): ArithmeticError"):
        minv.compare(Raises, sizes=(4,), topologies=("serial",), against=("abi",), out=out,
                     repetitions=1, min_time=0.001)
    assert "raises" not in minv.solver_names()
    assert not os.path.exists(out) and not os.path.exists(str(out) + ".compare-tmp")
    with pytest.raises(ValueError, match="unknown solver 'nope'"):
        minv.compare(ScipyCholesky, against=("nope",), out=out)
    with pytest.raises(ValueError, match="character"):
        minv.compare(ScipyCholesky, name="a b", out=out)
    with pytest.raises(minv.ModelError):
        minv.compare(ScipyCholesky, topologies=("ring",), out=out)
    assert "scipycholesky" not in minv.solver_names()
    # Refused before anything is made: no new folder is left behind, no sweep runs first.
    for bad in ((0,), (-4,), (), (2.5,)):
        with pytest.raises(ValueError, match="sizes must be positive integers"):
            minv.compare(ScipyCholesky, sizes=bad, out=tmp_path / "new" / "deeper" / "c.h5")
    assert not os.path.exists(tmp_path / "new")
    with pytest.raises(ValueError, match="up to 16384"):
        minv.compare(ScipyCholesky, sizes=(10**7,), out=out)  # once grew to 24 GB
    with pytest.raises(IsADirectoryError, match="must name a file"):
        minv.compare(ScipyCholesky, out="")
    with pytest.raises(IsADirectoryError, match="must name a file"):
        minv.compare(ScipyCholesky, out=str(tmp_path / "sub") + "/")
    (tmp_path / "plain").write_text("x")
    with pytest.raises(NotADirectoryError, match="is a file, not a directory"):
        minv.compare(ScipyCholesky, out=tmp_path / "plain" / "c.h5")
    with pytest.raises(ValueError, match="min_time"):
        minv.compare(ScipyCholesky, min_time=float("inf"), out=out)
    with pytest.raises(IsADirectoryError, match="is a directory"):
        minv.compare(ScipyCholesky, out=tmp_path)
    # A failure in the sweep also removes the folders the call made.
    with pytest.raises(minv.ModelError):
        minv.compare(ScipyCholesky, topologies=("ring",), out=tmp_path / "made" / "c.h5")
    assert not os.path.exists(tmp_path / "made")


def test_solver_names_in_messages_are_text():
    """A name with a non-ASCII letter or a NUL is refused with the byte spelled out."""
    with pytest.raises(ValueError, match=r"solver name '\\xC3\\xA9' has the character '\\xC3'"):
        minv.register_solver("é", ScipyCholesky)
    with pytest.raises(ValueError, match=r"solver name 'ab\\x00c' has the character '\\x00'"):
        minv.register_solver("ab\x00c", ScipyCholesky)
    with pytest.raises(ValueError, match=r"unknown solver 'x\\x00y'"):
        minv.make_solver("x\x00y")


def test_compare_resume_keeps_points(tmp_path):
    out = tmp_path / "r.h5"
    kw = dict(topologies=("serial",), against=("abi",), out=out, repetitions=1, min_time=0.001)
    minv.compare(ScipyCholesky, sizes=(4,), **kw)
    again = minv.compare(ScipyCholesky, sizes=(4, 6), resume=True, **kw)
    assert again.stats == {"measured": 2, "skipped": 0, "resumed": 2}
    fresh = minv.compare(ScipyCholesky, sizes=(6,), **kw)
    assert fresh.stats["resumed"] == 0 and len(minv.read_points(out)) == 2
    # Resumed with other settings, the points would have been measured two ways: refused.
    kw["min_time"] = 0.002
    with pytest.raises(ValueError, match=r"made with min_time_s '0.001' \(this run: '0.002'\)"):
        minv.compare(ScipyCholesky, sizes=(6, 8), resume=True, **kw)
    assert len(minv.read_points(out)) == 2


def test_compare_replaces_only_a_timing_sweep(tmp_path):
    """Without resume an existing out is replaced: only if it is a timing sweep (a solve result
    and a model file were replaced)."""
    kw = dict(sizes=(4,), topologies=("serial",), against=("abi",), repetitions=1,
              min_time=0.001)
    model = tmp_path / "m.json"
    minv.save_model(minv.random_tree("serial", 3), model)
    text = model.read_bytes()
    with pytest.raises(ValueError, match="exists and is not a timing sweep"):
        minv.compare(ScipyCholesky, out=model, **kw)
    assert model.read_bytes() == text
    solved = tmp_path / "solved.h5"
    run = subprocess.run([str(cli_path()), "solve", "--model", str(model), "--solver", "abi",
                          "--out", str(solved)], capture_output=True, text=True)
    assert run.returncode == 0, run.stderr
    result = solved.read_bytes()
    with pytest.raises(ValueError, match="exists and is not a timing sweep"):
        minv.compare(ScipyCholesky, out=solved, **kw)
    assert solved.read_bytes() == result
    out = tmp_path / "r.h5"
    minv.compare(ScipyCholesky, out=out, **kw)
    minv.compare(ScipyCholesky, out=out, **kw)
    # Nor is a user's file at the name of compare's tmp file replaced
    mine = tmp_path / "r.h5.compare-tmp"
    mine.write_text("mine\n")
    with pytest.raises(RuntimeError, match="exists and is not an HDF5 file"):
        minv.compare(ScipyCholesky, out=out, **kw)
    assert mine.read_text() == "mine\n"


def test_compare_file_suits_plots(tmp_path, source_dir):
    pytest.importorskip("h5py")
    pytest.importorskip("matplotlib")
    out = tmp_path / "p.h5"
    minv.compare(ScipyCholesky, sizes=(4, 8), topologies=("serial",), against=("abi",), out=out,
                 repetitions=2, min_time=0.001)
    # plots/analysis.py reads it as it reads results/timing.h5.
    sys.path.insert(0, str(source_dir / "plots"))
    try:
        import analysis
        root, points = analysis.load_timing(str(out))
        n, t, lo, hi = analysis.series(points, "pipeline", "scipycholesky", "serial", "fixed")
        assert list(n) == [4, 8] and (lo <= t).all() and (t <= hi).all()
    finally:
        sys.path.remove(str(source_dir / "plots"))
    # plots/compare.py draws it; minv.plot too.
    png = tmp_path / "p.png"
    run = subprocess.run([sys.executable, str(source_dir / "plots" / "compare.py"), str(out),
                          "--out", str(png)], capture_output=True, text=True)
    assert run.returncode == 0, run.stderr
    assert png.stat().st_size > 0
    from minv.plot import plot_comparison
    plot_comparison(out, out=tmp_path / "q.png")
    assert (tmp_path / "q.png").stat().st_size > 0


class Interrupted(ScipyCholesky):
    def configure(self, q):
        raise KeyboardInterrupt("stop")


class FailsLater(ScipyCholesky):
    """Fails inside the timed loop (after the harness's untimed first call)."""
    calls = 0

    def inverse(self):
        FailsLater.calls += 1
        if FailsLater.calls > 20:
            raise ZeroDivisionError("tired")
        return super().inverse()


def test_keyboard_interrupt_stops_check_and_compare(tmp_path):
    with pytest.raises(KeyboardInterrupt):
        minv.check(Interrupted, max_n=3)
    with pytest.raises(KeyboardInterrupt):
        minv.compare(Interrupted, sizes=(4,), topologies=("serial",), against=(),
                     out=tmp_path / "k.h5", repetitions=1, min_time=0.001)
    assert "interrupted" not in minv.solver_names()


def test_failure_inside_the_timed_loop(tmp_path):
    FailsLater.calls = 0
    with pytest.raises(RuntimeError, match=r"FailsLater.inverse\(\): ZeroDivisionError: tired"):
        minv.compare(FailsLater, sizes=(4,), topologies=("serial",), against=(),
                     out=tmp_path / "f.h5", repetitions=3, min_time=0.01)
    assert "failslater" not in minv.solver_names()
    # The harness (Google Benchmark) still works afterwards.
    result = minv.compare(ScipyCholesky, sizes=(4,), topologies=("serial",), against=("abi",),
                          out=tmp_path / "ok.h5", repetitions=1, min_time=0.001, verbose=True)
    assert result.times["abi"]["serial"][4] > 0


class Reentrant(ScipyCholesky):
    """Tries to start a comparison from inside one."""
    out = None

    def configure(self, q):
        minv.compare(ScipyCholesky, sizes=(2,), topologies=("serial",), against=(), out=self.out)


def test_compare_inside_compare_is_an_error_not_a_deadlock(tmp_path):
    Reentrant.out = tmp_path / "inner.h5"
    with pytest.raises(RuntimeError, match="in use by minv.compare"):
        minv.compare(Reentrant, sizes=(4,), topologies=("serial",), against=(),
                     out=tmp_path / "re.h5", repetitions=1, min_time=0.001)
    assert "reentrant" not in minv.solver_names()
