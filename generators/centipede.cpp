#include "generators/centipede.hpp"

#include <cmath>

namespace minv {

SegmentJoint segmentJointFromName(const std::string& name) {
  if (name == "yaw") return SegmentJoint::Yaw;
  if (name == "spherical") return SegmentJoint::Spherical;
  throw ModelError("unknown segment joint '" + name + "' (expected yaw or spherical)");
}

const char* segmentJointName(SegmentJoint j) {
  return j == SegmentJoint::Yaw ? "yaw" : "spherical";
}

namespace {

// A solid box of mass m and sides a (x), b (y), c (z), com at the origin.
Body box(const std::string& name, double m, double a, double b, double c) {
  Body body;
  body.name = name;
  body.mass = m;
  body.inertia =
      Eigen::Vector3d(m * (b * b + c * c) / 12, m * (a * a + c * c) / 12, m * (a * a + b * b) / 12)
          .asDiagonal();
  return body;
}

// A solid cylinder (rod) of mass m, length l, radius r along `axis` (0 x, 1 y, 2 z), its com
// at `com`.
Body rod(const std::string& name, double m, double l, double r, int axis, Eigen::Vector3d com) {
  Body body;
  body.name = name;
  body.mass = m;
  const double across = m * (3 * r * r + l * l) / 12, along = m * r * r / 2;
  Eigen::Vector3d d = Eigen::Vector3d::Constant(across);
  d(axis) = along;
  body.inertia = d.asDiagonal();
  body.com = com;
  return body;
}

}  // namespace

Centipede makeCentipede(const CentipedeOptions& o) {
  if (o.segments < 1 || o.segments > kMaxCentipedeSegments)
    throw ModelError("centipede: segments must be between 1 and " +
                     std::to_string(kMaxCentipedeSegments) + ", got " + std::to_string(o.segments));
  for (double x : {o.segment_length, o.segment_width, o.segment_height, o.segment_mass,
                   o.upper_length, o.lower_length, o.upper_mass, o.lower_mass, o.leg_radius})
    if (!(x > 0) || !std::isfinite(x))
      throw ModelError("centipede: sizes and masses must be positive and finite");
  Centipede c;
  c.options = o;
  c.tip = Eigen::Vector3d(0, 0, -o.lower_length);
  std::vector<int> parent;
  std::vector<Joint> joints;
  std::vector<Body> bodies;
  for (int k = 0; k < o.segments; ++k) {
    const std::string s = std::to_string(k);
    const int seg = static_cast<int>(bodies.size());
    c.segment_body.push_back(seg);
    Joint j;
    j.name = "seg" + s;
    if (k == 0) {
      j.type = JointType::Floating;
      parent.push_back(-1);
    } else {
      j.type = o.segment_joint == SegmentJoint::Yaw ? JointType::Revolute : JointType::Spherical;
      j.axis = Eigen::Vector3d::UnitZ();
      j.placement.p = Eigen::Vector3d(-o.segment_length, 0, 0);
      parent.push_back(c.segment_body[k - 1]);
    }
    joints.push_back(j);
    bodies.push_back(
        box("segment" + s, o.segment_mass, o.segment_length, o.segment_width, o.segment_height));
    for (int side : {1, -1}) {
      const std::string lr = side > 0 ? "l" : "r";
      // Upper leg on a spherical hip.
      Joint hip;
      hip.name = "hip" + s + lr;
      hip.type = JointType::Spherical;
      hip.placement.p = Eigen::Vector3d(0, side * o.segment_width / 2, 0);
      c.leg_segment.push_back(k);
      c.upper_body.push_back(static_cast<int>(bodies.size()));
      parent.push_back(seg);
      joints.push_back(hip);
      bodies.push_back(rod("upper" + s + lr, o.upper_mass, o.upper_length, o.leg_radius, 1,
                           Eigen::Vector3d(0, side * o.upper_length / 2, 0)));
      // Lower leg on a revolute knee about x.
      Joint knee;
      knee.name = "knee" + s + lr;
      knee.type = JointType::Revolute;
      knee.axis = Eigen::Vector3d::UnitX();
      knee.placement.p = Eigen::Vector3d(0, side * o.upper_length, 0);
      c.lower_body.push_back(static_cast<int>(bodies.size()));
      parent.push_back(c.upper_body.back());
      joints.push_back(knee);
      bodies.push_back(rod("lower" + s + lr, o.lower_mass, o.lower_length, o.leg_radius, 2,
                           Eigen::Vector3d(0, 0, -o.lower_length / 2)));
    }
  }
  c.model = Model::create(std::move(parent), std::move(joints), std::move(bodies));
  return c;
}

Eigen::VectorXd centipedeStanding(const Centipede& c, double clearance) {
  Eigen::VectorXd q = c.model.neutral();
  q(2) = c.options.lower_length + clearance;
  return q;
}

}  // namespace minv
