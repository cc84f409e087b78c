#include "sim/gait.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <numbers>

#include "core/sincos.hpp"

namespace minv::sim {

namespace {
void clipNorm(Eigen::Ref<Eigen::VectorXd> tau, double bound) {
  const double n = tau.norm();
  if (n > bound) tau *= bound / n;
}
}  // namespace

void CentipedeGait::operator()(double t, const Eigen::VectorXd& q, const Eigen::VectorXd& v,
                               Eigen::VectorXd& tau) const {
  const Model& m = c_.model;
  const double ramp = o_.ramp > 0 ? std::min(1.0, t / o_.ramp) : 1.0;
  // Segment joints: hold straight.
  for (int s = 1; s < static_cast<int>(c_.segment_body.size()); ++s) {
    const int b = c_.segment_body[s], qi = m.qIdx(b), vi = m.vIdx(b);
    if (m.nvOf(b) == 1) {
      tau(vi) = std::clamp(-o_.kp_body * q(qi) - o_.kd_body * v(vi), -o_.max_body, o_.max_body);
    } else {
      const Eigen::Quaterniond Q(q(qi), q(qi + 1), q(qi + 2), q(qi + 3));
      const Eigen::AngleAxisd e(Q.conjugate().normalized());
      tau.segment<3>(vi) = o_.kp_body * e.angle() * e.axis() - o_.kd_body * v.segment<3>(vi);
      clipNorm(tau.segment<3>(vi), o_.max_body);
    }
  }
  // Every leg's phase φ, then its hip target R_d = Rz(yaw)·Rx(lift) as the quaternion
  // (cz cx, cz sx, sz sx, sz cx) of the half angles: the sines and cosines of all legs at once.
  const int legs = c_.legs();
  for (int l = 0; l < legs; ++l)
    angle_[l] = 2 * std::numbers::pi * (o_.frequency * t - c_.leg_segment[l] / o_.wave) +
                (Centipede::side(l) < 0 ? std::numbers::pi : 0.0);
  sinCos(angle_.data(), legs, sin_.data(), cos_.data());
  for (int l = 0; l < legs; ++l) {
    const double side = Centipede::side(l);
    const double yaw = ramp * side * o_.swing * sin_[l];
    const double lift = ramp * side * o_.lift * std::max(0.0, -cos_[l]);
    angle_[l] = 0.5 * yaw, angle_[legs + l] = 0.5 * lift;
  }
  sinCos(angle_.data(), 2 * legs, sin_.data(), cos_.data());
  for (int l = 0; l < legs; ++l) {
    const double cz = cos_[l], sz = sin_[l], cx = cos_[legs + l], sx = sin_[legs + l];
    const Eigen::Quaterniond Qd(cz * cx, cz * sx, sz * sx, sz * cx);
    // Hip.
    const int hb = c_.upper_body[l], qh = m.qIdx(hb), vh = m.vIdx(hb);
    const Eigen::Quaterniond Q(q(qh), q(qh + 1), q(qh + 2), q(qh + 3));
    Eigen::Quaterniond E = Q.normalized().conjugate() * Qd;
    if (E.w() < 0) E.coeffs() = -E.coeffs();
    const Eigen::AngleAxisd e(E);
    tau.segment<3>(vh) = o_.kp_hip * e.angle() * e.axis() - o_.kd_hip * v.segment<3>(vh);
    clipNorm(tau.segment<3>(vh), o_.max_hip);
    // Knee.
    const int kb = c_.lower_body[l], qk = m.qIdx(kb), vk = m.vIdx(kb);
    tau(vk) = std::clamp(-o_.kp_knee * q(qk) - o_.kd_knee * v(vk), -o_.max_knee, o_.max_knee);
  }
}

std::vector<ContactPoint> legTips(const Centipede& c) {
  std::vector<ContactPoint> tips;
  for (int l = 0; l < c.legs(); ++l) tips.push_back({c.lower_body[l], c.tip});
  return tips;
}

WalkingCentipede::WalkingCentipede(const Centipede& c, const SimOptions& so, GaitOptions g)
    : gait_(c, g), sim_(c.model, legTips(c), so) {
  // The controller and the standing start.
  sim_.setController([this](double t, const Eigen::VectorXd& q, const Eigen::VectorXd& v,
                            Eigen::VectorXd& tau) { gait_(t, q, v, tau); });
  sim_.setState(centipedeStanding(c), Eigen::VectorXd::Zero(c.model.nv()));
}

}  // namespace minv::sim
