// Waiting for a condition in a test: the condition is polled, never a fixed sleep.
#pragma once

#include <chrono>
#include <thread>

namespace gaugeloop::testing {

// Polls `done` until it holds or `within` passes (a loaded machine is slow: be generous).
template <typename F>
bool wait_until(F&& done, std::chrono::milliseconds within = std::chrono::seconds(30)) {
  const auto deadline = std::chrono::steady_clock::now() + within;
  while (!done()) {
    if (std::chrono::steady_clock::now() > deadline) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  return true;
}

}  // namespace gaugeloop::testing
