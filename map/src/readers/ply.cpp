// SPDX-License-Identifier: BSD-3-Clause
#include "adit/map/readers/ply.hpp"

#include <algorithm>
#include <cmath>
#include <map>
#include <sstream>

#include "adit/map/map_io.hpp"
#include "adit/map/readers/mesh.hpp"
#include "common.hpp"

namespace adit::map {

using namespace readers_internal;

namespace {

struct PlyProperty {
  int size = 0;        // bytes of a value (of each list item for a list)
  int count_size = 0;  // bytes of a list's length field; 0 for a scalar property
  bool count_signed = false;
};

struct PlyElement {
  std::string name;
  std::uint64_t count = 0;
  std::uint64_t min_bytes = 0;  // fixed properties plus each list's length field
  std::vector<PlyProperty> props;
};

int typeSize(const std::string& t) {
  static const std::map<std::string, int> sizes = {
      {"char", 1},   {"uchar", 1},  {"int8", 1},  {"uint8", 1},   {"short", 2},  {"ushort", 2},
      {"int16", 2},  {"uint16", 2}, {"int", 4},   {"uint", 4},    {"int32", 4},  {"uint32", 4},
      {"float", 4},  {"float32", 4}, {"double", 8}, {"float64", 8}};
  auto it = sizes.find(t);
  return it == sizes.end() ? 0 : it->second;
}

bool isIntegerType(const std::string& t) { return t != "float" && t != "float32" && t != "double" && t != "float64"; }

// A mesh's body is walked against its header before Assimp parses it, so a malformed body is
// reported by line or offset and Assimp's PLY parser (which misbehaved under the fuzzer, see
// tests/fuzz/README.md) only sees well-formed input: in ascii every element is a line of exactly
// the numbers its properties take, in binary every list length is a non-negative integer and
// every record lies inside the file.
Status checkBody(const std::string& b, std::size_t pos, std::uint64_t line, const std::vector<PlyElement>& elems,
                 bool ascii, bool big_endian, const std::string& name) {
  for (const PlyElement& e : elems) {
    if (e.props.empty()) continue;
    for (std::uint64_t i = 0; i < e.count; ++i) {
      if (ascii) {
        std::string l;
        do {
          if (pos >= b.size()) return dataLoss(atLine(name, line + 1) + ": '" + e.name + "' " + std::to_string(i + 1) + " is missing");
          std::size_t end = b.find('\n', pos);
          if (end == std::string::npos) end = b.size();
          l = b.substr(pos, end - pos);
          pos = end + 1;
          ++line;
        } while (l.find_first_not_of(" \t\r") == std::string::npos);
        std::istringstream is(l);
        std::vector<double> v;
        for (std::string tok; is >> tok;) {
          char* stop = nullptr;
          v.push_back(std::strtod(tok.c_str(), &stop));
          if (stop == tok.c_str() || *stop) return invalidArgument(atLine(name, line) + ": '" + tok + "' is not a number");
        }
        std::size_t k = 0;
        for (const PlyProperty& p : e.props) {
          if (k >= v.size()) return invalidArgument(atLine(name, line) + ": too few values for a '" + e.name + "'");
          if (p.count_size) {
            if (!(v[k] >= 0 && v[k] <= double(v.size())) || v[k] != std::floor(v[k]))
              return invalidArgument(atLine(name, line) + ": list length " + std::to_string(v[k]) + " does not fit the line");
            k += std::size_t(v[k]);
          }
          ++k;
        }
        if (k != v.size())
          return invalidArgument(atLine(name, line) + ": " + std::to_string(v.size()) + " values where a '" + e.name +
                                 "' takes " + std::to_string(k));
      } else {
        for (const PlyProperty& p : e.props) {
          pos += std::size_t(p.count_size ? 0 : p.size);
          if (!p.count_size) continue;
          if (pos + std::size_t(p.count_size) > b.size()) {
            pos = b.size() + 1;  // reported below
            break;
          }
          std::uint64_t n = 0;
          for (int j = 0; j < p.count_size; ++j) {
            const auto byte = std::uint64_t(static_cast<unsigned char>(b[pos + std::size_t(big_endian ? j : p.count_size - 1 - j)]));
            n = (n << 8) | byte;
          }
          if (p.count_signed && (n >> (8 * p.count_size - 1)))
            return invalidArgument(at(name, pos) + ": negative list length in '" + e.name + "' " + std::to_string(i + 1));
          pos += std::size_t(p.count_size) + std::size_t(n) * std::size_t(p.size);
          if (pos > b.size()) break;
        }
        if (pos > b.size())
          return dataLoss(name + ": truncated: '" + e.name + "' " + std::to_string(i + 1) + " of " + std::to_string(e.count) +
                          " runs past the end of the file");
      }
    }
  }
  return {};
}

}  // namespace

StatusOr<Geometry> parsePly(const std::string& b, const std::string& name, const ReadLimits& limits) {
  if (b.compare(0, 3, "ply") != 0 || b.size() < 4 || (b[3] != '\n' && b[3] != '\r'))
    return invalidArgument(name + ": not a PLY file (no 'ply' magic line)");
  std::vector<PlyElement> elems;
  std::string format;
  std::size_t pos = 0;
  std::uint64_t line = 0;
  bool has_x = false;
  while (true) {
    if (pos >= b.size() || pos > (1u << 20)) return invalidArgument(name + ": PLY header has no end_header");
    std::size_t end = b.find('\n', pos);
    if (end == std::string::npos) end = b.size();
    std::string l = b.substr(pos, end - pos);
    pos = end + 1;
    ++line;
    if (!l.empty() && l.back() == '\r') l.pop_back();
    std::istringstream is(l);
    std::string key;
    is >> key;
    const std::string where = atLine(name, line);
    if (key == "end_header") break;
    if (key == "ply" || key == "comment" || key == "obj_info" || key.empty()) continue;
    if (key == "format") {
      std::string ver;
      is >> format >> ver;
      if (format != "ascii" && format != "binary_little_endian" && format != "binary_big_endian")
        return invalidArgument(where + ": unknown PLY format '" + format + "'");
    } else if (key == "element") {
      PlyElement e;
      std::string n;
      is >> e.name >> n;
      if (n.empty() || n.size() > 19 || n.find_first_not_of("0123456789") != std::string::npos)
        return invalidArgument(where + ": element count '" + n + "' is not a non-negative integer");
      e.count = std::stoull(n);
      if (e.count > limits.max_points)
        return outOfRange(where + ": element '" + e.name + "' announces " + n + " entries, more than the limit of " +
                          std::to_string(limits.max_points));
      elems.push_back(e);
    } else if (key == "property") {
      if (elems.empty()) return invalidArgument(where + ": property before any element");
      std::string t, pname;
      is >> t;
      if (t == "list") {
        std::string ct, it;
        is >> ct >> it >> pname;
        if (!typeSize(ct) || !typeSize(it) || !isIntegerType(ct)) return invalidArgument(where + ": bad list property types");
        elems.back().min_bytes += std::uint64_t(typeSize(ct));
        elems.back().props.push_back({typeSize(it), typeSize(ct), ct[0] != 'u'});
      } else {
        is >> pname;
        if (!typeSize(t)) return invalidArgument(where + ": unknown property type '" + t + "'");
        elems.back().min_bytes += std::uint64_t(typeSize(t));
        elems.back().props.push_back({typeSize(t), 0, false});
        if (elems.back().name == "vertex" && pname == "x") has_x = true;
      }
    } else {
      return invalidArgument(where + ": unknown PLY header line '" + key + "'");
    }
  }
  if (format.empty()) return invalidArgument(name + ": PLY header has no format line");
  const PlyElement* vertex = nullptr;
  std::uint64_t faces = 0;
  for (const auto& e : elems) {
    if (e.name == "vertex") vertex = &e;
    if (e.name == "face") faces = e.count;
  }
  if (!vertex || !has_x) return invalidArgument(name + ": PLY has no vertex element with x, y, z");
  if (vertex->count == 0) return invalidArgument(name + ": PLY has no vertices (element vertex 0)");
  const std::uint64_t avail = b.size() - std::min(pos, b.size());
  if (format == "ascii") {
    std::uint64_t need = 0, lines = 0;
    for (const auto& e : elems) need += e.count;
    for (std::size_t p = pos; p < b.size() && lines < need;) {
      std::size_t e = b.find('\n', p);
      if (e == std::string::npos) e = b.size();
      if (b.find_first_not_of(" \t\r", p) < e) ++lines;
      p = e + 1;
    }
    if (lines < need)
      return dataLoss(atLine(name, line + 1) + ": header announces " + std::to_string(need) + " element lines, only " +
                      std::to_string(lines) + " follow");
  } else {
    std::uint64_t need = 0;
    for (const auto& e : elems) need += e.count * e.min_bytes;
    if (avail < need)
      return dataLoss(at(name, pos) + ": truncated: the header's elements need at least " + std::to_string(need) +
                      " bytes, only " + std::to_string(avail) + " follow");
  }
  if (faces > 0) {
    ADIT_RETURN_IF_ERROR(checkBody(b, pos, line, elems, format == "ascii", format == "binary_big_endian", name));
    return parseMesh(b, name, "ply", limits);
  }
  ADIT_ASSIGN_OR_RETURN(MemFile mem, MemFile::create(b, name));
  Geometry g;
  ADIT_ASSIGN_OR_RETURN(g.points, decodeCloud(mem.path(), "ply", name, "the PLY vertices", vertex->count, "vertices"));
  const std::int64_t bad = firstNonFinite(g.points);
  if (bad >= 0) return invalidArgument(name + ": vertex " + std::to_string(bad + 1) + " has a non-finite coordinate");
  return g;
}

StatusOr<Geometry> readPly(const std::string& path, const ReadLimits& limits) {
  ADIT_ASSIGN_OR_RETURN(std::string bytes, readFile(path));
  return parsePly(bytes, path, limits);
}

}  // namespace adit::map
