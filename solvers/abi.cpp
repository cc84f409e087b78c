// abi's solver on doubles. Not compiled into libminv_solvers: each instruction-set level
// compiles it into its own module (solvers/abi_variant.cpp, solvers/abi_variants.hpp).
#include "solvers/abi.hpp"

#include "core/cpu.hpp"

namespace minv {

// A team of another size gets its copies anew, from the last configuration if there was one.
void AbiSolver::setThreads(int n) {
  threads_ = std::clamp(n, 1, kMaxThreads);
  if (model_ && team() != static_cast<int>(kin_.size())) allocate();
}

void AbiSolver::prepare(const Model& model) {
  model_ = &model;
  q_ = model.neutral();
  configured_ = 0;
  allocate();
}

// A configuration and a workspace per thread used: threads_, or one below kParallelColumns.
// One copy is brought to the last configuration here, several by their threads (makeCopy).
void AbiSolver::allocate() {
  const int team = this->team();
  kin_.clear(), art_.clear();
  kin_.reserve(team), art_.reserve(team);
  for (int t = 0; t < team; ++t)
    kin_.emplace_back(*model_, Origin::EachRoot), art_.emplace_back(*model_);
  ws_ = std::make_unique<AbiWorkspace<double>>(*model_, team);
  ws_->stream_rows = streamStridedRows();
  made_.assign(team, -1);
  if (team == 1 && configured_ > 0) makeCopy(0);
}

// q is kept. One copy: computed here. Several: each thread makes its own copy in the next
// inverse or solve (makeCopy), in the same parallel region as its columns.
void AbiSolver::configure(const Eigen::VectorXd& q) {
  q_ = q;
  ++configured_;
  if (kin_.size() == 1) makeCopy(0);
}

// Copy t at the last configuration, if it is not already (the same code for every copy, so
// the same bits).
void AbiSolver::makeCopy(int t) {
  if (made_[t] == configured_) return;
  computeKinematics<double>(*model_, q_, kin_[t]);
  articulatedInertias<double>(*model_, kin_[t], art_[t]);
  made_[t] = configured_;
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
  makeCopy(0);
  FlushSubnormals flush;
  for (int c0 = 0; c0 + W <= m.nv(); c0 += W) {
    const int last = m.dofBody(c0 + W - 1);
    abiBackward<double, W, true>(m, kin_[0], art_[0], ws_->wide[0], last, c0, W);
    abiForward<double, W>(m, kin_[0], art_[0], ws_->wide[0], last);
  }
}

}  // namespace minv
