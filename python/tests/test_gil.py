"""The GIL is released while a C++ solver works, and Python solvers called from C++ threads
re-acquire it without deadlocking."""
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


def test_resumed_compare_beside_a_thread_inside_hdf5(tmp_path):
    """A resumed compare (the GIL released) reads its file in a forked child first, while
    another thread reads result files with h5py: the fork waits for HDF5's lock, so the child
    does not inherit it held by a thread it does not have (it waited 10 s, and the file was
    reported damaged, in nearly every such run)."""
    h5py = pytest.importorskip("h5py")
    out = tmp_path / "c.h5"
    args = dict(sizes=(4,), topologies=("serial",), against=("abi",), out=out, repetitions=1,
                min_time=0.001)
    minv.compare(ScipyCholesky, **args)
    stop = threading.Event()
    reads = []

    def hammer():
        while not stop.is_set():
            with h5py.File(out, "r") as f:
                f.visit(lambda name: None)
            reads.append(1)

    thread = threading.Thread(target=hammer)
    thread.start()
    try:
        for _ in range(4):
            minv.compare(ScipyCholesky, resume=True, **args)
    finally:
        stop.set()
        thread.join()
    assert reads
