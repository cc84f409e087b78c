#include "experiments/lib/centipede_run.hpp"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <memory>
#include <ostream>
#include <stdexcept>

#include "experiments/lib/provenance.hpp"
#include "generators/centipede.hpp"
#include "sim/gait.hpp"
#include "sim/mujoco_step.hpp"
#include "solvers/openblas.hpp"

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

// Untimed steps of a throwaway walker before a timed run (see runCentipede).
constexpr int kWarmupSteps = 3;

// --threads: at least 1, and 1 for mujoco-step.
void checkThreads(const std::string& path, int threads) {
  if (threads < 1) throw std::invalid_argument("--threads must be at least 1");
  if (path == kMujocoStepPath && threads != 1)
    throw std::invalid_argument("path mujoco-step runs MuJoCo 2.2's mj_step, which has one thread");
}

std::string fmt(const char* f, double a, double b = 0, double c = 0, double d = 0) {
  char buf[256];
  std::snprintf(buf, sizeof buf, f, a, b, c, d);
  return buf;
}

}  // namespace

CentipedeRunResult runCentipede(const CentipedeRunOptions& o, std::ostream& log, H5Writer* h5,
                                const std::string& group) {
  if (o.steps < 1) throw std::invalid_argument("--steps must be at least 1");
  if (!(o.dt > 0)) throw std::invalid_argument("--dt must be positive");
  const bool mujoco = o.solver == kMujocoStepPath;
  if (mujoco && !haveMujocoStep())
    throw std::invalid_argument("path mujoco-step needs MuJoCo, and this build has none");
  checkThreads(o.solver, o.threads);
  if (mujoco && o.friction_dirs != 4)
    throw std::invalid_argument("path mujoco-step has MuJoCo's pyramidal cone of 4 directions");
  // BLAS on one thread unless a solver path asks for more (its setThreads), as the benchmarks
  // run it: OpenBLAS's idle workers would otherwise spin beside the timed step.
  openblas_set_num_threads(1);
  CentipedeOptions co;
  co.segments = o.segments;
  co.segment_joint = segmentJointFromName(o.segment_joint);
  const Centipede c = makeCentipede(co);
  const Model& m = c.model;
  SimOptions so;
  so.dt = o.dt;
  so.mu = o.mu;
  so.friction_dirs = o.friction_dirs;
  so.path = o.solver;
  so.threads = o.threads;
  auto makeWalker = [&]() -> std::unique_ptr<Walker> {
#ifdef MINV_HAVE_MUJOCO
    if (mujoco) {
      MujocoStepOptions mo;
      mo.dt = o.dt;
      mo.gravity = so.gravity;
      mo.mu = o.mu;
      return std::make_unique<MujocoWalker>(c, mo);
    }
#endif
    return std::make_unique<OurWalker>(c, so);
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
  std::unique_ptr<Walker> sim = makeWalker();

  CentipedeRunResult r;
  r.nv = m.nv();
  r.engine = mujoco ? "mujoco" : "minv";
  Kinematics<double> kin(m);
  computeKinematics<double>(m, sim->q(), kin);
  const Eigen::Vector3d head0 = kin.X[0].p, com0 = centreOfMass(m, kin);

  const int S = o.segments, L = c.legs();
  const int every = o.frames > 0 ? std::max(1, o.steps / o.frames) : 0;
  const int F = o.frames > 0 ? o.steps / every + 1 : 0;
  Eigen::MatrixXd stepTimes(o.steps, 5), com(F, 3), seg(F, 3 * S), hips(F, 3 * L), knees(F, 3 * L),
      tipsXyz(F, 3 * L);
  Eigen::VectorXd frameTime(F), stepTotal(o.steps);
  std::vector<int> contacts(o.steps), iterations(o.steps);
  auto record = [&](int f) {
    computeKinematics<double>(m, sim->q(), kin);
    frameTime(f) = sim->time();
    com.row(f) = centreOfMass(m, kin).transpose();
    for (int s = 0; s < S; ++s) seg.row(f).segment<3>(3 * s) = kin.X[c.segment_body[s]].p;
    for (int l = 0; l < L; ++l) {
      hips.row(f).segment<3>(3 * l) = kin.X[c.upper_body[l]].p;
      const Pose<double>& X = kin.X[c.lower_body[l]];
      knees.row(f).segment<3>(3 * l) = X.p;
      tipsXyz.row(f).segment<3>(3 * l) = X.p + X.R * c.tip;
    }
  };
  if (F > 0) record(0);

  log << "# centipede: " << S << " segments (" << o.segment_joint << " segment joints), nv "
      << m.nv() << ", " << L << " legs; " << o.steps << " steps of " << o.dt << " s; path "
      << o.solver << "\n";
  log.flush();
  const auto wall0 = std::chrono::steady_clock::now();
  const int progressEvery = o.progress_lines > 0 ? std::max(1, o.steps / o.progress_lines) : 0;
  double contactSum = 0;
  for (int k = 0; k < o.steps; ++k) {
    sim->step();
    const StepTimes t = sim->lastTimes();
    stepTimes.row(k) << t.dynamics, t.collision, t.matrices, t.solve, t.update;
    stepTotal(k) = sim->lastTotal();
    r.times += t;
    r.time_total += stepTotal(k);
    contacts[k] = sim->lastContacts();
    contactSum += contacts[k];
    if (const ContactResiduals* res = sim->lastResiduals()) {
      iterations[k] = res->iterations;
      r.max_penetration = std::max(r.max_penetration, res->penetration);
      r.max_cone = std::max(r.max_cone, res->cone);
      r.max_complementarity = std::max(r.max_complementarity, res->complementarity);
      r.max_kkt = std::max(r.max_kkt, res->kkt);
      r.max_pgs_iterations = std::max(r.max_pgs_iterations, res->iterations);
      r.unconverged_steps += res->converged ? 0 : 1;
    }
    if (!sim->v().allFinite())
      throw std::runtime_error("the simulation diverged (non-finite velocity)");
    if (every > 0 && (k + 1) % every == 0) record((k + 1) / every);
    if (progressEvery > 0 && ((k + 1) % progressEvery == 0 || k + 1 == o.steps)) {
      const double wall =
          std::chrono::duration<double>(std::chrono::steady_clock::now() - wall0).count();
      log << fmt("step %6.0f", k + 1) << "/" << o.steps
          << fmt("  t=%.4f s  contacts=%2.0f  head x=%+.4f m  wall %.2f s", sim->time(),
                 contacts[k], sim->q()(0) - head0.x(), wall)
          << "\n";
      log.flush();
    }
  }
  r.mean_contacts = contactSum / o.steps;
  computeKinematics<double>(m, sim->q(), kin);
  r.head_dx = kin.X[0].p.x() - head0.x();
  r.head_dy = kin.X[0].p.y() - head0.y();
  const Eigen::Vector3d com1 = centreOfMass(m, kin);
  r.com_dx = com1.x() - com0.x();
  r.com_dy = com1.y() - com0.y();

  if (h5) {
    const std::string& g = group;
    h5->createGroup(g);
    h5->setAttribute(g, "segments", S);
    h5->setAttribute(g, "segment_joint", o.segment_joint);
    h5->setAttribute(g, "nv", m.nv());
    h5->setAttribute(g, "nq", m.nq());
    h5->setAttribute(g, "legs", L);
    h5->setAttribute(g, "steps", o.steps);
    h5->setAttribute(g, "dt", o.dt);
    h5->setAttribute(g, "solver", o.solver);
    h5->setAttribute(g, "threads", o.threads);
    h5->setAttribute(g, "mu", o.mu);
    h5->setAttribute(g, "friction_dirs", o.friction_dirs);
    h5->setAttribute(g, "warmup_steps", kWarmupSteps);
    sim->writeAttributes(*h5, g);
    h5->setAttribute(g, "time_dynamics", r.times.dynamics);
    h5->setAttribute(g, "time_collision", r.times.collision);
    h5->setAttribute(g, "time_matrices", r.times.matrices);
    h5->setAttribute(g, "time_solve", r.times.solve);
    h5->setAttribute(g, "time_update", r.times.update);
    h5->setAttribute(g, "time_total", r.time_total);
    h5->setAttribute(g, "mean_contacts", r.mean_contacts);
    if (!mujoco) {
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
    h5->writeMatrix(p + "step_times", stepTimes);
    h5->writeVector(p + "step_total", stepTotal);
    h5->writeIntVector(p + "contacts", contacts);
    if (!mujoco) h5->writeIntVector(p + "pgs_iterations", iterations);
    h5->writeVector(p + "q_final", sim->q());
    if (F > 0) {
      h5->writeVector(p + "frame_time", frameTime);
      h5->writeMatrix(p + "com", com);
      h5->writeMatrix(p + "segments", seg);
      h5->writeMatrix(p + "hips", hips);
      h5->writeMatrix(p + "knees", knees);
      h5->writeMatrix(p + "tips", tipsXyz);
    }
  }
  return r;
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
    if (s == kMujocoStepPath && !haveMujocoStep())
      throw std::invalid_argument("path mujoco-step needs MuJoCo, and this build has none");
    checkThreads(s, o.threads);  // before any point: a refused path is not a skipped point
  }
  for (int s : o.segments)
    if (s < 1) throw std::invalid_argument("--segments values must be at least 1");
  H5Writer h5 = H5Writer::append(o.out);
  writeProvenance(h5, "/");
  h5.setAttribute("/", "steps", o.steps);
  h5.setAttribute("/", "dt", o.dt);
  h5.flush();
  for (int S : o.segments)
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
      h5.createGroup("S" + std::to_string(S));
      const std::string g = h5.beginPoint(name);
      CentipedeRunResult r;
      try {
        r = runCentipede(ro, log, &h5, g);
      } catch (const std::exception& e) {
        if (solver != kMujocoStepPath) throw;
        // MuJoCo cannot load or run this size: the point says why, the sweep goes on.
        CentipedeOptions co;
        co.segments = S;
        const Centipede c = makeCentipede(co);
        h5.setAttribute(g, "segments", S);
        h5.setAttribute(g, "legs", c.legs());
        h5.setAttribute(g, "nv", c.model.nv());
        h5.setAttribute(g, "steps", o.steps);
        h5.setAttribute(g, "dt", o.dt);
        h5.setAttribute(g, "solver", solver);
        h5.setAttribute(g, "engine", "mujoco");
        h5.setAttribute(g, "status", "skipped");
        h5.setAttribute(g, "skipped", e.what());
        h5.endPoint(name);
        log << "# " << name << " skipped: " << e.what() << "\n";
        log.flush();
        continue;
      }
      h5.setAttribute(g, "status", "ok");
      h5.endPoint(name);
      char buf[320];
      std::snprintf(buf, sizeof buf,
                    "S=%-4d nv=%-5d %-13s total %8.3f s  dyn %7.3f  coll %6.3f  matrices %8.3f  "
                    "solve %7.3f  update %6.3f  (%.3f ms/step, %.1f contacts)\n",
                    S, r.nv, sweepPointPath(solver, o.threads).c_str(), r.time_total,
                    r.times.dynamics, r.times.collision, r.times.matrices, r.times.solve,
                    r.times.update, 1e3 * r.time_total / o.steps, r.mean_contacts);
      log << buf;
      log.flush();
    }
  log << "wrote " << o.out << "\n";
}

}  // namespace minv::sim
