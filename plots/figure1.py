"""Figure 1: multiplications vs n, measured counts (points) against the paper's formulas
(lines), for Cholesky only, CRBA + Cholesky, the Θ(n²) method and the Θ(n²) method per
processor. Reads results/flops.h5 (serial chains, fixed base)."""
import h5py
import matplotlib.pyplot as plt
import numpy as np

from common import result_path, save

FRONT = ["spatial axes", "isolated inertias", "composite inertias", "Ic s vectors",
         "elements of M"]


def mults(g, stages):
    """Multiplications and divisions (the paper's 'multiplications') summed over stages."""
    return sum(g[s]["mul"][()] + g[s]["div"][()] for s in stages)


def main():
    with h5py.File(result_path("flops.h5"), "r") as f:
        g = f["serial_fixed"]
        n = g["nv"][()].astype(float)
        measured = {
            "Cholesky only (naive)": mults(g["naive"], ["factorization"]),
            "CRBA + Cholesky (naive)": mults(g["naive"], FRONT + ["factorization"]),
            "Θ(n²) method (abi)": mults(g["abi"], ["total"]),
            "Θ(n²) per processor (abi, n processors)": mults(g["abi_parallel"], ["total"]),
        }
    x = np.geomspace(n.min(), n.max(), 200)
    paper = {
        "Cholesky only (naive)": x**3 / 2 + x**2 / 2 + x,
        "CRBA + Cholesky (naive)": x**3 / 2 + 7 * x**2 / 2 + 145 * x,
        "Θ(n²) method (abi)": 45 * x**2 / 2 + 216 * x,
        "Θ(n²) per processor (abi, n processors)": 261 * x / 2 + 108,
    }
    colors = ["tab:blue", "tab:green", "tab:red", "black"]
    fig, ax = plt.subplots(figsize=(6.4, 4.6))
    for (label, y), c in zip(measured.items(), colors):
        ax.plot(n, y, "o", color=c, label=f"{label}, measured")
        ax.plot(x, paper[label], "-", color=c, alpha=0.6, label="  paper's formula")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("n (joints, serial chain, fixed base)")
    ax.set_ylabel("multiplications + divisions")
    ax.set_title("Figure 1: operation counts, measured vs the paper")
    ax.legend(fontsize=7)
    ax.grid(True, which="both", alpha=0.3)
    save(fig, "figure1_flops")


if __name__ == "__main__":
    main()
