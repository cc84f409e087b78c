"""Accuracy vs n (a figure the paper does not have): for every solver on serial (solid) and
branched (dashed) trees, fixed base: relative residual ‖MX − I‖_F/(‖M‖_F‖X‖_F), the forward
error ‖X − X_ref‖_F/‖X_ref‖_F against a long-double reference (the impulse sweeps in long
double; dotted: the estimate of its own error), and cond₂(M). Reads results/accuracy.h5."""
import matplotlib.pyplot as plt
import numpy as np

from analysis import STYLE, accuracy_problems, load_accuracy
from common import save

EPS = np.finfo(float).eps


def main():
    root, points = load_accuracy()
    fig, axes = plt.subplots(1, 3, figsize=(15, 4.4))
    solvers = sorted({p["solver"] for p in points},
                     key=lambda s: list(STYLE).index(s) if s in STYLE else 99)
    for s in solvers:
        c, lw, mk = STYLE.get(s, ("black", 1.0, "."))
        for topo, ls in (("serial", "-"), ("branched", "--")):
            rows = sorted((p for p in points if p["solver"] == s and p["topology"] == topo
                           and p.get("status") == "ok"), key=lambda p: int(p["n"]))
            if not rows:
                continue
            n = [int(p["n"]) for p in rows]
            axes[0].plot(n, [p["residual"] for p in rows], ls, marker=mk, ms=3, color=c, lw=lw,
                         label=f"{s} ({topo})")
            axes[1].plot(n, [p["error"] for p in rows], ls, marker=mk, ms=3, color=c, lw=lw)
    for topo, ls in (("serial", "-"), ("branched", "--")):
        rows = {int(p["n"]): p["cond"] for p in points if p["topology"] == topo}
        n = sorted(rows)
        axes[2].plot(n, [rows[k] for k in n], ls, color="k", marker="o", ms=3, label=f"cond₂(M), {topo}")
        axes[1].plot(n, [EPS * rows[k] for k in n], ls, color="k", lw=0.8, alpha=0.6,
                     label=f"ε·cond₂(M), {topo}")
        # The reference's own error (an estimate); files before 2026-12-07 lack it.
        est = {int(g["n"]): g["reference_error_estimate"] for g in accuracy_problems()
               if g["topology"] == topo and "reference_error_estimate" in g}
        if est:
            ne = sorted(est)
            axes[1].plot(ne, [est[k] for k in ne], ":" if topo == "serial" else "-.", color="grey",
                         lw=1.0,
                         label=f"X_ref's own error (est.), {topo}")
    titles = ("relative residual ‖MX − I‖/(‖M‖‖X‖)", "error vs long-double reference", "cond₂(M)")
    for ax, t in zip(axes, titles):
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel("n (links), fixed base")
        ax.set_title(t)
        ax.grid(True, which="both", alpha=0.3)
    axes[0].legend(fontsize=6, ncol=2)
    axes[1].legend(fontsize=6)
    axes[2].legend(fontsize=7)
    fig.suptitle("Accuracy of M⁻¹ per solver (solid: serial; dashed: branched)")
    save(fig, "accuracy")


if __name__ == "__main__":
    main()
