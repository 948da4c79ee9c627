// SPDX-License-Identifier: BSD-3-Clause
// The floor's slope under a ground vehicle (map::floorSlope) against the incline the voxel floor
// was made from: voxel stairs of inclines from level to 15 degrees in several directions, bodies
// at random points and headings, stair edges included. The fit must follow the incline within
// its stated bound (0.75 res / half_window); the plane through a body's own ends does not (a
// whole stair over its length), which is what tilted the referee's bodies into the ribs.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <limits>
#include <optional>
#include <random>
#include <vector>

#include "adit/map/distance_field.hpp"
#include "adit/map/occupancy_map.hpp"
#include "adit/map/rock_points.hpp"

namespace adit::map {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kSize = 12.0;  // metres, square

// A square of voxel floor quantised from the plane z = gx x + gy y (each column's floor on the
// voxel face below the plane at its centre), free for 2.5 m above it, rock 1 m below; columns with
// x > wall_x are rock from bottom to top (a rib with nothing beyond it).
struct Floor {
  DistanceField field;
  double gx, gy;
};
Floor inclinedFloor(double res, double slope_deg, double dir_rad, double wall_x = kSize + 1.0) {
  const double g = std::tan(slope_deg * kPi / 180.0), gx = g * std::cos(dir_rad), gy = g * std::sin(dir_rad);
  std::vector<Vec3> free, occupied;
  const int n = int(std::lround(kSize / res));
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      const double x = (i + 0.5) * res, y = (j + 0.5) * res;
      const double f = res * std::floor((gx * x + gy * y) / res);
      for (int k = -int(std::lround(1.0 / res)); k < int(std::lround(2.5 / res)); ++k) {
        const double z = f + (k + 0.5) * res;
        (z < f || x > wall_x ? occupied : free).emplace_back(x, y, z);
      }
    }
  StatusOr<OccupancyMap> m = OccupancyMap::fromVoxels(res, free, occupied);
  EXPECT_TRUE(m.ok()) << m.status().message();
  StatusOr<DistanceField> f = DistanceField::build(*m);
  EXPECT_TRUE(f.ok()) << f.status().message();
  return {std::move(*f), gx, gy};
}

struct Worst {
  double err = 0.0;
  int fewest_samples = std::numeric_limits<int>::max();
};

// The fit at `points` random positions and headings (the window inside the square), against the
// incline's rise along and across each heading.
Worst fitError(const Floor& fl, double half_window, std::uint64_t seed, int points, double max_x = kSize) {
  std::mt19937_64 rng(seed);
  // The turned window's corners stay inside the square.
  const double reach = half_window * std::sqrt(2.0) + 0.3;
  const double lo = reach, hi_x = std::min(max_x, kSize - reach + 0.3) - 0.3, hi_y = kSize - reach;
  std::uniform_real_distribution<double> ux(lo, hi_x), uy(lo, hi_y), uyaw(-kPi, kPi);
  const double tan15 = std::tan(15.0 * kPi / 180.0);
  Worst w;
  for (int k = 0; k < points; ++k) {
    const double x = ux(rng), y = uy(rng), yaw = uyaw(rng);
    const std::optional<double> f = floorBelow(fl.field, Vec3(x, y, fl.gx * x + fl.gy * y + 1.0), 3.0);
    EXPECT_TRUE(f.has_value()) << x << ", " << y;
    if (!f) continue;
    const FloorSlope s = floorSlope(fl.field, Vec3(x, y, *f), yaw, half_window, tan15, 0.1);
    const double along = fl.gx * std::cos(yaw) + fl.gy * std::sin(yaw);
    const double across = -fl.gx * std::sin(yaw) + fl.gy * std::cos(yaw);
    w.err = std::max({w.err, std::abs(s.along - along), std::abs(s.across - across)});
    w.fewest_samples = std::min(w.fewest_samples, s.samples);
  }
  return w;
}

TEST(FloorSlope, FollowsTheInclineNotTheVoxelStairs) {
  constexpr double kRes = 0.2, kWindow = 2.5;
  const double bound = 0.75 * kRes / kWindow;
  for (double slope : {0.0, 3.0, 5.0, 10.0, 15.0})
    for (double dir : {0.0, 0.4, 1.3, 2.6}) {
      const Floor fl = inclinedFloor(kRes, slope, dir);
      const Worst w = fitError(fl, kWindow, std::uint64_t(slope * 10 + dir * 100), 60);
      EXPECT_LE(w.err, bound) << slope << " deg toward " << dir << " rad: rise off by " << w.err;
      EXPECT_EQ(w.fewest_samples, 81);
      // The plane through a 1.0 x 0.7 m body's own ends and sides (the window shrunk to the body):
      // a stair edge under it tilts it by the whole stair; the test's floors are built to show that.
      const Worst body = fitError(fl, 0.5, std::uint64_t(slope * 10 + dir * 100) + 1, 200);
      if (slope > 0.0 && slope < 15.0) {
        EXPECT_GT(body.err, 2.0 * bound) << slope << " deg toward " << dir;
      }
      std::printf("%4.1f deg toward %.1f rad: worst rise error %.4f over 2.5 m (%.1f deg), %.4f over 0.5 m (%.1f deg)\n", slope,
                  dir, w.err, std::atan(w.err) * 180 / kPi, body.err, std::atan(body.err) * 180 / kPi);
    }
}

// Beside a rib the samples beyond it have no floor and are left out; the rest still give the incline.
TEST(FloorSlope, LeavesOutWhatIsBeyondARib) {
  constexpr double kRes = 0.2, kWindow = 2.5;
  const Floor fl = inclinedFloor(kRes, 5.0, 0.3, /*wall_x=*/7.0);
  const Worst w = fitError(fl, kWindow, 7, 60, /*max_x=*/6.5);
  EXPECT_LE(w.err, 0.75 * kRes / (0.5 * kWindow)) << "rise off by " << w.err;
  EXPECT_LT(w.fewest_samples, 81);
  EXPECT_GE(w.fewest_samples, 3);
}

TEST(FloorSlope, BadInputGivesALevelFloorWithNoSamples) {
  const Floor fl = inclinedFloor(0.2, 5.0, 0.0);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  for (const FloorSlope s : {floorSlope(fl.field, Vec3(nan, 5, 0), 0, 2.5, 0.27, 0.1),
                             floorSlope(fl.field, Vec3(5, 5, 0.5), nan, 2.5, 0.27, 0.1),
                             floorSlope(fl.field, Vec3(5, 5, 0.5), 0, -1.0, 0.27, 0.1),
                             floorSlope(fl.field, Vec3(5, 5, 0.5), 0, 2.5, 0.27, 0.1, 1),
                             // In rock, far from any floor: nothing to fit.
                             floorSlope(fl.field, Vec3(5, 5, -30.0), 0, 2.5, 0.27, 0.1)}) {
    EXPECT_EQ(s.samples, 0);
    EXPECT_EQ(s.along, 0.0);
    EXPECT_EQ(s.across, 0.0);
  }
}

}  // namespace
}  // namespace adit::map
