// The extension module minv._minv: the C++ half of `import minv` (python/minv/__init__.py
// re-exports it and adds the pure-Python parts).
//
// Contract: every C++ exception reaches Python with its message: minv::ModelError as
// minv.ModelError (a subclass of ValueError), std::invalid_argument as ValueError, any other
// std::exception as RuntimeError (pybind11's standard translations for the rest of <stdexcept>);
// a KeyboardInterrupt or SystemExit raised inside a Python solver that C++ called comes back
// as itself. Bytes of a message that are not UTF-8 (a path's) are escaped, not lost.
#include <pybind11/pybind11.h>

#include <cstring>
#include <stdexcept>

#include "bindings.hpp"
#include "core/model.hpp"
#include "experiments/lib/h5writer.hpp"
#include "python_solver.hpp"

namespace py = pybind11;

namespace {

// The exception `type` with `what` as its text; bytes that are not UTF-8 as \xNN escapes
// (PyErr_SetString would leave an empty message).
void setError(PyObject* type, const char* what) {
  PyObject* text =
      PyUnicode_DecodeUTF8(what, static_cast<Py_ssize_t>(std::strlen(what)), "backslashreplace");
  if (!text) {
    PyErr_Clear();
    PyErr_SetString(type, "");
    return;
  }
  PyErr_SetObject(type, text);
  Py_DECREF(text);
}

}  // namespace

PYBIND11_MODULE(_minv, m) {
  m.doc() = "minv: the joint-space inertia matrix M of articulated trees and its inverse (C++).";

  // Exceptions: ModelError is a ValueError; a Python interrupt travels through C++ as itself.
  static py::exception<minv::ModelError> model_error(m, "ModelError", PyExc_ValueError);
  // HDF5's error printing off (experiments/lib/h5writer.cpp). Its close at exit, where a file
  // whose flush had failed made it crash, is harmless now that the files Python writes (all in
  // append mode) are built in memory and written by the writer itself.
  minv::silenceHdf5Errors();
  // This module's exceptions only (a local translator: another module's stay its own).
  py::register_local_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const minv::python::PythonInterrupt& e) {
      setError(e.system_exit ? PyExc_SystemExit : PyExc_KeyboardInterrupt, e.message.c_str());
    } catch (const py::builtin_exception&) {
      throw;  // pybind11's own (py::value_error …): as pybind11 raises them
    } catch (const minv::ModelError& e) {
      setError(model_error.ptr(), e.what());
    } catch (const std::invalid_argument& e) {
      setError(PyExc_ValueError, e.what());
    } catch (const std::range_error&) {
      throw;  // pybind11's standard translation
    } catch (const std::overflow_error&) {
      throw;
    } catch (const std::runtime_error& e) {
      setError(PyExc_RuntimeError, e.what());
    }
  });

  minv::python::bindModels(m);
  minv::python::bindSolvers(m);
  minv::python::bindHarness(m);
}
