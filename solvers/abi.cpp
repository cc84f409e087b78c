// abi's solver on doubles. Not compiled into libminv_solvers: each instruction-set level
// compiles it into its own module (solvers/abi_variant.cpp, solvers/abi_variants.hpp).
#include "solvers/abi.hpp"

#include "core/cpu.hpp"

namespace minv {

void AbiSolver::setThreads(int n) {
  threads_ = std::max(1, n);
  if (model_) allocate();
}

void AbiSolver::prepare(const Model& model) {
  model_ = &model;
  allocate();
}

// A configuration and a workspace per thread used: threads_, or one below kParallelColumns.
void AbiSolver::allocate() {
  const int team = model_->nv() >= kParallelColumns ? threads_ : 1;
  kin_.clear(), art_.clear();
  kin_.reserve(team), art_.reserve(team);
  for (int t = 0; t < team; ++t)
    kin_.emplace_back(*model_, Origin::EachRoot), art_.emplace_back(*model_);
  ws_ = std::make_unique<AbiWorkspace<double>>(*model_, team);
  ws_->stream_rows = streamStridedRows();
}

void AbiSolver::configure(const Eigen::VectorXd& q) {
  const int team = static_cast<int>(kin_.size());
  if (team == 1) {
    computeKinematics<double>(*model_, q, kin_[0]);
    articulatedInertias<double>(*model_, kin_[0], art_[0]);
    return;
  }
  // Every thread its own copy, all at once (the same code, so the same bits); copies for
  // threads the runtime did not start are made after.
  int started = 1;
#pragma omp parallel num_threads(team)
  {
    const int t = omp_get_thread_num();
    if (t == 0) started = omp_get_num_threads();
    computeKinematics<double>(*model_, q, kin_[t]);
    articulatedInertias<double>(*model_, kin_[t], art_[t]);
  }
  for (int t = started; t < team; ++t) {
    computeKinematics<double>(*model_, q, kin_[t]);
    articulatedInertias<double>(*model_, kin_[t], art_[t]);
  }
}

void AbiSolver::inverse(MatrixOut Minv) {
  abiInverse<double>(*model_, configurations(), *ws_, Minv);
}

void AbiSolver::inverseUpper(MatrixOut Minv) {
  abiInverse<double>(*model_, configurations(), *ws_, Minv, NoMark{}, true);
}

void AbiSolver::solve(MatrixIn R, MatrixOut X) {
  abiSolve<double>(*model_, configurations(), *ws_, R, X);
}

void AbiSolver::sweepsOnly() {
  constexpr int W = kAbiLanes<double>;
  const Model& m = *model_;
  FlushSubnormals flush;
  for (int c0 = 0; c0 + W <= m.nv(); c0 += W) {
    const int last = m.dofBody(c0 + W - 1);
    abiBackward<double, W, true>(m, kin_[0], art_[0], ws_->wide[0], last, c0, W);
    abiForward<double, W>(m, kin_[0], art_[0], ws_->wide[0], last);
  }
}

}  // namespace minv
