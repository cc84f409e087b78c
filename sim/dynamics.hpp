// Rigid-body dynamics for the simulator, on core/'s world-frame quantities (double only).
//
//   aba()              articulated-body forward dynamics (RBDA Table 7.1, in world
//                      coordinates, where Ṡ_i = V_i × S_i): q̈ = M⁻¹(τ − C(q, v) + gravity),
//                      given IA, U, D⁻¹ from core/articulated.hpp. Θ(nb). abaStep() also takes
//                      the unconstrained step of every solver path in its forward pass: v* =
//                      v + h q̈ and every body's velocity V* (for the contacts' velocities).
//   contact wrenches   a unit force along direction d at world point p is the spatial force
//                      f = [p × d; d] about the world origin; the Jacobian column of a contact on
//                      body b is J_k = S_kᵀ f for the DOFs k of b and its ancestors (zero
//                      elsewhere); the contact point's velocity along d is fᵀ V_b.
//   testImpulses()     contact-space inertia by spatial test impulses (Mirtich 1996; RBDA §7.
//                      applied to impulses): a unit spatial impulse f at body b is swept up b's
//                      path to the root through the articulated inertias, then one forward sweep
//                      gives every body's velocity change ΔV; entry (r, c) of the contact-space
//                      inertia is f_rᵀ ΔV_{b_r}. No nv-sized product is formed: O(nb·m + m²).
//   applyImpulses()    Δv = M⁻¹ Σ_c J_c λ_c by one backward and one forward sweep, Θ(nb).
//   integrate()        q ← q ⊕ h·v: angles and positions by Euler, quaternions by the
//                      exponential map of the child/body-frame angular velocity, renormalised;
//                      a floating base moves by R·v_body.
// testImpulses() and applyImpulses() run the impulse sweeps of core/impulse_sweeps.hpp
// (Drumwright's Algorithms 1 and 2, the recursions solvers/abi runs in SIMD lanes):
// testImpulseResponse() per column, spatialImpulseResponse() for the update.
#pragma once

#include <Eigen/Core>
#include <vector>

#include "core/articulated.hpp"
#include "core/impulse_sweeps.hpp"
#include "core/kinematics.hpp"

namespace minv::sim {

// A point fixed in a body: the body and the point in its frame.
struct ContactPoint {
  int body = 0;
  Eigen::Vector3d point = Eigen::Vector3d::Zero();
};

// Scratch for aba() and abaStep().
struct AbaWorkspace {
  Mat6N<double> V, c, pA, a;  // per body: velocity, velocity-product acceleration, bias, accel.
  Mat6N<double> Vstar;        // per body: velocity after the step (abaStep)
  Eigen::VectorXd u;
  explicit AbaWorkspace(const Model& m)
      : V(Mat6N<double>::Zero(6, m.nb())),
        c(V),
        pA(V),
        a(V),
        Vstar(V),
        u(Eigen::VectorXd::Zero(m.nv())) {}
};

// Scratch of the impulse sweeps (core/impulse_sweeps.hpp): Y, Δv per body, u per DOF.
using ImpulseWorkspace = minv::ImpulseWorkspace<double>;

// World spatial velocities V_i = V_λ(i) + S_i v_i of every body.
void bodyVelocities(const Model& model, const Kinematics<double>& kin, const Eigen::VectorXd& v,
                    Mat6N<double>& V);

// q̈ from ABA; `gravity` is the world gravity vector (e.g. (0, 0, −9.81)).
void aba(const Model& model, const Kinematics<double>& kin, const Articulated<double>& art,
         const Eigen::VectorXd& v, const Eigen::VectorXd& tau, const Eigen::Vector3d& gravity,
         AbaWorkspace& ws, Eigen::VectorXd& qdd);

// aba() and the unconstrained step in its forward pass: vstar = v + h q̈ and ws.Vstar the
// bodies' velocities V*_i = V*_λ(i) + S_i v*_i (bodyVelocities of vstar, without another pass).
void abaStep(const Model& model, const Kinematics<double>& kin, const Articulated<double>& art,
             const Eigen::VectorXd& v, const Eigen::VectorXd& tau, const Eigen::Vector3d& gravity,
             double h, AbaWorkspace& ws, Eigen::VectorXd& qdd, Eigen::VectorXd& vstar);

// The spatial force of a unit force along d at world point p.
inline void unitWrench(const Eigen::Vector3d& p, const Eigen::Vector3d& d, Vec6<double>& f) {
  f << p.cross(d), d;
}
inline Vec6<double> unitWrench(const Eigen::Vector3d& p, const Eigen::Vector3d& d) {
  Vec6<double> f;
  unitWrench(p, d, f);
  return f;
}

// Adds J_f = (S_kᵀ f)_k over b's path to column `col` of J (nv×m).
void addJacobianColumn(const Model& model, const Kinematics<double>& kin, int body,
                       const Vec6<double>& f, Eigen::MatrixXd& J, int col);

// The DOFs on body b's path to the root (b's own first), for sparse products with J.
std::vector<int> pathDofs(const Model& model, int body);

// Contact-space inertia A (m×m), A_rc = f_rᵀ ΔV_{b_r}(unit impulse f_c at b_c): equals
// Jᵀ M⁻¹ J for J = [J_f0 … J_f(m−1)].
void testImpulses(const Model& model, const Kinematics<double>& kin, const Articulated<double>& art,
                  ImpulseWorkspace& ws, const std::vector<int>& bodies,
                  const std::vector<Vec6<double>>& wrenches, Eigen::MatrixXd& A,
                  Eigen::VectorXd& scratch);

// The same with the columns shared among ws.size() OpenMP threads, ws[t] and scratch[t]
// (nv) thread t's own.
void testImpulses(const Model& model, const Kinematics<double>& kin, const Articulated<double>& art,
                  std::vector<ImpulseWorkspace>& ws, const std::vector<int>& bodies,
                  const std::vector<Vec6<double>>& wrenches, Eigen::MatrixXd& A,
                  std::vector<Eigen::VectorXd>& scratch);

// dqd = M⁻¹ Σ_c J_c λ_c for impulses λ_c along wrenches f_c at bodies b_c.
void applyImpulses(const Model& model, const Kinematics<double>& kin,
                   const Articulated<double>& art, ImpulseWorkspace& ws,
                   const std::vector<int>& bodies, const std::vector<Vec6<double>>& wrenches,
                   const Eigen::VectorXd& lambda, Eigen::VectorXd& dqd);

// q ← q ⊕ h·v (see above); quaternions renormalised.
void integrate(const Model& model, Eigen::VectorXd& q, const Eigen::VectorXd& v, double h);

// Total spatial momentum Σ I_i V_i about the world origin, world coordinates.
Vec6<double> spatialMomentum(const Model& model, const Kinematics<double>& kin,
                             const Eigen::VectorXd& v);
// Kinetic energy ½ Σ V_iᵀ I_i V_i.
double kineticEnergy(const Model& model, const Kinematics<double>& kin, const Eigen::VectorXd& v);

}  // namespace minv::sim
