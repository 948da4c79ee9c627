// SPDX-License-Identifier: BSD-3-Clause
#include "adit/sim/batch.hpp"

#include <yaml-cpp/yaml.h>

#include <charconv>
#include <cmath>
#include <limits>
#include <optional>
#include <cstdio>
#include <random>
#include <vector>

#include "adit/global/global_planner_params.hpp"
#include "adit/global/roadway_graph.hpp"
#include "adit/map/distance_field.hpp"
#include "adit/sim/navigated_simulation.hpp"

namespace adit::sim {

namespace {

// The robot's centre above the roadway floor, as in the bundled district scenarios.
constexpr double kCentreAboveFloorM = 1.6;
constexpr int kMaxDraws = 1000;

struct Segment {
  Vec3 a, b;
  double length;
};

// Every axis segment, for drawing points uniformly along the roadways.
std::vector<Segment> segments(const BatchRoadways& roadways) {
  std::vector<Segment> out;
  for (const map::Polyline& c : roadways.axes)
    for (std::size_t i = 0; i + 1 < c.points.size(); ++i) {
      const double len = (c.points[i + 1] - c.points[i]).norm();
      if (len > 0) out.push_back({c.points[i], c.points[i + 1], len});
    }
  return out;
}

struct RoadwayPoint {
  Vec3 position;
  Vec3 direction;  // unit, along the roadway
};

class Drawer {
 public:
  Drawer(const std::vector<Segment>& segs, const Vec3& lift, std::uint64_t seed) : segs_(segs), lift_(lift), rng_(seed) {
    std::vector<double> w;
    for (const Segment& s : segs) w.push_back(s.length);
    pick_ = std::discrete_distribution<std::size_t>(w.begin(), w.end());
  }
  RoadwayPoint point() {
    const Segment& s = segs_[pick_(rng_)];
    const double t = uniform(0.0, 1.0);
    return {s.a + t * (s.b - s.a) + lift_, (s.b - s.a) / s.length};
  }
  double uniform(double lo, double hi) { return std::uniform_real_distribution<double>(lo, hi)(rng_); }
  int integer(int lo, int hi) { return std::uniform_int_distribution<int>(lo, hi)(rng_); }

 private:
  const std::vector<Segment>& segs_;
  Vec3 lift_;
  std::mt19937_64 rng_;
  std::discrete_distribution<std::size_t> pick_;
};

// A ground robot's body on the floor under p clears rock by kBodyRoomM at every heading
// (`everywhere`: it can turn on the spot, as at its start) or at one (it can stand there).
constexpr double kBodyRoomM = 0.05;
bool groundBodyFits(const Scenario& sc, const Environment& truth, const Vec3& p, bool everywhere) {
  Scenario at = sc;
  at.start = at.goal = p;
  at.expected_path.points = {p};
  const StatusOr<Scenario> placed = placeOnFloor(at, truth);
  if (!placed.ok()) return false;
  const BodyFit fit = bodyFit(*placed, truth, placed->start);
  return (everywhere ? fit.least_m : fit.most_m) > kBodyRoomM;
}

// The goal moved off the axis toward the floor or a rib (BatchParams::near_rock_goal_share),
// from a stream of its own: the other draws of the run are not shifted. Last of the draws, so
// that t_max and the roof fall's time stay those of the axis goal.
void moveGoalNearRock(Scenario& sc, const Vec3& along, const Environment& truth, const BatchParams& params,
                      std::uint64_t run_seed) {
  std::mt19937_64 rng(batchRunSeed(run_seed ^ 0x474F414C4E454152ull, 0));  // "GOALNEAR"
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  if (!(unit(rng) < params.near_rock_goal_share)) return;
  const double side = unit(rng), extra = 0.1 + 0.4 * unit(rng);
  const map::DistanceField& field = *truth.field();
  const double r = sc.params.robot.radius_m, margin = global::GlobalPlannerParams().safety_margin_m;
  const double target = r + margin + std::max(extra, 0.5 * field.resolution());
  Vec3 toward = -Vec3::UnitZ();  // the floor
  if (side >= 1.0 / 3.0) {
    const Vec3 rib = Vec3(-along.y(), along.x(), 0.0);  // the left rib, horizontal
    if (rib.norm() < 1e-6) return;                      // a vertical shaft has no rib to find this way
    toward = (side < 2.0 / 3.0 ? 1.0 : -1.0) * rib.normalized();
  }
  // March in 2 cm steps while the centre keeps `target` from rock: the last such point is within
  // 2 cm of it (the field changes by at most 1 m per metre).
  constexpr double kStep = 0.02, kFarthest = 6.0;
  Vec3 g = sc.goal;
  if (!field.isFree(g) || field.distance(g) < target) return;
  for (double s = kStep; s <= kFarthest; s += kStep) {
    const Vec3 p = sc.goal + s * toward;
    if (!field.isFree(p) || field.distance(p) < target) break;
    g = p;
  }
  // A ground robot's body on the floor there (a real rib bulges at the floor, where the field at
  // the drawn height does not see it): back toward the drawn goal until it fits at some heading.
  if (sc.params.robot.ground()) {
    const Vec3 back = sc.goal - g;
    const int steps = int(std::ceil(back.norm() / kStep));
    int k = 0;
    while (k < steps && !groundBodyFits(sc, truth, g, false)) g += back / double(steps), ++k;
    if (k == steps) return;
  }
  const double d = (g - sc.start).norm();
  if (d < params.min_separation_m || d > params.max_separation_m) return;
  for (const ScenarioEvent& e : sc.events)
    if ((g - e.center).norm() < e.radius_m + r + 1.0) return;
  sc.goal = g;
}

std::string number(double v) {
  if (!std::isfinite(v)) return "";
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.3f", v);
  return buf;
}

}  // namespace

Status BatchParams::validate() const {
  auto positive = [](double v) { return std::isfinite(v) && v > 0.0; };
  if (!positive(min_separation_m)) return invalidArgument("batch: min_separation_m must be > 0 (got " + std::to_string(min_separation_m) + ")");
  if (!positive(max_separation_m) || max_separation_m < min_separation_m)
    return invalidArgument("--max-separation (max_separation_m) must be >= min_separation_m (got " + std::to_string(max_separation_m) + ")");
  if (max_moving_obstacles < 0 || max_moving_obstacles > 100)
    return invalidArgument("batch: max_moving_obstacles must be in 0..100 (got " + std::to_string(max_moving_obstacles) + ")");
  if (!(roof_fall_probability >= 0.0 && roof_fall_probability <= 1.0))
    return invalidArgument("batch: roof_fall_probability must be in [0, 1] (got " + std::to_string(roof_fall_probability) + ")");
  if (!positive(roof_fall_radius_m)) return invalidArgument("batch: roof_fall_radius_m must be > 0 (got " + std::to_string(roof_fall_radius_m) + ")");
  if (!(std::isfinite(t_max_s) && t_max_s >= 0.0)) return invalidArgument("--t-max (t_max_s) must be >= 0 (got " + std::to_string(t_max_s) + ")");
  if (!(std::isfinite(vehicle_speed_min_mps) && vehicle_speed_min_mps >= 0.0 && std::isfinite(vehicle_speed_max_mps) &&
        vehicle_speed_max_mps >= vehicle_speed_min_mps))
    return invalidArgument("batch: vehicle speed range must satisfy 0 <= min <= max (got " +
                           std::to_string(vehicle_speed_min_mps) + ".." + std::to_string(vehicle_speed_max_mps) + ")");
  if (!positive(vehicle_radius_m)) return invalidArgument("batch: vehicle_radius_m must be > 0 (got " + std::to_string(vehicle_radius_m) + ")");
  // A range is unset (both 0) or 0 < min <= max.
  auto range = [&](double lo, double hi, const char* what) {
    if (lo == 0.0 && hi == 0.0) return Status();
    if (!positive(lo) || !positive(hi) || hi < lo)
      return invalidArgument(std::string("batch: ") + what + " range must satisfy 0 < min <= max (got " +
                             std::to_string(lo) + ".." + std::to_string(hi) + ")");
    return Status();
  };
  if (!(near_rock_goal_share >= 0.0 && near_rock_goal_share <= 1.0))
    return invalidArgument("batch: near_rock_goal_share must be in [0, 1] (got " + std::to_string(near_rock_goal_share) + ")");
  ADIT_RETURN_IF_ERROR(range(robot_radius_min_m, robot_radius_max_m, "robot radius"));
  ADIT_RETURN_IF_ERROR(range(robot_speed_min_mps, robot_speed_max_mps, "robot speed"));
  return Status();
}

std::uint64_t batchRunSeed(std::uint64_t seed, int index) {
  // SplitMix64 (Steele, Lea, Flood 2014) of the seed advanced by the index: neighbouring
  // indices give unrelated streams.
  std::uint64_t z = seed + 0x9E3779B97F4A7C15ull * (std::uint64_t(index) + 1);
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  return z ^ (z >> 31);
}

BatchRoadways BatchRoadways::fromSurvey(const map::SurveyNetwork& survey) {
  BatchRoadways out;
  out.source = "survey";
  out.lift = Vec3(0, 0, kCentreAboveFloorM);
  for (const map::SurveyRoadway& r : survey.roadways) {
    out.axes.push_back(survey.centreline(r));
    const auto section = survey.sections.find(r.section);
    out.widths_m.push_back(section != survey.sections.end() ? 2.0 * section->second.halfWidthAt(kCentreAboveFloorM) : 0.0);
  }
  return out;
}

StatusOr<BatchRoadways> BatchRoadways::fromFreeSpace(const map::OccupancyMap& map, const map::DistanceField& field,
                                                     double clearance_m) {
  ADIT_ASSIGN_OR_RETURN(const global::RoadwayGraph graph,
                        global::RoadwayGraph::fromFreeSpace(map, field, clearance_m, 1.0));
  BatchRoadways out;
  out.source = "free_space";
  for (const global::RoadwayEdge& e : graph.edges()) {
    out.axes.push_back(e.axis);
    out.widths_m.push_back(global::measurePassage(e, field).width_m);
  }
  return out;
}

double BatchRoadways::widthAt(const Vec3& p) const {
  double best = std::numeric_limits<double>::infinity(), width = 0.0;
  for (std::size_t i = 0; i < axes.size(); ++i) {
    if (axes[i].empty()) continue;
    const double d = (axes[i].nearestPoint(p) - p).norm();
    if (d < best) best = d, width = widths_m[i];
  }
  return width;
}

StatusOr<Scenario> makeBatchScenario(const Scenario& base, const map::SurveyNetwork& survey,
                                            const Environment& truth, const BatchParams& params, int index) {
  return makeBatchScenario(base, BatchRoadways::fromSurvey(survey), truth, params, index);
}

namespace {
std::string jsonString(const std::string& text) {
  std::string out = "\"";
  for (const char c : text) {
    if (c == '"' || c == '\\') {
      out += '\\';
      out += c;
    } else if (static_cast<unsigned char>(c) < 0x20) {
      char buf[8];
      std::snprintf(buf, sizeof buf, "\\u%04x", unsigned(static_cast<unsigned char>(c)));
      out += buf;
    } else {
      out += c;
    }
  }
  return out + "\"";
}
// The shortest text that reads back as x.
std::string jsonNumber(double x) {
  char buf[32];
  const auto [end, ec] = std::to_chars(buf, buf + sizeof buf, x);
  return ec == std::errc() ? std::string(buf, end) : "0";
}
}  // namespace

StatusOr<BatchRobot> robotFromJson(const std::string& robot_json) {
  // JSON is YAML: the robot mapping goes through the scenario reader, in a scenario of its own.
  StatusOr<Scenario> sc =
      parseScenario("start: [0, 0, 0]\ngoal: [1, 0, 0]\nmethod: tian2016\nrobot: " + robot_json + "\n", "robot");
  if (!sc.ok()) {
    // "robot:3:9: robot.height: ..." -> "robot.height: ...": the caller says where the mapping is.
    std::string m = sc.status().message();
    const std::size_t at = m.find("robot.");
    return invalidArgument(at != std::string::npos ? m.substr(at) : m);
  }
  return BatchRobot{sc->params.robot, sc->sensor_range_m};
}

StatusOr<Scenario> makeBatchScenario(const Scenario& base, const BatchRoadways& roadways,
                                            const Environment& truth, const BatchParams& params, int index) {
  ADIT_RETURN_IF_ERROR(params.validate());
  if (index < 0) return invalidArgument("batch: run index must be >= 0 (got " + std::to_string(index) + ")");
  if (!truth.field()) return invalidArgument(base.file + ": map: a batch needs a map");
  const std::vector<Segment> segs = segments(roadways);
  if (segs.empty())
    return invalidArgument(base.file + ": map: " +
                           (roadways.source == "survey" ? "the survey has no roadway" : "the map has no passage for the robot"));
  const std::uint64_t run_seed = batchRunSeed(params.seed, index);
  Drawer draw(segs, roadways.lift, run_seed);
  Scenario sc = base;
  if (!params.robot_json.empty()) {
    ADIT_ASSIGN_OR_RETURN(const BatchRobot robot, robotFromJson(params.robot_json));
    sc.params.robot = robot.limits;
    if (robot.sensor_range_m) sc.sensor_range_m = robot.sensor_range_m;  // else the base's sensor
  }
  if (params.robot_radius_max_m > 0.0 || params.robot_speed_max_mps > 0.0) {
    // A stream of its own: the draws below stay those of a run without robot ranges.
    std::mt19937_64 robot_rng(batchRunSeed(run_seed ^ 0x524F424F54ull, 0));
    auto uniform = [&robot_rng](double lo, double hi) {
      return lo == hi ? lo : std::uniform_real_distribution<double>(lo, hi)(robot_rng);
    };
    if (params.robot_radius_max_m > 0.0)
      sc.params.robot.radius_m = uniform(params.robot_radius_min_m, params.robot_radius_max_m);
    if (params.robot_speed_max_mps > 0.0)
      sc.params.robot.v_max_mps = uniform(params.robot_speed_min_mps, params.robot_speed_max_mps);
  }
  const double r = sc.params.robot.radius_m;
  const double v_max = sc.params.robot.v_max_mps;
  auto roomy = [&](const Vec3& p) { return truth.field()->isFree(p) && truth.field()->distance(p) > r + 0.4; };
  // A ground robot's start lets it turn on the spot, and it can stand at its goal (a real mine's
  // rib may bulge at the floor where the field at the drawn height sees room).
  const bool ground = sc.params.robot.ground();
  auto fitsAt = [&](const Vec3& p, bool everywhere) { return !ground || groundBodyFits(sc, truth, p, everywhere); };

  sc.name = "batch-" + std::to_string(index);
  sc.seed = run_seed;
  sc.plan_expected_path = true;
  sc.expected_path.points.clear();
  sc.moving_obstacles.clear();
  sc.events.clear();
  bool found = false;
  Vec3 goal_direction = Vec3::UnitX();  // along the goal's roadway
  for (int k = 0; k < kMaxDraws && !found; ++k) {
    const RoadwayPoint sp = draw.point(), gp = draw.point();
    const Vec3 s = sp.position, g = gp.position;
    const double d = (g - s).norm();
    if (d < params.min_separation_m || d > params.max_separation_m || !roomy(s) || !roomy(g)) continue;
    if (!fitsAt(s, true) || !fitsAt(g, false)) continue;
    sc.start = s;
    sc.goal = g;
    goal_direction = gp.direction;
    found = true;
  }
  if (!found)
    return invalidArgument(base.file + ": map: no start/goal pair " + std::to_string(params.min_separation_m) + ".." +
                           std::to_string(params.max_separation_m) + " m apart on the roadways in " +
                           std::to_string(kMaxDraws) + " draws");
  const double dist = (sc.goal - sc.start).norm();
  sc.t_max_s = params.t_max_s > 0.0 ? params.t_max_s : 120.0 + 6.0 * dist / v_max;

  // Vehicles: on a roadway away from the start, driving along it either way.
  const int vehicles = draw.integer(0, params.max_moving_obstacles);
  for (int v = 0; v < vehicles; ++v) {
    for (int k = 0; k < kMaxDraws; ++k) {
      const RoadwayPoint p = draw.point();
      const double speed = draw.uniform(params.vehicle_speed_min_mps, params.vehicle_speed_max_mps) * (draw.integer(0, 1) ? 1.0 : -1.0);
      if ((p.position - sc.start).norm() < 10.0 || !roomy(p.position)) continue;
      NamedObstacle o;
      o.name = "vehicle-" + std::to_string(v + 1);
      o.obstacle.shape = map::RobotShape::sphere(params.vehicle_radius_m);
      o.obstacle.position = p.position;
      o.obstacle.velocity = speed * p.direction;
      sc.moving_obstacles.push_back(o);
      break;
    }
  }

  // A roof fall on a roadway between start and goal (the box they span, grown by 10 m), clear of
  // both ends, while the robot is on its way.
  if (draw.uniform(0.0, 1.0) < params.roof_fall_probability) {
    map::Aabb box(sc.start, sc.start);
    box.extend(sc.goal);
    box = box.inflated(10.0);
    const double keep_off = params.roof_fall_radius_m + r + 3.0;
    for (int k = 0; k < kMaxDraws; ++k) {
      const Vec3 c = draw.point().position;
      if (!box.contains(c) || (c - sc.start).norm() < keep_off || (c - sc.goal).norm() < keep_off) continue;
      ScenarioEvent e;
      e.t_s = draw.uniform(2.0, 2.0 + 0.5 * dist / v_max);
      e.center = c;
      e.radius_m = params.roof_fall_radius_m;
      sc.events.push_back(e);
      break;
    }
  }
  if (params.near_rock_goal_share > 0.0) moveGoalNearRock(sc, goal_direction, truth, params, run_seed);
  sc.expected_path.points = {sc.start, sc.goal};
  ADIT_RETURN_IF_ERROR(sc.validate());
  return sc;
}

StatusOr<BatchParams> parseBatchParams(const std::string& yaml_text, const std::string& file,
                                       const BatchParams& defaults) {
  YAML::Node root;
  try {
    root = YAML::Load(yaml_text);
  } catch (const YAML::Exception& e) {
    return invalidArgument(file + ":" + std::to_string(e.mark.line + 1) + ": not YAML: " + e.msg);
  }
  if (!root.IsDefined() || root.IsNull()) return defaults;
  if (!root.IsMap()) return invalidArgument(file + ": the generator must be a YAML mapping");
  auto where = [&file](const YAML::Node& n, const std::string& key) {
    return file + ":" + std::to_string(n.Mark().line + 1) + ": " + key;
  };
  auto number = [&](const YAML::Node& n, const std::string& key) -> StatusOr<double> {
    if (!n.IsScalar()) return invalidArgument(where(n, key) + ": expected a number");
    try {
      const double v = n.as<double>();
      if (!std::isfinite(v)) return invalidArgument(where(n, key) + ": must be finite (got " + n.Scalar() + ")");
      return v;
    } catch (const YAML::Exception&) {
      return invalidArgument(where(n, key) + ": expected a number (got '" + n.Scalar() + "')");
    }
  };
  auto pair = [&](const YAML::Node& n, const std::string& key, double& lo, double& hi) -> Status {
    if (!n.IsSequence() || n.size() != 2) return invalidArgument(where(n, key) + ": expected [min, max]");
    ADIT_ASSIGN_OR_RETURN(lo, number(n[0], key + "[0]"));
    ADIT_ASSIGN_OR_RETURN(hi, number(n[1], key + "[1]"));
    if (lo > hi) return invalidArgument(where(n, key) + ": min > max");
    return Status();
  };
  BatchParams p = defaults;
  for (const auto& kv : root) {
    if (!kv.first.IsScalar()) return invalidArgument(where(kv.first, "key") + ": expected a name");
    const std::string key = kv.first.Scalar();
    const YAML::Node& v = kv.second;
    if (key == "separation") {
      ADIT_RETURN_IF_ERROR(pair(v, key, p.min_separation_m, p.max_separation_m));
    } else if (key == "max_moving_obstacles") {
      ADIT_ASSIGN_OR_RETURN(const double n, number(v, key));
      if (n != std::floor(n) || n < 0 || n > 100) return invalidArgument(where(v, key) + ": expected an integer in 0..100");
      p.max_moving_obstacles = int(n);
    } else if (key == "vehicle_speed") {
      ADIT_RETURN_IF_ERROR(pair(v, key, p.vehicle_speed_min_mps, p.vehicle_speed_max_mps));
    } else if (key == "vehicle_radius") {
      ADIT_ASSIGN_OR_RETURN(p.vehicle_radius_m, number(v, key));
    } else if (key == "roof_fall") {
      if (!v.IsMap()) return invalidArgument(where(v, key) + ": expected {probability: P, radius: R}");
      for (const auto& f : v) {
        const std::string sub = f.first.IsScalar() ? f.first.Scalar() : std::string("?");
        if (sub == "probability") {
          ADIT_ASSIGN_OR_RETURN(p.roof_fall_probability, number(f.second, "roof_fall.probability"));
        } else if (sub == "radius") {
          ADIT_ASSIGN_OR_RETURN(p.roof_fall_radius_m, number(f.second, "roof_fall.radius"));
        } else {
          return invalidArgument(where(f.first, "roof_fall." + sub) + ": unknown key (probability, radius)");
        }
      }
    } else if (key == "robot_radius") {
      ADIT_RETURN_IF_ERROR(pair(v, key, p.robot_radius_min_m, p.robot_radius_max_m));
    } else if (key == "robot_speed") {
      ADIT_RETURN_IF_ERROR(pair(v, key, p.robot_speed_min_mps, p.robot_speed_max_mps));
    } else if (key == "t_max") {
      ADIT_ASSIGN_OR_RETURN(p.t_max_s, number(v, key));
    } else if (key == "near_rock_goals") {
      ADIT_ASSIGN_OR_RETURN(p.near_rock_goal_share, number(v, key));
    } else if (key == "robot") {
      // Kept as JSON (the campaign's identity records it so; a number stays a number, anything
      // else a string), and read now, so that a mistake is said with this file and line.
      if (!v.IsMap()) return invalidArgument(where(v, key) + ": expected a mapping, as a scenario's robot");
      std::string robot = "{";
      for (const auto& f : v) {
        if (!f.first.IsScalar() || !f.second.IsScalar())
          return invalidArgument(where(f.first, "robot") + ": expected name: value pairs");
        const std::string text = f.second.Scalar();
        double x = 0.0;
        const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), x);
        const bool numeric = f.second.Tag() != "!" && !text.empty() && ec == std::errc() &&
                             end == text.data() + text.size() && std::isfinite(x);
        if (robot.size() > 1) robot += ", ";
        robot += jsonString(f.first.Scalar()) + ": " + (numeric ? jsonNumber(x) : jsonString(text));
      }
      p.robot_json = robot + "}";
      if (StatusOr<BatchRobot> r = robotFromJson(p.robot_json); !r.ok())
        return invalidArgument(where(v, key) + ": " + r.status().message());
    } else {
      return invalidArgument(where(kv.first, key) +
                             ": unknown key (separation, max_moving_obstacles, vehicle_speed, vehicle_radius, "
                             "roof_fall, robot_radius, robot_speed, t_max, near_rock_goals, robot)");
    }
  }
  if (!p.robot_json.empty() && p.robot_radius_max_m > 0.0) {
    ADIT_ASSIGN_OR_RETURN(const BatchRobot r, robotFromJson(p.robot_json));
    if (r.limits.ground())
      return invalidArgument(file + ": robot_radius: a ground robot's size is its footprint (robot.footprint)");
  }
  if (Status s = p.validate(); !s.ok()) return invalidArgument(file + ": " + s.message());
  return p;
}

double roadwayWidthAt(const map::SurveyNetwork& survey, const map::Vec3& p) {
  return BatchRoadways::fromSurvey(survey).widthAt(p);
}

BatchRunResult runBatchScenario(const Scenario& scenario, const Environment& truth, int index,
                                const map::World* believed) {
  BatchRunResult out;
  out.index = index;
  out.seed = scenario.seed;
  out.vehicles = int(scenario.moving_obstacles.size());
  out.roof_fall = !scenario.events.empty();
  out.separation_m = (scenario.goal - scenario.start).norm();
  out.robot_radius_m = scenario.params.robot.radius_m;
  out.robot_speed_mps = scenario.params.robot.v_max_mps;
  NavigatedOptions options;
  options.believed = believed;
  StatusOr<NavigatedRun> n = simulateNavigated(scenario, truth, options);
  if (!n.ok()) {
    out.outcome = "error";
    out.message = n.status().message();
    return out;
  }
  const SimulationResult& r = n->run;
  out.outcome = outcomeName(r.outcome);
  out.message = r.message;
  out.arrival_time_s = r.arrival_time_s;
  out.path_length_m = r.path_length_m;
  out.min_clearance_m = r.min_clearance_m;
  out.collisions = r.collisions;
  out.replans = n->replans;
  out.step_p50_us = r.step_time_p50_us;
  out.step_p99_us = r.step_time_p99_us;
  out.final_goal_distance_m = r.final_goal_distance_m;
  out.arrival_tolerance_m = r.arrival_tolerance_m;
  out.end_cause = r.end_cause;
  return out;
}

const char* batchCsvHeader() {
  return "index,seed,outcome,arrival_time,path_length,min_clearance,replans,step_p50_us,step_p99_us,"
         "collisions,final_goal_distance,arrival_tolerance,vehicles,roof_fall,separation,robot_radius,robot_speed,"
         "roadway_width,end_cause";
}

std::string batchCsvRow(const BatchRunResult& r) {
  return std::to_string(r.index) + "," + std::to_string(r.seed) + "," + r.outcome + "," + number(r.arrival_time_s) +
         "," + number(r.path_length_m) + "," + number(r.min_clearance_m) + "," + std::to_string(r.replans) + "," +
         number(r.step_p50_us) + "," + number(r.step_p99_us) + "," + std::to_string(r.collisions) + "," +
         number(r.final_goal_distance_m) + "," + number(r.arrival_tolerance_m) + "," + std::to_string(r.vehicles) +
         "," + (r.roof_fall ? "1" : "0") + "," + number(r.separation_m) + "," + number(r.robot_radius_m) + "," +
         number(r.robot_speed_mps) + "," + number(r.roadway_width_m) + "," + endCauseName(r.end_cause);
}

namespace {

constexpr int kCsvColumns = 19;
const char* const kCsvColumnNames[kCsvColumns] = {
    "index",      "seed",        "outcome",           "arrival_time", "path_length", "min_clearance",
    "replans",    "step_p50_us", "step_p99_us",       "collisions",   "final_goal_distance",
    "arrival_tolerance", "vehicles", "roof_fall",     "separation",   "robot_radius", "robot_speed",
    "roadway_width", "end_cause"};

std::string columnError(int c, std::string_view text, const char* why) {
  std::string shown(text.substr(0, 40));
  if (text.size() > 40) shown += "...";
  return std::string("column ") + std::to_string(c + 1) + " (" + kCsvColumnNames[c] + "): '" + shown + "' " + why;
}

// A decimal integer in [0, hi]: digits only (no sign, no spaces), checked before it can wrap.
StatusOr<std::uint64_t> csvInteger(std::string_view s, int c, std::uint64_t hi) {
  if (s.empty() || s.size() > 20) return invalidArgument(columnError(c, s, "is not an integer"));
  std::uint64_t v = 0;
  const auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
  if (ec == std::errc::result_out_of_range || (ec == std::errc() && v > hi))
    return invalidArgument(columnError(c, s, ("is beyond " + std::to_string(hi)).c_str()));
  if (ec != std::errc() || end != s.data() + s.size()) return invalidArgument(columnError(c, s, "is not an integer"));
  return v;
}

// A finite decimal number in [lo, hi]; empty gives `empty` when that is allowed (not NaN).
StatusOr<double> csvNumber(std::string_view s, int c, double lo, double hi, std::optional<double> empty = {}) {
  if (s.empty()) {
    if (empty) return *empty;
    return invalidArgument(columnError(c, s, "is empty"));
  }
  double v = 0.0;
  const auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), v, std::chars_format::fixed);
  if (ec != std::errc() || end != s.data() + s.size() || !std::isfinite(v))
    return invalidArgument(columnError(c, s, "is not a number"));
  if (v < lo || v > hi) return invalidArgument(columnError(c, s, "is out of range"));
  return v;
}

}  // namespace

StatusOr<BatchRunResult> parseBatchCsvRow(std::string_view line) {
  if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
  std::string_view f[kCsvColumns];
  int n = 0;
  std::size_t from = 0;
  for (;;) {
    const std::size_t comma = line.find(',', from);
    if (n == kCsvColumns)
      return invalidArgument("more than " + std::to_string(kCsvColumns) + " columns (" + batchCsvHeader() + ")");
    f[n++] = line.substr(from, comma == std::string_view::npos ? std::string_view::npos : comma - from);
    if (comma == std::string_view::npos) break;
    from = comma + 1;
  }
  if (n != kCsvColumns)
    return invalidArgument(std::to_string(n) + " columns, expected " + std::to_string(kCsvColumns) + " (" +
                           batchCsvHeader() + ")");
  constexpr double kLength = 1e9, kTime = 1e9, kStepUs = 1e12;
  constexpr std::uint64_t kInt = std::numeric_limits<int>::max();
  BatchRunResult r;
  ADIT_ASSIGN_OR_RETURN(const std::uint64_t index, csvInteger(f[0], 0, kInt));
  r.index = int(index);
  ADIT_ASSIGN_OR_RETURN(r.seed, csvInteger(f[1], 1, std::numeric_limits<std::uint64_t>::max()));
  bool known = f[2] == "error";
  for (Outcome o : {Outcome::kArrived, Outcome::kCollision, Outcome::kStuck,
                           Outcome::kTimeout, Outcome::kNoRoute, Outcome::kHitByFall,
                           Outcome::kHitByMover})
    known = known || f[2] == outcomeName(o);
  if (!known) return invalidArgument(columnError(2, f[2], "is not an outcome (arrived, collision, stuck, timeout, no_route, hit_by_fall, hit_by_mover, error)"));
  r.outcome = std::string(f[2]);
  const double nan = std::numeric_limits<double>::quiet_NaN(), inf = std::numeric_limits<double>::infinity();
  ADIT_ASSIGN_OR_RETURN(r.arrival_time_s, csvNumber(f[3], 3, 0.0, kTime, nan));
  ADIT_ASSIGN_OR_RETURN(r.path_length_m, csvNumber(f[4], 4, 0.0, kLength));
  ADIT_ASSIGN_OR_RETURN(r.min_clearance_m, csvNumber(f[5], 5, -kLength, kLength, inf));
  ADIT_ASSIGN_OR_RETURN(const std::uint64_t replans, csvInteger(f[6], 6, kInt));
  r.replans = int(replans);
  ADIT_ASSIGN_OR_RETURN(r.step_p50_us, csvNumber(f[7], 7, 0.0, kStepUs));
  ADIT_ASSIGN_OR_RETURN(r.step_p99_us, csvNumber(f[8], 8, 0.0, kStepUs));
  ADIT_ASSIGN_OR_RETURN(const std::uint64_t collisions, csvInteger(f[9], 9, kInt));
  r.collisions = int(collisions);
  ADIT_ASSIGN_OR_RETURN(r.final_goal_distance_m, csvNumber(f[10], 10, 0.0, kLength, nan));
  ADIT_ASSIGN_OR_RETURN(r.arrival_tolerance_m, csvNumber(f[11], 11, 0.0, kLength));
  ADIT_ASSIGN_OR_RETURN(const std::uint64_t vehicles, csvInteger(f[12], 12, kInt));
  r.vehicles = int(vehicles);
  ADIT_ASSIGN_OR_RETURN(const std::uint64_t roof_fall, csvInteger(f[13], 13, 1));
  r.roof_fall = roof_fall == 1;
  ADIT_ASSIGN_OR_RETURN(r.separation_m, csvNumber(f[14], 14, 0.0, kLength));
  ADIT_ASSIGN_OR_RETURN(r.robot_radius_m, csvNumber(f[15], 15, 0.0, kLength));
  ADIT_ASSIGN_OR_RETURN(r.robot_speed_mps, csvNumber(f[16], 16, 0.0, kLength));
  ADIT_ASSIGN_OR_RETURN(r.roadway_width_m, csvNumber(f[17], 17, 0.0, kLength));
  const std::optional<EndCause> cause = endCauseFromName(f[18]);
  if (!cause)
    return invalidArgument(columnError(18, f[18], "is not an end cause (empty, route_outlasts_t_max, short_of_goal, en_route)"));
  r.end_cause = *cause;
  const bool needs_cause = r.outcome == "timeout" || r.outcome == "stuck";
  if (needs_cause != (r.end_cause != EndCause::kNone))
    return invalidArgument(columnError(18, f[18], needs_cause ? "is empty for a timeout or stuck run" : "is given for an outcome that has none"));
  return r;
}

}  // namespace adit::sim
