#include "solvers/conformance.hpp"

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>
#include <mutex>
#include <sstream>

#include "core/crba.hpp"
#include "generators/model_io.hpp"

namespace minv {

namespace {

// 11 right-hand sides: more than abi's half-width block (8 of its 16 lanes), so M⁻¹R takes its
// full-width path with a partial block, and the first column alone its one-lane path.
constexpr int kRhsColumns = 11;

double rel(const Eigen::MatrixXd& a, const Eigen::MatrixXd& b) {
  // (stableNorm: entries of M⁻¹ reach 1e300 where masses are 1e-300)
  return (a - b).stableNorm() / std::max(b.stableNorm(), 1e-300);
}

// The case's trees side by side, each body's parent renumbered (roots stay −1), masses and
// inertias times the case's scale (and its alternating factor), joints made spherical where
// the case says so.
Model forest(const ConformanceCase& c) {
  std::vector<int> parent;
  std::vector<Joint> joints;
  std::vector<Body> bodies;
  std::vector<TreeOptions> trees = {c.options};
  trees.insert(trees.end(), c.beside.begin(), c.beside.end());
  for (std::size_t k = 0; k < trees.size(); ++k) {
    const Model t = randomTree(trees[k]);
    const int offset = static_cast<int>(parent.size());
    for (int i = 0; i < t.nb(); ++i) {
      parent.push_back(t.parent(i) < 0 ? -1 : t.parent(i) + offset);
      joints.push_back(t.joint(i));
      joints.back().name += "_t" + std::to_string(k);
      if (c.spherical && joints.back().type != JointType::Floating)
        joints.back().type = JointType::Spherical;
      bodies.push_back(t.body(i));
      bodies.back().name += "_t" + std::to_string(k);
      const double scale = c.mass_scale * (i % 2 == 0 ? c.alternate : 1 / c.alternate);
      bodies.back().mass *= scale;
      bodies.back().inertia *= scale;
    }
  }
  return Model::create(std::move(parent), std::move(joints), std::move(bodies));
}

Model buildModel(const ConformanceCase& c) {
  const bool plain = c.beside.empty() && c.mass_scale == 1 && !c.spherical && c.alternate == 1;
  Model m = plain ? randomTree(c.options) : forest(c);
  if (!c.via_urdf) return m;
  std::ostringstream xml;
  writeUrdf(m, xml, c.name);
  return readUrdf(xml.str(), c.name + ".urdf", c.options.floating_base);
}

double condition(const Eigen::MatrixXd& M) {
  const Eigen::VectorXd ev = Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(M).eigenvalues();
  return ev.maxCoeff() / ev.minCoeff();
}

double bound(double n, double kappa) {
  return 10 * (n + 10) * kappa * std::numeric_limits<double>::epsilon();
}

}  // namespace

std::vector<ConformanceCase> conformanceCases(const ConformanceOptions& options) {
  std::vector<ConformanceCase> out;
  for (int n : {1, 2, 3, 7, 32, 100, 300}) {
    if (n > options.max_n) continue;
    for (Topology t : {Topology::Serial, Topology::Branched})
      for (bool floating : {false, true})
        for (JointSet j : {JointSet::Revolute, JointSet::Mixed}) {
          TreeOptions o{t, n, static_cast<std::uint64_t>(1000 + n), floating, j};
          std::string name = std::string(topologyName(t)) + "_" + jointSetName(j) +
                             (floating ? "_floating" : "_fixed") + "_n" + std::to_string(n);
          out.push_back({name, o, false});
          // URDF carries 1-DOF joints: round-trip the revolute trees through it.
          if (options.urdf && j == JointSet::Revolute && n <= 100)
            out.push_back({name + "_urdf", o, true});
        }
  }
  // Forests: a floating mixed serial tree beside a fixed revolute branched one (n = 32: 21 + 11
  // links; n = 300: 200 + 100, enough DOFs for abi's two threads).
  for (int n : {32, 300}) {
    if (n > options.max_n) continue;
    const int first = n * 2 / 3;
    const auto seed = static_cast<std::uint64_t>(2000 + n);
    TreeOptions a{Topology::Serial, first, seed, true, JointSet::Mixed};
    TreeOptions b{Topology::Branched, n - first, seed + 1, false, JointSet::Revolute};
    out.push_back({"forest_mixed_floating_n" + std::to_string(n), a, false, {b}});
  }
  // Masses of 1e-200 and 1e-300 (kg; inertias alike): chains, where runs of links regroup D
  if (options.max_n >= 32) {
    out.push_back({"serial_mixed_floating_n32_mass1e-200",
                   {Topology::Serial, 32, 3032, true, JointSet::Mixed},
                   false,
                   {},
                   1e-200});
    out.push_back({"serial_revolute_fixed_n32_mass1e-300",
                   {Topology::Serial, 32, 3033, false, JointSet::Revolute},
                   false,
                   {},
                   1e-300});
  }
  // Spherical chains, heavy and light in turn (masses 1e3 and 1e-3 of the generator's): a
  // light body's D is nearly singular
  if (options.max_n >= 8)
    for (bool floating : {false, true}) {
      ConformanceCase c{
          std::string("serial_spherical_alternating_") + (floating ? "floating" : "fixed") + "_n8",
          {Topology::Serial, 8, 3040, floating, JointSet::Mixed}};
      c.spherical = true;
      c.alternate = 1e3;
      c.limits = {{"bullet",
                   "bullet: Bullet 3.24's articulated-body pass multiplies by each ball joint's "
                   "explicit D⁻¹, which loses about cond(D)·ε where a light body sits between "
                   "heavy ones (|MX − I| 9.9e-4 and 4.5e-3 here, bounds 1.1e-4 and 2.9e-4)"}};
      out.push_back(c);
    }
  return out;
}

const ConformanceProblem& conformanceProblem(const ConformanceCase& c) {
  static std::mutex mutex;
  static std::map<std::string, std::unique_ptr<ConformanceProblem>> memo;
  std::lock_guard<std::mutex> lock(mutex);
  auto it = memo.find(c.name);
  if (it != memo.end()) return *it->second;
  auto p = std::make_unique<ConformanceProblem>(buildModel(c));
  const int n = p->model.nv();
  // Two seeded configurations, M at each from CRBA, and the dense reference inverse.
  p->q = randomConfiguration(p->model, c.options.seed + 7);
  p->q2 = randomConfiguration(p->model, c.options.seed + 8);
  p->M = massMatrix(p->model, p->q);
  p->M2 = massMatrix(p->model, p->q2);
  p->Xref = p->M.llt().solve(Eigen::MatrixXd::Identity(n, n));
  p->kappa = condition(p->M);
  p->kappa2 = condition(p->M2);
  p->tol = bound(n, p->kappa);
  p->tol2 = bound(n, p->kappa2);
  // Seeded right-hand sides, deterministic on every platform.
  p->R = Eigen::MatrixXd::NullaryExpr(n, kRhsColumns, [](Eigen::Index i, Eigen::Index j) {
    return std::sin(1.0 + 3.0 * static_cast<double>(i) + 7.0 * static_cast<double>(j));
  });
  return *memo.emplace(c.name, std::move(p)).first->second;
}

void checkCase(const SolverFactory& make, const ConformanceCase& c, ConformanceReport& report,
               const ConformanceOptions& options) {
  const ConformanceProblem& p = conformanceProblem(c);
  const int n = p.model.nv();
  auto add = [&](const std::string& check, double value, double bound) {
    report.checks.push_back({c.name, check, value, bound, value <= bound});  // NaN fails
  };
  for (const auto& [solver, why] : c.limits)
    if (solver == report.solver) {
      report.skipped.emplace_back(c.name, why);
      return;
    }
  try {
    std::unique_ptr<Solver> s = make();
    std::string why;
    if (!s->supports(p.model, &why)) {
      report.skipped.emplace_back(c.name, why.empty() ? "not supported" : why);
      return;
    }
    // One thread: M⁻¹, M⁻¹R for 11 columns and for one.
    s->setThreads(1);
    s->prepare(p.model);
    s->configure(p.q);
    Eigen::MatrixXd X(n, n), Y(n, kRhsColumns), Y1(n, 1);
    X.setConstant(std::numeric_limits<double>::quiet_NaN());  // every entry must be written
    s->inverse(X);
    s->solve(p.R, Y);
    s->solve(p.R.leftCols(1), Y1);
    const Eigen::MatrixXd I = Eigen::MatrixXd::Identity(n, n);
    const double nan = std::numeric_limits<double>::quiet_NaN();
    const bool finite = X.allFinite() && Y.allFinite() && Y1.allFinite();
    add("finite", finite ? 0 : nan, 0);
    add("inverse |MX-I|", rel(p.M * X, I), p.tol);
    // Each triangle on its own against the reference: independent of any mirroring.
    const Eigen::MatrixXd upper = X.triangularView<Eigen::Upper>();
    const Eigen::MatrixXd lower = X.triangularView<Eigen::Lower>();
    add("upper triangle vs dense inverse",
        rel(upper, Eigen::MatrixXd(p.Xref.triangularView<Eigen::Upper>())), 2 * p.tol);
    add("lower triangle vs dense inverse",
        rel(lower, Eigen::MatrixXd(p.Xref.triangularView<Eigen::Lower>())), 2 * p.tol);
    add("symmetric", rel(X, X.transpose()), p.tol);
    // The upper triangle alone (inverseUpper), the rest left unwritten, against the reference.
    Eigen::MatrixXd U(n, n);
    U.setConstant(nan);
    s->inverseUpper(U);
    add("inverseUpper vs dense inverse",
        rel(Eigen::MatrixXd(U.triangularView<Eigen::Upper>()),
            Eigen::MatrixXd(p.Xref.triangularView<Eigen::Upper>())),
        2 * p.tol);
    add("solve(R) vs X R", rel(Y, X * p.R), p.tol);
    add("solve(r) one column", rel(Y1, X * p.R.leftCols(1)), p.tol);
    // A second configuration: the solver must recompute, not return a cached result.
    if (options.reconfigure) {
      Eigen::MatrixXd X2(n, n);
      s->configure(p.q2);
      s->inverse(X2);
      add("reconfigure |M2 X2 - I|", rel(p.M2 * X2, I), p.tol2);
    }
    // Two threads (where a solver uses them: abi's column blocks run in parallel).
    if (options.two_threads) {
      std::unique_ptr<Solver> t = make();
      t->setThreads(2);
      t->prepare(p.model);
      t->configure(p.q);
      Eigen::MatrixXd Xt(n, n), Yt(n, kRhsColumns);
      t->inverse(Xt);
      t->solve(p.R, Yt);
      add("2 threads: inverse", rel(p.M * Xt, I), p.tol);
      add("2 threads: symmetric", rel(Xt, Xt.transpose()), p.tol);
      // The upper triangle alone on two threads, into a block of a larger matrix (a strided
      // output whose lower part and border stay unwritten).
      Eigen::MatrixXd big(n + 3, n + 2);
      big.setConstant(nan);
      Eigen::Ref<Eigen::MatrixXd> Ub = big.block(1, 1, n, n);
      t->inverseUpper(Ub);
      add("2 threads: inverseUpper into a block vs dense inverse",
          rel(Eigen::MatrixXd(Ub.triangularView<Eigen::Upper>()),
              Eigen::MatrixXd(p.Xref.triangularView<Eigen::Upper>())),
          2 * p.tol);
      add("2 threads: |M solve(R) - R|", rel(p.M * Yt, p.R), p.tol);
      // A second configuration on the same solver (abi keeps a copy per thread: every copy
      // must move to it).
      if (options.reconfigure) {
        Eigen::MatrixXd X2t(n, n);
        t->configure(p.q2);
        t->inverse(X2t);
        add("2 threads: reconfigure |M2 X2 - I|", rel(p.M2 * X2t, I), p.tol2);
      }
      // Threads changed after configure: the configuration carries over (abi reallocates its
      // per-thread copies).
      const Eigen::MatrixXd& Mlast = options.reconfigure ? p.M2 : p.M;
      const double tolLast = options.reconfigure ? p.tol2 : p.tol;
      Eigen::MatrixXd Xs(n, n);
      t->setThreads(1);
      t->inverse(Xs);
      add("setThreads(1) after configure |MX - I|", rel(Mlast * Xs, I), tolLast);
      t->setThreads(2);
      t->inverse(Xs);
      add("setThreads(2) after configure |MX - I|", rel(Mlast * Xs, I), tolLast);
    }
  } catch (const std::exception& e) {
    report.errors.emplace_back(c.name, e.what());
  }
}

ConformanceReport checkSolver(const std::string& label, const SolverFactory& make,
                              const ConformanceOptions& options) {
  ConformanceReport report;
  report.solver = label;
  for (const ConformanceCase& c : conformanceCases(options)) checkCase(make, c, report, options);
  return report;
}

ConformanceReport checkSolver(const std::string& name, const ConformanceOptions& options) {
  const SolverEntry* e = findSolver(name);
  if (!e) makeSolver(name);            // throws with the list of known names
  const SolverFactory make = e->make;  // a copy: a later registerSolver() may move the entry
  return checkSolver(name, make, options);
}

bool ConformanceReport::passed() const {
  return failures() == 0 && errors.empty() && !checks.empty();
}

int ConformanceReport::failures() const {
  return static_cast<int>(std::count_if(checks.begin(), checks.end(),
                                        [](const ConformanceCheck& c) { return !c.passed; }));
}

const ConformanceCheck* ConformanceReport::worst() const {
  const ConformanceCheck* w = nullptr;
  double worst_ratio = -1;
  for (const ConformanceCheck& c : checks) {
    const double r = c.bound > 0 ? c.value / c.bound : (c.value > 0 || !c.passed ? 1e300 : 0);
    const double key = std::isnan(r) ? 1e300 : r;
    if (key > worst_ratio) worst_ratio = key, w = &c;
  }
  return w;
}

void ConformanceReport::print(std::ostream& out, int max_failures) const {
  std::size_t cases = 0;
  {
    std::vector<std::string> names;
    for (const ConformanceCheck& c : checks) names.push_back(c.case_name);
    std::sort(names.begin(), names.end());
    cases = std::unique(names.begin(), names.end()) - names.begin();
  }
  out << "conformance of " << solver << ": " << (passed() ? "PASSED" : "FAILED") << ", " << cases
      << " cases, " << checks.size() - failures() << "/" << checks.size() << " checks passed, "
      << skipped.size() << " skipped, " << errors.size() << " errors\n";
  char buf[256];
  if (const ConformanceCheck* w = worst()) {
    std::snprintf(buf, sizeof buf, "  worst: %s on %s: %.3g (bound %.3g)\n", w->check.c_str(),
                  w->case_name.c_str(), w->value, w->bound);
    out << buf;
  }
  int shown = 0;
  for (const ConformanceCheck& c : checks)
    if (!c.passed && shown++ < max_failures) {
      std::snprintf(buf, sizeof buf, "  FAIL %s on %s: %.3g > %.3g\n", c.check.c_str(),
                    c.case_name.c_str(), c.value, c.bound);
      out << buf;
    }
  for (const auto& [name, what] : errors) out << "  ERROR on " << name << ": " << what << "\n";
  if (!skipped.empty())
    out << "  skipped " << skipped.size() << " cases, e.g. " << skipped.front().first << ": "
        << skipped.front().second << "\n";
}

std::string testNameOf(const std::string& text) {
  std::string out = text;
  for (char& ch : out)
    if (!std::isalnum(static_cast<unsigned char>(ch))) ch = '_';
  return out;
}

}  // namespace minv
