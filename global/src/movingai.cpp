// SPDX-License-Identifier: BSD-3-Clause
#include "adit/global/movingai.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "adit/map/file_io.hpp"

namespace adit::global {

bool MovingAiMap::isBlocked(int x, int y, int z) const {
  if (x < 0 || y < 0 || z < 0 || x >= width || y >= height || z >= depth) return true;
  const std::uint64_t i = std::uint64_t(x) + std::uint64_t(width) * (std::uint64_t(y) + std::uint64_t(height) * z);
  return (blocked[i >> 6] >> (i & 63)) & 1u;
}

namespace {
// Lines of a text file with their numbers, comments and blanks skipped.
template <class Fn>
Status forEachLine(const std::string& path, Fn&& fn) {
  ADIT_ASSIGN_OR_RETURN(const std::string text, map::readFile(path, std::size_t{1} << 30));
  std::istringstream in(text);
  std::string line;
  int lineno = 0;
  while (std::getline(in, line)) {
    ++lineno;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line.find_first_not_of(" \t") == std::string::npos) continue;
    ADIT_RETURN_IF_ERROR(fn(line, lineno));
  }
  return {};
}
Status lineError(const std::string& path, int lineno, const std::string& what) {
  return invalidArgument(path + ":" + std::to_string(lineno) + ": " + what);
}
}  // namespace

StatusOr<MovingAiMap> loadMovingAiMap(const std::string& path) {
  MovingAiMap m;
  bool header = false;
  Status s = forEachLine(path, [&](const std::string& line, int lineno) -> Status {
    std::istringstream is(line);
    if (!header) {
      std::string word;
      if (!(is >> word >> m.width >> m.height >> m.depth) || word != "voxel" || m.width <= 0 || m.height <= 0 ||
          m.depth <= 0)
        return lineError(path, lineno, "expected 'voxel W H D' with positive sizes, got '" + line + "'");
      if (double(m.width) * m.height * m.depth > 4e9) return lineError(path, lineno, "map too large");
      m.blocked.assign((std::uint64_t(m.width) * m.height * m.depth + 63) / 64, 0);
      header = true;
      return {};
    }
    int x, y, z;
    std::string extra;
    if (!(is >> x >> y >> z) || (is >> extra)) return lineError(path, lineno, "expected 'x y z', got '" + line + "'");
    if (x < 0 || y < 0 || z < 0 || x >= m.width || y >= m.height || z >= m.depth)
      return lineError(path, lineno, "voxel (" + line + ") outside the " + std::to_string(m.width) + " x " +
                                         std::to_string(m.height) + " x " + std::to_string(m.depth) + " box");
    const std::uint64_t i = std::uint64_t(x) + std::uint64_t(m.width) * (std::uint64_t(y) + std::uint64_t(m.height) * z);
    m.blocked[i >> 6] |= std::uint64_t{1} << (i & 63);
    return {};
  });
  if (!s.ok()) return s;
  if (!header) return invalidArgument(path + ": empty file (expected 'voxel W H D')");
  return m;
}

StatusOr<std::vector<MovingAiProblem>> loadMovingAiScenarios(const std::string& path) {
  std::vector<MovingAiProblem> out;
  int seen = 0;
  Status s = forEachLine(path, [&](const std::string& line, int lineno) -> Status {
    if (++seen <= 2) {
      if (seen == 1 && line.rfind("version", 0) != 0) return lineError(path, lineno, "expected 'version 1'");
      return {};  // version line, then the map's name
    }
    std::istringstream is(line);
    MovingAiProblem p;
    double ratio = 0;
    if (!(is >> p.start[0] >> p.start[1] >> p.start[2] >> p.goal[0] >> p.goal[1] >> p.goal[2] >> p.optimal_length >>
          ratio) ||
        !std::isfinite(p.optimal_length) || p.optimal_length < 0)
      return lineError(path, lineno, "expected 'sx sy sz gx gy gz optimal ratio', got '" + line + "'");
    out.push_back(p);
    return {};
  });
  if (!s.ok()) return s;
  return out;
}

StatusOr<map::OccupancyMap> movingAiCrop(const MovingAiMap& m, const VoxelIndex& lo_in, const VoxelIndex& hi_in,
                                         double voxel_m, double max_voxels) {
  ADIT_RETURN_IF_ERROR(map::checkResolution(voxel_m));
  const VoxelIndex lo{std::max(lo_in[0], 0), std::max(lo_in[1], 0), std::max(lo_in[2], 0)};
  const VoxelIndex hi{std::min(hi_in[0], m.width), std::min(hi_in[1], m.height), std::min(hi_in[2], m.depth)};
  if (hi[0] <= lo[0] || hi[1] <= lo[1] || hi[2] <= lo[2]) return invalidArgument("empty MovingAI crop");
  const double count = double(hi[0] - lo[0]) * (hi[1] - lo[1]) * (hi[2] - lo[2]);
  if (count > max_voxels) return outOfRange("MovingAI crop of " + std::to_string(count) + " voxels is too large");
  ADIT_RETURN_IF_ERROR(map::checkExtent({map::Vec3(lo[0], lo[1], lo[2]) * voxel_m, map::Vec3(hi[0], hi[1], hi[2]) * voxel_m}, voxel_m));
  std::vector<map::Vec3> free, occupied;
  for (int z = lo[2]; z < hi[2]; ++z)
    for (int y = lo[1]; y < hi[1]; ++y)
      for (int x = lo[0]; x < hi[0]; ++x)
        (m.isBlocked(x, y, z) ? occupied : free).emplace_back((x + 0.5) * voxel_m, (y + 0.5) * voxel_m, (z + 0.5) * voxel_m);
  return map::OccupancyMap::fromVoxels(voxel_m, free, occupied, map::UnknownPolicy::kRock);
}

}  // namespace adit::global
