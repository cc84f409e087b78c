#include "solvers/module.hpp"

#include <dlfcn.h>

#include <vector>

namespace minv {

namespace {

// The directory of the library this file is in (libminv_solvers), with a trailing '/'; empty
// if unknown.
std::string ownDirectory() {
  Dl_info info;
  if (dladdr(reinterpret_cast<void*>(&ownDirectory), &info) == 0 || !info.dli_fname) return {};
  const std::string path = info.dli_fname;
  const std::size_t slash = path.rfind('/');
  return slash == std::string::npos ? std::string() : path.substr(0, slash + 1);
}

}  // namespace

void* openModule(const std::string& file_name, const std::string& build_path, int flags,
                 std::string* error) {
  std::vector<std::string> paths = {ownDirectory() + file_name};
  if (paths[0] != build_path) paths.push_back(build_path);
  std::string errors;
  for (const std::string& path : paths) {
    if (void* handle = dlopen(path.c_str(), flags)) return handle;
    const char* e = dlerror();
    errors += (errors.empty() ? "" : "; ") + std::string(e ? e : path);
  }
  if (error) *error = errors;
  return nullptr;
}

}  // namespace minv
