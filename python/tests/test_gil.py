"""The GIL is released while a C++ solver works, and Python solvers called from C++ threads
re-acquire it without deadlocking."""
import subprocess
import sys
import textwrap
import threading
import time

import numpy as np
import pytest

import minv
from conftest import ScipyCholesky


def _slow_solver(min_seconds=0.2):
    """A configured `naive` solver (unblocked, one thread) whose inverse() takes at least
    min_seconds here (the tree grows until it does), an output array and that time."""
    n = 300
    while True:
        model = minv.random_tree("serial", n, seed=1)
        solver = minv.make_solver("naive")
        solver.prepare(model)
        solver.configure(minv.random_configuration(model, 1))
        X = np.empty((n, n), order="F")
        t0 = time.perf_counter()
        solver.inverse(out=X)
        seconds = time.perf_counter() - t0
        if seconds >= min_seconds or n >= 4000:
            return solver, X, seconds
        n = min(4000, int(n * max(1.25, 1.1 * (min_seconds / seconds) ** (1 / 3))))


def test_main_thread_runs_during_inverse():
    """While a thread is inside one inverse() call, the main thread keeps running Python code.

    Were the GIL held through the call, the main thread's time stamps would have a gap as long
    as the call: the window from just before to just after it is the call plus at most a few
    switch intervals (5 ms) in which the main thread ran around it."""
    solver, X, seconds = _slow_solver()
    window = {}

    def work():
        window["start"] = time.perf_counter()
        solver.inverse(out=X)
        window["end"] = time.perf_counter()

    stamps = []
    thread = threading.Thread(target=work)
    thread.start()
    while thread.is_alive():
        stamps.append(time.perf_counter())
    thread.join()
    start, end = window["start"], window["end"]
    inside = [start] + [t for t in stamps if start < t < end] + [end]
    largest_gap = max(b - a for a, b in zip(inside, inside[1:]))
    assert end - start >= 0.1, "the call is too short to tell"
    assert largest_gap < 0.5 * (end - start), (largest_gap, end - start)


def test_two_threads_invert_concurrently():
    """Two threads, each with its own solver, and two threads sharing one: all finish and agree."""
    model = minv.random_tree("branched", 400, seed=2)
    q = minv.random_configuration(model, 3)
    reference = np.linalg.inv(minv.mass_matrix(model, q))
    solvers = []
    for name in ("abi", "lapack"):
        s = minv.make_solver(name)
        s.prepare(model)
        s.configure(q)
        solvers.append(s)
    shared = solvers[0]
    results, errors = [], []

    def run(solver):
        try:
            for _ in range(5):
                results.append(solver.inverse())
        except Exception as e:  # pragma: no cover - reported below
            errors.append(e)

    threads = [threading.Thread(target=run, args=(s,)) for s in solvers + [shared]]
    for t in threads:
        t.start()
    for t in threads:
        t.join(timeout=120)
    assert not any(t.is_alive() for t in threads), "deadlock"
    assert not errors and len(results) == 15
    for X in results:
        np.testing.assert_allclose(X, reference, rtol=1e-6, atol=1e-8 * np.abs(reference).max())


def test_python_solver_from_threads_of_python():
    """A registered Python solver used from several Python threads at once (each call
    releases the GIL in C++ and re-acquires it for the Python methods)."""
    model = minv.random_tree("serial", 30, seed=5)
    q = minv.random_configuration(model, 1)
    with minv.registered(ScipyCholesky, name="py-gil-test"):
        handles = []
        for _ in range(3):
            h = minv.make_solver("py-gil-test")
            h.prepare(model)
            h.configure(q)
            handles.append(h)
        out = []
        threads = [threading.Thread(target=lambda h=h: out.extend(h.inverse() for _ in range(20)))
                   for h in handles]
        for t in threads:
            t.start()
        for t in threads:
            t.join(timeout=60)
        assert not any(t.is_alive() for t in threads), "deadlock"
    assert len(out) == 60
    M = minv.mass_matrix(model, q)
    assert max(np.abs(M @ X - np.eye(30)).max() for X in out) < 1e-8


def test_check_runs_beside_other_threads():
    """minv.check releases the GIL: another Python thread keeps running meanwhile."""
    ticks = []
    done = threading.Event()

    def ticker():
        while not done.is_set():
            ticks.append(time.perf_counter())
            time.sleep(0.001)

    t = threading.Thread(target=ticker)
    t.start()
    try:
        assert minv.check("lapack", max_n=100).passed
    finally:
        done.set()
        t.join()
    assert len(ticks) > 10


def test_result_files_read_and_written_beside_h5py_threads(tmp_path):
    """read_points and a resumed compare (each reads its file in a forked child first) beside
    threads that walk the same file with h5py, whose visititems callback takes the GIL back
    inside HDF5. The fork waits for HDF5's lock, so the child does not inherit it held by a
    thread it does not have (it waited 10 s, and the file was reported damaged, in nearly every
    resumed compare); and minv waits for that lock without the GIL (read_points and compare's
    annotation held it, and deadlocked). Run in a subprocess with a time limit."""
    pytest.importorskip("h5py")
    script = textwrap.dedent(f"""
        import threading, time
        import h5py
        import minv
        from minv.reference import ScipyCholesky

        out = {str(tmp_path / "c.h5")!r}
        args = dict(sizes=(4,), topologies=("serial",), against=("abi",), out=out,
                    repetitions=1, min_time=0.001)
        minv.compare(ScipyCholesky, **args)
        stop = threading.Event()

        def walk():
            while not stop.is_set():
                try:
                    with h5py.File(out, "r") as f:
                        f.visititems(lambda name, obj: time.sleep(0.0005))
                except OSError:
                    pass  # (the file is being replaced)

        threads = [threading.Thread(target=walk) for _ in range(2)]
        for t in threads:
            t.start()
        try:
            for _ in range(4):
                minv.compare(ScipyCholesky, resume=True, **args)
                minv.read_points(out)
        finally:
            stop.set()
            for t in threads:
                t.join()
        print("done")
    """)
    run = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True,
                         timeout=120)
    assert run.returncode == 0 and "done" in run.stdout, run.stderr[-3000:]


def test_children_forked_during_a_compare_leave_its_files_alone(tmp_path):
    """Processes forked while a compare writes (multiprocessing's fork, say) leave its files
    alone: one that gets SIGTERM does not remove the writer's working copy (the signal handler
    did, in 2 of 3 runs), and one that outlives the compare does not stop the next compare of
    that file (the lock it inherited is on the working copy that the writer removed)."""
    import os
    import signal

    class SlowPrepare(ScipyCholesky):
        def prepare(self, model):
            time.sleep(0.5)
            super().prepare(model)

    out = tmp_path / "c.h5"
    working = str(out) + ".append.tmp"
    args = dict(topologies=("serial",), against=("abi",), out=out, repetitions=1,
                min_time=0.001)
    minv.compare(ScipyCholesky, sizes=(4,), **args)
    failures = []

    def slow_compare():
        try:
            minv.compare(SlowPrepare, sizes=(4, 8, 16), resume=True, **args)
        except Exception as e:  # (reported by the assertion below)
            failures.append(e)

    thread = threading.Thread(target=slow_compare)
    thread.start()
    children = []
    try:
        deadline = time.time() + 30
        while not os.path.exists(working) and time.time() < deadline:
            time.sleep(0.01)
        assert os.path.exists(working)
        for _ in range(2):
            pid = os.fork()
            if pid == 0:
                time.sleep(20)
                os._exit(0)
            children.append(pid)
        os.kill(children[0], signal.SIGTERM)
        os.waitpid(children[0], 0)
        assert thread.is_alive() and os.path.exists(working), os.listdir(tmp_path)
        thread.join()
        assert not failures, failures
        minv.compare(ScipyCholesky, sizes=(32,), resume=True, **args)
        assert set(minv.read_points(out)) >= {
            f"pipeline.{s}.serial.fixed.n{n:05d}.m0.t1" for s in ("abi", "scipycholesky")
            for n in (4, 32)}
    finally:
        for pid in children[1:]:
            os.kill(pid, signal.SIGKILL)
            os.waitpid(pid, 0)
        thread.join()


def test_processes_forked_beside_read_points_do_not_inherit_hdf5_held(tmp_path):
    """A thread loops read_points (inside HDF5 without the GIL) while the main thread forks
    processes that open the file with h5py: a fork waits for the call to leave HDF5, so no
    child inherits HDF5's lock held by a thread it does not have (13 of 40 children hung at
    their first HDF5 call, and were stopped by an alarm, before the fork waited)."""
    pytest.importorskip("h5py")
    out = tmp_path / "c.h5"
    minv.compare(ScipyCholesky, sizes=(4,), topologies=("serial",), against=("abi",), out=out,
                 repetitions=1, min_time=0.001)
    script = textwrap.dedent(f"""
        import os, signal, threading, time
        import h5py
        import minv

        path = {str(out)!r}
        stop = threading.Event()

        def loop():
            while not stop.is_set():
                minv.read_points(path)

        thread = threading.Thread(target=loop)
        thread.start()
        hung = 0
        try:
            for _ in range(40):
                time.sleep(0.005)
                pid = os.fork()
                if pid == 0:
                    signal.alarm(3)
                    with h5py.File(path, "r") as f:
                        f.attrs.keys()
                    os._exit(0)
                _, status = os.waitpid(pid, 0)
                hung += os.WIFSIGNALED(status)
        finally:
            stop.set()
            thread.join()
        print("hung", hung)
    """)
    run = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True,
                         timeout=300)
    assert run.returncode == 0, run.stderr[-3000:]
    assert run.stdout.split() == ["hung", "0"], run.stdout
