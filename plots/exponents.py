"""Fitted scaling exponents: the slope of log(time) on log(n) for n ≥ 128 of every measured
curve of the pipeline family, as a bar chart, against the paper's 2 (abi) and 3 (Cholesky).
Reads results/timing.h5."""
import matplotlib.pyplot as plt

from analysis import EXPONENT_MIN_N, STYLE, exponents, load_timing
from common import save


def main():
    _, points = load_timing()
    fits = exponents(points, "pipeline")
    labels, values, colors = [], [], []
    for (s, topo, base), (e, lo, hi) in sorted(
            fits.items(), key=lambda kv: (list(STYLE).index(kv[0][0]) if kv[0][0] in STYLE else 99, kv[0])):
        labels.append(f"{s} {topo} {base} (n {lo}–{hi})")
        values.append(e)
        colors.append(STYLE.get(s, ("black",))[0])
    fig, ax = plt.subplots(figsize=(7, 0.28 * len(labels) + 1.5))
    ax.barh(range(len(labels)), values, color=colors)
    ax.set_yticks(range(len(labels)))
    ax.set_yticklabels(labels, fontsize=7)
    ax.invert_yaxis()
    for x in (2, 3):
        ax.axvline(x, color="k", ls=":", lw=1)
    for i, v in enumerate(values):
        ax.text(v + 0.02, i, f"{v:.2f}", va="center", fontsize=7)
    ax.set_xlabel(f"fitted exponent of time q → M⁻¹ (log-log slope, n ≥ {EXPONENT_MIN_N})")
    ax.set_title("Scaling exponents (paper: 2 for the Θ(n²) method, 3 for Cholesky)")
    save(fig, "exponents")


if __name__ == "__main__":
    main()
