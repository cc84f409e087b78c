// The accuracy experiment (a figure the paper does not have): for every registered solver, on
// serial and branched trees (fixed base), vs n:
//   residual          ‖M·X − I‖_F / (‖M‖_F ‖X‖_F)   (LAPACK dpot03's normalisation: a
//                     backward-stable method gives a few n·ε whatever cond(M) is)
//   residual_identity ‖M·X − I‖_F / √n              (grows with cond(M))
//   error             ‖X − X_ref‖_F / ‖X_ref‖_F     forward error against a long-double
//                     reference
// where M is the double-precision CRBA matrix at q and X the solver's M⁻¹ (configure(q) +
// inverse(), so the forward error includes the rounding of each method's own front end).
// Reference: M formed in long double (x87, 64-bit mantissa) by the same templated kinematics
// and CRBA (core/kinematics.hpp, core/crba.hpp) from the same q, then Eigen::LLT in long double
// and X_ref = LLT.solve(I) in long double. M·X is formed in double (Eigen GEMM).
// cond₂(M) = λ_max(M) · λ_max(X_ref), each by 300 power iterations (a slight underestimate).
//
// File (HDF5, append mode, resumable): per (topology, n) a group "problems/<topology>.n<N>"
// (attributes topology, n, nv, cond, ref_precision; dataset parent) and per solver a point
// "points/<topology>.n<N>.<solver>" (attributes solver, topology, n, nv, residual,
// residual_identity, error, cond, status, skipped when skipped by the skip table in
// timing.hpp, family "accuracy"). Root: the sweep and provenance.
#pragma once

#include <cstdint>
#include <ostream>
#include <string>
#include <vector>

namespace minv {

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
