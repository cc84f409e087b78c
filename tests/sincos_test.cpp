// core/sincos.hpp against libm's sin and cos.
#include "core/sincos.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>
#include <vector>

namespace minv {
namespace {

// |a − b| in units of b's last place (the spacing of doubles at |b|).
double ulpsApart(double a, double b) {
  const double spacing =
      std::nextafter(std::fabs(b), std::numeric_limits<double>::infinity()) - std::fabs(b);
  return std::fabs(a - b) / spacing;
}

void expectLibm(const std::vector<double>& x, double max_ulps) {
  std::vector<double> s(x.size()), c(x.size());
  sinCos(x.data(), static_cast<int>(x.size()), s.data(), c.data());
  for (std::size_t i = 0; i < x.size(); ++i) {
    ASSERT_LE(ulpsApart(s[i], std::sin(x[i])), max_ulps) << "sin(" << x[i] << ")";
    ASSERT_LE(ulpsApart(c[i], std::cos(x[i])), max_ulps) << "cos(" << x[i] << ")";
  }
}

TEST(SinCos, WithinThreeUlpsOfLibmOnJointAngles) {
  // Joint angles as the generators draw them, and a wide spread of magnitudes.
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> angle(-M_PI, M_PI), unit(-1, 1), exponent(-30, 17);
  std::vector<double> x;
  for (int i = 0; i < 100000; ++i) x.push_back(angle(rng));
  for (int i = 0; i < 100000; ++i)
    x.push_back(std::ldexp(unit(rng), static_cast<int>(exponent(rng))));
  expectLibm(x, 3.0);
}

TEST(SinCos, NearMultiplesOfHalfPi) {
  // Where the reduction cancels most: k·π/2 rounded, and its neighbours, up to the vector bound.
  std::vector<double> x;
  for (int k = -63000; k <= 63000; k += 7) {
    const double t = k * (M_PI / 2);
    x.insert(x.end(), {t, std::nextafter(t, 1e300), std::nextafter(t, -1e300)});
  }
  expectLibm(x, 3.0);
}

TEST(SinCos, LargeInfiniteAndNanGoToLibm) {
  const double inf = std::numeric_limits<double>::infinity();
  const std::vector<double> x = {
      kSinCosVectorMax, -kSinCosVectorMax, 2 * kSinCosVectorMax, 1e22, -1e300, 0.5};
  expectLibm(x, 1.0);
  std::vector<double> bad = {inf, -inf, std::nan(""), 0.25}, s(4), c(4);
  sinCos(bad.data(), 4, s.data(), c.data());
  for (int i = 0; i < 3; ++i) EXPECT_TRUE(std::isnan(s[i]) && std::isnan(c[i])) << bad[i];
  EXPECT_EQ(s[3], std::sin(0.25));
  EXPECT_EQ(c[3], std::cos(0.25));
}

TEST(SinCos, ZeroAndEmpty) {
  double x = 0, s = 1, c = 0;
  sinCos(&x, 1, &s, &c);
  EXPECT_EQ(s, 0.0);
  EXPECT_EQ(c, 1.0);
  sinCos(nullptr, 0, nullptr, nullptr);
}

}  // namespace
}  // namespace minv
