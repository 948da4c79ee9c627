// SPDX-License-Identifier: BSD-3-Clause
#pragma once
/// @file
/// A progress bar on stderr for long work, fed by the libraries' ProgressFn. On a terminal it
/// redraws one line; otherwise (CI logs, pipes) it prints one line per finished stage so logs stay
/// readable. Silent when quiet.
///
///   ProgressBar bar(/*quiet=*/false);
///   auto map = loadMap(path, {UnknownPolicy::kRock, bar.callback()});
///   bar.finish();

#include <chrono>
#include <string>

#include "adit/map/types.hpp"

namespace adit::tools {

class ProgressBar {
 public:
  explicit ProgressBar(bool quiet);
  ~ProgressBar();
  adit::map::ProgressFn callback();
  void update(const char* stage, double fraction);
  /// Ends the current line (if a bar is drawn).
  void finish();

 private:
  bool quiet_, tty_;
  std::string stage_;
  int last_permille_ = -1;
  bool open_line_ = false;
  std::chrono::steady_clock::time_point start_, last_draw_;
};

}  // namespace adit::tools
