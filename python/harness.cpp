// minv._minv, harness: the conformance checks, the timing comparison, Python solvers in the
// registry, and reading timing files. The pure-Python front ends (minv.check, minv.compare,
// minv.register_solver) are in python/minv/__init__.py; these are their C++ halves.
//
// Contract:
//   _check(label, factory, …) / _check_registered(name, …) run minv::checkSolver with the GIL
//     released (a Python solver's methods re-acquire it) and return a ConformanceReport.
//   _register(name, summary, factory) adds a Python solver to the registry (ValueError for an
//     invalid or taken name); _unregister(name) removes it; _unregister_python() removes every
//     solver registered from Python (called at exit, before the interpreter goes away).
//   _compare(…) registers the Python solver under `name` (`label` names it in messages), runs
//     one "pipeline" block of the timing sweep (experiments/lib/timing.hpp) with Google
//     Benchmark into `path`, and unregisters it again, also on error; OpenBLAS's and OpenMP's
//     thread counts, which the sweep sets to 1, are restored. The sweep runs with the GIL
//     released. Progress lines go to the Python callable `log` (or nowhere if it is None).
//   _read_points(path) is minv::readPoints.
//   A KeyboardInterrupt inside a Python solver stops the whole check or sweep (PythonInterrupt).
#include <omp.h>
#include <pybind11/numpy.h>
#include <pybind11/stl.h>

#include <ostream>
#include <set>
#include <sstream>
#include <streambuf>

#include "bindings.hpp"
#include "experiments/lib/gbench.hpp"
#include "experiments/lib/h5reader.hpp"
#include "experiments/lib/h5writer.hpp"
#include "experiments/lib/isolate.hpp"
#include "experiments/lib/timing.hpp"
#include "generators/random_tree.hpp"
#include "python_solver.hpp"
#include "solvers/conformance.hpp"

extern "C" {
int openblas_get_num_threads(void);
void openblas_set_num_threads(int);
}

namespace minv::python {

namespace {

// Serialises registry changes made from Python with the timing sweeps that read the registry
// (minv.compare), which run without the GIL. Not re-entrant: a solver that minv.compare is
// timing cannot register solvers or start another comparison (RuntimeError, not a deadlock).
thread_local bool t_holds_harness = false;

class HarnessLock {
 public:
  HarnessLock() : lock_(mutex(), std::defer_lock) {
    if (t_holds_harness)
      throw std::runtime_error(
          "the solver registry is in use by minv.compare in this thread: a solver being timed "
          "cannot register solvers or start another comparison");
    waitFor(lock_);
    t_holds_harness = true;
  }
  ~HarnessLock() { t_holds_harness = false; }
  HarnessLock(const HarnessLock&) = delete;
  HarnessLock& operator=(const HarnessLock&) = delete;

 private:
  static std::mutex& mutex() {
    static std::mutex m;
    return m;
  }
  std::unique_lock<std::mutex> lock_;
};

// Names registered from Python (guarded by the harness mutex).
std::set<std::string>& pythonNames() {
  static std::set<std::string> names;
  return names;
}

ConformanceOptions conformanceOptions(int max_n, bool urdf, bool two_threads, bool reconfigure) {
  if (max_n < 1) throw py::value_error("max_n must be at least 1, got " + std::to_string(max_n));
  ConformanceOptions o;
  o.max_n = max_n;
  o.urdf = urdf;
  o.two_threads = two_threads;
  o.reconfigure = reconfigure;
  return o;
}

ConformanceReport checkWith(const std::string& label, const SolverFactory& make,
                            const ConformanceOptions& options) {
  py::gil_scoped_release release;
  return checkSolver(label, make, options);
}

// Lines written to it go to a Python callable, one call per flush (std::endl).
class PythonLogBuffer : public std::streambuf {
 public:
  explicit PythonLogBuffer(py::object log) : log_(shareObject(std::move(log))) {}

 protected:
  int overflow(int c) override {
    if (c != traits_type::eof()) text_.push_back(static_cast<char>(c));
    return c;
  }
  std::streamsize xsputn(const char* s, std::streamsize n) override {
    text_.append(s, static_cast<std::size_t>(n));
    return n;
  }
  int sync() override {
    if (text_.empty() || log_->is_none()) return text_.clear(), 0;
    py::gil_scoped_acquire gil;
    try {
      (*log_)(text_);
    } catch (py::error_already_set&) {
      // A failing logger must not stop the sweep.
    }
    text_.clear();
    return 0;
  }

 private:
  SharedObject log_;
  std::string text_;
};

// Restores OpenBLAS's and OpenMP's thread counts on scope exit (the sweep sets them to 1).
class ThreadCountsGuard {
 public:
  ThreadCountsGuard() : blas_(openblas_get_num_threads()), omp_(omp_get_max_threads()) {}
  ~ThreadCountsGuard() {
    openblas_set_num_threads(blas_);
    omp_set_num_threads(omp_);
  }

 private:
  int blas_, omp_;
};

// Removes a registry entry on scope exit (with the GIL held: it may own Python objects).
class RegistrationGuard {
 public:
  explicit RegistrationGuard(std::string name) : name_(std::move(name)) {}
  ~RegistrationGuard() { unregisterSolver(name_); }

 private:
  std::string name_;
};

py::dict compare(const std::string& name, const std::string& label, const std::string& summary,
                 const py::object& factory, const std::vector<int>& sizes,
                 const std::vector<std::string>& topologies,
                 const std::vector<std::string>& against, const std::string& path,
                 Int repetitions_arg, double min_time, const std::string& mode,
                 const py::object& log) {
  // Validate everything before any work.
  const int repetitions = repetitions_arg;
  if (const std::string why = solverNameProblem(name); !why.empty()) throw py::value_error(why);
  if (sizes.empty()) throw py::value_error("sizes must not be empty");
  for (int n : sizes)
    if (n < 1) throw py::value_error("sizes must be positive, got " + std::to_string(n));
  if (topologies.empty()) throw py::value_error("topologies must not be empty");
  for (const std::string& t : topologies) topologyFromName(t);
  for (const std::string& a : against) {
    if (a == name)
      throw py::value_error("against must not contain the solver's own name '" + a + "'");
    if (!findSolver(a)) makeSolver(a);  // ValueError listing the known names
  }
  if (repetitions < 1) throw py::value_error("repetitions must be at least 1");
  if (!(min_time > 0)) throw py::value_error("min_time must be positive (seconds)");
  if (mode != "quick" && mode != "full" && mode != "tiny")
    throw py::value_error("mode must be 'quick', 'full' or 'tiny' (the skip caps), got '" + mode +
                          "'");
  if (!PyCallable_Check(factory.ptr())) throw py::type_error("factory must be callable");

  // The sweep: one pipeline block, fixed base, M⁻¹ (m = 0), one thread.
  TimingSweep sweep;
  sweep.mode = mode;
  sweep.repetitions = repetitions;
  sweep.min_time = min_time;
  SweepBlock block;
  block.family = "pipeline";
  block.solvers = against;
  block.solvers.push_back(name);
  block.topologies = topologies;
  block.floating = {false};
  block.n = sizes;
  block.m = {0};
  block.threads = {1};
  sweep.blocks = {block};

  // Register (holding the harness mutex), run without the GIL, unregister.
  SolverEntry entry{name, summary, pythonFactory(shareObject(factory), label), {}};
  HarnessLock lock;
  registerSolver(std::move(entry));
  RegistrationGuard registered(name);
  PythonLogBuffer buffer(log);
  std::ostream out(&buffer);
  SweepStats stats;
  {
    ThreadCountsGuard threads;
    py::gil_scoped_release release;
    stats = runTimingSweep(sweep, Shard{}, path, measureWithGoogleBenchmark, out);
  }
  py::dict result;
  result["measured"] = stats.measured;
  result["skipped"] = stats.skipped;
  result["resumed"] = stats.resumed;
  return result;
}

// Adds root attributes (strings) to a finished result file.
// Without the GIL, as every call here that enters HDF5: a thread inside HDF5 (h5py) may hold
// HDF5's lock while it waits for the GIL (a visititems callback), and waiting for that lock
// with the GIL held deadlocked.
void annotate(const std::string& path, const std::map<std::string, std::string>& attributes) {
  py::gil_scoped_release release;
  const ForksWait forks_wait;
  H5Writer h5 = H5Writer::append(path);
  for (const auto& [key, value] : attributes) h5.setAttribute("/", key, value);
  h5.commit();
}

// (H5Fis_hdf5 enters HDF5: without the GIL, as annotate)
void requireReplaceableHdf5(const std::string& path, const std::string& role) {
  py::gil_scoped_release release;
  const ForksWait forks_wait;
  requireReplaceableByHdf5(path, role);
}

py::dict readPointsPy(const std::string& path) {
  // Without the GIL (as annotate); the child that reads the file first is forked while this
  // thread holds HDF5's lock (isolate.hpp)
  std::map<std::string, PointRecord> points;
  {
    py::gil_scoped_release release;
    const ForksWait forks_wait;
    points = readPoints(path);
  }
  py::dict out;
  for (const auto& [name, record] : points) {
    py::dict d;
    d["attrs"] = record.attrs;
    d["real_time_s"] = py::array_t<double>(record.real_s.size(), record.real_s.data());
    d["parent"] = py::array_t<std::int64_t>(record.parent.size(), record.parent.data());
    out[py::str(name)] = d;
  }
  return out;
}

}  // namespace

void bindHarness(py::module_& m) {
  // Conformance reports.
  py::class_<ConformanceCheck>(m, "ConformanceCheck",
                               "One check of one case: passed = value <= bound.")
      .def_readonly("case", &ConformanceCheck::case_name)
      .def_readonly("check", &ConformanceCheck::check)
      .def_readonly("value", &ConformanceCheck::value)
      .def_readonly("bound", &ConformanceCheck::bound)
      .def_readonly("passed", &ConformanceCheck::passed)
      .def("__repr__", [](const ConformanceCheck& c) {
        std::ostringstream s;
        s << "<" << (c.passed ? "pass" : "FAIL") << " " << c.check << " on " << c.case_name << ": "
          << c.value << " (bound " << c.bound << ")>";
        return s.str();
      });
  py::class_<ConformanceReport>(m, "ConformanceReport", R"doc(
The outcome of minv.check: passed, checks (ConformanceCheck: case, check, value, bound,
passed), skipped and errors ((case, reason) pairs), failures, worst; str() prints the summary
of the C++ suite.)doc")
      .def_readonly("solver", &ConformanceReport::solver)
      .def_property_readonly("passed", &ConformanceReport::passed,
                             "Every check passed, no error, and at least one case ran.")
      .def_property_readonly("failures", &ConformanceReport::failures)
      .def_readonly("checks", &ConformanceReport::checks)
      .def_readonly("skipped", &ConformanceReport::skipped)
      .def_readonly("errors", &ConformanceReport::errors)
      .def_property_readonly(
          "worst",
          [](const ConformanceReport& r) -> py::object {
            const ConformanceCheck* w = r.worst();
            return w ? py::cast(*w) : py::none();
          },
          "The check closest to its bound (value/bound largest), or None.")
      .def("__str__",
           [](const ConformanceReport& r) {
             std::ostringstream s;
             r.print(s);
             std::string text = s.str();
             while (!text.empty() && text.back() == '\n') text.pop_back();
             return text;
           })
      .def("__repr__", [](const ConformanceReport& r) {
        return "<minv.ConformanceReport " + r.solver + ": " + (r.passed() ? "passed" : "FAILED") +
               ", " + std::to_string(r.checks.size()) + " checks>";
      });

  m.def(
      "_check",
      [](const std::string& label, const py::object& factory, Int max_n, bool urdf,
         bool two_threads, bool reconfigure) {
        const ConformanceOptions o = conformanceOptions(max_n, urdf, two_threads, reconfigure);
        return checkWith(label, pythonFactory(shareObject(factory), label), o);
      },
      py::arg("label"), py::arg("factory"), py::arg("max_n") = 300, py::arg("urdf") = true,
      py::arg("two_threads") = true, py::arg("reconfigure") = true);
  m.def(
      "_check_registered",
      [](const std::string& name, Int max_n, bool urdf, bool two_threads, bool reconfigure) {
        const ConformanceOptions o = conformanceOptions(max_n, urdf, two_threads, reconfigure);
        // A copy of the factory: the registry may grow (and move) while the checks run.
        const SolverEntry* e = findSolver(name);
        if (!e) makeSolver(name);
        const SolverFactory make = e->make;
        return checkWith(name, make, o);
      },
      py::arg("name"), py::arg("max_n") = 300, py::arg("urdf") = true,
      py::arg("two_threads") = true, py::arg("reconfigure") = true);

  m.def(
      "_register",
      [](const std::string& name, const std::string& summary, const py::object& factory) {
        if (!PyCallable_Check(factory.ptr())) throw py::type_error("factory must be callable");
        SolverEntry entry{name, summary, pythonFactory(shareObject(factory), name), {}};
        HarnessLock lock;
        registerSolver(std::move(entry));
        pythonNames().insert(name);
      },
      py::arg("name"), py::arg("summary"), py::arg("factory"));
  m.def(
      "_unregister",
      [](const std::string& name) {
        HarnessLock lock;
        pythonNames().erase(name);
        return unregisterSolver(name);
      },
      py::arg("name"));
  m.def("_unregister_python", [] {
    HarnessLock lock;
    for (const std::string& name : pythonNames()) unregisterSolver(name);
    pythonNames().clear();
  });

  m.def("_compare", &compare, py::arg("name"), py::arg("label"), py::arg("summary"),
        py::arg("factory"), py::arg("sizes"), py::arg("topologies"), py::arg("against"),
        py::arg("path"), py::arg("repetitions"), py::arg("min_time"), py::arg("mode"),
        py::arg("log"));
  m.def("_annotate", &annotate, py::arg("path"), py::arg("attributes"));
  m.def("_read_points", &readPointsPy, py::arg("path"));
  m.def("_require_replaceable_hdf5", &requireReplaceableHdf5, py::arg("path"), py::arg("role"));
  m.def("_solver_name_problem", &solverNameProblem, py::arg("name"));
}

}  // namespace minv::python
