// `ltdl`: CRBA, then Featherstone's branch-induced-sparsity factorization M = Lᵀ D L
// (Featherstone, "Efficient factorization of the joint-space inertia matrix for branched
// kinematic trees", IJRR 24(6), 2005, Table 2), in place on M, and its sparse solves.
//
// λ is the DOF parent array (Model::dofParent(), expandLambda for multi-DOF joints), λ(k) < k,
// root −1. M_ij ≠ 0 only where i is an ancestor of j or j of i, so every loop walks ancestor
// chains and fill-in never leaves that pattern. After the factorization the lower triangle of
// H holds L (unit diagonal implied) below the diagonal and D on it.
// Cost, with d_k the depth of DOF k counting itself: Σ_k d_k(d_k−1)/2 multiplications and
// Σ_k (d_k−1) divisions to factor; Σ_k 2(d_k−1) multiplications and n divisions per solve.
#pragma once

#include <vector>

#include "solvers/crba_solver.hpp"

namespace minv {

// The method for TreeCholeskySolver (solvers/crba_solver.hpp): its three kernels and the check
// of its factor.
struct Ltdl {
  static constexpr const char* kName = "LTDL";
  static bool factorOk(const Eigen::MatrixXd& M) { return (M.diagonal().array() > 0).all(); }

  // H = M (lower triangle) becomes L and D in place.
  template <class T>
  static void factor(const std::vector<int>& lambda, MatX<T>& H) {
    const int n = static_cast<int>(H.rows());
    for (int k = n - 1; k >= 0; --k) {
      for (int i = lambda[k]; i != -1; i = lambda[i]) {
        // a = H_ki / H_kk; H_ij −= a H_kj for every ancestor j of i (and i itself).
        const T a = H(k, i) / H(k, k);
        for (int j = i; j != -1; j = lambda[j]) H(i, j) -= a * H(k, j);
        H(k, i) = a;
      }
    }
  }

  // x = M⁻¹ x = L⁻¹ D⁻¹ L⁻ᵀ x for one column.
  template <class T, class Col>
  static void solve(const std::vector<int>& lambda, const MatX<T>& H, Col&& x) {
    const int n = static_cast<int>(H.rows());
    // x = L⁻ᵀ x: leaves first, each DOF pushes its value to its ancestors.
    for (int i = n - 1; i >= 0; --i)
      for (int j = lambda[i]; j != -1; j = lambda[j]) x(j) -= H(i, j) * x(i);
    // x = D⁻¹ x.
    for (int i = 0; i < n; ++i) x(i) /= H(i, i);
    // x = L⁻¹ x: root first, each DOF pulls from its ancestors.
    for (int i = 0; i < n; ++i)
      for (int j = lambda[i]; j != -1; j = lambda[j]) x(i) -= H(i, j) * x(j);
  }

  // M⁻¹ column by column: L⁻ᵀ e_k is non-zero only on k's ancestors, so the first two steps
  // walk that path alone; L⁻¹ then fills the column. Lower half mirrored.
  template <class T, class Out>
  static void inverse(const std::vector<int>& lambda, const MatX<T>& H, Out&& Minv) {
    const int n = static_cast<int>(H.rows());
    Minv.setZero();
    for (int k = 0; k < n; ++k) {
      auto x = Minv.col(k);
      x(k) = T(1);
      // x = D⁻¹ L⁻ᵀ e_k along the path k, λ(k), …
      for (int i = k; i != -1; i = lambda[i]) {
        for (int j = lambda[i]; j != -1; j = lambda[j]) x(j) -= H(i, j) * x(i);
        x(i) /= H(i, i);
      }
      // x = L⁻¹ x over every DOF.
      for (int i = 0; i < n; ++i)
        for (int j = lambda[i]; j != -1; j = lambda[j]) x(i) -= H(i, j) * x(j);
    }
    Minv.template triangularView<Eigen::StrictlyUpper>() = Minv.transpose();
  }
};

using LtdlSolver = TreeCholeskySolver<Ltdl>;

}  // namespace minv
