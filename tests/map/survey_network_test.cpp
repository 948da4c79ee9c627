// SPDX-License-Identifier: BSD-3-Clause
#include "adit/map/survey_network.hpp"

#include <gtest/gtest.h>

#include <cmath>

#include "adit/map/distance_field.hpp"
#include "support/survey_example.hpp"
#include "support/synthetic_roadway.hpp"

namespace adit::map {
namespace {

const std::string kExample = test::kIssueSurveyExample;

TEST(SurveyNetwork, ParsesTheIssueExampleAsWritten) {
  StatusOr<SurveyNetwork> net = parseSurvey(kExample, "example.yaml");
  ASSERT_TRUE(net.ok()) << net.status().toString();
  EXPECT_DOUBLE_EQ(net->resolution_m, 0.2);
  EXPECT_EQ(net->stations.size(), 3u);
  EXPECT_EQ(net->sections.size(), 4u);
  ASSERT_EQ(net->roadways.size(), 2u);
  EXPECT_EQ(net->roadways[1].name, "crosscut-1");
  EXPECT_NEAR(net->totalLength(), std::hypot(300.0, 3.0) + std::hypot(80.0, 1.0), 1e-9);
  EXPECT_EQ(net->sections.at("haul").shape(), SectionShape::kThreeCentredArch);
}

struct Bad {
  const char* what;
  std::string yaml;
  const char* expect;  // substring of the message: file:line and field
};

std::string replace(std::string s, const std::string& from, const std::string& to) {
  const auto at = s.find(from);
  EXPECT_NE(at, std::string::npos) << from;
  return s.replace(at, from.size(), to);
}

TEST(SurveyNetwork, MalformedFilesNameFileLineAndField) {
  const std::string ex = kExample;
  const std::vector<Bad> cases = {
      {"unknown station", replace(ex, "[S2, S3]", "[S2, S9]"), "bad.yaml:13:39: roadways[1].stations[1]"},
      {"unknown section", replace(ex, "section: gate}", "section: gaet}"), "unknown section 'gaet'"},
      {"negative width", replace(ex, "width: 4.5", "width: -4.5"), "bad.yaml:8:35: sections.gate.width"},
      {"NaN coordinate", replace(ex, "[300, 0, 3]", "[300, .nan, 3]"), "stations.S2[1]"},
      {"duplicate station", replace(ex, "  S3: [300, 80, 4]", "  S3: [300, 80, 4]\n  S3: [1, 2, 3]"), "duplicate key 'S3'"},
      {"duplicate roadway", replace(ex, "name: crosscut-1", "name: main"), "duplicate roadway name"},
      {"YAML syntax", replace(ex, "S1: [0, 0, 0]", "S1: [0, 0, 0"), "YAML error"},
      {"typo in a field", replace(ex, "wall_height: 3.0}", "wall_heigth: 3.0}"), "unknown field 'wall_heigth'"},
      {"missing resolution", replace(ex, "resolution: 0.2", "name: x"), "resolution"},
      {"zero resolution", replace(ex, "resolution: 0.2", "resolution: 0"), "resolution"},
      {"text number", replace(ex, "height: 3.5", "height: tall"), "sections.gate.height"},
      {"shaft", replace(ex, "S3: [300, 80, 4]", "S3: [300, 0, 40]"), "vertically aligned"},
      {"too far for 16-bit keys", replace(ex, "S3: [300, 80, 4]", "S3: [300, 8000, 4]"), "16-bit keys"},
      {"one station", replace(ex, "[S1, S2]", "[S1]"), "at least two"},
      {"empty", "", "empty file"},
      {"not a mapping", "- 1\n- 2\n", "expected a mapping"},
      {"bad shape", replace(ex, "shape: trapezoid", "shape: hexagon"), "unknown shape 'hexagon'"},
  };
  for (const Bad& b : cases) {
    StatusOr<SurveyNetwork> net = parseSurvey(b.yaml, "bad.yaml");
    ASSERT_FALSE(net.ok()) << b.what;
    EXPECT_EQ(net.status().code(), net.status().code() == StatusCode::kOutOfRange ? StatusCode::kOutOfRange
                                                                                : StatusCode::kInvalidArgument);
    EXPECT_NE(net.status().message().find(b.expect), std::string::npos)
        << b.what << ": " << net.status().message();
    EXPECT_EQ(net.status().message().rfind("bad.yaml", 0), 0u) << b.what << ": " << net.status().message();
  }
}

// Every section shape: free at the centre with the expected clearance, rock 0.5 m past the wall.
class SectionShapes : public ::testing::TestWithParam<int> {};

CrossSection shapeFor(int i) {
  switch (i) {
    case 0: return CrossSection::arch(5.0, 3.0);
    case 1: return CrossSection::rectangle(4.5, 3.5);
    case 2: return CrossSection::trapezoid(4.0, 3.2, 3.0);
    default: return CrossSection::threeCentredArch(5.5, 2.8, 1.8);
  }
}

TEST_P(SectionShapes, CentreFreeWithClearanceAndRockBeyondTheWall) {
  const CrossSection s = shapeFor(GetParam());
  const double res = 0.1;
  const OccupancyMap map = test::voxelizeOrFail(test::straightRoadway(s, 8.0, res, 0.4));
  StatusOr<DistanceField> df = DistanceField::build(map);
  ASSERT_TRUE(df.ok());
  const double x = 4.0, floor_z = 0.2;  // floor rises 0.4 m over 8 m
  // Expected clearance at mid-height on the centreline: the nearest of walls, floor and roof.
  const double v = 0.5 * s.height();
  double expected = std::min(v, s.height() - v);
  for (double dv = -v; dv <= s.height() - v; dv += 0.001)
    expected = std::min(expected, std::hypot(s.halfWidthAt(v + dv) > 0 ? s.halfWidthAt(v + dv) : 0.0, dv));
  const Vec3 centre(x, 0.0, floor_z + v);
  EXPECT_TRUE(map.isFree(centre));
  // Voxel centres decide membership, so walls move by up to one voxel.
  EXPECT_NEAR(df->distance(centre), expected, 1.0 * res) << sectionShapeName(s.shape());
  for (double vv : {0.3, 0.5 * s.height(), 0.9 * s.height()}) {
    const double hw = s.halfWidthAt(vv);
    EXPECT_TRUE(map.isFree({x, 0.8 * hw, floor_z + vv})) << vv;
    EXPECT_FALSE(map.isFree({x, hw + 0.5, floor_z + vv})) << vv;
    EXPECT_FALSE(map.isFree({x, -hw - 0.5, floor_z + vv})) << vv;
  }
  EXPECT_FALSE(map.isFree({x, 0.0, floor_z - 0.5}));
  EXPECT_FALSE(map.isFree({x, 0.0, floor_z + s.height() + 0.5}));
  // Rock right behind the wall is written as occupied (the shell); far rock is unknown = rock.
  EXPECT_EQ(map.state({x, s.halfWidthAt(0.3) + 0.3, floor_z + 0.3}), VoxelState::kOccupied);
  EXPECT_EQ(map.state({x, 20.0, floor_z}), VoxelState::kUnknown);
  EXPECT_EQ(map.withUnknownPolicy(UnknownPolicy::kRock).isFree({x, 20.0, floor_z}), false);
}

INSTANTIATE_TEST_SUITE_P(AllShapes, SectionShapes, ::testing::Range(0, 4));

TEST(Voxelize, JunctionsAndBendsAreOpen) {
  const OccupancyMap map = test::voxelizeOrFail(test::junctionNetwork(0.2));
  // Walk each roadway's centreline at 1 m height: every point free, so junctions connect.
  const SurveyNetwork net = test::junctionNetwork(0.2);
  for (const SurveyRoadway& r : net.roadways) {
    const Polyline line = net.centreline(r);
    for (std::size_t i = 1; i < line.size(); ++i)
      for (double t = 0; t <= 1.0; t += 0.02) {
        const Vec3 p = line.points[i - 1] + t * (line.points[i] - line.points[i - 1]) + Vec3(0, 0, 1.0);
        EXPECT_TRUE(map.isFree(p)) << r.name << " " << p.transpose();
      }
  }
  // The outside corner of the L at B is filled by the revolved section.
  EXPECT_TRUE(map.isFree({14.8, 0.8, 1.3}));
}

TEST(Voxelize, RefusesHugeNetworksBeforeAllocating) {
  SurveyNetwork net = test::straightRoadway(CrossSection::rectangle(4, 3), 3000.0, 0.1);
  VoxelizeOptions o;
  o.max_voxels = 1e6;
  StatusOr<OccupancyMap> map = voxelize(net, o);
  ASSERT_FALSE(map.ok());
  EXPECT_NE(map.status().message().find("coarser resolution"), std::string::npos);
}

}  // namespace
}  // namespace adit::map
