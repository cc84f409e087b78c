// The reference impulse sweeps (core/impulse_sweeps.hpp) against a dense inverse of CRBA's M,
// and abi's SIMD kernel (solvers/abi.hpp, at every instruction-set level this CPU runs) against
// the reference, on every tree kind (serial and branched, fixed and floating base, revolute
// and mixed joints, the centipede with yaw and spherical segment joints) and every lane
// remainder: nv mod 16 takes each value 0 … 15 with nv ≥ 16 (full blocks of 16 lanes and a
// partial one) for every kind, and every kind also has trees with nv < 16 (one partial block)
// and all but the centipede (nv ≥ 14) trees with nv ≤ 8 (a lone half-width block; remainders
// 1 … 8 give a half-width last block after full ones); solve() runs with m ∈ {1, …, 17, 33}
// columns (the one-lane, half and full blocks, and two full blocks + one lane).
//
// Bounds, as in solvers/conformance.hpp: relative Frobenius ≤ tol = 10·(nv + 10)·κ·ε with
// κ = cond₂(M) and ε the unit roundoff. A failure names the worst column, its block and lane.
#include "core/impulse_sweeps.hpp"

#include <gtest/gtest.h>
#include <immintrin.h>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <Eigen/QR>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <memory>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "core/articulated.hpp"
#include "core/counting.hpp"
#include "core/crba.hpp"
#include "core/kinematics.hpp"
#include "generators/centipede.hpp"
#include "generators/random_tree.hpp"
#include "solvers/abi_variants.hpp"
#include "solvers/solver.hpp"

namespace minv {
namespace {

constexpr int kLanes = 16;  // kAbiLanes<double> (solvers/abi.hpp)

struct Case {
  std::string kind, name;
  Model model;
  Eigen::VectorXd q;
  Eigen::MatrixXd M;
  double tol = 0;
};

double relativeError(const Eigen::MatrixXd& x, const Eigen::MatrixXd& ref) {
  return (x - ref).norm() / std::max(ref.norm(), 1e-300);
}

double bound(const Eigen::MatrixXd& M) {
  const Eigen::VectorXd ev = Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(M).eigenvalues();
  const double kappa = ev.maxCoeff() / ev.minCoeff();
  return 10 * (M.rows() + 10) * kappa * std::numeric_limits<double>::epsilon();
}

Case makeCase(std::string kind, std::string name, Model model, std::uint64_t seed) {
  Case c{std::move(kind), std::move(name), std::move(model), {}, {}, 0};
  c.q = randomConfiguration(c.model, seed);
  c.M = massMatrix(c.model, c.q);
  c.tol = bound(c.M);
  return c;
}

// Every tree kind, each with n = 1, 2, … until nv mod 16 has taken all 16 values with
// nv ≥ 16; the centipede with S = 1 … 17 segments (nv = 9S + 5 and 11S + 3: 9 and 11 are
// prime to 16, so S = 2 … 17, all with nv ≥ 16, give every remainder).
const std::vector<Case>& cases() {
  static const std::vector<Case> all = [] {
    std::vector<Case> out;
    for (Topology t : {Topology::Serial, Topology::Branched})
      for (bool floating : {false, true})
        for (JointSet j : {JointSet::Revolute, JointSet::Mixed}) {
          const std::string kind = std::string(topologyName(t)) + "_" + jointSetName(j) +
                                   (floating ? "_floating" : "_fixed");
          std::set<int> remainders;
          for (int n = 1; remainders.size() < kLanes; ++n) {
            const std::uint64_t seed = 500 + n;
            Model m = randomTree({t, n, seed, floating, j});
            if (m.nv() >= kLanes) remainders.insert(m.nv() % kLanes);
            out.push_back(makeCase(kind, kind + "_n" + std::to_string(n), std::move(m), seed));
          }
        }
    for (SegmentJoint sj : {SegmentJoint::Yaw, SegmentJoint::Spherical})
      for (int S = 1; S <= kLanes + 1; ++S) {
        const std::string kind = std::string("centipede_") + segmentJointName(sj);
        Centipede c = makeCentipede({.segments = S, .segment_joint = sj});
        out.push_back(makeCase(kind, kind + "_S" + std::to_string(S), std::move(c.model), 90 + S));
      }
    return out;
  }();
  return all;
}

Eigen::MatrixXd reference(const Case& c) {
  Kinematics<double> kin(c.model);
  computeKinematics<double>(c.model, c.q, kin);
  Articulated<double> art(c.model);
  articulatedInertias<double>(c.model, kin, art);
  Eigen::MatrixXd X(c.model.nv(), c.model.nv());
  referenceInverse<double>(c.model, kin, art, X);
  return X;
}

// The largest error/bound seen by a test, printed at its end (how close to failing).
struct Worst {
  double ratio = 0;
  std::string where;
  void add(double error, double bound, const std::string& name) {
    if (error / bound > ratio) ratio = error / bound, where = name;
  }
  ~Worst() { std::printf("  worst error/bound %.3g (%s)\n", ratio, where.c_str()); }
};

// "worst column c (block b, lane w): error e" for a failure message.
std::string worstColumn(const Eigen::MatrixXd& x, const Eigen::MatrixXd& ref) {
  int worst = 0;
  double e = -1;
  for (int c = 0; c < x.cols(); ++c) {
    const double ec = (x.col(c) - ref.col(c)).norm() / std::max(ref.col(c).norm(), 1e-300);
    if (!(ec <= e)) worst = c, e = ec;
  }
  std::ostringstream s;
  s << "worst column " << worst << " (block " << worst / kLanes << ", lane " << worst % kLanes
    << "): relative error " << e;
  return s.str();
}

// The case list is what the header promises: per kind, every remainder with nv ≥ 16, and
// trees with nv < 16 and nv ≤ 8.
TEST(ImpulseSweeps, CasesCoverEveryLaneRemainder) {
  std::set<std::string> kinds;
  for (const Case& c : cases()) kinds.insert(c.kind);
  EXPECT_EQ(kinds.size(), 10u);
  for (const std::string& kind : kinds) {
    std::set<int> remainders;
    bool small = false, half = false;
    for (const Case& c : cases()) {
      if (c.kind != kind) continue;
      if (c.model.nv() >= kLanes) remainders.insert(c.model.nv() % kLanes);
      small |= c.model.nv() < kLanes;
      half |= c.model.nv() <= kLanes / 2;
    }
    EXPECT_EQ(remainders.size(), static_cast<std::size_t>(kLanes)) << kind;
    EXPECT_TRUE(small) << kind;
    // A floating centipede has nv ≥ 14; every other kind reaches nv ≤ 8.
    if (kind.rfind("centipede", 0) != 0) {
      EXPECT_TRUE(half) << kind;
    }
  }
}

// The oracle is independent of abi: against CRBA's M, inverted densely, and multiplied back.
TEST(ImpulseSweeps, ReferenceInverseMatchesDenseInverseOfCrba) {
  Worst worst;
  for (const Case& c : cases()) {
    const int n = c.model.nv();
    const Eigen::MatrixXd I = Eigen::MatrixXd::Identity(n, n);
    const Eigen::MatrixXd X = reference(c);
    const Eigen::MatrixXd Xd = c.M.llt().solve(I);
    const double e = relativeError(X, Xd), r = relativeError(c.M * X, I);
    EXPECT_LE(e, c.tol) << c.name << ": " << worstColumn(X, Xd);
    EXPECT_LE(r, c.tol) << c.name << " |M X − I|";
    worst.add(e, c.tol, c.name);
    worst.add(r, c.tol, c.name + " |M X − I|");
  }
}

// The reference on the counting scalar: the same values, and Θ(nb) operations per column.
TEST(ImpulseSweeps, ReferenceRunsOnTheCountingScalar) {
  for (int n : {10, 20}) {
    const Model m = randomTree({Topology::Serial, n, 3, false, JointSet::Revolute});
    const Eigen::VectorXd q = randomConfiguration(m, 4);
    Kinematics<Counted> kin(m);
    computeKinematics<Counted>(m, q.cast<Counted>(), kin);
    Articulated<Counted> art(m);
    articulatedInertias<Counted>(m, kin, art);
    ImpulseWorkspace<Counted> ws(m);
    VecX<Counted> r = VecX<Counted>::Zero(m.nv()), dq(m.nv());
    r(n / 2) = 1;
    flopReset();
    impulseResponse<Counted>(m, kin, art, r, dq, ws);
    const FlopCounts counts = flopTotal();
    // Per body 12 mul + 18 add backward and 13 mul + 12 add forward; the root 6 + 6 and 7 + 0
    // (nothing to hand up, no Δv_λ): the cost in the header.
    EXPECT_EQ(counts.mul, std::uint64_t(25 * n - 12)) << n;
    EXPECT_EQ(counts.add, std::uint64_t(30 * n - 24)) << n;
    Kinematics<double> kd(m);
    computeKinematics<double>(m, q, kd);
    Articulated<double> ad(m);
    articulatedInertias<double>(m, kd, ad);
    Eigen::MatrixXd X(m.nv(), m.nv());
    referenceInverse<double>(m, kd, ad, X);
    for (int v = 0; v < m.nv(); ++v)
      EXPECT_NEAR(dq(v).value(), X(v, n / 2), 1e-12 * X.col(n / 2).norm()) << v;
  }
}

// Spatial impulses: a test impulse and a combination of them against M⁻¹ Jᵀ-style products
// formed with the dense inverse, and Δv_i = Σ S_j Δq̇_j over i's path.
TEST(ImpulseSweeps, SpatialImpulsesMatchDenseProducts) {
  for (const Case& c : cases()) {
    if (c.model.nb() < 2 || c.model.nv() > 80) continue;
    const Model& m = c.model;
    Kinematics<double> kin(m);
    computeKinematics<double>(m, c.q, kin);
    Articulated<double> art(m);
    articulatedInertias<double>(m, kin, art);
    const Eigen::MatrixXd Xd = c.M.llt().solve(Eigen::MatrixXd::Identity(m.nv(), m.nv()));
    ImpulseWorkspace<double> ws(m);
    Rng rng(m.nv());
    std::vector<int> bodies;
    std::vector<Vec6<double>> f;
    Eigen::VectorXd lambda(3), r = Eigen::VectorXd::Zero(m.nv()), dq(m.nv());
    for (int s = 0; s < 3; ++s) {
      bodies.push_back(rng.below(m.nb()));
      Vec6<double> fs;
      for (int i = 0; i < 6; ++i) fs(i) = rng.uniform(-1, 1);
      f.push_back(fs);
      lambda(s) = rng.uniform(-1, 1);
      // J_bᵀ f: S_jᵀ f over b's path.
      Eigen::VectorXd rs = Eigen::VectorXd::Zero(m.nv());
      for (int i = bodies[s]; i >= 0; i = m.parent(i))
        rs.segment(m.vIdx(i), m.nvOf(i)) = kin.S.middleCols(m.vIdx(i), m.nvOf(i)).transpose() * fs;
      r += lambda(s) * rs;
      // One test impulse, and the Δv of its body.
      testImpulseResponse<double>(m, kin, art, bodies[s], fs, dq, ws);
      const Eigen::VectorXd ref = Xd * rs;
      EXPECT_LE(relativeError(dq, ref), c.tol) << c.name << " test impulse " << s;
      Vec6<double> dv = Vec6<double>::Zero();
      for (int i = bodies[s]; i >= 0; i = m.parent(i))
        dv += kin.S.middleCols(m.vIdx(i), m.nvOf(i)) * ref.segment(m.vIdx(i), m.nvOf(i));
      EXPECT_LE((ws.dv.col(bodies[s]) - dv).norm(), c.tol * std::max(dv.norm(), 1e-300))
          << c.name << " Δv " << s;
    }
    spatialImpulseResponse<double>(m, kin, art, bodies, f, lambda, dq, ws);
    EXPECT_LE(relativeError(dq, Xd * r), c.tol) << c.name << " combined";
  }
}

// The SIMD kernel at every instruction-set level this CPU runs (solvers/abi_variants.hpp);
// every level's lane count divides kLanes, so the remainders above cover each of them.
std::vector<Isa> abiLevelsHere() {
  std::vector<Isa> out;
  for (Isa l : abiLevels())
    if (abiLevelUsable(l)) {
      EXPECT_EQ(kLanes % abiVariant(l).lanes, 0) << isaName(l);
      out.push_back(l);
    }
  return out;
}

// An environment variable as it was when made, put back when destroyed.
struct RestoreEnv {
  std::string name, value;
  bool set;
  explicit RestoreEnv(const char* n) : name(n), set(std::getenv(n) != nullptr) {
    if (set) value = std::getenv(n);
  }
  ~RestoreEnv() {
    if (set)
      setenv(name.c_str(), value.c_str(), 1);
    else
      unsetenv(name.c_str());
  }
};

// abi's inverse() against the reference, column by column, with the mirrored rows streamed
// and stored plainly (MINV_ABI_ROWS, read in prepare(); core/cpu.hpp).
TEST(ImpulseSweeps, AbiInverseMatchesReference) {
  ASSERT_FALSE(abiLevelsHere().empty());
  const RestoreEnv restore("MINV_ABI_ROWS");
  Worst worst;
  for (const Case& c : cases()) {
    const int n = c.model.nv();
    const Eigen::MatrixXd ref = reference(c);
    for (Isa level : abiLevelsHere())
      for (const char* rows : {"plain", "stream"}) {
        const std::string name = std::string("abi at ") + isaName(level) + ", rows " + rows;
        setenv("MINV_ABI_ROWS", rows, 1);
        auto abi = makeAbiAt(level);
        abi->prepare(c.model);
        abi->configure(c.q);
        Eigen::MatrixXd X(n, n);
        abi->inverse(X);
        const double e = relativeError(X, ref);
        EXPECT_LE(e, c.tol) << name << " " << c.name << " nv=" << n << " nv mod 16=" << n % 16
                            << ": " << worstColumn(X, ref);
        worst.add(e, c.tol, name + " " + c.name);
      }
  }
}

// abi's inverse() takes full blocks in groups at level avx512: pairs from nv = 256, eight from
// nv = 4096 (kAbiGroup in solvers/abi.hpp), their forward sweeps in pieces of kAbiGroupChunk
// bodies (abiInverseBlockGroup); inverseUpper() takes one block at a time in one piece. A run of
// links cut between pieces is resumed, not restarted, so both compute every entry with the same
// operations: their upper triangles agree bit for bit, at every level, on trees long enough for
// several pieces (a restarted run would differ in the last bits). Bit for bit also needs the
// same machine code (the forward sweep is one out-of-line function; the backward sweep is
// inlined into both callers and contracted alike by GCC 12): another compiler may need this
// test relaxed.

// X = inverse() and U = inverseUpper() of abi at `level`, rows streamed or plain, the inverse
// on `threads` threads (units dealt by OpenMP); the number of upper-triangle entries where X
// differs from U or from its own transpose (X starts as NaN: an entry left unwritten differs).
int groupedAgainstSingle(Isa level, const char* rows, int threads, const Case& c,
                         Eigen::MatrixXd& X) {
  const int n = c.model.nv();
  setenv("MINV_ABI_ROWS", rows, 1);
  auto abi = makeAbiAt(level);
  abi->prepare(c.model);
  abi->setThreads(threads);
  abi->configure(c.q);
  X.setConstant(n, n, std::numeric_limits<double>::quiet_NaN());
  Eigen::MatrixXd U = Eigen::MatrixXd::Zero(n, n);
  abi->inverse(X);
  abi->setThreads(1);
  abi->inverseUpper(U);
  int differ = 0;
  for (int j = 0; j < n; ++j)
    for (int i = 0; i <= j; ++i) differ += X(i, j) != U(i, j) || X(j, i) != X(i, j);
  return differ;
}

// Pairs (nv >= 256) on four trees, every level (single blocks alike where none pair).
TEST(ImpulseSweeps, AbiPairedBlocksMatchSingleBlocksExactly) {
  ASSERT_FALSE(abiLevelsHere().empty());
  std::vector<Case> big;
  // n = 310: 19 full blocks (a full block left over after the pairs) and a half-wide last one.
  big.push_back(makeCase("serial", "serial_revolute_n310",
                         randomTree({Topology::Serial, 310, 7, false, JointSet::Revolute}), 7));
  big.push_back(makeCase("branched", "branched_mixed_floating_n270",
                         randomTree({Topology::Branched, 270, 8, true, JointSet::Mixed}), 8));
  big.push_back(makeCase("serial", "serial_mixed_floating_n260",
                         randomTree({Topology::Serial, 260, 9, true, JointSet::Mixed}), 9));
  big.push_back(makeCase(
      "centipede", "centipede_spherical_S30",
      makeCentipede({.segments = 30, .segment_joint = SegmentJoint::Spherical}).model, 10));
  const RestoreEnv restore("MINV_ABI_ROWS");
  bool paired = false;
  Eigen::MatrixXd X;
  for (const Case& c : big) {
    const int n = c.model.nv();
    ASSERT_GE(n, 256) << c.name;
    for (Isa level : abiLevelsHere()) {
      paired |= level == Isa::Avx512;
      // Rows streamed and plain; the inverse on one thread and on two.
      for (const char* rows : {"plain", "stream"})
        for (int threads : {1, 2}) {
          const std::string name = std::string(isaName(level)) + ", rows " + rows + ", " +
                                   std::to_string(threads) + " thread(s), " + c.name;
          EXPECT_EQ(groupedAgainstSingle(level, rows, threads, c, X), 0) << name << " nv=" << n;
          // And both are M⁻¹.
          EXPECT_LE(relativeError(X, c.M.inverse()), c.tol) << name;
        }
    }
  }
  if (!paired)
    std::printf("note: no avx512 level on this CPU: no block was paired (single blocks only)\n");
}

// The same for groups of eight blocks (nv >= 4096), on a serial chain (n = 4148: 259 full
// blocks, so 32 groups, 3 single blocks and a half-wide last one) and a branched tree with
// mixed joints and a floating base (its branch points' Y and Δv go through memory). M⁻¹ is
// checked on 24 columns against the one-column reference, within 1e-9 relative per column (the
// chain's κ is large; as in AbiFlushesSubnormalsAndRestoresTheMode). Only at the levels that
// group (avx512): elsewhere the other tests cover these single blocks.
TEST(ImpulseSweeps, AbiGroupsOfEightMatchSingleBlocksExactly) {
  ASSERT_FALSE(abiLevelsHere().empty());
  std::vector<Isa> grouping;
  for (Isa level : abiLevelsHere())
    if (level == Isa::Avx512) grouping.push_back(level);
  if (grouping.empty()) {
    std::printf("note: no avx512 level on this CPU: no blocks are grouped, nothing to compare\n");
    return;
  }
  constexpr double kTol = 1e-9;
  std::vector<Case> big;
  for (auto [name, options] :
       {std::pair{"serial_revolute_n4148",
                  TreeOptions{Topology::Serial, 4148, 11, false, JointSet::Revolute}},
        std::pair{"branched_mixed_floating_n3000",
                  TreeOptions{Topology::Branched, 3000, 12, true, JointSet::Mixed}}}) {
    Case c{"big", name, randomTree(options), {}, {}, 0};
    c.q = randomConfiguration(c.model, options.seed);
    big.push_back(std::move(c));
  }
  const RestoreEnv restore("MINV_ABI_ROWS");
  Eigen::MatrixXd X;
  for (const Case& c : big) {
    const int n = c.model.nv();
    ASSERT_GE(n, 4096) << c.name;
    Kinematics<double> kin(c.model);
    computeKinematics<double>(c.model, c.q, kin);
    Articulated<double> art(c.model);
    articulatedInertias<double>(c.model, kin, art);
    ImpulseWorkspace<double> ws(c.model);
    std::vector<int> cols;
    for (int j = 0; j < 24; ++j) cols.push_back(static_cast<int>(std::int64_t(j) * (n - 1) / 23));
    Eigen::MatrixXd ref(n, static_cast<Eigen::Index>(cols.size()));
    for (std::size_t j = 0; j < cols.size(); ++j)
      impulseResponse<double>(c.model, kin, art, Eigen::VectorXd::Unit(n, cols[j]), ref.col(j), ws);
    // Rows streamed and plain; the inverse on one thread and on two.
    for (Isa level : grouping)
      for (const char* rows : {"plain", "stream"})
        for (int threads : {1, 2}) {
          const std::string name = std::string(isaName(level)) + ", rows " + rows + ", " +
                                   std::to_string(threads) + " thread(s), " + c.name;
          EXPECT_EQ(groupedAgainstSingle(level, rows, threads, c, X), 0) << name << " nv=" << n;
          for (std::size_t j = 0; j < cols.size(); ++j) {
            const auto r = ref.col(static_cast<Eigen::Index>(j));
            EXPECT_LE((X.col(cols[j]) - r).norm(), kTol * r.norm())
                << name << " column " << cols[j];
          }
        }
  }
}

// abi's solve(R) against the reference's response to each column of R.
TEST(ImpulseSweeps, AbiSolveMatchesReference) {
  ASSERT_FALSE(abiLevelsHere().empty());
  std::vector<int> widths;
  for (int m = 1; m <= 17; ++m) widths.push_back(m);
  widths.push_back(33);
  Worst worst;
  for (const Case& c : cases()) {
    const Model& model = c.model;
    const int n = model.nv();
    Kinematics<double> kin(model);
    computeKinematics<double>(model, c.q, kin);
    Articulated<double> art(model);
    articulatedInertias<double>(model, kin, art);
    ImpulseWorkspace<double> ws(model);
    Rng rng(7 * n + 1);
    for (int m : widths) {
      Eigen::MatrixXd R(n, m), ref(n, m);
      for (int j = 0; j < m; ++j)
        for (int i = 0; i < n; ++i) R(i, j) = rng.uniform(-1, 1);
      for (int j = 0; j < m; ++j)
        impulseResponse<double>(model, kin, art, R.col(j), ref.col(j), ws);
      for (Isa level : abiLevelsHere()) {
        const std::string name = std::string("abi at ") + isaName(level);
        auto abi = makeAbiAt(level);
        abi->prepare(model);
        abi->configure(c.q);
        Eigen::MatrixXd X(n, m);
        abi->solve(R, X);
        const double e = relativeError(X, ref);
        EXPECT_LE(e, c.tol) << name << " " << c.name << " nv=" << n << " m=" << m << ": "
                            << worstColumn(X, ref);
        worst.add(e, c.tol, name + " " + c.name + " m=" + std::to_string(m));
      }
    }
  }
}

// Far along a long chain M⁻¹'s entries underflow (on this serial chain of n = 4096 about a
// quarter fall below DBL_MIN): abi flushes them to zero at every level (core/fpenv.hpp), agrees
// with the reference (which keeps them subnormal) entry by entry elsewhere, and leaves the
// caller's floating-point mode as it found it, flush-to-zero on or off.
TEST(ImpulseSweeps, AbiFlushesSubnormalsAndRestoresTheMode) {
  ASSERT_FALSE(abiLevelsHere().empty());
  constexpr double kTol = 1e-9;  // relative, per column (the chain's κ is large)
  const Model model = randomTree({Topology::Serial, 4096, 1, false, JointSet::Revolute});
  const int n = model.nv();
  const Eigen::VectorXd q = randomConfiguration(model, 3);
  Kinematics<double> kin(model);
  computeKinematics<double>(model, q, kin);
  Articulated<double> art(model);
  articulatedInertias<double>(model, kin, art);
  // Reference columns at both ends and in the middle, subnormals kept.
  const std::vector<int> cols = {0, n / 2, n - 1};
  Eigen::MatrixXd ref(n, static_cast<Eigen::Index>(cols.size()));
  ImpulseWorkspace<double> ws(model);
  for (std::size_t j = 0; j < cols.size(); ++j)
    impulseResponse<double>(model, kin, art, Eigen::VectorXd::Unit(n, cols[j]), ref.col(j), ws);
  const double tiny = std::numeric_limits<double>::min();
  auto subnormals = [&](const auto& x) {
    return (x.array() != 0 && x.array().abs() < tiny).count();
  };
  ASSERT_GT(subnormals(ref), n / 10) << "the case no longer underflows";
  Eigen::MatrixXd X(n, n);
  for (Isa level : abiLevelsHere()) {
    const std::string name = std::string("abi at ") + isaName(level);
    auto abi = makeAbiAt(level);
    abi->prepare(model);
    abi->configure(q);
    for (unsigned ftz : {0u, 1u << 15}) {
      const unsigned before = _mm_getcsr();
      _mm_setcsr((before & ~(1u << 15)) | ftz);
      const unsigned mode = _mm_getcsr();
      abi->inverse(X);
      EXPECT_EQ(_mm_getcsr(), mode) << name << ": the caller's MXCSR changed";
      _mm_setcsr(before);
      EXPECT_EQ(subnormals(X), 0) << name;
      // Column by column within kTol of the reference, and where the reference's entry is
      // subnormal abi's is zero or as negligible (the two round differently near DBL_MIN).
      for (std::size_t j = 0; j < cols.size(); ++j) {
        const auto r = ref.col(static_cast<Eigen::Index>(j));
        const auto x = X.col(cols[j]);
        EXPECT_LE((x - r).norm(), kTol * r.norm()) << name << " column " << cols[j];
        for (int i = 0; i < n; ++i) {
          if (std::abs(r(i)) < tiny) {
            ASSERT_LT(std::abs(x(i)), 1e-300) << name << " entry (" << i << ", " << cols[j] << ")";
          }
        }
      }
    }
  }
}

// The joint blocks' inverse D⁻¹ (SpdFactor: every size above 1 by L Δ Lᵀ)
// on SPD matrices with condition numbers up to 1e12, against Eigen's LDLᵀ solve in long double:
// relative error ≤ 50·κ·ε (backward stable; an adjugate formula's error grows as κ²). Each size
// as the articulated pass compiles it (3 and 6 fixed) and at run time (Eigen::Dynamic).
TEST(ImpulseSweeps, SmallSpdInverseIsStable) {
  Rng rng(77);
  for (int k : {2, 3, 6}) {
    for (int trial = 0; trial < 200; ++trial) {
      // D = Q diag(σ) Qᵀ with σ spread over 10^0 … 10^(trial mod 13).
      const Eigen::MatrixXd Q =
          Eigen::MatrixXd::NullaryExpr(k, k, [&] { return rng.uniform(-1, 1); })
              .householderQr()
              .householderQ();
      Eigen::VectorXd sigma(k);
      const double decades = trial % 13;
      for (int i = 0; i < k; ++i) sigma(i) = std::pow(10.0, -decades * i / std::max(1, k - 1));
      const Eigen::MatrixXd D = Q * sigma.asDiagonal() * Q.transpose();
      const double kappa = sigma.maxCoeff() / sigma.minCoeff();
      using MatL = Eigen::Matrix<long double, Eigen::Dynamic, Eigen::Dynamic>;
      const MatL ref = D.cast<long double>().ldlt().solve(MatL::Identity(k, k));
      Eigen::MatrixXd fixed(k, k), dynamic(k, k);
      if (k == 3) SpdFactor<double, 3>(D).inverse(fixed);
      if (k == 6) SpdFactor<double, 6>(D).inverse(fixed);
      SpdFactor<double, Eigen::Dynamic>(D, k).inverse(dynamic);
      for (const Eigen::MatrixXd* Dinv : {&fixed, &dynamic}) {
        if (k == 2 && Dinv == &fixed) continue;
        const double err =
            static_cast<double>((Dinv->cast<long double>() - ref).norm() / ref.norm());
        EXPECT_LE(err, 50 * kappa * std::numeric_limits<double>::epsilon())
            << "k = " << k << (Dinv == &fixed ? " fixed" : " dynamic") << ", kappa = " << kappa;
        EXPECT_TRUE(*Dinv == Dinv->transpose())
            << "k = " << k << (Dinv == &fixed ? " fixed" : " dynamic");
      }
    }
  }
}

}  // namespace
}  // namespace minv
