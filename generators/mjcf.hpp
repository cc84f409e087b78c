// MuJoCo's MJCF, both ways: our tree written as MJCF for MuJoCo's compiler (the `mujoco`
// solver, solvers/mujoco.hpp), and MJCF files read through MuJoCo's own parser into our tree.
//
// Export (toMjcf). Body i is <body name="b<i>"> with pos/quat = its joint placement, one joint
// <joint name="j<i>"> at the body origin (hinge, slide, ball; a floating joint is a free
// joint), armature, damping and ref 0, and <inertial> with the body's mass, centre of mass and
// principal moments, the principal axes as the inertial quat (diagonalised here, with Eigen,
// so MuJoCo's compiler does no eigen-decomposition of its own). inertiafromgeom="false",
// boundmass = boundinertia = 0, no balanceinertia, no settotalmass: MuJoCo keeps the inertias
// as given (to rounding: numbers are written in shortest round-trip form). Bodies are written
// depth-first, children in index order, which is MuJoCo's body numbering.
//   MuJoCo 2.2.2 parses XML with tinyxml2 (Debian's 9.0), which refuses an element nested 100
// deep: one MJCF file holds a chain of at most 96 nested bodies (measured: 96 load, 97 fail
// with XML_ELEMENT_DEPTH_EXCEEDED). toMjcf therefore splits a deep tree into several files:
// below a body nested kMjcfNestPerFile deep in its file, the children go to a new file
// "part<k>.xml" pulled in by <include>. MuJoCo splices included files into the parsed document,
// which has no depth limit, so any depth loads (measured: 1000-body ball chains, nv = 3000;
// a 3000-body ball chain, nv = 9000, fails in MuJoCo's mjData allocation, whose int-sized
// buffer holds ≈ 35·nv² bytes for a chain: see solvers/mujoco.hpp).
//
// Import (loadMjcf, modelFromMujoco). The file is compiled by MuJoCo (mj_loadXML, so
// defaults, <include>, inertiafromgeom, fusestatic etc. are MuJoCo's), then the compiled
// mjModel becomes our tree, in MuJoCo's body and joint order (so our q and v numbering is
// MuJoCo's qpos and qvel numbering, except that a free joint's velocity is [ω; v] in the
// body frame where MuJoCo has [v (world); ω (local)]):
//   hinge → revolute, slide → prismatic, ball → spherical, free → floating (our body 0 only;
//   placement identity, q = MuJoCo's qpos);
//   a body without joints is welded to its parent: its mass, centre of mass and inertia are
//   merged into the parent's body (parallel-axis theorem); one welded to the world is dropped
//   and its children become roots;
//   a joint not at the body origin (jnt_pos ≠ 0) puts our joint frame at its anchor: our body
//   frame is MuJoCo's shifted by the anchor (same orientation), so the same motion;
//   a body with k > 1 joints (MuJoCo applies them in order, each about its own anchor and
//   axis in the body frame as moved by the earlier ones) becomes a chain of k of our bodies
//   named "<body>", with the first k − 1 named "<body>:<joint>". Our bodies need a positive
//   mass, so each of those joint-only bodies carries kJointOnlyMassFraction (1e-10) of the
//   MuJoCo body's mass and inertia (same centre of mass, as at zero joint values); the last
//   body carries the full mass. M changes by about that fraction of the body's contribution:
//   relative error ≲ 1e-10. (Exact would need massless bodies in core/model.hpp.)
//   hinge and slide `ref` (qpos0): our zero is MuJoCo's qpos0, q = qpos − qpos0;
//   MuJoCo's armature (added to M's diagonal) and everything non-inertial are ignored.
// floating_base = true: a model without a free joint gets one on the first child body of the
// world, which must have no joints of its own (the robot's base); false never removes a free
// joint the file has. ModelError for: a file MuJoCo refuses (its message, and for the nesting
// limit an explanation), a free joint not on the first root or not alone on its body, a body
// that ends up without mass.
//   Caveat: MuJoCo takes a ball or free joint's rotation axes from the body's final frame
// ("assume no subsequent rotations"), so for a body that has a rotating joint after a ball
// joint MuJoCo's own M is not that of the kinematics; ours is.
#pragma once

#include <string>
#include <vector>

#include "core/model.hpp"

#ifdef MINV_HAVE_MUJOCO
#include <mujoco/mujoco.h>

#include <memory>
#endif

namespace minv {

// Bodies nested at most this deep in one exported file (tinyxml2 allows 96 with children).
inline constexpr int kMjcfNestPerFile = 64;
// Mass and inertia fraction carried by the extra bodies of a multi-joint MuJoCo body.
inline constexpr double kJointOnlyMassFraction = 1e-10;

// An MJCF document as files: files[0] is the main file, the rest are <include>d parts.
struct MjcfFile {
  std::string name;
  std::string text;
};

// What a caller adds to the exported tree (for MuJoCo's own stepping, sim/mujoco_step.hpp):
// `head` replaces the default <option gravity="0 0 0"/> (options, <size>, …), `world` goes into
// <worldbody> before the bodies (a ground plane), body[i] into body i after its inertial
// (geoms); an empty string adds nothing.
struct MjcfExtras {
  std::string head, world;
  std::vector<std::string> body;
};

// Our tree as MJCF (see the top of this file). Body i is "b<i>", its joint "j<i>".
std::vector<MjcfFile> toMjcf(const Model& model, int nest_per_file = kMjcfNestPerFile,
                             const MjcfExtras* extras = nullptr);

// An MJCF file read through MuJoCo's parser (see the top of this file). Without MuJoCo this
// throws ModelError saying so.
Model loadMjcf(const std::string& path, bool floating_base);

#ifdef MINV_HAVE_MUJOCO
struct MjModelDeleter {
  void operator()(mjModel* m) const { mj_deleteModel(m); }
};
struct MjDataDeleter {
  void operator()(mjData* d) const { mj_deleteData(d); }
};
using MjModelPtr = std::unique_ptr<mjModel, MjModelDeleter>;
using MjDataPtr = std::unique_ptr<mjData, MjDataDeleter>;

// Compiles files held in memory (through MuJoCo's virtual file system: no file is written).
// Throws ModelError with MuJoCo's message (source_name first).
MjModelPtr compileMjcf(const std::vector<MjcfFile>& files, const std::string& source_name);
// Compiles an MJCF or URDF file from disk with MuJoCo; ModelError with MuJoCo's message.
MjModelPtr compileMujocoFile(const std::string& path);
// Our tree of a compiled MuJoCo model (the import rules at the top of this file).
Model modelFromMujoco(const mjModel* m, bool floating_base, const std::string& source_name);
// Routes MuJoCo's errors and warnings away from its defaults (which print, write
// MUJOCO_LOG.TXT and, for errors, wait for Enter and exit): an error throws
// std::runtime_error("mujoco: …"), a warning is printed to stderr. Idempotent.
void installMujocoHandlers();
#endif

}  // namespace minv
