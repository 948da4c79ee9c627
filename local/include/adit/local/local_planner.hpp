// SPDX-License-Identifier: BSD-3-Clause
#pragma once
/// @file
/// LocalPlanner: the reactive step a robot calls every control period. Given the robot's state,
/// the expected path (from the global planner, or a straight line), the moving obstacles it
/// senses and the period, step() returns velocity and acceleration set-points within the robot's
/// limits, the current sub-goal and a status. It uses the potential field of the selected model
/// (params.hpp, potential_terms.hpp), a progress monitor that detects local minima and
/// oscillation (no new best progress along the path over a window), escapes them (the UUV
/// rotation direction picks the side, a virtual sub-goal on that side leads round the obstacle)
/// and, after a bounded number of failed escapes, says kStuck so that the caller can replan.
/// Near the goal, with the goal in sight, every model enters the terminal phase (TerminalParams):
/// the goal is steered at directly and the static repulsion fades toward it, so that a goal by a
/// rib or the floor is reached, not circled.
///
/// step() does not allocate (scratch buffers are sized in create()), takes time linear in the
/// number of obstacles passed, and never returns NaN: non-finite input gets a refused command
/// (zero set-points, status kRefused, a message). kArrived only when the centre is within
/// MonitorParams::arrival_tolerance_m of the path's last point.
///
/// @code
///   World world;  world.field = &field;                 // rock (optional: open space without)
///   StatusOr<LocalPlanner> planner = LocalPlanner::create(LocalParams::preset(Method::kTian2016), world);
///   for (;;) {                                           // every control period
///     RobotState s = readOdometry();
///     StepCommand c = planner->step(s, expected_path, sensed_obstacles, 0.1);
///     if (c.status == StepStatus::kStuck) replan();
///     sendSetPoints(c.velocity, c.acceleration);
///   }
/// @endcode

#include <array>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <vector>

#include "adit/local/params.hpp"
#include "adit/map/rock_points.hpp"
#include "adit/map/types.hpp"
#include "adit/status.hpp"

namespace adit::map {
class DistanceField;
class CollisionChecker;
}  // namespace adit::map

namespace adit::local {

using map::Vec3;
struct TermValue;  // potential_terms.hpp

enum class StepStatus {
  kFollowing,  ///< on the way, the field mostly pulls along the path
  kYielding,   ///< slowing or backing off for a moving obstacle that closes in
  kDetouring,  ///< deflected round an obstacle, or escaping a local minimum
  kStuck,      ///< no progress after the bounded escapes: replan (stays until reset() or a new path)
  kArrived,    ///< the centre is within the arrival tolerance of the goal
  kRefused,    ///< the input was not usable (non-finite, empty path, dt <= 0); set-points zero
};
const char* stepStatusName(StepStatus s);

/// The robot's state in the world frame.
/// Ground mode (RobotLimits::mode): `position` is the body's centre, half its height above the
/// floor; `velocity` lies in the floor's plane; `yaw` is the heading about z and `yaw_rate` its
/// rate. Fly mode ignores the two.
struct RobotState {
  Vec3 position = Vec3::Zero();
  Vec3 velocity = Vec3::Zero();
  Vec3 acceleration = Vec3::Zero();
  double yaw = 0.0;       ///< [rad], ground mode
  double yaw_rate = 0.0;  ///< [rad/s], ground mode
};

/// A static sphere (a disc in the papers' 2-D set-ups) given besides the map.
struct StaticSphere {
  Vec3 center = Vec3::Zero();
  double radius = 0.5;
};

/// What the robot knows besides the moving obstacles. Pointers are not owned and must outlive the
/// planner.
struct World {
  const map::DistanceField* field = nullptr;  ///< rock; null: open space
  /// With a non-spherical `shape`, the rock distance comes from this exact checker (FCL) instead
  /// of the field; the shape's local x axis is turned to the direction of travel.
  const map::CollisionChecker* checker = nullptr;
  map::RobotShape shape = map::RobotShape::sphere(0.3);
  std::vector<StaticSphere> static_obstacles;
};

struct StepCommand {
  Vec3 velocity = Vec3::Zero();      ///< set-point, |v| <= v_max
  Vec3 acceleration = Vec3::Zero();  ///< (velocity - current velocity) / dt, |a| <= a_max
  Vec3 sub_goal = Vec3::Zero();      ///< the break point (or virtual sub-goal, or setSubgoal's) being steered to
  StepStatus status = StepStatus::kRefused;
  double potential = 0.0;            ///< total U at the robot (models with a potential)
  double clearance_m = std::numeric_limits<double>::infinity();  ///< nearest obstacle surface seen
  int escapes = 0;                   ///< escape attempts since the last real progress
  const char* message = "";          ///< why, for kRefused and kStuck (a static string)
  /// Ground mode: the drive's set-points. `velocity` is forward_speed along the heading reached
  /// at the period's end (in the floor's plane); a differential, skid or Ackermann robot sends
  /// (forward_speed, yaw_rate) to its wheels. Negative forward_speed: reversing (backing off).
  double forward_speed = 0.0;  ///< [m/s]
  double yaw_rate = 0.0;       ///< [rad/s], |yaw_rate| <= omega_max
};

class LocalPlanner {
 public:
  /// Validates the parameters and the static obstacles, sizes the scratch buffers.
  static StatusOr<LocalPlanner> create(const LocalParams& params, World world);

  /// One control period. `moving` holds the obstacles as sensed now: position, velocity and
  /// acceleration at this instant (MovingObstacle's t = 0 is "now").
  StepCommand step(const RobotState& state, const map::Polyline& expected_path, const map::MovingObstacle* moving,
                   std::size_t moving_count, double dt);
  StepCommand step(const RobotState& state, const map::Polyline& expected_path,
                   const std::vector<map::MovingObstacle>& moving, double dt) {
    return step(state, expected_path, moving.data(), moving.size(), dt);
  }

  /// Forgets the progress history, the sub-goal index and a kStuck verdict (after a replan).
  /// A sub-goal given with setSubgoal() stays: the caller owns it.
  void reset();

  /// A sub-goal chosen by the caller (e.g. adit::fusion's per-period selection, Tian 2016 §2.3):
  /// until clearSubgoal(), the attraction pulls toward `p` instead of the current break point.
  /// Everything else still follows the expected path: the line field lies along the current
  /// segment, progress is measured along the path, and arrival is at the path's last point.
  /// No allocation; a non-finite `p` makes step() refuse.
  void setSubgoal(const Vec3& p) {
    subgoal_ = p;
    has_subgoal_ = true;
  }
  void clearSubgoal() { has_subgoal_ = false; }

  /// The operator's override (Guo 2022 §1; the operations console's `manual` command): until clearOverride(), step() takes
  /// `velocity` as the set-point in place of the attraction, and the progress monitor, the
  /// escapes and the arrival test rest (a robot driven by hand is neither stuck nor arrived).
  /// The local layer still keeps the robot safe: repulsion from moving obstacles and their
  /// safety check, and a braking cap (the speed toward the nearest rock never exceeds what stops
  /// the robot, one period late, a few centimetres short of it) always; with
  /// `keep_clear_of_rock` the rock's repulsion too. So a set-point into a rib never collides. A zero set-point
  /// without the rock terms is a pause: hold position, give way to what moves. Speed caps as ever.
  /// No allocation; a non-finite velocity makes step() refuse.
  void setOverride(const Vec3& velocity, bool keep_clear_of_rock) {
    override_velocity_ = velocity;
    override_rock_ = keep_clear_of_rock;
    has_override_ = true;
  }
  void clearOverride() { has_override_ = false; }
  bool overriding() const { return has_override_; }
  /// Index of the expected path's segment the last step() steered along (0 before the first).
  std::size_t currentSegment() const { return segment_; }

  const LocalParams& params() const { return params_; }
  const World& world() const { return world_; }

 private:
  LocalPlanner(const LocalParams& params, World world);

  // ---- step() in named steps, in the order it calls them. A Cycle holds one period's values.
  struct Cycle;
  struct ObstacleData;
  /// Why the inputs cannot be stepped (a static string), or null.
  const char* inputError(const RobotState& state, const map::Polyline& path, const map::MovingObstacle* moving,
                         std::size_t moving_count, double dt) const;
  /// A new path (the caller replanned) restarts the monitor and the segment index.
  void restartOnNewPath(const map::Polyline& path);
  /// Braking straight at a_max, reported as `status` (arrived, stuck).
  StepCommand& brakeTo(const Cycle& c, StepStatus status, StepCommand& cmd) const;
  /// The segment steered along (never back along the path), the terminal phase, the sub-goal.
  void followPath(Cycle& c);
  /// The path length still to go, and the best so far (the progress monitor's measure).
  void measureProgress(Cycle& c);
  /// Rock and movers near the robot this period, the nearest, whether a mover is closing.
  void senseObstacles(Cycle& c, StepCommand& cmd);
  /// No progress for a window: begin an escape, or, when they are spent, say stuck (true).
  bool watchForStall(Cycle& c, StepCommand& cmd);
  /// The selected model's attraction and repulsion; false if it came out non-finite.
  bool fieldForce(Cycle& c, StepCommand& cmd) const;
  TermValue repulsionOf(const ObstacleData& o, const Cycle& c, const Vec3& field_goal, double wang_rho0,
                        Vec3* no_potential) const;
  /// The side to pass an obstacle on (an axis to circulate about).
  Vec3 freeSideAxis(const Vec3& q, const Vec3& dir, const Vec3& to_obstacle) const;
  /// The set-point: along the force, an escape, the pursuit of the path, the operator's.
  void desiredVelocity(Cycle& c);
  /// The safety check against movers over the horizon: brake, side-step or back off if needed.
  void giveWayToMovers(Cycle& c);
  /// The safety envelope: speeds toward rock and movers that still stop short, braking first.
  void applyEnvelope(Cycle& c);
  StepStatus statusOf(const Cycle& c) const;

  void gatherObstacles(const Vec3& q, const Vec3& v, const Vec3& a, const map::MovingObstacle* moving,
                       std::size_t moving_count);
  void addRockPoints(const Vec3& q, const Vec3& v, const Vec3& a, double radius);
  // Smallest clearance (negative: overlap) to moving obstacles and static spheres over the safety
  // horizon if the robot steers its velocity to v_target.
  // Only the obstacles listed in reachable_ count.
  // The operator's set-point with its speed toward rock capped so the robot can still stop.
  Vec3 capTowardRock(const Vec3& q, Vec3 v_des, double dt, const map::MovingObstacle* moving = nullptr,
                     std::size_t moving_count = 0) const;
  // The terminal phase's test: the segment q-goal clears rock and static obstacles by the robot's
  // radius (the field sampled every half voxel, at most a fixed number of samples).
  bool goalInSight(const Vec3& q, const Vec3& goal) const;
  /// Ground mode: the point PursuitParams::lookahead_m along `path` past `proj` (the robot's
  /// projection onto segment segment_), when the straight line to it is clear; else none.
  bool pursuitPoint(const Vec3& q, const map::Polyline& path, const Vec3& proj, Vec3* point) const;
  /// The safety envelope's test: a period at `v`, then braking at a_max in a straight line,
  /// keeps the robot's sphere at least `floor` from rock and static obstacles.
  /// `yaw`: the body's heading on the run, for a box footprint's own check (NaN: the covering
  /// circle's only, as for a set-point the drive has not turned to yet).
  bool stoppingRunClear(const Vec3& q, const Vec3& v, double dt, double floor,
                        double yaw = std::numeric_limits<double>::quiet_NaN()) const;
  /// The same for a drive that turns at yaw rate `w` this period: it cannot stop turning at
  /// once, so its braking run curves on while the rate is brought to zero at alpha_max (a robot
  /// turning toward a rib as it brakes ends nearer the rib than the straight run says).
  bool stoppingArcClear(const Vec3& q, const Vec3& v, double w, double dt, double floor) const;
  /// The clearance a stopping run must keep: half the envelope's reserve, or less than now when
  /// the robot is already nearer (a sensed fall, the first period).
  double stoppingFloor(const Vec3& q) const;
  /// Ground mode: the covering circle at p (horizontally) is nearer than `floor` to the band's
  /// rock (a rib, a pillar, a floor rising at a rib's foot: what the body can hit, which the
  /// lifted sphere of the field checks does not see below its equator).
  /// With a box footprint and the heading `yaw` the body has at p (NaN: unknown), also when the
  /// box is nearer than box_floor_ to the band's points: where the covering circle already
  /// reaches into rock (it may, once nearer than the reserve), the circle's clearance can hold
  /// while the box's front runs into rock nearer than the circle's nearest.
  bool bandWithin(const Vec3& p, double floor, double yaw = std::numeric_limits<double>::quiet_NaN()) const;
  /// Ground mode: the covering circle's horizontal clearance at p to the band's points.
  double bandClearance(const Vec3& p) const;
  /// Ground mode, a box footprint: the box's clearance at heading `yaw`, centred at p, to the
  /// band's points (infinity for a circle: turning does not move it).
  double footprintClearance(const Vec3& p, double yaw) const;
  /// Ground mode: turning at yaw rate `w` this period and then bringing the rate to zero at
  /// alpha_max, the box footprint at q stays in free voxels, grown by a centimetre (boxFree,
  /// every 5 degrees of the swing). The covering circle may already reach into rock the box does
  /// not (a floor rising into a rib's foot): the box's corners must not swing into it.
  /// `grow`: turnGrow(q, yaw), the same for every rate tried in one period.
  bool turnClear(const Vec3& q, double yaw, double w, double dt, double grow) const;
  /// What turnClear grows the outline by at (q, yaw): a centimetre, or 0 where the grown box
  /// already meets rock; negative where no turn is held (the covering circle is clear, or the
  /// box already reads as in rock).
  double turnGrow(const Vec3& q, double yaw) const;
  /// Ground mode: the box footprint at q turned to `yaw`, grown by `grow`, stands in free voxels
  /// at its body's heights (its outline every quarter voxel, from max_step and a voxel over the
  /// floor's plane, as the referee's body, to its top): exact where the band's 24 nearest points
  /// are too sparse for a corner swinging past a pillar's face.
  bool boxFree(const Vec3& q, double yaw, double grow) const;
  double encounterMargin(const Vec3& q, const Vec3& v, const Vec3& v_target, const map::MovingObstacle* moving) const;
  // ---- ground mode
  // Where the field is read for a ground robot whose centre is at p: lifted so that the sphere
  // of radius_m stands max_step plus a voxel above the floor (the floor is not rock in the way).
  Vec3 probe(const Vec3& p) const { return p + Vec3(0, 0, lift_); }
  // The band scan (band_) around the robot at q, above the floor under it.
  // `speed`: how far ahead the body's underside is checked against the floor's plane (the
  // stopping run at that speed).
  void scanBand(const Vec3& q, double range, double speed);
  // Floor slope (rise per metre) ahead of q along the unit horizontal direction u; 0 if unknown.
  double slopeAhead(const Vec3& q, const Vec3& u) const;
  // The drive's command from the holonomic set-point v_cmd (the wish, after the envelope's caps): heading error to yaw rate, forward
  // speed by the heading's agreement, reversing when backing off; the floor's slope to z.
  void driveCommand(const RobotState& state, const Vec3& v_cmd, const Vec3& wish, double dt, StepCommand& cmd);

  LocalParams params_;
  World world_;

  // Progress monitor.
  double clock_s_ = 0.0;
  double best_progress_ = std::numeric_limits<double>::infinity();
  double last_improvement_s_ = 0.0;
  double wait_credit_s_ = 0.0;  // time not counted against the robot while it yields
  int escapes_ = 0;
  bool escaping_ = false;
  double escape_until_s_ = 0.0;
  Vec3 escape_axis_ = Vec3::UnitZ();
  bool pursuit_escape_ = false;     // the escape under way pursues the path (PursuitParams)
  double escape_from_progress_ = 0.0;  // the best progress when it began
  bool stuck_ = false;
  std::size_t segment_ = 0;
  std::size_t path_size_ = 0;
  std::uint64_t path_signature_ = 0;  // of the path the monitor state belongs to
  Vec3 subgoal_ = Vec3::Zero();       // setSubgoal()
  bool has_subgoal_ = false;
  Vec3 override_velocity_ = Vec3::Zero();  // setOverride()
  bool override_rock_ = true;
  bool has_override_ = false;

  // Scratch, sized in create(): never reallocated by step().
  struct ObstacleData {
    double rho;
    Vec3 grad;
    double pivot;
    Vec3 v_rel, a_rel;
    Vec3 point;   // nearest point on the obstacle
    bool moving;
    bool closing;  // moving and getting nearer now (true geometry, not the prediction)
  };
  std::vector<ObstacleData> obstacles_;
  std::vector<Vec3> rock_points_;
  std::vector<std::size_t> reachable_;  // moving obstacles that can reach the robot within the safety horizon
  static constexpr int kAzimuthBins = 24, kElevationBins = 7;
  std::array<double, kAzimuthBins * kElevationBins> bin_distance_{};
  std::array<Vec3, kAzimuthBins * kElevationBins> bin_point_{};
  // Ground mode.
  bool ground_ = false;
  double lift_ = 0.0;       // probe()'s offset
  double floor_z_ = 0.0;    // floor under the robot this period
  map::BandScan band_{};
  Vec3 band_centre_ = Vec3::Zero();  // where band_ was scanned
  double band_nearest_ = std::numeric_limits<double>::infinity();  // its nearest point's distance
  // The clearance a box footprint keeps along stopping runs: half the reserve, or what the box
  // has now at its heading if that is less (infinite for a circle).
  double box_floor_ = std::numeric_limits<double>::infinity();
  double yaw_ = 0.0;  // the robot's heading this period
  double plane_gx_ = 0.0, plane_gy_ = 0.0;  // the floor's plane under it (rise per metre in x, y)
  map::BandCache band_cache_;  // what the band scans read, sized at construction for their range
  double car_direction_ = 1.0;  // an Ackermann robot's turn about: +1 forward, -1 reverse
};

/// Ground mode: the footprint's clearance at `centre`, turned to `yaw`, to the rock in its body's
/// band within `range` (map::rockInBand: what it can run into, not the floor it stands on), as
/// the local planner sees it; infinity when none is in range. For an operator's display: the
/// field's distance from a point of the body counts the floor's voxel stairs as rock.
double bandFootprintClearance(const map::DistanceField& field, const RobotLimits& robot, const Vec3& centre, double yaw,
                              double range = 3.0);

}  // namespace adit::local
