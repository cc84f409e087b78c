// `eigen`: CRBA, then Eigen's blocked dense Cholesky (Eigen::LLT), a modern reference.
#pragma once

#include <Eigen/Cholesky>

#include "solvers/crba_solver.hpp"

namespace minv {

class EigenSolver final : public CrbaSolver {
 public:
  void inverse(MatrixOut Minv) override {
    Minv.setIdentity();
    llt_.solveInPlace(Minv);
  }
  void solve(MatrixIn R, MatrixOut X) override {
    X = R;
    llt_.solveInPlace(X);
  }

 private:
  void allocate(const Model& model) override { llt_ = Eigen::LLT<Eigen::MatrixXd>(model.nv()); }
  void factor() override {
    llt_.compute(M_);
    if (llt_.info() != Eigen::Success)
      throw std::runtime_error("Eigen::LLT failed: M is not positive definite");
  }
  Eigen::LLT<Eigen::MatrixXd> llt_;
};

}  // namespace minv
