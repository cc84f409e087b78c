// The pieces an outside user touches: registering a solver (name rules, duplicates, reserved
// words, removal), and configuration files (generators/model_io.hpp: readConfiguration), each
// bad input with its message.
#include <gtest/gtest.h>

#include <sstream>

#include "generators/model_io.hpp"
#include "generators/random_tree.hpp"
#include "solvers/solver.hpp"

namespace minv {
namespace {

SolverEntry entryNamed(const std::string& name) {
  return {name, "a test solver", [] { return makeSolver("lapack"); }, {}};
}

// The message of the std::invalid_argument that `f` throws ("" if none).
template <class F>
std::string thrown(F&& f) {
  try {
    f();
  } catch (const std::exception& e) {
    return e.what();
  }
  return "";
}

TEST(Registry, NamesAreValidated) {
  EXPECT_EQ(solverNameProblem("abi"), "");
  EXPECT_EQ(solverNameProblem("eigen-ldlt"), "");
  EXPECT_EQ(solverNameProblem("my_solver2"), "");
  EXPECT_NE(solverNameProblem(""), "");
  EXPECT_NE(solverNameProblem("-x"), "");
  EXPECT_NE(solverNameProblem("a b"), "");
  EXPECT_NE(solverNameProblem("a/b"), "");
  EXPECT_NE(solverNameProblem(std::string(33, 'a')), "");
  EXPECT_NE(solverNameProblem("all"), "");
  EXPECT_NE(solverNameProblem("test-impulse"), "");
  EXPECT_NE(solverNameProblem("contact-inertia"), "");
  EXPECT_NE(solverNameProblem("mujoco-step"), "");
  EXPECT_NE(thrown([] { registerSolver(entryNamed("bad name")); }).find("character ' '"),
            std::string::npos);
}

TEST(Registry, RegisterFindAndRemove) {
  const std::size_t before = solverRegistry().size();
  registerSolver(entryNamed("eigen-ldlt-test"));
  ASSERT_NE(findSolver("eigen-ldlt-test"), nullptr);
  EXPECT_EQ(solverRegistry().size(), before + 1);
  EXPECT_EQ(solverNames().back(), "eigen-ldlt-test");
  // A second registration under the same name, and a built-in name, are refused.
  EXPECT_NE(thrown([] { registerSolver(entryNamed("eigen-ldlt-test")); }).find("already"),
            std::string::npos);
  EXPECT_NE(thrown([] { registerSolver(entryNamed("abi")); }).find("already"), std::string::npos);
  // No summary, or no factory.
  EXPECT_NE(thrown([] { registerSolver({"x1", "", [] { return makeSolver("abi"); }, {}}); }), "");
  EXPECT_NE(thrown([] { registerSolver({"x2", "s", nullptr, {}}); }), "");
  EXPECT_TRUE(unregisterSolver("eigen-ldlt-test"));
  EXPECT_FALSE(unregisterSolver("eigen-ldlt-test"));
  EXPECT_FALSE(unregisterSolver("abi"));  // built-in solvers stay
  EXPECT_EQ(findSolver("eigen-ldlt-test"), nullptr);
  EXPECT_EQ(solverRegistry().size(), before);
}

// A floating-base tree with a spherical joint: q names of every kind.
Model mixedModel() {
  return randomTree({Topology::Serial, 4, 3, true, JointSet::Mixed});
}

Eigen::VectorXd readText(const Model& m, const std::string& text) {
  std::istringstream in(text);
  return readConfiguration(m, in, "q.txt");
}

TEST(Configuration, PlainNumbers) {
  const Model m = randomTree({Topology::Serial, 3, 1, false, JointSet::Revolute});
  const Eigen::VectorXd q = readText(m, "# three angles\n0.5 -1\n  2.25  # last\n");
  ASSERT_EQ(q.size(), 3);
  EXPECT_EQ(q(0), 0.5);
  EXPECT_EQ(q(1), -1.0);
  EXPECT_EQ(q(2), 2.25);
}

TEST(Configuration, NamesKeepNeutralElsewhere) {
  const Model m = mixedModel();
  const std::vector<std::string> names = m.qNames();
  ASSERT_EQ(static_cast<int>(names.size()), m.nq());
  EXPECT_EQ(names[0], "base_x");
  EXPECT_EQ(names[3], "base_qw");
  // Set the base height and one joint; everything else stays neutral.
  const std::string joint = names[7];
  const Eigen::VectorXd q = readText(m, "base_z 0.75\n" + joint + " 0.25\n");
  Eigen::VectorXd expect = m.neutral();
  expect(2) = 0.75;
  expect(7) = 0.25;
  EXPECT_EQ(q, expect);
}

TEST(Configuration, BadInputsNameTheProblem) {
  const Model m = mixedModel();
  auto message = [&](const std::string& text) { return thrown([&] { readText(m, text); }); };
  EXPECT_NE(message("1 2 3").find("3 numbers, the model needs nq = " + std::to_string(m.nq())),
            std::string::npos);
  EXPECT_NE(message("nope 1").find("unknown q name 'nope'"), std::string::npos);
  // Control bytes are refused by their code (a NUL cut the quoted name short)
  EXPECT_NE(
      message(std::string("base_z 1\nj0\0 1", 14)).find(":2: not a text line (control byte 0x00)"),
      std::string::npos);
  EXPECT_NE(message("\x1b[31mred 1").find("control byte 0x1b"), std::string::npos);
  EXPECT_EQ(message("base_z\t1\r\n"), "");
  EXPECT_EQ(message("base_z\f1\v # a comment may hold anything: \x1b\n"), "");
  EXPECT_NE(message("base_z 1\nbase_z 2").find("already given on line 1"), std::string::npos);
  EXPECT_NE(message("base_z nan").find("is not a finite number"), std::string::npos);
  EXPECT_NE(message("base_z 1e999").find("'1e999' is beyond the range of a double"),
            std::string::npos);
  EXPECT_NE(message("base_z 1x").find("'1x' is not a number"), std::string::npos);
  // A subnormal value is a finite number; nan as the first word is an entry, not a name.
  EXPECT_EQ(message("base_z 1e-320"), "");
  EXPECT_NE(message("nan").find("entry q[0] 'nan' is not a finite number"), std::string::npos);
  EXPECT_NE(message("base_qw 0").find("zero quaternion"), std::string::npos);
  EXPECT_NE(message("# nothing\n").find("no configuration"), std::string::npos);
  EXPECT_NE(message("base_z").find("expected 'name value'"), std::string::npos);
  // Every message names the file and, where there is one, the line.
  EXPECT_EQ(message("nope 1").rfind("q.txt:1: ", 0), 0u);
}

}  // namespace
}  // namespace minv
