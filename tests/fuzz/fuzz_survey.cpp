// SPDX-License-Identifier: BSD-3-Clause
// Survey YAML text -> parseSurvey, and for a network that parses and is small, voxelize(): what
// `adit map info maps/x.yaml` does.
#include <cstddef>
#include <cstdint>
#include <string>

#include "adit/map/size_estimate.hpp"
#include "adit/map/survey_network.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace adit::map;
  const std::string text(reinterpret_cast<const char*>(data), size);
  if (estimateSurveyParseBytes(text) > 256.0 * (1 << 20)) return 0;
  adit::StatusOr<SurveyNetwork> net = parseSurvey(text, "fuzz.yaml");
  if (!net.ok()) return 0;
  (void)net->totalLength();
  if (estimateVoxelizeBytes(*net) > 2.0 * (1 << 20)) return 0;  // ~45k voxels: keeps executions fast
  (void)voxelize(*net);
  return 0;
}
