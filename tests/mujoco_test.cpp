// MuJoCo as an independent check of the whole model pipeline, and the `mujoco` solver and MJCF
// import: our CRBA's M against MuJoCo's mj_fullM on the same random trees (serial, branched,
// floating base, ball and slide joints, deep chains split across <include>d files), the
// solver's M⁻¹ and M⁻¹R against Eigen's LLT of our M, and MJCF files read through MuJoCo's
// parser against MuJoCo's own M for the same file.
#ifdef MINV_HAVE_MUJOCO

#include "solvers/mujoco.hpp"

#include <gtest/gtest.h>
#include <unistd.h>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cstdio>
#include <fstream>
#include <limits>
#include <string>

#include "core/crba.hpp"
#include "generators/mjcf.hpp"
#include "generators/random_tree.hpp"
#include "tests/model_error.hpp"

namespace minv {
namespace {

double relError(const Eigen::MatrixXd& A, const Eigen::MatrixXd& B) {
  return (A - B).norm() / B.norm();
}

std::string caseName(const TreeOptions& o) {
  return std::string(topologyName(o.topology)) + "_" + jointSetName(o.joints) +
         (o.floating_base ? "_floating" : "_fixed") + "_n" + std::to_string(o.n);
}

std::vector<TreeOptions> randomCases(std::initializer_list<int> sizes) {
  std::vector<TreeOptions> out;
  for (int n : sizes)
    for (Topology t : {Topology::Serial, Topology::Branched})
      for (bool floating : {false, true})
        for (JointSet j : {JointSet::Revolute, JointSet::Mixed})
          out.push_back({t, n, static_cast<std::uint64_t>(77 + n), floating, j});
  return out;
}

// (a) Our CRBA equals MuJoCo's mj_fullM, mapped to our coordinates (DOF permutation and the
// free joint's congruence), to 1e-10 relative.
TEST(Mujoco, CrbaEqualsMujocoFullM) {
  for (const TreeOptions& o : randomCases({1, 5, 30, 90, 150})) {
    const Model model = randomTree(o);
    MujocoSolver solver;
    ASSERT_TRUE(solver.supports(model, nullptr)) << caseName(o);
    solver.prepare(model);
    for (std::uint64_t seed : {1, 2}) {
      const Eigen::VectorXd q = randomConfiguration(model, seed);
      solver.configure(q);
      const Eigen::MatrixXd M = massMatrix(model, q);
      EXPECT_LT(relError(solver.massMatrix(), M), 1e-10) << caseName(o) << " seed " << seed;
    }
  }
}

// The free-joint congruence alone, on one free body with a placement: MuJoCo's M in its
// [v (world); ω (local)] coordinates differs from ours unless mapped.
TEST(Mujoco, FreeBodyWithPlacement) {
  Joint base;
  base.type = JointType::Floating;
  base.placement.R = Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized()).matrix();
  base.placement.p = {0.3, -0.2, 0.5};
  Body b;
  b.mass = 2.5;
  b.com = {0.1, -0.05, 0.2};
  b.inertia << 0.3, 0.01, 0.02, 0.01, 0.25, -0.03, 0.02, -0.03, 0.2;
  Joint hinge;
  hinge.axis = Eigen::Vector3d(0.2, 1, -0.4).normalized();
  hinge.placement.p = {0.4, 0, 0};
  const Model model = Model::create({-1, 0}, {base, hinge}, {b, b});
  MujocoSolver solver;
  solver.prepare(model);
  const Eigen::VectorXd q = randomConfiguration(model, 5);
  solver.configure(q);
  const Eigen::MatrixXd M = massMatrix(model, q);
  EXPECT_LT(relError(solver.massMatrix(), M), 1e-12);
  Eigen::MatrixXd X(7, 7);
  solver.inverse(X);
  EXPECT_LT((M * X - Eigen::MatrixXd::Identity(7, 7)).norm(), 1e-12);
}

// (b) The solver's M⁻¹ and M⁻¹R against Eigen's LLT of our CRBA M, within the conformance
// suite's bound 10·(n + 10)·κ·ε (solvers/conformance.hpp): it scales with cond(M) and n and
// leaves room for rounding at n = 1, where a bare 8ε failed under -O2 (1.9984e-15 > 1.7764e-15).
TEST(Mujoco, SolverInvertsOurM) {
  for (const TreeOptions& o : randomCases({1, 5, 30, 90})) {
    const Model model = randomTree(o);
    const Eigen::VectorXd q = randomConfiguration(model, 3);
    const Eigen::MatrixXd M = massMatrix(model, q);
    const int n = model.nv();
    auto bound = [n](const Eigen::MatrixXd& A) {
      const Eigen::VectorXd e = Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(A).eigenvalues();
      return 10.0 * (n + 10) * (e(n - 1) / e(0)) * std::numeric_limits<double>::epsilon();
    };
    const double tol = bound(M);
    const Eigen::MatrixXd ref = M.llt().solve(Eigen::MatrixXd::Identity(n, n));
    const Eigen::MatrixXd R = Eigen::MatrixXd::NullaryExpr(
        n, 4, [](Eigen::Index i, Eigen::Index j) { return std::sin(2.0 + 5.0 * i + 3.0 * j); });
    auto solver = makeSolver("mujoco");
    solver->prepare(model);
    solver->configure(q);
    Eigen::MatrixXd X(n, n), Y(n, 4);
    solver->inverse(X);
    solver->solve(R, Y);
    EXPECT_LT(relError(X, ref), tol) << caseName(o);
    EXPECT_LT(relError(Y, ref * R), tol) << caseName(o);
    // A second configuration on the same prepared solver.
    const Eigen::VectorXd q2 = randomConfiguration(model, 4);
    solver->configure(q2);
    solver->inverse(X);
    const Eigen::MatrixXd M2 = massMatrix(model, q2);
    EXPECT_LT((M2 * X - Eigen::MatrixXd::Identity(n, n)).norm() / std::sqrt(n), bound(M2))
        << caseName(o);
  }
}

// (d) Deep trees: tinyxml2 stops one MJCF file at 96 nested bodies, so toMjcf splits the tree
// with <include>; every joint type gets through at any depth.
TEST(Mujoco, DeepChainsLoadThroughIncludes) {
  for (JointSet j : {JointSet::Revolute, JointSet::Mixed}) {
    const TreeOptions o{Topology::Serial, 300, 9, true, j};
    const Model model = randomTree(o);
    const std::vector<MjcfFile> files = toMjcf(model);
    EXPECT_EQ(files.size(), 5u);  // 301 bodies, 64 nested per file
    MujocoSolver solver;
    solver.prepare(model);
    const Eigen::VectorXd q = randomConfiguration(model, 8);
    solver.configure(q);
    EXPECT_LT(relError(solver.massMatrix(), massMatrix(model, q)), 1e-10) << caseName(o);
  }
}

const char* kRobotXml = R"(
<mujoco model="test robot">
  <compiler angle="radian"/>
  <worldbody>
    <body name="floor"><geom type="plane" size="5 5 0.1"/></body>
    <body name="torso" pos="0 0 1">
      <freejoint name="root"/>
      <inertial pos="0.01 -0.02 0.03" mass="4" fullinertia="0.4 0.3 0.2 0.01 -0.02 0.015"/>
      <body name="sensor" pos="0.1 0 0.05" euler="0.3 0.2 0.1">
        <inertial pos="0 0 0.01" mass="0.3" diaginertia="0.002 0.003 0.004"/>
      </body>
      <body name="upper" pos="0.2 0.1 0" quat="0.9 0.1 -0.2 0.3">
        <joint name="shoulder" type="ball" pos="0 0 0.05"/>
        <inertial pos="0 0 -0.2" quat="0.7 0.7 0 0" mass="1.2" diaginertia="0.02 0.018 0.005"/>
        <body name="lower" pos="0 0 -0.4">
          <joint name="elbow" type="hinge" axis="0 1 0.2" pos="0 0.01 0.02"/>
          <joint name="twist" type="hinge" axis="0 0 1" pos="0.03 0 -0.01"/>
          <geom type="capsule" fromto="0 0 0 0 0 -0.3" size="0.04" density="900"/>
          <body name="slider" pos="0 0 -0.35" euler="0 0.5 0">
            <joint name="extend" type="slide" axis="1 0.5 0"/>
            <inertial pos="0.02 0 0" mass="0.5" diaginertia="0.001 0.002 0.0015"/>
          </body>
        </body>
      </body>
      <body name="leg" pos="-0.1 0 -0.2">
        <joint name="hip" type="hinge" axis="1 0 0"/>
        <joint name="knee" type="slide" axis="0 0 1" pos="0 0 -0.1"/>
        <inertial pos="0 0 -0.15" mass="2" diaginertia="0.05 0.05 0.01"/>
      </body>
    </body>
  </worldbody>
</mujoco>
)";

// A file in the test's temporary directory, named for this process (the unit tests run in
// shards, several processes at once), removed on scope exit.
struct TempFile {
  std::string path;
  TempFile(const std::string& name, const std::string& text)
      : path(::testing::TempDir() + "/" + std::to_string(::getpid()) + "_" + name) {
    std::ofstream(path) << text;
  }
  ~TempFile() { std::remove(path.c_str()); }
};

// MuJoCo's M for a compiled model at qpos = q, mapped to our coordinates (the free joint is
// MuJoCo's first joint when free_first: qvel = [v_world; ω_local]).
Eigen::MatrixXd mujocoM(const mjModel* m, const Eigen::VectorXd& q, bool free_first) {
  MjDataPtr d(mj_makeData(m));
  for (int k = 0; k < m->nq; ++k) d->qpos[k] = q(k);
  mj_kinematics(m, d.get());
  mj_comPos(m, d.get());
  mj_crb(m, d.get());
  Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> Mmj(m->nv, m->nv);
  mj_fullM(m, Mmj.data(), d->qM);
  Eigen::MatrixXd T = Eigen::MatrixXd::Identity(m->nv, m->nv);
  if (free_first) {
    const int body = m->jnt_bodyid[0];
    Eigen::Matrix3d R;
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) R(r, c) = d->xmat[9 * body + 3 * r + c];
    T.topLeftCorner<6, 6>().setZero();
    T.block<3, 3>(0, 3) = R;            // v_world = R v_body
    T.block<3, 3>(3, 0).setIdentity();  // ω local
  }
  return T.transpose() * Mmj * T;
}

// (c) MJCF import: hinge, slide, ball and free joints, bodies with two joints, joints off the
// body origin, a welded child body, mass from a geom; our CRBA on the imported tree against
// MuJoCo's own M for the same file.
TEST(Mujoco, MjcfImportMatchesMujoco) {
  const TempFile file("minv_mujoco_test_robot.xml", kRobotXml);
  const Model model = loadMjcf(file.path, false);
  ASSERT_TRUE(model.floatingBase());
  // torso, upper, lower:elbow, lower, slider, leg:hip, leg.
  ASSERT_EQ(model.nb(), 7);
  EXPECT_EQ(model.body(2).name, "lower:elbow");
  EXPECT_EQ(model.body(3).name, "lower");
  EXPECT_EQ(model.nv(), 6 + 3 + 2 + 1 + 2);
  const MjModelPtr m = compileMujocoFile(file.path);
  ASSERT_EQ(m->nq, model.nq());
  for (std::uint64_t seed : {1, 2, 3}) {
    const Eigen::VectorXd q = randomConfiguration(model, seed);
    const Eigen::MatrixXd M = massMatrix(model, q);
    // Two bodies with two joints each carry 1e-10 of their mass on an extra body.
    EXPECT_LT(relError(M, mujocoM(m.get(), q, true)), 3 * kJointOnlyMassFraction)
        << "seed " << seed;
    // And the `mujoco` solver on the imported tree (round trip through toMjcf).
    MujocoSolver solver;
    solver.prepare(model);
    solver.configure(q);
    EXPECT_LT(relError(solver.massMatrix(), M), 1e-10);
  }
}

TEST(Mujoco, MjcfImportSingleJointBodiesIsExact) {
  // Every body with one joint: the import is exact (to rounding).
  const Model src = randomTree({Topology::Branched, 40, 5, true, JointSet::Mixed});
  const std::vector<MjcfFile> files = toMjcf(src);
  ASSERT_EQ(files.size(), 1u);
  const TempFile file("minv_mujoco_test_tree.xml", files[0].text);
  const Model model = loadMjcf(file.path, false);
  ASSERT_EQ(model.nv(), src.nv());
  const MjModelPtr m = compileMujocoFile(file.path);
  const Eigen::VectorXd q = randomConfiguration(model, 11);
  EXPECT_LT(relError(massMatrix(model, q), mujocoM(m.get(), q, true)), 1e-12);
}

TEST(Mujoco, MjcfFloatingBaseAndErrors) {
  const char* fixed = R"(<mujoco><worldbody><body name="base" pos="0 0 1">
      <inertial pos="0 0 0" mass="3" diaginertia="0.1 0.1 0.1"/>
      <body name="arm"><joint name="a" axis="0 1 0"/>
        <inertial pos="0.2 0 0" mass="1" diaginertia="0.01 0.01 0.01"/></body>
    </body></worldbody></mujoco>)";
  const TempFile file("minv_mujoco_test_fixed.xml", fixed);
  const Model fix = loadMjcf(file.path, false);
  EXPECT_EQ(fix.nb(), 1);
  EXPECT_FALSE(fix.floatingBase());
  const Model flo = loadMjcf(file.path, true);
  EXPECT_EQ(flo.nb(), 2);
  EXPECT_TRUE(flo.floatingBase());
  EXPECT_EQ(flo.nv(), 7);
  EXPECT_DOUBLE_EQ(flo.body(0).mass, 3);

  // Two free bodies: only body 0 may float.
  const char* two = R"(<mujoco><worldbody>
      <body name="a"><freejoint/><geom size="0.1"/></body>
      <body name="b"><freejoint/><geom size="0.1"/></body></worldbody></mujoco>)";
  const TempFile file2("minv_mujoco_test_two.xml", two);
  EXPECT_ERROR(loadMjcf(file2.path, false), "not the first moving body");

  // The measured limit of one file: 96 nested jointed bodies load, 97 do not.
  auto chain = [](int n) {
    std::string x = "<mujoco><worldbody>";
    for (int i = 0; i < n; ++i) x += "<body><joint/><geom size=\"0.1\"/>";
    for (int i = 0; i < n; ++i) x += "</body>";
    return std::vector<MjcfFile>{{"chain.xml", x + "</worldbody></mujoco>"}};
  };
  EXPECT_EQ(compileMjcf(chain(96), "chain96")->nbody, 97);
  EXPECT_THROW(compileMjcf(chain(97), "chain97"), ModelError);
  // An MJCF chain nested deeper than tinyxml2 allows: the error names the limit.
  std::string deep = "<mujoco><worldbody>";
  for (int i = 0; i < 100; ++i) deep += "<body><joint/><geom size=\"0.1\"/>";
  for (int i = 0; i < 100; ++i) deep += "</body>";
  deep += "</worldbody></mujoco>";
  const TempFile file3("minv_mujoco_test_deep.xml", deep);
  EXPECT_ERROR(loadMjcf(file3.path, false), "at most 96 nested bodies");
  EXPECT_THROW(loadMjcf(::testing::TempDir() + "/no_such_file.xml", false), ModelError);

  // MuJoCo's warning about a NaN is held back: a refused file says only what minv says.
  const TempFile file4("minv_mujoco_test_nan.xml", R"(<mujoco><worldbody><body name="a">
      <inertial pos="0 0 0" mass="1" diaginertia="0.1 0.1 0.1"/>
      <joint name="j" type="hinge" axis="nan 0 1"/></body></worldbody></mujoco>)");
  ::testing::internal::CaptureStderr();
  EXPECT_ERROR(loadMjcf(file4.path, false), "joint axis is not finite");
  EXPECT_EQ(::testing::internal::GetCapturedStderr(), "");
  // A NaN that MuJoCo reads as 0 (a body's position), with only a warning: refused.
  const TempFile file5("minv_mujoco_test_nan_pos.xml", R"(<mujoco><worldbody><body name="a">
      <inertial pos="0 0 0" mass="1" diaginertia="0.1 0.1 0.1"/><joint type="hinge"/>
      <body name="b" pos="nan 0 0"><inertial pos="0 0 0" mass="1" diaginertia="0.1 0.1 0.1"/>
      <joint type="hinge"/></body></body></worldbody></mujoco>)");
  ::testing::internal::CaptureStderr();
  EXPECT_ERROR(loadMjcf(file5.path, false), "the file contains a NaN");
  EXPECT_EQ(::testing::internal::GetCapturedStderr(), "");
}

TEST(Mujoco, SupportsRefusesWhatMujocoRefuses) {
  Body tiny;
  tiny.mass = 1e-3;
  tiny.inertia = 1e-16 * Eigen::Matrix3d::Identity();
  const Model model = Model::create({-1}, {Joint{}}, {tiny});
  MujocoSolver solver;
  std::string why;
  EXPECT_FALSE(solver.supports(model, &why));
  EXPECT_NE(why.find("mjMINVAL"), std::string::npos) << why;
}

}  // namespace
}  // namespace minv

#endif  // MINV_HAVE_MUJOCO
