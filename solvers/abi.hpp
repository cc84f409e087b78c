// `abi`: M⁻¹ and M⁻¹R from articulated-body inertias, never forming M.
//
// Drumwright, "Fast dynamic simulation of highly articulated robots with contact via Θ(n²)
// time dense generalized inertia matrix inversion" (SIMPAR 2012), Algorithms 1 (fixed base)
// and 2 (floating base), in RBDA (2008) notation, world frame, with §5.2's savings.
// A unit impulse r = e_k applied in generalized coordinates gives column k of M⁻¹:
//   backward, i = nb−1 … 0:  u_i = r_i − S_iᵀ Y_i,  Y_λ(i) += Y_i + U_i D_i⁻¹ u_i
//   forward,  i = 0 … nb−1:  Δq̇_i = D_i⁻¹ u_i − (U_i D_i⁻¹)ᵀ Δv_λ(i),  Δv_i = Δv_λ(i) + S_i Δq̇_i
// with Δv_λ = 0 at a root. Corrections to the printed pseudo-code (see the reading notes):
// Alg. 1 line 5 needs the `Y_i +` term and line 8 the minus sign. A floating base is body 0
// with a 6-DOF joint whose S is the base's Plücker transform; D₀ = S₀ᵀ IA₀ S₀, so Alg. 2's
// Δv₀ = (IA₀)⁻¹(r₀ − Y₀) is the k = 6 case of the same forward step.
// §5.2: U, D⁻¹ and U D⁻¹ are computed once per configuration (core/articulated.hpp); for a
// unit column only the ancestors of its body carry a non-zero Y, so the backward sweep walks
// that path alone. Multi-DOF joints make D a k×k block.
// Cost: Θ(nv·depth + nv·nb) for M⁻¹ (Θ(n²)); Θ(m·nb) for M⁻¹R. Scratch Θ(nb); no allocation.
#pragma once

#include "core/articulated.hpp"
#include "core/counting.hpp"
#include "core/kinematics.hpp"
#include "solvers/solver.hpp"

namespace minv {

// Per-tree scratch of the impulse sweeps.
template <class T>
struct AbiWorkspace {
  Mat6N<T> Y;   // articulated impulses, per body
  Mat6N<T> dv;  // velocity changes Δv, per body
  VecX<T> u;    // u_i = r_i − S_iᵀ Y_i, per DOF

  explicit AbiWorkspace(const Model& m)
      : Y(Mat6N<T>::Zero(6, m.nb())), dv(Mat6N<T>::Zero(6, m.nb())), u(VecX<T>::Zero(m.nv())) {}
};

// Forward sweep for one column: Δq̇ of every DOF from u (zero off the impulse's path).
template <class T, class Col>
void abiForwardSweep(const Model& model, const Kinematics<T>& kin, const Articulated<T>& art,
                     AbiWorkspace<T>& ws, Col&& out) {
  for (int i = 0; i < model.nb(); ++i) {
    const int p = model.parent(i), v = model.vIdx(i), k = model.nvOf(i);
    if (k == 1) {
      // Δq̇_i = u_i/d_i − (U_i/d_i)ᵀ Δv_λ(i)
      T qd = art.Dinv[i](0, 0) * ws.u(v);
      if (p >= 0) qd -= art.UDinv.col(v).dot(ws.dv.col(p));
      out(v) = qd;
      // Δv_i = Δv_λ(i) + S_i Δq̇_i
      if (p >= 0)
        ws.dv.col(i) = ws.dv.col(p) + kin.S.col(v) * qd;
      else
        ws.dv.col(i) = kin.S.col(v) * qd;
    } else {
      VecK<T> qd = art.Dinv[i].lazyProduct(ws.u.segment(v, k));
      if (p >= 0) qd.noalias() -= art.UDinv.middleCols(v, k).transpose().lazyProduct(ws.dv.col(p));
      out.segment(v, k) = qd;
      if (p >= 0)
        ws.dv.col(i) = ws.dv.col(p);
      else
        ws.dv.col(i).setZero();
      ws.dv.col(i).noalias() += kin.S.middleCols(v, k).lazyProduct(qd);
    }
  }
}

// Stages "impulse propagation" and "velocity updates" for all columns: Minv = M⁻¹.
template <class T, class Mark = NoMark>
void abiInverse(const Model& model, const Kinematics<T>& kin, const Articulated<T>& art,
                AbiWorkspace<T>& ws, MatX<T>& Minv, Mark&& mark = {}) {
  for (int c = 0; c < model.nv(); ++c) {
    // Backward: the unit impulse e_c enters at its body b; only b's ancestors carry Y (§5.2).
    const int b = model.dofBody(c);
    Vec6<T> Y = Vec6<T>::Zero();
    for (int i = b; i >= 0; i = model.parent(i)) {
      const int v = model.vIdx(i), k = model.nvOf(i);
      // u_i = r_i − S_iᵀ Y_i
      if (i == b) {
        ws.u.segment(v, k).setZero();
        ws.u(c) = T(1);
      } else {
        ws.u.segment(v, k).noalias() = -(kin.S.middleCols(v, k).transpose().lazyProduct(Y));
      }
      // Y_λ(i) = Y_i + U_i D_i⁻¹ u_i
      Y.noalias() += art.UDinv.middleCols(v, k).lazyProduct(ws.u.segment(v, k));
    }
    mark("impulse propagation");
    // Forward: every body's velocity change.
    abiForwardSweep(model, kin, art, ws, Minv.col(c));
    mark("velocity updates");
    // Clear u on the path for the next column.
    for (int i = b; i >= 0; i = model.parent(i)) ws.u.segment(model.vIdx(i), model.nvOf(i)).setZero();
  }
  // M⁻¹ is symmetric: keep the lower triangle, mirror it.
  Minv.template triangularView<Eigen::StrictlyUpper>() = Minv.transpose();
}

// M⁻¹R column by column, Θ(nb) each: the full backward sweep, then the forward sweep.
template <class T, class Mark = NoMark>
void abiSolve(const Model& model, const Kinematics<T>& kin, const Articulated<T>& art,
              AbiWorkspace<T>& ws, const MatX<T>& R, MatX<T>& X, Mark&& mark = {}) {
  for (int c = 0; c < R.cols(); ++c) {
    ws.Y.setZero();
    // Backward: u_i = r_i − S_iᵀ Y_i; Y_λ(i) += Y_i + U_i D_i⁻¹ u_i.
    for (int i = model.nb() - 1; i >= 0; --i) {
      const int v = model.vIdx(i), k = model.nvOf(i), p = model.parent(i);
      ws.u.segment(v, k) = R.col(c).segment(v, k);
      ws.u.segment(v, k).noalias() -= kin.S.middleCols(v, k).transpose().lazyProduct(ws.Y.col(i));
      if (p >= 0) {
        ws.Y.col(p) += ws.Y.col(i);
        ws.Y.col(p).noalias() += art.UDinv.middleCols(v, k).lazyProduct(ws.u.segment(v, k));
      }
    }
    mark("impulse propagation");
    // Forward: velocity changes.
    abiForwardSweep(model, kin, art, ws, X.col(c));
    mark("velocity updates");
  }
  ws.u.setZero();
}

// Algorithm 1/2's whole pipeline from q on the scalar T, marking each stage of Table 1:
// spatial axes, isolated inertias, articulated inertias, then per column impulse propagation
// and velocity updates. M⁻¹ for m = 0, else M⁻¹R for R = the first m columns of I.
template <class T, class Mark>
void abiPipeline(const Model& model, const Eigen::VectorXd& q, int m, Mark&& mark) {
  Kinematics<T> kin(model);
  Articulated<T> art(model);
  AbiWorkspace<T> ws(model);
  const VecX<T> qt = q.cast<T>();
  forwardKinematics<T>(model, qt, kin, mark);
  worldInertias<T>(model, kin, mark);
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

  void prepare(const Model& model) override;
  void configure(const Eigen::VectorXd& q) override;
  void inverse(Eigen::MatrixXd& Minv) override;
  void solve(const Eigen::MatrixXd& R, Eigen::MatrixXd& X) override;

 private:
  const Model* model_ = nullptr;
  std::unique_ptr<Kinematics<double>> kin_;
  std::unique_ptr<Articulated<double>> art_;
  std::unique_ptr<AbiWorkspace<double>> ws_;
};

}  // namespace minv
