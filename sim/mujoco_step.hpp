// `mujoco-step`: the same centipede walked by MuJoCo 2.2.2 itself (mj_step), timed beside our
// contact-space paths in Figure 4 (experiments/lib/centipede_run.hpp). It is no Simulator path
// (simulationPaths() lists those) but its own engine: MuJoCo's collision, its soft contact
// constraints (solref, solimp: MuJoCo's defaults) and its PGS solve in one call per step.
//
// The model (centipedeMjcf). toMjcf's tree (generators/mjcf.hpp: the same masses, inertias,
// joints and placements; body i is "b<i>", its joint "j<i>") plus
//   a ground plane at z = 0 (contype 1, conaffinity 0) and, in every lower leg, a sphere of
//   radius r at (0, 0, −lower_length + r) (contype 0, conaffinity 1): it touches the plane
//   exactly where our contact point, the tip (0, 0, −lower_length), does on a vertical leg;
//   only sphere–plane pairs can collide, at most one contact per leg;
//   <option timestep = dt, gravity = ours, integrator Euler (semi-implicit, as ours),
//   cone pyramidal (condim 3: 4 edges ↔ our linearised cone of 4 directions), solver PGS>;
//   friction μ on the plane and the spheres (MuJoCo takes the larger of the two);
//   <size nconmax = L + 100, njmax = 4·nconmax + 100> for L legs: MuJoCo 2.2.2 keeps 100
//   contacts by default and drops more with only a warning (mjWARN_CONTACTFULL).
// Coordinates (MujocoCentipede). Our DOF k is MuJoCo's DOF π(k) (by joint name); the free
// joint's velocity is MuJoCo's [v (world); ω (body)] against our [ω; v] in the body frame, so
// v_mj = R v; hinge and ball coordinates are the same (ball: quaternion w x y z, angular
// velocity in the child frame). Generalized forces go into qfrc_applied by π; the floating
// base (body 0, without placement, as the centipede's) gets none (the gait applies none).
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

#include "generators/centipede.hpp"
#include "generators/mjcf.hpp"

namespace minv::sim {

constexpr const char* kMujocoStepPath = "mujoco-step";

// Whether this build has MuJoCo (the path needs it).
bool haveMujocoStep();

struct MujocoStepOptions {
  double dt = 1e-5;
  Eigen::Vector3d gravity = Eigen::Vector3d(0, 0, -9.81);
  double mu = 0.8;
  double tip_radius = 0.01;  // m
};

// The centipede's MJCF for MuJoCo's own stepping (the model at the top of this file).
std::vector<MjcfFile> centipedeMjcf(const Centipede& c, const MujocoStepOptions& o);

#ifdef MINV_HAVE_MUJOCO
class MujocoCentipede {
 public:
  // Compiles centipedeMjcf and allocates mjData; ModelError or std::runtime_error with
  // MuJoCo's reason. The centipede must outlive this object.
  MujocoCentipede(const Centipede& c, const MujocoStepOptions& o);

  // Our q and v into qpos and qvel, then mj_forward.
  void setState(const Eigen::VectorXd& q, const Eigen::VectorXd& v);
  // τ (ours; the floating base's entries are ignored) into qfrc_applied, then one mj_step;
  // returns the seconds mj_step took (steady_clock).
  double step(const Eigen::VectorXd& tau);
  // The state in our coordinates.
  void state(Eigen::VectorXd& q, Eigen::VectorXd& v) const;
  double time() const { return d_->time; }
  int contacts() const { return d_->ncon; }
  // Contacts or constraint rows MuJoCo dropped for lack of room (its CONTACTFULL and
  // CNSTRFULL warnings): 0 when nconmax and njmax suffice.
  int overflows() const;
  // Times MuJoCo reset the state for a non-finite or huge qpos, qvel or qacc (its BADQPOS,
  // BADQVEL, BADQACC warnings): a diverged simulation, which MuJoCo restarts silently.
  int resets() const;
  // MuJoCo's M at the current state (mj_fullM; after setState or step), in our coordinates:
  // Tᵀ M_mj T with MuJoCo's qvel = T v. Allocates.
  Eigen::MatrixXd massMatrix() const;
  const mjModel* model() const { return m_.get(); }
  const mjData* data() const { return d_.get(); }

 private:
  const Centipede& c_;
  MjModelPtr m_;
  MjDataPtr d_;
  std::vector<int> dof_;   // our DOF k → MuJoCo's DOF π(k)
  std::vector<int> qpos_;  // our body i → its joint's qpos address
  int free_dof_ = -1;      // MuJoCo's first (linear) DOF of the free joint
  Eigen::VectorXd tau_mj_;
};
#endif

}  // namespace minv::sim
