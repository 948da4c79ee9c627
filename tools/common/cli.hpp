// SPDX-License-Identifier: BSD-3-Clause
#pragma once
/// @file
/// Exit codes and error reporting shared by every `adit` verb. Scripts rely on these codes:
/// 0 success, 1 failure of a valid run (or an internal error), 2 bad input (usage, missing or
/// malformed file, invalid value).

#include <cstdio>
#include <string>

#include "adit/status.hpp"

namespace adit::tools {

constexpr int kExitOk = 0;
constexpr int kExitFailure = 1;
constexpr int kExitBadInput = 2;

inline int exitCodeFor(const adit::Status& s) {
  using adit::StatusCode;
  switch (s.code()) {
    case StatusCode::kOk: return kExitOk;
    case StatusCode::kInternal: return kExitFailure;
    default: return kExitBadInput;
  }
}

/// Prints "adit: <message>" on stderr and returns the exit code for the status.
inline int report(const adit::Status& s) {
  std::fprintf(stderr, "adit: error: %s\n", s.message().c_str());
  return exitCodeFor(s);
}

}  // namespace adit::tools
