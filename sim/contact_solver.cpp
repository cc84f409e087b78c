#include "sim/contact_solver.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>

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

ContactSolution solveMaxDissipation(const ContactProblem& p, const Eigen::VectorXd& beta,
                                    const ContactSolverOptions& o) {
  const int nc = static_cast<int>(p.b.size()), k = p.k;
  if (p.A.rows() != 3 * nc || p.A.cols() != 3 * nc || p.v0.size() != 3 * nc)
    throw std::invalid_argument("contact problem: A must be 3nc x 3nc and v0 3nc");
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
  const double inradius = std::cos(std::numbers::pi / k);
  for (int c = 0; c < nc; ++c) {
    s.residuals.penetration = std::max(s.residuals.penetration, -(vplus(3 * c) + p.b(c)));
    const double fn = s.lambda(3 * c);
    double out = std::max(0.0, -fn);
    for (int j = 0; j < k; ++j) {  // facet normals of the polygon μ fn conv{t_j}
      const double th = 2 * std::numbers::pi * (j + 0.5) / k;
      out = std::max(out, std::cos(th) * s.lambda(3 * c + 1) + std::sin(th) * s.lambda(3 * c + 2) -
                              p.mu * fn * inradius);
    }
    s.residuals.cone = std::max(s.residuals.cone, out);
  }
  s.residuals.penetration = std::max(0.0, s.residuals.penetration);
  return s;
}

}  // namespace minv::sim
