// SPDX-License-Identifier: BSD-3-Clause
// ROS map_server YAML text -> isRosMapYaml and parseRosMapYaml.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <string>

#include "adit/map/readers/ros_map.hpp"
#include "fuzz_check.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace adit::map;
  const std::string text(reinterpret_cast<const char*>(data), size);
  (void)isRosMapYaml(text);
  adit::StatusOr<RosMap> m = parseRosMapYaml(text, "fuzz_map.yaml");
  if (!m.ok()) return 0;
  if (m->image.empty() || !(m->resolution_m > 0) || !std::isfinite(m->resolution_m))
    adit::fuzz::broken("map YAML accepted without image or resolution");
  if (!(m->free_thresh >= 0 && m->free_thresh <= m->occupied_thresh && m->occupied_thresh <= 1))
    adit::fuzz::broken("map YAML accepted with thresholds out of order");
  return 0;
}
