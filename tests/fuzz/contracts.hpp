// The contracts of minv's model loaders under arbitrary input, as functions of the input's bytes
// that return "" when the contract holds and otherwise a message saying what broke it. Shared
// by the libFuzzer targets (tests/fuzz/fuzz_*.cpp, which abort on a message) and by their
// replay in the normal test suite (tests/fuzz_regressions_test.cpp); header-only, needs neither
// libFuzzer nor GoogleTest.
//
// Contract of every loader (generators/model_io.hpp, generators/mjcf.hpp): on any input it
// either returns a valid Model or throws ModelError. Valid here means:
//   - the tree is well formed (parent(i) < i, nq and nv the sums over the joints) and its
//     neutral configuration passes checkConfiguration;
//   - writeJson -> readJson accepts it and reproduces it bit for bit (so it passes
//     Model::create's validation again);
//   - for nv ≤ kMaxCheckedNv, M = massMatrix(model, neutral) is finite, symmetric to a relative
//     1e-12 and positive definite (Eigen's LLT succeeds), unless rounding alone makes it
//     indefinite (indefiniteByRounding): a valid tree's M can be singular to double precision
//     (a 1e29 kg tip on a straight chain of 1 kg links), which the loaders cannot refuse without
//     forming M, and which the solvers report.
// Configurations (checkConfigurationInput, on the fixed model configurationModel()): for any
// text readConfiguration returns a q that passes checkConfiguration or throws ModelError; for
// any vector checkConfiguration throws ModelError exactly when q breaks its spec
// (validConfiguration below: size, finite entries, ranges, no zero quaternion); an accepted q
// gives an M that is finite, symmetric and SPD (unless indefinite by rounding), and equal
// (relative 1e-9) to M at q with its quaternions normalised beforehand. A different exception type
// or a failed check is a violation; a crash, hang, leak or sanitizer report is the sanitizers' and
// libFuzzer's to catch. Inputs over kMaxInputBytes are skipped (contract holds vacuously), and so
// are MJCF inputs with a <size> element (see checkMjcfInput).
//
// Known, reported finding classes can be set aside to keep fuzzing past them: the environment
// variable MINV_FUZZ_SKIP holds a comma-separated list of check names ("spd" skips the
// finiteness, symmetry and LLT checks of M, "normalised" the comparison with pre-normalised
// quaternions, "roundtrip" the JSON round trip, "names" only its comparison of names,
// "exception" the exception type: any std::exception then counts as a rejection). The test suite
// never sets it.
#pragma once

#include <cxxabi.h>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <optional>
#include <sstream>
#include <string>
#include <string_view>
#include <typeinfo>
#include <vector>

#include "core/crba.hpp"
#include "core/model.hpp"
#include "generators/model_io.hpp"
#ifdef MINV_HAVE_MUJOCO
#include "generators/mjcf.hpp"
#endif

namespace minv::fuzz {

// Inputs above this size are skipped, so that every run stays fast.
inline constexpr std::size_t kMaxInputBytes = 64 * 1024;
// M is computed and factorised only for models with at most this many DOFs.
inline constexpr int kMaxCheckedNv = 200;

// Whether MINV_FUZZ_SKIP names this check.
inline bool skipped(const char* check) {
  const char* env = std::getenv("MINV_FUZZ_SKIP");
  if (!env) return false;
  std::stringstream list(env);
  for (std::string item; std::getline(list, item, ',');)
    if (item == check) return true;
  return false;
}

// The readable name of an exception's dynamic type.
inline std::string typeName(const std::type_info& t) {
  int status = 0;
  std::unique_ptr<char, void (*)(void*)> name(
      abi::__cxa_demangle(t.name(), nullptr, nullptr, &status), std::free);
  return status == 0 && name ? name.get() : t.name();
}

// The violation of a loader that threw e instead of ModelError ("" when set aside).
inline std::string wrongException(const std::string& what, const std::exception& e) {
  if (skipped("exception")) return "";
  return what + ": threw " + typeName(typeid(e)) + " instead of ModelError: " + e.what();
}

// Runs f(); "" if it returned, else the escaped exception as a violation of `what`.
template <class F>
std::string noException(const std::string& what, F&& f) {
  try {
    f();
    return "";
  } catch (const std::exception& e) {
    return what + ": threw " + typeName(typeid(e)) + ": " + e.what();
  } catch (...) {
    return what + ": threw an exception not derived from std::exception";
  }
}

// The unit roundoff of double, and the multiple of it, times nv and ‖M‖_F, within which M
// formed in double, and its Cholesky factorisation, may be off (CRBA sums over up to nv bodies;
// generous, so that only rounding qualifies).
inline constexpr double kUnitRoundoff = 0x1p-53;
inline constexpr double kRoundoffs = 1e3;

// "" unless the double M at q (given) may be indefinite by rounding alone, then a sentence
// saying so: M formed in long double (the same CRBA with 11 more bits) is the yardstick, the
// double M lies within R = kRoundoffs · nv · u · ‖M‖_F of it, and M's smallest eigenvalue lies
// within 4·(their difference) + R of zero. A tree whose M is singular to double precision (a
// 1e29 kg tip on a straight chain of 1 kg links) qualifies. An M off by more than R does not,
// nor does one whose rounding reaches its smallest eigenvalue only because the kernels' m r²
// products far from the root lose it (Model::create refuses the bodies that would). The
// yardstick runs the same code, so a shared defect that makes M singular would qualify too.
inline std::string indefiniteByRounding(const Model& m, const Eigen::VectorXd& q,
                                        const Eigen::MatrixXd& M) {
  using LMat = MatX<long double>;
  const LMat Ml = massMatrix<long double>(m, q);
  const long double diff = (M.cast<long double>() - Ml).norm(), norm = Ml.norm();
  const long double rounding = kRoundoffs * m.nv() * kUnitRoundoff * norm;
  const long double low =
      Eigen::SelfAdjointEigenSolver<LMat>(Ml, Eigen::EigenvaluesOnly).eigenvalues()(0);
  if (!(diff <= rounding && std::abs(low) <= 4 * diff + rounding)) return "";
  return "M is indefinite by rounding (long double: λ_min = " +
         formatNumber(static_cast<double>(low)) + "; double M off by " +
         formatNumber(static_cast<double>(diff)) +
         ", ‖M‖_F = " + formatNumber(static_cast<double>(norm)) + ")";
}

// "" if M = massMatrix(m, q) is finite, symmetric to a relative 1e-12 and SPD (Eigen's LLT) or
// indefinite by rounding only (indefiniteByRounding), else what is wrong.
inline std::string checkMassMatrix(const Model& m, const Eigen::VectorXd& q,
                                   const Eigen::MatrixXd& M, const std::string& what) {
  if (skipped("spd")) return "";
  if (!M.allFinite()) return what + ": M is not finite";
  const double scale = M.cwiseAbs().maxCoeff();
  const double asym = (M - M.transpose()).cwiseAbs().maxCoeff();
  if (asym > 1e-12 * scale)
    return what + ": M is not symmetric (|M - M^T| = " + formatNumber(asym) +
           ", max |M| = " + formatNumber(scale) + ")";
  const Eigen::LLT<Eigen::MatrixXd> llt(M);
  if (llt.info() != Eigen::Success && indefiniteByRounding(m, q, M).empty())
    return what +
           ": M is not positive definite (Eigen's LLT fails; max |M| = " + formatNumber(scale) +
           ", min diagonal = " + formatNumber(M.diagonal().minCoeff()) + ") by more than rounding";
  return "";
}

// "" if a and b agree bit for bit in every field a model file holds, else the first difference.
inline std::string sameModel(const Model& a, const Model& b) {
  if (a.parents() != b.parents()) return "parents differ";
  for (int i = 0; i < a.nb(); ++i) {
    const Joint &ja = a.joint(i), &jb = b.joint(i);
    const Body &ba = a.body(i), &bb = b.body(i);
    const std::string at = "body " + std::to_string(i) + ": ";
    if (ja.name != jb.name && !skipped("names"))
      return at + "joint name '" + ja.name + "' became '" + jb.name + "'";
    if (ja.type != jb.type) return at + "joint type differs";
    if (jointNv(ja.type) == 1 && ja.axis != jb.axis) return at + "joint axis differs";
    if (ja.placement.R != jb.placement.R || ja.placement.p != jb.placement.p)
      return at + "joint placement differs";
    if (ba.name != bb.name && !skipped("names"))
      return at + "body name '" + ba.name + "' became '" + bb.name + "'";
    if (ba.mass != bb.mass || ba.com != bb.com || ba.inertia != bb.inertia)
      return at + "mass, centre of mass or inertia differs";
  }
  return "";
}

// "" if m is a valid model (see the top of this file), else what is wrong with it.
inline std::string checkModel(const Model& m, const std::string& what) {
  // The tree's structure and its neutral configuration.
  if (m.nb() < 1) return what + ": model has no bodies";
  int nq = 0, nv = 0;
  for (int i = 0; i < m.nb(); ++i) {
    if (m.parent(i) < -1 || m.parent(i) >= i)
      return what + ": body " + std::to_string(i) + " has parent " + std::to_string(m.parent(i));
    if (m.qIdx(i) != nq || m.vIdx(i) != nv) return what + ": q or v index of body is wrong";
    nq += jointNq(m.joint(i).type), nv += jointNv(m.joint(i).type);
  }
  if (m.nq() != nq || m.nv() != nv) return what + ": nq or nv is not the sum over the joints";
  const Eigen::VectorXd q0 = m.neutral();
  if (std::string e =
          noException(what + ": checkConfiguration(neutral)", [&] { m.checkConfiguration(q0); });
      !e.empty())
    return e;
  // The JSON round trip: the writer's file must read back to the same model.
  if (!skipped("roundtrip")) {
    std::stringstream file;
    std::optional<Model> back;
    if (std::string e = noException(what + ": writeJson -> readJson",
                                    [&] {
                                      writeJson(m, file, "fuzz");
                                      back.emplace(readJson(file, "roundtrip.json"));
                                    });
        !e.empty())
      return e;
    if (std::string e = sameModel(m, *back); !e.empty())
      return what + ": writeJson -> readJson changes the model: " + e;
  }
  // M at the neutral configuration.
  if (m.nv() > kMaxCheckedNv) return "";
  return checkMassMatrix(
      m, q0, massMatrix(m, q0),
      what + " (nb = " + std::to_string(m.nb()) + ", nv = " + std::to_string(m.nv()) + ")");
}

// Runs load(): "" if it threw ModelError or returned a valid model, else the violation.
template <class Load>
std::string checkLoader(const std::string& what, Load&& load) {
  std::optional<Model> m;
  try {
    m.emplace(load());
  } catch (const ModelError&) {
    return "";
  } catch (const std::exception& e) {
    return wrongException(what, e);
  } catch (...) {
    return what + ": threw an exception not derived from std::exception instead of ModelError";
  }
  return checkModel(*m, what);
}

// ---- the loaders ---------------------------------------------------------------------------

// readJson on the input as a stream.
inline std::string checkJsonInput(std::string_view data) {
  if (data.size() > kMaxInputBytes) return "";
  return checkLoader("readJson", [&] {
    std::istringstream in{std::string(data)};
    return readJson(in, "fuzz.json");
  });
}

// readUrdf on the input as the XML text, with floating_base false and then true.
inline std::string checkUrdfInput(std::string_view data) {
  if (data.size() > kMaxInputBytes) return "";
  const std::string xml(data);
  for (const bool floating : {false, true}) {
    const std::string what =
        std::string("readUrdf(floating_base = ") + (floating ? "true" : "false") + ")";
    if (std::string e = checkLoader(what, [&] { return readUrdf(xml, "fuzz.urdf", floating); });
        !e.empty())
      return e;
  }
  return "";
}

#ifdef MINV_HAVE_MUJOCO
// MuJoCo compiles the input from its virtual file system (compileMjcf: no file is written),
// then modelFromMujoco, with floating_base false and then true.
inline std::string checkMjcfInput(std::string_view data) {
  if (data.size() > kMaxInputBytes) return "";
  // MuJoCo allocates what a <size> element asks for (nstack × 8 bytes, njmax, …) while it
  // compiles: lazily, but ASan touches it, so nstack = 3e8 takes 6 s and 2e9 is an
  // out-of-memory report about the file's own request, not about the loader. Skipped.
  if (data.find("<size") != std::string_view::npos) return "";
  MjModelPtr compiled;
  try {
    compiled = compileMjcf({{"fuzz.xml", std::string(data)}}, "fuzz.xml");
  } catch (const ModelError&) {
    return "";
  } catch (const std::exception& e) {
    return wrongException("compileMjcf", e);
  } catch (...) {
    return "compileMjcf: threw an exception not derived from std::exception";
  }
  if (!compiled) return "compileMjcf: returned no model and threw nothing";
  for (const bool floating : {false, true}) {
    const std::string what =
        std::string("modelFromMujoco(floating_base = ") + (floating ? "true" : "false") + ")";
    if (std::string e = checkLoader(
            what, [&] { return modelFromMujoco(compiled.get(), floating, "fuzz.xml"); });
        !e.empty())
      return e;
  }
  return "";
}
#endif

// ---- configurations ------------------------------------------------------------------------

// The fixed model of the configuration target: every joint type, a branch, a rotated
// placement; nq = 14 (base x y z qw qx qy qz, ball qw qx qy qz, elbow, slider, wrist).
inline const Model& configurationModel() {
  static const Model model = [] {
    auto joint = [](const char* name, JointType type, Eigen::Vector3d axis, Eigen::Vector3d p) {
      Joint j;
      j.name = name, j.type = type, j.axis = axis, j.placement.p = p;
      return j;
    };
    auto body = [](const char* name, double mass, Eigen::Vector3d com, Eigen::Vector3d moments) {
      Body b;
      b.name = name, b.mass = mass, b.com = com, b.inertia = moments.asDiagonal();
      return b;
    };
    std::vector<Joint> joints = {
        joint("base", JointType::Floating, Eigen::Vector3d::UnitZ(), Eigen::Vector3d::Zero()),
        joint("ball", JointType::Spherical, Eigen::Vector3d::UnitZ(), {0, 0, 0.5}),
        joint("elbow", JointType::Revolute, {0, 1, 0}, {0.1, 0, 0.4}),
        joint("slider", JointType::Prismatic, {1, 0, 0}, {0, 0, 0.3}),
        joint("wrist", JointType::Revolute, {1, 0, 1}, {0.2, -0.1, 0})};
    // The elbow's frame is turned a quarter turn about x.
    joints[2].placement.R << 1, 0, 0, 0, 0, -1, 0, 1, 0;
    std::vector<Body> bodies = {body("torso", 5, {0.05, 0, 0}, {0.3, 0.4, 0.5}),
                                body("upper", 2, {0, 0, 0.2}, {0.05, 0.05, 0.02}),
                                body("lower", 1.5, {0.1, 0, 0.1}, {0.03, 0.04, 0.02}),
                                body("hand", 0.5, {0, 0.02, 0}, {0.01, 0.01, 0.01}),
                                body("tail", 0.8, {0.1, 0, 0}, {0.02, 0.03, 0.04})};
    return Model::create({-1, 0, 1, 2, 0}, std::move(joints), std::move(bodies));
  }();
  return model;
}

// The spec of checkConfiguration (core/model.hpp): right size, finite entries; a floating base's
// position and a prismatic displacement within ±kMaxLength; a revolute angle within ±kMaxAngle;
// quaternion entries within ±1e100 and no zero quaternion (norm < 1e-12). (Its rule that
// prismatic displacements must not carry a body to where it is a point mass never applies to
// configurationModel: the slider's hand, 0.5 kg with Ī = 0.01, is no point mass within 1e5.)
inline bool validConfiguration(const Model& m, const Eigen::VectorXd& q) {
  if (q.size() != m.nq() || !q.allFinite()) return false;
  for (int i = 0; i < m.nb(); ++i) {
    const JointType t = m.joint(i).type;
    const int o = m.qIdx(i);
    const int lengths = t == JointType::Floating ? 3 : t == JointType::Prismatic ? 1 : 0;
    for (int k = 0; k < lengths; ++k)
      if (std::abs(q(o + k)) > kMaxLength) return false;
    if (t == JointType::Revolute && std::abs(q(o)) > kMaxAngle) return false;
    if (t != JointType::Spherical && t != JointType::Floating) continue;
    const auto quat = q.segment<4>(o + (t == JointType::Floating ? 3 : 0));
    if (quat.cwiseAbs().maxCoeff() > 1e100 || quat.norm() < 1e-12) return false;
  }
  return true;
}

// q with every quaternion scaled to unit length without overflow (by its largest entry first).
inline Eigen::VectorXd normalisedQuaternions(const Model& m, Eigen::VectorXd q) {
  for (int i = 0; i < m.nb(); ++i) {
    const JointType t = m.joint(i).type;
    if (t != JointType::Spherical && t != JointType::Floating) continue;
    auto quat = q.segment<4>(m.qIdx(i) + (t == JointType::Floating ? 3 : 0));
    quat /= quat.cwiseAbs().maxCoeff();
    quat.normalize();
  }
  return q;
}

// "" if M at an accepted q is finite, symmetric, SPD and the same as with unit quaternions.
inline std::string checkAcceptedConfiguration(const Model& m, const Eigen::VectorXd& q,
                                              const std::string& what) {
  if (!validConfiguration(m, q)) return what + ": accepted a configuration that is not valid";
  const Eigen::MatrixXd M = massMatrix(m, q);
  if (std::string e = checkMassMatrix(m, q, M, what); !e.empty()) return e;
  if (skipped("normalised") || skipped("spd")) return "";
  const Eigen::MatrixXd Mu = massMatrix(m, normalisedQuaternions(m, q));
  const double diff = (M - Mu).cwiseAbs().maxCoeff(), scale = Mu.cwiseAbs().maxCoeff();
  if (!(diff <= 1e-9 * scale))
    return what + ": M differs from M with the quaternions normalised beforehand (max |dM| = " +
           formatNumber(diff) + ", max |M| = " + formatNumber(scale) + ")";
  return "";
}

// readConfiguration on the input as text, and checkConfiguration on its bytes as doubles.
inline std::string checkConfigurationInput(std::string_view data) {
  if (data.size() > kMaxInputBytes) return "";
  const Model& m = configurationModel();
  // Text.
  std::optional<Eigen::VectorXd> q;
  try {
    std::istringstream in{std::string(data)};
    q = readConfiguration(m, in, "fuzz.q");
  } catch (const ModelError&) {
  } catch (const std::exception& e) {
    return wrongException("readConfiguration", e);
  } catch (...) {
    return "readConfiguration: threw an exception not derived from std::exception";
  }
  if (q) {
    if (std::string e = noException("readConfiguration's q: checkConfiguration",
                                    [&] { m.checkConfiguration(*q); });
        !e.empty())
      return e;
    if (std::string e = checkAcceptedConfiguration(m, *q, "readConfiguration"); !e.empty())
      return e;
  }
  // Bytes: as many doubles as fit.
  Eigen::VectorXd x(static_cast<Eigen::Index>(data.size() / sizeof(double)));
  if (x.size() > 0) std::memcpy(x.data(), data.data(), x.size() * sizeof(double));
  bool accepted = true;
  try {
    m.checkConfiguration(x);
  } catch (const ModelError&) {
    accepted = false;
  } catch (const std::exception& e) {
    return wrongException("checkConfiguration", e);
  }
  if (accepted != validConfiguration(m, x))
    return std::string("checkConfiguration: ") + (accepted ? "accepted" : "rejected") +
           " a configuration its contract " + (accepted ? "rejects" : "accepts");
  return accepted ? checkAcceptedConfiguration(m, x, "checkConfiguration") : "";
}

// The fuzz targets' reaction to a violation: print it and abort, so libFuzzer keeps the input.
inline void abortOnViolation(const std::string& violation) {
  if (violation.empty()) return;
  std::fprintf(stderr, "\n==== minv fuzz: contract violation: %s\n", violation.c_str());
  std::abort();
}

}  // namespace minv::fuzz
