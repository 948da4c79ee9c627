// SPDX-License-Identifier: BSD-3-Clause
#include "adit/local/params.hpp"

#include <cmath>
#include <cstdlib>
#include <sstream>

namespace adit::local {

namespace {

// One rule per call: "Struct::field = value violates rule".
class Checker {
 public:
  explicit Checker(const char* owner) : owner_(owner) {}
  Checker& positive(const char* field, double v) { return rule(field, v, v > 0.0 && std::isfinite(v), "> 0"); }
  Checker& nonNegative(const char* field, double v) {
    return rule(field, v, v >= 0.0 && std::isfinite(v), ">= 0");
  }
  Checker& atLeast(const char* field, double v, double lo, const char* text) {
    return rule(field, v, v >= lo && std::isfinite(v), text);
  }
  Checker& rule(const char* field, double v, bool ok, const char* text) {
    if (!ok && status_.ok()) {
      std::ostringstream os;
      os << owner_ << "::" << field << " = " << v << " violates " << field << " " << text;
      status_ = invalidArgument(os.str());
    }
    return *this;
  }
  Status status() const { return status_; }

 private:
  const char* owner_;
  Status status_;
};

}  // namespace

const char* methodName(Method m) {
  switch (m) {
    case Method::kClassic: return "classic";
    case Method::kTian2016: return "tian2016";
    case Method::kWang2014: return "wang2014";
    case Method::kVff: return "vff";
    case Method::kCvff: return "cvff";
    case Method::kUuv: return "uuv";
  }
  return "?";
}

StatusOr<Method> parseMethod(const std::string& name) {
  for (Method m : {Method::kClassic, Method::kTian2016, Method::kWang2014, Method::kVff, Method::kCvff, Method::kUuv})
    if (name == methodName(m)) return m;
  return invalidArgument("unknown method '" + name + "' (classic, tian2016, wang2014, vff, cvff, uuv)");
}

Status ClassicParams::validate() const {
  return Checker("ClassicParams").nonNegative("xi", xi).nonNegative("eta", eta).positive("rho0_m", rho0_m).status();
}

Status Tian2016Params::validate() const {
  return Checker("Tian2016Params")
      .nonNegative("k_q", k_q).nonNegative("k_v", k_v).nonNegative("k_a", k_a).nonNegative("k_l", k_l)
      .atLeast("s", s, 1.0, ">= 1").atLeast("t", t, 1.0, ">= 1").atLeast("p", p, 1.0, ">= 1")
      .atLeast("l", l, 1.0, ">= 1")
      .nonNegative("K_q", K_q).nonNegative("K_v", K_v).nonNegative("K_a", K_a).positive("rho0_m", rho0_m)
      .status();
}

Status Wang2014Params::validate() const {
  return Checker("Wang2014Params")
      .nonNegative("k_att", k_att).nonNegative("K_2", K_2).nonNegative("n", n)
      .positive("view_range_m", view_range_m)
      .rule("view_half_angle_deg", view_half_angle_deg, view_half_angle_deg > 0 && view_half_angle_deg <= 180,
            "in (0, 180]")
      .positive("sensing_radius_m", sensing_radius_m)
      .nonNegative("approach_factor", approach_factor).nonNegative("recede_factor", recede_factor)
      .nonNegative("goal_factor_cap_m", goal_factor_cap_m)
      .status();
}

Status VffParams::validate() const {
  return Checker("VffParams")
      .nonNegative("K_p", K_p).nonNegative("K_v", K_v).nonNegative("M_p", M_p).nonNegative("M_v", M_v)
      .positive("p0_m", p0_m)
      .status();
}

Status UuvParams::validate() const {
  return Checker("UuvParams")
      .nonNegative("k_att", k_att).positive("conic_distance_m", conic_distance_m).nonNegative("k_rep", k_rep)
      .positive("rho0_m", rho0_m).nonNegative("rotation_gain", rotation_gain)
      .nonNegative("goal_factor_cap_m", goal_factor_cap_m)
      .status();
}

const char* robotModeName(RobotMode m) { return m == RobotMode::kGround ? "ground" : "fly"; }

StatusOr<RobotMode> parseRobotMode(const std::string& name) {
  if (name == "fly") return RobotMode::kFly;
  if (name == "ground") return RobotMode::kGround;
  return invalidArgument("unknown robot mode '" + name + "' (fly, ground)");
}

const char* driveTypeName(DriveType d) {
  switch (d) {
    case DriveType::kDifferential: return "differential";
    case DriveType::kSkid: return "skid";
    case DriveType::kAckermann: return "ackermann";
    case DriveType::kHolonomic: return "holonomic";
  }
  return "?";
}

StatusOr<DriveType> parseDriveType(const std::string& name) {
  for (DriveType d : {DriveType::kDifferential, DriveType::kSkid, DriveType::kAckermann, DriveType::kHolonomic})
    if (name == driveTypeName(d)) return d;
  return invalidArgument("unknown drive '" + name + "' (differential, skid, ackermann, holonomic)");
}

std::string Footprint::text() const {
  std::ostringstream os;
  if (box) os << "box:" << length_m << "," << width_m;
  else os << "circle:" << radius_m;
  return os.str();
}

Status Footprint::validate() const {
  Checker c("Footprint");
  if (box) c.positive("length_m", length_m).positive("width_m", width_m);
  else c.positive("radius_m", radius_m);
  return c.status();
}

StatusOr<Footprint> parseFootprint(const std::string& text) {
  const auto colon = text.find(':');
  const std::string kind = text.substr(0, colon), rest = colon == std::string::npos ? "" : text.substr(colon + 1);
  auto number = [&](const std::string& t, double* out) {
    char* end = nullptr;
    *out = std::strtod(t.c_str(), &end);
    return !t.empty() && end == t.c_str() + t.size() && std::isfinite(*out) && *out > 0.0 && *out <= 100.0;
  };
  Footprint f;
  if (kind == "circle") {
    if (!number(rest, &f.radius_m)) return invalidArgument("footprint '" + text + "': circle:R with 0 < R <= 100 m");
    return f;
  }
  if (kind == "box") {
    const auto comma = rest.find(',');
    f.box = true;
    if (comma == std::string::npos || !number(rest.substr(0, comma), &f.length_m) ||
        !number(rest.substr(comma + 1), &f.width_m))
      return invalidArgument("footprint '" + text + "': box:L,W with 0 < L, W <= 100 m");
    return f;
  }
  return invalidArgument("footprint '" + text + "': circle:R or box:L,W");
}

Status RobotLimits::validate() const {
  Checker c("RobotLimits");
  c.positive("radius_m", radius_m).positive("v_max_mps", v_max_mps).positive("a_max_mps2", a_max_mps2);
  if (ground()) {
    ADIT_RETURN_IF_ERROR(footprint.validate());
    c.positive("height_m", height_m).positive("omega_max_rps", omega_max_rps).positive("alpha_max_rps2", alpha_max_rps2)
        .rule("max_slope_deg", max_slope_deg, max_slope_deg >= 0 && max_slope_deg < 60, "in [0, 60)")
        .rule("max_step_m", max_step_m, max_step_m > 0 && max_step_m < height_m, "in (0, height_m)")
        .rule("max_steer_deg", max_steer_deg, max_steer_deg > 0 && max_steer_deg < 80, "in (0, 80)")
        .nonNegative("wheelbase_m", wheelbase_m)
        .rule("radius_m", radius_m, radius_m >= footprint.circumradius() - 1e-9,
              ">= the footprint's circumradius (the field's circle must hold the footprint)");
  }
  return c.status();
}

Status MonitorParams::validate() const {
  return Checker("MonitorParams")
      .positive("window_s", window_s).nonNegative("max_wait_s", max_wait_s)
      .nonNegative("min_progress_m", min_progress_m)
      .rule("max_escapes", max_escapes, max_escapes >= 0 && max_escapes <= 100, "in [0, 100]")
      .positive("escape_time_s", escape_time_s).positive("virtual_goal_offset_m", virtual_goal_offset_m)
      .positive("arrival_tolerance_m", arrival_tolerance_m).positive("subgoal_switch_m", subgoal_switch_m)
      .positive("full_speed_force", full_speed_force)
      .rule("prediction_horizon_s", prediction_horizon_s, prediction_horizon_s >= 0 && prediction_horizon_s <= 60,
            "in [0, 60]")
      .rule("safety_horizon_s", safety_horizon_s, safety_horizon_s >= 0 && safety_horizon_s <= 10, "in [0, 10]")
      .status();
}

Status TerminalParams::validate() const {
  return Checker("TerminalParams").positive("range_m", range_m).nonNegative("n", n).status();
}

Status EnvelopeParams::validate() const {
  return Checker("EnvelopeParams")
      .rule("keep_m", keep_m, keep_m >= 0 && keep_m <= 1, "in [0, 1]")
      .status();
}

Status PursuitParams::validate() const {
  return Checker("PursuitParams")
      .rule("lookahead_m", lookahead_m, lookahead_m >= 0.1 && lookahead_m <= 10, "in [0.1, 10]")
      .rule("escape_run_m", escape_run_m, escape_run_m >= 0 && escape_run_m <= 100, "in [0, 100]")
      .status();
}

LocalParams LocalParams::preset(Method m) {
  LocalParams p;
  p.method = m;
  switch (m) {
    case Method::kClassic:
      p.monitor.escape = false;
      break;
    case Method::kTian2016:
      // k_q = 0.05 makes a weak pull (0.1 N per metre from the goal); full speed at 0.5.
      p.monitor.full_speed_force = 0.5;
      break;
    case Method::kVff:
    case Method::kCvff:
      p.vff.compound = (m == Method::kCvff);
      p.monitor.full_speed_force = 10.0;  // the gains are tens: K_p = 13
      break;
    case Method::kWang2014:
    case Method::kUuv:
      break;
  }
  return p;
}

LocalParams LocalParams::paper(Method m) {
  LocalParams p = preset(m);
  p.terminal.enabled = false;
  p.terminal.pull_to_go = false;
  p.envelope.enabled = false;
  p.envelope.sight_switch = false;
  p.pursuit.enabled = false;
  p.wang2014.goal_factor_cap_m = 0.0;
  p.uuv.goal_factor_cap_m = 0.0;
  return p;
}

Status LocalParams::validate() const {
  ADIT_RETURN_IF_ERROR(robot.validate());
  ADIT_RETURN_IF_ERROR(monitor.validate());
  ADIT_RETURN_IF_ERROR(terminal.validate());
  ADIT_RETURN_IF_ERROR(envelope.validate());
  ADIT_RETURN_IF_ERROR(pursuit.validate());
  switch (method) {
    case Method::kClassic: return classic.validate();
    case Method::kTian2016: return tian2016.validate();
    case Method::kWang2014: return wang2014.validate();
    case Method::kVff:
    case Method::kCvff: return vff.validate();
    case Method::kUuv: return uuv.validate();
  }
  return {};
}

}  // namespace adit::local
