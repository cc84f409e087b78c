// The contact-space inertia recursion (sim/contact_inertia.hpp) against the dense Jᵀ M⁻¹ J with
// M⁻¹J from the `lapack` solver (CRBA + Cholesky), relative Frobenius error ≤ 1e-10: the
// centipede with yaw and spherical segment joints, random branched trees (mixed joints, fixed
// and floating base) with several contacts on one body and contacts on the floating base
// itself, serial chains with many directions far below a branch (the composite propagators),
// a forest, directions given out of preorder (the scattered path), the Counted scalar, and
// the operation counts of paper/contact_inertia_counts.md (written when MINV_COUNT_TABLE names
// a file).
#include "sim/contact_inertia.hpp"

#include <gtest/gtest.h>

#include <Eigen/QR>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <memory>
#include <numeric>
#include <string>
#include <vector>

#include "core/counting.hpp"
#include "generators/centipede.hpp"
#include "generators/random_tree.hpp"
#include "sim/dynamics.hpp"
#include "solvers/solver.hpp"

namespace minv::sim {
namespace {

struct Contacts {
  std::vector<int> bodies;
  std::vector<Vec6<double>> wrenches;
  void add(int body, const Vec6<double>& f) {
    bodies.push_back(body);
    wrenches.push_back(f);
  }
  // A point contact: the simulator's three directions (z, x, y) at world point p.
  void point(int body, const Eigen::Vector3d& p) {
    for (int d = 0; d < 3; ++d) add(body, unitWrench(p, Eigen::Vector3d::Unit((d + 2) % 3)));
  }
  int m() const { return static_cast<int>(bodies.size()); }
};

// A random point near body b's origin in world coordinates.
Eigen::Vector3d nearBody(const Kinematics<double>& kin, int b, Rng& rng) {
  return kin.X[b].p + 0.2 * rng.unitVector();
}

// A branched tree of mixed joints on a floating base.
Model floatingMixed(int n, std::uint64_t seed) {
  return randomTree({.topology = Topology::Branched,
                     .n = n,
                     .seed = seed,
                     .floating_base = true,
                     .joints = JointSet::Mixed});
}

// `count` point contacts, each on a random body near its origin.
void randomPoints(Contacts& c, const Kinematics<double>& kin, int count, Rng& rng) {
  for (int e = 0; e < count; ++e) {
    const int b = rng.below(static_cast<int>(kin.X.size()));
    c.point(b, nearBody(kin, b, rng));
  }
}

// World-frame kinematics of the model at q.
Kinematics<double> kinematicsAt(const Model& model, const Eigen::VectorXd& q) {
  Kinematics<double> kin(model);
  computeKinematics<double>(model, q, kin);
  return kin;
}

// Jᵀ M⁻¹ J with X = M⁻¹J from the lapack solver.
Eigen::MatrixXd denseReference(const Model& model, const Eigen::VectorXd& q,
                               const Kinematics<double>& kin, const Contacts& c) {
  std::unique_ptr<Solver> s = makeSolver("lapack");
  s->prepare(model);
  s->configure(q);
  Eigen::MatrixXd J = Eigen::MatrixXd::Zero(model.nv(), c.m()), X(model.nv(), c.m());
  for (int r = 0; r < c.m(); ++r) addJacobianColumn(model, kin, c.bodies[r], c.wrenches[r], J, r);
  s->solve(J, X);
  return J.transpose() * X;
}

// The recursion's A for the contacts at q.
Eigen::MatrixXd recursion(const Model& model, const Kinematics<double>& kin, const Contacts& c,
                          int capacity = 0, int threads = 1) {
  Articulated<double> art(model);
  articulatedInertias<double>(model, kin, art);
  ContactInertiaWorkspace<double> ws(model, capacity);
  Eigen::MatrixXd A(c.m(), c.m());
  A.setConstant(std::nan(""));  // every entry must be written
  contactInertia<double>(model, kin, art, c.bodies, c.wrenches, ws, A, threads);
  return A;
}

double relativeError(const Eigen::MatrixXd& A, const Eigen::MatrixXd& ref) {
  return (A - ref).norm() / ref.norm();
}

// Checks the recursion against the reference at q; returns the error.
double check(const Model& model, const Eigen::VectorXd& q, const Contacts& c,
             const std::string& what) {
  const Kinematics<double> kin = kinematicsAt(model, q);
  const Eigen::MatrixXd ref = denseReference(model, q, kin, c);
  const Eigen::MatrixXd A = recursion(model, kin, c);
  EXPECT_TRUE(A.allFinite()) << what;
  EXPECT_TRUE(A == A.transpose()) << what << ": not exactly symmetric";
  const double err = relativeError(A, ref);
  EXPECT_LT(err, 1e-10) << what << " (m = " << c.m() << ", nv = " << model.nv() << ")";
  return err;
}

// A point contact at every leg tip of the centipede posed by kin.
Contacts tipContacts(const Centipede& cp, const Kinematics<double>& kin) {
  Contacts c;
  for (int l = 0; l < cp.legs(); ++l) {
    const Pose<double>& X = kin.X[cp.lower_body[l]];
    c.point(cp.lower_body[l], X.p + X.R * cp.tip);
  }
  return c;
}

// Every tip in contact at a random configuration, plus random wrenches on random bodies.
void centipedeCase(SegmentJoint joint, int segments, std::uint64_t seed) {
  const Centipede cp = makeCentipede({.segments = segments, .segment_joint = joint});
  const Model& m = cp.model;
  const Eigen::VectorXd q = randomConfiguration(m, seed);
  const Kinematics<double> kin = kinematicsAt(m, q);
  Contacts c = tipContacts(cp, kin);
  Rng rng(seed);
  randomPoints(c, kin, 4, rng);
  check(m, q, c,
        std::string("centipede ") + segmentJointName(joint) + " S=" + std::to_string(segments));
}

// Two threads split the large pair blocks by rows: the same matrix bit for bit, and the
// reference's within 1e-10. A floating base with two chains of 80 revolute bodies and a point
// contact on each: the root's block pairs the chains' 240 directions, 240 × 240 entries, over
// the split threshold (the centipede's blocks are one subtree × at most 6 directions: none is).
TEST(ContactInertia, TwoThreads) {
  constexpr int kChain = 80;
  std::vector<int> parent{-1};
  std::vector<Joint> joints(1);
  joints[0].type = JointType::Floating;
  Rng axes(7);
  for (int c = 0; c < 2; ++c)
    for (int i = 0; i < kChain; ++i) {
      parent.push_back(i == 0 ? 0 : static_cast<int>(parent.size()) - 1);
      Joint j;
      j.axis = axes.unitVector();
      j.placement.p = Eigen::Vector3d(c == 0 ? 0.1 : -0.1, 0.02, 0);
      joints.push_back(j);
    }
  for (std::size_t i = 0; i < joints.size(); ++i) joints[i].name = "j" + std::to_string(i);
  std::vector<Body> bodies(joints.size());
  for (std::size_t i = 0; i < bodies.size(); ++i) {
    bodies[i].name = "b" + std::to_string(i);
    bodies[i].com = Eigen::Vector3d(0.05, 0, 0);
  }
  const Model m = Model::create(parent, joints, bodies);
  const Eigen::VectorXd q = randomConfiguration(m, 41);
  const Kinematics<double> kin = kinematicsAt(m, q);
  Rng rng(42);
  Contacts c;
  for (int b = 1; b < m.nb(); ++b) c.point(b, nearBody(kin, b, rng));
  static_assert(3 * kChain * 3 * kChain >= ContactInertiaWorkspace<double>::kParallelEntries);
  const Eigen::MatrixXd one = recursion(m, kin, c), two = recursion(m, kin, c, 0, 2);
  EXPECT_TRUE(two == one) << "two threads changed A";
  EXPECT_LT(relativeError(two, denseReference(m, q, kin, c)), 1e-10);
}

TEST(ContactInertia, CentipedeYaw) {
  for (int S : {1, 2, 5, 12}) centipedeCase(SegmentJoint::Yaw, S, 10 + S);
}

TEST(ContactInertia, CentipedeSpherical) {
  for (int S : {1, 2, 5, 12}) centipedeCase(SegmentJoint::Spherical, S, 20 + S);
}

// Random branched trees, mixed joints, fixed and floating base: several points on one body,
// points on the root (the floating base itself), random bodies; the directions in a random
// order (out of preorder: the scattered path) and sorted by body (the direct path).
TEST(ContactInertia, RandomBranchedTrees) {
  for (int trial = 0; trial < 24; ++trial) {
    const bool floating = trial % 2 == 0;
    const Model m = randomTree({.topology = Topology::Branched,
                                .n = 5 + 3 * trial,
                                .seed = 300u + trial,
                                .floating_base = floating,
                                .joints = JointSet::Mixed});
    const Eigen::VectorXd q = randomConfiguration(m, 400 + trial);
    const Kinematics<double> kin = kinematicsAt(m, q);
    Rng rng(500 + trial);
    Contacts c;
    const int crowded = rng.below(m.nb());
    for (int e = 0; e < 3; ++e) c.point(crowded, nearBody(kin, crowded, rng));  // one body
    for (int e = 0; e < 2; ++e) c.point(0, nearBody(kin, 0, rng));              // the root
    for (int e = 0; e < 2 + trial % 5; ++e) {
      const int b = rng.below(m.nb());
      c.add(b, unitWrench(nearBody(kin, b, rng), rng.unitVector()));
    }
    // Random order, then sorted by body.
    std::vector<int> idx(c.m());
    std::iota(idx.begin(), idx.end(), 0);
    for (int i = c.m() - 1; i > 0; --i) std::swap(idx[i], idx[rng.below(i + 1)]);
    Contacts shuffled, sorted;
    for (int i : idx) shuffled.add(c.bodies[i], c.wrenches[i]);
    std::stable_sort(idx.begin(), idx.end(),
                     [&](int x, int y) { return c.bodies[x] < c.bodies[y]; });
    for (int i : idx) sorted.add(c.bodies[i], c.wrenches[i]);
    const std::string what = "trial " + std::to_string(trial);
    check(m, q, shuffled, what + " shuffled");
    check(m, q, sorted, what + " sorted");
  }
}

// Contacts only on the floating base: A = F Ω₀ Fᵀ with Ω₀ = IA₀⁻¹, the whole tree's
// articulated inertia seen at the base.
TEST(ContactInertia, ContactsOnTheFloatingBaseOnly) {
  const Model m =
      randomTree({.topology = Topology::Branched, .n = 12, .seed = 7, .floating_base = true});
  const Eigen::VectorXd q = randomConfiguration(m, 8);
  const Kinematics<double> kin = kinematicsAt(m, q);
  Rng rng(9);
  Contacts c;
  for (int e = 0; e < 4; ++e) c.point(0, nearBody(kin, 0, rng));
  check(m, q, c, "base only");
}

// A random serial chain of n bodies at a random configuration (seeds seed, seed + 100, and
// seed + 200 for the contacts), its contacts placed by place(model, kin, rng, contacts).
template <class Place>
void chainCase(int n, std::uint64_t seed, bool floating, JointSet joints, const std::string& what,
               Place&& place) {
  const Model m = randomTree({.topology = Topology::Serial,
                              .n = n,
                              .seed = seed,
                              .floating_base = floating,
                              .joints = joints});
  const Eigen::VectorXd q = randomConfiguration(m, seed + 100);
  const Kinematics<double> kin = kinematicsAt(m, q);
  Rng rng(seed + 200);
  Contacts c;
  place(m, kin, rng, c);
  check(m, q, c, what);
}

// Serial chains (revolute and mixed) with many directions at the tip and a few in the middle:
// long contact-free stretches carry > 6 directions, so the composite propagators Φ are used.
TEST(ContactInertia, SerialChainsCompositePropagators) {
  for (int trial = 0; trial < 6; ++trial)
    chainCase(15 + 5 * trial, 700u + trial, trial % 2 == 1,
              trial < 3 ? JointSet::Revolute : JointSet::Mixed, "chain " + std::to_string(trial),
              [](const Model& m, const Kinematics<double>& kin, Rng& rng, Contacts& c) {
                const int tip = m.nb() - 1, mid = m.nb() / 2;
                for (int e = 0; e < 4; ++e) c.point(tip, nearBody(kin, tip, rng));
                c.point(mid, nearBody(kin, mid, rng));
              });
}

// One or two points (3 or 6 directions: deferred) or three (9: not) at the tip of a chain,
// nothing else: the tip's own pairs climb the whole chain and are finished at the root.
TEST(ContactInertia, DeferredToTheRoot) {
  for (int trial = 0; trial < 6; ++trial)
    chainCase(4 + 3 * trial, 1100u + trial, trial % 2 == 1, JointSet::Mixed,
              "tip of chain " + std::to_string(trial),
              [&](const Model& m, const Kinematics<double>& kin, Rng& rng, Contacts& c) {
                const int tip = m.nb() - 1;
                for (int e = 0; e <= trial % 3; ++e) c.point(tip, nearBody(kin, tip, rng));
              });
}

// A forest: two trees side by side (no common ancestor, so their directions do not couple).
TEST(ContactInertia, Forest) {
  const Model a = floatingMixed(8, 11);
  const Model b = randomTree({.topology = Topology::Branched, .n = 6, .seed = 12});
  std::vector<int> parent;
  std::vector<Joint> joints;
  std::vector<Body> bodies;
  for (const Model* t : {&a, &b}) {
    const int off = static_cast<int>(parent.size());
    for (int i = 0; i < t->nb(); ++i) {
      parent.push_back(t->parent(i) < 0 ? -1 : t->parent(i) + off);
      Joint j = t->joint(i);
      j.name += t == &a ? "_a" : "_b";
      joints.push_back(j);
      Body bd = t->body(i);
      bd.name += t == &a ? "_a" : "_b";
      bodies.push_back(bd);
    }
  }
  const Model m = Model::create(parent, joints, bodies);
  const Eigen::VectorXd q = randomConfiguration(m, 13);
  const Kinematics<double> kin = kinematicsAt(m, q);
  Rng rng(14);
  Contacts c;
  randomPoints(c, kin, 6, rng);
  c.point(a.nb(), nearBody(kin, a.nb(), rng));  // the second tree's root
  check(m, q, c, "forest");
}

// The workspace grows once when m exceeds its capacity, and one workspace serves calls with
// changing contact sets, and with a set repeated at a new configuration (its tables kept).
TEST(ContactInertia, WorkspaceReuse) {
  const Centipede cp = makeCentipede({.segments = 6});
  const Model& m = cp.model;
  ContactInertiaWorkspace<double> ws(m, 3);
  Articulated<double> art(m);
  Kinematics<double> kin(m);
  const int sets[] = {0, 0, 1, 1, 2, 0, 3, 3, 3};
  for (int call = 0; call < 9; ++call) {
    const int set = sets[call];
    const Eigen::VectorXd q = randomConfiguration(m, 60 + call);
    computeKinematics<double>(m, q, kin);
    articulatedInertias<double>(m, kin, art);
    Contacts c;
    for (int l = set; l < cp.legs(); l += 1 + set) {
      const Pose<double>& X = kin.X[cp.lower_body[l]];
      c.point(cp.lower_body[l], X.p + X.R * cp.tip);
    }
    Eigen::MatrixXd A(c.m(), c.m());
    contactInertia<double>(m, kin, art, c.bodies, c.wrenches, ws, A);
    EXPECT_LT(relativeError(A, denseReference(m, q, kin, c)), 1e-10) << call;
  }
}

// The cached tables on any tree: one workspace (and a copy of it) through sets of directions
// that repeat at new configurations, out of preorder, with several on one body, and a larger
// set after a smaller one; every A against the dense reference, every entry written.
TEST(ContactInertia, CachedTablesOnRandomTrees) {
  for (int trial = 0; trial < 6; ++trial) {
    const Model m = floatingMixed(8 + 4 * trial, 700u + trial);
    Rng rng(800 + trial);
    // Three sets of (body, direction seed); each call draws its wrenches at its own q.
    std::vector<std::vector<int>> sets(3);
    for (int k = 0; k < 3; ++k)
      for (int e = 0; e < 2 + 3 * k; ++e) sets[k].push_back(rng.below(m.nb()));
    sets[1].push_back(sets[1][0]);  // two directions on one body
    ContactInertiaWorkspace<double> ws(m, 2);
    Articulated<double> art(m);
    const int order[] = {0, 0, 1, 1, 0, 2, 2, 1};
    for (int call = 0; call < 8; ++call) {
      const Eigen::VectorXd q = randomConfiguration(m, 900 + 10 * trial + call);
      const Kinematics<double> kin = kinematicsAt(m, q);
      articulatedInertias<double>(m, kin, art);
      Contacts c;
      for (int b : sets[order[call]]) c.add(b, unitWrench(nearBody(kin, b, rng), rng.unitVector()));
      ContactInertiaWorkspace<double> copy = ws;  // a copy keeps the tables and the capacity
      for (ContactInertiaWorkspace<double>* w : {&ws, &copy}) {
        Eigen::MatrixXd A(c.m(), c.m());
        A.setConstant(std::nan(""));
        contactInertia<double>(m, kin, art, c.bodies, c.wrenches, *w, A);
        EXPECT_TRUE(A.allFinite()) << trial << " " << call;
        EXPECT_LT(relativeError(A, denseReference(m, q, kin, c)), 1e-10) << trial << " " << call;
      }
    }
  }
}

// The Counted instantiation computes the same A (it is the same code).
TEST(ContactInertia, CountedGivesTheSameNumbers) {
  const Model m = floatingMixed(20, 31);
  const Eigen::VectorXd q = randomConfiguration(m, 32);
  const Kinematics<double> kin = kinematicsAt(m, q);
  Rng rng(33);
  Contacts c;
  randomPoints(c, kin, 8, rng);
  const Eigen::MatrixXd A = recursion(m, kin, c);
  Kinematics<Counted> kc(m);
  computeKinematics<Counted>(m, q.cast<Counted>(), kc);
  Articulated<Counted> ac(m);
  articulatedInertias<Counted>(m, kc, ac);
  ContactInertiaWorkspace<Counted> ws(m, c.m());
  std::vector<Vec6<Counted>> wc;
  for (const Vec6<double>& f : c.wrenches) wc.push_back(f.cast<Counted>());
  MatX<Counted> Ac(c.m(), c.m());
  contactInertia<Counted>(m, kc, ac, c.bodies, wc, ws, Ac);
  const Eigen::MatrixXd Ad = Ac.unaryExpr([](const Counted& x) { return x.value(); });
  EXPECT_LT((Ad - A).norm(), 1e-13 * A.norm());
}

// Operation counts of one call at the standing centipede with every tip in contact (yaw
// segment joints, m = 3·2S directions), the fit counts ≈ a·n + b·m² (least squares over S),
// written as Markdown to $MINV_COUNT_TABLE if set. Checks the Θ(n + m²) shape: the fit's
// worst relative residual, and the m² coefficient near the 6 mul + 6 add per entry of one
// triangle (3 per entry of A).
TEST(ContactInertia, OperationCountTable) {
  const std::vector<int> segments{5, 10, 20, 40, 80, 160, 250};
  struct Row {
    int S, n, m;
    FlopCounts counts;
  };
  std::vector<Row> rows;
  for (int S : segments) {
    const Centipede cp = makeCentipede({.segments = S});
    const Model& m = cp.model;
    const Eigen::VectorXd q = centipedeStanding(cp);
    Kinematics<Counted> kin(m);
    computeKinematics<Counted>(m, q.cast<Counted>(), kin);
    Articulated<Counted> art(m);
    articulatedInertias<Counted>(m, kin, art);
    std::vector<int> bodies;
    std::vector<Vec6<Counted>> wrenches;
    for (int l = 0; l < cp.legs(); ++l) {
      const Pose<Counted>& X = kin.X[cp.lower_body[l]];
      const Vec3<Counted> p = X.p + X.R * cp.tip.cast<Counted>();
      for (int d = 0; d < 3; ++d) {
        const Vec3<Counted> dir = Eigen::Vector3d::Unit((d + 2) % 3).cast<Counted>();
        Vec6<Counted> f;
        f << p.cross(dir), dir;
        bodies.push_back(cp.lower_body[l]);
        wrenches.push_back(f);
      }
    }
    const int mm = static_cast<int>(bodies.size());
    ContactInertiaWorkspace<Counted> ws(m, mm);
    MatX<Counted> A(mm, mm);
    const FlopCounts before = flopTotal();
    contactInertia<Counted>(m, kin, art, bodies, wrenches, ws, A);
    rows.push_back({S, m.nv(), mm, flopTotal() - before});
  }
  // Least squares a·n + b·m² for mul and for add.
  Eigen::MatrixXd X(rows.size(), 2);
  Eigen::VectorXd ymul(rows.size()), yadd(rows.size());
  for (std::size_t i = 0; i < rows.size(); ++i) {
    X(i, 0) = rows[i].n;
    X(i, 1) = double(rows[i].m) * rows[i].m;
    ymul(i) = static_cast<double>(rows[i].counts.mul);
    yadd(i) = static_cast<double>(rows[i].counts.add);
  }
  const Eigen::Vector2d fm = X.colPivHouseholderQr().solve(ymul);
  const Eigen::Vector2d fa = X.colPivHouseholderQr().solve(yadd);
  double worst = 0;
  for (std::size_t i = 0; i < rows.size(); ++i) {
    worst = std::max(worst, std::abs((X.row(i) * fm)(0) - ymul(i)) / ymul(i));
    worst = std::max(worst, std::abs((X.row(i) * fa)(0) - yadd(i)) / yadd(i));
  }
  std::string md =
      "# Operation counts of the contact-space inertia recursion\n\n"
      "One call of `contactInertia` (sim/contact_inertia.hpp) per time step, counted on the\n"
      "`Counted` scalar (core/counting.hpp), at the standing centipede (yaw segment joints)\n"
      "with every leg tip in contact: m = 3 directions (normal, two tangents) per tip, 2S tips.\n"
      "Produced by `MINV_COUNT_TABLE=paper/contact_inertia_counts.md minv_tests\n"
      "--gtest_filter=ContactInertia.OperationCountTable` (tests/contact_inertia_test.cpp).\n"
      "Divisions, square roots: none.\n\n"
      "| S | n (DOF) | m | mul | add | mul / m² | add / m² |\n"
      "|---:|---:|---:|---:|---:|---:|---:|\n";
  char buf[256];
  for (const Row& r : rows) {
    const double m2 = double(r.m) * r.m;
    std::snprintf(buf, sizeof buf, "| %d | %d | %d | %llu | %llu | %.2f | %.2f |\n", r.S, r.n, r.m,
                  static_cast<unsigned long long>(r.counts.mul),
                  static_cast<unsigned long long>(r.counts.add), r.counts.mul / m2,
                  r.counts.add / m2);
    md += buf;
    EXPECT_EQ(r.counts.div, 0u);
    EXPECT_EQ(r.counts.sqrt, 0u);
  }
  std::snprintf(buf, sizeof buf,
                "\nLeast-squares fit over the rows: mul ≈ %.1f·n + %.3f·m², add ≈ %.1f·n + "
                "%.3f·m²; worst relative residual %.1f%%.\n",
                fm(0), fm(1), fa(0), fa(1), 100 * worst);
  md += buf;
  std::printf("%s", md.c_str());
  if (const char* path = std::getenv("MINV_COUNT_TABLE")) {
    std::ofstream out(path);
    out << md;
  }
  EXPECT_LT(worst, 0.1);
  EXPECT_GT(fm(1), 2.5);
  EXPECT_LT(fm(1), 6.0);
}

}  // namespace
}  // namespace minv::sim
