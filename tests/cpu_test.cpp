// The CPU's instruction-set levels (core/cpu.hpp) against the compiler's own CPU detection
// (libgcc's __builtin_cpu_supports, which also checks the register state the OS saves), and
// the choice of abi's level (solvers/abi_variants.hpp): MINV_ISA forces a level, a bad or
// unusable MINV_ISA is a clear error, and without it abi takes the highest usable level.
#include "core/cpu.hpp"

#include <gtest/gtest.h>

#include <cstdio>
#include <cstdlib>
#include <optional>
#include <string>

#include "solvers/abi_variants.hpp"
#include "solvers/solver.hpp"

namespace minv {
namespace {

TEST(Cpu, LevelsAgreeWithTheCompilersDetection) {
  __builtin_cpu_init();
  const bool v3 = __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma") &&
                  __builtin_cpu_supports("bmi") && __builtin_cpu_supports("bmi2") &&
                  __builtin_cpu_supports("avx");
  const bool v4 = v3 && __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512bw") &&
                  __builtin_cpu_supports("avx512cd") && __builtin_cpu_supports("avx512dq") &&
                  __builtin_cpu_supports("avx512vl");
  EXPECT_TRUE(cpuRuns(Isa::Baseline));
  // The compiler's list has no lzcnt/movbe/f16c: a CPU with AVX2 and BMI2 has them all.
  EXPECT_EQ(cpuRuns(Isa::Avx2), v3);
  EXPECT_EQ(cpuRuns(Isa::Avx512), v4);
  std::string why;
  if (!v4) {
    EXPECT_FALSE(cpuRuns(Isa::Avx512, &why));
    EXPECT_NE(why.find("cannot run level avx512: no "), std::string::npos) << why;
  }
  const CpuIdentity id = cpuIdentity();
  EXPECT_NE(id.vendor, "unknown");
  EXPECT_NE(id.signature.find("family 0x"), std::string::npos) << id.signature;
  EXPECT_EQ(id.extensions.find("avx2") != std::string::npos, __builtin_cpu_supports("avx2") != 0)
      << id.extensions;
}

// The numeric family and model are the ones the signature names.
TEST(Cpu, FamilyAndModelMatchTheSignature) {
  const CpuIdentity id = cpuIdentity();
  char sig[64];
  std::snprintf(sig, sizeof sig, "family 0x%x model 0x%x ", id.family, id.model);
  EXPECT_EQ(id.signature.rfind(sig, 0), 0u) << id.signature;
}

// Mirrored rows are streamed on every CPU where that was measured (Intel Xeon, AMD Zen 4 and
// Zen 5).
TEST(Cpu, StreamedRowsWhereTheyMeasuredFaster) {
  auto cpu = [](const char* vendor, unsigned family, unsigned model) {
    CpuIdentity c;
    c.vendor = vendor, c.family = family, c.model = model;
    return c;
  };
  EXPECT_TRUE(streamsStridedRowsBest(cpu("GenuineIntel", 0x6, 0xcf)));   // Emerald Rapids
  EXPECT_TRUE(streamsStridedRowsBest(cpu("AuthenticAMD", 0x19, 0x11)));  // Zen 4
  EXPECT_TRUE(streamsStridedRowsBest(cpu("AuthenticAMD", 0x1a, 0x2)));   // Zen 5
}

TEST(Cpu, LevelNamesRoundTrip) {
  for (Isa isa : kIsas) EXPECT_EQ(isaFromName(isaName(isa)), isa);
  EXPECT_FALSE(isaFromName("avx9").has_value());
  EXPECT_FALSE(isaFromName("").has_value());
}

// Sets MINV_ISA for one scope.
struct ForcedIsa {
  std::optional<std::string> saved;
  explicit ForcedIsa(const char* value) {
    if (const char* s = std::getenv("MINV_ISA")) saved = s;
    if (value)
      setenv("MINV_ISA", value, 1);
    else
      unsetenv("MINV_ISA");
  }
  ~ForcedIsa() {
    if (saved)
      setenv("MINV_ISA", saved->c_str(), 1);
    else
      unsetenv("MINV_ISA");
  }
};

TEST(AbiLevels, ChosenFromCpuidOrForced) {
  {
    // Without MINV_ISA: the highest level this build has and this CPU runs.
    const ForcedIsa none(nullptr);
    Isa best = Isa::Baseline;
    for (Isa l : abiLevels())
      if (abiLevelUsable(l)) best = l;
    EXPECT_EQ(abiLevel(), best);
    EXPECT_GE(abiLevel(), cpuRuns(Isa::Avx2) ? Isa::Avx2 : Isa::Baseline);
  }
  {
    const ForcedIsa baseline("baseline");
    EXPECT_EQ(abiLevel(), Isa::Baseline);
    EXPECT_EQ(std::string(abiVariant(Isa::Baseline).widest), "sse2");
    EXPECT_NE(findSolver("abi")->make(), nullptr);
  }
  {
    const ForcedIsa bad("avx9");
    try {
      makeSolver("abi");
      ADD_FAILURE() << "MINV_ISA=avx9 accepted";
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find("MINV_ISA='avx9' names no instruction-set level"),
                std::string::npos)
          << e.what();
    }
  }
  // Every level this build has: its module says what it was compiled for; a level this CPU
  // cannot run is refused with the reason before its module is loaded.
  for (Isa l : abiLevels()) {
    std::string why;
    if (abiLevelUsable(l, &why)) {
      EXPECT_EQ(std::string(abiVariant(l).level), isaName(l));
      EXPECT_GE(abiVariant(l).lanes, 1);
    } else {
      const ForcedIsa forced(isaName(l));
      EXPECT_THROW(abiLevel(), std::invalid_argument) << why;
    }
  }
  if (abiLevelUsable(Isa::Avx2)) {
    EXPECT_EQ(std::string(abiVariant(Isa::Avx2).widest), "avx2+fma");
  }
}

}  // namespace
}  // namespace minv
