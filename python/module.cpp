// The extension module minv._minv: the C++ half of `import minv` (python/minv/__init__.py
// re-exports it and adds the pure-Python parts).
//
// Contract: every C++ exception reaches Python with its message: minv::ModelError as
// minv.ModelError (a subclass of ValueError), std::invalid_argument as ValueError, any other
// std::exception as RuntimeError (pybind11's standard translations for the rest of <stdexcept>);
// a KeyboardInterrupt or SystemExit raised inside a Python solver that C++ called comes back
// as itself.
#include <pybind11/pybind11.h>

#include "bindings.hpp"
#include "core/model.hpp"
#include "python_solver.hpp"

namespace py = pybind11;

PYBIND11_MODULE(_minv, m) {
  m.doc() = "minv: the joint-space inertia matrix M of articulated trees and its inverse (C++).";

  // Exceptions: ModelError is a ValueError; a Python interrupt travels through C++ as itself.
  py::register_exception<minv::ModelError>(m, "ModelError", PyExc_ValueError);
  py::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const minv::python::PythonInterrupt& e) {
      PyErr_SetString(e.system_exit ? PyExc_SystemExit : PyExc_KeyboardInterrupt,
                      e.message.c_str());
    }
  });

  minv::python::bindModels(m);
  minv::python::bindSolvers(m);
  minv::python::bindHarness(m);
}
