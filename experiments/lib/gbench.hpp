// Google Benchmark as the timing sweeps' measuring instrument (experiments/lib/timing.hpp's
// MeasureFn), used by `minv time`, bench_timing and the Python module's minv.compare.
//
// Each point registers one benchmark (a lambda over the prepared solver), runs it with
// Repetitions(r), MinTime(t) and real time, and a reporter captures every repetition's real and
// CPU time per iteration (the raw repetitions, not aggregates).
#pragma once

#include <functional>
#include <string>

#include "experiments/lib/timing.hpp"

namespace minv {

Measurement measureWithGoogleBenchmark(const std::string& label, const std::function<void()>& body,
                                       const TimingSweep& sweep);

}  // namespace minv
