// SPDX-License-Identifier: BSD-3-Clause
#pragma once
/// @file
/// A simulation scenario: the YAML schema of `adit simulate` as a struct, and its loader. It is
/// adit::sim's, not the local planner's: a scenario describes a whole run (the true world, its
/// events, the navigator's options), of which LocalParams are one part. The schema is fixed;
/// fields marked "extension" are additions.
///
///   map: ../district.bt          # optional: relative to this file (else to the working directory)
///   start: [0, 0, 0]
///   goal: [14, 14, 0]
///   expected_path: [[0,0,0], [4.9,5,0], [10.8,6.2,0], [14,14,0]]   # optional: straight line
///   robot: {radius: 0.3, v_max: 1.0, a_max: 0.5}
///   static_obstacles:  [{center: [9, 11.5, 0], radius: 0.5}]
///   moving_obstacles:  [{start: [4, 8, 0], velocity: [0.25, -0.35, 0], acceleration: [0.036, 0.16, 0], radius: 0.3}]
///   method: tian2016             # classic | tian2016 | wang2014 | vff | cvff | uuv
///   preset: default              # extension: default | paper (the papers' fields as published:
///                                # the terminal phase off; the reproduction runs use it)
///   params: {}                   # overrides of the preset: the method's fields, MonitorParams' and
///                                # TerminalParams' (terminal, terminal_range_m, terminal_n, terminal_seek)
///   dt: 0.1
///   t_max: 300
///   seed: 1
///
/// Navigated runs: a planned expected path, a sensor and roof falls (run by
/// simulateNavigated() of navigated_simulation.hpp, not by simulate() of simulator.hpp):
///
///   expected_path: plan          # plan it with the global layer on the scenario's map
///   robot: {sensor_range: 8}     # rock within this range of the robot is sensed [m]
///   events: [{t: 10, type: roof_fall, center: [90, 20, -3], radius: 3}]
///   subgoals: ga_trust_region    # none (default) | ga_trust_region: per-period sub-goals (Tian 2016
///                                # §2.3), chosen by adit::fusion (simulate gets the selector
///                                # through SimulateOptions; the navigated runs choose it themselves)
///   subgoal_period: 1.0          # extension: t0 [s], a multiple of dt (default 1)
///
/// A ground vehicle (extension; `mode` defaults to fly, so scenarios without it run as before):
///
///   robot: {mode: ground, drive: skid, footprint: "box:1.0,0.7", height: 0.6, omega_max: 1.0,
///           alpha_max: 2.0, max_slope_deg: 15, max_step: 0.1}   # drive: differential | skid |
///                                # ackermann (max_steer_deg, wheelbase) | holonomic; footprint:
///                                # circle:R | box:L,W; radius becomes the footprint's circumradius
///
/// Extensions: `name`, `description`; a moving obstacle may have `name`, `shape: sphere | box |
/// cylinder` with `size: [x, y, z]` (box) or `length` (cylinder, along z).
///
///   StatusOr<Scenario> s = loadScenario("maps/scenarios/tian2016_straight.yaml");
///   if (!s.ok()) return report(s.status());   // "file:line:col: robot.radius: must be > 0 (got -1)"

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "adit/local/local_planner.hpp"
#include "adit/local/params.hpp"
#include "adit/map/types.hpp"
#include "adit/status.hpp"

namespace adit::sim {

using map::Vec3;

struct NamedObstacle {
  std::string name;
  map::MovingObstacle obstacle;  ///< position/velocity/acceleration at t = 0
};

/// Something that happens to the true world during the run. Only `roof_fall`: at t_s the
/// ball becomes rock; the robot learns it only through its sensor.
struct ScenarioEvent {
  double t_s = 0.0;
  std::string type = "roof_fall";
  Vec3 center = Vec3::Zero();
  double radius_m = 1.0;
};

/// How the robot picks what it steers at. kNone: the current break point of the
/// expected path; kGaTrustRegion: every subgoal_period_s the point of the annulus around the robot
/// that minimises the potential (adit::fusion::selectSubgoal).
enum class SubgoalMode { kNone, kGaTrustRegion };
/// "none" | "ga_trust_region".
const char* subgoalModeName(SubgoalMode m);
StatusOr<SubgoalMode> parseSubgoalMode(const std::string& name);

/// Which parameters a scenario's method starts from (`preset`). kDefault: LocalParams::preset(),
/// the paper's values with this project's additions (the terminal phase); kPaper:
/// LocalParams::paper(), the paper's field as published, so that a reproduction stays exact.
enum class ParamsPreset { kDefault, kPaper };
/// "default" | "paper".
const char* paramsPresetName(ParamsPreset p);
StatusOr<ParamsPreset> parseParamsPreset(const std::string& name);

struct Scenario {
  std::string name;         ///< `name`, else the file's stem
  std::string description;
  std::string file;         ///< where it was loaded from (messages)
  std::optional<std::string> map_path;  ///< resolved path of `map`
  Vec3 start = Vec3::Zero();
  Vec3 goal = Vec3::Zero();
  map::Polyline expected_path;  ///< never empty after loading: [start, goal] by default
  std::vector<local::StaticSphere> static_obstacles;
  std::vector<NamedObstacle> moving_obstacles;
  ParamsPreset preset = ParamsPreset::kDefault;  ///< `preset`
  local::LocalParams params;  ///< `preset` of `method` with `params` and `robot` applied
  double dt_s = 0.1;
  double t_max_s = 300.0;
  std::uint64_t seed = 1;
  bool plan_expected_path = false;        ///< `expected_path: plan` (expected_path is then [start, goal])
  std::optional<double> sensor_range_m;   ///< `robot.sensor_range`
  std::vector<ScenarioEvent> events;      ///< `events`, sorted by time
  SubgoalMode subgoal_mode = SubgoalMode::kNone;  ///< `subgoals`
  double subgoal_period_s = 1.0;          ///< `subgoal_period`: t0, a multiple of dt_s
  /// The run needs the navigator (adit::fusion): a planned path, a sensor or events.
  bool needsNavigator() const { return plan_expected_path || sensor_range_m.has_value() || !events.empty(); }

  /// Range checks that need no map (the loader calls it; code that builds a Scenario should too).
  Status validate() const;
};

/// Reads and validates a scenario file. Errors name the file, line, column and field.
StatusOr<Scenario> loadScenario(const std::string& path);
/// The same from text; `file` names it in messages and locates a relative `map`.
StatusOr<Scenario> parseScenario(const std::string& text, const std::string& file);

}  // namespace adit::sim
