// bench_timing: the timing sweeps of Figures 2 and 3 (experiments/lib/timing.hpp), measured
// with Google Benchmark used as a library: each point registers one benchmark (a lambda over
// the prepared solver), runs it with Repetitions(r) and MinTime(t), and a reporter captures
// every repetition's real and CPU time per iteration (the raw repetitions, not aggregates).
//
//   bench_timing [--mode quick|full|tiny] [--shard i/N] [--min-time S] [--repetitions R]
//                [--list] --out FILE.h5
//
// The file is written point by point and resumed on a rerun (see timing.hpp). Errors: one
// line "bench_timing: error: …", exit 2.
#include <benchmark/benchmark.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <filesystem>
#include <iostream>
#include <stdexcept>

#include "experiments/lib/provenance.hpp"
#include "experiments/lib/timing.hpp"

namespace {

// Captures the per-repetition runs; aggregates (mean, median, stddev) are ignored.
class CaptureReporter : public benchmark::BenchmarkReporter {
 public:
  minv::Measurement result;
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

minv::Measurement measureWithGoogleBenchmark(const std::string& label,
                                             const std::function<void()>& body,
                                             const minv::TimingSweep& sweep) {
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

int fail(std::string message) {
  std::replace(message.begin(), message.end(), '\n', ' ');
  std::cerr << "bench_timing: error: " << message << std::endl;
  return 2;
}

}  // namespace

int main(int argc, char** argv) {
  std::string mode = "quick", shard_text = "0/1", out;
  double min_time = -1;
  int repetitions = -1;
  bool list = false;
  CLI::App app{"Timing sweeps (Figures 2 and 3) with Google Benchmark; resumable HDF5 output"};
  app.add_option("--mode", mode, "quick | full | tiny")->capture_default_str();
  app.add_option("--shard", shard_text, "Run the points i, i+N, i+2N, … of the sweep")
      ->capture_default_str();
  app.add_option("--min-time", min_time, "Google Benchmark min time per repetition (s)");
  app.add_option("--repetitions", repetitions, "Repetitions per point");
  app.add_flag("--list", list, "Print the shard's points and exit");
  app.add_option("--out", out, "Output HDF5 file (appended to and resumed)");
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    if (e.get_exit_code() == static_cast<int>(CLI::ExitCodes::Success)) return app.exit(e);
    return fail(e.what());
  }
  try {
    minv::TimingSweep sweep = minv::timingSweep(mode);
    if (min_time > 0) sweep.min_time = min_time;
    if (repetitions > 0) sweep.repetitions = repetitions;
    const minv::Shard shard = minv::parseShard(shard_text);
    if (list) {
      for (const auto& p : minv::shardPoints(minv::sweepPoints(sweep), shard)) {
        const auto skip = minv::skipReason(p.solver, p.family, p.topology, p.n, sweep.mode);
        std::cout << p.name() << (skip ? "  skipped: " + *skip : "") << "\n";
      }
      return 0;
    }
    if (out.empty()) throw std::invalid_argument("--out is required");
    const std::filesystem::path dir = std::filesystem::path(out).parent_path();
    if (!dir.empty() && !std::filesystem::is_directory(dir))
      throw std::runtime_error("output directory '" + dir.string() + "' does not exist");
    // Google Benchmark wants Initialize(); give it no flags of its own.
    int bargc = 1;
    char* bargv[] = {argv[0], nullptr};
    benchmark::Initialize(&bargc, bargv);
    std::cout << "# " << minv::provenanceSummary() << "\n# sweep " << sweep.mode << ", shard "
              << shard_text << ", min_time " << sweep.min_time << " s, " << sweep.repetitions
              << " repetitions -> " << out << std::endl;
    const minv::SweepStats st =
        minv::runTimingSweep(sweep, shard, out, measureWithGoogleBenchmark, std::cout);
    std::cout << "bench_timing: " << st.measured << " measured, " << st.skipped << " skipped, "
              << st.resumed << " already in " << out << std::endl;
    return 0;
  } catch (const std::exception& e) {
    return fail(e.what());
  }
}
