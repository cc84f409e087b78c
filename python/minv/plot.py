"""Figures of timing result files (minv.compare, ``minv time``), without plots/.

``plot_comparison(path, out=None)`` draws time vs n (log-log), q → M⁻¹ (the "pipeline"
family, fixed base, one thread), one panel per topology, one curve per solver: the median of
the repetitions, with a band from the fastest to the slowest. Needs matplotlib (imported on
first use; without a display it draws with Agg). Reads the file with the
harness's reader (minv.read_points), so any timing file works, not only compare's.
"""

import numpy

from . import read_points


def _pyplot():
    # Without a display matplotlib falls back to Agg by itself; a chosen backend is kept.
    import matplotlib.pyplot as plt
    return plt


def series(points, solver, topology, family="pipeline", base="fixed", m=0, threads=1):
    """(n, median, min, max) arrays of one curve's measured points, sorted by n."""
    rows = sorted((p for p in points.values()
                   if p["attrs"].get("family") == family and p["attrs"].get("solver") == solver
                   and p["attrs"].get("topology") == topology and p["attrs"].get("base") == base
                   and p["attrs"].get("m") == m and p["attrs"].get("threads") == threads
                   and p["attrs"].get("status") == "ok"),
                  key=lambda p: p["attrs"]["n"])
    n = numpy.array([p["attrs"]["n"] for p in rows], dtype=float)
    med = numpy.array([numpy.median(p["real_time_s"]) for p in rows])
    lo = numpy.array([numpy.min(p["real_time_s"]) for p in rows])
    hi = numpy.array([numpy.max(p["real_time_s"]) for p in rows])
    return n, med, lo, hi


def plot_comparison(path, out=None, family="pipeline", base="fixed"):
    """Draws a timing file; saves it to ``out`` (any matplotlib format) if given.

    Returns the matplotlib figure.
    """
    plt = _pyplot()
    points = read_points(path)
    chosen = [p["attrs"] for p in points.values()
              if p["attrs"].get("family") == family and p["attrs"].get("base") == base]
    topologies = sorted({a["topology"] for a in chosen})
    solvers = list(dict.fromkeys(a["solver"] for a in chosen))
    fig, axes = plt.subplots(1, max(len(topologies), 1), figsize=(5 * max(len(topologies), 1), 4),
                             squeeze=False)
    for ax, topology in zip(axes[0], topologies):
        for solver in solvers:
            n, med, lo, hi = series(points, solver, topology, family, base)
            if len(n) == 0:
                continue
            line, = ax.plot(n, med, marker="o", ms=3.5, label=solver)
            ax.fill_between(n, lo, hi, color=line.get_color(), alpha=0.15, lw=0)
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.grid(True, which="both", alpha=0.3)
        ax.set_title(f"{topology} tree, {base} base")
        ax.set_xlabel("n (links)")
    axes[0][0].set_ylabel("time q → M⁻¹ (s, median; band = min–max)")
    axes[0][0].legend(fontsize=8)
    fig.suptitle(str(path))
    if out is not None:
        fig.savefig(out, dpi=150, bbox_inches="tight")
    return fig
