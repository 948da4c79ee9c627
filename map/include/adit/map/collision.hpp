// SPDX-License-Identifier: BSD-3-Clause
#pragma once
/// @file
/// Exact collision and distance between a robot shape and the mine's rock (CollisionChecker),
/// between two shapes (shapeDistance, obstacleDistance for moving obstacles), and FCL's own
/// octree distance kept as a measured baseline (FclOctreeDistance). FCL stays private to
/// adit_map: this header names adit types only.
///
/// CollisionChecker is the one to call from planners. Rock is what the DistanceField calls rock:
/// occupied voxels, and unknown ones under UnknownPolicy::kRock. A query first reads the field at
/// the robot's origin and answers "farther than max_distance_m" without FCL when the clearance
/// allows; otherwise it collects the rock voxels on the rock surface near the robot and runs FCL
/// shape-vs-box on them, nearest lower bound first, stopping as soon as no box can do better.
///
///   StatusOr<CollisionChecker> checker = CollisionChecker::create(map, field);
///   const RobotShape robot = RobotShape::capsule(0.4, 1.2);
///   Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
///   pose.translation() = Vec3(10, 0, 1.5);
///   if (checker->inCollision(robot, pose)) reject();
///   ShapeDistance d = checker->distance(robot, pose, /*max_distance_m=*/1.0);
///   if (d.exact && d.distance_m < 0.3) slowDown(d.point_on_obstacle);
///   ShapeDistance c = obstacleDistance(robot, pose, cart, /*t_s=*/2.5);
///
/// Invalid queries (a non-finite or non-rigid pose, a shape that fails RobotShape::validate(), a
/// NaN max_distance_m or time) never crash: they report collision = true, distance_m = 0,
/// exact = false and NaN points, so a planner rejects the state. That combination occurs for
/// invalid input only (a real collision is always exact); validateQuery() gives the reason. The
/// same answer is given in the unlikely case that FCL throws (its EPA does on some degenerate
/// configurations); no exception leaves these functions.

#include <limits>
#include <memory>

#include "adit/map/distance_field.hpp"
#include "adit/map/occupancy_map.hpp"
#include "adit/status.hpp"
#include "adit/map/types.hpp"

namespace adit::map {

/// Distance between a robot and an obstacle (rock or another shape).
struct ShapeDistance {
  /// Between the surfaces [m]; 0 when touching or overlapping. When !exact, a lower bound that is
  /// >= the max_distance_m of the query.
  double distance_m = 0.0;
  bool collision = false;  ///< the shapes overlap (penetration depth is not computed)
  /// False when the true distance exceeds max_distance_m and only a lower bound is known (and for
  /// invalid input, see the file comment).
  bool exact = true;
  /// Nearest points in the world frame, valid when exact. On a collision both are one point of
  /// the overlap (FCL's contact point). NaN when unknown.
  Vec3 point_on_robot = Vec3::Constant(std::numeric_limits<double>::quiet_NaN());
  Vec3 point_on_obstacle = Vec3::Constant(std::numeric_limits<double>::quiet_NaN());
  int candidates_checked = 0;  ///< FCL narrow-phase calls the query made (0 for the octree baseline)
};

/// OK when `shape` passes RobotShape::validate() and `pose` is finite and rigid (orthonormal
/// rotation with determinant +1, to 1e-6).
Status validateQuery(const RobotShape& shape, const Eigen::Isometry3d& pose);

/// Exact distance between two shapes (FCL primitives); on overlap, collision = true at distance 0.
ShapeDistance shapeDistance(const RobotShape& a, const Eigen::Isometry3d& pose_a,
                            const RobotShape& b, const Eigen::Isometry3d& pose_b);

/// The robot against a moving obstacle at time `t_s`: the obstacle is at ob.positionAt(t_s) with
/// identity orientation. point_on_obstacle lies on the obstacle.
ShapeDistance obstacleDistance(const RobotShape& robot, const Eigen::Isometry3d& pose,
                               const MovingObstacle& ob, double t_s);

/// Robot-vs-rock queries for the planners' hot loops.
///
/// Cost: a query far from rock (clearance - boundingRadius() > max_distance_m) is two field
/// reads. Near rock, distance() runs FCL against the nearest rock voxel of a few points inside
/// the robot (an upper bound), then scans the rock surface voxels in the robot's bounding box
/// grown by that bound and branch-and-bounds FCL over them; measured near a wall at 0.2 m, about
/// 4 us for a sphere and 10-30 us for a box or capsule, with 1-5 FCL calls. inCollision() needs
/// no upper bound and costs a few us. Thread-safe: queries are const and their scratch memory is
/// per thread.
class CollisionChecker {
 public:
  /// Keeps pointers to `map` and `field`, which must outlive the checker (and its copies). The
  /// field is read on every query, so DistanceField::update() after OccupancyMap::setVoxels()
  /// is seen at once. Refuses a field whose resolution differs from the map's.
  static StatusOr<CollisionChecker> create(const OccupancyMap& map, const DistanceField& field);

  /// True when the shape overlaps rock, or its origin is in a rock voxel.
  bool inCollision(const RobotShape& shape, const Eigen::Isometry3d& pose) const;

  /// Distance from the shape to the nearest rock voxel (cubes of edge resolution()). Exact (to
  /// FCL's GJK tolerance, 1e-6 m) whenever it is <= max_distance_m; otherwise exact = false and
  /// distance_m is a lower bound >= max_distance_m. Infinity asks for the exact distance always
  /// (still cheap: the search never reaches beyond the clearance at the robot's origin).
  ShapeDistance distance(const RobotShape& shape, const Eigen::Isometry3d& pose,
                         double max_distance_m = std::numeric_limits<double>::infinity()) const;

  /// A proven lower bound on the distance from the point p to rock, from the field's reads
  /// around p and no search: what distance() settles a shape far from rock with (less the
  /// shape's bounding radius). Within about a voxel of the true distance where the clearance
  /// varies slowly; -infinity where the field knows no rock.
  double clearanceLowerBound(const Vec3& p) const;

  double resolution() const;
  const OccupancyMap& map() const { return *map_; }
  const DistanceField& field() const { return *field_; }

 private:
  CollisionChecker(const OccupancyMap& map, const DistanceField& field) : map_(&map), field_(&field) {}
  const OccupancyMap* map_;
  const DistanceField* field_;
};

/// Baseline only: FCL's fcl::OcTree distance against the map's octree, kept to measure
/// CollisionChecker against and to cross-check it. Not for hot paths: near a wall of a small
/// roadway map a sphere query costs about 0.1 ms and a capsule 0.4-0.6 ms, 20 times
/// CollisionChecker, and the octree walk grows with the map.
///
/// It differs from CollisionChecker's rock model: fcl::OcTree sees *occupied* nodes only and
/// treats unknown space as free. It therefore agrees with the checker only where the rock is
/// explicitly occupied, e.g. within the rock shell voxelize() writes around roadways
/// (SurveyNetwork::rock_shell_m, 0.6 m by default): distances below the shell thickness match.
///
/// FCL 0.7 quirks handled here: fcl::distance(shape, octree) returns the nearest points swapped
/// (and result.o1 is the octree), and reports -1 on overlap; this wrapper un-swaps the points and
/// answers overlaps with fcl::collide (collision = true, distance 0). With no occupied node at all
/// the distance is +infinity (exact, NaN points).
class FclOctreeDistance {
 public:
  /// Shares the map's octree (std::shared_ptr): the map object need not outlive this one, and
  /// later OccupancyMap::setVoxels() changes are seen.
  static StatusOr<FclOctreeDistance> create(const OccupancyMap& map);

  FclOctreeDistance(const FclOctreeDistance&);
  FclOctreeDistance& operator=(const FclOctreeDistance&);
  FclOctreeDistance(FclOctreeDistance&&) noexcept;
  FclOctreeDistance& operator=(FclOctreeDistance&&) noexcept;
  ~FclOctreeDistance();

  /// Distance to the nearest occupied voxel; candidates_checked stays 0 (FCL does not count).
  ShapeDistance distance(const RobotShape& shape, const Eigen::Isometry3d& pose) const;
  /// fcl::collide against the occupied voxels.
  bool inCollision(const RobotShape& shape, const Eigen::Isometry3d& pose) const;

 private:
  struct Impl;
  explicit FclOctreeDistance(std::shared_ptr<const Impl> impl);
  std::shared_ptr<const Impl> impl_;  // immutable after create(): copies share it
};

}  // namespace adit::map
