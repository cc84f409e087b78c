"""Figure 3: threads. abi parallel over columns with OpenMP (solver->setThreads(t)), and lapack
with OpenBLAS threads, t = 1, 2, 4, serial chain, fixed base, the pipeline from q to M⁻¹:
speed-up t1/tk vs n, with the paper's +34 % (2 threads) and +117 % (4 threads).
Reads results/timing.h5."""
import matplotlib.pyplot as plt

from analysis import PAPER_SPEEDUP, STYLE, load_timing, series, speedups
from common import save


def main():
    root, points = load_timing()
    fig, (ax0, ax1) = plt.subplots(1, 2, figsize=(11, 4.4))
    for s in ("abi", "lapack"):
        c = STYLE[s][0]
        for t, ls in ((1, "-"), (2, "--"), (4, ":")):
            n, med, _, _ = series(points, "threads", s, threads=t)
            if len(n):
                ax0.plot(n, med, ls, marker="o", ms=3, color=c, label=f"{s}, {t} thread(s)")
        for t, ls in ((2, "--"), (4, ":")):
            n, sp = speedups(points, s, t)
            if len(n):
                ax1.plot(n, sp, ls, marker="o", ms=3, color=c, label=f"{s}, {t} vs 1")
    for t, v in PAPER_SPEEDUP.items():
        ax1.axhline(v, color="k", lw=0.8, ls="--" if t == 2 else ":")
        ax1.text(0.02, v * 1.02, f"paper, {t} threads: ×{v}", fontsize=7,
                 transform=ax1.get_yaxis_transform())
    ax1.axhline(1, color="gray", lw=0.6)
    for ax in (ax0, ax1):
        ax.set_xscale("log")
        ax.set_xlabel("n (links), serial, fixed base")
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=7)
    ax0.set_yscale("log")
    ax0.set_ylabel("time q → M⁻¹ (s, median)")
    ax1.set_ylabel("speed-up over 1 thread")
    cores = root.get("cpu_cores", "?")
    fig.suptitle(f"Figure 3: threads (abi: OpenMP over columns; lapack: OpenBLAS); "
                 f"machine: {cores} cores")
    save(fig, "figure3_threads")


if __name__ == "__main__":
    main()
