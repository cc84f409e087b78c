"""Figure 4: simulated time cost of the walking centipede vs number of legs, for the
contact-space paths abi (Θ(nm) impulse sweeps), lapack and ltdl (factor M once per step, then
back-substitute), test-impulse (spatial test impulses, no generalized product) and
contact-inertia (the Θ(n + m²) contact-space inertia recursion), each split by component, and,
when the file has it, mujoco-step (MuJoCo's own mj_step on the same centipede: one undivided
total, drawn as one bar). Reads results/centipede.h5 (`minv simulate sweep`); the paper's y
axis is the total time of its 1000-step run, so per-step means are scaled to 1000 steps (points
whose run had fewer steps are extrapolated that way and drawn hollow). Points run on more than
one thread (`--threads`, paths "<path>@<threads>") are drawn dotted in their path's colour. Skipped
points (status "skipped") are left out."""
import textwrap

import h5py
import matplotlib.pyplot as plt
import numpy as np

from common import provenance_line, result_path, save

PATHS = [("abi", "tab:red", "-."), ("lapack", "tab:blue", "-"), ("ltdl", "tab:green", "--"),
         ("test-impulse", "black", ":"), ("contact-inertia", "tab:purple", "-x"),
         ("mujoco-step", "tab:brown", "-s")]
COMPONENTS = ["dynamics", "collision", "matrices", "solve", "update"]
# The part of a step's total no component holds: MuJoCo's whole mj_step.
UNDIVIDED = "mj_step (MuJoCo, undivided)"


def load():
    out = {}
    with h5py.File(result_path("centipede.h5"), "r") as f:
        prov = provenance_line(f)
        for sname in f:
            if not sname.startswith("S") or sname.endswith(".partial"):
                continue
            for path in f[sname]:
                if path.endswith(".partial"):
                    continue
                g = f[sname][path]
                a = g.attrs
                status = a.get("status", "ok")
                if (status.decode() if isinstance(status, bytes) else status) != "ok":
                    continue
                steps = int(a["steps"])
                row = {c: float(a[f"time_{c}"]) / steps for c in COMPONENTS}
                row["total"] = float(a["time_total"]) / steps
                row[UNDIVIDED] = max(0.0, row["total"] - sum(row[c] for c in COMPONENTS))
                row["legs"] = int(a["legs"])
                row["nv"] = int(a["nv"])
                row["steps"] = steps
                out.setdefault(path, []).append(row)
    for rows in out.values():
        rows.sort(key=lambda r: r["legs"])
    return out, prov


def threaded_paths(data):
    """The points on more than one thread ("<path>@<threads>"), drawn in their path's colour
    with a dotted line."""
    colors = {p: c for p, c, _ in PATHS}
    return [(p, colors.get(p.split("@")[0], "tab:gray"), ":d") for p in sorted(data) if "@" in p]


def main():
    data, prov = load()
    fig, (ax, bx) = plt.subplots(1, 2, figsize=(12, 4.6))
    for path, color, style in PATHS + threaded_paths(data):
        rows = data.get(path, [])
        if not rows:
            continue
        legs = np.array([r["legs"] for r in rows])
        total = np.array([r["total"] for r in rows]) * 1000
        full = np.array([r["steps"] >= 100 for r in rows])
        label = path if "@" not in path else "{}, {} threads".format(*path.split("@"))
        ax.plot(legs, total, style, color=color, label=label)
        ax.plot(legs[full], total[full], "o", color=color)
        ax.plot(legs[~full], total[~full], "o", mfc="none", color=color)
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("number of legs (2 per segment)")
    ax.set_ylabel("time for 1000 steps of h = 1e-5 s (s)")
    ax.set_title("Figure 4: centipede walking, total time")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    # Components at the largest S measured for every path.
    common = set.intersection(*[set(r["legs"] for r in data[p]) for p, _, _ in PATHS if p in data])
    if common:
        legs = max(common)
        names = [p for p, _, _ in PATHS if p in data]
        bottom = np.zeros(len(names))
        colors = ["tab:gray", "tab:olive", "tab:purple", "tab:orange", "tab:cyan", "tab:brown"]
        for comp, col in zip(COMPONENTS + [UNDIVIDED], colors):
            vals = np.array([next(r[comp] for r in data[p] if r["legs"] == legs) for p in names]) * 1e3
            if comp == UNDIVIDED and not vals.any():
                continue
            bx.bar(names, vals, bottom=bottom, color=col, label=comp)
            bottom += vals
        bx.tick_params(axis="x", labelrotation=20)
        bx.set_ylabel("ms per step")
        bx.set_title(f"per-step components, {legs} legs ({legs // 2} segments)")
        bx.legend(fontsize=8)
    # The provenance under the panels, wrapped to the figure's width.
    fig.text(0.01, -0.02, "\n".join(textwrap.wrap(prov, 190)), fontsize=5, va="top")
    save(fig, "figure4_centipede")


if __name__ == "__main__":
    main()
