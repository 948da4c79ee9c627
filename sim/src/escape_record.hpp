// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// Private to adit::sim: both run loops (simulate() and simulateNavigated()) account for the local
// planner's escape manoeuvres the same way, so that a replay marks them alike in either kind of run.

#include <algorithm>

#include "adit/sim/simulator.hpp"

namespace adit::sim {

// The planner reports a running count (StepCommand::escapes); a run records when it went up. The
// count restarts at zero when the planner is reset (a new expected path, a replan), so the last
// period's count is kept apart from the run's maximum.
class EscapeRecord {
 public:
  // After the step of the period that starts at `t_s`, whose command reports `escapes`.
  void add(int escapes, double t_s, SimulationResult& result) {
    if (escapes > before_) result.escape_times_s.push_back(t_s);
    before_ = escapes;
    result.escapes = std::max(result.escapes, escapes);
  }

 private:
  int before_ = 0;  // the previous period's count
};

}  // namespace adit::sim
