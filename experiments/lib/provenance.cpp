#include "experiments/lib/provenance.hpp"

#include <omp.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <fstream>
#include <thread>

#include "core/cpu.hpp"
#include "solvers/abi_variants.hpp"
#include "solvers/openblas.hpp"

// The commit the sources were built from, written at build time by cmake/git_sha.cmake.
#if __has_include("minv_git_sha.h")
#include "minv_git_sha.h"
#endif
#ifndef MINV_GIT_SHA
#define MINV_GIT_SHA "unknown"
#endif
#ifndef MINV_COMPILER
#define MINV_COMPILER "unknown"
#endif
#ifndef MINV_BUILD_FLAGS
#define MINV_BUILD_FLAGS "unknown"
#endif
#ifndef MINV_VERSION
#define MINV_VERSION "0.1"
#endif

namespace minv {

namespace {

// The first "model name" line of /proc/cpuinfo.
std::string cpuModel() {
  std::ifstream in("/proc/cpuinfo");
  for (std::string line; std::getline(in, line);) {
    if (line.rfind("model name", 0) != 0) continue;
    const std::size_t colon = line.find(':');
    if (colon == std::string::npos) continue;
    const std::size_t start = line.find_first_not_of(" \t", colon + 1);
    return start == std::string::npos ? "unknown" : line.substr(start);
  }
  return "unknown";
}

// Now, as ISO-8601 UTC.
std::string utcNow() {
  const std::time_t t = std::chrono::system_clock::to_time_t(std::chrono::system_clock::now());
  std::tm tm{};
  gmtime_r(&t, &tm);
  char buf[32];
  std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%SZ", &tm);
  return buf;
}

std::string hostName() {
  char buf[256] = {};
  if (gethostname(buf, sizeof buf - 1) != 0) return "unknown";
  return buf;
}

}  // namespace

// Compile-time facts first, then the machine and the libraries' run-time settings.
Provenance collectProvenance() {
  Provenance p;
  p.git_sha = MINV_GIT_SHA;
  p.compiler = MINV_COMPILER;
  p.build_flags = MINV_BUILD_FLAGS;
  p.minv_version = MINV_VERSION;
  p.cpu_model = cpuModel();
  const CpuIdentity id = cpuIdentity();
  p.cpu_vendor = id.vendor;
  p.cpu_signature = id.signature;
  p.cpu_extensions = id.extensions;
  p.build_isa = MINV_COMPILED_ISA;  // minv's own code (this library's flags)
  // abi's level in use, and every level with whether it can be used here.
  try {
    const AbiVariantApi& v = abiVariant(abiLevel());
    p.abi_isa = std::string(v.level) + " (" + v.target + "; widest " + v.widest + ", " +
                std::to_string(v.lanes) + " lanes; mirrored rows " +
                (streamStridedRows() ? "streamed" : "plain") + ")";
  } catch (const std::exception& e) {
    p.abi_isa = std::string("none: ") + e.what();
  }
  for (Isa l : kIsas) {
    std::string why;
    p.abi_isa_levels += (p.abi_isa_levels.empty() ? "" : "; ") + std::string(isaName(l)) + ": " +
                        (abiLevelUsable(l, &why) ? "usable" : why);
  }
  p.cpu_cores = static_cast<int>(std::thread::hardware_concurrency());
  // openblas_get_config() reads "OpenBLAS 0.3.21 DYNAMIC_ARCH …"; prefix the name if not.
  const std::string config = openblas_get_config() ? openblas_get_config() : "(no config)";
  p.blas_library = config.rfind("OpenBLAS", 0) == 0 ? config : "OpenBLAS " + config;
  p.blas_threads = openblas_get_num_threads();
  p.omp_max_threads = omp_get_max_threads();
  p.date_utc = utcNow();
  p.hostname = hostName();
  return p;
}

void writeProvenance(H5Writer& writer, const std::string& group) {
  const Provenance p = collectProvenance();
  writer.createGroup(group);
  writer.setAttribute(group, "git_sha", p.git_sha);
  writer.setAttribute(group, "compiler", p.compiler);
  writer.setAttribute(group, "build_flags", p.build_flags);
  writer.setAttribute(group, "minv_version", p.minv_version);
  writer.setAttribute(group, "cpu_model", p.cpu_model);
  writer.setAttribute(group, "cpu_vendor", p.cpu_vendor);
  writer.setAttribute(group, "cpu_signature", p.cpu_signature);
  writer.setAttribute(group, "cpu_extensions", p.cpu_extensions);
  writer.setAttribute(group, "build_isa", p.build_isa);
  writer.setAttribute(group, "abi_isa", p.abi_isa);
  writer.setAttribute(group, "abi_isa_levels", p.abi_isa_levels);
  writer.setAttribute(group, "cpu_cores", p.cpu_cores);
  writer.setAttribute(group, "blas_library", p.blas_library);
  writer.setAttribute(group, "blas_threads", p.blas_threads);
  writer.setAttribute(group, "omp_max_threads", p.omp_max_threads);
  writer.setAttribute(group, "date_utc", p.date_utc);
  writer.setAttribute(group, "hostname", p.hostname);
}

std::string provenanceSummary() {
  const Provenance p = collectProvenance();
  return "minv " + p.minv_version + " (" + p.git_sha + ", " + p.compiler + ", built for " +
         p.build_isa + ", abi " + p.abi_isa + ") on " + p.cpu_model + " (" + p.cpu_vendor + " " +
         p.cpu_signature + "; " + p.cpu_extensions + "), " + std::to_string(p.cpu_cores) +
         " cores; " + p.blas_library + ", " + std::to_string(p.blas_threads) + " BLAS / " +
         std::to_string(p.omp_max_threads) + " OpenMP threads; " + p.hostname + " " + p.date_utc;
}

}  // namespace minv
