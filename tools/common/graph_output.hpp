// SPDX-License-Identifier: BSD-3-Clause
#pragma once
/// @file
/// `adit map graph`'s outputs: the roadway network adit routes on, for a surveyor to check and
/// load into the tools they use. JSON (nodes with kind and position; edges with name, ends,
/// length, corridor radius, narrowest clearance, width, blocked state and axis), GeoJSON (a
/// FeatureCollection of LineStrings for the passages and Points for junctions and ends, in the
/// map's own metres), DXF (3-D polylines on layer PASSAGES, points and names on JUNCTIONS / ENDS /
/// NAMES) and the top-view picture drawn with the one Figure renderer.

#include <nlohmann/json.hpp>

#include <string>

#include "adit/global/roadway_graph.hpp"
#include "adit/map/distance_field.hpp"
#include "adit/map/occupancy_map.hpp"
#include "adit/status.hpp"

namespace adit::tools {

/// What the graph was built for, written with it.
struct GraphContext {
  std::string map_path;
  std::string source;  ///< "survey" or "free_space"
  std::string robot;   ///< e.g. "sphere:0.4"
  double margin_m = 0.0;
  double required_clearance_m = 0.0;
};

/// "junction" (3 or more passages), "end" (one), "node" (two, e.g. a survey station).
const char* nodeKind(const global::RoadwayGraph& g, int node);

nlohmann::ordered_json graphJson(const global::RoadwayGraph& g, const map::DistanceField& field,
                                 const GraphContext& context);
nlohmann::ordered_json graphGeoJson(const global::RoadwayGraph& g, const map::DistanceField& field,
                                    const GraphContext& context);
/// By extension: .json, .geojson, .dxf; written atomically.
Status writeGraph(const global::RoadwayGraph& g, const map::DistanceField& field, const GraphContext& context,
                  const std::string& path);
/// The top view with every passage (blocked ones dashed red), junctions, ends and passage numbers.
Status drawGraph(const map::OccupancyMap& map, const global::RoadwayGraph& g, const std::string& title,
                 const std::string& path);

}  // namespace adit::tools
