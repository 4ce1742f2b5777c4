// Error values for expected failures: every fallible call returns a Result<T> or a Status.
#pragma once

#include <cassert>
#include <string>
#include <string_view>
#include <utility>
#include <variant>

namespace gaugeloop {

// What kind of failure, so callers can choose an exit code or a retry without parsing text.
enum class ErrorCode {
  kInvalidInput,      // a file, a setting or a table that is malformed or out of range
  kNotFound,          // a file or a record that does not exist
  kIo,                // the operating system refused a read or a write
  kGaugeUnreachable,  // no connection to the gauge amplifier
  kGaugeTimeout,      // the gauge stopped answering
  kGaugeProtocol,     // the gauge answered with an exception or nonsense
  kIncompleteRun,     // revolutions with missing degrees, or a bad gauge status
  kStorage,           // the run database refused a read or a write
  kRefused,           // the geometry or a guard refuses the request
  kInternal,          // a bug: should never reach a user
};

std::string_view error_code_name(ErrorCode code);

// An error a person can act on: what was wrong, where, and what to do.
struct Error {
  ErrorCode code = ErrorCode::kInternal;
  std::string message;
};

// Either a value or an Error. Accessing the wrong alternative is a programmer error (asserts).
template <typename T>
class [[nodiscard]] Result {
 public:
  Result(T value) : state_(std::move(value)) {}      // NOLINT: implicit by design
  Result(Error error) : state_(std::move(error)) {}  // NOLINT: implicit by design

  bool ok() const { return std::holds_alternative<T>(state_); }
  explicit operator bool() const { return ok(); }

  T& value() & {
    assert(ok());
    return std::get<T>(state_);
  }
  const T& value() const& {
    assert(ok());
    return std::get<T>(state_);
  }
  // By value, so `auto&& x = f().value();` never dangles.
  T value() && {
    assert(ok());
    return std::get<T>(std::move(state_));
  }
  const Error& error() const {
    assert(!ok());
    return std::get<Error>(state_);
  }

  T& operator*() & { return value(); }
  const T& operator*() const& { return value(); }
  T* operator->() { return &value(); }
  const T* operator->() const { return &value(); }

 private:
  std::variant<T, Error> state_;
};

// Success or an Error, for calls that return nothing.
class [[nodiscard]] Status {
 public:
  Status() = default;
  Status(Error error) : error_(std::move(error)), ok_(false) {}  // NOLINT: implicit by design

  bool ok() const { return ok_; }
  explicit operator bool() const { return ok_; }
  const Error& error() const {
    assert(!ok_);
    return error_;
  }

 private:
  Error error_;
  bool ok_ = true;
};

inline Error make_error(ErrorCode code, std::string message) { return Error{code, std::move(message)}; }

}  // namespace gaugeloop
