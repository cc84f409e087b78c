// The front end shared by the Cholesky family (lapack, eigen, naive, ltl, ltdl): kinematics and
// CRBA form M at each configuration (core/crba.hpp), then the method factors it.
#pragma once

#include <memory>
#include <vector>

#include "core/crba.hpp"
#include "solvers/solver.hpp"

namespace minv {

class CrbaSolver : public Solver {
 public:
  void prepare(const Model& model) final {
    model_ = &model;
    kin_ = std::make_unique<Kinematics<double>>(model);
    Ic_.assign(model.nb(), Mat6<double>::Zero());
    M_ = Eigen::MatrixXd::Zero(model.nv(), model.nv());
    allocate(model);
  }

  // Kinematics, CRBA, then the method's factorization of M.
  void configure(const Eigen::VectorXd& q) final {
    computeKinematics<double>(*model_, q, *kin_);
    crba<double>(*model_, *kin_, Ic_, M_);
    factor();
  }

 protected:
  virtual void allocate(const Model& model) = 0;  // the factor's storage
  virtual void factor() = 0;  // factor M_, in place where the method allows

  const Model* model_ = nullptr;
  std::unique_ptr<Kinematics<double>> kin_;
  std::vector<Mat6<double>> Ic_;
  Eigen::MatrixXd M_;
};

}  // namespace minv
