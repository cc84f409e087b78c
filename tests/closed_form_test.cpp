// Closed-form joint-space inertia matrices: a pendulum, the planar two-link arm and a
// free-floating body. CRBA and every registered solver are checked against them.
#include <gtest/gtest.h>

#include <cmath>

#include "core/crba.hpp"
#include "solvers/solver.hpp"

namespace minv {
namespace {

Body makeBody(double m, Eigen::Vector3d com, Eigen::Vector3d moments) {
  Body b;
  b.mass = m;
  b.com = com;
  b.inertia = moments.asDiagonal();
  return b;
}

Joint revoluteZ(Eigen::Vector3d at) {
  Joint j;
  j.axis = Eigen::Vector3d::UnitZ();
  j.placement.p = at;
  return j;
}

// Every solver's M⁻¹ and M⁻¹R against the inverse of the closed-form M.
void expectAllSolversInvert(const Model& model, const Eigen::VectorXd& q,
                            const Eigen::MatrixXd& M) {
  const Eigen::MatrixXd ref = M.inverse();
  // Seeded right-hand sides (Eigen's Random would differ from run to run).
  const Eigen::MatrixXd R = Eigen::MatrixXd::NullaryExpr(
      model.nv(), 3,
      [](Eigen::Index i, Eigen::Index j) { return std::sin(1.0 + 3.0 * i + 7.0 * j); });
  for (const SolverEntry& e : solverRegistry()) {
    auto solver = e.make();
    solver->prepare(model);
    solver->configure(q);
    Eigen::MatrixXd X(model.nv(), model.nv()), Y(model.nv(), 3);
    solver->inverse(X);
    solver->solve(R, Y);
    EXPECT_LT((X - ref).norm(), 1e-11 * ref.norm()) << e.name;
    EXPECT_LT((Y - ref * R).norm(), 1e-11 * (ref * R).norm()) << e.name;
  }
}

TEST(ClosedForm, Pendulum) {
  const double m = 2.0, l = 0.7, Izz = 0.05;
  const Model model = Model::create({-1}, {revoluteZ(Eigen::Vector3d::Zero())},
                                    {makeBody(m, {l, 0, 0}, {0.03, 0.04, Izz})});
  Eigen::VectorXd q(1);
  q << 0.4;
  Eigen::MatrixXd M(1, 1);
  M << Izz + m * l * l;  // M = I_zz + m l²
  EXPECT_NEAR(massMatrix(model, q)(0, 0), M(0, 0), 1e-14);
  expectAllSolversInvert(model, q, M);
}

TEST(ClosedForm, PlanarTwoLinkArm) {
  const double m1 = 1.5, m2 = 0.8, l1 = 0.9, c1 = 0.4, c2 = 0.35, I1 = 0.07, I2 = 0.02;
  const Model model = Model::create(
      {-1, 0}, {revoluteZ(Eigen::Vector3d::Zero()), revoluteZ({l1, 0, 0})},
      {makeBody(m1, {c1, 0, 0}, {0.05, 0.06, I1}), makeBody(m2, {c2, 0, 0}, {0.01, 0.015, I2})});
  for (double q2 : {-2.0, 0.0, 0.3, 1.9}) {
    Eigen::VectorXd q(2);
    q << 0.6, q2;
    // The textbook planar arm (e.g. Spong, Hutchinson & Vidyasagar, eq. 7.87).
    const double c = std::cos(q2);
    Eigen::Matrix2d M;
    M(0, 0) = I1 + I2 + m1 * c1 * c1 + m2 * (l1 * l1 + c2 * c2 + 2 * l1 * c2 * c);
    M(0, 1) = M(1, 0) = I2 + m2 * (c2 * c2 + l1 * c2 * c);
    M(1, 1) = I2 + m2 * c2 * c2;
    EXPECT_LT((massMatrix(model, q) - M).norm(), 1e-14);
    expectAllSolversInvert(model, q, M);
  }
}

TEST(ClosedForm, FreeFloatingBody) {
  Joint base;
  base.type = JointType::Floating;
  base.name = "base";
  const double m = 3.0;
  const Eigen::Vector3d com(0.1, -0.2, 0.3);
  Eigen::Matrix3d Ic;
  Ic << 0.5, 0.01, -0.02, 0.01, 0.4, 0.03, -0.02, 0.03, 0.6;
  Body body = makeBody(m, com, Eigen::Vector3d::Ones());
  body.inertia = Ic;
  const Model model = Model::create({-1}, {base}, {body});
  // Any pose: M is independent of it, also 10 km from the world origin, where world-frame
  // products lose |p|²·ε ≈ 2e-8 relative unless each tree is computed about its root.
  Eigen::VectorXd q(7), far(7);
  q << 0.3, -1.0, 2.0, 0.9, 0.1, -0.3, 0.2;
  far << 9e3, -8e3, 1e4, 0.9, 0.1, -0.3, 0.2;
  // In base coordinates ([ω; v] of the body frame) M is the body's spatial inertia
  // [Ī + m c̃c̃ᵀ, m c̃; m c̃ᵀ, m 1], written out here independently of core/spatial.hpp.
  Eigen::Matrix3d C;
  C << 0, -com.z(), com.y(), com.z(), 0, -com.x(), -com.y(), com.x(), 0;
  Eigen::Matrix<double, 6, 6> M;
  M << Ic + m * C * C.transpose(), m * C, m * C.transpose(), m * Eigen::Matrix3d::Identity();
  for (const Eigen::VectorXd& at : {q, far}) {
    EXPECT_LT((massMatrix(model, at) - M).norm(), 1e-13) << at.transpose();
    expectAllSolversInvert(model, at, M);
  }
}

}  // namespace
}  // namespace minv
