// own_minv: minv's command with this project's solver registered, e.g.
//   own_minv solvers
//   own_minv solve --model robot.urdf --solver all --out robot.h5
//   own_minv check --solver blocked-cholesky
//   own_minv time --mode tiny --solvers abi,blocked-cholesky --out t.h5
#include "blocked_cholesky.hpp"
#include "experiments/lib/cli.hpp"

int main(int argc, char** argv) {
  own::registerBlockedCholesky();
  return minv::runCli(argc, argv, "own_minv");
}
