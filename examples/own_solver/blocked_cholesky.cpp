#include "blocked_cholesky.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace own {

void BlockedCholeskySolver::factor() {
  Eigen::MatrixXd& A = M_;  // CRBA's M, factored in place (lower triangle)
  const int n = static_cast<int>(A.rows());
  for (int k = 0; k < n; k += block_) {
    const int b = std::min(block_, n - k), rest = n - k - b;
    // L_kk = chol(A_kk), column by column.
    for (int j = k; j < k + b; ++j) {
      double d = A(j, j) - A.row(j).segment(k, j - k).squaredNorm();
      if (!(d > 0)) throw std::runtime_error("blocked Cholesky: M is not positive definite");
      A(j, j) = std::sqrt(d);
      for (int i = j + 1; i < k + b; ++i)
        A(i, j) = (A(i, j) - A.row(i).segment(k, j - k).dot(A.row(j).segment(k, j - k))) / A(j, j);
    }
    if (rest == 0) break;
    // L_ik = A_ik L_kk⁻ᵀ for the panel below the diagonal block.
    auto panel = A.block(k + b, k, rest, b);
    A.block(k, k, b, b)
        .triangularView<Eigen::Lower>()
        .transpose()
        .solveInPlace<Eigen::OnTheRight>(panel);
    // Trailing update A_22 −= L_21 L_21ᵀ (lower triangle only).
    A.block(k + b, k + b, rest, rest).selfadjointView<Eigen::Lower>().rankUpdate(panel, -1.0);
  }
}

void BlockedCholeskySolver::inverse(minv::MatrixOut Minv) {
  // M⁻¹ = L⁻ᵀ L⁻¹: forward then back substitution on the columns of I.
  Minv.setIdentity();
  M_.triangularView<Eigen::Lower>().solveInPlace(Minv);
  M_.triangularView<Eigen::Lower>().transpose().solveInPlace(Minv);
}

void BlockedCholeskySolver::solve(minv::MatrixIn R, minv::MatrixOut X) {
  X = R;
  M_.triangularView<Eigen::Lower>().solveInPlace(X);
  M_.triangularView<Eigen::Lower>().transpose().solveInPlace(X);
}

void registerBlockedCholesky() {
  if (minv::findSolver("blocked-cholesky")) return;
  minv::registerSolver({"blocked-cholesky",
                        "CRBA + blocked right-looking Cholesky (examples/own_solver), B = 32",
                        [] { return std::make_unique<BlockedCholeskySolver>(); },
                        {}});
}

}  // namespace own
