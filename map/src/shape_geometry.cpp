// SPDX-License-Identifier: BSD-3-Clause
#include "shape_geometry.hpp"

namespace adit::map::geom {

Aabb shapeAabb(const RobotShape& s, const Eigen::Isometry3d& pose) {
  const Eigen::Matrix3d& r = pose.linear();
  Vec3 half = Vec3::Zero();
  switch (s.type) {
    case ShapeType::kSphere: half = Vec3::Constant(s.radius); break;
    case ShapeType::kBox: half = r.cwiseAbs() * (0.5 * s.size); break;
    case ShapeType::kCylinder:
    case ShapeType::kCapsule: {
      const Vec3 axis = r.col(2);
      for (int i = 0; i < 3; ++i) {
        const double disc = s.type == ShapeType::kCapsule
                                ? s.radius
                                : s.radius * std::sqrt(std::max(0.0, 1.0 - axis[i] * axis[i]));
        half[i] = std::abs(axis[i]) * 0.5 * s.length + disc;
      }
      break;
    }
  }
  const Vec3 c = pose.translation();
  return {c - half, c + half};
}

SeedPoints seedPoints(const RobotShape& s, const Eigen::Isometry3d& pose) {
  SeedPoints out;
  out.points[0] = pose.translation();
  Vec3 half_axis = Vec3::Zero();
  switch (s.type) {
    case ShapeType::kSphere: return out;
    case ShapeType::kBox: {
      Eigen::Index longest = 0;
      s.size.maxCoeff(&longest);
      half_axis[longest] = 0.5 * s.size[longest];
      break;
    }
    case ShapeType::kCylinder:
    case ShapeType::kCapsule: half_axis.z() = 0.5 * s.length; break;
  }
  if (half_axis.isZero()) return out;
  half_axis *= 0.999;  // inside the box and the cylinder, not on their faces
  out.points[1] = pose * half_axis;
  out.points[2] = pose * Vec3(-half_axis);
  out.count = 3;
  return out;
}

double inscribedRadius(const RobotShape& s) {
  switch (s.type) {
    case ShapeType::kSphere: return s.radius;
    case ShapeType::kBox: return 0.5 * s.size.minCoeff();
    case ShapeType::kCylinder: return std::min(s.radius, 0.5 * s.length);
    case ShapeType::kCapsule: return s.radius;
  }
  return 0.0;
}

}  // namespace adit::map::geom
