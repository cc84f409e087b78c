// The `mujoco-step` path (sim/mujoco_step.hpp): MuJoCo's centipede is ours (nv, total mass, M
// at the standing and at a turned configuration, the state's coordinate maps), every tip
// touches the plane once it has settled (also beyond MuJoCo's default 100 contacts), it walks
// forward under our gait, and the Figure 4 sweep writes its points beside ours.
#ifdef MINV_HAVE_MUJOCO

#include "sim/mujoco_step.hpp"

#include <gtest/gtest.h>
#include <hdf5.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <sstream>
#include <stdexcept>
#include <string>

#include "core/crba.hpp"
#include "experiments/lib/centipede_run.hpp"
#include "generators/random_tree.hpp"
#include "sim/gait.hpp"

namespace minv::sim {
namespace {

double relError(const Eigen::MatrixXd& A, const Eigen::MatrixXd& B) {
  return (A - B).norm() / B.norm();
}

// The same centipede: nv, total mass, and M mapped to our coordinates equals our CRBA.
TEST(MujocoStep, SameCentipedeAsOurs) {
  for (SegmentJoint joint : {SegmentJoint::Yaw, SegmentJoint::Spherical}) {
    const Centipede c = makeCentipede({.segments = 5, .segment_joint = joint});
    const Model& model = c.model;
    MujocoCentipede mj(c, {});
    EXPECT_EQ(mj.model()->nv, model.nv());
    EXPECT_EQ(mj.model()->nq, model.nq());
    double mass = 0;
    for (int i = 0; i < model.nb(); ++i) mass += model.body(i).mass;
    EXPECT_NEAR(mj_getTotalmass(mj.model()), mass, 1e-12 * mass);
    const Eigen::VectorXd zero = Eigen::VectorXd::Zero(model.nv());
    const Eigen::VectorXd standing = centipedeStanding(c);
    mj.setState(standing, zero);
    EXPECT_LT(relError(mj.massMatrix(), massMatrix(model, standing)), 1e-9);
    // The tip spheres stand on the plane: their centres one radius above it.
    for (int l = 0; l < c.legs(); ++l) {
      const int g = mj_name2id(mj.model(), mjOBJ_GEOM, ("tip" + std::to_string(l)).c_str());
      ASSERT_GE(g, 0);
      EXPECT_NEAR(mj.data()->geom_xpos[3 * g + 2], MujocoStepOptions{}.tip_radius, 1e-12);
    }
    // A turned configuration with velocities: M, and the state there and back.
    const Eigen::VectorXd q = randomConfiguration(model, 3);
    const Eigen::VectorXd v = Eigen::VectorXd::LinSpaced(model.nv(), -1, 1);
    mj.setState(q, v);
    EXPECT_LT(relError(mj.massMatrix(), massMatrix(model, q)), 1e-9);
    Eigen::VectorXd q1, v1;
    mj.state(q1, v1);
    EXPECT_LT((q1 - q).norm(), 1e-12);
    EXPECT_LT((v1 - v).norm(), 1e-12);
  }
}

// Holding the standing pose (the gait's PD without swing or lift), every tip is in contact once
// settled: ncon = legs, 4 rows each (pyramidal cone of 4 edges), nothing dropped; 60 segments
// need more than MuJoCo's default 100 contacts.
TEST(MujocoStep, EveryTipTouchesThePlane) {
  for (int S : {5, 60}) {
    const Centipede c = makeCentipede({.segments = S});
    MujocoStepOptions o;
    o.dt = 1e-4;
    MujocoCentipede mj(c, o);
    CentipedeGait gait(c, {.swing = 0, .lift = 0});
    Eigen::VectorXd q = centipedeStanding(c), v = Eigen::VectorXd::Zero(c.model.nv()), tau;
    mj.setState(q, v);
    for (int k = 0; k < 40; ++k) {
      mj.state(q, v);
      tau = Eigen::VectorXd::Zero(c.model.nv());
      gait(mj.time(), q, v, tau);
      mj.step(tau);
      if (k < 10) continue;
      ASSERT_EQ(mj.contacts(), c.legs()) << "S " << S << " step " << k;
      EXPECT_EQ(mj.data()->nefc, 4 * c.legs()) << "S " << S << " step " << k;
    }
    EXPECT_EQ(mj.overflows(), 0);
    EXPECT_EQ(mj.resets(), 0);
  }
}

// The walk: 1.5 s under the gait moves the head and the centre of mass forward.
TEST(MujocoStep, WalksForward) {
  CentipedeRunOptions o;
  o.segments = 5;
  o.steps = 1500;
  o.dt = 1e-3;
  o.solver = kMujocoStepPath;
  o.progress_lines = 0;
  std::ostringstream log;
  const CentipedeRunResult r = runCentipede(o, log);
  EXPECT_EQ(r.engine, "mujoco");
  EXPECT_GT(r.time_total, 0);
  EXPECT_EQ(r.times.total(), 0);
  EXPECT_GT(r.mean_contacts, 0);
  EXPECT_GT(r.head_dx, 0.05) << log.str();  // measured 0.18 m (ours, contact-inertia: 0.14)
  EXPECT_GT(r.com_dx, 0.05) << log.str();
}

// Attributes of a finished sweep point, read independently of the writer.
double doubleAttr(hid_t file, const std::string& obj, const char* name) {
  const hid_t a = H5Aopen_by_name(file, obj.c_str(), name, H5P_DEFAULT, H5P_DEFAULT);
  if (a < 0) throw std::runtime_error("no attribute " + obj + "@" + name);
  double x = 0;
  EXPECT_GE(H5Aread(a, H5T_NATIVE_DOUBLE, &x), 0) << obj << "@" << name;
  H5Aclose(a);
  return x;
}

std::string stringAttr(hid_t file, const std::string& obj, const char* name) {
  const hid_t a = H5Aopen_by_name(file, obj.c_str(), name, H5P_DEFAULT, H5P_DEFAULT);
  if (a < 0) throw std::runtime_error("no attribute " + obj + "@" + name);
  const hid_t type = H5Tcopy(H5T_C_S1);
  H5Tset_size(type, H5T_VARIABLE);
  H5Tset_cset(type, H5T_CSET_UTF8);
  char* raw = nullptr;
  EXPECT_GE(H5Aread(a, type, &raw), 0) << obj << "@" << name;
  std::string s = raw ? raw : "";
  H5free_memory(raw);
  H5Tclose(type);
  H5Aclose(a);
  return s;
}

// The sweep runs mujoco-step beside our paths: one point each, told apart by `engine`.
TEST(MujocoStep, SweepWritesItsPoints) {
  const std::string path = (std::filesystem::temp_directory_path() /
                            ("minv_mujoco_step_" + std::to_string(::getpid()) + ".h5"))
                               .string();
  std::filesystem::remove(path);
  CentipedeSweepOptions o;
  o.segments = {3};
  o.solvers = {kContactInertiaPath, kMujocoStepPath};
  o.steps = 5;
  o.dt = 1e-4;
  o.out = path;
  std::ostringstream log;
  runCentipedeSweep(o, log);
  H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
  const hid_t f = H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  ASSERT_GE(f, 0) << log.str();
  EXPECT_EQ(stringAttr(f, "S3/mujoco-step", "engine"), "mujoco");
  EXPECT_EQ(stringAttr(f, "S3/mujoco-step", "status"), "ok");
  EXPECT_GT(doubleAttr(f, "S3/mujoco-step", "time_total"), 0);
  EXPECT_EQ(doubleAttr(f, "S3/mujoco-step", "time_matrices"), 0);
  EXPECT_EQ(doubleAttr(f, "S3/mujoco-step", "overflows"), 0);
  EXPECT_EQ(stringAttr(f, "S3/contact-inertia", "engine"), "minv");
  EXPECT_GT(doubleAttr(f, "S3/contact-inertia", "time_matrices"), 0);
  H5Fclose(f);
  std::filesystem::remove(path);
}

}  // namespace
}  // namespace minv::sim

#endif  // MINV_HAVE_MUJOCO
