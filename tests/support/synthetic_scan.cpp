// SPDX-License-Identifier: BSD-3-Clause
#include "support/synthetic_scan.hpp"

#include <cmath>
#include <cstring>
#include <sstream>

namespace adit::test {

using map::Vec3;

namespace {

template <class T>
void put(std::string* s, T v) {
  char b[sizeof(T)];
  std::memcpy(b, &v, sizeof(T));
  s->append(b, sizeof(T));
}

std::string pcdHeader(std::size_t n, const char* data) {
  std::ostringstream os;
  os << "# .PCD v0.7 - Point Cloud Data file format\nVERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\n"
     << "COUNT 1 1 1\nWIDTH " << n << "\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS " << n << "\nDATA " << data << "\n";
  return os.str();
}

std::string plyHeader(std::size_t n, const char* format) {
  std::ostringstream os;
  os << "ply\nformat " << format << " 1.0\ncomment adit test\nelement vertex " << n
     << "\nproperty float x\nproperty float y\nproperty float z\nend_header\n";
  return os.str();
}

}  // namespace

std::vector<Vec3> TubeScan::points() const {
  std::vector<Vec3> pts;
  const int nx = int(std::lround(length / spacing)), ny = int(std::lround(width / spacing)),
            nz = int(std::lround(height / spacing));
  for (int i = 0; i <= nx; ++i) {
    const double x = i * spacing;
    for (int j = 0; j <= ny; ++j) {
      const double y = -0.5 * width + j * spacing;
      pts.emplace_back(x, y, 0.0);
      pts.emplace_back(x, y, height);
    }
    for (int k = 1; k < nz; ++k) {
      const double z = k * spacing;
      pts.emplace_back(x, -0.5 * width, z);
      const bool hole = x >= hole_x0 && x <= hole_x1 && z >= hole_z0 && z <= hole_z1;
      if (!hole) pts.emplace_back(x, 0.5 * width, z);
    }
  }
  return pts;
}

map::Geometry TubeScan::mesh() const {
  map::Geometry g;
  const double w = 0.5 * width;
  // Corners of the section at x = 0 (0..3) and x = length (4..7): floor-left, floor-right,
  // roof-right, roof-left.
  for (double x : {0.0, length})
    for (const auto& yz : {std::pair{-w, 0.0}, std::pair{w, 0.0}, std::pair{w, height}, std::pair{-w, height}})
      g.points.emplace_back(x, yz.first, yz.second);
  for (std::uint32_t s = 0; s < 4; ++s) {
    const std::uint32_t a = s, b = (s + 1) % 4, c = b + 4, d = a + 4;
    g.triangles.push_back({a, b, c});
    g.triangles.push_back({a, c, d});
  }
  return g;
}

std::vector<Vec3> lScan(double leg, double width, double height, double spacing) {
  std::vector<Vec3> pts;
  const double w = 0.5 * width;
  // Leg 1 along x from 0 to leg + w; leg 2 along y from w to leg + w at x in [leg - w, leg + w].
  for (double x = 0; x <= leg + w + 1e-9; x += spacing)
    for (double y = -w; y <= w + 1e-9; y += spacing) {
      pts.emplace_back(x, y, 0.0);
      pts.emplace_back(x, y, height);
    }
  for (double y = w; y <= leg + w + 1e-9; y += spacing)
    for (double x = leg - w; x <= leg + w + 1e-9; x += spacing) {
      pts.emplace_back(x, y, 0.0);
      pts.emplace_back(x, y, height);
    }
  for (double z = spacing; z < height - 1e-9; z += spacing) {
    for (double x = 0; x <= leg + w + 1e-9; x += spacing) {
      pts.emplace_back(x, -w, z);                         // south wall, whole length
      if (x <= leg - w) pts.emplace_back(x, w, z);        // north wall up to the corner
    }
    for (double y = -w; y <= leg + w + 1e-9; y += spacing) pts.emplace_back(leg + w, y, z);  // east wall
    for (double y = w; y <= leg + w + 1e-9; y += spacing) pts.emplace_back(leg - w, y, z);   // west wall of leg 2
  }
  return pts;
}

// Header, then one "x y z" float line or 12 float bytes per point.
std::string floatRows(std::string header, const std::vector<Vec3>& pts, bool ascii) {
  std::ostringstream os;
  os.precision(9);
  for (const Vec3& p : pts) {
    if (ascii) os << float(p.x()) << " " << float(p.y()) << " " << float(p.z()) << "\n";
    else
      for (int i = 0; i < 3; ++i) put(&header, float(p[i]));
  }
  return header + os.str();
}

std::string pcdAscii(const std::vector<Vec3>& pts) { return floatRows(pcdHeader(pts.size(), "ascii"), pts, true); }
std::string pcdBinary(const std::vector<Vec3>& pts) { return floatRows(pcdHeader(pts.size(), "binary"), pts, false); }

std::string pcdCompressed(const std::vector<Vec3>& pts) {
  std::string raw;
  for (int i = 0; i < 3; ++i)
    for (const Vec3& p : pts) put(&raw, float(p[i]));
  std::string lzf;
  for (std::size_t o = 0; o < raw.size(); o += 32) {
    const std::size_t n = std::min<std::size_t>(32, raw.size() - o);
    lzf.push_back(char(n - 1));  // literal run of n bytes
    lzf.append(raw, o, n);
  }
  std::string s = pcdHeader(pts.size(), "binary_compressed");
  put(&s, std::uint32_t(lzf.size()));
  put(&s, std::uint32_t(raw.size()));
  return s + lzf;
}

std::string plyAscii(const std::vector<Vec3>& pts) { return floatRows(plyHeader(pts.size(), "ascii"), pts, true); }
std::string plyBinary(const std::vector<Vec3>& pts) {
  return floatRows(plyHeader(pts.size(), "binary_little_endian"), pts, false);
}

std::string xyzText(const std::vector<Vec3>& pts, char sep, const std::string& header) {
  std::ostringstream os;
  os.precision(17);
  if (!header.empty()) os << header << "\n";
  for (const Vec3& p : pts) os << p.x() << sep << p.y() << sep << p.z() << "\n";
  return os.str();
}

std::string las(const std::vector<Vec3>& pts, int minor, const Vec3& offset) {
  const bool v14 = minor >= 4;
  const std::uint16_t header_size = v14 ? 375 : 227;
  const std::uint8_t format = v14 ? 6 : 0;
  const std::uint16_t record = v14 ? 30 : 20;
  std::string h(header_size, '\0');
  std::memcpy(&h[0], "LASF", 4);
  h[24] = 1;
  h[25] = char(minor);
  auto at = [&](std::size_t off, auto v) { std::memcpy(&h[off], &v, sizeof v); };
  at(94, header_size);
  at(96, std::uint32_t(header_size));
  at(104, format);
  at(105, record);
  at(107, std::uint32_t(v14 ? 0 : pts.size()));
  for (int i = 0; i < 3; ++i) {
    at(131 + 8 * std::size_t(i), 0.001);
    at(155 + 8 * std::size_t(i), offset[i]);
  }
  if (v14) at(247, std::uint64_t(pts.size()));
  std::string s = h;
  for (const Vec3& p : pts) {
    std::string rec(record, '\0');
    for (int i = 0; i < 3; ++i) {
      const std::int32_t v = std::int32_t(std::lround((p[i] - offset[i]) / 0.001));
      std::memcpy(&rec[4 * std::size_t(i)], &v, 4);
    }
    s += rec;
  }
  return s;
}

std::string stlBinary(const map::Geometry& m) {
  std::string s(80, '\0');
  put(&s, std::uint32_t(m.triangles.size()));
  for (const auto& t : m.triangles) {
    for (int i = 0; i < 3; ++i) put(&s, 0.0f);
    for (std::uint32_t v : t)
      for (int i = 0; i < 3; ++i) put(&s, float(m.points[v][i]));
    put(&s, std::uint16_t(0));
  }
  return s;
}

std::string stlAscii(const map::Geometry& m) {
  std::ostringstream os;
  os.precision(9);
  os << "solid tube\n";
  for (const auto& t : m.triangles) {
    os << "facet normal 0 0 0\n outer loop\n";
    for (std::uint32_t v : t) os << "  vertex " << m.points[v].x() << " " << m.points[v].y() << " " << m.points[v].z() << "\n";
    os << " endloop\nendfacet\n";
  }
  os << "endsolid tube\n";
  return os.str();
}

std::string objText(const map::Geometry& m) {
  std::ostringstream os;
  os.precision(17);
  for (const Vec3& p : m.points) os << "v " << p.x() << " " << p.y() << " " << p.z() << "\n";
  for (const auto& t : m.triangles) os << "f " << t[0] + 1 << " " << t[1] + 1 << " " << t[2] + 1 << "\n";
  return os.str();
}

}  // namespace adit::test
