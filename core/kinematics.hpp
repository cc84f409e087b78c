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

// Per body, the tree's constants that its kinematics reads, as 4-entry columns (the fourth entry
// zero) that Three::load4 takes whole: the revolute joint's placement rotation P split by
// Rodrigues' formula,
//   P·exp(θ ã) = Pa + cos θ·Pc + sin θ·Ps,  Pa = P a aᵀ, Pc = P (1 − a aᵀ), Ps = P ã
// (zero for other joints), P itself, the joint's placement origin and axis, and the body's
// centre of mass and rotational inertia Ī about it; built with the Kinematics object.
template <class T>
struct BodyColumns {
  using Col = Eigen::Matrix<T, 4, 1>;
  using Cols = Eigen::Matrix<T, 4, 3>;
  Cols Pa = Cols::Zero(), Pc = Cols::Zero(), Ps = Cols::Zero(), P = Cols::Zero();
  Cols inertia = Cols::Zero();
  Col origin = Col::Zero(), axis = Col::Zero(), com = Col::Zero();
};

// Built for one model (its constants are that model's): not to be reused for another.
template <class T>
struct Kinematics {
  std::vector<Pose<T>> X;  // body i's pose in the world
  Mat6N<T> S;              // motion subspaces in world coordinates, column k for DOF k
  std::vector<Mat6<T>> I;  // body spatial inertias in world coordinates
  Origin origin;           // World, or each tree's root joint
  VecX<T> sinq, cosq;      // on doubles, sin and cos of each coordinate of q (jointSinCos)
  std::vector<BodyColumns<T>> cols;  // per body

  explicit Kinematics(const Model& m, Origin o = Origin::World)
      : X(m.nb()),
        S(Mat6N<T>::Zero(6, m.nv())),
        I(m.nb()),
        origin(o),
        sinq(VecX<T>::Zero(std::is_same_v<T, double> ? m.nq() : 0)),
        cosq(VecX<T>::Zero(std::is_same_v<T, double> ? m.nq() : 0)),
        cols(m.nb()) {
    for (int i = 0; i < m.nb(); ++i) {
      const Joint& j = m.joint(i);
      const Body& b = m.body(i);
      BodyColumns<T>& c = cols[i];
      const Eigen::Matrix3d P = j.placement.R;
      c.P.template topRows<3>() = P.cast<T>();
      c.origin.template head<3>() = j.placement.p.cast<T>();
      c.axis.template head<3>() = j.axis.cast<T>();
      c.com.template head<3>() = b.com.cast<T>();
      c.inertia.template topRows<3>() = b.inertia.cast<T>();
      if (j.type != JointType::Revolute) continue;
      // The split in T's precision where T is wider than double (long double, the accuracy
      // reference's), else in double (the counting scalar counts no constant).
      using W = std::conditional_t<std::is_floating_point_v<T>, T, double>;
      const Mat3<W> Pw = P.cast<W>();
      const Vec3<W> a = j.axis.cast<W>();
      const Mat3<W> aa = a * a.transpose();
      c.Pa.template topRows<3>() = (Pw * aa).template cast<T>();
      c.Pc.template topRows<3>() = (Pw * (Mat3<W>::Identity() - aa)).template cast<T>();
      c.Ps.template topRows<3>() = (Pw * skew<W>(a)).template cast<T>();
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

// Poses below are columns (Three, core/spatial.hpp): a rotation R as its 3 columns, a
// translation p as one. The per-body steps are column operations on them, so that a chain keeps
// its poses in registers; the results go to kin (Eigen) once.

// The 4-entry column k of a BodyColumns matrix.
template <class T>
MINV_INLINE Three<T> col4(const Eigen::Matrix<T, 4, 3>& M, int k) {
  return Three<T>::load4(M.data() + 4 * k);
}

// y = x + A·b: ((x + A₀b₀) + A₁b₁) + A₂b₂ (3×3 as columns, 3).
template <class T, class B>
MINV_INLINE Three<T> mulAdd3(const Three<T>& x, const Three<T>* A, const B& b) {
  return x + A[0] * T(b[0]) + A[1] * T(b[1]) + A[2] * T(b[2]);
}

// y = A·b: (A₀b₀ + A₁b₁) + A₂b₂.
template <class T, class B>
MINV_INLINE Three<T> mul3(const Three<T>* A, const B& b) {
  return A[0] * T(b[0]) + A[1] * T(b[1]) + A[2] * T(b[2]);
}

// C = A·B (3×3 as columns): column k of C is A·(column k of B).
template <class T>
MINV_INLINE void mul33(const Three<T>* A, const Three<T>* B, Three<T>* C) {
  for (int k = 0; k < 3; ++k) C[k] = mul3(A, B[k]);
}

// A rotation matrix as columns.
template <class T>
MINV_INLINE void columns(const Mat3<T>& R, Three<T>* C) {
  for (int k = 0; k < 3; ++k) C[k] = Three<T>::load(R.data() + 3 * k);
}

// The joint's pose in its parent's frame, placement · X_J(q_i), into (L, l); a revolute
// joint's sin and cos come from kin on doubles (jointSinCos), its rotation from the split
// placement.
template <class T>
MINV_INLINE void localPose(const Model& model, const VecX<T>& q, const Kinematics<T>& kin, int i,
                           Three<T>* L, Three<T>& l) {
  const Joint& j = model.joint(i);
  const BodyColumns<T>& bc = kin.cols[i];
  const int o = model.qIdx(i);
  const Three<T> origin = Three<T>::load4(bc.origin.data());
  switch (j.type) {
    case JointType::Revolute: {
      // P·exp(θ ã) = Pa + cos θ·Pc + sin θ·Ps; the joint does not move the origin.
      using std::cos;
      using std::sin;
      T c, s;
      if constexpr (std::is_same_v<T, double>)
        c = kin.cosq(o), s = kin.sinq(o);
      else
        c = cos(q(o)), s = sin(q(o));
      for (int k = 0; k < 3; ++k) L[k] = col4(bc.Pa, k) + col4(bc.Pc, k) * c + col4(bc.Ps, k) * s;
      l = origin;
      return;
    }
    case JointType::Prismatic: {
      // The rotation is the placement's; the origin moves by q along P·a.
      const T d[3] = {bc.axis(0) * q(o), bc.axis(1) * q(o), bc.axis(2) * q(o)};
      for (int k = 0; k < 3; ++k) L[k] = col4(bc.P, k);
      l = mulAdd3(origin, L, d);
      return;
    }
    case JointType::Spherical: {
      const Mat3<T> J = quatToRotation<T>(q(o), q(o + 1), q(o + 2), q(o + 3));
      const Three<T> P[3] = {col4(bc.P, 0), col4(bc.P, 1), col4(bc.P, 2)};
      for (int k = 0; k < 3; ++k) L[k] = mul3(P, J.col(k));
      l = origin;
      return;
    }
    case JointType::Floating:
    default: {
      const Mat3<T> J = quatToRotation<T>(q(o + 3), q(o + 4), q(o + 5), q(o + 6));
      const Three<T> P[3] = {col4(bc.P, 0), col4(bc.P, 1), col4(bc.P, 2)};
      for (int k = 0; k < 3; ++k) L[k] = mul3(P, J.col(k));
      l = mulAdd3(origin, P, q.data() + o);
      return;
    }
  }
}

// S_i from body i's world pose (R, p): the joint's body-frame subspace in world coordinates,
// [R e; p × R e] for a rotation axis e, [0; R e] for a translation.
template <class T>
MINV_INLINE void motionSubspace(const Model& model, const Three<T>* R, const Three<T>& p,
                                Kinematics<T>& kin, int i) {
  const Joint& j = model.joint(i);
  T* S = kin.S.col(model.vIdx(i)).data();
  // One column of S from a world direction w: a rotation about it through p, or a translation.
  auto column = [&](const Three<T>& w, bool rotation, T* s) {
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
  switch (j.type) {
    case JointType::Revolute:
    case JointType::Prismatic:
      column(mul3(R, kin.cols[i].axis), j.type == JointType::Revolute, S);
      break;
    case JointType::Spherical:
      for (int c = 0; c < 3; ++c) column(R[c], true, S + 6 * c);
      break;
    case JointType::Floating:
      for (int c = 0; c < 3; ++c) {
        column(R[c], true, S + 6 * c);
        column(R[c], false, S + 6 * (3 + c));
      }
      break;
  }
}

// I_i about the world origin from body i's world pose (R, p), as mcI (core/spatial.hpp) with
// m, c = p + R·c_body and R Ī Rᵀ: R Ī, then one triangle of (R Ī) Rᵀ, the only one mcI reads.
// (Measured dead end: I's columns built in registers; paper/ENGINEERING.md, "World inertia
// columns in registers".)
template <class T>
MINV_INLINE void worldInertia(const Model& model, const Three<T>* R, const Three<T>& p,
                              Kinematics<T>& kin, int i) {
  const BodyColumns<T>& bc = kin.cols[i];
  const Three<T> c = mulAdd3(p, R, bc.com);
  Three<T> RI[3];
  for (int k = 0; k < 3; ++k) RI[k] = mul3(R, col4(bc.inertia, k));
  // (R Ī) Rᵀ: column j is R Ī · (row j of R), its entries j … 2
  T Ic[9], cc[3];
  for (int j = 0; j < 3; ++j) {
    const T Rj[3] = {R[0][j], R[1][j], R[2][j]};
    Three<T>::lowerColumn(j, RI, Rj).store(Ic + 3 * j);
  }
  c.store(cc);
  mcI<T>(T(model.body(i).mass), cc, Ic, kin.I[i].data());
}

// Stages "spatial axes" (poses ⁰X_i and world-frame motion subspaces S_i) and "isolated
// inertias" (I_i), one mark each per body. Each body is done whole, parents first, its parent's
// pose still in registers along a chain. On one thread: split among OpenMP threads it was
// 2.2-2.5× slower (paper/ENGINEERING.md, "One configuration per thread").
template <class T, class Mark>
void computeKinematics(const Model& model, const VecX<T>& q, Kinematics<T>& kin, Mark&& mark) {
  const int nb = model.nb();
  const bool each_root = kin.origin == Origin::EachRoot;
  // sin and cos of the joint angles, all at once
  jointSinCos(q, kin);
  Three<T> R[3] = {Three<T>::zero(), Three<T>::zero(), Three<T>::zero()};  // ⁰X of the body
  Three<T> p = Three<T>::zero();                                           // just done
  for (int i = 0; i < nb; ++i) {
    const int parent = model.parent(i);
    // the joint's pose in its parent's frame
    Three<T> L[3], l;
    localPose(model, q, kin, i, L, l);
    // ⁰X_i = ⁰X_λ(i) · (L, l): R = R_λ L, p = p_λ + R_λ l; along a chain the parent's pose is
    // the one just done
    Three<T> Ri[3], pi;
    if (parent == i - 1 && parent >= 0) {
      mul33(R, L, Ri);
      pi = mulAdd3(p, R, l);
    } else if (parent >= 0) {
      Three<T> Rp[3];
      columns(kin.X[parent].R, Rp);
      mul33(Rp, L, Ri);
      pi = mulAdd3(Three<T>::load(kin.X[parent].p.data()), Rp, l);
    } else {
      for (int k = 0; k < 3; ++k) Ri[k] = L[k];
      pi = each_root ? Three<T>::zero() : l;
    }
    for (int k = 0; k < 3; ++k) R[k] = Ri[k], Ri[k].store(kin.X[i].R.data() + 3 * k);
    p = pi, pi.store(kin.X[i].p.data());
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
