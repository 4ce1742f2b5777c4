// The one check of an expected refusal: an error with the given code whose message names what
// was wrong. A gtest predicate, so a failure prints the code and the whole message.
#pragma once

#include <gtest/gtest.h>

#include <string>

#include "core/result.h"

namespace gaugeloop::testing {

template <typename T>
::testing::AssertionResult refused(const Result<T>& r, ErrorCode code, const std::string& expected) {
  if (r.ok()) return ::testing::AssertionFailure() << "read, expected a refusal containing: " << expected;
  if (r.error().code != code) {
    return ::testing::AssertionFailure() << "code " << error_code_name(r.error().code) << ": " << r.error().message;
  }
  if (r.error().message.find(expected) == std::string::npos) {
    return ::testing::AssertionFailure() << "message: " << r.error().message << "\nexpected in it: " << expected;
  }
  return ::testing::AssertionSuccess();
}

// Refused as bad input (kInvalidInput), the readers' refusal.
template <typename T>
::testing::AssertionResult refused(const Result<T>& r, const std::string& expected) {
  return refused(r, ErrorCode::kInvalidInput, expected);
}

}  // namespace gaugeloop::testing
