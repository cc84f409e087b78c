/* Force-included (-include) into minv's own translation units when compiling with GCC < 13.
 * GCC 12 reports -Wmaybe-uninitialized (and, in the sanitizer build, -Wuninitialized) inside its
 * own AVX-512 headers (the `__Y = __Y` idiom of _mm512_undefined_pd in avx512fintrin.h, inlined
 * through Eigen's GEMM kernels and transposes): thousands of false positives on an AVX-512
 * machine (GCC bug 105593, fixed in GCC 13). The warning state of a GCC diagnostic pragma is
 * taken at the location the warning points to, so including the intrinsics here, once, with
 * those warnings off, silences exactly those locations and nothing in minv's own code. */
#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__)
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#pragma GCC diagnostic ignored "-Wuninitialized"
#include <immintrin.h>
#pragma GCC diagnostic pop
#endif
