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
#include <stdexcept>
#include <string>
#include <vector>

#include "core/counting.hpp"
#include "core/model.hpp"

namespace minv {

// Outputs are the caller's memory, sized by the caller: a MatrixXd, a block of one, or a
// numpy array (column-major, any column stride); a solver never resizes them. Inputs likewise.
using MatrixOut = Eigen::Ref<Eigen::MatrixXd>;
using MatrixIn = const Eigen::Ref<const Eigen::MatrixXd>&;

// The most threads a solver or the simulator takes: OpenMP could not start a team of tens of
// thousands (libgomp crashed at 65 536), and abi keeps a configuration per thread.
inline constexpr int kMaxThreads = 512;
// Throws std::invalid_argument naming `what` unless 1 ≤ n ≤ kMaxThreads.
inline void checkThreads(int n, const std::string& what = "threads") {
  if (n < 1 || n > kMaxThreads)
    throw std::invalid_argument(what + " must be between 1 and " + std::to_string(kMaxThreads) +
                                ", got " + std::to_string(n));
}

class Solver {
 public:
  virtual ~Solver() = default;
  // Whether this solver can handle the tree at all (a peer library may have limits); if not,
  // *why says so. The conformance suite and the experiments skip it with that reason.
  virtual bool supports(const Model& model, std::string* why) const { return true; }
  // Threads this solver may use from now on (default 1; 1 ≤ n ≤ kMaxThreads, which callers
  // taking n from a user check with checkThreads). Solvers without a parallel path ignore it;
  // `threads()` says what they will actually use.
  virtual void setThreads(int n) {}
  virtual int threads() const { return 1; }
  // Allocate for this tree; the model must outlive the solver.
  virtual void prepare(const Model& model) = 0;
  // Per configuration q (size model.nq()).
  virtual void configure(const Eigen::VectorXd& q) = 0;
  // Minv (nv×nv) = M⁻¹, dense and symmetric; every entry is written.
  virtual void inverse(MatrixOut Minv) = 0;
  // The upper triangle of M⁻¹ (diagonal included) into Minv's upper triangle, for callers that
  // need only one (a symmetric consumer, the contact path); Minv's strictly lower part is left
  // unspecified. By default the full inverse(); a solver that can skip the other half does.
  virtual void inverseUpper(MatrixOut Minv) { inverse(Minv); }
  // X (nv×m) = M⁻¹ R for R (nv×m).
  virtual void solve(MatrixIn R, MatrixOut X) = 0;
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
using CountFn =
    std::function<std::vector<StageCount>(const Model&, const Eigen::VectorXd& q, int m)>;

struct SolverEntry {
  std::string name;     // see validSolverName(): letters, digits, '_' and '-'
  std::string summary;  // one line for `minv solvers`: the method, the library, the precision
  std::function<std::unique_ptr<Solver>()> make;
  CountFn count;  // empty where the solver's arithmetic cannot be counted
};

// Every registered solver: the built-in ones in a fixed order, then those added by
// registerSolver() in the order they were added. The reference stays valid, but a later
// registerSolver() may add to it (take a copy to iterate while registering).
const std::vector<SolverEntry>& solverRegistry();
// The names of the registry, in order.
std::vector<std::string> solverNames();
// Throws std::invalid_argument("unknown solver 'x' (known: …)") for an unknown name.
std::unique_ptr<Solver> makeSolver(const std::string& name);
// The registry entry of `name`, or nullptr.
const SolverEntry* findSolver(const std::string& name);

// Adds a solver from outside this repository (an out-of-tree adapter, a Python class), so that
// the conformance checks (solvers/conformance.hpp), `minv solve --solver all`, `minv flops` and
// the timing sweeps include it. Throws std::invalid_argument for an invalid or taken name, an
// empty summary or no factory.
void registerSolver(SolverEntry entry);
// Removes a solver added by registerSolver() (built-in ones stay); false if there was none.
bool unregisterSolver(const std::string& name);

// A solver name is 1 to 32 characters from [A-Za-z0-9_-], starting with a letter or digit, and
// is none of "all", "test-impulse", "contact-inertia" and "mujoco-step" (words of the `minv`
// command). Returns the reason it is not valid, or an empty string.
std::string solverNameProblem(const std::string& name);

}  // namespace minv
