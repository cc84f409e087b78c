// The `minv` command (runCli, experiments/lib/cli.hpp): generate random trees, invert their
// joint-space inertia matrix M with every registered solver, check a solver's conformance,
// count operations, time sweeps, simulate, and list the solvers.
//
//   minv generate --topology serial|branched --n N [--seed S] [--floating-base]
//                 [--joints revolute|mixed] --out FILE.json|FILE.urdf
//   minv solve --model FILE [--free-root] [--solver NAME|all] [--q-seed S | --q FILE]
//              [--rhs M] [--rhs-seed S] --out FILE.h5
//   minv generate --topology centipede --segments S [--segment-joint yaw|spherical] --out FILE
//   minv simulate centipede [--segments S] [--steps K] [--dt H]
//                           [--solver NAME|test-impulse|contact-inertia|mujoco-step]
//                 [--threads T] [--frames F] [--segment-joint yaw|spherical]
//                 [--out FILE.h5]   (sim/)
//   minv simulate sweep [--segments 5,10,20,40]
//                       [--solvers abi,lapack,ltdl,test-impulse,contact-inertia]
//                 [--steps K] [--dt H] [--threads T] --out FILE.h5   (Figure 4; appended to
//                 and resumed; mujoco-step is a path too, not among the defaults; with T > 1
//                 the points are named <path>@T)
//   minv solvers
//   minv check [--solver NAME|all] [--max-n N]   (solvers/conformance.hpp; exit 1 if a check
//              fails)
//   minv time [--mode quick|full|tiny] [--solvers A,B] [--shard i/N] [--min-time S]
//             [--repetitions R] [--list] --out FILE.h5   (the timing sweeps of Figures 2 and 3,
//             Google Benchmark; appended to and resumed; experiments/lib/timing.hpp)
//   minv flops [--solver NAME|all] --topology serial|branched --n N [--floating-base]
//              [--joints revolute|mixed] [--rhs M] [--seed S]
//   minv experiment flops [--max-n N] [--seed S] --out FILE.h5
//   minv experiment accuracy [--mode quick|full|tiny] --out FILE.h5 (experiments/lib/accuracy.hpp)
//   minv merge --out FILE.h5 SHARD.h5…   (join timing shard files; experiments/lib/timing.hpp)
// (build/bench_timing is the same as `minv time`.)
//
// Contract: success exits 0. Every failure (bad or missing options, an unreadable or invalid
// model or configuration file, an unknown solver, a solver error, a non-finite residual, an
// I/O error) prints one line "minv: error: <message>" to stderr and exits 2. A command that
// writes one result file (generate, solve, simulate centipede, experiment flops, merge)
// leaves no output file on failure: it writes FILE.tmp and renames it only on success. The
// sweeps (experiment accuracy, simulate sweep, time) append point by point to their file, so
// a failure keeps the points finished before it (a rerun resumes). `check` exits 1 when a
// conformance check fails.
// `--help` on any subcommand prints its help and exits 0.
//
// solve: q = randomConfiguration(model, q_seed), or read from --q FILE (generators/
// model_io.hpp: readConfiguration); M from CRBA; for each solver prepare,
// configure(q), inverse → Minv, relative residual ‖M·Minv − 1‖_F / (‖M‖_F ‖Minv‖_F) (the
// normalisation of LAPACK's dpot03 test: backward-stable methods reach a few n·ε whatever
// cond(M) is), residual_identity ‖M·Minv − 1‖_F / √nv (which grows with cond₂(M), also stored,
// as cond), time = median of 5 repetitions
// of configure + inverse (a sanity figure; the timing harness is Google Benchmark). With
// --rhs m > 0 also solve(R) for R (nv×m, entries uniform in [−1, 1) from Rng(rhs_seed), filled
// column by column), solve_residual = ‖solve(R) − Minv·R‖_F / ‖Minv·R‖_F.
// HDF5 layout: root datasets q, M, dof_names, parent (DOF parent array), body_parent, and for
// a floating base base_position (3) and base_quaternion (4, w x y z); root attributes model,
// nv, nq, nb, max_depth, topology, q_seed, rhs, rhs_seed and the provenance
// (experiments/lib/provenance.hpp); per solver a group /solvers/<name> with dataset Minv and
// attributes summary, residual, residual_identity, time_s, repetitions and (with --rhs)
// solve_residual; the root also holds cond, cond₂(M) from its eigenvalues (inf beyond the
// double range, e.g. a mass of 1e-300 beside 1e30), and cond_log10, its log10 (finite there).
// A solver that does not support the tree is skipped under `all` (its group holds only
// `skipped`, the reason) and is an error when named.
#include "experiments/lib/cli.hpp"

#include <CLI/CLI.hpp>
#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <charconv>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <limits>
#include <new>
#include <stdexcept>
#include <string>
#include <vector>

#include "core/crba.hpp"
#include "experiments/lib/accuracy.hpp"
#include "experiments/lib/centipede_run.hpp"
#include "experiments/lib/flops.hpp"
#include "experiments/lib/gbench.hpp"
#include "experiments/lib/h5reader.hpp"
#include "experiments/lib/h5writer.hpp"
#include "experiments/lib/output_matrix.hpp"
#include "experiments/lib/provenance.hpp"
#include "experiments/lib/timing.hpp"
#include "generators/centipede.hpp"
#include "generators/model_io.hpp"
#include "generators/random_tree.hpp"
#include "solvers/conformance.hpp"
#include "solvers/solver.hpp"

namespace minv {
namespace {

constexpr int kErrorExit = 2;
constexpr int kRepetitions = 5;

// Upper bounds of the sizes a user gives: far beyond any research use, and each well before
// memory runs out (past them a command would only end in "out of memory").
constexpr int kMaxLinks = kMaxTreeLinks;             // generate --n (generators/random_tree.hpp)
constexpr int kMaxCountedLinks = 16384;              // flops --n, experiment flops --max-n (as n²)
constexpr int kMaxSegments = kMaxCentipedeSegments;  // generators/centipede.hpp
constexpr int kMaxRhs = 100000;                      // --rhs columns
constexpr int kMaxRepetitions = 1000;                // time --repetitions
constexpr double kMaxMinTime = 3600;                 // time --min-time, seconds

// What the command is allocating, named in an "out of memory" message.
std::string& allocating() {
  static std::string what;
  return what;
}

// Print "<program>: error: <message>" as a single line and give the error exit status.
int reportError(const std::string& program, std::string message) {
  std::replace(message.begin(), message.end(), '\n', ' ');
  std::cerr << program << ": error: " << message << std::endl;
  return kErrorExit;
}

// A CLI11 check for seeds and counts: a plain integer from 0 to `max` (no sign, no
// wrap-around, no clamping to the type's largest value).
CLI::Validator nonNegative(std::uint64_t max) {
  return CLI::Validator(
      [max](std::string& value) -> std::string {
        const std::string range = "an integer from 0 to " + std::to_string(max);
        if (value.empty() || value.find_first_not_of("0123456789") != std::string::npos)
          return "expected " + range + ", got '" + value + "'";
        std::uint64_t v = 0;
        for (const char c : value) {
          const unsigned digit = static_cast<unsigned>(c - '0');
          if (v > (max - digit) / 10) return "expected " + range + ", got '" + value + "'";
          v = 10 * v + digit;
        }
        return {};
      },
      "", "non-negative integer");
}
const CLI::Validator kSeed = nonNegative(std::numeric_limits<std::uint64_t>::max());
const CLI::Validator kRhs = nonNegative(kMaxRhs);

// A CLI11 check for int options: a decimal integer within int's range (said so, rather than
// CLI11's "Could not convert"); the command then checks its own bounds.
const CLI::Validator kInt(
    [](std::string& value) -> std::string {
      const std::size_t start = !value.empty() && (value[0] == '-' || value[0] == '+') ? 1 : 0;
      if (value.size() == start ||
          value.find_first_not_of("0123456789", start) != std::string::npos)
        return "expected an integer, got '" + value + "'";
      long long v = 0;
      const char* first = value.data() + (value[0] == '+' ? 1 : 0);
      const auto [end, ec] = std::from_chars(first, value.data() + value.size(), v);
      if (ec != std::errc() || v < std::numeric_limits<int>::min() ||
          v > std::numeric_limits<int>::max())
        return "'" + value + "' is out of range (at most " +
               std::to_string(std::numeric_limits<int>::max()) + " in size)";
      return {};
    },
    "", "integer");

// `value` of option `name` must lie in [lo, hi]; else std::invalid_argument saying so.
void checkRange(const std::string& name, long long value, long long lo, long long hi,
                const std::string& why = "") {
  if (value < lo || value > hi)
    throw std::invalid_argument(name + " must be between " + std::to_string(lo) + " and " +
                                std::to_string(hi) + why + ", got " + std::to_string(value));
}

// Fail fast, before any work, if the output file's directory does not exist, or the output
// names a directory itself (it failed only at the final rename), or an HDF5 output would
// replace a file that is not one (`solve --out model.json` replaced the model).
void checkOutputDirectory(const std::string& path, bool hdf5 = true) {
  if (path.empty()) throw std::invalid_argument("--out names no file");
  const std::filesystem::path out(path), dir = out.parent_path();
  std::error_code ec;
  if (!out.has_filename())
    throw std::runtime_error("output '" + path + "' is a directory; name a file");
  requireOutputFile(path);
  if (hdf5) requireReplaceableByHdf5(path);
  if (dir.empty() || std::filesystem::is_directory(dir, ec)) return;
  if (std::filesystem::exists(dir, ec))
    throw std::runtime_error("output directory '" + dir.string() + "' is not a directory");
  throw std::runtime_error("output directory '" + dir.string() + "' does not exist");
}

// a / (b·c) without overflow or underflow on the way (only the quotient itself can leave the
// double range): mantissas and exponents apart. 0 / (b·c) = 0 for b·c > 0; x / 0 = inf.
double quotient(double a, double b, double c = 1) {
  int ea = 0, eb = 0, ec = 0;
  const double ma = std::frexp(a, &ea), mb = std::frexp(b, &eb), mc = std::frexp(c, &ec);
  return std::ldexp(ma / (mb * mc), ea - eb - ec);
}

struct GenerateOptions {
  std::string topology, joints = "revolute", out, segment_joint = "yaw";
  int n = 0, segments = 0;
  std::uint64_t seed = 1;
  bool floating_base = false;
  std::vector<std::string> given;  // the options on the command line
};

struct SolveOptions {
  std::string model, solver = "all", out, q_file;
  bool floating_base = false;
  std::uint64_t q_seed = 1, rhs_seed = 1;
  int rhs = 0;
};

// "serial" if no body has two or more children, else "branched".
std::string topologyOf(const Model& model) {
  std::vector<int> children(model.nb(), 0);
  for (int i = 0; i < model.nb(); ++i)
    if (model.parent(i) >= 0 && ++children[model.parent(i)] > 1) return "branched";
  return "serial";
}

// saveModel, and no FILE.tmp left behind whatever it throws (running out of memory while it
// writes the text, too).
void saveModelOrRemoveTmp(const Model& model, const std::string& path) {
  std::error_code ec;
  // (a tmp file that was there before is not this run's: saveModel refuses it, and it stays)
  const std::string tmp = path + ".tmp";
  if (std::filesystem::exists(std::filesystem::symlink_status(tmp, ec)))
    return saveModel(model, path);
  // This run's: removed on a failure, and on a signal (SIGINT, a file-size limit …) as the
  // writers' tmp files are; only a SIGKILLed run leaves it, and the next one names it
  const RemovedOnSignal guard(tmp);
  try {
    saveModel(model, path);
  } catch (...) {
    std::filesystem::remove(tmp, ec);
    throw;
  }
  if (const std::string note = floatingUrdfNote(model, path); !note.empty())
    std::fprintf(stderr, "%s\n", note.c_str());
}

// generate: parse the names, build the tree, save it atomically, print one line.
int runGenerate(const GenerateOptions& o) {
  checkOutputDirectory(o.out, /*hdf5=*/false);
  if (o.topology != "serial" && o.topology != "branched" && o.topology != "centipede")
    throw std::invalid_argument("unknown topology '" + o.topology +
                                "' (expected serial, branched or centipede)");
  // An option of the other kind of tree is refused, not ignored.
  const bool centipede = o.topology == "centipede";
  for (const std::string& name : o.given) {
    const bool centipedes = name == "--segments" || name == "--segment-joint";
    const bool random =
        name == "--n" || name == "--seed" || name == "--floating-base" || name == "--joints";
    if ((centipede && random) || (!centipede && centipedes))
      throw std::invalid_argument(name + " does not apply to --topology " + o.topology + " (" +
                                  (centipede ? "a centipede takes --segments and --segment-joint"
                                             : "--segments and --segment-joint are a centipede's") +
                                  ")");
  }
  if (centipede) {
    checkRange("--segments", o.segments, 1, kMaxSegments);
    allocating() = "a centipede of " + std::to_string(o.segments) + " segments";
    CentipedeOptions co;
    co.segments = o.segments;
    co.segment_joint = segmentJointFromName(o.segment_joint);
    const Model model = makeCentipede(co).model;
    saveModelOrRemoveTmp(model, o.out);
    std::printf("bodies=%d nv=%d max_depth=%d segments=%d segment_joint=%s file=%s\n", model.nb(),
                model.nv(), model.maxDepth(), o.segments, o.segment_joint.c_str(), o.out.c_str());
    return 0;
  }
  TreeOptions t;
  t.topology = topologyFromName(o.topology);
  t.joints = jointSetFromName(o.joints);
  checkRange("--n", o.n, 1, kMaxLinks);
  allocating() = "a random tree of " + std::to_string(o.n) + " links";
  t.n = o.n;
  t.seed = o.seed;
  t.floating_base = o.floating_base;
  const Model model = randomTree(t);
  saveModelOrRemoveTmp(model, o.out);
  std::printf("bodies=%d nv=%d max_depth=%d file=%s\n", model.nb(), model.nv(), model.maxDepth(),
              o.out.c_str());
  return 0;
}

// The solvers to run: one by name (unknown → std::invalid_argument) or the whole registry.
std::vector<const SolverEntry*> selectSolvers(const std::string& name) {
  std::vector<const SolverEntry*> out;
  for (const SolverEntry& e : solverRegistry())
    if (name == "all" || e.name == name) out.push_back(&e);
  if (out.empty()) makeSolver(name);  // throws with the list of known names
  return out;
}

// cond₂(M) = λmax/λmin, scale-invariant, with its log10 (finite where cond itself is beyond
// the double range). Eigen's solver scales M by its largest entry, so a λmin below about
// 1e-8·λmax is lost to rounding (or underflow, for a mass of 1e-300 beside 1e30); then
// λmin = 1/λmax(M⁻¹), with M⁻¹ from Cholesky (accurate for a graded M), the product taken by
// mantissa and exponent. Both are inf for an M that is singular to double precision.
struct Condition {
  double value, log10;
};
Condition conditionNumber(const Eigen::MatrixXd& M) {
  using Eigen::SelfAdjointEigenSolver;
  constexpr double kInf = std::numeric_limits<double>::infinity();
  const Eigen::VectorXd ev =
      SelfAdjointEigenSolver<Eigen::MatrixXd>(M, Eigen::EigenvaluesOnly).eigenvalues();
  const double hi = ev.maxCoeff(), lo = ev.minCoeff();
  if (lo > 1e-8 * hi) return {hi / lo, std::log10(hi / lo)};
  const Eigen::LLT<Eigen::MatrixXd> llt(M);
  if (llt.info() != Eigen::Success) return {kInf, kInf};
  const Eigen::MatrixXd inverse = llt.solve(Eigen::MatrixXd::Identity(M.rows(), M.cols()));
  if (!inverse.allFinite()) return {kInf, kInf};
  const double hi_inverse = SelfAdjointEigenSolver<Eigen::MatrixXd>(inverse, Eigen::EigenvaluesOnly)
                                .eigenvalues()
                                .maxCoeff();
  int e1 = 0, e2 = 0;
  const double m = std::frexp(hi, &e1) * std::frexp(hi_inverse, &e2);
  return {std::ldexp(m, e1 + e2), std::log10(m) + (e1 + e2) * std::log10(2.0)};
}

double seconds(std::chrono::steady_clock::duration d) {
  return std::chrono::duration<double>(d).count();
}

// One solver on (model, q): checked inverse, median time and optional solve, written to h5.
void runSolver(const SolverEntry& e, const Model& model, const Eigen::VectorXd& q,
               const Eigen::MatrixXd& M, const SolveOptions& o, const std::string& topology,
               H5Writer& h5, bool named, int width) {
  const std::string group = "solvers/" + e.name;
  const int nv = model.nv();
  h5.createGroup(group);
  h5.setAttribute(group, "summary", e.summary);
  auto solver = e.make();
  // A solver that cannot handle this tree: an error if asked for by name, else skipped.
  std::string why;
  if (!solver->supports(model, &why)) {
    if (named)
      throw std::runtime_error("solver '" + e.name + "' does not support this model: " + why);
    h5.setAttribute(group, "skipped", why);
    std::printf("%-*s %-9s %6d  skipped: %s\n", width, e.name.c_str(), topology.c_str(), nv,
                why.c_str());
    return;
  }
  // First run: prepare, configure, inverse; the residual must be finite.
  Eigen::MatrixXd X(nv, nv);
  solver->prepare(model);
  solver->configure(q);
  solver->inverse(X);
  // Masses of 1e-200 or 1e30 are valid: M·X is formed as it is (each product M_ik·X_kj is at
  // most cond(M) in size, so none overflows, and one that underflows is below 1e-308 against
  // the entries 0 and 1 of M·X), the norms with stableNorm (a sum of squares would underflow
  // or overflow) and the quotient by mantissa and exponent.
  // (M·X evaluated once: stableNorm of the expression re-formed the product per block, Θ(n⁴))
  Eigen::MatrixXd defect_matrix = M * X;
  defect_matrix.diagonal().array() -= 1.0;
  const double defect = defect_matrix.stableNorm();
  const double residual = quotient(defect, M.stableNorm(), X.stableNorm());
  const double residual_identity = defect / std::sqrt(static_cast<double>(nv));
  if (!X.allFinite())
    throw std::runtime_error("solver '" + e.name + "': Minv has non-finite entries");
  if (!std::isfinite(residual) || !std::isfinite(defect))
    throw std::runtime_error("solver '" + e.name + "': residual ‖M·Minv − 1‖ is not finite");
  // Far above what a backward-stable method reaches (a few nv·ε): said, not only stored (bullet
  // where light and heavy bodies alternate on ball joints; README, "Known limits of the peers")
  const double rounding = 1000 * nv * std::numeric_limits<double>::epsilon();
  if (residual > rounding)
    std::fprintf(stderr,
                 "minv: warning: solver '%s': residual %.2e is far above rounding (1000 nv eps = "
                 "%.1e): its Minv is inaccurate\n",
                 e.name.c_str(), residual, rounding);
  // A backward error at rounding, yet M·Minv not near 1 at all: an M too ill-conditioned for
  // the solver (light and heavy bodies alternating; on ball joints M is singular to double
  // precision), where ‖M‖·‖Minv‖ is so large that the residual above is tiny or underflows to
  // 0. Said too: this Minv is no inverse of M.
  else if (residual_identity >= 1)
    std::fprintf(stderr,
                 "minv: warning: solver '%s': |M Minv - 1|_F / sqrt(n) = %.2e: its Minv is not "
                 "M's inverse (M is too ill-conditioned for it; its residual %.2e is only a "
                 "backward error)\n",
                 e.name.c_str(), residual_identity, residual);
  // Timing: median of kRepetitions runs of configure + inverse.
  std::vector<double> times;
  Eigen::MatrixXd Xt = outputMatrix(nv, nv);
  for (int r = 0; r < kRepetitions; ++r) {
    const auto t0 = std::chrono::steady_clock::now();
    solver->configure(q);
    solver->inverse(Xt);
    times.push_back(seconds(std::chrono::steady_clock::now() - t0));
  }
  std::nth_element(times.begin(), times.begin() + kRepetitions / 2, times.end());
  const double time_s = times[kRepetitions / 2];
  h5.writeMatrix(group + "/Minv", X);
  h5.setAttribute(group, "residual", residual);
  h5.setAttribute(group, "residual_identity", residual_identity);
  h5.setAttribute(group, "time_s", time_s);
  h5.setAttribute(group, "repetitions", kRepetitions);
  // Optional right-hand sides: solve(R) against Minv·R.
  std::string solve_col;
  if (o.rhs > 0) {
    const Eigen::MatrixXd R = randomMatrix(nv, o.rhs, o.rhs_seed);
    Eigen::MatrixXd Y(nv, o.rhs);
    solver->solve(R, Y);
    const Eigen::MatrixXd ref = X * R;
    const double solve_residual =
        quotient((Y - ref).stableNorm(), std::max(ref.stableNorm(), 1e-300));
    if (!std::isfinite(solve_residual))
      throw std::runtime_error("solver '" + e.name + "': solve residual is not finite");
    h5.setAttribute(group, "solve_residual", solve_residual);
    char buf[32];
    std::snprintf(buf, sizeof buf, "  %9.2e", solve_residual);
    solve_col = buf;
  }
  std::printf("%-*s %-9s %6d  %9.2e  %9.2e  %10.3f%s\n", width, e.name.c_str(), topology.c_str(),
              nv, residual, residual_identity, time_s * 1e3, solve_col.c_str());
  std::fflush(stdout);
}

// solve: validate everything, build M, then write the result file solver by solver.
int runSolve(const SolveOptions& o) {
  const std::vector<const SolverEntry*> solvers = selectSolvers(o.solver);
  checkOutputDirectory(o.out);
  allocating() = "the model " + o.model;
  const Model model = loadModel(o.model, o.floating_base);
  const Eigen::VectorXd q =
      o.q_file.empty() ? randomConfiguration(model, o.q_seed) : loadConfiguration(model, o.q_file);
  model.checkConfiguration(q);
  char size[64];
  std::snprintf(size, sizeof size, "nv × nv matrices (nv = %d, %.3g GB each)", model.nv(),
                8e-9 * model.nv() * model.nv());
  allocating() = size;
  const Eigen::MatrixXd M = massMatrix(model, q);
  if (!M.allFinite()) throw std::runtime_error("the mass matrix M has non-finite entries");
  const std::string topology = topologyOf(model);
  const Condition condition = conditionNumber(M);
  const double cond = condition.value;
  if (std::isnan(cond)) throw std::runtime_error("cond(M) is not a number");
  // The printed cond(M): beyond the double range as a power of ten (stored as inf).
  char cond_text[96];
  if (std::isfinite(cond))
    std::snprintf(cond_text, sizeof cond_text, "%.2e", cond);
  else if (std::isfinite(condition.log10))
    std::snprintf(
        cond_text, sizeof cond_text, "%.2fe+%.0f (beyond the double range; stored as inf)",
        std::pow(10.0, condition.log10 - std::floor(condition.log10)), std::floor(condition.log10));
  else
    std::snprintf(cond_text, sizeof cond_text, "inf (M is singular to double precision)");

  // Root: the problem (q, M, numbering) and where it came from.
  H5Writer h5(o.out);
  h5.writeVector("q", q);
  h5.writeMatrix("M", M);
  h5.writeStrings("dof_names", model.dofNames());
  h5.writeIntVector("parent", model.dofParent());
  h5.writeIntVector("body_parent", model.parents());
  if (model.floatingBase()) {
    h5.writeVector("base_position", Eigen::VectorXd(q.head<3>()));
    h5.writeVector("base_quaternion", Eigen::VectorXd(q.segment<4>(3)));
  }
  h5.setAttribute("/", "model", o.model);
  h5.setAttribute("/", "nv", model.nv());
  h5.setAttribute("/", "nq", model.nq());
  h5.setAttribute("/", "nb", model.nb());
  h5.setAttribute("/", "max_depth", model.maxDepth());
  h5.setAttribute("/", "topology", topology);
  h5.setAttribute("/", "cond", cond);
  h5.setAttribute("/", "cond_log10", condition.log10);
  h5.setAttribute("/", "q_seed", o.q_seed);
  if (!o.q_file.empty()) h5.setAttribute("/", "q_file", o.q_file);
  h5.setAttribute("/", "rhs", o.rhs);
  h5.setAttribute("/", "rhs_seed", o.rhs_seed);
  writeProvenance(h5, "/");

  // One row per solver.
  const std::string q_from =
      o.q_file.empty() ? "q_seed " + std::to_string(o.q_seed) : "q from " + o.q_file;
  std::printf("# %s\n# model %s: %d bodies, nv %d, max depth %d, %s, cond(M) %s\n",
              provenanceSummary().c_str(), o.model.c_str(), model.nb(), model.nv(),
              model.maxDepth(), q_from.c_str(), cond_text);
  std::printf("# residual = |M X - I|_F / (|M|_F |X|_F); residual_I = |M X - I|_F / sqrt(n)\n");
  // The name column is as wide as the longest name.
  int width = 6;
  for (const SolverEntry* e : solvers) width = std::max(width, static_cast<int>(e->name.size()));
  std::printf("%-*s %-9s %6s  %9s  %9s  %10s%s\n", width, "solver", "topology", "n", "residual",
              "residual_I", "time_ms", o.rhs > 0 ? "  solve_res" : "");
  const bool named = o.solver != "all";
  std::string failed;  // the solvers that failed, with all
  for (const SolverEntry* e : solvers) {
    try {
      runSolver(*e, model, q, M, o, topology, h5, named, width);
    } catch (const std::bad_alloc&) {
      throw;
    } catch (const std::exception& x) {
      std::string what = x.what();
      // (the result file's own failures are not the solver's)
      if (what.rfind("HDF5: ", 0) == 0) throw;
      if (what.rfind("solver '", 0) != 0) what = "solver '" + e->name + "': " + what;
      // A solver asked for by name: the error, naming the model. With all, the others go on:
      // its group keeps only why it failed (a peer that cannot factor an M of cond 1e16), and
      // the command fails at the end, after writing the file.
      if (named) throw std::runtime_error(what + " (model '" + o.model + "')");
      failed += (failed.empty() ? "" : ", ") + e->name;
      const std::string group = "solvers/" + e->name;
      h5.remove(group);
      h5.createGroup(group);
      h5.setAttribute(group, "summary", e->summary);
      h5.setAttribute(group, "failed", x.what());
      std::printf("%-*s %-9s %6d  failed: %s\n", width, e->name.c_str(), topology.c_str(),
                  model.nv(), x.what());
      std::fprintf(stderr, "minv: warning: %s (model '%s')\n", what.c_str(), o.model.c_str());
    }
  }
  h5.commit();
  std::printf("wrote %s\n", o.out.c_str());
  if (!failed.empty())
    throw std::runtime_error("solver(s) " + failed + " failed on '" + o.model +
                             "' (their rows above say why; " + o.out +
                             " holds every other result)");
  return 0;
}

struct FlopsOptions {
  std::string solver = "all", topology, joints = "revolute";
  int n = 0, rhs = 0;
  std::uint64_t seed = 1;
  bool floating_base = false;
};

// flops: per-stage operation counts of one or every solver on one random tree.
int runFlops(const FlopsOptions& o) {
  const std::vector<const SolverEntry*> solvers = selectSolvers(o.solver);
  checkRange("--n", o.n, 1, kMaxCountedLinks, " for flops (its counted matrices are dense)");
  allocating() = "the counted run of " + std::to_string(o.n) + " links";
  const Model model = randomTree(
      {topologyFromName(o.topology), o.n, o.seed, o.floating_base, jointSetFromName(o.joints)});
  const Eigen::VectorXd q = randomConfiguration(model, o.seed);
  std::printf("# %s tree, %d bodies, nv %d, max depth %d, %s; counts for %s\n", o.topology.c_str(),
              model.nb(), model.nv(), model.maxDepth(),
              o.floating_base ? "floating base" : "fixed base",
              o.rhs > 0 ? ("M^-1 R, " + std::to_string(o.rhs) + " columns").c_str() : "M^-1");
  for (const SolverEntry* e : solvers) {
    std::printf("\n");
    if (!e->count) {
      std::printf("%s: not counted (its arithmetic cannot run on the counting scalar)\n",
                  e->name.c_str());
      continue;
    }
    printStageTable(std::cout, e->name, e->count(model, q, o.rhs));
    if (e->name == "abi" && o.rhs == 0) {
      std::printf("\n# abi per processor, one processor per column (Table 3)\n");
      printStageTable(std::cout, "abi/proc", abiParallelCounts(model, q));
    }
    std::cout.flush();
  }
  return 0;
}

struct ExperimentOptions {
  std::string out;
  int max_n = 256;
  std::uint64_t seed = 1;
};

// experiment flops: the operation-count sweep behind Tables 1-3 and Figure 1.
int runFlopsExperiment(const ExperimentOptions& o) {
  checkOutputDirectory(o.out);
  checkRange("--max-n", o.max_n, 2, kMaxCountedLinks,
             " for experiment flops (its counted matrices are dense)");
  allocating() = "the counted runs up to n = " + std::to_string(o.max_n);
  FlopsSweep sweep;
  sweep.n.clear();
  for (int n = 2; n <= o.max_n; n *= 2) sweep.n.push_back(n);
  sweep.seed = o.seed;
  runFlopsSweep(sweep, o.out, std::cout);
  return 0;
}

struct AccuracyOptions {
  std::string mode = "quick", out;
};

// experiment accuracy: residuals and forward errors vs a long-double reference, vs n.
int runAccuracyExperiment(const AccuracyOptions& o) {
  const AccuracySweep sweep = accuracySweep(o.mode);
  checkOutputDirectory(o.out);
  runAccuracySweep(sweep, o.out, std::cout);
  return 0;
}

struct MergeOptions {
  std::string out;
  std::vector<std::string> inputs;
};

// merge: join shard files of a sweep into one file.
int runMerge(const MergeOptions& o) {
  checkOutputDirectory(o.out);
  std::error_code ec;
  for (const std::string& in : o.inputs) {
    if (!std::filesystem::exists(in))
      throw std::runtime_error("input file '" + in + "' does not exist");
    if (std::filesystem::equivalent(in, o.out, ec))
      throw std::runtime_error("output '" + o.out + "' is the input file '" + in +
                               "': name another output");
  }
  // (merge writes in a child process, whose crash on a damaged input removes OUT.tmp)
  requireReplaceableByHdf5(o.out + ".tmp", "the tmp file of '" + o.out + "',");
  const int points = mergeResultFiles(o.inputs, o.out);
  std::printf("merged %d points from %zu files into %s\n", points, o.inputs.size(), o.out.c_str());
  return 0;
}

struct SimulateOptions {
  sim::CentipedeRunOptions run;
  std::string out;
  sim::CentipedeSweepOptions sweep;
};

// simulate centipede: one walk, progress on stdout, the net displacement, optionally HDF5.
int runSimulate(SimulateOptions o) {
  if (!o.out.empty()) checkOutputDirectory(o.out);
  if (o.run.frames > 0 && o.out.empty())
    throw std::invalid_argument("--frames keeps trajectory frames in the output file: give --out");
  // (The walk's other options are checked by sim::runCentipede before it steps.)
  checkRange("--segments", o.run.segments, 1, kMaxSegments);
  allocating() = "a walk of a centipede of " + std::to_string(o.run.segments) + " segments, " +
                 std::to_string(o.run.steps) + " steps";
  std::unique_ptr<H5Writer> h5;
  if (!o.out.empty()) h5 = std::make_unique<H5Writer>(o.out);
  const sim::CentipedeRunResult r = sim::runCentipede(o.run, std::cout, h5.get(), "/");
  std::printf(
      "times (s): dynamics %.3f  collision %.3f  contact matrices %.3f  contact solve "
      "%.3f  update %.3f  total %.3f%s\n",
      r.times.dynamics, r.times.collision, r.times.matrices, r.times.solve, r.times.update,
      r.time_total, r.engine == "mujoco" ? " (MuJoCo's mj_step, undivided)" : "");
  if (r.engine != "mujoco")
    std::printf(
        "contact residuals (max): penetration %.2e m/s  cone %.2e  complementarity %.2e  "
        "kkt %.2e; pgs iterations max %d, unconverged steps %d\n",
        r.max_penetration, r.max_cone, r.max_complementarity, r.max_kkt, r.max_pgs_iterations,
        r.unconverged_steps);
  std::printf(
      "net displacement: head dx=%+.4f m dy=%+.4f m; centre of mass dx=%+.4f m dy=%+.4f m\n",
      r.head_dx, r.head_dy, r.com_dx, r.com_dy);
  if (h5) {
    writeProvenance(*h5, "/");
    h5->commit();
    std::printf("wrote %s\n", o.out.c_str());
  }
  return 0;
}

// simulate sweep: the Figure 4 timings, one point per (segments, solver).
int runSimulateSweep(const SimulateOptions& o) {
  checkOutputDirectory(o.sweep.out);
  // (Steps, dt and threads are checked by runCentipedeSweep before it creates the file.)
  for (const int S : o.sweep.segments) checkRange("--segments", S, 1, kMaxSegments);
  sim::runCentipedeSweep(o.sweep, std::cout);
  return 0;
}

struct CheckOptions {
  std::string solver = "all";
  int max_n = 300;
};

// check: the conformance checks (solvers/conformance.hpp) of one or every solver; exit 1 if
// any fails.
int runCheck(const CheckOptions& o) {
  const std::vector<const SolverEntry*> solvers = selectSolvers(o.solver);
  // Below 1 no case would run (the smallest is n = 1).
  if (o.max_n < 1)
    throw std::invalid_argument("--max-n must be at least 1 (the smallest case is n = 1), got " +
                                std::to_string(o.max_n));
  ConformanceOptions options;
  options.max_n = o.max_n;
  bool all_passed = true;
  for (const SolverEntry* e : solvers) {
    const ConformanceReport r = checkSolver(e->name, e->make, options);
    r.print(std::cout);
    std::cout.flush();
    all_passed &= r.passed() || (r.checks.empty() && r.errors.empty());
  }
  return all_passed ? 0 : 1;
}

struct TimeOptions {
  std::string mode = "quick", shard = "0/1", out;
  std::vector<std::string> solvers;
  double min_time = -1;
  int repetitions = -1;
  bool min_time_given = false, repetitions_given = false, list = false;
};

// time: the timing sweeps (experiments/lib/timing.hpp) measured with Google Benchmark.
int runTime(const TimeOptions& o, const std::string& program) {
  TimingSweep sweep = timingSweep(o.mode);
  // Given values are checked, never replaced by the defaults (before the file is created).
  if (o.min_time_given) {
    if (!(o.min_time > 0) || !(o.min_time <= kMaxMinTime)) {
      throw std::invalid_argument("--min-time must be above 0 and at most " +
                                  formatNumber(kMaxMinTime) + " s, got " +
                                  formatNumber(o.min_time));
    }
    sweep.min_time = o.min_time;
  }
  if (o.repetitions_given) {
    checkRange("--repetitions", o.repetitions, 1, kMaxRepetitions);
    sweep.repetitions = o.repetitions;
  }
  // --solvers: only these (each must be registered).
  if (!o.solvers.empty()) {
    for (const std::string& name : o.solvers) makeSolver(name);
    std::vector<std::string> timed;  // what the sweep times at all, for the message below
    for (SweepBlock& b : sweep.blocks) {
      std::vector<std::string> keep;
      const std::vector<std::string> from = b.solvers.empty() ? solverNames() : b.solvers;
      for (const std::string& name : from) {
        if (!b.n.empty() && std::find(timed.begin(), timed.end(), name) == timed.end())
          timed.push_back(name);
        if (std::find(o.solvers.begin(), o.solvers.end(), name) != o.solvers.end())
          keep.push_back(name);
      }
      if (keep.empty()) b.n.clear();  // no solver of this block was asked for
      b.solvers = keep;
    }
    // (an empty selection once wrote a file of no points and exited 0)
    if (sweepPoints(sweep).empty()) {
      std::string list;
      for (const std::string& name : timed) list += (list.empty() ? "" : ", ") + name;
      throw std::invalid_argument("--solvers: the " + sweep.mode +
                                  " sweep times none of these solvers (it times " + list + ")");
    }
  }
  const Shard shard = parseShard(o.shard);
  if (o.list) {
    for (const auto& p : shardPoints(sweepPoints(sweep), shard)) {
      const auto skip = skipReason(p.solver, p.family, p.topology, p.n, sweep.mode);
      std::cout << p.name() << (skip ? "  skipped: " + *skip : "") << "\n";
    }
    return 0;
  }
  if (o.out.empty()) throw std::invalid_argument("--out is required");
  checkOutputDirectory(o.out);
  std::cout << "# " << provenanceSummary() << "\n# sweep " << sweep.mode << ", shard " << o.shard
            << ", min_time " << sweep.min_time << " s, " << sweep.repetitions << " repetitions -> "
            << o.out << std::endl;
  const SweepStats st = runTimingSweep(sweep, shard, o.out, measureWithGoogleBenchmark, std::cout);
  std::cout << program << ": " << st.measured << " measured, " << st.skipped << " skipped, "
            << st.resumed << " already in " << o.out << std::endl;
  return 0;
}

// solvers: name and summary, one line each.
int runSolvers() {
  std::size_t width = 0;
  for (const SolverEntry& e : solverRegistry()) width = std::max(width, e.name.size());
  for (const SolverEntry& e : solverRegistry())
    std::printf("%-*s  %s\n", static_cast<int>(width), e.name.c_str(), e.summary.c_str());
  return 0;
}

}  // namespace

int runCli(int argc, char** argv, const std::string& program) {
  auto reportError = [&program](const std::string& message) {
    return minv::reportError(program, message);
  };
  CLI::App app{program + ": the joint-space inertia matrix M of articulated trees and its inverse",
               program};
  app.require_subcommand(1);
  app.set_version_flag("--version", collectProvenance().minv_version);

  // generate
  GenerateOptions g;
  CLI::App* gen = app.add_subcommand("generate", "Write a random tree to a model file");
  gen->add_option("--topology", g.topology, "serial | branched (the paper's §6.1 rule) | centipede")
      ->required();
  gen->add_option("--n", g.n,
                  "Number of jointed links, not counting a floating base (> 0; required "
                  "except for --topology centipede, which takes --segments)")
      ->check(kInt);
  gen->add_option("--seed", g.seed, "Random seed")->check(kSeed)->capture_default_str();
  gen->add_flag("--floating-base", g.floating_base,
                "Add a floating base: a new body 0 on a 6-DOF joint above the n links "
                "(nv = n + 6 for revolute links)");
  gen->add_option("--joints", g.joints, "revolute | mixed (revolute, prismatic, spherical)")
      ->capture_default_str();
  gen->add_option("--out", g.out, "Output model file, .json or .urdf")->required();

  // solve
  SolveOptions s;
  CLI::App* sol = app.add_subcommand("solve", "Invert M with one or all solvers; write HDF5");
  sol->add_option("--model", s.model, "Model file: .json, .urdf or .xml (MJCF)")->required();
  sol->add_flag("--free-root", s.floating_base,
                "Set the model's root body free: its joint to the world becomes a 6-DOF floating "
                "joint (no body is added; a model that floats already is unchanged)");
  sol->add_option("--solver", s.solver, "Solver name (see `minv solvers`) or all")
      ->capture_default_str();
  CLI::Option* qseed = sol->add_option("--q-seed", s.q_seed, "Seed of the random configuration q")
                           ->check(kSeed)
                           ->capture_default_str();
  sol->add_option("--q", s.q_file,
                  "Configuration file instead of a random q: nq numbers in q order, or "
                  "'name value' lines (names: minv's q names, see the README)")
      ->excludes(qseed);
  sol->add_option("--rhs", s.rhs, "Also solve M X = R for this many random columns")
      ->check(kRhs)
      ->capture_default_str();
  sol->add_option("--rhs-seed", s.rhs_seed, "Seed of the random right-hand sides")
      ->check(kSeed)
      ->capture_default_str();
  sol->add_option("--out", s.out, "Output HDF5 file")->required();

  // solvers
  CLI::App* list = app.add_subcommand("solvers", "List the registered solvers");

  // check
  CheckOptions ck;
  CLI::App* chk =
      app.add_subcommand("check", "Run the conformance checks on solvers (exit 1 on a failure)");
  chk->add_option("--solver", ck.solver, "Solver name or all")->capture_default_str();
  chk->add_option("--max-n", ck.max_n, "Largest tree (cases n = 1, 2, 3, 7, 32, 100, 300)")
      ->check(kInt)
      ->capture_default_str();

  // time
  TimeOptions tm;
  CLI::App* tim = app.add_subcommand("time", "Timing sweeps (Figures 2, 3) with Google Benchmark");
  tim->add_option("--mode", tm.mode, "quick | full | tiny")->capture_default_str();
  tim->add_option("--solvers", tm.solvers, "Only these solvers")->delimiter(',');
  tim->add_option("--shard", tm.shard, "Run the points i, i+N, i+2N, … of the sweep")
      ->capture_default_str();
  CLI::Option* min_time =
      tim->add_option("--min-time", tm.min_time, "Google Benchmark min time per repetition (s)");
  CLI::Option* repetitions =
      tim->add_option("--repetitions", tm.repetitions, "Repetitions per point")->check(kInt);
  tim->add_flag("--list", tm.list, "Print the shard's points and exit");
  tim->add_option("--out", tm.out, "Output HDF5 file (appended to and resumed)");

  // flops
  FlopsOptions f;
  CLI::App* fl = app.add_subcommand("flops", "Print measured operation counts per stage");
  fl->add_option("--solver", f.solver, "Solver name or all")->capture_default_str();
  fl->add_option("--topology", f.topology, "serial | branched")->required();
  fl->add_option("--n", f.n, "Number of jointed links (> 0)")->required()->check(kInt);
  fl->add_flag("--floating-base", f.floating_base,
               "Add a floating base: a new body 0 on a 6-DOF joint above the n links");
  fl->add_option("--joints", f.joints, "revolute | mixed")->capture_default_str();
  fl->add_option("--rhs", f.rhs, "Count M^-1 R with this many columns instead of M^-1")
      ->check(kRhs)
      ->capture_default_str();
  fl->add_option("--seed", f.seed, "Random seed")->check(kSeed)->capture_default_str();

  // experiment
  CLI::App* exp = app.add_subcommand("experiment", "Run an experiment sweep into results/");
  exp->require_subcommand(1);
  ExperimentOptions x;
  CLI::App* xfl = exp->add_subcommand("flops", "Operation counts vs n (Tables 1-3, Figure 1)");
  xfl->add_option("--max-n", x.max_n, "Largest n (powers of two from 2)")
      ->check(kInt)
      ->capture_default_str();
  xfl->add_option("--seed", x.seed, "Random seed")->check(kSeed)->capture_default_str();
  xfl->add_option("--out", x.out, "Output HDF5 file")->required();
  AccuracyOptions xa;
  CLI::App* xac =
      exp->add_subcommand("accuracy", "Residual and error vs a long-double reference, vs n");
  xac->add_option("--mode", xa.mode, "quick | full | tiny")->capture_default_str();
  xac->add_option("--out", xa.out, "Output HDF5 file (appended to and resumed)")->required();

  // merge
  MergeOptions mg;
  CLI::App* mrg = app.add_subcommand("merge", "Join the shard files of a sweep into one file");
  mrg->add_option("--out", mg.out, "Output HDF5 file")->required();
  mrg->add_option("inputs", mg.inputs, "Shard files")->required();

  gen->add_option("--segments", g.segments, "Centipede: number of body segments (>= 1)")
      ->check(kInt);
  gen->add_option("--segment-joint", g.segment_joint, "Centipede: yaw | spherical")
      ->capture_default_str();

  // simulate
  SimulateOptions sm;
  CLI::App* simc = app.add_subcommand("simulate", "Contact dynamics: the walking centipede (sim/)");
  simc->require_subcommand(1);
  CLI::App* scen = simc->add_subcommand("centipede", "One walk; prints the net displacement");
  scen->add_option("--segments", sm.run.segments, "Body segments (>= 1)")
      ->check(kInt)
      ->capture_default_str();
  scen->add_option("--steps", sm.run.steps, "Time steps")->check(kInt)->capture_default_str();
  scen->add_option("--dt", sm.run.dt, "Step size (s)")->capture_default_str();
  scen->add_option("--solver", sm.run.solver,
                   "Contact-space path: a solver name, test-impulse or contact-inertia; or "
                   "mujoco-step (MuJoCo's own mj_step)")
      ->capture_default_str();
  scen->add_option("--segment-joint", sm.run.segment_joint, "yaw | spherical")
      ->capture_default_str();
  scen->add_option("--threads", sm.run.threads,
                   "OpenMP threads of the contact-space matrices (mujoco-step: 1)")
      ->check(kInt)
      ->capture_default_str();
  scen->add_option("--frames", sm.run.frames, "Trajectory frames to save")
      ->check(kInt)
      ->capture_default_str();
  scen->add_option("--out", sm.out, "Output HDF5 file (optional)")->check([](const std::string& s) {
    return s.empty() ? "--out names no file" : "";
  });
  CLI::App* ssw = simc->add_subcommand("sweep", "Figure 4: time per step vs segments and solver");
  ssw->add_option("--segments", sm.sweep.segments, "Segment counts")
      ->delimiter(',')
      ->check(kInt)
      ->capture_default_str();
  ssw->add_option("--solvers", sm.sweep.solvers,
                  "Paths: solver names, test-impulse, contact-inertia, mujoco-step")
      ->delimiter(',')
      ->capture_default_str();
  ssw->add_option("--steps", sm.sweep.steps, "Time steps per run")
      ->check(kInt)
      ->capture_default_str();
  ssw->add_option("--dt", sm.sweep.dt, "Step size (s)")->capture_default_str();
  ssw->add_option("--threads", sm.sweep.threads,
                  "OpenMP threads of every path; points > 1 are named <path>@<threads>")
      ->check(kInt)
      ->capture_default_str();
  ssw->add_option("--out", sm.sweep.out, "Output HDF5 file (appended to and resumed)")->required();

  // An unknown subcommand word (CLI11 would only say that one is required).
  bool known = false;
  for (CLI::App* sub : {gen, sol, list, chk, tim, fl, exp, mrg, simc})
    known |= argc > 1 && sub->check_name(argv[1]);
  if (argc > 1 && argv[1][0] != '-' && !known)
    return reportError(std::string("unknown subcommand '") + argv[1] +
                       "' (expected generate, solve, solvers, check, time, flops, experiment, "
                       "merge or simulate)");
  // The same for `experiment` and `simulate`, whose own subcommand is missing or unknown.
  struct Parent {
    CLI::App* app;
    std::vector<CLI::App*> subs;
    const char* names;
  };
  for (const Parent& p : {Parent{exp, {xfl, xac}, "flops or accuracy"},
                          Parent{simc, {scen, ssw}, "centipede or sweep"}}) {
    if (argc < 2 || !p.app->check_name(argv[1])) continue;
    const std::string word = argc > 2 ? argv[2] : "";
    if (!word.empty() && word[0] == '-') continue;  // --help, or CLI11's own message
    bool found = false;
    for (CLI::App* sub : p.subs) found |= !word.empty() && sub->check_name(word);
    if (word.empty()) return reportError(std::string(argv[1]) + " needs a subcommand: " + p.names);
    if (!found)
      return reportError("unknown " + std::string(argv[1]) + " subcommand '" + word +
                         "' (expected " + p.names + ")");
  }
  // Parse: --help/--version exit 0 through CLI11; every other parse error is one line, exit 2.
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    if (e.get_exit_code() == static_cast<int>(CLI::ExitCodes::Success)) return app.exit(e);
    return reportError(e.what());
  }
  // Run: any exception is one line, exit 2; running out of memory says what was allocated.
  tm.min_time_given = min_time->count() > 0;
  tm.repetitions_given = repetitions->count() > 0;
  allocating().clear();
  try {
    if (gen->parsed()) {
      for (const CLI::Option* opt : gen->get_options())
        if (opt->count() > 0) g.given.push_back(opt->get_name());
      return runGenerate(g);
    }
    if (sol->parsed()) return runSolve(s);
    if (list->parsed()) return runSolvers();
    if (chk->parsed()) return runCheck(ck);
    if (tim->parsed()) return runTime(tm, program);
    if (fl->parsed()) return runFlops(f);
    if (xfl->parsed()) return runFlopsExperiment(x);
    if (xac->parsed()) return runAccuracyExperiment(xa);
    if (mrg->parsed()) return runMerge(mg);
    if (scen->parsed()) return runSimulate(sm);
    if (ssw->parsed()) return runSimulateSweep(sm);
    return reportError("no subcommand given");
  } catch (const std::bad_alloc&) {
    return reportError("out of memory" +
                       (allocating().empty() ? "" : " (allocating " + allocating() + ")"));
  } catch (const std::exception& e) {
    return reportError(e.what());
  } catch (...) {
    return reportError("unknown failure");
  }
}

}  // namespace minv
