// The `minv` command: everything is in the library (experiments/lib/cli.hpp), so that an
// outside project can give its users the same command with its own solvers registered.
#include "experiments/lib/cli.hpp"

int main(int argc, char** argv) {
  return minv::runCli(argc, argv);
}
