// abi's operation counts: its kernels run on the counting scalar (the same code the modules
// of solvers/abi_variant.cpp run on doubles).
#include "solvers/abi.hpp"

namespace minv {

std::vector<StageCount> AbiSolver::countStages(const Model& model, const Eigen::VectorXd& q,
                                               int m) {
  flopReset();
  StageCounter mark;
  abiPipeline<Counted>(model, q, m, mark);
  return stageCounts(mark);
}

}  // namespace minv
