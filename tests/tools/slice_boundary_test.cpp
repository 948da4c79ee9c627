// SPDX-License-Identifier: BSD-3-Clause
// `adit map slice --z` exactly on a voxel boundary (issue 10): z = 0.5 on a 0.1 m map drew
// "unknown" over the whole roadway, because the map handed the renderer float voxel centres
// (0.55f - 0.05 > 0.5 excluded the layer above, and the layer below ends at 0.5).
#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdio>
#include <string>

#include "adit/map/survey_network.hpp"
#include "common/render_topview.hpp"

namespace adit::tools {
namespace {

using namespace adit::map;

// Free pixels of a slice at `z` through a flat 0.1 m roadway (floor 0, 3 m high, 10 m x 4 m).
std::uint64_t freePixelsAt(const OccupancyMap& map, double z) {
  TopViewOptions o;
  o.slice_z_m = z;
  o.pixels_per_m = 20;
  TopViewInfo info;
  const std::string path = ::testing::TempDir() + "/slice_boundary_" + std::to_string(::getpid()) + ".png";
  const Status s = renderTopView(map, o, path, &info);
  std::remove(path.c_str());
  EXPECT_TRUE(s.ok()) << s.toString();
  return info.free_pixels;
}

TEST(SliceOnAVoxelBoundary, HalfAMetreOnATenCentimetreMapShowsTheRoadway) {
  SurveyNetwork net;
  net.resolution_m = 0.1;
  net.rock_shell_m = 0.2;
  net.stations["A"] = Vec3(0, 0, 0);
  net.stations["B"] = Vec3(10, 0, 0);
  net.sections["s"] = CrossSection::rectangle(4.0, 3.0);
  net.roadways.push_back({"r", {"A", "B"}, "s"});
  StatusOr<OccupancyMap> map = voxelize(net);
  ASSERT_TRUE(map.ok());
  const std::uint64_t inside = freePixelsAt(*map, 0.55);  // mid-voxel: the reference
  EXPECT_GT(inside, 10000u);                             // 10 m x 4 m at 20 px/m = 16000
  EXPECT_EQ(freePixelsAt(*map, 0.5), inside);
  EXPECT_EQ(freePixelsAt(*map, 1.5), inside);
}

}  // namespace
}  // namespace adit::tools
