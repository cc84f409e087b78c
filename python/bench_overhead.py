"""Overhead of calling minv from Python (a benchmark, not a test).

    PYTHONPATH=build/python /usr/bin/python3 python/bench_overhead.py [--runs 21]

For serial chains of n = 64 and n = 1024 links (fixed base), abi on one thread, it times
solver.inverse(out=X) called from a Python loop against the same call looped in C++
(Solver._time_inverse, into the same X): seconds per call over runs of many calls each
(about 0.1 s per run), the two alternating; the overhead is the median over these pairs of
runs of (python − c++), which a busy machine disturbs least. Targets: overhead ≤ 5 µs + 10 %
at n = 64 and ≤ 2 % at n = 1024. It also times
minv.check on a numpy/scipy Cholesky solver (target < 60 s). Exit status 1 if a target is
missed.
"""
import argparse
import os
import statistics
import sys
import time

# Run as a script, this file puts python/ first on sys.path, where minv/ is the source package
# without its extension: look for minv on PYTHONPATH instead.
_HERE = os.path.dirname(os.path.abspath(__file__))
sys.path = [p for p in sys.path if os.path.abspath(p or os.curdir) != _HERE]

import numpy as np  # noqa: E402

import minv  # noqa: E402
from minv.reference import ScipyCholesky  # noqa: E402


def python_loop(solver, X, repetitions, runs):
    """Seconds per solver.inverse(out=X) from Python: median over runs."""
    inverse = solver.inverse
    per_call = []
    for _ in range(runs):
        t0 = time.perf_counter()
        for _ in range(repetitions):
            inverse(out=X)
        per_call.append((time.perf_counter() - t0) / repetitions)
    return statistics.median(per_call)


def overhead(n, runs, budget_s=0.1):
    """Per call at n, both into the same Fortran-ordered X: (python s, c++ s) medians, and
    the median over interleaved pairs of runs of (python − c++) and of (python − c++) / c++."""
    model = minv.random_tree("serial", n, seed=1)
    solver = minv.make_solver("abi")
    solver.set_threads(1)
    solver.prepare(model)
    solver.configure(minv.random_configuration(model, 1))
    X = np.empty((model.nv, model.nv), order="F")
    once = solver._time_inverse(3, runs=1, out=X)
    repetitions = max(3, int(budget_s / once))
    # Interleave the two, pair by pair, so that other load on the machine hits both alike.
    py, cpp = [], []
    for _ in range(runs):
        cpp.append(solver._time_inverse(repetitions, runs=1, out=X))
        py.append(python_loop(solver, X, repetitions, 1))
    diff = statistics.median(p - c for p, c in zip(py, cpp))
    rel = statistics.median((p - c) / c for p, c in zip(py, cpp))
    return statistics.median(py), statistics.median(cpp), diff, rel


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=21, help="runs per measurement (median)")
    parser.add_argument("--skip-check", action="store_true", help="do not time minv.check")
    args = parser.parse_args()
    ok = True
    print("abi, serial chain, one thread: seconds per inverse(out=X), medians over runs")
    print(f"{'n':>6} {'python':>12} {'c++':>12} {'overhead':>12} {'relative':>9}  target")
    for n, target in ((64, lambda d, c: d <= 5e-6 + 0.10 * c), (1024, lambda d, c: d <= 0.02 * c)):
        py, cpp, diff, rel = overhead(n, args.runs)
        met = target(diff, cpp)
        ok &= met
        goal = "<= 5 us + 10 %" if n == 64 else "<= 2 %"
        print(f"{n:>6} {py:12.4e} {cpp:12.4e} {diff * 1e6:10.3f}us {100 * rel:8.2f}%  {goal}: "
              f"{'met' if met else 'MISSED'}")
    if not args.skip_check:
        t0 = time.perf_counter()
        report = minv.check(ScipyCholesky)
        elapsed = time.perf_counter() - t0
        met = elapsed < 60 and report.passed
        ok &= met
        print(report)
        print(f"minv.check(ScipyCholesky): {elapsed:.1f} s (target < 60 s): "
              f"{'met' if met else 'MISSED'}")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
