// Subnormal doubles flushed to zero for the lifetime of a scope, on the calling thread.
//
// Far along a long chain M⁻¹'s entries decay geometrically: on a serial chain of n = 4096 a
// quarter of them fall below DBL_MIN (2.2e-308), and every operation on such a subnormal
// number takes a microcode assist on Intel cores (≈ 100 cycles). There abi's inverse took
// 400 ms instead of 60 ms (Xeon, Emerald Rapids); AMD's Zen cores pay far less. Setting the
// MXCSR's flush-to-zero (FTZ: subnormal results become 0) and denormals-are-zero (DAZ:
// subnormal inputs read as 0) changes only numbers below 2.2e-308, an absolute error below
// 2.2e-308 on entries of order one, and keeps the time independent of the data.
// The previous mode is restored on exit, so callers' own arithmetic is untouched. MXCSR is
// per thread: each OpenMP thread of a kernel takes its own guard.
#pragma once

#if defined(__SSE2__) || defined(_M_X64)
#include <immintrin.h>
#define MINV_HAS_MXCSR 1
#endif

namespace minv {

class FlushSubnormals {
 public:
  FlushSubnormals() {
#ifdef MINV_HAS_MXCSR
    saved_ = _mm_getcsr();
    _mm_setcsr(saved_ | kFtz | kDaz);
#endif
  }
  ~FlushSubnormals() {
#ifdef MINV_HAS_MXCSR
    _mm_setcsr(saved_);
#endif
  }
  FlushSubnormals(const FlushSubnormals&) = delete;
  FlushSubnormals& operator=(const FlushSubnormals&) = delete;

 private:
  static constexpr unsigned kFtz = 1u << 15, kDaz = 1u << 6;
  unsigned saved_ = 0;
};

}  // namespace minv
