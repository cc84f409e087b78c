// The contact solver (sim/contact_solver.hpp) on random contact-space instances: KKT,
// complementarity, penetration and cone residuals under tolerance, and the optimum against
// brute-force enumeration of active sets on small instances; the block Gauss–Seidel solve
// against the former implementation (solveMaxDissipationReference) on random problems and on
// problems recorded from a walking centipede: the same λ and v⁺ within the tolerance; the
// simulator's extrapolated warm start.
#include <gtest/gtest.h>

#include <Eigen/Cholesky>
#include <Eigen/QR>
#include <cmath>
#include <map>
#include <set>

#include "generators/centipede.hpp"
#include "generators/random_tree.hpp"
#include "sim/contact_solver.hpp"
#include "sim/gait.hpp"
#include "sim/simulator.hpp"

namespace minv::sim {
namespace {

// A random PSD contact-space inertia A = BBᵀ (rank r ≤ 3nc; r < 3nc is the singular case of
// more contact directions than DOFs) and random pre-contact velocities.
ContactProblem randomProblem(int nc, int rank, std::uint64_t seed) {
  Rng rng(seed);
  Eigen::MatrixXd B(3 * nc, rank);
  for (int i = 0; i < B.size(); ++i) B.data()[i] = rng.uniform(-1, 1);
  ContactProblem p;
  p.A = B * B.transpose();
  // v0 = Jᵀv* lies in range(A) = range(Jᵀ), as in a simulation (else a singular A would let
  // the kinetic energy fall without bound).
  Eigen::VectorXd y(rank);
  for (int i = 0; i < rank; ++i) y(i) = rng.uniform(-1, 1);
  p.v0 = B * y;
  p.b = Eigen::VectorXd::Zero(nc);
  p.mu = rng.uniform(0.2, 1.2);
  p.k = 4 + 2 * rng.below(3);
  return p;
}

// How far λ (3nc: n, t1, t2 per contact) lies outside the linearised cone, from λ alone: λn ≥ 0
// and the tangential impulse inside the regular k-gon of circumradius μλn with vertices at
// θ_j = 2πj/k, i.e. on the inner side of each edge (outward normal at 2π(j + ½)/k, apothem
// μλn cos(π/k)). Independent of the solver's generators W and of β.
double outsideCone(const Eigen::VectorXd& lambda, double mu, int k) {
  double worst = 0;
  for (int c = 0; c < lambda.size() / 3; ++c) {
    const double n = lambda(3 * c), t1 = lambda(3 * c + 1), t2 = lambda(3 * c + 2);
    worst = std::max(worst, -n);
    for (int j = 0; j < k; ++j) {
      const double phi = 2 * M_PI * (j + 0.5) / k;
      worst = std::max(worst, t1 * std::cos(phi) + t2 * std::sin(phi) -
                                  mu * std::max(n, 0.0) * std::cos(M_PI / k));
    }
  }
  return worst;
}

// The oracle itself: inside, on and outside the cone.
TEST(SimContactSolver, ConeMembershipOracle) {
  const double mu = 0.5;
  Eigen::VectorXd vertex(3), beyond(3), pulled(3);
  vertex << 2, mu * 2, 0;  // a vertex of the 4-gon: on the boundary
  beyond << 2, mu * 2 * 1.01, 0;
  pulled << -1e-3, 0, 0;  // a pulling normal impulse
  EXPECT_LT(outsideCone(vertex, mu, 4), 1e-15);
  EXPECT_GT(outsideCone(beyond, mu, 4), 1e-3);
  EXPECT_GT(outsideCone(pulled, mu, 4), 0);
  // A point on the circular cone between two generators lies outside the inscribed 4-gon.
  Eigen::VectorXd circle(3);
  circle << 1, mu * std::cos(M_PI / 4), mu * std::sin(M_PI / 4);
  EXPECT_GT(outsideCone(circle, mu, 4), 0.1 * mu);
}

double objective(const Eigen::MatrixXd& G, const Eigen::VectorXd& g0, const Eigen::VectorXd& x) {
  return 0.5 * x.dot(G * x) + g0.dot(x);
}

TEST(SimContactSolver, ResidualsUnderToleranceOnRandomInstances) {
  ContactSolverOptions o;
  o.tolerance = 1e-10;
  o.max_iterations = 100000;
  for (int trial = 0; trial < 40; ++trial) {
    const int nc = 1 + trial % 12;
    const int rank = trial % 3 == 0 ? std::max(1, 3 * nc / 2) : 3 * nc;  // singular every third
    const ContactProblem p = randomProblem(nc, rank, 100 + trial);
    const ContactSolution s = solveMaxDissipation(p, {}, o);
    const double scale = std::max(p.v0.cwiseAbs().maxCoeff(), 1e-6);
    EXPECT_TRUE(s.residuals.converged) << trial;
    EXPECT_LT(s.residuals.kkt, 1e-9 * scale) << trial;
    EXPECT_LT(s.residuals.penetration, 1e-9 * scale) << trial;
    // λ itself in the cone (not only λ = Wβ with β ≥ 0, which holds by construction).
    EXPECT_LT(outsideCone(s.lambda, p.mu, p.k), 1e-12 * std::max(1.0, s.lambda.norm())) << trial;
    EXPECT_LT(s.residuals.complementarity, 1e-9 * scale * (1 + s.beta.norm())) << trial;
  }
}

// The QP min ½βᵀGβ + βᵀg0, β ≥ 0 by enumerating every active set (m ≤ 10).
double bruteForce(const Eigen::MatrixXd& G, const Eigen::VectorXd& g0) {
  const int m = static_cast<int>(g0.size());
  double best = 0;  // β = 0 is feasible
  for (int mask = 1; mask < (1 << m); ++mask) {
    std::vector<int> F;
    for (int j = 0; j < m; ++j)
      if (mask >> j & 1) F.push_back(j);
    const int f = static_cast<int>(F.size());
    Eigen::MatrixXd GF(f, f);
    Eigen::VectorXd gF(f);
    for (int a = 0; a < f; ++a) {
      gF(a) = g0(F[a]);
      for (int b = 0; b < f; ++b) GF(a, b) = G(F[a], F[b]);
    }
    const Eigen::VectorXd xF = GF.completeOrthogonalDecomposition().solve(-gF);
    if (xF.minCoeff() < 0) continue;
    Eigen::VectorXd x = Eigen::VectorXd::Zero(m);
    for (int a = 0; a < f; ++a) x(F[a]) = xF(a);
    best = std::min(best, objective(G, g0, x));
  }
  return best;
}

TEST(SimContactSolver, MatchesBruteForceOnSmallInstances) {
  ContactSolverOptions o;
  o.tolerance = 1e-12;
  o.max_iterations = 200000;
  for (int trial = 0; trial < 20; ++trial) {
    Rng rng(500 + trial);
    const int m = 3 + rng.below(6);
    Eigen::MatrixXd B(m, 1 + rng.below(m));
    for (int i = 0; i < B.size(); ++i) B.data()[i] = rng.uniform(-1, 1);
    const Eigen::MatrixXd G = B * B.transpose() + 1e-3 * Eigen::MatrixXd::Identity(m, m);
    Eigen::VectorXd g0(m);
    for (int i = 0; i < m; ++i) g0(i) = rng.uniform(-1, 1);
    Eigen::VectorXd beta;
    const ContactResiduals r = solveBoundQP(G, g0, beta, o);
    EXPECT_TRUE(r.converged);
    EXPECT_NEAR(objective(G, g0, beta), bruteForce(G, g0), 1e-9) << trial;
  }
}

// One contact, unit inertia: approaching and sliding slowly → stops dead (stick). Sliding
// fast → the impulse is on the cone's edge, and, as in every maximum-dissipation model with a
// coupled cone, the contact leaves with normal velocity μ|v⁺_t| (here λn = 1.6, v⁺ = (0.6,
// 1.2, 0): minimise ½(λn − 1)² + ½(2 − μλn)²). Separating without sliding → no impulse.
TEST(SimContactSolver, SingleContactCases) {
  ContactProblem p;
  p.A = Eigen::Matrix3d::Identity();
  p.b = Eigen::VectorXd::Zero(1);
  p.mu = 0.5;
  p.k = 4;
  ContactSolverOptions o;
  o.tolerance = 1e-13;
  o.max_iterations = 100000;
  p.v0 = Eigen::Vector3d(-1, 0.3, 0);
  ContactSolution s = solveMaxDissipation(p, {}, o);
  EXPECT_LT((p.A * s.lambda + p.v0).norm(), 1e-10);
  p.v0 = Eigen::Vector3d(-1, 2, 0);
  s = solveMaxDissipation(p, {}, o);
  EXPECT_NEAR(s.lambda(0), 1.6, 1e-9);
  EXPECT_NEAR(s.lambda(1), -0.8, 1e-9);
  EXPECT_NEAR(s.lambda(2), 0.0, 1e-9);
  p.v0 = Eigen::Vector3d(0.5, 0, 0);
  s = solveMaxDissipation(p, {}, o);
  EXPECT_LT(s.lambda.norm(), 1e-12);
}

// The velocity scale of the relative test, max(‖g0‖∞, floor), g0 = Wᵀ(v0 + [b; 0; 0]).
double velocityScale(const ContactProblem& p, double floor) {
  const Eigen::MatrixXd W = coneGenerators(p.mu, p.k);
  double g0 = 0;
  for (int c = 0; c < p.b.size(); ++c) {
    Eigen::Vector3d vc = p.v0.segment<3>(3 * c);
    vc(0) += p.b(c);
    g0 = std::max(g0, (W.transpose() * vc).cwiseAbs().maxCoeff());
  }
  return std::max(g0, floor);
}

// Both solves of one problem from one warm start: both converged, the same v⁺ = Aλ + v0
// within 100× the absolute tolerance, the same objective ½λᵀAλ + λᵀ(v0 + [b; 0; 0]), and,
// where A is not singular (λ unique), the same λ within lambda_rel relative.
void expectSameSolution(const ContactProblem& p, const Eigen::VectorXd& warm,
                        const ContactSolverOptions& o, double lambda_rel, const std::string& what) {
  const ContactSolution ref = solveMaxDissipationReference(p, warm, o);
  const ContactSolution s = solveMaxDissipation(p, warm, o);
  const double tol = o.tolerance * velocityScale(p, o.floor);
  ASSERT_TRUE(ref.residuals.converged) << what;
  EXPECT_TRUE(s.residuals.converged) << what;
  EXPECT_LE(s.residuals.kkt, tol) << what;
  const Eigen::VectorXd dv = p.A * (s.lambda - ref.lambda);
  EXPECT_LT(dv.cwiseAbs().maxCoeff(), 100 * tol) << what;
  Eigen::VectorXd vb = p.v0;
  for (int c = 0; c < p.b.size(); ++c) vb(3 * c) += p.b(c);
  auto objective = [&](const Eigen::VectorXd& l) { return 0.5 * l.dot(p.A * l) + l.dot(vb); };
  EXPECT_NEAR(objective(s.lambda), objective(ref.lambda),
              100 * tol * std::max(1.0, ref.lambda.lpNorm<1>()))
      << what;
  if (lambda_rel > 0) {
    EXPECT_LT((s.lambda - ref.lambda).norm(), lambda_rel * std::max(1e-12, ref.lambda.norm()))
        << what;
  }
  EXPECT_LE(s.residuals.penetration, std::max(100 * tol, 2 * ref.residuals.penetration)) << what;
  EXPECT_LT(s.residuals.cone, 1e-12 * std::max(1.0, s.lambda.norm())) << what;
}

// Random problems (a third singular), cold and warm started, at the default tolerance and a
// tight one, with one and with several inner passes per contact.
TEST(SimContactSolver, BlockSolveMatchesReferenceOnRandomProblems) {
  for (int trial = 0; trial < 30; ++trial) {
    const int nc = 1 + trial % 15;
    const int rank = trial % 3 == 0 ? std::max(1, 3 * nc / 2) : 3 * nc;
    const ContactProblem p = randomProblem(nc, rank, 900 + trial);
    Rng rng(1900 + trial);
    Eigen::VectorXd warm(p.k * nc);
    for (int j = 0; j < warm.size(); ++j) warm(j) = rng.uniform() < 0.5 ? 0.0 : rng.uniform();
    for (int inner : {1, 2, 3}) {
      for (double tolerance : {1e-9, 1e-12}) {
        ContactSolverOptions o;
        o.tolerance = tolerance;
        o.max_iterations = 200000;
        o.inner_sweeps = inner;
        const std::string what = "trial " + std::to_string(trial) + " inner " +
                                 std::to_string(inner) + " tol " + std::to_string(tolerance);
        const double lambda_rel = rank == 3 * nc ? 1e-6 : -1;
        expectSameSolution(p, {}, o, lambda_rel, what + " cold");
        expectSameSolution(p, warm, o, lambda_rel, what + " warm");
      }
    }
  }
}

// With one inner pass the block solve takes, step for step, the reference's coordinate steps:
// the same iteration count (up to one, for rounding at the threshold) and the same β.
TEST(SimContactSolver, OneInnerPassIsTheReferenceIteration) {
  for (int trial = 0; trial < 12; ++trial) {
    const ContactProblem p = randomProblem(2 + trial, 3 * (2 + trial), 1300 + trial);
    ContactSolverOptions o;
    o.tolerance = 1e-10;
    o.max_iterations = 100000;
    o.inner_sweeps = 1;
    const ContactSolution ref = solveMaxDissipationReference(p, {}, o);
    const ContactSolution s = solveMaxDissipation(p, {}, o);
    EXPECT_LE(std::abs(s.residuals.iterations - ref.residuals.iterations), 1) << trial;
    EXPECT_LT((s.beta - ref.beta).cwiseAbs().maxCoeff(), 1e-8 * (1 + ref.beta.norm())) << trial;
  }
}

// Problems recorded from a walking centipede (the simulator's own A, v0, b and warm starts
// after 5 … 60 steps, yaw and spherical segment joints): the default solve reaches the
// reference's λ and v⁺ within the tolerance.
TEST(SimContactSolver, BlockSolveMatchesReferenceOnRecordedCentipedeProblems) {
  for (SegmentJoint joint : {SegmentJoint::Yaw, SegmentJoint::Spherical}) {
    const Centipede c = makeCentipede({.segments = 8, .segment_joint = joint});
    SimOptions so;
    so.dt = 1e-3;
    so.path = kContactInertiaPath;
    WalkingCentipede walk(c, so);
    Simulator& sim = walk.sim();
    int recorded = 0;
    for (int step = 1; step <= 60; ++step) {
      sim.step();
      if (step % 5 != 0 || sim.lastContacts() == 0) continue;
      const std::string what =
          std::string(segmentJointName(joint)) + " step " + std::to_string(step);
      expectSameSolution(sim.lastProblem(), sim.lastWarmStart(), so.contact, 1e-5, what);
      ContactSolverOptions tight = so.contact;
      tight.tolerance = 1e-12;
      tight.max_iterations = 100000;
      expectSameSolution(sim.lastProblem(), sim.lastWarmStart(), tight, 1e-8, what + " tight");
      ++recorded;
    }
    EXPECT_GE(recorded, 6);
  }
}

// The minimum-norm weights of one contact's λ = Wβ over β ≥ 0 (k = 4, whose W has the 1-D null
// space z), found independently of the simulator's closed form: W⁺λ if it is non-negative,
// else the shortest of the feasible points β + t z at which one weight is zero.
Eigen::Vector4d minimumNormWeights(const Eigen::MatrixXd& W, const Eigen::Vector4d& beta) {
  const Eigen::Vector4d z(1, -1, 1, -1);
  EXPECT_LT((W * z).norm(), 1e-15);
  const Eigen::Vector4d pinv = W.completeOrthogonalDecomposition().solve(W * beta);
  if (pinv.minCoeff() >= 0) return pinv;
  Eigen::Vector4d best = beta;
  for (int j = 0; j < 4; ++j) {
    const Eigen::Vector4d cand = beta - beta(j) / z(j) * z;
    if (cand.minCoeff() >= -1e-15 && cand.norm() < best.norm()) best = cand.cwiseMax(0.0);
  }
  return best;
}

// The walking centipede's options in these tests: the contact-inertia path at step h.
SimOptions walkingOptions(double h) {
  SimOptions so;
  so.dt = h;
  so.path = kContactInertiaPath;
  return so;
}

// The start expected from the minimum-norm weights h of the consecutive steps in contact
// before (the last at the back): max(0, ·) of the least-squares quadratic through the last five
// at the next step (its weights fitted here from the 5×3 Vandermonde matrix, not copied), the
// line through the last two after two to four, the last after one, else 0.
Eigen::VectorXd expectedStart(const std::vector<Eigen::VectorXd>& h, int size) {
  const int n = static_cast<int>(h.size());
  if (n == 0) return Eigen::VectorXd::Zero(size);
  if (n == 1) return h[0];
  if (n < 5) return (2 * h[n - 1] - h[n - 2]).cwiseMax(0.0);
  Eigen::MatrixXd V(5, 3);
  for (int d = 1; d <= 5; ++d) V.row(d - 1) << 1, -d, d * d;
  const Eigen::VectorXd fit =
      V * (V.transpose() * V).colPivHouseholderQr().solve(Eigen::Vector3d::UnitX());
  Eigen::VectorXd e = Eigen::VectorXd::Zero(size);
  for (int d = 1; d <= 5; ++d) e += fit(d - 1) * h[n - d];
  return e.cwiseMax(0.0);
}

// The simulator's warm start (sim/simulator.hpp) is expectedStart() of each point's minimum-norm
// weights, on a standing centipede whose legs all stay in contact. Each step's weights are
// solved again here from its recorded problem and start (the solve is deterministic).
TEST(SimContactSolver, WarmStartExtrapolatesMinimumNormWeights) {
  const Centipede c = makeCentipede({.segments = 3});
  const SimOptions so = walkingOptions(1e-5);
  WalkingCentipede walk(c, so);
  Simulator& sim = walk.sim();
  ASSERT_EQ(so.friction_dirs, 4);
  const Eigen::MatrixXd W = coneGenerators(so.mu, 4);
  std::vector<Eigen::VectorXd> canon;  // each step's weights, per contact minimum-norm
  int checked = 0, quadratic = 0, distinct = 0, moved = 0;
  for (int step = 0; step < 12; ++step) {
    sim.step();
    ASSERT_EQ(sim.lastContacts(), c.legs()) << "step " << step;
    const Eigen::VectorXd& start = sim.lastWarmStart();
    const int nb = static_cast<int>(start.size());
    const Eigen::VectorXd expected = expectedStart(canon, nb);
    quadratic += step >= 5;
    // Relative to the start's own scale (β is about 1e-5 here), not an absolute floor.
    const double tol = 1e-10 * expected.norm();
    if (step >= 5)
      distinct +=
          (expected - (2 * canon[step - 1] - canon[step - 2]).cwiseMax(0.0)).norm() > 100 * tol;
    EXPECT_LE((start - expected).norm(), tol) << "step " << step;
    checked += step >= 1;
    // This step's weights, solved again, and their minimum-norm form (the same λ).
    const Eigen::VectorXd beta = solveMaxDissipation(sim.lastProblem(), start, so.contact).beta;
    Eigen::VectorXd m(nb);
    for (int q = 0; q < nb / 4; ++q) {
      m.segment<4>(4 * q) = minimumNormWeights(W, beta.segment<4>(4 * q));
      EXPECT_LE((W * (m.segment<4>(4 * q) - beta.segment<4>(4 * q))).norm(),
                1e-12 * beta.segment<4>(4 * q).norm());
    }
    moved += (m - beta).norm() > 1e-6 * m.norm();
    canon.push_back(m);
  }
  EXPECT_EQ(checked, 11);
  EXPECT_EQ(quadratic, 7);
  EXPECT_GE(distinct, 5);  // the test tells the quadratic from the line
  EXPECT_GE(moved, 1);     // and stored weights as solved from their minimum-norm form
}

// The same per contact point while the contact set changes: a walking centipede at h = 1 ms
// lifts and sets down its legs, so points leave contact and come back (their history then
// starts again from 0) and the contacts' order in the problem changes.
TEST(SimContactSolver, WarmStartFollowsEachPointThroughContactChanges) {
  const Centipede c = makeCentipede({.segments = 3});
  const SimOptions so = walkingOptions(1e-3);
  WalkingCentipede walk(c, so);
  Simulator& sim = walk.sim();
  const Eigen::MatrixXd W = coneGenerators(so.mu, 4);
  // Per point, its minimum-norm weights of the consecutive steps in contact up to the last.
  std::map<int, std::vector<Eigen::VectorXd>> history;
  int reentries = 0, changes = 0, by_kind[4] = {};
  std::vector<int> last_active;
  std::set<int> ever;
  for (int step = 0; step < 400; ++step) {
    sim.step();
    const std::vector<int>& active = sim.activeContacts();
    changes += active != last_active;
    const Eigen::VectorXd& start = sim.lastWarmStart();
    ASSERT_EQ(start.size(), 4 * static_cast<int>(active.size()));
    for (std::size_t q = 0; q < active.size(); ++q) {
      const std::vector<Eigen::VectorXd>& h = history[active[q]];
      const int n = static_cast<int>(h.size());
      const Eigen::VectorXd expected = expectedStart(h, 4);
      ++by_kind[std::min(n, 5) == 5 ? 3 : std::min(n, 2)];
      reentries += n == 0 && ever.count(active[q]);
      EXPECT_LE((start.segment<4>(4 * q) - expected).norm(), 1e-10 * expected.norm())
          << "step " << step << " point " << active[q] << " history " << n;
    }
    // This step's weights, solved again; histories of points out of contact end.
    const Eigen::VectorXd beta = solveMaxDissipation(sim.lastProblem(), start, so.contact).beta;
    std::map<int, std::vector<Eigen::VectorXd>> next;
    for (std::size_t q = 0; q < active.size(); ++q) {
      std::vector<Eigen::VectorXd> h = std::move(history[active[q]]);
      h.push_back(minimumNormWeights(W, beta.segment<4>(4 * q)));
      next[active[q]] = std::move(h);
      ever.insert(active[q]);
    }
    history = std::move(next);
    last_active = active;
  }
  EXPECT_GE(changes, 4);
  EXPECT_GE(reentries, 2);
  for (int kind = 0; kind < 4; ++kind) EXPECT_GE(by_kind[kind], 2) << "kind " << kind;
}

}  // namespace
}  // namespace minv::sim
