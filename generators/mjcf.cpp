#include "generators/mjcf.hpp"

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <algorithm>
#include <charconv>
#include <cmath>
#include <iostream>
#include <mutex>
#include <stdexcept>
#include <string_view>
#include <utility>
#include <vector>

#include "core/spatial.hpp"
#include "generators/model_io.hpp"

namespace minv {

namespace {

// Shortest round-trip decimal form of x.
void put(std::string& out, double x) {
  char buf[32];
  const auto r = std::to_chars(buf, buf + sizeof buf, x);
  out.append(buf, r.ptr);
}

void put3(std::string& out, const Eigen::Vector3d& v) {
  for (int k = 0; k < 3; ++k) {
    if (k) out += ' ';
    put(out, v(k));
  }
}

// MuJoCo's quaternion order: w x y z.
void putQuat(std::string& out, const Eigen::Matrix3d& R) {
  const Eigen::Quaterniond q(R);
  const double c[4] = {q.w(), q.x(), q.y(), q.z()};
  for (int k = 0; k < 4; ++k) {
    if (k) out += ' ';
    put(out, c[k]);
  }
}

bool isIdentity(const Pose<double>& X) {
  return X.p.isZero(0) && X.R.isIdentity(0);
}

// The joint and inertial elements of body i.
void writeBodyContent(const Model& model, int i, std::string& out) {
  const Joint& j = model.joint(i);
  out += "<joint name=\"j" + std::to_string(i) + "\" ";
  switch (j.type) {
    case JointType::Revolute:
    case JointType::Prismatic:
      out += j.type == JointType::Revolute ? "type=\"hinge\" axis=\"" : "type=\"slide\" axis=\"";
      put3(out, j.axis);
      out += "\" pos=\"0 0 0\" ref=\"0\" ";
      break;
    case JointType::Spherical:
      out += "type=\"ball\" pos=\"0 0 0\" ";
      break;
    case JointType::Floating:
      out += "type=\"free\" ";
      break;
  }
  out += "armature=\"0\" damping=\"0\" stiffness=\"0\"/>";
  // Principal moments and axes (a proper rotation), so MuJoCo does no eigen-decomposition.
  const Body& b = model.body(i);
  const Eigen::Matrix3d I = 0.5 * (b.inertia + b.inertia.transpose());
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(I);
  Eigen::Matrix3d V = es.eigenvectors();
  if (V.determinant() < 0) V.col(0) = -V.col(0);
  Eigen::Vector3d d = es.eigenvalues();  // ascending
  // MuJoCo refuses A + B < C outright; ours allows a relative 1e-9 slack: close the gap.
  if (d(0) + d(1) < d(2)) d(2) = d(0) + d(1);
  out += "<inertial pos=\"";
  put3(out, b.com);
  out += "\" quat=\"";
  putQuat(out, V);
  out += "\" mass=\"";
  put(out, b.mass);
  out += "\" diaginertia=\"";
  put3(out, d);
  out += "\"/>";
}

struct MjcfWriter {
  const Model& model;
  int nest_per_file;
  const MjcfExtras* extras;
  std::vector<std::vector<int>> children;
  std::vector<MjcfFile> files;

  // Body i nested `nest` deep in files[f] (1 for a top-level body of the file).
  void writeBody(int i, int f, int nest) {
    std::string s = "<body name=\"b" + std::to_string(i) + "\"";
    const Pose<double>& X = model.joint(i).placement;
    if (!isIdentity(X)) {
      s += " pos=\"";
      put3(s, X.p);
      s += "\" quat=\"";
      putQuat(s, X.R);
      s += "\"";
    }
    s += ">";
    writeBodyContent(model, i, s);
    if (extras && i < static_cast<int>(extras->body.size())) s += extras->body[i];
    files[f].text += s;
    if (!children[i].empty()) {
      if (nest >= nest_per_file) {
        // The subtree below goes to a new file, spliced in by MuJoCo's <include>.
        const int g = static_cast<int>(files.size());
        files.push_back({"part" + std::to_string(g) + ".xml", "<mujoco>"});
        files[f].text += "<include file=\"" + files[g].name + "\"/>";
        for (int c : children[i]) writeBody(c, g, 1);
        files[g].text += "</mujoco>\n";
      } else {
        for (int c : children[i]) writeBody(c, f, nest + 1);
      }
    }
    files[f].text += "</body>";
  }
};

}  // namespace

std::vector<MjcfFile> toMjcf(const Model& model, int nest_per_file, const MjcfExtras* extras) {
  if (nest_per_file < 1 || nest_per_file > 90)
    throw std::invalid_argument("toMjcf: nest_per_file must be in [1, 90]");
  MjcfWriter w{model, nest_per_file, extras, std::vector<std::vector<int>>(model.nb()), {}};
  for (int i = 0; i < model.nb(); ++i)
    if (model.parent(i) >= 0) w.children[model.parent(i)].push_back(i);
  const bool head = extras && !extras->head.empty();
  w.files.push_back({"minv.xml",
                     "<mujoco model=\"minv\">\n"
                     "<compiler angle=\"radian\" inertiafromgeom=\"false\" boundmass=\"0\" "
                     "boundinertia=\"0\" balanceinertia=\"false\" settotalmass=\"-1\" "
                     "fusestatic=\"false\"/>\n" +
                         (head ? extras->head : std::string("<option gravity=\"0 0 0\"/>\n")) +
                         "<worldbody>" + (extras ? extras->world : std::string())});
  for (int i = 0; i < model.nb(); ++i)
    if (model.parent(i) < 0) w.writeBody(i, 0, 1);
  w.files[0].text += "</worldbody>\n</mujoco>\n";
  return std::move(w.files);
}

#ifndef MINV_HAVE_MUJOCO

Model loadMjcf(const std::string& path, bool) {
  throw ModelError(path + ": MJCF import needs MuJoCo, and this build has none");
}

#else

namespace {

std::mutex& mujocoLoadMutex() {
  static std::mutex m;
  return m;
}

// Set on a thread while it runs mj_loadXML (LoadingXml).
thread_local bool loading_xml = false;
struct LoadingXml {
  LoadingXml() { loading_xml = true; }
  ~LoadingXml() { loading_xml = false; }
  LoadingXml(const LoadingXml&) = delete;
  LoadingXml& operator=(const LoadingXml&) = delete;
};

// mju_error as a C++ exception, with one exception inside mj_loadXML. A file attribute that
// names no file (<include file=""/>) makes MuJoCo 2.2.2's virtual file system raise "Empty
// filename in VFS"; an exception thrown from there unwinds through the XML parser, whose
// objects are then never freed (8592 bytes in 5 allocations, the fuzzer's finding
// tests/fuzz/regressions/mjcf/leak-9a3cd708…). When the handler returns instead, the lookup
// fails as for a missing file and mj_loadXML reports it ("Include error … FILE_NOT_FOUND") and
// cleans up (measured with a program that calls only mj_loadXML: no leak). Every other error
// still throws: MuJoCo may not go on safely after it.
void throwingError(const char* msg) {
  if (loading_xml && std::string_view(msg) == "Empty filename in VFS") return;
  throw std::runtime_error(std::string("mujoco: ") + msg);
}
// MuJoCo's warnings, printed, or held while a HeldWarnings lives on this thread.
thread_local std::vector<std::string>* held_warnings = nullptr;
void printingWarning(const char* msg) {
  if (held_warnings) {
    held_warnings->push_back(msg);
    return;
  }
  std::cerr << "mujoco warning: " << msg << "\n";
}
// Holds MuJoCo's warnings while a user's file is read; print() shows them once the model is
// accepted. A file refused (by MuJoCo or minv) gets only its one error line, which names the
// problem ("XML contains a 'NaN'" beside "joint axis is not finite" was a second line).
class HeldWarnings {
 public:
  HeldWarnings() : outer_(std::exchange(held_warnings, &list_)) {}
  ~HeldWarnings() { held_warnings = outer_; }
  HeldWarnings(const HeldWarnings&) = delete;
  HeldWarnings& operator=(const HeldWarnings&) = delete;
  bool any(std::string_view part) const {
    for (const std::string& w : list_)
      if (w.find(part) != std::string::npos) return true;
    return false;
  }
  void print() {
    held_warnings = outer_;
    for (const std::string& w : list_) printingWarning(w.c_str());
  }

 private:
  std::vector<std::string> list_;
  std::vector<std::string>* outer_;
};

// MuJoCo's parse or compile error, with the nesting limit explained.
[[noreturn]] void loadFailed(const std::string& source, const char* error) {
  std::string msg = source + ": MuJoCo cannot load it: " + error;
  while (!msg.empty() && (msg.back() == '\n' || msg.back() == ' ')) msg.pop_back();
  if (msg.find("XML_ELEMENT_DEPTH_EXCEEDED") != std::string::npos)
    msg +=
        " (MuJoCo 2.2.2 parses XML with tinyxml2, which refuses elements nested 100 deep: one "
        "MJCF file holds a chain of at most 96 nested bodies; split deeper trees with <include>)";
  throw ModelError(msg);
}

struct VfsDeleter {
  void operator()(mjVFS* v) const {
    mj_deleteVFS(v);
    delete v;
  }
};

}  // namespace

void installMujocoHandlers() {
  static std::once_flag once;
  std::call_once(once, [] {
    mju_user_error = throwingError;
    mju_user_warning = printingWarning;
  });
}

namespace {
MjModelPtr compileMjcfFiles(const std::vector<MjcfFile>& files, const std::string& source_name);
MjModelPtr compileMujocoPath(const std::string& path);

// Runs MuJoCo calls whose errors (mju_error, thrown as std::runtime_error by throwingError)
// must reach the caller as a ModelError naming the file.
template <class F>
auto asModelError(const std::string& source, F&& f) {
  try {
    return f();
  } catch (const ModelError&) {
    throw;
  } catch (const std::exception& e) {
    throw ModelError(source + ": MuJoCo cannot load it: " + e.what());
  }
}
}  // namespace

MjModelPtr compileMjcf(const std::vector<MjcfFile>& files, const std::string& source_name) {
  return asModelError(source_name, [&] { return compileMjcfFiles(files, source_name); });
}

namespace {
MjModelPtr compileMjcfFiles(const std::vector<MjcfFile>& files, const std::string& source_name) {
  installMujocoHandlers();
  if (files.empty()) throw ModelError(source_name + ": no MJCF file to compile");
  for (const MjcfFile& f : files)
    if (f.text.empty()) throw ModelError(source_name + ": '" + f.name + "' is empty");
  if (files.size() > mjMAXVFS)
    throw ModelError(source_name + ": the MJCF needs " + std::to_string(files.size()) +
                     " files, more than MuJoCo's virtual file system holds (" +
                     std::to_string(mjMAXVFS) + ")");
  std::unique_ptr<mjVFS, VfsDeleter> vfs(new mjVFS);
  mj_defaultVFS(vfs.get());
  for (const MjcfFile& f : files) {
    if (mj_makeEmptyFileVFS(vfs.get(), f.name.c_str(), static_cast<int>(f.text.size())) != 0)
      throw ModelError(source_name + ": cannot add '" + f.name + "' to MuJoCo's file system");
    const int k = mj_findFileVFS(vfs.get(), f.name.c_str());
    std::copy(f.text.begin(), f.text.end(), static_cast<char*>(vfs->filedata[k]));
  }
  char error[1024] = "";
  mjModel* m = nullptr;
  {
    std::lock_guard<std::mutex> lock(mujocoLoadMutex());
    const LoadingXml loading;
    m = mj_loadXML(files[0].name.c_str(), vfs.get(), error, sizeof error);
    mj_freeLastXML();
  }
  if (!m) loadFailed(source_name, error);
  return MjModelPtr(m);
}
}  // namespace

MjModelPtr compileMujocoFile(const std::string& path) {
  return asModelError(path, [&] { return compileMujocoPath(path); });
}

namespace {
MjModelPtr compileMujocoPath(const std::string& path) {
  installMujocoHandlers();
  char error[1024] = "";
  mjModel* m = nullptr;
  {
    std::lock_guard<std::mutex> lock(mujocoLoadMutex());
    const LoadingXml loading;
    m = mj_loadXML(path.c_str(), nullptr, error, sizeof error);
    mj_freeLastXML();
  }
  if (!m) loadFailed(path, error);
  return MjModelPtr(m);
}
}  // namespace

namespace {

std::string nameOf(const mjModel* m, int adr, const char* fallback, int id) {
  const char* s = m->names + adr;
  return *s ? std::string(s) : fallback + std::to_string(id);
}

Eigen::Vector3d vec3(const mjtNum* v) {
  return {v[0], v[1], v[2]};
}

Eigen::Matrix3d quatRotation(const mjtNum* q) {
  return Eigen::Quaterniond(q[0], q[1], q[2], q[3]).normalized().toRotationMatrix();
}

Pose<double> translation(const Eigen::Vector3d& p) {
  Pose<double> X;
  X.p = p;
  return X;
}

}  // namespace

Model modelFromMujoco(const mjModel* m, bool floating_base, const std::string& source) {
  const int nbody = m->nbody;
  // Which MuJoCo bodies have a joint in their subtree (children come after parents).
  std::vector<char> moving(nbody, 0);
  for (int b = nbody - 1; b >= 1; --b) {
    if (m->body_jntnum[b] > 0) moving[b] = 1;
    if (moving[b]) moving[m->body_parentid[b]] = 1;
  }
  bool has_free = false;
  for (int j = 0; j < m->njnt; ++j) has_free = has_free || m->jnt_type[j] == mjJNT_FREE;
  // floating_base: the first world child that carries the robot is set free.
  int float_body = -1;
  if (floating_base && !has_free) {
    for (int b = 1; b < nbody && float_body < 0; ++b)
      if (m->body_parentid[b] == 0 && moving[b]) float_body = b;
    if (float_body < 0)
      for (int b = 1; b < nbody && float_body < 0; ++b)
        if (m->body_parentid[b] == 0) float_body = b;
    if (float_body < 0) throw ModelError(source + ": the model has no body to set free");
    if (m->body_jntnum[float_body] > 0)
      throw ModelError(source + ": floating base: MuJoCo body '" +
                       nameOf(m, m->name_bodyadr[float_body], "body", float_body) +
                       "' (the robot's root) has joints of its own; only a jointless root can "
                       "be set free");
  }

  std::vector<int> parents;
  std::vector<Joint> joints;
  std::vector<Body> bodies;
  std::vector<std::vector<Body>> parts;  // the MuJoCo bodies merged into each of ours
  struct JointOnly {
    int body, last;
    Eigen::Vector3d to_last;  // the last body's origin in this body's frame (zero joints)
  };
  std::vector<JointOnly> joint_only;
  std::vector<int> ours(nbody, -1);      // our body carrying MuJoCo body b's frame
  std::vector<Pose<double>> off(nbody);  // MuJoCo body b's frame in that body's frame
  auto addBody = [&](int parent, Joint j, const std::string& name) {
    parents.push_back(parent);
    joints.push_back(std::move(j));
    Body body;
    body.name = name;
    bodies.push_back(body);
    parts.emplace_back();
    return static_cast<int>(parents.size()) - 1;
  };

  for (int b = 1; b < nbody; ++b) {
    const int p = m->body_parentid[b];
    const std::string bname = nameOf(m, m->name_bodyadr[b], "body", b);
    Pose<double> local;
    local.p = vec3(m->body_pos + 3 * b);
    local.R = quatRotation(m->body_quat + 4 * b);
    const Pose<double> F = off[p] * local;  // b's frame in ours[p]'s frame (world: -1)
    const int nj = m->body_jntnum[b], j0 = m->body_jntadr[b];
    if (b == float_body || (nj > 0 && m->jnt_type[j0] == mjJNT_FREE)) {
      if (nj > 1)
        throw ModelError(source + ": MuJoCo body '" + bname +
                         "' has a free joint and other joints; a free joint must be alone");
      if (!parents.empty())
        throw ModelError(source + ": MuJoCo body '" + bname +
                         "' is free but is not the first moving body: our trees allow one "
                         "floating body, body 0");
      Joint j;
      j.type = JointType::Floating;
      j.name = nj > 0 ? nameOf(m, m->name_jntadr[j0], "joint", j0) : "base";
      ours[b] = addBody(-1, j, bname);
      off[b] = Pose<double>{};  // the free body's frame is its configuration
    } else if (nj == 0) {
      ours[b] = ours[p];  // welded to the parent (or to the world)
      off[b] = F;
    } else {
      int parent = ours[p];
      Pose<double> place = F;
      Eigen::Vector3d prev_anchor = Eigen::Vector3d::Zero();
      for (int t = 0; t < nj; ++t) {
        const int jid = j0 + t;
        Joint j;
        j.name = nameOf(m, m->name_jntadr[jid], "joint", jid);
        switch (m->jnt_type[jid]) {
          case mjJNT_HINGE:
            j.type = JointType::Revolute;
            break;
          case mjJNT_SLIDE:
            j.type = JointType::Prismatic;
            break;
          case mjJNT_BALL:
            j.type = JointType::Spherical;
            break;
          default:
            throw ModelError(source + ": MuJoCo joint '" + j.name + "' of body '" + bname +
                             "' is free but not alone on its body");
        }
        if (j.type != JointType::Spherical) j.axis = vec3(m->jnt_axis + 3 * jid);
        // MuJoCo turns the body about the anchor: our joint frame sits at the anchor.
        const Eigen::Vector3d anchor = vec3(m->jnt_pos + 3 * jid);
        j.placement = place * translation(anchor - prev_anchor);
        prev_anchor = anchor;
        place = Pose<double>{};
        const bool last = t == nj - 1;
        parent = addBody(parent, j, last ? bname : bname + ":" + j.name);
        if (!last) joint_only.push_back({parent, -1, Eigen::Vector3d::Zero()});
      }
      for (int k = static_cast<int>(joint_only.size()) - (nj - 1);
           k < static_cast<int>(joint_only.size()); ++k) {
        joint_only[k].last = parent;
      }
      // Anchors of the earlier joints, for the joint-only bodies' share of the mass.
      for (int t = 0; t < nj - 1; ++t) {
        JointOnly& jo = joint_only[joint_only.size() - (nj - 1) + t];
        jo.to_last = prev_anchor - vec3(m->jnt_pos + 3 * (j0 + t));
      }
      ours[b] = parent;
      off[b] = translation(-prev_anchor);
    }
    // b's own inertia, in the frame of the body that carries it.
    const double mass = m->body_mass[b];
    if (ours[b] >= 0 && mass > 0) {
      const Pose<double>& X = off[b];
      const Eigen::Vector3d c = X.p + X.R * vec3(m->body_ipos + 3 * b);
      const Eigen::Matrix3d Ri = X.R * quatRotation(m->body_iquat + 4 * b);
      Body part;
      part.mass = mass, part.com = c;
      const Eigen::Matrix3d Ic = Ri * vec3(m->body_inertia + 3 * b).asDiagonal() * Ri.transpose();
      part.inertia = 0.5 * (Ic + Ic.transpose());  // exactly symmetric
      parts[ours[b]].push_back(part);
    }
  }
  if (parents.empty()) throw ModelError(source + ": the model has no joints (nothing moves)");

  std::vector<char> is_joint_only(parents.size(), 0);
  for (const JointOnly& jo : joint_only) is_joint_only[jo.body] = 1;
  for (std::size_t i = 0; i < parents.size(); ++i) {
    if (is_joint_only[i]) continue;
    if (parts[i].empty())
      throw ModelError(source + ": MuJoCo body '" + bodies[i].name + "' has no mass");
    const std::string name = bodies[i].name;
    bodies[i] = mergeRigid(parts[i]);
    bodies[i].name = name;
  }
  for (const JointOnly& jo : joint_only) {
    const Body& last = bodies[jo.last];
    Body& b = bodies[jo.body];
    b.mass = kJointOnlyMassFraction * last.mass;
    b.com = last.com + jo.to_last;
    b.inertia = kJointOnlyMassFraction * last.inertia;
  }
  try {
    return Model::create(std::move(parents), std::move(joints), std::move(bodies));
  } catch (const ModelError& e) {
    throw ModelError(source + ": " + e.what());
  }
}

Model loadMjcf(const std::string& path, bool floating_base) {
  requireInputFile(path);
  HeldWarnings warnings;
  const MjModelPtr m = compileMujocoFile(path);
  Model model = asModelError(path, [&] { return modelFromMujoco(m.get(), floating_base, path); });
  // A NaN that minv's checks did not name: MuJoCo read it as 0 and only warned
  if (warnings.any("XML contains a 'NaN'"))
    throw ModelError(path + ": the file contains a NaN (MuJoCo would read it as 0)");
  warnings.print();
  return model;
}

#endif

}  // namespace minv
