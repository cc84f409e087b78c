// The Bullet side of the `bullet` solver; conventions in solvers/bullet_bridge.hpp and
// solvers/bullet.hpp. Compiled with Bullet's flags (bullet-float64: BT_USE_DOUBLE_PRECISION).
#include "solvers/bullet_bridge.hpp"

#include <BulletDynamics/Featherstone/btMultiBody.h>
#include <LinearMath/btScalar.h>

#include <climits>
#include <cmath>
#include <stdexcept>
#include <string>
#include <type_traits>

#include "solvers/plain_tree.hpp"

static_assert(std::is_same_v<btScalar, double>,
              "solvers/bullet_bridge.cpp must be compiled with -DBT_USE_DOUBLE_PRECISION");

namespace minv {

namespace {

// A column-major 3×3 of plain doubles as Bullet's (row-major constructor) matrix.
btMatrix3x3 matrix(const double* m) {
  return btMatrix3x3(m[0], m[3], m[6], m[1], m[4], m[7], m[2], m[5], m[8]);
}

btVector3 vector(const double* v) {
  return btVector3(v[0], v[1], v[2]);
}

// The rotation of our quaternion (w, x, y, z), normalised.
btMatrix3x3 rotation(const double* wxyz) {
  btQuaternion r(wxyz[1], wxyz[2], wxyz[3], wxyz[0]);
  r.normalize();
  return btMatrix3x3(r);
}

// A rotation matrix as a unit quaternion (Bullet's own conversion).
btQuaternion quaternion(const btMatrix3x3& R) {
  btQuaternion r;
  R.getRotation(r);
  r.normalize();
  return r;
}

// Whether body i is Bullet's movable base: body 0 with a floating joint.
bool floatingBase(const std::vector<PlainBody>& bodies) {
  return !bodies.empty() && bodies[0].joint == PlainJoint::Floating;
}

int jointDofs(PlainJoint t) {
  switch (t) {
    case PlainJoint::Revolute:
    case PlainJoint::Prismatic:
      return 1;
    case PlainJoint::Spherical:
      return 3;
    case PlainJoint::Floating:
      return 6;
  }
  return 0;
}

}  // namespace

struct BulletBridge::Impl {
  std::unique_ptr<btMultiBody> mb;
  bool floating = false;
  int offset = 0;  // link l is our body l + offset
  // Per link, what configure() needs: its joint, our q index and R_BPᵀ (spherical).
  struct Link {
    PlainJoint joint;
    int q;
    btMatrix3x3 RBPt;
  };
  std::vector<Link> links;
  // A floating base: the placement of body 0's joint, R_BP and com of body 0.
  btMatrix3x3 place_R, base_RBP;
  btVector3 place_p, base_com;
  // Bullet's scratch arrays, sized once in the constructor.
  btAlignedObjectArray<btScalar> aba_r, delta_r;
  btAlignedObjectArray<btVector3> aba_v, delta_v;
  btAlignedObjectArray<btMatrix3x3> aba_m;
};

std::string BulletBridge::supported(const std::vector<PlainBody>& bodies,
                                    const std::vector<PrincipalFrame>& frames) {
  if (bodies.empty()) return "bullet: the tree has no bodies";
  if (frames.size() != bodies.size()) return "bullet: one principal frame per body is needed";
  const bool floating = floatingBase(bodies);
  long long dofs = 0;
  for (std::size_t i = 0; i < bodies.size(); ++i) {
    const PlainBody& b = bodies[i];
    // One base per btMultiBody: a floating body 0 leaves no place for another root.
    if (floating && i > 0 && b.parent < 0)
      return "bullet: body " + std::to_string(i) +
             " is attached to the world beside the floating body 0, but a btMultiBody has one "
             "base";
    // Bullet drops (zeroes) a 1-DOF D⁻¹ below SIMD_EPSILON and a base inverse inertia below
    // it; D ≥ the mass (prismatic) or the smallest principal moment (revolute).
    const double* m = frames[i].moments;
    if (!(b.mass >= SIMD_EPSILON) || !(m[0] >= SIMD_EPSILON) || !(m[1] >= SIMD_EPSILON) ||
        !(m[2] >= SIMD_EPSILON))
      return "bullet: body " + std::to_string(i) +
             " has a mass or principal moment of inertia below Bullet's SIMD_EPSILON (2.2e-16), "
             "which Bullet 3.24's articulated-body pass treats as zero";
    if (!(floating && i == 0)) dofs += jointDofs(b.joint);
  }
  // btMultiBody keeps dofs² scalars for its D⁻¹ blocks, indexed with int.
  if (dofs * dofs + 2 * dofs + 12 > INT_MAX)
    return "bullet: " + std::to_string(dofs) +
           " joint DOFs overflow the int-indexed dofs² buffer of btMultiBody::finalizeMultiDof";
  return {};
}

BulletBridge::BulletBridge(const std::vector<PlainBody>& bodies,
                           const std::vector<PrincipalFrame>& frames)
    : impl_(std::make_unique<Impl>()) {
  const std::string why = supported(bodies, frames);
  if (!why.empty()) throw std::runtime_error(why);
  Impl& s = *impl_;
  s.floating = floatingBase(bodies);
  s.offset = s.floating ? 1 : 0;
  const int nb = static_cast<int>(bodies.size());
  const int nl = nb - s.offset;

  // The base: body 0 at its com in its principal frame, or a fixed base at the world origin.
  if (s.floating) {
    const PlainBody& b = bodies[0];
    s.mb = std::make_unique<btMultiBody>(nl, b.mass, vector(frames[0].moments), false, false);
    s.place_R = matrix(b.placement_R);
    s.place_p = vector(b.placement_p);
    s.base_RBP = matrix(frames[0].R);
    s.base_com = vector(b.com);
  } else {
    s.mb = std::make_unique<btMultiBody>(nl, 1.0, btVector3(1, 1, 1), true, false);
  }

  // One link per remaining body, in our (parent-first) order, so Bullet's parent < child.
  s.links.reserve(nl);
  for (int i = s.offset; i < nb; ++i) {
    const PlainBody& b = bodies[i];
    const int l = i - s.offset;
    const int p = b.parent;
    const int bullet_parent = p < 0 || (s.floating && p == 0) ? -1 : p - s.offset;
    // The parent's principal frame P' (R_B'P', com c'); the world for a root.
    btMatrix3x3 RBPp = btMatrix3x3::getIdentity();
    btVector3 cp(0, 0, 0);
    if (p >= 0) {
      RBPp = matrix(frames[p].R);
      cp = vector(bodies[p].com);
    }
    const btMatrix3x3 RBP = matrix(frames[i].R);
    const btMatrix3x3 RBPt = RBP.transpose();
    // The pivot is the joint frame's origin: e = R_B'P'ᵀ (placement.p − c') in P', d = R_BPᵀ c
    // in P; rotParentToThis (P' → P coordinates at q = 0) = R_BPᵀ placementᵀ R_B'P'.
    const btVector3 e = RBPp.transpose() * (vector(b.placement_p) - cp);
    const btVector3 d = RBPt * vector(b.com);
    const btQuaternion E0 = quaternion(RBPt * matrix(b.placement_R).transpose() * RBPp);
    const btVector3 inertia = vector(frames[i].moments);
    const btVector3 axis = RBPt * vector(b.axis);
    switch (b.joint) {
      case PlainJoint::Revolute:
        s.mb->setupRevolute(l, b.mass, inertia, bullet_parent, E0, axis, e, d, true);
        break;
      case PlainJoint::Prismatic:
        s.mb->setupPrismatic(l, b.mass, inertia, bullet_parent, E0, axis, e, d, true);
        break;
      case PlainJoint::Spherical:
        s.mb->setupSpherical(l, b.mass, inertia, bullet_parent, E0, e, d, true);
        break;
      case PlainJoint::Floating:
        throw std::runtime_error("bullet: only body 0 may carry a floating joint");
    }
    s.links.push_back({b.joint, b.q_index, RBPt});
  }
  s.mb->finalizeMultiDof();

  // No damping, no gyroscopic term, zero velocities and forces: with these the
  // articulated-body pass of configure() leaves only the inertias (and they are velocity-free
  // anyway: Bullet's damping and gyroscopic terms multiply the velocities).
  s.mb->setLinearDamping(0);
  s.mb->setAngularDamping(0);
  s.mb->setUseGyroTerm(false);
  s.mb->setCanSleep(false);
  s.mb->clearVelocities();
  s.mb->clearForcesAndTorques();
  s.mb->clearConstraintForces();

  // Size Bullet's scratch arrays once (the passes resize them to the same sizes later).
  s.aba_r.resize(2 * s.mb->getNumDofs() + 7);
  s.aba_v.resize(8 * nl + 6);
  s.aba_m.resize(4 * nl + 4);
  s.delta_r.resize(s.mb->getNumDofs());
  s.delta_v.resize(4 * nl + 4);
}

BulletBridge::~BulletBridge() = default;

int BulletBridge::size() const {
  return 6 + impl_->mb->getNumDofs();
}

void BulletBridge::configure(const double* q) {
  Impl& s = *impl_;
  btMultiBody& mb = *s.mb;
  // Floating base: body 0's pose placement · X_J(q); Bullet's base is its com, and Bullet
  // stores the world → base (P) rotation.
  if (s.floating) {
    const btMatrix3x3 R = s.place_R * rotation(q + 3);
    const btVector3 p = s.place_p + s.place_R * vector(q);
    mb.setBasePos(p + R * s.base_com);
    mb.setWorldToBaseRot(quaternion((R * s.base_RBP).transpose()));
  }
  // Joints: Bullet's revolute angle and prismatic displacement are ours; a spherical joint's
  // rotation in P coordinates is R_BPᵀ R(q) R_BP: quaternion (R_BPᵀ v, w), stored (x, y, z, w).
  for (int l = 0; l < static_cast<int>(s.links.size()); ++l) {
    const Impl::Link& k = s.links[l];
    if (k.joint == PlainJoint::Spherical) {
      const double* w = q + k.q;
      const double norm = std::sqrt(w[0] * w[0] + w[1] * w[1] + w[2] * w[2] + w[3] * w[3]);
      const btVector3 v = k.RBPt * btVector3(w[1], w[2], w[3]) / norm;
      const double xyzw[4] = {v.x(), v.y(), v.z(), w[0] / norm};
      mb.setJointPosMultiDof(l, xyzw);
    } else {
      mb.setJointPos(l, q[k.q]);
    }
  }
  // The articulated-body pass (dt = 0: velocities untouched) caches what
  // calcAccelerationDeltasMultiDof reads: rot_from_parent, h = IA S, D⁻¹ and the base's IA.
  mb.computeAccelerationsArticulatedBodyAlgorithmMultiDof(0, s.aba_r, s.aba_v, s.aba_m, false,
                                                          false, false);
}

void BulletBridge::solve(const double* force, double* out) {
  Impl& s = *impl_;
  s.mb->calcAccelerationDeltasMultiDof(force, out, s.delta_r, s.delta_v);
}

}  // namespace minv
