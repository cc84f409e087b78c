// `lapack`: CRBA, then LAPACK's dense Cholesky through LAPACKE (linked to OpenBLAS):
// dpotrf (M = L Lᵀ), then dpotri for M⁻¹ or dpotrs for M⁻¹R. The paper's baseline.
// Cost: n³/3 + O(n²) flops to factor (LAWN 41), 2n³/3 more for the inverse, 2n²m to solve.
#pragma once

#include "solvers/crba_solver.hpp"

namespace minv {

class LapackSolver final : public CrbaSolver {
 public:
  // CRBA counted on the counting scalar; dpotrf, dpotri and dpotrs by their documented counts
  // (LAWN 41, which books divisions as multiplications and square roots apart).
  static std::vector<StageCount> countStages(const Model& model, const Eigen::VectorXd& q, int m);

  LapackSolver() { setThreads(1); }
  // OpenBLAS's thread count is process-wide: this sets it for every LAPACK call.
  void setThreads(int n) override;
  int threads() const override { return threads_; }
  void inverse(MatrixOut Minv) override;
  void inverseUpper(MatrixOut Minv) override;
  void solve(MatrixIn R, MatrixOut X) override;

 private:
  void allocate(const Model&) override {}
  void factor() override;  // in place: M_'s lower triangle becomes L
  int threads_ = 1;
};

}  // namespace minv
