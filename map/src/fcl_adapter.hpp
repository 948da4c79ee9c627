// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// Private to adit_map: the one place that talks to FCL for the collision checker: FCL primitives
// for adit's shapes, pair distance and collision, and the guard that keeps FCL's exceptions in.
#include <fcl/geometry/shape/box.h>
#include <fcl/geometry/shape/capsule.h>
#include <fcl/geometry/shape/cylinder.h>
#include <fcl/geometry/shape/sphere.h>

#include <exception>
#include <type_traits>
#include <variant>

#include "adit/map/collision.hpp"

namespace adit::map::fclx {

static_assert(std::is_same_v<fcl::Transform3d, Eigen::Isometry3d>,
              "adit passes Eigen::Isometry3d to FCL unchanged");

// The answer for a query that cannot be evaluated (see the header): reject the state.
ShapeDistance invalidResult();

ShapeDistance collisionAt(const Vec3& p, int checked);

// One FCL primitive for a RobotShape, held by value so that a query allocates nothing for it.
class FclShape {
 public:
  explicit FclShape(const RobotShape& s) {
    switch (s.type) {
      case ShapeType::kSphere: geom_.emplace<fcl::Sphered>(s.radius); break;
      case ShapeType::kBox: geom_.emplace<fcl::Boxd>(s.size.x(), s.size.y(), s.size.z()); break;
      case ShapeType::kCylinder: geom_.emplace<fcl::Cylinderd>(s.radius, s.length); break;
      case ShapeType::kCapsule: geom_.emplace<fcl::Capsuled>(s.radius, s.length); break;
    }
  }
  const fcl::CollisionGeometryd* get() const {
    return std::visit(
        [](const auto& g) -> const fcl::CollisionGeometryd* {
          if constexpr (std::is_same_v<std::decay_t<decltype(g)>, std::monostate>) return nullptr;
          else return &g;
        },
        geom_);
  }

 private:
  std::variant<std::monostate, fcl::Sphered, fcl::Boxd, fcl::Cylinderd, fcl::Capsuled> geom_;
};

// FCL distance between two geometries, o1 being the robot. FCL's primitive distance reports -1
// (or a meaningless value) on overlap, so anything <= 0 is settled by fcl::collide.
ShapeDistance fclPairDistance(const fcl::CollisionGeometryd* robot, const Eigen::Isometry3d& tf_robot,
                              const fcl::CollisionGeometryd* other, const Eigen::Isometry3d& tf_other);

bool fclCollide(const fcl::CollisionGeometryd* a, const Eigen::Isometry3d& tf_a,
                const fcl::CollisionGeometryd* b, const Eigen::Isometry3d& tf_b);

// FCL throws from a few degenerate configurations (std::logic_error, FailedAtThisConfiguration
// in its EPA). Queries never let that escape: `fn` runs under a catch, and a failure gives the
// rejecting answer, as invalid input does.
template <class Fn>
ShapeDistance guarded(Fn&& fn) noexcept {
  try {
    return fn();
  } catch (const std::exception&) {
    return invalidResult();
  }
}
template <class Fn>
bool guardedCollide(Fn&& fn) noexcept {
  try {
    return fn();
  } catch (const std::exception&) {
    return true;
  }
}

}  // namespace adit::map::fclx
