// SPDX-License-Identifier: BSD-3-Clause
#pragma once
/// @file
/// The vocabulary every adit layer shares: points and boxes (Eigen, metres, frame x east, y north,
/// z up), polylines, robot shapes with a pose, and moving obstacles with constant acceleration.
///
///   RobotShape robot = RobotShape::capsule(0.4, 1.2);         // radius, cylinder length
///   Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
///   pose.translation() = Vec3(10, 0, 1);
///   MovingObstacle cart{RobotShape::box({1, 0.5, 0.5}), {20, 0, 1}, {-0.5, 0, 0}, {0, 0, 0}};

#include <Eigen/Geometry>
#include <functional>
#include <limits>
#include <string>
#include <vector>

#include "adit/status.hpp"

namespace adit::map {

using Vec3 = Eigen::Vector3d;

/// Axis-aligned box. Default-constructed boxes are empty (min > max) and grow with extend().
struct Aabb {
  Vec3 min = Vec3::Constant(std::numeric_limits<double>::infinity());
  Vec3 max = Vec3::Constant(-std::numeric_limits<double>::infinity());

  Aabb() = default;
  Aabb(const Vec3& lo, const Vec3& hi) : min(lo), max(hi) {}

  bool empty() const { return (min.array() > max.array()).any(); }
  bool contains(const Vec3& p) const {
    return (p.array() >= min.array()).all() && (p.array() <= max.array()).all();
  }
  void extend(const Vec3& p) { min = min.cwiseMin(p); max = max.cwiseMax(p); }
  void extend(const Aabb& b) { if (!b.empty()) { extend(b.min); extend(b.max); } }
  Aabb inflated(double margin) const {
    return {min - Vec3::Constant(margin), max + Vec3::Constant(margin)};
  }
  Vec3 size() const { return empty() ? Vec3::Zero() : Vec3(max - min); }
  Vec3 center() const { return 0.5 * (min + max); }
  double volume() const { Vec3 s = size(); return s.x() * s.y() * s.z(); }
};

/// A piecewise-linear path; the vertices between the ends are the break points (A, B, ...).
struct Polyline {
  std::vector<Vec3> points;

  bool empty() const { return points.empty(); }
  std::size_t size() const { return points.size(); }
  double length() const;
  /// Point of the polyline nearest to `p` (the paper's q_line), with its segment index.
  Vec3 nearestPoint(const Vec3& p, std::size_t* segment = nullptr) const;
};

enum class ShapeType { kSphere, kBox, kCylinder, kCapsule };

/// Robot or obstacle geometry in its own frame: centred at the origin; cylinders and capsules
/// run along the local z axis (FCL's convention), so a pose rotates them into place.
struct RobotShape {
  ShapeType type = ShapeType::kSphere;
  double radius = 0.0;                 ///< sphere, cylinder, capsule [m]
  double length = 0.0;                 ///< cylinder/capsule length of the straight part [m]
  Vec3 size = Vec3::Zero();            ///< box edge lengths [m]

  static RobotShape sphere(double r) { RobotShape s; s.type = ShapeType::kSphere; s.radius = r; return s; }
  static RobotShape box(const Vec3& edges) { RobotShape s; s.type = ShapeType::kBox; s.size = edges; return s; }
  static RobotShape cylinder(double r, double len) {
    RobotShape s; s.type = ShapeType::kCylinder; s.radius = r; s.length = len; return s;
  }
  static RobotShape capsule(double r, double len) {
    RobotShape s; s.type = ShapeType::kCapsule; s.radius = r; s.length = len; return s;
  }

  /// Radius of the smallest origin-centred sphere that holds the shape.
  double boundingRadius() const;
  /// Positive, finite dimensions for the fields the type uses.
  Status validate() const;
  std::string name() const;
};

/// An obstacle that moves with constant acceleration (the papers' moving obstacles).
/// Beware brace-initialisation with `{}` for a vector: it replaces the zero default with Eigen's
/// uninitialised default constructor. Write Vec3::Zero() instead.
struct MovingObstacle {
  RobotShape shape = RobotShape::sphere(0.5);
  Vec3 position = Vec3::Zero();      ///< at t = 0 [m]
  Vec3 velocity = Vec3::Zero();      ///< [m/s]
  Vec3 acceleration = Vec3::Zero();  ///< [m/s^2]

  Vec3 positionAt(double t_s) const { return position + velocity * t_s + 0.5 * acceleration * t_s * t_s; }
  Vec3 velocityAt(double t_s) const { return velocity + acceleration * t_s; }
};

/// Progress of long work: a short stage label and a fraction in [0, 1]. Libraries report through
/// it and never print; the CLI draws the bar.
using ProgressFn = std::function<void(const char* stage, double fraction)>;

/// True when every coefficient is finite (no NaN, no infinity).
inline bool allFinite(const Vec3& v) { return v.array().isFinite().all(); }

}  // namespace adit::map
