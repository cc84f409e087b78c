#include "experiments/lib/timing.hpp"

#include <omp.h>

#include <Eigen/Core>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <memory>
#include <stdexcept>
#include <thread>

#include "experiments/lib/cores.hpp"
#include "experiments/lib/h5reader.hpp"
#include "experiments/lib/h5writer.hpp"
#include "experiments/lib/output_matrix.hpp"
#include "experiments/lib/provenance.hpp"
#include "generators/random_tree.hpp"
#include "solvers/solver.hpp"

extern "C" void openblas_set_num_threads(int);

namespace minv {

std::string TimingPoint::name() const {
  char buf[64];
  std::snprintf(buf, sizeof buf, ".n%05d.m%d.t%d", n, m, threads);
  return family + "." + solver + "." + topology + "." + (floating ? "floating" : "fixed") + buf;
}

std::vector<int> logSpaced(int lo, int hi, int per_octave) {
  std::vector<int> out;
  const double steps = std::log2(static_cast<double>(hi) / lo) * per_octave;
  for (int k = 0; k <= static_cast<int>(std::lround(steps)); ++k) {
    const int v =
        static_cast<int>(std::lround(lo * std::exp2(static_cast<double>(k) / per_octave)));
    if (v <= hi && (out.empty() || v != out.back())) out.push_back(v);
  }
  return out;
}

TimingSweep timingSweep(const std::string& mode) {
  TimingSweep s;
  s.mode = mode;
  if (mode == "tiny") {
    s.min_time = 0.002;
    s.repetitions = 3;
    s.blocks = {{"pipeline", {"abi", "lapack"}, {"serial", "branched"}, {false}, {4, 8}, {0}, {1}},
                {"kernel", {"abi", "lapack"}, {"serial"}, {false}, {8}, {0, 4}, {1}}};
    return s;
  }
  int hi;
  if (mode == "quick") {
    hi = 1024;
  } else if (mode == "full") {
    hi = 4096;
    s.min_time = 0.05;
  } else {
    throw std::invalid_argument("unknown sweep mode '" + mode + "' (expected quick, full or tiny)");
  }
  const bool full = mode == "full";
  SweepBlock pipeline{"pipeline", {}, {"serial", "branched"}, {false, true}, logSpaced(8, hi, 2)};
  SweepBlock kernel{"kernel",     {}, {"serial", "branched"}, {false}, logSpaced(8, hi, 1),
                    {0, 1, 8, 64}};
  if (full) kernel.floating = {false, true};
  SweepBlock threads{"threads", {"abi", "lapack"}, {"serial"}, {false}, logSpaced(64, hi, 1),
                     {0},       {1, 2, 4}};
  s.blocks = {pipeline, kernel, threads};
  return s;
}

std::vector<TimingPoint> sweepPoints(const TimingSweep& sweep) {
  std::vector<TimingPoint> out;
  const std::vector<std::string> registered = solverNames();
  for (const SweepBlock& b : sweep.blocks) {
    std::vector<std::string> solvers;
    for (const std::string& name : registered)
      if (b.solvers.empty() ||
          std::find(b.solvers.begin(), b.solvers.end(), name) != b.solvers.end())
        solvers.push_back(name);
    for (const std::string& topo : b.topologies)
      for (bool fl : b.floating)
        for (int n : b.n)
          for (const std::string& solver : solvers)
            for (int m : b.m)
              for (int t : b.threads) out.push_back({b.family, solver, topo, fl, n, m, t});
  }
  return out;
}

Shard parseShard(const std::string& text) {
  const auto slash = text.find('/');
  auto number = [&](const std::string& s) {
    if (s.empty() || s.find_first_not_of("0123456789") != std::string::npos || s.size() > 6)
      throw std::invalid_argument("bad shard '" + text + "' (expected i/N with 0 <= i < N)");
    return std::stoi(s);
  };
  if (slash == std::string::npos)
    throw std::invalid_argument("bad shard '" + text + "' (expected i/N with 0 <= i < N)");
  Shard s{number(text.substr(0, slash)), number(text.substr(slash + 1))};
  if (s.count < 1 || s.index >= s.count)
    throw std::invalid_argument("bad shard '" + text + "' (expected i/N with 0 <= i < N)");
  return s;
}

std::vector<TimingPoint> shardPoints(const std::vector<TimingPoint>& points, Shard shard) {
  std::vector<TimingPoint> out;
  for (std::size_t i = 0; i < points.size(); ++i)
    if (static_cast<int>(i % shard.count) == shard.index) out.push_back(points[i]);
  return out;
}

namespace {

void setBaselineThreads() {
  openblas_set_num_threads(1);
  omp_set_num_threads(1);
}

void writePointAttributes(H5Writer& h5, const std::string& g, const TimingPoint& p,
                          const TimingSweep& sweep) {
  h5.setAttribute(g, "family", p.family);
  h5.setAttribute(g, "solver", p.solver);
  h5.setAttribute(g, "topology", p.topology);
  h5.setAttribute(g, "base", p.floating ? "floating" : "fixed");
  h5.setAttribute(g, "n", p.n);
  h5.setAttribute(g, "m", p.m);
  h5.setAttribute(g, "threads", p.threads);
  h5.setAttribute(g, "seed", sweep.seed);
  h5.setAttribute(g, "mode", sweep.mode);
}

}  // namespace

SweepStats runTimingSweep(const TimingSweep& sweep, Shard shard, const std::string& path,
                          const MeasureFn& measure, std::ostream& log) {
  // Resumed points must have been measured as this run would measure them.
  requireSameSettings(path, "output file",
                      {{"experiment", "timing"},
                       {"mode", sweep.mode},
                       {"seed", sweep.seed},
                       {"min_time_s", sweep.min_time},
                       {"repetitions", sweep.repetitions}});
  // Each core's speed, measured by every sweep (before OpenMP is held to one thread, so that
  // its workers start on every core); one-thread points run on the fastest core, points on
  // several threads on every core (experiments/lib/cores.hpp: a VM's cores need not be equal,
  // and a one-thread point on the slower one made Figure 3's two-thread speed-up look
  // superlinear, 2.03× at n = 1024 on the 2-vCPU Zen 5 guest).
  const CorePinning pinning;
  setBaselineThreads();
  log << "cores: " << pinning.summary() << std::endl;
  const std::vector<TimingPoint> all = sweepPoints(sweep);
  const std::vector<TimingPoint> points = shardPoints(all, shard);
  H5Writer h5 = H5Writer::append(path);
  h5.setAttribute("/", "experiment", "timing");
  h5.setAttribute("/", "mode", sweep.mode);
  h5.setAttribute("/", "seed", sweep.seed);
  h5.setAttribute("/", "min_time_s", sweep.min_time);
  h5.setAttribute("/", "repetitions", sweep.repetitions);
  h5.setAttribute("/", "points_in_sweep", static_cast<int>(all.size()));
  h5.setAttribute("/", "shard", std::to_string(shard.index) + "/" + std::to_string(shard.count));
  h5.setAttribute("/", "timer", "Google Benchmark 1.7.1, real time per iteration");
  writeProvenance(h5, "/");
  h5.setAttribute("/", "cores", pinning.summary());
  h5.createGroup("points");
  h5.flush();

  SweepStats stats;
  int k = 0;
  for (const TimingPoint& p : points) {
    ++k;
    const std::string name = "points/" + p.name();
    char head[48];
    std::snprintf(head, sizeof head, "[%d/%zu] ", k, points.size());
    if (h5.hasGroup(name)) {
      ++stats.resumed;
      continue;
    }
    const Model model = randomTree({topologyFromName(p.topology), p.n, sweep.seed, p.floating});
    std::unique_ptr<Solver> solver = makeSolver(p.solver);
    std::string why;
    std::optional<std::string> skip = skipReason(p.solver, p.family, p.topology, p.n, sweep.mode);
    if (!skip && !solver->supports(model, &why)) skip = "solver does not support the tree: " + why;
    if (skip) {
      const std::string g = h5.beginPoint(name);
      writePointAttributes(h5, g, p, sweep);
      h5.setAttribute(g, "nv", model.nv());
      h5.setAttribute(g, "status", "skipped");
      h5.setAttribute(g, "skipped", *skip);
      h5.endPoint(name);
      ++stats.skipped;
      log << head << p.name() << " skipped: " << *skip << std::endl;
      continue;
    }
    // Untimed set-up: model, prepare, q, R, outputs; threads.
    const Eigen::VectorXd q = randomConfiguration(model, sweep.seed);
    const int nv = model.nv();
    solver->prepare(model);
    solver->setThreads(p.family == "threads" ? p.threads : 1);
    const Eigen::MatrixXd R = randomMatrix(nv, std::max(p.m, 1), sweep.seed + 1);
    Eigen::MatrixXd X = outputMatrix(nv, p.m > 0 ? p.m : nv);
    solver->configure(q);  // warm-up, and the kernel family's untimed configuration
    std::function<void()> body;
    Solver* s = solver.get();
    if (p.family == "kernel") {
      if (p.m == 0)
        body = [s, &X] { s->inverse(X); };
      else
        body = [s, &R, &X] { s->solve(R, X); };
    } else {
      if (p.m == 0)
        body = [s, &q, &X] {
          s->configure(q);
          s->inverse(X);
        };
      else
        body = [s, &q, &R, &X] {
          s->configure(q);
          s->solve(R, X);
        };
    }
    body();
    if (!X.allFinite()) throw std::runtime_error(p.name() + ": non-finite result");
    const int solver_threads = solver->threads();
    // Provenance now, so blas_threads/omp_max_threads are those of the measurement.
    Provenance prov = collectProvenance();
    // Pinned for this point only, and released however it ends (a caller, such as the Python
    // module's, keeps its thread).
    struct Pinned {
      const CorePinning& pinning;
      ~Pinned() { pinning.release(); }
    } pinned{pinning};
    if (p.threads == 1) pinning.pinFastest();
    const Measurement meas = measure(p.name(), body, sweep);
    solver.reset();
    setBaselineThreads();
    // After a point on several threads, a pause: OpenBLAS's idle workers spin for about 0.1 s
    // after their last call, and on a 2-core machine they took the core that the next point's
    // second OpenMP thread needed (abi's two-thread point at n = 256 right after lapack's
    // four-thread point at 128: 192 us against 71 us on one thread).
    if (p.threads > 1) std::this_thread::sleep_for(std::chrono::milliseconds(250));
    if (meas.real_s.empty()) throw std::runtime_error(p.name() + ": no repetitions measured");

    const std::string g = h5.beginPoint(name);
    writePointAttributes(h5, g, p, sweep);
    h5.setAttribute(g, "status", "ok");
    h5.setAttribute(g, "nv", nv);
    h5.setAttribute(g, "nb", model.nb());
    h5.setAttribute(g, "max_depth", model.maxDepth());
    h5.setAttribute(g, "solver_threads", solver_threads);
    h5.setAttribute(g, "repetitions", static_cast<int>(meas.real_s.size()));
    h5.setAttribute(g, "min_time_s", sweep.min_time);
    h5.writeVector(g + "/real_time_s", meas.real_s);
    h5.writeVector(g + "/cpu_time_s", meas.cpu_s);
    h5.writeIntVector(g + "/iterations", meas.iterations);
    h5.writeIntVector(g + "/parent", model.parents());
    // The measuring process (shards may run on different nodes); the root has the rest.
    h5.setAttribute(g, "hostname", prov.hostname);
    h5.setAttribute(g, "cpu_model", prov.cpu_model);
    h5.setAttribute(g, "date_utc", prov.date_utc);
    h5.setAttribute(g, "git_sha", prov.git_sha);
    h5.setAttribute(g, "blas_threads", prov.blas_threads);
    h5.setAttribute(g, "omp_max_threads", prov.omp_max_threads);
    h5.endPoint(name);
    ++stats.measured;
    std::vector<double> sorted = meas.real_s;
    std::sort(sorted.begin(), sorted.end());
    char line[96];
    std::snprintf(line, sizeof line, " median %.4g s (%zu reps)", sorted[sorted.size() / 2],
                  sorted.size());
    log << head << p.name() << line << std::endl;
  }
  h5.commit();
  return stats;
}

}  // namespace minv
