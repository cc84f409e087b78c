// The timing sweeps behind the paper's Figures 2 and 3: their definition (points, skip rules,
// shards), the resumable result file, and the merge of shard files. The measurement itself is
// injected (MeasureFn): experiments/bench_timing.cpp measures with Google Benchmark, so this
// library does not depend on it.
//
// A point is one (family, solver, topology, base, n, m, threads):
//   family "pipeline": everything from a configuration q to M⁻¹ (m = 0) or M⁻¹R (m > 0), i.e.
//          configure(q) + inverse()/solve() through the Solver interface: kinematics + CRBA +
//          factorization + inverse for the Cholesky family, kinematics + articulated inertias +
//          impulse sweeps for `abi` (the paper's Figure 2);
//   family "kernel": inverse() (m = 0) or solve(R) (m columns) alone, configure(q) having run
//          outside the timed region. For the Cholesky family the factorization therefore lies
//          OUTSIDE the kernel (kernel = the inverse/back-substitution from the factor); for abi
//          the articulated inertias lie outside (kernel = the impulse sweeps). Since the
//          factorization is never timed here, an in-place factorization needs no fresh copy.
//   family "threads": the pipeline with setThreads(threads) (Figure 3: abi over OpenMP, lapack
//          over OpenBLAS threads).
// Model building and prepare() lie outside every timed region. Every point runs with OpenBLAS
// and OpenMP at 1 thread except the `threads` family, which calls solver->setThreads(t).
//
// The random tree of a point is randomTree({topology, n, seed, floating}) and its q is
// randomConfiguration(model, seed); R is uniform in [−1, 1) from Rng(seed + 1).
//
// Result file (HDF5, through H5Writer::append): group "points/<name>" per point, written when
// it finishes (beginPoint/endPoint): datasets real_time_s and cpu_time_s (seconds per
// iteration, one entry per repetition: the raw repetitions), iterations (per repetition),
// parent (the tree's body parent array); attributes family, solver, topology, base, n, nv, nb,
// max_depth, m, threads, solver_threads, seed, mode, repetitions, min_time_s, status ("ok" or
// "skipped"), skipped (the reason, only when skipped) and the measuring process's hostname,
// cpu_model, date_utc, git_sha, blas_threads, omp_max_threads (shards may run on different
// nodes; omp_max_threads is the process's OpenMP default, 1: abi's team on the `threads` family
// is set by its own num_threads clause, and solver_threads says its size). The root holds the
// sweep's description and the full provenance (experiments/lib/provenance.hpp) of the latest
// run. A rerun skips every finished point (and every recorded skip), so a killed sweep resumes
// where it stopped.
#pragma once

#include <cstdint>
#include <functional>
#include <map>
#include <optional>
#include <ostream>
#include <string>
#include <vector>

#include "experiments/lib/budget.hpp"

namespace minv {

struct TimingPoint {
  std::string family, solver, topology;
  bool floating = false;
  int n = 0, m = 0, threads = 1;
  // "pipeline.abi.serial.fixed.n00064.m0.t1"; the group is "points/" + name().
  std::string name() const;
};

// One block of a sweep: the cartesian product of its axes.
struct SweepBlock {
  std::string family;
  std::vector<std::string> solvers;  // empty = every registered solver
  std::vector<std::string> topologies = {"serial", "branched"};
  std::vector<bool> floating = {false, true};
  std::vector<int> n, m = {0}, threads = {1};
};

struct TimingSweep {
  std::string mode = "quick";  // quick | full | tiny: also selects the skip caps
  std::vector<SweepBlock> blocks;
  std::uint64_t seed = 1;
  double min_time = 0.01;  // Google Benchmark's min time per repetition, seconds
  int repetitions = 5;
};

// n log-spaced from lo to hi, `per_octave` values per doubling (rounded, distinct).
std::vector<int> logSpaced(int lo, int hi, int per_octave);

// quick: to n = 1024 (pipeline on a √2 grid with both bases, kernel on a ×2 grid with a fixed
// base and m ∈ {0, 1, 8, 64}, threads 1/2/4 for abi and lapack); full: the same to n = 4096,
// kernel with both bases; tiny: a few small points (tests).
TimingSweep timingSweep(const std::string& mode);

// Every point of the sweep in a fixed order (blocks, then topology, base, n, solver, m,
// threads); solvers not in the registry are dropped.
std::vector<TimingPoint> sweepPoints(const TimingSweep& sweep);

// --shard i/N: the points whose index in sweepPoints() is ≡ i (mod N); deterministic.
struct Shard {
  int index = 0, count = 1;
};
Shard parseShard(const std::string& text);  // "i/N", 0 ≤ i < N; else std::invalid_argument
std::vector<TimingPoint> shardPoints(const std::vector<TimingPoint>& points, Shard shard);

// Raw repetitions of one point: seconds per iteration, per repetition.
struct Measurement {
  std::vector<double> real_s, cpu_s;
  std::vector<std::int64_t> iterations;
};
// Measure `body` (one iteration) under `label`.
using MeasureFn = std::function<Measurement(
    const std::string& label, const std::function<void()>& body, const TimingSweep& sweep)>;

struct SweepStats {
  int measured = 0, resumed = 0, skipped = 0;
};
// Runs the shard's points into `path` (append mode), skipping finished ones; logs one line per
// point to `log` (flushed after the point is on disk).
SweepStats runTimingSweep(const TimingSweep& sweep, Shard shard, const std::string& path,
                          const MeasureFn& measure, std::ostream& log);

}  // namespace minv
