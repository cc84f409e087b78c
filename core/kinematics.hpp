// Kinematics at a configuration q, in the world ("global") frame, as the paper computes it.
//
// Stage "spatial axes": body poses ⁰X_i and each joint's motion subspace S_i (6×k, one column
// per DOF) in world coordinates. Stage "isolated inertias": each body's spatial inertia I_i in
// world coordinates, about the world origin. Parametrisation of q: see core/model.hpp.
//
// Origin::EachRoot keeps the world's axes but puts the origin at each tree's root joint (the
// translation of a root's placement, or a floating base's position, is dropped). M and M⁻¹ do
// not depend on where a tree stands, and world-frame products such as p × ω and m·c·cᵀ lose
// accuracy as ε·(|p|/ℓ)² far from the origin (ℓ the tree's size: 1e-8 relative at 10 km for a
// 1 m robot), so every solver uses it; the simulator, which needs positions in the world, does
// not. The dropped translation is still computed, so flop counts are the same in both.
// Cost: Θ(nb); no allocation after the Kinematics object is built.
#pragma once

#include <algorithm>
#include <cmath>
#include <type_traits>
#include <vector>

#include "core/counting.hpp"
#include "core/model.hpp"
#include "core/sincos.hpp"
#include "core/spatial.hpp"

namespace minv {

template <class T>
using VecX = Eigen::Matrix<T, Eigen::Dynamic, 1>;
template <class T>
using MatX = Eigen::Matrix<T, Eigen::Dynamic, Eigen::Dynamic>;
template <class T>
using Mat6N = Eigen::Matrix<T, 6, Eigen::Dynamic>;

// Where the frame of a Kinematics object has its origin (its axes are always the world's).
enum class Origin { World, EachRoot };

// Per body: the revolute joint's placement rotation P split by Rodrigues' formula, so that
//   P·exp(θ ã) = Pa + cos θ·Pc + sin θ·Ps,  Pa = P a aᵀ, Pc = P (1 − a aᵀ), Ps = P ã,
// constant for the tree (zero for other joints); built with the Kinematics object.
template <class T>
struct RevoluteSplit {
  Mat3<T> Pa = Mat3<T>::Zero(), Pc = Mat3<T>::Zero(), Ps = Mat3<T>::Zero();
};

// Built for one model (its revolute splits are that model's): not to be reused for another.
template <class T>
struct Kinematics {
  std::vector<Pose<T>> X;  // body i's pose in the world
  Mat6N<T> S;              // motion subspaces in world coordinates, column k for DOF k
  std::vector<Mat6<T>> I;  // body spatial inertias in world coordinates
  Origin origin;           // World, or each tree's root joint
  VecX<T> sinq, cosq;      // on doubles, sin and cos of each coordinate of q (jointSinCos)
  std::vector<RevoluteSplit<T>> split;  // per body, for revolute joints

  explicit Kinematics(const Model& m, Origin o = Origin::World)
      : X(m.nb()),
        S(Mat6N<T>::Zero(6, m.nv())),
        I(m.nb()),
        origin(o),
        sinq(VecX<T>::Zero(std::is_same_v<T, double> ? m.nq() : 0)),
        cosq(VecX<T>::Zero(std::is_same_v<T, double> ? m.nq() : 0)),
        split(m.nb()) {
    for (int i = 0; i < m.nb(); ++i) {
      const Joint& j = m.joint(i);
      if (j.type != JointType::Revolute) continue;
      const Eigen::Matrix3d P = j.placement.R, aa = j.axis * j.axis.transpose();
      split[i].Pa = (P * aa).cast<T>();
      split[i].Pc = (P * (Eigen::Matrix3d::Identity() - aa)).cast<T>();
      split[i].Ps = (P * skew<double>(j.axis)).cast<T>();
    }
  }
};

// Rotation of the quaternion (w, x, y, z) after normalising it: with s = 2/|q|², entries such
// as 1 − s(y² + z²) and s(xy − wz), which is the unit quaternion's rotation without its
// square root. 16 mul, 1 div.
template <class T>
MINV_INLINE Mat3<T> quatToRotation(T w, T x, T y, T z) {
  const T s = T(2) / (w * w + x * x + y * y + z * z);
  const T xs = x * s, ys = y * s, zs = z * s;
  const T wx = w * xs, wy = w * ys, wz = w * zs;
  const T xx = x * xs, xy = x * ys, xz = x * zs;
  const T yy = y * ys, yz = y * zs, zz = z * zs;
  Mat3<T> R;
  R << T(1) - (yy + zz), xy - wz, xz + wy,  //
      xy + wz, T(1) - (xx + zz), yz - wx,   //
      xz - wy, yz + wx, T(1) - (xx + yy);
  return R;
}

// On doubles, sin and cos of every coordinate of q into kin.sinq, kin.cosq, in one vectorised
// loop (core/sincos.hpp; only the revolute joints' are read). Any other scalar (the counting
// one, long double) takes each joint's sin and cos at its body instead (localPose), so that
// counts stay per body.
template <class T>
void jointSinCos(const VecX<T>& q, Kinematics<T>& kin) {
  if constexpr (std::is_same_v<T, double>) {
    const auto n = std::min(q.size(), kin.sinq.size());
    sinCos(q.data(), static_cast<int>(n), kin.sinq.data(), kin.cosq.data());
  }
}

// Poses below are plain arrays: a rotation R as 9 entries, column-major (Eigen's order), a
// translation p as 3. The per-body steps are scalar code on them, so that a chain keeps its
// poses in registers; the results go to kin (Eigen) once.

// C = A·B (3×3).
template <class T, class U>
MINV_INLINE void mul33(const T* A, const U* B, T* C) {
  for (int c = 0; c < 3; ++c)
    for (int r = 0; r < 3; ++r)
      C[r + 3 * c] = A[r] * T(B[3 * c]) + A[r + 3] * T(B[3 * c + 1]) + A[r + 6] * T(B[3 * c + 2]);
}

// y = x + A·b (3×3, 3).
template <class T, class U>
MINV_INLINE void mulAdd3(const T* x, const T* A, const U* b, T* y) {
  for (int r = 0; r < 3; ++r)
    y[r] = x[r] + A[r] * T(b[0]) + A[r + 3] * T(b[1]) + A[r + 6] * T(b[2]);
}

// y = A·b (3×3, 3).
template <class T, class U>
MINV_INLINE void mul3(const T* A, const U* b, T* y) {
  for (int r = 0; r < 3; ++r) y[r] = A[r] * T(b[0]) + A[r + 3] * T(b[1]) + A[r + 6] * T(b[2]);
}

// The joint's pose in its parent's frame, placement · X_J(q_i), into (L, l); a revolute
// joint's sin and cos come from kin on doubles (jointSinCos), its rotation from the split
// placement.
template <class T>
MINV_INLINE void localPose(const Model& model, const VecX<T>& q, const Kinematics<T>& kin, int i,
                           T* L, T* l) {
  const Joint& j = model.joint(i);
  const int o = model.qIdx(i);
  const double* P = j.placement.R.data();
  const double* pp = j.placement.p.data();
  switch (j.type) {
    case JointType::Revolute: {
      // P·exp(θ ã) = Pa + cos θ·Pc + sin θ·Ps; the joint does not move the origin.
      const RevoluteSplit<T>& r = kin.split[i];
      using std::cos;
      using std::sin;
      T c, s;
      if constexpr (std::is_same_v<T, double>)
        c = kin.cosq(o), s = kin.sinq(o);
      else
        c = cos(q(o)), s = sin(q(o));
      for (int k = 0; k < 9; ++k) L[k] = r.Pa.data()[k] + c * r.Pc.data()[k] + s * r.Ps.data()[k];
      for (int k = 0; k < 3; ++k) l[k] = T(pp[k]);
      return;
    }
    case JointType::Prismatic: {
      // The rotation is the placement's; the origin moves by q along P·a.
      const T d[3] = {T(j.axis(0)) * q(o), T(j.axis(1)) * q(o), T(j.axis(2)) * q(o)};
      for (int k = 0; k < 9; ++k) L[k] = T(P[k]);
      const T p0[3] = {T(pp[0]), T(pp[1]), T(pp[2])};
      mulAdd3(p0, L, d, l);
      return;
    }
    case JointType::Spherical: {
      const Mat3<T> J = quatToRotation<T>(q(o), q(o + 1), q(o + 2), q(o + 3));
      const Mat3<T> Pt = j.placement.R.cast<T>();
      mul33(Pt.data(), J.data(), L);
      for (int k = 0; k < 3; ++k) l[k] = T(pp[k]);
      return;
    }
    case JointType::Floating:
    default: {
      const Mat3<T> J = quatToRotation<T>(q(o + 3), q(o + 4), q(o + 5), q(o + 6));
      const Mat3<T> Pt = j.placement.R.cast<T>();
      mul33(Pt.data(), J.data(), L);
      const T p0[3] = {T(pp[0]), T(pp[1]), T(pp[2])};
      mulAdd3(p0, Pt.data(), q.data() + o, l);
      return;
    }
  }
}

// S_i from body i's world pose (R, p): the joint's body-frame subspace in world coordinates,
// [R e; p × R e] for a rotation axis e, [0; R e] for a translation.
template <class T>
MINV_INLINE void motionSubspace(const Model& model, const T* R, const T* p, Kinematics<T>& kin,
                                int i) {
  const Joint& j = model.joint(i);
  T* S = kin.S.col(model.vIdx(i)).data();
  // One column of S from a world direction w: a rotation about it through p, or a translation.
  auto column = [&](const T* w, bool rotation, T* s) {
    if (!rotation) {
      s[0] = s[1] = s[2] = T(0);
      s[3] = w[0], s[4] = w[1], s[5] = w[2];
      return;
    }
    s[0] = w[0], s[1] = w[1], s[2] = w[2];
    s[3] = p[1] * w[2] - p[2] * w[1];
    s[4] = p[2] * w[0] - p[0] * w[2];
    s[5] = p[0] * w[1] - p[1] * w[0];
  };
  T w[3];
  switch (j.type) {
    case JointType::Revolute:
    case JointType::Prismatic:
      mul3(R, j.axis.data(), w);
      column(w, j.type == JointType::Revolute, S);
      break;
    case JointType::Spherical:
      for (int c = 0; c < 3; ++c) column(R + 3 * c, true, S + 6 * c);
      break;
    case JointType::Floating:
      for (int c = 0; c < 3; ++c) {
        column(R + 3 * c, true, S + 6 * c);
        column(R + 3 * c, false, S + 6 * (3 + c));
      }
      break;
  }
}

// I_i about the world origin from body i's world pose (R, p), as mcI (core/spatial.hpp) with
// m, c = p + R·c_body and R Ī Rᵀ: R Ī, then one triangle of (R Ī) Rᵀ, the only one mcI reads.
template <class T>
MINV_INLINE void worldInertia(const Model& model, const T* R, const T* p, Kinematics<T>& kin,
                              int i) {
  const Body& b = model.body(i);
  T c[3], RI[9], Ic[9];
  mulAdd3(p, R, b.com.data(), c);
  mul33(R, b.inertia.data(), RI);
  for (int j = 0; j < 3; ++j)
    for (int r = j; r < 3; ++r)
      Ic[r + 3 * j] = RI[r] * R[j] + RI[r + 3] * R[j + 3] + RI[r + 6] * R[j + 6];
  mcI<T>(T(b.mass), c, Ic, kin.I[i].data());
}

// ⁰X_i = ⁰X_λ(i) · (L, l) for a body with a parent: R = R_λ L, p = p_λ + R_λ l.
template <class T>
MINV_INLINE void composePose(const T* Rp, const T* pp, const T* L, const T* l, T* R, T* p) {
  mul33(Rp, L, R);
  mulAdd3(pp, Rp, l, p);
}

// Stages "spatial axes" (poses ⁰X_i and world-frame motion subspaces S_i) and "isolated
// inertias" (I_i), one mark each per body. Each body is done whole, parents first, its parent's
// pose still in registers along a chain. On one thread: splitting the per-body steps among
// OpenMP threads (the composition along the tree in order) made abi's configure 2.2-2.5×
// slower on two threads of a 2-vCPU Zen 5 guest at n = 512 … 2048 (poses crossing between
// the cores, three barriers), and the simulator's kinematics never gained by it either.
template <class T, class Mark>
void computeKinematics(const Model& model, const VecX<T>& q, Kinematics<T>& kin, Mark&& mark) {
  const int nb = model.nb();
  const bool each_root = kin.origin == Origin::EachRoot;
  // sin and cos of the joint angles, all at once
  jointSinCos(q, kin);
  T R[9] = {}, p[3] = {};  // ⁰X of the body just done
  for (int i = 0; i < nb; ++i) {
    const int parent = model.parent(i);
    // the joint's pose in its parent's frame
    T L[9], l[3];
    localPose(model, q, kin, i, L, l);
    // ⁰X_i = ⁰X_λ(i) · (L, l); along a chain the parent's pose is the one just done
    T Ri[9], pi[3];
    if (parent == i - 1 && parent >= 0) {
      composePose(R, p, L, l, Ri, pi);
    } else if (parent >= 0) {
      composePose(kin.X[parent].R.data(), kin.X[parent].p.data(), L, l, Ri, pi);
    } else {
      for (int k = 0; k < 9; ++k) Ri[k] = L[k];
      for (int k = 0; k < 3; ++k) pi[k] = each_root ? T(0) : l[k];
    }
    for (int k = 0; k < 9; ++k) R[k] = Ri[k], kin.X[i].R.data()[k] = Ri[k];
    for (int k = 0; k < 3; ++k) p[k] = pi[k], kin.X[i].p.data()[k] = pi[k];
    // S_i
    motionSubspace(model, Ri, pi, kin, i);
    mark("spatial axes");
    // I_i
    worldInertia(model, Ri, pi, kin, i);
    mark("isolated inertias");
  }
}

// Both stages without marks.
template <class T>
void computeKinematics(const Model& model, const VecX<T>& q, Kinematics<T>& kin) {
  computeKinematics(model, q, kin, NoMark{});
}

}  // namespace minv
