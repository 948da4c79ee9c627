// SPDX-License-Identifier: BSD-3-Clause
#pragma once
/// @file
/// Exit codes and error reporting shared by every `adit` verb. Scripts rely on these codes:
/// 0 success, 1 failure of a valid run (or an internal error), 2 bad input (usage, missing or
/// malformed file, invalid value), 3 no path (`adit plan`: start and goal valid, but not
/// connected, or nothing found within the budget).

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <string>

#include "adit/map/types.hpp"
#include "adit/status.hpp"

namespace adit::tools {

constexpr int kExitOk = 0;
constexpr int kExitFailure = 1;
constexpr int kExitBadInput = 2;
constexpr int kExitNoPath = 3;

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

/// Flushes stdout and checks that everything printed on it arrived: results on a full disk,
/// `> /dev/full` or a closed pipe must not end in exit 0. Called once, after every verb, so no
/// verb needs its own check. Returns `rc`, or kExitFailure with a message when stdout failed.
inline int finishStdout(int rc) {
  errno = 0;
  const bool flushed = std::fflush(stdout) == 0;
  const int flush_errno = errno;
  if (flushed && !std::ferror(stdout)) return rc;
  std::fprintf(stderr, "adit: error: cannot write the results to standard output%s%s\n",
               flush_errno ? ": " : "", flush_errno ? std::strerror(flush_errno) : "");
  return rc == kExitOk ? kExitFailure : rc;
}

}  // namespace adit::tools
