// The Bullet side of the `bullet` solver (solvers/bullet.hpp): a btMultiBody built from a plain
// tree, in Bullet's double-precision build. Free of Eigen and of Bullet: only this header and
// solvers/plain_tree.hpp are shared between solvers/bullet_bridge.cpp (compiled with Bullet's
// flags, -DBT_USE_DOUBLE_PRECISION) and minv's side.
//
// Bullet's coordinates (the vectors of size() entries that solve() takes and returns):
//   [0, 3)  base angular velocity ω, world coordinates     (force side: torque about the base com)
//   [3, 6)  base com velocity v_c, world coordinates       (force side: force)
//   [6, …)  joint velocities, link by link (link l = our body l, or l + 1 with a floating base):
//           revolute/prismatic q̇; spherical ω of the link relative to its parent, in the link's
//           principal frame P.
// With a fixed base the first six entries are zero on output and ignored on input.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "solvers/plain_tree.hpp"

namespace minv {

// A body's principal frame P at its centre of mass, made on minv's side (an eigen-decomposition
// of the inertia): R_BP (columns: the principal axes in body coordinates, column-major, a proper
// rotation) and the principal moments about the com, in the same order.
struct PrincipalFrame {
  double R[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};
  double moments[3] = {1, 1, 1};
};

class BulletBridge {
 public:
  // Builds the btMultiBody: a fixed base (the world) under every root, or, where body 0 has a
  // floating joint, body 0 as Bullet's movable base; every other body is a link, each with its
  // principal frame. Throws std::runtime_error for a tree Bullet cannot hold (see supported()).
  BulletBridge(const std::vector<PlainBody>& bodies, const std::vector<PrincipalFrame>& frames);
  ~BulletBridge();
  BulletBridge(const BulletBridge&) = delete;
  BulletBridge& operator=(const BulletBridge&) = delete;

  // Empty if Bullet can hold this tree, else the reason (names "bullet:").
  static std::string supported(const std::vector<PlainBody>& bodies,
                               const std::vector<PrincipalFrame>& frames);

  // 6 + Bullet's joint DOFs: the length of solve()'s vectors.
  int size() const;
  // Sets our configuration q (core/model.hpp's layout) and recomputes Bullet's cached joint
  // transforms and articulated-body quantities at zero velocity. Does not allocate.
  void configure(const double* q);
  // out = M_b⁻¹ force in Bullet's coordinates (one articulated-body pass). Does not allocate.
  void solve(const double* force, double* out);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace minv
