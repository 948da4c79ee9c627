// SPDX-License-Identifier: BSD-3-Clause
#include "adit/global/roadway_graph.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <map>
#include <queue>
#include <sstream>
#include <unordered_map>

#include "free_space_index.hpp"
#include "geometry.hpp"

namespace adit::global {

using map::Aabb;
using map::Polyline;

int RoadwayGraph::addNode(const Vec3& position, const std::string& name) {
  nodes_.push_back({position, name});
  incident_.emplace_back();
  return int(nodes_.size()) - 1;
}

int RoadwayGraph::addEdge(int from, int to, const std::string& roadway, Polyline axis, double radius_m,
                          double half_height_m) {
  RoadwayEdge e;
  e.from = from;
  e.to = to;
  e.roadway = roadway;
  e.radius_m = radius_m;
  e.half_height_m = half_height_m;
  e.length_m = axis.length();
  for (std::size_t i = 0; i + 1 < axis.points.size(); ++i) {
    const Vec3 d = axis.points[i + 1] - axis.points[i];
    const double run = d.head<2>().norm();
    const double slope = std::atan2(std::abs(d.z()), run) * 180.0 / M_PI;
    e.max_slope_deg = std::max(e.max_slope_deg, slope);
  }
  e.axis = std::move(axis);
  edges_.push_back(std::move(e));
  const int id = int(edges_.size()) - 1;
  incident_[std::size_t(from)].push_back(id);
  if (to != from) incident_[std::size_t(to)].push_back(id);
  return id;
}

double RoadwayGraph::totalLength() const {
  double sum = 0;
  for (const RoadwayEdge& e : edges_) sum += e.length_m;
  return sum;
}

std::vector<int> RoadwayGraph::ends() const {
  std::vector<int> out;
  for (std::size_t i = 0; i < nodes_.size(); ++i)
    if (incident_[i].size() == 1) out.push_back(int(i));
  return out;
}

int RoadwayGraph::farthestAlongGraph(int from) const {
  std::vector<double> dist(nodes_.size(), std::numeric_limits<double>::infinity());
  using Item = std::pair<double, int>;
  std::priority_queue<Item, std::vector<Item>, std::greater<Item>> open;
  dist[std::size_t(from)] = 0;
  open.push({0.0, from});
  int far = from;
  while (!open.empty()) {
    const auto [d, n] = open.top();
    open.pop();
    if (d > dist[std::size_t(n)]) continue;
    if (d > dist[std::size_t(far)]) far = n;
    for (int e : incident_[std::size_t(n)]) {
      const RoadwayEdge& edge = edges_[std::size_t(e)];
      if (edge.blocked) continue;
      const int o = edge.from == n ? edge.to : edge.from;
      if (d + edge.length_m < dist[std::size_t(o)]) {
        dist[std::size_t(o)] = d + edge.length_m;
        open.push({dist[std::size_t(o)], o});
      }
    }
  }
  return far;
}

std::optional<std::pair<int, int>> RoadwayGraph::farthestEnds() const {
  if (nodes_.empty()) return std::nullopt;
  // Only within the connected part with the most roadway: a scan has pockets of free space cut
  // off from the roadways, and their ends are no place to send a robot.
  std::vector<int> part(nodes_.size(), -1);
  std::vector<double> part_length;
  for (std::size_t s = 0; s < nodes_.size(); ++s) {
    if (part[s] >= 0) continue;
    const int id = int(part_length.size());
    part_length.push_back(0.0);
    std::vector<int> stack{int(s)};
    part[s] = id;
    while (!stack.empty()) {
      const int n = stack.back();
      stack.pop_back();
      for (int e : incident_[std::size_t(n)]) {
        const RoadwayEdge& edge = edges_[std::size_t(e)];
        const int o = edge.from == n ? edge.to : edge.from;
        if (edge.from == n) part_length[std::size_t(id)] += edge.length_m;
        if (part[std::size_t(o)] < 0) part[std::size_t(o)] = id, stack.push_back(o);
      }
    }
  }
  const int main_part = int(std::max_element(part_length.begin(), part_length.end()) - part_length.begin());
  std::vector<int> e;
  for (int n : ends())
    if (part[std::size_t(n)] == main_part) e.push_back(n);
  if (e.size() < 2) {
    // A part without two ends (a loop): the ends of its longest shortest path instead (two
    // sweeps of Dijkstra, exact on trees, close on roadway networks).
    int first = 0;
    while (part[std::size_t(first)] != main_part) ++first;
    const int u = farthestAlongGraph(first);
    const int v = farthestAlongGraph(u);
    if (u == v) return std::nullopt;
    return std::make_pair(u, v);
  }
  std::optional<std::pair<int, int>> best;
  double far = -1;
  for (std::size_t i = 0; i < e.size(); ++i)
    for (std::size_t j = i + 1; j < e.size(); ++j) {
      const double d = (nodes_[std::size_t(e[i])].position - nodes_[std::size_t(e[j])].position).norm();
      if (d > far) far = d, best = std::make_pair(e[i], e[j]);
    }
  return best;
}

Vec3 RoadwayGraph::pointNearEnd(int node, double inset_m) const {
  const std::vector<int>& inc = incident_.at(std::size_t(node));
  if (inc.empty()) return nodes_[std::size_t(node)].position;
  const RoadwayEdge& e = edges_[std::size_t(inc.front())];
  std::vector<Vec3> pts = e.axis.points;
  if (e.to == node) std::reverse(pts.begin(), pts.end());
  double left = std::min(inset_m, 0.5 * e.length_m);
  for (std::size_t i = 0; i + 1 < pts.size(); ++i) {
    const double len = (pts[i + 1] - pts[i]).norm();
    if (len >= left) return pts[i] + (pts[i + 1] - pts[i]) * (left / len);
    left -= len;
  }
  return pts.back();
}

// ---- from a survey ----

StatusOr<RoadwayGraph> RoadwayGraph::fromSurvey(const map::SurveyNetwork& survey) {
  ADIT_RETURN_IF_ERROR(survey.validate());
  RoadwayGraph g;
  std::map<std::string, int> station_node;
  // Stations at the same spot under different names are one node ("A=G").
  std::map<std::string, std::string> same_as;
  for (auto i = survey.stations.begin(); i != survey.stations.end(); ++i)
    for (auto j = std::next(i); j != survey.stations.end(); ++j)
      if ((i->second - j->second).norm() <= 1e-3 && !same_as.count(j->first))
        same_as[j->first] = same_as.count(i->first) ? same_as[i->first] : i->first;
  auto nodeFor = [&](const std::string& station) {
    const std::string& name = same_as.count(station) ? same_as.at(station) : station;
    auto it = station_node.find(name);
    if (it != station_node.end()) return it->second;
    std::string label = name;
    for (const auto& [other, rep] : same_as)
      if (rep == name) label += "=" + other;
    const int id = g.addNode(survey.stations.at(name), label);  // floor for now, lifted below
    station_node[name] = id;
    return id;
  };

  // Points along each roadway: its stations, plus junctions where another roadway's station lies
  // on one of its segments (a gate road leaving a main between two main stations).
  struct Stop {
    Vec3 floor;
    int node;
  };
  struct Junction {
    std::size_t segment;
    double t;
    Vec3 point;
    std::string station;
  };
  int junction_count = 0;
  std::vector<std::vector<Stop>> stops(survey.roadways.size());
  std::vector<std::pair<int, int>> connectors;  // (station node, junction node)
  std::vector<std::string> connector_roadway;
  std::vector<std::pair<std::string, std::string>> station_links;  // coincident stations
  // Where two roadways' sections overlap, their free space is joined, and so must the graph be:
  // a station of one inside the other's section (a gate road leaving a main between two main
  // stations, or ending on its rib), two differently named stations at one spot, and crossings
  // with no shared station. `meets` is true when points inside two roadways (not at their ends)
  // are that close: in plan within the two half-widths, in height within the taller section.
  auto meets = [&](std::size_t r, std::size_t q, const Vec3& a, const Vec3& b) {
    const map::CrossSection& sr = survey.sections.at(survey.roadways[r].section);
    const map::CrossSection& sq = survey.sections.at(survey.roadways[q].section);
    return (a - b).head<2>().norm() <= 0.5 * (sr.maxWidth() + sq.maxWidth()) &&
           std::abs(a.z() - b.z()) <= std::max(sr.height(), sq.height());
  };
  // Crossings: closest points of two segments of different roadways, both strictly between
  // stations; one node shared by both roadways.
  struct Crossing {
    std::size_t segment;
    double t;
    Vec3 point;
    int node;
  };
  std::vector<std::vector<Crossing>> crossings(survey.roadways.size());
  for (std::size_t r = 0; r < survey.roadways.size(); ++r)
    for (std::size_t q = r + 1; q < survey.roadways.size(); ++q) {
      const map::SurveyRoadway& a = survey.roadways[r];
      const map::SurveyRoadway& b = survey.roadways[q];
      for (std::size_t i = 0; i + 1 < a.stations.size(); ++i)
        for (std::size_t j = 0; j + 1 < b.stations.size(); ++j) {
          const Vec3 a0 = survey.stations.at(a.stations[i]), a1 = survey.stations.at(a.stations[i + 1]);
          const Vec3 b0 = survey.stations.at(b.stations[j]), b1 = survey.stations.at(b.stations[j + 1]);
          const auto [t, u] = closestSegmentParameters(a0, a1, b0, b1);
          const double margin_a = 1e-3 / std::max(1e-9, (a1 - a0).norm()), margin_b = 1e-3 / std::max(1e-9, (b1 - b0).norm());
          if (t <= margin_a || t >= 1 - margin_a || u <= margin_b || u >= 1 - margin_b) continue;  // at a station
          const Vec3 pa = a0 + t * (a1 - a0), pb = b0 + u * (b1 - b0);
          if (!meets(r, q, pa, pb)) continue;
          const int node = g.addNode(0.5 * (pa + pb), "junction-" + std::to_string(junction_count++));
          crossings[r].push_back({i, t, pa, node});
          crossings[q].push_back({j, u, pb, node});
        }
    }
  for (std::size_t r = 0; r < survey.roadways.size(); ++r) {
    const map::SurveyRoadway& road = survey.roadways[r];
    const map::CrossSection& section = survey.sections.at(road.section);
    std::vector<Junction> junctions;
    for (std::size_t q = 0; q < survey.roadways.size(); ++q) {
      if (q == r) continue;
      for (const std::string& name : survey.roadways[q].stations) {
        if (std::find(road.stations.begin(), road.stations.end(), name) != road.stations.end()) continue;
        const Vec3 s = survey.stations.at(name);
        for (std::size_t i = 0; i + 1 < road.stations.size(); ++i) {
          const Vec3 a = survey.stations.at(road.stations[i]), b = survey.stations.at(road.stations[i + 1]);
          const double t = segmentParameter(s, a, b);
          const Vec3 p = a + t * (b - a);
          // A station is a point of its roadway's centreline, and an end station its face: it
          // joins this roadway when it lies within this section (its rib included).
          if ((p - s).head<2>().norm() > 0.5 * (section.maxWidth() + survey.resolution_m) ||
              std::abs(p.z() - s.z()) > section.height())
            continue;
          if (t <= 1e-6 || t >= 1 - 1e-6) {
            // At one of this roadway's stations under another name: the two are one junction.
            const std::string& here = road.stations[t <= 1e-6 ? i : i + 1];
            station_links.emplace_back(here, name);
            break;
          }
          junctions.push_back({i, t, p, name});
          break;
        }
      }
    }
    std::sort(junctions.begin(), junctions.end(), [](const Junction& x, const Junction& y) {
      return x.segment != y.segment ? x.segment < y.segment : x.t < y.t;
    });
    std::vector<Crossing>& cross = crossings[r];
    std::sort(cross.begin(), cross.end(), [](const Crossing& x, const Crossing& y) {
      return x.segment != y.segment ? x.segment < y.segment : x.t < y.t;
    });
    std::size_t next = 0, next_cross = 0;
    for (std::size_t i = 0; i < road.stations.size(); ++i) {
      stops[r].push_back({survey.stations.at(road.stations[i]), nodeFor(road.stations[i])});
      // This segment's junctions and crossings, in order along it.
      while ((next < junctions.size() && junctions[next].segment == i) ||
             (next_cross < cross.size() && cross[next_cross].segment == i)) {
        const bool take_cross = next_cross < cross.size() && cross[next_cross].segment == i &&
                                (next >= junctions.size() || junctions[next].segment != i || cross[next_cross].t < junctions[next].t);
        if (take_cross) {
          stops[r].push_back({cross[next_cross].point, cross[next_cross].node});
          ++next_cross;
          continue;
        }
        const Junction& j = junctions[next++];
        const int station = nodeFor(j.station);
        int node = station;
        if ((j.point - survey.stations.at(j.station)).norm() > 1e-3) {
          node = g.addNode(j.point, "junction-" + std::to_string(junction_count++));
          connectors.emplace_back(station, node);
          // The connector belongs to the roadway that ends there.
          for (const map::SurveyRoadway& other : survey.roadways)
            if (std::find(other.stations.begin(), other.stations.end(), j.station) != other.stations.end()) {
              connector_roadway.push_back(other.name + "|" + other.section);
              break;
            }
        }
        stops[r].push_back({j.point, node});
      }
    }
  }
  // Differently named stations at one spot (or within each other's sections): a connector.
  for (const auto& [a, b] : station_links) {
    const int na = nodeFor(a), nb = nodeFor(b);
    if (na == nb) continue;
    bool have = false;
    for (const auto& [x, y] : connectors) have |= (x == na && y == nb) || (x == nb && y == na);
    if (have) continue;
    connectors.emplace_back(na, nb);
    for (const map::SurveyRoadway& other : survey.roadways)
      if (std::find(other.stations.begin(), other.stations.end(), b) != other.stations.end()) {
        connector_roadway.push_back(other.name + "|" + other.section);
        break;
      }
  }

  // Lift node positions from the floor to the mid-height of the tallest section meeting there.
  std::vector<double> half_height(g.nodes_.size(), 0.0);
  auto sectionOf = [&](const std::string& name) -> const map::CrossSection& { return survey.sections.at(name); };
  for (std::size_t r = 0; r < survey.roadways.size(); ++r)
    for (const Stop& s : stops[r])
      half_height[std::size_t(s.node)] =
          std::max(half_height[std::size_t(s.node)], 0.5 * sectionOf(survey.roadways[r].section).height());

  auto addPiece = [&](int a, int b, const Vec3& fa, const Vec3& fb, const std::string& roadway,
                      const map::CrossSection& section) {
    const double hh = 0.5 * section.height();
    const Vec3 up(0, 0, hh);
    Polyline axis;
    axis.points = {fa + up, fb + up};
    if ((fb - fa).norm() < 1e-9) return;
    const double radius = std::hypot(0.5 * section.maxWidth(), hh) + survey.resolution_m;
    g.addEdge(a, b, roadway, std::move(axis), radius, hh);
  };
  for (std::size_t r = 0; r < survey.roadways.size(); ++r) {
    const map::SurveyRoadway& road = survey.roadways[r];
    for (std::size_t i = 0; i + 1 < stops[r].size(); ++i)
      addPiece(stops[r][i].node, stops[r][i + 1].node, stops[r][i].floor, stops[r][i + 1].floor, road.name,
               sectionOf(road.section));
  }
  for (std::size_t c = 0; c < connectors.size(); ++c) {
    const std::string& tag = connector_roadway[c];
    const std::size_t bar = tag.find('|');
    const auto [a, b] = connectors[c];
    addPiece(a, b, g.nodes_[std::size_t(a)].position, g.nodes_[std::size_t(b)].position, tag.substr(0, bar),
             sectionOf(tag.substr(bar + 1)));
  }
  for (std::size_t n = 0; n < g.nodes_.size(); ++n) g.nodes_[n].position.z() += half_height[n];
  return g;
}

// ---- blocking ----

void RoadwayGraph::setBlocked(int edge, bool blocked, const std::string& reason) {
  RoadwayEdge& e = edges_.at(std::size_t(edge));
  e.blocked = blocked;
  e.blocked_reason = blocked ? reason : std::string();
  e.blocked_from_m = 0.0;
  e.blocked_to_m = blocked ? e.length_m : 0.0;
}

namespace {
// Some point of the disc of `radius` around `c`, perpendicular to `t`, with clearance >= need.
bool crossSectionPassable(const map::DistanceField& field, const Vec3& c, const Vec3& t, double radius,
                          double need, double step) {
  if (field.distance(c) >= need) return true;
  Vec3 a = t.unitOrthogonal();
  Vec3 b = t.cross(a).normalized();
  for (double r = step; r <= radius; r += step) {
    const int count = std::max(6, int(std::ceil(2 * M_PI * r / step)));
    for (int k = 0; k < count; ++k) {
      const double phi = 2 * M_PI * k / count;
      if (field.distance(c + r * (std::cos(phi) * a + std::sin(phi) * b)) >= need) return true;
    }
  }
  return false;
}
}  // namespace

int RoadwayGraph::refreshBlocked(const map::DistanceField& field, double required_clearance_m, const Aabb& window) {
  return refreshBlocked(field, required_clearance_m, window, SectionTest());
}

int RoadwayGraph::refreshBlocked(const map::DistanceField& field, double required_clearance_m, const Aabb& window,
                                 const SectionTest& section_test) {
  const double step = field.resolution();
  int blocked = 0;
  for (RoadwayEdge& e : edges_) {
    // A dead end's last cross-section is the rock face itself; the roadway there is passable as
    // far as the robot can go, so those last metres are not checked.
    // On a ramp the end face is square to the centreline (the voxelizer sweeps sections
    // perpendicular to it), so at mid-height it stands half_height * sin(slope) nearer than at the
    // floor: the skipped length grows by that much.
    auto endTilt = [&](std::size_t i0, std::size_t i1) {
      const Vec3 d = e.axis.points[i1] - e.axis.points[i0];
      const double n = d.norm();
      return n > 0 ? e.half_height_m * std::abs(d.z()) / n : 0.0;
    };
    const std::size_t np = e.axis.points.size();
    const double skip_from =
        incident_[std::size_t(e.from)].size() == 1 ? required_clearance_m + step + (np > 1 ? endTilt(0, 1) : 0.0) : 0.0;
    const double skip_to = incident_[std::size_t(e.to)].size() == 1
                               ? required_clearance_m + step + (np > 1 ? endTilt(np - 2, np - 1) : 0.0)
                               : 0.0;
    if (!window.empty()) {
      Aabb box;
      for (const Vec3& p : e.axis.points) box.extend(p);
      box = box.inflated(e.radius_m);
      if ((box.max.array() < window.min.array()).any() || (box.min.array() > window.max.array()).any()) {
        blocked += e.blocked;
        continue;
      }
    }
    if (free_space_) {
      blocked += refreshFreeSpaceEdge(int(&e - edges_.data()), field, required_clearance_m);
      continue;
    }
    bool passable = true;
    Vec3 where = Vec3::Zero();
    double arc = 0, first_bad = 0, last_bad = 0;
    for (std::size_t i = 0; i + 1 < e.axis.points.size(); ++i) {
      const Vec3 a = e.axis.points[i], b = e.axis.points[i + 1];
      const double len = (b - a).norm();
      if (len <= 0) continue;
      const Vec3 t = (b - a) / len;
      const int samples = int(std::ceil(len / step));
      for (int k = 0; k <= samples; ++k) {
        const double along = arc + len * k / samples;
        if (along < skip_from || along > e.length_m - skip_to) continue;
        const Vec3 c = a + (len * k / samples) * t;
        if (section_test ? section_test(c, t, e.radius_m)
                         : crossSectionPassable(field, c, t, e.radius_m, required_clearance_m, step))
          continue;
        if (passable) first_bad = along, where = c;
        passable = false;
        last_bad = along;
      }
      arc += len;
    }
    e.blocked = !passable;
    e.blocked_from_m = passable ? 0.0 : first_bad;
    e.blocked_to_m = passable ? 0.0 : last_bad;
    if (e.blocked) {
      std::ostringstream m;
      m.precision(1);
      m << std::fixed << "no cross-section with clearance " << required_clearance_m << " m at (" << where.x()
        << ", " << where.y() << ", " << where.z() << ")";
      e.blocked_reason = m.str();
    } else {
      e.blocked_reason.clear();
    }
    blocked += e.blocked;
  }
  return blocked;
}

// ---- routing ----

StatusOr<RoadwayGraph::Attachment> RoadwayGraph::attach(const Vec3& p, const char* what,
                                                        const EdgeFilter& usable) const {
  if (free_space_) {
    // The passage whose voxels hold the point, not the nearest axis (which may lie behind a wall).
    StatusOr<Attachment> a = attachByVoxel(p, usable);
    if (a.ok()) return a;
  }
  Attachment best;
  best.distance = std::numeric_limits<double>::infinity();
  double best_excess = std::numeric_limits<double>::infinity();
  for (std::size_t e = 0; e < edges_.size(); ++e) {
    const RoadwayEdge& edge = edges_[e];
    if (usable && !usable(edge)) continue;
    for (std::size_t i = 0; i + 1 < edge.axis.points.size(); ++i) {
      const Vec3 a = edge.axis.points[i], b = edge.axis.points[i + 1];
      const Vec3 q = a + segmentParameter(p, a, b) * (b - a);
      const double d = (p - q).norm();
      // Prefer the corridor the point is deepest inside (relative to its radius).
      const double excess = d / edge.radius_m;
      if (excess < best_excess) {
        best_excess = excess;
        best = {int(e), i, q, d};
      }
    }
  }
  if (best.edge < 0 || best_excess > 1.0) {
    std::ostringstream m;
    m << what << " (" << p.x() << ", " << p.y() << ", " << p.z() << ") lies in no roadway corridor";
    if (best.edge >= 0) m << " (nearest: " << edges_[std::size_t(best.edge)].roadway << ", " << best.distance << " m away)";
    return notFound(m.str());
  }
  return best;
}

namespace {
// Arc length of `q` (on segment `segment`) along `axis`.
double arcLength(const Polyline& axis, std::size_t segment, const Vec3& q) {
  double s = 0;
  for (std::size_t i = 0; i < segment; ++i) s += (axis.points[i + 1] - axis.points[i]).norm();
  return s + (q - axis.points[segment]).norm();
}
// Axis points strictly after `segment` towards the end, or strictly before it towards the start.
void appendAxis(const Polyline& axis, std::size_t segment, bool towards_end, std::vector<Vec3>* out) {
  if (towards_end) {
    for (std::size_t i = segment + 1; i < axis.points.size(); ++i) out->push_back(axis.points[i]);
  } else {
    for (std::size_t i = segment + 1; i-- > 0;) out->push_back(axis.points[i]);
  }
}
}  // namespace

StatusOr<Route> RoadwayGraph::route(const Vec3& start, const Vec3& goal, const EdgeFilter& filter) const {
  auto usable = [&](const RoadwayEdge& e) { return !e.blocked && (!filter || filter(e)); };
  auto allowed = [&](const RoadwayEdge& e) { return !filter || filter(e); };
  ADIT_ASSIGN_OR_RETURN(const Attachment s, attach(start, "start", allowed));
  ADIT_ASSIGN_OR_RETURN(const Attachment t, attach(goal, "goal", allowed));
  // Open between arc lengths lo and hi of edge e (no blockage in between)?
  auto open_between = [](const RoadwayEdge& e, double lo, double hi) {
    if (lo > hi) std::swap(lo, hi);
    return !e.blocked || e.blocked_to_m < lo || e.blocked_from_m > hi;
  };
  const RoadwayEdge& es = edges_[std::size_t(s.edge)];
  const RoadwayEdge& et = edges_[std::size_t(t.edge)];
  const double s_arc = arcLength(es.axis, s.segment, s.point), t_arc = arcLength(et.axis, t.segment, t.point);

  // A* from the start's edge ends to the goal's edge ends (costs: axis length).
  const std::size_t n = nodes_.size();
  std::vector<double> g(n, std::numeric_limits<double>::infinity());
  std::vector<int> via(n, -1);  // edge used to reach the node; -2 = directly from the start
  using Item = std::pair<double, int>;
  std::priority_queue<Item, std::vector<Item>, std::greater<Item>> open;
  auto h = [&](int node) { return (nodes_[std::size_t(node)].position - goal).norm() * 0.999; };
  auto seed = [&](int node, double cost) {
    if (cost < g[std::size_t(node)]) {
      g[std::size_t(node)] = cost;
      via[std::size_t(node)] = -2;
      open.push({cost + h(node), node});
    }
  };
  if (open_between(es, 0.0, s_arc)) seed(es.from, s_arc);
  if (open_between(es, s_arc, es.length_m)) seed(es.to, es.length_m - s_arc);
  double best = std::numeric_limits<double>::infinity();
  int best_end = -1;  // node through which the goal's edge is entered; -3 = same edge directly
  if (s.edge == t.edge && open_between(es, s_arc, t_arc)) {
    best = std::abs(t_arc - s_arc);
    best_end = -3;
  }
  std::vector<bool> closed(n, false);
  while (!open.empty()) {
    const auto [f, node] = open.top();
    open.pop();
    if (closed[std::size_t(node)]) continue;
    if (f >= best) break;
    closed[std::size_t(node)] = true;
    if (node == et.from && open_between(et, 0.0, t_arc) && g[std::size_t(node)] + t_arc < best)
      best = g[std::size_t(node)] + t_arc, best_end = node;
    if (node == et.to && open_between(et, t_arc, et.length_m) && g[std::size_t(node)] + et.length_m - t_arc < best)
      best = g[std::size_t(node)] + et.length_m - t_arc, best_end = node;
    for (int e : incident_[std::size_t(node)]) {
      const RoadwayEdge& edge = edges_[std::size_t(e)];
      if (!usable(edge)) continue;
      const int other = edge.from == node ? edge.to : edge.from;
      const double cost = g[std::size_t(node)] + edge.length_m;
      if (cost < g[std::size_t(other)]) {
        g[std::size_t(other)] = cost;
        via[std::size_t(other)] = e;
        open.push({cost + h(other), other});
      }
    }
  }
  if (best_end == -1) {
    std::ostringstream m;
    m << "start and goal are disconnected on the roadway graph";
    std::vector<std::string> blocked;
    for (const RoadwayEdge& e : edges_) {
      if (!e.blocked) continue;
      // Where along it, so that a user can look: metres from its first station.
      const std::string& from = nodes_[std::size_t(e.from)].name;
      std::ostringstream at;
      at.precision(1);
      at << std::fixed << e.blocked_from_m;
      if (e.blocked_to_m > e.blocked_from_m + 0.05) at << "-" << e.blocked_to_m;
      blocked.push_back(e.roadway + " (" + from + "-" + nodes_[std::size_t(e.to)].name + ", " + at.str() + " m from " +
                        from + ")");
    }
    if (!blocked.empty()) {
      m << "; blocked:";
      for (std::size_t i = 0; i < blocked.size() && i < 8; ++i) m << (i ? ", " : " ") << blocked[i];
      if (blocked.size() > 8) m << " and " << blocked.size() - 8 << " more";
    } else if (filter) {
      m << "; the roadways between them are refused for this robot (e.g. too steep)";
    }
    return failedPrecondition(m.str());
  }

  Route r;
  std::vector<Vec3> pts{start};
  std::vector<const RoadwayEdge*> seg_edge;  // edge of each segment pts[i] -> pts[i+1]
  auto push = [&](const Vec3& p, const RoadwayEdge* e) {
    if ((p - pts.back()).norm() < 1e-9) return;
    pts.push_back(p);
    seg_edge.push_back(e);
  };
  auto addRoadway = [&](const RoadwayEdge& e) {
    if (r.roadways.empty() || r.roadways.back() != e.roadway) r.roadways.push_back(e.roadway);
  };
  push(s.point, &es);
  addRoadway(es);
  if (best_end == -3) {
    r.edges.push_back(s.edge);
    std::vector<Vec3> mid;
    if (t_arc >= s_arc) {
      for (std::size_t i = s.segment + 1; i <= t.segment; ++i) mid.push_back(es.axis.points[i]);
    } else {
      for (std::size_t i = s.segment; i > t.segment; --i) mid.push_back(es.axis.points[i]);
    }
    for (const Vec3& p : mid) push(p, &es);
  } else {
    // Walk back from the goal side to the start edge.
    std::vector<int> chain;
    int node = best_end;
    while (via[std::size_t(node)] >= 0) {
      const int e = via[std::size_t(node)];
      chain.push_back(e);
      const RoadwayEdge& edge = edges_[std::size_t(e)];
      node = edge.from == node ? edge.to : edge.from;
    }
    std::reverse(chain.begin(), chain.end());
    const int first_node = node;  // where the start's edge is left
    r.edges.push_back(s.edge);
    std::vector<Vec3> piece;
    appendAxis(es.axis, s.segment, first_node == es.to, &piece);
    for (const Vec3& p : piece) push(p, &es);
    int at = first_node;
    for (int e : chain) {
      const RoadwayEdge& edge = edges_[std::size_t(e)];
      r.edges.push_back(e);
      addRoadway(edge);
      const bool forward = edge.from == at;
      std::vector<Vec3> axis = edge.axis.points;
      if (!forward) std::reverse(axis.begin(), axis.end());
      for (const Vec3& p : axis) push(p, &edge);
      at = forward ? edge.to : edge.from;
    }
    r.edges.push_back(t.edge);
    addRoadway(et);
    piece.clear();
    // From the node we arrived at, along the goal's edge to the goal's attachment.
    if (at == et.from) {
      for (std::size_t i = 0; i <= t.segment; ++i) piece.push_back(et.axis.points[i]);
    } else {
      for (std::size_t i = et.axis.points.size(); i-- > t.segment + 1;) piece.push_back(et.axis.points[i]);
    }
    for (const Vec3& p : piece) push(p, &et);
  }
  push(t.point, &et);
  push(goal, &et);
  r.axis.points = pts;
  for (std::size_t i = 0; i + 1 < pts.size(); ++i) r.radius_m.push_back(seg_edge[i]->radius_m);
  r.length_m = r.axis.length();
  return r;
}

PassageMeasure measurePassage(const RoadwayEdge& edge, const map::DistanceField& field) {
  PassageMeasure m;
  const double res = field.resolution();
  // Distance to rock along a horizontal ray, by sphere tracing on the field (never steps past rock).
  auto reach = [&](const Vec3& from, const Vec3& dir) {
    double t = 0;
    for (int i = 0; i < 4096; ++i) {
      const double d = field.distance(from + t * dir);
      if (d < 0.5 * res) break;
      t += std::max(d, 0.5 * res);
    }
    return t;
  };
  double lowest = std::numeric_limits<double>::infinity();
  std::vector<double> widths;
  for (std::size_t i = 0; i + 1 < edge.axis.points.size(); ++i) {
    const Vec3 a = edge.axis.points[i], b = edge.axis.points[i + 1];
    const double len = (b - a).norm();
    const int n = std::max(1, int(std::ceil(len / res)));
    Vec3 across(-(b - a).y(), (b - a).x(), 0.0);
    const bool has_across = across.norm() > 1e-9;
    if (has_across) across.normalize();
    for (int k = 0; k <= n; ++k) {
      const Vec3 c = a + (b - a) * (double(k) / n);
      lowest = std::min(lowest, field.distance(c));
      if (has_across) widths.push_back(reach(c, across) + reach(c, -across));
    }
  }
  m.min_clearance_m = std::isfinite(lowest) ? lowest : 0.0;
  if (!widths.empty()) {
    std::nth_element(widths.begin(), widths.begin() + std::ptrdiff_t(widths.size() / 2), widths.end());
    m.width_m = widths[widths.size() / 2];
  }
  return m;
}

}  // namespace adit::global
