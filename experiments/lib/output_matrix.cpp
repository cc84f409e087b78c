#include "experiments/lib/output_matrix.hpp"

#include <sys/mman.h>

#include <cstdint>

namespace minv {

Eigen::MatrixXd outputMatrix(int rows, int cols) {
  Eigen::MatrixXd X(rows, cols);
  // The 2 MiB pages wholly inside X's storage (none under 2 MiB, at most one under 4 MiB).
  constexpr std::uintptr_t kHuge = std::uintptr_t(2) << 20;
  const auto first = reinterpret_cast<std::uintptr_t>(X.data());
  const std::uintptr_t begin = (first + kHuge - 1) / kHuge * kHuge;
  const std::uintptr_t end = (first + sizeof(double) * X.size()) / kHuge * kHuge;
  // A refusal (THP off, an old kernel) leaves plain pages: the advice is only advice.
  if (end > begin) madvise(reinterpret_cast<void*>(begin), end - begin, MADV_HUGEPAGE);
  X.setZero();
  return X;
}

}  // namespace minv
