#include "generators/random_tree.hpp"

#include <cmath>
#include <limits>
#include <numbers>

namespace minv {

namespace {

// Sums of products with explicit fused multiply-adds, so no compiler contraction can differ.
double dot(const double* a, const double* b, int n) {
  double s = a[0] * b[0];
  for (int k = 1; k < n; ++k) s = std::fma(a[k], b[k], s);
  return s;
}

// A uniform direction: a point of the unit ball by rejection from the cube, normalised.
template <int N>
Eigen::Matrix<double, N, 1> unitByRejection(Rng& rng) {
  for (;;) {
    Eigen::Matrix<double, N, 1> x;
    for (int k = 0; k < N; ++k) x(k) = rng.uniform(-1, 1);
    const double r2 = dot(x.data(), x.data(), N);
    if (r2 > 1e-6 && r2 <= 1) return x / std::sqrt(r2);
  }
}

// Rotation of a unit quaternion (w, x, y, z); the products of 2 are exact.
Eigen::Matrix3d quaternionRotation(const Eigen::Vector4d& q) {
  const double w = q(0), x = q(1), y = q(2), z = q(3);
  Eigen::Matrix3d R;
  R << 1 - 2 * std::fma(y, y, z * z), 2 * std::fma(x, y, -(w * z)), 2 * std::fma(x, z, w * y),
      2 * std::fma(x, y, w * z), 1 - 2 * std::fma(x, x, z * z), 2 * std::fma(y, z, -(w * x)),
      2 * std::fma(x, z, -(w * y)), 2 * std::fma(y, z, w * x), 1 - 2 * std::fma(x, x, y * y);
  return R;
}

// R diag(d) Rᵀ, upper triangle computed once and mirrored, so it is exactly symmetric.
Eigen::Matrix3d rotateDiagonal(const Eigen::Matrix3d& R, const Eigen::Vector3d& d) {
  Eigen::Matrix3d J;
  for (int i = 0; i < 3; ++i)
    for (int j = i; j < 3; ++j) {
      const double a[3] = {R(i, 0) * d(0), R(i, 1) * d(1), R(i, 2) * d(2)};
      const double b[3] = {R(j, 0), R(j, 1), R(j, 2)};
      J(i, j) = J(j, i) = dot(a, b, 3);
    }
  return J;
}

// One link's joint and body, drawn in the order documented in the header.
void randomLink(Rng& rng, JointSet set, Joint& joint, Body& body) {
  // The joint: type, axis, placement.
  const double u = rng.uniform();
  joint.type = set == JointSet::Revolute || u < 0.6 ? JointType::Revolute
               : u < 0.8                            ? JointType::Prismatic
                                                    : JointType::Spherical;
  const Eigen::Vector3d axis = rng.unitVector();
  if (joint.type != JointType::Spherical) joint.axis = axis;
  joint.placement.R = rng.rotation();
  const Eigen::Vector3d dir = rng.unitVector();
  joint.placement.p = dir * rng.uniform(0.3, 0.5);
  // The body: mass, ellipsoid semi-axes, inertia, centre of mass.
  body.mass = rng.uniform(0.5, 2);
  double s[3];
  for (double& h : s) h = rng.uniform(0.05, 0.2);
  // Solid ellipsoid: I_xx = m(b² + c²)/5 and cyclically, turned by a random rotation.
  const Eigen::Vector3d principal(body.mass * std::fma(s[1], s[1], s[2] * s[2]) / 5,
                                  body.mass * std::fma(s[2], s[2], s[0] * s[0]) / 5,
                                  body.mass * std::fma(s[0], s[0], s[1] * s[1]) / 5);
  body.inertia = rotateDiagonal(rng.rotation(), principal);
  for (int k = 0; k < 3; ++k) body.com(k) = rng.uniform(-0.1, 0.1);
}

// kMaxTreeLinks keeps every random tree clear of the point-mass rule (random_tree.hpp): the
// ranges above and randomConfiguration's prismatic displacements, at most 0.5 m.
static_assert([] {
  const double r = 0.5 * (kMaxTreeLinks + 1) + 0.5 * kMaxTreeLinks + 0.18;
  return kMinInertiaRatio * r * r < 1e-3;
}());

}  // namespace

double Rng::uniform(double a, double b) {
  return std::fma(b - a, uniform(), a);
}

int Rng::below(int n) {
  if (n <= 0) throw ModelError("Rng::below: n must be positive, got " + std::to_string(n));
  // Reject the top partial block of the 64-bit range, then reduce.
  const std::uint64_t range = static_cast<std::uint64_t>(n);
  const std::uint64_t limit = std::numeric_limits<std::uint64_t>::max() / range * range;
  std::uint64_t x;
  do x = engine_();
  while (x >= limit);
  return static_cast<int>(x % range);
}

Eigen::Vector3d Rng::unitVector() {
  return unitByRejection<3>(*this);
}
Eigen::Vector4d Rng::unitQuaternion() {
  return unitByRejection<4>(*this);
}
Eigen::Matrix3d Rng::rotation() {
  return quaternionRotation(unitQuaternion());
}

Topology topologyFromName(const std::string& name) {
  if (name == "serial") return Topology::Serial;
  if (name == "branched") return Topology::Branched;
  throw ModelError("unknown topology '" + name + "' (expected serial or branched)");
}

const char* topologyName(Topology t) {
  return t == Topology::Serial ? "serial" : "branched";
}

JointSet jointSetFromName(const std::string& name) {
  if (name == "revolute") return JointSet::Revolute;
  if (name == "mixed") return JointSet::Mixed;
  throw ModelError("unknown joint set '" + name + "' (expected revolute or mixed)");
}

const char* jointSetName(JointSet s) {
  return s == JointSet::Revolute ? "revolute" : "mixed";
}

std::vector<int> randomParents(Topology topology, int n, Rng& rng) {
  if (n <= 0) throw ModelError("random tree: n must be at least 1, got " + std::to_string(n));
  std::vector<int> parent(n, -1), children(n, 0);
  int end = 0;  // the end of the chain
  for (int i = 1; i < n; ++i) {
    // Serial, or heads: extend the chain.
    int p = end;
    // Tails: a sibling of the end link, or of the nearest chain link above with room.
    if (topology == Topology::Branched && rng.uniform() < 0.5) {
      int x = end;
      while (parent[x] >= 0 && children[parent[x]] >= 2) x = parent[x];
      if (parent[x] >= 0) p = parent[x];
    }
    if (p == end) end = i;
    parent[i] = p;
    ++children[p];
  }
  return parent;
}

Model randomTree(const TreeOptions& o) {
  if (o.n <= 0) throw ModelError("random tree: n must be at least 1, got " + std::to_string(o.n));
  if (o.n > kMaxTreeLinks)
    throw ModelError("random tree: n must be at most " + std::to_string(kMaxTreeLinks) + ", got " +
                     std::to_string(o.n));
  // Separate streams for the topology and for the bodies (see the header).
  Rng topo(o.seed), rng(o.seed ^ 0x9e3779b97f4a7c15ULL);
  const std::vector<int> links = randomParents(o.topology, o.n, topo);
  const int shift = o.floating_base ? 1 : 0, nb = o.n + shift;
  std::vector<int> parent(nb, -1);
  std::vector<Joint> joints(nb);
  std::vector<Body> bodies(nb);
  // The links, shifted below the base when there is one.
  for (int k = 0; k < o.n; ++k) {
    const int i = k + shift;
    parent[i] = links[k] < 0 ? shift - 1 : links[k] + shift;
    joints[i].name = std::string("j").append(std::to_string(k));
    bodies[i].name = std::string("b").append(std::to_string(k));
    randomLink(rng, o.joints, joints[i], bodies[i]);
  }
  // The floating base body, drawn last; only its body values are kept.
  if (o.floating_base) {
    Joint unused;
    randomLink(rng, JointSet::Revolute, unused, bodies[0]);
    joints[0].name = "base";
    joints[0].type = JointType::Floating;
    bodies[0].name = "base";
  }
  return Model::create(std::move(parent), std::move(joints), std::move(bodies));
}

Eigen::VectorXd randomConfiguration(const Model& model, std::uint64_t seed) {
  Rng rng(seed);
  Eigen::VectorXd q(model.nq());
  const double pi = std::numbers::pi;
  for (int i = 0; i < model.nb(); ++i) {
    const int o = model.qIdx(i);
    // One block per joint, in body order.
    switch (model.joint(i).type) {
      case JointType::Revolute:
        q(o) = rng.uniform(-pi, pi);
        break;
      case JointType::Prismatic:
        q(o) = rng.uniform(-0.5, 0.5);
        break;
      case JointType::Spherical:
        q.segment<4>(o) = rng.unitQuaternion();
        break;
      case JointType::Floating:
        for (int k = 0; k < 3; ++k) q(o + k) = rng.uniform(-1, 1);
        q.segment<4>(o + 3) = rng.unitQuaternion();
        break;
    }
  }
  return q;
}

Eigen::MatrixXd randomMatrix(int rows, int cols, std::uint64_t seed) {
  Rng rng(seed);
  Eigen::MatrixXd R(rows, cols);
  for (int c = 0; c < cols; ++c)
    for (int r = 0; r < rows; ++r) R(r, c) = rng.uniform(-1.0, 1.0);
  return R;
}

}  // namespace minv
