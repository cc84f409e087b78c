// Random kinematic trees for the experiments: serial chains and the paper's branched bodies
// (§6.1), with random but physically valid bodies, and random configurations.
//
// Contract: every result is a deterministic function of the seed, bit-identical on every
// platform and compiler. The only source of randomness is std::mt19937_64 (fully specified
// by the C++ standard); it is turned into doubles by exact bit manipulation, never by the
// implementation-defined <random> distributions, and the arithmetic after that uses only
// IEEE-754 correctly rounded operations (+ − × ÷ √ and explicit std::fma, so the compiler's
// floating-point contraction cannot change a result) and no transcendental functions.
// (Checked with GCC -O0 and -O3 -march=native and Clang -ffp-contract=fast. One exception:
// Model::create renormalises joint axes through Eigen's norm(), which can differ in the last
// bit between such builds.)
//
// randomTree(): n jointed links named "b<k>" on joints "j<k>", k = 0 … n−1, numbered so that
// λ(k) < k. With a floating base, body 0 is an extra base body "base" on a floating joint
// "base" (identity placement) and link k is body k + 1, the root link hanging below the base:
// nv = n + 6 for a revolute tree. Each link draws, in this order from its own stream:
//   joint type   JointSet::Mixed: revolute 0.6, prismatic 0.2, spherical 0.2 (the draw is made
//                for JointSet::Revolute too, so both sets give the same bodies);
//   joint axis   uniform on the unit sphere (spherical joints keep the default z axis);
//   placement    a uniform random rotation, translation of length [0.3, 0.5] in a uniform
//                random direction;
//   mass         uniform in [0.5, 2];
//   inertia      a solid ellipsoid with semi-axes in [0.05, 0.2] (I_xx = m(b² + c²)/5, …, which
//                always satisfies the triangle inequality), turned by a random rotation;
//   com          each coordinate uniform in [−0.1, 0.1].
// The parent array comes from a separate stream, so a serial and a branched tree with the
// same seed (and a fixed- and a floating-base tree) have the same links; the base body is
// drawn after the links.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <random>
#include <string>
#include <vector>

#include "core/model.hpp"

namespace minv {

// A small reproducible random number generator (see the contract above).
class Rng {
 public:
  explicit Rng(std::uint64_t seed) : engine_(seed) {}

  // Uniform in [0, 1): the top 53 bits of one 64-bit draw.
  double uniform() { return static_cast<double>(engine_() >> 11) * 0x1.0p-53; }
  // Uniform in [a, b) (b itself only by rounding).
  double uniform(double a, double b);
  // Uniform integer in [0, n) for n > 0, without modulo bias.
  int below(int n);
  // Uniform on the unit sphere (rejection from the cube, then normalised).
  Eigen::Vector3d unitVector();
  // Uniform unit quaternion (w, x, y, z), i.e. a uniformly random rotation.
  Eigen::Vector4d unitQuaternion();
  // A uniformly random rotation matrix.
  Eigen::Matrix3d rotation();

  std::mt19937_64& engine() { return engine_; }

 private:
  std::mt19937_64 engine_;
};

enum class Topology { Serial, Branched };
Topology topologyFromName(const std::string& name);  // "serial" | "branched", else ModelError
const char* topologyName(Topology t);

enum class JointSet { Revolute, Mixed };  // revolute only, or revolute/prismatic/spherical
JointSet jointSetFromName(const std::string& name);  // "revolute" | "mixed", else ModelError
const char* jointSetName(JointSet s);

struct TreeOptions {
  Topology topology = Topology::Serial;
  int n = 10;  // jointed links, not counting a floating base
  std::uint64_t seed = 1;
  bool floating_base = false;
  JointSet joints = JointSet::Revolute;
};

// Parent array of n ≥ 1 links; link 0 is the root (parent −1) and λ(i) < i.
// Serial: λ(i) = i − 1. Branched, the paper's rule (§6.1): "the chain" runs from the root to
// its end link t (initially link 0). Each new link i flips a fair coin: heads, it extends the
// chain (λ(i) = t, and i becomes the end); tails, it becomes a sibling of the end link (a
// second child of λ(t)). No link may have more than two children: if λ(t) already has two,
// the sibling goes to the nearest chain link above whose parent has room, and if there is
// none (the walk reached the root) link i extends the chain instead. Siblings are leaves, so
// the depth is the chain's length: n/2 + O(√n) on average. (Falling back to "extend" right
// away instead of walking up would give depth ≈ 2n/3, since after a sibling the next link
// could never be one.)
std::vector<int> randomParents(Topology topology, int n, Rng& rng);

// The most links a random tree may have: far beyond any research use (a dense M⁻¹ of 720 GB),
// and short of where a body could be a point mass in the solvers' frame (core/model.hpp's
// kMinInertiaRatio): placements and prismatic displacements of at most 0.5 m each put a centre
// of mass at most 0.5 (n + 1) + 0.5 n + 0.18 ≈ 3.0e5 m from the root, and e₀ ≥ 1e-3 m allows
// √(1e-3 / 1e-14) ≈ 3.16e5 m.
inline constexpr int kMaxTreeLinks = 300000;

// A random tree as described at the top of this file; throws ModelError for n outside
// [1, kMaxTreeLinks].
Model randomTree(const TreeOptions& options);

// Right-hand sides R (rows × cols): entries uniform in [−1, 1), column by column from
// Rng(seed); bit-identical everywhere, like the trees.
Eigen::MatrixXd randomMatrix(int rows, int cols, std::uint64_t seed);

// A random configuration: revolute angles uniform in [−π, π), prismatic displacements in
// [−0.5, 0.5), uniform unit quaternions for spherical joints, and for a floating base a
// position uniform in [−1, 1)³ and a uniform unit quaternion.
Eigen::VectorXd randomConfiguration(const Model& model, std::uint64_t seed);

}  // namespace minv
