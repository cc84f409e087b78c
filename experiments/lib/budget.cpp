#include "experiments/lib/budget.hpp"

namespace minv {

// THE skip table. Caps are on n (links); the reasons go into the result files. Times quoted
// are single-thread, on this project's 2-core AMD EPYC machines.
const std::vector<SkipRule>& skipRules() {
  static const std::vector<SkipRule> rules = {
      // The accuracy sweep runs each solver once per tree: it affords larger n.
      {"naive", "accuracy", "*", 1024, 2048,
       "textbook triple-loop Cholesky: Θ(n³) without blocking, too slow for this mode's budget"},
      {"ltl", "accuracy", "*", 1024, 2048,
       "Featherstone LᵀL: unblocked, tens of seconds at n = 2048 here, too slow for this mode's "
       "budget"},
      {"ltdl", "accuracy", "*", 1024, 2048,
       "Featherstone LᵀDL: unblocked, tens of seconds at n = 2048 here, too slow for this mode's "
       "budget"},
      {"mujoco", "accuracy", "*", 512, 1024,
       "MuJoCo's prepare() (mj_setConst) is Θ(n³) per tree: 11 s at n = 1000"},
      {"dart", "accuracy", "*", 1024, 2048,
       "DART's getInvMassMatrix is Θ(n²) but slow: about 0.2 s a call at n = 1024 here"},
      // Every timed family.
      {"naive", "*", "*", 512, 2048,
       "textbook triple-loop Cholesky: Θ(n³) without blocking, too slow for this mode's budget"},
      {"ltl", "*", "serial", 512, 2048,
       "branch-induced sparsity is dense on a serial chain: unblocked Θ(n³), too slow for this "
       "mode's budget"},
      {"ltdl", "*", "serial", 512, 2048,
       "branch-induced sparsity is dense on a serial chain: unblocked Θ(n³), too slow for this "
       "mode's budget"},
      {"ltl", "*", "branched", 768, 2048,
       "sparse inverse of the branched tree takes seconds at n = 1024 here: too slow for this "
       "mode's budget"},
      {"ltdl", "*", "branched", 768, 2048,
       "sparse inverse of the branched tree takes seconds at n = 1024 here: too slow for this "
       "mode's budget"},
      {"mujoco", "*", "*", 256, 512,
       "MuJoCo's prepare() (mj_setConst) is Θ(n³) per tree, run once per point: 11 s at n = 1000"},
      {"dart", "*", "*", 512, 2048,
       "DART's getInvMassMatrix is Θ(n²) but slow: about 0.2 s a call at n = 1024 here"},
      {"eigen", "*", "*", 2048, 4096,
       "Eigen::LLT's inverse is Θ(n³): about 1 s a call at n = 2048 here, 7-8 s at 4096"},
      // bench_abi's quick run takes only the serial chain (the performance targets) to 4096.
      {"*", "perf", "branched", 2048, 4096,
       "quick mode runs only the serial chain to n = 4096 (the performance targets)"},
  };
  return rules;
}

std::optional<std::string> skipReason(const std::string& solver, const std::string& family,
                                      const std::string& topology, int n, const std::string& mode) {
  auto match = [](const char* rule, const std::string& v) {
    return std::string(rule) == "*" || v == rule;
  };
  for (const SkipRule& r : skipRules()) {
    if (!match(r.solver, solver) || !match(r.family, family) || !match(r.topology, topology))
      continue;
    // The first matching rule decides.
    const int cap = mode == "full" ? r.full_max_n : r.quick_max_n;
    if (n > cap)
      return std::string(r.reason) + " (" + mode + " mode caps " + solver +
             " at n = " + std::to_string(cap) + ")";
    return std::nullopt;
  }
  return std::nullopt;
}

}  // namespace minv
