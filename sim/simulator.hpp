// Velocity-level (impulse-based) time stepping with point contacts on the ground plane z = 0.
//
// One step of size h: the controller's torques τ(t, q, v) first, untimed (MuJoCo's mj_step,
// timed beside ours, is given the same torques computed outside it), then five timed
// components:
//   dynamics     kinematics, articulated-body inertias, ABA forward dynamics q̈
//                (sim/dynamics.hpp), v* = v + h q̈ and the bodies' velocities V* (abaStep):
//                the same for every path.
//   collision    each contact point's height φ; points with φ < margin are contacts, with
//                normal z and tangents x, y; their velocities J₂ᵀv* and the bias
//                b = φ/h if φ ≥ 0 (speculative: the point may just reach the plane) or
//                erp·φ/h if φ < 0 (push out a fraction erp of the penetration per step).
//   matrices     the contact-space inertia A = Jᵀ M⁻¹ J (3 columns per contact: N and the two
//                tangent columns of D; see sim/contact_solver.hpp) by the chosen path:
//                  a registry solver (abi, lapack, ltdl, …): configure(q), then
//                  X = solve(J) = M⁻¹J (abi: Θ(nm) impulse sweeps, never forming M⁻¹;
//                  Cholesky family: CRBA, factor once, back-substitute), A = JᵀX using J's
//                  sparsity (each column lives on one body's path to the root);
//                  "test-impulse": spatial test impulses at the contact points through the
//                  articulated inertias already computed for ABA (sim/dynamics.hpp), no
//                  generalized-coordinate product, O(nb·m + m²);
//                  "contact-inertia": the recursion of sim/contact_inertia.hpp on the same
//                  articulated inertias, every pair of directions meeting at its lowest
//                  common ancestor, Θ(n + m²).
//   solve        the maximum-dissipation contact impulses λ (sim/contact_solver.hpp), warm
//                started per contact point by extrapolating its weights β of earlier steps.
//                β is not unique (W has a null space) and the solves' β wander along it, so
//                each step's β is stored in its minimum-norm form: for the usual k = 4 the
//                null space is z = (1, −1, 1, −1), and β + t z, t = −βᵀz/4 clamped so that
//                β + t z ≥ 0, is the shortest β ≥ 0 with the same λ. The start is max(0, ·) of
//                the least-squares quadratic through the last five steps' β, evaluated at the
//                next (1.8 β_{t−1} − 0.8 β_{t−3} − 0.6 β_{t−4} + 0.6 β_{t−5}), where the point
//                was in contact in all five; the line through the last two (2β_{t−1} − β_{t−2})
//                after two to four steps, and for k ≠ 4 (β as solved); β_{t−1} after one; else
//                0. The answer is the solver's, whatever the start. Measured on the walking
//                centipede (`minv simulate sweep --segments S`, medians, Zen 4, builds
//                alternated; the line through the last two before): at S = 5, 77 % of the
//                solves need one block Gauss–Seidel sweep (mean 1.45, was 2.54) and the solve
//                stage takes 1.25 us (was 1.63); at S = 10 2.60 (3.97), S = 20 5.9-6.4
//                (7.8-10.5), S = 40 23.8-25.2 (29.9-32.6, 1000 and 2000 steps), S = 100 153-160
//                (177-185). An earlier trial of this scheme, whose code was not kept, had
//                measured S = 40 slower (24.0 -> 25.5-26.2 us, against a baseline run then);
//                this implementation did not reproduce that. Extrapolating β as solved (not in
//                minimum-norm form) by 3β_{t−1} − 3β_{t−2} + β_{t−3}, with one inner pass, made
//                the median solve take 23 sweeps.
//   update       v⁺ = v* + M⁻¹Jλ (solver paths: X λ; test-impulse and contact-inertia: one
//                impulse sweep), then
//                q ← q ⊕ h v⁺ (sim/dynamics.hpp). This is semi-implicit ("symplectic")
//                Euler: the paper's explicit Euler step with the new velocity, as every
//                velocity-level contact method integrates.
#pragma once

#include <Eigen/Core>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "core/articulated.hpp"
#include "core/kinematics.hpp"
#include "sim/contact_inertia.hpp"
#include "sim/contact_solver.hpp"
#include "sim/dynamics.hpp"
#include "solvers/solver.hpp"

namespace minv::sim {

constexpr const char* kTestImpulsePath = "test-impulse";
constexpr const char* kContactInertiaPath = "contact-inertia";

// Every contact-space path: the registry's solvers, then "test-impulse" and "contact-inertia".
std::vector<std::string> simulationPaths();

struct SimOptions {
  double dt = 1e-5;
  Eigen::Vector3d gravity = Eigen::Vector3d(0, 0, -9.81);
  double mu = 0.8;
  int friction_dirs = 4;
  double margin = 2e-3;  // m
  double erp = 0.2;
  std::string path = "abi";
  ContactSolverOptions contact;
  // OpenMP threads of the stages that split (the contact-space matrices: the solver's own
  // threads, test impulses by column, the contact-inertia pair blocks of at least
  // kParallelEntries by rows); kinematics, the articulated pass, ABA, the contact solve and the
  // update stay on one.
  int threads = 1;
};

struct StepTimes {
  double dynamics = 0, collision = 0, matrices = 0, solve = 0, update = 0;
  double total() const { return dynamics + collision + matrices + solve + update; }
  StepTimes& operator+=(const StepTimes& o) {
    dynamics += o.dynamics, collision += o.collision, matrices += o.matrices, solve += o.solve,
        update += o.update;
    return *this;
  }
};

class Simulator {
 public:
  using Controller = std::function<void(double t, const Eigen::VectorXd& q,
                                        const Eigen::VectorXd& v, Eigen::VectorXd& tau)>;

  // Throws std::invalid_argument for an unknown path or a solver that does not support the
  // model. The model must outlive the simulator.
  Simulator(const Model& model, std::vector<ContactPoint> points, SimOptions options);

  void setState(const Eigen::VectorXd& q, const Eigen::VectorXd& v);
  void setController(Controller c) { controller_ = std::move(c); }
  void step();

  const Eigen::VectorXd& q() const { return q_; }
  const Eigen::VectorXd& v() const { return v_; }
  double time() const { return t_; }
  int steps() const { return steps_; }
  const StepTimes& lastTimes() const { return last_; }
  const StepTimes& totalTimes() const { return total_; }
  int lastContacts() const { return static_cast<int>(active_.size()); }
  const ContactResiduals& lastResiduals() const { return residuals_; }
  const Eigen::VectorXd& lastImpulses() const { return lambda_; }  // 3 per active contact
  const std::vector<int>& activeContacts() const { return active_; }
  // The last step's contact problem (A, v0, b, μ, k; nothing if it had no contact) and the
  // warm start β it was solved from: for recording problems and replaying them. Before the
  // first step both hold zeros sized for every point in contact (allocated up front).
  const ContactProblem& lastProblem() const { return prob_; }
  const Eigen::VectorXd& lastWarmStart() const { return warm_beta_; }
  // Kinematics at the configuration of the last step's start.
  const Kinematics<double>& kinematics() const { return kin_; }
  const SimOptions& options() const { return o_; }
  const Model& model() const { return model_; }

 private:
  const Model& model_;
  std::vector<ContactPoint> points_;
  SimOptions o_;
  std::unique_ptr<Solver> solver_;
  Controller controller_;
  Kinematics<double> kin_;
  Articulated<double> art_;
  // Fills kin_ and art_ from q_ on one thread (abi's module of the level in use).
  void (*articulate_)(const Model&, const Eigen::VectorXd&, Kinematics<double>&,
                      Articulated<double>&) = nullptr;
  AbaWorkspace aba_;
  ImpulseWorkspace abi_;
  std::vector<ImpulseWorkspace> column_ws_;  // test impulses: one workspace per thread
  std::vector<Eigen::VectorXd> column_scratch_;
  ContactInertiaWorkspace<double> cia_;
  Eigen::VectorXd q_, v_, tau_, qdd_, vstar_, dv_, scratch_, lambda_, warm_beta_;
  Eigen::MatrixXd J_, X_, Xt_;
  ContactProblem prob_;  // A is built in place here
  ContactSolution sol_;  // the last solve (its storage kept)
  // The generator weights of the last kWarmHistory steps, a column per step and contact point
  // (column slot·P + point, slot warm_head_ the last step's), and per point in how many of
  // those steps, back from the last, it was in contact.
  static constexpr int kWarmHistory = 5;
  Eigen::MatrixXd warm_;
  int warm_head_ = 0;
  std::vector<int> warm_steps_;
  std::vector<int> active_;
  // This step's contact directions (3 per active contact): body, unit wrench, velocity; the
  // normal bias per contact. Members so that their capacity is kept from step to step.
  std::vector<int> bodies_;
  std::vector<Vec6<double>> wrenches_;
  std::vector<double> vel_, bias_;
  ContactResiduals residuals_;
  StepTimes last_, total_;
  double t_ = 0;
  int steps_ = 0;
};

}  // namespace minv::sim
