// Articulated-body inertias in the world frame (RBDA §7.2-7.3, Table 7.1, pass 2).
//
// Contract: kin holds world-frame S and I. For each body i, leaves first:
//   U_i = IA_i S_i,  D_i = S_iᵀ U_i (k×k),  IA_λ(i) += IA_i − U_i D_i⁻¹ U_iᵀ
// Stored per configuration for the impulse sweeps of solvers/abi: U, D⁻¹ and U·D⁻¹ (the
// paper's §5.2 saving: computed once, not per column). Cost Θ(nb); no allocation.
#pragma once

#include <cmath>
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

  explicit Articulated(const Model& m)
      : IA(m.nb()),
        U(Mat6N<T>::Zero(6, m.nv())),
        UDinv(Mat6N<T>::Zero(6, m.nv())),
        Dinv(m.nb()),
        dinv(VecX<T>::Zero(m.nv())) {
    for (int i = 0; i < m.nb(); ++i) Dinv[i] = MatK<T>::Zero(m.nvOf(i), m.nvOf(i));
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

// Inverse of a small symmetric positive-definite k×k matrix (k ≤ 6) by Cholesky, D = L Lᵀ
// (3×3 by its square-root-free form L Δ Lᵀ); Dinv is k×k on entry. K: k at compile time (or
// Eigen::Dynamic). (The 3×3 adjugate, without square roots, was tried: its error grows as κ² where
// Cholesky's grows as κ, 4e-8 against 5e-12 on a light spherical body above a heavy sliding child.)
template <class T, int K = Eigen::Dynamic, class In, class Out>
void spdInverse(const In& D, Out&& Dinv) {
  using std::sqrt;
  const int k = K == Eigen::Dynamic ? static_cast<int>(D.rows()) : K;
  if (k == 1) {
    Dinv(0, 0) = T(1) / D(0, 0);
    return;
  }
  if constexpr (K == 3) {
    // 3×3 (spherical joints): D = L Δ Lᵀ with L unit lower triangular, no square roots (the
    // same elimination as Cholesky, as stable on SPD matrices); D⁻¹ = Mᵀ Δ⁻¹ M, M = L⁻¹.
    const T r0 = T(1) / D(0, 0);
    const T l10 = D(1, 0) * r0, l20 = D(2, 0) * r0;
    const T r1 = T(1) / (D(1, 1) - l10 * D(1, 0));
    const T e21 = D(2, 1) - l20 * D(1, 0);
    const T l21 = e21 * r1;
    const T r2 = T(1) / (D(2, 2) - l20 * D(2, 0) - l21 * e21);
    const T m10 = -l10, m21 = -l21, m20 = l10 * l21 - l20;
    const T m20r2 = m20 * r2, m21r2 = m21 * r2;
    Dinv(0, 0) = r0 + m10 * m10 * r1 + m20 * m20r2;
    Dinv(1, 0) = Dinv(0, 1) = m10 * r1 + m21 * m20r2;
    Dinv(2, 0) = Dinv(0, 2) = m20r2;
    Dinv(1, 1) = r1 + m21 * m21r2;
    Dinv(2, 1) = Dinv(1, 2) = m21r2;
    Dinv(2, 2) = r2;
    return;
  }
  // Factor D = L Lᵀ; keep 1/L_jj.
  MatJ<T, K> L = MatJ<T, K>::Zero(k, k);
  Eigen::Matrix<T, K, 1, 0, K == Eigen::Dynamic ? 6 : K, 1> rdiag(k);
  for (int j = 0; j < k; ++j) {
    T s = D(j, j);
    for (int p = 0; p < j; ++p) s -= L(j, p) * L(j, p);
    L(j, j) = sqrt(s);
    rdiag(j) = T(1) / L(j, j);
    for (int i = j + 1; i < k; ++i) {
      T t = D(i, j);
      for (int p = 0; p < j; ++p) t -= L(i, p) * L(j, p);
      L(i, j) = t * rdiag(j);
    }
  }
  // Linv = L⁻¹ by forward substitution, then D⁻¹ = L⁻ᵀ L⁻¹.
  MatJ<T, K> Linv = MatJ<T, K>::Zero(k, k);
  for (int j = 0; j < k; ++j) {
    Linv(j, j) = rdiag(j);
    for (int i = j + 1; i < k; ++i) {
      T t = T(0);
      for (int p = j; p < i; ++p) t -= L(i, p) * Linv(p, j);
      Linv(i, j) = t * rdiag(i);
    }
  }
  for (int i = 0; i < k; ++i)
    for (int j = 0; j <= i; ++j) {
      T t = T(0);
      for (int p = i; p < k; ++p) t += Linv(p, i) * Linv(p, j);
      Dinv(i, j) = t;
      Dinv(j, i) = t;
    }
}

// One body of K DOFs at v (K > 1): U_i = IA_i S_i, D_i = S_iᵀ U_i, D_i⁻¹, U_i D_i⁻¹, and
// IA_λ(i) += IA_i − U_i D_i⁻¹ U_iᵀ.
template <class T, int K>
void articulatedStep(std::integral_constant<int, K>, const Kinematics<T>& kin, Articulated<T>& art,
                     int i, int p, int v, int k) {
  const auto S = kin.S.template middleCols<K>(v, k);
  auto U = art.U.template middleCols<K>(v, k);
  auto UD = art.UDinv.template middleCols<K>(v, k);
  auto Dinv = art.Dinv[i].template topLeftCorner<K, K>(k, k);
  U.noalias() = art.IA[i].lazyProduct(S);
  const MatJ<T, K> D = S.transpose().lazyProduct(U);
  spdInverse<T, K>(D, Dinv);
  UD.noalias() = U.lazyProduct(Dinv);
  if (p >= 0) {
    art.IA[p] += art.IA[i];
    art.IA[p].noalias() -= UD.lazyProduct(U.transpose());
  }
}

// Stage "articulated inertias": IA, U, D⁻¹, U D⁻¹ for every body, leaves first.
template <class T>
void articulatedInertias(const Model& model, const Kinematics<T>& kin, Articulated<T>& art) {
  for (int i = 0; i < model.nb(); ++i) art.IA[i] = kin.I[i];
  for (int i = model.nb() - 1; i >= 0; --i) {
    const int v = model.vIdx(i), k = model.nvOf(i), p = model.parent(i);
    if (k == 1) {
      // One DOF: the same steps on fixed-size vectors, d a scalar.
      const Vec6<T> U = art.IA[i] * kin.S.col(v);
      const T dinv = T(1) / kin.S.col(v).dot(U);
      art.U.col(v) = U;
      art.Dinv[i](0, 0) = art.dinv(v) = dinv;
      art.UDinv.col(v) = U * dinv;
      if (p >= 0) {
        art.IA[p] += art.IA[i];
        art.IA[p].noalias() -= art.UDinv.col(v) * U.transpose();
      }
      continue;
    }
    // More DOFs: the same steps on fixed-size blocks (k = 3, 6) where possible.
    forJointSize(k, [&](auto K) { articulatedStep(K, kin, art, i, p, v, k); });
  }
}

}  // namespace minv
