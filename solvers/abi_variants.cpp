#include "solvers/abi_variants.hpp"

// Exported by libminv_abi_generic.so (solvers/abi_variant.cpp).
extern "C" minv::Solver* minv_abi_make_generic();

namespace minv {

std::unique_ptr<Solver> makeAbiGeneric() {
  return std::unique_ptr<Solver>(minv_abi_make_generic());
}

}  // namespace minv
