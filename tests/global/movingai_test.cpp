// SPDX-License-Identifier: BSD-3-Clause
// The MovingAI .3dmap/.3dscen reader: small files written here, errors with file:line, crops.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <limits>
#include <queue>
#include <random>

#include "adit/global/global_planner.hpp"
#include "adit/global/movingai.hpp"
#include "adit/map/distance_field.hpp"

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

TEST(MovingAi, SubdivisionKeepsTheGeometry) {
  StatusOr<MovingAiMap> m = loadMovingAiMap(write("sub.3dmap", "voxel 6 6 6\n3 3 3\n"));
  ASSERT_TRUE(m.ok());
  StatusOr<map::OccupancyMap> crop = movingAiCrop(*m, {1, 1, 1}, {5, 5, 5}, 1.0, 2e7, 3);
  ASSERT_TRUE(crop.ok()) << crop.status().toString();
  EXPECT_DOUBLE_EQ(crop->resolution(), 1.0 / 3);
  EXPECT_TRUE(crop->isRock({3.1, 3.9, 3.5}));
  EXPECT_TRUE(crop->isFree({2.9, 3.5, 3.5}));
  EXPECT_TRUE(crop->isRock({0.9, 2.5, 2.5})) << "outside the crop";
  StatusOr<map::OccupancyMap> big = movingAiCrop(*m, {0, 0, 0}, {6, 6, 6}, 1.0, 1000, 3);
  ASSERT_FALSE(big.ok());
  EXPECT_NE(big.status().message().find("5832 voxels is too large"), std::string::npos) << big.status().message();
  EXPECT_FALSE(movingAiCrop(*m, {0, 0, 0}, {6, 6, 6}, 1.0, 2e7, 0).ok());
}

TEST(MovingAi, ProblemBoxHoldsEveryPathNoLongerThanTheOptimum) {
  MovingAiMap m;
  m.width = m.height = m.depth = 200;
  MovingAiProblem p;
  p.start = {50, 60, 70};
  p.goal = {90, 60, 70};
  p.optimal_length = 50;
  const auto [lo, hi] = movingAiProblemBox(m, p, 0);
  // Semi-axes 25 (along x) and 15: the box is 50 x 30 x 30 round the midpoint's centre (70.5, 60.5, 70.5).
  EXPECT_EQ(lo, (VoxelIndex{45, 45, 55}));
  EXPECT_EQ(hi, (VoxelIndex{96, 76, 86}));
  // Every point with |x-s| + |x-g| <= L falls inside, sampled.
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(0, 200);
  const map::Vec3 s(50.5, 60.5, 70.5), g(90.5, 60.5, 70.5);
  for (int i = 0; i < 200000; ++i) {
    const map::Vec3 x(u(rng), u(rng), u(rng));
    if ((x - s).norm() + (x - g).norm() > p.optimal_length) continue;
    for (int k = 0; k < 3; ++k) {
      EXPECT_GE(x[k], lo[std::size_t(k)]);
      EXPECT_LE(x[k], hi[std::size_t(k)]);
    }
  }
  const auto [clo, chi] = movingAiProblemBox(m, {{0, 0, 0}, {3, 0, 0}, 3.0}, 2);
  EXPECT_EQ(clo, (VoxelIndex{0, 0, 0})) << "clipped to the map";
  EXPECT_EQ(chi[0], 6);
}

// The benchmark's own movement model, independently: 26-connected moves between free voxel
// centres costing 1, sqrt 2, sqrt 3, a diagonal move only when every voxel of the block it spans is
// free (Brewer & Sturtevant's optima follow it). Dijkstra; infinity when unreachable.
double movingAiOptimum(const MovingAiMap& m, const VoxelIndex& s, const VoxelIndex& g) {
  const int w = m.width, h = m.height, d = m.depth;
  auto id = [&](int x, int y, int z) { return std::size_t(x + w * (y + h * z)); };
  std::vector<double> dist(std::size_t(w) * h * d, std::numeric_limits<double>::infinity());
  using Item = std::pair<double, std::size_t>;
  std::priority_queue<Item, std::vector<Item>, std::greater<>> open;
  dist[id(s[0], s[1], s[2])] = 0;
  open.push({0.0, id(s[0], s[1], s[2])});
  while (!open.empty()) {
    const auto [c, i] = open.top();
    open.pop();
    if (c > dist[i]) continue;
    const int x = int(i % std::size_t(w)), y = int(i / std::size_t(w) % std::size_t(h)), z = int(i / std::size_t(w * h));
    if (x == g[0] && y == g[1] && z == g[2]) return c;
    for (int dz = -1; dz <= 1; ++dz)
      for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx) {
          if (!dx && !dy && !dz) continue;
          bool ok = true;
          for (int cz = std::min(0, dz); cz <= std::max(0, dz) && ok; ++cz)
            for (int cy = std::min(0, dy); cy <= std::max(0, dy) && ok; ++cy)
              for (int cx = std::min(0, dx); cx <= std::max(0, dx) && ok; ++cx) ok = !m.isBlocked(x + cx, y + cy, z + cz);
          if (!ok) continue;
          const std::size_t j = id(x + dx, y + dy, z + dz);
          const double nc = c + std::sqrt(double(dx * dx + dy * dy + dz * dz));
          if (nc < dist[j]) {
            dist[j] = nc;
            open.push({nc, j});
          }
        }
  }
  return std::numeric_limits<double>::infinity();
}

// Distance from a point to the nearest blocked benchmark voxel (unit cubes; outside the map is
// blocked), by brute force over the voxels within reach.
double clearanceToBlocked(const MovingAiMap& m, const map::Vec3& p) {
  double best = 2.0;
  for (int z = int(std::floor(p.z())) - 2; z <= int(std::floor(p.z())) + 2; ++z)
    for (int y = int(std::floor(p.y())) - 2; y <= int(std::floor(p.y())) + 2; ++y)
      for (int x = int(std::floor(p.x())) - 2; x <= int(std::floor(p.x())) + 2; ++x) {
        if (!m.isBlocked(x, y, z)) continue;
        const map::Vec3 lo(x, y, z);
        const map::Vec3 q = p.cwiseMax(lo).cwiseMin(lo + map::Vec3::Ones());
        best = std::min(best, (p - q).norm());
      }
  return best;
}

// Random small voxel worlds (25 % blocked, with walls) and endpoints on free voxels, many of them
// beside blocked ones: with two map voxels per benchmark voxel the planner accepts every free
// endpoint, finds a path exactly when the benchmark's model does, and the path keeps the point
// agent's sphere off every blocked voxel by an independent brute-force check.
TEST(MovingAi, PointAgentOnSubdividedCropsAgreesWithTheBenchmarksModel) {
  std::mt19937 rng(2026);
  int reachable = 0, unreachable = 0, beside_blocked = 0;
  for (int world = 0; world < 12; ++world) {
    std::string text = "voxel 10 10 4\n";
    std::bernoulli_distribution blocked(0.25);
    std::vector<VoxelIndex> cells;
    for (int z = 0; z < 4; ++z)
      for (int y = 0; y < 10; ++y)
        for (int x = 0; x < 10; ++x) {
          // Every third world has a wall across x = 5 with one gap, so some problems are
          // unreachable and some squeeze through a single voxel.
          const bool wall = world % 3 == 0 && x == 5 && !(y == 4 && z == 1 && world % 2 == 0);
          if (wall || blocked(rng))
            text += std::to_string(x) + " " + std::to_string(y) + " " + std::to_string(z) + "\n";
        }
    StatusOr<MovingAiMap> m = loadMovingAiMap(write("oracle" + std::to_string(world) + ".3dmap", text));
    ASSERT_TRUE(m.ok()) << m.status().toString();
    for (int z = 0; z < 4; ++z)
      for (int y = 0; y < 10; ++y)
        for (int x = 0; x < 10; ++x)
          if (!m->isBlocked(x, y, z)) cells.push_back({x, y, z});
    StatusOr<map::OccupancyMap> crop = movingAiCrop(*m, {0, 0, 0}, {10, 10, 4}, 1.0, 2e7, 3);
    ASSERT_TRUE(crop.ok()) << crop.status().toString();
    StatusOr<map::DistanceField> field = map::DistanceField::build(*crop);
    ASSERT_TRUE(field.ok());
    GlobalPlannerParams params;
    params.robot = map::RobotShape::sphere(0.05);
    params.safety_margin_m = 0.0;
    params.time_budget_s = 0.5;  // the default planner (BIT*), a quarter of the default budget
    params.skeleton_cell_m = 2.0;
    StatusOr<GlobalPlanner> planner = GlobalPlanner::create(*crop, *field, params);
    ASSERT_TRUE(planner.ok()) << planner.status().toString();
    std::uniform_int_distribution<std::size_t> pick(0, cells.size() - 1);
    for (int k = 0; k < 4; ++k) {
      const VoxelIndex s = cells[pick(rng)], g = cells[pick(rng)];
      if (s == g) continue;
      auto centre = [](const VoxelIndex& v) { return map::Vec3(v[0] + 0.5, v[1] + 0.5, v[2] + 0.5); };
      for (const VoxelIndex& e : {s, g}) {
        EXPECT_TRUE(planner->stateValid(centre(e))) << "free voxel " << e[0] << " " << e[1] << " " << e[2];
        if (clearanceToBlocked(*m, centre(e)) < 0.51) ++beside_blocked;
      }
      const double optimum = movingAiOptimum(*m, s, g);
      const GlobalPlanResult r = planner->plan(centre(s), centre(g));
      SCOPED_TRACE("world " + std::to_string(world) + " problem " + std::to_string(k) + ": " + r.message);
      if (!std::isfinite(optimum)) {
        ++unreachable;
        EXPECT_FALSE(r.solved()) << "the benchmark's model finds no path";
        continue;
      }
      ++reachable;
      ASSERT_TRUE(r.solved());
      EXPECT_LE(r.length_m, optimum * 1.05 + 1e-9) << "any-angle, so no longer than the 26-connected optimum (+5 %)";
      for (std::size_t i = 0; i + 1 < r.path.size(); ++i)
        for (int t = 0; t <= 40; ++t) {
          const map::Vec3 p = r.path.points[i] + (r.path.points[i + 1] - r.path.points[i]) * (t / 40.0);
          ASSERT_GE(clearanceToBlocked(*m, p), 0.05 - 1e-6) << "path point " << p.transpose();
        }
    }
  }
  EXPECT_GE(reachable, 20);
  EXPECT_GE(unreachable, 2);
  EXPECT_GE(beside_blocked, 20);
}

}  // namespace
}  // namespace adit::global
