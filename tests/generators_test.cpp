// Tests of generators/random_tree: the branched-tree rule (at most two children, parents
// before children, expected depth ≈ n/2), determinism, layout, valid bodies and a
// well-conditioned mass matrix for long chains.
#include <gtest/gtest.h>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <bit>
#include <cmath>

#include "core/crba.hpp"
#include "generators/random_tree.hpp"

namespace minv {
namespace {

bool sameJoint(const Joint& a, const Joint& b) {
  return a.name == b.name && a.type == b.type && a.axis == b.axis &&
         a.placement.R == b.placement.R && a.placement.p == b.placement.p;
}

bool sameBody(const Body& a, const Body& b) {
  return a.name == b.name && a.mass == b.mass && a.com == b.com && a.inertia == b.inertia;
}

bool sameModel(const Model& a, const Model& b) {
  if (a.parents() != b.parents()) return false;
  for (int i = 0; i < a.nb(); ++i)
    if (!sameJoint(a.joint(i), b.joint(i)) || !sameBody(a.body(i), b.body(i))) return false;
  return true;
}

TEST(GeneratorsTest, NamesRoundTripAndUnknownNamesThrow) {
  for (Topology t : {Topology::Serial, Topology::Branched})
    EXPECT_EQ(topologyFromName(topologyName(t)), t);
  for (JointSet s : {JointSet::Revolute, JointSet::Mixed})
    EXPECT_EQ(jointSetFromName(jointSetName(s)), s);
  EXPECT_THROW(topologyFromName("tree"), ModelError);
  EXPECT_THROW(jointSetFromName("Revolute"), ModelError);
}

TEST(GeneratorsTest, RngRangesAndBelowIsUnbiased) {
  Rng rng(42);
  std::vector<int> counts(7, 0);
  for (int k = 0; k < 70000; ++k) {
    const double u = rng.uniform(), v = rng.uniform(-2, 3);
    ASSERT_TRUE(u >= 0 && u < 1);
    ASSERT_TRUE(v >= -2 && v < 3);
    ++counts[rng.below(7)];
  }
  for (int c : counts) EXPECT_NEAR(c, 10000, 500);
  for (int k = 0; k < 100; ++k) {
    EXPECT_NEAR(rng.unitVector().norm(), 1, 1e-15);
    EXPECT_NEAR(rng.unitQuaternion().norm(), 1, 1e-15);
    const Eigen::Matrix3d R = rng.rotation();
    EXPECT_LT((R.transpose() * R - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff(), 4e-15);
    EXPECT_NEAR(R.determinant(), 1, 4e-15);
  }
  EXPECT_THROW(rng.below(0), ModelError);
}

// Golden values: a change here means runs are no longer reproducible across versions.
TEST(GeneratorsTest, GoldenValuesForSeed7) {
  Rng rng(7);
  EXPECT_EQ(std::bit_cast<std::uint64_t>(rng.uniform()), 0x3fe823eca63d6cdbULL);
  Rng topo(7);
  const std::vector<int> expected = {-1, 0, 1, 1, 2, 2, 0, 4, 7, 7, 8, 10};
  EXPECT_EQ(randomParents(Topology::Branched, 12, topo), expected);
  const Model m = randomTree({Topology::Branched, 12, 7, false, JointSet::Revolute});
  EXPECT_EQ(std::bit_cast<std::uint64_t>(m.body(5).mass), 0x3feb282f06e7c6dfULL);
  EXPECT_EQ(std::bit_cast<std::uint64_t>(m.body(5).inertia(0, 1)), 0xbf5496903e7e0689ULL);
  EXPECT_EQ(std::bit_cast<std::uint64_t>(randomConfiguration(m, 3)(4)), 0x3fd80b95a539f2a5ULL);
}

TEST(GeneratorsTest, SerialParentsFormAChain) {
  Rng rng(1);
  const std::vector<int> p = randomParents(Topology::Serial, 6, rng);
  EXPECT_EQ(p, (std::vector<int>{-1, 0, 1, 2, 3, 4}));
  EXPECT_EQ(randomTree({Topology::Serial, 40, 3}).maxDepth(), 40);
}

TEST(GeneratorsTest, BranchedTreesHaveAtMostTwoChildrenAndParentsFirst) {
  for (int n : {1, 2, 3, 5, 17, 200})
    for (std::uint64_t seed = 1; seed <= 50; ++seed) {
      Rng rng(seed);
      const std::vector<int> p = randomParents(Topology::Branched, n, rng);
      ASSERT_EQ(static_cast<int>(p.size()), n);
      EXPECT_EQ(p[0], -1);
      std::vector<int> children(n, 0);
      for (int i = 1; i < n; ++i) {
        ASSERT_TRUE(p[i] >= 0 && p[i] < i) << "n " << n << " seed " << seed << " link " << i;
        ++children[p[i]];
      }
      EXPECT_LE(*std::max_element(children.begin(), children.end()), 2);
    }
}

TEST(GeneratorsTest, BranchedExpectedDepthIsAboutHalf) {
  const int n = 200, seeds = 200;
  double sum = 0;
  for (int s = 1; s <= seeds; ++s)
    sum += randomTree({Topology::Branched, n, std::uint64_t(s)}).maxDepth();
  const double mean = sum / seeds;
  RecordProperty("mean_max_depth_n200", std::to_string(mean));
  std::printf("branched n = %d: mean max depth over %d seeds = %.2f (%.3f n)\n", n, seeds, mean,
              mean / n);
  EXPECT_GT(mean, 0.4 * n);
  EXPECT_LT(mean, 0.6 * n);
}

TEST(GeneratorsTest, SameSeedIsIdenticalAndOtherSeedsDiffer) {
  for (Topology t : {Topology::Serial, Topology::Branched})
    for (JointSet s : {JointSet::Revolute, JointSet::Mixed})
      for (bool fb : {false, true}) {
        const TreeOptions o{t, 30, 11, fb, s};
        const Model a = randomTree(o), b = randomTree(o);
        EXPECT_TRUE(sameModel(a, b));
        EXPECT_EQ(randomConfiguration(a, 5), randomConfiguration(b, 5));
        EXPECT_NE(randomConfiguration(a, 5), randomConfiguration(a, 6));
        TreeOptions other = o;
        other.seed = 12;
        const Model c = randomTree(other);
        EXPECT_NE(a.body(3).mass, c.body(3).mass);
        if (t == Topology::Branched) {
          EXPECT_NE(a.parents(), c.parents());
        }
      }
}

TEST(GeneratorsTest, FloatingBaseAddsABaseBodyAboveTheSameLinks) {
  const Model fixed = randomTree({Topology::Branched, 25, 4, false});
  const Model floating = randomTree({Topology::Branched, 25, 4, true});
  ASSERT_EQ(floating.nb(), 26);
  EXPECT_EQ(floating.nv(), 25 + 6);
  EXPECT_EQ(floating.nq(), 25 + 7);
  EXPECT_TRUE(floating.floatingBase());
  EXPECT_EQ(floating.joint(0).name, "base");
  EXPECT_EQ(floating.body(0).name, "base");
  EXPECT_EQ(floating.parent(1), 0);
  for (int k = 0; k < 25; ++k) {
    EXPECT_EQ(floating.parent(k + 1), fixed.parent(k) + 1);
    EXPECT_TRUE(sameJoint(floating.joint(k + 1), fixed.joint(k)));
    EXPECT_TRUE(sameBody(floating.body(k + 1), fixed.body(k)));
  }
  EXPECT_EQ(fixed.joint(7).name, "j7");
  EXPECT_EQ(fixed.body(7).name, "b7");
}

TEST(GeneratorsTest, BodiesAndPlacementsAreInTheirRanges) {
  const Model m = randomTree({Topology::Serial, 300, 9, true, JointSet::Mixed});
  for (int i = 1; i < m.nb(); ++i) {
    const Body& b = m.body(i);
    EXPECT_TRUE(b.mass >= 0.5 && b.mass <= 2);
    EXPECT_LE(b.com.cwiseAbs().maxCoeff(), 0.1);
    const double len = m.joint(i).placement.p.norm();
    EXPECT_TRUE(len >= 0.3 - 1e-15 && len <= 0.5 + 1e-15);
    EXPECT_EQ(b.inertia, b.inertia.transpose());
    const Eigen::Vector3d e =
        Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(b.inertia).eigenvalues();
    EXPECT_GT(e(0) + e(1), e(2));
  }
}

TEST(GeneratorsTest, MixedJointSetHasTheDocumentedShares) {
  const Model m = randomTree({Topology::Branched, 5000, 2, false, JointSet::Mixed});
  int count[4] = {0, 0, 0, 0};
  for (int i = 0; i < m.nb(); ++i) ++count[static_cast<int>(m.joint(i).type)];
  EXPECT_NEAR(count[0] / 5000.0, 0.6, 0.03);
  EXPECT_NEAR(count[1] / 5000.0, 0.2, 0.03);
  EXPECT_NEAR(count[2] / 5000.0, 0.2, 0.03);
  const Eigen::VectorXd q = randomConfiguration(m, 8);
  EXPECT_NO_THROW(m.checkConfiguration(q));
  for (int i = 0; i < m.nb(); ++i) {
    const int o = m.qIdx(i);
    switch (m.joint(i).type) {
      case JointType::Spherical:
        EXPECT_NEAR(q.segment<4>(o).norm(), 1, 1e-15);
        break;
      case JointType::Prismatic:
        EXPECT_LE(std::abs(q(o)), 0.5);
        break;
      case JointType::Revolute:
        EXPECT_LE(std::abs(q(o)), M_PI);
        break;
      case JointType::Floating:
        ADD_FAILURE() << "floating joint in a fixed-base tree";
    }
  }
}

TEST(GeneratorsTest, FloatingConfigurationHasPositionAndUnitQuaternion) {
  const Model m = randomTree({Topology::Serial, 3, 5, true});
  const Eigen::VectorXd q = randomConfiguration(m, 1);
  ASSERT_EQ(q.size(), 3 + 7);
  EXPECT_LE(q.head<3>().cwiseAbs().maxCoeff(), 1);
  EXPECT_NEAR(q.segment<4>(3).norm(), 1, 1e-15);
}

TEST(GeneratorsTest, RejectsNonPositiveN) {
  for (int n : {0, -3}) {
    try {
      randomTree({Topology::Serial, n});
      FAIL() << "no exception for n = " << n;
    } catch (const ModelError& e) {
      EXPECT_NE(std::string(e.what()).find("n must be at least 1"), std::string::npos);
    }
  }
}

TEST(GeneratorsTest, LongChainsGiveASolvableMassMatrix) {
  for (bool fb : {false, true}) {
    const Model m = randomTree({Topology::Serial, 500, 1, fb});
    const Eigen::MatrixXd M = massMatrix(m, randomConfiguration(m, 1));
    const Eigen::LLT<Eigen::MatrixXd> llt(M);
    ASSERT_EQ(llt.info(), Eigen::Success);
    const Eigen::VectorXd e = Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(M).eigenvalues();
    std::printf("serial n = 500%s: cond(M) = %.3g\n", fb ? " floating" : "",
                e.maxCoeff() / e.minCoeff());
    EXPECT_LT(e.maxCoeff() / e.minCoeff(), 1e12);
    const Eigen::VectorXd x = Eigen::VectorXd::LinSpaced(m.nv(), -1, 1);
    EXPECT_LT((M * llt.solve(M * x) - M * x).norm(), 1e-8 * (M * x).norm());
  }
}

}  // namespace
}  // namespace minv
