#include "experiments/lib/provenance.hpp"

#include <cpuid.h>
#include <omp.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <fstream>
#include <thread>

#include "solvers/openblas.hpp"

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

// CPUID: vendor, family/model/stepping (with AMD's microarchitecture where the family and model
// tell it), and the vector extensions present; virtual machines often report only "AMD EPYC"
// as the model name, which cannot tell a Zen 3 from a Zen 4.
struct CpuId {
  std::string vendor = "unknown", signature = "unknown", extensions;
};

CpuId cpuId() {
  CpuId c;
  unsigned a = 0, b = 0, cx = 0, d = 0;
  if (!__get_cpuid(0, &a, &b, &cx, &d)) return c;
  char vendor[13] = {};
  std::memcpy(vendor, &b, 4);
  std::memcpy(vendor + 4, &d, 4);
  std::memcpy(vendor + 8, &cx, 4);
  c.vendor = vendor;
  const unsigned max_leaf = a;
  __get_cpuid(1, &a, &b, &cx, &d);
  const unsigned base_family = (a >> 8) & 0xf, base_model = (a >> 4) & 0xf, stepping = a & 0xf;
  const unsigned family = base_family == 0xf ? base_family + ((a >> 20) & 0xff) : base_family;
  const unsigned model =
      base_family == 0x6 || base_family == 0xf ? (((a >> 16) & 0xf) << 4) | base_model : base_model;
  char sig[96];
  std::snprintf(sig, sizeof sig, "family 0x%x model 0x%x stepping %u", family, model, stepping);
  c.signature = sig;
  if (c.vendor == "AuthenticAMD") {
    const char* uarch = family == 0x17 ? (model < 0x30 ? "Zen/Zen+" : "Zen 2")
                        : family == 0x19
                            ? ((model >= 0x10 && model < 0x20) || (model >= 0x60 && model < 0x80) ||
                                       (model >= 0xa0 && model < 0xb0)
                                   ? "Zen 4"
                                   : "Zen 3")
                        : family == 0x1a ? "Zen 5"
                                         : nullptr;
    if (uarch) c.signature += std::string(" (") + uarch + ")";
  }
  // The vector extensions that matter to minv's kernels and to Eigen.
  std::string ext;
  auto add = [&](bool has, const char* name) {
    if (has) ext += (ext.empty() ? "" : " ") + std::string(name);
  };
  add(cx & bit_SSE4_2, "sse4.2");
  add(cx & bit_AVX, "avx");
  add(cx & bit_FMA, "fma");
  if (max_leaf >= 7) {
    __get_cpuid_count(7, 0, &a, &b, &cx, &d);
    add(b & bit_AVX2, "avx2");
    add(b & bit_AVX512F, "avx512f");
    add(b & bit_AVX512DQ, "avx512dq");
    add(b & bit_AVX512BW, "avx512bw");
    add(b & bit_AVX512VL, "avx512vl");
  }
  c.extensions = ext;
  return c;
}

// The widest vector extension the build itself was compiled for (minv's own code).
const char* buildIsa() {
#if defined(__AVX512F__)
  return "avx512f";
#elif defined(__AVX2__) && defined(__FMA__)
  return "avx2+fma";
#elif defined(__AVX__)
  return "avx";
#elif defined(__SSE4_2__)
  return "sse4.2";
#else
  return "sse2 (x86-64 baseline)";
#endif
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
  const CpuId id = cpuId();
  p.cpu_vendor = id.vendor;
  p.cpu_signature = id.signature;
  p.cpu_extensions = id.extensions;
  p.build_isa = buildIsa();
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
         p.build_isa + ") on " + p.cpu_model + " (" + p.cpu_vendor + " " + p.cpu_signature + "; " +
         p.cpu_extensions + "), " + std::to_string(p.cpu_cores) + " cores; " + p.blas_library +
         ", " + std::to_string(p.blas_threads) + " BLAS / " + std::to_string(p.omp_max_threads) +
         " OpenMP threads; " + p.hostname + " " + p.date_utc;
}

}  // namespace minv
