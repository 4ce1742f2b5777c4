// The one entry guard of the product's threads: an escaping exception is told, not fatal.
#include "core/guarded_thread.h"

#include <gtest/gtest.h>

#include <stdexcept>
#include <string>

namespace gaugeloop {
namespace {

TEST(GuardedThread, ABodyThatReturnsIsNotAFault) {
  bool ran = false;
  bool told = false;
  EXPECT_TRUE(run_guarded(
      "worker", [&] { ran = true; }, [&](std::string_view, std::string_view) { told = true; }));
  EXPECT_TRUE(ran);
  EXPECT_FALSE(told);
}

TEST(GuardedThread, AnExceptionIsToldWithTheThreadsName) {
  std::string name;
  std::string what;
  const bool returned = run_guarded(
      "PLC trigger", [] { throw std::runtime_error("register 7 out of range"); },
      [&](std::string_view n, std::string_view w) {
        name = n;
        what = w;
      });
  EXPECT_FALSE(returned);
  EXPECT_EQ(name, "PLC trigger");
  EXPECT_EQ(what, "register 7 out of range");
}

TEST(GuardedThread, SomethingThatIsNotAStdExceptionIsToldToo) {
  std::string what;
  EXPECT_FALSE(run_guarded(
      "worker", [] { throw 42; }, [&](std::string_view, std::string_view w) { what = w; }));
  EXPECT_EQ(what, "unknown exception");
}

TEST(GuardedThread, AThreadEndedByAnExceptionLeavesTheProcessRunning) {
  std::string what;
  std::thread t = start_guarded_thread(
      "measuring", [] { throw std::logic_error("scripted"); }, [&](std::string_view, std::string_view w) { what = w; });
  t.join();  // without the guard, std::terminate would have ended this test binary
  EXPECT_EQ(what, "scripted");
}

}  // namespace
}  // namespace gaugeloop
