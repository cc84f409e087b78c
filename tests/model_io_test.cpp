// Tests of generators/model_io: JSON round trips bit for bit, URDF round trips to rounding,
// fixed-joint merging against an independent reference model, and a clear ModelError for
// every kind of bad input.
#include "generators/model_io.hpp"

#include <gtest/gtest.h>
#include <unistd.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <filesystem>
#include <fstream>
#include <functional>
#include <nlohmann/json.hpp>
#include <sstream>

#include "core/crba.hpp"
#include "generators/random_tree.hpp"
#include "tests/model_error.hpp"

namespace minv {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

// Every field equal within tol (0: bit for bit).
void expectSameModel(const Model& a, const Model& b, double tol) {
  ASSERT_EQ(a.parents(), b.parents());
  auto near = [tol](const auto& x, const auto& y) {
    return tol == 0 ? x == y : (x - y).cwiseAbs().maxCoeff() <= tol;
  };
  for (int i = 0; i < a.nb(); ++i) {
    const Joint &ja = a.joint(i), &jb = b.joint(i);
    const Body &ba = a.body(i), &bb = b.body(i);
    EXPECT_EQ(ja.name, jb.name) << i;
    EXPECT_EQ(ja.type, jb.type) << i;
    if (jointNv(ja.type) == 1) {
      EXPECT_TRUE(near(ja.axis, jb.axis)) << i;
    }
    EXPECT_TRUE(near(ja.placement.R, jb.placement.R)) << i;
    EXPECT_TRUE(near(ja.placement.p, jb.placement.p)) << i;
    EXPECT_EQ(ba.name, bb.name) << i;
    EXPECT_TRUE(tol == 0 ? ba.mass == bb.mass : std::abs(ba.mass - bb.mass) <= tol) << i;
    EXPECT_TRUE(near(ba.com, bb.com)) << i;
    EXPECT_TRUE(near(ba.inertia, bb.inertia)) << i;
  }
}

void expectSameMassMatrix(const Model& a, const Model& b, const Eigen::VectorXd& q, double rel) {
  const Eigen::MatrixXd Ma = massMatrix(a, q), Mb = massMatrix(b, q);
  ASSERT_EQ(Ma.rows(), Mb.rows());
  EXPECT_LE((Ma - Mb).cwiseAbs().maxCoeff(), rel * Ma.cwiseAbs().maxCoeff());
}

std::string toJson(const Model& m) {
  std::ostringstream s;
  writeJson(m, s, "test");
  return s.str();
}

Model fromJson(const std::string& text) {
  std::istringstream in(text);
  return readJson(in, "model.json");
}

std::string toUrdf(const Model& m) {
  std::ostringstream s;
  writeUrdf(m, s, "test");
  return s.str();
}

Joint joint(const std::string& name, JointType type = JointType::Revolute) {
  Joint j;
  j.name = name;
  j.type = type;
  return j;
}

Body body(const std::string& name) {
  Body b;
  b.name = name;
  return b;
}

// A scratch directory removed at the end of the test.
struct TempDir {
  fs::path path =
      fs::temp_directory_path() / ("minv_model_io_" + std::to_string(::getpid()) + "_" +
                                   ::testing::UnitTest::GetInstance()->current_test_info()->name());
  TempDir() { fs::create_directories(path); }
  ~TempDir() { fs::remove_all(path); }
  std::string file(const std::string& name, const std::string& text = "") const {
    const fs::path p = path / name;
    if (!text.empty()) std::ofstream(p) << text;
    return p.string();
  }
};

// Random revolute trees in every layout the round trips cover.
std::vector<Model> sampleModels(JointSet joints) {
  std::vector<Model> models;
  for (Topology t : {Topology::Serial, Topology::Branched})
    for (bool fb : {false, true})
      for (int n : {1, 7, 32})
        models.push_back(randomTree({t, n, std::uint64_t(n + 3), fb, joints}));
  return models;
}

TEST(ModelIoTest, JsonRoundTripIsBitExact) {
  for (JointSet s : {JointSet::Revolute, JointSet::Mixed})
    for (const Model& m : sampleModels(s)) {
      const std::string text = toJson(m);
      const Model back = fromJson(text);
      expectSameModel(m, back, 0);
      expectSameMassMatrix(m, back, randomConfiguration(m, 2), 0);
      // The text itself holds every axis bit for bit.
      const json doc = json::parse(text);
      for (int i = 0; i < m.nb(); ++i) {
        if (jointNv(m.joint(i).type) != 1) continue;
        for (int k = 0; k < 3; ++k)
          EXPECT_EQ(doc["bodies"][i]["joint"]["axis"][k].get<double>(), m.joint(i).axis(k));
      }
    }
}

TEST(ModelIoTest, JsonFormatIsAsDocumented) {
  const Model m = randomTree({Topology::Serial, 2, 1});
  const json doc = json::parse(toJson(m));
  EXPECT_EQ(doc["format"], "minv-model");
  EXPECT_EQ(doc["version"], 1);
  EXPECT_EQ(doc["name"], "test");
  const json& b = doc["bodies"][1];
  EXPECT_EQ(b["name"], "b1");
  EXPECT_EQ(b["parent"], 0);
  EXPECT_EQ(b["joint"]["type"], "revolute");
  EXPECT_EQ(b["joint"]["placement"]["rotation"][1][2].get<double>(), m.joint(1).placement.R(1, 2));
  EXPECT_EQ(b["inertia"][0][2].get<double>(), m.body(1).inertia(0, 2));
  // A hand-written model with only the required keys reads.
  const Model h = fromJson(R"({"format": "minv-model", "version": 1, "bodies": [
    {"name": "a", "parent": -1, "joint": {"name": "f", "type": "floating", "placement":
      {"rotation": [[1, 0, 0], [0, 1, 0], [0, 0, 1]], "translation": [0, 0, 0]}},
     "mass": 2, "com": [0, 0, 0], "inertia": [[1, 0, 0], [0, 1, 0], [0, 0, 1]]},
    {"name": "b", "parent": 0, "joint": {"name": "s", "type": "spherical", "placement":
      {"rotation": [[1, 0, 0], [0, 1, 0], [0, 0, 1]], "translation": [1, 0, 0]}},
     "mass": 1, "com": [0.5, 0, 0], "inertia": [[1, 0, 0], [0, 1, 0], [0, 0, 1.5]]}]})");
  EXPECT_EQ(h.nv(), 9);
  EXPECT_TRUE(h.floatingBase());
}

TEST(ModelIoTest, UrdfRoundTripMatchesFieldsAndMassMatrix) {
  for (const Model& m : sampleModels(JointSet::Revolute)) {
    const Model back = readUrdf(toUrdf(m), "test.urdf", m.floatingBase());
    expectSameModel(m, back, 1e-12);
    for (std::uint64_t s : {1, 2}) expectSameMassMatrix(m, back, randomConfiguration(m, s), 1e-10);
  }
}

TEST(ModelIoTest, UrdfRoundTripWithPrismaticJoints) {
  // Mixed joints with the spherical ones turned prismatic.
  const Model mixed = randomTree({Topology::Branched, 40, 6, false, JointSet::Mixed});
  std::vector<Joint> joints;
  std::vector<Body> bodies;
  for (int i = 0; i < mixed.nb(); ++i) {
    joints.push_back(mixed.joint(i));
    bodies.push_back(mixed.body(i));
    if (joints.back().type == JointType::Spherical) joints.back().type = JointType::Prismatic;
  }
  const Model m = Model::create(mixed.parents(), joints, bodies);
  const Model back = readUrdf(toUrdf(m), "test.urdf", false);
  expectSameModel(m, back, 1e-12);
  expectSameMassMatrix(m, back, randomConfiguration(m, 3), 1e-10);
}

TEST(ModelIoTest, RpyConversionIsAccurateNearGimbalLock) {
  // Placements with pitch ±π/2 (and nearly) survive the rpy round trip.
  for (double pitch : {M_PI / 2, -M_PI / 2, M_PI / 2 - 1e-9, 0.0, M_PI})
    for (double yaw : {0.3, -2.0}) {
      Joint j = joint("j");
      j.axis = Eigen::Vector3d::UnitX();
      j.placement.R = (Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()) *
                       Eigen::AngleAxisd(pitch, Eigen::Vector3d::UnitY()) *
                       Eigen::AngleAxisd(0.7, Eigen::Vector3d::UnitX()))
                          .toRotationMatrix();
      const Model m = Model::create({-1}, {j}, {body("b")});
      const Model back = readUrdf(toUrdf(m), "t.urdf", false);
      EXPECT_LT((back.joint(0).placement.R - j.placement.R).cwiseAbs().maxCoeff(), 1e-14)
          << pitch << " " << yaw;
    }
}

TEST(ModelIoTest, SaveAndLoadFilesByExtension) {
  TempDir dir;
  const Model m = randomTree({Topology::Branched, 20, 8, true});
  for (const char* name : {"m.json", "m.urdf", "M.JSON"}) {
    const std::string path = dir.file(name);
    saveModel(m, path);
    EXPECT_FALSE(fs::exists(path + ".tmp"));
    const Model back = loadModel(path, true);
    expectSameModel(m, back, std::string(name) == "m.urdf" ? 1e-12 : 0);
  }
  // A model URDF cannot hold leaves no file behind.
  const Model sph = randomTree({Topology::Serial, 20, 8, false, JointSet::Mixed});
  const std::string bad = dir.file("s.urdf");
  EXPECT_ERROR(saveModel(sph, bad), "spherical");
  EXPECT_FALSE(fs::exists(bad));
  EXPECT_FALSE(fs::exists(bad + ".tmp"));
  EXPECT_ERROR(saveModel(m, dir.file("m.txt")), "extension");
  EXPECT_ERROR(saveModel(m, (dir.path / "no/such/dir/m.json").string()), "cannot write");
}

TEST(ModelIoTest, WithFloatingBaseFreesTheRoot) {
  const Model fixed = randomTree({Topology::Branched, 10, 3});
  const Model fl = withFloatingBase(fixed);
  EXPECT_TRUE(fl.floatingBase());
  EXPECT_EQ(fl.nb(), fixed.nb());
  EXPECT_EQ(fl.nv(), fixed.nv() + 5);
  EXPECT_EQ(fl.joint(0).name, "base");
  for (int i = 1; i < fl.nb(); ++i) EXPECT_EQ(fl.joint(i).placement.p, fixed.joint(i).placement.p);
  expectSameModel(withFloatingBase(fl), fl, 0);
  // JSON with floating_base = true goes through it; two roots cannot get one base.
  TempDir dir;
  const std::string path = dir.file("f.json");
  saveModel(fixed, path);
  expectSameModel(loadModel(path, true), fl, 0);
  expectSameModel(loadModel(path, false), fixed, 0);
  const Model two = Model::create({-1, -1}, {joint("a"), joint("b")}, {body("x"), body("y")});
  EXPECT_ERROR(withFloatingBase(two), "2 root bodies");
}

// A URDF with fixed joints mid-chain, a massless sensor frame and mass fixed to the world.
const char* kMergeUrdf = R"(<?xml version="1.0"?>
<robot name="merge">
  <link name="world"/>
  <link name="stand"><inertial><mass value="5"/>
    <inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/></inertial></link>
  <joint name="js0" type="fixed"><parent link="world"/><child link="stand"/>
    <origin xyz="0 0 -1"/></joint>
  <link name="l1"><inertial><origin xyz="0.1 0 0.05" rpy="0.3 -0.2 0.5"/><mass value="1.5"/>
    <inertia ixx="0.02" ixy="0.001" ixz="0" iyy="0.03" iyz="0.002" izz="0.04"/></inertial></link>
  <joint name="j1" type="revolute"><parent link="world"/><child link="l1"/>
    <origin xyz="0 0 0.2" rpy="0 0 0.1"/><axis xyz="0 0 1"/>
    <limit lower="-3" upper="3" effort="1" velocity="1"/></joint>
  <link name="l2"><inertial><origin xyz="0.2 0.1 -0.1" rpy="-0.4 0.3 1.1"/><mass value="0.8"/>
    <inertia ixx="0.01" ixy="0" ixz="0.002" iyy="0.015" iyz="0" izz="0.012"/></inertial></link>
  <joint name="jf" type="fixed"><parent link="l1"/><child link="l2"/>
    <origin xyz="0.4 0.1 0" rpy="0.2 0.1 -0.3"/></joint>
  <link name="l3"><inertial><origin xyz="0.15 0 0"/><mass value="1.2"/>
    <inertia ixx="0.01" ixy="0" ixz="0" iyy="0.02" iyz="0" izz="0.02"/></inertial></link>
  <joint name="j2" type="continuous"><parent link="l2"/><child link="l3"/>
    <origin xyz="0.3 0 0" rpy="0 0.4 0"/><axis xyz="0 1 0"/></joint>
  <link name="sensor"/>
  <joint name="jsensor" type="fixed"><parent link="l3"/><child link="sensor"/>
    <origin xyz="0.3 0.05 0" rpy="0.5 0 0"/></joint>
  <link name="l4"><inertial><origin xyz="0 0 0.1" rpy="0 0 0.7"/><mass value="0.6"/>
    <inertia ixx="0.004" ixy="0" ixz="0" iyy="0.005" iyz="0" izz="0.003"/></inertial></link>
  <joint name="j3" type="prismatic"><parent link="sensor"/><child link="l4"/>
    <origin xyz="0.1 0 0" rpy="0 -0.2 0"/><axis xyz="1 1 0"/>
    <limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
</robot>
)";

Pose<double> origin(double x, double y, double z, double r, double p, double yaw) {
  const Eigen::Matrix3d R = (Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()) *
                             Eigen::AngleAxisd(p, Eigen::Vector3d::UnitY()) *
                             Eigen::AngleAxisd(r, Eigen::Vector3d::UnitX()))
                                .toRotationMatrix();
  return {R, Eigen::Vector3d(x, y, z)};
}

Body inertial(const std::string& name, double m, const Pose<double>& o, double ixx, double ixy,
              double ixz, double iyy, double iyz, double izz) {
  Eigen::Matrix3d I;
  I << ixx, ixy, ixz, ixy, iyy, iyz, ixz, iyz, izz;
  return {name, m, o.p, o.R * I * o.R.transpose()};
}

TEST(ModelIoTest, UrdfFixedJointsMergeLikeARigidReference) {
  const Model merged = readUrdf(kMergeUrdf, "merge.urdf", false);
  ASSERT_EQ(merged.nb(), 3);
  EXPECT_EQ(merged.body(0).name, "l1");
  EXPECT_EQ(merged.body(1).name, "l3");
  EXPECT_EQ(merged.body(2).name, "l4");
  EXPECT_EQ(merged.joint(2).type, JointType::Prismatic);
  EXPECT_NEAR(merged.body(0).mass, 2.3, 1e-15);
  // Reference: every link its own body; each fixed joint a revolute joint held at q = 0.
  const Eigen::Vector3d z = Eigen::Vector3d::UnitZ();
  const std::vector<Joint> joints = {
      {"j1", JointType::Revolute, z, origin(0, 0, 0.2, 0, 0, 0.1)},
      {"jf", JointType::Revolute, z, origin(0.4, 0.1, 0, 0.2, 0.1, -0.3)},
      {"j2", JointType::Revolute, Eigen::Vector3d::UnitY(), origin(0.3, 0, 0, 0, 0.4, 0)},
      {"j3", JointType::Prismatic, Eigen::Vector3d(1, 1, 0),
       origin(0.3, 0.05, 0, 0.5, 0, 0) * origin(0.1, 0, 0, 0, -0.2, 0)}};
  const std::vector<Body> bodies = {
      inertial("l1", 1.5, origin(0.1, 0, 0.05, 0.3, -0.2, 0.5), 0.02, 0.001, 0, 0.03, 0.002, 0.04),
      inertial("l2", 0.8, origin(0.2, 0.1, -0.1, -0.4, 0.3, 1.1), 0.01, 0, 0.002, 0.015, 0, 0.012),
      inertial("l3", 1.2, origin(0.15, 0, 0, 0, 0, 0), 0.01, 0, 0, 0.02, 0, 0.02),
      inertial("l4", 0.6, origin(0, 0, 0.1, 0, 0, 0.7), 0.004, 0, 0, 0.005, 0, 0.003)};
  const Model ref = Model::create({-1, 0, 1, 2}, joints, bodies);
  for (std::uint64_t s = 1; s <= 3; ++s) {
    const Eigen::VectorXd q = randomConfiguration(merged, s);
    const Eigen::Vector4d qr(q(0), 0, q(1), q(2));
    const Eigen::MatrixXd Mr = massMatrix(ref, qr);
    const std::vector<int> keep = {0, 2, 3};
    Eigen::MatrixXd Mref(3, 3);
    for (int a = 0; a < 3; ++a)
      for (int b = 0; b < 3; ++b) Mref(a, b) = Mr(keep[a], keep[b]);
    const Eigen::MatrixXd M = massMatrix(merged, q);
    EXPECT_LT((M - Mref).cwiseAbs().maxCoeff(), 1e-13 * Mref.cwiseAbs().maxCoeff()) << M << "\n\n"
                                                                                    << Mref;
  }
}

TEST(ModelIoTest, UrdfFloatingBaseMakesTheRootLinkBody0) {
  // The l1 subtree with l1 as the root link: l1 and l2 merge into the floating base.
  std::string xml = kMergeUrdf;
  const Model fixed = readUrdf(xml, "merge.urdf", false);
  // The whole file: the massless world link and the stand fixed to it become the base.
  const Model all = readUrdf(xml, "merge.urdf", true);
  ASSERT_EQ(all.nb(), 4);
  EXPECT_EQ(all.body(0).name, "world");
  EXPECT_EQ(all.body(0).mass, 5);
  EXPECT_EQ(all.body(0).com, Eigen::Vector3d(0, 0, -1));
  EXPECT_EQ(all.parent(1), 0);
  // Drop world, stand and j1, js0.
  for (const char* cut : {"<link name=\"world\"/>", "<joint name=\"js0\"", "<joint name=\"j1\""}) {
    const auto a = xml.find(cut);
    const auto b = cut[1] == 'j' ? xml.find("</joint>", a) + 8 : a + std::string(cut).size();
    xml.erase(a, b - a);
  }
  const auto a = xml.find("<link name=\"stand\">");
  xml.erase(a, xml.find("</link>", a) + 7 - a);
  const Model fl = readUrdf(xml, "sub.urdf", true);
  ASSERT_EQ(fl.nb(), 3);
  EXPECT_TRUE(fl.floatingBase());
  EXPECT_EQ(fl.nv(), 8);
  EXPECT_EQ(fl.body(0).name, "l1");
  EXPECT_EQ(fl.joint(0).name, "base");
  EXPECT_EQ(fl.body(0).mass, fixed.body(0).mass);
  EXPECT_LT((fl.body(0).inertia - fixed.body(0).inertia).cwiseAbs().maxCoeff(), 1e-15);
}

// ---- bad input -------------------------------------------------------------------------

json validDoc() {
  return json::parse(toJson(randomTree({Topology::Serial, 3, 1})));
}

std::string readError(const json& doc) {
  return test::errorOf([&] { fromJson(doc.dump()); });
}

// Reading validDoc() changed by f fails with a message containing text.
void expectMutation(const std::function<void(json&)>& f, const std::string& text) {
  json d = validDoc();
  f(d);
  const std::string msg = readError(d);
  EXPECT_NE(msg.find(text), std::string::npos) << "message: '" << msg << "'";
}

TEST(ModelIoTest, BadJsonGivesClearErrors) {
  EXPECT_ERROR(fromJson("{\"format\": \"minv-model\", "), "model.json: invalid JSON at byte");
  EXPECT_ERROR(fromJson(""), "model.json: invalid JSON at byte 1");
  EXPECT_ERROR(fromJson(R"({"format": "minv-model", "version": 1, "x": NaN})"), "invalid JSON");
  json d = validDoc();
  std::string text = d.dump();
  text.replace(text.find("\"mass\":") + 7, 0, "1e999, \"m\":");
  EXPECT_ERROR(fromJson(text), "overflow parsing '1e999'");
  EXPECT_ERROR(fromJson("[1, 2]"), "model.json: expected an object, got array");

  expectMutation([](json& d) { d["format"] = "urdf"; }, "format: expected \"minv-model\"");
  expectMutation([](json& d) { d["version"] = 2; }, "version: expected 1, got 2");
  expectMutation([](json& d) { d.erase("bodies"); }, "missing key 'bodies'");
  expectMutation([](json& d) { d["bodies"] = json::array(); }, "bodies: model has no bodies");
  expectMutation([](json& d) { d["bodies"][1].erase("mass"); },
                 "model.json: bodies[1]: missing key 'mass'");
  expectMutation([](json& d) { d["bodies"][1]["mass"] = "heavy"; },
                 "bodies[1].mass: expected a number, got string");
  expectMutation(
      [](json& d) {
        d["bodies"][2]["com"] = {0, 1};
      },
      "bodies[2].com: expected an array of 3 numbers, got 2 entries");
  expectMutation([](json& d) { d["bodies"][2]["inertia"][1] = 5; },
                 "bodies[2].inertia[1]: expected an array of 3 numbers, got number");
  expectMutation([](json& d) { d["bodies"][0]["joint"]["type"] = "ball"; },
                 "bodies[0].joint.type: unknown joint type 'ball'");
  expectMutation([](json& d) { d["bodies"][0]["joint"].erase("axis"); },
                 "bodies[0].joint: missing key 'axis'");
  expectMutation([](json& d) { d["bodies"][2]["parent"] = 2; }, "bodies[2].parent: index 2");
  expectMutation([](json& d) { d["bodies"][2]["parent"] = 0.5; },
                 "bodies[2].parent: expected an integer");
  expectMutation([](json& d) { d["bodies"][1]["mass"] = -1; },
                 "model.json: body 1 ('b1'): mass must be positive");
  expectMutation(
      [](json& d) {
        d["bodies"][1]["inertia"] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 3}};
      },
      "triangle inequality");
  expectMutation(
      [](json& d) {
        d["bodies"][1]["inertia"] = {{1, 0, 0}, {0, -1, 0}, {0, 0, 1}};
      },
      "not positive definite");
  expectMutation(
      [](json& d) {
        d["bodies"][1]["joint"]["axis"] = {0, 0, 0};
      },
      "joint axis is zero");
  expectMutation(
      [](json& d) {
        d["bodies"][1]["joint"]["placement"]["rotation"] = {{2, 0, 0}, {0, 1, 0}, {0, 0, 1}};
      },
      "not a rotation matrix");
  expectMutation([](json& d) { d["bodies"][1]["joint"]["type"] = "floating"; },
                 "floating joint must attach a root");
}

// A one-link URDF with the given joint element pieces.
std::string oneLink(const std::string& joint_type, const std::string& axis,
                    const std::string& inertial) {
  return "<robot name=\"r\"><link name=\"w\"/><link name=\"a\">" + inertial +
         "</link><joint name=\"j\" type=\"" + joint_type +
         "\"><parent link=\"w\"/><child link=\"a\"/><axis xyz=\"" + axis + "\"/></joint></robot>";
}
const std::string kInertial =
    "<inertial><mass value=\"1\"/><inertia ixx=\"1\" ixy=\"0\" ixz=\"0\" iyy=\"1\" iyz=\"0\" "
    "izz=\"1\"/></inertial>";

TEST(ModelIoTest, BadUrdfGivesClearErrors) {
  EXPECT_NO_THROW(readUrdf(oneLink("continuous", "0 0 1", kInertial), "r.urdf", false));
  EXPECT_ERROR(readUrdf("<robot", "r.urdf", false), "r.urdf: not a valid URDF tree");
  EXPECT_ERROR(
      readUrdf("<robot name=\"r\"><link name=\"a\"/><link name=\"b\"/></robot>", "two.urdf", false),
      "two.urdf: not a valid URDF tree");
  EXPECT_ERROR(readUrdf("<robot name=\"r\"><link name=\"a\"/><link name=\"b\"/>"
                        "<joint name=\"x\" type=\"fixed\"><parent link=\"a\"/><child link=\"b\"/>"
                        "</joint><joint name=\"y\" type=\"fixed\"><parent link=\"b\"/>"
                        "<child link=\"a\"/></joint></robot>",
                        "cycle.urdf", false),
               "cycle.urdf: not a valid URDF tree");
  // Links w, a, b with revolute joints name: parent -> child; each of these once hung the walk
  // (a cycle below the root) or dropped a joint (a link with two parents).
  auto chain = [](std::vector<std::array<const char*, 3>> joints) {
    std::string x = "<robot name=\"r\"><link name=\"w\"/>";
    for (const char* l : {"a", "b"})
      x += std::string("<link name=\"") + l + "\">" + kInertial + "</link>";
    for (const auto& [name, parent, child] : joints)
      x += std::string("<joint name=\"") + name + "\" type=\"revolute\"><parent link=\"" + parent +
           "\"/><child link=\"" + child +
           "\"/><axis xyz=\"0 0 1\"/><limit lower=\"-1\" "
           "upper=\"1\" effort=\"1\" velocity=\"1\"/></joint>";
    return x + "</robot>";
  };
  EXPECT_NO_THROW(readUrdf(chain({{"j1", "w", "a"}, {"j2", "a", "b"}}), "r.urdf", false));
  EXPECT_ERROR(
      readUrdf(chain({{"j1", "w", "a"}, {"j2", "a", "b"}, {"j3", "b", "a"}}), "c.urdf", false),
      "c.urdf: not a valid URDF tree: link 'a' is the child of two joints, 'j1' and 'j3'");
  EXPECT_ERROR(
      readUrdf(chain({{"j1", "w", "b"}, {"j2", "a", "b"}, {"j3", "w", "a"}}), "t.urdf", false),
      "link 'b' is the child of two joints, 'j1' and 'j2'");
  EXPECT_ERROR(
      readUrdf(chain({{"j0", "w", "b"}, {"j1", "w", "a"}, {"j2", "a", "a"}}), "s.urdf", false),
      "s.urdf: not a valid URDF tree: joint 'j2' joins link 'a' to itself");
  EXPECT_ERROR(readUrdf("<robot name=\"r\"><link name=\"a\"/><joint name=\"x\" type=\"fixed\">"
                        "<parent link=\"ghost\"/><child link=\"a\"/></joint></robot>",
                        "ghost.urdf", false),
               "ghost");
  EXPECT_ERROR(readUrdf(oneLink("floating", "0 0 1", kInertial), "r.urdf", false),
               "joint 'j': unsupported joint type (floating)");
  EXPECT_ERROR(readUrdf(oneLink("planar", "0 0 1", kInertial), "r.urdf", false), "planar");
  EXPECT_ERROR(readUrdf(oneLink("continuous", "0 0 1", ""), "r.urdf", false),
               "r.urdf: link 'a' has no inertial (mass must be positive)");
  EXPECT_ERROR(readUrdf(oneLink("continuous", "0 0 0", kInertial), "r.urdf", false), "axis");
  std::string heavy = kInertial;
  heavy.replace(heavy.find("izz=\"1\""), 7, "izz=\"3\"");
  EXPECT_ERROR(readUrdf(oneLink("continuous", "0 0 1", heavy), "r.urdf", false), "triangle");
  std::string negative = kInertial;
  negative.replace(negative.find("value=\"1\""), 9, "value=\"-2\"");
  EXPECT_ERROR(readUrdf(oneLink("continuous", "0 0 1", negative), "r.urdf", false),
               "r.urdf: link 'a' has mass -2; every link's mass must be positive");
  std::string merged = oneLink("continuous", "0 0 1", kInertial);
  merged.insert(merged.find("</robot>"), "<link name=\"tip\">" + negative +
                                             "</link><joint name=\"f\" type=\"fixed\">"
                                             "<parent link=\"a\"/><child link=\"tip\"/></joint>");
  EXPECT_ERROR(readUrdf(merged, "m.urdf", false),
               "m.urdf: link 'tip' (merged into body 'a' by a fixed joint) has mass -2");
  // A text ending inside a multi-byte UTF-8 sequence (TinyXML would step past its end): refused
  // before parsing, with the byte named; a complete sequence there is fine.
  const std::string open = "<robot name=\"r\"><link name=\"a\"><inertial><origin xyz=\"1";
  EXPECT_ERROR(readUrdf(open + "\xF1", "u.urdf", false),
               "u.urdf: not valid XML text: it ends inside a 4-byte UTF-8 sequence (byte 0xF1");
  EXPECT_ERROR(readUrdf(open + "\xE2\x82", "u.urdf", false), "3-byte UTF-8 sequence (byte 0xE2");
  EXPECT_ERROR(readUrdf("\xC3", "u.urdf", false), "2-byte UTF-8 sequence (byte 0xC3 at offset 0");
  EXPECT_ERROR(readUrdf(open + "\xE2\x82\xAC", "u.urdf", false), "not a valid URDF tree");
}

TEST(ModelIoTest, BadFilesGiveClearErrors) {
  TempDir dir;
  EXPECT_ERROR(loadModel(dir.file("missing.json"), false), "No such file");
  EXPECT_ERROR(loadModel(dir.file("missing.urdf"), false), "cannot open");
  EXPECT_ERROR(loadUrdf(dir.file("missing.urdf"), false), "missing.urdf");
  const std::string empty = dir.file("empty.json");
  std::ofstream(empty).close();
  EXPECT_ERROR(loadModel(empty, false), "file is empty");
  EXPECT_ERROR(loadModel(dir.file("m.yaml", "x: 1"), false), "unknown model file extension");
  fs::create_directories(dir.path / "d.json");
  EXPECT_ERROR(loadModel((dir.path / "d.json").string(), false), "is a directory");
  const std::string bad = dir.file("bad.json", "{\"format\": 1}");
  EXPECT_ERROR(loadModel(bad, false), bad + ": format: expected a string, got number");
}

TEST(ModelIoTest, UrdfWriterRejectsWhatUrdfCannotHold) {
  const Model sph = randomTree({Topology::Serial, 20, 8, false, JointSet::Mixed});
  std::ostringstream s;
  EXPECT_ERROR(writeUrdf(sph, s, "r"), "is spherical");
  // (Two bodies named alike are refused by Model::create itself: tests/model_validation_test.)
  const Model unnamed = Model::create({-1, 0}, {joint("a"), joint("b")}, {body("x"), body("")});
  EXPECT_ERROR(writeUrdf(unnamed, s, "r"), "link name '' is empty or not unique");
  const Model two = Model::create({-1, -1}, {joint("a", JointType::Floating), joint("b")},
                                  {body("x"), body("y")});
  EXPECT_ERROR(writeUrdf(two, s, "r"), "single root");
}

}  // namespace
}  // namespace minv
