// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// Private to adit_map: geometry of adit's robot shapes that the collision checker needs besides
// FCL: bounding boxes, seed points, inscribed radii, nearest points and the cheap lower bounds on
// the distance to a voxel cube that let it skip most narrow-phase calls.
#include <algorithm>
#include <cmath>

#include "adit/map/types.hpp"

namespace adit::map::geom {

// World-frame bounding box of a posed shape (tighter than the bounding sphere's box).
Aabb shapeAabb(const RobotShape& s, const Eigen::Isometry3d& pose);

// Points strictly inside the shape where the nearest rock is looked up to seed the search: the
// origin and, for elongated shapes, near the ends of the long axis (world frame).
struct SeedPoints {
  Vec3 points[3];
  int count = 1;
};
SeedPoints seedPoints(const RobotShape& s, const Eigen::Isometry3d& pose);

// Radius of the largest origin-centred ball inside the shape.
double inscribedRadius(const RobotShape& s);

// Distance from a point to the axis-aligned cube of edge `edge` around `centre` (0 inside).
inline double pointToCube(const Vec3& p, const Vec3& centre, double edge) {
  return ((p - centre).cwiseAbs() - Vec3::Constant(0.5 * edge)).cwiseMax(0.0).norm();
}

// Nearest point of the solid shape to `q` (both in the shape's frame).
inline Vec3 nearestOnShape(const RobotShape& s, const Vec3& q) {
  const double half_len = 0.5 * s.length;
  switch (s.type) {
    case ShapeType::kSphere: {
      const double n = q.norm();
      return n > s.radius ? Vec3(q * (s.radius / n)) : q;
    }
    case ShapeType::kBox: return q.cwiseMax(-0.5 * s.size).cwiseMin(0.5 * s.size);
    case ShapeType::kCylinder: {
      const double rho = std::hypot(q.x(), q.y());
      const double k = rho > s.radius ? s.radius / rho : 1.0;
      return {q.x() * k, q.y() * k, std::clamp(q.z(), -half_len, half_len)};
    }
    case ShapeType::kCapsule: {
      const Vec3 axis_point(0.0, 0.0, std::clamp(q.z(), -half_len, half_len));
      const Vec3 d = q - axis_point;
      const double n = d.norm();
      return n > s.radius ? Vec3(axis_point + d * (s.radius / n)) : q;
    }
  }
  return q;
}

// Distance from the posed shape to the cube of edge 2 * half around a voxel centre v, from below.
// Three bounds, the largest wins:
//  - separating plane: with p the shape's point nearest to v and n = (v - p) / |v - p|, the
//    plane through p normal to n has the convex shape behind it, and the cube reaches at most
//    half * |n|_1 towards it, so the distance is >= |v - p| - half * |n|_1. Near a wall the
//    nearest cubes lie along an axis, |n|_1 ~ 1, and the bound is within half a voxel;
//  - bounding sphere: |cube - origin| - boundingRadius(), exact for spheres;
//  - the cube's gap to the shape's bounding box.
class CubeLowerBound {
 public:
  CubeLowerBound(const RobotShape& s, const Eigen::Isometry3d& pose, const Aabb& box, double edge)
      : shape_(s), rot_(pose.linear()), origin_(pose.translation()), box_centre_(box.center()),
        box_half_(0.5 * box.size()), half_(0.5 * edge), edge_(edge), radius_(s.boundingRadius()) {}

  double radius() const { return radius_; }
  /// The bounding-sphere and bounding-box bounds: a few flops, for every voxel of the window.
  double coarse(const Vec3& v) const {
    const Vec3 gap_v = ((v - box_centre_).cwiseAbs() - box_half_ - Vec3::Constant(half_)).cwiseMax(0.0);
    return std::max({pointToCube(origin_, v, edge_) - radius_, gap_v.norm(), 0.0});
  }
  /// coarse(v) > reach, without square roots (the scan's inner loop).
  bool coarseExceeds(const Vec3& v, double reach) const {
    const Vec3 gap_v = ((v - box_centre_).cwiseAbs() - box_half_ - Vec3::Constant(half_)).cwiseMax(0.0);
    if (gap_v.squaredNorm() > reach * reach) return true;
    const double outer = radius_ + reach;
    return ((v - origin_).cwiseAbs() - Vec3::Constant(half_)).cwiseMax(0.0).squaredNorm() > outer * outer;
  }
  /// All three, for the surface rock voxels that pass coarse().
  double operator()(const Vec3& v) const {
    const Vec3 q = rot_.transpose() * (v - origin_);
    const Vec3 d = q - nearestOnShape(shape_, q);
    const double dn = d.norm();
    const double plane = dn > 0.0 ? dn - half_ * (rot_ * d).lpNorm<1>() / dn : 0.0;
    return std::max(plane, coarse(v));
  }

 private:
  const RobotShape& shape_;
  Eigen::Matrix3d rot_;
  Vec3 origin_, box_centre_, box_half_;
  double half_, edge_, radius_;
};

}  // namespace adit::map::geom
