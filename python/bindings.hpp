// Shared declarations of the extension module minv._minv (python/module.cpp defines it).
//
// The module is split by subject: models.cpp (Model, generators, model files, CRBA, flops),
// solvers.cpp (the Solver handle: prepare / configure / inverse / solve with out=), harness.cpp
// (conformance checks, timing comparison, registering Python solvers, reading result files).
//
// Locking rules (no deadlock, no crash under Python threads):
//   * a C++ solver runs with the GIL released; a Python solver's methods re-acquire it;
//   * nothing ever waits for a C++ mutex while holding the GIL (release it first: waitFor());
//   * a mutex in harness.cpp serialises every change to the solver registry made from Python
//     with the timing sweeps that read it (minv.compare), which run with the GIL released.
#pragma once

#include <pybind11/pybind11.h>

#include <Eigen/Core>
#include <cstdint>
#include <mutex>
#include <string>

namespace minv::python {

namespace py = pybind11;

void bindModels(py::module_& m);
void bindSolvers(py::module_& m);
void bindHarness(py::module_& m);

// Locks `lock` with the GIL released while waiting; returns with both held.
template <class Lock>
void waitFor(Lock& lock) {
  py::gil_scoped_release release;
  lock.lock();
}

// A seed from a Python int: ValueError for a negative or too large one.
std::uint64_t seedFrom(const py::int_& seed, const char* what = "seed");

// A configuration or other vector from anything numpy reads as a 1-D array of real numbers;
// ValueError naming `what` for a complex one (whose imaginary part would be dropped) or any
// other shape or type.
Eigen::VectorXd realVector(const py::handle& v, const char* what);

}  // namespace minv::python
