#include "generators/model_io.hpp"

#include <console_bridge/console.h>
#include <urdf_parser/urdf_parser.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cctype>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>
#include <string_view>
#include <tuple>

#include "generators/mjcf.hpp"

namespace minv {

namespace {

using nlohmann::json;

// ---- JSON reading --------------------------------------------------------------------------

// Typed access to a parsed document; every failure names the source and the JSON path.
struct JsonReader {
  const std::string& source;

  [[noreturn]] void fail(const std::string& at, const std::string& what) const {
    throw ModelError(source + ": " + (at.empty() ? "" : at + ": ") + what);
  }
  const json& key(const json& obj, const std::string& at, const std::string& k) const {
    if (!obj.is_object()) fail(at, std::string("expected an object, got ") + obj.type_name());
    const auto it = obj.find(k);
    if (it == obj.end()) fail(at, "missing key '" + k + "'");
    return *it;
  }
  double number(const json& v, const std::string& at) const {
    if (!v.is_number()) fail(at, std::string("expected a number, got ") + v.type_name());
    return v.get<double>();
  }
  std::string string(const json& v, const std::string& at) const {
    if (!v.is_string()) fail(at, std::string("expected a string, got ") + v.type_name());
    return v.get<std::string>();
  }
  const json& array(const json& v, const std::string& at, std::size_t n, const char* what) const {
    if (!v.is_array() || (n > 0 && v.size() != n))
      fail(at, "expected " + std::string(what) + ", got " +
                   (v.is_array() ? std::to_string(v.size()) + " entries" : v.type_name()));
    return v;
  }
  Eigen::Vector3d vec3(const json& v, const std::string& at) const {
    array(v, at, 3, "an array of 3 numbers");
    Eigen::Vector3d x;
    for (int k = 0; k < 3; ++k) x(k) = number(v[k], at + "[" + std::to_string(k) + "]");
    return x;
  }
  Eigen::Matrix3d mat3(const json& v, const std::string& at) const {
    array(v, at, 3, "a 3x3 array (3 rows of 3 numbers)");
    Eigen::Matrix3d m;
    for (int r = 0; r < 3; ++r) m.row(r) = vec3(v[r], at + "[" + std::to_string(r) + "]");
    return m;
  }
};

// ---- JSON writing --------------------------------------------------------------------------

using ojson = nlohmann::ordered_json;

// Vectors as arrays, matrices as arrays of rows.
ojson toJson(const Eigen::Vector3d& v) {
  return ojson::array({v(0), v(1), v(2)});
}
ojson toJson(const Eigen::Matrix3d& m) {
  return ojson::array({toJson(Eigen::Vector3d(m.row(0))), toJson(Eigen::Vector3d(m.row(1))),
                       toJson(Eigen::Vector3d(m.row(2)))});
}

// Compact, full precision; invalid UTF-8 in names is replaced rather than fatal.
std::string dump(const ojson& j) {
  return j.dump(-1, ' ', false, json::error_handler_t::replace);
}

// ---- files ---------------------------------------------------------------------------------

// The whole file; ModelError naming the path if it is missing, unreadable or empty.
std::string readFile(const std::string& path) {
  requireInputFile(path);
  std::ifstream f(path, std::ios::binary);
  if (!f) throw ModelError("cannot open '" + path + "': " + std::strerror(errno));
  std::ostringstream s;
  s << f.rdbuf();
  if (f.bad()) throw ModelError("cannot read '" + path + "': " + std::strerror(errno));
  if (s.str().empty()) throw ModelError("'" + path + "': file is empty");
  // (a model file is text: the parsers stopped at a NUL and ignored what followed it)
  if (s.str().find('\0') != std::string::npos)
    throw ModelError("'" + path + "': not a text file (it contains a NUL byte)");
  return s.str();
}

}  // namespace

void requireInputFile(const std::string& path) {
  namespace fs = std::filesystem;
  std::error_code ec;
  const fs::file_status st = fs::status(path, ec);
  if (fs::is_directory(st)) throw ModelError("cannot open '" + path + "': is a directory");
  if (fs::exists(st) && !fs::is_regular_file(st))
    throw ModelError("cannot read '" + path + "': not a regular file (a device, FIFO or socket)");
}

void requireOutputFile(const std::string& path) {
  namespace fs = std::filesystem;
  std::error_code ec;
  const fs::file_status st = fs::status(path, ec);
  if (fs::is_directory(st)) throw ModelError("output '" + path + "' is a directory; name a file");
  if (fs::exists(st) && !fs::is_regular_file(st))
    throw ModelError("output '" + path +
                     "' exists and is not a regular file (a device, FIFO or socket): writing "
                     "would replace it; name a regular file");
}

namespace {

// The extension in lower case, with its dot.
std::string extension(const std::string& path) {
  std::string e = std::filesystem::path(path).extension().string();
  std::transform(e.begin(), e.end(), e.begin(), [](unsigned char c) { return std::tolower(c); });
  return e;
}

// ---- URDF reading --------------------------------------------------------------------------

// The joint of a floating base: "base", identity placement.
Joint floatingJoint() {
  Joint j;
  j.name = "base";
  j.type = JointType::Floating;
  return j;
}

// Collects urdfdom's error messages (it reports through console_bridge and returns null).
struct ErrorCapture : console_bridge::OutputHandler {
  std::string errors;
  ErrorCapture() { console_bridge::useOutputHandler(this); }
  ~ErrorCapture() override { console_bridge::restorePreviousOutputHandler(); }
  void log(const std::string& text, console_bridge::LogLevel level, const char*, int) override {
    if (level < console_bridge::CONSOLE_BRIDGE_LOG_ERROR) return;
    errors += (errors.empty() ? "" : "; ") + text;
  }
};

// A URDF pose (xyz, quaternion from rpy) as a Pose.
Pose<double> toPose(const urdf::Pose& p) {
  const urdf::Rotation& r = p.rotation;
  return {Eigen::Quaterniond(r.w, r.x, r.y, r.z).normalized().toRotationMatrix(),
          Eigen::Vector3d(p.position.x, p.position.y, p.position.z)};
}

// Natural order: digit runs compare as numbers, so "b2" < "b10".
bool naturalLess(const std::string& a, const std::string& b) {
  std::size_t i = 0, j = 0;
  while (i < a.size() && j < b.size()) {
    if (std::isdigit(static_cast<unsigned char>(a[i])) &&
        std::isdigit(static_cast<unsigned char>(b[j]))) {
      std::size_t i1 = i, j1 = j;
      while (i1 < a.size() && std::isdigit(static_cast<unsigned char>(a[i1]))) ++i1;
      while (j1 < b.size() && std::isdigit(static_cast<unsigned char>(b[j1]))) ++j1;
      std::string x = a.substr(i, i1 - i), y = b.substr(j, j1 - j);
      x.erase(0, std::min(x.find_first_not_of('0'), x.size()));
      y.erase(0, std::min(y.find_first_not_of('0'), y.size()));
      if (x.size() != y.size()) return x.size() < y.size();
      if (x != y) return x < y;
      i = i1, j = j1;
    } else {
      if (a[i] != b[j]) return a[i] < b[j];
      ++i, ++j;
    }
  }
  if (a.size() - i != b.size() - j) return a.size() - i < b.size() - j;
  return a < b;
}

// A body under construction: its joint, and the inertials of the links merged into it.
struct UrdfBody {
  std::string parent;  // owning body of the parent link; "" = the world
  Joint joint;
  std::string link;  // the link that names the body
  // Each merged link: its inertial, its pose in the body and its name.
  std::vector<std::tuple<urdf::InertialSharedPtr, Pose<double>, std::string>> parts;
};

// Mass, centre of mass and inertia of the merged links, by the parallel-axis theorem.
void combine(const UrdfBody& ub, const std::string& source, Body& body) {
  std::vector<Body> parts;
  for (const auto& [in, T, name] : ub.parts) {
    // Each link of a merged body must be physical on its own, not only their sum.
    if (!(in->mass > 0))
      throw ModelError(
          source + ": link '" + name + "'" +
          (name == ub.link ? "" : " (merged into body '" + ub.link + "' by a fixed joint)") +
          " has mass " + formatNumber(in->mass) + "; every link's mass must be positive");
    Body b;
    const Pose<double> C = T * toPose(in->origin);  // inertial frame in the body frame
    Eigen::Matrix3d I;
    I << in->ixx, in->ixy, in->ixz, in->ixy, in->iyy, in->iyz, in->ixz, in->iyz, in->izz;
    b.mass = in->mass;
    b.com = C.p;
    b.inertia = C.R * I * C.R.transpose();
    parts.push_back(b);
  }
  if (parts.empty())
    throw ModelError(source + ": link '" + ub.link + "' has no inertial (mass must be positive)");
  body = mergeRigid(parts);
  body.name = ub.link;
}

// ---- URDF writing --------------------------------------------------------------------------

// Shortest text that reads back to the same double.
std::string num(double x) {
  char buf[64];
  const auto r = std::to_chars(buf, buf + sizeof buf, x);
  return std::string(buf, r.ptr);
}

std::string nums(const Eigen::Vector3d& v) {
  return num(v(0)) + " " + num(v(1)) + " " + num(v(2));
}

// Text safe inside an XML attribute.
std::string xmlEscape(const std::string& s) {
  std::string out;
  for (char c : s)
    out += c == '&'   ? "&amp;"
           : c == '<' ? "&lt;"
           : c == '>' ? "&gt;"
           : c == '"' ? "&quot;"
                      : std::string(1, c);
  return out;
}

// Roll, pitch, yaw with R = Rz(yaw) Ry(pitch) Rx(roll): yaw first, then the rest from
// Rz(yaw)ᵀ R = Ry(pitch) Rx(roll), which stays accurate near pitch = ±π/2.
Eigen::Vector3d rpy(const Eigen::Matrix3d& R) {
  const double yaw = std::atan2(R(1, 0), R(0, 0));
  const Eigen::Matrix3d A =
      Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix().transpose() * R;
  return {std::atan2(-A(1, 2), A(1, 1)), std::atan2(-A(2, 0), A(0, 0)), yaw};
}

}  // namespace

Model readJson(std::istream& in, const std::string& source) {
  const JsonReader r{source};
  // Parse, turning the library's exceptions into ModelErrors with the byte position.
  json doc;
  try {
    doc = json::parse(in);
  } catch (const json::parse_error& e) {
    const std::string what = e.what();
    r.fail("", "invalid JSON at byte " + std::to_string(e.byte) + ": " +
                   what.substr(what.find("] ") + 2));
  } catch (const json::exception& e) {
    const std::string what = e.what();
    r.fail("", "invalid JSON: " + what.substr(what.find("] ") + 2) + " (numbers must be finite)");
  }
  // The header.
  if (r.string(r.key(doc, "", "format"), "format") != "minv-model")
    r.fail("format", "expected \"minv-model\"");
  const json& version = r.key(doc, "", "version");
  if (!version.is_number_integer() || version.get<long long>() != 1)
    r.fail("version", "expected 1, got " + version.dump());
  if (doc.contains("name")) r.string(doc["name"], "name");
  const json& list = r.array(r.key(doc, "", "bodies"), "bodies", 0, "an array of bodies");
  if (list.empty()) r.fail("bodies", "model has no bodies");
  // Each body and its joint.
  const int nb = static_cast<int>(list.size());
  std::vector<int> parent(nb);
  std::vector<Joint> joints(nb);
  std::vector<Body> bodies(nb);
  for (int i = 0; i < nb; ++i) {
    const std::string at = "bodies[" + std::to_string(i) + "]", jat = at + ".joint";
    const json& b = list[i];
    bodies[i].name = r.string(r.key(b, at, "name"), at + ".name");
    const json& p = r.key(b, at, "parent");
    if (!p.is_number_integer()) r.fail(at + ".parent", "expected an integer, got " + p.dump());
    // An unsigned number beyond long long's range would wrap to a negative one (−1, a root).
    if ((p.is_number_unsigned() && p.get<std::uint64_t>() >= static_cast<std::uint64_t>(i)) ||
        p.get<long long>() < -1 || p.get<long long>() >= i)
      r.fail(at + ".parent", "index " + p.dump() + " must be in [-1, " + std::to_string(i - 1) +
                                 "] (parent before child)");
    parent[i] = p.get<int>();
    const json& j = r.key(b, at, "joint");
    joints[i].name = r.string(r.key(j, jat, "name"), jat + ".name");
    const std::string type = r.string(r.key(j, jat, "type"), jat + ".type");
    try {
      joints[i].type = jointTypeFromName(type);
    } catch (const ModelError& e) {
      r.fail(jat + ".type", e.what());
    }
    const bool one_dof = jointNv(joints[i].type) == 1;
    if (one_dof || j.contains("axis"))
      joints[i].axis = r.vec3(r.key(j, jat, "axis"), jat + ".axis");
    const json& pl = r.key(j, jat, "placement");
    joints[i].placement.R =
        r.mat3(r.key(pl, jat + ".placement", "rotation"), jat + ".placement.rotation");
    joints[i].placement.p =
        r.vec3(r.key(pl, jat + ".placement", "translation"), jat + ".placement.translation");
    bodies[i].mass = r.number(r.key(b, at, "mass"), at + ".mass");
    bodies[i].com = r.vec3(r.key(b, at, "com"), at + ".com");
    bodies[i].inertia = r.mat3(r.key(b, at, "inertia"), at + ".inertia");
  }
  // Model::create checks the values.
  try {
    return Model::create(std::move(parent), std::move(joints), std::move(bodies));
  } catch (const ModelError& e) {
    throw ModelError(source + ": " + e.what());
  }
}

void writeJson(const Model& m, std::ostream& out, const std::string& name) {
  // The header, then one body per line.
  out << "{\"format\": \"minv-model\", \"version\": 1, \"name\": " << dump(name)
      << ",\n \"bodies\": [\n";
  for (int i = 0; i < m.nb(); ++i) {
    const Joint& j = m.joint(i);
    const Body& b = m.body(i);
    ojson joint = {{"name", j.name}, {"type", jointTypeName(j.type)}};
    if (jointNv(j.type) == 1) joint["axis"] = toJson(j.axis);
    joint["placement"] = {{"rotation", toJson(j.placement.R)},
                          {"translation", toJson(j.placement.p)}};
    const ojson body = {{"name", b.name}, {"parent", m.parent(i)}, {"joint", joint},
                        {"mass", b.mass}, {"com", toJson(b.com)},  {"inertia", toJson(b.inertia)}};
    out << "  " << dump(body) << (i + 1 < m.nb() ? ",\n" : "\n");
  }
  out << "]}\n";
}

Model loadUrdf(const std::string& path, bool floating_base) {
  // Read the file here, so a missing or empty one gets our message.
  return readUrdf(readFile(path), path, floating_base);
}

namespace {

// One XML tag of a scan: its name, its attribute text, and whether it closes or is empty.
struct XmlTag {
  std::string_view name, attributes;
  bool closing = false, empty = false;
};

// Calls visit(tag) for every element tag of `xml` in order, in one linear pass (comments,
// processing instructions and declarations are skipped; quoted attribute values may hold '>').
// Stops with false at the first malformed tag (urdfdom, which ran first, reports those).
template <class Visit>
bool forEachTag(std::string_view xml, Visit&& visit) {
  std::size_t i = 0;
  while ((i = xml.find('<', i)) != std::string_view::npos) {
    if (xml.compare(i, 4, "<!--") == 0) {
      const std::size_t e = xml.find("-->", i + 4);
      if (e == std::string_view::npos) return false;
      i = e + 3;
      continue;
    }
    if (xml.compare(i, 2, "<?") == 0 || xml.compare(i, 2, "<!") == 0) {
      const std::size_t e = xml.find('>', i + 2);
      if (e == std::string_view::npos) return false;
      i = e + 1;
      continue;
    }
    XmlTag tag;
    std::size_t j = i + 1;
    tag.closing = j < xml.size() && xml[j] == '/';
    if (tag.closing) ++j;
    const std::size_t name_start = j;
    while (j < xml.size() && !std::isspace(static_cast<unsigned char>(xml[j])) && xml[j] != '>' &&
           xml[j] != '/')
      ++j;
    tag.name = xml.substr(name_start, j - name_start);
    // The end of the tag, outside quoted values.
    const std::size_t attrs = j;
    char quote = 0;
    for (; j < xml.size(); ++j) {
      if (quote) {
        if (xml[j] == quote) quote = 0;
      } else if (xml[j] == '"' || xml[j] == '\'') {
        quote = xml[j];
      } else if (xml[j] == '>') {
        break;
      }
    }
    if (j >= xml.size()) return false;
    tag.empty = j > attrs && xml[j - 1] == '/';
    tag.attributes = xml.substr(attrs, j - attrs - (tag.empty ? 1 : 0));
    visit(tag);
    i = j + 1;
  }
  return true;
}

// The attributes of a tag as (name, value) pairs, in order.
std::vector<std::pair<std::string, std::string>> xmlAttributes(std::string_view text) {
  std::vector<std::pair<std::string, std::string>> out;
  std::size_t i = 0;
  while (i < text.size()) {
    while (i < text.size() && std::isspace(static_cast<unsigned char>(text[i]))) ++i;
    const std::size_t k = i;
    while (i < text.size() && text[i] != '=' && !std::isspace(static_cast<unsigned char>(text[i])))
      ++i;
    std::string key(text.substr(k, i - k));
    while (i < text.size() && (text[i] == '=' || std::isspace(static_cast<unsigned char>(text[i]))))
      ++i;
    if (i >= text.size() || (text[i] != '"' && text[i] != '\'')) break;
    const char quote = text[i++];
    const std::size_t e = text.find(quote, i);
    if (e == std::string_view::npos) break;
    out.emplace_back(std::move(key), std::string(text.substr(i, e - i)));
    i = e + 1;
  }
  return out;
}

// urdfdom parses XML with TinyXML, whose time grows with the square of the nesting depth (6 s
// for 21 000 unclosed elements, found by fuzzing); a URDF is a handful of levels deep, so
// anything deeper than this is refused before it is parsed.
constexpr int kMaxUrdfDepth = 64;

void checkUrdfDepth(const std::string& xml, const std::string& source) {
  int depth = 0, deepest = 0;
  forEachTag(xml, [&](const XmlTag& t) {
    if (t.closing)
      --depth;
    else if (!t.empty)
      deepest = std::max(deepest, ++depth);
  });
  if (deepest > kMaxUrdfDepth)
    throw ModelError(source + ": not a valid URDF tree: elements nested " +
                     std::to_string(deepest) + " deep (a URDF needs a few levels; at most " +
                     std::to_string(kMaxUrdfDepth) + ")");
}

// TinyXML (urdfdom's parser) takes a byte from 0xC2 to 0xF4 as the first of a 2-, 3- or 4-byte
// UTF-8 sequence and steps over the whole sequence at once, even past the end of the text: a
// file ending inside one (an unclosed attribute value ending "…\xF1", found by fuzzing) sent it
// reading beyond the buffer. Such a file is refused before it is parsed. (Other invalid UTF-8 is
// left to TinyXML, which keeps it in bounds; names that are not UTF-8 are replaced when written.)
void checkUrdfText(const std::string& xml, const std::string& source) {
  // (Only a sequence that starts in the last three bytes can run past the end.)
  for (std::size_t i = xml.size() > 3 ? xml.size() - 3 : 0; i < xml.size(); ++i) {
    const auto lead = static_cast<unsigned char>(xml[i]);
    const std::size_t length = lead < 0xC2   ? 1
                               : lead < 0xE0 ? 2
                               : lead < 0xF0 ? 3
                               : lead < 0xF5 ? 4
                                             : 1;
    if (i + length > xml.size()) {
      char hex[8];
      std::snprintf(hex, sizeof hex, "0x%02X", lead);
      throw ModelError(source + ": not valid XML text: it ends inside a " + std::to_string(length) +
                       "-byte UTF-8 sequence (byte " + hex + " at offset " + std::to_string(i) +
                       " of " + std::to_string(xml.size()) + ")");
    }
  }
}

// urdfdom reads a number it cannot parse ("nan", "1e999", "abc") without complaint, as 0 or
// as NaN, so a bad mass would be reported as "got 0". Before its values are used, every number
// minv reads from the file (the inertial's mass, inertia and origin, the joint's origin and
// axis) is checked here, in the file's own text, and a bad one is named with its link or
// joint. The XML itself has been accepted by urdfdom, so one linear scan of its tags suffices.
void checkUrdfNumbers(const std::string& xml, const std::string& source) {
  std::string owner;  // "link 'b'" or "joint 'j'"
  bool inertial = false, joint = false;
  forEachTag(xml, [&](const XmlTag& t) {
    if (t.name == "link" || t.name == "joint") {
      if (t.closing) {
        owner.clear(), joint = false;
        return;
      }
      std::string id;
      for (const auto& [key, value] : xmlAttributes(t.attributes))
        if (key == "name") id = value;
      owner = std::string(t.name) + " '" + id + "'";
      joint = t.name == "joint" && !t.empty;
      return;
    }
    if (t.name == "inertial") {
      inertial = !t.closing && !t.empty;
      return;
    }
    const bool read =
        (inertial && (t.name == "mass" || t.name == "inertia" || t.name == "origin")) ||
        (joint && (t.name == "origin" || t.name == "axis"));
    if (t.closing || !read) return;
    for (const auto& [key, value] : xmlAttributes(t.attributes)) {
      std::istringstream tokens(value);
      for (std::string v; tokens >> v;) {
        char* end = nullptr;
        const double x = std::strtod(v.c_str(), &end);
        if (end != v.c_str() + v.size() || !std::isfinite(x))
          throw ModelError(source + ": " + owner + ": <" + std::string(t.name) + " " + key + "=\"" +
                           value + "\">: '" + v + "' is not a finite number");
      }
    }
  });
}

// urdfdom's links hold shared pointers to their children and their children to their parents,
// so a parsed model never frees itself; cut those links when minv is done with it.
struct UrdfRelease {
  urdf::ModelInterfaceSharedPtr& u;
  ~UrdfRelease() {
    if (!u) return;
    for (auto& [name, link] : u->links_) {
      link->child_links.clear();
      link->child_joints.clear();
      link->parent_joint.reset();
    }
  }
};

}  // namespace

Model readUrdf(const std::string& xml, const std::string& source, bool floating_base) {
  // Parse with urdfdom, which rejects several roots and dangling links.
  checkUrdfText(xml, source);
  checkUrdfDepth(xml, source);
  urdf::ModelInterfaceSharedPtr u;
  const UrdfRelease release{u};
  {
    ErrorCapture capture;
    try {
      u = urdf::parseURDF(xml);
    } catch (const std::exception& e) {
      capture.errors += std::string(capture.errors.empty() ? "" : "; ") + e.what();
    }
    if (!u || !u->getRoot())
      throw ModelError(source + ": not a valid URDF tree: " +
                       (capture.errors.empty() ? "rejected by urdfdom" : capture.errors));
  }
  checkUrdfNumbers(xml, source);
  // One parent joint per link: urdfdom keeps the last of several and lists the link among the
  // children of every parent, so that a cycle through the root's tree would never end below.
  std::map<std::string, std::string> parentJoint;
  for (const auto& [name, j] : u->joints_) {
    if (j->parent_link_name == j->child_link_name)
      throw ModelError(source + ": not a valid URDF tree: joint '" + name + "' joins link '" +
                       j->child_link_name + "' to itself");
    const auto [it, fresh] = parentJoint.emplace(j->child_link_name, name);
    if (!fresh)
      throw ModelError(source + ": not a valid URDF tree: link '" + j->child_link_name +
                       "' is the child of two joints, '" + it->second + "' and '" + name +
                       "' (a tree gives each link one parent joint; a cycle of joints?)");
  }
  const urdf::LinkConstSharedPtr root = u->getRoot();
  // Walk the tree: each link's owning body ("" = world) and its pose in that body's frame.
  std::map<std::string, UrdfBody> bodies;
  std::map<std::string, std::pair<std::string, Pose<double>>> owner;
  owner[root->name] = {floating_base ? root->name : "", {}};
  if (floating_base) bodies[root->name] = {"", floatingJoint(), root->name, {}};
  std::vector<urdf::LinkConstSharedPtr> stack = {root};
  std::set<std::string> seen;
  while (!stack.empty()) {
    const urdf::LinkConstSharedPtr link = stack.back();
    stack.pop_back();
    // (Unreachable after the check above; it keeps the walk finite whatever urdfdom links.)
    if (!seen.insert(link->name).second)
      throw ModelError(source + ": not a valid URDF tree: link '" + link->name +
                       "' is reached twice from the root (a cycle of joints?)");
    const auto [body, T] = owner.at(link->name);
    if (!body.empty() && link->inertial)
      bodies.at(body).parts.emplace_back(link->inertial, T, link->name);
    for (const urdf::LinkSharedPtr& c : link->child_links) {
      const urdf::Joint& j = *c->parent_joint;
      const Pose<double> place = T * toPose(j.parent_to_joint_origin_transform);
      stack.push_back(c);
      // Fixed joints merge; 1-DOF joints start a new body; the rest are unsupported.
      if (j.type == urdf::Joint::FIXED) {
        owner[c->name] = {body, place};
        continue;
      }
      Joint joint;
      joint.name = j.name;
      joint.axis = Eigen::Vector3d(j.axis.x, j.axis.y, j.axis.z);
      joint.placement = place;
      if (j.type == urdf::Joint::PRISMATIC)
        joint.type = JointType::Prismatic;
      else if (j.type != urdf::Joint::REVOLUTE && j.type != urdf::Joint::CONTINUOUS)
        throw ModelError(source + ": joint '" + j.name + "': unsupported joint type (" +
                         (j.type == urdf::Joint::FLOATING ? "floating"
                          : j.type == urdf::Joint::PLANAR ? "planar"
                                                          : "unknown") +
                         "); supported: revolute, continuous, prismatic, fixed");
      bodies[c->name] = {body, joint, c->name, {}};
      owner[c->name] = {c->name, {}};
    }
  }
  // Every link must hang below the root (urdfdom drops a cycle of joints that is not).
  if (owner.size() != u->links_.size()) {
    std::string lost;
    for (const auto& [name, link] : u->links_)
      if (!owner.count(name)) lost += (lost.empty() ? "'" : ", '") + name + "'";
    throw ModelError(source + ": not a valid URDF tree: links " + lost +
                     " are not connected to the root link '" + root->name +
                     "' (a cycle of joints?)");
  }
  // Number the bodies: parents first, otherwise in natural name order.
  std::map<std::string, std::vector<std::string>> children;
  for (const auto& [name, b] : bodies) children[b.parent].push_back(name);
  std::map<std::string, int> index;
  std::set<std::string, decltype(&naturalLess)> ready(&naturalLess);
  ready.insert(children[""].begin(), children[""].end());
  std::vector<int> parent;
  std::vector<Joint> joints;
  std::vector<Body> out;
  while (!ready.empty()) {
    const std::string name = *ready.begin();
    ready.erase(ready.begin());
    const UrdfBody& b = bodies.at(name);
    index[name] = static_cast<int>(parent.size());
    parent.push_back(b.parent.empty() ? -1 : index.at(b.parent));
    joints.push_back(b.joint);
    combine(b, source, out.emplace_back());
    ready.insert(children[name].begin(), children[name].end());
  }
  // Model::create checks the values.
  try {
    return Model::create(std::move(parent), std::move(joints), std::move(out));
  } catch (const ModelError& e) {
    throw ModelError(source + ": " + e.what());
  }
}

void writeUrdf(const Model& m, std::ostream& out, const std::string& robot_name) {
  const bool floating = m.floatingBase();
  // Check that URDF can express the model.
  std::set<std::string> links = {floating ? "" : "world_base"}, joint_names;
  for (int i = 0; i < m.nb(); ++i) {
    const std::string at = "cannot write URDF: body " + std::to_string(i);
    if (m.joint(i).type == JointType::Spherical)
      throw ModelError(at + ": joint '" + m.joint(i).name +
                       "' is spherical (URDF export supports revolute and prismatic joints)");
    if (floating && i > 0 && m.parent(i) < 0)
      throw ModelError(at + ": a second root; a floating-base model must have a single root");
    if (m.body(i).name.empty() || !links.insert(m.body(i).name).second)
      throw ModelError(at + ": link name '" + m.body(i).name + "' is empty or not unique");
    if (!(floating && i == 0) &&
        (m.joint(i).name.empty() || !joint_names.insert(m.joint(i).name).second))
      throw ModelError(at + ": joint name '" + m.joint(i).name + "' is empty or not unique");
  }
  out << "<?xml version=\"1.0\"?>\n<robot name=\"" << xmlEscape(robot_name) << "\">\n";
  if (!floating) out << "  <link name=\"world_base\"/>\n";
  for (int i = 0; i < m.nb(); ++i) {
    const Body& b = m.body(i);
    const Eigen::Matrix3d& I = b.inertia;
    // The link: inertial at the com, axes of the body frame.
    out << "  <link name=\"" << xmlEscape(b.name) << "\">\n    <inertial>\n      <origin xyz=\""
        << nums(b.com) << "\" rpy=\"0 0 0\"/>\n      <mass value=\"" << num(b.mass)
        << "\"/>\n      <inertia ixx=\"" << num(I(0, 0)) << "\" ixy=\"" << num(I(0, 1))
        << "\" ixz=\"" << num(I(0, 2)) << "\" iyy=\"" << num(I(1, 1)) << "\" iyz=\"" << num(I(1, 2))
        << "\" izz=\"" << num(I(2, 2)) << "\"/>\n    </inertial>\n  </link>\n";
    if (floating && i == 0) continue;
    // Its joint from the parent link (or world_base).
    const Joint& j = m.joint(i);
    const bool prismatic = j.type == JointType::Prismatic;
    const std::string parent = m.parent(i) < 0 ? "world_base" : m.body(m.parent(i)).name;
    out << "  <joint name=\"" << xmlEscape(j.name) << "\" type=\""
        << (prismatic ? "prismatic" : "continuous") << "\">\n    <parent link=\""
        << xmlEscape(parent) << "\"/>\n    <child link=\"" << xmlEscape(b.name)
        << "\"/>\n    <origin xyz=\"" << nums(j.placement.p) << "\" rpy=\""
        << nums(rpy(j.placement.R)) << "\"/>\n    <axis xyz=\"" << nums(j.axis) << "\"/>\n"
        << (prismatic ? "    <limit lower=\"-1e6\" upper=\"1e6\" effort=\"0\" velocity=\"0\"/>\n"
                      : "")
        << "  </joint>\n";
  }
  out << "</robot>\n";
}

Model loadModel(const std::string& path, bool floating_base) {
  // Dispatch on the extension.
  const std::string ext = extension(path);
  if (ext != ".json" && ext != ".urdf" && ext != ".xml")
    throw ModelError("'" + path + "': unknown model file extension '" + ext +
                     "' (expected .json, .urdf or .xml for MJCF)");
  const std::string text = readFile(path);
  if (ext == ".xml") return loadMjcf(path, floating_base);
  if (ext == ".urdf") return readUrdf(text, path, floating_base);
  // JSON, then a floating base if asked for and missing.
  std::istringstream in(text);
  const Model m = readJson(in, path);
  try {
    return floating_base ? withFloatingBase(m) : m;
  } catch (const ModelError& e) {
    throw ModelError(path + ": " + e.what());
  }
}

std::string floatingUrdfNote(const Model& model, const std::string& path) {
  if (!model.floatingBase() || extension(path) != ".urdf") return {};
  return "minv: note: URDF has no floating joint: '" + path +
         "' holds the tree without its floating base (and the base's placement); read it back "
         "with --free-root (Python: load_model(path, floating_base=True))";
}

void saveModel(const Model& m, const std::string& path) {
  // Serialise first, so a model the format cannot express touches no file.
  const std::string ext = extension(path), name = std::filesystem::path(path).stem().string();
  std::ostringstream text;
  if (ext == ".json")
    writeJson(m, text, name);
  else if (ext == ".urdf")
    writeUrdf(m, text, name);
  else
    throw ModelError("'" + path + "': unknown model file extension '" + ext +
                     "' (expected .json or .urdf)");
  // Write a temporary file, then rename it over the target.
  requireOutputFile(path);
  const std::string tmp = path + ".tmp";
  // The tmp file's name is not ours to take: a file or directory there (a user's, or a
  // SIGKILLed run's) is kept, and named
  std::error_code ec;
  if (std::filesystem::exists(std::filesystem::symlink_status(tmp, ec)))
    throw ModelError("'" + tmp + "' exists: the model is written there first and renamed to '" +
                     path + "' (remove it, or name another output)");
  {
    std::ofstream f(tmp, std::ios::binary | std::ios::trunc);
    if (!f) throw ModelError("cannot write '" + tmp + "': " + std::strerror(errno));
    f << text.str();
    f.close();
    if (!f) {
      std::filesystem::remove(tmp);
      throw ModelError("cannot write '" + tmp + "': " + std::strerror(errno));
    }
  }
  std::filesystem::rename(tmp, path, ec);
  if (ec) {
    std::filesystem::remove(tmp);
    throw ModelError("cannot rename '" + tmp + "' to '" + path + "': " + ec.message());
  }
}

Model withFloatingBase(const Model& fixed) {
  if (fixed.floatingBase()) return fixed;
  // A single root is required.
  const std::vector<int>& parents = fixed.parents();
  const auto roots = std::count(parents.begin(), parents.end(), -1);
  if (roots > 1)
    throw ModelError("cannot add a floating base: the model has " + std::to_string(roots) +
                     " root bodies, a floating base needs exactly one");
  // Body 0's joint becomes the floating joint.
  std::vector<Joint> joints;
  std::vector<Body> bodies;
  for (int i = 0; i < fixed.nb(); ++i) joints.push_back(fixed.joint(i));
  for (int i = 0; i < fixed.nb(); ++i) bodies.push_back(fixed.body(i));
  joints[0] = floatingJoint();
  return Model::create(parents, std::move(joints), std::move(bodies));
}

Eigen::VectorXd readConfiguration(const Model& model, std::istream& in, const std::string& source) {
  const std::vector<std::string> names = model.qNames();
  Eigen::VectorXd q = model.neutral();
  std::vector<int> line_of(model.nq(), 0);  // where each named entry was set
  int count = 0, line_no = 0;
  enum { Unknown, Plain, Named } form = Unknown;
  // Whether the whole token reads as a double (nan and inf included), into *x.
  auto parses = [](const std::string& token, double* x) {
    char* end = nullptr;
    *x = std::strtod(token.c_str(), &end);
    return !token.empty() && end == token.c_str() + token.size();
  };
  // A finite double from the whole token (a subnormal one too), else ModelError naming the place.
  auto number = [&](const std::string& token, const std::string& what) {
    double x = 0;
    const bool read = parses(token, &x);
    if (read && std::isfinite(x)) return x;
    // nan and inf spell an n; any other infinity is a number too large for a double.
    const char* why = !read ? "is not a number"
                      : token.find_first_of("nN") != std::string::npos
                          ? "is not a finite number"
                          : "is beyond the range of a double (about ±1.8e308)";
    throw ModelError(source + ":" + std::to_string(line_no) + ": " + what + " '" + token + "' " +
                     why);
  };
  std::string line;
  while (std::getline(in, line)) {
    ++line_no;
    if (const auto hash = line.find('#'); hash != std::string::npos) line.erase(hash);
    // Text only, outside comments: a control byte other than white space (a NUL cut the
    // messages that quote the line short, an escape reached the terminal) is refused, by code.
    for (const char ch : line) {
      const auto c = static_cast<unsigned char>(ch);
      if ((c < 0x20 && !std::isspace(c)) || c == 0x7f) {
        char code[8];
        std::snprintf(code, sizeof code, "0x%02x", c);
        throw ModelError(source + ":" + std::to_string(line_no) +
                         ": not a text line (control byte " + code + ")");
      }
    }
    std::istringstream tokens(line);
    std::string first;
    if (!(tokens >> first)) continue;
    // The first word decides the form: a number (nan and inf too, refused below) or a name.
    if (form == Unknown) {
      double x = 0;
      const char c = first[0];
      form = (std::isdigit(static_cast<unsigned char>(c)) || c == '-' || c == '+' || c == '.' ||
              parses(first, &x))
                 ? Plain
                 : Named;
    }
    if (form == Plain) {
      // Every token of the line is the next entry of q.
      for (std::string t = first;;) {
        if (count >= model.nq())
          throw ModelError(source + ":" + std::to_string(line_no) +
                           ": more than nq = " + std::to_string(model.nq()) + " numbers");
        q(count) = number(t, "entry q[" + std::to_string(count) + "]");
        ++count;
        if (!(tokens >> t)) break;
      }
      continue;
    }
    // Named: "name value" and nothing else on the line.
    std::string value, extra;
    if (!(tokens >> value) || (tokens >> extra))
      throw ModelError(source + ":" + std::to_string(line_no) + ": expected 'name value', got '" +
                       line + "'");
    const auto it = std::find(names.begin(), names.end(), first);
    if (it == names.end())
      throw ModelError(source + ":" + std::to_string(line_no) + ": unknown q name '" + first +
                       "' (names are the joints' names, with _qw/_qx/_qy/_qz for a spherical "
                       "joint and _x/_y/_z/_qw/_qx/_qy/_qz for a floating base)");
    const int k = static_cast<int>(it - names.begin());
    if (line_of[k])
      throw ModelError(source + ":" + std::to_string(line_no) + ": '" + first +
                       "' was already given on line " + std::to_string(line_of[k]));
    line_of[k] = line_no;
    q(k) = number(value, "value of '" + first + "'");
    ++count;
  }
  if (form == Unknown) throw ModelError(source + ": no configuration in the file");
  if (form == Plain && count != model.nq())
    throw ModelError(source + ": " + std::to_string(count) +
                     " numbers, the model needs nq = " + std::to_string(model.nq()));
  try {
    model.checkConfiguration(q);
  } catch (const ModelError& e) {
    throw ModelError(source + ": " + e.what());
  }
  return q;
}

Eigen::VectorXd loadConfiguration(const Model& model, const std::string& path) {
  requireInputFile(path);
  std::ifstream in(path);
  if (!in) throw ModelError("cannot open configuration file '" + path + "'");
  return readConfiguration(model, in, path);
}

}  // namespace minv
