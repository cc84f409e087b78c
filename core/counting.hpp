// A flop-counting scalar: the solvers' kernels are templates, and instantiating them on
// `Counted` instead of `double` counts their arithmetic with the very code that is timed.
//
// Each operation on Counted computes the double result and bumps a per-thread counter:
// multiplications, additions (and subtractions), divisions, square roots, comparisons and
// transcendental functions (sin, cos) are kept apart; negation and copies are free.
// Per-thread counters make it safe when columns run in threads: flopTotal() sums every
// thread's counter (threads that have ended included). A kernel marks the end of each stage by
// calling its `mark("stage")` hook; with double the hook is NoMark and compiles away, with
// Counted a StageCounter books the counts since the previous mark to that stage.
#pragma once

#include <Eigen/Core>
#include <cmath>
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

namespace minv {

struct FlopCounts {
  std::uint64_t mul = 0, add = 0, div = 0, sqrt = 0, cmp = 0, trig = 0;

  FlopCounts& operator+=(const FlopCounts& o) {
    mul += o.mul, add += o.add, div += o.div, sqrt += o.sqrt, cmp += o.cmp, trig += o.trig;
    return *this;
  }
  FlopCounts operator-(const FlopCounts& o) const {
    return {mul - o.mul, add - o.add, div - o.div, sqrt - o.sqrt, cmp - o.cmp, trig - o.trig};
  }
  bool operator==(const FlopCounts&) const = default;
  // Every counted floating-point operation except comparisons.
  std::uint64_t flops() const { return mul + add + div + sqrt + trig; }
};

// This thread's counter.
FlopCounts& threadFlops();
// The sum over every thread that has counted, including ended ones.
FlopCounts flopTotal();
// Zero every counter. Call only while no other thread is counting.
void flopReset();

class Counted {
 public:
  Counted() = default;
  Counted(double v) : v_(v) {}  // NOLINT: implicit, as a double literal would convert
  double value() const { return v_; }
  explicit operator double() const { return v_; }

  Counted operator-() const { return Counted(-v_); }
  Counted& operator+=(const Counted& o) { return ++threadFlops().add, v_ += o.v_, *this; }
  Counted& operator-=(const Counted& o) { return ++threadFlops().add, v_ -= o.v_, *this; }
  Counted& operator*=(const Counted& o) { return ++threadFlops().mul, v_ *= o.v_, *this; }
  Counted& operator/=(const Counted& o) { return ++threadFlops().div, v_ /= o.v_, *this; }

  friend Counted operator+(Counted a, const Counted& b) { return a += b; }
  friend Counted operator-(Counted a, const Counted& b) { return a -= b; }
  friend Counted operator*(Counted a, const Counted& b) { return a *= b; }
  friend Counted operator/(Counted a, const Counted& b) { return a /= b; }

#define MINV_COUNTED_COMPARE(op)                                \
  friend bool operator op(const Counted& a, const Counted& b) { \
    ++threadFlops().cmp;                                        \
    return a.v_ op b.v_;                                        \
  }
  MINV_COUNTED_COMPARE(<)
  MINV_COUNTED_COMPARE(<=)
  MINV_COUNTED_COMPARE(>)
  MINV_COUNTED_COMPARE(>=)
  MINV_COUNTED_COMPARE(==)
  MINV_COUNTED_COMPARE(!=)
#undef MINV_COUNTED_COMPARE

  friend Counted sqrt(const Counted& a) {
    return ++threadFlops().sqrt, Counted(std::sqrt(a.v_));
  }
  friend Counted sin(const Counted& a) {
    return ++threadFlops().trig, Counted(std::sin(a.v_));
  }
  friend Counted cos(const Counted& a) {
    return ++threadFlops().trig, Counted(std::cos(a.v_));
  }
  friend Counted abs(const Counted& a) {
    return Counted(std::abs(a.v_));
  }
  friend bool isfinite(const Counted& a) {
    return std::isfinite(a.v_);
  }
  friend bool isnan(const Counted& a) {
    return std::isnan(a.v_);
  }
  friend bool isinf(const Counted& a) {
    return std::isinf(a.v_);
  }

 private:
  double v_ = 0;
};

// The mark hook of a kernel run on double: nothing.
struct NoMark {
  void operator()(const char*) const {}
};

// Books the counts between consecutive marks to the named stage, in first-seen order.
class StageCounter {
 public:
  StageCounter() : last_(flopTotal()) {}
  void operator()(const char* stage);
  const std::vector<std::pair<std::string, FlopCounts>>& stages() const { return stages_; }
  FlopCounts total() const;

 private:
  FlopCounts last_;
  std::vector<std::pair<std::string, FlopCounts>> stages_;
};

}  // namespace minv

namespace Eigen {
template <>
struct NumTraits<minv::Counted> : NumTraits<double> {
  using Real = minv::Counted;
  using NonInteger = minv::Counted;
  using Nested = minv::Counted;
  using Literal = minv::Counted;
  enum {
    IsComplex = 0,
    IsInteger = 0,
    IsSigned = 1,
    RequireInitialization = 1,
    ReadCost = 1,
    AddCost = 1,
    MulCost = 1
  };
  static minv::Counted epsilon() { return NumTraits<double>::epsilon(); }
  static minv::Counted dummy_precision() { return NumTraits<double>::dummy_precision(); }
  static minv::Counted highest() { return NumTraits<double>::highest(); }
  static minv::Counted lowest() { return NumTraits<double>::lowest(); }
  static int digits10() { return NumTraits<double>::digits10(); }
};
}  // namespace Eigen
