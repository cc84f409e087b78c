// Articulated-body inertias about each joint's origin, with the projector form of the downdate:
// the same U, D⁻¹, U D⁻¹ and couplings as articulatedInertias (core/articulated.hpp), in the
// world frame the sweeps read, to far smaller rounding errors on long chains.
//
// RBDA §7.2-7.3 (Table 7.1, pass 2) with two changes of form, neither of the result:
//   - body i's inertias are taken about its joint's origin p_i (world axes), not the world
//     origin: I_i = mcI(m, R c, R Ī Rᵀ) with c the body-frame centre of mass, and S_i there is
//     [R a; 0] for a rotation axis, [0; R a] for a translation; a child's term moves to its
//     parent's origin by Xᵀ Ia X, X = [1 0; −d̃ 1], d = p_i − p_λ(i);
//   - Ia = Pᵀ (IA P), P = 1 − S (U D⁻¹)ᵀ, where the world-frame pass forms IA − U D⁻¹ Uᵀ.
// U and U D⁻¹ then go to the world frame, [n + p × f; f], for the unchanged impulse sweeps.
// On seed-1 random chains (paper/ENGINEERING.md, "## Accuracy") the impulse sweeps' M⁻¹ from
// this pass in double has a relative error of 8.8e-15 at n = 1024 serial, where the world-frame
// pass's has 3.8e-12; neither change alone does it, nor P's product expanded.
// Used for the accuracy experiment's reference (experiments/lib/accuracy.cpp), in long double;
// not abi's pass: written with dense 6×6 products (several times the world pass's operations),
// not regrouped, not vectorised.
// Contract: kin from computeKinematics (its X, S; any Origin); art for the same model.
// Cost Θ(nb); no allocation (fixed-size blocks of at most 6).
#pragma once

#include <stdexcept>
#include <string>
#include <vector>

#include "core/articulated.hpp"
#include "core/kinematics.hpp"

namespace minv {

// Scratch: one IA per body, about its joint's origin.
template <class T>
struct JointArticulatedWorkspace {
  std::vector<Mat6<T>> IA;
  explicit JointArticulatedWorkspace(const Model& m) : IA(m.nb()) {}
};

// Whether column c of joint j's S is a rotation (else a translation).
inline bool rotationColumn(const Joint& j, int c) {
  return j.type == JointType::Revolute || j.type == JointType::Spherical ||
         (j.type == JointType::Floating && c < 3);
}

// Stage "articulated inertias" about each joint's origin (see above): art.U, art.UDinv,
// art.Dinv, art.dinv and art.couple as articulatedInertias writes them (art.IA is not written).
template <class T>
void articulatedInertiasAtJoints(const Model& model, const Kinematics<T>& kin, Articulated<T>& art,
                                 JointArticulatedWorkspace<T>& ws) {
  using V3 = Vec3<T>;
  const int nb = model.nb();
  // I_i about p_i: mcI with the centre of mass relative to the joint's origin.
  for (int i = 0; i < nb; ++i) {
    const Mat3<T> R = kin.X[i].R;
    const Body& b = model.body(i);
    const V3 c = R * b.com.cast<T>();
    const Mat3<T> Ic = R * b.inertia.cast<T>() * R.transpose();
    ws.IA[i] = mcI<T>(T(b.mass), c, Ic);
  }
  for (int i = nb - 1; i >= 0; --i) {
    const int v = model.vIdx(i), k = model.nvOf(i), p = model.parent(i);
    const Joint& joint = model.joint(i);
    const Mat6<T>& IA = ws.IA[i];
    // S about p_i: the world-frame columns without their moment about the world origin.
    Vec6<T> S[6], U[6], UD[6];
    for (int c = 0; c < k; ++c) {
      S[c] = kin.S.col(v + c);
      if (rotationColumn(joint, c))
        S[c].template tail<3>().setZero();
      else
        S[c].template head<3>().setZero();
      U[c] = IA * S[c];
    }
    // D = Sᵀ U, D⁻¹ and U D⁻¹ (as articulatedStep)
    Eigen::Matrix<T, 6, 6> D;
    for (int r = 0; r < k; ++r)
      for (int c = 0; c < k; ++c) D(r, c) = S[r].dot(U[c]);
    forJointSize(k, [&](auto K) {
      constexpr int N = decltype(K)::value;
      // (Every joint type has 1, 3 or 6 DOFs.)
      if constexpr (N == Eigen::Dynamic) {
        throw std::logic_error("articulatedInertiasAtJoints: a joint of " + std::to_string(k) +
                               " DOFs");
      } else {
        auto Dinv = art.Dinv[i].template topLeftCorner<N, N>(k, k);
        jointInverse<T, N>(D, k, Dinv, U, UD);
        if constexpr (N == 1) art.dinv(v) = Dinv(0, 0);
      }
    });
    // U and U D⁻¹ in the world frame: a force [n; f] about p_i is [n + p_i × f; f].
    const V3 pi = kin.X[i].p;
    auto world = [&](const Vec6<T>& f) {
      Vec6<T> w;
      const V3 lin = f.template tail<3>();
      w.template head<3>() = f.template head<3>() + pi.cross(lin);
      w.template tail<3>() = lin;
      return w;
    };
    for (int c = 0; c < k; ++c) {
      art.U.col(v + c) = world(U[c]);
      art.UDinv.col(v + c) = world(UD[c]);
    }
    if (p < 0) continue;
    // Ia = Pᵀ (IA P), P = 1 − S (U D⁻¹)ᵀ
    Mat6<T> P = Mat6<T>::Identity();
    for (int c = 0; c < k; ++c) P -= S[c] * UD[c].transpose();
    const Mat6<T> IAP = IA * P;
    const Mat6<T> Ia = P.transpose() * IAP;
    // to the parent's origin: Xᵀ Ia X, X = [1 0; −d̃ 1], d = p_i − p_λ
    const V3 d = pi - V3(kin.X[p].p);
    Mat6<T> X = Mat6<T>::Identity();
    X.template block<3, 3>(3, 0) = -skew<T>(d);
    ws.IA[p] += X.transpose() * Ia * X;
  }
  // The couplings c_i = −S_λᵀ U_i D_i⁻¹ (world frame) of consecutive one-DOF links.
  for (int i = 1; i < nb; ++i) {
    const int v = model.vIdx(i);
    if (model.nvOf(i) == 1 && model.parent(i) == i - 1 && model.nvOf(i - 1) == 1)
      art.couple(v) = -kin.S.col(v - 1).dot(art.UDinv.col(v));
  }
}

}  // namespace minv
