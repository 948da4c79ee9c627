// SPDX-License-Identifier: BSD-3-Clause
// Surface voxels and free-space recovery. The working grid covers the surface's bounding box in
// 8^3 bricks allocated only where needed (the band around the surface, ray cells), indexed by a
// dense brick table, so a 300 m scan costs the band's volume, not the box's.
#include "adit/map/free_space.hpp"

#include <octomap/OcTree.h>

#include <algorithm>
#include <cmath>
#include <deque>
#include <memory>
#include <unordered_map>
#include <sstream>

#include "voxel_blocks.hpp"

namespace adit::map {

namespace {
constexpr int kMaxThinVoxels = 16;
}  // namespace

using internal::BitVoxelSet;
using internal::centreOf;
using internal::keyOf;

Status ImportParams::validate() const {
  ADIT_RETURN_IF_ERROR(checkResolution(resolution_m));
  if (!std::isfinite(max_wall_distance_m) || max_wall_distance_m <= 0)
    return invalidArgument("max wall distance must be a finite positive distance");
  if (!std::isfinite(closing_radius_m) || closing_radius_m < 0 || closing_radius_m >= max_wall_distance_m)
    return invalidArgument("closing radius must be >= 0 and below the max wall distance");
  if (!std::isfinite(hull_cell_m) || hull_cell_m < 0) return invalidArgument("hull cell must be >= 0");
  if (!std::isfinite(max_ray_m) || max_ray_m <= 0) return invalidArgument("max ray length must be > 0");
  if (thin_radius_m) {
    std::ostringstream os;
    os << *thin_radius_m;
    if (!std::isfinite(*thin_radius_m) || *thin_radius_m < 0)
      return invalidArgument("thin radius must be a finite distance >= 0 m (0: off), got " + os.str());
    // The test per voxel looks at a window of (2 r + 1)^3 voxels: keep it a local test.
    if (*thin_radius_m / resolution_m > kMaxThinVoxels + 0.5) {
      os << " m is more than " << kMaxThinVoxels << " voxels at " << resolution_m << " m resolution";
      return invalidArgument("thin radius " + os.str());
    }
  }
  if (max_wall_distance_m / resolution_m > 250)
    return invalidArgument("max wall distance must be at most 250 voxels (" + std::to_string(250 * resolution_m) +
                           " m at this resolution)");
  if (!seed && trajectory.empty() && !auto_seed)
    return invalidArgument("no source of free space: give a seed point inside a roadway (--seed x,y,z) "
                           "or the scanner trajectory (--trajectory poses.csv)");
  if (seed && !seed->allFinite()) return invalidArgument("seed is not finite");
  for (std::size_t i = 0; i < trajectory.size(); ++i)
    if (!trajectory[i].allFinite()) return invalidArgument("trajectory pose " + std::to_string(i + 1) + " is not finite");
  return {};
}

const char* freeSpaceSourceName(FreeSpaceSource s) {
  return s == FreeSpaceSource::kSeedFlood ? "seed flood fill" : "trajectory rays";
}

std::vector<VoxelKey> occupiedVoxelKeys(const std::vector<Vec3>& points, double res) {
  BitVoxelSet set;
  const double inv = 1.0 / res;
  for (const Vec3& p : points) set.set(keyOf(p.x(), inv), keyOf(p.y(), inv), keyOf(p.z(), inv));
  std::vector<VoxelKey> keys;
  keys.reserve(set.count());
  set.forEach([&](int x, int y, int z) { keys.push_back({std::uint16_t(x), std::uint16_t(y), std::uint16_t(z)}); });
  return keys;
}

StatusOr<std::vector<VoxelKey>> meshVoxelKeys(const Geometry& mesh, double res, std::uint64_t max_samples) {
  const double step = 0.45 * res, inv = 1.0 / res;
  // Estimate first: n(n+1)/2 samples per triangle with n = ceil(longest edge / step).
  double total = 0;
  for (const auto& t : mesh.triangles) {
    const Vec3 &a = mesh.points[t[0]], &b = mesh.points[t[1]], &c = mesh.points[t[2]];
    const double n = std::ceil(std::max({(b - a).norm(), (c - b).norm(), (a - c).norm()}) / step);
    total += 0.5 * (n + 1) * (n + 2);
  }
  if (!(total <= double(max_samples))) {
    std::ostringstream os;
    os << "the mesh needs about " << total << " surface samples at resolution " << res << " m (limit " << max_samples
       << "); use a coarser --resolution";
    return outOfRange(os.str());
  }
  BitVoxelSet set;
  for (const auto& t : mesh.triangles) {
    const Vec3 &a = mesh.points[t[0]], &b = mesh.points[t[1]], &c = mesh.points[t[2]];
    const int n = std::max(1, int(std::ceil(std::max({(b - a).norm(), (c - b).norm(), (a - c).norm()}) / step)));
    const Vec3 u = (b - a) / n, v = (c - a) / n;
    for (int i = 0; i <= n; ++i)
      for (int j = 0; i + j <= n; ++j) {
        const Vec3 p = a + double(i) * u + double(j) * v;
        set.set(keyOf(p.x(), inv), keyOf(p.y(), inv), keyOf(p.z(), inv));
      }
  }
  std::vector<VoxelKey> keys;
  keys.reserve(set.count());
  set.forEach([&](int x, int y, int z) { keys.push_back({std::uint16_t(x), std::uint16_t(y), std::uint16_t(z)}); });
  return keys;
}

namespace {

// kThinSeen/kThin: clearThinRock's marks; kTried: flooded by a seed that auto_seed tried and did
// not keep.
enum : std::uint8_t { kSurface = 1, kClosed = 2, kFree = 4, kEroded = 8, kThinSeen = 16, kThin = 32, kTried = 64 };
constexpr std::uint8_t kFar = 255;
constexpr int kB = 8, kBV = kB * kB * kB;

struct Brick {
  std::uint8_t dist[kBV];
  std::uint8_t flags[kBV];
};

// Cells are addressed relative to the surface's minimum key; coordinates outside [0, n) are
// outside the input's box and never part of the map.
class Grid {
 public:
  static StatusOr<Grid> create(const std::array<int, 3>& lo, const std::array<int, 3>& n, std::uint64_t budget) {
    Grid g;
    g.lo_ = lo;
    g.n_ = n;
    std::uint64_t table = 1;
    for (int i = 0; i < 3; ++i) {
      g.nb_[i] = (n[i] + kB - 1) / kB;
      table *= std::uint64_t(g.nb_[i]);
    }
    g.budget_ = budget;
    if (table * 4 > budget) {
      std::ostringstream os;
      os << "the input's box spans " << n[0] << " x " << n[1] << " x " << n[2] << " voxels; its brick table alone needs "
         << (table * 4 >> 20) << " MiB (budget " << (budget >> 20)
         << " MiB): use a coarser --resolution, crop the input, or raise --max-memory";
      return outOfRange(os.str());
    }
    g.table_.assign(table, 0);
    return g;
  }
  bool inside(int x, int y, int z) const {
    return unsigned(x) < unsigned(n_[0]) && unsigned(y) < unsigned(n_[1]) && unsigned(z) < unsigned(n_[2]);
  }
  // Brick of an inside cell, nullptr when not allocated.
  Brick* find(int x, int y, int z) {
    const std::uint32_t i = table_[index(x, y, z)];
    return i ? &bricks_[i - 1] : nullptr;
  }
  // Allocates on demand; nullptr when the budget is exhausted (sticky: over_budget()).
  Brick* get(int x, int y, int z) {
    std::uint32_t& i = table_[index(x, y, z)];
    if (!i) {
      if (bytes() + sizeof(Brick) > budget_) {
        over_ = true;
        return nullptr;
      }
      bricks_.emplace_back();
      std::fill(std::begin(bricks_.back().dist), std::end(bricks_.back().dist), kFar);
      std::fill(std::begin(bricks_.back().flags), std::end(bricks_.back().flags), std::uint8_t(0));
      coords_.push_back({x / kB, y / kB, z / kB});
      i = std::uint32_t(bricks_.size());
    }
    return &bricks_[i - 1];
  }
  static int cell(int x, int y, int z) { return (x & (kB - 1)) + kB * ((y & (kB - 1)) + kB * (z & (kB - 1))); }
  bool overBudget() const { return over_; }
  std::uint64_t bytes() const { return table_.size() * 4 + bricks_.size() * (sizeof(Brick) + 12); }
  std::size_t brickCount() const { return bricks_.size(); }
  Brick& brick(std::size_t i) { return bricks_[i]; }
  const std::array<int, 3>& brickCoord(std::size_t i) const { return coords_[i]; }
  const std::array<int, 3>& lo() const { return lo_; }
  const std::array<int, 3>& n() const { return n_; }

 private:
  std::size_t index(int x, int y, int z) const {
    return (std::size_t(x / kB) * std::size_t(nb_[1]) + std::size_t(y / kB)) * std::size_t(nb_[2]) + std::size_t(z / kB);
  }
  std::array<int, 3> lo_{}, n_{}, nb_{};
  std::uint64_t budget_ = 0;
  bool over_ = false;
  std::vector<std::uint32_t> table_;
  std::deque<Brick> bricks_;  // stable addresses while the BFS holds pointers
  std::vector<std::array<int, 3>> coords_;
};

using Cell = std::array<int, 3>;

// fn(x, y, z) for the 26 neighbours of c, which may lie outside the grid; stops when fn returns
// false and then returns false.
template <class Fn>
bool eachNeighbour(const Cell& c, Fn&& fn) {
  for (int dz = -1; dz <= 1; ++dz)
    for (int dy = -1; dy <= 1; ++dy)
      for (int dx = -1; dx <= 1; ++dx)
        if ((dx | dy | dz) && !fn(c[0] + dx, c[1] + dy, c[2] + dz)) return false;
  return true;
}

Status budgetError(const Grid& g, const char* stage) {
  std::ostringstream os;
  os << stage << ": the working grid reached its memory budget (" << (g.bytes() >> 20)
     << " MiB); use a coarser --resolution, a smaller --max-wall-distance, or raise --max-memory";
  return outOfRange(os.str());
}

// Per line of the grid along one axis, the lowest and highest surface cell (or empty).
class LineExtent {
 public:
  // Lines are `k` x `k` voxels thick: a sparse scan leaves single columns without a floor point.
  LineExtent(int axis, const std::array<int, 3>& n, int k) : axis_(axis), k_(k) {
    a_ = (axis + 1) % 3;
    b_ = (axis + 2) % 3;
    na_ = n[a_] / k + 1;
    lo_.assign(std::size_t(na_) * std::size_t(n[b_] / k + 1), INT32_MAX);
    hi_.assign(lo_.size(), INT32_MIN);
  }
  void add(const Cell& c) {
    const std::size_t i = idx(c);
    lo_[i] = std::min(lo_[i], c[axis_]);
    hi_[i] = std::max(hi_[i], c[axis_]);
  }
  bool encloses(const Cell& c) const {
    const std::size_t i = idx(c);
    return lo_[i] < c[axis_] && c[axis_] < hi_[i];
  }

 private:
  std::size_t idx(const Cell& c) const { return std::size_t(c[b_] / k_) * std::size_t(na_) + std::size_t(c[a_] / k_); }
  int axis_, k_, a_, b_, na_;
  std::vector<int> lo_, hi_;
};

// Roof above and floor below: outside a wall, beyond an open end, under a holed floor or over a
// holed roof the column holds no surface on one side. (Walls on both sides along x or y would
// be stricter, but a straight roadway scanned with open ends has none along its axis, and in
// front of a cross-cut's mouth none across it: that test would cut roadways at every junction.)
struct Hull {
  LineExtent z;
  Hull(const std::array<int, 3>& n, int k) : z(2, n, k) {}
  bool inside(const Cell& c) const { return z.encloses(c); }
};

// Trajectory poses bucketed in cubes of `cell` metres: the nearest pose to a point is searched
// ring by ring outwards, so a scan of millions of points against thousands of poses stays linear.
class PoseIndex {
 public:
  PoseIndex(const std::vector<Vec3>& poses, double cell) : poses_(poses), cell_(cell) {
    for (std::size_t i = 0; i < poses.size(); ++i) buckets_[key(cellOf(poses[i]))].push_back(i);
  }
  // Nearest pose within max_d (ties: the later pose), or nullptr.
  const Vec3* nearest(const Vec3& p, double max_d) const {
    const std::array<std::int64_t, 3> c = cellOf(p);
    const int rings = int(std::ceil(max_d / cell_)) + 1;
    const Vec3* best = nullptr;
    double bd = max_d * max_d;
    std::size_t bi = 0;
    for (int k = 0; k <= rings; ++k) {
      for (int dx = -k; dx <= k; ++dx)
        for (int dy = -k; dy <= k; ++dy)
          for (int dz = -k; dz <= k; ++dz) {
            if (std::max({std::abs(dx), std::abs(dy), std::abs(dz)}) != k) continue;
            auto it = buckets_.find(key({c[0] + dx, c[1] + dy, c[2] + dz}));
            if (it == buckets_.end()) continue;
            for (std::size_t i : it->second) {
              const double d2 = (poses_[i] - p).squaredNorm();
              if (d2 < bd || (d2 == bd && best && i > bi)) {
                bd = d2;
                best = &poses_[i];
                bi = i;
              }
            }
          }
      // Every pose in ring k + 1 is at least k cells away.
      if (best && std::sqrt(bd) <= k * cell_) break;
    }
    return best;
  }

 private:
  std::array<std::int64_t, 3> cellOf(const Vec3& p) const {
    return {std::int64_t(std::floor(p.x() / cell_)), std::int64_t(std::floor(p.y() / cell_)),
            std::int64_t(std::floor(p.z() / cell_))};
  }
  static std::uint64_t key(const std::array<std::int64_t, 3>& c) {
    return (std::uint64_t(c[0] & 0x1fffff) << 42) | (std::uint64_t(c[1] & 0x1fffff) << 21) | std::uint64_t(c[2] & 0x1fffff);
  }
  const std::vector<Vec3>& poses_;
  double cell_;
  std::unordered_map<std::uint64_t, std::vector<std::size_t>> buckets_;
};

bool isFreeCell(Grid& grid, int x, int y, int z) {
  if (!grid.inside(x, y, z)) return false;
  const Brick* b = grid.find(x, y, z);
  return b && (b->flags[Grid::cell(x, y, z)] & kFree);
}

// True when `c` lies in some cube of (k + 1)^3 cells holding no free cell: the opening of the
// rock (everything not free, the unknown beyond the walls included) by that cube keeps it.
// Free cells of the window [c - k, c + k]^3 are summed into a 3-D prefix table `sum`, so each of
// the (k + 1)^3 cubes through `c` is tested in constant time.
bool inThickRock(Grid& grid, const Cell& c, int k, std::vector<int>& sum) {
  const int w = 2 * k + 1, s = w + 1;
  sum.assign(std::size_t(s) * s * s, 0);
  auto at = [&](int x, int y, int z) -> int& { return sum[(std::size_t(z) * s + y) * s + x]; };
  for (int z = 1; z <= w; ++z)
    for (int y = 1; y <= w; ++y)
      for (int x = 1; x <= w; ++x)
        at(x, y, z) = int(isFreeCell(grid, c[0] + x - 1 - k, c[1] + y - 1 - k, c[2] + z - 1 - k)) + at(x - 1, y, z) +
                      at(x, y - 1, z) + at(x, y, z - 1) - at(x - 1, y - 1, z) - at(x - 1, y, z - 1) -
                      at(x, y - 1, z - 1) + at(x - 1, y - 1, z - 1);
  // Cube [a, a + k]^3 in window cells, a in [0, k]^3: its free count from eight corners.
  for (int az = 0; az <= k; ++az)
    for (int ay = 0; ay <= k; ++ay)
      for (int ax = 0; ax <= k; ++ax) {
        const int bx = ax + k + 1, by = ay + k + 1, bz = az + k + 1;
        const int n = at(bx, by, bz) - at(ax, by, bz) - at(bx, ay, bz) - at(bx, by, az) + at(ax, ay, bz) +
                      at(ax, by, az) + at(bx, ay, az) - at(ax, ay, az);
        if (n == 0) return true;
      }
  return false;
}

// Clears scanned rock (surface and plugs) that the opening removes and that borders free space,
// directly or through other such cells (a speckle blob's inner voxels). Decided on the free space
// as recovered, then applied, so the order of the visits does not matter. Returns the count;
// `stack_bytes`: the peak of its work list (at most one entry per cleared cell).
std::uint64_t clearThinRock(Grid& grid, int k, std::uint64_t* stack_bytes) {
  static constexpr int kFaces[6][3] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
  std::vector<int> sum;
  std::vector<Cell> stack;
  auto visit = [&](Brick& b, int i, const Cell& c) {
    b.flags[i] |= kThinSeen;
    if (inThickRock(grid, c, k, sum)) return;
    b.flags[i] |= kThin;
    stack.push_back(c);
    *stack_bytes = std::max<std::uint64_t>(*stack_bytes, stack.capacity() * sizeof(Cell));
  };
  for (std::size_t bi = 0; bi < grid.brickCount(); ++bi) {
    Brick& b = grid.brick(bi);
    const auto& bc = grid.brickCoord(bi);
    for (int i = 0; i < kBV; ++i) {
      if (!(b.flags[i] & (kSurface | kClosed)) || (b.flags[i] & kThinSeen)) continue;
      const Cell c{bc[0] * kB + (i % kB), bc[1] * kB + (i / kB) % kB, bc[2] * kB + i / (kB * kB)};
      bool borders = false;
      for (const auto& f : kFaces) borders = borders || isFreeCell(grid, c[0] + f[0], c[1] + f[1], c[2] + f[2]);
      if (borders) visit(b, i, c);
    }
  }
  while (!stack.empty()) {
    const Cell c = stack.back();
    stack.pop_back();
    for (const auto& f : kFaces) {
      const Cell m{c[0] + f[0], c[1] + f[1], c[2] + f[2]};
      Brick* mb = grid.inside(m[0], m[1], m[2]) ? grid.find(m[0], m[1], m[2]) : nullptr;
      const int mi = Grid::cell(m[0], m[1], m[2]);
      if (mb && (mb->flags[mi] & (kSurface | kClosed)) && !(mb->flags[mi] & kThinSeen)) visit(*mb, mi, m);
    }
  }
  std::uint64_t cleared = 0;
  for (std::size_t bi = 0; bi < grid.brickCount(); ++bi) {
    Brick& b = grid.brick(bi);
    for (int i = 0; i < kBV; ++i) {
      if (b.flags[i] & kThin) {
        b.flags[i] = kFree;
        ++cleared;
      }
      b.flags[i] &= std::uint8_t(~kThinSeen);
    }
  }
  return cleared;
}

// A surface cell within `reach` cells of `c` along `step` (stopping where the distance band ends).
bool surfaceAlong(Grid& grid, const Cell& c, const std::array<int, 3>& step, int reach) {
  Cell q = c;
  for (int i = 0; i < reach; ++i) {
    for (int k = 0; k < 3; ++k) q[k] += step[k];
    if (!grid.inside(q[0], q[1], q[2])) return false;
    const Brick* b = grid.find(q[0], q[1], q[2]);
    const int qi = Grid::cell(q[0], q[1], q[2]);
    if (!b || b->dist[qi] == kFar) return false;
    if (b->flags[qi] & (kSurface | kClosed)) return true;
  }
  return false;
}

// ImportParams::auto_seed: candidates in decreasing distance from the surface (in slices of at
// most 2^22 cells, so that a large scan does not hold its whole band), the first that has roof
// and floor above and below and walls on both sides along x or y. Among equally distant cells
// the one farthest from the box's sides wins (a roadway's middle, not its open scanned end),
// then grid order.
std::optional<Cell> chooseSeed(Grid& grid, const Hull& hull, int reach, const std::array<int, 3>& n) {
  auto candidate = [&](const Brick& b, int i, const Cell& c) {
    return b.dist[i] != kFar && b.dist[i] > 0 && !(b.flags[i] & (kSurface | kClosed | kTried)) && hull.inside(c);
  };
  auto cellOf = [](const std::array<int, 3>& bc, int i) {
    return Cell{bc[0] * kB + (i % kB), bc[1] * kB + (i / kB) % kB, bc[2] * kB + i / (kB * kB)};
  };
  std::vector<std::uint64_t> count(256, 0);
  for (std::size_t bi = 0; bi < grid.brickCount(); ++bi) {
    const Brick& b = grid.brick(bi);
    for (int i = 0; i < kBV; ++i)
      if (candidate(b, i, cellOf(grid.brickCoord(bi), i))) ++count[b.dist[i]];
  }
  constexpr std::uint64_t kSlice = std::uint64_t{1} << 22;
  auto margin = [&](const Cell& c) { return std::min({c[0], n[0] - 1 - c[0], c[1], n[1] - 1 - c[1]}); };
  std::vector<std::pair<int, Cell>> slice;
  for (int hi = 255; hi > 0;) {
    int lo = hi - 1;
    std::uint64_t in_slice = count[std::size_t(lo)];
    while (lo > 1 && in_slice + count[std::size_t(lo - 1)] <= kSlice) in_slice += count[std::size_t(--lo)];
    slice.clear();
    for (std::size_t bi = 0; bi < grid.brickCount(); ++bi) {
      const Brick& b = grid.brick(bi);
      for (int i = 0; i < kBV; ++i) {
        const Cell c = cellOf(grid.brickCoord(bi), i);
        if (b.dist[i] >= lo && b.dist[i] < hi && candidate(b, i, c)) slice.push_back({b.dist[i], c});
      }
    }
    std::stable_sort(slice.begin(), slice.end(), [&](const auto& x, const auto& y) {
      return x.first != y.first ? x.first > y.first : margin(x.second) > margin(y.second);
    });
    for (const auto& [d, c] : slice) {
      if (!surfaceAlong(grid, c, {0, 0, 1}, reach) || !surfaceAlong(grid, c, {0, 0, -1}, reach)) continue;
      const bool across_x = surfaceAlong(grid, c, {1, 0, 0}, reach) && surfaceAlong(grid, c, {-1, 0, 0}, reach);
      if (across_x || (surfaceAlong(grid, c, {0, 1, 0}, reach) && surfaceAlong(grid, c, {0, -1, 0}, reach))) return c;
    }
    hi = lo;
  }
  return std::nullopt;
}

std::string fmtPoint(const Vec3& p) {
  std::ostringstream os;
  os << p.x() << "," << p.y() << "," << p.z();
  return os.str();
}

}  // namespace

StatusOr<ImportResult> buildMapFromGeometry(const Geometry& geometry, const ImportParams& params,
                                            const ProgressFn& progress) {
  ADIT_RETURN_IF_ERROR(params.validate());
  auto report = [&](const char* stage, double f) { if (progress) progress(stage, f); };
  if (geometry.points.empty()) return invalidArgument("the input has no points");
  const double res = params.resolution_m, inv = 1.0 / res;
  Aabb box;
  for (const Vec3& p : geometry.points) box.extend(p);
  if (!box.min.allFinite() || !box.max.allFinite()) return invalidArgument("the input has non-finite coordinates");
  ADIT_RETURN_IF_ERROR(checkExtent(box, res));

  report("surface voxels", 0.0);
  std::vector<VoxelKey> surface;
  const std::uint64_t inputs = geometry.isMesh() ? geometry.triangles.size() : geometry.points.size();
  if (geometry.isMesh()) {
    ADIT_ASSIGN_OR_RETURN(surface, meshVoxelKeys(geometry, res));
  } else {
    surface = occupiedVoxelKeys(geometry.points, res);
  }
  report("surface voxels", 1.0);

  std::array<int, 3> lo{65535, 65535, 65535}, hi{0, 0, 0}, n{};
  for (const VoxelKey& k : surface)
    for (int i = 0; i < 3; ++i) {
      lo[i] = std::min(lo[i], int(k[i]));
      hi[i] = std::max(hi[i], int(k[i]));
    }
  for (int i = 0; i < 3; ++i) n[i] = hi[i] - lo[i] + 1;
  // The three hull tables are dense 2-D planes of the box: estimate them before allocating.
  const int hk = std::max(1, int(std::lround(params.hull_cell_m * inv)));
  const std::uint64_t plane_bytes = 8 * std::uint64_t(n[0] / hk + 1) * std::uint64_t(n[1] / hk + 1);
  if (plane_bytes > params.max_memory_bytes / 2) {
    std::ostringstream os;
    os << "the input's box spans " << n[0] << " x " << n[1] << " x " << n[2] << " voxels at " << res
       << " m; its hull table alone needs " << (plane_bytes >> 20) << " MiB (budget " << (params.max_memory_bytes >> 20)
       << " MiB): use a coarser --resolution or crop the input";
    return outOfRange(os.str());
  }
  ADIT_ASSIGN_OR_RETURN(Grid grid, Grid::create(lo, n, params.max_memory_bytes - plane_bytes));
  Hull hull(n, hk);

  // Brushfire: Chebyshev distance (26-neighbourhood layers) from the surface up to R voxels.
  const int R = std::max(1, int(std::lround(params.max_wall_distance_m * inv)));
  std::vector<Cell> layer, next;
  layer.reserve(surface.size());
  for (const VoxelKey& k : surface) {
    const Cell c{int(k[0]) - lo[0], int(k[1]) - lo[1], int(k[2]) - lo[2]};
    Brick* b = grid.get(c[0], c[1], c[2]);
    if (!b) return budgetError(grid, "surface");
    const int i = Grid::cell(c[0], c[1], c[2]);
    b->flags[i] |= kSurface;
    b->dist[i] = 0;
    hull.z.add(c);
    layer.push_back(c);
  }
  for (int d = 1; d <= R && !layer.empty(); ++d) {
    next.clear();
    for (const Cell& c : layer) {
      const bool ok = eachNeighbour(c, [&](int x, int y, int z) {
        if (!grid.inside(x, y, z)) return true;
        Brick* b = grid.get(x, y, z);
        if (!b) return false;
        std::uint8_t& dd = b->dist[Grid::cell(x, y, z)];
        if (dd == kFar) {
          dd = std::uint8_t(d);
          next.push_back({x, y, z});
        }
        return true;
      });
      if (!ok) return budgetError(grid, "distance band");
    }
    layer.swap(next);
    report("distance band", double(d) / R);
  }

  // Closing = dilation by r (dist <= r) then erosion by r: cells of the dilation within r of its
  // outside are eroded; the rest that is not surface plugs a hole.
  std::uint64_t closed = 0;
  const int r = int(std::lround(params.closing_radius_m * inv));
  if (r > 0) {
    layer.clear();
    for (std::size_t bi = 0; bi < grid.brickCount(); ++bi) {
      Brick& b = grid.brick(bi);
      const auto& bc = grid.brickCoord(bi);
      for (int i = 0; i < kBV; ++i) {
        if (b.dist[i] > r) continue;
        const Cell c{bc[0] * kB + (i % kB), bc[1] * kB + (i / kB) % kB, bc[2] * kB + i / (kB * kB)};
        // Beyond the box is unknown, not open: holes in walls that lie on the box's rim close too.
        const bool edge = !eachNeighbour(c, [&](int x, int y, int z) {
          if (!grid.inside(x, y, z)) return true;
          Brick* nb = grid.find(x, y, z);
          return nb && nb->dist[Grid::cell(x, y, z)] <= r;
        });
        if (edge) {
          b.flags[i] |= kEroded;
          layer.push_back(c);
        }
      }
    }
    for (int d = 2; d <= r && !layer.empty(); ++d) {
      next.clear();
      for (const Cell& c : layer)
        eachNeighbour(c, [&](int x, int y, int z) {
          Brick* b = grid.inside(x, y, z) ? grid.find(x, y, z) : nullptr;
          const int i = Grid::cell(x, y, z);
          if (b && b->dist[i] <= r && !(b->flags[i] & kEroded)) {
            b->flags[i] |= kEroded;
            next.push_back({x, y, z});
          }
          return true;
        });
      layer.swap(next);
    }
    for (std::size_t bi = 0; bi < grid.brickCount(); ++bi) {
      Brick& b = grid.brick(bi);
      for (int i = 0; i < kBV; ++i)
        if (b.dist[i] <= r && !(b.flags[i] & (kEroded | kSurface))) {
          b.flags[i] |= kClosed;
          ++closed;
        }
    }
    report("closing holes", 1.0);
  }

  auto toCell = [&](const Vec3& p) {
    return Cell{keyOf(p.x(), inv) - lo[0], keyOf(p.y(), inv) - lo[1], keyOf(p.z(), inv) - lo[2]};
  };
  // Free space connected to `c` (6-neighbours, inside the hull and the distance band, not rock).
  auto flood = [&](const Cell& c) -> std::uint64_t {
    grid.find(c[0], c[1], c[2])->flags[Grid::cell(c[0], c[1], c[2])] |= kFree;
    std::uint64_t count = 1;
    layer.assign(1, c);
    static constexpr int kSteps[6][3] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
    std::size_t rounds = 0;
    while (!layer.empty()) {
      next.clear();
      for (const Cell& q : layer)
        for (const auto& st : kSteps) {
          const Cell m{q[0] + st[0], q[1] + st[1], q[2] + st[2]};
          if (!grid.inside(m[0], m[1], m[2])) continue;
          Brick* mb = grid.find(m[0], m[1], m[2]);
          if (!mb) continue;
          const int mi = Grid::cell(m[0], m[1], m[2]);
          if (mb->dist[mi] == kFar || (mb->flags[mi] & (kSurface | kClosed | kFree)) || !hull.inside(m)) continue;
          mb->flags[mi] |= kFree;
          ++count;
          next.push_back(m);
        }
      layer.swap(next);
      if ((++rounds & 63) == 0) report("flood fill", 0.5);
    }
    report("flood fill", 1.0);
    return count;
  };
  std::uint64_t free_count = 0;
  FreeSpaceSource source = FreeSpaceSource::kSeedFlood;
  std::optional<Vec3> chosen_seed;
  if (!params.trajectory.empty()) {
    source = FreeSpaceSource::kTrajectoryRays;
    // Each point is seen from the nearest pose; the ray stops at the first surface or plug it
    // meets, so a point hidden behind rock from that pose clears nothing beyond the rock.
    octomap::OcTree keyer(res);
    octomap::KeyRay ray;
    const PoseIndex poses(params.trajectory, std::max(2.0, params.max_ray_m / 8));
    for (std::size_t pi = 0; pi < geometry.points.size(); ++pi) {
      const Vec3& p = geometry.points[pi];
      const Vec3* best = poses.nearest(p, params.max_ray_m);
      if (!best) continue;
      const Aabb span(best->cwiseMin(p), best->cwiseMax(p));
      if (!checkExtent(span, res).ok()) continue;
      if (!keyer.computeRayKeys(octomap::point3d(float(best->x()), float(best->y()), float(best->z())),
                                octomap::point3d(float(p.x()), float(p.y()), float(p.z())), ray))
        continue;
      for (const octomap::OcTreeKey& k : ray) {
        const int x = int(k[0]) - lo[0], y = int(k[1]) - lo[1], z = int(k[2]) - lo[2];
        if (!grid.inside(x, y, z)) continue;
        Brick* b = grid.get(x, y, z);
        if (!b) return budgetError(grid, "trajectory rays");
        std::uint8_t& f = b->flags[Grid::cell(x, y, z)];
        if (f & (kSurface | kClosed)) break;
        if (!(f & kFree)) {
          f |= kFree;
          ++free_count;
        }
      }
      if ((pi & 0xffff) == 0) report("trajectory rays", double(pi) / double(geometry.points.size()));
    }
  } else {
    Cell c{};
    if (params.seed) {
      chosen_seed = *params.seed;
      c = toCell(*params.seed);
    } else {
      // A sparse scan's hull has holes: the best-placed cell may sit in a pocket the flood cannot
      // leave. Up to kTrials seeds, each outside the earlier ones' floods, are flooded and the
      // largest flood's seed kept (its flood is redone below).
      report("choosing a seed", 0.0);
      constexpr int kTrials = 8;
      std::optional<Cell> found;
      std::uint64_t best = 0;
      for (int trial = 0; trial < kTrials; ++trial) {
        const std::optional<Cell> t = chooseSeed(grid, hull, R, n);
        if (!t) break;
        const std::uint64_t got = flood(*t);
        if (got > best) best = got, found = t;
        for (std::size_t bi = 0; bi < grid.brickCount(); ++bi)
          for (std::uint8_t& f : grid.brick(bi).flags)
            if (f & kFree) f = std::uint8_t((f & ~kFree) | kTried);
        report("choosing a seed", double(trial + 1) / kTrials);
      }
      if (!found)
        return invalidArgument("no seed found: no point has scanned surface above and below and walls on both sides "
                               "within " + std::to_string(params.max_wall_distance_m) +
                               " m: give a point inside a roadway (--seed x,y,z) or raise --max-wall-distance");
      c = *found;
      chosen_seed = Vec3(centreOf(lo[0] + c[0], res), centreOf(lo[1] + c[1], res), centreOf(lo[2] + c[2], res));
      report("choosing a seed", 1.0);
    }
    const std::string where =
        "seed " + (params.seed_name.empty() || !params.seed ? fmtPoint(*chosen_seed) : params.seed_name);
    if (!grid.inside(c[0], c[1], c[2]))
      return invalidArgument(where + " lies outside the input's bounding box [" + fmtPoint(box.min) + "] .. [" +
                             fmtPoint(box.max) + "]");
    Brick* b = grid.find(c[0], c[1], c[2]);
    const int ci = Grid::cell(c[0], c[1], c[2]);
    if (!b || b->dist[ci] == kFar)
      return invalidArgument(where + " is farther than " + std::to_string(params.max_wall_distance_m) +
                             " m from every scanned surface: put it inside a roadway or raise --max-wall-distance");
    if (b->flags[ci] & kSurface)
      return invalidArgument(where + " lies in a surface voxel (rock): move it into the open roadway");
    if (b->flags[ci] & kClosed)
      return invalidArgument(where + " lies in space the closing filled (a passage narrower than twice --close)");
    if (!hull.inside(c))
      return invalidArgument(where + " is not inside the scan's hull (no scanned roof above it or no floor below it): "
                                     "move it into a roadway");
    free_count = flood(c);
  }
  if (free_count == 0) return failedPrecondition("no free space was recovered (no ray crossed open space)");
  const int thin_k = int(std::lround(params.thin_radius_m.value_or(res) * inv));
  std::uint64_t thin = 0, thin_bytes = 0;
  if (thin_k > 0) {
    report("thin rock", 0.0);
    thin = clearThinRock(grid, thin_k, &thin_bytes);
    free_count += thin;
    report("thin rock", 1.0);
  }

  auto tree = std::make_shared<octomap::OcTree>(res);
  const float free_value = tree->getClampingThresMinLog(), rock_value = tree->getClampingThresMaxLog();
  for (std::size_t bi = 0; bi < grid.brickCount(); ++bi) {
    Brick& b = grid.brick(bi);
    const auto& bc = grid.brickCoord(bi);
    for (int i = 0; i < kBV; ++i) {
      const std::uint8_t f = b.flags[i];
      if (!(f & (kSurface | kClosed | kFree))) continue;
      const octomap::OcTreeKey key(octomap::key_type(lo[0] + bc[0] * kB + (i % kB)),
                                   octomap::key_type(lo[1] + bc[1] * kB + (i / kB) % kB),
                                   octomap::key_type(lo[2] + bc[2] * kB + i / (kB * kB)));
      tree->setNodeValue(key, (f & (kSurface | kClosed)) ? rock_value : free_value, /*lazy_eval=*/true);
    }
    if ((bi & 1023) == 0) report("building octree", double(bi) / double(grid.brickCount()));
  }
  tree->updateInnerOccupancy();
  tree->prune();
  report("building octree", 1.0);
  const std::uint64_t working = grid.bytes() + plane_bytes + thin_bytes;
  ADIT_ASSIGN_OR_RETURN(OccupancyMap map, OccupancyMap::create(std::move(tree), params.unknown_policy));
  return ImportResult{std::move(map), source, inputs, surface.size(), closed, free_count, thin, working, chosen_seed};
}

}  // namespace adit::map
