// SPDX-License-Identifier: BSD-3-Clause
#pragma once
/// @file
/// DXF drawings of a mine (read with dxflib): roadway centrelines as LWPOLYLINE (at its
/// elevation) or POLYLINE (3-D vertices), one cross-section per layer, voxelized exactly like a
/// survey network (the polyline vertices are stations on the roadway floor; polylines that meet
/// at a vertex share the station, so junctions are rounded as in the survey). 3DFACE entities
/// form a triangle mesh instead (free space then needs a seed, as for any mesh).
///
/// Sections come from a small YAML in the survey schema, named by layer:
///   resolution: 0.2            # optional
///   rock_shell: 0.6            # optional
///   sections:
///     MAIN:  {shape: arch, width: 5.0, wall_height: 3.0}
///     DRIFT: {shape: rectangle, width: 4.0, height: 3.0}
/// and/or one default for every other layer from the command line (the same flow mapping).

#include <map>
#include <optional>
#include <string>

#include "adit/map/readers/geometry.hpp"
#include "adit/map/survey_network.hpp"

namespace adit::map {

struct DxfPolyline {
  std::string layer;
  std::vector<Vec3> points;
  bool closed = false;
};

struct DxfContents {
  std::vector<DxfPolyline> polylines;
  Geometry faces;  ///< 3DFACE triangles
};

StatusOr<DxfContents> parseDxf(const std::string& bytes, const std::string& name, const ReadLimits& limits = {});
StatusOr<DxfContents> readDxf(const std::string& path, const ReadLimits& limits = {});

/// Cross-sections by layer name, with the optional resolution and rock shell.
struct DxfSections {
  std::map<std::string, CrossSection> by_layer;
  std::optional<double> resolution_m, rock_shell_m;
};
/// The YAML above; errors name the file, line and field (the survey parser checks each section).
StatusOr<DxfSections> parseDxfSections(const std::string& yaml_text, const std::string& name);
/// One section as a YAML flow mapping, e.g. "{shape: rectangle, width: 4, height: 3}".
StatusOr<CrossSection> parseSectionSpec(const std::string& spec);

/// Centrelines -> survey network (stations merged where polylines meet, to 1 mm). Every layer
/// with a polyline needs a section, from `sections` or `default_section`; the error names the layer.
StatusOr<SurveyNetwork> dxfToSurvey(const DxfContents& dxf, const DxfSections& sections,
                                    const std::optional<CrossSection>& default_section, double resolution_m);

}  // namespace adit::map
