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
                                         double voxel_m, double max_voxels, int subdivision) {
  ADIT_RETURN_IF_ERROR(map::checkResolution(voxel_m));
  if (subdivision < 1 || subdivision > 8)
    return invalidArgument("MovingAI subdivision must be 1..8, got " + std::to_string(subdivision));
  const double res = voxel_m / subdivision;
  ADIT_RETURN_IF_ERROR(map::checkResolution(res));
  const VoxelIndex lo{std::max(lo_in[0], 0), std::max(lo_in[1], 0), std::max(lo_in[2], 0)};
  const VoxelIndex hi{std::min(hi_in[0], m.width), std::min(hi_in[1], m.height), std::min(hi_in[2], m.depth)};
  if (hi[0] <= lo[0] || hi[1] <= lo[1] || hi[2] <= lo[2]) return invalidArgument("empty MovingAI crop");
  const double count = double(hi[0] - lo[0]) * (hi[1] - lo[1]) * (hi[2] - lo[2]) * std::pow(subdivision, 3);
  if (count > max_voxels)
    return outOfRange("MovingAI crop of " + std::to_string(std::llround(count)) + " voxels is too large (limit " +
                      std::to_string(std::llround(max_voxels)) + ")");
  ADIT_RETURN_IF_ERROR(map::checkExtent({map::Vec3(lo[0], lo[1], lo[2]) * voxel_m, map::Vec3(hi[0], hi[1], hi[2]) * voxel_m}, res));
  std::vector<map::Vec3> free, occupied;
  for (int z = lo[2]; z < hi[2]; ++z)
    for (int y = lo[1]; y < hi[1]; ++y)
      for (int x = lo[0]; x < hi[0]; ++x) {
        std::vector<map::Vec3>& into = m.isBlocked(x, y, z) ? occupied : free;
        for (int c = 0; c < subdivision; ++c)
          for (int b = 0; b < subdivision; ++b)
            for (int a = 0; a < subdivision; ++a)
              into.emplace_back(x * voxel_m + (a + 0.5) * res, y * voxel_m + (b + 0.5) * res, z * voxel_m + (c + 0.5) * res);
      }
  return map::OccupancyMap::fromVoxels(res, free, occupied, map::UnknownPolicy::kRock);
}

std::pair<VoxelIndex, VoxelIndex> movingAiProblemBox(const MovingAiMap& m, const MovingAiProblem& p, int pad) {
  // A path of length <= L between the foci s and g lies in the ellipsoid |x-s| + |x-g| <= L. Its
  // extent along axis k about the midpoint is sqrt(a^2 u_k^2 + b^2 (1 - u_k^2)), a = L/2 the
  // semi-major axis, b = sqrt(a^2 - c^2) the semi-minor, c = |g-s|/2, u the unit focal axis.
  const map::Vec3 s(p.start[0], p.start[1], p.start[2]), g(p.goal[0], p.goal[1], p.goal[2]);
  const map::Vec3 mid = 0.5 * (s + g) + map::Vec3::Constant(0.5);
  const double c = 0.5 * (g - s).norm();
  const double a = std::max(0.5 * p.optimal_length, c);
  const double b2 = std::max(0.0, a * a - c * c);
  const map::Vec3 u = c > 0 ? map::Vec3((g - s) / (2 * c)) : map::Vec3(1, 0, 0);
  VoxelIndex lo{}, hi{};
  const int size[3] = {m.width, m.height, m.depth};
  for (int k = 0; k < 3; ++k) {
    const double half = std::sqrt(a * a * u[k] * u[k] + b2 * (1 - u[k] * u[k]));
    lo[std::size_t(k)] = std::clamp(int(std::floor(mid[k] - half)) - pad, 0, size[k]);
    hi[std::size_t(k)] = std::clamp(int(std::ceil(mid[k] + half)) + pad, 0, size[k]);
    // The ends themselves, whatever the optimum says.
    lo[std::size_t(k)] = std::min(lo[std::size_t(k)], std::min(p.start[std::size_t(k)], p.goal[std::size_t(k)]));
    hi[std::size_t(k)] = std::max(hi[std::size_t(k)], std::max(p.start[std::size_t(k)], p.goal[std::size_t(k)]) + 1);
  }
  return {lo, hi};
}

}  // namespace adit::global
