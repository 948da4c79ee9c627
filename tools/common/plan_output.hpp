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
#include "adit/map/world.hpp"
#include "adit/status.hpp"
#include "common/render_topview.hpp"

namespace adit::tools {

/// map::World::load with the progress bar on stderr (none when `quiet`), through the map cache
/// unless `no_cache` (--no-cache) or ADIT_NO_MAP_CACHE; what the cache did is logged on stderr.
/// Loading refuses work estimated beyond `max_memory_bytes` (0: the machine's budget,
/// map::machineMemoryBudgetBytes).
StatusOr<map::World> loadWorld(const std::string& path, map::UnknownPolicy policy, bool quiet, bool no_cache = false,
                               std::uint64_t max_memory_bytes = 0);

/// WorldOptions::cache as the verbs use it: on unless `no_cache` or ADIT_NO_MAP_CACHE.
map::MapCacheOptions verbCacheOptions(bool no_cache);
/// "map cache: ..." lines on stderr for what the cache did (nothing when it was not asked for).
void logCacheReport(const map::World& world);

/// sphere:r | capsule:r,len | box:x,y,z | cylinder:r,h (metres).
StatusOr<map::RobotShape> parseRobot(const std::string& text);

enum class PlanFormat { kJson, kCsv };
StatusOr<PlanFormat> planFormatFromPath(const std::string& path);

/// `adit plan --refine`: the unrefined path's figures ("before" in the JSON) and how the
/// break-point refinement went ("refine"). With --refine both before and after clearances are the
/// distance field minus the robot's horizontal radius, sampled a voxel apart (for a sphere in fly
/// mode the planner's own measure).
struct PlanRefinementInfo {
  double length_m = 0.0;
  double min_clearance_m = 0.0;
  double mean_clearance_m = 0.0;
  map::Polyline path;
  std::string outcome, message;
  double time_s = 0.0;
  int iterations = 0;
};

nlohmann::ordered_json planJson(const global::GlobalPlanResult& r, const PlanRefinementInfo* refinement = nullptr);
/// JSON or CSV by extension, atomically. CSV: "label,x,y,z" rows (start, A, B, ..., goal).
Status writePlan(const global::GlobalPlanResult& r, const std::string& path,
                 const PlanRefinementInfo* refinement = nullptr);

/// Break-point labels: A, B, ..., Z, AA, AB, ...
std::string breakPointLabel(std::size_t index);

/// Top view with the path, break points, start and goal, blocked roadways, and a side profile
/// (path height, floor and roof along it). `unrefined`, when given, is drawn dashed under the path;
/// `info`, when given, receives the picture's geometry and label counts.
Status drawPlan(const map::OccupancyMap& map, const global::RoadwayGraph& graph, const global::GlobalPlanResult& r,
                const map::Vec3& start, const map::Vec3& goal, const std::string& title, const std::string& path,
                const map::Polyline* unrefined = nullptr, TopViewInfo* info = nullptr);

}  // namespace adit::tools
