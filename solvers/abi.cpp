#include "solvers/abi.hpp"

namespace minv {

std::vector<StageCount> AbiSolver::countStages(const Model& model, const Eigen::VectorXd& q,
                                               int m) {
  flopReset();
  StageCounter mark;
  abiPipeline<Counted>(model, q, m, mark);
  return stageCounts(mark);
}

void AbiSolver::setThreads(int n) {
  threads_ = std::max(1, n);
  if (model_) ws_ = std::make_unique<AbiWorkspace<double>>(*model_, threads_);
}

void AbiSolver::prepare(const Model& model) {
  model_ = &model;
  kin_ = std::make_unique<Kinematics<double>>(model, Origin::EachRoot);
  art_ = std::make_unique<Articulated<double>>(model);
  ws_ = std::make_unique<AbiWorkspace<double>>(model, threads_);
}

void AbiSolver::configure(const Eigen::VectorXd& q) {
  computeKinematics<double>(*model_, q, *kin_, threads_);
  articulatedInertias<double>(*model_, *kin_, *art_);
}

void AbiSolver::inverse(MatrixOut Minv) {
  abiInverse<double>(*model_, *kin_, *art_, *ws_, Minv);
}

void AbiSolver::solve(MatrixIn R, MatrixOut X) {
  abiSolve<double>(*model_, *kin_, *art_, *ws_, R, X);
}

}  // namespace minv
