// `blocked-cholesky`: CRBA (minv's front end), then a blocked right-looking Cholesky
// factorization M = L Lᵀ written here, in blocks of B columns:
//   for each diagonal block k:   L_kk = chol(A_kk)                    (unblocked, in place)
//                                L_ik = A_ik L_kk⁻ᵀ  for blocks i > k  (triangular solve)
//                                A_ij −= L_ik L_jkᵀ  for k < j ≤ i     (trailing update)
// then M⁻¹ and M⁻¹R by forward and back substitution. Cost n³/3 + O(n²B) for the factor,
// like LAPACK's dpotrf, but with no library: an example of a solver kept outside minv.
#pragma once

#include "solvers/crba_solver.hpp"

namespace own {

class BlockedCholeskySolver final : public minv::CrbaSolver {
 public:
  explicit BlockedCholeskySolver(int block = 32) : block_(block) {}
  void inverse(minv::MatrixOut Minv) override;
  void solve(minv::MatrixIn R, minv::MatrixOut X) override;

 private:
  void allocate(const minv::Model& model) override {}
  void factor() override;
  int block_;
};

// Adds "blocked-cholesky" to minv's registry (once; later calls do nothing).
void registerBlockedCholesky();

}  // namespace own
