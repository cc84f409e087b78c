// Replays every committed fuzz input through the contract its libFuzzer target checks, without
// libFuzzer: each file of tests/fuzz/corpus/<target>/ (the seeds) and of
// tests/fuzz/regressions/<target>/ (every finding so far) must satisfy tests/fuzz/contracts.hpp
// — the loader returns a valid model or throws ModelError. One test per target; a failure names
// the file and the violation. Each input runs in a child process, so an input that still
// crashes (a signal) or hangs (over kTimeoutSeconds) fails this test and not the test binary.
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <sstream>
#include <string>
#include <vector>

#include "tests/fuzz/contracts.hpp"

namespace minv {
namespace {

namespace fs = std::filesystem;
using Check = std::function<std::string(std::string_view)>;

// A replayed input that runs longer than this counts as a hang (scripts/fuzz's -timeout).
constexpr unsigned kTimeoutSeconds = 10;

// The files of tests/fuzz/<kind>/<target>/, sorted; none if the folder does not exist.
std::vector<fs::path> inputs(const std::string& kind, const std::string& target) {
  const fs::path dir = fs::path(MINV_SOURCE_DIR) / "tests" / "fuzz" / kind / target;
  std::vector<fs::path> files;
  if (fs::is_directory(dir))
    for (const fs::directory_entry& e : fs::directory_iterator(dir))
      if (e.is_regular_file()) files.push_back(e.path());
  std::sort(files.begin(), files.end());
  return files;
}

// The whole file, as bytes.
std::string contents(const fs::path& path) {
  std::ifstream f(path, std::ios::binary);
  std::ostringstream s;
  s << f.rdbuf();
  return s.str();
}

// check(data) in a child process: its violation, or how the child died; "" if the contract holds.
std::string isolated(const Check& check, const std::string& data) {
  int fd[2];
  if (pipe(fd) != 0) return "cannot create a pipe";
  std::fflush(nullptr);
  const pid_t pid = fork();
  if (pid < 0) return "cannot fork";
  if (pid == 0) {
    // The child: the check, its message down the pipe, no GoogleTest epilogue.
    close(fd[0]);
    alarm(kTimeoutSeconds);
    const std::string violation = check(data);
    for (std::size_t done = 0; done < violation.size();) {
      const ssize_t n = write(fd[1], violation.data() + done, violation.size() - done);
      if (n <= 0) _exit(3);
      done += static_cast<std::size_t>(n);
    }
    _exit(0);
  }
  // The parent: the message, then the child's fate.
  close(fd[1]);
  std::string out;
  char buf[4096];
  for (ssize_t n; (n = read(fd[0], buf, sizeof buf)) > 0;)
    out.append(buf, static_cast<std::size_t>(n));
  close(fd[0]);
  int status = 0;
  waitpid(pid, &status, 0);
  if (WIFSIGNALED(status))
    return WTERMSIG(status) == SIGALRM
               ? "hangs: still running after " + std::to_string(kTimeoutSeconds) + " s"
               : "crashed with signal " + std::to_string(WTERMSIG(status)) + " (" +
                     strsignal(WTERMSIG(status)) + ")";
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0)
    return "the check exited with status " + std::to_string(WEXITSTATUS(status));
  return out;
}

// Every seed and regression input of a target through its contract; the corpus must not be empty.
void replay(const std::string& target, const Check& check) {
  unsetenv("MINV_FUZZ_SKIP");  // every check counts here
  const std::vector<fs::path> corpus = inputs("corpus", target);
  EXPECT_FALSE(corpus.empty()) << "no seed corpus in tests/fuzz/corpus/" << target;
  std::vector<fs::path> all = corpus;
  for (const fs::path& p : inputs("regressions", target)) all.push_back(p);
  for (const fs::path& p : all) {
    SCOPED_TRACE(p.string());
    EXPECT_EQ(isolated(check, contents(p)), "") << "input: " << p;
  }
}

TEST(FuzzRegressions, Json) {
  replay("json", fuzz::checkJsonInput);
}

TEST(FuzzRegressions, Urdf) {
  replay("urdf", fuzz::checkUrdfInput);
}

TEST(FuzzRegressions, Configuration) {
  replay("configuration", fuzz::checkConfigurationInput);
}

TEST(FuzzRegressions, Mjcf) {
#ifdef MINV_HAVE_MUJOCO
  replay("mjcf", fuzz::checkMjcfInput);
#else
  GTEST_SKIP() << "this build has no MuJoCo";
#endif
}

// The fixed model of the configuration target is what its file comment says.
TEST(FuzzRegressions, ConfigurationModel) {
  const Model& m = fuzz::configurationModel();
  EXPECT_EQ(m.nb(), 5);
  EXPECT_EQ(m.nq(), 14);
  EXPECT_EQ(m.nv(), 12);
  EXPECT_EQ(fuzz::checkModel(m, "configurationModel"), "");
  // Its slider may go to ±kMaxLength without carrying the hand to where it is a point mass
  // (validConfiguration leaves that rule of checkConfiguration out).
  Eigen::VectorXd q = m.neutral();
  for (const double d : {-kMaxLength, kMaxLength}) {
    q(m.qIdx(3)) = d;
    EXPECT_NO_THROW(m.checkConfiguration(q));
  }
}

// M may fail LLT only by rounding: the committed heavy tip on a straight chain (1e29 kg on two
// 1 kg links, all joints about z along x: the tip cannot move along the chain) is singular to
// double precision and excused; a well-conditioned M with a flipped diagonal is not, nor is the
// heavy tip's M with a diagonal entry off by far more than rounding.
TEST(FuzzRegressions, OnlyASingularMMayFailItsFactorisation) {
  const Model tip = loadUrdf((fs::path(MINV_SOURCE_DIR) / "tests" / "fuzz" / "regressions" /
                              "urdf" / "heavy_tip_on_straight_chain_singular_to_double.urdf")
                                 .string(),
                             false);
  const Eigen::VectorXd q0 = tip.neutral();
  // (whether its LLT fails depends on the rounding: it did here, with GCC 12 at -O2)
  const Eigen::MatrixXd M = massMatrix(tip, q0);
  EXPECT_NE(fuzz::indefiniteByRounding(tip, q0, M).find("indefinite by rounding"),
            std::string::npos);
  EXPECT_EQ(fuzz::checkMassMatrix(tip, q0, M, "tip"), "");
  Eigen::MatrixXd off = M;
  off(0, 0) = -1e-3 * M(0, 0);
  EXPECT_EQ(fuzz::indefiniteByRounding(tip, q0, off), "");
  EXPECT_NE(fuzz::checkMassMatrix(tip, q0, off, "tip").find("not positive definite"),
            std::string::npos);
  const Model& m = fuzz::configurationModel();
  const Eigen::VectorXd q = m.neutral();
  Eigen::MatrixXd bad = massMatrix(m, q);
  bad(4, 4) = -bad(4, 4);
  EXPECT_EQ(fuzz::indefiniteByRounding(m, q, bad), "");
  EXPECT_NE(fuzz::checkMassMatrix(m, q, bad, "flipped").find("not positive definite"),
            std::string::npos);
}

}  // namespace
}  // namespace minv
