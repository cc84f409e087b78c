"""A timing file of any origin (minv.compare in Python, `minv time`) drawn like Figure 2: time
from q to M⁻¹ vs n (log-log), the `pipeline` family, one panel per topology for a fixed and,
when present, a floating base; every solver in the file is a curve (band = min–max).

    /usr/bin/python3 plots/compare.py results/compare.h5 [--out FILE.png]

Without --out the figure goes to paper/figures/compare_<file name>.png and .pdf. Reads the file
with the same reader as figure2.py (analysis.load_timing)."""
import argparse
import os

import matplotlib.pyplot as plt

from analysis import load_timing
from common import save
from figure2 import curves


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("file", help="timing result file (HDF5)")
    parser.add_argument("--out", help="output image (any matplotlib format)")
    args = parser.parse_args()
    try:
        root, points = load_timing(os.path.abspath(args.file))
        pipeline = [p for p in points if p["family"] == "pipeline"]
    except (OSError, KeyError) as e:
        raise SystemExit(f"plots: {args.file} is not a timing file (of minv time or "
                         f"minv.compare): {e}") from None
    if not pipeline:
        raise SystemExit(f"plots: {args.file} has no pipeline points")
    topologies = sorted({p["topology"] for p in pipeline})
    bases = [b for b in ("fixed", "floating") if any(p["base"] == b for p in pipeline)]
    fig, axes = plt.subplots(len(bases), len(topologies), squeeze=False,
                             figsize=(5 * len(topologies), 4 * len(bases)))
    for i, base in enumerate(bases):
        for j, topology in enumerate(topologies):
            ax = axes[i][j]
            curves(ax, points, "pipeline", topology, base)
            ax.set_title(f"{topology} tree, {base} base")
            ax.set_xlabel("n (links)")
            if j == 0:
                ax.set_ylabel("time q → M⁻¹ (s, median; band = min–max)")
    axes[0][0].legend(fontsize=8)
    fig.suptitle(f"{os.path.basename(args.file)} ({root.get('cpu_model', '?')}, 1 thread)")
    if args.out:
        fig.savefig(args.out, dpi=150, bbox_inches="tight")
        print(f"plots: wrote {args.out}")
    else:
        save(fig, "compare_" + os.path.splitext(os.path.basename(args.file))[0])


if __name__ == "__main__":
    main()
