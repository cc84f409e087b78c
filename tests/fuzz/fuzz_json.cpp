// libFuzzer target: readJson on arbitrary bytes (the JSON model reader).
// Contract: tests/fuzz/contracts.hpp (checkJsonInput); a violation aborts with its message.
#include <cstddef>
#include <cstdint>
#include <string_view>

#include "tests/fuzz/contracts.hpp"

// One input.
extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  minv::fuzz::abortOnViolation(
      minv::fuzz::checkJsonInput(std::string_view(reinterpret_cast<const char*>(data), size)));
  return 0;
}
