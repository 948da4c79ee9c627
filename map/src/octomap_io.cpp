// SPDX-License-Identifier: BSD-3-Clause
// OctoMap .bt/.ot reading with full validation, and atomic writing.
#include <octomap/OcTree.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>
#include <vector>

#include "adit/map/map_io.hpp"

namespace adit::map {

namespace fs = std::filesystem;

namespace {

constexpr unsigned kTreeDepth = 16;  // OctoMap's fixed depth for 16-bit keys

std::string lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  return s;
}

struct Header {
  bool binary = true;
  std::string id;
  std::uint64_t size = 0;
  bool has_size = false;
  double resolution = 0.0;
  bool has_res = false;
  std::size_t data_offset = 0;
};

// OctoMap headers are short text lines ending in "data"; reading stops at 64 lines so that a
// binary file without the header cannot keep us scanning.
StatusOr<Header> parseHeader(const std::string& bytes, const std::string& name) {
  Header h;
  std::size_t pos = 0;
  auto nextLine = [&](std::string* line) {
    if (pos >= bytes.size()) return false;
    std::size_t end = bytes.find('\n', pos);
    if (end == std::string::npos || end - pos > 4096) return false;
    *line = bytes.substr(pos, end - pos);
    if (!line->empty() && line->back() == '\r') line->pop_back();
    pos = end + 1;
    return true;
  };
  std::string line;
  if (bytes.empty()) return dataLoss(name + ": file is empty");
  if (!nextLine(&line)) return invalidArgument(name + ": not an OctoMap file (no header line)");
  if (line.rfind("# Octomap OcTree binary file", 0) == 0) {
    h.binary = true;
  } else if (line.rfind("# Octomap OcTree file", 0) == 0) {
    h.binary = false;
  } else {
    return invalidArgument(name + ": not an OctoMap file: first line is not '# Octomap OcTree binary file' "
                           "or '# Octomap OcTree file'");
  }
  int lineno = 1;
  bool got_data = false;
  while (lineno < 64 && nextLine(&line)) {
    ++lineno;
    if (line.empty() || line[0] == '#') continue;
    std::istringstream ls(line);
    std::string token;
    ls >> token;
    if (token == "data") { got_data = true; break; }
    if (token == "id") {
      ls >> h.id;
    } else if (token == "size") {
      long double v = -1;
      if (!(ls >> v) || v < 0 || v > 1e15)
        return invalidArgument(name + ":" + std::to_string(lineno) + ": bad 'size' value in header");
      h.size = std::uint64_t(v);
      h.has_size = true;
    } else if (token == "res") {
      double r = 0;
      if (!(ls >> r)) return invalidArgument(name + ":" + std::to_string(lineno) + ": bad 'res' value in header");
      h.resolution = r;
      h.has_res = true;
    } else {
      return invalidArgument(name + ":" + std::to_string(lineno) + ": unknown header field '" + token + "'");
    }
  }
  if (!got_data) return dataLoss(name + ": header has no 'data' line (truncated or not an OctoMap file)");
  if (h.binary && h.id.empty()) h.id = "OcTree";  // old binary files had no id line
  if (h.id != "OcTree")
    return invalidArgument(name + ": tree type '" + h.id + "' is not supported (adit reads OcTree maps only)");
  if (!h.has_res) return invalidArgument(name + ": header has no 'res' line");
  Status rs = checkResolution(h.resolution);
  if (!rs.ok()) return invalidArgument(name + ": header " + rs.message());
  if (!h.has_size) return invalidArgument(name + ": header has no 'size' line");
  h.data_offset = pos;
  return h;
}

// Walks the .bt node encoding (2 bytes per inner node, 2 bits per child: 01 occupied leaf,
// 10 free leaf, 11 inner, 00 unknown) in OctoMap's order without building anything.
Status validateBinaryData(const std::string& bytes, std::size_t offset, std::uint64_t expected_nodes,
                          const std::string& name) {
  struct Frame { unsigned depth; };
  std::vector<Frame> stack{{0}};
  std::uint64_t nodes = 1;
  std::size_t pos = offset;
  while (!stack.empty()) {
    const Frame f = stack.back();
    stack.pop_back();
    if (pos + 2 > bytes.size())
      return dataLoss(name + ": data ends at byte " + std::to_string(bytes.size()) +
                      " in the middle of the tree (truncated file)");
    const auto lo = static_cast<unsigned char>(bytes[pos]), hi = static_cast<unsigned char>(bytes[pos + 1]);
    pos += 2;
    const unsigned bits = unsigned(lo) | (unsigned(hi) << 8);
    // Children with children are read after all 8 flags, in child order: push in reverse.
    for (int i = 7; i >= 0; --i) {
      const unsigned b = (bits >> (2 * i)) & 3u;
      if (b == 0) continue;
      if (f.depth + 1 > kTreeDepth)
        return dataLoss(name + ": node at byte " + std::to_string(pos - 2) + " is deeper than 16 levels");
      ++nodes;
      if (b == 3) stack.push_back({f.depth + 1});
    }
    if (nodes > expected_nodes)
      return dataLoss(name + ": tree has more nodes than the header's size " + std::to_string(expected_nodes));
  }
  if (nodes != expected_nodes)
    return dataLoss(name + ": tree has " + std::to_string(nodes) + " nodes, header says " +
                    std::to_string(expected_nodes));
  if (pos != bytes.size())
    return dataLoss(name + ": " + std::to_string(bytes.size() - pos) + " unexpected bytes after the tree");
  return {};
}

// Walks the .ot encoding (float log-odds + child bit mask per node, depth first).
Status validateFullData(const std::string& bytes, std::size_t offset, std::uint64_t expected_nodes,
                        const std::string& name) {
  std::vector<unsigned> stack{0};
  std::uint64_t nodes = 0;
  std::size_t pos = offset;
  while (!stack.empty()) {
    const unsigned depth = stack.back();
    stack.pop_back();
    if (depth > kTreeDepth) return dataLoss(name + ": node at byte " + std::to_string(pos) + " is deeper than 16 levels");
    if (pos + 5 > bytes.size())
      return dataLoss(name + ": data ends at byte " + std::to_string(bytes.size()) +
                      " in the middle of the tree (truncated file)");
    float value;
    std::memcpy(&value, bytes.data() + pos, sizeof(float));
    if (!std::isfinite(value))
      return dataLoss(name + ": node at byte " + std::to_string(pos) + " has a non-finite log-odds value");
    const auto mask = static_cast<unsigned char>(bytes[pos + 4]);
    pos += 5;
    if (++nodes > expected_nodes)
      return dataLoss(name + ": tree has more nodes than the header's size " + std::to_string(expected_nodes));
    for (int i = 7; i >= 0; --i)
      if (mask & (1u << i)) stack.push_back(depth + 1);
  }
  if (nodes != expected_nodes)
    return dataLoss(name + ": tree has " + std::to_string(nodes) + " nodes, header says " +
                    std::to_string(expected_nodes));
  if (pos != bytes.size())
    return dataLoss(name + ": " + std::to_string(bytes.size() - pos) + " unexpected bytes after the tree");
  return {};
}

}  // namespace

StatusOr<MapFormat> formatFromPath(const std::string& path) {
  const std::string ext = lower(fs::path(path).extension().string());
  if (ext == ".yaml" || ext == ".yml") return MapFormat::kSurveyYaml;
  if (ext == ".bt") return MapFormat::kOctomapBinary;
  if (ext == ".ot") return MapFormat::kOctomapFull;
  return invalidArgument(path + ": unknown map format '" + ext +
                         "' (supported: .yaml/.yml survey network, .bt and .ot OctoMap)");
}

StatusOr<std::string> readFile(const std::string& path, std::size_t max_bytes) {
  std::error_code ec;
  const fs::file_status st = fs::status(path, ec);
  if (ec || !fs::exists(st)) return notFound(path + ": no such file");
  if (fs::is_directory(st)) return invalidArgument(path + ": is a directory, not a file");
  std::ifstream in(path, std::ios::binary);
  if (!in) return notFound(path + ": cannot open: " + std::strerror(errno));
  in.seekg(0, std::ios::end);
  const std::streamoff size = in.tellg();
  if (size < 0) return dataLoss(path + ": cannot determine the file size");
  if (std::uint64_t(size) > max_bytes)
    return invalidArgument(path + ": file is " + std::to_string(size) + " bytes, above the limit of " +
                           std::to_string(max_bytes));
  in.seekg(0);
  std::string bytes(std::size_t(size), '\0');
  if (size > 0 && !in.read(bytes.data(), size)) return dataLoss(path + ": read error");
  return bytes;
}

StatusOr<OccupancyMap> parseOctomap(const std::string& bytes, const std::string& name, UnknownPolicy policy) {
  StatusOr<Header> header = parseHeader(bytes, name);
  if (!header.ok()) return header.status();
  const Header& h = *header;
  if (h.size == 0) return failedPrecondition(name + ": empty map (the tree has no nodes)");
  const std::size_t min_bytes_per_node = h.binary ? 0 : 5;
  if (min_bytes_per_node && h.size > (bytes.size() - h.data_offset) / min_bytes_per_node + 1)
    return dataLoss(name + ": header claims " + std::to_string(h.size) + " nodes but the file holds at most " +
                    std::to_string((bytes.size() - h.data_offset) / min_bytes_per_node));
  ADIT_RETURN_IF_ERROR(h.binary ? validateBinaryData(bytes, h.data_offset, h.size, name)
                                : validateFullData(bytes, h.data_offset, h.size, name));
  auto tree = std::make_shared<octomap::OcTree>(h.resolution);
  std::istringstream data(bytes.substr(h.data_offset));
  if (h.binary) tree->readBinaryData(data); else tree->readData(data);
  if (tree->size() != h.size)
    return internalError(name + ": OctoMap read " + std::to_string(tree->size()) + " nodes, expected " +
                         std::to_string(h.size));
  StatusOr<OccupancyMap> map = OccupancyMap::create(std::move(tree), policy);
  if (!map.ok()) return Status(map.status().code(), name + ": " + map.status().message());
  return map;
}

StatusOr<OccupancyMap> loadOctomap(const std::string& path, UnknownPolicy policy) {
  StatusOr<std::string> bytes = readFile(path);
  if (!bytes.ok()) return bytes.status();
  return parseOctomap(*bytes, path, policy);
}

Status writeFileAtomically(const std::string& path, const std::function<bool(std::ostream&)>& write) {
  const fs::path target(path);
  const fs::path dir = target.has_parent_path() ? target.parent_path() : fs::path(".");
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) return notFound(path + ": directory '" + dir.string() + "' does not exist");
  if (fs::is_directory(target, ec)) return invalidArgument(path + ": is a directory");
  std::random_device rd;
  const fs::path tmp = dir / ("." + target.filename().string() + ".tmp" + std::to_string(::getpid()) + "_" +
                              std::to_string(rd() % 1000000));
  bool ok = false;
  std::string why;
  try {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    if (!out) return invalidArgument(path + ": cannot create a file in '" + dir.string() + "': " + std::strerror(errno));
    ok = write(out);
    out.flush();
    ok = ok && out.good();
    out.close();
    ok = ok && !out.fail();
    if (!ok) why = "write failed (disk full or I/O error?)";
  } catch (const std::exception& e) {
    ok = false;
    why = e.what();
  }
  if (ok) {
    fs::rename(tmp, target, ec);
    if (ec) { ok = false; why = "rename failed: " + ec.message(); }
  }
  if (!ok) {
    fs::remove(tmp, ec);
    return internalError(path + ": " + why + "; nothing was written");
  }
  return {};
}

Status writeOctomap(const OccupancyMap& map, const std::string& path) {
  StatusOr<MapFormat> format = formatFromPath(path);
  if (!format.ok()) return format.status();
  if (*format == MapFormat::kSurveyYaml)
    return invalidArgument(path + ": a survey network cannot be written from an octree; use .bt or .ot");
  const bool binary = *format == MapFormat::kOctomapBinary;
  return writeFileAtomically(path, [&](std::ostream& os) {
    return binary ? map.octree().writeBinaryConst(os) : map.octree().write(os);
  });
}

}  // namespace adit::map
