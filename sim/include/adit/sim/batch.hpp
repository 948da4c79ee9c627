// SPDX-License-Identifier: BSD-3-Clause
#pragma once
/// @file
/// Randomized navigated scenarios for `adit simulate --batch`. makeBatchScenario()
/// turns (batch seed, run index) into one scenario on a map: start and goal on roadway
/// axes (a survey's centrelines 1.6 m above the floor, or the passages of the free-space roadway
/// graph of a map without a survey; at least min_separation_m apart), 0..max_moving_obstacles
/// vehicles driving along roadways, and with roof_fall_probability a roof fall on a roadway
/// between them; with near_rock_goal_share the goal moved off the axis to beside the floor or a
/// rib (where refuge chambers, pumps and a ground robot's poses are). Every random draw comes from a generator seeded by batchRunSeed(seed, index)
/// alone, so a run does not depend on which worker runs it, nor in which order: the table is the
/// same whatever the number of workers. runBatchScenario() runs one through simulateNavigated()
/// and keeps the figures of the table.
///
/// Workers must be separate processes, not threads: the global planner seeds OMPL's
/// process-global random generator, so two plans on two threads at once are not deterministic
/// (global_planner.hpp). `adit simulate --batch --jobs J` forks J workers.
///
///   StatusOr<Scenario> sc = makeBatchScenario(base, *survey, truth, params, 17);
///   BatchRunResult r = runBatchScenario(*sc, truth, 17, params.seed);

#include <cstdint>
#include <limits>
#include <optional>
#include <string>
#include <string_view>

#include "adit/map/survey_network.hpp"
#include "adit/sim/navigated_simulation.hpp"
#include "adit/sim/scenario.hpp"
#include "adit/sim/simulator.hpp"
#include "adit/status.hpp"

namespace adit::sim {

struct BatchParams {
  std::uint64_t seed = 1;
  double min_separation_m = 20.0;   ///< straight-line distance between start and goal, at least
  double max_separation_m = 150.0;  ///< and at most (keeps runs short on a large district)
  int max_moving_obstacles = 3;     ///< 0..this many vehicles per run
  double roof_fall_probability = 0.5;
  double roof_fall_radius_m = 3.0;  ///< fills a district roadway's section
  double vehicle_speed_min_mps = 0.2;  ///< each vehicle's speed is uniform in [min, max]
  double vehicle_speed_max_mps = 0.8;
  double vehicle_radius_m = 0.6;
  /// Robot radius and top speed ranges; 0 (the default): the base scenario's robot. When set,
  /// they are drawn from a stream of their own (seeded from the run's seed), so the main
  /// stream is not shifted, and without them the tables of `--batch` do not change.
  double robot_radius_min_m = 0.0, robot_radius_max_m = 0.0;
  double robot_speed_min_mps = 0.0, robot_speed_max_mps = 0.0;
  /// Simulated-time cap; 0: 120 s plus 6 s per metre of start-goal distance at v_max 1 m/s.
  double t_max_s = 0.0;
  /// Share of the runs whose goal is moved from the roadway's axis straight toward the floor or
  /// either rib (a third each) until the robot's centre is radius + safety margin (the global
  /// planner's, 0.2 m) + U(0.1, 0.5) m from rock, and never less than the planner's clearance
  /// (radius + margin + half a voxel). Drawn from a stream of its own, so that every other draw of
  /// a run (start, vehicles, roof fall, t_max) is the same as with 0. Kept on the axis when the
  /// moved goal would come within 1 m of a roof fall's ball, or fall outside the separation range.
  double near_rock_goal_share = 0.2;
  /// The robot every run uses instead of the base scenario's, as a scenario's `robot:` mapping in
  /// JSON (e.g. {"mode": "ground", "drive": "skid", "footprint": "box:1.0,0.7", "height": 0.6});
  /// empty: the base scenario's. Read with the scenario file's own rules (robotFromJson).
  std::string robot_json;
  Status validate() const;
};

/// The robot a generator's `robot` mapping describes (RobotLimits and sensor range), by the
/// scenario file's reader: the same keys, ranges and messages.
struct BatchRobot {
  local::RobotLimits limits;
  std::optional<double> sensor_range_m;
};
StatusOr<BatchRobot> robotFromJson(const std::string& robot_json);

/// The run's own seed: a SplitMix64 of the batch seed and the index.
std::uint64_t batchRunSeed(std::uint64_t seed, int index);

/// Where a batch draws its starts, goals, vehicles and roof falls: the roadways' axes, each point
/// drawn uniformly along their length and lifted by `lift` (to the robot's centre height), and
/// their widths. From a survey: the centrelines, lifted 1.6 m above the floor. From any other map
/// (a scan, a mesh, a .bt): the passages of the free-space roadway graph for a robot of
/// `clearance_m` (global::RoadwayGraph::fromFreeSpace), whose axes already run where the robot fits.
struct BatchRoadways {
  std::vector<map::Polyline> axes;
  std::vector<double> widths_m;  ///< per axis, at the robot's centre height
  map::Vec3 lift = map::Vec3::Zero();
  std::string source;            ///< "survey" or "free_space"
  static BatchRoadways fromSurvey(const map::SurveyNetwork& survey);
  static StatusOr<BatchRoadways> fromFreeSpace(const map::OccupancyMap& map, const map::DistanceField& field,
                                               double clearance_m);
  /// The width of the roadway whose axis passes nearest to `p`; 0 without roadways.
  double widthAt(const map::Vec3& p) const;
};

/// Scenario `index` of the batch: `base` gives the map, robot, method, params and dt; the rest is
/// drawn. `truth` is the map loaded for `base` (start and goal must have the robot's clearance).
/// Errors: bad params, a map without roadways, no admissible start/goal pair in 1000 draws.
StatusOr<Scenario> makeBatchScenario(const Scenario& base, const BatchRoadways& roadways, const Environment& truth,
                                     const BatchParams& params, int index);
/// The same on a survey's roadways.
StatusOr<Scenario> makeBatchScenario(const Scenario& base, const map::SurveyNetwork& survey,
                                     const Environment& truth, const BatchParams& params, int index);

/// One row of the table. outcome is outcomeName() or "error" (message says why).
struct BatchRunResult {
  int index = 0;
  std::uint64_t seed = 0;
  std::string outcome;
  std::string message;
  double arrival_time_s = std::numeric_limits<double>::quiet_NaN();
  double path_length_m = 0.0;
  double min_clearance_m = std::numeric_limits<double>::infinity();
  int collisions = 0;
  int replans = 0;
  double step_p50_us = 0.0;
  double step_p99_us = 0.0;
  double final_goal_distance_m = 0.0;
  double arrival_tolerance_m = 0.5;
  EndCause end_cause = EndCause::kNone;  ///< timeout and stuck: why (EndCause)
  // The scenario's features (for outcome rates by feature; not in the CSV): 0 for an "error"
  // row whose scenario could not be drawn.
  int vehicles = 0;
  bool roof_fall = false;
  double separation_m = 0.0;  ///< straight-line start-goal distance
  double robot_radius_m = 0.0;
  double robot_speed_mps = 0.0;  ///< v_max
  double roadway_width_m = 0.0;  ///< roadwayWidthAt(start)
};

/// The width, at the robot's centre height above the floor (1.6 m), of the section of the
/// roadway whose centreline passes nearest to `p`; 0 for a survey without roadways.
double roadwayWidthAt(const map::SurveyNetwork& survey, const map::Vec3& p);

/// The scenario generator's ranges from a small YAML (every key optional, defaults as above;
/// `seed` is not read: it is the campaign's):
///   separation: [20, 150]          # start-goal straight-line distance range [m]
///   max_moving_obstacles: 3
///   vehicle_speed: [0.2, 0.8]      # [m/s]
///   vehicle_radius: 0.6            # [m]
///   roof_fall: {probability: 0.5, radius: 3.0}
///   robot_radius: [0.3, 0.5]       # [m]; absent: the base scenario's robot
///   robot_speed: [0.8, 1.2]        # v_max [m/s]; absent: the base scenario's
///   t_max: 0                       # simulated-time cap [s]; 0: from the distance
///   near_rock_goals: 0.2           # share of goals moved beside the floor or a rib
///   robot: {mode: ground, drive: skid, footprint: "box:1.0,0.7", height: 0.6}   # a scenario's robot
/// Errors name the file, line and key: unknown keys, non-numbers, ranges with min > max,
/// values that validate() refuses.
StatusOr<BatchParams> parseBatchParams(const std::string& yaml_text, const std::string& file,
                                       const BatchParams& defaults = {});

/// `believed`, if given, is the scenario map preloaded (NavigatedOptions::believed); the row is the same.
BatchRunResult runBatchScenario(const Scenario& scenario, const Environment& truth, int index,
                                const map::World* believed = nullptr);

/// `index,seed,outcome,arrival_time,path_length,min_clearance,replans,step_p50_us,step_p99_us,`
/// `collisions,final_goal_distance,arrival_tolerance,vehicles,roof_fall,separation,robot_radius,`
/// `robot_speed,roadway_width,end_cause`: the first nine as before, then what a campaign's
/// statistics are computed from (so that they can be recomputed from the rows alone); end_cause is
/// endCauseName() (empty unless the outcome is timeout or stuck).
const char* batchCsvHeader();
/// One CSV line (no newline); numbers with 3 decimals, empty fields for NaN / infinite values.
/// Timing columns vary between runs of the same seed; the others do not. The message is not a
/// column (free text).
std::string batchCsvRow(const BatchRunResult& r);
/// The inverse of batchCsvRow() for untrusted text: exactly the header's columns; integers in
/// range (seed: any uint64); outcome an outcomeName() or "error"; end_cause an
/// endCauseName(), given exactly for timeout and stuck rows; numbers finite and within
/// bounds no run reaches (lengths and times below 1e9, step times below 1e12 us), empty only
/// where batchCsvRow() writes an empty field (arrival_time, min_clearance, final_goal_distance).
/// Errors name the column and the text. Allocation-bounded: fields are views.
StatusOr<BatchRunResult> parseBatchCsvRow(std::string_view line);

}  // namespace adit::sim
