// The one interface every solver implements, and the one registry every test, experiment and
// plot loops over. A new solver is one adapter (a class below) plus one line in registry.cpp;
// the conformance suite (tests/conformance_test.cpp) then checks it with no new test code.
//
// Life cycle: prepare(model) once per tree (all allocation happens here), configure(q) once
// per configuration (kinematics plus whatever the method needs before a right-hand side,
// e.g. CRBA + factorization, or articulated-body inertias), then any number of inverse() and
// solve() calls, which do not allocate. Outputs are sized by the caller.
#pragma once

#include <Eigen/Core>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "core/counting.hpp"
#include "core/model.hpp"

namespace minv {

class Solver {
 public:
  virtual ~Solver() = default;
  // Whether this solver can handle the tree at all (a peer library may have limits); if not,
  // *why says so. The conformance suite and the experiments skip it with that reason.
  virtual bool supports(const Model& model, std::string* why) const { return true; }
  // Threads this solver may use from now on (default 1). Solvers without a parallel path
  // ignore it; `threads()` says what they will actually use.
  virtual void setThreads(int n) {}
  virtual int threads() const { return 1; }
  // Allocate for this tree; the model must outlive the solver.
  virtual void prepare(const Model& model) = 0;
  // Per configuration q (size model.nq()).
  virtual void configure(const Eigen::VectorXd& q) = 0;
  // Minv (nv×nv) = M⁻¹, dense and symmetric.
  virtual void inverse(Eigen::MatrixXd& Minv) = 0;
  // X (nv×m) = M⁻¹ R for R (nv×m).
  virtual void solve(const Eigen::MatrixXd& R, Eigen::MatrixXd& X) = 0;
};

// Operation counts of one stage of a method: counted by running its kernels on the Counted
// scalar, or, for a library that cannot run on it, its documented counts (LAPACK Working
// Note 41), marked as such.
struct StageCount {
  std::string stage;
  FlopCounts counts;
  bool documented = false;
};

// The stages of a StageCounter as the registry reports them.
inline std::vector<StageCount> stageCounts(const StageCounter& counter) {
  std::vector<StageCount> out;
  for (const auto& [stage, counts] : counter.stages()) out.push_back({stage, counts, false});
  return out;
}

// Counts every stage of a solver's pipeline from q to M⁻¹ (inverse) or to M⁻¹R with m columns.
using CountFn = std::function<std::vector<StageCount>(const Model&, const Eigen::VectorXd& q, int m)>;

struct SolverEntry {
  std::string name;
  std::string summary;  // one line for `minv solvers`
  std::function<std::unique_ptr<Solver>()> make;
  CountFn count;  // empty where the solver's arithmetic cannot be counted
};

// Every registered solver, in a fixed order.
const std::vector<SolverEntry>& solverRegistry();
// The names of the registry, in order.
std::vector<std::string> solverNames();
// Throws std::invalid_argument("unknown solver 'x' (known: …)") for an unknown name.
std::unique_ptr<Solver> makeSolver(const std::string& name);

}  // namespace minv
