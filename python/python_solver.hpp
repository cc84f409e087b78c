// The bridge between Python solvers and minv's C++ harness.
//
// PythonSolver is a minv::Solver whose work is done by a Python object with the methods
//   prepare(model), configure(q), inverse() -> (nv, nv) array, solve(R) -> (nv, m) array
// and, optionally, set_threads(n), threads (an int attribute or a method) and supports(model)
// (-> bool or (bool, reason)). Every call acquires the GIL (pybind11::gil_scoped_acquire), so
// it may be made from a thread that released it (minv.check and minv.compare release the GIL
// around the C++ harness). The Python object receives its own copy of the model (a minv.Model)
// and q as a float64 numpy array; R as a Fortran-ordered float64 copy.
//
// Contract: results are converted to float64 and copied into the C++ outputs; a result of
// the wrong shape or with a non-finite entry throws std::runtime_error naming the solver, the
// method and what was expected. A Python exception raised by a method becomes a
// std::runtime_error "<label>.<method>(): <PythonType>: <message>", except KeyboardInterrupt
// and SystemExit, which become PythonInterrupt (deliberately NOT a std::exception, so the
// conformance checks, which record std::exceptions per case, let it through and the user's
// Ctrl-C stops the whole run). The Python objects are released with the GIL held, and are
// leaked instead when the interpreter is already finalising (a solver destroyed at exit).
#pragma once

#include <pybind11/pybind11.h>

#include <memory>
#include <string>

#include "solvers/solver.hpp"

namespace minv::python {

namespace py = pybind11;

// A Ctrl-C (KeyboardInterrupt) or SystemExit raised inside a Python solver's method.
struct PythonInterrupt {
  bool system_exit = false;
  std::string message;
};

// A Python object shared by C++ copies (std::function, registry entries) without touching
// its reference count: the one reference is dropped, with the GIL, by the last owner.
using SharedObject = std::shared_ptr<py::object>;
SharedObject shareObject(py::object object);

class PythonSolver : public Solver {
 public:
  // `object` is the Python solver; `label` names it in messages. Needs the GIL.
  PythonSolver(SharedObject object, std::string label);

  bool supports(const Model& model, std::string* why) const override;
  void setThreads(int n) override;
  int threads() const override;
  void prepare(const Model& model) override;
  void configure(const Eigen::VectorXd& q) override;
  void inverse(MatrixOut Minv) override;
  void solve(MatrixIn R, MatrixOut X) override;

 private:
  SharedObject object_;
  std::string label_;
  int nv_ = -1;
  int threads_ = 1;
};

// Checks that `object` has the four required methods (TypeError naming the missing ones).
// Needs the GIL.
void requireSolverMethods(const py::handle& object, const std::string& label);

// A factory for the harness: each call runs `factory()` (a Python callable returning a solver
// object) with the GIL and wraps the result.
std::function<std::unique_ptr<Solver>()> pythonFactory(SharedObject factory, std::string label);

}  // namespace minv::python
