// Status and Result<T>: how the core API reports caller misuse and numerical failure.
// No exceptions cross the core API. A function that can fail returns Status (or Result<T> when it
// also produces a value); the message names what was wrong (the variable, the field, the line).
#pragma once

#include <optional>
#include <string>
#include <utility>
#include <variant>

#include "core/base/check.h"

namespace slamd::core {

enum class StatusCode {
  kOk = 0,
  kInvalidArgument,     // caller passed something malformed (NaN, wrong dimension, bad option)
  kNotFound,            // unknown key, missing file
  kAlreadyExists,       // duplicate variable or factor
  kFailedPrecondition,  // operation not valid in the current state
  kNumericalFailure,    // indefinite / rank-deficient system; message names a nearby variable
  kOutOfRange,          // index or value outside its allowed range
  kIoError,             // the operating system refused a read or write
  kDataLoss,            // corrupt or truncated file
  kUnavailable,         // a remote service (NATS) did not answer in time: retry later
};

const char* StatusCodeName(StatusCode code);

class [[nodiscard]] Status {
 public:
  Status() = default;  // ok
  Status(StatusCode code, std::string message) : code_(code), message_(std::move(message)) {}

  static Status Ok() { return Status(); }
  bool ok() const { return code_ == StatusCode::kOk; }
  StatusCode code() const { return code_; }
  const std::string& message() const { return message_; }
  // "NumericalFailure: matrix not positive definite near x12" (or "OK").
  std::string ToString() const;

 private:
  StatusCode code_ = StatusCode::kOk;
  std::string message_;
};

inline Status InvalidArgument(std::string m) { return {StatusCode::kInvalidArgument, std::move(m)}; }
inline Status NotFound(std::string m) { return {StatusCode::kNotFound, std::move(m)}; }
inline Status AlreadyExists(std::string m) { return {StatusCode::kAlreadyExists, std::move(m)}; }
inline Status FailedPrecondition(std::string m) { return {StatusCode::kFailedPrecondition, std::move(m)}; }
inline Status NumericalFailure(std::string m) { return {StatusCode::kNumericalFailure, std::move(m)}; }
inline Status OutOfRange(std::string m) { return {StatusCode::kOutOfRange, std::move(m)}; }
inline Status IoError(std::string m) { return {StatusCode::kIoError, std::move(m)}; }
inline Status DataLoss(std::string m) { return {StatusCode::kDataLoss, std::move(m)}; }
inline Status Unavailable(std::string m) { return {StatusCode::kUnavailable, std::move(m)}; }

// Either a value or a non-ok Status.
template <typename T>
class [[nodiscard]] Result {
 public:
  Result(T value) : value_(std::move(value)) {}  // NOLINT: implicit, so `return value;` works
  Result(Status status) : status_(std::move(status)) {  // NOLINT: implicit, so `return status;`
    SLAMD_CHECK(!status_.ok()) << "a Result built from a Status must carry an error";
  }

  bool ok() const { return value_.has_value(); }
  const Status& status() const { return status_; }
  const T& value() const& {
    SLAMD_CHECK(ok()) << "value() of a failed Result: " << status_.ToString();
    return *value_;
  }
  T& value() & {
    SLAMD_CHECK(ok()) << "value() of a failed Result: " << status_.ToString();
    return *value_;
  }
  T&& value() && {
    SLAMD_CHECK(ok()) << "value() of a failed Result: " << status_.ToString();
    return std::move(*value_);
  }
  const T& operator*() const& { return value(); }
  T& operator*() & { return value(); }
  const T* operator->() const { return &value(); }
  T* operator->() { return &value(); }

 private:
  std::optional<T> value_;
  Status status_;
};

// Returns early from the enclosing function when `expr` (a Status) is not ok.
#define SLAMD_RETURN_IF_ERROR(expr)               \
  do {                                            \
    ::slamd::core::Status slamd_status_ = (expr); \
    if (!slamd_status_.ok()) return slamd_status_; \
  } while (false)

}  // namespace slamd::core
