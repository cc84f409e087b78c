// The accuracy experiment (a figure the paper does not have): for every registered solver, on
// serial and branched trees (fixed base), vs n:
//   residual          ‖M·X − I‖_F / (‖M‖_F ‖X‖_F)   (LAPACK dpot03's normalisation: a
//                     backward-stable method gives a few n·ε whatever cond(M) is)
//   residual_identity ‖M·X − I‖_F / √n              (grows with cond(M))
//   error             ‖X − X_ref‖_F / ‖X_ref‖_F     forward error against a long-double
//                     reference
// where M is the double-precision CRBA matrix at q and X the solver's M⁻¹ (configure(q) +
// inverse(), so the forward error includes the rounding of each method's own front end).
// M·X is formed in double (Eigen GEMM).
// Reference: X_ref = M⁻¹ by the impulse sweeps of Algorithms 1/2 in long double (x87, 64-bit
// mantissa, u = 2⁻⁶⁴): core/impulse_sweeps.hpp's plain referenceInverse (every column's whole
// backward and forward sweep), on the same templated kinematics and articulated inertias
// (core/kinematics.hpp, core/articulated.hpp) from the same q. These sweeps never form M, so
// their error does not grow as cond₂(M)·u: the reference is three orders more accurate than
// long-double CRBA + Cholesky at n = 2048, whose error (about cond₂(M)·u/40 there) bounded the
// best solvers' errors while it was the reference.
//   Check: X_chol = long-double CRBA + Eigen::LLT, an independent method; the sweep stops with
//   an error where ‖X_chol − X_ref‖_F/‖X_ref‖_F > 16·cond₂(M)·u (X_chol's error is about
//   cond₂(M)·u at most), and records the difference.
//   Estimate of X_ref's own error: the same sweeps in double, their error against X_ref scaled
//   by the ratio of the unit roundoffs, 2⁻¹¹ (the sweeps' rounding errors scale with u).
// cond₂(M) = λ_max(M) · λ_max(X_ref), each by 300 power iterations (a slight underestimate).
//
// File (HDF5, append mode, resumable): per (topology, n) a group "problems/<topology>.n<N>"
// (attributes topology, n, nv, cond, reference_seconds, reference_error_estimate,
// reference_cholesky_difference; dataset parent) and per solver a point
// "points/<topology>.n<N>.<solver>" (attributes solver, topology, n, nv, residual,
// residual_identity, error, cond, reference_error_estimate, status, skipped when skipped by the
// skip table in timing.hpp, family "accuracy"). Root: the sweep and provenance.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <ostream>
#include <string>
#include <vector>

#include "core/model.hpp"

namespace minv {

// The sweep's reference for one tree at q (see above).
struct AccuracyReference {
  Eigen::MatrixXd M;  // double CRBA: the M the solvers' residuals are taken with
  Eigen::Matrix<long double, Eigen::Dynamic, Eigen::Dynamic> Xref;  // M⁻¹, long-double sweeps
  double cond = 0;                                                  // cond₂(M)
  double cholesky = 0;  // ‖X_chol − X_ref‖_F/‖X_ref‖_F
  double estimate = 0;  // X_ref's own error, estimated
};

// Throws std::runtime_error where the check fails (or the long-double Cholesky does).
AccuracyReference accuracyReference(const Model& model, const Eigen::VectorXd& q);

struct AccuracySweep {
  std::string mode = "quick";  // quick | full | tiny (skip caps as in timing.hpp)
  std::vector<int> n;
  std::vector<std::string> topologies = {"serial", "branched"};
  std::uint64_t seed = 1;
};

// quick: n = 16, 64, 256, 1024, 2048; full: powers of two 16 … 4096; tiny: 8, 16.
AccuracySweep accuracySweep(const std::string& mode);

// Runs the sweep into `path` (resumable), one log line per point.
void runAccuracySweep(const AccuracySweep& sweep, const std::string& path, std::ostream& log);

}  // namespace minv
