// Articulated-body inertias in the world frame (RBDA §7.2-7.3, Table 7.1, pass 2).
//
// Contract: kin holds world-frame S and I. For each body i, leaves first:
//   U_i = IA_i S_i,  D_i = S_iᵀ U_i (k×k),  IA_λ(i) += IA_i − U_i D_i⁻¹ U_iᵀ
// Stored per configuration for the impulse sweeps of solvers/abi: U, D⁻¹ and U·D⁻¹ (the
// paper's §5.2 saving: computed once, not per column), and c_i = −S_λᵀ U_i D_i⁻¹ where a one-DOF
// body's parent is the previous body and has one DOF (the links' coupling, by which abi
// regroups its sweeps). Cost Θ(nb); no allocation.
#pragma once

#include <type_traits>
#include <vector>

#include "core/kinematics.hpp"

namespace minv {

template <class T>
struct Articulated {
  std::vector<Mat6<T>> IA;    // articulated-body inertias
  Mat6N<T> U;                 // U = IA S, column per DOF
  Mat6N<T> UDinv;             // U D⁻¹, column per DOF
  std::vector<MatK<T>> Dinv;  // D⁻¹ per body, k×k
  VecX<T> dinv;               // D⁻¹ of each one-DOF body at its DOF: dense, for the sweeps
  // c_i = −S_λᵀ U_i D_i⁻¹ at the DOF of a one-DOF body i whose parent λ = i − 1 has one DOF
  // (else 0): the coupling of consecutive links, by which abi's sweeps regroup their chains.
  VecX<T> couple;
  // The bodies with a child other than the next body (a branch point), in order: their IA
  // gathers those children's terms in memory (articulatedInertias).
  std::vector<int> gathering;
  std::vector<char> gathers;  // per body: is it in `gathering`

  explicit Articulated(const Model& m)
      : IA(m.nb()),
        U(Mat6N<T>::Zero(6, m.nv())),
        UDinv(Mat6N<T>::Zero(6, m.nv())),
        Dinv(m.nb()),
        dinv(VecX<T>::Zero(m.nv())),
        couple(VecX<T>::Zero(m.nv())),
        gathers(m.nb(), 0) {
    for (int i = 0; i < m.nb(); ++i) {
      Dinv[i] = MatK<T>::Zero(m.nvOf(i), m.nvOf(i));
      const int p = m.parent(i);
      if (p >= 0 && p != i - 1) gathers[p] = 1;
    }
    for (int i = 0; i < m.nb(); ++i)
      if (gathers[i]) gathering.push_back(i);
  }
};

// Per-joint steps are compiled per joint size, so that their products are fixed-size: calls
// step(std::integral_constant<int, K>) with K = 1 (revolute, prismatic), 3 (spherical),
// 6 (floating), Eigen::Dynamic for any other k.
template <class Step>
void forJointSize(int k, Step&& step) {
  if (k == 1) return step(std::integral_constant<int, 1>{});
  if (k == 3) return step(std::integral_constant<int, 3>{});
  if (k == 6) return step(std::integral_constant<int, 6>{});
  step(std::integral_constant<int, Eigen::Dynamic>{});
}

// A K×K block (K fixed, or Dynamic up to 6) without heap allocation.
template <class T, int K>
using MatJ = Eigen::Matrix<T, K, K, 0, K == Eigen::Dynamic ? 6 : K, K == Eigen::Dynamic ? 6 : K>;

// A small symmetric positive-definite k×k matrix (k ≤ 6) factored as D = L Δ Lᵀ, L unit lower
// triangular, without square roots (the same elimination as Cholesky, as stable on SPD
// matrices): L below the diagonal and r_j = 1 / Δ_jj. N: k at compile time, or 6 with k given
// at run time (Eigen::Dynamic). One division per column on the chain from one column to the
// next, where Cholesky has a square root and a division; the 3×3 adjugate and pivots from
// leading minors were far less accurate (paper/ENGINEERING.md, "Small SPD inverses").
template <class T, int K>
struct SpdFactor {
  static constexpr int N = K == Eigen::Dynamic ? 6 : K;
  int k = N;
  T L[N][N], r[N];  // (below the diagonal and r[0 … k−1] written before read: not zeroed)

  template <class In>
  explicit SpdFactor(const In& D, int size = N) : k(K == Eigen::Dynamic ? size : K) {
    T E[N][N];  // L Δ below the diagonal
    for (int j = 0; j < k; ++j) {
      T s = D(j, j);
      for (int p = 0; p < j; ++p) s -= L[j][p] * E[j][p];
      r[j] = T(1) / s;
      for (int i = j + 1; i < k; ++i) {
        T t = D(i, j);
        for (int p = 0; p < j; ++p) t -= E[i][p] * L[j][p];
        E[i][j] = t;
        L[i][j] = t * r[j];
      }
    }
  }

  // D⁻¹ = Mᵀ Δ⁻¹ M with M = L⁻¹, into the k×k Dinv (exactly symmetric).
  template <class Out>
  void inverse(Out&& Dinv) const {
    // M = L⁻¹ (unit lower triangular, below the diagonal)
    T M[N][N];
    for (int j = 0; j < k; ++j)
      for (int i = j + 1; i < k; ++i) {
        T t = -L[i][j];
        for (int p = j + 1; p < i; ++p) t -= L[i][p] * M[p][j];
        M[i][j] = t;
      }
    // R = Δ⁻¹ M below the diagonal, formed once
    T R[N][N];
    for (int j = 0; j < k; ++j)
      for (int p = j + 1; p < k; ++p) R[p][j] = r[p] * M[p][j];
    for (int i = 0; i < k; ++i)
      for (int j = 0; j <= i; ++j) {
        T t = (i == j ? r[i] : R[i][j]);
        for (int p = i + 1; p < k; ++p) t += M[p][i] * R[p][j];
        Dinv(i, j) = t;
        Dinv(j, i) = t;
      }
  }

  // Y = X D⁻¹ for k columns X[0 … k−1] (any type with + − and a scalar ·): X L⁻ᵀ, then Δ⁻¹,
  // then L⁻¹, by substitution. The same multiplications and additions as X times the explicit
  // D⁻¹, and Y D = X to rounding however ill-conditioned D is, which X · D⁻¹ is not.
  template <class C>
  void solveRight(const C* X, C* Y) const {
    C W[N];
    for (int j = 0; j < k; ++j) {
      W[j] = X[j];
      for (int p = 0; p < j; ++p) W[j] = W[j] - W[p] * L[j][p];
    }
    for (int j = k - 1; j >= 0; --j) {
      Y[j] = W[j] * r[j];
      for (int p = j + 1; p < k; ++p) Y[j] = Y[j] - Y[p] * L[p][j];
    }
  }
};

// D⁻¹ into Dinv and U D⁻¹ into UD, for a body's k columns U (any column type with + − and a
// scalar ·): 1 / D for one DOF; else D⁻¹ from D's L Δ Lᵀ factors and U D⁻¹ by substitution with
// them: through the explicit D⁻¹ a light body above a heavy one (D's condition 1e9) left
// Ia S = U (1 − D⁻¹D) far from zero, and M⁻¹ of an alternating heavy/light spherical chain
// wrong by 73 % (conformance cases serial_spherical_alternating_{fixed,floating}_n8).
template <class T, int K, class Dk, class Out, class C>
MINV_INLINE void jointInverse(const Dk& D, int k, Out&& Dinv, const C* U, C* UD) {
  if constexpr (K == 1) {
    Dinv(0, 0) = T(1) / D(0, 0);
    UD[0] = U[0] * Dinv(0, 0);
  } else {
    const SpdFactor<T, K> F(D, k);
    F.inverse(Dinv);
    F.solveRight(U, UD);
  }
}

// One body of k DOFs (K: k at compile time, or Eigen::Dynamic) at v, IA_i in columns:
//   U_i = IA_i S_i,  D_i = S_iᵀ U_i,  D_i⁻¹,  U_i D_i⁻¹,
// stored in art; and, for a body with a parent, its term Ia = IA_i − U_i D_i⁻¹ U_iᵀ. Each
// column of U in two halves (a short dependency chain).
template <class T, int K>
MINV_INLINE void articulatedStep(std::integral_constant<int, K>, const Kinematics<T>& kin,
                                 Articulated<T>& art, const Six<T>* IA, int i, int v, int kk,
                                 bool parent, Six<T>* Ia) {
  using C = Six<T>;
  constexpr int N = K == Eigen::Dynamic ? 6 : K;
  const int k = K == Eigen::Dynamic ? kk : K;
  C S[N] = {}, U[N] = {}, UD[N] = {};
  for (int j = 0; j < k; ++j) {
    const T* s = kin.S.col(v + j).data();
    S[j] = C::loadFar(s);
    U[j] =
        (IA[0] * s[0] + IA[2] * s[2] + IA[4] * s[4]) + (IA[1] * s[1] + IA[3] * s[3] + IA[5] * s[5]);
    U[j].store(art.U.col(v + j).data());
  }
  // D = Sᵀ U
  MatJ<T, K> D;
  if constexpr (K == Eigen::Dynamic) D.resize(k, k);
  for (int c = 0; c < k; ++c)
    for (int r = 0; r < k; ++r) D(r, c) = dot(S[r], U[c]);
  // D⁻¹ and U D⁻¹
  auto Dinv = art.Dinv[i].template topLeftCorner<K, K>(k, k);
  jointInverse<T, K>(D, k, Dinv, U, UD);
  if constexpr (K == 1) art.dinv(v) = Dinv(0, 0);
  for (int j = 0; j < k; ++j) UD[j].store(art.UDinv.col(v + j).data());
  if (!parent) return;
  // Ia = IA − (U D⁻¹) Uᵀ
  for (int c = 0; c < 6; ++c) {
    C t = UD[0] * U[0][c];
    for (int j = 1; j < k; ++j) t = t + UD[j] * U[j][c];
    Ia[c] = IA[c] - t;
  }
}

// Up a run of one-DOF links from the one-DOF body i (its parent i − 1 one-DOF), whose IA (in
// columns), U, D⁻¹ and U D⁻¹ are done: for each parent j = i − 1, i − 2, … while the run goes
// on, with B = I_j (+ a branch point's gathered terms) + IA_{j+1},
//   q = S_jᵀ U_{j+1},  D_j = S_jᵀ (B S_j) − q (q D_{j+1}⁻¹),  U_j = B S_j − U_{j+1} D_{j+1}⁻¹ q,
//   IA_j = B − U_{j+1} D_{j+1}⁻¹ U_{j+1}ᵀ,  c_{j+1} = −q D_{j+1}⁻¹,
// the same quantities as U_j = IA_j S_j and D_j = S_jᵀ IA_j S_j regrouped so that D_j does not
// wait for IA_j: from one body's D⁻¹ to the next a multiply-add and a division wait, where IA_j
// S_j, a dot product and the division lay between them. Reads body i's IA, U, D⁻¹ and U D⁻¹
// from art; adds Ia of the run's top body j into its parent's IA (I_λ + Ia where the parent is
// not a branch point); returns j.
template <class T>
MINV_NOINLINE int articulatedLinks(const Model& model, const Kinematics<T>& kin,
                                   Articulated<T>& art, int i) {
  using C = Six<T>;
  C IA[6];
  // (just written, yet loaded masked: loaded entry by entry, GCC kept the run's IA on the stack)
  for (int c = 0; c < 6; ++c) IA[c] = C::loadFar(art.IA[i].data() + 6 * c);
  int v = model.vIdx(i);
  C U = C::loadFar(art.U.col(v).data()), UD = C::loadFar(art.UDinv.col(v).data());
  T dinv = art.dinv(v);
  for (;;) {
    const int j = i - 1, vj = v - 1;
    // B = I_j (with a branch point's gathered terms) + IA_{j+1}
    T* IAj = art.IA[j].data();
    // (masked loads and stores along the run, paper/ENGINEERING.md "Masked loads and stores":
    // a branch point's gathered terms were written a few bodies before, if at all)
    const T* base = art.gathers[j] ? IAj : kin.I[j].data();
    C B[6];
    for (int c = 0; c < 6; ++c) B[c] = C::loadFar(base + 6 * c) + IA[c];
    // B S_j, q = S_jᵀ U_{j+1}, D_j = S_jᵀ B S_j − q (q D_{j+1}⁻¹) (q² alone underflows for
    // masses below 1e-154; q D⁻¹ is of order one)
    const T* s = kin.S.col(vj).data();
    const C S = C::loadFar(s);
    const C BS =
        (B[0] * s[0] + B[2] * s[2] + B[4] * s[4]) + (B[1] * s[1] + B[3] * s[3] + B[5] * s[5]);
    const T q = dot(S, U), qd = q * dinv;
    const T dj = T(1) / (dot(S, BS) - q * qd);
    // The coupling c_{j+1} = −S_jᵀ U_{j+1} D_{j+1}⁻¹ (q D⁻¹ formed once, as the compiler forms it
    // on doubles, so that the counting scalar counts what runs)
    art.couple(v) = -qd;
    // IA_j = B − U_{j+1} D_{j+1}⁻¹ U_{j+1}ᵀ
    for (int c = 0; c < 6; ++c) {
      IA[c] = B[c] - UD * U[c];
      IA[c].storeFar(IAj + 6 * c);
    }
    // U_j = B S_j − U_{j+1} D_{j+1}⁻¹ q and U_j D_j⁻¹
    U = BS - UD * q;
    UD = U * dj;
    dinv = dj;
    U.storeFar(art.U.col(vj).data());
    UD.storeFar(art.UDinv.col(vj).data());
    art.Dinv[j](0, 0) = dinv;
    art.dinv(vj) = dinv;
    i = j, v = vj;
    const int p = model.parent(i);
    if (p >= 0 && p == i - 1 && model.nvOf(p) == 1) continue;
    if (p < 0) return i;
    // Ia = IA − (U D⁻¹) Uᵀ into the parent's IA: I_p + Ia if the parent is the next body (it
    // then starts from its IA, not I_p), else added to its gathered terms.
    const T* from = p == i - 1 && !art.gathers[p] ? kin.I[p].data() : art.IA[p].data();
    for (int c = 0; c < 6; ++c) {
      T* IAp = art.IA[p].data() + 6 * c;
      (C::load(from + 6 * c) + (IA[c] - UD * U[c])).store(IAp);
    }
    return i;
  }
}

// Whether bodies i, i − 1, …, i − kRun + 1 are one-DOF links, each the child of the next, and
// that one one-DOF. Shorter runs (a centipede's legs) keep the plain step, which was faster
// there; along a chain the runs made configure 12-19 % faster (paper/ENGINEERING.md, "Runs of
// links in the articulated pass").
inline constexpr int kRun = 4;
inline bool linkRun(const Model& model, int i) {
  for (int j = i; j > i - kRun; --j)
    if (model.nvOf(j) != 1 || model.parent(j) != j - 1 || model.nvOf(j - 1) != 1) return false;
  return true;
}

// Stage "articulated inertias": IA, U, D⁻¹, U D⁻¹ for every body, leaves first (RBDA Table 7.1,
// pass 2: IA_λ(i) = I_λ(i) + Σ Ia_i over its children, Ia_i = IA_i − U_i D_i⁻¹ U_iᵀ). Along a
// chain (the parent is the next body done) Ia_i goes on in registers (`carry`), not through
// memory; a branch point's other children add theirs into its IA, which starts as I_λ. A run of
// at least kRun one-DOF links goes up in articulatedLinks, regrouped (8 multiplications and 7
// additions more per link). The same operations on every scalar (Tables 1–3 count them).
template <class T>
void articulatedInertias(const Model& model, const Kinematics<T>& kin, Articulated<T>& art) {
  // Branch points gather their other children's Ia in memory, from I_i.
  for (const int i : art.gathering) art.IA[i] = kin.I[i];
  using C = Six<T>;
  C carry[6];            // Ia of the body just done (columns), when this body is its parent
  bool carried = false;  // whether carry holds one
  bool started = false;  // whether this body's IA already holds I_i + the chain child's Ia
  for (int i = model.nb() - 1; i >= 0; --i) {
    const int v = model.vIdx(i), k = model.nvOf(i), p = model.parent(i);
    // IA_i = I_i (with a branch point's gathered terms) + the chain child's Ia
    T* IAi = art.IA[i].data();
    const T* base = art.gathers[i] || started ? IAi : kin.I[i].data();
    started = false;
    C IA[6], Ia[6] = {};
    for (int c = 0; c < 6; ++c) {
      IA[c] = C::load(base + 6 * c);
      if (carried) IA[c] = IA[c] + carry[c];
      IA[c].store(IAi + 6 * c);
    }
    // The bottom of a run of at least kRun links (kRun + 1 one-DOF bodies): its U, D⁻¹ and
    // U D⁻¹, then the run (articulatedLinks), which ends with the top body's Ia handed on.
    if (i >= kRun && linkRun(model, i)) {
      articulatedStep(std::integral_constant<int, 1>{}, kin, art, IA, i, v, k, false, Ia);
      i = articulatedLinks<T>(model, kin, art, i);
      carried = false;
      started = model.parent(i) >= 0 && model.parent(i) == i - 1;
      continue;
    }
    // U, D⁻¹, U D⁻¹ and Ia, on fixed-size blocks for k = 1, 3, 6
    forJointSize(k, [&](auto K) { articulatedStep(K, kin, art, IA, i, v, k, p >= 0, Ia); });
    // The coupling with a one-DOF parent that is the previous body. (This test, linkRun's and
    // articulatedLinks' are written out: one shared helper for the three was slower.)
    if (k == 1 && p >= 0 && p == i - 1 && model.nvOf(p) == 1) {
      const auto S = kin.S.col(v - 1);
      const auto UD = art.UDinv.col(v);
      art.couple(v) = -((S(0) * UD(0) + S(1) * UD(1) + S(2) * UD(2)) +
                        (S(3) * UD(3) + S(4) * UD(4) + S(5) * UD(5)));
    }
    // Ia to the parent: in registers if it is the next body, else into its IA.
    carried = p >= 0 && p == i - 1;
    if (carried)
      for (int c = 0; c < 6; ++c) carry[c] = Ia[c];
    else if (p >= 0)
      for (int c = 0; c < 6; ++c) {
        T* IAp = art.IA[p].data() + 6 * c;
        (C::load(IAp) + Ia[c]).store(IAp);
      }
  }
}

}  // namespace minv
