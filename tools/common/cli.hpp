// SPDX-License-Identifier: BSD-3-Clause
#pragma once
/// @file
/// Exit codes and error reporting shared by every `adit` verb. Scripts rely on these codes:
/// 0 success, 1 failure of a valid run (or an internal error), 2 bad input (usage, missing or
/// malformed file, invalid value), 3 no path (`adit plan`: start and goal valid, but not
/// connected, or nothing found within the budget).

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <sstream>
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

/// "x,y,z" with finite numbers (commas, semicolons, tabs or spaces between); `where` names the
/// source in errors.
inline adit::StatusOr<adit::map::Vec3> parsePoint(const std::string& text, const std::string& where) {
  std::string t = text;
  for (char& c : t)
    if (c == ',' || c == ';' || c == '\t') c = ' ';
  std::istringstream is(t);
  adit::map::Vec3 p;
  std::string tok;
  for (int i = 0; i < 3; ++i) {
    if (!(is >> tok)) return adit::invalidArgument(where + ": expected x,y,z, got '" + text + "'");
    char* end = nullptr;
    p[i] = std::strtod(tok.c_str(), &end);
    if (end == tok.c_str() || *end != '\0') return adit::invalidArgument(where + ": '" + tok + "' is not a number");
    if (!std::isfinite(p[i])) return adit::invalidArgument(where + ": coordinate '" + tok + "' is not finite");
  }
  if (is >> tok) return adit::invalidArgument(where + ": expected three values, got more in '" + text + "'");
  return p;
}

}  // namespace adit::tools
