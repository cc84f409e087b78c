// The centipede of the paper's §6.3 (Fig. 4): S body segments on a floating base, each
// segment carrying two legs; the legs' tips are the contact points.
//
// Layout (segment frame: x forward, y left, z up; SI units):
//   segment k     a box segment_length × segment_width × segment_height, mass segment_mass;
//                 segment 0 (the head) is the floating base; segment k > 0 hangs behind
//                 segment k−1 at (−segment_length, 0, 0) on the segment joint:
//                   SegmentJoint::Yaw        revolute about the segment's z axis (default;
//                                            1 DOF, the body bends in the ground plane)
//                   SegmentJoint::Spherical  3 DOF (yaw, pitch and roll)
//                 The paper does not say which joint joins its segments; Yaw is ours.
//   upper leg     on a spherical joint at (0, ±segment_width/2, 0) of its segment; a rod of
//                 length upper_length along ±y (outwards), mass upper_mass.
//   lower leg     on a revolute knee about x at the upper leg's end (0, ±upper_length, 0);
//                 a rod of length lower_length hanging along −z, mass lower_mass; its tip,
//                 (0, 0, −lower_length) in its frame, is the contact point.
// At the neutral configuration the upper legs are horizontal and the lower legs vertical, so
// the centipede stands with its segments' origins lower_length above the ground.
// Bodies are numbered segment by segment: segment k is body 5k, then its left upper, left
// lower, right upper, right lower legs (5k+1 … 5k+4); parent(5k) = 5(k−1).
// nv = 6 + (S−1)·(1 or 3) + 8·S  (9S + 5 with yaw joints: 2255 DOF at S = 250).
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

#include "core/model.hpp"

namespace minv {

enum class SegmentJoint { Yaw, Spherical };
SegmentJoint segmentJointFromName(const std::string& name);  // "yaw" | "spherical", else ModelError
const char* segmentJointName(SegmentJoint j);

// The most segments a centipede may have (90 005 DOFs with yaw joints, 110 003 with spherical
// ones): far beyond any research use.
inline constexpr int kMaxCentipedeSegments = 10000;

struct CentipedeOptions {
  int segments = 20;
  SegmentJoint segment_joint = SegmentJoint::Yaw;
  double segment_length = 0.15, segment_width = 0.10, segment_height = 0.05;
  double segment_mass = 0.30;
  double upper_length = 0.08, lower_length = 0.10;
  double upper_mass = 0.05, lower_mass = 0.05;
  double leg_radius = 0.012;  // the legs' inertia is that of a solid cylinder of this radius
};

struct Centipede {
  Model model;
  CentipedeOptions options;
  // Per leg (2 per segment, left first): its segment, upper and lower leg bodies.
  std::vector<int> leg_segment, upper_body, lower_body;
  std::vector<int> segment_body;  // body index of segment k
  Eigen::Vector3d tip;            // the tip in a lower leg's frame, (0, 0, −lower_length)
  int legs() const { return static_cast<int>(upper_body.size()); }
  // +1 for a left leg (+y), −1 for a right leg.
  static int side(int leg) { return leg % 2 == 0 ? 1 : -1; }
};

// Builds the centipede; throws ModelError for segments outside [1, kMaxCentipedeSegments]
// or a non-positive size or mass.
Centipede makeCentipede(const CentipedeOptions& options);

// Standing configuration: neutral joints, the head at (0, 0, lower_length + clearance).
Eigen::VectorXd centipedeStanding(const Centipede& c, double clearance = 0.0);

}  // namespace minv
