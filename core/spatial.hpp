// Spatial algebra in the notation of Featherstone, Rigid Body Dynamics Algorithms (RBDA, 2008).
//
// Motion vectors are [ω; v], force vectors [n; f]; the pairing sᵀf is a plain transpose.
// crossM(v) = v×, crossF(v) = v×* = -crossM(v)ᵀ (RBDA eqs. 2.31-2.33).
// A spatial inertia about a point with offset c to the centre of mass is
//   I = [Ī_c + m c̃ c̃ᵀ, m c̃; m c̃ᵀ, m 1]   (RBDA eq. 2.63, "mcI").
// Everything is templated on the scalar so the same code runs on double and on the
// flop-counting scalar of core/counting.hpp.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace minv {

// Small per-body steps that a caller's loop must inline whole (GCC and Clang otherwise leave
// some out of line in long loops, and their results then go through memory).
#if defined(__GNUC__)
#define MINV_INLINE __attribute__((always_inline)) inline
#else
#define MINV_INLINE inline
#endif

template <class T>
using Vec3 = Eigen::Matrix<T, 3, 1>;
template <class T>
using Mat3 = Eigen::Matrix<T, 3, 3>;
template <class T>
using Vec6 = Eigen::Matrix<T, 6, 1>;
template <class T>
using Mat6 = Eigen::Matrix<T, 6, 6>;
// A joint's motion subspace or a k-column block (k ≤ 6) without heap allocation.
template <class T>
using Mat6X = Eigen::Matrix<T, 6, Eigen::Dynamic, 0, 6, 6>;
template <class T>
using MatK = Eigen::Matrix<T, Eigen::Dynamic, Eigen::Dynamic, 0, 6, 6>;
template <class T>
using VecK = Eigen::Matrix<T, Eigen::Dynamic, 1, 0, 6, 1>;

// r̃: the 3x3 skew-symmetric matrix with r̃ x = r × x.
template <class T>
Mat3<T> skew(const Vec3<T>& r) {
  Mat3<T> m;
  m << T(0), -r.z(), r.y(), r.z(), T(0), -r.x(), -r.y(), r.x(), T(0);
  return m;
}

// v×: spatial cross product for motion vectors (RBDA eq. 2.31).
template <class T>
Mat6<T> crossM(const Vec6<T>& v) {
  Mat6<T> m = Mat6<T>::Zero();
  const Mat3<T> w = skew<T>(v.template head<3>());
  m.template topLeftCorner<3, 3>() = w;
  m.template bottomRightCorner<3, 3>() = w;
  m.template bottomLeftCorner<3, 3>() = skew<T>(v.template tail<3>());
  return m;
}

// v×*: spatial cross product for force vectors, -(v×)ᵀ (RBDA eq. 2.32).
template <class T>
Mat6<T> crossF(const Vec6<T>& v) {
  return -crossM<T>(v).transpose();
}

// Spatial inertia of a body of mass m, centre of mass c and rotational inertia Ī_c about c,
// expressed about the origin of the frame c is given in (RBDA eq. 2.63). With h = m c and
// c̃ c̃ᵀ = |c|² 1 − c cᵀ: the top-left block is Ī_c + (hᵀc) 1 − h cᵀ (symmetric: 6 products),
// the off-diagonal blocks are h̃ and h̃ᵀ. 12 mul, 12 add; reads Ī_c's lower triangle only.
template <class T>
MINV_INLINE void mcI(const T& m, const T* c, const T* Ic, T* I) {
  // On plain arrays, column-major (Eigen's order): c 3, Ī_c 3×3, I 6×6.
  const T h[3] = {m * c[0], m * c[1], m * c[2]};
  const T hc = h[0] * c[0] + h[1] * c[1] + h[2] * c[2];
  // Ī_c + m c̃ c̃ᵀ, one triangle then mirrored.
  for (int j = 0; j < 3; ++j)
    for (int i = j; i < 3; ++i) {
      T x = Ic[i + 3 * j] - h[i] * c[j];
      if (i == j) x += hc;
      I[i + 6 * j] = x;
      I[j + 6 * i] = x;
    }
  // m c̃ (top right), m c̃ᵀ (bottom left), m 1.
  const T H[9] = {T(0), h[2], -h[1], -h[2], T(0), h[0], h[1], -h[0], T(0)};  // h̃, column-major
  for (int j = 0; j < 3; ++j)
    for (int i = 0; i < 3; ++i) {
      I[i + 6 * (3 + j)] = H[i + 3 * j];
      I[(3 + j) + 6 * i] = H[i + 3 * j];
      I[(3 + i) + 6 * (3 + j)] = i == j ? m : T(0);
    }
}
template <class T>
Mat6<T> mcI(const T& m, const Vec3<T>& c, const Mat3<T>& Ic) {
  Mat6<T> I;
  mcI<T>(m, c.data(), Ic.data(), I.data());
  return I;
}

// A rigid pose: the frame's orientation R (frame → world) and origin p (in world).
// The Plücker transform from this frame to the world frame, for motion vectors, is
//   ⁰X = [R, 0; p̃R, R]   (RBDA eq. 2.24 with E = Rᵀ, r = p).
template <class T>
struct Pose {
  Mat3<T> R = Mat3<T>::Identity();
  Vec3<T> p = Vec3<T>::Zero();

  // this ∘ b: b is given relative to this frame.
  Pose operator*(const Pose& b) const { return {R * b.R, p + R * b.p}; }

  // A motion vector given in this frame, expressed in the world frame.
  Vec6<T> motionToWorld(const Vec6<T>& m) const {
    Vec6<T> out;
    out.template head<3>() = R * m.template head<3>();
    out.template tail<3>() = R * m.template tail<3>() + p.cross(out.template head<3>());
    return out;
  }
};

// Converts a Pose<double> to another scalar.
template <class T>
Pose<T> castPose(const Pose<double>& x) {
  return {x.R.template cast<T>(), x.p.template cast<T>()};
}

}  // namespace minv
