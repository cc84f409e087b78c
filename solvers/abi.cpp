#include "solvers/abi.hpp"

namespace minv {

std::vector<StageCount> AbiSolver::countStages(const Model& model, const Eigen::VectorXd& q,
                                               int m) {
  flopReset();
  StageCounter mark;
  Kinematics<Counted> kin(model);
  Articulated<Counted> art(model);
  AbiWorkspace<Counted> ws(model);
  const VecX<Counted> qc = q.cast<Counted>();
  forwardKinematics<Counted>(model, qc, kin);
  mark("spatial axes");
  worldInertias<Counted>(model, kin);
  mark("isolated inertias");
  articulatedInertias<Counted>(model, kin, art);
  mark("articulated inertias");
  MatX<Counted> X(model.nv(), m > 0 ? m : model.nv());
  if (m == 0) {
    abiInverse<Counted>(model, kin, art, ws, X, mark);
  } else {
    const MatX<Counted> R = MatX<Counted>::Identity(model.nv(), m);
    abiSolve<Counted>(model, kin, art, ws, R, X, mark);
  }
  return stageCounts(mark);
}

void AbiSolver::prepare(const Model& model) {
  model_ = &model;
  kin_ = std::make_unique<Kinematics<double>>(model);
  art_ = std::make_unique<Articulated<double>>(model);
  ws_ = std::make_unique<AbiWorkspace<double>>(model);
}

void AbiSolver::configure(const Eigen::VectorXd& q) {
  computeKinematics<double>(*model_, q, *kin_);
  articulatedInertias<double>(*model_, *kin_, *art_);
}

void AbiSolver::inverse(Eigen::MatrixXd& Minv) { abiInverse<double>(*model_, *kin_, *art_, *ws_, Minv); }

void AbiSolver::solve(const Eigen::MatrixXd& R, Eigen::MatrixXd& X) {
  abiSolve<double>(*model_, *kin_, *art_, *ws_, R, X);
}

}  // namespace minv
