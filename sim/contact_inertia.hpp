// The contact-space inertia A = Jᵀ M⁻¹ J in Θ(n + m²), without M⁻¹J: a recursion over the tree
// that meets every pair of contact directions at their lowest common ancestor.
//
// References: Wensing, Featherstone & Orin, "A reduced-order recursive algorithm for the
// computation of the operational-space inertia matrix", ICRA 2012 (the extended-force-
// propagator algorithm, EFPA, O(N + md + m²) for m end-effectors in a tree of depth d);
// Sathya, Decré & Swevers, "PV-OSIMr: a lowest order complexity algorithm for computing the
// Delassus matrix" (2024), O(n + m²) by composing force and motion propagators, the bound
// this code attains the same way (composite propagators along the chains that carry one
// subtree's contacts). Articulated-body quantities: Featherstone, Rigid Body Dynamics
// Algorithms (RBDA, 2008), §7.2-7.3. The derivation below is ours, in RBDA notation, world
// frame, 0-based bodies with λ(i) < i.
//
// Notation. Per body i with k_i DOFs (core/articulated.hpp): S_i (6×k_i), IA_i, U_i = IA_i S_i,
// D_i = S_iᵀ U_i. The force propagator of joint i, Pᵀ_i = 1 − U_i D_i⁻¹ S_iᵀ, carries a spatial
// force (impulse) applied to i's articulated body to the force it exerts on λ(i) (the backward
// step of the impulse sweeps, core/impulse_sweeps.hpp); its transpose P_i = 1 − S_i D_i⁻¹ U_iᵀ
// carries λ(i)'s velocity change to the part of i's that i does not produce itself;
// K_i = S_i D_i⁻¹ S_iᵀ is the velocity change the joint adds per unit force on i's articulated
// body. A unit impulse f at body b gives, with f_b = f and f_λ(j) = Pᵀ_j f_j on b's path,
//   Δv_i = P_i Δv_λ(i) + K_i f_i  on b's path (Δv_λ(root) = 0),  Δv_i = P_i Δv_λ(i)  elsewhere.
// Hence, for a second impulse f' at b' whose lowest common ancestor with b is a,
//   f'ᵀ Δv_b' = f'ᵀ_a Δv_a = Σ_{j = a, λ(a), …, root} f'ᵀ_j K_j f_j = f'ᵀ_a Ω_a f_a,
//   Ω_i = K_i + P_i Ω_λ(i) Pᵀ_i   (Ω_λ(root) = 0),
// where f_a, f'_a are f and f' propagated to a (Pᵀ of every joint strictly below a on their
// paths) and Ω_i is the apparent inverse inertia of body i within the whole tree: the
// velocity change of i per unit impulse on i (Ω_root = IA_root⁻¹ for a floating base, whose
// S_0 is invertible). Every
// entry of A is one such bilinear form: A_rc = f_{r,a}ᵀ Ω_a f_{c,a}, a = LCA(b_r, b_c);
// directions in different trees of a forest do not couple (A_rc = 0).
//
// Algorithm. Directions are sorted by the preorder position of their body (stable), so that
// the directions of every subtree occupy a contiguous range [s_i, e_i) and those on body i
// itself come first. (1) Ω_i top-down where pairs meet and above: at roots, at bodies with
// contacts of their own and below them or below two children, and at their ancestors; with
// W = Ω_λ(i) U_i D_i⁻¹, Q = D_i⁻ᵀU_iᵀ W + D_i⁻¹, E = W − ½ S_i Q:  Ω_i = Ω_λ(i) − S_i Eᵀ − E S_iᵀ.
// A leaf body with contacts (≤ 6 directions, not a root) needs no Ω: by the sum above, its
// own pairs are f_xᵀ Ω_a f_y = Σ_j (S_jᵀ f_x)ᵀ D_j⁻¹ (S_jᵀ f_y) over the joints j from the
// leaf up to (excluding) the first body a with Ω, plus the directions propagated to a times
// Ω_a; the S_jᵀ f are the products the propagation forms anyway. Such a deferred block climbs
// with its directions and is written at a (the centipede: Ω at the segments only, none on
// the legs).
// (2) Bottom-up in reverse preorder, the propagated forces F (m×6, a row per direction) climb
// the tree. A body with contacts of its own or with two or more children carrying contacts is
// a branch node: each child's range is brought up to it (F ← F P_c, i.e. f ← Pᵀ_c f, or by a
// pending composite propagator), and every pair whose LCA it is gets its block
// A(X, Y) = F_X Ω_a F_Yᵀ, written with its mirror: own × [s_a, e_a) and child range ×
// [its end, e_a). Any other body on a contact path (one child with contacts, no contacts of
// its own) only composes the pending propagator Φ ← Pᵀ_c Φ (6×6), or, for ≤ 6 directions,
// applies Pᵀ_c to them at once. Every pair is written exactly once (both triangles).
//
// Cost. (1) ≈ 85 mul + 85 add per 1-DOF body with Ω; (2) per direction one
// propagation per branch node above it (12·k mul + 12·k add for k DOFs, 36 + 30 for a
// composite), at most 2·(contact bodies) − 1 branch nodes, and ≤ 6 directions through any
// pass-through body; then 6 mul + 6 add per entry of one triangle of A plus 36 mul + 30 add
// per direction of the smaller side of each block for F Ω (formed once per node: a child's
// deferred block and its pair block there share it); a deferred block adds, per joint
// climbed, k² multiply-adds per direction and k per entry of its triangle. In all Θ(n + m²) with
// the Θ(m²) term ≈ 6·m²/2 multiply-adds; the centipede's counts are in
// paper/contact_inertia_counts.md.
//
// Contract. kin and art hold the world-frame S, U, D⁻¹ and U D⁻¹ of one configuration
// (core/kinematics.hpp, core/articulated.hpp); direction r is the unit spatial force (wrench)
// wrenches[r] on bodies[r], about the world origin; A is m×m on entry (the caller sizes it)
// and holds A_rc = (J_rᵀ)ᵀ M⁻¹ J_c on exit, exactly symmetric, every entry written. Any tree:
// forests, several directions on one body, directions on a (floating) root, joints of 1, 3 or
// 6 DOFs. The workspace is built once per tree for up to `max_columns` directions; the kernel
// does not allocate unless m exceeds that capacity (then it grows it once); the per-call
// tables (the directions' order, where Ω is needed) are kept while the bodies repeat. Templated on
// the scalar: the Counted instantiation counts the very code that runs on double. With threads > 1
// the large pair blocks (the Θ(m²) part) are split by rows among OpenMP threads; the result is
// the same bit for bit (every entry is computed by the same products in the same order).
//
// Measured dead end: sharing the rows of every subtree of at least 256 directions between two
// threads (the whole bottom-up pass in one OpenMP region; bit for bit the same A) made the S =
// 250 centipede slower on the 2-vCPU Zen 5 guest (20 steps, medians): matrices 1.93-2.14 ms on
// one thread against 3.12 ms with two OpenMP barriers per spine segment, and 2.59-3.18 ms with
// a position cut and the lead's per-node signal in their place (no barrier); the contact
// solve, which reads A on the first core, 1.62-1.84 -> 1.92-2.90 ms. With every row on the
// lead and the other thread only waiting the pass alone took 2.6 ms against 2.1: on this
// guest, lines written on one core and read on the other cost more than the rows' arithmetic.
#pragma once

#include <Eigen/Core>
#include <algorithm>
#include <stdexcept>
#include <type_traits>
#include <vector>

#include "core/articulated.hpp"
#include "core/impulse_sweeps.hpp"
#include "core/kinematics.hpp"
#include "core/model.hpp"

namespace minv::sim {

// Scratch of contactInertia() for one tree; per-tree tables are built here.
template <class T>
struct ContactInertiaWorkspace {
  using RowsX6 = Eigen::Matrix<T, Eigen::Dynamic, 6>;
  static constexpr int kDirectMax = 6;  // pass-through: apply Pᵀ directly up to this many rows
  static constexpr int kTile = 64;      // scatter tile when directions arrive out of preorder
  static constexpr int kParallelEntries = 16384;  // threads split pair blocks at least this big

  // Per tree: preorder of the bodies, each body's position in it, children (CSR, by index).
  std::vector<int> order, pre, child_start, children;
  // Per body, kept while the directions' bodies repeat (the tables): directions on the body,
  // in its subtree, range start, children with directions, Ω needed. Per body, per call: Ω,
  // pending Φ, a deferred own block (the K terms summed so far), their flags.
  std::vector<int> own, cnt, start, cursor, kids;
  std::vector<Mat6<T>> Omega, Phi, Bpend;
  std::vector<char> phi_identity, need, pend;
  // Per direction: sorted position → input index and back (tables); F (row per direction, per
  // call), F·Ω (row x at position x; `gof[x]`: the Ω it was formed with, this call), Fᵀ·S
  // scratch. The first `nbodies` of `bodies` are the last call's directions' bodies (sized to
  // the capacity, so that a copied workspace keeps it); `tables`: whether the tables are theirs.
  std::vector<int> perm, pos, bodies;
  std::vector<const Mat6<T>*> gof;
  int nbodies = 0;
  bool tables = false, identity = true;
  RowsX6 F, G, Tk;
  MatX<T> tile;

  ContactInertiaWorkspace(const Model& model, int max_columns)
      : pre(model.nb()),
        child_start(model.nb() + 1, 0),
        own(model.nb()),
        cnt(model.nb()),
        start(model.nb()),
        cursor(model.nb()),
        kids(model.nb()),
        Omega(model.nb()),
        Phi(model.nb()),
        Bpend(model.nb()),
        phi_identity(model.nb()),
        need(model.nb()),
        pend(model.nb()),
        tile(kTile, kTile) {
    const int nb = model.nb();
    // Children lists, in increasing index.
    for (int i = 0; i < nb; ++i)
      if (model.parent(i) >= 0) ++child_start[model.parent(i) + 1];
    for (int i = 0; i < nb; ++i) child_start[i + 1] += child_start[i];
    children.resize(child_start[nb]);
    std::vector<int> fill(child_start.begin(), child_start.end() - 1);
    for (int i = 0; i < nb; ++i)
      if (model.parent(i) >= 0) children[fill[model.parent(i)]++] = i;
    // Preorder: roots in increasing index, children in increasing index.
    std::vector<int> stack;
    for (int r = nb - 1; r >= 0; --r)
      if (model.parent(r) < 0) stack.push_back(r);
    while (!stack.empty()) {
      const int i = stack.back();
      stack.pop_back();
      pre[i] = static_cast<int>(order.size());
      order.push_back(i);
      for (int c = child_start[i + 1] - 1; c >= child_start[i]; --c) stack.push_back(children[c]);
    }
    reserve(max_columns);
  }

  // Capacity for m directions.
  void reserve(int m) {
    if (static_cast<int>(perm.size()) >= m) return;
    perm.resize(m), pos.resize(m), bodies.resize(m), gof.resize(m);
    F.resize(m, 6);
    G.resize(m, 6);
    Tk.resize(m, 6);
  }
};

namespace detail {

template <int K>
using MaxK = std::integral_constant<int, K == Eigen::Dynamic ? 6 : K>;
template <class T, int K>
using Mat6K = Eigen::Matrix<T, 6, K, 0, 6, MaxK<K>::value>;
template <class T, int K>
using MatKK = Eigen::Matrix<T, K, K, 0, MaxK<K>::value, MaxK<K>::value>;

// C(x, y) = Σ_{d < D} X(x, d) Y(y, d) (or C −= it) for x < nx, y < ny, with X(x, d) =
// X[x + lx·d], Y(y, d) = Y[sy·y + sd·d], C(x, y) = C[x + lc·y]; in plain loops along x (the
// contiguous direction of F's columns): the products with rows of F below, small (3 rows) or
// long (a subtree's thousand), where Eigen's generic loops over dynamic-height blocks cost
// more than the arithmetic. D: the inner size at compile time, or Eigen::Dynamic with dd.
// NX rows known at compile time: the accumulators of a column of C stay in registers across d,
// where the loop over x below would reload and store them.
template <int D, bool Sub, int NX, class T>
MINV_INLINE void rowProductFixed(const T* __restrict X, int lx, const T* __restrict Y, int sy,
                                 int sd, int ny, T* __restrict C, int lc, int dd) {
  const int n = D == Eigen::Dynamic ? dd : D;
  for (int y = 0; y < ny; ++y) {
    T* c = C + static_cast<std::ptrdiff_t>(lc) * y;
    // acc = ±X(:, 0) Y(y, 0) (+ C(:, y) when subtracting)
    T acc[NX];
    const T y0 = Y[sy * y];
    for (int x = 0; x < NX; ++x) acc[x] = Sub ? c[x] - X[x] * y0 : X[x] * y0;
    // acc ±= X(:, d) Y(y, d) for the remaining d
    for (int d = 1; d < n; ++d) {
      const T yd = Y[sy * y + sd * d];
      for (int x = 0; x < NX; ++x)
        acc[x] = Sub ? acc[x] - X[x + static_cast<std::ptrdiff_t>(lx) * d] * yd
                     : acc[x] + X[x + static_cast<std::ptrdiff_t>(lx) * d] * yd;
    }
    for (int x = 0; x < NX; ++x) c[x] = acc[x];
  }
}

template <int D, bool Sub, class T>
MINV_INLINE void rowProduct(const T* __restrict X, int lx, const T* __restrict Y, int sy, int sd,
                            int nx, int ny, T* __restrict C, int lc, int dd = D) {
  // 3 rows (a leg's contact directions): the fixed-size loop above, same operations in the same
  // order. Only that count: on Zen 5 variants for every count below 8 made the centipede's step
  // slower (S = 5 matrices 2.75 -> 3.69 us), though a Xeon gained by them.
  if (nx == 0) return;
  if (nx == 3) return rowProductFixed<D, Sub, 3>(X, lx, Y, sy, sd, ny, C, lc, dd);
  const int n = D == Eigen::Dynamic ? dd : D;
  for (int y = 0; y < ny; ++y) {
    T yd[6];
    for (int d = 0; d < n; ++d) yd[d] = Y[sy * y + sd * d];
    T* c = C + static_cast<std::ptrdiff_t>(lc) * y;
    for (int x = 0; x < nx; ++x) {
      T acc = Sub ? c[x] - X[x] * yd[0] : X[x] * yd[0];
      for (int d = 1; d < n; ++d)
        acc = Sub ? acc - X[x + static_cast<std::ptrdiff_t>(lx) * d] * yd[d]
                  : acc + X[x + static_cast<std::ptrdiff_t>(lx) * d] * yd[d];
      c[x] = acc;
    }
  }
}

// Ω_i = Ω_λ(i) − S Eᵀ − E Sᵀ with W = Ω_λ(i) U D⁻¹, Q = (U D⁻¹)ᵀ W + D⁻¹, E = W − ½ S Q
// (Ω_λ(i) = 0 at a root: Ω_i = S D⁻¹ Sᵀ); only one triangle is summed, then mirrored.
template <class T, int K>
void omegaStep(std::integral_constant<int, K>, const Kinematics<T>& kin, const Articulated<T>& art,
               const Mat6<T>* Op, Mat6<T>& O, int i, int v, int k) {
  const auto S = kin.S.template middleCols<K>(v, k);
  const auto UD = art.UDinv.template middleCols<K>(v, k);
  MatKK<T, K> Q = art.Dinv[i].template topLeftCorner<K, K>(k, k);
  Mat6K<T, K> E(6, k);
  if (Op) {
    E.noalias() = Op->lazyProduct(UD);
    Q.noalias() += UD.transpose().lazyProduct(E);
  } else {
    E.setZero();
  }
  // E = W − ½ S Q
  const MatKK<T, K> halfQ = T(0.5) * Q;
  E.noalias() -= S.lazyProduct(halfQ);
  // Ω_i(r, c) = Ω_λ(i)(r, c) − (S Eᵀ)(r, c) − (S Eᵀ)(c, r)
  const Mat6<T> SE = S.lazyProduct(E.transpose());
  for (int c = 0; c < 6; ++c)
    for (int r = c; r < 6; ++r) {
      T x = -SE(r, c) - SE(c, r);
      if (Op) x += (*Op)(r, c);
      O(r, c) = x;
      O(c, r) = x;
    }
}

// f ← Pᵀ_c f = f − U D⁻¹ (Sᵀ f) for the rows [r0, r0 + L) of F (a row per direction).
template <class T>
void applyPropagator(const Kinematics<T>& kin, const Articulated<T>& art,
                     ContactInertiaWorkspace<T>& ws, int v, int k, int r0, int L) {
  T* F = ws.F.data() + r0;
  T* t = ws.Tk.data();
  const int lf = static_cast<int>(ws.F.rows()), lt = static_cast<int>(ws.Tk.rows());
  const T *S = kin.S.data() + 6 * v, *UD = art.UDinv.data() + 6 * v;
  forJointSize(k, [&](auto K) {
    constexpr int N = decltype(K)::value;
    // t = F S (L×k, into Tk), then F −= t (U D⁻¹)ᵀ.
    rowProduct<6, false>(F, lf, S, 6, 1, L, k, t, lt);
    rowProduct<N, true>(t, lt, UD, 1, 6, L, 6, F, lf, k);
  });
}

// f ← Φ f for the rows [r0, r0 + L) of F.
template <class T>
void applyComposite(ContactInertiaWorkspace<T>& ws, const Mat6<T>& Phi, int r0, int L) {
  T* F = ws.F.data() + r0;
  T* t = ws.Tk.data();
  const int lf = static_cast<int>(ws.F.rows()), lt = static_cast<int>(ws.Tk.rows());
  // t = F Φᵀ, then F = t.
  rowProduct<6, false>(F, lf, Phi.data(), 1, 6, L, 6, t, lt);
  for (int d = 0; d < 6; ++d)
    for (int r = 0; r < L; ++r) F[r + static_cast<std::ptrdiff_t>(lf) * d] = t[r + lt * d];
}

// Φ ← Pᵀ_c Φ = Φ − U D⁻¹ (Sᵀ Φ), or Pᵀ_c itself for Φ = 1.
template <class T>
void composePropagator(const Kinematics<T>& kin, const Articulated<T>& art, int v, int k,
                       bool identity, const Mat6<T>& Phi, Mat6<T>& out) {
  const auto S = kin.S.middleCols(v, k);
  const auto UD = art.UDinv.middleCols(v, k);
  if (identity) {
    out.setIdentity();
    out.noalias() -= UD * S.transpose();
    return;
  }
  const MatK<T> StPhi = S.transpose() * Phi;
  out = Phi;
  out.noalias() -= UD * StPhi;
}

// B ← B + t D_c⁻¹ tᵀ (lower triangle) for t = F_rows S_c (L×k), left in Tk by
// applyPropagator: joint c's term f_xᵀ K_c f_y = (S_cᵀ f_x)ᵀ D_c⁻¹ (S_cᵀ f_y) of a deferred block.
// K: k at compile time (forJointSize: 1, 3, 6; the centipede's knees and hips are 1 and 3), or
// Eigen::Dynamic.
template <class T, int K>
void addJointTerm(std::integral_constant<int, K>, const Articulated<T>& art,
                  const ContactInertiaWorkspace<T>& ws, int c, int kk, int L, Mat6<T>& B) {
  const int k = K == Eigen::Dynamic ? kk : K;
  const T* t = ws.Tk.data();
  const int lt = static_cast<int>(ws.Tk.rows());
  const MatK<T>& Dinv = art.Dinv[c];
  for (int x = 0; x < L; ++x) {
    // td = t_x D⁻¹, then B(x, y) += td · t_y for y ≤ x.
    T td[6];
    for (int j = 0; j < k; ++j) {
      T acc = t[x] * Dinv(0, j);
      for (int i = 1; i < k; ++i) acc += t[x + lt * i] * Dinv(i, j);
      td[j] = acc;
    }
    for (int y = 0; y <= x; ++y) {
      T acc = td[0] * t[y];
      for (int j = 1; j < k; ++j) acc += td[j] * t[y + lt * j];
      B(x, y) += acc;
    }
  }
}
template <class T>
void addJointTerm(const Articulated<T>& art, const ContactInertiaWorkspace<T>& ws, int c, int k,
                  int L, Mat6<T>& B) {
  forJointSize(k, [&](auto K) { addJointTerm(K, art, ws, c, k, L, B); });
}

// G = F Ω for the rows [x0, x0 + L) (at their own positions in G), unless this call already
// formed them with this Ω: a deferred block at a branch node and the node's pair block of the
// same child range share them. Returns G's row x0.
template <class T>
T* formG(ContactInertiaWorkspace<T>& ws, const Mat6<T>& Om, int x0, int L) {
  T* G = ws.G.data() + x0;
  if (std::all_of(ws.gof.begin() + x0, ws.gof.begin() + x0 + L,
                  [&](const Mat6<T>* o) { return o == &Om; }))
    return G;
  const int lf = static_cast<int>(ws.F.rows()), lg = static_cast<int>(ws.G.rows());
  rowProduct<6, false>(ws.F.data() + x0, lf, Om.data(), 6, 1, L, 6, G, lg);
  std::fill(ws.gof.begin() + x0, ws.gof.begin() + x0 + L, &Om);
  return G;
}

// A deferred block finished at a: A(P(x), P(y)) = F_x Ω_a F_yᵀ + B(x, y) for the rows
// [x0, x0 + L) (L ≤ kDirectMax), both triangles.
template <class T>
void deferredBlock(ContactInertiaWorkspace<T>& ws, const Mat6<T>& Om, int x0, int L,
                   const Mat6<T>& B, MatX<T>& A) {
  const T* F = ws.F.data() + x0;
  const T* G = formG(ws, Om, x0, L);
  const int lf = static_cast<int>(ws.F.rows()), lg = static_cast<int>(ws.G.rows());
  for (int y = 0; y < L; ++y)
    for (int x = y; x < L; ++x) {
      T v = B(x, y);
      for (int d = 0; d < 6; ++d) v += G[x + lg * d] * F[y + lf * d];
      const int r = ws.perm[x0 + x], c = ws.perm[x0 + y];
      A(r, c) = v;
      A(c, r) = v;
    }
}

// The pairs of position ranges X = [x0, x0 + nx) and Y = [y0, y0 + ny), disjoint or equal
// (diag): A(P(X), P(Y)) = F_X Ω F_Yᵀ and its mirror, P the sorted position → input index.
// With threads > 1, a block of at least kParallelEntries entries in preorder is split by rows
// among OpenMP threads (each writes its rows and their mirror).
template <class T>
void pairBlock(ContactInertiaWorkspace<T>& ws, const Mat6<T>& Om, int x0, int nx, int y0, int ny,
               bool diag, bool identity, MatX<T>& A, int threads) {
  if (nx == 0 || ny == 0) return;
  // G = F_s Ω on the smaller side s; the block is F_big Gᵀ (big rows, small columns).
  if (ny > nx) std::swap(x0, y0), std::swap(nx, ny);
  const T* F = ws.F.data();
  const T* G = formG(ws, Om, y0, ny);
  const int lf = static_cast<int>(ws.F.rows()), lg = static_cast<int>(ws.G.rows());
  const int la = static_cast<int>(A.rows());
  // Rows [x, x + L) of F_X Gᵀ into C (column stride lc).
  auto block = [&](int x, int L, T* C, int lc) {
    rowProduct<6, false>(F + x, lf, G, 1, lg, L, ny, C, lc);
  };
  if (identity && !diag) {
    // Rows [r0, r0 + L) of the block and their mirror.
    auto rows = [&](int r0, int L) {
      block(x0 + r0, L, A.data() + x0 + r0 + static_cast<std::ptrdiff_t>(la) * y0, la);
      A.block(y0, x0 + r0, ny, L) = A.block(x0 + r0, y0, L, ny).transpose();
    };
    // Chunks of rows, the same on one thread or several (the same products, bit for bit).
    constexpr int kChunk = 64;
    const int chunks = (nx + kChunk - 1) / kChunk;
    const bool split =
        threads > 1 && chunks > 1 && nx * ny >= ContactInertiaWorkspace<T>::kParallelEntries;
    auto chunk = [&](int q) { rows(q * kChunk, std::min(kChunk, nx - q * kChunk)); };
    if (split) {
#pragma omp parallel for schedule(static) num_threads(threads)
      for (int q = 0; q < chunks; ++q) chunk(q);
    } else {
      for (int q = 0; q < chunks; ++q) chunk(q);
    }
    return;
  }
  if (identity) {
    auto B = A.block(x0, y0, nx, ny);
    block(x0, nx, A.data() + x0 + static_cast<std::ptrdiff_t>(la) * y0, la);
    for (int c = 1; c < nx; ++c)
      for (int r = 0; r < c; ++r) B(r, c) = B(c, r);
    return;
  }
  // Out of preorder: tiles of the block, scattered to the input order.
  const int tl = ContactInertiaWorkspace<T>::kTile;
  for (int j0 = 0; j0 < ny; j0 += tl)
    for (int i0 = diag ? j0 : 0; i0 < nx; i0 += tl) {
      const int ti = std::min(tl, nx - i0), tj = std::min(tl, ny - j0);
      auto tile = ws.tile.topLeftCorner(ti, tj);
      rowProduct<6, false>(F + x0 + i0, lf, G + j0, 1, lg, ti, tj, ws.tile.data(), tl);
      for (int j = 0; j < tj; ++j)
        for (int i = diag && i0 == j0 ? j : 0; i < ti; ++i) {
          const int r = ws.perm[x0 + i0 + i], c = ws.perm[y0 + j0 + j];
          A(r, c) = tile(i, j);
          A(c, r) = tile(i, j);
        }
    }
}

}  // namespace detail

// A = Jᵀ M⁻¹ J for the m unit wrenches `wrenches` on `bodies` (see the contract above).
template <class T>
void contactInertia(const Model& model, const Kinematics<T>& kin, const Articulated<T>& art,
                    const std::vector<int>& bodies, const std::vector<Vec6<T>>& wrenches,
                    ContactInertiaWorkspace<T>& ws, MatX<T>& A, int threads = 1) {
  const int nb = model.nb(), m = static_cast<int>(bodies.size());
  if (static_cast<int>(wrenches.size()) != m || A.rows() != m || A.cols() != m)
    throw std::invalid_argument("contactInertia: bodies, wrenches and A (m x m) disagree");
  if (m == 0) return;
  ws.reserve(m);
  constexpr int kDirect = ContactInertiaWorkspace<T>::kDirectMax;
  // The per-call tables below depend only on the directions' bodies: kept while they repeat,
  // as a simulator's contacts do from step to step.
  if (!ws.tables || ws.nbodies != m ||
      !std::equal(bodies.begin(), bodies.end(), ws.bodies.begin())) {
    // Directions per body, each subtree's range in preorder, the sorted order (stable).
    std::fill(ws.own.begin(), ws.own.end(), 0);
    for (int r = 0; r < m; ++r) ++ws.own[bodies[r]];
    for (int p = 0, run = 0; p < nb; ++p) {
      const int i = ws.order[p];
      ws.start[i] = ws.cursor[i] = run;
      run += ws.own[i];
    }
    ws.identity = true;
    for (int r = 0; r < m; ++r) {
      const int pos = ws.cursor[bodies[r]]++;
      ws.perm[pos] = r, ws.pos[r] = pos;
      ws.identity &= pos == r;
    }
    for (int i = 0; i < nb; ++i) ws.cnt[i] = ws.own[i], ws.kids[i] = 0, ws.need[i] = 0;
    for (int i = nb - 1; i >= 0; --i)
      if (model.parent(i) >= 0 && ws.cnt[i] > 0) {
        ws.cnt[model.parent(i)] += ws.cnt[i];
        ++ws.kids[model.parent(i)];
      }
    // Ω where pairs meet and on the way down to there: a root, a body with directions of its
    // own and below it, or below two children, or a leaf with too many to defer; and their
    // ancestors.
    for (int i = nb - 1; i >= 0; --i) {
      const int o = ws.own[i], kd = ws.kids[i];
      ws.need[i] |= ws.cnt[i] > 0 && (model.parent(i) < 0 || kd >= 2 || (o > 0 && kd >= 1) ||
                                      (kd == 0 && o > kDirect));
      if (ws.need[i] && model.parent(i) >= 0) ws.need[model.parent(i)] = 1;
    }
    std::copy(bodies.begin(), bodies.end(), ws.bodies.begin());
    ws.nbodies = m;
    ws.tables = true;
  }
  const bool identity = ws.identity;
  // F: a row per direction, in the sorted order; no F Ω formed yet.
  for (int r = 0; r < m; ++r) ws.F.row(ws.pos[r]) = wrenches[r].transpose();
  std::fill(ws.gof.begin(), ws.gof.begin() + m, nullptr);

  // (1) Ω top-down where needed.
  for (int i = 0; i < nb; ++i) {
    if (!ws.need[i]) continue;
    const int p = model.parent(i), v = model.vIdx(i), k = model.nvOf(i);
    const Mat6<T>* Op = p >= 0 ? &ws.Omega[p] : nullptr;
    forJointSize(k, [&](auto K) { detail::omegaStep(K, kin, art, Op, ws.Omega[i], i, v, k); });
  }

  // (2) Bottom-up: bring the children's directions up, write the pairs that meet here.
  for (int p = nb - 1; p >= 0; --p) {
    const int a = ws.order[p];
    ws.pend[a] = 0;
    if (ws.cnt[a] == 0) continue;
    const int kd = ws.kids[a], o = ws.own[a];
    // A leaf body's own pairs (≤ kDirect directions, not a root): deferred to the next body
    // with Ω, each joint on the way adding its K term (see the header).
    if (kd == 0 && !ws.need[a]) {
      ws.Bpend[a].setZero();
      ws.pend[a] = 1;
      ws.phi_identity[a] = 1;
      continue;
    }
    // Pass-through: one child's directions, none of its own; compose or apply Pᵀ_c.
    if (o == 0 && kd == 1) {
      int c = -1;
      for (int q = ws.child_start[a]; q < ws.child_start[a + 1]; ++q)
        if (ws.cnt[ws.children[q]] > 0) c = ws.children[q];
      const int v = model.vIdx(c), k = model.nvOf(c);
      if (ws.phi_identity[c] && ws.cnt[c] <= kDirect) {
        detail::applyPropagator(kin, art, ws, v, k, ws.start[c], ws.cnt[c]);
        ws.phi_identity[a] = 1;
        if (ws.pend[c]) {
          // The deferred block climbs; at a root it is finished there.
          ws.Bpend[a] = ws.Bpend[c];
          detail::addJointTerm(art, ws, c, k, ws.cnt[c], ws.Bpend[a]);
          if (model.parent(a) >= 0)
            ws.pend[a] = 1;
          else
            detail::deferredBlock(ws, ws.Omega[a], ws.start[c], ws.cnt[c], ws.Bpend[a], A);
        }
      } else {
        detail::composePropagator(kin, art, v, k, ws.phi_identity[c], ws.Phi[c], ws.Phi[a]);
        ws.phi_identity[a] = 0;
      }
      continue;
    }
    // Branch node: every child's range propagated to a; deferred blocks finished here.
    const Mat6<T>& Om = ws.Omega[a];
    for (int q = ws.child_start[a]; q < ws.child_start[a + 1]; ++q) {
      const int c = ws.children[q];
      if (ws.cnt[c] == 0) continue;
      const int v = model.vIdx(c), k = model.nvOf(c);
      if (ws.phi_identity[c]) {
        detail::applyPropagator(kin, art, ws, v, k, ws.start[c], ws.cnt[c]);
        if (ws.pend[c]) {
          detail::addJointTerm(art, ws, c, k, ws.cnt[c], ws.Bpend[c]);
          detail::deferredBlock(ws, Om, ws.start[c], ws.cnt[c], ws.Bpend[c], A);
        }
      } else {
        Mat6<T> Phi;
        detail::composePropagator(kin, art, v, k, false, ws.Phi[c], Phi);
        detail::applyComposite(ws, Phi, ws.start[c], ws.cnt[c]);
      }
    }
    ws.phi_identity[a] = 1;
    // Pairs meeting at a: own × own, own × children, each child × the later children.
    const int s = ws.start[a], e = s + ws.cnt[a];
    detail::pairBlock(ws, Om, s, o, s, o, true, identity, A, threads);
    detail::pairBlock(ws, Om, s + o, e - s - o, s, o, false, identity, A, threads);
    for (int q = ws.child_start[a]; q < ws.child_start[a + 1]; ++q) {
      const int c = ws.children[q];
      if (ws.cnt[c] == 0) continue;
      const int end = ws.start[c] + ws.cnt[c];
      detail::pairBlock(ws, Om, ws.start[c], ws.cnt[c], end, e - end, false, identity, A, threads);
    }
  }

  // Directions in different trees of a forest do not couple.
  for (int p = 0; p < nb; ++p) {
    const int r = ws.order[p];
    if (model.parent(r) >= 0 || ws.cnt[r] == 0) continue;
    const int s = ws.start[r], e = s + ws.cnt[r];
    for (int x = s; x < e; ++x)
      for (int y = e; y < m; ++y) A(ws.perm[x], ws.perm[y]) = A(ws.perm[y], ws.perm[x]) = T(0);
  }
}

}  // namespace minv::sim
