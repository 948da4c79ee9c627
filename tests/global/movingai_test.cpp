// SPDX-License-Identifier: BSD-3-Clause
// The MovingAI .3dmap/.3dscen reader: small files written here, errors with file:line, crops.
#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <fstream>

#include "adit/global/movingai.hpp"

namespace adit::global {
namespace {

std::string write(const std::string& name, const std::string& text) {
  const std::string path = (std::filesystem::temp_directory_path() / ("adit_movingai_" + name)).string();
  std::ofstream(path) << text;
  return path;
}

TEST(MovingAi, ReadsMapAndScenarios) {
  StatusOr<MovingAiMap> m = loadMovingAiMap(write("ok.3dmap", "voxel 4 3 2\n1 1 0\n3 2 1\n"));
  ASSERT_TRUE(m.ok()) << m.status().toString();
  EXPECT_EQ(m->width, 4);
  EXPECT_TRUE(m->isBlocked(1, 1, 0));
  EXPECT_TRUE(m->isBlocked(3, 2, 1));
  EXPECT_FALSE(m->isBlocked(0, 0, 0));
  EXPECT_TRUE(m->isBlocked(4, 0, 0)) << "outside the box is nothing";
  StatusOr<std::vector<MovingAiProblem>> s =
      loadMovingAiScenarios(write("ok.3dscen", "version 1\nok.3dmap\n0 0 0 3 0 0 3.0 1.0\n0 0 0 1 1 1 1.7320508 1.0\n"));
  ASSERT_TRUE(s.ok()) << s.status().toString();
  ASSERT_EQ(s->size(), 2u);
  EXPECT_EQ(s->at(1).goal, (VoxelIndex{1, 1, 1}));
  EXPECT_NEAR(s->at(1).optimal_length, 1.7320508, 1e-9);
}

TEST(MovingAi, ErrorsNameFileAndLine) {
  StatusOr<MovingAiMap> bad = loadMovingAiMap(write("bad.3dmap", "voxel 4 3 2\n1 1 0\n9 0 0\n"));
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.status().message().find("bad.3dmap:3: voxel (9 0 0) outside"), std::string::npos)
      << bad.status().message();
  EXPECT_FALSE(loadMovingAiMap(write("head.3dmap", "voxels 4 3\n")).ok());
  EXPECT_FALSE(loadMovingAiMap(write("word.3dmap", "voxel 4 3 2\n1 x 0\n")).ok());
  StatusOr<std::vector<MovingAiProblem>> s = loadMovingAiScenarios(write("bad.3dscen", "version 1\nm\n0 0 0 1 1\n"));
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.status().message().find("bad.3dscen:3:"), std::string::npos) << s.status().message();
}

TEST(MovingAi, CropIsAnOccupancyMap) {
  StatusOr<MovingAiMap> m = loadMovingAiMap(write("crop.3dmap", "voxel 8 8 8\n4 4 4\n"));
  ASSERT_TRUE(m.ok());
  StatusOr<map::OccupancyMap> crop = movingAiCrop(*m, {2, 2, 2}, {7, 7, 7});
  ASSERT_TRUE(crop.ok()) << crop.status().toString();
  EXPECT_TRUE(crop->isRock({4.5, 4.5, 4.5}));
  EXPECT_TRUE(crop->isFree({3.5, 4.5, 4.5}));
  EXPECT_TRUE(crop->isRock({1.5, 4.5, 4.5})) << "outside the crop";
  EXPECT_FALSE(movingAiCrop(*m, {5, 5, 5}, {5, 9, 9}).ok());
}

}  // namespace
}  // namespace adit::global
