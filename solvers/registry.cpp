// The one registry: a solver is one adapter class plus one line here (or, from outside this
// repository, one registerSolver() call).
#include <algorithm>
#include <cstdio>
#include <mutex>
#include <sstream>
#include <stdexcept>

#include "solvers/abi.hpp"
#include "solvers/abi_variants.hpp"
#include "solvers/eigen.hpp"
#include "solvers/lapack.hpp"
#include "solvers/ltdl.hpp"
#include "solvers/ltl.hpp"
#include "solvers/naive.hpp"
#ifdef MINV_HAVE_MUJOCO
#include "solvers/mujoco.hpp"
#endif
#ifdef MINV_HAVE_DART
#include "solvers/dart.hpp"
#endif
#ifdef MINV_HAVE_BULLET
#include "solvers/bullet.hpp"
#endif

namespace minv {

namespace {
// A solver class T with a static countStages(model, q, m) gets it registered as its counter.
template <class T>
SolverEntry entry(const char* name, const char* summary) {
  SolverEntry e{name, summary, [] { return std::unique_ptr<Solver>(new T()); }, {}};
  if constexpr (requires { &T::countStages; }) e.count = &T::countStages;
  return e;
}

std::vector<SolverEntry> builtIn() {
  return {
      {"abi", abiSummary(), makeAbi, &AbiSolver::countStages},
      {"abi-generic",
       "abi's baseline level (x86-64, SSE2: what Debian's peer libraries are compiled for); "
       "counts as abi",
       [] { return makeAbiAt(Isa::Baseline); },
       {}},
      entry<LapackSolver>("lapack", "CRBA + LAPACKE dpotrf/dpotri/dpotrs (OpenBLAS)"),
      entry<LtlSolver>("ltl", "CRBA + Featherstone 2005 branch-induced-sparsity LᵀL"),
      entry<LtdlSolver>("ltdl", "CRBA + Featherstone 2005 branch-induced-sparsity LᵀDL"),
      entry<NaiveSolver>("naive", "CRBA + textbook dense Cholesky, no library"),
      entry<EigenSolver>("eigen", "CRBA + Eigen::LLT blocked dense Cholesky"),
#ifdef MINV_HAVE_MUJOCO
      entry<MujocoSolver>("mujoco", "MuJoCo 2.2.2: MJCF model, mj_crb + mj_factorM + mj_solveM"),
#endif
#ifdef MINV_HAVE_DART
      entry<DartSolver>("dart", DartSolver::kSummary),
#endif
#ifdef MINV_HAVE_BULLET
      entry<BulletSolver>("bullet", BulletSolver::kSummary),
#endif
  };
}

struct Registry {
  std::vector<SolverEntry> entries = builtIn();
  std::size_t builtin = entries.size();
  std::mutex mutex;  // registerSolver() may be called from any thread
};

Registry& registry() {
  static Registry r;
  return r;
}
}  // namespace

const std::vector<SolverEntry>& solverRegistry() {
  return registry().entries;
}

std::vector<std::string> solverNames() {
  std::vector<std::string> names;
  for (const SolverEntry& e : solverRegistry()) names.push_back(e.name);
  return names;
}

const SolverEntry* findSolver(const std::string& name) {
  for (const SolverEntry& e : solverRegistry())
    if (e.name == name) return &e;
  return nullptr;
}

// `name` with every byte outside printable ASCII as \xNN: a message quoting it stays one line of
// valid text (a lone byte of a UTF-8 sequence emptied Python's message, a NUL cut it short).
static std::string escaped(const std::string& name) {
  std::string out;
  for (const char c : name) {
    const auto b = static_cast<unsigned char>(c);
    if (b >= 0x20 && b < 0x7F) {
      out += c;
    } else {
      char hex[5];
      std::snprintf(hex, sizeof hex, "\\x%02X", b);
      out += hex;
    }
  }
  return out;
}

std::unique_ptr<Solver> makeSolver(const std::string& name) {
  if (const SolverEntry* e = findSolver(name)) return e->make();
  std::ostringstream known;
  for (const SolverEntry& e : solverRegistry()) known << (known.tellp() ? ", " : "") << e.name;
  throw std::invalid_argument("unknown solver '" + escaped(name) + "' (known: " + known.str() +
                              ")");
}

std::string solverNameProblem(const std::string& name) {
  if (name.empty()) return "a solver name must not be empty";
  const std::string quoted = "solver name '" + escaped(name) + "'";
  if (name.size() > 32) return quoted + " is longer than 32 characters";
  for (char c : name)
    if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-'))
      return quoted + " has the character '" + escaped(std::string(1, c)) +
             "'; use ASCII letters, digits, '_' and '-'";
  if (!std::isalnum(static_cast<unsigned char>(name[0])))
    return quoted + " must start with a letter or a digit";
  if (name == "all" || name == "test-impulse" || name == "contact-inertia" || name == "mujoco-step")
    return quoted + " is reserved by the minv command";
  return {};
}

void registerSolver(SolverEntry entry) {
  if (const std::string why = solverNameProblem(entry.name); !why.empty())
    throw std::invalid_argument(why);
  if (entry.summary.empty())
    throw std::invalid_argument("solver '" + entry.name + "' needs a one-line summary");
  if (entry.summary.find('\n') != std::string::npos)
    throw std::invalid_argument("solver '" + entry.name + "': the summary must be one line");
  if (!entry.make) throw std::invalid_argument("solver '" + entry.name + "' has no factory");
  Registry& r = registry();
  std::lock_guard<std::mutex> lock(r.mutex);
  if (findSolver(entry.name))
    throw std::invalid_argument("a solver named '" + entry.name + "' is already registered");
  r.entries.push_back(std::move(entry));
}

bool unregisterSolver(const std::string& name) {
  Registry& r = registry();
  std::lock_guard<std::mutex> lock(r.mutex);
  for (std::size_t i = r.builtin; i < r.entries.size(); ++i)
    if (r.entries[i].name == name) {
      r.entries.erase(r.entries.begin() + static_cast<std::ptrdiff_t>(i));
      return true;
    }
  return false;
}

}  // namespace minv
