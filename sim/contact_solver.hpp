// The contact solver: Drumwright & Shell's maximum-dissipation model (WAFR 2010) with a
// linearised friction cone, solved in contact space.
//
// Problem. nc point contacts, contact c with unit normal n_c and orthonormal tangents
// t1_c, t2_c. The contact-space inertia A (3nc×3nc) is Jᵀ M⁻¹ J for J = [N D₂] ordered per
// contact (columns n, t1, t2 of contact c at 3c, 3c+1, 3c+2); it holds NᵀM⁻¹N, NᵀM⁻¹D₂ and
// D₂ᵀM⁻¹D₂, and the k-direction matrices follow exactly as NᵀM⁻¹D = (NᵀM⁻¹D₂)T, DᵀM⁻¹D =
// TᵀD₂ᵀM⁻¹D₂T with T (2×k) the unit directions (cos θ_j, sin θ_j), θ_j = 2πj/k. v0 (3nc) are
// the contact velocities Jᵀv* before contact, b (nc) a normal velocity bias (stabilisation,
// see sim/simulator.hpp). The post-contact velocity v⁺ = v* + M⁻¹Jλ minimises the kinetic
// energy ½ v⁺ᵀ M v⁺ + Σ b_c λn_c subject to λn ≥ 0 and the tangential impulse in the
// linearised cone μ λn · conv{t_j}. The non-penetration constraint N·v⁺ + b ≥ 0 is implied at
// the optimum (see below), so adding it, as Drumwright & Shell write the model, changes
// nothing.
//
// Algorithm. The cone is parametrised by its k generators w_j = (1, μ cos θ_j, μ sin θ_j)
// (the cone is their conic hull because 0 ∈ conv{t_j} for k ≥ 3): λ_c = W β_c, β_c ≥ 0. The
// problem becomes the bound-constrained convex QP
//     min ½ βᵀGβ + βᵀg0,  β ≥ 0,   G = WᵀAW (PSD, often singular), g0 = Wᵀ(v0 + [b; 0; 0]),
// solved by projected Gauss–Seidel (coordinate descent with exact line minimisation and
// projection on β_j ≥ 0; converges for PSD G with positive diagonal, Luo & Tseng 1992), warm
// started, the gradient g = Gβ + g0 kept up to date incrementally. g_j is the bias-shifted
// contact velocity along generator j; KKT: β ≥ 0, g ≥ 0, βᵀg = 0. Since Σ_j cos θ_j =
// Σ_j sin θ_j = 0, mean_j g_j = v⁺_n + b ≥ 0: non-penetration follows from g ≥ 0.
// Convergence test: the natural KKT residual ‖min(β, g)‖_∞ ≤ tolerance · max(‖g0‖_∞, floor).
//
// Implementation (solveMaxDissipation). G is never formed: it would cost Θ((k·nc)²) memory
// and two products with A per solve, and each coordinate step an axpy of length k·nc. Since
// W is block diagonal (3×k per contact), g_c = Wᵀ(u_c + [b_c; 0; 0]) with the contact
// velocities u = Aλ + v0, λ_c = W β_c, which are kept up to date instead. A sweep visits the
// contacts in order (per-contact block Gauss–Seidel): contact c's generators are relaxed by
// `inner_sweeps` coordinate-descent passes on the exact local gradient (through the k×k block
// G_cc = Wᵀ A_cc W), then u += A_{:,c} Δλ_c, one 3-column update (A symmetric: its columns
// are contiguous) of length 3nc. With inner_sweeps = 1 this is, step for step, the same
// projected Gauss–Seidel on β as before (the same coordinate order and updates, only the
// bookkeeping differs), at 3/k of the update work and without the Θ((k·nc)²) setup; more
// inner passes solve each contact's sub-problem further before moving on (a pass that moves
// no generator ends them). The default is 2: on problems recorded from the walking centipede
// (warm started, five per size) two passes halve the sweeps (4 -> 2 per solve) and the solve
// takes 17-33 % less time from S = 5 to 250 (Zen 5: 1.57 -> 1.26 us at S = 5, 27.8 -> 20.9 us
// at 40, 2.41 -> 1.63 ms at 250); three passes also need 2 sweeps but cost more. With the
// minimum-norm warm start (sim/simulator.hpp) one pass took the S = 5 solve from 1.25 to 1.42 us
// (Zen 4; mean sweeps 1.45 -> 2.58). The residual test, the drift refresh every 64 sweeps
// (u = Aλ + v0 afresh) and the residuals reported are as above; the final residuals use λ = Wβ
// and v⁺ = Aλ + v0 recomputed from β, and a sweep that passes the test on the incremental u
// passes it again on those before the solve stops (else the sweeps go on), so a converged solve
// reports a KKT residual within the tolerance.
// solveMaxDissipationReference() is the former implementation (G formed, solveBoundQP),
// kept as the oracle of tests/sim_contact_solver_test.cpp. The solve is one function compiled
// per ISA level (sim/clones.hpp), its coordinate steps without data-dependent branches. Cost per
// sweep Θ(nc·3nc) flops (reference Θ((k·nc)²)); setup Θ(nc) plus one product Aλ when warm started.
//
// Limits. PGS converges linearly, slowly when G is ill-conditioned (long chains, many
// coupled contacts, large mass ratios); it stops at max_iterations and says so (converged =
// false, with the residual reached). The cone is polyhedral (k directions, inscribed in the
// circular cone, so friction is at most cos(π/k) weaker in the worst direction). Like every
// maximum-dissipation model with a coupled cone (and Anitescu's convex relaxation), a sliding
// contact may leave with a small separating normal velocity (μ·mean over the active
// generators), not exactly zero. β is not unique when G is singular; λ and v⁺ are.
#pragma once

#include <Eigen/Core>

namespace minv::sim {

struct ContactSolverOptions {
  int max_iterations = 1000;
  double tolerance = 1e-9;  // relative KKT residual
  double floor = 1e-6;      // velocity scale floor (m/s) of the relative test
  int inner_sweeps = 2;     // coordinate-descent passes per contact and sweep (≥ 1)
};

struct ContactResiduals {
  int iterations = 0;
  bool converged = true;
  double kkt = 0;              // ‖min(β, g)‖_∞ (velocity units)
  double complementarity = 0;  // max_j |β_j g_j|
  double penetration = 0;      // max_c max(0, −(v⁺_n + b))
  double cone = 0;             // max_c distance outside the linearised cone (impulse units)
};

// min ½βᵀGβ + βᵀg0 over β ≥ 0 by PGS; β is the warm start on entry (resized and zeroed if
// its size is wrong), the solution on exit.
ContactResiduals solveBoundQP(const Eigen::MatrixXd& G, const Eigen::VectorXd& g0,
                              Eigen::VectorXd& beta, const ContactSolverOptions& options);

struct ContactProblem {
  Eigen::MatrixXd A;   // 3nc×3nc contact-space inertia, per contact (n, t1, t2)
  Eigen::VectorXd v0;  // 3nc pre-contact velocities
  Eigen::VectorXd b;   // nc normal bias
  double mu = 0.8;
  int k = 4;  // friction directions (≥ 3)
};

struct ContactSolution {
  Eigen::VectorXd lambda;  // 3nc impulses (n, t1, t2) per contact
  Eigen::VectorXd beta;    // k·nc generator weights
  ContactResiduals residuals;
};

// Solves the maximum-dissipation problem; `beta` is the warm start (k·nc, or empty). The
// residuals are measured on λ and v⁺ = Aλ + v0, independently of the parametrisation.
ContactSolution solveMaxDissipation(const ContactProblem& problem, const Eigen::VectorXd& beta,
                                    const ContactSolverOptions& options);
// The same into `out`, reusing its storage (beta may be out.beta); the solve's other scratch
// is kept per thread, so a caller that keeps `out` solves step after step without allocating.
void solveMaxDissipation(const ContactProblem& problem, const Eigen::VectorXd& beta,
                         const ContactSolverOptions& options, ContactSolution& out);
// The same problem by the former implementation: G = WᵀAW formed, solveBoundQP (the oracle
// of the tests; options.inner_sweeps is ignored).
ContactSolution solveMaxDissipationReference(const ContactProblem& problem,
                                             const Eigen::VectorXd& beta,
                                             const ContactSolverOptions& options);

// The generator matrix W (3×k) of the linearised cone.
Eigen::MatrixXd coneGenerators(double mu, int k);

}  // namespace minv::sim
