#include "experiments/lib/accuracy.hpp"

#include <omp.h>

#include <Eigen/Cholesky>
#include <Eigen/Core>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <memory>
#include <optional>
#include <stdexcept>

#include "core/articulated.hpp"
#include "core/articulated_joint.hpp"
#include "core/crba.hpp"
#include "core/impulse_sweeps.hpp"
#include "core/kinematics.hpp"
#include "experiments/lib/budget.hpp"
#include "experiments/lib/h5reader.hpp"
#include "experiments/lib/h5writer.hpp"
#include "experiments/lib/provenance.hpp"
#include "generators/random_tree.hpp"
#include "solvers/openblas.hpp"
#include "solvers/solver.hpp"

namespace minv {

AccuracySweep accuracySweep(const std::string& mode) {
  AccuracySweep s;
  s.mode = mode;
  if (mode == "quick")
    s.n = {16, 64, 256, 1024, 2048};
  else if (mode == "full")
    s.n = {16, 32, 64, 128, 256, 512, 1024, 2048, 4096};
  else if (mode == "tiny")
    s.n = {8, 16};
  else
    throw std::invalid_argument("unknown sweep mode '" + mode + "' (expected quick, full or tiny)");
  return s;
}

namespace {

// λ_max of a symmetric positive (semi)definite matrix by power iteration.
template <class Mat>
double lambdaMax(const Mat& A, int iterations = 300) {
  using S = typename Mat::Scalar;
  VecX<S> v = VecX<S>::Ones(A.rows()) / std::sqrt(static_cast<S>(A.rows()));
  S lambda = 0;
  for (int k = 0; k < iterations; ++k) {
    VecX<S> w = A * v;
    lambda = v.dot(w);
    const S norm = w.norm();
    if (!(norm > 0)) break;
    v = w / norm;
  }
  return static_cast<double>(lambda);
}

// The unit roundoffs of long double (x87, 64-bit mantissa) and double.
constexpr double kUnitLong = 0x1.0p-64, kUnitDouble = 0x1.0p-53;

}  // namespace

// X_ref = M⁻¹ at q by the impulse sweeps in long double on the pass about each joint's
// origin, checked against M by long-double CRBA (residual) and long-double CRBA + Cholesky; its
// error estimated from the same pipeline in double.
AccuracyReference accuracyReference(const Model& model, const Eigen::VectorXd& q) {
  AccuracyReference r;
  const int nv = model.nv();
  r.M = massMatrix(model, q);
  // The impulse sweeps in long double, from long-double kinematics and articulated inertias
  // about each joint's origin (core/articulated_joint.hpp).
  Kinematics<long double> kin(model, Origin::EachRoot);
  computeKinematics<long double>(model, q.cast<long double>(), kin);
  {
    Articulated<long double> art(model);
    JointArticulatedWorkspace<long double> ws(model);
    articulatedInertiasAtJoints<long double>(model, kin, art, ws);
    r.Xref.resize(nv, nv);
    referenceInverse<long double>(model, kin, art, r.Xref);
  }
  const long double ref_norm = r.Xref.norm();
  r.cond = lambdaMax(r.M) * lambdaMax(Eigen::MatrixXd(r.Xref.cast<double>()));
  // The check: long-double CRBA + Cholesky, an independent method whose own error is about
  // cond₂(M)·u; a larger difference means that one of the two is wrong.
  {
    std::vector<Mat6<long double>> Ic(model.nb());
    MatX<long double> Ml(nv, nv);
    crba<long double>(model, kin, Ic, Ml);
    Eigen::LLT<MatX<long double>> llt(Ml);
    if (llt.info() != Eigen::Success) throw std::runtime_error("long-double Cholesky failed");
    const MatX<long double> Xchol = llt.solve(MatX<long double>::Identity(nv, nv));
    r.cholesky = static_cast<double>((Xchol - r.Xref).norm() / ref_norm);
    // The precision: X_ref's residual against this M, as of a long-double inverse (the
    // world-frame sweeps in double leave 1e-18 to 1e-17, 18u and more).
    const MatX<long double> R = Ml * r.Xref - MatX<long double>::Identity(nv, nv);
    r.residual = static_cast<double>(R.norm() / (Ml.norm() * ref_norm));
  }
  // A check that fails names both figures.
  auto fail = [](const char* what, double value, const char* bound_name, double bound) {
    char line[240];
    std::snprintf(line, sizeof line, "accuracy reference: %s = %.2e, beyond %s = %.2e", what, value,
                  bound_name, bound);
    throw std::runtime_error(line);
  };
  if (!(r.residual <= 16 * kUnitLong))
    fail("‖M X_ref − I‖/(‖M‖‖X_ref‖) with M by long-double CRBA (not a long-double inverse)",
         r.residual, "16u", 16 * kUnitLong);
  if (!(r.cholesky <= 16 * r.cond * kUnitLong))
    fail("the difference of the long-double impulse sweeps and Cholesky", r.cholesky,
         "16·cond₂(M)·u", 16 * r.cond * kUnitLong);
  // The estimate: the same pipeline in double, its error against X_ref scaled by the ratio of
  // the unit roundoffs (2⁻¹¹).
  {
    Kinematics<double> kd(model, Origin::EachRoot);
    computeKinematics<double>(model, q, kd);
    Articulated<double> ad(model);
    JointArticulatedWorkspace<double> ws(model);
    articulatedInertiasAtJoints<double>(model, kd, ad, ws);
    Eigen::MatrixXd Xd(nv, nv);
    referenceInverse<double>(model, kd, ad, Xd);
    const double ed = static_cast<double>((Xd.cast<long double>() - r.Xref).norm() / ref_norm);
    r.estimate = ed * (kUnitLong / kUnitDouble);
  }
  return r;
}

void runAccuracySweep(const AccuracySweep& sweep, const std::string& path, std::ostream& log) {
  openblas_set_num_threads(1);
  omp_set_num_threads(1);
  // Resumed points must have been made from the same trees, and measured against the same
  // reference, as this run's.
  const char* reference =
      "the impulse sweeps (core/impulse_sweeps.hpp, referenceInverse) on articulated inertias "
      "about each joint's origin (core/articulated_joint.hpp), in long double (x87 80-bit, "
      "64-bit mantissa; every derived constant in long double), checked against M by "
      "long-double CRBA (residual) and long-double CRBA + Eigen::LLT";
  requireSameSettings(path, "output file",
                      {{"experiment", "accuracy"},
                       {"mode", sweep.mode},
                       {"seed", sweep.seed},
                       {"reference", reference}});
  H5Writer h5 = H5Writer::append(path);
  h5.setAttribute("/", "experiment", "accuracy");
  h5.setAttribute("/", "mode", sweep.mode);
  h5.setAttribute("/", "seed", sweep.seed);
  h5.setAttribute("/", "reference", reference);
  writeProvenance(h5, "/");
  h5.createGroup("points");
  h5.createGroup("problems");
  h5.flush();
  const std::vector<std::string> solvers = solverNames();
  for (const std::string& topo : sweep.topologies) {
    for (int n : sweep.n) {
      char tag[48];
      std::snprintf(tag, sizeof tag, "%s.n%05d", topo.c_str(), n);
      const std::string problem = std::string("problems/") + tag;
      bool all_done = h5.hasGroup(problem);
      for (const std::string& s : solvers)
        all_done &= h5.hasGroup("points/" + std::string(tag) + "." + s);
      if (all_done) continue;
      const Model model = randomTree({topologyFromName(topo), n, sweep.seed, false});
      const Eigen::VectorXd q = randomConfiguration(model, sweep.seed);
      const int nv = model.nv();
      const auto t0 = std::chrono::steady_clock::now();
      const AccuracyReference ref = accuracyReference(model, q);
      const double ref_s =
          std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      {
        char line[200];
        std::snprintf(line, sizeof line,
                      "%s reference: cond %.2e, own error about %.1e, Cholesky differs by %.1e, "
                      "residual %.1e (%.1f s)",
                      tag, ref.cond, ref.estimate, ref.cholesky, ref.residual, ref_s);
        log << line << std::endl;
      }
      if (!h5.hasGroup(problem)) {
        const std::string g = h5.beginPoint(problem);
        h5.setAttribute(g, "topology", topo);
        h5.setAttribute(g, "n", n);
        h5.setAttribute(g, "nv", nv);
        h5.setAttribute(g, "seed", sweep.seed);
        h5.setAttribute(g, "cond", ref.cond);
        h5.setAttribute(g, "reference_seconds", ref_s);
        h5.setAttribute(g, "reference_error_estimate", ref.estimate);
        h5.setAttribute(g, "reference_cholesky_difference", ref.cholesky);
        h5.setAttribute(g, "reference_residual", ref.residual);
        h5.writeIntVector(g + "/parent", model.parents());
        h5.endPoint(problem);
      }
      const long double ref_norm = ref.Xref.norm();
      const double m_norm = ref.M.norm();
      for (const std::string& s : solvers) {
        const std::string name = "points/" + std::string(tag) + "." + s;
        if (h5.hasGroup(name)) continue;
        std::unique_ptr<Solver> solver = makeSolver(s);
        std::string why;
        std::optional<std::string> skip = skipReason(s, "accuracy", topo, n, sweep.mode);
        if (!skip && !solver->supports(model, &why))
          skip = "solver does not support the tree: " + why;
        const std::string g = h5.beginPoint(name);
        h5.setAttribute(g, "family", "accuracy");
        h5.setAttribute(g, "solver", s);
        h5.setAttribute(g, "topology", topo);
        h5.setAttribute(g, "n", n);
        h5.setAttribute(g, "nv", nv);
        h5.setAttribute(g, "cond", ref.cond);
        h5.setAttribute(g, "reference_error_estimate", ref.estimate);
        char line[160];
        if (skip) {
          h5.setAttribute(g, "status", "skipped");
          h5.setAttribute(g, "skipped", *skip);
          h5.endPoint(name);
          log << tag << " " << s << " skipped: " << *skip << std::endl;
          continue;
        }
        solver->prepare(model);
        solver->setThreads(1);
        solver->configure(q);
        Eigen::MatrixXd X(nv, nv);
        solver->inverse(X);
        const double defect = (ref.M * X - Eigen::MatrixXd::Identity(nv, nv)).norm();
        const double residual = defect / (m_norm * X.norm());
        const double residual_identity = defect / std::sqrt(static_cast<double>(nv));
        const double error =
            static_cast<double>((X.cast<long double>() - ref.Xref).norm() / ref_norm);
        h5.setAttribute(g, "status", "ok");
        h5.setAttribute(g, "residual", residual);
        h5.setAttribute(g, "residual_identity", residual_identity);
        h5.setAttribute(g, "error", error);
        h5.endPoint(name);
        std::snprintf(line, sizeof line,
                      "%s %-7s cond %.2e residual %.2e residual_I %.2e error %.2e", tag, s.c_str(),
                      ref.cond, residual, residual_identity, error);
        log << line << std::endl;
      }
    }
  }
  h5.commit();
}

}  // namespace minv
