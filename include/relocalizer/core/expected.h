#pragma once
// A value or an error message, for library boundaries where failure is an
// expected outcome (bad input files, frames the solver cannot use). Exceptions
// stay reserved for programmer errors. Debian bookworm has no tl::expected and
// its compilers only ship std::expected under -std=c++23, which ROS 1 headers
// are not tested against, hence this small stand-in.

#include <stdexcept>
#include <string>
#include <utility>
#include <variant>

namespace relocalizer {

struct Error {
  std::string message;
};

template <typename T>
class Expected {
 public:
  Expected(T value) : state_(std::move(value)) {}      // NOLINT: implicit by design
  Expected(Error error) : state_(std::move(error)) {}  // NOLINT

  bool ok() const { return std::holds_alternative<T>(state_); }
  explicit operator bool() const { return ok(); }

  T& value() & {
    check();
    return std::get<T>(state_);
  }
  const T& value() const& {
    check();
    return std::get<T>(state_);
  }
  T&& value() && {
    check();
    return std::get<T>(std::move(state_));
  }
  T* operator->() { return &value(); }
  const T* operator->() const { return &value(); }
  T& operator*() & { return value(); }
  const T& operator*() const& { return value(); }

  const std::string& error() const { return std::get<Error>(state_).message; }

 private:
  void check() const {
    if (!ok()) throw std::logic_error("Expected::value() on an error: " + error());
  }
  std::variant<T, Error> state_;
};

// For calls that produce nothing but may fail.
struct Nothing {};
using Status = Expected<Nothing>;
inline Status okStatus() { return Nothing{}; }

inline Error makeError(std::string message) { return Error{std::move(message)}; }

}  // namespace relocalizer
