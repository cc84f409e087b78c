// One instruction-set level of `abi` (see solvers/abi_variants.hpp): the solver's source,
// solvers/abi.cpp, compiled with the level's flags (MINV_ABI_LEVEL, MINV_ABI_TARGET) into a
// module of its own, which exports only the table below.
#include "solvers/abi.cpp"
#include "solvers/abi_variants.hpp"

namespace {

minv::Solver* make() {
  return new minv::AbiSolver();
}

void sweeps(minv::Solver& abi) {
  static_cast<minv::AbiSolver&>(abi).sweepsOnly();
}

void articulate(const minv::Model& model, const Eigen::VectorXd& q, minv::Kinematics<double>& kin,
                minv::Articulated<double>& art) {
  minv::computeKinematics<double>(model, q, kin);
  minv::articulatedInertias<double>(model, kin, art);
}

}  // namespace

extern "C" __attribute__((visibility("default"))) const minv::AbiVariantApi minv_abi_variant = {
    minv::kAbiVariantVersion, MINV_ABI_LEVEL, MINV_ABI_TARGET, MINV_COMPILED_ISA,
    minv::kAbiLanes<double>,  make,           sweeps,          articulate};
