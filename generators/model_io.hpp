// Model files: our own JSON format, which holds every field of a Model exactly, and URDF.
//
// Contract: every reader throws ModelError on any problem, never crashes, and the message
// starts with the source (file) name and says what is wrong and where, e.g.
//   "arm.json: bodies[3].com: expected an array of 3 numbers, got 2 entries";
// problems found by Model::create keep its wording ("arm.json: body 3 ('b3'): mass must be
// positive and finite, …"), body i being bodies[i]. Writers throw ModelError for a model the
// format cannot express; saveModel never leaves a partial file behind.
//
// JSON format "minv-model", version 1. Every key is required unless marked optional; other
// keys are ignored. Numbers must be finite: JSON has no NaN or Infinity, and a literal that
// overflows a double (1e999) is rejected. The writer prints one body per line with
// round-trip precision, so write → read reproduces a model bit for bit.
//   {
//     "format": "minv-model",
//     "version": 1,
//     "name": "arm",                      optional, any string
//     "bodies": [                         at least one; a parent comes before its children
//       {
//         "name": "b0",
//         "parent": -1,                   index into "bodies", −1 for a root
//         "joint": {
//           "name": "j0",
//           "type": "revolute",           revolute | prismatic | spherical | floating
//           "axis": [0, 0, 1],            joint frame; optional for spherical and floating
//           "placement": {                joint frame in the parent body frame (world: roots)
//             "rotation": [[1, 0, 0], [0, 1, 0], [0, 0, 1]],     row-major 3×3
//             "translation": [0, 0, 0.5]
//           }
//         },
//         "mass": 1.5,                    > 0
//         "com": [0, 0, 0.1],             centre of mass, body frame
//         "inertia": [[0.1, 0, 0], [0, 0.1, 0], [0, 0, 0.05]]    about the com, body axes:
//       }                                 symmetric positive definite, triangle inequality
//     ]
//   }
// Joint conventions are those of core/model.hpp (a floating joint only on body 0).
//
// URDF (read with urdfdom): revolute and continuous joints become revolute joints, prismatic
// stay prismatic; a fixed joint merges its child link into the parent body (mass, centre of
// mass and inertia combined by the parallel-axis theorem; the merged link's children hang
// from that body with composed placements); floating and planar joints are rejected. A joint's
// <origin> is the placement of the joint frame in the parent link frame, the child link frame
// is the joint frame, <axis> is in the joint frame; an <inertial> origin (xyz, rpy) gives the
// centre of mass and turns the inertia into the link frame (R I Rᵀ). The root link is the
// world when floating_base is false (its mass and everything fixed to it are dropped; its
// child joints attach roots); when it is true the root link becomes body 0 on a floating
// joint "base" with identity placement. A body with no mass (no <inertial> anywhere in it)
// is rejected. Bodies are numbered in a topological order that takes the link names in
// natural order ("b2" before "b10") among the links whose parent is already numbered, so a
// model whose body names sort in body order (as randomTree's do) keeps its numbering.
#pragma once

#include <iosfwd>
#include <string>

#include "core/model.hpp"

namespace minv {

// JSON: read from a stream (source_name only labels the messages) and write.
Model readJson(std::istream& in, const std::string& source_name);
void writeJson(const Model& model, std::ostream& out, const std::string& name = "model");

// URDF from a file or from the text of one (source_name labels the messages).
Model loadUrdf(const std::string& path, bool floating_base);
Model readUrdf(const std::string& xml, const std::string& source_name, bool floating_base);
// URDF export of revolute and prismatic joints (revolute as "continuous", prismatic with wide
// dummy limits); a fixed base becomes a massless root link "world_base", a floating base
// body 0 itself is the root link (its placement is dropped: read the file back with
// floating_base = true). Needs unique non-empty body and joint names; ModelError for a
// spherical joint, a floating model with more than one root, or bad names.
void writeUrdf(const Model& model, std::ostream& out, const std::string& robot_name);
// What to tell the one who saved `model` at `path`, if it has a floating base and `path` is
// URDF (it reads back fixed); else "".
std::string floatingUrdfNote(const Model& model, const std::string& path);

// The files the harness reads and writes, checked before they are opened (ModelError naming the
// path). An input must be a regular file after symbolic links: a FIFO would block the read and
// a device such as /dev/zero never ends. An output, written to a tmp file that is then renamed
// over it, must be absent or a regular file: the rename would replace a device (/dev/null), a
// FIFO or a socket.
void requireInputFile(const std::string& path);
void requireOutputFile(const std::string& path);

// By extension: .json, .urdf, or .xml for MJCF (generators/mjcf.hpp, MuJoCo's parser). A
// missing, unreadable or empty file is a ModelError naming the path. floating_base = true gives a
// fixed-base JSON model a floating base through withFloatingBase (a JSON model that has one keeps
// it; false never removes one).
Model loadModel(const std::string& path, bool floating_base);
// By extension; the model and name are written to path + ".tmp", which is then renamed.
void saveModel(const Model& model, const std::string& path);

// A configuration from a text file, in one of two forms (# starts a comment; blank lines are
// ignored):
//   plain:  exactly nq numbers separated by white space or newlines, in the model's q order;
//   named:  lines "name value" with the names of Model::qNames() (a 1-DOF joint's name;
//           "<joint>_qw" … for a quaternion, "<joint>_x" … for a floating base); entries not
//           named keep their neutral value (zero angle, identity quaternion).
// The form is taken from the first entry (a number or a name). Quaternions are normalised by
// the kinematics, as everywhere. ModelError, naming the file and line, for: a wrong count, an
// unknown or repeated name, a value that is not a finite number, a zero quaternion.
Eigen::VectorXd readConfiguration(const Model& model, std::istream& in,
                                  const std::string& source_name);
Eigen::VectorXd loadConfiguration(const Model& model, const std::string& path);

// The same tree with its root body set free: body 0's joint becomes a floating joint "base"
// with identity placement (so nv grows by 5 for a revolute root); bodies and numbering are
// unchanged. A model that is already floating is returned as it is; ModelError if the model
// has more than one root. randomTree's floating base instead adds a new body 0.
Model withFloatingBase(const Model& fixed);

}  // namespace minv
