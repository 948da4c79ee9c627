// SPDX-License-Identifier: BSD-3-Clause
#include "adit/sim/simulator.hpp"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cmath>
#include <limits>
#include <optional>
#include <sstream>

#include "adit/map/collision.hpp"
#include "adit/map/distance_field.hpp"
#include "adit/map/map_io.hpp"
#include "adit/map/occupancy_map.hpp"
#include "adit/map/rock_points.hpp"
#include "adit/map/world.hpp"
#include "escape_record.hpp"

namespace adit::sim {

using local::LocalPlanner;
using local::RobotLimits;
using local::RobotState;
using local::StaticSphere;
using local::StepCommand;
using local::StepStatus;
using local::SubgoalPick;
using local::SubgoalRequest;
using local::World;
using map::allFinite;

// ---- Environment ------------------------------------------------------------------------------

struct Environment::Impl {
  std::optional<map::World> own;
  const map::OccupancyMap* map = nullptr;
  const map::DistanceField* field = nullptr;
  std::optional<map::CollisionChecker> checker;
};

Environment::Environment(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
Environment::Environment(Environment&&) noexcept = default;
Environment& Environment::operator=(Environment&&) noexcept = default;
Environment::~Environment() = default;

const map::OccupancyMap* Environment::map() const { return impl_->map; }
const map::DistanceField* Environment::field() const { return impl_->field; }
const map::CollisionChecker* Environment::checker() const { return impl_->checker ? &*impl_->checker : nullptr; }

Environment Environment::openSpace() { return Environment(std::make_unique<Impl>()); }

StatusOr<Environment> Environment::borrow(const map::OccupancyMap& m, const map::DistanceField& f) {
  auto impl = std::make_unique<Impl>();
  impl->map = &m;
  impl->field = &f;
  ADIT_ASSIGN_OR_RETURN(map::CollisionChecker checker, map::CollisionChecker::create(m, f));
  impl->checker = checker;
  return Environment(std::move(impl));
}

StatusOr<Environment> Environment::borrow(const map::World& world) { return borrow(world.map(), world.field()); }

StatusOr<Environment> Environment::load(const Scenario& scenario) {
  if (!scenario.map_path) return openSpace();
  auto impl = std::make_unique<Impl>();
  ADIT_ASSIGN_OR_RETURN(map::World w, map::World::load(*scenario.map_path));
  impl->own.emplace(std::move(w));
  impl->map = &impl->own->map();
  impl->field = &impl->own->field();
  ADIT_ASSIGN_OR_RETURN(map::CollisionChecker checker, map::CollisionChecker::create(*impl->map, *impl->field));
  impl->checker = checker;
  return Environment(std::move(impl));
}

const char* outcomeName(Outcome o) {
  switch (o) {
    case Outcome::kArrived: return "arrived";
    case Outcome::kCollision: return "collision";
    case Outcome::kStuck: return "stuck";
    case Outcome::kTimeout: return "timeout";
    case Outcome::kNoRoute: return "no_route";
    case Outcome::kHitByFall: return "hit_by_fall";
    case Outcome::kHitByMover: return "hit_by_mover";
  }
  return "?";
}

const char* endCauseName(EndCause c) {
  switch (c) {
    case EndCause::kNone: return "";
    case EndCause::kRouteOutlastsTime: return "route_outlasts_t_max";
    case EndCause::kShortOfGoal: return "short_of_goal";
    case EndCause::kEnRoute: return "en_route";
  }
  return "?";
}

std::optional<EndCause> endCauseFromName(std::string_view name) {
  for (EndCause c : {EndCause::kNone, EndCause::kRouteOutlastsTime, EndCause::kShortOfGoal, EndCause::kEnRoute})
    if (name == endCauseName(c)) return c;
  return std::nullopt;
}

EndCause endCause(const Scenario& sc, Outcome outcome, double goal_distance_m, double path_made_at_s,
                  double path_length_m) {
  if (outcome != Outcome::kTimeout && outcome != Outcome::kStuck) return EndCause::kNone;
  const double v = sc.params.robot.v_max_mps;
  if (outcome == Outcome::kTimeout && v > 0.0 && path_made_at_s + path_length_m / v > sc.t_max_s)
    return EndCause::kRouteOutlastsTime;
  if (goal_distance_m <= sc.params.terminal.range_m) return EndCause::kShortOfGoal;
  return EndCause::kEnRoute;
}

// ---- simulate ---------------------------------------------------------------------------------

namespace {

// The independent referee: surface distances of the robot's body at a pose, time `t`. Fly: the
// sphere. Ground: the footprint's box (or cylinder) from `bottom_` above the floor to the robot's
// height, on the floor under it.
class Referee {
 public:
  Referee(const Scenario& sc, const Environment& env)
      : sc_(sc), env_(env), robot_(map::RobotShape::sphere(sc.params.robot.radius_m)) {
    const RobotLimits& r = sc.params.robot;
    if (r.ground()) {
      // max_step above the floor, plus one voxel: a floor quantised to voxels rises a voxel between
      // the samples under the footprint (the same lift as the planner's, RobotLimits::probeLift).
      bottom_ = r.max_step_m + (env.field() ? env.field()->resolution() : 0.0);
      const double tall = std::max(r.height_m - bottom_, 0.05);
      tall_ = tall;
      robot_ = r.footprint.box ? map::RobotShape::box(Vec3(r.footprint.length_m, r.footprint.width_m, tall))
                               : map::RobotShape::cylinder(r.footprint.radius_m, tall);
      if (env.field())
        band_ = &bandCache(env.field()->resolution(), kClearanceReachM + r.footprint.circumradius(), r.max_step_m,
                           std::tan(r.max_slope_deg * 3.14159265358979323846 / 180.0), r.height_m);
    }
  }

  // Ground mode: the body's clearance to what it could drive into, the floor it stands on left
  // out. The exact body distance (rockDistance) is the gap over the floor (max_step plus a voxel)
  // whenever nothing else is nearer, so a ground run's smallest clearance said only that. This is
  // the footprint's horizontal distance to the nearest rock of the body's band (a rib, a pillar,
  // a step, a drop, a floor too steep: map::rockInBand, the planner's own view of the rock),
  // read up to kClearanceReachM beyond the footprint; beyond that, the reach itself.
  static constexpr double kClearanceReachM = 2.0;
  double groundClearance(const Vec3& centre, double yaw, double floor) const {
    const RobotLimits& r = sc_.params.robot;
    if (!env_.field()) return kClearanceReachM;
    map::BandScan scan;
    map::rockInBand(*env_.field(), centre, kClearanceReachM + r.footprint.circumradius(), floor, r.max_step_m,
                    std::tan(r.max_slope_deg * 3.14159265358979323846 / 180.0), r.height_m, scan, 1u << 16, band_);
    const double c = std::cos(yaw), s = std::sin(yaw);
    double best = kClearanceReachM;
    for (int b = 0; b < map::BandScan::kBins; ++b) {
      if (!std::isfinite(scan.distance[b])) continue;
      // The point in the body's frame, against its footprint (box or circle).
      const double dx = scan.point[b].x() - centre.x(), dy = scan.point[b].y() - centre.y();
      best = std::min(best, r.footprint.gapTo(c * dx + s * dy, -s * dx + c * dy));
    }
    return best;
  }

  double rockDistance(const Eigen::Isometry3d& x) const {
    if (!env_.checker()) return std::numeric_limits<double>::infinity();
    const map::ShapeDistance d = env_.checker()->distance(robot_, x, 10.0);
    return d.collision ? 0.0 : d.distance_m;
  }
  // Ground mode: what a period's sub-sample needs of the rock. The body's exact distance to rock
  // is the gap over the floor it drives on whenever nothing is nearer, and the run reports the
  // band's clearance instead (groundClearance), so the distance counts only for contact and for
  // whether something else (`nearer_than`: a roof fall) is nearer than the rock. Returns 0 on
  // contact, the exact distance when it is below `nearer_than`, and infinity otherwise: farther
  // than anything it is compared with. Bodies clear of rock are settled from a few field reads
  // (CollisionChecker's covering bound) instead of the surface scan of their box.
  double groundRockDistance(const Eigen::Isometry3d& x, double nearer_than) const {
    constexpr double kInf = std::numeric_limits<double>::infinity();
    if (!env_.checker()) return kInf;
    if (!(nearer_than < kInf)) return env_.checker()->inCollision(robot_, x) ? 0.0 : kInf;
    return rockDistanceWithin(x, std::min(nearer_than, 10.0));
  }
  // 0 on contact, the exact distance up to `cap`, infinity beyond it.
  double rockDistanceWithin(const Eigen::Isometry3d& x, double cap) const {
    const map::ShapeDistance d = env_.checker()->distance(robot_, x, cap);
    if (d.collision) return 0.0;
    return d.exact ? d.distance_m : std::numeric_limits<double>::infinity();
  }
  double rockDistance(const Vec3& p) const { return rockDistance(pose(p)); }
  // Flying: the same, exact only below `compared` (the run's least clearance so far): a distance
  // beyond that changes nothing, and infinity stands for it. Most periods are then settled by the field's bound alone, without
  // the surface scan. Up to 10 m it is what rockDistance() gives.
  double rockDistanceBelow(const Eigen::Isometry3d& x, double compared) const {
    constexpr double kReach = 10.0;
    if (!(compared < kReach)) return rockDistance(x);
    if (!env_.checker()) return std::numeric_limits<double>::infinity();
    return rockDistanceWithin(x, compared);
  }
  double staticDistance(const Eigen::Isometry3d& x, std::size_t i) const {
    const StaticSphere& s = sc_.static_obstacles[i];
    if (robot_.type == map::ShapeType::kSphere)
      return std::max(0.0, (x.translation() - s.center).norm() - s.radius - robot_.radius);
    const map::ShapeDistance d = map::shapeDistance(robot_, x, map::RobotShape::sphere(s.radius), pose(s.center));
    return d.collision ? 0.0 : d.distance_m;
  }
  double movingDistance(const Eigen::Isometry3d& x, std::size_t i, double t) const {
    const map::ShapeDistance d = map::obstacleDistance(robot_, x, sc_.moving_obstacles[i].obstacle, t);
    return d.collision ? 0.0 : d.distance_m;
  }

  // Ground mode: the floor under (x, y), climbing at most max_step from `hint` (the last floor)
  // and descending at most a metre; none: a step too high (the body will meet it) or a drop.
  std::optional<double> floorAt(double x, double y, double hint) const {
    if (!env_.field()) return hint;
    const RobotLimits& r = sc_.params.robot;
    const double res = env_.field()->resolution();
    return map::floorBelow(*env_.field(), Vec3(x, y, hint + r.max_step_m + res), r.max_step_m + res + 1.0);
  }
  struct Placed {
    bool on_floor = true;
    double floor = 0.0;  // under the centre
    Eigen::Isometry3d body = Eigen::Isometry3d::Identity();
  };
  // The body standing at (x, y) with heading yaw, on the floor's plane (map::floorSlope over
  // kTiltWindowM: the incline, not the voxel stair under the body, which tilted a 0.7 m-wide box 16
  // degrees on every stair edge of a 0.2 m map and swung its top into the rib: the six collisions
  // of the 2,000-scenario ground campaign, each a box turning on a stair edge beside a rib),
  // resting on the highest floor under its footprint, as a vehicle does on a crest.
  static constexpr double kTiltWindowM = 2.5;
  Placed place(const Vec3& p, double yaw, double hint) const {
    const RobotLimits& r = sc_.params.robot;
    Placed out;
    const std::optional<double> fc = floorAt(p.x(), p.y(), hint);
    out.on_floor = fc.has_value();
    out.floor = fc.value_or(hint);
    const double half_l = r.footprint.box ? 0.5 * r.footprint.length_m : r.footprint.radius_m;
    const double half_w = r.footprint.box ? 0.5 * r.footprint.width_m : r.footprint.radius_m;
    const Vec3 fwd(std::cos(yaw), std::sin(yaw), 0.0), left(-std::sin(yaw), std::cos(yaw), 0.0);
    double sp = 0.0, sr = 0.0;  // the plane's rise per metre along fwd and along left
    if (env_.field()) {
      const double tan_max = std::tan(r.max_slope_deg * 3.14159265358979323846 / 180.0);
      const map::FloorSlope fs = map::floorSlope(*env_.field(), Vec3(p.x(), p.y(), out.floor), yaw,
                                                 std::max(kTiltWindowM, std::hypot(half_l, half_w)), tan_max, r.max_step_m);
      sp = std::clamp(fs.along, -tan_max, tan_max);
      sr = std::clamp(fs.across, -tan_max, tan_max);
    }
    constexpr int kAlong = 5, kAcross = 3;
    double base = out.floor;
    for (int a = 0; a < kAlong; ++a)
      for (int c = 0; c < kAcross; ++c) {
        const double u = half_l * (2.0 * a / (kAlong - 1) - 1.0), v = half_w * (2.0 * c / (kAcross - 1) - 1.0);
        const Vec3 at = p + u * fwd + v * left;
        const double f = floorAt(at.x(), at.y(), out.floor).value_or(out.floor);
        base = std::max(base, f - u * sp - v * sr);
      }
    const double pitch = std::atan(sp), roll = std::atan(sr);
    Eigen::Matrix3d rot = (Eigen::AngleAxisd(yaw, Vec3::UnitZ()) * Eigen::AngleAxisd(-pitch, Vec3::UnitY()) *
                           Eigen::AngleAxisd(roll, Vec3::UnitX()))
                              .toRotationMatrix();
    out.body.linear() = rot;
    // The bottom face parallel to that plane, `bottom_` above it along its normal.
    out.body.translation() = Vec3(p.x(), p.y(), base) + rot * Vec3(0, 0, bottom_ + 0.5 * tall_);
    return out;
  }

  static Eigen::Isometry3d pose(const Vec3& p) {
    Eigen::Isometry3d x = Eigen::Isometry3d::Identity();
    x.translation() = p;
    return x;
  }

 private:
  const Scenario& sc_;
  const Environment& env_;
  map::RobotShape robot_;
  double bottom_ = 0.0, tall_ = 0.0;
  // groundClearance()'s reads, kept from one period to the next (a referee lives for one period;
  // the cache per thread, re-sized when the robot or the field's resolution differs, and dropped
  // by the cache itself when the field's content changes).
  struct BandCacheSlot {
    map::BandCache cache;
    double args[5] = {0, 0, 0, 0, 0};
  };
  static map::BandCache& bandCache(double res, double radius, double step, double slope_tan, double height) {
    thread_local BandCacheSlot slot;
    const double args[5] = {res, radius, step, slope_tan, height};
    if (!std::equal(args, args + 5, slot.args)) {
      slot.cache.reserve(res, radius, step, slope_tan, height);
      std::copy(args, args + 5, slot.args);
    }
    return slot.cache;
  }
  map::BandCache* band_ = nullptr;
};

}  // namespace

double stepTimePercentile(std::vector<double> v, double q) {
  if (v.empty()) return 0.0;
  const std::size_t k = std::min(v.size() - 1, std::size_t(q * double(v.size() - 1) + 0.5));
  std::nth_element(v.begin(), v.begin() + std::ptrdiff_t(k), v.end());
  return v[k];
}

void refereePeriod(const Scenario& sc, const Environment& env, const Vec3& acc, double t, RobotState& state, SimulationResult& res, const ExtraDistanceFn& extra) {
  const Referee referee(sc, env);
  const std::size_t nm = sc.moving_obstacles.size();
  double min_obstacle_radius = sc.params.robot.radius_m;
  for (const auto& m : sc.moving_obstacles)
    min_obstacle_radius = std::min(min_obstacle_radius, m.obstacle.shape.type == map::ShapeType::kBox
                                                            ? 0.5 * m.obstacle.shape.size.minCoeff()
                                                            : m.obstacle.shape.radius);
  const double sample_step = 0.25 * std::max(min_obstacle_radius, 0.01);
  // The robot follows the set-points: constant acceleration over the period.
  const Vec3 p0 = state.position, v0 = state.velocity;
  const double dt = sc.dt_s;
  // Sub-samples so that no relative motion within one exceeds sample_step.
  double reach = v0.norm() * dt + 0.5 * acc.norm() * dt * dt;
  double ob_reach = 0.0;
  for (std::size_t i = 0; i < nm; ++i) {
    const map::MovingObstacle& m = sc.moving_obstacles[i].obstacle;
    ob_reach = std::max(ob_reach, m.velocityAt(t).norm() * dt + 0.5 * m.acceleration.norm() * dt * dt);
  }
  const int subs = int(std::clamp(std::ceil((reach + ob_reach) / sample_step), 1.0, 1000.0));
  const RobotLimits& robot = sc.params.robot;
  const bool ground = robot.ground();
  const double yaw0 = state.yaw, yaw_rate = state.yaw_rate;
  double floor = p0.z() - 0.5 * robot.height_m;
  bool hit = false;
  Vec3 p_end = p0;
  for (int s = 1; s <= subs; ++s) {
    const double tau = dt * double(s) / double(subs);
    Vec3 p = p0 + v0 * tau + 0.5 * acc * tau * tau;
    Eigen::Isometry3d body = Referee::pose(p);
    std::string what = "rock";
    double d = std::numeric_limits<double>::infinity();
    if (ground) {
      const Referee::Placed placed = referee.place(p, yaw0 + yaw_rate * tau, floor);
      floor = placed.floor;
      p.z() = floor + 0.5 * robot.height_m;
      body = placed.body;
      if (!placed.on_floor) {
        const bool step_up = env.field() && !env.field()->isFree(Vec3(p.x(), p.y(), floor + robot.max_step_m + env.field()->resolution()));
        d = 0.0;
        what = step_up ? "rock (a step higher than max_step)" : "no floor (a drop)";
      }
    }
    p_end = p;
    // What `extra` (a roof fall) would lower the distance to, and its name; asked first, so that
    // a ground robot's rock distance need only be exact below it.
    double extra_d = std::numeric_limits<double>::infinity();
    std::string extra_what = what;
    if (extra) extra(p, t + tau, extra_d, extra_what);
    // Nearest thing to the robot at this instant, and what it is.
    // Flying, the rock distance matters only below the least clearance so far: above it, it
    // lowers nothing (the clearance reported is the least of rock, fall, obstacles and movers),
    // and it names no contact (a contact is a distance of 0, below any of them). A roof fall's
    // distance need not be told from it there: which of two is nearer matters only at contact.
    if (d > 0.0)
      d = ground ? referee.groundRockDistance(body, extra_d) : referee.rockDistanceBelow(body, res.min_clearance_m);
    // What the run reports as its clearance: the same, but for a ground robot the rock is what
    // stands beside it, not the floor it drives on (read once a period: the band scan is the
    // costly part; contact is still judged on every sub-sample by the exact distance d).
    double reported = d;
    if (ground && d > 0.0)
      reported = s == subs ? referee.groundClearance(p, yaw0 + yaw_rate * tau, floor)
                           : std::numeric_limits<double>::infinity();
    int mover = -1;
    if (extra_d < d) {
      d = extra_d;
      what = extra_what;
      reported = std::min(reported, d);
    }
    for (std::size_t i = 0; i < sc.static_obstacles.size(); ++i) {
      const double ds = referee.staticDistance(body, i);
      reported = std::min(reported, ds);
      if (ds < d) { d = ds; what = "static obstacle " + std::to_string(i + 1); }
    }
    for (std::size_t i = 0; i < nm; ++i) {
      const double dm = referee.movingDistance(body, i, t + tau);
      if (dm < res.closest[i].distance_m) res.closest[i] = {res.closest[i].name, dm, t + tau};
      reported = std::min(reported, dm);
      if (dm < d) { d = dm; what = sc.moving_obstacles[i].name; mover = int(i); }
    }
    res.min_clearance_m = std::min(res.min_clearance_m, reported);
    if (d <= 0.0 && !hit && res.collisions == 0) {
      res.first_collision_t_s = t + tau;
      res.first_collision_with = what;
      if (mover >= 0) {
        // Was the robot closing on it? Its velocity toward the mover's centre at the contact.
        constexpr double kNotClosingMps = 0.05;
        const Vec3 to = sc.moving_obstacles[std::size_t(mover)].obstacle.positionAt(t + tau) - p;
        const Vec3 vel = v0 + acc * tau;
        res.first_collision_by_mover = to.norm() < 1e-9 || vel.dot(to.normalized()) <= kNotClosingMps;
      }
    }
    hit = hit || d <= 0.0;
  }
  if (hit) ++res.collisions;
  if (ground) {
    state.position = p_end;
    // The command's velocity (along the floor's mean slope): a floor quantised to voxels steps a
    // voxel at once, which is no speed of the robot's.
    state.velocity = v0 + acc * dt;
    state.yaw = std::remainder(yaw0 + yaw_rate * dt, 2.0 * 3.14159265358979323846);
  } else {
    state.position = p0 + v0 * dt + 0.5 * acc * dt * dt;
    state.velocity = v0 + acc * dt;
  }
  state.acceleration = acc;
  res.path_length_m += (state.position - p0).norm();
}

void refereePeriod(const Scenario& sc, const Environment& env, const StepCommand& cmd, double t, RobotState& state,
                   SimulationResult& res, const ExtraDistanceFn& extra) {
  state.yaw_rate = sc.params.robot.ground() ? cmd.yaw_rate : 0.0;
  refereePeriod(sc, env, cmd.acceleration, t, state, res, extra);
}

StatusOr<Scenario> placeOnFloor(const Scenario& sc, const Environment& env) {
  if (!sc.params.robot.ground() || !env.field()) return sc;
  Scenario out = sc;
  const double half = 0.5 * sc.params.robot.height_m;
  auto put = [&](Vec3& p, const std::string& what) -> Status {
    if (!env.field()->isFree(p)) return invalidArgument(sc.file + ": " + what + ": inside rock");
    const std::optional<double> f = map::floorBelow(*env.field(), p, 5.0);
    if (!f) {
      std::ostringstream os;
      os << sc.file << ": " << what << ": no floor within 5 m under (" << p.x() << ", " << p.y() << ", " << p.z()
         << ") for the ground robot";
      return invalidArgument(os.str());
    }
    p.z() = *f + half;
    return {};
  };
  ADIT_RETURN_IF_ERROR(put(out.start, "start"));
  ADIT_RETURN_IF_ERROR(put(out.goal, "goal"));
  for (std::size_t i = 0; i < out.expected_path.points.size(); ++i) {
    Vec3& p = out.expected_path.points[i];
    // Break points given at the start and goal follow them; the rest find their own floor.
    if ((p - sc.start).norm() < 1e-9) p = out.start;
    else if ((p - sc.goal).norm() < 1e-9) p = out.goal;
    else ADIT_RETURN_IF_ERROR(put(p, "expected_path[" + std::to_string(i) + "]"));
  }
  return out;
}

namespace {
double bodyRockClearance(const Referee& referee, const Scenario& sc, const Vec3& p, double yaw) {
  if (!sc.params.robot.ground()) return referee.rockDistance(p);
  const Referee::Placed at = referee.place(p, yaw, p.z() - 0.5 * sc.params.robot.height_m);
  return at.on_floor ? referee.rockDistance(at.body) : 0.0;
}
}  // namespace

double bodyRockClearance(const Scenario& sc, const Environment& env, const Vec3& p, double yaw) {
  return bodyRockClearance(Referee(sc, env), sc, p, yaw);
}

BodyFit bodyFit(const Scenario& sc, const Environment& env, const Vec3& p) {
  BodyFit fit;
  const Referee referee(sc, env);
  if (!sc.params.robot.ground()) {
    fit.least_m = fit.most_m = bodyRockClearance(referee, sc, p, 0.0);
    return fit;
  }
  constexpr int kHeadings = 16;
  fit.least_m = std::numeric_limits<double>::infinity();
  fit.most_m = -std::numeric_limits<double>::infinity();
  for (int k = 0; k < kHeadings; ++k) {
    const double c = bodyRockClearance(referee, sc, p, 2.0 * 3.14159265358979323846 * double(k) / kHeadings);
    fit.least_m = std::min(fit.least_m, c);
    fit.most_m = std::max(fit.most_m, c);
  }
  return fit;
}

std::string robotBodyName(const local::RobotLimits& robot) {
  char buf[96];
  if (robot.ground() && robot.footprint.box)
    std::snprintf(buf, sizeof buf, "the robot's %.2f x %.2f m body", robot.footprint.length_m, robot.footprint.width_m);
  else if (robot.ground())
    std::snprintf(buf, sizeof buf, "the robot's body (radius %.2f m)", robot.footprint.radius_m);
  else
    std::snprintf(buf, sizeof buf, "the robot (radius %.2f m)", robot.radius_m);
  return buf;
}

Status checkRunEnds(const Scenario& sc, const Environment& env) {
  const double r = sc.params.robot.radius_m;
  const bool ground = sc.params.robot.ground();
  if (env.field()) {
    if (!env.field()->isFree(sc.start)) return invalidArgument(sc.file + ": start: inside rock");
    if (!env.field()->isFree(sc.goal)) return invalidArgument(sc.file + ": goal: inside rock");
  }
  char why[200];
  if (bodyRockClearance(sc, env, sc.start, ground ? startYaw(sc) : 0.0) <= 0.0) {
    if (ground)
      std::snprintf(why, sizeof why, "start: %s overlaps rock there, heading %.0f deg (on the floor under it)",
                    robotBodyName(sc.params.robot).c_str(), startYaw(sc) * 180.0 / 3.14159265358979323846);
    else
      std::snprintf(why, sizeof why, "start: the robot (radius %f m) overlaps rock", r);
    return invalidArgument(sc.file + ": " + why);
  }
  // A goal the robot cannot be at is refused before the run, not discovered as a stall by it. A
  // ground robot need only stand there at some heading.
  if (!env.field()) return Status();
  if (ground) {
    if (bodyFit(sc, env, sc.goal).most_m <= 0.0) {
      std::snprintf(why, sizeof why, "goal: %s does not fit there at any heading (on the floor under it)",
                    robotBodyName(sc.params.robot).c_str());
      return invalidArgument(sc.file + ": " + why);
    }
  } else if (bodyRockClearance(sc, env, sc.goal, 0.0) <= 0.0) {
    std::snprintf(why, sizeof why, "goal: the robot (radius %.2f m) does not fit there: its sphere overlaps rock "
                  "(centre %.2f m from the nearest rock voxel)", r, env.field()->distance(sc.goal));
    return invalidArgument(sc.file + ": " + why);
  }
  return Status();
}

double startYaw(const Scenario& sc) {
  const std::vector<Vec3>& pts = sc.expected_path.points;
  for (std::size_t i = 1; i < pts.size(); ++i) {
    const Vec3 d = pts[i] - pts[0];
    if (std::hypot(d.x(), d.y()) > 1e-6) return std::atan2(d.y(), d.x());
  }
  const Vec3 d = sc.goal - sc.start;
  return std::hypot(d.x(), d.y()) > 1e-6 ? std::atan2(d.y(), d.x()) : 0.0;
}

bool collisionVerdict(SimulationResult& res) {
  if (res.collisions == 0) return false;
  res.outcome = res.first_collision_by_mover ? Outcome::kHitByMover : Outcome::kCollision;
  std::ostringstream os;
  if (res.first_collision_by_mover)
    os << res.first_collision_with << " ran into the robot, which was not closing on it, at t = " << res.first_collision_t_s
       << " s (" << res.collisions << " periods in contact)";
  else
    os << "the robot overlapped " << res.first_collision_with << " at t = " << res.first_collision_t_s << " s ("
       << res.collisions << " periods in contact)";
  res.message = os.str();
  return true;
}

StatusOr<SimulationResult> simulate(const Scenario& scenario, const Environment& env, const SimulateOptions& options) {
  ADIT_RETURN_IF_ERROR(scenario.validate());
  ADIT_ASSIGN_OR_RETURN(const Scenario sc, placeOnFloor(scenario, env));
  if (sc.needsNavigator())
    return invalidArgument(sc.file + ": expected_path: plan, robot.sensor_range and events need the navigator "
                           "(adit::simulateNavigated)");
  const bool select_subgoals = sc.subgoal_mode != SubgoalMode::kNone;
  if (select_subgoals && !options.subgoals)
    return invalidArgument(sc.file + ": subgoals: " + subgoalModeName(sc.subgoal_mode) +
                           " needs the selector of adit::fusion (SimulateOptions::subgoals)");
  const double r = sc.params.robot.radius_m;
  ADIT_RETURN_IF_ERROR(checkRunEnds(sc, env));
  const double yaw0 = sc.params.robot.ground() ? startYaw(sc) : 0.0;

  World world;
  world.field = env.field();
  world.checker = env.checker();
  world.shape = map::RobotShape::sphere(r);
  world.static_obstacles = sc.static_obstacles;
  ADIT_ASSIGN_OR_RETURN(LocalPlanner planner, LocalPlanner::create(sc.params, world));

  SimulationResult res;
  res.arrival_tolerance_m = sc.params.monitor.arrival_tolerance_m;
  const std::size_t nm = sc.moving_obstacles.size();
  res.closest.resize(nm);
  for (std::size_t i = 0; i < nm; ++i) res.closest[i].name = sc.moving_obstacles[i].name;
  std::vector<map::MovingObstacle> sensed(nm);
  std::vector<double> step_us;
  const auto max_steps = std::size_t(std::ceil(sc.t_max_s / sc.dt_s - 1e-9));
  step_us.reserve(max_steps);
  res.trajectory.reserve(max_steps + 1);

  RobotState state;
  state.position = sc.start;
  state.yaw = yaw0;
  double t = 0.0;
  res.trajectory.push_back({0.0, state.position, state.velocity, StepStatus::kFollowing, state.position, state.yaw});
  bool stuck = false;
  StepStatus last = StepStatus::kFollowing;
  // Sub-goals: chosen at the start of each period of subgoal_period_s steps, and again as soon as
  // the robot moves on to the next segment (the old sub-goal aimed at the passed break point).
  const auto period_steps = std::size_t(std::llround(sc.subgoal_period_s / sc.dt_s));
  std::size_t next_selection = 0, selected_segment = 0;
  std::optional<Vec3> subgoal;  // in force
  EscapeRecord escapes;

  for (std::size_t k = 0; k < max_steps; ++k) {
    for (std::size_t i = 0; i < nm; ++i) {
      const map::MovingObstacle& m = sc.moving_obstacles[i].obstacle;
      sensed[i] = m;
      sensed[i].position = m.positionAt(t);
      sensed[i].velocity = m.velocityAt(t);
    }
    if (select_subgoals && (k >= next_selection || planner.currentSegment() != selected_segment)) {
      selected_segment = planner.currentSegment();
      next_selection = k + period_steps;
      const std::vector<Vec3>& pts = sc.expected_path.points;
      SubgoalRequest rq;
      rq.t_s = t;
      rq.state = &state;
      rq.segment_a = pts.size() >= 2 ? pts[selected_segment] : pts.back();
      rq.segment_b = pts.size() >= 2 ? pts[selected_segment + 1] : pts.back();
      rq.moving = &sensed;
      rq.static_obstacles = &sc.static_obstacles;
      rq.field = env.field();
      const auto s0 = std::chrono::steady_clock::now();
      const SubgoalPick pick = options.subgoals(rq);
      res.subgoals.add(pick.kind, std::chrono::duration<double, std::micro>(std::chrono::steady_clock::now() - s0).count());
      subgoal = pick.point;
      if (pick.point) planner.setSubgoal(pick.aim);
      else planner.clearSubgoal();
    }
    const auto t0 = std::chrono::steady_clock::now();
    const StepCommand c = planner.step(state, sc.expected_path, sensed, sc.dt_s);
    const auto t1 = std::chrono::steady_clock::now();
    step_us.push_back(std::chrono::duration<double, std::micro>(t1 - t0).count());
    ++res.steps;
    escapes.add(c.escapes, t, res);
    last = c.status;
    if (c.status == StepStatus::kArrived) break;
    if (c.status == StepStatus::kStuck || c.status == StepStatus::kRefused) {
      stuck = true;
      res.message = c.message;
      break;
    }
    refereePeriod(sc, env, c, t, state, res);
    t = double(k + 1) * sc.dt_s;
    res.trajectory.push_back({t, state.position, state.velocity, c.status, subgoal.value_or(c.sub_goal), state.yaw});
  }
  res.final_goal_distance_m = (state.position - sc.goal).norm();
  res.step_time_p50_us = stepTimePercentile(step_us, 0.5);
  res.step_time_p99_us = stepTimePercentile(step_us, 0.99);
  // The verdict is the referee's, not the planner's.
  const bool within = res.final_goal_distance_m <= res.arrival_tolerance_m;
  if (collisionVerdict(res)) {
  } else if (last == StepStatus::kArrived && within) {
    res.outcome = Outcome::kArrived;
    res.arrival_time_s = t;
  } else if (stuck) {
    res.outcome = Outcome::kStuck;
  } else {
    res.outcome = Outcome::kTimeout;
    res.message = "t_max reached";
  }
  res.end_cause = endCause(sc, res.outcome, res.final_goal_distance_m, 0.0, sc.expected_path.length());
  if (!res.trajectory.empty()) res.trajectory.back().status = last;
  return res;
}

fusion::SubgoalParams subgoalParamsFor(const Scenario& scenario) {
  fusion::SubgoalParams p;
  p.t0_s = scenario.subgoal_period_s;
  p.optimizer.seed = scenario.seed;
  return p;
}

}  // namespace adit::sim
