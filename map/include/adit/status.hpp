// SPDX-License-Identifier: BSD-3-Clause
#pragma once
/// @file
/// Status and StatusOr<T>: the "value or reason" type returned at every adit boundary (loading a
/// map, parsing a survey or a scenario, validating parameters, the CLI), in every layer. Expected planning outcomes are *not* errors and
/// live in result structs; programmer errors abort through ADIT_DEMAND.
///
///   StatusOr<SurveyNetwork> survey = loadSurvey("maps/district.yaml");
///   if (!survey.ok()) { std::cerr << survey.status().message() << "\n"; return 2; }
///   const SurveyNetwork& net = *survey;

#include <cstdlib>
#include <optional>
#include <string>
#include <utility>

namespace adit {

enum class StatusCode {
  kOk = 0,
  kInvalidArgument,     ///< bad input value (NaN, negative width, malformed file content)
  kNotFound,            ///< a file or a named entity does not exist
  kOutOfRange,          ///< a value outside what the representation can hold (OctoMap key range)
  kFailedPrecondition,  ///< the operation needs a state the object is not in (empty map)
  kDataLoss,            ///< a file is truncated or corrupt
  kInternal,            ///< a third-party library failed unexpectedly
};

/// Human-readable name of a code ("invalid argument", ...).
const char* statusCodeName(StatusCode code);

class [[nodiscard]] Status {
 public:
  Status() = default;
  Status(StatusCode code, std::string message) : code_(code), message_(std::move(message)) {}

  static Status okStatus() { return {}; }
  bool ok() const { return code_ == StatusCode::kOk; }
  StatusCode code() const { return code_; }
  const std::string& message() const { return message_; }
  /// "invalid argument: <message>"
  std::string toString() const;

 private:
  StatusCode code_ = StatusCode::kOk;
  std::string message_;
};

inline Status invalidArgument(std::string m) { return {StatusCode::kInvalidArgument, std::move(m)}; }
inline Status notFound(std::string m) { return {StatusCode::kNotFound, std::move(m)}; }
inline Status outOfRange(std::string m) { return {StatusCode::kOutOfRange, std::move(m)}; }
inline Status failedPrecondition(std::string m) {
  return {StatusCode::kFailedPrecondition, std::move(m)};
}
inline Status dataLoss(std::string m) { return {StatusCode::kDataLoss, std::move(m)}; }
inline Status internalError(std::string m) { return {StatusCode::kInternal, std::move(m)}; }

[[noreturn]] void demandFailed(const char* condition, const char* file, int line);

/// Always-on invariant check: aborts with file:line. For broken invariants, never for bad input.
#define ADIT_DEMAND(cond) \
  ((cond) ? static_cast<void>(0) : ::adit::demandFailed(#cond, __FILE__, __LINE__))

template <class T>
class [[nodiscard]] StatusOr {
 public:
  StatusOr(Status status) : status_(std::move(status)) {  // NOLINT: implicit by design
    ADIT_DEMAND(!status_.ok());
  }
  StatusOr(T value) : value_(std::move(value)) {}  // NOLINT: implicit by design

  bool ok() const { return status_.ok(); }
  const Status& status() const { return status_; }

  const T& value() const& { check(); return *value_; }
  T& value() & { check(); return *value_; }
  T&& value() && { check(); return std::move(*value_); }
  const T& operator*() const& { return value(); }
  T& operator*() & { return value(); }
  T&& operator*() && { return std::move(*this).value(); }
  const T* operator->() const { return &value(); }
  T* operator->() { return &value(); }

 private:
  void check() const { ADIT_DEMAND(status_.ok() && value_.has_value()); }
  Status status_;
  std::optional<T> value_;
};

/// Propagates a non-OK status from an expression returning Status.
#define ADIT_RETURN_IF_ERROR(expr)       \
  do {                                   \
    ::adit::Status adit_s_ = (expr); \
    if (!adit_s_.ok()) return adit_s_;   \
  } while (0)

/// Evaluates an expression returning StatusOr<T>; on error returns its status, else moves the
/// value into `lhs` (a declaration or an lvalue):  ADIT_ASSIGN_OR_RETURN(auto map, loadMap(path));
#define ADIT_ASSIGN_OR_RETURN(lhs, expr) \
  ADIT_ASSIGN_OR_RETURN_IMPL_(ADIT_STATUS_CONCAT_(adit_sor_, __LINE__), lhs, expr)
#define ADIT_STATUS_CONCAT_INNER_(a, b) a##b
#define ADIT_STATUS_CONCAT_(a, b) ADIT_STATUS_CONCAT_INNER_(a, b)
#define ADIT_ASSIGN_OR_RETURN_IMPL_(tmp, lhs, expr) \
  auto tmp = (expr);                                 \
  if (!tmp.ok()) return tmp.status();                \
  lhs = std::move(tmp).value()

}  // namespace adit
