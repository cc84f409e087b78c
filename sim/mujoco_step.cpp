#include "sim/mujoco_step.hpp"

#include <charconv>
#include <stdexcept>

#ifdef MINV_HAVE_MUJOCO
#include <Eigen/Geometry>
#include <chrono>
#endif

namespace minv::sim {

namespace {

// Shortest round-trip decimal form of x.
std::string num(double x) {
  char buf[32];
  const auto r = std::to_chars(buf, buf + sizeof buf, x);
  return std::string(buf, r.ptr);
}

}  // namespace

bool haveMujocoStep() {
#ifdef MINV_HAVE_MUJOCO
  return true;
#else
  return false;
#endif
}

std::vector<MjcfFile> centipedeMjcf(const Centipede& c, const MujocoStepOptions& o) {
  if (!(o.dt > 0) || !(o.mu >= 0) || !(o.tip_radius > 0))
    throw std::invalid_argument("mujoco-step: dt and the tip radius must be positive, mu ≥ 0");
  const int legs = c.legs(), nconmax = legs + 100, njmax = 4 * nconmax + 100;
  const std::string friction = "friction=\"" + num(o.mu) + " 0.005 0.0001\"";
  MjcfExtras x;
  // Options: step, gravity, MuJoCo's semi-implicit Euler, pyramidal cone, PGS; room for every
  // tip in contact.
  x.head = "<option timestep=\"" + num(o.dt) + "\" gravity=\"" + num(o.gravity.x()) + " " +
           num(o.gravity.y()) + " " + num(o.gravity.z()) +
           "\" integrator=\"Euler\" cone=\"pyramidal\" solver=\"PGS\"/>\n<size nconmax=\"" +
           std::to_string(nconmax) + "\" njmax=\"" + std::to_string(njmax) + "\"/>\n";
  // The ground: collides with the tip spheres only.
  x.world = "<geom name=\"ground\" type=\"plane\" size=\"0 0 1\" contype=\"1\" conaffinity=\"0\" " +
            friction + "/>";
  // A sphere at each tip, its lowest point at the tip on a vertical leg.
  x.body.assign(c.model.nb(), std::string());
  const double z = -c.options.lower_length + o.tip_radius;
  for (int l = 0; l < legs; ++l)
    x.body[c.lower_body[l]] = "<geom name=\"tip" + std::to_string(l) +
                              "\" type=\"sphere\" size=\"" + num(o.tip_radius) + "\" pos=\"0 0 " +
                              num(z) + "\" contype=\"0\" conaffinity=\"1\" condim=\"3\" " +
                              friction + "/>";
  return toMjcf(c.model, kMjcfNestPerFile, &x);
}

#ifdef MINV_HAVE_MUJOCO

MujocoCentipede::MujocoCentipede(const Centipede& c, const MujocoStepOptions& o)
    : c_(c), m_(compileMjcf(centipedeMjcf(c, o), "mujoco-step")) {
  const Model& model = c.model;
  const mjModel* m = m_.get();
  if (m->nv != model.nv() || m->nq != model.nq())
    throw std::runtime_error("mujoco-step: MuJoCo's model has nv = " + std::to_string(m->nv) +
                             ", nq = " + std::to_string(m->nq) + "; ours has " +
                             std::to_string(model.nv()) + ", " + std::to_string(model.nq()));
  d_ = MjDataPtr(mj_makeData(m));
  if (!d_) throw std::runtime_error("mujoco-step: could not create mjData (out of memory?)");
  // Our joint i is MuJoCo's joint "j<i>": its qpos address and DOFs.
  dof_.assign(model.nv(), -1);
  qpos_.assign(model.nb(), -1);
  for (int i = 0; i < model.nb(); ++i) {
    std::string name = "j";
    name += std::to_string(i);
    const int jid = mj_name2id(m, mjOBJ_JOINT, name.c_str());
    if (jid < 0) throw std::runtime_error("mujoco-step: joint '" + name + "' missing");
    const int dof = m->jnt_dofadr[jid], v = model.vIdx(i);
    qpos_[i] = m->jnt_qposadr[jid];
    if (model.joint(i).type == JointType::Floating) {
      const Pose<double>& P = model.joint(i).placement;
      if (i != 0 || !P.p.isZero(0) || !P.R.isIdentity(0))
        throw std::runtime_error("mujoco-step: a floating base must be body 0, unplaced");
      // Ours [ω; v], MuJoCo's [v; ω].
      for (int k = 0; k < 3; ++k) dof_[v + k] = dof + 3 + k, dof_[v + 3 + k] = dof + k;
      free_dof_ = dof;
    } else {
      for (int k = 0; k < model.nvOf(i); ++k) dof_[v + k] = dof + k;
    }
  }
  tau_mj_ = Eigen::VectorXd::Zero(model.nv());
}

// Body i's number of position coordinates (7 free, 4 ball, 1 hinge or slide), from the q layout.
static int nqOf(const Model& model, int i) {
  return (i + 1 < model.nb() ? model.qIdx(i + 1) : model.nq()) - model.qIdx(i);
}

void MujocoCentipede::setState(const Eigen::VectorXd& q, const Eigen::VectorXd& v) {
  const Model& model = c_.model;
  model.checkConfiguration(q);
  if (v.size() != model.nv()) throw std::invalid_argument("velocity has the wrong size");
  // Coordinates: the same numbers per joint (MuJoCo's free qpos is position, then w x y z).
  for (int i = 0; i < model.nb(); ++i) {
    const int nq = nqOf(model, i);
    for (int k = 0; k < nq; ++k) d_->qpos[qpos_[i] + k] = q(model.qIdx(i) + k);
  }
  // Velocities: permuted, the base's linear velocity turned into the world frame.
  for (int k = 0; k < model.nv(); ++k) d_->qvel[dof_[k]] = v(k);
  if (free_dof_ >= 0) {
    const Eigen::Quaterniond Q(q(3), q(4), q(5), q(6));
    Eigen::Map<Eigen::Vector3d>(d_->qvel + free_dof_) = Q.normalized() * v.segment<3>(3);
  }
  mj_forward(m_.get(), d_.get());
}

double MujocoCentipede::step(const Eigen::VectorXd& tau) {
  const Model& model = c_.model;
  // Joint torques by π; the floating base's stay zero.
  tau_mj_.setZero();
  for (int k = free_dof_ >= 0 ? 6 : 0; k < model.nv(); ++k) tau_mj_(dof_[k]) = tau(k);
  Eigen::Map<Eigen::VectorXd>(d_->qfrc_applied, model.nv()) = tau_mj_;
  // One step, timed alone.
  const auto t0 = std::chrono::steady_clock::now();
  mj_step(m_.get(), d_.get());
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

void MujocoCentipede::state(Eigen::VectorXd& q, Eigen::VectorXd& v) const {
  const Model& model = c_.model;
  q.resize(model.nq());
  v.resize(model.nv());
  for (int i = 0; i < model.nb(); ++i) {
    const int nq = nqOf(model, i);
    for (int k = 0; k < nq; ++k) q(model.qIdx(i) + k) = d_->qpos[qpos_[i] + k];
  }
  for (int k = 0; k < model.nv(); ++k) v(k) = d_->qvel[dof_[k]];
  if (free_dof_ >= 0) {
    const Eigen::Quaterniond Q(q(3), q(4), q(5), q(6));
    v.segment<3>(3) =
        Q.normalized().conjugate() * Eigen::Map<const Eigen::Vector3d>(d_->qvel + free_dof_);
  }
}

int MujocoCentipede::overflows() const {
  return d_->warning[mjWARN_CONTACTFULL].number + d_->warning[mjWARN_CNSTRFULL].number;
}

int MujocoCentipede::resets() const {
  return d_->warning[mjWARN_BADQPOS].number + d_->warning[mjWARN_BADQVEL].number +
         d_->warning[mjWARN_BADQACC].number;
}

Eigen::MatrixXd MujocoCentipede::massMatrix() const {
  const int nv = c_.model.nv();
  Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> Mmj(nv, nv);
  mj_fullM(m_.get(), Mmj.data(), d_->qM);
  // T: MuJoCo's qvel = T v.
  Eigen::MatrixXd T = Eigen::MatrixXd::Zero(nv, nv);
  for (int k = 0; k < nv; ++k) T(dof_[k], k) = 1;
  if (free_dof_ >= 0) {
    const mjtNum* w = d_->qpos + qpos_[0] + 3;  // body 0's orientation, w x y z
    T.block<3, 3>(free_dof_, 3) =
        Eigen::Quaterniond(w[0], w[1], w[2], w[3]).normalized().toRotationMatrix();
  }
  return T.transpose() * Mmj * T;
}

#endif  // MINV_HAVE_MUJOCO

}  // namespace minv::sim
