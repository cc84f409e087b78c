// bench_timing: the timing sweeps of Figures 2 and 3, the same as `minv time` (see
// experiments/lib/cli.cpp and experiments/lib/timing.hpp), kept as its own program for the
// Slurm script and existing command lines.
//
//   bench_timing [--mode quick|full|tiny] [--solvers A,B] [--shard i/N] [--min-time S]
//                [--repetitions R] [--list] --out FILE.h5
//
// Errors: one line "bench_timing: error: …", exit 2.
#include <string>
#include <vector>

#include "experiments/lib/cli.hpp"

int main(int argc, char** argv) {
  // bench_timing ARGS… is minv time ARGS…
  std::string time = "time";
  std::vector<char*> args{argv[0], time.data()};
  for (int i = 1; i < argc; ++i) args.push_back(argv[i]);
  args.push_back(nullptr);
  return minv::runCli(argc + 1, args.data(), "bench_timing");
}
