#include "sim/contact_solver.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <stdexcept>
#include <string>
#include <vector>

#include "sim/clones.hpp"

namespace minv::sim {

Eigen::MatrixXd coneGenerators(double mu, int k) {
  if (k < 3) throw std::invalid_argument("the linearised friction cone needs k >= 3 directions");
  Eigen::MatrixXd W(3, k);
  for (int j = 0; j < k; ++j) {
    const double th = 2 * std::numbers::pi * j / k;
    W.col(j) << 1.0, mu * std::cos(th), mu * std::sin(th);
  }
  return W;
}

ContactResiduals solveBoundQP(const Eigen::MatrixXd& G, const Eigen::VectorXd& g0,
                              Eigen::VectorXd& beta, const ContactSolverOptions& o) {
  const int m = static_cast<int>(g0.size());
  if (beta.size() != m) beta = Eigen::VectorXd::Zero(m);
  beta = beta.cwiseMax(0.0);
  ContactResiduals r;
  if (m == 0) return r;
  const double tol = o.tolerance * std::max(g0.cwiseAbs().maxCoeff(), o.floor);
  Eigen::VectorXd g = G * beta + g0;
  auto kkt = [&] {
    double e = 0;
    for (int j = 0; j < m; ++j) e = std::max(e, std::abs(std::min(beta(j), g(j))));
    return e;
  };
  r.converged = false;
  for (int it = 1; it <= o.max_iterations; ++it) {
    for (int j = 0; j < m; ++j) {
      const double d = G(j, j);
      if (!(d > 0)) continue;
      const double nb = std::max(0.0, beta(j) - g(j) / d);
      const double delta = nb - beta(j);
      if (delta != 0) {
        beta(j) = nb;
        g.noalias() += delta * G.col(j);
      }
    }
    if (it % 64 == 0) g.noalias() = G * beta + g0;  // no drift from the incremental updates
    r.iterations = it;
    if (kkt() <= tol) {
      r.converged = true;
      break;
    }
  }
  g.noalias() = G * beta + g0;
  r.kkt = kkt();
  for (int j = 0; j < m; ++j)
    r.complementarity = std::max(r.complementarity, std::abs(beta(j) * g(j)));
  return r;
}

namespace {

// The linearised cone of (μ, k): its generators W (3×k), the facet normals of the polygon
// μ fn conv{t_j} (at angles 2π(j + ½)/k) and its inradius cos(π/k). Built once per thread and
// kept while (μ, k) repeat, as they do step after step: its sines and cosines are not free. A
// reference to it stays valid until the next cone() call on the thread with another (μ, k).
struct Cone {
  double mu = std::numeric_limits<double>::quiet_NaN();
  int k = 0;
  Eigen::MatrixXd W;
  std::vector<double> fc, fs;
  double inradius = 0;
};
const Cone& cone(double mu, int k) {
  thread_local Cone c;
  if (c.mu == mu && c.k == k) return c;
  c.W = coneGenerators(mu, k);
  c.fc.resize(k), c.fs.resize(k);
  for (int j = 0; j < k; ++j) {
    const double th = 2 * std::numbers::pi * (j + 0.5) / k;
    c.fc[j] = std::cos(th), c.fs[j] = std::sin(th);
  }
  c.inradius = std::cos(std::numbers::pi / k);
  c.mu = mu, c.k = k;
  return c;
}

// The residuals measured on λ and v⁺ = Aλ + v0 themselves: penetration and cone.
void residualsOnLambda(const ContactProblem& p, const Cone& cn, const double* vplus,
                       ContactSolution& s) {
  const int nc = static_cast<int>(p.b.size()), k = p.k;
  const double inradius = cn.inradius;
  const std::vector<double>&fc = cn.fc, &fs = cn.fs;
  for (int c = 0; c < nc; ++c) {
    s.residuals.penetration = std::max(s.residuals.penetration, -(vplus[3 * c] + p.b(c)));
    const double fn = s.lambda(3 * c);
    double out = std::max(0.0, -fn);
    for (int j = 0; j < k; ++j)
      out = std::max(
          out, fc[j] * s.lambda(3 * c + 1) + fs[j] * s.lambda(3 * c + 2) - p.mu * fn * inradius);
    s.residuals.cone = std::max(s.residuals.cone, out);
  }
  s.residuals.penetration = std::max(0.0, s.residuals.penetration);
}

// Generators per contact the solver holds on the stack.
constexpr int kMaxGenerators = 64;

void checkProblem(const ContactProblem& p) {
  const int nc = static_cast<int>(p.b.size());
  if (p.A.rows() != 3 * nc || p.A.cols() != 3 * nc || p.v0.size() != 3 * nc)
    throw std::invalid_argument("contact problem: A must be 3nc x 3nc and v0 3nc");
  if (p.k < 3) throw std::invalid_argument("the linearised friction cone needs k >= 3 directions");
  if (p.k > kMaxGenerators)
    throw std::invalid_argument("the linearised friction cone takes at most " +
                                std::to_string(kMaxGenerators) + " directions");
}

// g_c = Wᵀ(u_c + [b_c; 0; 0]): contact c's generator velocities from its contact velocities.
inline void generatorVelocities(const double* Wd, const double* u, const Eigen::VectorXd& b, int c,
                                int k, double* g) {
  const double un = u[3 * c] + b(c), u1 = u[3 * c + 1], u2 = u[3 * c + 2];
  for (int j = 0; j < k; ++j) g[j] = Wd[3 * j] * un + Wd[3 * j + 1] * u1 + Wd[3 * j + 2] * u2;
}

// λ_c = W β_c for every contact c.
void lambdaFromBeta(const double* Wd, const Eigen::VectorXd& beta, int k, Eigen::VectorXd& lambda) {
  const int nc = static_cast<int>(lambda.size()) / 3;
  for (int c = 0; c < nc; ++c) {
    const double* b = beta.data() + k * c;
    double l0 = 0, l1 = 0, l2 = 0;
    for (int j = 0; j < k; ++j)
      l0 += Wd[3 * j] * b[j], l1 += Wd[3 * j + 1] * b[j], l2 += Wd[3 * j + 2] * b[j];
    lambda(3 * c) = l0, lambda(3 * c + 1) = l1, lambda(3 * c + 2) = l2;
  }
}

// u += a0 d0 + a1 d1 + a2 d2 over n entries: the sweep's one long loop.
inline void addThreeColumns(int n, const double* a0, const double* a1, const double* a2, double d0,
                            double d1, double d2, double* u) {
  for (int i = 0; i < n; ++i) u[i] += a0[i] * d0 + a1[i] * d1 + a2[i] * d2;
}

// ‖min(β, g)‖_∞ with g = Wᵀ(u + [b; 0; 0]) per contact (left in g).
inline double kktResidual(const ContactProblem& p, const double* Wd, const Eigen::VectorXd& beta,
                          const Eigen::VectorXd& u, Eigen::VectorXd& g) {
  const int nc = static_cast<int>(p.b.size()), k = p.k, m = k * nc;
  for (int c = 0; c < nc; ++c) generatorVelocities(Wd, u.data(), p.b, c, k, g.data() + k * c);
  // The maximum in 8 independent lanes (one vector; a single running maximum is a chain of
  // dependent max instructions, one per generator), then across them.
  constexpr int kLanes = 8;
  double e[kLanes] = {};
  const double *bb = beta.data(), *gg = g.data();
  int j = 0;
  for (; j + kLanes <= m; j += kLanes)
    for (int l = 0; l < kLanes; ++l)
      e[l] = std::max(e[l], std::abs(std::min(bb[j + l], gg[j + l])));
  for (; j < m; ++j) e[0] = std::max(e[0], std::abs(std::min(bb[j], gg[j])));
  double r = 0;
  for (int l = 0; l < kLanes; ++l) r = std::max(r, e[l]);
  return r;
}

// One block Gauss–Seidel sweep: contact by contact, its k generators by coordinate descent on
// the local gradient (exact through G_cc = Gd's block c; Rd: −1 / diag, 0 = never moved), then
// one 3-column update of the contact velocities u. K: k at compile time, or Eigen::Dynamic.
template <int K>
void contactSweep(const ContactProblem& p, const double* Wd, const double* Gd, const double* Rd,
                  int inner, ContactSolution& s, Eigen::VectorXd& u) {
  const int nc = static_cast<int>(p.b.size()), k = K == Eigen::Dynamic ? p.k : K, n3 = 3 * nc;
  constexpr int n = K == Eigen::Dynamic ? kMaxGenerators : K;
  double gc[n];
  double* uu = u.data();
  for (int c = 0; c < nc; ++c) {
    double* bc = s.beta.data() + k * c;
    const double* G = Gd + k * k * c;
    const double* rd = Rd + k * c;
    generatorVelocities(Wd, uu, p.b, c, k, gc);
    // Δλ_c = W Δβ_c, summed as the generators move (off the chain of dependent steps).
    double d0 = 0, d1 = 0, d2 = 0;
    bool changed = false;
    for (int sweep = 0; sweep < inner; ++sweep) {
      // The step Δβ_j = max(−β_j, −g_j / G_jj) (β_j + Δβ_j ≥ 0), without data-dependent
      // branches (a generator at its bound moves or not unpredictably): rd = 0 gives Δβ_j = 0,
      // and adding 0·G leaves gc as it is. rd holds −1 / G_jj, so that no negation lengthens
      // the chain from one generator's step to the next (the same values: IEEE negation and
      // products are sign-symmetric; 2 % off the S = 5 centipede's solve on Zen 5).
      bool moved = false;
      for (int j = 0; j < k; ++j) {
        const double delta = std::max(-bc[j], gc[j] * rd[j]);
        bc[j] += delta;
        for (int i = 0; i < k; ++i) gc[i] += delta * G[k * j + i];
        d0 += delta * Wd[3 * j], d1 += delta * Wd[3 * j + 1], d2 += delta * Wd[3 * j + 2];
        moved |= delta != 0;
      }
      changed |= moved;
      if (!moved) break;
    }
    if (!changed) continue;
    // u += A_{:,c} Δλ_c (three contiguous columns, one pass over u).
    s.lambda(3 * c) += d0, s.lambda(3 * c + 1) += d1, s.lambda(3 * c + 2) += d2;
    const double* a0 = p.A.data() + static_cast<std::ptrdiff_t>(3 * c) * n3;
    const double *a1 = a0 + n3, *a2 = a1 + n3;
    addThreeColumns(n3, a0, a1, a2, d0, d1, d2, uu);
  }
}

// G_cc = Wᵀ A_cc W for every contact c (k×k each, side by side in Gd) and the negated
// reciprocals of their diagonals in Rd (0 where not positive). K: k at compile time, or
// Eigen::Dynamic.
template <int K>
void diagonalBlocks(const ContactProblem& p, const double* Wd, double* Gd, double* Rd) {
  const int nc = static_cast<int>(p.b.size()), k = K == Eigen::Dynamic ? p.k : K;
  constexpr int n = K == Eigen::Dynamic ? kMaxGenerators : K;
  for (int c = 0; c < nc; ++c) {
    // A_cc W (3×k), then Wᵀ (A_cc W), in plain loops.
    double aw[3 * n];
    for (int j = 0; j < k; ++j)
      for (int r = 0; r < 3; ++r)
        aw[3 * j + r] = p.A(3 * c + r, 3 * c) * Wd[3 * j] +
                        p.A(3 * c + r, 3 * c + 1) * Wd[3 * j + 1] +
                        p.A(3 * c + r, 3 * c + 2) * Wd[3 * j + 2];
    double* G = Gd + k * k * c;
    for (int j = 0; j < k; ++j)
      for (int i = 0; i < k; ++i)
        G[k * j + i] =
            Wd[3 * i] * aw[3 * j] + Wd[3 * i + 1] * aw[3 * j + 1] + Wd[3 * i + 2] * aw[3 * j + 2];
    for (int j = 0; j < k; ++j) {
      const double d = G[k * j + j];
      Rd[k * c + j] = d > 0 ? -1 / d : 0.0;
    }
  }
}

// u = v0 + A λ, three columns of A (one contact's) per pass over u.
inline void contactVelocities(const ContactProblem& p, const Eigen::VectorXd& lambda,
                              Eigen::VectorXd& u) {
  const int n3 = static_cast<int>(p.v0.size());
  double* uu = u.data();
  for (int i = 0; i < n3; ++i) uu[i] = p.v0(i);
  for (int c = 0; c < n3; c += 3) {
    const double* a0 = p.A.data() + static_cast<std::ptrdiff_t>(c) * n3;
    addThreeColumns(n3, a0, a0 + n3, a0 + 2 * n3, lambda(c), lambda(c + 1), lambda(c + 2), uu);
  }
}

// The solve's scratch, kept per thread and grown, never shrunk: the diagonal blocks G_cc,
// the negated reciprocals of their diagonals, the contact velocities u and generator velocities g.
struct SolveScratch {
  Eigen::VectorXd Gd, Rd, u, g;
};

// The whole solve (see the header), compiled for AVX-512 and AVX2 beside the portable build
// and chosen at load time (GCC target_clones; FMA contraction aside, the same arithmetic on
// every path). s.beta holds the warm start on entry (any size: a wrong one starts from 0).
// Measured and dropped on the S = 5 centipede (Zen 4; most solves take one sweep): a first
// sweep that forms each contact's velocities from its rows of A (no u = Aλ + v0 before it)
// made the solve stage slower, 1.25 -> 1.33 us in the step; in a standalone probe, steps on
// gradients pre-scaled by −1/G_jj were 7-9 % slower, u = Aλ + v0 in blocks of 8 rows 1.35-2x
// slower, in groups of 16 rows summed over every column (two partial sums) 1.6x slower (170 ->
// 270 ns), and Eigen's product with vectorised reciprocals no faster; the diagonals'
// reciprocals divided in vector lanes left the solve stage as it was (1.19-1.22 us in the step
// against 1.21-1.22).
MINV_CLONES_FLAT void solveInto(const ContactProblem& p, const ContactSolverOptions& o,
                                const Cone& cn, SolveScratch& w, ContactSolution& s) {
  const int nc = static_cast<int>(p.b.size()), k = p.k, m = k * nc;
  const double* Wd = cn.W.data();  // W(r, j) = Wd[3 j + r]
  const int inner = std::max(1, o.inner_sweeps);
  if (s.beta.size() == m)
    s.beta = s.beta.cwiseMax(0.0);
  else
    s.beta.setZero(m);
  s.lambda.resize(3 * nc);
  ContactResiduals& r = s.residuals;
  r = ContactResiduals{};
  if (nc == 0) return;
  if (w.Gd.size() < k * m) w.Gd.resize(k * m);
  if (w.Rd.size() < m) w.Rd.resize(m), w.g.resize(m);
  if (w.u.size() < 3 * nc) w.u.resize(3 * nc);
  auto g = w.g.head(m);
  double *Gd = w.Gd.data(), *Rd = w.Rd.data();
  // Diagonal blocks G_cc = Wᵀ A_cc W (k×k each, side by side), the negated reciprocals of
  // their diagonals (0 where not positive: that generator is never moved); λ_c = W β_c.
  if (k == 4)
    diagonalBlocks<4>(p, Wd, Gd, Rd);
  else
    diagonalBlocks<Eigen::Dynamic>(p, Wd, Gd, Rd);
  lambdaFromBeta(Wd, s.beta, k, s.lambda);
  // u = Aλ + v0: the contact velocities, kept up to date as λ changes.
  if (s.beta.any())
    contactVelocities(p, s.lambda, w.u);
  else
    w.u.head(3 * nc) = p.v0;
  // The scale of the relative test: ‖g0‖∞, g0 = Wᵀ(v0 + [b; 0; 0]).
  for (int c = 0; c < nc; ++c) generatorVelocities(Wd, p.v0.data(), p.b, c, k, g.data() + k * c);
  const double tol = o.tolerance * std::max(g.cwiseAbs().maxCoeff(), o.floor);
  r.converged = false;
  // λ = Wβ and u = Aλ + v0 afresh, and the KKT residual on them (g left for the checks below).
  auto fresh = [&] {
    lambdaFromBeta(Wd, s.beta, k, s.lambda);
    contactVelocities(p, s.lambda, w.u);
    return kktResidual(p, Wd, s.beta, w.u, w.g);
  };
  for (int it = 1; it <= o.max_iterations; ++it) {
    // One block Gauss-Seidel sweep (fixed-size for the usual k = 4).
    if (k == 4)
      contactSweep<4>(p, Wd, Gd, Rd, inner, s, w.u);
    else
      contactSweep<Eigen::Dynamic>(p, Wd, Gd, Rd, inner, s, w.u);
    // No drift from the incremental updates: every 64 sweeps, λ and u afresh.
    if (it % 64 == 0) {
      lambdaFromBeta(Wd, s.beta, k, s.lambda);
      contactVelocities(p, s.lambda, w.u);
    }
    r.iterations = it;
    if (kktResidual(p, Wd, s.beta, w.u, w.g) > tol) continue;
    // Below the tolerance on the incremental u: confirmed on λ and v⁺ = u afresh (rounding in
    // the updates can leave the two a hair apart), the state the residuals describe.
    r.kkt = fresh();
    if (r.kkt <= tol) {
      r.converged = true;
      break;
    }
  }
  if (!r.converged) r.kkt = fresh();
  // Complementarity, penetration and cone on that λ and v⁺.
  for (int j = 0; j < m; ++j)
    r.complementarity = std::max(r.complementarity, std::abs(s.beta(j) * g(j)));
  residualsOnLambda(p, cn, w.u.data(), s);
}

}  // namespace

void solveMaxDissipation(const ContactProblem& p, const Eigen::VectorXd& beta,
                         const ContactSolverOptions& o, ContactSolution& s) {
  checkProblem(p);
  const Cone& cn = cone(p.mu, p.k);  // no other cone() call until the solve returns
  thread_local SolveScratch scratch;
  if (&beta != &s.beta) s.beta = beta;
  solveInto(p, o, cn, scratch, s);
}

ContactSolution solveMaxDissipation(const ContactProblem& p, const Eigen::VectorXd& beta,
                                    const ContactSolverOptions& o) {
  ContactSolution s;
  solveMaxDissipation(p, beta, o, s);
  return s;
}

ContactSolution solveMaxDissipationReference(const ContactProblem& p, const Eigen::VectorXd& beta,
                                             const ContactSolverOptions& o) {
  checkProblem(p);
  const int nc = static_cast<int>(p.b.size()), k = p.k;
  const Eigen::MatrixXd W = coneGenerators(p.mu, k);
  // G = WᵀAW blockwise, g0 = Wᵀ(v0 + [b; 0; 0]).
  Eigen::MatrixXd AW(3 * nc, k * nc), G(k * nc, k * nc);
  for (int c = 0; c < nc; ++c) AW.middleCols(k * c, k).noalias() = p.A.middleCols(3 * c, 3) * W;
  for (int c = 0; c < nc; ++c)
    G.middleRows(k * c, k).noalias() = W.transpose() * AW.middleRows(3 * c, 3);
  Eigen::VectorXd g0(k * nc);
  for (int c = 0; c < nc; ++c) {
    Eigen::Vector3d vc = p.v0.segment<3>(3 * c);
    vc(0) += p.b(c);
    g0.segment(k * c, k) = W.transpose() * vc;
  }
  ContactSolution s;
  s.beta = beta;
  s.residuals = solveBoundQP(G, g0, s.beta, o);
  s.lambda.resize(3 * nc);
  for (int c = 0; c < nc; ++c) s.lambda.segment<3>(3 * c) = W * s.beta.segment(k * c, k);
  // Residuals on λ and v⁺ themselves.
  const Eigen::VectorXd vplus = p.A * s.lambda + p.v0;
  residualsOnLambda(p, cone(p.mu, k), vplus.data(), s);
  return s;
}

}  // namespace minv::sim
