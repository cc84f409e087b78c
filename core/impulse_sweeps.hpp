// The impulse sweeps of Drumwright's Algorithms 1 (fixed base) and 2 (floating base), scalar
// and plain: the readable version of solvers/abi.hpp's SIMD kernel, the oracle the tests hold
// that kernel to, and the sweeps the simulator's test impulses run on (sim/dynamics.cpp).
//
// Drumwright, "Fast dynamic simulation of highly articulated robots with contact via Θ(n²)
// time dense generalized inertia matrix inversion", SIMPAR 2012, Algorithms 1 and 2; in the
// notation of Featherstone, Rigid Body Dynamics Algorithms (2008), world frame, 0-based
// bodies with λ(i) < i and λ = −1 at a root (core/model.hpp).
//
// Contract: kin holds the world-frame S_i (core/kinematics.hpp) and art the articulated
// quantities of the same configuration: U_i = IA_i S_i, D_i⁻¹ and U_i D_i⁻¹ per body
// (core/articulated.hpp). For a generalized impulse r (nv) and spatial impulses f_b applied to
// bodies b (force vectors [n; f] about the world origin), the velocity change is
//   Δq̇ = M⁻¹ (r + Σ_b J_bᵀ f_b),   J_bᵀ f = (S_jᵀ f) over the DOFs j on b's path to the root,
// and Δv_i = Σ_{j on i's path} S_j Δq̇_j is each body's spatial velocity change. With
// Y_i = −f_i on entry (an impulse applied to a body enters its articulated impulse negated):
//   backward, i = nb−1 … 0:  u_i = r_i − S_iᵀ Y_i,           Y_λ(i) += Y_i + U_i D_i⁻¹ u_i
//   forward,  i = 0 … nb−1:  Δq̇_i = D_i⁻¹ u_i − (U_i D_i⁻¹)ᵀ Δv_λ(i),  Δv_i = Δv_λ(i) + S_i Δq̇_i
// with Δv_λ(i) = 0 at a root. A k-DOF joint makes S_i 6×k and D_i k×k; nothing else changes.
//
// Corrections to the printed pseudo-code (/work/shared/paper/READING-NOTES.md): Alg. 1 line 5
// drops the `Y_i +` term (a body's articulated impulse must reach its parent with the new
// term, as in the articulated-body algorithm) and line 8 lost the minus sign before
// (U_i D_i⁻¹)ᵀ Δv_λ(i) (Alg. 2 line 12 has it). Alg. 2's base step
// Δv₀ = (IA₀)⁻¹ (r₀ − Y₀) needs no code of its own: a floating base is body 0 on a 6-DOF
// joint whose S₀ (6×6, invertible) is the base's Plücker transform, so D₀ = S₀ᵀ IA₀ S₀ and
// the forward step with k = 6 and no parent gives Δv₀ = S₀ D₀⁻¹ S₀ᵀ (r₀ − Y₀), that formula,
// for the spatial impulse r₀ whose generalized impulse is S₀ᵀ r₀; Δq̇₀ is Δv₀ in base
// coordinates.
//
// Cost per column, for one-DOF bodies: backward 12 mul + 18 add, forward 13 mul + 12 add per
// body (a root: 6 mul + 6 add and 7 mul): 25 mul + 30 add per body, Θ(nb) (checked on the
// counting scalar in tests/impulse_sweeps_test.cpp). M⁻¹ column by column: Θ(nv·nb). §5.2's
// savings (sweeps that start at a column's body and stop there, by symmetry) are
// solvers/abi.hpp's; here only a single test impulse uses one, walking only its body's path.
// Everything is templated on the scalar: it runs on double and on the counting scalar
// (core/counting.hpp). The sweeps do not allocate; scratch lives in an ImpulseWorkspace.
#pragma once

#include <type_traits>
#include <vector>

#include "core/articulated.hpp"
#include "core/kinematics.hpp"
#include "core/model.hpp"

namespace minv {

// Scratch of the sweeps for one tree, allocated once.
template <class T>
struct ImpulseWorkspace {
  Mat6N<T> Y;   // −f_i per body on entry (a force vector), then the backward sweep's scratch
  Mat6N<T> dv;  // Δv_i: spatial velocity change, a motion vector per body
  VecX<T> u;    // u_i = r_i − S_iᵀ Y_i, per DOF

  explicit ImpulseWorkspace(const Model& m)
      : Y(Mat6N<T>::Zero(6, m.nb())), dv(Mat6N<T>::Zero(6, m.nb())), u(VecX<T>::Zero(m.nv())) {}
};

// Vector arguments: a VecX, a column of a matrix or a segment (T is deduced from kin only).
template <class T>
using ImpulseIn = std::type_identity_t<const Eigen::Ref<const VecX<T>>&>;
template <class T>
using ImpulseOut = std::type_identity_t<Eigen::Ref<VecX<T>>>;

// One body of the backward sweep, K DOFs at v: u_i = r_i − S_iᵀ Y_i (ws.u holds r_i on entry),
// then Y becomes Y_i + U_i D_i⁻¹ u_i, what λ(i) receives (not formed at a root).
template <class T, int K, class Y6>
void impulseBackwardStep(std::integral_constant<int, K>, const Kinematics<T>& kin,
                         const Articulated<T>& art, ImpulseWorkspace<T>& ws, Y6&& Y, int v, int k,
                         bool root) {
  auto u = ws.u.template segment<K>(v, k);
  // u_i = r_i − S_iᵀ Y_i
  u -= kin.S.template middleCols<K>(v, k).transpose().lazyProduct(Y);
  // Y_i + U_i D_i⁻¹ u_i
  if (!root) Y += art.UDinv.template middleCols<K>(v, k).lazyProduct(u);
}

// One body of the forward sweep, K DOFs at v: Δq̇_i into dq and Δv_i into dv (and ws.dv), from
// Δv_λ(i) in dvp.
template <class T, int K, class Dq>
void impulseForwardStep(std::integral_constant<int, K>, const Kinematics<T>& kin,
                        const Articulated<T>& art, ImpulseWorkspace<T>& ws, Dq& dq, int i, int p,
                        int v, int k, const Vec6<T>& dvp, Vec6<T>& dv) {
  auto qd = dq.template segment<K>(v, k);
  // Δq̇_i = D_i⁻¹ u_i − (U_i D_i⁻¹)ᵀ Δv_λ(i)   (Δv_λ(i) = 0 at a root)
  qd = art.Dinv[i].template topLeftCorner<K, K>(k, k).lazyProduct(ws.u.template segment<K>(v, k));
  if (p >= 0) qd -= art.UDinv.template middleCols<K>(v, k).transpose().lazyProduct(dvp);
  // Δv_i = Δv_λ(i) + S_i Δq̇_i
  dv = kin.S.template middleCols<K>(v, k).lazyProduct(qd);
  if (p >= 0) dv += dvp;
  ws.dv.col(i) = dv;
}

// Backward sweep (Alg. 1 lines 2-5), leaves first. On entry ws.u = r and ws.Y.col(i) = −f_i
// (zero where no impulse is applied); on exit ws.u = u (ws.Y is left as scratch). Along a chain
// (the parent is the next body done) Y_i + U_i D_i⁻¹ u_i goes on in registers (`carry`), not
// through memory, as in core/articulated.hpp; the same operations.
template <class T>
void impulseBackward(const Model& model, const Kinematics<T>& kin, const Articulated<T>& art,
                     ImpulseWorkspace<T>& ws) {
  Vec6<T> carry;
  bool carried = false;
  for (int i = model.nb() - 1; i >= 0; --i) {
    const int p = model.parent(i), v = model.vIdx(i), k = model.nvOf(i);
    // Y_i: its own and its children's terms
    Vec6<T> Y = ws.Y.col(i);
    if (carried) Y += carry;
    // u_i = r_i − S_iᵀ Y_i, and Y_i + U_i D_i⁻¹ u_i in place of Y_i
    forJointSize(k, [&](auto K) { impulseBackwardStep(K, kin, art, ws, Y, v, k, p < 0); });
    // Y_λ(i) += Y_i + U_i D_i⁻¹ u_i: in registers if λ(i) is the next body, else in memory
    carried = p >= 0 && p == i - 1;
    if (carried)
      carry = Y;
    else if (p >= 0)
      ws.Y.col(p) += Y;
  }
}

// Forward sweep (Alg. 1 lines 6-9), roots first: Δq̇ from the u of the backward sweep into
// dq, and every body's Δv into ws.dv (the parent's read back from registers along a chain).
template <class T>
void impulseForward(const Model& model, const Kinematics<T>& kin, const Articulated<T>& art,
                    ImpulseWorkspace<T>& ws, ImpulseOut<T> dq) {
  Vec6<T> dv = Vec6<T>::Zero();  // Δv of the body just done
  for (int i = 0; i < model.nb(); ++i) {
    const int p = model.parent(i), v = model.vIdx(i), k = model.nvOf(i);
    Vec6<T> dvp;
    if (p < 0)
      dvp.setZero();
    else if (p == i - 1)
      dvp = dv;
    else
      dvp = ws.dv.col(p);
    // Δq̇_i = D_i⁻¹ u_i − (U_i D_i⁻¹)ᵀ Δv_λ(i),  Δv_i = Δv_λ(i) + S_i Δq̇_i
    forJointSize(k, [&](auto K) { impulseForwardStep(K, kin, art, ws, dq, i, p, v, k, dvp, dv); });
  }
}

// Δq̇ = M⁻¹ r for a generalized impulse r (one column of Alg. 1 / 2); ws.dv holds every
// body's Δv on exit.
template <class T>
void impulseResponse(const Model& model, const Kinematics<T>& kin, const Articulated<T>& art,
                     ImpulseIn<T> r, ImpulseOut<T> dq, ImpulseWorkspace<T>& ws) {
  // No spatial impulse; u starts as r.
  ws.Y.setZero();
  ws.u = r;
  impulseBackward(model, kin, art, ws);
  impulseForward(model, kin, art, ws, dq);
}

// Δq̇ = M⁻¹ Σ_c λ_c J_cᵀ f_c for spatial impulses λ_c f_c applied to bodies[c] (r = 0); ws.dv
// holds every body's Δv on exit.
template <class T>
void spatialImpulseResponse(const Model& model, const Kinematics<T>& kin, const Articulated<T>& art,
                            const std::vector<int>& bodies, const std::vector<Vec6<T>>& f,
                            ImpulseIn<T> lambda, ImpulseOut<T> dq, ImpulseWorkspace<T>& ws) {
  // Y_b = −Σ λ_c f_c over the impulses at b; r = 0.
  ws.Y.setZero();
  ws.u.setZero();
  for (std::size_t c = 0; c < bodies.size(); ++c) ws.Y.col(bodies[c]) -= lambda(c) * f[c];
  impulseBackward(model, kin, art, ws);
  impulseForward(model, kin, art, ws, dq);
}

// A test impulse (Mirtich 1996): Δq̇ = M⁻¹ J_bᵀ f for one spatial impulse f at body b, and
// every body's Δv in ws.dv; for an impulse f' at body b', f'ᵀ Δv_b' = (J_b'ᵀ f')ᵀ M⁻¹ J_bᵀ f,
// an entry of the contact-space inertia. Only b's ancestors carry a Y (§5.2): the backward
// sweep walks b's path alone.
template <class T>
void testImpulseResponse(const Model& model, const Kinematics<T>& kin, const Articulated<T>& art,
                         int b, const Vec6<T>& f, ImpulseOut<T> dq, ImpulseWorkspace<T>& ws) {
  // r = 0, so u = 0 off the path; Y_b = −f.
  ws.u.setZero();
  Vec6<T> Y = -f;
  for (int i = b; i >= 0; i = model.parent(i)) {
    const int p = model.parent(i), v = model.vIdx(i), k = model.nvOf(i);
    // u_i = r_i − S_iᵀ Y_i, and Y_λ(i) = Y_i + U_i D_i⁻¹ u_i (i is λ(i)'s only child on the path)
    forJointSize(k, [&](auto K) { impulseBackwardStep(K, kin, art, ws, Y, v, k, p < 0); });
  }
  impulseForward(model, kin, art, ws, dq);
}

// M⁻¹ into X (nv×nv), column c the response to the unit impulse e_c: Θ(nv·nb), for tests and
// as a reference (it allocates its workspace; the sweeps themselves do not).
template <class T>
void referenceInverse(const Model& model, const Kinematics<T>& kin, const Articulated<T>& art,
                      std::type_identity_t<Eigen::Ref<MatX<T>>> X) {
  ImpulseWorkspace<T> ws(model);
  VecX<T> e = VecX<T>::Zero(model.nv());
  for (int c = 0; c < model.nv(); ++c) {
    // Column c: the response to e_c.
    e(c) = T(1);
    impulseResponse(model, kin, art, e, X.col(c), ws);
    e(c) = T(0);
  }
}

}  // namespace minv
