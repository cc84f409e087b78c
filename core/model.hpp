// The kinematic tree: an immutable description of bodies, joints and their parent array.
//
// Bodies are numbered 0 … nb−1 with parent(i) < i and parent −1 for a body attached to the
// world (RBDA §4.1.2, 0-based). Body i's joint connects parent(i) to i. Joint types:
//   revolute, prismatic  1 DOF, q = angle / displacement along `axis` (joint frame)
//   spherical            3 DOF, q = unit quaternion (w, x, y, z) of the joint rotation,
//                        velocity = angular velocity in the child (body) frame
//   floating             6 DOF, only on a root body; q = (p_x, p_y, p_z, w, x, y, z): the body
//                        origin in world and its orientation; velocity = the body's spatial
//                        velocity [ω; v] expressed in the body frame (RBDA §4.5, "in body
//                        coordinates"), so M's 6×6 base block is the tree's composite inertia
//                        in the base frame.
// Body i's frame is its joint frame after the joint motion; `placement` puts the joint frame
// in the parent body's frame (or in the world for a root).
// Velocity DOFs are numbered body by body; dofParent() is the DOF parent array of
// Featherstone's expandLambda: within a multi-DOF joint each DOF's parent is the previous one.
#pragma once

#include <Eigen/Core>
#include <stdexcept>
#include <string>
#include <vector>

#include "core/spatial.hpp"

namespace minv {

// Every rejected model, file or configuration throws this, with a message naming the place.
struct ModelError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// A number in a message: the shortest text that reads back to the same double ("1e-09",
// "0.30000000000000004"), and "nan", "inf" or "-inf" for the non-finite ones.
std::string formatNumber(double x);

// The largest magnitude a model's physical quantities may have: a mass, an entry of a
// rotational inertia, a coordinate of a centre of mass or of a joint placement's translation.
// Within it, every product minv's kernels form (m·r², sums over the tree, their squares in a
// factorization) stays finite; beyond it a model is rejected at load, naming the place.
inline constexpr double kMaxPhysicalMagnitude = 1e30;
// The largest length a model or a configuration may hold: a coordinate of a centre of mass, of a
// joint placement's translation, of a floating base's position, a prismatic displacement. The
// paper's kernels work in world-aligned coordinates, where a body at distance |p| from the
// origin costs about |p|²·ε of relative accuracy in M. The solvers put the origin at each tree's
// root joint (Origin::EachRoot, core/kinematics.hpp), so where a tree stands costs nothing; the
// limit bounds the lengths within a tree, and the simulator's world-frame kinematics.
inline constexpr double kMaxLength = 1e4;
// The largest revolute angle (rad) a configuration may hold, about 160 000 turns: beyond it an
// angle keeps too few digits below the radian to place its joint (at 1e16 none), and DART's
// joint transform check aborted the process on angles from 1e160 on.
inline constexpr double kMaxAngle = 1e6;
// The smallest ratio of a body's smallest principal moment of inertia e₀ (about its centre of
// mass) to m·r², its mass times the squared distance r of the centre of mass from the origin of
// its tree's root body frame, where the solvers' world-aligned frame has its origin (r bounded
// over all angles by the placements' lengths and |c|). The kernels form m r² products there,
// rounded by a few ε·m r²; at the ratio that is under a tenth of e₀. Below it the body is a point
// mass to double precision, and M can lose its positive definiteness. Random trees never reach
// it (generators/random_tree.hpp's kMaxTreeLinks).
inline constexpr double kMinInertiaRatio = 1e-14;

enum class JointType { Revolute, Prismatic, Spherical, Floating };

int jointNv(JointType t);
int jointNq(JointType t);
const char* jointTypeName(JointType t);
JointType jointTypeFromName(const std::string& name);  // throws ModelError

struct Joint {
  std::string name;
  JointType type = JointType::Revolute;
  Eigen::Vector3d axis = Eigen::Vector3d::UnitZ();  // unit; used by revolute and prismatic
  Pose<double> placement;                           // joint frame in the parent body frame
};

struct Body {
  std::string name;
  double mass = 1.0;
  Eigen::Vector3d com = Eigen::Vector3d::Zero();          // in the body frame
  Eigen::Matrix3d inertia = Eigen::Matrix3d::Identity();  // about the com, body axes
};

// The smallest principal moment of a body's rotational inertia (of its symmetric part): what a
// peer that refuses small inertias compares.
double smallestPrincipalMoment(const Body& b);

// One body from links joined rigidly (URDF fixed joints, MJCF welded bodies), each given by its
// mass, centre of mass and inertia about it in the body's frame: total mass, mass-weighted
// centre, Σ Ī_k + m_k (|d_k|² 1 − d_k d_kᵀ) with d_k = c_k − c (parallel-axis theorem, about
// the common centre, so far-off links lose no accuracy). One part is returned unchanged. The
// name is left empty; the parts must have positive mass.
Body mergeRigid(const std::vector<Body>& parts);

class Model {
 public:
  // Validates and builds; throws ModelError naming the first problem found: a parent after its
  // child, a non-positive or out-of-range mass, an inertia that is not symmetric positive
  // definite or breaks the triangle inequality or is negligible against m·r², r its centre of
  // mass's distance from its tree's root body frame, bounded over all angles (kMinInertiaRatio),
  // a zero or non-finite axis, a placement that is not a rigid transform, a mass or inertia beyond
  // kMaxPhysicalMagnitude, a length beyond kMaxLength, a name that is not valid UTF-8, two bodies
  // or two joints with the same (non-empty) name.
  static Model create(std::vector<int> parent, std::vector<Joint> joints, std::vector<Body> bodies);

  int nb() const { return static_cast<int>(parent_.size()); }
  int nq() const { return nq_; }
  int nv() const { return nv_; }
  bool floatingBase() const { return nb() > 0 && joints_[0].type == JointType::Floating; }

  int parent(int i) const { return parent_[i]; }
  const std::vector<int>& parents() const { return parent_; }
  const Joint& joint(int i) const { return joints_[i]; }
  const Body& body(int i) const { return bodies_[i]; }
  int qIdx(int i) const { return q_idx_[i]; }
  int vIdx(int i) const { return v_idx_[i]; }
  int nvOf(int i) const { return nv_of_[i]; }

  // DOF parent array (expandLambda) and the body each DOF belongs to.
  const std::vector<int>& dofParent() const { return dof_parent_; }
  int dofBody(int k) const { return dof_body_[k]; }
  std::vector<std::string> dofNames() const;
  // Names of the q entries: a 1-DOF joint's name; "<joint>_qw" … "_qz" for a spherical joint's
  // quaternion; "<joint>_x", "_y", "_z", "_qw" … "_qz" for a floating joint.
  std::vector<std::string> qNames() const;
  // Depth of each body (a root has depth 1) and the tree's maximum depth.
  int depth(int i) const { return depth_[i]; }
  int maxDepth() const;

  // The neutral configuration (zero angles, identity quaternions).
  Eigen::VectorXd neutral() const;
  // Throws ModelError if q has the wrong size, a non-finite entry, a zero quaternion or one with
  // an entry beyond ±1e100 (its norm would overflow), a floating base position or a
  // prismatic displacement beyond ±kMaxLength, a revolute angle beyond ±kMaxAngle, or prismatic
  // displacements that carry a body to where it is a point mass (see create).
  void checkConfiguration(const Eigen::VectorXd& q) const;

 private:
  std::vector<int> parent_;
  std::vector<Joint> joints_;
  std::vector<Body> bodies_;
  std::vector<int> q_idx_, v_idx_, nv_of_, depth_, dof_parent_, dof_body_;
  // Per body: its joint's distance from its tree's root body frame (placements only), and the
  // greatest distance of its centre of mass from there at which it is not a point mass.
  std::vector<double> joint_reach_, max_reach_;
  bool prismatic_ = false;  // a prismatic joint below a root
  int nq_ = 0, nv_ = 0;
};

}  // namespace minv
