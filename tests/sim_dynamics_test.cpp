// The simulator's dynamics: ABA against CRBA, test impulses against Jᵀ M⁻¹ J, momentum
// conservation, a body dropped on the plane, a block on an incline, and every contact-space
// path giving the same trajectory.
#include <gtest/gtest.h>

#include <Eigen/Cholesky>
#include <Eigen/Geometry>
#include <cmath>
#include <numbers>

#include "core/crba.hpp"
#include "generators/centipede.hpp"
#include "generators/random_tree.hpp"
#include "sim/dynamics.hpp"
#include "sim/gait.hpp"
#include "sim/simulator.hpp"

namespace minv::sim {
namespace {

Eigen::MatrixXd massMatrix(const Model& m, const Kinematics<double>& kin) {
  std::vector<Mat6<double>> Ic(m.nb());
  Eigen::MatrixXd M(m.nv(), m.nv());
  crba<double>(m, kin, Ic, M);
  return M;
}

Eigen::VectorXd randomVector(int n, std::uint64_t seed, double scale = 1.0) {
  Rng rng(seed);
  Eigen::VectorXd v(n);
  for (int i = 0; i < n; ++i) v(i) = scale * rng.uniform(-1, 1);
  return v;
}

// Kinematics (world coordinates, as the simulator has them) and articulated inertias at q.
struct AtConfiguration {
  Kinematics<double> kin;
  Articulated<double> art;
  AtConfiguration(const Model& m, const Eigen::VectorXd& q) : kin(m), art(m) {
    computeKinematics<double>(m, q, kin);
    articulatedInertias<double>(m, kin, art);
  }
};

TEST(SimDynamics, AbaEqualsCrbaSolveAtRest) {
  const Centipede c = makeCentipede({.segments = 3, .segment_joint = SegmentJoint::Spherical});
  const Model& m = c.model;
  const Eigen::VectorXd q = randomConfiguration(m, 7);
  const AtConfiguration at(m, q);
  const Kinematics<double>& kin = at.kin;
  const Articulated<double>& art = at.art;
  AbaWorkspace ws(m);
  const Eigen::VectorXd tau = randomVector(m.nv(), 3);
  Eigen::VectorXd qdd(m.nv());
  aba(m, kin, art, Eigen::VectorXd::Zero(m.nv()), tau, Eigen::Vector3d::Zero(), ws, qdd);
  const Eigen::VectorXd ref = massMatrix(m, kin).ldlt().solve(tau);
  EXPECT_LT((qdd - ref).norm(), 1e-9 * ref.norm());
}

// abaStep's v* = v + h q̈ against aba()'s q̈, and its body velocities V*_b against the sum
// Σ S_d v*_d over the DOFs d on b's path (no recursion), with gravity and spherical joints.
TEST(SimDynamics, AbaStepGivesTheStepAndTheBodiesVelocities) {
  const Centipede c = makeCentipede({.segments = 3, .segment_joint = SegmentJoint::Spherical});
  const Model& m = c.model;
  const Eigen::VectorXd q = randomConfiguration(m, 17);
  const Eigen::VectorXd v = randomVector(m.nv(), 4, 2.0);
  const Eigen::VectorXd tau = randomVector(m.nv(), 6);
  const Eigen::Vector3d g(0.1, 0.2, -9.81);
  const double h = 1e-3;
  const AtConfiguration at(m, q);
  AbaWorkspace ws(m), ws_step(m);
  Eigen::VectorXd qdd(m.nv()), qdd_step(m.nv()), vstar(m.nv());
  aba(m, at.kin, at.art, v, tau, g, ws, qdd);
  abaStep(m, at.kin, at.art, v, tau, g, h, ws_step, qdd_step, vstar);
  EXPECT_LT((qdd_step - qdd).norm(), 1e-12 * qdd.norm());
  const Eigen::VectorXd ref = v + h * qdd;
  EXPECT_LT((vstar - ref).norm(), 1e-13 * ref.norm());
  for (int b = 0; b < m.nb(); ++b) {
    Vec6<double> V = Vec6<double>::Zero();
    for (const int d : pathDofs(m, b)) V += at.kin.S.col(d) * ref(d);
    EXPECT_LT((ws_step.Vstar.col(b) - V).norm(), 1e-12 * (1 + V.norm())) << "body " << b;
  }
}

// d/dt of the total spatial momentum is the gravity wrench (Σ m_i g at the coms), so with
// gravity the ABA accelerations must satisfy d h/dt = Σ I_i a_i + V_i ×* I_i V_i = external.
TEST(SimDynamics, AbaMomentumRateIsGravityWrench) {
  const Centipede c = makeCentipede({.segments = 2});
  const Model& m = c.model;
  const Eigen::VectorXd q = randomConfiguration(m, 11);
  const Eigen::VectorXd v = randomVector(m.nv(), 5, 2.0);
  const Eigen::Vector3d g(0.3, -0.2, -9.81);
  const AtConfiguration at(m, q);
  const Kinematics<double>& kin = at.kin;
  const Articulated<double>& art = at.art;
  AbaWorkspace ws(m);
  Eigen::VectorXd qdd(m.nv());
  Eigen::VectorXd tau = randomVector(m.nv(), 9);
  tau.head<6>().setZero();  // joint torques are internal; a base "torque" would be external
  aba(m, kin, art, v, tau, g, ws, qdd);
  // Finite difference of h along the motion (central, on q ⊕ ±εv, v ± ε q̈).
  const double eps = 1e-6;
  Eigen::VectorXd qp = q, qm = q;
  integrate(m, qp, v, eps);
  integrate(m, qm, v, -eps);
  Kinematics<double> kp(m), km(m);
  computeKinematics<double>(m, qp, kp);
  computeKinematics<double>(m, qm, km);
  const Vec6<double> dh =
      (spatialMomentum(m, kp, v + eps * qdd) - spatialMomentum(m, km, v - eps * qdd)) / (2 * eps);
  Vec6<double> ext = Vec6<double>::Zero();
  for (int i = 0; i < m.nb(); ++i) {
    const Eigen::Vector3d com = kin.X[i].p + kin.X[i].R * m.body(i).com;
    ext += unitWrench(com, g) * m.body(i).mass;
  }
  EXPECT_LT((dh - ext).norm(), 1e-5 * ext.norm()) << dh.transpose() << "\n" << ext.transpose();
}

// integrate's rotation of a spherical or floating joint against the closed form
// Q ⊗ (cos φ, sin φ ω/|ω|), φ = h|ω|/2, through Eigen's angle-axis quaternion: small steps (the
// series branch), large ones (std::sin, std::cos), backwards, and ω = 0.
TEST(SimDynamics, IntegrateRotatesByTheExponential) {
  const Centipede c = makeCentipede({.segments = 3, .segment_joint = SegmentJoint::Spherical});
  const Model& m = c.model;
  int rotations = 0;
  for (const double h : {1e-5, -1e-5, 3e-3, 0.3, -0.7}) {
    for (const double scale : {0.0, 1.0, 20.0}) {
      const Eigen::VectorXd q = randomConfiguration(m, 7);
      const Eigen::VectorXd v = randomVector(m.nv(), 8, scale);
      Eigen::VectorXd qn = q;
      integrate(m, qn, v, h);
      for (int i = 0; i < m.nb(); ++i) {
        const JointType type = m.joint(i).type;
        if (type != JointType::Spherical && type != JointType::Floating) continue;
        const int o = m.qIdx(i) + (type == JointType::Floating ? 3 : 0), vi = m.vIdx(i);
        const Eigen::Vector3d w = v.segment<3>(vi);
        Eigen::Quaterniond Q(q(o), q(o + 1), q(o + 2), q(o + 3));
        if (w.norm() > 0)
          Q = Q * Eigen::Quaterniond(Eigen::AngleAxisd(h * w.norm(), w.normalized()));
        Q.normalize();
        const Eigen::Vector4d ref(Q.w(), Q.x(), Q.y(), Q.z());
        EXPECT_LT((qn.segment<4>(o) - ref).cwiseAbs().maxCoeff(), 2e-15)
            << "body " << i << ", h " << h << ", |w| " << w.norm();
        ++rotations;
      }
    }
  }
  EXPECT_GT(rotations, 50);
}

// Relative change of the total spatial momentum of a free-floating centipede (no gravity, no
// contact, gait torques on) over `seconds` of steps of size dt.
double momentumDrift(double dt, double seconds) {
  const Centipede c = makeCentipede({.segments = 6});
  SimOptions o;
  o.dt = dt;
  o.gravity.setZero();
  Simulator sim(c.model, {}, o);
  CentipedeGait gait(c);
  sim.setController([&](double t, const Eigen::VectorXd& q, const Eigen::VectorXd& v,
                        Eigen::VectorXd& tau) { gait(t, q, v, tau); });
  sim.setState(centipedeStanding(c, 0.5), randomVector(c.model.nv(), 21, 0.5));
  Kinematics<double> kin(c.model);
  computeKinematics<double>(c.model, sim.q(), kin);
  const Vec6<double> h0 = spatialMomentum(c.model, kin, sim.v());
  for (int s = 0; s < static_cast<int>(std::lround(seconds / dt)); ++s) sim.step();
  computeKinematics<double>(c.model, sim.q(), kin);
  return (spatialMomentum(c.model, kin, sim.v()) - h0).norm() / h0.norm();
}

// Conserved up to the integrator's O(h) error: with the paper's h = 1e-5 over its 1000 steps
// the relative drift is below 1e-6 (measured 2e-7), and it shrinks tenfold with h (first
// order, so it is the integrator's, not a dynamics error, which would not shrink).
TEST(SimDynamics, FreeFloatingMomentumConserved) {
  const double fine = momentumDrift(1e-5, 0.01), coarse = momentumDrift(1e-4, 0.01);
  EXPECT_LT(fine, 1e-6);
  EXPECT_GT(coarse / fine, 5.0);
  EXPECT_LT(coarse / fine, 20.0);
}

// Jᵀ M⁻¹ J by test impulses equals the product from the lapack solver's M⁻¹.
TEST(SimDynamics, TestImpulsesEqualJtMinvJ) {
  const Centipede c = makeCentipede({.segments = 4});
  const Model& m = c.model;
  const Eigen::VectorXd q = randomConfiguration(m, 3);
  const AtConfiguration at(m, q);
  const Kinematics<double>& kin = at.kin;
  const Articulated<double>& art = at.art;
  std::vector<int> bodies;
  std::vector<Vec6<double>> wrenches;
  Rng rng(4);
  for (int l = 0; l < c.legs(); ++l)
    for (int d = 0; d < 3; ++d) {
      bodies.push_back(c.lower_body[l]);
      const Eigen::Vector3d p = kin.X[c.lower_body[l]].p + kin.X[c.lower_body[l]].R * c.tip;
      wrenches.push_back(unitWrench(p, rng.unitVector()));
    }
  const int mm = static_cast<int>(bodies.size());
  Eigen::MatrixXd J = Eigen::MatrixXd::Zero(m.nv(), mm);
  for (int r = 0; r < mm; ++r) addJacobianColumn(m, kin, bodies[r], wrenches[r], J, r);
  auto lapack = makeSolver("lapack");
  lapack->prepare(m);
  lapack->configure(q);
  Eigen::MatrixXd Minv(m.nv(), m.nv());
  lapack->inverse(Minv);
  const Eigen::MatrixXd ref = J.transpose() * Minv * J;
  Eigen::MatrixXd A(mm, mm);
  ImpulseWorkspace ws(m);
  Eigen::VectorXd scratch(m.nv());
  testImpulses(m, kin, art, ws, bodies, wrenches, A, scratch);
  EXPECT_LT((A - ref).norm(), 1e-10 * ref.norm());
  // The columns on two threads, each with its own workspace: the same matrix.
  std::vector<ImpulseWorkspace> wss(2, ImpulseWorkspace(m));
  std::vector<Eigen::VectorXd> scratches(2, Eigen::VectorXd(m.nv()));
  Eigen::MatrixXd A2 = Eigen::MatrixXd::Constant(mm, mm, std::nan(""));
  testImpulses(m, kin, art, wss, bodies, wrenches, A2, scratches);
  EXPECT_LT((A2 - ref).norm(), 1e-10 * ref.norm());
  EXPECT_TRUE(A2 == A) << "two threads changed the test-impulse matrix";
  // And one combined impulse sweep gives M⁻¹ J λ.
  const Eigen::VectorXd lambda = randomVector(mm, 8);
  Eigen::VectorXd dqd(m.nv());
  applyImpulses(m, kin, art, ws, bodies, wrenches, lambda, dqd);
  EXPECT_LT((dqd - Minv * J * lambda).norm(), 1e-10 * (Minv * J * lambda).norm());
}

// A box (0.2 × 0.1 × 0.05 m, 1 kg) with its 8 corners as contact points.
struct BoxModel {
  Model model;
  std::vector<ContactPoint> corners;
};
BoxModel box() {
  Joint j;
  j.name = "base";
  j.type = JointType::Floating;
  Body b;
  b.name = "box";
  b.mass = 1.0;
  const double a = 0.2, w = 0.1, h = 0.05;
  b.inertia = Eigen::Vector3d((w * w + h * h) / 12, (a * a + h * h) / 12, (a * a + w * w) / 12)
                  .asDiagonal();
  BoxModel out{Model::create({-1}, {j}, {b}), {}};
  for (int s = 0; s < 8; ++s)
    out.corners.push_back({0, Eigen::Vector3d((s & 1 ? 0.5 : -0.5) * a, (s & 2 ? 0.5 : -0.5) * w,
                                              (s & 4 ? 0.5 : -0.5) * h)});
  return out;
}

double lowestCorner(const Simulator& sim, const BoxModel& b) {
  Kinematics<double> kin(b.model);
  computeKinematics<double>(b.model, sim.q(), kin);
  double z = 1e9;
  for (const ContactPoint& c : b.corners) z = std::min(z, (kin.X[0].p + kin.X[0].R * c.point).z());
  return z;
}

TEST(SimContact, DroppedBoxComesToRestWithoutSinking) {
  const BoxModel b = box();
  for (const std::string path : {"abi", "test-impulse"}) {
    SimOptions o;
    o.dt = 1e-3;
    o.path = path;
    Simulator sim(b.model, b.corners, o);
    Eigen::VectorXd q = b.model.neutral();
    q(2) = 0.1;  // corners 0.075 m above the plane
    // A small tilt so that it does not land flat.
    const Eigen::Quaterniond Q(Eigen::AngleAxisd(0.2, Eigen::Vector3d(1, 1, 0).normalized()));
    q.segment<4>(3) << Q.w(), Q.x(), Q.y(), Q.z();
    sim.setState(q, Eigen::VectorXd::Zero(6));
    double lowest = 1e9;
    for (int s = 0; s < 1500; ++s) {
      sim.step();
      lowest = std::min(lowest, lowestCorner(sim, b));
    }
    // Stated tolerances: sinks at most 1 mm at any time, rests (|v| < 1e-3) after 1.5 s.
    EXPECT_GT(lowest, -1e-3) << path;
    EXPECT_LT(sim.v().norm(), 1e-3) << path;
    EXPECT_NEAR(lowestCorner(sim, b), 0.0, 1e-3) << path;
    EXPECT_LT(sim.lastResiduals().penetration, 1e-6);
  }
}

// An incline of angle θ: gravity tilted by θ about y (the plane stays z = 0), so the box's
// downhill direction is +x. μ = 0.5: friction angle atan(0.5) = 26.6°. With k = 4 the cone's
// vertices lie on ±x, ±y, so the full μ acts along x.
double inclineSlide(double theta_deg, double seconds) {
  const BoxModel b = box();
  SimOptions o;
  o.dt = 1e-3;
  o.mu = 0.5;
  o.path = "test-impulse";
  const double th = theta_deg * std::numbers::pi / 180;
  o.gravity = 9.81 * Eigen::Vector3d(std::sin(th), 0, -std::cos(th));
  Simulator sim(b.model, b.corners, o);
  Eigen::VectorXd q = b.model.neutral();
  q(2) = 0.025;  // resting on its face
  sim.setState(q, Eigen::VectorXd::Zero(6));
  for (int s = 0; s < static_cast<int>(seconds / o.dt); ++s) sim.step();
  return sim.q()(0);
}

TEST(SimContact, BlockOnInclineSticksBelowFrictionAngleAndSlidesAbove) {
  EXPECT_LT(std::abs(inclineSlide(20, 1.0)), 1e-6);
  const double th = 35 * std::numbers::pi / 180;
  const double expected = 0.5 * 9.81 * (std::sin(th) - 0.5 * std::cos(th)) * 1.0;  // ½ a t²
  EXPECT_NEAR(inclineSlide(35, 1.0), expected, 0.02 * expected);
}

// Every path (the registry's solvers and test-impulse) gives the same 200-step trajectory of
// a walking centipede within 1e-8 (PGS run to 1e-13).
TEST(SimPaths, EveryPathGivesTheSameTrajectory) {
  const Centipede c = makeCentipede({.segments = 4});
  Eigen::VectorXd ref;
  for (const std::string& path : simulationPaths()) {
    SimOptions o;
    o.dt = 1e-3;
    o.path = path;
    o.contact.tolerance = 1e-13;
    o.contact.max_iterations = 20000;
    WalkingCentipede walk(c, o);
    Simulator& sim = walk.sim();
    for (int s = 0; s < 200; ++s) sim.step();
    if (ref.size() == 0) {
      ref = sim.q();
      continue;
    }
    EXPECT_LT((sim.q() - ref).cwiseAbs().maxCoeff(), 1e-8) << path;
  }
}

}  // namespace
}  // namespace minv::sim
