// SPDX-License-Identifier: BSD-3-Clause
#include "adit/map/readers/pcd.hpp"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <sstream>

#include "adit/map/map_io.hpp"
#include "common.hpp"

namespace adit::map {

using namespace readers_internal;

namespace {

struct PcdHeader {
  std::vector<std::string> fields;
  std::vector<std::uint64_t> size, count;
  std::vector<char> type;
  std::uint64_t width = 0, height = 1, points = 0, point_size = 0;
  std::vector<double> viewpoint;
  std::string data;
  std::size_t data_offset = 0;
  std::uint64_t data_line = 0;  // first data line (1-based), ascii
  std::uint64_t points_line = 0;
};

StatusOr<std::uint64_t> parseCount(const std::string& tok, const std::string& where) {
  if (tok.empty() || tok.size() > 19 || tok.find_first_not_of("0123456789") != std::string::npos)
    return invalidArgument(where + ": '" + tok + "' is not a non-negative integer");
  return std::stoull(tok);
}

StatusOr<PcdHeader> parseHeader(const std::string& b, const std::string& name, const ReadLimits& limits) {
  PcdHeader h;
  std::size_t pos = 0;
  std::uint64_t line = 0;
  bool have_points = false, have_width = false;
  while (true) {
    if (pos >= b.size() || pos > (1u << 20))
      return invalidArgument(name + ": not a PCD file (no DATA line in the header)");
    std::size_t end = b.find('\n', pos);
    if (end == std::string::npos) end = b.size();
    std::string l = b.substr(pos, end - pos);
    ++line;
    pos = end + 1;
    if (!l.empty() && l.back() == '\r') l.pop_back();
    const std::string where = atLine(name, line);
    if (l.empty() || l[0] == '#') continue;
    std::istringstream is(l);
    std::string key, tok;
    is >> key;
    std::vector<std::string> v;
    while (is >> tok) v.push_back(tok);
    if (line == 1 && key != "VERSION" && key != "FIELDS")
      return invalidArgument(where + ": not a PCD file (expected a VERSION or FIELDS line, got '" + key + "')");
    if (key == "VERSION") continue;
    if (key == "FIELDS" || key == "COLUMNS") {
      h.fields = v;
    } else if (key == "SIZE" || key == "COUNT") {
      auto& dst = key == "SIZE" ? h.size : h.count;
      dst.clear();
      for (const auto& t : v) {
        ADIT_ASSIGN_OR_RETURN(std::uint64_t x, parseCount(t, where + ": " + key));
        if (x == 0 || x > 1024) return invalidArgument(where + ": " + key + " " + t + " is out of range (1..1024)");
        dst.push_back(x);
      }
    } else if (key == "TYPE") {
      h.type.clear();
      for (const auto& t : v) {
        if (t.size() != 1 || (t[0] != 'F' && t[0] != 'I' && t[0] != 'U'))
          return invalidArgument(where + ": TYPE '" + t + "' is not F, I or U");
        h.type.push_back(t[0]);
      }
    } else if (key == "WIDTH" || key == "HEIGHT" || key == "POINTS") {
      if (v.size() != 1) return invalidArgument(where + ": " + key + " needs one value");
      ADIT_ASSIGN_OR_RETURN(std::uint64_t x, parseCount(v[0], where + ": " + key));
      if (key == "WIDTH") { h.width = x; have_width = true; }
      else if (key == "HEIGHT") h.height = x;
      else { h.points = x; have_points = true; h.points_line = line; }
    } else if (key == "VIEWPOINT") {
      h.viewpoint.clear();
      for (const auto& t : v) {
        char* e = nullptr;
        const double d = std::strtod(t.c_str(), &e);
        if (e == t.c_str() || *e || !std::isfinite(d)) return invalidArgument(where + ": VIEWPOINT value '" + t + "' is not a finite number");
        h.viewpoint.push_back(d);
      }
      if (h.viewpoint.size() != 7) return invalidArgument(where + ": VIEWPOINT needs 7 values (tx ty tz qw qx qy qz)");
    } else if (key == "DATA") {
      if (v.size() != 1 || (v[0] != "ascii" && v[0] != "binary" && v[0] != "binary_compressed"))
        return invalidArgument(where + ": DATA must be ascii, binary or binary_compressed");
      h.data = v[0];
      h.data_offset = std::min(pos, b.size());
      h.data_line = line + 1;
      break;
    } else {
      return invalidArgument(where + ": unknown PCD header line '" + key + "'");
    }
  }
  const std::size_t nf = h.fields.size();
  if (nf == 0) return invalidArgument(name + ": PCD header has no FIELDS");
  if (h.count.empty()) h.count.assign(nf, 1);
  if (h.size.size() != nf || h.type.size() != nf || h.count.size() != nf)
    return invalidArgument(name + ": PCD header lists " + std::to_string(nf) + " FIELDS but " +
                           std::to_string(h.size.size()) + " SIZE, " + std::to_string(h.type.size()) + " TYPE and " +
                           std::to_string(h.count.size()) + " COUNT entries");
  for (const char* axis : {"x", "y", "z"})
    if (std::find(h.fields.begin(), h.fields.end(), axis) == h.fields.end())
      return invalidArgument(name + ": PCD has no '" + axis + "' field (FIELDS are not a point cloud)");
  for (std::size_t i = 0; i < nf; ++i) {
    const bool ok = h.type[i] == 'F' ? (h.size[i] == 4 || h.size[i] == 8)
                                     : (h.size[i] == 1 || h.size[i] == 2 || h.size[i] == 4 || h.size[i] == 8);
    if (!ok) return invalidArgument(name + ": field '" + h.fields[i] + "' has TYPE " + h.type[i] + " with SIZE " +
                                    std::to_string(h.size[i]) + " (not a PCD type)");
    h.point_size += h.size[i] * h.count[i];
  }
  if (!have_width) return invalidArgument(name + ": PCD header has no WIDTH");
  if (!have_points) h.points = h.width * h.height;
  if (h.height != 0 && h.width > UINT64_MAX / h.height) return invalidArgument(name + ": WIDTH x HEIGHT overflows");
  if (h.points != h.width * h.height)
    return invalidArgument(name + ": POINTS " + std::to_string(h.points) + " is not WIDTH x HEIGHT = " +
                           std::to_string(h.width * h.height));
  if (h.points == 0) return invalidArgument(name + ": the PCD file has no points (POINTS 0)");
  if (h.points > limits.max_points)
    return outOfRange(atLine(name, h.points_line) + ": header announces " + std::to_string(h.points) +
                      " points, more than the limit of " +
                      std::to_string(limits.max_points));
  return h;
}

// The data section must be able to hold what the header announces, before anything is allocated.
Status checkDataSize(const std::string& b, const PcdHeader& h, const std::string& name) {
  const std::uint64_t avail = b.size() - h.data_offset;
  const std::uint64_t need = h.points * h.point_size;  // points <= limit, point_size <= 2^20
  if (h.data == "binary") {
    if (avail < need)
      return dataLoss(at(name, h.data_offset) + ": truncated binary data: header says " + std::to_string(h.points) +
                      " points x " + std::to_string(h.point_size) + " bytes = " + std::to_string(need) +
                      " bytes, only " + std::to_string(avail) + " follow");
  } else if (h.data == "binary_compressed") {
    if (avail < 8) return dataLoss(at(name, h.data_offset) + ": truncated: no compressed block sizes");
    const std::uint32_t comp = loadLE<std::uint32_t>(b, h.data_offset), raw = loadLE<std::uint32_t>(b, h.data_offset + 4);
    if (raw != need)
      return dataLoss(at(name, h.data_offset + 4) + ": compressed block unpacks to " + std::to_string(raw) +
                      " bytes but the header's " + std::to_string(h.points) + " points need " + std::to_string(need));
    if (comp > avail - 8)
      return dataLoss(at(name, h.data_offset) + ": truncated compressed block: " + std::to_string(comp) +
                      " bytes announced, " + std::to_string(avail - 8) + " follow");
  } else {
    // Open3D reads a line's values by position and leaves what a short line lacks unset (the
    // coordinates are then whatever memory held), so every line is checked here: as many values
    // as the header's FIELDS and COUNT name, each a number.
    std::uint64_t values = 0;
    for (const std::uint64_t c : h.count) values += c;
    std::uint64_t lines = 0, line = h.data_line;
    for (std::size_t p = h.data_offset; p < b.size() && lines < h.points; ++line) {
      std::size_t e = b.find('\n', p);
      if (e == std::string::npos) e = b.size();
      std::uint64_t n = 0;
      for (std::size_t q = b.find_first_not_of(" \t\r", p); q < e; q = b.find_first_not_of(" \t\r", q)) {
        const std::size_t t = std::min(b.find_first_of(" \t\r\n", q), e);
        char* end = nullptr;
        std::strtod(b.c_str() + q, &end);
        if (end != b.c_str() + t)
          return dataLoss(atLine(name, line) + ": '" + b.substr(q, std::min<std::size_t>(t - q, 40)) +
                          "' is not a number");
        ++n;
        q = t;
      }
      if (n > 0 && n < values)
        return dataLoss(atLine(name, line) + ": " + std::to_string(n) + " values, the header's FIELDS and COUNT name " +
                        std::to_string(values));
      lines += n > 0;
      p = e + 1;
    }
    if (lines < h.points)
      return dataLoss(atLine(name, h.data_line) + ": header says " + std::to_string(h.points) +
                      " points but only " + std::to_string(lines) + " data lines follow");
  }
  return {};
}

}  // namespace

StatusOr<Geometry> parsePcd(const std::string& bytes, const std::string& name, const ReadLimits& limits) {
  ADIT_ASSIGN_OR_RETURN(PcdHeader h, parseHeader(bytes, name, limits));
  ADIT_RETURN_IF_ERROR(checkDataSize(bytes, h, name));
  ADIT_ASSIGN_OR_RETURN(MemFile mem, MemFile::create(bytes, name));
  Geometry g;
  ADIT_ASSIGN_OR_RETURN(g.points, decodeCloud(mem.path(), "pcd", name, "the PCD " + h.data + " data", h.points, "points"));
  const std::int64_t bad = firstNonFinite(g.points);
  if (bad >= 0) {
    const std::string coords = "(" + std::to_string(g.points[bad].x()) + ", " + std::to_string(g.points[bad].y()) +
                               ", " + std::to_string(g.points[bad].z()) + ")";
    std::string where;
    if (h.data == "ascii") where = atLine(name, h.data_line + std::uint64_t(bad));
    else if (h.data == "binary") where = at(name, h.data_offset + std::uint64_t(bad) * h.point_size);
    else where = name + ": compressed point " + std::to_string(bad + 1);
    return invalidArgument(where + ": point " + std::to_string(bad + 1) + " has a non-finite coordinate " + coords +
                           " (remove invalid points before importing)");
  }
  if (!h.viewpoint.empty() && (h.viewpoint[0] != 0 || h.viewpoint[1] != 0 || h.viewpoint[2] != 0))
    g.viewpoint = Vec3(h.viewpoint[0], h.viewpoint[1], h.viewpoint[2]);
  return g;
}

StatusOr<Geometry> readPcd(const std::string& path, const ReadLimits& limits) {
  ADIT_ASSIGN_OR_RETURN(std::string bytes, readFile(path));
  return parsePcd(bytes, path, limits);
}

}  // namespace adit::map
