#include "solvers/abi_variants.hpp"

#include <dlfcn.h>

#include <algorithm>
#include <cstdlib>
#include <map>
#include <mutex>
#include <stdexcept>

#include "solvers/module.hpp"

namespace minv {

namespace {

// The levels CMake compiled (MINV_ABI_LEVELS: "baseline,avx2,avx512[,native]").
std::vector<Isa> builtLevels() {
  std::vector<Isa> out;
  std::string list = MINV_ABI_LEVELS;
  for (std::size_t at = 0; at <= list.size();) {
    const std::size_t end = std::min(list.find(',', at), list.size());
    if (auto isa = isaFromName(list.substr(at, end - at))) out.push_back(*isa);
    at = end + 1;
  }
  return out;
}

// The file name and build path of a level's module.
std::string moduleName(Isa isa) {
  return std::string("libminv_abi_") + isaName(isa) + ".so";
}

// The built levels as "baseline|avx2|avx512".
std::string levelList() {
  std::string out;
  for (Isa l : abiLevels()) out += (out.empty() ? "" : "|") + std::string(isaName(l));
  return out;
}

}  // namespace

std::vector<Isa> abiLevels() {
  static const std::vector<Isa> levels = builtLevels();
  return levels;
}

bool abiLevelUsable(Isa isa, std::string* why) {
  const std::vector<Isa> built = abiLevels();
  if (std::find(built.begin(), built.end(), isa) == built.end()) {
    if (why)
      *why = std::string("level ") + isaName(isa) + " is not in this build" +
             (isa == Isa::Native ? " (configure with -DMINV_NATIVE=ON)" : "");
    return false;
  }
  // The native module runs where the level its flags imply runs: libminv_solvers is compiled
  // with the same -march=native, so its own macros tell that level.
  if (isa == Isa::Native) {
#if defined(__AVX512F__) && defined(__AVX512BW__) && defined(__AVX512DQ__) && defined(__AVX512VL__)
    return cpuRuns(Isa::Avx512, why);
#elif defined(__AVX2__) && defined(__FMA__)
    return cpuRuns(Isa::Avx2, why);
#else
    return cpuRuns(Isa::Baseline, why);
#endif
  }
  return cpuRuns(isa, why);
}

Isa abiLevel() {
  if (const char* forced = std::getenv("MINV_ISA"); forced && *forced) {
    const std::optional<Isa> isa = isaFromName(forced);
    if (!isa)
      throw std::invalid_argument("MINV_ISA='" + std::string(forced) +
                                  "' names no instruction-set level (this build: " + levelList() +
                                  ")");
    std::string why;
    if (!abiLevelUsable(*isa, &why))
      throw std::invalid_argument("MINV_ISA=" + std::string(forced) + ": " + why);
    return *isa;
  }
  // The highest usable level (native, in a build that asked for it).
  Isa best = Isa::Baseline;
  for (Isa l : abiLevels())
    if (abiLevelUsable(l)) best = l;
  return best;
}

const AbiVariantApi& abiVariant(Isa isa) {
  // Nothing compiled for a level this CPU cannot run is ever mapped.
  std::string why;
  if (!abiLevelUsable(isa, &why)) throw std::runtime_error("abi: " + why);
  static std::mutex lock;
  static std::map<Isa, const AbiVariantApi*> loaded;
  const std::lock_guard<std::mutex> guard(lock);
  if (const auto it = loaded.find(isa); it != loaded.end()) return *it->second;
  std::string error;
  void* handle =
      openModule(moduleName(isa), std::string(MINV_ABI_BUILD_DIR) + "/" + moduleName(isa),
                 RTLD_NOW | RTLD_LOCAL, &error);
  if (!handle)
    throw std::runtime_error(std::string("abi: cannot load the ") + isaName(isa) +
                             " module: " + error);
  const auto* api = static_cast<const AbiVariantApi*>(dlsym(handle, kAbiVariantSymbol));
  if (!api || api->version != kAbiVariantVersion || std::string(api->level) != isaName(isa))
    throw std::runtime_error("abi: " + moduleName(isa) + " is not this build's module of level " +
                             isaName(isa) + " (a stale file from another build?)");
  loaded[isa] = api;
  return *api;
}

std::unique_ptr<Solver> makeAbiAt(Isa isa) {
  std::string why;
  if (!abiLevelUsable(isa, &why)) throw std::invalid_argument("abi: " + why);
  return std::unique_ptr<Solver>(abiVariant(isa).make());
}

std::unique_ptr<Solver> makeAbi() {
  return makeAbiAt(abiLevel());
}

std::string abiSummary() {
  std::string s = "Θ(n²) M⁻¹ from articulated-body inertias (Drumwright Alg. 1-2); ";
  try {
    const Isa isa = abiLevel();
    s += std::string("kernels for ") + isaName(isa) + " (" + abiVariant(isa).target + ")";
  } catch (const std::exception& e) {
    s += e.what();
  }
  const char* forced = std::getenv("MINV_ISA");
  s += forced && *forced ? ", forced by MINV_ISA; MINV_ISA=" : ", chosen from CPUID; MINV_ISA=";
  s += levelList() + " forces one; mirrored rows ";
  try {
    s += streamStridedRows() ? "streamed" : "plain";
  } catch (const std::exception& e) {
    s += e.what();
  }
  return s + " (MINV_ABI_ROWS=stream|plain)";
}

}  // namespace minv
