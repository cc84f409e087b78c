"""The centipede's walk (results/walk.h5, `minv simulate centipede --frames F --out …`):
paper/figures/walk_path.png/.pdf (the path of the centre of mass and of the head from above,
with the body drawn at a few instants) and paper/figures/walk.gif (the body from above and
from the side, animated)."""
import os

import h5py
import matplotlib.pyplot as plt
import numpy as np
from matplotlib.animation import FuncAnimation, PillowWriter

from common import FIGURES, result_path, save


def load():
    with h5py.File(result_path("walk.h5"), "r") as f:
        d = {k: f[k][()] for k in ("frame_time", "com", "segments", "hips", "knees", "tips")}
        d["attrs"] = dict(f.attrs)
    F = len(d["frame_time"])
    for k in ("segments", "hips", "knees", "tips"):
        d[k] = d[k].reshape(F, -1, 3)
    return d


def draw_body(ax, d, i, view, color="k", alpha=1.0):
    """view: (0, 1) from above, (0, 2) from the side."""
    a, b = view
    seg = d["segments"][i]
    ax.plot(seg[:, a], seg[:, b], "-", color=color, lw=2.5, alpha=alpha)
    for leg in range(d["hips"].shape[1]):
        s = seg[leg // 2]
        pts = np.array([s, d["hips"][i, leg], d["knees"][i, leg], d["tips"][i, leg]])
        ax.plot(pts[:, a], pts[:, b], "-", color=color, lw=0.8, alpha=alpha)


def main():
    d = load()
    t, com = d["frame_time"], d["com"]
    head = d["segments"][:, 0, :]
    at = d["attrs"]
    fig, ax = plt.subplots(figsize=(8, 4))
    for i in np.linspace(0, len(t) - 1, 4).astype(int):
        draw_body(ax, d, i, (0, 1), color="tab:gray", alpha=0.5)
    ax.plot(com[:, 0], com[:, 1], "-", color="tab:red", label="centre of mass")
    ax.plot(head[:, 0], head[:, 1], "-", color="tab:blue", label="head")
    ax.set_aspect("equal")
    ax.set_xlabel("x (m), the initial heading")
    ax.set_ylabel("y (m)")
    ax.set_title(f"Walk from above: {int(at['segments'])} segments, {t[-1]:.1f} s, "
                 f"net dx = {float(at['com_dx']):+.3f} m (centre of mass)")
    ax.legend(fontsize=8)
    ax.grid(True, alpha=0.3)
    save(fig, "walk_path")

    # Animation: from above (top) and from the side (bottom).
    fig, (top, side) = plt.subplots(2, 1, figsize=(8, 5))
    allp = np.concatenate([d[k].reshape(-1, 3) for k in ("segments", "hips", "knees", "tips")])
    lo, hi = allp.min(axis=0) - 0.05, allp.max(axis=0) + 0.05

    def frame(i):
        for ax, view, lab in ((top, (0, 1), "y (m)"), (side, (0, 2), "z (m)")):
            ax.clear()
            draw_body(ax, d, i, view)
            ax.set_xlim(lo[0], hi[0])
            ax.set_ylim(lo[view[1]], hi[view[1]])
            ax.set_aspect("equal")
            ax.set_ylabel(lab)
        side.axhline(0, color="tab:brown", lw=1)
        side.set_xlabel("x (m)")
        top.set_title(f"t = {t[i]:.2f} s")

    anim = FuncAnimation(fig, frame, frames=len(t))
    os.makedirs(FIGURES, exist_ok=True)
    out = os.path.join(FIGURES, "walk.gif")
    anim.save(out, writer=PillowWriter(fps=20))
    print(f"plots: wrote {os.path.relpath(out, os.path.dirname(FIGURES))}")


if __name__ == "__main__":
    main()
