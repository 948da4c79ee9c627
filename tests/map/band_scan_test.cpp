// SPDX-License-Identifier: BSD-3-Clause
// The band scan with its cache against the scan that reads every voxel (the reference), on
// rugged generated terrain and on pillar fields, along robot-like walks with jumps and field
// updates in between; and the field's voxel clearance, on which the cache's skips rest, against
// brute force.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <optional>
#include <random>
#include <string>
#include <vector>

#include "adit/map/distance_field.hpp"
#include "adit/map/map_io.hpp"
#include "adit/map/occupancy_map.hpp"
#include "adit/map/rock_points.hpp"
#include "adit/map/survey_network.hpp"
#include "support/pillar_field.hpp"

namespace adit::map {
namespace {

constexpr double kPi = 3.14159265358979323846;

// A 16 x 10 m terrain at `res`: a floor of slopes, steps and holes, pillars, overhangs low
// enough to block a robot, a roof 2.5 m above the floor; unknown (rock) elsewhere.
OccupancyMap ruggedTerrain(std::uint64_t seed, double res) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  const int nx = int(16.0 / res), ny = int(10.0 / res);
  std::vector<double> floor_z(std::size_t(nx * ny));
  // Smooth slopes of random direction, plus terraces (steps) and a few holes.
  const double a = 0.25 * (u(rng) - 0.5), b = 0.25 * (u(rng) - 0.5), wave = 0.4 * u(rng);
  for (int j = 0; j < ny; ++j)
    for (int i = 0; i < nx; ++i) {
      const double x = (i + 0.5) * res, y = (j + 0.5) * res;
      double z = a * x + b * y + wave * std::sin(0.7 * x) * std::cos(0.5 * y);
      if (x > 6.0 && x < 6.6) z += 0.3;   // a kerb
      if (y > 7.0) z += 0.15 * std::floor((x - 2.0) / 1.3);  // a staircase of terraces
      floor_z[std::size_t(j * nx + i)] = res * std::floor(z / res);
    }
  std::vector<Vec3> free, occupied;
  for (int j = 0; j < ny; ++j)
    for (int i = 0; i < nx; ++i) {
      const double x = (i + 0.5) * res, y = (j + 0.5) * res, f = floor_z[std::size_t(j * nx + i)];
      const bool hole = u(rng) < 0.01, pillar = u(rng) < 0.02, overhang = u(rng) < 0.02;
      for (int k = -int(std::lround(1.5 / res)); k < int(std::lround(2.5 / res)); ++k) {
        const double z = f + (k + 0.5) * res;  // voxel centres (f is on a voxel face)
        bool rock = z < f && !hole;
        if (pillar) rock = rock || z < f + 1.0;
        if (overhang && z > f + 0.5 && z < f + 0.9) rock = true;
        (rock ? occupied : free).emplace_back(x, y, z);
      }
    }
  StatusOr<OccupancyMap> m = OccupancyMap::fromVoxels(res, free, occupied);
  EXPECT_TRUE(m.ok()) << m.status().message();
  return std::move(*m);
}

// A flat room of 16 x 10 m, 2.6 m high, floor at z = 0.
OccupancyMap flatRoom(double res) {
  std::vector<Vec3> free, occupied;
  for (double x = 0.5 * res; x < 16.0; x += res)
    for (double y = 0.5 * res; y < 10.0; y += res)
      for (int k = -int(std::lround(0.6 / res)); k < int(std::lround(2.6 / res)); ++k)
        (k < 0 ? occupied : free).emplace_back(x, y, (k + 0.5) * res);
  StatusOr<OccupancyMap> m = OccupancyMap::fromVoxels(res, free, occupied);
  EXPECT_TRUE(m.ok()) << m.status().message();
  return std::move(*m);
}

void expectSameScan(const BandScan& a, const BandScan& b, const Vec3& at) {
  ASSERT_EQ(a.truncated, b.truncated) << at.transpose();
  for (int k = 0; k < BandScan::kBins; ++k) {
    ASSERT_EQ(a.distance[k], b.distance[k]) << "bin " << k << " at " << at.transpose();
    if (std::isfinite(a.distance[k])) {
      ASSERT_EQ(a.point[k], b.point[k]) << "bin " << k << " at " << at.transpose();
    }
  }
}

// The floor under (x, y): below the highest free voxel of the column (under the roof).
std::optional<double> floorAt(const DistanceField& field, double x, double y) {
  // Voxel centres: a point on a voxel's face is on one side or the other by rounding.
  for (double z = 4.0 + 0.5 * field.resolution(); z > -4.0; z -= field.resolution())
    if (field.isFree(Vec3(x, y, z))) return floorBelow(field, Vec3(x, y, z), 6.0);
  return std::nullopt;
}

struct Robot {
  double radius = 2.6, max_step = 0.15, slope_tan = std::tan(15.0 * kPi / 180.0), height = 0.6;
};

// A walk of `steps` periods in [lo, hi] (x, y): 5 cm steps in a slowly turning direction, a jump
// now and then; at each, the cached scan equals the reference. Returns the scans with a way.
int walkAndCompare(const DistanceField& field, BandCache& cache, const Robot& r, Vec3 lo, Vec3 hi, int steps,
                   std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  Vec3 q(lo.x() + u(rng) * (hi.x() - lo.x()), lo.y() + u(rng) * (hi.y() - lo.y()), 0.0);
  double heading = 2.0 * kPi * u(rng);
  int with_way = 0;
  for (int n = 0; n < steps; ++n) {
    if (u(rng) < 0.03) {
      q = Vec3(lo.x() + u(rng) * (hi.x() - lo.x()), lo.y() + u(rng) * (hi.y() - lo.y()), 0.0);
    } else {
      heading += 0.3 * (u(rng) - 0.5);
      q += 0.05 * Vec3(std::cos(heading), std::sin(heading), 0.0);
      q.x() = std::clamp(q.x(), lo.x(), hi.x());
      q.y() = std::clamp(q.y(), lo.y(), hi.y());
    }
    // The robot's floor: the floor under it, or (over a hole) a made-up height.
    const std::optional<double> f = floorAt(field, q.x(), q.y());
    const double z_floor = f ? *f : 0.0;
    const Vec3 c(q.x(), q.y(), z_floor + 0.3);
    BandScan ref, got;
    rockInBand(field, c, r.radius, z_floor, r.max_step, r.slope_tan, r.height, ref);
    rockInBand(field, c, r.radius, z_floor, r.max_step, r.slope_tan, r.height, got, 1u << 16, &cache);
    expectSameScan(ref, got, c);
    if (::testing::Test::HasFatalFailure()) return with_way;
    with_way += std::any_of(std::begin(ref.distance), std::end(ref.distance), [](double d) { return std::isfinite(d); });
  }
  return with_way;
}

TEST(BandScan, CachedScanEqualsTheReferenceOnRuggedTerrain) {
  for (std::uint64_t seed : {1u, 2u, 3u}) {
    for (double res : {0.1, 0.2}) {
      const OccupancyMap m = ruggedTerrain(seed, res);
      StatusOr<DistanceField> field = DistanceField::build(m);
      ASSERT_TRUE(field.ok());
      Robot r;
      BandCache cache;
      ASSERT_TRUE(cache.reserve(res, r.radius, r.max_step, r.slope_tan, r.height));
      const int with_way = walkAndCompare(*field, cache, r, Vec3(0.5, 0.5, 0), Vec3(15.5, 9.5, 0), 600, seed);
      if (HasFatalFailure()) return;
      EXPECT_GT(with_way, 300) << "the terrain should put something in the way of most scans";
    }
  }
}

TEST(BandScan, CachedScanEqualsTheReferenceInPillarFields) {
  for (std::uint64_t seed : {11u, 12u}) {
    test::PillarFieldSpec spec;
    spec.seed = seed;
    spec.fill = 0.2;
    const auto pf = test::makePillarField(spec);
    ASSERT_TRUE(pf && pf->field);
    Robot r;
    r.radius = 1.4;  // a small robot's rho0 plus its radius
    BandCache cache;
    ASSERT_TRUE(cache.reserve(spec.cell_m, r.radius, r.max_step, r.slope_tan, r.height));
    const Vec3 lo = pf->cellCentre(0, 0, 0), hi = pf->cellCentre(spec.rows - 1, spec.cols - 1, 0);
    walkAndCompare(*pf->field, cache, r, lo, hi, 600, seed);
    if (HasFatalFailure()) return;
  }
}

// The bundled district's roadways, walked as the tracked rescue robot does (1.0 x 0.7 x 0.6 m,
// 0.1 m steps, its underside checked to its stopping reach): long stretches of one floor level,
// where whole scans pass their step and slope tests on the cache's bounds, and level changes,
// junctions and ribs where they do not. A run of 150 periods (5 cm each) along every roadway.
TEST(BandScan, CachedScanEqualsTheReferenceAlongTheDistrictsRoadways) {
  StatusOr<SurveyNetwork> net = loadSurvey(std::string(ADIT_MAPS_DIR) + "/district.yaml");
  StatusOr<OccupancyMap> m = loadMap(std::string(ADIT_MAPS_DIR) + "/district.bt");
  ASSERT_TRUE(net.ok() && m.ok());
  StatusOr<DistanceField> field = DistanceField::build(*m);
  ASSERT_TRUE(field.ok());
  const double res = field->resolution(), radius = 2.61, step = 0.1, slope = std::tan(15.0 * kPi / 180.0);
  BandCache cache;
  ASSERT_TRUE(cache.reserve(res, radius, step, slope, 0.6));
  BandBody body;
  body.reach = 0.91;
  body.clearance = step + res;
  int scans = 0, with_way = 0;
  for (const SurveyRoadway& r : net->roadways) {
    const Polyline line = net->centreline(r);
    int n = 0;
    for (std::size_t i = 1; i < line.size() && n < 150; ++i) {
      const Vec3 d = line.points[i] - line.points[i - 1];
      for (double t = 0; t < d.norm() && n < 150; t += 0.05, ++n) {
        // Off the centreline by up to a metre and a half, toward a rib.
        const Vec3 p = line.points[i - 1] + d.normalized() * t + Vec3(0, 0, 1.2) +
                       1.5 * std::sin(0.05 * n) * Vec3(-d.y(), d.x(), 0).normalized();
        const std::optional<double> f = floorBelow(*field, p, 3.0);
        if (!f) continue;
        const Vec3 c(p.x(), p.y(), *f + 0.3);
        BandScan ref, got;
        rockInBand(*field, c, radius, *f, step, slope, 0.6, ref, 1u << 16, nullptr, &body);
        rockInBand(*field, c, radius, *f, step, slope, 0.6, got, 1u << 16, &cache, &body);
        expectSameScan(ref, got, c);
        if (HasFatalFailure()) return;
        ++scans;
        with_way += std::any_of(std::begin(ref.distance), std::end(ref.distance), [](double x) { return std::isfinite(x); });
      }
    }
  }
  EXPECT_GT(scans, 1500);
  EXPECT_GT(with_way, scans / 2) << "most scans should reach a rib";
}

// A room of flat floors joined by a kerb two voxels high (a step the robot may not take: 0.4 m
// against 0.15) and by a ramp three voxels high over a metre (31 degrees against 15): the
// smallest floor differences that fail the step and the slope test, where the cache's bounds
// on the window's floors are tightest, and wide flat floors, where whole scans pass on them.
// Every scan across them equals the reference.
TEST(BandScan, CachedScanEqualsTheReferenceAtTheSmallestFailingStepAndSlope) {
  const double res = 0.2;
  // Floor level (in voxels) of column (i, j): a kerb at x = 4 m for y < 5 m; a ramp from x = 10
  // to 11 m elsewhere.
  auto level = [&](int i, int j) {
    const double x = (i + 0.5) * res, y = (j + 0.5) * res;
    if (y < 5.0) return x > 4.0 ? 2 : 0;
    return x < 10.0 ? 0 : x > 11.0 ? 3 : int(std::floor((x - 10.0) * 3.0 / 1.0 + 0.5));
  };
  std::vector<Vec3> free, occupied;
  for (int i = 0; i < int(16.0 / res); ++i)
    for (int j = 0; j < int(10.0 / res); ++j)
      for (int k = -3; k < 16; ++k)
        (k < level(i, j) ? occupied : free).emplace_back((i + 0.5) * res, (j + 0.5) * res, (k + 0.5) * res);
  StatusOr<OccupancyMap> m = OccupancyMap::fromVoxels(res, free, occupied);
  ASSERT_TRUE(m.ok()) << m.status().message();
  StatusOr<DistanceField> field = DistanceField::build(*m);
  ASSERT_TRUE(field.ok());
  Robot r;
  BandCache cache;
  ASSERT_TRUE(cache.reserve(res, r.radius, r.max_step, r.slope_tan, r.height));
  int with_way = 0, n = 0;
  for (double y : {2.5, 7.5})
    for (double x = 1.0; x < 15.0; x += 0.05, ++n) {
      const std::optional<double> f = floorAt(*field, x, y);
      ASSERT_TRUE(f.has_value()) << x << " " << y;
      // The floor as the caller says it is: the floor under the robot, and (every fourth period)
      // a voxel or more above or below it (a robot on a box, or in a hole), where the step to
      // its own floor, a drop or the climbable height decide; the body's underside tilted.
      const double z_floor = *f + (n % 4 == 3 ? res * double((n / 4) % 7 - 3) : 0.0);
      BandBody body;
      body.grad_x = 0.25 * std::sin(0.3 * n);
      body.grad_y = 0.25 * std::cos(0.2 * n);
      body.reach = 0.6 + 0.5 * std::abs(std::sin(0.1 * n));
      body.clearance = r.max_step + res;
      const Vec3 c(x, y, z_floor + 0.3);
      const BandBody* bodies[] = {nullptr, &body};
      for (const BandBody* b : bodies) {
        BandScan ref, got;
        rockInBand(*field, c, r.radius, z_floor, r.max_step, r.slope_tan, r.height, ref, 1u << 16, nullptr, b);
        rockInBand(*field, c, r.radius, z_floor, r.max_step, r.slope_tan, r.height, got, 1u << 16, &cache, b);
        expectSameScan(ref, got, c);
        if (HasFatalFailure()) return;
        with_way += std::any_of(std::begin(ref.distance), std::end(ref.distance), [](double d) { return std::isfinite(d); });
      }
    }
  EXPECT_GT(with_way, 200) << "the kerb and the ramp should be in the way";
}

TEST(BandScan, CacheIsDroppedWhenTheFieldChanges) {
  OccupancyMap m = flatRoom(0.2);
  StatusOr<DistanceField> field = DistanceField::build(m);
  ASSERT_TRUE(field.ok());
  Robot r;
  BandCache cache;
  ASSERT_TRUE(cache.reserve(0.2, r.radius, r.max_step, r.slope_tan, r.height));
  const Vec3 at(8.0, 5.0, 0.0);
  const std::optional<double> f = floorAt(*field, at.x(), at.y());
  ASSERT_TRUE(f);
  const Vec3 c(at.x(), at.y(), *f + 0.3);
  BandScan before, after, ref;
  rockInBand(*field, c, r.radius, *f, r.max_step, r.slope_tan, r.height, before, 1u << 16, &cache);
  // A fall of rubble 1.5 m east of the robot, then the same scan.
  std::vector<Vec3> rubble;
  for (double y = at.y() - 0.5; y <= at.y() + 0.5; y += 0.2)
    for (double z = *f + 0.1; z < *f + 1.0; z += 0.2) rubble.emplace_back(at.x() + 1.5, y, z);
  const std::uint64_t g0 = field->generation();
  const DistanceField copy = *field;
  EXPECT_EQ(copy.generation(), g0) << "a copy holds the same content";
  ASSERT_TRUE(m.setVoxels(rubble, VoxelState::kOccupied).ok());
  ASSERT_TRUE(field->update(m, Aabb{at + Vec3(1.0, -1.0, -2.0), at + Vec3(2.0, 1.0, 5.0)}).ok());
  EXPECT_NE(field->generation(), g0);
  EXPECT_EQ(copy.generation(), g0);
  rockInBand(*field, c, r.radius, *f, r.max_step, r.slope_tan, r.height, after, 1u << 16, &cache);
  rockInBand(*field, c, r.radius, *f, r.max_step, r.slope_tan, r.height, ref);
  expectSameScan(ref, after, c);
  // The rubble is in the way now, nearer than anything was in its bin before.
  const int bin = BandScan::kBins / 2;  // azimuth 0 (east)
  EXPECT_LT(after.distance[bin], 1.5);
  EXPECT_GT(before.distance[bin], after.distance[bin]);
}

TEST(BandScan, ReserveRefusesWhatItCannotHold) {
  BandCache cache;
  EXPECT_FALSE(cache.reserve(0.0, 2.0, 0.1, 0.2, 0.6));
  EXPECT_FALSE(cache.reserve(0.1, std::nan(""), 0.1, 0.2, 0.6));
  EXPECT_FALSE(cache.reserve(0.001, 50.0, 0.1, 0.2, 0.6)) << "more than 64 MiB";
  EXPECT_TRUE(cache.empty());
  EXPECT_TRUE(cache.reserve(0.2, 2.6, 0.15, 0.27, 0.6));
  EXPECT_FALSE(cache.empty());
}

// A point on the face between two voxels (half a body above a floor that is itself on a face)
// reads one voxel or the other by rounding; the floor under it must not move by a voxel. Found on
// the district: at x = 40.5 the floor top is -2.2 and floorBelow((40.5, 0, -1.6000000000000001))
// said -2.4, so the ground planner found nowhere to stand there and blocked the roadway.
// A floor that rises a voxel a column: a lump 0.4 m high and 0.4 m across its flank in a flat
// room, and beside it a 10 degree ramp. Every one-column step and the metre's slope pass both, so
// without the body's underside neither is in the way; with it (max_step and a voxel above the
// floor's plane, within the reach) the lump is and the ramp, on its own tilted plane, is not.
TEST(BandScan, TheBodysUndersideMeetsALumpButNotARamp) {
  const double res = 0.2, tan15 = std::tan(15.0 * kPi / 180.0);
  std::vector<Vec3> free, occupied;
  for (double x = 0.1; x < 8.0; x += res)
    for (double y = 0.1; y < 6.0; y += res) {
      // The lump: a column one voxel up, five two voxels up, one one voxel up.
      double f = (x > 3.2 && x < 3.4) || (x > 4.4 && x < 4.6) ? 0.2 : x > 3.4 && x < 4.4 ? 0.4 : 0.0;
      if (y > 3.0) f = res * std::floor(std::tan(10.0 * kPi / 180.0) * std::max(0.0, x - 1.0) / res);  // the ramp
      for (double z = -0.5; z < 2.6; z += res) (z < f ? occupied : free).emplace_back(x, y, z);
    }
  StatusOr<OccupancyMap> m = OccupancyMap::fromVoxels(res, free, occupied);
  ASSERT_TRUE(m.ok()) << m.status().message();
  StatusOr<DistanceField> f = DistanceField::build(*m);
  ASSERT_TRUE(f.ok());
  auto nearestAhead = [&](const Vec3& at, const BandBody* body) {
    BandScan scan;
    rockInBand(*f, at, 2.0, 0.0, 0.1, tan15, 0.6, scan, 1u << 16, nullptr, body);
    EXPECT_FALSE(scan.truncated);
    return scan.distance[BandScan::kBins / 2];  // the bin starting at azimuth 0: +x
  };
  BandBody flat;
  flat.reach = 1.5;
  flat.clearance = 0.1 + res;
  const Vec3 before_lump(2.7, 1.5, 0.3);
  EXPECT_FALSE(std::isfinite(nearestAhead(before_lump, nullptr))) << "the lump's flank passes the column tests";
  EXPECT_NEAR(nearestAhead(before_lump, &flat), 0.7, 1e-9) << "the underside meets the lump's top at x = 3.4";
  flat.reach = 0.5;
  EXPECT_FALSE(std::isfinite(nearestAhead(before_lump, &flat))) << "beyond the reach the lump is not checked";
  // On the ramp, its plane: nothing in the way.
  const Vec3 on_ramp(3.0, 4.5, res * std::floor(std::tan(10.0 * kPi / 180.0) * 2.0 / res) + 0.3);
  BandBody tilted;
  tilted.grad_x = std::tan(10.0 * kPi / 180.0);
  tilted.reach = 1.5;
  tilted.clearance = 0.1 + res;
  BandScan scan;
  rockInBand(*f, on_ramp, 1.5, on_ramp.z() - 0.3, 0.1, tan15, 0.6, scan, 1u << 16, nullptr, &tilted);
  EXPECT_FALSE(std::isfinite(scan.distance[BandScan::kBins / 2])) << scan.distance[BandScan::kBins / 2];
}

// The floor's plane read through the band scan's cache (as the local planner reads it, between
// its scans) equals the plane read voxel by voxel, along walks over rugged terrain at several
// headings: turned windows wider than the cache's ring fall back to the field.
TEST(FloorSlope, ThroughTheCacheEqualsTheFieldsOwnReading) {
  for (double res : {0.1, 0.2}) {
    const OccupancyMap m = ruggedTerrain(5, res);
    StatusOr<DistanceField> field = DistanceField::build(m);
    ASSERT_TRUE(field.ok());
    Robot r;
    BandCache cache;
    ASSERT_TRUE(cache.reserve(res, r.radius, r.max_step, r.slope_tan, r.height));
    std::mt19937_64 rng(9);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    int fitted = 0;
    Vec3 q(8.0, 5.0, 0.0);
    for (int n = 0; n < 400; ++n) {
      q += Vec3(0.05 * (u(rng) - 0.3), 0.05 * (u(rng) - 0.5), 0.0);
      if (n % 100 == 0) q = Vec3(1.0 + 14.0 * u(rng), 1.0 + 8.0 * u(rng), 0.0);
      const std::optional<double> f = floorAt(*field, q.x(), q.y());
      if (!f) continue;
      const Vec3 at(q.x(), q.y(), *f);
      const double yaw = n % 3 == 0 ? 0.0 : 2.0 * kPi * u(rng);
      const FloorSlope a = floorSlope(*field, at, yaw, 2.5, r.slope_tan, r.max_step);
      BandScan scan;
      rockInBand(*field, at + Vec3(0, 0, 0.3), r.radius, *f, r.max_step, r.slope_tan, r.height, scan, 1u << 16, &cache);
      const FloorSlope b = floorSlope(*field, at, yaw, 2.5, r.slope_tan, r.max_step, 9, &cache);
      ASSERT_EQ(a.samples, b.samples) << at.transpose() << " yaw " << yaw;
      ASSERT_EQ(a.along, b.along) << at.transpose() << " yaw " << yaw;
      ASSERT_EQ(a.across, b.across) << at.transpose() << " yaw " << yaw;
      fitted += a.samples >= 3;
    }
    EXPECT_GT(fitted, 300);
  }
}

TEST(FloorBelow, PointsOnVoxelFacesFindTheFloor) {
  for (double floor_z : {0.0, -2.2, 1.4}) {
    std::vector<Vec3> free, occupied;
    const double res = 0.2;
    for (double x = 0.1; x < 2.0; x += res)
      for (double y = 0.1; y < 2.0; y += res)
        for (int k = -5; k < 15; ++k) {
          const double z = floor_z + (k + 0.5) * res;
          (k < 0 ? occupied : free).emplace_back(x, y, z);
        }
    StatusOr<OccupancyMap> m = OccupancyMap::fromVoxels(res, free, occupied);
    ASSERT_TRUE(m.ok());
    StatusOr<DistanceField> field = DistanceField::build(*m);
    ASSERT_TRUE(field.ok());
    for (int faces = 1; faces <= 6; ++faces) {
      const double z = floor_z + faces * res;
      for (double zz : {z, std::nextafter(z, 1e9), std::nextafter(z, -1e9), floor_z + 0.3 + 0.3}) {
        const std::optional<double> f = floorBelow(*field, Vec3(1.05, 1.05, zz), 2.0);
        ASSERT_TRUE(f) << zz;
        EXPECT_NEAR(*f, floor_z, 1e-9) << "from z = " << zz;
      }
    }
  }
}

TEST(DistanceField, VoxelClearanceIsTheExactDistanceBetweenVoxelCentres) {
  const OccupancyMap m = ruggedTerrain(7, 0.2);
  StatusOr<DistanceField> field = DistanceField::build(m);
  ASSERT_TRUE(field.ok());
  const double res = 0.2;
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> ux(0.5, 15.5), uy(0.5, 9.5), uz(-1.0, 2.5);
  int free_points = 0;
  for (int n = 0; n < 600; ++n) {
    const Vec3 p(ux(rng), uy(rng), uz(rng));
    const double c = field->voxelClearance(p);
    if (!field->isFree(p)) {
      EXPECT_EQ(c, 0.0);
      continue;
    }
    ++free_points;
    // Brute force over the voxels around p, by the map itself.
    const Vec3 centre((std::floor(p.x() / res) + 0.5) * res, (std::floor(p.y() / res) + 0.5) * res,
                      (std::floor(p.z() / res) + 0.5) * res);
    double best = std::numeric_limits<double>::infinity();
    const int reach = int(std::ceil(c / res)) + 1;
    for (int i = -reach; i <= reach; ++i)
      for (int j = -reach; j <= reach; ++j)
        for (int k = -reach; k <= reach; ++k) {
          const Vec3 v = centre + res * Vec3(i, j, k);
          if (!m.isFree(v)) best = std::min(best, (v - centre).norm());
        }
    EXPECT_NEAR(c, best, 1e-9) << p.transpose();
  }
  EXPECT_GT(free_points, 120);
}

}  // namespace
}  // namespace adit::map
