// SPDX-License-Identifier: BSD-3-Clause
#include "common/plan_output.hpp"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <cstdio>
#include <iomanip>
#include <sstream>

#include "adit/map/map_io.hpp"
#include "common/figure.hpp"
#include "common/json_output.hpp"
#include "common/progress.hpp"

namespace adit::tools {

using map::Vec3;

map::MapCacheOptions verbCacheOptions(bool no_cache) {
  map::MapCacheOptions o;
  o.enabled = !no_cache && !map::mapCacheDisabledByEnvironment();
  return o;
}

void logCacheReport(const map::World& world) {
  const map::MapCacheReport& r = world.cacheReport();
  for (const std::string& why : r.refused) std::fprintf(stderr, "map cache: refused %s; rebuilding\n", why.c_str());
  if (!r.used.empty()) std::fprintf(stderr, "map cache: read %s (%.3f s)\n", r.used.c_str(), r.read_s);
  if (!r.written.empty()) std::fprintf(stderr, "map cache: wrote %s (%.3f s)\n", r.written.c_str(), r.write_s);
  if (!r.write_error.empty()) std::fprintf(stderr, "map cache: not written: %s\n", r.write_error.c_str());
}

StatusOr<map::World> loadWorld(const std::string& path, map::UnknownPolicy policy, bool quiet, bool no_cache,
                               std::uint64_t max_memory_bytes) {
  ProgressBar bar(quiet);
  map::WorldOptions options;
  options.load.unknown_policy = policy;
  options.load.max_memory_bytes = max_memory_bytes ? max_memory_bytes : map::machineMemoryBudgetBytes();
  options.load.progress = bar.callback();
  options.cache = verbCacheOptions(no_cache);
  StatusOr<map::World> world = map::World::load(path, options);
  bar.finish();
  if (world.ok() && !quiet) logCacheReport(*world);
  return world;
}

StatusOr<map::RobotShape> parseRobot(const std::string& text) {
  const std::size_t colon = text.find(':');
  const std::string kind = text.substr(0, colon);
  std::vector<double> v;
  if (colon != std::string::npos) {
    std::string rest = text.substr(colon + 1);
    std::replace(rest.begin(), rest.end(), ',', ' ');
    std::istringstream is(rest);
    std::string tok;
    while (is >> tok) {
      char* end = nullptr;
      const double x = std::strtod(tok.c_str(), &end);
      if (end == tok.c_str() || *end != '\0' || !std::isfinite(x))
        return invalidArgument("--robot " + text + ": '" + tok + "' is not a finite number");
      v.push_back(x);
    }
  }
  auto need = [&](std::size_t n, const char* form) -> Status {
    if (v.size() != n) return invalidArgument("--robot " + text + ": expected " + form);
    return {};
  };
  map::RobotShape shape;
  if (kind == "sphere") {
    ADIT_RETURN_IF_ERROR(need(1, "sphere:r"));
    shape = map::RobotShape::sphere(v[0]);
  } else if (kind == "capsule") {
    ADIT_RETURN_IF_ERROR(need(2, "capsule:r,len"));
    shape = map::RobotShape::capsule(v[0], v[1]);
  } else if (kind == "box") {
    ADIT_RETURN_IF_ERROR(need(3, "box:x,y,z"));
    shape = map::RobotShape::box({v[0], v[1], v[2]});
  } else if (kind == "cylinder") {
    ADIT_RETURN_IF_ERROR(need(2, "cylinder:r,h"));
    shape = map::RobotShape::cylinder(v[0], v[1]);
  } else {
    return invalidArgument("--robot " + text + ": unknown shape '" + kind + "' (sphere, capsule, box or cylinder)");
  }
  if (Status s = shape.validate(); !s.ok()) return invalidArgument("--robot " + text + ": " + s.message());
  return shape;
}

StatusOr<PlanFormat> planFormatFromPath(const std::string& path) {
  std::string ext = std::filesystem::path(path).extension().string();
  for (char& c : ext) c = char(std::tolower(static_cast<unsigned char>(c)));
  if (ext == ".json") return PlanFormat::kJson;
  if (ext == ".csv") return PlanFormat::kCsv;
  // A device or a pipe (/dev/null, /dev/stdout, a FIFO a script reads) has no extension to go by:
  // it gets what stdout would, JSON.
  std::error_code ec;
  const auto type = std::filesystem::status(path, ec).type();
  if (!ec && (type == std::filesystem::file_type::character || type == std::filesystem::file_type::fifo))
    return PlanFormat::kJson;
  if (path.rfind("/dev/", 0) == 0) return PlanFormat::kJson;  // /dev/stdout redirected to a file
  return invalidArgument("--out " + path + ": expected a .json or .csv file (or a device or FIFO, written as JSON)");
}

std::string breakPointLabel(std::size_t index) {
  std::string s;
  for (std::size_t i = index + 1; i > 0; i = (i - 1) / 26) s.insert(s.begin(), char('A' + (i - 1) % 26));
  return s;
}

namespace {
nlohmann::ordered_json pathJson(const map::Polyline& p) {
  nlohmann::ordered_json path = nlohmann::ordered_json::array();
  for (const Vec3& q : p.points) path.push_back(mmPoint(q));
  return path;
}
}  // namespace

nlohmann::ordered_json planJson(const global::GlobalPlanResult& r, const PlanRefinementInfo* refinement) {
  nlohmann::ordered_json j;
  j["outcome"] = global::outcomeName(r.outcome);
  j["message"] = r.message;
  j["length"] = mm(r.length_m);
  j["min_clearance"] = mm(r.min_clearance_m);
  j["mean_clearance"] = mm(r.mean_clearance_m);
  j["planning_time"] = us(r.planning_time_s);
  j["planner"] = r.planner;
  j["path"] = pathJson(r.path);
  j["route"] = r.route;
  // Extensions beyond the fixed fields.
  j["first_path_time"] = us(r.first_solution_time_s);
  j["break_points"] = r.path.size() >= 2 ? r.path.size() - 2 : 0;
  j["time_limited"] = r.time_limited;
  j["iterations"] = r.iterations;
  // Where a found path came from: the search, or the route's own axis, shortened (the search found
  // none within the budget, or a longer one: common on routes of kilometres).
  if (r.solved()) j["path_source"] = r.from_route_axis ? "route_axis" : "search";
  // A ground box robot's path through a gap narrower than its turning circle: the box fits
  // heading along the path only.
  if (r.solved() && r.headed) j["body_check"] = "heading";
  if (refinement) {
    j["before"] = {{"length", mm(refinement->length_m)},
                   {"min_clearance", mm(refinement->min_clearance_m)},
                   {"mean_clearance", mm(refinement->mean_clearance_m)},
                   {"break_points", refinement->path.size() >= 2 ? refinement->path.size() - 2 : 0},
                   {"path", pathJson(refinement->path)}};
    j["refine"] = {{"outcome", refinement->outcome},
                   {"message", refinement->message},
                   {"time", us(refinement->time_s)},
                   {"iterations", refinement->iterations}};
  }
  return stamped("adit.plan", std::move(j));
}

Status writePlan(const global::GlobalPlanResult& r, const std::string& path, const PlanRefinementInfo* refinement) {
  ADIT_ASSIGN_OR_RETURN(const PlanFormat format, planFormatFromPath(path));
  return map::writeFileAtomically(path, [&](std::ostream& os) {
    if (format == PlanFormat::kJson) {
      os << planJson(r, refinement).dump(2) << "\n";
    } else {
      os << "label,x,y,z\n";
      const std::vector<Vec3>& p = r.path.points;
      for (std::size_t i = 0; i < p.size(); ++i) {
        const std::string label = i == 0 ? "start" : i + 1 == p.size() ? "goal" : breakPointLabel(i - 1);
        os << label << "," << csvNumber(p[i].x(), 3) << "," << csvNumber(p[i].y(), 3) << "," << csvNumber(p[i].z(), 3)
           << "\n";
      }
    }
    return bool(os);
  });
}

namespace {
// Floor and roof above and below a point of the path (rock under the map's policy).
std::pair<double, double> floorAndRoof(const map::OccupancyMap& map, const Vec3& p) {
  const double res = map.resolution();
  double lo = p.z(), hi = p.z();
  for (int i = 0; i < 200 && map.isFree({p.x(), p.y(), lo - res}); ++i) lo -= res;
  for (int i = 0; i < 200 && map.isFree({p.x(), p.y(), hi + res}); ++i) hi += res;
  return {(std::floor(lo / res)) * res, (std::floor(hi / res) + 1) * res};
}
}  // namespace

Status drawPlan(const map::OccupancyMap& map, const global::RoadwayGraph& graph, const global::GlobalPlanResult& r,
                const Vec3& start, const Vec3& goal, const std::string& title, const std::string& path,
                const map::Polyline* unrefined, TopViewInfo* info) {
  TopViewOptions o;
  o.title = title;
  Figure fig(o);
  fig.setMap(&map);
  bool blocked_legend = false;
  for (const global::RoadwayEdge& e : graph.edges()) {
    if (!e.blocked) continue;
    fig.addLine({e.axis.points, kFigureBlocked, 3.0, true, {}, blocked_legend ? "" : "blocked roadway", ""});
    blocked_legend = true;
  }
  const std::vector<Vec3>& p = r.path.points;
  if (unrefined && unrefined->size() >= 2)
    fig.addLine({unrefined->points, kFigurePath, 1.5, true, {}, "before refinement", ""});
  if (p.size() >= 2) fig.addLine({p, kFigurePath, 2.5, false, {}, unrefined ? "refined path" : "expected path", ""});
  for (std::size_t i = 1; i + 1 < p.size(); ++i)
    fig.addMarker({p[i], MarkerShape::kCircle, kFigureBreakPoint, 7, breakPointLabel(i - 1), i == 1 ? "break point" : ""});
  fig.addMarker({p.size() >= 2 ? p.front() : start, MarkerShape::kCircle, kFigureStart, 10, "start", "start", 0});
  fig.addMarker({p.size() >= 2 ? p.back() : goal, MarkerShape::kSquare, kFigureGoal, 10, "goal", "goal", 0});

  if (p.size() >= 2) {
    SideProfile profile;
    profile.title = "side profile along the path";
    ProfileSeries centre{{}, {}, kFigurePath, 2.0, false, "path (robot centre)"};
    ProfileSeries floor{{}, {}, 0x9A8F7A, 1.5, false, "floor"};
    ProfileSeries roof{{}, {}, 0x6B6B6B, 1.0, true, "roof"};
    const double total = r.path.length();
    const double step = std::max(total / 600.0, map.resolution());
    double s0 = 0;
    for (std::size_t i = 0; i + 1 < p.size(); ++i) {
      const double len = (p[i + 1] - p[i]).norm();
      const int n = std::max(1, int(std::ceil(len / step)));
      for (int k = 0; k <= n; ++k) {
        if (k == 0 && i > 0) continue;
        const Vec3 q = p[i] + (p[i + 1] - p[i]) * (double(k) / n);
        const double s = s0 + len * k / n;
        const auto [f, c] = floorAndRoof(map, q);
        centre.s_m.push_back(s), centre.z_m.push_back(q.z());
        floor.s_m.push_back(s), floor.z_m.push_back(f);
        roof.s_m.push_back(s), roof.z_m.push_back(c);
      }
      if (i + 2 < p.size()) profile.labels.push_back({s0 + len, p[i + 1].z(), breakPointLabel(i)});
      s0 += len;
    }
    profile.labels.push_back({0.0, p.front().z(), "start", 0});
    profile.labels.push_back({s0, p.back().z(), "goal", 0});
    profile.series = {floor, roof, centre};
    fig.setProfile(profile);
  }
  return fig.render(path, info);
}

}  // namespace adit::tools
