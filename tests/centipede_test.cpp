// The centipede model and the `minv generate --topology centipede` / `minv simulate` commands.
#include "generators/centipede.hpp"

#include <gtest/gtest.h>

#include <array>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>

#include "core/kinematics.hpp"
#include "tests/test_util.hpp"

namespace minv {
namespace {

TEST(Centipede, SizesAndNumbering) {
  for (int S : {1, 2, 7}) {
    const Centipede c = makeCentipede({.segments = S});
    EXPECT_EQ(c.model.nb(), 5 * S);
    EXPECT_EQ(c.model.nv(), 9 * S + 5);
    EXPECT_EQ(c.legs(), 2 * S);
    EXPECT_TRUE(c.model.floatingBase());
    for (int i = 1; i < c.model.nb(); ++i) EXPECT_LT(c.model.parent(i), i);
    const Centipede sph = makeCentipede({.segments = S, .segment_joint = SegmentJoint::Spherical});
    EXPECT_EQ(sph.model.nv(), 6 + 3 * (S - 1) + 8 * S);
  }
  EXPECT_EQ(makeCentipede({.segments = 250}).model.nv(), 2255);
  EXPECT_THROW(makeCentipede({.segments = 0}), ModelError);
}

// Standing: every tip exactly on the plane, the segments lower_length above it.
TEST(Centipede, StandsOnItsTips) {
  const Centipede c = makeCentipede({.segments = 5});
  const Eigen::VectorXd q = centipedeStanding(c);
  Kinematics<double> kin(c.model);
  computeKinematics<double>(c.model, q, kin);
  for (int l = 0; l < c.legs(); ++l) {
    const Pose<double>& X = kin.X[c.lower_body[l]];
    EXPECT_NEAR((X.p + X.R * c.tip).z(), 0.0, 1e-15);
  }
  for (int b : c.segment_body) EXPECT_NEAR(kin.X[b].p.z(), c.options.lower_length, 1e-15);
}

// A file in this process's own scratch folder, removed at exit: the unit tests run in shards,
// several processes at once.
std::string scratchFile(const std::string& name) {
  static const struct Scratch {
    std::filesystem::path dir = test::tempDir("centipede_test");
    ~Scratch() {
      std::error_code ec;
      std::filesystem::remove_all(dir, ec);
    }
  } scratch;
  return (scratch.dir / name).string();
}

std::string run(const std::string& args, int* status) {
  std::array<char, 4096> buf;
  std::string out;
  const std::string cmd = std::string(MINV_CLI) + " " + args + " 2>&1";
  FILE* f = popen(cmd.c_str(), "r");
  while (fgets(buf.data(), buf.size(), f)) out += buf.data();
  *status = WEXITSTATUS(pclose(f));
  return out;
}

TEST(CentipedeCli, GeneratePrintsTheDofCount) {
  const std::string path = scratchFile("centipede.json");
  int status = 0;
  const std::string out = run("generate --topology centipede --segments 5 --out " + path, &status);
  EXPECT_EQ(status, 0) << out;
  EXPECT_NE(out.find("nv=50"), std::string::npos) << out;
  EXPECT_TRUE(std::filesystem::exists(path));
  std::filesystem::remove(path);
  const std::string bad = run("generate --topology centipede --segments 0 --out " + path, &status);
  EXPECT_EQ(status, 2);
  EXPECT_EQ(bad.rfind("minv: error: ", 0), 0u) << bad;
  EXPECT_FALSE(std::filesystem::exists(path));
}

// The acceptance run: `minv simulate centipede --segments 20` walks forward.
TEST(CentipedeCli, TwentySegmentsWalkForward) {
  int status = 0;
  const std::string out = run("simulate centipede --segments 20", &status);
  ASSERT_EQ(status, 0) << out;
  const auto at = out.find("centre of mass dx=");
  ASSERT_NE(at, std::string::npos) << out;
  const double dx = std::stod(out.substr(at + 18));
  EXPECT_GT(dx, 0.1) << out;  // metres in the default 3 s walk (measured 0.38)
}

TEST(CentipedeCli, SimulateErrorsAreOneLine) {
  const std::string path = scratchFile("sim_bad.h5");
  int status = 0;
  std::string out =
      run("simulate centipede --segments 3 --steps 5 --solver nope --out " + path, &status);
  EXPECT_EQ(status, 2);
  EXPECT_EQ(out.rfind("minv: error: ", 0), 0u) << out;
  EXPECT_FALSE(std::filesystem::exists(path));
  out = run("simulate centipede --segments 3 --dt -1 --out " + path, &status);
  EXPECT_EQ(status, 2);
  EXPECT_FALSE(std::filesystem::exists(path));
  out = run("simulate centipede --segments 3 --dt inf --out " + path, &status);
  EXPECT_EQ(status, 2);
  EXPECT_NE(out.find("--dt must be a step in (0, 1] s"), std::string::npos) << out;
  // 0 and a team OpenMP cannot start (65 536 crashed libgomp) are both refused.
  for (const char* threads : {"0", "65536"}) {
    out =
        run("simulate centipede --segments 3 --threads " + std::string(threads) + " --out " + path,
            &status);
    EXPECT_EQ(status, 2);
    EXPECT_NE(out.find("--threads must be between 1 and 512, got " + std::string(threads)),
              std::string::npos)
        << out;
    EXPECT_FALSE(std::filesystem::exists(path));
  }
  // A sweep refused for its options leaves no file (it once left one with provenance only).
  for (const char* bad : {"--steps 0", "--dt nan", "--dt -1", "--threads 65536"}) {
    out = run("simulate sweep --segments 1 --solvers abi " + std::string(bad) + " --out " + path,
              &status);
    EXPECT_EQ(status, 2) << bad;
    EXPECT_EQ(out.rfind("minv: error: ", 0), 0u) << out;
    EXPECT_FALSE(std::filesystem::exists(path)) << bad;
  }
}

// The net displacement line of a short walk.
std::string displacement(const std::string& args) {
  int status = 0;
  const std::string out = run("simulate centipede --segments 4 --steps 400 " + args, &status);
  EXPECT_EQ(status, 0) << out;
  const auto at = out.find("net displacement:");
  return at == std::string::npos ? out : out.substr(at);
}

// Two threads split only work whose result does not depend on the split (the contact-inertia
// pair blocks by rows, the test-impulse columns): the same walk to the last printed digit.
TEST(CentipedeCli, TwoThreadsWalkTheSame) {
  for (const char* path : {"contact-inertia", "test-impulse"}) {
    const std::string solver = std::string("--dt 1e-3 --solver ") + path;  // moves millimetres
    EXPECT_EQ(displacement(solver + " --threads 2"), displacement(solver)) << path;
  }
  // A sweep names its points on more than one thread <path>@<threads>.
  const std::string path = scratchFile("sweep_t2.h5");
  std::filesystem::remove(path);
  int status = 0;
  const std::string out = run(
      "simulate sweep --segments 2 --steps 3 --solvers contact-inertia --threads 2 --out " + path,
      &status);
  EXPECT_EQ(status, 0) << out;
  EXPECT_NE(out.find("contact-inertia@2"), std::string::npos) << out;
  std::filesystem::remove(path);
}

// A sweep resumes into its file only where the points already there walked as this run's
// would: a point of other steps is refused (it was kept and counted as done), a new point of
// other steps is added (scripts/reproduce adds S = 250 with fewer steps), and a file of
// another experiment is refused.
TEST(CentipedeCli, SweepResumesOnlyItsOwnSettings) {
  const std::string path = scratchFile("sweep_resume.h5");
  const std::string timing = scratchFile("sweep_resume_timing.h5");
  std::filesystem::remove(path);
  std::filesystem::remove(timing);
  int status = 0;
  std::string out =
      run("simulate sweep --segments 2 --steps 3 --solvers abi --out " + path, &status);
  ASSERT_EQ(status, 0) << out;
  out = run("simulate sweep --segments 2 --steps 4 --solvers abi --out " + path, &status);
  EXPECT_EQ(status, 2) << out;
  EXPECT_NE(out.find("holds point S2/abi made with steps '3' (this run: '4')"), std::string::npos)
      << out;
  out = run("simulate sweep --segments 3 --steps 4 --solvers abi --out " + path, &status);
  EXPECT_EQ(status, 0) << out;
  out = run("simulate sweep --segments 2,3 --steps 3 --solvers abi --out " + path, &status);
  EXPECT_EQ(status, 2) << out;
  EXPECT_NE(out.find("holds point S3/abi made with steps '4' (this run: '3')"), std::string::npos)
      << out;
  out = run("time --mode tiny --solvers lapack --min-time 0.001 --repetitions 1 --out " + timing,
            &status);
  ASSERT_EQ(status, 0) << out;
  out = run("simulate sweep --segments 2 --steps 3 --solvers abi --out " + timing, &status);
  EXPECT_EQ(status, 2) << out;
  EXPECT_NE(out.find("holds experiment 'timing', not 'centipede'"), std::string::npos) << out;
  out = run("time --mode tiny --solvers lapack --min-time 0.001 --repetitions 1 --out " + path,
            &status);
  EXPECT_EQ(status, 2) << out;
  EXPECT_NE(out.find("holds experiment 'centipede', not 'timing'"), std::string::npos) << out;
  std::filesystem::remove(path);
  std::filesystem::remove(timing);
}

}  // namespace
}  // namespace minv
