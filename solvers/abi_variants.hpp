// `abi` compiled for several instruction-set levels, one chosen at run time.
//
// solvers/abi.cpp is compiled once per level (core/cpu.hpp: baseline = x86-64, avx2 =
// x86-64-v3, avx512 = x86-64-v4, and native = -march=native in a MINV_NATIVE=ON build) into
// a module of its own, libminv_abi_<level>.so (solvers/abi_variant.cpp), whose symbols are
// hidden and bound inside it (-fvisibility=hidden, -Bsymbolic), so its Eigen and kernel
// instantiations never merge with another level's. A module is loaded (dlopen) only when its
// level is used (by a solver, or to name it in the registry's summary and the provenance), and
// only if this CPU runs that level: nothing compiled for AVX-512 is ever mapped on an AVX2
// machine. Eigen's alignment is pinned by minv::core (EIGEN_MAX_ALIGN_BYTES
// = 64), so the Model and the caller's matrices have one layout at every level; a module
// never resizes or frees a caller's matrix.
//
// The `abi` solver takes the level once, when it is made: MINV_ISA (environment) if set, else
// the highest level this CPU runs. `abi-generic` is the baseline level: what Debian's prebuilt
// peers (DART, Bullet, MuJoCo) are compiled for, for like-for-like tables.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "core/cpu.hpp"
#include "solvers/solver.hpp"

namespace minv {

template <class T>
struct Kinematics;
template <class T>
struct Articulated;

// What a level's module exports (symbol kAbiVariantSymbol). `version` must equal
// kAbiVariantVersion: a module from another build of minv (a stale file) is refused.
inline constexpr int kAbiVariantVersion = 4;  // 4: Articulated::couple
struct AbiVariantApi {
  int version;         // kAbiVariantVersion of the build that compiled it
  const char* level;   // isaName() of the level it was compiled for
  const char* target;  // its target flags ("-march=x86-64-v3 -mtune=generic")
  const char* widest;  // the widest extension the compiler used ("avx512f", "avx2+fma", …)
  int lanes;           // columns per SIMD block, kAbiLanes<double>
  Solver* (*make)();   // a new AbiSolver
  void (*sweeps)(Solver& abi);  // AbiSolver::sweepsOnly() of a solver it made
  // Kinematics and articulated-body inertias of q into the caller's kin and art, the pass
  // abi's configure runs (the simulator's dynamics stage uses it at the level in use: on a
  // Zen 4 core its S = 5 step is 0.3 us faster than a target_clones copy of the same code,
  // whose 3- and 6-vector columns keep the portable layout, core/spatial.hpp).
  void (*articulate)(const Model& model, const Eigen::VectorXd& q, Kinematics<double>& kin,
                     Articulated<double>& art);
};
inline constexpr const char* kAbiVariantSymbol = "minv_abi_variant";

// The levels this build compiled, lowest first.
std::vector<Isa> abiLevels();
// Whether `isa` can be used here (built, and run by this CPU); if not, *why says why.
bool abiLevelUsable(Isa isa, std::string* why = nullptr);
// The level `abi` uses: MINV_ISA if set (std::invalid_argument if it names no level, or one
// this build or CPU cannot use), else the highest usable level.
Isa abiLevel();
// A level's module, loaded once per process (std::runtime_error if it cannot be, or if the
// level is not usable here).
const AbiVariantApi& abiVariant(Isa isa);

// A new `abi` solver at level abiLevel(), or at `isa`.
std::unique_ptr<Solver> makeAbi();
std::unique_ptr<Solver> makeAbiAt(Isa isa);
// The registry's summary line of `abi`, naming the level in use.
std::string abiSummary();

}  // namespace minv
