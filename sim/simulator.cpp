#include "sim/simulator.hpp"

#include <algorithm>
#include <chrono>
#include <stdexcept>

#include "sim/clones.hpp"
#include "solvers/abi_variants.hpp"

namespace minv::sim {

namespace {
using Clock = std::chrono::steady_clock;
// Seconds since t0, and t0 moved to now: a stage boundary. A steady-clock read takes 24 ns on the
// Zen 4 guest; reading the inner boundaries from the time-stamp counter instead (9.5 ns, the total
// from the steady clock shared out by ticks) left the S = 5 step as it was (7.58-7.67 us against
// 7.59-7.80, builds alternated, 4 rounds; again later, 7.45-7.57 against 7.49-7.57).
double since(Clock::time_point& t0) {
  const Clock::time_point t1 = Clock::now();
  const double s = std::chrono::duration<double>(t1 - t0).count();
  t0 = t1;
  return s;
}

// The contact-inertia recursion on doubles, compiled (the whole call tree inlined) for AVX-512
// and AVX2 beside the portable build and chosen at load time (GCC target_clones): its Θ(m²)
// pair blocks are products of depth 6 that want FMA and wide vectors. The same code the
// Counted scalar counts. The flattened AVX-512 clone is large (115 KB), but without `flatten`
// (the helpers then run out of line at the portable level) the S = 5 centipede's matrices stage
// took 2.82-2.91 us against 2.39-2.44 (Zen 4, builds alternated, 3 rounds). In a standalone
// probe (S = 5, each call alternated with the committed one 100 000 times), three rewrites were
// slower: rowProductFixed holding X's block in locals (+2-7 %), the pair blocks' mirror written
// by a plain loop instead of Eigen's transposed copy (+6-25 %), and a deferred block handed up
// by index instead of copied (+8-12 %). The per-call tables and the out-of-preorder tiles moved
// out of line (noinline, cold) shrank the clone to 93 KB and the probe's call by 60 ns, but left
// the matrices stage in the step as it was (2.39-2.45 us against 2.37-2.42). In the step the call
// takes 0.2 us more than when called back to back (2.35-2.39 us after a whole step, 2.13-2.17).
MINV_CLONES_FLAT void contactInertiaWide(const Model& model, const Kinematics<double>& kin,
                                         const Articulated<double>& art,
                                         const std::vector<int>& bodies,
                                         const std::vector<Vec6<double>>& wrenches,
                                         ContactInertiaWorkspace<double>& ws, MatX<double>& A,
                                         int threads) {
  contactInertia<double>(model, kin, art, bodies, wrenches, ws, A, threads);
}

}  // namespace

std::vector<std::string> simulationPaths() {
  std::vector<std::string> names = solverNames();
  names.push_back(kTestImpulsePath);
  names.push_back(kContactInertiaPath);
  return names;
}

Simulator::Simulator(const Model& model, std::vector<ContactPoint> points, SimOptions options)
    : model_(model),
      points_(std::move(points)),
      o_(std::move(options)),
      kin_(model),
      art_(model),
      aba_(model),
      abi_(model),
      cia_(model, 3 * static_cast<int>(points_.size())) {
  checkThreads(o_.threads);
  // Kinematics and articulated inertias: abi's own pass, compiled for the level abi uses
  // (solvers/abi_variants.hpp: this CPU's highest, or MINV_ISA's).
  articulate_ = abiVariant(abiLevel()).articulate;
  if (o_.path != kTestImpulsePath && o_.path != kContactInertiaPath) {
    solver_ = makeSolver(o_.path);  // throws for an unknown name
    solver_->setThreads(o_.threads);
    std::string why;
    if (!solver_->supports(model_, &why))
      throw std::invalid_argument("solver '" + o_.path + "' does not support this model: " + why);
    solver_->prepare(model_);
  }
  if (!(o_.dt > 0)) throw std::invalid_argument("the time step must be positive");
  if (o_.friction_dirs < 3) throw std::invalid_argument("friction needs at least 3 directions");
  for (const ContactPoint& p : points_)
    if (p.body < 0 || p.body >= model_.nb())
      throw std::invalid_argument("contact point on a body the model does not have");
  const int nv = model_.nv();
  q_ = model_.neutral();
  v_ = tau_ = qdd_ = vstar_ = dv_ = scratch_ = Eigen::VectorXd::Zero(nv);
  warm_.setZero(o_.friction_dirs, kWarmHistory * points_.size());
  warm_steps_.assign(points_.size(), 0);
  if (o_.path == kTestImpulsePath && o_.threads > 1) {
    column_ws_.assign(o_.threads, ImpulseWorkspace(model_));
    column_scratch_.assign(o_.threads, Eigen::VectorXd::Zero(nv));
  }
  // The per-step buffers sized (and first touched) for every point in contact, as a simulator
  // allocates its data up front: a step with all of them in contact allocates nothing.
  const int P = static_cast<int>(points_.size()), M = 3 * P;
  active_.reserve(P), bodies_.reserve(M), wrenches_.reserve(M), vel_.reserve(M), bias_.reserve(P);
  prob_.A.setZero(M, M);
  prob_.v0.setZero(M), prob_.b.setZero(P), warm_beta_.setZero(o_.friction_dirs * P);
  if (solver_) J_.setZero(nv, M), X_.setZero(nv, M), Xt_.setZero(M, nv);
}

void Simulator::setState(const Eigen::VectorXd& q, const Eigen::VectorXd& v) {
  model_.checkConfiguration(q);
  if (v.size() != model_.nv()) throw std::invalid_argument("velocity has the wrong size");
  q_ = q;
  v_ = v;
}

void Simulator::step() {
  const double h = o_.dt;
  const int k = o_.friction_dirs;
  // The controller's torques, before the clock starts (as MuJoCo's timed mj_step is given
  // them).
  tau_.setZero();
  if (controller_) controller_(t_, q_, v_, tau_);
  StepTimes st;
  Clock::time_point t0 = Clock::now();

  // dynamics: v* = v + h·ABA(q, v, τ), and the bodies' velocities V* (ABA's forward pass).
  articulate_(model_, q_, kin_, art_);
  abaStep(model_, kin_, art_, v_, tau_, o_.gravity, h, aba_, qdd_, vstar_);
  st.dynamics = since(t0);

  // collision: points below the margin that approach the plane (v*_n + b < 0: a separating
  // contact would only receive the model's spurious "push-away" impulses, see
  // sim/contact_solver.hpp); their unit wrenches (n, t1, t2), velocities and bias.
  active_.clear();
  std::vector<int>& bodies = bodies_;
  std::vector<Vec6<double>>& wrenches = wrenches_;
  std::vector<double>& bias = bias_;
  std::vector<double>& vel = vel_;
  bodies.clear(), wrenches.clear(), bias.clear(), vel.clear();
  for (int c = 0; c < static_cast<int>(points_.size()); ++c) {
    const int b = points_[c].body;
    const Pose<double>& X = kin_.X[b];
    const Eigen::Vector3d p = X.p + X.R * points_[c].point;
    const double phi = p.z();
    if (phi < o_.margin) {
      const double bc = phi >= 0 ? phi / h : o_.erp * phi / h;
      // The point's velocity u = v + ω × p (body b's V* = (ω, v) about the world origin): the
      // velocity of direction e's unit wrench (p × e, e) is Vᵀ(p × e, e) = e·u.
      const double* V = aba_.Vstar.col(b).data();
      const double u[3] = {V[3] + (V[1] * p[2] - V[2] * p[1]), V[4] + (V[2] * p[0] - V[0] * p[2]),
                           V[5] + (V[0] * p[1] - V[1] * p[0])};
      if (u[2] + bc < 0) {
        active_.push_back(c);
        // Directions z, x, y, their wrenches built in place (a Vec6 returned and copied was
        // reloaded in pairs straddling its halves, a load no store forwards).
        for (int d = 0; d < 3; ++d) {
          const int e = (d + 2) % 3;
          unitWrench(p, Eigen::Vector3d::Unit(e), wrenches.emplace_back());
          bodies.push_back(b);
          vel.push_back(u[e]);
        }
        bias.push_back(bc);
        continue;
      }
    }
    warm_steps_[c] = 0;
  }
  const int nc = static_cast<int>(active_.size()), m = 3 * nc;
  st.collision = since(t0);

  if (nc == 0) {
    lambda_.resize(0);
    prob_.A.resize(0, 0), prob_.v0.resize(0), prob_.b.resize(0), warm_beta_.resize(0);
    residuals_ = ContactResiduals{};
    v_ = vstar_;
    integrate(model_, q_, v_, h);
  } else {
    // matrices: A = Jᵀ M⁻¹ J, in place in the contact problem.
    Eigen::MatrixXd& A = prob_.A;
    A.resize(m, m);
    if (o_.path == kContactInertiaPath) {
      contactInertiaWide(model_, kin_, art_, bodies, wrenches, cia_, A, o_.threads);
    } else if (!solver_ && o_.threads > 1) {
      testImpulses(model_, kin_, art_, column_ws_, bodies, wrenches, A, column_scratch_);
    } else if (!solver_) {
      testImpulses(model_, kin_, art_, abi_, bodies, wrenches, A, scratch_);
    } else {
      solver_->configure(q_);
      J_.setZero(model_.nv(), m);
      for (int r = 0; r < m; ++r) addJacobianColumn(model_, kin_, bodies[r], wrenches[r], J_, r);
      X_.resize(model_.nv(), m);
      solver_->solve(J_, X_);
      // A = JᵀX with J's sparsity: the 3 columns of a contact live on its body's path, so
      // column r of A (= row r, A is symmetric) is Σ_{d on the path} J(d, r) Xᵀ(:, d), with
      // Xᵀ stored so that those are contiguous axpys. Θ(m² · depth), not Θ(m² · nv).
      Xt_ = X_.transpose();
      A.setZero();
#pragma omp parallel for schedule(static) num_threads(o_.threads) if (o_.threads > 1)
      for (int r = 0; r < m; ++r)
        for (int i = bodies[r]; i >= 0; i = model_.parent(i))
          for (int d = model_.vIdx(i); d < model_.vIdx(i) + model_.nvOf(i); ++d)
            A.col(r).noalias() += J_(d, r) * Xt_.col(d);
      A = (0.5 * (A + A.transpose())).eval();
    }
    st.matrices = since(t0);

    // solve: maximum dissipation, warm started by extrapolating the weights of earlier steps.
    prob_.v0 = Eigen::Map<const Eigen::VectorXd>(vel.data(), m);
    prob_.b = Eigen::Map<const Eigen::VectorXd>(bias.data(), nc);
    prob_.mu = o_.mu;
    prob_.k = k;
    warm_beta_.resize(k * nc);
    const int P = static_cast<int>(points_.size());
    // β of point a, d steps back (d = 1: the last step), in the ring of kWarmHistory steps;
    // the ring's columns d steps back found once per step (a remainder per point and history
    // step took the S = 5 solve stage from 1.21-1.23 us to 1.25).
    int back[kWarmHistory + 1];
    for (int d = 1; d <= kWarmHistory; ++d)
      back[d] = (warm_head_ - d + 1 + kWarmHistory) % kWarmHistory * P;
    auto past = [&](int a, int d) { return warm_.col(back[d] + a).data(); };
    for (int c = 0; c < nc; ++c) {
      const int a = active_[c], steps = warm_steps_[a];
      double* out = warm_beta_.data() + k * c;
      static_assert(kWarmHistory == 5, "the quadratic's weights are for five steps");
      if (steps >= kWarmHistory && k == 4) {
        // The least-squares quadratic through the last five steps, at the next.
        const double *b1 = past(a, 1), *b3 = past(a, 3), *b4 = past(a, 4), *b5 = past(a, 5);
        for (int j = 0; j < k; ++j)
          out[j] = std::max(0.0, 1.8 * b1[j] - 0.8 * b3[j] - 0.6 * b4[j] + 0.6 * b5[j]);
      } else if (steps >= 2) {
        // The line through the last two.
        const double *b1 = past(a, 1), *b2 = past(a, 2);
        for (int j = 0; j < k; ++j) out[j] = std::max(0.0, 2 * b1[j] - b2[j]);
      } else {
        for (int j = 0; j < k; ++j) out[j] = steps == 1 ? past(a, 1)[j] : 0.0;
      }
    }
    solveMaxDissipation(prob_, warm_beta_, o_.contact, sol_);
    // This step's weights into the ring (k = 4: in minimum-norm form, see sim/simulator.hpp).
    warm_head_ = (warm_head_ + 1) % kWarmHistory;
    const int head = warm_head_ * P;
    for (int c = 0; c < nc; ++c) {
      const int a = active_[c];
      const double* b = sol_.beta.data() + k * c;
      double* w = warm_.col(head + a).data();
      if (k == 4) {
        // β + t z, z = (1, −1, 1, −1) spanning W's null space, t = −βᵀz / 4 clamped to β + t z ≥ 0
        const double lo = -std::min(b[0], b[2]), hi = std::min(b[1], b[3]);
        const double t = std::clamp(-0.25 * (b[0] - b[1] + b[2] - b[3]), lo, hi);
        w[0] = b[0] + t, w[1] = b[1] - t, w[2] = b[2] + t, w[3] = b[3] - t;
      } else {
        for (int j = 0; j < k; ++j) w[j] = b[j];
      }
      warm_steps_[a] = std::min(warm_steps_[a] + 1, kWarmHistory);
    }
    lambda_ = sol_.lambda;
    residuals_ = sol_.residuals;
    st.solve = since(t0);

    // update: v⁺ = v* + M⁻¹Jλ, then q.
    if (!solver_)
      applyImpulses(model_, kin_, art_, abi_, bodies, wrenches, lambda_, dv_);
    else
      dv_.noalias() = X_ * lambda_;
    v_ = vstar_ + dv_;
    integrate(model_, q_, v_, h);
  }
  st.update = since(t0);
  t_ += h;
  ++steps_;
  last_ = st;
  total_ += st;
}

}  // namespace minv::sim
