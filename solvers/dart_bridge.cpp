// The DART side of the `dart` solver; see solvers/dart_bridge.hpp. Compiled with DART's flags
// (cmake/peers/dart.cmake): the only minv headers it may include are the two plain ones.
#include "solvers/dart_bridge.hpp"

#include <dart/dynamics/BallJoint.hpp>
#include <dart/dynamics/BodyNode.hpp>
#include <dart/dynamics/FreeJoint.hpp>
#include <dart/dynamics/PrismaticJoint.hpp>
#include <dart/dynamics/RevoluteJoint.hpp>
#include <dart/dynamics/Skeleton.hpp>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <utility>

namespace minv {

namespace dd = dart::dynamics;

namespace {

// A unit quaternion (w, x, y, z), normalised as core/kinematics.hpp does, as a rotation.
Eigen::Matrix3d rotation(const double* wxyz) {
  return Eigen::Quaterniond(wxyz[0], wxyz[1], wxyz[2], wxyz[3]).normalized().toRotationMatrix();
}

// A plain placement as DART's T_ParentBodyToJoint.
Eigen::Isometry3d placement(const PlainBody& b) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::Map<const Eigen::Matrix3d>(b.placement_R);
  T.translation() = Eigen::Map<const Eigen::Vector3d>(b.placement_p);
  return T;
}

// Body i on a joint of type J under `parent` (nullptr: the world): the joint properties every
// type shares (name, placement, child frame at the joint), and the axis where J has one.
template <class J>
std::pair<dd::Joint*, dd::BodyNode*> addBody(dd::Skeleton& skel, dd::BodyNode* parent,
                                             const PlainBody& b, int i,
                                             const dd::BodyNode::Properties& body) {
  typename J::Properties p;
  p.mName = "j" + std::to_string(i);
  p.mT_ParentBodyToJoint = placement(b);
  p.mT_ChildBodyToJoint = Eigen::Isometry3d::Identity();
  if constexpr (std::is_same_v<J, dd::RevoluteJoint> || std::is_same_v<J, dd::PrismaticJoint>)
    p.mAxis = Eigen::Map<const Eigen::Vector3d>(b.axis);
  const auto pair = skel.template createJointAndBodyNodePair<J>(parent, p, body);
  return {pair.first, pair.second};
}

}  // namespace

// The Skeleton and what configure() needs; see solvers/dart_bridge.hpp for the contract.
class DartSkeletonBridge final : public DartBridge {
 public:
  void build(const std::vector<PlainBody>& bodies) override;
  int nv() const override { return static_cast<int>(positions_.size()); }
  void configure(const double* q) override;
  const double* inverse() override { return skel_->getInvMassMatrix().data(); }
  void massMatrix(double* out) override;
  void relativeJacobian(int body, double* out) override;

 private:
  dd::SkeletonPtr skel_;
  // Per body: its joint type, our first q entry, DART's first DOF, and its joint.
  struct Coord {
    PlainJoint type;
    int q, dof;
    dd::Joint* joint;
  };
  std::vector<Coord> coords_;
  Eigen::VectorXd positions_;  // DART's generalized positions, nv
};

void DartSkeletonBridge::build(const std::vector<PlainBody>& bodies) {
  skel_ = dd::Skeleton::create("minv");
  skel_->setGravity(Eigen::Vector3d::Zero());
  coords_.clear();
  std::vector<dd::BodyNode*> nodes(bodies.size(), nullptr);
  int nv = 0;
  for (int i = 0; i < static_cast<int>(bodies.size()); ++i) {
    const PlainBody& b = bodies[i];
    // Body: mass, centre of mass and rotational inertia about it, in the body frame.
    dd::BodyNode::Properties body;
    body.mName = "b" + std::to_string(i);
    body.mInertia = dd::Inertia(b.mass, Eigen::Map<const Eigen::Vector3d>(b.com),
                                Eigen::Map<const Eigen::Matrix3d>(b.inertia));
    dd::BodyNode* parent = b.parent < 0 ? nullptr : nodes.at(b.parent);
    // Joint: the body frame is the joint frame after the motion.
    std::pair<dd::Joint*, dd::BodyNode*> made;
    switch (b.joint) {
      case PlainJoint::Revolute:
        made = addBody<dd::RevoluteJoint>(*skel_, parent, b, i, body);
        break;
      case PlainJoint::Prismatic:
        made = addBody<dd::PrismaticJoint>(*skel_, parent, b, i, body);
        break;
      case PlainJoint::Spherical:
        made = addBody<dd::BallJoint>(*skel_, parent, b, i, body);
        break;
      case PlainJoint::Floating:
        made = addBody<dd::FreeJoint>(*skel_, parent, b, i, body);
        break;
    }
    dd::Joint* joint = made.first;
    nodes[i] = made.second;
    // DART's DOFs must be ours: same count per joint, numbered in creation order.
    const int dof = static_cast<int>(joint->getIndexInSkeleton(0));
    if (dof != b.v_index || dof != nv)
      throw std::runtime_error("dart: joint " + std::to_string(i) + " has DART DOF " +
                               std::to_string(dof) + ", ours is " + std::to_string(b.v_index));
    nv += static_cast<int>(joint->getNumDofs());
    coords_.push_back({b.joint, b.q_index, dof, joint});
  }
  if (static_cast<int>(skel_->getNumDofs()) != nv)
    throw std::runtime_error("dart: the Skeleton has " + std::to_string(skel_->getNumDofs()) +
                             " DOFs, ours " + std::to_string(nv));
  positions_ = Eigen::VectorXd::Zero(nv);
  // Allocate DART's caches (M⁻¹, articulated inertias) now rather than in the first inverse().
  skel_->setPositions(positions_);
  skel_->getInvMassMatrix();
}

void DartSkeletonBridge::configure(const double* q) {
  // Our q → DART's positions: angles and displacements as they are; a ball joint's rotation
  // and a free joint's pose as DART's exponential coordinates [log R; p].
  for (const Coord& c : coords_) {
    switch (c.type) {
      case PlainJoint::Revolute:
      case PlainJoint::Prismatic:
        positions_(c.dof) = q[c.q];
        break;
      case PlainJoint::Spherical:
        positions_.segment<3>(c.dof) = dd::BallJoint::convertToPositions(rotation(q + c.q));
        break;
      case PlainJoint::Floating: {
        Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
        T.linear() = rotation(q + c.q + 3);
        T.translation() = Eigen::Map<const Eigen::Vector3d>(q + c.q);
        positions_.segment<6>(c.dof) = dd::FreeJoint::convertToPositions(T);
        break;
      }
    }
  }
  skel_->setPositions(positions_);
  // setPositions skips a joint whose positions are unchanged (GenericJoint::
  // setPositionsStatic), and getInvMassMatrix() then returns its cache: mark every joint as
  // moved, which is what a new q does (transforms, Jacobians, articulated inertias, M⁻¹).
  for (const Coord& c : coords_) c.joint->notifyPositionUpdated();
}

void DartSkeletonBridge::massMatrix(double* out) {
  const Eigen::MatrixXd& M = skel_->getMassMatrix();
  Eigen::Map<Eigen::MatrixXd>(out, M.rows(), M.cols()) = M;
}

void DartSkeletonBridge::relativeJacobian(int body, double* out) {
  using Jacobian = Eigen::Matrix<double, 6, Eigen::Dynamic>;
  const Jacobian J = coords_.at(body).joint->getRelativeJacobian();
  Eigen::Map<Jacobian>(out, 6, J.cols()) = J;
}

// The module's entry point (solvers/dart_bridge.hpp): the only symbol it exports.
extern "C" __attribute__((visibility("default"))) DartBridge* minv_dart_bridge_create() {
  return new DartSkeletonBridge();
}

}  // namespace minv
