// SPDX-License-Identifier: BSD-3-Clause
// The roadway surface for the page: free cells on a grid a few voxels coarse, and the faces
// between a free cell and a rock cell, merged greedily into rectangles per slice (the classic
// voxel "greedy meshing"). At the voxel size itself the district's surface is about a million
// faces, too much for a browser; four voxels (0.8 m) keep the roadways' shape and the page's
// download small.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

#include "adit/console/server.hpp"

namespace adit::console {
namespace {

constexpr double kTargetFreeCells = 150000.0;
constexpr double kMaxGridCells = 64e6;

struct Grid {
  map::Vec3 origin;
  double cell = 0.0;
  long n[3] = {0, 0, 0};  // with one rock cell of padding on every side
  std::vector<std::uint8_t> free;
  std::size_t index(long i, long j, long k) const {
    return static_cast<std::size_t>((k * n[1] + j) * n[0] + i);
  }
  bool isFree(long i, long j, long k) const {
    if (i < 0 || j < 0 || k < 0 || i >= n[0] || j >= n[1] || k >= n[2]) return false;
    return free[index(i, j, k)] != 0;
  }
};

long floorDiv(long a, long b) { return a >= 0 ? a / b : -((-a + b - 1) / b); }

// A cell is free when the voxel at its centre (voxel index cell*k + k/2) is a free leaf.
Grid rasterize(const map::OccupancyMap& map, double res, long k) {
  const map::Aabb box = map.bounds();
  Grid g;
  g.cell = res * static_cast<double>(k);
  g.origin = box.min - map::Vec3::Constant(g.cell);  // the padding cell
  long voxels[3];
  for (int a = 0; a < 3; ++a) {
    voxels[a] = std::lround((box.max[a] - box.min[a]) / res);
    g.n[a] = (voxels[a] + k - 1) / k + 2;
  }
  g.free.assign(static_cast<std::size_t>(g.n[0] * g.n[1] * g.n[2]), 0);
  map.forEachLeaf([&](const map::Vec3& c, double size, map::VoxelState state) {
    if (state != map::VoxelState::kFree) return;
    long lo[3], hi[3];
    for (int a = 0; a < 3; ++a) {
      const long first = std::lround((c[a] - size / 2 - box.min[a]) / res);  // voxel index range [first, last)
      const long last = first + std::max(1L, std::lround(size / res));
      // cells i with i*k + k/2 in [first, last)
      lo[a] = std::max(0L, floorDiv(first - k / 2 + k - 1, k));
      hi[a] = std::min(g.n[a] - 3, floorDiv(last - 1 - k / 2, k));
    }
    for (long z = lo[2]; z <= hi[2]; ++z)
      for (long y = lo[1]; y <= hi[1]; ++y)
        for (long x = lo[0]; x <= hi[0]; ++x) g.free[g.index(x + 1, y + 1, z + 1)] = 1;
  });
  return g;
}

float mm(double v) { return static_cast<float>(std::round(v * 1000.0) / 1000.0); }

// Faces of cells that are free and whose neighbour in direction (axis, sign) is rock, merged
// into maximal rectangles slice by slice.
void emitFaces(const Grid& g, int axis, int sign, RoadwayMesh* mesh) {
  const int u = (axis + 1) % 3, v = (axis + 2) % 3;
  const long nu = g.n[u], nv = g.n[v];
  std::vector<std::uint8_t> mask(static_cast<std::size_t>(nu * nv));
  long c[3];
  for (long s = 0; s < g.n[axis]; ++s) {
    bool any = false;
    for (long b = 0; b < nv; ++b)
      for (long a = 0; a < nu; ++a) {
        c[axis] = s, c[u] = a, c[v] = b;
        bool face = g.isFree(c[0], c[1], c[2]);
        if (face) {
          c[axis] += sign;
          face = !g.isFree(c[0], c[1], c[2]);
        }
        mask[static_cast<std::size_t>(b * nu + a)] = face;
        any |= face;
      }
    if (!any) continue;
    // The face plane: the cell's side toward the rock.
    const double plane = g.origin[axis] + g.cell * static_cast<double>(s + (sign > 0 ? 1 : 0));
    for (long b = 0; b < nv; ++b)
      for (long a = 0; a < nu;) {
        if (!mask[static_cast<std::size_t>(b * nu + a)]) {
          ++a;
          continue;
        }
        long w = 1;
        while (a + w < nu && mask[static_cast<std::size_t>(b * nu + a + w)]) ++w;
        long h = 1;
        for (; b + h < nv; ++h) {
          bool row = true;
          for (long x = 0; x < w && row; ++x) row = mask[static_cast<std::size_t>((b + h) * nu + a + x)];
          if (!row) break;
        }
        for (long y = 0; y < h; ++y)
          std::fill_n(mask.begin() + (b + y) * nu + a, w, std::uint8_t{0});
        const auto base = static_cast<std::uint32_t>(mesh->positions.size() / 3);
        const long corners[4][2] = {{a, b}, {a + w, b}, {a + w, b + h}, {a, b + h}};
        for (const auto& corner : corners) {
          map::Vec3 p;
          p[axis] = plane;
          p[u] = g.origin[u] + g.cell * static_cast<double>(corner[0]);
          p[v] = g.origin[v] + g.cell * static_cast<double>(corner[1]);
          map::Vec3 normal = map::Vec3::Zero();
          normal[axis] = -sign;  // into the free cell
          for (int d = 0; d < 3; ++d) {
            mesh->positions.push_back(mm(p[d]));
            mesh->normals.push_back(static_cast<float>(normal[d]));
          }
        }
        // Counter-clockwise seen from the free side.
        if (sign < 0) {
          mesh->indices.insert(mesh->indices.end(), {base, base + 1, base + 2, base, base + 2, base + 3});
        } else {
          mesh->indices.insert(mesh->indices.end(), {base, base + 2, base + 1, base, base + 3, base + 2});
        }
        a += w;
      }
  }
}

}  // namespace

StatusOr<RoadwayMesh> buildRoadwayMesh(const map::OccupancyMap& map, double cell) {
  const map::MapStats& stats = map.stats();
  const double res = stats.resolution_m;
  if (map.bounds().empty()) return invalidArgument("the map has no known voxels to draw");
  if (!(cell >= 0.0) || !std::isfinite(cell)) return invalidArgument("mesh cell must be >= 0 (0: automatic)");
  long k = 1;
  if (cell > 0.0) {
    k = std::max(1L, std::lround(cell / res));
  } else {
    const double free_volume = static_cast<double>(stats.free_voxels) * stats.voxelVolume();
    while (free_volume / std::pow(res * static_cast<double>(k), 3) > kTargetFreeCells) k *= 2;
  }
  const map::Vec3 size = map.bounds().max - map.bounds().min;
  while ((size / (res * static_cast<double>(k))).array().ceil().prod() > kMaxGridCells) k *= 2;
  const Grid grid = rasterize(map, res, k);
  RoadwayMesh mesh;
  mesh.cell = grid.cell;
  for (int axis = 0; axis < 3; ++axis)
    for (int sign : {-1, 1}) emitFaces(grid, axis, sign, &mesh);
  return mesh;
}

}  // namespace adit::console
