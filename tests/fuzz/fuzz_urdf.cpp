// libFuzzer target: readUrdf on arbitrary bytes, with floating_base false and true.
// Contract: tests/fuzz/contracts.hpp (checkUrdfInput); a violation aborts with its message.
#include <cstddef>
#include <cstdint>
#include <string_view>

#include "tests/fuzz/contracts.hpp"

// One input.
extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  minv::fuzz::abortOnViolation(
      minv::fuzz::checkUrdfInput(std::string_view(reinterpret_cast<const char*>(data), size)));
  return 0;
}
