// SPDX-License-Identifier: BSD-3-Clause
#include "common/points_csv.hpp"

#include <algorithm>
#include <charconv>
#include <cctype>
#include <cmath>
#include <cstdlib>
#include <sstream>

#include "adit/map/map_io.hpp"
#include "adit/map/size_estimate.hpp"

namespace adit::tools {

using map::Vec3;

StatusOr<Vec3> parsePoint(const std::string& text, const std::string& where) {
  std::string t = text;
  for (char& c : t)
    if (c == ',' || c == ';' || c == '\t') c = ' ';
  std::istringstream is(t);
  Vec3 p;
  std::string tok;
  for (int i = 0; i < 3; ++i) {
    if (!(is >> tok)) return invalidArgument(where + ": expected x,y,z, got '" + text + "'");
    char* end = nullptr;
    p[i] = std::strtod(tok.c_str(), &end);
    if (end == tok.c_str() || *end != '\0') return invalidArgument(where + ": '" + tok + "' is not a number");
    if (!std::isfinite(p[i])) return invalidArgument(where + ": coordinate '" + tok + "' is not finite");
  }
  if (is >> tok) return invalidArgument(where + ": expected three values, got more in '" + text + "'");
  return p;
}

StatusOr<std::vector<Vec3>> parsePointsCsv(const std::string& text, const std::string& name) {
  // Spreadsheets on Windows save "CSV UTF-8" with a byte-order mark before the header.
  static const std::string kBom = "\xEF\xBB\xBF";
  const std::size_t start = text.compare(0, kBom.size(), kBom) == 0 ? kBom.size() : 0;
  std::vector<Vec3> pts;
  int lineno = 0;
  for (std::size_t pos = start; pos < text.size();) {
    std::size_t end = text.find('\n', pos);
    if (end == std::string::npos) end = text.size();
    std::string line = text.substr(pos, end - pos);
    pos = end + 1;
    ++lineno;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    const auto first = line.find_first_not_of(" \t");
    if (first == std::string::npos || line[first] == '#') continue;
    // A header row such as "x,y,z" is allowed on the first data line.
    if (pts.empty() && (std::isalpha(static_cast<unsigned char>(line[first])) && line.substr(first, 3) != "nan" &&
                        line.substr(first, 3) != "inf"))
      continue;
    StatusOr<Vec3> p = parsePoint(line, name + ":" + std::to_string(lineno));
    if (!p.ok()) return p.status();
    pts.push_back(*p);
  }
  if (pts.empty()) return invalidArgument(name + ": no points (expected lines of x,y,z)");
  return pts;
}

StatusOr<std::vector<Vec3>> readPointsCsv(const std::string& path, std::uint64_t max_memory_bytes) {
  StatusOr<std::string> text = map::readFile(path, std::min<std::uint64_t>(std::uint64_t{1} << 30, max_memory_bytes));
  if (!text.ok()) return text.status();
  const auto lines = double(std::count(text->begin(), text->end(), '\n') + 1);
  ADIT_RETURN_IF_ERROR(map::MemoryBudget{max_memory_bytes}.check(
      double(text->size()) + lines * double(sizeof(Vec3)), path + ": reading " + std::to_string(std::uint64_t(lines)) + " lines of points",
      "split the file or raise --max-memory"));
  return parsePointsCsv(*text, path);
}

std::string roundTripNumber(double v) {
  char buf[64];
  const std::to_chars_result r = std::to_chars(buf, buf + sizeof buf, v);
  return std::string(buf, r.ptr);
}

}  // namespace adit::tools
