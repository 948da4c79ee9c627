// SPDX-License-Identifier: BSD-3-Clause
// The exact separable Euclidean feature transform (Felzenszwalb-Huttenlocher lower envelopes, one
// pass per axis), over all tiles (build) or over a dense box (windowed update).
#include <algorithm>
#include <cmath>
#include <limits>

#include "distance_field_impl.hpp"

namespace adit::map {
namespace {

// One line of the separable transform: candidates (position along the line, squared distance
// already accumulated over the earlier axes, site word) in increasing position; for every query
// position (increasing) the candidate minimising (q - p)^2 + f. Felzenszwalb & Huttenlocher 2012.
class LineSolver {
 public:
  void clear() { pos_.clear(); f_.clear(); site_.clear(); all_zero_ = true; }
  void add(int p, double f, std::uint64_t site) {
    pos_.push_back(p);
    f_.push_back(f);
    site_.push_back(site);
    all_zero_ = all_zero_ && f == 0.0;
  }
  bool empty() const { return pos_.empty(); }

  void prepare() {
    k_ = 0;
    // Only rock on the line (the first pass): the nearest candidate by position, no envelope.
    if (all_zero_) return;
    const std::size_t n = pos_.size();
    v_.resize(n);
    z_.resize(n + 1);
    int k = 0;
    v_[0] = 0;
    z_[0] = -std::numeric_limits<double>::infinity();
    z_[1] = std::numeric_limits<double>::infinity();
    for (std::size_t q = 1; q < n; ++q) {
      double s;
      for (;;) {
        const std::size_t r = v_[std::size_t(k)];
        s = ((f_[q] + double(pos_[q]) * pos_[q]) - (f_[r] + double(pos_[r]) * pos_[r])) /
            (2.0 * double(pos_[q] - pos_[r]));
        if (s <= z_[std::size_t(k)]) { --k; continue; }  // z_[0] = -inf ends this
        break;
      }
      ++k;
      v_[std::size_t(k)] = q;
      z_[std::size_t(k)] = s;
      z_[std::size_t(k) + 1] = std::numeric_limits<double>::infinity();
    }
    k_ = 0;
  }
  // Queries must come in increasing position after prepare().
  std::uint64_t solve(int q) {
    if (all_zero_) {
      const std::size_t n = pos_.size();
      std::size_t k = std::size_t(k_);
      while (k + 1 < n && pos_[k + 1] <= q) ++k;
      if (k + 1 < n && (pos_[k] > q || pos_[k + 1] - q < q - pos_[k])) {
        k_ = int(k);
        return site_[pos_[k] > q ? k : k + 1];
      }
      k_ = int(k);
      return site_[k];
    }
    while (z_[std::size_t(k_) + 1] < double(q)) ++k_;
    return site_[v_[std::size_t(k_)]];
  }

 private:
  std::vector<int> pos_;
  std::vector<double> f_;
  std::vector<std::uint64_t> site_;
  std::vector<std::size_t> v_;
  std::vector<double> z_;
  int k_ = 0;
  bool all_zero_ = true;
};

// Squared distance from voxel `key` to `site` (a packed key), over the axes before `axis` (the
// axes a previous pass has already resolved; the other coordinates of the site equal the voxel's).
inline double partialF(const int key[3], std::uint64_t site, int axis) {
  double f = 0;
  for (int a = 0; a < axis; ++a) {
    const double d = key[a] - keyCoord(site, a);
    f += d * d;
  }
  return f;
}

// Between the passes of transformAll() a free cell holds the site found so far, relative to
// the voxel and modulo 2^16 on each axis resolved (any key difference fits, exactly): after the
// x pass, kFreeBit | dx; after the y pass, dx | dy << 16, never 0 since the site is rock and the
// voxel free. Rock cells stay 0 throughout. Only the last pass writes the final cell format.
inline bool isFreeBetweenPasses(Cell c, int axis) { return axis < 2 ? isFreeCell(c) : c != 0; }
inline std::uint64_t siteBetweenPasses(Cell c, const int key[3], int axis) {
  const int x = axis >= 1 ? (key[0] + int(c & 0xFFFF)) & 0xFFFF : key[0];
  const int y = axis >= 2 ? (key[1] + int(c >> 16)) & 0xFFFF : key[1];
  return packKey(x, y, key[2]);
}
inline Cell cellBetweenPasses(std::uint64_t site, const int key[3], int axis) {
  const Cell dx = Cell(std::uint16_t(keyCoord(site, 0) - key[0]));
  if (axis == 0) return kFreeBit | dx;
  return dx | (Cell(std::uint16_t(keyCoord(site, 1) - key[1])) << 16);
}

// transformBox()'s dense grid: the whole site key per voxel (16 bits per axis) plus two flags.
constexpr std::uint64_t kGridFree = std::uint64_t{1} << 48;
constexpr std::uint64_t kGridSite = std::uint64_t{1} << 49;
constexpr std::uint64_t kGridKey = (std::uint64_t{1} << 48) - 1;

}  // namespace

// Full transform in place, over the allocated tiles only: along each axis, the tiles are
// grouped in lines; gaps between tiles (and the ends) are rock, of which only the two voxels
// bounding each gap can be nearest for anything outside it.
void DistanceField::Impl::transformAll(const ProgressFn& progress) {
  far.clear();
  far_unused = 0;
  far_overflow = false;
  for (Tile& t : tiles)
    for (Cell& c : t) c = isFreeCell(c) ? kFreeBit : 0;  // the first pass must see rock voxels only
  std::vector<std::array<int, 3>> tile_coords(tiles.size());
  for (std::size_t r = 0; r < regions.size(); ++r)
    for (int j = 0; j < kTilesPerBlock; ++j)
      if (const std::int32_t t = regions[r][std::size_t(j)]; t != kRockTile)
        tile_coords[std::size_t(t)] = {(block_coords[r][0] << kSubBits) + (j & kSubMask),
                                       (block_coords[r][1] << kSubBits) + ((j >> kSubBits) & kSubMask),
                                       (block_coords[r][2] << kSubBits) + (j >> (2 * kSubBits))};
  LineSolver solver;
  std::vector<std::pair<int, Cell*>> queries;
  for (int axis = 0; axis < 3; ++axis) {
    const int b1 = (axis + 1) % 3, b2 = (axis + 2) % 3;
    // Tiles sorted by (other two tile coords, own coord) form the lines.
    std::vector<std::uint32_t> order(tiles.size() - 1);
    for (std::uint32_t i = 0; i < order.size(); ++i) order[i] = i + 1;  // not the shared rock tile
    std::sort(order.begin(), order.end(), [&](std::uint32_t a, std::uint32_t b) {
      const auto& ca = tile_coords[a];
      const auto& cb = tile_coords[b];
      if (ca[b2] != cb[b2]) return ca[b2] < cb[b2];
      if (ca[b1] != cb[b1]) return ca[b1] < cb[b1];
      return ca[axis] < cb[axis];
    });
    std::size_t start = 0;
    while (start < order.size()) {
      std::size_t end = start + 1;
      while (end < order.size() && tile_coords[order[end]][b1] == tile_coords[order[start]][b1] &&
             tile_coords[order[end]][b2] == tile_coords[order[start]][b2])
        ++end;
      for (int u = 0; u < kTileSize; ++u)
        for (int v = 0; v < kTileSize; ++v) {
          int key[3];
          key[b1] = (tile_coords[order[start]][b1] << kTileBits) + u;
          key[b2] = (tile_coords[order[start]][b2] << kTileBits) + v;
          solver.clear();
          queries.clear();
          auto addRock = [&](int p) {
            // Keys 0 and 65535 are always rock (see build()), so nothing beyond them is needed.
            if (p < 0 || p > 65535) return;
            key[axis] = p;
            solver.add(p, 0.0, packKey(key[0], key[1], key[2]));
          };
          int prev_end = std::numeric_limits<int>::min();
          for (std::size_t i = start; i < end; ++i) {
            const int first = tile_coords[order[i]][axis] << kTileBits;
            if (first != prev_end + 1) {
              if (prev_end != std::numeric_limits<int>::min()) addRock(prev_end + 1);
              if (prev_end == std::numeric_limits<int>::min() || first - 1 > prev_end + 1) addRock(first - 1);
            }
            Tile& tile = tiles[order[i]];
            for (int p = first; p < first + kTileSize; ++p) {
              key[axis] = p;
              Cell& c = tile[std::size_t(localIndex(key[0], key[1], key[2]))];
              if (!isFreeBetweenPasses(c, axis)) {
                solver.add(p, 0.0, packKey(key[0], key[1], key[2]));
              } else {
                // Every line holds rock (its ends at least), so after the first pass every free
                // voxel has a site.
                if (axis > 0) {
                  const std::uint64_t site = siteBetweenPasses(c, key, axis);
                  solver.add(p, partialF(key, site, axis), site);
                }
                queries.emplace_back(p, &c);
              }
            }
            prev_end = first + kTileSize - 1;
          }
          addRock(prev_end + 1);
          if (queries.empty()) continue;
          solver.prepare();
          for (auto& [p, c] : queries) {
            key[axis] = p;
            const std::uint64_t site = solver.solve(p);
            *c = axis < 2 ? cellBetweenPasses(site, key, axis) : encodeSite(key[0], key[1], key[2], site);
          }
        }
      start = end;
    }
    if (progress) progress("distance field", double(axis + 1) / 3.0);
  }
}

// Transform over a dense copy of box `r` (outside it: no sites), writing back the free voxels
// of `write`. Returns the largest centre-to-centre distance (voxels) found in `write`, or
// infinity if some free voxel there saw no rock inside `r`.
double DistanceField::Impl::transformBox(const BoxI& r, BoxI write) {
  for (int a = 0; a < 3; ++a) {  // nothing outside the tiles to write
    write.lo[a] = std::max(write.lo[a], r.lo[a]);
    write.hi[a] = std::min(write.hi[a], r.hi[a]);
  }
  const int n[3] = {r.hi[0] - r.lo[0] + 1, r.hi[1] - r.lo[1] + 1, r.hi[2] - r.lo[2] + 1};
  std::vector<std::uint64_t> grid(static_cast<std::size_t>(n[0]) * std::size_t(n[1]) * std::size_t(n[2]));
  auto at = [&](int x, int y, int z) -> std::uint64_t& {
    return grid[(std::size_t(z - r.lo[2]) * std::size_t(n[1]) + std::size_t(y - r.lo[1])) * std::size_t(n[0]) +
                std::size_t(x - r.lo[0])];
  };
  for (int z = r.lo[2]; z <= r.hi[2]; ++z)
    for (int y = r.lo[1]; y <= r.hi[1]; ++y) {
      std::uint64_t* row = &at(r.lo[0], y, z);
      forRowRuns(r.lo[0], r.hi[0], y, z, [row, x0 = r.lo[0]](int x, const Cell* cells, int run) {
        for (int i = 0; i < run; ++i) row[x - x0 + i] = isFreeCell(cells[i]) ? kGridFree : 0;
      });
    }
  LineSolver solver;
  std::vector<std::pair<int, std::uint64_t*>> queries;
  // Only what the written voxels read is computed: their z lines (the last pass) read the y pass
  // at the written x and y only, those y lines the x pass at the written x only. So the y pass
  // runs on the lines at the written x, the z pass on those at the written x and y, and each pass
  // answers only where the next one reads. A line's envelope is built from all of its voxels, as
  // the whole-box passes build it, so the written sites are theirs bit for bit.
  for (int axis = 0; axis < 3; ++axis) {
    // Lines next to each other in memory one after the other (the outer of the two other axes
    // the one of larger stride): a z line steps a whole plane per voxel, and the next z line
    // along x reads the cache lines it brought in. Lines are independent, so the order changes
    // no site.
    const int b1 = axis == 2 ? 1 : 2, b2 = axis == 0 ? 1 : 0;
    int lo[3], hi[3];
    for (int a = 0; a < 3; ++a) {
      const bool narrowed = (axis == 1 && a == 0) || (axis == 2 && a != 2);
      lo[a] = narrowed ? write.lo[a] : r.lo[a];
      hi[a] = narrowed ? write.hi[a] : r.hi[a];
    }
    int key[3];
    for (key[b1] = lo[b1]; key[b1] <= hi[b1]; ++key[b1])
      for (key[b2] = lo[b2]; key[b2] <= hi[b2]; ++key[b2]) {
        solver.clear();
        queries.clear();
        for (int p = r.lo[axis]; p <= r.hi[axis]; ++p) {
          key[axis] = p;
          std::uint64_t& w = at(key[0], key[1], key[2]);
          if (!(w & kGridFree)) {
            solver.add(p, 0.0, packKey(key[0], key[1], key[2]));
          } else {
            if (w & kGridSite) solver.add(p, partialF(key, w & kGridKey, axis), w & kGridKey);
            if (p >= write.lo[axis] && p <= write.hi[axis]) queries.emplace_back(p, &w);
          }
        }
        if (queries.empty()) continue;
        if (solver.empty()) {
          for (auto& q : queries) *q.second = kGridFree;
          continue;
        }
        solver.prepare();
        for (auto& [p, w] : queries) *w = kGridFree | kGridSite | solver.solve(p);
      }
  }
  double worst = 0;
  for (int z = write.lo[2]; z <= write.hi[2]; ++z)
    for (int y = write.lo[1]; y <= write.hi[1]; ++y)
      for (int x = write.lo[0]; x <= write.hi[0]; ++x) {
        const std::uint64_t w = at(x, y, z);
        if (!(w & kGridFree)) continue;
        if (!(w & kGridSite)) return std::numeric_limits<double>::infinity();
        const double dx = x - keyCoord(w, 0), dy = y - keyCoord(w, 1), dz = z - keyCoord(w, 2);
        worst = std::max(worst, std::sqrt(dx * dx + dy * dy + dz * dz));
      }
  for (int z = write.lo[2]; z <= write.hi[2]; ++z)
    for (int y = write.lo[1]; y <= write.hi[1]; ++y)
      for (int x = write.lo[0]; x <= write.hi[0]; ++x) {
        const std::int32_t t = tileIndex(x, y, z);
        if (t == kRockTile) continue;
        Cell& c = tiles[std::size_t(t)][std::size_t(localIndex(x, y, z))];
        retire(c);
        const std::uint64_t w = at(x, y, z);
        c = (w & kGridFree) ? encodeSite(x, y, z, w & kGridKey) : 0;
      }
  return worst;
}

}  // namespace adit::map
