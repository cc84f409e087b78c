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
#include <climits>
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

// An int argument (a size, a count): any Python integer, or object with __index__ such as
// numpy's; one outside C's int is a ValueError naming it (pybind11's own int gives a TypeError
// listing every signature). The range a size must lie in is the callee's to check.
struct Int {
  int value = 0;
  operator int() const { return value; }  // NOLINT: used as the int it holds
};

// A seed from a Python int: ValueError for a negative or too large one.
std::uint64_t seedFrom(const py::int_& seed, const char* what = "seed");

// A configuration or other vector from anything numpy reads as a 1-D array of real numbers;
// ValueError naming `what` for a complex one (whose imaginary part would be dropped) or any
// other shape or type.
Eigen::VectorXd realVector(const py::handle& v, const char* what);

}  // namespace minv::python

namespace pybind11::detail {
template <>
struct type_caster<minv::python::Int> {
  PYBIND11_TYPE_CASTER(minv::python::Int, const_name("int"));
  bool load(handle src, bool) {
    // floats are not sizes (pybind11's int refuses them too)
    if (!src || PyFloat_Check(src.ptr())) return false;
    const object index = reinterpret_steal<object>(PyNumber_Index(src.ptr()));
    if (!index) {
      // not an integer: the next overload, or pybind11's TypeError; anything else (an
      // interrupt inside __index__) as it was raised
      if (!PyErr_ExceptionMatches(PyExc_TypeError)) throw error_already_set();
      PyErr_Clear();
      return false;
    }
    int overflow = 0;
    const long long v = PyLong_AsLongLongAndOverflow(index.ptr(), &overflow);
    if (overflow != 0 || v < INT_MIN || v > INT_MAX)
      throw value_error(repr(src).cast<std::string>() +
                        " is out of range: an int argument lies in [-2**31, 2**31)");
    value.value = static_cast<int>(v);
    return true;
  }
  static handle cast(minv::python::Int src, return_value_policy, handle) {
    return PyLong_FromLong(src.value);
  }
};
}  // namespace pybind11::detail
