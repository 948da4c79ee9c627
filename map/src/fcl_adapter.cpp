// SPDX-License-Identifier: BSD-3-Clause
#include "fcl_adapter.hpp"

#include <fcl/narrowphase/collision.h>
#include <fcl/narrowphase/distance.h>

namespace adit::map::fclx {

ShapeDistance invalidResult() {
  ShapeDistance r;
  r.collision = true;
  r.exact = false;
  return r;
}

ShapeDistance collisionAt(const Vec3& p, int checked) {
  ShapeDistance r;
  r.collision = true;
  r.point_on_robot = r.point_on_obstacle = p;
  r.candidates_checked = checked;
  return r;
}

ShapeDistance fclPairDistance(const fcl::CollisionGeometryd* robot, const Eigen::Isometry3d& tf_robot,
                              const fcl::CollisionGeometryd* other, const Eigen::Isometry3d& tf_other) {
  ShapeDistance out;
  fcl::DistanceRequestd request(/*enable_nearest_points=*/true);
  fcl::DistanceResultd result;
  fcl::distance(robot, tf_robot, other, tf_other, request, result);
  out.candidates_checked = 1;
  if (result.min_distance > 0.0) {
    out.distance_m = result.min_distance;
    out.point_on_robot = result.nearest_points[0];
    out.point_on_obstacle = result.nearest_points[1];
    return out;
  }
  fcl::CollisionRequestd creq(/*num_max_contacts=*/1, /*enable_contact=*/true);
  fcl::CollisionResultd cres;
  fcl::collide(robot, tf_robot, other, tf_other, creq, cres);
  out.candidates_checked = 2;
  if (cres.isCollision()) {
    out.collision = true;
    out.point_on_robot = out.point_on_obstacle =
        cres.numContacts() > 0 ? cres.getContact(0).pos : result.nearest_points[0];
  } else {
    // Touching (or GJK rounding at contact): distance 0 without overlap.
    out.point_on_robot = result.nearest_points[0];
    out.point_on_obstacle = result.nearest_points[1];
  }
  return out;
}

bool fclCollide(const fcl::CollisionGeometryd* a, const Eigen::Isometry3d& tf_a,
                const fcl::CollisionGeometryd* b, const Eigen::Isometry3d& tf_b) {
  fcl::CollisionRequestd request;
  fcl::CollisionResultd result;
  return fcl::collide(a, tf_a, b, tf_b, request, result) > 0;
}

}  // namespace adit::map::fclx
