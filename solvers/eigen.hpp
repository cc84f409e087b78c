// `eigen`: CRBA, then Eigen's blocked dense Cholesky (Eigen::LLT), a modern reference.
#pragma once

#include <Eigen/Cholesky>
#include <optional>

#include "solvers/crba_solver.hpp"

namespace minv {

class EigenSolver final : public CrbaSolver {
 public:
  void inverse(MatrixOut Minv) override {
    Minv.setIdentity();
    llt_->solveInPlace(Minv);
  }
  void solve(MatrixIn R, MatrixOut X) override {
    X = R;
    llt_->solveInPlace(X);
  }

 private:
  // Built in place: move-assigning an LLT reads its m_info, which Eigen 3.4's sized constructor
  // leaves uninitialised (UBSan: "load of value …, which is not a valid value for type
  // 'ComputationInfo'"); the sanitizer run of scripts/test covers it.
  void allocate(const Model& model) override { llt_.emplace(model.nv()); }
  void factor() override {
    llt_->compute(M_);
    if (llt_->info() != Eigen::Success)
      throw std::runtime_error("Eigen::LLT failed: M is not positive definite");
  }
  std::optional<Eigen::LLT<Eigen::MatrixXd>> llt_;
};

}  // namespace minv
