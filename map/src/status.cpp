// SPDX-License-Identifier: BSD-3-Clause
#include "adit/status.hpp"

#include <cstdio>

namespace adit {

const char* statusCodeName(StatusCode code) {
  switch (code) {
    case StatusCode::kOk: return "ok";
    case StatusCode::kInvalidArgument: return "invalid argument";
    case StatusCode::kNotFound: return "not found";
    case StatusCode::kOutOfRange: return "out of range";
    case StatusCode::kFailedPrecondition: return "failed precondition";
    case StatusCode::kDataLoss: return "data loss";
    case StatusCode::kInternal: return "internal";
  }
  return "unknown";
}

std::string Status::toString() const {
  if (ok()) return "ok";
  return std::string(statusCodeName(code_)) + ": " + message_;
}

void demandFailed(const char* condition, const char* file, int line) {
  std::fprintf(stderr, "adit: invariant violated: %s (%s:%d)\n", condition, file, line);
  std::abort();
}

}  // namespace adit
