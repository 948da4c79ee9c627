// SPDX-License-Identifier: BSD-3-Clause
#include "adit/map/readers/dxf.hpp"

#include <dl_creationadapter.h>
#include <dl_dxf.h>
#include <yaml-cpp/yaml.h>

#include <cmath>
#include <sstream>

#include "adit/map/map_io.hpp"
#include "common.hpp"

namespace adit::map {

using namespace readers_internal;

namespace {

class Collector : public DL_CreationAdapter {
 public:
  explicit Collector(std::uint64_t max_items) : max_(max_items) {}
  void addPolyline(const DL_PolylineData& d) override {
    finish();
    open_ = true;
    three_d_ = (d.flags & 8) != 0;
    elevation_ = d.elevation;
    current_ = DxfPolyline{getAttributes().getLayer(), {}, (d.flags & 1) != 0};
  }
  void addVertex(const DL_VertexData& d) override {
    if (!open_) return;
    if (++items_ > max_) { over_ = true; return; }
    current_.points.emplace_back(d.x, d.y, three_d_ ? d.z : elevation_);
  }
  void add3dFace(const DL_3dFaceData& d) override {
    if ((items_ += 4) > max_) { over_ = true; return; }
    const auto base = std::uint32_t(out.faces.points.size());
    for (int i = 0; i < 4; ++i) out.faces.points.emplace_back(d.x[i], d.y[i], d.z[i]);
    out.faces.triangles.push_back({base, base + 1, base + 2});
    // A 3DFACE whose fourth corner repeats the third is a triangle.
    if (Vec3(d.x[3] - d.x[2], d.y[3] - d.y[2], d.z[3] - d.z[2]).norm() > 1e-12)
      out.faces.triangles.push_back({base, base + 2, base + 3});
  }
  void endEntity() override { finish(); }
  void endSequence() override { finish(); }
  void finish() {
    if (open_ && !current_.points.empty()) out.polylines.push_back(std::move(current_));
    open_ = false;
    current_ = {};
  }
  bool overLimit() const { return over_; }
  DxfContents out;

 private:
  std::uint64_t max_, items_ = 0;
  bool over_ = false, open_ = false, three_d_ = false;
  double elevation_ = 0;
  DxfPolyline current_;
};

std::string keyOf(const Vec3& p) {
  std::ostringstream os;
  os << std::llround(p.x() * 1000) << "_" << std::llround(p.y() * 1000) << "_" << std::llround(p.z() * 1000);
  return os.str();
}

// The survey parser validates sections with file:line:column messages; a stub network around
// the user's text lets it do that here (its own keys come after the user's lines).
StatusOr<SurveyNetwork> parseWithStub(const std::string& text, const std::string& name, const std::string& section,
                                      bool has_resolution) {
  const std::string stub = std::string(has_resolution ? "" : "\nresolution: 0.2") + "\nstations: {adit_dxf_a: [0, 0, 0], adit_dxf_b: [1, 0, 0]}\n"
                           "roadways: [{name: adit_dxf, stations: [adit_dxf_a, adit_dxf_b], section: " + section + "}]\n";
  return parseSurvey(text + stub, name);
}

// dxflib sizes an LWPOLYLINE's vertex buffer from its group 90 before reading any vertex: a count
// the file cannot hold (each vertex takes at least two group pairs, ~8 bytes) is refused first.
Status checkVertexCounts(const std::string& b, const std::string& name) {
  std::istringstream in(b);
  std::string code, value;
  std::uint64_t line = 0;
  bool in_lw = false;
  while (std::getline(in, code) && std::getline(in, value)) {
    line += 2;
    const auto trim = [](std::string& t) {
      while (!t.empty() && (t.back() == '\r' || t.back() == ' ')) t.pop_back();
      t.erase(0, t.find_first_not_of(' '));
    };
    trim(code);
    trim(value);
    if (code == "0") in_lw = value == "LWPOLYLINE";
    if (!in_lw || code != "90") continue;
    char* end = nullptr;
    const double n = std::strtod(value.c_str(), &end);
    if (end == value.c_str() || !(n >= 0) || n > double(b.size()) / 8)
      return invalidArgument(atLine(name, line) + ": LWPOLYLINE announces " + value +
                             " vertices, more than the file (" + std::to_string(b.size()) + " bytes) can hold");
  }
  return {};
}

}  // namespace

StatusOr<DxfContents> parseDxf(const std::string& bytes, const std::string& name, const ReadLimits& limits) {
  if (bytes.empty()) return invalidArgument(name + ": empty file");
  if (bytes.compare(0, 22, "AutoCAD Binary DXF\r\n\x1a") == 0)
    return invalidArgument(name + ": binary DXF is not supported, save it as ASCII DXF");
  ADIT_RETURN_IF_ERROR(checkVertexCounts(bytes, name));
  Collector c(limits.max_points);
  std::istringstream in(bytes);
  DL_Dxf dxf;
  try {
    dxf.in(in, &c);
  } catch (const std::exception& e) {
    return invalidArgument(name + ": cannot read the DXF: " + e.what());
  }
  c.finish();
  if (c.overLimit()) return outOfRange(name + ": more than " + std::to_string(limits.max_points) + " vertices");
  if (c.out.polylines.empty() && c.out.faces.triangles.empty())
    return invalidArgument(name + ": no LWPOLYLINE/POLYLINE centrelines or 3DFACE faces in the DXF");
  for (const DxfPolyline& p : c.out.polylines) {
    if (firstNonFinite(p.points) >= 0)
      return invalidArgument(name + ": a polyline on layer '" + p.layer + "' has a non-finite vertex");
  }
  if (firstNonFinite(c.out.faces.points) >= 0) return invalidArgument(name + ": a 3DFACE has a non-finite corner");
  return std::move(c.out);
}

StatusOr<DxfContents> readDxf(const std::string& path, const ReadLimits& limits) {
  ADIT_ASSIGN_OR_RETURN(std::string bytes, readFile(path));
  return parseDxf(bytes, path, limits);
}

StatusOr<DxfSections> parseDxfSections(const std::string& text, const std::string& name) {
  // The first section named in the file feeds the stub roadway.
  YAML::Node root;
  try {
    root = YAML::Load(text);
  } catch (const YAML::Exception&) {
    return parseSurvey(text, name).status();  // the survey parser words the syntax error
  }
  const YAML::Node secs = root.IsMap() ? root["sections"] : YAML::Node();
  if (!secs || !secs.IsMap() || secs.size() == 0)
    return invalidArgument(name + ": expected a 'sections:' mapping of layer names to cross-sections");
  // A YAML key can be a sequence or mapping ("? [a, b]"); as<std::string>() would throw on it.
  const YAML::Node first_key = secs.begin()->first;
  if (!first_key.IsScalar())
    return invalidArgument(name + ":" + std::to_string(first_key.Mark().line + 1) +
                           ": sections: a layer name must be a plain string (quote it)");
  const std::string first = first_key.Scalar();
  ADIT_ASSIGN_OR_RETURN(SurveyNetwork net, parseWithStub(text, name, first, bool(root["resolution"])));
  DxfSections s;
  s.by_layer = net.sections;
  if (root["resolution"]) s.resolution_m = net.resolution_m;
  if (root["rock_shell"]) s.rock_shell_m = net.rock_shell_m;
  return s;
}

StatusOr<CrossSection> parseSectionSpec(const std::string& spec) {
  ADIT_ASSIGN_OR_RETURN(SurveyNetwork net, parseWithStub("sections:\n  default: " + spec + "\n", "--section", "default", false));
  return net.sections.at("default");
}

StatusOr<SurveyNetwork> dxfToSurvey(const DxfContents& dxf, const DxfSections& sections,
                                    const std::optional<CrossSection>& default_section, double resolution_m) {
  if (dxf.polylines.empty()) return invalidArgument("the DXF has no centreline polylines");
  SurveyNetwork net;
  net.resolution_m = sections.resolution_m.value_or(resolution_m);
  if (sections.rock_shell_m) net.rock_shell_m = *sections.rock_shell_m;
  std::map<std::string, std::string> station_at;  // coordinate key -> station name
  for (std::size_t i = 0; i < dxf.polylines.size(); ++i) {
    const DxfPolyline& pl = dxf.polylines[i];
    const std::string layer = pl.layer.empty() ? "0" : pl.layer;
    if (!net.sections.count(layer)) {
      auto it = sections.by_layer.find(layer);
      if (it != sections.by_layer.end()) net.sections.emplace(layer, it->second);
      else if (default_section) net.sections.emplace(layer, *default_section);
      else
        return invalidArgument("layer '" + layer + "' has centrelines but no cross-section: add it to the sections "
                               "YAML or give --section");
    }
    SurveyRoadway road;
    road.name = layer + "#" + std::to_string(i + 1);
    road.section = layer;
    for (const Vec3& p : pl.points) {
      auto [it, inserted] = station_at.try_emplace(keyOf(p), "P" + std::to_string(station_at.size() + 1));
      if (inserted) net.stations.emplace(it->second, p);
      if (road.stations.empty() || road.stations.back() != it->second) road.stations.push_back(it->second);
    }
    if (pl.closed && road.stations.size() > 2) road.stations.push_back(road.stations.front());
    if (road.stations.size() < 2)
      return invalidArgument("polyline " + std::to_string(i + 1) + " on layer '" + layer + "' has fewer than two distinct vertices");
    net.roadways.push_back(std::move(road));
  }
  ADIT_RETURN_IF_ERROR(net.validate());
  return net;
}

}  // namespace adit::map
