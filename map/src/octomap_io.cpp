// SPDX-License-Identifier: BSD-3-Clause
// OctoMap .bt/.ot reading with full validation, and atomic writing.
#include <octomap/OcTree.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <locale>
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
  bool has_id = false;
  while (lineno < 64 && nextLine(&line)) {
    ++lineno;
    if (line.empty() || line[0] == '#') continue;
    std::istringstream ls(line);
    ls.imbue(std::locale::classic());
    std::string token, value, extra;
    ls >> token >> value >> extra;
    const std::string where = name + ":" + std::to_string(lineno) + ": ";
    if (token == "data" && value.empty()) { got_data = true; break; }
    if (token != "id" && token != "size" && token != "res")
      return invalidArgument(where + "unknown header field '" + token + "'");
    if (value.empty()) return invalidArgument(where + "header field '" + token + "' has no value");
    if (!extra.empty())
      return invalidArgument(where + "header field '" + token + "' has more than one value ('" + value + "' '" +
                             extra + "')");
    bool& seen = token == "id" ? has_id : token == "size" ? h.has_size : h.has_res;
    if (seen) return invalidArgument(where + "header field '" + token + "' given twice");
    seen = true;
    if (token == "id") {
      h.id = value;
    } else if (token == "size") {
      // A plain decimal node count (istream would accept "-5" for an unsigned and wrap it).
      if (value.size() > 15 || value.find_first_not_of("0123456789") != std::string::npos)
        return invalidArgument(where + "bad 'size' value '" + value + "' in header (expected a node count)");
      h.size = std::stoull(value);
    } else {
      std::istringstream vs(value);
      vs.imbue(std::locale::classic());
      double r = 0;
      if (!(vs >> r) || vs.peek() != std::char_traits<char>::eof())
        return invalidArgument(where + "bad 'res' value '" + value + "' in header (expected metres)");
      h.resolution = r;
    }
  }
  if (!got_data) return dataLoss(name + ": header has no 'data' line (truncated or not an OctoMap file)");
  if (h.binary && !has_id) h.id = "OcTree";  // old binary files had no id line
  if (h.id != "OcTree")
    return invalidArgument(name + ": tree type '" + h.id + "' is not supported (adit reads OcTree maps only)");
  if (!h.has_res) return invalidArgument(name + ": header has no 'res' line");
  Status rs = checkResolution(h.resolution);
  if (!rs.ok()) return invalidArgument(name + ": header 'res': " + rs.message());
  if (!h.has_size) return invalidArgument(name + ": header has no 'size' line");
  h.data_offset = pos;
  return h;
}

// Walks the .bt node encoding (2 bytes per inner node, 2 bits per child; OctoMap 1.9.7 writes
// the low bit alone for a free leaf, the high bit alone for an occupied leaf, both for an inner
// node, neither for no child) in OctoMap's order without building anything.
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
    // OctoMap marks a node "inner" only when it has children; its reader would turn a childless
    // one into a leaf with log-odds -FLT_MAX. (A childless root is a one-node tree.)
    if (bits == 0 && f.depth > 0)
      return dataLoss(name + ": node at byte " + std::to_string(pos - 2) +
                      " is marked as having children but has none (corrupt file)");
    // Children with children are read after all 8 flags, in child order: push in reverse.
    for (int i = 7; i >= 0; --i) {
      const unsigned b = (bits >> (2 * i)) & 3u;
      if (b == 0) continue;
      // A leaf may sit at depth 16 (a finest voxel); an inner node there would have children at 17.
      if (f.depth + (b == 3 ? 2 : 1) > kTreeDepth)
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

// Read-only stream buffer over bytes already in memory (a file can be gigabytes).
class ViewBuf : public std::streambuf {
 public:
  ViewBuf(const char* begin, const char* end) {
    char* b = const_cast<char*>(begin);  // never written: the buffer is only read
    setg(b, b, const_cast<char*>(end));
  }
};

}  // namespace

StatusOr<MapFormat> formatFromPath(const std::string& path) {
  const std::string ext = lower(fs::path(path).extension().string());
  if (ext == ".yaml" || ext == ".yml") return MapFormat::kSurveyYaml;
  if (ext == ".bt") return MapFormat::kOctomapBinary;
  if (ext == ".ot") return MapFormat::kOctomapFull;
  return invalidArgument(path + ": unknown map format '" + ext +
                         "' (supported: .yaml/.yml survey network, .bt and .ot OctoMap)");
}

StatusOr<OccupancyMap> parseOctomap(const std::string& bytes, const std::string& name, UnknownPolicy policy,
                                    std::uint64_t max_memory_bytes) {
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
  // The node count is now known to be true: check what the tree will cost before building it.
  ADIT_RETURN_IF_ERROR(MemoryBudget{max_memory_bytes}.check(
      estimateOctreeBytes(double(h.size)), name + ": the octree (" + std::to_string(h.size) + " nodes)",
      "raise --max-memory (a crop is applied only after loading)"));
  auto tree = std::make_shared<octomap::OcTree>(h.resolution);
  ViewBuf view(bytes.data() + h.data_offset, bytes.data() + bytes.size());  // no copy of the data
  std::istream data(&view);
  if (h.binary) tree->readBinaryData(data); else tree->readData(data);
  if (tree->size() != h.size)
    return internalError(name + ": OctoMap read " + std::to_string(tree->size()) + " nodes, expected " +
                         std::to_string(h.size));
  StatusOr<OccupancyMap> map = OccupancyMap::create(std::move(tree), policy);
  if (!map.ok()) return Status(map.status().code(), name + ": " + map.status().message());
  return map;
}

StatusOr<OccupancyMap> loadOctomap(const std::string& path, UnknownPolicy policy, std::uint64_t max_memory_bytes) {
  StatusOr<std::string> bytes = readFile(path, std::min<std::uint64_t>(std::uint64_t{1} << 32, max_memory_bytes));
  if (!bytes.ok()) return bytes.status();
  return parseOctomap(*bytes, path, policy, max_memory_bytes);
}

namespace {

// OctoMap's writers print the resolution with the stream's default 6 significant digits, so a
// map at 0.1234567891 m would come back at 0.123457 m with every voxel moved. Print the shortest
// form that reads back exactly (0.25 stays "0.25", matching OctoMap byte for byte).
std::string exactNumber(double v) {
  for (int digits = 6; digits <= 17; ++digits) {
    std::ostringstream os;
    os.imbue(std::locale::classic());
    os << std::setprecision(digits) << v;
    std::istringstream back(os.str());
    back.imbue(std::locale::classic());
    double r = 0;
    if ((back >> r) && r == v) return os.str();
  }
  std::ostringstream os;
  os.imbue(std::locale::classic());
  os << std::setprecision(17) << v;
  return os.str();
}

// The header OctoMap's AbstractOcTree::write / AbstractOccupancyOcTree::writeBinaryConst write,
// with an exact resolution.
std::string octomapHeader(const octomap::OcTree& tree, bool binary) {
  std::string h = binary ? "# Octomap OcTree binary file" : "# Octomap OcTree file";
  h += "\n# (feel free to add / change comments, but leave the first line as it is!)\n#\n";
  h += "id " + tree.getTreeType() + "\n";
  h += "size " + std::to_string(tree.size()) + "\n";
  h += "res " + exactNumber(tree.getResolution()) + "\n";
  h += "data\n";
  return h;
}

}  // namespace

Status writeOctomap(const OccupancyMap& map, const std::string& path) {
  StatusOr<MapFormat> format = formatFromPath(path);
  if (!format.ok()) return format.status();
  if (*format == MapFormat::kSurveyYaml)
    return invalidArgument(path + ": a survey network cannot be written from an octree; use .bt or .ot");
  const bool binary = *format == MapFormat::kOctomapBinary;
  const octomap::OcTree& tree = map.octree();
  return writeFileAtomically(path, [&](std::ostream& os) {
    os << octomapHeader(tree, binary);
    if (binary) tree.writeBinaryData(os); else tree.writeData(os);
    return bool(os);
  });
}

}  // namespace adit::map
