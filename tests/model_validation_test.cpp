// Model::create's checks that a user's own file reaches (core/model.hpp): unique names, the
// physical range, an axis given with huge entries, and numbers in messages that say what they
// are (not "%f", which turns 1e-9 into 0.000000).
#include <gtest/gtest.h>

#include <Eigen/Cholesky>
#include <limits>

#include "core/crba.hpp"
#include "core/model.hpp"
#include "generators/model_io.hpp"

namespace minv {
namespace {

// Three bodies in a chain, revolute about z, unit placements along x.
struct Chain {
  std::vector<int> parent{-1, 0, 1};
  std::vector<Joint> joints{3};
  std::vector<Body> bodies{3};
  Chain() {
    for (int i = 0; i < 3; ++i) {
      joints[i].name = "j" + std::to_string(i);
      joints[i].placement.p = Eigen::Vector3d(i > 0 ? 1.0 : 0.0, 0, 0);
      bodies[i].name = "b" + std::to_string(i);
    }
  }
  std::string error() const {
    try {
      Model::create(parent, joints, bodies);
    } catch (const ModelError& e) {
      return e.what();
    }
    return "";
  }
};

TEST(ModelValidation, FormatNumberRoundTrips) {
  EXPECT_EQ(formatNumber(1e-9), "1e-09");
  EXPECT_EQ(formatNumber(0.5), "0.5");
  EXPECT_EQ(formatNumber(0.1 + 0.2), "0.30000000000000004");
  EXPECT_EQ(formatNumber(std::numeric_limits<double>::quiet_NaN()), "nan");
  EXPECT_EQ(formatNumber(-std::numeric_limits<double>::infinity()), "-inf");
}

TEST(ModelValidation, DuplicateNamesNameBothPlaces) {
  Chain c;
  c.joints[2].name = "j0";
  EXPECT_NE(c.error().find("joint name 'j0' is already used by the joint of body 0"),
            std::string::npos)
      << c.error();
  EXPECT_NE(c.error().find("body 2"), std::string::npos) << c.error();
  Chain d;
  d.bodies[1].name = "b0";
  EXPECT_NE(d.error().find("body 1 ('b0'): the body name 'b0' is already used by body 0"),
            std::string::npos)
      << d.error();
  // Empty names are allowed, and numbered in the DOF names.
  Chain e;
  e.joints[0].name = e.joints[1].name = "";
  EXPECT_EQ(e.error(), "");
  // Nor may two coordinates' derived names clash: an unnamed joint 1 is "joint1".
  Chain f;
  f.joints[1].name = "";
  f.joints[2].name = "joint1";
  EXPECT_NE(f.error().find("two coordinates of q are both named 'joint1' (1 and 2)"),
            std::string::npos)
      << f.error();
  // A spherical joint "a" names its quaternion a_qw … a_qz, and its DOFs a_wx … a_wz.
  Chain g;
  g.joints[0].type = JointType::Spherical;
  g.joints[0].name = "a";
  g.joints[1].name = "a_qz";
  EXPECT_NE(g.error().find("two coordinates of q are both named 'a_qz' (3 and 4)"),
            std::string::npos)
      << g.error();
  g.joints[1].name = "a_wy";
  EXPECT_NE(g.error().find("two coordinates of v (DOF) are both named 'a_wy' (1 and 3)"),
            std::string::npos)
      << g.error();
}

// A revolute angle beyond ±kMaxAngle is refused (DART aborted the process from 1e160 rad on);
// one just inside is a configuration.
TEST(ModelValidation, RevoluteAnglesAreBounded) {
  Chain c;
  const Model m = Model::create(c.parent, c.joints, c.bodies);
  Eigen::VectorXd q = m.neutral();
  q(1) = kMaxAngle;
  EXPECT_NO_THROW(m.checkConfiguration(q));
  q(1) = -1e300;
  try {
    m.checkConfiguration(q);
    ADD_FAILURE() << "no error";
  } catch (const ModelError& e) {
    EXPECT_NE(std::string(e.what()).find("q[1] = -1e+300 rad is beyond ±1e+06 rad"),
              std::string::npos)
        << e.what();
  }
}

TEST(ModelValidation, NumbersInMessagesKeepTheirValue) {
  Chain c;
  c.bodies[1].mass = -1e-9;
  EXPECT_NE(c.error().find("got -1e-09"), std::string::npos) << c.error();
  c.bodies[1].mass = std::numeric_limits<double>::quiet_NaN();
  EXPECT_NE(c.error().find("got nan"), std::string::npos) << c.error();
}

TEST(ModelValidation, PhysicalRangeIsCheckedAtLoad) {
  Chain c;
  c.bodies[2].mass = 1e308;
  EXPECT_NE(c.error().find("body 2 ('b2'): mass 1e+308 is beyond 1e+30"), std::string::npos)
      << c.error();
  Chain d;
  d.bodies[0].com = Eigen::Vector3d(0, 2e4, 0);
  EXPECT_NE(d.error().find("centre of mass coordinate 20000 is beyond ±10000"), std::string::npos)
      << d.error();
  Chain e;
  e.bodies[1].inertia *= 1e40;
  EXPECT_NE(e.error().find("rotational inertia entry"), std::string::npos) << e.error();
  Chain f;
  f.joints[1].placement.p = Eigen::Vector3d(-1e8, 0, 0);
  EXPECT_NE(f.error().find("joint of body 1 ('j1'): placement translation -1e+08 is beyond ±10000"),
            std::string::npos)
      << f.error();
}

// A body that is a point mass to double precision (its smallest principal moment below
// kMinInertiaRatio · m·r², r its centre of mass's distance from the root body, bounded by the
// placements' lengths and |c|) is refused, naming the body and the numbers; just above the ratio
// it loads and its M factorises. The fuzzers' cases: 1e30 kg, Ī ≈ 4e-5, |c| = 5 cm (JSON); a
// 1e7 kg body with Ī = 1e-3 on its joint, which stands 1e4 m from the root (URDF: M's diagonal
// came out -1.2 with the old rule, which measured |c| only).
TEST(ModelValidation, PointMassBodyIsRefused) {
  Chain c;  // body 2's joint stands 2 from the root body's origin
  c.bodies[2].mass = 1e30;
  c.bodies[2].com = Eigen::Vector3d(0.05, 0, 0);
  c.bodies[2].inertia = Eigen::Vector3d(4e-5, 4e-5, 4e-5).asDiagonal();
  EXPECT_NE(
      c.error().find("body 2 ('b2'): rotational inertia is negligible against m·r², r = 2.05 "),
      std::string::npos)
      << c.error();
  // (Bent at joint 2: a straight chain of revolute joints about z cannot move its tip body
  // along the chain, and with 1e30 kg there against 1 kg, M is singular to double precision
  // whatever the tip's inertia.)
  const double r2 = 2.05 * 2.05;
  for (const double times : {0.5, 2.0}) {
    Chain d;
    d.joints[2].placement.p = Eigen::Vector3d(0, 1, 0);
    d.bodies[2].mass = 1e30;
    d.bodies[2].com = Eigen::Vector3d(0.05, 0, 0);
    d.bodies[2].inertia = Eigen::Matrix3d::Identity() * (times * kMinInertiaRatio * 1e30 * r2);
    if (times < 1) {
      EXPECT_NE(d.error().find("negligible against m·r²"), std::string::npos) << d.error();
      continue;
    }
    ASSERT_EQ(d.error(), "");
    const Model md = Model::create(d.parent, d.joints, d.bodies);
    EXPECT_EQ(Eigen::LLT<Eigen::MatrixXd>(massMatrix(md, md.neutral())).info(), Eigen::Success);
  }
  // The URDF fuzzer's case: the centre of mass on the joint (|c| = 0), the joint far off.
  Chain far;
  far.joints[2].placement.p = Eigen::Vector3d(7000, 7000, 0);
  far.bodies[2].mass = 1e7;
  far.bodies[2].inertia = Eigen::Matrix3d::Identity() * 1e-3;
  EXPECT_NE(far.error().find("body 2 ('b2'): rotational inertia is negligible against m·r², r = "
                             "9900.49"),
            std::string::npos)
      << far.error();
  far.bodies[2].inertia *= 1e4;  // 10 > 1e-14 · 1e7 · 9900.5² ≈ 9.8
  ASSERT_EQ(far.error(), "");
  const Model mf = Model::create(far.parent, far.joints, far.bodies);
  EXPECT_EQ(Eigen::LLT<Eigen::MatrixXd>(massMatrix(mf, mf.neutral())).info(), Eigen::Success);
  Chain e;
  e.bodies[1].inertia *= 1e-9;  // small, but far above the ratio (m = 1, r² = 1.5² = 2.25)
  e.bodies[1].com = Eigen::Vector3d(0.5, 0, 0);
  EXPECT_EQ(e.error(), "");
}

// A prismatic joint carries its subtree away from the root: a configuration that carries a body
// to where it is a point mass is refused; one short of it is accepted and M factorises.
TEST(ModelValidation, PrismaticDisplacementMakingAPointMassIsRefused) {
  Chain c;
  c.joints[1].type = JointType::Prismatic;
  c.joints[1].axis = Eigen::Vector3d::UnitX();
  c.bodies[2].inertia = Eigen::Matrix3d::Identity() * 1e-7;  // m = 1: r ≤ √(1e-7 / 1e-14) ≈ 3162
  ASSERT_EQ(c.error(), "");
  const Model m = Model::create(c.parent, c.joints, c.bodies);
  Eigen::VectorXd q = m.neutral();
  q(1) = -3000;  // r = 2 + 3000
  EXPECT_NO_THROW(m.checkConfiguration(q));
  EXPECT_EQ(Eigen::LLT<Eigen::MatrixXd>(massMatrix(m, q)).info(), Eigen::Success);
  q(1) = 5000;
  try {
    m.checkConfiguration(q);
    ADD_FAILURE() << "a displacement of 5000 was accepted";
  } catch (const ModelError& e) {
    EXPECT_NE(std::string(e.what()).find("body 2 ('b2'): rotational inertia is negligible against "
                                         "m·r², r = 5002 "),
              std::string::npos)
        << e.what();
    EXPECT_NE(std::string(e.what()).find("prismatic displacements"), std::string::npos);
  }
  // The body's own displacement counts; the root's does not (the solvers' origin moves with it).
  Chain own;
  own.joints[0].type = own.joints[2].type = JointType::Prismatic;
  own.bodies[2].inertia = Eigen::Matrix3d::Identity() * 1e-7;
  const Model mo = Model::create(own.parent, own.joints, own.bodies);
  Eigen::VectorXd qo = mo.neutral();
  qo(0) = kMaxLength;
  qo(2) = 3000;
  EXPECT_NO_THROW(mo.checkConfiguration(qo));
  qo(2) = -5000;
  EXPECT_THROW(mo.checkConfiguration(qo), ModelError);
}

// Names must be valid UTF-8 (they travel as UTF-8 through JSON and HDF5): a stray byte, an
// overlong form and a surrogate are refused; accents and Greek letters are fine.
TEST(ModelValidation, NamesAreUtf8) {
  for (const char* bad : {"a\xff", "a\xc0\x80", "\xed\xa0\x80", "\xe2\x82"}) {
    Chain c;
    c.bodies[1].name = bad;
    EXPECT_NE(c.error().find("not valid UTF-8"), std::string::npos) << c.error();
  }
  // nor a NUL (a URDF written from the model cut the name there and did not read back)
  Chain nul;
  nul.joints[1].name = std::string("a\0b", 3);
  EXPECT_NE(nul.error().find("contains a NUL"), std::string::npos) << nul.error();
  Chain ok;
  ok.bodies[1].name = "bras_épaule";
  ok.joints[2].name = "θ₂";
  EXPECT_EQ(ok.error(), "");
}

// Configurations: lengths beyond kMaxLength and quaternion entries whose norm would overflow.
TEST(ModelValidation, ConfigurationRanges) {
  Chain c;
  c.joints[0].type = JointType::Floating;
  c.joints[1].type = JointType::Prismatic;
  c.joints[2].type = JointType::Spherical;
  const Model m = Model::create(c.parent, c.joints, c.bodies);
  auto error = [&](const Eigen::VectorXd& q) {
    try {
      m.checkConfiguration(q);
    } catch (const ModelError& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  Eigen::VectorXd q = m.neutral();
  EXPECT_EQ(error(q), "");
  q(0) = 1e5;  // base x
  EXPECT_NE(error(q).find("q[0] = 1e+05 is beyond ±10000"), std::string::npos) << error(q);
  q = m.neutral();
  q(7) = -2e4;  // the prismatic joint
  EXPECT_NE(error(q).find("q[7] = -20000"), std::string::npos) << error(q);
  q = m.neutral();
  q.segment<4>(8) << 1e155, 1e155, 0, 0;  // a 90° turn whose norm would overflow
  EXPECT_NE(error(q).find("beyond ±1e100"), std::string::npos) << error(q);
}

// M of a multi-DOF joint is exactly symmetric (its diagonal block Sᵀ(Ic S) is mirrored).
TEST(ModelValidation, MassMatrixExactlySymmetric) {
  Chain c;
  c.joints[0].type = JointType::Floating;
  c.joints[2].type = JointType::Spherical;
  c.joints[0].placement.p = Eigen::Vector3d(5e3, -7e3, 1e3);
  const Model m = Model::create(c.parent, c.joints, c.bodies);
  Eigen::VectorXd q = m.neutral();
  q.segment<4>(3) << 0.3, 0.5, -0.2, 0.7;
  q.segment<4>(8) << 0.1, -0.4, 0.8, 0.3;
  const Eigen::MatrixXd M = massMatrix(m, q);
  EXPECT_EQ(M, M.transpose());
  EXPECT_EQ(M.llt().info(), Eigen::Success);
}

// An axis with huge (or tiny) entries names a direction: it is normalised without overflow and
// gives the same M as the unit axis.
TEST(ModelValidation, ExtremeAxisIsItsDirection) {
  Chain a, b;
  a.joints[1].axis = Eigen::Vector3d(1e308, 1e308, 0);
  b.joints[1].axis = Eigen::Vector3d(1, 1, 0);
  const Model ma = Model::create(a.parent, a.joints, a.bodies);
  const Model mb = Model::create(b.parent, b.joints, b.bodies);
  EXPECT_TRUE(ma.joint(1).axis.isApprox(mb.joint(1).axis, 1e-15));
  const Eigen::VectorXd q = Eigen::Vector3d(0.3, -0.4, 0.5);
  EXPECT_TRUE(massMatrix(ma, q).allFinite());
  EXPECT_LT((massMatrix(ma, q) - massMatrix(mb, q)).norm(), 1e-14);
  Chain t;
  t.joints[1].axis = Eigen::Vector3d(1e-200, 0, 0);
  EXPECT_NE(t.error().find("joint axis is zero"), std::string::npos);
}

// A URDF mass of nan names the value it read.
TEST(ModelValidation, UrdfNanMassIsNamed) {
  const std::string urdf = R"(<robot name="r"><link name="a"/>
    <link name="b"><inertial><mass value="nan"/>
      <inertia ixx="1" iyy="1" izz="1" ixy="0" ixz="0" iyz="0"/></inertial></link>
    <joint name="j" type="revolute"><parent link="a"/><child link="b"/><axis xyz="0 0 1"/>
      <limit lower="-1" upper="1" effort="1" velocity="1"/></joint></robot>)";
  try {
    readUrdf(urdf, "r.urdf", false);
    FAIL() << "accepted a nan mass";
  } catch (const ModelError& e) {
    EXPECT_NE(std::string(e.what()).find("'nan' is not a finite number"), std::string::npos)
        << e.what();
    EXPECT_NE(std::string(e.what()).find("link 'b'"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace minv
