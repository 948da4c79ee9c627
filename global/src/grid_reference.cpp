// SPDX-License-Identifier: BSD-3-Clause
#include "adit/global/grid_reference.hpp"

#include <algorithm>
#include <cmath>
#include <queue>
#include <unordered_map>
#include <vector>

namespace adit::global {

using map::Vec3;

namespace {
using Key = std::uint64_t;
constexpr std::int64_t kOffset = 1 << 20;
Key pack(std::int64_t i, std::int64_t j, std::int64_t k) {
  return (Key(i + kOffset) << 42) | (Key(j + kOffset) << 21) | Key(k + kOffset);
}
void unpack(Key key, std::int64_t* i, std::int64_t* j, std::int64_t* k) {
  *i = std::int64_t(key >> 42) - kOffset;
  *j = std::int64_t((key >> 21) & 0x1FFFFF) - kOffset;
  *k = std::int64_t(key & 0x1FFFFF) - kOffset;
}
}  // namespace

StatusOr<GridPathResult> gridOptimum(const std::function<bool(const Vec3&)>& valid, double res, const Vec3& start,
                                     const Vec3& goal, std::uint64_t max_expansions) {
  if (!(res > 0) || !map::allFinite(start) || !map::allFinite(goal))
    return invalidArgument("grid optimum: resolution must be > 0 and start/goal finite");
  auto index = [&](const Vec3& p) {
    return Eigen::Array<std::int64_t, 3, 1>(std::int64_t(std::floor(p.x() / res)), std::int64_t(std::floor(p.y() / res)),
                                            std::int64_t(std::floor(p.z() / res)));
  };
  auto centre = [&](std::int64_t i, std::int64_t j, std::int64_t k) {
    return Vec3((double(i) + 0.5) * res, (double(j) + 0.5) * res, (double(k) + 0.5) * res);
  };
  const auto si = index(start), gi = index(goal);
  if ((si.abs() >= kOffset - 2).any() || (gi.abs() >= kOffset - 2).any()) return outOfRange("grid optimum: coordinates too large");
  std::unordered_map<Key, bool> free_cache;
  auto isValid = [&](std::int64_t i, std::int64_t j, std::int64_t k) {
    const Key key = pack(i, j, k);
    auto it = free_cache.find(key);
    if (it != free_cache.end()) return it->second;
    const bool v = valid(centre(i, j, k));
    free_cache.emplace(key, v);
    return v;
  };
  if (!isValid(si[0], si[1], si[2])) return invalidArgument("grid optimum: the start's voxel is not valid");
  if (!isValid(gi[0], gi[1], gi[2])) return invalidArgument("grid optimum: the goal's voxel is not valid");

  auto h = [&](std::int64_t i, std::int64_t j, std::int64_t k) {
    // Octile distance in 3-D: admissible and consistent for 26-connected moves.
    double d[3] = {double(std::llabs(i - gi[0])), double(std::llabs(j - gi[1])), double(std::llabs(k - gi[2]))};
    std::sort(d, d + 3);
    return res * ((std::sqrt(3.0) - std::sqrt(2.0)) * d[0] + (std::sqrt(2.0) - 1.0) * d[1] + d[2]);
  };
  struct Node {
    double g;
    Key parent;
    bool closed;
  };
  std::unordered_map<Key, Node> nodes;
  using Item = std::pair<double, Key>;
  std::priority_queue<Item, std::vector<Item>, std::greater<Item>> open;
  const Key start_key = pack(si[0], si[1], si[2]), goal_key = pack(gi[0], gi[1], gi[2]);
  nodes[start_key] = {0.0, start_key, false};
  open.push({h(si[0], si[1], si[2]), start_key});
  GridPathResult out;
  while (!open.empty()) {
    const auto [f, key] = open.top();
    open.pop();
    Node& node = nodes[key];
    if (node.closed) continue;
    node.closed = true;
    if (key == goal_key) break;
    if (++out.expanded > max_expansions) return out;
    std::int64_t i, j, k;
    unpack(key, &i, &j, &k);
    const double g = node.g;
    for (int dz = -1; dz <= 1; ++dz)
      for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx) {
          if (!dx && !dy && !dz) continue;
          // No corner cutting: every voxel of the block the move spans must be valid.
          bool ok = true;
          for (int cz = 0; cz <= std::abs(dz) && ok; ++cz)
            for (int cy = 0; cy <= std::abs(dy) && ok; ++cy)
              for (int cx = 0; cx <= std::abs(dx) && ok; ++cx)
                ok = isValid(i + cx * dx, j + cy * dy, k + cz * dz);
          if (!ok) continue;
          const Key nk = pack(i + dx, j + dy, k + dz);
          const double ng = g + res * std::sqrt(double(dx * dx + dy * dy + dz * dz));
          auto it = nodes.find(nk);
          if (it != nodes.end() && (it->second.closed || it->second.g <= ng)) continue;
          nodes[nk] = {ng, key, false};
          open.push({ng + h(i + dx, j + dy, k + dz), nk});
        }
  }
  auto it = nodes.find(goal_key);
  if (it == nodes.end() || !it->second.closed) return out;
  out.found = true;
  std::vector<Vec3> rev{goal};
  for (Key key = goal_key;; key = nodes[key].parent) {
    std::int64_t i, j, k;
    unpack(key, &i, &j, &k);
    rev.push_back(centre(i, j, k));
    if (key == start_key) break;
  }
  rev.push_back(start);
  out.path.points.assign(rev.rbegin(), rev.rend());
  out.length_m = out.path.length();
  return out;
}

}  // namespace adit::global
