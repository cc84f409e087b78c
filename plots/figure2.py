"""Figure 2: time vs n (log-log), from a configuration q to M⁻¹ (the `pipeline` family): the
paper's methods (abi = the Θ(n²) method, lapack = CRBA + LAPACK Cholesky, ltl = CRBA + branch-
induced-sparsity Cholesky) and every other registered solver, serial and branched trees, fixed
and floating base. A second figure shows the `kernel` family: inverse()/solve(R) alone, after
configure(q) (so without the Cholesky factorization, or without abi's articulated inertias),
for m ∈ {M⁻¹, 1, 8, 64} right-hand sides. Reads results/timing.h5."""
import matplotlib.pyplot as plt

from analysis import PAPER_CROSSOVER, STYLE, load_timing, series
from common import save


def curves(ax, points, family, topology, base, m=0):
    solvers = sorted({p["solver"] for p in points if p["family"] == family},
                     key=lambda s: list(STYLE).index(s) if s in STYLE else 99)
    for s in solvers:
        n, t, lo, hi = series(points, family, s, topology, base, m=m)
        if len(n) == 0:
            continue
        c, lw, mk = STYLE.get(s, ("black", 1.0, "."))
        ax.plot(n, t, marker=mk, ms=3.5, lw=lw, color=c, label=s)
        ax.fill_between(n, lo, hi, color=c, alpha=0.15, lw=0)
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.grid(True, which="both", alpha=0.3)


def main():
    root, points = load_timing()
    fig, axes = plt.subplots(2, 2, figsize=(10, 8), sharex=True)
    for i, base in enumerate(("fixed", "floating")):
        for j, topo in enumerate(("serial", "branched")):
            ax = axes[i][j]
            curves(ax, points, "pipeline", topo, base)
            ax.axvline(PAPER_CROSSOVER, color="k", ls=":", lw=1)
            ax.set_title(f"{topo} tree, {base} base")
            if i == 1:
                ax.set_xlabel("n (links)")
            if j == 0:
                ax.set_ylabel("time q → M⁻¹ (s, median; band = min–max)")
    axes[0][0].legend(fontsize=8)
    axes[0][0].text(PAPER_CROSSOVER * 1.05, axes[0][0].get_ylim()[0] * 2, "paper's\ncrossover",
                    fontsize=7)
    fig.suptitle(f"Figure 2: time to M⁻¹ from q ({root.get('cpu_model', '?')}, 1 thread)")
    save(fig, "figure2_time")

    fig, axes = plt.subplots(1, 4, figsize=(15, 4), sharey=True)
    for ax, m in zip(axes, (0, 1, 8, 64)):
        curves(ax, points, "kernel", "serial", "fixed", m=m)
        ax.set_title("kernel M⁻¹ (inverse)" if m == 0 else f"kernel M⁻¹R, m = {m}")
        ax.set_xlabel("n (links), serial, fixed base")
    axes[0].set_ylabel("time after configure(q) (s)")
    axes[0].legend(fontsize=7)
    fig.suptitle("Kernels alone: inverse()/solve(R) after configure(q) "
                 "(no factorization / no articulated inertias)")
    save(fig, "figure2_kernel")


if __name__ == "__main__":
    main()
