// Measured operation counts (the paper's Tables 1-3 and Figure 1): every solver's kernels run
// on the counting scalar (core/counting.hpp), stage by stage, through the registry.
#pragma once

#include <Eigen/Core>
#include <ostream>
#include <string>
#include <vector>

#include "core/model.hpp"
#include "generators/random_tree.hpp"
#include "solvers/solver.hpp"

namespace minv {

// Per-stage counts of a registered solver for M⁻¹ (m = 0) or M⁻¹R with m columns.
// Throws std::invalid_argument for an unknown solver or one without a counter.
std::vector<StageCount> countSolver(const std::string& solver, const Model& model,
                                    const Eigen::VectorXd& q, int m = 0);

// Table 3: abi with one processor per column (and per body). Spatial axes and isolated
// inertias are those of the costliest body, articulated inertias stay sequential, impulse
// propagation and velocity updates are those of the costliest column: the critical path.
std::vector<StageCount> abiParallelCounts(const Model& model, const Eigen::VectorXd& q);

// Least-squares coefficients of y on the columns of the basis matrix B (rows = points).
Eigen::VectorXd leastSquares(const Eigen::MatrixXd& B, const Eigen::VectorXd& y);

// Σ d_k and Σ d_k² over the DOFs (d_k = depth of DOF k in the DOF tree, counting itself).
std::pair<double, double> dofDepthSums(const Model& model);

// Prints one solver's per-stage counts as an aligned table.
void printStageTable(std::ostream& os, const std::string& solver,
                     const std::vector<StageCount>& stages);

struct FlopsSweep {
  std::vector<int> n = {2, 4, 8, 16, 32, 64, 128, 256};
  std::vector<Topology> topologies = {Topology::Serial, Topology::Branched};
  std::vector<bool> floating = {false, true};
  std::uint64_t seed = 1;
};

// Sweeps n for every counted solver (and abi's parallel count) over the topologies and bases,
// and writes raw counts and fits (a·n³ + b·n² + c·n + d, and for every solver the depth-sum
// basis Σd², Σd, n, 1) to an HDF5 file at `path`.
void runFlopsSweep(const FlopsSweep& sweep, const std::string& path, std::ostream& log);

}  // namespace minv
