// The conformance checks every solver must pass, as a library: the GoogleTest suite
// (tests/conformance_test.cpp) runs them for every registered solver, and a solver written
// outside this repository (C++ through registerSolver(), Python through minv.check) gets the
// same checks, with the same bounds, from checkSolver().
//
// Cases: random serial and branched trees, fixed and floating base, revolute and mixed
// (revolute/prismatic/spherical) joints, n ∈ {1, 2, 3, 7, 32, 100, 300} jointed links, and the
// revolute trees with n ≤ 100 once more after a round trip through URDF, and forests (a floating
// mixed serial tree beside a fixed revolute branched one, n ∈ {32, 300}), chains of masses
// 1e-200 and 1e-300, and chains of spherical joints whose masses alternate between heavy and
// light (1e3 and 1e-3, fixed and floating base, n = 8). q is a seeded random
// configuration. References are independent of the solver under test: M from CRBA (itself
// checked against closed forms and MuJoCo elsewhere) and Xref = M⁻¹ from a dense Cholesky
// (Eigen's LLT) of that M.
//
// Checks, per case (relative Frobenius norms; κ = cond₂(M) from M's eigenvalues, ε the double
// precision unit roundoff, n = nv):
//   inverse        ‖M X − I‖ / ‖I‖                     ≤ tol = 10·(n + 10)·κ·ε
//   upper, lower   each triangle of X against Xref's    ≤ 2·tol   (a solver that computes one
//                  triangle and mirrors it is checked on both, before and after its mirror)
//   symmetric      ‖X − Xᵀ‖ / ‖X‖                       ≤ tol
//   inverseUpper   its upper triangle against Xref's     ≤ 2·tol   (the lower part unread)
//   solve          ‖solve(R) − X R‖ / ‖X R‖, R seeded with 11 columns (a full and a partial SIMD
//                  block of abi's), and its first column alone            ≤ tol
//   finite         X, solve(R) finite
//   reconfigure    configure(q₂) after q gives M(q₂)⁻¹ (a solver must not return a cached
//                  result from an earlier configuration)                ‖M₂X₂ − I‖ ≤ tol₂
//   two threads    with setThreads(2): inverse and ‖M solve(R) − R‖/‖R‖ ≤ tol, symmetric, and
//                  inverseUpper into a block of a larger matrix (a strided output) ≤ 2·tol;
//                  then setThreads(1) and (2) after configure keep the configuration
// A backward-stable inverse has ‖M X − I‖ ≲ c·n·κ·ε; the bound allows c = 10 with a margin of
// 10 in n (so n = 1 still has room for rounding). A solver that does not support a tree
// (Solver::supports) is skipped on it, with its reason in the report.
#pragma once

#include <Eigen/Core>
#include <functional>
#include <memory>
#include <ostream>
#include <string>
#include <utility>
#include <vector>

#include "core/model.hpp"
#include "generators/random_tree.hpp"
#include "solvers/solver.hpp"

namespace minv {

struct ConformanceCase {
  std::string name;  // e.g. "serial_mixed_floating_n32", "serial_revolute_fixed_n7_urdf"
  TreeOptions options;
  bool via_urdf = false;
  // Further trees beside the first, each with its own root (parent −1): a forest.
  std::vector<TreeOptions> beside = {};
  // Every mass and inertia times this: M⁻¹ scales by its inverse, which a solver must follow
  // to the ends of the double range (a product of two masses underflows below 1e-154).
  double mass_scale = 1;
  // Every joint but a floating base made spherical, and the masses and inertias of a tree's
  // bodies times `alternate` and 1/`alternate` in turn (0, 2, 4, … heavy): a light body between
  // heavy ones has a ball-joint D of condition about alternate²·1e3.
  bool spherical = false;
  double alternate = 1;
  // (solver, why): a peer library's own known limit on this case, reported as a skip with
  // the reason (minv cannot mend another library's arithmetic).
  std::vector<std::pair<std::string, std::string>> limits = {};
};

// Which cases to run.
struct ConformanceOptions {
  int max_n = 300;          // the largest n of the case list {1, 2, 3, 7, 32, 100, 300}
  bool urdf = true;         // include the URDF round trips
  bool two_threads = true;  // include the two-thread check
  bool reconfigure = true;  // include the second configuration
};

std::vector<ConformanceCase> conformanceCases(const ConformanceOptions& options = {});

// One case's model, configuration and references, built once per case name and kept for the
// process (thread-safe).
struct ConformanceProblem {
  explicit ConformanceProblem(Model m) : model(std::move(m)) {}
  Model model;
  Eigen::VectorXd q, q2;         // the configuration and a second one (reconfigure)
  Eigen::MatrixXd M, M2;         // CRBA at q and q2
  Eigen::MatrixXd Xref;          // M⁻¹ by a dense Cholesky of M
  Eigen::MatrixXd R;             // the seeded right-hand sides (nv × 11)
  double kappa = 0, kappa2 = 0;  // cond₂(M), cond₂(M2)
  double tol = 0, tol2 = 0;      // 10·(n + 10)·κ·ε
};
const ConformanceProblem& conformanceProblem(const ConformanceCase& c);

// One check's outcome: value ≤ bound passes (a NaN value fails).
struct ConformanceCheck {
  std::string case_name, check;
  double value = 0, bound = 0;
  bool passed = false;
};

struct ConformanceReport {
  std::string solver;
  std::vector<ConformanceCheck> checks;
  std::vector<std::pair<std::string, std::string>> skipped;  // (case, reason)
  std::vector<std::pair<std::string, std::string>> errors;   // (case, exception message)

  bool passed() const;  // every check passed, no error, and at least one case ran
  int failures() const;
  // The check with the largest value/bound (the closest to failing, or the worst failure).
  const ConformanceCheck* worst() const;
  // A few lines: cases run and skipped, checks passed, the worst check, every failure.
  void print(std::ostream& out, int max_failures = 20) const;
};

using SolverFactory = std::function<std::unique_ptr<Solver>()>;

// Every check of one case for a solver; appends to `report`.
void checkCase(const SolverFactory& make, const ConformanceCase& c, ConformanceReport& report,
               const ConformanceOptions& options = {});
// Every case. checkSolver(name) takes the solver from the registry (std::invalid_argument for
// an unknown name).
ConformanceReport checkSolver(const std::string& label, const SolverFactory& make,
                              const ConformanceOptions& options = {});
ConformanceReport checkSolver(const std::string& name, const ConformanceOptions& options = {});

// A valid GoogleTest parameter name for any solver and case name (letters, digits and '_';
// every other character becomes '_').
std::string testNameOf(const std::string& text);

}  // namespace minv
