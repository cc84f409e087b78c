// The conformance suite: every registered solver, with no per-solver code, on serial, branched,
// floating-base, mixed-joint and URDF-loaded trees. References are independent of the solver
// under test: CRBA's M (itself checked against closed forms and MuJoCo elsewhere) and the
// other solvers.
//
// Bounds: a backward-stable inverse has ‖M X − I‖ ≲ c·n·κ(M)·ε; we allow 10·(n + 10)·κ·ε, and
// the same scale for symmetry, solve-vs-inverse and pairwise agreement (relative, Frobenius).
#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <map>
#include <sstream>

#include "core/crba.hpp"
#include "generators/model_io.hpp"
#include "generators/random_tree.hpp"
#include "solvers/solver.hpp"

namespace minv {
namespace {

struct Case {
  std::string name;
  TreeOptions options;
  bool via_urdf = false;
};

std::vector<Case> cases() {
  std::vector<Case> out;
  for (int n : {1, 2, 3, 7, 32, 100, 300})
    for (Topology t : {Topology::Serial, Topology::Branched})
      for (bool floating : {false, true})
        for (JointSet j : {JointSet::Revolute, JointSet::Mixed}) {
          TreeOptions o{t, n, static_cast<std::uint64_t>(1000 + n), floating, j};
          std::string name = std::string(topologyName(t)) + "_" + jointSetName(j) +
                             (floating ? "_floating" : "_fixed") + "_n" + std::to_string(n);
          out.push_back({name, o, false});
          // URDF carries 1-DOF joints: round-trip the revolute trees through it.
          if (j == JointSet::Revolute && n <= 100) out.push_back({name + "_urdf", o, true});
        }
  return out;
}

void PrintTo(const Case& c, std::ostream* os) { *os << c.name; }

// A model case with its configuration, M, and LAPACK-free facts about M.
struct Problem {
  Model model;
  Eigen::VectorXd q;
  Eigen::MatrixXd M;
  double kappa = 0;  // cond₂(M)
  double tol = 0;    // 10·(n + 10)·κ·ε
};

Model buildModel(const Case& c) {
  Model m = randomTree(c.options);
  if (!c.via_urdf) return m;
  std::ostringstream xml;
  writeUrdf(m, xml, c.name);
  return readUrdf(xml.str(), c.name + ".urdf", c.options.floating_base);
}

const Problem& problem(const Case& c) {
  static std::map<std::string, Problem> memo;
  auto it = memo.find(c.name);
  if (it != memo.end()) return it->second;
  Problem p{buildModel(c), {}, {}, 0, 0};
  p.q = randomConfiguration(p.model, c.options.seed + 7);
  p.M = massMatrix(p.model, p.q);
  const Eigen::VectorXd ev = Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(p.M).eigenvalues();
  p.kappa = ev.maxCoeff() / ev.minCoeff();
  const double n = p.model.nv();
  p.tol = 10 * (n + 10) * p.kappa * std::numeric_limits<double>::epsilon();
  return memo.emplace(c.name, std::move(p)).first->second;
}

// Runs one solver: M⁻¹, and M⁻¹R for a seeded R with 11 columns (a full SIMD block of abi's
// and a partial one) and for its first column alone (the one-column path).
struct Result {
  Eigen::MatrixXd X, Y, R, Y1;
};

bool run(const std::string& solver, const Problem& p, Result& out, std::string* why,
         int threads = 1) {
  auto s = makeSolver(solver);
  if (!s->supports(p.model, why)) return false;
  s->setThreads(threads);
  s->prepare(p.model);
  s->configure(p.q);
  const int n = p.model.nv();
  out.R = Eigen::MatrixXd::NullaryExpr(n, 11, [](Eigen::Index i, Eigen::Index j) {
    return std::sin(1.0 + 3.0 * i + 7.0 * j);
  });
  out.X.resize(n, n);
  out.Y.resize(n, 11);
  out.Y1.resize(n, 1);
  s->inverse(out.X);
  s->solve(out.R, out.Y);
  s->solve(out.R.leftCols(1), out.Y1);
  return true;
}

double rel(const Eigen::MatrixXd& a, const Eigen::MatrixXd& b) {
  return (a - b).norm() / std::max(b.norm(), 1e-300);
}

class Conformance : public ::testing::TestWithParam<std::tuple<std::string, Case>> {};

TEST_P(Conformance, InverseSolveSymmetry) {
  const auto& [solver, c] = GetParam();
  const Problem& p = problem(c);
  Result r;
  std::string why;
  if (!run(solver, p, r, &why)) GTEST_SKIP() << solver << ": " << why;
  const int n = p.model.nv();
  const Eigen::MatrixXd I = Eigen::MatrixXd::Identity(n, n);
  // ‖M X − I‖ / ‖I‖ within the backward-stability bound.
  EXPECT_LE(rel(p.M * r.X, I), p.tol) << "kappa " << p.kappa;
  // X symmetric.
  EXPECT_LE(rel(r.X, r.X.transpose()), p.tol);
  // solve(R) = inverse()·R.
  EXPECT_LE(rel(r.Y, r.X * r.R), p.tol);
  EXPECT_LE(rel(r.Y1, r.X * r.R.leftCols(1)), p.tol);
  EXPECT_TRUE(r.X.allFinite() && r.Y.allFinite() && r.Y1.allFinite());
}

TEST_P(Conformance, AgreesWithEverySolver) {
  const auto& [solver, c] = GetParam();
  const Problem& p = problem(c);
  Result mine;
  std::string why;
  if (!run(solver, p, mine, &why)) GTEST_SKIP() << solver << ": " << why;
  for (const std::string& other : solverNames()) {
    if (other == solver) continue;
    Result theirs;
    if (!run(other, p, theirs, &why)) continue;
    EXPECT_LE(rel(mine.X, theirs.X), p.tol) << solver << " vs " << other;
  }
}

// On two threads (where a solver uses them: abi's column blocks run in parallel and write
// disjoint parts of M⁻¹) the results meet the same bounds.
TEST_P(Conformance, TwoThreads) {
  const auto& [solver, c] = GetParam();
  const Problem& p = problem(c);
  Result r;
  std::string why;
  if (!run(solver, p, r, &why, 2)) GTEST_SKIP() << solver << ": " << why;
  const int n = p.model.nv();
  EXPECT_LE(rel(p.M * r.X, Eigen::MatrixXd::Identity(n, n)), p.tol) << "kappa " << p.kappa;
  EXPECT_LE(rel(r.X, r.X.transpose()), p.tol);
  EXPECT_LE(rel(p.M * r.Y, r.R), p.tol);
  EXPECT_TRUE(r.X.allFinite() && r.Y.allFinite());
}

std::string caseName(const ::testing::TestParamInfo<Conformance::ParamType>& info) {
  return std::get<0>(info.param) + "_" + std::get<1>(info.param).name;
}

INSTANTIATE_TEST_SUITE_P(Registry, Conformance,
                         ::testing::Combine(::testing::ValuesIn(solverNames()),
                                            ::testing::ValuesIn(cases())),
                         caseName);

// The floating-base block of abi's M⁻¹ (Algorithm 2's base rows) against the inverse of the
// floating-base CRBA, for a serial and a branched tree.
TEST(ConformanceFloatingBase, AbiBaseBlockMatchesCrbaInverse) {
  for (Topology t : {Topology::Serial, Topology::Branched}) {
    const Case c{"abi_base_block", {t, 40, 77, true, JointSet::Mixed}, false};
    Problem p{randomTree(c.options), {}, {}, 0, 0};
    p.q = randomConfiguration(p.model, 5);
    p.M = massMatrix(p.model, p.q);
    const Eigen::MatrixXd ref = p.M.llt().solve(Eigen::MatrixXd::Identity(p.M.rows(), p.M.cols()));
    Result r;
    std::string why;
    ASSERT_TRUE(run("abi", p, r, &why));
    EXPECT_LT(rel(r.X.topLeftCorner(6, 6), ref.topLeftCorner(6, 6)), 1e-10);
    EXPECT_LT(rel(r.X.topRows(6), ref.topRows(6)), 1e-10);
  }
}

}  // namespace
}  // namespace minv
