// abi's solver on doubles. Not compiled into libminv_solvers: each instruction-set level
// compiles it into its own module (solvers/abi_variant.cpp, solvers/abi_variants.hpp).
#include "solvers/abi.hpp"

#include "core/cpu.hpp"

namespace minv {

void AbiSolver::setThreads(int n) {
  threads_ = std::max(1, n);
  if (model_) {
    ws_ = std::make_unique<AbiWorkspace<double>>(*model_, threads_);
    ws_->stream_rows = streamStridedRows();
  }
}

void AbiSolver::prepare(const Model& model) {
  model_ = &model;
  kin_ = std::make_unique<Kinematics<double>>(model, Origin::EachRoot);
  art_ = std::make_unique<Articulated<double>>(model);
  ws_ = std::make_unique<AbiWorkspace<double>>(model, threads_);
  ws_->stream_rows = streamStridedRows();
}

void AbiSolver::configure(const Eigen::VectorXd& q) {
  computeKinematics<double>(*model_, q, *kin_, threads_);
  articulatedInertias<double>(*model_, *kin_, *art_);
}

void AbiSolver::inverse(MatrixOut Minv) {
  abiInverse<double>(*model_, *kin_, *art_, *ws_, Minv);
}

void AbiSolver::inverseUpper(MatrixOut Minv) {
  abiInverse<double>(*model_, *kin_, *art_, *ws_, Minv, NoMark{}, true);
}

void AbiSolver::solve(MatrixIn R, MatrixOut X) {
  abiSolve<double>(*model_, *kin_, *art_, *ws_, R, X);
}

void AbiSolver::sweepsOnly() {
  constexpr int W = kAbiLanes<double>;
  const Model& m = *model_;
  FlushSubnormals flush;
  for (int c0 = 0; c0 + W <= m.nv(); c0 += W) {
    const int last = m.dofBody(c0 + W - 1);
    abiBackward<double, W, true>(m, *kin_, *art_, ws_->wide[0], last, c0, W);
    abiForward<double, W>(m, *kin_, *art_, ws_->wide[0], last);
  }
}

}  // namespace minv
