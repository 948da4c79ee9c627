// SPDX-License-Identifier: BSD-3-Clause
#pragma once
/// @file
/// The hand-off of a per-period sub-goal (Tian 2016 §2.3) between whoever chooses it and the
/// local step that steers at it (LocalPlanner::setSubgoal). The selector itself lives in
/// adit::fusion (subgoal_selector.hpp: it needs the genetic trust-region optimiser); the runs that
/// call it live above (adit::sim's simulator, adit::fusion's Navigator). These types sit here,
/// in the layer both see, so that the selector and its callers agree on one request and one
/// answer without the planner a robot links depending on either.
///
///   SubgoalFn select = fusion::subgoalFunction(params, subgoal_params);  // once
///   SubgoalPick pick = select(request);                                  // every period
///   if (pick.point) planner.setSubgoal(pick.aim); else planner.clearSubgoal();

#include <functional>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "adit/local/local_planner.hpp"
#include "adit/map/types.hpp"

namespace adit::map {
class DistanceField;
}  // namespace adit::map

namespace adit::local {

/// What the sub-goal selector sees at the start of a period (`subgoals: ga_trust_region`).
/// References are valid for the call only.
struct SubgoalRequest {
  double t_s = 0.0;
  const RobotState* state = nullptr;
  Vec3 segment_a = Vec3::Zero();  ///< the expected path's current segment (line field)
  Vec3 segment_b = Vec3::Zero();  ///< its end: the break point (or the goal) the selection aims at
  const std::vector<map::MovingObstacle>* moving = nullptr;  ///< as sensed now (t = 0 is now)
  const std::vector<StaticSphere>* static_obstacles = nullptr;
  const map::DistanceField* field = nullptr;  ///< rock; null in open space
};
/// The selector's answer: the sub-goal, the point the attraction is to pull toward
/// (LocalPlanner::setSubgoal) and a short name of how it was found ("optimized", "straight", ...:
/// counted in SubgoalStats). No point: keep steering at the break point.
struct SubgoalPick {
  std::optional<Vec3> point;
  Vec3 aim = Vec3::Zero();
  std::string kind;
};
/// Called once per period; may allocate (it runs outside the allocation-free step()).
using SubgoalFn = std::function<SubgoalPick(const SubgoalRequest&)>;

/// How the per-period selection went over a run.
struct SubgoalStats {
  int periods = 0;                                    ///< selections made
  std::vector<std::pair<std::string, int>> by_kind;   ///< SubgoalPick::kind → count, first-seen order
  double time_mean_us = 0.0;                          ///< wall time per selection
  double time_max_us = 0.0;
  void add(const std::string& kind, double us);
};

}  // namespace adit::local
