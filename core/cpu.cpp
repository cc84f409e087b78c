#include "core/cpu.hpp"

#include <cpuid.h>

#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <stdexcept>
#include <string>
#include <vector>

namespace minv {

namespace {

struct Regs {
  unsigned a = 0, b = 0, c = 0, d = 0;
};

// CPUID leaf (and subleaf); zeros where the leaf does not exist.
Regs cpuid(unsigned leaf, unsigned sub = 0) {
  Regs r;
  const unsigned top = __get_cpuid_max(leaf & 0x80000000u, nullptr);
  if (top >= leaf) __cpuid_count(leaf, sub, r.a, r.b, r.c, r.d);
  return r;
}

// The register state the OS saves on a context switch (XCR0); 0 without OSXSAVE.
unsigned long long xcr0() {
  if (!(cpuid(1).c & bit_OSXSAVE)) return 0;
  unsigned lo = 0, hi = 0;
  __asm__ volatile("xgetbv" : "=a"(lo), "=d"(hi) : "c"(0));
  return (static_cast<unsigned long long>(hi) << 32) | lo;
}

struct Feature {
  const char* name;
  bool present;
};

// Each extension a level needs (a level needs those of the levels below it, too).
struct Need {
  Isa level;
  const char* name;
  bool present;
};
std::vector<Need> needs() {
  const Regs l1 = cpuid(1), l7 = cpuid(7), e1 = cpuid(0x80000001u);
  const unsigned long long x = xcr0();
  return {{Isa::Avx2, "avx", (l1.c & bit_AVX) != 0},
          {Isa::Avx2, "avx2", (l7.b & bit_AVX2) != 0},
          {Isa::Avx2, "fma", (l1.c & bit_FMA) != 0},
          {Isa::Avx2, "bmi1", (l7.b & bit_BMI) != 0},
          {Isa::Avx2, "bmi2", (l7.b & bit_BMI2) != 0},
          {Isa::Avx2, "f16c", (l1.c & bit_F16C) != 0},
          {Isa::Avx2, "lzcnt", (e1.c & bit_LZCNT) != 0},
          {Isa::Avx2, "movbe", (l1.c & bit_MOVBE) != 0},
          {Isa::Avx2, "OS-saved AVX state (XCR0)", (x & 0x6) == 0x6},
          {Isa::Avx512, "avx512f", (l7.b & bit_AVX512F) != 0},
          {Isa::Avx512, "avx512bw", (l7.b & bit_AVX512BW) != 0},
          {Isa::Avx512, "avx512cd", (l7.b & bit_AVX512CD) != 0},
          {Isa::Avx512, "avx512dq", (l7.b & bit_AVX512DQ) != 0},
          {Isa::Avx512, "avx512vl", (l7.b & bit_AVX512VL) != 0},
          {Isa::Avx512, "OS-saved AVX-512 state (XCR0)", (x & 0xe6) == 0xe6}};
}

}  // namespace

const char* isaName(Isa isa) {
  static constexpr const char* kNames[] = {"baseline", "avx2", "avx512", "native"};
  return kNames[static_cast<int>(isa)];
}

std::optional<Isa> isaFromName(const std::string& name) {
  for (Isa isa : kIsas)
    if (name == isaName(isa)) return isa;
  return std::nullopt;
}

bool cpuRuns(Isa isa, std::string* why) {
  // Native is judged by the caller, by the level its build implies.
  if (isa == Isa::Native) return true;
  // Each level includes the ones below it.
  std::string missing;
  for (const Need& f : needs())
    if (f.level <= isa && !f.present)
      missing += (missing.empty() ? "" : ", ") + std::string(f.name);
  if (why && !missing.empty())
    *why = std::string("this CPU cannot run level ") + isaName(isa) + ": no " + missing;
  return missing.empty();
}

CpuIdentity cpuIdentity() {
  CpuIdentity c;
  const Regs l0 = cpuid(0);
  if (l0.a == 0 && l0.b == 0) return c;
  char vendor[13] = {};
  std::memcpy(vendor, &l0.b, 4);
  std::memcpy(vendor + 4, &l0.d, 4);
  std::memcpy(vendor + 8, &l0.c, 4);
  c.vendor = vendor;
  // Family, model and stepping, with the extended fields where they apply.
  const Regs l1 = cpuid(1);
  const unsigned base_family = (l1.a >> 8) & 0xf, base_model = (l1.a >> 4) & 0xf;
  const unsigned stepping = l1.a & 0xf;
  const unsigned family = base_family == 0xf ? base_family + ((l1.a >> 20) & 0xff) : base_family;
  const unsigned model = base_family == 0x6 || base_family == 0xf
                             ? (((l1.a >> 16) & 0xf) << 4) | base_model
                             : base_model;
  char sig[96];
  std::snprintf(sig, sizeof sig, "family 0x%x model 0x%x stepping %u", family, model, stepping);
  c.signature = sig;
  c.family = family, c.model = model;
  // AMD's microarchitecture, where the family and model tell it.
  if (c.vendor == "AuthenticAMD") {
    const bool zen4 = (model >= 0x10 && model < 0x20) || (model >= 0x60 && model < 0x80) ||
                      (model >= 0xa0 && model < 0xb0);
    const char* uarch = family == 0x17   ? (model < 0x30 ? "Zen/Zen+" : "Zen 2")
                        : family == 0x19 ? (zen4 ? "Zen 4" : "Zen 3")
                        : family == 0x1a ? "Zen 5"
                                         : nullptr;
    if (uarch) c.signature += std::string(" (") + uarch + ")";
  }
  // Intel's server cores, where the model tells it.
  if (c.vendor == "GenuineIntel" && family == 0x6) {
    const char* uarch = model == 0x55                    ? "Skylake-SP/Cascade Lake"
                        : model == 0x6a || model == 0x6c ? "Ice Lake-SP"
                        : model == 0x8f                  ? "Sapphire Rapids"
                        : model == 0xcf                  ? "Emerald Rapids"
                        : model == 0xad || model == 0xae ? "Granite Rapids"
                                                         : nullptr;
    if (uarch) c.signature += std::string(" (") + uarch + ")";
  }
  // The vector extensions that matter to minv's kernels and to Eigen.
  const Regs l7 = cpuid(7);
  const Feature ext[] = {
      {"sse4.2", (l1.c & bit_SSE4_2) != 0},     {"avx", (l1.c & bit_AVX) != 0},
      {"fma", (l1.c & bit_FMA) != 0},           {"avx2", (l7.b & bit_AVX2) != 0},
      {"avx512f", (l7.b & bit_AVX512F) != 0},   {"avx512dq", (l7.b & bit_AVX512DQ) != 0},
      {"avx512bw", (l7.b & bit_AVX512BW) != 0}, {"avx512vl", (l7.b & bit_AVX512VL) != 0}};
  for (const Feature& f : ext)
    if (f.present) c.extensions += (c.extensions.empty() ? "" : " ") + std::string(f.name);
  return c;
}

bool streamStridedRows() {
  const char* forced = std::getenv("MINV_ABI_ROWS");
  if (forced && *forced) {
    if (std::strcmp(forced, "stream") == 0) return true;
    if (std::strcmp(forced, "plain") == 0) return false;
    throw std::invalid_argument(std::string("MINV_ABI_ROWS must be stream or plain, not '") +
                                forced + "'");
  }
  return streamsStridedRowsBest(cpuIdentity());
}

bool streamsStridedRowsBest(const CpuIdentity& /*cpu*/) {
  return true;
}

}  // namespace minv
