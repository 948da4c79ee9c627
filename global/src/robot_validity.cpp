// SPDX-License-Identifier: BSD-3-Clause
#include "robot_validity.hpp"

#include "adit/map/rock_points.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace adit::global {

using map::RobotShape;
using map::ShapeType;
using map::Vec3;

namespace {
constexpr double kPi = 3.14159265358979323846;
// Headings a state is tried at (over half a turn: a box turned by pi is the same box), and the
// largest step of a turn checked at a break point.
constexpr int kStateHeadings = 16;
constexpr double kTurnStep = 5.0 * kPi / 180.0;
// The pose of a shape centred at c, turned by yaw about z.
Eigen::Isometry3d poseAt(const Vec3& c, double yaw) {
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.translation() = c;
  if (yaw != 0.0) pose.linear() = Eigen::AngleAxisd(yaw, Vec3::UnitZ()).toRotationMatrix();
  return pose;
}
// Horizontal direction of a-b; NaN for a vertical (or null) move.
double headingOf(const Vec3& a, const Vec3& b) {
  const double dx = b.x() - a.x(), dy = b.y() - a.y();
  return dx * dx + dy * dy > 1e-12 ? std::atan2(dy, dx) : std::numeric_limits<double>::quiet_NaN();
}
}  // namespace

RobotValidity::RobotValidity(const map::DistanceField& field, const map::CollisionChecker& checker,
                             const GlobalPlannerParams& params, bool headed)
    : field_(&field), checker_(&checker), params_(params) {
  headed_ = headed && ground() && params.robot.type == ShapeType::kBox;
  res_ = field.resolution();
  step_ = params.motion_step_voxels * res_;
  const RobotShape& r = params.robot;
  double horizontal = r.radius;
  switch (r.type) {
    case ShapeType::kSphere: half_height_ = r.radius; break;
    case ShapeType::kCapsule: half_height_ = r.radius + 0.5 * r.length; break;
    case ShapeType::kCylinder:
      half_height_ = 0.5 * r.length;
      checked_ = r;
      break;
    case ShapeType::kBox:
      horizontal = 0.5 * std::hypot(r.size.x(), r.size.y());
      half_height_ = 0.5 * r.size.z();
      checked_ = RobotShape::cylinder(horizontal, r.size.z());
      break;
  }
  required_ = horizontal + params.safety_margin_m + 0.5 * res_;
  // One voxel for the floor's quantisation under the footprint, one for the floor voxel itself.
  lift_ = params.safety_margin_m + 2.0 * res_;
}

bool RobotValidity::bodyClear(const Vec3& c) const {
  const RobotShape& r = params_.robot;
  if (!map::allFinite(c)) return false;
  switch (r.type) {
    case ShapeType::kSphere: return field_->distance(c) >= required_;
    case ShapeType::kCapsule: {
      const double half = 0.5 * r.length;
      const int n = std::max(1, int(std::ceil(r.length / step_)));
      for (int k = 0; k <= n; ++k)
        if (field_->distance(c + Vec3(0, 0, -half + r.length * k / n)) < required_) return false;
      return true;
    }
    case ShapeType::kBox:
    case ShapeType::kCylinder: return shapeClearAt(checked_, c, 0.0);
  }
  return false;
}

bool RobotValidity::shapeClearAt(const map::RobotShape& shape, const Vec3& c, double yaw) const {
  const map::ShapeDistance d = checker_->distance(shape, poseAt(c, yaw), params_.safety_margin_m);
  if (d.collision) return false;
  return !d.exact || d.distance_m >= params_.safety_margin_m;
}

bool RobotValidity::bodyClearHeaded(const Vec3& b, double yaw) const {
  if (bodyClear(b)) return true;
  if (!headed_) return false;
  if (std::isfinite(yaw)) return shapeClearAt(params_.robot, b, yaw);
  for (int h = 0; h < kStateHeadings; ++h)
    if (shapeClearAt(params_.robot, b, kPi * h / kStateHeadings)) return true;
  return false;
}

std::optional<Vec3> RobotValidity::bodyAt(const Vec3& p) const {
  const std::optional<double> f = groundFloor(p);
  if (!f) return std::nullopt;
  return Vec3(p.x(), p.y(), *f + half_height_ + lift_);
}

int RobotValidity::badTurns(const std::vector<Vec3>& path, std::size_t* first) const {
  if (!headed_) return 0;
  int bad = 0;
  double yaw_in = std::numeric_limits<double>::quiet_NaN();
  for (std::size_t k = 0; k + 1 < path.size(); ++k) {
    const double yaw_out = headingOf(path[k], path[k + 1]);
    if (!std::isfinite(yaw_out)) continue;  // a vertical move keeps the heading
    if (std::isfinite(yaw_in)) {
      // The shorter turn modulo half a turn: the box may drive on backwards.
      double d = std::remainder(yaw_out - yaw_in, kPi);
      const std::optional<Vec3> b = bodyAt(path[k]);
      bool ok = b.has_value();
      if (ok && !bodyClear(*b)) {
        const int n = std::max(1, int(std::ceil(std::abs(d) / kTurnStep)));
        for (int i = 0; i <= n && ok; ++i) ok = shapeClearAt(params_.robot, *b, yaw_in + d * i / n);
      }
      if (!ok && bad++ == 0 && first) *first = k;
    }
    yaw_in = yaw_out;
  }
  return bad;
}

std::optional<double> RobotValidity::floorBelow(const Vec3& c, double depth) const {
  return map::floorBelow(*field_, c, depth);
}

std::optional<Vec3> RobotValidity::onFloor(const Vec3& c, double depth) const {
  const std::optional<double> f = floorBelow(c, depth);
  if (!f) return std::nullopt;
  return Vec3(c.x(), c.y(), *f + half_height_);
}

bool RobotValidity::stateValid(const Vec3& c) const {
  if (!ground()) return bodyClear(c);
  const std::optional<Vec3> b = bodyAt(c);
  return b && bodyClearHeaded(*b, std::numeric_limits<double>::quiet_NaN());
}

bool RobotValidity::motionValid(const Vec3& a, const Vec3& b) const { return motionValid(a, b, nullptr); }

bool RobotValidity::motionValid(const Vec3& a, const Vec3& b, double* last_valid) const {
  const double len = (b - a).norm();
  const int n = std::max(1, int(std::ceil(len / step_)));
  SlopeWindow slope(*this);
  auto fail = [&](int k) {
    if (last_valid) *last_valid = std::max(0.0, double(k - 1) / n);
    return false;
  };
  const double run = (b - a).head<2>().norm();
  const double yaw = headingOf(a, b);
  for (int k = 0; k <= n; ++k) {
    const Vec3 p = a + (b - a) * (double(k) / n);
    if (!ground()) {
      if (!bodyClear(p)) return fail(k);
      continue;
    }
    const std::optional<double> f = groundFloor(p);
    if (!f || !bodyClearHeaded(Vec3(p.x(), p.y(), *f + half_height_ + lift_), yaw)) return fail(k);
    if (!slope.add(run * double(k) / n, *f)) return fail(k);
  }
  // Segments shorter than the baseline: their own slope, once they span a few voxels.
  if (ground() && run < params_.slope_baseline_m && run >= 4 * res_ && !slope.steepnessOk(run, slope.first(), slope.last()))
    return fail(n);
  if (last_valid) *last_valid = 1.0;
  return true;
}

std::optional<double> RobotValidity::groundFloor(const Vec3& p) const {
  const std::optional<double> f =
      floorBelow(p + Vec3(0, 0, params_.ground_tolerance_m), half_height_ + 2 * params_.ground_tolerance_m);
  if (!f || std::abs(p.z() - (*f + half_height_)) > params_.ground_tolerance_m) return std::nullopt;
  return f;
}

bool RobotValidity::SlopeWindow::steepnessOk(double run, double z0, double z1) const {
  // One voxel of the difference is the floor's quantisation.
  return (std::abs(z1 - z0) - v_.res_) / run <= tan_max_;
}

bool RobotValidity::SlopeWindow::add(double s, double floor) {
  floors_.emplace_back(s, floor);
  while (tail_ + 1 < floors_.size() && s - floors_[tail_ + 1].first >= v_.params_.slope_baseline_m) ++tail_;
  const double run = s - floors_[tail_].first;
  return run < v_.params_.slope_baseline_m || steepnessOk(run, floors_[tail_].second, floor);
}

bool RobotValidity::pathSlopeValid(const std::vector<Vec3>& path) const {
  if (!ground()) return true;
  SlopeWindow slope(*this);
  double s = 0;
  for (std::size_t i = 0; i + 1 < path.size(); ++i) {
    const double run = (path[i + 1] - path[i]).head<2>().norm();
    const int n = std::max(1, int(std::ceil((path[i + 1] - path[i]).norm() / step_)));
    for (int k = (i == 0 ? 0 : 1); k <= n; ++k) {
      const std::optional<double> f = groundFloor(path[i] + (path[i + 1] - path[i]) * (double(k) / n));
      if (!f || !slope.add(s + run * double(k) / n, *f)) return false;
    }
    s += run;
  }
  return true;
}

double RobotValidity::clearance(const Vec3& c) const {
  const RobotShape& r = params_.robot;
  const Vec3 body = ground() ? Vec3(c + Vec3(0, 0, lift_)) : c;
  switch (r.type) {
    case ShapeType::kSphere: return field_->distance(body) - r.radius;
    case ShapeType::kCapsule: {
      double best = field_->distance(body);
      const int n = std::max(1, int(std::ceil(r.length / step_)));
      for (int k = 0; k <= n; ++k)
        best = std::min(best, field_->distance(body + Vec3(0, 0, -0.5 * r.length + r.length * k / n)));
      return best - r.radius;
    }
    case ShapeType::kBox:
    case ShapeType::kCylinder: {
      return checker_->distance(checked_, poseAt(body, 0.0)).distance_m;
    }
  }
  return 0.0;
}

double RobotValidity::clearance(const Vec3& c, double yaw) const {
  const double turning = clearance(c);
  if (!headed_ || !std::isfinite(yaw)) return turning;
  return std::max(turning, checker_->distance(params_.robot, poseAt(c + Vec3(0, 0, lift_), yaw)).distance_m);
}

double RobotValidity::costFactor(const Vec3& c) const {
  if (params_.clearance_weight <= 0) return 1.0;
  const double extra = field_->distance(ground() ? Vec3(c + Vec3(0, 0, lift_)) : c) - required_;
  return 1.0 + params_.clearance_weight * std::max(0.0, 1.0 - extra / params_.preferred_clearance_m);
}

double RobotValidity::segmentCost(const Vec3& a, const Vec3& b) const {
  const double len = (b - a).norm();
  if (params_.clearance_weight <= 0) return len;
  // Midpoint rule over pieces of about a metre (at most 64): the penalty varies slowly.
  const int n = std::clamp(int(std::ceil(len)), 1, 64);
  double sum = 0;
  for (int k = 0; k < n; ++k) sum += costFactor(a + (b - a) * ((k + 0.5) / n));
  return len * sum / n;
}

}  // namespace adit::global
