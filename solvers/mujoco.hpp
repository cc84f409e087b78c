// `mujoco`: MuJoCo 2.2.2 as a peer. prepare() writes the tree as MJCF (generators/mjcf.hpp:
// same kinematics and inertias; hinge, slide, ball, free joints) and compiles it with
// MuJoCo's own parser, in memory; configure(q) sets qpos and runs the part of MuJoCo's
// position stage that M needs: mj_kinematics, mj_comPos, mj_crb (M in MuJoCo's sparse
// format) and mj_factorM (its branch-induced-sparsity LᵀDL); inverse() and solve(R) are
// mj_solveM on the columns of I or R (in place in the output, no allocation).
//
// Coordinates. MuJoCo numbers bodies depth-first (XML order) where ours are any parent-first
// order, so our DOF k is MuJoCo's DOF π(k) (found by joint name). A free joint's velocity in
// MuJoCo is [v; ω]: v the body origin's velocity in world coordinates, ω in body coordinates;
// ours is [ω; v] both in body coordinates, so MuJoCo's qvel = T ν with, on the base block,
// v_mj = R v, ω_mj = ω (R the base orientation), and a permutation elsewhere. Then
//   M = Tᵀ M_mj T,   M⁻¹ = T⁻¹ M_mj⁻¹ T⁻ᵀ,   M⁻¹R = T⁻¹ M_mj⁻¹ (T⁻ᵀ R),
// T⁻ᵀ taking our generalized forces [n; f] to MuJoCo's [R f; n]. A floating root's placement
// is folded into qpos (MuJoCo's free body pose is qpos itself). MuJoCo's ball qpos is (w, x,
// y, z) with angular velocity in the child frame, as ours.
//
// Limits (supports()): MuJoCo refuses a moving body with mass or a principal moment of inertia
// below mjMINVAL = 1e-15; and its mjData buffer size is an int, which its nv²-sized arrays for
// a chain (≈ 35·nv² bytes, measured) overflow near nv ≈ 7800: we refuse beyond an estimated
// 1.5 GB. The XML nesting limit of tinyxml2 (96 nested bodies per file) does not apply:
// toMjcf splits deep trees with <include>.
// Cost of prepare(): MuJoCo's compiler (mj_setConst) solves with M for every body, Θ(n³) for a
// chain: measured 0.3 s at n = 300, 11 s at 1000, 79 s at 2000, 672 s at 4000 (revolute
// chains). configure(), inverse() and solve() are what the experiments time.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "solvers/solver.hpp"

namespace minv {

class MujocoSolver final : public Solver {
 public:
  MujocoSolver();
  ~MujocoSolver() override;

  bool supports(const Model& model, std::string* why) const override;
  void prepare(const Model& model) override;
  void configure(const Eigen::VectorXd& q) override;
  void inverse(MatrixOut Minv) override;
  void solve(MatrixIn R, MatrixOut X) override;

  // MuJoCo's M at the last configuration (mj_fullM), in our coordinates: Tᵀ M_mj T.
  // For tests; allocates.
  Eigen::MatrixXd massMatrix() const;
  // MuJoCo's DOF index of each of our DOFs (π above; a free joint's ω and v map to its
  // angular and linear DOFs).
  const std::vector<int>& dofMap() const { return perm_; }

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  std::vector<int> perm_;
};

}  // namespace minv
