// The CPU minv runs on: CPUID's identity, and the instruction-set levels this CPU and its
// operating system can run. The levels are those abi's kernels are compiled for
// (solvers/abi_variants.hpp), chosen at run time; the identity goes into every result file's
// provenance, since virtual machines often report only "AMD EPYC" as the model name.
#pragma once

#include <optional>
#include <string>

namespace minv {

struct CpuIdentity {
  std::string vendor = "unknown";     // "AuthenticAMD", "GenuineIntel"
  std::string signature = "unknown";  // "family 0x19 model 0x11 stepping 1 (Zen 4)"
  std::string extensions;             // the vector extensions present: "sse4.2 avx fma avx2 …"
  unsigned family = 0, model = 0;     // CPUID's, with the extended fields where they apply
};
CpuIdentity cpuIdentity();

// Instruction-set levels, lowest first:
//   baseline  x86-64 (SSE2): every x86-64 CPU, what Debian's prebuilt peers are built for
//   avx2      x86-64-v3: AVX, AVX2, FMA, BMI1/2, F16C, LZCNT, MOVBE
//   avx512    x86-64-v4: x86-64-v3 plus AVX-512 F, BW, CD, DQ, VL
//   native    -march=native of the machine that built minv (a build with MINV_NATIVE=ON)
enum class Isa { Baseline, Avx2, Avx512, Native };
inline constexpr Isa kIsas[] = {Isa::Baseline, Isa::Avx2, Isa::Avx512, Isa::Native};
const char* isaName(Isa isa);
std::optional<Isa> isaFromName(const std::string& name);

// Whether this CPU, with the register state its OS saves (XGETBV), runs level `isa`; if not,
// *why names what is missing. Always true for `native`, which the caller judges by the level
// its build implies.
bool cpuRuns(Isa isa, std::string* why = nullptr);

// Whether pieces of a few cache lines written one column apart into a large column-major
// matrix (the rows of M⁻¹ that abi mirrors: 16 doubles per column) go out as non-temporal
// full-line stores rather than plain ones: streamed was as fast or faster on every CPU measured
// (Intel Xeon, AMD Zen 4 and Zen 5; paper/ENGINEERING.md, "Non-temporal stores").
// MINV_ABI_ROWS=stream|plain forces either (std::invalid_argument for another value); read at
// each call (abi reads it in prepare()).
bool streamStridedRows();
// The measured rule alone, for a given CPU (what streamStridedRows() applies without
// MINV_ABI_ROWS): streamed on every CPU measured so far.
bool streamsStridedRowsBest(const CpuIdentity& cpu);

// The widest vector extension the including translation unit is compiled for (a macro, so that
// each library and each level's module reports its own flags).
#if defined(__AVX512F__)
#define MINV_COMPILED_ISA "avx512f"
#elif defined(__AVX2__) && defined(__FMA__)
#define MINV_COMPILED_ISA "avx2+fma"
#elif defined(__AVX__)
#define MINV_COMPILED_ISA "avx"
#elif defined(__SSE4_2__)
#define MINV_COMPILED_ISA "sse4.2"
#else
#define MINV_COMPILED_ISA "sse2"
#endif

}  // namespace minv
