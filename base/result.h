#pragma once
// Result<T>: the return type for environment failures (a file that cannot be read, a JIT that
// cannot be created). Not for user source errors (diagnostics) nor for bugs (HFRT_CHECK).

#include <string>
#include <utility>
#include <variant>

#include "base/check.h"

namespace hfrt {

struct Error {
  std::string message;
  std::string hint = {};  ///< how to fix it, when the failure can say (e.g. a limit's option)
};

template <typename T>
class [[nodiscard]] Result {
 public:
  Result(T value) : v_(std::move(value)) {}
  Result(Error error) : v_(std::move(error)) {}

  bool ok() const { return v_.index() == 0; }
  explicit operator bool() const { return ok(); }
  T& value() & {
    HFRT_CHECK(ok());
    return std::get<0>(v_);
  }
  const T& value() const& {
    HFRT_CHECK(ok());
    return std::get<0>(v_);
  }
  T&& value() && {
    HFRT_CHECK(ok());
    return std::get<0>(std::move(v_));
  }
  T* operator->() { return &value(); }
  const T* operator->() const { return &value(); }
  T& operator*() & { return value(); }
  const Error& error() const {
    HFRT_CHECK(!ok());
    return std::get<1>(v_);
  }

 private:
  std::variant<T, Error> v_;
};

}  // namespace hfrt
