// minv._minv, solvers: the registry as seen from Python and the Solver handle.
//
// Contract of minv.Solver (one C++ solver from the registry):
//   * life cycle prepare(model) → configure(q) → inverse()/solve(R), as in solvers/solver.hpp;
//     calling a step before the previous one raises RuntimeError (never reaches the solver);
//   * prepare keeps the model (the Python object) alive while the solver uses it: the handle
//     holds a reference to the model of its latest prepare(), so an older one is released
//     (pybind11's keep_alive would keep every model ever prepared);
//   * configure(q) checks q with Model.check_configuration first (the CLI's messages);
//   * inverse(out=None), solve(R, out=None) return float64 arrays in Fortran order. With out=
//     the result is written into the caller's array through an Eigen::Map, without allocating
//     or copying: out must be a writeable, aligned float64 numpy array of exactly the result's
//     shape whose columns are contiguous (Fortran order, or a column slice of a Fortran array);
//     anything else is a ValueError saying what was expected. out must not overlap R.
//     inverse(upper=True) asks for the upper triangle alone (Solver::inverseUpper).
//   * R is any real array with nv rows, 2-D (nv, m) or 1-D (nv,) (→ a 1-D result); it is
//     converted (copied) to float64 Fortran order only when it is not already that.
//   * prepare / configure / inverse / solve run with the GIL released; a per-handle mutex
//     makes concurrent calls on the same handle wait for each other instead of racing.
#include <pybind11/eigen.h>
#include <pybind11/numpy.h>
#include <pybind11/stl.h>

#include <algorithm>
#include <chrono>
#include <memory>
#include <mutex>
#include <vector>

#include "bindings.hpp"
#include "experiments/lib/output_matrix.hpp"
#include "solvers/solver.hpp"

namespace minv::python {

namespace {

// One registered solver, its prepared model and where it is in its life cycle.
struct SolverHandle {
  std::string name;
  std::unique_ptr<Solver> solver;
  py::object model_object;       // keeps the prepared model alive
  const Model* model = nullptr;  // the C++ model inside model_object
  bool configured = false;
  std::mutex busy;  // held (without the GIL) by every call into the solver
};

using OuterMap = Eigen::Map<Eigen::MatrixXd, Eigen::Unaligned, Eigen::OuterStride<>>;

std::string shapeText(const std::vector<py::ssize_t>& shape) {
  std::string out = "(";
  for (std::size_t k = 0; k < shape.size(); ++k) out += (k ? ", " : "") + std::to_string(shape[k]);
  return out + (shape.size() == 1 ? ",)" : ")");
}

// Byte range [lo, hi) spanned by an array.
std::pair<const char*, const char*> extent(const py::array& a) {
  const char* lo = static_cast<const char*>(a.data());
  const char* hi = lo + a.itemsize();
  for (py::ssize_t k = 0; k < a.ndim(); ++k) {
    if (a.shape(k) == 0) return {lo, lo};
    const py::ssize_t span = a.strides(k) * (a.shape(k) - 1);
    (span < 0 ? lo : hi) += span;
  }
  return {lo, hi};
}

// The caller's `out` as a column-major map of the expected shape, or a ValueError. The checks
// are cheap; the message is only built for a rejected array.
OuterMap mapOut(const py::handle& out, const std::vector<py::ssize_t>& shape) {
  auto reject = [&](const std::string& got) {
    const std::string want = shapeText(shape);
    return py::value_error("out must be a writeable float64 array of shape " + want +
                           " in Fortran order: numpy.empty(" +
                           (shape.size() == 1 ? std::to_string(shape[0]) : want) +
                           ", order='F'); got " + got);
  };
  if (!py::isinstance<py::array>(out))
    throw reject("a " + py::str(py::type::of(out).attr("__name__")).cast<std::string>());
  py::array a = py::reinterpret_borrow<py::array>(out);
  auto describe = [&](const char* adjective) {
    std::vector<py::ssize_t> got(a.shape(), a.shape() + a.ndim());
    return std::string("a ") + adjective + py::str(a.dtype()).cast<std::string>() +
           " array of shape " + shapeText(got);
  };
  const bool same_shape = a.ndim() == static_cast<py::ssize_t>(shape.size()) &&
                          std::equal(shape.begin(), shape.end(), a.shape());
  if (!same_shape || !a.dtype().equal(py::dtype::of<double>())) throw reject(describe(""));
  if (!a.writeable()) throw reject(describe("read-only "));
  const py::ssize_t rows = shape[0], cols = shape.size() == 2 ? shape[1] : 1;
  // An empty result has nothing to write.
  if (rows == 0 || cols == 0)
    return OuterMap(static_cast<double*>(a.mutable_data()), rows, cols,
                    Eigen::OuterStride<>(std::max<py::ssize_t>(rows, 1)));
  // Aligned, rows contiguous (unit stride), columns at a stride of at least a column.
  constexpr py::ssize_t kDouble = sizeof(double);
  const auto flags = a.flags();
  const py::ssize_t row_stride = a.strides(0), col_stride = shape.size() == 2 ? a.strides(1) : 0;
  const bool aligned = (flags & py::detail::npy_api::NPY_ARRAY_ALIGNED_) != 0;
  const bool rows_ok = rows <= 1 || row_stride == kDouble;
  const bool cols_ok = cols <= 1 || (col_stride % kDouble == 0 && col_stride >= rows * kDouble);
  if (!aligned || !rows_ok || !cols_ok) {
    const bool c_order = (flags & py::detail::npy_api::NPY_ARRAY_C_CONTIGUOUS_) != 0;
    throw reject(describe("") + (c_order ? " in C order" : " with other strides"));
  }
  const Eigen::Index outer = cols <= 1 ? rows : col_stride / kDouble;
  return OuterMap(static_cast<double*>(a.mutable_data()), rows, cols, Eigen::OuterStride<>(outer));
}

// The handle's model, or RuntimeError naming the call that came too early.
const Model& requirePrepared(const SolverHandle& h, const char* call) {
  if (!h.model)
    throw std::runtime_error(std::string(call) + ": solver '" + h.name +
                             "' needs prepare(model) first");
  return *h.model;
}

void requireConfigured(const SolverHandle& h, const char* call) {
  requirePrepared(h, call);
  if (!h.configured)
    throw std::runtime_error(std::string(call) + ": solver '" + h.name +
                             "' needs configure(q) after prepare(model)");
}

// Called with the handle locked: the model may have changed since the output was sized.
void requireSameSize(const SolverHandle& h, int nv, const char* call) {
  requireConfigured(h, call);
  if (h.model->nv() != nv)
    throw std::runtime_error(std::string(call) + ": solver '" + h.name +
                             "' was prepared again by another thread during the call");
}

void prepare(SolverHandle& h, const py::object& model_object) {
  if (!py::isinstance<Model>(model_object))
    throw py::type_error("prepare(model) expects a minv.Model, got a " +
                         py::str(py::type::of(model_object).attr("__name__")).cast<std::string>());
  const Model& model = model_object.cast<const Model&>();
  std::unique_lock lock(h.busy, std::defer_lock);
  waitFor(lock);
  h.model = nullptr;
  h.configured = false;
  {
    py::gil_scoped_release release;
    h.solver->prepare(model);
  }
  h.model_object = model_object;
  h.model = &model;
}

void configure(SolverHandle& h, const py::object& q_object) {
  const Eigen::VectorXd q = realVector(q_object, "q");
  std::unique_lock lock(h.busy, std::defer_lock);
  waitFor(lock);
  const Model& model = requirePrepared(h, "configure(q)");
  model.checkConfiguration(q);
  h.configured = false;
  {
    py::gil_scoped_release release;
    h.solver->configure(q);
  }
  h.configured = true;
}

// M⁻¹, or with `upper` its upper triangle (Solver::inverseUpper: the strict lower triangle
// unspecified; a new array starts zeroed).
py::array inverse(SolverHandle& h, const py::object& out, bool upper) {
  const int nv = requirePrepared(h, "inverse()").nv();
  requireConfigured(h, "inverse()");
  py::array result;
  if (out.is_none()) {
    py::array_t<double, py::array::f_style> fresh({nv, nv});
    if (upper) std::fill_n(fresh.mutable_data(), fresh.size(), 0.0);
    result = fresh;
  } else {
    result = py::reinterpret_borrow<py::array>(out);
  }
  OuterMap X = mapOut(result, {nv, nv});
  std::unique_lock lock(h.busy, std::defer_lock);
  py::gil_scoped_release release;
  lock.lock();
  requireSameSize(h, nv, "inverse()");
  if (upper)
    h.solver->inverseUpper(X);
  else
    h.solver->inverse(X);
  // M singular to double precision (masses near the smallest doubles): an error, not NaN in X.
  bool finite = true;
  for (int j = 0; j < nv && finite; ++j)
    finite = upper ? X.col(j).head(j + 1).allFinite() : X.col(j).allFinite();
  if (!finite)
    throw std::domain_error(
        "inverse(): M⁻¹ is not finite: M is singular in double precision "
        "(masses or inertias too small?)");
  return result;
}

py::array solve(SolverHandle& h, const py::object& R_object, const py::object& out) {
  const int nv = requirePrepared(h, "solve(R)").nv();
  requireConfigured(h, "solve(R)");
  // R: real numbers, (nv,) or (nv, m), as float64 in Fortran order (a copy only if needed).
  auto reject = [&](const std::string& got) {
    return py::value_error("R must be a real array of shape (nv,) or (nv, m) with nv = " +
                           std::to_string(nv) + "; got " + got);
  };
  if (py::isinstance<py::array>(R_object) &&
      py::reinterpret_borrow<py::array>(R_object).dtype().kind() == 'c')
    throw reject("a complex array");
  using FArray = py::array_t<double, py::array::f_style | py::array::forcecast>;
  FArray R = FArray::ensure(R_object);
  if (!R)
    throw reject("a " + py::str(py::type::of(R_object).attr("__name__")).cast<std::string>() +
                 " that numpy cannot convert to float64");
  if ((R.ndim() != 1 && R.ndim() != 2) || R.shape(0) != nv)
    throw reject("shape " + shapeText(std::vector<py::ssize_t>(R.shape(), R.shape() + R.ndim())));
  const py::ssize_t m = R.ndim() == 2 ? R.shape(1) : 1;
  const std::vector<py::ssize_t> shape =
      R.ndim() == 2 ? std::vector<py::ssize_t>{nv, m} : std::vector<py::ssize_t>{nv};
  py::array result;
  if (out.is_none())
    result = py::array_t<double, py::array::f_style>(shape);
  else
    result = py::reinterpret_borrow<py::array>(out);
  OuterMap X = mapOut(result, shape);
  // The solver reads R while it writes X: they must not share memory.
  const auto [rlo, rhi] = extent(R);
  const auto [xlo, xhi] = extent(result);
  if (rlo < xhi && xlo < rhi) throw py::value_error("out must not share memory with R");
  if (m == 0) return result;
  Eigen::Map<const Eigen::MatrixXd> Rmap(R.data(), nv, m);
  // A NaN or an infinity in R would only come back as NaN in X (lapack even blamed M for it).
  if (!Rmap.allFinite()) {
    Eigen::Index i = 0, j = 0;
    (!Rmap.array().isFinite()).cast<int>().maxCoeff(&i, &j);
    throw reject("an array with the non-finite entry " + std::to_string(Rmap(i, j)) + " at (" +
                 std::to_string(i) + ", " + std::to_string(j) + ")");
  }
  {
    std::unique_lock lock(h.busy, std::defer_lock);
    py::gil_scoped_release release;
    lock.lock();
    requireSameSize(h, nv, "solve(R)");
    h.solver->solve(Rmap, X);
  }
  // Finite R, yet M⁻¹R beyond the largest double: an error, not a silent infinity in X.
  if (!X.allFinite())
    throw py::value_error("solve(R): M⁻¹R overflows (an entry is beyond ±1.8e308); scale R down");
  return result;
}

// Seconds per inverse() call timed in C++: the median over `runs` of (time of `repetitions`
// back-to-back calls) / repetitions, into `out` if given (the same memory as a Python loop),
// else into a zeroed matrix on huge pages like every output the harness times (outputMatrix).
double timeInverse(SolverHandle& h, int repetitions, int runs, const py::object& out) {
  if (repetitions < 1 || runs < 1) throw py::value_error("repetitions and runs must be at least 1");
  const int nv = requirePrepared(h, "_time_inverse()").nv();
  requireConfigured(h, "_time_inverse()");
  Eigen::MatrixXd own;
  py::array keep;
  if (out.is_none()) {
    own = outputMatrix(nv, nv);
  } else {
    keep = py::reinterpret_borrow<py::array>(out);
  }
  OuterMap X = out.is_none() ? OuterMap(own.data(), nv, nv, Eigen::OuterStride<>(nv))
                             : mapOut(keep, {nv, nv});
  std::unique_lock lock(h.busy, std::defer_lock);
  py::gil_scoped_release release;
  lock.lock();
  requireSameSize(h, nv, "_time_inverse()");
  std::vector<double> per_call;
  h.solver->inverse(X);  // warm-up
  for (int r = 0; r < runs; ++r) {
    const auto t0 = std::chrono::steady_clock::now();
    for (int k = 0; k < repetitions; ++k) h.solver->inverse(X);
    const std::chrono::duration<double> dt = std::chrono::steady_clock::now() - t0;
    per_call.push_back(dt.count() / repetitions);
  }
  std::sort(per_call.begin(), per_call.end());
  return per_call[per_call.size() / 2];
}

}  // namespace

void bindSolvers(py::module_& m) {
  // The registry.
  m.def(
      "solvers",
      [] {
        std::vector<std::pair<std::string, std::string>> out;
        for (const SolverEntry& e : solverRegistry()) out.emplace_back(e.name, e.summary);
        return out;
      },
      "The registered solvers in registry order, as a list of (name, summary) tuples.");
  m.def(
      "counted_solvers",
      [] {
        std::vector<std::string> out;
        for (const SolverEntry& e : solverRegistry())
          if (e.count) out.push_back(e.name);
        return out;
      },
      "Names of the registered solvers whose operations flops() can count.");

  py::class_<SolverHandle>(m, "Solver", R"doc(
A registered solver (minv.make_solver(name)): prepare(model) once per tree, configure(q) once
per configuration, then inverse() / solve(R) any number of times. The GIL is released while
the C++ solver runs.)doc")
      .def_property_readonly("name", [](const SolverHandle& h) { return h.name; })
      .def_property_readonly(
          "nv",
          [](const SolverHandle& h) { return h.model ? py::cast(h.model->nv()) : py::none(); },
          "nv of the prepared model, or None before prepare().")
      .def_property_readonly(
          "model", [](const SolverHandle& h) { return h.model ? h.model_object : py::none(); },
          "The prepared model, or None.")
      .def_property_readonly(
          "threads",
          [](SolverHandle& h) {
            std::unique_lock lock(h.busy, std::defer_lock);
            waitFor(lock);
            return h.solver->threads();
          },
          "Threads the solver will actually use.")
      .def(
          "set_threads",
          [](SolverHandle& h, Int n_arg) {
            const int n = n_arg;
            if (n < 1 || n > kMaxThreads)
              throw py::value_error("threads must be between 1 and " + std::to_string(kMaxThreads) +
                                    ", got " + std::to_string(n));
            std::unique_lock lock(h.busy, std::defer_lock);
            waitFor(lock);
            h.solver->setThreads(n);
          },
          py::arg("n"), "Threads the solver may use from now on (default 1).")
      .def(
          "supports",
          [](SolverHandle& h, const Model& model) {
            std::string why;
            std::unique_lock lock(h.busy, std::defer_lock);
            waitFor(lock);
            const bool ok = h.solver->supports(model, &why);
            return py::make_tuple(ok, why);
          },
          py::arg("model"), "(True, '') if the solver handles this tree, else (False, reason).")
      .def("prepare", &prepare, py::arg("model"),
           "Allocates for this tree; the solver keeps the model alive.")
      .def("configure", &configure, py::arg("q"),
           "Per configuration q (checked with Model.check_configuration).")
      .def("inverse", &inverse, py::arg("out") = py::none(), py::kw_only(),
           py::arg("upper") = false, R"doc(
M⁻¹ as an (nv, nv) float64 array. out: write into this array instead (float64, shape (nv, nv),
Fortran order: numpy.empty((nv, nv), order='F')); it is filled in place and returned.
upper=True: M⁻¹'s upper triangle (diagonal included), for a symmetric consumer; the strict
lower triangle is unspecified (abi and lapack leave it as it was, zero in a new array, and take
less time; other solvers write the whole inverse).)doc")
      .def("solve", &solve, py::arg("R"), py::arg("out") = py::none(), R"doc(
M⁻¹R for R of shape (nv, m), or (nv,) for one vector. out: write into this array instead
(float64, the result's shape, Fortran order); it is filled in place and returned.)doc")
      .def("_time_inverse", &timeInverse, py::arg("repetitions"), py::arg("runs") = 7,
           py::arg("out") = py::none(),
           "Seconds per inverse() call timed in C++ (median of runs), for overhead checks.")
      .def("__repr__", [](const SolverHandle& h) {
        std::string state = "not prepared";
        if (h.model)
          state = "prepared for nv=" + std::to_string(h.model->nv()) +
                  (h.configured ? ", configured" : ", not configured");
        return "<minv.Solver '" + h.name + "', " + state + ">";
      });

  m.def(
      "make_solver",
      [](const std::string& name) {
        auto h = std::make_unique<SolverHandle>();
        h->solver = makeSolver(name);
        h->name = name;
        return h;
      },
      py::arg("name"), "A new instance of a registered solver (ValueError for an unknown name).");
}

}  // namespace minv::python
