#ifdef MINV_HAVE_DART

#include "solvers/dart.hpp"

#include <dlfcn.h>

#include <stdexcept>
#include <string>
#include <vector>

#include "solvers/dart_bridge.hpp"
#include "solvers/plain_tree_model.hpp"

namespace minv {

namespace {

// The bridge module (cmake/peers/dart.cmake), loaded once per process; `error` says why not.
struct BridgeModule {
  DartBridge* (*create)() = nullptr;
  std::string error;
};

// The directory of the library this file is in (libminv_solvers), where the module is built
// and installed; empty if unknown.
std::string ownDirectory() {
  Dl_info info;
  if (dladdr(reinterpret_cast<void*>(&ownDirectory), &info) == 0 || !info.dli_fname) return {};
  const std::string path = info.dli_fname;
  const std::size_t slash = path.rfind('/');
  return slash == std::string::npos ? std::string() : path.substr(0, slash + 1);
}

const BridgeModule& bridgeModule() {
  static const BridgeModule module = [] {
    BridgeModule m;
    // RTLD_DEEPBIND: libdart, loaded with the module, binds to its own Eigen functions first.
    const int flags = RTLD_NOW | RTLD_LOCAL | RTLD_DEEPBIND;
    // Next to libminv_solvers (build tree, install), else where this build put it.
    void* handle = nullptr;
    std::vector<std::string> paths = {ownDirectory() + MINV_DART_BRIDGE_NAME};
    if (paths[0] != MINV_DART_BRIDGE_BUILD_PATH) paths.push_back(MINV_DART_BRIDGE_BUILD_PATH);
    for (const std::string& path : paths) {
      if ((handle = dlopen(path.c_str(), flags))) break;
      const char* e = dlerror();
      m.error += (m.error.empty() ? "" : "; ") + std::string(e ? e : path);
    }
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
  // rotational inertia) has a DART counterpart; only a missing bridge module stops us.
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
