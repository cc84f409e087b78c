// The accuracy experiment's reference (experiments/lib/accuracy.hpp): X_ref must be M⁻¹ to
// long-double accuracy, not to double's, or the errors it reports are its own.
//
// Independent check: M formed in long double by CRBA (core/crba.hpp, a different algorithm
// from the impulse sweeps that make X_ref) and the relative residual ‖M X_ref − I‖_F /
// (‖M‖_F ‖X_ref‖_F), taken in long double. A backward-stable long-double inverse gives a small
// fraction of u = 2⁻⁶⁴ (5.4e-20) here, 7e-22 to 2e-20; the same sweeps in double give 1e-18 to
// 1e-17 (checked here too), so the bound 8u tells a long-double pipeline from a double one.
// The kinematics is shared with M, so this cannot see a rounding there: its constants are
// formed in long double (core/kinematics.hpp), as KinematicsConstantsInLongDouble checks.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <vector>

#include "core/articulated.hpp"
#include "core/articulated_joint.hpp"
#include "core/crba.hpp"
#include "core/impulse_sweeps.hpp"
#include "core/kinematics.hpp"
#include "experiments/lib/accuracy.hpp"
#include "generators/random_tree.hpp"

namespace minv {
namespace {

using LMat = Eigen::Matrix<long double, Eigen::Dynamic, Eigen::Dynamic>;

// ‖M X − I‖_F / (‖M‖_F ‖X‖_F) with M by long-double CRBA at q.
long double longDoubleResidual(const Model& model, const Eigen::VectorXd& q, const LMat& X) {
  const LMat M = massMatrix<long double>(model, q);
  const LMat R = M * X - LMat::Identity(model.nv(), model.nv());
  return R.norm() / (M.norm() * X.norm());
}

TEST(AccuracyReference, IsALongDoubleInverse) {
  const long double u = 0x1.0p-64L;
  for (Topology t : {Topology::Serial, Topology::Branched})
    for (int n : {16, 64, 200}) {
      const Model model = randomTree({t, n, 1, false});
      const Eigen::VectorXd q = randomConfiguration(model, 1);
      const AccuracyReference ref = accuracyReference(model, q);
      const long double res = longDoubleResidual(model, q, ref.Xref);
      std::printf(
          "%s n=%d: residual %.2Le (bound 8u %.2Le), cond %.2e, own error about "
          "%.1e, Cholesky differs by %.1e\n",
          topologyName(t), n, res, 8 * u, ref.cond, ref.estimate, ref.cholesky);
      EXPECT_LE(res, 8 * u) << topologyName(t) << " n=" << n;
      // The bound tells precisions apart: the same sweeps in double exceed it.
      Kinematics<double> kd(model, Origin::EachRoot);
      computeKinematics<double>(model, q, kd);
      Articulated<double> ad(model);
      articulatedInertias<double>(model, kd, ad);
      Eigen::MatrixXd Xd(model.nv(), model.nv());
      referenceInverse<double>(model, kd, ad, Xd);
      EXPECT_GT(longDoubleResidual(model, q, Xd.cast<long double>()), 8 * u);
      // The independent Cholesky agrees with X_ref within its own error, cond₂(M)·u.
      EXPECT_LE(ref.cholesky, ref.cond * static_cast<double>(u)) << topologyName(t) << " n=" << n;
    }
}

// The same on a floating base with spherical and prismatic joints (the sweep itself runs fixed
// bases only): 3- and 6-DOF joints in the pass about each joint's origin.
TEST(AccuracyReference, IsALongDoubleInverseOnMixedFloatingTrees) {
  const long double u = 0x1.0p-64L;
  for (Topology t : {Topology::Serial, Topology::Branched}) {
    TreeOptions o;
    o.topology = t, o.n = 60, o.floating_base = true, o.joints = JointSet::Mixed;
    const Model model = randomTree(o);
    const Eigen::VectorXd q = randomConfiguration(model, 1);
    const AccuracyReference ref = accuracyReference(model, q);
    const long double res = longDoubleResidual(model, q, ref.Xref);
    std::printf("%s floating mixed n=60 (nv %d): residual %.2Le, own error about %.1e\n",
                topologyName(t), model.nv(), res, ref.estimate);
    EXPECT_LE(res, 8 * u) << topologyName(t);
  }
}

// core/articulated_joint.hpp's pass gives abi's quantities (U D⁻¹, D⁻¹ against
// articulatedInertias, in double) and, through the plain sweeps, an M⁻¹ far closer to the
// reference than the world-frame pass's (6.0e-15 against 4.6e-13 at n = 256 serial when written).
TEST(AccuracyReference, ThePassAboutEachJointIsTheSamePassMoreAccurately) {
  TreeOptions o;
  o.topology = Topology::Serial, o.n = 256;
  const Model model = randomTree(o);
  const Eigen::VectorXd q = randomConfiguration(model, 1);
  const AccuracyReference ref = accuracyReference(model, q);
  Kinematics<double> kin(model, Origin::EachRoot);
  computeKinematics<double>(model, q, kin);
  Articulated<double> world(model), joint(model);
  articulatedInertias<double>(model, kin, world);
  JointArticulatedWorkspace<double> ws(model);
  articulatedInertiasAtJoints<double>(model, kin, joint, ws);
  EXPECT_LE((joint.UDinv - world.UDinv).norm(), 1e-9 * world.UDinv.norm());
  EXPECT_LE((joint.dinv - world.dinv).norm(), 1e-9 * world.dinv.norm());
  EXPECT_LE((joint.couple - world.couple).norm(), 1e-9 * world.couple.norm());
  const long double norm = ref.Xref.norm();
  auto error = [&](const Articulated<double>& art) {
    Eigen::MatrixXd X(model.nv(), model.nv());
    referenceInverse<double>(model, kin, art, X);
    return static_cast<double>((X.cast<long double>() - ref.Xref).norm() / norm);
  };
  const double e_world = error(world), e_joint = error(joint);
  std::printf("n=256 serial, M⁻¹'s error: world-frame pass %.2e, about each joint %.2e\n", e_world,
              e_joint);
  EXPECT_LE(e_joint, 5e-14);
  EXPECT_LE(e_joint * 10, e_world);
}

// The revolute joints' split placement (Pa, Pc, Ps) of Kinematics<long double> is formed in
// long double: Pa + Pc = P and Ps = P ã to long-double rounding, which a split formed in double
// and widened misses by about 1e-16 (1.7e-16 on this tree).
TEST(AccuracyReference, KinematicsConstantsInLongDouble) {
  const Model model = randomTree({Topology::Serial, 64, 1, false});
  const Kinematics<long double> kin(model, Origin::EachRoot);
  long double worst = 0;
  int revolute = 0;
  for (int i = 0; i < model.nb(); ++i) {
    if (model.joint(i).type != JointType::Revolute) continue;
    ++revolute;
    const auto& c = kin.cols[i];
    const Mat3<long double> P = model.joint(i).placement.R.cast<long double>();
    const Mat3<long double> Ps = P * skew<long double>(model.joint(i).axis.cast<long double>());
    const Mat3<long double> sum = (c.Pa + c.Pc).template topRows<3>();
    worst = std::max(worst, (sum - P).cwiseAbs().maxCoeff());
    worst = std::max(worst, (c.Ps.template topRows<3>() - Ps).cwiseAbs().maxCoeff());
  }
  std::printf("%d revolute joints: max |Pa + Pc − P|, |Ps − P ã| = %.2Le\n", revolute, worst);
  ASSERT_GT(revolute, 0);
  EXPECT_LE(worst, 8 * 0x1.0p-64L);
}

}  // namespace
}  // namespace minv
