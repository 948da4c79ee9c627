// SPDX-License-Identifier: BSD-3-Clause
#include "common/graph_output.hpp"

#include <dxflib/dl_dxf.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <unistd.h>

#include "adit/map/map_io.hpp"
#include "common/figure.hpp"
#include "common/json_output.hpp"

namespace adit::tools {

using global::RoadwayEdge;
using global::RoadwayGraph;
using map::Vec3;

namespace {

nlohmann::ordered_json point(const Vec3& p) { return mmPoint(p); }

std::string lowerExtension(const std::string& path) {
  std::string ext = std::filesystem::path(path).extension().string();
  for (char& c : ext) c = char(std::tolower(static_cast<unsigned char>(c)));
  return ext;
}

Status writeDxf(const RoadwayGraph& g, const std::string& path) {
  // dxflib writes to a named file: write a private temporary one, then copy it through the
  // atomic writer, so the user's file is never half written.
  char tmpl[] = "/tmp/adit-graph-XXXXXX";
  const int fd = mkstemp(tmpl);
  if (fd < 0) return internalError("cannot create a temporary file for the DXF");
  close(fd);
  const std::string tmp = tmpl;
  {
    DL_Dxf dxf;
    const DL_Codes::version version = DL_Codes::AC1009;  // R12: read by every CAD and GIS tool
    DL_WriterA* dw = dxf.out(tmp.c_str(), version);
    if (!dw) {
      std::remove(tmp.c_str());
      return internalError("dxflib could not open " + tmp);
    }
    dxf.writeHeader(*dw);
    dw->sectionEnd();
    dw->sectionTables();
    dxf.writeVPort(*dw);
    dw->tableLinetypes(1);
    dxf.writeLinetype(*dw, DL_LinetypeData("CONTINUOUS", "Continuous", 0, 0, 0.0));
    dw->tableEnd();
    const char* layers[] = {"0", "PASSAGES", "BLOCKED", "JUNCTIONS", "ENDS", "NAMES"};
    const int colours[] = {7, 3, 1, 5, 2, 7};
    dw->tableLayers(6);
    for (int i = 0; i < 6; ++i)
      dxf.writeLayer(*dw, DL_LayerData(layers[i], 0), DL_Attributes("", colours[i], -1, "CONTINUOUS", 1.0));
    dw->tableEnd();
    dxf.writeStyle(*dw, DL_StyleData("standard", 0, 0.0, 1.0, 0.0, 0, 2.5, "txt", ""));
    dxf.writeView(*dw);
    dxf.writeUcs(*dw);
    dw->tableAppid(1);
    dxf.writeAppid(*dw, "ACAD");
    dw->tableEnd();
    dw->sectionEnd();
    dw->sectionEntities();
    for (const RoadwayEdge& e : g.edges()) {
      const DL_Attributes attr(e.blocked ? "BLOCKED" : "PASSAGES", 256, -1, "BYLAYER", 1.0);
      dxf.writePolyline(*dw, DL_PolylineData(int(e.axis.points.size()), 0, 0, 8 /* 3-D polyline */), attr);
      for (const Vec3& p : e.axis.points) dxf.writeVertex(*dw, DL_VertexData(p.x(), p.y(), p.z(), 0.0));
      dxf.writePolylineEnd(*dw);
      const Vec3 mid = e.axis.points[e.axis.points.size() / 2];
      dxf.writeText(*dw, DL_TextData(mid.x(), mid.y(), mid.z(), 0, 0, 0, 1.0, 1.0, 0, 0, 0, e.roadway, "standard", 0.0),
                    DL_Attributes("NAMES", 256, -1, "BYLAYER", 1.0));
    }
    for (std::size_t n = 0; n < g.nodes().size(); ++n) {
      const int d = g.degree(int(n));
      if (d == 2) continue;
      const Vec3& p = g.nodes()[n].position;
      dxf.writePoint(*dw, DL_PointData(p.x(), p.y(), p.z()),
                     DL_Attributes(d == 1 ? "ENDS" : "JUNCTIONS", 256, -1, "BYLAYER", 1.0));
    }
    dw->sectionEnd();
    dw->dxfEOF();
    dw->close();
    delete dw;
  }
  std::ifstream in(tmp, std::ios::binary);
  std::stringstream body;
  body << in.rdbuf();
  std::remove(tmp.c_str());
  if (!in.good() && !in.eof()) return internalError("could not read back the DXF written by dxflib");
  const std::string text = body.str();
  return map::writeFileAtomically(path, [&](std::ostream& out) { return bool(out << text); });
}

}  // namespace

const char* nodeKind(const RoadwayGraph& g, int node) {
  const int d = g.degree(node);
  return d >= 3 ? "junction" : d == 1 ? "end" : d == 0 ? "isolated" : "node";
}

nlohmann::ordered_json graphJson(const RoadwayGraph& g, const map::DistanceField& field, const GraphContext& c) {
  nlohmann::ordered_json j;
  j["map"] = c.map_path;
  j["source"] = c.source;
  j["robot"] = c.robot;
  j["margin"] = mm(c.margin_m);
  j["required_clearance"] = mm(c.required_clearance_m);
  int junctions = 0, ends = 0;
  nlohmann::ordered_json nodes = nlohmann::ordered_json::array();
  for (std::size_t n = 0; n < g.nodes().size(); ++n) {
    const char* kind = nodeKind(g, int(n));
    junctions += std::string(kind) == "junction";
    ends += std::string(kind) == "end";
    nodes.push_back({{"id", n}, {"name", g.nodes()[n].name}, {"kind", kind}, {"position", point(g.nodes()[n].position)}});
  }
  nlohmann::ordered_json edges = nlohmann::ordered_json::array();
  for (std::size_t e = 0; e < g.edges().size(); ++e) {
    const RoadwayEdge& edge = g.edges()[e];
    const global::PassageMeasure m = global::measurePassage(edge, field);
    nlohmann::ordered_json axis = nlohmann::ordered_json::array();
    for (const Vec3& p : edge.axis.points) axis.push_back(point(p));
    nlohmann::ordered_json item = {{"id", e},
                                   {"name", edge.roadway},
                                   {"from", edge.from},
                                   {"to", edge.to},
                                   {"length", mm(edge.length_m)},
                                   {"min_clearance", mm(m.min_clearance_m)},
                                   {"width", mm(m.width_m)},
                                   {"corridor_radius", mm(edge.radius_m)},
                                   {"max_slope_deg", std::round(edge.max_slope_deg * 10) / 10},
                                   {"blocked", edge.blocked}};
    if (edge.blocked) item["blocked_reason"] = edge.blocked_reason;
    item["axis"] = axis;
    edges.push_back(item);
  }
  j["summary"] = {{"nodes", g.nodes().size()}, {"junctions", junctions}, {"ends", ends},
                  {"edges", g.edges().size()}, {"length", mm(g.totalLength())}};
  if (g.fromFreeSpaceMap()) {
    const global::FreeSpaceGraphInfo& i = g.freeSpaceInfo();
    j["free_space"] = {{"voxels", i.voxels}, {"regions", i.regions}, {"pieces", i.pieces},
                       {"folded_branches", i.folded_branches}, {"memory_bytes", i.memory_bytes},
                       {"build_seconds", us(i.seconds)}};
  }
  j["nodes"] = nodes;
  j["edges"] = edges;
  return stamped("adit.roadway_graph", std::move(j));
}

nlohmann::ordered_json graphGeoJson(const RoadwayGraph& g, const map::DistanceField& field, const GraphContext& c) {
  nlohmann::ordered_json features = nlohmann::ordered_json::array();
  for (const RoadwayEdge& edge : g.edges()) {
    const global::PassageMeasure m = global::measurePassage(edge, field);
    nlohmann::ordered_json coords = nlohmann::ordered_json::array();
    for (const Vec3& p : edge.axis.points) coords.push_back(point(p));
    features.push_back({{"type", "Feature"},
                        {"geometry", {{"type", "LineString"}, {"coordinates", coords}}},
                        {"properties",
                         {{"name", edge.roadway},
                          {"from", g.nodes()[std::size_t(edge.from)].name},
                          {"to", g.nodes()[std::size_t(edge.to)].name},
                          {"length_m", mm(edge.length_m)},
                          {"min_clearance_m", mm(m.min_clearance_m)},
                          {"width_m", mm(m.width_m)},
                          {"blocked", edge.blocked}}}});
  }
  for (std::size_t n = 0; n < g.nodes().size(); ++n) {
    const char* kind = nodeKind(g, int(n));
    if (std::string(kind) == "node") continue;
    features.push_back({{"type", "Feature"},
                        {"geometry", {{"type", "Point"}, {"coordinates", point(g.nodes()[n].position)}}},
                        {"properties", {{"name", g.nodes()[n].name}, {"kind", kind}}}});
  }
  nlohmann::ordered_json j;
  j["type"] = "FeatureCollection";
  // Coordinates are the map's own frame in metres (not WGS84): say so for GIS tools.
  j["name"] = "adit roadway graph of " + c.map_path;
  j["adit"] = {{"schema_version", kSchemaVersion}, {"coordinates", "map frame, metres"}, {"source", c.source},
               {"robot", c.robot}, {"required_clearance", mm(c.required_clearance_m)}};
  j["features"] = features;
  return j;
}

Status writeGraph(const RoadwayGraph& g, const map::DistanceField& field, const GraphContext& c,
                  const std::string& path) {
  const std::string ext = lowerExtension(path);
  if (ext == ".dxf") return writeDxf(g, path);
  nlohmann::ordered_json j;
  if (ext == ".json") j = graphJson(g, field, c);
  else if (ext == ".geojson") j = graphGeoJson(g, field, c);
  else return invalidArgument("--out " + path + ": expected a .json, .geojson or .dxf file");
  const std::string text = j.dump(2) + "\n";
  return map::writeFileAtomically(path, [&](std::ostream& out) { return bool(out << text); });
}

Status drawGraph(const map::OccupancyMap& map, const RoadwayGraph& g, const std::string& title,
                 const std::string& path) {
  TopViewOptions o;
  o.title = title;
  Figure fig(o);
  fig.setMap(&map);
  bool open_legend = false, blocked_legend = false;
  for (const RoadwayEdge& e : g.edges()) {
    const bool first = e.blocked ? !blocked_legend : !open_legend;
    fig.addLine({e.axis.points, e.blocked ? kFigureBlocked : 0x2E86DE, e.blocked ? 3.0 : 2.0, e.blocked, {},
                 first ? (e.blocked ? "blocked passage" : "passage (axis)") : "", ""});
    (e.blocked ? blocked_legend : open_legend) = true;
  }
  bool junction_legend = false, end_legend = false;
  for (std::size_t n = 0; n < g.nodes().size(); ++n) {
    const std::string kind = nodeKind(g, int(n));
    if (kind == "junction") {
      fig.addMarker({g.nodes()[n].position, MarkerShape::kDiamond, 0xF39C12, 9, "", junction_legend ? "" : "junction"});
      junction_legend = true;
    } else if (kind == "end") {
      fig.addMarker({g.nodes()[n].position, MarkerShape::kSquare, 0xFFFFFF, 7, "", end_legend ? "" : "end"});
      end_legend = true;
    }
  }
  // Each passage's number at the middle of its axis (the JSON has the full names and figures).
  for (std::size_t e = 0; e < g.edges().size(); ++e) {
    const RoadwayEdge& edge = g.edges()[e];
    std::string label = edge.roadway;
    const std::string prefix = "passage-";
    if (label.rfind(prefix, 0) == 0) label = label.substr(prefix.size());
    fig.addMarker({edge.axis.points[edge.axis.points.size() / 2], MarkerShape::kCross, 0x2E86DE, 4, label, ""});
  }
  return fig.render(path);
}

}  // namespace adit::tools
