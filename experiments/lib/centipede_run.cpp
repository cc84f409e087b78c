#include "experiments/lib/centipede_run.hpp"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <ostream>
#include <stdexcept>

#include "experiments/lib/provenance.hpp"
#include "generators/centipede.hpp"
#include "sim/gait.hpp"

namespace minv::sim {

namespace {

Eigen::Vector3d centreOfMass(const Model& m, const Kinematics<double>& kin) {
  Eigen::Vector3d c = Eigen::Vector3d::Zero();
  double mass = 0;
  for (int i = 0; i < m.nb(); ++i) {
    c += m.body(i).mass * (kin.X[i].p + kin.X[i].R * m.body(i).com);
    mass += m.body(i).mass;
  }
  return c / mass;
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
  CentipedeOptions co;
  co.segments = o.segments;
  co.segment_joint = segmentJointFromName(o.segment_joint);
  const Centipede c = makeCentipede(co);
  const Model& m = c.model;
  std::vector<ContactPoint> tips;
  for (int l = 0; l < c.legs(); ++l) tips.push_back({c.lower_body[l], c.tip});
  SimOptions so;
  so.dt = o.dt;
  so.mu = o.mu;
  so.friction_dirs = o.friction_dirs;
  so.path = o.solver;
  Simulator sim(m, tips, so);
  CentipedeGait gait(c);
  sim.setController([&](double t, const Eigen::VectorXd& q, const Eigen::VectorXd& v,
                        Eigen::VectorXd& tau) { gait(t, q, v, tau); });
  sim.setState(centipedeStanding(c), Eigen::VectorXd::Zero(m.nv()));

  CentipedeRunResult r;
  r.nv = m.nv();
  Kinematics<double> kin(m);
  computeKinematics<double>(m, sim.q(), kin);
  const Eigen::Vector3d head0 = kin.X[0].p, com0 = centreOfMass(m, kin);

  const int S = o.segments, L = c.legs();
  const int every = o.frames > 0 ? std::max(1, o.steps / o.frames) : 0;
  const int F = o.frames > 0 ? o.steps / every + 1 : 0;
  Eigen::MatrixXd stepTimes(o.steps, 5), com(F, 3), seg(F, 3 * S), hips(F, 3 * L), knees(F, 3 * L),
      tipsXyz(F, 3 * L);
  Eigen::VectorXd frameTime(F);
  std::vector<int> contacts(o.steps), iterations(o.steps);
  auto record = [&](int f) {
    computeKinematics<double>(m, sim.q(), kin);
    frameTime(f) = sim.time();
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
    sim.step();
    const StepTimes& t = sim.lastTimes();
    stepTimes.row(k) << t.dynamics, t.collision, t.matrices, t.solve, t.update;
    contacts[k] = sim.lastContacts();
    contactSum += contacts[k];
    const ContactResiduals& res = sim.lastResiduals();
    iterations[k] = res.iterations;
    r.max_penetration = std::max(r.max_penetration, res.penetration);
    r.max_cone = std::max(r.max_cone, res.cone);
    r.max_complementarity = std::max(r.max_complementarity, res.complementarity);
    r.max_kkt = std::max(r.max_kkt, res.kkt);
    r.max_pgs_iterations = std::max(r.max_pgs_iterations, res.iterations);
    r.unconverged_steps += res.converged ? 0 : 1;
    if (!sim.v().allFinite())
      throw std::runtime_error("the simulation diverged (non-finite velocity)");
    if (every > 0 && (k + 1) % every == 0) record((k + 1) / every);
    if (progressEvery > 0 && ((k + 1) % progressEvery == 0 || k + 1 == o.steps)) {
      const double wall =
          std::chrono::duration<double>(std::chrono::steady_clock::now() - wall0).count();
      log << fmt("step %6.0f", k + 1) << "/" << o.steps
          << fmt("  t=%.4f s  contacts=%2.0f  head x=%+.4f m  wall %.2f s", sim.time(), contacts[k],
                 sim.q()(0) - head0.x(), wall)
          << "\n";
      log.flush();
    }
  }
  r.times = sim.totalTimes();
  r.mean_contacts = contactSum / o.steps;
  computeKinematics<double>(m, sim.q(), kin);
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
    h5->setAttribute(g, "mu", o.mu);
    h5->setAttribute(g, "friction_dirs", o.friction_dirs);
    h5->setAttribute(g, "time_dynamics", r.times.dynamics);
    h5->setAttribute(g, "time_collision", r.times.collision);
    h5->setAttribute(g, "time_matrices", r.times.matrices);
    h5->setAttribute(g, "time_solve", r.times.solve);
    h5->setAttribute(g, "time_update", r.times.update);
    h5->setAttribute(g, "time_total", r.times.total());
    h5->setAttribute(g, "mean_contacts", r.mean_contacts);
    h5->setAttribute(g, "max_penetration", r.max_penetration);
    h5->setAttribute(g, "max_cone", r.max_cone);
    h5->setAttribute(g, "max_complementarity", r.max_complementarity);
    h5->setAttribute(g, "max_kkt", r.max_kkt);
    h5->setAttribute(g, "max_pgs_iterations", r.max_pgs_iterations);
    h5->setAttribute(g, "unconverged_steps", r.unconverged_steps);
    h5->setAttribute(g, "head_dx", r.head_dx);
    h5->setAttribute(g, "head_dy", r.head_dy);
    h5->setAttribute(g, "com_dx", r.com_dx);
    h5->setAttribute(g, "com_dy", r.com_dy);
    const std::string p = g == "/" ? "" : g + "/";
    h5->writeMatrix(p + "step_times", stepTimes);
    h5->writeIntVector(p + "contacts", contacts);
    h5->writeIntVector(p + "pgs_iterations", iterations);
    h5->writeVector(p + "q_final", sim.q());
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

void runCentipedeSweep(const CentipedeSweepOptions& o, std::ostream& log) {
  if (o.segments.empty() || o.solvers.empty())
    throw std::invalid_argument("the sweep needs segments and solvers");
  const std::vector<std::string> known = simulationPaths();
  for (const std::string& s : o.solvers)
    if (std::find(known.begin(), known.end(), s) == known.end())
      throw std::invalid_argument("unknown solver '" + s + "'");
  for (int s : o.segments)
    if (s < 1) throw std::invalid_argument("--segments values must be at least 1");
  H5Writer h5 = H5Writer::append(o.out);
  writeProvenance(h5, "/");
  h5.setAttribute("/", "steps", o.steps);
  h5.setAttribute("/", "dt", o.dt);
  h5.flush();
  for (int S : o.segments)
    for (const std::string& solver : o.solvers) {
      const std::string name = "S" + std::to_string(S) + "/" + solver;
      if (h5.hasGroup(name)) {
        log << "# " << name << ": done already, skipped\n";
        continue;
      }
      CentipedeRunOptions ro;
      ro.segments = S;
      ro.steps = o.steps;
      ro.dt = o.dt;
      ro.solver = solver;
      ro.progress_lines = 2;
      h5.createGroup("S" + std::to_string(S));
      const std::string g = h5.beginPoint(name);
      const CentipedeRunResult r = runCentipede(ro, log, &h5, g);
      h5.endPoint(name);
      char buf[320];
      std::snprintf(buf, sizeof buf,
                    "S=%-4d nv=%-5d %-13s total %8.3f s  dyn %7.3f  coll %6.3f  matrices %8.3f  "
                    "solve %7.3f  update %6.3f\n",
                    S, r.nv, solver.c_str(), r.times.total(), r.times.dynamics, r.times.collision,
                    r.times.matrices, r.times.solve, r.times.update);
      log << buf;
      log.flush();
    }
  log << "wrote " << o.out << "\n";
}

}  // namespace minv::sim
