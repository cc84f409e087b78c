"""Reading the timing and accuracy result files and the numbers the figures and the report
share: medians of the raw repetitions, crossover n, fitted scaling exponents, thread speed-ups.
Reads only results/ (through common.result_path)."""
import math

import h5py
import numpy as np

from common import result_path

# The paper's four methods of Figure 2 and how our registry names them.
PAPER_METHODS = {"abi": "Θ(n²) method (abi)", "lapack": "CRBA + LAPACK Cholesky (lapack)",
                 "ltl": "CRBA + BIS Cholesky (ltl)"}
STYLE = {  # colour, line width, marker
    "abi": ("tab:red", 2.2, "o"), "lapack": ("tab:blue", 2.2, "s"), "ltl": ("tab:green", 2.0, "^"),
    "ltdl": ("tab:olive", 1.0, "v"), "naive": ("tab:gray", 1.0, "x"),
    "eigen": ("tab:purple", 1.0, "d"), "mujoco": ("tab:orange", 1.0, "P"),
    "abi-generic": ("salmon", 1.4, "o"), "dart": ("tab:brown", 1.4, "D"),
    "bullet": ("tab:cyan", 1.4, "*"),
}
PAPER_CROSSOVER = 130
PAPER_SPEEDUP = {2: 1.34, 4: 2.17}
EXPONENT_MIN_N = 128


def text(v):
    return v.decode() if isinstance(v, bytes) else v


def load_points(name):
    """(file attributes, every finished point: its attributes, 'name', and for a timed point
    'real' (raw repetitions, s) and 'median') of a sweep file in results/."""
    out = []
    with h5py.File(result_path(name), "r") as f:
        root = {k: text(v) for k, v in f.attrs.items()}
        for pname, g in f["points"].items():
            if pname.endswith(".partial"):
                continue
            rec = {k: text(v) for k, v in g.attrs.items()}
            rec["name"] = pname
            if "real_time_s" in g:
                rec["real"] = g["real_time_s"][()]
                rec["median"] = float(np.median(rec["real"]))
            out.append(rec)
    return root, out


def load_timing(name="timing.h5"):
    return load_points(name)


def series(points, family, solver, topology="serial", base="fixed", m=0, threads=1):
    """(n, median seconds, min, max) of the measured points of one curve, sorted by n."""
    rows = [p for p in points if p["family"] == family and p["solver"] == solver
            and p["topology"] == topology and p["base"] == base and int(p["m"]) == m
            and int(p["threads"]) == threads and p.get("status") == "ok"]
    rows.sort(key=lambda p: int(p["n"]))
    n = np.array([int(p["n"]) for p in rows], dtype=float)
    med = np.array([p["median"] for p in rows])
    lo = np.array([float(np.min(p["real"])) for p in rows])
    hi = np.array([float(np.max(p["real"])) for p in rows])
    return n, med, lo, hi


def skipped(points, family=None):
    """{(solver, reason)} of the skipped points."""
    return sorted({(p["solver"], p["skipped"]) for p in points
                   if p.get("status") == "skipped" and (family is None or p["family"] == family)})


def crossover(points, a="abi", b="lapack", topology="serial", base="fixed", family="pipeline"):
    """The n above which a stays faster than b (log-log interpolation between grid points);
    (value, note). None if a never or always wins on the measured range."""
    na, ta, _, _ = series(points, family, a, topology, base)
    nb, tb, _, _ = series(points, family, b, topology, base)
    common = sorted(set(na) & set(nb))
    if len(common) < 2:
        return None, "not enough common points"
    ra = dict(zip(na, ta))
    rb = dict(zip(nb, tb))
    ratio = np.array([math.log(ra[n] / rb[n]) for n in common])  # < 0: a faster
    n = np.array(common)
    if np.all(ratio < 0):
        return None, f"{a} is faster at every measured n (from n = {int(n[0])})"
    if np.all(ratio > 0):
        return None, f"{b} is faster at every measured n (to n = {int(n[-1])})"
    last_slow = int(np.max(np.nonzero(ratio >= 0)[0]))
    if last_slow == len(n) - 1:
        return None, f"{b} is faster at the largest n"
    x0, x1 = math.log(n[last_slow]), math.log(n[last_slow + 1])
    y0, y1 = ratio[last_slow], ratio[last_slow + 1]
    x = x0 + (x1 - x0) * y0 / (y0 - y1)
    return math.exp(x), f"between n = {int(n[last_slow])} and {int(n[last_slow + 1])}"


def exponent(n, t, nmin=EXPONENT_MIN_N):
    """Least-squares slope of log t on log n over n ≥ nmin (None with fewer than 3 points)."""
    sel = n >= nmin
    if sel.sum() < 3:
        return None
    return float(np.polyfit(np.log(n[sel]), np.log(t[sel]), 1)[0])


def exponents(points, family="pipeline", m=0):
    """{(solver, topology, base): (exponent, n range)} for every measured curve."""
    out = {}
    keys = sorted({(p["solver"], p["topology"], p["base"]) for p in points
                   if p["family"] == family and p.get("status") == "ok"})
    for solver, topo, base in keys:
        n, t, _, _ = series(points, family, solver, topo, base, m=m)
        e = exponent(n, t)
        if e is not None:
            sel = n >= EXPONENT_MIN_N
            out[(solver, topo, base)] = (e, int(n[sel].min()), int(n[sel].max()))
    return out


def speedups(points, solver, threads):
    """(n, t1/tk) for the `threads` family."""
    n1, t1, _, _ = series(points, "threads", solver, threads=1)
    nk, tk, _, _ = series(points, "threads", solver, threads=threads)
    d1 = dict(zip(n1, t1))
    n = np.array([x for x in nk if x in d1])
    s = np.array([d1[x] / t for x, t in zip(nk, tk) if x in d1])
    return n, s


def load_accuracy(name="accuracy.h5"):
    return load_points(name)


def accuracy_problems(name="accuracy.h5"):
    """The attributes of each tree of an accuracy sweep (cond₂(M), the reference's own error
    estimate and its difference from the Cholesky check), with 'name'."""
    out = []
    with h5py.File(result_path(name), "r") as f:
        for pname, g in f["problems"].items():
            rec = {k: text(v) for k, v in g.attrs.items()}
            rec["name"] = pname
            out.append(rec)
    return out
