// SPDX-License-Identifier: BSD-3-Clause
// The FCL bridge against oracles: CollisionChecker against brute force over every rock voxel,
// FclOctreeDistance against brute force over the occupied voxels, shape pairs and moving
// obstacles against closed forms, and bad input.
//
// The brute-force oracle calls FCL itself (shape vs one box per rock voxel), independently of
// the wrapper under test; FCL is private to adit_map, so only this test includes it.
#include <gtest/gtest.h>

#include <fcl/geometry/octree/octree.h>
#include <fcl/geometry/shape/box.h>
#include <fcl/geometry/shape/capsule.h>
#include <fcl/geometry/shape/cylinder.h>
#include <fcl/geometry/shape/sphere.h>
#include <fcl/narrowphase/collision.h>
#include <fcl/narrowphase/distance.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <memory>
#include <random>

#include "adit/map/brute_force_distance.hpp"
#include "adit/map/collision.hpp"
#include "adit/map/distance_field.hpp"
#include "support/synthetic_roadway.hpp"

namespace adit::map {
namespace {

// FCL's GJK stops at 1e-6; sphere-box and sphere-sphere are closed forms, far tighter.
constexpr double kGjkTolerance_m = 1e-6;
constexpr double kClosedFormTolerance_m = 1e-9;
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

Eigen::Isometry3d poseAt(const Vec3& t, const Eigen::Quaterniond& q = Eigen::Quaterniond::Identity()) {
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.linear() = q.normalized().toRotationMatrix();
  pose.translation() = t;
  return pose;
}

Eigen::Quaterniond randomRotation(std::mt19937_64& rng) {
  std::normal_distribution<double> n(0.0, 1.0);
  return Eigen::Quaterniond(n(rng), n(rng), n(rng), n(rng)).normalized();
}

std::vector<RobotShape> testShapes() {
  return {RobotShape::sphere(0.35), RobotShape::box({0.9, 0.5, 0.4}), RobotShape::cylinder(0.3, 0.8),
          RobotShape::capsule(0.25, 0.7)};
}

/// Signed distance from a world point to the posed shape's surface (negative inside).
double signedDistanceToShape(const RobotShape& s, const Eigen::Isometry3d& pose, const Vec3& p) {
  const Vec3 q = pose.linear().transpose() * (p - pose.translation());
  switch (s.type) {
    case ShapeType::kSphere: return q.norm() - s.radius;
    case ShapeType::kBox: {
      const Vec3 d = q.cwiseAbs() - 0.5 * s.size;
      return d.cwiseMax(0.0).norm() + std::min(d.maxCoeff(), 0.0);
    }
    case ShapeType::kCylinder: {
      const double dr = std::hypot(q.x(), q.y()) - s.radius, dz = std::abs(q.z()) - 0.5 * s.length;
      return std::min(std::max(dr, dz), 0.0) + std::hypot(std::max(dr, 0.0), std::max(dz, 0.0));
    }
    case ShapeType::kCapsule: {
      const double dz = std::max(std::abs(q.z()) - 0.5 * s.length, 0.0);
      return std::sqrt(q.x() * q.x() + q.y() * q.y() + dz * dz) - s.radius;
    }
  }
  return kNaN;
}

/// Distance from a point to an axis-aligned cube of edge `edge` (0 inside).
double pointToCube(const Vec3& p, const Vec3& centre, double edge) {
  return ((p - centre).cwiseAbs() - Vec3::Constant(0.5 * edge)).cwiseMax(0.0).norm();
}

// ---- the brute-force oracle ----------------------------------------------------------------

std::unique_ptr<fcl::CollisionGeometryd> fclGeometry(const RobotShape& s) {
  switch (s.type) {
    case ShapeType::kSphere: return std::make_unique<fcl::Sphered>(s.radius);
    case ShapeType::kBox: return std::make_unique<fcl::Boxd>(s.size.x(), s.size.y(), s.size.z());
    case ShapeType::kCylinder: return std::make_unique<fcl::Cylinderd>(s.radius, s.length);
    case ShapeType::kCapsule: return std::make_unique<fcl::Capsuled>(s.radius, s.length);
  }
  return nullptr;
}

struct OracleAnswer {
  double distance = std::numeric_limits<double>::infinity();
  bool collision = false;
  int fcl_calls = 0;
};

/// Minimum over a list of rock voxels of FCL shape-vs-box; overlap (FCL distance <= 0) is decided
/// by fcl::collide. nearest() orders the voxels by the exact distance from the robot's origin to
/// the cube minus the bounding radius, a lower bound, and skips the voxels that bound proves
/// cannot win; scan() runs FCL on every voxel and checks that shortcut.
class RockOracle {
 public:
  RockOracle(std::vector<Vec3> rock, double res) : rock_(std::move(rock)), res_(res), cube_(res, res, res) {}

  OracleAnswer scan(const RobotShape& shape, const Eigen::Isometry3d& pose) const {
    const auto geom = fclGeometry(shape);
    OracleAnswer a;
    for (const Vec3& c : rock_) accumulate(*geom, pose, c, a);
    return a;
  }

  OracleAnswer nearest(const RobotShape& shape, const Eigen::Isometry3d& pose) const {
    const auto geom = fclGeometry(shape);
    const Vec3 origin = pose.translation();
    const double radius = shape.boundingRadius();
    std::vector<double> bound(rock_.size());
    std::size_t first = 0;
    for (std::size_t i = 0; i < rock_.size(); ++i) {
      bound[i] = std::max(pointToCube(origin, rock_[i], res_) - radius, 0.0);
      if (bound[i] < bound[first]) first = i;
    }
    OracleAnswer a;
    if (rock_.empty()) return a;
    accumulate(*geom, pose, rock_[first], a);  // an upper bound to prune with
    std::vector<std::pair<double, std::size_t>> order;
    for (std::size_t i = 0; i < rock_.size(); ++i)
      if (bound[i] < a.distance && i != first) order.push_back({bound[i], i});
    std::sort(order.begin(), order.end());
    for (const auto& [b, i] : order) {
      if (a.collision || b >= a.distance) break;
      accumulate(*geom, pose, rock_[i], a);
    }
    return a;
  }

  const std::vector<Vec3>& rock() const { return rock_; }
  /// Distance from a point to the nearest listed cube.
  double pointDistance(const Vec3& p) const {
    double best = std::numeric_limits<double>::infinity();
    for (const Vec3& c : rock_) best = std::min(best, pointToCube(p, c, res_));
    return best;
  }

 private:
  void accumulate(const fcl::CollisionGeometryd& geom, const Eigen::Isometry3d& pose, const Vec3& centre,
                  OracleAnswer& a) const {
    if (a.collision) return;
    const Eigen::Isometry3d cube_pose = poseAt(centre);
    fcl::DistanceRequestd request;
    fcl::DistanceResultd result;
    fcl::distance(&geom, pose, &cube_, cube_pose, request, result);
    ++a.fcl_calls;
    if (result.min_distance > 0.0) {
      a.distance = std::min(a.distance, result.min_distance);
      return;
    }
    fcl::CollisionRequestd creq;
    fcl::CollisionResultd cres;
    fcl::collide(&geom, pose, &cube_, cube_pose, creq, cres);
    a.distance = 0.0;
    a.collision = cres.isCollision();
  }

  std::vector<Vec3> rock_;
  double res_;
  fcl::Boxd cube_;
};

// ---- fixtures --------------------------------------------------------------------------------

using Case = test::NamedNetwork;

std::vector<Case> collisionCases() { return test::oracleRoadways(8.0); }

/// A voxelized roadway with its field, checker and oracles, built once per test. Not copyable:
/// the checker and the oracle point into it.
struct World {
  World(const World&) = delete;
  World& operator=(const World&) = delete;
  explicit World(const SurveyNetwork& net)
      : map(test::voxelizeOrFail(net)),
        field(std::move(DistanceField::build(map)).value()),
        checker(std::move(CollisionChecker::create(map, field)).value()),
        brute(std::move(BruteForceDistance::create(map)).value()),
        oracle(brute.rockCentres(), map.resolution()) {}

  /// A random orientation at a point anywhere in the bounds (mostly rock) or, with
  /// `free_origin`, at a free point.
  Eigen::Isometry3d randomPose(std::mt19937_64& rng, bool free_origin) const {
    Vec3 p = test::randomPoint(rng, map.bounds());
    while (free_origin && !map.isFree(p)) p = test::randomPoint(rng, map.bounds());
    return poseAt(p, randomRotation(rng));
  }

  OccupancyMap map;
  DistanceField field;
  CollisionChecker checker;
  BruteForceDistance brute;
  RockOracle oracle;
};

class CollisionOracle : public ::testing::TestWithParam<std::size_t> {};

// The checker's exact answers equal the minimum over every rock voxel of the map; its inexact
// answers are valid lower bounds; its nearest points lie on the robot and on rock.
TEST_P(CollisionOracle, DistanceMatchesBruteForceOverAllRock) {
  const Case c = collisionCases()[GetParam()];
  const World w(c.net);
  std::mt19937_64 rng(1000 + GetParam());
  int exact = 0, inexact = 0, collisions = 0, checked = 0, queries = 0;
  double max_err = 0.0;
  for (int i = 0; i < 50; ++i) {
    const Eigen::Isometry3d pose = w.randomPose(rng, i % 4 != 0);
    for (const RobotShape& shape : testShapes()) {
      const OracleAnswer truth = w.oracle.nearest(shape, pose);
      for (double max_d : {std::numeric_limits<double>::infinity(), 0.4}) {
        const ShapeDistance d = w.checker.distance(shape, pose, max_d);
        ++queries;
        checked += d.candidates_checked;
        SCOPED_TRACE(::testing::Message() << c.name << " " << shape.name() << " at "
                                          << pose.translation().transpose() << " max_d " << max_d);
        ASSERT_EQ(d.collision, truth.collision) << "oracle distance " << truth.distance;
        if (d.collision) {
          ++collisions;
          EXPECT_TRUE(d.exact);
          EXPECT_EQ(d.distance_m, 0.0);
          continue;
        }
        if (!d.exact) {
          ++inexact;
          EXPECT_FALSE(std::isinf(max_d)) << "an infinite max_distance must give an exact answer";
          EXPECT_GE(d.distance_m, max_d);
          EXPECT_LE(d.distance_m, truth.distance + kGjkTolerance_m) << "not a lower bound";
          continue;
        }
        ++exact;
        EXPECT_LE(d.distance_m, max_d);
        EXPECT_NEAR(d.distance_m, truth.distance, kGjkTolerance_m);
        max_err = std::max(max_err, std::abs(d.distance_m - truth.distance));
        if (d.distance_m > 1e-6) {
          EXPECT_NEAR((d.point_on_robot - d.point_on_obstacle).norm(), d.distance_m, 1e-5);
          EXPECT_NEAR(signedDistanceToShape(shape, pose, d.point_on_robot), 0.0, 1e-5) << "not on the robot";
          EXPECT_LT(w.brute.query(d.point_on_obstacle).distance, 1e-5) << "not on a rock voxel";
          // The obstacle point is the rock point nearest to the robot point.
          EXPECT_NEAR(w.brute.query(d.point_on_robot).distance, d.distance_m, 1e-5);
        }
      }
    }
  }
  EXPECT_GT(exact, 60) << c.name;
  EXPECT_GT(inexact, 10) << c.name;
  EXPECT_GT(collisions, 40) << c.name;
  RecordProperty("max_error_m", (::testing::Message() << max_err).GetString());
  RecordProperty("mean_fcl_calls", (::testing::Message() << double(checked) / queries).GetString());
  RecordProperty("exact_inexact_collision", (::testing::Message() << exact << "/" << inexact << "/" << collisions).GetString());
}

TEST_P(CollisionOracle, InCollisionMatchesBruteForce) {
  const Case c = collisionCases()[GetParam()];
  const World w(c.net);
  std::mt19937_64 rng(2000 + GetParam());
  int hits = 0, misses = 0;
  for (int i = 0; i < 80; ++i) {
    const Eigen::Isometry3d pose = w.randomPose(rng, i % 4 != 0);
    for (const RobotShape& shape : testShapes()) {
      const bool truth = w.oracle.nearest(shape, pose).collision;
      EXPECT_EQ(w.checker.inCollision(shape, pose), truth)
          << c.name << " " << shape.name() << " at " << pose.translation().transpose();
      (truth ? hits : misses)++;
    }
  }
  EXPECT_GT(hits, 40) << c.name;
  EXPECT_GT(misses, 40) << c.name;
}

// For a sphere the oracle has a closed form: the point distance of its centre minus the radius.
TEST_P(CollisionOracle, SphereMatchesAnalyticDistance) {
  const Case c = collisionCases()[GetParam()];
  const World w(c.net);
  std::mt19937_64 rng(3000 + GetParam());
  std::uniform_real_distribution<double> radius(0.05, 0.8);
  int separated = 0;
  for (int i = 0; i < 300; ++i) {
    const RobotShape sphere = RobotShape::sphere(radius(rng));
    const Eigen::Isometry3d pose = w.randomPose(rng, true);
    const DistanceSample s = w.brute.query(pose.translation());
    const double analytic = s.distance - sphere.radius;
    const ShapeDistance d = w.checker.distance(sphere, pose);
    ASSERT_TRUE(d.exact);
    if (analytic < -1e-9) {
      EXPECT_TRUE(d.collision) << pose.translation().transpose();
    } else if (analytic > 1e-9) {
      ++separated;
      EXPECT_FALSE(d.collision);
      EXPECT_NEAR(d.distance_m, analytic, kClosedFormTolerance_m) << pose.translation().transpose();
      EXPECT_NEAR((d.point_on_obstacle - s.nearest).norm(), 0.0, 1e-6) << "a different nearest point";
    }
  }
  EXPECT_GT(separated, 50) << c.name;
}

// clearanceLowerBound() never exceeds the distance to the nearest rock cube of the whole map, at
// free points, in rock and on the roadways' walls; and it is tight: 0.41-0.46 voxel below the
// truth on average over the free points here, where the bound from the point's own voxel alone
// is 0.75-0.83 voxel below (measured; that bound fails the second expectation).
TEST_P(CollisionOracle, ClearanceLowerBoundIsProvenAndTight) {
  const Case c = collisionCases()[GetParam()];
  const World w(c.net);
  const double res = w.map.resolution();
  std::mt19937_64 rng(5000 + GetParam());
  double gap_sum = 0.0;
  int free_points = 0;
  for (int i = 0; i < 3000; ++i) {
    const Vec3 p = test::randomPoint(rng, w.map.bounds());
    const DistanceSample truth = w.brute.query(p);
    const double lb = w.checker.clearanceLowerBound(p);
    ASSERT_LE(lb, truth.distance + 1e-12) << c.name << " at " << p.transpose();
    if (truth.in_rock) continue;
    ++free_points;
    gap_sum += truth.distance - lb;
  }
  ASSERT_GT(free_points, 300) << c.name;
  EXPECT_LT(gap_sum / free_points, 0.6 * res) << c.name;
}

INSTANTIATE_TEST_SUITE_P(Roadways, CollisionOracle, ::testing::Range<std::size_t>(0, 4),
                         [](const ::testing::TestParamInfo<std::size_t>& i) {
                           return std::string(collisionCases()[i.param].name);
                         });

// The oracle's pruning (lower bound from the bounding sphere) against FCL on every voxel.
TEST(CollisionOracleSelfCheck, PrunedOracleEqualsExhaustiveScan) {
  const World w(collisionCases()[0].net);
  std::mt19937_64 rng(4000);
  for (int i = 0; i < 3; ++i) {
    const Eigen::Isometry3d pose = w.randomPose(rng, true);
    for (const RobotShape& shape : testShapes()) {
      const OracleAnswer pruned = w.oracle.nearest(shape, pose), full = w.oracle.scan(shape, pose);
      EXPECT_EQ(pruned.collision, full.collision);
      EXPECT_NEAR(pruned.distance, full.distance, 1e-12) << shape.name();
      EXPECT_LT(pruned.fcl_calls, full.fcl_calls);
    }
  }
}

// ---- CollisionChecker specifics --------------------------------------------------------------

TEST(CollisionChecker, FarFromRockAnswersFromTheFieldAlone) {
  const World w(test::straightRoadway(CrossSection::rectangle(4.0, 3.0), 8.0, 0.2));
  const RobotShape robot = RobotShape::sphere(0.3);
  const Eigen::Isometry3d pose = poseAt({4.0, 0.0, 1.5});  // 1.5 m from every wall
  const ShapeDistance d = w.checker.distance(robot, pose, 0.2);
  EXPECT_FALSE(d.exact);
  EXPECT_FALSE(d.collision);
  EXPECT_EQ(d.candidates_checked, 0);
  EXPECT_GE(d.distance_m, 0.2);
  EXPECT_LE(d.distance_m, w.oracle.nearest(robot, pose).distance);
  // Asked for everything, the same query is exact and cheap: it searches no farther than the
  // clearance at the origin.
  const ShapeDistance full = w.checker.distance(robot, pose);
  EXPECT_TRUE(full.exact);
  EXPECT_NEAR(full.distance_m, 1.5 - 0.3, kClosedFormTolerance_m);
  EXPECT_LE(full.candidates_checked, 4);
}

// A body standing over its floor: its bounding ball reaches the floor, so the bound at the origin
// decides nothing, but the balls that cover it clear the floor and settle the query without a
// single FCL call. The referee's contact check of a tracked robot's box 0.3 m over the floor
// (max_d 0), the global planner's margin check of the cylinder around it lifted 0.5 m (max_d =
// its 0.1 m margin), a capsule lying 0.3 m over the floor. Beside a rib the same query still
// gives the exact distance.
TEST(CollisionChecker, ABodyOverItsFloorIsSettledByItsCoveringBalls) {
  const World w(test::straightRoadway(CrossSection::rectangle(4.0, 3.0), 8.0, 0.2));  // floor z = 0
  const Eigen::Matrix3d yawed = Eigen::AngleAxisd(0.5, Vec3::UnitZ()).toRotationMatrix();
  struct Body {
    RobotShape shape;
    double bottom;  // gap from the floor to the body's underside
    double half_z;  // half its height as posed
    Eigen::Matrix3d lie;
    double max_d;
  };
  const Eigen::Matrix3d upright = Eigen::Matrix3d::Identity();
  const Eigen::Matrix3d lying = Eigen::AngleAxisd(0.5 * 3.14159265358979, Vec3::UnitX()).toRotationMatrix();
  for (const Body& b : {Body{RobotShape::box({1.0, 0.7, 0.3}), 0.3, 0.15, upright, 0.0},
                        Body{RobotShape::cylinder(0.61, 0.6), 0.5, 0.3, upright, 0.1},
                        Body{RobotShape::capsule(0.3, 0.6), 0.3, 0.3, lying, 0.0}}) {
    for (const Eigen::Matrix3d& yaw : {upright, yawed}) {
      const Eigen::Matrix3d rot = yaw * b.lie;
      const Eigen::Isometry3d pose = poseAt({4.0, 0.0, b.bottom + b.half_z}, Eigen::Quaterniond(rot));
      SCOPED_TRACE(b.shape.name());
      // Its bounding ball alone needs the surface scan and FCL.
      EXPECT_GT(w.checker.distance(RobotShape::sphere(b.shape.boundingRadius()), pose, b.max_d).candidates_checked, 0);
      const double truth = w.oracle.nearest(b.shape, pose).distance;
      EXPECT_NEAR(truth, b.bottom, 1e-6);
      const ShapeDistance d = w.checker.distance(b.shape, pose, b.max_d);
      EXPECT_FALSE(d.collision);
      EXPECT_FALSE(d.exact);
      EXPECT_EQ(d.candidates_checked, 0);
      EXPECT_GE(d.distance_m, b.max_d);
      EXPECT_LE(d.distance_m, truth);
      EXPECT_FALSE(w.checker.inCollision(b.shape, pose));
      // Beside the rib (y = 2), 5 cm off it: exact, as before.
      Eigen::Isometry3d rib = pose;
      rib.translation().y() = 2.0 - 0.05 - (b.shape.type == ShapeType::kBox ? 0.5 * b.shape.size.y()
                                           : b.shape.type == ShapeType::kCapsule ? 0.5 * b.shape.length + b.shape.radius
                                                                                 : b.shape.radius);
      if (yaw.isIdentity()) {
        const ShapeDistance e = w.checker.distance(b.shape, rib, 0.1);
        EXPECT_TRUE(e.exact);
        EXPECT_NEAR(e.distance_m, w.oracle.nearest(b.shape, rib).distance, kGjkTolerance_m);
        EXPECT_NEAR(e.distance_m, 0.05, 1e-6);
      }
    }
  }
}

TEST(CollisionChecker, SeesFieldUpdatesAfterSetVoxels) {
  OccupancyMap map = test::voxelizeOrFail(test::straightRoadway(CrossSection::rectangle(4.0, 3.0), 8.0, 0.2));
  StatusOr<DistanceField> field = DistanceField::build(map);
  ASSERT_TRUE(field.ok());
  StatusOr<CollisionChecker> checker = CollisionChecker::create(map, *field);
  ASSERT_TRUE(checker.ok());
  const RobotShape robot = RobotShape::box({0.6, 0.6, 0.6});
  const Eigen::Isometry3d pose = poseAt({4.1, 0.1, 1.1});
  ASSERT_FALSE(checker->inCollision(robot, pose));
  // A boulder of one voxel next to the robot, then one inside it.
  ASSERT_TRUE(map.setVoxel({4.7, 0.1, 1.1}, VoxelState::kOccupied).ok());
  ASSERT_TRUE(field->update(map, Aabb({4.6, 0.0, 1.0}, {4.8, 0.2, 1.2})).ok());
  ShapeDistance d = checker->distance(robot, pose);
  EXPECT_FALSE(d.collision);
  EXPECT_NEAR(d.distance_m, 0.6 - 0.3 - 0.1, kGjkTolerance_m);  // boulder face at x = 4.6
  ASSERT_TRUE(map.setVoxel({4.3, 0.1, 1.1}, VoxelState::kOccupied).ok());
  ASSERT_TRUE(field->update(map, Aabb({4.2, 0.0, 1.0}, {4.4, 0.2, 1.2})).ok());
  EXPECT_TRUE(checker->inCollision(robot, pose));
  d = checker->distance(robot, pose);
  EXPECT_TRUE(d.collision);
  EXPECT_EQ(d.distance_m, 0.0);
}

TEST(CollisionChecker, RefusesAFieldOfAnotherResolution) {
  const OccupancyMap fine = test::voxelizeOrFail(test::straightRoadway(CrossSection::rectangle(4, 3), 6.0, 0.2));
  const OccupancyMap coarse = test::voxelizeOrFail(test::straightRoadway(CrossSection::rectangle(4, 3), 6.0, 0.25));
  StatusOr<DistanceField> field = DistanceField::build(coarse);
  ASSERT_TRUE(field.ok());
  StatusOr<CollisionChecker> checker = CollisionChecker::create(fine, *field);
  ASSERT_FALSE(checker.ok());
  EXPECT_EQ(checker.status().code(), StatusCode::kInvalidArgument);
}

// ---- FclOctreeDistance -----------------------------------------------------------------------

class FclOctreeOracle : public ::testing::TestWithParam<std::size_t> {};

// Against brute force over the *occupied* voxels, for spheres nearer to rock than the shell is
// thick: there FCL, the occupied-only oracle and the checker's full rock model all agree.
TEST_P(FclOctreeOracle, MatchesBruteForceOverOccupiedVoxelsWithinTheShell) {
  const Case c = collisionCases()[GetParam()];
  const World w(c.net);
  std::vector<Vec3> occupied;
  for (const Vec3& r : w.brute.rockCentres())
    if (w.map.state(r) == VoxelState::kOccupied) occupied.push_back(r);
  const RockOracle occupied_oracle(occupied, w.map.resolution());
  StatusOr<FclOctreeDistance> fcl_tree = FclOctreeDistance::create(w.map);
  ASSERT_TRUE(fcl_tree.ok());
  const double shell = c.net.rock_shell_m;
  std::mt19937_64 rng(5000 + GetParam());
  std::uniform_real_distribution<double> radius(0.1, 0.5);
  int compared = 0, collisions = 0;
  for (int i = 0; i < 400 && compared < 60; ++i) {
    const RobotShape sphere = RobotShape::sphere(radius(rng));
    const Eigen::Isometry3d pose = w.randomPose(rng, true);
    const double truth = occupied_oracle.pointDistance(pose.translation()) - sphere.radius;
    if (truth > shell - w.map.resolution()) continue;  // unknown rock could be nearer
    const ShapeDistance d = fcl_tree->distance(sphere, pose);
    SCOPED_TRACE(::testing::Message() << c.name << " r " << sphere.radius << " at " << pose.translation().transpose());
    EXPECT_TRUE(d.exact);
    EXPECT_EQ(d.candidates_checked, 0);
    EXPECT_EQ(fcl_tree->inCollision(sphere, pose), truth < 0.0);
    if (truth < -1e-9) {
      ++collisions;
      EXPECT_TRUE(d.collision);
      EXPECT_EQ(d.distance_m, 0.0);
      continue;
    }
    ++compared;
    EXPECT_FALSE(d.collision);
    EXPECT_NEAR(d.distance_m, truth, kClosedFormTolerance_m);
    // Un-swapped: the robot point on the sphere, the obstacle point on an occupied voxel.
    EXPECT_NEAR((d.point_on_robot - pose.translation()).norm(), sphere.radius, 1e-9);
    EXPECT_LT(occupied_oracle.pointDistance(d.point_on_obstacle), 1e-9);
    EXPECT_NEAR((d.point_on_robot - d.point_on_obstacle).norm(), d.distance_m, 1e-9);
    // Within the shell the checker's rock model gives the same answer.
    EXPECT_NEAR(w.checker.distance(sphere, pose).distance_m, d.distance_m, kClosedFormTolerance_m);
  }
  EXPECT_GE(compared, 30) << c.name;
  RecordProperty("collisions", std::to_string(collisions));
}

INSTANTIATE_TEST_SUITE_P(Roadways, FclOctreeOracle, ::testing::Range<std::size_t>(0, 4),
                         [](const ::testing::TestParamInfo<std::size_t>& i) {
                           return std::string(collisionCases()[i.param].name);
                         });

// Pins FCL 0.7's behaviour that the wrapper corrects. If FCL changes, this test says so; the
// wrapper follows result.o1 and keeps working either way.
TEST(FclOctreeDistance, RawFclSwapsNearestPointsAndReturnsMinusOneOnOverlap) {
  const OccupancyMap map = test::voxelizeOrFail(test::straightRoadway(CrossSection::rectangle(4, 3), 6.0, 0.2));
  const fcl::OcTreed tree(map.sharedOctree());
  const fcl::Sphered sphere(0.3);
  // The wall y = +2 is 1 m away from a sphere at y = 0.7.
  const Eigen::Isometry3d pose = poseAt({3.0, 0.7, 1.5});
  fcl::DistanceRequestd request(true);
  fcl::DistanceResultd result;
  fcl::distance(&sphere, pose, &tree, Eigen::Isometry3d::Identity(), request, result);
  EXPECT_NEAR(result.min_distance, 1.0, 1e-9);
  EXPECT_EQ(result.o1, &tree) << "FCL no longer swaps: update the header's note";
  EXPECT_NEAR(result.nearest_points[0].y(), 2.0, 1e-9) << "point 0 is on the octree";
  EXPECT_NEAR(result.nearest_points[1].y(), 1.0, 1e-9) << "point 1 is on the sphere";

  fcl::DistanceResultd overlap;
  fcl::distance(&sphere, poseAt({3.0, 1.9, 1.5}), &tree, Eigen::Isometry3d::Identity(), request, overlap);
  EXPECT_EQ(overlap.min_distance, -1.0);

  StatusOr<FclOctreeDistance> wrapped = FclOctreeDistance::create(map);
  ASSERT_TRUE(wrapped.ok());
  const ShapeDistance d = wrapped->distance(RobotShape::sphere(0.3), pose);
  EXPECT_NEAR(d.point_on_robot.y(), 1.0, 1e-9);
  EXPECT_NEAR(d.point_on_obstacle.y(), 2.0, 1e-9);
  const ShapeDistance o = wrapped->distance(RobotShape::sphere(0.3), poseAt({3.0, 1.9, 1.5}));
  EXPECT_TRUE(o.collision);
  EXPECT_EQ(o.distance_m, 0.0);
}

// fcl::OcTree ignores unknown space: with no occupied shell the mine is empty to FCL while the
// checker (unknown = rock) still sees the walls.
TEST(FclOctreeDistance, SeesOccupiedVoxelsOnlyUnknownIsFree) {
  SurveyNetwork net = test::straightRoadway(CrossSection::rectangle(4, 3), 6.0, 0.2);
  net.rock_shell_m = 0.0;
  const World w(net);
  StatusOr<FclOctreeDistance> fcl_tree = FclOctreeDistance::create(w.map);
  ASSERT_TRUE(fcl_tree.ok());
  const RobotShape robot = RobotShape::sphere(0.3);
  const Eigen::Isometry3d in_wall = poseAt({3.0, 2.5, 1.5});
  EXPECT_TRUE(w.checker.inCollision(robot, in_wall));
  EXPECT_FALSE(fcl_tree->inCollision(robot, in_wall));
  const ShapeDistance d = fcl_tree->distance(robot, poseAt({3.0, 0.7, 1.5}));
  EXPECT_TRUE(std::isinf(d.distance_m));
  EXPECT_NEAR(w.checker.distance(robot, poseAt({3.0, 0.7, 1.5})).distance_m, 1.0, kClosedFormTolerance_m);
}

// ---- shape pairs and moving obstacles ----------------------------------------------------------

TEST(CollisionMovingObstacle, SphereVsSphereIsAnalytic) {
  // Passes the robot around t = 8.5 s, decelerating along x and drifting up.
  const MovingObstacle ob{RobotShape::sphere(0.5), {10, 0, 1}, {-1.0, 0.2, 0}, {0.02, 0, 0.01}};
  const RobotShape robot = RobotShape::sphere(0.4);
  const Eigen::Isometry3d pose = poseAt({2, 1, 1}, Eigen::Quaterniond(Eigen::AngleAxisd(0.7, Vec3::UnitZ())));
  int separated = 0, overlapping = 0;
  for (double t = 0.0; t <= 12.0; t += 0.25) {
    const Vec3 centre = ob.positionAt(t);
    const double analytic = (centre - pose.translation()).norm() - 0.9;
    const ShapeDistance d = obstacleDistance(robot, pose, ob, t);
    SCOPED_TRACE(::testing::Message() << "t = " << t << " analytic " << analytic);
    ASSERT_TRUE(d.exact);
    if (analytic > 1e-9) {
      ++separated;
      EXPECT_FALSE(d.collision);
      EXPECT_NEAR(d.distance_m, analytic, kClosedFormTolerance_m);
      EXPECT_NEAR((d.point_on_robot - pose.translation()).norm(), 0.4, 1e-9);
      EXPECT_NEAR((d.point_on_obstacle - centre).norm(), 0.5, 1e-9);
    } else if (analytic < -1e-9) {
      ++overlapping;
      EXPECT_TRUE(d.collision);
      EXPECT_EQ(d.distance_m, 0.0);
    }
  }
  EXPECT_GT(separated, 10);
  EXPECT_GT(overlapping, 0);
}

TEST(CollisionMovingObstacle, BoxObstacleAtTimeT) {
  // A 1 x 0.5 x 0.5 cart moving along -x; the robot sphere waits at the origin.
  const MovingObstacle cart{RobotShape::box({1.0, 0.5, 0.5}), {20, 0, 0}, {-2.0, 0, 0}, {0, 0, 0}};
  const RobotShape robot = RobotShape::sphere(0.5);
  const Eigen::Isometry3d pose = poseAt({0, 0.1, 0});
  for (double t : {0.0, 5.0, 9.0, 9.2}) {
    const double front = cart.positionAt(t).x() - 0.5;  // the cart's face nearest the robot
    const double analytic = front - 0.5;
    const ShapeDistance d = obstacleDistance(robot, pose, cart, t);
    EXPECT_FALSE(d.collision) << t;
    EXPECT_NEAR(d.distance_m, analytic, kClosedFormTolerance_m) << t;
    EXPECT_NEAR(d.point_on_obstacle.x(), front, 1e-9) << t;
    EXPECT_NEAR(d.point_on_robot.x(), 0.5, 1e-9) << t;
  }
  EXPECT_TRUE(obstacleDistance(robot, pose, cart, 9.9).collision);
  // Rotated box robot vs the box cart: a GJK pair, with a closed form when faces are parallel.
  const Eigen::Isometry3d yawed = poseAt({0, 0, 0}, Eigen::Quaterniond(Eigen::AngleAxisd(M_PI / 2, Vec3::UnitZ())));
  const ShapeDistance boxes = obstacleDistance(RobotShape::box({2.0, 0.6, 0.5}), yawed, cart, 8.0);
  EXPECT_NEAR(boxes.distance_m, (20 - 16 - 0.5) - 0.3, kGjkTolerance_m);
}

TEST(CollisionMovingObstacle, ShapeDistanceIsSymmetric) {
  std::mt19937_64 rng(6000);
  const std::vector<RobotShape> shapes = testShapes();
  for (int i = 0; i < 40; ++i) {
    const RobotShape& a = shapes[std::size_t(i) % shapes.size()];
    const RobotShape& b = shapes[std::size_t(i / 4) % shapes.size()];
    const Eigen::Isometry3d pa = poseAt(test::randomPoint(rng, Aabb({-1, -1, -1}, {1, 1, 1})), randomRotation(rng));
    const Eigen::Isometry3d pb = poseAt(test::randomPoint(rng, Aabb({-1, -1, -1}, {1, 1, 1})), randomRotation(rng));
    const ShapeDistance ab = shapeDistance(a, pa, b, pb), ba = shapeDistance(b, pb, a, pa);
    EXPECT_EQ(ab.collision, ba.collision) << a.name() << " " << b.name();
    EXPECT_NEAR(ab.distance_m, ba.distance_m, 1e-5) << a.name() << " " << b.name();
    if (!ab.collision) {
      EXPECT_NEAR(signedDistanceToShape(a, pa, ab.point_on_robot), 0.0, 1e-5);
      EXPECT_NEAR(signedDistanceToShape(b, pb, ab.point_on_obstacle), 0.0, 1e-5);
    }
  }
}

// ---- bad input -------------------------------------------------------------------------------

void expectRejected(const ShapeDistance& d) {
  EXPECT_TRUE(d.collision);
  EXPECT_FALSE(d.exact);
  EXPECT_EQ(d.distance_m, 0.0);
  EXPECT_TRUE(std::isnan(d.point_on_robot.x()));
  EXPECT_EQ(d.candidates_checked, 0);
}

TEST(CollisionBadInput, NonFiniteOrNonRigidPoseAndInvalidShapeAreRejectedNotCrashed) {
  const World w(test::straightRoadway(CrossSection::rectangle(4, 3), 6.0, 0.2));
  StatusOr<FclOctreeDistance> fcl_tree = FclOctreeDistance::create(w.map);
  ASSERT_TRUE(fcl_tree.ok());
  const RobotShape good = RobotShape::sphere(0.3);
  const Eigen::Isometry3d ok_pose = poseAt({3, 0, 1.5});
  Eigen::Isometry3d nan_pose = ok_pose, nan_rotation = ok_pose, scaled = ok_pose, mirrored = ok_pose;
  nan_pose.translation().x() = kNaN;
  nan_rotation.linear()(0, 1) = kNaN;
  scaled.linear() *= 2.0;
  mirrored.linear()(2, 2) = -1.0;
  const Eigen::Isometry3d far_away = poseAt({1e12, 0, 0});
  RobotShape bad_type = good;
  bad_type.type = static_cast<ShapeType>(17);

  for (const Eigen::Isometry3d& pose : {nan_pose, nan_rotation, scaled, mirrored}) {
    EXPECT_EQ(validateQuery(good, pose).code(), StatusCode::kInvalidArgument);
    expectRejected(w.checker.distance(good, pose, 1.0));
    EXPECT_TRUE(w.checker.inCollision(good, pose));
    expectRejected(fcl_tree->distance(good, pose));
    EXPECT_TRUE(fcl_tree->inCollision(good, pose));
    expectRejected(shapeDistance(good, pose, good, ok_pose));
  }
  for (const RobotShape& shape : {RobotShape::sphere(-0.3), RobotShape::sphere(kNaN), RobotShape::box({1, 0, 1}),
                                  RobotShape::capsule(0.3, -1.0), RobotShape::cylinder(0.3, 0.0), bad_type}) {
    EXPECT_EQ(validateQuery(shape, ok_pose).code(), StatusCode::kInvalidArgument) << shape.name();
    expectRejected(w.checker.distance(shape, ok_pose));
    EXPECT_TRUE(w.checker.inCollision(shape, ok_pose));
    expectRejected(fcl_tree->distance(shape, ok_pose));
    expectRejected(obstacleDistance(good, ok_pose, MovingObstacle{shape, {5, 0, 1.5}, Vec3::Zero(), Vec3::Zero()}, 0.0));
  }
  expectRejected(w.checker.distance(good, ok_pose, kNaN));
  expectRejected(obstacleDistance(good, ok_pose, MovingObstacle{}, kNaN));
  // Valid but off the map: rock, like everywhere outside it.
  EXPECT_TRUE(validateQuery(good, far_away).ok());
  EXPECT_TRUE(w.checker.inCollision(good, far_away));
  const ShapeDistance off = w.checker.distance(good, far_away);
  EXPECT_TRUE(off.collision);
  EXPECT_TRUE(off.exact);
  // A robot absurdly large for the resolution answers at once (collision), never scans for minutes.
  const auto t0 = std::chrono::steady_clock::now();
  EXPECT_TRUE(w.checker.inCollision(RobotShape::sphere(1e7), ok_pose));
  EXPECT_TRUE(w.checker.distance(RobotShape::sphere(1e7), ok_pose).collision);
  EXPECT_TRUE(w.checker.inCollision(RobotShape::capsule(0.01, 1e7), ok_pose));
  // A hang guard (it answers in microseconds; a scan would take minutes), not a speed test.
  EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(), 10.0);
  // Negative max distance means 0: only contact is exact.
  const ShapeDistance neg = w.checker.distance(good, ok_pose, -1.0);
  EXPECT_FALSE(neg.exact);
  EXPECT_GE(neg.distance_m, 0.0);
}

// ---- timing (reported, not asserted: the machines are shared) ------------------------------------

TEST(CollisionTiming, QueriesNearAWallVersusFclOctree) {
  const World w(test::straightRoadway(CrossSection::rectangle(4.0, 3.0), 8.0, 0.2));
  StatusOr<FclOctreeDistance> fcl_tree = FclOctreeDistance::create(w.map);
  ASSERT_TRUE(fcl_tree.ok());
  std::mt19937_64 rng(7000);
  // Robots between 0.1 and 0.6 m from the wall y = 2.
  std::vector<Eigen::Isometry3d> poses;
  std::uniform_real_distribution<double> x(1.0, 7.0), gap(0.1, 0.6), z(0.8, 2.2);
  for (int i = 0; i < 200; ++i) poses.push_back(poseAt({x(rng), 2.0 - 0.3 - gap(rng), z(rng)}, randomRotation(rng)));
  using Clock = std::chrono::steady_clock;
  // The best of three rounds: other jobs on the machine only ever add time.
  auto perQueryUs = [&](auto&& fn, int repeats) {
    double best = std::numeric_limits<double>::infinity();
    for (int round = 0; round < 3; ++round) {
      const auto t0 = Clock::now();
      double sink = 0;
      for (int r = 0; r < repeats; ++r)
        for (const Eigen::Isometry3d& p : poses) sink += fn(p);
      EXPECT_FALSE(std::isnan(sink));
      best = std::min(best, std::chrono::duration<double, std::micro>(Clock::now() - t0).count() /
                                double(repeats * poses.size()));
    }
    return best;
  };
  const RobotShape sphere = RobotShape::sphere(0.3), capsule = RobotShape::capsule(0.3, 0.8);
  const double checker_sphere = perQueryUs([&](const auto& p) { return w.checker.distance(sphere, p, 1.0).distance_m; }, 10);
  const double checker_capsule = perQueryUs([&](const auto& p) { return w.checker.distance(capsule, p, 1.0).distance_m; }, 10);
  const double checker_collide = perQueryUs([&](const auto& p) { return double(w.checker.inCollision(capsule, p)); }, 10);
  const double octree_sphere = perQueryUs([&](const auto& p) { return fcl_tree->distance(sphere, p).distance_m; }, 1);
  const double octree_capsule = perQueryUs([&](const auto& p) { return fcl_tree->distance(capsule, p).distance_m; }, 1);
  RecordProperty("checker_sphere_us", std::to_string(checker_sphere));
  RecordProperty("checker_capsule_us", std::to_string(checker_capsule));
  RecordProperty("checker_incollision_capsule_us", std::to_string(checker_collide));
  RecordProperty("fcl_octree_sphere_us", std::to_string(octree_sphere));
  RecordProperty("fcl_octree_capsule_us", std::to_string(octree_capsule));
  std::printf("[ timing   ] per query near a wall: checker sphere %.1f us, capsule %.1f us, inCollision(capsule) %.1f us; "
              "fcl::OcTree sphere %.1f us, capsule %.1f us\n",
              checker_sphere, checker_capsule, checker_collide, octree_sphere, octree_capsule);
}

}  // namespace
}  // namespace adit::map
