// SPDX-License-Identifier: BSD-3-Clause
// Scanner trajectory text (x,y,z / 7 columns / TUM 8 columns / header row) -> parseTrajectory.
#include <cstddef>
#include <cstdint>
#include <string>

#include "adit/map/readers/import.hpp"
#include "fuzz_check.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string bytes(reinterpret_cast<const char*>(data), size);
  adit::StatusOr<std::vector<adit::map::Vec3>> poses = adit::map::parseTrajectory(bytes, "fuzz_trajectory.csv");
  if (!poses.ok()) return 0;
  if (poses->empty()) adit::fuzz::broken("trajectory parsed ok without poses");
  for (const adit::map::Vec3& p : *poses)
    if (!p.allFinite()) adit::fuzz::broken("non-finite pose in an ok result");
  return 0;
}
