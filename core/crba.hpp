// Composite-Rigid-Body Algorithm in the world frame (RBDA §6.2, Table 6.2; Walker & Orin
// method 3), the paper's Table 2 set-up.
//
// Contract: kin holds world-frame S and I (core/kinematics.hpp). Writes the full symmetric
// nv×nv joint-space inertia matrix M (entries off the branch-induced pattern are zero).
// Stages: composite inertias Ic_i = I_i + Σ_children Ic_j; the vectors F = Ic_i S_i; M's
// elements M_ji = S_jᵀ F for every ancestor j of i. Cost Θ(nb) + Θ(Σ depth) for 1-DOF joints.
#pragma once

#include <vector>

#include "core/counting.hpp"
#include "core/kinematics.hpp"

namespace minv {

// Stage "composite inertias": Ic_i = I_i + Σ_{children j} Ic_j, leaves first.
template <class T>
void compositeInertias(const Model& model, const Kinematics<T>& kin, std::vector<Mat6<T>>& Ic) {
  for (int i = 0; i < model.nb(); ++i) Ic[i] = kin.I[i];
  for (int i = model.nb() - 1; i >= 0; --i)
    if (model.parent(i) >= 0) Ic[model.parent(i)] += Ic[i];
}

// Stages "Ic·s vectors" and "elements of M": M_ii = S_iᵀ F, M_ji = S_jᵀ F up the ancestors.
template <class T, class Mark = NoMark>
void crbaMassMatrix(const Model& model, const Kinematics<T>& kin, const std::vector<Mat6<T>>& Ic,
                    MatX<T>& M, Mark&& mark = {}) {
  M.setZero();
  for (int i = 0; i < model.nb(); ++i) {
    const int vi = model.vIdx(i), ki = model.nvOf(i);
    if (ki == 1) {
      // One DOF: F is a 6-vector and every element a 6-term dot product.
      const Vec6<T> F = Ic[i] * kin.S.col(vi);
      mark("Ic s vectors");
      M(vi, vi) = kin.S.col(vi).dot(F);
      for (int j = model.parent(i); j >= 0; j = model.parent(j)) {
        const int vj = model.vIdx(j), kj = model.nvOf(j);
        for (int c = 0; c < kj; ++c) M(vi, vj + c) = M(vj + c, vi) = kin.S.col(vj + c).dot(F);
      }
      mark("elements of M");
      continue;
    }
    const Mat6X<T> F = Ic[i].lazyProduct(kin.S.middleCols(vi, ki));
    mark("Ic s vectors");
    M.block(vi, vi, ki, ki).noalias() = kin.S.middleCols(vi, ki).transpose().lazyProduct(F);
    // Sᵀ(Ic S) is symmetric in exact arithmetic only: keep its upper triangle on both sides.
    for (int a = 0; a < ki; ++a)
      for (int b = a + 1; b < ki; ++b) M(vi + b, vi + a) = M(vi + a, vi + b);
    for (int j = model.parent(i); j >= 0; j = model.parent(j)) {
      const int vj = model.vIdx(j), kj = model.nvOf(j);
      M.block(vj, vi, kj, ki).noalias() = kin.S.middleCols(vj, kj).transpose().lazyProduct(F);
      M.block(vi, vj, ki, kj) = M.block(vj, vi, kj, ki).transpose();
    }
    mark("elements of M");
  }
}

// Both stages; Ic is scratch of size nb.
template <class T>
void crba(const Model& model, const Kinematics<T>& kin, std::vector<Mat6<T>>& Ic, MatX<T>& M) {
  compositeInertias(model, kin, Ic);
  crbaMassMatrix(model, kin, Ic, M);
}

// M at q in one call, in T's precision (long double for references). It allocates: for tests,
// tools and references, not for timed loops.
template <class T = double>
MatX<T> massMatrix(const Model& model, const Eigen::VectorXd& q) {
  Kinematics<T> kin(model, Origin::EachRoot);
  computeKinematics<T>(model, q.cast<T>(), kin);
  std::vector<Mat6<T>> Ic(model.nb());
  MatX<T> M(model.nv(), model.nv());
  crba<T>(model, kin, Ic, M);
  return M;
}

}  // namespace minv
