// `ltl`: CRBA, then Featherstone's branch-induced-sparsity factorization M = Lᵀ L
// (Featherstone, IJRR 24(6), 2005, Table 1), in place on M, and its sparse solves.
//
// λ is the DOF parent array (Model::dofParent()), λ(k) < k, root −1; loops walk ancestor chains
// only, so fill-in stays inside M's branch-induced pattern. After the factorization the lower
// triangle of H holds L, diagonal included.
// Cost, with d_k the depth of DOF k counting itself: Σ_k d_k(d_k−1)/2 multiplications,
// Σ_k (d_k−1) divisions and n square roots to factor; per solve Σ_k 2(d_k−1) multiplications
// and 2n divisions.
#pragma once

#include <cmath>
#include <vector>

#include "solvers/crba_solver.hpp"

namespace minv {

// The method for TreeCholeskySolver (solvers/crba_solver.hpp): its three kernels and the check
// of its factor.
struct Ltl {
  static constexpr const char* kName = "LTL";
  static bool factorOk(const Eigen::MatrixXd& M) { return M.diagonal().allFinite(); }

  // H = M (lower triangle) becomes L in place.
  template <class T>
  static void factor(const std::vector<int>& lambda, MatX<T>& H) {
    using std::sqrt;
    const int n = static_cast<int>(H.rows());
    for (int k = n - 1; k >= 0; --k) {
      // L_kk = √H_kk; L_ki = H_ki / L_kk for the ancestors i of k.
      H(k, k) = sqrt(H(k, k));
      for (int i = lambda[k]; i != -1; i = lambda[i]) H(k, i) /= H(k, k);
      // H_ij −= L_ki L_kj for every pair of ancestors j ≤ i of k.
      for (int i = lambda[k]; i != -1; i = lambda[i])
        for (int j = i; j != -1; j = lambda[j]) H(i, j) -= H(k, i) * H(k, j);
    }
  }

  // x = M⁻¹ x = L⁻¹ L⁻ᵀ x for one column.
  template <class T, class Col>
  static void solve(const std::vector<int>& lambda, const MatX<T>& H, Col&& x) {
    const int n = static_cast<int>(H.rows());
    // x = L⁻ᵀ x: leaves first.
    for (int i = n - 1; i >= 0; --i) {
      x(i) /= H(i, i);
      for (int j = lambda[i]; j != -1; j = lambda[j]) x(j) -= H(i, j) * x(i);
    }
    // x = L⁻¹ x: root first.
    for (int i = 0; i < n; ++i) {
      for (int j = lambda[i]; j != -1; j = lambda[j]) x(i) -= H(i, j) * x(j);
      x(i) /= H(i, i);
    }
  }

  // M⁻¹ column by column: L⁻ᵀ e_k lives on k's ancestors only; L⁻¹ then fills the column.
  template <class T, class Out>
  static void inverse(const std::vector<int>& lambda, const MatX<T>& H, Out&& Minv) {
    const int n = static_cast<int>(H.rows());
    Minv.setZero();
    for (int k = 0; k < n; ++k) {
      auto x = Minv.col(k);
      x(k) = T(1);
      // x = L⁻ᵀ e_k along the path k, λ(k), …
      for (int i = k; i != -1; i = lambda[i]) {
        x(i) /= H(i, i);
        for (int j = lambda[i]; j != -1; j = lambda[j]) x(j) -= H(i, j) * x(i);
      }
      // x = L⁻¹ x over every DOF.
      for (int i = 0; i < n; ++i) {
        for (int j = lambda[i]; j != -1; j = lambda[j]) x(i) -= H(i, j) * x(j);
        x(i) /= H(i, i);
      }
    }
    Minv.template triangularView<Eigen::StrictlyUpper>() = Minv.transpose();
  }
};

using LtlSolver = TreeCholeskySolver<Ltl>;

}  // namespace minv
