// The timing harness: sweep definition, shards, skip table, merge, and a sweep killed with
// SIGKILL midway that resumes without losing or rerunning a finished point. Runs the real
// bench_timing binary (built next to minv) on the tiny sweep.
#include "experiments/lib/timing.hpp"

#include <fcntl.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>
#include <string>
#include <thread>

#include "experiments/lib/h5reader.hpp"
#include "solvers/solver.hpp"
#include "tests/test_util.hpp"

namespace fs = std::filesystem;
using minv::test::shell;
using minv::test::slurp;
using minv::test::tempDir;
using namespace minv;

namespace {

fs::path benchBinary() {
  return fs::path(MINV_CLI).parent_path() / "bench_timing";
}

int countFinishedLines(const fs::path& log) {
  std::ifstream in(log);
  std::string line;
  int k = 0;
  while (std::getline(in, line))
    if (!line.empty() && line[0] == '[') ++k;
  return k;
}

// Attributes that describe the point itself (not when/where it was measured).
const char* kIdentity[] = {"family",    "solver", "topology", "base", "n",    "nv",    "nb",
                           "max_depth", "m",      "threads",  "seed", "mode", "status"};

}  // namespace

TEST(Timing, ShardParsing) {
  const Shard s = parseShard("1/3");
  EXPECT_EQ(s.index, 1);
  EXPECT_EQ(s.count, 3);
  for (const char* bad : {"3/3", "1", "a/2", "-1/2", "1/0", "", "1/2/3"})
    EXPECT_THROW(parseShard(bad), std::invalid_argument) << bad;
}

TEST(Timing, ShardsPartitionTheSweep) {
  for (const char* mode : {"tiny", "quick", "full"}) {
    const std::vector<TimingPoint> all = sweepPoints(timingSweep(mode));
    std::set<std::string> names;
    for (const auto& p : all)
      EXPECT_TRUE(names.insert(p.name()).second) << "duplicate " << p.name();
    std::set<std::string> seen;
    std::size_t total = 0;
    for (int i = 0; i < 3; ++i) {
      const auto part = shardPoints(all, {i, 3});
      total += part.size();
      for (const auto& p : part) seen.insert(p.name());
      const auto again = shardPoints(all, {i, 3});  // deterministic
      ASSERT_EQ(again.size(), part.size());
      for (std::size_t k = 0; k < part.size(); ++k) EXPECT_EQ(again[k].name(), part[k].name());
    }
    EXPECT_EQ(total, all.size());
    EXPECT_EQ(seen, names);
  }
}

TEST(Timing, QuickSweepCoversTheIssue) {
  const std::vector<TimingPoint> all = sweepPoints(timingSweep("quick"));
  std::set<std::string> families, solvers;
  std::set<int> ms, threads;
  int max_n = 0;
  bool floating = false;
  for (const auto& p : all) {
    families.insert(p.family), solvers.insert(p.solver), ms.insert(p.m), threads.insert(p.threads);
    max_n = std::max(max_n, p.n);
    floating |= p.floating;
  }
  EXPECT_EQ(families, (std::set<std::string>{"pipeline", "kernel", "threads"}));
  EXPECT_EQ(ms, (std::set<int>{0, 1, 8, 64}));
  EXPECT_EQ(threads, (std::set<int>{1, 2, 4}));
  EXPECT_EQ(max_n, 1024);
  EXPECT_TRUE(floating);
  for (const std::string& s : solverNames()) EXPECT_TRUE(solvers.count(s)) << s;
  int full_max = 0;
  for (const auto& p : sweepPoints(timingSweep("full"))) full_max = std::max(full_max, p.n);
  EXPECT_EQ(full_max, 4096);
  EXPECT_THROW(timingSweep("medium"), std::invalid_argument);
}

// The skip table (experiments/lib/budget.cpp) as data that can be wrong: every rule must name a
// solver that can be registered, a known family and topology, caps with quick ≤ full, a reason,
// and must be reachable (no earlier rule matches everything it matches, which would make it
// dead). A reason reaches the point with the mode's cap.
TEST(Timing, SkipTableIsConsistent) {
  const std::vector<std::string> names = solverNames();
  std::set<std::string> solvers(names.begin(), names.end());
  for (const char* optional : {"mujoco", "dart", "bullet"}) solvers.insert(optional);
  const std::set<std::string> families = {"*", "pipeline", "kernel", "threads", "accuracy", "perf"};
  const std::set<std::string> topologies = {"*", "serial", "branched"};
  auto covers = [](const char* a, const char* b) {
    return std::string(a) == "*" || std::string(a) == b;
  };
  const std::vector<SkipRule>& rules = skipRules();
  for (std::size_t j = 0; j < rules.size(); ++j) {
    const SkipRule& r = rules[j];
    EXPECT_TRUE(std::string(r.solver) == "*" || solvers.count(r.solver)) << r.solver;
    EXPECT_TRUE(families.count(r.family)) << r.family;
    EXPECT_TRUE(topologies.count(r.topology)) << r.topology;
    EXPECT_LE(r.quick_max_n, r.full_max_n) << r.solver;
    EXPECT_GT(std::string(r.reason).size(), 10u) << r.solver;
    for (std::size_t i = 0; i < j; ++i)
      EXPECT_FALSE(covers(rules[i].solver, r.solver) && covers(rules[i].family, r.family) &&
                   covers(rules[i].topology, r.topology))
          << "rule " << j << " (" << r.solver << ", " << r.family << ", " << r.topology
          << ") is dead: rule " << i << " matches everything it matches";
  }
  // The first matching rule decides, and its cap and reason reach the point.
  for (const SkipRule& r : rules) {
    if (std::string(r.solver) == "*" || std::string(r.family) == "*") continue;
    const std::string topo = std::string(r.topology) == "*" ? "serial" : r.topology;
    EXPECT_FALSE(skipReason(r.solver, r.family, topo, r.quick_max_n, "quick"));
    const auto why = skipReason(r.solver, r.family, topo, r.quick_max_n + 1, "quick");
    ASSERT_TRUE(why) << r.solver;
    EXPECT_NE(why->find(r.reason), std::string::npos);
    EXPECT_NE(why->find("at n = " + std::to_string(r.quick_max_n)), std::string::npos) << *why;
  }
  // A solver without a rule is never skipped.
  EXPECT_FALSE(skipReason("abi", "pipeline", "serial", 4096, "full"));
}

TEST(Timing, LogSpaced) {
  EXPECT_EQ(logSpaced(8, 64, 1), (std::vector<int>{8, 16, 32, 64}));
  EXPECT_EQ(logSpaced(8, 32, 2), (std::vector<int>{8, 11, 16, 23, 32}));
}

// A sweep killed (SIGKILL) after some points finished keeps them, and the rerun completes the
// sweep without rerunning them: their raw times are bit-identical.
TEST(Timing, KilledSweepResumesWithoutLosingPoints) {
  ASSERT_TRUE(fs::exists(benchBinary()))
      << benchBinary() << " is missing: build the bench_timing target";
  const fs::path dir = tempDir("resume");
  const fs::path out = dir / "t.h5", log = dir / "first.log";
  const std::size_t total = sweepPoints(timingSweep("tiny")).size();
  // Everything the child needs is built before fork (only async-signal-safe calls after it).
  const std::string bin = benchBinary().string(), o = out.string(), l = log.string();
  const pid_t child = fork();
  ASSERT_GE(child, 0);
  if (child == 0) {
    const int fd = ::open(l.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    dup2(fd, 1);
    dup2(fd, 2);
    execl(bin.c_str(), bin.c_str(), "--mode", "tiny", "--min-time", "0.05", "--out", o.c_str(),
          static_cast<char*>(nullptr));
    _exit(127);
  }
  // Kill it once two points are on disk (the driver logs a point after endPoint's flush).
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
  while (countFinishedLines(log) < 2 && std::chrono::steady_clock::now() < deadline)
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  kill(child, SIGKILL);
  int status = 0;
  waitpid(child, &status, 0);
  ASSERT_TRUE(WIFSIGNALED(status)) << "the sweep finished before it could be killed:\n"
                                   << slurp(log);
  const auto before = readPoints(out.string());
  ASSERT_GE(before.size(), 2u);
  ASSERT_LT(before.size(), total) << "nothing left to resume";

  // Other settings would mix points measured two ways: refused, the file untouched.
  const std::string other = (dir / "other.log").string();
  EXPECT_EQ(shell(benchBinary().string() + " --mode tiny --min-time 0.002 --out " + out.string() +
                  " > " + other + " 2>&1"),
            2)
      << slurp(other);
  EXPECT_NE(slurp(other).find("holds points made with min_time_s '0.05' (this run: '0.002')"),
            std::string::npos)
      << slurp(other);
  EXPECT_EQ(readPoints(out.string()).size(), before.size());
  ASSERT_EQ(shell(benchBinary().string() + " --mode tiny --min-time 0.05 --out " + out.string() +
                  " > " + (dir / "second.log").string() + " 2>&1"),
            0)
      << slurp(dir / "second.log");
  EXPECT_NE(slurp(dir / "second.log").find(std::to_string(before.size()) + " already in"),
            std::string::npos)
      << slurp(dir / "second.log");
  const auto after = readPoints(out.string());
  EXPECT_EQ(after.size(), total);
  for (const auto& [name, rec] : before) {
    ASSERT_TRUE(after.count(name)) << name;
    EXPECT_EQ(after.at(name).real_s, rec.real_s) << name << " was rerun";
    EXPECT_EQ(after.at(name).attrs.at("date_utc"), rec.attrs.at("date_utc")) << name;
  }
  for (const auto& [name, rec] : after) {
    EXPECT_EQ(rec.attrs.at("status"), "ok") << name;
    EXPECT_FALSE(rec.real_s.empty()) << name;
    EXPECT_EQ(rec.parent.size(), static_cast<std::size_t>(std::stoi(rec.attrs.at("n")))) << name;
  }
  fs::remove_all(dir);
}

// Shards run apart and merged give the same points as one process (identity attributes and
// parent arrays; the times are measurements and differ).
TEST(Timing, MergedShardsEqualOneProcess) {
  ASSERT_TRUE(fs::exists(benchBinary())) << benchBinary() << " is missing";
  const fs::path dir = tempDir("merge");
  const std::string bench = benchBinary().string() + " --mode tiny --min-time 0.001 ";
  ASSERT_EQ(shell(bench + "--out " + (dir / "one.h5").string() + " > /dev/null"), 0);
  for (int i = 0; i < 2; ++i)
    ASSERT_EQ(shell(bench + "--shard " + std::to_string(i) + "/2 --out " +
                    (dir / ("s" + std::to_string(i) + ".h5")).string() + " > /dev/null"),
              0);
  ASSERT_EQ(shell(std::string(MINV_CLI) + " merge --out " + (dir / "merged.h5").string() + " " +
                  (dir / "s0.h5").string() + " " + (dir / "s1.h5").string() + " > /dev/null"),
            0);
  const auto one = readPoints((dir / "one.h5").string());
  const auto merged = readPoints((dir / "merged.h5").string());
  ASSERT_EQ(merged.size(), one.size());
  for (const auto& [name, rec] : one) {
    ASSERT_TRUE(merged.count(name)) << name;
    for (const char* key : kIdentity)
      EXPECT_EQ(merged.at(name).attrs.at(key), rec.attrs.at(key)) << name << " " << key;
    EXPECT_EQ(merged.at(name).parent, rec.parent) << name;
    EXPECT_EQ(merged.at(name).real_s.size(), rec.real_s.size()) << name;
  }
  // A point in two inputs is an error; a failed merge leaves no output file.
  EXPECT_EQ(shell(std::string(MINV_CLI) + " merge --out " + (dir / "dup.h5").string() + " " +
                  (dir / "s0.h5").string() + " " + (dir / "s0.h5").string() + " 2> /dev/null"),
            2);
  EXPECT_FALSE(fs::exists(dir / "dup.h5"));
  EXPECT_FALSE(fs::exists(dir / "dup.h5.tmp"));
  // Shards measured with other settings are not one sweep.
  ASSERT_EQ(shell(benchBinary().string() + " --mode tiny --min-time 0.002 --shard 1/2 --out " +
                  (dir / "s1b.h5").string() + " > /dev/null"),
            0);
  const std::string mixed = (dir / "mixed.log").string();
  EXPECT_EQ(shell(std::string(MINV_CLI) + " merge --out " + (dir / "mix.h5").string() + " " +
                  (dir / "s0.h5").string() + " " + (dir / "s1b.h5").string() + " 2> " + mixed),
            2);
  EXPECT_NE(slurp(mixed).find("was measured with min_time_s '0.002' (not '0.001')"),
            std::string::npos)
      << slurp(mixed);
  EXPECT_FALSE(fs::exists(dir / "mix.h5"));
  EXPECT_EQ(shell(std::string(MINV_CLI) + " merge --out " + (dir / "x.h5").string() +
                  " /nonexistent.h5 2> /dev/null"),
            2);
  EXPECT_EQ(shell(benchBinary().string() + " --shard 2/2 --out " + (dir / "y.h5").string() +
                  " 2> /dev/null"),
            2);
  fs::remove_all(dir);
}
