// The solver's conformance test: every check of minv's suite, with minv's bounds.
#include <iostream>

#include "blocked_cholesky.hpp"
#include "solvers/conformance.hpp"

int main() {
  own::registerBlockedCholesky();
  const minv::ConformanceReport report = minv::checkSolver("blocked-cholesky");
  report.print(std::cout);
  return report.passed() ? 0 : 1;
}
