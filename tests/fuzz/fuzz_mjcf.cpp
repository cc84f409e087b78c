// libFuzzer target: MJCF through MuJoCo's parser from its virtual file system (compileMjcf,
// no file written), then modelFromMujoco with floating_base false and true.
// Contract: tests/fuzz/contracts.hpp (checkMjcfInput); a violation aborts with its message.
#include <cstddef>
#include <cstdint>
#include <string_view>

#include "tests/fuzz/contracts.hpp"

// MuJoCo's warnings go nowhere (minv prints them to stderr, once per input otherwise).
extern "C" int LLVMFuzzerInitialize(int*, char***) {
  minv::installMujocoHandlers();
  mju_user_warning = [](const char*) {};
  return 0;
}

// One input.
extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  minv::fuzz::abortOnViolation(
      minv::fuzz::checkMjcfInput(std::string_view(reinterpret_cast<const char*>(data), size)));
  return 0;
}
