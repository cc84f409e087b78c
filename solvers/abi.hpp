// `abi`: M⁻¹ and M⁻¹R from articulated-body inertias, never forming M.
//
// Drumwright, "Fast dynamic simulation of highly articulated robots with contact via Θ(n²)
// time dense generalized inertia matrix inversion" (SIMPAR 2012), Algorithms 1 (fixed base)
// and 2 (floating base), in RBDA (2008) notation, world frame, with §5.2's savings.
// A unit impulse r = e_c applied in generalized coordinates gives column c of M⁻¹:
//   backward, i = nb−1 … 0:  u_i = r_i − S_iᵀ Y_i,  Y_λ(i) += Y_i + U_i D_i⁻¹ u_i
//   forward,  i = 0 … nb−1:  Δq̇_i = D_i⁻¹ u_i − (U_i D_i⁻¹)ᵀ Δv_λ(i),  Δv_i = Δv_λ(i) + S_i Δq̇_i
// with Δv_λ = 0 at a root. Corrections to the printed pseudo-code (see the reading notes):
// Alg. 1 line 5 needs the `Y_i +` term and line 8 the minus sign. A floating base is body 0
// with a 6-DOF joint whose S is the base's Plücker transform; D₀ = S₀ᵀ IA₀ S₀, so Alg. 2's
// Δv₀ = (IA₀)⁻¹(r₀ − Y₀) is the k = 6 case of the same forward step.
// The same sweeps one column at a time in plain scalar code, without the lane bookkeeping
// below (and without the links' regrouping, abiBackwardLinks), are core/impulse_sweeps.hpp:
// read that first; tests/impulse_sweeps_test.cpp holds this kernel to it for every lane
// remainder nv mod W.
//
// Savings: U, D⁻¹ and U D⁻¹ are computed once per configuration (§5.2; core/articulated.hpp).
// For a unit column e_c at body b only b's ancestors carry a non-zero Y (§5.2), and since M⁻¹
// is symmetric only the rows of bodies 0 … b are needed (bodies are numbered parent first, so
// their Δv never needs a later body): both sweeps stop at b, and each block writes its
// columns above the diagonal and, by symmetry, its rows left of it (on AVX-512 2 or 8 blocks at
// a time, their forward sweeps in turn: abiInverseBlockGroup). Columns go in blocks of W lanes
// (W = kAbiLanes<T>: 16 for double, 1 for the counting scalar), one lane per column, so every
// update is a W-wide vector operation; along a chain Y and Δv pass from body to body in local
// variables, not the workspace (in registers where a row is one or two vectors: VectorLanes
// below); blocks run in OpenMP threads (setThreads), each thread reading its own copy of the
// configuration, which it makes itself in the same parallel region (AbiSolver::configure: one
// fork per configure + inverse). Multi-DOF joints make D a k×k block. Along runs of one-DOF
// links both sweeps regroup their recurrences so that from one body's u (or Δq̇) to the next
// one multiply-add waits, not a dot product (abiBackwardLinks, abiForwardLinks): one multiply
// and one add more per column and link, for a dependency chain about half as long.
// Cost: Σ_c (depth(b_c) + b_c) body steps ≈ n²/2 + Σ depth for M⁻¹ (Θ(n²)); Θ(m·nb) for M⁻¹R.
// Scratch Θ(nv·W) per block and thread (up to kAbiGroupMax blocks a thread), allocated in the
// workspace; the sweeps do not allocate.
// Numbers below DBL_MIN are flushed to zero while the sweeps run (core/fpenv.hpp): an absolute
// change below 2.2e-308 that keeps Intel cores off their slow subnormal path at large n.
#pragma once

#include <immintrin.h>
#include <omp.h>

#include <algorithm>
#include <cstdint>
#include <type_traits>
#include <utility>
#include <vector>

#include "core/articulated.hpp"
#include "core/counting.hpp"
#include "core/fpenv.hpp"
#include "core/kinematics.hpp"
#include "solvers/solver.hpp"

namespace minv {

inline int omp_thread() {
  return omp_get_thread_num();
}

// The sweeps are compiled with every call inside them inlined, so that their lane arithmetic
// is one loop body whatever inlining budget the including translation unit leaves.
#if defined(__GNUC__)
#define MINV_FLATTEN __attribute__((flatten))
#else
#define MINV_FLATTEN
#endif

// Columns per SIMD block: 16 doubles, four AVX2 (two AVX-512) registers per row, so each body
// step has four independent FMA chains to hide the latency of the body-to-body recursion; best
// at every level measured (paper/ENGINEERING.md, "Columns per block"). Each level's module may
// set its own (MINV_ABI_LANES, CMakeLists.txt). The counting scalar runs one column at a time:
// its counts are the kernel's (the links' regrouping included), column by column.
#ifndef MINV_ABI_LANES
#define MINV_ABI_LANES 16
#endif
template <class T>
inline constexpr int kAbiLanes = 1;
template <>
inline constexpr int kAbiLanes<double> = MINV_ABI_LANES;

// One value per column of a block of W columns. On doubles, where W is one or two of the widest
// vectors (8 doubles on AVX-512, 4 on AVX, 2 on SSE): an array of such vectors (GCC/Clang vector
// extension) that the compiler keeps in registers, rows indexed by constants (forRows), where
// Eigen arrays sent a sweep's running Y and Δv through the stack at every body. Wider blocks
// (a row in 4 or 8 registers of 16) and any other scalar: an Eigen array (measurements:
// paper/ENGINEERING.md, "Lanes held in registers").
#if defined(__GNUC__)
#if defined(__AVX512F__)
inline constexpr int kVectorDoubles = 8;
#elif defined(__AVX__)
inline constexpr int kVectorDoubles = 4;
#else
inline constexpr int kVectorDoubles = 2;
#endif
template <int W>
struct VectorLanes {
  static constexpr int SizeAtCompileTime = W;
  static constexpr int L = kVectorDoubles;
  typedef double V __attribute__((vector_size(8 * L)));
  V p[W / L];
  static VectorLanes Zero() {
    VectorLanes z;
    z.setZero();
    return z;
  }
  void setZero() {
    for (V& x : p) x = V{};
  }
  // For intrinsic loads only (abiStoreLine: their pointer types may alias anything).
  const double* data() const { return reinterpret_cast<const double*>(p); }
  void set(int w, double x) { p[w / L][w % L] = x; }
  double operator()(int w) const { return p[w / L][w % L]; }
  VectorLanes& operator+=(const VectorLanes& o) {
    for (int i = 0; i < W / L; ++i) p[i] += o.p[i];
    return *this;
  }
  friend VectorLanes operator+(VectorLanes a, const VectorLanes& b) { return a += b; }
  friend VectorLanes operator*(double s, const VectorLanes& a) {
    VectorLanes r;
    for (int i = 0; i < W / L; ++i) r.p[i] = s * a.p[i];
    return r;
  }
};
template <class T, int W>
struct LaneOf {
  using type = Eigen::Array<T, 1, W>;
};
template <int W>
requires(W % kVectorDoubles == 0 && W <= 2 * kVectorDoubles) struct LaneOf<double, W> {
  using type = VectorLanes<W>;
};
template <class T, int W>
using LaneT = typename LaneOf<T, W>::type;
template <class Lane>
inline constexpr bool kVectorLanes = false;
template <int W>
inline constexpr bool kVectorLanes<VectorLanes<W>> = true;
#else
template <class T, int W>
using LaneT = Eigen::Array<T, 1, W>;
template <class Lane>
inline constexpr bool kVectorLanes = false;
#endif

// Lane w of l set to x (on vector lanes by element, never through a double*).
template <class Lane, class X>
inline void setLane(Lane& l, int w, const X& x) {
  if constexpr (kVectorLanes<Lane>)
    l.set(w, x);
  else
    l(w) = x;
}

// f(0) … f(5), row by row. On vector lanes each index is a compile-time constant, so that a
// block's running Y and Δv can stay in registers; on Eigen lanes a plain loop.
template <class Lane, class F>
MINV_INLINE void forRows(F&& f) {
  if constexpr (kVectorLanes<Lane>) {
    [&]<int... R>(std::integer_sequence<int, R...>) {
      (f(R), ...);
    }
    (std::make_integer_sequence<int, 6>{});
  } else {
    for (int r = 0; r < 6; ++r) f(r);
  }
}

// A spatial vector per column: six rows of W lanes.
template <class T, int W>
struct LaneSpatial {
  using Lane = LaneT<T, W>;
  Lane r[6];
  Lane& row(int i) { return r[i]; }
  const Lane& row(int i) const { return r[i]; }
  void setZero() {
    forRows<Lane>([&](auto i) { r[i].setZero(); });
  }
  LaneSpatial& operator+=(const LaneSpatial& o) {
    forRows<Lane>([&](auto i) { r[i] += o.r[i]; });
    return *this;
  }
  static LaneSpatial Zero() {
    LaneSpatial z;
    z.setZero();
    return z;
  }
};

// Full blocks of columns in groups (abiInverseBlockGroup) where a block's lanes are vectors held
// in registers (VectorLanes: at the default 16 lanes, the avx512 module): kAbiGroup<T>(nv)
// blocks a group (1, 2 or 8; 1: blocks go one at a time). A block's mirrored rows in one column
// of X are W contiguous entries (2 lines at W = 16), the next column's 8·ld bytes on; a group
// writes its blocks' rows of a column close together in time, which the memory system takes
// far better than 2 lines per column per sweep (paper/ENGINEERING.md, "Blocks in groups").
inline constexpr int kAbiGroupChunk = 32;  // bodies per forward piece (16 worse, 64 alike)
inline constexpr int kAbiPairMin = 256;
inline constexpr int kAbiOctetMin = 4096;
inline constexpr int kAbiGroupMax = 8;
template <class T>
constexpr int kAbiGroup(int nv) {
  static_assert(kAbiGroupMax == 8, "abiInverse dispatches groups of 2 and kAbiGroupMax");
  if (!kVectorLanes<LaneT<T, kAbiLanes<T>>>) return 1;
  return nv >= kAbiOctetMin ? kAbiGroupMax : nv >= kAbiPairMin ? 2 : 1;
}

// Scratch of one thread for a block of W columns.
template <class T, int W>
struct AbiLanes {
  using Lane = LaneT<T, W>;           // one value per column
  using Spatial = LaneSpatial<T, W>;  // one spatial vector per column
  // gather[i]: body i has a child other than i + 1. Along a chain (parent(i + 1) = i) Y and Δv
  // pass from body to body in registers; only at such branch points do they go through memory,
  // at slot[i] of Y and dv (−1 elsewhere: a serial chain keeps none).
  std::vector<char> gather;
  std::vector<int> slot;
  std::vector<Spatial> Y;   // what children other than i + 1 hand up to body i, per slot
  std::vector<Spatial> dv;  // Δv_i read by a child that is not the next body, per slot
  std::vector<Lane> u;      // u_i = r_i − S_iᵀ Y_i, then Δq̇, per DOF
  std::vector<char> held;   // held[i]: Y[slot[i]] holds a share left by a child (backward)
  // link[i]: body i has one DOF, its parent is i − 1 and its only child (if any) is i + 1: Y
  // passes through it up the chain and Δv down it.
  std::vector<char> link;
  std::vector<Lane> e;  // e[w]: 1 in lane w, 0 elsewhere (the unit impulse of lane w)

  explicit AbiLanes(const Model& m)
      : gather(m.nb(), 0),
        slot(m.nb(), -1),
        u(m.nv(), Lane::Zero()),
        held(m.nb(), 0),
        link(m.nb(), 0),
        e(W, Lane::Zero()) {
    for (int w = 0; w < W; ++w) setLane(e[w], w, T(1));
    for (int j = 1; j < m.nb(); ++j)
      if (m.parent(j) >= 0 && m.parent(j) != j - 1) gather[m.parent(j)] = 1;
    int slots = 0;
    for (int j = 0; j < m.nb(); ++j)
      if (gather[j]) slot[j] = slots++;
    Y.assign(slots, Spatial::Zero());
    dv.assign(slots, Spatial::Zero());
    for (int j = 1; j < m.nb(); ++j) link[j] = m.nvOf(j) == 1 && m.parent(j) == j - 1 && !gather[j];
  }
};

// Per-tree scratch of the impulse sweeps, per thread: a wide block (and a group's other blocks,
// kAbiGroup − 1 more), a half-wide one (for a last block of few columns) and a one-column one.
template <class T>
struct AbiWorkspace {
  static constexpr int kHalf = kAbiLanes<T> > 1 ? kAbiLanes<T> / 2 : 1;
  const int group;                                      // blocks per group (kAbiGroup)
  std::vector<AbiLanes<T, kAbiLanes<T>>> wide, others;  // others: thread t's at t·(group − 1)
  std::vector<AbiLanes<T, kHalf>> half;
  std::vector<AbiLanes<T, 1>> narrow;

  // The rows abi mirrors streamed (core/cpu.hpp: streamStridedRows) or stored plainly.
  bool stream_rows = false;

  explicit AbiWorkspace(const Model& m, int threads = 1)
      : group(kAbiGroup<T>(m.nv())),
        wide(threads, AbiLanes<T, kAbiLanes<T>>(m)),
        others(threads * (group - 1), AbiLanes<T, kAbiLanes<T>>(m)),
        half(threads, AbiLanes<T, kHalf>(m)),
        narrow(threads, AbiLanes<T, 1>(m)) {}
  int threads() const { return static_cast<int>(wide.size()); }
  // Block j of thread t's group.
  AbiLanes<T, kAbiLanes<T>>& lanes(int t, int j) {
    return j == 0 ? wide[t] : others[t * (group - 1) + j - 1];
  }
};

// −aᵀY for a 6-vector a and Y's six rows, in two halves (a shorter dependency chain).
template <class Lane, class Col, class Spatial>
MINV_INLINE Lane abiNegDot(const Col& a, const Spatial& Y) {
  using T = std::decay_t<decltype(a(0))>;
  const T s0 = -a(0), s1 = -a(1), s2 = -a(2), s3 = -a(3), s4 = -a(4), s5 = -a(5);
  return (s0 * Y.row(0) + s1 * Y.row(1) + s2 * Y.row(2)) +
         (s3 * Y.row(3) + s4 * Y.row(4) + s5 * Y.row(5));
}

// One body of the backward sweep on Y = Y_i (Y_i + U D⁻¹ u on exit), for K DOFs (K = 0: k).
// The 6-term dot products go as two halves, a shorter dependency chain.
template <class T, int W, bool Unit, int K>
inline void abiBackwardBody(const Kinematics<T>& kin, const Articulated<T>& art, AbiLanes<T, W>& ws,
                            typename AbiLanes<T, W>::Spatial& Y, int v, int k, bool root, int c0,
                            int width) {
  using Lane = typename AbiLanes<T, W>::Lane;
  if constexpr (K > 0) k = K;
  Lane u[K > 0 ? K : 6];
  for (int j = 0; j < k; ++j) {
    // u = r − S_jᵀ Y, as r + Σ (−S)·Y so that no subtraction waits at the end of the chain
    const auto S = kin.S.col(v + j);
    if constexpr (Unit) {
      u[j] = abiNegDot<Lane>(S, Y);
      if (static_cast<unsigned>(v + j - c0) < static_cast<unsigned>(width))
        u[j] += ws.e[v + j - c0];
    } else {
      const T s0 = -S(0), s1 = -S(1), s2 = -S(2), s3 = -S(3), s4 = -S(4), s5 = -S(5);
      u[j] = (ws.u[v + j] + s0 * Y.row(0) + s1 * Y.row(1) + s2 * Y.row(2)) +
             (s3 * Y.row(3) + s4 * Y.row(4) + s5 * Y.row(5));
    }
    ws.u[v + j] = u[j];
  }
  if (root) return;
  // Y + Σ_j (U D⁻¹)_j u_j, what the parent receives.
  for (int j = 0; j < k; ++j)
    forRows<Lane>([&](auto r) { Y.row(r) += art.UDinv(r, v + j) * u[j]; });
}

// Backward along a run of links, from the one-DOF body i (parent i − 1, a link) with Y = Y_i:
// u_i, then, link by link (j = i − 1, i − 2, … while the run goes on),
//   u_j = r_j − S_jᵀ Y_{j+1} + c_{j+1} u_{j+1},   Y_j = Y_{j+1} + U_{j+1} D_{j+1}⁻¹ u_{j+1},
// with c_{j+1} = −S_jᵀ U_{j+1} D_{j+1}⁻¹ (art.couple, once per configuration): u_j = r_j − S_jᵀ Y_j
// regrouped. The dot product now reads Y a body earlier: from one u to the next one multiply-add
// waits, and the chain through Y (a multiply-add, the dot product, the coupling's multiply-add)
// spans two bodies, where before a dot product and a multiply-add lay between consecutive
// bodies. One multiply and one add more per column and link; the sweeps about 25-30 % faster
// (paper/ENGINEERING.md, "Runs of links regrouped").
// On exit Y = Y_j + U_j D_j⁻¹ u_j for the run's last body j, what its parent receives; returns j.
template <class T, int W, bool Unit>
MINV_INLINE int abiBackwardLinks(const Model& model, const Kinematics<T>& kin,
                                 const Articulated<T>& art, AbiLanes<T, W>& ws,
                                 typename AbiLanes<T, W>::Spatial& Y, int i, int c0, int width) {
  using Lane = typename AbiLanes<T, W>::Lane;
  int v = model.vIdx(i);
  // r_v: a unit impulse in lane v − c0 within the block, else zero; or held in ws.u
  auto impulse = [&](Lane& u, int dof) {
    if constexpr (Unit) {
      if (static_cast<unsigned>(dof - c0) < static_cast<unsigned>(width)) u += ws.e[dof - c0];
    } else {
      u += ws.u[dof];
    }
  };
  // u_i = r_i − S_iᵀ Y_i
  Lane u = abiNegDot<Lane>(kin.S.col(v), Y);
  impulse(u, v);
  ws.u[v] = u;
  for (; ws.link[i - 1]; --i, --v) {
    // u_{i−1} from Y_i and u_i
    const auto S = kin.S.col(v - 1);
    const auto UD = art.UDinv.col(v);
    Lane un = abiNegDot<Lane>(S, Y);
    un += art.couple(v) * u;
    impulse(un, v - 1);
    // Y_{i−1} = Y_i + U_i D_i⁻¹ u_i
    forRows<Lane>([&](auto r) { Y.row(r) += UD(r) * u; });
    ws.u[v - 1] = un;
    u = un;
  }
  // The last link's share for its parent.
  forRows<Lane>([&](auto r) { Y.row(r) += art.UDinv(r, v) * u; });
  return i;
}

// Backward sweep from body `last` to the roots:
//   u_i = r_i − S_iᵀ Y_i,  Y_λ(i) += Y_i + U_i D_i⁻¹ u_i.
// r is either the unit impulses e_{c0+w} (Unit; ws.u is then written, not read) or held in
// ws.u on entry. With unit impulses only their bodies' ancestors carry a Y (§5.2): any other
// body has u = 0 and is skipped. ws.Y is zero on entry and again on exit (each entry is
// cleared once gathered).
template <class T, int W, bool Unit>
MINV_FLATTEN void abiBackward(const Model& model, const Kinematics<T>& kin,
                              const Articulated<T>& art, AbiLanes<T, W>& ws, int last, int c0 = 0,
                              int width = 0) {
  auto Y = AbiLanes<T, W>::Spatial::Zero();  // Y_i of the current body
  bool carried = false;                      // Y holds what child i + 1 handed up
  for (int i = last; i >= 0; --i) {
    const int v = model.vIdx(i), k = model.nvOf(i), p = model.parent(i);
    const bool gathered = ws.held[i];  // other children left a share in memory
    // A body with no impulse of its own and nothing from its children: u = 0, nothing to hand up.
    if (Unit && !carried && !gathered && (v + k <= c0 || v >= c0 + width)) {
      for (int j = 0; j < k; ++j) ws.u[v + j].setZero();
      continue;
    }
    // Y_i: carried up the chain from i + 1, plus what other children left in memory.
    if (!carried) Y.setZero();
    if (gathered) {
      Y += ws.Y[ws.slot[i]];
      ws.Y[ws.slot[i]].setZero();
      ws.held[i] = 0;
    }
    // A one-DOF body above a run of links: the run, its chain shortened (abiBackwardLinks).
    if (k == 1 && p >= 0 && p == i - 1 && ws.link[p]) {
      i = abiBackwardLinks<T, W, Unit>(model, kin, art, ws, Y, i, c0, width);
      carried = true;
      continue;
    }
    // u_i, and Y_i + U_i D_i⁻¹ u_i for the parent.
    if (k == 1)
      abiBackwardBody<T, W, Unit, 1>(kin, art, ws, Y, v, k, p < 0, c0, width);
    else
      abiBackwardBody<T, W, Unit, 0>(kin, art, ws, Y, v, k, p < 0, c0, width);
    // Carried on along a chain, else left in memory.
    carried = p >= 0 && p == i - 1;
    if (p >= 0 && !carried) {
      ws.Y[ws.slot[p]] += Y;
      ws.held[p] = 1;
    }
  }
}

// One body of the forward sweep on dv = Δv_λ(i) (Δv_i on exit), for K DOFs (K = 0: k):
// Δq̇ = D⁻¹ u − (U D⁻¹)ᵀ Δv_λ into ws.u, then Δv_i = Δv_λ + S Δq̇ (Δv_λ = 0 at a root).
template <class T, int W, int K>
inline void abiForwardBody(const Kinematics<T>& kin, const Articulated<T>& art, AbiLanes<T, W>& ws,
                           typename AbiLanes<T, W>::Spatial& dv, int i, int v, int k, bool root) {
  using Lane = typename AbiLanes<T, W>::Lane;
  if constexpr (K > 0) k = K;
  Lane qd[K > 0 ? K : 6];
  // (k of the six are set below; all are zeroed, so no compiler sees one unset)
  if constexpr (K == 0)
    for (Lane& x : qd) x.setZero();
  for (int j = 0; j < k; ++j) {
    // D⁻¹ u
    if constexpr (K == 1) {
      qd[j] = art.dinv(v) * ws.u[v];
    } else {
      qd[j] = art.Dinv[i](j, 0) * ws.u[v];
      for (int l = 1; l < k; ++l) qd[j] += art.Dinv[i](j, l) * ws.u[v + l];
    }
    // − (U D⁻¹)ᵀ Δv_λ as D⁻¹u + Σ (−U D⁻¹)·Δv_λ in two halves, a shorter dependency chain
    if (!root) {
      const auto UD = art.UDinv.col(v + j);
      const T a0 = -UD(0), a1 = -UD(1), a2 = -UD(2), a3 = -UD(3), a4 = -UD(4), a5 = -UD(5);
      qd[j] = (qd[j] + a0 * dv.row(0) + a1 * dv.row(1) + a2 * dv.row(2)) +
              (a3 * dv.row(3) + a4 * dv.row(4) + a5 * dv.row(5));
    }
  }
  for (int j = 0; j < k; ++j) ws.u[v + j] = qd[j];
  // Δv_i = Δv_λ + S Δq̇
  forRows<Lane>([&](auto r) {
    Lane row = kin.S(r, v) * qd[0];
    for (int j = 1; j < k; ++j) row += kin.S(r, v + j) * qd[j];
    if (root)
      dv.row(r) = row;
    else
      dv.row(r) += row;
  });
}

// Eight doubles to dst without reading its cache line first (a non-temporal store) when dst
// starts a 64-byte line; plain stores otherwise, and for any other scalar. M⁻¹'s entries are
// written once and not read again by the inverse, so reading each line for ownership before
// overwriting it would only double the memory traffic. abiInverse fences them (abiStoreFence).
// Used for the column strips above each block's diagonal (whole 8-row lines), and for the rows
// left of the diagonal (two lines per column, one column apart) unless MINV_ABI_ROWS=plain
// (core/cpu.hpp, streamStridedRows; measurements: paper/ENGINEERING.md, "Non-temporal stores").
template <class T>
inline void abiStoreLine(T* dst, const T* src) {
  if constexpr (std::is_same_v<T, double>) {
    if ((reinterpret_cast<std::uintptr_t>(dst) & 63) == 0) {
#if defined(__AVX512F__)
      _mm512_stream_pd(dst, _mm512_loadu_pd(src));
#elif defined(__AVX__)
      _mm256_stream_pd(dst, _mm256_loadu_pd(src));
      _mm256_stream_pd(dst + 4, _mm256_loadu_pd(src + 4));
#else
      for (int k = 0; k < 8; k += 2) _mm_stream_pd(dst + k, _mm_loadu_pd(src + k));
#endif
      return;
    }
    // (src may be a VectorLanes' storage: read with intrinsics, never through a double*)
    for (int k = 0; k < 8; k += 2) _mm_storeu_pd(dst + k, _mm_loadu_pd(src + k));
    return;
  }
  std::copy_n(src, 8, dst);
}
#if defined(__AVX512F__)
// The same for a line already in a register.
inline void abiStoreLine(double* dst, __m512d x) {
  if ((reinterpret_cast<std::uintptr_t>(dst) & 63) == 0)
    _mm512_stream_pd(dst, x);
  else
    _mm512_storeu_pd(dst, x);
}
// An 8×8 block of doubles transposed in registers: r[v] (row v) becomes column v. Pairs of
// rows interleaved, then 128- and 256-bit halves exchanged: 24 shuffles.
MINV_INLINE void abiTranspose8(__m512d* r) {
  __m512d t[8], s[8];
  // t[2k] = (r[2k][0], r[2k+1][0], r[2k][2], …), t[2k+1] the odd entries
  for (int k = 0; k < 4; ++k) {
    t[2 * k] = _mm512_unpacklo_pd(r[2 * k], r[2 * k + 1]);
    t[2 * k + 1] = _mm512_unpackhi_pd(r[2 * k], r[2 * k + 1]);
  }
  // s[e], s[4 + e]: entries e and e + 4 of rows 0-3 and of rows 4-7
  for (int k = 0; k < 2; ++k)
    for (int o = 0; o < 2; ++o) {
      s[4 * k + o] = _mm512_shuffle_f64x2(t[4 * k + o], t[4 * k + 2 + o], 0x88);
      s[4 * k + 2 + o] = _mm512_shuffle_f64x2(t[4 * k + o], t[4 * k + 2 + o], 0xDD);
    }
  // columns e and e + 4: rows 0-3 from s[e] beside rows 4-7 from s[4 + e]
  for (int e = 0; e < 4; ++e) {
    r[e] = _mm512_shuffle_f64x2(s[e], s[4 + e], 0x88);
    r[e + 4] = _mm512_shuffle_f64x2(s[e], s[4 + e], 0xDD);
  }
}
#elif defined(__AVX__)
// The same for a line already in two registers (its first and last four doubles).
inline void abiStoreLine(double* dst, __m256d lo, __m256d hi) {
  if ((reinterpret_cast<std::uintptr_t>(dst) & 63) == 0) {
    _mm256_stream_pd(dst, lo);
    _mm256_stream_pd(dst + 4, hi);
  } else {
    _mm256_storeu_pd(dst, lo);
    _mm256_storeu_pd(dst + 4, hi);
  }
}
// A 4×4 block of doubles transposed in registers: r[v] (row v) becomes column v. Pairs of rows
// interleaved, then 128-bit halves exchanged: 8 shuffles.
MINV_INLINE void abiTranspose4(__m256d* r) {
  const __m256d t0 = _mm256_unpacklo_pd(r[0], r[1]), t1 = _mm256_unpackhi_pd(r[0], r[1]);
  const __m256d t2 = _mm256_unpacklo_pd(r[2], r[3]), t3 = _mm256_unpackhi_pd(r[2], r[3]);
  r[0] = _mm256_permute2f128_pd(t0, t2, 0x20);
  r[1] = _mm256_permute2f128_pd(t1, t3, 0x20);
  r[2] = _mm256_permute2f128_pd(t0, t2, 0x31);
  r[3] = _mm256_permute2f128_pd(t1, t3, 0x31);
}
#elif defined(__SSE2__)
// The same for a line already in four registers.
inline void abiStoreLine(double* dst, const __m128d* x) {
  if ((reinterpret_cast<std::uintptr_t>(dst) & 63) == 0)
    for (int k = 0; k < 4; ++k) _mm_stream_pd(dst + 2 * k, x[k]);
  else
    for (int k = 0; k < 4; ++k) _mm_storeu_pd(dst + 2 * k, x[k]);
}
#endif
// Orders the non-temporal stores before anything that follows (a thread's join included).
template <class T>
inline void abiStoreFence() {
  if constexpr (std::is_same_v<T, double>) _mm_sfence();
}

// Where the forward sweep also stores Δq̇ as it goes (the stores then overlap the arithmetic of
// the bodies that follow):
// - rows: lane w of DOF v < end to x[w + v·ld], for the first `width` lanes (x = nullptr:
//   nowhere); with `stream`, whole blocks as full lines without reading them (abiStoreLine);
// - columns: once DOFs v0 … v0+7 < tiles are done, lane w's eight values to col[v0 + w·ld],
//   one full line per lane, transposed in registers (through a small buffer on other scalars;
//   col = nullptr: nowhere).
// (Measured dead ends: tiles deferred into the next block's backward sweep, and rows gathered
// in a scratch strip to write four blocks' at once; paper/ENGINEERING.md, "Dead ends in the
// writes".)
template <class T>
struct LaneRows {
  T* x = nullptr;
  std::size_t ld = 0;
  int end = 0, width = 0;
  bool stream = false;
  T* col = nullptr;
  int tiles = 0;

  template <class Lanes>
  void store(const Lanes& u, int v, int k) const {
    constexpr int W = std::decay_t<decltype(u[0])>::SizeAtCompileTime;
    if (x)
      for (int j = 0; j < k && v + j < end; ++j) {
        T* dst = x + (v + j) * ld;
        if (width < W)
          for (int w = 0; w < width; ++w) dst[w] = u[v + j](w);
        else if (W % 8 == 0 && stream)
          for (int w = 0; w < W; w += 8) abiStoreLine(dst + w, u[v + j].data() + w);
        else
          for (int w = 0; w < W; ++w) dst[w] = u[v + j](w);
      }
    if (col)
      for (int j = 0; j < k; ++j)
        if (((v + j + 1) & 7) == 0 && v + j < tiles) tile(u, v + j - 7);
  }

  // Rows v0 … v0+7 of the block's columns, lanes to columns, transposed in registers on
  // AVX-512, AVX and SSE2 (element by element it was 1-11 % slower: paper/ENGINEERING.md,
  // "Tiles transposed in registers").
  template <class Lanes>
  void tile(const Lanes& u, int v0) const {
    constexpr int W = std::decay_t<decltype(u[0])>::SizeAtCompileTime;
#if defined(__AVX512F__)
    // On AVX-512, eight lanes at a time transposed in registers (abiTranspose8).
    if constexpr (std::is_same_v<T, double> && W % 8 == 0) {
      for (int h = 0; h < W && h < width; h += 8) {
        __m512d r[8];
        for (int v = 0; v < 8; ++v) r[v] = _mm512_loadu_pd(u[v0 + v].data() + h);
        abiTranspose8(r);
        for (int w = 0; w < 8 && h + w < width; ++w) abiStoreLine(col + v0 + (h + w) * ld, r[w]);
      }
      return;
    }
#elif defined(__AVX__)
    // On AVX, four lanes at a time: rows 0-3 and 4-7 transposed in registers (abiTranspose4).
    if constexpr (std::is_same_v<T, double> && W % 4 == 0) {
      for (int h = 0; h < W && h < width; h += 4) {
        __m256d a[4], b[4];
        for (int v = 0; v < 4; ++v) {
          a[v] = _mm256_loadu_pd(u[v0 + v].data() + h);
          b[v] = _mm256_loadu_pd(u[v0 + 4 + v].data() + h);
        }
        abiTranspose4(a);
        abiTranspose4(b);
        for (int w = 0; w < 4 && h + w < width; ++w)
          abiStoreLine(col + v0 + (h + w) * ld, a[w], b[w]);
      }
      return;
    }
#elif defined(__SSE2__)
    // On SSE2, two lanes at a time: pairs of rows interleaved into two columns' entries.
    if constexpr (std::is_same_v<T, double> && W % 2 == 0) {
      for (int h = 0; h < W && h < width; h += 2) {
        __m128d a[4], b[4];
        for (int k = 0; k < 4; ++k) {
          const __m128d r0 = _mm_loadu_pd(u[v0 + 2 * k].data() + h);
          const __m128d r1 = _mm_loadu_pd(u[v0 + 2 * k + 1].data() + h);
          a[k] = _mm_unpacklo_pd(r0, r1);
          b[k] = _mm_unpackhi_pd(r0, r1);
        }
        abiStoreLine(col + v0 + h * ld, a);
        if (h + 1 < width) abiStoreLine(col + v0 + (h + 1) * ld, b);
      }
      return;
    }
#endif
    T t[W][8];
    for (int v = 0; v < 8; ++v)
      for (int w = 0; w < W; ++w) t[w][v] = u[v0 + v](w);
    for (int w = 0; w < width; ++w) abiStoreLine(col + v0 + w * ld, t[w]);
  }
};

// Forward down a run of links from the one-DOF body i, with dv = Δv_λ(i) (unused at a root):
// Δq̇_i, then, link by link (j = i + 1, i + 2, … ≤ end while the run goes on), with
// λ' = λ(j − 1) (j − 2, or λ(i) for the first link; Δv_λ' = 0 at a root):
//   Δq̇_j = D_j⁻¹ u_j − (U_j D_j⁻¹)ᵀ Δv_λ' + c_j Δq̇_{j−1},   Δv_{j−1} = Δv_λ' + S_{j−1} Δq̇_{j−1},
// with the same c_j = −(U_j D_j⁻¹)ᵀ S_{j−1}: Δq̇_j = D_j⁻¹ u_j − (U_j D_j⁻¹)ᵀ Δv_{j−1} regrouped as
// in abiBackwardLinks. Each Δq̇ into ws.u and `rows`. On exit dv = Δv_j of the run's last body
// j; returns j. A sweep taken in pieces (abiInverseBlockGroup) stops at `end` < last: if the run
// goes on past it, `open` is set, q = Δq̇_end and dv = Δv_λ(end) are left as the loop has them,
// and the next piece resumes there (`resume`, from i = end): the same operations as in one piece.
template <class T, int W>
MINV_INLINE int abiForwardLinks(const Model& model, const Kinematics<T>& kin,
                                const Articulated<T>& art, AbiLanes<T, W>& ws,
                                typename AbiLanes<T, W>::Spatial& dv,
                                typename AbiLanes<T, W>::Lane& q, int i, int last, int end,
                                bool resume, bool root, bool& open, const LaneRows<T>& rows) {
  using Lane = typename AbiLanes<T, W>::Lane;
  int v = model.vIdx(i);
  if (!resume) {
    // Δq̇_i = D_i⁻¹ u_i − (U_i D_i⁻¹)ᵀ Δv_λ(i)
    q = art.dinv(v) * ws.u[v];
    // (At a root Δv_λ(i) = 0, and the first link adds S_i Δq̇_i to it: on the counting scalar
    // six additions of zero per column, where a separate first step was slower.)
    if (root)
      dv.setZero();
    else
      q += abiNegDot<Lane>(art.UDinv.col(v), dv);
    ws.u[v] = q;
    rows.store(ws.u, v, 1);
  }
  for (; i + 1 <= end && ws.link[i + 1]; ++i, ++v) {
    // Δq̇_{i+1} from Δv_λ(i) and Δq̇_i
    const auto UD = art.UDinv.col(v + 1);
    const auto S = kin.S.col(v);
    Lane qn = art.dinv(v + 1) * ws.u[v + 1] + abiNegDot<Lane>(UD, dv);
    qn += art.couple(v + 1) * q;
    // Δv_i = Δv_λ(i) + S_i Δq̇_i (kept for a child that is not the next body: only the run's
    // first body can have one)
    forRows<Lane>([&](auto r) { dv.row(r) += S(r) * q; });
    if (ws.gather[i]) ws.dv[ws.slot[i]] = dv;
    ws.u[v + 1] = qn;
    rows.store(ws.u, v + 1, 1);
    q = qn;
  }
  // The run goes on in the next piece.
  open = i < last && ws.link[i + 1];
  if (open) return i;
  // Δv of the run's last body.
  forRows<Lane>([&](auto r) { dv.row(r) += kin.S(r, v) * q; });
  return i;
}

// What the forward sweep hands from one piece to the next (abiForwardRange): Δv of the piece's
// last body, or, where a run of links goes on (`open`), Δv of its parent and its Δq̇ (q).
template <class T, int W>
struct ForwardCarry {
  typename AbiLanes<T, W>::Spatial dv = AbiLanes<T, W>::Spatial::Zero();
  typename AbiLanes<T, W>::Lane q = AbiLanes<T, W>::Lane::Zero();
  bool open = false;
};

// Forward sweep over bodies first … end of a sweep that stops at `last`:
// Δq̇_i = D_i⁻¹ u_i − (U_i D_i⁻¹)ᵀ Δv_λ(i), left in ws.u (and in `rows`), and
// Δv_i = Δv_λ(i) + S_i Δq̇_i; `carry` from the piece before (zero for the first) and to the next.
// Out of line, the one forward sweep of every block, whole or in pieces: each call keeps its
// carry in registers, and a group's blocks and a single block run the same machine code, so
// that they agree bit for bit (inlined into each caller, FMA contraction differed between them
// in the last bits; paper/ENGINEERING.md, "One out-of-line forward range").
template <class T, int W>
__attribute__((noinline)) MINV_FLATTEN void abiForwardRange(
    const Model& model, const Kinematics<T>& kin, const Articulated<T>& art, AbiLanes<T, W>& ws,
    int first, int end, int last, ForwardCarry<T, W>& carry, const LaneRows<T>& rows) {
  auto dv = carry.dv;  // Δv of the current body; of body i − 1 on entry
  auto q = carry.q;
  bool open = carry.open;
  int i = first;
  // A run of links cut at first − 1: resumed.
  if (open)
    i = abiForwardLinks<T, W>(model, kin, art, ws, dv, q, first - 1, last, end, true, false, open,
                              rows) +
        1;
  for (; i <= end; ++i) {
    const int v = model.vIdx(i), k = model.nvOf(i), p = model.parent(i);
    // Δv_λ(i): carried from body i − 1 along a chain, else read from memory.
    if (p >= 0 && p != i - 1) dv = ws.dv[ws.slot[p]];
    // A one-DOF body above a run of links: the run, its chain shortened (abiForwardLinks).
    if (k == 1 && i + 1 <= last && ws.link[i + 1]) {
      i = abiForwardLinks<T, W>(model, kin, art, ws, dv, q, i, last, end, false, p < 0, open, rows);
      continue;
    }
    // Δq̇_i and Δv_i.
    if (k == 1)
      abiForwardBody<T, W, 1>(kin, art, ws, dv, i, v, k, p < 0);
    else
      abiForwardBody<T, W, 0>(kin, art, ws, dv, i, v, k, p < 0);
    rows.store(ws.u, v, k);
    // Kept in memory for a child that is not the next body.
    if (ws.gather[i]) ws.dv[ws.slot[i]] = dv;
  }
  carry.dv = dv, carry.q = q, carry.open = open;
}

// Forward sweep over bodies 0 … last in one piece.
template <class T, int W>
MINV_FLATTEN void abiForward(const Model& model, const Kinematics<T>& kin,
                             const Articulated<T>& art, AbiLanes<T, W>& ws, int last,
                             LaneRows<T> rows = {}) {
  ForwardCarry<T, W> carry;
  abiForwardRange<T, W>(model, kin, art, ws, 0, last, last, carry, rows);
}

// What a block's forward sweep left unwritten: the rows of a last partial tile above the
// diagonal, and the diagonal tile (its upper triangle, mirrored so that X is exactly symmetric,
// unless `upper`).
template <class T, int W>
MINV_INLINE void abiBlockTail(const AbiLanes<T, W>& ws, int c0, int width, T* x, std::size_t ld,
                              bool upper) {
  const int tiles = c0 / 8 * 8;
  for (int w = 0; w < width; ++w)
    for (int v = tiles; v < c0; ++v) x[v + (c0 + w) * ld] = ws.u[v](w);
  for (int w = 0; w < width; ++w)
    for (int v = c0; v <= c0 + w; ++v) {
      x[v + (c0 + w) * ld] = ws.u[v](w);
      if (!upper) x[c0 + w + v * ld] = ws.u[v](w);
    }
}

// Columns c0 … c0+W−1 (those below nv) of M⁻¹: Δq̇ of lane w for the rows of bodies
// 0 … b(last column), which include every row up to column c0 + w. By symmetry they give the
// block's rows too, so each block writes its own strips of X and nothing is mirrored after:
// the columns above the block's rows and the rows left of (and on) its diagonal tile.
// With `upper` only the strips above the diagonal are written, and the diagonal tile's upper
// triangle: M⁻¹'s upper triangle, half the stores.
template <class T, int W, class Out, class Mark>
MINV_FLATTEN void abiInverseBlock(const Model& model, const Kinematics<T>& kin,
                                  const Articulated<T>& art, AbiLanes<T, W>& ws, int c0, Out& X,
                                  Mark& mark, bool upper = false, bool stream = false) {
  const int nv = model.nv(), width = std::min(W, nv - c0);
  const int last = model.dofBody(c0 + width - 1);
  // The unit impulses e_{c0+w}, one per lane, up to the roots; then Δq̇ of bodies 0 … last.
  // Rows c0 … c0+width−1 left of the diagonal tile, X(c0 + w, v) = Δq̇_v of lane w (one
  // contiguous run of the lanes per column v), are stored by the forward sweep.
  const std::size_t ld = X.outerStride();
  T* x = X.data();
  abiBackward<T, W, true>(model, kin, art, ws, last, c0, width);
  mark("impulse propagation");
  // Columns c0 … above the diagonal tile, X(v, c0 + w), in 8-row tiles as the sweep goes.
  const int tiles = c0 / 8 * 8;
  abiForward<T, W>(
      model, kin, art, ws, last,
      LaneRows<T>{upper ? nullptr : x + c0, ld, c0, width, stream, x + c0 * ld, tiles});
  mark("velocity updates");
  abiBlockTail<T, W>(ws, c0, width, x, ld, upper);
}

// g adjacent full blocks (kAbiGroup), c0 … c0+gW−1: every block's backward sweep, then their
// forward sweeps in turn, kAbiGroupChunk bodies at a time (a run of links cut between pieces is
// resumed, so every entry takes the same operations as in abiInverseBlock), so that the rows of
// all g blocks in one column of X (gW contiguous entries) are written close together in time.
// Rows are always mirrored (inverseUpper takes single blocks). ws[j]: block j's scratch; g is a
// template argument, so that a pair zeroes two carries, not kAbiGroupMax. (Measured dead end:
// the next group's backward sweeps run in pieces between these forward pieces;
// paper/ENGINEERING.md, "Dead ends in the writes".)
template <class T, int W, int g, class Out, class Mark>
MINV_FLATTEN void abiInverseBlockGroup(const Model& model, const Kinematics<T>& kin,
                                       const Articulated<T>& art, AbiLanes<T, W>* const* ws, int c0,
                                       Out& X, Mark& mark, bool stream) {
  const std::size_t ld = X.outerStride();
  T* x = X.data();
  // Each block's unit impulses up to the roots.
  int last[g];
  for (int j = 0; j < g; ++j) {
    last[j] = model.dofBody(c0 + (j + 1) * W - 1);
    abiBackward<T, W, true>(model, kin, art, *ws[j], last[j], c0 + j * W, W);
  }
  mark("impulse propagation");
  // Each block's strips of X (as in abiInverseBlock) and its forward sweep's carry.
  LaneRows<T> rows[g];
  ForwardCarry<T, W> carry[g];
  for (int j = 0; j < g; ++j) {
    const int c = c0 + j * W;
    rows[j] = LaneRows<T>{x + c, ld, c, W, stream, x + c * ld, c / 8 * 8};
  }
  // The forward sweeps in turn, a piece each, while a block's sweep goes on.
  for (int first = 0; first <= last[g - 1]; first += kAbiGroupChunk)
    for (int j = 0; j < g; ++j)
      if (first <= last[j])
        abiForwardRange<T, W>(model, kin, art, *ws[j], first,
                              std::min(first + kAbiGroupChunk - 1, last[j]), last[j], carry[j],
                              rows[j]);
  mark("velocity updates");
  for (int j = 0; j < g; ++j) abiBlockTail<T, W>(*ws[j], c0 + j * W, W, x, ld, /*upper=*/false);
}

// What the sweeps read of a configuration (S, U D⁻¹, D⁻¹), per thread: thread t reads copy t,
// or the last copy where there are fewer (one copy: every thread reads the same). With
// `make`, each thread first brings its own copy up to date, make(context, t), inside the same
// parallel region as its columns (AbiSolver: one fork and one join per configure + inverse);
// one copy made by one thread and read by all was slower (paper/ENGINEERING.md, "Two threads").
template <class T>
struct AbiConfigurations {
  const Kinematics<T>* kins;
  const Articulated<T>* arts;
  int copies = 1;
  void (*make)(void* context, int thread) = nullptr;
  void* context = nullptr;
  const Kinematics<T>& kin(int thread) const { return kins[std::min(thread, copies - 1)]; }
  const Articulated<T>& art(int thread) const { return arts[std::min(thread, copies - 1)]; }
  void ready(int thread) const {
    if (make) make(context, std::min(thread, copies - 1));
  }
};

// Stages "impulse propagation" and "velocity updates" for all columns: Minv = M⁻¹, in blocks
// of W columns (a last block of at most W/2 columns runs half as wide); with `upper`, only its
// upper triangle.
template <class T, class Out, class Mark = NoMark>
void abiInverse(const Model& model, AbiConfigurations<T> config, AbiWorkspace<T>& ws, Out& Minv,
                Mark&& mark = {}, bool upper = false) {
  constexpr int W = kAbiLanes<T>;
  const int nv = model.nv(), blocks = (nv + W - 1) / W;
  const bool halfLast = W > 1 && nv - (blocks - 1) * W <= W / 2;
  auto block = [&](int b, int thread, auto& mk) {
    const Kinematics<T>& kin = config.kin(thread);
    const Articulated<T>& art = config.art(thread);
    if (b == blocks - 1 && halfLast)
      abiInverseBlock<T, AbiWorkspace<T>::kHalf>(model, kin, art, ws.half[thread], b * W, Minv, mk,
                                                 upper, ws.stream_rows);
    else
      abiInverseBlock<T, W>(model, kin, art, ws.wide[thread], b * W, Minv, mk, upper,
                            ws.stream_rows);
  };
  // Full blocks (W columns) in groups of ws.group (abiInverseBlockGroup) where rows are
  // mirrored: unit b is blocks gb … gb + g − 1 while all are full, else one block.
  const int g = upper ? 1 : ws.group;
  const int groups = g > 1 ? nv / W / g : 0;
  const int units = blocks - groups * (g - 1);
  auto unit = [&](int b, int thread, auto& mk) {
    if constexpr (kVectorLanes<LaneT<T, W>>) {
      if (b < groups) {
        AbiLanes<T, W>* lanes[kAbiGroupMax];
        for (int j = 0; j < g; ++j) lanes[j] = &ws.lanes(thread, j);
        // (kAbiGroup gives 2 or 8 here.)
        if (g == kAbiGroupMax)
          abiInverseBlockGroup<T, W, kAbiGroupMax>(model, config.kin(thread), config.art(thread),
                                                   lanes, g * b * W, Minv, mk, ws.stream_rows);
        else
          abiInverseBlockGroup<T, W, 2>(model, config.kin(thread), config.art(thread), lanes,
                                        g * b * W, Minv, mk, ws.stream_rows);
        return;
      }
    }
    block(b + groups * (g - 1), thread, mk);
  };
  // Subnormals flushed to zero on every thread (core/fpenv.hpp): far entries of a long chain
  // underflow, and on Intel cores each operation on them takes a microcode assist.
  if (ws.threads() == 1 || !std::is_same_v<std::decay_t<Mark>, NoMark>) {
    config.ready(0);
    FlushSubnormals flush;
    for (int b = 0; b < units; ++b) unit(b, 0, mark);
    abiStoreFence<T>();
    return;
  }
#pragma omp parallel num_threads(ws.threads())
  {
    // This thread's configuration, then its blocks: it reads no other thread's copy.
    config.ready(omp_thread());
    FlushSubnormals flush;
    NoMark none;
    // Units (groups, then single blocks) are independent and write disjoint parts of Minv;
    // later blocks cost more: the last units first, handed out as threads come free (the
    // single blocks after the groups, each less than a group, go out before the last group;
    // a fixed snake order was slower: paper/ENGINEERING.md, "Units handed out largest first").
#pragma omp for schedule(dynamic, 1) nowait
    for (int r = 0; r < units; ++r) unit(units - 1 - r, omp_thread(), none);
    abiStoreFence<T>();
  }
}

// The same with one configuration read by every thread.
template <class T, class Out, class Mark = NoMark>
void abiInverse(const Model& model, const Kinematics<T>& kin, const Articulated<T>& art,
                AbiWorkspace<T>& ws, Out& Minv, Mark&& mark = {}, bool upper = false) {
  abiInverse<T>(model, AbiConfigurations<T>{&kin, &art, 1}, ws, Minv, mark, upper);
}

// Columns c0 … c0+W−1 of X = M⁻¹R: the full backward sweep, then the full forward sweep.
template <class T, int W, class In, class Out, class Mark>
MINV_FLATTEN void abiSolveBlock(const Model& model, const Kinematics<T>& kin,
                                const Articulated<T>& art, AbiLanes<T, W>& ws, const In& R, int c0,
                                Out& X, Mark& mark) {
  const int nb = model.nb(), nv = model.nv();
  const int width = std::min<int>(W, static_cast<int>(R.cols()) - c0);
  // r: the right-hand sides, one per lane (unused lanes zero); Y is zero between blocks.
  for (int v = 0; v < nv; ++v) {
    ws.u[v].setZero();
    for (int w = 0; w < width; ++w) setLane(ws.u[v], w, R(v, c0 + w));
  }
  abiBackward<T, W, false>(model, kin, art, ws, nb - 1);
  mark("impulse propagation");
  abiForward<T, W>(model, kin, art, ws, nb - 1);
  mark("velocity updates");
  // Δq̇ of lane w is column c0 + w of X.
  for (int w = 0; w < width; ++w)
    for (int v = 0; v < nv; ++v) X(v, c0 + w) = ws.u[v](w);
}

// X = M⁻¹R, W columns at a time; a block of at most W/2 columns runs half as wide, and a
// single column one lane wide.
template <class T, class In, class Out, class Mark = NoMark>
void abiSolve(const Model& model, AbiConfigurations<T> config, AbiWorkspace<T>& ws, const In& R,
              Out& X, Mark&& mark = {}) {
  constexpr int W = kAbiLanes<T>;
  const int m = static_cast<int>(R.cols()), blocks = (m + W - 1) / W;
  auto block = [&](int b, int thread, auto& mk) {
    const Kinematics<T>& kin = config.kin(thread);
    const Articulated<T>& art = config.art(thread);
    const int width = std::min(W, m - b * W);
    if (W > 1 && width == 1)
      abiSolveBlock<T, 1>(model, kin, art, ws.narrow[thread], R, b * W, X, mk);
    else if (2 * width <= W)
      abiSolveBlock<T, AbiWorkspace<T>::kHalf>(model, kin, art, ws.half[thread], R, b * W, X, mk);
    else
      abiSolveBlock<T, W>(model, kin, art, ws.wide[thread], R, b * W, X, mk);
  };
  // Subnormals flushed to zero on every thread, as in abiInverse.
  if (ws.threads() == 1 || blocks == 1 || !std::is_same_v<std::decay_t<Mark>, NoMark>) {
    config.ready(0);
    FlushSubnormals flush;
    for (int b = 0; b < blocks; ++b) block(b, 0, mark);
    return;
  }
#pragma omp parallel num_threads(ws.threads())
  {
    config.ready(omp_thread());
    FlushSubnormals flush;
    NoMark none;
    // Every block sweeps the whole tree: equal costs, handed out in equal shares.
#pragma omp for schedule(static)
    for (int b = 0; b < blocks; ++b) block(b, omp_thread(), none);
  }
}

// The same with one configuration read by every thread.
template <class T, class In, class Out, class Mark = NoMark>
void abiSolve(const Model& model, const Kinematics<T>& kin, const Articulated<T>& art,
              AbiWorkspace<T>& ws, const In& R, Out& X, Mark&& mark = {}) {
  abiSolve<T>(model, AbiConfigurations<T>{&kin, &art, 1}, ws, R, X, mark);
}

// Algorithm 1/2's whole pipeline from q on the scalar T, marking each stage of Table 1:
// spatial axes, isolated inertias, articulated inertias, then per column impulse propagation
// and velocity updates. M⁻¹ for m = 0, else M⁻¹R for R = the first m columns of I.
template <class T, class Mark>
void abiPipeline(const Model& model, const Eigen::VectorXd& q, int m, Mark&& mark) {
  Kinematics<T> kin(model, Origin::EachRoot);
  Articulated<T> art(model);
  AbiWorkspace<T> ws(model);
  const VecX<T> qt = q.cast<T>();
  computeKinematics<T>(model, qt, kin, mark);
  articulatedInertias<T>(model, kin, art);
  mark("articulated inertias");
  MatX<T> X(model.nv(), m > 0 ? m : model.nv());
  if (m == 0) {
    abiInverse<T>(model, kin, art, ws, X, mark);
  } else {
    const MatX<T> R = MatX<T>::Identity(model.nv(), m);
    abiSolve<T>(model, kin, art, ws, R, X, mark);
  }
}

class AbiSolver final : public Solver {
 public:
  // Every stage of Table 1 on the counting scalar.
  static std::vector<StageCount> countStages(const Model& model, const Eigen::VectorXd& q, int m);

  void setThreads(int n) override;
  int threads() const override { return threads_; }
  void prepare(const Model& model) override;
  void configure(const Eigen::VectorXd& q) override;
  void inverse(MatrixOut Minv) override;
  void inverseUpper(MatrixOut Minv) override;
  void solve(MatrixIn R, MatrixOut X) override;
  // The two sweeps of every full block of columns on one thread, writing nothing: the part of
  // inverse() that is arithmetic (bench_abi's parts).
  void sweepsOnly();

 private:
  const Model* model_ = nullptr;
  int threads_ = 1;
  // Below this many DOFs abi runs on one thread whatever setThreads says: the fork and the
  // copies' configure cost more than the columns they share (two threads 0.71× at n = 128 on
  // the Zen 5 guest, 1.20× at 256).
  static constexpr int kParallelColumns = 192;
  // Threads used: threads_, or one below kParallelColumns.
  int team() const { return model_->nv() >= kParallelColumns ? threads_ : 1; }
  // One configuration per thread, each computed by its own thread at the start of the next
  // inverse or solve (configure() keeps q; one parallel region does both): a thread's sweeps
  // then read only lines its own core wrote (shared, thread 0's configure rewrote lines the
  // other core had read, 2-4× slower: paper/ENGINEERING.md, "Two threads").
  std::vector<Kinematics<double>> kin_;
  std::vector<Articulated<double>> art_;
  std::unique_ptr<AbiWorkspace<double>> ws_;
  // The last configuration, its number (0: none since prepare) and the number each copy holds.
  Eigen::VectorXd q_;
  long configured_ = 0;
  std::vector<long> made_;
  void allocate();
  void makeCopy(int t);
  AbiConfigurations<double> configurations() {
    if (kin_.size() == 1) return {kin_.data(), art_.data(), 1};
    return {kin_.data(), art_.data(), static_cast<int>(kin_.size()),
            [](void* self, int t) { static_cast<AbiSolver*>(self)->makeCopy(t); }, this};
  }
};

}  // namespace minv
