#include "experiments/lib/cores.hpp"

#include <omp.h>

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <cstdio>

#if defined(__linux__)
#include <sched.h>
#endif

namespace minv {

namespace {

#if defined(__linux__)
std::vector<int> currentMask() {
  cpu_set_t set;
  CPU_ZERO(&set);
  std::vector<int> cpus;
  if (sched_getaffinity(0, sizeof set, &set) != 0) return cpus;
  for (int c = 0; c < CPU_SETSIZE; ++c)
    if (CPU_ISSET(c, &set)) cpus.push_back(c);
  return cpus;
}

bool setMask(const std::vector<int>& cpus) {
  cpu_set_t set;
  CPU_ZERO(&set);
  for (int c : cpus) CPU_SET(c, &set);
  return sched_setaffinity(0, sizeof set, &set) == 0;
}
#endif

// Dependent additions per ns: x += 1 through an empty asm that hides x from the optimiser, so
// each addition waits for the one before (a chain of 1-cycle additions).
double chainRate() {
  constexpr std::uint64_t kAdds = 4'000'000;
  double best = 0;
  for (int run = 0; run < 5; ++run) {
    std::uint64_t x = 0;
    const auto t0 = std::chrono::steady_clock::now();
    for (std::uint64_t k = 0; k < kAdds; ++k) {
      x += 1;
      asm volatile("" : "+r"(x));
    }
    const double ns =
        std::chrono::duration<double, std::nano>(std::chrono::steady_clock::now() - t0).count();
    if (x == kAdds && ns > 0) best = std::max(best, static_cast<double>(kAdds) / ns);
  }
  return best;
}

}  // namespace

std::vector<CoreSpeed> measureCoreSpeeds() {
  std::vector<CoreSpeed> out;
#if defined(__linux__)
  const std::vector<int> mask = currentMask();
  for (int c : mask)
    if (setMask({c})) out.push_back({c, chainRate()});
  setMask(mask);
#endif
  return out;
}

CorePinning::CorePinning() {
#if defined(__linux__)
  mask_ = currentMask();
#endif
  // OpenMP's threads start now, on every core: a thread keeps the mask it was made with, so a
  // team first made while this thread is pinned would stay on the one core.
#pragma omp parallel num_threads(omp_get_max_threads())
  {}
  speeds_ = measureCoreSpeeds();
  double best = 0;
  for (const CoreSpeed& s : speeds_)
    if (s.adds_per_ns > best) best = s.adds_per_ns, fastest_ = s.cpu;
}

void CorePinning::pinFastest() const {
#if defined(__linux__)
  if (fastest_ >= 0) setMask({fastest_});
#endif
}

void CorePinning::release() const {
#if defined(__linux__)
  if (!mask_.empty()) setMask(mask_);
#endif
}

std::string CorePinning::summary() const {
  if (speeds_.empty() || fastest_ < 0) return "cores not measured (no affinity control here)";
  std::string s;
  char buf[64];
  for (const CoreSpeed& c : speeds_) {
    std::snprintf(buf, sizeof buf, "%scpu %d: %.2f adds/ns", s.empty() ? "" : ", ", c.cpu,
                  c.adds_per_ns);
    s += buf;
  }
  return s + "; single-threaded runs pinned to cpu " + std::to_string(fastest_);
}

}  // namespace minv
