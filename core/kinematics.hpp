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

#include <cmath>
#include <type_traits>
#include <vector>

#include "core/counting.hpp"
#include "core/model.hpp"
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

template <class T>
struct Kinematics {
  std::vector<Pose<T>> X;  // body i's pose in the world
  Mat6N<T> S;              // motion subspaces in world coordinates, column k for DOF k
  std::vector<Mat6<T>> I;  // body spatial inertias in world coordinates
  Origin origin;           // World, or each tree's root joint

  explicit Kinematics(const Model& m, Origin o = Origin::World)
      : X(m.nb()), S(Mat6N<T>::Zero(6, m.nv())), I(m.nb()), origin(o) {}
};

// Rotation of a unit quaternion (w, x, y, z); normalises first.
template <class T>
Mat3<T> quatToRotation(T w, T x, T y, T z) {
  using std::sqrt;
  const T inv = T(1) / sqrt(w * w + x * x + y * y + z * z);
  w = w * inv, x = x * inv, y = y * inv, z = z * inv;
  Mat3<T> R;
  R << T(1) - T(2) * (y * y + z * z), T(2) * (x * y - w * z), T(2) * (x * z + w * y),
      T(2) * (x * y + w * z), T(1) - T(2) * (x * x + z * z), T(2) * (y * z - w * x),
      T(2) * (x * z - w * y), T(2) * (y * z + w * x), T(1) - T(2) * (x * x + y * y);
  return R;
}

// Pose of the joint's motion: body frame relative to the joint frame.
template <class T>
Pose<T> jointPose(const Joint& j, const VecX<T>& q, int o) {
  using std::cos;
  using std::sin;
  Pose<T> J;
  const Vec3<T> a = j.axis.cast<T>();
  switch (j.type) {
    case JointType::Revolute: {
      // Rodrigues: R = c·1 + s·ã + (1 − c)·a aᵀ, entry by entry (the symmetric part once).
      const T c = cos(q(o)), s = sin(q(o));
      const Vec3<T> ta = (T(1) - c) * a, sa = s * a;
      for (int col = 0; col < 3; ++col)
        for (int row = col; row < 3; ++row) {
          const T x = ta(row) * a(col);
          J.R(row, col) = J.R(col, row) = x;
        }
      for (int i = 0; i < 3; ++i) J.R(i, i) += c;
      J.R(0, 1) -= sa(2), J.R(1, 0) += sa(2);
      J.R(0, 2) += sa(1), J.R(2, 0) -= sa(1);
      J.R(1, 2) -= sa(0), J.R(2, 1) += sa(0);
      break;
    }
    case JointType::Prismatic:
      J.p = a * q(o);
      break;
    case JointType::Spherical:
      J.R = quatToRotation<T>(q(o), q(o + 1), q(o + 2), q(o + 3));
      break;
    case JointType::Floating:
      J.p = q.template segment<3>(o);
      J.R = quatToRotation<T>(q(o + 3), q(o + 4), q(o + 5), q(o + 6));
      break;
  }
  return J;
}

// Stage "spatial axes": poses ⁰X_i and world-frame motion subspaces S_i; one mark per body.
// With threads > 1 (and no marks) the per-body steps are shared among OpenMP threads and only
// the composition along the tree runs in order.
template <class T, class Mark = NoMark>
void forwardKinematics(const Model& model, const VecX<T>& q, Kinematics<T>& kin, Mark&& mark = {},
                       int threads = 1) {
  // The joint's pose in its parent's frame: placement · X_J(q_i).
  auto local = [&](int i) {
    const Joint& j = model.joint(i);
    kin.X[i] = castPose<T>(j.placement) * jointPose<T>(j, q, model.qIdx(i));
  };
  // ⁰X_i = ⁰X_λ(i) · (placement · X_J), parents first; a root at the origin if asked.
  auto compose = [&](int i) {
    if (model.parent(i) >= 0)
      kin.X[i] = kin.X[model.parent(i)] * kin.X[i];
    else if (kin.origin == Origin::EachRoot)
      kin.X[i].p.setZero();
  };
  // S_i: the joint's body-frame subspace carried to world coordinates.
  auto axes = [&](int i) {
    const Joint& j = model.joint(i);
    const Pose<T>& X = kin.X[i];
    const int v = model.vIdx(i);
    switch (j.type) {
      case JointType::Revolute: {
        const Vec3<T> w = X.R * j.axis.cast<T>();
        kin.S.col(v) << w, X.p.cross(w);
        break;
      }
      case JointType::Prismatic:
        kin.S.col(v) << Vec3<T>::Zero(), X.R * j.axis.cast<T>();
        break;
      case JointType::Spherical:
        for (int c = 0; c < 3; ++c) kin.S.col(v + c) << X.R.col(c), X.p.cross(X.R.col(c));
        break;
      case JointType::Floating:
        for (int c = 0; c < 3; ++c) {
          kin.S.col(v + c) << X.R.col(c), X.p.cross(X.R.col(c));
          kin.S.col(v + 3 + c) << Vec3<T>::Zero(), X.R.col(c);
        }
        break;
    }
  };
  const int nb = model.nb();
  if (threads > 1 && std::is_same_v<std::decay_t<Mark>, NoMark>) {
#pragma omp parallel num_threads(threads)
    {
#pragma omp for schedule(static)
      for (int i = 0; i < nb; ++i) local(i);
#pragma omp single
      for (int i = 0; i < nb; ++i) compose(i);
#pragma omp for schedule(static)
      for (int i = 0; i < nb; ++i) axes(i);
    }
    return;
  }
  for (int i = 0; i < nb; ++i) {
    local(i);
    compose(i);
    axes(i);
    mark("spatial axes");
  }
}

// Stage "isolated inertias": I_i = mcI(m, ⁰c_i, R Ī Rᵀ) about the world origin; a mark per body.
// Bodies are independent: with threads > 1 (and no marks) they are shared among OpenMP threads.
template <class T, class Mark = NoMark>
void worldInertias(const Model& model, Kinematics<T>& kin, Mark&& mark = {}, int threads = 1) {
  auto body = [&](int i) {
    const Body& b = model.body(i);
    const Pose<T>& X = kin.X[i];
    const Vec3<T> c = X.p + X.R * b.com.cast<T>();
    // R Ī Rᵀ: R Ī, then one triangle of (R Ī) Rᵀ; mcI reads that triangle only.
    const Mat3<T> RI = X.R * b.inertia.cast<T>();
    Mat3<T> Ic;
    for (int j = 0; j < 3; ++j)
      for (int r = j; r < 3; ++r) Ic(r, j) = RI.row(r).dot(X.R.row(j));
    mcI<T>(T(b.mass), c, Ic, kin.I[i]);
  };
  if (threads > 1 && std::is_same_v<std::decay_t<Mark>, NoMark>) {
#pragma omp parallel for schedule(static) num_threads(threads)
    for (int i = 0; i < model.nb(); ++i) body(i);
    return;
  }
  for (int i = 0; i < model.nb(); ++i) {
    body(i);
    mark("isolated inertias");
  }
}

// Both stages; the second on `threads` OpenMP threads.
template <class T>
void computeKinematics(const Model& model, const VecX<T>& q, Kinematics<T>& kin, int threads = 1) {
  forwardKinematics(model, q, kin, NoMark{}, threads);
  worldInertias(model, kin, NoMark{}, threads);
}

}  // namespace minv
