"""minv: the joint-space inertia matrix M of articulated rigid-body trees and its inverse.

The C++ library through pybind11 (the extension ``minv._minv``) plus a harness for solvers
written in Python.

Models
    ``load_model(path, floating_base=False)``, ``save_model(model, path)``,
    ``random_tree(topology, n, seed=1, floating_base=False, joints="revolute")``,
    ``centipede(segments, segment_joint="yaw")``; a :class:`Model` has ``nb``, ``nq``, ``nv``,
    ``parents``, ``dof_parent``, ``dof_names``, ``q_names``, ``body_names``, ``joint_types``,
    ``floating_base``, ``max_depth``, ``neutral()`` and ``check_configuration(q)``.
Configurations and M
    ``random_configuration(model, seed)``, ``read_configuration(model, path)``,
    ``mass_matrix(model, q)`` (CRBA, an (nv, nv) array).
Solvers
    ``solvers()`` lists the registry as ``(name, summary)`` tuples; ``make_solver(name)``
    gives a :class:`Solver` (``prepare``, ``configure``, ``inverse(out=None, *,
    upper=False)``, ``solve(R, out=None)``, ``set_threads``, ``threads``, ``supports``);
    ``flops(name, model, q, m=0)`` counts operations per stage.
Your own solver, in Python
    Any object with ``prepare(model)``, ``configure(q)``, ``inverse()`` and ``solve(R)``:
    ``check(solver)`` runs the C++ conformance suite on it, ``compare(solver)`` times it
    against registered solvers with the harness (Google Benchmark, HDF5 with provenance),
    ``register_solver(name, solver)`` adds it to the registry.
Errors
    C++ exceptions keep their message: :class:`ModelError` (a ValueError) for a bad model,
    file or configuration; ValueError for a bad argument; RuntimeError for the rest.
"""

import atexit
import contextlib
import math
import numbers
import os
import re
import sys

import numpy

from . import _minv
from ._minv import (
    ConformanceCheck,
    ConformanceReport,
    Model,
    ModelError,
    Solver,
    centipede,
    counted_solvers,
    flops,
    load_model,
    make_solver,
    mass_matrix,
    random_configuration,
    random_tree,
    read_configuration,
    save_model,
    solvers,
)

__all__ = [
    "Comparison", "ConformanceCheck", "ConformanceReport", "Model", "ModelError", "Solver",
    "centipede", "check", "compare", "counted_solvers", "flops", "load_model", "make_solver",
    "mass_matrix", "random_configuration", "random_tree", "read_configuration", "read_points",
    "register_solver", "registered", "save_model", "solver_names", "solvers",
    "unregister_solver",
]

_METHODS = ("prepare", "configure", "inverse", "solve")

# Solvers registered from Python hold Python objects: drop them before the interpreter goes.
atexit.register(_minv._unregister_python)


def solver_names():
    """The names of the registered solvers, in registry order."""
    return [name for name, _ in solvers()]


def _factory(solver):
    """(label, zero-argument factory) for a solver class, factory or instance.

    A class or a factory makes a new instance per use (each conformance case, each timing
    point); an instance (an object with prepare, configure, inverse and solve) is reused.
    """
    if isinstance(solver, type):
        missing = [f"{m}()" for m in _METHODS if not callable(getattr(solver, m, None))]
        if missing:
            raise TypeError(f"solver class {solver.__name__} lacks {', '.join(missing)}; a "
                            f"Python solver needs prepare(model), configure(q), inverse() and "
                            f"solve(R)")
        return solver.__name__, solver
    if all(callable(getattr(solver, m, None)) for m in _METHODS):
        return type(solver).__name__, lambda: solver
    if callable(solver):
        return getattr(solver, "__name__", type(solver).__name__), solver
    raise TypeError(
        f"expected a solver class, a zero-argument factory or a solver instance with "
        f"prepare(model), configure(q), inverse() and solve(R); got a {type(solver).__name__}")


def check(solver, max_n=300, *, urdf=True, two_threads=True, reconfigure=True):
    """Runs minv's conformance checks (solvers/conformance.hpp) on a solver.

    ``solver`` is a Python solver class (a new instance per case), a zero-argument factory,
    an instance (reused), or the name of a registered solver. The checks and bounds are those
    of the C++ suite: random serial and branched trees, fixed and floating base, revolute and
    mixed joints, n in {1, 2, 3, 7, 32, 100, 300} up to ``max_n``, URDF round trips
    (``urdf``), a second configuration (``reconfigure``) and ``set_threads(2)``
    (``two_threads``). Returns a :class:`ConformanceReport`: ``passed``, ``checks``,
    ``skipped``, ``errors``, ``worst``; ``print(report)`` gives the summary. An exception in
    the solver is recorded in ``errors`` for its case (KeyboardInterrupt stops the run).
    """
    if isinstance(solver, str):
        return _minv._check_registered(solver, max_n, urdf, two_threads, reconfigure)
    label, factory = _factory(solver)
    return _minv._check(label, factory, max_n, urdf, two_threads, reconfigure)


def _default_name(label):
    """A valid registry name derived from a class name, not clashing with a registered one."""
    name = re.sub(r"[^a-z0-9_-]+", "-", label.lower()).strip("-_")[:32] or "python"
    if _minv._solver_name_problem(name) or name in solver_names():
        name = ("py-" + name)[:32]
    return name


def register_solver(name, solver, summary=None):
    """Adds a Python solver to the registry under ``name``.

    From then on ``make_solver(name)``, ``check(name)`` and the timing sweeps see it like a
    C++ solver (calls into it acquire the GIL). ``solver`` is a class, a factory or an
    instance (see :func:`check`). ValueError for an invalid or taken name.
    """
    label, factory = _factory(solver)
    _minv._register(name, summary or f"Python solver {label}", factory)


def unregister_solver(name):
    """Removes a solver added by :func:`register_solver`; False if there was none."""
    return _minv._unregister(name)


@contextlib.contextmanager
def registered(solver, name=None, summary=None):
    """``with minv.registered(MySolver) as name:`` registers for the block only."""
    label, _ = _factory(solver)
    name = name or _default_name(label)
    register_solver(name, solver, summary)
    try:
        yield name
    finally:
        unregister_solver(name)


# Integer and real attributes of a timing point (the rest are text).
_INT_ATTRS = {"n", "nv", "nb", "max_depth", "m", "threads", "solver_threads", "seed",
              "repetitions", "blas_threads", "omp_max_threads"}
_REAL_ATTRS = {"min_time_s"}


def read_points(path):
    """The points of a timing result file, read by the harness's reader (readPoints).

    Returns ``{point name: {"attrs": {...}, "real_time_s": array, "parent": array}}``: the
    attributes (family, solver, topology, base, n, status, skipped, …; numbers as numbers),
    the raw repetitions in seconds per iteration, and the tree's body parent array.
    """
    points = _minv._read_points(os.fspath(path))
    for point in points.values():
        attrs = point["attrs"]
        for key in _INT_ATTRS & attrs.keys():
            attrs[key] = int(attrs[key])
        for key in _REAL_ATTRS & attrs.keys():
            attrs[key] = float(attrs[key])
    return points


class Comparison:
    """The outcome of :func:`compare`.

    ``path``: the HDF5 file; ``solver``: the registered name the Python solver was timed
    under; ``times``: ``{solver: {topology: {n: median seconds}}}`` for q → M⁻¹
    (configure + inverse); ``skipped``: ``{point name: reason}``; ``stats``: points measured,
    skipped, and resumed from an earlier run. ``str()`` gives a table; ``plot()`` a figure.
    """

    def __init__(self, path, solver, solvers, topologies, sizes, stats):
        self.path = path
        self.solver = solver
        self.stats = stats
        self.times = {s: {t: {} for t in topologies} for s in solvers}
        self.skipped = {}
        for name, point in read_points(path).items():
            a = point["attrs"]
            ours = (a.get("family") == "pipeline" and a.get("solver") in self.times
                    and a.get("topology") in topologies and a.get("base") == "fixed"
                    and a.get("n") in sizes and a.get("m") == 0 and a.get("threads") == 1)
            if not ours:
                continue
            if a.get("status") == "ok":
                self.times[a["solver"]][a["topology"]][a["n"]] = float(
                    numpy.median(point["real_time_s"]))
            else:
                self.skipped[name] = a.get("skipped", "")

    def __str__(self):
        lines = [f"q -> M^-1 (configure + inverse), median seconds; {self.path}"]
        width = max([10] + [len(s) for s in self.times])
        for topology in next(iter(self.times.values()), {}):
            sizes = sorted({n for s in self.times.values() for n in s[topology]})
            lines.append(f"{topology:>{width}} " + "".join(f"{f'n={n}':>11}" for n in sizes))
            for solver, by_topology in self.times.items():
                row = by_topology[topology]
                cells = "".join(f"{row[n]:11.3e}" if n in row else f"{'-':>11}" for n in sizes)
                lines.append(f"{solver:>{width}} {cells}")
        for name, reason in self.skipped.items():
            lines.append(f"skipped {name}: {reason}")
        return "\n".join(lines)

    def __repr__(self):
        return f"<minv.Comparison of {self.solver}: {self.path}>"

    def plot(self, out=None):
        """Time vs n, one panel per topology (minv.plot.plot_comparison); returns the figure."""
        from .plot import plot_comparison
        return plot_comparison(self.path, out=out)


# The largest n compare() takes (as `minv flops --n`): each point holds dense n × n matrices.
_MAX_COMPARE_N = 16384


def compare(solver, sizes=(8, 16, 32, 64), topologies=("serial", "branched"),
            against=("abi", "lapack"), out="results/compare.h5", name=None, repetitions=5,
            min_time=0.01, *, summary=None, resume=False, mode="quick", verbose=False):
    """Times a Python solver against registered ones with the harness's timing sweep.

    The solver (a class, a factory or an instance; see :func:`check`) is registered for the
    duration of the call under ``name`` (default: its class name, lower-cased, prefixed with
    "py-" if that is taken) and unregistered afterwards, also on error. The sweep is one
    "pipeline" block (experiments/lib/timing.hpp): for each topology and n in ``sizes``, a
    random fixed-base tree (seed 1), its random q, and configure(q) + inverse() timed with
    Google Benchmark (``repetitions`` repetitions of at least ``min_time`` seconds each), one
    thread, with the harness's skip rules for ``mode`` ("quick" by default). The GIL is
    released during the sweep; the Python solver's methods re-acquire it, so their time
    includes the Python call overhead.

    The result file ``out`` (its folder is created) is the harness's timing format, with
    provenance and the attributes compare_solver, compare_against, python_version and
    numpy_version at its root: readable by ``read_points``, by ``minv time``'s tools and by
    plots/ (``plots/compare.py FILE`` draws it). Unless ``resume`` is true an existing ``out``,
    which must be a timing sweep (another file there is an error), is replaced (only once the
    new sweep has finished); with ``resume=True`` the points already in it are kept and not
    measured again. ``verbose`` prints one line per point.

    Returns a :class:`Comparison` (``times[solver][topology][n]``: median seconds).
    """
    label, factory = _factory(solver)
    name = name or _default_name(label)
    summary = summary or f"Python solver {label} (minv.compare)"
    if isinstance(sizes, int):
        sizes = (sizes,)
    if isinstance(topologies, str):
        topologies = (topologies,)
    if isinstance(against, str):
        against = (against,)
    sizes, topologies, against = list(sizes), list(topologies), list(against)
    # Arguments the sweep would refuse, refused before anything is created.
    if not sizes or any(isinstance(n, bool) or not isinstance(n, numbers.Integral) or n < 1
                        or n > _MAX_COMPARE_N for n in sizes):
        raise ValueError(f"sizes must be positive integers up to {_MAX_COMPARE_N} (each point "
                         f"holds dense n × n matrices), got {sizes!r}")
    if int(repetitions) < 1 or not (math.isfinite(float(min_time)) and float(min_time) > 0):
        raise ValueError(f"repetitions must be at least 1 and min_time a positive number of "
                         f"seconds, got {repetitions!r} and {min_time!r}")
    path = os.fspath(out)
    if not os.path.basename(path) or os.path.isdir(path):
        raise IsADirectoryError(f"out must name a file, and {path!r} is a directory")
    # (the sweep's file is renamed over out: a FIFO or a device such as /dev/null would go)
    _minv._require_output_file(path)
    # What replacing may destroy: only an earlier timing sweep (a solve result, a model or
    # another file named by mistake stays, as the command line's sweeps keep them)
    if not resume and os.path.exists(path):
        try:
            read_points(path)
        except (RuntimeError, ValueError) as e:
            raise ValueError(f"out {path!r} exists and is not a timing sweep, the only file "
                             f"compare replaces: remove it or name another out ({e})") from None
    # The folders this call creates (deepest first), removed again if still empty when it fails;
    # the nearest existing one must be a folder.
    folder = os.path.dirname(os.path.abspath(path))
    created = []
    while not os.path.exists(folder):
        created.append(folder)
        folder = os.path.dirname(folder)
    if not os.path.isdir(folder):
        raise NotADirectoryError(f"out {path!r}: {folder!r} is a file, not a directory")
    os.makedirs(os.path.dirname(os.path.abspath(path)), exist_ok=True)
    work = path if resume else path + ".compare-tmp"
    if work != path and os.path.exists(work):
        # (an earlier compare's, killed: an HDF5 file; a user's other file there stays)
        _minv._require_replaceable_hdf5(work, f"the tmp file of {path!r},")
        os.remove(work)
    log = (lambda line: print(line, end="", flush=True)) if verbose else None
    try:
        stats = _minv._compare(name, label, summary, factory, sizes, topologies, against, work,
                               int(repetitions), float(min_time), mode, log)
        _minv._annotate(work, {
            "compare_solver": name, "compare_label": label, "compare_summary": summary,
            "compare_against": ",".join(against), "python_version": sys.version.split()[0],
            "numpy_version": numpy.__version__})
        if work != path:
            os.replace(work, path)
    except BaseException:
        if work != path and os.path.exists(work):
            os.remove(work)
        for made in created:  # deepest first
            if os.path.isdir(made) and not os.listdir(made):
                os.rmdir(made)
        raise
    return Comparison(path, name, against + [name], topologies, sizes, stats)
