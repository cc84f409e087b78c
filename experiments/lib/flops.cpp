#include "experiments/lib/flops.hpp"

#include <Eigen/QR>
#include <algorithm>
#include <cstdio>
#include <stdexcept>

#include "experiments/lib/h5writer.hpp"
#include "experiments/lib/provenance.hpp"
#include "solvers/abi.hpp"

namespace minv {

std::vector<StageCount> countSolver(const std::string& solver, const Model& model,
                                    const Eigen::VectorXd& q, int m) {
  for (const SolverEntry& e : solverRegistry()) {
    if (e.name != solver) continue;
    if (!e.count) throw std::invalid_argument("solver '" + solver + "' has no operation counter");
    return e.count(model, q, m);
  }
  makeSolver(solver);  // throws the registry's "unknown solver" message
  return {};
}

namespace {
// A mark hook that books stages like StageCounter and also keeps, per stage, the largest
// count booked by a single mark (one column of the impulse sweeps).
struct ColumnMaxMark {
  StageCounter stages;
  std::vector<std::pair<std::string, FlopCounts>> max;
  FlopCounts last = flopTotal();

  void operator()(const char* stage) {
    const FlopCounts now = flopTotal();
    const FlopCounts delta = now - last;
    last = now;
    stages(stage);
    auto it = std::find_if(max.begin(), max.end(), [&](auto& p) { return p.first == stage; });
    if (it == max.end()) {
      max.emplace_back(stage, delta);
    } else if (delta.mul + delta.add > it->second.mul + it->second.add) {
      it->second = delta;
    }
  }
};

}  // namespace

std::vector<StageCount> abiParallelCounts(const Model& model, const Eigen::VectorXd& q) {
  // abi marks each sweep once per block of kAbiLanes<T> columns: the largest count booked by a
  // single mark is one column's only when a block is one column wide.
  static_assert(kAbiLanes<Counted> == 1,
                "abiParallelCounts (ColumnMaxMark) takes one mark of abi's impulse sweeps for one "
                "column: the counting scalar must run abi one lane (one column) per block");
  flopReset();
  ColumnMaxMark mark;
  abiPipeline<Counted>(model, q, 0, mark);
  std::vector<StageCount> out;
  for (const auto& [stage, counts] : mark.stages.stages()) {
    // Articulated inertias are sequential; every other stage is its costliest body or column.
    FlopCounts c = counts;
    if (stage != "articulated inertias")
      for (const auto& [name, mx] : mark.max)
        if (name == stage) c = mx;
    out.push_back({stage, c, false});
  }
  return out;
}

Eigen::VectorXd leastSquares(const Eigen::MatrixXd& B, const Eigen::VectorXd& y) {
  return B.colPivHouseholderQr().solve(y);
}

std::pair<double, double> dofDepthSums(const Model& model) {
  const std::vector<int>& lambda = model.dofParent();
  std::vector<int> d(lambda.size());
  double s1 = 0, s2 = 0;
  for (size_t k = 0; k < lambda.size(); ++k) {
    d[k] = lambda[k] < 0 ? 1 : d[lambda[k]] + 1;
    s1 += d[k];
    s2 += double(d[k]) * d[k];
  }
  return {s1, s2};
}

void printStageTable(std::ostream& os, const std::string& solver,
                     const std::vector<StageCount>& stages) {
  char line[200];
  std::snprintf(line, sizeof line, "%-8s %-24s %12s %12s %10s %8s %8s %8s\n", "solver", "stage",
                "mul", "add", "div", "sqrt", "trig", "cmp");
  os << line;
  FlopCounts total;
  bool documented = false;
  for (const StageCount& s : stages) {
    const FlopCounts& c = s.counts;
    std::snprintf(line, sizeof line, "%-8s %-24s %12llu %12llu %10llu %8llu %8llu %8llu%s\n",
                  solver.c_str(), s.stage.c_str(), (unsigned long long)c.mul,
                  (unsigned long long)c.add, (unsigned long long)c.div, (unsigned long long)c.sqrt,
                  (unsigned long long)c.trig, (unsigned long long)c.cmp,
                  s.documented ? "  (documented, LAWN 41)" : "");
    os << line;
    total += c;
    documented |= s.documented;
  }
  std::snprintf(line, sizeof line, "%-8s %-24s %12llu %12llu %10llu %8llu %8llu %8llu%s\n",
                solver.c_str(), "total", (unsigned long long)total.mul,
                (unsigned long long)total.add, (unsigned long long)total.div,
                (unsigned long long)total.sqrt, (unsigned long long)total.trig,
                (unsigned long long)total.cmp, documented ? "  (part documented)" : "");
  os << line;
}

namespace {
const char* kFields[] = {"mul", "add", "div", "sqrt", "cmp", "trig"};

double field(const FlopCounts& c, int f) {
  const std::uint64_t v[] = {c.mul, c.add, c.div, c.sqrt, c.cmp, c.trig};
  return static_cast<double>(v[f]);
}

// Counts of one solver over the sweep's points: stage → point → counts.
struct Series {
  std::vector<std::string> stages;
  std::vector<bool> documented;
  std::vector<std::vector<FlopCounts>> counts;  // [stage][point]

  void add(const std::vector<StageCount>& point, size_t index) {
    FlopCounts total;
    for (const StageCount& s : point) {
      auto it = std::find(stages.begin(), stages.end(), s.stage);
      if (it == stages.end()) {
        stages.push_back(s.stage);
        documented.push_back(s.documented);
        counts.emplace_back();
        it = stages.end() - 1;
      }
      auto& v = counts[it - stages.begin()];
      v.resize(index + 1);
      v[index] = s.counts;
      total += s.counts;
    }
    if (std::find(stages.begin(), stages.end(), "total") == stages.end()) {
      stages.push_back("total");
      documented.push_back(false);
      counts.emplace_back();
    }
    auto& v = counts.back();
    v.resize(index + 1);
    v[index] = total;
  }
};
}  // namespace

void runFlopsSweep(const FlopsSweep& sweep, const std::string& path, std::ostream& log) {
  H5Writer out(path);
  writeProvenance(out);
  out.setAttribute("/", "experiment", "flops");
  out.setAttribute("/", "seed", static_cast<std::int64_t>(sweep.seed));
  for (Topology topology : sweep.topologies)
    for (bool floating : sweep.floating) {
      const std::string config =
          std::string(topologyName(topology)) + (floating ? "_floating" : "_fixed");
      log << "flops: " << config << " n =";
      std::vector<int> nv;
      std::vector<double> s1, s2;
      std::vector<std::pair<std::string, Series>> series;
      auto seriesOf = [&](const std::string& name) -> Series& {
        for (auto& [s, v] : series)
          if (s == name) return v;
        return series.emplace_back(name, Series{}).second;
      };
      for (size_t p = 0; p < sweep.n.size(); ++p) {
        const int n = sweep.n[p];
        log << " " << n << std::flush;
        const Model model = randomTree({topology, n, sweep.seed, floating, JointSet::Revolute});
        const Eigen::VectorXd q = randomConfiguration(model, sweep.seed);
        nv.push_back(model.nv());
        const auto [d1, d2] = dofDepthSums(model);
        s1.push_back(d1);
        s2.push_back(d2);
        // Every counted solver of the registry, then abi's per-processor count.
        for (const SolverEntry& e : solverRegistry())
          if (e.count) seriesOf(e.name).add(e.count(model, q, 0), p);
        seriesOf("abi_parallel").add(abiParallelCounts(model, q), p);
      }
      log << "\n";
      out.writeIntVector(config + "/nv", nv);
      out.writeVector(config + "/depth_sum", s1);
      out.writeVector(config + "/depth_sq_sum", s2);
      // Bases of the fits: polynomial in nv, and the depth sums. The polynomial is fitted from
      // kRun + 1 links on: a shorter chain has no run of links long enough for the articulated
      // pass's regrouped step (core/articulated.hpp), so its counts follow another polynomial.
      const int P = static_cast<int>(nv.size());
      std::vector<int> from;
      for (int i = 0; i < P; ++i)
        if (sweep.n[i] > kRun) from.push_back(i);
      Eigen::MatrixXd poly(from.size(), 4), depth(P, 4);
      for (int i = 0; i < P; ++i) depth.row(i) << s2[i], s1[i], nv[i], 1;
      for (std::size_t r = 0; r < from.size(); ++r) {
        const double x = nv[from[r]];
        poly.row(r) << x * x * x, x * x, x, 1;
      }
      out.setAttribute(config, "poly_fit_from_links", static_cast<std::int64_t>(kRun + 1));
      for (const auto& [solver, s] : series) {
        const std::string g = config + "/" + solver;
        out.writeStrings(g + "/stages", s.stages);
        for (size_t k = 0; k < s.stages.size(); ++k) {
          const std::string sg = g + "/" + s.stages[k];
          out.createGroup(sg);
          out.setAttribute(sg, "documented", static_cast<std::int64_t>(s.documented[k]));
          for (int f = 0; f < 6; ++f) {
            Eigen::VectorXd y(P);
            for (int i = 0; i < P; ++i) y(i) = field(s.counts[k][i], f);
            out.writeVector(sg + "/" + kFields[f], y);
            Eigen::VectorXd yp(from.size());
            for (std::size_t r = 0; r < from.size(); ++r) yp(r) = y(from[r]);
            out.writeVector(sg + "/" + kFields[f] + "_fit_poly", leastSquares(poly, yp));
            out.writeVector(sg + "/" + kFields[f] + "_fit_depth", leastSquares(depth, y));
          }
        }
      }
    }
  out.commit();
  log << "flops: wrote " << path << "\n";
}

}  // namespace minv
