// What each solver can afford, per size and mode: THE skip table, read by every driver (the
// timing sweeps of Figures 2-3 in experiments/lib/timing.hpp, the accuracy sweep, bench_abi's
// performance run and minv.compare), so that a point is measured or skipped for the same
// reason everywhere.
//
// A rule matches a solver, a family and a topology ("*" matches anything); a point whose n
// exceeds the cap of the first matching rule for the sweep's mode is not measured, and its
// result records the rule's reason and the cap. Families: "pipeline", "kernel", "threads"
// (timing sweeps), "accuracy" (the accuracy sweep, which runs each solver once per tree and so
// affords more), "perf" (bench_abi: ratios side by side, 5 interleaved repetitions). Modes:
// quick, full, tiny (tiny uses quick's caps). A solver added with registerSolver() has no rule
// and is never skipped; budgetRules() is the one place to give it one.
#pragma once

#include <optional>
#include <string>
#include <vector>

namespace minv {

struct SkipRule {
  const char* solver;
  const char* family;
  const char* topology;
  int quick_max_n, full_max_n;  // tiny uses quick's caps
  const char* reason;
};

// The rules in the order they are tried (the first match decides).
const std::vector<SkipRule>& skipRules();

// The reason a point is not measured, with the mode's cap, or nothing.
std::optional<std::string> skipReason(const std::string& solver, const std::string& family,
                                      const std::string& topology, int n, const std::string& mode);

}  // namespace minv
