#include "experiments/lib/centipede_run.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <memory>
#include <ostream>
#include <stdexcept>

#include "experiments/lib/h5reader.hpp"
#include "experiments/lib/provenance.hpp"
#include "generators/centipede.hpp"
#include "sim/gait.hpp"
#include "sim/mujoco_step.hpp"
#include "solvers/openblas.hpp"
#include "solvers/solver.hpp"

namespace minv::sim {

namespace {

// One way of stepping the centipede under the gait: our Simulator on one contact-space path,
// or MuJoCo's mj_step (sim/mujoco_step.hpp).
class Walker {
 public:
  virtual ~Walker() = default;
  virtual void step() = 0;
  virtual const Eigen::VectorXd& q() const = 0;
  virtual const Eigen::VectorXd& v() const = 0;
  virtual double time() const = 0;
  virtual StepTimes lastTimes() const = 0;  // the components (MuJoCo: none)
  virtual double lastTotal() const = 0;     // seconds of the whole step
  virtual int lastContacts() const = 0;
  // Our contact solve's residuals; null for MuJoCo, which reports none of them.
  virtual const ContactResiduals* lastResiduals() const = 0;
  // Engine-specific attributes of the run's group.
  virtual void writeAttributes(H5Writer& h5, const std::string& g) const = 0;
};

class OurWalker final : public Walker {
 public:
  OurWalker(const Centipede& c, const SimOptions& so) : walk_(c, so), sim_(walk_.sim()) {}
  void step() override { sim_.step(); }
  const Eigen::VectorXd& q() const override { return sim_.q(); }
  const Eigen::VectorXd& v() const override { return sim_.v(); }
  double time() const override { return sim_.time(); }
  StepTimes lastTimes() const override { return sim_.lastTimes(); }
  double lastTotal() const override { return sim_.lastTimes().total(); }
  int lastContacts() const override { return sim_.lastContacts(); }
  const ContactResiduals* lastResiduals() const override { return &sim_.lastResiduals(); }
  void writeAttributes(H5Writer& h5, const std::string& g) const override {
    h5.setAttribute(g, "engine", "minv");
  }

 private:
  WalkingCentipede walk_;
  Simulator& sim_;
};

#ifdef MINV_HAVE_MUJOCO
class MujocoWalker final : public Walker {
 public:
  MujocoWalker(const Centipede& c, const MujocoStepOptions& mo)
      : mo_(mo), mj_(c, mo), gait_(c), tau_(Eigen::VectorXd::Zero(c.model.nv())) {
    mj_.setState(centipedeStanding(c), Eigen::VectorXd::Zero(c.model.nv()));
    mj_.state(q_, v_);
  }
  // The gait's torques at the step's start state, as ours, then mj_step (timed alone).
  void step() override {
    tau_.setZero();
    gait_(mj_.time(), q_, v_, tau_);
    last_ = mj_.step(tau_);
    if (mj_.resets() > 0)
      throw std::runtime_error("mujoco-step: MuJoCo reset a diverged state (bad qacc)");
    mj_.state(q_, v_);
  }
  const Eigen::VectorXd& q() const override { return q_; }
  const Eigen::VectorXd& v() const override { return v_; }
  double time() const override { return mj_.time(); }
  StepTimes lastTimes() const override { return {}; }
  double lastTotal() const override { return last_; }
  int lastContacts() const override { return mj_.contacts(); }
  const ContactResiduals* lastResiduals() const override { return nullptr; }
  void writeAttributes(H5Writer& h5, const std::string& g) const override {
    h5.setAttribute(g, "engine", "mujoco");
    h5.setAttribute(g, "engine_version", mj_version());
    h5.setAttribute(g, "tip_radius", mo_.tip_radius);
    h5.setAttribute(g, "nconmax", mj_.model()->nconmax);
    h5.setAttribute(g, "njmax", mj_.model()->njmax);
    h5.setAttribute(g, "overflows", mj_.overflows());
  }

 private:
  MujocoStepOptions mo_;
  MujocoCentipede mj_;
  CentipedeGait gait_;
  Eigen::VectorXd q_, v_, tau_;
  double last_ = 0;
};
#endif

Eigen::Vector3d centreOfMass(const Model& m, const Kinematics<double>& kin) {
  Eigen::Vector3d c = Eigen::Vector3d::Zero();
  double mass = 0;
  for (int i = 0; i < m.nb(); ++i) {
    c += m.body(i).mass * (kin.X[i].p + kin.X[i].R * m.body(i).com);
    mass += m.body(i).mass;
  }
  return c / mass;
}

// Untimed steps of a throwaway walker before a timed run (see CentipedeRun).
constexpr int kWarmupSteps = 3;
// A sweep point's paths take turns in this many rounds of steps.
constexpr int kRounds = 20;

// --threads: 1 … kMaxThreads, and 1 for mujoco-step.
void checkPathThreads(const std::string& path, int threads) {
  checkThreads(threads, "--threads");
  if (path == kMujocoStepPath && threads != 1)
    throw std::invalid_argument("path mujoco-step runs MuJoCo 2.2's mj_step, which has one thread");
}

// --steps at least 1, --dt in (0, 1] s (a longer step of a walking robot only diverges).
void checkStepping(int steps, double dt) {
  if (steps < 1)
    throw std::invalid_argument("--steps must be at least 1, got " + std::to_string(steps));
  // (the value as it round-trips: %g printed 1.0000001 as "got 1")
  if (!(dt > 0) || !(dt <= 1))
    throw std::invalid_argument("--dt must be a step in (0, 1] s, got " + formatNumber(dt));
}

std::string fmt(const char* f, double a, double b = 0, double c = 0, double d = 0) {
  char buf[256];
  std::snprintf(buf, sizeof buf, f, a, b, c, d);
  return buf;
}

// One timed run, step by step: runCentipede() takes all its steps at once, the sweep takes the
// steps of every path of one S in turns. Construction checks the options, warms up and records
// the first frame; finish() writes the run.
class CentipedeRun {
 public:
  CentipedeRun(const CentipedeRunOptions& o, std::ostream& log);
  bool done() const { return k_ == o_.steps; }
  // Up to `count` more timed steps.
  void steps(int count);
  CentipedeRunResult finish(H5Writer* h5, const std::string& group);

 private:
  void record(int f);
  CentipedeRunOptions o_;
  std::ostream& log_;
  bool mujoco_;
  Centipede c_;
  std::unique_ptr<Walker> sim_;
  CentipedeRunResult r_;
  Kinematics<double> kin_;
  Eigen::Vector3d head0_, com0_;
  int every_, F_, progress_every_, k_ = 0;
  Eigen::MatrixXd step_times_, com_, seg_, hips_, knees_, tips_;
  Eigen::VectorXd frame_time_, step_total_;
  std::vector<int> contacts_, iterations_;
  double contact_sum_ = 0, wall_ = 0;
};

// The centipede of the options (bad ones throw before anything is built).
Centipede checkedCentipede(const CentipedeRunOptions& o) {
  checkStepping(o.steps, o.dt);
  if (o.frames < 0)
    throw std::invalid_argument("--frames must be at least 0, got " + std::to_string(o.frames));
  const bool mujoco = o.solver == kMujocoStepPath;
  if (mujoco && !haveMujocoStep())
    throw std::invalid_argument("path mujoco-step needs MuJoCo, and this build has none");
  checkPathThreads(o.solver, o.threads);
  if (mujoco && o.friction_dirs != 4)
    throw std::invalid_argument("path mujoco-step has MuJoCo's pyramidal cone of 4 directions");
  // BLAS on one thread unless a solver path asks for more (its setThreads), as the benchmarks
  // run it: OpenBLAS's idle workers would otherwise spin beside the timed step.
  openblas_set_num_threads(1);
  CentipedeOptions co;
  co.segments = o.segments;
  co.segment_joint = segmentJointFromName(o.segment_joint);
  return makeCentipede(co);
}

CentipedeRun::CentipedeRun(const CentipedeRunOptions& o, std::ostream& log)
    : o_(o),
      log_(log),
      mujoco_(o.solver == kMujocoStepPath),
      c_(checkedCentipede(o)),
      kin_(c_.model) {
  const Model& m = c_.model;
  SimOptions so;
  so.dt = o.dt;
  so.mu = o.mu;
  so.friction_dirs = o.friction_dirs;
  so.path = o.solver;
  so.threads = o.threads;
  auto makeWalker = [&]() -> std::unique_ptr<Walker> {
#ifdef MINV_HAVE_MUJOCO
    if (mujoco_) {
      MujocoStepOptions mo;
      mo.dt = o.dt;
      mo.gravity = so.gravity;
      mo.mu = o.mu;
      return std::make_unique<MujocoWalker>(c_, mo);
    }
#endif
    return std::make_unique<OurWalker>(c_, so);
  };
  // Untimed steps of a throwaway walker of the same path first (MuJoCo's too), as a benchmark
  // warms up: the process's one-time costs (lazy symbol binding, code paged in, per-thread
  // tables) are no part of a step's time. Three steps: a first step, a second (one earlier
  // solution to start from) and a later one (two) run different code. The timed walker's own
  // memory is still first touched by its timed steps.
  {
    const std::unique_ptr<Walker> w = makeWalker();
    for (int k = 0; k < kWarmupSteps; ++k) w->step();
  }
  sim_ = makeWalker();

  r_.nv = m.nv();
  r_.engine = mujoco_ ? "mujoco" : "minv";
  computeKinematics<double>(m, sim_->q(), kin_);
  head0_ = kin_.X[0].p, com0_ = centreOfMass(m, kin_);

  const int S = o.segments, L = c_.legs();
  every_ = o.frames > 0 ? std::max(1, o.steps / o.frames) : 0;
  F_ = o.frames > 0 ? o.steps / every_ + 1 : 0;
  step_times_.resize(o.steps, 5), com_.resize(F_, 3), seg_.resize(F_, 3 * S);
  hips_.resize(F_, 3 * L), knees_.resize(F_, 3 * L), tips_.resize(F_, 3 * L);
  frame_time_.resize(F_), step_total_.resize(o.steps);
  contacts_.assign(o.steps, 0), iterations_.assign(o.steps, 0);
  if (F_ > 0) record(0);
  progress_every_ = o.progress_lines > 0 ? std::max(1, o.steps / o.progress_lines) : 0;

  log_ << "# centipede: " << S << " segments (" << o.segment_joint << " segment joints), nv "
       << m.nv() << ", " << L << " legs; " << o.steps << " steps of " << o.dt << " s; path "
       << o.solver << "\n";
  log_.flush();
}

void CentipedeRun::record(int f) {
  const Model& m = c_.model;
  computeKinematics<double>(m, sim_->q(), kin_);
  frame_time_(f) = sim_->time();
  com_.row(f) = centreOfMass(m, kin_).transpose();
  for (int s = 0; s < o_.segments; ++s)
    seg_.row(f).segment<3>(3 * s) = kin_.X[c_.segment_body[s]].p;
  for (int l = 0; l < c_.legs(); ++l) {
    hips_.row(f).segment<3>(3 * l) = kin_.X[c_.upper_body[l]].p;
    const Pose<double>& X = kin_.X[c_.lower_body[l]];
    knees_.row(f).segment<3>(3 * l) = X.p;
    tips_.row(f).segment<3>(3 * l) = X.p + X.R * c_.tip;
  }
}

void CentipedeRun::steps(int count) {
  const auto wall0 = std::chrono::steady_clock::now();
  for (const int end = std::min(o_.steps, k_ + count); k_ < end; ++k_) {
    const int k = k_;
    sim_->step();
    const StepTimes t = sim_->lastTimes();
    step_times_.row(k) << t.dynamics, t.collision, t.matrices, t.solve, t.update;
    step_total_(k) = sim_->lastTotal();
    r_.times += t;
    r_.time_total += step_total_(k);
    contacts_[k] = sim_->lastContacts();
    contact_sum_ += contacts_[k];
    if (const ContactResiduals* res = sim_->lastResiduals()) {
      iterations_[k] = res->iterations;
      r_.max_penetration = std::max(r_.max_penetration, res->penetration);
      r_.max_cone = std::max(r_.max_cone, res->cone);
      r_.max_complementarity = std::max(r_.max_complementarity, res->complementarity);
      r_.max_kkt = std::max(r_.max_kkt, res->kkt);
      r_.max_pgs_iterations = std::max(r_.max_pgs_iterations, res->iterations);
      r_.unconverged_steps += res->converged ? 0 : 1;
    }
    if (!sim_->v().allFinite() || !sim_->q().allFinite())
      throw std::runtime_error("the simulation diverged (non-finite velocity or position)");
    if (every_ > 0 && (k + 1) % every_ == 0) record((k + 1) / every_);
    if (progress_every_ > 0 && ((k + 1) % progress_every_ == 0 || k + 1 == o_.steps)) {
      const double wall =
          wall_ + std::chrono::duration<double>(std::chrono::steady_clock::now() - wall0).count();
      log_ << fmt("step %6.0f", k + 1) << "/" << o_.steps
           << fmt("  t=%.4f s  contacts=%2.0f  head x=%+.4f m  wall %.2f s", sim_->time(),
                  contacts_[k], sim_->q()(0) - head0_.x(), wall)
           << "  " << sweepPointPath(o_.solver, o_.threads) << "\n";
      log_.flush();
    }
  }
  wall_ += std::chrono::duration<double>(std::chrono::steady_clock::now() - wall0).count();
}

CentipedeRunResult CentipedeRun::finish(H5Writer* h5, const std::string& group) {
  const Model& m = c_.model;
  CentipedeRunResult& r = r_;
  const int S = o_.segments, L = c_.legs();
  r.mean_contacts = contact_sum_ / k_;
  computeKinematics<double>(m, sim_->q(), kin_);
  r.head_dx = kin_.X[0].p.x() - head0_.x();
  r.head_dy = kin_.X[0].p.y() - head0_.y();
  const Eigen::Vector3d com1 = centreOfMass(m, kin_);
  r.com_dx = com1.x() - com0_.x();
  r.com_dy = com1.y() - com0_.y();
  if (h5) {
    const std::string& g = group;
    h5->createGroup(g);
    h5->setAttribute(g, "segments", S);
    h5->setAttribute(g, "segment_joint", o_.segment_joint);
    h5->setAttribute(g, "nv", m.nv());
    h5->setAttribute(g, "nq", m.nq());
    h5->setAttribute(g, "legs", L);
    h5->setAttribute(g, "steps", o_.steps);
    h5->setAttribute(g, "dt", o_.dt);
    h5->setAttribute(g, "solver", o_.solver);
    h5->setAttribute(g, "threads", o_.threads);
    h5->setAttribute(g, "mu", o_.mu);
    h5->setAttribute(g, "friction_dirs", o_.friction_dirs);
    h5->setAttribute(g, "warmup_steps", kWarmupSteps);
    sim_->writeAttributes(*h5, g);
    h5->setAttribute(g, "time_dynamics", r.times.dynamics);
    h5->setAttribute(g, "time_collision", r.times.collision);
    h5->setAttribute(g, "time_matrices", r.times.matrices);
    h5->setAttribute(g, "time_solve", r.times.solve);
    h5->setAttribute(g, "time_update", r.times.update);
    h5->setAttribute(g, "time_total", r.time_total);
    h5->setAttribute(g, "mean_contacts", r.mean_contacts);
    if (!mujoco_) {
      h5->setAttribute(g, "max_penetration", r.max_penetration);
      h5->setAttribute(g, "max_cone", r.max_cone);
      h5->setAttribute(g, "max_complementarity", r.max_complementarity);
      h5->setAttribute(g, "max_kkt", r.max_kkt);
      h5->setAttribute(g, "max_pgs_iterations", r.max_pgs_iterations);
      h5->setAttribute(g, "unconverged_steps", r.unconverged_steps);
    }
    h5->setAttribute(g, "head_dx", r.head_dx);
    h5->setAttribute(g, "head_dy", r.head_dy);
    h5->setAttribute(g, "com_dx", r.com_dx);
    h5->setAttribute(g, "com_dy", r.com_dy);
    const std::string p = g == "/" ? "" : g + "/";
    h5->writeMatrix(p + "step_times", step_times_);
    h5->writeVector(p + "step_total", step_total_);
    h5->writeIntVector(p + "contacts", contacts_);
    if (!mujoco_) h5->writeIntVector(p + "pgs_iterations", iterations_);
    h5->writeVector(p + "q_final", sim_->q());
    if (F_ > 0) {
      h5->writeVector(p + "frame_time", frame_time_);
      h5->writeMatrix(p + "com", com_);
      h5->writeMatrix(p + "segments", seg_);
      h5->writeMatrix(p + "hips", hips_);
      h5->writeMatrix(p + "knees", knees_);
      h5->writeMatrix(p + "tips", tips_);
    }
  }
  return r;
}

}  // namespace

CentipedeRunResult runCentipede(const CentipedeRunOptions& o, std::ostream& log, H5Writer* h5,
                                const std::string& group) {
  CentipedeRun run(o, log);
  run.steps(o.steps);
  return run.finish(h5, group);
}

std::string sweepPointPath(const std::string& solver, int threads) {
  return threads == 1 ? solver : solver + "@" + std::to_string(threads);
}

void runCentipedeSweep(const CentipedeSweepOptions& o, std::ostream& log) {
  if (o.segments.empty() || o.solvers.empty())
    throw std::invalid_argument("the sweep needs segments and solvers");
  std::vector<std::string> known = simulationPaths();
  known.push_back(kMujocoStepPath);
  for (const std::string& s : o.solvers) {
    if (std::find(known.begin(), known.end(), s) == known.end())
      throw std::invalid_argument("unknown solver '" + s + "'");
    if (std::count(o.solvers.begin(), o.solvers.end(), s) > 1)
      throw std::invalid_argument("--solvers names '" + s + "' twice (each path walks once)");
    if (s == kMujocoStepPath && !haveMujocoStep())
      throw std::invalid_argument("path mujoco-step needs MuJoCo, and this build has none");
    checkPathThreads(s, o.threads);  // before any point: a refused path is not a skipped point
  }
  for (int s : o.segments)
    if (s < 1) throw std::invalid_argument("--segments values must be at least 1");
  checkStepping(o.steps, o.dt);  // before the file: a refused sweep leaves none
  // A point already there must have walked as this run's will. Steps and dt are each point's
  // (scripts/reproduce adds S = 250 with fewer steps to the file of S = 5 … 40).
  std::vector<std::string> points;
  for (int S : o.segments)
    for (const std::string& solver : o.solvers)
      points.push_back("S" + std::to_string(S) + "/" + sweepPointPath(solver, o.threads));
  requireSameSettings(o.out, "--out", {{"experiment", "centipede"}, {"rounds", kRounds}});
  requireSameSettings(o.out, "--out", {{"steps", o.steps}, {"dt", o.dt}}, points);
  H5Writer h5 = H5Writer::append(o.out);
  h5.setAttribute("/", "experiment", "centipede");
  writeProvenance(h5, "/");
  // (the last run's; a file may hold points of several, each with its own steps and dt)
  h5.setAttribute("/", "steps", o.steps);
  h5.setAttribute("/", "dt", o.dt);
  h5.setAttribute("/", "rounds", kRounds);  // the paths of a point take turns (see below)
  h5.flush();
  // A MuJoCo point it cannot load or run holds why; the sweep goes on.
  auto skipped = [&](int S, const std::string& solver, const std::string& name, const char* why) {
    CentipedeOptions co;
    co.segments = S;
    const Centipede c = makeCentipede(co);
    h5.createGroup("S" + std::to_string(S));
    const std::string g = h5.beginPoint(name);
    h5.setAttribute(g, "segments", S);
    h5.setAttribute(g, "legs", c.legs());
    h5.setAttribute(g, "nv", c.model.nv());
    h5.setAttribute(g, "steps", o.steps);
    h5.setAttribute(g, "dt", o.dt);
    h5.setAttribute(g, "solver", solver);
    h5.setAttribute(g, "engine", "mujoco");
    h5.setAttribute(g, "status", "skipped");
    h5.setAttribute(g, "skipped", why);
    h5.endPoint(name);
    log << "# " << name << " skipped: " << why << "\n";
    log.flush();
  };
  for (int S : o.segments) {
    // Every path of this S not done already, built (and warmed up) first.
    std::vector<std::string> names, solvers;
    std::vector<std::unique_ptr<CentipedeRun>> runs;
    for (const std::string& solver : o.solvers) {
      const std::string name = "S" + std::to_string(S) + "/" + sweepPointPath(solver, o.threads);
      if (h5.hasGroup(name)) {
        log << "# " << name << ": done already, skipped\n";
        continue;
      }
      CentipedeRunOptions ro;
      ro.segments = S;
      ro.steps = o.steps;
      ro.dt = o.dt;
      ro.solver = solver;
      ro.threads = o.threads;
      ro.progress_lines = 2;
      try {
        runs.push_back(std::make_unique<CentipedeRun>(ro, log));
      } catch (const std::exception& e) {
        if (solver != kMujocoStepPath) throw;
        skipped(S, solver, name, e.what());
        continue;
      }
      names.push_back(name), solvers.push_back(solver);
    }
    // The paths take turns, kRounds rounds of steps/kRounds steps (at least one), so that a
    // change in the machine's speed during the sweep (a shared machine's neighbours, its clock)
    // falls on every path of the point alike and their ratios stay comparable.
    const int block = std::max(1, (o.steps + kRounds - 1) / kRounds);
    for (bool left = !runs.empty(); left;) {
      left = false;
      for (std::size_t j = 0; j < runs.size(); ++j) {
        if (!runs[j] || runs[j]->done()) continue;
        try {
          runs[j]->steps(block);
        } catch (const std::exception& e) {
          if (solvers[j] != kMujocoStepPath) throw;
          skipped(S, solvers[j], names[j], e.what());
          runs[j].reset();
          continue;
        }
        left |= !runs[j]->done();
      }
    }
    // Each finished path its point.
    for (std::size_t j = 0; j < runs.size(); ++j) {
      if (!runs[j]) continue;
      h5.createGroup("S" + std::to_string(S));
      const std::string g = h5.beginPoint(names[j]);
      const CentipedeRunResult r = runs[j]->finish(&h5, g);
      h5.setAttribute(g, "status", "ok");
      h5.endPoint(names[j]);
      runs[j].reset();
      char buf[320];
      std::snprintf(buf, sizeof buf,
                    "S=%-4d nv=%-5d %-13s total %8.3f s  dyn %7.3f  coll %6.3f  matrices %8.3f  "
                    "solve %7.3f  update %6.3f  (%.3f ms/step, %.1f contacts)\n",
                    S, r.nv, sweepPointPath(solvers[j], o.threads).c_str(), r.time_total,
                    r.times.dynamics, r.times.collision, r.times.matrices, r.times.solve,
                    r.times.update, 1e3 * r.time_total / o.steps, r.mean_contacts);
      log << buf;
      log.flush();
    }
  }
  log << "wrote " << o.out << "\n";
}

}  // namespace minv::sim
