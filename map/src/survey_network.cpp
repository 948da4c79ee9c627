// SPDX-License-Identifier: BSD-3-Clause
// Survey YAML parsing and validation. yaml-cpp stays in this file.
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <set>
#include <sstream>

#include "adit/map/file_io.hpp"
#include "adit/map/size_estimate.hpp"
#include "adit/map/survey_network.hpp"

namespace adit::map {

namespace {

// Every error names the file, the 1-based line and column, and the field path.
class Reporter {
 public:
  explicit Reporter(std::string file) : file_(std::move(file)) {}
  Status error(const YAML::Node& node, const std::string& field, const std::string& what) const {
    std::ostringstream os;
    os << file_;
    const YAML::Mark m = node.Mark();
    if (!m.is_null()) os << ":" << m.line + 1 << ":" << m.column + 1;
    os << ": " << field << ": " << what;
    return invalidArgument(os.str());
  }
  const std::string& file() const { return file_; }

 private:
  std::string file_;
};

const char* kindName(const YAML::Node& n) {
  switch (n.Type()) {
    case YAML::NodeType::Null: return "nothing";
    case YAML::NodeType::Scalar: return "a scalar";
    case YAML::NodeType::Sequence: return "a list";
    case YAML::NodeType::Map: return "a mapping";
    default: return "undefined";
  }
}

StatusOr<double> readNumber(const Reporter& r, const YAML::Node& n, const std::string& field) {
  if (!n.IsScalar()) return r.error(n, field, std::string("expected a number, got ") + kindName(n));
  double v = 0;
  if (!YAML::convert<double>::decode(n, v))
    return r.error(n, field, "expected a number, got '" + n.Scalar() + "'");
  if (!std::isfinite(v)) return r.error(n, field, "must be finite, got '" + n.Scalar() + "'");
  return v;
}

StatusOr<std::string> readString(const Reporter& r, const YAML::Node& n, const std::string& field) {
  if (!n.IsScalar() || n.Scalar().empty())
    return r.error(n, field, std::string("expected a non-empty name, got ") + kindName(n));
  return n.Scalar();
}

// Iterates a mapping, refusing duplicate keys (yaml-cpp keeps them silently) and, when
// `allowed` is given, keys outside it (a typo in a field name must not pass unnoticed).
Status forEachEntry(const Reporter& r, const YAML::Node& map, const std::string& field,
                    const std::set<std::string>* allowed,
                    const std::function<Status(const std::string&, const YAML::Node&, const YAML::Node&)>& fn) {
  if (!map.IsMap()) return r.error(map, field, std::string("expected a mapping, got ") + kindName(map));
  std::set<std::string> seen;
  for (auto it = map.begin(); it != map.end(); ++it) {
    if (!it->first.IsScalar()) return r.error(it->first, field, "keys must be plain names");
    const std::string key = it->first.Scalar();
    if (!seen.insert(key).second) return r.error(it->first, field + "." + key, "duplicate key '" + key + "'");
    if (allowed && !allowed->count(key)) {
      std::string list;
      for (const auto& a : *allowed) list += (list.empty() ? "" : ", ") + a;
      return r.error(it->first, field + "." + key, "unknown field '" + key + "' (expected one of: " + list + ")");
    }
    ADIT_RETURN_IF_ERROR(fn(key, it->first, it->second));
  }
  return {};
}

StatusOr<CrossSection> parseSection(const Reporter& r, const YAML::Node& n, const std::string& field) {
  if (!n.IsMap()) return r.error(n, field, std::string("expected a mapping, got ") + kindName(n));
  const YAML::Node shape_node = n["shape"];
  if (!shape_node) return r.error(n, field, "missing 'shape' (arch, rectangle, trapezoid, three_centred_arch)");
  StatusOr<std::string> shape = readString(r, shape_node, field + ".shape");
  if (!shape.ok()) return shape.status();
  std::set<std::string> allowed{"shape"};
  std::vector<std::string> needed;
  if (*shape == "arch") needed = {"width", "wall_height"};
  else if (*shape == "rectangle") needed = {"width", "height"};
  else if (*shape == "trapezoid") needed = {"bottom_width", "top_width", "height"};
  else if (*shape == "three_centred_arch" || *shape == "three_centered_arch") needed = {"width", "wall_height", "rise"};
  else
    return r.error(shape_node, field + ".shape",
                   "unknown shape '" + *shape + "' (arch, rectangle, trapezoid, three_centred_arch)");
  allowed.insert(needed.begin(), needed.end());
  std::map<std::string, double> values;
  std::map<std::string, YAML::Node> nodes;
  ADIT_RETURN_IF_ERROR(forEachEntry(r, n, field, &allowed,
      [&](const std::string& key, const YAML::Node&, const YAML::Node& value) -> Status {
        if (key == "shape") return {};
        StatusOr<double> v = readNumber(r, value, field + "." + key);
        if (!v.ok()) return v.status();
        values[key] = *v;
        nodes[key] = value;
        return {};
      }));
  for (const std::string& k : needed)
    if (!values.count(k)) return r.error(n, field, "missing '" + k + "' for shape " + *shape);
  CrossSection s;
  if (*shape == "arch") s = CrossSection::arch(values["width"], values["wall_height"]);
  else if (*shape == "rectangle") s = CrossSection::rectangle(values["width"], values["height"]);
  else if (*shape == "trapezoid") s = CrossSection::trapezoid(values["bottom_width"], values["top_width"], values["height"]);
  else s = CrossSection::threeCentredArch(values["width"], values["wall_height"], values["rise"]);
  Status v = s.validate();
  if (!v.ok()) {
    // Point at the field the message names, when we can tell which.
    for (const std::string& k : needed)
      if (v.message().find(": " + k + " =") != std::string::npos) return r.error(nodes[k], field + "." + k, v.message());
    return r.error(n, field, v.message());
  }
  return s;
}

}  // namespace

StatusOr<SurveyNetwork> parseSurvey(const std::string& text, const std::string& name) {
  const Reporter r(name);
  YAML::Node root;
  try {
    root = YAML::Load(text);
  } catch (const YAML::ParserException& e) {
    std::ostringstream os;
    os << name << ":" << e.mark.line + 1 << ":" << e.mark.column + 1 << ": YAML error: " << e.msg;
    return invalidArgument(os.str());
  } catch (const std::exception& e) {
    return invalidArgument(name + ": YAML error: " + e.what());
  }
  if (!root || root.IsNull()) return invalidArgument(name + ": empty file: expected a survey network");
  SurveyNetwork net;
  const std::set<std::string> top{"name", "description", "resolution", "rock_shell", "stations", "sections", "roadways"};
  YAML::Node stations_node, sections_node, roadways_node;
  Status st = forEachEntry(r, root, "(top level)", &top,
      [&](const std::string& key, const YAML::Node&, const YAML::Node& value) -> Status {
        if (key == "name" || key == "description") {
          if (!value.IsScalar()) return r.error(value, key, "expected text");
          if (key == "name") net.name = value.Scalar();
        } else if (key == "resolution") {
          StatusOr<double> v = readNumber(r, value, key);
          if (!v.ok()) return v.status();
          Status rs = checkResolution(*v);
          if (!rs.ok()) return r.error(value, key, rs.message());
          net.resolution_m = *v;
        } else if (key == "rock_shell") {
          StatusOr<double> v = readNumber(r, value, key);
          if (!v.ok()) return v.status();
          if (*v < 0 || *v > 100) return r.error(value, key, "must be within [0, 100] m");
          net.rock_shell_m = *v;
        } else if (key == "stations") {
          stations_node = value;
        } else if (key == "sections") {
          sections_node = value;
        } else {
          roadways_node = value;
        }
        return {};
      });
  if (!st.ok()) return st;
  if (!root["resolution"]) return r.error(root, "resolution", "missing (voxel edge in metres, e.g. 0.2)");
  if (!stations_node) return r.error(root, "stations", "missing");
  if (!sections_node) return r.error(root, "sections", "missing");
  if (!roadways_node) return r.error(root, "roadways", "missing");

  std::map<std::string, YAML::Node> station_nodes;
  ADIT_RETURN_IF_ERROR(forEachEntry(r, stations_node, "stations", nullptr,
      [&](const std::string& id, const YAML::Node&, const YAML::Node& value) -> Status {
        const std::string field = "stations." + id;
        if (!value.IsSequence() || value.size() != 3)
          return r.error(value, field, "expected [x, y, z] (three numbers, metres)");
        Vec3 p;
        for (int i = 0; i < 3; ++i) {
          StatusOr<double> v = readNumber(r, value[i], field + "[" + std::to_string(i) + "]");
          if (!v.ok()) return v.status();
          p[i] = *v;
        }
        net.stations[id] = p;
        station_nodes[id] = value;
        return {};
      }));
  if (net.stations.empty()) return r.error(stations_node, "stations", "no stations given");

  ADIT_RETURN_IF_ERROR(forEachEntry(r, sections_node, "sections", nullptr,
      [&](const std::string& id, const YAML::Node&, const YAML::Node& value) -> Status {
        StatusOr<CrossSection> s = parseSection(r, value, "sections." + id);
        if (!s.ok()) return s.status();
        net.sections[id] = *s;
        return {};
      }));
  if (net.sections.empty()) return r.error(sections_node, "sections", "no sections given");

  if (!roadways_node.IsSequence() || roadways_node.size() == 0)
    return r.error(roadways_node, "roadways", "expected a non-empty list of roadways");
  std::set<std::string> roadway_names;
  const std::set<std::string> roadway_fields{"name", "stations", "section"};
  for (std::size_t i = 0; i < roadways_node.size(); ++i) {
    const YAML::Node rn = roadways_node[i];
    const std::string field = "roadways[" + std::to_string(i) + "]";
    SurveyRoadway road;
    ADIT_RETURN_IF_ERROR(forEachEntry(r, rn, field, &roadway_fields,
        [&](const std::string& key, const YAML::Node&, const YAML::Node& value) -> Status {
          if (key == "name") {
            StatusOr<std::string> s = readString(r, value, field + ".name");
            if (!s.ok()) return s.status();
            road.name = *s;
          } else if (key == "section") {
            StatusOr<std::string> s = readString(r, value, field + ".section");
            if (!s.ok()) return s.status();
            if (!net.sections.count(*s)) return r.error(value, field + ".section", "unknown section '" + *s + "'");
            road.section = *s;
          } else {
            if (!value.IsSequence() || value.size() < 2)
              return r.error(value, field + ".stations", "expected a list of at least two station ids");
            for (std::size_t k = 0; k < value.size(); ++k) {
              StatusOr<std::string> s = readString(r, value[k], field + ".stations[" + std::to_string(k) + "]");
              if (!s.ok()) return s.status();
              if (!net.stations.count(*s))
                return r.error(value[k], field + ".stations[" + std::to_string(k) + "]", "unknown station '" + *s + "'");
              if (!road.stations.empty() && road.stations.back() == *s)
                return r.error(value[k], field + ".stations[" + std::to_string(k) + "]", "station '" + *s + "' repeated");
              road.stations.push_back(*s);
            }
          }
          return {};
        }));
    if (road.name.empty()) road.name = "roadway-" + std::to_string(i + 1);
    if (!rn["stations"]) return r.error(rn, field, "missing 'stations'");
    if (!rn["section"]) return r.error(rn, field, "missing 'section'");
    if (!roadway_names.insert(road.name).second)
      return r.error(rn["name"] ? rn["name"] : rn, field + ".name", "duplicate roadway name '" + road.name + "'");
    // A vertical segment has no horizontal direction to sweep a section along.
    for (std::size_t k = 1; k < road.stations.size(); ++k) {
      const Vec3 d = net.stations[road.stations[k]] - net.stations[road.stations[k - 1]];
      if (d.head<2>().norm() < 1e-6)
        return r.error(rn["stations"][k], field + ".stations[" + std::to_string(k) + "]",
                       "stations '" + road.stations[k - 1] + "' and '" + road.stations[k] +
                           "' are vertically aligned; shafts are not supported");
    }
    net.roadways.push_back(std::move(road));
  }
  Status v = net.validate();
  if (!v.ok()) return Status(v.code(), name + ": " + v.message());
  return net;
}

StatusOr<SurveyNetwork> loadSurvey(const std::string& path, std::uint64_t max_memory_bytes) {
  StatusOr<std::string> text = readFile(path, std::min<std::uint64_t>(std::uint64_t{256} << 20, max_memory_bytes));
  if (!text.ok()) return text.status();
  ADIT_RETURN_IF_ERROR(MemoryBudget{max_memory_bytes}.check(
      estimateSurveyParseBytes(*text), path + ": parsing the survey (" + std::to_string(text->size()) + " bytes of YAML)",
      "split the network into several files or raise --max-memory"));
  return parseSurvey(*text, path);
}

namespace {

// Part [t0, t1] of the segment a + t (b - a), t in [0, 1], inside `box` (Liang-Barsky).
bool clipSegment(const Vec3& a, const Vec3& b, const Aabb& box, double* t0, double* t1) {
  *t0 = 0;
  *t1 = 1;
  const Vec3 d = b - a;
  for (int k = 0; k < 3; ++k) {
    if (std::abs(d[k]) < 1e-12) {
      if (a[k] < box.min[k] || a[k] > box.max[k]) return false;
      continue;
    }
    double lo = (box.min[k] - a[k]) / d[k], hi = (box.max[k] - a[k]) / d[k];
    if (lo > hi) std::swap(lo, hi);
    *t0 = std::max(*t0, lo);
    *t1 = std::min(*t1, hi);
    if (*t0 > *t1) return false;
  }
  return true;
}

}  // namespace

StatusOr<SurveyNetwork> cropNetwork(const SurveyNetwork& net, const Aabb& box) {
  if (!allFinite(box.min) || !allFinite(box.max) || box.empty())
    return invalidArgument("crop box must be finite with min <= max");
  SurveyNetwork out;
  out.name = net.name;
  out.resolution_m = net.resolution_m;
  out.rock_shell_m = net.rock_shell_m;
  out.sections = net.sections;
  int cuts = 0;
  for (const SurveyRoadway& road : net.roadways) {
    const CrossSection& s = net.sections.at(road.section);
    // Whatever a centreline point can reach: its section (any tilt), the shell, a voxel's rounding.
    const double reach = std::hypot(0.5 * s.maxWidth(), s.height()) + net.rock_shell_m + 2 * net.resolution_m;
    const Aabb grown = box.inflated(reach);
    std::vector<SurveyRoadway> runs;
    bool open = false;
    for (std::size_t k = 1; k < road.stations.size(); ++k) {
      const std::string &ia = road.stations[k - 1], &ib = road.stations[k];
      const Vec3 &a = net.stations.at(ia), &b = net.stations.at(ib);
      double t0 = 0, t1 = 1;
      if (!clipSegment(a, b, grown, &t0, &t1) || (b - a).head<2>().norm() * (t1 - t0) < 1e-3) {
        open = false;
        continue;
      }
      // A long segment is cut at the grown box, so that only the part near the box is voxelized.
      auto station = [&](const std::string& id, double t) {
        if (t == 0.0 || t == 1.0) {
          out.stations[id] = net.stations.at(id);
          return id;
        }
        const std::string cut = id + "#cut" + std::to_string(++cuts);
        out.stations[cut] = a + t * (b - a);
        return cut;
      };
      const std::string from = station(ia, t0), to = station(ib, t1);
      if (!open || t0 > 0.0) runs.push_back({road.name, {from}, road.section});
      runs.back().stations.push_back(to);
      open = t1 == 1.0;
    }
    for (std::size_t i = 0; i < runs.size(); ++i) {
      if (runs.size() > 1) runs[i].name += "/" + std::to_string(i + 1);
      out.roadways.push_back(std::move(runs[i]));
    }
  }
  if (out.roadways.empty()) return failedPrecondition("crop box reaches no roadway of the survey network");
  return out;
}

Status SurveyNetwork::validate() const {
  ADIT_RETURN_IF_ERROR(checkResolution(resolution_m));
  if (!std::isfinite(rock_shell_m) || rock_shell_m < 0) return invalidArgument("rock_shell must be finite and >= 0");
  if (roadways.empty()) return invalidArgument("no roadways");
  for (const auto& [id, p] : stations)
    if (!allFinite(p)) return invalidArgument("station '" + id + "' has a non-finite coordinate");
  for (const auto& [id, s] : sections) {
    Status st = s.validate();
    if (!st.ok()) return invalidArgument("section '" + id + "': " + st.message());
  }
  for (const SurveyRoadway& road : roadways) {
    if (!sections.count(road.section)) return invalidArgument("roadway '" + road.name + "': unknown section '" + road.section + "'");
    if (road.stations.size() < 2) return invalidArgument("roadway '" + road.name + "': needs at least two stations");
    for (const std::string& s : road.stations)
      if (!stations.count(s)) return invalidArgument("roadway '" + road.name + "': unknown station '" + s + "'");
    for (std::size_t k = 1; k < road.stations.size(); ++k) {
      // A vertical (or zero-length) segment has no horizontal direction to sweep a section along.
      const Vec3 d = stations.at(road.stations[k]) - stations.at(road.stations[k - 1]);
      if (d.head<2>().norm() < 1e-6)
        return invalidArgument("roadway '" + road.name + "': stations '" + road.stations[k - 1] + "' and '" +
                               road.stations[k] + "' are vertically aligned or repeated; shafts are not supported");
    }
  }
  Status extent = checkExtent(bounds(), resolution_m);
  if (!extent.ok()) return Status(extent.code(), extent.message());
  if (estimatedVoxels() > 3e9) {
    std::ostringstream os;
    os << "the network would need about " << estimatedVoxels() << " voxels at resolution " << resolution_m
       << " m; use a coarser resolution";
    return outOfRange(os.str());
  }
  return {};
}

Polyline SurveyNetwork::centreline(const SurveyRoadway& roadway) const {
  Polyline line;
  for (const std::string& s : roadway.stations) line.points.push_back(stations.at(s));
  return line;
}

double SurveyNetwork::totalLength() const {
  double total = 0;
  for (const SurveyRoadway& road : roadways) total += centreline(road).length();
  return total;
}

Aabb SurveyNetwork::bounds() const {
  Aabb box;
  for (const SurveyRoadway& road : roadways) {
    const CrossSection& s = sections.at(road.section);
    // Sections are swept square to the centreline, so an inclined roadway's roof leans back
    // horizontally by height * sin(slope).
    double max_sin = 0;
    for (std::size_t k = 1; k < road.stations.size(); ++k) {
      const Vec3 d = stations.at(road.stations[k]) - stations.at(road.stations[k - 1]);
      max_sin = std::max(max_sin, std::abs(d.z()) / d.norm());
    }
    const double grow = std::max(0.5 * s.maxWidth(), s.height() * max_sin) + rock_shell_m + resolution_m;
    for (const std::string& id : road.stations) {
      const Vec3& p = stations.at(id);
      box.extend(Vec3(p.x() - grow, p.y() - grow, p.z() - rock_shell_m - resolution_m));
      box.extend(Vec3(p.x() + grow, p.y() + grow, p.z() + s.height() + rock_shell_m + resolution_m));
    }
  }
  return box;
}

double SurveyNetwork::estimatedVoxels() const {
  const double v3 = resolution_m * resolution_m * resolution_m;
  double total = 0;
  for (const SurveyRoadway& road : roadways) {
    const CrossSection& s = sections.at(road.section);
    const double outer = (s.maxWidth() + 2 * rock_shell_m + 2 * resolution_m) * (s.height() + 2 * rock_shell_m + 2 * resolution_m);
    total += (centreline(road).length() + s.maxWidth()) * outer / v3;
  }
  return total;
}

}  // namespace adit::map
