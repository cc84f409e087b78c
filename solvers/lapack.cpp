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

std::vector<StageCount> LapackSolver::countStages(const Model& model, const Eigen::VectorXd& q,
                                                  int m) {
  flopReset();
  StageCounter mark;
  MatX<Counted> H(model.nv(), model.nv());
  countCrbaFront(model, q, H, mark);
  std::vector<StageCount> out = stageCounts(mark);
  // LAWN 41: POTRF n³/6 + n²/2 + n/3 mults, n³/6 − n/6 adds and n square roots; POTRI
  // n³/3 + n² + 2n/3 mults, n³/3 − n²/2 + n/6 adds; POTRS m·n(n+1) mults, m·n(n−1) adds. LAWN 41
  // books each reciprocal (n in POTRF, n in POTRI's TRTRI) as a multiplication: no divisions.
  const std::uint64_t n = model.nv();
  FlopCounts potrf{(n * n * n + 3 * n * n + 2 * n) / 6, (n * n * n - n) / 6, 0, n, 0, 0};
  out.push_back({"factorization", potrf, true});
  if (m == 0) {
    FlopCounts potri{
        (n * n * n + 3 * n * n + 2 * n) / 3, (2 * n * n * n - 3 * n * n + n) / 6, 0, 0, 0, 0};
    out.push_back({"inverse from factor", potri, true});
  } else {
    FlopCounts potrs{m * n * (n + 1), m * n * (n - 1), 0, 0, 0, 0};
    out.push_back({"back-substitution", potrs, true});
  }
  return out;
}

extern "C" void openblas_set_num_threads(int);

void LapackSolver::setThreads(int n) {
  threads_ = n < 1 ? 1 : n;
  openblas_set_num_threads(threads_);
}

void LapackSolver::factor() {
  // M = L Lᵀ, in place in the lower triangle.
  const lapack_int n = static_cast<lapack_int>(M_.rows());
  check(LAPACKE_dpotrf(LAPACK_COL_MAJOR, 'L', n, M_.data(), n), "dpotrf");
}

void LapackSolver::inverse(MatrixOut Minv) {
  // M⁻¹ = L⁻ᵀ L⁻¹ in the lower triangle, then mirrored.
  Minv = M_;
  const lapack_int n = static_cast<lapack_int>(Minv.rows());
  const lapack_int ld = static_cast<lapack_int>(Minv.outerStride());
  check(LAPACKE_dpotri(LAPACK_COL_MAJOR, 'L', n, Minv.data(), ld), "dpotri");
  Minv.triangularView<Eigen::StrictlyUpper>() = Minv.transpose();
}

void LapackSolver::inverseUpper(MatrixOut Minv) {
  // Lᵀ is the upper Cholesky factor: M⁻¹ straight into the upper triangle, nothing mirrored.
  Minv.triangularView<Eigen::Upper>() = M_.transpose();
  const lapack_int n = static_cast<lapack_int>(Minv.rows());
  const lapack_int ld = static_cast<lapack_int>(Minv.outerStride());
  check(LAPACKE_dpotri(LAPACK_COL_MAJOR, 'U', n, Minv.data(), ld), "dpotri");
}

void LapackSolver::solve(MatrixIn R, MatrixOut X) {
  // X = L⁻ᵀ L⁻¹ R.
  X = R;
  const lapack_int n = static_cast<lapack_int>(X.rows()), m = static_cast<lapack_int>(X.cols());
  const lapack_int ld = static_cast<lapack_int>(X.outerStride());
  check(LAPACKE_dpotrs(LAPACK_COL_MAJOR, 'L', n, m, M_.data(), n, X.data(), ld), "dpotrs");
}

}  // namespace minv
