#include "core/model.hpp"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <initializer_list>
#include <map>

namespace minv {

Body mergeRigid(const std::vector<Body>& parts) {
  if (parts.size() == 1) return parts[0];
  Body body;
  body.mass = 0;
  Eigen::Vector3d moment = Eigen::Vector3d::Zero();
  for (const Body& b : parts) body.mass += b.mass, moment += b.mass * b.com;
  body.com = moment / body.mass;
  body.inertia.setZero();
  for (const Body& b : parts) {
    const Eigen::Vector3d d = b.com - body.com;
    body.inertia +=
        b.inertia + b.mass * (d.squaredNorm() * Eigen::Matrix3d::Identity() - d * d.transpose());
  }
  return body;
}

std::string formatNumber(double x) {
  if (std::isnan(x)) return "nan";
  if (std::isinf(x)) return x > 0 ? "inf" : "-inf";
  char buf[32];
  const auto r = std::to_chars(buf, buf + sizeof buf, x);
  return std::string(buf, r.ptr);
}

int jointNv(JointType t) {
  switch (t) {
    case JointType::Revolute:
    case JointType::Prismatic:
      return 1;
    case JointType::Spherical:
      return 3;
    case JointType::Floating:
      return 6;
  }
  return 0;
}

int jointNq(JointType t) {
  switch (t) {
    case JointType::Revolute:
    case JointType::Prismatic:
      return 1;
    case JointType::Spherical:
      return 4;
    case JointType::Floating:
      return 7;
  }
  return 0;
}

const char* jointTypeName(JointType t) {
  switch (t) {
    case JointType::Revolute:
      return "revolute";
    case JointType::Prismatic:
      return "prismatic";
    case JointType::Spherical:
      return "spherical";
    case JointType::Floating:
      return "floating";
  }
  return "?";
}

JointType jointTypeFromName(const std::string& name) {
  for (JointType t :
       {JointType::Revolute, JointType::Prismatic, JointType::Spherical, JointType::Floating})
    if (name == jointTypeName(t)) return t;
  throw ModelError("unknown joint type '" + name +
                   "' (expected revolute, prismatic, spherical or floating)");
}

namespace {

bool finite(const auto& m) {
  return m.allFinite();
}

std::string where(int i, const std::string& name) {
  return "body " + std::to_string(i) + (name.empty() ? "" : " ('" + name + "')");
}

// The first entry of m beyond ±limit, as a message, or "".
std::string outOfRange(const auto& m, const std::string& what, double limit, const char* why) {
  for (Eigen::Index k = 0; k < m.size(); ++k)
    if (std::abs(m.data()[k]) > limit)
      return what + " " + formatNumber(m.data()[k]) + " is beyond ±" + formatNumber(limit) + ", " +
             why;
  return "";
}
constexpr const char* kFinite = "the range minv's kernels keep finite";
constexpr const char* kAccurate =
    "the range in which the world-frame kernels keep M accurate (see core/model.hpp)";

// Whether a name is valid UTF-8 (names travel through JSON and HDF5 as UTF-8 text).
bool validUtf8(const std::string& s) {
  for (std::size_t i = 0; i < s.size();) {
    const unsigned char c = s[i];
    const int n = c < 0x80           ? 1
                  : (c >> 5) == 0x6  ? 2
                  : (c >> 4) == 0xe  ? 3
                  : (c >> 3) == 0x1e ? 4
                                     : 0;
    if (n == 0 || i + n > s.size()) return false;
    std::uint32_t cp = n == 1 ? c : c & (0x7f >> n);
    for (int k = 1; k < n; ++k) {
      const unsigned char d = s[i + k];
      if ((d >> 6) != 0x2) return false;
      cp = (cp << 6) | (d & 0x3f);
    }
    // No overlong forms, surrogates or code points beyond U+10FFFF.
    if ((n == 2 && cp < 0x80) || (n == 3 && cp < 0x800) || (n == 4 && cp < 0x10000) ||
        (cp >= 0xd800 && cp <= 0xdfff) || cp > 0x10ffff)
      return false;
    i += n;
  }
  return true;
}

void checkBody(int i, const Body& b) {
  const std::string at = where(i, b.name);
  if (!std::isfinite(b.mass) || b.mass <= 0)
    throw ModelError(at + ": mass must be positive and finite, got " + formatNumber(b.mass));
  if (b.mass > kMaxPhysicalMagnitude)
    throw ModelError(at + ": mass " + formatNumber(b.mass) + " is beyond " +
                     formatNumber(kMaxPhysicalMagnitude) +
                     ", the range minv's kernels keep finite");
  if (!finite(b.com)) throw ModelError(at + ": centre of mass is not finite");
  if (!finite(b.inertia)) throw ModelError(at + ": rotational inertia is not finite");
  if (const std::string e = outOfRange(b.com, "centre of mass coordinate", kMaxLength, kAccurate);
      !e.empty())
    throw ModelError(at + ": " + e);
  if (const std::string e =
          outOfRange(b.inertia, "rotational inertia entry", kMaxPhysicalMagnitude, kFinite);
      !e.empty())
    throw ModelError(at + ": " + e);
  const Eigen::Matrix3d& J = b.inertia;
  const double scale = J.cwiseAbs().maxCoeff();
  if ((J - J.transpose()).cwiseAbs().maxCoeff() > 1e-9 * std::max(scale, 1e-300))
    throw ModelError(at + ": rotational inertia is not symmetric");
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(J);
  const Eigen::Vector3d e = es.eigenvalues();  // ascending
  if (!(e(0) > 0))
    throw ModelError(at + ": rotational inertia is not positive definite (smallest eigenvalue " +
                     formatNumber(e(0)) + ")");
  if (e(0) + e(1) < e(2) * (1 - 1e-9))
    throw ModelError(at + ": rotational inertia breaks the triangle inequality (principal " +
                     "moments " + formatNumber(e(0)) + ", " + formatNumber(e(1)) + ", " +
                     formatNumber(e(2)) + ")");
}

}  // namespace

double smallestPrincipalMoment(const Body& b) {
  const Eigen::Matrix3d J = 0.5 * (b.inertia + b.inertia.transpose());
  return Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(J, Eigen::EigenvaluesOnly).eigenvalues()(0);
}

namespace {

void checkJoint(int i, Joint& j, int parent) {
  const std::string at = "joint of " + where(i, j.name);
  if (j.type == JointType::Revolute || j.type == JointType::Prismatic) {
    if (!finite(j.axis)) throw ModelError(at + ": joint axis is not finite");
    // The axis is a direction: where its norm would overflow or underflow it is taken from the
    // axis scaled by its largest entry, so an axis of (1e308, 1e308, 0) is the unit axis it names.
    const double big = j.axis.cwiseAbs().maxCoeff();
    const Eigen::Vector3d d = j.axis / (big > 0 ? big : 1.0);
    double n = j.axis.norm();
    const bool extreme = !std::isfinite(n) || n < 1e-150;
    if (extreme) n = d.norm() * big;
    if (n < 1e-12) throw ModelError(at + ": joint axis is zero");
    // Normalise, but keep an axis that is already unit to rounding, so that reading a written
    // model reproduces it bit for bit.
    if (extreme)
      j.axis = d / d.norm();
    else if (std::abs(n - 1) > 4e-16)
      j.axis /= n;
  }
  if (j.type == JointType::Floating && parent != -1)
    throw ModelError(at + ": a floating joint must attach a root body to the world");
  if (!finite(j.placement.R) || !finite(j.placement.p))
    throw ModelError(at + ": joint placement is not finite");
  if (const std::string e =
          outOfRange(j.placement.p, "placement translation", kMaxLength, kAccurate);
      !e.empty())
    throw ModelError(at + ": " + e);
  const Eigen::Matrix3d& R = j.placement.R;
  if ((R.transpose() * R - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff() > 1e-9 ||
      R.determinant() < 0)
    throw ModelError(at + ": joint placement rotation is not a rotation matrix");
}

// The greatest distance r from the origin of the solvers' frame at which a body's rotational
// inertia still weighs kMinInertiaRatio · m r²: r = √(e₀ / (ratio · m)), e₀ its smallest
// principal moment.
double maxReach(const Body& b) {
  return std::sqrt(std::max(smallestPrincipalMoment(b), 0.0) / (kMinInertiaRatio * b.mass));
}

// A body that is a point mass to double precision where it stands: the world-aligned kernels
// form its inertia about the origin of its tree's root body frame, whose entries m r² (r the
// centre of mass's distance from that origin) are rounded to ε m r², and where its rotational
// inertia is not well above that, the directions of M that only turn the body about its centre
// of mass weigh little more than the rounding and M can lose its positive definiteness. Found by
// CI's fuzzers: a 1e30 kg knee with Ī ≈ 4e-5 at 5 cm (JSON); a 1e7 kg body with Ī = 1e-3 whose
// joint stands 1e4 m from the root (URDF). `how` says what put it there, if not the model alone.
void checkReach(int i, const Body& b, double r, double max_r, const std::string& how) {
  if (r < max_r) return;
  const double e0 = smallestPrincipalMoment(b), mr2 = b.mass * r * r;
  throw ModelError(
      where(i, b.name) + ": rotational inertia is negligible against m·r², r = " + formatNumber(r) +
      " bounding its centre of mass's distance from its tree's root body over all joint "
      "angles" +
      how + " (smallest principal moment " + formatNumber(e0) + ", m·r² = " + formatNumber(mr2) +
      "): a point mass to double precision in the solvers' frame; give it a "
      "rotational inertia of at least " +
      formatNumber(kMinInertiaRatio) + "·m·r², or bring it closer to the root");
}

}  // namespace

Model Model::create(std::vector<int> parent, std::vector<Joint> joints, std::vector<Body> bodies) {
  const int nb = static_cast<int>(parent.size());
  if (nb == 0) throw ModelError("model has no bodies (n = 0)");
  if (static_cast<int>(joints.size()) != nb || static_cast<int>(bodies.size()) != nb)
    throw ModelError("model arrays disagree: " + std::to_string(nb) + " parents, " +
                     std::to_string(joints.size()) + " joints, " + std::to_string(bodies.size()) +
                     " bodies");
  Model m;
  m.q_idx_.resize(nb);
  m.v_idx_.resize(nb);
  m.depth_.resize(nb);
  for (int i = 0; i < nb; ++i) {
    // The parent must come before its child: parent(i) < i (RBDA's regular numbering).
    if (parent[i] < -1 || parent[i] >= i)
      throw ModelError(where(i, bodies[i].name) + ": parent index " + std::to_string(parent[i]) +
                       " must be in [-1, " + std::to_string(i - 1) + "] (parent before child)");
    checkJoint(i, joints[i], parent[i]);
    checkBody(i, bodies[i]);
    // Distances from the origin of the tree's root body frame, where the solvers' world-aligned
    // frame has its origin: the joint's (whatever the angles: a placement is rigid) and the
    // centre of mass's. The body must not be a point mass at that distance.
    m.joint_reach_.push_back(
        parent[i] < 0 ? 0.0 : m.joint_reach_[parent[i]] + joints[i].placement.p.norm());
    m.max_reach_.push_back(maxReach(bodies[i]));
    checkReach(i, bodies[i], m.joint_reach_[i] + bodies[i].com.norm(), m.max_reach_[i], "");
    m.prismatic_ = m.prismatic_ || (joints[i].type == JointType::Prismatic && parent[i] >= 0);
    m.q_idx_[i] = m.nq_;
    m.v_idx_[i] = m.nv_;
    m.depth_[i] = parent[i] < 0 ? 1 : m.depth_[parent[i]] + 1;
    const int k = jointNv(joints[i].type);
    m.nv_of_.push_back(k);
    // Expand λ over DOFs: the first DOF hangs off the parent's last DOF, the rest chain.
    for (int j = 0; j < k; ++j) {
      int p = j > 0 ? m.nv_ + j - 1 : -1;
      if (j == 0 && parent[i] >= 0) p = m.v_idx_[parent[i]] + jointNv(joints[parent[i]].type) - 1;
      m.dof_parent_.push_back(p);
      m.dof_body_.push_back(i);
    }
    m.nq_ += jointNq(joints[i].type);
    m.nv_ += k;
  }
  for (int i = 1; i < nb; ++i)
    if (joints[i].type == JointType::Floating && parent[i] == -1)
      throw ModelError("joint of " + where(i, joints[i].name) +
                       ": only body 0 may carry a floating joint");
  // Names are how users map DOFs and configurations: two bodies, or two joints, may not share
  // one (empty names are allowed and numbered).
  std::map<std::string, int> body_at, joint_at;
  for (int i = 0; i < nb; ++i) {
    if (!validUtf8(bodies[i].name) || !validUtf8(joints[i].name))
      throw ModelError("body " + std::to_string(i) + ": its body or joint name is not valid UTF-8");
    // (a NUL cut the name short in a URDF written from the model, which then did not read back)
    if (bodies[i].name.find('\0') != std::string::npos ||
        joints[i].name.find('\0') != std::string::npos)
      throw ModelError("body " + std::to_string(i) + ": its body or joint name contains a NUL");
    const std::string& b = bodies[i].name;
    if (!b.empty() && !body_at.emplace(b, i).second)
      throw ModelError(where(i, b) + ": the body name '" + b + "' is already used by body " +
                       std::to_string(body_at[b]));
    const std::string& j = joints[i].name;
    if (!j.empty() && !joint_at.emplace(j, i).second)
      throw ModelError("joint of " + where(i, bodies[i].name) + ": the joint name '" + j +
                       "' is already used by the joint of body " + std::to_string(joint_at[j]));
  }
  m.parent_ = std::move(parent);
  m.joints_ = std::move(joints);
  m.bodies_ = std::move(bodies);
  // So must the coordinates' derived names (a joint "a_qw" beside a spherical "a"; a joint
  // "joint2" beside an unnamed joint 2): a configuration file sets q by them.
  for (const auto& [names, what] : {std::pair{m.qNames(), "q"}, {m.dofNames(), "v (DOF)"}}) {
    std::map<std::string, std::size_t> seen;
    for (std::size_t k = 0; k < names.size(); ++k)
      if (const auto [it, fresh] = seen.emplace(names[k], k); !fresh)
        throw ModelError("two coordinates of " + std::string(what) + " are both named '" +
                         names[k] + "' (" + std::to_string(it->second) + " and " +
                         std::to_string(k) +
                         "): rename a joint (names: a 1-DOF joint's own, <joint>_qw … for a "
                         "spherical or floating joint's coordinates, joint<i> for an unnamed "
                         "joint i)");
  }
  return m;
}

int Model::maxDepth() const {
  return *std::max_element(depth_.begin(), depth_.end());
}

namespace {
// One name per coordinate: a 1-DOF joint's own name, else "<joint>_<suffix>" for each suffix of
// a spherical or a floating joint.
std::vector<std::string> coordinateNames(const std::vector<Joint>& joints,
                                         std::initializer_list<const char*> spherical,
                                         std::initializer_list<const char*> floating) {
  std::vector<std::string> names;
  for (std::size_t i = 0; i < joints.size(); ++i) {
    const Joint& j = joints[i];
    const std::string base = j.name.empty() ? "joint" + std::to_string(i) : j.name;
    if (j.type == JointType::Spherical || j.type == JointType::Floating) {
      for (const char* s : j.type == JointType::Spherical ? spherical : floating)
        names.push_back(base + "_" + s);
    } else {
      names.push_back(base);
    }
  }
  return names;
}
}  // namespace

std::vector<std::string> Model::dofNames() const {
  return coordinateNames(joints_, {"wx", "wy", "wz"}, {"wx", "wy", "wz", "vx", "vy", "vz"});
}

std::vector<std::string> Model::qNames() const {
  return coordinateNames(joints_, {"qw", "qx", "qy", "qz"},
                         {"x", "y", "z", "qw", "qx", "qy", "qz"});
}

Eigen::VectorXd Model::neutral() const {
  Eigen::VectorXd q = Eigen::VectorXd::Zero(nq_);
  for (int i = 0; i < nb(); ++i) {
    if (joints_[i].type == JointType::Spherical) q(q_idx_[i]) = 1;
    if (joints_[i].type == JointType::Floating) q(q_idx_[i] + 3) = 1;
  }
  return q;
}

void Model::checkConfiguration(const Eigen::VectorXd& q) const {
  if (q.size() != nq_)
    throw ModelError("configuration has " + std::to_string(q.size()) + " entries, model needs " +
                     std::to_string(nq_));
  for (int k = 0; k < nq_; ++k)
    if (!std::isfinite(q(k)))
      throw ModelError("configuration entry q[" + std::to_string(k) + "] is not finite");
  for (int i = 0; i < nb(); ++i) {
    const JointType t = joints_[i].type;
    const int o = q_idx_[i];
    // Lengths: a floating base's position, a prismatic displacement.
    const int lengths = t == JointType::Floating ? 3 : t == JointType::Prismatic ? 1 : 0;
    for (int k = 0; k < lengths; ++k)
      if (std::abs(q(o + k)) > kMaxLength)
        throw ModelError("configuration of " + where(i, joints_[i].name) + ": q[" +
                         std::to_string(o + k) + "] = " + formatNumber(q(o + k)) + " is beyond ±" +
                         formatNumber(kMaxLength) +
                         ", the range in which the world-frame kernels keep M accurate");
    // Angles: a revolute joint's, within ±kMaxAngle.
    if (t == JointType::Revolute && std::abs(q(o)) > kMaxAngle)
      throw ModelError("configuration of " + where(i, joints_[i].name) + ": q[" +
                       std::to_string(o) + "] = " + formatNumber(q(o)) + " rad is beyond ±" +
                       formatNumber(kMaxAngle) +
                       " rad (about 160 000 turns), where an angle keeps too few digits to place "
                       "its joint: reduce it modulo 2π");
    if (t != JointType::Spherical && t != JointType::Floating) continue;
    // Quaternions: not zero, and small enough that their norm does not overflow.
    const int w = o + (t == JointType::Floating ? 3 : 0);
    if (q.segment<4>(w).cwiseAbs().maxCoeff() > 1e100)
      throw ModelError("configuration of " + where(i, joints_[i].name) +
                       ": a quaternion entry is beyond ±1e100 (its norm would overflow)");
    if (q.segment<4>(w).norm() < 1e-12)
      throw ModelError("configuration of " + where(i, joints_[i].name) +
                       ": zero quaternion (norm " + formatNumber(q.segment<4>(w).norm()) +
                       ", below 1e-12)");
  }
  // Prismatic joints below a root move their subtrees away from it: no body may become a point
  // mass (Model::create's rule, at the distances of this configuration).
  if (!prismatic_) return;
  std::vector<double> slide(nb(), 0.0);
  for (int i = 0; i < nb(); ++i) {
    const int parent = parent_[i];
    if (parent < 0) continue;
    slide[i] =
        slide[parent] + (joints_[i].type == JointType::Prismatic ? std::abs(q(q_idx_[i])) : 0.0);
    if (slide[i] > 0)
      checkReach(i, bodies_[i], joint_reach_[i] + slide[i] + bodies_[i].com.norm(), max_reach_[i],
                 ", with this configuration's prismatic displacements");
  }
}

}  // namespace minv
