// SPDX-License-Identifier: BSD-3-Clause
#pragma once
/// @file
/// Parameters of the local layer: one struct per potential-field model with the paper's values as
/// defaults (and a named preset), the robot's limits, the progress monitor, and LocalParams that
/// bundles them with the selected Method. Every struct has validate(), whose message names the
/// field, the value and the rule. The formulas are the papers', cited at each field.
///
///   LocalParams p = LocalParams::preset(Method::kTian2016);
///   p.robot.v_max_mps = 1.0;
///   if (Status s = p.validate(); !s.ok()) fail(s);

#include <algorithm>
#include <cmath>
#include <string>

#include "adit/status.hpp"

namespace adit::local {

/// The selectable models. Names are the scenario YAML's `method` values.
enum class Method { kClassic, kTian2016, kWang2014, kVff, kCvff, kUuv };

const char* methodName(Method m);
/// "classic" | "tian2016" | "wang2014" | "vff" | "cvff" | "uuv".
StatusOr<Method> parseMethod(const std::string& name);

/// Khatib's APF (Tian 2016 eqs. 1-8), the baseline.
struct ClassicParams {
  double xi = 1.0;       ///< attraction gain, U = 1/2 xi rho_g^2
  double eta = 1.0;      ///< repulsion gain, U = 1/2 eta (1/rho - 1/rho0)^2
  double rho0_m = 2.0;   ///< influence distance rho_0
  Status validate() const;
  /// One field list for YAML overrides, dumps and docs.
  template <class V>
  void visit(V& v) {
    v("xi", xi); v("eta", eta); v("rho0_m", rho0_m);
  }
};

/// Tian, Gao, Zhang 2016: attraction with the expected-path line field (eqs. 9-11) and repulsion
/// with relative velocity and acceleration (eq. 12).
struct Tian2016Params {
  double k_q = 0.05;      ///< goal gain
  double k_v = 0.1;       ///< relative-velocity gain
  double k_a = 0.1;       ///< relative-acceleration gain
  double k_l = 0.1;       ///< line-field gain (0 turns the line field off)
  double s = 2.0;         ///< goal exponent ("m")
  double t = 2.0;         ///< velocity exponent ("n")
  double p = 2.0;         ///< acceleration exponent ("q")
  double l = 2.0;         ///< line-field exponent
  double K_q = 1.0;       ///< repulsion position gain (not given in the paper)
  double K_v = 0.5;       ///< repulsion closing-speed gain
  double K_a = 0.5;       ///< repulsion closing-acceleration gain
  double rho0_m = 2.0;    ///< influence distance rho_0
  /// An interpretation: Tian, Gao & Zhang 2016 (eq. 12) give the repulsion only while the robot
  /// closes in; here the position term also applies when it does not, so that a robot sliding
  /// along a wall still feels it.
  bool position_term_always = true;
  Status validate() const;
  /// One field list for YAML overrides, dumps and docs.
  template <class V>
  void visit(V& v) {
    v("k_q", k_q); v("k_v", k_v); v("k_a", k_a); v("k_l", k_l); v("s", s); v("t", t); v("p", p);
    v("l", l); v("K_q", K_q); v("K_v", K_v); v("K_a", K_a); v("rho0_m", rho0_m);
    v("position_term_always", position_term_always);
  }
};

/// Wang, Song, Zhang 2014: field of view, Ge-Cui goal-aware repulsion, shrinking influence range,
/// fuzzy repulsion gain.
struct Wang2014Params {
  double k_att = 1.0;           ///< attraction gain (Khatib form)
  double K_2 = 1.0;             ///< base repulsion gain, multiplied by the fuzzy gain
  double n = 2.0;               ///< goal-distance exponent of the Ge-Cui repulsion
  double view_range_m = 4.0;    ///< D_r, radius of the field-of-view sector
  double view_half_angle_deg = 60.0;  ///< the sector is +- this about the heading
  double sensing_radius_m = 2.0;      ///< r: rho_0 while the goal is farther than r
  double approach_factor = 2.0;       ///< delta for an approaching obstacle
  double recede_factor = 0.5;         ///< delta for a receding obstacle
  /// The Ge-Cui factor rho_g^n stops growing beyond this goal distance [m] (0: unbounded, as
  /// published). Unbounded, a goal 23 m away multiplies the repulsion by 529: in a roadway whose
  /// floor, roof and ribs all lie within rho_0 the walls ahead in the field of view then push
  /// the robot back harder than the goal pulls, and it crawls. Bounded, the factor still
  /// vanishes at the goal (its purpose) and the gains keep their size in metres near it.
  double goal_factor_cap_m = 2.0;
  Status validate() const;
  /// One field list for YAML overrides, dumps and docs.
  template <class V>
  void visit(V& v) {
    v("k_att", k_att); v("K_2", K_2); v("n", n); v("view_range_m", view_range_m);
    v("view_half_angle_deg", view_half_angle_deg); v("sensing_radius_m", sensing_radius_m);
    v("approach_factor", approach_factor); v("recede_factor", recede_factor);
    v("goal_factor_cap_m", goal_factor_cap_m);
  }
};

/// Guo et al. 2022: VFF (eq. 4) and, with `compound`, the CVFF velocity fields (eqs. 7-12).
/// The paper's units are grid cells (decimetres); here metres, so the paper's grid maps 1:1 onto
/// scenario units.
struct VffParams {
  bool compound = false;   ///< CVFF when true
  double K_p = 13.0;       ///< position attraction, F = K_p unit(q_g - q)
  double K_v = 15.0;       ///< velocity attraction
  double M_p = 5.0;        ///< position repulsion, M_p C / d^2
  double M_v = 7.0;        ///< velocity repulsion, M_v |V_b| C / d
  double p0_m = 1.0;       ///< influence distance p_0 (certainty C = 1 within it)
  Status validate() const;
  /// One field list for YAML overrides, dumps and docs.
  template <class V>
  void visit(V& v) {
    v("K_p", K_p); v("K_v", K_v); v("M_p", M_p); v("M_v", M_v); v("p0_m", p0_m);
  }
};

/// The UUV paper: Ge-Cui repulsion with n = 2, attraction bounded (conic) far from the goal, and the
/// 3-D rotation direction d = (a x b) x a.
struct UuvParams {
  double k_att = 1.0;          ///< attraction gain
  double conic_distance_m = 5.0;  ///< beyond it the attraction is conic (constant magnitude)
  double k_rep = 1.0;          ///< repulsion gain
  double rho0_m = 2.0;         ///< influence distance
  double rotation_gain = 1.0;  ///< tangential force, as a fraction of the repulsion magnitude
  /// As Wang2014Params::goal_factor_cap_m: rho_g^2 bounded beyond this goal distance [m] (0: as
  /// published). Unbounded, the repulsion and the rotation force it scales dwarf the bounded
  /// attraction far from the goal, and the vehicle is spun round the roadway.
  double goal_factor_cap_m = 2.0;
  Status validate() const;
  /// One field list for YAML overrides, dumps and docs.
  template <class V>
  void visit(V& v) {
    v("k_att", k_att); v("conic_distance_m", conic_distance_m); v("k_rep", k_rep); v("rho0_m", rho0_m);
    v("rotation_gain", rotation_gain); v("goal_factor_cap_m", goal_factor_cap_m);
  }
};

/// kFly: the robot's centre moves freely in 3-D (a drone; the papers' spheres). kGround: a wheeled
/// or tracked vehicle on the roadway floor: its centre is half its height above the floor under
/// it, it moves in the floor's plane, floor contact is not a collision, and rock counts only
/// within its body's band above the floor (from max_step_m up to its height), with floor that
/// rises faster than max_slope_deg counted as rock.
enum class RobotMode { kFly, kGround };
/// "fly" | "ground".
const char* robotModeName(RobotMode m);
StatusOr<RobotMode> parseRobotMode(const std::string& name);

/// How a ground robot turns. kDifferential and kSkid: forward speed and yaw rate, turning on the
/// spot (skid steering is modelled kinematically as differential); kAckermann: a car's steering,
/// yaw rate at most |v| tan(max_steer) / wheelbase, no turning on the spot; kHolonomic: any
/// direction in the floor's plane, the heading turned toward the travel at omega_max.
enum class DriveType { kDifferential, kSkid, kAckermann, kHolonomic };
/// "differential" | "skid" | "ackermann" | "holonomic".
const char* driveTypeName(DriveType d);
StatusOr<DriveType> parseDriveType(const std::string& name);

/// A ground robot's outline on the floor: a circle of radius_m, or a box length_m (along its
/// heading) by width_m. `circle:0.3`, `box:1.0,0.7`.
struct Footprint {
  bool box = false;
  double radius_m = 0.3;  ///< circle
  double length_m = 0.0;  ///< box, along the heading
  double width_m = 0.0;   ///< box
  /// The circle that holds the footprint at any heading: what the potential field sees.
  double circumradius() const { return box ? 0.5 * std::hypot(length_m, width_m) : radius_m; }
  /// Distance in the floor's plane from the footprint to the point (x, y) of the body's frame
  /// (x along the heading); 0 on or inside it.
  double gapTo(double x, double y) const {
    return box ? std::hypot(std::max(std::abs(x) - 0.5 * length_m, 0.0), std::max(std::abs(y) - 0.5 * width_m, 0.0))
               : std::max(std::hypot(x, y) - radius_m, 0.0);
  }
  std::string text() const;
  Status validate() const;
};
/// "circle:R" or "box:L,W" (metres, > 0).
StatusOr<Footprint> parseFootprint(const std::string& text);

/// The robot as the local planner sees it: its speed and acceleration limits and its size. One
/// description serves every layer (the navigator hands the same shape and mode to the global
/// planner). In fly mode a sphere of radius_m; in ground mode radius_m is the footprint's
/// circumradius (the loader sets it), the field's repulsion acts on that circle in the body's
/// band, and the referee checks the exact footprint box (or cylinder) with FCL.
struct RobotLimits {
  double radius_m = 0.3;
  double v_max_mps = 1.0;
  double a_max_mps2 = 0.5;
  RobotMode mode = RobotMode::kFly;
  // ---- ground mode only
  DriveType drive = DriveType::kDifferential;
  Footprint footprint;            ///< circle of radius_m unless a box is given
  double height_m = 0.6;          ///< body height above the floor
  double omega_max_rps = 1.0;     ///< yaw-rate limit [rad/s]
  double alpha_max_rps2 = 2.0;    ///< yaw-acceleration limit [rad/s^2]
  double max_slope_deg = 15.0;    ///< steepest floor it climbs (as the global ground mode)
  double max_step_m = 0.1;        ///< highest step it drives over; the body band starts there
  double max_steer_deg = 30.0;    ///< ackermann: steering angle limit
  double wheelbase_m = 0.0;       ///< ackermann: 0 = 0.6 x the footprint's length (or diameter)
  bool ground() const { return mode == RobotMode::kGround; }
  /// The robot of the bundled rescue and inspection runs (maps/scenarios/district_rescue.yaml):
  /// tracked, skid steering, a 1.0 x 0.7 m box 0.6 m high; the other limits as the defaults.
  static RobotLimits trackedRescue() {
    RobotLimits r;
    r.mode = RobotMode::kGround;
    r.drive = DriveType::kSkid;
    r.footprint.box = true;
    r.footprint.length_m = 1.0;
    r.footprint.width_m = 0.7;
    r.height_m = 0.6;
    r.radius_m = r.footprint.circumradius();
    return r;
  }
  /// Ackermann's wheelbase as used.
  double wheelbase() const {
    return wheelbase_m > 0.0 ? wheelbase_m : 0.6 * (footprint.box ? footprint.length_m : 2.0 * footprint.radius_m);
  }
  /// Ground mode: how far above the robot's centre the distance field is read for the sphere of
  /// radius_m, so that its bottom stands max_step plus one voxel (`resolution`) above the floor
  /// (a floor quantised to voxels rises a voxel between two samples on a slope). 0 when flying.
  double probeLift(double resolution) const {
    return ground() ? max_step_m + resolution + radius_m - 0.5 * height_m : 0.0;
  }
  Status validate() const;
};

/// Progress monitor and escape: potential fields are known to trap a robot in local minima (where
/// attraction and repulsion cancel) and in oscillation between obstacles; the monitor notices that
/// the distance to the goal stops shrinking and tries escapes before it declares the robot stuck.
struct MonitorParams {
  double window_s = 4.0;           ///< progress is judged over this much time
  /// Waiting for closing moving obstacles is not held against the robot, up to this much time
  /// since the last progress (then the monitor counts again: no endless yielding).
  double max_wait_s = 30.0;
  double min_progress_m = 0.3;     ///< less goal-distance reduction than this over a window: no progress
  bool escape = true;              ///< try escapes (rotation direction, then virtual sub-goals)
  int max_escapes = 3;             ///< after this many failed escapes in a row: stuck
  double escape_time_s = 20.0;     ///< longest escape manoeuvre (it ends early on progress)
  double virtual_goal_offset_m = 2.0;  ///< lateral offset of the virtual sub-goal
  double arrival_tolerance_m = 0.5;    ///< arrived when the centre is within this of the goal
  double subgoal_switch_m = 1.0;       ///< advance to the next break point within this distance
  double full_speed_force = 1.0;       ///< |F| at or above which the robot commands v_max
  /// Moving obstacles repel from their closest approach within this horizon (constant
  /// acceleration); 0 = from where they are now. The classic baseline never predicts.
  double prediction_horizon_s = 2.0;
  /// Safety check of each command against moving obstacles over this horizon (0 = off): a command
  /// that leads into one is replaced by braking or a side step (status kYielding).
  double safety_horizon_s = 2.0;
  Status validate() const;
  /// One field list for YAML overrides, dumps and docs.
  template <class V>
  void visit(V& v) {
    v("window_s", window_s); v("max_wait_s", max_wait_s); v("min_progress_m", min_progress_m); v("escape", escape);
    v("max_escapes", max_escapes); v("escape_time_s", escape_time_s);
    v("virtual_goal_offset_m", virtual_goal_offset_m); v("arrival_tolerance_m", arrival_tolerance_m);
    v("subgoal_switch_m", subgoal_switch_m); v("full_speed_force", full_speed_force);
    v("prediction_horizon_s", prediction_horizon_s); v("safety_horizon_s", safety_horizon_s);
  }
};

/// The terminal phase, for every model: in a roadway every point lies within some
/// rock's repulsion range, so a goal near the floor or a rib is not the minimum of the field and
/// the robot would rest, or circle, short of it. Once the goal is within range_m and in line of
/// sight of the robot's sphere (the segment robot→goal clear of rock and static obstacles by the
/// robot's radius), the goal becomes the sub-goal, the static repulsion (rock, static obstacles;
/// moving ones keep theirs) is scaled by Ge & Cui's goal-aware factor min(1, (rho_g / range_m)^n),
/// and with `seek` the desired velocity is v_max toward the goal blended with that repulsion. In
/// the phase the speed toward rock is capped so that the robot can always stop short of it. Off
/// (`preset: paper` in a scenario, or `terminal: false`): the papers' fields as published.
struct TerminalParams {
  bool enabled = true;    ///< the phase at all (false: the papers' fields only)
  double range_m = 4.0;   ///< R: the phase starts within this distance of the goal [m]
  double n = 2.0;         ///< exponent of the goal-aware factor (rho_g / R)^n on the static repulsion
  /// Steer straight at the goal (v_max along unit(q_g - q), plus the scaled repulsion) instead of
  /// along the model's force with the scaled repulsion.
  bool seek = true;
  /// Short of a break point of the path, the model's goal-distance terms (attraction, Wang's
  /// shrinking range, the Ge-Cui factor) take the goal at the path length still to go, along
  /// the bearing to the break point: only the goal slows the robot, not every corner.
  bool pull_to_go = true;
  Status validate() const;
  /// One field list for YAML overrides, dumps and docs.
  template <class V>
  void visit(V& v) {
    v("terminal", enabled); v("terminal_range_m", range_m); v("terminal_n", n); v("terminal_seek", seek);
    v("pull_to_go", pull_to_go);
  }
};

/// The safety envelope, for every model and every mode of step(): after the field's
/// command and the moving-obstacle check, the speed toward rock and toward each moving obstacle
/// is capped so that the robot can still brake at a_max, a period late, before its clearance
/// drops below keep_m: the braking-distance barrier of a control-barrier-function safety filter,
/// closing speed <= sqrt(2 a_max (d - keep_m)) less what one period's delay costs. A mover's own
/// closing speed counts (under its present motion). Only the component that closes on rock is
/// removed, so the robot slides along ribs and does not stall at corners; then the whole
/// stopping run (a period at the command, then braking) is checked along the distance field and
/// the command scaled down until it is clear (corners, the face at the end of a rib).
/// `preset: paper` turns it off with the terminal phase (the papers' runs as published, their
/// robots keep clear of rock anyway); `envelope: false` turns it off elsewhere, to show what the
/// field alone does.
struct EnvelopeParams {
  bool enabled = true;   ///< the envelope at all
  double keep_m = 0.05;  ///< clearance to rock and movers the braking run keeps in reserve [m]
  /// Advance along the expected path only when the break point after next is in line of sight
  /// of the robot's sphere (else, within subgoal_switch_m, the robot turns early and cuts the
  /// corner into the rib); within half that distance it advances anyway.
  bool sight_switch = true;
  Status validate() const;
  /// One field list for YAML overrides, dumps and docs.
  template <class V>
  void visit(V& v) {
    v("envelope", enabled); v("envelope_keep_m", keep_m); v("sight_switch", sight_switch);
  }
};

/// Ground robots follow a clear expected path by pursuit (as Nav2's and BARN's path followers
/// do): while the straight line from the robot to a point `pursuit_lookahead_m` ahead along the
/// path is clear of rock for its covering circle, it steers at that point and the static field's
/// repulsion rests. Among pillars a repulsion on both sides pushes the robot off a passage the
/// global layer proved clear, and it stalls there. Where the line is blocked (rock the map did not
/// show, the robot pushed off the path) the field drives as before; movers keep their repulsion,
/// the safety check and the envelope throughout. Fly mode keeps the papers' fields, except in an
/// escape: the first escape from a stall pursues the path (the line to the pursued point clear of
/// rock for the robot's sphere) until the robot has made `escape_run_m` of progress past the
/// stall, since the usual stall is a gap the global layer proved passable where rock on both sides
/// (a roof fall beside a rib corner) cancels the field's pull; the later escapes circulate.
struct PursuitParams {
  bool enabled = true;
  double lookahead_m = 1.0;   ///< distance of the pursued point along the path [m]
  double escape_run_m = 5.0;  ///< a pursuit escape lasts this much progress past the stall (0: none) [m]
  Status validate() const;
  template <class V>
  void visit(V& v) {
    v("pursuit", enabled); v("pursuit_lookahead_m", lookahead_m); v("pursuit_escape_run_m", escape_run_m);
  }
};

/// Everything step() needs: the method, the model parameters (only the selected one is used),
/// the robot, the monitor and the terminal phase.
struct LocalParams {
  Method method = Method::kTian2016;
  ClassicParams classic;
  Tian2016Params tian2016;
  Wang2014Params wang2014;
  VffParams vff;
  UuvParams uuv;
  RobotLimits robot;
  MonitorParams monitor;
  TerminalParams terminal;
  EnvelopeParams envelope;
  PursuitParams pursuit;

  /// The paper's values for `m`, with this project's additions on (the terminal phase). The
  /// classic preset turns escapes off: Khatib's APF has none, which is what the baseline shows.
  static LocalParams preset(Method m);
  /// preset(m) with the additions off (terminal phase, bounded Ge-Cui factor, safety envelope,
  /// line-of-sight switching):
  /// the paper's field exactly as published, for the reproduction runs (`preset: paper`).
  static LocalParams paper(Method m);
  Status validate() const;
};

}  // namespace adit::local
