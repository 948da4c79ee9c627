// SPDX-License-Identifier: BSD-3-Clause
#pragma once
/// @file
/// Exit codes and error reporting shared by every `adit` verb. Scripts rely on these codes:
/// 0 success, 1 failure of a valid run (or an internal error), 2 bad input (usage, missing or
/// malformed file, invalid value), 3 no path (`adit plan`: start and goal valid, but not
/// connected, or nothing found within the budget).

#include <cerrno>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <string>

#include <unistd.h>

#include "adit/map/map_io.hpp"
#include "adit/map/size_estimate.hpp"
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

/// A token file (`adit serve --token-file`, `adit simulate --live-token-file`): its first
/// non-empty line, `TOKEN` or `LABEL:TOKEN` (the label names the operator in the command log).
struct TokenFile {
  std::string label, token;
};
inline adit::StatusOr<TokenFile> readTokenFile(const std::string& path) {
  ADIT_ASSIGN_OR_RETURN(std::string text, adit::map::readFile(path, 4096));
  std::string line;
  int n = 0;
  for (std::size_t start = 0; start <= text.size();) {
    std::size_t end = text.find('\n', start);
    if (end == std::string::npos) end = text.size();
    line = text.substr(start, end - start);
    ++n;
    while (!line.empty() && (line.back() == '\r' || line.back() == ' ' || line.back() == '\t')) line.pop_back();
    if (!line.empty()) break;
    start = end + 1;
  }
  if (line.empty()) return adit::invalidArgument(path + ": no token in the file");
  const std::string at = path + ":" + std::to_string(n) + ": ";
  TokenFile t;
  const auto colon = line.find(':');
  if (colon != std::string::npos) {
    t.label = line.substr(0, colon);
    line = line.substr(colon + 1);
    if (t.label.empty()) return adit::invalidArgument(at + "the label before ':' is empty");
  }
  if (line.size() < 16) return adit::invalidArgument(at + "the token is shorter than 16 characters");
  for (char c : line)
    if (c == ' ' || c == '\t') return adit::invalidArgument(at + "the token contains white space");
  t.token = line;
  return t;
}

/// Checks, before any work, that `path` (given with `flag`) can be written: an existing file,
/// device or FIFO that is writable, or a new name in an existing, writable directory. A verb
/// checks every output this way before it loads anything, so that a bad second output cannot
/// leave the first one written (or a long run end in an unwritable place).
inline adit::Status checkOutputPath(const std::string& path, const std::string& flag) {
  if (path.empty()) return {};
  if (path == "-") return {};
  if (::access(path.c_str(), F_OK) == 0) {
    if (::access(path.c_str(), W_OK) != 0)
      return adit::invalidArgument(flag + " " + path + ": cannot write it: " + std::strerror(errno));
    return {};
  }
  const std::string::size_type slash = path.find_last_of('/');
  const std::string dir = slash == std::string::npos ? "." : slash == 0 ? "/" : path.substr(0, slash);
  if (::access(dir.c_str(), F_OK) != 0)
    return adit::invalidArgument(flag + " " + path + ": no such directory '" + dir + "'");
  if (::access(dir.c_str(), W_OK | X_OK) != 0)
    return adit::invalidArgument(flag + " " + path + ": cannot write in '" + dir + "': " + std::strerror(errno));
  return {};
}

/// --max-memory as bytes: the value given, or (empty) the machine's default budget
/// (map::machineMemoryBudgetBytes). Errors name the flag.
inline adit::StatusOr<std::uint64_t> memoryBudgetOf(const std::string& max_memory) {
  if (max_memory.empty()) return adit::map::machineMemoryBudgetBytes();
  adit::StatusOr<std::uint64_t> bytes = adit::map::parseByteSize(max_memory);
  if (!bytes.ok()) return adit::invalidArgument("--max-memory: " + bytes.status().message());
  return bytes;
}

/// --max-memory's help text, one wording for every verb; `what` says what the budget covers.
inline std::string maxMemoryHelp(const std::string& what) {
  return "Refuse work estimated to need more memory than this: " + what + " (e.g. 512M, 8G; default " +
         adit::map::kMachineMemoryBudgetText + ")";
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
