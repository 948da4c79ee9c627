// SPDX-License-Identifier: BSD-3-Clause
// OctoMap .bt and .ot bytes -> parseOctomap, and what `adit map info|query` do with a map that
// loads: statistics, the size estimates, the footprint estimate and (when small) a distance field.
#include <cstddef>
#include <cstdint>
#include <string>

#include "adit/map/distance_field.hpp"
#include "adit/map/map_io.hpp"
#include "adit/map/map_summary.hpp"
#include "adit/map/size_estimate.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace adit::map;
  const std::string bytes(reinterpret_cast<const char*>(data), size);
  // The policy comes from the input's last byte so both paths of the distance field are reached.
  const UnknownPolicy policy = size > 0 && (data[size - 1] & 1) ? UnknownPolicy::kFree : UnknownPolicy::kRock;
  adit::StatusOr<OccupancyMap> map = parseOctomap(bytes, "fuzz.bt", policy, std::uint64_t{256} << 20);
  if (!map.ok()) return 0;
  (void)map->stats();
  (void)estimateRoadwayLength(*map, 1e6);
  const DistanceFieldEstimate e = estimateDistanceField(*map);
  if (e.tiles > 0 && e.bytes < 4.0 * (1 << 20)) {  // ~120 tiles: keeps executions fast
    adit::StatusOr<DistanceField> df = DistanceField::build(*map, {}, 2048);
    if (df.ok()) (void)df->query(map->bounds().center());
  }
  return 0;
}
