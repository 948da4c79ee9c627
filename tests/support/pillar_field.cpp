// SPDX-License-Identifier: BSD-3-Clause
#include "support/pillar_field.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <deque>
#include <functional>
#include <optional>
#include <random>

#include "adit/map/rock_points.hpp"
#include "support/synthetic_roadway.hpp"

namespace adit::test {

double PillarField::filledFraction() const {
  int filled = 0, cells = 0;
  for (int r = 0; r < spec.rows; ++r)
    for (int c = spec.first_col; c < spec.last_col; ++c) {
      filled += at(r, c);
      ++cells;
    }
  return cells ? double(filled) / cells : 0.0;
}

std::unique_ptr<PillarField> makePillarField(const PillarFieldSpec& spec) {
  auto f = std::make_unique<PillarField>();
  f->spec = spec;
  const int rows = spec.rows, cols = spec.cols;
  auto idx = [cols](int r, int c) { return std::size_t(r * cols + c); };
  std::mt19937_64 rng(spec.seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::vector<char> g(std::size_t(rows * cols), 0);
  for (int r = 0; r < rows; ++r)
    for (int c = spec.first_col; c < spec.last_col; ++c) g[idx(r, c)] = u(rng) < spec.fill;
  for (int pass = 0; pass < spec.smoothing; ++pass) {
    std::vector<char> h = g;
    for (int r = 0; r < rows; ++r)
      for (int c = spec.first_col; c < spec.last_col; ++c) {
        int n = 0;
        for (int dr = -1; dr <= 1; ++dr)
          for (int dc = -1; dc <= 1; ++dc)
            if ((dr || dc) && r + dr >= 0 && r + dr < rows && g[idx(r + dr, c + dc)]) ++n;
        h[idx(r, c)] = n >= spec.fill_threshold || (g[idx(r, c)] && n > spec.clear_threshold);
      }
    g = h;
  }
  f->pillar = g;
  f->survey = straightRoadway(map::CrossSection::rectangle(rows * spec.cell_m, spec.height_m), cols * spec.cell_m,
                              spec.cell_m);
  f->map = std::make_unique<map::OccupancyMap>(voxelizeOrFail(f->survey));
  // The slab's voxels: find the floor at the roadway's middle, then the cell grid over its width.
  StatusOr<map::DistanceField> probe = map::DistanceField::build(*f->map);
  EXPECT_TRUE(probe.ok());
  if (!probe.ok()) return f;
  const std::optional<double> floor = map::floorBelow(*probe, map::Vec3(cols * spec.cell_m / 2, 0, 1.0), 3.0);
  EXPECT_TRUE(floor.has_value());
  f->floor_z = floor.value_or(0.0);
  // Cell centres on voxel centres: the first free column from the south rib.
  double y0 = 0.0;
  for (double y = 0.0; y > -4.0; y -= spec.cell_m)
    if (probe->isFree(map::Vec3(cols * spec.cell_m / 2, y, f->floor_z + 0.5))) y0 = y;
  f->origin = map::Vec3(0.5 * spec.cell_m, y0, f->floor_z);
  std::vector<map::Vec3> rock;
  for (int r = 0; r < rows; ++r)
    for (int c = 0; c < cols; ++c)
      if (f->at(r, c))
        for (double z = f->floor_z + 0.5 * spec.cell_m; z < f->floor_z + spec.height_m; z += spec.cell_m)
          rock.push_back(f->cellCentre(r, c, z));
  EXPECT_TRUE(f->map->setVoxels(rock, map::VoxelState::kOccupied).ok());
  StatusOr<map::DistanceField> field = map::DistanceField::build(*f->map);
  EXPECT_TRUE(field.ok()) << field.status().message();
  if (field.ok()) f->field = std::make_unique<map::DistanceField>(std::move(*field));
  return f;
}

namespace {

// A disc of radius + margin fits at p, at the body's height (the exact field there).
bool discFits(const PillarField& f, const map::Vec3& p, double clearance) {
  return f.field->isFree(p) && f.field->distance(p) >= clearance;
}

std::vector<std::pair<int, int>> search(const PillarField& f, double radius, double margin,
                                        const std::function<bool(int, int)>& source,
                                        const std::function<bool(int, int)>& target) {
  const int rows = f.spec.rows, cols = f.spec.cols;
  const double z = f.floor_z + std::min(1.0, 0.5 * f.spec.height_m);
  auto fits = [&](int r, int c) { return discFits(f, f.cellCentre(r, c, z), radius + margin); };
  std::vector<int> prev(std::size_t(rows * cols), -2);
  std::deque<int> open;
  for (int r = 0; r < rows; ++r)
    for (int c = 0; c < cols; ++c)
      if (source(r, c) && fits(r, c)) {
        prev[std::size_t(r * cols + c)] = -1;
        open.push_back(r * cols + c);
      }
  int end = -1;
  while (!open.empty() && end < 0) {
    const int cur = open.front();
    open.pop_front();
    const int r = cur / cols, c = cur % cols;
    if (target(r, c)) {
      end = cur;
      break;
    }
    const int dr[4] = {1, -1, 0, 0}, dc[4] = {0, 0, 1, -1};
    for (int k = 0; k < 4; ++k) {
      const int nr = r + dr[k], nc = c + dc[k];
      if (nr < 0 || nr >= rows || nc < 0 || nc >= cols) continue;
      const int n = nr * cols + nc;
      if (prev[std::size_t(n)] != -2 || !fits(nr, nc)) continue;
      prev[std::size_t(n)] = cur;
      open.push_back(n);
    }
  }
  std::vector<std::pair<int, int>> path;
  for (int c = end; c >= 0; c = prev[std::size_t(c)]) path.emplace_back(c / cols, c % cols);
  std::reverse(path.begin(), path.end());
  return path;
}

}  // namespace

std::vector<std::pair<int, int>> gridPassage(const PillarField& f, double radius, double margin, int from_col,
                                             int to_col) {
  return search(f, radius, margin, [from_col](int, int c) { return c == from_col; },
                [to_col](int, int c) { return c == to_col; });
}

std::vector<std::pair<int, int>> gridPassage(const PillarField& f, double radius, double margin,
                                             std::pair<int, int> from, std::pair<int, int> to) {
  return search(f, radius, margin, [from](int r, int c) { return r == from.first && c == from.second; },
                [to](int r, int c) { return r == to.first && c == to.second; });
}

double pulledLength(const PillarField& f, const std::vector<std::pair<int, int>>& cells, double radius, double margin) {
  if (cells.size() < 2) return 0.0;
  const double z = f.floor_z + std::min(1.0, 0.5 * f.spec.height_m);
  auto centre = [&](std::size_t i) { return f.cellCentre(cells[i].first, cells[i].second, z); };
  auto clear = [&](const map::Vec3& a, const map::Vec3& b) {
    const int n = std::max(1, int(std::ceil((b - a).norm() / (0.25 * f.spec.cell_m))));
    for (int k = 0; k <= n; ++k)
      if (!discFits(f, a + (b - a) * (double(k) / n), radius + margin)) return false;
    return true;
  };
  double length = 0.0;
  std::size_t i = 0;
  while (i + 1 < cells.size()) {
    std::size_t j = i + 1;
    for (std::size_t k = cells.size() - 1; k > i + 1; --k)
      if (clear(centre(i), centre(k))) {
        j = k;
        break;
      }
    length += (centre(j) - centre(i)).norm();
    i = j;
  }
  return length;
}

}  // namespace adit::test
