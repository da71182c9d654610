// Result and Error: bad input is reported as a value carrying a one-line message that names
// the file and the element (../shared/STYLE.md "Errors"), never printed by the library.
#pragma once

#include <string>
#include <utility>
#include <variant>

#include "lib/base/check.h"

namespace visgate {

struct Error {
  std::string message;
};

template <class T>
class Result {
 public:
  Result(T value) : v_(std::move(value)) {}
  Result(Error e) : v_(std::move(e)) {}
  bool ok() const { return v_.index() == 0; }
  explicit operator bool() const { return ok(); }
  T& value() { VG_CHECK(ok()); return std::get<0>(v_); }
  const T& value() const { VG_CHECK(ok()); return std::get<0>(v_); }
  T& operator*() { return value(); }
  T* operator->() { return &value(); }
  const Error& error() const { VG_CHECK(!ok()); return std::get<1>(v_); }

 private:
  std::variant<T, Error> v_;
};

// Result<void> analogue.
class Status {
 public:
  Status() = default;
  Status(Error e) : err_(std::move(e.message)), failed_(true) {}
  bool ok() const { return !failed_; }
  explicit operator bool() const { return ok(); }
  Error error() const { return Error{err_}; }

 private:
  std::string err_;
  bool failed_ = false;
};

}  // namespace visgate
