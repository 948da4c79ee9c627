// SPDX-License-Identifier: BSD-3-Clause
#include "adit/map/readers/xyz.hpp"

#include <charconv>
#include <cmath>

#include "adit/map/map_io.hpp"
#include "common.hpp"

namespace adit::map {

using namespace readers_internal;

namespace {
bool isSep(char c) { return c == ' ' || c == '\t' || c == ',' || c == ';' || c == '\r'; }
}  // namespace

StatusOr<Geometry> parseXyz(const std::string& b, const std::string& name, const ReadLimits& limits) {
  Geometry g;
  std::size_t pos = b.compare(0, 3, "\xEF\xBB\xBF") == 0 ? 3 : 0;
  std::uint64_t line = 0;
  bool header_allowed = true;
  while (pos < b.size()) {
    std::size_t end = b.find('\n', pos);
    if (end == std::string::npos) end = b.size();
    ++line;
    const char* p = b.data() + pos;
    const char* e = b.data() + end;
    pos = end + 1;
    while (p < e && isSep(*p)) ++p;
    if (p == e || *p == '#' || *p == '/') continue;
    double v[3];
    int k = 0;
    const char* q = p;
    for (; k < 3; ++k) {
      while (q < e && isSep(*q)) ++q;
      if (q == e) break;
      // from_chars does not take a leading '+'; writers of CSV sometimes emit one.
      const char* start = (*q == '+') ? q + 1 : q;
      auto [next, ec] = std::from_chars(start, e, v[k]);
      if (ec != std::errc() || (next < e && !isSep(*next))) break;
      q = next;
    }
    if (k < 3) {
      if (header_allowed && g.points.empty() && std::isalpha(static_cast<unsigned char>(*p)) &&
          std::string(p, std::size_t(std::min<std::ptrdiff_t>(3, e - p))) != "nan" &&
          std::string(p, std::size_t(std::min<std::ptrdiff_t>(3, e - p))) != "inf") {
        header_allowed = false;  // one header row, e.g. "x,y,z,intensity"
        continue;
      }
      return invalidArgument(atLine(name, line) + ": expected x y z, got '" + std::string(p, std::size_t(std::min<std::ptrdiff_t>(60, e - p))) + "'");
    }
    if (!std::isfinite(v[0]) || !std::isfinite(v[1]) || !std::isfinite(v[2]))
      return invalidArgument(atLine(name, line) + ": non-finite coordinate");
    if (g.points.size() >= limits.max_points)
      return outOfRange(atLine(name, line) + ": more than " + std::to_string(limits.max_points) + " points");
    g.points.emplace_back(v[0], v[1], v[2]);
    header_allowed = false;
  }
  if (g.points.empty()) return invalidArgument(name + ": no points (expected lines of x y z)");
  return g;
}

StatusOr<Geometry> readXyz(const std::string& path, const ReadLimits& limits) {
  ADIT_ASSIGN_OR_RETURN(std::string bytes, readFile(path));
  return parseXyz(bytes, path, limits);
}

}  // namespace adit::map
