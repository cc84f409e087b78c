#ifdef MINV_HAVE_MUJOCO

#include "solvers/mujoco.hpp"

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <stdexcept>

#include "generators/mjcf.hpp"

namespace minv {

namespace {

// Estimated bytes of MuJoCo's mjData for this tree: its largest arrays are the sparse M
// (qM, qLD, qH: one entry per DOF pair on a root path) and the derivative pattern (qDeriv,
// qLU, D_colind: every ancestor-or-descendant DOF pair).
double estimatedDataBytes(const Model& model) {
  double nM = 0;
  for (int k = 0; k < model.nv(); ++k)
    for (int a = k; a >= 0; a = model.dofParent()[a]) nM += 1;
  const double nD = 2 * nM - model.nv();
  return 8.0 * (3 * nM + 2 * nD) + 4.0 * (nD + nM);
}

// mjData buffer sizes are ints (bytes); keep well below 2³¹.
constexpr double kMaxDataBytes = 1.5e9;

}  // namespace

struct MujocoSolver::Impl {
  const Model* model = nullptr;
  MjModelPtr m;
  MjDataPtr d;
  // Per body of ours: what configure() copies into qpos.
  struct Coord {
    JointType type;
    int q, qpos;  // our q index, MuJoCo's qpos address
  };
  std::vector<Coord> coords;
  int free_body = -1;        // MuJoCo body id of a floating root, or −1
  int free_dof = -1;         // its first (linear) DOF in MuJoCo
  Eigen::Quaterniond place;  // the floating root's placement
  Eigen::Vector3d place_p;
  bool place_identity = true;
  Eigen::Matrix3d R;    // floating root orientation at the last configuration
  Eigen::VectorXd tmp;  // one column, nv

  // x (our generalized forces) → y = T⁻ᵀ x (MuJoCo's), for one column.
  template <class In, class Out>
  void forcesToMj(const std::vector<int>& perm, const In& x, Out&& y) const {
    for (int k = 0; k < static_cast<int>(perm.size()); ++k) y(perm[k]) = x(k);
    if (free_dof >= 0) y.template segment<3>(free_dof) = R * x.template segment<3>(3);
  }
  // X ← M_mj⁻¹ X in place: all columns in one call when they are contiguous, else one by one.
  void solveColumns(MatrixOut X) {
    const int nv = static_cast<int>(X.rows()), cols = static_cast<int>(X.cols());
    if (X.outerStride() == nv) {
      mj_solveM(m.get(), d.get(), X.data(), X.data(), cols);
      return;
    }
    for (int c = 0; c < cols; ++c) mj_solveM(m.get(), d.get(), &X(0, c), &X(0, c), 1);
  }
  // z (MuJoCo's velocities) → T⁻¹ z (ours), in place, for one column.
  template <class Col>
  void velocitiesToOurs(const std::vector<int>& perm, Col&& z) {
    tmp = z;
    for (int k = 0; k < static_cast<int>(perm.size()); ++k) z(k) = tmp(perm[k]);
    if (free_dof >= 0) z.template segment<3>(3) = R.transpose() * tmp.segment<3>(free_dof);
  }
};

MujocoSolver::MujocoSolver() : impl_(std::make_unique<Impl>()) {}
MujocoSolver::~MujocoSolver() = default;

bool MujocoSolver::supports(const Model& model, std::string* why) const {
  for (int i = 0; i < model.nb(); ++i) {
    const Body& b = model.body(i);
    if (b.mass < mjMINVAL || smallestPrincipalMoment(b) < mjMINVAL) {
      if (why)
        *why = "mujoco: body " + std::to_string(i) +
               " has a mass or principal moment of inertia below MuJoCo's mjMINVAL (1e-15), "
               "which MuJoCo refuses for a moving body";
      return false;
    }
  }
  const double bytes = estimatedDataBytes(model);
  if (bytes > kMaxDataBytes) {
    if (why)
      *why = "mujoco: this tree needs about " +
             std::to_string(static_cast<long long>(bytes / 1e6)) +
             " MB of mjData (nv² arrays for deep trees), beyond MuJoCo 2.2.2's int-sized buffer";
    return false;
  }
  return true;
}

void MujocoSolver::prepare(const Model& model) {
  Impl& s = *impl_;
  s.model = &model;
  s.d.reset();
  s.m = compileMjcf(toMjcf(model), "mujoco");
  const mjModel* m = s.m.get();
  if (m->nv != model.nv() || m->nq != model.nq())
    throw std::runtime_error("mujoco: compiled model has nv = " + std::to_string(m->nv) +
                             ", nq = " + std::to_string(m->nq) + "; ours has " +
                             std::to_string(model.nv()) + ", " + std::to_string(model.nq()));
  s.d = MjDataPtr(mj_makeData(m));
  if (!s.d) throw std::runtime_error("mujoco: mj_makeData failed (out of memory?)");
  for (int k = 0; k < m->nv; ++k)
    if (m->dof_armature[k] != 0) throw std::runtime_error("mujoco: nonzero armature");

  // Our joint i is MuJoCo's joint "j<i>": map q and v.
  s.coords.clear();
  perm_.assign(model.nv(), -1);
  s.free_body = s.free_dof = -1;
  for (int i = 0; i < model.nb(); ++i) {
    std::string name = "j";  // (not "j" + …: GCC 12 warns falsely, -Wrestrict)
    name += std::to_string(i);
    const int jid = mj_name2id(m, mjOBJ_JOINT, name.c_str());
    if (jid < 0) throw std::runtime_error("mujoco: joint '" + name + "' missing after compile");
    const int dof = m->jnt_dofadr[jid], v = model.vIdx(i);
    const JointType t = model.joint(i).type;
    s.coords.push_back({t, model.qIdx(i), m->jnt_qposadr[jid]});
    if (t == JointType::Floating) {
      // Ours [ω; v], MuJoCo's [v; ω].
      for (int c = 0; c < 3; ++c) {
        perm_[v + c] = dof + 3 + c;
        perm_[v + 3 + c] = dof + c;
      }
      s.free_body = m->jnt_bodyid[jid];
      s.free_dof = dof;
      const Pose<double>& P = model.joint(i).placement;
      s.place = Eigen::Quaterniond(P.R);
      s.place_p = P.p;
      s.place_identity = P.p.isZero(0) && P.R.isIdentity(0);
    } else {
      for (int c = 0; c < model.nvOf(i); ++c) perm_[v + c] = dof + c;
    }
  }
  s.R.setIdentity();
  s.tmp.resize(model.nv());
}

void MujocoSolver::configure(const Eigen::VectorXd& q) {
  Impl& s = *impl_;
  const mjModel* m = s.m.get();
  mjData* d = s.d.get();
  mjtNum* qpos = d->qpos;
  for (const Impl::Coord& c : s.coords) {
    switch (c.type) {
      case JointType::Revolute:
      case JointType::Prismatic:
        qpos[c.qpos] = q(c.q);
        break;
      case JointType::Spherical:
        for (int k = 0; k < 4; ++k) qpos[c.qpos + k] = q(c.q + k);
        break;
      case JointType::Floating:
        if (s.place_identity) {
          for (int k = 0; k < 7; ++k) qpos[c.qpos + k] = q(c.q + k);
        } else {
          // MuJoCo's free body pose is qpos itself: fold in our placement.
          const Eigen::Vector3d p = s.place_p + s.place * q.segment<3>(c.q);
          const Eigen::Quaterniond r =
              s.place * Eigen::Quaterniond(q(c.q + 3), q(c.q + 4), q(c.q + 5), q(c.q + 6));
          for (int k = 0; k < 3; ++k) qpos[c.qpos + k] = p(k);
          const double w[4] = {r.w(), r.x(), r.y(), r.z()};
          for (int k = 0; k < 4; ++k) qpos[c.qpos + 3 + k] = w[k];
        }
        break;
    }
  }
  mj_kinematics(m, d);
  mj_comPos(m, d);
  mj_crb(m, d);
  mj_factorM(m, d);
  if (s.free_body >= 0) {
    const mjtNum* x = d->xmat + 9 * s.free_body;  // row-major, body → world
    s.R << x[0], x[1], x[2], x[3], x[4], x[5], x[6], x[7], x[8];
  }
}

void MujocoSolver::inverse(MatrixOut Minv) {
  Impl& s = *impl_;
  const int nv = s.model->nv();
  // Minv = T⁻¹ M_mj⁻¹ T⁻ᵀ: T⁻ᵀ's columns, solved in place, then T⁻¹ on every column.
  Minv.setZero();
  for (int k = 0; k < nv; ++k) Minv(perm_[k], k) = 1;
  if (s.free_dof >= 0) Minv.block<3, 3>(s.free_dof, 3) = s.R;
  s.solveColumns(Minv);
  for (int c = 0; c < nv; ++c) s.velocitiesToOurs(perm_, Minv.col(c));
}

void MujocoSolver::solve(MatrixIn R, MatrixOut X) {
  Impl& s = *impl_;
  const int cols = static_cast<int>(R.cols());
  for (int c = 0; c < cols; ++c) s.forcesToMj(perm_, R.col(c), X.col(c));
  s.solveColumns(X);
  for (int c = 0; c < cols; ++c) s.velocitiesToOurs(perm_, X.col(c));
}

Eigen::MatrixXd MujocoSolver::massMatrix() const {
  const Impl& s = *impl_;
  const int nv = s.model->nv();
  Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> Mmj(nv, nv);
  mj_fullM(s.m.get(), Mmj.data(), s.d->qM);
  // T: MuJoCo's qvel = T ν.
  Eigen::MatrixXd T = Eigen::MatrixXd::Zero(nv, nv);
  for (int k = 0; k < nv; ++k) T(perm_[k], k) = 1;
  if (s.free_dof >= 0) T.block<3, 3>(s.free_dof, 3) = s.R;
  return T.transpose() * Mmj * T;
}

}  // namespace minv

#endif  // MINV_HAVE_MUJOCO
