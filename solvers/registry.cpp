// The one registry: a solver is one adapter class plus one line here.
#include <sstream>
#include <stdexcept>

#include "solvers/abi.hpp"
#include "solvers/eigen.hpp"
#include "solvers/lapack.hpp"
#include "solvers/ltdl.hpp"
#include "solvers/ltl.hpp"
#include "solvers/naive.hpp"
#ifdef MINV_HAVE_MUJOCO
#include "solvers/mujoco.hpp"
#endif

namespace minv {

namespace {
// A solver class T with a static countStages(model, q, m) gets it registered as its counter.
template <class T>
SolverEntry entry(const char* name, const char* summary) {
  SolverEntry e{name, summary, [] { return std::unique_ptr<Solver>(new T()); }, {}};
  if constexpr (requires { &T::countStages; }) e.count = &T::countStages;
  return e;
}
}  // namespace

const std::vector<SolverEntry>& solverRegistry() {
  static const std::vector<SolverEntry> registry = {
      entry<AbiSolver>("abi", "Θ(n²) M⁻¹ from articulated-body inertias (Drumwright Alg. 1-2)"),
      entry<LapackSolver>("lapack", "CRBA + LAPACKE dpotrf/dpotri/dpotrs (OpenBLAS)"),
      entry<LtlSolver>("ltl", "CRBA + Featherstone 2005 branch-induced-sparsity LᵀL"),
      entry<LtdlSolver>("ltdl", "CRBA + Featherstone 2005 branch-induced-sparsity LᵀDL"),
      entry<NaiveSolver>("naive", "CRBA + textbook dense Cholesky, no library"),
      entry<EigenSolver>("eigen", "CRBA + Eigen::LLT blocked dense Cholesky"),
#ifdef MINV_HAVE_MUJOCO
      entry<MujocoSolver>("mujoco", "MuJoCo 2.2.2: MJCF model, mj_crb + mj_factorM + mj_solveM"),
#endif
  };
  return registry;
}

std::vector<std::string> solverNames() {
  std::vector<std::string> names;
  for (const SolverEntry& e : solverRegistry()) names.push_back(e.name);
  return names;
}

std::unique_ptr<Solver> makeSolver(const std::string& name) {
  for (const SolverEntry& e : solverRegistry())
    if (e.name == name) return e.make();
  std::ostringstream known;
  for (const SolverEntry& e : solverRegistry()) known << (known.tellp() ? ", " : "") << e.name;
  throw std::invalid_argument("unknown solver '" + name + "' (known: " + known.str() + ")");
}

}  // namespace minv
