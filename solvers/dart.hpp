// `dart`: DART 6.12 (Debian's libdart-dev) as a peer. prepare() builds a dart::dynamics::
// Skeleton with one joint and body node per body, in our order: RevoluteJoint, PrismaticJoint,
// BallJoint, FreeJoint, placed by T_ParentBodyToJoint = our placement with the child frame at
// the joint (T_ChildBodyToJoint = 1), a root attached to the world, Inertia(mass, com, inertia
// about the com). configure(q) sets DART's positions; inverse() is Skeleton::
// getInvMassMatrix(), which runs DART's articulated-body pass once per unit generalized force
// (Θ(n²) for a chain, double); solve(R) = M⁻¹·R, a GEMM on that matrix (DART has no M⁻¹R).
//
// Coordinates. DART numbers DOFs by joint creation order (= our body order, checked in
// prepare), so DART's DOF k is ours. Positions: angles and displacements as they are; a ball
// joint's position is DART's exponential coordinates log R (BallJoint::convertToPositions of
// our quaternion's rotation), a free joint's is [log R; p] (FreeJoint::convertToPositions of
// X_J(q) = (R, p)). Velocities are read off DART's relative Jacobians J (V_child = J q̇_DART,
// [angular; linear] in the child frame; relativeJacobian() below, at rotated configurations):
// revolute [a; 0], prismatic [0; a], ball [1; 0], free 1 (DART 6.12; DART's main branch reads
// free J = diag(Rᵀ, Rᵀ), parent-frame velocities: recheck on an upgrade). So DART's velocities
// are ours (ball: ω in the child frame; free: [ω; v] of the body in the body frame), and with
// ν_ours = T ν_DART,
//   T = 1,   M = M_DART,   M⁻¹ = T M_DART⁻¹ Tᵀ = M_DART⁻¹,   M⁻¹R = M_DART⁻¹ R.
//
// Caching. DART caches M⁻¹ until a position changes, and GenericJoint::setPositionsStatic
// ignores a write of unchanged values, so a benchmark repeating configure(q) + inverse() at
// one q would time a copy of the cache. configure() therefore calls Joint::
// notifyPositionUpdated() on every joint after setPositions: exactly what a new q triggers
// (transforms, Jacobians, articulated inertias and M⁻¹ marked stale). Measured (n = 64
// revolute chain): 678 µs per configure + inverse at one q, 674 µs alternating two q; 0.3 µs
// at one q without the notification.
//
// Alignment. Debian compiled libdart for generic x86-64 with Eigen's default 16-byte alignment;
// minv compiles with -march=native and EIGEN_MAX_ALIGN_BYTES=64. A minv translation unit that
// includes DART's headers and builds a Skeleton aborts (std::bad_alloc), so every DART call is
// in solvers/dart_bridge.cpp, compiled with DART's flags, and only plain numbers cross
// (solvers/plain_tree.hpp, solvers/dart_bridge.hpp); this file and dart.cpp include no DART
// header. That is not enough at run time: minv's shared libraries export their out-of-line
// Eigen instantiations (aligned_malloc, PlainObjectBase<MatrixXd>::resize, GEMV kernels), and
// a libdart loaded with them binds its own calls to those native, 64-byte copies (113 such
// bindings, LD_DEBUG=bindings). So the bridge is a module of its own (cmake/peers/dart.cmake)
// that minv does not link: dart.cpp loads it once with dlopen(RTLD_LOCAL | RTLD_DEEPBIND),
// next to libminv_solvers or at its build path, which loads libdart with it, bound to its own
// symbols first. (A process that has already loaded libdart otherwise keeps that binding.)
//
// Limits (supports()): none found; every tree our Model accepts (positive mass, positive
// definite rotational inertia) DART represents. supports() is false only when the bridge
// module cannot be loaded, with dlopen's reason.
// Cost: prepare() Θ(n) (plus DART's nv² caches); configure() Θ(n); inverse() Θ(n²) for any
// topology: per unit force j a backward pass over all bodies and a forward pass up to DOF j's
// body (the upper triangle, then mirrored), plus an nv² copy; solve(R) that and Θ(nv²·m).
#pragma once

#include <memory>
#include <string>

#include "solvers/solver.hpp"

namespace minv {

class DartSolver final : public Solver {
 public:
  static constexpr const char* kSummary =
      "DART 6.12 Skeleton::getInvMassMatrix: articulated-body pass per unit force, double; "
      "solve = M⁻¹·R";

  DartSolver();
  ~DartSolver() override;

  bool supports(const Model& model, std::string* why) const override;
  void prepare(const Model& model) override;
  void configure(const Eigen::VectorXd& q) override;
  void inverse(MatrixOut Minv) override;
  void solve(MatrixIn R, MatrixOut X) override;

  // For tests (allocate): DART's M at the last configuration (Skeleton::getMassMatrix), in
  // our coordinates (the same); and body i's joint's relative Jacobian (6×nvOf(i), DART's
  // [angular; linear] in the child frame), which is how the velocity mapping was read off.
  Eigen::MatrixXd massMatrix() const;
  Eigen::MatrixXd relativeJacobian(int body) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace minv
