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
//
// Savings: U, D⁻¹ and U D⁻¹ are computed once per configuration (§5.2; core/articulated.hpp).
// For a unit column e_c at body b only b's ancestors carry a non-zero Y (§5.2), and since M⁻¹
// is symmetric only the rows of bodies 0 … b are needed (bodies are numbered parent first, so
// their Δv never needs a later body): both sweeps stop at b, and the other triangle is
// mirrored. Columns go in blocks of W lanes (W = kAbiLanes<T>: 8 for double, 1 for the
// counting scalar), one lane per column, so every update is a W-wide vector operation;
// blocks run in OpenMP threads (setThreads). Multi-DOF joints make D a k×k block.
// Cost: Σ_c (depth(b_c) + b_c) body steps ≈ n²/2 + Σ depth for M⁻¹ (Θ(n²)); Θ(m·nb) for M⁻¹R.
// Scratch Θ(nb·W) per thread, allocated in the workspace; the sweeps do not allocate.
#pragma once

#include <omp.h>

#include <algorithm>
#include <type_traits>
#include <vector>

#include "core/articulated.hpp"
#include "core/counting.hpp"
#include "core/kinematics.hpp"
#include "solvers/solver.hpp"

namespace minv {

inline int omp_thread() { return omp_get_thread_num(); }

// Columns per SIMD block: 8 doubles (two AVX2 or one AVX-512 register per row); the counting
// scalar runs one column at a time, so its counts are those of the algorithm, column by column.
template <class T>
inline constexpr int kAbiLanes = 1;
template <>
inline constexpr int kAbiLanes<double> = 8;

// Scratch of one thread for a block of W columns.
template <class T, int W>
struct AbiLanes {
  using Lane = Eigen::Array<T, 1, W>;                   // one value per column
  using Spatial = Eigen::Array<T, 6, W, W == 1 ? Eigen::ColMajor : Eigen::RowMajor>;  // per column
  std::vector<Spatial> Y;   // articulated impulses, per body
  std::vector<Spatial> dv;  // velocity changes Δv, per body
  std::vector<Lane> u;      // u_i = r_i − S_iᵀ Y_i, then Δq̇, per DOF

  explicit AbiLanes(const Model& m)
      : Y(m.nb(), Spatial::Zero()), dv(m.nb(), Spatial::Zero()), u(m.nv(), Lane::Zero()) {}
};

// Per-tree scratch of the impulse sweeps: a wide block and a one-column block per thread.
template <class T>
struct AbiWorkspace {
  std::vector<AbiLanes<T, kAbiLanes<T>>> wide;
  std::vector<AbiLanes<T, 1>> narrow;

  explicit AbiWorkspace(const Model& m, int threads = 1)
      : wide(threads, AbiLanes<T, kAbiLanes<T>>(m)), narrow(threads, AbiLanes<T, 1>(m)) {}
  int threads() const { return static_cast<int>(wide.size()); }
};

// Backward sweep from body `last` to the roots: u_i = r_i − S_iᵀ Y_i, Y_λ(i) += Y_i + U_i D_i⁻¹ u_i.
// On entry ws.u holds r for the DOFs of bodies 0 … last and ws.Y is zero there.
template <class T, int W>
void abiBackward(const Model& model, const Kinematics<T>& kin, const Articulated<T>& art,
                 AbiLanes<T, W>& ws, int last) {
  for (int i = last; i >= 0; --i) {
    const int v = model.vIdx(i), k = model.nvOf(i), p = model.parent(i);
    auto& Y = ws.Y[i];
    for (int j = 0; j < k; ++j) {
      // u = r − S_jᵀ Y
      auto& u = ws.u[v + j];
      for (int r = 0; r < 6; ++r) u -= kin.S(r, v + j) * Y.row(r);
    }
    if (p < 0) continue;
    // Y_λ(i) += Y_i + Σ_j (U D⁻¹)_j u_j
    auto& Yp = ws.Y[p];
    Yp += Y;
    for (int j = 0; j < k; ++j)
      for (int r = 0; r < 6; ++r) Yp.row(r) += art.UDinv(r, v + j) * ws.u[v + j];
  }
}

// Forward sweep over bodies 0 … last: Δq̇_i = D_i⁻¹ u_i − (U_i D_i⁻¹)ᵀ Δv_λ(i) (into ws.u),
// Δv_i = Δv_λ(i) + S_i Δq̇_i.
template <class T, int W>
void abiForward(const Model& model, const Kinematics<T>& kin, const Articulated<T>& art,
                AbiLanes<T, W>& ws, int last) {
  using Lane = typename AbiLanes<T, W>::Lane;
  for (int i = 0; i <= last; ++i) {
    const int v = model.vIdx(i), k = model.nvOf(i), p = model.parent(i);
    auto& dv = ws.dv[i];
    if (k == 1) {
      // Δq̇ = u/d − (U/d)ᵀ Δv_λ
      Lane qd = art.Dinv[i](0, 0) * ws.u[v];
      if (p >= 0)
        for (int r = 0; r < 6; ++r) qd -= art.UDinv(r, v) * ws.dv[p].row(r);
      ws.u[v] = qd;
    } else {
      // Δq̇ = D⁻¹ u − (U D⁻¹)ᵀ Δv_λ, k rows at once.
      Lane qd[6];
      for (int j = 0; j < k; ++j) {
        qd[j] = art.Dinv[i](j, 0) * ws.u[v];
        for (int l = 1; l < k; ++l) qd[j] += art.Dinv[i](j, l) * ws.u[v + l];
        if (p >= 0)
          for (int r = 0; r < 6; ++r) qd[j] -= art.UDinv(r, v + j) * ws.dv[p].row(r);
      }
      for (int j = 0; j < k; ++j) ws.u[v + j] = qd[j];
    }
    // Δv_i = Δv_λ(i) + S_i Δq̇_i
    for (int r = 0; r < 6; ++r) {
      Lane row = kin.S(r, v) * ws.u[v];
      for (int j = 1; j < k; ++j) row += kin.S(r, v + j) * ws.u[v + j];
      if (p >= 0)
        dv.row(r) = ws.dv[p].row(r) + row;
      else
        dv.row(r) = row;
    }
  }
}

// Columns c0 … c0+W−1 (those below nv) of M⁻¹, rows of bodies 0 … b(last column), written
// transposed as X(c, rows): by symmetry that is the lower triangle, contiguous per row.
template <class T, int W, class Mark>
void abiInverseBlock(const Model& model, const Kinematics<T>& kin, const Articulated<T>& art,
                     AbiLanes<T, W>& ws, int c0, MatX<T>& X, Mark& mark) {
  const int nv = model.nv(), width = std::min(W, nv - c0);
  const int last = model.dofBody(c0 + width - 1);
  const int lastDof = model.vIdx(last) + model.nvOf(last);
  // r: the unit impulses, one per lane; Y = 0.
  for (int i = 0; i <= last; ++i) ws.Y[i].setZero();
  for (int v = 0; v < lastDof; ++v) ws.u[v].setZero();
  for (int w = 0; w < width; ++w) ws.u[c0 + w](w) = T(1);
  abiBackward(model, kin, art, ws, last);
  mark("impulse propagation");
  abiForward(model, kin, art, ws, last);
  mark("velocity updates");
  // Store Δq̇ of DOF v for column c0 + w at X(c0 + w, v).
  for (int v = 0; v < lastDof; ++v)
    for (int w = 0; w < width; ++w) X(c0 + w, v) = ws.u[v](w);
}

// X = Xᵀ from the lower triangle, in tiles that stay in cache.
template <class T>
void mirrorLower(MatX<T>& X) {
  constexpr int B = 64;
  const int n = static_cast<int>(X.rows());
  for (int jb = 0; jb < n; jb += B)
    for (int ib = jb; ib < n; ib += B)
      for (int j = jb; j < std::min(jb + B, n); ++j)
        for (int i = std::max(ib, j + 1); i < std::min(ib + B, n); ++i) X(j, i) = X(i, j);
}

// Stages "impulse propagation" and "velocity updates" for all columns: Minv = M⁻¹.
template <class T, class Mark = NoMark>
void abiInverse(const Model& model, const Kinematics<T>& kin, const Articulated<T>& art,
                AbiWorkspace<T>& ws, MatX<T>& Minv, Mark&& mark = {}) {
  constexpr int W = kAbiLanes<T>;
  const int blocks = (model.nv() + W - 1) / W;
  if constexpr (std::is_same_v<std::decay_t<Mark>, NoMark>) {
    // Blocks are independent; later blocks cost more, so hand them out dynamically.
#pragma omp parallel for schedule(dynamic, 1) num_threads(ws.threads()) if (ws.threads() > 1)
    for (int b = 0; b < blocks; ++b) {
      NoMark none;
      abiInverseBlock<T, W>(model, kin, art, ws.wide[omp_thread()], b * W, Minv, none);
    }
  } else {
    for (int b = 0; b < blocks; ++b) abiInverseBlock<T, W>(model, kin, art, ws.wide[0], b * W, Minv, mark);
  }
  mirrorLower(Minv);
}

// Columns c0 … c0+W−1 of X = M⁻¹R: the full backward sweep, then the full forward sweep.
template <class T, int W, class Mark>
void abiSolveBlock(const Model& model, const Kinematics<T>& kin, const Articulated<T>& art,
                   AbiLanes<T, W>& ws, const MatX<T>& R, int c0, MatX<T>& X, Mark& mark) {
  const int nb = model.nb(), nv = model.nv();
  const int width = std::min<int>(W, static_cast<int>(R.cols()) - c0);
  // r: the right-hand sides, one per lane (unused lanes zero); Y = 0.
  for (int i = 0; i < nb; ++i) ws.Y[i].setZero();
  for (int v = 0; v < nv; ++v) {
    ws.u[v].setZero();
    for (int w = 0; w < width; ++w) ws.u[v](w) = R(v, c0 + w);
  }
  abiBackward(model, kin, art, ws, nb - 1);
  mark("impulse propagation");
  abiForward(model, kin, art, ws, nb - 1);
  mark("velocity updates");
  for (int w = 0; w < width; ++w)
    for (int v = 0; v < nv; ++v) X(v, c0 + w) = ws.u[v](w);
}

// X = M⁻¹R, W columns at a time (one at a time when R has fewer columns than half a block).
template <class T, class Mark = NoMark>
void abiSolve(const Model& model, const Kinematics<T>& kin, const Articulated<T>& art,
              AbiWorkspace<T>& ws, const MatX<T>& R, MatX<T>& X, Mark&& mark = {}) {
  constexpr int W = kAbiLanes<T>;
  const int m = static_cast<int>(R.cols());
  if (W > 1 && 2 * m < W) {
    for (int c = 0; c < m; ++c) abiSolveBlock<T, 1>(model, kin, art, ws.narrow[0], R, c, X, mark);
    return;
  }
  const int blocks = (m + W - 1) / W;
  if constexpr (std::is_same_v<std::decay_t<Mark>, NoMark>) {
#pragma omp parallel for schedule(static) num_threads(ws.threads()) if (ws.threads() > 1)
    for (int b = 0; b < blocks; ++b) {
      NoMark none;
      abiSolveBlock<T, W>(model, kin, art, ws.wide[omp_thread()], R, b * W, X, none);
    }
  } else {
    for (int b = 0; b < blocks; ++b) abiSolveBlock<T, W>(model, kin, art, ws.wide[0], R, b * W, X, mark);
  }
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

  void setThreads(int n) override;
  int threads() const override { return threads_; }
  void prepare(const Model& model) override;
  void configure(const Eigen::VectorXd& q) override;
  void inverse(Eigen::MatrixXd& Minv) override;
  void solve(const Eigen::MatrixXd& R, Eigen::MatrixXd& X) override;

 private:
  const Model* model_ = nullptr;
  int threads_ = 1;
  std::unique_ptr<Kinematics<double>> kin_;
  std::unique_ptr<Articulated<double>> art_;
  std::unique_ptr<AbiWorkspace<double>> ws_;
};

}  // namespace minv
