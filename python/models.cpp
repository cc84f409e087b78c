// minv._minv, models: the Model class, the generators, model and configuration files, the mass
// matrix (CRBA) and operation counts.
//
// Contract: every function validates its inputs and reports a problem as a Python exception
// with the C++ message (ModelError → minv.ModelError, a ValueError; std::invalid_argument →
// ValueError); a configuration q is checked with Model::checkConfiguration before any
// computation, so a wrong size, a NaN or a zero quaternion gives the `minv` command's message.
// Arrays come back as new numpy arrays (float64; M is (nv, nv)). Paths are str or os.PathLike.
#include <pybind11/eigen.h>
#include <pybind11/numpy.h>
#include <pybind11/stl.h>
#include <pybind11/stl/filesystem.h>

#include <climits>
#include <filesystem>

#include "bindings.hpp"
#include "core/crba.hpp"
#include "core/model.hpp"
#include "experiments/lib/flops.hpp"
#include "generators/centipede.hpp"
#include "generators/model_io.hpp"
#include "generators/random_tree.hpp"

namespace minv::python {

std::uint64_t seedFrom(const py::int_& seed, const char* what) {
  // Negative or wider than 64 bits: a ValueError naming the value.
  const unsigned long long v = PyLong_AsUnsignedLongLong(seed.ptr());
  if (v == static_cast<unsigned long long>(-1) && PyErr_Occurred()) {
    PyErr_Clear();
    throw py::value_error(std::string(what) + " must be an integer in [0, 2**64), got " +
                          py::repr(seed).cast<std::string>());
  }
  return v;
}

Eigen::VectorXd realVector(const py::handle& v, const char* what) {
  const auto reject = [&](const std::string& got) {
    return py::value_error(std::string(what) + " must be a 1-D array of real numbers; got " + got);
  };
  const py::array a = py::array::ensure(v);
  if (!a) throw reject("a " + py::str(py::type::of(v).attr("__name__")).cast<std::string>());
  if (a.dtype().kind() == 'c') throw reject("a complex array");
  using F = py::array_t<double, py::array::forcecast>;
  const F d = F::ensure(a);
  if (!d) throw reject("an array of dtype " + py::str(a.dtype()).cast<std::string>());
  if (d.ndim() != 1) throw reject("an array of " + std::to_string(d.ndim()) + " dimensions");
  Eigen::VectorXd out(d.shape(0));
  for (py::ssize_t i = 0; i < d.shape(0); ++i) out[i] = d.at(i);
  return out;
}

void bindModels(py::module_& m) {
  // The Model: read-only views of the tree.
  py::class_<Model>(m, "Model", R"doc(
A kinematic tree (core/model.hpp): bodies 0 … nb−1 with parents[i] < i (−1 for a root), one
joint per body (revolute, prismatic, spherical, floating). Immutable; made by load_model,
random_tree or centipede.)doc")
      .def_property_readonly("nb", &Model::nb, "Number of bodies.")
      .def_property_readonly("nq", &Model::nq, "Size of a configuration q.")
      .def_property_readonly("nv", &Model::nv, "Degrees of freedom: M is nv × nv.")
      .def_property_readonly("parents", &Model::parents,
                             "Body parent array (list of nb ints, −1 for a root).")
      .def_property_readonly("dof_parent", &Model::dofParent,
                             "DOF parent array (Featherstone's expandLambda; list of nv ints).")
      .def_property_readonly("dof_names", &Model::dofNames, "Names of the nv DOFs.")
      .def_property_readonly("q_names", &Model::qNames,
                             "Names of the nq entries of q (quaternions: <joint>_qw … _qz).")
      .def_property_readonly(
          "body_names",
          [](const Model& model) {
            std::vector<std::string> names;
            for (int i = 0; i < model.nb(); ++i) names.push_back(model.body(i).name);
            return names;
          },
          "Names of the nb bodies.")
      .def_property_readonly(
          "joint_types",
          [](const Model& model) {
            std::vector<std::string> types;
            for (int i = 0; i < model.nb(); ++i)
              types.push_back(jointTypeName(model.joint(i).type));
            return types;
          },
          "Joint type of each body: 'revolute', 'prismatic', 'spherical' or 'floating'.")
      .def_property_readonly("floating_base", &Model::floatingBase,
                             "Whether body 0 is on a floating joint.")
      .def_property_readonly("max_depth", &Model::maxDepth,
                             "Depth of the deepest body (a root has depth 1).")
      .def("neutral", &Model::neutral, "The neutral configuration (zero angles, unit quaternions).")
      .def("check_configuration", &Model::checkConfiguration, py::arg("q"),
           "Raises ModelError if q has the wrong size, a non-finite entry or a zero quaternion.")
      .def("__repr__", [](const Model& model) {
        return "<minv.Model nb=" + std::to_string(model.nb()) +
               " nv=" + std::to_string(model.nv()) + " nq=" + std::to_string(model.nq()) +
               " max_depth=" + std::to_string(model.maxDepth()) +
               (model.floatingBase() ? " floating base>" : " fixed base>");
      });

  // Model files.
  m.def(
      "load_model",
      [](const std::filesystem::path& path, bool floating_base) {
        return loadModel(path.string(), floating_base);
      },
      py::arg("path"), py::arg("floating_base") = false, R"doc(
Reads a model file by extension: .json (minv's format), .urdf, or .xml (MJCF). With
floating_base=True the root body is set free. Raises ModelError naming the file and the
problem.)doc");
  m.def(
      "save_model",
      [](const Model& model, const std::filesystem::path& path) {
        saveModel(model, path.string());
        if (const std::string note = floatingUrdfNote(model, path.string()); !note.empty())
          py::module_::import("warnings").attr("warn")(note);
      },
      py::arg("model"), py::arg("path"),
      "Writes a model file by extension (.json or .urdf), atomically. URDF has no floating "
      "joint: a floating base is dropped (a warning says so; load_model(path, "
      "floating_base=True) sets the root free again).");
  // (for minv.compare, which renames its sweep over its output itself)
  m.def(
      "_require_output_file",
      [](const std::filesystem::path& path) { requireOutputFile(path.string()); }, py::arg("path"));

  // Generators.
  m.def(
      "random_tree",
      [](const std::string& topology, Int n, const py::int_& seed, bool floating_base,
         const std::string& joints) {
        TreeOptions o;
        o.topology = topologyFromName(topology);
        o.joints = jointSetFromName(joints);
        o.n = n;
        o.seed = seedFrom(seed);
        o.floating_base = floating_base;
        return randomTree(o);
      },
      py::arg("topology"), py::arg("n"), py::arg("seed") = 1, py::arg("floating_base") = false,
      py::arg("joints") = "revolute", R"doc(
A random tree of n jointed links (generators/random_tree.hpp): topology 'serial' or
'branched' (the paper's rule), joints 'revolute' or 'mixed'; floating_base adds a free base
body. Deterministic in the seed.)doc");
  m.def(
      "centipede",
      [](Int segments, const std::string& segment_joint) {
        CentipedeOptions o;
        o.segments = segments;
        o.segment_joint = segmentJointFromName(segment_joint);
        return makeCentipede(o).model;
      },
      py::arg("segments"), py::arg("segment_joint") = "yaw",
      "The paper's centipede (§6.3): `segments` body segments on a floating base, two legs each.");

  // Configurations.
  m.def(
      "random_configuration",
      [](const Model& model, const py::int_& seed) {
        return randomConfiguration(model, seedFrom(seed));
      },
      py::arg("model"), py::arg("seed") = 1,
      "A seeded random configuration q (angles in [−π, π), unit quaternions).");
  m.def(
      "read_configuration",
      [](const Model& model, const std::filesystem::path& path) {
        return loadConfiguration(model, path.string());
      },
      py::arg("model"), py::arg("path"),
      "Reads q from a text file: nq numbers, or 'name value' lines (see Model.q_names).");

  // The mass matrix.
  m.def(
      "mass_matrix",
      [](const Model& model, const py::object& q_object) {
        const Eigen::VectorXd q = realVector(q_object, "q");
        model.checkConfiguration(q);
        py::gil_scoped_release release;
        return massMatrix(model, q);
      },
      py::arg("model"), py::arg("q"),
      "The joint-space inertia matrix M(q) by CRBA: a symmetric positive definite (nv, nv) array.");

  // Operation counts (the GIL stays held: the counters are per thread, reset per count).
  m.def(
      "flops",
      [](const std::string& name, const Model& model, const py::object& q_object, Int m_arg) {
        const int m = m_arg;
        // (As `minv flops --rhs`: the counted run holds dense nv × m matrices.)
        if (m < 0 || m > 100000)
          throw py::value_error("m must be between 0 and 100000, got " + std::to_string(m));
        const Eigen::VectorXd q = realVector(q_object, "q");
        model.checkConfiguration(q);
        py::dict out;
        for (const StageCount& s : countSolver(name, model, q, m)) {
          py::dict d;
          d["mul"] = s.counts.mul;
          d["add"] = s.counts.add;
          d["div"] = s.counts.div;
          d["sqrt"] = s.counts.sqrt;
          d["cmp"] = s.counts.cmp;
          d["trig"] = s.counts.trig;
          d["flops"] = s.counts.flops();
          d["documented"] = s.documented;
          out[py::str(s.stage)] = d;
        }
        return out;
      },
      py::arg("name"), py::arg("model"), py::arg("q"), py::arg("m") = 0, R"doc(
Operation counts of a registered solver from q to M⁻¹ (m = 0) or to M⁻¹R with m columns, per
stage: {stage: {"mul", "add", "div", "sqrt", "cmp", "trig": int, "flops": int (all but cmp),
"documented": bool (LAPACK's documented counts rather than measured ones)}}. ValueError for a
solver that cannot be counted.)doc");
}

}  // namespace minv::python
