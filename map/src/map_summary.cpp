// SPDX-License-Identifier: BSD-3-Clause
#include "adit/map/map_summary.hpp"

#include <algorithm>
#include <cmath>
#include <vector>

namespace adit::map {

StatusOr<RoadwayLengthEstimate> estimateRoadwayLength(const OccupancyMap& map, double max_cells) {
  RoadwayLengthEstimate out;
  const Aabb b = map.bounds();
  if (b.empty()) return out;
  const double res = map.resolution();
  const int nx = int(std::lround(b.size().x() / res)), ny = int(std::lround(b.size().y() / res));
  if (double(nx) * double(ny) > max_cells)
    return outOfRange("roadway length estimate: top view of " + std::to_string(nx) + " x " + std::to_string(ny) +
                      " cells is too large");
  std::vector<std::uint8_t> foot(std::size_t(nx) * std::size_t(ny), 0);
  map.forEachLeaf([&](const Vec3& c, double size, VoxelState s) {
    if (s != VoxelState::kFree) return;
    const int x0 = int(std::lround((c.x() - 0.5 * size - b.min.x()) / res));
    const int y0 = int(std::lround((c.y() - 0.5 * size - b.min.y()) / res));
    const int n = int(std::lround(size / res));
    for (int y = std::max(0, y0); y < std::min(ny, y0 + n); ++y)
      for (int x = std::max(0, x0); x < std::min(nx, x0 + n); ++x) foot[std::size_t(y) * std::size_t(nx) + std::size_t(x)] = 1;
  });
  // Shortest run through each cell, over four directions; a run's length is cells x step.
  std::vector<float> width(foot.size(), std::numeric_limits<float>::infinity());
  const int dirs[4][2] = {{1, 0}, {0, 1}, {1, 1}, {1, -1}};
  std::vector<std::size_t> run;
  for (const auto& d : dirs) {
    const double step = res * std::hypot(d[0], d[1]);
    // Start cells: those whose predecessor is outside the grid.
    for (int sy = 0; sy < ny; ++sy)
      for (int sx = 0; sx < nx; ++sx) {
        const int px = sx - d[0], py = sy - d[1];
        if (px >= 0 && px < nx && py >= 0 && py < ny) continue;
        run.clear();
        for (int x = sx, y = sy;; x += d[0], y += d[1]) {
          const bool inside = x >= 0 && x < nx && y >= 0 && y < ny;
          const std::size_t i = inside ? std::size_t(y) * std::size_t(nx) + std::size_t(x) : 0;
          if (inside && foot[i]) { run.push_back(i); continue; }
          const float len = float(double(run.size()) * step);
          for (std::size_t k : run) width[k] = std::min(width[k], len);
          run.clear();
          if (!inside) break;
        }
      }
  }
  std::vector<float> widths;
  double length = 0.0;
  for (std::size_t i = 0; i < foot.size(); ++i) {
    if (!foot[i]) continue;
    widths.push_back(width[i]);
    length += res * res / double(width[i]);
  }
  out.footprint_area_m2 = double(widths.size()) * res * res;
  out.length_m = length;
  if (!widths.empty()) {
    std::nth_element(widths.begin(), widths.begin() + std::ptrdiff_t(widths.size() / 2), widths.end());
    out.median_width_m = widths[widths.size() / 2];
  }
  return out;
}

}  // namespace adit::map
