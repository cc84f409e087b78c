// Hot simulator functions compiled for AVX-512 and AVX2 beside the portable build and chosen
// at load time by the CPU (GCC target_clones; MINV_CLONES_FLAT also inlines the function's
// whole call tree into each clone). The same source on every path, FMA contraction aside.
// Sanitizer builds and -march=native builds (MINV_NO_CLONES, set by MINV_SANITIZE and by
// MINV_NATIVE) and other compilers compile each function once, for the build's own level: the
// instrumented clones of a flattened call tree took GCC over ten minutes for one file, and a
// native build's Eigen code (AVX-512 intrinsics) cannot be inlined into a lower level's clone.
// Marking the clones `hot` (grouped in .text.hot) left the S = 5 centipede's step as it was
// (7.51-7.89 us against 7.48-7.67, Zen 4, builds alternated, 4 rounds).
#pragma once

#if defined(__GNUC__) && !defined(__clang__) && !defined(MINV_NO_CLONES)
#define MINV_CLONES __attribute__((target_clones("arch=x86-64-v4", "arch=x86-64-v3", "default")))
#define MINV_CLONES_FLAT \
  __attribute__((target_clones("arch=x86-64-v4", "arch=x86-64-v3", "default"), flatten))
#else
#define MINV_CLONES
#define MINV_CLONES_FLAT
#endif
