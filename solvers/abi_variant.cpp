// One instruction-set variant of `abi` (see solvers/abi_variants.hpp): the same source as the
// native solver, solvers/abi.cpp, compiled again with the variant's flags into its own shared
// library, with one exported factory.
#include "solvers/abi.cpp"

extern "C" __attribute__((visibility("default"))) minv::Solver* minv_abi_make_generic() {
  return new minv::AbiSolver();
}
