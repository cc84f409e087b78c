// `abi` compiled for another instruction set than the rest of minv.
//
// `abi-generic` is solvers/abi.cpp compiled for generic x86-64 (-march=x86-64, SSE2: what
// Debian's prebuilt peers DART, Bullet and MuJoCo are compiled for), so that the timing tables
// can set abi against those peers like for like as well as natively. It lives in its own shared
// library (libminv_abi_generic.so, solvers/abi_variant.cpp) whose symbols are hidden and bound
// inside it (-fvisibility=hidden, -Bsymbolic): its Eigen and kernel instantiations can never be
// merged with the native ones at link time, which a second object file in the same library
// would allow. Only the factory below is exported. Eigen's alignment is pinned by minv::core
// (EIGEN_MAX_ALIGN_BYTES = 64), so the Model and the caller's matrices have one layout on
// both sides; the variant never resizes or frees a caller's matrix.
#pragma once

#include <memory>

#include "solvers/solver.hpp"

namespace minv {

// A new `abi` solver from the generic x86-64 build.
std::unique_ptr<Solver> makeAbiGeneric();

}  // namespace minv
