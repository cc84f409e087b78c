// The `minv` command as a library entry point. experiments/minv.cpp is `return runCli(…)`; an
// outside project's own main registers its solvers first (solvers/solver.hpp:
// registerSolver) and then calls runCli, so its users get a minv-like command whose `solve
// --solver all`, `check`, `flops` and `time` include those solvers:
//
//   int main(int argc, char** argv) {
//     minv::registerSolver({"mine", "my method", [] { return std::make_unique<Mine>(); }, {}});
//     return minv::runCli(argc, argv, "mine-bench");
//   }
//
// The subcommands, their options and the contract (exit 0 on success, one line
// "<program>: error: …" and exit 2 on any failure, no half-written output file) are described
// at the top of experiments/lib/cli.cpp and in the README; `--help` on any subcommand prints
// its options.
#pragma once

#include <string>

namespace minv {

// Runs one command line; returns the process exit status. `program` names the command in
// its messages ("minv: error: …").
int runCli(int argc, char** argv, const std::string& program = "minv");

}  // namespace minv
