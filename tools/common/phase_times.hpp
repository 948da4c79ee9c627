// SPDX-License-Identifier: BSD-3-Clause
#pragma once
/// @file
/// Where a verb's wall time went, as one stderr line whose phases add up to it: each mark()
/// charges the time since the previous mark to a phase, and split() moves a part a library
/// measured (the world's voxelizing, pruning and field) out of the phase that contains it. So an
/// unlabelled second cannot hide between the phases: what no phase names is in "other".
///
///   PhaseTimes t;
///   StatusOr<World> w = loadWorld(...);
///   t.mark("load");
///   t.splitWorld("load", w->times());
///   ...
///   t.mark("teardown");
///   t.print();   // adit: time: voxelize 1.10 s, prune+stats 0.41 s, field 0.60 s, ... = 2.71 s wall

#include <chrono>
#include <cstdio>
#include <string>
#include <utility>
#include <vector>

#include "adit/map/world.hpp"

namespace adit::tools {

class PhaseTimes {
 public:
  PhaseTimes() : start_(Clock::now()), last_(start_) {}

  void mark(const std::string& phase) {
    const Clock::time_point now = Clock::now();
    add(phase, std::chrono::duration<double>(now - last_).count());
    last_ = now;
  }
  /// Moves `seconds` of `from` to `part` (never more than `from` holds).
  void split(const std::string& from, const std::string& part, double seconds) {
    double& f = at(from);
    const double s = std::min(std::max(seconds, 0.0), f);
    f -= s;
    add(part, s);
  }
  /// The world's own phases out of `from` (the phase its load was charged to).
  void splitWorld(const std::string& from, const map::WorldTimes& w) {
    split(from, "cache read", w.cache_read_s);
    split(from, "voxelize", w.load_s - w.prune_s);
    split(from, "prune+stats", w.prune_s);
    split(from, "field", w.field_s);
    split(from, "cache write", w.cache_write_s);
  }
  void print() const {
    const double wall = std::chrono::duration<double>(Clock::now() - start_).count();
    std::string line = "adit: time:";
    double sum = 0.0;
    char buf[96];
    for (const auto& [name, s] : phases_) {
      if (s < 0.0005) continue;
      std::snprintf(buf, sizeof buf, "%s %s %.3f s", sum > 0.0 ? "," : "", name.c_str(), s);
      line += buf;
      sum += s;
    }
    std::snprintf(buf, sizeof buf, " = %.3f s of %.3f s wall since the verb started\n", sum, wall);
    line += buf;
    std::fputs(line.c_str(), stderr);
  }

 private:
  using Clock = std::chrono::steady_clock;
  double& at(const std::string& phase) {
    for (auto& p : phases_)
      if (p.first == phase) return p.second;
    phases_.emplace_back(phase, 0.0);
    return phases_.back().second;
  }
  void add(const std::string& phase, double s) { at(phase) += s; }

  Clock::time_point start_, last_;
  std::vector<std::pair<std::string, double>> phases_;
};

}  // namespace adit::tools
