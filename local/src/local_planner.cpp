// SPDX-License-Identifier: BSD-3-Clause
#include "adit/local/local_planner.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>

#include "adit/local/potential_terms.hpp"
#include "adit/map/collision.hpp"
#include "adit/map/content_hash.hpp"
#include "adit/map/distance_field.hpp"
#include "adit/map/rock_points.hpp"

namespace adit::local {

using map::allFinite;

namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr std::size_t kMaxObstacles = 512;   // kept per period (the nearest win when more)
constexpr std::size_t kRockBuffer = 8192;    // rock surface points per period
constexpr double kClosingSpeed = 0.05;       // m/s: slower relative motion counts as static
constexpr int kMaxSightSamples = 4096;       // bounds the line-of-sight test's work per period

bool finiteShape(const map::RobotShape& s) {
  return std::isfinite(s.radius) && std::isfinite(s.length) && allFinite(s.size);
}

// Nearest point of an obstacle shape (identity orientation, centred at c) to q; false when q is
// inside it.
bool nearestOnShape(const map::RobotShape& s, const Vec3& c, const Vec3& q, Vec3* out) {
  const Vec3 d = q - c;
  switch (s.type) {
    case map::ShapeType::kSphere: {
      const double n = d.norm();
      if (n <= s.radius) return false;
      *out = c + d * (s.radius / n);
      return true;
    }
    case map::ShapeType::kBox: {
      const Vec3 h = 0.5 * s.size;
      const Vec3 cl = d.cwiseMax(-h).cwiseMin(h);
      if (cl == d) return false;
      *out = c + cl;
      return true;
    }
    case map::ShapeType::kCylinder:
    case map::ShapeType::kCapsule: {
      const double hl = 0.5 * s.length;
      if (s.type == map::ShapeType::kCapsule) {
        const Vec3 axis_pt(0, 0, std::clamp(d.z(), -hl, hl));
        const Vec3 r = d - axis_pt;
        const double n = r.norm();
        if (n <= s.radius) return false;
        *out = c + axis_pt + r * (s.radius / n);
        return true;
      }
      const Vec3 radial(d.x(), d.y(), 0.0);
      const double rn = radial.norm();
      const bool inside_r = rn <= s.radius, inside_z = std::abs(d.z()) <= hl;
      if (inside_r && inside_z) return false;
      const Vec3 rp = inside_r ? radial : Vec3(radial * (s.radius / rn));
      *out = c + Vec3(rp.x(), rp.y(), std::clamp(d.z(), -hl, hl));
      return true;
    }
  }
  return false;
}

// Bearing of `to` about the heading in the horizontal plane, positive to the left.
double bearing(const Vec3& heading, const Vec3& to) {
  const double cross = heading.x() * to.y() - heading.y() * to.x();
  const double dot = heading.x() * to.x() + heading.y() * to.y();
  return std::atan2(cross, dot);
}

Vec3 clampNorm(const Vec3& v, double max) {
  const double n = v.norm();
  return n > max ? Vec3(v * (max / n)) : v;
}

Vec3 unitOr(const Vec3& v, const Vec3& fallback) {
  const double n = v.norm();
  return n > 1e-12 ? Vec3(v / n) : fallback;
}

// FNV-1a over the path's coordinates: any change of any point is a new path.
std::uint64_t pathSignature(const map::Polyline& path) {
  std::uint64_t h = map::kFnv1a64Basis;
  for (const Vec3& p : path.points)
    for (int i = 0; i < 3; ++i) {
      const double x = p[i];
      h = map::fnv1a64(&x, sizeof x, h);
    }
  return h;
}

// How far the method's repulsion reaches: rock beyond it is not gathered.
double repulsionRange(const LocalParams& p) {
  switch (p.method) {
    case Method::kClassic: return p.classic.rho0_m;
    case Method::kTian2016: return p.tian2016.rho0_m;
    case Method::kWang2014: return std::max(p.wang2014.sensing_radius_m, 0.0);
    case Method::kVff:
    case Method::kCvff: return p.vff.p0_m;
    case Method::kUuv: return p.uuv.rho0_m;
  }
  return 0.0;
}

// The band scan's range: the repulsion's, or pursuit's lookahead when that is longer (pursuit
// asks whether the line to its point is clear of the band's rock, and the field does not know a
// floor too steep is rock there).
double bandRange(const LocalParams& p) {
  return p.pursuit.enabled ? std::max(repulsionRange(p), p.pursuit.lookahead_m) : repulsionRange(p);
}

// The footprint at p, turned to yaw, to the nearest of a band scan's points (its gap, 0 on or
// inside it).
double footprintGapToBand(const map::BandScan& scan, const Footprint& f, const Vec3& p, double yaw) {
  const double c = std::cos(yaw), s = std::sin(yaw);
  double least = std::numeric_limits<double>::infinity();
  for (int b = 0; b < map::BandScan::kBins; ++b) {
    if (!std::isfinite(scan.distance[b])) continue;
    const double dx = scan.point[b].x() - p.x(), dy = scan.point[b].y() - p.y();
    least = std::min(least, f.gapTo(c * dx + s * dy, -s * dx + c * dy));
  }
  return least;
}

}  // namespace

const char* stepStatusName(StepStatus s) {
  switch (s) {
    case StepStatus::kFollowing: return "following";
    case StepStatus::kYielding: return "yielding";
    case StepStatus::kDetouring: return "detouring";
    case StepStatus::kStuck: return "stuck";
    case StepStatus::kArrived: return "arrived";
    case StepStatus::kRefused: return "refused";
  }
  return "?";
}

StatusOr<LocalPlanner> LocalPlanner::create(const LocalParams& params, World world) {
  ADIT_RETURN_IF_ERROR(params.validate());
  for (std::size_t i = 0; i < world.static_obstacles.size(); ++i) {
    const StaticSphere& s = world.static_obstacles[i];
    if (!allFinite(s.center) || !(s.radius >= 0.0) || !std::isfinite(s.radius))
      return invalidArgument("static_obstacles[" + std::to_string(i) + "]: centre and radius must be finite, radius >= 0");
  }
  if (world.shape.type != map::ShapeType::kSphere) {
    ADIT_RETURN_IF_ERROR(world.shape.validate());
    if (!world.checker) return invalidArgument("World::shape is not a sphere but no CollisionChecker is given");
  }
  return LocalPlanner(params, std::move(world));
}

LocalPlanner::LocalPlanner(const LocalParams& params, World world) : params_(params), world_(std::move(world)) {
  obstacles_.reserve(kMaxObstacles);
  reachable_.reserve(kMaxObstacles);
  rock_points_.resize(world_.field ? kRockBuffer : 0);
  ground_ = params_.robot.ground();
  if (ground_) {
    // The sphere's bottom max_step plus one voxel above the floor: a floor quantised to voxels
    // rises a voxel between two samples on a slope, and that voxel is not rock in the way.
    // In open space the floor is flat, half the height under the robot.
    lift_ = params_.robot.probeLift(world_.field ? world_.field->resolution() : 0.0);
    if (world_.field)
      band_cache_.reserve(world_.field->resolution(), bandRange(params_) + params_.robot.radius_m, params_.robot.max_step_m,
                          std::tan(params_.robot.max_slope_deg * kPi / 180.0), params_.robot.height_m);
  }
}

void LocalPlanner::scanBand(const Vec3& q, double range, double speed) {
  const RobotLimits& r = params_.robot;
  const double res = world_.field->resolution(), tan_max = std::tan(r.max_slope_deg * kPi / 180.0);
  const std::optional<double> f =
      map::floorBelow(*world_.field, q + Vec3(0, 0, r.max_step_m), 0.5 * r.height_m + r.max_step_m + 2.0 * res);
  floor_z_ = f ? *f : q.z() - 0.5 * r.height_m;
  // The body's underside stands max_step and a voxel above the floor's plane, fitted as the
  // referee fits it (over 2.5 m about the robot, clamped to the slope limit): what rises above it
  // under the body, or where the body gets to before it stops, is in the way.
  // (Refitting it only every quarter metre, or from 5 x 5 samples, left a Koutzi run in contact.)
  const map::FloorSlope plane = map::floorSlope(*world_.field, Vec3(q.x(), q.y(), floor_z_), 0.0,
                                                std::max(2.5, r.radius_m), tan_max, r.max_step_m, 9, &band_cache_);
  map::BandBody body;
  body.grad_x = std::clamp(plane.along, -tan_max, tan_max);
  body.grad_y = std::clamp(plane.across, -tan_max, tan_max);
  plane_gx_ = body.grad_x;
  plane_gy_ = body.grad_y;
  body.reach = r.radius_m + speed * 0.1 + speed * speed / (2.0 * r.a_max_mps2);
  body.clearance = r.max_step_m + res;
  map::rockInBand(*world_.field, q, range + r.radius_m, floor_z_, r.max_step_m, tan_max, r.height_m, band_, 1u << 16,
                  &band_cache_, &body);
  band_centre_ = q;
  band_nearest_ = std::numeric_limits<double>::infinity();
  for (int b = 0; b < map::BandScan::kBins; ++b) band_nearest_ = std::min(band_nearest_, band_.distance[b]);
}

double LocalPlanner::slopeAhead(const Vec3& q, const Vec3& u) const {
  if (!world_.field) return 0.0;
  const RobotLimits& r = params_.robot;
  const double res = world_.field->resolution(), tan_max = std::tan(r.max_slope_deg * kPi / 180.0);
  // Over a metre (four voxels on coarse maps): a floor quantised to voxels is a staircase.
  const double run = std::max(1.0, 4.0 * res);
  const Vec3 ahead(q.x() + u.x() * run, q.y() + u.y() * run, floor_z_ + run * tan_max + r.max_step_m + res);
  const std::optional<double> f = map::floorBelow(*world_.field, ahead, 2.0 * run * tan_max + r.max_step_m + 2.0 * res);
  if (!f) return 0.0;
  return std::clamp((*f - floor_z_) / run, -tan_max, tan_max);
}

void LocalPlanner::driveCommand(const RobotState& state, const Vec3& v_cmd, const Vec3& wish, double dt,
                                StepCommand& cmd) {
  const RobotLimits& R = params_.robot;
  constexpr double kYawGain = 2.0;        // [1/s]: heading error to yaw rate (pure-pursuit-like)
  constexpr double kReverseRad = 2.2;     // wanted direction this far behind: back off in reverse
  const double a_max = R.a_max_mps2, v_max = R.v_max_mps;
  const Vec3 q = state.position, want(v_cmd.x(), v_cmd.y(), 0.0);
  const double yaw = state.yaw, speed = want.norm();
  const Vec3 fwd(std::cos(yaw), std::sin(yaw), 0.0);
  const double vf0 = Vec3(state.velocity.x(), state.velocity.y(), 0.0).dot(fwd);
  // Yaw acceleration limit about the present rate (a rate beyond omega_max is brought back).
  double w_lo = std::max(-R.omega_max_rps, state.yaw_rate - R.alpha_max_rps2 * dt);
  double w_hi = std::min(R.omega_max_rps, state.yaw_rate + R.alpha_max_rps2 * dt);
  if (w_lo > w_hi) w_lo = w_hi = state.yaw_rate > 0.0 ? w_lo : w_hi;
  auto wrap = [](double x) { return std::remainder(x, 2.0 * kPi); };
  Vec3 v_new;
  double vf = 0.0, w = 0.0;
  if (R.drive == DriveType::kHolonomic) {
    // The wish within a_max of the present velocity (in the floor's plane).
    const Vec3 v_flat(state.velocity.x(), state.velocity.y(), 0.0);
    v_new = clampNorm(Vec3(v_flat + clampNorm(Vec3(want - v_flat), a_max * dt)), v_max);
    const double err = speed > 0.05 ? wrap(std::atan2(want.y(), want.x()) - yaw) : 0.0;
    w = std::clamp(kYawGain * err, w_lo, w_hi);
    vf = v_new.dot(fwd);
  } else {
    double err = speed > 1e-3 ? wrap(std::atan2(want.y(), want.x()) - yaw) : 0.0;
    double sign = 1.0;
    const bool car = R.drive == DriveType::kAckermann;
    // The envelope stopped the wish: tracks and differential wheels still turn toward it on the
    // spot (the covering circle turns in place without touching anything), so that the next
    // period starts facing the way out rather than frozen facing the rock.
    if (!car && speed <= 1e-3 && Vec3(wish.x(), wish.y(), 0.0).norm() > 1e-3)
      err = wrap(std::atan2(wish.y(), wish.x()) - yaw);
    // Backing off (a slow wish behind the robot): reverse rather than turn about.
    if (std::abs(err) > kReverseRad && speed <= 0.55 * v_max) {
      sign = -1.0;
      err = wrap(err + kPi);
    }
    double w_des = std::clamp(kYawGain * err, -R.omega_max_rps, R.omega_max_rps);
    // No speed while facing away: turn first (on the spot, for tracks and differential wheels).
    double vf_des = sign * speed * std::max(0.0, std::cos(err));
    if (car && std::abs(err) > 0.5 * kPi && speed > 1e-3) {
      // A car cannot turn on the spot: it turns about slowly at full steer, forward until that is
      // blocked, then in reverse (the yaw rate keeps its sense), and so on: a many-point turn.
      vf_des = car_direction_ * sign * 0.3 * speed;
    }
    vf = std::clamp(vf_des, vf0 - a_max * dt, vf0 + a_max * dt);
    vf = std::clamp(vf, -v_max, v_max);
    if (R.drive == DriveType::kAckermann) {
      const double w_steer = std::abs(vf) * std::tan(R.max_steer_deg * kPi / 180.0) / R.wheelbase();
      w_des = std::clamp(w_des, -w_steer, w_steer);
    }
    // The turn's lateral acceleration is held to a_max too: a fast robot turns wide and slows.
    if (std::abs(vf) > 1e-6) w_des = std::clamp(w_des, -a_max / std::abs(vf), a_max / std::abs(vf));
    w = std::clamp(w_des, w_lo, w_hi);
    const double yaw_end = yaw + w * dt;
    v_new = vf * Vec3(std::cos(yaw_end), std::sin(yaw_end), 0.0);
  }
  auto onFloor = [&](Vec3 v) {
    const double h = v.norm();
    if (h > 1e-9) v.z() = slopeAhead(q, v / h) * h;
    return v;
  };
  v_new = onFloor(v_new);
  // The drive's heading is not the set-point's: its stopping run must be clear as well, or its
  // speed comes down (no further than braking at a_max allows).
  if (params_.envelope.enabled) {
    const double floor = stoppingFloor(q);
    const bool tracks = R.drive == DriveType::kDifferential || R.drive == DriveType::kSkid;
    if (tracks && std::abs(vf) > 1e-6 && !stoppingArcClear(q, v_new, w, dt, floor)) {
      // Braking while the heading swings toward rock curves the stopping run into it (a robot
      // turning out of a bend at speed): the yaw rate within reach whose run is clear, nearest
      // the wish, if there is one.
      double best = w, best_cost = std::numeric_limits<double>::infinity();
      for (int i = 0; i <= 8; ++i) {
        const double wi = w_lo + (w_hi - w_lo) * double(i) / 8.0, yaw_end = yaw + wi * dt;
        if (std::abs(wi - w) < best_cost &&
            stoppingArcClear(q, onFloor(vf * Vec3(std::cos(yaw_end), std::sin(yaw_end), 0.0)), wi, dt, floor)) {
          best = wi;
          best_cost = std::abs(wi - w);
        }
      }
      // None clear: brake straight on (what the envelope's barrier assumed), not swinging on,
      // unless the robot stops within this period anyway (then it turns on the spot).
      if (std::isfinite(best_cost)) w = best;
      else if (std::abs(vf0) > a_max * dt) w = std::clamp(0.0, w_lo, w_hi);
      v_new = onFloor(vf * Vec3(std::cos(yaw + w * dt), std::sin(yaw + w * dt), 0.0));
    }
    // The box's corners swing as it turns: a rate whose swing (this period's and the stop's)
    // takes its outline into rock is replaced by the one nearest it that does not, or the
    // slowest within reach.
    const double turn_grow = R.drive != DriveType::kAckermann ? turnGrow(q, yaw) : -1.0;
    if (turn_grow >= 0.0 && !turnClear(q, yaw, w, dt, turn_grow)) {
      double best = std::clamp(0.0, w_lo, w_hi), best_cost = std::numeric_limits<double>::infinity();
      for (int i = 0; i <= 8; ++i) {
        const double wi = w_lo + (w_hi - w_lo) * double(i) / 8.0;
        if (std::abs(wi - w) < best_cost && turnClear(q, yaw, wi, dt, turn_grow)) {
          best = wi;
          best_cost = std::abs(wi - w);
        }
      }
      w = best;
      if (R.drive != DriveType::kHolonomic) {
        // Held from turning toward the wish and hardly moving: edge along the heading the way
        // the box gains clearance (backing off a rib to turn), slowly, where a decimetre on is
        // free for its outline in voxels (the band's points are too sparse for its corners);
        // the stopping runs below still check that way.
        if (std::abs(vf) < 0.05 * v_max) {
          const double now = footprintClearance(q, yaw);
          double back = footprintClearance(q - 0.1 * fwd, yaw), ahead = footprintClearance(q + 0.1 * fwd, yaw);
          if (!boxFree(q - 0.1 * fwd, yaw, 0.01)) back = -1.0;
          if (!boxFree(q + 0.1 * fwd, yaw, 0.01)) ahead = -1.0;
          if (std::max(back, ahead) > now) {
            const double edge = (ahead > back ? 1.0 : -1.0) * 0.2 * v_max;
            vf = std::clamp(edge, vf0 - a_max * dt, vf0 + a_max * dt);
          }
        }
        v_new = onFloor(vf * Vec3(std::cos(yaw + w * dt), std::sin(yaw + w * dt), 0.0));
      }
    }
    // Tracks keep turning as they brake (the yaw rate falls at alpha_max); a car's rate is its
    // speed's, and slower it turns less.
    const double w_run = tracks ? w : 0.0;
    if (!stoppingArcClear(q, v_new, w_run, dt, floor)) {
      const double h0 = Vec3(v_new.x(), v_new.y(), 0.0).norm();
      const double slowest = std::max(0.0, std::abs(vf0) - a_max * dt);
      double lo = h0 > 1e-9 ? std::min(1.0, slowest / h0) : 0.0, hi = 1.0;
      if (!stoppingArcClear(q, v_new * lo, w_run, dt, floor)) hi = lo;
      for (int i = 0; i < 10 && hi > lo; ++i) {
        const double mid = 0.5 * (lo + hi);
        (stoppingArcClear(q, v_new * mid, w_run, dt, floor) ? lo : hi) = mid;
      }
      v_new *= lo;
      vf *= lo;
      if (R.drive == DriveType::kAckermann) {
        // A car's yaw rate is its speed's (steering angle fixed): slower, it turns slower.
        w *= lo;
        const double yaw_end = yaw + w * dt;
        const double z = v_new.z();
        v_new = vf * Vec3(std::cos(yaw_end), std::sin(yaw_end), 0.0);
        v_new.z() = z;
        // A turn about that can go no further this way goes the other way next period.
        if (lo < 0.2) car_direction_ = -car_direction_;
      }
    }
  }
  cmd.velocity = v_new;
  cmd.acceleration = (v_new - state.velocity) / dt;
  cmd.forward_speed = vf;
  cmd.yaw_rate = w;
}

void LocalPlanner::reset() {
  clock_s_ = 0.0;
  best_progress_ = std::numeric_limits<double>::infinity();
  last_improvement_s_ = 0.0;
  wait_credit_s_ = 0.0;
  escapes_ = 0;
  escaping_ = false;
  stuck_ = false;
  segment_ = 0;
  path_size_ = 0;
}

void LocalPlanner::addRockPoints(const Vec3& q, const Vec3& v, const Vec3& a, double radius) {
  // Wang 2014 sees only its field of view: the scan skips the rest (the same test as inFieldOfView).
  map::ViewCone cone;
  if (params_.method == Method::kWang2014) {
    cone.axis = unitOr(v, Vec3::Zero());
    cone.half_angle_rad = params_.wang2014.view_half_angle_deg * kPi / 180.0;
  }
  const map::RockPointsResult r =
      map::rockSurfacePoints(*world_.field, q, radius, cone, rock_points_.data(), rock_points_.size());
  // One point per direction bin (the nearest), as a range sensor would see the rock: a wall is
  // then a few obstacles, not hundreds of voxels whose forces would swamp everything else.
  bin_distance_.fill(std::numeric_limits<double>::infinity());
  for (std::size_t i = 0; i < r.written; ++i) {
    const Vec3 d = rock_points_[i] - q;
    const double n = d.norm();
    if (n <= 1e-9) continue;
    const double az = std::atan2(d.y(), d.x()), el = std::asin(std::clamp(d.z() / n, -1.0, 1.0));
    const int ia = std::min(kAzimuthBins - 1, int((az + kPi) / (2 * kPi) * kAzimuthBins));
    const int ie = std::min(kElevationBins - 1, int((el + 0.5 * kPi) / kPi * kElevationBins));
    const int b = ie * kAzimuthBins + ia;
    if (n < bin_distance_[std::size_t(b)]) {
      bin_distance_[std::size_t(b)] = n;
      bin_point_[std::size_t(b)] = rock_points_[i];
    }
  }
  const double rr = params_.robot.radius_m;
  for (std::size_t b = 0; b < bin_distance_.size(); ++b) {
    if (!std::isfinite(bin_distance_[b]) || obstacles_.size() >= kMaxObstacles) continue;
    const Proximity p = pointProximity(q, bin_point_[b], rr);
    obstacles_.push_back({p.rho, p.grad, p.pivot_distance, v, a, bin_point_[b], false, false});
  }
}

void LocalPlanner::gatherObstacles(const Vec3& q, const Vec3& v, const Vec3& a, const map::MovingObstacle* moving,
                                   std::size_t moving_count) {
  obstacles_.clear();
  const double rr = params_.robot.radius_m;
  const double range = repulsionRange(params_);
  auto keep = [&](const ObstacleData& o) {
    if (!(o.rho <= range)) return;
    if (obstacles_.size() < kMaxObstacles) {
      obstacles_.push_back(o);
      return;
    }
    auto far = std::max_element(obstacles_.begin(), obstacles_.end(),
                                [](const ObstacleData& x, const ObstacleData& y) { return x.rho < y.rho; });
    if (far->rho > o.rho) *far = o;
  };

  if (world_.field && ground_) {
    // What stands in the body's band, as a horizontal scan: a ground robot is repelled within the
    // floor's plane, by rock that is in its way, never by the floor it drives on.
    const bool all_points = params_.method == Method::kWang2014 || params_.method == Method::kVff ||
                            params_.method == Method::kCvff;
    scanBand(q, bandRange(params_), Vec3(v.x(), v.y(), 0.0).norm());
    int best = -1;
    for (int b = 0; b < map::BandScan::kBins; ++b) {
      if (!std::isfinite(band_.distance[b])) continue;
      if (all_points) {
        const Vec3 flat(band_.point[b].x(), band_.point[b].y(), q.z());
        const Proximity p = pointProximity(q, flat, rr);
        keep({p.rho, p.grad, p.pivot_distance, v, a, flat, false, false});
      } else if (best < 0 || band_.distance[b] < band_.distance[best]) {
        best = b;
      }
    }
    if (best >= 0) {
      const Vec3 flat(band_.point[best].x(), band_.point[best].y(), q.z());
      const Proximity p = pointProximity(q, flat, rr);
      keep({p.rho, p.grad, p.pivot_distance, v, a, flat, false, false});
    }
  } else if (world_.field) {
    const bool all_points = params_.method == Method::kWang2014 || params_.method == Method::kVff ||
                            params_.method == Method::kCvff;
    if (world_.shape.type != map::ShapeType::kSphere && world_.checker) {
      // The exact robot shape against the rock, turned to the direction of travel.
      Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
      pose.translation() = q;
      if (std::hypot(v.x(), v.y()) > 1e-6) pose.linear() = Eigen::AngleAxisd(std::atan2(v.y(), v.x()), Vec3::UnitZ()).toRotationMatrix();
      const map::ShapeDistance d = world_.checker->distance(world_.shape, pose, range);
      if (d.exact && allFinite(d.point_on_obstacle)) {
        const Vec3 sep = d.point_on_robot - d.point_on_obstacle;
        Vec3 g = sep.norm() > 1e-9 ? Vec3(sep.normalized()) : world_.field->query(q).gradient;
        if (g.norm() < 0.5) g = Vec3::UnitZ();
        keep({d.distance_m, g, sep.norm(), v, a, d.point_on_obstacle, false, false});
      }
    } else if (all_points) {
      addRockPoints(q, v, a, range + rr);
    } else {
      const map::DistanceSample s = world_.field->query(q);
      if (!s.in_rock) {
        const Proximity p = pointProximity(q, s.nearest, rr);
        keep({p.rho, p.grad, p.pivot_distance, v, a, s.nearest, false, false});
      }
    }
  }
  for (const StaticSphere& s : world_.static_obstacles) {
    const Proximity p = sphereProximity(q, s.center, s.radius, rr);
    keep({p.rho, p.grad, p.pivot_distance, v, a, s.center - p.grad * s.radius, false, false});
  }
  const double horizon = params_.method == Method::kClassic ? 0.0 : params_.monitor.prediction_horizon_s;
  for (std::size_t i = 0; i < moving_count; ++i) {
    const map::MovingObstacle& m = moving[i];
    // Where the obstacle will be relative to the robot at their closest approach within the
    // horizon (constant acceleration for the obstacle, constant velocity for the robot): the
    // robot is repelled from that encounter, not only from where the obstacle is now.
    Vec3 centre = m.position;
    const Vec3 d0 = q - m.position, w = v - m.velocity;
    const bool closing = -d0.dot(w) > kClosingSpeed * d0.norm();
    if (horizon > 0.0) {
      const double w2 = w.squaredNorm();
      const double t_star = w2 > 1e-12 ? std::clamp(-d0.dot(w) / w2, 0.0, horizon) : 0.0;
      const Vec3 d_star = (q + v * t_star) - m.positionAt(t_star);
      // A later encounter is less pressing: by then the robot can move 1/2 a_max t^2 aside.
      const double dist = std::min(d0.norm(), d_star.norm() + 0.5 * params_.robot.a_max_mps2 * t_star * t_star);
      if (dist < d0.norm()) centre = q - unitOr(d_star, unitOr(d0, Vec3::UnitX())) * dist;
    }
    Proximity p;
    Vec3 point;
    if (m.shape.type == map::ShapeType::kSphere) {
      p = sphereProximity(q, centre, m.shape.radius, rr);
      point = centre - p.grad * m.shape.radius;
    } else if (nearestOnShape(m.shape, centre, q, &point)) {
      p = pointProximity(q, point, rr);
    } else {
      p = sphereProximity(q, centre, m.shape.boundingRadius(), rr);  // inside: push out
      point = centre;
    }
    keep({p.rho, p.grad, p.pivot_distance, v - m.velocity, a - m.acceleration, point, true, closing});
  }
}

double LocalPlanner::encounterMargin(const Vec3& q, const Vec3& v, const Vec3& v_target,
                                     const map::MovingObstacle* moving) const {
  constexpr double kSample = 0.1;   // s
  constexpr double kMargin = 0.05;  // m kept free beyond the bounding spheres
  const double a_max = params_.robot.a_max_mps2, rr = params_.robot.radius_m;
  const int n = std::max(1, int(std::ceil(params_.monitor.safety_horizon_s / kSample)));
  Vec3 pos = q, vel = v;
  double margin = std::numeric_limits<double>::infinity();
  for (int k = 1; k <= n; ++k) {
    vel += clampNorm(v_target - vel, a_max * kSample);
    pos += vel * kSample;
    const double t = double(k) * kSample;
    for (std::size_t i : reachable_) {
      const map::MovingObstacle& m = moving[i];
      margin = std::min(margin, (pos - m.positionAt(t)).norm() - m.shape.boundingRadius() - rr - kMargin);
    }
    for (const StaticSphere& s : world_.static_obstacles)
      margin = std::min(margin, (pos - s.center).norm() - s.radius - rr - kMargin);
  }
  return margin;
}

Vec3 LocalPlanner::capTowardRock(const Vec3& q, Vec3 v_des, double dt, const map::MovingObstacle* moving,
                                 std::size_t moving_count) const {
  const double kKeep = params_.envelope.keep_m;  // clearance the cap keeps in reserve
  const double a_max = params_.robot.a_max_mps2, rr = params_.robot.radius_m;
  // The fastest approach that still stops short: one period at that speed, then braking at a_max
  // (v dt + v^2 / 2a = gap), since the next command comes a period later. `own` is the
  // obstacle's speed along `toward` (a mover's): the robot's approach is what it adds to that.
  auto cap = [&](const Vec3& toward, double gap, double own = 0.0) {
    const double ad = a_max * dt;
    const double allowed = std::max(0.0, -ad + std::sqrt(ad * ad + 2.0 * a_max * std::max(0.0, gap - kKeep)));
    const double approach = v_des.dot(toward);
    if (approach > allowed + own) v_des -= (approach - allowed - own) * toward;
  };
  // Movers first, under their present motion: where one closes faster than the robot can brake,
  // the cap asks the robot to back off. Rock comes last, so that giving way never means rock.
  for (std::size_t i = 0; i < moving_count; ++i) {
    const map::MovingObstacle& m = moving[i];
    Vec3 point;
    if (m.shape.type == map::ShapeType::kSphere) {
      const Vec3 out = unitOr(Vec3(q - m.position), Vec3::UnitX());
      point = m.position + m.shape.radius * out;
      if ((q - m.position).norm() <= m.shape.radius) continue;  // inside: nothing to brake for
    } else if (!nearestOnShape(m.shape, m.position, q, &point)) {
      continue;
    }
    const Vec3 d = point - q;
    const double dn = d.norm();
    const double stop = v_des.norm() * dt + v_des.squaredNorm() / (2.0 * a_max) + m.velocity.norm() * dt;
    if (dn < 1e-9 || dn - rr > stop + 2.0 * m.velocity.norm() + kKeep + 0.5) continue;  // out of reach
    const Vec3 toward = d / dn;
    cap(toward, dn - rr, m.velocity.dot(toward));
  }
  for (const StaticSphere& s : world_.static_obstacles) {
    const Vec3 d = s.center - q;
    const double dn = d.norm();
    if (dn > 1e-9) cap(d / dn, dn - s.radius - rr);
  }
  // The nearest rock whatever the influence range (a fast robot needs more than rho0 to stop),
  // then every static obstacle gathered this period.
  if (world_.field && ground_) {
    for (int b = 0; b < map::BandScan::kBins; ++b) {
      if (!std::isfinite(band_.distance[b])) continue;
      const Vec3 toward(band_.point[b].x() - q.x(), band_.point[b].y() - q.y(), 0.0);
      if (toward.norm() > 1e-9) cap(toward.normalized(), band_.distance[b] - rr);
    }
  } else if (world_.field) {
    const map::DistanceSample s = world_.field->query(q);
    const Vec3 toward = s.nearest - q;
    if (!s.in_rock && toward.norm() > 1e-9) cap(toward.normalized(), s.distance - rr);
  }
  for (const ObstacleData& o : obstacles_)
    if (!o.moving) cap(-o.grad, o.rho);
  if (!world_.field) return v_des;
  // The nearest rock is not the only rock (a corner, the face at the end of a rib the robot
  // slides along): the stopping run itself (a period at v_des, then braking) must stay clear, or
  // the set-point is scaled down until it does.
  const double floor = stoppingFloor(q);
  if (stoppingRunClear(q, v_des, dt, floor)) return v_des;
  double lo = 0.0, hi = 1.0;
  for (int i = 0; i < 12; ++i) {
    const double mid = 0.5 * (lo + hi);
    (stoppingRunClear(q, mid * v_des, dt, floor) ? lo : hi) = mid;
  }
  return lo * v_des;
}

double LocalPlanner::stoppingFloor(const Vec3& q) const {
  double now = world_.field ? world_.field->distance(probe(q)) - params_.robot.radius_m : 0.0;
  // The band's rock, as near as it is now (a robot already nearer may not come nearer).
  if (ground_ && world_.field) now = std::min(now, bandClearance(q));
  return std::min(0.5 * params_.envelope.keep_m, now - 1e-6);
}

double LocalPlanner::bandClearance(const Vec3& p) const {
  double least = std::numeric_limits<double>::infinity();
  for (int b = 0; b < map::BandScan::kBins; ++b)
    if (std::isfinite(band_.distance[b]))
      least = std::min(least, std::hypot(p.x() - band_.point[b].x(), p.y() - band_.point[b].y()));
  return least - params_.robot.radius_m;
}

double LocalPlanner::footprintClearance(const Vec3& p, double yaw) const {
  if (!params_.robot.footprint.box) return std::numeric_limits<double>::infinity();
  return footprintGapToBand(band_, params_.robot.footprint, p, yaw);
}

double LocalPlanner::turnGrow(const Vec3& q, double yaw) const {
  if (!ground_ || !world_.field || !params_.robot.footprint.box) return -1.0;
  // A centimetre: the box is inside its covering circle, so a circle that far off the band's
  // rock (and the field's) turns anyway. (Half the envelope's reserve froze the BARN-like
  // benchmark's robot among pillars in 2 of 66 fields, where no turn touched.)
  constexpr double kGrow = 0.01;
  if (bandClearance(q) >= kGrow && world_.field->distance(probe(q)) - params_.robot.radius_m >= kGrow) return -1.0;
  // Where it stands already reads as in rock (a real contact, or a stepped floor whose voxels
  // the outline's heights misjudge) the check cannot tell one turn from another: it does not
  // hold the robot there.
  if (!boxFree(q, yaw, 0.0)) return -1.0;
  return boxFree(q, yaw, kGrow) ? kGrow : 0.0;
}

bool LocalPlanner::turnClear(const Vec3& q, double yaw, double w, double dt, double grow) const {
  if (grow < 0.0) return true;
  const double sweep = w * dt + w * std::abs(w) / (2.0 * params_.robot.alpha_max_rps2);
  if (std::abs(sweep) < 1e-6) return true;
  constexpr double kStep = 5.0 * kPi / 180.0;  // a corner 0.6 m out moves 5 cm a step
  const int n = std::min(72, int(std::ceil(std::abs(sweep) / kStep)));
  for (int k = 1; k <= n; ++k)
    if (!boxFree(q, yaw + sweep * double(k) / double(n), grow)) return false;
  return true;
}

bool LocalPlanner::boxFree(const Vec3& q, double yaw, double grow) const {
  const Footprint& f = params_.robot.footprint;
  const RobotLimits& r = params_.robot;
  const double res = world_.field->resolution(), step = 0.25 * res;
  const double hx = 0.5 * f.length_m + grow, hy = 0.5 * f.width_m + grow, c = std::cos(yaw), s = std::sin(yaw);
  const double bottom = r.max_step_m + res + 0.01, top = r.height_m - 0.01;
  const int levels = std::max(2, int(std::ceil((top - bottom) / res)) + 1);
  auto freeAt = [&](double u, double v) {
    const double x = q.x() + c * u - s * v, y = q.y() + s * u + c * v;
    const double base = floor_z_ + plane_gx_ * (x - q.x()) + plane_gy_ * (y - q.y());
    for (int l = 0; l < levels; ++l) {
      const double z = base + bottom + (top - bottom) * double(l) / double(levels - 1);
      if (!(top > bottom) && l > 0) break;
      if (!world_.field->isFree(Vec3(x, y, z))) return false;
    }
    return true;
  };
  const int nx = std::max(1, int(std::ceil(2.0 * hx / step))), ny = std::max(1, int(std::ceil(2.0 * hy / step)));
  for (int i = 0; i <= nx; ++i) {
    const double u = -hx + 2.0 * hx * double(i) / double(nx);
    if (!freeAt(u, -hy) || !freeAt(u, hy)) return false;
  }
  for (int j = 1; j < ny; ++j) {
    const double v = -hy + 2.0 * hy * double(j) / double(ny);
    if (!freeAt(-hx, v) || !freeAt(hx, v)) return false;
  }
  return true;
}

bool LocalPlanner::bandWithin(const Vec3& p, double floor, double yaw) const {
  // Nothing of the band can be nearer p than its nearest point less the way from where it was
  // seen; the box lies inside the circle.
  const bool box = std::isfinite(yaw) && std::isfinite(box_floor_);
  const double moved = std::hypot(p.x() - band_centre_.x(), p.y() - band_centre_.y());
  if (band_nearest_ - moved - params_.robot.radius_m >= (box ? std::max(floor, box_floor_) : floor)) return false;
  return bandClearance(p) < floor || (box && footprintClearance(p, yaw) < box_floor_);
}

bool LocalPlanner::stoppingRunClear(const Vec3& q, const Vec3& v, double dt, double floor, double yaw) const {
  if (!world_.field) return true;
  const double a_max = params_.robot.a_max_mps2, rr = params_.robot.radius_m;
  const double speed = v.norm();
  if (speed < 1e-9) return true;
  const double reach = speed * dt + speed * speed / (2.0 * a_max);
  const double step = 0.5 * world_.field->resolution();
  const Vec3 end = q + v * (reach / speed);
  // A sphere against the run's segment exactly; rock sampled every half voxel along it.
  for (const StaticSphere& s : world_.static_obstacles) {
    const double now = (q - s.center).norm() - s.radius - rr;
    if ((nearestOnSegment(s.center, q, end) - s.center).norm() - s.radius - rr < std::min(floor, now - 1e-6)) return false;
  }
  const int n = std::min(kMaxSightSamples, std::max(1, int(std::ceil(reach / step))));
  for (int k = 1; k <= n; ++k) {
    const Vec3 p = q + (end - q) * (double(k) / double(n));
    if (world_.field->distance(probe(p)) - rr < floor || (ground_ && bandWithin(p, floor, yaw))) return false;
  }
  return true;
}

bool LocalPlanner::stoppingArcClear(const Vec3& q, const Vec3& v, double w, double dt, double floor) const {
  const double alpha = params_.robot.alpha_max_rps2, a_max = params_.robot.a_max_mps2, rr = params_.robot.radius_m;
  const double turn_on = w * std::abs(w) / (2.0 * alpha);  // heading change after the period
  // The drive's body heads along its run (a box turned by pi is the same box); a holonomic
  // robot's stays as it is.
  const double run_yaw = params_.robot.drive == DriveType::kHolonomic ? yaw_ : std::atan2(v.y(), v.x());
  if (!world_.field || std::abs(turn_on) < 1e-3) return stoppingRunClear(q, v, dt, floor, run_yaw);
  const double flat = std::hypot(v.x(), v.y());
  if (flat < 1e-9) return stoppingRunClear(q, v, dt, floor, run_yaw);
  const double speed = v.norm(), rise = v.z() / flat;
  const double reach = speed * dt + speed * speed / (2.0 * a_max);
  const double h0 = std::atan2(v.y(), v.x()), t_turn = std::abs(w) / alpha, sw = w > 0.0 ? 1.0 : -1.0;
  // Travel direction after arc length s: straight through the period, then braking, the yaw
  // rate falling from w to zero at alpha_max.
  auto heading = [&](double s) {
    const double s_brake = s - speed * dt;
    if (s_brake <= 0.0) return h0;
    const double t = (speed - std::sqrt(std::max(0.0, speed * speed - 2.0 * a_max * s_brake))) / a_max;
    return t >= t_turn ? h0 + turn_on : h0 + w * t - sw * 0.5 * alpha * t * t;
  };
  const double step = 0.5 * world_.field->resolution();
  const int n = std::min(kMaxSightSamples, std::max(1, int(std::ceil(reach / step))));
  const double ds = reach / double(n), ds_flat = ds * flat / speed;
  Vec3 p = q;
  for (int k = 1; k <= n; ++k) {
    const double h = heading((double(k) - 0.5) * ds);
    p += Vec3(std::cos(h) * ds_flat, std::sin(h) * ds_flat, rise * ds_flat);
    for (const StaticSphere& s : world_.static_obstacles) {
      const double now = (q - s.center).norm() - s.radius - rr;
      if ((p - s.center).norm() - s.radius - rr < std::min(floor, now - 1e-6)) return false;
    }
    if (world_.field->distance(probe(p)) - rr < floor || (ground_ && bandWithin(p, floor, h))) return false;
  }
  return true;
}

bool LocalPlanner::goalInSight(const Vec3& q, const Vec3& goal) const {
  // The robot's sphere along the whole segment: a non-spherical shape counts as its bounding
  // sphere (conservative: such a robot may see less of the terminal phase, never more).
  const double rr = ground_ || world_.shape.type == map::ShapeType::kSphere
                        ? params_.robot.radius_m
                        : std::max(params_.robot.radius_m, world_.shape.boundingRadius());
  for (const StaticSphere& s : world_.static_obstacles)
    if ((nearestOnSegment(s.center, q, goal) - s.center).norm() < s.radius + rr) return false;
  if (!world_.field) return true;
  // Every half voxel, so that no rock voxel lies between two samples unseen.
  const Vec3 d = goal - q;
  const double step = 0.5 * world_.field->resolution();
  const int n = std::clamp(int(std::ceil(d.norm() / step)), 1, kMaxSightSamples);
  for (int k = 1; k <= n; ++k)
    if (world_.field->distance(probe(q + d * (double(k) / double(n)))) < rr) return false;
  return true;
}

bool LocalPlanner::pursuitPoint(const Vec3& q, const map::Polyline& path, const Vec3& proj, Vec3* point) const {
  const std::size_t n = path.points.size();
  // Without a field there is neither a floor nor a band scan to check the line against.
  if (n < 2 || !world_.field) return false;
  // Rock of the body's band (steps and floors too steep to climb included), in the floor's plane.
  const double clear = params_.robot.radius_m + params_.envelope.keep_m;
  auto bandClear = [&](const Vec3& to) {
    const Vec3 a(q.x(), q.y(), 0.0), b(to.x(), to.y(), 0.0);
    for (int k = 0; k < map::BandScan::kBins; ++k) {
      if (!std::isfinite(band_.distance[k])) continue;
      const Vec3 p(band_.point[k].x(), band_.point[k].y(), 0.0);
      if ((nearestOnSegment(p, a, b) - p).norm() < clear) return false;
    }
    return true;
  };
  // The floor along the line: no step above max_step, no rise steeper than max_slope_deg (the
  // band sees such floors only once they stand higher than the robot could climb to them).
  const RobotLimits& R = params_.robot;
  const double res = world_.field->resolution(), tan_max = std::tan(R.max_slope_deg * kPi / 180.0);
  auto floorClear = [&](const Vec3& to) {
    // Over a metre at least, whatever the line's length: a short line up a ramp too steep rises
    // no more than a step.
    Vec3 d(to.x() - q.x(), to.y() - q.y(), 0.0);
    if (d.norm() < 1e-9) return true;
    d *= std::max(1.0, d.norm()) / d.norm();
    const double run = d.norm();
    const int m = std::clamp(int(std::ceil(run / res)), 1, kMaxSightSamples);
    // A floor one voxel higher is the quantisation of any slope, never a step (as the band's).
    const double step_tol = std::max(R.max_step_m, res) + 0.5 * res;
    double prev = floor_z_;
    for (int k = 1; k <= m; ++k) {
      const double s = run * double(k) / double(m);
      const Vec3 p = q + d * (double(k) / double(m));
      const std::optional<double> f = map::floorBelow(
          *world_.field, Vec3(p.x(), p.y(), floor_z_ + s * tan_max + R.max_step_m + res), 2.0 * (s * tan_max + R.max_step_m + res));
      if (!f || std::abs(*f - prev) > step_tol || std::abs(*f - floor_z_) > s * tan_max + R.max_step_m + 0.5 * res)
        return false;
      prev = *f;
    }
    return true;
  };
  double left = params_.pursuit.lookahead_m;
  Vec3 at = proj;
  for (std::size_t i = segment_ + 1; i < n && left > 0.0; ++i) {
    const Vec3& next = path.points[i];
    const double d = (next - at).norm();
    if (d >= left) {
      at += (next - at) * (left / d);
      break;
    }
    left -= d;
    at = next;  // the path ends sooner: its end
  }
  // A shorter lookahead would let the robot creep up to what only the whole line shows (the foot
  // of a ramp too steep for it). At a bend the line to the lookahead point cuts the corner: then
  // the break point itself, the path's own corner. Where neither line is clear, the field decides.
  // A flying robot has neither a band nor a floor to climb: the sphere's line is the test.
  auto lineClear = [&](const Vec3& to) { return goalInSight(q, to) && (!ground_ || (bandClear(to) && floorClear(to))); };
  const Vec3& corner = path.points[std::min(segment_ + 1, n - 1)];
  if (lineClear(at)) *point = at;
  else if ((corner - q).norm() > 1e-3 && lineClear(corner)) *point = corner;
  else return false;
  return true;
}

// ---- step(), one period in named steps ------------------------------------------------------------

// One period's working values, handed from each named step of step() to the next. On the stack:
// step() allocates nothing.
struct LocalPlanner::Cycle {
  Cycle(const RobotState& s, const map::Polyline& p, const map::MovingObstacle* m, std::size_t count, double period)
      : state(s), path(p), moving(m), moving_count(count), dt(period), q(s.position), v(s.velocity),
        a(s.acceleration), goal(p.points.back()), goal_distance((q - goal).norm()), n(p.points.size()) {}
  const RobotState& state;
  const map::Polyline& path;
  const map::MovingObstacle* moving;
  std::size_t moving_count;
  double dt;
  Vec3 q, v, a, goal;
  double goal_distance;
  std::size_t n;                  // the path's points
  bool manual = false;            // the operator drives (setOverride)
  // followPath()
  Vec3 seg_a = Vec3::Zero(), seg_b = Vec3::Zero();  // the segment steered along
  bool terminal = false;          // TerminalParams: the goal near and in sight
  Vec3 sub_goal = Vec3::Zero();   // what the field steers at
  // measureProgress()
  Vec3 proj = Vec3::Zero();       // the robot's projection onto the segment
  double progress = 0.0;          // path length still to go
  // senseObstacles()
  const ObstacleData* nearest = nullptr;
  bool moving_closing = false;
  Vec3 to_goal = Vec3::UnitX(), heading = Vec3::UnitX();
  // fieldForce()
  Vec3 force = Vec3::Zero(), moving_force = Vec3::Zero(), repulsion_force = Vec3::Zero();
  // desiredVelocity() and after
  Vec3 v_des = Vec3::Zero(), steer_to = Vec3::Zero(), wish = Vec3::Zero();
  bool safety_override = false;   // giveWayToMovers() changed the set-point
  Vec3 acc = Vec3::Zero(), v_cmd = Vec3::Zero();
};

const char* LocalPlanner::inputError(const RobotState& state, const map::Polyline& path,
                                     const map::MovingObstacle* moving, std::size_t moving_count, double dt) const {
  if (!allFinite(state.position) || !allFinite(state.velocity) || !allFinite(state.acceleration) ||
      !std::isfinite(state.yaw) || !std::isfinite(state.yaw_rate))
    return "robot state is not finite";
  if (!(dt > 0.0) || !std::isfinite(dt)) return "dt must be finite and > 0";
  if (path.points.empty()) return "expected path is empty";
  for (const Vec3& p : path.points)
    if (!allFinite(p)) return "expected path has a non-finite point";
  if (moving_count > 0 && !moving) return "moving obstacles: null array";
  if (has_subgoal_ && !allFinite(subgoal_)) return "the caller's sub-goal is not finite";
  if (has_override_ && !allFinite(override_velocity_)) return "the operator's velocity is not finite";
  for (std::size_t i = 0; i < moving_count; ++i) {
    const map::MovingObstacle& m = moving[i];
    if (!allFinite(m.position) || !allFinite(m.velocity) || !allFinite(m.acceleration) || !finiteShape(m.shape))
      return "a moving obstacle is not finite";
  }
  return nullptr;
}

StepCommand& LocalPlanner::brakeTo(const Cycle& c, StepStatus status, StepCommand& cmd) const {
  const Vec3 acc = clampNorm(-c.v / c.dt, params_.robot.a_max_mps2);
  cmd.acceleration = acc;
  cmd.velocity = c.v + acc * c.dt;
  if (ground_) cmd.forward_speed = cmd.velocity.dot(Vec3(std::cos(c.state.yaw), std::sin(c.state.yaw), 0.0));
  cmd.status = status;
  return cmd;
}

void LocalPlanner::restartOnNewPath(const map::Polyline& path) {
  // A different path (the caller replanned) restarts the sub-goal index and the monitor, and
  // clears a kStuck verdict.
  const std::uint64_t signature = pathSignature(path);
  if (signature != path_signature_ || path.points.size() != path_size_) {
    reset();
    path_size_ = path.points.size();
    path_signature_ = signature;
  }
}

void LocalPlanner::followPath(Cycle& c) {
  const LocalParams& P = params_;
  // Current segment and sub-goal: never move back along the path.
  c.seg_a = c.goal;
  c.seg_b = c.goal;
  if (c.n >= 2) {
    std::size_t nearest_seg = 0;
    c.path.nearestPoint(c.q, &nearest_seg);
    segment_ = std::min(std::max(segment_, nearest_seg), c.n - 2);
    while (segment_ + 2 < c.n) {
      const double to_break = (c.q - c.path.points[segment_ + 1]).norm();
      if (to_break >= P.monitor.subgoal_switch_m) break;
      // Turning toward a break point behind the corner cuts the corner into the rib.
      if (P.envelope.sight_switch && to_break >= 0.5 * P.monitor.subgoal_switch_m &&
          !goalInSight(c.q, c.path.points[segment_ + 2]))
        break;
      ++segment_;
    }
    c.seg_a = c.path.points[segment_];
    c.seg_b = c.path.points[segment_ + 1];
  }
  // Terminal phase (TerminalParams): the goal near and in sight of the robot's sphere. Then it is
  // what the robot steers at, whatever the break point or the caller's sub-goal.
  c.terminal = !c.manual && P.terminal.enabled && c.goal_distance <= P.terminal.range_m && goalInSight(c.q, c.goal);
  // By hand, the goal-aware terms look where the operator drives.
  const Vec3 toward_hand = override_velocity_.norm() > 1e-6 ? override_velocity_
                                                            : Vec3(1e-3 * unitOr(c.goal - c.q, Vec3::UnitX()));
  c.sub_goal = c.manual ? Vec3(c.q + toward_hand) : c.terminal ? c.goal : has_subgoal_ ? subgoal_ : c.seg_b;
}

void LocalPlanner::measureProgress(Cycle& c) {
  const LocalParams& P = params_;
  // Progress: path length still to go from the projection onto the current segment, plus the
  // distance off the path. It only counts as progress when it beats the best so far.
  c.proj = nearestOnSegment(c.q, c.seg_a, c.seg_b);
  c.progress = (c.proj - c.seg_b).norm() + (c.q - c.proj).norm();
  for (std::size_t i = segment_ + 1; i + 1 < c.n; ++i) c.progress += (c.path.points[i + 1] - c.path.points[i]).norm();
  if (c.manual) {
    // The monitor rests while the operator drives: it starts afresh when the override ends.
    best_progress_ = std::numeric_limits<double>::infinity();
    escapes_ = 0;
    escaping_ = false;
  } else if (!std::isfinite(best_progress_)) {
    // A new path may point behind the robot: it cannot make progress before it has stopped,
    // so its stopping time is not held against it.
    best_progress_ = c.progress;
    last_improvement_s_ = clock_s_ + c.v.norm() / P.robot.a_max_mps2;
  } else if (c.progress < best_progress_ - P.monitor.min_progress_m) {
    best_progress_ = c.progress;
    last_improvement_s_ = clock_s_;
    wait_credit_s_ = 0.0;
    // A pursuit escape runs on past the stall: ended at the first gain, it handed the robot back
    // to the field inside the gap that had stalled it.
    if (!(escaping_ && pursuit_escape_ && c.progress > escape_from_progress_ - P.pursuit.escape_run_m)) {
      escapes_ = 0;
      escaping_ = false;
    }
  }
}

void LocalPlanner::senseObstacles(Cycle& c, StepCommand& cmd) {
  gatherObstacles(c.q, c.v, c.a, c.moving, c.moving_count);
  yaw_ = c.state.yaw;
  box_floor_ = ground_ && params_.robot.footprint.box
                   ? std::min(0.5 * params_.envelope.keep_m, footprintClearance(c.q, c.state.yaw) - 1e-6)
                   : std::numeric_limits<double>::infinity();
  for (const ObstacleData& o : obstacles_) {
    if (!c.nearest || o.rho < c.nearest->rho) c.nearest = &o;
    c.moving_closing = c.moving_closing || o.closing;
  }
  if (c.nearest) cmd.clearance_m = c.nearest->rho;
  c.to_goal = unitOr(c.sub_goal - c.q, unitOr(c.goal - c.q, Vec3::UnitX()));
  c.heading = unitOr(c.v, c.to_goal);
}

Vec3 LocalPlanner::freeSideAxis(const Vec3& q, const Vec3& dir, const Vec3& to_obstacle) const {
  // The side to pass an obstacle on: the UUV rotation direction (the turn is toward -d); with no
  // preferred side (head-on), the side where the obstacles are fewer and farther.
  Vec3 c = dir.cross(to_obstacle);
  if (c.norm() > 1e-6 * std::max(1.0, to_obstacle.norm())) return Vec3(c.normalized());
  Vec3 up = std::abs(dir.z()) < 0.9 ? Vec3::UnitZ() : Vec3::UnitX();
  const Vec3 left = up.cross(dir).normalized();
  double lean = 0.0;  // > 0: obstacles lean left
  for (const ObstacleData& o : obstacles_) lean += (o.point - q).dot(left) / std::max(o.rho, 0.05);
  // Axis +up circulates to the right of an obstacle ahead (see potential_terms.hpp).
  return lean >= 0.0 ? up : Vec3(-up);
}

bool LocalPlanner::watchForStall(Cycle& c, StepCommand& cmd) {
  const LocalParams& P = params_;
  // Progress monitor: a window without a new best is a local minimum or an oscillation. Waiting
  // for a moving obstacle does not count against the robot.
  if (!c.manual && c.moving_closing && wait_credit_s_ < P.monitor.max_wait_s) {
    last_improvement_s_ += c.dt;
    wait_credit_s_ += c.dt;
  }
  if (escaping_ && clock_s_ >= escape_until_s_) {
    escaping_ = false;
    last_improvement_s_ = clock_s_;
  }
  if (!c.manual && !escaping_ && clock_s_ - last_improvement_s_ > P.monitor.window_s) {
    if (P.monitor.escape && escapes_ < P.monitor.max_escapes) {
      ++escapes_;
      escaping_ = true;
      escape_until_s_ = clock_s_ + P.monitor.escape_time_s;
      escape_axis_ = freeSideAxis(c.q, c.to_goal, c.nearest ? Vec3(c.nearest->point - c.q) : c.to_goal);
      pursuit_escape_ = !ground_ && world_.field && escapes_ == 1 && P.pursuit.enabled && P.pursuit.escape_run_m > 0.0 &&
                        !has_subgoal_ && c.n >= 2;
      escape_from_progress_ = best_progress_;
      if (escapes_ % 2 == 0) escape_axis_ = -escape_axis_;  // every other attempt: the other side
    } else {
      stuck_ = true;
      cmd.message = P.monitor.escape ? "no progress after the escapes; replan" : "no progress (local minimum)";
      cmd.escapes = escapes_;
      return true;
    }
  }
  cmd.escapes = escapes_;
  return false;
}

TermValue LocalPlanner::repulsionOf(const ObstacleData& o, const Cycle& c, const Vec3& field_goal, double wang_rho0,
                                    Vec3* no_potential) const {
  const LocalParams& P = params_;
  const Proximity prox{o.rho, o.grad, o.pivot};
  switch (P.method) {
    case Method::kClassic: return classicRepulsion(prox, P.classic.eta, P.classic.rho0_m);
    case Method::kTian2016: return tianRepulsion(prox, o.v_rel, o.a_rel, P.tian2016);
    case Method::kWang2014: {
      const Wang2014Params& w = P.wang2014;
      const double half_view = w.view_half_angle_deg * kPi / 180.0;
      if (o.rho > wang_rho0 || !inFieldOfView(c.q, c.heading, o.point, w.view_range_m, half_view)) return {};
      double delta = 1.0;
      if (o.moving) {
        const double v_ro = o.v_rel.dot(-o.grad);
        delta = v_ro > kClosingSpeed ? w.approach_factor : v_ro < -kClosingSpeed ? w.recede_factor : 1.0;
      }
      const double f = fuzzyRepulsionGain(o.rho, bearing(c.heading, o.point - c.q), w.view_range_m, half_view);
      return goalAwareRepulsion(prox, c.q, field_goal, w.K_2 * delta * f, wang_rho0, w.n, w.goal_factor_cap_m);
    }
    case Method::kVff:
    case Method::kCvff:
      if (P.vff.compound) *no_potential += cvffVelocityRepulsion(prox, o.v_rel, P.vff.M_v, P.vff.p0_m);
      return vffRepulsion(prox, P.vff.M_p, P.vff.p0_m);
    case Method::kUuv: {
      const TermValue rep = goalAwareRepulsion(prox, c.q, field_goal, P.uuv.k_rep, P.uuv.rho0_m, 2.0, P.uuv.goal_factor_cap_m);
      const Vec3 b = o.point - c.q;
      if (rep.dq.norm() > 0.0 && b.dot(c.heading) > 0.0) {
        // Turn the velocity toward the free side: -d, d = (a x b) x a.
        Vec3 side = rotationSide(c.heading, b);
        if (side.norm() <= 0.0) side = freeSideAxis(c.q, c.heading, b).cross(c.heading).cross(c.heading);
        *no_potential -= P.uuv.rotation_gain * rep.dq.norm() * unitOr(side, Vec3::Zero());
      }
      return rep;
    }
  }
  return {};
}

bool LocalPlanner::fieldForce(Cycle& c, StepCommand& cmd) const {
  const LocalParams& P = params_;
  const Vec3 q = c.q;
  // Toward a break point of the path (not the goal) the field's goal-distance terms see the goal
  // where the path's remaining length puts it, along the same bearing: a break point is not where
  // the robot stops, and an attraction that fades as it nears (Tian 2016's k_q rho_g^s gives
  // 0.1 m/s at 1 m) crawled into every corner (tian2016 took 37 s for an 11 m path round a T).
  Vec3 field_goal = c.sub_goal;
  if (!c.manual && !c.terminal && !has_subgoal_ && P.terminal.pull_to_go && segment_ + 2 < c.n) {
    const double d = (c.sub_goal - q).norm();
    if (d > 1e-9 && c.progress > d) field_goal = q + (c.sub_goal - q) * (c.progress / d);
  }
  // The field of the selected model: attraction, then each obstacle's repulsion (a potential
  // term plus, for CVFF and UUV, forces the papers define without one).
  TermValue total;
  Vec3 extra = Vec3::Zero();
  if (!c.manual) switch (P.method) {
    case Method::kClassic: total += classicAttraction(q, field_goal, P.classic.xi); break;
    case Method::kTian2016: total += tianAttraction(q, c.v, c.a, field_goal, c.seg_a, c.seg_b, P.tian2016); break;
    case Method::kWang2014: total += classicAttraction(q, field_goal, P.wang2014.k_att); break;
    case Method::kVff:
    case Method::kCvff:
      total += cvffAttraction(q, field_goal, P.vff.K_p);
      if (P.vff.compound) extra += cvffVelocityAttraction(c.v, P.vff.K_v, P.robot.v_max_mps);
      break;
    case Method::kUuv: total += boundedAttraction(q, field_goal, P.uuv.k_att, P.uuv.conic_distance_m); break;
  }
  const double wang_rho0 = shrinkingInfluenceRange((q - field_goal).norm(), P.wang2014.sensing_radius_m);
  // In the terminal phase the static repulsion U becomes s U with Ge & Cui's factor
  // s = min(1, (rho_g / R)^n): zero at the goal, so the goal is the minimum of the whole field
  // however near rock it lies. Its gradient s dU + U ds; U ds pulls toward the goal (Wang 2014's
  // F_rep2). Forces without a potential are scaled alike. Moving obstacles keep their repulsion.
  double goal_factor = 1.0;
  Vec3 goal_factor_grad = Vec3::Zero();
  if (c.terminal && c.goal_distance < P.terminal.range_m) {
    const double R = P.terminal.range_m, e = P.terminal.n;
    goal_factor = std::pow(c.goal_distance / R, e);
    if (c.goal_distance > 1e-9)
      goal_factor_grad = (e / R) * std::pow(c.goal_distance / R, e - 1.0) * ((q - c.goal) / c.goal_distance);
  }
  // Moving obstacles' repulsion is kept apart (escapes still give way to them), and so is every
  // obstacle's as applied (the terminal phase's seek adds it).
  for (const ObstacleData& o : obstacles_) {
    Vec3 no_potential = Vec3::Zero();
    TermValue rep = repulsionOf(o, c, field_goal, wang_rho0, &no_potential);
    if (!o.moving && goal_factor < 1.0) {
      const double u = rep.u;
      rep.u *= goal_factor;
      rep.dq = goal_factor * rep.dq + u * goal_factor_grad;
      rep.dv *= goal_factor;
      rep.da *= goal_factor;
      no_potential *= goal_factor;
    }
    total += rep;
    extra += no_potential;
    c.repulsion_force += rep.force() + no_potential;
    if (o.moving) c.moving_force += rep.force() + no_potential;
  }
  cmd.potential = total.u;
  c.force = total.force() + extra;
  if (ground_) {
    // A ground robot moves in the floor's plane: what the field asks of z is the floor's to give.
    c.force.z() = 0.0;
    c.moving_force.z() = 0.0;
    c.repulsion_force.z() = 0.0;
  }
  return allFinite(c.force) && allFinite(c.moving_force);
}

void LocalPlanner::desiredVelocity(Cycle& c) {
  const LocalParams& P = params_;
  const double v_max = P.robot.v_max_mps, a_max = P.robot.a_max_mps2;
  const Vec3 q = c.q;
  const double full = P.monitor.full_speed_force;
  // Along the force (or round the obstacle when escaping), no faster than the robot can still
  // stop at the goal.
  Vec3 v_des;
  c.steer_to = c.sub_goal;
  // A pursuit escape whose line is blocked circulates from here on, and so ends at its first gain
  // as a circulating escape does.
  Vec3 escape_carrot = Vec3::Zero();
  if (escaping_ && pursuit_escape_ && !c.manual && !c.terminal && !pursuitPoint(q, c.path, c.proj, &escape_carrot))
    pursuit_escape_ = false;
  if (c.manual) {
    // The operator's set-point replaces the attraction; the repulsion (all of it, or only the
    // moving obstacles' for a pause) bends it as the field would.
    const Vec3 push = override_rock_ ? c.force : c.moving_force;
    v_des = override_velocity_ + v_max * push / full;
    v_des = capTowardRock(q, v_des, c.dt);  // pushed or driven, never into rock
  } else if (c.terminal && P.terminal.seek) {
    // Straight at the goal, bent by the (scaled) repulsion; an escape in progress rests, since its
    // virtual goal would lead away from a goal in sight.
    v_des = v_max * unitOr(c.goal - q, Vec3::Zero()) + v_max * c.repulsion_force / full;
  } else if (escaping_ && pursuit_escape_ && !c.terminal) {
    // Along the path the global layer proved clear, at the circulating escape's speed, giving way
    // to movers; the envelope below still keeps the stopping run off rock.
    v_des = 0.6 * v_max * unitOr(Vec3(escape_carrot - q), Vec3::Zero()) + v_max * c.moving_force / full;
    c.steer_to = escape_carrot;
  } else if (escaping_ && !c.terminal) {
    // Virtual sub-goal on the chosen side: circulate about the escape axis round the nearest
    // obstacle, holding about half a metre from its surface.
    const ObstacleData* wall = nullptr;  // the static obstacle being followed
    for (const ObstacleData& o : obstacles_)
      if (!o.moving && (!wall || o.rho < wall->rho)) wall = &o;
    const Vec3 g = wall ? wall->grad : Vec3(-c.to_goal);
    const double rho = wall ? wall->rho : 1.0;
    Vec3 tangent = unitOr(escape_axis_.cross(g), c.to_goal);
    const Vec3 dir = unitOr(tangent + std::clamp(0.5 - rho, -1.0, 1.0) * g, tangent);
    c.steer_to = q + P.monitor.virtual_goal_offset_m * dir;
    v_des = 0.6 * v_max * dir + v_max * c.moving_force / full;
  } else if (Vec3 carrot = Vec3::Zero();
             ground_ && P.pursuit.enabled && !has_subgoal_ && c.n >= 2 && pursuitPoint(q, c.path, c.proj, &carrot) &&
             // A car-like robot cannot turn about on the spot: a point behind it is the field's
             // (which backs and fills), not a pursuit's.
             (P.robot.drive != DriveType::kAckermann ||
              (carrot - q).dot(Vec3(std::cos(c.state.yaw), std::sin(c.state.yaw), 0.0)) > 0.0)) {
    // The path ahead is clear (PursuitParams): along it, giving way to movers as an escape does,
    // slow enough at the next break point to turn there rather than overshoot it (as regulated
    // pure pursuit slows for curvature): the turn's cosine of full speed, braking at a_max / 2.
    double speed = v_max;
    if (segment_ + 2 < c.n) {
      const Vec3 in = c.path.points[segment_ + 1] - c.path.points[segment_];
      const Vec3 out = c.path.points[segment_ + 2] - c.path.points[segment_ + 1];
      if (in.norm() > 1e-9 && out.norm() > 1e-9) {
        const double turn = std::clamp(in.dot(out) / (in.norm() * out.norm()), 0.15, 1.0) * v_max;
        speed = std::min(v_max, std::sqrt(turn * turn + a_max * (c.path.points[segment_ + 1] - q).norm()));
      }
    }
    v_des = speed * unitOr(Vec3(carrot - q), Vec3::Zero()) + v_max * c.moving_force / full;
    c.steer_to = carrot;
  } else {
    const double fn = c.force.norm();
    const double speed = v_max * std::min(1.0, fn / full);
    v_des = fn > 1e-12 ? Vec3(c.force * (speed / fn)) : Vec3::Zero();
  }
  if (ground_) v_des.z() = 0.0;
  const double stop_speed = c.manual ? v_max : std::sqrt(2.0 * a_max * 0.8 * c.goal_distance);
  c.v_des = clampNorm(v_des, std::min(v_max, stop_speed));
}

void LocalPlanner::giveWayToMovers(Cycle& c) {
  const LocalParams& P = params_;
  const double v_max = P.robot.v_max_mps, a_max = P.robot.a_max_mps2;
  // Only obstacles that can reach the robot within the safety horizon take part in the check.
  reachable_.clear();
  if (P.monitor.safety_horizon_s > 0.0) {
    const double T = P.monitor.safety_horizon_s;
    const double robot_reach = std::max(c.v.norm(), v_max) * T + 0.5 * a_max * T * T;
    for (std::size_t i = 0; i < c.moving_count && reachable_.size() < reachable_.capacity(); ++i) {
      const map::MovingObstacle& m = c.moving[i];
      const double reach = robot_reach + m.velocity.norm() * T + 0.5 * m.acceleration.norm() * T * T;
      if ((c.q - m.position).norm() - m.shape.boundingRadius() - P.robot.radius_m <= reach + 0.1) reachable_.push_back(i);
    }
    // More than the buffer holds: check them all rather than miss one.
    if (reachable_.size() == reachable_.capacity() && c.moving_count > reachable_.size()) {
      reachable_.clear();
      for (std::size_t i = 0; i < std::min(c.moving_count, reachable_.capacity()); ++i) reachable_.push_back(i);
    }
  }
  if (reachable_.empty()) return;  // also without a horizon: nothing was listed
  // Last line of defence against moving obstacles: the field's velocity must not lead into one
  // within the horizon (the robot turning toward it at a_max and holding it, the obstacles under
  // constant acceleration). Otherwise the first clear of: brake, either side, back off; if none
  // is clear, the one that keeps the most room.
  const double score_des = encounterMargin(c.q, c.v, c.v_des, c.moving);
  if (score_des >= 0.0) return;
  const Vec3 up = std::abs(c.heading.z()) < 0.9 ? Vec3::UnitZ() : Vec3::UnitX();
  const Vec3 left = up.cross(c.heading).normalized();
  const Vec3 candidates[4] = {Vec3::Zero(), 0.6 * v_max * left, -0.6 * v_max * left, -0.5 * v_max * c.heading};
  Vec3 best = c.v_des;
  double best_score = score_des;
  for (const Vec3& cand : candidates) {
    const double sc = encounterMargin(c.q, c.v, cand, c.moving);
    if (sc > best_score + 1e-9) {
      best = cand;
      best_score = sc;
    }
    if (sc >= 0.0) break;
  }
  c.safety_override = best != c.v_des;
  c.v_des = best;
}

void LocalPlanner::applyEnvelope(Cycle& c) {
  const LocalParams& P = params_;
  const double v_max = P.robot.v_max_mps, a_max = P.robot.a_max_mps2, dt = c.dt;
  const Vec3 q = c.q, v = c.v;
  if (ground_) {
    // Along the floor: the stopping runs below then follow a ramp rather than run into it.
    c.v_des.z() = 0.0;
    const double h = c.v_des.norm();
    if (h > 1e-9) c.v_des.z() = slopeAhead(q, c.v_des / h) * h;
  }
  // The safety envelope (EnvelopeParams): whatever the field, the escape or the safety check
  // asked for, the speed toward rock and movers stays what still stops the robot short of them.
  // Off, the terminal phase still caps toward rock: its goal is near rock by design.
  c.wish = c.v_des;  // before the envelope: where a drive that must stop may still face
  if (P.envelope.enabled) c.v_des = capTowardRock(q, c.v_des, dt, c.moving, c.moving_count);
  else if (c.terminal) c.v_des = capTowardRock(q, c.v_des, dt);
  const Vec3 v_des = c.v_des;
  Vec3 acc = clampNorm((v_des - v) / dt, a_max);
  if (P.envelope.enabled && world_.field) {
    // Braking toward the nearest rock first: the barrier above assumed all of a_max for it, and
    // a turn asked at the same time (an escape, a side step) must not take its share.
    map::DistanceSample s = world_.field->query(q);
    if (ground_) {
      s.in_rock = true;  // no rock in the band: nothing to brake for
      for (int b = 0; b < map::BandScan::kBins; ++b)
        if (std::isfinite(band_.distance[b]) && (s.in_rock || band_.distance[b] < s.distance)) {
          s.in_rock = false;
          s.distance = band_.distance[b];
          s.nearest = Vec3(band_.point[b].x(), band_.point[b].y(), q.z());
        }
    }
    const Vec3 toward = s.nearest - q;
    if (!s.in_rock && toward.norm() > 1e-9) {
      // Only the braking of an approach that is under way has priority (down to no approach);
      // moving away from rock, or turning, shares what is left.
      // Only near the barrier's limit: far from rock (bobbing between roof and floor in mid-air)
      // a turn keeps its share.
      const Vec3 nrm = toward.normalized();
      const double vn = v.dot(nrm), target_n = std::max(0.0, v_des.dot(nrm));
      const double ad = a_max * dt, gap = s.distance - P.robot.radius_m - P.envelope.keep_m;
      const double limit = -ad + std::sqrt(ad * ad + 2.0 * a_max * std::max(0.0, gap));
      if (vn > target_n && vn > limit - 2.0 * ad) {
        const double brake_n = std::max((target_n - vn) / dt, -a_max);
        const double rest = std::sqrt(std::max(0.0, a_max * a_max - brake_n * brake_n));
        acc = brake_n * nrm + clampNorm(Vec3((v_des - v) / dt - brake_n * nrm), rest);
      }
    }
  }
  Vec3 v_cmd = v + acc * dt;
  if (v_cmd.norm() > v_max) {
    v_cmd = clampNorm(v_cmd, v_max);
    acc = clampNorm((v_cmd - v) / dt, a_max);  // a_max wins if the robot was already too fast
    v_cmd = v + acc * dt;
  }
  if (P.envelope.enabled && world_.field) {
    // The set-point was safe; what the robot can reach of it in one period must be too (a turn
    // asked at speed is not reached at once): else blend toward straight braking, which stops
    // the robot soonest, until the stopping run from the command is clear.
    const double floor = stoppingFloor(q);
    if (!stoppingRunClear(q, v_cmd, dt, floor)) {
      const Vec3 brake_acc = clampNorm(-v / dt, a_max);
      double lo = 0.0, hi = 1.0;  // lo: known unclear blend, hi: straight braking
      for (int i = 0; i < 10; ++i) {
        const double mid = 0.5 * (lo + hi);
        (stoppingRunClear(q, v + ((1.0 - mid) * acc + mid * brake_acc) * dt, dt, floor) ? hi : lo) = mid;
      }
      acc = (1.0 - hi) * acc + hi * brake_acc;
      v_cmd = v + acc * dt;
    }
  }
  c.acc = acc;
  c.v_cmd = v_cmd;
}

StepStatus LocalPlanner::statusOf(const Cycle& c) const {
  const double v_max = params_.robot.v_max_mps;
  const double along = c.v_cmd.dot(c.to_goal);
  if (c.safety_override) return StepStatus::kYielding;
  if (c.manual) return StepStatus::kFollowing;
  if (escaping_ && !c.terminal) return StepStatus::kDetouring;
  if (c.moving_closing && along < 0.5 * v_max) return StepStatus::kYielding;
  if (c.nearest && c.v_cmd.norm() > 1e-3 && along < std::cos(30.0 * kPi / 180.0) * c.v_cmd.norm())
    return StepStatus::kDetouring;
  return StepStatus::kFollowing;
}

StepCommand LocalPlanner::step(const RobotState& state, const map::Polyline& path, const map::MovingObstacle* moving,
                               std::size_t moving_count, double dt) {
  StepCommand cmd;
  auto refuse = [&](const char* why) {
    cmd.status = StepStatus::kRefused;
    cmd.message = why;
    return cmd;
  };
  if (const char* why = inputError(state, path, moving, moving_count, dt)) return refuse(why);
  Cycle c(state, path, moving, moving_count, dt);
  clock_s_ += dt;
  restartOnNewPath(path);
  c.manual = has_override_;
  cmd.sub_goal = c.goal;
  if (!c.manual && c.goal_distance <= params_.monitor.arrival_tolerance_m) return brakeTo(c, StepStatus::kArrived, cmd);
  if (!c.manual && stuck_) {
    cmd.message = "no progress after the escapes; replan";
    cmd.escapes = escapes_;
    return brakeTo(c, StepStatus::kStuck, cmd);
  }
  followPath(c);  // the segment, the terminal phase, the sub-goal
  cmd.sub_goal = c.sub_goal;
  measureProgress(c);
  senseObstacles(c, cmd);
  if (watchForStall(c, cmd)) return brakeTo(c, StepStatus::kStuck, cmd);  // or begin an escape
  if (!fieldForce(c, cmd)) return refuse("internal: non-finite force");
  desiredVelocity(c);
  giveWayToMovers(c);
  applyEnvelope(c);
  if (!allFinite(c.v_cmd) || !allFinite(c.acc)) return refuse("internal: non-finite command");
  cmd.velocity = c.v_cmd;
  cmd.acceleration = c.acc;
  if (ground_) {
    driveCommand(state, c.v_des, c.wish, dt, cmd);
    if (!allFinite(cmd.velocity) || !allFinite(cmd.acceleration) || !std::isfinite(cmd.yaw_rate))
      return refuse("internal: non-finite drive command");
    c.v_cmd = cmd.velocity;
  }
  cmd.sub_goal = c.steer_to;
  cmd.status = statusOf(c);
  return cmd;
}

double bandFootprintClearance(const map::DistanceField& field, const RobotLimits& robot, const Vec3& centre, double yaw,
                              double range) {
  const double res = field.resolution(), tan_max = std::tan(robot.max_slope_deg * kPi / 180.0);
  const std::optional<double> f =
      map::floorBelow(field, centre + Vec3(0, 0, robot.max_step_m), 0.5 * robot.height_m + robot.max_step_m + 2.0 * res);
  map::BandScan scan;
  map::rockInBand(field, centre, range + robot.radius_m, f ? *f : centre.z() - 0.5 * robot.height_m, robot.max_step_m,
                  tan_max, robot.height_m, scan);
  if (robot.footprint.box) return footprintGapToBand(scan, robot.footprint, centre, yaw);
  double least = std::numeric_limits<double>::infinity();
  for (int b = 0; b < map::BandScan::kBins; ++b)
    if (std::isfinite(scan.distance[b]))
      least = std::min(least, std::hypot(scan.point[b].x() - centre.x(), scan.point[b].y() - centre.y()) - robot.radius_m);
  return least;
}

}  // namespace adit::local
