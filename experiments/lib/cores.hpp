// The speed of each core this process may run on, and pinning to the fastest.
//
// A virtual machine's vCPUs need not be equal: on the project's 2-vCPU Zen 5 guest, at times,
// one core ran single-threaded kernels 15 % slower than the other and a chain of dependent
// additions 42 % slower (2.09 against 3.60 per ns; no steal time reported), so a benchmark
// process landing on one core or the other gave two modes of timings; an hour later both cores
// were equal again. So each core's speed is measured when the program starts, with a chain of
// dependent integer additions (one per cycle on x86-64 cores: a clock-like rate), the figures go
// into the results' provenance, and single-threaded benchmarks are pinned to the fastest core
// (one core for the whole run, whichever it is, also keeps the scheduler from moving them).
// Linux only (sched_setaffinity); elsewhere nothing is measured or pinned.
#pragma once

#include <string>
#include <vector>

namespace minv {

struct CoreSpeed {
  int cpu;             // the logical CPU's number
  double adds_per_ns;  // dependent additions per ns, the best of several short runs
};

// Every CPU in this thread's affinity mask, measured in turn (about 8 ms a core); the mask is
// restored after.
std::vector<CoreSpeed> measureCoreSpeeds();

// The calling thread's affinity mask when made, and the speed of each core in it.
class CorePinning {
 public:
  // Records the current mask, starts OpenMP's threads on it, and measures the cores in it.
  CorePinning();
  // This thread on the fastest core (single-threaded work).
  void pinFastest() const;
  // This thread back on every CPU of the recorded mask (threads made while it was pinned keep
  // the pinned mask: OpenMP's are made by the constructor).
  void release() const;
  int fastest() const { return fastest_; }
  const std::vector<CoreSpeed>& speeds() const { return speeds_; }
  // "cpu 0: 3.55 adds/ns, cpu 1: 3.07 adds/ns; single-threaded runs pinned to cpu 0".
  std::string summary() const;

 private:
  std::vector<CoreSpeed> speeds_;
  std::vector<int> mask_;
  int fastest_ = -1;
};

}  // namespace minv
