// The conformance suite: every registered solver, with no per-solver code, on every case of
// solvers/conformance.hpp (serial, branched, floating-base, mixed-joint and URDF-loaded trees,
// n up to 300). The checks and their bounds are the library's, so that a solver from outside
// the repository gets exactly these through checkSolver(). One test per (solver, case); a
// solver that does not support a case is skipped with its reason.
//
// MINV_CONFORMANCE_MAX_N=N (environment) keeps the cases with n ≤ N: the sanitizer run of
// scripts/test sets 100, where the n = 300 cases would take most of its time; every solver still
// runs on every kind of tree.
#include "solvers/conformance.hpp"

#include <gtest/gtest.h>

#include <Eigen/Cholesky>
#include <cstdio>
#include <cstdlib>

#include "core/crba.hpp"
#include "generators/random_tree.hpp"
#include "solvers/abi_variants.hpp"
#include "solvers/solver.hpp"

namespace minv {

// How GoogleTest prints a case (found by argument-dependent lookup in minv).
void PrintTo(const ConformanceCase& c, std::ostream* os) {
  *os << c.name;
}

namespace {

// Every check of one case: a pass, a skip with the solver's reason, or a failure per check.
void expectConforms(const std::string& solver, const SolverFactory& make,
                    const ConformanceCase& c) {
  ConformanceReport report;
  report.solver = solver;
  checkCase(make, c, report);
  if (report.checks.empty() && report.errors.empty() && !report.skipped.empty())
    GTEST_SKIP() << solver << ": " << report.skipped.front().second;
  for (const auto& [name, what] : report.errors) ADD_FAILURE() << solver << " threw: " << what;
  for (const ConformanceCheck& k : report.checks)
    EXPECT_TRUE(k.passed) << solver << " " << k.check << ": " << k.value << " > " << k.bound
                          << " (kappa " << conformanceProblem(c).kappa << ")";
}

class Conformance : public ::testing::TestWithParam<std::tuple<std::string, ConformanceCase>> {};

TEST_P(Conformance, Checks) {
  const auto& [solver, c] = GetParam();
  expectConforms(solver, findSolver(solver)->make, c);
}

std::string caseName(const ::testing::TestParamInfo<Conformance::ParamType>& info) {
  return testNameOf(std::get<0>(info.param) + "_" + std::get<1>(info.param).name);
}

// The cases, trimmed by MINV_CONFORMANCE_MAX_N.
std::vector<ConformanceCase> suiteCases() {
  ConformanceOptions o;
  if (const char* n = std::getenv("MINV_CONFORMANCE_MAX_N")) o.max_n = std::atoi(n);
  return conformanceCases(o);
}

INSTANTIATE_TEST_SUITE_P(Registry, Conformance,
                         ::testing::Combine(::testing::ValuesIn(solverNames()),
                                            ::testing::ValuesIn(suiteCases())),
                         caseName);

// abi at every instruction-set level (solvers/abi_variants.hpp), whichever the registry's
// `abi` uses: each level this build has and this CPU runs passes every case; any other level is
// skipped, and the skip says why (not built, the extensions this CPU lacks, or checked above as
// the registry's abi or abi-generic).
class ConformanceLevels : public ::testing::TestWithParam<std::tuple<Isa, ConformanceCase>> {};

TEST_P(ConformanceLevels, Checks) {
  const auto& [isa, c] = GetParam();
  std::string why;
  if (!abiLevelUsable(isa, &why)) GTEST_SKIP() << "abi level " << isaName(isa) << ": " << why;
  // The registry's abi and abi-generic are these levels: checked above under their names.
  if (isa == abiLevel()) GTEST_SKIP() << "abi level " << isaName(isa) << " is the registry's abi";
  if (isa == Isa::Baseline && findSolver("abi-generic"))
    GTEST_SKIP() << "abi level baseline is the registry's abi-generic";
  expectConforms(
      std::string("abi at ") + isaName(isa), [isa = isa] { return makeAbiAt(isa); }, c);
}

INSTANTIATE_TEST_SUITE_P(AbiLevels, ConformanceLevels,
                         ::testing::Combine(::testing::ValuesIn(kIsas),
                                            ::testing::ValuesIn(suiteCases())),
                         [](const ::testing::TestParamInfo<ConformanceLevels::ParamType>& info) {
                           return testNameOf(std::string(isaName(std::get<0>(info.param))) + "_" +
                                             std::get<1>(info.param).name);
                         });

// A case's `limits` skip only what is a peer's own limit: bullet, run on those cases under
// another name (so that nothing skips it), fails their inverse check, by the figures the
// skip's reason gives. (Should Bullet become accurate there, this fails: drop the limit.)
TEST(ConformanceLimits, BulletFailsWhereItIsSkipped) {
  const SolverEntry* bullet = findSolver("bullet");
  if (!bullet) GTEST_SKIP() << "bullet is not in this build";
  int limited = 0;
  for (const ConformanceCase& c : conformanceCases()) {
    if (c.limits.empty()) continue;
    ++limited;
    ConformanceReport report;
    report.solver = "bullet, unlimited";
    checkCase(bullet->make, c, report);
    bool inverse_failed = false;
    for (const ConformanceCheck& k : report.checks)
      if (k.check == "inverse |MX-I|" && !k.passed) {
        inverse_failed = true;
        std::printf("bullet on %s: |MX - I| %.2g > %.2g\n", c.name.c_str(), k.value, k.bound);
      }
    EXPECT_TRUE(inverse_failed) << c.name;
  }
  EXPECT_GT(limited, 0);
}

// The library's report: a registered solver passes with every case run; a deliberately wrong
// solver (abi with one entry of M⁻¹ perturbed) fails the inverse and triangle checks, so the
// checks can fail.
TEST(ConformanceLibrary, ReportPassesAndFails) {
  ConformanceOptions small;
  small.max_n = 7;
  const ConformanceReport good = checkSolver("lapack", small);
  EXPECT_TRUE(good.passed());
  EXPECT_EQ(good.failures(), 0);
  struct Wrong : Solver {
    std::unique_ptr<Solver> inner = makeSolver("abi");
    void prepare(const Model& m) override { inner->prepare(m); }
    void configure(const Eigen::VectorXd& q) override { inner->configure(q); }
    void inverse(MatrixOut X) override {
      inner->inverse(X);
      X(X.rows() - 1, 0) += 1e-6 * X.norm();  // one entry of the lower triangle
    }
    void solve(MatrixIn R, MatrixOut X) override { inner->solve(R, X); }
  };
  const ConformanceReport bad = checkSolver(
      "wrong", [] { return std::unique_ptr<Solver>(new Wrong()); }, small);
  EXPECT_FALSE(bad.passed());
  bool lower_failed = false, upper_failed = false;
  for (const ConformanceCheck& k : bad.checks) {
    if (k.case_name.find("_n7") == std::string::npos) continue;
    lower_failed |= k.check == "lower triangle vs dense inverse" && !k.passed;
    upper_failed |= k.check == "upper triangle vs dense inverse" && !k.passed;
  }
  EXPECT_TRUE(lower_failed);
  EXPECT_FALSE(upper_failed);  // the triangles are checked separately
}

// A solver that returns the first configuration's inverse again fails "reconfigure".
TEST(ConformanceLibrary, CachedResultFailsReconfigure) {
  struct Stale : Solver {
    std::unique_ptr<Solver> inner = makeSolver("lapack");
    bool configured = false;
    void prepare(const Model& m) override { inner->prepare(m); }
    void configure(const Eigen::VectorXd& q) override {
      if (!configured) inner->configure(q);
      configured = true;
    }
    void inverse(MatrixOut X) override { inner->inverse(X); }
    void solve(MatrixIn R, MatrixOut X) override { inner->solve(R, X); }
  };
  ConformanceOptions small;
  small.max_n = 7;
  const ConformanceReport r = checkSolver(
      "stale", [] { return std::unique_ptr<Solver>(new Stale()); }, small);
  int stale = 0;
  for (const ConformanceCheck& k : r.checks)
    stale += k.check == "reconfigure |M2 X2 - I|" && !k.passed;
  EXPECT_GT(stale, 0);
}

// The floating-base block of abi's M⁻¹ (Algorithm 2's base rows) against the inverse of the
// floating-base CRBA, for a serial and a branched tree.
TEST(ConformanceFloatingBase, AbiBaseBlockMatchesCrbaInverse) {
  for (Topology t : {Topology::Serial, Topology::Branched}) {
    const Model model = randomTree({t, 40, 77, true, JointSet::Mixed});
    const Eigen::VectorXd q = randomConfiguration(model, 5);
    const Eigen::MatrixXd M = massMatrix(model, q);
    const int n = model.nv();
    const Eigen::MatrixXd ref = M.llt().solve(Eigen::MatrixXd::Identity(n, n));
    auto s = makeSolver("abi");
    s->prepare(model);
    s->configure(q);
    Eigen::MatrixXd X(n, n);
    s->inverse(X);
    EXPECT_LT(
        (X.topLeftCorner(6, 6) - ref.topLeftCorner(6, 6)).norm() / ref.topLeftCorner(6, 6).norm(),
        1e-10);
    EXPECT_LT((X.topRows(6) - ref.topRows(6)).norm() / ref.topRows(6).norm(), 1e-10);
  }
}

}  // namespace
}  // namespace minv
