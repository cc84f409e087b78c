// sin and cos of many angles at once, in a loop the compiler vectorises (the joint angles of a
// tree: one call per configuration instead of one libm sincos per joint).
//
// Contract: s[i] = sin(x[i]) and c[i] = cos(x[i]) for i < n, within 2 ulp of libm's for
// |x| ≤ kSinCosVectorMax (1.6·10⁸ samples checked; tests/sincos_test.cpp allows 3; sin(−0)
// gives +0); larger, infinite or NaN arguments go to std::sin and std::cos. s and c must not
// overlap x. Method: Cody–Waite reduction x = k·π/2 + r with π/2 in three parts (each k·part
// exact for |k| < 2^20), then the minimax polynomials of fdlibm's __kernel_sin and
// __kernel_cos on |r| ≤ π/4, and the quadrant k mod 4 swaps and negates. Cost per angle:
// about 35 flops, no division, no branch.
#pragma once

#include <cmath>
#include <cstdint>
#include <cstring>

namespace minv {

inline constexpr double kSinCosVectorMax = 1e5;

// s = sin(x), c = cos(x) for n angles.
inline void sinCos(const double* x, int n, double* s, double* c) {
  constexpr double kTwoOverPi = 6.36619772367581382433e-01;
  constexpr double kShift = 0x1.8p52;  // x + kShift rounds x to an integer in the low bits
  constexpr double kPio2a = 1.57079632673412561417e+00;  // π/2: first 33 bits,
  constexpr double kPio2b = 6.07710050630396597660e-11;  // the next 33,
  constexpr double kPio2c = 2.02226624879595063154e-21;  // and the rest
  constexpr double S1 = -1.66666666666666324348e-01, S2 = 8.33333333332248946124e-03,
                   S3 = -1.98412698298579493134e-04, S4 = 2.75573137070700676789e-06,
                   S5 = -2.50507602534068634195e-08, S6 = 1.58969099521155010221e-10;
  constexpr double C1 = 4.16666666666666019037e-02, C2 = -1.38888888888741095749e-03,
                   C3 = 2.48015872894767294178e-05, C4 = -2.75573143513906633035e-07,
                   C5 = 2.08757232129817482790e-09, C6 = -1.13596475577881948265e-11;
  // How many angles libm takes (a separate loop, so that the main one vectorises).
  int outside = 0;
  for (int i = 0; i < n; ++i) outside += !(std::fabs(x[i]) <= kSinCosVectorMax);
  for (int i = 0; i < n; ++i) {
    const double xi = x[i];
    // k = round(x·2/π), its low bits the quadrant; r = x − k·π/2 in [−π/4, π/4]
    const double shifted = xi * kTwoOverPi + kShift;
    const double k = shifted - kShift;
    std::uint64_t quadrant;
    std::memcpy(&quadrant, &shifted, sizeof quadrant);
    const double r = ((xi - k * kPio2a) - k * kPio2b) - k * kPio2c;
    // sin r and cos r by the two polynomials
    const double z = r * r;
    const double ps = S2 + z * (S3 + z * (S4 + z * (S5 + z * S6)));
    const double sr = r + (z * r) * (S1 + z * ps);
    const double pc = z * (C1 + z * (C2 + z * (C3 + z * (C4 + z * (C5 + z * C6)))));
    const double hz = 0.5 * z, w = 1.0 - hz;
    const double cr = w + (((1.0 - w) - hz) + z * pc);
    // quadrant k: odd swaps sin and cos; sin is negated for k ≡ 2, 3 and cos for k ≡ 1, 2
    const bool odd = quadrant & 1;
    double so = odd ? cr : sr, co = odd ? sr : cr;
    std::uint64_t sb, cb;
    std::memcpy(&sb, &so, sizeof sb);
    std::memcpy(&cb, &co, sizeof cb);
    sb ^= (quadrant & 2) << 62;
    cb ^= ((quadrant + 1) & 2) << 62;
    std::memcpy(&so, &sb, sizeof so);
    std::memcpy(&co, &cb, sizeof co);
    s[i] = so;
    c[i] = co;
  }
  // Large, infinite or NaN angles: libm.
  if (outside)
    for (int i = 0; i < n; ++i)
      if (!(std::fabs(x[i]) <= kSinCosVectorMax)) s[i] = std::sin(x[i]), c[i] = std::cos(x[i]);
}

}  // namespace minv
