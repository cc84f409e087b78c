#include "experiments/lib/gbench.hpp"

#include <benchmark/benchmark.h>

#include <algorithm>
#include <mutex>
#include <stdexcept>

namespace minv {

namespace {

// Captures the per-repetition runs; aggregates (mean, median, stddev) are ignored.
class CaptureReporter : public benchmark::BenchmarkReporter {
 public:
  Measurement result;
  std::string error;
  bool ReportContext(const Context&) override { return true; }
  void ReportRuns(const std::vector<Run>& runs) override {
    for (const Run& r : runs) {
      if (r.run_type != Run::RT_Iteration) continue;
      if (r.error_occurred) {
        error = r.error_message;
        continue;
      }
      const double it = static_cast<double>(std::max<benchmark::IterationCount>(r.iterations, 1));
      result.real_s.push_back(r.real_accumulated_time / it);
      result.cpu_s.push_back(r.cpu_accumulated_time / it);
      result.iterations.push_back(static_cast<std::int64_t>(r.iterations));
    }
  }
};

}  // namespace

Measurement measureWithGoogleBenchmark(const std::string& label, const std::function<void()>& body,
                                       const TimingSweep& sweep) {
  // Google Benchmark wants Initialize() once; give it no flags of its own.
  static std::once_flag init;
  std::call_once(init, [] {
    int argc = 1;
    char name[] = "minv";
    char* argv[] = {name, nullptr};
    benchmark::Initialize(&argc, argv);
  });
  benchmark::ClearRegisteredBenchmarks();
  benchmark::RegisterBenchmark(label.c_str(),
                               [&body](benchmark::State& state) {
                                 for (auto _ : state) body();
                               })
      ->Repetitions(sweep.repetitions)
      ->MinTime(sweep.min_time)
      ->UseRealTime()
      ->Unit(benchmark::kMicrosecond);
  CaptureReporter reporter;
  benchmark::RunSpecifiedBenchmarks(&reporter);
  benchmark::ClearRegisteredBenchmarks();
  if (!reporter.error.empty()) throw std::runtime_error(label + ": " + reporter.error);
  return reporter.result;
}

}  // namespace minv
