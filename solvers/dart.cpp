#ifdef MINV_HAVE_DART

#include "solvers/dart.hpp"

#include <dlfcn.h>

#include <stdexcept>
#include <string>

#include "solvers/dart_bridge.hpp"
#include "solvers/module.hpp"
#include "solvers/plain_tree_model.hpp"

namespace minv {

namespace {

// The bridge module (cmake/peers/dart.cmake), loaded once per process; `error` says why not.
struct BridgeModule {
  DartBridge* (*create)() = nullptr;
  std::string error;
};

const BridgeModule& bridgeModule() {
  static const BridgeModule module = [] {
    BridgeModule m;
    // RTLD_DEEPBIND: libdart, loaded with the module, binds to its own Eigen functions first.
    const int flags = RTLD_NOW | RTLD_LOCAL | RTLD_DEEPBIND;
    void* handle = openModule(MINV_DART_BRIDGE_NAME, MINV_DART_BRIDGE_BUILD_PATH, flags, &m.error);
    if (!handle) {
      m.error = "dart: cannot load the DART bridge module: " + m.error;
      return m;
    }
    m.create = reinterpret_cast<DartBridge* (*)()>(dlsym(handle, kDartBridgeCreate));
    m.error = m.create ? "" : "dart: the bridge module has no " + std::string(kDartBridgeCreate);
    return m;
  }();
  return module;
}

}  // namespace

struct DartSolver::Impl {
  const Model* model = nullptr;
  std::unique_ptr<DartBridge> bridge;
  // DART's M⁻¹ (nv×nv) as a map, once per configure(): DART's DOFs and velocities are ours.
  Eigen::Map<const Eigen::MatrixXd> inverse() {
    const int nv = model->nv();
    return Eigen::Map<const Eigen::MatrixXd>(bridge->inverse(), nv, nv);
  }
};

DartSolver::DartSolver() : impl_(std::make_unique<Impl>()) {}
DartSolver::~DartSolver() = default;

bool DartSolver::supports(const Model& model, std::string* why) const {
  // Every joint type and every inertia a Model accepts (positive mass, positive definite
  // rotational inertia, both at most 1e30) has a DART counterpart. But DART inverts a ball
  // joint's 3×3 articulated inertia through its determinant, the cube of the masses' scale:
  // below 1e-100 it underflows, and DART aborts the process on the NaN.
  bool ball = false;
  for (int i = 0; i < model.nb(); ++i) ball = ball || model.joint(i).type == JointType::Spherical;
  for (int k = 0; ball && k < model.nb(); ++k) {
    const Body& b = model.body(k);
    if (b.mass < 1e-100 || smallestPrincipalMoment(b) < 1e-100) {
      if (why)
        *why = "dart: body " + std::to_string(k) +
               " has a mass or principal moment of inertia below 1e-100, where DART's inverse of "
               "a ball joint's 3x3 articulated inertia underflows (DART aborts on the NaN)";
      return false;
    }
  }
  const BridgeModule& module = bridgeModule();
  if (module.create) return true;
  if (why) *why = module.error;
  return false;
}

void DartSolver::prepare(const Model& model) {
  Impl& s = *impl_;
  const BridgeModule& module = bridgeModule();
  if (!module.create) throw std::runtime_error(module.error);
  s.model = &model;
  s.bridge.reset(module.create());
  // The plain copy crosses to the bridge, which builds and checks the Skeleton.
  s.bridge->build(plainTree(model));
  if (s.bridge->nv() != model.nv())
    throw std::runtime_error("dart: the Skeleton has " + std::to_string(s.bridge->nv()) +
                             " DOFs, ours " + std::to_string(model.nv()));
}

void DartSolver::configure(const Eigen::VectorXd& q) {
  impl_->bridge->configure(q.data());
}

void DartSolver::inverse(MatrixOut Minv) {
  Minv = impl_->inverse();
}

void DartSolver::solve(MatrixIn R, MatrixOut X) {
  X.noalias() = impl_->inverse() * R;
}

Eigen::MatrixXd DartSolver::massMatrix() const {
  const int nv = impl_->model->nv();
  Eigen::MatrixXd M(nv, nv);
  impl_->bridge->massMatrix(M.data());
  return M;
}

Eigen::MatrixXd DartSolver::relativeJacobian(int body) const {
  Eigen::MatrixXd J(6, impl_->model->nvOf(body));
  impl_->bridge->relativeJacobian(body, J.data());
  return J;
}

}  // namespace minv

#endif  // MINV_HAVE_DART
