// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// Scans and meshes of generated roadways, and their encodings in every import format, so the
// reader and free-space tests build their own inputs (nothing binary is committed).
#include <string>
#include <vector>

#include "adit/map/readers/geometry.hpp"

namespace adit::test {

/// A box-section roadway along x from 0 to `length`, floor at z = 0, walls at y = +-width/2,
/// roof at `height`, ends open; surface points every `spacing`. A window (x0..x1, z0..z1) can be
/// left out of the +y wall to make a scan hole.
struct TubeScan {
  double length = 12.0, width = 4.0, height = 3.0, spacing = 0.1;
  double hole_x0 = 0, hole_x1 = 0, hole_z0 = 0, hole_z1 = 0;
  std::vector<map::Vec3> points() const;
  /// The same walls, floor and roof as 8 triangles (ends open).
  map::Geometry mesh() const;
};

/// An L: the tube along x, then a second leg along +y from its far end (points only).
std::vector<map::Vec3> lScan(double leg = 10.0, double width = 4.0, double height = 3.0, double spacing = 0.1);

// Encoders. Each writes the points exactly as the format stores them (float32 where it does).
std::string pcdAscii(const std::vector<map::Vec3>& pts);
std::string pcdBinary(const std::vector<map::Vec3>& pts);
/// binary_compressed with a valid LZF stream made of literal runs (what a compressor emits for
/// incompressible data), fields laid out one after another as PCL does.
std::string pcdCompressed(const std::vector<map::Vec3>& pts);
std::string plyAscii(const std::vector<map::Vec3>& pts);
std::string plyBinary(const std::vector<map::Vec3>& pts);
std::string xyzText(const std::vector<map::Vec3>& pts, char sep = ' ', const std::string& header = "");
/// LAS 1.2 (point format 0) or 1.4 (format 6, extended count); millimetre scale.
std::string las(const std::vector<map::Vec3>& pts, int minor = 2, const map::Vec3& offset = map::Vec3::Zero());
std::string stlBinary(const map::Geometry& mesh);
std::string stlAscii(const map::Geometry& mesh);
std::string objText(const map::Geometry& mesh);

}  // namespace adit::test
