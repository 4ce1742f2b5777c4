// Angles in the tests: the product's own constants (core/angles.h), also under testing::.
#pragma once

#include "core/angles.h"

namespace gaugeloop::testing {

using gaugeloop::kPi;
using gaugeloop::kRadPerDeg;

}  // namespace gaugeloop::testing
