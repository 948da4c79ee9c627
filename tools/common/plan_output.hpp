// SPDX-License-Identifier: BSD-3-Clause
#pragma once
/// @file
/// What `adit plan` and `adit bench global` share: the --robot syntax, the result as JSON or CSV
/// (the JSON fields are a fixed interface: outcome, message, length, min_clearance,
/// mean_clearance, planning_time, planner, path, route), and the plan picture drawn with Figure.

#include <nlohmann/json.hpp>

#include <string>

#include "adit/global/global_planner.hpp"
#include "adit/map/distance_field.hpp"
#include "adit/map/map_io.hpp"
#include "adit/map/occupancy_map.hpp"
#include "adit/status.hpp"

namespace adit::tools {

/// A map ready to plan on: loaded (with its survey, if any) and its distance field built, with
/// the progress bar on stderr. Keep it in place while planners use it (they point into it).
struct PlanWorld {
  map::LoadedMap loaded;
  map::DistanceField field;
  const map::SurveyNetwork* survey() const { return loaded.survey ? &*loaded.survey : nullptr; }
};
StatusOr<PlanWorld> loadPlanWorld(const std::string& path, map::UnknownPolicy policy, bool quiet);

/// sphere:r | capsule:r,len | box:x,y,z | cylinder:r,h (metres).
StatusOr<map::RobotShape> parseRobot(const std::string& text);

enum class PlanFormat { kJson, kCsv };
StatusOr<PlanFormat> planFormatFromPath(const std::string& path);

nlohmann::ordered_json planJson(const global::GlobalPlanResult& r);
/// JSON or CSV by extension, atomically. CSV: "label,x,y,z" rows (start, A, B, ..., goal).
Status writePlan(const global::GlobalPlanResult& r, const std::string& path);

/// Break-point labels: A, B, ..., Z, AA, AB, ...
std::string breakPointLabel(std::size_t index);

/// Top view with the path, break points, start and goal, blocked roadways, and a side profile
/// (path height, floor and roof along it).
Status drawPlan(const map::OccupancyMap& map, const global::RoadwayGraph& graph, const global::GlobalPlanResult& r,
                const map::Vec3& start, const map::Vec3& goal, const std::string& title, const std::string& path);

}  // namespace adit::tools
