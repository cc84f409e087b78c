"""The performance section: abi against every peer in the registry, from results/perf.h5
(written by build/bench_abi). Writes paper/PERFORMANCE.md, paper/figures/perf_ratios.png/.pdf
and the figure of the Θ(n²) implementations, paper/figures/theta_n2.png/.pdf.

Layout read (bench_abi's report()): runs/<benchmark>/repetitions_s with attribute median_s for
every benchmark ("inverse/<topology>/<solver>/<n>", "solve/…/<n>/<m>", "store/<n>",
"dgemm/<n>", "copies/<topology>/abi/<n>", "parts/serial/<part>/<n>"); ratios/<topology>/{n,
abi_us, <peer>_over_abi};
ratios/<topology>/generic/{n, abi-generic_us, <peer>_over_abi_generic}; abi/<topology>/{n,
abi_gflops, abi_percent_of_dgemm, abi_over_store, abi_2thread_speedup, abi_2copies_speedup
(two one-thread pipelines at once, "copies/<topology>/abi/<n>": the reference for the
two-thread speed-up; absent from older files), lapack_over_abi_solve8};
parts/serial/…; upper/serial/{n, abi_full_us, abi_upper_us, upper_over_full,
upper_over_store, lapack_upper_over_abi_upper}; levels/serial/{n, <level>_us,
<level>_over_<level in use>} with attribute level_in_use; attributes
ratios/<topology>@skipped_<peer> (the skip table's reason)."""
import os

import h5py
import matplotlib.pyplot as plt
import numpy as np

from common import PAPER, RESULTS, cpu_name, provenance_line, result_path, save, short_sha

# The sizes of the "abi vs every peer" table.
TABLE_N = (16, 64, 256, 1024, 2048)
# The Θ(n²) implementations drawn in theta_n2 (those present in the file).
THETA = (("abi", "abi (level in use)", "o-"), ("abi-generic", "abi (baseline x86-64)", "o--"),
         ("dart", "DART getInvMassMatrix", "s-"), ("bullet", "Bullet btMultiBody", "^-"),
         ("mujoco", "MuJoCo sparse LᵀDL", "v-"), ("ltdl", "Featherstone LᵀDL", "d-"))

ABI_COLUMNS = [  # dataset, header, format
    ("abi_gflops", "abi GFLOP/s (counted)", "{:.2f}"),
    ("abi_percent_of_dgemm", "% of dgemm", "{:.1f}"),
    ("abi_over_store", "abi / store n² doubles", "{:.2f}"),
    ("abi_2thread_speedup", "speed-up on 2 threads (1-thread time / 2-thread time)", "{:.2f}"),
    ("abi_2copies_speedup", "speed-up of 2 copies at once", "{:.2f}"),
    ("lapack_over_abi_solve8", "M⁻¹R, m = 8: lapack / abi", "{:.1f}"),
]


def cell(fmt, x):
    return "—" if x == 0 else fmt.format(x)


def micro(x):
    """A format for x µs with about three significant digits (0.43, 13.1, 399)."""
    return "{:.2f}" if x < 10 else "{:.1f}" if x < 100 else "{:.0f}"


def text(v):
    return v.decode() if isinstance(v, bytes) else v


def median(f, name):
    """The median (s) of one benchmark, or 0 if it was not run."""
    g = f.get("runs/" + name)
    return float(g.attrs["median_s"]) if g is not None else 0.0


def abi_ops(n):
    """abi's counted operations on a serial chain of n links, all but comparisons, from the
    exact fits in results/flops.h5: (the sweeps' (Table 1's impulse propagation and velocity
    updates), the total), or (0, 0) without that file."""
    path = os.path.join(RESULTS, "flops.h5")
    if not os.path.exists(path):
        return 0.0, 0.0
    with h5py.File(path, "r") as f:
        g = f["serial_fixed"]["abi"]

        def ops(stage):
            return sum(float(np.polyval(g[stage][k + "_fit_poly"][()], n))
                       for k in ("add", "mul", "div", "sqrt", "trig"))

        return ops("impulse propagation") + ops("velocity updates"), ops("total")


def peers_of(f, topo):
    """The peers of the ratio table, in the file's order (abi's own column excluded)."""
    g = f["ratios"][topo]
    return [k[: -len("_over_abi")] for k in g.keys() if k.endswith("_over_abi")]


def ratio_table(f, topo, generic):
    """Markdown: every n of the run, peer time / abi time (or / abi-generic time)."""
    g = f["ratios"][topo]["generic"] if generic else f["ratios"][topo]
    suffix = "_over_abi_generic" if generic else "_over_abi"
    base = "abi-generic" if generic else "abi"
    peers = [k[: -len(suffix)] for k in g.keys() if k.endswith(suffix)]
    lines = [f"| n | {base} (µs) | " + " | ".join(f"{p} / {base}" for p in peers) + " |",
             "|---" * (len(peers) + 2) + "|"]
    for i, nv in enumerate(g["n"][()]):
        lines.append(f"| {int(nv)} | {g[base + '_us'][()][i]:.1f} | " +
                     " | ".join(cell("{:.2f}", g[p + suffix][()][i]) for p in peers) + " |")
    return lines


def versus_table(f, topo, mode):
    """Markdown: abi against every peer at TABLE_N, both ways: peer / abi native and
    peer / abi generic (abi built for generic x86-64, like Debian's prebuilt peers)."""
    lines = ["| peer | " + " | ".join(f"n = {n}" for n in TABLE_N) + " |",
             "|---" * (len(TABLE_N) + 1) + "|"]
    dashed = set()
    for p in peers_of(f, topo):
        if p == "abi-generic":
            continue
        cells = []
        for n in TABLE_N:
            t, a = median(f, f"inverse/{topo}/{p}/{n}"), median(f, f"inverse/{topo}/abi/{n}")
            ag = median(f, f"inverse/{topo}/abi-generic/{n}")
            if t == 0 or a == 0:
                cells.append("—")
                dashed.add(p)
            else:
                cells.append(f"{t / a:.2f}× / {t / ag:.2f}×" if ag > 0 else f"{t / a:.2f}×")
        lines.append(f"| {p} | " + " | ".join(cells) + " |")
    # The skip table's reason for each peer with a dash in this table.
    skipped = [f"`{p}`: {text(v)}" for k, v in f["ratios"][topo].attrs.items()
               for p in [k[len("skipped_"):]] if k.startswith("skipped_") and p in dashed]
    if skipped:
        lines += ["", f"— = not measured in this {mode} run; from the skip table "
                  "(experiments/lib/budget.cpp): " + "; ".join(skipped) + "."]
    return lines


def abi_table(f, topo):
    g = f["abi"][topo]
    lines = ["| n | " + " | ".join(h for _, h, _ in ABI_COLUMNS) + " |",
             "|---" * (len(ABI_COLUMNS) + 1) + "|"]
    for i, nv in enumerate(g["n"][()]):
        lines.append(f"| {int(nv)} | " +
                     " | ".join(cell(fmt, g[d][()][i] if d in g else 0)
                                for d, _, fmt in ABI_COLUMNS) + " |")
    return lines


def theta_figure(f, cpu):
    """Time of M⁻¹ (configure + inverse) against n for the Θ(n²) implementations."""
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.4), sharey=True)
    for ax, topo in zip(axes, ("serial", "branched")):
        for solver, label, style in THETA:
            ns, ts = [], []
            for n in (8, 16, 32, 64, 128, 256, 512, 1024, 2048):
                t = median(f, f"inverse/{topo}/{solver}/{n}")
                if t > 0:
                    ns.append(n)
                    ts.append(t)
            if ns:
                ax.plot(ns, ts, style, label=label, ms=4)
        ax.set(xscale="log", yscale="log", xlabel="n (links)", title=f"{topo} trees")
        ax.grid(True, which="both", alpha=0.3)
    axes[0].set_ylabel("seconds per M⁻¹ (configure + inverse), one core")
    axes[0].legend(fontsize=7)
    fig.suptitle(f"Θ(n²) implementations of M⁻¹ — {cpu}", fontsize=9)
    save(fig, "theta_n2")


def ratios_figure(f):
    fig, ax = plt.subplots(1, 2, figsize=(11, 4.2))
    for topo in ("serial", "branched"):
        g = f["ratios"][topo]
        n = g["n"][()]
        for p in peers_of(f, topo):
            y = g[p + "_over_abi"][()]
            keep = y > 0
            if keep.any():
                ax[0].plot(n[keep], y[keep], "o-" if topo == "serial" else "s--",
                           label=f"{p}, {topo}", ms=3)
        a = f["abi"][topo]
        ax[1].plot(a["n"][()], a["abi_gflops"][()], "o-", label=f"abi GFLOP/s, {topo}")
    ax[0].axhline(1, color="gray", lw=0.8)
    ax[0].set(xscale="log", yscale="log", xlabel="n", ylabel="peer time / abi time",
              title="M⁻¹ pipeline: how much faster abi is")
    ax[0].legend(fontsize=6, ncol=2)
    ax[1].set(xscale="log", xlabel="n", ylabel="GFLOP/s", title="abi's counted flop rate")
    ax[1].legend(fontsize=7)
    for a in ax:
        a.grid(True, which="both", alpha=0.3)
    save(fig, "perf_ratios")


PARTS = [  # dataset, header
    ("configure_us", "configure"),
    ("sweeps_us", "sweeps"),
    ("writes_us", "writes"),
    ("inverse_us", "inverse (sweeps + writes)"),
    ("pipeline_us", "pipeline (timed above)"),
    ("store_us", "store n² doubles"),
]


def parts_section(f):
    """Where abi's time goes: its parts on the serial chain, one thread, in µs."""
    if "parts" not in f:
        return []
    g = f["parts"]["serial"]
    n = g["n"][()]
    lines = ["", "## Where abi's time goes (serial chain, one thread, medians in µs)", "",
             "Each part timed on its own: `configure` (kinematics and articulated inertias), "
             "the impulse `sweeps` of all column blocks without writing, and the `writes` "
             "(each block storing, as its forward sweep goes, its columns above the diagonal "
             "and, by symmetry, its rows left of it; at the avx512 level from n = 256 two blocks "
             "at a time, eight from n = 4096, their forward sweeps in turn, so that the blocks' "
             "rows in a column are written together: the blocks timed whole, less the sweeps, "
             "which are timed one block at a time, so that the writes also carry what grouping "
             "changes in the sweeps). "
             "On two threads each thread makes its own configuration (one fork per call; "
             "sharing one was slower), so two threads can at best take configure + (pipeline "
             "− configure) / 2: the bound beside the measured speed-up (1-thread time / 2-thread time; — where not "
             "measured). Where the bound is below a target, the target is out of reach of this "
             "design however fast each part gets in proportion; where the measured figure "
             "falls short of a bound above it, the loss is in running the parts on two threads "
             "at once, which this table does not show. The parts are those of the level in "
             "use; the other levels are in the per-level table below.", "",
             "| n | " + " | ".join(h for _, h in PARTS) +
             " | inverse / store | speed-up on 2 threads: bound | measured |",
             "|---" * (len(PARTS) + 4) + "|"]
    two = f["abi"]["serial"] if "abi" in f and "serial" in f["abi"] else None
    for i, nv in enumerate(n):
        row = [g[d][()][i] for d, _ in PARTS]
        ratio = row[3] / row[5] if row[5] > 0 else 0
        configure, pipeline = row[0], row[4]
        bound = pipeline / (configure + (pipeline - configure) / 2) if pipeline > 0 else 0
        measured = at(two, "abi_2thread_speedup", int(nv))
        lines.append(f"| {int(nv)} | " + " | ".join(cell(micro(x), x) for x in row) +
                     f" | {cell('{:.2f}', ratio)} | {cell('{:.2f}', bound)} |"
                     f" {cell('{:.2f}', measured)} |")
    return lines


def upper_section(f):
    """One triangle: inverseUpper against the full inverse and the store (serial, one thread)."""
    if "upper" not in f or "serial" not in f["upper"]:
        return []
    g = f["upper"]["serial"]
    lines = ["", "## M⁻¹'s upper triangle only (serial chain, one thread)", "",
             "`inverseUpper()` writes M⁻¹'s upper triangle and leaves the rest (for a symmetric "
             "consumer such as the contact path). abi then skips the rows its blocks would "
             "mirror; lapack (CRBA + dpotrf) runs dpotri on the upper factor and mirrors "
             "nothing. The full inverse stays the headline above; this is reported apart.", "",
             "| n | abi full (µs) | abi upper (µs) | upper / full | upper / store n² | "
             "lapack upper / abi upper |", "|---|---|---|---|---|---|"]
    cols = ("abi_full_us", "abi_upper_us", "upper_over_full", "upper_over_store",
            "lapack_upper_over_abi_upper")
    fmts = ("{:.1f}", "{:.1f}", "{:.2f}", "{:.2f}", "{:.1f}")
    for i, nv in enumerate(g["n"][()]):
        lines.append(f"| {int(nv)} | " + " | ".join(cell(fm, g[c][()][i])
                                                     for c, fm in zip(cols, fmts)) + " |")
    return lines


def levels_section(f):
    """abi at every instruction-set level this CPU runs (serial chain, one thread)."""
    if "levels" not in f or "serial" not in f["levels"]:
        return []
    g = f["levels"]["serial"]
    used = text(g.attrs.get("level_in_use", "?"))
    levels = [k[: -len("_us")] for k in g.keys() if k.endswith("_us")]
    order = {"baseline": 0, "avx2": 1, "avx512": 2, "native": 3}
    levels.sort(key=lambda x: order.get(x, 9))
    lines = ["", "## abi per instruction-set level (serial chain, one thread)", "",
             f"Each level's module timed side by side in one run (configure + inverse, medians "
             f"in µs), and its time over the level in use (`{used}`, the highest this CPU "
             "runs). `MINV_ISA` or `bench_abi --isa` forces a level.", "",
             "| n | " + " | ".join(f"{l} µs | {l} / {used}" for l in levels) + " |",
             "|---" * (1 + 2 * len(levels)) + "|"]
    for i, nv in enumerate(g["n"][()]):
        cells = []
        for l in levels:
            cells += [cell("{:.1f}", g[l + "_us"][()][i]),
                      cell("{:.2f}", g[f"{l}_over_{used}"][()][i])]
        lines.append(f"| {int(nv)} | " + " | ".join(cells) + " |")
    return lines


def lowest_speedup(f, n):
    """The two-thread speed-up of a serial chain of n in its worst pairing of repetitions (the
    slowest two-thread repetition against the fastest one-thread one): the figure that holds in
    every one of the run's repetitions; 0 where the file has no raw repetitions."""
    one, two = f.get(f"runs/inverse/serial/abi/{n}"), f.get(f"runs/inverse/serial/abi@2/{n}")
    if one is None or two is None or "repetitions_s" not in one or "repetitions_s" not in two:
        return 0.0
    return float(min(one["repetitions_s"][()]) / max(two["repetitions_s"][()]))


def lowest_text(f, n):
    """lowest_speedup as " (≥ 1.61)", or nothing where the file has no repetitions."""
    low = lowest_speedup(f, n)
    return f" (≥ {low:.2f})" if low > 0 else ""


def at(g, name, n):
    """Dataset `name` of group g at size n (0 where the run has no such point)."""
    if g is None or name not in g:
        return 0.0
    ns = list(g["n"][()])
    return float(g[name][()][ns.index(n)]) if n in ns else 0.0


def machines_section():
    """Issue 16's targets on every machine with a result file: results/perf.h5 and any
    results/perf_<machine>.h5 kept from another CPU (bench_abi --out)."""
    files = sorted(p for p in os.listdir(RESULTS)
                   if p.startswith("perf") and p.endswith(".h5") and p != "perf_memory.h5")
    rows = []
    for name in files:
        with h5py.File(os.path.join(RESULTS, name), "r") as f:
            if "abi" not in f or "serial" not in f["abi"]:
                continue
            a, r = f["abi"]["serial"], f["ratios"]["serial"]
            lv = f["levels"]["serial"] if "levels" in f and "serial" in f["levels"] else None
            sig = text(f.attrs.get("cpu_signature", "?"))
            isa = text(f.attrs.get("abi_isa", "?"))
            rows_mode = "streamed" if "rows streamed" in isa else "plain"
            blas = text(f.attrs.get("blas_library", "?")).split()
            store = median(f, "store/4096")
            avx2 = at(lv, "avx2_us", 4096) * 1e-6
            # The sweeps' share: the sweeps' counted operations over the sweeps' time.
            pg = f["parts"]["serial"] if "parts" in f else None
            sw, pl = at(pg, "sweeps_us", 2048), at(pg, "pipeline_us", 2048)
            pct = at(a, "abi_percent_of_dgemm", 2048)
            # The sweeps' share of the operations the file's rate counted (its commit's count:
            # abi's rate times its time), less today's count outside the sweeps (configure)
            sweeps_ops, total_ops = abi_ops(2048)
            file_ops = at(a, "abi_gflops", 2048) * 1e9 * median(f, "inverse/serial/abi/2048")
            share = (file_ops - (total_ops - sweeps_ops)) / file_ops if file_ops > 0 else 0
            cells = [f"`{name}`: {text(f.attrs.get('cpu_vendor', ''))} {sig}, "
                     f"git {short_sha(f.attrs.get('git_sha', '?'))}, rows {rows_mode}, "
                     f"OpenBLAS {blas[-2] if len(blas) > 2 else '?'}",
                     cell("{:.2f}", at(r, "lapack_over_abi", 16)),
                     cell("{:.2f}", at(r, "lapack_over_abi", 32)),
                     cell("{:.1f}", pct),
                     cell("{:.1f}", pct * share * pl / sw if sw > 0 else 0)]
            cells += [cell("{:.2f}", at(a, "abi_2thread_speedup", n)) + lowest_text(f, n) +
                      " / " + cell("{:.2f}", at(a, "abi_2copies_speedup", n))
                      for n in (512, 1024, 2048)]
            cells += [cell("{:.2f}", at(a, "abi_over_store", 4096)),
                      cell("{:.2f}", avx2 / store if store > 0 else 0)]
            rows.append("| " + " | ".join(cells) + " |")
    if not rows:
        return []
    return ["", "## Issue 16's targets on every machine measured", "",
            "One row per result file (the machines are not all one CPU: Zen 5 handles "
            "subnormal numbers well, an Intel Xeon does not; each row says whether abi streamed "
            "M⁻¹'s mirrored rows, as it now does on every CPU; see README, \"Two CPU "
            "traits\"). Pipeline ratios as above; % of dgemm is abi's counted "
            "operations per second over dgemm's: the whole pipeline's operations over its time, "
            "then the sweeps' operations (Table 1's impulse propagation and velocity updates, "
            "results/flops.h5) over the sweeps' time (the parts table: configure and the writes "
            "excluded; — without flops.h5). Each file counts the operations of the code it ran "
            "(its rate is stored with it: files older than fcab329, whose sweeps did 2n² + 29n − 31 "
            "fewer operations, count 101.5 M at n = 2048 where today's code counts 110.0 M), and "
            "its sweeps' operations are that count less today's count outside the sweeps; the "
            "last column "
            "is abi forced to its avx2 level over the store, the nearest this run has to an "
            "AVX2-only machine. Each two-thread cell is abi on 1 thread's time / abi on 2 "
            "threads' time (medians; in brackets the lowest speed-up of any pairing of the "
            "run's repetitions, the slowest two-thread one against the fastest one-thread one: "
            "what held in every repetition), then twice one alone's time / the time of two "
            "one-thread copies of "
            "abi run at once (each its own solver and output, one per thread): what two threads "
            "gained on that machine with nothing shared but the machine itself, the reference "
            "for the first (— where the file predates that benchmark).", "",
            "| machine | lapack / abi n = 16 | n = 32 | % of dgemm n = 2048, pipeline | sweeps | "
            "speed-up on 2 threads (of 2 copies) n = 512 | 1024 | 2048 | abi / store n = 4096 | "
            "avx2 level / store n = 4096 |",
            "|---|---|---|---|---|---|---|---|---|---|",
            "| target | ≥ 3 | ≥ 3 | | ≥ 35 | ≥ 1.85 | ≥ 1.85 | ≥ 1.85 | ≤ 2 | ≤ 2 |"] + rows


def memory_section():
    """The largest inverse: peak resident memory beyond the output (results/perf_memory.h5)."""
    path = os.path.join(RESULTS, "perf_memory.h5")
    if not os.path.exists(path):
        return []
    with h5py.File(path, "r") as f:
        n, secs = int(f["n"][0]), f["seconds"][0]
        out, peak, growth = f["output_mib"][0], f["peak_rss_mib"][0], f["rss_growth_mib"][0]
        prov = provenance_line(f)
    return ["", "## The largest inverse", "",
            f"From `results/perf_memory.h5` ({prov}): a serial chain of n = {n}, M⁻¹ of "
            f"{out:.0f} MiB, configure + inverse in {secs:.2f} s on one thread; peak resident "
            f"memory {peak:.0f} MiB, {peak - out:.0f} MiB beyond the output (the process, its "
            f"libraries and the tree); growth during configure + inverse {growth:.1f} MiB: "
            "the scratch is O(n·W)."]


def machine_lines(f):
    """The machine and build the figures come from, from the result file's provenance."""
    a = f.attrs

    def get(k):
        return text(a.get(k, "?"))
    return [f"- CPU: {get('cpu_model')}, {get('cpu_cores')} cores (host {get('hostname')})",
            f"- compiler: {get('compiler')}, flags `{get('build_flags')}`",
            f"- abi's instruction-set level in use: {get('abi_isa')} (chosen from CPUID; "
            f"levels here: {get('abi_isa_levels')}); `abi-generic` is abi's baseline level "
            "(`-march=x86-64`, SSE2), as Debian compiled DART, Bullet and MuJoCo",
            f"- BLAS: {get('blas_library')}, {get('blas_threads')} thread(s); OpenMP up to "
            f"{get('omp_max_threads')} threads (abi's two-thread runs only)",
            f"- cores at the start of the run (dependent additions per ns): {get('cores')} "
            "(experiments/lib/cores.hpp)",
            f"- run: git {get('git_sha')}, {get('date_utc')}, mode {get('mode')}, "
            f"trees and q from seed {seed_of(a)}"]


def seed_of(attrs):
    """The seed of bench_abi's trees and q: recorded since the file's `seed` attribute came in;
    bench_abi has used seed 1 since its first version, so older files get 1 with a note."""
    if "seed" in attrs:
        return text(attrs["seed"])
    return "1 (not recorded in this file; bench_abi has always used 1)"


def versus_section(f):
    """The "abi vs every peer" section (also pasted into REPORT.md by plots/report.py)."""
    mode = text(f.attrs.get("mode", "?"))
    cpu = cpu_name(f)
    lines = ["## abi against every peer", "",
             f"Machine: {cpu}. Medians of 5 interleaved repetitions in one run, one core, the "
             "pipeline from q to M⁻¹ (configure + inverse). Each cell is peer time / abi time "
             "with abi at the instruction-set level this CPU runs (chosen at run time), then / "
             "abi at its baseline level (generic x86-64, like the peers' Debian packages); > 1 "
             "means abi is faster.", ""]
    for topo in ("serial", "branched"):
        lines += [f"### {topo} trees", ""] + versus_table(f, topo, mode) + [""]
    lines.append("![Θ(n²) implementations](figures/theta_n2.png)")
    return lines


def main():
    with h5py.File(result_path("perf.h5"), "r") as f:
        cpu = cpu_name(f)
        lines = ["# Performance of `abi`", "",
                 f"Generated by `plots/perf.py` from `results/perf.h5` ({provenance_line(f)}, "
                 f"mode {text(f.attrs.get('mode', '?'))}). Every figure below was measured on "
                 "this machine:", ""] + machine_lines(f) + [
                 "", "Google Benchmark medians of 5 repetitions, each the pipeline from a "
                 "configuration q to M⁻¹ (configure + inverse), single thread and BLAS threads 1 "
                 "unless stated. Ratios are peer time / abi time measured side by side in one "
                 "run; > 1 means abi is faster. GFLOP/s counts abi's own operations on the "
                 "counting scalar; '% of dgemm' divides by OpenBLAS dgemm's rate at the same n on "
                 "the same core; 'abi / store' is abi's time over the time to write n² doubles "
                 "(the memory floor: Eigen's setConstant, plain stores); '2 copies at once / 1' "
                 "is twice abi's time over the time of two one-thread abi pipelines run at once, "
                 "each on its own thread with its own solver and output (what two threads can "
                 "gain on this machine when they share nothing: the reference for '2 threads / "
                 "1'; being timed apart, it can exceed 2 in a noisy run). Every solver and the "
                 "floor write into a zeroed output on transparent huge pages where the kernel "
                 "allows them (experiments/lib/output_matrix.hpp), its pages touched before "
                 "timing. — = not measured at that n (the skip table, "
                 "experiments/lib/budget.cpp, gives each reason).", ""]
        lines += versus_section(f) + [""]
        theta_figure(f, cpu)
        for topo in ("serial", "branched"):
            lines += [f"## {topo}: every peer, every n", ""] + ratio_table(f, topo, False) + [""]
            if "generic" in f["ratios"][topo]:
                lines += [f"Against abi built for generic x86-64 ({topo}):", ""]
                lines += ratio_table(f, topo, True) + [""]
            lines += [f"abi's own figures ({topo}):", ""] + abi_table(f, topo) + [""]
        ratios_figure(f)
        lines.append("![ratios](figures/perf_ratios.png)")
        lines += parts_section(f)
        lines += upper_section(f)
        lines += levels_section(f)
    lines += machines_section()
    lines += memory_section()
    with open(os.path.join(PAPER, "PERFORMANCE.md"), "w") as out:
        out.write("\n".join(lines) + "\n")
    print("plots: wrote paper/PERFORMANCE.md")


if __name__ == "__main__":
    main()
