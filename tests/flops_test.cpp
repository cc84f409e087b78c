// The counting scalar and the measured operation counts: closed-form counts of the sparse and
// naive factorizations, exact polynomial fits, the same numbers as double, thread safety.
#include "experiments/lib/flops.hpp"

#include <gtest/gtest.h>

#include <thread>

#include "solvers/abi.hpp"
#include "solvers/ltdl.hpp"
#include "solvers/naive.hpp"

namespace minv {
namespace {

FlopCounts stage(const std::vector<StageCount>& stages, const std::string& name) {
  for (const StageCount& s : stages)
    if (s.stage == name) return s.counts;
  ADD_FAILURE() << "no stage " << name;
  return {};
}

// Σ_k d_k(d_k − 1)/2 and Σ_k (d_k − 1) over the DOF tree.
std::pair<std::uint64_t, std::uint64_t> depthFormulas(const Model& model) {
  std::vector<std::uint64_t> d(model.nv());
  std::uint64_t tri = 0, lin = 0;
  for (int k = 0; k < model.nv(); ++k) {
    const int p = model.dofParent()[k];
    d[k] = p < 0 ? 1 : d[p] + 1;
    tri += d[k] * (d[k] - 1) / 2;
    lin += d[k] - 1;
  }
  return {tri, lin};
}

TEST(Flops, SparseFactorizationsMatchDepthFormulas) {
  for (std::uint64_t seed : {1, 2, 3})
    for (Topology t : {Topology::Serial, Topology::Branched})
      for (JointSet j : {JointSet::Revolute, JointSet::Mixed}) {
        const Model model = randomTree({t, 60, seed, seed == 2, j});
        const Eigen::VectorXd q = randomConfiguration(model, seed);
        const auto [tri, lin] = depthFormulas(model);
        const FlopCounts ltdl = stage(countSolver("ltdl", model, q), "factorization");
        EXPECT_EQ(ltdl.mul, tri);
        EXPECT_EQ(ltdl.div, lin);
        EXPECT_EQ(ltdl.sqrt, 0u);
        const FlopCounts ltl = stage(countSolver("ltl", model, q), "factorization");
        EXPECT_EQ(ltl.mul, tri);
        EXPECT_EQ(ltl.div, lin);
        EXPECT_EQ(ltl.sqrt, static_cast<std::uint64_t>(model.nv()));
      }
}

TEST(Flops, NaiveCholeskyIsTheTextbookCubic) {
  // Multiplications (n³ − n)/6, additions the same, n(n − 1)/2 divisions, n square roots.
  for (int n : {1, 5, 17, 40}) {
    const Model model = randomTree({Topology::Serial, n, 3, false, JointSet::Revolute});
    const FlopCounts c =
        stage(countSolver("naive", model, randomConfiguration(model, 1)), "factorization");
    const std::uint64_t N = n;
    EXPECT_EQ(c.mul, (N * N * N - N) / 6) << n;
    EXPECT_EQ(c.add, (N * N * N - N) / 6) << n;
    EXPECT_EQ(c.div, N * (N - 1) / 2) << n;
    EXPECT_EQ(c.sqrt, N) << n;
  }
}

// Fits every stage's multiplications and additions over n and checks the fit is exact with
// the given highest degree (the coefficients above it vanish).
// From n = kRun + 1: a shorter chain has no run of links long enough for the articulated pass's
// regrouped step (core/articulated.hpp), so its counts follow another polynomial.
void expectExactPolynomial(const std::string& solver, int degree) {
  const std::vector<int> ns = {kRun + 1, 8, 13, 21, 34, 55, 89};
  std::vector<std::vector<StageCount>> runs;
  Eigen::MatrixXd B(ns.size(), 4);
  for (size_t i = 0; i < ns.size(); ++i) {
    const Model model = randomTree({Topology::Serial, ns[i], 9, false, JointSet::Revolute});
    runs.push_back(countSolver(solver, model, randomConfiguration(model, 2)));
    const double n = ns[i];
    B.row(i) << n * n * n, n * n, n, 1;
  }
  for (size_t s = 0; s < runs[0].size(); ++s)
    for (int f = 0; f < 2; ++f) {
      Eigen::VectorXd y(ns.size());
      for (size_t i = 0; i < ns.size(); ++i)
        y(i) = static_cast<double>(f == 0 ? runs[i][s].counts.mul : runs[i][s].counts.add);
      const Eigen::VectorXd c = leastSquares(B, y);
      EXPECT_LE((B * c - y).cwiseAbs().maxCoeff(), 1e-6 * y.cwiseAbs().maxCoeff())
          << solver << " " << runs[0][s].stage;
      for (int k = 0; k < 3 - degree; ++k)
        EXPECT_NEAR(c(k), 0.0, 1e-8 * std::max(1.0, c.cwiseAbs().maxCoeff()))
            << solver << " " << runs[0][s].stage << " coefficient of n^" << 3 - k;
    }
}

TEST(Flops, AbiOnChainsIsExactlyQuadratic) {
  expectExactPolynomial("abi", 2);
}
TEST(Flops, NaiveOnChainsIsExactlyCubic) {
  expectExactPolynomial("naive", 3);
}

// The kinematics' counts per revolute body, closed form (the two stages of Tables 1–3 before the
// articulated pass): a non-root body's pose P·exp(θ ã) = Pa + cos θ Pc + sin θ Ps (18 mul, 18
// add), ⁰X = ⁰X_λ · (L, l) (36, 27), its axis R a and p × R a (15, 9); the root skips the
// composition. Its inertia: c = p + R c_b (9, 9), R Ī (27, 18), the lower triangle of (R Ī) Rᵀ
// (18, 12), mcI (12, 11). Whatever the column type the kernel runs on doubles (core/spatial.hpp,
// Three), the counting scalar must do exactly these operations.
TEST(Flops, KinematicsPerRevoluteBodyIsClosedForm) {
  for (const int n : {1, 2, 7, 33}) {
    const Model model = randomTree({Topology::Serial, n, 3, false, JointSet::Revolute});
    const std::vector<StageCount> stages = countSolver("abi", model, randomConfiguration(model, 5));
    const FlopCounts axes = stage(stages, "spatial axes");
    const FlopCounts inertias = stage(stages, "isolated inertias");
    const std::uint64_t N = n;
    EXPECT_EQ(axes.mul, 69 * (N - 1) + 33) << n;
    EXPECT_EQ(axes.add, 54 * (N - 1) + 27) << n;
    EXPECT_EQ(axes.trig, 2 * N) << n;
    EXPECT_EQ(inertias.mul, 66 * N) << n;
    EXPECT_EQ(inertias.add, 50 * N) << n;
  }
}

// On a branched tree of mixed joints (no run of kRun links), and on a serial chain (the
// articulated pass's regrouped runs, core/articulated.hpp).
class CountedAndDouble : public ::testing::TestWithParam<TreeOptions> {};
INSTANTIATE_TEST_SUITE_P(
    Flops, CountedAndDouble,
    ::testing::Values(TreeOptions{Topology::Branched, 30, 4, true, JointSet::Mixed},
                      TreeOptions{Topology::Serial, 30, 4, true, JointSet::Revolute}));

TEST_P(CountedAndDouble, GiveTheSameNumbers) {
  const Model model = randomTree(GetParam());
  const Eigen::VectorXd q = randomConfiguration(model, 4);
  // The same kernels on double and on Counted.
  Kinematics<double> kd(model);
  Articulated<double> ad(model);
  AbiWorkspace<double> wd(model);
  computeKinematics<double>(model, q, kd);
  articulatedInertias<double>(model, kd, ad);
  MatX<double> Xd(model.nv(), model.nv());
  abiInverse<double>(model, kd, ad, wd, Xd);
  Kinematics<Counted> kc(model);
  Articulated<Counted> ac(model);
  AbiWorkspace<Counted> wc(model);
  computeKinematics<Counted>(model, q.cast<Counted>(), kc);
  articulatedInertias<Counted>(model, kc, ac);
  MatX<Counted> Xc(model.nv(), model.nv());
  abiInverse<Counted>(model, kc, ac, wc, Xc);
  const Eigen::MatrixXd Xcd = Xc.unaryExpr([](const Counted& c) { return c.value(); });
  // Equal up to the order of summation that SIMD code may choose for double.
  EXPECT_LT((Xcd - Xd).norm(), 1e-12 * Xd.norm());
  // M⁻¹R the same way, for 11 right-hand sides (one lane at a time on Counted; 11 lanes of
  // one block on double), both against the inverse times R.
  const Eigen::MatrixXd R = Eigen::MatrixXd::Random(model.nv(), 11);
  MatX<double> Yd(model.nv(), 11);
  abiSolve<double>(model, kd, ad, wd, R, Yd);
  MatX<Counted> Yc(model.nv(), 11);
  const MatX<Counted> Rc = R.cast<Counted>();
  abiSolve<Counted>(model, kc, ac, wc, Rc, Yc);
  const Eigen::MatrixXd Ycd = Yc.unaryExpr([](const Counted& c) { return c.value(); });
  EXPECT_LT((Ycd - Yd).norm(), 1e-12 * Yd.norm());
  EXPECT_LT((Yd - Xd * R).norm(), 1e-10 * Yd.norm());
  EXPECT_GT(flopTotal().mul, 0u);
}

TEST(Flops, CountersAreSafeAcrossThreads) {
  flopReset();
  auto work = [] {
    Counted a(1.0), b(2.0);
    for (int i = 0; i < 100000; ++i) a = a * b / b + b - b;
  };
  std::thread t1(work), t2(work);
  work();
  t1.join();
  t2.join();
  const FlopCounts total = flopTotal();
  EXPECT_EQ(total.mul, 300000u);
  EXPECT_EQ(total.div, 300000u);
  EXPECT_EQ(total.add, 600000u);
}

TEST(Flops, ParallelCountIsLinearForChains) {
  // One processor per column: every stage grows at most linearly in n (Table 3).
  std::vector<double> totals;
  for (int n : {16, 32, 64}) {
    const Model model = randomTree({Topology::Serial, n, 5, false, JointSet::Revolute});
    FlopCounts t;
    for (const StageCount& s : abiParallelCounts(model, randomConfiguration(model, 5)))
      t += s.counts;
    totals.push_back(static_cast<double>(t.mul));
  }
  // Linear: over n = 16, 32, 64 the increments double; a quadratic term would quadruple them.
  EXPECT_DOUBLE_EQ(totals[2] - totals[1], 2 * (totals[1] - totals[0]));
}

}  // namespace
}  // namespace minv
