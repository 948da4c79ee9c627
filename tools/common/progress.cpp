// SPDX-License-Identifier: BSD-3-Clause
#include "common/progress.hpp"

#include <unistd.h>

#include <algorithm>
#include <cstdio>

namespace adit::tools {

ProgressBar::ProgressBar(bool quiet)
    : quiet_(quiet), tty_(::isatty(STDERR_FILENO) != 0), start_(std::chrono::steady_clock::now()) {}

ProgressBar::~ProgressBar() { finish(); }

adit::map::ProgressFn ProgressBar::callback() {
  return [this](const char* stage, double fraction) { update(stage, fraction); };
}

void ProgressBar::update(const char* stage, double fraction) {
  if (quiet_) return;
  fraction = std::clamp(fraction, 0.0, 1.0);
  const auto now = std::chrono::steady_clock::now();
  const bool new_stage = stage_ != stage;
  if (new_stage) {
    if (open_line_) finish();
    stage_ = stage;
    start_ = now;
    last_permille_ = -1;
  }
  const int permille = int(fraction * 1000.0);
  if (tty_) {
    // Redraw at most every 50 ms, and always at the end of a stage.
    if (permille == last_permille_ || (permille < 1000 && !new_stage && now - last_draw_ < std::chrono::milliseconds(50)))
      return;
    const int width = 30, filled = int(fraction * width);
    std::string bar(std::size_t(filled), '#');
    bar.resize(std::size_t(width), '.');
    const double secs = std::chrono::duration<double>(now - start_).count();
    std::fprintf(stderr, "\r%-20s [%s] %5.1f%%  %6.1f s", stage, bar.c_str(), fraction * 100.0, secs);
    std::fflush(stderr);
    open_line_ = true;
    last_draw_ = now;
    if (permille >= 1000) finish();
  } else if (permille >= 1000 && last_permille_ < 1000) {
    const double secs = std::chrono::duration<double>(now - start_).count();
    std::fprintf(stderr, "%s: done in %.1f s\n", stage, secs);
  }
  last_permille_ = permille;
}

void ProgressBar::finish() {
  if (open_line_) {
    std::fputc('\n', stderr);
    open_line_ = false;
  }
}

}  // namespace adit::tools
