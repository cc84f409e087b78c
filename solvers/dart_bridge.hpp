// The DART side of the `dart` solver (solvers/dart.hpp): a dart::dynamics::Skeleton built from
// a plain tree (solvers/plain_tree.hpp), behind an interface of plain doubles and ints.
//
// This header is included by both sides of the bridge, which are compiled with different
// flags (solvers/dart_bridge.cpp as Debian compiled libdart: generic x86-64, Eigen's default
// alignment; solvers/dart.cpp as minv: -march=native, 64-byte Eigen alignment). It must
// therefore never name an Eigen or a DART type: only doubles, ints, std::vector, std::string.
// The bridge is a module of its own, loaded with dlopen (solvers/dart.hpp says why): minv
// reaches it only through minv_dart_bridge_create() and the virtual functions below.
//
// DOF order: DART numbers a Skeleton's DOFs in the order its joints were created; the bridge
// creates them in our body order, so DART's DOF k is ours (checked in build()). Velocities:
// DART 6.12's revolute, prismatic and ball velocities are ours, and so is its free joint's
// [ω; v] in the child frame (its relative Jacobian is Ad(T_ChildBodyToJoint) = 1 here), so
// DART's M⁻¹ is ours with no transform (see solvers/dart.hpp).
#pragma once

#include <vector>

#include "solvers/plain_tree.hpp"

namespace minv {

class DartBridge {
 public:
  virtual ~DartBridge() = default;

  // Builds the Skeleton (one joint and body node per body, in order) and allocates DART's
  // caches. Throws std::runtime_error if DART's DOF count or order is not ours.
  virtual void build(const std::vector<PlainBody>& bodies) = 0;
  virtual int nv() const = 0;

  // Sets DART's positions from our q (size nq; quaternions (w, x, y, z)) and marks every
  // joint's position as changed, so that the next inverse() recomputes from scratch even
  // when q equals the previous configuration.
  virtual void configure(const double* q) = 0;

  // DART's M⁻¹ (getInvMassMatrix) at the last configuration: nv×nv, column-major, valid until
  // the next configure(). Computed on the first call after configure(), cached after.
  virtual const double* inverse() = 0;

  // For tests (allocate): DART's M (getMassMatrix) into out (nv×nv, column-major); and the
  // relative Jacobian of body i's joint (6×k, DART's [angular; linear] in the child frame).
  virtual void massMatrix(double* out) = 0;
  virtual void relativeJacobian(int body, double* out) = 0;
};

// The bridge module's one exported function (looked up by this name with dlsym): a new bridge,
// owned by the caller (delete it through the virtual destructor).
extern "C" DartBridge* minv_dart_bridge_create();
inline constexpr const char* kDartBridgeCreate = "minv_dart_bridge_create";

}  // namespace minv
