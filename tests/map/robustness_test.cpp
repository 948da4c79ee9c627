// SPDX-License-Identifier: BSD-3-Clause
// Regressions from the robustness pass of issue 10: inclined roadways keep their clearance,
// voxel faces sit exactly on the grid, and size estimates refuse huge builds before allocating.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "adit/map/distance_field.hpp"
#include "adit/map/map_io.hpp"
#include "adit/map/occupancy_map.hpp"
#include "adit/map/size_estimate.hpp"
#include "adit/map/survey_network.hpp"
#include "support/survey_example.hpp"

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


// ---------------------------------------------------------------------------------------------
// Size estimates and crops

const std::string kDistrictBt = std::string(ADIT_MAPS_DIR) + "/district.bt";

bool mentions(const Status& s, const std::string& what) { return s.message().find(what) != std::string::npos; }

TEST(ByteSize, ParsesUnitsAndRefusesNonsense) {
  EXPECT_EQ(*parseByteSize("4G"), std::uint64_t{4} << 30);
  EXPECT_EQ(*parseByteSize("512M"), std::uint64_t{512} << 20);
  EXPECT_EQ(*parseByteSize("1.5GiB"), std::uint64_t{3} << 29);
  EXPECT_EQ(*parseByteSize("800k"), 800u * 1024u);
  EXPECT_EQ(*parseByteSize("123"), 123u);
  for (const char* bad : {"", "G", "-1G", "0", "4X", "nan", "1e30T"}) {
    const StatusOr<std::uint64_t> r = parseByteSize(bad);
    EXPECT_FALSE(r.ok()) << bad;
  }
  EXPECT_EQ(formatBytes(3.0 * (1 << 30)), "3.0 GiB");
  EXPECT_EQ(formatBytes(100), "100 B");
}

TEST(ByteSize, TheMachineBudgetIsThreeQuartersOfItsMemoryBetween2And8GiB) {
  const std::uint64_t budget = machineMemoryBudgetBytes();
  const long pages = ::sysconf(_SC_PHYS_PAGES), page = ::sysconf(_SC_PAGE_SIZE);
  ASSERT_GT(pages, 0);
  const double three_quarters = 0.75 * double(pages) * double(page);
  EXPECT_GE(budget, kDefaultMaxMemoryBytes);
  EXPECT_LE(budget, std::uint64_t{8} << 30);
  if (three_quarters >= double(std::uint64_t{8} << 30)) EXPECT_EQ(budget, std::uint64_t{8} << 30);
  else if (three_quarters >= double(kDefaultMaxMemoryBytes)) EXPECT_NEAR(double(budget), three_quarters, 1.0);
}

TEST(Box, ParsesSixFiniteValues) {
  const StatusOr<Aabb> b = parseBox("0,-1,2.5,10,1,3");
  ASSERT_TRUE(b.ok());
  EXPECT_EQ(b->min, Vec3(0, -1, 2.5));
  EXPECT_EQ(b->max, Vec3(10, 1, 3));
  for (const char* bad : {"1,2,3,4,5", "1,2,3,4,5,6,7", "0,0,0,nan,1,1", "0,0,0,1,x,1", "5,0,0,1,1,1"})
    EXPECT_FALSE(parseBox(bad).ok()) << bad;
}

// The estimate counts exactly the tiles the build allocates, under both policies, without
// building anything.
TEST(DistanceFieldEstimate, CountsTheTilesTheBuildAllocates) {
  for (double deg : {0.0, 35.0}) {
    for (UnknownPolicy policy : {UnknownPolicy::kRock, UnknownPolicy::kFree}) {
      VoxelizeOptions vo;
      vo.unknown_policy = policy;
      StatusOr<OccupancyMap> map = voxelize(inclinedRoadway(deg, 12.0, 0.1), vo);
      ASSERT_TRUE(map.ok());
      const DistanceFieldEstimate e = estimateDistanceField(*map);
      StatusOr<DistanceField> df = DistanceField::build(*map);
      ASSERT_TRUE(df.ok());
      if (policy == UnknownPolicy::kRock) {
        EXPECT_EQ(e.tiles, df->stats().blocks) << deg;
      }
      // Under kFree the box is filled; the estimate rounds each axis up by one tile.
      EXPECT_GE(e.tiles, df->stats().blocks) << deg;
      EXPECT_LE(double(e.tiles), 1.6 * double(df->stats().blocks)) << deg;
      EXPECT_GE(e.bytes, 0.9 * double(df->stats().memory_bytes)) << deg;
      EXPECT_LE(e.bytes, 2.0 * double(df->stats().memory_bytes)) << deg;
    }
  }
}

// The issue's case: `--unknown free` on the bundled district made the field fill a 611 x 451 x 40 m
// box (19 GB). The estimate names it from the octree alone.
TEST(DistanceFieldEstimate, BundledDistrictUnderUnknownFreeIsRefusedByTheDefaultBudget) {
  LoadOptions o;
  o.unknown_policy = UnknownPolicy::kFree;
  StatusOr<OccupancyMap> map = loadMap(kDistrictBt, o);
  ASSERT_TRUE(map.ok()) << map.status().toString();
  const DistanceFieldEstimate e = estimateDistanceField(*map);
  // The whole box as free space: about 5.7 GB at the compact field's ~6 B per free voxel (8 GiB
  // and more with the 8-byte cells before it), far beyond the 2 GiB default budget.
  EXPECT_GT(e.bytes, 4.0 * (1 << 30));
  const Status s = MemoryBudget{}.check(e.bytes, "the distance field", "use --crop");
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.code(), StatusCode::kOutOfRange);
  EXPECT_TRUE(mentions(s, "GiB")) << s.message();
  EXPECT_TRUE(mentions(s, "--crop")) << s.message();
  // Under the default policy the same map fits easily.
  StatusOr<OccupancyMap> rock = loadMap(kDistrictBt);
  ASSERT_TRUE(rock.ok());
  EXPECT_LT(estimateDistanceField(*rock).bytes, 0.5 * (1 << 30));
}

TEST(Crop, KeepsExactlyTheVoxelsInTheBox) {
  StatusOr<OccupancyMap> map = voxelize(inclinedRoadway(20.0, 16.0, 0.2));
  ASSERT_TRUE(map.ok());
  const Aabb box(Vec3(3, -1, -1), Vec3(9, 3, 6));
  StatusOr<OccupancyMap> part = cropMap(*map, box);
  ASSERT_TRUE(part.ok()) << part.status().toString();
  EXPECT_EQ(part->resolution(), map->resolution());
  std::size_t compared = 0;
  for (double x = -1.1; x < 18; x += 0.2)
    for (double y = -4.1; y < 4; y += 0.2)
      for (double z = -1.1; z < 9; z += 0.2) {
        const Vec3 p(x, y, z);
        if (box.contains(p)) {
          EXPECT_EQ(part->state(p), map->state(p)) << p.transpose();
          ++compared;
        } else if (!box.inflated(0.2).contains(p)) {
          EXPECT_EQ(part->state(p), VoxelState::kUnknown) << p.transpose();
        }
      }
  EXPECT_GT(compared, 1000u);
  EXPECT_FALSE(cropMap(*map, Aabb(Vec3(100, 100, 100), Vec3(101, 101, 101))).ok());
  EXPECT_FALSE(cropMap(*map, Aabb(Vec3(1, 1, 1), Vec3(0, 0, 0))).ok());
}

// A survey cut to a box voxelizes, inside the box, exactly as the whole network does.
TEST(Crop, SurveyCutBeforeVoxelizingMatchesTheWholeNetworkInTheBox) {
  StatusOr<SurveyNetwork> net = parseSurvey(test::shortIssueSurveyExample(), "short.yaml");
  ASSERT_TRUE(net.ok());
  StatusOr<OccupancyMap> whole = voxelize(*net);
  ASSERT_TRUE(whole.ok());
  for (const Aabb& box : {Aabb(Vec3(10, -3, -1), Vec3(16, 3, 5)),    // the middle of the main roadway
                          Aabb(Vec3(26, -3, 0), Vec3(33, 4, 7))}) {  // around the junction S2
    StatusOr<SurveyNetwork> cut = cropNetwork(*net, box);
    ASSERT_TRUE(cut.ok()) << cut.status().toString();
    EXPECT_LT(cut->estimatedVoxels(), net->estimatedVoxels());
    StatusOr<OccupancyMap> part = voxelize(*cut);
    ASSERT_TRUE(part.ok()) << part.status().toString();
    std::size_t compared = 0;
    for (double x = box.min.x(); x <= box.max.x(); x += 0.2)
      for (double y = box.min.y(); y <= box.max.y(); y += 0.2)
        for (double z = box.min.z(); z <= box.max.z(); z += 0.2, ++compared)
          ASSERT_EQ(part->state(Vec3(x, y, z)), whole->state(Vec3(x, y, z))) << x << " " << y << " " << z;
    EXPECT_GT(compared, 1000u);
  }
  EXPECT_FALSE(cropNetwork(*net, Aabb(Vec3(500, 500, 0), Vec3(501, 501, 1))).ok());
}

TEST(MemoryBudgetOfReaders, EveryReaderRefusesBeforeBuilding) {
  // Survey parse: the YAML's token count.
  const std::string yaml = test::shortIssueSurveyExample();
  EXPECT_GT(estimateSurveyParseBytes(yaml), double(yaml.size()));
  const std::string path = ::testing::TempDir() + "/budget_short_" + std::to_string(::getpid()) + ".yaml";
  {
    FILE* f = std::fopen(path.c_str(), "wb");
    ASSERT_NE(f, nullptr);
    std::fwrite(yaml.data(), 1, yaml.size(), f);
    std::fclose(f);
  }
  StatusOr<SurveyNetwork> tiny = loadSurvey(path, 4096);
  ASSERT_FALSE(tiny.ok());
  EXPECT_TRUE(mentions(tiny.status(), "parsing the survey")) << tiny.status().message();
  // Voxelizing: the network's voxel estimate, with the crop as the way out.
  LoadOptions o;
  o.max_memory_bytes = std::uint64_t(estimateSurveyParseBytes(yaml)) + 1024;
  StatusOr<OccupancyMap> map = loadMap(path, o);
  ASSERT_FALSE(map.ok());
  EXPECT_TRUE(mentions(map.status(), "voxelizing the survey network")) << map.status().message();
  EXPECT_TRUE(mentions(map.status(), "--crop")) << map.status().message();
  o.max_memory_bytes = 1u << 30;
  o.crop = Aabb(Vec3(10, -3, -1), Vec3(16, 3, 5));
  map = loadMap(path, o);
  ASSERT_TRUE(map.ok()) << map.status().toString();
  EXPECT_TRUE(map->isFree(Vec3(13, 0, 2.5)));  // floor at 1.3 m there
  EXPECT_FALSE(map->isFree(Vec3(20, 0, 3.2)));  // free in the whole network, outside the crop
  std::remove(path.c_str());

  // OctoMap: the node count, known true once the node stream is validated.
  StatusOr<OccupancyMap> bt = loadOctomap(kDistrictBt, UnknownPolicy::kRock, 1u << 20);
  ASSERT_FALSE(bt.ok());
  EXPECT_EQ(bt.status().code(), StatusCode::kOutOfRange);
  EXPECT_TRUE(mentions(bt.status(), "nodes)")) << bt.status().message();
}

}  // namespace
}  // namespace adit::map
