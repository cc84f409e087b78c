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
// backward and forward sweep), on articulated inertias taken about each joint's origin with
// the projector form of the downdate (core/articulated_joint.hpp; not abi's world-frame pass,
// whose rounding errors on long chains are hundreds of times larger), from the same templated
// kinematics (core/kinematics.hpp) at the same q, every derived constant in long double. These
// sweeps never form M, so their error does not grow as cond₂(M)·u as long-double CRBA +
// Cholesky's does (5·10⁻¹² at n = 2048 serial; it was the reference before 2026-12-07 and
// bounded the best solvers' errors at large n). Each tree's reference is checked:
//   - precision: ‖M X_ref − I‖_F/(‖M‖_F ‖X_ref‖_F) ≤ 16u with M by long-double CRBA, an
//     independent algorithm (the world-frame sweeps in double leave 18u and more);
//   - agreement: X_chol = long-double CRBA + Eigen::LLT differs from X_ref by at most
//     16·cond₂(M)·u (X_chol's own error; this catches gross errors only);
// and its own forward error estimated as the same pipeline's error in double scaled by the
// ratio of the unit roundoffs, 2⁻¹¹: an estimate that assumes errors linear in u, and that
// misses any error the two share (the model's data are doubles, exact in both).
// cond₂(M) = λ_max(M) · λ_max(X_ref), each by 300 power iterations (a slight underestimate).
//
// File (HDF5, append mode, resumable): per (topology, n) a group "problems/<topology>.n<N>"
// (attributes topology, n, nv, cond, reference_seconds, reference_error_estimate,
// reference_cholesky_difference, reference_residual; dataset parent) and per solver a point
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
  double residual = 0;  // ‖M X_ref − I‖_F/(‖M‖_F ‖X_ref‖_F), M by long-double CRBA
};

// Throws std::runtime_error where a check fails (or the long-double Cholesky does).
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
