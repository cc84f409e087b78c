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
// r is either the unit impulses e_{c0+w} (Unit; ws.u is then written, not read) or held in
// ws.u on entry. ws.Y is zero on entry; each Y_i is zeroed again once used, so the next block
// starts clean without a pass of its own.
template <class T, int W, bool Unit>
void abiBackward(const Model& model, const Kinematics<T>& kin, const Articulated<T>& art,
                 AbiLanes<T, W>& ws, int last, int c0 = 0, int width = 0) {
  for (int i = last; i >= 0; --i) {
    const int v = model.vIdx(i), k = model.nvOf(i), p = model.parent(i);
    auto& Y = ws.Y[i];
    for (int j = 0; j < k; ++j) {
      // u = r − S_jᵀ Y
      auto& u = ws.u[v + j];
      typename AbiLanes<T, W>::Lane sy = kin.S(0, v + j) * Y.row(0);
      for (int r = 1; r < 6; ++r) sy += kin.S(r, v + j) * Y.row(r);
      if constexpr (Unit) {
        u = -sy;
        if (static_cast<unsigned>(v + j - c0) < static_cast<unsigned>(width)) u(v + j - c0) += T(1);
      } else {
        u -= sy;
      }
    }
    if (p >= 0) {
      // Y_λ(i) += Y_i + Σ_j (U D⁻¹)_j u_j
      auto& Yp = ws.Y[p];
      Yp += Y;
      for (int j = 0; j < k; ++j)
        for (int r = 0; r < 6; ++r) Yp.row(r) += art.UDinv(r, v + j) * ws.u[v + j];
    }
    Y.setZero();
  }
}

// Forward sweep over bodies 0 … last: Δq̇_i = D_i⁻¹ u_i − (U_i D_i⁻¹)ᵀ Δv_λ(i), stored for
// lane w < width at out[v + w·ld] (column w of the output), Δv_i = Δv_λ(i) + S_i Δq̇_i.
template <class T, int W>
void abiForward(const Model& model, const Kinematics<T>& kin, const Articulated<T>& art,
                AbiLanes<T, W>& ws, int last, T* out, std::size_t ld, int width) {
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
    // Store Δq̇ column by column.
    for (int j = 0; j < k; ++j)
      for (int w = 0; w < width; ++w) out[v + j + w * ld] = ws.u[v + j](w);
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

// Columns c0 … c0+W−1 (those below nv) of M⁻¹, rows of bodies 0 … b(last column): the upper
// triangle of those columns (and a few entries below it, overwritten by the mirror).
template <class T, int W, class Mark>
void abiInverseBlock(const Model& model, const Kinematics<T>& kin, const Articulated<T>& art,
                     AbiLanes<T, W>& ws, int c0, MatX<T>& X, Mark& mark) {
  const int nv = model.nv(), width = std::min(W, nv - c0);
  const int last = model.dofBody(c0 + width - 1);
  // The unit impulses e_{c0+w}, one per lane, up to the roots; then Δq̇ of bodies 0 … last.
  abiBackward<T, W, true>(model, kin, art, ws, last, c0, width);
  mark("impulse propagation");
  abiForward<T, W>(model, kin, art, ws, last, &X(0, c0), X.rows(), width);
  mark("velocity updates");
}

// The lower triangle from the upper one, X(i, j) = X(j, i) for i > j, in square tiles that
// stay in cache (both the read and the written tile).
template <class T>
void mirrorUpper(MatX<T>& X) {
  constexpr int B = 32;
  const int n = static_cast<int>(X.rows());
  T* x = X.data();
  for (int jb = 0; jb < n; jb += B)
    for (int ib = jb; ib < n; ib += B) {
      const int je = std::min(jb + B, n), ie = std::min(ib + B, n);
      for (int j = jb; j < je; ++j)
        for (int i = std::max(ib, j + 1); i < ie; ++i) x[i + std::size_t(j) * n] = x[j + std::size_t(i) * n];
    }
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
  mirrorUpper(Minv);
}

// Columns c0 … c0+W−1 of X = M⁻¹R: the full backward sweep, then the full forward sweep.
template <class T, int W, class Mark>
void abiSolveBlock(const Model& model, const Kinematics<T>& kin, const Articulated<T>& art,
                   AbiLanes<T, W>& ws, const MatX<T>& R, int c0, MatX<T>& X, Mark& mark) {
  const int nb = model.nb(), nv = model.nv();
  const int width = std::min<int>(W, static_cast<int>(R.cols()) - c0);
  // r: the right-hand sides, one per lane (unused lanes zero); Y is zero between blocks.
  for (int v = 0; v < nv; ++v) {
    ws.u[v].setZero();
    for (int w = 0; w < width; ++w) ws.u[v](w) = R(v, c0 + w);
  }
  abiBackward<T, W, false>(model, kin, art, ws, nb - 1);
  mark("impulse propagation");
  abiForward<T, W>(model, kin, art, ws, nb - 1, &X(0, c0), X.rows(), width);
  mark("velocity updates");
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
