#ifdef MINV_HAVE_BULLET

#include "solvers/bullet.hpp"

#include <Eigen/Eigenvalues>
#include <stdexcept>
#include <vector>

#include "core/kinematics.hpp"
#include "solvers/bullet_bridge.hpp"
#include "solvers/plain_tree_model.hpp"

namespace minv {

namespace {

// Body i's principal frame: R_BP with det +1 and the moments, ascending.
PrincipalFrame principalFrame(const Body& b) {
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(0.5 *
                                                          (b.inertia + b.inertia.transpose()));
  Eigen::Matrix3d R = es.eigenvectors();
  if (R.determinant() < 0) R.col(2) = -R.col(2);
  PrincipalFrame f;
  for (int c = 0; c < 3; ++c) {
    f.moments[c] = es.eigenvalues()(c);
    for (int r = 0; r < 3; ++r) f.R[r + 3 * c] = R(r, c);
  }
  return f;
}

std::vector<PrincipalFrame> principalFrames(const Model& model) {
  std::vector<PrincipalFrame> frames(model.nb());
  for (int i = 0; i < model.nb(); ++i) frames[i] = principalFrame(model.body(i));
  return frames;
}

}  // namespace

struct BulletSolver::Impl {
  const Model* model = nullptr;
  std::unique_ptr<BulletBridge> bridge;
  int shift = 0;  // Bullet's index of our DOF k is k + shift (6 with a fixed base, else 0)
  bool floating = false;
  Eigen::Vector3d com;  // a floating body 0's com (body frame)
  Eigen::Matrix3d R;    // its orientation at the last configuration (body → world)
  // Spherical joints: our first DOF and R_BP.
  struct Spherical {
    int v;
    Eigen::Matrix3d RBP;
  };
  std::vector<Spherical> spherical;
  std::vector<double> f, z;  // one Bullet force and its velocity change

  // x (our generalized forces, one column) → f = Tᵀ x (Bullet's).
  template <class In>
  void forcesToBullet(const In& x) {
    const int nv = model->nv();
    for (int k = 0; k < 6; ++k) f[k] = 0;
    for (int k = 0; k < nv; ++k) f[k + shift] = x(k);
    Eigen::Map<Eigen::VectorXd> F(f.data(), f.size());
    // Base: [R (n − c × f); R f].
    if (floating) {
      const Eigen::Vector3d n = x.template segment<3>(0), fo = x.template segment<3>(3);
      F.segment<3>(0) = R * (n - com.cross(fo));
      F.segment<3>(3) = R * fo;
    }
    // Spherical: R_BPᵀ τ.
    for (const Spherical& s : spherical)
      F.segment<3>(s.v + shift) = s.RBP.transpose() * x.template segment<3>(s.v);
  }
  // z (Bullet's velocity change) → y = T z (ours), one column.
  template <class Out>
  void velocitiesToOurs(Out&& y) const {
    const int nv = model->nv();
    for (int k = 0; k < nv; ++k) y(k) = z[k + shift];
    const Eigen::Map<const Eigen::VectorXd> Z(z.data(), z.size());
    // Base: ω = Rᵀ ω_w, v_O = Rᵀ v_c + c × ω.
    if (floating) {
      const Eigen::Vector3d w = R.transpose() * Z.segment<3>(0);
      y.template segment<3>(0) = w;
      y.template segment<3>(3) = R.transpose() * Z.segment<3>(3) + com.cross(w);
    }
    // Spherical: R_BP ω_P.
    for (const Spherical& s : spherical)
      y.template segment<3>(s.v) = s.RBP * Z.segment<3>(s.v + shift);
  }
};

BulletSolver::BulletSolver() : impl_(std::make_unique<Impl>()) {}
BulletSolver::~BulletSolver() = default;

bool BulletSolver::supports(const Model& model, std::string* why) const {
  const std::string reason = BulletBridge::supported(plainTree(model), principalFrames(model));
  if (reason.empty()) return true;
  if (why) *why = reason;
  return false;
}

void BulletSolver::prepare(const Model& model) {
  Impl& s = *impl_;
  s.model = &model;
  const std::vector<PrincipalFrame> frames = principalFrames(model);
  s.bridge = std::make_unique<BulletBridge>(plainTree(model), frames);
  s.floating = model.floatingBase();
  s.shift = s.floating ? 0 : 6;
  if (s.bridge->size() != model.nv() + s.shift)
    throw std::runtime_error("bullet: the btMultiBody has " + std::to_string(s.bridge->size()) +
                             " velocity entries; expected " + std::to_string(model.nv() + s.shift));
  s.com = model.body(0).com;
  s.R.setIdentity();
  // Spherical joints and their principal frames.
  s.spherical.clear();
  for (int i = 0; i < model.nb(); ++i) {
    if (model.joint(i).type != JointType::Spherical) continue;
    s.spherical.push_back({model.vIdx(i), Eigen::Map<const Eigen::Matrix3d>(frames[i].R)});
  }
  s.f.assign(s.bridge->size(), 0.0);
  s.z.assign(s.bridge->size(), 0.0);
}

void BulletSolver::configure(const Eigen::VectorXd& q) {
  Impl& s = *impl_;
  s.bridge->configure(q.data());
  // A floating body 0's orientation, for T: placement.R · R(quaternion).
  if (s.floating) {
    const int o = s.model->qIdx(0);
    s.R = s.model->joint(0).placement.R *
          quatToRotation<double>(q(o + 3), q(o + 4), q(o + 5), q(o + 6));
  }
}

void BulletSolver::inverse(MatrixOut Minv) {
  Impl& s = *impl_;
  const int nv = s.model->nv();
  // Column k: T M_b⁻¹ Tᵀ e_k.
  for (int k = 0; k < nv; ++k) {
    s.forcesToBullet(Eigen::VectorXd::Unit(nv, k));
    s.bridge->solve(s.f.data(), s.z.data());
    s.velocitiesToOurs(Minv.col(k));
  }
}

void BulletSolver::solve(MatrixIn R, MatrixOut X) {
  Impl& s = *impl_;
  // Column c: T M_b⁻¹ Tᵀ R_c.
  for (int c = 0; c < R.cols(); ++c) {
    s.forcesToBullet(R.col(c));
    s.bridge->solve(s.f.data(), s.z.data());
    s.velocitiesToOurs(X.col(c));
  }
}

}  // namespace minv

#endif  // MINV_HAVE_BULLET
