// Modules that libminv_solvers loads at run time (dlopen): abi's per-ISA kernels and the DART
// bridge. A module is found next to libminv_solvers (the build tree, an install), else at the
// path this build put it.
#pragma once

#include <string>

namespace minv {

// dlopen(flags) of `file_name` next to this library, else of `build_path`; nullptr with the
// loader's messages in *error if neither loads.
void* openModule(const std::string& file_name, const std::string& build_path, int flags,
                 std::string* error);

}  // namespace minv
