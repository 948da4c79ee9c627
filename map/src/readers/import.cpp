// SPDX-License-Identifier: BSD-3-Clause
#include "adit/map/readers/import.hpp"

#include <cmath>
#include <sstream>

#include "adit/map/map_io.hpp"
#include "adit/map/readers/las.hpp"
#include "adit/map/readers/mesh.hpp"
#include "adit/map/readers/pcd.hpp"
#include "adit/map/readers/ply.hpp"
#include "adit/map/readers/xyz.hpp"
#include "common.hpp"

namespace adit::map {

using namespace readers_internal;

namespace {
bool isText(const std::string& e) { return e == ".xyz" || e == ".csv" || e == ".txt" || e == ".pts"; }
bool isMeshExt(const std::string& e) { return e == ".stl" || e == ".obj" || e == ".dae"; }
}  // namespace

bool isImportFormat(const std::string& path) {
  const std::string e = extensionOf(path);
  return e == ".pcd" || e == ".ply" || e == ".las" || e == ".laz" || isText(e) || isMeshExt(e);
}

StatusOr<Geometry> parseGeometry(const std::string& bytes, const std::string& name, const std::string& ext,
                                 const ReadLimits& limits) {
  if (ext == ".pcd") return parsePcd(bytes, name, limits);
  if (ext == ".ply") return parsePly(bytes, name, limits);
  if (ext == ".las") return parseLas(bytes, name, limits);
  if (ext == ".laz") return invalidArgument(name + ": " + kLazNotSupported);
  if (isText(ext)) return parseXyz(bytes, name, limits);
  if (isMeshExt(ext)) return parseMesh(bytes, name, ext.substr(1), limits);
  return invalidArgument(name + ": unknown import format '" + ext +
                         "' (point clouds: .pcd .ply .xyz .csv .txt .pts .las; meshes: .stl .obj .ply .dae)");
}

StatusOr<Geometry> readGeometry(const std::string& path, const ReadLimits& limits) {
  const std::string ext = extensionOf(path);
  if (ext == ".laz") return invalidArgument(path + ": " + kLazNotSupported);
  if (!isImportFormat(path)) return parseGeometry({}, path, ext, limits);
  ADIT_ASSIGN_OR_RETURN(std::string bytes, readFile(path));
  return parseGeometry(bytes, path, ext, limits);
}

Vec3 toMapFrame(const Vec3& p, bool y_up, const Vec3& origin) {
  return (y_up ? Vec3(p.x(), -p.z(), p.y()) : p) - origin;
}

void toMapFrame(Geometry* g, bool y_up, const Vec3& origin) {
  for (Vec3& p : g->points) p = toMapFrame(p, y_up, origin);
  if (g->viewpoint) g->viewpoint = toMapFrame(*g->viewpoint, y_up, origin);
}

Vec3 chooseOrigin(const Aabb& box, double resolution_m, const std::optional<Vec3>& requested, bool* automatic) {
  *automatic = false;
  if (requested) return *requested;
  if (box.empty()) return Vec3::Zero();
  const double far = std::max(box.min.cwiseAbs().maxCoeff(), box.max.cwiseAbs().maxCoeff());
  if (checkExtent(box, resolution_m).ok() && far <= 1e4) return Vec3::Zero();
  *automatic = true;
  const Vec3 c = box.center();
  return Vec3(std::round(c.x()), std::round(c.y()), std::round(c.z()));
}

StatusOr<std::vector<Vec3>> parseTrajectory(const std::string& bytes, const std::string& name) {
  std::istringstream in(bytes);
  std::string line;
  std::uint64_t lineno = 0;
  std::vector<Vec3> poses;
  int cx = -1, cy = -1, cz = -1;
  bool first = true;
  while (std::getline(in, line)) {
    ++lineno;
    if (lineno == 1 && line.compare(0, 3, "\xEF\xBB\xBF") == 0) line.erase(0, 3);
    for (char& c : line)
      if (c == ',' || c == ';' || c == '\t' || c == '\r') c = ' ';
    std::istringstream ls(line);
    std::vector<std::string> tok;
    for (std::string t; ls >> t;) tok.push_back(t);
    if (tok.empty() || tok[0][0] == '#') continue;
    std::vector<double> v;
    bool numeric = true;
    for (const auto& t : tok) {
      char* e = nullptr;
      const double d = std::strtod(t.c_str(), &e);
      if (e == t.c_str() || *e) { numeric = false; break; }
      v.push_back(d);
    }
    if (!numeric) {
      if (!first) return invalidArgument(atLine(name, lineno) + ": expected numbers, got '" + line + "'");
      for (int i = 0; i < int(tok.size()); ++i) {
        if (tok[i] == "x" || tok[i] == "tx") cx = i;
        if (tok[i] == "y" || tok[i] == "ty") cy = i;
        if (tok[i] == "z" || tok[i] == "tz") cz = i;
      }
      if (cx < 0 || cy < 0 || cz < 0)
        return invalidArgument(atLine(name, lineno) + ": header row must name x, y and z columns");
      first = false;
      continue;
    }
    if (cx < 0) {
      if (v.size() == 3 || v.size() == 7) { cx = 0; cy = 1; cz = 2; }
      else if (v.size() == 8) { cx = 1; cy = 2; cz = 3; }
      else
        return invalidArgument(atLine(name, lineno) + ": " + std::to_string(v.size()) +
                               " columns; expected x,y,z (3), x y z qx qy qz qw (7), t x y z qx qy qz qw (8) or a header row");
    }
    first = false;
    if (int(v.size()) <= std::max({cx, cy, cz}))
      return invalidArgument(atLine(name, lineno) + ": too few columns");
    const Vec3 p(v[std::size_t(cx)], v[std::size_t(cy)], v[std::size_t(cz)]);
    if (!p.allFinite()) return invalidArgument(atLine(name, lineno) + ": non-finite pose position");
    poses.push_back(p);
  }
  if (poses.empty()) return invalidArgument(name + ": no poses");
  return poses;
}

StatusOr<std::vector<Vec3>> readTrajectory(const std::string& path) {
  ADIT_ASSIGN_OR_RETURN(std::string bytes, readFile(path, std::size_t{1} << 30));
  return parseTrajectory(bytes, path);
}

}  // namespace adit::map
