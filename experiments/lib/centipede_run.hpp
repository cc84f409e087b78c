// The centipede runs behind `minv simulate` (experiments/minv.cpp):
//
//   runCentipede()       one walk: S segments standing on the plane (all tips touching), the
//                        travelling-wave gait (sim/gait.hpp), `steps` steps of size dt through
//                        one contact-space path, or with path "mujoco-step" through MuJoCo's
//                        own mj_step (sim/mujoco_step.hpp: the same centipede, gait torques
//                        and start); progress lines on `log`; optionally written to an HDF5
//                        group (layout below).
//   runCentipedeSweep()  the Figure 4 sweep: every (S, path) pair, one point per pair written
//                        to FILE.h5 in append mode as it finishes (H5Writer::beginPoint/
//                        endPoint: a killed sweep resumes, finished points are skipped). A
//                        mujoco-step point that MuJoCo cannot load or run holds only segments,
//                        legs, nv, steps, dt, solver, engine, status "skipped" and skipped (the
//                        reason), and the sweep goes on; every other point has status "ok".
//
// Layout of a run (attributes of its group): segments, segment_joint, nv, nq, legs, steps, dt,
// solver, threads, mu, friction_dirs, engine ("minv" or "mujoco"), time_<component> (seconds summed
// over the run; components dynamics, collision, matrices, solve, update; all 0 for
// mujoco-step), time_total (their sum; for mujoco-step the mj_step calls alone, timed with
// steady_clock), mean_contacts (for mujoco-step MuJoCo's ncon), max_penetration, max_cone,
// max_complementarity, max_kkt, max_pgs_iterations, unconverged_steps (not for mujoco-step),
// head_dx, head_dy, com_dx, com_dy (metres; x is the initial heading); mujoco-step also
// engine_version (mj_version()), tip_radius, nconmax, njmax and overflows (contacts or
// constraint rows MuJoCo dropped: 0). Datasets: step_times (steps × 5, the components in that
// order), step_total (steps), contacts (steps), pgs_iterations (steps; not for mujoco-step),
// q_final (nq), and with frames > 0: frame_time (F), com (F × 3), segments (F × 3S: segment
// origins), hips, knees, tips (F × 3L; L = 2S legs, left first).
#pragma once

#include <iosfwd>
#include <string>
#include <vector>

#include "experiments/lib/h5writer.hpp"
#include "sim/simulator.hpp"

namespace minv::sim {

struct CentipedeRunOptions {
  int segments = 20;
  std::string segment_joint = "yaw";
  int steps = 3000;
  double dt = 1e-3;
  std::string solver = "abi";
  double mu = 0.8;
  int friction_dirs = 4;
  int threads = 1;          // SimOptions::threads (mujoco-step: 1 only)
  int frames = 0;           // trajectory frames to record (0: none)
  int progress_lines = 10;  // progress lines on the log (0: none)
};

struct CentipedeRunResult {
  int nv = 0;
  std::string engine;     // "minv" (our Simulator) or "mujoco" (mujoco-step)
  StepTimes times;        // the components (all 0 for mujoco-step)
  double time_total = 0;  // seconds: the components' sum, or MuJoCo's mj_step
  double head_dx = 0, head_dy = 0, com_dx = 0, com_dy = 0, mean_contacts = 0;
  double max_penetration = 0, max_cone = 0, max_complementarity = 0, max_kkt = 0;
  int max_pgs_iterations = 0, unconverged_steps = 0;
};

// Throws std::invalid_argument for bad options (segments < 1, steps < 1, dt ≤ 0, unknown
// solver) before any step.
CentipedeRunResult runCentipede(const CentipedeRunOptions& options, std::ostream& log,
                                H5Writer* h5 = nullptr, const std::string& group = "/");

struct CentipedeSweepOptions {
  std::vector<int> segments{5, 10, 20, 40};
  std::vector<std::string> solvers{"abi", "lapack", "ltdl", kTestImpulsePath, kContactInertiaPath};
  int steps = 100;
  double dt = 1e-5;
  int threads = 1;
  std::string out;
};

// A sweep point's path name: the solver, with "@<threads>" when it ran on more than one.
std::string sweepPointPath(const std::string& solver, int threads);

// Points are groups "S<segments>/<solver>" (on one thread) or "S<segments>/<solver>@<threads>";
// the root holds the provenance and the options.
void runCentipedeSweep(const CentipedeSweepOptions& options, std::ostream& log);

}  // namespace minv::sim
