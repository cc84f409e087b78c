// Issue 7's benchmarks: `abi` against the field, side by side in one run, as ratios.
//
//   build/bench_abi [--full] [--isa LEVEL] [--out results/perf.h5] [benchmark flags]
//   build/bench_abi --memory-n N [--out results/perf_memory.h5]
//
// Google Benchmark times, single thread (BLAS threads 1) unless stated, medians of 5
// repetitions run in a random interleaved order, each of them the pipeline from a
// configuration q: configure(q) (kinematics + CRBA + factor, or kinematics + articulated
// inertias) then inverse() for M⁻¹ or solve(R) for M⁻¹R with m = 8 (--full: m ∈ {1, 8, 64}).
// n from 8 to 4096 (quick mode: the serial chain only at 4096, cubic peers stop earlier).
// Beside them: a store of n² doubles (the memory floor: the time to write the output at all),
// OpenBLAS dgemm's rate on the same core, abi's counted flops (its own kernels on the counting
// scalar) per second, abi on 2 threads beside two one-thread copies of abi run at once (what
// two threads gain here when they share nothing), and abi's parts (configure, sweeps, writes of the
// output): where its time goes. Every raw repetition, the medians, the ratios, the parts and
// the provenance go to one HDF5 file (a run with --benchmark_filter writes none unless --out).
// --isa LEVEL (baseline, avx2, avx512, native) forces abi's instruction-set level, as MINV_ISA
// does; every level this CPU runs is also timed on its own (inverse/serial/abi-<level>/n).
// --memory-n N inverts one serial chain of n = N (N² doubles of output) and reports the peak
// resident memory beyond the output: the scratch is O(n·W), not O(n²).
#include <benchmark/benchmark.h>
#include <cblas.h>
#include <omp.h>
#include <sys/resource.h>

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <functional>
#include <map>
#include <memory>
#include <set>
#include <string>
#include <vector>

#include "experiments/lib/budget.hpp"
#include "experiments/lib/cores.hpp"
#include "experiments/lib/h5writer.hpp"
#include "experiments/lib/output_matrix.hpp"
#include "experiments/lib/provenance.hpp"
#include "experiments/lib/timing.hpp"
#include "generators/random_tree.hpp"
#include "solvers/abi.hpp"
#include "solvers/abi_variants.hpp"
#include "solvers/solver.hpp"

extern "C" void openblas_set_num_threads(int);

namespace minv {
namespace {

// One problem: a tree, its configuration and right-hand sides (built outside timed regions).
struct Problem {
  Model model;
  Eigen::VectorXd q;
};

// Every benchmark's tree and q: randomTree and randomConfiguration from this seed (recorded in
// the result file's root as `seed`).
constexpr std::uint64_t kSeed = 1;

const Problem& problem(Topology t, int n) {
  static std::map<std::pair<int, int>, std::unique_ptr<Problem>> cache;
  auto& p = cache[{static_cast<int>(t), n}];
  if (!p) {
    Model m = randomTree({t, n, kSeed, false, JointSet::Revolute});
    Eigen::VectorXd q = randomConfiguration(m, kSeed);
    p = std::make_unique<Problem>(Problem{std::move(m), std::move(q)});
  }
  return *p;
}

// Whether a solver's point is measured: the one skip table (experiments/lib/budget.hpp,
// family "perf").
bool affordable(const std::string& solver, bool full, Topology t, int n) {
  return !skipReason(solver, "perf", topologyName(t), n, full ? "full" : "quick");
}

// Every registered solver: abi first, then the registry's order.
std::vector<std::string> peers() {
  std::vector<std::string> out = {"abi"};
  for (const std::string& s : solverNames())
    if (s != "abi") out.push_back(s);
  return out;
}

struct Median {
  std::vector<double> reps;  // seconds
  double median = 0;
};
std::map<std::string, Median> medians;

// Collects every repetition and the median of each benchmark; prints the medians.
class Collector : public benchmark::ConsoleReporter {
 public:
  void ReportRuns(const std::vector<Run>& runs) override {
    std::vector<Run> shown;
    for (const Run& r : runs) {
      std::string name = r.run_name.str();
      // Google Benchmark appends "/real_time" to benchmarks that use real time.
      if (const auto at = name.rfind("/real_time"); at != std::string::npos) name.resize(at);
      // A benchmark that skipped itself with an error: its message, once, and no timing.
      if (r.error_occurred) {
        if (errors.insert(name).second) shown.push_back(r);
        continue;
      }
      const double s = r.GetAdjustedRealTime() * 1e-9;  // time unit is ns
      if (r.run_type == Run::RT_Iteration) medians[name].reps.push_back(s);
      if (r.run_type == Run::RT_Aggregate && r.aggregate_name == "median") {
        medians[name].median = s;
        shown.push_back(r);
      }
    }
    ConsoleReporter::ReportRuns(shown);
  }

 private:
  std::set<std::string> errors;
};

// Each core's speed, measured once; single-threaded benchmarks run on the fastest
// (experiments/lib/cores.hpp: at times one core of the 2-vCPU Zen 5 guest ran 15 % slower).
const CorePinning& pinning() {
  static const CorePinning p;
  return p;
}

// A benchmark on several threads: every core while it lives, then back on the fastest, also
// if the benchmark throws (`on` false: nothing changes).
struct Unpinned {
  bool on;
  explicit Unpinned(bool on_ = true) : on(on_) {
    if (on) pinning().release();
  }
  ~Unpinned() {
    if (on) pinning().pinFastest();
  }
};

// The pipeline of one registered solver: configure(q), then inverse (m = 0), inverseUpper
// (m = kUpper: M⁻¹'s upper triangle only) or solve. `make` replaces the registry's factory (abi
// at a forced instruction-set level).
constexpr int kUpper = -1;
void registerSolver(const std::string& solver, Topology t, int n, int m, int threads,
                    std::function<std::unique_ptr<Solver>()> make = {}) {
  const char* kind = m == 0 ? "inverse/" : m == kUpper ? "upper/" : "solve/";
  std::string name = std::string(kind) + topologyName(t) + "/" + solver +
                     (threads > 1 ? "@" + std::to_string(threads) : "") + "/" + std::to_string(n) +
                     (m > 0 ? "/" + std::to_string(m) : "");
  benchmark::RegisterBenchmark(name.c_str(),
                               [=](benchmark::State& state) {
                                 const Problem& p = problem(t, n);
                                 const Unpinned unpinned(threads > 1);
                                 auto s = make ? make() : makeSolver(solver);
                                 s->setThreads(threads);
                                 s->prepare(p.model);
                                 const int nv = p.model.nv();
                                 // The output's pages are touched before timing, for every solver
                                 // alike.
                                 Eigen::MatrixXd X = outputMatrix(nv, m > 0 ? m : nv),
                                                 R = Eigen::MatrixXd::Random(nv, m > 0 ? m : 1);
                                 for (auto _ : state) {
                                   s->configure(p.q);
                                   if (m == 0)
                                     s->inverse(X);
                                   else if (m == kUpper)
                                     s->inverseUpper(X);
                                   else
                                     s->solve(R, X);
                                   benchmark::DoNotOptimize(X.data());
                                   benchmark::ClobberMemory();
                                 }
                                 s->setThreads(1);
                               })
      ->Unit(benchmark::kNanosecond)
      ->UseRealTime();
}

// Two one-thread abi pipelines at once, each with its own solver, configuration and output,
// one per OpenMP thread (forked per iteration, as abi@2 forks per call): an iteration is two
// inverses. 2·t(abi) / t(copies) is what two threads gain when nothing is shared but the
// machine (its caches, its memory, its host): the reference for abi@2's speed-up. Not a strict
// bound: on the noisy 2-vCPU guest single runs of it ranged from 1.56 to 2.10 at n = 2048.
void registerCopies(Topology t, int n) {
  const std::string name = "copies/" + std::string(topologyName(t)) + "/abi/" + std::to_string(n);
  benchmark::RegisterBenchmark(
      name.c_str(),
      [=](benchmark::State& state) {
        const Problem& p = problem(t, n);
        const Unpinned unpinned;
        std::unique_ptr<Solver> s[2] = {makeSolver("abi"), makeSolver("abi")};
        Eigen::MatrixXd X[2];
        for (int c = 0; c < 2; ++c) {
          s[c]->prepare(p.model);
          X[c] = outputMatrix(p.model.nv(), p.model.nv());
        }
        // Each copy on a thread of its own: a team of fewer than two (OMP_THREAD_LIMIT=1, say)
        // would time one inverse as two. (abi does not throw here; an exception inside the
        // parallel region would end the program.)
        int team = 0;
#pragma omp parallel num_threads(2)
#pragma omp single
        team = omp_get_num_threads();
        if (team != 2) {
          state.SkipWithError("OpenMP gave one thread: two copies cannot run at once");
          return;
        }
        for (auto _ : state) {
#pragma omp parallel num_threads(2)
          {
            const int c = omp_get_thread_num();
            s[c]->configure(p.q);
            s[c]->inverse(X[c]);
          }
          benchmark::DoNotOptimize(X[0].data());
          benchmark::DoNotOptimize(X[1].data());
          benchmark::ClobberMemory();
        }
      })
      ->Unit(benchmark::kNanosecond)
      ->UseRealTime();
}

// abi's parts on the serial chain, one thread, at the level in use: configure (kinematics +
// articulated inertias), the sweeps alone, and the blocks (sweeps + writing each block's
// strips of M⁻¹: the inverse). Where the time of inverse/serial/abi goes.
void registerParts(int n) {
  for (const char* part : {"configure", "sweeps", "blocks"}) {
    const std::string name = "parts/serial/" + std::string(part) + "/" + std::to_string(n);
    benchmark::RegisterBenchmark(name.c_str(),
                                 [=](benchmark::State& state) {
                                   const Problem& p = problem(Topology::Serial, n);
                                   const std::unique_ptr<Solver> s = makeSolver("abi");
                                   const AbiVariantApi& level = abiVariant(abiLevel());
                                   s->prepare(p.model);
                                   s->configure(p.q);
                                   Eigen::MatrixXd X = outputMatrix(n, n);
                                   const std::string what = part;
                                   for (auto _ : state) {
                                     if (what == "configure")
                                       s->configure(p.q);
                                     else if (what == "sweeps")
                                       level.sweeps(*s);
                                     else
                                       s->inverse(X);
                                     benchmark::DoNotOptimize(X.data());
                                     benchmark::ClobberMemory();
                                   }
                                 })
        ->Unit(benchmark::kNanosecond)
        ->UseRealTime();
  }
}

// The timing sweep's kernel grid (experiments/lib/timing.cpp: ×2 from n = 8), to full mode's
// largest n: one grid for both timing drivers.
std::vector<int> perfSizes() {
  return logSpaced(8, 4096, 1);
}

void registerAll(bool full) {
  const std::vector<int> sizes = perfSizes();
  for (Topology t : {Topology::Serial, Topology::Branched})
    for (int n : sizes) {
      for (const std::string& s : peers()) {
        if (!affordable(s, full, t, n)) continue;
        registerSolver(s, t, n, 0, 1);
        // M⁻¹R for abi and the Cholesky family's reference (--full: every solver).
        if (full || s == "abi" || s == "lapack")
          for (int m : full ? std::vector<int>{1, 8, 64} : std::vector<int>{8})
            registerSolver(s, t, n, m, 1);
      }
      if (n >= 256 && affordable("abi", full, t, n)) {
        registerSolver("abi", t, n, 0, 2);
        registerCopies(t, n);
      }
      // M⁻¹'s upper triangle alone (inverseUpper), abi and lapack (which computes it anyway).
      if (t == Topology::Serial && n >= 64)
        for (const char* s : {"abi", "lapack"})
          if (affordable(s, full, t, n)) registerSolver(s, t, n, kUpper, 1);
      // abi at every level this CPU runs (the serial chain), beside the level in use.
      if (t == Topology::Serial && n >= 16)
        for (Isa l : abiLevels())
          if (abiLevelUsable(l))
            registerSolver("abi-" + std::string(isaName(l)), t, n, 0, 1,
                           [l] { return makeAbiAt(l); });
      if ((n >= 256 || (n >= 16 && n <= 64)) && t == Topology::Serial) registerParts(n);
    }
  for (int n : sizes) {
    // The memory floor: write n² doubles.
    benchmark::RegisterBenchmark(("store/" + std::to_string(n)).c_str(),
                                 [n](benchmark::State& st) {
                                   Eigen::MatrixXd X = outputMatrix(n, n);
                                   double v = 0;
                                   for (auto _ : st) {
                                     X.setConstant(v += 1);
                                     benchmark::DoNotOptimize(X.data());
                                     benchmark::ClobberMemory();
                                   }
                                 })
        ->Unit(benchmark::kNanosecond)
        ->UseRealTime();
    // OpenBLAS dgemm, n×n×n, one thread (to n = 2048 in quick mode: 3.4 s a call at 4096).
    if (n >= 64 && (full || n <= 2048)) {
      const std::string name = "dgemm/" + std::to_string(n);
      benchmark::RegisterBenchmark(
          name.c_str(),
          [n](benchmark::State& st) {
            Eigen::MatrixXd A = Eigen::MatrixXd::Random(n, n), B = A, C(n, n);
            openblas_set_num_threads(1);  // one core, whatever ran before
            for (auto _ : st) {
              cblas_dgemm(CblasColMajor, CblasNoTrans, CblasNoTrans, n, n, n, 1.0, A.data(), n,
                          B.data(), n, 0.0, C.data(), n);
              benchmark::DoNotOptimize(C.data());
            }
          })
          ->Unit(benchmark::kNanosecond)
          ->UseRealTime();
    }
  }
}

// abi's counted floating-point operations (all but comparisons) for the M⁻¹ pipeline.
double abiFlops(Topology t, int n) {
  const Problem& p = problem(t, n);
  double f = 0;
  for (const StageCount& s : AbiSolver::countStages(p.model, p.q, 0)) f += s.counts.flops();
  return f;
}

// The result file's vectors, or nothing when no file is written.
struct ScratchWriter {
  H5Writer* file;
  void writeVector(const std::string& path, const std::vector<double>& v) {
    if (file) file->writeVector(path, v);
  }
};

double med(const std::string& name) {
  auto it = medians.find(name);
  return it == medians.end() ? 0 : it->second.median;
}

// The ratio table, and the result file unless `out` is empty (a filtered run).
void report(bool full, const std::string& out) {
  std::unique_ptr<H5Writer> file = out.empty() ? nullptr : std::make_unique<H5Writer>(out);
  ScratchWriter h5(file.get());
  if (file) {
    writeProvenance(*file);
    file->setAttribute("/", "experiment", "perf");
    file->setAttribute("/", "mode", full ? "full" : "quick");
    file->setAttribute("/", "seed", static_cast<std::int64_t>(kSeed));
    file->setAttribute("/", "cores", pinning().summary());
    for (const auto& [name, m] : medians) {
      file->writeVector("runs/" + name + "/repetitions_s", m.reps);
      file->setAttribute("runs/" + name, "median_s", m.median);
    }
  }
  const std::vector<int> sizes = perfSizes();
  for (Topology t : {Topology::Serial, Topology::Branched}) {
    const std::string T = topologyName(t);
    auto time = [&](const std::string& s, int n) {
      return med("inverse/" + T + "/" + s + "/" + std::to_string(n));
    };
    // abi against every peer: peer time / abi time, and the same against abi built for generic
    // x86-64 (like Debian's prebuilt peers).
    std::vector<std::string> others;
    for (const std::string& s : peers())
      if (s != "abi") others.push_back(s);
    for (const char* base : {"abi", "abi-generic"}) {
      if (!findSolver(base)) continue;
      std::printf(
          "\n%s, full M^-1 (configure + inverse), medians; ratios = peer time / %s time "
          "(0.00 = not measured at that n)\n%6s %10s",
          T.c_str(), base, "n", (std::string(base) + "_us").c_str());
      for (const std::string& s : others)
        if (s != base)
          std::printf(" %*s", static_cast<int>(std::max<std::size_t>(8, s.size())), s.c_str());
      std::printf("\n");
      std::vector<double> ns;
      std::map<std::string, std::vector<double>> cols;
      for (int n : sizes) {
        const double b = time(base, n);
        if (b == 0) continue;
        ns.push_back(n);
        cols[std::string(base) + "_us"].push_back(b * 1e6);
        std::printf("%6d %10.1f", n, b * 1e6);
        for (const std::string& s : others) {
          if (s == base) continue;
          const double x = time(s, n), r = x > 0 ? x / b : 0.0;
          cols[s + "_over_" + (std::string(base) == "abi" ? "abi" : "abi_generic")].push_back(r);
          std::printf(" %*.2f", static_cast<int>(std::max<std::size_t>(8, s.size())), r);
        }
        std::printf("\n");
      }
      const std::string g =
          std::string("ratios/") + T + (std::string(base) == "abi" ? "" : "/generic");
      h5.writeVector(g + "/n", ns);
      for (const auto& [name, v] : cols) h5.writeVector(g + "/" + name, v);
    }
    // abi's own figures: counted rate, share of dgemm's rate, the memory floor, 2 threads and two
    // copies at once, M⁻¹R.
    std::printf("\n%s, abi: %6s %9s %7s %9s %8s %8s %10s\n", T.c_str(), "n", "GF/s", "%dgemm",
                "abi/store", "2thr", "2copies", "solve8:lap");
    std::vector<double> ns, cols[6];
    for (int n : sizes) {
      const std::string N = std::to_string(n);
      const double abi = time("abi", n);
      if (abi == 0) continue;
      const double gflops = abiFlops(t, n) / abi * 1e-9;
      const double dg = med("dgemm/" + N);
      const double dgemm_rate = dg > 0 ? 2.0 * n * n * n / dg * 1e-9 : 0;
      const double store = med("store/" + N);
      const double thr2 = med("inverse/" + T + "/abi@2/" + N);
      const double copies = med("copies/" + T + "/abi/" + N);
      const double s8 = med("solve/" + T + "/abi/" + N + "/8");
      const double l8 = med("solve/" + T + "/lapack/" + N + "/8");
      const double row[6] = {gflops,
                             dgemm_rate > 0 ? 100 * gflops / dgemm_rate : 0,
                             store > 0 ? abi / store : 0,
                             thr2 > 0 ? abi / thr2 : 0,
                             copies > 0 ? 2 * abi / copies : 0,
                             s8 > 0 ? l8 / s8 : 0};
      std::printf("%*s %6d %9.2f %7.1f %9.2f %8.2f %8.2f %10.1f\n", static_cast<int>(T.size() + 5),
                  "", n, row[0], row[1], row[2], row[3], row[4], row[5]);
      ns.push_back(n);
      for (int c = 0; c < 6; ++c) cols[c].push_back(row[c]);
    }
    const char* names[6] = {"abi_gflops",          "abi_percent_of_dgemm",
                            "abi_over_store",      "abi_2thread_speedup",
                            "abi_2copies_speedup", "lapack_over_abi_solve8"};
    h5.writeVector("abi/" + T + "/n", ns);
    for (int c = 0; c < 6; ++c) h5.writeVector("abi/" + T + "/" + names[c], cols[c]);
    // Why a peer has no point at some n: the skip table's reasons.
    for (const std::string& s : others)
      for (int n : sizes)
        if (auto why = skipReason(s, "perf", T, n, full ? "full" : "quick")) {
          if (file) file->setAttribute("ratios/" + T, "skipped_" + s, *why);
          break;
        }
  }
  // Where abi's time goes on the serial chain (one thread).
  std::printf(
      "\nserial, abi's parts (one thread), medians in us: inverse = sweeps + writes "
      "(of M^-1's entries); pipeline = configure + inverse\n");
  std::printf("%6s %10s %10s %10s %10s %10s %10s\n", "n", "configure", "sweeps", "writes",
              "inverse", "store", "pipeline");
  std::vector<double> pn, parts[6];
  for (int n : {16, 32, 64, 256, 512, 1024, 2048, 4096}) {
    const std::string N = std::to_string(n);
    const double c = med("parts/serial/configure/" + N), sw = med("parts/serial/sweeps/" + N),
                 bl = med("parts/serial/blocks/" + N);
    if (c == 0) continue;
    const double row[6] = {c * 1e6,
                           sw * 1e6,
                           (bl - sw) * 1e6,
                           bl * 1e6,
                           med("store/" + N) * 1e6,
                           med("inverse/serial/abi/" + N) * 1e6};
    std::printf("%6d %10.1f %10.1f %10.1f %10.1f %10.1f %10.1f\n", n, row[0], row[1], row[2],
                row[3], row[4], row[5]);
    pn.push_back(n);
    for (int k = 0; k < 6; ++k) parts[k].push_back(row[k]);
  }
  const char* pnames[6] = {"configure_us", "sweeps_us", "writes_us",
                           "inverse_us",   "store_us",  "pipeline_us"};
  if (!pn.empty()) {
    h5.writeVector("parts/serial/n", pn);
    for (int k = 0; k < 6; ++k) h5.writeVector("parts/serial/" + std::string(pnames[k]), parts[k]);
  }
  // One triangle: inverseUpper against the full inverse and the store of n² doubles.
  std::printf("\nserial, M^-1's upper triangle only (inverseUpper, one thread), medians in us\n");
  std::printf("%6s %10s %10s %10s %12s %10s %12s\n", "n", "abi full", "abi upper", "upper/full",
              "upper/store", "lapack up", "lapack/abi");
  std::vector<double> un, ucols[5];
  for (int n : sizes) {
    const std::string N = std::to_string(n);
    const double up = med("upper/serial/abi/" + N), whole = med("inverse/serial/abi/" + N);
    if (up == 0 || whole == 0) continue;
    const double store = med("store/" + N), lap = med("upper/serial/lapack/" + N);
    const double row[5] = {whole * 1e6, up * 1e6, up / whole, store > 0 ? up / store : 0,
                           lap > 0 ? lap / up : 0};
    std::printf("%6d %10.1f %10.1f %10.2f %12.2f %10.1f %12.2f\n", n, row[0], row[1], row[2],
                row[3], lap * 1e6, row[4]);
    un.push_back(n);
    for (int k = 0; k < 5; ++k) ucols[k].push_back(row[k]);
  }
  const char* unames[5] = {"abi_full_us", "abi_upper_us", "upper_over_full", "upper_over_store",
                           "lapack_upper_over_abi_upper"};
  if (!un.empty()) {
    h5.writeVector("upper/serial/n", un);
    for (int k = 0; k < 5; ++k) h5.writeVector("upper/serial/" + std::string(unames[k]), ucols[k]);
  }
  // abi at each instruction-set level (serial chain, one thread), and each over the level in use.
  const std::string used = isaName(abiLevel());
  std::printf("\nserial, abi per instruction-set level (in use: %s), medians in us; / %s\n%6s",
              used.c_str(), used.c_str(), "n");
  std::vector<Isa> levels;
  for (Isa l : abiLevels())
    if (abiLevelUsable(l)) levels.push_back(l);
  for (Isa l : levels) std::printf(" %10s %7s", isaName(l), "ratio");
  std::printf("\n");
  std::vector<double> ln;
  std::map<std::string, std::vector<double>> lcols;
  for (int n : sizes) {
    const std::string N = std::to_string(n);
    const double base = med("inverse/serial/abi-" + used + "/" + N);
    if (base == 0) continue;
    ln.push_back(n);
    std::printf("%6d", n);
    for (Isa l : levels) {
      const double x = med("inverse/serial/abi-" + std::string(isaName(l)) + "/" + N);
      lcols[std::string(isaName(l)) + "_us"].push_back(x * 1e6);
      lcols[std::string(isaName(l)) + "_over_" + used].push_back(x / base);
      std::printf(" %10.1f %7.2f", x * 1e6, x / base);
    }
    std::printf("\n");
  }
  if (!ln.empty()) {
    h5.writeVector("levels/serial/n", ln);
    for (const auto& [name, v] : lcols) h5.writeVector("levels/serial/" + name, v);
    if (file) file->setAttribute("levels/serial", "level_in_use", used);
  }
  if (!file) return;
  file->commit();
  std::printf("\nwrote %s\n", out.c_str());
}

// One inverse of an n-chain; peak resident memory beyond the n² output, printed and written
// (with the provenance) to `out`.
int memoryRun(int n, const std::string& out) {
  const Problem& p = problem(Topology::Serial, n);
  const std::unique_ptr<Solver> abi = makeSolver("abi");
  Solver& s = *abi;
  s.prepare(p.model);
  Eigen::MatrixXd X = outputMatrix(n, n);  // resident before we measure
  rusage before{};
  getrusage(RUSAGE_SELF, &before);
  const auto t0 = std::chrono::steady_clock::now();
  s.configure(p.q);
  s.inverse(X);
  const double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  rusage after{};
  getrusage(RUSAGE_SELF, &after);
  const double out_mib = 8.0 * n * n / (1 << 20), peak = after.ru_maxrss / 1024.0;
  const double growth = (after.ru_maxrss - before.ru_maxrss) / 1024.0;
  const bool finite = X.allFinite();
  std::printf(
      "memory: n = %d, M^-1 is %.0f MiB; inverse took %.2f s; peak RSS %.0f MiB "
      "(%.1f MiB beyond the output); rss growth during configure+inverse %.1f MiB; "
      "finite: %s\n",
      n, out_mib, secs, peak, peak - out_mib, growth, finite ? "yes" : "no");
  H5Writer h5(out);
  writeProvenance(h5);
  h5.setAttribute("/", "experiment", "perf_memory");
  h5.setAttribute("/", "seed", static_cast<std::int64_t>(kSeed));
  h5.writeVector("n", std::vector<double>{double(n)});
  h5.writeVector("seconds", std::vector<double>{secs});
  h5.writeVector("output_mib", std::vector<double>{out_mib});
  h5.writeVector("peak_rss_mib", std::vector<double>{peak});
  h5.writeVector("rss_growth_mib", std::vector<double>{growth});
  h5.commit();
  return finite ? 0 : 1;
}

}  // namespace
}  // namespace minv

int main(int argc, char** argv) {
  using namespace minv;
  bool full = false;
  int memory_n = 0;
  std::string out;
  // Our flags first; the rest go to Google Benchmark.
  std::vector<char*> rest = {argv[0]};
  for (int i = 1; i < argc; ++i) {
    if (!std::strcmp(argv[i], "--full")) {
      full = true;
    } else if (!std::strcmp(argv[i], "--out") && i + 1 < argc) {
      out = argv[++i];
    } else if (!std::strcmp(argv[i], "--isa") && i + 1 < argc) {
      setenv("MINV_ISA", argv[++i], 1);  // abi's level (solvers/abi_variants.hpp)
    } else if (!std::strcmp(argv[i], "--memory-n") && i + 1 < argc) {
      memory_n = std::atoi(argv[++i]);
    } else {
      rest.push_back(argv[i]);
    }
  }
  silenceHdf5Errors();
  try {
    const AbiVariantApi& v = abiVariant(abiLevel());
    std::printf("abi: level %s (%s; widest %s, %d lanes)\n", v.level, v.target, v.widest, v.lanes);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "bench_abi: error: %s\n", e.what());
    return 2;
  }
  openblas_set_num_threads(1);  // single thread unless a benchmark says otherwise
  // A filtered or listing run prints its table but writes no result file unless asked to.
  bool partial = false;
  for (char* a : rest)
    partial |= !std::strncmp(a, "--benchmark_filter", 18) ||
               !std::strncmp(a, "--benchmark_list_tests", 22);
  if (out.empty() && !(partial && memory_n == 0))
    out = memory_n > 0 ? "results/perf_memory.h5" : "results/perf.h5";
  if (memory_n > 0) {
    try {
      return memoryRun(memory_n, out);
    } catch (const std::exception& e) {
      std::fprintf(stderr, "bench_abi: error: %s\n", e.what());
      return 2;
    }
  }
  // Repetitions of all benchmarks run in a random interleaved order, so a slow spell of this
  // shared machine falls on every solver alike rather than on one of a pair being compared.
  std::string reps = "--benchmark_repetitions=5", mint = "--benchmark_min_time=0.02",
              mix = "--benchmark_enable_random_interleaving=true";
  rest.insert(rest.begin() + 1, {reps.data(), mint.data(), mix.data()});
  int n = static_cast<int>(rest.size());
  benchmark::Initialize(&n, rest.data());
  if (benchmark::ReportUnrecognizedArguments(n, rest.data())) return 2;
  // Single-threaded unless a benchmark says otherwise: on the fastest core.
  std::printf("cores: %s\n", pinning().summary().c_str());
  pinning().pinFastest();
  registerAll(full);
  Collector collector;
  benchmark::RunSpecifiedBenchmarks(&collector);
  try {
    report(full, out);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "bench_abi: error: %s\n", e.what());
    return 2;
  }
  return 0;
}
