#include "solvers/lapack.hpp"

#include <lapacke.h>

#include <stdexcept>
#include <string>

namespace minv {

namespace {
void check(lapack_int info, const char* routine) {
  if (info != 0)
    throw std::runtime_error(std::string(routine) + " failed (info = " + std::to_string(info) +
                             "): M is not positive definite to working precision");
}
}  // namespace

void LapackSolver::factor() {
  // M = L Lᵀ, in place in the lower triangle.
  const lapack_int n = static_cast<lapack_int>(M_.rows());
  check(LAPACKE_dpotrf(LAPACK_COL_MAJOR, 'L', n, M_.data(), n), "dpotrf");
}

void LapackSolver::inverse(Eigen::MatrixXd& Minv) {
  // M⁻¹ = L⁻ᵀ L⁻¹ in the lower triangle, then mirrored.
  Minv = M_;
  const lapack_int n = static_cast<lapack_int>(Minv.rows());
  check(LAPACKE_dpotri(LAPACK_COL_MAJOR, 'L', n, Minv.data(), n), "dpotri");
  Minv.triangularView<Eigen::StrictlyUpper>() = Minv.transpose();
}

void LapackSolver::solve(const Eigen::MatrixXd& R, Eigen::MatrixXd& X) {
  // X = L⁻ᵀ L⁻¹ R.
  X = R;
  const lapack_int n = static_cast<lapack_int>(X.rows()), m = static_cast<lapack_int>(X.cols());
  check(LAPACKE_dpotrs(LAPACK_COL_MAJOR, 'L', n, m, M_.data(), n, X.data(), n), "dpotrs");
}

}  // namespace minv
