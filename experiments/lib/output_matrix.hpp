// The matrices the harness writes solvers' results into (M⁻¹, M⁻¹R), allocated alike for every
// solver and for the store floor, so that a timing compares kernels, not page tables.
#pragma once

#include <Eigen/Core>

namespace minv {

// A zeroed rows × cols matrix on transparent huge pages where the kernel allows them (THP mode
// "always" or "madvise"; elsewhere plain pages): the whole 2 MiB pages inside it are asked for
// before this function touches them, so that writing n² doubles column by column does not miss
// the TLB every few columns, and every page is resident before any timing starts. Only memory
// not yet touched can come as huge pages: a matrix larger than glibc's mmap threshold (which
// rises to the largest block freed, at most 32 MiB) is always a fresh mapping, n = 2048's M⁻¹
// and larger; a smaller one may reuse heap memory already on small pages (its TLB reach then
// matters less: Zen 5's second-level TLB covers 12 MiB of small pages).
Eigen::MatrixXd outputMatrix(int rows, int cols);

}  // namespace minv
