// `bullet`: Bullet 3.24's btMultiBody (Featherstone's articulated-body algorithm, Mirtich's
// formulation) as a peer, in Bullet's double-precision build (libBullet*-float64, btScalar =
// double). prepare() builds a btMultiBody from the plain tree (solvers/plain_tree.hpp);
// configure(q) sets the base pose and joint positions and runs Bullet's articulated-body pass
// (computeAccelerationsArticulatedBodyAlgorithmMultiDof at zero velocity, dt = 0), which caches
// the joint transforms, h = IA S, D⁻¹ and the base's articulated inertia; inverse() and solve(R)
// then apply one generalized impulse per column with calcAccelerationDeltasMultiDof (the
// velocity-free ABA: Δν = M_b⁻¹ f).
//
// Bullet's model. Every link frame sits at the link's centre of mass, and Bullet takes the
// rotational inertia as a diagonal in that frame, so each link frame is the body's principal
// frame P: R_BP (columns: eigenvectors of Ī_c, det +1) and moments λ, Ī_c = R_BP diag(λ) R_BPᵀ.
// Body i (ours) is link i (fixed base: our roots hang from Bullet's fixed base, the world) or
// link i − 1 (floating base: our body 0 is Bullet's movable base), so Bullet's parent < child.
// The pivot is our joint frame's origin:
//   parentComToThisPivotOffset e = R_B'P'ᵀ (placement.p − c')   (P' = parent's frame; world at a
//                                                                 root: R = 1, c' = 0)
//   thisPivotToThisComOffset   d = R_BPᵀ c,   joint axis a_P = R_BPᵀ a
//   rotParentToThis            E₀ = R_BPᵀ placement.Rᵀ R_B'P'    (P' → P coordinates at q = 0)
// Bullet's joint transform (btMultibodyLink::updateCacheMultiDof) is E = Rot(a_P, −q) E₀ for a
// revolute joint, i.e. the child turns by +q about a_P: Bullet's angle is ours, no offset; a
// prismatic joint moves the child by q a_P; a spherical joint with position (x, y, z, w) has
// E = conj(Q) E₀: the child's rotation Q in P coordinates, so Q = (R_BPᵀ v, w) for our (w, v).
//
// Base. A fixed base is the world (identity pose); a floating body 0 of pose (R, p) = placement
// · X_J(q) becomes Bullet's base at its com, setBasePos(p + R c), setWorldToBaseRot((R R_BP)ᵀ).
//
// Coordinates. Bullet's velocity (the force and output of calcAccelerationDeltasMultiDof) is
// ν_b = [ω_w; v_c,w; joint rates]: the base's angular velocity and com velocity in world
// coordinates (always 6 base entries, zero for a fixed base), then the joints in link order; a
// spherical joint's rate is the relative angular velocity in P. Its force side is [τ_c; f; joint
// forces], τ_c about the base com, world coordinates. Ours (core/model.hpp) is ν = T ν_b with,
// for a floating base of orientation R (body → world) and com c (body frame),
//   ω = Rᵀ ω_w,   v_O = Rᵀ v_c,w + c × ω         (T_base = [Rᵀ, 0; c̃ Rᵀ, Rᵀ])
//   ω_sph = R_BP ω_P                             (spherical joints)
// and the identity on revolute and prismatic rates (no permutation: our DOF k is Bullet's k, or
// 6 + k with a fixed base). Then M = T⁻ᵀ M_b T⁻¹ and
//   M⁻¹ = T M_b⁻¹ Tᵀ,   M⁻¹R = T M_b⁻¹ (Tᵀ R),
// Tᵀ taking our generalized forces [n; f] (body frame, about the body origin) to Bullet's
// [R (n − c × f); R f] and a spherical torque τ to R_BPᵀ τ. Nothing else enters: Bullet's
// damping and gyroscopic terms multiply velocities (zero here; damping is set to 0 and the
// gyroscopic term off regardless), and maxAppliedImpulse / maxCoordinateVelocity only clamp
// applyDeltaVee*, which is never called.
//
// Precision: double throughout (BT_USE_DOUBLE_PRECISION is confined to bullet_bridge.cpp; only
// plain numbers cross). Limits (supports()): a btMultiBody has one base, so a floating body 0
// beside another root is declined; Bullet silently zeroes a 1-DOF D⁻¹ or the single-body base
// inverse below SIMD_EPSILON (2.2e-16), so a mass or principal moment below it is declined; its
// dofs² D⁻¹ buffer is int-indexed (declined beyond ~46000 DOFs).
// Cost: configure() Θ(n); inverse() n passes of Θ(n) each (Θ(n²), no use of symmetry);
// solve(R) m passes, Θ(m n); all O(n) per column. Bullet keeps dofs² scalars for its D⁻¹
// blocks (btMultiBody::finalizeMultiDof), allocated in prepare().
#pragma once

#include <Eigen/Core>
#include <memory>
#include <string>

#include "solvers/solver.hpp"

namespace minv {

class BulletSolver final : public Solver {
 public:
  static constexpr const char* kSummary =
      "Bullet 3.24 btMultiBody, double precision: M⁻¹ by n unit impulses, O(n) articulated-body "
      "pass each; M⁻¹R by columns";

  BulletSolver();
  ~BulletSolver() override;

  bool supports(const Model& model, std::string* why) const override;
  void prepare(const Model& model) override;
  void configure(const Eigen::VectorXd& q) override;
  void inverse(MatrixOut Minv) override;
  void solve(MatrixIn R, MatrixOut X) override;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace minv
