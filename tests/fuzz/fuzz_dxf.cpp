// SPDX-License-Identifier: BSD-3-Clause
// DXF text -> parseDxf (adit's vertex-count pre-check, then dxflib), and for centrelines that
// parse, dxfToSurvey with a default section and, when the network is small, voxelize(): what
// `adit map convert drawing.dxf --section ...` does.
#include <cstddef>
#include <cstdint>
#include <string>

#include "adit/map/readers/dxf.hpp"
#include "adit/map/size_estimate.hpp"
#include "fuzz_check.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace adit::map;
  const std::string bytes(reinterpret_cast<const char*>(data), size);
  adit::StatusOr<DxfContents> dxf = parseDxf(bytes, "fuzz.dxf");
  if (!dxf.ok()) return 0;
  if (dxf->polylines.empty() && dxf->faces.triangles.empty()) adit::fuzz::broken("empty DXF parsed ok");
  if (!dxf->faces.triangles.empty()) adit::fuzz::checkGeometry(dxf->faces);
  if (dxf->polylines.empty()) return 0;
  adit::StatusOr<SurveyNetwork> net = dxfToSurvey(*dxf, DxfSections{}, CrossSection::rectangle(4.0, 3.0), 1.0);
  if (!net.ok() || estimateVoxelizeBytes(*net) > 256.0 * 1024) return 0;  // keeps executions fast
  (void)voxelize(*net);
  return 0;
}
