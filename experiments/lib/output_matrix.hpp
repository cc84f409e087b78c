// The matrices the harness writes solvers' results into (M⁻¹, M⁻¹R), allocated alike for every
// solver and for the store floor, so that a timing compares kernels, not page tables.
#pragma once

#include <Eigen/Core>

namespace minv {

// A zeroed rows × cols matrix on transparent huge pages where the kernel allows them (THP mode
// "always" or "madvise"; elsewhere plain pages): the whole 2 MiB pages inside it are asked for
// before they are first touched, so that writing n² doubles column by column does not miss the
// TLB every few columns, and every page is resident before any timing starts.
Eigen::MatrixXd outputMatrix(int rows, int cols);

}  // namespace minv
