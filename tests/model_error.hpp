// Checking the message of a ModelError (bad models, bad files) in tests.
#pragma once

#include <gtest/gtest.h>

#include <string>

#include "core/model.hpp"

namespace minv::test {

// The message of the ModelError that f throws ("" if none).
template <class F>
std::string errorOf(F f) {
  try {
    f();
  } catch (const ModelError& e) {
    return e.what();
  }
  return "";
}

#define EXPECT_ERROR(expr, text)                                                  \
  do {                                                                            \
    const std::string msg_ = ::minv::test::errorOf([&] { (void)(expr); });        \
    EXPECT_NE(msg_.find(text), std::string::npos) << "message: '" << msg_ << "'"; \
  } while (0)

}  // namespace minv::test
