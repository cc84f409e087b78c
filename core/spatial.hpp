// Spatial algebra in the notation of Featherstone, Rigid Body Dynamics Algorithms (RBDA, 2008).
//
// Motion vectors are [ω; v], force vectors [n; f]; the pairing sᵀf is a plain transpose.
// crossM(v) = v×, crossF(v) = v×* = -crossM(v)ᵀ (RBDA eqs. 2.31-2.33).
// A spatial inertia about a point with offset c to the centre of mass is
//   I = [Ī_c + m c̃ c̃ᵀ, m c̃; m c̃ᵀ, m 1]   (RBDA eq. 2.63, "mcI").
// Everything is templated on the scalar so the same code runs on double and on the
// flop-counting scalar of core/counting.hpp.
#pragma once

#include <immintrin.h>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <type_traits>

namespace minv {

// Small per-body steps that a caller's loop must inline whole (GCC and Clang otherwise leave
// some out of line in long loops, and their results then go through memory).
// MINV_NOINLINE: a loop kept out of its caller's, so that neither's registers crowd the other's.
#if defined(__GNUC__)
#define MINV_INLINE __attribute__((always_inline)) inline
#define MINV_NOINLINE __attribute__((noinline))
#else
#define MINV_INLINE inline
#define MINV_NOINLINE
#endif

// A column of a 6×6 spatial matrix for the per-body kernels (core/articulated.hpp). On any
// scalar but double: six scalars, each entry-wise operation six scalar operations, so that the
// counting scalar counts exactly what the kernel does. On doubles: one SIMD value, the same
// operations lane by lane; its layout is the instruction-set level's (the build's, or an abi
// module's, solvers/abi_variants.hpp):
// - AVX-512: one 8-lane register (GCC/Clang vector extension, two lanes zero). A body's IA then
//   stays in 6 of the 32 registers.
// - narrower levels: Eigen's 6-entry array (4 + 2 lanes on AVX2, 3 × 2 on SSE), where an 8-lane
//   value goes through memory and 16 registers do not hold IA.
// (Measurements: paper/ENGINEERING.md, "Spatial columns as SIMD values".)
template <class T>
struct Six {
  T v[6];
  static MINV_INLINE Six load(const T* p) {
    Six a;
    for (int r = 0; r < 6; ++r) a.v[r] = p[r];
    return a;
  }
  MINV_INLINE void store(T* p) const {
    for (int r = 0; r < 6; ++r) p[r] = v[r];
  }
  // The same, for memory not written just before (loadFar) or not read just after (storeFar).
  static MINV_INLINE Six loadFar(const T* p) { return load(p); }
  MINV_INLINE void storeFar(T* p) const { store(p); }
  MINV_INLINE T operator[](int r) const { return v[r]; }
  friend MINV_INLINE Six operator+(const Six& a, const Six& b) {
    Six c;
    for (int r = 0; r < 6; ++r) c.v[r] = a.v[r] + b.v[r];
    return c;
  }
  friend MINV_INLINE Six operator-(const Six& a, const Six& b) {
    Six c;
    for (int r = 0; r < 6; ++r) c.v[r] = a.v[r] - b.v[r];
    return c;
  }
  friend MINV_INLINE Six operator*(const Six& a, const T& s) {
    Six c;
    for (int r = 0; r < 6; ++r) c.v[r] = a.v[r] * s;
    return c;
  }
  // aᵀb in pairs (a short dependency chain): 6 mul, 5 add.
  friend MINV_INLINE T dot(const Six& a, const Six& b) {
    return (a[0] * b[0] + a[1] * b[1]) + (a[2] * b[2] + a[3] * b[3]) + (a[4] * b[4] + a[5] * b[5]);
  }
};

template <>
struct Six<double> {
#if defined(__GNUC__) && defined(__AVX512F__)
  typedef double V __attribute__((vector_size(64)));
  static MINV_INLINE V loadLanes(const double* p) {
    return V{p[0], p[1], p[2], p[3], p[4], p[5], 0.0, 0.0};
  }
  static MINV_INLINE void storeLanes(const V& v, double* p) {
    for (int r = 0; r < 6; ++r) p[r] = v[r];
  }
#else
  using V = Eigen::Array<double, 6, 1>;
  static MINV_INLINE V loadLanes(const double* p) {
    return Eigen::Map<const V>(p);
  }
  static MINV_INLINE void storeLanes(const V& v, double* p) {
    Eigen::Map<V> to(p);
    to = v;
  }
#endif
  V v;
  static MINV_INLINE Six load(const double* p) {
    return {loadLanes(p)};
  }
  MINV_INLINE void store(double* p) const {
    storeLanes(v, p);
  }
  // For memory not written just before (loadFar) or not read just after (storeFar). On AVX-512
  // one masked instruction each, where the entry-wise forms take five or six; but a masked load
  // cannot take its data from stores still in flight (store-to-load forwarding), hence apart
  // (paper/ENGINEERING.md, "Masked loads and stores").
  static MINV_INLINE Six loadFar(const double* p) {
#if defined(__GNUC__) && defined(__AVX512F__)
    return {V(_mm512_maskz_loadu_pd(0x3f, p))};
#else
    return load(p);
#endif
  }
  MINV_INLINE void storeFar(double* p) const {
#if defined(__GNUC__) && defined(__AVX512F__)
    _mm512_mask_storeu_pd(p, 0x3f, __m512d(v));
#else
    store(p);
#endif
  }
  MINV_INLINE double operator[](int r) const {
    return v[r];
  }
  friend MINV_INLINE Six operator+(const Six& a, const Six& b) {
    return {a.v + b.v};
  }
  friend MINV_INLINE Six operator-(const Six& a, const Six& b) {
    return {a.v - b.v};
  }
  friend MINV_INLINE Six operator*(const Six& a, double s) {
    return {a.v * s};
  }
  // The products as one SIMD value, then summed in the same pairs.
  friend MINV_INLINE double dot(const Six& a, const Six& b) {
    const V p = a.v * b.v;
#if defined(__GNUC__) && defined(__AVX512F__)
    // p[0] + p[1], p[2] + p[3], p[4] + p[5] in lanes 0, 2, 4 of one sum (each pair swapped)
    const V s = p + V(_mm512_permute_pd(__m512d(p), 0x55));
    return (s[0] + s[2]) + s[4];
#else
    return (p[0] + p[1]) + (p[2] + p[3]) + (p[4] + p[5]);
#endif
  }
};

// A 3-vector (a column of a 3×3 rotation or inertia, a point) for the per-body kinematics
// (core/kinematics.hpp), in the same manner as Six: on any scalar but double, three scalars and
// scalar operations, so that the counting scalar counts exactly what the kernel does; on doubles
// at AVX and above, one 4-lane SIMD value (the fourth lane zero), the same operations lane by
// lane: a 3×3 product is then 9 vector multiply-adds, not 27 scalar ones. Below AVX the 4-lane
// value is lowered through memory, so there it is three doubles (measurements:
// paper/ENGINEERING.md, "Spatial columns as SIMD values").
// load4 reads a 4-entry column whose fourth entry is zero (BodyColumns, core/kinematics.hpp).
template <class T>
struct Three {
  T v[3];
  static MINV_INLINE Three load(const T* p) { return {{p[0], p[1], p[2]}}; }
  static MINV_INLINE Three load4(const T* p) { return load(p); }
  static MINV_INLINE Three zero() { return {{T(0), T(0), T(0)}}; }
  MINV_INLINE void store(T* p) const {
    for (int r = 0; r < 3; ++r) p[r] = v[r];
  }
  MINV_INLINE T operator[](int r) const { return v[r]; }
  friend MINV_INLINE Three operator+(const Three& a, const Three& b) {
    return {{a.v[0] + b.v[0], a.v[1] + b.v[1], a.v[2] + b.v[2]}};
  }
  friend MINV_INLINE Three operator*(const Three& a, const T& s) {
    return {{a.v[0] * s, a.v[1] * s, a.v[2] * s}};
  }
  // Entries j … 2 of (A₀b₀ + A₁b₁) + A₂b₂, the rest zero: a column of a symmetric product's
  // lower triangle (the double lanes compute every entry, in the same vector operations).
  static MINV_INLINE Three lowerColumn(int j, const Three* A, const T* b) {
    Three c = zero();
    for (int r = j; r < 3; ++r) c.v[r] = A[0].v[r] * b[0] + A[1].v[r] * b[1] + A[2].v[r] * b[2];
    return c;
  }
};

#if defined(__GNUC__) && defined(__AVX__)
template <>
struct Three<double> {
  typedef double V __attribute__((vector_size(32)));
  V v;
  static MINV_INLINE Three load(const double* p) { return {V{p[0], p[1], p[2], 0.0}}; }
  static MINV_INLINE Three load4(const double* p) {
    V x;
    __builtin_memcpy(&x, p, sizeof x);
    return {x};
  }
  static MINV_INLINE Three zero() { return {V{0.0, 0.0, 0.0, 0.0}}; }
  MINV_INLINE void store(double* p) const {
    for (int r = 0; r < 3; ++r) p[r] = v[r];
  }
  MINV_INLINE double operator[](int r) const { return v[r]; }
  friend MINV_INLINE Three operator+(const Three& a, const Three& b) { return {a.v + b.v}; }
  friend MINV_INLINE Three operator*(const Three& a, double s) { return {a.v * s}; }
  static MINV_INLINE Three lowerColumn(int, const Three* A, const double* b) {
    return {A[0].v * b[0] + A[1].v * b[1] + A[2].v * b[2]};
  }
};
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
// the off-diagonal blocks are h̃ and h̃ᵀ. 12 mul, 11 add; reads Ī_c's lower triangle only.
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
