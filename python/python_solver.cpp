// PythonSolver: a minv::Solver that calls a Python object (see python_solver.hpp).
#include "python_solver.hpp"

#include <pybind11/numpy.h>

#include <Eigen/Core>
#include <stdexcept>
#include <utility>

namespace minv::python {

namespace {

// "(3, 4)" for a numpy shape.
std::string shapeText(const py::array& a) {
  std::string out = "(";
  for (py::ssize_t k = 0; k < a.ndim(); ++k) out += (k ? ", " : "") + std::to_string(a.shape(k));
  return out + (a.ndim() == 1 ? ",)" : ")");
}

std::string typeName(const py::handle& object) {
  return py::str(py::type::of(object).attr("__name__")).cast<std::string>();
}

// Runs `body` (which calls into Python; the GIL is held) and turns what it raises into the
// C++ exceptions of the contract, naming `label.method()`.
template <class Body>
auto callPython(const std::string& label, const char* method, Body&& body) {
  try {
    return body();
  } catch (py::error_already_set& e) {
    // "Type: message", without the traceback that what() appends.
    const std::string text = typeName(e.value()) + ": " + py::str(e.value()).cast<std::string>();
    if (e.matches(PyExc_KeyboardInterrupt)) throw PythonInterrupt{false, text};
    if (e.matches(PyExc_SystemExit)) throw PythonInterrupt{true, text};
    throw std::runtime_error(label + "." + method + "(): " + text);
  } catch (const std::exception& e) {
    throw std::runtime_error(label + "." + method + "(): " + e.what());
  }
}

// Copies a returned array into `out` (rows × cols), checking type, shape and finiteness. A
// 1-D array of `rows` entries is accepted where one column is expected.
void copyResult(const py::object& result, MatrixOut out, const std::string& label,
                const char* method) {
  const Eigen::Index rows = out.rows(), cols = out.cols();
  const std::string what = std::string(method) == "inverse" ? "(nv, nv) = (" : "(nv, m) = (";
  const std::string expected = "expected a float array of shape " + what + std::to_string(rows) +
                               ", " + std::to_string(cols) + ")";
  using FArray = py::array_t<double, py::array::f_style | py::array::forcecast>;
  FArray a = FArray::ensure(result);
  if (!a)
    throw std::runtime_error(label + "." + method + "() returned a " + typeName(result) +
                             ", not an array of numbers; " + expected);
  const bool matrix = a.ndim() == 2 && a.shape(0) == rows && a.shape(1) == cols;
  const bool column = a.ndim() == 1 && cols == 1 && a.shape(0) == rows;
  if (!matrix && !column)
    throw std::runtime_error(label + "." + method + "() returned an array of shape " +
                             shapeText(a) + "; " + expected);
  Eigen::Map<const Eigen::MatrixXd> values(a.data(), rows, cols);
  if (!values.allFinite())
    throw std::runtime_error(label + "." + method + "() returned non-finite entries (NaN or inf)");
  out = values;
}

}  // namespace

SharedObject shareObject(py::object object) {
  return SharedObject(new py::object(std::move(object)), [](py::object* p) {
    // At exit, after the interpreter is gone, the reference is leaked rather than dropped.
    if (!Py_IsInitialized()) {
      p->release();
      delete p;
      return;
    }
    py::gil_scoped_acquire gil;
    delete p;
  });
}

void requireSolverMethods(const py::handle& object, const std::string& label) {
  std::string missing;
  for (const char* name : {"prepare", "configure", "inverse", "solve"})
    if (!py::hasattr(object, name) || !PyCallable_Check(object.attr(name).ptr()))
      missing += std::string(missing.empty() ? "" : ", ") + name + "()";
  if (!missing.empty())
    throw py::type_error("solver " + label + " (a " + typeName(object) + ") lacks " + missing +
                         "; a Python solver needs prepare(model), configure(q), inverse() and "
                         "solve(R)");
}

PythonSolver::PythonSolver(SharedObject object, std::string label)
    : object_(std::move(object)), label_(std::move(label)) {}

bool PythonSolver::supports(const Model& model, std::string* why) const {
  py::gil_scoped_acquire gil;
  if (!py::hasattr(*object_, "supports")) return true;
  return callPython(label_, "supports", [&] {
    // supports(model) -> bool, or (bool, reason).
    py::object r = object_->attr("supports")(py::cast(model, py::return_value_policy::copy));
    if (py::isinstance<py::tuple>(r) && py::len(r) == 2) {
      const bool ok = py::bool_(r[py::int_(0)]);
      if (!ok && why) *why = py::str(r[py::int_(1)]).cast<std::string>();
      return ok;
    }
    const bool ok = py::bool_(r);
    if (!ok && why) *why = label_ + ".supports() returned False";
    return ok;
  });
}

void PythonSolver::setThreads(int n) {
  threads_ = n;
  py::gil_scoped_acquire gil;
  if (!py::hasattr(*object_, "set_threads")) return;
  callPython(label_, "set_threads", [&] { object_->attr("set_threads")(n); });
}

int PythonSolver::threads() const {
  py::gil_scoped_acquire gil;
  if (!py::hasattr(*object_, "threads")) return 1;
  return callPython(label_, "threads", [&] {
    // An int attribute (property) or a method.
    py::object t = object_->attr("threads");
    if (PyCallable_Check(t.ptr())) t = t();
    return t.cast<int>();
  });
}

void PythonSolver::prepare(const Model& model) {
  py::gil_scoped_acquire gil;
  nv_ = -1;
  callPython(label_, "prepare",
             [&] { object_->attr("prepare")(py::cast(model, py::return_value_policy::copy)); });
  nv_ = model.nv();
}

void PythonSolver::configure(const Eigen::VectorXd& q) {
  py::gil_scoped_acquire gil;
  if (nv_ < 0) throw std::runtime_error(label_ + ": configure(q) before prepare(model)");
  py::array_t<double> qa(q.size(), q.data());
  callPython(label_, "configure", [&] { object_->attr("configure")(qa); });
}

void PythonSolver::inverse(MatrixOut Minv) {
  py::gil_scoped_acquire gil;
  py::object r = callPython(label_, "inverse", [&] { return object_->attr("inverse")(); });
  copyResult(r, Minv, label_, "inverse");
}

void PythonSolver::solve(MatrixIn R, MatrixOut X) {
  py::gil_scoped_acquire gil;
  // R as a Fortran-ordered float64 copy (the solver may keep or modify it).
  py::array_t<double, py::array::f_style> Ra({R.rows(), R.cols()});
  Eigen::Map<Eigen::MatrixXd>(Ra.mutable_data(), R.rows(), R.cols()) = R;
  py::object r = callPython(label_, "solve", [&] { return object_->attr("solve")(Ra); });
  copyResult(r, X, label_, "solve");
}

std::function<std::unique_ptr<Solver>()> pythonFactory(SharedObject factory, std::string label) {
  return [factory = std::move(factory), label = std::move(label)]() -> std::unique_ptr<Solver> {
    py::gil_scoped_acquire gil;
    py::object solver = callPython(label, "__init__", [&] { return (*factory)(); });
    requireSolverMethods(solver, label);
    return std::make_unique<PythonSolver>(shareObject(std::move(solver)), label);
  };
}

}  // namespace minv::python
