// The simulator faults of up to one revolution that a run must absorb, in either mode: the
// list both modes' tests are parametrised over, and a test name for each.
#pragma once

#include <gtest/gtest.h>

#include <cctype>
#include <string>

namespace gaugeloop::testing {

inline constexpr const char* kOutagesUpToARevolution[] = {
    "refuse@1.5+1", "drop@1.5", "silent@1.5+1", "exception@1.5+1", "late@1.5:300", "frozen@1.5+1",
};

// "refuse@1.5+1" -> "refuse_1_5_1".
inline std::string fault_test_name(const ::testing::TestParamInfo<const char*>& fault) {
  std::string name;
  for (char c : std::string(fault.param)) name += std::isalnum(static_cast<unsigned char>(c)) ? c : '_';
  return name;
}

}  // namespace gaugeloop::testing
