// SPDX-License-Identifier: BSD-3-Clause
// ROS map image bytes (PGM P2/P5 read by adit, PNG by Open3D) -> decodeRosMapImage, then for a
// small map extrudeRosMap: the image half of `adit map convert map.yaml`. The first byte picks
// negate and the resolution, the rest is the image.
#include <cstddef>
#include <cstdint>
#include <string>

#include "adit/map/readers/ros_map.hpp"
#include "fuzz_check.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace adit::map;
  const adit::fuzz::Selected in = adit::fuzz::select(data, size);
  RosMap m;
  m.resolution_m = (in.selector & 2) ? 0.5 : 0.25;
  m.negate = (in.selector & 1) != 0;
  m.origin_yaw = (in.selector & 4) ? 0.5 : 0.0;
  if (!decodeRosMapImage(in.bytes, "fuzz.img", &m, 1u << 24).ok()) return 0;
  if (m.width <= 0 || m.height <= 0 || m.cells.size() != std::size_t(m.width) * std::size_t(m.height))
    adit::fuzz::broken("image decoded to a size that does not match its cells");
  for (std::int8_t c : m.cells)
    if (c != -1 && c != 0 && c != 100) adit::fuzz::broken("cell neither unknown, free nor occupied");
  ExtrudeOptions o;
  o.height_m = 1.0;
  o.max_voxels = 2'000;  // keeps executions fast
  (void)extrudeRosMap(m, o);
  return 0;
}
