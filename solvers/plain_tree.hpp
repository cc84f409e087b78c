// A kinematic tree as plain numbers, for the adapters of peer libraries that are compiled with
// other flags than minv (Debian's generic x86-64 builds of DART and Bullet).
//
// Why: Eigen's alignment (EIGEN_MAX_ALIGN_BYTES) and so the layout and allocator of its types
// depend on the instruction set a translation unit is compiled for. A library built for
// generic x86-64 and our code must therefore never exchange Eigen objects: a peer's bridge
// (solvers/<peer>_bridge.cpp) is compiled with the peer's own flags and includes only this
// header from minv; between the two sides there are only doubles, ints and strings.
//
// Conventions are core/model.hpp's: bodies in parent-first order (parent < child, −1 for a
// root), joint frames placed in the parent body's frame, the axis in the joint frame, the
// centre of mass and the rotational inertia about it in the body frame. Matrices are 3×3,
// column-major.
#pragma once

#include <string>
#include <vector>

namespace minv {

enum class PlainJoint : int { Revolute = 0, Prismatic = 1, Spherical = 2, Floating = 3 };

struct PlainBody {
  std::string name, joint_name;
  int parent = -1;
  PlainJoint joint = PlainJoint::Revolute;
  double axis[3] = {0, 0, 1};
  double placement_R[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};  // joint frame in the parent's frame
  double placement_p[3] = {0, 0, 0};
  double mass = 1;
  double com[3] = {0, 0, 0};
  double inertia[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};  // about the centre of mass, body axes
  int q_index = 0, v_index = 0;                     // this body's first q and velocity entry
};

}  // namespace minv
