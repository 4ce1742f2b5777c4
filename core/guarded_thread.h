// Every thread of the product starts through one guard: an exception that escapes a thread's
// body is caught, named and handed to the owner, so a fault in one worker never takes the
// process down with std::terminate (the service goes on, and says what happened).
#pragma once

#include <functional>
#include <string>
#include <string_view>
#include <thread>

namespace gaugeloop {

// Told which thread failed and what the exception said ("unknown exception" for one that is
// not a std::exception). Called on the failing thread; must not throw.
using ThreadFault = std::function<void(std::string_view thread_name, std::string_view what)>;

// Runs `body` on the calling thread. Returns true when it returned, false when it threw (after
// `on_fault` was told; an empty `on_fault` writes one line to stderr).
bool run_guarded(std::string_view thread_name, const std::function<void()>& body, const ThreadFault& on_fault);

// A new thread running `body` under run_guarded.
std::thread start_guarded_thread(std::string thread_name, std::function<void()> body, ThreadFault on_fault);

}  // namespace gaugeloop
