// A travelling-wave gait for the centipede (generators/centipede.hpp): joint PD control with
// bounded torques.
//
// Leg l of segment s on side σ (+1 left, −1 right) has phase φ = 2π f t − 2π s / wave + (σ < 0
// ? π : 0) (the wave runs from head to tail; the two legs of a segment alternate). Its hip
// target is R_d = Rz(σ·swing·sin φ) · Rx(σ·lift·max(0, −cos φ)): the leg sweeps backward
// while cos φ > 0 (stance, the tip on the ground pushes the body forward) and forward, lifted,
// while cos φ < 0 (swing). Hip torque (child frame) τ = kp·log(Rᵀ R_d) − kd·ω, knee and
// segment joints τ = kp·(0 − q) − kd·q̇; each joint's torque is clipped to its bound (the
// norm for a spherical joint). Amplitudes ramp up linearly over `ramp` seconds.
#pragma once

#include <Eigen/Core>
#include <vector>

#include "generators/centipede.hpp"
#include "sim/simulator.hpp"

namespace minv::sim {

struct GaitOptions {
  double frequency = 1.5;                             // Hz
  double wave = 6.0;                                  // wavelength in segments
  double swing = 0.35;                                // rad, yaw amplitude of a hip
  double lift = 0.35;                                 // rad, hip lift during swing
  double kp_hip = 6.0, kd_hip = 0.05, max_hip = 2.0;  // N·m/rad, N·m·s/rad, N·m
  double kp_knee = 6.0, kd_knee = 0.05, max_knee = 2.0;
  double kp_body = 4.0, kd_body = 0.1, max_body = 3.0;  // segment joints
  double ramp = 0.25;                                   // s
};

class CentipedeGait {
 public:
  CentipedeGait(const Centipede& c, GaitOptions o = {})
      : c_(c), o_(o), angle_(2 * c.legs()), sin_(2 * c.legs()), cos_(2 * c.legs()) {}
  void operator()(double t, const Eigen::VectorXd& q, const Eigen::VectorXd& v,
                  Eigen::VectorXd& tau) const;

 private:
  const Centipede& c_;
  GaitOptions o_;
  // Scratch for the legs' angles and their sines and cosines (all legs in one call): one
  // gait is not to be called from two threads at once (each walk owns its own).
  mutable std::vector<double> angle_, sin_, cos_;
};

// One contact point at every leg tip of the centipede, in leg order.
std::vector<ContactPoint> legTips(const Centipede& c);

// The centipede standing at rest, a contact point at every leg tip, driven by the gait.
class WalkingCentipede {
 public:
  WalkingCentipede(const Centipede& c, const SimOptions& so, GaitOptions g = {});
  Simulator& sim() { return sim_; }
  const Simulator& sim() const { return sim_; }

 private:
  CentipedeGait gait_;  // before sim_: the controller refers to it
  Simulator sim_;
};

}  // namespace minv::sim
