// `naive`: CRBA, then the textbook dense Cholesky M = L Lᵀ (Golub & Van Loan, Alg. 4.2.1,
// "inner product" form) and dense triangular solves; no library. The paper's Table 2 row.
// Cost: n³/6 + O(n²) multiplications and n square roots to factor; 2n² per right-hand side.
#pragma once

#include <cmath>

#include "solvers/crba_solver.hpp"

namespace minv {

// A (n×n, lower triangle read) becomes L in place: L_jj = √(A_jj − Σ L_jp²),
// L_ij = (A_ij − Σ L_ip L_jp) / L_jj.
template <class T>
void naiveCholesky(MatX<T>& A) {
  using std::sqrt;
  const int n = static_cast<int>(A.rows());
  for (int j = 0; j < n; ++j) {
    // Diagonal.
    T s = A(j, j);
    for (int p = 0; p < j; ++p) s -= A(j, p) * A(j, p);
    A(j, j) = sqrt(s);
    // Column below the diagonal.
    for (int i = j + 1; i < n; ++i) {
      T t = A(i, j);
      for (int p = 0; p < j; ++p) t -= A(i, p) * A(j, p);
      A(i, j) = t / A(j, j);
    }
  }
}

// x = L⁻ᵀ L⁻¹ x for one column; rows above `first` of x are known to be zero.
template <class T, class Col>
void naiveCholeskySolve(const MatX<T>& L, Col&& x, int first = 0) {
  const int n = static_cast<int>(L.rows());
  // Forward: L y = x.
  for (int i = first; i < n; ++i) {
    T t = x(i);
    for (int p = first; p < i; ++p) t -= L(i, p) * x(p);
    x(i) = t / L(i, i);
  }
  // Backward: Lᵀ z = y.
  for (int i = n - 1; i >= 0; --i) {
    T t = x(i);
    for (int p = i + 1; p < n; ++p) t -= L(p, i) * x(p);
    x(i) = t / L(i, i);
  }
}

// M⁻¹ column by column from e_k (forward substitution starts at row k), lower half mirrored.
template <class T, class Out>
void naiveCholeskyInverse(const MatX<T>& L, Out&& Minv) {
  Minv.setIdentity();
  for (int k = 0; k < L.rows(); ++k) naiveCholeskySolve<T>(L, Minv.col(k), k);
  Minv.template triangularView<Eigen::StrictlyUpper>() = Minv.transpose();
}

class NaiveSolver final : public CrbaSolver {
 public:
  static std::vector<StageCount> countStages(const Model& model, const Eigen::VectorXd& q, int m) {
    return countCholeskyPipeline(
        model, q, m, [](MatX<Counted>& H) { naiveCholesky<Counted>(H); },
        [](const MatX<Counted>& H, MatX<Counted>& X) { naiveCholeskyInverse<Counted>(H, X); },
        [](const MatX<Counted>& H, auto&& x) { naiveCholeskySolve<Counted>(H, x); });
  }

  void inverse(MatrixOut Minv) override { naiveCholeskyInverse<double>(M_, Minv); }
  void solve(MatrixIn R, MatrixOut X) override {
    X = R;
    for (int c = 0; c < X.cols(); ++c) naiveCholeskySolve<double>(M_, X.col(c));
  }

 private:
  void allocate(const Model&) override {}
  void factor() override {
    naiveCholesky<double>(M_);
    if (!M_.diagonal().allFinite())
      throw std::runtime_error("naive Cholesky failed: M is not positive definite");
  }
};

}  // namespace minv
