// SPDX-License-Identifier: BSD-3-Clause
#include "adit/sim/scenario.hpp"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <initializer_list>
#include <sstream>

#include "adit/map/map_io.hpp"

namespace adit::sim {

using local::DriveType;
using local::Footprint;
using local::LocalParams;
using local::Method;
using local::RobotLimits;
using local::RobotMode;
using local::StaticSphere;
using local::parseDriveType;
using local::parseFootprint;
using local::parseMethod;
using local::parseRobotMode;
using map::allFinite;

namespace {

namespace fs = std::filesystem;

// The selection runs at the start of a period, so t0 must be a whole number (>= 1) of steps.
Status subgoalPeriodStatus(double t0, double dt) {
  const double steps = t0 / dt;
  if (std::isfinite(t0) && t0 >= dt && std::abs(steps - std::round(steps)) <= 1e-6 * steps) return {};
  std::ostringstream os;
  os << "must be a multiple of dt = " << dt << " (got " << t0 << ")";
  return invalidArgument(os.str());
}

// Parse errors carry the position of the node they are about; yaml-cpp's own exceptions are caught
// at the boundary (parseScenario) and converted, so nothing escapes the library.
struct ScenarioError {
  Status status;
};

class Reader {
 public:
  explicit Reader(std::string file) : file_(std::move(file)) {}

  [[noreturn]] void fail(const YAML::Node& node, const std::string& field, const std::string& what) const {
    std::ostringstream os;
    os << file_;
    if (node.IsDefined() && node.Mark().line >= 0) os << ":" << node.Mark().line + 1 << ":" << node.Mark().column + 1;
    os << ": " << field << ": " << what;
    throw ScenarioError{invalidArgument(os.str())};
  }

  void onlyKeys(const YAML::Node& map, const std::string& field, std::initializer_list<const char*> keys) const {
    if (!map.IsMap()) fail(map, field, "must be a mapping");
    noDuplicateKeys(map, field);
    for (const auto& kv : map) {
      const std::string k = kv.first.as<std::string>();
      bool known = false;
      for (const char* allowed : keys) known = known || k == allowed;
      if (!known) fail(kv.first, field.empty() ? k : field + "." + k, "unknown field");
    }
  }

  // yaml-cpp keeps a repeated key and answers lookups with the first: a second `goal:` further
  // down would be silently ignored. A mapping says each thing once.
  void noDuplicateKeys(const YAML::Node& map, const std::string& field) const {
    std::vector<std::string> seen;
    for (const auto& kv : map) {
      const std::string k = kv.first.as<std::string>();
      if (std::find(seen.begin(), seen.end(), k) != seen.end())
        fail(kv.first, field.empty() ? k : field + "." + k, "given twice (a mapping names each field once)");
      seen.push_back(k);
    }
  }

  double number(const YAML::Node& n, const std::string& field) const {
    if (!n.IsScalar()) fail(n, field, "must be a number");
    const std::string s = n.Scalar();
    double v = 0.0;
    try {
      std::size_t used = 0;
      v = std::stod(s, &used);
      if (used != s.size()) fail(n, field, "'" + s + "' is not a number");
    } catch (const std::logic_error&) {
      fail(n, field, "'" + s + "' is not a number");
    }
    if (!std::isfinite(v)) fail(n, field, "'" + s + "' is not finite");
    // Finite is not enough: 1e308 squared is infinite, and would surface as an internal error deep
    // in a force computation instead of here, naming the field.
    if (std::abs(v) > kMaxMagnitude) fail(n, field, "'" + s + "' is out of range (|value| <= 1e12)");
    return v;
  }

  // A number in [lo, hi], the range a physical quantity can have.
  double within(const YAML::Node& n, const std::string& field, double lo, double hi, const char* unit) const {
    const double v = number(n, field);
    if (!(v >= lo && v <= hi)) {
      std::ostringstream os;
      os << "must be in [" << lo << ", " << hi << "] " << unit << " (got " << n.Scalar() << ")";
      fail(n, field, os.str());
    }
    return v;
  }

  // A seed: every unsigned 64-bit value, written as digits, taken exactly (a double would round
  // seeds above 2^53 and wrap those above 2^64).
  std::uint64_t seed(const YAML::Node& n, const std::string& field) const {
    if (!n.IsScalar()) fail(n, field, "must be an integer");
    const std::string s = n.Scalar();
    if (s.empty() || s.size() > 20 || !std::all_of(s.begin(), s.end(), [](char c) { return c >= '0' && c <= '9'; }))
      fail(n, field, "must be an integer 0..18446744073709551615 written in digits (got '" + s + "')");
    std::uint64_t v = 0;
    for (char c : s) {
      const std::uint64_t d = std::uint64_t(c - '0');
      if (v > (UINT64_MAX - d) / 10) fail(n, field, "'" + s + "' is larger than 18446744073709551615");
      v = v * 10 + d;
    }
    return v;
  }

  double positive(const YAML::Node& n, const std::string& field) const {
    const double v = number(n, field);
    if (!(v > 0.0)) fail(n, field, "must be > 0 (got " + n.Scalar() + ")");
    return v;
  }

  double nonNegative(const YAML::Node& n, const std::string& field) const {
    const double v = number(n, field);
    if (!(v >= 0.0)) fail(n, field, "must be >= 0 (got " + n.Scalar() + ")");
    return v;
  }

  // A point or a vector; no mine, and no survey grid, is 10,000 km from its origin.
  Vec3 vec3(const YAML::Node& n, const std::string& field, double max_abs = kMaxCoordinate) const {
    if (!n.IsSequence() || (n.size() != 3 && n.size() != 2)) fail(n, field, "must be [x, y, z] (or [x, y])");
    Vec3 v = Vec3::Zero();
    for (std::size_t i = 0; i < n.size(); ++i) {
      const std::string fi = field + "[" + std::to_string(i) + "]";
      v[int(i)] = within(n[i], fi, -max_abs, max_abs, "m");
    }
    return v;
  }

  template <class T>
  void setField(T& target, const YAML::Node& n, const std::string& field) const {
    if constexpr (std::is_same_v<T, bool>) {
      if (!n.IsScalar() || (n.Scalar() != "true" && n.Scalar() != "false")) fail(n, field, "must be true or false");
      target = n.Scalar() == "true";
    } else if constexpr (std::is_integral_v<T>) {
      const double v = number(n, field);
      if (v != std::floor(v)) fail(n, field, "must be an integer");
      target = T(v);
    } else {
      target = number(n, field);
    }
  }

  const std::string& file() const { return file_; }

  static constexpr double kMaxMagnitude = 1e12;
  static constexpr double kMaxCoordinate = 1e7;

 private:
  std::string file_;
};

// Applies one `params` entry to the struct whose visit() lists the key; false when none does.
struct FieldSetter {
  const Reader& reader;
  const std::string& key;
  const YAML::Node& value;
  bool found = false;
  template <class T>
  void operator()(const char* name, T& field) {
    if (key == name) {
      reader.setField(field, value, "params." + key);
      found = true;
    }
  }
};

Scenario parse(const YAML::Node& root, const Reader& r) {
  Scenario s;
  if (!root.IsMap()) r.fail(root, "(document)", "a scenario is a YAML mapping");
  r.onlyKeys(root, "", {"name", "description", "map", "start", "goal", "expected_path", "robot",
                        "static_obstacles", "moving_obstacles", "method", "params", "dt", "t_max", "seed", "events",
                        "subgoals", "subgoal_period", "preset"});
  s.file = r.file();
  s.name = root["name"] ? root["name"].as<std::string>() : fs::path(r.file()).stem().string();
  if (root["description"]) s.description = root["description"].as<std::string>();

  if (!root["method"]) r.fail(root, "method", "missing (classic, tian2016, wang2014, vff, cvff, uuv)");
  StatusOr<Method> method = parseMethod(root["method"].as<std::string>());
  if (!method.ok()) r.fail(root["method"], "method", method.status().message());
  if (const YAML::Node pr = root["preset"]) {
    if (!pr.IsScalar()) r.fail(pr, "preset", "must be default or paper");
    StatusOr<ParamsPreset> preset = parseParamsPreset(pr.Scalar());
    if (!preset.ok()) r.fail(pr, "preset", preset.status().message());
    s.preset = *preset;
  }
  s.params = s.preset == ParamsPreset::kPaper ? LocalParams::paper(*method) : LocalParams::preset(*method);

  if (const YAML::Node m = root["map"]) {
    const std::string p = m.as<std::string>();
    // Relative to the scenario's own folder first, so that a scenario means the same map from
    // wherever it is run; the working directory only when the scenario's folder has no such file
    // (scripts written when that came first).
    fs::path resolved = p;
    if (fs::path(p).is_relative()) {
      const fs::path beside = fs::path(r.file()).parent_path() / p;
      if (fs::exists(beside) || !fs::exists(resolved)) resolved = beside.lexically_normal();
    }
    if (!fs::exists(resolved)) r.fail(m, "map", "no such file '" + p + "' (relative to the scenario, or to the working directory)");
    s.map_path = resolved.string();
  }
  for (const char* k : {"start", "goal"})
    if (!root[k]) r.fail(root, k, "missing");
  s.start = r.vec3(root["start"], "start");
  s.goal = r.vec3(root["goal"], "goal");
  if (const YAML::Node p = root["expected_path"]; p && p.IsScalar()) {
    if (p.Scalar() != "plan") r.fail(p, "expected_path", "must be a list of points or 'plan' (got '" + p.Scalar() + "')");
    s.plan_expected_path = true;
    s.expected_path.points = {s.start, s.goal};
  } else if (p) {
    if (!p.IsSequence() || p.size() < 1) r.fail(p, "expected_path", "must be a list of at least one point");
    for (std::size_t i = 0; i < p.size(); ++i)
      s.expected_path.points.push_back(r.vec3(p[i], "expected_path[" + std::to_string(i) + "]"));
    if ((s.expected_path.points.back() - s.goal).norm() > 1e-6)
      r.fail(p[p.size() - 1], "expected_path", "must end at the goal");
  } else {
    s.expected_path.points = {s.start, s.goal};
  }

  if (const YAML::Node rb = root["robot"]) {
    r.onlyKeys(rb, "robot", {"radius", "v_max", "a_max", "sensor_range", "mode", "drive", "footprint", "height",
                             "omega_max", "alpha_max", "max_slope_deg", "max_step", "max_steer_deg", "wheelbase"});
    // Ranges a robot in a mine can have (a sensor to the horizon, a vehicle at highway speed, 10 g).
    auto limit = [&](const char* key, double hi, const char* unit, auto& target) {
      if (!rb[key]) return;
      const std::string field = std::string("robot.") + key;
      r.positive(rb[key], field);
      target = r.within(rb[key], field, 0.0, hi, unit);
    };
    limit("sensor_range", 1e4, "m", s.sensor_range_m);
    limit("radius", 100.0, "m", s.params.robot.radius_m);
    limit("v_max", 100.0, "m/s", s.params.robot.v_max_mps);
    limit("a_max", 100.0, "m/s^2", s.params.robot.a_max_mps2);
    RobotLimits& robot = s.params.robot;
    if (const YAML::Node m = rb["mode"]) {
      if (!m.IsScalar()) r.fail(m, "robot.mode", "must be fly or ground");
      StatusOr<RobotMode> mode = parseRobotMode(m.Scalar());
      if (!mode.ok()) r.fail(m, "robot.mode", mode.status().message());
      robot.mode = *mode;
    }
    const char* ground_keys[] = {"drive", "footprint", "height", "omega_max", "alpha_max", "max_slope_deg",
                                 "max_step", "max_steer_deg", "wheelbase"};
    if (!robot.ground())
      for (const char* k : ground_keys)
        if (rb[k]) r.fail(rb[k], std::string("robot.") + k, "only for a ground robot (robot.mode: ground)");
    if (const YAML::Node d = rb["drive"]) {
      StatusOr<DriveType> drive = parseDriveType(d.IsScalar() ? d.Scalar() : "");
      if (!drive.ok()) r.fail(d, "robot.drive", drive.status().message());
      robot.drive = *drive;
    }
    if (const YAML::Node f = rb["footprint"]) {
      StatusOr<Footprint> fp = parseFootprint(f.IsScalar() ? f.Scalar() : "");
      if (!fp.ok()) r.fail(f, "robot.footprint", fp.status().message());
      robot.footprint = *fp;
      if (rb["radius"] && rb["radius"].as<double>() < fp->circumradius() - 1e-9)
        r.fail(rb["radius"], "robot.radius", "less than the footprint's circumradius " + std::to_string(fp->circumradius()));
    } else if (robot.ground()) {
      robot.footprint.radius_m = robot.radius_m;  // circle:radius
    }
    if (robot.ground()) {
      limit("height", 20.0, "m", robot.height_m);
      limit("omega_max", 100.0, "rad/s", robot.omega_max_rps);
      limit("alpha_max", 1000.0, "rad/s^2", robot.alpha_max_rps2);
      limit("max_slope_deg", 59.0, "deg", robot.max_slope_deg);
      limit("max_step", 10.0, "m", robot.max_step_m);
      limit("max_steer_deg", 79.0, "deg", robot.max_steer_deg);
      limit("wheelbase", 20.0, "m", robot.wheelbase_m);
      // The field's circle holds the footprint at any heading.
      if (!rb["radius"] || robot.radius_m < robot.footprint.circumradius()) robot.radius_m = robot.footprint.circumradius();
      if (robot.max_step_m >= robot.height_m)
        r.fail(rb["max_step"] ? rb["max_step"] : rb, "robot.max_step", "must be less than robot.height");
    }
  }
  if (const YAML::Node list = root["static_obstacles"]) {
    if (!list.IsSequence()) r.fail(list, "static_obstacles", "must be a list");
    for (std::size_t i = 0; i < list.size(); ++i) {
      const std::string f = "static_obstacles[" + std::to_string(i) + "]";
      r.onlyKeys(list[i], f, {"center", "radius"});
      if (!list[i]["center"]) r.fail(list[i], f + ".center", "missing");
      StaticSphere o;
      o.center = r.vec3(list[i]["center"], f + ".center");
      o.radius = list[i]["radius"] ? r.positive(list[i]["radius"], f + ".radius") : 0.5;
      s.static_obstacles.push_back(o);
    }
  }
  if (const YAML::Node list = root["moving_obstacles"]) {
    if (!list.IsSequence()) r.fail(list, "moving_obstacles", "must be a list");
    for (std::size_t i = 0; i < list.size(); ++i) {
      const std::string f = "moving_obstacles[" + std::to_string(i) + "]";
      const YAML::Node o = list[i];
      r.onlyKeys(o, f, {"name", "start", "velocity", "acceleration", "radius", "shape", "size", "length"});
      if (!o["start"]) r.fail(o, f + ".start", "missing");
      NamedObstacle m;
      m.name = o["name"] ? o["name"].as<std::string>() : "obstacle " + std::to_string(i + 1);
      m.obstacle.position = r.vec3(o["start"], f + ".start");
      if (o["velocity"]) m.obstacle.velocity = r.vec3(o["velocity"], f + ".velocity");
      if (o["acceleration"]) m.obstacle.acceleration = r.vec3(o["acceleration"], f + ".acceleration");
      const std::string shape = o["shape"] ? o["shape"].as<std::string>() : "sphere";
      const double radius = o["radius"] ? r.positive(o["radius"], f + ".radius") : 0.3;
      if (shape == "sphere") {
        m.obstacle.shape = map::RobotShape::sphere(radius);
      } else if (shape == "box") {
        if (!o["size"]) r.fail(o, f + ".size", "missing (a box needs size: [x, y, z])");
        const Vec3 size = r.vec3(o["size"], f + ".size");
        if (!(size.array() > 0).all()) r.fail(o["size"], f + ".size", "every edge must be > 0");
        m.obstacle.shape = map::RobotShape::box(size);
      } else if (shape == "cylinder") {
        if (!o["length"]) r.fail(o, f + ".length", "missing (a cylinder needs length)");
        m.obstacle.shape = map::RobotShape::cylinder(radius, r.positive(o["length"], f + ".length"));
      } else {
        r.fail(o["shape"], f + ".shape", "unknown shape '" + shape + "' (sphere, box, cylinder)");
      }
      s.moving_obstacles.push_back(m);
    }
  }
  if (const YAML::Node p = root["params"]) {
    if (!p.IsMap()) r.fail(p, "params", "must be a mapping");
    r.noDuplicateKeys(p, "params");
    for (const auto& kv : p) {
      const std::string key = kv.first.as<std::string>();
      FieldSetter set{r, key, kv.second};
      switch (s.params.method) {
        case Method::kClassic: s.params.classic.visit(set); break;
        case Method::kTian2016: s.params.tian2016.visit(set); break;
        case Method::kWang2014: s.params.wang2014.visit(set); break;
        case Method::kVff:
        case Method::kCvff: s.params.vff.visit(set); break;
        case Method::kUuv: s.params.uuv.visit(set); break;
      }
      s.params.monitor.visit(set);
      s.params.terminal.visit(set);
      s.params.envelope.visit(set);
      s.params.pursuit.visit(set);
      if (!set.found)
        r.fail(kv.first, "params." + key, std::string("unknown field for method ") + methodName(s.params.method));
    }
  }
  if (const YAML::Node list = root["events"]) {
    if (!list.IsSequence()) r.fail(list, "events", "must be a list");
    for (std::size_t i = 0; i < list.size(); ++i) {
      const std::string f = "events[" + std::to_string(i) + "]";
      const YAML::Node e = list[i];
      r.onlyKeys(e, f, {"t", "type", "center", "radius"});
      for (const char* k : {"t", "type", "center", "radius"})
        if (!e[k]) r.fail(e, f + "." + k, "missing");
      ScenarioEvent ev;
      ev.t_s = r.nonNegative(e["t"], f + ".t");
      ev.type = e["type"].as<std::string>();
      if (ev.type != "roof_fall") r.fail(e["type"], f + ".type", "unknown event type '" + ev.type + "' (roof_fall)");
      ev.center = r.vec3(e["center"], f + ".center");
      ev.radius_m = r.positive(e["radius"], f + ".radius");
      s.events.push_back(ev);
    }
    std::stable_sort(s.events.begin(), s.events.end(),
                     [](const ScenarioEvent& a, const ScenarioEvent& b) { return a.t_s < b.t_s; });
  }
  if (const YAML::Node m = root["subgoals"]) {
    if (!m.IsScalar()) r.fail(m, "subgoals", "must be none or ga_trust_region");
    StatusOr<SubgoalMode> mode = parseSubgoalMode(m.Scalar());
    if (!mode.ok()) r.fail(m, "subgoals", mode.status().message());
    s.subgoal_mode = *mode;
  }
  if (root["dt"]) s.dt_s = r.positive(root["dt"], "dt");
  if (const YAML::Node n = root["subgoal_period"]) {
    s.subgoal_period_s = r.positive(n, "subgoal_period");
    if (Status st = subgoalPeriodStatus(s.subgoal_period_s, s.dt_s); !st.ok()) r.fail(n, "subgoal_period", st.message());
  }
  if (root["t_max"]) s.t_max_s = r.positive(root["t_max"], "t_max");
  if (root["seed"]) s.seed = r.seed(root["seed"], "seed");
  if (Status st = s.validate(); !st.ok()) r.fail(root, "(scenario)", st.message());
  return s;
}

}  // namespace

const char* paramsPresetName(ParamsPreset p) {
  switch (p) {
    case ParamsPreset::kDefault: return "default";
    case ParamsPreset::kPaper: return "paper";
  }
  return "?";
}

StatusOr<ParamsPreset> parseParamsPreset(const std::string& name) {
  for (ParamsPreset p : {ParamsPreset::kDefault, ParamsPreset::kPaper})
    if (name == paramsPresetName(p)) return p;
  return invalidArgument("unknown preset '" + name + "' (default, paper)");
}

const char* subgoalModeName(SubgoalMode m) {
  switch (m) {
    case SubgoalMode::kNone: return "none";
    case SubgoalMode::kGaTrustRegion: return "ga_trust_region";
  }
  return "?";
}

StatusOr<SubgoalMode> parseSubgoalMode(const std::string& name) {
  for (SubgoalMode m : {SubgoalMode::kNone, SubgoalMode::kGaTrustRegion})
    if (name == subgoalModeName(m)) return m;
  return invalidArgument("unknown sub-goal mode '" + name + "' (none, ga_trust_region)");
}

Status Scenario::validate() const {
  ADIT_RETURN_IF_ERROR(params.validate());
  if (expected_path.points.empty()) return invalidArgument("expected_path: empty");
  if (!(dt_s > 0.0) || !(t_max_s >= dt_s)) return invalidArgument("dt must be > 0 and t_max >= dt");
  if (t_max_s / dt_s > 1e7) return invalidArgument("t_max / dt: more than 10 million steps");
  if (Status st = subgoalPeriodStatus(subgoal_period_s, dt_s); !st.ok()) return invalidArgument("subgoal_period: " + st.message());
  const double r = params.robot.radius_m;
  for (std::size_t i = 0; i < static_obstacles.size(); ++i) {
    const StaticSphere& o = static_obstacles[i];
    if ((start - o.center).norm() < o.radius + r)
      return invalidArgument("start: the robot overlaps static_obstacles[" + std::to_string(i) + "]");
  }
  for (std::size_t i = 0; i < moving_obstacles.size(); ++i) {
    const map::MovingObstacle& o = moving_obstacles[i].obstacle;
    if ((start - o.position).norm() < o.shape.boundingRadius() + r)
      return invalidArgument("start: the robot overlaps moving_obstacles[" + std::to_string(i) + "] at t = 0");
  }
  return {};
}

StatusOr<Scenario> parseScenario(const std::string& text, const std::string& file) {
  try {
    const YAML::Node root = YAML::Load(text);
    // A survey map handed over as a scenario would fail on its first key ("resolution: unknown
    // field"); say what it is and what to do with it instead.
    if (root.IsMap() && root["stations"] && root["roadways"] && !root["start"])
      return invalidArgument(file + ": this is a survey map, not a scenario: name it as `map:` in a scenario, or plan on it "
                                    "with `adit plan --map " + file + "`");
    return parse(root, Reader(file));
  } catch (const ScenarioError& e) {
    return e.status;
  } catch (const YAML::Exception& e) {
    std::ostringstream os;
    os << file << ":" << e.mark.line + 1 << ":" << e.mark.column + 1 << ": " << e.msg;
    return invalidArgument(os.str());
  }
}

StatusOr<Scenario> loadScenario(const std::string& path) {
  ADIT_ASSIGN_OR_RETURN(const std::string text, map::readFile(path, std::size_t{16} << 20));
  return parseScenario(text, path);
}

}  // namespace adit::sim
