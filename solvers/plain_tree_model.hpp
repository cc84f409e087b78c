// The plain copy of a Model (solvers/plain_tree.hpp), made on minv's side of a peer bridge.
#pragma once

#include <vector>

#include "core/model.hpp"
#include "solvers/plain_tree.hpp"

namespace minv {

// One PlainBody per body of `model`, in the same order.
std::vector<PlainBody> plainTree(const Model& model);

}  // namespace minv
