// Build and machine provenance for every result file.
//
// Contract: writeProvenance() stores these scalar string/integer attributes on `group`:
//   git_sha          commit the build was configured from (compile definition MINV_GIT_SHA)
//   compiler         compiler id and version (MINV_COMPILER)
//   build_flags      optimisation and target flags (MINV_BUILD_FLAGS)
//   minv_version     the project version (MINV_VERSION, else the version below)
//   cpu_model        /proc/cpuinfo "model name" ("unknown" if absent)
//   cpu_vendor       CPUID's vendor string ("AuthenticAMD", "GenuineIntel")
//   cpu_signature    CPUID's family, model and stepping, with AMD's microarchitecture where
//                    they tell it ("family 0x19 model 0x11 stepping 1 (Zen 4)")
//   cpu_extensions   the vector extensions present ("sse4.2 avx fma avx2 avx512f …")
//   build_isa        the widest extension minv's own code was compiled for ("avx512f",
//                    "avx2+fma", "avx", "sse4.2" (the default x86-64-v2 build), "sse2")
//   abi_isa          the level of abi's kernels in use (solvers/abi_variants.hpp): level,
//                    target flags, widest extension, lanes ("avx512 (-march=x86-64-v4 …)")
//   abi_isa_levels   every level and whether it can be used here, or why not
//   cpu_cores        std::thread::hardware_concurrency()
//   blas_library     openblas_get_config() ("OpenBLAS 0.3.21 DYNAMIC_ARCH …")
//   blas_threads     openblas_get_num_threads()
//   omp_max_threads  omp_get_max_threads()
//   date_utc         the time of the call, ISO-8601 UTC ("2024-05-01T12:34:56Z")
//   hostname         gethostname()
// provenanceSummary() is the same as one line for the terminal.
#pragma once

#include <string>

#include "experiments/lib/h5writer.hpp"

namespace minv {

struct Provenance {
  std::string git_sha, compiler, build_flags, minv_version, cpu_model, cpu_vendor, cpu_signature,
      cpu_extensions, build_isa, abi_isa, abi_isa_levels, blas_library, date_utc, hostname;
  int cpu_cores = 0, blas_threads = 0, omp_max_threads = 0;
};

// Collect everything now.
Provenance collectProvenance();
// Store collectProvenance() as attributes of `group` ("/" = the file root).
void writeProvenance(H5Writer& writer, const std::string& group = "/");
// One line: version, git sha, compiler, cpu, cores, BLAS and threads, host, date.
std::string provenanceSummary();

}  // namespace minv
