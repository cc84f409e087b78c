#include "solvers/plain_tree_model.hpp"

namespace minv {

std::vector<PlainBody> plainTree(const Model& model) {
  std::vector<PlainBody> out(model.nb());
  for (int i = 0; i < model.nb(); ++i) {
    const Joint& j = model.joint(i);
    const Body& b = model.body(i);
    PlainBody& p = out[i];
    p.name = b.name;
    p.joint_name = j.name;
    p.parent = model.parent(i);
    p.mass = b.mass;
    p.joint = static_cast<PlainJoint>(static_cast<int>(j.type));
    for (int r = 0; r < 3; ++r) {
      p.axis[r] = j.axis(r);
      p.placement_p[r] = j.placement.p(r);
      p.com[r] = b.com(r);
      for (int c = 0; c < 3; ++c) {
        p.placement_R[r + 3 * c] = j.placement.R(r, c);
        p.inertia[r + 3 * c] = b.inertia(r, c);
      }
    }
    p.q_index = model.qIdx(i);
    p.v_index = model.vIdx(i);
  }
  return out;
}

}  // namespace minv
