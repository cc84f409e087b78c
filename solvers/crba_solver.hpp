// The front end shared by the Cholesky family (lapack, eigen, naive, ltl, ltdl): kinematics and
// CRBA form M at each configuration (core/crba.hpp), then the method factors it.
#pragma once

#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "core/crba.hpp"
#include "solvers/solver.hpp"

namespace minv {

// Kinematics and CRBA on the counting scalar, one mark per stage; H (nv×nv) receives M.
inline void countCrbaFront(const Model& model, const Eigen::VectorXd& q, MatX<Counted>& H,
                           StageCounter& mark) {
  Kinematics<Counted> kin(model, Origin::EachRoot);
  std::vector<Mat6<Counted>> Ic(model.nb());
  const VecX<Counted> qc = q.cast<Counted>();
  computeKinematics<Counted>(model, qc, kin, mark);
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
    kin_ = std::make_unique<Kinematics<double>>(model, Origin::EachRoot);
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

// A Cholesky-family solver on the tree's DOF parent array λ: CRBA, then a method given as three
// kernels on the scalar T (so the timed code is the counted code) and a check of its factor:
//   Method::factor<T>(λ, H)          factor M in place in H
//   Method::inverse<T>(λ, H, X)      X = M⁻¹ from the factor
//   Method::solve<T>(λ, H, x)        x ← M⁻¹x, one column
//   Method::factorOk(H)              whether the factor is usable (M positive definite)
//   Method::kName                    its name in messages
template <class Method>
class TreeCholeskySolver final : public CrbaSolver {
 public:
  static std::vector<StageCount> countStages(const Model& model, const Eigen::VectorXd& q, int m) {
    const std::vector<int>& lambda = model.dofParent();
    return countCholeskyPipeline(
        model, q, m, [&](MatX<Counted>& H) { Method::template factor<Counted>(lambda, H); },
        [&](const MatX<Counted>& H, MatX<Counted>& X) {
          Method::template inverse<Counted>(lambda, H, X);
        },
        [&](const MatX<Counted>& H, auto&& x) { Method::template solve<Counted>(lambda, H, x); });
  }

  void inverse(MatrixOut Minv) override {
    Method::template inverse<double>(model_->dofParent(), M_, Minv);
  }
  void solve(MatrixIn R, MatrixOut X) override {
    X = R;
    for (int c = 0; c < X.cols(); ++c)
      Method::template solve<double>(model_->dofParent(), M_, X.col(c));
  }

 private:
  void allocate(const Model&) override {}
  void factor() override {
    Method::template factor<double>(model_->dofParent(), M_);
    if (!Method::factorOk(M_))
      throw std::runtime_error(std::string(Method::kName) + " failed: M is not positive definite");
  }
};

}  // namespace minv
