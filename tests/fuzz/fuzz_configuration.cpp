// libFuzzer target: readConfiguration (text) and Model::checkConfiguration (bytes as doubles)
// on a fixed five-body model with every joint type.
// Contract: tests/fuzz/contracts.hpp (checkConfigurationInput); a violation aborts with its
// message.
#include <cstddef>
#include <cstdint>
#include <string_view>

#include "tests/fuzz/contracts.hpp"

// One input.
extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  minv::fuzz::abortOnViolation(minv::fuzz::checkConfigurationInput(
      std::string_view(reinterpret_cast<const char*>(data), size)));
  return 0;
}
