// The front end shared by the Cholesky family (lapack, eigen, naive, ltl, ltdl): kinematics and
// CRBA form M at each configuration (core/crba.hpp), then the method factors it.
#pragma once

#include <memory>
#include <vector>

#include "core/crba.hpp"
#include "solvers/solver.hpp"

namespace minv {

// Kinematics and CRBA on the counting scalar, one mark per stage; H (nv×nv) receives M.
inline void countCrbaFront(const Model& model, const Eigen::VectorXd& q, MatX<Counted>& H,
                           StageCounter& mark) {
  Kinematics<Counted> kin(model);
  std::vector<Mat6<Counted>> Ic(model.nb());
  const VecX<Counted> qc = q.cast<Counted>();
  forwardKinematics<Counted>(model, qc, kin, mark);
  worldInertias<Counted>(model, kin, mark);
  compositeInertias<Counted>(model, kin, Ic);
  mark("composite inertias");
  crbaMassMatrix<Counted>(model, kin, Ic, H, mark);
}

// The counted pipeline of a Cholesky-family method: CRBA, factor(H) and, for M⁻¹ (m = 0)
// inverse(H, X), or for M⁻¹R solveColumn(H, x) on each of m columns.
template <class Factor, class Inverse, class SolveColumn>
std::vector<StageCount> countCholeskyPipeline(const Model& model, const Eigen::VectorXd& q, int m,
                                              Factor factor, Inverse inverse,
                                              SolveColumn solveColumn) {
  flopReset();
  StageCounter mark;
  MatX<Counted> H(model.nv(), model.nv());
  countCrbaFront(model, q, H, mark);
  factor(H);
  mark("factorization");
  MatX<Counted> X = MatX<Counted>::Identity(model.nv(), m > 0 ? m : model.nv());
  if (m == 0) {
    inverse(H, X);
    mark("inverse from factor");
  } else {
    for (int c = 0; c < m; ++c) solveColumn(H, X.col(c));
    mark("back-substitution");
  }
  return stageCounts(mark);
}

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
  virtual void factor() = 0;                      // factor M_, in place where the method allows

  const Model* model_ = nullptr;
  std::unique_ptr<Kinematics<double>> kin_;
  std::vector<Mat6<double>> Ic_;
  Eigen::MatrixXd M_;
};

}  // namespace minv
