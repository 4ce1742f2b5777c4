// The one entry guard for the product's threads.
#include "core/guarded_thread.h"

#include <cstdio>
#include <exception>
#include <string>
#include <utility>

namespace gaugeloop {

namespace {

void tell(const ThreadFault& on_fault, std::string_view thread_name, std::string_view what) {
  if (on_fault) {
    on_fault(thread_name, what);
    return;
  }
  std::fprintf(stderr, "gaugeloop: thread '%.*s' ended by an exception: %.*s\n", static_cast<int>(thread_name.size()),
               thread_name.data(), static_cast<int>(what.size()), what.data());
}

}  // namespace

bool run_guarded(std::string_view thread_name, const std::function<void()>& body, const ThreadFault& on_fault) {
  try {
    body();
    return true;
  } catch (const std::exception& e) {
    tell(on_fault, thread_name, e.what());
  } catch (...) {
    tell(on_fault, thread_name, "unknown exception");
  }
  return false;
}

std::thread start_guarded_thread(std::string thread_name, std::function<void()> body, ThreadFault on_fault) {
  return std::thread([name = std::move(thread_name), body = std::move(body), on_fault = std::move(on_fault)] {
    run_guarded(name, body, on_fault);
  });
}

}  // namespace gaugeloop
