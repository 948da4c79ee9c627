// SPDX-License-Identifier: BSD-3-Clause
#include "adit/map/types.hpp"

#include <cmath>
#include <limits>
#include <sstream>

namespace adit::map {

double Polyline::length() const {
  double total = 0.0;
  for (std::size_t i = 1; i < points.size(); ++i) total += (points[i] - points[i - 1]).norm();
  return total;
}

Vec3 Polyline::nearestPoint(const Vec3& p, std::size_t* segment) const {
  ADIT_DEMAND(!points.empty());
  if (points.size() == 1) {
    if (segment) *segment = 0;
    return points.front();
  }
  double best = std::numeric_limits<double>::infinity();
  Vec3 best_point = points.front();
  for (std::size_t i = 0; i + 1 < points.size(); ++i) {
    const Vec3 a = points[i], ab = points[i + 1] - points[i];
    const double len2 = ab.squaredNorm();
    const double t = len2 > 0 ? std::clamp((p - a).dot(ab) / len2, 0.0, 1.0) : 0.0;
    const Vec3 q = a + t * ab;
    const double d = (p - q).squaredNorm();
    if (d < best) {
      best = d;
      best_point = q;
      if (segment) *segment = i;
    }
  }
  return best_point;
}

double RobotShape::boundingRadius() const {
  switch (type) {
    case ShapeType::kSphere: return radius;
    case ShapeType::kBox: return 0.5 * size.norm();
    case ShapeType::kCylinder: return std::hypot(radius, 0.5 * length);
    case ShapeType::kCapsule: return radius + 0.5 * length;
  }
  return 0.0;
}

std::string RobotShape::name() const {
  std::ostringstream os;
  switch (type) {
    case ShapeType::kSphere: os << "sphere(r=" << radius << ")"; break;
    case ShapeType::kBox: os << "box(" << size.x() << "x" << size.y() << "x" << size.z() << ")"; break;
    case ShapeType::kCylinder: os << "cylinder(r=" << radius << ", l=" << length << ")"; break;
    case ShapeType::kCapsule: os << "capsule(r=" << radius << ", l=" << length << ")"; break;
  }
  return os.str();
}

Status RobotShape::validate() const {
  auto positive = [](double v) { return std::isfinite(v) && v > 0.0; };
  switch (type) {
    case ShapeType::kSphere:
      if (!positive(radius)) return invalidArgument("sphere radius = " + std::to_string(radius) + " must be finite and > 0");
      break;
    case ShapeType::kBox:
      if (!positive(size.x()) || !positive(size.y()) || !positive(size.z()))
        return invalidArgument("box edges must be finite and > 0, got " + name());
      break;
    case ShapeType::kCylinder:
    case ShapeType::kCapsule:
      if (!positive(radius) || !std::isfinite(length) || length < 0.0 ||
          (type == ShapeType::kCylinder && length <= 0.0))
        return invalidArgument("bad dimensions for " + name());
      break;
    default:
      return invalidArgument("unknown shape type " + std::to_string(int(type)));
  }
  return {};
}

}  // namespace adit::map
